"""The generic batched EKF: filterpy step by step (2-, 3- and 4-state models, fixed and moving beacon),
batched == single, NaN = predict only, the gate hook, and bad input."""

import copy
import warnings

import numpy as np
import pytest
from filterpy.kalman import ExtendedKalmanFilter as FilterpyEKF

from uwtutor.errors import BeaconSingularityWarning, IllConditionedError, UwtutorWarning
from uwtutor.filters import (ChiSquareGate, ExtendedKalmanFilter, Gate, KalmanFilter, extended_kalman_filter,
                             range_only_ekf, run_filter)
from uwtutor.models import (DeadReckoning, DirectMeasurement, LinearMeasurement, LinearMotion, MeasurementModel,
                            RangeToBeacon)

TOL = dict(rtol=1e-9, atol=1e-9)
DT = 8.0


def current_motion(q_pos=1.0, q_cur=1e-4):
    """State [x, y, Ux, Uy]: the DR displacement plus dt times an unknown constant current."""
    F = np.eye(4)
    F[0, 2] = F[1, 3] = DT
    B = np.vstack([np.eye(2), np.zeros((2, 2))])
    return LinearMotion(F, np.diag([q_pos, q_pos, q_cur, q_cur]), B)


def study(n, M=5, K=80, seed=3, moving=False, missing=0.2):
    """Inputs for an n-state model (2: position; 3: + range bias; 4: + current) around a fixed or moving beacon."""
    rng = np.random.default_rng(seed)
    theta = np.linspace(0.0, 2.5 * np.pi, K + 1)
    track = 400.0 * np.column_stack([np.cos(theta), np.sin(theta)]) + [100.0, -50.0]
    u = np.diff(track, axis=0)
    beacon = (np.column_stack([np.linspace(0.0, 600.0, K), 200.0 * np.sin(np.linspace(0, 3, K))])
              if moving else np.array([0.0, 0.0]))
    bpath = beacon if moving else np.broadcast_to(beacon, (K, 2))
    z = np.linalg.norm(track[1:] - bpath, axis=-1) + rng.normal(0.0, 3.0, (M, K)) + (5.0 if n == 3 else 0.0)
    z[rng.random((M, K)) < missing] = np.nan
    x0 = np.zeros((M, n))
    x0[:, :2] = track[0] + rng.normal(0.0, 30.0, (M, 2))
    P0 = np.diag([900.0, 900.0] + [25.0] * (n - 2))
    if n == 2:
        motion = DeadReckoning(np.eye(2) * 0.5)
    elif n == 3:
        motion = DeadReckoning(np.diag([0.5, 0.5, 0.01]))
    else:
        motion = current_motion()
    meas = RangeToBeacon(beacon, R=9.0, n=n, bias_index=2 if n == 3 else None)
    return motion, meas, x0, P0, u, z


def filterpy_run(motion, meas, x0, P0, u, z):
    """filterpy's ExtendedKalmanFilter stepped in a Python loop over one run, with our models' matrices."""
    n = motion.n
    f = FilterpyEKF(dim_x=n, dim_z=1, dim_u=2)
    f.x = np.array(x0, float).reshape(n, 1)
    f.P = np.array(P0, float)
    f.F = np.asarray(motion.F(f.x.T, None, 0), float)
    f.B = np.vstack([np.eye(2), np.zeros((n - 2, 2))])
    f.Q = np.asarray(motion.Q(f.x.T, None, 0), float)
    f.R = np.asarray(meas.R(None, 0), float)
    out = {key: [] for key in ("x", "P", "x_prior", "P_prior")}
    for k, (uk, zk) in enumerate(zip(u, z)):
        f.predict(u=np.asarray(uk).reshape(2, 1))
        out["x_prior"].append(f.x[:, 0].copy())
        out["P_prior"].append(f.P.copy())
        if np.isfinite(zk):
            f.update(np.array([[zk]]), HJacobian=lambda x, k=k: meas.H(x.T, k)[0],
                     Hx=lambda x, k=k: meas.h(x.T, k)[0].reshape(1, 1))
        out["x"].append(f.x[:, 0].copy())
        out["P"].append(f.P.copy())
    return {key: np.array(v) for key, v in out.items()}


