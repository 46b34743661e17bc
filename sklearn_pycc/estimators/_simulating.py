"""Simulating a fitted model, and the initial state a record implies: :class:`SimulationMixin`."""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from numbers import Integral

import numpy as np
import pandas as pd
from scipy.optimize import least_squares
from sklearn.utils.validation import check_is_fitted

from ..exceptions import ExtrapolationWarning, SimulationError
from ..fitting.uncertainty.intervals import N_DRAWS, check_level
from ..measurements.measurement import Measurement
from ..simulation.integration import requested_hold
from ..skeleton.compiler import compile_expression
from ..skeleton.printer import to_text
from ..skeleton.skeleton import simulate_system

__all__ = ["SimulationMixin"]

#: estimate_initial_state runs least squares from this many of its guesses, those whose
#: simulation follows the record best as they stand
INITIAL_STATE_STARTS = 2

#: an unmeasured state fitted to fewer rows than this comes with a warning: a second row
#: alone leaves one residual per measured state, which any of many starts can follow
FEW_ROWS = 5


class SimulationMixin:
    """What a fitted :class:`~sklearn_pycc.estimators.base.CCRegressor` simulates.

    :meth:`simulate` integrates the compiled model (with a band from the
    fit's uncertainty on request) and :meth:`estimate_initial_state` reads
    or fits the state a record starts from. The host class gives
    ``_system()`` (the compiled right-hand side), ``_arguments(name)`` and
    ``_simulation_band``.
    """

    def estimate_initial_state(self, X, *, n_samples: int = 200,
                               input_hold: str = "auto") -> dict[str, float]:
        """The full state at the first time of a record: measured states read, others fitted.

        A state that ``X`` holds is read at its first row; a state it does
        not hold (unmeasured, such as a tank's level no sensor reads) is
        chosen so that the model, simulated over the first ``n_samples`` rows
        with ``X``'s inputs, follows the measured states best (least
        squares, from the two best of several guesses: rest with the first
        sample, the training experiments' fitted initial states, the state's
        limits). The result is ready for :meth:`simulate`'s ``y0``.

        Parameters
        ----------
        X : DataFrame
            A record with ``t``, the model's inputs and some of its states.
        n_samples : int, default=200
            Rows simulated to fit the unmeasured states (all of them when
            ``X`` has fewer).
        input_hold : {"auto", "bandlimited", "foh", "zoh"}, default="auto"
            How the inputs are read between samples, as in :meth:`simulate`;
            ``"auto"`` is the hold the model was fitted with (``input_hold_``).

        Returns
        -------
        dict
            State -> value at ``X``'s first time, within the states' limits
            (a reading beyond one, noise at a rim, is taken at the limit).

        Raises
        ------
        ValueError
            If ``X`` has no time column, lacks an input, holds no state, or
            its times run backwards; and, where a state must be fitted, if
            ``X`` has a single row or a NaN time or input in the stretch.

        Warns
        -----
        UserWarning
            When the model cannot be simulated over the stretch from any
            guess (the estimate is then unchecked), and when a state is
            fitted to fewer than :data:`FEW_ROWS` rows.
        """
        from ..fitting.output_error.whole_record import (
            check_initial_stretch,
            equilibrium,
            sensor_readings,
        )

        check_is_fitted(self, "functions_")
        skeleton = self.skeleton_
        input_hold = requested_hold(self, input_hold)
        if isinstance(X, Measurement):
            X = X.X
        if not isinstance(X, pd.DataFrame) or "t" not in X.columns:
            raise ValueError("estimate_initial_state reads a DataFrame with a time column 't'")
        if isinstance(n_samples, bool) or not isinstance(n_samples, Integral) or n_samples < 2:
            raise ValueError(f"n_samples must be an integer of at least 2, got {n_samples!r}")
        inputs = [name for name in skeleton.inputs if name != "t"]
        missing = [name for name in inputs if name not in X.columns]
        if missing:
            raise ValueError(f"X has no column {missing[0]!r}, an input of the model")
        stretch = X.iloc[:min(len(X), int(n_samples))]
        t = stretch["t"].to_numpy(dtype=float)
        read = [s for s in skeleton.states
                if s in X.columns and np.isfinite(X[s].to_numpy(dtype=float)[0])]
        sensed = [o for o in skeleton.outputs if o in X.columns]
        if not read and not sensed:
            raise ValueError(f"X holds none of the states {skeleton.states}"
                             + (f" nor the outputs {skeleton.outputs}" if skeleton.outputs
                                else "") + ": there is nothing to fit an initial state to")
        limits = skeleton.limits_at(self.params_)
        # a level read beyond its limit (noise at a rim) starts at the limit
        state = {s: float(np.clip(X[s].iloc[0], *limits.get(s, (-np.inf, np.inf))))
                 for s in read}
        unknown = [s for s in skeleton.states if s not in read]
        drive = {name: stretch[name].to_numpy(dtype=float) for name in inputs}
        check_initial_stretch(t, drive, unknown)
        if not unknown:
            return state
        system = self._system()
        point = {**state, **{name: values[0] for name, values in drive.items()}, "t": t[0]}
        start = np.array([equilibrium(system, unknown, point)[s] for s in unknown])
        targets = stretch[read + sensed].to_numpy(dtype=float)
        scale = np.sqrt(np.nanmean(targets ** 2, axis=0))
        scale[~(scale > 0)] = 1.0

        def compared(frame: pd.DataFrame) -> np.ndarray:
            if not sensed:
                return frame[read].to_numpy(dtype=float)
            data = {s: frame[s].to_numpy(dtype=float) for s in skeleton.states}
            readings = sensor_readings(system, {**data, **drive, "t": t}, sensed)
            return np.column_stack([frame[read].to_numpy(dtype=float), readings])

        def residuals(z: np.ndarray) -> np.ndarray:
            y0 = [state[s] if s in state else z[unknown.index(s)] for s in skeleton.states]
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    frame = simulate_system(system, t, y0, drive, input_hold=input_hold)
                simulated = compared(frame)
            except (SimulationError, ValueError, ArithmeticError):
                return np.full(targets.size, 1e3)
            error = (simulated - targets) / scale
            return np.where(np.isfinite(error), error, 1e3).ravel()

        # every guess simulated once, within the states' limits; least squares from the best
        low = np.array([limits.get(s, (-np.inf, np.inf))[0] for s in unknown])
        high = np.array([limits.get(s, (-np.inf, np.inf))[1] for s in unknown])
        high = np.where(high > low, high, np.nextafter(low, np.inf))
        guesses = sorted(((0.5 * float(np.sum(residuals(g) ** 2)), k, g) for k, g in enumerate(
            np.clip(g, low, high) for g in self._initial_guesses(start, unknown))),
                         key=lambda item: item[:2])
        best_cost, _, best = guesses[0]
        for _, _, guess in guesses[:INITIAL_STATE_STARTS]:
            solution = least_squares(residuals, guess, x_scale="jac", bounds=(low, high),
                                     max_nfev=50 * (len(start) + 1), ftol=1e-6, xtol=1e-6)
            if solution.cost < best_cost:
                best, best_cost = solution.x, solution.cost
        z = np.clip(best, low, high)
        if len(t) < FEW_ROWS:
            warnings.warn(f"{', '.join(unknown)} fitted to {len(t)} rows of X: the model "
                          "follows so short a stretch from many initial states, and the "
                          f"estimate ({', '.join(f'{s}={v:.6g}' for s, v in zip(unknown, z))}) "
                          f"may be far off; give {FEW_ROWS} rows or more", UserWarning,
                          stacklevel=2)
        if np.all(residuals(z) == 1e3):
            warnings.warn(f"the model cannot be simulated over X's first {len(t)} rows from "
                          f"any guess of {', '.join(unknown)}: the estimate "
                          f"({', '.join(f'{s}={v:.6g}' for s, v in zip(unknown, z))}) is a "
                          "guess the record could not check", UserWarning, stacklevel=2)
        return {s: (state[s] if s in state else float(z[unknown.index(s)]))
                for s in skeleton.states}

    def _initial_guesses(self, start: np.ndarray, unknown: list[str]) -> list[np.ndarray]:
        """Where :meth:`estimate_initial_state` starts: rest, and what the fit saw.

        From the equilibrium with the first sample; from each training
        experiment's fitted initial state (``initial_states_``); and from
        each state's limits and their midpoint, where it has finite ones (a
        slow unmeasured state far from rest can make a short stretch's
        least squares settle elsewhere).
        """
        guesses = [np.asarray(start, dtype=float)]
        table = getattr(self, "initial_states_", None)
        if table is not None and all(s in table.columns for s in unknown):
            guesses.extend(table[unknown].to_numpy(dtype=float))
        limits = self.skeleton_.limits_at(self.params_)
        ends = []
        for s in unknown:
            low, high = limits.get(s, (-np.inf, np.inf))
            finite = [v for v in (low, high) if np.isfinite(v)]
            ends.append(finite + ([0.5 * (low + high)] if len(finite) == 2 else
                                  [0.5 * finite[0]] if finite else []))
        for k, values in enumerate(ends):
            for value in values:
                guess = guesses[0].copy()
                guess[k] = value
                guesses.append(guess)
        out = []
        for guess in guesses:
            if np.all(np.isfinite(guess)) and not any(np.array_equal(guess, g) for g in out):
                out.append(guess)
        return out

    def simulate(
        self,
        t,
        y0,
        inputs: Mapping | None = None,
        *,
        method: str | None = None,
        rtol: float = 1e-6,
        atol: float = 1e-8,
        return_derivatives: bool = False,
        input_hold: str = "auto",
        verbose: bool = False,
        level: float | None = None,
        n_draws: int = N_DRAWS,
        random_state=None,
        **solver_options,
    ) -> pd.DataFrame:
        """Simulate the fitted model.

        Parameters
        ----------
        t : array-like
            Strictly increasing output times.
        y0 : array-like or dict
            Initial state, in the order of the equations or by state name.
        inputs : dict, optional
            Input name -> callable of ``t``, array sampled on ``t``, or constant.
        method : str, optional
            How to integrate; as in :meth:`Skeleton.simulate
            <sklearn_pycc.Skeleton.simulate>` (the sampled-input integrator
            for array inputs, else LSODA).
        input_hold : {"auto", "bandlimited", "foh", "zoh"}, default="auto"
            How an array input is read between its samples; see
            :meth:`Skeleton.simulate <sklearn_pycc.Skeleton.simulate>`.
            ``"auto"`` is the hold the model was fitted with
            (``input_hold_``).
        verbose : bool, default=False
            Show a progress bar (tqdm) over the samples.
        rtol, atol : float
            Solver tolerances.
        return_derivatives : bool
            Add the inputs and the ``NAME_dot`` columns along the trajectory.
        level : float, optional
            Add ``NAME_lower`` and ``NAME_upper`` columns for each state and
            output: the band holding that share of ``n_draws`` simulations
            of models drawn from the fit's uncertainty (``covariance_``).
        n_draws : int, default=100
            Models simulated for the band.
        random_state : int, RandomState, Generator or None
            Seeds the draws of the band.
        **solver_options
            Passed to the SciPy solver, and ``max_steps``: the most solver
            steps before a :class:`SimulationError` (by default 500000; with
            array inputs 50 a sample, at most
            ``sklearn_pycc.simulation.STEP_BUDGET``, and a record of
            more samples than ``max_steps`` is refused before the first
            step, with how to simulate it in pieces).

        Returns
        -------
        pandas.DataFrame
            Columns ``t``, the states and the outputs of static equations
            (``F1`` of ``F1 = f1(x1)``) along the trajectory.

        Raises
        ------
        SimulationError
            When the model diverges, the solver fails or takes more than
            ``max_steps``; it carries the time reached and the partial
            trajectory.
        ValueError
            When the skeleton has no differential equation, ``y0`` starts
            a state beyond its hard limits, or ``input_hold`` is none of
            the holds above.

        Warns
        -----
        UserWarning
            Once per call, naming the equations without a derivative of
            their own and without an output (``0 = ...``, a conserved
            quantity): they were fitted, and are left out of the simulation.
        ExtrapolationWarning
            Once, when the trajectory takes a curve that declares an
            ``extrapolation`` policy more than 1 % of its training range
            beyond that range.
        """
        system = self._system()
        skeleton = self.skeleton_
        input_hold = requested_hold(self, input_hold)
        if not skeleton.states:
            raise ValueError(
                "the skeleton has no differential equation, so there is nothing to "
                f"simulate: its equations ({'; '.join(skeleton.equations)}) are static; "
                "use predict")
        loose = [eq for eq in skeleton.algebraic if eq.output is None]
        if loose:
            warnings.warn(
                "simulate integrates the differential equations only: "
                + "; ".join(f"equations[{eq.index}] ({eq.text!r})" for eq in loose)
                + (" has" if len(loose) == 1 else " have") + " no derivative of its own "
                "and, fitted with the others, takes no part in the simulation",
                UserWarning, stacklevel=2)
        if isinstance(y0, Mapping):
            states = skeleton.states
            unknown = [k for k in y0 if k not in states]
            if unknown:
                raise ValueError(f"y0 names {unknown[0]!r}, which is not a state of {states}")
            missing = [s for s in states if s not in y0]
            if missing:
                raise ValueError(f"y0 has no value for the state {missing[0]!r}")
            y0 = [y0[s] for s in states]
        watched = {name: curve for name, curve in self.functions_.items()
                   if curve.extrapolation}
        outputs = skeleton.outputs
        frame = simulate_system(system, t, y0, inputs, method=method, rtol=rtol, atol=atol,
                                return_derivatives=(return_derivatives or bool(watched)
                                                    or bool(outputs)),
                                input_hold=input_hold, verbose=verbose, **solver_options)
        if watched:
            self._warn_outside_domain(frame, watched)
        if outputs:
            columns = {name: frame[name].to_numpy() for name in frame.columns}
            values = system.evaluate_outputs(columns, len(frame))
            for j, name in enumerate(outputs):
                frame[name] = values[:, j]
        if not return_derivatives:
            frame = frame[["t", *skeleton.states, *outputs]]
        if level is None:
            return frame
        level = check_level(level)

        def simulate_draw(functions, params):
            system = skeleton.compile(functions, params)
            start = system.clip(np.array(y0, dtype=float))  # at a fitted limit: the drawn one
            drawn = simulate_system(system, t, start, inputs, method=method, rtol=rtol, atol=atol,
                                    return_derivatives=bool(outputs), input_hold=input_hold,
                                    **solver_options)
            if outputs:
                columns = {name: drawn[name].to_numpy() for name in drawn.columns}
                values = system.evaluate_outputs(columns, len(drawn))
                for j, name in enumerate(outputs):
                    drawn[name] = values[:, j]
            return drawn

        band = frame[["t", *skeleton.states, *outputs]]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ExtrapolationWarning)
            band = self._simulation_band(band, simulate_draw, level, n_draws, random_state)
        added = [c for c in band.columns if c not in frame.columns]
        return pd.concat([frame, band[added]], axis=1)

    def _warn_outside_domain(self, frame: pd.DataFrame, watched: Mapping) -> None:
        """Warn once if the trajectory takes curves beyond their training range."""
        columns = list(frame.columns)
        slots = {name: i for i, name in enumerate(columns)}
        env = [frame[name].to_numpy() for name in columns]
        t = env[slots["t"]]
        found = []
        for name, curve in watched.items():
            lo, hi = curve.domain
            margin = 0.01 * (hi - lo)
            for arg in self._arguments(name):
                values = compile_expression(arg, slots, self.params_, self.functions_)(env)
                values = np.broadcast_to(np.asarray(values, dtype=float), t.shape)
                outside = (values < lo - margin) | (values > hi + margin)
                if outside.any():
                    k = int(np.flatnonzero(outside)[0])
                    found.append(f"the argument {to_text(arg)} of {name} reaches "
                                 f"{values[k]:.4g} at t={t[k]:.4g}, outside [{lo:.4g}, {hi:.4g}] "
                                 f"(extrapolation={curve.extrapolation!r})")
                    break
        if found:
            warnings.warn(
                "the simulated trajectory leaves the range the curves were trained on: "
                + "; ".join(found) + ". Beyond it the model extrapolates.",
                ExtrapolationWarning, stacklevel=3)
