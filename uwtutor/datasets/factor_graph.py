r"""An outside anchor: GTSAM's MAP solution of a log as a factor graph (chapter 11).

GTSAM (Dellaert and contributors) solves navigation as a **factor graph**: unknowns and one factor per piece of
information, solved for the maximum a posteriori (MAP) trajectory -- the values minimizing the sum of the factors'
squared whitened errors -- by Levenberg--Marquardt (batch) or iSAM2 (incremental). :func:`gtsam_map` builds, by
default, the graph of **the same model as** :func:`~uwtutor.datasets.navigate` (``model="navigate"``):

* one ``Pose2`` :math:`\mathbf x_k = (x_k, y_k, \theta_k)` per epoch, a gyro bias :math:`b_k` and a range scale
  :math:`s_k` per epoch (the chains of navigate's random walks);
* priors: the start pose (``PriorFactorPose2``), :math:`b_0 \sim \mathcal N(0, \sigma_{b,0}^2)` and
  :math:`s_0 \sim \mathcal N(1, \sigma_{s,0}^2)` (``PriorFactorDouble``);
* the random walks :math:`b_k - b_{k-1} \sim \mathcal N(0, q_b\Delta t_k)`, :math:`s_k - s_{k-1} \sim
  \mathcal N(0, q_s\Delta t_k)` (``BetweenFactorDouble``);
* the odometry, navigate's move-then-turn step with its noise
  :math:`\operatorname{diag}(a + c\,|d_k|,\ \sigma_\perp,\ q_\theta\sqrt{\Delta t_k})` along, across and in
  heading (the filter has no across-track noise; the graph needs a small one, ``across_sigma``), with the error
  of a step

  .. math::

      \mathbf e_k = \begin{bmatrix} R(\theta_{k-1})^\mathsf{T}(p_k - p_{k-1}) - (d_k, 0) \\
      \theta_k - \theta_{k-1} - \Delta\theta_k + b_{k-1}\Delta t_k \end{bmatrix};

  with a gyro bias, the steps between two pose variables (at every range, and at least every ``pose_interval``)
  are pre-integrated into one factor, as GTSAM's IMU factors pre-integrate;
* one factor per range, :math:`e = s_k\,\lVert p_k - b_j\rVert - z_{k,j}` with :math:`\sigma_r`, optionally
  behind a robust kernel (Huber).

GTSAM's Python wheel has compiled factors for the priors, the scalar random walks, a ``Pose2`` odometry without a
bias (``BetweenFactorPose2``) and a range without a scale (``RangeFactor2D``), and none for a relative pose that
depends on a third, scalar variable (the bias) or a range multiplied by one (the scale): those two are
``CustomFactor``\ s, Python callbacks at about 0.1 ms a call -- most of the solve time, and the reason the biased
odometry is pre-integrated between pose variables rather than written step by step. With ``gyro_bias=False`` or
``scale=False`` the compiled factors take their place.

``model="pose"`` gives the graph of poses alone (no bias, no scale): a heading that drifts can then only be
absorbed by a looser heading noise of the odometry factors, and a scale only removed from the ranges before they
enter (``range_scale``) -- the graph a user of GTSAM's standard factors writes first.

References
----------
Dellaert, F. and Kaess, M. (2017). Factor graphs for robot perception. *Foundations and Trends in Robotics* 6(1-2).
Kaess, M. et al. (2012). iSAM2: incremental smoothing and mapping using the Bayes tree. *IJRR* 31(2).
GTSAM 4.3 (BSD): ``examples/RangeISAMExample_plaza2.cpp`` solves the same data (with unknown beacons).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np
from numpy.typing import ArrayLike

from .._validate import as_choice, as_finite, as_flag, as_int, as_nonnegative, as_scalar
from ._core import BeaconIds, RangeDataset

__all__ = ["GraphSolution", "gtsam_map", "HEADING_NOISE"]

#: Default heading noise density [rad/√s] of the pose-only graph's odometry factors (``model="pose"``): loose enough
#: that a heading random walk can follow a drift of a few mrad/s, as the Plaza 2 heading drifts. The same-model
#: graph uses navigate's own (1e-3), since its gyro-bias chain follows the drift.
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
        Levenberg--Marquardt iterations (0 for iSAM2).
    initial_error : float
        The graph's error (half the sum of squared whitened residuals) at the initial guess.
    final_error : float
        The same at the solution.
    seconds : float
        Wall time of the optimization (the graph's construction excluded).
    gyro_bias : ndarray, shape (K,)
        :math:`b_k` [rad/s] (NaN when the graph has none).
    scale : ndarray, shape (K,)
        :math:`s_k` (NaN when the graph has none).
    model : str
        What was built and how it was solved.
    solver : str
        What was built and how it was solved.
    n_poses : int
        Pose variables in the graph (every epoch, or fewer with a gyro bias: ``pose_interval``).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.datasets import square_log
    >>> # a 10 m square driven twice, ranging to two beacons in turn
    >>> data = square_log()
    >>> from uwtutor.datasets.factor_graph import gtsam_map
    >>> sol = gtsam_map(data, [3, 7], range_sigma=0.1)
    >>> sol.poses.shape, sol.n_ranges, sol.model
    ((81, 3), 80, 'navigate')
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
    gyro_bias: np.ndarray = field(default_factory=lambda: np.empty(0))
    scale: np.ndarray = field(default_factory=lambda: np.empty(0))
    model: str = "navigate"
    solver: str = "lm"
    n_poses: int = 0


def _positive(name: str, value: Any) -> float:
    # bounded so that its square (a variance) neither underflows to 0 nor overflows
    return as_scalar(name, value, domain="positive", low=1e-9, high=1e6)


def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def _scaled_range_error(beacon: np.ndarray, z: float) -> Callable[..., np.ndarray]:
    r"""The error :math:`s_k\,\lVert p_k - b_j\rVert - z` of a range with a scale, and its Jacobians."""
    bx, by = float(beacon[0]), float(beacon[1])

    def error(this: Any, values: Any, H: list[np.ndarray] | None) -> np.ndarray:
        keys = this.keys()
        pose, s = values.atPose2(keys[0]), values.atDouble(keys[1])
        ex, ey = pose.x() - bx, pose.y() - by
        dist = math.hypot(ex, ey)
        if H is not None:
            ux, uy = ex / max(dist, 1e-9), ey / max(dist, 1e-9)
            c, sn = math.cos(pose.theta()), math.sin(pose.theta())
            H[0] = np.array([[s * (ux * c + uy * sn), s * (-ux * sn + uy * c), 0.0]])
            H[1] = np.array([[dist]])
        return np.array([s * dist - z])

    return error


def gtsam_map(data: RangeDataset, beacon_ids: BeaconIds = None, *, min_period: float | None = None, offset: float = 0.0,
              thinning: str = "per beacon", model: str = "navigate", gyro_bias: bool = True, scale: bool = True,
              range_sigma: float = 0.6, distance_sigma: ArrayLike = (0.01, 0.02), across_sigma: float = 0.002,
              heading_noise: float | None = None, gyro_bias_prior: float = 0.01, gyro_bias_walk: float = 1e-4,
              scale_prior: float = 0.1, scale_walk: float = 1e-5, range_scale: float = 1.0, robust: str | None = None,
              solver: str = "lm", initial: ArrayLike | None = None, max_iterations: int = 100,
              pose_interval: float = 2.0) -> GraphSolution:
    r"""GTSAM's MAP solution of a log: by default the graph of navigate's model (module docstring), batch or iSAM2.

    Parameters
    ----------
    data : RangeDataset
        The log, with a start pose.
    beacon_ids : sequence of int, optional
        The beacons used (default: all).
    min_period, offset, thinning
        The range schedule, as :meth:`~uwtutor.datasets.RangeDataset.ranges_on_epochs` thins the log.
    model : {"navigate", "pose"}, default "navigate"
        The same model as :func:`~uwtutor.datasets.navigate` (with ``gyro_bias`` and ``scale`` as there), or
        poses alone.
    gyro_bias, scale : bool, default True
        The gyro-bias and range-scale chains of ``model="navigate"`` (ignored by ``"pose"``). Pass the states
        navigate chose (``result.extras["states"]``) to solve the same model as its default.
    range_sigma, distance_sigma, gyro_bias_prior, gyro_bias_walk, scale_prior, scale_walk
        navigate's noise, with its defaults and meaning.
    across_sigma : float, default 0.002
        The across-track noise of an odometry factor [m] (nearly zero: the odometry moves along its heading).
    heading_noise : float, optional
        :math:`q_\theta` [rad/√s]; default navigate's 1e-3 for ``"navigate"`` and ``HEADING_NOISE`` for ``"pose"``.
    range_scale : float, default 1
        Every range is divided by it before it enters the graph (the pose-only graph's way to remove a scale
        measured elsewhere -- against the truth, in chapter 11).
    robust : {None, "huber"}, default None
        A Huber kernel (k = 1.345) on the range factors.
    solver : {"lm", "isam2"}, default "lm"
        Batch Levenberg--Marquardt, or iSAM2 fed epoch by epoch (its estimate after the last epoch).
    initial : array_like, shape (K, 3), optional
        The initial guess of the poses (default: the dead reckoning; the bias starts at 0, the scale at 1).
    max_iterations : int, default 100
        Levenberg--Marquardt's limit.
    pose_interval : float, default 2
        With a gyro bias: the longest time [s] between two pose variables. Every epoch with a range has one; the
        odometry between two is pre-integrated into one factor (its noise propagated step by step), and the
        poses between are the odometry from the earlier variable with its bias, the mismatch at the later one
        spread over the segment.

    Returns
    -------
    GraphSolution

    Raises
    ------
    ModuleNotFoundError
        When gtsam is not installed (``pip install "uwtutor[data]"``).

    Examples
    --------
    A square with a range to one of two beacons at every epoch, odometry without error and ranges 3 % long: the
    same-model graph finds the scale and the track.

    >>> import numpy as np
    >>> import pytest
    >>> gtsam = pytest.importorskip("gtsam")
    >>> from uwtutor.datasets import square_log
    >>> from uwtutor.datasets.factor_graph import gtsam_map
    >>> data = square_log(range_scale=1.03)
    >>> solution = gtsam_map(data, range_sigma=0.05)
    >>> solution.poses.shape, solution.n_ranges
    ((81, 3), 80)
    >>> round(float(solution.scale[-1]), 3)
    1.03
    >>> bool(np.abs(solution.poses[:, :2] - data.truth[:, :2]).max() < 0.05)
    True

    The pose-only graph, solved incrementally, with the scale removed beforehand:

    >>> pose_only = gtsam_map(data, model="pose", range_scale=1.03, solver="isam2")
    >>> bool(np.abs(pose_only.poses[:, :2] - data.truth[:, :2]).max() < 0.05)
    True
    """
    gtsam = _import_gtsam()
    from gtsam.symbol_shorthand import B, S, X
    if not isinstance(data, RangeDataset):
        raise TypeError(f"data must be a uwtutor.datasets.RangeDataset; got {type(data).__name__}")
    if data.start is None:
        raise ValueError("data has no start pose: build the RangeDataset with start= (or truth=)")
    model = as_choice("model", model, ("navigate", "pose"))
    solver = as_choice("solver", solver, ("lm", "isam2"))
    if robust is not None:
        robust = as_choice("robust", robust, ("huber",))
    with_bias = model == "navigate" and as_flag("gyro_bias", gyro_bias)
    with_scale = model == "navigate" and as_flag("scale", scale)
    ids = list(data.beacons) if beacon_ids is None else list(np.atleast_1d(beacon_ids).tolist())
    z = (data.ranges_on_epochs(ids, min_period=min_period, offset=offset, thinning=thinning)
         / _positive("range_scale", range_scale))
    beacons = data.beacon_positions(ids)
    a, c = _distance_sigma(distance_sigma)
    across = _positive("across_sigma", across_sigma)
    q_heading = _positive("heading_noise", (1e-3 if model == "navigate" else HEADING_NOISE)
                          if heading_noise is None else heading_noise)
    sigma_r = _positive("range_sigma", range_sigma)
    iterations = as_int("max_iterations", max_iterations, minimum=1, maximum=10_000)
    K = data.n_epochs
    guess = data.dead_reckoning() if initial is None else as_finite("initial", initial, shape=(K, 3))
    dt = np.diff(data.times, prepend=data.times[0])
    # the pose variables: every epoch, except with a gyro bias, where the odometry between two variables is
    # pre-integrated (one factor per segment; _Segment) and the poses between are filled in after the solve
    kept = (_pose_epochs(z, data.times, _positive("pose_interval", pose_interval)) if with_bias
            else np.arange(K))
    range_noise = _range_noise(gtsam, sigma_r, robust)
    n = len(kept)
    steps_of: list[Any] = [None] * n           # what moves node i - 1 to node i (iSAM2's initial guesses)
    node_factors: list[list[Any]] = [[] for _ in range(n)]
    node_values = [gtsam.Values() for _ in range(n)]
    walk_b, walk_s = _start_factors(gtsam, data.start, data.start_cov, beacons, node_factors[0], node_values[0],
                                    (gyro_bias_prior, gyro_bias_walk) if with_bias else None,
                                    (scale_prior, scale_walk) if with_scale else None)
    sigma_d = a + c * np.abs(data.odometry[:, 0])
    sigma_theta = q_heading * np.sqrt(dt) + 1e-9
    for i, k in enumerate(kept.tolist()):
        factors = node_factors[i]
        _insert_guess(gtsam, node_values[i], i, guess[k], with_bias, with_scale)
        if i > 0:
            before = int(kept[i - 1])
            steps = slice(before + 1, k + 1)
            if with_bias:
                steps_of[i] = _Segment(data.odometry[steps], dt[steps], sigma_d[steps], sigma_theta[steps], across)
            else:
                steps_of[i] = tuple(float(v) for v in data.odometry[k])
            factors.extend(_odometry_factors(gtsam, i, steps_of[i], float(data.times[k] - data.times[before]),
                                             (float(sigma_d[k]), across, float(sigma_theta[k])), walk_b, walk_s))
        factors.extend(_range_factors(gtsam, i, z[k], beacons, range_noise, with_scale))

    graph, values = _joined(gtsam, node_factors, node_values)
    start = time.perf_counter()
    if solver == "lm":
        solution, n_iter = _solve_in_batch(gtsam, graph, values, iterations)
    else:
        solution = _solve_incrementally(gtsam, node_factors, node_values, steps_of, with_bias, with_scale,
                                        iterations)
        n_iter = 0
    seconds = time.perf_counter() - start
    nodes = np.array([[p.x(), p.y(), p.theta()] for p in (solution.atPose2(X(i)) for i in range(n))])
    bias = np.array([solution.atDouble(B(i)) for i in range(n)]) if with_bias else np.zeros(n)
    poses = _fill_between(nodes, kept, bias, data.odometry, dt) if with_bias else nodes
    per_epoch = np.searchsorted(kept, np.arange(K), side="right") - 1       # the node at or before each epoch
    nan = np.full(K, np.nan)
    return GraphSolution(times=data.times, poses=poses, n_ranges=int(np.isfinite(z).sum()), iterations=n_iter,
                         initial_error=float(graph.error(values)), final_error=float(graph.error(solution)),
                         seconds=seconds, gyro_bias=bias[per_epoch] if with_bias else nan,
                         scale=np.array([solution.atDouble(S(i)) for i in range(n)])[per_epoch] if with_scale
                         else nan, model=model, solver=solver, n_poses=n)


def _range_noise(gtsam: Any, sigma: float, robust: str | None) -> Any:
    """The noise model of every range factor: sigma, behind a Huber kernel (k = 1.345) with ``robust="huber"``."""
    unit = gtsam.noiseModel.Isotropic.Sigma(1, sigma)
    return (gtsam.noiseModel.Robust.Create(gtsam.noiseModel.mEstimator.Huber.Create(1.345), unit)
            if robust == "huber" else unit)


def _joined(gtsam: Any, node_factors: list[list[Any]], node_values: list[Any]) -> tuple[Any, Any]:
    """The whole graph and its initial values, from those of every node in order."""
    graph = gtsam.NonlinearFactorGraph()
    values = gtsam.Values()
    for factors, vals in zip(node_factors, node_values):
        for f in factors:
            graph.add(f)
        values.insert(vals)
    return graph, values


def _import_gtsam() -> Any:
    """The gtsam module, or an error that says how to install it."""
    try:
        import gtsam
    except ModuleNotFoundError:
        raise ModuleNotFoundError('gtsam_map needs GTSAM: pip install "uwtutor[data]" (or pip install '
                                  '"gtsam>=4.3,<4.4")') from None
    return gtsam


def _distance_sigma(value: Any) -> tuple[float, float]:
    """``distance_sigma`` checked: the odometry's (a, c) of a + c |d|, a > 0, both at most 1e6."""
    # bounded like the other standard deviations, so that the factors' information neither underflows nor overflows
    a, c = (float(v) for v in as_nonnegative("distance_sigma", value, shape=(2,)))
    if max(a, c) > 1e6:
        raise ValueError(f"distance_sigma must be at most 1e+06 (a standard deviation in m and m/m); got "
                         f"({a:.3g}, {c:.3g}). Check its units")
    if a <= 0.0:
        raise ValueError(f"distance_sigma[0] must be > 0; got {a}")
    return a, c


