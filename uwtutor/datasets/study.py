r"""Chapter 11's study: the book's methods, :func:`~uwtutor.datasets.navigate` and GTSAM on the Plaza logs.

The runs behind chapter 11 take minutes (a filter over the 4091 epochs of Plaza 2 takes about a second, over the
9658 of Plaza 1 more than two), so, as for chapter 10, a study computes them once
(``studies/real_data.py``, ``make study-real``) and the chapter and its widget read the committed result
(:func:`load_real_data_study`); ``tests/test_real_data_study.py`` re-runs a sample and matches it.

What it holds:

* ``table`` -- every method on each Plaza set, with the set's most-heard beacon (:func:`most_heard_beacon`) and with
  all four, at the logged rate and at an acoustic rate (one range per beacon every ``ACOUSTIC_PERIOD`` s): RMSE,
  median and final position error and the fraction of epochs within 2 m (:func:`error_summary`);
* ``ablation`` -- each position-only method of chapters 4 to 9 on Plaza 2 with its most-heard beacon, on the log
  as it is, with the range scale removed, with the heading taken from the truth, and with both
  (:func:`without_scale`, :func:`with_true_heading`): which real error each method leaves out (the virtual
  baseline's rows also hold paper E's trial statistic, :func:`fixes_within`);
* ``sweep`` -- GTSAM's batch solution against the heading noise of its odometry factors, per beacon;
* ``grid`` -- :func:`~uwtutor.datasets.navigate` on Plaza 2 for every beacon (and all four), range period and set of
  estimated states (chapter 11's widget), with the error, the scale estimate and the NEES, decimated to one value a
  second.

Every number is deterministic (the particle filter draws from a fixed seed); nothing here is timed.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

import numpy as np
from numpy.typing import ArrayLike

from .._linalg import distances
from .._validate import as_choice, as_finite, as_scalar
from ._core import BeaconIds, RangeDataset

if TYPE_CHECKING:
    from ..filters.base import FilterResult
    from .baselines import BaselineRun

__all__ = ["ACOUSTIC_PERIOD", "GRID_BEACONS", "GRID_PERIODS", "GRID_STATES", "STATE_FLAGS", "DECIMATION",
           "TABLE_METHODS", "ABLATION_METHODS", "ABLATION_VARIANTS", "SWEEP_HEADING_NOISE", "PF_SEED", "error_summary",
           "nees", "measured_scale", "fixes_within", "most_heard_beacon", "without_scale", "with_true_heading",
           "navigation_run", "navigation_grid", "method_table", "ablation_table", "gtsam_sweep", "RealDataStudy",
           "run_real_data_study", "load_real_data_study", "STUDY_FILES"]

#: One range per beacon every this many seconds, an acoustic modem's rate.
ACOUSTIC_PERIOD = 10.0
#: The widget's beacons, each alone or all four.
GRID_BEACONS: tuple[str, ...] = ("0", "1", "5", "6", "all")
#: The widget's range periods [s] (None for every range logged).
GRID_PERIODS: tuple[float | None, ...] = (None, 5.0, 10.0, 30.0)
#: The widget's sets of estimated states beyond the pose [x, y, heading].
GRID_STATES: tuple[str, ...] = ("pose only", "+ scale", "+ gyro bias", "+ scale and gyro bias")
#: ``(gyro_bias, scale)`` of :func:`~uwtutor.datasets.navigate` for each entry of ``GRID_STATES``.
STATE_FLAGS = {"pose only": (False, False), "+ scale": (False, True), "+ gyro bias": (True, False),
               "+ scale and gyro bias": (True, True)}
#: The grid's curves keep one epoch in this many (one value a second on Plaza 2).
DECIMATION = 10
#: The seed of the particle filter's draws.
PF_SEED = 11
#: GTSAM's heading noise densities of the sweep [rad/√s].
SWEEP_HEADING_NOISE: tuple[float, ...] = (1e-3, 3e-3, 1e-2, 3e-2)
#: The methods of ``ablation``, in the order of the chapters' table.
ABLATION_METHODS: tuple[str, ...] = ("EKF", "IEKF", "ISFEKF", "OR-VMLBL-KF", "particle filter")
#: The variants of the log in ``ablation``.
ABLATION_VARIANTS: tuple[str, ...] = ("as logged", "scale removed", "true heading", "both")
#: The rows of ``table`` (method, what it runs), in order.
TABLE_METHODS: tuple[str, ...] = (
    "odometry alone", "EKF", "IEKF", "ISFEKF", "ISFEKF, known scale", "OR-VMLBL-KF", "particle filter",
    "navigate, no gyro bias", "navigate", "navigate, RTS", "GTSAM, as logged", "GTSAM, scale removed",
)
#: The package files of the committed study.
STUDY_FILES = {"json": "real_data.json", "npz": "real_data_curves.npz"}


# -- measures ----------------------------------------------------------------------------------------------------------
def error_summary(positions: ArrayLike, truth: ArrayLike, within: float = 2.0) -> dict[str, float]:
    r"""RMSE, median and final horizontal error and the fraction of epochs within ``within`` metres.

    Parameters
    ----------
    positions : array_like, shape (K, >= 2)
        Estimated ``[x, y, ...]`` per epoch [m].
    truth : array_like, shape (K, >= 2)
        True ``[x, y, ...]`` [m].
    within : float, default 2
        The radius of the last measure [m].

    Returns
    -------
    dict
        ``rmse``, ``median``, ``final`` [m] and ``within`` (a fraction).

    Examples
    --------
    >>> from uwtutor.datasets.study import error_summary
    >>> error_summary([[0.0, 0.0], [3.0, 4.0]], [[0.0, 1.0], [0.0, 0.0]])
    {'rmse': 3.605551275463989, 'median': 3.0, 'final': 5.0, 'within': 0.5}
    """
    p = as_finite("positions", positions, ndim=2, nonempty=True, max_abs=1e9)
    t = as_finite("truth", truth, ndim=2, nonempty=True, max_abs=1e9)
    for name, a in (("positions", p), ("truth", t)):
        if a.shape[1] < 2:
            raise ValueError(f"{name} must hold [x, y, ...] per epoch, shape (K, >= 2); got {a.shape}")
    if p.shape[0] != t.shape[0]:
        raise ValueError(f"positions and truth must have one row per epoch each; got {p.shape[0]} and {t.shape[0]}")
    radius = as_scalar("within", within, domain="positive")
    e = np.hypot(*(p[:, :2] - t[:, :2]).T)
    return {"rmse": float(np.sqrt(np.mean(e**2))), "median": float(np.median(e)), "final": float(e[-1]),
            "within": float(np.mean(e <= radius))}


def _wrap(angle: np.ndarray) -> np.ndarray:
    return (np.asarray(angle) + np.pi) % (2.0 * np.pi) - np.pi


def nees(x: ArrayLike, P: ArrayLike, truth: ArrayLike, components: str = "pose") -> np.ndarray:
    r"""The NEES of a single run against a true log, per epoch, with the heading error wrapped to
    :math:`[-\pi, \pi)`.

    Parameters
    ----------
    x : array_like, shape (K, n)
        Estimates ``[x, y, heading, ...]``.
    P : array_like, shape (K, n, n)
        Their covariances.
    truth : array_like, shape (K, 3)
        True ``[x, y, heading]``.
    components : {"pose", "position", "heading"}
        :math:`[x, y, \theta]` (3 degrees of freedom), :math:`[x, y]` (2) or :math:`\theta` (1).

    Returns
    -------
    ndarray, shape (K,)
        :math:`\tilde{\mathbf x}_k^\mathsf{T} \mathbf P_k^{-1} \tilde{\mathbf x}_k` over the chosen components.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.datasets.study import nees
    >>> x = np.array([[1.0, 0.0, np.pi - 0.05]])
    >>> P = np.diag([1.0, 1.0, 0.01])[None]
    >>> # the heading error is 0.1 rad, not 2 pi - 0.1
    >>> nees(x, P, [[0.0, 0.0, -np.pi + 0.05]]).round(6)
    array([2.])
    """
    chosen = {"pose": [0, 1, 2], "position": [0, 1], "heading": [2]}
    idx = chosen[as_choice("components", components, chosen)]
    x = as_finite("x", x, ndim=2, nonempty=True, max_abs=1e9)
    t = as_finite("truth", truth, ndim=2, nonempty=True, max_abs=1e9)
    if x.shape[1] < 3 or t.shape[1] < 3 or x.shape[0] != t.shape[0]:
        raise ValueError(f"x and truth must hold [x, y, heading, ...] at the same epochs, shapes (K, >= 3); got "
                         f"{x.shape} and {t.shape}")
    from .._validate import as_covariance

    P = as_covariance("P", P)
    if P.shape[:2] != (x.shape[0], x.shape[1]) or P.shape[2] != x.shape[1]:
        raise ValueError(f"P must hold one ({x.shape[1]}, {x.shape[1]}) covariance per epoch of x; got {P.shape}")
    e = np.column_stack([x[:, :2] - t[:, :2], _wrap(x[:, 2] - t[:, 2])])[:, idx]
    S = P[:, idx][:, :, idx]
    value: np.ndarray = np.einsum("ki,ki->k", e, np.linalg.solve(S, e[..., None])[..., 0])
    return value


def measured_scale(data: RangeDataset, beacon_ids: BeaconIds = None) -> float:
    r"""The range scale of a log measured against its truth: the least-squares slope through the origin,
    :math:`\hat s = \sum_j r_j d_j / \sum_j d_j^2`, of the ranges on the epochs on the true distances there.

    Examples
    --------
    >>> import pytest
    >>> _ = pytest.importorskip("gtsam")
    >>> from uwtutor.datasets import plaza
    >>> from uwtutor.datasets.study import measured_scale
    >>> round(measured_scale(plaza(2)), 4)
    1.0697
    """
    _with_truth(data, "measured_scale")
    r = data.ranges_on_epochs(beacon_ids)
    d = data.true_ranges(beacon_ids)
    ok = np.isfinite(r)
    if not ok.any():
        raise ValueError("data has no range to the beacons chosen (beacon_ids): no scale to measure")
    return float(r[ok] @ d[ok] / (d[ok] @ d[ok]))


def _with_truth(data: RangeDataset, what: str) -> RangeDataset:
    _truth_of(data, what)
    return data


def _truth_of(data: Any, what: str) -> np.ndarray:
    """The log's true poses, or an error naming ``what`` needs them."""
    if not isinstance(data, RangeDataset):
        raise TypeError(f"data must be a uwtutor.datasets.RangeDataset; got {type(data).__name__}")
    if data.truth is None:
        raise ValueError(f"{what} needs the truth: data.truth is None")
    return data.truth


