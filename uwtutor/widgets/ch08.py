r"""Chapter 8 widget: paper B's cooperative EKF for a leader pattern, a current, an update interval and a packet-loss
rate, with paper B's tuning or the matched one."""

from __future__ import annotations

import functools
import warnings
from dataclasses import dataclass
from typing import Any, Callable

import matplotlib.pyplot as plt
from matplotlib.figure import Figure
import numpy as np

from .._validate import as_finite, as_int
from ..errors import UnobservableWarning
from ..filters.cooperative import cooperative_ekf
from ..plotting import plot_track
from ..scenarios import paper_b
from ._panel import keep, kept, rescale, slider_panel

__all__ = ["CooperativeView", "cooperative_view", "plot_cooperative_view", "cooperative_widget", "COMPUTE_FUNCTIONS",
           "TUNINGS"]

#: The filter tunings the widget offers.
TUNINGS = ("paper B", "matched")
#: A run has lost the track when its position error exceeds this after ``LOST_AFTER`` seconds [m].
LOST_ERROR = 200.0
#: ... [s].
LOST_AFTER = 800.0
#: The summaries use the epochs of the last this many seconds [s].
LATE_WINDOW = 1000.0


@dataclass(frozen=True)
class CooperativeView:
    r"""What the chapter-8 widget shows for one setting (returned by ``cooperative_view``).

    Shapes: ``K`` filter steps (epochs 1..K), ``K + 1`` epochs.

    Attributes
    ----------
    pattern : str
        Leader pattern.
    tuning : str
        Filter tuning.
    current : tuple of float
        True current [m/s].
    interval : float
        :math:`\delta t` [s].
    packet_loss : float
        Probability that a message is lost.
    n_runs : int
        Monte Carlo runs behind the error curves.
    times : ndarray, shape (K,)
        Times of the estimates [s].
    truth : ndarray, shape (K + 1, 2)
        The follower's true track [m].
    leader : ndarray, shape (K + 1, 2)
        The leader's track [m].
    dr : ndarray, shape (K + 1, 2)
        Run 0's DR track [m].
    estimate : ndarray, shape (K, 2)
        Run 0's estimated track [m].
    current_estimate : ndarray, shape (K, 2)
        Run 0's current estimate [m/s].
    current_sigma : ndarray, shape (K, 2)
        Its standard deviations [m/s].
    median_error : ndarray, shape (K,)
        Median position error over the runs at each epoch [m].
    late_median_error : float
        Median position error over the runs and the last ``LATE_WINDOW`` seconds [m].
    lost_fraction : float
        Fraction of runs with an error above ``LOST_ERROR`` after ``LOST_AFTER`` seconds.
    unobservable : bool
        Whether the filter emitted an ``UnobservableWarning`` (the relative track is straight); always False in a
        partial view (``epochs_run``), which cannot judge the whole track.
    epochs_run : int or None, default None
        ``None``: the filter ran over all K steps. Otherwise it ran over the first ``epochs_run`` steps only (the
        widget's first answer for a new setting), which are those of the full run: the estimates and the median
        error are NaN after them, and ``late_median_error`` and ``lost_fraction`` are NaN (the tracks are whole).

    Examples
    --------
    >>> view = cooperative_view(n_runs=5, seed=0)
    >>> # K filter steps, K + 1 epochs
    >>> view.times.shape, view.truth.shape, view.current_estimate.shape
    ((312,), (313, 2), (312, 2))
    """

    pattern: str
    tuning: str
    current: tuple[float, float]
    interval: float
    packet_loss: float
    n_runs: int
    times: np.ndarray
    truth: np.ndarray
    leader: np.ndarray
    dr: np.ndarray
    estimate: np.ndarray
    current_estimate: np.ndarray
    current_sigma: np.ndarray
    median_error: np.ndarray
    late_median_error: float
    lost_fraction: float
    unobservable: bool
    epochs_run: int | None = None


@functools.lru_cache(maxsize=16)
def _scenario(params: Any, M: int, seed: int) -> Any:
    """Paper B's runs for these parameters (the tuning does not enter): kept for the widget's next setting."""
    return paper_b.make(np.random.default_rng(seed), M, params)


