"""Chapter 7 widget: paper A's IEKF started by pre-positioning, with a drifting bias, an initial error and the
precision-factor threshold."""

from __future__ import annotations

import functools
from dataclasses import dataclass, replace
from typing import Any, Callable

import matplotlib.pyplot as plt
from matplotlib.figure import Figure
import numpy as np

from .._validate import as_int, as_scalar, as_seed, check_work
from ..filters import bias_ekf
from ..pipelines import prepositioned_bias_ekf
from ..models import paper_a_process_noise
from ..plotting import legend_below, mark_beacon, plain_log_ticks
from ..scenarios import paper_a
from ._panel import keep, kept, rescale, slider_panel

__all__ = ["BiasTrackingView", "bias_tracking_view", "plot_bias_tracking_view", "bias_tracking_widget",
           "COMPUTE_FUNCTIONS"]


@dataclass(frozen=True)
class BiasTrackingView:
    r"""A Monte Carlo study of paper A's IEKF, started by pre-positioning and, for contrast, from a bad guess.

    Attributes
    ----------
    drift_rate : float
        Bias ramp added to the paper's range error [m/s].
    initial_error : float
        Distance of the provisional start from the truth [m].
    max_alpha : float
        Precision-factor threshold of the pre-positioning.
    times : ndarray, shape (K,)
        Epoch times [s].
    truth : ndarray, shape (K, 2)
        True track [m].
    estimate : ndarray, shape (K, 3)
        Run 0: the pre-positioned IEKF's ``[x, y, bias]`` (NaN before its start).
    bias_sigma : ndarray, shape (K,)
        Run 0: the filter's standard deviation of the bias [m].
    true_bias : ndarray, shape (K,)
        Run 0: the true slowly varying bias [m].
    start_epochs : ndarray of int, shape (M,)
        The epoch at which each run's filter started (:math:`\alpha <` ``max_alpha``).
    rmse : ndarray, shape (K,)
        RMS position error over the runs, pre-positioned IEKF (NaN until every run has started) [m].
    rmse_unstarted : ndarray, shape (K,)
        The same for the IEKF started at epoch 0 from the provisional start with paper A's :math:`P_0 = I`.
    final_rmse : float
        RMS position error over the last 500 epochs, pre-positioned IEKF [m].
    n_runs : int
        Number of runs.
    epochs_run : int or None
        ``None``: the filters ran over every epoch. Otherwise the pre-positioned IEKF ran over the first
        ``epochs_run`` epochs only (the widget's first answer for a new setting, while the rest is computed): its
        arrays and ``true_bias`` are those of the full run there and NaN after, ``final_rmse`` is NaN, and
        ``start_epochs`` is ``len(times)`` for a run not started by then; ``rmse_unstarted`` is the same, or whole
        when it was at hand (it does not depend on the α threshold).

    Examples
    --------
    >>> # fewer runs and ranges than the chapter's
    >>> view = bias_tracking_view(n_runs=4, n_obs=600, seed=0)
    >>> # [x, y, bias] of run 0; a start per run
    >>> view.times.shape, view.estimate.shape, view.start_epochs.shape
    ((600,), (600, 3), (4,))
    """

    drift_rate: float
    initial_error: float
    max_alpha: float
    times: np.ndarray
    truth: np.ndarray
    estimate: np.ndarray
    bias_sigma: np.ndarray
    true_bias: np.ndarray
    start_epochs: np.ndarray
    rmse: np.ndarray
    rmse_unstarted: np.ndarray
    final_rmse: float
    n_runs: int
    epochs_run: int | None = None


@functools.lru_cache(maxsize=4)
def _scenario(M: int, K: int, seed: int) -> tuple[Any, Any, np.ndarray, np.ndarray]:
    """Paper A's runs and the unit directions of the start errors: what ``bias_tracking_view`` draws that no slider
    changes (kept for the widget's next setting; never modified)."""
    rng = np.random.default_rng(seed)
    params = replace(paper_a.PaperAParameters(), n_obs=K)
    sc, bias = paper_a.make_with_truth(rng, M, params)
    direction = rng.normal(size=(M, 2))
    return params, sc, bias, direction / np.linalg.norm(direction, axis=1, keepdims=True)


#: The curves of ``_from_the_start`` computed, by arguments (the last 64).
_CURVES: dict[tuple[Any, ...], np.ndarray] = {}


