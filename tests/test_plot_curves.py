"""plot_curves: the fitted curves with their bands, the true curves and the measured range."""

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.collections import PolyCollection

from sklearn_pycc import NeuralCCRegressor, PolyCCRegressor, datasets
from sklearn_pycc.plotting import plot_curves

EQUATIONS = ["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"]


@pytest.fixture(scope="module")
def duffing():
    frame, truth = datasets.make_duffing(n_samples=800, noise=30, noise_columns=["x2_dot"],
                                         random_state=0, return_truth=True)
    return frame[["x1", "x2", "F_ext"]], frame[["x1_dot", "x2_dot"]], truth


def legend_texts(ax):
    return [t.get_text() for t in ax.get_legend().get_texts()]


def test_curves_with_bands_truth_and_the_measured_range(duffing):
    X, y, truth = duffing
    model = PolyCCRegressor(equations=EQUATIONS, constraints=["f1 odd", "f2 odd"],
                            degree=5).fit(X, y)
    fig = plot_curves(model, truth=truth.functions, domain=(-3, 3))
    axes = fig.axes
    assert [ax.get_title() for ax in axes] == ["f1", "f2"]
    assert [ax.get_xlabel() for ax in axes] == ["x2", "x1"]
    assert axes[1].get_ylabel() == "f2(x1)"
    for ax in axes:
        assert legend_texts(ax) == ["95 % band", "fitted", "true", "beyond the data"]
        band = [c for c in ax.collections if isinstance(c, PolyCollection)]
        assert band  # the band is drawn as a filled area
        fitted, true = ax.get_lines()[:2]
        np.testing.assert_allclose(true.get_ydata(),
                                   truth.functions[ax.get_title()](true.get_xdata()))
        assert fitted.get_xdata()[0] == -3 and fitted.get_xdata()[-1] == 3
        assert ax.get_yscale() == "linear"
    plt.close(fig)


def test_a_model_without_bands_draws_none_unless_asked(duffing):
    X, y, _ = duffing
    model = NeuralCCRegressor(equations=EQUATIONS, hidden_layer_sizes=(8,), max_epochs=5,
                              random_state=0).fit(X, y)
    fig = plot_curves(model)
    for ax in fig.axes:
        assert legend_texts(ax) == ["fitted"]
        assert not [c for c in ax.collections if isinstance(c, PolyCollection)]
    plt.close(fig)
    with pytest.raises(ValueError, match="n_bootstrap"):
        plot_curves(model, level=0.9)
    with pytest.raises(ValueError, match="truth names 'f9', which is not a curve"):
        plot_curves(model, truth={"f1": np.sin, "f9": np.cos})
    with pytest.raises(ValueError, match="no curves to plot"):
        plot_curves(PolyCCRegressor(equations=["x1_dot = -a1 x1"]).fit(
            X.assign(x1=np.exp(-np.linspace(0, 1, len(X)))),
            -np.exp(-np.linspace(0, 1, len(X)))))
