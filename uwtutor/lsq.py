r"""Least squares before filtering: a first fix, and an honest measure of how good it is.

A filter needs a starting point. The three methods of this module find one from a batch of ranges and
dead-reckoned (DR) displacements, and each says how far it can be trusted:

=================================  ==================================================================================
``linearized_lsq``                 Gauss-Newton steps of range least squares about a provisional position, with an
                                   optional constant range bias; reports paper A's precision factor
``prepositioning``                 paper A's pre-positioning: the same on a DR track (virtual beacons), fix *now*
``nonlinear_lsq``                  the reference: ``scipy.optimize.least_squares`` on the exact range model
``precision_factor``               :math:`\alpha = \operatorname{tr}(A^\mathsf{T}A)^{-1} = \sum_i 1/\lambda_i`
``condition_number``               :math:`\kappa(A) = s_\mathrm{max}/s_\mathrm{min}` (singular values of A)
``precision_factor_history``       :math:`\alpha` after each epoch along a track (paper A, Fig. 2)
``prelocation_cost``               paper D's travel-time cost over a grid of start bearing and sound-speed error
``grid_prelocation``               paper D's grid-search pre-location, at every epoch, batched over runs
``prelocation_acceptance``         paper D's two acceptance conditions (a heading change; K stable fixes)
``virtual_beacon_lsq``             paper E's virtual-beacon (VMLBL) fix from pairwise-differenced spheres
=================================  ==================================================================================

**Linearized range least squares** (Liu et al., paper A). A range to beacon :math:`b_i` (a real beacon, or a
*virtual* one: the beacon moved by the vehicle's DR displacement since epoch :math:`i`) with a constant bias
:math:`\upsilon` is :math:`r_i = \lVert p - b_i \rVert + \upsilon + \eta_i`. About a provisional position
:math:`p_0`, with :math:`\rho_i = \lVert p_0 - b_i \rVert` and the unit line of sight
:math:`h_i = (p_0 - b_i)^\mathsf{T}/\rho_i`,

.. math::

    r_i - \rho_i \approx h_i\,\delta p + \upsilon + \eta_i, \qquad
    y = A\beta + \eta, \quad A = \begin{bmatrix} h_1 & 1 \\ \vdots & \vdots \\ h_N & 1 \end{bmatrix},
    \quad \beta = \begin{bmatrix} \delta p \\ \upsilon \end{bmatrix},

so :math:`\hat\beta = (A^\mathsf{T}A)^{-1}A^\mathsf{T}y`, :math:`\hat p = p_0 + \delta\hat p`, and for white noise of
variance :math:`\sigma^2` :math:`\operatorname{Cov}\hat\beta = \sigma^2 (A^\mathsf{T}A)^{-1}`: the mean squared error
of the three unknowns is :math:`\alpha\sigma^2`, with the **precision factor**
:math:`\alpha = \operatorname{tr}(A^\mathsf{T}A)^{-1} = \sum_i 1/\lambda_i(A^\mathsf{T}A)` (paper A, eqs. 10-11).
Paper A trusts the fix, and starts its filter, once :math:`\alpha < 2`. The same covariance is the Cramér-Rao bound of
position and bias (chapter 2), so :math:`\alpha\sigma^2` is the trace of that bound.

**Ill-conditioned problems warn, never fail silently.** Every fix carries its precision factor, the condition
number :math:`\kappa(A)` and a *noise gain* (RMS error of the unknowns per unit range noise). A problem whose
:math:`\kappa` exceeds ``max_condition`` or whose noise gain exceeds ``max_noise_gain`` gives its fix with an
:class:`IllConditionedWarning`; a singular one (:math:`\kappa > 10^7`: too few epochs, no change of bearing,
collinear virtual beacons) gives NaN with the warning.

References
----------
Liu J., Han S., Xu J., Yang G. "An improved EKF positioning algorithm for underwater acoustic beacon" (paper A),
sec. 1.2, eqs. (3)-(11).
Zhu Z., Han S., Guo Z., Liu J. (2019). "Single beacon location algorithm based on nonlinear fading filter under
multiplicative noise background". J. Electronics & Information Technology 41(1), 165-171 (paper D), sec. 3.1, eq. (6)-(7).
Paper E (VMLBL for the manned submersible *Jiaolong*), sec. 1.2, eqs. (14)-(17).
Björck, Å. (1996). *Numerical Methods for Least Squares Problems*. SIAM (conditioning of least squares).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

from ._validate import as_finite, as_float_array, as_int, as_positive
from .errors import IllConditionedWarning
from .models.range import line_of_sight

__all__ = [
    "IllConditionedWarning",
    "SINGULAR_RTOL",
    "precision_factor",
    "condition_number",
    "precision_factor_history",
    "LSQFix",
    "linearized_lsq",
    "prepositioning",
    "nonlinear_lsq",
    "Prelocation",
    "prelocation_cost",
    "grid_prelocation",
    "PrelocationAcceptance",
    "prelocation_acceptance",
    "VirtualBeaconFix",
    "virtual_beacon_lsq",
]

#: Singular-value ratio :math:`s_\mathrm{min}/s_\mathrm{max}` below which a design matrix counts as singular
#: (:math:`\kappa > 10^7`): the precision factor is then infinite and a fix is NaN.
SINGULAR_RTOL = 1e-7

#: Largest elements of one intermediate array of the grid search (runs are processed in chunks below it).
_GRID_CHUNK_ELEMENTS = 4_000_000




# ---------------------------------------------------------------------------------------------------------------
# conditioning
# ---------------------------------------------------------------------------------------------------------------

def _as_design(A: Any) -> np.ndarray:
    A = as_finite("A", A)
    if A.ndim < 2:
        raise ValueError(f"A must be a design matrix of shape (N, p) or a stack (..., N, p); got shape {A.shape}")
    if A.shape[-2] < 1 or A.shape[-1] < 1:
        raise ValueError(f"A must have at least one row and one column; got shape {A.shape}")
    return A


def _scalar_or_array(a: np.ndarray) -> float | np.ndarray:
    return float(a) if np.ndim(a) == 0 else a


def _alpha_from_singular_values(s: np.ndarray, n_cols: int) -> tuple[np.ndarray, np.ndarray]:
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


def precision_factor(A: Any) -> float | np.ndarray:
    r"""Paper A's precision factor :math:`\alpha = \operatorname{tr}\,(A^\mathsf{T}A)^{-1} = \sum_i 1/\lambda_i`.

    For the linear model :math:`y = A\beta + \eta` with white noise of variance :math:`\sigma^2`, the least-squares
    estimate has covariance :math:`\sigma^2 (A^\mathsf{T}A)^{-1}`, so its mean squared error (summed over the
    unknowns) is :math:`\alpha\sigma^2` (paper A, eq. 11; paper A writes the matrix :math:`X`). :math:`\alpha` is
    computed from the singular values :math:`s_i` of :math:`A` (:math:`\lambda_i = s_i^2`), which is accurate even
    when :math:`A^\mathsf{T}A` is nearly singular.

    Parameters
    ----------
    A : array_like, shape (N, p) or (..., N, p)
        Design (regressor) matrix, or a stack of them (e.g. one per Monte Carlo run).

    Returns
    -------
    float or ndarray, shape (...)
        :math:`\alpha`; ``inf`` where :math:`A` is singular (rank below ``p``, or
        :math:`s_\mathrm{min} \le 10^{-7} s_\mathrm{max}`, see ``SINGULAR_RTOL``).

    Examples
    --------
    Four ranges from bearings 0, 90, 180 and 270 degrees, with a bias column: :math:`A^\mathsf{T}A =
    \operatorname{diag}(2, 2, 4)`, so :math:`\alpha = 1/2 + 1/2 + 1/4`.

    >>> import numpy as np
    >>> from uwtutor.lsq import precision_factor
    >>> phi = np.radians([0.0, 90.0, 180.0, 270.0])
    >>> A = np.column_stack([np.cos(phi), np.sin(phi), np.ones(4)])
    >>> round(precision_factor(A), 12)
    1.25
    """
    A = _as_design(A)
    s = np.linalg.svd(A, compute_uv=False)
    alpha, _ = _alpha_from_singular_values(s, A.shape[-1])
    return _scalar_or_array(alpha)


def condition_number(A: Any) -> float | np.ndarray:
    r"""Condition number :math:`\kappa(A) = s_\mathrm{max}/s_\mathrm{min}` of a design matrix (2-norm).

    A relative error in the data can be magnified up to about :math:`\kappa` times in the least-squares solution
    (:math:`\kappa^2` when the normal equations are formed). It measures how close :math:`A` is to losing rank
    (columns nearly dependent: no change of bearing, collinear virtual beacons), independently of the number of
    rows; the precision factor measures the resulting noise, and shrinks as rows are added.

    Parameters
    ----------
    A : array_like, shape (N, p) or (..., N, p)
        Design matrix or stack of them.

    Returns
    -------
    float or ndarray, shape (...)
        :math:`\kappa(A) \ge 1`; ``inf`` where :math:`A` is singular (see ``SINGULAR_RTOL``).
    """
    A = _as_design(A)
    s = np.linalg.svd(A, compute_uv=False)
    _, cond = _alpha_from_singular_values(s, A.shape[-1])
    return _scalar_or_array(cond)


def _unit_los(positions: np.ndarray, beacons: np.ndarray, name: str) -> tuple[np.ndarray, np.ndarray]:
    """Unit line-of-sight rows (p - b)/|p - b| and distances; an error if a point sits on its beacon."""
    rho, los, defined = line_of_sight(positions, beacons)
    if not defined.all():
        raise ValueError(f"{name} coincides with a beacon, where the range has no direction (its gradient is "
                         "undefined); move the linearization point off the beacon")
    return los, rho


def precision_factor_history(positions: Any, beacon: Any = (0.0, 0.0), unknown_bias: bool = True) -> np.ndarray:
    r"""The precision factor after each epoch along a track: :math:`\alpha_k` from the rows of epochs 1..k.

    With the rows :math:`a_i = [h_i, 1]` (unit line of sight from the beacon, and the bias column when
    ``unknown_bias``) evaluated at the given positions, the normal matrix after :math:`k` epochs is the running sum
    :math:`A_k^\mathsf{T}A_k = \sum_{i \le k} a_i^\mathsf{T} a_i`, and
    :math:`\alpha_k = \sum_j 1/\lambda_j(A_k^\mathsf{T}A_k)` (paper A, Fig. 2: :math:`\alpha` against the number of
    observations). Evaluated on the true track it is the geometry's verdict; on a provisional track shifted by a
    few tens of metres it barely changes when the ranges are long.

    Parameters
    ----------
    positions : array_like, shape (K, 2) or (M, K, 2)
        Positions at the epochs [m] (true or provisional), one track or a batch.
    beacon : array_like, shape (2,) or (K, 2), optional
        Beacon position [m], fixed (the origin by default) or one per epoch.
    unknown_bias : bool, default True
        Include paper A's bias column (three unknowns); ``False`` gives the position-only GDOP squared.

    Returns
    -------
    ndarray, shape (K,) or (M, K)
        :math:`\alpha_k`; ``inf`` while the rows do not yet determine every unknown (fewer epochs than unknowns, or
        no change of bearing yet).
    """
    p = as_finite("positions", positions, ndim=(2, 3))
    if p.shape[-1] != 2:
        raise ValueError(f"positions must have shape (K, 2) or (M, K, 2); got {p.shape}")
    b = as_finite("beacon", beacon)
    if b.shape not in ((2,), p.shape[-2:]):
        raise ValueError(f"beacon must have shape (2,) or {p.shape[-2:]} (one position per epoch); got {b.shape}")
    h, _ = _unit_los(p, b, "a position")
    rows = np.concatenate([h, np.ones(h.shape[:-1] + (1,))], axis=-1) if unknown_bias else h
    info = np.cumsum(rows[..., :, None] * rows[..., None, :], axis=-3)     # (..., K, n, n)
    lam = np.linalg.eigvalsh(info)                                         # ascending
    # eigenvalues of A^T A are squared singular values: the same singularity rule as precision_factor
    singular = ~(lam[..., 0] > SINGULAR_RTOL**2 * lam[..., -1])
    with np.errstate(divide="ignore"):
        alpha = np.sum(1.0 / np.where(lam > 0, lam, 1.0), axis=-1)
    return np.where(singular, np.inf, alpha)


# ---------------------------------------------------------------------------------------------------------------
# linearized and nonlinear range least squares
# ---------------------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class LSQFix:
    r"""A least-squares fix with its quality (returned by ``linearized_lsq``, ``prepositioning``,
    ``nonlinear_lsq``).

    Shapes: ``N`` ranges, ``p`` unknowns (2, or 3 with the bias), and a leading runs axis ``M`` when the inputs had
    one.

    Attributes
    ----------
    estimate : ndarray, shape (p,) or (M, p)
        The unknowns ``[x, y]`` or ``[x, y, bias]`` [m]; NaN where the problem is singular.
    position : ndarray, shape (2,) or (M, 2)
        The position part of ``estimate`` [m].
    bias : ndarray or None
        The range bias [m], shape () or (M,); ``None`` without ``unknown_bias``.
    covariance : ndarray, shape (p, p) or (M, p, p)
        :math:`\sigma^2 (A^\mathsf{T}A)^{-1}` [m²], with the given ``sigma`` or, if none was given, the residual
        estimate :math:`\hat\sigma^2 = \sum e_i^2 / (N - p)` (NaN when :math:`N = p`).
    sigma : ndarray
        The :math:`\sigma` used there [m], shape () or (M,).
    alpha : ndarray
        Precision factor :math:`\operatorname{tr}(A^\mathsf{T}A)^{-1}`, shape () or (M,).
    condition_number : ndarray
        :math:`\kappa(A)`, shape () or (M,).
    noise_gain : ndarray
        :math:`\sqrt\alpha`: RMS error of the unknowns per unit of white range noise, shape () or (M,).
    residuals : ndarray, shape (N,) or (M, N)
        Range residuals at the fix, :math:`r_i - \lVert\hat p - b_i\rVert - \hat\upsilon` [m].
    design : ndarray, shape (N, p) or (M, N, p)
        The design matrix :math:`A` of the last linearization.
    iterations : int
        Gauss-Newton steps taken (``linearized_lsq``) or function evaluations (``nonlinear_lsq``).
    well_conditioned : ndarray
        Boolean, shape () or (M,): :math:`\kappa \le` ``max_condition`` and noise gain :math:`\le`
        ``max_noise_gain``.
    """

    estimate: np.ndarray
    position: np.ndarray
    bias: np.ndarray | None
    covariance: np.ndarray
    sigma: np.ndarray
    alpha: np.ndarray
    condition_number: np.ndarray
    noise_gain: np.ndarray
    residuals: np.ndarray
    design: np.ndarray
    iterations: int
    well_conditioned: np.ndarray

    def trusted(self, max_alpha: float = 2.0) -> np.ndarray:
        r"""Paper A's acceptance test :math:`\alpha <` ``max_alpha`` (2 in the paper), per run."""
        return np.asarray(self.alpha < float(as_positive("max_alpha", max_alpha)))