def _from_the_start(rate: float, d0: float, M: int, K: int, seed: int, epochs: int | None = None) -> np.ndarray:
    """The RMSE per epoch of the IEKF started at epoch 0 from the provisional start (no pre-positioning: the α
    threshold does not enter), over the first ``epochs`` epochs (``None``: all); the curve only is kept, not the
    filter's result (the cache holds the last 64)."""
    key = (rate, d0, M, K, seed, epochs)
    if key not in _CURVES:
        curve = _run_from_the_start(rate, d0, M, K, seed, epochs)
        if len(_CURVES) >= 64:
            _CURVES.pop(next(iter(_CURVES)), None)
        _CURVES[key] = curve
    return _CURVES[key]


def _run_from_the_start(rate: float, d0: float, M: int, K: int, seed: int, epochs: int | None) -> np.ndarray:
    params, sc, _, direction = _scenario(M, K, seed)
    n = slice(None, epochs)
    t = np.asarray(sc.times)[n]
    z = np.asarray(sc.ranges)[:, n] + rate * t
    truth = np.asarray(sc.true_positions[0])[n]
    start = truth[0] + d0 * direction
    plain = bias_ekf(np.column_stack([start, np.zeros(M)]), np.eye(3), np.asarray(sc.dr_displacements)[:, n], z,
                     paper_a_process_noise(params.dr_sigma), params.noise_variance, times=t, keep_priors=False)
    rmse: np.ndarray = np.sqrt(np.mean(np.sum((plain.x[..., :2] - truth) ** 2, axis=-1), axis=0))
    rmse.setflags(write=False)
    return rmse


def bias_tracking_view(drift_rate: float = 0.0, initial_error: float = 150.0, max_alpha: float = 2.0,
                       n_runs: int = 30, n_obs: int = 2000, seed: int = 0) -> BiasTrackingView:
    r"""Run paper A's simulation (``scenarios.paper_a``) with a bias ramp, and its IEKF two ways.

    The ranges get an extra bias :math:`\dot\upsilon\,t` (``drift_rate``) on top of paper A's error; the filter
    keeps paper A's :math:`\mathbf Q` rule (``models.paper_a_process_noise`` with the scenario's DR noise) and
    :math:`R = 5` m². One way it starts where pre-positioning first gives :math:`\alpha <` ``max_alpha``
    (``pipelines.prepositioned_bias_ekf``, :math:`P_0 = I`); the other way it starts at epoch 0 from the provisional
    position, ``initial_error`` metres from the truth in a random direction, with a zero bias and paper A's
    :math:`P_0 = I`.

    Parameters
    ----------
    drift_rate : float, default 0
        Bias ramp [m/s] (0.01 m/s: a 1 % sound-speed error while the range opens at 1 m/s), between -1 and 1;
        a falling bias must not make a range negative.
    initial_error : float, default 150
        Provisional start error [m], 0 to 1e6.
    max_alpha : float, default 2
        Pre-positioning threshold, > 0 and at most 1000.
    n_runs : int, default 30
        Monte Carlo runs, >= 2.
    n_obs : int, default 2000
        Number of ranges, >= 600.
    seed : int, default 0
        Seed of the scenario and the start errors.

    Returns
    -------
    BiasTrackingView

    Examples
    --------
    >>> import numpy as np
    >>> view = bias_tracking_view(initial_error=300.0, n_runs=5, n_obs=1000, seed=0)
    >>> # the IEKF from the bad guess
    >>> started_late = np.sqrt(np.mean(view.rmse_unstarted[-500:] ** 2))
    >>> # RMS error over the last 500 [m]
    >>> round(view.final_rmse), bool(started_late > 2.0 * view.final_rmse)
    (20, True)
    >>> # each run waits for alpha < 2 before the filter starts
    >>> bool(np.all(view.start_epochs > 0))
    True
    >>> miss = view.estimate[-1, 2] - view.true_bias[-1]
    >>> # the bias of run 0 tracked within 2 sigma
    >>> bool(abs(miss) < 2.0 * view.bias_sigma[-1])
    True
    """
    # a drift beyond 1 m/s (a sound-speed error of 100 % at 1 m/s of opening) or a start error beyond 1000 km is not
    # a sound-speed effect or a provisional start; a precision factor alpha above 1000 accepts a fix that is none
    rate = as_scalar("drift_rate", drift_rate, low=-1.0, high=1.0)
    d0 = as_scalar("initial_error", initial_error, low=0.0, high=1e6)
    a_max = as_scalar("max_alpha", max_alpha, domain="positive", high=1e3)
    M = as_int("n_runs", n_runs, minimum=2)
    K = as_int("n_obs", n_obs, minimum=600)
    check_work("n_runs", 20 * M * K, "floats (n_runs x n_obs x 20)")
    return _view(rate, d0, a_max, M, K, as_seed("seed", seed))


