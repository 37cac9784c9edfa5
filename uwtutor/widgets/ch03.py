"""Chapter 3 widgets: paper A's precision factor on an arc of a circle, and paper D's pre-location cost map."""

from __future__ import annotations

import functools
import warnings
from dataclasses import dataclass
from typing import Any, Callable

import matplotlib.pyplot as plt
from matplotlib.figure import Figure
import numpy as np
from numpy.typing import ArrayLike

from .. import lsq, observability, scenarios
from .._validate import as_int, as_positive, as_scalar, as_seed, check_work
from ..plotting import mark_beacon
from ._panel import keep, kept, rescale, slider_panel

__all__ = [
    "PrecisionView",
    "precision_view",
    "plot_precision_view",
    "precision_widget",
    "covariance_ellipse",
    "PrelocationView",
    "prelocation_view",
    "plot_prelocation_view",
    "prelocation_widget",
    "COMPUTE_FUNCTIONS",
]


# --- the precision factor ------------------------------------------------------------------------------------------
#: Largest radius and bias [m] the precision view takes: beyond 1000 km a value is not a beacon's range (wrong units).
_MAX_RANGE = 1e6

@dataclass(frozen=True)
class PrecisionView:
    r"""Paper A's least-squares fix on an arc of a circle around the beacon (chapter 3).

    Attributes
    ----------
    n_obs : int
        Number of ranges.
    turn_deg : float
        Change of bearing from the beacon over the arc [deg].
    radius : float
        Radius of the arc (the range) [m].
    noise_sigma : float
        White range noise standard deviation [m].
    bias : float
        Constant range bias added to every range (estimated by the fix) [m].
    positions : ndarray, shape (N, 2)
        The epochs' positions on the arc [m] (the fix is of the last one).
    alpha_history : ndarray, shape (N,)
        :math:`\alpha` after 1..N ranges (``inf`` while singular).
    alpha : float
        :math:`\alpha` of all N ranges (at the true position).
    condition_number : float
        :math:`\kappa(A)`.
    predicted_rmse : float
        :math:`\sigma\sqrt{C_{xx} + C_{yy}}` from :math:`C = (A^\mathsf{T}A)^{-1}`: the RMS position error white
        noise alone should give [m].
    position_covariance : ndarray, shape (2, 2)
        :math:`\sigma^2` times the position block of :math:`(A^\mathsf{T}A)^{-1}` [m²].
    errors : ndarray, shape (M, 2)
        Position error (estimate minus truth) of each of the M (``n_runs``) Monte Carlo fixes [m].
    rmse : float
        Their RMS [m] (NaN if the problem is singular).
    well_conditioned : bool
        Whether the fix passed ``uwtutor.lsq``'s conditioning limits (no ``IllConditionedWarning``).

    Examples
    --------
    >>> view = precision_view(n_obs=20, turn_deg=90.0, n_runs=20, seed=0)
    >>> view.positions.shape, view.errors.shape, view.well_conditioned
    ((20, 2), (20, 2), True)
    """

    n_obs: int
    turn_deg: float
    radius: float
    noise_sigma: float
    bias: float
    positions: np.ndarray
    alpha_history: np.ndarray
    alpha: float
    condition_number: float
    predicted_rmse: float
    position_covariance: np.ndarray
    errors: np.ndarray
    rmse: float
    well_conditioned: bool


