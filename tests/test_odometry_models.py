"""Odometry motion and multi-beacon range models: conventions, Jacobians against finite differences, noise, batches,
bad input named; and the filter on a simulated odometry log with a range scale of 1.07 and a gyro bias recovers both
within its own 3 sigma."""

from __future__ import annotations

import numpy as np
import pytest

from uwtutor.filters import ReacquiringGate, extended_kalman_filter
from uwtutor.models import BeaconRanges, OdometryMotion, StateLayout, wrap_angle
from uwtutor.models.odometry import ORDERS

BEACONS = {"A": (0.0, 0.0), "B": (40.0, 0.0), "C": (40.0, 30.0), "D": (0.0, 30.0)}


def simulate_log(rng, K=600, dt=0.5, scale=1.07, gyro_bias=0.004, sigma_d=0.02, sigma_th=0.003, sigma_r=0.05,
                 beacons=BEACONS, order="turn-first", p_missing=0.3):
    """A robot wandering among the beacons at 1 m/s: true poses, odometry with noise and a gyro bias (rad/s),
    ranges ``scale`` times the distance with noise, ``p_missing`` of them missing (NaN)."""
    t = dt * np.arange(K)
    omega = 0.12 + 0.08 * np.sin(2 * np.pi * t / 90.0)
    u_true = np.column_stack([np.full(K, dt), omega * dt])
    u_true[0] = 0.0                                      # row 0: the motion up to times[0], none
    x0 = np.array([20.0, 5.0, 0.0])
    truth = OdometryMotion(0.0, 0.0, order=order).integrate(x0, u_true)
    u = u_true + np.column_stack([rng.normal(0, sigma_d, K), rng.normal(0, sigma_th, K)])
    u[1:, 1] += gyro_bias * dt
    u[0] = 0.0
    b = np.array(list(beacons.values()))
    z = scale * np.linalg.norm(truth[:, None, :2] - b[None], axis=-1) + rng.normal(0, sigma_r, (K, len(b)))
    z[rng.random(z.shape) < p_missing] = np.nan
    return dict(t=t, u=u, truth=truth, z=z, x0=x0)


def _numeric_jacobian(fun, x, eps=1e-6):
    """Central differences of fun (M, n) -> (M, q) at x (M, n): (M, q, n)."""
    cols = []
    for i in range(x.shape[-1]):
        dx = np.zeros_like(x)
        dx[..., i] = eps
        cols.append((fun(x + dx) - fun(x - dx)) / (2 * eps))
    return np.stack(cols, axis=-1)


# --- the layout ------------------------------------------------------------------------------------------------

def test_layouts():
    lay = StateLayout.odometry(gyro_bias=True, scale=True, range_bias=4)
    assert lay.n == 9 and (lay.heading, lay.gyro_bias, lay.scale) == (2, 3, 4) and lay.range_bias == (5, 6, 7, 8)
    assert lay.names[-1] == "range_bias_3"
    assert StateLayout.odometry(range_bias=True).range_bias == (3,)
    assert StateLayout.position(scale=True).names == ("x", "y", "scale")
    assert StateLayout(n=4, scale=3, range_bias=2).range_bias == (2,)


def test_initial_state_augments_the_start():
    lay = StateLayout.odometry(gyro_bias=True, scale=True, range_bias=2)
    x0, P0 = lay.initial_state([1.0, 2.0, 0.3], np.diag([4.0, 4.0, 0.01]), gyro_bias=(0.0, 0.01), scale=(1.0, 0.1),
                               range_bias=(0.5, 2.0))
    np.testing.assert_allclose(x0, [1.0, 2.0, 0.3, 0.0, 1.0, 0.5, 0.5])
    np.testing.assert_allclose(np.diag(P0), [4.0, 4.0, 0.01, 1e-4, 0.01, 4.0, 4.0])
    assert np.count_nonzero(P0 - np.diag(np.diag(P0))) == 0
    with pytest.raises(ValueError, match=r"missing \['scale'\]"):
        lay.initial_state([1.0, 2.0, 0.3], np.eye(3), gyro_bias=(0.0, 0.01), range_bias=(0.0, 1.0))
    with pytest.raises(ValueError, match="not in the layout"):
        StateLayout.odometry().initial_state([1.0, 2.0, 0.3], np.eye(3), scale=(1.0, 0.1))
    with pytest.raises(ValueError, match="start must hold the first 3"):
        lay.initial_state([1.0, 2.0], np.eye(2), gyro_bias=(0.0, 0.01), scale=(1.0, 0.1), range_bias=(0.0, 1.0))
    with pytest.raises(ValueError, match="std > 0"):
        StateLayout.odometry(scale=True).initial_state([1.0, 2.0, 0.3], np.eye(3), scale=(1.0, 0.0))


