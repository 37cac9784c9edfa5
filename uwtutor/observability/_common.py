"""What the observability modules share: the rank tolerance, the warning, argument checks, a batch of bounds."""

from __future__ import annotations

from typing import Any

import numpy as np

from .._validate import (
    as_in_range,
    as_positive,
    as_scalar,
)
from ..errors import UnobservableWarning, warn

#: Relative tolerance on the singular values of a column-scaled Jacobian (on the square roots of the eigenvalues of
#: a diagonally scaled information matrix) below which a direction counts as unobservable, because its standard
#: deviation would be amplified more than a million times. Exact degeneracies give about 1e-8 here or less, so the
#: default separates them cleanly from poor but genuine geometry.
DEFAULT_RTOL = 1e-6


# Entries of the projector on the unobservable subspace below this count as zero (rounding).
_NULL_ENTRY_TOL = 1e-8


def _warn(message: str) -> None:
    """Emit an ``UnobservableWarning`` attributed to the first caller outside this module (the user's line)."""
    warn(message, UnobservableWarning)


def _as_rtol(rtol: Any) -> float:
    r = as_scalar("rtol", rtol, domain="positive")
    if r >= 1:
        raise ValueError(f"rtol must be < 1 (a relative tolerance such as 1e-6); got {r}")
    return r


def _broadcast(name_a: str, a: np.ndarray, name_b: str, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    try:
        a_b, b_a = np.broadcast_arrays(a, b)
        return a_b, b_a
    except ValueError:
        raise ValueError(f"{name_a} of shape {a.shape} does not broadcast against {name_b} of shape "
                         f"{b.shape}") from None


def _describe_direction(v: np.ndarray, labels: list[str]) -> str:
    v = v / np.max(np.abs(v))
    parts = [f"{c:+.2f} {lab}" for c, lab in zip(v, labels) if abs(c) > 5e-3]
    return "[" + ", ".join(parts) + "]"


def _state_labels(n: int, unknown_bias: bool = False, unknown_current: bool = False) -> list[str]:
    labels = ["x", "y"]
    if unknown_bias:
        labels.append("bias")
    if unknown_current:
        labels += ["Ux", "Uy"]
    if len(labels) != n:
        labels = [f"x{i}" for i in range(n)]
    return labels


def _sigma_per_row(sigma: Any, shape: tuple[int, ...]) -> np.ndarray:
    # 1 / sigma^2 must stay a float64 (1e-300 .. 1e300) for the information to mean anything
    s = as_in_range("sigma", as_positive("sigma", sigma), 1e-150, 1e150)
    try:
        return np.broadcast_to(s, shape)
    except ValueError:
        raise ValueError(f"sigma must be a number or one standard deviation per range (shape {shape}); got shape "
                         f"{s.shape}") from None


def _as_reference(reference: Any, k: int) -> int:
    if isinstance(reference, bool) or not isinstance(reference, (int, np.integer)) or not -k <= reference < k:
        raise ValueError(f"reference must be an epoch index in [{-k}, {k - 1}]; got {reference!r}")
    return int(reference) % k


def _bound_batch(info: np.ndarray, rtol: float) -> tuple[np.ndarray, np.ndarray, list[tuple[int, np.ndarray]]]:
    """Bounds and ranks of a stack (..., n, n); the list holds (flat index, null vectors) of the singular ones."""
    n = info.shape[-1]
    flat = info.reshape(-1, n, n)
    bounds = np.empty_like(flat)
    ranks = np.full(len(flat), n, dtype=int)
    # scale to a unit diagonal (a state with no information keeps a zero row and column: a null direction)
    d = np.sqrt(np.clip(np.diagonal(flat, axis1=-2, axis2=-1), 0.0, None))
    safe = np.where(d > 0, d, 1.0)
    scaled = flat / (safe[:, :, None] * safe[:, None, :])
    lam, vec = np.linalg.eigh((scaled + np.swapaxes(scaled, -1, -2)) / 2)
    top = np.maximum(lam[:, -1], np.finfo(float).tiny)
    regular = np.all(lam > rtol ** 2 * top[:, None], axis=-1)
    if regular.any():
        lr, vr, dr = lam[regular], vec[regular], safe[regular]
        inv = np.einsum("kij,kj,klj->kil", vr, 1.0 / lr, vr) / (dr[:, :, None] * dr[:, None, :])
        bounds[regular] = (inv + np.swapaxes(inv, -1, -2)) / 2
    singular: list[tuple[int, np.ndarray]] = []
    # singular: grouped by the number m of null directions (eigh sorts them first, the m smallest eigenvalues)
    n_null = np.count_nonzero(lam <= rtol ** 2 * top[:, None], axis=-1)
    for m in range(1, n + 1):
        group = np.flatnonzero(~regular & (n_null == m))
        if group.size == 0:
            continue
        lg, vg, dg = lam[group], vec[group], safe[group]
        inv_l = np.where(np.arange(n) >= m, 1.0 / np.where(np.arange(n) >= m, lg, 1.0), 0.0)
        g = np.einsum("kij,kj,klj->kil", vg, inv_l, vg) / (dg[:, :, None] * dg[:, None, :])
        null = vg[:, :, :m] / dg[:, :, None]                       # null vectors in original coordinates
        q, _ = np.linalg.qr(null)
        proj = q @ np.swapaxes(q, -1, -2)
        keep = np.eye(n) - proj
        b = keep @ g @ keep
        b = (b + np.swapaxes(b, -1, -2)) / 2
        infinite = np.abs(proj) > _NULL_ENTRY_TOL
        b[infinite] = np.copysign(np.inf, proj[infinite])
        bounds[group] = b
        ranks[group] = n - m
        singular.extend((int(i), null[j]) for j, i in enumerate(group))
    singular.sort(key=lambda item: item[0])
    return bounds.reshape(info.shape), ranks.reshape(info.shape[:-2]), singular


def _warn_singular(singular: list[tuple[int, np.ndarray]], total: int, n: int, labels: list[str]) -> None:
    if not singular:
        return
    index, null = singular[0]
    dirs = "; ".join(_describe_direction(v, labels) for v in null.T)
    rank = n - null.shape[1]
    where = (f" (rank {rank} of {n})" if total == 1 else
             f" in {len(singular)} of {total} matrices (the first, index {index}, has rank {rank} of {n})")
    _warn(f"the Fisher information is singular{where}. Unobservable direction(s) in "
          f"({', '.join(labels)}): {dirs}. The bound is infinite along them (entries set to inf); only the "
          "finite entries are bounds of estimable quantities")
