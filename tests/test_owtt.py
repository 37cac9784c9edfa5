"""OWTT timing models: clock errors as range errors, the whole-second ambiguity, send- vs reception-time geometry."""

from __future__ import annotations

import numpy as np
import pytest

from uwtutor import owtt
from uwtutor.acoustics import range_from_travel_time


def test_clock_error_is_offset_plus_drift_times_time():
    t = np.array([0.0, 100.0, 2500.0])
    np.testing.assert_allclose(owtt.clock_error(t, offset=2e-3, drift=1e-6), 2e-3 + 1e-6 * t)
    assert owtt.clock_error(7.0) == 0.0


def test_one_millisecond_is_one_and_a_half_metres():
    assert owtt.clock_range_error(0.0, offset=1e-3) == pytest.approx(1.5)
    # a 1 ppm oscillator adds 1.5 m per 1000 s; with another sound speed the same time error scales
    assert owtt.clock_range_error(1000.0, drift=1e-6) == pytest.approx(1.5)
    assert owtt.clock_range_error(0.0, offset=1e-3, sound_speed=1480.0) == pytest.approx(1.48)
    # and it is the range of that travel time (the conversion of uwtutor.acoustics)
    assert owtt.clock_range_error(0.0, offset=0.01) == pytest.approx(range_from_travel_time(0.01, 1500.0))


def test_wrapping_keeps_the_fraction_of_the_period():
    tau = np.array([0.2, 1.0, 1.75, 3.01])
    np.testing.assert_allclose(owtt.wrap_travel_time(tau), [0.2, 0.0, 0.75, 0.01], atol=1e-12)
    np.testing.assert_allclose(owtt.wrap_travel_time(tau, period=2.0), [0.2, 1.0, 1.75, 1.01], atol=1e-12)
    assert owtt.ambiguity_range() == 1500.0


def test_resolution_is_right_within_half_a_period_and_off_by_one_beyond():
    c = 1500.0
    true_tau = np.linspace(0.05, 4.9, 200)
    wrapped = owtt.wrap_travel_time(true_tau)
    true_range = c * true_tau
    for error in (-740.0, -300.0, 0.0, 300.0, 740.0):
        got = owtt.resolve_travel_time(wrapped, np.maximum(true_range + error, 0.0), c)
        np.testing.assert_allclose(got, true_tau, atol=1e-9)
    too_far = owtt.resolve_travel_time(wrapped, true_range + 760.0, c)
    np.testing.assert_allclose(too_far - true_tau, 1.0, atol=1e-9)      # one whole second: 1500 m
    assert np.isnan(owtt.resolve_travel_time(np.nan, 1000.0))
    assert np.isnan(owtt.resolve_travel_time(0.3, np.nan))


@pytest.mark.parametrize("kw, match", [
    (dict(wrapped=1.2, predicted_range=100.0), "wrapped"),
    (dict(wrapped=0.2, predicted_range=-5.0), "predicted_range"),
    (dict(wrapped=0.2, predicted_range=np.inf), "infinite"),
    (dict(wrapped=0.2, predicted_range=10.0, period=0.0), "period"),
])
def test_resolve_rejects_bad_input(kw, match):
    with pytest.raises(ValueError, match=match):
        owtt.resolve_travel_time(**kw)


def test_wrap_rejects_negative_travel_times():
    with pytest.raises(ValueError, match="travel_times"):
        owtt.wrap_travel_time(-0.1)


def follower_moving_away(t):
    t = np.asarray(t, dtype=float)
    return np.stack([1500.0 + 2.0 * t, 0.0 * t], axis=-1)


def test_simulation_geometry_send_versus_reception():
    def leader(t):                                     # the leader moves west
        return np.stack([-1.0 * np.asarray(t), 0.0 * np.asarray(t)], axis=-1)

    m = owtt.simulate_owtt([0.0, 10.0], leader, follower_moving_away)
    # the sound covers the distance between the leader at send time and the follower at reception
    d = np.linalg.norm(m.follower_positions - m.leader_positions, axis=-1)
    np.testing.assert_allclose(m.true_ranges, d, rtol=1e-12)
    np.testing.assert_allclose(m.true_ranges, 1500.0 * m.travel_times, rtol=1e-12)
    # chasing sound: 1500 + 2 * (t_s + tau) + t_s = 1500 tau  ->  tau = (1500 + 3 t_s) / 1498
    np.testing.assert_allclose(m.travel_times, (1500.0 + 3.0 * np.array([0.0, 10.0])) / 1498.0, rtol=1e-9)
    np.testing.assert_allclose(m.follower_positions[:, 0] - m.follower_positions_at_send[:, 0], 2.0 * m.travel_times)
    np.testing.assert_allclose(m.leader_positions_at_reception[:, 0] - m.leader_positions[:, 0], -m.travel_times)
    np.testing.assert_allclose(m.ranges, m.true_ranges)                     # perfect clocks, right sound speed


def test_simulation_clock_error_sound_speed_and_ambiguity():
    m = owtt.simulate_owtt([0.0, 100.0], (0.0, 0.0), follower_moving_away, clock_offset=1e-3, clock_drift=1e-5)
    np.testing.assert_allclose(m.ranges - m.true_ranges, 1500.0 * (1e-3 + 1e-5 * m.reception_times), rtol=1e-9)
    slow = owtt.simulate_owtt([0.0], (0.0, 0.0), follower_moving_away, assumed_sound_speed=1470.0)
    assert slow.ranges[0] == pytest.approx(slow.true_ranges[0] * 1470.0 / 1500.0)
    wrapped = owtt.simulate_owtt([0.0, 100.0], (0.0, 0.0), follower_moving_away, period=1.0)
    assert np.all((wrapped.measured_travel_times >= 0) & (wrapped.measured_travel_times < 1.0))
    np.testing.assert_allclose(wrapped.measured_travel_times, np.mod(wrapped.travel_times, 1.0))
    back = owtt.resolve_travel_time(wrapped.measured_travel_times, wrapped.true_ranges + 100.0)
    np.testing.assert_allclose(back, wrapped.travel_times, rtol=1e-12)


def test_simulation_rejects_bad_input_and_arrays_are_read_only():
    with pytest.raises(ValueError, match="send_times"):
        owtt.simulate_owtt([1.0, 0.0], (0.0, 0.0), follower_moving_away)
    with pytest.raises(ValueError, match="sound_speed"):
        owtt.simulate_owtt([0.0], (0.0, 0.0), follower_moving_away, sound_speed=-1.0)
    with pytest.raises(ValueError, match="clock offset"):
        owtt.simulate_owtt([0.0], (0.0, 0.0), (10.0, 0.0), clock_offset=-1.0)
    m = owtt.simulate_owtt([0.0], (0.0, 0.0), follower_moving_away)
    with pytest.raises(ValueError):
        m.ranges[0] = 1.0