def test_layout_extra_slots_read_as_the_blocks_name_them():
    """A slot the fields do not name (a clock) given by its indices: a measurement model reads the layout as it reads
    the motion model built from blocks, to the same numbers."""
    from uwtutor.models import BlockMotion, OffsetAndRate, OneWayTravelTimeRanges, Position, RandomWalk
    motion = BlockMotion(Position(np.eye(2)), RandomWalk("scale"), OffsetAndRate("clock", rate_walk=1e-7), dt=1.0)
    layout = StateLayout(n=5, scale=2, extra={"clock": (3, 4)})
    assert layout.slots == motion.slots[:2] + ("clock",) and layout == StateLayout(n=5, scale=2,
                                                                                   extra=[("clock", [3, 4])])
    np.testing.assert_array_equal(layout.slot("clock"), motion.slot("clock"))
    hash(layout)                                    # still a frozen value
    x = np.array([[30.0, 40.0, 1.01, 2e-3, 20e-6], [-5.0, 12.0, 0.99, -1e-3, 0.0]])
    by_motion = OneWayTravelTimeRanges([[0.0, 0.0], [50.0, 0.0]], 0.25, motion, scale="scale")
    by_layout = OneWayTravelTimeRanges([[0.0, 0.0], [50.0, 0.0]], 0.25, layout, scale="scale")
    for a, b in zip(by_motion.linearize(x, 0), by_layout.linearize(x, 0)):
        np.testing.assert_array_equal(a, b)
    x0, P0 = layout.initial_state([1.0, 2.0], np.eye(2), scale=(1.0, 0.1), clock=(0.0, 1e-3))
    np.testing.assert_allclose(np.diag(P0), [1.0, 1.0, 0.01, 1e-6, 1e-6])
    # one (mean, std) per component: the clock's offset and rate apart
    x0, P0 = layout.initial_state([1.0, 2.0], np.eye(2), scale=(1.0, 0.1), clock=([1e-3, 0.0], [1e-3, 1e-4]))
    np.testing.assert_allclose(x0[3:], [1e-3, 0.0])
    np.testing.assert_allclose(np.diag(P0)[3:], [1e-6, 1e-8])
    with pytest.raises(ValueError, match="one per component"):
        layout.initial_state([1.0, 2.0], np.eye(2), scale=(1.0, 0.1), clock=([0.0, 0.0, 0.0], [1.0, 1.0, 1.0]))
    with pytest.raises(ValueError, match=r"missing \['clock'\]"):
        layout.initial_state([1.0, 2.0], np.eye(2), scale=(1.0, 0.1))


@pytest.mark.parametrize("extra, err, match", [
    ({"scale": 3}, ValueError, "field of StateLayout"),
    ({"clock": (2, 3)}, ValueError, "already the index of scale"),
    ({"clock": (3, 5)}, ValueError, r"extra\['clock'\] must index the state"),
    ({"clock": ()}, ValueError, "no index"),
    ({"2clock": 3}, ValueError, "slot name"),
    (5, TypeError, "extra must map slot names"),
])
def test_layout_extra_bad_input_named(extra, err, match):
    with pytest.raises(err, match=match):
        StateLayout(n=5, scale=2, extra=extra)


