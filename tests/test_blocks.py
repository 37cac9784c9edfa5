"""The state blocks reproduce the library's hand-assembled models where they describe the same state, and run in the
generic engine unchanged."""

from __future__ import annotations

import functools

import numpy as np
import pytest

from uwtutor.filters import extended_kalman_filter
from uwtutor.models import (BeaconRanges, BiasRateDeadReckoning, BlockMotion, BlockRanges, Current, DeadReckoning,
                            OdometryMotion, OdometryPose, OffsetAndRate, OneWayTravelTimeRanges, Position, RandomWalk,
                            RangeToBeacon, StateLayout, bias_rate_process_noise)


def _states(center, spread, M=6, seed=0):
    rng = np.random.default_rng(seed)
    return np.asarray(center) + np.asarray(spread) * rng.uniform(-1.0, 1.0, (M, len(center)))


def _assert_same(a, b):
    """Equal to within the last bits (the two assemble the same sums, possibly in another order)."""
    a, b = np.broadcast_arrays(np.asarray(a, float), np.asarray(b, float))
    np.testing.assert_allclose(a, b, rtol=1e-14, atol=1e-15)


@pytest.mark.parametrize("order", ["turn-first", "move-first", "midpoint"])
def test_odometry_pose_with_gyro_bias_and_scale_blocks_is_odometry_motion(order):
    times = np.cumsum(np.r_[0.0, np.full(9, 0.5)])
    sd = 0.01 + 0.02 * np.linspace(0.0, 1.0, 10)
    reference = OdometryMotion(sd, 0.003, gyro_bias=True, scale=True, times=times, order=order,
                               gyro_bias_walk=1e-4, scale_walk=1e-5)
    blocks = BlockMotion(OdometryPose(sd, 0.003, order=order, gyro_bias="gyro_bias"),
                         RandomWalk("gyro_bias", 1e-4), RandomWalk("scale", 1e-5), times=times)
    assert blocks.names == reference.layout.names
    x = _states([20.0, 5.0, 3.0, 0.004, 1.05], [10.0, 10.0, 0.3, 0.002, 0.02])
    for k in (0, 3, 9):
        u = np.array([0.5 + 0.1 * k, 0.06 - 0.01 * k])
        for got, want in zip(blocks.linearize(x, u, k), reference.linearize(x, u, k)):
            _assert_same(got, want)
        _assert_same(blocks.difference(x, x[::-1]), reference.difference(x, x[::-1]))


def test_position_and_offset_rate_blocks_are_bias_rate_dead_reckoning():
    reference = BiasRateDeadReckoning(bias_rate_process_noise(0.5, 0.3, rate_sigma=0.01, dt=5.0), dt=5.0)
    blocks = BlockMotion(Position(np.diag([0.25, 0.09])), OffsetAndRate("bias", rate_walk=0.01), dt=5.0)
    x = _states([50.0, -20.0, 5.0, 0.1], [20.0, 20.0, 2.0, 0.05])
    u = np.array([1.0, 2.0])
    for got, want in zip(blocks.linearize(x, u, 2), reference.linearize(x, u, 2)):
        _assert_same(got, want)


def test_position_and_random_walk_blocks_are_dead_reckoning_and_ranges_read_by_name():
    reference = DeadReckoning(np.diag([0.25, 0.25, 0.01]))
    blocks = BlockMotion(Position(np.eye(2) * 0.25), RandomWalk("range_bias", 0.1))
    x = _states([100.0, 0.0, 3.0], [20.0, 20.0, 1.0])
    u = np.array([2.0, 1.0])
    for got, want in zip(blocks.linearize(x, u, 0), reference.linearize(x, u, 0)):
        _assert_same(got, want)
    got, want = BlockRanges([(5.0, 1.0)], 4.0, blocks, bias="range_bias"), RangeToBeacon((5.0, 1.0), 4.0, n=3,
                                                                                          bias_index=2)
    for a, b in zip(got.linearize(x, 0), want.linearize(x, 0)):
        _assert_same(a, b)


