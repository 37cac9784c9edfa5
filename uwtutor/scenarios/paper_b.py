r"""Paper B's simulation: a leader AUV that broadcasts its position, a follower with dead reckoning only, one-way
travel-time ranges between them and an unknown current that carries both.

``PaperBParameters`` holds paper B's values (speeds, duration, depth, the dead-reckoning step :math:`\Delta t`, the
cooperative interval :math:`\delta t`, the current, the filter's :math:`\hat{\mathbf{x}}_1`, :math:`\mathbf{P}_1`,
:math:`\mathbf{Q}` and :math:`\mathbf{R}`) next to the choices the paper does not state, which are ours and marked
so: the tracks (the paper's figure only shows that they span about 8 km by 2.5 km), the true noise levels of the
ranges, of the leader's broadcast position and of the follower's dead reckoning, and the optional effects the paper
leaves out (lost packets, a current that changes, the leader's navigation drift, OWTT clock errors, the travel
time between send and reception, the whole-second ambiguity).

``make(rng, n_runs)`` simulates ``M`` runs at once over one deterministic pair of tracks; ``make_followers`` gives
several followers that hear the same broadcasts. The leader's and the follower's motion through the water is at
``speed``; the current carries both over ground (the leader knows its ground position, e.g. from bottom-lock DVL and
an inertial unit; the follower's speed log measures only its motion through the water, so its dead reckoning misses
the current). Dead reckoning is simulated at :math:`\Delta t` and summed over each cooperative interval into paper
B's motion radius vector, eq. (1): :math:`\mathbf{u}_k = \sum_{i} \Delta t\, v_i [\cos\theta_i, \sin\theta_i]`.

Randomness: ``rng`` is split (``Generator.spawn``) into independent streams for the dead reckoning, the leader's
broadcast errors, the range noise and the packet losses, so that changing one noise level does not change the
others' draws.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .._linalg import distances
from .._validate import (MAX_COORDINATE, as_finite, as_flag, as_instance, as_int, as_nonnegative, as_positive,
                         as_rng, as_scalar, check_work, readonly)
from ..motion import Track, circle_track, dead_reckoning, straight_track, turning_track
from ..acoustics import range_from_travel_time, travel_time_from_range
from ..errors import deprecated_aliases
from ..owtt import clock_range_error, simulate_owtt, wrap_travel_time
from ..ranging import add_range_errors

__all__ = ["PaperBParameters", "PARAMETERS", "CooperativeScenario", "make", "make_followers", "LEADER_PATTERNS",
           "FilterTuning", "paper_tuning", "matched_tuning"]

#: The leader patterns ``make`` knows.
LEADER_PATTERNS = ("zigzag", "parallel", "circling")


@dataclass(frozen=True)
class PaperBParameters:
    r"""Paper B's simulation (sec. 4) and filter parameters, with our choices for what it leaves open.

    Paper B's values: ``speed`` = 2 m/s for both vehicles, ``duration`` = 2500 s, ``depth`` = 10 m,
    ``dr_step`` :math:`\Delta t` = 1 s, ``interval`` :math:`\delta t` = 8 s, ``current`` = (0.5, 0.5) m/s,
    ``initial_estimate`` :math:`\hat{\mathbf{x}}_1 = [10, -100, 0, 0]`, ``initial_covariance``
    :math:`\mathbf{P}_1 = \operatorname{blkdiag}(10^8, 10^8, 10^7, 10^7)`, ``process_noise``
    :math:`\mathbf{Q} = \operatorname{blkdiag}(10^2, 10^2, 2^2, 2^2, 0.05^2, 0.05^2)` over
    :math:`[x, y, \Delta x, \Delta y, U_x, U_y]` and ``measurement_noise``
    :math:`\mathbf{R} = \operatorname{blkdiag}(10^2 \times 6, 2^2, 2^2, 0.05^2, 0.05^2)` over
    :math:`[x, y, x^\mathrm{M}_k, y^\mathrm{M}_k, x^\mathrm{M}_{k+1}, y^\mathrm{M}_{k+1}, \Delta x, \Delta y, U_x,
    U_y]` (diagonals stored here; the properties return the matrices).

    Ours (not in the paper): the follower starts at the origin heading east (so the initial estimate is 100.5 m
    off); the leader starts at ``leader_start`` and zigzags across the follower's path (legs of ``leg_duration``
    at :math:`\pm` ``zigzag_angle`` from the follower's heading), runs parallel to it, or circles (``circle_radius``)
    in the water; white noise of ``range_sigma`` on the ranges and ``leader_sigma`` per axis on the broadcast
    positions; speed-log and compass noise ``dr_speed_sigma`` and ``dr_heading_sigma`` per :math:`\Delta t`.

    Beyond the paper (all off by default): ``packet_loss`` (probability that a message is lost); ``current_after``
    and ``change_time`` (the current switches at that time); ``leader_drift`` (the leader's navigation error grows
    as this velocity times the time); ``owtt`` (simulate the send and reception times, the range then joins the
    leader at send time to the follower at reception, and the epochs are the reception times), with the follower's
    ``clock_offset`` [s] and ``clock_drift`` [s/s], ``sound_speed`` [m/s] and ``ambiguity_period`` (travel times
    known modulo it).

    Examples
    --------
    >>> from uwtutor.scenarios.paper_b import PaperBParameters
    >>> p = PaperBParameters()
    >>> p.n_epochs, p.x1.tolist(), p.Q.shape, p.R.shape
    (313, [10.0, -100.0, 0.0, 0.0], (6, 6), (10, 10))
    """

    speed: float = 2.0
    duration: float = 2500.0
    depth: float = 10.0
    dr_step: float = 1.0
    interval: float = 8.0
    current: tuple[float, float] = (0.5, 0.5)
    initial_estimate: tuple[float, ...] = (10.0, -100.0, 0.0, 0.0)
    initial_covariance_diag: tuple[float, ...] = (1e8, 1e8, 1e7, 1e7)
    process_noise_diag: tuple[float, ...] = (10.0**2, 10.0**2, 2.0**2, 2.0**2, 0.05**2, 0.05**2)
    measurement_noise_diag: tuple[float, ...] = (10.0**2,) * 6 + (2.0**2, 2.0**2, 0.05**2, 0.05**2)
    # -- ours: tracks and true noise
    follower_start: tuple[float, float] = (0.0, 0.0)
    follower_heading: float = 0.0
    leader_pattern: str = "zigzag"
    leader_start: tuple[float, float] = (500.0, -300.0)
    zigzag_angle: float = float(np.radians(75.0))
    leg_duration: float = 200.0
    circle_radius: float = 400.0
    range_sigma: float = 5.0
    leader_sigma: float = 5.0
    dr_speed_sigma: float = 0.05
    dr_heading_sigma: float = float(np.radians(1.0))
    # -- beyond the paper
    packet_loss: float = 0.0
    current_after: tuple[float, float] | None = None
    change_time: float | None = None
    leader_drift: tuple[float, float] = (0.0, 0.0)
    owtt: bool = False
    clock_offset: float = 0.0
    clock_drift: float = 0.0
    sound_speed: float = 1500.0
    ambiguity_period: float | None = None

    def __post_init__(self) -> None:
        for name in ("speed", "duration", "dr_step", "interval", "sound_speed"):
            as_scalar(name, getattr(self, name), domain="positive")    # a one-element list is refused by name
        ratio = self.interval / self.dr_step
        if abs(ratio - round(ratio)) > 1e-9:
            raise ValueError(f"interval must be a whole number of dr_step (paper B: 8 s = 8 x 1 s); got "
                             f"{self.interval:g} and {self.dr_step:g}")
        if self.leader_pattern not in LEADER_PATTERNS:
            raise ValueError(f"leader_pattern must be one of {LEADER_PATTERNS}; got {self.leader_pattern!r}")
        if not 0.0 <= as_scalar("packet_loss", self.packet_loss) < 1.0:
            raise ValueError(f"packet_loss must lie in [0, 1); got {self.packet_loss!r}")
        for name in ("range_sigma", "leader_sigma", "dr_speed_sigma", "dr_heading_sigma", "depth"):
            as_scalar(name, getattr(self, name), domain="nonnegative")
        for name in ("leg_duration", "circle_radius"):
            as_scalar(name, getattr(self, name), domain="positive")
        for name in ("follower_heading", "zigzag_angle", "clock_offset", "clock_drift"):
            as_scalar(name, getattr(self, name))
        for name in ("current", "follower_start", "leader_start", "leader_drift"):
            as_finite(name, getattr(self, name), shape=(2,))
        as_finite("initial_estimate", self.initial_estimate, shape=(4,))
        as_positive("initial_covariance_diag", self.initial_covariance_diag, shape=(4,))
        as_nonnegative("process_noise_diag", self.process_noise_diag, shape=(6,))
        as_positive("measurement_noise_diag", self.measurement_noise_diag, shape=(10,))
        as_flag("owtt", self.owtt)
        if self.current_after is not None:
            as_finite("current_after", self.current_after, shape=(2,))
        if self.change_time is not None:
            as_scalar("change_time", self.change_time)
        if self.ambiguity_period is not None:
            as_scalar("ambiguity_period", self.ambiguity_period, domain="positive")
        if (self.current_after is None) != (self.change_time is None):
            raise ValueError("give both current_after and change_time (or neither)")
        if self.ambiguity_period is not None and not self.owtt:
            raise ValueError("ambiguity_period needs owtt=True (travel times exist only in the OWTT simulation)")

    @property
    def x1(self) -> np.ndarray:
        r""":math:`\hat{\mathbf{x}}_1`, shape (4,)."""
        return np.array(self.initial_estimate, dtype=float)

    @property
    def P1(self) -> np.ndarray:
        r""":math:`\mathbf{P}_1`, shape (4, 4)."""
        return np.diag(np.array(self.initial_covariance_diag, dtype=float))

    @property
    def Q(self) -> np.ndarray:
        r"""Paper B's :math:`\mathbf{Q}`, shape (6, 6)."""
        return np.diag(np.array(self.process_noise_diag, dtype=float))

    @property
    def R(self) -> np.ndarray:
        r"""Paper B's :math:`\mathbf{R}`, shape (10, 10)."""
        return np.diag(np.array(self.measurement_noise_diag, dtype=float))

    @property
    def n_epochs(self) -> int:
        """Number of ranging epochs ``K + 1`` (313 for paper B: t = 0, 8, ..., 2496 s)."""
        return int(np.floor(self.duration / self.interval + 1e-9)) + 1