def cooperative_view(pattern: str = "zigzag", current: float = 0.7071, interval: float = 8.0,
                     packet_loss: float = 0.0, tuning: str = "matched", n_runs: int = 100,
                     seed: int = 0) -> CooperativeView:
    r"""Run paper B's cooperative EKF (consistent pair) on ``n_runs`` runs of its scenario.

    Parameters
    ----------
    pattern : {"zigzag", "parallel", "circling"}, default "zigzag"
        The leader's track (``paper_b.LEADER_PATTERNS``).
    current : float, default 0.7071
        Speed of the current towards the north-east [m/s], between 0 and 2 (paper B: 0.5 m/s in each axis).
    interval : float, default 8
        Update interval :math:`\delta t` [s], a whole number of seconds between 1 and 60.
    packet_loss : float, default 0
        Probability that a message is lost, in [0, 0.9].
    tuning : {"matched", "paper B"}, default "matched"
        ``paper_b.matched_tuning`` or ``paper_b.paper_tuning``.
    n_runs : int, default 100
        Monte Carlo runs (>= 1).
    seed : int, default 0
        Seed of the scenario.

    Returns
    -------
    CooperativeView

    Examples
    --------
    >>> import numpy as np
    >>> zigzag = cooperative_view(pattern="zigzag", n_runs=5, seed=0)
    >>> zigzag.unobservable, zigzag.lost_fraction, bool(zigzag.late_median_error < 20.0)
    (False, 0.0, True)
    >>> # the current is found
    >>> bool(np.allclose(zigzag.current_estimate[-1], zigzag.current, atol=0.05))
    True
    >>> # a straight relative track
    >>> parallel = cooperative_view(pattern="parallel", n_runs=5, seed=0)
    >>> (parallel.unobservable,
    ...  bool(parallel.late_median_error > 10.0 * zigzag.late_median_error))
    (True, True)
    """
    if pattern not in paper_b.LEADER_PATTERNS:
        raise ValueError(f"pattern must be one of {paper_b.LEADER_PATTERNS}; got {pattern!r}")
    if tuning not in TUNINGS:
        raise ValueError(f"tuning must be one of {TUNINGS}; got {tuning!r}")
    speed = float(as_finite("current", current, ndim=0))
    if not 0.0 <= speed <= 2.0:
        raise ValueError(f"current must lie between 0 and 2 m/s; got {speed:g}")
    dt = float(as_finite("interval", interval, ndim=0))
    if not (1.0 <= dt <= 60.0 and dt == round(dt)):
        raise ValueError(f"interval must be a whole number of seconds between 1 and 60; got {dt:g}")
    loss = float(as_finite("packet_loss", packet_loss, ndim=0))
    if not 0.0 <= loss <= 0.9:
        raise ValueError(f"packet_loss must lie between 0 and 0.9; got {loss:g}")
    M = as_int("n_runs", n_runs, minimum=1)
    seed = as_int("seed", seed, minimum=0)
    return _view(pattern, speed, dt, loss, tuning, M, seed)


def _view(pattern: str, speed: float, dt: float, loss: float, tuning: str, M: int, seed: int,
          epochs: int | None = None) -> CooperativeView:
    """``cooperative_view`` on checked arguments, with the filter run over its first ``epochs`` steps only
    (``None``: all). An EKF's estimate at a step depends on the steps up to it only, so those steps are the full
    run's."""
    U = (speed / np.sqrt(2.0), speed / np.sqrt(2.0))
    params = paper_b.PaperBParameters(leader_pattern=pattern, current=U, interval=dt, packet_loss=loss)
    sc = _scenario(params, M, seed)
    tune = paper_b.paper_tuning(params) if tuning == "paper B" else paper_b.matched_tuning(params)
    t = sc.times[1:]
    K = len(t)
    if epochs is not None and epochs >= K:          # a long δt: the whole run is no longer than the first steps
        epochs = None
    n = K if epochs is None else epochs             # the filter steps run, over n + 1 ranging epochs
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UnobservableWarning)
        res = cooperative_ekf(params.x1, tune.P1, sc.dr_displacements[:, :n], sc.ranges[:, :n + 1], tune.Q, tune.R,
                              t[:n], leader=sc.leader_broadcast[:, :n + 1], dt=dt)
    # the warning judges the whole relative track: a partial run's first steps cannot tell (a zigzag's first leg is
    # straight), so a partial view makes no claim
    unobservable = epochs is None and any(issubclass(w.category, UnobservableWarning) for w in caught)
    err = np.linalg.norm(res.x[..., :2] - sc.true_positions[1:n + 1], axis=-1)
    estimate, current_estimate, current_sigma = (np.full((K, 2), np.nan) for _ in range(3))
    median_error = np.full(K, np.nan)
    estimate[:n] = res.x[0, :, :2]
    current_estimate[:n] = res.x[0, :, 2:]
    current_sigma[:n] = np.sqrt(np.diagonal(res.P[0], axis1=-2, axis2=-1)[:, 2:])
    median_error[:n] = np.median(err, axis=0)
    if epochs is None:
        late = t >= t[-1] - LATE_WINDOW
        lost = np.max(err[:, t > LOST_AFTER], axis=1, initial=0.0) > LOST_ERROR
        late_median, lost_fraction = float(np.median(err[:, late])), float(np.mean(lost))
    else:
        late_median = lost_fraction = float("nan")
    return CooperativeView(pattern=pattern, tuning=tuning, current=U, interval=dt, packet_loss=loss, n_runs=M,
                           times=np.array(t), truth=np.array(sc.true_positions), leader=np.array(sc.leader_positions),
                           dr=np.array(sc.dr_positions[0]), estimate=estimate, current_estimate=current_estimate,
                           current_sigma=current_sigma, median_error=median_error, late_median_error=late_median,
                           lost_fraction=lost_fraction, unobservable=unobservable, epochs_run=epochs)


