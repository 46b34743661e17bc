"""scikit-learn's own estimator checks over every estimator."""

import pytest
from sklearn.utils.estimator_checks import check_param_validation, parametrize_with_checks

from sklearn_pycc import (
    CCRegressor,
    InterpolatedCCRegressor,
    NeuralCCRegressor,
    PolyCCRegressor,
    SymbolicCCRegressor,
)

# Without column names, an array's columns are called x0, x1, ...; the check
# instance's skeleton reads the first one, so it accepts any X the checks build.
CHECK_EQUATIONS = ["z_dot = f1(x0)"]

# check_regressors_train runs in full: its score test is left out by the estimators'
# poor_score tag (the check's skeleton reads one of ten features), its others stand
EXPECTED_FAILURES = {
    "check_regressor_multioutput": (
        "the number of outputs is fixed by the skeleton (one per equation); the "
        "check's five-column y does not match the one-equation check skeleton"
    ),
}

ESTIMATORS = [
    PolyCCRegressor(equations=CHECK_EQUATIONS, degree=3),
    # small and short so that the ~40 checks, each fitting several times, stay quick
    NeuralCCRegressor(equations=CHECK_EQUATIONS, hidden_layer_sizes=(8,), max_epochs=10,
                      random_state=0),
    SymbolicCCRegressor(equations=CHECK_EQUATIONS, population_size=50, generations=5,
                        max_iterations=1, maxsize=10, random_state=0),
    InterpolatedCCRegressor(equations=CHECK_EQUATIONS, estimator=PolyCCRegressor(degree=3),
                            n_points=50),
]


@parametrize_with_checks(ESTIMATORS, expected_failed_checks=lambda est: EXPECTED_FAILURES)
def test_sklearn_compatible(estimator, check):
    check(estimator)


@pytest.mark.parametrize("estimator", ESTIMATORS, ids=lambda e: type(e).__name__)
def test_every_hyperparameter_is_validated_before_fitting(estimator):
    # scikit-learn runs this check on its own estimators only: every parameter
    # has a constraint, and a value of the wrong type is refused by fit (and by
    # partial_fit-free estimators' other fitting methods) with InvalidParameterError
    check_param_validation(type(estimator).__name__, estimator)


def test_the_base_class_cannot_be_fitted_by_mistake():
    with pytest.raises(TypeError, match="abstract class CCRegressor"):
        CCRegressor(equations=CHECK_EQUATIONS)


@pytest.mark.parametrize("estimator", ESTIMATORS, ids=lambda e: type(e).__name__)
def test_hyperparameters_are_keyword_only(estimator):
    with pytest.raises(TypeError, match="positional argument"):
        type(estimator)(CHECK_EQUATIONS)