def _solve_in_batch(gtsam: Any, graph: Any, values: Any, iterations: int) -> tuple[Any, int]:
    """Levenberg--Marquardt from ``values``: the solution and the iterations it took."""
    params = gtsam.LevenbergMarquardtParams()
    params.setMaxIterations(iterations)
    optimizer = gtsam.LevenbergMarquardtOptimizer(graph, values, params)
    solution = optimizer.optimize()
    return solution, int(optimizer.iterations())


def _pose_epochs(z: np.ndarray, times: np.ndarray, interval: float) -> np.ndarray:
    """The epochs with a pose variable: the first, the last, every one with a range, and no gap over ``interval``."""
    K = len(times)
    keep = np.isfinite(z).any(axis=1)
    keep[[0, K - 1]] = True
    last = times[0]
    for k in range(K):
        if keep[k] or times[k] - last >= interval:
            keep[k] = True
            last = times[k]
    return np.nonzero(keep)[0]


def _insert_guess(gtsam: Any, values: Any, i: int, pose: np.ndarray, with_bias: bool, with_scale: bool) -> None:
    """Node ``i``'s initial values: the guessed pose, gyro bias 0 and range scale 1 (where the graph has them)."""
    from gtsam.symbol_shorthand import B, S, X
    values.insert(X(i), gtsam.Pose2(*map(float, pose)))
    if with_bias:
        values.insert(B(i), 0.0)
    if with_scale:
        values.insert(S(i), 1.0)