def test_block_ranges_are_beacon_ranges_wherever_the_slots_sit():
    beacons = {1: (0.0, 0.0), 2: (40.0, 0.0), 3: (40.0, 30.0)}
    layout = StateLayout.odometry(scale=True, range_bias=3)
    reference = BeaconRanges(beacons, R=0.01, layout=layout)
    same = BlockMotion(OdometryPose(0.1, 0.01), RandomWalk("scale"), RandomWalk("bias", size=3))
    x = _states([13.0, 14.0, 0.3, 1.07, 0.5, -0.2, 0.1], [5.0, 5.0, 0.5, 0.02, 0.3, 0.3, 0.3])
    ranges = BlockRanges(beacons, 0.01, same, scale="scale", bias="bias")
    for a, b in zip(ranges.linearize(x, 0), reference.linearize(x, 0)):
        _assert_same(a, b)
    _assert_same(ranges.R(x, 0), reference.R(x, 0))
    # the blocks in another order: the model finds its slots by name, the prediction is the same
    moved = BlockMotion(RandomWalk("bias", size=3), RandomWalk("scale"), OdometryPose(0.1, 0.01))
    perm = np.r_[4:7, 3, 0:3]
    z, H, _ = BlockRanges(beacons, 0.01, moved, scale="scale", bias="bias").linearize(x[:, perm], 0)
    _assert_same(z, reference.h(x, 0))
    _assert_same(H, reference.H(x, 0)[..., perm])


def test_position_drifts_with_the_current_it_reads():
    motion = BlockMotion(Position(np.eye(2) * 0.01, current="current"), Current(walk=0.001), dt=10.0)
    f, F, Q = motion.linearize(np.array([[0.0, 0.0, 0.1, -0.2]]), np.array([1.0, 1.0]), 0)
    _assert_same(f, [[2.0, -1.0, 0.1, -0.2]])
    assert F.shape == Q.shape == (4, 4)           # shared by every run: no block depends on the state
    _assert_same(F[:2, 2:], 10.0 * np.eye(2))
    _assert_same(Q, np.diag([0.01, 0.01, 1e-5, 1e-5]))


def test_a_clock_block_and_owtt_ranges_run_in_the_engine_and_find_the_drift():
    # a vehicle on a 200 m line ranging every 10 s to two beacons with a clock that gains 20 us/s: the filter
    # with the clock block recovers the drift; the same engine, no new loop
    rng = np.random.default_rng(3)
    K, dt, c = 200, 10.0, 1500.0
    truth = np.column_stack([np.linspace(0.0, 200.0, K), np.full(K, 50.0)])
    u = np.diff(truth, axis=0, prepend=truth[:1])
    motion = BlockMotion(Position(np.eye(2) * 0.01), OffsetAndRate("clock", rate_walk=1e-9), dt=dt)
    beacons = np.array([[0.0, 0.0], [300.0, 0.0]])
    offset = 20e-6 * dt * np.arange(K)
    z = np.linalg.norm(truth[:, None] - beacons, axis=-1) + c * offset[:, None] + rng.normal(0.0, 0.5, (K, 2))
    ranges = OneWayTravelTimeRanges(beacons, 0.25, motion, sound_speed=c)
    x0, P0 = motion.initial_state(position=(truth[0], 5.0), clock=([0.0, 0.0], [1e-3, 1e-4]))
    result = extended_kalman_filter(motion, ranges, x0, P0, u, z)
    assert abs(result.x[-1, 3] - 20e-6) < 0.5e-6
    assert np.linalg.norm(result.x[-1, :2] - truth[-1]) < 2.0


def test_bad_block_states_get_errors_that_name_the_slot():
    with pytest.raises(ValueError, match="reads the slot 'gyro_bias'"):
        BlockMotion(OdometryPose(0.1, 0.01, gyro_bias="gyro_bias"), dt=1.0)
    with pytest.raises(ValueError, match="rate"):
        BlockMotion(Position(np.eye(2)), OffsetAndRate("clock", 1e-8))
    with pytest.raises(ValueError, match="both called 'scale'"):
        BlockMotion(RandomWalk("scale"), RandomWalk("scale"))
    motion = BlockMotion(Position(np.eye(2)))
    with pytest.raises(ValueError, match="'clock'"):
        OneWayTravelTimeRanges([[0.0, 0.0]], 1.0, motion)
    with pytest.raises(ValueError, match="missing"):
        BlockMotion(Position(np.eye(2)), RandomWalk("scale")).initial_state(position=(0.0, 1.0))


