"""Chapter 6 (paper C): the GPF explorer widget (a view, its plot, a thin widget).

Paper C's parameters, the maneuvering depth profile, the sensors and the EKF / MMPF / GPF comparison live in
:mod:`uwtutor.scenarios.paper_c` (importable from here too: ``PARAMETERS``,
``maneuvering_depth_profile``, ``simulate_depth_sensors``, ``run_depth_study``, ...). :func:`gpf_view` is the light
version behind the chapter's widget (a shorter profile, fewer particles).
"""

from __future__ import annotations

import copy
import functools
from dataclasses import dataclass
from typing import Any, Callable

import matplotlib.pyplot as plt
from matplotlib.figure import Figure
import numpy as np

from .._validate import as_int, as_scalar, check_work, readonly
from ..errors import deprecated_aliases
from ..filters import ExtendedKalmanFilter, GreyParticleFilter
from ..models.depth import DepthSensors, DepthSpeedPitch
from ..pipelines.depth_study import DepthStudy, run_depth_study  # noqa: F401 (chapter 6 calls ch06.run_depth_study)
from ..scenarios.paper_c import (FILTER_NAMES, PARAMETERS, DepthProfile, maneuvering_depth_profile,  # noqa: F401
                                 simulate_depth_sensors)
from ..scenarios.paper_c import PITCH_OFFSET as _PITCH_OFFSET
from ._panel import keep, kept, rescale, slider_panel

#: ``ch06.PAPER_C``, paper C's parameters as a dict, is ``paper_c.PARAMETERS.as_dict()`` (the old name, one release)
__getattr__ = deprecated_aliases(__name__, {"PAPER_C": ("uwtutor.scenarios.paper_c.PARAMETERS.as_dict()",
                                                       lambda: PARAMETERS.as_dict())})

__all__ = [                   # the paper's content above is documented in uwtutor.scenarios.paper_c
    "GPFView",
    "gpf_view",
    "plot_gpf_view",
    "gpf_widget",
    "COMPUTE_FUNCTIONS",
]

# --- the widget -----------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class GPFView:
    """What the GPF explorer shows: one run of a short dive with a noise change, the EKF against the GPF.

    Attributes
    ----------
    times : ndarray, shape (K,)
        Sample times [s].
    truth : ndarray, shape (K, 3)
        True depth, speed, pitch.
    measurements : ndarray, shape (K, 3)
        Sensor readings.
    estimates : dict of ndarray
        ``"EKF"`` and ``"GPF"`` estimates, shape (K, 3).
    rmse : dict of ndarray
        RMSE of each filter over the run (after its first second), shape (3,) [m, m/s, rad].
    ess : ndarray, shape (K,)
        The GPF's effective sample size after each update.
    noise_std : ndarray, shape (K, 3)
        The GPF's wavelet noise estimates.
    true_noise_std : ndarray, shape (K, 3)
        The sensors' true noise standard deviations.
    n_particles : int
        ``N``.
    n_grey : int
        Grey particles per step.

    Examples
    --------
    >>> view = gpf_view(n_particles=100, seed=1)
    >>> # 12 s at 20 Hz; depth, speed, pitch
    >>> view.times.shape, view.truth.shape, view.n_grey
    ((240,), (240, 3), 10)
    """

    times: np.ndarray
    truth: np.ndarray
    measurements: np.ndarray
    estimates: dict[str, np.ndarray]
    rmse: dict[str, np.ndarray]
    ess: np.ndarray
    noise_std: np.ndarray
    true_noise_std: np.ndarray
    n_particles: int
    n_grey: int


#: When the widget's dive changes its sensor noise [s]: the readings before it are the same whatever the change
#: (the same draws at the nominal level), and so are both filters' steps over them.
_NOISE_CHANGE_AT = 13.0

#: The filters' state at the noise change and their results before it, with the readings they ran over, by
#: filter and settings (the last few): a new change runs them over the readings after it only.
_BEFORE_CHANGE: dict[tuple[Any, ...], tuple[np.ndarray, Any, Any]] = {}


