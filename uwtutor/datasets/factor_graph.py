r"""An outside anchor: GTSAM's batch solution of a log, a factor graph of poses, odometry and ranges (chapter 11).

GTSAM (Dellaert and contributors) solves navigation as a **factor graph**: one unknown ``Pose2`` per epoch,
:math:`\mathbf x_k = (x_k, y_k, \theta_k)`, and one factor per piece of information,

* a prior on the start pose, :math:`\mathcal N(\mathbf x_0;\ \text{start},\ \mathbf P_0)`
  (``PriorFactorPose2``);
* between consecutive poses, the odometry as a relative pose, ``BetweenFactorPose2`` with the measurement
  ``Pose2(d_k, 0, Δθ_k)``: move :math:`d_k` along the previous heading, then turn -- the composition
  :math:`\mathbf x_k = \mathbf x_{k-1} \oplus (d_k, 0, \Delta\theta_k)`, the odometry's own convention
  (:meth:`~uwtutor.datasets.RangeDataset.dead_reckoning`);
* for every range, ``RangeFactor2D`` between the pose of its epoch and the beacon, a ``Point2`` held at its surveyed
  position by a ``NonlinearEqualityPoint2`` (a hard constraint: the beacons are known, as in this book);

and finds the maximum a posteriori (MAP) trajectory, the poses minimizing the sum of the factors' squared
whitened errors, with Levenberg--Marquardt from an initial guess (here the dead reckoning). Each factor's noise
is diagonal in the frame of the previous pose: :math:`[\sigma_{\text{along}}, \sigma_{\text{across}},
\sigma_{\theta}]`.

The graph holds the same information as the filter of :func:`~uwtutor.datasets.navigate` with two differences:
it uses *every* range for *every* pose (it is a smoother), and its standard factors have no gyro bias and no range
scale. A heading that drifts can only be absorbed by the heading noise of the odometry factors
(``heading_noise``); a scale can only be removed from the ranges before they enter (``range_scale``).

References
----------
Dellaert, F. and Kaess, M. (2017). Factor graphs for robot perception. *Foundations and Trends in Robotics* 6(1-2).
GTSAM 4.3 (BSD): ``examples/RangeISAMExample_plaza2.cpp`` builds the same graph on the same data (with iSAM2 and
unknown beacons).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._validate import as_finite, as_int, as_nonnegative, as_scalar
from ._core import RangeDataset

__all__ = ["GraphSolution", "gtsam_map", "HEADING_NOISE"]

#: Default heading noise density of the odometry factors [rad/√s], loose enough that a heading random walk can
#: follow a drift of a few mrad/s (a one-sigma step of 0.01 rad per second), as the Plaza 2 heading drifts.
HEADING_NOISE = 0.01


@dataclass(frozen=True)
class GraphSolution:
    """GTSAM's MAP trajectory of a log.

    Attributes
    ----------
    times : ndarray, shape (K,)
        The epochs [s].
    poses : ndarray, shape (K, 3)
        ``[x, y, heading]`` of every epoch.
    n_ranges : int
        Range factors in the graph.
    iterations : int
        Levenberg--Marquardt iterations.
    initial_error : float
        The graph's error (half the sum of squared whitened residuals) at the initial guess.
    final_error : float
        The same at the solution.
    seconds : float
        Wall time of the optimization (the graph's construction excluded).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.datasets import square_log
    >>> # a 10 m square driven twice, ranging to two beacons in turn
    >>> data = square_log()
    >>> from uwtutor.datasets.factor_graph import gtsam_map
    >>> sol = gtsam_map(data, [3, 7], range_sigma=0.1)
    >>> sol.poses.shape, sol.n_ranges
    ((81, 3), 80)
    >>> bool(sol.final_error <= sol.initial_error)
    True
    """

    times: np.ndarray
    poses: np.ndarray
    n_ranges: int
    iterations: int
    initial_error: float
    final_error: float
    seconds: float


def _positive(name: str, value: Any) -> float:
    # bounded so that its square (a variance) neither underflows to 0 nor overflows
    return as_scalar(name, value, domain="positive", low=1e-9, high=1e6)


def gtsam_map(data: RangeDataset, beacon_ids: Any = None, *, min_period: Any = None, range_scale: Any = 1.0,
              range_sigma: Any = 0.6, distance_sigma: Any = (0.01, 0.02), across_sigma: Any = 0.002,
              heading_noise: Any = HEADING_NOISE, initial: Any = None, max_iterations: int = 100) -> GraphSolution:
    r"""GTSAM's batch MAP solution of a log: ``Pose2`` odometry factors, ``RangeFactor2D`` to known beacons, LM.

    Parameters
    ----------
    data : RangeDataset
        The log, with a start pose.
    beacon_ids : sequence of int, optional
        The beacons used (default: all).
    min_period : float, optional
        At most one range per beacon every ``min_period`` seconds (as
        :meth:`~uwtutor.datasets.RangeDataset.ranges_on_epochs`).
    range_scale : float, default 1
        Every range is divided by it before it enters the graph (1: the ranges as logged; the log's scale: the
        scale removed).
    range_sigma : float, default 0.6
        Standard deviation of a range factor [m].
    distance_sigma : (float, float), default (0.01, 0.02)
        :math:`(a, c)`: the along-track noise of an odometry factor, :math:`a + c\,d_k` [m].
    across_sigma : float, default 0.002
        Its across-track noise [m] (the odometry moves straight along the previous heading: nearly zero).
    heading_noise : float, default ``HEADING_NOISE``
        :math:`q_\theta` [rad/√s]: the heading noise of a step of :math:`\Delta t_k` seconds is
        :math:`q_\theta\sqrt{\Delta t_k}`.
    initial : array_like, shape (K, 3), optional
        The initial guess of the poses (default: the dead reckoning from the start).
    max_iterations : int, default 100
        Levenberg--Marquardt's limit.

    Returns
    -------
    GraphSolution

    Raises
    ------
    ModuleNotFoundError
        When gtsam is not installed (``pip install "uwtutor[data]"``).

    Examples
    --------
    A square with a range to one of two beacons at every epoch, odometry without error: the MAP is the truth.

    >>> import numpy as np
    >>> import pytest
    >>> gtsam = pytest.importorskip("gtsam")
    >>> from uwtutor.datasets import RangeDataset
    >>> from uwtutor.datasets.factor_graph import gtsam_map
    >>> K = 41
    >>> turn = np.where(np.arange(K) % 10 == 1, np.pi / 2, 0.0)
    >>> turn[:2] = 0.0
    >>> odo = np.column_stack([np.r_[0.0, np.ones(K - 1)], turn])
    >>> truth = RangeDataset(
    ...     times=np.arange(K, dtype=float),
    ...     odometry=odo,
    ...     ranges=np.zeros((0, 3)),
    ...     beacons={1: (5.0, 12.0)},
    ...     start=[0.0, 0.0, 0.0],
    ... ).dead_reckoning()
    >>> beacons = {1: (5.0, 12.0), 2: (-4.0, 3.0)}
    >>> ids = np.where(np.arange(1, K) % 2 == 0, 1, 2)
    >>> b = np.array([beacons[int(i)] for i in ids])
    >>> r = np.linalg.norm(truth[1:, :2] - b, axis=1)
    >>> data = RangeDataset(
    ...     times=np.arange(K, dtype=float),
    ...     odometry=odo,
    ...     ranges=np.column_stack([np.arange(1.0, K), ids, r]),
    ...     beacons=beacons,
    ...     truth=truth,
    ... )
    >>> solution = gtsam_map(data, initial=truth + [0.5, -0.3, 0.05])
    >>> solution.poses.shape, solution.n_ranges
    ((41, 3), 40)
    >>> bool(np.abs(solution.poses[:, :2] - truth[:, :2]).max() < 1e-3)
    True
    """
    try:
        import gtsam  # type: ignore[import-not-found]
        from gtsam.symbol_shorthand import L, X  # type: ignore[import-not-found]
    except ModuleNotFoundError:
        raise ModuleNotFoundError('gtsam_map needs GTSAM: pip install "uwtutor[data]" (or pip install '
                                  '"gtsam>=4.3,<4.4")') from None
    if not isinstance(data, RangeDataset):
        raise TypeError(f"data must be a uwtutor.datasets.RangeDataset; got {type(data).__name__}")
    if data.start is None:
        raise ValueError("data has no start pose: build the RangeDataset with start= (or truth=)")
    ids = list(data.beacons) if beacon_ids is None else list(np.atleast_1d(beacon_ids).tolist())
    z = data.ranges_on_epochs(ids, min_period=min_period) / _positive("range_scale", range_scale)
    beacons = data.beacon_positions(ids)
    a, c = (float(v) for v in as_nonnegative("distance_sigma", distance_sigma, shape=(2,)))
    if a <= 0.0:
        raise ValueError(f"distance_sigma[0] must be > 0; got {a}")
    across = _positive("across_sigma", across_sigma)
    q_heading = _positive("heading_noise", heading_noise)
    sigma_r = _positive("range_sigma", range_sigma)
    iterations = as_int("max_iterations", max_iterations, minimum=1, maximum=10_000)
    K = data.n_epochs
    guess = data.dead_reckoning() if initial is None else as_finite("initial", initial, shape=(K, 3))

    graph = gtsam.NonlinearFactorGraph()
    values = gtsam.Values()
    graph.add(gtsam.PriorFactorPose2(X(0), gtsam.Pose2(*map(float, data.start)),
                                     gtsam.noiseModel.Gaussian.Covariance(np.asarray(data.start_cov, dtype=float))))
    dt = np.diff(data.times, prepend=data.times[0])
    for k in range(K):
        values.insert(X(k), gtsam.Pose2(*map(float, guess[k])))
    for k in range(1, K):
        d, turn = (float(v) for v in data.odometry[k])
        sigmas = np.array([a + c * abs(d), across, q_heading * np.sqrt(dt[k]) + 1e-9])
        graph.add(gtsam.BetweenFactorPose2(X(k - 1), X(k), gtsam.Pose2(d, 0.0, turn),
                                           gtsam.noiseModel.Diagonal.Sigmas(sigmas)))
    for j, b in enumerate(beacons):
        point = gtsam.Point2(float(b[0]), float(b[1]))
        values.insert(L(j), point)
        graph.add(gtsam.NonlinearEqualityPoint2(L(j), point))
    noise = gtsam.noiseModel.Isotropic.Sigma(1, sigma_r)
    epochs, which = np.nonzero(np.isfinite(z))
    for k, j in zip(epochs.tolist(), which.tolist()):
        graph.add(gtsam.RangeFactor2D(X(k), L(j), float(z[k, j]), noise))
    params = gtsam.LevenbergMarquardtParams()
    params.setMaxIterations(iterations)
    optimizer = gtsam.LevenbergMarquardtOptimizer(graph, values, params)
    start = time.perf_counter()
    solution = optimizer.optimize()
    seconds = time.perf_counter() - start
    poses = np.array(gtsam.utilities.extractPose2(solution), dtype=float).reshape(K, 3)
    return GraphSolution(times=data.times, poses=poses, n_ranges=int(epochs.size),
                         iterations=int(optimizer.iterations()), initial_error=float(graph.error(values)),
                         final_error=float(graph.error(solution)), seconds=seconds)
