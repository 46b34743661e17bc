"""The backend contract: how one family of curves is fitted to a :class:`Problem`.

An estimator such as :class:`~sklearn_pycc.PolyCCRegressor` reads the data,
parses the skeleton, fixes the gauge and builds a :class:`Problem`; its
backend fits the unknown curves and parameters of that problem and hands back
a :class:`FitResult`; the estimator alone stores it. A new family of curves is
one subclass of :class:`Backend` plus a thin estimator that builds it (see the
user guide's page on backends)::

    class MyBackend(Backend):
        def fit(self, problem):
            ...
            return FitResult(functions, params, {"my_attribute_": value})

What a backend can do beyond ``fit`` it declares by class attributes, never
by the presence of a method: :attr:`Backend.output_error` (it implements
:meth:`Backend.refine`), :attr:`Backend.uncertainty` (it implements
:meth:`Backend.curve_sd` and :meth:`Backend.draws` from a covariance).
What ``fit``, ``refine`` and ``hidden_start`` return is checked as it is
received (:func:`check_fit_result`), so a broken result is refused with the
backend's name rather than failing later, deep inside.
"""

from __future__ import annotations

import copy
from abc import ABC, abstractmethod
from collections.abc import Mapping
from typing import ClassVar

import numpy as np

from ..fitting.numbers import Numbers, parameters_only
from ..fitting.problem import FitResult, Problem
from ..skeleton.curves import ZeroCurve, as_curve

__all__ = ["RESERVED_ATTRIBUTES", "Backend", "FitResult", "Problem", "check_fit_result"]

#: fitted attributes the estimator sets itself, which a backend's result may not carry
RESERVED_ATTRIBUTES = frozenset({
    "params_", "functions_", "skeleton_", "gauge_", "curve_ranges_", "n_parameters_",
    "backend_", "fit_mode_", "derivative_source_", "measured_states_", "n_features_in_",
    "feature_names_in_", "bootstrap_", "bootstrap_params_", "bootstrap_method_",
    "params_std_"})


