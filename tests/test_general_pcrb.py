"""The posterior CRLB of any model pair: equal to posterior_crlb on its models, to an independent recursion with
explicit inverses on the odometry model, to the Kalman filter's covariance on a linear model; missing components
skipped; batched == single; bad input named."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from uwtutor.errors import UnobservableWarning
from uwtutor.filters import KalmanFilter
from uwtutor.models import (BeaconRanges, DeadReckoning, LinearMeasurement, LinearMotion, OdometryMotion,
                            RangeToBeacon)
from uwtutor.observability import model_posterior_crlb, posterior_crlb

K = 60
BEACONS = np.array([[0.0, 0.0], [40.0, 0.0], [40.0, 30.0], [0.0, 30.0]])


def _track(K=K):
    s = np.linspace(0.0, 1.0, K)
    theta = 0.2 + 2.5 * np.minimum(s, 0.6)
    radius = 150.0 + 250.0 * s
    return np.column_stack([radius * np.cos(theta), radius * np.sin(theta)])


@pytest.mark.parametrize("bias", [False, True])
def test_equals_posterior_crlb_on_its_models(bias):
    p = _track()
    sigma = np.linspace(1.0, 3.0, K)
    sigma[::5] = np.inf                                              # no range there
    n = 3 if bias else 2
    Q = np.diag([0.25, 0.25, 1e-4][:n])
    P0 = np.diag([400.0, 100.0, 9.0][:n])
    want = posterior_crlb(p, [10.0, -20.0], sigma, Q, P0, bias=bias, full=True)
    R = np.where(np.isfinite(sigma), sigma**2, np.nan)
    meas = RangeToBeacon([10.0, -20.0], R=R, n=n, bias_index=2 if bias else None)
    truth = np.column_stack([p, np.full(K, 3.0)]) if bias else p
    x0 = truth[0]
    got = model_posterior_crlb(DeadReckoning(Q), meas, x0, P0, truth, np.diff(p, axis=0, prepend=p[:1]),
                               measured=np.isfinite(sigma), full=True)
    np.testing.assert_allclose(got, want, rtol=1e-10)
    np.testing.assert_allclose(model_posterior_crlb(DeadReckoning(Q), meas, x0, P0, truth, measured=np.isfinite(sigma)),
                               want[..., :2, :2], rtol=1e-10)


def test_equals_posterior_crlb_with_a_current():
    """Paper B's state: the current moves the vehicle by dt U (a linear model with F = [[I, dt I], [0, I]])."""
    p = _track()
    dt = 2.0
    Q = np.diag([0.25, 0.25, 1e-6, 1e-6])
    P0 = np.diag([400.0, 100.0, 0.04, 0.04])
    F = np.eye(4)
    F[0, 2] = F[1, 3] = dt
    want = posterior_crlb(p, np.zeros(2), 2.0, Q, P0, times=dt * np.arange(1, K + 1), current=True, full=True)
    meas = RangeToBeacon((0.0, 0.0), R=4.0, n=4)
    truth = np.column_stack([p, np.full((K, 2), 0.1)])
    got = model_posterior_crlb(LinearMotion(F, Q), meas, truth[0], P0, truth, full=True)
    np.testing.assert_allclose(got, want, rtol=1e-10)


def _numeric(fun, x, eps=1e-6):
    cols = []
    for i in range(len(x)):
        d = np.zeros_like(x)
        d[i] = eps
        cols.append((fun(x + d) - fun(x - d)) / (2 * eps))
    return np.stack(cols, axis=-1)


