r"""Chapter 9 widget: paper E's OR-VMLBL-KF on one dive, with the outliers, the test and the epoch spacing chosen.

The compute function ``outlier_view`` draws one of paper E's simulated dives, adds outliers of the chosen
amplitude and pattern, runs the whole method (``pipelines.or_vmlbl_kf``) and returns what the plot shows: the
range errors with the flags of the range filter, and the position errors of the fixes before and after the
cascade filter.
"""

from __future__ import annotations

import functools
import warnings
from dataclasses import dataclass
from typing import Any, Callable, Mapping

import matplotlib.pyplot as plt
from matplotlib.figure import Figure
import numpy as np

from .._validate import as_finite, as_int
from ..errors import IllConditionedWarning
from ..filters.base import FilterResult
from ..filters.robust import robust_range_kf
from ..pipelines import or_vmlbl_kf
from ..ranging import Outliers, RangeErrorModel
from ..scenarios import paper_e
from ._panel import keep, kept, rescale, slider_panel

__all__ = ["PATTERNS", "OutlierView", "outlier_view", "plot_outlier_view", "outlier_widget", "COMPUTE_FUNCTIONS"]

#: The outlier patterns the widget offers: paper E's two patches, isolated outliers (2 % of the epochs, random
#: sign), and one long one-sided patch of 40 epochs from 500 s.
PATTERNS = ("paper", "isolated", "long patch")


@dataclass(frozen=True)
class OutlierView:
    r"""What the chapter-9 widget shows for one setting (returned by ``outlier_view``).

    Shapes: ``K`` epochs, ``J`` fixes.

    Attributes
    ----------
    amplitude : float
        Outlier size [m].
    pattern : str
        The outlier pattern, one of ``PATTERNS``.
    delta : float
        The test's :math:`\delta`.
    test : str
        The range filter's test, ``"paper"`` or ``"chi2"``.
    spacing : int
        Epochs between the four epochs of a fix.
    reacquire : bool
        Whether the range filter re-acquires after 20 consecutive rejections.
    times : ndarray, shape (K,)
        Epoch times [s].
    range_error : ndarray, shape (K,)
        Measured minus true slant range [m].
    plain_error : ndarray, shape (K,)
        The standard KF's range minus the true range [m].
    robust_error : ndarray, shape (K,)
        The outlier-rejecting KF's range minus the true range [m].
    outlier : ndarray of bool, shape (K,)
        The injected outliers.
    flagged : ndarray of bool, shape (K,)
        The ranges the filter classed as outliers.
    fix_times : ndarray, shape (J,)
        Times of the fixes [s].
    fix_error : ndarray, shape (J,)
        Horizontal position error of OR-VMLBL (the fixes) [m].
    track_error : ndarray, shape (J,)
        Horizontal position error of OR-VMLBL-KF (the cascade filter) [m].
    summary : dict of float
        ``"flagged"`` (fraction of the outliers flagged), ``"good_flagged"`` (fraction of the good ranges flagged),
        ``"rms_fix"``, ``"rms_track"`` [m], ``"within_10_fix"``, ``"within_10_track"`` (fraction of fixes with an
        error under 10 % of the slant range).
    filtered : bool
        False in the widget's first picture of a new setting: the measured ranges and the outliers only, the
        filters' arrays NaN (nothing flagged, no fixes) and the summary NaN, while the filters run.

    Examples
    --------
    >>> # a fix every 300 s: fewer fixes, faster
    >>> view = outlier_view(spacing=300, seed=0)
    >>> # paper E's two patches: 10 and 20 outliers
    >>> view.times.shape, int(view.outlier.sum())
    ((1201,), 30)
    """

    amplitude: float
    pattern: str
    delta: float
    spacing: int
    test: str
    reacquire: bool
    times: np.ndarray
    range_error: np.ndarray
    plain_error: np.ndarray
    robust_error: np.ndarray
    outlier: np.ndarray
    flagged: np.ndarray
    fix_times: np.ndarray
    fix_error: np.ndarray
    track_error: np.ndarray
    summary: dict[str, float]
    filtered: bool = True


