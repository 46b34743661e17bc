"""The one helper every diagnostic refit goes through: what it keeps and what it drops."""

from sklearn_pycc import PolyCCRegressor, Skeleton
from sklearn_pycc.diagnostics._refit import KEEP, prepared

EQUATIONS = ["x1_dot = x2", "x2_dot = u - a1 x2 - a2 x1"]


def _model(**settings):
    return PolyCCRegressor(equations=EQUATIONS, constraints=["a1 >= 0"], **settings)


def test_a_refit_makes_no_refits_on_resamples_unless_asked_to_keep_them():
    model = _model(n_bootstrap=3, param_init={"a1": 0.5})
    assert prepared(model).n_bootstrap == 0
    assert prepared(model, n_bootstrap=KEEP).n_bootstrap == 3
    assert prepared(model, n_bootstrap=5).n_bootstrap == 5
    assert prepared(_model()).n_bootstrap == _model().n_bootstrap
    # the user's model is never changed
    assert model.n_bootstrap == 3 and model.param_init == {"a1": 0.5}


def test_another_skeleton_brings_its_own_constraints_and_only_its_parameters_start():
    extended = Skeleton(["x1_dot = x2", "x2_dot = u - a1 x2 - a2 x1 - a3 x1^3"])
    refit = prepared(_model(), equations=extended,
                     param_init={"a1": 0.1, "a3": 2.0, "a9": 7.0})
    assert list(refit.equations) == list(extended.equations) and refit.constraints is None
    assert refit.param_init == {"a1": 0.1, "a3": 2.0}
    # skeleton text is left for the fit to read: nothing is filtered
    assert prepared(_model(), equations=EQUATIONS, param_init={"a9": 1.0}).param_init == \
        {"a9": 1.0}


def test_fit_mode_other_settings_and_the_fitted_hold():
    model = _model(input_hold="auto")
    assert prepared(model, fit_mode="simulation").fit_mode == "simulation"
    assert prepared(model, extrapolation="linear").extrapolation == "linear"
    model.input_hold_ = "zoh"  # as a fit that chose the held input leaves it
    assert prepared(model, hold_as_fitted=True).input_hold == "zoh"
    assert prepared(model).input_hold == "auto"