#: Paper B's parameters with our defaults for the rest.
PARAMETERS = PaperBParameters()


@dataclass(frozen=True)
class FilterTuning:
    r"""The noise a cooperative EKF is told about: :math:`\mathbf{P}_1` (4x4), paper B's :math:`\mathbf{Q}` (6x6)
    and :math:`\mathbf{R}` (10x10), and the range variance of the single-range variant [m²].

    Examples
    --------
    >>> from uwtutor.scenarios import paper_b
    >>> tuning = paper_b.paper_tuning()
    >>> sorted(tuning.as_kwargs()), tuning.P1.shape
    (['P0', 'Q', 'R', 'range_variance'], (4, 4))
    """

    P1: np.ndarray
    Q: np.ndarray
    R: np.ndarray
    range_variance: float

    def as_kwargs(self) -> dict[str, Any]:
        """``P0``, ``Q``, ``R`` and ``range_variance`` as keyword arguments of ``cooperative_ekf``."""
        return dict(P0=self.P1, Q=self.Q, R=self.R, range_variance=self.range_variance)


def paper_tuning(params: PaperBParameters | None = None) -> FilterTuning:
    r"""Paper B's own :math:`\mathbf{P}_1`, :math:`\mathbf{Q}` and :math:`\mathbf{R}`; the single range gets
    :math:`R_{11} + R_{33}` (the follower's and the leader's x variances, as they enter a range).

    Examples
    --------
    >>> from uwtutor.scenarios import paper_b
    >>> paper_b.paper_tuning().range_variance
    200.0
    """
    p = PARAMETERS if params is None else as_instance("params", params, PaperBParameters)
    return FilterTuning(p.P1, p.Q, p.R, float(p.R[0, 0] + p.R[2, 2]))


