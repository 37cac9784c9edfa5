"""Chapter 1 widgets: the Mackenzie sound speed, and the four range error models on one simulated approach."""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any, Callable

import matplotlib.pyplot as plt
from matplotlib.figure import Figure
import numpy as np

from .. import acoustics, motion, ranging
from .._validate import as_scalar, as_seed
from ._panel import keep, kept, rescale, slider_panel

__all__ = [
    "SoundSpeedView",
    "sound_speed_view",
    "plot_sound_speed_view",
    "sound_speed_widget",
    "RangeErrorView",
    "range_error_view",
    "plot_range_error_view",
    "range_error_widget",
]


# --- Chapter 1: sound speed ---------------------------------------------------------------------------------------

@dataclass(frozen=True)
class SoundSpeedView:
    """What the sound-speed widget shows for one choice of temperature, salinity and depth.

    Attributes
    ----------
    temperature : float
        The chosen temperature [deg C].
    salinity : float
        The chosen salinity [PSU].
    depth : float
        The chosen depth [m].
    speed : float
        Mackenzie sound speed there [m/s].
    sensitivity : dict of float
        Partial derivatives of the speed: ``"temperature"`` [m/s per deg C], ``"salinity"`` [m/s per PSU],
        ``"depth"`` [m/s per m].
    range_error_per_km : float
        Range error per kilometre of true range made by a navigator that assumes 1500 m/s here [m/km].
    temperatures : ndarray
        A temperature grid [deg C].
    speed_vs_temperature : ndarray
        The speed over that grid, salinity and depth held [m/s].
    depths : ndarray
        A depth grid [m].
    speed_vs_depth : ndarray
        The speed over that grid, temperature and salinity held [m/s].

    Examples
    --------
    >>> view = sound_speed_view(temperature=10.0, salinity=35.0, depth=1000.0)
    >>> round(view.speed, 1), view.speed_vs_depth.shape
    (1506.3, (61,))
    """

    temperature: float
    salinity: float
    depth: float
    speed: float
    sensitivity: dict[str, float]
    range_error_per_km: float
    temperatures: np.ndarray
    speed_vs_temperature: np.ndarray
    depths: np.ndarray
    speed_vs_depth: np.ndarray


def sound_speed_view(temperature: float = 10.0, salinity: float = 35.0, depth: float = 1000.0) -> SoundSpeedView:
    """Compute everything the sound-speed widget shows (see :class:`SoundSpeedView`).

    Sensitivities are central differences of the Mackenzie equation (steps 0.01 deg C, 0.01 PSU, 1 m; one-sided at
    the surface).

    Examples
    --------
    >>> view = sound_speed_view(temperature=10.0, salinity=35.0, depth=1000.0)
    >>> # a navigator assuming 1500 m/s comes up short
    >>> round(view.speed, 1), round(view.range_error_per_km, 1)
    (1506.3, -4.2)
    >>> {name: round(d, 3) for name, d in view.sensitivity.items()}
    {'temperature': 3.601, 'salinity': 1.238, 'depth': 0.017}
    """
    T = as_scalar("temperature", temperature)
    S = as_scalar("salinity", salinity)
    D = as_scalar("depth", depth, domain="nonnegative")
    c = float(acoustics.sound_speed(T, S, D))            # scalar arguments: a float already
    steps = {"temperature": 0.01, "salinity": 0.01, "depth": 1.0}
    args = {"temperature": T, "salinity": S, "depth": D}
    sens: dict[str, float] = {}
    for name, h in steps.items():
        lo, hi = dict(args), dict(args)
        lo[name] = max(args[name] - h, 0.0) if name == "depth" else args[name] - h  # no negative depth
        hi[name] = args[name] + h
        sens[name] = (float(acoustics.sound_speed(**hi)) - float(acoustics.sound_speed(**lo))) / (hi[name] - lo[name])
    temperatures = np.linspace(2.0, 30.0, 57)
    depths = np.linspace(0.0, 6000.0, 61)
    return SoundSpeedView(
        temperature=T, salinity=S, depth=D, speed=c, sensitivity=sens,
        range_error_per_km=1000.0 * (1500.0 / c - 1.0),
        temperatures=temperatures, speed_vs_temperature=np.asarray(acoustics.sound_speed(temperatures, S, D)),
        depths=depths, speed_vs_depth=np.asarray(acoustics.sound_speed(T, S, depths)),
    )


