r"""Chapter 11 widget: :func:`~uwtutor.datasets.navigate` on the real Plaza 2 log, one beacon or four, at a range
period, with the states of your choice.

Every combination of the controls -- a beacon (or all four), a range period (every range, or one per beacon every 5,
10 or 30 s) and the states estimated beyond the pose (none, the range scale, the gyro bias, both) -- was run once by
chapter 11's study (``make study-real``; :func:`uwtutor.datasets.study.load_real_data_study`), so that a move of a
control only picks arrays: ``real_data_view`` is that pick (tested without a UI), ``plot_real_data_view`` draws the
track against the truth and the dead reckoning, the error over time (filter and RTS smoother) and the scale
estimate with its standard deviation against the scale measured on the truth.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any, Callable, Literal

import matplotlib.pyplot as plt
from matplotlib.figure import Figure
import numpy as np
from matplotlib.ticker import NullLocator

from ..datasets.study import GRID_BEACONS, GRID_PERIODS, GRID_STATES, RealDataStudy, load_real_data_study
from ._panel import keep, kept, rescale, slider_panel

__all__ = ["RealDataView", "real_data_view", "plot_real_data_view", "real_data_widget", "PERIOD_LABELS",
           "COMPUTE_FUNCTIONS"]

#: The widget's names of the range periods of ``GRID_PERIODS``.
PERIOD_LABELS = {None: "every range", 5.0: "one per 5 s", 10.0: "one per 10 s", 30.0: "one per 30 s"}


@dataclass(frozen=True)
class RealDataView:
    """What the chapter-11 widget shows for one (beacon, period, states) of the committed grid (Plaza 2).

    Attributes
    ----------
    beacon : str
        ``"0"``, ``"1"``, ``"5"``, ``"6"`` or ``"all"``.
    period : float or None
        The range period [s] (None: every range).
    states : str
        The states estimated beyond :math:`[x, y, \\theta]`, one of ``GRID_STATES``.
    times : ndarray, shape (K,)
        Time since the start of the log [s], one epoch a second.
    truth : ndarray, shape (K, 2)
        The true track [m].
    dead_reckoning : ndarray, shape (K, 2)
        The odometry alone, integrated from the start [m].
    estimate : ndarray, shape (K, 2)
        The filter's track [m].
    error : ndarray, shape (K,)
        The filter's position error [m].
    error_rts : ndarray, shape (K,)
        The RTS smoother's position error [m].
    scale : ndarray, shape (K,)
        The scale estimate :math:`\\hat s_k` (NaN when the scale is not estimated).
    scale_sigma : ndarray, shape (K,)
        Its standard deviation.
    measured_scale : float
        The scale measured against the truth (least squares over every range).
    beacons : dict
        The positions of the beacons used, by id.
    all_beacons : dict
        The positions of all four.
    summary : dict
        The filter's RMSE, median, final error [m] and fraction within 2 m, over every epoch.
    rts_rmse : float
        The smoother's RMSE [m].

    Examples
    --------
    >>> # read from the committed runs on Plaza 2
    >>> view = real_data_view(beacon="5")
    >>> view.times.shape, view.estimate.shape, sorted(view.beacons)
    ((410,), (410, 2), [5])
    """

    beacon: str
    period: float | None
    states: str
    times: np.ndarray
    truth: np.ndarray
    dead_reckoning: np.ndarray
    estimate: np.ndarray
    error: np.ndarray
    error_rts: np.ndarray
    scale: np.ndarray
    scale_sigma: np.ndarray
    measured_scale: float
    beacons: dict[int, tuple[float, float]]
    all_beacons: dict[int, tuple[float, float]]
    summary: dict[str, float]
    rts_rmse: float


def real_data_view(beacon: str = "5", period: float | None = None, states: str = "+ scale and gyro bias",
                   study: RealDataStudy | None = None) -> RealDataView:
    """The committed run of ``navigate`` on Plaza 2 for a beacon (``"all"`` for four), a range period and the
    estimated states (``study``: the committed one by default).

    Examples
    --------
    >>> full = real_data_view(beacon="5", states="+ scale and gyro bias")
    >>> pose = real_data_view(beacon="5", states="pose only")
    >>> # estimating the odometry's scale pays
    >>> round(full.summary["rmse"], 1), round(pose.summary["rmse"], 1)
    (2.4, 24.0)
    >>> (bool(abs(full.scale[-1] - full.measured_scale) < 0.01),
    ...  bool(full.rts_rmse < full.summary["rmse"]))
    (True, True)
    >>> round(real_data_view(beacon="all").summary["rmse"], 1)      # four beacons
    0.3
    """
    s = load_real_data_study() if study is None else study
    if not isinstance(study, (RealDataStudy, type(None))):
        raise TypeError(f"study must be a RealDataStudy (load_real_data_study()) or None; got {type(study).__name__}")
    if not isinstance(beacon, str) or beacon not in GRID_BEACONS:
        raise ValueError(f"beacon must be one of {list(GRID_BEACONS)} (strings); got {beacon!r}")
    if period is not None and (isinstance(period, (bool, np.bool_)) or not isinstance(period, (int, float, np.number))
                               or not np.isreal(period)):
        raise TypeError(f"period must be None or one of {list(GRID_PERIODS[1:])} seconds; got {period!r}")
    if period not in GRID_PERIODS:
        raise ValueError(f"period must be one of {list(GRID_PERIODS)} (seconds; None for every range); got {period!r}")
    if not isinstance(states, str) or states not in GRID_STATES:
        raise ValueError(f"states must be one of {list(GRID_STATES)}; got {states!r}")
    i, j, k = GRID_BEACONS.index(beacon), GRID_PERIODS.index(period), GRID_STATES.index(states)
    g = s.grid
    c = {name: np.asarray(values[i, j, k], dtype=float) for name, values in g["curves"].items()}
    m = {name: float(values[i, j, k]) for name, values in g["measures"].items()}
    used = g["beacons"] if beacon == "all" else {int(beacon): g["beacons"][int(beacon)]}
    t = np.asarray(g["times"], dtype=float)
    return RealDataView(beacon=beacon, period=period, states=states, times=t - t[0],
                        truth=np.asarray(g["truth"])[:, :2], dead_reckoning=np.asarray(g["dead_reckoning"])[:, :2],
                        estimate=c["xy"], error=c["error"], error_rts=c["error_rts"], scale=c["scale"],
                        scale_sigma=c["scale_sigma"], measured_scale=float(s.info["scale"]["Plaza 2"]),
                        beacons=dict(used), all_beacons=dict(g["beacons"]),
                        summary={key: m[f"filter_{key}"] for key in ("rmse", "median", "final", "within")},
                        rts_rmse=m["smoother_rmse"])


def plot_real_data_view(view: RealDataView, fig: Figure | None = None) -> Figure:
    """The track against the truth and the odometry (left), the error over time (top right) and the scale estimate
    with its one-sigma band (bottom right).

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> fig = plot_real_data_view(real_data_view())
    >>> # the tracks, the error over time, the scale estimate
    >>> len(fig.axes) >= 3
    True
    >>> plt.close(fig)
    """
    fig = fig or plt.figure(figsize=(7.8, 3.9))
    # fixed margins, no tight_layout: it measures every tick label, most of the time of a redraw
    grid = fig.add_gridspec(2, 2, width_ratios=(1.0, 1.25), left=0.085, right=0.78, bottom=0.2, top=0.92,
                            wspace=0.3, hspace=0.18)
    ax_t = fig.add_subplot(grid[:, 0])
    ax_e = fig.add_subplot(grid[0, 1])
    ax_s = fig.add_subplot(grid[1, 1], sharex=ax_e)
    ax_t.plot(*view.dead_reckoning.T, color="0.6", lw=0.8, label="odometry alone")
    ax_t.plot(*view.truth.T, color="k", lw=1.0, label="truth")
    (track,) = ax_t.plot(*view.estimate.T, color="C3", lw=1.0, label="filter")
    marks = {}
    for ident, (bx, by) in view.all_beacons.items():
        used = ident in view.beacons
        marks[ident] = (ax_t.plot(bx, by, "^", color="C0" if used else "0.7", ms=7 if used else 5, zorder=4)[0],
                        ax_t.annotate(str(ident), (bx, by), xytext=(4, 4), textcoords="offset points", fontsize=7,
                                      color="C0" if used else "0.5"))
    ax_t.set_aspect("equal", adjustable="datalim")
    ax_t.set_xlabel("x [m]")
    ax_t.set_ylabel("y [m]")
    ax_t.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=3, frameon=False)
    (error,) = ax_e.semilogy(view.times, np.maximum(view.error, 1e-3), color="C3", lw=0.9, label="filter")
    (error_rts,) = ax_e.semilogy(view.times, np.maximum(view.error_rts, 1e-3), color="C2", lw=0.9,
                                 label="RTS smoother")
    ax_e.set_ylim(0.05, 300.0)
    ax_e.yaxis.set_minor_locator(NullLocator())          # major ticks only: a redraw is mostly tick objects
    ax_e.set_ylabel("error [m]")
    ax_e.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.0, 1.0), frameon=False)
    ax_e.tick_params(labelbottom=False)
    # the band, the estimate, the note and both legends are made whatever the states, and shown or hidden: an
    # update then switches the scale on or off in place (a scale of NaN, not estimated, draws nothing)
    band = ax_s.fill_between(view.times, view.scale - view.scale_sigma, view.scale + view.scale_sigma,
                             color="C0", alpha=0.25, lw=0)
    (scale,) = ax_s.plot(view.times, view.scale, color="C0", lw=1.0, label="estimate ± σ")
    note = ax_s.text(0.5, 0.5, "scale not estimated (taken as 1)", transform=ax_s.transAxes, ha="center",
                     va="center", fontsize=8, color="0.4")
    measured = ax_s.axhline(view.measured_scale, color="k", ls="--", lw=1.0, label="measured on the truth")
    ax_s.set_ylim(0.95, 1.15)
    ax_s.set_xlabel("time since the start [s]")
    ax_s.set_ylabel("range scale s")
    style: dict[str, Any] = dict(fontsize=7, loc="upper left", bbox_to_anchor=(1.0, 1.0), frameon=False)
    plain = ax_s.legend(handles=[measured], **style)
    ax_s.add_artist(plain)              # kept when the next call makes the full legend the axes' own
    full = ax_s.legend(handles=[scale, measured], **style)
    legends = (full, plain)
    _show_scale(np.isfinite(view.scale).any(), note, legends)
    _real_data_titles(view, ax_t, ax_e)
    return keep(fig, track=track, marks=marks, error=error, error_rts=error_rts, band=band, scale=scale, note=note,
                legends=legends)


def _show_scale(estimated: bool, note: Any, legends: tuple[Any, Any]) -> list[Any]:
    """Show the scale's legend entry, or the note that it is not estimated; returns the artists switched."""
    note.set_visible(not estimated)
    legends[0].set_visible(estimated)
    legends[1].set_visible(not estimated)
    return [note, *legends]