def matched_tuning(params: PaperBParameters | None = None, *, position_noise: float = 1.0,
                   current_noise: float = 1e-3) -> FilterTuning:
    r"""A tuning that knows the simulation's noise (ours, for comparison with paper B's).

    * :math:`\mathbf{Q}`: ``position_noise`` [m] and ``current_noise`` [m/s] per interval on :math:`x, y` and
      :math:`U_x, U_y` (small random walks that keep the filter from trusting its first linearizations forever), and
      the DR error of one interval on :math:`\Delta x, \Delta y`: :math:`\sqrt{N}\,\Delta t\,\max(\sigma_v,
      v\,\sigma_\theta)` for :math:`N = \delta t / \Delta t` steps;
    * :math:`\mathbf{R}`: twice the range noise variance on :math:`x, y` and twice the leader's on its coordinates
      (each range enters two pairs, so its information would otherwise be counted twice), the same DR and current
      terms;
    * the single range: :math:`\sigma_r^2 + \sigma_\mathrm{M}^2`, once;
    * :math:`\mathbf{P}_1 = \operatorname{diag}(d^2, d^2, 1, 1)` with :math:`d` the distance of paper B's initial
      estimate from the true start, and 1 (m/s)² for a current of unknown direction.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.scenarios import paper_b
    >>> tu = paper_b.matched_tuning()
    >>> tu.range_variance, np.sqrt(tu.Q[2, 2]).round(3)
    (50.0, np.float64(0.141))
    """
    p = PARAMETERS if params is None else as_instance("params", params, PaperBParameters)
    n = p.interval / p.dr_step
    dr = np.sqrt(n) * p.dr_step * max(p.dr_speed_sigma, p.speed * p.dr_heading_sigma)
    q = as_scalar("position_noise", position_noise, domain="positive", high=MAX_COORDINATE) ** 2
    cu = as_scalar("current_noise", current_noise, domain="positive", high=MAX_COORDINATE) ** 2
    Q = np.diag([q, q, dr**2, dr**2, cu, cu])
    R = np.diag([2 * p.range_sigma**2] * 2 + [2 * p.leader_sigma**2] * 4 + [dr**2, dr**2, cu, cu])
    d = float(np.linalg.norm(np.asarray(p.initial_estimate[:2]) - np.asarray(p.follower_start)))
    return FilterTuning(np.diag([d**2, d**2, 1.0, 1.0]), Q, R, float(p.range_sigma**2 + p.leader_sigma**2))