def precision_view(n_obs: int = 236, turn_deg: float = 90.0, radius: float = 1500.0,
                   noise_sigma: float = float(np.sqrt(5.0)), bias: float = 10.0, n_runs: int = 200,
                   seed: int = 0) -> PrecisionView:
    r"""Compute the precision factor and the actual LS error of ``n_obs`` ranges spread over ``turn_deg`` of bearing.

    The epochs sit evenly on an arc of radius ``radius`` around the beacon, starting due south (as in paper A's
    circling scenario, where 236 ranges cover 90 degrees); dead reckoning is exact, so only the geometry and the
    white noise matter. Each of the ``n_runs`` Monte Carlo fixes is ``lsq.prepositioning`` with a bias unknown, three
    Gauss-Newton steps, from a provisional position 30 m (RMS per axis) off the truth.

    Parameters
    ----------
    n_obs : int, default 236
        Number of ranges (>= 1).
    turn_deg : float, default 90
        Bearing change over the arc [deg], 1 to 360.
    radius : float, default 1500
        Range to the beacon [m], 1 m to 1000 km.
    noise_sigma : float, default sqrt(5)
        White range noise [m] (paper A: "variance 5"), > 0 and at most 1000 km.
    bias : float, default 10
        Constant range bias [m], above ``-radius`` and at most 1000 km.
    n_runs : int, default 200
        Monte Carlo fixes.
    seed : int, default 0
        Seed of the noise.

    Returns
    -------
    PrecisionView

    Examples
    --------
    >>> # paper A's arc
    >>> wide = precision_view(n_obs=236, turn_deg=90.0, n_runs=20, seed=0)
    >>> round(wide.alpha, 2), round(wide.predicted_rmse, 1)
    (1.0, 1.7)
    >>> # 10 degrees of bearing
    >>> narrow = precision_view(n_obs=20, turn_deg=10.0, n_runs=20, seed=0)
    >>> (bool(narrow.alpha > 1000.0), narrow.well_conditioned,
    ...  bool(narrow.rmse > 100.0 * wide.rmse))
    (True, False, True)
    """
    n = as_int("n_obs", n_obs, minimum=1)
    # an arc of less than a degree, or a radius below a metre, gives no fix at all (the normal matrix is singular
    # in float64); a radius, noise or bias beyond 1000 km is not a beacon's range (their squares overflow float64)
    turn = as_scalar("turn_deg", turn_deg, low=1.0, high=360.0)
    R = as_scalar("radius", radius, low=1.0, high=_MAX_RANGE)
    sigma = as_scalar("noise_sigma", noise_sigma, domain="positive", high=_MAX_RANGE)
    b = as_scalar("bias", bias, low=-_MAX_RANGE, high=_MAX_RANGE)
    if R + b <= 0.0:
        raise ValueError(f"bias must be above -radius (the measured range R + bias must be > 0); got bias = {b:g} "
                         f"with radius = {R:g}")
    runs = as_int("n_runs", n_runs, minimum=1)
    check_work("n_runs", runs * n, "ranges (n_runs x n_obs)")
    rng = np.random.default_rng(as_seed("seed", seed))
    phi = np.deg2rad(-90.0 + turn * np.linspace(0.0, 1.0, n))
    positions = R * np.column_stack([np.cos(phi), np.sin(phi)])
    alpha_hist = lsq.precision_factor_history(positions)
    ranges = np.maximum(R + b + sigma * rng.standard_normal((runs, n)), 0.0)     # noise larger than the range
    provisional = positions[-1] + 30.0 * rng.standard_normal((runs, 2))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", lsq.IllConditionedWarning)   # shown in the figure's title instead
        truth_fix = lsq.prepositioning(np.full(n, R + b), positions, positions[-1])
        fix = lsq.prepositioning(ranges, np.broadcast_to(positions, (runs, n, 2)), provisional, iterations=3)
    # (A^T A)^-1 at the true position (the fix above has no residuals, so its own covariance is 0)
    A = truth_fix.design
    inv_normal = np.linalg.inv(A.T @ A) if np.isfinite(truth_fix.alpha) else np.full((3, 3), np.inf)
    cov = sigma**2 * inv_normal[:2, :2]
    errors = fix.position - positions[-1]
    with np.errstate(invalid="ignore"):
        rmse = float(np.sqrt(np.mean(np.sum(errors**2, axis=-1))))
    return PrecisionView(n_obs=n, turn_deg=turn, radius=R, noise_sigma=sigma, bias=b, positions=positions,
                         alpha_history=alpha_hist, alpha=float(truth_fix.alpha),
                         condition_number=float(truth_fix.condition_number),
                         predicted_rmse=float(np.sqrt(cov[0, 0] + cov[1, 1])), position_covariance=cov,
                         errors=errors, rmse=rmse, well_conditioned=bool(np.all(fix.well_conditioned)))