def plot_sound_speed_view(view: SoundSpeedView, fig: Figure | None = None) -> Figure:
    """Draw a :class:`SoundSpeedView`: speed against temperature and against depth, the chosen point marked.

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> fig = plot_sound_speed_view(sound_speed_view(temperature=10.0))
    >>> # speed against temperature, and against depth
    >>> len(fig.axes), bool(fig.axes[1].yaxis_inverted())
    (2, True)
    >>> plt.close(fig)
    """
    fig = fig or plt.figure(figsize=(7.0, 3.2))
    ax_t, ax_d = fig.subplots(1, 2)
    (curve_t,) = ax_t.plot(view.temperatures, view.speed_vs_temperature)
    (point_t,) = ax_t.plot([view.temperature], [view.speed], "o", color="C3")
    ax_t.set_xlabel("temperature [°C]")
    ax_t.set_ylabel("sound speed [m/s]")
    ax_t.set_title(" ", fontsize=9)
    (curve_d,) = ax_d.plot(view.speed_vs_depth, view.depths)
    (point_d,) = ax_d.plot([view.speed], [view.depth], "o", color="C3")
    ax_d.invert_yaxis()
    ax_d.set_xlabel("sound speed [m/s]")
    ax_d.set_ylabel("depth [m]")
    ax_d.set_title(" ", fontsize=9)
    title = fig.suptitle(" ", fontsize=10)
    keep(fig, curve_t=curve_t, point_t=point_t, curve_d=curve_d, point_d=point_d, title=title)
    _sound_speed_texts(view, fig, title)
    fig.tight_layout()
    return fig


def _sound_speed_texts(view: SoundSpeedView, fig: Figure, title: Any) -> list[Any]:
    ax_t, ax_d = fig.axes[:2]
    ax_t.set_title(f"S = {view.salinity:.1f} PSU, D = {view.depth:.0f} m", fontsize=9)
    ax_d.set_title(f"T = {view.temperature:.1f} °C, S = {view.salinity:.1f} PSU", fontsize=9)
    title.set_text(f"c = {view.speed:.2f} m/s;  assuming 1500 m/s costs {view.range_error_per_km:+.1f} m per km")
    return [ax_t.title, ax_d.title, title]


def update_sound_speed_view(fig: Figure, view: SoundSpeedView) -> list[Any] | None:
    """Put another :class:`SoundSpeedView` into a figure drawn by ``plot_sound_speed_view``; returns what changed
    (``None`` for a figure that function did not draw: it is drawn anew)."""
    a = kept(fig)
    if a is None:                   # not a figure the plot function drew: draw it anew
        return None
    a["curve_t"].set_data(view.temperatures, view.speed_vs_temperature)
    a["point_t"].set_data([view.temperature], [view.speed])
    a["curve_d"].set_data(view.speed_vs_depth, view.depths)
    a["point_d"].set_data([view.speed], [view.depth])
    rescale(*fig.axes[:2])
    return [a["curve_t"], a["point_t"], a["curve_d"], a["point_d"], *_sound_speed_texts(view, fig, a["title"])]


def sound_speed_widget() -> Any:
    """Sliders for temperature, salinity and depth over the Mackenzie sound speed (chapter 1).

    Examples
    --------
    >>> # draws the first picture; works without a browser
    >>> panel = sound_speed_widget()
    >>> [slider.description for slider in panel.children[0].children]
    ['T [°C]', 'S [PSU]', 'D [m]']
    >>> image = panel.children[2].children[0]
    >>> before = image.value
    >>> # a warmer sea: the picture is drawn again
    >>> panel.children[0].children[0].value = 20.0
    >>> image.value != before
    True
    """
    import ipywidgets as w

    style = {"description_width": "initial"}
    sliders = {
        "temperature": w.FloatSlider(value=10.0, min=2.0, max=30.0, step=0.5, description="T [°C]",
                                     continuous_update=False, style=style),
        "salinity": w.FloatSlider(value=35.0, min=25.0, max=40.0, step=0.5, description="S [PSU]",
                                  continuous_update=False, style=style),
        "depth": w.FloatSlider(value=1000.0, min=0.0, max=6000.0, step=100.0, description="D [m]",
                               continuous_update=False, style=style),
    }
    view = functools.lru_cache(maxsize=256)(sound_speed_view)
    return slider_panel(sliders, lambda fig, **p: plot_sound_speed_view(view(**p), fig),
                        lambda fig, **p: update_sound_speed_view(fig, view(**p)))


