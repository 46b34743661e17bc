"""A trained curve network exported to a plain numpy forward pass.

``predict`` and ``simulate`` evaluate fitted curves through
:class:`NumpyCurve` only: no torch call, no validation.

Arrays go through the network itself. An ODE solver's right-hand side asks
for one Python float at a time, where a dozen numpy calls on 16-element
vectors would cost more than the rest of the step; for those, a network
with a smooth activation is tabulated once (values and exact slopes on a
grid, cubic Hermite in between) and the table is accepted only when it
matches the network to ``TABLE_TOLERANCE`` of the curve's scale at every
interval's midpoint, the grid being refined where it does not. That is far
below what float32 training resolves; a network the table cannot match
within ``MAX_TABLE_SIZE`` nodes, or a ReLU/ELU one, is evaluated
exactly.
"""

from __future__ import annotations

from bisect import bisect_right

import numpy as np

from ...skeleton.curves import Curve
from .activations import is_smooth, numpy_activation, numpy_derivative

__all__ = ["EXTRAPOLATIONS", "NumpyCurve", "OutsideTrainingRange"]

EXTRAPOLATIONS = ("linear", "clip", "raise")
#: largest accepted deviation of the scalar table from the network, relative
#: to the largest absolute value of the curve on its domain
TABLE_TOLERANCE = 1e-9
MIN_TABLE_SIZE = 256
MAX_TABLE_SIZE = 65536


class OutsideTrainingRange(ValueError):
    """A curve with ``extrapolation="raise"`` was evaluated outside its training range."""


