r"""Chapter 5 widget: paper D's fading EKF on the approach track (assumed sound-speed error, forgetting factor,
weakening factor on or off, initial error) against the additive-noise EKF."""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any, Callable

import matplotlib.pyplot as plt
from matplotlib.figure import Figure
import numpy as np

from ..scenarios import paper_d
from .._validate import as_finite, as_int, check_work
from ..filters.ekf import range_only_ekf
from ..filters.fading import fading_ekf
from ..plotting import mark_beacon, plot_track
from ._panel import keep, kept, rescale, slider_panel, snap_to_decades

__all__ = [
    "PAPER_D",
    "FadingView",
    "fading_view",
    "plot_fading_view",
    "fading_widget",
    "COMPUTE_FUNCTIONS",
]

#: Paper D's parameters by name (from :mod:`uwtutor.scenarios.paper_d`, the one place they are written down).
#: Epochs of paper D's approach (a ping every 10 s for 1500 s): the work of a run, to refuse a count of runs too large.
_EPOCHS = 151
PAPER_D: dict[str, float] = {key: value for key, value in paper_d.PARAMETERS.as_dict().items() if key != "n_runs"}
#: Start of the steady-state window of the summaries, in seconds (epochs at or after it count).
STEADY_FROM = 1200.0


@dataclass(frozen=True)
class FadingView:
    r"""What the chapter-5 widget shows for one setting (returned by ``fading_view``).

    Shapes: ``K`` epochs; ``n_runs`` Monte Carlo runs behind the error curves.

    Attributes
    ----------
    assumed_dc : float
        The sound-speed error :math:`\Delta c = c - c_\mathrm e` the filter assumes [m/s] (the truth is -30).
    rho : float
        Forgetting factor.
    weakening : bool
        True: paper D's :math:`\beta_k = \mathbf H_k \mathbf m_k` (ISFEKF); False: :math:`\beta = 1`.
    initial_error : float
        Distance of the initial estimate from the truth [m].
    n_runs : int
        Number of Monte Carlo runs.
    times : ndarray, shape (K,)
        Reception times [s].
    truth : ndarray, shape (K, 2)
        True track [m] (the same in every run).
    x_fading : ndarray, shape (K, 2)
        The fading filter's estimate in the displayed run.
    x_ekf : ndarray, shape (K, 2)
        The additive-noise EKF's estimate in the displayed run.
    rmse_fading : ndarray, shape (K,)
        RMS error of the fading filter over the runs at each epoch [m].
    rmse_ekf : ndarray, shape (K,)
        The same for the EKF.
    median_fading : ndarray, shape (K,)
        Median error of the fading filter over the runs [m].
    median_ekf : ndarray, shape (K,)
        The same for the EKF.
    fading_factor : ndarray, shape (K,)
        :math:`\lambda_k` in the displayed run.
    weakening_factor : ndarray, shape (K,)
        :math:`\beta_k` in the displayed run.
    fraction_faded : float
        Fraction of all steps of all runs with :math:`\lambda_k > 1`.
    steady_rmse : dict of float
        ``"fading"`` and ``"ekf"``: RMS error over the runs and the epochs after ``STEADY_FROM`` [m].
    steady_median : dict of float
        The median over the runs of each run's RMS error after ``STEADY_FROM`` [m].

    Examples
    --------
    >>> view = fading_view(n_runs=10, seed=0)
    >>> view.times.shape, view.x_fading.shape, view.fading_factor.shape
    ((151,), (151, 2), (151,))
    """

    assumed_dc: float
    rho: float
    weakening: bool
    initial_error: float
    n_runs: int
    times: np.ndarray
    truth: np.ndarray
    x_fading: np.ndarray
    x_ekf: np.ndarray
    rmse_fading: np.ndarray
    rmse_ekf: np.ndarray
    median_fading: np.ndarray
    median_ekf: np.ndarray
    fading_factor: np.ndarray
    weakening_factor: np.ndarray
    fraction_faded: float
    steady_rmse: dict[str, float]
    steady_median: dict[str, float]


