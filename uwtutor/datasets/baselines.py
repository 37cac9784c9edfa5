r"""The book's earlier methods on a real log, each as its chapter built it (chapter 11).

Chapters 4 to 9 built their filters for simulations in which the vehicle's dead reckoning arrives as world-frame
displacements :math:`\mathbf u_k = [\Delta x_k, \Delta y_k]` and the ranges go to one beacon. A
:class:`~uwtutor.datasets.RangeDataset` holds body-frame odometry instead. The functions here make the inputs those
chapters assumed and run their filters unchanged:

* the displacements are the differences of the log's own dead reckoning
  (:meth:`~uwtutor.datasets.RangeDataset.dead_reckoning`, from the start pose; its heading, drift included, is
  taken as right: :func:`world_displacements`);
* their noise per step and axis is :math:`\sigma_k = a + c\,d_k` (the distance noise of
  :func:`~uwtutor.datasets.navigate`, ``distance_sigma``), the range noise :math:`\sigma_r` = 0.6 m;
* the ranges are those of :meth:`~uwtutor.datasets.RangeDataset.ranges_on_epochs` (nearest epoch, optionally thinned
  to one per ``min_period`` seconds), taken at face value.

=============================  ======================================================================================
:func:`position_ekf`           chapter 4's range-only EKF, state :math:`[x, y]` (several beacons: the generic engine
                               with :class:`~uwtutor.models.range.BeaconRanges`)
:func:`bias_iekf`              chapter 7's IEKF (paper A), :math:`[x, y, \upsilon]` (several beacons: one bias each)
:func:`fading_filter`          chapter 5's ISFEKF (paper D) with the range factor :math:`\mu_\gamma` given
:func:`vmlbl_filter`           chapter 9's OR-VMLBL-KF (paper E): gated range filter, four-epoch virtual long-baseline
                               fixes, gated cascade filter; dead reckoning until the first fix
:func:`particle_filter`        chapter 6's bootstrap particle filter on chapter 4's model
=============================  ======================================================================================

Each returns a :class:`BaselineRun`: the positions at every epoch of the log and the chapter's own result object.
None of them knows the heading drift or the range scale of a real log: that is what chapter 11 measures.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .._validate import as_int, as_nonnegative, as_scalar
from ._core import BeaconIds, RangeDataset

__all__ = ["BaselineRun", "world_displacements", "displacement_covariance", "position_ekf", "bias_iekf",
           "fading_filter", "vmlbl_filter", "particle_filter", "RANGE_SIGMA", "DISTANCE_SIGMA"]

#: The range noise :math:`\sigma_r` [m] of every method here (the Plaza radios: about 0.55 m measured).
RANGE_SIGMA = 0.6
#: :math:`(a, c)`, the displacement noise per step and axis being :math:`a + c\,d_k` [m] (as the distance noise of
#: :func:`~uwtutor.datasets.navigate`).
DISTANCE_SIGMA = (0.01, 0.02)


@dataclass(frozen=True)
class BaselineRun:
    """A method's run on a log.

    Attributes
    ----------
    name : str
        The method.
    times : ndarray, shape (K,)
        The log's epochs [s].
    positions : ndarray, shape (K, 2)
        The estimated positions at every epoch [m].
    result : object
        The method's own result (a :class:`~uwtutor.filters.base.FilterResult`, or a
        :class:`~uwtutor.pipelines.vmlbl.VMLBLResult` for the virtual baseline), for its innovations, covariances and
        extras.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.datasets import square_log
    >>> # a 10 m square driven twice, ranging to two beacons in turn
    >>> data = square_log()
    >>> from uwtutor.datasets.baselines import position_ekf
    >>> run = position_ekf(data, [3, 7])
    >>> run.name, run.times.shape, run.positions.shape, type(run.result).__name__
    ('EKF', (81,), (81, 2), 'FilterResult')
    """

    name: str
    times: np.ndarray
    positions: np.ndarray
    result: Any


def _check(data: Any) -> RangeDataset:
    if not isinstance(data, RangeDataset):
        raise TypeError(f"data must be a uwtutor.datasets.RangeDataset; got {type(data).__name__}")
    if data.start is None:
        raise ValueError("data has no start pose: build the RangeDataset with start= (or truth=)")
    return data


def _pos(name: str, value: Any) -> float:
    # bounded so that its square (a variance) neither underflows to 0 nor overflows
    return as_scalar(name, value, domain="positive", low=1e-9, high=1e6)


def _one_beacon(data: RangeDataset, beacon_ids: BeaconIds, method: str) -> int:
    ids = list(data.beacons) if beacon_ids is None else list(np.atleast_1d(beacon_ids).tolist())
    if len(ids) != 1:
        raise ValueError(f"{method} ranges to one beacon, as its chapter built it; got beacon_ids={ids}. Pass one "
                         "id, e.g. beacon_ids=[5]")
    data.beacon_positions(ids)                       # an unknown id is named there
    return int(ids[0])


def world_displacements(data: RangeDataset) -> np.ndarray:
    r"""The world-frame displacements :math:`\mathbf u_k` of the log's dead reckoning, row 0 zero [m].

    :math:`\mathbf u_k = \mathbf p^\mathrm{DR}_k - \mathbf p^\mathrm{DR}_{k-1}`, the input of the position-only
    filters of chapters 4 to 9. The heading that turned the odometry into them is the odometry's own, drift
    included.

    Examples
    --------
    North at 1 m per step, then a quarter turn left after the second step (move first, then turn):

    >>> import numpy as np
    >>> from uwtutor.datasets import RangeDataset
    >>> from uwtutor.datasets.baselines import world_displacements
    >>> data = RangeDataset(
    ...     times=[0.0, 1.0, 2.0, 3.0],
    ...     odometry=[[0, 0], [1, 0], [1, np.pi / 2], [1, 0]],
    ...     ranges=[[1.0, 3, 5.0]],
    ...     beacons={3: (1.0, 5.0)},
    ...     start=[0.0, 0.0, np.pi / 2],
    ... )
    >>> world_displacements(data).round(6) + 0.0
    array([[ 0.,  0.],
           [ 0.,  1.],
           [ 0.,  1.],
           [-1.,  0.]])
    """
    _check(data)
    dr = data.dead_reckoning()
    return np.diff(dr[:, :2], axis=0, prepend=dr[:1, :2])


def displacement_covariance(data: RangeDataset, distance_sigma: ArrayLike = DISTANCE_SIGMA) -> np.ndarray:
    r"""The per-step covariance :math:`\sigma_k^2\mathbf I` of :math:`\mathbf u_k`, :math:`\sigma_k = a + c\,d_k`,
    shape ``(K, 2, 2)`` [m²].

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.datasets import square_log
    >>> # a 10 m square driven twice, ranging to two beacons in turn
    >>> data = square_log()
    >>> from uwtutor.datasets.baselines import displacement_covariance
    >>> C = displacement_covariance(data, distance_sigma=(0.01, 0.02))
    >>> # one 2x2 covariance per step: (0.01 + 0.02 * 1 m)^2 on a 1 m step
    >>> C.shape, np.round(C[5], 4).tolist()
    ((81, 2, 2), [[0.0009, 0.0], [0.0, 0.0009]])
    """
    _check(data)
    # standard deviations: their squares stay within the covariances' bound, 1e150
    a, c = (float(v) for v in as_nonnegative("distance_sigma", distance_sigma, shape=(2,), max_abs=1e75))
    if a <= 0.0:
        raise ValueError(f"distance_sigma[0] must be > 0; got {a}")
    sigma = a + c * np.abs(data.odometry[:, 0])
    covariances: np.ndarray = sigma[:, None, None] ** 2 * np.eye(2)
    return covariances


def _start(data: RangeDataset) -> tuple[np.ndarray, np.ndarray]:
    start, cov = data.start, data.start_cov
    if start is None or cov is None:    # RangeDataset gives a start pose its covariance
        raise ValueError("data has no start pose: build the RangeDataset with start= (or truth=)")
    return np.asarray(start[:2], dtype=float), np.asarray(cov[:2, :2], dtype=float)


def position_ekf(data: RangeDataset, beacon_ids: BeaconIds = None, *, min_period: float | None = None,
                 range_sigma: float = RANGE_SIGMA, distance_sigma: ArrayLike = DISTANCE_SIGMA) -> BaselineRun:
    r"""Chapter 4's range-only EKF on a log: state :math:`[x, y]`, dead-reckoned displacements, ranges as logged.

    One beacon runs :func:`uwtutor.filters.ekf.range_only_ekf` itself; several run the generic engine on
    :class:`~uwtutor.models.dead_reckoning.DeadReckoning` and :class:`~uwtutor.models.range.BeaconRanges` (the same
    filter, every beacon heard at an epoch in one update).

    Parameters
    ----------
    data : RangeDataset
        The log (with a start pose).
    beacon_ids : sequence of int, optional
        The beacons used (default: all).
    min_period : float, optional
        At most one range per beacon every ``min_period`` seconds.
    range_sigma : float, default 0.6
        :math:`\sigma_r` [m].
    distance_sigma : (float, float), default (0.01, 0.02)
        :math:`(a, c)` of the displacement noise :math:`a + c\,d_k` per step and axis [m, -].

    Returns
    -------
    BaselineRun

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.datasets import square_log
    >>> # a 10 m square driven twice, ranging to two beacons in turn
    >>> data = square_log()
    >>> from uwtutor.datasets.baselines import position_ekf
    >>> run = position_ekf(data, [3, 7], range_sigma=0.1)
    >>> # exact ranges from the exact start: the track is followed [m]
    >>> round(float(np.linalg.norm(run.positions[-1] - data.truth[-1, :2])), 2)
    0.0
    """
    from ..filters import extended_kalman_filter, range_only_ekf
    from ..models import BeaconRanges, DeadReckoning

    _check(data)
    ids = list(data.beacons) if beacon_ids is None else list(np.atleast_1d(beacon_ids).tolist())
    z = data.ranges_on_epochs(ids, min_period=min_period)
    u, Q = world_displacements(data), displacement_covariance(data, distance_sigma)
    x0, P0 = _start(data)
    R = _pos("range_sigma", range_sigma) ** 2
    if len(ids) == 1:
        result = range_only_ekf(x0, P0, u, z[:, 0], Q, R, beacon=data.beacons[int(ids[0])], times=data.times)
    else:
        result = extended_kalman_filter(DeadReckoning(Q), BeaconRanges(data.beacon_positions(ids), R=R), x0, P0, u,
                                        z, times=data.times)
    return BaselineRun("EKF", data.times, result.x[:, :2], result)


def bias_iekf(data: RangeDataset, beacon_ids: BeaconIds = None, *, min_period: float | None = None,
              range_sigma: float = RANGE_SIGMA, distance_sigma: ArrayLike = DISTANCE_SIGMA,
              bias_sigma: float = 5.0) -> BaselineRun:
    r"""Chapter 7's IEKF (paper A) on a log: :math:`[x, y, \upsilon]`, a slowly varying range bias in the state.

    Paper A's process noise: the bias walks by :math:`q_\upsilon = (\sigma_x^2 + \sigma_y^2)/2` per step (here
    :math:`\sigma_k^2`); the bias starts at 0 with standard deviation ``bias_sigma``. One beacon runs
    :func:`uwtutor.filters.bias.bias_ekf`; several give each beacon its own bias (the generic engine, state
    :math:`[x, y, \upsilon_1, \dots, \upsilon_B]`).

    Parameters
    ----------
    data, beacon_ids, min_period, range_sigma, distance_sigma
        As for :func:`position_ekf`.
    bias_sigma : float, default 5
        Prior standard deviation of each bias [m].

    Returns
    -------
    BaselineRun
        ``result.x[:, 2:]`` holds the bias estimates.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.datasets import square_log
    >>> # a 10 m square driven twice, ranging to two beacons in turn
    >>> data = square_log()
    >>> from uwtutor.datasets.baselines import bias_iekf
    >>> # 0.5 m too long: the bias state takes it
    >>> longer = square_log(range_offset=0.5)
    >>> run = bias_iekf(longer, [3], range_sigma=0.1, bias_sigma=1.0)
    >>> run.name, round(float(run.result.x[-1, 2]), 1)
    ('IEKF', 0.5)
    """
    from ..filters import bias_ekf, extended_kalman_filter
    from ..models import BeaconRanges, DeadReckoning

    _check(data)
    ids = list(data.beacons) if beacon_ids is None else list(np.atleast_1d(beacon_ids).tolist())
    z = data.ranges_on_epochs(ids, min_period=min_period)
    u, Q2 = world_displacements(data), displacement_covariance(data, distance_sigma)
    B = len(ids)
    n = 2 + B
    Q = np.zeros((len(Q2), n, n))
    Q[:, :2, :2] = Q2
    idx = np.arange(2, n)
    Q[:, idx, idx] = Q2[:, :1, 0]                       # paper A: (sx^2 + sy^2) / 2
    x0p, P0p = _start(data)
    x0 = np.concatenate([x0p, np.zeros(B)])
    P0 = np.zeros((n, n))
    P0[:2, :2] = P0p
    P0[idx, idx] = _pos("bias_sigma", bias_sigma) ** 2
    R = _pos("range_sigma", range_sigma) ** 2
    if B == 1:
        result = bias_ekf(x0, P0, u, z[:, 0], Q, R, beacon=data.beacons[int(ids[0])], times=data.times)
    else:
        result = extended_kalman_filter(DeadReckoning(Q), BeaconRanges(data.beacon_positions(ids), R=R, n=n,
                                                                       bias_index=list(range(2, n))),
                                        x0, P0, u, z, times=data.times)
    return BaselineRun("IEKF", data.times, result.x[:, :2], result)


def fading_filter(data: RangeDataset, beacon_ids: BeaconIds = None, *, mu_gamma: float = 1.0,
                  sigma_gamma: float = 5.0 / 1500.0, min_period: float | None = None, range_sigma: float = RANGE_SIGMA,
                  distance_sigma: ArrayLike = DISTANCE_SIGMA) -> BaselineRun:
    r"""Chapter 5's ISFEKF (paper D) on a log: multiplicative range noise of mean :math:`\mu_\gamma`, fading memory.

    :func:`uwtutor.filters.fading.fading_ekf` with paper D's weakening factor and forgetting factor
    :math:`\rho` = 0.95. Its :math:`\mathbf Q` is one matrix for every step: the mean of the per-step
    :math:`\sigma_k^2\mathbf I`. The factor :math:`\mu_\gamma` is *given* (paper D's filter assumes it: 1 for a
    sound speed believed right, the log's measured scale for a calibrated one); ``sigma_gamma`` is paper D's
    trial value, 5/1500.

    Parameters
    ----------
    data, min_period, range_sigma, distance_sigma
        As for :func:`position_ekf`.
    beacon_ids : sequence of one int
        The one beacon.
    mu_gamma, sigma_gamma : float
        :math:`\mu_\gamma` and :math:`\sigma_\gamma` of the range factor.

    Returns
    -------
    BaselineRun

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.datasets import square_log
    >>> # a 10 m square driven twice, ranging to two beacons in turn
    >>> data = square_log()
    >>> from uwtutor.datasets.baselines import fading_filter
    >>> run = fading_filter(data, [3], range_sigma=0.1)
    >>> run.name, type(run.result).__name__, run.positions.shape
    ('ISFEKF', 'FadingResult', (81, 2))
    >>> # the fading factor of each epoch (>= 1)
    >>> bool(np.all(run.result.extras["fading_factor"] >= 1.0))
    True
    """
    from ..filters.fading import fading_ekf

    _check(data)
    beacon = _one_beacon(data, beacon_ids, "fading_filter")
    z = data.ranges_on_epochs([beacon], min_period=min_period)[:, 0]
    Q = displacement_covariance(data, distance_sigma).mean(axis=0)
    x0, P0 = _start(data)
    result = fading_ekf(x0, P0, world_displacements(data), z, Q, _pos("range_sigma", range_sigma) ** 2,
                        mu_gamma=_pos("mu_gamma", mu_gamma),
                        sigma_gamma=as_scalar("sigma_gamma", sigma_gamma, domain="nonnegative", high=1.0),
                        rho=0.95, beta="range", beacon=data.beacons[beacon], times=data.times)
    return BaselineRun("ISFEKF", data.times, result.x[:, :2], result)


def vmlbl_filter(data: RangeDataset, beacon_ids: BeaconIds = None, *, min_period: float | None = None,
                 spacing: float = 10.0, range_q: float = 30.0, fix_q: float = 1.0,
                 range_sigma: float = RANGE_SIGMA) -> BaselineRun:
    r"""Chapter 9's OR-VMLBL-KF (paper E) on a log: the fixed beacon as the "ship", four-epoch virtual baselines.

    :func:`uwtutor.pipelines.vmlbl.or_vmlbl_kf` with the beacon's position at every epoch as the ship's, depth 0, the
    log's dead reckoning as the vehicle's, the range filter's chi-square gate (chapter 10's choice; paper E's
    relative test is tuned to 1 s epochs at hundreds of metres) and a gated cascade filter. Before the first fix
    the positions are the dead reckoning.

    Parameters
    ----------
    data, min_period, range_sigma
        As for :func:`position_ekf`.
    beacon_ids : sequence of one int
        The one beacon.
    spacing : float, default 10
        Seconds between the four epochs of a fix.
    range_q : float, default 30
        Acceleration variance of the range filter [(m/s²)²]. A robot turning at 3.6 m/s within metres of a beacon
        has range accelerations of a few m/s² (:math:`v^2/r`); with paper E's :math:`q = 2`, tuned for a
        submersible kilometres from its ship, the range filter's gate locks out on Plaza 2 (chapter 11).
    fix_q : float, default 1
        Acceleration variance of the cascade filter [(m/s²)²] (a robot that turns and brakes, not a submersible
        holding its course).

    Returns
    -------
    BaselineRun
        ``result`` is the :class:`~uwtutor.pipelines.vmlbl.VMLBLResult`.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.datasets import square_log
    >>> # a 10 m square driven twice, ranging to two beacons in turn
    >>> data = square_log()
    >>> from uwtutor.datasets.baselines import vmlbl_filter
    >>> run = vmlbl_filter(data, [3], spacing=4.0)
    >>> run.name, type(run.result).__name__, run.positions.shape
    ('OR-VMLBL-KF', 'VMLBLResult', (81, 2))
    >>> bool(np.linalg.norm(run.positions[-1] - data.truth[-1, :2]) < 1.0)
    True
    """
    import warnings

    from ..errors import IllConditionedWarning
    from ..pipelines import or_vmlbl_kf

    _check(data)
    beacon = _one_beacon(data, beacon_ids, "vmlbl_filter")
    z = data.ranges_on_epochs([beacon], min_period=min_period)[:, 0]
    dr = data.dead_reckoning()[:, :2]
    ship = np.broadcast_to(np.asarray(data.beacons[beacon], dtype=float), dr.shape)
    steps = max(int(round(_pos("spacing", spacing) / float(np.median(np.diff(data.times))))), 1)
    range_q, fix_q = _pos("range_q", range_q), _pos("fix_q", fix_q)
    r = _pos("range_sigma", range_sigma) ** 2
    with warnings.catch_warnings():         # near-collinear windows are part of what is measured
        warnings.simplefilter("ignore", IllConditionedWarning)
        out = or_vmlbl_kf(dr, z, ship_positions=ship, depth=0.0, times=data.times, spacing=steps,
                          range_options=dict(q=range_q, r=r, test="chi2"), fix_q=fix_q,
                          fix_options=dict(reacquire=5))
    positions = dr.copy()
    track = np.asarray(out.track.x[:, :2])
    ok = np.isfinite(track).all(axis=-1)
    positions[np.asarray(out.now)[ok]] = track[ok]
    return BaselineRun("OR-VMLBL-KF", data.times, positions, out)


def particle_filter(data: RangeDataset, beacon_ids: BeaconIds = None, *, rng: np.random.Generator,
                    n_particles: int = 500, min_period: float | None = None, range_sigma: float = RANGE_SIGMA,
                    distance_sigma: ArrayLike = DISTANCE_SIGMA) -> BaselineRun:
    r"""Chapter 6's bootstrap particle filter on chapter 4's model: :math:`[x, y]` relative to the one beacon.

    :class:`~uwtutor.filters.particle.bootstrap.BootstrapParticleFilter` on the EKF's model pair,
    :class:`~uwtutor.models.dead_reckoning.DeadReckoning` (its :math:`\mathbf Q` the mean of the per-step
    :math:`\sigma_k^2\mathbf I`) and :class:`~uwtutor.models.range.RangeToBeacon` (the beacon at the origin of the
    frame), particles drawn from the start's :math:`N(\mathbf p_0, \mathbf P_0)`, systematic resampling when the
    effective sample size falls below half (:func:`uwtutor.methods.particle_filter`'s settings).

    Parameters
    ----------
    data, min_period, range_sigma, distance_sigma
        As for :func:`position_ekf`.
    beacon_ids : sequence of one int
        The one beacon.
    rng : numpy.random.Generator
        Every random draw.
    n_particles : int, default 500
        :math:`N`.

    Returns
    -------
    BaselineRun

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.datasets import square_log
    >>> # a 10 m square driven twice, ranging to two beacons in turn
    >>> data = square_log()
    >>> from uwtutor.datasets.baselines import particle_filter
    >>> run = particle_filter(
    ...     data, [3], rng=np.random.default_rng(0), n_particles=200, range_sigma=0.3
    ... )
    >>> run.name, run.positions.shape
    ('particle filter', (81, 2))
    >>> bool(np.linalg.norm(run.positions[-1] - data.truth[-1, :2]) < 1.0)
    True
    """
    from ..filters import BootstrapParticleFilter
    from ..models import DeadReckoning, RangeToBeacon

    _check(data)
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator, e.g. np.random.default_rng(1); got "
                        f"{type(rng).__name__}")
    beacon = _one_beacon(data, beacon_ids, "particle_filter")
    z = data.ranges_on_epochs([beacon], min_period=min_period)[:, 0]
    b = np.asarray(data.beacons[beacon], dtype=float)
    Q = displacement_covariance(data, distance_sigma).mean(axis=0)
    x0, P0 = _start(data)
    n = as_int("n_particles", n_particles, minimum=1, maximum=1_000_000)
    ranges = RangeToBeacon(np.zeros(2), R=_pos("range_sigma", range_sigma) ** 2)
    pf = BootstrapParticleFilter.from_gaussian(DeadReckoning(Q), ranges, x0 - b, P0, n, rng, ess_threshold=0.5)
    result = pf.run(z[:, None], world_displacements(data), times=data.times)
    return BaselineRun("particle filter", data.times, result.x[:, :2] + b, result)