@functools.lru_cache(maxsize=4)
def _dive(seed: int) -> tuple[paper_e.Dive, Mapping[str, Any]]:
    """Paper E's dive for this seed and the state of the stream after it (no control changes them; kept for the
    widget's next setting, never modified)."""
    rng = np.random.default_rng(seed)
    dive = paper_e.make(rng, 1, outlier_onsets=(), outlier_counts=(), outlier_two_sided=())
    return dive, rng.bit_generator.state


_PLAIN: dict[tuple[float, str, int], FilterResult] = {}


def _standard_kf(amplitude: float, pattern: str, seed: int, ranges: np.ndarray) -> FilterResult:
    """The standard KF on these ranges, which depend on the outliers alone (not on the test, δ, the spacing or
    re-acquisition): kept for the last few outlier settings."""
    key = (amplitude, pattern, seed)
    if key not in _PLAIN:
        if len(_PLAIN) >= 16:
            _PLAIN.pop(next(iter(_PLAIN)))
        _PLAIN[key] = robust_range_kf(ranges, 1.0, test="none")
    return _PLAIN[key]


def _measured(a: float, pattern: str, seed: int) -> tuple[paper_e.Dive, np.ndarray, np.ndarray, np.ndarray,
                                                          np.ndarray]:
    """The dive, its epoch times, true slant ranges, the measured ranges with the outliers, and the outliers' mask
    (checked arguments)."""
    dive, state = _dive(seed)
    rng = np.random.default_rng()
    rng.bit_generator.state = state                     # where the stream stood after the dive was drawn
    times = np.asarray(dive.times)
    truth_r = np.asarray(dive.true_slant_ranges[0])
    model: RangeErrorModel
    if pattern == "paper":
        model = Outliers((300.0,), 10, a) + Outliers((700.0,), 20, a, two_sided=True)
    elif pattern == "isolated":
        model = Outliers((), 1, a, two_sided=True, probability=0.02)
    else:
        model = Outliers((500.0,), 40, a)
    e, mask = model.sample_with_mask(truth_r, times, rng)
    return dive, times, truth_r, np.asarray(dive.slant_ranges[0]) + e, mask


def _measured_view(amplitude: float, pattern: str, delta: float, spacing: int, test: str, reacquire: bool,
                   seed: int = 0) -> OutlierView:
    """The widget's first picture of a new setting (``OutlierView.filtered`` False): the measured ranges of
    ``outlier_view`` with the same arguments, without running the filters."""
    dive, times, truth_r, ranges, mask = _measured(float(amplitude), pattern, int(seed))
    none = np.full(len(times), np.nan)
    return OutlierView(amplitude=float(amplitude), pattern=pattern, delta=float(delta), spacing=int(spacing),
                       test=test, reacquire=bool(reacquire), times=times, range_error=ranges - truth_r,
                       plain_error=none, robust_error=none, outlier=mask, flagged=np.zeros(len(times), bool),
                       fix_times=np.empty(0), fix_error=np.empty(0), track_error=np.empty(0),
                       summary=dict.fromkeys(("flagged", "good_flagged", "rms_fix", "rms_track", "within_10_fix",
                                              "within_10_track"), float("nan")), filtered=False)


#: The range filter's results, by (amplitude, pattern, seed, range options): the last few.
_RANGE_RUNS: dict[tuple[float, str, int, float, str, bool], FilterResult] = {}


def _range_run(key: tuple[float, str, int, float, str, bool]) -> FilterResult | None:
    """The range filter's result kept for ``key`` (a new spacing reuses it: only the fixes and the cascade filter
    depend on the spacing), or None."""
    return _RANGE_RUNS.get(key)


def _keep_range_run(key: tuple[float, str, int, float, str, bool], result: FilterResult) -> None:
    if len(_RANGE_RUNS) >= 16:
        _RANGE_RUNS.pop(next(iter(_RANGE_RUNS)), None)
    _RANGE_RUNS[key] = result


