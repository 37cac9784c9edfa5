"""Vector measurements with missing components, per-step noise, gates that cannot lock out, and models that return
NaN: the update with the components present equals sequential scalar updates and the model of those components;
per-step Q and R equal a hand loop; the chi-square gate's lock-out is re-acquired; bad values are named."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from uwtutor.errors import BeaconSingularityWarning
from uwtutor.filters import (BootstrapParticleFilter, ChiSquareGate, ExtendedKalmanFilter, Gate, GateContext,
                             RangeOnlyEKF, ReacquiringGate, bias_ekf, cooperative_ekf,
                             extended_kalman_filter, range_only_ekf)
from uwtutor.filters.robust import SecondMomentGate
from uwtutor.models import (BeaconRanges, DeadReckoning, LinearMeasurement, LinearMotion,
                            MeasurementModel, OdometryMotion, RangeToBeacon)
from uwtutor.scenarios import paper_b

BEACONS = np.array([[0.0, 0.0], [40.0, 0.0], [40.0, 30.0], [0.0, 30.0]])


def _scalar_update(x, P, H_row, r, z):
    """One Kalman update with a scalar measurement, Joseph form."""
    S = H_row @ P @ H_row + r
    K = P @ H_row / S
    A = np.eye(len(x)) - np.outer(K, H_row)
    return x + K * (z - H_row @ x), A @ P @ A.T + r * np.outer(K, K)


# --- the update with the components present ------------------------------------------------------------------

def test_partial_update_equals_sequential_scalar_updates():
    rng = np.random.default_rng(0)
    n, m = 4, 3
    H = rng.normal(size=(m, n))
    r = np.array([0.5, 2.0, 1.0])
    A = rng.normal(size=(n, n))
    P0 = A @ A.T + np.eye(n)
    x0 = rng.normal(size=n)
    motion = LinearMotion(np.eye(n), np.zeros((n, n)))
    from uwtutor.models import LinearMeasurement
    for pattern in ([True, False, True], [False, True, False], [True, True, True]):
        z = rng.normal(size=m)
        z[~np.array(pattern)] = np.nan
        filt = ExtendedKalmanFilter(motion, LinearMeasurement(H, np.diag(r)), x0, P0)
        filt.predict()
        filt.update(z)
        x, P = x0.copy(), P0.copy()
        for j in np.flatnonzero(pattern):
            x, P = _scalar_update(x, P, H[j], r[j], z[j])
        np.testing.assert_allclose(filt.x, x, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(filt.P, P, rtol=1e-10, atol=1e-12)
        assert np.isnan(filt.y[~np.array(pattern)]).all() and np.isfinite(filt.y[pattern]).all()
        assert np.isnan(filt.S[~np.array(pattern)]).all() and np.isnan(filt.S[:, ~np.array(pattern)]).all()


def test_partial_update_equals_the_model_of_the_beacons_present():
    """A nonlinear model: four beacons with two missing == a model of the other two (same state, same noise)."""
    motion = OdometryMotion(0.05, 0.01, scale=True)
    R = np.diag([0.01, 0.02, 0.03, 0.04])
    x0, P0 = np.array([10.0, 12.0, 0.3, 1.05]), np.diag([4.0, 4.0, 0.01, 0.01])
    u = np.array([1.0, 0.05])
    z = np.array([17.0, np.nan, 35.0, np.nan])
    full = ExtendedKalmanFilter(motion, BeaconRanges(BEACONS, R, layout=motion.layout), x0, P0)
    part = ExtendedKalmanFilter(motion, BeaconRanges(BEACONS[[0, 2]], R[np.ix_([0, 2], [0, 2])],
                                                     layout=motion.layout), x0, P0)
    for f, zz in ((full, z), (part, z[[0, 2]])):
        f.predict(u)
        f.update(zz)
    np.testing.assert_allclose(full.x, part.x, rtol=1e-13)
    np.testing.assert_allclose(full.P, part.P, rtol=1e-11, atol=1e-15)
    np.testing.assert_allclose(full.y[[0, 2]], part.y, rtol=1e-12)
    np.testing.assert_allclose(full.S[np.ix_([0, 2], [0, 2])], part.S, rtol=1e-12)


def test_batched_runs_with_different_patterns_equal_single_runs():
    rng = np.random.default_rng(1)
    M, K = 5, 40
    motion = OdometryMotion(0.05, 0.01, scale=True)
    model = BeaconRanges(BEACONS, 0.01, layout=motion.layout)
    u = np.column_stack([np.full(K, 1.0), np.full(K, 0.1)])
    truth = motion.integrate([20.0, 5.0, 0.0, 1.07], u)
    z = truth[None, :, None, 3] * np.linalg.norm(truth[None, :, None, :2] - BEACONS, axis=-1) \
        + rng.normal(0, 0.1, (M, K, 4))
    z[rng.random(z.shape) < 0.4] = np.nan
    x0 = np.array([20.0, 5.0, 0.0, 1.0]) + rng.normal(0, [1, 1, 0.05, 0.0], (M, 4))
    P0 = np.diag([2.0, 2.0, 0.01, 0.01])
    batched = extended_kalman_filter(motion, model, x0, P0, u, z)
    for m in range(M):
        single = extended_kalman_filter(motion, model, x0[m], P0, u, z[m])
        for name in ("x", "P", "innovations", "innovation_cov"):
            np.testing.assert_allclose(getattr(batched, name)[m], getattr(single, name), rtol=1e-10, atol=1e-12)
    assert np.array_equal(np.isnan(batched.innovations), np.isnan(z))


def test_nothing_changes_for_complete_or_missing_measurements():
    """Runs whose measurement is complete or wholly missing take the plain path: bit for bit as before."""
    motion = DeadReckoning(np.eye(2) * 0.1)
    model = RangeToBeacon((0.0, 0.0), R=4.0)
    z = np.array([[300.0], [np.nan]])
    f = ExtendedKalmanFilter(motion, model, np.array([[290.0, 5.0], [290.0, 5.0]]), np.eye(2) * 100.0)
    f.predict([1.0, 0.0])
    f.update(z)
    np.testing.assert_array_equal(f.x[1], [291.0, 5.0])
    np.testing.assert_array_equal(f.P[1], np.eye(2) * 100.1)


# --- NaN from the models ---------------------------------------------------------------------------------------

class _TableRange(MeasurementModel):
    """A range to a beacon whose position comes from a per-step table: NaN at the steps it does not cover."""

    m, n = 1, 2

    def __init__(self, table):
        self.table = np.asarray(table, dtype=float)

    def h(self, x, k):
        return np.linalg.norm(x - self.table[k], axis=-1, keepdims=True)

    def H(self, x, k):
        d = x - self.table[k]
        return (d / np.linalg.norm(d, axis=-1, keepdims=True))[:, None, :]

    def R(self, x, k):
        return np.array([[1.0]])


def test_a_nan_jacobian_where_nothing_is_measured_is_not_used():
    table = np.array([[0.0, 0.0], [np.nan, np.nan], [0.0, 0.0]])
    z = np.array([100.0, np.nan, 101.0])
    res = extended_kalman_filter(DeadReckoning(np.eye(2)), _TableRange(table), [99.0, 1.0], np.eye(2) * 10.0,
                                 np.zeros((3, 2)), z)
    assert np.isfinite(res.x).all() and np.isfinite(res.P).all()
    np.testing.assert_array_equal(res.extras["accepted"], [True, False, True])
    np.testing.assert_array_equal(res.x[1], res.x_prior[1])


def test_a_nan_from_the_model_where_a_measurement_is_present_is_named():
    table = np.array([[0.0, 0.0], [np.nan, np.nan]])
    with pytest.raises(ValueError, match=r"_TableRange\.h returned a non-finite value at step 1 \(run 0, component "
                                         r"0\) where a measurement is present"):
        extended_kalman_filter(DeadReckoning(np.eye(2)), _TableRange(table), [99.0, 1.0], np.eye(2) * 10.0,
                               np.zeros((2, 2)), [100.0, 100.0])
    with pytest.raises(ValueError, match=r"RangeToBeacon\.R returned a non-finite value at step 1"):
        extended_kalman_filter(DeadReckoning(np.eye(2)), RangeToBeacon((0.0, 0.0), R=[1.0, np.nan]), [99.0, 1.0],
                               np.eye(2) * 10.0, np.zeros((2, 2)), [100.0, 100.0])
    # NaN variance at a step without a range: fine
    res = extended_kalman_filter(DeadReckoning(np.eye(2)), RangeToBeacon((0.0, 0.0), R=[1.0, np.nan]), [99.0, 1.0],
                                 np.eye(2) * 10.0, np.zeros((2, 2)), [100.0, np.nan])
    assert np.isfinite(res.P).all()


def test_a_nan_from_the_motion_model_is_named():
    class Broken(LinearMotion):
        def F(self, x, u, k):
            return np.full((2, 2), np.nan) if k == 2 else super().F(x, u, k)

    with pytest.raises(ValueError, match=r"Broken\.F returned a non-finite value at step 2"):
        extended_kalman_filter(Broken(np.eye(2), np.eye(2)), RangeToBeacon((0.0, 0.0), R=1.0), [99.0, 1.0],
                               np.eye(2), None, np.full(4, 100.0))


def test_on_a_beacon_only_that_component_is_skipped():
    motion = DeadReckoning(np.eye(2) * 0.0)
    model = BeaconRanges(BEACONS, 0.01)
    filt = ExtendedKalmanFilter(motion, model, [40.0, 0.0], np.eye(2))
    filt.predict([0.0, 0.0])
    with pytest.warns(BeaconSingularityWarning):
        filt.update([40.0, 0.0, 30.0, 50.0])
    assert np.isnan(filt.y[1]) and np.isfinite(filt.y[[0, 2, 3]]).all() and bool(filt.accepted)


# --- gates -------------------------------------------------------------------------------------------------------

def _ctx(y, S, present=None):
    M, m = y.shape
    return GateContext(k=1, z=y, z_pred=np.zeros_like(y), y=y, S=S, H=np.ones((M, m, 2)), R=np.eye(m),
                       x_prior=np.zeros((M, 2)), P_prior=np.tile(np.eye(2), (M, 1, 1)), present=present)


def test_chi_square_gate_counts_the_components_present():
    y = np.array([[2.0, np.nan, np.nan], [2.0, 1.0, 1.0]])
    S = np.tile(np.eye(3), (2, 1, 1))
    present = np.isfinite(y)
    # NIS 4 for one component: beyond chi2_1(0.95) = 3.84; NIS 6 for three: within chi2_3(0.95) = 7.81
    np.testing.assert_array_equal(ChiSquareGate(0.95).accept(_ctx(y, S, present)), [False, True])
    per = ChiSquareGate(0.95, per_component=True).accept(_ctx(y, S, present))
    np.testing.assert_array_equal(per, [[False, False, False], [False, True, True]])
    np.testing.assert_array_equal(SecondMomentGate(0.5).accept(_ctx(np.array([[1.0, np.nan]]), np.eye(2)[None],
                                                                     np.array([[True, False]]))), [True])


def test_a_per_component_verdict_drops_only_those_components():
    class DropSecond(Gate):
        def accept(self, ctx):
            v = np.ones(ctx.y.shape, dtype=bool)
            v[:, 1] = False
            return v

    motion = DeadReckoning(np.eye(2) * 0.01)
    R = np.diag([0.01, 0.02, 0.03, 0.04])
    z = np.array([17.0, 30.0, 35.0, 20.0])
    gated = ExtendedKalmanFilter(motion, BeaconRanges(BEACONS, R), [10.0, 12.0], np.eye(2) * 4, gate=DropSecond())
    missing = ExtendedKalmanFilter(motion, BeaconRanges(BEACONS, R), [10.0, 12.0], np.eye(2) * 4)
    for f, zz in ((gated, z), (missing, np.where([True, False, True, True], z, np.nan))):
        f.predict([0.0, 0.0])
        f.update(zz)
    np.testing.assert_allclose(gated.x, missing.x, rtol=1e-14)
    np.testing.assert_allclose(gated.P, missing.P, rtol=1e-12)
    np.testing.assert_array_equal(np.isnan(gated.y), [False, True, False, False])


def _circle(K=200, offset=(60.0, 0.0), seed=0):
    theta = np.linspace(0.0, 2 * np.pi, K + 1)
    track = 200.0 * np.column_stack([np.cos(theta), np.sin(theta)])
    z = np.linalg.norm(track[1:], axis=1) + np.random.default_rng(seed).normal(0.0, 1.0, K)
    return track, track[0] + np.asarray(offset), np.diff(track, axis=0), z


def test_a_chi_square_lock_out_is_reacquired():
    track, x0, u, z = _circle()
    locked = range_only_ekf(x0, np.eye(2), u, z, Q=np.eye(2) * 0.01, R=1.0, gate=ChiSquareGate(0.99))
    assert np.linalg.norm(locked.x[-1] - track[-1]) > 50.0 and locked.extras["updated"].mean() < 0.1
    res = range_only_ekf(x0, np.eye(2), u, z, Q=np.eye(2) * 0.01, R=1.0, gate=ReacquiringGate(patience=5))
    assert set(res.extras) == {"updated", "rejected", "inflated", "forced"}
    assert res.extras["inflated"].any() and res.extras["updated"][-100:].all()
    assert np.linalg.norm(res.x[-1] - track[-1]) < 1.0
    first = int(np.argmax(res.extras["inflated"]))
    assert res.extras["rejected"][first - 4:first + 1].all()                 # five rejections, then inflated
    np.testing.assert_allclose(res.P[first], 10.0 * res.P_prior[first], rtol=1e-12)
    assert res.extras["forced"][first + 1] and res.extras["updated"][first + 1]      # the next range is used
    # without forcing: the inflation alone also gets the single range back
    unforced = range_only_ekf(x0, np.eye(2), u, z, Q=np.eye(2) * 0.01, R=1.0,
                              gate=ReacquiringGate(patience=5, force=False))
    assert not unforced.extras["forced"].any() and np.linalg.norm(unforced.x[-1] - track[-1]) < 1.0


def test_reacquisition_of_an_odometry_state_inflating_the_position_only():
    """The gate works for any state: a heading, a bias and a scale stay as they were, the position opens up."""
    motion = OdometryMotion(0.02, 0.003, gyro_bias=True, scale=True, dt=1.0)
    model = BeaconRanges(BEACONS, 0.01, layout=motion.layout)
    K = 150
    u = np.column_stack([np.full(K, 0.5), np.full(K, 0.05)])
    truth = motion.integrate([20.0, 5.0, 0.0, 0.0, 1.07], u)
    z = 1.07 * np.linalg.norm(truth[:, None, :2] - BEACONS, axis=-1)
    x0 = np.array([28.0, 5.0, 0.0, 0.0, 1.07])                              # 8 m off, P says 0.1 m
    P0 = np.diag([0.01, 0.01, 1e-4, 1e-8, 1e-6])
    locked = extended_kalman_filter(motion, model, x0, P0, u, z, gate=ChiSquareGate(0.99))
    assert not locked.extras["accepted"].any()
    gate = ReacquiringGate(ChiSquareGate(0.99), patience=3, factor=100.0, states=[0, 1])
    res = extended_kalman_filter(motion, model, x0, P0, u, z, gate=gate)
    first = int(np.argmax(res.extras["inflated"]))
    scale = np.array([10.0, 10.0, 1.0, 1.0, 1.0])
    np.testing.assert_allclose(res.P[first], res.P_prior[first] * np.outer(scale, scale), rtol=1e-12)
    assert np.linalg.norm(res.x[-1, :2] - truth[-1, :2]) < 0.1 and res.extras["accepted"][-100:].all()


def test_bias_ekf_and_the_engine_take_a_gate():
    track, x0, u, z = _circle()
    res = bias_ekf(np.append(x0, 0.0), np.eye(3), u, z + 5.0, Q=np.diag([0.01, 0.01, 1e-4]), R=1.0,
                   gate=ReacquiringGate())
    assert np.linalg.norm(res.x[-1, :2] - track[-1]) < 2.0 and abs(res.x[-1, 2] - 5.0) < 2.0
    assert {"accepted", "rejected", "inflated", "forced"} == set(res.extras)


def test_gate_bad_input_named():
    with pytest.raises(ValueError, match="factor must be > 1"):
        ReacquiringGate(factor=1.0)
    with pytest.raises(ValueError, match="patience must be >= 1"):
        ReacquiringGate(patience=0)
    with pytest.raises(TypeError, match="test must be a uwtutor.filters.Gate"):
        ReacquiringGate("chi2")
    with pytest.raises(TypeError, match="per_component must be True or False"):
        ChiSquareGate(0.99, per_component=1)
    with pytest.raises(ValueError, match="max_variance must be > 0"):
        ReacquiringGate(max_variance=0.0)
    track, x0, u, z = _circle(K=20)
    with pytest.raises(ValueError, match=r"states must index the state \(0..1\)"):
        range_only_ekf(x0, np.eye(2), u, z, Q=np.eye(2) * 0.01, R=1.0, gate=ReacquiringGate(states=[2], patience=1))
    with pytest.raises(TypeError, match="gate must be a uwtutor.filters.Gate"):
        range_only_ekf(x0, np.eye(2), u, z, Q=np.eye(2) * 0.01, R=1.0, gate="chi2")


# --- per-step Q and R -----------------------------------------------------------------------------------------------

def _hand_range_ekf(x, P, u, z, Q, R, beacon=(0.0, 0.0)):
    xs, Ps = [], []
    for k in range(len(z)):
        x, P = x + u[k], P + Q[k]
        if np.isfinite(z[k]):
            d = x - beacon
            r = np.linalg.norm(d)
            x, P = _scalar_update(x - 0.0, P, d / r, R[k], z[k] - r + d / r @ x)
        xs.append(x)
        Ps.append(P)
    return np.array(xs), np.array(Ps)


def test_per_step_q_and_r_equal_a_hand_loop():
    track, x0, u, z = _circle(K=80, offset=(10.0, -5.0))
    z[::7] = np.nan
    K = len(z)
    Q = np.einsum("k,ij->kij", np.linspace(0.01, 1.0, K), np.eye(2))
    Q[:, 0, 1] = Q[:, 1, 0] = 0.005
    R = np.linspace(0.5, 5.0, K)
    R[::7] = np.nan                                       # no range there: a NaN variance is allowed
    want_x, want_P = _hand_range_ekf(x0, np.eye(2) * 100.0, u, z, Q, np.nan_to_num(R, nan=1.0))
    fast = range_only_ekf(x0, np.eye(2) * 100.0, u, z, Q=Q, R=R)
    np.testing.assert_allclose(fast.x, want_x, rtol=1e-10)
    np.testing.assert_allclose(fast.P, want_P, rtol=1e-9, atol=1e-12)
    generic = extended_kalman_filter(DeadReckoning(Q), RangeToBeacon((0.0, 0.0), R), x0, np.eye(2) * 100.0, u, z)
    np.testing.assert_allclose(generic.x, want_x, rtol=1e-10)
    gated = range_only_ekf(x0, np.eye(2) * 100.0, u, z, Q=Q, R=R, gate=Gate())
    np.testing.assert_allclose(gated.x, fast.x, rtol=1e-10)
    np.testing.assert_array_equal(gated.extras["updated"], fast.extras["updated"])
    # bias_ekf: the same with a third, constant state
    Q3 = np.zeros((K, 3, 3))
    Q3[:, :2, :2] = Q
    res = bias_ekf(np.append(x0, 0.0), np.diag([100.0, 100.0, 1e-12]), u, z, Q=Q3, R=R)
    np.testing.assert_allclose(res.x[:, :2], want_x, rtol=1e-6, atol=1e-6)


def test_the_trial_messages_are_gone_and_bad_per_step_noise_is_named():
    track, x0, u, z = _circle(K=30)
    K = len(z)
    range_only_ekf(x0, np.eye(2), u, z, Q=np.tile(np.eye(2), (K, 1, 1)), R=np.ones(K))     # no error
    with pytest.raises(ValueError, match=r"Q must be one 2x2 matrix shared by all runs, or one per step \(30, 2, 2\)"):
        range_only_ekf(x0, np.eye(2), u, z, Q=np.tile(np.eye(2), (K + 1, 1, 1)), R=1.0)
    with pytest.raises(ValueError, match=r"R must be the range variance, or one per step \(30,\)"):
        range_only_ekf(x0, np.eye(2), u, z, Q=np.eye(2), R=np.ones(K - 1))
    with pytest.raises(ValueError, match="R must hold range variances > 0"):
        range_only_ekf(x0, np.eye(2), u, z, Q=np.eye(2), R=np.r_[0.0, np.ones(K - 1)])
    with pytest.raises(ValueError, match="R is NaN at step 3, where a range is present"):
        range_only_ekf(x0, np.eye(2), u, z, Q=np.eye(2), R=np.r_[np.ones(3), np.nan, np.ones(K - 4)])
    with pytest.raises(ValueError, match="one Q per step is taken by range_only_ekf's functional form"):
        RangeOnlyEKF(x0, np.eye(2), np.tile(np.eye(2), (K, 1, 1)), 1.0)
    with pytest.raises(ValueError, match=r"Q must be one 3x3 matrix .* or one per step \(30, 3, 3\)"):
        bias_ekf(np.append(x0, 0.0), np.eye(3), u, z, Q=np.tile(np.eye(3), (K + 1, 1, 1)), R=1.0)
    with pytest.raises(IndexError, match="Q has 30 per-step matrices; step 30 is beyond them"):
        DeadReckoning(np.tile(np.eye(2), (K, 1, 1))).Q(None, None, K)


# --- the other families ----------------------------------------------------------------------------------------

def test_particle_filter_likelihood_marginalises_missing_components():
    """A NaN component is skipped: the weights are those of the model of the other components."""
    motion = LinearMotion(np.eye(2), np.eye(2) * 0.1)
    model = LinearMeasurement(H=[[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]], R=np.diag([1.0, 2.0, 3.0]))
    sub = LinearMeasurement(H=[[1.0, 0.0], [1.0, 1.0]], R=np.diag([1.0, 3.0]))
    particles = np.random.default_rng(0).normal(size=(200, 2))
    np.testing.assert_allclose(model.log_likelihood(particles[None], np.array([[0.5, np.nan, 1.0]]), 0),
                               sub.log_likelihood(particles[None], np.array([[0.5, 1.0]]), 0), rtol=1e-12)
    filters = [BootstrapParticleFilter(motion, m, particles, np.random.default_rng(1), ess_threshold=0.0)
               for m in (model, sub)]
    filters[0].update(np.array([0.5, np.nan, 1.0]))
    filters[1].update(np.array([0.5, 1.0]))
    np.testing.assert_allclose(filters[0].weights, filters[1].weights, rtol=1e-12)


def test_cooperative_pairs_follow_the_chosen_rule():
    sc = paper_b.make(np.random.default_rng(3), 2, packet_loss=0.3)
    p = paper_b.PARAMETERS
    args = (p.x1, np.diag([1e4, 1e4, 1.0, 1.0]), sc.dr_displacements, sc.ranges, p.Q, p.R)
    kw = dict(leader=sc.leader_broadcast, dt=p.interval)
    step = cooperative_ekf(*args, **kw)
    ranged = cooperative_ekf(*args, **kw, lost="range")
    lost = np.isnan(sc.ranges)
    partial = lost[:, :-1] ^ lost[:, 1:]                                    # one end of the pair lost
    assert partial.any()
    assert not step.extras["accepted"][partial].any() and ranged.extras["accepted"][partial].all()
    np.testing.assert_array_equal(np.isnan(ranged.innovations[partial]), np.stack([lost[:, :-1], lost[:, 1:]],
                                                                                   -1)[partial])
    with pytest.raises(ValueError, match="lost must be one of"):
        cooperative_ekf(*args, **kw, lost="drop")


def test_odometry_filter_warns_nothing_on_clean_data():
    motion = OdometryMotion(0.02, 0.003, scale=True)
    model = BeaconRanges(BEACONS, 0.01, layout=motion.layout)
    u = np.tile([0.5, 0.02], (50, 1))
    truth = motion.integrate([20.0, 5.0, 0.0, 1.0], u)
    z = np.linalg.norm(truth[:, None, :2] - BEACONS, axis=-1)
    z[::3, :2] = np.nan
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        res = extended_kalman_filter(motion, model, [20.0, 5.0, 0.0, 1.0], np.diag([1.0, 1.0, 0.01, 0.01]), u, z)
    assert res.extras["accepted"].all()


def test_a_patch_of_outliers_shorter_than_the_patience_is_still_rejected():
    track, x0, u, z = _circle(offset=(0.0, 0.0))
    z[100:104] += 40.0
    res = range_only_ekf(x0, np.eye(2), u, z, Q=np.eye(2) * 0.01, R=1.0, gate=ReacquiringGate(patience=5))
    np.testing.assert_array_equal(np.flatnonzero(res.extras["rejected"]), [100, 101, 102, 103])
    assert not res.extras["inflated"].any() and not res.extras["forced"].any()
    assert np.linalg.norm(res.x[-1] - track[-1]) < 1.0


def test_inflation_stops_at_max_variance():
    track, x0, u, z = _circle(offset=(0.0, 0.0))
    z[:] = np.nan
    z[::2] = 1e6                                          # garbage, for ever
    gate = ReacquiringGate(patience=2, factor=100.0, force=False, max_variance=1e6)
    res = range_only_ekf(x0, np.eye(2), u, z, Q=np.eye(2) * 0.0, R=1.0, gate=gate)
    assert res.extras["inflated"].sum() > 3 and not res.extras["updated"].any()
    assert res.P[..., 0, 0].max() <= 1e6 and res.P[-1, 0, 0] == res.P[-1, 1, 1] == 1e6