def _view(rate: float, d0: float, a_max: float, M: int, K: int, seed: int,
          epochs: int | None = None) -> BiasTrackingView:
    """``bias_tracking_view`` on checked arguments, with the filters run over the first ``epochs`` epochs only
    (``None``: all). A filter's estimate at an epoch depends on the epochs up to it only, so the first ``epochs``
    epochs are those of the full run (see ``BiasTrackingView.epochs_run``)."""
    params, sc, bias, direction = _scenario(M, K, seed)
    t = np.asarray(sc.times)
    z = np.asarray(sc.ranges) + rate * t
    if np.any(z < 0.0):
        k = int(np.argmax(np.any(z < 0.0, axis=0)))
        raise ValueError(f"drift_rate = {rate:g} m/s makes the measured range negative at {t[k]:g} s: a falling "
                         "bias cannot exceed the range (use a smaller drift, or fewer ranges n_obs)")
    true_bias = bias + rate * t
    truth = np.asarray(sc.true_positions[0])
    start = truth[0] + d0 * direction
    Q = paper_a_process_noise(params.dr_sigma)
    R = params.noise_variance
    n = slice(None, epochs)
    k_run = K if epochs is None else epochs
    pre = prepositioned_bias_ekf(start, np.eye(3), np.asarray(sc.dr_displacements)[:, n], z[:, n], Q, R,
                                 max_alpha=a_max, times=t[n])
    whole = (rate, d0, M, K, seed, None)
    # the whole curve when it is at hand (an α move), else over the same epochs as the pre-positioned IEKF
    rmse_plain = _CURVES[whole] if epochs is not None and whole in _CURVES else \
        _from_the_start(rate, d0, M, K, seed, epochs)
    started = pre.extras["started"]
    k0 = np.where(started.any(axis=1), np.argmax(started, axis=1), K)
    sq = np.sum((pre.x[..., :2] - truth[n]) ** 2, axis=-1)
    all_started = started.all(axis=0)
    rmse = np.full(K, np.nan)
    rmse[:k_run][all_started] = np.sqrt(np.mean(sq[:, all_started], axis=0))
    tail = sq[:, -500:]
    final = float(np.sqrt(np.mean(tail))) if epochs is None and np.isfinite(tail).all() else float("nan")
    estimate, bias_sigma = np.full((K, 3), np.nan), np.full(K, np.nan)
    estimate[:k_run] = pre.x[0]
    bias_sigma[:k_run] = np.sqrt(pre.P[0, :, 2, 2])
    if len(rmse_plain) < K:
        rmse_plain = np.concatenate([rmse_plain, np.full(K - len(rmse_plain), np.nan)])
    true_bias = np.array(true_bias[0])
    true_bias[k_run:] = np.nan                      # shown as far as the estimates, in a partial view
    return BiasTrackingView(drift_rate=rate, initial_error=d0, max_alpha=a_max, times=t, truth=truth,
                            estimate=estimate, bias_sigma=bias_sigma, true_bias=true_bias,
                            start_epochs=k0, rmse=rmse, rmse_unstarted=rmse_plain, final_rmse=final, n_runs=M,
                            epochs_run=epochs)


