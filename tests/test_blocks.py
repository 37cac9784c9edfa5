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


# -- paper A's pair in the block vocabulary: DeadReckoning is a BlockMotion, RangeToBeacon a BlockMeasurement --

def _psd(rng, n, K=None):
    """A random PSD matrix (n, n), or one per step (K, n, n): correlated everywhere, position and further alike."""
    A = rng.normal(size=(() if K is None else (K,)) + (n, n))
    return A @ np.swapaxes(A, -1, -2)


def _dead_reckoning_reference(Q):
    """DeadReckoning's arithmetic before it was built from blocks: f moves x[..., :2], F = I, Q given whole."""
    def f(x, u, k):
        out = x.copy()
        if u is not None:
            out[..., :2] += np.asarray(u, dtype=float)
        return out

    def Qk(k):
        return Q if Q.ndim == 2 else Q[k]
    return f, Qk


@pytest.mark.parametrize("n", [2, 3, 5])
@pytest.mark.parametrize("per_step", [False, True], ids=["one-Q", "per-step-Q"])
def test_dead_reckoning_is_a_block_motion_with_its_arithmetic_bit_for_bit(n, per_step):
    from uwtutor.models.noise import gaussian_noise, psd_sqrt

    rng = np.random.default_rng(n + 10 * per_step)
    K = 5
    Q = _psd(rng, n, K if per_step else None)
    motion = DeadReckoning(Q)
    assert isinstance(motion, BlockMotion) and motion.n == n and motion.n_steps == (K if per_step else None)
    np.testing.assert_array_equal(motion.slot("position"), [0, 1])
    assert motion.names == ("x", "y") + tuple(f"state_{i}" for i in range(2, n))
    f_ref, Q_ref = _dead_reckoning_reference(Q)
    for shape in ((4, n), (3, 6, n)):                           # runs (M, n) and particles (M, N, n)
        x = rng.normal(size=shape) * 50.0
        per_run = rng.normal(size=(shape[0], 2) if len(shape) == 2 else (shape[0], 1, 2))
        for u in (None, rng.normal(size=2), per_run):
            for k in (0, K - 1):
                f, F, Qk = motion.linearize(x, u, k)
                assert np.array_equal(f, f_ref(x, u, k)) and np.array_equal(motion.f(x, u, k), f)
                assert np.array_equal(F, np.eye(n)) and np.array_equal(motion.F(x, u, k), F)
                assert np.array_equal(Qk, Q_ref(k)) and np.array_equal(motion.Q(x, u, k), Qk)
                if len(shape) == 3:
                    draw = motion.sample(x, u, k, [np.random.default_rng(i) for i in range(shape[0])])
                    want = f_ref(x, u, k) + gaussian_noise(psd_sqrt(Q_ref(k)), [np.random.default_rng(i)
                                                                                 for i in range(shape[0])], x.shape)
                    assert np.array_equal(draw, want)
    if per_step:
        with pytest.raises(IndexError, match="beyond"):
            motion.Q(None, None, K)


@pytest.mark.parametrize("per_step", [False, True], ids=["one-Q", "per-step-Q"])
def test_dead_reckoning_blocks_assembled_one_by_one_are_the_model_when_q_has_no_cross_terms(per_step):
    """The blocks say what the model does: a Position with Q's top-left block and a RandomWalk per named slot with
    its own diagonal block. Without cross terms in Q, the block-by-block assembly is the model, bit for bit."""
    rng = np.random.default_rng(4)
    K = 4
    Q = np.zeros((K, 5, 5)) if per_step else np.zeros((5, 5))
    Q[..., :2, :2] = _psd(rng, 2, K if per_step else None)
    Q[..., 2:4, 2:4] = _psd(rng, 2, K if per_step else None)
    Q[..., 4, 4] = 0.01
    motion = DeadReckoning(Q, names={"current": 2, "range_bias": 1})
    assert [type(b) for b in motion.blocks] == [Position, RandomWalk, RandomWalk]
    assert motion.names == ("x", "y", "current_0", "current_1", "range_bias")
    np.testing.assert_array_equal(motion.slot("current"), [2, 3])
    np.testing.assert_array_equal(motion.slot("range_bias"), [4])
    blockwise = BlockMotion(*motion.blocks)
    x = rng.normal(size=(3, 5))
    u = rng.normal(size=2)
    for k in range(K):
        for got, want in zip(motion.linearize(x, u, k), blockwise.linearize(x, u, k)):
            np.testing.assert_array_equal(got, want)


