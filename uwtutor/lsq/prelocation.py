"""Paper D's grid-search pre-location and its acceptance test."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .._validate import MAX_COORDINATE, as_finite, as_float_array, as_int, as_scalar, common_runs


#: Largest elements of one intermediate array of the grid search (runs are processed in chunks below it).
_GRID_CHUNK_ELEMENTS = 4_000_000


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

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.lsq import grid_prelocation
    >>> track = np.array([[50.0 * k, -500.0] for k in range(6)]
    ...                  + [[250.0, -500.0 + 50.0 * k] for k in range(1, 5)])
    >>> dr = np.vstack([np.zeros(2), np.diff(track, axis=0)])
    >>> pre = grid_prelocation(np.linalg.norm(track, axis=1) / 1500.0, dr,
    ...                        speed_error_grid=[-30.0, 0.0, 30.0])
    >>> pre.n_steps, pre.cost_map.shape, float(pre.effective_speed[-1])
    (10, (180, 3), 1500.0)
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
    c = as_scalar("assumed_speed", assumed_speed, domain="positive")
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
    if tau.shape[-1] == 0:
        raise ValueError(f"{name} must hold at least one epoch; got shape {tau.shape}")
    if np.isinf(tau).any() or np.any(tau < 0):
        raise ValueError(f"{name} must be finite and >= 0 (NaN marks a missing epoch)")
    if np.isnan(tau[..., 0]).any():
        raise ValueError(f"{name} must be present (not NaN) at epoch 0: the first travel time fixes the start ring")
    u = as_finite("dr_displacements", dr_displacements, ndim=(2, 3), max_abs=MAX_COORDINATE)
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
    with np.errstate(invalid="ignore"):
        reach = float(np.nanmax(tau)) * float(np.max(c - dc))       # the largest ring radius c_e tau searched
    if not reach <= MAX_COORDINATE:
        raise ValueError(f"{name}, assumed_speed and speed_error_grid give ranges c_e tau up to {reach:.3g} m, "
                         f"beyond {MAX_COORDINATE:.0e} (the cost's squares overflow float64): check their units "
                         "(seconds, m/s, metres)")
    b = as_finite("beacon", beacon, shape=(2,), max_abs=MAX_COORDINATE)
    M = common_runs(dict(travel_times=tau.shape[0] if tau.ndim == 2 else None,
                         dr_displacements=u.shape[0] if u.ndim == 3 else None))
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

    Examples
    --------
    A vehicle 500 m south of the beacon drives east, then turns north; the travel times are at 1500 m/s, converted
    with 1470 m/s:

    >>> import numpy as np
    >>> from uwtutor.lsq import prelocation_cost
    >>> track = np.array([[50.0 * k, -500.0] for k in range(6)]
    ...                  + [[250.0, -500.0 + 50.0 * k] for k in range(1, 5)])
    >>> dr = np.vstack([np.zeros(2), np.diff(track, axis=0)])
    >>> bearings = np.radians(np.arange(-180.0, 180.0, 2.0))
    >>> cost = prelocation_cost(np.linalg.norm(track, axis=1) / 1500.0, dr, bearings,
    ...                         [-30.0, 0.0, 30.0])
    >>> i, j = np.unravel_index(np.argmin(cost), cost.shape)
    >>> cost.shape, float(np.degrees(bearings[i])), [-30.0, 0.0, 30.0][j]
    ((180, 3), -90.0, -30.0)
    """
    pre = grid_prelocation(travel_times, dr_displacements, bearing_grid, speed_error_grid, ranges=ranges,
                           assumed_speed=assumed_speed, beacon=beacon)
    return pre.cost_map


def _default_grids(c: float) -> tuple[np.ndarray, np.ndarray]:
    bearings = np.deg2rad(np.arange(0.0, 360.0, 2.0))
    speeds = np.arange(1550.0, 1300.0 - 1e-9, -10.0)                       # paper D's [Cmin, Cmax] = [1300, 1550]
    return bearings, c - speeds


#: Largest number of residuals ``grid_prelocation`` evaluates in one call (about a minute on a laptop core).
MAX_GRID_WORK = 2e10


