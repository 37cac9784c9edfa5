r"""Ready-made simulation scenarios: true tracks, DR displacements and measured ranges for ``M`` runs at once.

A ``Scenario`` is a plain dataclass of arrays with a leading axis of ``M`` Monte Carlo runs, so that a filter
can process the whole batch in one call. ``make_scenario`` builds one from a track, a beacon (fixed or moving)
and a range error model; three builders mirror the papers' simulations with their published parameters as
keyword defaults:

* ``circling_scenario`` -- a platform circling a buoy, white + multiplicative + slowly varying range error
  (Liu et al., paper A);
* ``approach_with_turn_scenario`` -- an approach with one heading change, sound-speed (multiplicative) error,
  pings every 10 s received at geometry-dependent times (Zhu et al. (2019), paper D);
* ``ship_and_submersible_scenario`` -- a submersible ranging to its S-turning mother ship, with patches of
  outliers (paper E).

Randomness: a builder splits its ``rng`` into two independent child streams (``Generator.spawn``), one for the
DR noise and one for the range errors. The range errors of a seed therefore do not change when only the DR
noise level changes, a convenience when comparing filters under different settings.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, cast

import numpy as np
from numpy.typing import ArrayLike

from .._linalg import distances
from .._validate import (MAX_COORDINATE, as_finite, as_flag, as_float_array, as_int, as_point, as_range_array,
                         as_rng, as_scalar, as_times, check_work, readonly)
from ..motion import Track, circle_track, displacement_noise, s_turn_track, straight_track, turning_track
from ..ranging import (GaussianNoise, Outliers, RangeErrorModel, SlowBias, SoundSpeedMismatch, measure_ranges,
                       reception_times)

__all__ = [
    "Scenario",
    "ScenarioRun",
    "make_scenario",
    "circling_scenario",
    "approach_with_turn_scenario",
    "ship_and_submersible_scenario",
]


def _as_measured(name: str, value: Any, shape: tuple[int, int]) -> np.ndarray:
    """Measured ranges of a scenario built or edited by hand: no infinities; NaN marks a missing measurement (the
    builders' ranges come from ``ranging.measure_ranges`` and are never negative; the filters check the sign)."""
    r = as_float_array(name, value, shape=shape)
    if np.isinf(r).any():
        raise ValueError(f"{name} must not be infinite; use NaN for a missing range")
    return r


def _as_list(name: str, value: Any) -> list:
    """A sequence (tuple, list or 1-D array) as a list; anything else refused by name."""
    if isinstance(value, np.ndarray) and value.ndim == 1:
        return list(value)
    if not isinstance(value, (tuple, list, range)):
        raise TypeError(f"{name} must be a sequence (a tuple or a list, one entry per patch of outliers); got "
                        f"{type(value).__name__}")
    return list(value)


def _dr_positions(true_positions: np.ndarray, dr_displacements: np.ndarray) -> np.ndarray:
    return true_positions[..., :1, :] + np.cumsum(dr_displacements, axis=-2)


@dataclass(frozen=True, eq=False)
class ScenarioRun:
    """One run of a ``Scenario``: the same arrays without the runs axis (returned by ``Scenario.run``).

    The fields have the names and meanings of the ``Scenario`` fields, with shapes ``(K,)`` for ``times``,
    ``true_ranges``, ``ranges``, ``range_errors`` and ``outlier_mask``, and ``(K, 2)`` for ``true_positions``,
    ``dr_displacements`` and ``beacon_positions``; ``index`` is the number of the run in its batch.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.scenarios import circling_scenario
    >>> sc = circling_scenario(np.random.default_rng(0), n_runs=3, duration=100.0)
    >>> run = sc.run(-1)
    >>> run.index, run.n_steps, run.ranges.shape, run.dr_positions.shape
    (2, 21, (21,), (21, 2))
    """

    times: np.ndarray
    true_positions: np.ndarray
    dr_displacements: np.ndarray
    beacon_positions: np.ndarray
    true_ranges: np.ndarray
    ranges: np.ndarray
    range_errors: np.ndarray
    outlier_mask: np.ndarray
    description: str
    index: int

    @property
    def n_steps(self) -> int:
        """Number of epochs K."""
        return len(self.times)

    @property
    def dr_positions(self) -> np.ndarray:
        """The DR track (shape ``(K, 2)``), the true start plus the cumulative DR displacements."""
        return _dr_positions(self.true_positions, self.dr_displacements)


@dataclass(frozen=True, eq=False)
class Scenario:
    """A batch of ``M`` simulated runs of single-beacon navigation over ``K`` epochs.

    Parameters
    ----------
    times
        Epoch (range reception) times [s], shape ``(K,)``, shared by all runs.
    true_positions
        True vehicle positions [m], shape ``(M, K, 2)``.
    dr_displacements
        DR estimate of ``true_positions[:, k] - true_positions[:, k - 1]``, shape ``(M, K, 2)``; row 0 is zeros.
        This is the filters' control input :math:`u_k`.
    beacon_positions
        Beacon position at each epoch, shape ``(M, K, 2)`` (a fixed beacon repeated, or a moving one).
    true_ranges
        True horizontal ranges [m], shape ``(M, K)``.
    ranges
        Measured ranges, ``|true_ranges + range_errors|`` (``ranging.measure_ranges``: the sum itself whenever
        it is non-negative), shape ``(M, K)``. In a hand-built or edited scenario (``dataclasses.replace``) NaN
        may mark a missing range.
    range_errors
        The errors drawn from the error model, shape ``(M, K)``.
    description
        What the scenario is (a string shown in plots and tables).
    outlier_mask
        Boolean, shape ``(M, K)``: the epochs that carry an outlier (all False without an ``Outliers`` model, or
        when omitted).

    Notes
    -----
    The arrays are read-only; the deterministic ones (e.g. a true track shared by all runs) may be broadcast
    views that take no memory per run. Copy an array (``np.array(...)``) before editing it.
    ``run(i)`` returns a ``ScenarioRun`` holding run ``i`` without the runs axis.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.motion import straight_track
    >>> from uwtutor.ranging import GaussianNoise
    >>> from uwtutor.scenarios import make_scenario
    >>> track = straight_track(np.arange(0.0, 100.0, 10.0), (-500.0, 200.0), 2.0, 0.0)
    >>> sc = make_scenario(
    ...     track, (0.0, 0.0), GaussianNoise(1.0), np.random.default_rng(0), n_runs=3
    ... )
    >>> sc.n_runs, sc.n_steps, sc.ranges.shape, sc.dr_positions.shape
    (3, 10, (3, 10), (3, 10, 2))
    """

    times: np.ndarray
    true_positions: np.ndarray
    dr_displacements: np.ndarray
    beacon_positions: np.ndarray
    true_ranges: np.ndarray
    ranges: np.ndarray
    range_errors: np.ndarray
    description: str = ""
    outlier_mask: np.ndarray | None = None

    def __post_init__(self) -> None:
        t = as_times("times", self.times)
        pos = as_finite("true_positions", self.true_positions, shape=(None, None, 2))
        m, k = pos.shape[:2]
        if m == 0:
            raise ValueError(f"true_positions has no runs (shape {pos.shape}): a scenario holds at least one run")
        if k != len(t):
            raise ValueError(f"true_positions must have one position per epoch: {k} along axis 1, times has {len(t)}")
        arrays = {
            "times": t,
            "true_positions": pos,
            "dr_displacements": as_finite("dr_displacements", self.dr_displacements, shape=(m, k, 2)),
            "beacon_positions": as_finite("beacon_positions", self.beacon_positions, shape=(m, k, 2)),
            "true_ranges": as_range_array("true_ranges", self.true_ranges, shape=(m, k)),
            "ranges": _as_measured("ranges", self.ranges, (m, k)),
            "range_errors": as_finite("range_errors", self.range_errors, shape=(m, k)),
        }
        if self.outlier_mask is None:
            arrays["outlier_mask"] = np.broadcast_to(False, (m, k))
        else:
            mask = np.asarray(self.outlier_mask)
            if mask.dtype != bool or mask.shape != (m, k):
                raise ValueError(f"outlier_mask must be a boolean array of shape {(m, k)}; "
                                 f"got {mask.dtype} {mask.shape}")
            arrays["outlier_mask"] = mask
        if not isinstance(self.description, str):
            raise TypeError(f"description must be a string; got {type(self.description).__name__}")
        for name, arr in arrays.items():
            object.__setattr__(self, name, readonly(arr))

    @property
    def n_runs(self) -> int:
        """Number of Monte Carlo runs M."""
        return self.true_positions.shape[0]

    @property
    def n_steps(self) -> int:
        """Number of epochs K."""
        return len(self.times)

    @property
    def dr_positions(self) -> np.ndarray:
        """The DR tracks (shape ``(M, K, 2)``), the true start plus the cumulative DR displacements."""
        return _dr_positions(self.true_positions, self.dr_displacements)

    def run(self, i: int) -> ScenarioRun:
        """Run ``i`` (negative indices count from the end) as a ``ScenarioRun``: views without the runs axis."""
        i = as_int("i", i)
        if not -self.n_runs <= i < self.n_runs:
            raise IndexError(f"run index {i} out of range for a scenario of {self.n_runs} run(s)")
        i %= self.n_runs
        mask = cast(np.ndarray, self.outlier_mask)  # never None after __post_init__ (all False when not given)
        return ScenarioRun(self.times, self.true_positions[i], self.dr_displacements[i], self.beacon_positions[i],
                           self.true_ranges[i], self.ranges[i], self.range_errors[i], mask[i], self.description, i)


def make_scenario(track: Track, beacon: ArrayLike | Track, error: RangeErrorModel | None, rng: np.random.Generator, *,
                  n_runs: int = 1, dr_sigma: float = 0.0, description: str = "") -> Scenario:
    r"""Simulate ``n_runs`` runs of a vehicle on ``track`` ranging to ``beacon``.

    Every run shares the true track; each run draws its own DR noise and range errors:

    .. math::

        u_k = (p_k - p_{k-1}) + w_k, \quad w_k \sim N(0, \sigma_{DR}^2 I_2), \qquad
        r_k = \|p_k - b_k\| + e_k,

    :math:`e_k` from ``error`` (``ranging.measure_ranges``: a negative sum is read as its magnitude). Ranges are
    horizontal and geometric at the epoch times (a moving beacon is taken at the same instant as the vehicle; use
    ``ranging.reception_times`` to build the epochs from the acoustic travel time, as
    ``approach_with_turn_scenario`` does).

    Parameters
    ----------
    track : Track
        True vehicle track; its times are the epochs.
    beacon : array_like, shape (2,), or Track
        A fixed beacon position [m] or a moving beacon's track (interpolated at the epochs).
    error : RangeErrorModel or None
        Range error model (``None``: exact ranges).
    rng : numpy.random.Generator
        Source of randomness (split into a DR stream and a range-error stream).
    n_runs : int, default 1
        Number of Monte Carlo runs ``M``.
    dr_sigma : float, default 0
        DR noise standard deviation per axis per epoch [m] (see ``motion.displacement_noise``).
    description : str, default ""
        Free text stored with the scenario.

    Returns
    -------
    Scenario

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.motion import straight_track
    >>> from uwtutor.ranging import GaussianNoise
    >>> from uwtutor.scenarios import make_scenario
    >>> track = straight_track(np.arange(0.0, 100.0, 10.0), (-500.0, 200.0), 2.0, 0.0)
    >>> sc = make_scenario(
    ...     track, (0.0, 0.0), GaussianNoise(1.0), np.random.default_rng(0), n_runs=3,
    ...     dr_sigma=0.5,
    ... )
    >>> sc.ranges.shape, sc.dr_displacements.shape
    ((3, 10), (3, 10, 2))
    >>> # the errors are those of the ranges
    >>> bool(np.allclose(sc.ranges - sc.true_ranges, sc.range_errors))
    True
    """
    if not isinstance(track, Track):
        raise TypeError(f"track must be a uwtutor.motion.Track; got {type(track).__name__}")
    if error is not None and not isinstance(error, RangeErrorModel):
        raise TypeError(f"error must be a range error model (e.g. GaussianNoise(1.0)) or None; "
                        f"got {type(error).__name__}")
    rng = as_rng(rng)
    m = as_int("n_runs", n_runs, minimum=1)
    sigma = as_scalar("dr_sigma", dr_sigma, domain="nonnegative")
    if not isinstance(description, str):
        raise TypeError(f"description must be a string; got {type(description).__name__}")
    times, k = track.times, track.n_steps
    check_work("n_runs", 8 * m * k, "floats (n_runs x the epochs x DR, ranges and errors)")
    beacon_xy = beacon.position_at(times) if isinstance(beacon, Track) else np.broadcast_to(as_point("beacon", beacon),
                                                                                              (k, 2))
    dr_rng, range_rng = rng.spawn(2)
    true_steps = np.diff(track.positions, axis=0, prepend=track.positions[:1])   # row 0: zeros
    dr = displacement_noise(true_steps, dr_rng, sigma, n_runs=m)
    true_ranges = distances(track.positions, beacon_xy)
    ranges, errors, mask = measure_ranges(true_ranges, times, error, range_rng, n_runs=m, return_errors=True)
    return Scenario(times=times,
                    true_positions=np.broadcast_to(track.positions, (m, k, 2)),
                    dr_displacements=dr,
                    beacon_positions=np.broadcast_to(beacon_xy, (m, k, 2)),
                    true_ranges=np.broadcast_to(true_ranges, (m, k)),
                    ranges=ranges,
                    range_errors=errors,
                    description=description,
                    outlier_mask=mask)


#: Floats a scenario holds per epoch and run (track, velocity, DR, range, error parts): the unit of its work guard.
_FLOATS_PER_EPOCH = 16


def _epochs(duration: float, interval: float, interval_name: str = "interval") -> np.ndarray:
    """0, interval, 2 interval, ... up to and including ``duration`` (when it is a multiple)."""
    count = duration / interval + 1e-9
    # a work guard counted in floats, before anything is computed: every epoch holds a track point, its velocity,
    # the DR, the range and its error parts, for every run (about 16 floats)
    check_work(f"duration / {interval_name}", _FLOATS_PER_EPOCH * count, "floats (16 per epoch)")
    n = int(np.floor(count)) + 1
    return interval * np.arange(n)


def circling_scenario(rng: np.random.Generator, n_runs: int = 1, *, radius: Any = 1500.0, speed: float = 2.0,
                      interval: float = 5.0, duration: float = 10000.0, center: Any = (0.0, 0.0),
                      noise_sigma: float = np.sqrt(5.0), gamma: float = 0.005, bias_mean: float = 5.0,
                      bias_sigma: float = 3.0, bias_time_constant: float = 600.0, dr_sigma: float = 0.5) -> Scenario:
    r"""Paper A (Liu et al.): a platform circling a buoy, range error = white + :math:`\gamma r_k` + slow bias.

    The platform circles the beacon (at the origin) counter-clockwise, starting due south of ``center``; the
    range error is

    .. math::

        e_k = \eta_k + \gamma\, r_k + \mu_k + \rho, \qquad \eta_k \sim N(0, \sigma_\eta^2),

    with :math:`\mu_k + \rho` the ``SlowBias(bias_mean, bias_sigma, bias_time_constant)`` process and
    :math:`\gamma r_k` a sound-speed scale error (``SoundSpeedMismatch`` with no ping-to-ping scatter).
    With the defaults the bearing to the buoy turns by 90 degrees in about 236 epochs, close to the paper's
    "about 200 observations" at which the precision factor reaches 1 (Fig. 2).

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of randomness.
    n_runs : int, default 1
        Number of Monte Carlo runs.
    radius, speed : float
        Circle radius [m] (paper A gives none; 1500 m chosen) and platform speed [m/s].
    interval, duration : float
        Ranging interval and total time [s].
    center : array_like, shape (2,)
        Centre of the circle [m]; offset it from the origin to make the ranges vary.
    noise_sigma : float
        :math:`\sigma_\eta` [m]; the paper's "variance 5" read as 5 m².
    gamma : float
        Relative sound-speed error :math:`\gamma` (paper: at most 1 %).
    bias_mean, bias_sigma, bias_time_constant : float
        :math:`\rho` [m], stationary std of :math:`\mu_k` [m] and its correlation time [s] (not given in the
        paper; chosen).
    dr_sigma : float
        DR noise per axis per epoch [m] (chosen).

    Returns
    -------
    Scenario

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.scenarios import circling_scenario
    >>> sc = circling_scenario(np.random.default_rng(0), n_runs=2, duration=500.0)
    >>> sc.ranges.shape
    (2, 101)
    >>> # the circle is centred on the buoy: the true range stays 1500 m
    >>> bool(np.allclose(sc.true_ranges, 1500.0))
    True
    """
    times = _epochs(as_scalar("duration", duration, domain="positive"),
                    as_scalar("interval", interval, domain="positive"))
    track = circle_track(times, radius, as_scalar("speed", speed, domain="positive"), center=center,
                         start_angle=-np.pi / 2)
    g = as_scalar("gamma", gamma)
    if not -0.5 < g < 0.5:
        raise ValueError(f"gamma is a relative sound-speed error and must lie in (-0.5, 0.5); got {g:g}")
    noise = GaussianNoise(as_scalar("noise_sigma", noise_sigma, domain="nonnegative"))
    sound = SoundSpeedMismatch(true_speed=1500.0, assumed_speed=1500.0 * (1.0 + g), speed_sigma=0.0)
    bias = SlowBias(as_scalar("bias_mean", bias_mean), as_scalar("bias_sigma", bias_sigma, domain="nonnegative"),
                    as_scalar("bias_time_constant", bias_time_constant, domain="positive"))
    error = noise + sound + bias
    description = (f"Paper A: circling a buoy, R = {float(radius):g} m at {float(speed):g} m/s, a range every "
                   f"{float(interval):g} s; range error N(0, {float(noise_sigma):.3g}^2) + {g:g} r + slow bias "
                   f"(mean {bias.mean:g} m, std {bias.sigma:g} m, tau {bias.time_constant:g} s)")
    return make_scenario(track, (0.0, 0.0), error, rng, n_runs=n_runs, dr_sigma=dr_sigma, description=description)


def approach_with_turn_scenario(rng: np.random.Generator, n_runs: int = 1, *, start: ArrayLike = (-3000.0, -1500.0),
                                speed: float = 2.0, headings: ArrayLike = (np.deg2rad(15.0), np.deg2rad(60.0)),
                                turn_time: float = 700.0, ping_interval: float = 10.0, duration: float = 1500.0,
                                true_speed: float = 1500.0, assumed_speed: Any = 1470.0, speed_sigma: Any = 1.0,
                                noise_sigma: float = 0.7, dr_sigma: float = 0.9) -> Scenario:
    r"""Paper D (Zhu et al. 2019): an approach to a beacon with one heading change, under multiplicative noise.

    The beacon at the origin pings every ``ping_interval`` seconds from :math:`t = 0`; the vehicle, leaving
    ``start`` at :math:`t = 0` at 2 m/s, hears each ping at a reception time computed from the geometry
    (``ranging.reception_times`` with the mean sound speed), so the epochs are not equally spaced. It turns once,
    from ``headings[0]`` to ``headings[1]`` at ``turn_time``, which removes the mirror ambiguity of a straight
    track. Range error (per ping, per run):

    .. math::

        e_k = r_k\left(\frac{c_a}{c'_k} - 1\right) + n_k, \qquad c'_k \sim N(1500, 1^2),\ c_a = 1470,\
        n_k \sim N(0, 0.7^2),

    and the DR displacements have N(0, 0.81) noise per axis per ping. The paper does not give the track; the
    default one runs from about 3.4 km to about 0.9 km from the beacon and turns by 45 degrees.

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of randomness.
    n_runs : int, default 1
        Number of Monte Carlo runs (the paper uses 1000).
    start : array_like, shape (2,)
        Position at :math:`t = 0` [m].
    speed : float
        Vehicle speed [m/s].
    headings : pair of float
        Headings before and after the turn [rad] (0 = east, counter-clockwise).
    turn_time : float
        Time of the heading change [s].
    ping_interval, duration : float
        Ping period and the time span of the pings [s] (pings at 0, 10, ..., 1500 s).
    true_speed, assumed_speed, speed_sigma : float
        Sound-speed model, see ``ranging.SoundSpeedMismatch`` [m/s].
    noise_sigma : float
        Extra white range noise [m] (variance 0.49).
    dr_sigma : float
        DR noise per axis per ping [m] (variance 0.81).

    Returns
    -------
    Scenario

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.scenarios import approach_with_turn_scenario
    >>> sc = approach_with_turn_scenario(np.random.default_rng(0), n_runs=2)
    >>> sc.ranges.shape
    (2, 151)
    >>> # pings every 10 s, each heard a travel time later (2.2 s for the first)
    >>> round(float(sc.times[0]), 2), round(float(sc.times[1] - sc.times[0]), 3)
    (2.23, 9.987)
    """
    pings = _epochs(as_scalar("duration", duration, domain="positive"),
                    as_scalar("ping_interval", ping_interval, domain="positive"), "ping_interval")
    turn = as_scalar("turn_time", turn_time)
    # a sound speed in water (about 1400-1600 m/s): a tiny one would put the receptions beyond float64's range
    true_speed = as_scalar("true_speed", true_speed, low=1000.0, high=2000.0)
    noise_sigma = as_scalar("noise_sigma", noise_sigma, domain="nonnegative")
    psi = as_finite("headings", headings, shape=(2,))
    start = as_finite("start", start, shape=(2,), max_abs=MAX_COORDINATE)
    speed = as_scalar("speed", speed, domain="positive")
    # A track sampled at the pings and the turn is exact under linear interpolation (straight legs between
    # samples) and beyond its end (extrapolated along the last leg): the reception-time iteration can use it.
    path = turning_track(np.union1d(pings, [turn]), start, speed, psi, [turn])
    t_r, _ = reception_times(pings, (0.0, 0.0), path.position_at, true_speed)
    track = turning_track(t_r, path.position_at(t_r[0]), speed, psi, [turn])
    sound = SoundSpeedMismatch(true_speed, assumed_speed, speed_sigma)
    noise = GaussianNoise(noise_sigma)
    error = sound + noise
    description = (f"Paper D: approach with one turn at {turn:g} s, {float(speed):g} m/s, a ping every "
                   f"{float(ping_interval):g} s; sound speed N({sound.true_speed:g}, {sound.speed_sigma:g}^2) "
                   f"converted with {sound.assumed_speed:g} m/s, range noise std {noise.sigma:g} m, "
                   f"DR noise std {as_scalar('dr_sigma', dr_sigma, domain='nonnegative'):g} m per axis per ping")
    return make_scenario(track, (0.0, 0.0), error, rng, n_runs=n_runs, dr_sigma=dr_sigma, description=description)


def ship_and_submersible_scenario(rng: np.random.Generator, n_runs: int = 1, *, duration: float = 1200.0,
                                  interval: float = 1.0, ship_start: ArrayLike = (0.0, 0.0),
                                  ship_velocity: ArrayLike = (2.0, 2.0), turn_rate: Any = -np.deg2rad(0.3),
                                  half_period: Any = 600.0, sub_start: ArrayLike = (-1000.0, -1000.0),
                                  sub_velocity: ArrayLike = (1.0, 1.0), noise_sigma: float = np.sqrt(2.0),
                                  outlier_amplitude: float = 80.0, outlier_onsets: ArrayLike = (300.0, 700.0),
                                  outlier_counts: Any = (10, 20), outlier_two_sided: Any = (False, True),
                                  dr_sigma: float = 0.1) -> Scenario:
    r"""Paper E: a submersible ranging to its S-turning mother ship, with patches of outliers.

    The ship (the moving beacon) starts with the velocity ``ship_velocity`` (2 m/s north and east) and weaves:
    turn right at 0.3 deg/s for ``half_period``, then left (``motion.s_turn_track``). The submersible goes
    straight at 1 m/s north and 1 m/s east. A range every second for 1200 s with white noise of variance 2
    (the paper's range-filter noise) plus outliers of 80 m: 10 one-sided at 300 s and 20 two-sided at 700 s.
    ``Scenario.outlier_mask`` marks them. The paper's turn rate of "0.3" is read as deg/s (0.3 rad/s would spin
    the ship round every 21 s). Positions are horizontal; the default geometry keeps the ranges between about
    1.1 and 2.2 km.

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of randomness.
    n_runs : int, default 1
        Number of Monte Carlo runs.
    duration, interval : float
        Total time and ranging interval [s].
    ship_start, ship_velocity : array_like, shape (2,)
        Ship start [m] and initial velocity [m/s].
    turn_rate, half_period : float
        Ship's turn rate [rad/s] (negative: right first) and how long it turns each way [s].
    sub_start, sub_velocity : array_like, shape (2,)
        Submersible start [m] and constant velocity [m/s].
    noise_sigma : float
        White range noise [m].
    outlier_amplitude : float
        Outlier size [m].
    outlier_onsets, outlier_counts, outlier_two_sided : sequences of equal length
        One patch of outliers per entry: start time [s], number of epochs, two-sidedness.
    dr_sigma : float
        Submersible's DR noise per axis per epoch [m] (chosen).

    Returns
    -------
    Scenario

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.scenarios import ship_and_submersible_scenario
    >>> sc = ship_and_submersible_scenario(np.random.default_rng(0))
    >>> sc.ranges.shape, int(sc.outlier_mask.sum())
    ((1, 1201), 30)
    """
    times = _epochs(as_scalar("duration", duration, domain="positive"),
                    as_scalar("interval", interval, domain="positive"))
    ship_v = as_point("ship_velocity", ship_velocity)
    sub_v = as_point("sub_velocity", sub_velocity)
    ship = s_turn_track(times, as_point("ship_start", ship_start), np.hypot(*ship_v), np.arctan2(ship_v[1], ship_v[0]),
                        turn_rate, half_period)
    sub = straight_track(times, as_point("sub_start", sub_start), np.hypot(*sub_v), np.arctan2(sub_v[1], sub_v[0]))
    onsets = as_finite("outlier_onsets", outlier_onsets, ndim=1)
    counts = _as_list("outlier_counts", outlier_counts)
    sides = _as_list("outlier_two_sided", outlier_two_sided)
    if not len(onsets) == len(counts) == len(sides):
        raise ValueError("outlier_onsets, outlier_counts and outlier_two_sided must have the same length; got "
                         f"{len(onsets)}, {len(counts)} and {len(sides)}")
    amplitude = as_scalar("outlier_amplitude", outlier_amplitude, domain="nonnegative")
    error: RangeErrorModel = GaussianNoise(as_scalar("noise_sigma", noise_sigma, domain="nonnegative"))
    for i, (onset, count, two_sided) in enumerate(zip(onsets, counts, sides)):
        error = error + Outliers((onset,), as_int(f"outlier_counts[{i}]", count, minimum=1), amplitude,
                                 two_sided=as_flag(f"outlier_two_sided[{i}]", two_sided))
    patches = ", ".join(f"{c} {'two' if s else 'one'}-sided at {o:g} s" for o, c, s in zip(onsets, counts, sides))
    description = (f"Paper E: submersible ranging to an S-turning ship every {float(interval):g} s for "
                   f"{float(duration):g} s; range noise std {float(noise_sigma):.3g} m; outliers of "
                   f"{float(outlier_amplitude):g} m: {patches or 'none'}")
    return make_scenario(sub, ship, error, rng, n_runs=n_runs, dr_sigma=dr_sigma, description=description)