def outlier_view(amplitude: float = 80.0, pattern: str = "paper", delta: float = 0.03, spacing: int = 100,
                 test: str = "paper", reacquire: bool = True, seed: int = 0) -> OutlierView:
    r"""Run paper E's OR-VMLBL-KF on one simulated dive with the chosen outliers.

    Parameters
    ----------
    amplitude : float, default 80
        Outlier size [m], 0 to 500.
    pattern : str, default "paper"
        One of ``PATTERNS``.
    delta : float, default 0.03
        Paper E's tolerance, in (0, 0.5].
    spacing : int, default 100
        Epochs (seconds) between the four epochs of a fix, 10 to 300.
    test : {"paper", "chi2"}, default "paper"
        The range filter's test (the chi-square gate at 99 %).
    reacquire : bool, default True
        Re-acquisition after 20 consecutive rejections.
    seed : int, default 0
        Seed of the dive and of the outliers.

    Returns
    -------
    OutlierView

    Examples
    --------
    >>> import numpy as np
    >>> view = outlier_view(amplitude=80.0, pattern="paper", spacing=300, seed=0)
    >>> # every outlier flagged, no good range
    >>> view.summary["flagged"], view.summary["good_flagged"]
    (1.0, 0.0)
    >>> plain, robust = np.abs(view.plain_error).max(), np.abs(view.robust_error).max()
    >>> # the standard KF follows the outliers; OR-VMLBL-KF not
    >>> bool(plain > 50.0), bool(robust < 0.2 * plain)
    (True, True)
    """
    a = float(as_finite("amplitude", amplitude, ndim=0))
    if not 0.0 <= a <= 500.0:
        raise ValueError(f"amplitude must lie between 0 and 500 m; got {a:g}")
    if pattern not in PATTERNS:
        raise ValueError(f"pattern must be one of {PATTERNS}; got {pattern!r}")
    d = float(as_finite("delta", delta, ndim=0))
    if not 0.0 < d <= 0.5:
        raise ValueError(f"delta must lie in (0, 0.5]; got {d:g}")
    s = as_int("spacing", spacing, minimum=10)
    if s > 300:
        raise ValueError(f"spacing must be at most 300 s (a fix needs 3 spacings within the 1200 s dive); got {s}")
    if test not in ("paper", "chi2"):
        raise ValueError(f"test must be 'paper' or 'chi2'; got {test!r}")
    if not isinstance(reacquire, (bool, np.bool_)):
        raise TypeError(f"reacquire must be True or False; got {reacquire!r}")
    seed = as_int("seed", seed, minimum=0)
    dive, times, truth_r, ranges, mask = _measured(a, pattern, seed)
    options = {"delta": d, "test": test, "reacquire": 20 if reacquire else None}
    key = (a, pattern, seed, d, test, bool(reacquire))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IllConditionedWarning)
        out = or_vmlbl_kf(dive.dr_positions[0], ranges, ship_positions=dive.ship_positions[0], depth=dive.depth,
                          spacing=s, range_options=options, range_result=_range_run(key))
    range_run = out.ranges
    assert range_run is not None                    # preprocess=True (the default): the range filter ran
    _keep_range_run(key, range_run)
    plain = _standard_kf(a, pattern, seed, ranges)
    truth = np.asarray(dive.true_positions[0])[out.now]
    fix_err = np.linalg.norm(out.fixes - truth, axis=-1)
    track_err = np.linalg.norm(out.filtered - truth, axis=-1)
    flagged = np.asarray(range_run.extras["outlier"])
    slant = truth_r[out.now]

    def rms(x: np.ndarray) -> float:
        return float(np.sqrt(np.nanmean(x**2)))

    summary = {
        "flagged": float(flagged[mask].mean()) if mask.any() else float("nan"),
        "good_flagged": float(flagged[~mask].mean()),
        "rms_fix": rms(fix_err), "rms_track": rms(track_err),
        "within_10_fix": float(np.mean(fix_err <= 0.1 * slant)),
        "within_10_track": float(np.mean(track_err <= 0.1 * slant)),
    }
    return OutlierView(amplitude=a, pattern=pattern, delta=d, spacing=s, test=test, reacquire=bool(reacquire),
                       times=times, range_error=ranges - truth_r, plain_error=plain.x[:, 0] - truth_r,
                       robust_error=range_run.x[:, 0] - truth_r, outlier=mask, flagged=flagged,
                       fix_times=out.fix_times, fix_error=fix_err, track_error=track_err, summary=summary)