def test_equals_an_explicit_recursion_on_the_odometry_model():
    motion = OdometryMotion(0.05, 0.01, gyro_bias=True, scale=True, dt=0.5, gyro_bias_walk=1e-4)
    ranges = BeaconRanges(BEACONS, R=np.diag([0.01, 0.02, 0.03, 0.04]), layout=motion.layout)
    u = np.column_stack([np.full(K, 0.5), 0.1 * np.sin(np.arange(K) / 5)])
    x0 = np.array([20.0, 5.0, 0.3, 0.002, 1.07])
    truth = motion.integrate(x0, u)
    measured = np.random.default_rng(0).random((K, 4)) > 0.3
    P0 = np.diag([4.0, 4.0, 0.05, 1e-4, 0.01])
    got = model_posterior_crlb(motion, ranges, x0, P0, truth, u, measured=measured, full=True)
    J = np.linalg.inv(P0)
    prev = x0
    for k in range(K):
        F = _numeric(lambda x: motion.f(x[None], u[k], k)[0], prev)
        F[2] = np.round(F[2], 9)                            # the heading row (no wrap inside eps)
        Q = motion.Q(prev[None], u[k], k)[0]
        J = np.linalg.inv(Q + F @ np.linalg.inv(J) @ F.T)
        H = _numeric(lambda x: ranges.h(x[None], k)[0], truth[k])[measured[k]]
        R = np.diag([0.01, 0.02, 0.03, 0.04])[np.ix_(measured[k], measured[k])]
        J = J + H.T @ np.linalg.inv(R) @ H
        np.testing.assert_allclose(got[k], np.linalg.inv(J), rtol=2e-5, atol=1e-12)
        prev = truth[k]


def test_equals_the_kalman_filter_covariance_on_a_linear_model():
    """On a linear-Gaussian model the bound is the Kalman filter's covariance (which does not depend on z)."""
    F = np.array([[1.0, 1.0], [0.0, 1.0]])
    Q = np.diag([0.01, 0.04])
    H = np.array([[1.0, 0.0], [1.0, 1.0]])
    R = np.diag([2.0, 3.0])
    P0 = np.eye(2) * 10.0
    z = np.random.default_rng(1).normal(size=(30, 2))
    z[::4, 1] = np.nan
    z[::7] = np.nan
    kf = KalmanFilter(F=F, H=H, Q=Q, R=R, x0=np.zeros(2), P0=P0).run(z)
    got = model_posterior_crlb(LinearMotion(F, Q), LinearMeasurement(H, R), np.zeros(2), P0, np.zeros((30, 2)),
                               measured=np.isfinite(z), full=True)
    np.testing.assert_allclose(got, kf.P, rtol=1e-10, atol=1e-12)


def test_batched_equals_single_runs_and_measured_shapes():
    motion = OdometryMotion(0.05, 0.01, scale=True)
    ranges = BeaconRanges(BEACONS, R=0.01, layout=motion.layout)
    rng = np.random.default_rng(2)
    u = np.column_stack([np.full(K, 0.5), rng.normal(0, 0.1, K)])
    x0 = np.array([[20.0, 5.0, 0.3, 1.07], [10.0, 15.0, -1.0, 0.95]])
    truth = motion.integrate(x0, u)
    measured = rng.random((2, K)) > 0.5
    P0 = np.diag([4.0, 4.0, 0.05, 0.01])
    batched = model_posterior_crlb(motion, ranges, x0, P0, truth, u, measured=measured)
    assert batched.shape == (2, K, 2, 2)
    for m in range(2):
        single = model_posterior_crlb(motion, ranges, x0[m], P0, truth[m], u, measured=measured[m])
        np.testing.assert_allclose(batched[m], single, rtol=1e-12)
        per_component = model_posterior_crlb(motion, ranges, x0[m], P0, truth[m], u,
                                             measured=np.repeat(measured[m][:, None], 4, axis=1))
        np.testing.assert_allclose(per_component, single, rtol=1e-12)
    none = model_posterior_crlb(motion, ranges, x0[0], P0, truth[0], u, measured=np.zeros(K, dtype=bool), full=True)
    assert (np.diff(np.trace(none, axis1=-2, axis2=-1)) > 0).all()          # dead reckoning alone: it only grows


def test_a_position_on_a_beacon_warns_and_adds_nothing_there():
    motion = DeadReckoning(np.eye(2) * 0.1)
    ranges = BeaconRanges(BEACONS, R=0.01)
    truth = np.array([[40.0, 0.0], [20.0, 10.0]])
    with pytest.warns(UnobservableWarning, match="undefined for 1 measured component"):
        model_posterior_crlb(motion, ranges, truth[0], np.eye(2), truth)


