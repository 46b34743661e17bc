"""Two real laboratory records, position only, with defaults (skipped without the folder).

The records stay outside the product (``../shared/real-data`` next to the
repository); these tests are loose on purpose: they check that real data go
through ``fit`` and ``diagnose`` and that the diagnosis is physically sound,
not any tuned figure.
"""

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from sklearn_pycc import PolyCCRegressor, diagnose

FOLDER = Path(__file__).resolve().parents[2] / "shared" / "real-data"
LINEAR = ["x1_dot = x2", "x2_dot = - a1 x2 - a2 x1"]

pytestmark = pytest.mark.skipif(not FOLDER.is_dir(), reason="the real records are absent")


def _positions(name: str, column: str) -> pd.DataFrame:
    frame = pd.read_csv(FOLDER / name)
    return frame[["t", column]].rename(columns={column: "x1"})


@pytest.mark.slow
def test_real_pendulum_lacks_a_softening_spring():
    X = _positions("real_pendulum.csv", "theta")
    model = PolyCCRegressor(equations=LINEAR).fit(X)
    assert model.params_["a1"] > 0 and model.params_["a2"] > 0  # damped, restoring
    report = diagnose(model, X)
    assert report.best is not None and report.best.effect in ("cubic_stiffness", "pendulum")
    refit = PolyCCRegressor(equations=report.best.equations,
                            param_init=report.best.param_init).fit(X)
    if report.best.effect == "cubic_stiffness":
        # sin(theta) = theta - theta^3 / 6 + ...: the added cubic term softens the spring
        (added,) = set(refit.params_) - set(model.params_)
        assert refit.params_[added] < 0
    assert diagnose(refit, X).simulation_rmse < 0.5 * report.simulation_rmse


@pytest.mark.slow
def test_real_linear_oscillator_lacks_nothing():
    # a free damping curve once passed held-out checks here: it changes the simulated
    # position by a tenth of the encoder's step, a third of its noise level
    X = _positions("real_linear_oscillator.csv", "x")
    model = PolyCCRegressor(equations=LINEAR).fit(X)
    report = diagnose(model, X)
    assert np.isfinite(report.simulation_rmse)
    assert report.best is None
    notes = report.ranking.set_index("effect").note
    assert "below its noise level" in notes["free_damping_curve"]
