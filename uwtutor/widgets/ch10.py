r"""Chapter 10 widget: the committed comparison, one scenario and error condition at a time, against the bound.

The study behind it (``make study``: every method of :mod:`uwtutor.methods` on every scenario and condition of
:mod:`uwtutor.scenarios.suite`, 1000 runs each) takes minutes; the widget only reads its table
(:func:`uwtutor.methods.load_comparison`), so that choosing a scenario redraws at once. ``comparison_view`` picks
the rows of one (scenario, condition); ``plot_comparison_view`` draws each method's RMSE over time with the
posterior Cramér-Rao bound, and the median and 95th percentile of its final error.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable

import matplotlib.pyplot as plt
from matplotlib.figure import Figure
import numpy as np

from .._validate import as_instance
from ._panel import keep, kept, slider_panel

if TYPE_CHECKING:
    from ..montecarlo import ComparisonTable

__all__ = ["ComparisonView", "comparison_view", "plot_comparison_view", "comparison_widget", "COMPUTE_FUNCTIONS"]

_TABLE: dict[str, Any] = {}


def _committed_table() -> Any:
    if "table" not in _TABLE:                       # read once per kernel: every redraw uses the same table
        from ..methods import load_comparison

        _TABLE["table"] = load_comparison()
    return _TABLE["table"]


def _table(table: Any) -> Any:
    """The committed comparison for ``None``, else ``table`` itself if it is a ``montecarlo.ComparisonTable``."""
    if table is None:
        return _committed_table()
    from ..montecarlo import ComparisonTable

    return as_instance("table", table, ComparisonTable, "read one with montecarlo.ComparisonTable.from_csv")


@dataclass(frozen=True)
class ComparisonView:
    """What the chapter-10 widget shows for one (scenario, condition): one entry per method that runs there.

    Attributes
    ----------
    scenario : str
        The scenario's name.
    condition : str
        The error condition's name.
    times : ndarray, shape (K,)
        Epoch times [s].
    bound : ndarray, shape (K,)
        :math:`B_k = \\sqrt{\\operatorname{tr} J_k^{-1}}`, the posterior CRLB on the RMS position error [m].
    methods : tuple of str
        The methods shown, in the registry's order.
    rmse : ndarray
        Each method's RMSE over the runs at each epoch [m], one row per method.
    median_final : ndarray
        Median of the final error of each method [m].
    p95_final : ndarray
        95th percentile of the final error of each method [m].
    divergence : ndarray
        Fraction of each method's runs whose final error exceeds the divergence threshold.
    nees_fraction : ndarray
        Fraction of the epochs whose mean NEES is inside its 95 % interval, per method (NaN without a covariance).
    n_runs : int
        Monte Carlo runs behind each number.

    Examples
    --------
    >>> # read from the committed comparison
    >>> view = comparison_view("circle", "white")
    >>> view.times.shape, len(view.methods), view.rmse.shape, view.n_runs
    ((150,), 11, (11, 150), 1000)
    """

    scenario: str
    condition: str
    times: np.ndarray
    bound: np.ndarray
    methods: tuple[str, ...]
    rmse: np.ndarray
    median_final: np.ndarray
    p95_final: np.ndarray
    divergence: np.ndarray
    nees_fraction: np.ndarray
    n_runs: int


def comparison_view(scenario: str = "circle", condition: str = "white",
                    table: ComparisonTable | None = None) -> ComparisonView:
    """The rows of ``table`` (the committed comparison by default) for one scenario and condition.

    Examples
    --------
    >>> import numpy as np
    >>> view = comparison_view(scenario="circle", condition="white")
    >>> view.methods[:3]
    ('LS pre-positioning', 'grid pre-location', 'EKF')
    >>> # no method beats the bound
    >>> bool(np.all(view.rmse[:, -1] >= view.bound[-1]))
    True
    >>> # the gated EKF is one of the methods (which EKF ends lowest is a tie)
    >>> "gated EKF" in view.methods
    True
    """
    t = _table(table)
    scenarios, conditions = list(dict.fromkeys(t.scenario.tolist())), list(dict.fromkeys(t.condition.tolist()))
    if scenario not in scenarios:
        raise ValueError(f"scenario must be one of {scenarios}; got {scenario!r}")
    if condition not in conditions:
        raise ValueError(f"condition must be one of {conditions}; got {condition!r}")
    rows = np.flatnonzero((t.scenario == scenario) & (t.condition == condition))
    if t.rmse_curves is None:
        raise ValueError("the table holds no curves: read it with ComparisonTable.from_csv(path, curves=...)")
    from ..scenarios.suite import PARAMETERS

    K = int(t.n_steps[rows[0]])
    times = PARAMETERS.interval * np.arange(1, K + 1, dtype=float)
    return ComparisonView(scenario=scenario, condition=condition, times=times, bound=t.bound_curves[rows[0]],
                          methods=tuple(t.method[rows].tolist()), rmse=t.rmse_curves[rows],
                          median_final=t.median_final_error[rows], p95_final=t.p95_final_error[rows],
                          divergence=t.divergence_fraction[rows], nees_fraction=t.nees_fraction[rows],
                          n_runs=int(t.n_runs[rows[0]]))


def plot_comparison_view(view: ComparisonView, fig: Figure | None = None, method: str = "all") -> Figure:
    """RMSE over time of every method with the bound (left); median and 95th percentile final errors (right).

    ``method`` (a name of ``view.methods``) draws that method in red and the others in grey; ``"all"`` colours
    every one.

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> # the EKF in red, the others grey
    >>> fig = plot_comparison_view(comparison_view(), method="EKF")
    >>> len(fig.axes)
    2
    >>> plt.close(fig)
    """
    if method != "all" and method not in view.methods:
        raise ValueError(f"method must be 'all' or one of the methods of this scenario, {list(view.methods)}; "
                         f"got {method!r}")
    fig = fig or plt.figure(figsize=(7.8, 3.6))
    ax_t, ax_f = fig.subplots(1, 2, gridspec_kw={"width_ratios": (1.6, 1)})
    n = len(view.methods)
    colors = _comparison_colors(view, method)
    curves = []
    for i, name in enumerate(view.methods):
        chosen = method == name
        curves += ax_t.semilogy(view.times / 60.0, view.rmse[i], color=colors[i], lw=2.0 if chosen else 1.1,
                                label=name, zorder=3 if chosen else 2)
    (bound,) = ax_t.semilogy(view.times / 60.0, view.bound, color="k", lw=2.0, ls="--", label="bound (PCRB)")
    ax_t.set_xlabel("time [min]")
    ax_t.set_ylabel("RMS position error [m]")
    ax_t.set_ylim(max(0.5, 0.5 * float(np.min(view.bound))), 5e3)
    ax_t.set_title(f"{view.scenario}, {view.condition}: {view.n_runs} runs", fontsize=9)
    y = np.arange(n)
    p95 = ax_f.barh(y, view.p95_final, color=colors, alpha=0.35)
    median = ax_f.barh(y, view.median_final, color=colors)
    final_bound = ax_f.axvline(view.bound[-1], color="k", ls="--", lw=1.5)
    lost = _lost_labels(view, ax_f)
    ax_f.set_xscale("log")
    ax_f.set_xlim(1.0, 2e4)
    ax_f.set_yticks(y, view.methods, fontsize=7)
    ax_f.invert_yaxis()
    ax_f.set_xlabel("final error [m]: median, 95 %")
    # no legend over the curves: the right panel's tick labels name the methods, in the curves' colours
    _color_tick_labels(ax_f, colors, method)
    ax_t.text(0.98, 0.97, "-- bound (PCRB)", transform=ax_t.transAxes, ha="right", va="top", fontsize=7)
    fig.tight_layout()
    return keep(fig, methods=tuple(view.methods), curves=curves, bound=bound, p95=p95, median=median,
                final_bound=final_bound, lost=lost)


def _comparison_colors(view: ComparisonView, method: str) -> list[Any]:
    n = len(view.methods)
    if method == "all":
        return [plt.get_cmap("tab10")(i) if i < 10 else (0.2, 0.2, 0.2, 1.0) for i in range(n)]   # no pastels
    # the chosen method in a strong colour, the others in grey behind it
    return ["C3" if name == method else (0.75, 0.75, 0.75, 1.0) for name in view.methods]


def _lost_labels(view: ComparisonView, ax_f: Any) -> list[Any]:
    return [ax_f.text(1.05 * view.p95_final[i], i, f"{100 * view.divergence[i]:.0f} % lost", va="center",
                      fontsize=6) for i in range(len(view.methods)) if view.divergence[i] > 0]


def _color_tick_labels(ax_f: Any, colors: list[Any], method: str) -> None:
    for label, color in zip(ax_f.get_yticklabels(), colors):
        label.set_color(color if method == "all" or color == "C3" else "0.45")


def update_comparison_view(fig: Figure, view: ComparisonView, method: str = "all") -> list[Any] | None:
    """Put another ``ComparisonView`` (and highlight) into a figure drawn by ``plot_comparison_view``, in place;
    returns the artists that changed (the method names on the right panel's y axis among them), or ``None`` when
    the scenario has other methods."""
    a = kept(fig)
    if a is None:                   # not a figure the plot function drew: draw it anew
        return None
    if a["methods"] != tuple(view.methods):
        return None
    ax_t, ax_f = fig.axes[:2]
    colors = _comparison_colors(view, method)
    for i, (line, name) in enumerate(zip(a["curves"], view.methods)):
        chosen = method == name
        line.set_ydata(view.rmse[i])
        line.set(color=colors[i], lw=2.0 if chosen else 1.1, zorder=3 if chosen else 2)
    a["bound"].set_ydata(view.bound)
    # the lower limit a fresh plot would take, or the one shown while that is at most 4 times lower (a little
    # more room under the bound): the bounds of the committed table are all within that, so the axes, and the
    # pixels kept of them, stay as they are after the first move
    low, shown_low = max(0.5, 0.5 * float(np.min(view.bound))), ax_t.get_ylim()[0]
    ax_t.set_ylim(low if not shown_low <= low <= 4.0 * shown_low else shown_low, 5e3)
    ax_t.set_title(f"{view.scenario}, {view.condition}: {view.n_runs} runs", fontsize=9)
    for bars, values in ((a["p95"], view.p95_final), (a["median"], view.median_final)):
        for rect, value, color in zip(bars, values, colors):
            rect.set_width(value)
            rect.set_facecolor(color)
    a["final_bound"].set_xdata([view.bound[-1], view.bound[-1]])
    for text in a["lost"]:
        text.remove()
    a["lost"] = _lost_labels(view, ax_f)
    _color_tick_labels(ax_f, colors, method)
    # drawn over the kept background: the curves, the bars, the labels and the method names (the y axis of the
    # right panel, whose tick labels take the colours)
    return [*a["curves"], a["bound"], *a["p95"], *a["median"], a["final_bound"], *a["lost"], ax_t.title,
            ax_f.yaxis]


def comparison_widget(table: ComparisonTable | None = None) -> Any:
    """Scenario, error condition and a method to highlight over the view (the committed table, or ``table``); a
    method that does not run on the chosen scenario highlights nothing.

    Examples
    --------
    >>> panel = comparison_widget()
    >>> [c.description for c in panel.children[0].children]
    ['scenario', 'error condition', 'highlight']
    """
    import ipywidgets as w

    t = _table(table)
    style = {"description_width": "initial"}
    sliders = {
        "scenario": w.Dropdown(options=list(dict.fromkeys(t.scenario.tolist())), value="circle",
                               description="scenario", style=style),
        "condition": w.Dropdown(options=list(dict.fromkeys(t.condition.tolist())), value="white",
                                description="error condition", style=style),
        "method": w.Dropdown(options=["all"] + list(dict.fromkeys(t.method.tolist())), value="all",
                             description="highlight", style=style),
    }

    @functools.lru_cache(maxsize=64)
    def view(scenario: str, condition: str) -> ComparisonView:
        return comparison_view(scenario, condition, table=t)

    def draw(fig: Figure, scenario: str, condition: str, method: str) -> Any:
        v = view(scenario, condition)
        return plot_comparison_view(v, fig, method=method if method in v.methods else "all")

    # the lowest lower limit of the RMSE axis over the table's scenarios: set before the first update (the first
    # picture is drawn by then), so that the background kept for the updates fits every scenario's bound
    lowest = max(0.5, 0.5 * float(np.nanmin(t.bound_curves))) if t.bound_curves is not None else None

    def update(fig: Figure, scenario: str, condition: str, method: str) -> Any:
        v = view(scenario, condition)
        ax_t = fig.axes[0]
        if lowest is not None and not getattr(ax_t, "_uwtutor_lowest", False):    # once per axes (a redraw makes
            setattr(ax_t, "_uwtutor_lowest", True)  # noqa: B010  (new ones); an attribute of our own on the Axes
            ax_t.set_ylim(min(lowest, ax_t.get_ylim()[0]), 5e3)
        return update_comparison_view(fig, v, method=method if method in v.methods else "all")

    return slider_panel(sliders, draw, update)


#: Zero-argument callables running each widget's computation at its defaults (wired into the registry).
COMPUTE_FUNCTIONS: dict[str, Callable[[], Any]] = {
    "ch10 comparison": comparison_view,
}