def plot_bias_tracking_view(view: BiasTrackingView, fig: Figure | None = None) -> Figure:
    """Draw a ``BiasTrackingView``: the track of run 0, its bias estimate with ±2σ, and the RMSE of both starts.

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> fig = plot_bias_tracking_view(bias_tracking_view(n_runs=4, n_obs=600))
    >>> # the track, the bias estimate, the RMSE of both starts
    >>> len(fig.axes)
    3
    >>> plt.close(fig)
    """
    fig = fig or plt.figure(figsize=(7.8, 3.8))
    grid = fig.add_gridspec(2, 2, width_ratios=(1.0, 1.3))
    ax_m = fig.add_subplot(grid[:, 0])
    ax_b = fig.add_subplot(grid[0, 1])
    ax_r = fig.add_subplot(grid[1, 1], sharex=ax_b)
    ax_m.plot(*view.truth.T, color="black", lw=1.0, label="truth")
    (track,) = ax_m.plot(*view.estimate[:, :2].T, color="C0", lw=0.8, label="IEKF, run 0")
    k0 = int(view.start_epochs[0])
    fix = None
    if k0 < len(view.times):
        (fix,) = ax_m.plot(*view.estimate[k0, :2], "o", color="C3", ms=4, label="pre-positioning fix")
    mark_beacon(ax_m)
    ax_m.set_aspect("equal", adjustable="datalim")
    ax_m.set_xlabel("x east [m]")
    ax_m.set_ylabel("y north [m]")
    legend_below(ax_m, ncol=2)  # under the map: the track fills it
    t, b, s = view.times, view.estimate[:, 2], view.bias_sigma
    (true_bias,) = ax_b.plot(t, view.true_bias, color="black", lw=1.0, label="true bias")
    (estimate,) = ax_b.plot(t, b, color="C0", lw=0.8, label="estimate")
    band = ax_b.fill_between(t, b - 2 * s, b + 2 * s, color="C0", alpha=0.25, lw=0, label="±2σ")
    ax_b.set_ylabel("bias [m]")
    # a free band above the data for the legend, kept by every refit of the limits (rescale autoscales with it)
    ax_b.set_ymargin(0.5)
    ax_b.legend(loc="upper left", fontsize=7, ncol=3)
    _bias_tracking_title(view, ax_b)
    (unstarted,) = ax_r.semilogy(t, view.rmse_unstarted, color="C1", lw=0.9, label="IEKF from the start, P₀ = I")
    (rmse,) = ax_r.semilogy(t, view.rmse, color="C0", lw=1.2, label="pre-positioning + IEKF")
    ax_r.set_xlabel("time [s]")
    ax_r.set_ylabel("RMSE [m]")
    plain_log_ticks(ax_r)
    ax_r.legend(loc="upper right", fontsize=7)
    fig.tight_layout()
    return keep(fig, track=track, fix=fix, true_bias=true_bias, estimate=estimate, band=band, unstarted=unstarted,
                rmse=rmse)


def _bias_tracking_title(view: BiasTrackingView, ax_b: Any) -> Any:
    # the threshold rounded as its slider shows it (three significant digits); a partial answer says so
    runs = f"{view.n_runs} runs" if view.epochs_run is None else f"first {view.times[view.epochs_run - 1]:.0f} s…"
    ax_b.set_title(f"drift {view.drift_rate:.3f} m/s, start {view.initial_error:g} m off, α < {view.max_alpha:.3g}; "
                   f"{runs}", fontsize=9)
    return ax_b.title


def update_bias_tracking_view(fig: Figure, view: BiasTrackingView) -> list[Any] | None:
    """Put another ``BiasTrackingView`` into a figure drawn by ``plot_bias_tracking_view``; returns what changed
    (``None``, to draw anew, when the pre-positioning fix of run 0 appears or disappears; in a partial view, see
    ``BiasTrackingView.epochs_run``, a fix not reached yet is hidden instead)."""
    a = kept(fig)
    if a is None:                   # not a figure of the plot function: drawn anew
        return None
    k0 = int(view.start_epochs[0])
    if (a["fix"] is None) != (k0 >= len(view.times)) and view.epochs_run is None:
        return None
    ax_m, ax_b, ax_r = fig.axes[:3]
    a["track"].set_data(*view.estimate[:, :2].T)
    changed = [a["track"]]
    if a["fix"] is not None:
        fix = view.estimate[k0, :2] if k0 < len(view.times) else (np.nan, np.nan)
        a["fix"].set_data([fix[0]], [fix[1]])
        changed.append(a["fix"])
    t, b, s = view.times, view.estimate[:, 2], view.bias_sigma
    a["true_bias"].set_ydata(view.true_bias)
    a["estimate"].set_ydata(b)
    # the band's outline in place: a new fill_between would ask the axes to autoscale at the next draw, moving
    # its limits (and so drawing the whole figure again) at every update
    a["band"].set_data(t, b - 2 * s, b + 2 * s)
    a["unstarted"].set_ydata(view.rmse_unstarted)
    a["rmse"].set_ydata(view.rmse)
    if view.epochs_run is None:     # a partial view keeps the limits: drawn over the kept background, at once
        rescale(ax_m, ax_b, ax_r)
    return changed + [a["true_bias"], a["estimate"], a["band"], a["unstarted"], a["rmse"],
                      _bias_tracking_title(view, ax_b)]