def test_layout_bad_input_named():
    with pytest.raises(ValueError, match="already the index of heading"):
        StateLayout(n=4, heading=2, scale=2)
    with pytest.raises(ValueError, match="scale must index the state"):
        StateLayout(n=3, scale=3)
    with pytest.raises(ValueError, match="scale must be >= 2"):
        StateLayout(n=3, scale=1)
    with pytest.raises(ValueError, match="needs a heading"):
        StateLayout(n=4, gyro_bias=3)
    with pytest.raises(TypeError, match="scale must be True or False"):
        StateLayout.odometry(scale="yes")


# --- the motion model ----------------------------------------------------------------------------------------

@pytest.mark.parametrize("order", list(ORDERS))
def test_orders_of_operations(order):
    x = np.array([[0.0, 0.0, 0.0]])
    out = OdometryMotion(0.1, 0.01, order=order).f(x, np.array([10.0, np.pi / 2]), 0)
    c = ORDERS[order]
    np.testing.assert_allclose(out[0], [10 * np.cos(c * np.pi / 2), 10 * np.sin(c * np.pi / 2), np.pi / 2],
                               atol=1e-12)


def test_gyro_bias_is_a_rate():
    """The same bias takes dt times as much heading off a step that lasts dt seconds."""
    x = np.array([[0.0, 0.0, 0.0, 0.01]])
    for dt in (0.5, 2.0):
        out = OdometryMotion(0.1, 0.01, gyro_bias=True, dt=dt).f(x, np.array([0.0, 0.03]), 0)
        assert out[0, 2] == pytest.approx(0.03 - 0.01 * dt)
    motion = OdometryMotion(0.1, 0.01, gyro_bias=True, times=[0.0, 1.0, 3.0])
    assert [motion.dt(k) for k in range(3)] == [0.0, 1.0, 2.0]           # x0 is the state at times[0]


def test_heading_is_wrapped():
    out = OdometryMotion(0.0, 0.0).f(np.array([[0.0, 0.0, 3.0]]), np.array([1.0, 0.5]), 0)
    assert -np.pi <= out[0, 2] < np.pi and out[0, 2] == pytest.approx(3.5 - 2 * np.pi)
    np.testing.assert_allclose(wrap_angle([np.pi, -np.pi, 7.0]), [-np.pi, -np.pi, 7.0 - 2 * np.pi])


@pytest.mark.parametrize("order", list(ORDERS))
def test_jacobians_equal_finite_differences(order):
    motion = OdometryMotion(0.05, 0.01, gyro_bias=True, scale=True, range_bias=True, dt=0.7, order=order)
    rng = np.random.default_rng(0)
    x = np.column_stack([rng.normal(0, 10, (5, 2)), rng.uniform(-3, 3, 5), rng.normal(0, 0.01, 5),
                         1 + rng.normal(0, 0.05, 5), rng.normal(0, 1, 5)])
    u = np.column_stack([rng.uniform(0, 2, 5), rng.normal(0, 0.2, 5)])
    F = motion.F(x, u, 0)

    def f_unwrapped(xx):                                 # no wrap discontinuity in the differences
        out = motion.f(xx, u, 0)
        out[:, 2] = xx[:, 2] + wrap_angle(out[:, 2] - xx[:, 2])
        return out

    np.testing.assert_allclose(F, _numeric_jacobian(f_unwrapped, x), atol=1e-7)
    steps = (np.array([1e-6, 0.0]), np.array([0.0, 1e-6]))
    diffs = np.stack([motion.f(x, u + e, 0) - motion.f(x, u - e, 0) for e in steps], axis=-1)
    diffs[:, 2] = wrap_angle(diffs[:, 2])
    np.testing.assert_allclose(motion.G(x, u, 0), diffs / 2e-6, atol=1e-7)


