r"""Paper E's pipeline: outlier-rejecting range filter, virtual-beacon fixes, cascade filter (:func:`or_vmlbl_kf`);
the epochs of each fix (:func:`epoch_windows`) and the error budget of a fix (:func:`vmlbl_error_budget`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .. import lsq
from ..lsq.virtual_baseline import check_slant_ranges
from .._validate import (MAX_COORDINATE, as_finite, as_int, as_nonnegative, as_range_array, as_rng,
                         as_scalar, check_work)
from ..errors import IllConditionedWarning, warn as _warn
from ..filters.base import FilterResult
from ..filters.gates import TestChoice
from ..filters.robust import cascade_kf, robust_range_kf
from ..filters.smoother import SmootherResult, rts_smoother
from ..models.robust import ConstantVelocity, step_lengths

__all__ = ["VMLBLResult", "epoch_windows", "or_vmlbl_kf", "NoUsableFixError", "ErrorBudget", "vmlbl_error_budget",
           "ERROR_SOURCES"]


class NoUsableFixError(ValueError):
    """No run of a batch has a single usable virtual-beacon fix (``or_vmlbl_kf``): every window's virtual beacons
    are collinear or too close together."""


def epoch_windows(n_steps: int, spacing: int, n_epochs: int = 4) -> tuple[np.ndarray, np.ndarray]:
    r"""The epochs of a sliding virtual-beacon fix: ``now`` and, for each, ``now - (n-1)s, ..., now - s, now``.

    Parameters
    ----------
    n_steps : int
        Number of epochs K of the run.
    spacing : int
        Steps between the epochs of one fix (s), >= 1.
    n_epochs : int, default 4
        Epochs per fix (paper E: 4), >= 3.

    Returns
    -------
    now : ndarray of int, shape (J,)
        The epoch of each fix, from ``(n - 1) s`` to ``K - 1``.
    index : ndarray of int, shape (J, n_epochs)
        The epochs each fix uses, oldest first.

    Examples
    --------
    >>> from uwtutor.pipelines import epoch_windows
    >>> now, index = epoch_windows(10, 3)
    >>> now.tolist(), index[0].tolist(), index[-1].tolist()
    ([9], [0, 3, 6, 9], [0, 3, 6, 9])
    """
    K = as_int("n_steps", n_steps, minimum=1)
    s = as_int("spacing", spacing, minimum=1)
    n = as_int("n_epochs", n_epochs, minimum=3)
    first = (n - 1) * s
    if first >= K:
        raise ValueError(f"a fix needs {n} epochs {s} steps apart, i.e. {first + 1} epochs; the run has only {K}")
    check_work("n_steps", (K - first) * (n + 1), "epoch indices")
    now = np.arange(first, K)
    return now, now[:, None] - s * np.arange(n - 1, -1, -1)


@dataclass(frozen=True)
class VMLBLResult:
    """Every stage of paper E's OR-VMLBL-KF (returned by :func:`or_vmlbl_kf`).

    Shapes: ``K`` epochs, ``J`` fixes (the epochs from ``3 s`` on), a leading runs axis ``M`` when the inputs
    had one.

    Attributes
    ----------
    times : ndarray, shape (K,)
        Epoch times [s].
    ranges : FilterResult or None
        The range filter's run (None when ``preprocess=False``).
    used_ranges : ndarray, shape (K,) or (M, K)
        The ranges the fixes were computed from (filtered, or raw without preprocessing) [m].
    now : ndarray of int, shape (J,)
        The epoch index of each fix.
    fix : lsq.VirtualBeaconFix
        The least-squares fixes with their conditioning, shapes ``(J, ...)`` or ``(M, J, ...)``.
    fix_cov : ndarray, shape (J, 2, 2) or (M, J, 2, 2)
        The covariance given to the cascade filter [m²].
    track : FilterResult
        The cascade filter's run on the fixes (state ``[x, y, vx, vy]``).
    smoothed : SmootherResult or None
        The RTS smoother over ``track`` (when ``smooth=True``).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.pipelines import or_vmlbl_kf
    >>> from uwtutor.scenarios import paper_e
    >>> d = paper_e.make(np.random.default_rng(3))
    >>> res = or_vmlbl_kf(
    ...     d.dr_positions[0][:400],
    ...     d.slant_ranges[0][:400],
    ...     ship_positions=d.ship_positions[0][:400],
    ...     depth=d.depth,
    ...     spacing=100,
    ... )
    >>> # 400 epochs; a fix at every epoch from 3 * 100 on
    >>> res.times.shape, res.now.shape, res.fix_cov.shape
    ((400,), (100,), (100, 2, 2))
    >>> # the cascade filter's state [x, y, vx, vy] at each fix
    >>> res.track.x.shape
    (100, 4)
    """

    times: np.ndarray
    ranges: FilterResult | None
    used_ranges: np.ndarray
    now: np.ndarray
    fix: lsq.VirtualBeaconFix
    fix_cov: np.ndarray
    track: FilterResult
    smoothed: SmootherResult | None

    @property
    def fix_times(self) -> np.ndarray:
        """Times of the fixes [s], shape ``(J,)``."""
        fix_times: np.ndarray = self.times[self.now]
        return fix_times

    @property
    def fixes(self) -> np.ndarray:
        """The least-squares positions of OR-VMLBL [m], ``(J, 2)`` or ``(M, J, 2)`` (NaN where singular)."""
        return self.fix.position

    @property
    def filtered(self) -> np.ndarray:
        """The cascade filter's positions, OR-VMLBL-KF [m], same shape as ``fixes``."""
        return self.track.x[..., :2]