def _filter_of(smoothed: FilterResult) -> FilterResult:
    """The filter's own result that ``navigate(smooth=True)`` keeps beside the smoothed one."""
    from ..filters.base import FilterResult

    filtered = smoothed.extras["filtered"]
    assert isinstance(filtered, FilterResult)           # navigate(smooth=True) keeps it there
    return filtered


def most_heard_beacon(data: RangeDataset) -> int:
    """The beacon with the most ranges in the log (the lowest id on a tie): the one-beacon case of the study.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.datasets import square_log
    >>> # a 10 m square driven twice, ranging to two beacons in turn
    >>> data = square_log()
    >>> from uwtutor.datasets.study import most_heard_beacon
    >>> # 40 ranges to each: the lowest id
    >>> most_heard_beacon(data)
    3
    """
    if not isinstance(data, RangeDataset):
        raise TypeError(f"data must be a uwtutor.datasets.RangeDataset; got {type(data).__name__}")
    if data.n_ranges == 0:
        raise ValueError("data has no range at all: no beacon is heard most")
    ids, counts = np.unique(data.ranges[:, 1].astype(int), return_counts=True)
    return int(ids[np.argmax(counts)])


def without_scale(data: RangeDataset, scale: float) -> RangeDataset:
    """The log with every range divided by ``scale`` (a calibrated scale removed).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.datasets import square_log
    >>> # a 10 m square driven twice, ranging to two beacons in turn
    >>> data = square_log()
    >>> from uwtutor.datasets.study import without_scale
    >>> scaled = without_scale(data, 1.05)
    >>> np.round(scaled.ranges[0], 3).tolist(), np.round(data.ranges[0], 3).tolist()
    ([1.0, 7.0, 5.553], [1.0, 7.0, 5.831])
    """
    if not isinstance(data, RangeDataset):
        raise TypeError(f"data must be a uwtutor.datasets.RangeDataset; got {type(data).__name__}")
    scale = as_scalar("scale", scale, domain="positive", low=1e-6, high=1e6)
    ranges = np.array(data.ranges)
    ranges[:, 2] /= scale
    return replace(data, ranges=ranges, name=f"{data.name}, ranges / {scale:.4f}",
                   notes=data.notes + (f"ranges divided by {scale:.6f}",))