def test_process_noise_is_G_sigma_G_plus_random_walks():
    motion = OdometryMotion([0.05, 0.1], [0.01, 0.02], gyro_bias=True, scale=True, range_bias=2, dt=[0.5, 2.0],
                            gyro_bias_walk=1e-3, scale_walk=1e-4, range_bias_walk=0.1)
    x = np.array([[1.0, 2.0, 0.4, 0.001, 1.05, 0.3, -0.2]])
    u = np.array([1.5, 0.1])
    for k in (0, 1):
        G = motion.G(x, u, k)[0]
        want = G @ np.diag([[0.05, 0.1][k] ** 2, [0.01, 0.02][k] ** 2]) @ G.T
        want += np.diag([0, 0, 0, 1e-6, 1e-8, 0.01, 0.01]) * [0.5, 2.0][k]
        np.testing.assert_allclose(motion.Q(x, u, k)[0], want, rtol=1e-12, atol=1e-18)
    f, F, Q = motion.linearize(x, u, 1)
    np.testing.assert_array_equal(f, motion.f(x, u, 1))
    np.testing.assert_array_equal(F, motion.F(x, u, 1))
    np.testing.assert_array_equal(Q, motion.Q(x, u, 1))


def test_batched_equals_single_runs():
    motion = OdometryMotion(0.05, 0.01, gyro_bias=True, scale=True, dt=1.0)
    rng = np.random.default_rng(3)
    x = np.column_stack([rng.normal(0, 5, (4, 2)), rng.uniform(-3, 3, 4), rng.normal(0, 0.01, 4), np.ones(4)])
    u = np.column_stack([rng.uniform(0, 2, 4), rng.normal(0, 0.2, 4)])
    for method in ("f", "F", "Q"):
        batched = getattr(motion, method)(x, u, 0)
        for m in range(4):
            np.testing.assert_allclose(batched[m], getattr(motion, method)(x[m:m + 1], u[m], 0)[0], rtol=1e-14)


def test_integrate_is_dead_reckoning():
    motion = OdometryMotion(0.0, 0.0)
    u = np.tile([[10.0, 0.0], [0.0, np.pi / 2]], (4, 1))
    track = motion.integrate([0.0, 0.0, 0.0], u)
    np.testing.assert_allclose(track[1::2, :2], [[10, 0], [10, 10], [0, 10], [0, 0]], atol=1e-9)
    batch = motion.integrate(np.zeros((3, 3)), np.broadcast_to(u, (3,) + u.shape))
    np.testing.assert_allclose(batch[2], track)


def test_motion_bad_input_named():
    with pytest.raises(ValueError, match="order must be one of"):
        OdometryMotion(0.1, 0.01, order="turn")
    with pytest.raises(ValueError, match="gyro bias is a rate"):
        OdometryMotion(0.1, 0.01, gyro_bias=True)
    with pytest.raises(ValueError, match="scale_walk was given but the state has no scale"):
        OdometryMotion(0.1, 0.01, scale_walk=1e-3)
    with pytest.raises(ValueError, match="sigma_distance must be >= 0"):
        OdometryMotion(-0.1, 0.01)
    with pytest.raises(ValueError, match="disagree on the number of steps K: sigma_distance has 3, times has 4"):
        OdometryMotion(np.ones(3), 0.01, times=np.arange(4.0))
    with pytest.raises(ValueError, match="times must not decrease"):
        OdometryMotion(0.1, 0.01, times=[0.0, 2.0, 1.0])
    with pytest.raises(ValueError, match="give times or dt"):
        OdometryMotion(0.1, 0.01, times=[0.0, 1.0], dt=1.0)
    motion = OdometryMotion(np.ones(3), 0.01)
    with pytest.raises(IndexError, match="step 3 is beyond the 3 steps"):
        motion.f(np.zeros((1, 3)), np.zeros(2), 3)
    with pytest.raises(ValueError, match=r"u must be the odometry of the step, \[distance, heading change\]"):
        motion.f(np.zeros((1, 3)), None, 0)
    with pytest.raises(ValueError, match="last axis of length 2"):
        motion.f(np.zeros((1, 3)), np.zeros(3), 0)


# --- the range model -----------------------------------------------------------------------------------------