def or_vmlbl_kf(dr_positions: ArrayLike, ranges: ArrayLike, *, ship_positions: ArrayLike, depth: float, dt: float = 1.0,
                times: ArrayLike | None = None, spacing: int = 100, n_epochs: int = 4, preprocess: bool = True,
                range_options: dict[str, Any] | None = None, fix_q: float = 1e-4, fix_test: TestChoice = "chi2",
                fix_options: dict[str, Any] | None = None, smooth: bool = False,
                range_result: FilterResult | None = None) -> VMLBLResult:
    r"""Paper E's OR-VMLBL-KF: ranges + ship positions + dead reckoning -> fixes -> filtered track.

    The arguments come in the filters' order, the dead reckoning ``u`` before the ranges ``z``; the ship's path
    (the moving beacon, a filter's ``beacon=``) is a keyword, so that it cannot be swapped with the DR track of the
    same shape.

    Parameters
    ----------
    dr_positions : array_like, shape (K, 2) or (M, K, 2)
        The submersible's dead-reckoned positions :math:`P_k` [m] (only differences matter).
    ranges : array_like, shape (K,) or (M, K)
        Measured slant ranges to the ship [m] (NaN where missing).
    ship_positions : array_like, shape (K, 2) or (M, K, 2)
        The ship's horizontal positions :math:`AB_k` (GPS) [m].
    depth : float
        The submersible's depth :math:`h` [m] (pressure sensor); the ship is at the surface.
    dt : float, default 1
        Time between epochs [s] (ignored when ``times`` is given).
    times : array_like, shape (K,), optional
        Epoch times [s].
    spacing : int, default 100
        Epochs between the four epochs of a fix (paper E does not give it; chapter 3 measures its effect).
    n_epochs : int, default 4
        Epochs per fix (paper E: 4).
    preprocess : bool, default True
        Filter the ranges first (OR); False computes the fixes from the raw ranges.
    range_options : dict, optional
        Keyword arguments for :func:`~uwtutor.filters.robust.robust_range_kf` (default: paper E's).
    fix_q : float, default 1e-4
        The cascade filter's acceleration variance [(m/s²)²].
    fix_test : {"chi2", "paper", "none"} or Gate, default "chi2"
        The cascade filter's outlier test.
    fix_options : dict, optional
        Further keyword arguments for :func:`~uwtutor.filters.robust.cascade_kf`.
    smooth : bool, default False
        Also run the RTS smoother over the cascade filter.
    range_result : FilterResult, optional
        The range filter's result on these ``ranges`` with these ``range_options`` (``ranges`` of a call made
        before, e.g. with another ``spacing``): used as it is instead of running the range filter again. It must
        have been computed on the same ranges; only its shape is checked.

    Returns
    -------
    VMLBLResult

    Raises
    ------
    NoUsableFixError
        When no run has a single usable fix (a ``ValueError``); runs without any among others get a NaN track and an
        ``IllConditionedWarning``.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.pipelines import or_vmlbl_kf
    >>> from uwtutor.scenarios import paper_e
    >>> dive = paper_e.make(np.random.default_rng(3))
    >>> out = or_vmlbl_kf(
    ...     dive.dr_positions[0],
    ...     dive.slant_ranges[0],
    ...     ship_positions=dive.ship_positions[0],
    ...     depth=dive.depth,
    ... )
    >>> truth = dive.true_positions[0][out.now]
    >>> def rms(e): return float(np.sqrt(np.mean(np.sum(e ** 2, axis=-1))))
    >>> rms(out.filtered - truth) < rms(out.fixes - truth)
    True
    """
    r = as_range_array("ranges", ranges, allow_nan=True, max_abs=MAX_COORDINATE, ndim=(1, 2), nonempty=True)
    batched = r.ndim == 2
    K = r.shape[-1]
    ship = as_finite("ship_positions", ship_positions, ndim=(2, 3))
    dr = as_finite("dr_positions", dr_positions, ndim=(2, 3))
    for name, a in (("ship_positions", ship), ("dr_positions", dr)):
        if a.shape[-2:] != (K, 2):
            raise ValueError(f"{name} must have one horizontal position per range, shape ({K}, 2) or "
                             f"(M, {K}, 2) for ranges of shape {r.shape}; got {a.shape}")
    M = r.shape[0] if batched else 1
    rb = np.broadcast_to(r, (M, K))
    shipb = np.broadcast_to(ship, (M, K, 2))
    drb = np.broadcast_to(dr, (M, K, 2))
    h = as_scalar("depth", depth, domain="nonnegative", high=MAX_COORDINATE)   # below the surface: h >= 0
    check_slant_ranges("ranges", rb, h)                     # the measured ones, before any preprocessing
    steps = step_lengths(K, dt, times)
    t = np.cumsum(steps) if times is None else as_finite("times", times, ndim=1)
    if range_result is not None and not preprocess:
        raise ValueError("range_result is the range filter's result: it cannot be used with preprocess=False")
    if range_result is not None:
        if np.shape(range_result.x) not in ((M, K, 2), (K, 2)) or (np.ndim(range_result.x) == 2) == batched:
            raise ValueError(f"range_result must be the range filter's result on these ranges, x of shape "
                             f"{(M, K, 2) if batched else (K, 2)}; got {np.shape(range_result.x)}")
        # with a runs axis, as the range filter gives it on the broadcast ranges
        range_run = range_result if batched else _with_runs_axis(range_result)
        used = np.maximum(range_run.x[..., 0], 0.0)
        var = range_run.P[..., 0, 0]
    elif preprocess:
        range_run = robust_range_kf(rb, dt, times=times, **(range_options or {}))
        # Near the beacon the constant-velocity range filter can extrapolate below zero (the range rate flips
        # sign at the closest approach); a range is a length, so the fix gets zero there.
        used = np.maximum(range_run.x[..., 0], 0.0)
        var = range_run.P[..., 0, 0]
    else:
        range_run = None
        used = rb
        var = np.full((M, K), 2.0 if range_options is None else float(range_options.get("r", 2.0)))
    now, index = epoch_windows(K, spacing, n_epochs)
    Kf, n = index.shape
    fix = lsq.virtual_beacon_lsq(used[:, index].reshape(M * Kf, n), shipb[:, index].reshape(M * Kf, n, 2),
                                 drb[:, index].reshape(M * Kf, n, 2), depth=h)
    fix = lsq.VirtualBeaconFix(**{name: np.asarray(value).reshape((M, Kf) + np.shape(value)[1:])
                                  for name, value in fix.__dict__.items()})
    gain = np.asarray(fix.noise_gain)
    sigma2 = np.mean(var[:, index], axis=-1)
    v = 0.5 * gain**2 * sigma2
    v = np.where(np.isfinite(v) & (v > 0), v, 1.0)               # unused where the fix is NaN
    fix_cov = v[..., None, None] * np.eye(2)
    fix_t = t[now]
    usable = np.isfinite(fix.position).all(axis=-1).any(axis=-1)        # runs with at least one fix
    if not usable.any():
        raise NoUsableFixError("no run has a single usable virtual-beacon fix (the virtual beacons of every window are "
                         "collinear or too close together: a straight track to a fixed beacon, or epochs too few "
                         "apart); lengthen spacing, or turn")
    if not usable.all():
        _warn(f"{int((~usable).sum())} of {M} runs have no usable virtual-beacon fix at all (collinear virtual "
              "beacons in every window); their track is NaN", IllConditionedWarning)
    track = cascade_kf(fix.position[usable], times=fix_t, q=fix_q, r=fix_cov[usable], test=fix_test,
                       **(fix_options or {}))
    smoothed = None
    if smooth:
        smoothed = rts_smoother(track, ConstantVelocity(2, fix_q, step_lengths(Kf, times=fix_t)))
    if not usable.all():
        track = _with_runs(track, usable)
        if smoothed is not None:
            smoothed = SmootherResult(times=smoothed.times, x=_spread(smoothed.x, usable, np.nan),
                                      P=_spread(smoothed.P, usable, np.nan),
                                      gain=_spread(smoothed.gain, usable, np.nan),
                                      filtered=track)

    def out(a: Any) -> Any:
        return a if batched else a[0]

    if not batched:
        fix = lsq.VirtualBeaconFix(**{name: out(value) for name, value in fix.__dict__.items()})
        if range_run is not None:
            range_run = _first_run(range_run)
        track = _first_run(track)
        if smoothed is not None:
            smoothed = SmootherResult(times=smoothed.times, x=smoothed.x[0], P=smoothed.P[0],
                                      gain=smoothed.gain[0], filtered=track)
    return VMLBLResult(times=t, ranges=range_run, used_ranges=out(used), now=now, fix=fix, fix_cov=out(fix_cov),
                       track=track, smoothed=smoothed)


