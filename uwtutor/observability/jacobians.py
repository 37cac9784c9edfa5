r"""Jacobians of ranges: to several beacons from one position, to one beacon along a track (virtual beacons).

The Jacobian of :math:`r = \|p - b\|` is the unit line of sight :math:`(p - b)^\mathsf{T} / \|p - b\|`; along a
track its rows gain a column of ones for a range bias and a block :math:`(t_k - t_\mathrm{ref})\,h_k` for a
constant current (see :mod:`uwtutor.observability`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._linalg import line_of_sight as _line_of_sight
from .._validate import (
    MAX_COORDINATE,
    as_finite,
    as_flag,
    as_points,
    as_positive,
)
from ._common import _as_reference, _broadcast, _warn

__all__ = ["range_jacobian", "squared_range_jacobian", "beacons_at_bearings", "virtual_beacons", "track_jacobian"]


def range_jacobian(position: ArrayLike, beacons: ArrayLike) -> NDArray[np.float64]:
    r"""Jacobian of the horizontal range with respect to the vehicle position: the unit line-of-sight vector.

    .. math::

        \frac{\partial r_i}{\partial p} = \frac{(p - b_i)^\mathsf{T}}{\|p - b_i\|}
        = [\cos\varphi_i, \sin\varphi_i],

    :math:`\varphi_i` being the bearing of the vehicle seen from beacon :math:`i` (the row points from the beacon
    to the vehicle; its sign never matters in :math:`J = \sum h_i^\mathsf{T} h_i`).

    Parameters
    ----------
    position : array_like, shape (..., 2)
        Vehicle position(s) ``[x, y]`` [m].
    beacons : array_like, shape (..., 2)
        Beacon position(s) [m], broadcast against ``position`` (e.g. ``position`` of shape ``(2,)`` and ``beacons``
        of shape ``(N, 2)`` give ``N`` rows).

    Returns
    -------
    ndarray, shape (..., 2)
        The unit vectors, one per broadcast pair. Where the vehicle sits on a beacon the range is not
        differentiable: that row is zero (no information) and an ``UnobservableWarning`` says so.

    Examples
    --------
    >>> # + 0.0 turns -0.0 into 0.0
    >>> range_jacobian([0.0, 0.0], [[100.0, 0.0], [0.0, -50.0]]) + 0.0
    array([[-1.,  0.],
           [ 0.,  1.]])
    """
    p = as_points("position", position)
    b = as_points("beacons", beacons, nonempty=True)
    p, b = _broadcast("position", p, "beacons", b)
    _, los, defined = _line_of_sight(p, b)
    if not defined.all():
        _warn(f"the position coincides with a beacon at {int((~defined).sum())} place(s): the range is not "
              "differentiable there, so that range is given no information (a zero Jacobian row)")
    return los


def squared_range_jacobian(position: ArrayLike, beacons: ArrayLike) -> NDArray[np.float64]:
    r"""Jacobian of the squared horizontal range with respect to the vehicle position.

    .. math::

        \frac{\partial r_i^2}{\partial p} = 2\,(p - b_i)^\mathsf{T} = 2\,r_i\,\frac{\partial r_i}{\partial p}.

    Each row is the range Jacobian times :math:`2 r_i`, so the stacked Jacobians of ranges and of squared ranges
    have the same rank: measuring :math:`r^2` (paper B's cooperative filter, Indiveri and Parlangeli's observers)
    changes the noise model, not observability.

    Parameters
    ----------
    position : array_like, shape (..., 2)
        Vehicle position(s) [m].
    beacons : array_like, shape (..., 2)
        Beacon position(s) [m], broadcast against ``position``.

    Returns
    -------
    ndarray, shape (..., 2)
        :math:`2 (p - b_i)` [m].

    Examples
    --------
    >>> from uwtutor.observability import squared_range_jacobian
    >>> squared_range_jacobian([3.0, 4.0], [[1000.0, 0.0], [0.0, 1000.0]])
    array([[-1994.,     8.],
           [    6., -1992.]])
    """
    p = as_points("position", position)
    b = as_points("beacons", beacons, nonempty=True)
    p, b = _broadcast("position", p, "beacons", b)
    return 2.0 * (p - b)


def beacons_at_bearings(position: ArrayLike, bearings: ArrayLike, distances: ArrayLike = 1000.0) -> NDArray[np.float64]:
    r"""Beacons placed at given bearings and distances from a position: :math:`b_i = p + \rho_i [\cos\beta_i,
    \sin\beta_i]`.

    Parameters
    ----------
    position : array_like, shape (2,)
        The vehicle position [m].
    bearings : array_like, shape (N,)
        Bearing of each beacon seen from ``position`` [rad], counter-clockwise from +x (east).
    distances : float or array_like, shape (N,), default 1000
        Distance of each beacon [m], > 0.

    Returns
    -------
    ndarray, shape (N, 2)
        Beacon positions [m].

    Examples
    --------
    >>> beacons_at_bearings([0.0, 0.0], [0.0, np.pi / 2], 100.0).round(6)
    array([[100.,   0.],
           [  0., 100.]])
    """
    p = as_points("position", position)
    if p.shape != (2,):
        raise ValueError(f"position must have shape (2,); got {p.shape}")
    beta = as_finite("bearings", bearings, ndim=1, nonempty=True)
    rho = as_positive("distances", distances, max_abs=MAX_COORDINATE)
    if rho.ndim > 1 or (rho.ndim == 1 and rho.shape != beta.shape):
        raise ValueError(f"distances must be a number or have one entry per bearing ({beta.size}); got shape "
                         f"{rho.shape}")
    return p + np.asarray(rho)[..., None] * np.stack([np.cos(beta), np.sin(beta)], axis=-1)


def virtual_beacons(beacon: ArrayLike, positions: ArrayLike, reference: int = -1) -> NDArray[np.float64]:
    r"""The virtual beacons of a track: one beacon pinged from several epochs, seen from the reference epoch.

    If the vehicle is at :math:`p_k` at epoch :math:`k` and at :math:`p` at the reference epoch, write
    :math:`d_k = p_k - p` (known from dead reckoning). Then

    .. math::

        r_k = \|p_k - b_k\| = \|p - (b_k - d_k)\|,

    so the range of epoch :math:`k` is a range from the *reference* position to the virtual beacon
    :math:`b_k - d_k`: the beacon moved by the distance the vehicle has travelled since (Larsen's synthetic long
    baseline; paper E's virtual beacons, :math:`VB_i = AB_i + \sum v_n \delta t`).

    Parameters
    ----------
    beacon : array_like, shape (2,) or (K, 2)
        Beacon position [m], fixed or one per epoch (a moving beacon such as paper E's mother ship).
    positions : array_like, shape (K, 2)
        Vehicle positions at the epochs [m]; only their differences matter, so dead-reckoned positions do.
    reference : int, default -1
        Index of the epoch whose position the virtual beacons refer to (default: the last, "now").

    Returns
    -------
    ndarray, shape (K, 2)
        Virtual beacon positions [m]; the one of the reference epoch is the beacon itself.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.observability import virtual_beacons
    >>> # a vehicle moving east 10 m per epoch: the beacon seen from its last position
    >>> virtual_beacons((0.0, 0.0), np.array([[0.0, 100.0], [10.0, 100.0], [20.0, 100.0]]))
    array([[20.,  0.],
           [10.,  0.],
           [ 0.,  0.]])
    """
    p = as_points("positions", positions, min_ndim=2)
    if p.ndim != 2:
        raise ValueError(f"positions must have shape (K, 2); got {p.shape}")
    b = as_points("beacon", beacon)
    if b.shape not in ((2,), p.shape):
        raise ValueError(f"beacon must have shape (2,) or {p.shape} (one position per epoch); got {b.shape}")
    k = len(p)
    if k == 0:
        raise ValueError("positions must hold at least one epoch, shape (K, 2) with K >= 1; got shape (0, 2)")
    return b - (p - p[_as_reference(reference, k)])


def _track_inputs(positions: Any, beacon: Any, times: Any, unknown_current: bool) -> tuple[np.ndarray, np.ndarray,
                                                                                            np.ndarray | None]:
    p = as_points("positions", positions, min_ndim=2)
    if p.ndim != 2 or len(p) == 0:
        raise ValueError(f"positions must have shape (K, 2) with K >= 1; got {p.shape}")
    b = as_points("beacon", beacon)
    if b.shape not in ((2,), p.shape):
        raise ValueError(f"beacon must have shape (2,) or {p.shape} (one position per epoch); got {b.shape}")
    t = None
    if unknown_current:
        if times is None:
            raise ValueError("times are needed with unknown_current=True: the current moves the vehicle by "
                             "U (t_k - t_ref)")
        t = as_finite("times", times, ndim=1)
        if len(t) != len(p):
            raise ValueError(f"times must have one entry per row of positions ({len(p)}); got {len(t)}")
    elif times is not None:
        t = as_finite("times", times, ndim=1)
        if len(t) != len(p):
            raise ValueError(f"times must have one entry per row of positions ({len(p)}); got {len(t)}")
    return p, b, t


def _track_rows(p: np.ndarray, b: np.ndarray, t: np.ndarray | None, unknown_bias: bool, unknown_current: bool,
                ref: int) -> np.ndarray:
    h = range_jacobian(p, b)
    cols = [h]
    if unknown_bias:
        cols.append(np.ones((len(p), 1)))
    if unknown_current:
        assert t is not None
        cols.append((t - t[ref])[:, None] * h)
    return np.concatenate(cols, axis=1)


def track_jacobian(positions: ArrayLike, beacon: ArrayLike, *, times: ArrayLike | None = None,
                   unknown_bias: bool = False,
                   unknown_current: bool = False, reference: int = -1) -> NDArray[np.float64]:
    r"""The stacked Jacobian of the ranges along a track with respect to the state at one epoch.

    The dead-reckoned displacements are taken as known, so the unknowns are the position :math:`p` at the
    reference epoch, optionally a constant range bias :math:`\upsilon` (paper A) and a constant current
    :math:`U` (paper B). The vehicle is at :math:`p_k = p + d_k + U (t_k - t_\mathrm{ref})` and measures
    :math:`r_k = \|p_k - b_k\| + \upsilon`, so row :math:`k` is

    .. math::

        \left[\; h_k,\;\; 1,\;\; (t_k - t_\mathrm{ref})\, h_k \;\right], \qquad
        h_k = \frac{(p_k - b_k)^\mathsf{T}}{\|p_k - b_k\|},

    with the bias and current blocks present only when asked for (state order ``[x, y, bias, Ux, Uy]``). The
    rows are evaluated on the true track: this is the local (linearized) observability matrix, and
    :math:`H^\mathsf{T} H / \sigma^2` is the Fisher information (``track_fisher_information``).

    Parameters
    ----------
    positions : array_like, shape (K, 2)
        True vehicle positions over ground at the ranging epochs [m].
    beacon : array_like, shape (2,) or (K, 2)
        Beacon position, fixed or one per epoch [m].
    times : array_like, shape (K,), optional
        Epoch times [s]; required with ``unknown_current``.
    unknown_bias : bool, default False
        Add the bias column.
    unknown_current : bool, default False
        Add the two current columns.
    reference : int, default -1
        The epoch whose position is the unknown (default: the last one).

    Returns
    -------
    ndarray, shape (K, n)
        :math:`H`, ``n`` = 2, 3, 4 or 5.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.observability import track_jacobian
    >>> theta = np.linspace(0.0, np.pi / 2, 3)
    >>> arc = 100.0 * np.column_stack([np.cos(theta), np.sin(theta)])
    >>> track_jacobian(arc, (0.0, 0.0), unknown_bias=True).round(3)
    array([[1.   , 0.   , 1.   ],
           [0.707, 0.707, 1.   ],
           [0.   , 1.   , 1.   ]])
    """
    unknown_bias = as_flag("unknown_bias", unknown_bias)
    unknown_current = as_flag("unknown_current", unknown_current)
    p, b, t = _track_inputs(positions, beacon, times, bool(unknown_current))
    ref = _as_reference(reference, len(p))
    return _track_rows(p, b, t, bool(unknown_bias), bool(unknown_current), ref)
