"""The shared base of every backend: :class:`CCRegressor`."""

from __future__ import annotations

import copy
import warnings
from abc import ABCMeta, abstractmethod
from collections.abc import Mapping
from dataclasses import replace
from numbers import Integral

import numpy as np
import pandas as pd
from sklearn.base import BaseEstimator, RegressorMixin, _fit_context, clone
from sklearn.metrics import r2_score
from sklearn.utils._param_validation import HasMethods, Interval, StrOptions
from sklearn.utils.validation import check_is_fitted, validate_data

from .._utils.progress import Progress
from .._utils.randomness import seeds
from .._utils.threads import blas_threads
from ..exceptions import DomainWarning, SimulationError
from ..fitting.filter.evidence import LAGS as PROCESS_NOISE_LAGS
from ..fitting.filter.evidence import process_noise_evidence
from ..fitting.filter.noises import check_measurement_noise, check_process_noise
from ..fitting.filter.stage import filter_stage
from ..fitting.fingerprint import fit_fingerprint
from ..fitting.initial_state import check_initial_state
from ..fitting.output_error.hidden import check_visible
from ..fitting.output_error.hidden_curves import hidden_level_gauge
from ..fitting.output_error.noise_model import NOISE_MODELS, fit_noise_model
from ..fitting.problem import (
    GAUGES,
    FitResult,
    Problem,
    build_skeleton,
    gauge_skeleton,
    measured_part,
)
from ..fitting.uncertainty.intervals import IntervalsMixin
from ..measurements import read_record
from ..measurements.columns import read_X, read_y, time_values
from ..measurements.differentiation import (
    DIFFERENTIATION_METHODS,
    Differentiator,
    resolve_differentiation,
)
from ..measurements.experiments import TIME, TRAJECTORY
from ..measurements.gaps import filled_across_gaps, missing_samples, split_at_gaps
from ..measurements.measurement import Measurement, unwrap
from ..measurements.reconstruct import kinematic_chains
from ..measurements.record import MEASURED, STATIC, targets_in_y
from ..quantities import state_quantities
from ..simulation.integration import INPUT_HOLDS, given_hold
from ..skeleton import Skeleton
from ..skeleton.compiler import compile_expression
from ..skeleton.curves import as_curve
from ..skeleton.nodes import sum_terms
from ..skeleton.printer import to_text
from ..skeleton.system import CompiledSystem
from ._delays import fit_delays, fit_error, refine_delays
from ._filtering import FilteringMixin
from ._reading import ReadingMixin
from ._simulating import SimulationMixin
from .backend import Backend

__all__ = ["FIT_MODES", "OUTPUT_ERROR_SETTINGS", "RANDOM_STATES", "RESAMPLING", "CCRegressor",
           "adopt", "backend_of", "check_equation_weights", "make_problem", "set_fitted"]

FIT_MODES = ("auto", "equation", "simulation", "filter")
#: the hyperparameters of the output-error stage, left out by estimators that have none
OUTPUT_ERROR_SETTINGS = ("fit_mode", "shooting_window", "shooting_iterations", "input_hold",
                         "noise_model", "process_noise", "measurement_noise", "initial_state")
#: below this signal-to-noise ratio of the measured states, ``fit_mode="auto"`` refines the
#: equation fit by output error: derivatives of such records bias the fit by per cents
AUTO_SIMULATION_SNR_DB = 45.0
_NEEDS_TIME = "fit_mode='simulation' needs the time column 't' in X"

#: each fit mode in the words a fit's progress says it in
_MODE_WORDS = {"equation": "equation error", "simulation": "output error",
               "filter": "the Kalman filter's likelihood"}
#: private fitted state, cleared with the public fitted attributes when fit starts again
_PRIVATE_STATE = ("_compiled", "_y_1d", "_covariance", "_fingerprint")
#: what ``random_state`` may be: a Generator is honoured like a RandomState
RANDOM_STATES = [None, Interval(Integral, 0, 2**32 - 1, closed="both"),
                 np.random.RandomState, np.random.Generator]
#: the hyperparameters of a backend that refits on resamples (``n_bootstrap``, ``n_jobs``)
#: most refits on resamples a fit may ask for (each is a whole fit)
MAX_BOOTSTRAP = 10_000
RESAMPLING = {"n_bootstrap": [Interval(Integral, 0, MAX_BOOTSTRAP, closed="both")],
              "n_jobs": [Integral, None]}


class EquationsView(list):
    """The ``equations`` hyperparameter as seen on an estimator.

    It is the list of equations as given, and calling it writes out the
    fitted model: ``model.equations()``.
    """

    def __init__(self, raw, estimator) -> None:
        if raw is None:
            items = []
        elif isinstance(raw, Skeleton):
            items = list(raw.equations)
        elif isinstance(raw, str):
            items = [raw]
        else:
            try:
                items = list(raw)
            except TypeError:
                items = [raw]
        super().__init__(items)
        self._estimator = estimator

    def __call__(self, precision: int = 6) -> list[str]:
        """The fitted model written out to ``precision`` digits (see ``equations_text``)."""
        return self._estimator.equations_text(precision)


class _EquationsParameter:
    """Data descriptor storing the raw hyperparameter and returning an :class:`EquationsView`."""

    def __get__(self, obj, objtype=None):
        if obj is None:
            return self
        return EquationsView(obj.__dict__.get("equations"), obj)

    def __set__(self, obj, value) -> None:
        obj.__dict__["equations"] = value


