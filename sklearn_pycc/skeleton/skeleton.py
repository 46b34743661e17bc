"""The :class:`Skeleton`: a parsed, checked system of equations with curves."""

from __future__ import annotations

import warnings
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import replace

import numpy as np
import pandas as pd

from ..exceptions import SimulationError, SkeletonError
from ..simulation.delays import delayed_name, read_delayed
from ..simulation.integration import (
    InputSignals,
    check_solver_options,
    check_time_grid,
    integrate_sampled,
    integrate_system,
    progress_bar,
    sampled_step_limit,
)
from .constraints import (
    Bound,
    Constraint,
    StateLimit,
    check_constraints,
    limit_params,
    merged_bounds,
    merged_limits,
    parse_constraints,
    resolved_limits,
)
from .equations import TIME, Equation, classify, evaluation_order, state_of
from .nodes import (
    BinOp,
    Neg,
    Param,
    Symbol,
    Unknown,
    params_in,
    product_factors,
    rename,
    rename_symbols,
    signed_terms,
    walk,
)
from .parser import parse_equation, parse_expression
from .printer import to_text
from .system import CompiledSystem

__all__ = ["Skeleton"]


def _unsigned(node):
    """``node`` with the minus signs of its product chain removed."""
    if isinstance(node, Neg):
        return _unsigned(node.operand)
    if isinstance(node, BinOp) and node.op == "*":
        return replace(node, left=_unsigned(node.left), right=_unsigned(node.right))
    return node


def _term_key(node) -> tuple[float, tuple[str, ...]]:
    """A product's sign and its factors as text, in order: equal for equal terms."""
    sign = 1.0
    stack = [node]
    while stack:
        item = stack.pop()
        if isinstance(item, Neg):
            sign = -sign
            stack.append(item.operand)
        elif isinstance(item, BinOp) and item.op == "*":
            stack.extend((item.left, item.right))
    factors = product_factors(_unsigned(node))
    return sign, tuple(sorted(to_text(f) for f in factors))


def _index_key(name: str) -> int:
    return int(name[1:])


