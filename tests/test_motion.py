"""Tests of uwtutor.motion: tracks, their generators, currents and dead reckoning."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from uwtutor.motion import (DeadReckoningResult, Track, circle_track, dead_reckoning, displacement_noise,
                            lawnmower_track, s_turn_track, straight_track, turning_track, with_current)

T = np.arange(0.0, 101.0)


def numerical_positions(track: Track) -> np.ndarray:
    """Integrate a finely sampled track's velocities (trapezoid rule): an independent check of its positions."""
    return track.positions[0] + np.concatenate([[[0.0, 0.0]], np.cumsum(
        (track.velocities[1:] + track.velocities[:-1]) / 2 * np.diff(track.times)[:, None], axis=0)])


def assert_consistent(track: Track, atol: float) -> None:
    """Positions are the integral of the velocities (``atol`` allows for the trapezoid rule's error at corners)."""
    np.testing.assert_allclose(numerical_positions(track), track.positions, atol=atol)


# --- Track -----------------------------------------------------------------------------------------------------

def test_track_headings_follow_math_convention():
    v = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -2.0]])
    tr = Track(np.arange(4.0), np.zeros((4, 2)), v)
    np.testing.assert_allclose(tr.headings, [0.0, np.pi / 2, np.pi, -np.pi / 2])
    np.testing.assert_allclose(tr.speeds, [1.0, 1.0, 1.0, 2.0])
    assert tr.n_steps == 4


def test_track_position_at_interpolates_and_extrapolates():
    tr = straight_track([0.0, 10.0, 30.0], (1.0, 2.0), 2.0, 0.0)
    np.testing.assert_allclose(tr.position_at(5.0), [11.0, 2.0])
    np.testing.assert_allclose(tr.position_at(tr.times), tr.positions)
    got = tr.position_at(np.array([[-5.0, 20.0], [30.0, 40.0]]))
    assert got.shape == (2, 2, 2)
    np.testing.assert_allclose(got[..., 0], [[-9.0, 41.0], [61.0, 81.0]])


def test_track_position_at_single_epoch():
    tr = Track([5.0], [[1.0, 1.0]], [[1.0, 0.0]])
    np.testing.assert_allclose(tr.position_at([4.0, 5.0, 7.0]), [[0.0, 1.0], [1.0, 1.0], [3.0, 1.0]])


def test_track_is_read_only():
    tr = straight_track(T, (0.0, 0.0), 1.0, 0.0)
    with pytest.raises(ValueError):
        tr.positions[0, 0] = 5.0
    with pytest.raises(AttributeError):
        tr.times = T  # frozen dataclass


@pytest.mark.parametrize("times, pos, vel, name", [
    ([0.0, 1.0], np.zeros((2, 2)), np.zeros((3, 2)), "same length"),
    ([0.0, 1.0], np.zeros((2, 3)), np.zeros((2, 2)), "positions"),
    ([0.0, 0.0], np.zeros((2, 2)), np.zeros((2, 2)), "strictly increasing"),
    ([0.0, np.nan], np.zeros((2, 2)), np.zeros((2, 2)), "times"),
    ([0.0, 1.0], [[0.0, 0.0], [np.inf, 0.0]], np.zeros((2, 2)), "positions"),
    ([0.0, 1.0], np.zeros((2, 2)), np.full((2, 2), np.nan), "velocities"),
    ([], np.zeros((0, 2)), np.zeros((0, 2)), "times"),
])
def test_track_rejects_bad_input(times, pos, vel, name):
    with pytest.raises(ValueError, match=name):
        Track(times, pos, vel)


def test_position_at_rejects_nan():
    with pytest.raises(ValueError, match="t must be finite"):
        straight_track(T, (0, 0), 1.0, 0.0).position_at([1.0, np.nan])


# --- generators ------------------------------------------------------------------------------------------------

def test_straight_track():
    tr = straight_track(T + 50.0, (10.0, -5.0), 2.0, np.pi / 2)
    np.testing.assert_allclose(tr.positions[-1], [10.0, 195.0], atol=1e-9)
    np.testing.assert_allclose(tr.headings, np.pi / 2)
    assert_consistent(tr, 1e-9)


@pytest.mark.parametrize("clockwise", [False, True])
def test_circle_track(clockwise):
    tr = circle_track(np.linspace(0.0, 600.0, 6001), 1500.0, 2.0, center=(100.0, -50.0), start_angle=-np.pi / 2,
                      clockwise=clockwise)
    r = np.hypot(*(tr.positions - [100.0, -50.0]).T)
    np.testing.assert_allclose(r, 1500.0)
    np.testing.assert_allclose(tr.speeds, 2.0)
    np.testing.assert_allclose(tr.positions[0], [100.0, -1550.0], atol=1e-9)
    # starting due south of the centre, counter-clockwise means heading east
    np.testing.assert_allclose(tr.velocities[0], [-2.0, 0.0] if clockwise else [2.0, 0.0], atol=1e-12)
    # the velocity is tangent: perpendicular to the radius
    np.testing.assert_allclose(np.sum((tr.positions - [100.0, -50.0]) * tr.velocities, axis=1), 0.0, atol=1e-9)
    assert_consistent(tr, 1e-4)