def _range_reference(beacon, n, bias_index):
    """RangeToBeacon's arithmetic before it read slots: the position x[..., :2], the bias x[..., bias_index]."""
    from uwtutor._linalg import distances, line_of_sight

    def at(x, k):
        b = beacon if beacon.ndim == 1 else beacon[k] if beacon.ndim == 2 else beacon[:, k]
        return b[:, None, :] if b.ndim == 2 and x.ndim == 3 else b

    def linearize(x, k):
        r, los, defined = line_of_sight(x[..., :2], at(x, k))
        H = np.zeros(x.shape[:-1] + (1, n))
        H[..., 0, :2] = los
        z = r[..., None]
        if bias_index is not None:
            H[..., 0, bias_index] = 1.0
            z = z + x[..., bias_index:bias_index + 1]
        return z, H, defined

    def h(x, k):
        z = distances(x[..., :2], at(x, k))[..., None]
        return z if bias_index is None else z + x[..., bias_index:bias_index + 1]
    return h, linearize


@pytest.mark.parametrize("beacon_kind", ["fixed", "path", "per-run"])
@pytest.mark.parametrize("n, bias_index", [(2, None), (3, 2), (5, 3)])
def test_range_to_beacon_reads_slots_with_its_arithmetic_bit_for_bit(beacon_kind, n, bias_index):
    rng = np.random.default_rng(n)
    K, M = 6, 4
    beacon = {"fixed": rng.normal(size=2), "path": rng.normal(size=(K, 2)),
              "per-run": rng.normal(size=(M, K, 2))}[beacon_kind] * 30.0
    R = np.abs(rng.normal(size=K)) + 0.1
    by_index = RangeToBeacon(beacon, R, n=n, bias_index=bias_index)
    names = tuple(f"state_{i}" for i in range(2, n))
    state = DeadReckoning(np.eye(n), names=tuple("range_bias" if i == bias_index else name
                                                  for i, name in enumerate(names, start=2)))
    by_name = RangeToBeacon(beacon, R, state=state, bias=None if bias_index is None else "range_bias")
    h_ref, linearize_ref = _range_reference(beacon, n, bias_index)
    for model in (by_index, by_name):
        assert model.n == n and model.bias_index == bias_index
        np.testing.assert_array_equal(model.columns["position"], [0, 1])
        for shape in ((M, n), (M, 7, n)):
            x = rng.normal(size=shape) * 50.0
            for k in (0, K - 1):
                assert np.array_equal(model.h(x, k), h_ref(x, k))
                for got, want in zip(model.linearize(x, k), linearize_ref(x, k)):
                    assert np.array_equal(got, want)
                assert np.array_equal(model.H(x, k), linearize_ref(x, k)[1])
                assert np.array_equal(model.R(x, k), [[R[k]]])
        if beacon_kind == "per-run":
            np.testing.assert_array_equal(model.select_runs([1, 3]).beacon, beacon[[1, 3]])
            np.testing.assert_array_equal(model.beacon_at(2), beacon[:, 2])


def test_multiplicative_range_keeps_its_arithmetic_on_the_position_slot():
    from uwtutor._linalg import line_of_sight
    from uwtutor.models import MultiplicativeRange

    rng = np.random.default_rng(1)
    ship = rng.normal(size=(5, 2)) * 30.0
    model = MultiplicativeRange(ship, 0.49, mu_gamma=0.98, sigma_gamma=0.01, n=3)
    x = rng.normal(size=(4, 3)) * 50.0
    r, los, _ = line_of_sight(x[..., :2], ship[2])
    assert np.array_equal(model.h(x, 2), 0.98 * r[:, None])
    assert np.array_equal(model.H(x, 2)[:, 0, :2], 0.98 * los)
    assert np.array_equal(model.R(x, 2), (0.01**2 * r**2 + 0.49)[:, None, None])