class CCRegressor(ReadingMixin, SimulationMixin, FilteringMixin, IntervalsMixin, RegressorMixin,
                  BaseEstimator, metaclass=ABCMeta):
    """Abstract base class of the characteristic-curve estimators.

    It cannot be fitted itself: use :class:`PolyCCRegressor`,
    :class:`NeuralCCRegressor` or :class:`SymbolicCCRegressor`. Each of
    them builds a :class:`~sklearn_pycc.estimators.backend.Backend` from its
    hyperparameters, which only decides how an unknown curve ``f_i`` is
    represented and fitted; parsing, constraints, the gauge, prediction,
    scoring and simulation live here. Hyperparameters are keyword-only and
    checked at the start of ``fit`` against ``_parameter_constraints``.

    Parameters
    ----------
    equations : list of str or Skeleton
        The structural skeleton, e.g.
        ``["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"]``. After
        ``fit``, calling it, ``model.equations(precision=6)``, returns the
        fitted model written out (:meth:`equations_text`); the value stays
        the list given.
    constraints : list of str or dict, optional
        Prior knowledge: ``"f1 odd"``, ``"f1 even"``, ``"f2(0)=0"`` or
        ``{"constraint": "f1 odd"}``.
    gauge : {"auto", "warn", "raise"}, default="auto"
        What to do when the skeleton is not identifiable: pin the ambiguity
        and record it in ``gauge_``, only warn, or raise.
    differentiation : str, dict or callable, default="auto"
        How derivatives are estimated when ``fit`` gets no ``y``. ``"auto"``
        reads each experiment's spectrum (sampling rate, noise floor,
        quantisation, dropped samples) and differentiates it by a zero-phase
        low-pass at the cutoff that minimises the estimated error of the
        highest derivative needed, then a band-limited differentiator; the
        inputs pass the same filter. What it chose, and why, is in
        ``derivative_source_``. Fixed methods: ``"lowpass"`` (the same with
        ``{"method": "lowpass", "cutoff": hz}``), ``"spline"`` (cubic
        smoothing spline, smoothing chosen by GCV), ``"savgol"``,
        ``"finite_difference"``, ``"kalman"``, ``"trend_filtered"`` (these two
        need the ``derivative`` package), ``{"method": name, **options}``, an
        object with ``d(x, t)`` or a callable ``f(x, t) -> dx/dt``. Each
        experiment (``trajectory``) is differentiated on its own; a state
        missing from ``X`` but defined by a kinematic equation
        (``x1_dot = x2``) is the derivative of the measured one.
    smooth_states : bool, default=True
        When derivatives are estimated, fit on the smoothed states rather
        than the raw measurements.
    fit_mode : {"auto", "equation", "simulation", "filter"}, default="auto"
        ``"equation"`` fits the derivatives (equation error). ``"simulation"``
        then refines the fit so that the simulated states match the
        measured ones (output error), by multiple shooting over short
        windows: an integral form of the equations that differentiates
        nothing; it needs ``t``. ``"auto"`` refines when the derivatives had
        to be estimated from states the ``"auto"`` differentiation found
        noisier than ``AUTO_SIMULATION_SNR_DB`` (45 dB), and the backend and
        skeleton can be simulated; it says so in ``derivative_source_``, and
        ``fit_mode_`` holds the mode used. Where that output-error model then
        shows process noise (it cannot follow the record without a random
        push, and the one-step errors the push leaves are white and depend on
        no state: a disturbance, not a missing effect), ``"auto"`` goes on as
        ``"filter"`` does and says so. ``"filter"`` reads the skeleton as
        a stochastic differential equation, every state but a kinematic
        identity pushed by its own white noise (a disturbance nobody
        measured), and refines the output-error fit by the extended Kalman
        filter's likelihood (the equation-error fit, for a backend without an
        output-error stage): the parameters, the polynomial curves'
        coefficients or the networks' last layers, the noises' intensities
        (``process_noise_``) and the measurement noise
        (``measurement_noise_``), their covariance from the likelihood's
        curvature. A monotone curve is held as the start drew it
        (``filter_["held"]``). Not with ``noise_model`` or
        ``n_bootstrap``; a state nobody measured is filtered through each
        whole experiment, and the states' hard limits hold inside the filter.
    shooting_window : int, default=40
        Samples per shooting segment in ``fit_mode="simulation"``.
    shooting_iterations : int, default=30
        Most iterations of the output-error optimisation.
    equation_weights : list of float, optional
        One non-negative weight per equation, in the order given (default 1
        each). Each equation's residual is first divided by its size on the
        data (its measured left side, e.g. ``x2_dot``, or for ``0 = ...`` the
        part without unknowns), then multiplied by its weight: raise the
        weight of a relation the fit must honour more closely, such as a
        conserved quantity.
    quantities : dict, optional
        What each state measures, ``{"x1": "level"}`` (one of
        :data:`sklearn_pycc.quantities.QUANTITIES`). The fit does not use it;
        :func:`~sklearn_pycc.diagnose` and :class:`~sklearn_pycc.HypothesisLoop`
        then try only the effects such a state can have and name them in its
        field's words (Torricelli outflow on a level). By default the units
        and the skeleton's structure decide
        (:func:`~sklearn_pycc.quantities.state_quantities`).
    input_hold : {"auto", "bandlimited", "foh", "zoh"}, default="auto"
        How the inputs were applied between samples, for the output-error
        stage, the diagnosis's simulations and :meth:`simulate`'s default: a
        measured or generated signal (band-limited), straight lines, or
        steps held from one sample to the next (``"zoh"``: a digital
        controller's or a plant's logged setpoints). A held input read as
        band-limited rings at its steps and biases an output-error fit by
        per cents. ``"auto"``: where states are unmeasured, the whole-record
        fit is polished under each hold and the one that follows the record
        best is kept (the record tells a held pump from a smooth one by its
        steps' mark on the measured states); elsewhere band-limited. The
        hold used is ``input_hold_``.
    noise_model : {"ar", "arma", "auto"} or None, default=None
        A model of the measurement noise for output-error fits (the
        prediction-error method). Coloured noise (correlated in time) makes
        plain least squares count its samples as independent; with a noise
        model, a first output-error fit's whole-record errors give each
        measured state's noise model (``"ar"``: autoregressive, order 1 to 4
        chosen by the BIC; ``"arma"``: ARMA(1,1); ``"auto"``: the best of
        those and white noise by the BIC), and the fit is made again with
        every output error whitened by it. The model is ``noise_model_``.
        Only for fits by output error without unmeasured states.
    process_noise : dict or None, default=None
        Which states the random push of ``fit_mode="filter"`` enters, and
        how its intensities are fitted (also where ``"auto"`` recognises a
        push). None: every state whose equation is more than a kinematic
        identity, each with its own fitted intensity. A dict overrides that
        state by state: a number holds the state's intensity at it (``0``:
        not pushed, ``{"x2": 0}`` for a level fed only through a pipe), a
        name makes the states given it share one fitted intensity
        (``{"x1": "load", "x2": "load"}``). States it does not name keep the
        default; a kinematic identity is pushed only where named. With no
        intensity left to fit, ``"auto"`` has no push to recognise and keeps
        output error.
    measurement_noise : dict or None, default=None
        For ``fit_mode="filter"``: measured state -> the standard deviation
        of its sensor's noise, held (the filter fits the others'). With
        every number given (in the equations, ``process_noise`` and here)
        :meth:`log_likelihood` evaluates that model without a fit.
    initial_state : dict or None, default=None
        State -> where every experiment starts, a number (known) or a pair
        ``(mean, variance)``. The filter starts there with that variance;
        output error (``fit_mode="simulation"``) holds the mean as every
        experiment's start instead of fitting it (``initial_states_`` then
        gives it). A state not given starts at the record's first sample (an
        unmeasured one where the output-error model simulates it), for the
        filter with the measured samples' mean square as its variance, and
        output error fits it. The equation-error fit does not read it and
        says so.

    Attributes
    ----------
    skeleton_ : Skeleton
        The parsed skeleton with its constraints.
    params_ : dict
        Fitted (and gauge-fixed) parameters ``{"a1": value, ...}``, the delays
        of inputs read late (``u(t - a5)``) among them.
    delays_ : dict
        Only for a skeleton that reads an input late by a fitted delay: each
        delay's parameter and value, in the time units of ``t``. The fitted
        skeleton (``skeleton_``) reads the input at that delay as a number.
    functions_ : dict
        Fitted curves ``{"f1": callable, ...}``, vectorised over numpy arrays.
    gauge_ : dict
        ``{pin: reason}`` for what was pinned to make the skeleton identifiable.
    curve_ranges_ : dict
        Range of each curve's argument over the training data.
    n_parameters_ : int
        Numbers fitted: free parameters ``a_i`` plus each curve's
        coefficients or weights (for information criteria).
    measured_states_ : list of str
        States given as columns of ``X`` in ``fit``.
    derivative_source_ : str
        ``"measured"``, or how the derivatives were estimated: per
        experiment, the method and its setting and, for ``"auto"``, what the
        record showed (sampling rate, noise level, quantisation, dropped
        samples) that led to it.
    fit_mode_ : str
        The mode the fit used: ``"equation"``, ``"simulation"`` or ``"filter"``.
    process_noise_, measurement_noise_ : dict
        Only with ``fit_mode="filter"``: each state's process-noise
        intensity (the standard deviation of its random increment over one
        unit of time; 0 for a kinematic identity) and each measured state's
        measurement-noise standard deviation. ``filter_`` holds the fit's
        negative log-likelihood, iterations and segments.
    process_noise_std_, measurement_noise_std_ : dict
        Only with ``fit_mode="filter"``: their standard errors, from the
        likelihood's curvature (0 for a held noise or a state not pushed;
        NaN where the curvature gave none).
    process_noise_evidence_ : ProcessNoiseEvidence or None
        Where ``fit_mode="auto"`` looked for process noise (after an
        output-error fit of noisy states), what the filter saw: whether a
        random push is recognised, or, where the one-step errors it leaves
        depend on a state, that the skeleton misses something
        (:func:`~sklearn_pycc.fitting.filter.evidence.process_noise_evidence`);
        None where it did not look.
    noise_model_ : NoiseModel or None
        With ``noise_model``, after an output-error fit: each measured
        state's noise model (AR coefficients and poles, MA coefficient,
        innovation and error levels), read from the final fit's
        whole-record errors; None otherwise.
    backend_ : Backend
        The backend that fitted the curves, built from the hyperparameters
        (:mod:`sklearn_pycc.estimators.backend`).
    shooting_ : dict
        Only after an output-error fit: segments, iterations, the
        normalised RMSE of the simulated states before and after, and the
        largest continuity defect. With unmeasured states also
        ``nrmse_whole`` (the measured states and readings simulated along
        whole experiments), ``unseen`` (directions the measurements cannot
        fix, in words) and ``whole_record_starts`` (the starts of the last,
        whole-record pass; the best is kept).
    starts_ : DataFrame
        Only after an output-error fit with unmeasured states: one row per
        start of the whole-record pass (``start``: where it came from;
        ``nrmse_start`` and ``nrmse``: the measured states' normalised RMSE
        simulated from it and after polishing; ``polished``: "whole", or
        "trial" for a start dropped after a few evaluations; ``kept``). Two
        starts that simulate the record equally well at different parameters
        raise a :class:`~sklearn_pycc.StartsWarning`. With curves through
        unmeasured states a column ``stage`` says which fit each start
        belongs to: "straight lines" (every curve a line, its law) or
        "curves" (of their degree, started on the lines).
    written_curves_ : dict
        Only after a fit with curves through unmeasured states (backends
        with ``hidden_curves``): for each free curve, a
        :class:`~sklearn_pycc.fitting.output_error.hidden_curves.WrittenCurve`,
        the polynomial form it was fitted as (over ``domain``, monotone there
        where the curve is constrained so) and its numbers.
    n_features_in_ : int
        Number of columns of ``X`` seen in ``fit``.
    feature_names_in_ : ndarray
        Column names of ``X`` when it was a DataFrame.

    Notes
    -----
    A missing sample of a measured state (NaN in its column) is filtered
    through by ``fit_mode="filter"`` and its methods (:meth:`smooth`,
    :meth:`log_likelihood`, ...): the update uses the signals present. The
    output-error fit the filter starts from reads it on the straight line
    between its neighbours. The other fit modes split the experiment there
    (each stretch between gaps its own experiment, a sample alone between
    two gaps left out) and say so.
    """

    equations = _EquationsParameter()

    #: checked at the start of ``fit`` (scikit-learn's parameter validation);
    #: each backend extends it with its own hyperparameters
    _parameter_constraints: dict = {
        "equations": [list, tuple, Skeleton, None],
        "constraints": [list, tuple, None],
        "gauge": [StrOptions(set(GAUGES))],
        "differentiation": [StrOptions(set(DIFFERENTIATION_METHODS)), dict, Differentiator,
                            HasMethods(["d"]), callable],
        "smooth_states": ["boolean"],
        "fit_mode": [StrOptions(set(FIT_MODES))],
        "shooting_window": [Interval(Integral, 2, None, closed="left")],
        "shooting_iterations": [Interval(Integral, 1, None, closed="left")],
        "equation_weights": ["array-like", None],
        "input_hold": [StrOptions({*INPUT_HOLDS, "auto"})],
        "noise_model": [StrOptions(set(NOISE_MODELS)), None],
        "quantities": [dict, None],
        "process_noise": [dict, None],
        "measurement_noise": [dict, None],
        "initial_state": [dict, None],
    }

    def __init__(self, *, equations=None, constraints=None, gauge: str = "auto",
                 differentiation="auto", smooth_states: bool = True,
                 fit_mode: str = "auto", shooting_window: int = 40,
                 shooting_iterations: int = 30, equation_weights=None,
                 input_hold: str = "auto", noise_model: str | None = None,
                 quantities: Mapping[str, str] | None = None,
                 process_noise: Mapping | None = None,
                 measurement_noise: Mapping | None = None,
                 initial_state: Mapping | None = None) -> None:
        self.equations = equations
        self.constraints = constraints
        self.equation_weights = equation_weights
        self.gauge = gauge
        self.differentiation = differentiation
        self.smooth_states = smooth_states
        self.fit_mode = fit_mode
        self.shooting_window = shooting_window
        self.shooting_iterations = shooting_iterations
        self.input_hold = input_hold
        self.noise_model = noise_model
        self.quantities = quantities
        self.process_noise = process_noise
        self.measurement_noise = measurement_noise
        self.initial_state = initial_state

    # -- to be provided by each estimator -------------------------------------
    @abstractmethod
    def _make_backend(self) -> Backend:
        """The backend these hyperparameters describe (checked already by ``fit``)."""

    def _backend_settings(self, backend: type[Backend]) -> dict:
        """The hyperparameters that are ``backend``'s settings, by name."""
        params = self.get_params(deep=False)
        return {name: params[name] for name in backend.settings}

    # -- scikit-learn plumbing -------------------------------------------------
    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.target_tags.multi_output = True
        tags.target_tags.single_output = True
        tags.input_tags.allow_nan = False
        # the user's skeleton, not the data, decides what can be fitted: no score is promised
        tags.regressor_tags.poor_score = True
        return tags

    def get_params(self, deep: bool = True) -> dict:
        """Get parameters for this estimator (``equations`` exactly as given)."""
        params = super().get_params(deep=deep)
        params["equations"] = self.__dict__.get("equations")
        return params

    def __getstate__(self) -> dict:
        state = super().__getstate__()
        state.pop("_compiled", None)
        if "_covariance" in state:  # a saved model carries the table, not what makes it
            state["_covariance"] = self.covariance_
        return state

    # -- fitting ---------------------------------------------------------------
    def _problem(self, X, y, backend: Backend | None = None, *,
                 delays: Mapping[str, float] | None = None,
                 profile: bool = False, filtering: bool | None = None) -> tuple[Problem, dict]:
        """The fitting problem, and what was learned about the record (to be stored).

        An input read late (``u(t - a5)``) is read with its delay at
        ``delays`` (the fitted ones when None and the model is fitted);
        ``profile`` fits by equation error where it can, as the search for
        the delays does. ``filtering`` (default: ``fit_mode="filter"``)
        reads a measured state's missing samples as missing (the problem's
        ``missing``), across which the record's other readers see straight
        lines; otherwise each experiment is split at its missing samples.
        """
        backend = self._make_backend() if backend is None else backend
        skeleton = build_skeleton(self.__dict__.get("equations"), self.constraints)
        given = None  # the record as given, where the split at its gaps changed its columns
        if self.fit_mode == "filter" if filtering is None else filtering:
            X, y, missing = _across_gaps(X, y, skeleton)
        else:
            missing = {}
            X, y, given = _split_at_gaps(X, y, skeleton, self.fit_mode)
        if skeleton.delay_params:
            if delays is None:
                delays = getattr(self, "delays_", None)
            if delays is None:
                raise ValueError(f"{type(self).__name__}: the delays "
                                 f"{', '.join(skeleton.delay_params)} are fitted by fit")
            skeleton = skeleton.with_delays(delays)
        state_quantities(skeleton, self.quantities)  # names a state or quantity it lacks
        if self.fit_mode in ("simulation", "filter"):
            _check_simulable(skeleton, outputs_ok=True)
        constraints, fixed, zeroed, gauge = gauge_skeleton(skeleton, self.gauge)
        record = read_record(skeleton, X, y, differentiation=self.differentiation,
                             smooth=bool(self.smooth_states), estimator=self, reset=True,
                             need_time=(_NEEDS_TIME.replace("'simulation'", repr(self.fit_mode))
                                        if self.fit_mode in ("simulation", "filter") else None),
                             who=type(self).__name__, trim=False,
                             hidden_ok=self.fit_mode != "equation")
        if given is not None:  # the model learns the columns the user gave
            validate_data(self, given, reset=True, skip_check_array=True)
        _warn_crossed_limits(skeleton, record)
        # a held sensor noise of a state X does not measure: said now, not after the fit
        check_measurement_noise(getattr(self, "measurement_noise", None), skeleton.states,
                                [s for s in skeleton.states if s in record.measured])
        if record.hidden:  # every limit is then fitted by output error
            _check_hidden(skeleton, record.hidden, backend)
            constraints, gauge = hidden_level_gauge(skeleton, record.hidden, constraints, gauge)
        else:
            fixed = {**fixed, **_measured_limits(skeleton, record)}
            if self.fit_mode in ("simulation", "filter"):
                _check_simulable(skeleton)
        weights = check_equation_weights(self.equation_weights, skeleton)
        mode, why = self._resolve_mode(skeleton, record, backend)
        if profile and not record.hidden:
            mode, why = "equation", ""
        facts = {"fit_mode_": "filter" if self.fit_mode == "filter" and not profile else mode,
                 "derivative_source_": record.source + why,
                 "input_hold_": given_hold(self),
                 "measured_states_": list(record.measured),
                 "_y_1d": record.y_ndim == 1 and len(skeleton.targets) == 1}
        # the equations are fitted where the derivatives can be trusted; an
        # output-error stage simulates the whole record
        trusted = record.keep()
        problem = Problem(skeleton, constraints, fixed, zeroed, trusted.data,
                          trusted.derivatives, gauge, record.experiments, record.measured,
                          record.smoothed, record.signals, fit_mode=mode,
                          equation_weights=weights,
                          rows=None if record.trusted is None else np.flatnonzero(record.trusted),
                          hidden=record.hidden,
                          input_hold=given_hold(self),
                          hold_chosen=getattr(self, "input_hold", "auto") == "auto",
                          observed=({o: record.data[o] for o in skeleton.outputs}
                                    if record.hidden else {}),
                          process_noise=self.process_noise,
                          measurement_noise=getattr(self, "measurement_noise", None),
                          initial_state=check_initial_state(getattr(self, "initial_state", None),
                                                            skeleton.states),
                          missing=missing)
        return problem, facts

    def _problem_of(self, X) -> Problem:
        """The fitting problem ``X`` makes, read by a clone (this model learns nothing).

        The clone reads the inputs late by the delays this model fitted,
        and a measured state's missing samples as missing (the filter's
        methods read them so).
        """
        return clone(self)._problem(X, None, delays=getattr(self, "delays_", None),
                                    filtering=True)[0]

    def _resolve_mode(self, skeleton, record, backend: Backend) -> tuple[str, str]:
        """The fit mode to use, and why ``"auto"`` chose output error (else "")."""
        if record.hidden:
            hidden = ", ".join(record.hidden)
            seen = ", ".join([*record.measured, *skeleton.outputs])
            return "simulation", (
                f"; {hidden} not measured: fitted by output error on {seen}, the value of "
                f"{hidden} at the start of each experiment a fitted number (initial_states_)")
        if self.fit_mode == "filter":  # the output-error fit is where the filter starts
            start = "simulation" if backend.output_error else "equation"
            return start, "; refined by the extended Kalman filter's likelihood"
        if self.fit_mode != "auto":
            return self.fit_mode, ""
        noisy = record.estimated and record.snr_db is not None \
            and record.snr_db < AUTO_SIMULATION_SNR_DB
        simulable = (backend.output_error
                     and record.experiments is not None
                     and all(eq.explicit for eq in skeleton.parsed)
                     and not skeleton.algebraic
                     and all(s in record.smoothed for s in skeleton.states)
                     and all(e.n_samples >= 2 for e in record.experiments))
        if not (noisy and simulable):
            return "equation", ""
        return "simulation", (
            f"; refined by output error (fit_mode='auto': the states' SNR of "
            f"{record.snr_db:.0f} dB is below {AUTO_SIMULATION_SNR_DB:g} dB, where estimated "
            "derivatives bias the fit)")

    def _reset_fitted(self) -> None:
        """Forget everything a previous fit learned (attributes ending in ``_``)."""
        for name in list(vars(self)):
            fitted = name.endswith("_") and not name.startswith("__")
            if fitted or name in _PRIVATE_STATE:
                del self.__dict__[name]

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y=None):
        """Fit the unknown curves and parameters of the skeleton.

        Parameters
        ----------
        X : DataFrame of shape (n_samples, n_columns)
            States and inputs by name (``t`` and ``trajectory`` optional). An
            array's columns are called ``x0, x1, ...``.
        y : DataFrame or array of shape (n_samples, n_states), optional
            Measured derivatives: columns ``NAME_dot`` (a DataFrame is matched
            by name, an array is taken in the order of the equations). When
            None, they are estimated from ``X`` and its ``t`` column (see
            ``differentiation``).

        Returns
        -------
        self : CCRegressor
            The fitted estimator.
        """
        self._reset_fitted()
        # every hyperparameter is checked before any data work
        n_bootstrap = getattr(self, "n_bootstrap", 0)
        if n_bootstrap == 1:
            raise ValueError("n_bootstrap must be 0 (no resampling) or at least 2, got 1")
        resolve_differentiation(self.differentiation)
        if self.fit_mode == "filter" and (self.noise_model is not None or n_bootstrap):
            setting = "noise_model" if self.noise_model is not None else "n_bootstrap"
            raise ValueError(f"fit_mode='filter' models the measurement noise as white and "
                             f"gives its own covariance; {setting} is for output-error fits "
                             f"(fit_mode='simulation')")
        backend = self._make_backend()
        skeleton = build_skeleton(self.__dict__.get("equations"), self.constraints)
        self._check_filter_settings(skeleton)
        progress = Progress(f"{type(self).__name__}.fit", getattr(self, "verbose", 0))
        if skeleton.delay_params:
            progress.stage(f"searching the delays {', '.join(skeleton.delay_params)}")
        delays = self._fit_delays(X, y, skeleton, backend) if skeleton.delay_params else {}
        progress.stage("reading the record")
        problem, facts = self._problem(X, y, backend, delays=delays)
        if delays:
            facts = {**facts, "delays_": delays}
        problem.check_enough_rows()
        _warn_still_record(problem)
        samples = (sum(e.n_samples for e in problem.experiments) if problem.experiments
                   else problem.data.n_samples)
        progress.stage(f"fitting by {_MODE_WORDS[problem.fit_mode]} ({samples:,} samples)")
        result = backend.estimate(problem, shooting_window=self.shooting_window,
                                  shooting_iterations=self.shooting_iterations)
        facts = {**facts, "process_noise_evidence_": None}
        if self.fit_mode == "filter":
            progress.stage("refining by the Kalman filter's likelihood")
            with blas_threads(1):
                result = filter_stage(problem, backend.numbers(problem, result),
                                      verbose=progress.verbose)
        elif self.fit_mode == "auto" and self.noise_model is None and not n_bootstrap:
            result, facts = self._recognised(problem, result, facts, backend)
        noise = None
        if self.noise_model is not None:
            if problem.fit_mode == "simulation" and not problem.hidden:
                result, noise = self._whitened(problem, result, backend)
            else:
                how = ("by output error with unmeasured states" if problem.hidden
                       else "by equation error")
                warnings.warn(f"noise_model={self.noise_model!r} was not used: it models the "
                              f"output errors of a fit by output error without unmeasured "
                              f"states, and this fit is {how} (noise_model_ is None)",
                              UserWarning, stacklevel=2)
        facts = {**facts, "noise_model_": noise, "_fingerprint": fit_fingerprint(self, X, y)}
        if n_bootstrap:
            progress.stage(f"refitting on {n_bootstrap} resamples")
            facts = {**facts, **self._bootstrap(problem, result, n_bootstrap, backend)}
        self._store(problem, result, {**facts, "backend_": backend})
        progress.stage(f"fitted by {_MODE_WORDS[self.fit_mode_]}")
        given = self._filter_settings_given(self.fit_mode_)
        if self.fit_mode == "auto" and given and self.fit_mode_ != "filter":
            looked = facts["process_noise_evidence_"] is not None
            warnings.warn(
                f"{' and '.join(given)} {'was' if len(given) == 1 else 'were'} not used: "
                f"fit_mode='auto' fitted by {self.fit_mode_!r}, "
                + ("as the filter recognised no random push in the record"
                   if looked else "without looking for a random push (it looks after an "
                   "output-error fit of measured states a simulation follows)")
                + f"; fit_mode='filter' reads {'it' if len(given) == 1 else 'them'}",
                UserWarning, stacklevel=2)
        _warn_unmet_relations(problem, result)
        if self.fit_mode_ == "equation" and not facts["derivative_source_"].startswith(
                "measured"):
            _warn_coarse_sampling(problem, self._system())
        return self

    def _filter_settings_given(self, mode: str) -> list[str]:
        """The filter's settings this estimator was given that ``mode`` does not read.

        Output error reads ``initial_state`` (each experiment's start, held);
        the noises only the filter reads.
        """
        read = ("initial_state",) if mode == "simulation" else ()
        return [name for name in ("process_noise", "measurement_noise", "initial_state")
                if getattr(self, name, None) and name not in read]

    def _check_filter_settings(self, skeleton: Skeleton) -> None:
        """Check the filter's settings against the skeleton; warn where the mode ignores them."""
        if self.process_noise is not None:
            check_process_noise(self.process_noise, skeleton.states, [])
        check_measurement_noise(getattr(self, "measurement_noise", None), skeleton.states)
        check_initial_state(getattr(self, "initial_state", None), skeleton.states)
        given = self._filter_settings_given(self.fit_mode)
        if given and self.fit_mode in ("equation", "simulation"):
            also = (" (initial_state by output error too, fit_mode='simulation')"
                    if "initial_state" in given else "")
            warnings.warn(f"{' and '.join(given)} {'is' if len(given) == 1 else 'are'} read by "
                          f"the filter (fit_mode='filter', or 'auto' where it recognises a "
                          f"push){also}; fit_mode={self.fit_mode!r} does not use "
                          f"{'it' if len(given) == 1 else 'them'}", UserWarning, stacklevel=3)

    def _recognised(self, problem: Problem, result, facts: dict, backend: Backend):
        """``fit_mode="auto"``: the fit refined by the filter where the record shows process noise.

        Looked for after an output-error fit (``"auto"`` chose it: the
        derivatives were estimated from noisy states) of states a simulation
        can follow (:func:`process_noise_evidence`: the filter over a grid of
        noises); where it is recognised, ``derivative_source_`` says so.
        """
        # after an equation fit, a little bias of its parameters reads as a push: looked for
        # where the output error fitted them (a noisy record, where the filter pays)
        simulable = (problem.fit_mode == "simulation"
                     and problem.experiments is not None and not problem.hidden
                     and problem.measured
                     and not facts["derivative_source_"].startswith((MEASURED, STATIC))
                     and all(eq.explicit for eq in problem.skeleton.parsed)
                     and not problem.skeleton.algebraic
                     and all(s in problem.smoothed for s in problem.skeleton.states)
                     and all(e.n_samples > 2 * PROCESS_NOISE_LAGS
                             for e in problem.experiments))
        if not simulable:
            return result, facts
        system = problem.skeleton.compile(result.functions,
                                          {**problem.fixed_params, **result.params})
        with blas_threads(1), np.errstate(all="ignore"):
            try:
                evidence = process_noise_evidence(problem, system)
            except (ValueError, ArithmeticError, np.linalg.LinAlgError, SimulationError):
                return result, facts  # a look that fails says nothing: the fit stands
            facts = {**facts, "process_noise_evidence_": evidence}
            if not evidence.recognised:
                return result, facts
            refined = filter_stage(problem, backend.numbers(problem, result),
                                   verbose=getattr(self, "verbose", 0))
        source = (f"{facts['derivative_source_']}; {evidence.describe()} (fit_mode='auto'): "
                  "refined by the extended Kalman filter's likelihood")
        return refined, {**facts, "fit_mode_": "filter", "derivative_source_": source}

    def _delay_searcher(self) -> CCRegressor:
        """The estimator whose many fits compare the delays of inputs read late.

        This one; where its fits are slow, one of polynomial curves on the same
        settings (:func:`~sklearn_pycc.estimators.poly.polynomial_stand_in`).
        """
        return self

    def _fit_delays(self, X, y, skeleton: Skeleton, backend: Backend) -> dict[str, float]:
        """The delays of the inputs read late, by a profile of equation-error fits."""
        frame = X.X if isinstance(X, Measurement) else X
        if not isinstance(frame, pd.DataFrame) or TIME not in frame.columns:
            raise ValueError(
                f"{type(self).__name__}: the skeleton reads "
                f"{', '.join(skeleton.delays)}, an input read late, and its delay is fitted "
                "from the time column 't': pass X as a DataFrame with a 't' column")

        searcher = self._delay_searcher()
        if searcher is not self:
            backend = searcher._make_backend()

        def error_at(values: Mapping[str, float], profile: bool = True) -> float:
            problem, _ = searcher._problem(X, y, backend, delays=values, profile=profile)
            problem.check_enough_rows()
            result = backend.estimate(problem, shooting_window=self.shooting_window,
                                      shooting_iterations=self.shooting_iterations)
            return fit_error(problem, result)

        t = time_values(frame[TIME])  # a logger's datetimes in seconds, as the fit reads them
        found = fit_delays(skeleton, t, error_at)
        # where the fit ends by output error, the delay is settled by it (a held input's
        # steps are not smeared by a simulation as by estimated derivatives)
        final, _ = searcher._problem(X, y, backend, delays=found)
        if final.fit_mode != "simulation":
            return found
        return refine_delays(skeleton, t, found, lambda values: error_at(values, profile=False))

    def _whitened(self, problem: Problem, result: FitResult,
                  backend: Backend) -> tuple[FitResult, object]:
        """The output-error fit again with its errors whitened by their noise model.

        The noise model is read from ``result``'s whole-record errors; where
        it is white (``"auto"`` may say so) ``result`` stands. The model
        returned is read again from the whitened fit's errors. A parametric
        skeleton is then polished on the whole record's whitened errors,
        which give its ``covariance_``.
        """
        from ..fitting.output_error.noise_model import output_errors, whitened_polish

        noise = fit_noise_model(output_errors(problem, result), self.noise_model)
        if not noise.white:
            taps = {state: model.taps() for state, model in noise.signals.items()}
            result = backend.estimate(replace(problem, whitening=taps),
                                      shooting_window=self.shooting_window,
                                      shooting_iterations=self.shooting_iterations)
            noise = fit_noise_model(output_errors(problem, result), self.noise_model)
        # a parametric skeleton: polished on the whole record's whitened errors, with
        # the covariance they give
        polished = whitened_polish(problem, result, noise)
        if polished is not None:
            params, first, covariance = polished
            shooting = {**result.attributes.get("shooting_", {}), "initial_states": first}
            result = replace(result, params=params, attributes={
                **result.attributes, "shooting_": shooting, "covariance_": covariance})
            noise = fit_noise_model(output_errors(problem, result), self.noise_model)
        return result, noise

    def _bootstrap(self, problem: Problem, result: FitResult, n: int,
                   backend: Backend) -> dict:
        """Refits on ``n`` resamples that respect time: the ``bootstrap_`` attributes."""
        from ..fitting.uncertainty.resampling import Resampler, fit_members

        seed = next(seeds(getattr(self, "random_state", None)))
        verbose = bool(getattr(self, "verbose", 0))  # a progress bar over the refits
        if problem.hidden:  # a block cannot fix its own hidden states: the noise is redrawn
            from ..fitting.uncertainty.hidden_bootstrap import hidden_members

            if result.attributes["shooting_"].get("unseen"):
                warnings.warn("no refits on resamples: the measurements leave a direction of "
                              "the parameters unseen, so the estimate is one of many and no "
                              "spread describes it (params_std_ is NaN)", UserWarning,
                              stacklevel=4)
                return {}
            members, failures, method = hidden_members(
                problem, dict(result.params), dict(result.functions), result.attributes, n,
                seed=seed, n_jobs=getattr(self, "n_jobs", None),
                iterations=self.shooting_iterations, verbose=verbose)
            return self._bootstrap_facts(result, members, failures, n, method)
        residuals = np.nan_to_num(problem.residual_values(result.params, result.functions))
        simulation = problem.fit_mode == "simulation"
        resampler = Resampler(problem, residuals,
                              min_block=2 * self.shooting_window if simulation else 2)
        members, failures = fit_members(backend, problem, resampler, n, seed,
                                        n_jobs=getattr(self, "n_jobs", None),
                                        window=self.shooting_window,
                                        iterations=self.shooting_iterations, verbose=verbose)
        return self._bootstrap_facts(result, members, failures, n, resampler.describe())

    @staticmethod
    def _bootstrap_facts(result: FitResult, members: list, failures: list[str], n: int,
                         method: str) -> dict:
        """The ``bootstrap_`` attributes from the refits, or why there are none."""
        if len(members) < 2:
            raise ValueError(f"{len(failures)} of {n} refits on resamples failed, so the "
                             f"fit has no bootstrap estimate; the first said: {failures[0]}")
        if failures:
            warnings.warn(f"{len(failures)} of {n} refits on resamples failed and are left out "
                          f"of the bootstrap estimate; the first said: {failures[0]}",
                          UserWarning, stacklevel=5)
        free = list(result.params)
        table = pd.DataFrame([[m.params[a] for a in free] for m in members], columns=free)
        return {"bootstrap_": members, "bootstrap_params_": table, "bootstrap_method_": method}

    def _store(self, problem: Problem, result: FitResult, facts: Mapping) -> None:
        """Store a backend's result: the only way a fit becomes fitted state."""
        skeleton = problem.skeleton
        all_params = {**problem.fixed_params,
                      **{k: float(v) for k, v in result.params.items()}}
        params = {a: float(all_params[a]) for a in skeleton.params}
        params.update(facts.get("delays_") or {})
        functions = {f: result.functions[f] for f in skeleton.functions}
        attributes = dict(result.attributes)
        # a scale of an unmeasured state the fit pinned (curves through it): the gauge's too
        gauge = {**problem.gauge, **attributes.pop("written_gauge_", {})}
        self._set_fitted({
            **facts, **attributes, "skeleton_": skeleton, "gauge_": gauge,
            "params_": params, "functions_": functions,
            "curve_ranges_": _argument_ranges(problem, params, functions)})
        self._set_fitted({"n_parameters_": len(problem.free_params)
                          + len(facts.get("delays_") or {}) + sum(
            facts["backend_"].n_numbers(problem, result, f) for f in problem.free_functions)})

    def _set_fitted(self, values: Mapping) -> None:
        """The one writer of fitted state; the model is compiled when its numbers change.

        Fitted attributes end in ``_``; a backend adds those it derives from
        the curves by :meth:`Backend.attributes_of`.
        """
        values = dict(values)
        if "functions_" in values and "backend_" not in values \
                and not hasattr(self, "backend_"):
            values["backend_"] = self._make_backend()
        if "functions_" in values:  # every stored curve speaks the Curve protocol
            values["functions_"] = {name: as_curve(curve)
                                    for name, curve in values["functions_"].items()}
        for name, value in values.items():
            setattr(self, name, value)
        if "params_" in values or "functions_" in values:
            skeleton = self.skeleton_
            solvable = all(eq.solvable for eq in skeleton.parsed)
            self._compiled = (skeleton.compile(self.functions_, self.params_) if solvable
                              else None)
            variables = {name: self._variable(name) for name in self.functions_}
            for name, value in self.backend_.attributes_of(self.functions_, variables).items():
                setattr(self, name, value)

    def _adopt(self, source: CCRegressor, functions: Mapping, params: Mapping,
               n_parameters: int, attributes: Mapping | None = None) -> None:
        """Become fitted with ``functions`` and ``params`` on ``source``'s data.

        The one documented hook by which a conversion or a meta-estimator
        makes an estimator fitted from another fitted one: the skeleton,
        gauge, curve ranges and what was learned about ``X`` are
        ``source``'s; ``attributes`` are the target's own fitted attributes.
        """
        adopted = ("skeleton_", "gauge_", "curve_ranges_", "n_features_in_",
                   "feature_names_in_", "measured_states_", "derivative_source_", "fit_mode_",
                   "initial_states_", "_y_1d", "delays_")
        skeleton = source.skeleton_
        values = {name: copy.deepcopy(getattr(source, name)) for name in adopted
                  if hasattr(source, name)}
        delays = dict(getattr(source, "delays_", None) or {})
        self._set_fitted({**values, **dict(attributes or {}), "backend_": self._make_backend(),
                          "params_": {**{a: float(params[a]) for a in skeleton.params},
                                      **delays},
                          "functions_": {f: functions[f] for f in skeleton.functions},
                          "n_parameters_": int(n_parameters)})

    # -- using a fitted model --------------------------------------------------
    def _system(self) -> CompiledSystem:
        check_is_fitted(self, "functions_")
        compiled = getattr(self, "_compiled", None)
        if compiled is None:
            compiled = self.skeleton_.compile(self.functions_, self.params_)
            self._compiled = compiled
        return compiled

    def predict(self, X) -> np.ndarray:
        """Derivatives (and static outputs) predicted by the fitted model.

        Parameters
        ----------
        X : DataFrame of shape (n_samples, n_columns)
            States and inputs by name.

        Returns
        -------
        ndarray of shape (n_samples, n_targets)
            One column per differential equation, in the order of
            ``equations``, then one per static equation ``NAME = rhs``
            (its ``NAME``): the skeleton's ``targets``. 1-D when ``y`` was
            1-D in ``fit``.
        """
        system = self._system()
        table = getattr(self, "initial_states_", None)
        unmeasured = [] if table is None else list(table.columns)
        if unmeasured and isinstance(X, pd.DataFrame):
            missing = [s for s in unmeasured if s not in X.columns]
            if missing:
                raise ValueError(
                    f"X has no column {missing[0]!r}: the model was fitted with "
                    f"{', '.join(unmeasured)} unmeasured, and predict reads every state from X. "
                    "Simulate the model instead, from the full initial state "
                    "estimate_initial_state(X) gives")
        if isinstance(X, pd.DataFrame):
            chains = kinematic_chains(self.skeleton_)
            missing = [s for s in self.skeleton_.states if s not in X.columns and s in chains]
            if missing:
                root, order = chains[missing[0]]
                raise ValueError(
                    f"X has no column {missing[0]!r}, derivative {order} of {root!r} by the "
                    "skeleton's kinematic equations: fit reconstructs it from the record, "
                    "predict reads every state from X. Give it as a column, compare the "
                    "derivatives with diagnose(model, X) (which reconstructs it), or simulate "
                    "the model from estimate_initial_state(X)")
        data = read_X(self, X, self.skeleton_.variables, reset=False)
        with np.errstate(all="ignore"):
            pred = np.hstack([system.evaluate(data.columns, data.n_samples),
                              system.evaluate_outputs(data.columns, data.n_samples)])
        if not np.isfinite(pred).all():
            self._warn_not_finite(data.columns, pred)
        if self._y_1d:
            return pred[:, 0]
        return pred

    def score(self, X, y=None, sample_weight=None) -> float:
        """Coefficient of determination R² of the predictions.

        ``y`` holds what :meth:`predict` returns: the derivatives, then the
        outputs of static equations; a DataFrame is matched by name. For a
        :class:`~sklearn_pycc.measurements.Measurement` ``X``, its own ``y``.
        """
        check_is_fitted(self, "functions_")
        held = isinstance(X, Measurement)
        X, y, _ = unwrap(X, y, who="score")
        if y is None:
            raise ValueError(
                ("score needs y, and the Measurement holds none (Measurement(X, y) gives it): "
                 if held else "score needs y, ") + "the measured targets "
                f"{list(self.skeleton_.targets)}; on a record without them (position only), "
                "score the simulation instead: "
                "sklearn_pycc.model_selection.make_simulation_scorer()")
        pred = np.asarray(self.predict(X))
        pred = pred[:, None] if pred.ndim == 1 else pred
        targets = self.skeleton_.targets
        held = targets_in_y(y, self.skeleton_)
        if held != targets and isinstance(X, pd.DataFrame) \
                and all(t in X.columns for t in targets if t not in held):
            # static outputs y does not hold are read from X, as fit reads them
            given = read_y(y, held, pred.shape[0])
            rest = [t for t in targets if t not in held]
            found = read_y(X[rest], rest, pred.shape[0])
            by_name = {**dict(zip(held, given.T)), **dict(zip(rest, found.T))}
            truth = np.column_stack([by_name[t] for t in targets])
        else:
            truth = read_y(y, targets, pred.shape[0])
        bad = ~np.isfinite(pred)
        if bad.any():
            raise ValueError(
                f"score: the predictions are NaN or infinite at "
                f"{int(bad.any(axis=1).sum())} of {pred.shape[0]} rows (see the DomainWarning "
                "predict gave), so R^2 has no value")
        # R^2 is the same for each column scaled by its largest value; the sums of
        # squares of data near 1e300 overflow unscaled
        scale = np.max(np.abs(truth), axis=0)
        scale = np.where(np.isfinite(scale) & (scale > 0), scale, 1.0)
        return float(r2_score(truth / scale, pred / scale, sample_weight=sample_weight))

    def _warn_not_finite(self, columns: Mapping, pred: np.ndarray) -> None:
        """Warn that predictions are NaN or infinite, naming the equation and the term."""
        slots = {name: i for i, name in enumerate(columns)}
        env = [np.asarray(columns[name], dtype=float) for name in columns]
        found = []
        predicted = [*self.skeleton_.parsed,
                     *(eq for eq in self.skeleton_.algebraic if eq.output is not None)]
        for j, eq in enumerate(predicted):
            bad = ~np.isfinite(pred[:, j])
            if not bad.any():
                continue
            row = int(np.flatnonzero(bad)[0])
            culprit = to_text(eq.expression)
            for term in sum_terms(eq.expression):
                try:
                    with np.errstate(all="ignore"):
                        values = compile_expression(term, slots, self.params_,
                                                    self.functions_)(env)
                except KeyError:  # a derivative of an implicit equation: not a column
                    continue
                values = np.broadcast_to(np.asarray(values, dtype=float), bad.shape)
                if not np.isfinite(values[row]):
                    culprit = to_text(term)
                    break
            at = ", ".join(f"{name}={columns[name][row]:.4g}" for name in columns
                           if name in eq.symbols())
            found.append(f"equations[{eq.index}] ({eq.derivative or eq.output}) at "
                         f"{int(bad.sum())} of "
                         f"{bad.size} rows, first at row {row} ({at}): the term '{culprit}' "
                         "is not finite there")
        warnings.warn(
            "predict returns NaN or infinite values: " + "; ".join(found) + ". The inputs "
            "leave a function's domain (sqrt, log, arcsin, ...) or overflow.",
            DomainWarning, stacklevel=3)

    @property
    def n_states_(self) -> int:
        """Number of states (differential equations)."""
        return len(self.skeleton_.states)