@functools.lru_cache(maxsize=16)
def _fading_start(d0: float, M: int, seed: int) -> tuple[Any, np.ndarray, np.ndarray]:
    """What ``fading_view`` draws and runs before the fading filter, which depends on the initial error, the number
    of runs and the seed only: paper D's scenario, the initial estimates (``initial_error`` metres from the truth in
    a random direction per run) and the additive EKF's estimates, shape (M, K, 2).

    Kept for the last few settings: a move of the sound-speed error, the forgetting factor or the weakening factor
    then runs the fading filter alone. The arrays are made read-only, so that no caller can change a kept one.
    """
    rng = np.random.default_rng(seed)
    sc = paper_d.make(rng, n_runs=M)
    angle = rng.uniform(0.0, 2.0 * np.pi, M)
    x0 = sc.true_positions[:, 0] + d0 * np.column_stack([np.cos(angle), np.sin(angle)])
    par = paper_d.PARAMETERS
    ekf = range_only_ekf(x0, np.eye(2) * d0**2, sc.dr_displacements, sc.ranges, np.eye(2) * par.Q, par.R,
                         times=sc.times)
    x_ekf = np.array(ekf.x)
    for array in (sc.true_positions, sc.dr_displacements, sc.ranges, sc.times, x0, x_ekf):
        if isinstance(array, np.ndarray):
            array.setflags(write=False)
    return sc, x0, x_ekf


def fading_view(assumed_dc: float = -30.0, rho: float = 0.95, weakening: bool = True, initial_error: float = 150.0,
                n_runs: int = 100, seed: int = 0) -> FadingView:
    r"""Run the fading EKF and the additive EKF on ``n_runs`` draws of paper D's approach scenario.

    The filter assumes :math:`\mu_\gamma = 1 + \Delta c / 1500` (``assumed_dc`` = :math:`\Delta c`; the scenario's
    truth is :math:`1470 - 1500 = -30` m/s) and :math:`\sigma_\gamma = 1/1500`; both filters start
    ``initial_error`` metres from the truth, in a random direction per run, with
    :math:`\mathbf P_1 = \mathrm{diag}(\Delta r^2, \Delta r^2)` (paper D, eq. 28). Run 0 is displayed.

    Parameters
    ----------
    assumed_dc : float, default -30
        Assumed systematic sound-speed error [m/s], between -200 and 200.
    rho : float, default 0.95
        Forgetting factor, in (0, 1].
    weakening : bool, default True
        Paper D's range weakening factor (True) or Zhou and Xi's :math:`\beta = 1` (False).
    initial_error : float, default 150
        Initial position error [m], 1e-3 to 1e6.
    n_runs : int, default 100
        Monte Carlo runs (>= 1).
    seed : int, default 0
        Seed of the scenario and of the initial errors.

    Returns
    -------
    FadingView

    Examples
    --------
    >>> paper_d = fading_view(assumed_dc=-30.0, weakening=True, n_runs=10, seed=0)
    >>> # beta = 1
    >>> plain = fading_view(assumed_dc=-30.0, weakening=False, n_runs=10, seed=0)
    >>> round(paper_d.steady_median["fading"], 1), round(plain.steady_median["fading"], 1)
    (30.6, 54.1)
    >>> # the weakening factor fades less often
    >>> bool(paper_d.fraction_faded < plain.fraction_faded)
    True
    """
    dc = float(as_finite("assumed_dc", assumed_dc, ndim=0))
    if not -200.0 <= dc <= 200.0:
        raise ValueError(f"assumed_dc must lie between -200 and 200 m/s; got {dc:g}")
    d0 = float(as_finite("initial_error", initial_error, ndim=0))
    if not 1e-3 <= d0 <= 1e6:           # beyond, the filter's P1 = diag(d0², d0²) underflows to 0 or overflows
        raise ValueError(f"initial_error must lie between 1e-3 and 1e6 m (the filter's P1 is diag(d0², d0²)); "
                         f"got {d0:g}")
    if not isinstance(weakening, (bool, np.bool_)):
        raise TypeError(f"weakening must be True or False; got {weakening!r}")
    M = as_int("n_runs", n_runs, minimum=1)
    check_work("n_runs", 10 * M * _EPOCHS, "floats (n_runs x paper D's epochs x 10)")
    seed = as_int("seed", seed, minimum=0)
    sc, x0, x_ekf = _fading_start(d0, M, seed)
    truth = sc.true_positions
    P0 = np.eye(2) * d0**2
    par = paper_d.PARAMETERS
    Q = np.eye(2) * par.Q
    c = par.true_speed
    fad = fading_ekf(x0, P0, sc.dr_displacements, sc.ranges, Q, par.R, mu_gamma=1.0 + dc / c,
                     sigma_gamma=par.speed_sigma / c, rho=rho, beta="range" if weakening else 1.0,
                     times=sc.times)
    err_f = np.linalg.norm(fad.x - truth, axis=-1)
    err_e = np.linalg.norm(x_ekf - truth, axis=-1)
    late = sc.times >= STEADY_FROM

    def steady(err: np.ndarray) -> tuple[float, float]:
        per_run = np.sqrt(np.mean(err[:, late] ** 2, axis=1))
        return float(np.sqrt(np.mean(per_run**2))), float(np.median(per_run))

    (rf, mf), (re, me) = steady(err_f), steady(err_e)
    return FadingView(assumed_dc=dc, rho=float(rho), weakening=bool(weakening), initial_error=d0, n_runs=M,
                      times=np.array(sc.times), truth=np.array(truth[0]), x_fading=np.array(fad.x[0]),
                      x_ekf=np.array(x_ekf[0]), rmse_fading=np.sqrt(np.mean(err_f**2, axis=0)),
                      rmse_ekf=np.sqrt(np.mean(err_e**2, axis=0)), median_fading=np.median(err_f, axis=0),
                      median_ekf=np.median(err_e, axis=0), fading_factor=np.array(fad.fading_factor[0]),
                      weakening_factor=np.array(fad.weakening_factor[0]),
                      fraction_faded=float(np.mean(fad.fading_factor > 1.0)),
                      steady_rmse={"fading": rf, "ekf": re}, steady_median={"fading": mf, "ekf": me})