class Skeleton:
    """A structural skeleton: equations with unknown curves ``f_i`` and scalars ``a_i``.

    Parameters
    ----------
    equations : list of str or Skeleton
        One equation per state, e.g. ``["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"]``.
        A state is a name with a ``NAME_dot`` equation; ``t`` is time; any
        other name is an input (a measured column). An equation may also be
        written unsolved, as ``F_ext = f1(x1) + f2(x1) x1_dot``. Equations
        without a derivative of their own are fitted too and left out of
        simulations: static ones, ``F1 = f1(x1)`` (``F1`` is then an output,
        predicted from the others), implicit relations among measured
        quantities, ``0 = x1^2 + x2^2 - a1``, and further relations among
        derivatives the others define, such as a conserved quantity,
        ``0 = x2 x2_dot + f2(x1) x2``.
    constraints : list of str or dict, optional
        On curves ``"f1 odd"``, ``"f1 even"``, ``"f2(0)=0"``, ``"f1 increasing"``,
        ``"f1 decreasing"``; on parameters ``"a2 >= 0"``, ``"a2 <= 5"``,
        ``"0 <= a3 <= 10"``; or any of them as ``{"constraint": "f1 odd"}``.

    Attributes
    ----------
    equations : tuple of str
        The equations as written.
    constraints : tuple of Constraint or Bound
        Parsed constraints (:attr:`bounds` merges those on parameters).
    states, inputs, derivatives, functions, params : list of str
        Names found in the equations; states and derivatives in the order of
        the equations, curves and parameters by index.
    outputs : list of str
        The left sides of static equations (``F1`` of ``F1 = f1(x1)``), in
        the order of the equations.

    Examples
    --------
    >>> sk = Skeleton(["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"], ["f1 odd"])
    >>> sk.states, sk.inputs, sk.functions
    (['x1', 'x2'], ['F_ext'], ['f1', 'f2'])
    """

    def __init__(self, equations, constraints: Iterable | None = None) -> None:
        if isinstance(equations, Skeleton):
            extra = parse_constraints(constraints)
            constraints = (*equations.constraints,
                           *[c for c in extra if c not in equations.constraints])
            equations = equations.equations
        if isinstance(equations, str):
            raise SkeletonError(
                "equations must be a list of strings, one per state, not a single string")
        try:
            texts = list(equations)
        except TypeError:
            raise SkeletonError(
                f"equations must be a list of strings, got {type(equations).__name__}") from None
        if not texts:
            raise SkeletonError("the skeleton has no equations")
        parsed = []
        for index, text in enumerate(texts):
            lhs, rhs = parse_equation(text, index)
            parsed.append((text, lhs, rhs))
        self.equations: tuple[str, ...] = tuple(texts)
        classified = classify(parsed)
        self._all: list[Equation] = classified
        self._equations: list[Equation] = [eq for eq in classified if eq.dynamic]
        evaluation_order(self._equations)  # rejects derivatives defined in a cycle
        self.derivatives = [eq.derivative for eq in self._equations]
        self.states = [state_of(d) for d in self.derivatives]
        self.outputs = [eq.output for eq in classified if eq.output is not None]
        functions: list[str] = []
        params: list[str] = []
        inputs: list[str] = []
        uses_time = False
        for eq in classified:
            for node in (*walk(eq.lhs), *walk(eq.rhs)):
                if isinstance(node, Unknown) and node.name not in functions:
                    functions.append(node.name)
                elif isinstance(node, Param) and node.name not in params:
                    params.append(node.name)
                elif isinstance(node, Symbol):
                    name = node.name
                    if name == TIME:
                        uses_time = True
                    elif (state_of(name) is None and name not in self.states
                          and name not in inputs
                          and (name not in self.outputs or self._reads(name))):
                        inputs.append(name)
        self.functions = sorted(functions, key=_index_key)
        self.inputs = inputs
        self.uses_time = uses_time
        #: delayed input's symbol -> (input, delay: a parameter's name or a number)
        self.delays = self._read_delays(classified, params)
        #: parameter -> the delayed inputs it delays (``u(t - a5)``), each fitted
        self.delay_params: dict[str, list[str]] = {}
        for name, (_, delay) in self.delays.items():
            if isinstance(delay, str):
                self.delay_params.setdefault(delay, []).append(name)
        self.constraints: tuple[Constraint | Bound | StateLimit, ...] = parse_constraints(
            constraints)
        check_constraints(self.constraints, self.functions, [*params, *self.delay_params],
                          self.states)
        #: parameter -> (state, side) of each state limit to fit (``x1 <= a5``)
        self.limit_params = limit_params(self.constraints)
        self.params = sorted([*params, *self.limit_params, *self.delay_params], key=_index_key)
        #: delays this skeleton was made with as numbers (:meth:`with_delays`): values of
        #: them are accepted beside its parameters, and not used
        self.delays_given: dict[str, float] = {}

    def _read_delays(self, classified: list[Equation], params: list[str]) -> dict:
        """The delayed inputs, checked: only an input is read late, by a delay of its own."""
        delays = {}
        for name in self.inputs:
            read = read_delayed(name)
            if read is None:
                continue
            signal, delay = read
            index = next(eq.index for eq in classified
                         if any(getattr(n, "name", None) == name
                                for side in (eq.lhs, eq.rhs) for n in walk(side)))
            if signal in self.states or state_of(signal) is not None \
                    or signal in self.outputs:
                raise SkeletonError(
                    f"{name}: only an input may be read late; {signal} is "
                    f"{'a state' if signal in self.states else 'defined by the skeleton'}, "
                    "and a state read late makes a delay-differential equation, which "
                    "the skeleton language does not express", equation=index)
            if isinstance(delay, str) and delay in params:
                raise SkeletonError(
                    f"{delay} is the delay of {name} and cannot also be a coefficient: "
                    "give the coefficient a parameter of its own", equation=index)
            delays[name] = (signal, delay)
        return delays

    # -- conveniences ---------------------------------------------------------
    def _reads(self, name: str) -> bool:
        """Whether an equation reads ``name`` other than as the output it predicts."""
        for eq in self._all:
            sides = (eq.rhs,) if eq.output == name else (eq.lhs, eq.rhs)
            if any(isinstance(n, Symbol) and n.name == name for side in sides
                   for n in walk(side)):
                return True
        return False

    @property
    def parsed(self) -> list[Equation]:
        """The differential equations (parsed trees and the derivative each determines)."""
        return list(self._equations)

    @property
    def algebraic(self) -> list[Equation]:
        """The equations without a derivative of their own, in the order given.

        Static equations ``NAME = rhs`` (their ``output`` is ``NAME``),
        implicit relations among measured quantities (``0 = ...``) and
        further relations among derivatives other equations define (a
        conserved quantity). They are fitted; a simulation leaves them out.
        """
        return [eq for eq in self._all if not eq.dynamic]

    @property
    def residual_equations(self) -> list[Equation]:
        """Every equation in the order given: what a fit makes hold on the data."""
        return list(self._all)

    @property
    def targets(self) -> list[str]:
        """What ``predict`` returns: the derivatives, then the static outputs."""
        return [*self.derivatives, *self.outputs]

    @property
    def variables(self) -> list[str]:
        """Data columns the equations read: states and inputs (and ``t`` if used).

        A static equation's output is not among them (it is predicted), unless
        another equation reads it. An input read late (``u(t - 0.3)``) comes
        with the input it is read from (``u``), and ``t``.
        """
        names = []
        for eq in self._all:
            for node in (*walk(eq.lhs), *walk(eq.rhs)):
                name = getattr(node, "name", None)
                if (isinstance(node, Symbol) and state_of(name) is None
                        and name not in names
                        and (name not in self.outputs or self._reads(name))):
                    names.append(name)
                    if name in self.delays:
                        names.extend(n for n in (self.delays[name][0], TIME)
                                     if n not in names)
        return names

    def curve_arguments(self, function: str) -> list:
        """Distinct argument expressions ``function`` is applied to, in order of appearance."""
        cache = self.__dict__.setdefault("_arguments_cache", {})
        if function not in cache:
            found = []
            for eq in self._all:
                for node in walk(eq.residual):
                    if isinstance(node, Unknown) and node.name == function \
                            and node.arg not in found:
                        found.append(node.arg)
            cache[function] = found
        return list(cache[function])

    def constraints_of(self, function: str) -> list[Constraint]:
        """Constraints applying to one curve."""
        return [c for c in self.constraints
                if isinstance(c, Constraint) and c.function == function]

    @property
    def bounds(self) -> dict[str, tuple[float, float]]:
        """Parameter -> ``(low, high)`` for every bounded parameter (``-inf``/``inf`` open).

        A limit's end to fit is bounded by its state's other end as well
        (``a5 >= 0`` with ``x1 >= 0`` and ``x1 <= a5``).
        """
        bounds = merged_bounds(self.constraints)
        for name in self.delay_params:  # a delay is never negative
            low, high = bounds.get(name, (-np.inf, np.inf))
            bounds[name] = (max(low, 0.0), high)
        return bounds

    def with_delays(self, values: Mapping[str, float]) -> Skeleton:
        """A new skeleton with each fitted delay given as a number.

        ``u(t - a5)`` becomes ``u(t - 0.3)``; the delays' own bounds go.

        Parameters
        ----------
        values : mapping
            A value (time units, at least 0) for every parameter of
            :attr:`delay_params`.
        """
        missing = [a for a in self.delay_params if a not in values]
        if missing:
            raise ValueError(f"no value given for the delay {missing[0]}")
        renamed = {}
        for name, (signal, delay) in self.delays.items():
            if isinstance(delay, str):
                value = float(values[delay])
                if not np.isfinite(value) or value < 0:
                    raise ValueError(f"the delay {delay} must be finite and at least 0, "
                                     f"got {value}")
                renamed[name] = delayed_name(signal, value)
        equations = []
        for index, text in enumerate(self.equations):
            lhs, rhs = parse_equation(text, index)
            lhs, rhs = (rename_symbols(side, renamed) for side in (lhs, rhs))
            equations.append(f"{to_text(lhs, precision=17)} = {to_text(rhs, precision=17)}")
        kept = [c for c in self.constraints
                if not (isinstance(c, Bound) and c.param in self.delay_params)]
        concrete = Skeleton(equations, kept)
        concrete.delays_given = {a: float(values[a]) for a in self.delay_params}
        return concrete

    @property
    def limits(self) -> dict[str, tuple[float | str, float | str]]:
        """State -> ``(low, high)`` for every state with a hard limit (``-inf``/``inf`` open).

        An end to fit is its parameter's name (:attr:`limit_params`); see
        :meth:`limits_at`.
        """
        return merged_limits(self.constraints)

    def limits_at(self, params: Mapping[str, float]) -> dict[str, tuple[float, float]]:
        """:attr:`limits` with every end to fit at its value in ``params``."""
        return resolved_limits(self.limits, params)

    def monotone(self, function: str) -> str | None:
        """``"increasing"``, ``"decreasing"`` or None for one curve."""
        kinds = {c.kind for c in self.constraints_of(function)}
        return next((k for k in ("increasing", "decreasing") if k in kinds), None)

    def with_constraints(self, constraints: Iterable | None) -> Skeleton:
        """A new skeleton with the same equations and these constraints added."""
        return Skeleton(self, constraints)

    def add_term(self, equation: int | str, term: str, sign: str = "-",
                 constraints: Iterable | None = None, *,
                 shared: Iterable[str] = ()) -> Skeleton:
        """A new skeleton with ``term`` added to the right-hand side of one equation.

        The term's curves and parameters are renumbered to fresh indices
        (above the largest the skeleton uses, in the order of their own
        indices), so a catalogue term written with ``a1`` or ``f1`` never
        collides with the skeleton's.

        Parameters
        ----------
        equation : int or str
            Index of the equation, its state (``"x2"``) or its derivative
            (``"x2_dot"``).
        term : str
            The term in the skeleton language, e.g. ``"a1 sign(x2)"``.
        sign : {"-", "+"}, default="-"
            Subtract the term (a force opposing motion) or add it.
        constraints : list of str or dict, optional
            Constraints on the term's curves and parameters, written with the
            term's names (``["f1 odd"]`` for ``term="f1(x2)"``, ``["a1 >= 0"]``
            for ``term="a1 x2"``); they are renamed too.
        shared : iterable of str, optional
            Parameters of this skeleton that the term reads under their own
            names (the shape of a law whose flow another term carries too):
            they are not renumbered, and their constraints are the skeleton's.

        Returns
        -------
        Skeleton
            The extended skeleton; this one is unchanged.

        Examples
        --------
        >>> sk = Skeleton(["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"])
        >>> sk.add_term("x2", "a1 sign(x2)").equations[1]
        'x2_dot = F_ext - a1 x2 - a2 x1 - a3*sign(x2)'
        """
        index = self._equation_index(equation)
        if sign not in ("-", "+"):
            raise ValueError(f"sign must be '-' or '+', got {sign!r}")
        node = parse_expression(term, kind="term")
        curves = sorted({n.name for n in walk(node) if isinstance(n, Unknown)}, key=_index_key)
        shared = set(shared)
        if shared - set(self.params):
            raise ValueError(f"shared names {', '.join(sorted(shared - set(self.params)))}, "
                             "which are not parameters of the skeleton")
        params = sorted((a for a in params_in(node) if a not in shared), key=_index_key)
        mapping = {}
        for names, taken in ((curves, self.functions), (params, self.params)):
            start = max((_index_key(name) for name in taken), default=0)
            for k, name in enumerate(names, start=start + 1):
                mapping[name] = f"{name[0]}{k}"
        renamed = rename(node, mapping)
        text = to_text(renamed)
        if text.startswith("-") or (isinstance(renamed, BinOp) and renamed.op in "+-"):
            text = f"({text})"
        extra = []
        for constraint in parse_constraints(constraints):
            field = "param" if isinstance(constraint, Bound) else "function"
            name = getattr(constraint, field)
            if name not in mapping:
                raise SkeletonError(
                    f"the constraint {str(constraint)!r} names {name}, which is not a "
                    f"{'parameter' if field == 'param' else 'curve'} of the term {term!r}",
                    kind="constraints")
            extra.append(replace(constraint, **{field: mapping[name]}))
        equations = list(self.equations)
        equations[index] = f"{equations[index]} {sign} {text}"
        return Skeleton(equations, [*self.constraints, *extra])

    def remove_term(self, equation: int | str, term: str) -> Skeleton:
        """A new skeleton without one term of an equation's right-hand side.

        Constraints of the curves and parameters that no equation uses any
        more are dropped with the term; the others keep their names (the
        skeleton's numbering may then have gaps, which is allowed).

        Parameters
        ----------
        equation : int or str
            Index of the equation, its state or its derivative.
        term : str
            The term as it stands in the sum, without its sign
            (``"a2 x1"``); matched by its structure, not its spacing.

        Returns
        -------
        Skeleton
            The reduced skeleton; this one is unchanged.

        Raises
        ------
        ValueError
            If the equation has no such term.

        Examples
        --------
        >>> sk = Skeleton(["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"])
        >>> sk.remove_term("x2", "a2 x1").equations[1]
        'x2_dot = F_ext - a1*x2'
        """
        index = self._equation_index(equation)
        eq = next(e for e in self._all if e.index == index)
        wanted = _term_key(parse_expression(term, kind="term"))[1]
        terms = [(sign * inner, key, node) for sign, node in signed_terms(eq.rhs)
                 for inner, key in [_term_key(node)]]
        if all(key != wanted for _, key, _ in terms):
            raise ValueError(f"equation {index} ({self.equations[index]!r}) has no term "
                             f"{term!r}; its terms are "
                             f"{', '.join(repr(to_text(node)) for _, _, node in terms)}")
        kept = [(sign, to_text(_unsigned(node))) for sign, key, node in terms if key != wanted]
        if not kept:
            body = "0"
        else:
            body = " ".join(f"{'-' if sign < 0 else '+'} {text}" for sign, text in kept)
            body = body[2:] if body.startswith("+ ") else f"-{body[2:]}"
        equations = list(self.equations)
        equations[index] = f"{to_text(eq.lhs)} = {body}"
        # constraints of names the reduced skeleton no longer has are dropped with the term
        used = set()
        for text in equations:
            lhs, rhs = parse_equation(text, 0)
            used |= {n.name for side in (lhs, rhs) for n in walk(side)
                     if isinstance(n, (Param, Unknown))}
        constraints = [c for c in self.constraints
                       if getattr(c, "param", None) in used or getattr(c, "function", None)
                       in used]
        return Skeleton(equations, constraints)

    def _equation_index(self, equation: int | str) -> int:
        if isinstance(equation, (int, np.integer)) and not isinstance(equation, bool):
            if not -len(self.equations) <= equation < len(self.equations):
                raise IndexError(f"the skeleton has {len(self.equations)} equations; "
                                 f"there is no equation {equation}")
            return int(equation) % len(self.equations)
        if isinstance(equation, str):
            for eq in self._equations:
                if equation in (eq.state, eq.derivative):
                    return eq.index
            raise ValueError(f"no equation determines {equation!r}; the states are "
                             f"{', '.join(self.states)}")
        raise TypeError(f"equation must be an index or a state name, got {equation!r}")

    def __iter__(self) -> Iterator[str]:
        return iter(self.equations)

    def __len__(self) -> int:
        return len(self.equations)

    def __repr__(self) -> str:
        eqs = ", ".join(repr(e) for e in self.equations)
        if self.constraints:
            cons = ", ".join(repr(str(c)) for c in self.constraints)
            return f"Skeleton([{eqs}], constraints=[{cons}])"
        return f"Skeleton([{eqs}])"

    def __str__(self) -> str:
        lines = list(self.equations)
        if self.constraints:
            lines.append("subject to: " + ", ".join(str(c) for c in self.constraints))
        return "\n".join(lines)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Skeleton):
            return NotImplemented
        return self.equations == other.equations and set(self.constraints) == set(
            other.constraints)

    def __hash__(self) -> int:
        return hash((self.equations, frozenset(self.constraints)))

    def __getstate__(self) -> dict:
        return {"equations": self.equations, "constraints": self.constraints,
                "delays_given": self.delays_given}

    def __setstate__(self, state: dict) -> None:
        self.__init__(list(state["equations"]), list(state["constraints"]))
        self.delays_given = dict(state.get("delays_given", {}))

    # -- analysis -------------------------------------------------------------
    def identifiability(self):
        """Structural identifiability analysis of the skeleton and its constraints.

        Returns
        -------
        IdentifiabilityReport
            Every ambiguity found, in words, with the constraint or fixed
            value that removes it.
        """
        from .identifiability import analyse

        return analyse(self)

    # -- evaluation -------------------------------------------------------------
    def check_values(self, functions: Mapping | None, params: Mapping | None):
        """``(functions, params)`` checked to give exactly the skeleton's curves and parameters.

        Raises a ``ValueError`` naming the first missing or unknown name (a
        ``TypeError`` for a curve that is not callable); parameter values are
        returned as floats.
        """
        functions = dict(functions or {})
        params = {a: v for a, v in dict(params or {}).items() if a not in self.delays_given}
        for kind, given, needed in (("curve", functions, self.functions),
                                    ("parameter", params, self.params)):
            missing = [n for n in needed if n not in given]
            if missing:
                raise ValueError(f"no value for the {kind} {missing[0]!r} of the skeleton")
            unknown = [n for n in given if n not in needed]
            if unknown:
                raise ValueError(
                    f"{unknown[0]!r} is not a {kind} of the skeleton (it has "
                    f"{', '.join(needed) or 'none'})")
        for name, fn in functions.items():
            if not callable(fn):
                raise TypeError(f"the curve {name!r} must be callable, got {type(fn).__name__}")
        params = {k: float(v) for k, v in params.items()}
        return functions, params

    def compile(self, functions: Mapping[str, Callable] | None = None,
                params: Mapping[str, float] | None = None) -> CompiledSystem:
        """Compile the right-hand side with given curves and parameter values.

        The delays of inputs read late are among the parameters: the system
        reads each such input at its delay.
        """
        functions, params = self.check_values(functions, params)
        if self.delay_params:
            late = self.with_delays({a: params[a] for a in self.delay_params})
            return late.compile(functions, params)
        static = [eq for eq in self._all if eq.output is not None]
        return CompiledSystem(self._equations, self.states, self.inputs, params, functions,
                              static=static, limits=self.limits_at(params))

    def simulate(
        self,
        t,
        y0,
        functions: Mapping[str, Callable] | None = None,
        params: Mapping[str, float] | None = None,
        inputs: Mapping | None = None,
        *,
        method: str | None = None,
        rtol: float = 1e-6,
        atol: float = 1e-8,
        return_derivatives: bool = False,
        input_hold: str = "bandlimited",
        verbose: bool = False,
        **solver_options,
    ) -> pd.DataFrame:
        """Simulate the skeleton with given curves and parameters (the paper's ``Theoretical``).

        Parameters
        ----------
        t : array-like
            Strictly increasing output times; integration runs from ``t[0]`` to ``t[-1]``.
        y0 : array-like
            Initial state, in the order of :attr:`states`, within the states'
            hard limits.
        functions : dict, optional
            Curve name -> callable (e.g. ``{"f1": lambda v: 0.1 * v}``).
        params : dict, optional
            Parameter name -> value.
        inputs : dict, optional
            Input name -> callable of ``t``, array sampled on ``t``, or constant.
        method : str, optional
            How to integrate. By default, an input given as an array sampled on
            ``t`` selects the sampled-input integrator (an adaptive
            Dormand-Prince 5(4) whose steps end on the samples, so that the
            held input never forces a restart; one step per sample for a slow
            model), and otherwise SciPy's LSODA. Name a SciPy solver (LSODA,
            RK45, RK23, DOP853, Radau, BDF) to use it whatever the inputs.
        input_hold : {"bandlimited", "foh", "zoh"}, default="bandlimited"
            How an array input is read between its samples: as a signal
            band-limited below the Nyquist frequency (cubic pieces with the
            band-limited signal's slopes; right for a measured or generated
            input even at a few samples per period), joined by straight lines
            (first-order hold), or kept constant until the next sample
            (zero-order hold, what a digital controller's output does).
        verbose : bool, default=False
            Show a progress bar (tqdm) over the samples.
        rtol, atol : float
            Solver tolerances.
        return_derivatives : bool
            Also return the ``NAME_dot`` columns evaluated on the trajectory.
        **solver_options
            Passed to the SciPy solver, and ``max_steps`` (default 500000):
            the most solver steps before a :class:`SimulationError`.

        Returns
        -------
        pandas.DataFrame
            Columns ``t``, the states (and the inputs and derivatives when
            ``return_derivatives``).

        Raises
        ------
        SimulationError
            If the trajectory diverges or the solver fails.
        ValueError
            If ``y0`` starts a state beyond its hard limits.
        """
        system = self.compile(functions, params)
        return simulate_system(system, t, y0, inputs, method=method, rtol=rtol, atol=atol,
                               return_derivatives=return_derivatives, input_hold=input_hold,
                               verbose=verbose, **solver_options)