def _across_gaps(X, y, skeleton: Skeleton):
    """``(X, y, missing)``: ``X`` read across its measured states' missing samples.

    Each state column with some (not all) samples missing gets straight
    lines across its gaps (:func:`~sklearn_pycc.measurements.gaps.filled_across_gaps`);
    ``missing`` says where they were. A record without such gaps comes back
    as it was.
    """
    frame, inner_y, _ = unwrap(X, y)
    missing = missing_samples(frame, skeleton.states)
    if not missing:
        return X, y, {}  # as given: a Measurement keeps its derivatives
    return filled_across_gaps(frame, missing), inner_y, missing


def _split_at_gaps(X, y, skeleton: Skeleton, mode: str):
    """``(X, y, given)``: ``X`` split into experiments at its measured states' missing samples.

    Every fit mode but the filter splits an experiment where a measured
    state misses a sample (:func:`~sklearn_pycc.measurements.gaps.split_at_gaps`)
    and says so; ``given`` is the frame as given where the split added a
    ``trajectory`` column to it (else None). A record without gaps comes
    back as it was.
    """
    frame, inner_y, _ = unwrap(X, y)
    missing = missing_samples(frame, skeleton.states)
    if not missing:
        return X, y, None
    split = split_at_gaps(frame, inner_y, missing)
    if not split.pieces:
        raise ValueError(f"X's column {next(iter(missing))!r} leaves no two neighbouring "
                         "samples between its missing ones: nothing to fit")
    alone = (f", leaving out {split.alone} sample(s) with no neighbour between gaps"
             if split.alone else "")
    lengths = split.X[TRAJECTORY].value_counts().to_numpy()
    short = (f"; each stretch's derivatives are estimated on its own, noisy on short ones "
             f"(median {int(np.median(lengths))} samples here: see params_std_), where "
             "fit_mode='simulation' reads the stretches by simulating them"
             if mode == "equation" and len(lengths) else "")
    warnings.warn(f"{', '.join(missing)} miss{'es' if len(missing) == 1 else ''} "
                  f"{split.missing} sample(s) (NaN): fit_mode={mode!r} splits the record there "
                  f"into {split.pieces} experiments{alone}{short}; fit_mode='filter' reads "
                  "across missing samples", UserWarning, stacklevel=4)
    return split.X, split.y, None if TRAJECTORY in frame.columns else frame