def _over_the_change(key: tuple[Any, ...], make: Callable[[], Any], z: np.ndarray, split: int) -> tuple[Any, Any]:
    """The run of the filter ``make()`` over the readings ``z``, in two parts: its results over the first ``split``
    readings and over the rest. The first part is taken from ``_BEFORE_CHANGE[key]`` when it ran over these same
    readings (a copy of the filter as it stood then runs the rest): a step depends on the steps before it only, so
    the parts are, bit for bit, those of one run over all of ``z``."""
    kept = _BEFORE_CHANGE.get(key)
    if kept is not None and np.array_equal(kept[0], z[:split]):
        filt = copy.deepcopy(kept[1])
        return kept[2], filt.run(z[split:])
    filt = make()
    head = filt.run(z[:split])
    if len(_BEFORE_CHANGE) >= 16:
        _BEFORE_CHANGE.pop(next(iter(_BEFORE_CHANGE)))
    _BEFORE_CHANGE[key] = (z[:split].copy(), copy.deepcopy(filt), head)
    return head, filt.run(z[split:])


@functools.lru_cache(maxsize=32)
def _dive_and_ekf(factor: float, seed: int) -> tuple[DepthProfile, np.ndarray, np.ndarray]:
    """The dive, its sensor readings and the EKF's estimates: what ``gpf_view`` computes that does not depend on
    the GPF's settings (kept for the widget's next setting; never modified)."""
    profile = maneuvering_depth_profile(noise_factors=(1.0, factor),
                                        noise_change_times=(_NOISE_CHANGE_AT,)).between(6.0, 18.0)
    rng = np.random.default_rng(seed)
    z = simulate_depth_sensors(profile, 1, rng)[0]
    R = np.diag(PARAMETERS.sensor_std ** 2)
    q = PARAMETERS.process_std
    motion, sensors = DepthSpeedPitch(T=profile.T, process_std=q), DepthSensors(R)
    head, tail = _over_the_change(("EKF", seed), lambda: ExtendedKalmanFilter(motion, sensors, z[0], R), z,
                                  _split(profile))
    return profile, z, readonly(np.concatenate([head.x, tail.x]))


def _split(profile: DepthProfile) -> int:
    """The number of samples before the noise change (at least one, and one short of all)."""
    return int(np.clip(np.searchsorted(profile.times, _NOISE_CHANGE_AT), 1, len(profile.times) - 1))


def gpf_view(n_particles: int = 200, grey_fraction: float = 0.1, noise_window: int = 50, noise_change: float = 3.0,
             seed: int = 1) -> GPFView:
    """Run the EKF and the GPF on 12 s of the dive whose sensor noise changes by ``noise_change`` at 13 s.

    The samples from 6 to 18 s of :func:`~uwtutor.scenarios.paper_c.maneuvering_depth_profile` (the pitch ramps to 20°
    at 8-11 s, the speed rises), with the noise nominal until 13 s and ``noise_change`` times nominal after; paper C's
    other parameters (T = 0.05 s, ``L`` = 30, the diagonal Q, fixed R for the EKF). Both filters start from the first
    reading.

    Parameters
    ----------
    n_particles : int, optional
        ``N`` of the GPF (the widget's default is small so that it recomputes in about 0.1 s).
    grey_fraction : float, optional
        :math:`N_\\mathrm{grey}/N`, in [0, 1).
    noise_window : int, optional
        Wavelet window length (>= 12, at most the dive's 240 samples).
    noise_change : float, optional
        Factor applied to the sensor noise from 13 s on (1e-3 to 1e3).
    seed : int, optional
        Seed of the sensor noise and of the GPF.

    Returns
    -------
    GPFView

    Examples
    --------
    >>> # the noise triples at 13 s
    >>> view = gpf_view(n_particles=200, noise_change=3.0, seed=1)
    >>> # RMSE of depth [m], speed [m/s], pitch [rad]
    >>> ekf, gpf = view.rmse["EKF"], view.rmse["GPF"]
    >>> # the GPF follows the new noise, the EKF does not
    >>> round(float(ekf[0]), 1), bool(gpf[0] < ekf[0])
    (0.3, True)
    >>> bool(view.ess.min() >= 1.0), bool(view.ess.max() <= view.n_particles)
    (True, True)
    """
    N = as_int("n_particles", n_particles, minimum=10)
    check_work("n_particles", 30 * N, "floats (n_particles x 3 states x the filter's working arrays)")
    grey_fraction = as_scalar("grey_fraction", grey_fraction)         # its range is the filter's to check
    window = as_int("noise_window", noise_window, minimum=1)
    # a factor beyond a thousand either way is not a change of sensor noise (its variances under- or overflow)
    factor = as_scalar("noise_change", noise_change, low=1e-3, high=1e3)
    seed = as_int("seed", seed, minimum=0)
    profile, z, ekf_x = _dive_and_ekf(factor, seed)
    if window > len(profile.times):
        raise ValueError(f"noise_window must be at most the dive's {len(profile.times)} samples; got {window}")
    R = np.diag(PARAMETERS.sensor_std ** 2)
    q = PARAMETERS.process_std
    motion, sensors = DepthSpeedPitch(T=profile.T, process_std=q), DepthSensors(R)
    head, tail = _over_the_change(
        ("GPF", N, grey_fraction, window, seed),
        lambda: GreyParticleFilter.from_gaussian(motion, sensors, z[0], R, N, np.random.default_rng(seed + 1000),
                                                 grey_fraction=grey_fraction, noise_window=noise_window,
                                                 grey_offset=[0.0, 0.0, _PITCH_OFFSET]),
        z, _split(profile))
    after = profile.times >= profile.times[0] + 1.0
    estimates = {"EKF": ekf_x, "GPF": np.concatenate([head.x, tail.x])}
    rmse = {k: np.sqrt(np.mean((v[after] - profile.truth[after]) ** 2, axis=0)) for k, v in estimates.items()}
    return GPFView(times=profile.times, truth=profile.truth, measurements=z, estimates=estimates, rmse=rmse,
                   ess=np.concatenate([head.extras["ess"], tail.extras["ess"]]),
                   noise_std=np.concatenate([head.extras["noise_std"], tail.extras["noise_std"]]),
                   true_noise_std=profile.sensor_std, n_particles=N, n_grey=int(round(grey_fraction * N)))