def with_true_heading(data: RangeDataset) -> RangeDataset:
    """The log with its odometry's heading changes replaced by the truth's (an oracle compass: no drift).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.datasets import square_log
    >>> # a 10 m square driven twice, ranging to two beacons in turn
    >>> data = square_log()
    >>> from uwtutor.datasets.study import with_true_heading
    >>> # a gyro that drifts 0.01 rad an epoch
    >>> from uwtutor.datasets import RangeDataset
    >>> drifting = RangeDataset(
    ...     times=data.times,
    ...     odometry=data.odometry + [0.0, 0.01],
    ...     ranges=data.ranges,
    ...     beacons=data.beacons,
    ...     truth=data.truth,
    ... )
    >>> fixed = with_true_heading(drifting)
    >>> bool(np.allclose(fixed.odometry[1:, 1], data.odometry[1:, 1]))
    True
    >>> fixed.name
    'dataset, true heading'
    """
    truth = _truth_of(data, "with_true_heading")
    odometry = np.array(data.odometry)
    odometry[1:, 1] = np.diff(np.unwrap(truth[:, 2]))
    return replace(data, odometry=odometry, name=f"{data.name}, true heading",
                   notes=data.notes + ("heading changes from the truth",))


# -- runs --------------------------------------------------------------------------------------------------------------
def _beacon_ids(data: RangeDataset, beacon: str) -> list[int]:
    return list(data.beacon_ids) if beacon == "all" else [int(beacon)]