def _measured_limits(skeleton, record) -> dict[str, float]:
    """Each limit to fit on a measured state, at the state's extreme in the record.

    A measured state shows where it stops; the equations cannot (at its
    limit a state's rate is held, not what they compute). The extreme of
    the smoothed state is read (the raw samples' overshoots it by the
    noise). With unmeasured states every limit is fitted by output error,
    a measured state's from there (:func:`~sklearn_pycc.fitting.output_error.hidden.limit_start`).
    """
    out = {}
    for name, (state, side) in skeleton.limit_params.items():
        if state in record.measured:
            values = np.asarray(record.smoothed.get(state, record.measured[state]), dtype=float)
            out[name] = float(values.max() if side == "high" else values.min())
    return out


#: a measured state crosses its limit where it lies beyond it by more than this many times
#: its noise (a level at its rim reads above it by the noise) ...
CROSSING_NOISE = 5.0
#: ... and by more than this share of its range (a smoothed level rounds its rim's corner)
CROSSING_SHARE = 0.02


def _warn_crossed_limits(skeleton: Skeleton, record) -> None:
    """Warn where a measured state lies beyond a known limit, naming it, how far and how often.

    The model holds the state within the limit, so it cannot follow the
    record there: the limit is likely wrong.
    """
    for state, (low, high) in skeleton.limits.items():
        if state not in record.measured:
            continue
        values = np.asarray(record.measured[state], dtype=float)
        smoothed = np.asarray(record.smoothed.get(state, values), dtype=float)
        residual = values - smoothed
        noise = 1.4826 * float(np.nanmedian(np.abs(residual - np.nanmedian(residual))))
        slack = max(CROSSING_NOISE * noise, CROSSING_SHARE * float(np.nanmax(smoothed)
                                                                   - np.nanmin(smoothed)))
        for end, sign in ((low, -1.0), (high, 1.0)):
            if isinstance(end, str) or not np.isfinite(end):
                continue  # an end to fit is read from the record
            beyond = sign * (values - end)
            crossing = np.flatnonzero(beyond > slack)
            if crossing.size:
                limit = f"{state} {'<=' if sign > 0 else '>='} {end:.6g}"
                warnings.warn(
                    f"the measured {state} crosses its limit {limit} at {crossing.size} of "
                    f"{np.isfinite(values).sum()} samples, by up to {np.nanmax(beyond):.4g} "
                    f"(its noise is about {noise:.3g}): the model holds {state} within the "
                    "limit and cannot follow the record there; check the limit, or leave it "
                    "out", UserWarning, stacklevel=4)