class NumpyCurve(Curve):
    """Forward pass of a one-input MLP with exact constraints, in numpy.

    Parameters
    ----------
    name : str
        Curve name (``"f1"``), used in error messages.
    layers : list of (ndarray, ndarray)
        ``(weight, bias)`` of each linear layer, weight shaped ``(out, in)``.
    activation : str
        Activation between the linear layers.
    center, scale : float
        The network sees ``u = (x - center) / scale``.
    parity : {"odd", "even"} or None
        Symmetrisation ``(g(u) -+ g(-u)) / 2`` applied to the network.
    exponents, coefficients : ndarray
        Polynomial correction ``sum_k coefficients[k] * u**exponents[k]`` that
        enforces the point constraints.
    domain : (float, float)
        Range of the argument seen in training.
    extrapolation : {"linear", "clip", "raise"}
        Behaviour outside ``domain``: continue with the slope at the edge,
        hold the edge value, or raise :class:`OutsideTrainingRange`.
    """

    def __init__(self, name, layers, activation, center, scale, *, parity, exponents,
                 coefficients, domain, extrapolation="linear") -> None:
        if extrapolation not in EXTRAPOLATIONS:
            raise ValueError(
                f"extrapolation must be one of {EXTRAPOLATIONS}, got {extrapolation!r}")
        self.name = name
        self.layers = [(np.asarray(w, dtype=float), np.asarray(b, dtype=float))
                       for w, b in layers]
        self.activation = activation
        self.center = float(center)
        self.scale = float(scale)
        self.parity = parity
        self.exponents = np.asarray(exponents, dtype=float)
        self.coefficients = np.asarray(coefficients, dtype=float)
        self.domain = (float(domain[0]), float(domain[1]))
        self.extrapolation = extrapolation
        self._prepare()

    # -- pickling: the numpy function is looked up again on load --------------
    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        for key in ("_act", "_first", "_hidden", "_last", "_edges", "_tabulated", "_family"):
            state.pop(key, None)
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._prepare()

    def _prepare(self) -> None:
        self._act = numpy_activation(self.activation)
        w0, b0 = self.layers[0]
        self._first = (w0[:, :1], b0[:, None])
        self._hidden = [(w, b[:, None]) for w, b in self.layers[1:-1]]
        w_last, b_last = self.layers[-1]
        self._last = (w_last[0], float(b_last[0]))
        lo, hi = self.domain
        edges = np.array([lo, hi])
        values, slopes = self._value_and_slope(edges)
        self._edges = (float(values[0]), float(values[1]), float(slopes[0]), float(slopes[1]))
        self._tabulated = None  # tabulated on the first call with a float
        # what the curves sharing these inner layers share (:meth:`with_last_layer`)
        self._family = {}

    @property
    def _table(self):
        """The scalar table (None: the network is evaluated exactly), built when first asked."""
        if self._tabulated is None:
            self._tabulated = (self._tabulate() if is_smooth(self.activation) else None,)
        return self._tabulated[0]

    # -- the scalar table ------------------------------------------------------------
    def _tabulate(self):
        """Cubic Hermite coefficients on an adapted grid, or None when it would be too big.

        The grid starts uniform and every interval whose Hermite midpoint
        misses the network by more than the tolerance is halved, so nodes
        gather where the curve bends sharply (a friction step).
        """
        lo, hi = self.domain
        if not hi > lo:
            return None
        x = np.linspace(lo, hi, MIN_TABLE_SIZE + 1)
        scale = None
        while x.size <= MAX_TABLE_SIZE + 1:
            v, d = self._value_and_slope(x)
            if scale is None:
                scale = max(float(np.max(np.abs(v))), 1e-300)
            h = np.diff(x)
            middle, pieces = _hermite(v, d, h)
            error = np.abs(middle - self.inside_value(x[:-1] + 0.5 * h))
            bad = error > TABLE_TOLERANCE * scale
            if not bad.any():
                self.table_error = float(error.max()) / scale
                return (x[:-1].tolist(), (1.0 / h).tolist(), *(c.tolist() for c in pieces))
            x = np.sort(np.concatenate([x, x[:-1][bad] + 0.5 * h[bad]]))
        self.table_error = None
        return None

    # -- evaluation ------------------------------------------------------------
    def _network(self, u: np.ndarray) -> np.ndarray:
        act = self._act
        w, b = self._first
        h = act(w * u + b)
        for w, b in self._hidden:
            h = act(w @ h + b)
        w, b = self._last
        return w @ h + b

    def _value_and_slope(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The constrained network and its derivative on a 1-D array (forward mode)."""
        h, dh = self._features_and_slopes(x)
        w, b = self._last
        last = w if self.parity == "odd" else np.append(w, b)  # an odd curve's bias cancels
        out, dout = h @ last, dh @ last
        if self.coefficients.size:
            u = (x - self.center) / self.scale
            e = self.exponents
            out = out + np.power.outer(u, e) @ self.coefficients
            with np.errstate(divide="ignore", invalid="ignore"):
                powers = np.where(e > 0, np.power.outer(u, np.maximum(e - 1.0, 0.0)) * e, 0.0)
            dout = dout + powers @ self.coefficients / self.scale
        return out, dout

    def inside_value(self, x: np.ndarray) -> np.ndarray:
        """The constrained network on a 1-D array, as if every point were inside its domain."""
        u = (x - self.center) / self.scale
        if self.parity is None:
            out = self._network(u)
        else:
            both = self._network(np.concatenate([u, -u]))
            m = u.shape[0]
            if self.parity == "odd":
                out = 0.5 * (both[:m] - both[m:])
            else:
                out = 0.5 * (both[:m] + both[m:])
        if self.coefficients.size:
            out = out + np.power.outer(u, self.exponents) @ self.coefficients
        return out

    def features(self, x: np.ndarray) -> np.ndarray:
        """The curve's derivatives by its last layer's weights and bias, at ``x``.

        Shaped ``(len(x), m)``: the last hidden layer's outputs, symmetrised
        like the curve (an odd curve has no bias column: it cancels), at
        ``x`` held to the training domain. The curve is linear in these
        numbers, so they span its changes when only the last layer moves;
        a point value holds when the change is zero there (see
        :mod:`sklearn_pycc.fitting.uncertainty.linearized`).
        """
        lo, hi = self.domain
        return self.hidden_features(np.clip(np.asarray(x, dtype=float).reshape(-1), lo, hi))

    def hidden_features(self, x: np.ndarray) -> np.ndarray:
        """:meth:`features` without the clip: the last hidden layer's outputs at ``x``.

        Shaped ``(len(x), m)``, symmetrised like the curve, with a column of
        ones unless the curve is odd.
        """
        u = (np.asarray(x, dtype=float).reshape(-1) - self.center) / self.scale
        act = self._act

        def hidden(v: np.ndarray) -> np.ndarray:
            w, b = self._first
            h = act(w * v + b)
            for w, b in self._hidden:
                h = act(w @ h + b)
            return h

        h = hidden(u)
        if self.parity is not None:
            mirror = hidden(-u)
            h = 0.5 * (h - mirror) if self.parity == "odd" else 0.5 * (h + mirror)
        if self.parity == "odd":
            return h.T
        return np.hstack([h.T, np.ones((u.size, 1))])

    def with_last_layer(self, change: np.ndarray) -> NumpyCurve:
        """The curve with its last layer moved by ``change``, in :meth:`features`' columns.

        The weights move by the first entries, the bias by the last (an odd
        curve has none: its bias cancels). The inner layers are shared, not
        copied, so that curves differing only in their last layers evaluate
        side by side (:meth:`stack`); the point values hold where ``change``
        leaves the features at the points unmoved.
        """
        change = np.asarray(change, dtype=float).reshape(-1)
        weight, bias = self.layers[-1]
        m = weight.shape[1]
        if change.size != m + (self.parity != "odd"):
            raise ValueError(f"{self.name}: the last layer has {m + (self.parity != 'odd')} "
                             f"numbers, got a change of {change.size}")
        moved_bias = bias + (change[m] if self.parity != "odd" else 0.0)
        moved = NumpyCurve(self.name, [*self.layers[:-1], (weight + change[:m], moved_bias)],
                           self.activation, self.center, self.scale, parity=self.parity,
                           exponents=self.exponents, coefficients=self.coefficients,
                           domain=self.domain, extrapolation=self.extrapolation)
        moved._family = self._family
        return moved

    def feature_table(self):
        """:meth:`hidden_features` tabulated on the domain, or None.

        Cubic Hermite pieces (values and exact slopes at the nodes) on a
        uniform grid, doubled until every interval's midpoint matches the
        features to ``TABLE_TOLERANCE`` of their largest size: ``(lo,
        intervals per unit, coefficients shaped (4, n, m))``. None for an
        activation with kinks, or where ``MAX_TABLE_SIZE`` nodes do not
        suffice. Built once for every curve that shares these inner layers.
        """
        if "features" not in self._family:
            self._family["features"] = (self._tabulate_features()
                                        if is_smooth(self.activation) else None)
        return self._family["features"]

    def _tabulate_features(self):
        lo, hi = self.domain
        if not hi > lo:
            return None
        n = MIN_TABLE_SIZE
        while n <= MAX_TABLE_SIZE:
            x = np.linspace(lo, hi, n + 1)
            h = (hi - lo) / n
            v, d = self._features_and_slopes(x)
            middle, pieces = _hermite(v, d, h)
            error = np.abs(middle - self.hidden_features(x[:-1] + 0.5 * h)).max()
            if error <= TABLE_TOLERANCE * max(float(np.abs(v).max()), 1e-300):
                return lo, 1.0 / h, np.stack(pieces)
            n *= 2
        return None

    def _features_and_slopes(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`hidden_features` and their derivatives by ``x`` (forward mode)."""
        act, dact = self._act, numpy_derivative(self.activation)
        u = (x - self.center) / self.scale

        def forward(v):
            w, b = self._first
            z = w * v + b
            h = act(z)
            dh = dact(z, h) * w
            for w, b in self._hidden:
                z = w @ h + b
                h = act(z)
                dh = dact(z, h) * (w @ dh)
            return h.T, dh.T

        h, dh = forward(u)
        if self.parity is not None:
            mirror, dmirror = forward(-u)  # d/du of h(-u) is -h'(-u)
            sign = -1.0 if self.parity == "odd" else 1.0
            h, dh = 0.5 * (h + sign * mirror), 0.5 * (dh - sign * dmirror)
        if self.parity != "odd":
            h = np.hstack([h, np.ones((u.size, 1))])
            dh = np.hstack([dh, np.zeros((u.size, 1))])
        return h, dh / self.scale

    @classmethod
    def stack(cls, curves, rows: int) -> Curve | None:
        """Curves that differ only in their last layers, evaluated at once.

        The inner layers run once on every row; each block of ``rows`` rows
        is then read through its own curve's last layer. None where the
        curves share less (their inner layers must be the same arrays, as
        :meth:`with_last_layer` leaves them).
        """
        first = curves[0]
        inner = first.layers[:-1]

        def shares(curve) -> bool:
            return (len(curve.layers) == len(first.layers)
                    and all(a is c and b is d for (a, b), (c, d) in zip(curve.layers[:-1], inner))
                    and (curve.activation, curve.center, curve.scale, curve.parity,
                         curve.domain, curve.extrapolation)
                    == (first.activation, first.center, first.scale, first.parity,
                        first.domain, first.extrapolation)
                    and np.array_equal(curve.exponents, first.exponents)
                    and np.array_equal(curve.coefficients, first.coefficients))

        if not all(isinstance(c, NumpyCurve) and shares(c) for c in curves):
            return None
        return _StackedLastLayers(curves, rows)

    def _outside(self, x) -> OutsideTrainingRange:
        lo, hi = self.domain
        return OutsideTrainingRange(
            f"{self.name} was evaluated at {float(x):.6g}, outside its training range "
            f"[{lo:.6g}, {hi:.6g}] (extrapolation='raise')")

    @property
    def n_numbers(self) -> int:
        """Weights and biases of the network."""
        return sum(w.size + b.size for w, b in self.layers)

    def __call__(self, x):
        """Evaluate the curve on a float or an array."""
        if isinstance(x, float):
            return self.scalar(x)
        x = np.asarray(x, dtype=float)
        if x.ndim == 0:
            return self.scalar(float(x))
        flat = x.reshape(-1)
        lo, hi = self.domain
        clipped = np.clip(flat, lo, hi)
        if self.extrapolation == "raise":
            bad = np.flatnonzero((flat < lo) | (flat > hi))
            if bad.size:
                raise self._outside(flat[bad[0]])
        out = self.inside_value(clipped)
        if self.extrapolation == "linear":
            v_lo, v_hi, s_lo, s_hi = self._edges
            below, above = flat < lo, flat > hi
            if below.any():
                out[below] = v_lo + s_lo * (flat[below] - lo)
            if above.any():
                out[above] = v_hi + s_hi * (flat[above] - hi)
        return out.reshape(x.shape)

    def scalar(self, x: float) -> float:
        """Evaluate the curve on one Python float (the ODE right-hand-side path)."""
        lo, hi = self.domain
        if x < lo or x > hi:
            if x != x:  # NaN propagates
                return x
            if self.extrapolation == "raise":
                raise self._outside(x)
            v_lo, v_hi, s_lo, s_hi = self._edges
            if self.extrapolation == "clip":
                return v_lo if x < lo else v_hi
            return v_lo + s_lo * (x - lo) if x < lo else v_hi + s_hi * (x - hi)
        table = self._tabulated  # the ODE path: an attribute, the property only once
        table = self._table if table is None else table[0]
        if table is None:
            return float(self.inside_value(np.array([x]))[0])
        nodes, inverse, c0, c1, c2, c3 = table
        k = bisect_right(nodes, x) - 1
        if k < 0:
            k = 0
        s = (x - nodes[k]) * inverse[k]
        return c0[k] + s * (c1[k] + s * (c2[k] + s * c3[k]))

    def float_path(self):
        """:meth:`scalar` as a closure over the table, for a compiled right-hand side.

        Inside the domain, the table's piece read directly (no attribute
        looked up per call); beyond it, or without a table, :meth:`scalar`.
        """
        table = self._table
        if table is None:
            return self.scalar
        nodes, inverse, c0, c1, c2, c3 = table
        lo, hi = self.domain
        outside = self.scalar

        def value(x: float) -> float:
            if not lo <= x <= hi:
                return outside(x)
            k = bisect_right(nodes, x) - 1
            if k < 0:
                k = 0
            s = (x - nodes[k]) * inverse[k]
            return c0[k] + s * (c1[k] + s * (c2[k] + s * c3[k]))

        return value

    def __repr__(self) -> str:
        sizes = [w.shape[0] for w, _ in self.layers[:-1]]
        return (f"NumpyCurve({self.name!r}, hidden={sizes}, activation={self.activation!r}, "
                f"parity={self.parity!r}, domain=({self.domain[0]:.4g}, {self.domain[1]:.4g}))")


def _hermite(v: np.ndarray, d: np.ndarray, h):
    """Cubic Hermite pieces through values ``v`` and slopes ``d`` at nodes ``h`` apart.

    Returns the pieces' midpoints and their coefficients ``(c0, c1, c2, c3)``
    in the interval's own unit (``c0 + s (c1 + s (c2 + s c3))``, ``s`` in
    [0, 1]). ``v`` and ``d`` may hold several functions, one per column.
    """
    h = np.asarray(h, dtype=float).reshape((-1,) + (1,) * (v.ndim - 1)) if np.ndim(h) else h
    m0, m1 = d[:-1] * h, d[1:] * h
    y0, y1 = v[:-1], v[1:]
    middle = 0.5 * (y0 + y1) + (m0 - m1) / 8.0
    return middle, (y0, m0, 3.0 * (y1 - y0) - 2.0 * m0 - m1, 2.0 * (y0 - y1) + m0 + m1)


class _StackedLastLayers(Curve):
    """Networks that share their inner layers, block ``b`` of ``rows`` rows read by the ``b``-th.

    What :meth:`NumpyCurve.stack` returns: the last hidden layer is
    evaluated once on every row, and each row weighs it by its own curve's
    last layer; beyond the domain each block continues as its own curve does.
    """

    def __init__(self, curves: list[NumpyCurve], rows: int) -> None:
        first = curves[0]
        self.first = first
        self.domain = first.domain
        self.extrapolation = first.extrapolation
        self.rows = int(rows)
        self.size = len(curves) * self.rows
        odd = first.parity == "odd"
        last = np.array([np.concatenate([c.layers[-1][0][0], [] if odd else c.layers[-1][1]])
                         for c in curves])
        edges = np.array([c._edges for c in curves])  # value, value, slope, slope at the ends
        self.edges = np.repeat(edges, self.rows, axis=0).T
        table = first.feature_table()
        self.table = self.weights = None
        if table is None:  # the network itself, each row weighed by its block's last layer
            self.weights = np.repeat(last, self.rows, axis=0)
        else:  # each block's curve tabulated: (4, nodes, blocks)
            lo, inverse, pieces = table
            self.table = (lo, inverse, pieces @ last.T,
                          np.repeat(np.arange(len(curves)), self.rows))

    def __call__(self, x):
        """Each block's curve on its rows of ``x`` (a float is every row's argument)."""
        first = self.first
        flat = np.broadcast_to(np.asarray(x, dtype=float), (self.size,))
        lo, hi = self.domain
        if self.extrapolation == "raise":
            bad = np.flatnonzero((flat < lo) | (flat > hi))
            if bad.size:
                raise first._outside(flat[bad[0]])
        clipped = np.clip(flat, lo, hi)
        if self.table is None:
            out = np.einsum("ij,ij->i", first.hidden_features(clipped), self.weights)
        else:
            start, inverse, pieces, block = self.table
            lost = np.isnan(clipped)  # a row that diverged reads NaN, as the curve gives it
            position = (np.where(lost, lo, clipped) - start) * inverse
            k = np.minimum(position.astype(np.intp), pieces.shape[1] - 1)
            s = position - k
            c0, c1, c2, c3 = pieces[:, k, block]
            out = np.where(lost, np.nan, c0 + s * (c1 + s * (c2 + s * c3)))
        if first.coefficients.size:
            u = (clipped - first.center) / first.scale
            out = out + np.power.outer(u, first.exponents) @ first.coefficients
        if self.extrapolation == "linear":
            v_lo, v_hi, s_lo, s_hi = self.edges
            below, above = flat < lo, flat > hi
            out = np.where(below, v_lo + s_lo * (flat - lo), out)
            out = np.where(above, v_hi + s_hi * (flat - hi), out)
        return out