def covariance_ellipse(cov: ArrayLike, scale: float = 1.0, n: int = 100) -> np.ndarray:
    """Points ``(n, 2)`` of the ellipse of a 2x2 covariance, ``scale`` standard deviations from its centre (0, 0)
    (:func:`uwtutor.observability.error_ellipse`, under the name the chapter uses).

    Examples
    --------
    >>> import numpy as np
    >>> # sigma 2 m east, 1 m north
    >>> points = covariance_ellipse(np.diag([4.0, 1.0]), scale=2.0, n=100)
    >>> distance = np.hypot(points[:, 0], points[:, 1])
    >>> points.shape, round(float(distance.min()), 2), round(float(distance.max()), 2)
    ((100, 2), 2.0, 4.0)
    """
    return observability.error_ellipse(cov, scale=scale, n_points=n)


def plot_precision_view(view: PrecisionView, fig: Figure | None = None) -> Figure:
    """Draw a ``PrecisionView``: alpha against the number of ranges, and the scatter of the fixes' errors.

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> fig = plot_precision_view(precision_view(n_obs=20, n_runs=20))
    >>> # alpha on a log axis; the fixes' errors
    >>> len(fig.axes), fig.axes[0].get_yscale()
    (2, 'log')
    >>> plt.close(fig)
    """
    fig = fig or plt.figure(figsize=(7.2, 3.3))
    ax_a, ax_e = fig.subplots(1, 2)
    k = np.arange(1, view.n_obs + 1)
    finite = np.isfinite(view.alpha_history)
    (alpha,) = ax_a.semilogy(k[finite], view.alpha_history[finite], color="C0")
    ax_a.axhline(2.0, color="C3", ls="--", lw=1, label="α = 2 (paper A)")
    ax_a.axhline(1.0, color="gray", ls=":", lw=1, label="α = 1")
    ax_a.set_xlabel("number of ranges")
    ax_a.set_ylabel("precision factor α")
    ax_a.legend(loc="upper right", fontsize=8)
    fixes = ellipse = None
    if np.all(np.isfinite(view.errors)):
        (fixes,) = ax_e.plot(view.errors[:, 0], view.errors[:, 1], ".", ms=3, color="C0", alpha=0.6,
                             label="LS fixes")
        if np.all(np.isfinite(view.position_covariance)):
            ell = covariance_ellipse(view.position_covariance, 2.0)
            (ellipse,) = ax_e.plot(ell[:, 0], ell[:, 1], color="C3", lw=1.2, label="2σ from (AᵀA)⁻¹")
        ax_e.set_aspect("equal", adjustable="datalim")
        ax_e.legend(loc="upper right", fontsize=8)
    else:
        ax_e.text(0.5, 0.5, "singular: no fix", ha="center", va="center", transform=ax_e.transAxes)
    ax_e.axhline(0.0, color="gray", lw=0.5)
    ax_e.axvline(0.0, color="gray", lw=0.5)
    ax_e.set_xlabel("east error [m]")
    ax_e.set_ylabel("north error [m]")
    _precision_titles(view, ax_a, ax_e)
    fig.tight_layout()
    return keep(fig, alpha=alpha, fixes=fixes, ellipse=ellipse)


def _precision_titles(view: PrecisionView, ax_a: Any, ax_e: Any) -> list[Any]:
    ax_a.set_title(f"{view.n_obs} ranges over {view.turn_deg:.0f}° of bearing", fontsize=9)
    flag = "" if view.well_conditioned else ", ill-conditioned"
    ax_e.set_title(f"α = {view.alpha:.3g}, κ = {view.condition_number:.3g}{flag}\n"
                   f"RMS error {view.rmse:.3g} m (predicted {view.predicted_rmse:.3g} m)", fontsize=9)
    return [ax_a.title, ax_e.title]