def _range_limit(view: OutlierView) -> float:
    """The range-error axis: symmetric, with a band above the largest outlier or filter error for the legend."""
    if not view.filtered:                               # the filters' curves are still to come
        return max(10.0, 1.6 * view.amplitude)
    reach = max(view.amplitude, float(np.nanmax(np.abs(view.plain_error))), float(np.nanmax(np.abs(view.robust_error))))
    return max(10.0, 1.6 * reach)


def plot_outlier_view(view: OutlierView, fig: Figure | None = None) -> Figure:
    """Draw an ``OutlierView``: range errors with the flags (top) and position errors of the fixes (bottom).

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> fig = plot_outlier_view(outlier_view(spacing=300))
    >>> # range errors with the flags; position errors of the fixes
    >>> len(fig.axes)
    2
    >>> plt.close(fig)
    """
    fig = fig or plt.figure(figsize=(7.8, 5.0))
    ax_r, ax_p = fig.subplots(2, 1, sharex=True)
    t = view.times
    (measured,) = ax_r.plot(t, view.range_error, ".", ms=2, color="0.6", label="measured")
    (plain,) = ax_r.plot(t, view.plain_error, color="C0", lw=1, label="standard KF")
    (robust,) = ax_r.plot(t, view.robust_error, color="C3", lw=1, label=f"KF with the {view.test} test")
    (flagged,) = ax_r.plot(t[view.flagged], view.range_error[view.flagged], "x", ms=3, color="k", label="flagged")
    lim = _range_limit(view)
    ax_r.set_ylim(-lim, lim)
    ax_r.set_ylabel("range error [m]")
    ax_r.legend(fontsize=6, ncol=4, loc="upper left")
    (fixes,) = ax_p.semilogy(view.fix_times, view.fix_error, color="0.5", lw=0.8, label="OR-VMLBL (fixes)")
    (track,) = ax_p.semilogy(view.fix_times, view.track_error, color="C3", lw=1.2, label="OR-VMLBL-KF")
    ax_p.set_xlabel("time [s]")
    ax_p.set_ylabel("position error [m]")
    ax_p.legend(fontsize=7)
    _outlier_titles(view, ax_r, ax_p)
    fig.tight_layout()
    return keep(fig, measured=measured, plain=plain, robust=robust, flagged=flagged, fixes=fixes, track=track,
                test=view.test)


def _outlier_titles(view: OutlierView, ax_r: Any, ax_p: Any) -> list[Any]:
    if not view.filtered:
        ax_r.set_title(f"{view.pattern} outliers of {view.amplitude:g} m, δ = {view.delta:.3g}: the filters are "
                       "running…", fontsize=8)
        ax_p.set_title(f"epochs {view.spacing} s apart: fixes and cascade filter to come…", fontsize=8)
        return [ax_r.title, ax_p.title]
    s = view.summary
    # δ rounded as its slider shows it (three significant digits)
    ax_r.set_title(f"{view.pattern} outliers of {view.amplitude:g} m, δ = {view.delta:.3g}: "
                   f"{100 * s['flagged']:.0f} % flagged, {100 * s['good_flagged']:.1f} % of good ranges flagged",
                   fontsize=8)
    ax_p.set_title(f"epochs {view.spacing} s apart: RMS {s['rms_fix']:.1f} m → {s['rms_track']:.1f} m; within 10 %: "
                   f"{100 * s['within_10_fix']:.1f} % → {100 * s['within_10_track']:.1f} %", fontsize=8)
    return [ax_r.title, ax_p.title]


