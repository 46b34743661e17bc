"""The method's published functional API: ``train``, ``simulate``, ``post_processing``.

Scripts written for the published package run after changing only the
import::

    from sklearn_pycc import pycc

    models, evals, obtained_coefs = pycc.train(df, eqs, method="NN", params=params_NN)
    sol, derivatives = pycc.simulate(eqs, method="NN", params=params_NN_simul)

Each call translates the paper's ``params`` onto an estimator
(:class:`~sklearn_pycc.NeuralCCRegressor`, :class:`~sklearn_pycc.PolyCCRegressor`,
:class:`~sklearn_pycc.SymbolicCCRegressor`) and returns its results in the
paper's shapes; ``models.estimator`` is the fitted estimator, to go on with
the estimator API. Curves are matched by name, never by position. Every
``params`` key the published package reads is known: mapped onto the
estimator, or named with the reason it has no effect here in one warning
per call. Unlike the published package, an unknown key is an error naming
the nearest known one. A curve found by symbolic regression is a
:class:`SymbolicEntry`: callable, and answering ``entry["pysr_model"]``
(a :class:`ParetoModel`), ``entry["expr"]``, ``entry["func"]`` and
``entry["sympy"]``.
"""

from ._post import post_processing
from ._shared import Models
from ._simulate import simulate
from ._symbolic import ParetoModel, SymbolicEntry
from ._train import train

__all__ = ["Models", "ParetoModel", "SymbolicEntry", "post_processing", "simulate", "train"]