# --- Chapter 1: range error models ----------------------------------------------------------------------------------

@dataclass(frozen=True)
class RangeErrorView:
    """Range errors of each model along one simulated approach to a beacon (chapter 1).

    Attributes
    ----------
    times : ndarray, shape (K,)
        Ping times [s].
    true_ranges : ndarray, shape (K,)
        Horizontal range to the beacon [m].
    errors : dict of ndarray
        The error of each model, in the order additive, multiplicative (sound speed), slow bias, outliers, and
        their sum under ``"total"``.

    Examples
    --------
    >>> view = range_error_view(seed=1)
    >>> view.times.shape, list(view.errors)
    ((151,), ['additive', 'multiplicative', 'slow bias', 'outliers', 'total'])
    """

    times: np.ndarray
    true_ranges: np.ndarray
    errors: dict[str, np.ndarray]


def range_error_view(noise_sigma: float = 0.7, assumed_speed: float = 1470.0, bias_mean: float = 5.0,
                     bias_sigma: float = 3.0, bias_time_constant: float = 200.0, outlier_amplitude: float = 80.0,
                     seed: int = 1) -> RangeErrorView:
    """Simulate each range error model on a 1500 s approach to a beacon at 2 m/s with pings every 10 s.

    The track starts 3000 m from the beacon (paper D's setting); the true sound speed is N(1500, 1) m/s per ping.
    Outliers: a patch of 5 one-sided ones at 400 s and 8 two-sided ones at 1000 s (paper E's kinds).

    Examples
    --------
    >>> import numpy as np
    >>> view = range_error_view(noise_sigma=0.7, outlier_amplitude=80.0, seed=1)
    >>> # 3 km out, a ping every 10 s
    >>> round(float(view.true_ranges[0]), 1), view.times.shape
    (3026.5, (151,))
    >>> parts = [err for name, err in view.errors.items() if name != "total"]
    >>> (bool(np.allclose(view.errors["total"], sum(parts))),
    ...  bool(np.abs(view.errors["outliers"]).max() > 50.0))
    (True, True)
    """
    # each value checked under its own name (the models below would name theirs: sigma, mean, amplitude...)
    noise_sigma = as_scalar("noise_sigma", noise_sigma, domain="nonnegative")
    assumed_speed = as_scalar("assumed_speed", assumed_speed, domain="positive")
    bias_mean = as_scalar("bias_mean", bias_mean)
    bias_sigma = as_scalar("bias_sigma", bias_sigma, domain="nonnegative")
    bias_time_constant = as_scalar("bias_time_constant", bias_time_constant, domain="positive")
    outlier_amplitude = as_scalar("outlier_amplitude", outlier_amplitude)
    rng = np.random.default_rng(as_seed("seed", seed))    # never OS entropy: the figure is reproducible
    times = np.arange(0.0, 1500.0 + 1e-9, 10.0)
    track = motion.straight_track(times, start=(-3000.0, 400.0), speed=2.0, heading=0.0)
    true_ranges = np.asarray(ranging.horizontal_range(track.positions, (0.0, 0.0)))     # (K,): an array already
    models = {
        "additive": ranging.GaussianNoise(noise_sigma),
        "multiplicative": ranging.SoundSpeedMismatch(true_speed=1500.0, assumed_speed=assumed_speed, speed_sigma=1.0),
        "slow bias": ranging.SlowBias(mean=bias_mean, sigma=bias_sigma, time_constant=bias_time_constant),
        "outliers": (ranging.Outliers(onset_times=(400.0,), count=5, amplitude=outlier_amplitude)
                     + ranging.Outliers(onset_times=(1000.0,), count=8, amplitude=outlier_amplitude,
                                        two_sided=True)),
    }
    errors = {name: model.sample(true_ranges, times, rng) for name, model in models.items()}
    errors["total"] = sum(errors.values(), np.zeros(len(times)))
    return RangeErrorView(times=times, true_ranges=true_ranges, errors=errors)


