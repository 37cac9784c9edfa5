r"""Paper A (Liu et al.): a platform circling a buoy with a slowly varying range bias, and its lake trial.

Two scenarios, each a parameters dataclass holding paper A's values (and, where the paper gives none, the book's
choices, marked as such) with a ``make(rng, n_runs)``:

* :class:`PaperAParameters` -- the simulation of paper A's sec. 2.1: the platform circles the buoy (the paper gives no
  radius; the book chooses 1500 m) and every ``leg_time`` seconds turns towards it by a random angle (the paper's
  Fig. 1a); the range error is

  .. math::

      \xi_k = \eta_k + (\gamma_k - 1)\, r_k + \tilde\upsilon_k + \mu_\upsilon, \qquad \eta_k \sim N(0, \sigma_r^2),\
      \gamma_k \sim N(\mu_\gamma, \sigma_\gamma^2),

  with :math:`\tilde\upsilon_k + \mu_\upsilon` low-pass filtered white noise (an Ornstein-Uhlenbeck process,
  ``ranging.SlowBias``) of mean :math:`\mu_\upsilon` (paper A's :math:`\mu_k + \rho`). Paper A's :math:`\gamma`, the
  book's :math:`\mu_\gamma - 1`, is a constant sound-speed error (:math:`\sigma_\gamma = 0`); its Fig. 6
  also needs a random multiplicative part, :math:`\sigma_\gamma > 0` (:func:`variance_split`).
  ``track="circle"`` replaces the random turns by the exact circle of ``scenarios.circling_scenario``.
  :data:`PARAMETERS` is the default set (``PaperAParameters()``).
* :class:`LakeTrialParameters` -- the structure of paper A's 2018 lake trial: a receiving boat and a sending boat,
  both on GNSS, four groups of pings from two directions about 90 degrees apart. The sender is a *moving beacon*;
  paper A turns it into a fixed one with the relative displacement :math:`\mathbf u_k = \mathbf u_{r,k} -
  \mathbf u_{s,k}` (:meth:`LakeTrial.relative`).

Randomness: ``make`` splits its ``rng`` (``Generator.spawn``) into a stream for the geometry (the random turns,
shared by all runs: one "typical track" like the paper's), one for the DR noise and one for each part of the
range error, so that changing one part's level leaves the other parts' draws as they were.

References
----------
Liu J., Han S., Xu J., Yang G. "An improved EKF positioning algorithm for underwater acoustic beacon" (paper A),
sec. 2.1 (simulation) and sec. 2.2 (lake trial).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .._linalg import distances
from .._validate import as_finite, as_int, as_positive, as_rng, as_scalar, as_times, check_work
from ..motion import Track, circle_track, turning_track
from ..ranging import GaussianNoise, SlowBias, SoundSpeedMismatch, add_range_errors
from . import Scenario, circling_scenario, make_scenario

__all__ = ["PaperAParameters", "PARAMETERS", "make", "make_with_truth", "random_turn_track", "variance_split",
           "LakeTrialParameters", "LakeTrial", "make_lake_trial"]


def random_turn_track(rng: np.random.Generator, times: ArrayLike, radius: float = 1500.0, speed: float = 2.0,
                      leg_time: float = 150.0, start_angle: float = -np.pi / 2) -> Track:
    r"""Straight legs round a buoy at the origin, turning towards it by a random angle every ``leg_time`` seconds.

    Each leg starts at the tangent heading (counter-clockwise round the buoy) turned inwards by
    :math:`\delta \sim U(0, 2\delta_0)`, where :math:`\sin\delta_0 = L / 2r` for a leg of length :math:`L` at range
    :math:`r`: the inward angle that would bring the platform back to its starting range at the end of the leg.
    So every turn is *towards* the buoy (by :math:`L/r + \delta' - \delta \ge 0`, about :math:`L/r` on average), the
    range wanders by tens of metres per leg, and the platform keeps circling (paper A, sec. 2.1, Fig. 1a; the paper
    gives neither the interval nor the angle distribution: both are the book's choice).

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of the turn angles.
    times : array_like, shape (K,)
        Epoch times [s], from 0, strictly increasing.
    radius : float
        Starting range [m].
    speed : float
        Platform speed [m/s].
    leg_time : float
        Time between turns [s].
    start_angle : float
        Bearing of the start point from the buoy [rad] (default: due south).

    Returns
    -------
    Track

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.scenarios.paper_a import random_turn_track
    >>> track = random_turn_track(
    ...     np.random.default_rng(0), np.arange(0.0, 15000.0, 5.0)
    ... )
    >>> r = np.hypot(*track.positions.T)
    >>> bool(1000 < r.min() and r.max() < 2000)
    True
    """
    rng = as_rng(rng)
    t = as_times("times", times)
    r0 = as_scalar("radius", radius, domain="positive")
    v = as_scalar("speed", speed, domain="positive")
    leg = as_scalar("leg_time", leg_time, domain="positive")
    a0 = as_scalar("start_angle", start_angle)
    check_work("leg_time", (t[-1] - t[0]) / leg, "legs (the span of times / leg_time)")
    turn_times = np.arange(t[0] + leg, t[-1], leg)
    start = r0 * np.array([np.cos(a0), np.sin(a0)])
    length = v * leg
    headings = np.empty(len(turn_times) + 1)
    p = start.copy()
    for i in range(len(headings)):
        r = np.hypot(p[0], p[1])
        tangent = np.arctan2(p[1], p[0]) + np.pi / 2
        headings[i] = tangent + rng.uniform(0.0, 2.0 * np.arcsin(min(1.0, length / (2.0 * r))))
        p = p + length * np.array([np.cos(headings[i]), np.sin(headings[i])])
    return turning_track(t, start, v, headings, turn_times)


@dataclass(frozen=True)
class PaperAParameters:
    r"""Paper A's simulation (sec. 2.1). Values the paper gives are its own; the others are the book's choice.

    Attributes
    ----------
    n_obs : int
        Number of ranges (paper A's figures run to about 3000 observations).
    interval : float
        Ranging interval [s] (chosen: 5 s).
    radius : float
        Starting range [m] (the paper gives none; chosen 1500 m).
    speed : float
        Platform speed [m/s] (chosen 2 m/s).
    track : str
        ``"turns"``: :func:`random_turn_track` (the paper's description); ``"circle"``: the exact circle of
        ``scenarios.circling_scenario``.
    leg_time : float
        Time between random turns [s] (chosen).
    noise_variance : float
        :math:`\sigma_r^2` [m²] (paper: "variance 5 m", read as 5 m²).
    gamma : float
        Paper A's relative sound-speed error :math:`\gamma = \mu_\gamma - 1` (paper: at most 1 %; taken at 1 %).
    gamma_sigma : float
        Ping-to-ping standard deviation :math:`\sigma_\gamma` of the relative error (0 in Figs. 3-5; Fig. 6 varies
        it, see :func:`variance_split`).
    bias_mean : float
        :math:`\mu_\upsilon` [m], paper A's :math:`\rho` (not given; chosen 50 m, which puts the plain EKF near the
        paper's 100 m).
    bias_sigma : float
        :math:`\sigma_\upsilon`, the stationary standard deviation of :math:`\tilde\upsilon_k` [m] (not given; chosen
        5 m).
    bias_time_constant : float
        :math:`T_\upsilon`, its correlation time [s] (not given; chosen 3000 s).
    dr_sigma : float
        DR noise per axis per epoch [m] (not given; chosen 1 m).

    Examples
    --------
    >>> from dataclasses import replace
    >>> from uwtutor.scenarios.paper_a import PaperAParameters
    >>> p = PaperAParameters()
    >>> p.n_obs, float(p.times[-1]), round(p.noise_sigma, 3)
    (3000, 14995.0, 2.236)
    >>> replace(p, n_obs=100, track="circle").times.shape
    (100,)
    """

    n_obs: int = 3000
    interval: float = 5.0
    radius: float = 1500.0
    speed: float = 2.0
    track: str = "turns"
    leg_time: float = 150.0
    noise_variance: float = 5.0
    gamma: float = 0.01
    gamma_sigma: float = 0.0
    bias_mean: float = 50.0
    bias_sigma: float = 5.0
    bias_time_constant: float = 3000.0
    dr_sigma: float = 1.0

    def __post_init__(self) -> None:
        as_int("n_obs", self.n_obs, minimum=2)
        check_work("n_obs", self.n_obs, "epochs")          # before the times are built
        if self.track not in ("turns", "circle"):
            raise ValueError(f'track must be "turns" or "circle"; got {self.track!r}')
        for name in ("interval", "radius", "speed", "leg_time", "noise_variance", "bias_time_constant"):
            as_scalar(name, getattr(self, name), domain="positive")
        for name in ("gamma_sigma", "bias_sigma", "dr_sigma"):
            as_scalar(name, getattr(self, name), domain="nonnegative")
        as_scalar("bias_mean", self.bias_mean)
        g = as_scalar("gamma", self.gamma)
        if not -0.5 < g < 0.5:
            raise ValueError(f"gamma is a relative sound-speed error and must lie in (-0.5, 0.5); got {g:g}")
        if self.gamma_sigma >= 0.1 / (1.0 + g):
            raise ValueError(f"gamma_sigma must be below 0.1 / (1 + gamma) (a sound-speed scatter under 10 %); "
                             f"got {self.gamma_sigma:g}")
        if self.track == "circle" and self.gamma_sigma > 0:
            raise ValueError('track="circle" (scenarios.circling_scenario) has no random multiplicative error; '
                             'use track="turns" with gamma_sigma > 0')

    @property
    def times(self) -> np.ndarray:
        """Epoch times [s], shape ``(n_obs,)``."""
        return self.interval * np.arange(self.n_obs)

    @property
    def noise_sigma(self) -> float:
        r""":math:`\sigma_r` [m]."""
        return float(np.sqrt(self.noise_variance))

    def error_parts(self) -> tuple[GaussianNoise, SoundSpeedMismatch, SlowBias]:
        r"""The three parts of the range error as ``ranging`` error models: :math:`\eta_k`, :math:`\gamma_k r_k`,
        :math:`\tilde\upsilon_k + \mu_\upsilon`.

        :math:`(\gamma_k - 1) r_k` is a ``SoundSpeedMismatch`` whose assumed speed is :math:`\mu_\gamma` times the
        true mean, with a ping-to-ping speed scatter that gives :math:`\sigma_\gamma` to first order.
        """
        c = 1500.0
        assumed = c * (1.0 + self.gamma)
        return (GaussianNoise(self.noise_sigma),
                SoundSpeedMismatch(true_speed=c, assumed_speed=assumed, speed_sigma=self.gamma_sigma * c**2 / assumed),
                SlowBias(self.bias_mean, self.bias_sigma, self.bias_time_constant))

    def make(self, rng: np.random.Generator, n_runs: Any = 1) -> Scenario:
        """Simulate ``n_runs`` runs (see :func:`make`)."""
        return make(rng, n_runs, self)


#: Paper A's parameters (``PaperAParameters()``: the paper's values and the book's choices).
PARAMETERS = PaperAParameters()


def _as_params(params: Any) -> PaperAParameters:
    p = PARAMETERS if params is None else params
    if not isinstance(p, PaperAParameters):
        raise TypeError(f"params must be a PaperAParameters; got {type(p).__name__}")
    return p


def make_with_truth(rng: np.random.Generator, n_runs: int = 1,
                    params: PaperAParameters | None = None) -> tuple[Scenario, np.ndarray]:
    r"""Paper A's simulation and its true slowly varying bias,
    :math:`\upsilon_k = (\mu_\gamma - 1) r_k + \tilde\upsilon_k + \mu_\upsilon`.

    The scenario is the one :func:`make` returns; the second array, shape ``(M, K)``, is the part of each range
    error that the IEKF's bias state should follow (the white :math:`\eta_k` and the ping-to-ping part of
    :math:`\gamma_k r_k` excluded), for bias errors and the NEES of the full state.

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of randomness.
    n_runs : int, default 1
        Number of Monte Carlo runs.
    params : PaperAParameters, optional
        Default :data:`PARAMETERS`.

    Returns
    -------
    (Scenario, ndarray)

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.scenarios import paper_a
    >>> sc, bias = paper_a.make_with_truth(np.random.default_rng(1), n_runs=2)
    >>> # what is left is the white noise, variance 5
    >>> white = sc.range_errors - bias
    >>> bool(abs(np.var(white) - 5.0) < 0.3)
    True
    """
    p = _as_params(params)
    rng = as_rng(rng)
    m = as_int("n_runs", n_runs, minimum=1)
    check_work("n_runs", 12 * m * p.n_obs, "floats (n_runs x params.n_obs x the DR, the ranges and three error parts)")
    geometry_rng, dr_rng, error_rng = rng.spawn(3)
    if p.track == "circle":
        # the geometry and the DR noise of scenarios.circling_scenario; the errors are drawn below, by part
        base = circling_scenario(dr_rng, m, radius=p.radius, speed=p.speed, interval=p.interval,
                                 duration=p.interval * (p.n_obs - 1), noise_sigma=0.0, gamma=0.0, bias_mean=0.0,
                                 bias_sigma=0.0, dr_sigma=p.dr_sigma)
        shape = "on a circle"
    else:
        track = random_turn_track(geometry_rng, p.times, p.radius, p.speed, p.leg_time)
        base = make_scenario(track, (0.0, 0.0), None, dr_rng, n_runs=m, dr_sigma=p.dr_sigma)
        shape = f"turning towards it every {p.leg_time:g} s"
    true_r = np.asarray(base.true_ranges)
    white, scale, slow = p.error_parts()
    streams = error_rng.spawn(3)
    parts = [model.sample(true_r[0], base.times, g, n_runs=m) for model, g in zip((white, scale, slow), streams)]
    bias = scale.mean_error(true_r) + parts[2]
    errors = parts[0] + parts[1] + parts[2]
    description = (f"Paper A: circling a buoy from {p.radius:g} m at {p.speed:g} m/s, {shape}, a range every "
                   f"{p.interval:g} s; range error N(0, {p.noise_variance:g}) + N({p.gamma:g}, "
                   f"{p.gamma_sigma:.3g}^2) r + slow bias (mean {p.bias_mean:g} m, std {p.bias_sigma:.3g} m, tau "
                   f"{p.bias_time_constant:g} s); DR noise {p.dr_sigma:g} m per axis")
    scenario = replace(base, ranges=add_range_errors(true_r, errors), range_errors=errors, description=description)
    return scenario, bias


def make(rng: np.random.Generator, n_runs: int = 1, params: PaperAParameters | None = None) -> Scenario:
    r"""Paper A's simulation: ``n_runs`` runs on one track, each with its own DR noise and range errors.

    The track is :func:`random_turn_track` (or, with ``params.track="circle"``, the circle of
    ``scenarios.circling_scenario``), shared by all runs; the range error is the sum of the three
    :meth:`PaperAParameters.error_parts`, each drawn from its own stream.

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of randomness (split into geometry, DR and range-error streams).
    n_runs : int, default 1
        Number of Monte Carlo runs (paper A's Fig. 6: 300).
    params : PaperAParameters, optional
        The parameters (default :data:`PARAMETERS`); change some with ``dataclasses.replace``.

    Returns
    -------
    Scenario
        ``true_positions`` (M, K, 2) shared by the runs, ``dr_displacements`` (M, K, 2), ``ranges`` (M, K), the
        beacon at the origin.

    See Also
    --------
    make_with_truth : the same scenario with its true slowly varying bias.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.scenarios import paper_a
    >>> sc = paper_a.make(np.random.default_rng(1), n_runs=4)
    >>> sc.ranges.shape, sc.dr_displacements.shape
    ((4, 3000), (4, 3000, 2))
    >>> # about rho + gamma r = 50 + 14 m
    >>> bias = sc.range_errors.mean()
    >>> bool(55.0 < bias < 75.0)
    True
    """
    return make_with_truth(rng, n_runs, params)[0]


def variance_split(bias_share: float, total_sigma: float = 20.0, params: PaperAParameters | None = None,
                   mean_range: float | None = None) -> PaperAParameters:
    r"""Paper A's Fig. 6 set-up: a fixed total variance shared between :math:`(\gamma_k - 1) r_k` and
    :math:`\tilde\upsilon_k`.

    With the share :math:`s` of the random bias,

    .. math::

        \sigma_\upsilon^2 = s\,\sigma_\mathrm{tot}^2, \qquad \sigma_\gamma^2 \bar r^2 = (1 - s)\,\sigma_\mathrm{tot}^2,

    :math:`\bar r` the mean range of the track, so that :math:`\operatorname{Var}(\gamma_k r_k) + \operatorname{Var}
    (\tilde\upsilon_k) = \sigma_\mathrm{tot}^2` on average over the track. The mean parts :math:`(\mu_\gamma - 1) r_k`
    and :math:`\mu_\upsilon` are left as in ``params``; :math:`\sigma_\mathrm{tot}` is not in the paper (chosen 20 m).

    Parameters
    ----------
    bias_share : float
        :math:`s \in [0, 1]`.
    total_sigma : float, default 20
        :math:`\sigma_\mathrm{tot}` [m].
    params : PaperAParameters, optional
        Base parameters (default: ``PaperAParameters(bias_mean=0.0)``, no constant bias besides
        :math:`(\mu_\gamma - 1) r_k`).
    mean_range : float, optional
        :math:`\bar r` [m]; default the starting range ``params.radius``.

    Returns
    -------
    PaperAParameters

    Examples
    --------
    >>> from uwtutor.scenarios.paper_a import variance_split
    >>> p = variance_split(0.25, total_sigma=20.0)
    >>> round(p.bias_sigma, 3), round(p.gamma_sigma * p.radius, 3)
    (10.0, 17.321)
    """
    s = as_scalar("bias_share", bias_share)
    if not 0.0 <= s <= 1.0:
        raise ValueError(f"bias_share is a fraction of the variance and must lie in [0, 1]; got {s:g}")
    total = as_scalar("total_sigma", total_sigma, domain="nonnegative")
    base = PaperAParameters(bias_mean=0.0) if params is None else _as_params(params)
    r_bar = base.radius if mean_range is None else as_scalar("mean_range", mean_range, domain="positive")
    gamma_sigma = float(np.sqrt(1.0 - s) * total / r_bar)
    if not gamma_sigma < 0.1 / (1.0 + base.gamma):            # the bound PaperAParameters holds gamma_sigma to
        raise ValueError(f"total_sigma = {total:g} m gives a range-proportional error of {gamma_sigma:.3g} of the "
                         f"range at {r_bar:g} m (above the 10 % a sound-speed scatter can make): give a total_sigma "
                         f"below {0.1 * r_bar / max(np.sqrt(1.0 - s), 1e-300):.3g} m, or a larger bias_share")
    return replace(base, bias_sigma=float(np.sqrt(s) * total), gamma_sigma=gamma_sigma)


# ---------------------------------------------------------------------------------------------------------------
# the lake trial
# ---------------------------------------------------------------------------------------------------------------

def _per_group(name: str, values: np.ndarray) -> None:
    if values.shape != (4,):
        raise ValueError(f"{name} must hold one value per group (4); got {values.size}")


@dataclass(frozen=True)
class LakeTrialParameters:
    r"""The structure of paper A's lake trial (sec. 2.2, Figs. 7-9), simulated.

    Two boats with GNSS: the sender transmits its position; the receiver ranges to it and knows its own
    displacement. The sender sent four groups of pings, groups 1-2 from a relative bearing of about 50 degrees
    and groups 3-4 from about 320 degrees (a 90-degree change of bearing), at similar ranges, with range noise
    that differs from group to group and depends little on range. The paper gives no more: the timing, speeds,
    ranges and error levels below are the book's choice.

    Attributes
    ----------
    range_m : float
        Mean distance between the boats [m].
    bearings_deg : tuple of 4 floats
        Bearing of the sender from the receiver in each group [deg, counter-clockwise from east].
    group_duration : float
        Length of each group of pings [s].
    gap : float
        Silence between two groups [s].
    interval : float
        Ping interval within a group [s].
    receiver_speed : float
        Speed of the receiver on its slow loop [m/s].
    sender_speed : float
        Speed of the sender's drift along the line of sight [m/s].
    group_bias : tuple of 4 floats
        Mean range error of each group [m] (a sound-speed or timing offset that differs a little between groups;
        make it differ between the two directions to see a single bias state fail).
    group_noise : tuple of 4 floats
        White range noise of each group [m].
    bias_sigma : float
        Standard deviation of the slowly varying part of the range error [m].
    bias_time_constant : float
        Its correlation time [s].
    gnss_sigma : float
        GNSS position noise per fix [m]; the displacements are differences of noisy fixes.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.scenarios.paper_a import LakeTrialParameters
    >>> p = LakeTrialParameters(group_duration=60.0, gap=30.0)
    >>> trial = p.make(np.random.default_rng(0), n_runs=2)
    >>> trial.ranges.shape
    (2, 166)
    """

    range_m: float = 800.0
    bearings_deg: tuple[float, float, float, float] = (50.0, 50.0, 320.0, 320.0)
    group_duration: float = 300.0
    gap: float = 120.0
    interval: float = 2.0
    receiver_speed: float = 1.5
    sender_speed: float = 1.0
    group_bias: tuple[float, float, float, float] = (10.0, 9.0, 11.0, 10.0)
    group_noise: tuple[float, float, float, float] = (1.0, 3.0, 2.0, 4.0)
    bias_sigma: float = 2.0
    bias_time_constant: float = 300.0
    gnss_sigma: float = 0.5

    def __post_init__(self) -> None:
        for name in ("range_m", "group_duration", "gap", "interval", "bias_time_constant"):
            as_scalar(name, getattr(self, name), domain="positive")
        for name in ("receiver_speed", "sender_speed", "bias_sigma", "gnss_sigma"):
            as_scalar(name, getattr(self, name), domain="nonnegative")
        for name in ("bearings_deg", "group_bias"):
            _per_group(name, as_finite(name, getattr(self, name), ndim=1))
        _per_group("group_noise", as_positive("group_noise", self.group_noise, ndim=1))

    def make(self, rng: np.random.Generator, n_runs: int = 1) -> LakeTrial:
        """Simulate ``n_runs`` runs (see :func:`make_lake_trial`)."""
        return make_lake_trial(rng, n_runs, self)


@dataclass(frozen=True, eq=False)
class LakeTrial:
    r"""A simulated lake trial: a receiver ranging to a moving sender, both positioned by GNSS.

    Attributes
    ----------
    times : ndarray, shape (K,)
        Epoch times [s] (pings and the silent epochs between groups).
    receiver : ndarray, shape (K, 2)
        True positions of the receiving boat [m].
    sender : ndarray, shape (K, 2)
        True positions of the sending boat (the moving beacon) [m].
    receiver_gnss : ndarray, shape (M, K, 2)
        The receiver's GNSS fixes (true + noise) [m].
    sender_gnss : ndarray, shape (M, K, 2)
        The sender's GNSS fixes [m].
    ranges : ndarray, shape (M, K)
        Measured ranges [m]; NaN between groups.
    range_errors : ndarray, shape (M, K)
        The errors (NaN between groups).
    group : ndarray of int, shape (K,)
        Group number 1-4 of each epoch, 0 between groups.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.scenarios.paper_a import make_lake_trial
    >>> trial = make_lake_trial(np.random.default_rng(0), n_runs=2)
    >>> relative, u = trial.relative()
    >>> relative.shape, u.shape, trial.n_runs
    ((781, 2), (2, 781, 2), 2)
    >>> # no range between the groups
    >>> bool(np.isnan(trial.ranges[:, trial.group == 0]).all())
    True
    """

    times: np.ndarray
    receiver: np.ndarray
    sender: np.ndarray
    receiver_gnss: np.ndarray
    sender_gnss: np.ndarray
    ranges: np.ndarray
    range_errors: np.ndarray
    group: np.ndarray

    @property
    def n_runs(self) -> int:
        """Number of runs M."""
        return self.ranges.shape[0]

    @property
    def receiver_displacements(self) -> np.ndarray:
        r""":math:`\mathbf u_{r,k}`: receiver GNSS displacement since the previous epoch, (M, K, 2); row 0 zeros."""
        return np.diff(self.receiver_gnss, axis=1, prepend=self.receiver_gnss[:, :1])

    @property
    def sender_displacements(self) -> np.ndarray:
        r""":math:`\mathbf u_{s,k}`: the sender's, (M, K, 2); row 0 zeros."""
        return np.diff(self.sender_gnss, axis=1, prepend=self.sender_gnss[:, :1])

    def relative(self) -> tuple[np.ndarray, np.ndarray]:
        r"""Paper A's equivalent fixed-beacon problem: the receiver relative to the sender.

        Returns ``(true_relative (K, 2), u (M, K, 2))`` with :math:`\mathbf p_k = \mathbf p_{r,k} - \mathbf p_{s,k}`
        (a platform moving round a fixed beacon at the origin) and :math:`\mathbf u_k = \mathbf u_{r,k} -
        \mathbf u_{s,k}`.
        """
        return self.receiver - self.sender, self.receiver_displacements - self.sender_displacements


def make_lake_trial(rng: np.random.Generator, n_runs: int = 1,
                    params: LakeTrialParameters | None = None) -> LakeTrial:
    r"""Simulate paper A's lake trial (structure only; see :class:`LakeTrialParameters`).

    The receiver drives a slow circle of radius 150 m; the sender stays at ``range_m`` from the receiver's centre
    at the group's bearing, drifting back and forth along the line of sight at ``sender_speed``, and moves to the
    new bearing during the gap before group 3. The range error of group :math:`g` is
    :math:`b_g + \tilde\upsilon_k + \eta_k`, :math:`\eta_k \sim N(0, \sigma_g^2)`, :math:`\tilde\upsilon_k` a slow
    Ornstein-Uhlenbeck bias.

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of randomness.
    n_runs : int, default 1
        Number of Monte Carlo runs.
    params : LakeTrialParameters, optional
        Default ``LakeTrialParameters()``.

    Returns
    -------
    LakeTrial

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.scenarios.paper_a import make_lake_trial
    >>> trial = make_lake_trial(np.random.default_rng(0), n_runs=3)
    >>> trial.ranges.shape == trial.range_errors.shape == (3, len(trial.times))
    True
    >>> sorted(set(trial.group.tolist()))
    [0, 1, 2, 3, 4]
    """
    p = LakeTrialParameters() if params is None else params
    if not isinstance(p, LakeTrialParameters):
        raise TypeError(f"params must be a LakeTrialParameters; got {type(p).__name__}")
    rng = as_rng(rng)
    m = as_int("n_runs", n_runs, minimum=1)
    period = p.group_duration + p.gap
    t_end = 4 * p.group_duration + 3 * p.gap
    check_work("params", t_end / p.interval, "epochs (4 group_duration + 3 gap, over interval)")
    check_work("n_runs", 8.0 * m * (t_end / p.interval + 1), "floats (n_runs x the epochs x GNSS fixes, ranges "
               "and errors)")
    times = np.arange(0.0, t_end + 1e-9, p.interval)
    g_index = np.floor(times / period).astype(int)
    in_group = (times - g_index * period) < p.group_duration
    group = np.where(in_group, np.minimum(g_index, 3) + 1, 0)
    receiver = circle_track(times, 150.0, max(p.receiver_speed, 1e-9), center=(0.0, 0.0)).positions
    if p.receiver_speed == 0:
        receiver = np.broadcast_to(receiver[:1], receiver.shape).copy()
    # bearing of the sender: groups 1-2 at the first bearing, 3-4 at the third; it swings across (by the shorter
    # way) during the silence between groups 2 and 3
    b12, b34 = np.deg2rad(p.bearings_deg[0]), np.deg2rad(p.bearings_deg[2])
    swing = (b34 - b12 + np.pi) % (2 * np.pi) - np.pi
    t_swing = 2 * p.group_duration + p.gap                      # the gap between groups 2 and 3 starts
    bearing = b12 + swing * np.clip((times - t_swing) / p.gap, 0.0, 1.0)
    los_wobble = p.sender_speed * p.group_duration / (2 * np.pi) * np.sin(2 * np.pi * times / p.group_duration)
    dist = p.range_m + los_wobble
    sender = dist[:, None] * np.column_stack([np.cos(bearing), np.sin(bearing)])
    geo_rng, err_rng = rng.spawn(2)
    rec_gnss = receiver + p.gnss_sigma * geo_rng.standard_normal((m, len(times), 2))
    snd_gnss = sender + p.gnss_sigma * geo_rng.standard_normal((m, len(times), 2))
    true_r = distances(receiver, sender)
    bias = SlowBias(0.0, p.bias_sigma, p.bias_time_constant).sample(true_r, times, err_rng, n_runs=m)
    gi = np.clip(group - 1, 0, 3)
    noise = np.asarray(p.group_noise)[gi] * err_rng.standard_normal((m, len(times)))
    err = np.asarray(p.group_bias)[gi] + bias + noise
    err = np.where(group > 0, err, np.nan)
    return LakeTrial(times=times, receiver=receiver, sender=sender, receiver_gnss=rec_gnss, sender_gnss=snd_gnss,
                     ranges=add_range_errors(true_r, err), range_errors=err, group=group)