@dataclass(frozen=True, eq=False)
class CooperativeScenario:
    r"""``M`` simulated runs of paper B's cooperative localization over ``K + 1`` ranging epochs.

    Attributes
    ----------
    times : ndarray, shape (K + 1,)
        Epoch times [s]: the send times, or with ``owtt`` the reception times of the first run's geometry (the
        same in every run; the tracks are deterministic).
    true_positions : ndarray, shape (K + 1, 2)
        The follower over ground at the epochs [m].
    true_currents : ndarray, shape (K + 1, 2)
        The current at the epochs [m/s].
    leader_positions : ndarray, shape (K + 1, 2)
        The leader's true position when each message left [m].
    leader_broadcast : ndarray, shape (M, K + 1, 2)
        The position each message carries: the truth plus the leader's navigation error [m].
    dr_displacements : ndarray, shape (M, K, 2)
        Paper B's motion radius vectors :math:`\mathbf{u}_k` between consecutive epochs [m].
    dr_positions : ndarray, shape (M, K + 1, 2)
        The DR track: the true start plus the cumulated displacements [m].
    true_ranges : ndarray, shape (K + 1,)
        Horizontal distance the sound travelled [m].
    ranges : ndarray, shape (M, K + 1)
        Measured ranges [m], NaN where the message was lost; with an ``ambiguity_period`` they are known only
        modulo :math:`c\,T_\mathrm{s}` (see ``travel_times``).
    travel_times : ndarray, shape (M, K + 1)
        ``ranges / sound_speed`` [s], wrapped modulo the ambiguity period when there is one.
    dr_displacements_at_send : ndarray, shape (M, K, 2)
        With ``owtt``: the DR displacements between send times (what a filter that ignores the travel time uses);
        otherwise the same as ``dr_displacements``.
    true_positions_at_send : ndarray, shape (K + 1, 2)
        With ``owtt``: the follower when each message left; otherwise ``true_positions``.
    leader_positions_at_reception : ndarray, shape (K + 1, 2)
        With ``owtt``: the leader when each message arrived (the wrong one to pair with the range); otherwise
        ``leader_positions``.
    params : PaperBParameters
    description : str

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.scenarios import paper_b
    >>> sc = paper_b.make(np.random.default_rng(0), n_runs=2, duration=80.0)
    >>> sc.n_runs, sc.n_steps, sc.true_states.shape, sc.initial_estimate().tolist()
    (2, 10, (10, 4), [10.0, -100.0, 0.0, 0.0])
    """

    times: np.ndarray
    true_positions: np.ndarray
    true_currents: np.ndarray
    leader_positions: np.ndarray
    leader_broadcast: np.ndarray
    dr_displacements: np.ndarray
    dr_positions: np.ndarray
    true_ranges: np.ndarray
    ranges: np.ndarray
    travel_times: np.ndarray
    dr_displacements_at_send: np.ndarray
    true_positions_at_send: np.ndarray
    leader_positions_at_reception: np.ndarray
    params: PaperBParameters
    description: str = field(default="")

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if isinstance(value, np.ndarray):
                object.__setattr__(self, f.name, readonly(value))

    @property
    def n_runs(self) -> int:
        """Number of runs M."""
        return self.ranges.shape[0]

    @property
    def n_steps(self) -> int:
        """Number of filter steps K (one fewer than the epochs)."""
        return self.dr_displacements.shape[1]

    @property
    def true_states(self) -> np.ndarray:
        r"""The true :math:`[x, y, U_x, U_y]` at epochs 1..K, shape (K, 4): what ``cooperative_ekf``'s ``x``
        estimates."""
        return np.concatenate([self.true_positions[1:], self.true_currents[1:]], axis=-1)

    def initial_estimate(self) -> np.ndarray:
        r"""Paper B's :math:`\hat{\mathbf{x}}_1`, shape (4,), moved with this follower's start: the same initial
        error for every follower of ``make_followers`` (for ``make`` it is ``params.x1``)."""
        offset = self.params.x1[:2] - np.asarray(self.params.follower_start, dtype=float)
        return np.concatenate([self.true_positions[0] + offset, self.params.x1[2:]])