@pytest.mark.parametrize("n", [2, 3, 4])
@pytest.mark.parametrize("moving", [False, True], ids=["fixed-beacon", "moving-beacon"])
def test_equals_filterpy_step_by_step(n, moving):
    motion, meas, x0, P0, u, z = study(n, moving=moving)
    res = extended_kalman_filter(motion, meas, x0, P0, u, z)
    for m in range(x0.shape[0]):
        ref = filterpy_run(motion, meas, x0[m], P0, u, z[m])
        for key in ("x", "P", "x_prior", "P_prior"):
            np.testing.assert_allclose(getattr(res, key)[m], ref[key], **TOL, err_msg=f"{key}, run {m}")


def test_linear_model_pair_equals_kalman_filter():
    rng = np.random.default_rng(5)
    F = np.array([[1.0, 1.0], [0.0, 1.0]])
    Q = np.diag([0.01, 0.04])
    H = np.array([[1.0, 0.0]])
    z = np.cumsum(rng.normal(0.0, 1.0, (4, 60)), axis=1)
    z[:, ::9] = np.nan
    kf = KalmanFilter(F=F, H=H, Q=Q, R=2.0, x0=np.zeros((4, 2)), P0=np.eye(2) * 10.0).run(z)
    gen = extended_kalman_filter(LinearMotion(F, Q), LinearMeasurement(H, 2.0), np.zeros(2), np.eye(2) * 10.0,
                                 None, z)
    for key in ("x", "P", "x_prior", "P_prior", "innovations", "innovation_cov"):
        np.testing.assert_allclose(getattr(gen, key), getattr(kf, key), **TOL)


def test_equals_the_packed_range_only_ekf_with_a_moving_beacon():
    motion, meas, x0, P0, u, z = study(2, moving=True)
    gen = extended_kalman_filter(motion, meas, x0, P0, u, z)
    fast = range_only_ekf(x0, P0, u, z, Q=motion.Q(None, None, 0), R=9.0, beacon=meas.beacon)
    for key in ("x", "P", "x_prior", "P_prior", "innovations", "innovation_cov"):
        np.testing.assert_allclose(getattr(fast, key), getattr(gen, key), **TOL)


def test_multidimensional_measurement_direct_position_fixes():
    rng = np.random.default_rng(2)
    truth = np.cumsum(np.full((40, 2), 1.0), axis=0)
    z = truth + rng.normal(0.0, 2.0, (40, 2))
    z[7] = np.nan
    res = extended_kalman_filter(DeadReckoning(np.eye(2) * 0.1), DirectMeasurement(2, [0, 1], np.eye(2) * 4.0),
                                 [0.0, 0.0], np.eye(2) * 100.0, np.full((40, 2), 1.0), z)
    kf = KalmanFilter(F=np.eye(2), H=np.eye(2), Q=np.eye(2) * 0.1, R=np.eye(2) * 4.0, x0=[0.0, 0.0],
                      P0=np.eye(2) * 100.0, B=np.eye(2)).run(z, u=np.full((40, 2), 1.0))
    np.testing.assert_allclose(res.x, kf.x, **TOL)
    assert not res.extras["accepted"][7]


def test_joseph_form_keeps_P_symmetric_psd_with_accurate_ranges_and_huge_P0():
    motion = DeadReckoning(np.eye(2) * 1e-8)
    meas = RangeToBeacon((0.0, 0.0), R=1e-6)
    theta = np.linspace(0, 20 * np.pi, 2001)
    track = 500.0 * np.column_stack([np.cos(theta), np.sin(theta)])
    z = np.linalg.norm(track[1:], axis=1)
    res = extended_kalman_filter(motion, meas, track[0] + 1.0, np.eye(2) * 1e12, np.diff(track, axis=0), z)
    np.testing.assert_array_equal(res.P, np.swapaxes(res.P, -1, -2))
    assert np.linalg.eigvalsh(res.P).min() > -1e-9 * np.abs(res.P).max()


class RejectAbove(Gate):
    """Reject innovations larger than a fixed size and remember what was rejected (for the test)."""

    def __init__(self, limit):
        self.limit = limit
        self.seen = []

    def accept(self, ctx):
        return np.abs(ctx.y[:, 0]) <= self.limit

    def after_update(self, x, P, accepted, k):
        self.seen.append(accepted.copy())
        return x, P


