"""The posterior Cramér-Rao bound: against an independent recursion, the static bound, and the Kalman filter."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from uwtutor.errors import UnobservableWarning
from uwtutor.filters import ExtendedKalmanFilter
from uwtutor.models import LinearMotion, MeasurementModel
from uwtutor.observability import posterior_crlb, rmse_bound, track_crlb

K = 60
DT = 2.0


def _track(K: int = K) -> np.ndarray:
    """A turn then a straight leg, 150-400 m from the beacon at the origin."""
    s = np.linspace(0.0, 1.0, K)
    theta = 0.2 + 2.5 * np.minimum(s, 0.6)
    radius = 150.0 + 250.0 * s
    return np.column_stack([radius * np.cos(theta), radius * np.sin(theta)])


def _lines_of_sight(p: np.ndarray, b: np.ndarray) -> np.ndarray:
    d = p - b
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def _transition(n: int, bias: bool, current: bool, dt: float) -> np.ndarray:
    F = np.eye(n)
    if current:
        c = 3 if bias else 2
        F[0, c] = F[1, c + 1] = dt
    return F


def _rows(p: np.ndarray, b: np.ndarray, n: int, bias: bool) -> np.ndarray:
    H = np.zeros((len(p), n))
    H[:, :2] = _lines_of_sight(p, b)
    if bias:
        H[:, 2] = 1.0
    return H


def _reference_recursion(p, b, sigma, Q, P0, bias=False, current=False, dt=DT):
    """Tichavský et al.'s recursion written out with explicit inverses, one epoch at a time."""
    n = P0.shape[0]
    F = _transition(n, bias, current, dt)
    H = _rows(p, np.broadcast_to(b, p.shape), n, bias)
    sig = np.broadcast_to(sigma, (len(p),))
    J = np.linalg.inv(P0)
    out = []
    for k in range(len(p)):
        J = np.linalg.inv(Q + F @ np.linalg.inv(J) @ F.T) + np.outer(H[k], H[k]) / sig[k] ** 2
        out.append(np.linalg.inv(J))
    return np.array(out)


def _full_Q(n: int, q_pos: float, q_rest: float = 0.0) -> np.ndarray:
    return np.diag([q_pos, q_pos] + [q_rest] * (n - 2))


CASES = [  # (bias, current, P0)
    (False, False, np.diag([400.0, 100.0])),
    (True, False, np.diag([400.0, 100.0, 9.0])),
    (False, True, np.diag([400.0, 100.0, 0.04, 0.04])),
    (True, True, np.diag([400.0, 100.0, 9.0, 0.04, 0.04])),
]


@pytest.mark.parametrize("bias, current, P0", CASES)
def test_equals_an_independent_recursion(bias, current, P0):
    n = P0.shape[0]
    p = _track()
    sigma = np.linspace(1.0, 3.0, K)
    Q = _full_Q(n, 0.25, 1e-4)                        # random-walk bias and current too
    ref = _reference_recursion(p, np.zeros(2), sigma, Q, P0, bias, current)
    got = posterior_crlb(p, [0.0, 0.0], sigma, Q, P0, times=DT * np.arange(K), bias=bias, current=current,
                         full=True)
    assert got.shape == (K, n, n)
    np.testing.assert_allclose(got, ref, rtol=1e-9, atol=1e-12)
    pos = posterior_crlb(p, [0.0, 0.0], sigma, Q, P0, times=DT * np.arange(K), bias=bias, current=current)
    np.testing.assert_array_equal(pos, got[:, :2, :2])


def test_position_only_Q_keeps_bias_and_current_constant():
    p = _track()
    P0 = CASES[3][2]
    got = posterior_crlb(p, [0.0, 0.0], 2.0, 0.25 * np.eye(2), P0, times=DT * np.arange(K), bias=True,
                         current=True, full=True)
    ref = _reference_recursion(p, np.zeros(2), 2.0, _full_Q(5, 0.25, 0.0), P0, True, True)
    np.testing.assert_allclose(got, ref, rtol=1e-9, atol=1e-12)


def test_moving_beacon_and_missing_ranges():
    p = _track()
    ship = np.column_stack([np.linspace(-100.0, 300.0, K), np.full(K, -50.0)])
    sigma = np.full(K, 2.0)
    sigma[10:20] = np.inf                              # no reply for ten epochs: predict only
    Q, P0 = 0.25 * np.eye(2), 100.0 * np.eye(2)
    got = posterior_crlb(p, ship, sigma, Q, P0)
    np.testing.assert_allclose(got, _reference_recursion(p, ship, sigma, Q, P0), rtol=1e-9, atol=1e-12)
    # while no range arrives the bound grows by Q per step
    np.testing.assert_allclose(got[10:20] - got[9:19], np.broadcast_to(Q, (10, 2, 2)), rtol=1e-9, atol=1e-12)