class Backend(ABC):
    """How the unknown curves and parameters of a :class:`Problem` are fitted.

    A backend holds its settings (already validated by the estimator that
    built it) and nothing it learns: :meth:`fit` returns what it found.
    Its settings are the names in :attr:`settings`, each given by keyword
    and kept as an attribute of that name; an estimator passes its
    hyperparameters of those names (``PolyBackend(degree=7, basis=...)``).

    Attributes
    ----------
    random_state : int, Generator or None
        Where the backend's randomness comes from (refits on resamples give
        each copy its own seed, see :meth:`reseeded`).
    """

    #: the names of its settings, every one required
    settings: ClassVar[tuple[str, ...]] = ()

    #: it implements :meth:`refine` (fit_mode="simulation")
    output_error: ClassVar[bool] = False
    #: it implements :meth:`curve_sd` and :meth:`draws` for a model it fitted
    uncertainty: ClassVar[bool] = False
    #: it implements :meth:`written_curve` and :meth:`written_degrees`: its curves are fitted
    #: through unmeasured states, written out as polynomials
    #: (:mod:`~sklearn_pycc.fitting.output_error.hidden_curves`)
    hidden_curves: ClassVar[bool] = False
    #: joblib's ``prefer`` for refits on resamples: "threads" when the work
    #: releases the GIL (LAPACK), else "processes"
    resample_in: ClassVar[str] = "processes"
    #: whether refits on resamples vary beyond the measured range (a curve
    #: that continues the same straight way in every refit says nothing there)
    bands_beyond_data: ClassVar[bool] = True

    random_state = None

    def __init__(self, **settings) -> None:
        missing = [name for name in self.settings if name not in settings]
        unknown = [name for name in settings if name not in self.settings]
        if missing or unknown:
            problems = ([f"missing {missing}"] if missing else []) + (
                [f"unknown {unknown}"] if unknown else [])
            raise TypeError(f"{type(self).__name__} takes the settings {list(self.settings)}: "
                            + "; ".join(problems))
        for name in self.settings:
            setattr(self, name, settings[name])

    @abstractmethod
    def fit(self, problem: Problem) -> FitResult:
        """Fit the free curves and parameters of ``problem`` by equation error.

        Parameters
        ----------
        problem : Problem
            The skeleton with its constraints and gauge, the data and the
            targets (see :class:`Problem`).

        Returns
        -------
        FitResult
            Every curve of the skeleton (``ZeroCurve`` for those the gauge
            pinned to zero), the free parameters, and the backend's own
            fitted attributes.
        """

    def refine(self, problem: Problem, result: FitResult, plan) -> FitResult:
        """Refine an equation-error fit so that simulations match the states.

        Only for backends with :attr:`output_error`. ``plan`` is a
        ``ShootingPlan``: the record cut into windows, with its substeps
        chosen and ``plan.iterations``, the most optimiser iterations. The
        result carries the stage's summary as the attribute ``shooting_``.
        """
        raise ValueError(f"{type(self).__name__} does not support fit_mode='simulation'")

    def numbers(self, problem: Problem, result: FitResult) -> Numbers:
        """``result`` as one vector of numbers, for a stage that moves them (the filter's).

        By default the free parameters, every curve held as ``result`` drew
        it; a backend whose curves are a few numbers each adds them.
        """
        return parameters_only(problem, result)

    def estimate(self, problem: Problem, *, shooting_window: int = 40,
                 shooting_iterations: int = 30) -> FitResult:
        """:meth:`fit`, then :meth:`refine` when ``problem.fit_mode`` is "simulation".

        Parameters
        ----------
        problem : Problem
            What to fit.
        shooting_window, shooting_iterations : int
            Samples per shooting window and most iterations of the
            output-error stage.

        Returns
        -------
        FitResult
        """
        if problem.fit_mode != "simulation":
            return check_fit_result(self, problem, self.fit(problem))
        from ..fitting.output_error.shooting import ShootingPlan, check_iterations

        iterations = check_iterations(shooting_iterations)
        if problem.hidden:
            return self._estimate_hidden(problem, shooting_window, iterations)
        plan = ShootingPlan(problem, shooting_window)
        plan.iterations = iterations
        result = check_fit_result(self, problem, self.fit(problem))
        start = problem.skeleton.compile(result.functions,
                                         {**problem.fixed_params, **result.params})
        plan.choose_substeps(start, dict(problem.data.columns))
        return check_fit_result(self, problem, self.refine(problem, result, plan), "refine")

    def _estimate_hidden(self, problem: Problem, window: int, iterations: int) -> FitResult:
        """Output error from :meth:`hidden_start`, the unmeasured states started by simulation.

        The same for every backend: a skeleton with unmeasured states has
        parameters only (:func:`~sklearn_pycc.fitting.output_error.hidden_fit.fit_hidden`).
        """
        from ..fitting.output_error.hidden_curves import fit_hidden_curves
        from ..fitting.output_error.hidden_fit import fit_hidden

        if problem.free_functions:
            result = fit_hidden_curves(
                problem, degrees=self.written_degrees(problem), make_curve=self.written_curve,
                held={name: ZeroCurve() for name in problem.zeroed},
                param_init=getattr(self, "param_init", None), window=window,
                iterations=iterations)
            return check_fit_result(self, problem, result, "fit_hidden_curves")
        start = check_fit_result(self, problem, self.hidden_start(problem), "hidden_start")
        return fit_hidden(problem, start, param_init=getattr(self, "param_init", None),
                          window=window, iterations=iterations)

    def written_degrees(self, problem: Problem) -> dict[str, int]:
        """Each free curve's degree as a polynomial through unmeasured states."""
        raise ValueError(f"{type(self).__name__} does not fit curves through unmeasured states")

    def written_curve(self, series: np.ndarray, center: float, half: float,
                      domain: tuple[float, float]):
        """The backend's curve for a power series in ``u = (x - center) / half`` on ``domain``."""
        raise ValueError(f"{type(self).__name__} does not fit curves through unmeasured states")

    def hidden_start(self, problem: Problem) -> FitResult:
        """Where the output-error fit of a problem with unmeasured states starts.

        The free parameters at the backend's ``param_init``; those it does
        not give start at 1 times the common factor whose simulation follows
        the record best (:func:`~sklearn_pycc.fitting.output_error.hidden.scaled_start`);
        the curves pinned to zero by the gauge.
        """
        from ..fitting.output_error.hidden import scaled_start, starting_params

        init = getattr(self, "param_init", None)
        params = scaled_start(problem, starting_params(problem, init), list(init or {}))
        return FitResult({name: ZeroCurve() for name in problem.zeroed}, params)

    def __repr__(self) -> str:
        shown = [f"{name}={getattr(self, name)!r}" for name in self.settings]
        return f"{type(self).__name__}({', '.join(shown)})"

    def reseeded(self, seed: int) -> Backend:
        """A copy of this backend that draws its randomness from ``seed``."""
        twin = copy.copy(self)
        twin.random_state = seed
        return twin

    # -- describing a fitted model -------------------------------------------------
    def n_numbers(self, problem: Problem, result: FitResult, name: str) -> int:
        """How many numbers were fitted for the curve ``name`` (for information criteria)."""
        return as_curve(result.functions[name]).n_numbers

    def curve_text(self, curve, variable: str, precision: int) -> str:
        """A fitted curve written as a function of ``variable``."""
        return as_curve(curve).text(variable, precision)

    def attributes_of(self, functions: Mapping, variables: Mapping[str, str]) -> dict:
        """Fitted attributes derived from the curves whenever they change.

        ``variables`` names each curve's argument as the model writes it.
        """
        return {}

    # -- uncertainty (backends with ``uncertainty``) --------------------------------
    def curve_sd(self, model, name: str, x: np.ndarray) -> np.ndarray | None:
        """Standard deviation of the fitted curve ``name`` of ``model`` at ``x``.

        None when the fit left no estimate of it.
        """
        return None

    def draws(self, model, n: int, rng: np.random.Generator) -> list[tuple[dict, dict]] | None:
        """``n`` models ``(functions, params)`` drawn from the estimate's distribution."""
        return None