def _spread(values: np.ndarray, rows: np.ndarray, fill: Any) -> np.ndarray:
    """``values`` of the runs ``rows`` (a bool mask of M) into an array of all M runs, ``fill`` elsewhere."""
    out = np.full((rows.size,) + values.shape[1:], fill, dtype=values.dtype if fill is False else float)
    out[rows] = values
    return out


def _with_runs(res: FilterResult, rows: np.ndarray) -> FilterResult:
    """A result of the runs ``rows`` only, spread back to all runs (NaN, or False for flags, in the others)."""
    def fill(a: np.ndarray) -> np.ndarray:
        return _spread(np.asarray(a), rows, False if np.asarray(a).dtype == bool else np.nan)

    return FilterResult(times=res.times, x=fill(res.x), P=fill(res.P),
                        x_prior=None if res.x_prior is None else fill(res.x_prior),
                        P_prior=None if res.P_prior is None else fill(res.P_prior), innovations=fill(res.innovations),
                        innovation_cov=fill(res.innovation_cov),
                        extras={k: fill(v) for k, v in res.extras.items()})


def _with_runs_axis(res: FilterResult) -> FilterResult:
    """A single run's result with a runs axis of one (the inverse of ``_first_run``)."""
    return FilterResult(times=res.times, x=res.x[None], P=res.P[None],
                        x_prior=None if res.x_prior is None else res.x_prior[None],
                        P_prior=None if res.P_prior is None else res.P_prior[None],
                        innovations=res.innovations[None], innovation_cov=res.innovation_cov[None],
                        extras={name: np.asarray(a)[None] for name, a in res.extras.items()})