def test_turning_track_legs_and_turn_velocity():
    tr = turning_track([0.0, 5.0, 10.0, 15.0, 20.0], (0.0, 0.0), 1.0, [0.0, np.pi / 2, np.pi], [10.0, 12.0])
    np.testing.assert_allclose(tr.positions, [[0, 0], [5, 0], [10, 0], [7, 2], [2, 2]], atol=1e-12)
    np.testing.assert_allclose(tr.velocities[2], [0.0, 1.0], atol=1e-12)  # at the turn: the new heading
    assert_consistent(turning_track(np.linspace(0, 20, 20001), (0, 0), 1.0, [0.0, 1.0], [7.0]), 1e-3)
    assert_consistent(turning_track(np.linspace(0, 20, 20001), (0, 0), 1.0, [0.0, 1.0], [7.0005]), 1e-3)


def test_turning_track_with_no_turn_is_straight():
    a = turning_track(T, (1.0, 2.0), 1.5, [0.3], [])
    b = straight_track(T, (1.0, 2.0), 1.5, 0.3)
    np.testing.assert_allclose(a.positions, b.positions)


def test_turning_track_turn_before_start():
    tr = turning_track([10.0, 11.0], (0.0, 0.0), 1.0, [0.0, np.pi / 2], [5.0])
    np.testing.assert_allclose(tr.positions[1], [0.0, 1.0], atol=1e-12)


@pytest.mark.parametrize("headings, turns, name", [([0.0, 1.0], [], "turn_times"), ([], [], "headings"),
                                                   ([0.0, 1.0, 2.0], [5.0, 4.0], "turn_times"),
                                                   ([0.0, np.nan], [5.0], "headings")])
def test_turning_track_rejects_bad_input(headings, turns, name):
    with pytest.raises(ValueError, match=name):
        turning_track(T, (0, 0), 1.0, headings, turns)


def test_s_turn_track_paper_e_ship():
    t = np.arange(0.0, 1201.0)
    tr = s_turn_track(t, (0.0, 0.0), 2 * np.sqrt(2), np.pi / 4, -np.deg2rad(0.3), 600.0)
    np.testing.assert_allclose(tr.speeds, 2 * np.sqrt(2))
    np.testing.assert_allclose(tr.velocities[0], [2.0, 2.0])
    # half circles of radius v/w: after 600 s the ship has turned 180 degrees, 2R further south-east
    radius = 2 * np.sqrt(2) / np.deg2rad(0.3)
    np.testing.assert_allclose(tr.positions[600], 2 * radius * np.array([1, -1]) / np.sqrt(2), atol=1e-9)
    np.testing.assert_allclose(tr.velocities[600], [-2.0, -2.0], atol=1e-9)
    np.testing.assert_allclose(tr.velocities[1200], [2.0, 2.0], atol=1e-9)
    # heading: a triangle wave, down at 0.3 deg/s for 600 s, then back up (compare as unit vectors)
    expected = np.pi / 4 - np.deg2rad(0.3) * np.minimum(t, 1200.0 - t)
    np.testing.assert_allclose(np.exp(1j * tr.headings), np.exp(1j * expected), atol=1e-9)


@given(st.floats(-0.05, 0.05), st.floats(10.0, 300.0), st.floats(-np.pi, np.pi))
@settings(max_examples=30, deadline=None)
def test_s_turn_track_positions_integrate_velocities(rate, half_period, heading):
    tr = s_turn_track(np.linspace(0.0, 3 * half_period, 30001), (3.0, 4.0), 2.0, heading, rate, half_period)
    assert_consistent(tr, 1e-3)


def test_s_turn_track_zero_rate_is_straight():
    np.testing.assert_allclose(s_turn_track(T, (0, 0), 1.0, 0.5, 0.0, 10.0).positions,
                               straight_track(T, (0, 0), 1.0, 0.5).positions, atol=1e-12)