def plot_gpf_view(view: GPFView, fig: Figure | None = None) -> Figure:
    """Draw a :class:`GPFView`: pitch estimates, the wavelet noise estimate, the ESS, and the RMSE bars.

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> fig = plot_gpf_view(gpf_view(n_particles=100))
    >>> len(fig.axes)                      # pitch, noise estimate, ESS, RMSE bars
    4
    >>> plt.close(fig)
    """
    fig = fig or plt.figure(figsize=(7.6, 5.0))
    ax = fig.subplots(2, 2)
    t = view.times
    a = ax[0, 0]
    (readings,) = a.plot(t, np.degrees(view.measurements[:, 2]), ".", ms=1.5, color="0.7", label="pitch sensor")
    a.plot(t, np.degrees(view.truth[:, 2]), color="black", lw=1, label="truth")
    pitch = {name: a.plot(t, np.degrees(view.estimates[name][:, 2]), color=color, lw=1, label=name)[0]
             for name, color in (("EKF", "C3"), ("GPF", "C2"))}
    a.set_xlabel("time [s]")
    a.set_ylabel("pitch [°]")
    a.legend(fontsize=7, loc="lower right")
    a = ax[0, 1]
    (true_noise,) = a.plot(t, view.true_noise_std[:, 0], color="black", lw=1, label="true σ (depth)")
    (noise,) = a.plot(t, view.noise_std[:, 0], color="C2", lw=1, label="wavelet estimate")
    a.set_xlabel("time [s]")
    a.set_ylabel("depth noise σ [m]")
    a.legend(fontsize=7)
    a = ax[1, 0]
    (ess,) = a.plot(t, view.ess, color="C2", lw=1)
    a.set_ylim(0, view.n_particles * 1.05)
    a.set_xlabel("time [s]")
    a.set_ylabel("ESS of the GPF")
    a.set_title(f"N = {view.n_particles}, {view.n_grey} grey", fontsize=9)
    a = ax[1, 1]
    labels = ["depth [cm]", "speed [cm/s]", "pitch [0.1°]"]
    pos = np.arange(3)
    bars = {name: a.bar(pos + (i - 0.5) * 0.38, view.rmse[name] * _RMSE_SCALE, width=0.38, color=color, label=name)
            for i, (name, color) in enumerate((("EKF", "C3"), ("GPF", "C2")))}
    a.set_xticks(pos, labels, fontsize=8)
    a.set_ylabel("RMSE")
    a.legend(fontsize=7)
    fig.tight_layout()
    return keep(fig, readings=readings, pitch=pitch, true_noise=true_noise, noise=noise, ess=ess, bars=bars)