def _as_thresholds(max_condition: Any, max_noise_gain: Any) -> tuple[float, float]:
    mc = float(as_positive("max_condition", max_condition, ndim=0))
    mg = float(as_positive("max_noise_gain", max_noise_gain, ndim=0))
    if mc < 1.0:
        raise ValueError(f"max_condition must be >= 1 (a condition number is never below 1); got {mc:g}")
    return mc, mg


def _warn_conditioning(cond: np.ndarray, gain: np.ndarray, max_condition: float, max_noise_gain: float,
                       what: str, stacklevel: int = 3) -> np.ndarray:
    """Warn about singular and ill-conditioned problems; return the per-run ``well_conditioned`` flags."""
    cond = np.atleast_1d(cond)
    gain = np.atleast_1d(gain)
    singular = ~np.isfinite(cond)
    ill = ~singular & ((cond > max_condition) | (gain > max_noise_gain))
    total = cond.size
    runs = "" if total == 1 else f" in {{n}} of its {total} stacked problems"
    if singular.any():
        warnings.warn(f"{what} is singular{runs.format(n=int(singular.sum()))}: the design matrix does not "
                      "determine every unknown (too few epochs, no change of bearing, or collinear beacons); the "
                      "fix is NaN there", IllConditionedWarning, stacklevel=stacklevel)
    if ill.any():
        worst = int(np.argmax(np.where(ill, gain, -np.inf)))
        warnings.warn(f"{what} is ill-conditioned{runs.format(n=int(ill.sum()))}: condition number "
                      f"{cond[worst]:.3g} (limit {max_condition:g}), noise gain {gain[worst]:.3g} "
                      f"(limit {max_noise_gain:g}: a 1 m range error moves the fix by about that many metres); "
                      "the fix is unreliable", IllConditionedWarning, stacklevel=stacklevel)
    return ~(singular | ill)