def test_gate_rejects_outliers_like_missing_ranges():
    motion, meas, x0, P0, u, z = study(2, missing=0.0, M=3)
    plain = extended_kalman_filter(motion, meas, x0, P0, u, z)
    z_bad = z.copy()
    z_bad[:, 40:45] += 300.0
    gate = RejectAbove(100.0)
    gated = extended_kalman_filter(motion, meas, x0, P0, u, z_bad, gate=gate)
    z_nan = z.copy()
    z_nan[:, 40:45] = np.nan
    as_missing = extended_kalman_filter(motion, meas, x0, P0, u, z_nan)
    assert not gated.extras["accepted"][:, 40:45].any()
    np.testing.assert_allclose(gated.x, as_missing.x, **TOL)
    np.testing.assert_array_equal(np.array(gate.seen).T, gated.extras["accepted"])
    # with no outliers a generous gate changes nothing (to rounding: without a gate this pair runs on the packed
    # back-end, whose Joseph form is factored differently)
    quiet = extended_kalman_filter(motion, meas, x0, P0, u, z, gate=ChiSquareGate(1 - 1e-12))
    np.testing.assert_array_equal(quiet.extras["accepted"], plain.extras["accepted"])
    np.testing.assert_allclose(quiet.x, plain.x, rtol=1e-12, atol=1e-9)


def test_gate_after_update_can_replace_the_estimate():
    class Freeze(Gate):
        def accept(self, ctx):
            return np.zeros(ctx.y.shape[0], dtype=bool)

        def after_update(self, x, P, accepted, k):
            return np.full_like(x, 7.0), P

    motion, meas, x0, P0, u, z = study(2, M=2)
    res = extended_kalman_filter(motion, meas, x0, P0, u, z, gate=Freeze())
    assert (res.x == 7.0).all() and not res.extras["accepted"].any()


def test_prediction_on_the_beacon_skips_the_update_and_warns_at_the_caller():
    filt = ExtendedKalmanFilter(DeadReckoning(np.eye(2)), RangeToBeacon((0.0, 0.0), R=1.0), [1.0, 0.0],
                                np.eye(2))
    filt.predict([-1.0, 0.0])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        filt.update(3.0)
    assert caught and issubclass(caught[0].category, BeaconSingularityWarning)
    assert issubclass(caught[0].category, UwtutorWarning)
    assert caught[0].filename == __file__
    assert np.isnan(filt.y).all() and not filt.accepted
    np.testing.assert_array_equal(filt.x, [0.0, 0.0])


def test_bad_input_names_the_argument():
    motion, meas = DeadReckoning(np.eye(2)), RangeToBeacon((0.0, 0.0), R=1.0)
    with pytest.raises(TypeError, match="motion must be"):
        ExtendedKalmanFilter("not a model", meas, [0.0, 0.0], np.eye(2))
    with pytest.raises(ValueError, match="state of size 3"):
        ExtendedKalmanFilter(motion, RangeToBeacon((0.0, 0.0), R=1.0, n=3), [0.0, 0.0], np.eye(2))
    with pytest.raises(ValueError, match="x0 must have 2 entries"):
        ExtendedKalmanFilter(motion, meas, [0.0, 0.0, 0.0], np.eye(2))
    with pytest.raises(ValueError, match="P0 must be positive definite"):
        ExtendedKalmanFilter(motion, meas, [0.0, 0.0], -np.eye(2))
    with pytest.raises(ValueError, match="disagree on the number of runs M: x0 has"):
        ExtendedKalmanFilter(motion, meas, np.zeros((3, 2)), np.tile(np.eye(2), (4, 1, 1)))
    filt = ExtendedKalmanFilter(motion, meas, [10.0, 0.0], np.eye(2))
    with pytest.raises(ValueError, match="u must be the input of one step"):
        filt.predict(np.zeros((5, 2)))
    with pytest.raises(ValueError, match="z must be finite, or NaN"):
        filt.update(np.inf)
    with pytest.raises(ValueError, match="z must be one measurement per run"):
        filt.update([1.0, 2.0])
    with pytest.raises(TypeError, match="gate must be"):
        ExtendedKalmanFilter(motion, meas, [10.0, 0.0], np.eye(2), gate=lambda ctx: True)
    with pytest.raises(ValueError, match="disagree on the number of runs"):
        extended_kalman_filter(motion, meas, np.zeros((3, 2)), np.eye(2), None, np.ones((4, 10)))
    with pytest.raises(IndexError, match="beacon path has 2 positions"):
        extended_kalman_filter(motion, RangeToBeacon(np.zeros((2, 2)), R=1.0), [10.0, 0.0], np.eye(2), None,
                               np.ones(3))
    with pytest.raises(ValueError, match="R must be positive definite"):
        RangeToBeacon((0.0, 0.0), R=0.0)
    with pytest.raises(ValueError, match="bias_index must index the state"):
        RangeToBeacon((0.0, 0.0), R=1.0, n=3, bias_index=3)


