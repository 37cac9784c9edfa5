r"""Paper C (Li et al. 2013): its parameters and the book's maneuvering-dive scenario.

Paper C estimates the depth, speed and pitch of a maneuvering AUV with a grey particle filter (GPF) and compares
it with an EKF and a multiple-model particle filter (MMPF) on a lake trial. The book simulates the trial instead:

* :class:`PaperCParameters` -- the paper's values (:data:`PARAMETERS` holds them; ``PARAMETERS.as_dict()`` as a
  plain dict);
* :func:`maneuvering_depth_profile` -- the true depth, speed and pitch of a dive, a level leg and a climb, with
  a sensor noise level that changes over time; :func:`simulate_depth_sensors` -- the readings of ``M`` runs;
* :func:`make` -- both at once: the scenario of the chapter on paper C for ``M`` runs.

The experiment -- the filters of the comparison (and the pieces of the GPF) on every run, all runs of a filter in one
batched call -- runs filters, so it is a pipeline: :func:`~uwtutor.pipelines.depth_study.run_depth_study`.

References
----------
Li Ting, Zhao Dexin, Huang Zhiping and Su Shaojing (2013). A method for self-estimating the depth of maneuvering
AUV based on the grey particle filter. *Journal of National University of Defense Technology* 35(5), 185-190
(paper C).
"""

from __future__ import annotations

import importlib.util
from dataclasses import asdict, dataclass, field
from typing import Any, Sequence

import numpy as np
from numpy.typing import ArrayLike

from .._validate import as_finite, as_instance, as_int, as_nonnegative, as_positive, as_rng, as_scalar, check_work
from ..errors import deprecated_aliases, warn
from ..wavelet import as_wavelet

__all__ = [
    "PaperCParameters",
    "PARAMETERS",
    "DepthProfile",
    "maneuvering_depth_profile",
    "simulate_depth_sensors",
    "PaperCScenario",
    "make",
    "FILTER_NAMES",
    "PITCH_OFFSET",
]


def _readonly(values: Any) -> np.ndarray:
    a = np.array(values, dtype=float)
    a.flags.writeable = False
    return a


@dataclass(frozen=True)
class PaperCParameters:
    r"""Paper C's parameters, in SI units (depth m, speed m/s, pitch rad).

    Attributes
    ----------
    T : float
        Sampling interval [s] (0.05 s).
    n_particles : int
        Particles of every particle filter (1000).
    n_grey : int
        Grey particles per step (100, i.e. 1 in 10).
    grey_window : int
        Measurements per GM(1,1) fit, ``L`` (30).
    noise_window : int
        Samples per wavelet noise estimate (50).
    polynomial_order : int
        Degree of the local polynomial the wavelet must cancel (5).
    wavelet : str
        ``"db6"`` (six vanishing moments).
    sensor_std : ndarray, shape (3,)
        The paper prints :math:`R = \mathrm{diag}(0.2^2, 5^2, 0.5^2)` without units: read here as 0.2 m, 5 cm/s and
        0.5 deg.
    process_std : ndarray, shape (3,)
        The diagonal of the paper's :math:`Q` (0.2 m, 1 cm/s, 0.5 deg per step). Its off-diagonal terms are dropped:
        the printed :math:`Q` is not positive semi-definite.
    Q_as_printed : ndarray, shape (3, 3)
        :math:`Q` exactly as printed, in the paper's units (m, cm/s, deg): not a covariance matrix.

    Examples
    --------
    >>> from uwtutor.scenarios.paper_c import PaperCParameters
    >>> p = PaperCParameters()
    >>> p.T, p.n_particles, p.n_grey, p.grey_window, p.noise_window
    (0.05, 1000, 100, 30, 50)
    """

    T: float = 0.05
    n_particles: int = 1000
    n_grey: int = 100
    grey_window: int = 30
    noise_window: int = 50
    polynomial_order: int = 5
    wavelet: str = "db6"
    sensor_std: np.ndarray = field(default_factory=lambda: _readonly([0.2, 0.05, np.radians(0.5)]))
    process_std: np.ndarray = field(default_factory=lambda: _readonly([0.2, 0.01, np.radians(0.5)]))
    Q_as_printed: np.ndarray = field(default_factory=lambda: _readonly(
        [[0.2**2, 0.8**2, 0.6**2], [0.8**2, 1.0**2, 0.0], [0.6**2, 0.0, 0.5**2]]))

    def __post_init__(self) -> None:
        as_scalar("T", self.T, domain="positive")
        n = as_int("n_particles", self.n_particles, minimum=1)
        as_int("n_grey", self.n_grey, minimum=0, maximum=n)
        as_int("grey_window", self.grey_window, minimum=4)
        as_int("noise_window", self.noise_window, minimum=1)
        as_int("polynomial_order", self.polynomial_order, minimum=0)
        if not isinstance(self.wavelet, str):
            raise TypeError(f"wavelet must be the name of a PyWavelets wavelet, e.g. 'db6'; got "
                            f"{type(self.wavelet).__name__}")
        if importlib.util.find_spec("pywt") is not None:     # PyWavelets is optional until the GPF runs
            as_wavelet(self.wavelet)
        # stored as read-only float arrays (the defaults already are; a list given by a user becomes one)
        object.__setattr__(self, "sensor_std", _readonly(as_positive("sensor_std", self.sensor_std, shape=(3,))))
        object.__setattr__(self, "process_std",
                           _readonly(as_nonnegative("process_std", self.process_std, shape=(3,))))
        object.__setattr__(self, "Q_as_printed", _readonly(as_finite("Q_as_printed", self.Q_as_printed,
                                                                     shape=(3, 3))))

    @property
    def R(self) -> np.ndarray:
        """The sensor noise covariance ``diag(sensor_std**2)``."""
        return np.diag(self.sensor_std**2)

    @property
    def Q(self) -> np.ndarray:
        """The process noise covariance used in place of the printed one, ``diag(process_std**2)``."""
        return np.diag(self.process_std**2)

    def as_dict(self) -> dict[str, Any]:
        """The parameters by name (arrays copied)."""
        return {k: (v.copy() if isinstance(v, np.ndarray) else v) for k, v in asdict(self).items()}


