r"""Vehicle motion in the horizontal plane: tracks, dead reckoning and currents.

Positions are 2-D, ``[x, y]`` = ``[east, north]`` in metres; headings are in radians in the *mathematical*
convention (0 along +x, counter-clockwise positive), not the compass convention. A ``Track`` is the true motion,
sampled at the ranging epochs; the generators below build the tracks that the papers' experiments use, each exact
(closed form, no numerical integration):

* ``circle_track`` -- circling a buoy (Liu et al., paper A);
* ``straight_track`` and ``turning_track`` -- straight legs with heading changes (Zhu et al. (2019), paper D:
  one heading change removes the mirror ambiguity of a straight track);
* ``s_turn_track`` -- the mother ship's S-shaped track of paper E;
* ``lawnmower_track`` -- a survey pattern;
* ``with_current`` -- the ground track when a constant current carries the vehicle (paper B).

``dead_reckoning`` and ``displacement_noise`` turn a true track into what the vehicle believes: dead-reckoned
(DR) displacements :math:`u_k` between epochs, the control input of every single-beacon filter.
``integrate_odometry`` goes the other way for logged body-frame odometry (distance travelled and heading change
per step, as wheel odometry or a log and a gyro give them, and as ``uwtutor.datasets`` stores them): it
integrates them into poses.
Monte Carlo batches carry a leading axis of ``M`` runs: ``(M, K, 2)`` instead of ``(K, 2)``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ._validate import (as_flag, as_finite, as_n_runs, as_point, as_rng, as_scalar,
                        as_times, check_same_length, check_work, readonly, with_runs)

__all__ = [
    "Track",
    "circle_track",
    "straight_track",
    "turning_track",
    "s_turn_track",
    "lawnmower_track",
    "with_current",
    "DeadReckoningResult",
    "dead_reckoning",
    "displacement_noise",
    "integrate_odometry",
]


# ----------------------------------------------------------------------------------------------------------------
# private helpers (also used by uwtutor.ranging and uwtutor.scenarios)

def _unit(angle: np.ndarray) -> np.ndarray:
    """Unit vectors ``[cos a, sin a]`` with the components on a new last axis."""
    return np.stack([np.cos(angle), np.sin(angle)], axis=-1)


def _arc(heading0: Any, rate: Any, speed: float, duration: Any) -> np.ndarray:
    r"""Displacement after ``duration`` at constant ``speed`` while the heading turns at a constant ``rate``.

    Integrating :math:`v[\cos\psi, \sin\psi]` with :math:`\psi = \psi_0 + \omega t` gives the chord
    :math:`v\,t\,\mathrm{sinc}(\omega t/2)\,[\cos, \sin](\psi_0 + \omega t/2)`: the chord points along the mean
    heading. This form is exact and stays accurate as :math:`\omega \to 0` (a straight line).
    """
    half_turn = np.asarray(rate) * np.asarray(duration) / 2.0
    length = speed * np.asarray(duration) * np.sinc(half_turn / np.pi)  # numpy's sinc is sin(pi x)/(pi x)
    return length[..., None] * _unit(np.asarray(heading0) + half_turn)


def _times_start_speed(times: Any, start: Any, speed: Any) -> tuple[np.ndarray, np.ndarray, float]:
    """The arguments every track that leaves a start point shares: its epoch times, start and speed (>= 0)."""
    return (as_times("times", times), as_point("start", start),
            as_scalar("speed", speed, domain="nonnegative"))


# ----------------------------------------------------------------------------------------------------------------
# tracks

@dataclass(frozen=True, eq=False)
class Track:
    """A true 2-D trajectory sampled at epoch times.

    Parameters
    ----------
    times : array_like, shape (K,)
        Epoch times [s], strictly increasing.
    positions : array_like, shape (K, 2)
        True positions ``[x east, y north]`` [m] at those times.
    velocities : array_like, shape (K, 2)
        True velocities [m/s] at those times (after a heading change, the new velocity).

    Notes
    -----
    The arrays are stored as read-only views, so a ``Track`` cannot be edited through its attributes. Build a
    new one (for example with ``with_current``) instead.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.motion import Track
    >>> track = Track(np.arange(2.0), [[0.0, 0.0], [1.0, 0.0]], [[1.0, 0.0], [1.0, 0.0]])
    >>> track.n_steps, track.position_at(0.5)
    (2, array([0.5, 0. ]))
    """

    times: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray

    def __post_init__(self) -> None:
        t = as_times("times", self.times)
        p = as_finite("positions", self.positions, shape=(None, 2))
        v = as_finite("velocities", self.velocities, shape=(None, 2))
        check_same_length(times=t, positions=p, velocities=v)
        for name, arr in (("times", t), ("positions", p), ("velocities", v)):
            object.__setattr__(self, name, readonly(arr))

    @property
    def n_steps(self) -> int:
        """Number of epochs K."""
        return len(self.times)

    @property
    def headings(self) -> np.ndarray:
        """Heading of the velocity at each epoch [rad], ``atan2(vy, vx)``: 0 = +x (east), counter-clockwise."""
        return np.arctan2(self.velocities[:, 1], self.velocities[:, 0])

    @property
    def speeds(self) -> np.ndarray:
        """Speed over ground at each epoch [m/s]."""
        return np.hypot(self.velocities[:, 0], self.velocities[:, 1])

    def position_at(self, t: ArrayLike) -> np.ndarray:
        """Position at arbitrary times by linear interpolation between the epochs.

        Before the first epoch and after the last one the position is extrapolated along the first or last
        velocity (so that, e.g., a reception slightly after the last epoch is still defined).

        Parameters
        ----------
        t : float or array_like
            Times [s], any shape ``S``.

        Returns
        -------
        ndarray, shape S + (2,)
            Positions [m].
        """
        t = as_finite("t", t)
        times, pos, vel = self.times, self.positions, self.velocities
        before = pos[0] + (t - times[0])[..., None] * vel[0]
        after = pos[-1] + (t - times[-1])[..., None] * vel[-1]
        if len(times) == 1:
            return np.where((t < times[0])[..., None], before, after)
        i = np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 2)
        frac = ((t - times[i]) / (times[i + 1] - times[i]))[..., None]
        inside = pos[i] + frac * (pos[i + 1] - pos[i])
        return np.where((t < times[0])[..., None], before, np.where((t > times[-1])[..., None], after, inside))


def circle_track(times: ArrayLike, radius: float, speed: float, center: ArrayLike = (0.0, 0.0),
                 start_angle: float = 0.0,
                 clockwise: bool = False) -> Track:
    r"""Constant-speed circle, e.g. a platform circling a buoy (Liu et al., paper A).

    .. math::

        \theta(t) = \theta_0 \pm \frac{v}{R}(t - t_0), \qquad
        p(t) = c + R\,[\cos\theta, \sin\theta], \qquad
        \dot p(t) = \pm v\,[-\sin\theta, \cos\theta]

    (``+`` counter-clockwise, ``-`` clockwise).

    Parameters
    ----------
    times : array_like, shape (K,)
        Epoch times [s], strictly increasing; the motion starts at ``times[0]``.
    radius : float
        Circle radius :math:`R` [m], > 0.
    speed : float
        Speed along the circle :math:`v` [m/s], >= 0.
    center : array_like, shape (2,), default (0, 0)
        Circle centre :math:`c` [m].
    start_angle : float, default 0
        Polar angle :math:`\theta_0` of the start point seen from the centre [rad] (0: east of the centre).
    clockwise : bool, default False
        Direction of travel.

    Returns
    -------
    Track

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.motion import circle_track
    >>> # a quarter of a 100 m circle at 2 m/s takes 25 pi seconds
    >>> track = circle_track(np.array([0.0, 25.0 * np.pi]), radius=100.0, speed=2.0)
    >>> track.positions.round(3)
    array([[100.,   0.],
           [  0., 100.]])
    """
    clockwise = as_flag("clockwise", clockwise)
    t = as_times("times", times)
    R = as_scalar("radius", radius, domain="positive")
    v = as_scalar("speed", speed, domain="nonnegative")
    c = as_point("center", center)
    a0 = as_scalar("start_angle", start_angle)
    sense = -1.0 if clockwise else 1.0
    theta = a0 + sense * v / R * (t - t[0])
    radial = _unit(theta)
    tangent = np.stack([-radial[:, 1], radial[:, 0]], axis=-1)
    return Track(t, c + R * radial, sense * v * tangent)


def straight_track(times: ArrayLike, start: ArrayLike, speed: float, heading: float) -> Track:
    r"""Constant velocity: :math:`p(t) = p_0 + v\,(t - t_0)\,[\cos\psi, \sin\psi]`.

    Parameters
    ----------
    times : array_like, shape (K,)
        Epoch times [s], strictly increasing.
    start : array_like, shape (2,)
        Position :math:`p_0` at ``times[0]`` [m].
    speed : float
        Speed :math:`v` [m/s], >= 0.
    heading : float
        Heading :math:`\psi` [rad], 0 = east, counter-clockwise.

    Returns
    -------
    Track

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.motion import straight_track
    >>> track = straight_track(np.arange(3.0), start=(0.0, 0.0), speed=2.0, heading=0.0)
    >>> track.positions
    array([[0., 0.],
           [2., 0.],
           [4., 0.]])
    """
    t, p0, v = _times_start_speed(times, start, speed)
    psi = as_scalar("heading", heading)
    u = _unit(np.asarray(psi))
    return Track(t, p0 + v * (t - t[0])[:, None] * u, np.broadcast_to(v * u, (len(t), 2)))


def turning_track(times: ArrayLike, start: ArrayLike, speed: float, headings: ArrayLike,
                  turn_times: ArrayLike) -> Track:
    r"""Straight legs at constant speed with instantaneous heading changes.

    The vehicle leaves ``start`` at ``times[0]`` with heading ``headings[0]``; at ``turn_times[i]`` it switches
    to ``headings[i + 1]``. An approach with one heading change is the track of Zhu et al. (2019), paper D.
    The position is the exact integral of the piecewise-constant velocity,

    .. math::

        p(t) = p_0 + v \sum_i \Delta t_i(t)\,[\cos\psi_i, \sin\psi_i],

    :math:`\Delta t_i(t)` being the time spent on leg :math:`i` between ``times[0]`` and :math:`t`.

    Parameters
    ----------
    times : array_like, shape (K,)
        Epoch times [s], strictly increasing.
    start : array_like, shape (2,)
        Position at ``times[0]`` [m].
    speed : float
        Speed [m/s], >= 0.
    headings : array_like, shape (n,)
        Heading of each leg [rad].
    turn_times : array_like, shape (n - 1,)
        Absolute times of the heading changes [s], strictly increasing (on the clock of ``times``). At a turn
        time itself the reported velocity is already the new one.

    Returns
    -------
    Track

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.motion import turning_track
    >>> # east at 1 m/s, north from t = 2 s
    >>> track = turning_track(np.arange(5.0), (0.0, 0.0), 1.0, [0.0, np.pi / 2], [2.0])
    >>> track.positions.round(3)
    array([[0., 0.],
           [1., 0.],
           [2., 0.],
           [2., 1.],
           [2., 2.]])
    """
    t, p0, v = _times_start_speed(times, start, speed)
    psi = as_finite("headings", headings, ndim=1)
    turns = as_finite("turn_times", turn_times, ndim=1)
    if psi.size == 0:
        raise ValueError("headings must hold at least one heading")
    if len(turns) != len(psi) - 1:
        raise ValueError(f"turn_times must hold one time per heading change, len(headings) - 1 = {len(psi) - 1}; "
                         f"got {len(turns)}")
    if np.any(np.diff(turns) <= 0):
        raise ValueError("turn_times must be strictly increasing")
    # Leg i lasts from edges[i] to edges[i + 1]; time spent on it since times[0], for every epoch.
    edges = np.concatenate([[-np.inf], turns, [np.inf]])
    leg_start = np.maximum(edges[:-1], t[0])
    spent = np.clip(np.minimum(t[:, None], edges[1:]) - leg_start, 0.0, None)  # (K, n)
    units = _unit(psi)                                                      # (n, 2)
    leg = np.searchsorted(turns, t, side="right")
    return Track(t, p0 + v * spent @ units, v * units[leg])


def s_turn_track(times: ArrayLike, start: ArrayLike, speed: float, heading: float, turn_rate: float,
                 half_period: float) -> Track:
    r"""S-shaped (weaving) track: the heading swings at a constant rate, one way then the other.

    The vehicle starts with heading :math:`\psi_0` and turns at ``turn_rate`` :math:`\omega` for ``half_period``
    :math:`T`, then at :math:`-\omega` for :math:`T` (back to :math:`\psi_0`), and so on: the heading is a
    triangle wave between :math:`\psi_0` and :math:`\psi_0 + \omega T`. Each half period is an arc of radius
    :math:`v/|\omega|`, integrated exactly. This is the mother ship of paper E (turn right, then left; a turn
    rate of 0.3 deg/s with :math:`T` = 600 s gives two half circles of radius about 540 m at 2.83 m/s).

    Parameters
    ----------
    times : array_like, shape (K,)
        Epoch times [s], strictly increasing; the motion starts at ``times[0]``.
    start : array_like, shape (2,)
        Position at ``times[0]`` [m].
    speed : float
        Speed [m/s], >= 0.
    heading : float
        Initial heading :math:`\psi_0` [rad], 0 = east, counter-clockwise.
    turn_rate : float
        :math:`\omega` [rad/s] during the first half period: positive turns left (counter-clockwise) first,
        negative turns right first; 0 gives a straight line.
    half_period : float
        :math:`T` [s], > 0.

    Returns
    -------
    Track

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.motion import s_turn_track
    >>> track = s_turn_track(np.arange(0.0, 9.0, 2.0), (0.0, 0.0), 1.0, 0.0,
    ...                      turn_rate=0.2, half_period=4.0)
    >>> track.headings.round(2)
    array([0. , 0.4, 0.8, 0.4, 0. ])
    """
    t, p0, v = _times_start_speed(times, start, speed)
    psi0 = as_scalar("heading", heading)
    w = as_scalar("turn_rate", turn_rate)
    T = as_scalar("half_period", half_period, domain="positive")
    elapsed = t - t[0]
    n = np.floor(elapsed / T)
    into = elapsed - n * T                    # time since the current half period began
    odd = (n % 2) == 1                        # odd half periods swing back
    seg_heading = psi0 + np.where(odd, w * T, 0.0)
    seg_rate = np.where(odd, -w, w)
    # Swinging out and swinging back share the same mean heading, hence the same chord: every completed half
    # period moves the vehicle by the same vector.
    per_half = _arc(psi0, w, v, T)
    pos = p0 + n[:, None] * per_half + _arc(seg_heading, seg_rate, v, into)
    return Track(t, pos, v * _unit(seg_heading + seg_rate * into))


def lawnmower_track(times: ArrayLike, start: ArrayLike, speed: float, leg_length: float, spacing: float,
                    heading: float = 0.0) -> Track:
    r"""Survey ("lawnmower", boustrophedon) pattern at constant speed.

    From ``start`` the vehicle runs ``leg_length`` along ``heading``, moves ``spacing`` across (to its left
    for a positive spacing, to its right for a negative one), runs a leg back, moves across again, and so on.
    Corners are sharp; at a corner the reported velocity is that of the next segment.

    Parameters
    ----------
    times : array_like, shape (K,)
        Epoch times [s], strictly increasing; the motion starts at ``times[0]``.
    start : array_like, shape (2,)
        Start position [m].
    speed : float
        Speed along the pattern [m/s], >= 0.
    leg_length : float
        Length of each survey leg [m], > 0.
    spacing : float
        Distance between neighbouring legs [m]; its sign picks the side.
    heading : float, default 0
        Direction of the first leg [rad], 0 = east, counter-clockwise.

    Returns
    -------
    Track

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.motion import lawnmower_track
    >>> # 4 m legs 3 m apart at 1 m/s, sampled every 2 s
    >>> track = lawnmower_track(np.arange(0.0, 16.0, 2.0), (0.0, 0.0), 1.0,
    ...                         leg_length=4.0, spacing=3.0)
    >>> track.positions.round(2).tolist()
    [[0.0, 0.0], [2.0, 0.0], [4.0, 0.0], [4.0, 2.0], [3.0, 3.0], [1.0, 3.0], [0.0, 4.0], [0.0, 6.0]]
    """
    t, p0, v = _times_start_speed(times, start, speed)
    L = as_scalar("leg_length", leg_length, domain="positive")
    spacing = as_scalar("spacing", spacing)
    psi = as_scalar("heading", heading)
    W, side = abs(spacing), (-1.0 if spacing < 0 else 1.0)
    # One cycle = leg out, cross, leg back, cross; work in (along, across) coordinates, then rotate.
    s = v * (t - t[0])
    cycle = 2.0 * (L + W)
    n = np.floor(s / cycle)
    r = s - n * cycle
    seg = [r < L, r < L + W, r < 2 * L + W]
    along = np.select(seg, [r, L, 2 * L + W - r], 0.0)
    across = 2 * W * n + np.select(seg, [0.0, r - L, W], r - 2 * L)
    v_along = v * np.select(seg, [1.0, 0.0, -1.0], 0.0)
    v_across = v * np.select(seg, [0.0, 1.0, 0.0], 1.0)
    e_along = _unit(np.asarray(psi))
    e_across = side * np.array([-e_along[1], e_along[0]])
    pos = p0 + along[:, None] * e_along + across[:, None] * e_across
    vel = v_along[:, None] * e_along + v_across[:, None] * e_across
    return Track(t, pos, vel)


def with_current(track: Track, current: ArrayLike) -> Track:
    r"""The ground track of a vehicle that moves through the water as ``track`` while a constant current flows.

    .. math::

        p_{ground}(t) = p(t) + U\,(t - t_0), \qquad \dot p_{ground} = \dot p + U

    A DR system that measures speed through the water (log, water-track DVL) only sees ``track``: give that
    one to ``dead_reckoning`` and it drifts from the ground truth by :math:`U (t - t_0)`, the error paper B
    estimates as extra states.

    Parameters
    ----------
    track : Track
        Motion relative to the water.
    current : array_like, shape (2,)
        Current velocity :math:`U` [m/s], ``[east, north]``.

    Returns
    -------
    Track
        Motion over ground, starting at the same point.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.motion import straight_track, with_current
    >>> track = with_current(straight_track(np.arange(3.0), (0.0, 0.0), 2.0, 0.0), (0.0, 0.5))
    >>> track.positions, track.velocities[0]
    (array([[0. , 0. ],
           [2. , 0.5],
           [4. , 1. ]]), array([2. , 0.5]))
    """
    _check_track("track", track)
    U = as_point("current", current)
    elapsed = (track.times - track.times[0])[:, None]
    return Track(track.times, track.positions + elapsed * U, track.velocities + U)


def _check_track(name: str, track: Any) -> None:
    if not isinstance(track, Track):
        raise TypeError(f"{name} must be a uwtutor.motion.Track (e.g. from straight_track); got {type(track).__name__}")


# ----------------------------------------------------------------------------------------------------------------
# dead reckoning

@dataclass(frozen=True, eq=False)
class DeadReckoningResult:
    """Result of ``dead_reckoning``.

    Parameters
    ----------
    times
        Epoch times [s], shape ``(K,)``.
    displacements
        DR estimate :math:`u_k` of ``position[k] - position[k - 1]``, shape ``(K, 2)`` or ``(M, K, 2)``; row 0 is
        zeros (nothing before the first epoch).
    positions
        DR track, same shape: the true start plus the cumulative sum of the displacements.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.motion import dead_reckoning, straight_track
    >>> track = straight_track(np.arange(3.0), (0.0, 0.0), 2.0, 0.0)
    >>> dr = dead_reckoning(track, np.random.default_rng(0), speed_scale=1.1)
    >>> dr.displacements.round(3), dr.positions[-1].round(3)
    (array([[0. , 0. ],
           [2.2, 0. ],
           [2.2, 0. ]]), array([4.4, 0. ]))
    """

    times: np.ndarray
    displacements: np.ndarray
    positions: np.ndarray


def dead_reckoning(track: Track, rng: np.random.Generator, *, speed_sigma: float = 0.0, heading_sigma: float = 0.0,
                   heading_bias: float = 0.0, speed_scale: float = 1.0,
                   n_runs: int | None = None) -> DeadReckoningResult:
    r"""Dead-reckon a true track with speed-log and compass errors.

    For each step :math:`k` (from epoch :math:`k-1` to :math:`k`, duration :math:`\Delta t_k`) with true
    displacement :math:`d_k` and unit direction :math:`e_k = d_k/|d_k|`, the DR displacement is

    .. math::

        \hat u_k = R(\beta + \epsilon^\psi_k)\left(s\,d_k + \Delta t_k\,\epsilon^v_k\,e_k\right), \qquad
        \epsilon^v_k \sim N(0, \sigma_v^2),\ \epsilon^\psi_k \sim N(0, \sigma_\psi^2),

    :math:`R(\cdot)` a rotation. White speed noise :math:`\epsilon^v` (m/s, averaged over the step) and white
    heading noise :math:`\epsilon^\psi` make the DR error a random walk; a constant heading bias :math:`\beta`
    and a speed scale factor :math:`s` make it *drift*: after a straight run of length :math:`D` a heading bias
    leaves a cross-track error :math:`D \sin\beta`. With zero noise, :math:`\beta = 0` and :math:`s = 1` the
    true displacements come back exactly. (Where the vehicle did not move, :math:`e_k` is taken along its
    velocity.)

    Parameters
    ----------
    track : Track
        The motion the DR sensors see (relative to the water if there is a current, see ``with_current``).
    rng : numpy.random.Generator
        Source of randomness.
    speed_sigma : float, default 0
        :math:`\sigma_v` [m/s], >= 0.
    heading_sigma : float, default 0
        :math:`\sigma_\psi` [rad], >= 0.
    heading_bias : float, default 0
        :math:`\beta` [rad]: positive rotates the DR track counter-clockwise.
    speed_scale : float, default 1
        :math:`s`, > 0 (e.g. 1.01 for a log reading 1 % high).
    n_runs : int, optional
        Number of Monte Carlo runs ``M``; ``None`` gives a single run without the runs axis.

    Returns
    -------
    DeadReckoningResult
        ``displacements`` and ``positions`` of shape ``(K, 2)``, or ``(M, K, 2)`` with ``n_runs``.

    Notes
    -----
    Two standard normal arrays are drawn, speed noise first, whatever the sigmas: changing one sigma does not
    change the other noise sequence.

    Examples
    --------
    A log that over-reads the speed by 10 %, noise-free, then three noisy runs:

    >>> import numpy as np
    >>> from uwtutor.motion import dead_reckoning, straight_track
    >>> track = straight_track(np.arange(3.0), (0.0, 0.0), 2.0, 0.0)
    >>> dead_reckoning(track, np.random.default_rng(0), speed_scale=1.1).positions.round(3)
    array([[0. , 0. ],
           [2.2, 0. ],
           [4.4, 0. ]])
    >>> dead_reckoning(track, np.random.default_rng(0), heading_sigma=0.01,
    ...                n_runs=3).positions.shape
    (3, 3, 2)
    """
    _check_track("track", track)
    rng = as_rng(rng)
    sv = as_scalar("speed_sigma", speed_sigma, domain="nonnegative")
    spsi = as_scalar("heading_sigma", heading_sigma, domain="nonnegative")
    beta = as_scalar("heading_bias", heading_bias)
    scale = as_scalar("speed_scale", speed_scale, domain="positive")
    n = as_n_runs(n_runs)
    m = 1 if n is None else n
    check_work("n_runs", 2 * m * track.n_steps, "values (runs x epochs x 2)")

    d = np.diff(track.positions, axis=0)                     # (K-1, 2) true steps
    dt = np.diff(track.times)
    length = np.hypot(d[:, 0], d[:, 1])
    moved = length > 0
    e = np.where(moved[:, None], d / np.where(moved, length, 1.0)[:, None], _unit(track.headings[1:]))
    eps_v = rng.standard_normal((m, len(dt)))
    eps_psi = rng.standard_normal((m, len(dt)))
    step = scale * d + (sv * dt * eps_v)[..., None] * e     # (m, K-1, 2)
    angle = beta + spsi * eps_psi
    cos, sin = np.cos(angle), np.sin(angle)
    rotated = np.stack([cos * step[..., 0] - sin * step[..., 1], sin * step[..., 0] + cos * step[..., 1]], axis=-1)
    disp = np.concatenate([np.zeros((m, 1, 2)), rotated], axis=1)
    pos = track.positions[0] + np.cumsum(disp, axis=1)
    if n is None:
        disp, pos = disp[0], pos[0]
    return DeadReckoningResult(track.times, disp, pos)


def displacement_noise(displacements: ArrayLike, rng: np.random.Generator, sigma: float,
                       n_runs: int | None = None) -> np.ndarray:
    r"""Add white Gaussian noise to true displacements: :math:`\hat u_k = u_k + w_k`, :math:`w_k \sim N(0, \sigma^2 I)`.

    The simple DR error model of Zhu et al. (2019), paper D (variance :math:`\sigma^2` = 0.81 m² per axis per
    ping) and of Liu et al., paper A. Row 0 is left unchanged: by convention it is the zero displacement
    before the first epoch.

    Parameters
    ----------
    displacements : array_like, shape (K, 2) or (M, K, 2)
        True displacements, row 0 normally zeros.
    rng : numpy.random.Generator
        Source of randomness.
    sigma : float
        Standard deviation per axis per step [m], >= 0.
    n_runs : int, optional
        Number of runs ``M``. A ``(K, 2)`` input is then shared by all runs, each with its own noise; a
        ``(M, K, 2)`` input must have ``M`` runs. ``None`` keeps the input's shape.

    Returns
    -------
    ndarray, shape (K, 2) or (M, K, 2)
        Noisy displacements.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.motion import displacement_noise
    >>> u = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 0.0]])
    >>> noisy = displacement_noise(u, np.random.default_rng(0), sigma=0.1)
    >>> noisy[0], bool(np.abs(noisy[1:] - u[1:]).max() < 0.5)
    (array([0., 0.]), True)
    >>> displacement_noise(u, np.random.default_rng(0), sigma=0.1, n_runs=4).shape
    (4, 3, 2)
    """
    d = as_finite("displacements", displacements, ndim=(2, 3), nonempty=True)
    if d.shape[-1] != 2:
        raise ValueError(f"displacements must have 2 components ([dx, dy]) on its last axis; got shape {d.shape}")
    rng = as_rng(rng)
    s = as_scalar("sigma", sigma, domain="nonnegative")
    n = as_n_runs(n_runs)
    if n is not None and d.ndim == 2:
        check_work("n_runs", n * d.size, "values (runs x epochs x 2)")
    batch, single = with_runs("displacements", d, n, core_ndim=2)
    noise = s * rng.standard_normal(batch.shape)
    noise[:, 0] = 0.0
    out = batch + noise
    return out[0] if single else out


def integrate_odometry(start: ArrayLike, odometry: ArrayLike) -> np.ndarray:
    r"""Integrate body-frame odometry into poses ``[x, y, heading]``: dead reckoning from logged odometry.

    Row :math:`k` of ``odometry`` is :math:`[d_k, \delta_k]`, the distance travelled and the heading change from
    epoch :math:`k-1` to epoch :math:`k`. The heading :math:`\psi` is in the mathematical convention of this module
    (0 along +x, counter-clockwise positive: a positive :math:`\delta_k` turns left). Each step first moves
    :math:`d_k` along the heading of the previous epoch, then turns by :math:`\delta_k`:

    .. math::

        \begin{bmatrix} x_k \\ y_k \end{bmatrix} = \begin{bmatrix} x_{k-1} \\ y_{k-1} \end{bmatrix}
        + d_k \begin{bmatrix} \cos\psi_{k-1} \\ \sin\psi_{k-1} \end{bmatrix}, \qquad
        \psi_k = \psi_{k-1} + \delta_k,

    with :math:`[x_0, y_0, \psi_0]` = ``start``. This is the composition of 2-D poses with the body-frame
    increment :math:`(d_k, 0, \delta_k)` (GTSAM's ``Pose2.compose``), and it is the rule the CMU Plaza logs
    follow best (see :func:`uwtutor.datasets.plaza`). Moving along the mean heading
    :math:`\psi_{k-1} + \delta_k/2` instead (the midpoint rule) differs by a turn of :math:`\delta_k/2` per step:
    a second-order difference when the steps are short.

    Parameters
    ----------
    start : array_like, shape (3,) or (M, 3)
        Pose at the first epoch, ``[x, y, heading]`` [m, m, rad]; a batch of ``M`` starts is allowed.
    odometry : array_like, shape (K, 2) or (M, K, 2)
        ``[distance, heading change]`` [m, rad] per step. Row 0 (the motion before the first epoch) is not used.
        A distance may be negative (reversing).

    Returns
    -------
    ndarray, shape (K, 3) or (M, K, 3)
        Poses at the K epochs; row 0 is ``start``. The heading is not wrapped: it is ``start[2]`` plus the
        cumulative heading change, so that it stays continuous through full turns.

    Examples
    --------
    A 1 m step east, then a quarter turn to the left at the end of a second 1 m step, then 1 m north:

    >>> import numpy as np
    >>> from uwtutor.motion import integrate_odometry
    >>> odometry = [[0.0, 0.0], [1.0, 0.0], [1.0, np.pi / 2], [1.0, 0.0]]
    >>> integrate_odometry([0.0, 0.0, 0.0], odometry).round(3)
    array([[0.   , 0.   , 0.   ],
           [1.   , 0.   , 0.   ],
           [2.   , 0.   , 1.571],
           [2.   , 1.   , 1.571]])
    """
    x0 = as_finite("start", start, ndim=(1, 2))
    if x0.shape[-1] != 3:
        raise ValueError(f"start must be a pose [x, y, heading] (3 values on its last axis); got shape {x0.shape}")
    u = as_finite("odometry", odometry, ndim=(2, 3))
    if u.shape[-1] != 2:
        raise ValueError("odometry must hold [distance, heading change] (2 columns on its last axis); "
                         f"got shape {u.shape}")
    if u.shape[-2] == 0:
        raise ValueError("odometry must hold at least one row (the first epoch)")
    if x0.ndim == 2 and u.ndim == 3 and x0.shape[0] != u.shape[0]:
        raise ValueError(f"start holds {x0.shape[0]} runs but odometry holds {u.shape[0]}; give as many of each "
                         "(or a single start or a single odometry log, shared by every run)")
    turn = u[..., 1:, 1]
    # heading at every epoch: the start plus the heading changes so far (row 0's change is not used)
    headings = x0[..., 2:3] + np.concatenate([np.zeros_like(u[..., :1, 1]), np.cumsum(turn, axis=-1)], axis=-1)
    steps = u[..., 1:, 0, None] * _unit(headings[..., :-1])                  # (..., K-1, 2): along psi_{k-1}
    positions = x0[..., None, :2] + np.concatenate([np.zeros_like(steps[..., :1, :]), np.cumsum(steps, axis=-2)],
                                                    axis=-2)
    return np.concatenate([positions, headings[..., None]], axis=-1)