def test_bad_input_named():
    motion = OdometryMotion(0.05, 0.01)
    ranges = BeaconRanges(BEACONS, R=0.01, layout=motion.layout)
    truth = np.zeros((5, 3)) + [20.0, 5.0, 0.0]
    u = np.zeros((5, 2))
    with pytest.raises(TypeError, match="motion must be a uwtutor.models.MotionModel"):
        model_posterior_crlb("odometry", ranges, truth[0], np.eye(3), truth, u)
    with pytest.raises(ValueError, match="reads a state of size 2"):
        model_posterior_crlb(motion, BeaconRanges(BEACONS, R=0.01), truth[0], np.eye(3), truth, u)
    with pytest.raises(ValueError, match="truth must have 3 entries per state"):
        model_posterior_crlb(motion, ranges, truth[0], np.eye(3), truth[:, :2], u)
    with pytest.raises(ValueError, match="u must give one input per step"):
        model_posterior_crlb(motion, ranges, truth[0], np.eye(3), truth, u[:4])
    with pytest.raises(TypeError, match=r"measured must be a bool array, .*np.isfinite\(z\)"):
        model_posterior_crlb(motion, ranges, truth[0], np.eye(3), truth, u, measured=np.ones(5))
    with pytest.raises(ValueError, match=r"measured must have shape \(5,\), \(5, 4\)"):
        model_posterior_crlb(motion, ranges, truth[0], np.eye(3), truth, u, measured=np.ones(4, dtype=bool))
    with pytest.raises(ValueError, match="P0 must be positive definite"):
        model_posterior_crlb(motion, ranges, truth[0], np.zeros((3, 3)), truth, u)
    with pytest.raises(ValueError, match="disagree on the number of runs M: x0 has 2, truth has 3"):
        model_posterior_crlb(motion, ranges, np.zeros((2, 3)), np.eye(3), np.zeros((3, 5, 3)), u)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        model_posterior_crlb(motion, ranges, truth[0], np.eye(3), truth, u)


def test_mean_over_runs_averages_the_measurement_information():
    """One bound from M sampled tracks: the information of each step averaged over them, by an explicit recursion;
    several components per step (four beacons, some missing) as well as one."""
    rng = np.random.default_rng(5)
    M = 4
    tracks = _track() + np.cumsum(rng.normal(0.0, 1.0, (M, K, 2)), axis=1)
    Q, P0 = np.diag([0.25, 0.16]), np.diag([400.0, 100.0])
    R = np.diag([1.0, 2.0, 3.0, 4.0])
    ranges = BeaconRanges(BEACONS * 5.0, R=R)
    measured = rng.random((M, K, 4)) > 0.3
    got = model_posterior_crlb(DeadReckoning(Q), ranges, tracks[:, 0], P0, tracks, measured=measured,
                               mean_over_runs=True)
    assert got.shape == (K, 2, 2)
    J = np.linalg.inv(P0)
    for k in range(K):
        J = np.linalg.inv(Q + np.linalg.inv(J))
        info = np.zeros((2, 2))
        for j in range(M):
            d = tracks[j, k] - BEACONS * 5.0
            H = (d / np.linalg.norm(d, axis=1, keepdims=True))[measured[j, k]]
            info += H.T @ np.linalg.inv(R[np.ix_(measured[j, k], measured[j, k])]) @ H
        J = J + info / M
        np.testing.assert_allclose(got[k], np.linalg.inv(J), rtol=1e-9)
    # posterior_crlb's mean_over_runs is this one, on its models
    one = RangeToBeacon((0.0, 0.0), R=4.0)
    np.testing.assert_allclose(model_posterior_crlb(DeadReckoning(Q), one, tracks[:, 0], P0, tracks,
                                                    mean_over_runs=True),
                               posterior_crlb(tracks, (0.0, 0.0), 2.0, Q, P0, mean_over_runs=True), rtol=1e-12)
    # one run: the mean is that run's bound
    np.testing.assert_array_equal(model_posterior_crlb(DeadReckoning(Q), one, tracks[0, 0], P0, tracks[0],
                                                       mean_over_runs=True),
                                  model_posterior_crlb(DeadReckoning(Q), one, tracks[0, 0], P0, tracks[0]))