def test_the_plain_range_pair_by_name_still_runs_on_the_packed_back_end():
    """The engine's fast path dispatches on the model types: the pair read by name is the same pair, so it runs
    the packed 2x2 kernel and gives range_only_ekf's bits; a bias sends it to the generic engine."""
    from uwtutor.filters import ExtendedKalmanFilter, range_only_ekf

    rng = np.random.default_rng(2)
    K = 30
    track = np.column_stack([np.linspace(0.0, 300.0, K), np.full(K, 80.0)])
    u = np.diff(track, axis=0, prepend=track[:1]) + rng.normal(0.0, 0.5, (K, 2))
    z = np.linalg.norm(track - [10.0, -5.0], axis=1) + rng.normal(0.0, 2.0, K)
    Q = np.eye(2) * 0.25
    motion = DeadReckoning(Q)
    for measurement in (RangeToBeacon((10.0, -5.0), 4.0), RangeToBeacon((10.0, -5.0), 4.0, state=motion)):
        filt = ExtendedKalmanFilter(motion, measurement, track[0], np.eye(2) * 100.0)
        assert filt._packed_kernel()
        engine = extended_kalman_filter(motion, measurement, track[0], np.eye(2) * 100.0, u, z)
        fast = range_only_ekf(track[0], np.eye(2) * 100.0, u, z, Q, 4.0, beacon=(10.0, -5.0))
        for field in ("x", "P", "x_prior", "P_prior", "innovations", "innovation_cov"):
            assert np.array_equal(getattr(engine, field), getattr(fast, field), equal_nan=True), field
    biased = DeadReckoning(np.diag([0.25, 0.25, 0.01]), names=("range_bias",))
    filt = ExtendedKalmanFilter(biased, RangeToBeacon((10.0, -5.0), 4.0, state=biased, bias="range_bias"),
                                np.r_[track[0], 0.0], np.eye(3) * 100.0)
    assert not filt._packed_kernel()


def test_paper_a_pair_by_name_is_the_pair_by_index_in_the_filter():
    rng = np.random.default_rng(5)
    K = 40
    track = np.column_stack([np.linspace(0.0, 400.0, K), np.full(K, 60.0)])
    u = np.diff(track, axis=0, prepend=track[:1]) + rng.normal(0.0, 0.5, (K, 2))
    z = np.linalg.norm(track, axis=1) + 3.0 + rng.normal(0.0, 2.0, K)
    Q = np.diag([0.25, 0.25, 0.01])
    x0, P0 = np.r_[track[0], 0.0], np.diag([100.0, 100.0, 25.0])
    by_index = extended_kalman_filter(DeadReckoning(Q), RangeToBeacon((0.0, 0.0), 4.0, n=3, bias_index=2),
                                      x0, P0, u, z)
    motion = DeadReckoning(Q, names=("range_bias",))
    by_name = extended_kalman_filter(motion, RangeToBeacon((0.0, 0.0), 4.0, state=motion, bias="range_bias"),
                                     x0, P0, u, z)
    for field in ("x", "P", "innovations", "innovation_cov"):
        assert np.array_equal(getattr(by_index, field), getattr(by_name, field)), field