def _start_factors(gtsam: Any, start: np.ndarray, start_cov: np.ndarray | None, beacons: np.ndarray, first: list[Any],
                   values: Any, bias: tuple[Any, Any] | None, scale: tuple[Any, Any] | None) -> tuple[float, float]:
    """Add the first node's priors (and the fixed beacons); return the checked bias and scale walks (0: no chain)."""
    # bias and scale: (prior, walk) as given, or None for a graph without that chain; without a scale the beacons
    # are variables fixed where they are (RangeFactor2D ranges to a variable)
    from gtsam.symbol_shorthand import B, L, S, X
    first.append(gtsam.PriorFactorPose2(X(0), gtsam.Pose2(*map(float, start)),
                                        gtsam.noiseModel.Gaussian.Covariance(np.asarray(start_cov, float))))
    walk_b = walk_s = 0.0
    if bias is not None:
        first.append(gtsam.PriorFactorDouble(B(0), 0.0, gtsam.noiseModel.Isotropic.Sigma(
            1, _positive("gyro_bias_prior", bias[0]))))
        walk_b = _positive("gyro_bias_walk", bias[1])
    if scale is not None:
        first.append(gtsam.PriorFactorDouble(S(0), 1.0, gtsam.noiseModel.Isotropic.Sigma(
            1, _positive("scale_prior", scale[0]))))
        walk_s = _positive("scale_walk", scale[1])
    else:
        for j, b in enumerate(beacons):
            point = gtsam.Point2(float(b[0]), float(b[1]))
            values.insert(L(j), point)
            first.append(gtsam.NonlinearEqualityPoint2(L(j), point))
    return walk_b, walk_s