def update_outlier_view(fig: Figure, view: OutlierView) -> list[Any] | None:
    """Put another ``OutlierView`` into a figure drawn by ``plot_outlier_view``; returns what changed (``None``, to
    draw anew, when the test changes: its name is in the legend; a view of the measured ranges alone, whose
    filter curves are hidden, leaves the legend to the full view that follows)."""
    a = kept(fig)
    if a is None:                   # not a figure of the plot function: drawn anew
        return None
    if a["test"] != view.test and view.filtered:
        return None
    ax_r, ax_p = fig.axes[:2]
    if not view.filtered:           # the measured ranges only, over the kept axes (drawn at once) ...
        a["measured"].set_ydata(view.range_error)
        a["plain"].set_ydata(view.plain_error)
        a["robust"].set_ydata(view.robust_error)
        for name in ("flagged", "fixes", "track"):
            a[name].set_data([], [])
        lim = _range_limit(view)
        if lim > ax_r.get_ylim()[1]:    # ... unless the new outliers outgrow them
            ax_r.set_ylim(-1.3 * lim, 1.3 * lim)
        return [a["measured"], a["plain"], a["robust"], a["flagged"], a["fixes"], a["track"],
                *_outlier_titles(view, ax_r, ax_p)]
    t = view.times
    a["measured"].set_ydata(view.range_error)
    a["plain"].set_ydata(view.plain_error)
    a["robust"].set_ydata(view.robust_error)
    a["flagged"].set_data(t[view.flagged], view.range_error[view.flagged])
    lim, shown = _range_limit(view), ax_r.get_ylim()[1]
    # the limit shown is kept while the data and the legend fit in it and fill at least half of it (the axes, and
    # the pixels kept of them, stay as they are); a new one gets room to grow by a few steps of the size slider
    if not lim <= shown <= 2.0 * lim:
        lim = 1.3 * lim if lim > shown else lim
        ax_r.set_ylim(-lim, lim)
    a["fixes"].set_data(view.fix_times, view.fix_error)
    a["track"].set_data(view.fix_times, view.track_error)
    rescale(ax_p)
    return [a["measured"], a["plain"], a["robust"], a["flagged"], a["fixes"], a["track"],
            *_outlier_titles(view, ax_r, ax_p)]


def outlier_widget() -> Any:
    """Outlier amplitude and pattern, the test and its δ, the epoch spacing and re-acquisition over the view.

    Each new setting runs paper E's whole method on the chapter's dive, as the chapter does (the range filter, the
    fixes and the cascade filter over 1201 epochs, and the standard KF when the outliers change; a new spacing
    reuses the range filter): a quarter to half a second of computation. In a live kernel the measured ranges of
    the new setting are shown at once, titled "the filters are running…", and the filters' answer replaces them
    when it is ready (``_panel.slider_panel``'s ``refine``); a setting shown before comes back at once.

    Examples
    --------
    >>> panel = outlier_widget()
    >>> [c.description for row in panel.children[:2] for c in row.children]
    ['outlier size [m]', 'pattern', 'δ', 'epoch spacing [s]', 'test', 're-acquire']
    """
    import ipywidgets as w

    style = {"description_width": "initial"}
    sliders = {
        "amplitude": w.FloatSlider(value=80.0, min=0.0, max=200.0, step=10.0, description="outlier size [m]",
                                   continuous_update=False, style=style),
        "pattern": w.Dropdown(options=list(PATTERNS), value="paper", description="pattern", style=style),
        "delta": w.FloatLogSlider(value=0.03, base=10, min=-3.0, max=-0.5, step=0.1, description="δ",
                                  continuous_update=False, style=style),
        "spacing": w.IntSlider(value=100, min=10, max=300, step=10, description="epoch spacing [s]",
                               continuous_update=False, style=style),
        "test": w.Dropdown(options=["paper", "chi2"], value="paper", description="test", style=style),
        "reacquire": w.Checkbox(value=True, description="re-acquire", style=style),
    }
    view = functools.lru_cache(maxsize=256)(outlier_view)
    full: dict[tuple[Any, ...], OutlierView] = {}                 # the views computed, by setting (as view's cache)

    def answer(coarse: bool, **p: Any) -> OutlierView:
        key = tuple(p.values())
        if key in full or not coarse:
            return full.setdefault(key, view(**p))
        return _measured_view(**p)          # the new ranges at once; the filters' answer follows

    def refine(**p: Any) -> Callable[[], Any] | None:
        return None if tuple(p.values()) in full else functools.partial(answer, False, **p)

    return slider_panel(sliders, lambda fig, coarse, **p: plot_outlier_view(answer(coarse, **p), fig),
                        lambda fig, coarse, **p: update_outlier_view(fig, answer(coarse, **p)), refine=refine)


#: Zero-argument callables running each widget's computation at its defaults (wired into the registry).
COMPUTE_FUNCTIONS: dict[str, Callable[[], Any]] = {
    "ch09 OR-VMLBL-KF": outlier_view,
}