def test_dead_reckoning_and_range_names_get_clear_errors():
    Q3 = np.diag([0.25, 0.25, 0.01])
    with pytest.raises(ValueError, match="names must name the 1 components"):
        DeadReckoning(Q3, names=("range_bias", "clock"))
    with pytest.raises(ValueError, match="twice"):
        DeadReckoning(np.eye(4), names=("bias", "bias"))
    with pytest.raises(ValueError, match="slot name"):
        DeadReckoning(Q3, names=("range bias",))
    with pytest.raises(TypeError, match="sequence of slot names"):
        DeadReckoning(Q3, names="range_bias")
    with pytest.raises(ValueError, match="'position' is the slot of x and y"):
        DeadReckoning(Q3, names=("position",))
    motion = DeadReckoning(Q3, names=("range_bias",))
    with pytest.raises(ValueError, match="not both"):
        RangeToBeacon((0.0, 0.0), 4.0, state=motion, n=3)
    with pytest.raises(ValueError, match="state="):
        RangeToBeacon((0.0, 0.0), 4.0, bias="range_bias")
    with pytest.raises(ValueError, match="'clock'"):
        RangeToBeacon((0.0, 0.0), 4.0, state=motion, bias="clock")
    with pytest.raises(ValueError, match="1 component"):
        RangeToBeacon((0.0, 0.0), 4.0, state=DeadReckoning(np.eye(4), names={"bias": 2}), bias="bias")
    with pytest.raises(ValueError, match="x before y"):
        RangeToBeacon((0.0, 0.0), 4.0, state=motion, position="range_bias")
    with pytest.raises(ValueError, match="bias_index must index the state"):
        RangeToBeacon((0.0, 0.0), 4.0, n=3, bias_index=3)


def test_per_step_blocks_say_how_many_steps_they_cover():
    Qs = np.tile(np.eye(2), (3, 1, 1))
    motion = BlockMotion(Position(Qs), RandomWalk("bias", Q=np.full((3, 1, 1), 0.5)))
    assert motion.n_steps == 3
    np.testing.assert_array_equal(motion.Q(np.zeros((1, 3)), None, 2), np.diag([1.0, 1.0, 0.5]))
    with pytest.raises(IndexError, match="beyond"):
        motion.Q(np.zeros((1, 3)), None, 3)
    with pytest.raises(ValueError, match="disagree"):
        BlockMotion(Position(Qs), RandomWalk("bias", Q=np.full((4, 1, 1), 0.5)))
    with pytest.raises(ValueError, match="not both"):
        RandomWalk("bias", walk=0.1, Q=[[0.5]])


def test_a_layout_and_a_dead_reckoning_named_alike_have_the_same_slots():
    """StateLayout is the index form of the state a motion model names: the same slots at the same indices."""
    for layout, names in [(StateLayout.position(range_bias=True), ("range_bias",)),
                          (StateLayout.position(scale=True, range_bias=2), {"scale": 1, "range_bias": 2})]:
        motion = DeadReckoning(np.eye(layout.n), names=names)
        assert motion.slots == layout.slots and motion.names == layout.names
        for slot in layout.slots:
            np.testing.assert_array_equal(motion.slot(slot), layout.slot(slot))
        x = np.random.default_rng(0).normal(size=(3, layout.n)) * 40.0
        by_layout = RangeToBeacon((5.0, 1.0), 4.0, state=layout, bias="range_bias" if len(layout.range_bias) == 1
                                  else None)
        by_motion = RangeToBeacon((5.0, 1.0), 4.0, state=motion, bias="range_bias" if len(layout.range_bias) == 1
                                  else None)
        for a, b in zip(by_layout.linearize(x, 0), by_motion.linearize(x, 0)):
            np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("blocks", [
    lambda: (Position(np.diag([0.3, 0.2])), RandomWalk("scale", walk=1e-3)),
    lambda: (Position(np.diag([0.3, 0.2]), current="current"), Current(walk=1e-3)),
    lambda: (Position(np.eye(2)), OffsetAndRate("clock", rate_walk=1e-7), RandomWalk("bias", walk=0.1, size=2)),
], ids=["walk", "current", "clock"])
def test_constant_path_of_linear_blocks_is_the_assembly_to_rounding(blocks):
    """A stack of linear blocks over steps of one length predicts with F and Q assembled once (x F^T + u): the same
    as the block-by-block assembly, to rounding (the product sums a row in another order than a block's own f)."""
    motion = BlockMotion(*blocks(), dt=2.0)
    assert motion._constant is not None
    rng = np.random.default_rng(5)
    x = rng.normal(size=(7, motion.n)) * 50.0
    u = rng.normal(size=(7, 2))
    for k in (0, 3):
        for fast, slow in zip(motion.linearize(x, u, k), motion._assemble(x, u, k)):
            np.testing.assert_allclose(fast, slow, rtol=1e-13, atol=1e-12)