def test_lawnmower_track_corners():
    tr = lawnmower_track(np.arange(0.0, 81.0, 10.0), (0.0, 0.0), 1.0, 30.0, 10.0, heading=0.0)
    np.testing.assert_allclose(tr.positions, [[0, 0], [10, 0], [20, 0], [30, 0], [30, 10], [20, 10], [10, 10],
                                              [0, 10], [0, 20]], atol=1e-12)
    right = lawnmower_track([0.0, 40.0], (0.0, 0.0), 1.0, 30.0, -10.0, heading=np.pi / 2)
    np.testing.assert_allclose(right.positions[1], [10.0, 30.0], atol=1e-12)   # heading north, stepping right (east)
    # sharp corners: the trapezoid rule errs by up to speed * step / 2 at each of the 5 corners
    assert_consistent(lawnmower_track(np.linspace(0, 200, 20001), (5, 5), 1.5, 40.0, 15.0, 0.7), 5 * 1.5 * 0.01)


def test_with_current():
    tr = straight_track(T, (0.0, 0.0), 1.0, 0.0)
    g = with_current(tr, (0.5, -0.25))
    np.testing.assert_allclose(g.positions[-1], [150.0, -25.0])
    np.testing.assert_allclose(g.velocities, np.broadcast_to([1.5, -0.25], (len(T), 2)))
    with pytest.raises(ValueError, match="current"):
        with_current(tr, (0.5, np.nan))
    with pytest.raises(ValueError, match="current"):
        with_current(tr, (0.5, 1.0, 2.0))
    with pytest.raises(TypeError, match="track"):
        with_current(tr.positions, (0.5, 0.5))


@pytest.mark.parametrize("call, name", [
    (lambda: circle_track(T, -1.0, 1.0), "radius"),
    (lambda: circle_track(T, 100.0, np.nan), "speed"),
    (lambda: circle_track(T, 100.0, 1.0, center=(0.0,)), "center"),
    (lambda: straight_track(T, (0.0, 0.0), -1.0, 0.0), "speed"),
    (lambda: straight_track(T[::-1], (0.0, 0.0), 1.0, 0.0), "times"),
    (lambda: straight_track(T, (0.0, np.inf), 1.0, 0.0), "start"),
    (lambda: straight_track(T, (0.0, 0.0), 1.0, [0.0, 1.0]), "heading"),
    (lambda: s_turn_track(T, (0, 0), 1.0, 0.0, 0.1, 0.0), "half_period"),
    (lambda: s_turn_track(T, (0, 0), 1.0, 0.0, np.nan, 10.0), "turn_rate"),
    (lambda: lawnmower_track(T, (0, 0), 1.0, 0.0, 10.0), "leg_length"),
    (lambda: lawnmower_track(T, (0, 0), 1.0, 10.0, np.nan), "spacing"),
])
def test_generators_reject_bad_input(call, name):
    with pytest.raises(ValueError, match=name):
        call()


# --- dead reckoning --------------------------------------------------------------------------------------------

def test_dead_reckoning_without_noise_is_exact():
    tr = circle_track(T, 200.0, 2.0)
    dr = dead_reckoning(tr, np.random.default_rng(0))
    assert isinstance(dr, DeadReckoningResult)
    np.testing.assert_allclose(dr.displacements[0], 0.0)
    np.testing.assert_allclose(dr.displacements[1:], np.diff(tr.positions, axis=0), atol=1e-12)
    np.testing.assert_allclose(dr.positions, tr.positions, atol=1e-9)
    batch = dead_reckoning(tr, np.random.default_rng(0), n_runs=3)
    assert batch.displacements.shape == (3, len(T), 2) and batch.positions.shape == (3, len(T), 2)
    np.testing.assert_allclose(batch.positions[2], tr.positions, atol=1e-9)


@given(st.floats(-0.2, 0.2))
@settings(max_examples=25, deadline=None)
def test_heading_bias_gives_cross_track_error(beta):
    tr = straight_track(np.linspace(0.0, 1000.0, 101), (0.0, 0.0), 2.0, 0.4)
    dr = dead_reckoning(tr, np.random.default_rng(1), heading_bias=beta)
    distance = 2.0 * (tr.times - tr.times[0])
    err = dr.positions - tr.positions
    across = np.array([-np.sin(0.4), np.cos(0.4)])
    np.testing.assert_allclose(err @ across, distance * np.sin(beta), atol=1e-8)


def test_speed_scale_gives_along_track_error():
    tr = straight_track(T, (0.0, 0.0), 2.0, 0.0)
    dr = dead_reckoning(tr, np.random.default_rng(1), speed_scale=1.01)
    np.testing.assert_allclose(dr.positions[-1], [202.0, 0.0])


