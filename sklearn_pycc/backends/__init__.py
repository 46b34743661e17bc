"""The internals of each backend: what fits a curve as polynomials, networks or formulas.

Each subpackage serves one estimator of :mod:`sklearn_pycc.estimators`
(:mod:`.poly`, :mod:`.neural`, :mod:`.symbolic`); all of them build on
:mod:`sklearn_pycc.fitting` and none imports an estimator.
"""
