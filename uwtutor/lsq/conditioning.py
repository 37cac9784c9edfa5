"""Conditioning of a least-squares problem: paper A's precision factor (the library's one), the condition number."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .._validate import as_flag, as_finite
from ._common import SINGULAR_RTOL, alpha_from_singular_values, as_design, scalar_or_array, unit_los


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
    A = as_design(A)
    s = np.linalg.svd(A, compute_uv=False)
    alpha, _ = alpha_from_singular_values(s, A.shape[-1])
    return scalar_or_array(alpha)


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

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.lsq import condition_number
    >>> phi = np.radians([0.0, 90.0, 180.0, 270.0])
    >>> round(condition_number(np.column_stack([np.cos(phi), np.sin(phi), np.ones(4)])), 4)
    1.4142
    >>> # two nearly parallel lines of sight
    >>> round(condition_number(np.array([[1.0, 0.0], [1.0, 1e-3]])), 1)
    2000.0
    """
    A = as_design(A)
    s = np.linalg.svd(A, compute_uv=False)
    _, cond = alpha_from_singular_values(s, A.shape[-1])
    return scalar_or_array(cond)


def precision_factor_history(positions: ArrayLike, beacon: ArrayLike = (0.0, 0.0),
                             unknown_bias: bool = True) -> np.ndarray:
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

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.lsq import precision_factor_history
    >>> theta = np.linspace(0.0, np.pi / 2, 6)
    >>> arc = 100.0 * np.column_stack([np.cos(theta), np.sin(theta)])
    >>> # position and bias: infinite until three ranges, then falling as the bearing turns
    >>> precision_factor_history(arc).round(1)
    array([   inf,    inf, 1217.7,  203.8,   58.7,   22.3])
    """
    unknown_bias = as_flag("unknown_bias", unknown_bias)
    p = as_finite("positions", positions, ndim=(2, 3), nonempty=True)
    if p.shape[-1] != 2:
        raise ValueError(f"positions must have shape (K, 2) or (M, K, 2); got {p.shape}")
    b = as_finite("beacon", beacon)
    if b.shape not in ((2,), p.shape[-2:]):
        raise ValueError(f"beacon must have shape (2,) or {p.shape[-2:]} (one position per epoch); got {b.shape}")
    h, _ = unit_los(p, b, "a position")
    rows = np.concatenate([h, np.ones(h.shape[:-1] + (1,))], axis=-1) if unknown_bias else h
    info = np.cumsum(rows[..., :, None] * rows[..., None, :], axis=-3)     # (..., K, n, n)
    lam = np.linalg.eigvalsh(info)                                         # ascending
    # eigenvalues of A^T A are squared singular values: the same singularity rule as precision_factor
    singular = ~(lam[..., 0] > SINGULAR_RTOL**2 * lam[..., -1])
    with np.errstate(divide="ignore"):
        alpha = np.sum(1.0 / np.where(lam > 0, lam, 1.0), axis=-1)
    return np.where(singular, np.inf, alpha)
