"""CPPN activation functions, as the original SharpNEAT 1.0 library defines them.

Each function works on numpy arrays and keeps their dtype, so float32 inputs give float32 signals (the original's
network signals are float32) and float64 inputs give a double-precision variant for analysis.  Every function has
a small integer code so an evaluation plan can be stored as plain arrays (usable from numba or JSON).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

Activation = Callable[[np.ndarray], np.ndarray]


def bipolar_sigmoid(x: np.ndarray) -> np.ndarray:
    """2/(1+e^(-4.9x)) - 1, range (-1, 1); the CPPN output nodes always use it."""
    t = x.dtype.type
    with np.errstate(over="ignore"):
        return t(2.0) / (t(1.0) + np.exp(t(-4.9) * x)) - t(1.0)


def sigmoid(x: np.ndarray) -> np.ndarray:
    """Steepened logistic 1/(1+e^(-4.9x)), range (0, 1); the substrate's node function and NEAT's XOR output."""
    t = x.dtype.type
    with np.errstate(over="ignore"):
        return t(1.0) / (t(1.0) + np.exp(t(-4.9) * x))


def gaussian(x: np.ndarray) -> np.ndarray:
    """2e^(-(2.5x)^2) - 1, range (-1, 1]: symmetric patterns."""
    t = x.dtype.type
    y = t(2.5) * x
    return t(2.0) * np.exp(-(y * y)) - t(1.0)


def absolute(x: np.ndarray) -> np.ndarray:
    """|x|; the original calls it "Linear" (its "(x+1)/2" comment is stale)."""
    return np.abs(x)


def sine(x: np.ndarray) -> np.ndarray:
    """sin(2x): repetition."""
    t = x.dtype.type
    return np.sin(t(2.0) * x)


def error_sign(x: np.ndarray) -> np.ndarray:
    """-1 if x <= -1e-4, 0 if |x| < 1e-4, +1 if x >= 1e-4 (the seed genome's node 609)."""
    t = x.dtype.type
    eps = t(0.0001)
    out = np.zeros_like(x)
    out[x >= eps] = t(1.0)
    out[x <= -eps] = t(-1.0)
    return out


def identity(x: np.ndarray) -> np.ndarray:
    """Pass-through; module input dummies use it."""
    return x


def zero(x: np.ndarray) -> np.ndarray:
    """Always 0: the original's ModuleOutputNeuron (and NullFn, never applied to bias/input nodes)."""
    return np.zeros_like(x)


#: name -> (code, function).  Codes are stable: they may be stored in plans and files.
ACTIVATIONS: dict[str, tuple[int, Activation]] = {
    "bipolar_sigmoid": (0, bipolar_sigmoid),
    "gaussian": (1, gaussian),
    "abs": (2, absolute),
    "sine": (3, sine),
    "error_sign": (4, error_sign),
    "identity": (5, identity),
    "zero": (6, zero),
    "sigmoid": (7, sigmoid),
    "null": (8, zero),
}

#: code -> function, indexable by the plan's activation codes.
BY_CODE: tuple[Activation, ...] = tuple(f for _, f in sorted(ACTIVATIONS.values(), key=lambda cf: cf[0]))


def activation_code(name: str) -> int:
    """The stable integer code of an activation name (ValueError if unknown)."""
    try:
        return ACTIVATIONS[name][0]
    except KeyError:
        raise ValueError(f"unknown activation function {name!r}; known: {sorted(ACTIVATIONS)}") from None
