"""Chapter 6 (paper C): a maneuvering depth profile, the EKF / MMPF / GPF comparison, and the GPF explorer widget.

Paper C's experiment is a lake trial of a maneuvering AUV; the book simulates it instead:
:func:`maneuvering_depth_profile` makes the true depth, speed and pitch of a dive, a level leg and a climb, with a
sensor noise level that changes over time, :func:`simulate_depth_sensors` draws the three sensors' readings for
``M`` Monte Carlo runs, and :func:`run_depth_study` runs the filters of the comparison on them with paper C's
parameters. :func:`gpf_view` is the light version behind the chapter's widget (a shorter profile, fewer particles).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import matplotlib.pyplot as plt
import numpy as np

from .._validate import as_finite, as_int, as_nonnegative, as_positive, as_rng
from ..filters import (BootstrapParticleFilter, DepthEKF, DepthSpeedPitchModel, GreyParticleFilter,
                       MultipleModelParticleFilter, PitchManeuverModel)
from ._panel import slider_panel

__all__ = [
    "PAPER_C",
    "DepthProfile",
    "maneuvering_depth_profile",
    "simulate_depth_sensors",
    "DepthStudy",
    "run_depth_study",
    "FILTER_NAMES",
    "GPFView",
    "gpf_view",
    "plot_gpf_view",
    "gpf_widget",
    "COMPUTE_FUNCTIONS",
]

#: Paper C's parameters, in SI units (depth m, speed m/s, pitch rad). The paper prints R = diag(0.2², 5², 0.5²)
#: without units: read here as 0.2 m, 5 cm/s and 0.5°. Its process covariance is not positive semi-definite;
#: ``"process_std"`` keeps its diagonal (0.2 m, 1 cm/s, 0.5° per step) and drops the impossible off-diagonal terms.
PAPER_C: dict[str, Any] = {
    "T": 0.05,
    "n_particles": 1000,
    "n_grey": 100,
    "grey_window": 30,
    "noise_window": 50,
    "polynomial_order": 5,
    "wavelet": "db6",
    "sensor_std": np.array([0.2, 0.05, np.radians(0.5)]),
    "process_std": np.array([0.2, 0.01, np.radians(0.5)]),
    # Q exactly as printed, in the paper's units (m, cm/s, deg): not a covariance matrix
    "Q_as_printed": np.array([[0.2**2, 0.8**2, 0.6**2], [0.8**2, 1.0**2, 0.0], [0.6**2, 0.0, 0.5**2]]),
}

#: The filters :func:`run_depth_study` knows: paper C's three, and three more that take the GPF apart.
FILTER_NAMES = ("EKF", "MMPF", "GPF", "PF", "PF + wavelet R", "EKF + wavelet R")

_PITCH_OFFSET = 1.0          # rad: shifts the pitch into (0, 2) for GM(1,1)


def _ramps(t: np.ndarray, ramps: Sequence[tuple[float, float]], values: Sequence[float]) -> np.ndarray:
    """``values[0]`` then a smooth (raised-cosine) ramp to ``values[i+1]`` over each ``ramps[i] = (start, end)``."""
    out = np.full(t.shape, float(values[0]))
    for (a, b), v0, v1 in zip(ramps, values[:-1], values[1:]):
        r = np.clip((t - a) / (b - a), 0.0, 1.0)
        out += (v1 - v0) * 0.5 * (1.0 - np.cos(np.pi * r))
    return out


@dataclass(frozen=True)
class DepthProfile:
    """True states of a maneuvering AUV and the standard deviation of its sensors' noise over time.

    Attributes
    ----------
    times : ndarray, shape (K,)
        Sample times [s] (``T, 2T, ..., K T``).
    truth : ndarray, shape (K, 3)
        Depth [m] (positive down), speed [m/s] and pitch [rad] (positive nose down: diving).
    sensor_std : ndarray, shape (K, 3)
        Standard deviation of each sensor's noise at each sample [m, m/s, rad].
    maneuvering : ndarray of bool, shape (K,)
        True while the pitch is changing (the ramps into and out of the dive and the climb).
    segments : dict
        Named time intervals ``(start, end)`` [s] of the profile: the legs and the noise periods.
    T : float
        Sampling interval [s].
    """

    times: np.ndarray
    truth: np.ndarray
    sensor_std: np.ndarray
    maneuvering: np.ndarray
    segments: dict[str, tuple[float, float]]
    T: float

    @property
    def n_steps(self) -> int:
        """Number of samples ``K``."""
        return self.times.size

    def mask(self, start: float, end: float) -> np.ndarray:
        """Boolean mask of the samples with ``start <= t < end``."""
        return (self.times >= start) & (self.times < end)

    def between(self, start: float, end: float) -> "DepthProfile":
        """The part of the profile with ``start <= t < end`` (times kept; segments clipped to it)."""
        keep = self.mask(start, end)
        if keep.sum() < 20:
            raise ValueError(f"the interval [{start}, {end}) must hold at least 20 samples; it holds {keep.sum()}")
        segments = {name: (max(a, start), min(b, end)) for name, (a, b) in self.segments.items()
                    if a < end and b > start}
        return DepthProfile(times=self.times[keep], truth=self.truth[keep], sensor_std=self.sensor_std[keep],
                            maneuvering=self.maneuvering[keep], segments=segments, T=self.T)


def maneuvering_depth_profile(duration: float = 60.0, T: float = 0.05, dive_pitch_deg: float = 20.0,
                              climb_pitch_deg: float = -25.0, noise_factors: Sequence[float] = (1.0, 3.0, 1.0, 0.5),
                              noise_change_times: Sequence[float] = (18.0, 30.0, 42.0),
                              sensor_std: Any = None) -> DepthProfile:
    """A dive, a level leg and a climb, with sensor noise that changes over time (the book's stand-in for paper C's
    lake trial).

    The 60 s profile (times scale with ``duration``): level at 10 m and 1.5 m/s until 8 s; the pitch ramps to
    ``dive_pitch_deg`` over 3 s while the speed rises to 2.5 m/s; a dive; back to level at 24-27 s (speed 2 m/s);
    a pitch ramp to ``climb_pitch_deg`` at 35-38 s; a climb; level again from 53 s (speed back to 1.5 m/s). The
    depth integrates the model's kinematics, :math:`z_k = z_{k-1} + v_k \\sin\\varphi_k\\, T`.

    The sensors' noise is paper C's R (0.2 m, 5 cm/s, 0.5°) times ``noise_factors[i]`` between the
    ``noise_change_times`` (abrupt changes): by default nominal, three times larger from 18 to 30 s (a disturbed
    period), nominal, then half from 42 s on (a quiet period).

    Parameters
    ----------
    duration : float, optional
        Length of the profile [s].
    T : float, optional
        Sampling interval [s] (paper C: 0.05 s).
    dive_pitch_deg : float, optional
        Pitch of the dive [deg] (positive: nose down).
    climb_pitch_deg : float, optional
        Pitch of the climb [deg] (negative: nose up).
    noise_factors : sequence of float, optional
        Multipliers of the nominal sensor noise, one per period (one more than ``noise_change_times``).
    noise_change_times : sequence of float, optional
        Times at which the noise level changes [s], increasing, for a 60 s profile (scaled with ``duration``).
    sensor_std : array_like, shape (3,), optional
        Nominal noise standard deviations [m, m/s, rad]; paper C's R by default.

    Returns
    -------
    DepthProfile
    """
    duration = float(as_positive("duration", duration))
    T = float(as_positive("T", T))
    K = int(round(duration / T))
    if K < 20:
        raise ValueError(f"duration must cover at least 20 samples of T = {T} s; got {duration} s")
    factors = as_nonnegative("noise_factors", noise_factors, ndim=1)
    changes = as_finite("noise_change_times", noise_change_times, ndim=1)
    if factors.size != changes.size + 1:
        raise ValueError(f"noise_factors must have one entry more than noise_change_times; got {factors.size} "
                         f"and {changes.size}")
    if (np.diff(changes) <= 0).any():
        raise ValueError("noise_change_times must increase")
    if (factors <= 0).any():
        raise ValueError("noise_factors must be > 0 (a sensor without noise makes R singular)")
    nominal = PAPER_C["sensor_std"] if sensor_std is None else as_positive("sensor_std", sensor_std, shape=(3,))
    s = duration / 60.0                                   # the profile is designed for 60 s
    t = np.arange(1, K + 1) * T
    pitch_ramps = [(8 * s, 11 * s), (24 * s, 27 * s), (35 * s, 38 * s), (50 * s, 53 * s)]
    pitch = _ramps(t, pitch_ramps, np.radians([0.0, dive_pitch_deg, 0.0, climb_pitch_deg, 0.0]))
    speed = _ramps(t, [(8 * s, 16 * s), (27 * s, 31 * s), (53 * s, 57 * s)], [1.5, 2.5, 2.0, 1.5])
    depth = 10.0 + np.cumsum(speed * np.sin(pitch)) * T
    factor = factors[np.searchsorted(changes * s, t, side="right")]
    maneuvering = np.zeros(K, dtype=bool)
    for a, b in pitch_ramps:
        maneuvering |= (t >= a) & (t < b)
    bounds = np.concatenate([[0.0], changes * s, [duration + T]])
    segments = {"dive": (8 * s, 27 * s), "level": (27 * s, 35 * s), "climb": (35 * s, 53 * s)}
    for i, f in enumerate(factors):
        segments[f"noise x{f:g} ({i + 1})"] = (float(bounds[i]), float(bounds[i + 1]))
    return DepthProfile(times=t, truth=np.column_stack([depth, speed, pitch]),
                        sensor_std=factor[:, None] * nominal, maneuvering=maneuvering, segments=segments, T=T)


def simulate_depth_sensors(profile: DepthProfile, n_runs: int, rng: np.random.Generator) -> np.ndarray:
    """Readings of the depth, speed and pitch sensors: the truth plus Gaussian noise of the profile's level.

    Parameters
    ----------
    profile : DepthProfile
        The true states and the noise level over time.
    n_runs : int
        Number of Monte Carlo runs ``M`` (independent noise, same truth).
    rng : numpy.random.Generator
        Source of the noise.

    Returns
    -------
    ndarray, shape (M, K, 3)
    """
    M = as_int("n_runs", n_runs, minimum=1)
    rng = as_rng(rng)
    return profile.truth + rng.standard_normal((M, profile.n_steps, 3)) * profile.sensor_std


@dataclass(frozen=True)
class DepthStudy:
    """The estimates of several filters on the same Monte Carlo runs (see :func:`run_depth_study`).

    Attributes
    ----------
    profile : DepthProfile
        The truth.
    measurements : ndarray, shape (M, K, 3)
        The sensor readings of the ``M`` runs.
    estimates : dict of ndarray
        For each filter, its estimates, shape (M, K, 3).
    ess : dict of ndarray
        For each particle filter, the effective sample size after each update, shape (M, K).
    extras : dict
        ``"GPF noise_std"`` (M, K, 3): the wavelet noise estimates the GPF used; ``"MMPF mode_probabilities"``
        (M, K, J): the posterior probabilities of the MMPF's modes.
    """

    profile: DepthProfile
    measurements: np.ndarray
    estimates: dict[str, np.ndarray]
    ess: dict[str, np.ndarray] = field(default_factory=dict)
    extras: dict[str, np.ndarray] = field(default_factory=dict)

    def rmse(self, name: str) -> np.ndarray:
        """RMSE over the runs at each step of filter ``name``, per component, shape (K, 3)."""
        err = self.estimates[name] - self.profile.truth
        return np.sqrt(np.mean(err**2, axis=0))

    def rmse_over(self, name: str, mask: Any = None) -> np.ndarray:
        """RMSE over the runs and the steps selected by ``mask`` (all by default), per component, shape (3,)."""
        err = self.estimates[name] - self.profile.truth
        if mask is not None:
            err = err[:, np.asarray(mask, dtype=bool)]
        return np.sqrt(np.mean(err**2, axis=(0, 1)))


def _mmpf_models(process_std: np.ndarray, R: np.ndarray, T: float, targets_deg: np.ndarray,
                 time_constant: float) -> list[PitchManeuverModel]:
    return [PitchManeuverModel(pitch_target=np.radians(p), time_constant=time_constant, T=T,
                               process_std=process_std, R=R) for p in targets_deg]


def _mmpf_transition(stay: float, J: int) -> np.ndarray:
    off = (1.0 - stay) / (J - 1) if J > 1 else 0.0
    return np.full((J, J), off) + np.eye(J) * (stay - off)


def run_depth_study(profile: DepthProfile, measurements: Any, filters: Sequence[str] = ("EKF", "MMPF", "GPF"), *,
                    n_particles: int = 1000, grey_fraction: float = 0.1, grey_window: int = 30,
                    noise_window: int = 50, process_std: Any = None,
                    mmpf_targets_deg: Sequence[float] = (0.0, 20.0, -20.0), mmpf_time_constant: float = 1.0,
                    mmpf_stay: float = 0.995, seed: int = 0) -> DepthStudy:
    """Run the filters of paper C's comparison on every Monte Carlo run of a depth profile.

    All filters start from the first measurement with covariance ``R`` and use paper C's nominal
    ``R = diag(0.2², 0.05², (0.5°)²)`` (m, m/s, rad) and the process noise ``process_std`` (the diagonal of the
    paper's Q by default). The filters:

    ``"EKF"``
        :class:`~uwtutor.filters.depth_ekf.DepthEKF` with the fixed ``R``.
    ``"MMPF"``
        :class:`~uwtutor.filters.particle.MultipleModelParticleFilter` over one
        :class:`~uwtutor.filters.particle.PitchManeuverModel` mode per pitch target in ``mmpf_targets_deg`` (by
        default cruise 0°, dive +20°, climb -20°), time constant ``mmpf_time_constant``, staying in a mode with
        probability ``mmpf_stay`` per step and switching to each other mode with equal probability; fixed ``R``.
    ``"GPF"``
        :class:`~uwtutor.filters.particle.GreyParticleFilter`: ``grey_fraction`` of the particles from the GM(1,1)
        forecast of the last ``grey_window`` measurements (pitch shifted by 1 rad), wavelet ``R_k`` from
        ``noise_window`` samples (db6).
    ``"PF"``, ``"PF + wavelet R"``, ``"EKF + wavelet R"``
        The pieces of the GPF: the bootstrap filter with the fixed ``R``; the GPF without grey particles; the EKF
        with the GPF's wavelet ``R_k``.

    Parameters
    ----------
    profile : DepthProfile
        The truth.
    measurements : array_like, shape (M, K, 3)
        Sensor readings (:func:`simulate_depth_sensors`).
    filters : sequence of str, optional
        Names from ``FILTER_NAMES``.
    n_particles : int, optional
        ``N`` of every particle filter (paper C: 1000).
    grey_fraction : float, optional
        :math:`N_\\mathrm{grey}/N` of the GPF (paper C: 0.1).
    grey_window : int, optional
        ``L`` of the GPF (paper C: 30).
    noise_window : int, optional
        Length of the wavelet window (paper C: 50).
    process_std : array_like, shape (3,), optional
        Process noise standard deviations per step [m, m/s, rad].
    mmpf_targets_deg : sequence of float, optional
        Pitch targets of the MMPF's modes [deg] (at least one).
    mmpf_time_constant : float, optional
        Time constant of the MMPF modes [s].
    mmpf_stay : float, optional
        Probability of staying in a mode at each step.
    seed : int, optional
        Seed of the particle filters' generators (run ``m`` of a filter uses ``seed + m``).

    Returns
    -------
    DepthStudy
    """
    unknown = [f for f in filters if f not in FILTER_NAMES]
    if unknown or not filters:
        raise ValueError(f"filters must be names from {FILTER_NAMES}; got {list(filters)!r}")
    Z = as_finite("measurements", measurements)
    if Z.ndim != 3 or Z.shape[1:] != (profile.n_steps, 3):
        raise ValueError(f"measurements must have shape (M, {profile.n_steps}, 3); got {Z.shape}")
    N = as_int("n_particles", n_particles, minimum=10)
    q = PAPER_C["process_std"] if process_std is None else as_nonnegative("process_std", process_std, shape=(3,))
    seed = as_int("seed", seed, minimum=0)
    targets = as_finite("mmpf_targets_deg", mmpf_targets_deg, ndim=1)
    if targets.size < 1:
        raise ValueError("mmpf_targets_deg must hold at least one pitch target")
    stay = float(as_finite("mmpf_stay", mmpf_stay))
    if not 0.0 < stay <= 1.0:
        raise ValueError(f"mmpf_stay must lie in (0, 1]; got {stay}")
    T = profile.T
    R = np.diag(PAPER_C["sensor_std"] ** 2)
    M = Z.shape[0]
    model = DepthSpeedPitchModel(T=T, process_std=q, R=R)
    gpf_kw = dict(grey_window=grey_window, noise_window=noise_window, grey_offset=[0.0, 0.0, _PITCH_OFFSET])
    makers: dict[str, Callable[[np.ndarray, np.random.Generator], Any]] = {
        "PF": lambda z0, rng: BootstrapParticleFilter.from_gaussian(model, z0, R, N, rng),
        "MMPF": lambda z0, rng: MultipleModelParticleFilter.from_gaussian(
            _mmpf_models(q, R, T, targets, mmpf_time_constant), z0, R, N, rng,
            transition=_mmpf_transition(stay, targets.size)),
        "GPF": lambda z0, rng: GreyParticleFilter.from_gaussian(model, z0, R, N, rng, grey_fraction=grey_fraction,
                                                                **gpf_kw),
        "PF + wavelet R": lambda z0, rng: GreyParticleFilter.from_gaussian(model, z0, R, N, rng, grey_fraction=0.0,
                                                                           **gpf_kw),
    }
    estimates: dict[str, np.ndarray] = {}
    ess: dict[str, np.ndarray] = {}
    extras: dict[str, np.ndarray] = {}
    for name in filters:
        if name == "EKF":
            estimates[name] = DepthEKF(Z[:, 0], R, np.diag(q**2), R, T=T).run(Z).x
            continue
        if name == "EKF + wavelet R":
            continue                                     # after the GPF (it uses the GPF's noise estimates)
        x = np.empty_like(Z)
        e = np.empty(Z.shape[:2])
        kept: dict[str, list[np.ndarray]] = {}
        for m in range(M):
            res = makers[name](Z[m, 0], np.random.default_rng(seed + m)).run(Z[m])
            x[m] = res.x
            e[m] = res.extras["ess"]
            for key in ("noise_std", "mode_probabilities"):
                if key in res.extras:
                    kept.setdefault(key, []).append(res.extras[key])
        estimates[name], ess[name] = x, e
        for key, values in kept.items():
            extras[f"{name} {key}"] = np.array(values)
    if "EKF + wavelet R" in filters:
        sd = extras.get("GPF noise_std")
        if sd is None:
            sd = extras.get("PF + wavelet R noise_std")
        if sd is None:                                   # compute the GPF's noise estimates without its particles
            from ..wavelet import sliding_noise_sigma

            sd = np.moveaxis(sliding_noise_sigma(np.moveaxis(Z, -1, 1), noise_window), 1, -1)
            sd = np.where(np.isnan(sd), PAPER_C["sensor_std"], np.maximum(sd, 0.01 * PAPER_C["sensor_std"]))
        Rs = np.zeros(Z.shape + (3,))
        Rs[..., [0, 1, 2], [0, 1, 2]] = sd**2
        estimates["EKF + wavelet R"] = DepthEKF(Z[:, 0], R, np.diag(q**2), R, T=T).run(Z, Rs=Rs).x
    estimates = {name: estimates[name] for name in filters}
    return DepthStudy(profile=profile, measurements=Z, estimates=estimates, ess=ess, extras=extras)


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


def gpf_view(n_particles: int = 200, grey_fraction: float = 0.1, noise_window: int = 50, noise_change: float = 3.0,
             seed: int = 1) -> GPFView:
    """Run the EKF and the GPF on 12 s of the dive whose sensor noise changes by ``noise_change`` at 13 s.

    The samples from 6 to 18 s of :func:`maneuvering_depth_profile` (the pitch ramps to 20° at 8-11 s, the speed
    rises), with the noise nominal until 13 s and ``noise_change`` times nominal after; paper C's other parameters
    (T = 0.05 s, ``L`` = 30, the diagonal Q, fixed R for the EKF). Both filters start from the first reading.

    Parameters
    ----------
    n_particles : int, optional
        ``N`` of the GPF (the widget's default is small so that it recomputes in about 0.1 s).
    grey_fraction : float, optional
        :math:`N_\\mathrm{grey}/N`, in [0, 1).
    noise_window : int, optional
        Wavelet window length (>= 12).
    noise_change : float, optional
        Factor applied to the sensor noise from 8 s on (> 0).
    seed : int, optional
        Seed of the sensor noise and of the GPF.

    Returns
    -------
    GPFView
    """
    N = as_int("n_particles", n_particles, minimum=10)
    factor = float(as_positive("noise_change", noise_change))
    seed = as_int("seed", seed, minimum=0)
    profile = maneuvering_depth_profile(noise_factors=(1.0, factor), noise_change_times=(13.0,)).between(6.0, 18.0)
    rng = np.random.default_rng(seed)
    z = simulate_depth_sensors(profile, 1, rng)[0]
    R = np.diag(PAPER_C["sensor_std"] ** 2)
    q = PAPER_C["process_std"]
    model = DepthSpeedPitchModel(T=profile.T, process_std=q, R=R)
    ekf = DepthEKF(z[0], R, np.diag(q**2), R, T=profile.T).run(z)
    gpf = GreyParticleFilter.from_gaussian(model, z[0], R, N, np.random.default_rng(seed + 1000),
                                           grey_fraction=grey_fraction, noise_window=noise_window,
                                           grey_offset=[0.0, 0.0, _PITCH_OFFSET]).run(z)
    after = profile.times >= profile.times[0] + 1.0
    estimates = {"EKF": ekf.x, "GPF": gpf.x}
    rmse = {k: np.sqrt(np.mean((v[after] - profile.truth[after]) ** 2, axis=0)) for k, v in estimates.items()}
    return GPFView(times=profile.times, truth=profile.truth, measurements=z, estimates=estimates, rmse=rmse,
                   ess=gpf.extras["ess"], noise_std=gpf.extras["noise_std"], true_noise_std=profile.sensor_std,
                   n_particles=N, n_grey=int(round(grey_fraction * N)))


def plot_gpf_view(view: GPFView, fig: Any = None) -> Any:
    """Draw a :class:`GPFView`: pitch estimates, the wavelet noise estimate, the ESS, and the RMSE bars."""
    fig = fig or plt.figure(figsize=(7.6, 5.0))
    ax = fig.subplots(2, 2)
    t = view.times
    a = ax[0, 0]
    a.plot(t, np.degrees(view.measurements[:, 2]), ".", ms=1.5, color="0.7", label="pitch sensor")
    a.plot(t, np.degrees(view.truth[:, 2]), color="black", lw=1, label="truth")
    for name, color in (("EKF", "C3"), ("GPF", "C2")):
        a.plot(t, np.degrees(view.estimates[name][:, 2]), color=color, lw=1, label=name)
    a.set_xlabel("time [s]")
    a.set_ylabel("pitch [°]")
    a.legend(fontsize=7, loc="lower right")
    a = ax[0, 1]
    a.plot(t, view.true_noise_std[:, 0], color="black", lw=1, label="true σ (depth)")
    a.plot(t, view.noise_std[:, 0], color="C2", lw=1, label="wavelet estimate")
    a.set_xlabel("time [s]")
    a.set_ylabel("depth noise σ [m]")
    a.legend(fontsize=7)
    a = ax[1, 0]
    a.plot(t, view.ess, color="C2", lw=1)
    a.set_ylim(0, view.n_particles * 1.05)
    a.set_xlabel("time [s]")
    a.set_ylabel("ESS of the GPF")
    a.set_title(f"N = {view.n_particles}, {view.n_grey} grey", fontsize=9)
    a = ax[1, 1]
    labels = ["depth [cm]", "speed [cm/s]", "pitch [0.1°]"]
    scale = np.array([100.0, 100.0, 10 * 180 / np.pi])
    pos = np.arange(3)
    for i, (name, color) in enumerate((("EKF", "C3"), ("GPF", "C2"))):
        a.bar(pos + (i - 0.5) * 0.38, view.rmse[name] * scale, width=0.38, color=color, label=name)
    a.set_xticks(pos, labels, fontsize=8)
    a.set_ylabel("RMSE")
    a.legend(fontsize=7)
    fig.tight_layout()
    return fig


def gpf_widget() -> Any:
    """Sliders for the GPF's particle count, grey share and wavelet window, and the change of the sensor noise."""
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
    return slider_panel(sliders, lambda fig, **p: plot_gpf_view(gpf_view(**p), fig))


#: Zero-argument callables running each widget's computation at its default parameters (timed by ``make bench``).
COMPUTE_FUNCTIONS: dict[str, Callable[[], Any]] = {
    "ch06 grey particle filter": gpf_view,
}
