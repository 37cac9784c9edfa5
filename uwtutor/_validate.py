"""Input validation shared by every public function of ``uwtutor``.

Each helper checks one argument and raises an error that names the argument, says what was wrong and what to do
about it. Public functions call these at their boundary so that bad input never turns into a silent wrong answer
deep inside a filter.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = [
    "as_float_array",
    "as_finite",
    "as_positive",
    "as_nonnegative",
    "as_range_array",
    "as_covariance",
    "as_rng",
    "as_int",
    "check_same_length",
]


def _first_bad_index(mask: np.ndarray) -> str:
    """Describe where the first True of ``mask`` sits, e.g. ``'index 12'`` or ``'index (3, 1)'``."""
    idx = np.argwhere(mask)[0]
    return f"index {int(idx[0])}" if idx.size == 1 else f"index {tuple(int(i) for i in idx)}"


def as_float_array(name: str, value: Any, *, ndim: int | tuple[int, ...] | None = None,
                   shape: tuple[int | None, ...] | None = None) -> np.ndarray:
    """Convert ``value`` to a float array, checking its number of dimensions or its shape.

    ``shape`` may use ``None`` for an axis of any length, e.g. ``(None, 2)`` for an array of 2-D points.
    """
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be numeric (a number or an array of numbers); got {type(value).__name__}") from exc
    if ndim is not None:
        allowed = (ndim,) if isinstance(ndim, int) else ndim
        if arr.ndim not in allowed:
            want = " or ".join(str(n) for n in allowed)
            raise ValueError(f"{name} must have {want} dimension(s); got shape {arr.shape}")
    if shape is not None:
        if arr.ndim != len(shape) or any(s is not None and s != a for s, a in zip(shape, arr.shape)):
            want = "(" + ", ".join("any" if s is None else str(s) for s in shape) + ")"
            raise ValueError(f"{name} must have shape {want}; got {arr.shape}")
    return arr


def as_finite(name: str, value: Any, **shape_kw: Any) -> np.ndarray:
    """A float array with no NaN or infinity (see :func:`as_float_array` for the shape keywords)."""
    arr = as_float_array(name, value, **shape_kw)
    bad = ~np.isfinite(arr)
    if bad.any():
        where = _first_bad_index(bad) if arr.ndim else "the value"
        raise ValueError(f"{name} must be finite; got {arr[bad].flat[0]} at {where}")
    return arr


def as_positive(name: str, value: Any, **shape_kw: Any) -> np.ndarray:
    """A finite array whose every element is > 0 (sound speeds, standard deviations that cannot be zero...)."""
    arr = as_finite(name, value, **shape_kw)
    bad = arr <= 0
    if bad.any():
        where = _first_bad_index(bad) if arr.ndim else "the value"
        raise ValueError(f"{name} must be > 0; got {arr[bad].flat[0]} at {where}")
    return arr


def as_nonnegative(name: str, value: Any, **shape_kw: Any) -> np.ndarray:
    """A finite array whose every element is >= 0 (standard deviations, durations, ...)."""
    arr = as_finite(name, value, **shape_kw)
    bad = arr < 0
    if bad.any():
        where = _first_bad_index(bad) if arr.ndim else "the value"
        raise ValueError(f"{name} must be >= 0; got {arr[bad].flat[0]} at {where}")
    return arr


def as_range_array(name: str, value: Any, *, allow_nan: bool = False, **shape_kw: Any) -> np.ndarray:
    """Measured ranges: finite and >= 0. With ``allow_nan`` a NaN marks a missing measurement (predict only)."""
    arr = as_float_array(name, value, **shape_kw)
    bad = np.isinf(arr) if allow_nan else ~np.isfinite(arr)
    bad |= arr < 0
    if bad.any():
        where = _first_bad_index(bad) if arr.ndim else "the value"
        missing = "; use NaN for a missing range" if allow_nan else ""
        raise ValueError(f"{name} must be finite and >= 0{missing}; got {arr[bad].flat[0]} at {where}")
    return arr


def as_covariance(name: str, value: Any, n: int | None = None, *, allow_singular: bool = False) -> np.ndarray:
    """A symmetric positive-definite (or, with ``allow_singular``, semi-definite) ``(n, n)`` matrix.

    A scalar is accepted for ``n == 1``. Stacks ``(..., n, n)`` are checked matrix by matrix.
    """
    P = as_finite(name, value)
    if P.ndim == 0:
        P = P.reshape(1, 1)
    if P.ndim < 2 or P.shape[-1] != P.shape[-2]:
        raise ValueError(f"{name} must be a square matrix; got shape {P.shape}")
    if n is not None and P.shape[-1] != n:
        raise ValueError(f"{name} must be {n}x{n} to match the state; got {P.shape[-2]}x{P.shape[-1]}")
    scale = max(1.0, float(np.max(np.abs(P))))
    if not np.allclose(P, np.swapaxes(P, -1, -2), rtol=1e-9, atol=1e-12 * scale):
        raise ValueError(f"{name} must be symmetric; use (P + P.T) / 2 if it is only off by rounding")
    eig_min = np.linalg.eigvalsh(P).min()
    tol = -1e-12 * scale if allow_singular else 0.0
    if (eig_min < tol) if allow_singular else (eig_min <= tol):
        kind = "positive semi-definite" if allow_singular else "positive definite"
        raise ValueError(f"{name} must be {kind}; its smallest eigenvalue is {eig_min:.3g}. "
                         "Check the variances on its diagonal and that correlations lie within [-1, 1]")
    return P


def as_rng(rng: Any) -> np.random.Generator:
    """Insist on an explicit :class:`numpy.random.Generator` so that every result is reproducible."""
    if not isinstance(rng, np.random.Generator):
        raise TypeError("rng must be a numpy.random.Generator, e.g. numpy.random.default_rng(42); "
                        f"got {type(rng).__name__}. uwtutor never uses the global random state")
    return rng


def as_int(name: str, value: Any, *, minimum: int | None = None) -> int:
    """An integer (``numpy`` integers accepted), optionally at least ``minimum``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an integer; got {value!r}")
    if minimum is not None and value < minimum:
        raise ValueError(f"{name} must be >= {minimum}; got {value}")
    return int(value)


def check_same_length(**arrays: np.ndarray) -> int:
    """Check that the given arrays agree on the length of their first axis and return it."""
    lengths = {name: len(a) for name, a in arrays.items()}
    if len(set(lengths.values())) > 1:
        described = ", ".join(f"{name} has {n}" for name, n in lengths.items())
        raise ValueError(f"arrays must have the same length along their first axis: {described}")
    return next(iter(lengths.values()))