def bias_tracking_widget() -> Any:
    """Sliders for the bias drift rate, the initial error and the α threshold over paper A's IEKF (chapter 7).

    Each new setting computes the chapter's 30 runs of 2000 ranges (both filters; an α move only the pre-positioned
    one): about half a second. In a live kernel the first picture of a new setting shows the same runs over their
    first 200 epochs (300 for an α move), titled "first ... s…", and the full answer replaces it when it is ready
    (``_panel.slider_panel``'s ``refine``); a setting shown before comes back at once.

    Examples
    --------
    >>> # computes the chapter's 30 runs of 2000 ranges: about a second
    >>> panel = bias_tracking_widget()
    >>> [c.description for c in panel.children[0].children]
    ['bias drift [m/s]', 'initial error [m]', 'α threshold']
    """
    import ipywidgets as w

    style = {"description_width": "initial"}
    sliders = {
        "drift_rate": w.FloatSlider(value=0.0, min=-0.05, max=0.05, step=0.005, readout_format=".3f",
                                    description="bias drift [m/s]", continuous_update=False, style=style),
        "initial_error": w.FloatSlider(value=150.0, min=0.0, max=500.0, step=10.0, description="initial error [m]",
                                       continuous_update=False, style=style),
        "max_alpha": w.FloatLogSlider(value=2.0, base=10, min=-0.5, max=1.0, step=0.1, description="α threshold",
                                      continuous_update=False, style=style),
    }
    view = functools.lru_cache(maxsize=256)(bias_tracking_view)
    full: dict[tuple[Any, ...], BiasTrackingView] = {}  # the full answers computed, by setting (as view's cache)

    def answer(coarse: bool, drift_rate: float, initial_error: float, max_alpha: float) -> BiasTrackingView:
        key = (drift_rate, initial_error, max_alpha)
        if key in full or not coarse:
            return full.setdefault(key, view(drift_rate=drift_rate, initial_error=initial_error, max_alpha=max_alpha))
        # the first epochs of the same runs at once: the same numbers as the full answer there
        return _early_view(drift_rate, initial_error, max_alpha)

    def refine(**p: float) -> Callable[[], Any] | None:
        key = (p["drift_rate"], p["initial_error"], p["max_alpha"])
        return None if key in full else functools.partial(answer, False, **p)

    return slider_panel(sliders, lambda fig, coarse, **p: plot_bias_tracking_view(answer(coarse, **p), fig),
                        lambda fig, coarse, **p: update_bias_tracking_view(fig, answer(coarse, **p)), refine=refine)


#: Epochs the widget's first answer for a new setting runs the filters over (of the chapter's 2000), while the full
#: answer is computed in the background: about a tenth of its time; half as many again when only the pre-positioned
#: IEKF runs (an α move: the IEKF from the start is at hand), which starts at about epoch 250 (so the first picture
#: shows its start; more epochs would cost a first picture over the 120 ms target).
EARLY_EPOCHS = (200, 300)


def _early_view(drift_rate: float, initial_error: float, max_alpha: float) -> BiasTrackingView:
    """The chapter's view over its first ``EARLY_EPOCHS`` epochs (the widget's coarse answer)."""
    rate = as_scalar("drift_rate", drift_rate, low=-1.0, high=1.0)
    d0 = as_scalar("initial_error", initial_error, low=0.0, high=1e6)
    a_max = as_scalar("max_alpha", max_alpha, domain="positive", high=1e3)
    at_hand = (rate, d0, 30, 2000, 0, None) in _CURVES
    return _view(rate, d0, a_max, 30, 2000, 0, EARLY_EPOCHS[at_hand])


#: Zero-argument callables running the chapter-7 widget's computation at its defaults (for ``make bench``).
COMPUTE_FUNCTIONS: dict[str, Callable[[], Any]] = {
    "ch07 bias tracking": bias_tracking_view,
}
