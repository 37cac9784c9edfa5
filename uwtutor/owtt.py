r"""One-way travel-time (OWTT) ranging: what synchronized clocks, whole-second schedules and moving vehicles do to a
range.

In OWTT ranging a leader (a vehicle, a ship, a buoy) transmits at a scheduled time :math:`t^\mathrm{s}_k` read on its
clock; the message carries its position at that time. A receiver with a synchronized clock notes the arrival time
:math:`t^\mathrm{r}_k` on its own clock and converts the difference into a range, :math:`r_k = c\,(t^\mathrm{r}_k -
t^\mathrm{s}_k)`. Every receiver within earshot gets a range from the same message, so the update rate does not
fall as followers are added (the reason OWTT replaced round-trip ranging in cooperative navigation; Webster et al.
2012). It costs three things that two-way ranging does not have:

==============================  ==================================================================================
``clock_error``                 the receiver's clock error :math:`\kappa(t) = \kappa_0 + \dot\kappa\,t`
``clock_range_error``           its range error :math:`c\,\kappa(t)`: 1 ms is 1.5 m, a 1 ppm drift 1.5 m per
                                thousand seconds
``wrap_travel_time``            the travel time a receiver reports when it knows the send time only to within a
                                whole period (the transmission scheduled "at the top of a second")
``resolve_travel_time``         the whole periods put back from a predicted range; right only while the
                                prediction is within :math:`c\,T_\mathrm{s}/2` (750 m for 1 s) of the truth
``ambiguity_range``             the range one period spans, :math:`c\,T_\mathrm{s}` (1500 m for 1 s)
``simulate_owtt``               the whole chain for a leader and a follower on given tracks: send and reception
                                times, the leader's position at send time, the follower's at reception (an
                                ``OWTTMeasurements``)
==============================  ==================================================================================

The third cost is geometric: the range joins the leader *at send time* to the follower *at reception time*, a
travel time later (about 0.7 ms per metre of range). A filter that attaches the range to the follower's position
at the send time, or takes the leader's position at the reception time, makes an error up to the vehicle's speed
times the travel time. ``simulate_owtt`` uses :func:`uwtutor.ranging.reception_times` for the exact geometry.

References
----------
S. E. Webster, R. M. Eustice, H. Singh and L. L. Whitcomb, "Advances in single-beacon one-way-travel-time acoustic
navigation for underwater vehicles", Int. J. Robotics Research 31(8), 935-950, 2012.
"AUV cooperative localization method based on motion radius vector in the presence of unknown currents" (paper B),
which assumes all three costs away.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ._validate import (as_finite, as_float_array, as_nonnegative, as_position_function, as_scalar,
                        as_times, check_finite_result, readonly)
from .acoustics import range_from_travel_time
from .ranging import reception_times

__all__ = [
    "clock_error",
    "clock_range_error",
    "wrap_travel_time",
    "resolve_travel_time",
    "ambiguity_range",
    "OWTTMeasurements",
    "simulate_owtt",
]


def _scalar_or_array(arr: np.ndarray) -> float | np.ndarray:
    return float(arr) if arr.ndim == 0 else arr


def clock_error(times: ArrayLike, offset: float = 0.0, drift: float = 0.0) -> float | np.ndarray:
    r"""Error of a receiver's clock against the leader's: :math:`\kappa(t) = \kappa_0 + \dot\kappa\,t`.

    Both clocks were synchronized (for example to GPS at the surface) at :math:`t = 0` with a residual offset
    :math:`\kappa_0`; after that the receiver's oscillator runs fast by :math:`\dot\kappa` seconds per second.

    Parameters
    ----------
    times : float or array_like
        Times since the synchronization [s], finite.
    offset : float, default 0
        :math:`\kappa_0` [s]; positive means the receiver's clock is ahead.
    drift : float, default 0
        :math:`\dot\kappa` [s/s], e.g. ``1e-6`` for a 1 ppm oscillator.

    Returns
    -------
    float or ndarray
        :math:`\kappa(t)` [s], the shape of ``times``.

    Examples
    --------
    >>> from uwtutor.owtt import clock_error
    >>> round(clock_error(2500.0, offset=1e-3, drift=1e-6), 6)
    0.0035
    """
    t = as_finite("times", times)
    e0 = as_scalar("offset", offset)
    rate = as_scalar("drift", drift)
    with np.errstate(over="ignore", invalid="ignore"):
        error = np.asarray(e0 + rate * t, dtype=float)
    return _scalar_or_array(check_finite_result(error, "times", "offset", "drift", what="the clock error"))


def clock_range_error(times: ArrayLike, offset: float = 0.0, drift: float = 0.0,
                      sound_speed: float = 1500.0) -> float | np.ndarray:
    r"""The range error a clock error makes: :math:`e_k = c\,\kappa(t^\mathrm{r}_k)`.

    A receiver whose clock is ahead by :math:`\kappa` notes every arrival :math:`\kappa` late, so every travel
    time is :math:`\kappa` too long and every range :math:`c\,\kappa` too long: a bias common to all ranges of
    one epoch, growing with time when the clock drifts. 1 ms at 1500 m/s is 1.5 m.

    Parameters
    ----------
    times : float or array_like
        Reception times since the synchronization [s].
    offset, drift : float
        The clock's :math:`\kappa_0` [s] and :math:`\dot\kappa` [s/s] (see ``clock_error``).
    sound_speed : float, default 1500
        Sound speed :math:`c` the receiver converts with [m/s], > 0.

    Returns
    -------
    float or ndarray
        Range error [m], the shape of ``times``.

    Examples
    --------
    >>> from uwtutor.owtt import clock_range_error
    >>> clock_range_error(0.0, offset=1e-3)
    1.5
    """
    c = as_scalar("sound_speed", sound_speed, domain="positive")
    return _scalar_or_array(c * np.asarray(clock_error(times, offset, drift), dtype=float))


def ambiguity_range(sound_speed: float = 1500.0, period: float = 1.0) -> float:
    r"""The range that one whole period of travel time spans, :math:`c\,T_\mathrm{s}` (1500 m for 1 s).

    A travel time known only modulo :math:`T_\mathrm{s}` gives a range modulo this value; a predicted range resolves
    it correctly while its error stays below half of it.

    Parameters
    ----------
    sound_speed : float, default 1500
        :math:`c` [m/s], > 0.
    period : float, default 1
        :math:`T_\mathrm{s}` [s], > 0.

    Returns
    -------
    float
        :math:`c\,T_\mathrm{s}` [m].

    Examples
    --------
    >>> from uwtutor.owtt import ambiguity_range
    >>> ambiguity_range(1500.0, 1.0)
    1500.0
    """
    return as_scalar("sound_speed", sound_speed, domain="positive") * as_scalar("period", period, domain="positive")


def wrap_travel_time(travel_times: ArrayLike, period: float = 1.0) -> float | np.ndarray:
    r"""The travel time modulo the transmission period: what a receiver measures when it knows only that the message
    left "at the top of some second".

    .. math::

        \tau^\mathrm{w}_k = \tau_k - T_\mathrm{s} \left\lfloor \tau_k / T_\mathrm{s} \right\rfloor
        \in [0, T_\mathrm{s}).

    Parameters
    ----------
    travel_times : float or array_like
        Travel times [s], finite and >= 0.
    period : float, default 1
        :math:`T_\mathrm{s}` [s], > 0.

    Returns
    -------
    float or ndarray
        :math:`\tau^\mathrm{w}_k` [s].

    Examples
    --------
    >>> from uwtutor.owtt import wrap_travel_time
    >>> round(wrap_travel_time(1.25), 12)
    0.25
    """
    tau = as_nonnegative("travel_times", travel_times)
    T = as_scalar("period", period, domain="positive")
    return _scalar_or_array(np.asarray(np.mod(tau, T), dtype=float))


def resolve_travel_time(wrapped: ArrayLike, predicted_range: ArrayLike, sound_speed: float = 1500.0,
                        period: float = 1.0) -> float | np.ndarray:
    r"""Put the whole periods back into a wrapped travel time, using a predicted range.

    .. math::

        \hat\tau_k = \tau^\mathrm{w}_k + n_k T_\mathrm{s}, \qquad
        n_k = \max\left(0, \operatorname{round}\frac{\hat r_k / c - \tau^\mathrm{w}_k}{T_\mathrm{s}}\right).

    The result is the true travel time whenever :math:`|\hat r_k - r_k| < c\,T_\mathrm{s}/2`; beyond that it is off
    by a whole period, a range error of :math:`\pm c\,T_\mathrm{s}` (1500 m). A NaN prediction or wrapped time (a
    lost message) gives NaN.

    Parameters
    ----------
    wrapped : float or array_like
        :math:`\tau^\mathrm{w}_k` [s], in ``[0, period)``; NaN allowed.
    predicted_range : float or array_like
        :math:`\hat r_k` [m], e.g. from the filter's prediction; NaN allowed; broadcasts against ``wrapped``.
    sound_speed : float, default 1500
        :math:`c` [m/s], > 0.
    period : float, default 1
        :math:`T_\mathrm{s}` [s], > 0.

    Returns
    -------
    float or ndarray
        :math:`\hat\tau_k` [s].

    Examples
    --------
    >>> from uwtutor.owtt import resolve_travel_time
    >>> # true travel time 1.25 s (1875 m)
    >>> round(resolve_travel_time(0.25, 1900.0), 12)
    1.25
    >>> # a prediction 825 m off: one second too many
    >>> round(resolve_travel_time(0.25, 2700.0), 12)
    2.25
    """
    w = as_float_array("wrapped", wrapped)
    r = as_float_array("predicted_range", predicted_range)
    T = as_scalar("period", period, domain="positive")
    c = as_scalar("sound_speed", sound_speed, domain="positive")
    if np.isinf(w).any() or np.isinf(r).any():
        raise ValueError("wrapped and predicted_range must not be infinite; use NaN for a lost message")
    if w.ndim and r.ndim and w.shape != r.shape:      # a scalar broadcasts; two arrays must match (no (K, 1) x (K,))
        raise ValueError(f"wrapped and predicted_range must have the same shape (or one of them be a single number); "
                         f"got shapes {w.shape} and {r.shape}")
    bad = np.isfinite(w) & ((w < 0) | (w >= T))
    if bad.any():
        raise ValueError(f"wrapped must lie in [0, period) = [0, {T:g}); got {w[bad].flat[0]:g}")
    if (np.isfinite(r) & (r < 0)).any():
        raise ValueError("predicted_range must be >= 0")
    with np.errstate(invalid="ignore"):
        n = np.maximum(0.0, np.round((r / c - w) / T))
    return _scalar_or_array(np.asarray(w + n * T, dtype=float))


@dataclass(frozen=True, eq=False)
class OWTTMeasurements:
    r"""One leader's broadcasts heard by one follower (returned by ``simulate_owtt``); arrays of shape ``(K,)`` or
    ``(K, 2)``, one entry per message.

    Attributes
    ----------
    send_times : ndarray
        :math:`t^\mathrm{s}_k`, on the leader's (true) clock [s].
    reception_times : ndarray
        True arrival times :math:`t^\mathrm{r}_k` [s].
    travel_times : ndarray
        True travel times :math:`\tau_k = t^\mathrm{r}_k - t^\mathrm{s}_k` [s].
    measured_travel_times : ndarray
        What the follower measures: :math:`\tau_k + \kappa(t^\mathrm{r}_k)`, wrapped modulo the period when one
        was given [s].
    ranges : ndarray
        :math:`c_\mathrm{a}\,\tau^\mathrm{meas}_k` with the assumed sound speed [m] (wrapped travel times give
        ranges modulo :math:`c_\mathrm{a} T_\mathrm{s}`).
    true_ranges : ndarray
        :math:`\lVert \mathbf{p}^\mathrm{S}(t^\mathrm{r}_k) - \mathbf{p}^\mathrm{M}(t^\mathrm{s}_k) \rVert`, the
        path the sound travelled [m].
    leader_positions : ndarray, shape (K, 2)
        :math:`\mathbf{p}^\mathrm{M}(t^\mathrm{s}_k)`, what the message carries [m].
    leader_positions_at_reception : ndarray, shape (K, 2)
        :math:`\mathbf{p}^\mathrm{M}(t^\mathrm{r}_k)` (the wrong one to pair with the range) [m].
    follower_positions : ndarray, shape (K, 2)
        :math:`\mathbf{p}^\mathrm{S}(t^\mathrm{r}_k)`, where the range really ends [m].
    follower_positions_at_send : ndarray, shape (K, 2)
        :math:`\mathbf{p}^\mathrm{S}(t^\mathrm{s}_k)` (where a filter that ignores the travel time puts it) [m].
    sound_speed : float
        True :math:`c` [m/s].
    assumed_sound_speed : float
        The :math:`c` the follower converts with [m/s].
    period : float or None
        :math:`T_\mathrm{s}` [s] when the travel times are wrapped.

    Examples
    --------
    A follower 3100 m from a fixed leader, travel times reported modulo one second:

    >>> from uwtutor.owtt import simulate_owtt
    >>> m = simulate_owtt([0.0, 10.0], (0.0, 0.0), (3100.0, 0.0), period=1.0)
    >>> m.travel_times.round(4), m.measured_travel_times.round(4)
    (array([2.0667, 2.0667]), array([0.0667, 0.0667]))
    >>> m.ranges.round(1), m.period
    (array([100., 100.]), 1.0)
    """

    send_times: np.ndarray
    reception_times: np.ndarray
    travel_times: np.ndarray
    measured_travel_times: np.ndarray
    ranges: np.ndarray
    true_ranges: np.ndarray
    leader_positions: np.ndarray
    leader_positions_at_reception: np.ndarray
    follower_positions: np.ndarray
    follower_positions_at_send: np.ndarray
    sound_speed: float
    assumed_sound_speed: float
    period: float | None

    def __post_init__(self) -> None:
        for name in ("send_times", "reception_times", "travel_times", "measured_travel_times", "ranges",
                     "true_ranges", "leader_positions", "leader_positions_at_reception", "follower_positions",
                     "follower_positions_at_send"):
            object.__setattr__(self, name, readonly(np.asarray(getattr(self, name), dtype=float)))


def simulate_owtt(send_times: ArrayLike, leader_position_at: Any, follower_position_at: Any, *,
                  sound_speed: float = 1500.0,
                  assumed_sound_speed: float | None = None, clock_offset: float = 0.0, clock_drift: float = 0.0,
                  period: float | None = None) -> OWTTMeasurements:
    r"""Simulate OWTT ranging from a leader to a follower, with the follower's clock error and, optionally, travel
    times known only modulo a period.

    For each message sent at :math:`t^\mathrm{s}_k`: the arrival :math:`t^\mathrm{r}_k` solves
    :math:`\lVert \mathbf{p}^\mathrm{S}(t^\mathrm{r}_k) - \mathbf{p}^\mathrm{M}(t^\mathrm{s}_k)\rVert =
    c\,(t^\mathrm{r}_k - t^\mathrm{s}_k)` (``uwtutor.ranging.reception_times``); the follower measures
    :math:`\tau^\mathrm{meas}_k = \tau_k + \kappa(t^\mathrm{r}_k)` (``clock_error``), wrapped modulo ``period``
    when one is given (``wrap_travel_time``), and converts it with its assumed sound speed. Horizontal geometry: for
    vehicles at the same depth the horizontal and the slant range agree.

    Parameters
    ----------
    send_times : array_like, shape (K,)
        :math:`t^\mathrm{s}_k` [s], strictly increasing.
    leader_position_at, follower_position_at : callable or array_like, shape (2,)
        Positions over ground: a fixed point or a function of an array of times (e.g. ``Track.position_at``).
    sound_speed : float, default 1500
        True sound speed :math:`c` [m/s].
    assumed_sound_speed : float, optional
        The speed the follower converts with (default: the true one).
    clock_offset, clock_drift : float, default 0
        The follower's clock error against the leader's, :math:`\kappa_0` [s] and :math:`\dot\kappa` [s/s].
    period : float, optional
        :math:`T_\mathrm{s}` [s]: report travel times modulo it (the whole-second ambiguity).

    Returns
    -------
    OWTTMeasurements

    Examples
    --------
    A leader fixed at the origin, a follower 1500 m east moving east at 2 m/s; a clock 1 ms ahead:

    >>> import numpy as np
    >>> from uwtutor.owtt import simulate_owtt
    >>> follower = lambda t: np.stack([1500.0 + 2.0 * t, 0.0 * t], axis=-1)
    >>> m = simulate_owtt([0.0], (0.0, 0.0), follower, clock_offset=1e-3)
    >>> round(float(m.ranges[0] - m.true_ranges[0]), 6)
    1.5
    >>> # moved 2 m/s x 1.0013 s
    >>> round(
    ...     float(m.follower_positions[0, 0] - m.follower_positions_at_send[0, 0]),
    ...     3,
    ... )
    2.003
    """
    ts = as_times("send_times", send_times)
    leader_at = as_position_function("leader_position_at", leader_position_at)
    follower_at = as_position_function("follower_position_at", follower_position_at)
    c = as_scalar("sound_speed", sound_speed, domain="positive")
    c_a = c if assumed_sound_speed is None else as_scalar("assumed_sound_speed", assumed_sound_speed, domain="positive")
    T = None if period is None else as_scalar("period", period, domain="positive")
    clock_offset = as_scalar("clock_offset", clock_offset)
    clock_drift = as_scalar("clock_drift", clock_drift)
    t_r, true_ranges = reception_times(ts, leader_at, follower_at, c)
    tau = t_r - ts
    measured = tau + np.asarray(clock_error(t_r, clock_offset, clock_drift), dtype=float)
    if (measured < 0).any():
        raise ValueError("the clock offset is so negative that a travel time comes out negative; check its sign "
                         "and units (seconds)")
    if T is not None:
        measured = np.asarray(wrap_travel_time(measured, T), dtype=float)
    return OWTTMeasurements(send_times=ts, reception_times=t_r, travel_times=tau, measured_travel_times=measured,
                            ranges=np.asarray(range_from_travel_time(measured, c_a), dtype=float),
                            true_ranges=true_ranges, leader_positions=leader_at(ts),
                            leader_positions_at_reception=leader_at(t_r), follower_positions=follower_at(t_r),
                            follower_positions_at_send=follower_at(ts), sound_speed=c, assumed_sound_speed=c_a,
                            period=T)
