"""The constrained least-squares solve behind the polynomial backend.

A well-conditioned design is solved through its Gram matrix (one pass over
the design); the answers must match a rank-revealing QR solve of the same
problem to rounding, and every other design must still take the QR path.
"""

import numpy as np
import pytest
from scipy.linalg import lstsq as lapack_lstsq
from scipy.linalg import null_space

from sklearn_pycc.fitting import lstsq as _lstsq
from sklearn_pycc.fitting.lstsq import constrained_lstsq


def reference(A, b, C=None, d=None, alpha=0.0):
    """``min ||A x + b||^2 + alpha ||z||^2`` with ``C x = d``, by an orthonormal null space."""
    p = A.shape[1]
    if C is None:
        x0, N = np.zeros(p), np.eye(p)
    else:
        x0 = np.linalg.lstsq(C, d, rcond=None)[0]
        N = null_space(C)
    M = A @ N
    rhs = -(b + A @ x0)
    if alpha:
        M = np.vstack([M, np.sqrt(alpha) * np.eye(N.shape[1])])
        rhs = np.concatenate([rhs, np.zeros(N.shape[1])])
    z = lapack_lstsq(M, rhs, lapack_driver="gelsy")[0]
    return x0 + N @ z


@pytest.fixture
def design():
    rng = np.random.default_rng(0)
    u = rng.uniform(-1, 1, 5000)
    A = np.asfortranarray(np.polynomial.legendre.legvander(u, 7))
    A[:, 3] *= 1e3  # columns of very different scales are fine
    x_true = rng.normal(size=8)
    b = -(A @ x_true) + 0.01 * rng.normal(size=5000)
    return A, b, x_true


def test_a_well_conditioned_design_goes_through_its_gram_matrix_and_matches_qr(design):
    A, b, _ = design
    before = A.copy()
    result = constrained_lstsq(A, b)
    assert result.gram is not None  # the quick path
    np.testing.assert_allclose(result.x, reference(A, b), rtol=1e-11, atol=1e-13)
    np.testing.assert_allclose(result.gram, A.T @ A, rtol=1e-12)
    np.testing.assert_allclose(result.residual, A @ result.x + b, atol=1e-12)
    assert result.null_directions.shape == (8, 0)
    np.testing.assert_array_equal(A, before)  # the design is read, not scaled in place


def test_point_constraints_hold_exactly_and_the_solution_matches_qr(design):
    A, b, _ = design
    C = np.array([np.polynomial.legendre.legvander(np.array([0.3]), 7)[0],
                  np.r_[1.0, np.zeros(7)]])
    d = np.array([0.5, -0.25])
    result = constrained_lstsq(A, b, C, d)
    assert result.gram is not None
    np.testing.assert_allclose(C @ result.x, d, atol=1e-12)
    expected = reference(A, b, C, d)
    np.testing.assert_allclose(result.x, expected, rtol=1e-10, atol=1e-12)
    assert result.cost == pytest.approx(float(np.sum((A @ expected + b) ** 2)), rel=1e-12)


def test_the_ridge_penalises_the_free_coefficients_as_before(design):
    A, b, _ = design
    quick = constrained_lstsq(A, b, alpha=3.0)
    assert quick.gram is not None
    np.testing.assert_allclose(quick.x, reference(A, b, alpha=3.0), rtol=1e-10, atol=1e-12)


def test_exact_data_are_recovered_to_rounding(design):
    A, _, x_true = design
    b = -(A @ x_true)
    result = constrained_lstsq(A, b)
    np.testing.assert_allclose(result.x, x_true, rtol=1e-12, atol=1e-13)
    assert result.cost < 1e-20 * float(b @ b)


@pytest.mark.parametrize("case", ["rank deficient", "ill conditioned", "fewer rows"])
def test_other_designs_take_the_rank_revealing_path(design, case):
    A, b, _ = design
    if case == "rank deficient":
        A = np.column_stack([A, A[:, 1] + A[:, 2]])
    elif case == "ill conditioned":
        wiggle = np.random.default_rng(1).normal(size=len(A))
        A = np.column_stack([A, A[:, 1] + 1e-7 * wiggle])  # condition number ~1e7
    else:
        A, b = A[:5], b[:5]
    result = constrained_lstsq(A, b)
    assert result.gram is None
    if case == "rank deficient":
        null = result.null_directions
        assert null.shape[1] == 1
        assert np.linalg.norm(A @ null[:, 0]) < 1e-10 * np.linalg.norm(A) * np.linalg.norm(null)
    if case == "ill conditioned":
        np.testing.assert_allclose(result.x, reference(A, b), rtol=1e-6, atol=1e-8)


def scaled_condition(A):
    return np.linalg.cond(A / np.linalg.norm(A, axis=0))


def test_the_quick_path_is_taken_exactly_below_its_condition_bound(design):
    A, b, _ = design
    wiggle = np.random.default_rng(1).normal(size=len(A))
    for gap, quick in ((1e-2, True), (1e-7, False)):
        B = np.column_stack([A, A[:, 1] + gap * wiggle])
        assert (scaled_condition(B) < _lstsq._GRAM_COND) == quick
        assert (constrained_lstsq(B, b).gram is not None) == quick