def update_precision_view(fig: Figure, view: PrecisionView) -> list[Any] | None:
    """Put another ``PrecisionView`` into a figure drawn by ``plot_precision_view``; returns what changed, or
    ``None`` when the figure must be drawn anew (a fix or its ellipse appears or disappears)."""
    a = kept(fig)
    if a is None:                   # not a figure the plot function drew: draw it anew
        return None
    has_fixes = bool(np.all(np.isfinite(view.errors)))
    has_ellipse = has_fixes and bool(np.all(np.isfinite(view.position_covariance)))
    if (a["fixes"] is not None) != has_fixes or (a["ellipse"] is not None) != has_ellipse:
        return None
    ax_a, ax_e = fig.axes[:2]
    k = np.arange(1, view.n_obs + 1)
    finite = np.isfinite(view.alpha_history)
    a["alpha"].set_data(k[finite], view.alpha_history[finite])
    changed = [a["alpha"]]
    if has_fixes:
        a["fixes"].set_data(view.errors[:, 0], view.errors[:, 1])
        changed.append(a["fixes"])
    if has_ellipse:
        ell = covariance_ellipse(view.position_covariance, 2.0)
        a["ellipse"].set_data(ell[:, 0], ell[:, 1])
        changed.append(a["ellipse"])
    rescale(ax_a, ax_e)
    return changed + _precision_titles(view, ax_a, ax_e)


def precision_widget() -> Any:
    """Sliders for the number of ranges and the bearing change, over alpha and the LS error (chapter 3).

    Examples
    --------
    >>> panel = precision_widget()
    >>> [c.description for c in panel.children[0].children]
    ['ranges', 'bearing change [°]', 'σ [m]']
    """
    import ipywidgets as w

    style = {"description_width": "initial"}
    sliders = {
        "n_obs": w.IntSlider(value=236, min=5, max=1000, step=1, description="ranges",
                             continuous_update=False, style=style),
        "turn_deg": w.FloatSlider(value=90.0, min=2.0, max=360.0, step=2.0, description="bearing change [°]",
                                  continuous_update=False, style=style),
        "noise_sigma": w.FloatSlider(value=float(np.sqrt(5.0)), min=0.5, max=10.0, step=0.1,
                                     description="σ [m]", continuous_update=False, style=style),
    }
    view = functools.lru_cache(maxsize=256)(precision_view)
    return slider_panel(sliders, lambda fig, **p: plot_precision_view(view(**p), fig),
                        lambda fig, **p: update_precision_view(fig, view(**p)))


# --- paper D's pre-location cost map ------------------------------------------------------------------------------

@dataclass(frozen=True)
class PrelocationView:
    r"""Paper D's grid-search pre-location on one run of its scenario, from the epochs up to ``epoch``.

    Attributes
    ----------
    bearing_step_deg : float
        Grid step in start bearing [deg].
    speed_step : float
        Grid step in effective sound speed [m/s].
    epoch : int
        Last epoch used (the vehicle turns at epoch 70).
    time : float
        Its time [s].
    bearings_deg : ndarray, shape (B,)
        The bearing grid [deg].
    speeds : ndarray, shape (C,)
        The effective sound speeds of the grid, :math:`c - \Delta c` [m/s].
    log_cost : ndarray, shape (B, C)
        :math:`\log_{10} L` over the grid.
    bearing_profile : ndarray, shape (B,)
        :math:`\min_c L(\theta, c)`, the floor of the cost along each bearing [s²].
    best : tuple of float
        ``(bearing_deg, speed)`` of the minimum.
    runner_up : tuple of float or None
        The best cell of the deepest other valley: the deepest local minimum of ``bearing_profile`` at least
        8 degrees from the best bearing (before the turn, the mirror), or ``None``.
    truth : tuple of float
        True start bearing [deg] and mean effective speed [m/s].
    mirror_bearing_deg : float
        The true start reflected across the line through the beacon along the first leg [deg]: where the
        mirror valley lies.
    true_track : ndarray, shape (K, 2)
        True positions of all epochs [m].
    estimated_track : ndarray, shape (epoch + 1, 2)
        The track implied by the minimum (its start plus the DR displacements) up to ``epoch`` [m].
    runner_up_track : ndarray or None
        The track implied by the runner-up [m].
    error : float
        Distance between the pre-located and the true position at ``epoch`` [m].

    Examples
    --------
    >>> view = prelocation_view(bearing_step_deg=2.0, speed_step=10.0, epoch=60)
    >>> # 180 bearings x 26 speeds; epochs 0..60
    >>> view.log_cost.shape, view.estimated_track.shape
    ((180, 26), (61, 2))
    """

    bearing_step_deg: float
    speed_step: float
    epoch: int
    time: float
    bearings_deg: np.ndarray
    speeds: np.ndarray
    log_cost: np.ndarray
    bearing_profile: np.ndarray
    best: tuple[float, float]
    runner_up: tuple[float, float] | None
    truth: tuple[float, float]
    mirror_bearing_deg: float
    true_track: np.ndarray
    estimated_track: np.ndarray
    runner_up_track: np.ndarray | None
    error: float


