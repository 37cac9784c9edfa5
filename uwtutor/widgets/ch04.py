"""Chapter 4 widget: the range-only EKF on paper D's approach, with its tuning, initial error and a range bias."""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any, Callable

import matplotlib.pyplot as plt
from matplotlib.figure import Figure
import numpy as np

from .. import scenarios
from .._validate import as_int, as_scalar, as_seed, check_work
from ..filters import range_only_ekf
from ..montecarlo import run_monte_carlo
from ..plotting import mark_beacon, plain_log_ticks
from ._panel import keep, kept, rescale, slider_panel, snap_to_decades

__all__ = [
    "EKFView",
    "ekf_view",
    "plot_ekf_view",
    "ekf_widget",
    "plain_log_ticks",
    "COMPUTE_FUNCTIONS",
]

#: DR noise variance per axis per ping and white range noise variance of paper D's simulation [m²].
DR_VARIANCE = 0.81
RANGE_VARIANCE = 0.49
#: Epochs of the approach (a ping every 10 s for 1500 s): the work of a run, to refuse a count of runs too large.
_EPOCHS = 151


@dataclass(frozen=True)
class EKFView:
    r"""A Monte Carlo study of the range-only EKF on paper D's approach track (chapter 4).

    Attributes
    ----------
    initial_error : float
        Standard deviation of the initial position error per axis [m] (also the filter's :math:`\sqrt{P_0}`).
    q_scale : float
        The filter's :math:`Q` divided by the true DR noise covariance.
    r_scale : float
        The filter's :math:`R` divided by the true range noise variance.
    bias : float
        Constant range bias added to every range, not modelled by the filter [m].
    times : ndarray, shape (K,)
        Epoch times [s].
    truth : ndarray, shape (K, 2)
        True track [m].
    estimates : ndarray, shape (S, K, 2)
        Estimated tracks of the first S (``n_shown``) runs [m].
    rmse : ndarray, shape (K,)
        RMS position error over the runs [m].
    mean_nees : ndarray, shape (K,)
        NEES averaged over the runs.
    nees_bounds : tuple of float
        95 % chi-square interval of ``mean_nees`` for a consistent filter.
    mean_nis : ndarray, shape (K,)
        NIS averaged over the runs.
    nis_bounds : tuple of ndarray
        95 % interval of ``mean_nis``.
    nees_fraction_within : float
        Fraction of epochs whose mean NEES is inside its interval.
    nis_fraction_within : float
        The same for the NIS.
    n_runs : int
        Number of Monte Carlo runs.

    Examples
    --------
    >>> view = ekf_view(n_runs=10, n_shown=2, seed=0)
    >>> # 151 epochs; the tracks of 2 runs kept
    >>> view.times.shape, view.estimates.shape, view.n_runs
    ((151,), (2, 151, 2), 10)
    """

    initial_error: float
    q_scale: float
    r_scale: float
    bias: float
    times: np.ndarray
    truth: np.ndarray
    estimates: np.ndarray
    rmse: np.ndarray
    mean_nees: np.ndarray
    nees_bounds: tuple[float, float]
    mean_nis: np.ndarray
    nis_bounds: tuple[np.ndarray, np.ndarray]
    nees_fraction_within: float
    nis_fraction_within: float
    n_runs: int