def _limit_text(name: str, low: float, high: float) -> str:
    return " ".join([*([f"{low:.6g} <="] if np.isfinite(low) else []), name,
                     *([f"<= {high:.6g}"] if np.isfinite(high) else [])])


#: a simulation of more samples than this says it will take a while
LONG_SIMULATION = 2_000_000

#: a start beyond a state's limit by less than this share of the limit's size is rounding:
#: it is moved onto the limit rather than refused
START_SLACK = 1e-9


def check_start(system: CompiledSystem, y0: np.ndarray, t0: float = 0.0) -> np.ndarray:
    """``y0`` checked to lie within the states' hard limits (a copy, rounding moved onto them).

    Raises
    ------
    ValueError
        Naming the first state that starts beyond its limits.
    SimulationError
        When the model's limits on a state leave it no value (an end fitted, or
        drawn, below the other).
    """
    y0 = np.array(y0, dtype=float)
    for q, name in enumerate(system.states):
        low, high = system.limits.get(name, (-np.inf, np.inf))
        if low > high:
            raise SimulationError(f"the limits of {name} leave it no value ({low:.6g} <= "
                                  f"{name} <= {high:.6g}): the model cannot be simulated",
                                  t_reached=t0, partial=pd.DataFrame())
        slack = START_SLACK * max([1.0, *(abs(v) for v in (low, high) if np.isfinite(v))])
        if y0[q] < low - slack or y0[q] > high + slack:
            side = "below its lower" if y0[q] < low else "above its upper"
            raise ValueError(f"y0 starts {name} at {y0[q]:.6g}, {side} limit "
                             f"({_limit_text(name, low, high)}): start it within its limits")
    return system.clip(y0)


