"""Activation functions shared by the torch networks and their numpy export."""

from __future__ import annotations

import numpy as np
from scipy.special import erf, expit

__all__ = ["ACTIVATIONS", "is_smooth", "numpy_activation", "numpy_derivative",
           "torch_activation"]

_SQRT_HALF = float(np.sqrt(0.5))


def _relu(x):
    return np.maximum(x, 0.0)


#: torch's LeakyReLU default slope below zero
_LEAK = 0.01


def _leaky_relu(x):
    return np.where(x > 0.0, x, _LEAK * x)


def _silu(x):
    return x * expit(x)


def _elu(x):
    return np.where(x > 0.0, x, np.expm1(np.minimum(x, 0.0)))


def _softplus(x):
    # torch's Softplus switches to the identity above 20 (beta=1)
    return np.where(x > 20.0, x, np.logaddexp(0.0, x))


def _gelu(x):
    return 0.5 * x * (1.0 + erf(x * _SQRT_HALF))


# derivatives, as functions of the pre-activation z and the activation a = act(z)
def _d_tanh(z, a):
    return 1.0 - a * a


def _d_relu(z, a):
    return (z > 0.0).astype(float)


def _d_leaky_relu(z, a):
    return np.where(z > 0.0, 1.0, _LEAK)


def _d_silu(z, a):
    s = expit(z)
    return s * (1.0 + z * (1.0 - s))


def _d_elu(z, a):
    return np.where(z > 0.0, 1.0, a + 1.0)


def _d_softplus(z, a):
    return np.where(z > 20.0, 1.0, expit(z))


def _d_sigmoid(z, a):
    return a * (1.0 - a)


def _d_gelu(z, a):
    return 0.5 * (1.0 + erf(z * _SQRT_HALF)) + z * np.exp(-0.5 * z * z) / np.sqrt(2.0 * np.pi)


#: name -> (torch.nn module class name, numpy function, its derivative, smooth)
ACTIVATIONS: dict[str, tuple[str, object, object, bool]] = {
    "tanh": ("Tanh", np.tanh, _d_tanh, True),
    "relu": ("ReLU", _relu, _d_relu, False),
    "leaky_relu": ("LeakyReLU", _leaky_relu, _d_leaky_relu, False),
    "silu": ("SiLU", _silu, _d_silu, True),
    "elu": ("ELU", _elu, _d_elu, False),
    "softplus": ("Softplus", _softplus, _d_softplus, True),
    "sigmoid": ("Sigmoid", expit, _d_sigmoid, True),
    "gelu": ("GELU", _gelu, _d_gelu, True),
}


def torch_activation(name: str):
    """A fresh ``torch.nn`` activation module for ``name``."""
    import torch

    return getattr(torch.nn, ACTIVATIONS[name][0])()


def numpy_activation(name: str):
    """The numpy function of the activation ``name``."""
    return ACTIVATIONS[name][1]


def numpy_derivative(name: str):
    """``d(z, a)``: derivative of the activation at ``z`` given ``a = act(z)``."""
    return ACTIVATIONS[name][2]


def is_smooth(name: str) -> bool:
    """True when the activation has continuous derivatives of every order."""
    return ACTIVATIONS[name][3]