def test_runs_axis_may_come_from_any_input():
    motion, meas, x0, P0, u, z = study(2, M=4)
    per_run_beacon = np.broadcast_to(np.array([5.0, -3.0]), (4, z.shape[1], 2))
    res = extended_kalman_filter(motion, RangeToBeacon(per_run_beacon, R=9.0), x0[0], P0, u, z[0])
    assert res.x.shape == (4, z.shape[1], 2)
    ref = extended_kalman_filter(motion, RangeToBeacon((5.0, -3.0), R=9.0), x0[0], P0, u, z[0])
    np.testing.assert_allclose(res.x[2], ref.x, **TOL)


def test_a_model_returning_wrong_shapes_is_reported():
    class Broken(MeasurementModel):
        m, n = 1, 2

        def h(self, x, k):
            return x[:, :1]

        def H(self, x, k):
            return np.ones((1, 2))

        def R(self, x, k):
            return np.eye(1)

    filt = ExtendedKalmanFilter(DeadReckoning(np.eye(2)), Broken(), np.zeros((3, 2)), np.eye(2))
    with pytest.raises(ValueError, match="H must have shape"):
        filt.update(np.ones(3))


def test_multiplicative_range_model_equals_filterpy_with_the_range_dependent_noise():
    from uwtutor.models import MultiplicativeRange

    motion, _, x0, P0, u, z = study(2, M=2, missing=0.1)
    meas = MultiplicativeRange((0.0, 0.0), R=0.49, mu_gamma=0.98, sigma_gamma=1 / 1500)
    res = extended_kalman_filter(motion, meas, x0, P0, u, 0.98 * z)
    for m in range(2):
        f = FilterpyEKF(dim_x=2, dim_z=1, dim_u=2)
        f.x, f.P, f.F, f.B, f.Q = x0[m].reshape(2, 1).copy(), P0.copy(), np.eye(2), np.eye(2), motion.Q(None, None, 0)
        for k, (uk, zk) in enumerate(zip(u, 0.98 * z[m])):
            f.predict(u=uk.reshape(2, 1))
            if np.isfinite(zk):
                x_row = f.x.T
                f.update(np.array([[zk]]), HJacobian=lambda x: meas.H(x.T, k)[0],
                         Hx=lambda x: meas.h(x.T, k)[0].reshape(1, 1), R=meas.R(x_row, k)[0])
            np.testing.assert_allclose(res.x[m, k], f.x[:, 0], **TOL)
            np.testing.assert_allclose(res.P[m, k], f.P, **TOL)
    with pytest.raises(ValueError, match="mu_gamma must be > 0"):
        MultiplicativeRange((0.0, 0.0), R=0.49, mu_gamma=0.0, sigma_gamma=0.001)


# --- the run's fast path (ExtendedKalmanFilter._run_steps) against the step-by-step loop (run_filter) -----------