def test_runs_axis_and_mean_over_runs():
    rng = np.random.default_rng(3)
    p = _track()
    M = 5
    tracks = p + np.cumsum(rng.normal(0.0, 0.5, (M, K, 2)), axis=1)   # the sampled true tracks
    Q, P0 = 0.25 * np.eye(2), 100.0 * np.eye(2)
    per_run = posterior_crlb(tracks, [0.0, 0.0], 2.0, Q, P0)
    assert per_run.shape == (M, K, 2, 2)
    for j in range(M):
        np.testing.assert_allclose(per_run[j], _reference_recursion(tracks[j], np.zeros(2), 2.0, Q, P0), rtol=1e-9)
    # one prior per run
    P0_runs = np.stack([P0 * (1 + j) for j in range(M)])
    per_prior = posterior_crlb(p, [0.0, 0.0], 2.0, Q, P0_runs)
    assert per_prior.shape == (M, K, 2, 2)
    np.testing.assert_allclose(per_prior[3], _reference_recursion(p, np.zeros(2), 2.0, Q, P0_runs[3]), rtol=1e-9)
    # the expectation as a mean over the runs: the information of each epoch averaged
    mean = posterior_crlb(tracks, [0.0, 0.0], 2.0, Q, P0, mean_over_runs=True)
    assert mean.shape == (K, 2, 2)
    H = _lines_of_sight(tracks, np.zeros(2))
    info = np.einsum("mki,mkj->kij", H, H) / M / 4.0
    J = np.linalg.inv(P0)
    for k in range(K):
        J = np.linalg.inv(Q + np.linalg.inv(J)) + info[k]
        np.testing.assert_allclose(mean[k], np.linalg.inv(J), rtol=1e-9)
    # metres of scatter 150-400 m from the beacon: the track-evaluated bound is within a few per cent
    nominal = rmse_bound(posterior_crlb(p, [0.0, 0.0], 2.0, Q, P0))
    np.testing.assert_allclose(rmse_bound(mean), nominal, rtol=0.05)


def test_the_scatter_of_the_true_tracks_lowers_the_bound():
    """The claims of the docstring: 4 m of scatter changes the bound by < 1 %, 15 m by 10-30 % (downwards)."""
    rng = np.random.default_rng(3)
    p = _track()
    P0 = 100.0 * np.eye(2)
    change = {}
    for step_std in (0.5, 2.0):
        tracks = p + np.cumsum(rng.normal(0.0, step_std, (200, K, 2)), axis=1)
        Q = step_std**2 * np.eye(2)
        mean = rmse_bound(posterior_crlb(tracks, [0.0, 0.0], 2.0, Q, P0, mean_over_runs=True))
        change[step_std] = mean / rmse_bound(posterior_crlb(p, [0.0, 0.0], 2.0, Q, P0)) - 1
    assert np.abs(change[0.5]).max() < 0.01
    assert -0.35 < change[2.0][K // 3:].min() and change[2.0][K // 3:].max() < -0.1


@pytest.mark.parametrize("bias, current", [(False, False), (True, False), (False, True), (True, True)])
def test_tends_to_the_static_bound_as_Q_goes_to_zero(bias, current):
    n = 2 + bias + 2 * current
    p = _track()
    times = DT * np.arange(K)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UnobservableWarning)     # the first epochs are unobservable statically
        static = track_crlb(p, [0.0, 0.0], 2.0, times=times, unknown_bias=bias, unknown_current=current)
    # compare where the static bound is finite and well below the (nearly absent) prior of the PCRB
    finite = np.isfinite(static).all(axis=(1, 2))
    finite[finite] = np.trace(static[finite], axis1=1, axis2=2) < 1e5
    assert finite.sum() >= 20
    P0 = np.eye(n) * 1e12

    def gap(q):
        pcrb = posterior_crlb(p, [0.0, 0.0], 2.0, q * np.eye(n), P0, times=times, bias=bias, current=current,
                              full=True)
        scale = np.abs(static[finite]).max(axis=(1, 2), keepdims=True)
        return np.max(np.abs(pcrb[finite] - static[finite]) / scale)

    gaps = [gap(q) for q in (1e-4, 1e-7, 1e-10)]
    assert gaps[0] > 1e-3                                          # process noise matters...
    assert gaps[1] < gaps[0] / 100                                 # ...less and less as Q -> 0 (linearly)...
    assert gaps[2] < 1e-6                                          # ...down to the static bound
    assert gap(0.0) < 1e-6                                         # Q = 0 exactly (a singular Q is allowed)