def _current_offset(t: np.ndarray, p: PaperBParameters) -> tuple[np.ndarray, np.ndarray]:
    """Displacement by the current since t = 0 and the current itself, at times t (shapes (..., 2))."""
    U1 = np.asarray(p.current, dtype=float)
    if p.current_after is None or p.change_time is None:  # both or neither (PaperBParameters checks)
        return t[..., None] * U1, np.broadcast_to(U1, t.shape + (2,)).copy()
    U2 = np.asarray(p.current_after, dtype=float)
    tc = float(p.change_time)
    before = np.minimum(t, tc)[..., None]
    after = np.maximum(t - tc, 0.0)[..., None]
    return before * U1 + after * U2, np.where((t < tc)[..., None], U1, U2)


def _leader_water_track(t: np.ndarray, p: PaperBParameters) -> Track:
    if p.leader_pattern == "parallel":
        return straight_track(t, p.leader_start, p.speed, p.follower_heading)
    if p.leader_pattern == "zigzag":
        n_legs = int(np.ceil(p.duration / p.leg_duration)) + 1
        signs = np.where(np.arange(n_legs) % 2 == 0, 1.0, -1.0)
        return turning_track(t, p.leader_start, p.speed, p.follower_heading + signs * p.zigzag_angle,
                             p.leg_duration * np.arange(1, n_legs))
    return circle_track(t, p.circle_radius, p.speed, center=p.leader_start)


def _over_ground(water: Track, p: PaperBParameters) -> Track:
    offset, U = _current_offset(water.times, p)
    return Track(water.times, water.positions + offset, water.velocities + U)