def test_dead_reckoning_noise_statistics():
    dt = 2.0
    tr = straight_track(np.arange(0.0, 401.0, dt), (0.0, 0.0), 1.5, 0.0)
    dr = dead_reckoning(tr, np.random.default_rng(7), speed_sigma=0.1, heading_sigma=0.02, n_runs=2000)
    err = dr.displacements[:, 1:] - np.diff(tr.positions, axis=0)
    # along track: dt * speed noise; across: step * heading noise (small angles)
    assert err[..., 0].std() == pytest.approx(dt * 0.1, rel=0.02)
    assert err[..., 1].std() == pytest.approx(1.5 * dt * 0.02, rel=0.02)
    assert abs(err[..., 0].mean()) < 0.01
    # white: neighbouring steps uncorrelated
    assert abs(np.corrcoef(err[:, 1:, 0].ravel(), err[:, :-1, 0].ravel())[0, 1]) < 0.01


def test_dead_reckoning_reproducible_and_runs_independent():
    tr = circle_track(T, 200.0, 2.0)
    a = dead_reckoning(tr, np.random.default_rng(3), speed_sigma=0.1, n_runs=4)
    b = dead_reckoning(tr, np.random.default_rng(3), speed_sigma=0.1, n_runs=4)
    np.testing.assert_array_equal(a.displacements, b.displacements)
    assert not np.allclose(a.displacements[0], a.displacements[1])


def test_dead_reckoning_stationary_vehicle():
    tr = Track([0.0, 1.0, 2.0], np.zeros((3, 2)), [[0.0, 1.0]] * 3)
    dr = dead_reckoning(tr, np.random.default_rng(0), speed_sigma=1.0)
    assert np.all(np.isfinite(dr.positions))
    np.testing.assert_allclose(dr.displacements[1:, 0], 0.0, atol=1e-12)   # noise along the heading (north)


@pytest.mark.parametrize("kwargs, exc, name", [
    ({"speed_sigma": -1.0}, ValueError, "speed_sigma"),
    ({"heading_sigma": np.nan}, ValueError, "heading_sigma"),
    ({"heading_bias": np.inf}, ValueError, "heading_bias"),
    ({"speed_scale": 0.0}, ValueError, "speed_scale"),
    ({"n_runs": 0}, ValueError, "n_runs"),
    ({"n_runs": 2.0}, TypeError, "n_runs"),
])
def test_dead_reckoning_rejects_bad_input(kwargs, exc, name):
    with pytest.raises(exc, match=name):
        dead_reckoning(straight_track(T, (0, 0), 1.0, 0.0), np.random.default_rng(0), **kwargs)


def test_dead_reckoning_requires_generator_and_track():
    tr = straight_track(T, (0, 0), 1.0, 0.0)
    with pytest.raises(TypeError, match="rng"):
        dead_reckoning(tr, 42)
    with pytest.raises(TypeError, match="rng"):
        dead_reckoning(tr, np.random.RandomState(0))
    with pytest.raises(TypeError, match="track"):
        dead_reckoning(tr.positions, np.random.default_rng(0))


def test_displacement_noise_statistics_and_shapes():
    d = np.zeros((301, 2))
    d[1:] = [2.0, 1.0]
    rng = np.random.default_rng(11)
    noisy = displacement_noise(d, rng, 0.9, n_runs=1000)
    assert noisy.shape == (1000, 301, 2)
    np.testing.assert_array_equal(noisy[:, 0], 0.0)          # row 0 keeps its convention
    err = noisy[:, 1:] - d[1:]
    assert err.std(axis=(0, 1)) == pytest.approx([0.9, 0.9], rel=0.01)
    assert np.abs(err.mean(axis=(0, 1))).max() < 0.01
    assert abs(np.corrcoef(err[..., 0].ravel(), err[..., 1].ravel())[0, 1]) < 0.01
    assert displacement_noise(d, rng, 0.9).shape == (301, 2)
    batch = np.broadcast_to(d, (5, 301, 2))
    assert displacement_noise(batch, rng, 0.9).shape == (5, 301, 2)
    np.testing.assert_array_equal(displacement_noise(d, rng, 0.0), d)


@pytest.mark.parametrize("d, sigma, n_runs, exc, name", [
    (np.zeros((5, 3)), 1.0, None, ValueError, "displacements"),
    (np.zeros(5), 1.0, None, ValueError, "displacements"),
    (np.full((5, 2), np.nan), 1.0, None, ValueError, "displacements"),
    (np.zeros((5, 2)), -1.0, None, ValueError, "sigma"),
    (np.zeros((5, 2)), np.nan, None, ValueError, "sigma"),
    (np.zeros((3, 5, 2)), 1.0, 4, ValueError, "n_runs"),
    (np.zeros((5, 2)), 1.0, 0, ValueError, "n_runs"),
])
def test_displacement_noise_rejects_bad_input(d, sigma, n_runs, exc, name):
    with pytest.raises(exc, match=name):
        displacement_noise(d, np.random.default_rng(0), sigma, n_runs=n_runs)


def test_displacement_noise_requires_generator():
    with pytest.raises(TypeError, match="rng"):
        displacement_noise(np.zeros((5, 2)), None, 1.0)