@pytest.mark.parametrize("bias", ["none", "shared", "per_beacon"])
def test_beacon_ranges_h_and_jacobian(bias):
    lay = StateLayout.odometry(scale=True, range_bias={"none": 0, "shared": 1, "per_beacon": 4}[bias])
    model = BeaconRanges(BEACONS, R=0.01, layout=lay)
    rng = np.random.default_rng(1)
    x = np.column_stack([rng.uniform(1, 39, (6, 2)), rng.uniform(-3, 3, 6), 1 + rng.normal(0, 0.05, 6),
                         rng.normal(0, 1, (6, lay.n - 4))])
    b = np.array(list(BEACONS.values()))
    dist = np.linalg.norm(x[:, None, :2] - b, axis=-1)
    want = x[:, 3:4] * dist + (0 if bias == "none" else x[:, 4:] if bias == "per_beacon" else x[:, 4:5])
    z, H, defined = model.linearize(x, 0)
    np.testing.assert_allclose(z, want, rtol=1e-14)
    np.testing.assert_allclose(H, _numeric_jacobian(lambda xx: model.h(xx, 0), x), atol=1e-7)
    assert defined.shape == (6, 4) and defined.all() and model.beacon_ids == ("A", "B", "C", "D")


def test_beacon_ranges_by_indices_array_and_single_beacon():
    model = BeaconRanges(np.array([[0.0, 0.0], [3.0, 0.0]]), R=[[1.0, 0.2], [0.2, 2.0]], n=4, scale_index=3,
                         bias_index=2)
    z = model.h(np.array([[0.0, 4.0, 0.5, 2.0]]), 0)
    np.testing.assert_allclose(z, [[8.5, 10.5]])
    assert model.beacon_ids == (0, 1)
    one = BeaconRanges((3.0, 4.0), R=1.0)
    assert one.m == 1 and one.h(np.zeros((1, 2)), 0)[0, 0] == 5.0


def test_on_a_beacon_only_that_component_is_undefined():
    model = BeaconRanges(BEACONS, R=0.01)
    _, H, defined = model.linearize(np.array([[40.0, 0.0]]), 0)
    np.testing.assert_array_equal(defined, [[True, False, True, True]])
    assert np.isfinite(H).all()


def test_per_step_noise():
    R = np.array([[0.1, 0.2, np.nan, 0.4]] * 5)
    model = BeaconRanges(BEACONS, R=R)
    np.testing.assert_array_equal(np.diag(model.R(None, 3)), R[3])
    assert model.n_steps == 5
    shared = BeaconRanges(BEACONS, R=np.arange(1.0, 6.0))
    np.testing.assert_array_equal(shared.R(None, 2), 3.0 * np.eye(4))
    with pytest.raises(IndexError, match="step 5 is beyond them"):
        shared.R(None, 5)


def test_range_model_bad_input_named():
    with pytest.raises(TypeError, match="got a dict of beacons. For ranges to several beacons at once use "
                                        "uwtutor.models.BeaconRanges"):
        from uwtutor.models import RangeToBeacon
        RangeToBeacon(BEACONS, R=1.0)
    with pytest.raises(ValueError, match="beacons must map each beacon id to its position"):
        BeaconRanges({"A": (0.0, 0.0), "B": (1.0, 2.0, 3.0)}, R=1.0)
    with pytest.raises(ValueError, match="empty dict"):
        BeaconRanges({}, R=1.0)
    with pytest.raises(ValueError, match="R must hold variances > 0"):
        BeaconRanges(BEACONS, R=np.array([[0.1, 0.0, 0.1, 0.1]] * 5))
    with pytest.raises(ValueError, match="R must be a variance, a \\(4, 4\\) covariance, or one per step"):
        BeaconRanges(BEACONS, R=np.ones((5, 3)))
    with pytest.raises(ValueError, match="per-step variances of a run of 4 steps"):
        BeaconRanges(BEACONS, R=np.full((4, 4), np.nan))
    with pytest.raises(ValueError, match="one shared by every beacon or one per beacon"):
        BeaconRanges(BEACONS, R=1.0, layout=StateLayout.odometry(range_bias=2))
    with pytest.raises(ValueError, match="give layout or the indices"):
        BeaconRanges(BEACONS, R=1.0, layout=StateLayout.odometry(), n=3)
    with pytest.raises(ValueError, match="scale_index must be a free index"):
        BeaconRanges(BEACONS, R=1.0, n=3, scale_index=3)
    with pytest.raises(TypeError, match="layout must be a uwtutor.models.StateLayout"):
        BeaconRanges(BEACONS, R=1.0, layout=5)


