import pytest

from sklearn_pycc import datasets

STICK_SLIP_FUNCTIONAL = ["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"]


@pytest.fixture(scope="session")
def stick_slip():
    return datasets.make_stick_slip(return_truth=True)


@pytest.fixture(scope="session")
def duffing():
    return datasets.make_duffing(n_samples=1500, return_truth=True)


def split(frame):
    """X (everything but the derivatives) and y (the derivatives) of a dataset frame."""
    y_cols = [c for c in frame.columns if c.endswith("_dot")]
    x_cols = [c for c in frame.columns if c not in y_cols]
    return frame[x_cols], frame[y_cols]
