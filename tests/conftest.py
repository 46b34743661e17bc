import numpy as np
import pandas as pd
import pytest

from sklearn_pycc import Skeleton, datasets

STICK_SLIP_FUNCTIONAL = ["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"]


@pytest.fixture(scope="session")
def stick_slip():
    return datasets.make_stick_slip(return_truth=True)


#: a first-order state driven by an input that acts 0.35 time units late
LATE_INPUT = ["x1_dot = a1 u(t - a3) - a2 x1"]


@pytest.fixture(scope="session")
def late_input():
    """600 samples every 0.1 of LATE_INPUT (a1 = 1, a2 = 0.5, a3 = 0.35), stepped u, x1 at 1 %."""
    rng = np.random.default_rng(0)
    t = np.arange(600) * 0.1
    u = np.repeat(rng.uniform(0.0, 1.0, 31), 20)[:600]
    states = Skeleton(LATE_INPUT).simulate(t, [0.0], params={"a1": 1.0, "a2": 0.5, "a3": 0.35},
                                           inputs={"u": u})
    clean = states["x1"].to_numpy()
    return pd.DataFrame({"t": t, "u": u, "x1": clean + 0.01 * rng.normal(size=600)}), clean


@pytest.fixture(scope="session")
def duffing():
    return datasets.make_duffing(n_samples=1500, return_truth=True)


def split(frame):
    """X (everything but the derivatives) and y (the derivatives) of a dataset frame."""
    y_cols = [c for c in frame.columns if c.endswith("_dot")]
    x_cols = [c for c in frame.columns if c not in y_cols]
    return frame[x_cols], frame[y_cols]
