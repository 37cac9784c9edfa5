"""Helpers shared by the least-squares modules of :mod:`uwtutor.lsq` (private to the package)."""

from __future__ import annotations


import numpy as np
from numpy.typing import ArrayLike

from .._validate import MAX_COORDINATE, as_finite, as_positive, as_scalar
from ..errors import IllConditionedWarning, warn
from .._linalg import line_of_sight as _line_of_sight

#: Singular-value ratio :math:`s_\mathrm{min}/s_\mathrm{max}` below which a design matrix counts as singular
#: (:math:`\kappa > 10^7`): the precision factor is then infinite and a fix is NaN.
SINGULAR_RTOL = 1e-7


def as_design(A: ArrayLike) -> np.ndarray:
    A = as_finite("A", A, max_abs=MAX_COORDINATE)
    if A.ndim < 2:
        raise ValueError(f"A must be a design matrix of shape (N, p) or a stack (..., N, p); got shape {A.shape}")
    if A.shape[-2] < 1 or A.shape[-1] < 1:
        raise ValueError(f"A must have at least one row and one column; got shape {A.shape}")
    if A.size == 0:
        raise ValueError(f"A has no matrices in its stack (shape {A.shape}): give at least one")
    return A


def scalar_or_array(a: np.ndarray) -> float | np.ndarray:
    return float(a) if np.ndim(a) == 0 else a


def alpha_from_singular_values(s: np.ndarray, n_cols: int) -> tuple[np.ndarray, np.ndarray]:
    """Precision factor and condition number from singular values ``s`` (..., q), q = min(N, p)."""
    smax = s[..., 0]
    smin = s[..., -1] if s.shape[-1] == n_cols else np.zeros(s.shape[:-1])   # fewer rows than columns: singular
    singular = ~(smin > SINGULAR_RTOL * smax)
    s_safe = np.where(s > SINGULAR_RTOL * smax[..., None], s, 1.0)        # the others make it singular anyway
    with np.errstate(divide="ignore", invalid="ignore"):
        alpha = np.where(singular, np.inf, np.sum(1.0 / s_safe**2, axis=-1))
        cond = np.where(singular | (smin == 0), np.inf, smax / np.where(smin > 0, smin, 1.0))
    # all-zero matrix: s_max = 0 makes both infinite as well
    return alpha, np.where(smax > 0, cond, np.inf)


def unit_los(positions: np.ndarray, beacons: np.ndarray, name: str) -> tuple[np.ndarray, np.ndarray]:
    """Unit line-of-sight rows (p - b)/|p - b| and distances; an error if a point sits on its beacon."""
    rho, los, defined = _line_of_sight(positions, beacons)
    if not defined.all():
        raise ValueError(f"{name} coincides with a beacon, where the range has no direction (its gradient is "
                         "undefined); move the linearization point off the beacon")
    return los, rho


def as_thresholds(max_condition: float, max_noise_gain: float) -> tuple[float, float]:
    mc = as_scalar("max_condition", max_condition, domain="positive")
    mg = as_scalar("max_noise_gain", max_noise_gain, domain="positive")
    if mc < 1.0:
        raise ValueError(f"max_condition must be >= 1 (a condition number is never below 1); got {mc:g}")
    return mc, mg


def warn_conditioning(cond: np.ndarray, gain: np.ndarray, max_condition: float, max_noise_gain: float,
                       what: str) -> np.ndarray:
    """Warn about singular and ill-conditioned problems; return the per-run ``well_conditioned`` flags."""
    cond = np.atleast_1d(cond)
    gain = np.atleast_1d(gain)
    singular = ~np.isfinite(cond)
    ill = ~singular & ((cond > max_condition) | (gain > max_noise_gain))
    total = cond.size
    runs = "" if total == 1 else f" in {{n}} of its {total} stacked problems"
    if singular.any():
        warn(f"{what} is singular{runs.format(n=int(singular.sum()))}: the design matrix does not "
                      "determine every unknown (too few epochs, no change of bearing, or collinear beacons); the "
                      "fix is NaN there", IllConditionedWarning)
    if ill.any():
        worst = int(np.argmax(np.where(ill, gain, -np.inf)))
        warn(f"{what} is ill-conditioned{runs.format(n=int(ill.sum()))}: condition number "
                      f"{cond[worst]:.3g} (limit {max_condition:g}), noise gain {gain[worst]:.3g} "
                      f"(limit {max_noise_gain:g}: a 1 m range error moves the fix by about that many metres); "
                      "the fix is unreliable", IllConditionedWarning)
    return ~(singular | ill)


def batched_lstsq(A: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Least squares of stacked problems through the SVD: solution (NaN if singular), alpha, cond, (A^T A)^-1."""
    U, s, Vt = np.linalg.svd(A, full_matrices=False)
    alpha, cond = alpha_from_singular_values(s, A.shape[-1])
    ok = np.isfinite(cond)
    s_safe = np.where(s > SINGULAR_RTOL * s[..., :1], s, 1.0)
    coef = np.einsum("...ni,...n->...i", U, y) / s_safe
    beta = np.einsum("...ij,...i->...j", Vt, coef)
    inv_normal = np.einsum("...ki,...k,...kj->...ij", Vt, 1.0 / s_safe**2, Vt)
    beta = np.where(ok[..., None], beta, np.nan)
    inv_normal = np.where(ok[..., None, None], inv_normal, np.inf)
    return beta, alpha, cond, inv_normal


def as_ranges_and_beacons(ranges: ArrayLike, beacons: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    r = as_finite("ranges", ranges, ndim=(1, 2), max_abs=MAX_COORDINATE)
    if np.any(r < 0):
        raise ValueError(f"ranges must be >= 0; got {r[r < 0].flat[0]:g}")
    b = as_finite("beacons", beacons, ndim=(2, 3), max_abs=MAX_COORDINATE)
    if b.shape[-1] != 2:
        raise ValueError(f"beacons must hold horizontal positions, shape (N, 2) or (M, N, 2); got {b.shape}")
    if b.shape[-2] != r.shape[-1]:
        raise ValueError(f"beacons must give one beacon per range: {b.shape[-2]} beacons for {r.shape[-1]} ranges")
    if r.shape[-1] == 0:
        raise ValueError(f"ranges is empty (shape {r.shape}): a fix needs ranges to at least as many beacons as "
                         "unknowns")
    return r, b


def sigma_and_cov(sigma: ArrayLike, residuals: np.ndarray, n_unknowns: int,
                   inv_normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    n = residuals.shape[-1]
    if sigma is None:
        with np.errstate(invalid="ignore", divide="ignore"):
            s = np.sqrt(np.sum(residuals**2, axis=-1) / (n - n_unknowns)) if n > n_unknowns \
                else np.full(residuals.shape[:-1], np.nan)
    else:
        s_in = as_positive("sigma", sigma)
        if np.any((s_in < 1e-150) | (s_in > 1e150)):     # sigma^2 times the inverse normal matrix stays finite
            raise ValueError(f"sigma must lie between 1e-150 and 1e150 (its square scales the covariance); got "
                             f"{s_in[(s_in < 1e-150) | (s_in > 1e150)].flat[0]:g}. Change its units")
        if s_in.shape not in ((), residuals.shape[:-1]):
            raise ValueError(f"sigma must be a number or one value per run, shape {residuals.shape[:-1]}; got shape "
                             f"{s_in.shape}")
        s = np.broadcast_to(s_in, residuals.shape[:-1]).astype(float)
    with np.errstate(invalid="ignore"):
        cov = s[..., None, None] ** 2 * inv_normal
    return s, cov