def _odometry_factors(gtsam: Any, i: int, step: Any, span: float, sigmas: tuple[float, float, float],
                      walk_b: float, walk_s: float) -> list[Any]:
    """The factors from node ``i - 1`` to node ``i``: the odometry, then the bias and scale walks (0: no chain)."""
    # step: a _Segment pre-integrated with the gyro bias, else one step (d, turn) with ``sigmas`` along, across
    # and in heading; span: the seconds between the two nodes
    from gtsam.symbol_shorthand import B, S, X
    factors: list[Any] = []
    if isinstance(step, _Segment):
        factors.append(gtsam.CustomFactor(gtsam.noiseModel.Gaussian.Covariance(step.covariance),
                                          [X(i - 1), X(i), B(i - 1)], step.error))
        factors.append(gtsam.BetweenFactorDouble(B(i - 1), B(i), 0.0, gtsam.noiseModel.Isotropic.Sigma(
            1, walk_b * np.sqrt(span) + 1e-12)))
    else:
        d, turn = step
        odo_noise = gtsam.noiseModel.Diagonal.Sigmas(np.array(sigmas))
        factors.append(gtsam.BetweenFactorPose2(X(i - 1), X(i), gtsam.Pose2(d, 0.0, turn), odo_noise))
    if walk_s:
        factors.append(gtsam.BetweenFactorDouble(S(i - 1), S(i), 0.0, gtsam.noiseModel.Isotropic.Sigma(
            1, walk_s * np.sqrt(span) + 1e-12)))
    return factors