def _fast_path_cases():
    from uwtutor.filters.bias import bias_model_pair
    from uwtutor.models import BeaconRanges, OdometryMotion

    rng = np.random.default_rng(5)
    K = 120
    theta = np.linspace(0.0, 2 * np.pi, K + 1)
    track = 300.0 * np.column_stack([np.cos(theta), np.sin(theta)])
    u = np.diff(track, axis=0)
    z = np.linalg.norm(track[1:], axis=1) + rng.normal(0.0, 2.0, (4, K))
    z[rng.random(z.shape) < 0.2] = np.nan
    range_pair = (DeadReckoning(np.eye(2) * 0.25), RangeToBeacon((0.0, 0.0), R=4.0))
    bias_pair = bias_model_pair(np.diag([0.25, 0.25, 0.01]), 5.0, (0.0, 0.0))
    beacons = np.array([[0.0, 0.0], [40.0, 0.0], [40.0, 30.0]])
    odo_u = np.column_stack([np.full(K, 0.5), np.full(K, 0.05)])
    truth = OdometryMotion(0.0, 0.0).integrate([20.0, 5.0, 0.0], odo_u)
    odo_z = np.linalg.norm(truth[:, None, :2] - beacons, axis=-1) + rng.normal(0, 0.05, (K, 3))
    odo_z[rng.random(odo_z.shape) < 0.3] = np.nan                  # some components missing: the masked update
    motion = OdometryMotion(0.02, 0.003, gyro_bias=True, times=0.5 * np.arange(K))
    x0, P0 = motion.layout.initial_state([20.0, 5.0, 0.0], np.diag([1.0, 1.0, 0.01]), gyro_bias=(0.0, 0.01))
    start = track[0] + rng.normal(0.0, 20.0, (4, 2))
    return {
        "range, batched": (*range_pair, start, np.eye(2) * 900.0, u, z, None),
        "range, one run": (*range_pair, start[0], np.eye(2) * 900.0, u, z[0], None),
        "range, gated": (*range_pair, start, np.eye(2) * 900.0, u, z, ChiSquareGate(0.95)),
        "bias": (*bias_pair, np.column_stack([start, np.zeros(4)]), np.eye(3) * 100.0, u, z, None),
        "odometry, masked": (motion, BeaconRanges(beacons, R=0.05**2, layout=motion.layout), x0, P0, odo_u,
                             odo_z, None),
    }


@pytest.mark.parametrize("case", list(_fast_path_cases()))
def test_run_fast_path_is_the_step_loop_bit_for_bit(case):
    motion, measurement, x0, P0, u, z, gate = _fast_path_cases()[case]
    make = lambda: ExtendedKalmanFilter(motion, measurement, x0, P0, gate=copy.deepcopy(gate))  # noqa: E731
    fast = make()
    assert fast._run_steps(np.asarray(z, dtype=float), u, None) is not None      # the fast path does apply
    fast = make().run(z, u)
    slow = run_filter(make(), z, u)
    for name in ("times", "x", "P", "x_prior", "P_prior", "innovations", "innovation_cov"):
        a, b = getattr(fast, name), getattr(slow, name)
        assert a.shape == b.shape and a.dtype == b.dtype and np.array_equal(a, b, equal_nan=True), name
    assert fast.extras.keys() == slow.extras.keys()
    for name in slow.extras:
        assert fast.extras[name].dtype == slow.extras[name].dtype
        assert np.array_equal(fast.extras[name], slow.extras[name], equal_nan=True), name


def test_run_fast_path_keeps_every_error_and_warning_of_the_step_loop():
    pair = (DeadReckoning(np.eye(2) * 0.25), RangeToBeacon((0.0, 0.0), R=4.0))
    u = np.tile([1.0, 0.0], (10, 1))
    z = np.full(10, 100.0)

    def messages(run):
        with pytest.raises(Exception) as caught:
            run()
        return type(caught.value), str(caught.value)

    # an infinite input at step 3: named at that step, as predict names it
    bad_u = u.copy()
    bad_u[3, 0] = np.inf
    filt, ref = (ExtendedKalmanFilter(*pair, [50.0, 0.0], np.eye(2) * 100.0) for _ in range(2))
    assert messages(lambda: filt.run(z, bad_u)) == messages(lambda: run_filter(ref, z, bad_u))
    assert filt.k == ref.k == 2 and np.array_equal(filt.x, ref.x)   # left where the step loop stops
    # a covariance that float64 cannot keep PSD: refused at the same step, with the same words (a third state puts
    # the pair on the generic back-end; the packed one of the plain pair keeps this case PSD, below)
    huge = (DeadReckoning(np.eye(3) * 0.0), RangeToBeacon((0.0, 0.0), R=1e-12, n=3))
    make = lambda: ExtendedKalmanFilter(*huge, [50.0, 3.0, 0.0], np.eye(3) * 1e12)  # noqa: E731
    slow = messages(lambda: run_filter(make(), z, u))
    assert slow[0] is IllConditionedError
    assert messages(lambda: make().run(z, u)) == slow
    plain = (DeadReckoning(np.eye(2) * 0.0), RangeToBeacon((0.0, 0.0), R=1e-12))
    packed = ExtendedKalmanFilter(*plain, [50.0, 3.0], np.eye(2) * 1e12).run(z, u)
    assert np.array_equal(packed.P, run_filter(ExtendedKalmanFilter(*plain, [50.0, 3.0], np.eye(2) * 1e12), z, u).P)
    assert (np.linalg.eigvalsh(packed.P) >= 0.0).all()
    # a prediction on the beacon: the same warning, once
    on = ExtendedKalmanFilter(*pair, [-1.0, 0.0], np.eye(2) * 100.0)
    with warnings.catch_warnings(record=True) as fast_w:
        warnings.simplefilter("always")
        on.run(z[:3], u[:3])
    with warnings.catch_warnings(record=True) as slow_w:
        warnings.simplefilter("always")
        run_filter(ExtendedKalmanFilter(*pair, [-1.0, 0.0], np.eye(2) * 100.0), z[:3], u[:3])
    assert [(w.category, str(w.message)) for w in fast_w] == [(w.category, str(w.message)) for w in slow_w]
    assert any(issubclass(w.category, BeaconSingularityWarning) for w in fast_w)


