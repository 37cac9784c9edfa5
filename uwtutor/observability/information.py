r"""Fisher information of ranges, :math:`J = H^\mathsf{T} R^{-1} H`, and the numerical rank that says what it
observes."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validate import (
    as_finite,
    as_flag,
    as_points,
)
from ._common import DEFAULT_RTOL, _as_rtol, _sigma_per_row
from .jacobians import _track_inputs, _track_rows, range_jacobian

__all__ = ["fisher_information", "track_fisher_information", "observability_rank", "numerical_rank"]


def _static_rows(beacons: Any, position: Any, unknown_bias: bool) -> np.ndarray:
    """The stacked Jacobian rows (..., N, n) of ranges from ``position`` (..., 2) to ``beacons`` (..., N, 2)."""
    b = as_points("beacons", beacons, min_ndim=2)
    p = as_points("position", position)
    if b.shape[-2] == 0:
        raise ValueError("beacons must hold at least one beacon, shape (N, 2) with N >= 1")
    h = range_jacobian(p[..., None, :], b)
    if unknown_bias:
        h = np.concatenate([h, np.ones(h.shape[:-1] + (1,))], axis=-1)
    return h


def fisher_information(beacons: ArrayLike, position: ArrayLike, sigma: ArrayLike,
                       unknown_bias: bool = False) -> NDArray[np.float64]:
    r"""Fisher information of a static position (and optionally a range bias) from ranges to several beacons.

    With range :math:`r_i = \|p - b_i\| + \upsilon + \eta_i`, :math:`\eta_i \sim N(0, \sigma_i^2)` independent,

    .. math::

        J = \sum_{i=1}^{N} \frac{h_i^\mathsf{T} h_i}{\sigma_i^2}, \qquad
        h_i = \left[\frac{(p - b_i)^\mathsf{T}}{\|p - b_i\|}\right] \text{ or, with the bias, }
        \left[\frac{(p - b_i)^\mathsf{T}}{\|p - b_i\|},\; 1\right].

    For :math:`N \ge 3` beacons evenly spaced in bearing, :math:`\sum \cos^2 = \sum \sin^2 = N/2` and the cross
    terms vanish, so :math:`J = \frac{N}{2\sigma^2} I` (and the bias adds an uncoupled :math:`N/\sigma^2`).
    The beacons may be virtual (``virtual_beacons``): that is how one beacon and a track give information.

    Parameters
    ----------
    beacons : array_like, shape (N, 2) or (..., N, 2)
        Beacon positions [m].
    position : array_like, shape (2,) or (..., 2)
        The (true) vehicle position where the information is evaluated [m]; leading axes broadcast against those
        of ``beacons`` (e.g. many positions at once).
    sigma : float or array_like, shape (N,) or (..., N)
        Standard deviation of each range error [m], > 0.
    unknown_bias : bool, default False
        Add a constant range bias :math:`\upsilon`, common to all ranges, to the unknowns (paper A's state).

    Returns
    -------
    ndarray, shape (..., 2, 2) or (..., 3, 3)
        :math:`J` [1/m²], state order ``[x, y]`` or ``[x, y, bias]``.

    Examples
    --------
    >>> from uwtutor.observability import beacons_at_bearings
    >>> b = beacons_at_bearings([0.0, 0.0], np.radians([0.0, 120.0, 240.0]))
    >>> fisher_information(b, [0.0, 0.0], sigma=2.0).round(12)
    array([[0.375, 0.   ],
           [0.   , 0.375]])
    """
    unknown_bias = as_flag("unknown_bias", unknown_bias)
    h = _static_rows(beacons, position, bool(unknown_bias))
    s = _sigma_per_row(sigma, h.shape[:-1])
    w = h / s[..., None]
    return np.einsum("...ki,...kj->...ij", w, w)


def _refer_current(J0: np.ndarray, tau: np.ndarray, unknown_bias: bool) -> np.ndarray:
    """Refer information about [p_0, (bias), U] to [p_k, (bias), U], p_k = p_0 + (t_k - t_0) U + known."""
    n = J0.shape[-1]
    c = 3 if unknown_bias else 2
    T_inv = np.broadcast_to(np.eye(n), J0.shape).copy()
    T_inv[:, 0, c] = -tau
    T_inv[:, 1, c + 1] = -tau
    return np.einsum("kai,kab,kbj->kij", T_inv, J0, T_inv)


def track_fisher_information(positions: ArrayLike, beacon: ArrayLike, sigma: ArrayLike, *,
                             times: ArrayLike | None = None,
                             unknown_bias: bool = False, unknown_current: bool = False,
                             cumulative: bool = False) -> NDArray[np.float64]:
    r"""Fisher information of the ranges along a track (the observability Gramian weighted by the noise).

    .. math::

        J_k = \sum_{j \le k} \frac{H_j^\mathsf{T} H_j}{\sigma_j^2},

    :math:`H_j` the rows of ``track_jacobian`` taken with respect to the state at epoch :math:`k`. With
    ``cumulative=False`` only the last epoch's :math:`J_K` (all ranges, state now) is returned; with
    ``cumulative=True`` the stack :math:`J_1, \dots, J_K`: what the ranges so far say about the position *now*,
    the quantity a filter with perfect dead reckoning tracks. Referring the state to another epoch is an invertible
    linear change of variables (:math:`p_k = p_j + d_k - d_j + U(t_k - t_j)`), so the rank does not depend on it.

    Parameters
    ----------
    positions : array_like, shape (K, 2)
        True positions over ground at the ranging epochs [m].
    beacon : array_like, shape (2,) or (K, 2)
        Beacon position(s) [m].
    sigma : float or array_like, shape (K,)
        Range noise standard deviation(s) [m], > 0.
    times : array_like, shape (K,), optional
        Epoch times [s]; required with ``unknown_current``.
    unknown_bias, unknown_current : bool, default False
        The extra unknowns (see ``track_jacobian``).
    cumulative : bool, default False
        Return the information after every epoch.

    Returns
    -------
    ndarray, shape (n, n) or (K, n, n)
        Information matrices, state order ``[x, y, bias, Ux, Uy]`` (the blocks asked for).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.observability import track_fisher_information
    >>> theta = np.linspace(0.0, np.pi / 2, 5)
    >>> arc = 100.0 * np.column_stack([np.cos(theta), np.sin(theta)])
    >>> track_fisher_information(arc, (0.0, 0.0), sigma=1.0).round(3)
    array([[2.5  , 1.207],
           [1.207, 2.5  ]])
    >>> track_fisher_information(arc, (0.0, 0.0), sigma=1.0, cumulative=True).shape
    (5, 2, 2)
    """
    unknown_bias = as_flag("unknown_bias", unknown_bias)
    unknown_current = as_flag("unknown_current", unknown_current)
    cumulative = as_flag("cumulative", cumulative)
    p, b, t = _track_inputs(positions, beacon, times, bool(unknown_current))
    k = len(p)
    s = _sigma_per_row(sigma, (k,))
    rows = _track_rows(p, b, t, bool(unknown_bias), bool(unknown_current), 0) / s[:, None]
    if not cumulative:
        J0 = rows.T @ rows
        if not unknown_current or t is None:       # (the times are required with a current)
            return J0
        return _refer_current(J0[None], (t[-1] - t[0])[None], bool(unknown_bias))[0]
    J0 = np.cumsum(np.einsum("ki,kj->kij", rows, rows), axis=0)
    if not unknown_current or t is None:
        return J0
    return _refer_current(J0, t - t[0], bool(unknown_bias))


def observability_rank(positions: ArrayLike, beacon: ArrayLike, *, times: ArrayLike | None = None,
                       unknown_bias: bool = False,
                       unknown_current: bool = False, cumulative: bool = True,
                       rtol: float = DEFAULT_RTOL) -> int | np.ndarray:
    r"""Numerical rank of the range information along a track: how many state directions the ranges fix.

    The rank of the stacked Jacobian :math:`H_{1:k}` (``track_jacobian``), computed as the number of eigenvalues
    of the diagonally scaled information :math:`D^{-1} H^\mathsf{T} H D^{-1}` above ``rtol**2`` times the largest
    (the squared singular values of the column-scaled Jacobian, so units do not matter). Full rank means local
    observability. Theory to check it against (beacon fixed, dead reckoning exact):

    =============================  ==========  ==============  =================
    motion                         position    + bias          + current
    =============================  ==========  ==============  =================
    straight, radial (through b)   1           1               2
    straight, not radial           2           3               3
    one heading change, circle     2           3               4
    =============================  ==========  ==============  =================

    (after enough epochs: one epoch gives rank 1.) The straight track with a current fails because
    :math:`r_k^2 = \|p - b\|^2 + 2 (p - b)\cdot w\, t_k + \|w\|^2 t_k^2` (ground velocity :math:`w`) depends on three
    combinations of the four unknowns; rotating the position about the beacon together with the velocity
    (through the current) leaves all ranges unchanged.

    Parameters
    ----------
    positions : array_like, shape (K, 2)
        True positions over ground [m].
    beacon : array_like, shape (2,) or (K, 2)
        Beacon position(s) [m].
    times : array_like, shape (K,), optional
        Epoch times [s]; required with ``unknown_current``.
    unknown_bias, unknown_current : bool, default False
        The extra unknowns.
    cumulative : bool, default True
        Return the rank after every epoch (shape ``(K,)``); otherwise one int for the whole track.
    rtol : float, default ``DEFAULT_RTOL``
        Relative tolerance on the singular values of the column-scaled Jacobian.

    Returns
    -------
    int or ndarray of int, shape (K,)
        The rank(s), between 0 and ``n``.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.observability import observability_rank
    >>> theta = np.linspace(0.0, np.pi / 2, 5)
    >>> arc = 100.0 * np.column_stack([np.cos(theta), np.sin(theta)])
    >>> observability_rank(arc, (0.0, 0.0), unknown_bias=True)
    array([1, 2, 3, 3, 3])
    >>> observability_rank(arc, (0.0, 0.0), unknown_bias=True, cumulative=False)
    3
    """
    unknown_bias = as_flag("unknown_bias", unknown_bias)
    unknown_current = as_flag("unknown_current", unknown_current)
    cumulative = as_flag("cumulative", cumulative)
    J = track_fisher_information(positions, beacon, 1.0, times=times, unknown_bias=unknown_bias,
                                 unknown_current=unknown_current, cumulative=bool(cumulative))
    ranks = _information_rank(J, _as_rtol(rtol))
    return int(ranks) if ranks.ndim == 0 else ranks


def _information_rank(J: np.ndarray, rtol: float) -> np.ndarray:
    d = np.sqrt(np.clip(np.diagonal(J, axis1=-2, axis2=-1), 0.0, None))
    live = d > 0
    safe = np.where(live, d, 1.0)
    scaled = J / (safe[..., :, None] * safe[..., None, :])
    scaled = np.where(live[..., :, None] & live[..., None, :], scaled, 0.0)
    lam = np.linalg.eigvalsh((scaled + np.swapaxes(scaled, -1, -2)) / 2)
    top = np.maximum(lam.max(axis=-1, keepdims=True), np.finfo(float).tiny)
    return np.count_nonzero(lam > rtol ** 2 * top, axis=-1)


def numerical_rank(matrix: ArrayLike, *, rtol: float = DEFAULT_RTOL) -> int | np.ndarray:
    r"""The numerical rank of a matrix (or a stack), with its columns scaled to unit length first.

    Counts the singular values above ``rtol`` times the largest. Scaling the columns makes the answer independent
    of units: a Jacobian whose current columns are in seconds (thousands) next to position columns of order one is
    judged on its geometry, not its units. ``numpy.linalg.matrix_rank`` uses a tolerance of about
    :math:`\max(m, n)\,\epsilon\, s_\mathrm{max}` instead, which counts poorly conditioned geometry as full rank.

    Parameters
    ----------
    matrix : array_like, shape (..., m, n)
        E.g. a stacked Jacobian from ``track_jacobian``.
    rtol : float, default ``DEFAULT_RTOL``
        Relative tolerance.

    Returns
    -------
    int or ndarray of int
        The rank(s).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.observability import numerical_rank
    >>> numerical_rank([[1.0, 2.0], [2.0, 4.0], [0.0, 0.0]]), numerical_rank(np.eye(3))
    (1, 3)
    """
    A = as_finite("matrix", matrix, nonempty=True)
    if A.ndim < 2:
        raise ValueError(f"matrix must have at least 2 dimensions, shape (..., m, n); got {A.shape}")
    rtol = _as_rtol(rtol)
    norms = np.linalg.norm(A, axis=-2, keepdims=True)
    scaled = A / np.where(norms > 0, norms, 1.0)
    s = np.linalg.svd(scaled, compute_uv=False)
    top = np.maximum(s.max(axis=-1, keepdims=True), np.finfo(float).tiny) if s.shape[-1] else s
    ranks = np.count_nonzero(s > rtol * top, axis=-1)
    return int(ranks) if np.ndim(ranks) == 0 else ranks