def _check_hidden(skeleton: Skeleton, hidden, backend: Backend) -> None:
    """Refuse unmeasured states where they cannot be fitted, saying why."""
    _check_simulable(skeleton, outputs_ok=True)
    check_visible(skeleton, hidden)
    if skeleton.functions and not backend.hidden_curves:
        raise ValueError(
            f"X has no column {hidden[0]!r}, which the skeleton uses (or only missing values "
            f"in it), and no kinematic equation reconstructs it: an unmeasured state is "
            f"fitted by output error, and {type(backend).__name__} does not fit curves "
            f"({', '.join(skeleton.functions)}) that way: use PolyCCRegressor, write them as "
            "parametric terms (a1 x1 + a2 x1^3, a1 tanh(a2 x2), ...), or measure every state")


def _check_simulable(skeleton: Skeleton, *, outputs_ok: bool = False) -> None:
    """Refuse ``fit_mode="simulation"`` for a skeleton with equations it cannot simulate.

    With ``outputs_ok`` a static equation (``y = ...``, what a sensor reads)
    passes: a fit with unmeasured states compares its simulated output.
    """
    if not skeleton.states:
        raise ValueError("fit_mode='simulation' fits simulated states, and the skeleton has "
                         "no differential equation")
    left_out = [eq for eq in skeleton.algebraic if not (outputs_ok and eq.output is not None)]
    if left_out:
        eq = left_out[0]
        raise ValueError(
            f"fit_mode='simulation' fits simulated states, which equations[{eq.index}] "
            f"({eq.text!r}), without a derivative of its own, takes no part in: fit it by "
            "equation error (fit_mode='equation')")