def plot_fading_view(view: FadingView, fig: Figure | None = None) -> Figure:
    """Draw a ``FadingView``: the tracks of the displayed run, the error over time (RMS and median over the runs)
    and the fading factor of the displayed run.

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> fig = plot_fading_view(fading_view(n_runs=10))
    >>> # the tracks, the error over time, the factors
    >>> len(fig.axes) >= 3
    True
    >>> plt.close(fig)
    """
    fig = fig or plt.figure(figsize=(8.0, 5.0))
    grid = fig.add_gridspec(2, 2, width_ratios=(1.0, 1.25))
    ax_map = fig.add_subplot(grid[:, 0])
    ax_err = fig.add_subplot(grid[0, 1])
    ax_lam = fig.add_subplot(grid[1, 1], sharex=ax_err)
    name = _fading_name(view.weakening)
    plot_track(ax_map, view.truth, label="truth", color="black", lw=1.2)
    plot_track(ax_map, view.x_ekf, label="EKF (additive)", color="C0", lw=1)
    plot_track(ax_map, view.x_fading, label=name, color="C3", lw=1)
    tracks = ax_map.lines[2:6]                      # the two estimates and their start dots
    mark_beacon(ax_map, (0.0, 0.0))
    ax_map.set_aspect("equal", adjustable="datalim")
    ax_map.legend(loc="upper left", fontsize=7)
    ax_map.set_title("run 0", fontsize=9)
    t = view.times
    errors = [ax_err.semilogy(t, view.rmse_ekf, color="C0", label="EKF, RMS")[0],
              ax_err.semilogy(t, view.median_ekf, color="C0", ls="--", label="EKF, median")[0],
              ax_err.semilogy(t, view.rmse_fading, color="C3", label=f"{name}, RMS")[0],
              ax_err.semilogy(t, view.median_fading, color="C3", ls="--", label=f"{name}, median")[0]]
    ax_err.set_ylabel("position error [m]")
    ax_err.legend(fontsize=7, ncol=2, loc="upper right")
    (factor,) = ax_lam.semilogy(t, view.fading_factor, ".", ms=3, color="C3")
    ax_lam.set_ylim(0.8, _factor_top(view.fading_factor))
    ax_lam.set_xlabel("time [s]")
    ax_lam.set_ylabel("fading factor λ (run 0)")
    _fading_titles(view, ax_err, ax_lam)
    fig.tight_layout()
    snap_to_decades(ax_err)             # as the updates keep them (see ``update_fading_view``)
    return keep(fig, tracks=tracks, errors=errors, factor=factor, weakening=view.weakening)


def _fading_titles(view: FadingView, ax_err: Any, ax_lam: Any) -> list[Any]:
    ax_err.set_title(f"{view.n_runs} runs; steady RMS {view.steady_rmse['fading']:.1f} m "
                     f"(EKF {view.steady_rmse['ekf']:.1f} m)", fontsize=8)
    ax_lam.set_title(f"λ > 1 in {100 * view.fraction_faded:.1f} % of all steps", fontsize=8)
    return [ax_err.title, ax_lam.title]