def _real_data_titles(view: RealDataView, ax_t: Any, ax_e: Any) -> list[Any]:
    period = PERIOD_LABELS.get(view.period, f"{view.period} s")
    who = "4 beacons" if view.beacon == "all" else f"beacon {view.beacon}"
    ax_t.set_title(f"{who}, {period}", fontsize=8)
    ax_e.set_title(f"{view.states}: RMSE {view.summary['rmse']:.2f} m (RTS {view.rts_rmse:.2f} m), "
                   f"{100 * view.summary['within']:.0f} % within 2 m", fontsize=8)
    return [ax_t.title, ax_e.title]


def update_real_data_view(fig: Figure, view: RealDataView) -> list[Any] | None:
    """Put another ``RealDataView`` into a figure drawn by ``plot_real_data_view``; returns what changed (the scale
    panel's band, estimate, note and legends among them: the scale starts or stops being estimated in place).
    ``None`` (draw anew) for a study with other beacons."""
    a = kept(fig)
    if a is None:                   # not a figure the plot function drew: draw it anew
        return None
    if set(a["marks"]) != set(view.all_beacons):
        return None
    ax_t, ax_e, ax_s = fig.axes[:3]
    a["track"].set_data(*view.estimate.T)
    changed = [a["track"]]
    for ident, (mark, label) in a["marks"].items():
        used = ident in view.beacons
        mark.set(color="C0" if used else "0.7", markersize=7 if used else 5)
        label.set_color("C0" if used else "0.5")
        changed += [mark, label]
    a["error"].set_data(view.times, np.maximum(view.error, 1e-3))
    a["error_rts"].set_data(view.times, np.maximum(view.error_rts, 1e-3))
    changed += [a["error"], a["error_rts"]]
    a["band"].remove()
    a["band"] = ax_s.fill_between(view.times, view.scale - view.scale_sigma, view.scale + view.scale_sigma,
                                  color="C0", alpha=0.25, lw=0)
    a["scale"].set_data(view.times, view.scale)
    changed += [a["band"], a["scale"], *_show_scale(np.isfinite(view.scale).any(), a["note"], a["legends"])]
    rescale(ax_t)
    return changed + _real_data_titles(view, ax_t, ax_e)