def test_mean_over_runs_refuses_what_it_cannot_average():
    motion = OdometryMotion(0.05, 0.01)
    ranges = BeaconRanges(BEACONS, R=0.01, layout=motion.layout)
    u = np.column_stack([np.full(K, 0.5), np.full(K, 0.05)])
    x0 = np.array([[20.0, 5.0, 0.3], [10.0, 15.0, -1.0]])
    truth = motion.integrate(x0, u)
    with pytest.raises(ValueError, match="OdometryMotion.F differs between the runs' true states at step 0"):
        model_posterior_crlb(motion, ranges, x0, np.eye(3), truth, u, mean_over_runs=True)
    with pytest.raises(ValueError, match=r"give one P0 of shape \(3, 3\)"):
        model_posterior_crlb(motion, ranges, x0, np.stack([np.eye(3)] * 2), truth, u, mean_over_runs=True)
    with pytest.raises(TypeError, match="mean_over_runs must be"):
        model_posterior_crlb(motion, ranges, x0, np.eye(3), truth, u, mean_over_runs="yes")


class _OneRange(RangeToBeacon):
    """A range model whose variance a user got wrong at one step."""

    def R(self, x, k):
        return np.array([[0.0 if k == 3 else 4.0]])


def test_a_variance_that_is_not_positive_is_named():
    p = _track(10)
    with pytest.raises(ValueError, match="_OneRange.R returned a variance that is not finite and > 0 at step 3"):
        model_posterior_crlb(DeadReckoning(np.eye(2)), _OneRange((0.0, 0.0), R=4.0), p[0], np.eye(2), p)
    # where the step has no measurement it does not matter
    measured = np.arange(10) != 3
    model_posterior_crlb(DeadReckoning(np.eye(2)), _OneRange((0.0, 0.0), R=4.0), p[0], np.eye(2), p,
                         measured=measured)


class _ReusedBuffer(DeadReckoning):
    """A motion model that writes each step's F into the same array (a legitimate way to save allocations)."""

    def __init__(self, Q):
        super().__init__(Q)
        self._buffer = np.eye(2)

    def F(self, x, u, k):
        self._buffer[:] = [[1.0, 0.1 * k], [0.0, 1.0]]
        return self._buffer


def test_a_model_that_reuses_its_array_gets_each_step_s_own_F():
    p = _track(10)
    Q, P0 = 0.25 * np.eye(2), 100.0 * np.eye(2)
    got = model_posterior_crlb(_ReusedBuffer(Q), RangeToBeacon((0.0, 0.0), R=4.0), p[0], P0, p)
    J = np.linalg.inv(P0)
    for k in range(10):
        F = np.array([[1.0, 0.1 * k], [0.0, 1.0]])
        J = np.linalg.inv(Q + F @ np.linalg.inv(J) @ F.T)
        d = p[k] / np.linalg.norm(p[k])
        J = J + np.outer(d, d) / 4.0
        np.testing.assert_allclose(got[k], np.linalg.inv(J), rtol=1e-9)


def test_the_position_bound_is_read_from_the_position_slot():
    """A state whose position is not first (a range scale before it): the bound returned is the position's block,
    found by the slot's name, not the first two components."""
    from uwtutor.models import BlockMotion, Position, RandomWalk, RangeToBeacon
    motion = BlockMotion(RandomWalk("scale"), Position(0.01 * np.eye(2)))
    ranges = RangeToBeacon((0.0, 0.0), 1.0, state=motion)
    K = 20
    truth = np.column_stack([np.ones(K), np.linspace(10.0, 30.0, K), np.full(K, 5.0)])
    args = (motion, ranges, truth[0], np.diag([0.01, 100.0, 100.0]), truth, np.zeros((K, 2)))
    whole = model_posterior_crlb(*args, full=True)
    np.testing.assert_array_equal(model_posterior_crlb(*args), whole[:, 1:, 1:])