def _batched_lstsq(A: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Least squares of stacked problems through the SVD: solution (NaN if singular), alpha, cond, (A^T A)^-1."""
    U, s, Vt = np.linalg.svd(A, full_matrices=False)
    alpha, cond = _alpha_from_singular_values(s, A.shape[-1])
    ok = np.isfinite(cond)
    s_safe = np.where(s > SINGULAR_RTOL * s[..., :1], s, 1.0)
    coef = np.einsum("...ni,...n->...i", U, y) / s_safe
    beta = np.einsum("...ij,...i->...j", Vt, coef)
    inv_normal = np.einsum("...ki,...k,...kj->...ij", Vt, 1.0 / s_safe**2, Vt)
    beta = np.where(ok[..., None], beta, np.nan)
    inv_normal = np.where(ok[..., None, None], inv_normal, np.inf)
    return beta, alpha, cond, inv_normal


def _as_ranges_and_beacons(ranges: Any, beacons: Any) -> tuple[np.ndarray, np.ndarray]:
    r = as_finite("ranges", ranges, ndim=(1, 2))
    if np.any(r < 0):
        raise ValueError(f"ranges must be >= 0; got {r[r < 0].flat[0]:g}")
    b = as_finite("beacons", beacons, ndim=(2, 3))
    if b.shape[-1] != 2:
        raise ValueError(f"beacons must hold horizontal positions, shape (N, 2) or (M, N, 2); got {b.shape}")
    if b.shape[-2] != r.shape[-1]:
        raise ValueError(f"beacons must give one beacon per range: {b.shape[-2]} beacons for {r.shape[-1]} ranges")
    return r, b


def _runs_of(**shapes: int | None) -> int | None:
    sizes = {k: v for k, v in shapes.items() if v is not None}
    if len(set(sizes.values())) > 1:
        described = ", ".join(f"{k} has {v}" for k, v in sizes.items())
        raise ValueError(f"the arguments with a leading runs axis disagree on the number of runs M: {described}")
    return next(iter(sizes.values()), None)


def _sigma_and_cov(sigma: Any, residuals: np.ndarray, n_unknowns: int,
                   inv_normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    n = residuals.shape[-1]
    if sigma is None:
        with np.errstate(invalid="ignore", divide="ignore"):
            s = np.sqrt(np.sum(residuals**2, axis=-1) / (n - n_unknowns)) if n > n_unknowns \
                else np.full(residuals.shape[:-1], np.nan)
    else:
        s = np.broadcast_to(as_positive("sigma", sigma), residuals.shape[:-1]).astype(float)
    with np.errstate(invalid="ignore"):
        cov = s[..., None, None] ** 2 * inv_normal
    return s, cov


def linearized_lsq(ranges: Any, beacons: Any, provisional: Any, *, unknown_bias: bool = True, iterations: int = 1,
                   sigma: Any = None, max_condition: float = 1e3, max_noise_gain: float = 100.0) -> LSQFix:
    r"""Range least squares linearized about a provisional position (paper A's pre-positioning step).

    Model :math:`r_i = \lVert p - b_i\rVert + \upsilon + \eta_i` (the bias :math:`\upsilon` only with
    ``unknown_bias``). Each Gauss-Newton step linearizes at the current estimate :math:`(p_0, \upsilon_0)`:

    .. math::

        y_i = r_i - \lVert p_0 - b_i\rVert - \upsilon_0, \qquad a_i = \Big[\frac{(p_0 - b_i)^\mathsf{T}}
        {\lVert p_0 - b_i\rVert},\ 1\Big], \qquad
        \begin{bmatrix}\delta p \\ \delta\upsilon\end{bmatrix} = (A^\mathsf{T}A)^{-1}A^\mathsf{T}y,

    then :math:`p_0 \leftarrow p_0 + \delta p`, :math:`\upsilon_0 \leftarrow \upsilon_0 + \delta\upsilon`
    (starting from :math:`\upsilon_0 = 0`). Paper A takes one step (``iterations=1``); more steps converge to the
    nonlinear least-squares fix when the problem is well conditioned. The sign convention is the one above (the
    correction is *added* to the provisional position); paper A's extracted eqs. (3)-(9) mix two conventions.

    The solution uses the SVD of :math:`A` (no normal equations), so :math:`\alpha` and :math:`\kappa(A)` come out
    accurately even when the geometry is poor.

    Parameters
    ----------
    ranges : array_like, shape (N,) or (M, N)
        Measured ranges [m], >= 0.
    beacons : array_like, shape (N, 2) or (M, N, 2)
        The beacon of each range [m]: real beacons, or virtual beacons of a track (see ``prepositioning``).
    provisional : array_like, shape (2,) or (M, 2)
        The provisional position :math:`p_0` [m] (not on a beacon).
    unknown_bias : bool, default True
        Estimate a constant range bias (paper A's third unknown).
    iterations : int, default 1
        Number of Gauss-Newton steps (>= 1).
    sigma : float or array_like, optional
        Range noise standard deviation [m] for the covariance; estimated from the residuals when omitted.
    max_condition : float, default 1e3
        Condition number above which an ``IllConditionedWarning`` is given.
    max_noise_gain : float, default 100
        Noise gain :math:`\sqrt\alpha` above which an ``IllConditionedWarning`` is given.

    Returns
    -------
    LSQFix
        The fix, its covariance, :math:`\alpha`, :math:`\kappa(A)` and residuals, with a runs axis if any input had
        one.

    Warns
    -----
    IllConditionedWarning
        When :math:`\kappa(A) >` ``max_condition`` or :math:`\sqrt\alpha >` ``max_noise_gain``, and when a problem
        is singular (its fix is then NaN).

    Examples
    --------
    Four beacons around the vehicle, ranges 5 m too long (a bias), provisional position 20 m off:

    >>> import numpy as np
    >>> from uwtutor.lsq import linearized_lsq
    >>> beacons = np.array([[1000.0, 0.0], [0.0, 1000.0], [-1000.0, 0.0], [0.0, -1000.0]])
    >>> truth = np.array([30.0, -40.0])
    >>> r = np.linalg.norm(truth - beacons, axis=1) + 5.0
    >>> fix = linearized_lsq(r, beacons, provisional=[10.0, -30.0], iterations=3)
    >>> np.round(fix.position, 6), round(float(fix.bias), 6), round(float(fix.alpha), 3)
    (array([ 30., -40.]), 5.0, 1.251)
    """
    r, b = _as_ranges_and_beacons(ranges, beacons)
    p0 = as_finite("provisional", provisional, ndim=(1, 2))
    if p0.shape[-1] != 2:
        raise ValueError(f"provisional must be a position [x, y], shape (2,) or (M, 2); got {p0.shape}")
    steps = as_int("iterations", iterations, minimum=1)
    mc, mg = _as_thresholds(max_condition, max_noise_gain)
    M = _runs_of(ranges=r.shape[0] if r.ndim == 2 else None, beacons=b.shape[0] if b.ndim == 3 else None,
                 provisional=p0.shape[0] if p0.ndim == 2 else None)
    batched = M is not None
    Mb = M or 1
    N = r.shape[-1]
    r = np.broadcast_to(r, (Mb, N))
    b = np.broadcast_to(b, (Mb, N, 2))
    p = np.array(np.broadcast_to(p0, (Mb, 2)), dtype=float)
    n_unknowns = 3 if unknown_bias else 2
    bias = np.zeros(Mb)
    for _ in range(steps):
        h, rho = _unit_los(p[:, None, :], b, "the provisional position (or an iterate)")
        h = np.nan_to_num(h)                     # a run made NaN by a singular step stays singular (and NaN)
        A = np.concatenate([h, np.ones((Mb, N, 1))], axis=-1) if unknown_bias else h
        y = r - rho - bias[:, None]
        delta, alpha, cond, inv_normal = _batched_lstsq(A, y)
        p = p + delta[:, :2]
        if unknown_bias:
            bias = bias + delta[:, 2]
    gain = np.sqrt(alpha)
    well = _warn_conditioning(cond, gain, mc, mg, "the linearized least-squares problem")
    with np.errstate(invalid="ignore"):
        predicted = np.hypot(*(p[:, None, :] - b).transpose(2, 0, 1)) + (bias[:, None] if unknown_bias else 0.0)
    residuals = r - predicted
    s, cov = _sigma_and_cov(sigma, residuals, n_unknowns, inv_normal)
    estimate = np.concatenate([p, bias[:, None]], axis=-1) if unknown_bias else p

    def out(a: np.ndarray) -> np.ndarray:
        return a if batched else a[0]

    return LSQFix(estimate=out(estimate), position=out(p), bias=out(bias) if unknown_bias else None,
                  covariance=out(cov), sigma=out(s), alpha=out(alpha), condition_number=out(cond),
                  noise_gain=out(gain), residuals=out(residuals), design=out(A), iterations=steps,
                  well_conditioned=out(well))


def _track_beacons(dr_positions: np.ndarray, beacon: np.ndarray) -> np.ndarray:
    """Virtual beacons b - (P_i - P_now) of a DR track (..., N, 2) seen from its last epoch."""
    return beacon - (dr_positions - dr_positions[..., -1:, :])


def prepositioning(ranges: Any, dr_positions: Any, provisional: Any, beacon: Any = (0.0, 0.0), *,
                   unknown_bias: bool = True, iterations: int = 1, sigma: Any = None, max_condition: float = 1e3,
                   max_noise_gain: float = 100.0) -> LSQFix:
    r"""Paper A's pre-positioning: a least-squares fix of the *current* position from a whole DR track of ranges.

    The vehicle measured :math:`r_1, \dots, r_N` at epochs where dead reckoning put it at :math:`P_1, \dots, P_N`
    (only the differences matter). Its position at epoch :math:`i` is :math:`p - (P_N - P_i)`, so the range of
    epoch :math:`i` is a range from the current position :math:`p` to the **virtual beacon**
    :math:`b_i = b + (P_N - P_i)` (paper A "back-propagates the provisional position to every past epoch with the
    DR displacements"; the two views are the same equations). The fix is then ``linearized_lsq`` on those virtual
    beacons, with paper A's bias column by default.

    Parameters
    ----------
    ranges : array_like, shape (N,) or (M, N)
        Ranges of the epochs so far [m].
    dr_positions : array_like, shape (N, 2) or (M, N, 2)
        DR positions at those epochs [m] (e.g. ``np.cumsum(dr_displacements, axis=-2)``).
    provisional : array_like, shape (2,) or (M, 2)
        Provisional *current* position [m].
    beacon : array_like, shape (2,), optional
        The beacon [m] (the origin by default).
    unknown_bias : bool, default True
        Estimate paper A's constant range bias.
    iterations : int, default 1
        Gauss-Newton steps (paper A: one).
    sigma : float, optional
        Range noise standard deviation for the covariance (estimated from the residuals when omitted).
    max_condition : float, default 1e3
        See ``linearized_lsq``.
    max_noise_gain : float, default 100
        See ``linearized_lsq``.

    Returns
    -------
    LSQFix
        The fix of the current position (epoch N) and its quality; ``fix.trusted()`` is paper A's test
        :math:`\alpha < 2`.

    Warns
    -----
    IllConditionedWarning
        As ``linearized_lsq``: typically in the first epochs, before the bearing to the beacon has changed.
    """
    P = as_finite("dr_positions", dr_positions, ndim=(2, 3))
    if P.shape[-1] != 2:
        raise ValueError(f"dr_positions must have shape (N, 2) or (M, N, 2); got {P.shape}")
    b = as_finite("beacon", beacon, shape=(2,))
    mc, mg = _as_thresholds(max_condition, max_noise_gain)
    with warnings.catch_warnings():
        # judged again below, so that the warning names this problem and points at the caller
        warnings.simplefilter("ignore", IllConditionedWarning)
        fix = linearized_lsq(ranges, _track_beacons(P, b), provisional, unknown_bias=unknown_bias,
                             iterations=iterations, sigma=sigma, max_condition=mc, max_noise_gain=mg)
    _warn_conditioning(fix.condition_number, fix.noise_gain, mc, mg, "the pre-positioning problem")
    return fix


def nonlinear_lsq(ranges: Any, beacons: Any, initial: Any, *, unknown_bias: bool = False, sigma: Any = None,
                  max_condition: float = 1e3, max_noise_gain: float = 100.0) -> LSQFix:
    r"""Nonlinear range least squares with ``scipy.optimize.least_squares``: the reference of the linearized forms.

    Minimizes :math:`\sum_i \big(r_i - \lVert p - b_i\rVert - \upsilon\big)^2` over :math:`p` (and the bias
    :math:`\upsilon` with ``unknown_bias``) with the Levenberg-Marquardt method (trust-region reflective when there
    are fewer ranges than unknowns), from ``initial``, with the analytic Jacobian. The quality numbers
    (:math:`\alpha`, :math:`\kappa`, covariance) use the Jacobian at the solution. One problem at a time: loop for
    a batch (the linearized form, ``linearized_lsq``, is batched).

    Parameters
    ----------
    ranges : array_like, shape (N,)
        Measured ranges [m].
    beacons : array_like, shape (N, 2)
        Beacon (or virtual beacon) of each range [m].
    initial : array_like, shape (2,) or (3,)
        Starting point: a position, or position and bias with ``unknown_bias`` (bias 0 if only a position).
    unknown_bias : bool, default False
        Estimate a constant range bias.
    sigma : float, optional
        Range noise standard deviation for the covariance (estimated from the residuals when omitted).
    max_condition : float, default 1e3
        See ``linearized_lsq``.
    max_noise_gain : float, default 100
        See ``linearized_lsq``.

    Returns
    -------
    LSQFix
        ``iterations`` holds the number of function evaluations.

    Warns
    -----
    IllConditionedWarning
        As ``linearized_lsq``, judged at the solution.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.lsq import nonlinear_lsq
    >>> beacons = np.array([[1000.0, 0.0], [0.0, 1000.0], [-1000.0, 0.0]])
    >>> r = np.linalg.norm(np.array([30.0, -40.0]) - beacons, axis=1)
    >>> np.round(nonlinear_lsq(r, beacons, initial=[0.0, 0.0]).position, 6)
    array([ 30., -40.])
    """
    from scipy.optimize import least_squares

    r, b = _as_ranges_and_beacons(ranges, beacons)
    if r.ndim != 1 or b.ndim != 2:
        raise ValueError("nonlinear_lsq solves one problem: ranges of shape (N,) and beacons of shape (N, 2); "
                         "loop over runs, or use linearized_lsq for a batch")
    n_unknowns = 3 if unknown_bias else 2
    x0 = as_finite("initial", initial, ndim=1)
    if x0.shape == (2,) and unknown_bias:
        x0 = np.append(x0, 0.0)
    if x0.shape != (n_unknowns,):
        raise ValueError(f"initial must have shape (2,){' or (3,)' if unknown_bias else ''}; got {x0.shape}")
    mc, mg = _as_thresholds(max_condition, max_noise_gain)
    N = len(r)

    def residual(x: np.ndarray) -> np.ndarray:
        return np.hypot(*(x[:2] - b).T) + (x[2] if unknown_bias else 0.0) - r

    def jacobian(x: np.ndarray) -> np.ndarray:
        d = x[:2] - b
        rho = np.hypot(*d.T)
        rho = np.where(rho > 0, rho, 1.0)        # at a beacon: any unit direction (a measure-zero case)
        h = d / rho[:, None]
        return np.column_stack([h, np.ones(N)]) if unknown_bias else h

    method = "lm" if N >= n_unknowns else "trf"
    sol = least_squares(residual, x0, jac=jacobian, method=method, xtol=1e-12, ftol=1e-12, gtol=1e-12)
    A = jacobian(sol.x)
    _, alpha, cond, inv_normal = _batched_lstsq(A[None], np.zeros((1, N)))
    alpha, cond, inv_normal = alpha[0], cond[0], inv_normal[0]
    gain = np.sqrt(alpha)
    well = _warn_conditioning(cond, gain, mc, mg, "the nonlinear least-squares problem")[0]
    residuals = -sol.fun
    s, cov = _sigma_and_cov(sigma, residuals, n_unknowns, inv_normal)
    x = sol.x.copy()
    return LSQFix(estimate=x, position=x[:2].copy(), bias=np.asarray(x[2]) if unknown_bias else None,
                  covariance=cov, sigma=np.asarray(s), alpha=np.asarray(alpha), condition_number=np.asarray(cond),
                  noise_gain=np.asarray(gain), residuals=residuals, design=A, iterations=int(sol.nfev),
                  well_conditioned=np.asarray(well))


# ---------------------------------------------------------------------------------------------------------------
# paper D: grid-search pre-location
# ---------------------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Prelocation:
    r"""Paper D's grid-search pre-location at every epoch (returned by ``grid_prelocation``).

    Shapes: ``K`` epochs, ``B`` bearings and ``C`` sound-speed errors on the grid, and a leading runs axis ``M``
    when the inputs had one. Entry ``k`` along the epoch axis is the pre-location from epochs ``0..k``
    (meaningless at ``k = 0``, where every cell fits the first travel time exactly).

    Attributes
    ----------
    bearing : ndarray, shape (K,) or (M, K)
        Best start bearing :math:`\hat\theta_k` [rad] (from the beacon to the vehicle at epoch 0, counter-clockwise
        from east).
    speed_error : ndarray, shape (K,) or (M, K)
        Best systematic sound-speed error :math:`\Delta\hat c_k = c - \hat c_\mathrm{e}` [m/s] (the book's
        convention :math:`c = c_\mathrm{e} + \Delta c`: negative when the assumed speed is too low).
    effective_speed : ndarray, shape (K,) or (M, K)
        The implied effective sound speed :math:`\hat c_\mathrm{e} = c - \Delta\hat c` [m/s].
    range_scale : ndarray, shape (K,) or (M, K)
        The implied mean multiplicative range factor :math:`\hat\mu_\gamma = c/\hat c_\mathrm{e}` (ranges converted
        with :math:`c` are :math:`\mu_\gamma` times the true ones; 0.98 for paper D's 1470 against 1500 m/s).
    start : ndarray, shape (K, 2) or (M, K, 2)
        Implied position at epoch 0 [m], :math:`b + \hat c_\mathrm{e}\tau_0[\cos\hat\theta, \sin\hat\theta]`.
    position : ndarray, shape (K, 2) or (M, K, 2)
        Implied position at epoch ``k`` [m]: the start plus the DR displacements up to ``k``.
    cost : ndarray, shape (K,) or (M, K)
        The minimum of the cost :math:`L` at each epoch [s²].
    cost_map : ndarray, shape (B, C) or (M, B, C)
        The cost over the whole grid at the last epoch [s²].
    bearing_grid : ndarray, shape (B,)
        The bearings searched [rad].
    speed_error_grid : ndarray, shape (C,)
        The sound-speed errors searched [m/s].
    assumed_speed : float
        The speed :math:`c` the travel times would be converted with [m/s].
    """

    bearing: np.ndarray
    speed_error: np.ndarray
    effective_speed: np.ndarray
    range_scale: np.ndarray
    start: np.ndarray
    position: np.ndarray
    cost: np.ndarray
    cost_map: np.ndarray
    bearing_grid: np.ndarray
    speed_error_grid: np.ndarray
    assumed_speed: float

    @property
    def n_steps(self) -> int:
        """Number of epochs K."""
        return self.cost.shape[-1]


def _prelocation_inputs(travel_times: Any, ranges: Any, dr_displacements: Any, bearing_grid: Any,
                        speed_error_grid: Any, assumed_speed: Any,
                        beacon: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float, np.ndarray, bool]:
    c = float(as_positive("assumed_speed", assumed_speed, ndim=0))
    if dr_displacements is None:
        raise TypeError("dr_displacements is required: the DR displacement between consecutive epochs, "
                        "shape (K, 2) or (M, K, 2)")
    if (travel_times is None) == (ranges is None):
        raise ValueError("give exactly one of travel_times and ranges (ranges are converted as ranges / "
                         "assumed_speed)")
    if travel_times is None:
        tau = as_float_array("ranges", ranges, ndim=(1, 2)) / c
        name = "ranges"
    else:
        tau = as_float_array("travel_times", travel_times, ndim=(1, 2))
        name = "travel_times"
    if np.isinf(tau).any() or np.any(tau < 0):
        raise ValueError(f"{name} must be finite and >= 0 (NaN marks a missing epoch)")
    if np.isnan(tau[..., 0]).any():
        raise ValueError(f"{name} must be present (not NaN) at epoch 0: the first travel time fixes the start ring")
    u = as_finite("dr_displacements", dr_displacements, ndim=(2, 3))
    if u.shape[-1] != 2:
        raise ValueError(f"dr_displacements must have shape (K, 2) or (M, K, 2); got {u.shape}")
    if u.shape[-2] != tau.shape[-1]:
        raise ValueError(f"dr_displacements must have one row per epoch: {u.shape[-2]} rows for "
                         f"{tau.shape[-1]} {name}")
    theta = as_finite("bearing_grid", bearing_grid, ndim=1)
    dc = as_finite("speed_error_grid", speed_error_grid, ndim=1)
    if theta.size == 0 or dc.size == 0:
        raise ValueError("bearing_grid and speed_error_grid must not be empty")
    if np.any(dc >= c):
        raise ValueError(f"speed_error_grid must stay below assumed_speed ({c:g} m/s): the effective speed "
                         f"c - dc must be > 0; got {dc.max():g}")
    b = as_finite("beacon", beacon, shape=(2,))
    M = _runs_of(travel_times=tau.shape[0] if tau.ndim == 2 else None,
                 dr_displacements=u.shape[0] if u.ndim == 3 else None)
    batched = M is not None
    K = tau.shape[-1]
    tau = np.broadcast_to(tau, (M or 1, K))
    u = np.broadcast_to(u, (M or 1, K, 2))
    return tau, u, theta, dc, c, b, batched


def _cumulative_dr(u: np.ndarray) -> np.ndarray:
    """DR offset of each epoch from epoch 0 (row 0 of the displacements is not used)."""
    D = np.cumsum(u, axis=-2)
    return D - u[..., :1, :]


def _squared_residuals(tau: np.ndarray, D: np.ndarray, cos_sin: np.ndarray, inv_speed: np.ndarray) -> np.ndarray:
    r"""Squared travel-time residuals (m, K, B, C) of every grid cell; zero at missing epochs.

    With :math:`s = c_e\tau_0` and :math:`w = 1/c_e`, :math:`\hat\tau_k = \lVert s e + D_k\rVert w =
    \sqrt{\tau_0^2 + 2\tau_0 w\,(e\cdot D_k) + w^2\lVert D_k\rVert^2}`: one product per cell and epoch, in place.
    """
    tau0 = tau[:, :1, None]                                                # (m, 1, 1)
    proj = np.einsum("mkj,bj->mkb", D, cos_sin)                            # e . D_k: (m, K, B)
    t = proj[..., None] * (2.0 * tau0 * inv_speed)[:, :, None, :]          # (m, K, B, C), one pass
    t += (tau0**2 + np.sum(D**2, axis=-1)[..., None] * inv_speed**2)[:, :, None, :]
    np.maximum(t, 0.0, out=t)                                              # rounding, vehicle over the beacon
    np.sqrt(t, out=t)
    valid = np.isfinite(tau)
    t -= np.where(valid, tau, 0.0)[..., None, None]
    np.square(t, out=t)
    if not valid.all():
        t *= valid[..., None, None]
    return t


def prelocation_cost(travel_times: Any = None, dr_displacements: Any = None, bearing_grid: Any = None,
                     speed_error_grid: Any = None, *, ranges: Any = None, assumed_speed: float = 1470.0,
                     beacon: Any = (0.0, 0.0)) -> np.ndarray:
    r"""Paper D's travel-time cost :math:`L(\theta, \Delta c)` over a grid, from all the epochs given.

    A start bearing :math:`\theta` and a sound-speed error :math:`\Delta c` (effective speed
    :math:`c_\mathrm{e} = c - \Delta c`) put the vehicle at :math:`p_0 = b + c_\mathrm{e}\tau_0 e_\theta` at the
    first epoch, on the ring fixed by the first travel time; dead reckoning carries it to
    :math:`p_k = p_0 + D_k` (:math:`D_k` the sum of the DR displacements since epoch 0). The cost compares the
    travel times that track predicts with the measured ones (paper D, eq. 6):

    .. math::

        L(\theta, \Delta c) = \sum_k \Big(\frac{\lVert p_k(\theta, \Delta c) - b\rVert}{c_\mathrm{e}}
        - \tau_k\Big)^2 .

    Every cell of the grid is computed at once (one array operation per step, no loop over cells).

    Parameters
    ----------
    travel_times : array_like, shape (K,) or (M, K)
        One-way travel times [s]; NaN marks a missing epoch (not at epoch 0). Give this or ``ranges``.
    dr_displacements : array_like, shape (K, 2) or (M, K, 2)
        DR displacement from epoch ``k - 1`` to ``k`` [m]; row 0 is not used.
    bearing_grid : array_like, shape (B,)
        Start bearings to search [rad].
    speed_error_grid : array_like, shape (C,)
        Sound-speed errors :math:`\Delta c = c - c_\mathrm{e}` to search [m/s] (below ``assumed_speed``).
    ranges : array_like, shape (K,) or (M, K), optional
        Ranges converted with ``assumed_speed`` instead of travel times (:math:`\tau = r / c`).
    assumed_speed : float, default 1470
        The speed :math:`c` the vehicle converts travel times with [m/s] (paper D: 1470).
    beacon : array_like, shape (2,), optional
        Beacon position [m].

    Returns
    -------
    ndarray, shape (B, C) or (M, B, C)
        :math:`L` [s²] on the grid (bearings along the first grid axis).
    """
    pre = grid_prelocation(travel_times, dr_displacements, bearing_grid, speed_error_grid, ranges=ranges,
                           assumed_speed=assumed_speed, beacon=beacon)
    return pre.cost_map


def _default_grids(c: float) -> tuple[np.ndarray, np.ndarray]:
    bearings = np.deg2rad(np.arange(0.0, 360.0, 2.0))
    speeds = np.arange(1550.0, 1300.0 - 1e-9, -10.0)                       # paper D's [Cmin, Cmax] = [1300, 1550]
    return bearings, c - speeds


def grid_prelocation(travel_times: Any = None, dr_displacements: Any = None, bearing_grid: Any = None,
                     speed_error_grid: Any = None, *, ranges: Any = None, assumed_speed: float = 1470.0,
                     beacon: Any = (0.0, 0.0)) -> Prelocation:
    r"""Paper D's grid-search pre-location, recomputed at every epoch, for one run or a batch of runs.

    At each epoch :math:`k` the estimate is the grid cell that minimizes the cost of ``prelocation_cost`` over
    epochs :math:`0..k` (paper D, sec. 3.1, steps 1-4, "computed again at every new signal"). All epochs come from
    one pass: the squared residuals of every cell and epoch are summed cumulatively along the epochs. The work is
    proportional to runs x cells x epochs (about 10 ns each in numpy); runs are processed in chunks of about four
    million cells x epochs (32 MB), so 1000 runs of paper D's scenario on the default grid (4680 cells, 151
    epochs) take a few seconds.

    Before a heading change a straight track has two tracks that fit (the mirror ambiguity): the cost map then has
    two valleys of nearly equal depth, and the estimate may jump between them from one epoch to the next. Use
    ``prelocation_acceptance`` to decide when to believe it.

    Parameters
    ----------
    travel_times : array_like, shape (K,) or (M, K)
        One-way travel times [s] (NaN: missing, not at epoch 0). Give this or ``ranges``.
    dr_displacements : array_like, shape (K, 2) or (M, K, 2)
        DR displacements from epoch ``k - 1`` to ``k`` [m] (row 0 not used), e.g. ``Scenario.dr_displacements``.
    bearing_grid : array_like, shape (B,), optional
        Start bearings [rad]; default every 2 degrees (paper D does not give its resolution; finer grids gain
        little until many epochs have been averaged, see chapter 3).
    speed_error_grid : array_like, shape (C,), optional
        Sound-speed errors :math:`\Delta c = c - c_\mathrm{e}` [m/s]; default: effective speeds from 1550 down to
        1300 m/s every 10 m/s (paper D's search range).
    ranges : array_like, shape (K,) or (M, K), optional
        Ranges converted with ``assumed_speed``, instead of travel times.
    assumed_speed : float, default 1470
        The speed :math:`c` [m/s] (paper D: 1470 m/s, against a true 1500 m/s).
    beacon : array_like, shape (2,), optional
        Beacon position [m].

    Returns
    -------
    Prelocation
        The best cell at every epoch, the implied start and current positions, and the last epoch's cost map.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor import scenarios
    >>> from uwtutor.lsq import grid_prelocation
    >>> sc = scenarios.approach_with_turn_scenario(np.random.default_rng(0), n_runs=20)
    >>> pre = grid_prelocation(ranges=sc.ranges, dr_displacements=sc.dr_displacements)
    >>> pre.position.shape, pre.cost_map.shape
    ((20, 151, 2), (20, 180, 26))
    >>> err = np.linalg.norm(pre.position[:, -1] - sc.true_positions[:, -1], axis=-1)
    >>> bool(np.median(err) < 60.0), bool(abs(np.median(pre.speed_error[:, -1]) + 30.0) <= 10.0)
    (True, True)
    """
    c = float(as_positive("assumed_speed", assumed_speed, ndim=0))
    default_b, default_c = _default_grids(c)
    tau, u, theta, dc, c, b, batched = _prelocation_inputs(
        travel_times, ranges, dr_displacements, default_b if bearing_grid is None else bearing_grid,
        default_c if speed_error_grid is None else speed_error_grid, c, beacon)
    M, K = tau.shape
    B, C = theta.size, dc.size
    c_e = c - dc
    inv_speed = 1.0 / c_e
    cos_sin = np.column_stack([np.cos(theta), np.sin(theta)])
    D = _cumulative_dr(u)

    best = np.empty((M, K), dtype=np.intp)
    cost = np.empty((M, K))
    cost_map = np.empty((M, B, C))
    chunk = max(1, _GRID_CHUNK_ELEMENTS // (K * B * C))
    for lo in range(0, M, chunk):
        hi = min(M, lo + chunk)
        t = _squared_residuals(tau[lo:hi], D[lo:hi], cos_sin, inv_speed)
        np.cumsum(t, axis=1, out=t)
        flat = t.reshape(hi - lo, K, B * C)
        idx = np.argmin(flat, axis=-1)
        best[lo:hi] = idx
        cost[lo:hi] = np.take_along_axis(flat, idx[..., None], axis=-1)[..., 0]
        cost_map[lo:hi] = t[:, -1]
    ib, ic = np.divmod(best, C)
    bearing = theta[ib]
    speed_error = dc[ic]
    eff = c_e[ic]
    start = b + (eff * tau[:, :1])[..., None] * np.stack([np.cos(bearing), np.sin(bearing)], axis=-1)
    position = start + D

    def out(a: np.ndarray) -> np.ndarray:
        return a if batched else a[0]

    return Prelocation(bearing=out(bearing), speed_error=out(speed_error), effective_speed=out(eff),
                       range_scale=out(c / eff), start=out(start), position=out(position), cost=out(cost),
                       cost_map=out(cost_map), bearing_grid=theta, speed_error_grid=dc, assumed_speed=c)


@dataclass(frozen=True)
class PrelocationAcceptance:
    r"""Paper D's acceptance of a pre-location (returned by ``prelocation_acceptance``).

    Attributes
    ----------
    accepted : ndarray
        Boolean, shape () or (M,): whether both conditions were met before the data ran out.
    epoch : ndarray
        Integer, shape () or (M,): the first epoch at which the pre-location is accepted (-1 if never).
    turn_epoch : ndarray
        Integer, shape () or (M,): the first epoch at which the DR heading has changed by more than the
        threshold (-1 if never).
    shifts : ndarray, shape (K,) or (M, K)
        :math:`\Delta d_k`, the move of the estimated start between epochs ``k - 1`` and ``k`` [m] (NaN at 0).
    heading_change : ndarray, shape (K,) or (M, K)
        DR heading change since the start [rad] (NaN for the first ``heading_window`` epochs).
    """

    accepted: np.ndarray
    epoch: np.ndarray
    turn_epoch: np.ndarray
    shifts: np.ndarray
    heading_change: np.ndarray


def prelocation_acceptance(starts: Any, dr_displacements: Any, *, min_heading_change: float = np.deg2rad(10.0),
                           n_consecutive: int = 10, max_shift: float = 50.0,
                           heading_window: int = 5) -> PrelocationAcceptance:
    r"""Paper D's two conditions for ending the pre-location and starting the filter.

    1. **A heading change has happened**: the DR heading has turned by more than ``min_heading_change`` (paper D:
       10 degrees in practice) since the start. Headings are taken from displacements summed over
       ``heading_window`` epochs, so that DR noise on one short step cannot fake a turn: the turn epoch is the
       first :math:`k` at which :math:`\angle\sum_{j=k-w+1}^{k} u_j` differs from :math:`\angle\sum_{j=1}^{w} u_j`
       by more than the threshold.
    2. **The estimate has settled after it**: the start estimates of :math:`K_\mathrm{stop}` consecutive epochs
       (``n_consecutive``; paper D: 10 in simulation, 7 in the trial), all at or after the turn epoch, each moved
       by less than :math:`D_\mathrm{stop}` (``max_shift``; 50 m) from the previous epoch's (paper D, eq. 7):
       :math:`\Delta d_k = \lVert \hat p_0^{(k)} - \hat p_0^{(k-1)}\rVert < D_\mathrm{stop}`.

    The accepted epoch is the last of those :math:`K_\mathrm{stop}` epochs.

    Parameters
    ----------
    starts : array_like, shape (K, 2) or (M, K, 2)
        The start position estimated at each epoch [m] (``Prelocation.start``).
    dr_displacements : array_like, shape (K, 2) or (M, K, 2)
        DR displacements (row 0 not used).
    min_heading_change : float, default 10 degrees
        Turn threshold [rad].
    n_consecutive : int, default 10
        :math:`K_\mathrm{stop}` (>= 1).
    max_shift : float, default 50
        :math:`D_\mathrm{stop}` [m].
    heading_window : int, default 5
        Number of DR displacements summed for a heading (>= 1).

    Returns
    -------
    PrelocationAcceptance
    """
    s = as_finite("starts", starts, ndim=(2, 3))
    u = as_finite("dr_displacements", dr_displacements, ndim=(2, 3))
    if s.shape[-1] != 2 or u.shape[-1] != 2:
        raise ValueError(f"starts and dr_displacements must have shape (K, 2) or (M, K, 2); got {s.shape} and "
                         f"{u.shape}")
    if s.shape[-2] != u.shape[-2]:
        raise ValueError(f"starts and dr_displacements must have the same number of epochs; got {s.shape[-2]} "
                         f"and {u.shape[-2]}")
    turn = float(as_positive("min_heading_change", min_heading_change, ndim=0))
    n_ok = as_int("n_consecutive", n_consecutive, minimum=1)
    dmax = float(as_positive("max_shift", max_shift, ndim=0))
    w = as_int("heading_window", heading_window, minimum=1)
    M = _runs_of(starts=s.shape[0] if s.ndim == 3 else None, dr_displacements=u.shape[0] if u.ndim == 3 else None)
    batched = M is not None
    Mb = M or 1
    K = s.shape[-2]
    s = np.broadcast_to(s, (Mb, K, 2))
    u = np.array(np.broadcast_to(u, (Mb, K, 2)))
    u[:, 0] = 0.0
    shifts = np.full((Mb, K), np.nan)
    shifts[:, 1:] = np.hypot(*np.diff(s, axis=1).transpose(2, 0, 1))
    change = np.full((Mb, K), np.nan)
    if K > w:
        csum = np.cumsum(u, axis=1)
        window = csum[:, w:] - csum[:, :-w]                              # sum of u over epochs k-w+1..k, k >= w
        ref = window[:, :1]                                              # epochs 1..w
        ang = np.arctan2(window[..., 1], window[..., 0]) - np.arctan2(ref[..., 1], ref[..., 0])
        change[:, w:] = np.abs(np.angle(np.exp(1j * ang)))
    turned = np.nan_to_num(change, nan=0.0) > turn
    turn_epoch = np.where(turned.any(axis=1), np.argmax(turned, axis=1), -1)
    epochs = np.arange(K)
    ok = (shifts < dmax) & (turn_epoch[:, None] >= 0) & (epochs >= turn_epoch[:, None])
    run = np.zeros(Mb, dtype=int)
    accepted_at = np.full(Mb, -1)
    for k in range(K):                 # a loop over epochs with vector operations over the runs
        run = np.where(ok[:, k], run + 1, 0)
        newly = (run >= n_ok) & (accepted_at < 0)
        accepted_at[newly] = k

    def out(a: np.ndarray) -> np.ndarray:
        return a if batched else a[0]

    return PrelocationAcceptance(accepted=out(accepted_at >= 0), epoch=out(accepted_at), turn_epoch=out(turn_epoch),
                                 shifts=out(shifts), heading_change=out(change))


# ---------------------------------------------------------------------------------------------------------------
# paper E: virtual-beacon least squares
# ---------------------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class VirtualBeaconFix:
    r"""Paper E's virtual-beacon fix and its conditioning (returned by ``virtual_beacon_lsq``).

    Shapes: ``N`` epochs (paper E: 4) and a leading runs axis ``M`` when the inputs had one.

    Attributes
    ----------
    position : ndarray, shape (2,) or (M, 2)
        Horizontal position at the last epoch [m]; NaN where the problem is singular.
    virtual_beacons : ndarray, shape (N, 2) or (M, N, 2)
        :math:`VB_i = AB_i + (P_N - P_i)` [m].
    design : ndarray, shape (N, 2) or (M, N, 2)
        :math:`A`, rows :math:`VB_{i+1} - VB_i` (cyclically: the last row is :math:`VB_1 - VB_N`).
    rhs : ndarray, shape (N,) or (M, N)
        :math:`B` [m²].
    condition_number : ndarray
        :math:`\kappa(A)`, shape () or (M,): large when the virtual beacons are nearly collinear.
    noise_gain : ndarray
        RMS horizontal position error per metre of white range noise, shape () or (M,):
        :math:`\sqrt{\operatorname{tr}(G G^\mathsf{T})}`, :math:`G = A^+ \partial B/\partial r`. It grows like
        range / baseline.
    residuals : ndarray, shape (N,) or (M, N)
        Range residuals at the fix, :math:`r_i - \lVert (\hat x, \hat y, h) - (VB_i, z_i)\rVert` [m].
    well_conditioned : ndarray
        Boolean, shape () or (M,): condition number and noise gain below their limits.
    """

    position: np.ndarray
    virtual_beacons: np.ndarray
    design: np.ndarray
    rhs: np.ndarray
    condition_number: np.ndarray
    noise_gain: np.ndarray
    residuals: np.ndarray
    well_conditioned: np.ndarray


def virtual_beacon_lsq(ranges: Any, beacon_positions: Any, dr_positions: Any, *, depth: Any = 0.0,
                       beacon_depths: Any = 0.0, max_condition: float = 1e3,
                       max_noise_gain: float = 100.0) -> VirtualBeaconFix:
    r"""Paper E's virtual moving long baseline: a closed-form fix from N ranges to a moving beacon.

    The mother ship (the beacon) was at :math:`AB_i` at epoch :math:`i` and the submersible's dead reckoning at
    :math:`P_i`. Shifting each ship position by the submersible's DR displacement from epoch :math:`i` to now makes
    a **virtual beacon** :math:`VB_i = AB_i + (P_N - P_i)` (paper E, eq. 14: :math:`AB_i + \sum_{n=i}^{3} v_n
    dt`) whose range from the *current* position is :math:`r_i`. With the depth :math:`h` known (pressure sensor)
    and the virtual beacons at depths :math:`z_i`, the spheres :math:`\lVert (x, y, h) - (VB_i, z_i)\rVert = r_i`,
    differenced pairwise around the cycle (1-2, 2-3, ..., N-1; paper E, eq. 16), are linear in :math:`(x, y)`:

    .. math::

        (x_{j} - x_i)\,x + (y_{j} - y_i)\,y = \frac{r_i^2 - r_{j}^2 + d_{j}^2 - d_i^2}{2} - h\,(z_{j} - z_i),
        \quad j = i + 1 \bmod N, \quad d_i^2 = x_i^2 + y_i^2 + z_i^2,

    :math:`A X = B`, solved by least squares :math:`X = A^+ B` (eq. 17). The cyclic rows sum to zero, so only
    :math:`N - 1` of them are independent (the last adds no information); the answer is still the least-squares
    one. When all :math:`z_i` are equal (a surface ship) the depth cancels exactly.

    Conditioning: the rows of :math:`A` are the baselines between virtual beacons, so :math:`A` is singular when
    they are collinear, and the fix's sensitivity to the ranges (``noise_gain``) grows like range / baseline: a
    submersible that moves little between the epochs, compared with its range, gets a useless fix (paper E:
    lengthen the sampling interval).

    Parameters
    ----------
    ranges : array_like, shape (N,) or (M, N)
        Ranges at the N epochs [m] (slant ranges when depths are given), N >= 3.
    beacon_positions : array_like, shape (N, 2) or (M, N, 2)
        Horizontal beacon (ship) positions :math:`AB_i` at those epochs [m].
    dr_positions : array_like, shape (N, 2) or (M, N, 2)
        The vehicle's DR positions :math:`P_i` at those epochs [m] (only differences matter; last = now).
    depth : float, default 0
        Vehicle depth :math:`h` [m], positive down.
    beacon_depths : float or array_like, shape (N,), default 0
        Beacon depths :math:`z_i` [m] (0: a surface ship).
    max_condition : float, default 1e3
        Condition number of :math:`A` above which an ``IllConditionedWarning`` is given.
    max_noise_gain : float, default 100
        Noise gain [m per m] above which an ``IllConditionedWarning`` is given.

    Returns
    -------
    VirtualBeaconFix

    Warns
    -----
    IllConditionedWarning
        When the fix is unreliable (limits exceeded) or the problem is singular (NaN fix).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.lsq import virtual_beacon_lsq
    >>> ship = np.array([[0.0, 0.0], [400.0, 100.0], [700.0, 400.0], [800.0, 800.0]])
    >>> sub = np.array([[-900.0, -1100.0], [-850.0, -1050.0], [-800.0, -1000.0], [-750.0, -950.0]])
    >>> r = np.sqrt(np.sum((ship - sub) ** 2, axis=1) + 1000.0**2)        # slant ranges, sub at 1000 m
    >>> fix = virtual_beacon_lsq(r, ship, sub, depth=1000.0)
    >>> np.round(fix.position, 6)
    array([-750., -950.])
    """
    r = as_finite("ranges", ranges, ndim=(1, 2))
    if np.any(r < 0):
        raise ValueError(f"ranges must be >= 0; got {r[r < 0].flat[0]:g}")
    N = r.shape[-1]
    if N < 3:
        raise ValueError(f"virtual_beacon_lsq needs ranges at N >= 3 epochs (paper E uses 4); got {N}")
    ab = as_finite("beacon_positions", beacon_positions, ndim=(2, 3))
    P = as_finite("dr_positions", dr_positions, ndim=(2, 3))
    for name, arr in (("beacon_positions", ab), ("dr_positions", P)):
        if arr.shape[-2:] != (N, 2):
            raise ValueError(f"{name} must have shape ({N}, 2) or (M, {N}, 2), one position per range; "
                             f"got {arr.shape}")
    h = float(as_finite("depth", depth, ndim=0))
    z = as_finite("beacon_depths", beacon_depths, ndim=(0, 1))
    if z.ndim == 1 and z.shape != (N,):
        raise ValueError(f"beacon_depths must be a number or have shape ({N},); got {z.shape}")
    z = np.broadcast_to(z, (N,))
    mc, mg = _as_thresholds(max_condition, max_noise_gain)
    M = _runs_of(ranges=r.shape[0] if r.ndim == 2 else None,
                 beacon_positions=ab.shape[0] if ab.ndim == 3 else None,
                 dr_positions=P.shape[0] if P.ndim == 3 else None)
    batched = M is not None
    Mb = M or 1
    r = np.broadcast_to(r, (Mb, N))
    ab = np.broadcast_to(ab, (Mb, N, 2))
    P = np.broadcast_to(P, (Mb, N, 2))

    vb = ab + (P[:, -1:, :] - P)
    nxt = np.roll(np.arange(N), -1)                                     # j = i + 1 (mod N)
    A = vb[:, nxt] - vb
    d2 = np.sum(vb**2, axis=-1) + z**2
    B = 0.5 * (r**2 - r[:, nxt] ** 2 + d2[:, nxt] - d2) - h * (z[nxt] - z)
    X, _, cond, _ = _batched_lstsq(A, B)
    # sensitivity of X to the ranges: dB_i/dr_i = r_i, dB_i/dr_j = -r_j
    dBdr = np.zeros((Mb, N, N))
    rows = np.arange(N)
    dBdr[:, rows, rows] = r
    dBdr[:, rows, nxt] = -r[:, nxt]
    with np.errstate(invalid="ignore"):
        pinv = np.where(np.isfinite(cond)[:, None, None], np.linalg.pinv(A), np.nan)
        G = pinv @ dBdr
        gain = np.sqrt(np.sum(G**2, axis=(-2, -1)))
    gain = np.where(np.isfinite(cond), gain, np.inf)
    well = _warn_conditioning(cond, gain, mc, mg, "the virtual-beacon least-squares problem")
    with np.errstate(invalid="ignore"):
        predicted = np.sqrt(np.sum((X[:, None, :] - vb) ** 2, axis=-1) + (h - z) ** 2)
    residuals = r - predicted

    def out(a: np.ndarray) -> np.ndarray:
        return a if batched else a[0]

    return VirtualBeaconFix(position=out(X), virtual_beacons=out(vb), design=out(A), rhs=out(B),
                            condition_number=out(cond), noise_gain=out(gain), residuals=out(residuals),
                            well_conditioned=out(well))