def grid_prelocation(travel_times: ArrayLike | None = None, dr_displacements: ArrayLike | None = None,
                     bearing_grid: Any = None,
                     speed_error_grid: Any = None, *, ranges: ArrayLike | None = None, assumed_speed: float = 1470.0,
                     beacon: ArrayLike = (0.0, 0.0)) -> Prelocation:
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
    >>> sc = scenarios.approach_with_turn_scenario(
    ...     np.random.default_rng(0), n_runs=20
    ... )
    >>> pre = grid_prelocation(
    ...     ranges=sc.ranges, dr_displacements=sc.dr_displacements
    ... )
    >>> pre.position.shape, pre.cost_map.shape
    ((20, 151, 2), (20, 180, 26))
    >>> err = np.linalg.norm(
    ...     pre.position[:, -1] - sc.true_positions[:, -1], axis=-1
    ... )
    >>> bool(np.median(err) < 60.0), bool(
    ...     abs(np.median(pre.speed_error[:, -1]) + 30.0) <= 10.0
    ... )
    (True, True)
    """
    c = as_scalar("assumed_speed", assumed_speed, domain="positive")
    default_b, default_c = _default_grids(c)
    tau, u, theta, dc, c, b, batched = _prelocation_inputs(
        travel_times, ranges, dr_displacements, default_b if bearing_grid is None else bearing_grid,
        default_c if speed_error_grid is None else speed_error_grid, c, beacon)
    M, K = tau.shape
    B, C = theta.size, dc.size
    work = M * K * B * C
    if work > MAX_GRID_WORK:
        raise ValueError(f"the grid search would evaluate {work:.2g} residuals ({M} runs x {K} epochs x {B} bearings "
                         f"x {C} speed errors), more than {MAX_GRID_WORK:.0e} (minutes of work): coarsen "
                         "bearing_grid or speed_error_grid, or split the runs into batches")
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

    Examples
    --------
    On a straight track the estimated start stops moving at once, but with no turn it may be the mirror start: the
    pre-location is never accepted (``prelocation_acceptance`` shows the accepted case):

    >>> import numpy as np
    >>> from uwtutor.lsq import grid_prelocation, prelocation_acceptance
    >>> track = np.array([[50.0 * k, -500.0] for k in range(10)])
    >>> dr = np.vstack([np.zeros(2), np.diff(track, axis=0)])
    >>> pre = grid_prelocation(np.linalg.norm(track, axis=1) / 1500.0, dr,
    ...                        speed_error_grid=[-30.0, 0.0, 30.0])
    >>> verdict = prelocation_acceptance(pre.start, dr, n_consecutive=2, heading_window=2)
    >>> (float(verdict.shifts[-1]), bool(verdict.accepted), int(verdict.turn_epoch),
    ...  int(verdict.epoch))
    (0.0, False, -1, -1)
    """

    accepted: np.ndarray
    epoch: np.ndarray
    turn_epoch: np.ndarray
    shifts: np.ndarray
    heading_change: np.ndarray


def prelocation_acceptance(starts: ArrayLike, dr_displacements: ArrayLike, *,
                           min_heading_change: float = np.deg2rad(10.0),
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

    Examples
    --------
    Before the turn north the grid picks the mirror start (north of the beacon); the turn (seen at epoch 6, with
    headings over two displacements) moves it to the true one, and two estimates that stay put accept it:

    >>> import numpy as np
    >>> from uwtutor.lsq import grid_prelocation, prelocation_acceptance
    >>> track = np.array([[50.0 * k, -500.0] for k in range(6)]
    ...                  + [[250.0, -500.0 + 50.0 * k] for k in range(1, 5)])
    >>> dr = np.vstack([np.zeros(2), np.diff(track, axis=0)])
    >>> pre = grid_prelocation(np.linalg.norm(track, axis=1) / 1500.0, dr,
    ...                        speed_error_grid=[-30.0, 0.0, 30.0])
    >>> accepted = prelocation_acceptance(pre.start, dr, n_consecutive=2, heading_window=2)
    >>> bool(accepted.accepted), int(accepted.turn_epoch), int(accepted.epoch)
    (True, 6, 8)
    >>> pre.position[accepted.epoch].round(1)
    array([ 250., -350.])
    """
    s = as_finite("starts", starts, ndim=(2, 3))
    u = as_finite("dr_displacements", dr_displacements, ndim=(2, 3))
    if s.shape[-1] != 2 or u.shape[-1] != 2:
        raise ValueError(f"starts and dr_displacements must have shape (K, 2) or (M, K, 2); got {s.shape} and "
                         f"{u.shape}")
    if s.shape[-2] != u.shape[-2]:
        raise ValueError(f"starts and dr_displacements must have the same number of epochs; got {s.shape[-2]} "
                         f"and {u.shape[-2]}")
    turn = as_scalar("min_heading_change", min_heading_change, domain="positive")
    n_ok = as_int("n_consecutive", n_consecutive, minimum=1)
    dmax = as_scalar("max_shift", max_shift, domain="positive")
    w = as_int("heading_window", heading_window, minimum=1)
    M = common_runs(dict(starts=s.shape[0] if s.ndim == 3 else None,
                         dr_displacements=u.shape[0] if u.ndim == 3 else None))
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