# --- the filter on a simulated log -----------------------------------------------------------------------------

def _filter(log, beacons=BEACONS, z=None, **kw):
    motion = OdometryMotion(0.02, 0.003, gyro_bias=True, scale=True, times=log["t"], gyro_bias_walk=1e-6,
                            scale_walk=1e-6)
    ranges = BeaconRanges(beacons, R=0.05**2, layout=motion.layout)
    x0, P0 = motion.layout.initial_state(log["x0"] + [0.5, -0.5, 0.05], np.diag([1.0, 1.0, 0.01]),
                                         gyro_bias=(0.0, 0.01), scale=(1.0, 0.1))
    res = extended_kalman_filter(motion, ranges, x0, P0, log["u"], log["z"] if z is None else z, times=log["t"],
                                 **kw)
    return motion, x0, res


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_ekf_recovers_the_range_scale_and_the_gyro_bias_within_3_sigma(seed):
    log = simulate_log(np.random.default_rng(seed))
    motion, x0, res = _filter(log)
    sd = np.sqrt(np.diagonal(res.P[-1]))
    assert abs(res.x[-1, 4] - 1.07) < 3 * sd[4] and sd[4] < 1e-3                # the scale
    assert abs(res.x[-1, 3] - 0.004) < 3 * sd[3] and sd[3] < 1e-3               # the gyro bias [rad/s]
    err = np.linalg.norm(res.x[:, :2] - log["truth"][:, :2], axis=-1)
    dead_reckoning = np.linalg.norm(motion.integrate(x0, log["u"])[:, :2] - log["truth"][:, :2], axis=-1)
    assert np.sqrt(np.mean(err[100:] ** 2)) < 0.1 < 5.0 < dead_reckoning[-1]
    e = np.column_stack([log["truth"], np.full(len(err), 0.004), np.full(len(err), 1.07)]) - res.x
    e[:, 2] = wrap_angle(e[:, 2])                                               # a heading error, not 2 pi
    nees = np.einsum("ki,ki->k", e, np.linalg.solve(res.P, e[..., None])[..., 0])
    assert np.mean(nees[100:]) < 2 * 5                                          # consistent (chi2_5 mean 5)


def test_one_beacon_with_a_column_of_ranges():
    """The ranges to one beacon, a (K, 1) column of the table: the filter still finds the scale and the bias."""
    log = simulate_log(np.random.default_rng(5), K=1200)
    motion, x0, res = _filter(log, beacons={"A": BEACONS["A"]}, z=log["z"][:, :1])
    sd = np.sqrt(np.diagonal(res.P[-1]))
    assert abs(res.x[-1, 4] - 1.07) < 3 * sd[4] and abs(res.x[-1, 3] - 0.004) < 3 * sd[3]
    err = np.linalg.norm(res.x[600:, :2] - log["truth"][600:, :2], axis=-1)
    dead_reckoning = np.linalg.norm(motion.integrate(x0, log["u"])[-1, :2] - log["truth"][-1, :2])
    assert np.sqrt(np.mean(err**2)) < 2.0 < 10.0 < dead_reckoning


def test_gated_filter_on_the_log():
    log = simulate_log(np.random.default_rng(5))
    z = log["z"].copy()
    z[200:206, 1] += 8.0                                                        # NLOS on beacon B
    from uwtutor.filters import ChiSquareGate
    _, _, res = _filter(log, z=z, gate=ReacquiringGate(ChiSquareGate(0.999, per_component=True), patience=5))
    assert np.isnan(res.innovations[200:206, 1]).all()                          # the outliers dropped...
    assert np.isfinite(res.innovations[200:206, [0, 2, 3]][np.isfinite(z[200:206, [0, 2, 3]])]).all()   # not the rest
    assert abs(res.x[-1, 4] - 1.07) < 3 * np.sqrt(res.P[-1, 4, 4])