def plot_range_error_view(view: RangeErrorView, fig: Figure | None = None) -> Figure:
    """Draw a :class:`RangeErrorView`: each model's error over time, and their sum against the true range.

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> fig = plot_range_error_view(range_error_view(seed=1))
    >>> # four models over time; their sum against range
    >>> len(fig.axes), len(fig.axes[0].lines)
    (2, 4)
    >>> plt.close(fig)
    """
    fig = fig or plt.figure(figsize=(7.0, 3.4))
    ax_t, ax_r = fig.subplots(1, 2)
    lines = {}
    for name, err in view.errors.items():
        if name != "total":
            (lines[name],) = ax_t.plot(view.times, err, label=name, lw=1)
    ax_t.set_xlabel("time [s]")
    ax_t.set_ylabel("range error [m]")
    (total,) = ax_r.plot(view.true_ranges, view.errors["total"], ".", ms=3, color="C4")
    ax_r.set_xlabel("true range [m]")
    ax_r.set_ylabel("total error [m]")
    fig.legend(loc="lower center", ncol=4, fontsize=8)
    fig.tight_layout(rect=(0.0, 0.08, 1.0, 1.0))
    return keep(fig, lines=lines, total=total)


def update_range_error_view(fig: Figure, view: RangeErrorView) -> list[Any] | None:
    """Put another :class:`RangeErrorView` into a figure drawn by ``plot_range_error_view``; returns what changed
    (``None`` for a figure that function did not draw: it is drawn anew)."""
    a = kept(fig)
    if a is None:                   # not a figure the plot function drew: draw it anew
        return None
    for name, line in a["lines"].items():
        line.set_data(view.times, view.errors[name])
    a["total"].set_data(view.true_ranges, view.errors["total"])
    rescale(*fig.axes[:2])
    return [*a["lines"].values(), a["total"]]


def range_error_widget() -> Any:
    """Sliders over the parameters of the four range error models (chapter 1).

    Examples
    --------
    >>> panel = range_error_widget()
    >>> [c.description for row in panel.children[:2] for c in row.children]
    ['σ white [m]', 'assumed c [m/s]', 'bias σ [m]', 'bias τ [s]', 'outlier size [m]']
    """
    import ipywidgets as w

    style = {"description_width": "initial"}
    sliders = {
        "noise_sigma": w.FloatSlider(value=0.7, min=0.0, max=10.0, step=0.1, description="σ white [m]",
                                     continuous_update=False, style=style),
        "assumed_speed": w.FloatSlider(value=1470.0, min=1440.0, max=1560.0, step=5.0,
                                       description="assumed c [m/s]", continuous_update=False, style=style),
        "bias_sigma": w.FloatSlider(value=3.0, min=0.0, max=20.0, step=0.5, description="bias σ [m]",
                                    continuous_update=False, style=style),
        "bias_time_constant": w.FloatSlider(value=200.0, min=10.0, max=1000.0, step=10.0,
                                            description="bias τ [s]", continuous_update=False, style=style),
        "outlier_amplitude": w.FloatSlider(value=80.0, min=0.0, max=200.0, step=5.0,
                                           description="outlier size [m]", continuous_update=False, style=style),
    }
    view = functools.lru_cache(maxsize=256)(range_error_view)
    return slider_panel(sliders, lambda fig, **p: plot_range_error_view(view(**p), fig),
                        lambda fig, **p: update_range_error_view(fig, view(**p)))


#: This chapter's widget computations at their default parameters (collected by ``uwtutor.widgets``).
COMPUTE_FUNCTIONS: dict[str, Callable[[], Any]] = {
    "ch01 sound speed": sound_speed_view,
    "ch01 range errors": range_error_view,
}
