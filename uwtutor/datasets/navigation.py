r"""The recommended filter for a real log, in one call: :func:`navigate`.

A real range log differs from the book's simulations in two errors that the position-only models leave out
(chapter 11 measures both on the Plaza sets):

* a **range scale** :math:`s`: every range is :math:`s\,\lVert p - b\rVert` with :math:`s \neq 1` (7 % on the
  Plaza radios; a sound-speed error does the same to an acoustic range, paper D's :math:`\mu_\gamma`) -- a
  constant to *estimate*, not a known factor;
* a **gyro bias** :math:`b_g`: the odometry's heading drifts (by more than 100 degrees over Plaza 2).

:func:`navigate` therefore runs the library's generic EKF (:func:`uwtutor.filters.engine.extended_kalman_filter`) on the
state :math:`[x, y, \theta, b_g, s]` with :class:`uwtutor.models.odometry.OdometryMotion` (each step moves along the
previous heading, then turns: the convention of the data, :meth:`RangeDataset.dead_reckoning`) and
:class:`uwtutor.models.BeaconRanges` (:math:`z_j = s\,\lVert p - b_j\rVert + v_j`, the beacons heard at an epoch,
the others skipped), behind a chi-square gate that cannot lock out (:class:`uwtutor.filters.gates.ReacquiringGate`),
and smooths it with :func:`uwtutor.filters.rts_smoother` when asked. Nothing here is a new loop: a model pair,
the engine and its gate.

:func:`navigation_models` gives that model pair, its start and the log's inputs and measurements, so that the
same pair runs in any other filter of the library -- the particle filter, on a log where the EKF's Gaussian is
not enough::

    nav = navigation_models(data)
    pf = BootstrapParticleFilter.from_gaussian(nav.motion, nav.measurement, nav.x0, nav.P0, 2000,
                                               numpy.random.default_rng(0), ess_threshold=0.5)
    result = pf.run(nav.z, nav.u, times=nav.times)

The noise defaults describe wheel odometry and radio ranges like the Plaza sets' (range noise about 0.55 m,
odometry good to about 0.1 m over 2 s); pass your own for other sensors.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .._validate import as_finite, as_flag, as_nonnegative, as_scalar
from ..filters import ChiSquareGate, FilterResult, ReacquiringGate, extended_kalman_filter, rts_smoother
from ..models import BeaconRanges, OdometryMotion
from ._core import RangeDataset

__all__ = ["navigate", "navigation_models", "NavigationModels"]


def _positive(name: str, value: Any) -> float:
    # bounded so that its square (a variance) neither underflows to 0 nor overflows
    return as_scalar(name, value, domain="positive", low=1e-9, high=1e6)


def navigate(data: RangeDataset, beacon_ids: Any = None, *, min_period: Any = None, smooth: bool = False,
             gyro_bias: bool = True, scale: bool = True, range_sigma: Any = 0.6,
             distance_sigma: tuple[float, float] = (0.01, 0.02), heading_noise: Any = 1e-3,
             gyro_bias_prior: Any = 0.01, gyro_bias_walk: Any = 1e-4, scale_prior: Any = 0.1,
             scale_walk: Any = 1e-5, gate: bool = True) -> FilterResult:
    r"""Navigate a range log from its start pose: odometry, ranges to known beacons, heading, gyro bias and scale.

    The state is :math:`[x, y, \theta, b_g, s]` (fewer with ``gyro_bias=False`` or ``scale=False``), the motion

    .. math::

        p_k = p_{k-1} + d_k \begin{bmatrix}\cos\theta_{k-1}\\ \sin\theta_{k-1}\end{bmatrix},\qquad
        \theta_k = \theta_{k-1} + \Delta\theta_k - b_{g}\,\Delta t_k,

    with the odometry noise :math:`\sigma_{d,k} = a + c\,|d_k|` on the distance and
    :math:`\sigma_{\theta,k} = q_\theta\sqrt{\Delta t_k}` on the heading change, slow random walks on :math:`b_g`
    and :math:`s`, and the ranges :math:`z_{k,j} = s\,\lVert p_k - b_j\rVert + v_{k,j}`,
    :math:`v \sim N(0, \sigma_r^2)`, to the beacons heard at epoch :math:`k`.

    Parameters
    ----------
    data : RangeDataset
        The log; it must have a start pose (``data.start``, ``data.start_cov``).
    beacon_ids : sequence, optional
        The beacons to use (default: all of ``data.beacons``), e.g. ``[5]`` for one.
    min_period : float, optional
        Use at most one range per beacon every ``min_period`` seconds (an acoustic modem's rate), as
        :meth:`RangeDataset.ranges_on_epochs` thins them.
    smooth : bool, default False
        Return the Rauch--Tung--Striebel smoothed estimates (every range, past and future, behind every epoch)
        instead of the filtered ones.
    gyro_bias, scale : bool, default True
        Estimate a gyro bias [rad/s] and a range scale. Leave out what your log does not have: an unneeded state
        that a single beacon observes weakly costs accuracy.
    range_sigma : float, default 0.6
        :math:`\sigma_r` [m], the range noise.
    distance_sigma : (float, float), default (0.01, 0.02)
        :math:`(a, c)`: the distance noise of a step, :math:`a` [m] plus :math:`c` times the distance.
    heading_noise : float, default 1e-3
        :math:`q_\theta` [rad/√s], the heading-change noise density.
    gyro_bias_prior, gyro_bias_walk : float, default 0.01, 1e-4
        Prior standard deviation of :math:`b_g` about 0 [rad/s], and its random walk [rad/s/√s].
    scale_prior, scale_walk : float, default 0.1, 1e-5
        Prior standard deviation of :math:`s` about 1, and its random walk [1/√s].
    gate : bool, default True
        Reject ranges outside the 99.9 % chi-square gate, component by component, with re-acquisition after 10
        rejected epochs in a row (:class:`uwtutor.filters.gates.ReacquiringGate`), so that the gate never locks out.

    Returns
    -------
    FilterResult
        At ``data.times``: ``x[:, :2]`` the positions, ``x[:, 2]`` the heading, then :math:`b_g` and :math:`s`
        (those estimated, in that order); with ``smooth=True`` the smoothed ``x`` and ``P`` beside the filter's
        priors and innovations. ``extras["ranges"]`` holds the ranges used, ``(K, B)``, NaN where none;
        with ``smooth=True``, ``extras["filtered"]`` holds the filter's own result (its ``x`` and ``P``).

    Raises
    ------
    ValueError
        If the dataset has no start pose, a beacon id is unknown, or a noise parameter is not positive.

    Examples
    --------
    A square driven twice with a 3 % range scale and a gyro bias of 0.002 rad/s, one beacon in the middle:

    >>> import numpy as np
    >>> from uwtutor.datasets import RangeDataset, navigate
    >>> rng = np.random.default_rng(0)
    >>> K, dt = 1601, 0.5
    >>> turn = np.where(np.arange(K) % 200 == 0, np.pi / 2, 0.0)
    >>> turn[0] = 0.0
    >>> odometry = np.column_stack([np.full(K, 0.5), turn + 0.002 * dt])
    >>> odometry[0] = 0.0
    >>> truth = RangeDataset(
    ...     times=dt * np.arange(K),
    ...     odometry=np.column_stack([odometry[:, 0], turn]),
    ...     ranges=np.empty((0, 3)),
    ...     beacons={7: (50.0, 50.0)},
    ...     start=[0.0, 0.0, 0.0],
    ... ).dead_reckoning()
    >>> heard = np.arange(1, K, 4)
    >>> r = 1.03 * np.linalg.norm(
    ...     truth[heard, :2] - [50.0, 50.0], axis=1
    ... ) + rng.normal(0.0, 0.3, heard.size)
    >>> data = RangeDataset(
    ...     times=dt * np.arange(K),
    ...     odometry=odometry,
    ...     ranges=np.column_stack([dt * heard, np.full(heard.size, 7), r]),
    ...     beacons={7: (50.0, 50.0)},
    ...     start=[0.0, 0.0, 0.0],
    ...     truth=truth,
    ... )
    >>> result = navigate(data, range_sigma=0.3)
    >>> result.x.shape
    (1601, 5)
    >>> round(float(result.x[-1, 4]), 2), round(float(result.x[-1, 3]), 3)
    (1.03, 0.002)
    >>> bool(np.linalg.norm(result.x[-1, :2] - truth[-1, :2]) < 1.0)
    True
    """
    smooth, gate = as_flag("smooth", smooth), as_flag("gate", gate)
    nav = navigation_models(data, beacon_ids, min_period=min_period, gyro_bias=gyro_bias, scale=scale,
                            range_sigma=range_sigma, distance_sigma=distance_sigma, heading_noise=heading_noise,
                            gyro_bias_prior=gyro_bias_prior, gyro_bias_walk=gyro_bias_walk,
                            scale_prior=scale_prior, scale_walk=scale_walk)
    chosen_gate = ReacquiringGate(ChiSquareGate(0.999, per_component=True), patience=10) if gate else None
    result = extended_kalman_filter(nav.motion, nav.measurement, nav.x0, nav.P0, nav.u, nav.z, times=nav.times,
                                    gate=chosen_gate)
    extras = dict(result.extras, ranges=nav.z)
    if not smooth:
        return FilterResult(result.times, result.x, result.P, result.x_prior, result.P_prior, result.innovations,
                            result.innovation_cov, extras)
    smoothed = rts_smoother(result, nav.motion, nav.u)
    extras["filtered"] = result
    return FilterResult(result.times, smoothed.x, smoothed.P, result.x_prior, result.P_prior, result.innovations,
                        result.innovation_cov, extras)


@dataclass(frozen=True)
class NavigationModels:
    """The model pair of :func:`navigate` for a log, with its start and the log's inputs and measurements.

    Attributes
    ----------
    motion : uwtutor.models.odometry.OdometryMotion
        The odometry with heading, gyro bias and range scale as :func:`navigate` sets it up.
    measurement : uwtutor.models.range.BeaconRanges
        The ranges to the chosen beacons.
    x0 : ndarray, shape (n,)
        The start state (the log's start pose; gyro bias 0, scale 1).
    P0 : ndarray, shape (n, n)
        Its covariance.
    u : ndarray, shape (K, 2)
        The odometry, the filters' input.
    z : ndarray, shape (K, B)
        The ranges on the epochs, NaN where a beacon was not heard.
    times : ndarray, shape (K,)
        The epochs [s].

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.datasets import square_log
    >>> # a 10 m square driven twice, ranging to two beacons in turn
    >>> data = square_log()
    >>> from uwtutor.datasets import navigation_models
    >>> nav = navigation_models(data, [3], gyro_bias=True, scale=True)
    >>> # the state [x, y, heading, gyro bias, scale]; one range column (beacon 3)
    >>> type(nav.motion).__name__, nav.x0.shape, nav.P0.shape, nav.z.shape
    ('OdometryMotion', (5,), (5, 5), (81, 1))
    """

    motion: OdometryMotion
    measurement: BeaconRanges
    x0: np.ndarray
    P0: np.ndarray
    u: np.ndarray
    z: np.ndarray
    times: np.ndarray


def navigation_models(data: RangeDataset, beacon_ids: Any = None, *, min_period: Any = None, gyro_bias: bool = True,
                      scale: bool = True, range_sigma: Any = 0.6, distance_sigma: tuple[float, float] = (0.01, 0.02),
                      heading_noise: Any = 1e-3, gyro_bias_prior: Any = 0.01, gyro_bias_walk: Any = 1e-4,
                      scale_prior: Any = 0.1, scale_walk: Any = 1e-5) -> NavigationModels:
    r"""The motion/measurement model pair of :func:`navigate` for a log, and what a filter runs it on.

    The same models, noise and start as :func:`navigate` (its parameters, with the same meaning and defaults),
    for any filter of the library: the EKF engine, the smoother, the posterior Cramér-Rao bound
    (:func:`uwtutor.observability.model_posterior_crlb`) or a particle filter.

    Returns
    -------
    NavigationModels

    Examples
    --------
    A straight 50 m drive with a beacon ahead, in the particle filter:

    >>> import numpy as np
    >>> from uwtutor.datasets import RangeDataset, navigation_models
    >>> from uwtutor.filters import BootstrapParticleFilter
    >>> K = 101
    >>> odometry = np.column_stack([np.r_[0.0, np.full(K - 1, 0.5)], np.zeros(K)])
    >>> truth = np.column_stack([0.5 * np.arange(K), np.zeros(K), np.zeros(K)])
    >>> heard = np.arange(1, K, 2)
    >>> ranges = np.column_stack(
    ...     [
    ...         heard * 0.5,
    ...         np.full(heard.size, 3),
    ...         1.02 * np.linalg.norm(truth[heard, :2] - [60.0, 10.0], axis=1),
    ...     ]
    ... )
    >>> data = RangeDataset(
    ...     times=0.5 * np.arange(K),
    ...     odometry=odometry,
    ...     ranges=ranges,
    ...     beacons={3: (60.0, 10.0)},
    ...     truth=truth,
    ... )
    >>> nav = navigation_models(data, range_sigma=0.3)
    >>> nav.motion.layout.names, nav.z.shape
    (('x', 'y', 'heading', 'gyro_bias', 'scale'), (101, 1))
    >>> pf = BootstrapParticleFilter.from_gaussian(
    ...     nav.motion,
    ...     nav.measurement,
    ...     nav.x0,
    ...     nav.P0,
    ...     2000,
    ...     np.random.default_rng(0),
    ...     ess_threshold=0.5,
    ... )
    >>> result = pf.run(nav.z, nav.u, times=nav.times)
    >>> bool(np.linalg.norm(result.x[-1, :2] - truth[-1, :2]) < 1.0)
    True
    """
    if not isinstance(data, RangeDataset):
        raise TypeError(f"data must be a uwtutor.datasets.RangeDataset; got {type(data).__name__}")
    if data.start is None:
        raise ValueError("data has no start pose: build the RangeDataset with start=(x, y, heading) (and "
                         "start_cov), or with truth, whose first row is the default start")
    gyro_bias, scale = as_flag("gyro_bias", gyro_bias), as_flag("scale", scale)
    ids = list(data.beacons) if beacon_ids is None else beacon_ids
    z = data.ranges_on_epochs(ids, min_period=min_period)
    beacons = data.beacon_positions(ids)
    sigma_r = _positive("range_sigma", range_sigma)
    # standard deviations: their squares stay within the covariances' bound, 1e150
    a, c = (float(v) for v in as_nonnegative("distance_sigma", distance_sigma, shape=(2,), max_abs=1e75))
    q_heading = _positive("heading_noise", heading_noise)
    if a <= 0.0:
        raise ValueError(f"distance_sigma[0] must be > 0 (a step's distance is never exact); got {a}")

    dt = np.diff(data.times, prepend=data.times[0])
    distance = np.abs(data.odometry[:, 0])
    # a step of zero length (the first) still gets a tiny heading noise, so that Q is never singular
    sigma_heading = q_heading * np.sqrt(dt) + 1e-9
    motion = OdometryMotion(a + c * distance, sigma_heading, gyro_bias=gyro_bias, scale=scale, times=data.times,
                            order="move-first",
                            gyro_bias_walk=_positive("gyro_bias_walk", gyro_bias_walk) if gyro_bias else 0.0,
                            scale_walk=_positive("scale_walk", scale_walk) if scale else 0.0)
    measurement = BeaconRanges(beacons, R=sigma_r**2, layout=motion.layout)
    extra = {}
    if gyro_bias:
        extra["gyro_bias"] = (0.0, _positive("gyro_bias_prior", gyro_bias_prior))
    if scale:
        extra["scale"] = (1.0, _positive("scale_prior", scale_prior))
    x0, P0 = motion.layout.initial_state(as_finite("data.start", data.start, shape=(3,)), data.start_cov, **extra)
    return NavigationModels(motion=motion, measurement=measurement, x0=x0, P0=P0, u=data.odometry, z=z,
                            times=data.times)
