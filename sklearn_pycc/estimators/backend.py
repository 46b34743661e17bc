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
import warnings
from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import ClassVar

import numpy as np

from ..exceptions import RankDeficiencyWarning
from ..fitting.problem import FitResult, Problem
from ..simulation import INPUT_HOLDS
from ..skeleton.curves import as_curve

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
        parameters only. Multiple shooting over the parameters and every
        window's start (with state limits, once holding the starts within
        them and once not), then every experiment simulated whole from each
        estimate and from each one's best common rescaling, and from a
        second start whose ratios between the parameters were found too
        (:func:`~sklearn_pycc.fitting.output_error.hidden.ratio_start`); the best whole-record fit
        wins. A
        start that ``param_init`` gives in full (a refit from a fitted model)
        gets one multiple-shooting pass and is simulated whole itself, with
        no rescaling and no second start. A limit to fit on an unmeasured
        state is held at its start through all that (where the state's scale
        is free, as a tank's of unknown cross-section, any level does as well
        and the scale is then fixed; where it is not, the level is found
        next), and a last whole-record pass frees it. That start is chosen on
        the state's course with the second start's parameters where there is
        one (the second start is searched with the limit open), as the ratios
        set the level the state runs at; else with the first's. From a
        guessed start, the fit is then polished once more with an unmeasured
        stage's speed and another's swapped
        (:func:`~sklearn_pycc.fitting.output_error.swapped_speeds.swapped_starts`: a cascade's
        second
        minimum) and moved along an unmeasured state's scale toward its
        known limit (:func:`~sklearn_pycc.fitting.output_error.hidden.along_hidden_scale`); the
        best
        whole-record fit wins. Where the problem's hold is to be chosen
        (``input_hold="auto"``), the fit is last polished under each other
        input hold, and the hold of the best whole-record fit is kept
        (``input_hold_``).
        """
        from ..fitting.output_error.hidden import (
            along_hidden_scale,
            initial_table,
            limit_start,
            opened_limits,
            ratio_start,
            single_shooting,
            starting_params,
            whole_record_covariance,
        )
        from ..fitting.output_error.swapped_speeds import swapped_starts

        result = check_fit_result(self, problem, self.hidden_start(problem), "hidden_start")
        limits = problem.skeleton.limit_params
        hidden_limits = [a for a in problem.free_params
                         if a in limits and limits[a][0] in problem.hidden]
        # a start that gives every rate (a refit from a fitted model) has its time scale
        # and its ratios; a guessed one gets a second start, its ratios found too
        init = getattr(self, "param_init", None)
        given = list(init or {})
        guessed = any(a not in (init or {}) and a not in limits for a in problem.free_params)
        other = None
        if guessed:
            defaults = {**starting_params(problem, init),
                        **{a: result.params[a] for a in limits if a in result.params}}
            # the ratios set the level an unmeasured state runs at: its limit is placed
            # on the course of the start found with them, the limit open meanwhile
            defaults.update(opened_limits(problem, [a for a in hidden_limits
                                                    if a not in given]))
            other = ratio_start(problem, defaults, given)
            if other is not None:
                other = limit_start(problem, other, given)
        pinned = {a: float((result.params if other is None else other)[a])
                  for a in hidden_limits}
        inner = problem if not pinned else replace(
            problem, fixed_params={**problem.fixed_params, **pinned})
        start = {a: v for a, v in result.params.items() if a not in pinned}
        others = [] if other is None else [{a: v for a, v in other.items() if a not in pinned}]
        params, first, info = _multistart(inner, result.functions, start, window, iterations,
                                          guessed=guessed, others=others)
        unseen = info.pop("unseen")
        if pinned:
            params, first, nrmse, unseen = single_shooting(
                problem, {**params, **pinned}, first, info["substeps"], iterations)
            info["nrmse_whole"] = nrmse
        if guessed:  # a cascade's stages may have settled in each other's speed
            for swapped, initial in swapped_starts(problem, params, first, info["substeps"]):
                found = single_shooting(problem, swapped, initial, info["substeps"], iterations)
                if found[2] < info["nrmse_whole"]:
                    params, first, info["nrmse_whole"], unseen = found
            # a state below a known limit its scale should have reached
            moved = along_hidden_scale(problem, params, first, info["substeps"], iterations)
            if moved is not None:
                params, first, info["nrmse_whole"], unseen = moved
        hold = problem.input_hold
        if problem.hold_chosen:  # a held pump or a smooth one: the record tells
            for other_hold in INPUT_HOLDS:
                if other_hold == hold:
                    continue
                trial_problem = replace(problem, input_hold=other_hold)
                found = single_shooting(trial_problem, params, first, info["substeps"],
                                        iterations)
                if found[2] < info["nrmse_whole"]:
                    params, first, info["nrmse_whole"], unseen = found
                    problem, hold = trial_problem, other_hold
        info.update(initial_states=first, unseen=unseen)
        for words in unseen:
            warnings.warn(
                f"{', '.join(problem.hidden)} not measured, and the measurements cannot fix "
                f"every parameter: {words}, so only combinations of those are determined (the "
                "values found are one of many). Write a known value or ratio into the "
                "skeleton, or measure the state once.", RankDeficiencyWarning, stacklevel=5)
        table = initial_table(problem, first, problem.skeleton.states)
        attributes = {"shooting_": info, "initial_states_": table, "input_hold_": hold}
        covariance = None if unseen else whole_record_covariance(problem, params, first,
                                                                  info["substeps"])
        if covariance is not None:
            attributes["covariance_"] = covariance
        return FitResult(result.functions, params, attributes)

    def hidden_start(self, problem: Problem) -> FitResult:
        """Where the output-error fit of a problem with unmeasured states starts.

        The free parameters at the backend's ``param_init``; those it does
        not give start at 1 times the common factor whose simulation follows
        the record best (:func:`~sklearn_pycc.fitting.output_error.hidden.scaled_start`); the
        curves pinned
        to zero by the gauge.
        """
        from ..fitting.output_error.hidden import scaled_start, starting_params
        from ..skeleton.curves import ZeroCurve

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


def _multistart(problem: Problem, functions: Mapping, start: Mapping[str, float], window: int,
                iterations: int, *, guessed: bool = True,
                others: Sequence[Mapping[str, float]] = ()) -> tuple[dict, np.ndarray, dict]:
    """The best whole-record fit of ``problem`` from ``start`` and its estimates.

    Multiple shooting, then every experiment simulated whole from ``start``,
    from each estimate and from each of ``others`` (more starts, simulated
    whole only). Where ``start`` was ``guessed`` (not a fitted model's
    parameters), multiple shooting runs twice with state limits (once
    holding the windows' starts within them, once not), the start's own
    whole-record pass is left to its estimates, and each estimate's best
    common rescaling is tried too.
    Returns the parameters, each experiment's initial state and the
    stage's summary (with ``unseen``, the directions the measurements do
    not see).
    """
    from ..fitting.output_error.hidden import hidden_trajectories, rescaled, single_shooting
    from ..fitting.output_error.shooting import ShootingPlan, fit_shooting
    from ..fitting.output_error.whole_record import WholeRecord

    names = list(problem.free_params)

    def system_for(theta: np.ndarray):
        values = {**problem.fixed_params, **dict(zip(names, theta))}
        return problem.skeleton.compile(functions, values)

    theta0 = np.array([start[a] for a in names], dtype=float)
    bounds = problem.bounds
    low = np.array([bounds.get(a, (-np.inf, np.inf))[0] for a in names])
    high = np.array([bounds.get(a, (-np.inf, np.inf))[1] for a in names])
    theta0 = np.clip(theta0, low, high)
    first_system = system_for(theta0)
    whole = WholeRecord(problem)
    first = whole.first_states(first_system)
    whole.choose_substeps(first_system, first)
    estimates = [(theta0, first)]  # the start itself, simulated whole
    info = {"substeps": whole.windows.substeps}
    if any(s in problem.measured for s in problem.skeleton.states):
        plan = ShootingPlan(problem, window, hidden=hidden_trajectories(problem, first_system))
        plan.choose_substeps(first_system, plan.columns())
        # the windows' starts held within the states' limits, and left free (where a
        # state sits on its limit much of the time, either may stall); a fitted model's
        # start is refined whole as well, which stands for the second pass
        both = problem.skeleton.limits and guessed
        for limit_starts in (True, False) if both else (True,):
            theta, info = fit_shooting(plan, system_for, theta0, iterations,
                                       bounds=(low, high), limit_starts=limit_starts)
            estimates.append((theta, info["initial_states"]))
        if guessed:  # its multiple-shooting estimates stand for it
            estimates = estimates[1:]
    substeps = info["substeps"]
    # the windows' joins are soft: a last pass simulates every experiment whole, from
    # each estimate and from its best common rescaling (multiple shooting may settle
    # on the wrong time scale); the best whole-record fit is kept
    starts, seen = [], []
    for theta, initial in estimates:
        theta = np.asarray(theta, dtype=float)
        if any(np.allclose(theta, other, rtol=1e-9, atol=0.0) for other in seen):
            continue  # both multiple-shooting passes may end at the same point
        seen.append(theta)
        params = dict(zip(names, theta.tolist()))
        starts.append((params, initial))
        other = rescaled(problem, params, initial) if guessed else None
        if other is not None:
            starts.append(other)
    for other in others:  # their time scale was searched with their ratios
        theta = np.clip(np.array([other[a] for a in names], dtype=float), low, high)
        starts.append((dict(zip(names, theta.tolist())), whole.first_states(system_for(theta))))
    params, first, nrmse, unseen = min(
        (single_shooting(problem, p, f, substeps, iterations) for p, f in starts),
        key=lambda found: found[2])
    info.update(nrmse_whole=nrmse, unseen=unseen, whole_record_starts=len(starts))
    return params, first, info