def _first_run(res: FilterResult) -> FilterResult:
    """Run 0 of a batched result, without the runs axis."""
    return FilterResult(times=res.times, x=res.x[0], P=res.P[0],
                        x_prior=None if res.x_prior is None else res.x_prior[0],
                        P_prior=None if res.P_prior is None else res.P_prior[0],
                        innovations=res.innovations[0], innovation_cov=res.innovation_cov[0],
                        extras={name: a[0] for name, a in res.extras.items()})



#: The error sources of paper E's Fig. 6, in its order.
ERROR_SOURCES = ("virtual beacon", "range", "depth")


@dataclass(frozen=True)
class ErrorBudget:
    """Paper E's Fig. 6 by Monte Carlo (returned by :func:`vmlbl_error_budget`).

    Attributes
    ----------
    sources : tuple of str
        The error sources, ``ERROR_SOURCES``.
    levels : ndarray, shape (L,)
        The error levels [m] (standard deviations; for the virtual beacons the 2-D RMS).
    rms : ndarray, shape (3, L)
        RMS horizontal position error of the fix per source and level [m].
    median : ndarray, shape (3, L)
        Median position error [m].
    slope : ndarray, shape (3,)
        Least-squares slope of ``rms`` against ``levels`` through the origin [m per m].
    runs_per_level : int
        Monte Carlo runs behind each point.
    spacing : int
        Epochs between the four epochs of each fix.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.pipelines import vmlbl_error_budget
    >>> from uwtutor.scenarios import paper_e
    >>> dive = paper_e.make(np.random.default_rng(0))
    >>> b = vmlbl_error_budget(
    ...     np.random.default_rng(1),
    ...     dive.ship_positions[0],
    ...     dive.true_positions[0],
    ...     depth=dive.depth,
    ...     levels=[1.0, 2.0],
    ...     n_runs=200,
    ... )
    >>> b.sources
    ('virtual beacon', 'range', 'depth')
    >>> # an RMS and a median per source and level, a slope per source
    >>> b.rms.shape, b.median.shape, b.slope.shape
    ((3, 2), (3, 2), (3,))
    """

    sources: tuple[str, ...]
    levels: np.ndarray
    rms: np.ndarray
    median: np.ndarray
    slope: np.ndarray
    runs_per_level: int
    spacing: int