def test_process_noise_keeps_the_bound_from_shrinking():
    p = _track(400)[1:]
    with pytest.warns(UnobservableWarning):                        # one range fixes no position
        static = rmse_bound(track_crlb(p, [0.0, 0.0], 2.0))
    pcrb = rmse_bound(posterior_crlb(p, [0.0, 0.0], 2.0, 0.25 * np.eye(2), 1e12 * np.eye(2)))
    assert np.all(pcrb[1:] >= static[1:] * (1 - 1e-9))
    assert pcrb[-1] > 10 * static[-1]                              # drift caps what old ranges are worth


class _LineOfSightRows(MeasurementModel):
    """A linear measurement z_k = H_k x + v_k whose rows are the lines of sight of the true track."""

    def __init__(self, H: np.ndarray, sigma: np.ndarray) -> None:
        self._H, self._var = H, np.asarray(sigma, dtype=float) ** 2
        self.m, self.n = 1, H.shape[1]

    def h(self, x, k):
        return x @ self._H[k][:, None]

    def H(self, x, k):
        return np.broadcast_to(self._H[k], (x.shape[0], 1, self.n))

    def R(self, x, k):
        return np.array([[self._var[k]]])


@pytest.mark.parametrize("bias, current, P0", CASES)
def test_equals_the_kalman_filter_covariance_on_a_linear_gaussian_model(bias, current, P0):
    """With H_k fixed at the truth the model is linear-Gaussian: the KF covariance is the bound, step by step."""
    n = P0.shape[0]
    p = _track()
    sigma = np.linspace(1.0, 3.0, K)
    Q = _full_Q(n, 0.25, 1e-4)
    times = np.concatenate([[-DT], DT * np.arange(K)])            # K + 1 times: the first is that of x0
    F = _transition(n, bias, current, DT)
    H = _rows(p, np.zeros((K, 2)), n, bias)
    rng = np.random.default_rng(11)
    x_true = rng.normal(size=n)
    z = np.empty(K)
    for k in range(K):
        x_true = F @ x_true + rng.multivariate_normal(np.zeros(n), Q)
        z[k] = H[k] @ x_true + rng.normal(0.0, sigma[k])
    kf = ExtendedKalmanFilter(LinearMotion(F, Q), _LineOfSightRows(H, sigma), np.zeros(n), P0)
    pcrb = posterior_crlb(p, [0.0, 0.0], sigma, Q, P0, times=times, bias=bias, current=current, full=True)
    for k in range(K):
        kf.predict()
        kf.update(z[k])
        np.testing.assert_allclose(kf.P, pcrb[k], rtol=1e-8, atol=1e-10)


def test_on_the_beacon_the_range_adds_nothing():
    p = _track(10)
    p[4] = [0.0, 0.0]
    with pytest.warns(UnobservableWarning, match="epoch 4"):
        got = posterior_crlb(p, [0.0, 0.0], 2.0, 0.25 * np.eye(2), 100.0 * np.eye(2))
    np.testing.assert_allclose(got[4] - got[3], 0.25 * np.eye(2), rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("kwargs, match", [
    (dict(sigma=-1.0), "sigma must be > 0"),
    (dict(sigma=np.nan), "sigma must be > 0"),
    (dict(sigma=np.ones(3)), "sigma must be a number"),
    (dict(Q=-np.eye(2)), "Q must be positive semi-definite"),
    (dict(Q=np.eye(3)), r"Q must be the process noise covariance"),
    (dict(P0=np.zeros((2, 2))), "P0 must be positive definite"),
    (dict(P0=np.eye(3)), r"P0 must be \(2, 2\)"),
    (dict(positions=np.zeros((10, 3))), "positions must hold 2-D points"),
    (dict(positions=np.full((10, 2), np.nan)), "positions must be finite"),
    (dict(beacon=np.zeros((4, 2))), "beacon must have shape"),
    (dict(current=True, P0=np.eye(4)), "times are needed with current=True"),
    (dict(current=True, P0=np.eye(4), times=np.arange(7.0)), "times must have one entry per epoch"),
    (dict(current=True, P0=np.eye(4), times=-np.arange(10.0)), "times must increase strictly"),
    (dict(positions=np.ones((3, 10, 2)), P0=np.broadcast_to(np.eye(2), (4, 2, 2))), "disagree on the number of runs"),
    (dict(sigma=1e80), "sigma must be at most 1e\\+75"),
    (dict(current=True, P0=np.eye(4), times=np.arange(10.0) * 1e60), "times must be in seconds"),
    (dict(positions=np.ones((3, 10, 2)), P0=np.stack([np.eye(2)] * 3), mean_over_runs=True),
     r"give one P0 of shape \(2, 2\)"),
])
def test_bad_input_is_named(kwargs, match):
    args = dict(positions=_track(10) , beacon=[0.0, 0.0], sigma=2.0, Q=0.25 * np.eye(2), P0=100.0 * np.eye(2))
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        posterior_crlb(**args)