def plot_cooperative_view(view: CooperativeView, fig: Figure | None = None) -> Figure:
    """Draw a ``CooperativeView``: the tracks of run 0, its current estimate with ±2σ, and the median position
    error over the runs.

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> fig = plot_cooperative_view(cooperative_view(n_runs=5))
    >>> # the tracks, the current estimate, the median error
    >>> len(fig.axes)
    3
    >>> plt.close(fig)
    """
    fig = fig or plt.figure(figsize=(7.8, 3.2))
    grid = fig.add_gridspec(2, 2, width_ratios=(1.3, 1.0))
    ax_map = fig.add_subplot(grid[:, 0])
    ax_cur = fig.add_subplot(grid[0, 1])
    ax_err = fig.add_subplot(grid[1, 1], sharex=ax_cur)
    plot_track(ax_map, view.leader, label="leader", color="C3", lw=0.8)
    plot_track(ax_map, view.truth, label="follower", color="black", lw=1.2)
    plot_track(ax_map, view.estimate, label="estimate (run 0)", color="C1", lw=1)
    plot_track(ax_map, view.dr, label="DR only", color="C0", ls="--", lw=1)
    tracks = ax_map.lines[-8:]
    ax_map.legend(fontsize=6, loc="upper left")
    t = view.times
    bands, currents, truths = [], [], []
    for i, (name, color) in enumerate((("U_x", "C0"), ("U_y", "C3"))):
        est, sig = view.current_estimate[:, i], view.current_sigma[:, i]
        bands.append(ax_cur.fill_between(t, est - 2 * sig, est + 2 * sig, color=color, alpha=0.2))
        currents += ax_cur.plot(t, est, color=color, lw=1, label=name)
        truths.append(ax_cur.axhline(view.current[i], color=color, ls=":", lw=1))
    ax_cur.set_ylim(min(view.current) - 1.0, max(view.current) + 1.0)
    ax_cur.set_ylabel("current [m/s]", fontsize=8)
    ax_cur.legend(fontsize=6, ncol=2)
    (median,) = ax_err.semilogy(t, np.maximum(view.median_error, 1e-2), color="C1", lw=1)
    ax_err.set_ylabel("median error [m]", fontsize=8)
    _plain_log_labels(ax_err.yaxis)
    ax_err.set_xlabel("time [s]")
    _cooperative_titles(view, ax_map, ax_err)
    fig.tight_layout()
    # the time axis fixed where autoscaling put it: a partial view (``epochs_run``) must not shrink it to its data;
    # update_cooperative_view moves it when the run's times no longer fit
    ax_err.set_xlim(ax_err.get_xlim())
    return keep(fig, tracks=tracks, bands=bands, currents=currents, truths=truths, median=median)


