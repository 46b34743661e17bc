"""Torch modules of the neural backend: one MLP per curve, the skeleton around them.

:class:`CurveNet` is a small MLP of one scaled input with the curve's
constraints built in (exact by construction, or as a penalty);
:class:`SkeletonModule` holds every curve network and free parameter and
evaluates the weighted residuals of the skeleton's equations, compiled once
from the parsed trees.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
import torch
from torch import nn
from torch.nn.utils import skip_init

from ...exceptions import SkeletonError
from .activations import torch_activation
from .numpy_mlp import NumpyCurve
from .torch_expr import compile_torch

__all__ = ["BoundedParameters", "CurveNet", "SkeletonModule", "correction_basis"]

#: activations that never decrease: a network of them with positive weights is monotone
MONOTONE_ACTIVATIONS = ("tanh", "relu", "elu", "softplus", "sigmoid")


def _inverse_softplus(value: float) -> float:
    return value + math.log(-math.expm1(-value)) if value < 30 else value


class BoundedParameters(Mapping):
    """Free parameters by name, each within its bounds by reparametrisation.

    ``low + softplus(r)``, ``high - softplus(r)`` or ``low + (high - low)
    sigmoid(r)`` of an unconstrained tensor ``r``: the value can never leave
    its bounds, whatever the optimiser does.
    """

    def __init__(self, raw: nn.ParameterDict, bounds: Mapping[str, tuple[float, float]]):
        self.raw = raw
        self.bounds = {name: bounds.get(name, (-math.inf, math.inf)) for name in raw}

    @staticmethod
    def unconstrained(value: float, low: float, high: float) -> float:
        """The raw value that gives ``value`` (moved strictly inside the bounds)."""
        if math.isinf(low) and math.isinf(high):
            return value
        if math.isinf(high):
            return _inverse_softplus(max(value - low, 1e-6 * max(1.0, abs(low))))
        if math.isinf(low):
            return _inverse_softplus(max(high - value, 1e-6 * max(1.0, abs(high))))
        share = min(max((value - low) / (high - low), 1e-6), 1 - 1e-6)
        return math.log(share / (1 - share))

    def __getitem__(self, name: str) -> torch.Tensor:
        raw = self.raw[name]
        low, high = self.bounds[name]
        if math.isinf(low) and math.isinf(high):
            return raw
        if math.isinf(high):
            return low + nn.functional.softplus(raw)
        if math.isinf(low):
            return high - nn.functional.softplus(raw)
        return low + (high - low) * torch.sigmoid(raw)

    def __iter__(self):
        return iter(self.raw)

    def __len__(self) -> int:
        return len(self.raw)



def correction_basis(points: Sequence[tuple[float, float]], parity: str | None,
                     center: float, scale: float, name: str):
    """Exponents and inverse Vandermonde matrix of the point-value correction.

    The correction ``sum_k c_k u**e_k`` (``u`` the scaled argument) uses the
    lowest powers that respect the parity: all of them, odd ones or even
    ones. It is solved so that the corrected curve passes through every
    point exactly.

    Returns
    -------
    at : ndarray
        Distinct constrained arguments (in units of ``x``).
    values : ndarray
        The values the curve must take there.
    exponents : ndarray
    inverse : ndarray of shape (k, k)
        Maps the misfit at the points to the correction coefficients.
    """
    kept: dict[float, float] = {}
    for at, value in points:
        key = abs(at) if parity else at
        if parity == "odd" and at == 0.0:
            if value != 0.0:
                raise SkeletonError(f"{name} is odd, so {name}(0) must be 0, not {value:g}",
                                    kind="constraints")
            continue
        sign = -1.0 if (parity == "odd" and at < 0) else 1.0
        target = sign * value
        if key in kept and not math.isclose(kept[key], target, rel_tol=1e-12, abs_tol=1e-12):
            raise SkeletonError(
                f"the point constraints of {name} contradict each other at {at:g}",
                kind="constraints")
        kept[key] = target
    if not kept:
        return np.zeros(0), np.zeros(0), np.zeros(0), np.zeros((0, 0))
    at = np.array(sorted(kept))
    values = np.array([kept[a] for a in at])
    k = len(at)
    if parity == "odd":
        exponents = np.arange(1, 2 * k, 2, dtype=float)
    elif parity == "even":
        exponents = np.arange(0, 2 * k, 2, dtype=float)
    else:
        exponents = np.arange(k, dtype=float)
    u = (at - center) / scale
    inverse = np.linalg.inv(np.power.outer(u, exponents))
    return at, values, exponents, inverse


class CurveNet(nn.Module):
    """One characteristic curve: an MLP of the scaled argument, constrained.

    Parameters
    ----------
    name : str
        Curve name, for messages.
    hidden : sequence of int
        Hidden layer sizes.
    activation : str
        Activation name (see ``_activations.ACTIVATIONS``).
    center, scale : float
        Input scaling ``u = (x - center) / scale`` (center 0 for a parity).
    parity : {"odd", "even"} or None
    points : sequence of (float, float)
        Point values ``f(at) = value``.
    exact : bool
        Constraints by construction (True) or only through :meth:`penalty`.
    generator : torch.Generator
        Source of the initial weights.
    dtype : torch.dtype
    monotone : {"increasing", "decreasing"} or None
        By construction: every weight is the softplus of a free one, so with
        a non-decreasing activation the network never decreases (its output
        is negated for "decreasing").
    """

    def __init__(self, name: str, hidden: Sequence[int], activation: str, center: float,
                 scale: float, *, parity: str | None, points: Sequence[tuple[float, float]],
                 exact: bool, generator: torch.Generator, dtype: torch.dtype,
                 monotone: str | None = None) -> None:
        super().__init__()
        if monotone is not None and exact:
            _check_monotone(name, activation, parity, points)
        self.monotone = monotone if exact else None
        self.soft_monotone = monotone if not exact else None
        self.name = name
        self.activation = activation
        self.center = float(center)
        self.scale = float(scale)
        self.parity = parity
        self.exact = exact
        self.points = [(float(a), float(v)) for a, v in points]
        layers: list[nn.Module] = []
        width = 1
        for size in hidden:
            layers += [skip_init(nn.Linear, width, size, dtype=dtype),
                       torch_activation(activation)]
            width = size
        layers.append(skip_init(nn.Linear, width, 1, dtype=dtype))
        self.mlp = nn.Sequential(*layers)
        with torch.no_grad():
            for layer in self.mlp:
                if isinstance(layer, nn.Linear):
                    bound = 1.0 / math.sqrt(layer.in_features)
                    layer.weight.uniform_(-bound, bound, generator=generator)
                    layer.bias.uniform_(-bound, bound, generator=generator)
                    if self.monotone is not None:  # softplus(raw) = |initial weight|
                        small = layer.weight.abs().clamp_min(1e-3 * bound)
                        layer.weight.copy_(small + torch.log(-torch.expm1(-small)))
        at, values, exponents, inverse = correction_basis(
            self.points, parity if exact else None, self.center, self.scale, name)
        # float64 copies for the export
        self.correction = (at, values, exponents, inverse)
        self.register_buffer("at", torch.as_tensor(at, dtype=dtype))
        self.register_buffer("values", torch.as_tensor(values, dtype=dtype))
        self.register_buffer("exponents", torch.as_tensor(exponents, dtype=dtype))
        self.register_buffer("inverse", torch.as_tensor(inverse, dtype=dtype))
        self.seen: list[float] | None = None

    # -- the unconstrained network -------------------------------------------
    def network(self, x: torch.Tensor) -> torch.Tensor:
        """Raw MLP on the scaled argument, 1-D in and out."""
        u = (x - self.center) / self.scale
        if self.monotone is None:
            return self.mlp(u.unsqueeze(-1)).squeeze(-1)
        h = u.unsqueeze(-1)
        for layer in self.mlp:
            if isinstance(layer, nn.Linear):
                h = nn.functional.linear(h, nn.functional.softplus(layer.weight), layer.bias)
            else:
                h = layer(h)
        h = h.squeeze(-1)
        return h if self.monotone == "increasing" else -h

    def weights(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """Each layer's effective weight and bias as float64 arrays.

        A monotone curve's weights are the softplus of its free ones;
        "decreasing" negates the last layer.
        """
        layers = []
        for layer in self.mlp:
            if isinstance(layer, nn.Linear):
                w = layer.weight.detach()
                if self.monotone is not None:
                    w = nn.functional.softplus(w)
                layers.append([w.cpu().double().numpy().copy(),
                               layer.bias.detach().cpu().double().numpy().copy()])
        if self.monotone == "decreasing":
            layers[-1] = [-layers[-1][0], -layers[-1][1]]
        return [(w, b) for w, b in layers]

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """The curve on a 1-D tensor of arguments."""
        if self.seen is not None:
            self._record(x)
        if not self.exact:
            return self.network(x)
        m = x.shape[0]
        k = self.at.shape[0]
        points = torch.cat([x, self.at]) if k else x
        out = self.network(torch.cat([points, -points]) if self.parity else points)
        if self.parity:
            sign = -1.0 if self.parity == "odd" else 1.0
            n_all = m + k
            plus, minus = out[:n_all], out[n_all:]
            out = 0.5 * (plus + sign * minus)
        g, g_at = out[:m], out[m:]
        if k:
            coefficients = self.inverse @ (self.values - g_at)
            u = (x - self.center) / self.scale
            g = g + torch.pow(u.unsqueeze(-1), self.exponents) @ coefficients
        return g

    def _record(self, x: torch.Tensor) -> None:
        finite = x[torch.isfinite(x)]
        if finite.numel():
            lo, hi = float(finite.min()), float(finite.max())
            self.seen = [min(self.seen[0], lo), max(self.seen[1], hi)]

    # -- soft constraints --------------------------------------------------------
    def penalty(self, grid: torch.Tensor) -> torch.Tensor:
        """Mean squared violation of the constraints (zero when they are exact)."""
        total = grid.new_zeros(())
        if self.exact:
            return total
        if self.parity:
            x = self.center + self.scale * grid
            sign = 1.0 if self.parity == "odd" else -1.0
            both = self.network(torch.cat([x, -x]))
            n = grid.shape[0]
            total = total + torch.mean((both[:n] + sign * both[n:]) ** 2) / 4.0
        if self.points:
            at = torch.tensor([a for a, _ in self.points], dtype=grid.dtype, device=grid.device)
            values = torch.tensor([v for _, v in self.points], dtype=grid.dtype,
                                  device=grid.device)
            total = total + torch.sum((self.network(at) - values) ** 2)
        if self.soft_monotone is not None:
            step = torch.diff(self.network(self.center + self.scale * grid))
            if self.soft_monotone == "decreasing":
                step = -step
            total = total + torch.mean(torch.relu(-step) ** 2) * grid.shape[0] ** 2
        return total

    # -- export ------------------------------------------------------------------
    def export(self, domain: tuple[float, float], extrapolation: str) -> NumpyCurve:
        """Export the network as a :class:`NumpyCurve` (weights copied to float64 on CPU)."""
        layers = self.weights()
        parity = self.parity if self.exact else None
        at, values, exponents, inverse = self.correction
        coefficients = np.zeros(0)
        if self.exact and at.size:
            bare = NumpyCurve(self.name, layers, self.activation, self.center, self.scale,
                              parity=parity, exponents=[], coefficients=[], domain=domain,
                              extrapolation=extrapolation)
            coefficients = inverse @ (values - bare.inside_value(at))
        else:
            exponents = np.zeros(0)
        if parity:
            reach = max(abs(domain[0]), abs(domain[1]))
            domain = (-reach, reach)
        return NumpyCurve(self.name, layers, self.activation, self.center, self.scale,
                          parity=parity, exponents=exponents, coefficients=coefficients,
                          domain=domain, extrapolation=extrapolation)


def _check_monotone(name: str, activation: str, parity: str | None, points) -> None:
    """A monotone network can meet a point value only by a shift: one point, or none when odd."""
    if activation not in MONOTONE_ACTIVATIONS:
        raise ValueError(f"{name} is monotone, which needs a non-decreasing activation "
                         f"({', '.join(MONOTONE_ACTIVATIONS)}); got {activation!r}")
    if parity == "odd" and any(at != 0.0 for at, _ in points):
        raise SkeletonError(f"an odd monotone {name} can pass through no point but the "
                            "origin in NeuralCCRegressor", kind="constraints")
    if parity is None and len({at for at, _ in points}) > 1:
        raise SkeletonError(f"a monotone {name} can pass through at most one given point in "
                            "NeuralCCRegressor", kind="constraints")


class SkeletonModule(nn.Module):
    """Weighted residuals of the skeleton's equations as a torch module.

    Built by skorch from ``module__*`` parameters.

    Parameters
    ----------
    residuals : list of Node
        Residual ``lhs - rhs`` of each equation that has something to fit.
    weights : list of float
        One scale per residual (the inverse RMS of its measured side).
    slots : mapping
        Column name -> position in the input matrix.
    curves : mapping
        Curve name -> ``dict(center=, scale=, parity=, points=)`` for its
        :class:`CurveNet` (curves pinned to zero by the gauge are absent).
    params : mapping
        Free parameter name -> initial value.
    fixed : mapping
        Parameters pinned by the gauge.
    bounds : mapping
        Parameter -> ``(low, high)``: held by reparametrisation
        (:class:`BoundedParameters`); ``params`` reads the bounded values.
    hidden_layer_sizes : sequence of int
    activation : str
    exact : bool
        Constraints by construction, or as penalties.
    seed : int
        Seed of the initial weights (a private generator; the global torch
        random state is not touched).
    dtype : torch.dtype
    """

    def __init__(self, residuals, weights, slots: Mapping[str, int],
                 curves: Mapping[str, dict], params: Mapping[str, float], *,
                 fixed: Mapping[str, float], hidden_layer_sizes: Sequence[int],
                 activation: str, exact: bool, seed: int, dtype: torch.dtype,
                 bounds: Mapping[str, tuple[float, float]] | None = None) -> None:
        super().__init__()
        generator = torch.Generator().manual_seed(int(seed))
        self.curves = nn.ModuleDict({
            name: CurveNet(name, hidden_layer_sizes, activation, spec["center"],
                           spec["scale"], parity=spec["parity"], points=spec["points"],
                           exact=exact, generator=generator,
                           dtype=dtype, monotone=spec.get("monotone"))
            for name, spec in curves.items()})
        bounds = dict(bounds or {})
        self.raw_params = nn.ParameterDict(
            {name: nn.Parameter(torch.tensor(BoundedParameters.unconstrained(
                float(v), *bounds.get(name, (-math.inf, math.inf))), dtype=dtype))
             for name, v in params.items()})
        self.params = BoundedParameters(self.raw_params, bounds)
        self.register_buffer("weights", torch.tensor(list(weights), dtype=dtype))
        self._residuals = [compile_torch(node, slots, self.curves, self.params, fixed)
                           for node in residuals]

    def forward(self, X: torch.Tensor) -> torch.Tensor:
        """Weighted residuals, shape ``(n_samples, n_residuals)``."""
        columns = X.unbind(1)
        n = X.shape[0]
        out = []
        for fn, w in zip(self._residuals, self.weights):
            r = fn(columns)
            if not isinstance(r, torch.Tensor) or r.ndim == 0:
                r = torch.as_tensor(r, dtype=X.dtype, device=X.device).expand(n)
            out.append(r * w)
        return torch.stack(out, dim=1)

    def penalty(self) -> torch.Tensor:
        """Sum of the curves' soft-constraint penalties."""
        grid = torch.linspace(-1.0, 1.0, 65, dtype=self.weights.dtype,
                              device=self.weights.device)
        total = self.weights.new_zeros(())
        for curve in self.curves.values():
            total = total + curve.penalty(grid)
        return total

    def record_ranges(self, X: torch.Tensor) -> dict[str, tuple[float, float]]:
        """Range of every curve's argument over ``X`` at the current parameters."""
        for curve in self.curves.values():
            curve.seen = [math.inf, -math.inf]
        try:
            with torch.no_grad():
                self.forward(X)
            ranges = {}
            for name, curve in self.curves.items():
                lo, hi = curve.seen
                ranges[name] = (lo, hi) if lo <= hi else (0.0, 0.0)
            return ranges
        finally:
            for curve in self.curves.values():
                curve.seen = None