def update_fading_view(fig: Figure, view: FadingView) -> list[Any] | None:
    """Put another ``FadingView`` into a figure drawn by ``plot_fading_view``; returns what changed (the
    legends among them: the fading filter's name changes with the weakening factor)."""
    a = kept(fig)
    if a is None:                   # not a figure the plot function drew: draw it anew
        return None
    ax_map, ax_err, ax_lam = fig.axes[:3]
    # both legends are redrawn at every update, so never kept in the background (where the old name would show
    # under the new one)
    map_legend, err_legend = ax_map.get_legend(), ax_err.get_legend()
    assert map_legend is not None and err_legend is not None     # plot_fading_view draws both
    legends = [map_legend, err_legend]
    if a["weakening"] != view.weakening:            # the fading filter's name changes in both legends
        old, new = (_fading_name(w) for w in (a["weakening"], view.weakening))
        for legend in legends:
            for text in legend.get_texts():
                text.set_text(text.get_text().replace(old, new))
        a["weakening"] = view.weakening
    ekf, ekf0, fading, fading0 = a["tracks"]
    ekf.set_data(*view.x_ekf[:, :2].T)
    ekf0.set_data([view.x_ekf[0, 0]], [view.x_ekf[0, 1]])
    fading.set_data(*view.x_fading[:, :2].T)
    fading0.set_data([view.x_fading[0, 0]], [view.x_fading[0, 1]])
    for line, y in zip(a["errors"], (view.rmse_ekf, view.median_ekf, view.rmse_fading, view.median_fading)):
        line.set_ydata(y)
    a["factor"].set_ydata(view.fading_factor)
    rescale(ax_map)
    # the error and the fading factor in whole decades, kept while at most one is spare: most moves of a slider
    # keep the axes, and the pixels drawn of them
    rescale(ax_err, decades=True)
    top, needed = ax_lam.get_ylim()[1], _factor_top(view.fading_factor)
    if not (_factor_peak(view.fading_factor) <= top <= 10.0 * needed):
        ax_lam.set_ylim(0.8, needed)
    return [*a["tracks"], *a["errors"], a["factor"], *legends, *_fading_titles(view, ax_err, ax_lam)]


def _factor_peak(factor: np.ndarray) -> float:
    """The largest fading factor with a 5 % margin above it (1 when there is none)."""
    finite = factor[np.isfinite(factor)]
    return 1.05 * float(finite.max()) if finite.size else 1.0


def _factor_top(factor: np.ndarray) -> float:
    """The top of the fading-factor panel: the decade above the largest factor (with its margin), at least 10."""
    decade: float = 10.0 ** float(np.ceil(np.log10(_factor_peak(factor))))
    return max(10.0, decade)


def _fading_name(weakening: bool) -> str:
    return "ISFEKF" if weakening else "fading EKF, β = 1"


def fading_widget() -> Any:
    """Assumed sound-speed error, forgetting factor, weakening factor on/off and initial error over the view.

    Examples
    --------
    >>> panel = fading_widget()
    >>> [c.description for row in panel.children[:2] for c in row.children]
    ['assumed Δc [m/s]', 'ρ', 'β = H m (paper D)', 'initial error [m]']
    """
    import ipywidgets as w

    style = {"description_width": "initial"}
    sliders = {
        "assumed_dc": w.FloatSlider(value=-30.0, min=-70.0, max=10.0, step=5.0, description="assumed Δc [m/s]",
                                    continuous_update=False, style=style),
        "rho": w.FloatSlider(value=0.95, min=0.3, max=1.0, step=0.05, description="ρ", continuous_update=False,
                             style=style),
        "weakening": w.Checkbox(value=True, description="β = H m (paper D)", style=style),
        "initial_error": w.FloatLogSlider(value=150.0, base=10, min=1.0, max=3.0, step=0.1,
                                          description="initial error [m]", continuous_update=False, style=style),
    }
    view = functools.lru_cache(maxsize=256)(fading_view)
    return slider_panel(sliders, lambda fig, **p: plot_fading_view(view(**p), fig),
                        lambda fig, **p: update_fading_view(fig, view(**p)))


#: Zero-argument callables running each widget's computation at its defaults (wired into the registry).
COMPUTE_FUNCTIONS: dict[str, Callable[[], Any]] = {
    "ch05 fading filter": fading_view,
}