def real_data_widget(study: RealDataStudy | None = None) -> Any:
    """Beacon, range period and estimated states over the committed runs (``study``: the committed one).

    Examples
    --------
    >>> panel = real_data_widget()
    >>> [c.description for c in panel.children[0].children]
    ['beacon', 'ranges', 'states']
    """
    import ipywidgets as w

    s = load_real_data_study() if study is None else study
    style = {"description_width": "initial"}
    controls = {
        "beacon": w.Dropdown(options=list(GRID_BEACONS), value="5", description="beacon", style=style),
        # "every" stands for None, which a Dropdown takes for "nothing chosen" (it would show an empty box)
        "period": w.Dropdown(options=[(PERIOD_LABELS[p], "every" if p is None else p) for p in GRID_PERIODS],
                             value="every",
                             description="ranges", style=style),
        "states": w.Dropdown(options=list(GRID_STATES), value="+ scale and gyro bias", description="states",
                             style=style),
    }

    @functools.lru_cache(maxsize=128)
    def view(beacon: str, period: float | Literal["every"], states: str) -> RealDataView:
        return real_data_view(beacon, None if isinstance(period, str) else period, states, study=s)

    return slider_panel(controls, lambda fig, **p: plot_real_data_view(view(**p), fig),
                        lambda fig, **p: update_real_data_view(fig, view(**p)))


#: Zero-argument callables running each widget's computation at its defaults (wired into the registry).
COMPUTE_FUNCTIONS: dict[str, Callable[[], Any]] = {
    "ch11 real data": real_data_view,
}