def navigation_run(data: RangeDataset, beacon: str = "all", period: float | None = None,
                   states: str = "+ scale and gyro bias", decimation: int = DECIMATION) -> dict[str, Any]:
    r"""One run of :func:`~uwtutor.datasets.navigate` (filter and RTS smoother) with its measures and decimated curves.

    Parameters
    ----------
    data : RangeDataset
        A log with its truth.
    beacon : str
        A beacon id as a string, or ``"all"``.
    period : float or None
        The range period [s] (None: every range).
    states : str
        One of ``GRID_STATES``.
    decimation : int
        Keep one epoch in this many for the curves.

    Returns
    -------
    dict
        ``filter`` and ``smoother``: :func:`error_summary` plus ``nees_pose``, ``nees_position`` (means over the
        epochs) and ``consistent_pose``, ``consistent_position`` (fractions of the epochs inside the two-sided
        95 % chi-square interval); ``scale``, ``gyro_bias``: final estimates (NaN when not estimated);
        ``curves``: ``times``, ``xy`` (filter), ``error``, ``error_rts``, ``scale``, ``scale_sigma``,
        ``gyro_bias``, decimated.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.datasets import square_log
    >>> # a 10 m square driven twice, ranging to two beacons in turn
    >>> data = square_log()
    >>> from uwtutor.datasets.study import navigation_run
    >>> run = navigation_run(data, beacon="3", states="+ scale", decimation=5)
    >>> sorted(run)
    ['curves', 'filter', 'gyro_bias', 'scale', 'smoother']
    >>> # the smoother's measures, and the scale it found (the ranges are exact)
    >>> sorted(run["smoother"])[:3], round(run["scale"], 3)
    (['consistent_pose', 'consistent_position', 'final'], 1.0)
    """
    from scipy import stats

    from .navigation import navigate

    if states not in STATE_FLAGS:
        raise ValueError(f"states must be one of {list(STATE_FLAGS)}; got {states!r}")
    gyro, scale = STATE_FLAGS[states]
    smoothed = navigate(data, _beacon_ids(data, beacon), min_period=period, smooth=True, gyro_bias=gyro,
                        scale=scale)
    filtered = _filter_of(smoothed)
    truth = _truth_of(data, "the schedule run")
    out: dict[str, Any] = {}
    for name, res in (("filter", filtered), ("smoother", smoothed)):
        summary = error_summary(res.x, truth)
        for comp, dof in (("pose", 3), ("position", 2)):
            value = nees(res.x, res.P, truth, comp)
            lo, hi = stats.chi2.ppf([0.025, 0.975], dof)
            summary[f"nees_{comp}"] = float(np.mean(value))
            summary[f"consistent_{comp}"] = float(np.mean((value >= lo) & (value <= hi)))
        out[name] = summary
    i_scale = 3 + int(gyro) if scale else None
    x, P = filtered.x, filtered.P
    keep = slice(None, None, decimation)
    e_f = np.hypot(*(x[:, :2] - truth[:, :2]).T)
    e_s = np.hypot(*(smoothed.x[:, :2] - truth[:, :2]).T)
    nan = np.full(len(x), np.nan)
    out["scale"] = float(x[-1, i_scale]) if scale else float("nan")
    out["gyro_bias"] = float(x[-1, 3]) if gyro else float("nan")
    out["curves"] = {
        "times": data.times[keep], "xy": x[keep, :2], "error": e_f[keep], "error_rts": e_s[keep],
        "scale": (x[:, i_scale] if scale else nan)[keep],
        "scale_sigma": (np.sqrt(P[:, i_scale, i_scale]) if scale else nan)[keep],
        "gyro_bias": (x[:, 3] if gyro else nan)[keep],
    }
    return out