def _range_factors(gtsam: Any, i: int, z: np.ndarray, beacons: np.ndarray, noise: Any, with_scale: bool
                   ) -> list[Any]:
    """One factor per range in ``z`` (node ``i``'s row): the scaled range with a scale, ``RangeFactor2D`` without."""
    from gtsam.symbol_shorthand import L, S, X
    if with_scale:
        return [gtsam.CustomFactor(noise, [X(i), S(i)], _scaled_range_error(beacons[j], float(z[j])))
                for j in np.nonzero(np.isfinite(z))[0].tolist()]
    return [gtsam.RangeFactor2D(X(i), L(j), float(z[j]), noise) for j in np.nonzero(np.isfinite(z))[0].tolist()]


def _solve_incrementally(gtsam: Any, node_factors: list[list[Any]], node_values: list[Any], steps_of: list[Any],
                         with_bias: bool, with_scale: bool, iterations: int) -> Any:
    """iSAM2 fed node by node, each new node's guess from the estimate so far; its estimate after the last node."""
    from gtsam.symbol_shorthand import B, S, X
    isam_params = gtsam.ISAM2Params()
    isam_params.relinearizeSkip = 1            # relinearize at every update, not every tenth
    isam = gtsam.ISAM2(isam_params)
    for i, (factors, vals) in enumerate(zip(node_factors, node_values)):
        step = gtsam.NonlinearFactorGraph()
        for f in factors:
            step.add(f)
        if i > 0:
            # each new node starts where the current estimate and its odometry put it (the dead reckoning
            # of the whole log can be far off by then, and iSAM2's Gauss-Newton steps are not damped)
            vals = gtsam.Values()
            before = isam.calculateEstimatePose2(X(i - 1))
            bias_now = isam.calculateEstimateDouble(B(i - 1)) if with_bias else 0.0
            if with_bias:
                seg = steps_of[i]
                dx, dy = seg.delta + seg.jac * bias_now
                c0, s0 = math.cos(before.theta()), math.sin(before.theta())
                vals.insert(X(i), gtsam.Pose2(before.x() + c0 * dx - s0 * dy, before.y() + s0 * dx + c0 * dy,
                                              before.theta() + seg.phi - seg.elapsed * bias_now))
                vals.insert(B(i), bias_now)
            else:
                vals.insert(X(i), before.compose(gtsam.Pose2(steps_of[i][0], 0.0, steps_of[i][1])))
            if with_scale:
                vals.insert(S(i), isam.calculateEstimateDouble(S(i - 1)))
        isam.update(step, vals)
    for _ in range(iterations if iterations < 10 else 10):   # let the last relinearizations settle
        isam.update()
    return isam.calculateEstimate()