#: Paper C's parameters (``PaperCParameters()``).
PARAMETERS = PaperCParameters()

#: The filters :func:`~uwtutor.pipelines.depth_study.run_depth_study` knows: paper C's three, and three more that take
#: the GPF apart.
FILTER_NAMES = ("EKF", "MMPF", "GPF", "PF", "PF + wavelet R", "EKF + wavelet R")

#: Shift [rad] that moves the pitch into (0, 2) for GM(1,1).
PITCH_OFFSET = 1.0


def _ramps(t: np.ndarray, ramps: Sequence[tuple[float, float]], values: Sequence[float] | np.ndarray) -> np.ndarray:
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

    Examples
    --------
    >>> from uwtutor.scenarios.paper_c import maneuvering_depth_profile
    >>> profile = maneuvering_depth_profile(duration=6.0)
    >>> profile.n_steps, profile.truth.shape, sorted(profile.segments)[:3]
    (120, (120, 3), ['climb', 'dive', 'level'])
    >>> profile.between(0.0, 3.0).n_steps
    59
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
                              sensor_std: ArrayLike | None = None) -> DepthProfile:
    """A dive, a level leg and a climb, with sensor noise that changes over time (the book's stand-in for paper C's
    lake trial).

    The 60 s profile (times scale with ``duration``): level at 10 m and 1.5 m/s until 8 s; the pitch ramps to
    ``dive_pitch_deg`` over 3 s while the speed rises to 2.5 m/s; a dive; back to level at 24-27 s (speed 2 m/s);
    a pitch ramp to ``climb_pitch_deg`` at 35-38 s; a climb; level again from 53 s (speed back to 1.5 m/s). The
    depth integrates the model's kinematics, :math:`z_k = z_{k-1} + v_k \\sin\\phi_k\\, T`.

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

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.scenarios.paper_c import maneuvering_depth_profile
    >>> p = maneuvering_depth_profile()
    >>> p.n_steps, round(float(np.degrees(p.truth[:, 2].max())), 1), round(
    ...     float(p.truth[:, 0].max()), 1
    ... )
    (1200, 20.0, 22.8)
    """
    duration = as_scalar("duration", duration, domain="positive")
    T = as_scalar("T", T, domain="positive")
    dive = as_scalar("dive_pitch_deg", dive_pitch_deg)
    climb = as_scalar("climb_pitch_deg", climb_pitch_deg)
    check_work("duration / T", duration / T, "samples")
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
    nominal = PARAMETERS.sensor_std if sensor_std is None else as_positive("sensor_std", sensor_std, shape=(3,))
    s = duration / 60.0                                   # the profile is designed for 60 s
    t = np.arange(1, K + 1) * T
    pitch_ramps = [(8 * s, 11 * s), (24 * s, 27 * s), (35 * s, 38 * s), (50 * s, 53 * s)]
    pitch = _ramps(t, pitch_ramps, np.radians([0.0, dive, 0.0, climb, 0.0]))
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

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.scenarios.paper_c import (
    ...     maneuvering_depth_profile,
    ...     simulate_depth_sensors,
    ... )
    >>> p = maneuvering_depth_profile(duration=6.0)
    >>> simulate_depth_sensors(p, 3, np.random.default_rng(0)).shape
    (3, 120, 3)
    """
    profile = as_instance("profile", profile, DepthProfile, "from maneuvering_depth_profile")
    M = as_int("n_runs", n_runs, minimum=1)
    check_work("n_runs", 3 * M * profile.n_steps, "readings (n_runs x the samples x 3 sensors)")
    rng = as_rng(rng)
    return profile.truth + rng.standard_normal((M, profile.n_steps, 3)) * profile.sensor_std


@dataclass(frozen=True)
class PaperCScenario:
    """The chapter's scenario for paper C: the true profile and the sensor readings of ``M`` runs.

    Attributes
    ----------
    profile : DepthProfile
        The truth and the noise level over time.
    measurements : ndarray, shape (M, K, 3)
        The readings of the depth, speed and pitch sensors of every run.
    parameters : PaperCParameters
        The paper's parameters the scenario was made with.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.scenarios import paper_c
    >>> scenario = paper_c.make(np.random.default_rng(0), n_runs=2, duration=6.0)
    >>> scenario.n_runs, scenario.truth.shape, scenario.measurements.shape
    (2, (120, 3), (2, 120, 3))
    """

    profile: DepthProfile
    measurements: np.ndarray
    parameters: PaperCParameters

    @property
    def n_runs(self) -> int:
        """Number of runs ``M``."""
        return self.measurements.shape[0]

    @property
    def truth(self) -> np.ndarray:
        """The true states ``(K, 3)``, shared by every run."""
        return self.profile.truth


def make(rng: np.random.Generator, n_runs: int = 1, *, params: PaperCParameters | None = None,
         **profile: Any) -> PaperCScenario:
    """Paper C's scenario: :func:`maneuvering_depth_profile` and ``n_runs`` draws of its sensors.

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of the sensor noise (the draws of :func:`simulate_depth_sensors` with this generator).
    n_runs : int, optional
        Number of Monte Carlo runs ``M``.
    params : PaperCParameters, optional
        The paper's values (default :data:`PARAMETERS`; the sampling interval and the nominal sensor noise are
        taken from them).
    **profile
        Further arguments of :func:`maneuvering_depth_profile` (``duration``, ``dive_pitch_deg``, ...).

    Returns
    -------
    PaperCScenario

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.scenarios import paper_c
    >>> scenario = paper_c.make(np.random.default_rng(2013), n_runs=4)
    >>> scenario.measurements.shape, scenario.profile.T
    ((4, 1200, 3), 0.05)
    """
    if "parameters" in profile:                 # the keyword's former name (one release)
        if params is not None:
            raise TypeError("give the parameters once, as params= (parameters= is its deprecated former name)")
        warn("paper_c.make(parameters=...) is deprecated and will be removed in the next release: use params=",
             DeprecationWarning)
        params = profile.pop("parameters")
    params = PARAMETERS if params is None else params
    if not isinstance(params, PaperCParameters):
        raise TypeError(f"params must be a PaperCParameters; got {type(params).__name__}")
    profile.setdefault("T", params.T)
    profile.setdefault("sensor_std", params.sensor_std)
    prof = maneuvering_depth_profile(**profile)
    return PaperCScenario(profile=prof, measurements=simulate_depth_sensors(prof, n_runs, rng), parameters=params)


#: The former name (one release): ``PAPER_C`` was the parameters as a dict, now ``PARAMETERS.as_dict()``.
__getattr__ = deprecated_aliases(__name__, {"PAPER_C": (f"{__name__}.PARAMETERS.as_dict()",
                                                       lambda: PARAMETERS.as_dict())})