def test_owtt_ranges_are_scaled_ranges_plus_the_clock_offset_times_the_sound_speed():
    state = BlockMotion(OdometryPose(0.1, 0.01), RandomWalk("scale"), OffsetAndRate("clock", 1e-8), dt=1.0)
    beacons = [(0.0, 0.0), (40.0, 0.0)]
    x = _states([13.0, 14.0, 0.3, 1.07, 2e-3, 2e-5], [5.0, 5.0, 0.5, 0.02, 1e-3, 1e-5])
    owtt = OneWayTravelTimeRanges(beacons, 0.25, state, sound_speed=1480.0, scale="scale")
    plain = BlockRanges(beacons, 0.25, state, scale="scale")
    z, H, _ = owtt.linearize(x, 0)
    z0, H0, _ = plain.linearize(x, 0)
    _assert_same(z, z0 + 1480.0 * x[:, 4:5])
    H0[..., 4] = 1480.0
    _assert_same(H, H0)


def test_the_posterior_bound_runs_on_blocks_and_the_ekf_covariance_meets_it():
    # the OWTT line of the engine test, noise free: the EKF linearised at its estimates, the bound at the truth;
    # near-linear, so the two covariances agree closely, and neither needs anything block-specific
    from uwtutor.observability import model_posterior_crlb

    K, dt, c = 200, 10.0, 1500.0
    track = np.column_stack([np.linspace(0.0, 200.0, K), np.full(K, 50.0)])
    u = np.diff(track, axis=0, prepend=track[:1])
    motion = BlockMotion(Position(np.eye(2) * 0.01), OffsetAndRate("clock", rate_walk=1e-9), dt=dt)
    ranges = OneWayTravelTimeRanges([[0.0, 0.0], [300.0, 0.0]], 0.25, motion, sound_speed=c)
    truth = np.column_stack([track, 20e-6 * dt * np.arange(K), np.full(K, 20e-6)])
    x0, P0 = motion.initial_state(position=(track[0], 5.0), clock=([0.0, 0.0], [1e-3, 1e-4]))
    bound = model_posterior_crlb(motion, ranges, x0, P0, truth, u, full=True)
    z = np.stack([ranges.h(truth[k][None], k)[0] for k in range(K)])
    result = extended_kalman_filter(motion, ranges, x0, P0, u, z)
    np.testing.assert_allclose(np.sqrt(np.diagonal(result.P[-1])), np.sqrt(np.diagonal(bound[-1])), rtol=0.05)


def test_a_block_state_runs_in_the_particle_filter_unchanged():
    from uwtutor.filters import BootstrapParticleFilter

    K = 60
    track = np.column_stack([np.linspace(0.0, 60.0, K), np.zeros(K)])
    odometry = np.column_stack([np.r_[0.0, np.full(K - 1, 60.0 / (K - 1))], np.zeros(K)])
    motion = BlockMotion(OdometryPose(0.01, 1e-3), RandomWalk("scale", 1e-5), dt=1.0)
    ranges = BlockRanges([[30.0, 40.0], [0.0, 30.0]], 0.04, motion, scale="scale")
    z = 1.03 * np.linalg.norm(track[:, None] - np.array([[30.0, 40.0], [0.0, 30.0]]), axis=-1)
    x0, P0 = motion.initial_state(pose=([0.0, 0.0, 0.0], [0.5, 0.5, 0.01]), scale=(1.0, 0.05))
    pf = BootstrapParticleFilter.from_gaussian(motion, ranges, x0, P0, 2000, np.random.default_rng(0))
    result = pf.run(z, odometry)
    assert abs(result.x[-1, 3] - 1.03) < 0.01
    assert np.linalg.norm(result.x[-1, :2] - track[-1]) < 1.0


# -- the library's odometry models are built from these blocks: the fused path is the block-by-block path --

@functools.lru_cache(maxsize=1)
def _odometry_runs():
    """The odometry model pair on the real logs and on the square log (navigate's states, plain, with range
    biases); each with the EKF's estimates to linearize at."""
    return list(_odometry_variants())