def _plain_log_labels(axis: Any) -> None:
    """Label a log axis at 1, 2 and 5 times the powers of ten, in plain numbers (``50``, ``100``, ``200``), and leave
    its minor ticks unlabelled: wherever the limits go as the widget's settings change, the labels stay short
    (matplotlib's default labels the minor ticks ``2×10²``, ``3×10²``... of an axis that spans less than a decade,
    wide enough to crowd the axis label)."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    # ticks at 1, 2 and 5 in every decade (numticks: matplotlib's locator drops ticks with subs altogether when it
    # would skip decades); over more than two decades only the powers of ten are labelled, so the labels do not crowd
    axis.set_major_locator(LogLocator(base=10.0, subs=(1.0, 2.0, 5.0), numticks=30))

    def label(value: float, _pos: Any) -> str:
        low, high = sorted(axis.get_view_interval())
        wide = low > 0 and np.log10(high / low) > 2.0
        return "" if wide and not np.isclose(10.0 ** np.round(np.log10(value)), value) else f"{value:g}"

    axis.set_major_formatter(FuncFormatter(label))
    axis.set_minor_formatter(NullFormatter())
    axis.set_tick_params(labelsize=8)


def _cooperative_titles(view: CooperativeView, ax_map: Any, ax_err: Any) -> list[Any]:
    warn = ", UNOBSERVABLE" if view.unobservable else ""
    ax_map.set_title(f"leader {view.pattern}, {view.tuning} tuning{warn}", fontsize=8)
    if view.epochs_run is None:
        ax_err.set_title(f"{view.n_runs} runs, {100 * view.lost_fraction:.0f} % lost; last {LATE_WINDOW:.0f} s: "
                         f"{view.late_median_error:.1f} m", fontsize=7)
    else:                               # the widget's first answer: says how far the filter has run
        ax_err.set_title(f"{view.n_runs} runs, first {view.times[view.epochs_run - 1]:.0f} s of "
                         f"{view.times[-1]:.0f} s…", fontsize=7)
    return [ax_map.title, ax_err.title]


def update_cooperative_view(fig: Figure, view: CooperativeView) -> list[Any] | None:
    """Put another ``CooperativeView`` into a figure drawn by ``plot_cooperative_view``; returns what changed."""
    a = kept(fig)
    if a is None:                                   # not a figure plot_cooperative_view drew: draw it anew
        return None
    ax_map, ax_cur, ax_err = fig.axes[:3]
    for (line, dot), track in zip(zip(a["tracks"][::2], a["tracks"][1::2]),
                                  (view.leader, view.truth, view.estimate, view.dr)):
        line.set_data(track[:, 0], track[:, 1])
        dot.set_data([track[0, 0]], [track[0, 1]])
    t = view.times
    for i, color in enumerate(("C0", "C3")):
        est, sig = view.current_estimate[:, i], view.current_sigma[:, i]
        a["bands"][i].remove()
        a["bands"][i] = ax_cur.fill_between(t, est - 2 * sig, est + 2 * sig, color=color, alpha=0.2)
        a["currents"][i].set_data(t, est)
        a["truths"][i].set_ydata([view.current[i], view.current[i]])
    low, high = min(view.current) - 1.0, max(view.current) + 1.0
    now_low, now_high = ax_cur.get_ylim()
    if not (now_low <= low and high <= now_high):       # kept while the band fits, with room when it moves
        ax_cur.set_ylim(low - 0.3, high + 0.3)
    a["median"].set_data(t, np.maximum(view.median_error, 1e-2))
    t_low, t_high = ax_err.get_xlim()
    if not (t_low <= t[0] and t[-1] <= t_high and t[-1] - t[0] >= 0.5 * (t_high - t_low)):
        margins = ax_err.margins()                          # (no argument: it reads them)
        assert margins is not None                          # (margins() without arguments returns them)
        margin = margins[0] * (t[-1] - t[0])                 # as autoscaling placed them at the first drawing
        ax_err.set_xlim(t[0] - margin, t[-1] + margin)
    rescale(ax_map)
    # kept while the median error fits (the widget gives the axis room for most settings), refitted when it does not
    rescale(ax_err, keep_within=0.0)
    return [*a["tracks"], *a["bands"], *a["currents"], *a["truths"], a["median"],
            *_cooperative_titles(view, ax_map, ax_err)]


def cooperative_widget() -> Any:
    """Leader pattern, current, update interval, packet loss and tuning over the view.

    Examples
    --------
    >>> panel = cooperative_widget()
    >>> [c.description for row in panel.children[:2] for c in row.children]
    ['leader', 'current [m/s]', 'δt [s]', 'packet loss', 'tuning']
    """
    import ipywidgets as w

    style = {"description_width": "initial"}
    sliders = {
        "pattern": w.Dropdown(options=list(paper_b.LEADER_PATTERNS), value="zigzag", description="leader",
                              style=style),
        "current": w.FloatSlider(value=0.7071, min=0.0, max=1.5, step=0.1, description="current [m/s]",
                                 continuous_update=False, style=style),
        "interval": w.IntSlider(value=8, min=2, max=32, step=2, description="δt [s]", continuous_update=False,
                                style=style),
        "packet_loss": w.FloatSlider(value=0.0, min=0.0, max=0.8, step=0.1, description="packet loss",
                                     continuous_update=False, style=style),
        "tuning": w.Dropdown(options=list(TUNINGS), value="matched", description="tuning", style=style),
    }
    # 30 runs per setting rather than the chapter's 100 (the figure's title says how many): the median error and the
    # lost share keep their story and a move costs less than half the time
    view = functools.lru_cache(maxsize=256)(functools.partial(cooperative_view, n_runs=WIDGET_RUNS))
    full: dict[tuple[Any, ...], CooperativeView] = {}   # the full answers computed, by setting (as view's cache)

    def answer(coarse: bool, **p: Any) -> CooperativeView:
        key = tuple(p.values())
        if key in full or not coarse:
            return full.setdefault(key, view(**p))
        # the same runs over their first steps at once: the same numbers as the full answer there
        return _early_view(**p)

    def refine(**p: Any) -> Callable[[], Any] | None:
        return None if tuple(p.values()) in full else functools.partial(answer, False, **p)

    def draw(fig: Figure, coarse: bool, **p: Any) -> Any:
        fig = plot_cooperative_view(answer(coarse, **p), fig)
        _room_for_every_setting(fig, sliders["current"].max)
        return fig

    return slider_panel(sliders, draw, lambda fig, coarse, **p: update_cooperative_view(fig, answer(coarse, **p)),
                        refine=refine)


def _room_for_every_setting(fig: Figure, max_current: float) -> None:
    """Give the widget's axes limits that most settings fit in, so that a move redraws no axes (their pixels are
    kept, see ``_panel.BlitRenderer``): the map holds, unseen, the tracks of every leader pattern with and without
    the strongest current (``update_cooperative_view`` keeps limits while the data fits them); the current axes the
    ±1 m/s band of any current of the slider; the median error 1 m to 5 km (the worst settings reach about 3 km)."""
    from matplotlib.lines import Line2D

    ax_map, ax_cur, ax_err = fig.axes[:3]
    corners = []
    for pattern in paper_b.LEADER_PATTERNS:
        for speed in (0.0, max_current):
            U = (speed / np.sqrt(2.0), speed / np.sqrt(2.0))
            sc = _scenario(paper_b.PaperBParameters(leader_pattern=pattern, current=U), 1, 0)
            for track in (sc.true_positions, sc.leader_positions):
                corners += [track.min(axis=0), track.max(axis=0)]
    low, high = np.min(corners, axis=0), np.max(corners, axis=0)
    # with a tenth of the span on each side for the estimates, which can stray outside the true tracks
    box = np.array([low - 0.1 * (high - low), high + 0.1 * (high - low)])
    # an invisible artist: it counts in the map's data limits at every refit but draws nothing
    ax_map.add_line(Line2D(box[:, 0], box[:, 1], visible=False))
    ax_map.relim()
    ax_map.autoscale_view()
    ax_cur.set_ylim(-1.0, max_current / np.sqrt(2.0) + 1.0)
    ax_err.set_ylim(1.0, 5000.0, auto=None)


#: Monte Carlo runs per setting of the widget (the compute function's default, used by the chapter, is 100).
WIDGET_RUNS = 30
#: Filter steps the widget's first answer for a new setting runs (of the 312 at δt = 8 s; fewer at a longer δt),
#: while the full answer is computed in the background: about an eighth of its time.
EARLY_STEPS = 40


def _early_view(pattern: str, current: float, interval: float, packet_loss: float, tuning: str) -> CooperativeView:
    """The widget's view over its first ``EARLY_STEPS`` filter steps (its coarse answer; arguments as checked by
    ``cooperative_view``, which the full answer has run or will run on the same values)."""
    return _view(pattern, float(current), float(interval), float(packet_loss), tuning, WIDGET_RUNS, 0, EARLY_STEPS)


#: Zero-argument callables running each widget's computation at its defaults (wired into the registry).
COMPUTE_FUNCTIONS: dict[str, Callable[[], Any]] = {
    "ch08 cooperative EKF": cooperative_view,
}