def check_equation_weights(weights, skeleton: Skeleton,
                           name: str = "equation_weights") -> tuple | None:
    """Weights of the skeleton's equations, one each, finite, non-negative, not all zero.

    ``name`` is what the user called them (``eq_weights`` in the published
    package's ``params``): every error names it.
    """
    if weights is None:
        return None
    wrong = f"{name} must be numbers, one per equation in their order, got {weights!r}"
    if isinstance(weights, (str, bytes, Mapping)):
        raise ValueError(wrong)
    try:
        values = np.asarray(weights, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(wrong) from None
    n = len(skeleton.equations)
    if values.ndim != 1 or len(values) != n:
        raise ValueError(f"{name} holds {values.size} value(s) but the skeleton has "
                         f"{n} equation(s): give one weight per equation, in their order")
    bad = np.flatnonzero(~np.isfinite(values) | (values < 0))
    if bad.size:
        k = int(bad[0])
        raise ValueError(f"{name}[{k}] = {float(values[k])!r} (for equations[{k}], "
                         f"{skeleton.equations[k]!r}) must be a finite, non-negative number")
    if not values.any():
        raise ValueError(f"{name} are all zero: nothing would be fitted")
    return tuple(float(v) for v in values)


def _argument_ranges(problem: Problem, params: Mapping,
                     functions: Mapping) -> dict[str, tuple[float, float]]:
    """Range of every curve's argument over the fitted data.

    A curve of an unmeasured state ran over the range its fit wrote it out
    on (its ``domain``).
    """
    ranges = {}
    for f in problem.skeleton.functions:
        values = problem.argument_values(f, params, functions)
        if values.size:
            ranges[f] = (float(values.min()), float(values.max()))
        else:
            domain = getattr(functions.get(f), "domain", None) if problem.hidden else None
            ranges[f] = (0.0, 0.0) if domain is None else tuple(float(v) for v in domain)
    return ranges


#: an algebraic relation whose fitted residual keeps this share of the spread of its
#: measured part does not hold on the data
UNMET_RELATION = 0.5


#: a fitted model whose fast decays (90th percentile along the record) go this far within
#: one sampling interval (``h |Re lambda|``) was fitted to derivatives the samples cannot give
COARSE_SAMPLING = 0.2


def _warn_still_record(problem: Problem) -> None:
    """Warn where no measured state moves: the record holds no dynamics to fit.

    A state stuck at one value (a sensor unplugged, a plant at rest) fixes
    at most the balance at that point; every other number is whatever the
    search starts from or drifts to.
    """
    # in the signal's own units: a state read in tiny units still moves
    still = {s: float(np.nanmean(v)) for s, v in problem.measured.items()
             if np.nanmax(v) - np.nanmin(v) <= 1e-12 * float(np.nanmax(np.abs(v)))}
    if still and len(still) == len(problem.measured):
        values = ", ".join(f"{s} at {v:.6g}" for s, v in still.items())
        warnings.warn(f"no measured state moves in X ({values} throughout): the record holds "
                      "no dynamics, and the fitted numbers are not determined by it; give a "
                      "record in which the system moves", UserWarning, stacklevel=3)


def _warn_coarse_sampling(problem: Problem, system) -> None:
    """Warn when the record is sampled coarsely against the fitted model's time constants.

    Derivatives estimated from the states are differences over a few
    samples: where the model's fastest time constant spans fewer than five
    sampling intervals (a process logged every few seconds), they are not
    to be trusted, and neither is an equation fit to them.
    """
    from ..simulation.windows import jacobian_eigenvalues

    if not problem.experiments or not problem.skeleton.states:
        return  # nothing sampled in time, or nothing that moves
    steps = np.concatenate([np.diff(e.t) for e in problem.experiments
                            if e.t is not None and e.n_samples > 1]
                           or [np.zeros(0)])
    columns = problem.data.columns
    states = list(problem.skeleton.states)
    if steps.size == 0 or any(s not in columns for s in states):
        return
    h = float(np.median(steps))
    scale = np.array([float(np.std(columns[s])) or 1.0 for s in states])
    data = {name: np.asarray(values, dtype=float) for name, values in columns.items()}
    try:
        # decays: an oscillation is followed by the band-limited differentiator up to
        # near the Nyquist frequency; a transient's corners are not
        rates = np.abs(jacobian_eigenvalues(system, data, states, scale).real).max(axis=1)
    except (ValueError, ArithmeticError, np.linalg.LinAlgError):
        return
    rates = rates[np.isfinite(rates)]
    if rates.size == 0:
        return
    fastest = float(np.quantile(rates, 0.9))
    if h * fastest > COARSE_SAMPLING:
        warnings.warn(
            f"the record is sampled every {h:.3g} time units, and the fitted model's fastest "
            f"time constant is about {1 / fastest:.3g}: fewer than {1 / COARSE_SAMPLING:.0f} "
            "samples per time constant, where derivatives estimated from the states are not "
            "to be trusted, nor an equation fit to them. Fit by output error "
            "(fit_mode='simulation'), which compares simulated states with the record",
            UserWarning, stacklevel=3)


def _warn_unmet_relations(problem: Problem, result: FitResult) -> None:
    """Warn when a relation ``0 = ...`` the data were to satisfy is far from holding.

    A differential or static equation is judged by its score; a relation
    among measured quantities (``0 = x1 - a1``) is fitted like the others
    and would otherwise never be judged at all.
    """
    relations = [(j, problem.equations[i]) for j, i in enumerate(problem.active)
                 if problem.equations[i].derivative is None
                 and problem.equations[i].output is None]
    if not relations:
        return
    residuals = problem.residual_values(result.params, result.functions)
    for j, eq in relations:
        value = residuals[:, j]
        size = float(np.std(value)) if np.isfinite(value).all() else np.inf
        # how much the measured part of the relation varies: what the fit must explain
        measured = measured_part(problem, eq)
        spread = float(np.std(measured)) if np.isfinite(measured).all() else 0.0
        if not spread > 0:
            continue  # nothing measured varies: nothing to judge the relation by
        share = size / spread
        if not share <= UNMET_RELATION:
            warnings.warn(f"equations[{eq.index}] ({eq.text!r}) does not hold on the data: "
                          f"after the fit its residual keeps {100 * share:.0f} % of the spread of "
                          "its measured part; the relation, or the data, is wrong", UserWarning,
                          stacklevel=3)


# -- what conversions and meta-estimators may do with an estimator ----------------------
def backend_of(estimator: CCRegressor) -> Backend:
    """The backend ``estimator``'s hyperparameters describe (they are checked first)."""
    estimator._validate_params()
    return estimator._make_backend()


def make_problem(estimator: CCRegressor, X, y=None) -> Problem:
    """The fitting problem ``estimator.fit(X, y)`` would hand its backend."""
    estimator._validate_params()
    problem, _ = estimator._problem(X, y)
    return problem


def adopt(target: CCRegressor, source: CCRegressor, functions: Mapping, params: Mapping,
          n_parameters: int, *, attributes: Mapping | None = None) -> CCRegressor:
    """Make ``target`` fitted with ``functions`` and ``params`` on ``source``'s data.

    The way a conversion or a meta-estimator makes an estimator fitted from
    another fitted one: the skeleton, gauge, curve ranges and what was
    learned about ``X`` are ``source``'s; ``attributes`` are the target's
    own fitted attributes. Returns ``target``.
    """
    target._adopt(source, functions, params, n_parameters, attributes)
    return target


def set_fitted(model: CCRegressor, values: Mapping) -> CCRegressor:
    """Write fitted attributes of ``model`` through its one writer; returns ``model``.

    For models made without data (:func:`~sklearn_pycc.from_tables`) and
    for replacing curves of a fitted model: the model is compiled again.
    """
    model._set_fitted(values)
    return model