def check_fit_result(backend: Backend, problem: Problem, result, step: str = "fit"
                     ) -> FitResult:
    """``result``, returned by ``backend``'s ``step``, checked against the contract.

    Every curve of the skeleton, each a callable that maps an array to one of
    the same shape; every free parameter and no other name, each a finite
    number; fitted attributes whose names end in ``_`` and are not among
    :data:`RESERVED_ATTRIBUTES`.

    Parameters
    ----------
    backend : Backend
        The backend that returned ``result`` (named in the errors).
    problem : Problem
        What it was asked to fit.
    result : object
        What it returned.
    step : str, default="fit"
        The method that returned it.

    Returns
    -------
    FitResult
        ``result`` itself.

    Raises
    ------
    TypeError
        When ``result`` is not a :class:`FitResult`, or one of its parts has
        the wrong type.
    ValueError
        When a curve, a parameter or an attribute breaks the contract.
    """
    who = f"{type(backend).__name__}.{step}"
    if not isinstance(result, FitResult):
        raise TypeError(f"{who} returned {type(result).__name__}, not a FitResult: return "
                        "FitResult(functions, params, attributes)")
    for part in ("functions", "params", "attributes"):
        if not isinstance(getattr(result, part), Mapping):
            raise TypeError(f"{who} returned a FitResult whose {part} is "
                            f"{type(getattr(result, part)).__name__}, not a dict by name")
    _check_names(who, "curve", list(result.functions), problem.skeleton.functions,
                 problem.skeleton.functions)
    _check_names(who, "parameter", list(result.params), problem.free_params,
                 problem.skeleton.params)
    params = _checked_params(who, problem, result.params)
    for name in problem.skeleton.functions:
        _check_curve(who, problem, name, result.functions[name], params)
    _check_attributes(who, result.attributes)
    return result