class _Segment:
    r"""The odometry between two pose variables, pre-integrated at zero gyro bias with its first-order bias
    correction (as GTSAM's IMU factors pre-integrate), and the covariance of its noise propagated through the
    filter's own linearization (each step's :math:`\operatorname{diag}(\sigma_d, \sigma_\perp, \sigma_\theta)`
    along, across and in heading): the same model as one factor per step, with one Python callback instead of
    one per step. :math:`\Delta p(b) = \Delta p_0 + J b`, :math:`\varphi(b) = \varphi_0 - T b`."""

    def __init__(self, odometry: np.ndarray, dt: np.ndarray, sigma_d: np.ndarray, sigma_theta: np.ndarray,
                 across: float) -> None:
        phi = elapsed = 0.0
        delta = np.zeros(2)
        jac = np.zeros(2)
        cov = np.zeros((3, 3))
        for (d, turn), step, sd, st in zip(odometry.tolist(), dt.tolist(), sigma_d.tolist(), sigma_theta.tolist()):
            c, s = math.cos(phi), math.sin(phi)
            F = np.array([[1.0, 0.0, -d * s], [0.0, 1.0, d * c], [0.0, 0.0, 1.0]])
            G = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
            cov = F @ cov @ F.T + (G * np.array([sd, across, st]) ** 2) @ G.T
            delta += d * np.array([c, s])
            jac += d * np.array([-s, c]) * -elapsed
            phi += turn
            elapsed += step
        self.delta, self.jac, self.phi, self.elapsed = delta, jac, phi, elapsed
        self.covariance = cov
        self._bias_column = np.array([[-jac[0]], [-jac[1]], [elapsed]])

    def error(self, this: Any, values: Any, H: list[np.ndarray] | None) -> np.ndarray:
        keys = this.keys()
        p0, p1 = values.atPose2(keys[0]), values.atPose2(keys[1])
        b = values.atDouble(keys[2])
        t0, t1 = p0.theta(), p1.theta()
        c, s = math.cos(t0), math.sin(t0)
        dx, dy = p1.x() - p0.x(), p1.y() - p0.y()
        along, across = c * dx + s * dy, -s * dx + c * dy
        e = np.array([along - self.delta[0] - self.jac[0] * b, across - self.delta[1] - self.jac[1] * b,
                      _wrap(t1 - t0 - self.phi + self.elapsed * b)])
        if H is not None:
            cd, sd = math.cos(t1 - t0), math.sin(t1 - t0)        # R(theta_0)^T R(theta_1) = R(theta_1 - theta_0)
            H[0] = np.array([[-1.0, 0.0, across], [0.0, -1.0, -along], [0.0, 0.0, -1.0]])
            H[1] = np.array([[cd, -sd, 0.0], [sd, cd, 0.0], [0.0, 0.0, 1.0]])
            H[2] = self._bias_column
        return e


def _fill_between(nodes: np.ndarray, kept: np.ndarray, bias: np.ndarray, odometry: np.ndarray,
                  dt: np.ndarray) -> np.ndarray:
    """The poses of every epoch: the odometry integrated from each pose variable with its gyro bias, and the
    mismatch at the next variable spread over the segment in proportion to the steps (so that every variable's
    pose is kept exactly)."""
    poses = np.empty((int(kept[-1]) + 1, 3))
    for i in range(len(kept) - 1):
        a, b = int(kept[i]), int(kept[i + 1])
        x, y, th = nodes[i]
        track = [(x, y, th)]
        for k in range(a + 1, b + 1):
            d, turn = odometry[k]
            x, y = x + d * math.cos(th), y + d * math.sin(th)
            th = th + turn - bias[i] * dt[k]
            track.append((x, y, th))
        track_arr = np.array(track)
        miss = nodes[i + 1] - track_arr[-1]
        miss[2] = _wrap(miss[2])
        weight = np.linspace(0.0, 1.0, b - a + 1)[:, None]
        poses[a:b + 1] = track_arr + weight * miss
    poses[int(kept[-1])] = nodes[-1]
    return poses