def _interp_rows(t_grid: np.ndarray, values: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Linear interpolation of values (M, N, 2) on t_grid (N,) at times t (K,) -> (M, K, 2)."""
    i = np.clip(np.searchsorted(t_grid, t, side="right") - 1, 0, len(t_grid) - 2)
    w = ((t - t_grid[i]) / (t_grid[i + 1] - t_grid[i]))[None, :, None]
    return values[:, i] * (1.0 - w) + values[:, i + 1] * w


def _simulate(rng: np.random.Generator, n_runs: int, p: PaperBParameters,
              followers: list[tuple[tuple[float, ...], float]]) -> list[CooperativeScenario]:
    rng_dr, rng_leader, rng_range, rng_loss = as_rng(rng).spawn(4)
    M = n_runs
    t1 = np.arange(0.0, p.duration + 1e-9, p.dr_step)
    step = int(round(p.interval / p.dr_step))
    send_idx = np.arange(0, len(t1), step)
    t_send = t1[send_idx]
    leader = _over_ground(_leader_water_track(t1, p), p)
    leader_true = leader.positions[send_idx]
    # the leader's navigation error: white noise plus a drift; one broadcast heard by every follower
    drift = np.asarray(p.leader_drift, dtype=float)
    leader_bc = (leader_true + t_send[:, None] * drift
                 + p.leader_sigma * rng_leader.standard_normal((M, len(t_send), 2)))
    out = []
    for f_index, (start, heading) in enumerate(followers):
        water = straight_track(t1, start, p.speed, heading)
        ground = _over_ground(water, p)
        dr = dead_reckoning(water, rng_dr, speed_sigma=p.dr_speed_sigma, heading_sigma=p.dr_heading_sigma,
                            n_runs=M)
        dr_grid = np.asarray(start, dtype=float) + np.cumsum(dr.displacements, axis=1)   # (M, N1, 2)
        if p.owtt:
            m = simulate_owtt(t_send, leader.position_at, ground.position_at, sound_speed=p.sound_speed)
            times = m.reception_times
            true_pos = m.follower_positions
            true_r = m.true_ranges
            clock = np.asarray(clock_range_error(times, p.clock_offset, p.clock_drift, p.sound_speed))
            dr_at = _interp_rows(t1, dr_grid, times)
            at_send, leader_rx = m.follower_positions_at_send, m.leader_positions_at_reception
        else:
            times = t_send
            true_pos = ground.positions[send_idx]
            true_r = distances(true_pos, leader_true, "norm")
            clock = np.zeros(len(times))
            dr_at = dr_grid[:, send_idx]
            at_send, leader_rx = true_pos, leader_true
        noise = p.range_sigma * rng_range.standard_normal((M, len(times)))
        ranges = add_range_errors(true_r, clock, noise)      # |true + clock + noise|: never negative
        travel = np.asarray(travel_time_from_range(ranges, p.sound_speed), dtype=float)
        if p.ambiguity_period is not None:
            travel = np.asarray(wrap_travel_time(travel, p.ambiguity_period), dtype=float)
            ranges = np.asarray(range_from_travel_time(travel, p.sound_speed), dtype=float)
        if p.packet_loss > 0:
            lost = rng_loss.random((M, len(times))) < p.packet_loss
            ranges = np.where(lost, np.nan, ranges)
            travel = np.where(lost, np.nan, travel)
        _, U = _current_offset(times, p)
        u = np.diff(dr_at, axis=1)
        u_send = np.diff(dr_grid[:, send_idx], axis=1)
        desc = (f"paper B: follower {f_index + 1} from {tuple(float(v) for v in start)} m heading "
                f"{np.degrees(heading):.0f} deg at {p.speed:g} m/s, leader {p.leader_pattern} from "
                f"{tuple(float(v) for v in p.leader_start)} m, current {tuple(p.current)} m/s, "
                f"{len(times)} epochs every {p.interval:g} s, {M} runs")
        out.append(CooperativeScenario(times=np.array(times), true_positions=np.array(true_pos), true_currents=U,
                                       leader_positions=np.array(leader_true), leader_broadcast=leader_bc,
                                       dr_displacements=u, dr_positions=dr_at, true_ranges=np.array(true_r),
                                       ranges=ranges, travel_times=travel, dr_displacements_at_send=u_send,
                                       true_positions_at_send=np.array(at_send),
                                       leader_positions_at_reception=np.array(leader_rx), params=p,
                                       description=desc))
    return out


def _params(params: PaperBParameters | None, changes: dict[str, Any]) -> PaperBParameters:
    base = PARAMETERS if params is None else params
    if not isinstance(base, PaperBParameters):
        raise TypeError(f"params must be a PaperBParameters; got {type(base).__name__}")
    unknown = set(changes) - {f.name for f in dataclasses.fields(PaperBParameters)}
    if unknown:
        raise TypeError(f"unknown parameter(s) {sorted(unknown)}; see PaperBParameters for the names")
    p = dataclasses.replace(base, **changes) if changes else base
    if not p.dr_step <= p.interval <= p.duration:
        raise ValueError(f"interval must lie between dr_step and duration ({p.dr_step:g} <= interval <= "
                         f"{p.duration:g} s); got {p.interval:g}")
    check_work("duration", p.duration / p.dr_step, "dead-reckoning steps (duration / dr_step)")
    return p


def make(rng: np.random.Generator, n_runs: int = 1, params: PaperBParameters | None = None,
         **changes: Any) -> CooperativeScenario:
    r"""Simulate ``n_runs`` runs of paper B's scenario.

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of randomness (split into independent streams, see the module docstring).
    n_runs : int, default 1
        Number of Monte Carlo runs ``M`` (the arrays keep their runs axis even for one run).
    params : PaperBParameters, optional
        The parameters (default ``PARAMETERS``).
    **changes
        Fields of ``PaperBParameters`` to change, e.g. ``leader_pattern="parallel"``, ``packet_loss=0.3``.

    Returns
    -------
    CooperativeScenario

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.scenarios import paper_b
    >>> sc = paper_b.make(np.random.default_rng(1), n_runs=3)
    >>> sc.ranges.shape, sc.dr_displacements.shape, sc.leader_broadcast.shape
    ((3, 313), (3, 312, 2), (3, 313, 2))
    >>> float(sc.times[-1]), sc.true_states.shape
    (2496.0, (312, 4))
    """
    M = as_int("n_runs", n_runs, minimum=1)
    p = _params(params, changes)
    check_work("n_runs", 20.0 * M * p.duration / p.dr_step, "floats (n_runs x the dead-reckoning steps)")
    follower = (tuple(float(v) for v in as_finite("follower_start", p.follower_start, shape=(2,))),
                float(p.follower_heading))
    return _simulate(rng, M, p, [follower])[0]


def make_followers(rng: np.random.Generator, n_runs: int, followers: Any, params: PaperBParameters | None = None,
                   **changes: Any) -> list[CooperativeScenario]:
    r"""Several followers that hear the same broadcasts of one leader (one OWTT message ranges them all).

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of randomness.
    n_runs : int
        Number of runs ``M``.
    followers : sequence of (start, heading)
        Each follower's start position [m] and heading [rad] (east = 0); all move at ``speed`` through the water.
    params : PaperBParameters, optional
        The parameters (default ``PARAMETERS``); ``follower_start`` and ``follower_heading`` are ignored.
    **changes
        Fields of ``PaperBParameters`` to change.

    Returns
    -------
    list of CooperativeScenario
        One per follower, sharing ``leader_positions`` and ``leader_broadcast`` (the same draws).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.scenarios import paper_b
    >>> first, second = paper_b.make_followers(
    ...     np.random.default_rng(0), 2, [((0.0, 0.0), 0.0), ((0.0, 200.0), 0.0)],
    ...     duration=80.0,
    ... )
    >>> # the same broadcasts heard by both
    >>> bool(np.array_equal(first.leader_broadcast, second.leader_broadcast))
    True
    >>> second.true_positions[0].tolist()
    [0.0, 200.0]
    """
    M = as_int("n_runs", n_runs, minimum=1)
    p = _params(params, changes)
    if not isinstance(followers, (list, tuple)):
        raise TypeError("followers must be a list of (start, heading) pairs, e.g. [((0.0, 0.0), 0.0)]; got "
                        f"{type(followers).__name__}")
    fl = []
    for i, item in enumerate(followers):
        try:
            start, heading = item
        except (TypeError, ValueError) as exc:
            raise ValueError(f"followers[{i}] must be a pair (start, heading); got {item!r}") from exc
        fl.append((tuple(float(v) for v in as_finite(f"followers[{i}] start", start, shape=(2,))),
                   float(as_finite(f"followers[{i}] heading", heading, ndim=0))))
    if not fl:
        raise ValueError("followers must hold at least one (start, heading) pair")
    # a work guard before anything is drawn: every run holds each follower's DR, ranges and truth at every step
    check_work("n_runs", 16.0 * M * len(fl) * p.duration / p.dr_step, "floats (n_runs x followers x the steps)")
    return _simulate(rng, M, p, fl)


#: The former name of the default parameters (one release): every scenario module calls its own ``PARAMETERS``.
__getattr__ = deprecated_aliases(__name__, {"PAPER_B": "PARAMETERS"})
