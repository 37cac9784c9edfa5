"""uwtutor.observability against closed forms, independent computations and Monte Carlo.

Nothing in the library is tuned to these numbers: the closed forms come from the geometry (evenly spaced beacons,
two beacons at an angle), the ranks from the algebra of the squared range, the Monte Carlo from a nonlinear least-
squares fix written here (and checked against scipy's).
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import least_squares

from uwtutor import motion
from uwtutor import observability as ob
from uwtutor.observability import UnobservableWarning


def _no_warnings():
    ctx = warnings.catch_warnings()
    ctx.__enter__()
    warnings.simplefilter("error")
    return ctx


# =====================================================================================================================
# Closed forms of the bound
# =====================================================================================================================
@settings(max_examples=60, deadline=None)
@given(n=st.integers(3, 16), rotation=st.floats(0.0, 2 * np.pi), sigma=st.floats(0.1, 50.0),
       x=st.floats(-5000, 5000), y=st.floats(-5000, 5000), seed=st.integers(0, 2**31))
def test_evenly_spaced_beacons_give_two_sigma_over_root_n(n, rotation, sigma, x, y, seed):
    # N >= 3 beacons evenly spaced in bearing, at any distances: J = N/(2 sigma^2) I, RMSE bound 2 sigma / sqrt(N)
    p = np.array([x, y])
    distances = np.random.default_rng(seed).uniform(50.0, 5000.0, n)
    bearings = rotation + 2 * np.pi * np.arange(n) / n
    beacons = p + distances[:, None] * np.column_stack([np.cos(bearings), np.sin(bearings)])
    J = ob.fisher_information(beacons, p, sigma)
    np.testing.assert_allclose(J, n / (2 * sigma**2) * np.eye(2), rtol=1e-9, atol=1e-12 * n / sigma**2)
    C = ob.position_crlb(beacons, p, sigma)
    assert ob.rmse_bound(C) == pytest.approx(2 * sigma / math.sqrt(n), rel=1e-9)
    assert ob.gdop(beacons, p) == pytest.approx(2 / math.sqrt(n), rel=1e-9)
    # with an unknown bias the balanced geometry costs nothing: the bias is uncoupled, variance sigma^2 / N
    Cb = ob.position_crlb(beacons, p, sigma, unknown_bias=True)
    np.testing.assert_allclose(Cb[:2, :2], C, rtol=1e-8, atol=1e-12 * sigma**2)
    assert Cb[2, 2] == pytest.approx(sigma**2 / n, rel=1e-8)
    assert ob.precision_factor(beacons, p) == pytest.approx(4 / n + 1 / n, rel=1e-8)


def test_two_beacons_at_0_and_60_degrees():
    b = ob.beacons_at_bearings([0.0, 0.0], np.radians([0.0, 60.0]), [300.0, 2000.0])
    assert ob.rmse_bound(ob.position_crlb(b, [0.0, 0.0], 1.0)) == pytest.approx(1.6330, abs=5e-5)
    assert ob.rmse_bound(ob.position_crlb(b, [0.0, 0.0], 1.0)) == pytest.approx(math.sqrt(8 / 3), rel=1e-12)
    assert ob.rmse_bound(ob.position_crlb(b, [0.0, 0.0], 3.0)) == pytest.approx(3 * 1.6330, abs=2e-4)


@settings(max_examples=60, deadline=None)
@given(delta=st.floats(2.0, 178.0), base=st.floats(-180.0, 180.0), sigma=st.floats(0.1, 30.0))
def test_two_beacons_closed_form(delta, base, sigma):
    # tr J = 2/sigma^2, det J = sin^2(delta)/sigma^4, so tr J^-1 = 2 sigma^2 / sin^2(delta)
    b = ob.beacons_at_bearings([10.0, -20.0], np.radians([base, base + delta]), 700.0)
    bound = ob.rmse_bound(ob.position_crlb(b, [10.0, -20.0], sigma))
    assert bound == pytest.approx(math.sqrt(2) * sigma / abs(math.sin(math.radians(delta))), rel=1e-8)


def test_unequal_noise_weights_each_range():
    # beacons east and north: J = diag(1/s1^2, 1/s2^2) exactly
    J = ob.fisher_information([[100.0, 0.0], [0.0, 100.0]], [0.0, 0.0], [2.0, 5.0])
    np.testing.assert_allclose(J, np.diag([1 / 4, 1 / 25]), atol=1e-15)
    C = ob.position_crlb([[100.0, 0.0], [0.0, 100.0]], [0.0, 0.0], [2.0, 5.0])
    np.testing.assert_allclose(C, np.diag([4.0, 25.0]), atol=1e-12)


def test_three_beacons_by_hand():
    # the exercise's numbers: h = (-1, 0), (0, -1), (1, 1)/sqrt 2 and sigma = 2
    J = ob.fisher_information([[1000.0, 0.0], [0.0, 500.0], [-800.0, -800.0]], [0.0, 0.0], 2.0)
    np.testing.assert_allclose(J, [[0.375, 0.125], [0.125, 0.375]], atol=1e-15)
    C = ob.position_crlb([[1000.0, 0.0], [0.0, 500.0], [-800.0, -800.0]], [0.0, 0.0], 2.0)
    np.testing.assert_allclose(C, [[3.0, -1.0], [-1.0, 3.0]], atol=1e-12)
    assert ob.rmse_bound(C) == pytest.approx(math.sqrt(6))


def test_batches_broadcast_over_positions():
    beacons = np.array([[100.0, 0.0], [0.0, 300.0], [-200.0, -50.0]])
    positions = np.array([[0.0, 0.0], [10.0, 20.0], [-30.0, 5.0]])
    C = ob.position_crlb(beacons, positions, 2.0)
    assert C.shape == (3, 2, 2)
    for i, p in enumerate(positions):
        np.testing.assert_allclose(C[i], ob.position_crlb(beacons, p, 2.0), rtol=1e-12)
    np.testing.assert_allclose(ob.gdop(beacons, positions), np.sqrt(np.trace(C, axis1=1, axis2=2)) / 2.0)


def test_precision_factor_is_the_trace_of_the_bound_with_bias():
    # paper A: alpha sigma^2 = tr CRLB of [x, y, bias]
    rng = np.random.default_rng(3)
    beacons = rng.uniform(-2000, 2000, (12, 2))
    p = np.array([100.0, -40.0])
    C = ob.position_crlb(beacons, p, 4.0, unknown_bias=True)
    assert ob.precision_factor(beacons, p) * 16.0 == pytest.approx(np.trace(C), rel=1e-10)
    assert ob.precision_factor(beacons, p) == pytest.approx(ob.gdop(beacons, p, unknown_bias=True) ** 2)
    X = np.column_stack([(p - beacons) / np.linalg.norm(p - beacons, axis=1, keepdims=True), np.ones(12)])
    assert ob.precision_factor(beacons, p) == pytest.approx(np.sum(1 / np.linalg.eigvalsh(X.T @ X)), rel=1e-10)


# =====================================================================================================================
# Degenerate geometry: a bound with a warning, infinite where unobservable
# =====================================================================================================================
def test_one_beacon_bounds_the_range_only():
    with pytest.warns(UnobservableWarning, match=r"rank 1 of 2.*\+1.00 y"):
        C = ob.position_crlb([[500.0, 0.0]], [0.0, 0.0], 3.0)
    assert C[0, 0] == pytest.approx(9.0)                # along the line of sight: one range, sigma^2
    assert C[1, 1] == np.inf                            # across it: nothing
    assert C[0, 1] == 0.0 and C[1, 0] == 0.0            # x is estimable on its own
    assert ob.rmse_bound(C) == np.inf


def test_collinear_beacons_through_the_vehicle():
    # two beacons on a line through the vehicle at 45 degrees: the perpendicular is unobservable
    b = ob.beacons_at_bearings([0.0, 0.0], np.radians([45.0, 225.0]), [100.0, 900.0])
    with pytest.warns(UnobservableWarning):
        C = ob.position_crlb(b, [0.0, 0.0], 1.0)
    assert np.all(np.isinf(C)) and not np.any(np.isnan(C))
    assert C[0, 0] > 0 and C[1, 1] > 0 and C[0, 1] < 0  # the unobservable direction (1, -1)/sqrt 2
    with pytest.warns(UnobservableWarning):
        assert ob.gdop(b, [0.0, 0.0]) == np.inf


def test_two_beacons_with_a_bias_are_not_enough():
    b = ob.beacons_at_bearings([0.0, 0.0], np.radians([0.0, 90.0]), 1000.0)
    with pytest.warns(UnobservableWarning, match="rank 2 of 3"):
        C = ob.position_crlb(b, [0.0, 0.0], 1.0, unknown_bias=True)
    assert C.shape == (3, 3) and np.all(np.isinf(np.diag(C)))
    with pytest.warns(UnobservableWarning):
        assert ob.precision_factor(b, [0.0, 0.0]) == np.inf


def test_position_on_a_beacon_gives_no_information_from_it():
    with pytest.warns(UnobservableWarning, match="coincides"):
        J = ob.fisher_information([[0.0, 0.0], [100.0, 0.0], [0.0, 100.0]], [0.0, 0.0], 1.0)
    np.testing.assert_allclose(J, np.eye(2))


def test_regular_geometry_does_not_warn():
    ctx = _no_warnings()
    try:
        ob.position_crlb([[100.0, 0.0], [0.0, 100.0]], [0.0, 0.0], 1.0)
        ob.position_crlb(ob.beacons_at_bearings([0, 0], np.radians([0, 100, 200])), [0, 0], 1.0, unknown_bias=True)
    finally:
        ctx.__exit__(None, None, None)


def test_nearly_degenerate_geometry_is_finite_and_large():
    # beacons 0.01 degrees apart: observable, but badly; the bound is finite and follows the closed form
    b = ob.beacons_at_bearings([0.0, 0.0], np.radians([0.0, 0.01]), 1000.0)
    C = ob.position_crlb(b, [0.0, 0.0], 1.0)
    assert ob.rmse_bound(C) == pytest.approx(math.sqrt(2) / math.sin(math.radians(0.01)), rel=1e-6)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31), n=st.integers(2, 5))
def test_cramer_rao_bound_inverts_regular_information(seed, n):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(n + 3, n)) * rng.uniform(0.01, 100.0, n)  # columns on very different scales
    J = A.T @ A
    np.testing.assert_allclose(ob.cramer_rao_bound(J), np.linalg.inv(J), rtol=1e-6,
                               atol=1e-9 * np.abs(np.linalg.inv(J)).max())


def test_cramer_rao_bound_of_a_singular_information():
    # information about x and (y + z) only: y and z are not estimable, x is, and keeps its bound
    H = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 1.0], [1.0, 0.0, 0.0]])
    J = H.T @ H
    with pytest.warns(UnobservableWarning, match=r"rank 2 of 3"):
        C = ob.cramer_rao_bound(J)
    assert C[0, 0] == pytest.approx(0.5)
    assert C[1, 1] == np.inf and C[2, 2] == np.inf
    assert C[1, 2] == -np.inf                           # the null direction (0, 1, -1)
    assert C[0, 1] == 0.0 and C[0, 2] == 0.0
    # the limit definition: (J + eps I)^-1 for a small eps has the same finite entries and signs
    reg = np.linalg.inv(J + 1e-9 * np.eye(3))
    assert reg[0, 0] == pytest.approx(0.5, rel=1e-6)
    assert np.sign(reg[1, 2]) == -1 and reg[1, 1] > 1e8


def test_cramer_rao_bound_does_not_depend_on_units():
    # a current in m/s next to positions in m: rescaling a state by 1e4 changes nothing but its units
    H = np.array([[1.0, 0.0, 3.0], [0.0, 1.0, 5.0], [0.6, 0.8, 1.0], [0.8, -0.6, 2.0]])
    J = H.T @ H
    D = np.diag([1.0, 1.0, 1e4])
    C = ob.cramer_rao_bound(J)
    Cs = ob.cramer_rao_bound(D @ J @ D)
    np.testing.assert_allclose(D @ Cs @ D, C, rtol=1e-8)


def test_cramer_rao_bound_validates():
    with pytest.raises(ValueError, match="square"):
        ob.cramer_rao_bound(np.ones((2, 3)))
    with pytest.raises(ValueError, match="symmetric"):
        ob.cramer_rao_bound([[1.0, 2.0], [0.0, 1.0]])
    with pytest.raises(ValueError, match="finite"):
        ob.cramer_rao_bound([[np.nan, 0.0], [0.0, 1.0]])
    with pytest.raises(ValueError, match="rtol"):
        ob.cramer_rao_bound(np.eye(2), rtol=2.0)


def test_inputs_are_validated_with_clear_errors():
    with pytest.raises(ValueError, match="sigma must be > 0"):
        ob.position_crlb([[1.0, 0.0]], [0.0, 0.0], 0.0)
    with pytest.raises(ValueError, match="beacons must hold 2-D points"):
        ob.position_crlb([1.0, 0.0, 3.0], [0.0, 0.0], 1.0)
    with pytest.raises(ValueError, match="position must be finite"):
        ob.fisher_information([[1.0, 0.0]], [np.nan, 0.0], 1.0)
    with pytest.raises(ValueError, match="one standard deviation per range"):
        ob.fisher_information([[1.0, 0.0], [0.0, 1.0]], [0.0, 0.0], [1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="at least one beacon"):
        ob.fisher_information(np.zeros((0, 2)), [0.0, 0.0], 1.0)
    with pytest.raises(ValueError, match="times are needed"):
        ob.track_jacobian([[0.0, 1.0], [1.0, 1.0]], [0.0, 0.0], unknown_current=True)
    with pytest.raises(ValueError, match="one entry per row of positions"):
        ob.track_jacobian([[0.0, 1.0], [1.0, 1.0]], [0.0, 0.0], times=[0.0], unknown_current=True)
    with pytest.raises(ValueError, match="reference must be an epoch index"):
        ob.track_jacobian([[0.0, 1.0], [1.0, 1.0]], [0.0, 0.0], reference=5)
    with pytest.raises(ValueError, match="beacon must have shape"):
        ob.virtual_beacons(np.zeros((3, 2)), np.zeros((2, 2)))
    with pytest.raises(ValueError, match="direction must not be zero"):
        ob.mirror_point([1.0, 1.0], [0.0, 0.0], [0.0, 0.0])


# =====================================================================================================================
# Jacobians and virtual beacons
# =====================================================================================================================
@settings(max_examples=50, deadline=None)
@given(px=st.floats(-1e4, 1e4), py=st.floats(-1e4, 1e4), bx=st.floats(-1e4, 1e4), by=st.floats(-1e4, 1e4))
def test_jacobians_are_the_derivatives(px, py, bx, by):
    p, b = np.array([px, py]), np.array([bx, by])
    r = np.hypot(*(p - b))
    if r < 1.0:
        return
    h = ob.range_jacobian(p, b)
    assert np.linalg.norm(h) == pytest.approx(1.0)
    eps = 1e-3
    numeric = [(np.hypot(*(p + eps * e - b)) - np.hypot(*(p - eps * e - b))) / (2 * eps) for e in np.eye(2)]
    np.testing.assert_allclose(h, numeric, atol=1e-6)
    np.testing.assert_allclose(ob.squared_range_jacobian(p, b), 2 * r * h, rtol=1e-9, atol=1e-9)


def test_virtual_beacons_reproduce_the_ranges():
    times = np.arange(0.0, 300.0, 10.0)
    track = motion.turning_track(times, (-400.0, 250.0), 2.0, [0.3, 1.9], [150.0])
    beacon = np.array([50.0, -30.0])
    for ref in (0, 12, -1):
        vb = ob.virtual_beacons(beacon, track.positions, reference=ref)
        np.testing.assert_allclose(np.hypot(*(track.positions[ref] - vb).T),
                                   np.hypot(*(track.positions - beacon).T), rtol=1e-12)
    moving = beacon + np.column_stack([times, -times]) * 0.5   # a moving beacon, one position per epoch
    vb = ob.virtual_beacons(moving, track.positions)
    np.testing.assert_allclose(np.hypot(*(track.positions[-1] - vb).T),
                               np.hypot(*(track.positions - moving).T), rtol=1e-12)


def test_track_bound_equals_the_static_bound_of_the_virtual_beacons():
    # two code paths: the cumulative track information, and position_crlb on virtual beacons
    times = np.arange(0.0, 600.0, 10.0)
    track = motion.circle_track(times, 700.0, 2.0, center=(100.0, 0.0))
    with pytest.warns(UnobservableWarning, match="2 of 60"):      # the first two epochs: fewer ranges than unknowns
        C_track = ob.track_crlb(track.positions, (0.0, 0.0), 3.0, unknown_bias=True)
    for k in (5, 30, len(times) - 1):
        vb = ob.virtual_beacons((0.0, 0.0), track.positions[:k + 1])
        C_static = ob.position_crlb(vb, track.positions[k], 3.0, unknown_bias=True)
        np.testing.assert_allclose(C_track[k], C_static, rtol=1e-8)


def test_cumulative_information_with_a_current_refers_to_each_epoch():
    # J_k from the cumulative path equals H^T H of the Jacobian taken at reference epoch k
    times = np.arange(0.0, 400.0, 10.0)
    track = motion.turning_track(times, (-800.0, 300.0), 2.0, [0.0, 1.2], [200.0])
    J = ob.track_fisher_information(track.positions, (0.0, 0.0), 2.0, times=times, unknown_current=True,
                                    unknown_bias=True, cumulative=True)
    for k in (3, 21, len(times) - 1):
        H = ob.track_jacobian(track.positions[:k + 1], (0.0, 0.0), times=times[:k + 1], unknown_current=True,
                              unknown_bias=True, reference=k)
        np.testing.assert_allclose(J[k], H.T @ H / 4.0, rtol=1e-9, atol=1e-9 * np.abs(J[k]).max())
    np.testing.assert_allclose(ob.track_fisher_information(track.positions, (0.0, 0.0), 2.0, times=times,
                                                           unknown_current=True, unknown_bias=True), J[-1])


# =====================================================================================================================
# The rank drops exactly where theory says
# =====================================================================================================================
TIMES = np.arange(0.0, 1200.0 + 1e-9, 10.0)


def _tracks():
    return {
        "radial": motion.straight_track(TIMES, (-2600.0, 0.0), 2.0, 0.0),
        "straight": motion.straight_track(TIMES, (-1500.0, 600.0), 2.0, 0.0),
        "turn": motion.turning_track(TIMES, (-1500.0, 600.0), 2.0, [0.0, np.pi / 2], [600.0]),
        "circle": motion.circle_track(TIMES, 800.0, 2.0, start_angle=-np.pi / 2),
        "lawnmower": motion.lawnmower_track(TIMES, (-600.0, -700.0), 2.0, 800.0, 250.0),
    }


# (position, + bias, + current): radial motion sees one direction (two with the current's time-weighted column);
# a straight track cannot separate the current from a rotation about the beacon; any turn can.
EXPECTED_RANKS = {
    "radial": (1, 1, 2),
    "straight": (2, 3, 3),
    "turn": (2, 3, 4),
    "circle": (2, 3, 4),
    "lawnmower": (2, 3, 4),
}


@pytest.mark.parametrize("name", list(EXPECTED_RANKS))
def test_final_ranks_match_theory(name):
    track = _tracks()[name]
    for flags, expected in zip(({}, {"unknown_bias": True}, {"unknown_current": True}), EXPECTED_RANKS[name]):
        rank = ob.observability_rank(track.positions, (0.0, 0.0), times=TIMES, cumulative=False, **flags)
        assert rank == expected, (name, flags)
        H = ob.track_jacobian(track.positions, (0.0, 0.0), times=TIMES, **flags)
        assert ob.numerical_rank(H) == expected
        # squared ranges: rows scaled by 2 r_k, same rank
        r = np.hypot(*track.positions.T)
        assert ob.numerical_rank(2 * r[:, None] * H) == expected


def test_straight_track_with_current_gains_rank_at_the_first_epoch_after_the_turn():
    track = _tracks()["turn"]
    ranks = ob.observability_rank(track.positions, (0.0, 0.0), times=TIMES, unknown_current=True)
    first_after = int(np.searchsorted(TIMES, 600.0, side="right"))    # 610 s: the first range on the new leg
    assert list(ranks[:4]) == [1, 2, 3, 3]
    assert np.all(ranks[2:first_after] == 3)
    assert np.all(ranks[first_after:] == 4)
    bounds = ob.rmse_bound(_quiet(ob.track_crlb, track.positions, (0.0, 0.0), 1.0, times=TIMES,
                                  unknown_current=True))
    assert np.all(np.isinf(bounds[:first_after])) and np.all(np.isfinite(bounds[first_after:]))


def test_position_rank_is_two_from_the_second_range_unless_radial():
    tracks = _tracks()
    ranks = ob.observability_rank(tracks["straight"].positions, (0.0, 0.0))
    assert ranks[0] == 1 and np.all(ranks[1:] == 2)
    radial = ob.observability_rank(tracks["radial"].positions, (0.0, 0.0), unknown_bias=True)
    assert np.all(radial == 1)


def test_the_unobservable_direction_of_a_straight_track_with_current_is_a_rotation():
    track = _tracks()["straight"]
    H = ob.track_jacobian(track.positions, (0.0, 0.0), times=TIMES, unknown_current=True, reference=-1)
    p_ref, w = track.positions[-1], track.velocities[-1]
    v = np.array([-p_ref[1], p_ref[0], -w[1], w[0]])   # turn p_ref about the beacon, and w with it
    assert np.linalg.norm(H @ v) < 1e-10 * np.linalg.norm(H) * np.linalg.norm(v)
    # and the ranges are invariant to a finite rotation of the whole ground track about the beacon
    angle = 0.3
    R = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    np.testing.assert_allclose(np.hypot(*(track.positions @ R.T).T), np.hypot(*track.positions.T), rtol=1e-12)


def test_numerical_rank_scales_columns_and_uses_the_tolerance():
    A = np.array([[1.0, 0.0], [0.0, 1e-9]])
    assert ob.numerical_rank(A) == 2                     # column scaling: a small unit is not a lost direction
    B = np.array([[1.0, 1.0], [1.0, 1.0 + 1e-9]])
    assert ob.numerical_rank(B) == 1 and ob.numerical_rank(B, rtol=1e-12) == 2
    np.testing.assert_array_equal(ob.numerical_rank(np.stack([np.eye(2), B])), [2, 1])


def _quiet(func, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UnobservableWarning)
        return func(*args, **kwargs)


# =====================================================================================================================
# Monte Carlo: the nonlinear least-squares fix approaches the bound as ranges accumulate
# =====================================================================================================================
def _nls_fix(beacons: np.ndarray, ranges: np.ndarray, start: np.ndarray, bias: bool = False,
             iterations: int = 100) -> np.ndarray:
    """Batched Gauss-Newton with step halving for min sum (r_k - |x - b_k| - bias)^2, one fix per row of ranges."""
    n = 3 if bias else 2
    x = np.zeros((len(ranges), n))
    x[:, :2] = start

    def residuals(x, rows):
        rho = np.linalg.norm(x[:, None, :2] - beacons[None], axis=-1)
        return ranges[rows] - rho - (x[:, 2:3] if bias else 0.0)

    cost = np.sum(residuals(x, slice(None)) ** 2, axis=-1)
    active = np.arange(len(x))
    for _ in range(iterations):
        xa = x[active]
        d = xa[:, None, :2] - beacons[None]
        H = d / np.linalg.norm(d, axis=-1, keepdims=True)
        if bias:
            H = np.concatenate([H, np.ones(H.shape[:-1] + (1,))], axis=-1)
        A = np.einsum("mki,mkj->mij", H, H)
        step = np.linalg.solve(A, np.einsum("mki,mk->mi", H, residuals(xa, active))[..., None])[..., 0]
        t = np.ones(len(active))
        trial = np.sum(residuals(xa + step, active) ** 2, axis=-1)
        for _ in range(40):                              # halve the step where it does not reduce the cost
            worse = np.flatnonzero(trial > cost[active])
            if worse.size == 0:
                break
            t[worse] /= 2
            trial[worse] = np.sum(residuals(xa[worse] + t[worse, None] * step[worse], active[worse]) ** 2, axis=-1)
        x[active] = xa + t[:, None] * step
        cost[active] = np.minimum(trial, cost[active])
        moving = np.linalg.norm(t[:, None] * step, axis=-1) > 1e-10 * (1.0 + np.linalg.norm(xa, axis=-1))
        active = active[moving]
        if active.size == 0:
            break
    return x


def _arc(k: int, radius: float = 1000.0, spacing_deg: float = 0.9) -> np.ndarray:
    phi = np.radians(spacing_deg * np.arange(k))
    return radius * np.column_stack([np.cos(phi), np.sin(phi)])


def test_batched_fix_agrees_with_scipy_least_squares():
    rng = np.random.default_rng(11)
    track = _arc(16)
    vb = ob.virtual_beacons((0.0, 0.0), track)
    p = track[-1]
    ranges = np.hypot(*(track).T) + rng.normal(0.0, 20.0, (20, len(track)))
    fixes = _nls_fix(vb, ranges, p)
    for r, fix in zip(ranges, fixes):
        ref = least_squares(lambda x: np.hypot(*(x - vb).T) - r, p, xtol=1e-12, ftol=1e-12, gtol=1e-12).x
        np.testing.assert_allclose(fix, ref, atol=1e-5)


def test_monte_carlo_of_the_nonlinear_fix_approaches_the_bound():
    # ranges accumulate along a circle about the beacon (0.9 degrees of bearing per range, sigma = 20 m): with a
    # few ranges the fix is nonlinear and biased; with many, its mean squared error meets the bound
    rng = np.random.default_rng(2020)
    sigma, m = 20.0, 4000
    ratio, bias_fraction = {}, {}
    for k in (4, 8, 64, 128, 256):
        track = _arc(k)
        vb = ob.virtual_beacons((0.0, 0.0), track)
        p = track[-1]
        bound = ob.position_crlb(vb, p, sigma)
        ranges = np.hypot(*track.T) + rng.normal(0.0, sigma, (m, k))
        err = _nls_fix(vb, ranges, p) - p
        ratio[k] = np.mean(np.sum(err**2, axis=-1)) / np.trace(bound)
        bias_fraction[k] = np.linalg.norm(err.mean(axis=0)) / math.sqrt(np.trace(bound))
    for k in (64, 128, 256):                       # sampling error of the ratio: about sqrt(2/m) = 2.2 %
        assert abs(ratio[k] - 1) < 0.08, (k, ratio[k])
        assert bias_fraction[k] < 0.05, (k, bias_fraction[k])
    assert bias_fraction[4] > 0.2 and bias_fraction[8] > bias_fraction[64]
    assert abs(ratio[256] - 1) < abs(ratio[4] - 1)


def test_monte_carlo_with_an_unknown_bias_meets_the_bound():
    # eight beacons evenly spaced in bearing, a 7 m range bias: bound 2 sigma / sqrt 8 for the position, sigma^2 / 8
    rng = np.random.default_rng(7)
    sigma, m, n = 5.0, 4000, 8
    p = np.array([120.0, -80.0])
    beacons = ob.beacons_at_bearings(p, 2 * np.pi * np.arange(n) / n + 0.2, np.linspace(600.0, 2500.0, n))
    ranges = np.hypot(*(p - beacons).T) + 7.0 + rng.normal(0.0, sigma, (m, n))
    est = _nls_fix(beacons, ranges, p, bias=True)
    C = ob.position_crlb(beacons, p, sigma, unknown_bias=True)
    mse_pos = np.mean(np.sum((est[:, :2] - p) ** 2, axis=-1))
    assert mse_pos / (C[0, 0] + C[1, 1]) == pytest.approx(1.0, abs=0.08)
    assert math.sqrt(C[0, 0] + C[1, 1]) == pytest.approx(2 * sigma / math.sqrt(n))
    assert np.var(est[:, 2]) / C[2, 2] == pytest.approx(1.0, abs=0.1)
    assert np.mean(est[:, 2]) == pytest.approx(7.0, abs=4 * math.sqrt(C[2, 2] / m))


# =====================================================================================================================
# Two-range fix, mirror point, ellipse
# =====================================================================================================================
@settings(max_examples=80, deadline=None)
@given(px=st.floats(-3000, 3000), py=st.floats(-3000, 3000), ux=st.floats(-500, 500), uy=st.floats(-500, 500),
       bx=st.floats(-100, 100), by=st.floats(-100, 100))
def test_two_range_fix_finds_the_truth_and_its_mirror(px, py, ux, uy, bx, by):
    p, u, b = np.array([px, py]), np.array([ux, uy]), np.array([bx, by])
    if np.hypot(*u) < 10.0 or np.hypot(*(p - b)) < 10.0 or np.hypot(*(p - u - b)) < 10.0:
        return
    e = u / np.hypot(*u)
    cross = abs(e[0] * (p - b)[1] - e[1] * (p - b)[0])   # distance of p from the mirror line
    if cross < 1.0:
        return  # (nearly) on the mirror line: the two solutions merge, tested separately
    r = [np.hypot(*(p - u - b)), np.hypot(*(p - b))]
    sol = ob.two_range_fix(b, r, u)
    mirror = ob.mirror_point(p, b, u)
    i = int(np.argmin(np.linalg.norm(sol - p, axis=1)))
    tol = 1e-6 * max(1.0, float(np.max(np.abs(p))))
    np.testing.assert_allclose(sol[i], p, atol=max(tol, 1e-3 * 3000 / cross))
    np.testing.assert_allclose(sol[1 - i], mirror, atol=max(tol, 1e-3 * 3000 / cross))
    for s in sol:                                        # both fit both ranges
        assert np.hypot(*(s - b)) == pytest.approx(r[1], abs=1e-6 * max(r))
        assert np.hypot(*(s - u - b)) == pytest.approx(r[0], abs=1e-6 * max(r))
    # row 0 is to the left of the direction of travel
    left = e[0] * (sol[0] - b)[1] - e[1] * (sol[0] - b)[0]
    assert left > 0


def test_two_range_fix_degenerate_cases():
    # radial motion: the circles touch, one solution
    sol = ob.two_range_fix([0.0, 0.0], [500.0, 300.0], [200.0, 0.0])
    np.testing.assert_allclose(sol, [[-300.0, 0.0], [-300.0, 0.0]], atol=1e-9)
    # inconsistent ranges: the best point on the line of centres, with a warning
    with pytest.warns(UnobservableWarning, match="do not meet"):
        sol = ob.two_range_fix([0.0, 0.0], [520.0, 300.0], [200.0, 0.0])
    np.testing.assert_allclose(sol[0], sol[1])
    assert sol[0, 1] == 0.0 and sol[0, 0] == pytest.approx(-310.0)   # splits the 20 m misfit
    with pytest.warns(UnobservableWarning, match="displacement is zero"):
        assert np.all(np.isnan(ob.two_range_fix([0.0, 0.0], [500.0, 500.0], [0.0, 0.0])))


def test_mirror_of_a_straight_track_has_the_same_ranges():
    track = _tracks()["straight"]
    mirror = ob.mirror_point(track.positions, (0.0, 0.0), track.velocities[0])
    np.testing.assert_allclose(np.hypot(*mirror.T), np.hypot(*track.positions.T), rtol=1e-12)
    np.testing.assert_allclose(mirror[:, 1], -track.positions[:, 1])


def test_error_ellipse_points_lie_on_the_ellipse():
    C = np.array([[9.0, 2.0], [2.0, 4.0]])
    pts = ob.error_ellipse(C, center=(10.0, -5.0), scale=2.0, n_points=50)
    d = pts - [10.0, -5.0]
    np.testing.assert_allclose(np.einsum("ki,ij,kj->k", d, np.linalg.inv(C), d), 4.0, rtol=1e-9)
    np.testing.assert_allclose(pts[0], pts[-1])
    with pytest.raises(ValueError, match="finite"):
        ob.error_ellipse(np.array([[np.inf, 0.0], [0.0, 1.0]]))