def _runner_up(profile: np.ndarray, bearings: np.ndarray, best: float, separation: float = 8.0) -> int | None:
    """Index of the deepest local minimum of a circular bearing profile at least ``separation`` deg from ``best``."""
    lower_left = profile <= np.roll(profile, 1)
    lower_right = profile <= np.roll(profile, -1)
    far = np.abs((bearings - best + 180.0) % 360.0 - 180.0) >= separation
    candidates = np.flatnonzero(lower_left & lower_right & far)
    if candidates.size == 0:
        return None
    return int(candidates[np.argmin(profile[candidates])])


def prelocation_view(bearing_step_deg: float = 2.0, speed_step: float = 10.0, epoch: int = 60,
                     seed: int = 0) -> PrelocationView:
    """Paper D's cost map after ``epoch`` epochs of one run of ``scenarios.approach_with_turn_scenario``.

    The grid covers all bearings and effective speeds from 1550 down to 1300 m/s (paper D's search range); the
    vehicle converts with 1470 m/s while the sound travels at N(1500, 1) m/s. The runner-up is the deepest local
    minimum other than the best one, found with a 3 x 3 minimum filter: before the turn (epoch 70) it is the mirror
    of the true start.

    Parameters
    ----------
    bearing_step_deg : float, default 2
        Bearing step [deg] (0.5 to 30).
    speed_step : float, default 10
        Speed step [m/s] (1 to 50).
    epoch : int, default 60
        Last epoch used, 2 to 150.
    seed : int, default 0
        Seed of the scenario.

    Returns
    -------
    PrelocationView

    Examples
    --------
    >>> # before the turn at epoch 70: a mirror valley
    >>> before = prelocation_view(epoch=60)
    >>> ([round(b) for b in before.truth], round(before.mirror_bearing_deg),
    ...  before.runner_up is None)
    ([207, 1500], 183, False)
    >>> # after it: one valley, at the truth
    >>> after = prelocation_view(epoch=100)
    >>> after.runner_up is None, round(after.best[0]), bool(after.error < before.error)
    (True, 206, True)
    """
    step_b = float(as_positive("bearing_step_deg", bearing_step_deg, ndim=0))
    step_c = float(as_positive("speed_step", speed_step, ndim=0))
    if not 0.5 <= step_b <= 30.0 or not 1.0 <= step_c <= 50.0:
        raise ValueError(f"bearing_step_deg must lie in [0.5, 30] and speed_step in [1, 50]; got {step_b:g} and "
                         f"{step_c:g}")
    sc = scenarios.approach_with_turn_scenario(np.random.default_rng(as_seed("seed", seed)))
    k = as_int("epoch", epoch, minimum=2)
    if k >= sc.n_steps:
        raise ValueError(f"epoch must be below the number of epochs ({sc.n_steps}); got {k}")
    run = sc.run(0)
    c = 1470.0
    bearings = np.arange(0.0, 360.0, step_b)
    speeds = np.arange(1550.0, 1300.0 - 1e-9, -step_c)
    pre = lsq.grid_prelocation(ranges=run.ranges[:k + 1], dr_displacements=run.dr_displacements[:k + 1],
                               bearing_grid=np.deg2rad(bearings), speed_error_grid=c - speeds, assumed_speed=c)
    cost = pre.cost_map
    profile = cost.min(axis=1)
    D = np.cumsum(run.dr_displacements[:k + 1], axis=0) - run.dr_displacements[0]
    best_bearing = float(np.rad2deg(pre.bearing[-1]))
    i = _runner_up(profile, bearings, best_bearing)
    runner, runner_track = None, None
    if i is not None:
        j = int(np.argmin(cost[i]))
        runner = (float(bearings[i]), float(speeds[j]))
        th = np.deg2rad(bearings[i])
        runner_track = speeds[j] * run.ranges[0] / c * np.array([np.cos(th), np.sin(th)]) + D
    p0 = run.true_positions[0]
    true_bearing = float(np.rad2deg(np.arctan2(p0[1], p0[0])) % 360.0)
    leg = run.true_positions[1] - run.true_positions[0]
    mirror = float((2.0 * np.rad2deg(np.arctan2(leg[1], leg[0])) - true_bearing) % 360.0)
    with np.errstate(divide="ignore"):
        log_cost = np.log10(cost)
    return PrelocationView(
        bearing_step_deg=step_b, speed_step=step_c, epoch=k, time=float(run.times[k]), bearings_deg=bearings,
        speeds=speeds, log_cost=log_cost, bearing_profile=profile,
        best=(best_bearing, float(pre.effective_speed[-1])), runner_up=runner, truth=(true_bearing, 1500.0),
        mirror_bearing_deg=mirror, true_track=np.array(run.true_positions), estimated_track=pre.start[-1] + D,
        runner_up_track=runner_track, error=float(np.linalg.norm(pre.position[-1] - run.true_positions[k])))


