"""Chapter 2 widget: observability and the Cramér–Rao bound along a track (mirror solution, rank, CRLB ellipses)."""

from __future__ import annotations

import functools
import warnings
from dataclasses import dataclass
from typing import Any, Callable

import matplotlib.pyplot as plt
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
import numpy as np

from .. import motion, observability
from .._validate import as_scalar
from ..plotting import mark_beacon, plot_track
from ._panel import keep, kept, rescale, slider_panel, snap_to_decades

__all__ = [
    "TRACK_CHOICES",
    "STATE_CHOICES",
    "ObservabilityView",
    "observability_view",
    "plot_observability_view",
    "observability_widget",
]

#: The tracks the widget offers (beacon at the origin, 2 m/s, a range every 10 s for 1200 s).
TRACK_CHOICES = ("circle", "straight", "straight + turn", "lawnmower", "radial")
#: The choices of unknowns, the position alone, with a constant range bias (paper A) or with a constant current
#: (paper B).
STATE_CHOICES = ("position", "position + bias", "position + current")

_STATE_FLAGS = {
    "position": {},
    "position + bias": {"unknown_bias": True},
    "position + current": {"unknown_current": True},
}
_SPEED = 2.0
_TURN_TIME = 600.0
_STRAIGHT_START = (-1500.0, 600.0)
# Epochs (every how many) at which the widget draws CRLB ellipses, and their magnification.
_ELLIPSE_EVERY = 20
ELLIPSE_SCALE = 20.0


@dataclass(frozen=True)
class ObservabilityView:
    """What the observability widget shows for one track, turn angle, range noise and choice of unknowns.

    Parameters
    ----------
    track : str
        One of ``TRACK_CHOICES``.
    turn_angle_deg : float
        Heading change of the ``"straight + turn"`` track at 600 s [deg], positive to the left
        (counter-clockwise); ignored by the other tracks.
    sigma : float
        Range noise standard deviation [m].
    state : str
        The unknowns whose CRLB ellipses are drawn, one of ``STATE_CHOICES``.
    times : ndarray, shape (K,)
        Ranging epochs [s].
    positions : ndarray, shape (K, 2)
        True track [m]; the beacon is at ``beacon``.
    beacon : ndarray, shape (2,)
        Beacon position [m].
    mirror_positions : ndarray, shape (K, 2)
        The mirror track: the same dead-reckoned shape started from the reflection of the start point across
        the line through the beacon along the initial heading. On a straight leg it fits every range exactly.
    mirror_misfit : ndarray, shape (K,)
        Range of the mirror track minus the true range at each epoch [m]: zero until a heading change betrays it.
    ranks : dict of ndarray
        For each entry of ``STATE_CHOICES``, the numerical rank of the information after each epoch, shape (K,).
    n_states : dict of int
        The number of unknowns of each choice (2, 3, 4): full rank.
    rmse : dict of ndarray
        For each choice, the bound on the RMS position error after each epoch [m] (``inf`` while unobservable).
    crlb : ndarray, shape (K, 2, 2)
        The position block of the bound of ``state`` after each epoch [m²].

    Examples
    --------
    >>> view = observability_view(track="straight + turn", turn_angle_deg=60.0)
    >>> # a range every 10 s for 1200 s
    >>> view.times.shape, view.positions.shape, view.crlb.shape
    ((121,), (121, 2), (121, 2, 2))
    """

    track: str
    turn_angle_deg: float
    sigma: float
    state: str
    times: np.ndarray
    positions: np.ndarray
    beacon: np.ndarray
    mirror_positions: np.ndarray
    mirror_misfit: np.ndarray
    ranks: dict[str, np.ndarray]
    n_states: dict[str, int]
    rmse: dict[str, np.ndarray]
    crlb: np.ndarray


def _make_track(track: str, turn_angle_deg: float, times: np.ndarray) -> motion.Track:
    if track == "circle":
        return motion.circle_track(times, radius=800.0, speed=_SPEED, start_angle=-np.pi / 2)
    if track == "straight":
        return motion.straight_track(times, start=_STRAIGHT_START, speed=_SPEED, heading=0.0)
    if track == "straight + turn":
        return motion.turning_track(times, start=_STRAIGHT_START, speed=_SPEED,
                                    headings=[0.0, np.radians(turn_angle_deg)], turn_times=[_TURN_TIME])
    if track == "lawnmower":
        return motion.lawnmower_track(times, start=(-600.0, -700.0), speed=_SPEED, leg_length=800.0, spacing=250.0)
    if track == "radial":
        return motion.straight_track(times, start=(-2600.0, 0.0), speed=_SPEED, heading=0.0)
    raise ValueError(f"track must be one of {', '.join(repr(t) for t in TRACK_CHOICES)}; got {track!r}")