def navigation_grid(data: RangeDataset, progress: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Every (beacon, period, states) of the grid: the measures and the decimated curves, stacked.

    Returns
    -------
    dict
        ``measures``: name -> array ``(len(GRID_BEACONS), len(GRID_PERIODS), len(GRID_STATES))`` (``filter_rmse``,
        ``smoother_rmse``, ..., ``scale``, ``gyro_bias``); ``curves``: name -> array with those three axes, then
        the decimated epochs (and 2 for ``xy``); ``times``, ``truth``, ``dead_reckoning`` decimated;
        ``beacons`` (the beacon positions by id).

    Examples
    --------
    The committed grid: a measure per beacon, range period and set of states:

    >>> from uwtutor.datasets.study import (
    ...     GRID_BEACONS,
    ...     GRID_PERIODS,
    ...     GRID_STATES,
    ...     load_real_data_study,
    ... )
    >>> grid = load_real_data_study().grid
    >>> grid["measures"]["filter_rmse"].shape == (
    ...     len(GRID_BEACONS),
    ...     len(GRID_PERIODS),
    ...     len(GRID_STATES),
    ... )
    True
    """
    shape = (len(GRID_BEACONS), len(GRID_PERIODS), len(GRID_STATES))
    measures: dict[str, np.ndarray] = {}
    curves: dict[str, np.ndarray] = {}
    for i, beacon in enumerate(GRID_BEACONS):
        for j, period in enumerate(GRID_PERIODS):
            for k, states in enumerate(GRID_STATES):
                if progress is not None:
                    progress(f"grid: beacon {beacon}, period {period}, {states}")
                run = navigation_run(data, beacon, period, states)
                flat = {f"{part}_{key}": value for part in ("filter", "smoother") for key, value in run[part].items()}
                flat.update(scale=run["scale"], gyro_bias=run["gyro_bias"])
                for key, value in flat.items():
                    measures.setdefault(key, np.full(shape, np.nan))[i, j, k] = value
                for key, value in run["curves"].items():
                    if key == "times":
                        continue
                    arr = curves.setdefault(key, np.full(shape + np.shape(value), np.nan, dtype=np.float32))
                    arr[i, j, k] = value
    keep = slice(None, None, DECIMATION)
    truth = _truth_of(data, "navigation_grid")
    return {"measures": measures, "curves": curves, "times": data.times[keep], "truth": truth[keep],
            "dead_reckoning": data.dead_reckoning()[keep], "beacons": dict(data.beacons)}


def _method_runs(data: RangeDataset, ids: list[int], period: float | None, scale: float) -> dict[str, np.ndarray]:
    """The positions of every method of the table on one (set, beacons, rate)."""
    from . import baselines
    from .factor_graph import gtsam_map
    from .navigation import navigate

    one = len(ids) == 1
    runs: dict[str, np.ndarray] = {"odometry alone": data.dead_reckoning()}
    runs["EKF"] = baselines.position_ekf(data, ids, min_period=period).positions
    runs["IEKF"] = baselines.bias_iekf(data, ids, min_period=period).positions
    if one:
        runs["ISFEKF"] = baselines.fading_filter(data, ids, min_period=period).positions
        runs["ISFEKF, known scale"] = baselines.fading_filter(data, ids, mu_gamma=scale, min_period=period).positions
        runs["OR-VMLBL-KF"] = baselines.vmlbl_filter(data, ids, min_period=period).positions
        runs["particle filter"] = baselines.particle_filter(data, ids, rng=np.random.default_rng(PF_SEED),
                                                            min_period=period).positions
    # the table's "navigate" is the candidate with both states (gyro bias and scale), as committed
    runs["navigate, no gyro bias"] = navigate(data, ids, min_period=period, gyro_bias=False, scale=True).x
    smoothed = navigate(data, ids, min_period=period, smooth=True, gyro_bias=True, scale=True)
    runs["navigate"] = _filter_of(smoothed).x
    runs["navigate, RTS"] = smoothed.x
    # the pose-only graph (model="pose"); "scale removed" divides the ranges by the scale measured against the truth
    runs["GTSAM, as logged"] = gtsam_map(data, ids, min_period=period, model="pose").poses
    runs["GTSAM, scale removed"] = gtsam_map(data, ids, min_period=period, range_scale=scale, model="pose").poses
    return runs


def method_table(data: RangeDataset, progress: Callable[[str], None] | None = None) -> list[dict[str, Any]]:
    """Every method of ``TABLE_METHODS`` with the most-heard beacon and with all, at the logged and the acoustic
    rate: one row each, with :func:`error_summary`'s measures (single-beacon methods have no four-beacon rows).

    Examples
    --------
    The rows of the committed study (Plaza 2's, then Plaza 1's), one per method, beacons and rate:

    >>> from uwtutor.datasets.study import load_real_data_study
    >>> rows = load_real_data_study().table
    >>> sorted(rows[0])
    ['beacon_ids', 'beacons', 'final', 'median', 'method', 'rate', 'rmse', 'set', 'within']
    >>> rows[0]["set"], rows[0]["method"], rows[0]["beacons"], rows[0]["rate"]
    ('Plaza 2', 'odometry alone', 'one', 'full')
    """
    scale = measured_scale(data)
    rows = []
    for beacons, ids in (("one", [most_heard_beacon(data)]), ("four", list(data.beacon_ids))):
        for rate, period in (("full", None), ("10 s", ACOUSTIC_PERIOD)):
            if progress is not None:
                progress(f"table: {data.name}, {beacons} beacon(s), {rate}")
            runs = _method_runs(data, ids, period, scale)
            for method in TABLE_METHODS:
                if method in runs:
                    rows.append({"set": data.name, "method": method, "beacons": beacons,
                                 "beacon_ids": [int(i) for i in ids], "rate": rate,
                                 **error_summary(runs[method], _truth_of(data, "method_table"))})
    return rows


def fixes_within(run: BaselineRun, truth: ArrayLike, beacon: ArrayLike, fraction: float = 0.1) -> float:
    r"""Paper E's trial statistic: the fraction of a virtual-baseline run's filtered fixes whose horizontal error is
    at most ``fraction`` of the distance to the beacon (chapter 9's reading of "within 10 % error").

    Parameters
    ----------
    run : BaselineRun
        A run of :func:`uwtutor.datasets.baselines.vmlbl_filter`.
    truth : array_like, shape (K, >= 2)
        The true positions at the log's epochs [m].
    beacon : array_like, shape (2,)
        The beacon's position [m].
    fraction : float, default 0.1
        The tolerance, a fraction of the distance.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.datasets import square_log
    >>> # a 10 m square driven twice, ranging to two beacons in turn
    >>> data = square_log()
    >>> from uwtutor.datasets.baselines import vmlbl_filter
    >>> from uwtutor.datasets.study import fixes_within
    >>> run = vmlbl_filter(data, [3], spacing=4.0)
    >>> # the share of the fixes within 10 % of the distance to the beacon
    >>> 0.5 < fixes_within(run, data.truth, data.beacons[3]) <= 1.0
    True
    """
    out = run.result
    now = np.asarray(out.now)
    fix = np.asarray(out.track.x)[:, :2]
    true = np.asarray(truth, dtype=float)[now, :2]
    dist = distances(true, np.asarray(beacon, dtype=float))
    ok = np.isfinite(fix).all(axis=-1)
    return float(np.mean(np.hypot(*(fix[ok] - true[ok]).T) <= fraction * dist[ok]))


def _ablation_run(data: RangeDataset, method: str, ids: list[int], scale: float | None) -> np.ndarray:
    from . import baselines

    if method == "EKF":
        return baselines.position_ekf(data, ids).positions
    if method == "IEKF":
        return baselines.bias_iekf(data, ids).positions
    if method == "ISFEKF":
        return baselines.fading_filter(data, ids).positions
    if method == "OR-VMLBL-KF":
        return baselines.vmlbl_filter(data, ids).positions
    return baselines.particle_filter(data, ids, rng=np.random.default_rng(PF_SEED)).positions


def ablation_table(data: RangeDataset, progress: Callable[[str], None] | None = None) -> list[dict[str, Any]]:
    """Each method of ``ABLATION_METHODS`` with the most-heard beacon at the logged rate, on the four variants of
    the log (``ABLATION_VARIANTS``), and GTSAM's batch solution on the same variants.

    Examples
    --------
    The rows of the committed study, one per method and variant of the log:

    >>> from uwtutor.datasets.study import ABLATION_VARIANTS, load_real_data_study
    >>> rows = load_real_data_study().ablation
    >>> sorted(rows[0])
    ['beacon_ids', 'final', 'median', 'method', 'rmse', 'set', 'variant', 'within']
    >>> sorted({row["variant"] for row in rows}) == sorted(ABLATION_VARIANTS)
    True
    """
    from .factor_graph import gtsam_map

    scale = measured_scale(data)
    ids = [most_heard_beacon(data)]
    variants = {"as logged": data, "scale removed": without_scale(data, scale), "true heading": with_true_heading(data),
                "both": with_true_heading(without_scale(data, scale))}
    rows = []
    for method in ABLATION_METHODS + ("GTSAM",):
        if progress is not None:
            progress(f"ablation: {method}")
        for variant, log in variants.items():
            extra = {}
            if method == "GTSAM":
                positions = gtsam_map(log, ids, model="pose").poses
            elif method == "OR-VMLBL-KF":
                from . import baselines

                run = baselines.vmlbl_filter(log, ids)
                positions = run.positions
                extra["within_ten_percent"] = fixes_within(run, _truth_of(data, "the ablation"), data.beacons[ids[0]])
            else:
                positions = _ablation_run(log, method, ids, scale)
            rows.append({"set": data.name, "method": method, "variant": variant, "beacon_ids": ids,
                         **error_summary(positions, _truth_of(data, "ablation_table")), **extra})
    return rows


def gtsam_sweep(data: RangeDataset, progress: Callable[[str], None] | None = None) -> list[dict[str, Any]]:
    """GTSAM's batch solution for each heading noise of ``SWEEP_HEADING_NOISE``, each beacon alone and all four,
    ranges as logged and scale removed, at the logged rate; and, for the most-heard beacon, from the truth as the
    initial guess (the same optimum: the graph's model, not its start, decides).

    Examples
    --------
    The rows of the committed study, one per beacon(s), scale and heading noise:

    >>> from uwtutor.datasets.study import SWEEP_HEADING_NOISE, load_real_data_study
    >>> rows = load_real_data_study().sweep
    >>> sorted(rows[0])[:5]
    ['beacon', 'final', 'heading_noise', 'initial', 'iterations']
    >>> sorted({row["heading_noise"] for row in rows}) == sorted(SWEEP_HEADING_NOISE)
    True
    """
    from .factor_graph import HEADING_NOISE, gtsam_map

    scale = measured_scale(data)
    rows = []
    for beacon in GRID_BEACONS:
        ids = _beacon_ids(data, beacon)
        for removed in (False, True):
            for q in SWEEP_HEADING_NOISE:
                if progress is not None:
                    progress(f"sweep: beacon {beacon}, scale removed {removed}, q {q}")
                sol = gtsam_map(data, ids, heading_noise=q, range_scale=scale if removed else 1.0, model="pose")
                rows.append({"set": data.name, "beacon": beacon, "scale_removed": removed, "heading_noise": q,
                             "initial": "dead reckoning", "iterations": sol.iterations,
                             **error_summary(sol.poses, _truth_of(data, "gtsam_sweep"))})
    ids = [most_heard_beacon(data)]
    for removed in (False, True):
        sol = gtsam_map(data, ids, initial=data.truth, range_scale=scale if removed else 1.0, model="pose")
        rows.append({"set": data.name, "beacon": str(ids[0]), "scale_removed": removed,
                     "heading_noise": HEADING_NOISE,
                     "initial": "truth", "iterations": sol.iterations,
                     **error_summary(sol.poses, _truth_of(data, "gtsam_sweep"))})
    return rows


# -- the committed study -----------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class RealDataStudy:
    """Chapter 11's committed study (see the module docstring).

    Attributes
    ----------
    table : list of dict
        The method table's rows.
    ablation : list of dict
        The ablation's rows.
    sweep : list of dict
        GTSAM's heading-noise sweep.
    grid : dict
        ``measures`` and ``curves`` (arrays over ``GRID_BEACONS`` x ``GRID_PERIODS`` x ``GRID_STATES``), ``times``,
        ``truth``, ``dead_reckoning`` (decimated) and ``beacons``.
    info : dict
        How it was computed: versions, scales, the most-heard beacons.

    Examples
    --------
    The committed study, read back:

    >>> from uwtutor.datasets.study import load_real_data_study
    >>> study = load_real_data_study()
    >>> len(study.table), len(study.ablation), len(study.sweep)
    (80, 24, 42)
    >>> study.row("Plaza 2", "navigate", "four")["rmse"] < 1.0
    True
    """

    table: list[dict[str, Any]]
    ablation: list[dict[str, Any]]
    sweep: list[dict[str, Any]]
    grid: dict[str, Any]
    info: dict[str, Any] = field(default_factory=dict)

    def row(self, set_name: str, method: str, beacons: str = "one", rate: str = "full") -> dict[str, Any]:
        """The ``table`` row of a method on a set (``"Plaza 1"`` or ``"Plaza 2"``), ``"one"`` or ``"four"``
        beacons, ``"full"`` or ``"10 s"`` rate."""
        hits = [r for r in self.table if (r["set"], r["method"], r["beacons"], r["rate"]) ==
                (set_name, method, beacons, rate)]
        if len(hits) != 1:
            known = sorted({r["method"] for r in self.table})
            raise KeyError(f"no table row ({set_name!r}, {method!r}, {beacons!r}, {rate!r}); methods: {known}, "
                           "beacons 'one'/'four', rate 'full'/'10 s' (single-beacon methods have no 'four' rows)")
        return hits[0]

    def save(self, folder: str | Path) -> None:
        """Write ``real_data.json`` (tables, info) and ``real_data_curves.npz`` (the grid) into ``folder``."""
        folder = Path(folder)
        doc = {"info": self.info, "table": self.table, "ablation": self.ablation, "sweep": self.sweep,
               "grid_beacons": list(GRID_BEACONS), "grid_periods": list(GRID_PERIODS), "grid_states": list(GRID_STATES),
               "grid_measures": {k: np.asarray(v).round(6).tolist() for k, v in self.grid["measures"].items()},
               "beacons": {str(k): list(v) for k, v in self.grid["beacons"].items()}}
        (folder / STUDY_FILES["json"]).write_text(json.dumps(_rounded(doc), indent=1) + "\n", encoding="utf-8")
        arrays: dict[str, Any] = {f"curve_{k}": np.asarray(v, dtype=np.float32)
                                  for k, v in self.grid["curves"].items()}
        arrays.update(times=self.grid["times"], truth=self.grid["truth"], dead_reckoning=self.grid["dead_reckoning"])
        np.savez_compressed(folder / STUDY_FILES["npz"], **arrays)

    @classmethod
    def load(cls, folder: str | Path) -> "RealDataStudy":
        """Read what :meth:`save` wrote."""
        folder = Path(folder)
        doc = json.loads((folder / STUDY_FILES["json"]).read_text(encoding="utf-8"))
        with np.load(folder / STUDY_FILES["npz"]) as npz:
            curves = {k[len("curve_"):]: npz[k] for k in npz.files if k.startswith("curve_")}
            grid = {"times": npz["times"], "truth": npz["truth"], "dead_reckoning": npz["dead_reckoning"]}
        grid.update(curves=curves, measures={k: np.array(v, dtype=float) for k, v in doc["grid_measures"].items()},
                    beacons={int(k): tuple(v) for k, v in doc["beacons"].items()})
        return cls(table=doc["table"], ablation=doc["ablation"], sweep=doc["sweep"], grid=grid, info=doc["info"])


def _rounded(value: Any) -> Any:
    """Floats rounded to 6 decimals (the JSON stays readable; far below any number the chapter shows)."""
    if isinstance(value, float):
        return round(value, 6) if np.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _rounded(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_rounded(v) for v in value]
    return value


def run_real_data_study(progress: Callable[[str], None] | None = None) -> RealDataStudy:
    """Compute the whole study on Plaza 1 and 2 (several minutes; ``make study-real``).

    Examples
    --------
    What it computes, as committed (read back by :func:`load_real_data_study`):

    >>> from uwtutor.datasets.study import load_real_data_study
    >>> study = load_real_data_study()
    >>> sorted(study.info)[:4]
    ['acoustic_period', 'decimation', 'gtsam', 'most_heard_beacon']
    >>> sorted({row["set"] for row in study.table})
    ['Plaza 1', 'Plaza 2']
    """
    from importlib.metadata import version

    from .. import __version__
    from ._plaza import plaza

    sets = {n: plaza(n) for n in (1, 2)}
    table = method_table(sets[2], progress) + method_table(sets[1], progress)
    ablation = ablation_table(sets[2], progress)
    sweep = gtsam_sweep(sets[2], progress)
    grid = navigation_grid(sets[2], progress)
    info = {"uwtutor": __version__, "numpy": np.__version__, "gtsam": version("gtsam"),
            "acoustic_period": ACOUSTIC_PERIOD, "pf_seed": PF_SEED, "decimation": DECIMATION,
            "scale": {s.name: measured_scale(s) for s in sets.values()},
            "most_heard_beacon": {s.name: most_heard_beacon(s) for s in sets.values()}}
    return RealDataStudy(table=table, ablation=ablation, sweep=sweep, grid=grid, info=info)


_CACHE: dict[str, RealDataStudy] = {}


def load_real_data_study() -> RealDataStudy:
    """The committed study (package data ``uwtutor/data/real_data.json`` and ``real_data_curves.npz``), read once
    per process.

    Examples
    --------
    >>> from uwtutor.datasets.study import load_real_data_study
    >>> study = load_real_data_study()
    >>> study.row("Plaza 2", "navigate", "four")["rmse"] < 1.0
    True
    """
    if "study" not in _CACHE:
        _CACHE["study"] = RealDataStudy.load(Path(__file__).resolve().parents[1] / "data")
    return _CACHE["study"]