def plot_prelocation_view(view: PrelocationView, fig: Figure | None = None) -> Figure:
    """Draw a ``PrelocationView``: the cost map with its minima, and the pre-located track against the truth.

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> fig = plot_prelocation_view(prelocation_view(epoch=60))
    >>> # the cost map, its colour bar, the tracks
    >>> len(fig.axes)
    3
    >>> plt.close(fig)
    """
    fig = fig or plt.figure(figsize=(7.4, 3.4))
    ax_c, ax_t = fig.subplots(1, 2)
    db, dc = view.bearing_step_deg, view.speed_step
    extent = (view.bearings_deg[0] - db / 2, view.bearings_deg[-1] + db / 2,
              view.speeds[-1] - dc / 2, view.speeds[0] + dc / 2)
    finite = view.log_cost[np.isfinite(view.log_cost)]
    im = ax_c.imshow(view.log_cost[:, ::-1].T, origin="lower", extent=extent, aspect="auto", cmap="viridis",
                     vmin=float(np.min(finite)), vmax=float(np.percentile(finite, 60)))
    ax_c.grid(False)
    fig.colorbar(im, ax=ax_c, label="log₁₀ L [s²]", fraction=0.05, pad=0.02)
    (truth,) = ax_c.plot(*view.truth, "o", mfc="none", mec="white", ms=9, label="truth")
    (best,) = ax_c.plot(*view.best, "x", color="C3", ms=8, mew=2, label="minimum")
    runner = runner_track = None
    if view.runner_up is not None:
        (runner,) = ax_c.plot(*view.runner_up, "+", color="C1", ms=9, mew=2, label="runner-up")
    ax_c.set_xlim(view.truth[0] - 60.0, view.truth[0] + 60.0)        # the whole circle is searched; zoom in
    ax_c.set_xlabel("start bearing θ [°] (zoomed)")
    ax_c.set_ylabel("effective speed c − Δc [m/s]")
    ax_c.legend(loc="lower left", fontsize=7, framealpha=0.7, frameon=True)
    ax_c.set_title(f"cost after {view.epoch + 1} epochs (t = {view.time:.0f} s)", fontsize=9)
    ax_t.plot(*view.true_track.T, color="black", lw=1, label="true track")
    (track,) = ax_t.plot(*view.estimated_track.T, color="C3", lw=1.2, label="pre-located")
    if view.runner_up_track is not None:
        (runner_track,) = ax_t.plot(*view.runner_up_track.T, color="C1", lw=1, ls="--", label="runner-up")
    (now,) = ax_t.plot(*view.true_track[view.epoch], "o", color="black", ms=4)
    mark_beacon(ax_t)
    ax_t.set_aspect("equal", adjustable="datalim")
    ax_t.set_xlabel("x east [m]")
    ax_t.set_ylabel("y north [m]")
    ax_t.legend(loc="upper left", fontsize=7)
    ax_t.set_title(f"error now {view.error:.0f} m", fontsize=9)
    fig.tight_layout()
    return keep(fig, image=im, best=best, runner=runner, track=track, runner_track=runner_track, now=now)