#: The bars' units: cm, cm/s and tenths of a degree.
_RMSE_SCALE = np.array([100.0, 100.0, 10 * 180 / np.pi])


def update_gpf_view(fig: Figure, view: GPFView) -> list[Any] | None:
    """Put another :class:`GPFView` into a figure drawn by ``plot_gpf_view``; returns what changed."""
    a = kept(fig)
    if a is None:                   # not a figure the plot function drew: draw it anew
        return None
    ax = fig.axes
    a["readings"].set_ydata(np.degrees(view.measurements[:, 2]))
    a["true_noise"].set_ydata(view.true_noise_std[:, 0])
    for name, line in a["pitch"].items():
        line.set_ydata(np.degrees(view.estimates[name][:, 2]))
    a["noise"].set_ydata(view.noise_std[:, 0])
    a["ess"].set_ydata(view.ess)
    top = ax[2].get_ylim()[1]
    if not 0.5 * top <= view.n_particles * 1.05 <= top:     # N outgrew the axis, or fills under half of it
        # up to the next 1, 2 or 5 x 10^k particles: the next moves of N fit (and blit) until N passes it
        ax[2].set_ylim(0, _round_up(view.n_particles) * 1.05)
    ax[2].set_title(f"N = {view.n_particles}, {view.n_grey} grey", fontsize=9)
    changed = [a["readings"], *a["pitch"].values(), a["true_noise"], a["noise"], a["ess"], ax[2].title]
    for name, bars in a["bars"].items():
        for rect, height in zip(bars, view.rmse[name] * _RMSE_SCALE):
            rect.set_height(height)
            changed.append(rect)
    # a quarter of the limits spanned is enough to keep them: the noise estimate and the bars change their
    # extent with every setting, and new limits draw the whole figure again
    rescale(ax[0], ax[1], ax[3], keep_within=0.25)
    return changed


def _round_up(n: int) -> float:
    """The smallest 1, 2 or 5 x 10^k that is >= ``n`` (``n`` > 0).

    Examples
    --------
    >>> _round_up(200), _round_up(250), _round_up(550)
    (200.0, 500.0, 1000.0)
    """
    power = 10.0 ** np.floor(np.log10(n))
    return float(next(m * power for m in (1.0, 2.0, 5.0, 10.0) if m * power >= n))


def gpf_widget() -> Any:
    """Sliders for the GPF's particle count, grey share and wavelet window, and the change of the sensor noise.

    Examples
    --------
    >>> panel = gpf_widget()
    >>> [c.description for row in panel.children[:2] for c in row.children]
    ['particles N', 'grey share', 'wavelet window', 'noise change ×']
    """
    import ipywidgets as w

    style = {"description_width": "initial"}
    sliders = {
        "n_particles": w.IntSlider(value=200, min=50, max=1000, step=50, description="particles N",
                                   continuous_update=False, style=style),
        "grey_fraction": w.FloatSlider(value=0.1, min=0.0, max=0.5, step=0.05, description="grey share",
                                       continuous_update=False, style=style),
        "noise_window": w.IntSlider(value=50, min=16, max=200, step=2, description="wavelet window",
                                    continuous_update=False, style=style),
        "noise_change": w.FloatSlider(value=3.0, min=0.25, max=5.0, step=0.25, description="noise change ×",
                                      continuous_update=False, style=style),
    }
    view = functools.lru_cache(maxsize=256)(gpf_view)
    return slider_panel(sliders, lambda fig, **p: plot_gpf_view(view(**p), fig),
                        lambda fig, **p: update_gpf_view(fig, view(**p)))


#: Zero-argument callables running each widget's computation at its default parameters (timed by ``make bench``).
COMPUTE_FUNCTIONS: dict[str, Callable[[], Any]] = {
    "ch06 grey particle filter": gpf_view,
}