def simulate_system(system: CompiledSystem, t, y0, inputs=None, *, method=None, rtol=1e-6,
                    atol=1e-8, return_derivatives=False, input_hold="bandlimited", verbose=False,
                    **solver_options) -> pd.DataFrame:
    """Simulate a compiled system (shared by :class:`Skeleton` and the estimators).

    ``method=None`` integrates sampled inputs by :func:`integrate_sampled`
    and everything else by LSODA.
    """
    t = check_time_grid(t)
    check_solver_options(rtol, atol, solver_options)
    y0 = np.asarray(y0, dtype=float)
    if y0.ndim != 1 or len(y0) != len(system.states):
        raise ValueError(
            f"y0 must hold {len(system.states)} values, one per state "
            f"({', '.join(system.states)}), got shape {y0.shape}")
    if not np.isfinite(y0).all():
        raise ValueError("y0 contains NaN or infinity")
    y0 = check_start(system, y0, float(t[0]))
    signals = InputSignals(system.inputs, inputs, t, input_hold)
    sampled = method is None and signals.sampled
    rhs = system.make_rhs(signals.at, list_states=sampled)
    if len(t) > LONG_SIMULATION and not verbose:
        warnings.warn(f"simulating {len(t):,} samples takes minutes (about 25 s per million on "
                      "one core); verbose=True shows its progress", UserWarning, stacklevel=3)
    with progress_bar(len(t), verbose) as progress:
        if sampled:
            unknown = set(solver_options) - {"max_steps"}
            if unknown:
                raise ValueError(f"the sampled-input integrator takes no option "
                                 f"{sorted(unknown)[0]!r}; pass method='LSODA' (or another "
                                 "SciPy solver) to use SciPy's options")
            # a long record earns its steps (50 per sample), up to a budget
            limit = solver_options.get("max_steps", sampled_step_limit(len(t)))
            frame = integrate_sampled(rhs, t, y0, system.states, signals, rtol=rtol, atol=atol,
                                      max_steps=limit, progress=progress)
        else:
            frame = integrate_system(rhs, t, y0, system.states, method=method or "LSODA",
                                     rtol=rtol, atol=atol, progress=progress,
                                     **solver_options)
    for name, (low, high) in system.limits.items():  # a step may overshoot by its error
        frame[name] = frame[name].clip(low, high)
    if return_derivatives:
        data = {name: frame[name].to_numpy() for name in system.states}
        values = signals.on(t)
        for name, v in zip(system.inputs, values):
            data[name] = v
            frame[name] = v
        data[TIME] = t
        derivs = system.evaluate(data, len(t))
        for j, name in enumerate(system.derivatives):
            frame[name] = derivs[:, j]
    return frame