# -- states known exactly (known_states) -------------------------------------------------------------------------------
def test_known_states_stay_known_and_the_others_see_the_model_with_them_fixed():
    from uwtutor.models import BeaconRanges, OdometryMotion

    rng = np.random.default_rng(4)
    K = 120
    u = np.column_stack([np.full(K, 1.0), np.where(np.arange(K) % 30 == 0, np.pi / 2, 0.0) + 0.002])
    beacons = np.array([[20.0, 5.0], [-5.0, 15.0]])
    z = rng.normal(20.0, 5.0, (K, 2))
    z[rng.random((K, 2)) < 0.5] = np.nan
    times = np.arange(K, dtype=float)
    small = OdometryMotion(0.05, 0.01, order="move-first", times=times)             # [x, y, heading]
    full = OdometryMotion(0.05, 0.01, gyro_bias=True, scale=True, order="move-first", times=times,
                          gyro_bias_walk=1e-4, scale_walk=1e-5)                     # + gyro bias, scale
    P0 = np.diag([4.0, 4.0, 0.01, 1e-4, 1e-2])
    pinned = P0.copy()
    pinned[3:, :] = pinned[:, 3:] = 0.0
    batched = extended_kalman_filter(
        full._with_walks_per_run(np.array([[0.0, 0.0, 0.0, 1e-4, 1e-5], [0.0] * 5])),
        BeaconRanges(beacons, R=0.25, layout=full.layout), [0.0, 0.0, 0.0, 0.0, 1.0], np.stack([P0, pinned]),
        u, z, times=times, gate=ChiSquareGate(0.999, per_component=True),
        known_states=np.array([[False] * 5, [False, False, False, True, True]]))
    alone = extended_kalman_filter(small, BeaconRanges(beacons, R=0.25, layout=small.layout), [0.0, 0.0, 0.0],
                                   P0[:3, :3], u, z, times=times, gate=ChiSquareGate(0.999, per_component=True))
    # the pinned run: its bias and scale never move, their rows of P stay exactly 0
    np.testing.assert_array_equal(batched.x[1, :, 3:], np.tile([0.0, 1.0], (K, 1)))
    assert not batched.P[1, :, 3:, :].any() and not batched.P[1, :, :, 3:].any()
    # and the rest of it is the three-state filter's run, up to round-off, with the same gate decisions
    np.testing.assert_allclose(batched.x[1, :, :3], alone.x, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(batched.P[1, :, :3, :3], alone.P, rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(batched.extras["accepted"][1], alone.extras["accepted"])
    # the free run estimates them
    assert batched.P[0, -1, 3, 3] > 0 and batched.x[0, -1, 4] != 1.0


@pytest.mark.parametrize("known, P0, message", [
    (np.array([1, 0]), np.eye(2), "known_states must be bools"),
    (np.array([True]), np.eye(2), "known_states must be bools"),
    (np.array([True, False]), np.eye(2), "P0 must be 0 in the rows and columns of the known_states"),
    (np.array([True, False]), np.diag([0.0, -1.0]), "P0 must be positive semi-definite"),
    (np.array([True, False]), np.zeros((2, 2)), "P0 \\(on the states not known\\) must be positive definite"),
])
def test_known_states_bad_input_is_named(known, P0, message):
    with pytest.raises(ValueError, match=message):
        extended_kalman_filter(DeadReckoning(np.eye(2)), RangeToBeacon((0.0, 0.0), R=1.0), [10.0, 0.0], P0,
                               np.ones((3, 2)), np.ones(3) * 10.0, known_states=known)


def test_navigate_runs_its_candidates_as_one_batch_equal_to_each_alone():
    from uwtutor.datasets import CANDIDATES, navigate, navigation_models, square_log
    from uwtutor.datasets.navigation import _log_predictive
    from uwtutor.filters import ReacquiringGate

    data = square_log(range_scale=1.05)
    result = navigate(data, range_sigma=0.1)
    for name, (bias, scale) in CANDIDATES.items():
        nav = navigation_models(data, gyro_bias=bias, scale=scale, range_sigma=0.1)
        alone = extended_kalman_filter(nav.motion, nav.measurement, nav.x0, nav.P0, nav.u, nav.z, times=nav.times,
                                       gate=ReacquiringGate(ChiSquareGate(0.999, per_component=True), patience=10))
        batch = result.candidates[name]
        for field in ("x", "P", "x_prior", "P_prior", "innovations", "innovation_cov"):
            np.testing.assert_allclose(getattr(batch, field), getattr(alone, field), rtol=1e-9, atol=1e-12,
                                       err_msg=f"{name}: {field}")
        for key, value in alone.extras.items():
            np.testing.assert_array_equal(batch.extras[key], value, err_msg=f"{name}: {key}")
        assert result.evidence[name] == pytest.approx(_log_predictive(nav, alone)[0], rel=1e-9)


# -- keep_priors=False: the same run without the priors -----------------------------------------------------------
@pytest.mark.parametrize("family", ["engine", "bias_ekf", "range_only_ekf", "range_only_ekf gated", "step loop"])
def test_without_the_priors_every_other_field_is_the_same_bit_for_bit(family):
    from uwtutor.filters import bias_ekf, rts_smoother
    from uwtutor.models import paper_a_process_noise

    _, _, x0, P0, u, z = study(2, M=4, K=60)
    Q, R = np.eye(2) * 0.5, 9.0
    if family == "engine":
        def run(**kw):
            return extended_kalman_filter(DeadReckoning(Q), RangeToBeacon((0.0, 0.0), R), x0, P0, u, z,
                                          gate=ChiSquareGate(0.99), **kw)
    elif family == "bias_ekf":
        def run(**kw):
            return bias_ekf(np.column_stack([x0, np.zeros(4)]), np.eye(3) * 100.0, u, z + 5.0,
                            paper_a_process_noise(0.5), R, **kw)
    elif family.startswith("range_only_ekf"):
        def run(**kw):
            return range_only_ekf(x0, P0, u, z, Q, R, gate=ChiSquareGate(0.99) if "gated" in family else None, **kw)
    else:                         # a model run_filter must step through: the fast path refuses a user's model
        class Users(DeadReckoning):
            pass

        def run(**kw):
            return extended_kalman_filter(Users(Q), RangeToBeacon((0.0, 0.0), R), x0, P0, u, z, **kw)
    kept, dropped = run(), run(keep_priors=False)
    assert dropped.x_prior is None and dropped.P_prior is None and kept.x_prior is not None
    for name in ("times", "x", "P", "innovations", "innovation_cov"):
        np.testing.assert_array_equal(getattr(dropped, name), getattr(kept, name))
    assert dropped.extras.keys() == kept.extras.keys()
    for name, value in kept.extras.items():
        np.testing.assert_array_equal(dropped.extras[name], value)
    if family == "engine":
        with pytest.raises(ValueError, match="result has no priors"):
            rts_smoother(dropped, DeadReckoning(Q), u)
        with pytest.raises(TypeError, match="keep_priors must be True or False"):
            run(keep_priors="no")