def ekf_view(initial_error: float = 30.0, q_scale: float = 1.0, r_scale: float = 1.0, bias: float = 0.0,
             n_runs: int = 50, seed: int = 0, n_shown: int = 8) -> EKFView:
    r"""Run the range-only EKF on ``n_runs`` draws of paper D's approach with white range noise (plus a bias).

    The scenario is ``scenarios.approach_with_turn_scenario`` with the sound speed known exactly (so that the only
    range errors are the white noise of variance 0.49 m² and the constant ``bias``); DR noise has variance
    0.81 m² per axis per ping. The filter uses :math:`Q` = ``q_scale`` x 0.81 I, :math:`R` = ``r_scale`` x 0.49
    and :math:`P_0` = ``initial_error`` squared times I; each run starts from the truth plus an error drawn from
    :math:`N(0, P_0)`, so the filter is consistent when both scales are 1 and the bias is 0 (up to linearization).

    Parameters
    ----------
    initial_error : float, default 30
        Initial error standard deviation per axis [m], 1e-3 to 1e6.
    q_scale : float, default 1
        Filter Q / true DR noise, 1e-6 to 1e6.
    r_scale : float, default 1
        Filter R / true range noise, 1e-6 to 1e6.
    bias : float, default 0
        Unmodelled constant range bias [m], at most 1e6 in size.
    n_runs : int, default 50
        Monte Carlo runs.
    seed : int, default 0
        Seed of the noise and the initial errors.
    n_shown : int, default 8
        Runs whose estimated tracks are kept for the plot: the first ``min(n_shown, n_runs)``.

    Returns
    -------
    EKFView

    Examples
    --------
    >>> # Q and R as the truth, no bias: consistent
    >>> tuned = ekf_view(n_runs=10, seed=0)
    >>> round(tuned.nees_fraction_within, 2), [round(b, 2) for b in tuned.nees_bounds]
    (0.95, [0.96, 3.42])
    >>> # a 20 m range bias the filter does not model
    >>> biased = ekf_view(bias=20.0, n_runs=10, seed=0)
    >>> round(biased.nees_fraction_within, 2), bool(biased.rmse[-1] > 2.0 * tuned.rmse[-1])
    (0.0, True)
    """
    # beyond these bounds the filter's variances underflow to 0 or their products overflow float64
    p0 = as_scalar("initial_error", initial_error, low=1e-3, high=1e6)
    qs = as_scalar("q_scale", q_scale, low=1e-6, high=1e6)
    rs = as_scalar("r_scale", r_scale, low=1e-6, high=1e6)
    # a bias beyond 1000 km is not a range bias (the ranges would overflow the filter's float64): refused by name
    b = as_scalar("bias", bias, low=-1e6, high=1e6)
    M = as_int("n_runs", n_runs, minimum=2)
    check_work("n_runs", 10 * M * _EPOCHS, "floats (n_runs x the scenario's epochs x 10)")
    shown = as_int("n_shown", n_shown, minimum=0)
    rng = np.random.default_rng(as_seed("seed", seed))
    sc = scenarios.approach_with_turn_scenario(rng, n_runs=M, assumed_speed=1500.0, speed_sigma=0.0,
                                               noise_sigma=np.sqrt(RANGE_VARIANCE), dr_sigma=np.sqrt(DR_VARIANCE))
    truth = np.array(sc.true_positions[0])
    x0 = truth[0] + p0 * rng.standard_normal((M, 2))
    z = np.maximum(sc.ranges + b, 0.0)
    study = run_monte_carlo(range_only_ekf, truth, x0=x0, P0=np.eye(2) * p0**2, u=sc.dr_displacements, z=z,
                            Q=np.eye(2) * qs * DR_VARIANCE, R=rs * RANGE_VARIANCE)
    if study.mean_nis is None or study.nis_bounds is None:      # pragma: no cover - the EKF reports innovations
        raise RuntimeError("the EKF reported no innovations")
    nees_lo, nees_hi = study.nees_bounds            # floats (one count of runs at every step)
    nis_lo, nis_hi = study.nis_bounds               # arrays (K,): the count of ranges per step
    return EKFView(initial_error=p0, q_scale=qs, r_scale=rs, bias=b, times=np.array(sc.times), truth=truth,
                   estimates=np.array(study.x[:min(shown, M)]), rmse=study.rmse, mean_nees=study.mean_nees,
                   nees_bounds=(float(nees_lo), float(nees_hi)), mean_nis=study.mean_nis,
                   nis_bounds=(np.asarray(nis_lo), np.asarray(nis_hi)),
                   nees_fraction_within=study.nees_fraction_within(),
                   nis_fraction_within=study.nis_fraction_within(), n_runs=M)