def vmlbl_error_budget(rng: np.random.Generator, ship_positions: ArrayLike, true_positions: ArrayLike, *,
                       depth: ArrayLike,
                       spacing: int = 100, levels: ArrayLike = (0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 4.5, 5.0),
                       n_runs: int = 50_000, n_epochs: int = 4) -> ErrorBudget:
    r"""Paper E's error budget (Fig. 6): the virtual-beacon fix's error against each error source alone.

    Each Monte Carlo run picks an epoch of the track at random (uniformly among those with ``n_epochs`` epochs
    ``spacing`` apart before them), builds the exact slant ranges, virtual beacons and depth there, and perturbs
    one of them:

    * **virtual beacon**: every virtual beacon moved by :math:`N(0, \sigma^2/2)` per axis (2-D RMS :math:`\sigma`),
      which is what a ship GPS error or a submersible DR error does;
    * **range**: every slant range off by :math:`N(0, \sigma^2)` (delay and sound-speed errors);
    * **depth**: the depth given to the fix off by :math:`N(0, \sigma^2)` (pressure sensor).

    ``n_runs`` runs per source are spread evenly over the ``levels``; all ``3 n_runs`` fixes are one batched call of
    :func:`~uwtutor.lsq.virtual_beacon_lsq`.

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of randomness.
    ship_positions, true_positions : array_like, shape (K, 2)
        The ship's and the submersible's true horizontal tracks [m].
    depth : float
        Submersible depth [m].
    spacing : int, default 100
        Epochs between the fix's epochs.
    levels : array_like, shape (L,)
        Error levels :math:`\sigma` [m], > 0.
    n_runs : int, default 50 000
        Monte Carlo runs per source (paper E: 50 000).
    n_epochs : int, default 4
        Epochs per fix.

    Returns
    -------
    ErrorBudget

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.pipelines import vmlbl_error_budget
    >>> from uwtutor.scenarios import paper_e
    >>> dive = paper_e.make(np.random.default_rng(0))
    >>> b = vmlbl_error_budget(
    ...     np.random.default_rng(1),
    ...     dive.ship_positions[0],
    ...     dive.true_positions[0],
    ...     depth=dive.depth,
    ...     levels=[1.0, 2.0],
    ...     n_runs=2000,
    ... )
    >>> b.rms.shape, bool(b.slope[1] > b.slope[0] > 1.0), float(b.slope[2]) < 1e-6
    ((3, 2), True, True)
    """
    rng = as_rng(rng)
    ship = as_finite("ship_positions", ship_positions, ndim=2)
    truth = as_finite("true_positions", true_positions, ndim=2)
    if ship.shape != truth.shape or ship.shape[1] != 2:
        raise ValueError(f"ship_positions and true_positions must both have shape (K, 2); got {ship.shape} and "
                         f"{truth.shape}")
    h = float(as_nonnegative("depth", depth, ndim=0, max_abs=MAX_COORDINATE))
    lv = as_finite("levels", levels, ndim=1, max_abs=MAX_COORDINATE)
    if lv.size == 0 or np.any(lv <= 0):
        raise ValueError("levels must be a non-empty list of error levels > 0 [m]")
    N = as_int("n_runs", n_runs, minimum=len(lv))
    check_work("n_runs", 3 * N * (as_int("n_epochs", n_epochs, minimum=3) + 2), "values (3 sources, an epoch "
               "window each)")
    per = N // len(lv)
    now, index = epoch_windows(len(ship), spacing, n_epochs)
    n = index.shape[1]
    S, L = len(ERROR_SOURCES), len(lv)
    total = S * L * per
    pick = index[rng.integers(0, len(now), total)]                     # (total, n) epochs of each run
    ab = ship[pick]
    p = truth[pick]
    r = np.sqrt(np.sum((p[:, -1:, :] - (ab + (p[:, -1:, :] - p))) ** 2, axis=-1) + h**2)
    sigma = np.tile(np.repeat(lv, per), S)                             # (total,)
    source = np.repeat(np.arange(S), L * per)
    noise = rng.standard_normal((total, n, 3))
    ab = ab + np.where(source[:, None, None] == 0, sigma[:, None, None] / np.sqrt(2.0) * noise[..., :2], 0.0)
    r = r + np.where(source[:, None] == 1, sigma[:, None] * noise[..., 2], 0.0)
    fixes = np.empty((total, 2))
    plain = source != 2
    fixes[plain] = lsq.virtual_beacon_lsq(r[plain], ab[plain], p[plain], depth=h).position
    # The fix takes one depth per call: a depth error is an offset of the pressure sensor, so each level is
    # applied as +sigma to half of its runs and -sigma to the other half.
    depth_runs = np.flatnonzero(~plain).reshape(L, 2, -1) if per % 2 == 0 else None
    for j, level in enumerate(lv):
        rows = depth_runs[j] if depth_runs is not None else [np.flatnonzero(~plain)[j * per:(j + 1) * per]]
        for sign, chunk in zip((1.0, -1.0), rows):
            fixes[chunk] = lsq.virtual_beacon_lsq(r[chunk], ab[chunk], p[chunk], depth=h + sign * level).position
    err = np.linalg.norm(fixes - p[:, -1], axis=-1).reshape(S, L, per)
    rms = np.sqrt(np.mean(err**2, axis=-1))
    med = np.median(err, axis=-1)
    slope = rms @ lv / (lv @ lv)
    return ErrorBudget(sources=ERROR_SOURCES, levels=lv, rms=rms, median=med, slope=slope, runs_per_level=per,
                       spacing=int(spacing))
