"""A window's Runge-Kutta steps generated as one Python function on floats.

The windows' float path (:meth:`~.windows.Windows.simulate` over a few long
windows) calls the compiled right-hand side four times a step, and most of
that time goes to calls: of the right-hand side, of each node's closure, of
the list comprehensions around them. :func:`float_integrator` writes the
whole loop, the right-hand side inlined four times a step
(:meth:`~sklearn_pycc.skeleton.system.CompiledSystem.rate_statements`), as
one function: the same floats, several times faster.

The generated function gives up (returns None, or raises) wherever the
simulation leaves the ordinary: a state beyond its bound or not finite, a
function read outside its domain, a division by zero. The caller then
integrates the window again on its general path, which says what happened
and where. No text of the user's is compiled: the source is written from the
parsed skeleton's tree, numbers and functions bound by generated names.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from .._utils.generated import generated_function

__all__ = ["float_integrator"]


@dataclass
class _Layout:
    """What the generated steps read: the counts of states and inputs, the rates' statements."""

    n: int
    n_inputs: int
    statements: list
    rates: list
    #: (state position, rate position) of each state with limits, in the system's order
    holds: list

    def stage(self, rate: str, state_of: Callable[[int], str], source: str,
              index: str) -> list[str]:
        """Statements of one stage: the states' locals set, the inputs read, the rates."""
        n = self.n
        lines = [f"v{q} = {state_of(q)}" for q in range(n)]
        if self.n_inputs:
            lines.append(", ".join(f"v{n + i}" for i in range(self.n_inputs))
                         + f", = {source}[{index}]")
        # a compiled system's slots: the states, the inputs, t, then the derivatives
        lines.append(f"v{n + self.n_inputs} = times[{index}]")
        lines += self.statements
        lines += [f"{rate}{j} = {name}" for j, name in enumerate(self.rates)]
        for k, (q, j) in enumerate(self.holds):  # a rate carrying a state beyond its limit
            lines.append(f"if (v{q} >= hi{k} and {rate}{j} > 0) or (v{q} <= lo{k} and "
                         f"{rate}{j} < 0): {rate}{j} = 0.0")
        return lines

    def source(self) -> str:
        """The generated function ``run(x, right, left, times, steps, m, bound)``."""
        n = self.n
        states = ", ".join(f"s{q}" for q in range(n)) + ","
        step = (self.stage("r1_", lambda q: f"s{q}", "right", "c")
                + self.stage("r2_", lambda q: f"s{q} + 0.5 * h * r1_{q}", "left", "c + 1")
                + self.stage("r3_", lambda q: f"s{q} + 0.5 * h * r2_{q}", "left", "c + 1")
                + self.stage("r4_", lambda q: f"s{q} + h * r3_{q}", "left", "c + 2"))
        step += [f"s{q} = s{q} + h / 6.0 * (r1_{q} + 2.0 * r2_{q} + 2.0 * r3_{q} + r4_{q})"
                 for q in range(n)]
        step += [f"s{q} = min(max(s{q}, lo{k}), hi{k})" for k, (q, _) in enumerate(self.holds)]
        within = " and ".join(f"isfinite(s{q}) and abs(s{q}) <= B{q}" for q in range(n))
        lines = ["def run(x, right, left, times, steps, m, bound):",
                 f"    {states} = x",
                 "    " + ", ".join(f"B{q}" for q in range(n)) + ", = bound",
                 f"    rows = [({states})]",
                 "    append = rows.append",
                 "    for i in range(len(steps)):",
                 "        h = steps[i]",
                 "        for j in range(m):",
                 "            c = 2 * (i * m + j)"]
        lines += ["            " + line for line in step]
        lines += [f"        if not ({within}):",
                  "            return None",
                  f"        append(({states}))",
                  "    return rows"]
        return "\n".join(lines) + "\n"


def float_integrator(system) -> Callable | None:
    """The generated Runge-Kutta loop of one window of ``system``, or None where it has none.

    ``run(x, right, left, times, steps, m, bound)`` takes the first state
    (floats), each stage's inputs (``right``, and ``left`` for the later
    stages of a step), each stage's time, each step's length, the substeps a
    step and each state's bound. It returns the states after every step (a
    list of tuples, the first state first), or None where a state leaves its
    bound or is not finite; a domain error or division by zero raises. The
    steps are those of the float path of
    :meth:`~sklearn_pycc.simulation.windows.Windows.simulate`.
    """
    written = system.rate_statements()
    if written is None:
        return None
    statements, rates, holds, namespace = written
    layout = _Layout(len(system.states), len(system.inputs), statements, rates, holds)
    namespace = {**namespace, "isfinite": math.isfinite}
    return generated_function(layout.source(), namespace, "run")