def plot_ekf_view(view: EKFView, fig: Figure | None = None) -> Figure:
    """Draw an ``EKFView``: a few estimated tracks, the RMSE over time, and the mean NEES against its bounds.

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> fig = plot_ekf_view(ekf_view(n_runs=10, n_shown=2))
    >>> # the tracks, the RMSE, the mean NEES
    >>> len(fig.axes)
    3
    >>> plt.close(fig)
    """
    fig = fig or plt.figure(figsize=(7.6, 3.6))
    grid = fig.add_gridspec(2, 2, width_ratios=(1.0, 1.15))
    ax_m = fig.add_subplot(grid[:, 0])
    ax_r = fig.add_subplot(grid[0, 1])
    ax_n = fig.add_subplot(grid[1, 1], sharex=ax_r)
    runs = [ax_m.plot(*est.T, color="C0", lw=0.6, alpha=0.7)[0] for est in view.estimates]
    ax_m.plot(*view.truth.T, color="black", lw=1.4, label="truth")
    ax_m.plot([], [], color="C0", lw=0.8, label="EKF runs")
    mark_beacon(ax_m)
    ax_m.set_aspect("equal", adjustable="datalim")
    ax_m.set_xlabel("x east [m]")
    ax_m.set_ylabel("y north [m]")
    ax_m.legend(loc="upper left", fontsize=7)
    (rmse,) = ax_r.semilogy(view.times, view.rmse, color="C0")
    ax_r.set_ylabel("RMSE [m]")
    plain_log_ticks(ax_r)
    lo, hi = view.nees_bounds
    (nees,) = ax_n.semilogy(view.times, view.mean_nees, color="C3", label="mean NEES")
    ax_n.axhspan(lo, hi, color="C2", alpha=0.25, label="95 % bounds")
    ax_n.axhline(2.0, color="gray", lw=0.6)
    ax_n.set_xlabel("time [s]")
    ax_n.set_ylabel("NEES")
    plain_log_ticks(ax_n)
    # beside the axes: the mean NEES and its band fill the whole panel
    ax_n.legend(loc="center left", bbox_to_anchor=(1.0, 0.5), fontsize=7, handlelength=1.2)
    inside = ax_n.text(0.01, 0.04, " ", transform=ax_n.transAxes, fontsize=8)
    keep(fig, runs=runs, rmse=rmse, nees=nees, inside=inside, bounds=(lo, hi))
    _ekf_texts(view, fig, inside)
    fig.tight_layout()
    snap_to_decades(ax_r, ax_n)         # as the updates keep them (see ``update_ekf_view``)
    return fig


def _ekf_texts(view: EKFView, fig: Figure, inside: Any) -> list[Any]:
    ax_r = fig.axes[1]
    # rounded as the sliders show them (three significant digits on the log sliders)
    ax_r.set_title(f"P₀ = ({view.initial_error:.0f} m)², Q×{view.q_scale:.3g}, R×{view.r_scale:.3g}, "
                   f"bias {view.bias:g} m; {view.n_runs} runs", fontsize=9)
    inside.set_text(f"{100 * view.nees_fraction_within:.0f} % of epochs inside")
    return [ax_r.title, inside]


def update_ekf_view(fig: Figure, view: EKFView) -> list[Any] | None:
    """Put another ``EKFView`` into a figure drawn by ``plot_ekf_view``; returns what changed (``None``: draw anew)."""
    a = kept(fig)
    if a is None:                   # not a figure the plot function drew: draw it anew
        return None
    if len(a["runs"]) != len(view.estimates) or a["bounds"] != tuple(view.nees_bounds):
        return None
    for line, est in zip(a["runs"], view.estimates):
        line.set_data(*est.T)
    a["rmse"].set_data(view.times, view.rmse)
    a["nees"].set_data(view.times, view.mean_nees)
    rescale(fig.axes[0])
    # the RMSE and NEES panels in whole decades, kept while at most one is spare: most moves of a slider keep
    # the axes, and the pixels drawn of them
    rescale(*fig.axes[1:3], decades=True)
    return [*a["runs"], a["rmse"], a["nees"], *_ekf_texts(view, fig, a["inside"])]


def ekf_widget() -> Any:
    """Sliders for the initial error, Q, R and a range bias over the EKF's tracks and NEES (chapter 4).

    Examples
    --------
    >>> panel = ekf_widget()
    >>> [c.description for row in panel.children[:2] for c in row.children]
    ['initial σ [m]', 'Q scale', 'R scale', 'range bias [m]']
    """
    import ipywidgets as w

    style = {"description_width": "initial"}
    sliders = {
        "initial_error": w.FloatSlider(value=30.0, min=5.0, max=500.0, step=5.0, description="initial σ [m]",
                                       continuous_update=False, style=style),
        "q_scale": w.FloatLogSlider(value=1.0, base=10, min=-2, max=2, step=0.25, description="Q scale",
                                    continuous_update=False, style=style),
        "r_scale": w.FloatLogSlider(value=1.0, base=10, min=-2, max=2, step=0.25, description="R scale",
                                    continuous_update=False, style=style),
        "bias": w.FloatSlider(value=0.0, min=-30.0, max=30.0, step=1.0, description="range bias [m]",
                              continuous_update=False, style=style),
    }
    view = functools.lru_cache(maxsize=256)(ekf_view)
    return slider_panel(sliders, lambda fig, **p: plot_ekf_view(view(**p), fig),
                        lambda fig, **p: update_ekf_view(fig, view(**p)))


#: Zero-argument callables running the chapter-4 widget's computation at its defaults (for ``make bench``).
COMPUTE_FUNCTIONS: dict[str, Callable[[], Any]] = {
    "ch04 range-only EKF": ekf_view,
}