def _odometry_variants():
    from uwtutor.datasets import navigation_models, square_log

    logs = [square_log(1.05, 0.3)]
    try:
        pytest.importorskip("gtsam")
        from uwtutor.datasets import plaza

        logs += [plaza(1), plaza(2)]
    except pytest.skip.Exception:
        pass
    for data in logs:
        nav = navigation_models(data)
        for gyro_bias, scale, range_bias in [(True, True, False), (False, False, True), (True, True, nav.z.shape[1])]:
            motion = OdometryMotion(nav.motion.sigma_distance, nav.motion.sigma_heading, gyro_bias=gyro_bias,
                                    scale=scale, range_bias=range_bias, times=nav.times, order=nav.motion.order,
                                    gyro_bias_walk=1e-4 if gyro_bias else 0.0, scale_walk=1e-5 if scale else 0.0,
                                    range_bias_walk=1e-3 if range_bias else 0.0)
            extra = {name: pair for name, pair, on in [("gyro_bias", (0.0, 0.01), gyro_bias),
                                                       ("scale", (1.0, 0.1), scale),
                                                       ("range_bias", (0.0, 1.0), range_bias)] if on}
            x0, P0 = motion.layout.initial_state(data.start, data.start_cov, **extra)
            ranges = BeaconRanges(nav.measurement.beacons, R=0.36, layout=motion.layout)
            x = extended_kalman_filter(motion, ranges, x0, P0, nav.u, nav.z, times=nav.times).x
            yield motion, ranges, nav, x


def test_odometry_motion_is_a_block_motion_and_its_fused_path_is_the_blocks_bit_for_bit():
    runs = 0
    for motion, _, nav, x in _odometry_runs():
        assert isinstance(motion, BlockMotion) and isinstance(motion.blocks[0], OdometryPose)
        assert all(isinstance(b, RandomWalk) for b in motion.blocks[1:])
        assert motion.names == motion.layout.names
        for slot in motion.layout.slots:
            np.testing.assert_array_equal(motion.slot(slot), motion.layout.slot(slot))
        general = BlockMotion(*motion.blocks, times=nav.times)          # the same blocks, assembled block by block
        for k in range(1, len(x), 1 if len(x) < 100 else 11):          # every step of the square, a sample of the logs'
            for fused, blockwise in zip(motion.linearize(x[k - 1:k], nav.u[k], k),
                                        general.linearize(x[k - 1:k], nav.u[k], k)):
                np.testing.assert_array_equal(fused, blockwise)
        particles = np.tile(x[len(x) // 2], (2, 50, 1))
        k = len(x) // 2 + 1
        draws = [model.sample(particles, nav.u[k], k, [np.random.default_rng(i) for i in (1, 2)])
                 for model in (motion, general)]
        np.testing.assert_array_equal(*draws)
        runs += 1
    assert runs >= 3


def test_beacon_ranges_are_block_ranges_reading_the_layout_bit_for_bit():
    for motion, ranges, _, x in _odometry_runs():
        assert isinstance(ranges, BlockRanges)
        scale, bias = ("scale" if motion.layout.scale is not None else None,
                       "range_bias" if motion.layout.range_bias else None)
        by_name = BlockRanges(ranges.beacons, 0.36, motion, scale=scale, bias=bias)
        for k in range(0, len(x), 7):
            for a, b in zip(ranges.linearize(x[k:k + 1], k), by_name.linearize(x[k:k + 1], k)):
                np.testing.assert_array_equal(a, b)
            np.testing.assert_array_equal(ranges.h(x[k:k + 1], k), by_name.h(x[k:k + 1], k))


def test_the_bias_rate_model_and_the_owtt_ranges_are_block_models():
    from uwtutor.models.base import MotionModel

    Q = bias_rate_process_noise(0.5, 0.3, rate_sigma=0.01, dt=5.0)
    Q[0, 2] = Q[2, 0] = 0.01                                # a noise that correlates the blocks stays whole
    model = BiasRateDeadReckoning(Q, dt=5.0)
    blocks = BlockMotion(Position(Q[:2, :2]), OffsetAndRate("bias", rate_walk=0.0), dt=5.0)
    assert isinstance(model, BlockMotion) and model.names == blocks.names == ("x", "y", "bias_offset", "bias_rate")
    np.testing.assert_array_equal(model.slot("bias"), [2, 3])
    x = _states([50.0, -20.0, 5.0, 0.1], [20.0, 20.0, 2.0, 0.05])
    u = np.array([1.0, 2.0])
    for got, want in zip(model.linearize(x, u, 2)[:2], blocks.linearize(x, u, 2)[:2]):
        np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(model.Q(x, u, 2), Q)
    assert type(model).difference is MotionModel.difference       # no angle: a particle filter's plain mean
    state = BlockMotion(Position(np.eye(2)), OffsetAndRate("clock", 1e-8), dt=1.0)
    owtt = OneWayTravelTimeRanges([(0.0, 0.0), (40.0, 0.0)], 0.25, state, sound_speed=1480.0)
    assert isinstance(owtt, BlockRanges) and owtt.reads == ("position", "clock")
