"""Windows integrated side by side and one by one in floats give the same numbers."""

import numpy as np
import pytest

from sklearn_pycc import Skeleton
from sklearn_pycc import windows as windows_module
from sklearn_pycc.windows import Windows


def _windows(hold: str, n_windows: int) -> Windows:
    rng = np.random.default_rng(0)
    t = np.arange(0.0, 60.0, 0.5)
    u = rng.uniform(0, 10, len(t))
    n = len(t) * n_windows
    rows = np.arange(n).reshape(n_windows, len(t))
    return Windows(["x1", "x2"], ["u"], True, [(r, t) for r in rows],
                   {"x1": np.zeros(n), "x2": np.zeros(n)}, {"u": np.tile(u, n_windows)},
                   len(t), merge_tail=False, hold=hold)


@pytest.mark.parametrize("hold", ["bandlimited", "zoh"])
@pytest.mark.parametrize("n_windows", [1, 3])
def test_few_windows_in_floats_match_the_side_by_side_integration(monkeypatch, hold, n_windows):
    # a limited cascade reading t, and a model that escapes part way (a1 x1^2 blows up)
    cases = [(["x1_dot = a1 u - a2 sqrt(x1) + 0.001 t", "x2_dot = 1.25 a2 sqrt(x1) - a3 sqrt(x2)"],
              ["x1 <= 12", "0 <= x2 <= 13"], {"a1": 0.3, "a2": 0.4, "a3": 0.45}),
             (["x1_dot = a1 u + a2 x1^2", "x2_dot = a3 sqrt(x1) - a3 x2"], [],
              {"a1": 0.02, "a2": 0.05, "a3": 0.045})]
    for equations, limits, params in cases:
        system = Skeleton(equations, limits).compile({}, params)
        start = np.tile([3.0, 7.0], (n_windows, 1)) * np.arange(1, n_windows + 1)[:, None]
        floats = _windows(hold, n_windows)
        one, escaped_one = floats.simulate(system, start)
        steps_one = floats.escape_step.copy()
        monkeypatch.setattr(windows_module, "FEW_WINDOWS", 0)
        side = _windows(hold, n_windows)
        many, escaped_many = side.simulate(system, start)
        monkeypatch.undo()
        assert np.array_equal(one, many)
        assert np.array_equal(escaped_one, escaped_many)
        assert np.array_equal(steps_one, side.escape_step)
    assert escaped_one.all() and not np.isnan(one).any()  # the second model escaped