def _track_and_mirror(track: str, turn_angle_deg: float, times: np.ndarray,
                      beacon: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The true track and its mirror (the same shape from the start reflected across the line through the beacon
    along the initial heading), each shape (K, 2) [m]."""
    tr = _make_track(track, turn_angle_deg, times)
    p = np.array(tr.positions)
    mirror_start = observability.mirror_point(p[0], beacon, tr.velocities[0])
    return p, mirror_start + (p - p[0])


@functools.lru_cache(maxsize=4)
def _widget_frame(angles: tuple[float, ...]) -> tuple[float, float, float, float]:
    """Map limits (x0, x1, y0, y1) [m] that hold every track of ``TRACK_CHOICES`` and its mirror at each turn angle
    of ``angles``, framed as ``plot_observability_view`` frames one view: chosen once for the widget, so that a
    move of the track or the turn angle keeps the map's axes (and the pixels drawn of them)."""
    times = np.arange(0.0, 1200.0 + 1e-9, 10.0)
    beacon = np.zeros(2)
    points = [beacon[None, :]]
    for track in TRACK_CHOICES:
        for angle in (angles if track == "straight + turn" else angles[:1]):
            points += list(_track_and_mirror(track, angle, times, beacon))
    return _frame(np.vstack(points))


def _frame(pts: np.ndarray) -> tuple[float, float, float, float]:
    """The square map limits (x0, x1, y0, y1) around the points ``pts``, shape (N, 2), with a fifth of their
    extent to spare."""
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    center, half = (lo + hi) / 2, 0.6 * max(float(np.max(hi - lo)), 1.0)
    return (float(center[0] - half), float(center[0] + half), float(center[1] - half), float(center[1] + half))


def observability_view(track: str = "straight + turn", turn_angle_deg: float = 60.0, sigma: float = 5.0,
                       state: str = "position") -> ObservabilityView:
    """Compute everything the observability widget shows (see ``ObservabilityView``).

    The vehicle runs at 2 m/s with a range to a beacon at the origin every 10 s for 1200 s (121 ranges); dead
    reckoning is exact, so the bounds show what the geometry alone allows. Expected degeneracies (the first epoch,
    a straight track with a current) are silenced here: they show as infinite bounds and low ranks.

    Parameters
    ----------
    track : str, default "straight + turn"
        One of ``TRACK_CHOICES``.
    turn_angle_deg : float, default 60
        Heading change at 600 s for ``"straight + turn"`` [deg], positive to the left.
    sigma : float, default 5
        Range noise standard deviation [m], > 0.
    state : str, default "position"
        Whose CRLB ellipses to keep in ``crlb``; one of ``STATE_CHOICES``.

    Returns
    -------
    ObservabilityView

    Examples
    --------
    >>> import numpy as np
    >>> straight = observability_view(track="straight")
    >>> # the mirror track fits every range
    >>> round(float(np.abs(straight.mirror_misfit).max()), 3)
    0.0
    >>> int(straight.ranks["position + current"][-1]), straight.n_states["position + current"]
    (3, 4)
    >>> turned = observability_view(track="straight + turn", turn_angle_deg=60.0)
    >>> # the turn betrays the mirror
    >>> bool(np.abs(turned.mirror_misfit).max() > 100.0)
    True
    >>> {name: int(rank[-1]) for name, rank in turned.ranks.items()} == turned.n_states
    True
    """
    if track not in TRACK_CHOICES:
        raise ValueError(f"track must be one of {', '.join(repr(t) for t in TRACK_CHOICES)}; got {track!r}")
    if state not in STATE_CHOICES:
        raise ValueError(f"state must be one of {', '.join(repr(s) for s in STATE_CHOICES)}; got {state!r}")
    theta = as_scalar("turn_angle_deg", turn_angle_deg)
    s = as_scalar("sigma", sigma, domain="positive")
    times = np.arange(0.0, 1200.0 + 1e-9, 10.0)
    beacon = np.zeros(2)
    p, mirror = _track_and_mirror(track, theta, times, beacon)
    misfit = np.hypot(*(mirror - beacon).T) - np.hypot(*(p - beacon).T)
    ranks: dict[str, np.ndarray] = {}            # per epoch (a track of K positions gives arrays)
    rmse: dict[str, np.ndarray] = {}
    n_states: dict[str, int] = {}
    crlb = np.empty((len(times), 2, 2))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", observability.UnobservableWarning)
        for name, flags in _STATE_FLAGS.items():
            bound = observability.track_crlb(p, beacon, s, times=times, **flags)
            ranks[name] = np.asarray(observability.observability_rank(p, beacon, times=times, **flags))
            n_states[name] = bound.shape[-1]
            rmse[name] = np.asarray(observability.rmse_bound(bound))
            if name == state:
                crlb = bound[:, :2, :2].copy()
    return ObservabilityView(track=track, turn_angle_deg=theta, sigma=s, state=state, times=times, positions=p,
                             beacon=beacon, mirror_positions=mirror, mirror_misfit=misfit, ranks=ranks,
                             n_states=n_states, rmse=rmse, crlb=crlb)


def plot_observability_view(view: ObservabilityView, fig: Figure | None = None,
                            frame: tuple[float, float, float, float] | None = None) -> Any:
    """Draw an ``ObservabilityView``: the track with its mirror and CRLB ellipses, the mirror's range misfit, the
    rank of the information over time and the RMSE bound of each choice of unknowns.

    ``frame``, the map limits (x0, x1, y0, y1) [m], defaults to a square around this view's tracks; the widget
    gives one that holds every track it offers (its updates then keep it).

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> fig = plot_observability_view(observability_view(track="circle"))
    >>> # the map, the mirror's misfit, the ranks and bounds
    >>> len(fig.axes) >= 3
    True
    >>> plt.close(fig)
    """
    fig = fig or plt.figure(figsize=(8.0, 5.6))
    # fixed margins rather than tight_layout: the static sweep redraws this figure frame after frame
    grid = fig.add_gridspec(3, 2, width_ratios=(1.15, 1.0), left=0.09, right=0.98, bottom=0.08, top=0.95,
                            wspace=0.3, hspace=0.32)
    ax_map = fig.add_subplot(grid[:, 0])
    ax_mis, ax_rank, ax_rmse = (fig.add_subplot(grid[i, 1]) for i in range(3))
    colors = _STATE_COLORS

    mark_beacon(ax_map, view.beacon)
    plot_track(ax_map, view.positions, label="true track", color="black", lw=1.2)
    plot_track(ax_map, view.mirror_positions, label="mirror track", color="C3", lw=1.0, ls="--")
    tracks = ax_map.lines[-2:]
    drawn = False
    ellipses = []
    for _k, pts in _ellipses(view):
        ellipses.append(ax_map.plot(pts[:, 0], pts[:, 1], color=colors[view.state], lw=1.0,
                                    label=None if drawn else _ellipse_label(view, True))[0])
        drawn = True
    if not drawn:
        ax_map.plot([], [], color=colors[view.state], label=_ellipse_label(view, False))
    # frame the tracks, not the ellipses (an early ellipse can be kilometres long)
    x0, x1, y0, y1 = frame or _frame(np.vstack([view.positions, view.mirror_positions, view.beacon[None, :]]))
    ax_map.set_xlim(x0, x1)
    ax_map.set_ylim(y0, y1)
    ax_map.set_aspect("equal", adjustable="box")
    ax_map.legend(loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=2, fontsize=7)
    ax_map.set_xlabel("x east [m]", fontsize=8)
    ax_map.set_ylabel("y north [m]", fontsize=8)
    ax_map.tick_params(labelsize=7)
    title = view.track + (f", turn {view.turn_angle_deg:+.0f}°" if view.track == "straight + turn" else "")
    ax_map.set_title(title, fontsize=9)

    t_min = view.times / 60.0
    floor = 0.1
    (misfit,) = ax_mis.semilogy(t_min, np.maximum(np.abs(view.mirror_misfit), floor), color="C3",
                                label="|mirror − true range| (0 drawn at 0.1)")
    noise = ax_mis.axhline(view.sigma, color="gray", ls=":", label=f"range noise σ = {view.sigma:g} m")
    ax_mis.set_ylim(floor / 1.5, 1e6)   # two decades of headroom for the legend above the largest misfit
    ax_mis.tick_params(labelbottom=False)
    ax_mis.set_ylabel("misfit [m]", fontsize=8)
    ax_mis.set_title(f"mirror track: ranges off by {abs(view.mirror_misfit[-1]):.0f} m at the end", fontsize=8)
    ax_mis.legend(loc="upper left", fontsize=6.5)
    ax_mis.tick_params(labelsize=7)
    ax_mis.minorticks_off()             # hundreds of minor log ticks would slow every redraw

    ranks = []
    for i, (name, r) in enumerate(view.ranks.items()):
        ranks += ax_rank.step(t_min, r + 0.06 * (i - 1), where="post", color=colors[name],
                     label=f"{name} (full: {view.n_states[name]})")
    ax_rank.set_yticks(range(0, 5))
    ax_rank.set_ylim(0.5, 6.5)          # room above full rank for the legend
    ax_rank.tick_params(labelbottom=False)
    ax_rank.set_ylabel("rank", fontsize=8)
    ax_rank.legend(loc="upper left", fontsize=6.5, ncol=2)
    ax_rank.tick_params(labelsize=7)

    finals, bounds = [], []
    for name, e in view.rmse.items():
        shown = np.where(np.isfinite(e), e, np.nan)
        bounds += ax_rmse.semilogy(t_min, shown, color=colors[name], label=name)
        finals.append("∞" if not np.isfinite(e[-1]) else f"{e[-1]:.1f}")
    ax_rmse.set_xlabel("time [min]", fontsize=8)
    ax_rmse.set_ylabel("RMSE bound [m]", fontsize=8)
    ax_rmse.set_title("final RMSE bound [m]: " + " / ".join(finals), fontsize=8)
    ax_rmse.legend(loc="upper right", fontsize=6.5)
    ax_rmse.tick_params(labelsize=7)
    ax_rmse.minorticks_off()
    snap_to_decades(ax_rmse)            # as the updates keep them (see ``rescale``)
    return keep(fig, tracks=tracks, ellipses=ellipses, state=view.state, misfit=misfit, noise=noise, ranks=ranks,
                bounds=bounds, frame=frame)


#: The colour of each choice of unknowns (its ellipses, rank and bound).
_STATE_COLORS = {"position": "C0", "position + bias": "C1", "position + current": "C2"}


def _ellipses(view: ObservabilityView) -> list[tuple[int, np.ndarray]]:
    """The CRLB ellipses the map shows: (epoch, points) every ``_ELLIPSE_EVERY`` epochs where the bound is finite."""
    out = []
    for k in range(_ELLIPSE_EVERY, len(view.times), _ELLIPSE_EVERY):
        C = view.crlb[k]
        if np.all(np.isfinite(C)):
            out.append((k, observability.error_ellipse(C, view.positions[k], scale=ELLIPSE_SCALE)))
    return out


def _ellipse_label(view: ObservabilityView, drawn: bool) -> str:
    """The map legend's entry for the ellipses (``drawn``: some bound is finite)."""
    return f"CRLB 1σ ×{ELLIPSE_SCALE:g} ({view.state})" if drawn else f"{view.state}: no finite bound"


def update_observability_view(fig: Figure, view: ObservabilityView) -> list[Any] | None:
    """Put another ``ObservabilityView`` into a figure drawn by ``plot_observability_view``; returns what changed.

    Other unknowns, another track and another number of finite ellipses (none among them) are all put in place:
    the ellipse lines are reused, added or removed and recoloured, and the map legend's last entry follows."""
    a = kept(fig)
    if a is None:                   # not a figure the plot function drew: draw it anew
        return None
    ellipses = _ellipses(view)
    ax_map, ax_mis, ax_rank, ax_rmse = fig.axes[:4]
    a["tracks"][0].set_data(*view.positions.T)
    a["tracks"][1].set_data(*view.mirror_positions.T)
    color = _STATE_COLORS[view.state]
    lines = a["ellipses"]
    while len(lines) > len(ellipses):
        lines.pop().remove()
    while len(lines) < len(ellipses):
        lines.append(ax_map.plot([], [], color=color, lw=1.0)[0])
    for line, (_, pts) in zip(lines, ellipses):
        line.set_data(pts[:, 0], pts[:, 1])
        line.set_color(color)
    # the map legend is redrawn at every update (so never kept in the background, where its old entry would show)
    map_legend = ax_map.get_legend()
    assert map_legend is not None                   # plot_observability_view draws it
    ellipse_handle = map_legend.legend_handles[-1]
    assert isinstance(ellipse_handle, Line2D)       # the handle of a plotted line
    ellipse_handle.set_color(color)
    map_legend.get_texts()[-1].set_text(_ellipse_label(view, bool(ellipses)))
    a["state"] = view.state
    pts = np.vstack([view.positions, view.mirror_positions, view.beacon[None, :]])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    center, half = (lo + hi) / 2, 0.6 * max(float(np.max(hi - lo)), 1.0)
    (x0, x1), (y0, y1) = ax_map.get_xlim(), ax_map.get_ylim()
    inside = x0 <= lo[0] and hi[0] <= x1 and y0 <= lo[1] and hi[1] <= y1
    # the widget's frame holds every track it offers: kept; another frame is kept while the tracks fill enough of it
    if not (inside and (a["frame"] is not None or 2 * half >= 0.6 * (x1 - x0))):
        half *= 1.15                    # the frame changes: with room for the next step of the same control
        ax_map.set_xlim(center[0] - half, center[0] + half)
        ax_map.set_ylim(center[1] - half, center[1] + half)
    title = view.track + (f", turn {view.turn_angle_deg:+.0f}°" if view.track == "straight + turn" else "")
    ax_map.set_title(title, fontsize=9)
    t_min = view.times / 60.0
    a["misfit"].set_ydata(np.maximum(np.abs(view.mirror_misfit), 0.1))
    a["noise"].set_ydata([view.sigma, view.sigma])
    legend = ax_mis.get_legend()
    assert legend is not None                       # plot_observability_view draws it
    legend.get_texts()[1].set_text(f"range noise σ = {view.sigma:g} m")
    ax_mis.set_title(f"mirror track: ranges off by {abs(view.mirror_misfit[-1]):.0f} m at the end", fontsize=8)
    for i, (line, r) in enumerate(zip(a["ranks"], view.ranks.values())):
        line.set_data(t_min, r + 0.06 * (i - 1))
    finals = []
    for line, e in zip(a["bounds"], view.rmse.values()):
        line.set_data(t_min, np.where(np.isfinite(e), e, np.nan))
        finals.append("∞" if not np.isfinite(e[-1]) else f"{e[-1]:.1f}")
    ax_rmse.set_title("final RMSE bound [m]: " + " / ".join(finals), fontsize=8)
    # whole decades, kept while at most three are spare: the early bound of one track can be 100 times another's,
    # and most moves then keep the axes (and their pixels)
    rescale(ax_rmse, decades=True, spare_decades=3.0)
    return [*a["tracks"], *lines, map_legend, ax_map.title, a["misfit"], a["noise"], legend,
            ax_mis.title, *a["ranks"], *a["bounds"], ax_rmse.title]


def observability_widget() -> Any:
    """A track, a turn angle, the range noise and the unknowns over the observability view (chapter 2).

    Examples
    --------
    >>> panel = observability_widget()
    >>> [c.description for row in panel.children[:2] for c in row.children]
    ['track', 'turn [°]', 'σ range [m]', 'ellipses of']
    """
    import ipywidgets as w

    style = {"description_width": "initial"}
    sliders = {
        "track": w.Dropdown(options=list(TRACK_CHOICES), value="straight + turn", description="track",
                            style=style),
        "turn_angle_deg": w.IntSlider(value=60, min=-180, max=180, step=15, description="turn [°]",
                                      continuous_update=False, style=style),
        "sigma": w.FloatSlider(value=5.0, min=0.5, max=20.0, step=0.5, description="σ range [m]",
                               continuous_update=False, style=style),
        "state": w.Dropdown(options=list(STATE_CHOICES), value="position", description="ellipses of",
                            style=style),
    }
    view = functools.lru_cache(maxsize=256)(observability_view)
    turn = sliders["turn_angle_deg"]
    frame = _widget_frame(tuple(float(a) for a in range(turn.min, turn.max + 1, turn.step)))
    return slider_panel(sliders, lambda fig, **p: plot_observability_view(view(**p), fig, frame),
                        lambda fig, **p: update_observability_view(fig, view(**p)))


#: This chapter's widget computations at their default parameters (collected by ``uwtutor.widgets``).
COMPUTE_FUNCTIONS: dict[str, Callable[[], Any]] = {
    "ch02 observability": observability_view,
}