def update_prelocation_view(fig: Figure, view: PrelocationView) -> list[Any] | None:
    """Put another ``PrelocationView`` into a figure drawn by ``plot_prelocation_view``; returns what changed, or
    ``None`` when it must be drawn anew (a runner-up appearing or disappearing)."""
    a = kept(fig)
    if a is None:                   # not a figure the plot function drew: draw it anew
        return None
    db, dc = view.bearing_step_deg, view.speed_step
    if (a["runner"] is None) != (view.runner_up is None) or \
            (a["runner_track"] is None) != (view.runner_up_track is None):
        return None
    ax_c, ax_t = fig.axes[:2]
    finite = view.log_cost[np.isfinite(view.log_cost)]
    a["image"].set_data(view.log_cost[:, ::-1].T)
    a["image"].set_extent((view.bearings_deg[0] - db / 2, view.bearings_deg[-1] + db / 2,
                           view.speeds[-1] - dc / 2, view.speeds[0] + dc / 2))
    ax_c.set_xlim(view.truth[0] - 60.0, view.truth[0] + 60.0)          # set_extent fits the limits to the image
    ax_c.set_ylim(view.speeds[-1] - dc / 2, view.speeds[0] + dc / 2)
    # the colour scale (and its bar) kept while the new one is within a tenth of its span
    low, high = float(np.min(finite)), float(np.percentile(finite, 60))
    now_low, now_high = a["image"].get_clim()
    if max(abs(low - now_low), abs(high - now_high)) > 0.1 * (now_high - now_low):
        a["image"].set_clim(low, high)
    a["best"].set_data([view.best[0]], [view.best[1]])
    a["track"].set_data(*view.estimated_track.T)
    a["now"].set_data([view.true_track[view.epoch][0]], [view.true_track[view.epoch][1]])
    changed = [a["image"], a["best"], a["track"], a["now"]]
    if view.runner_up is not None:                  # (the two are None together: drawn as the figure draws them)
        a["runner"].set_data([view.runner_up[0]], [view.runner_up[1]])
        changed.append(a["runner"])
    if view.runner_up_track is not None:
        a["runner_track"].set_data(*view.runner_up_track.T)
        changed.append(a["runner_track"])
    ax_c.set_title(f"cost after {view.epoch + 1} epochs (t = {view.time:.0f} s)", fontsize=9)
    ax_t.set_title(f"error now {view.error:.0f} m", fontsize=9)
    rescale(ax_t)
    return changed + [ax_c.title, ax_t.title]


def prelocation_widget() -> Any:
    """Sliders for the grid resolution and the number of epochs over paper D's cost map (chapter 3).

    Examples
    --------
    >>> panel = prelocation_widget()
    >>> [c.description for c in panel.children[0].children]
    ['bearing step [°]', 'speed step [m/s]', 'epochs used']
    """
    import ipywidgets as w

    style = {"description_width": "initial"}
    sliders = {
        "bearing_step_deg": w.FloatSlider(value=2.0, min=1.0, max=20.0, step=0.5, description="bearing step [°]",
                                          continuous_update=False, style=style),
        "speed_step": w.FloatSlider(value=10.0, min=5.0, max=50.0, step=5.0, description="speed step [m/s]",
                                    continuous_update=False, style=style),
        "epoch": w.IntSlider(value=60, min=5, max=150, step=1, description="epochs used",
                             continuous_update=False, style=style),
    }
    view = functools.lru_cache(maxsize=256)(prelocation_view)
    return slider_panel(sliders, lambda fig, **p: plot_prelocation_view(view(**p), fig),
                        lambda fig, **p: update_prelocation_view(fig, view(**p)))


#: Zero-argument callables running each chapter-3 widget's computation at its defaults (for ``make bench``).
COMPUTE_FUNCTIONS: dict[str, Callable[[], Any]] = {
    "ch03 precision factor": precision_view,
    "ch03 pre-location": prelocation_view,
}