def _check_names(who: str, kind: str, given: list, needed: list, known: list) -> None:
    """Refuse a result that leaves out a name of ``needed`` or gives one not in ``known``."""
    missing = [name for name in needed if name not in given]
    if missing:
        raise ValueError(f"{who} returned no {kind} {', '.join(map(str, missing))}: a result "
                         f"holds every {kind} to fit ({', '.join(needed)})"
                         + (", ZeroCurve() for those the gauge pinned to zero"
                            if kind == "curve" else ""))
    extra = [name for name in given if name not in known]
    if extra:
        raise ValueError(f"{who} returned the {kind} {', '.join(map(repr, extra))}, which the "
                         f"skeleton does not have (its {kind}s: {', '.join(known) or 'none'})")


def _checked_params(who: str, problem: Problem, params: Mapping) -> dict[str, float]:
    """Every parameter of the skeleton as a float: the result's, then the gauge's pins."""
    values = dict(problem.fixed_params)
    for name, value in params.items():
        if np.ndim(value) != 0 or isinstance(value, (str, bytes)):
            raise TypeError(f"{who} returned the parameter {name} = {value!r}, not a number")
        try:
            number = float(value)
        except (TypeError, ValueError):
            raise TypeError(f"{who} returned the parameter {name} = {value!r}, not a "
                            "number") from None
        if not np.isfinite(number):
            raise ValueError(f"{who} returned the parameter {name} = {number}: a fit gives "
                             "finite values (did the optimiser diverge, or divide by zero?)")
        pinned = problem.fixed_params.get(name)
        if pinned is not None and number != pinned:
            raise ValueError(f"{who} returned {name} = {number:g}, which the problem pins to "
                             f"{pinned:g} (problem.fixed_params): fit problem.free_params only")
        values[name] = number
    return values


def _check_curve(who: str, problem: Problem, name: str, curve, params: Mapping) -> None:
    """Refuse a curve that is not callable or does not map an array to one of its shape."""
    if not callable(curve):
        raise TypeError(f"{who} returned {type(curve).__name__} for the curve {name}, not a "
                        "callable on numpy arrays")
    x = _probe_points(problem, name, params, as_curve(curve).domain)
    try:
        with np.errstate(all="ignore"):
            value = curve(x)
    except Exception as error:  # a user's curve: any failure is reported as its own
        raise ValueError(f"{who} returned a curve {name} that fails on {len(x)} values of its "
                         f"argument in the data: {type(error).__name__}: {error}") from error
    shape = np.shape(value)
    if shape != x.shape:
        raise ValueError(f"{who} returned a curve {name} that maps an array of shape {x.shape} "
                         f"to one of shape {shape}: a curve maps an array to one of the same "
                         "shape, value by value")


def _probe_points(problem: Problem, name: str, params: Mapping, domain) -> np.ndarray:
    """A few values of a curve's argument in the data, within the curve's domain.

    Never as many as the data's rows, so that a curve returning its training
    values whatever it is given is caught.
    """
    x = problem.argument_values(name, params)
    count = 5 if problem.data.n_samples != 5 else 4
    x = x[np.linspace(0, x.size - 1, count).astype(int)] if x.size else np.linspace(-1, 1,
                                                                                    count)
    low, high = (float(v) for v in domain)
    if low <= high:  # a table or network asked beyond its range may raise, as it should
        x = np.clip(x, low, high)
    return np.asarray(x, dtype=float)


def _check_attributes(who: str, attributes: Mapping) -> None:
    """Refuse fitted attributes that do not end in ``_`` or that the estimator sets itself."""
    for name in attributes:
        if not isinstance(name, str) or not name.endswith("_") or name.startswith("_"):
            raise ValueError(f"{who} returned the fitted attribute {name!r}: a fitted "
                             "attribute is a name that ends in '_' and does not start with one")
        if name in RESERVED_ATTRIBUTES:
            raise ValueError(f"{who} returned the fitted attribute {name!r}, which the "
                             "estimator sets itself (reserved: "
                             f"{', '.join(sorted(RESERVED_ATTRIBUTES))}): give it a name of "
                             "its own")
