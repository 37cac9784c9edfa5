"""The RTS smoother equals batch least squares over the whole trajectory on a linear-Gaussian model."""

from __future__ import annotations

import numpy as np
import pytest

from uwtutor.filters import FilterResult, KalmanFilter, rts_smoother
from uwtutor.filters.robust import robust_range_kf
from uwtutor.models import LinearMotion
from uwtutor.models.robust import ConstantVelocity, step_lengths


def _batch_least_squares(F, H, Q, R, x0, P0, z):
    """Minimize |x_-1 - x0|²_P0^-1 + sum |x_k - F x_k-1|²_Q^-1 + sum |z_k - H x_k|²_R^-1 over x_-1..x_K-1.

    Returns the estimates x_0..x_K-1 and the blocks of the inverse normal matrix (their covariances); NaN
    measurements contribute nothing."""
    K, n = len(z), F.shape[0]
    N = (K + 1) * n
    A = np.zeros((N, N))
    b = np.zeros(N)
    Pi, Qi, Ri = np.linalg.inv(P0), np.linalg.inv(Q), np.linalg.inv(R)
    A[:n, :n] += Pi
    b[:n] += Pi @ x0
    for k in range(K):
        i, j = k * n, (k + 1) * n                 # x_{k-1} at block k, x_k at block k + 1
        D = np.zeros((n, N))
        D[:, i:i + n] = -F
        D[:, j:j + n] = np.eye(n)
        A += D.T @ Qi @ D
        if np.all(np.isfinite(z[k])):
            E = np.zeros((H.shape[0], N))
            E[:, j:j + n] = H
            A += E.T @ Ri @ E
            b += E.T @ Ri @ z[k]
    cov = np.linalg.inv(A)
    x = cov @ b
    return x[n:].reshape(K, n), np.array([cov[j:j + n, j:j + n] for j in range(n, N, n)])


@pytest.mark.parametrize("with_gaps", [False, True])
def test_smoother_equals_batch_least_squares(with_gaps):
    rng = np.random.default_rng(0)
    F = np.array([[1.0, 1.0], [0.0, 1.0]])
    Q = np.array([[0.3, 0.1], [0.1, 0.2]])
    H = np.array([[1.0, 0.0]])
    R = np.array([[4.0]])
    x0, P0 = np.array([10.0, 1.0]), np.diag([9.0, 1.0])
    z = (10.0 + np.arange(40.0) + rng.normal(0.0, 2.0, 40))[:, None]
    if with_gaps:
        z[[5, 17, 18, 30]] = np.nan
    filtered = KalmanFilter(F=F, H=H, Q=Q, R=R, x0=x0, P0=P0).run(z)
    smoothed = rts_smoother(filtered, LinearMotion(F, Q))
    x_ls, P_ls = _batch_least_squares(F, H, Q, R, x0, P0, z)
    np.testing.assert_allclose(smoothed.x, x_ls, rtol=0, atol=1e-8)
    np.testing.assert_allclose(smoothed.P, P_ls, rtol=1e-8, atol=1e-10)
    # the last estimate is the filter's; every other variance is smaller than the filter's
    np.testing.assert_allclose(smoothed.x[-1], filtered.x[-1])
    assert np.all(smoothed.P[:-1, 0, 0] < filtered.P[:-1, 0, 0])


def test_smoother_of_a_batch_equals_the_smoother_of_each_run():
    rng = np.random.default_rng(1)
    z = 1500.0 - 2.0 * np.arange(200.0) + rng.normal(0.0, np.sqrt(2.0), (3, 200))
    res = robust_range_kf(z, 1.0, q=0.01)
    motion = ConstantVelocity(1, 0.01, step_lengths(200, 1.0))
    batch = rts_smoother(res, motion)
    for m in range(3):
        single = rts_smoother(robust_range_kf(z[m], 1.0, q=0.01), motion)
        np.testing.assert_allclose(single.x, batch.x[m], rtol=0, atol=1e-9)
        np.testing.assert_allclose(single.P, batch.P[m], rtol=1e-9, atol=1e-12)
    assert batch.gain.shape == (3, 200, 2, 2) and not batch.gain[:, -1].any()


def test_smoother_rejects_what_it_cannot_smooth():
    res = robust_range_kf(np.full(10, 1000.0), 1.0)
    with pytest.raises(TypeError, match="FilterResult"):
        rts_smoother({"x": res.x}, ConstantVelocity(1, 1.0, step_lengths(10)))
    with pytest.raises(TypeError, match="MotionModel"):
        rts_smoother(res, np.eye(2))
    with pytest.raises(ValueError, match="state has size 2"):
        rts_smoother(res, ConstantVelocity(2, 1.0, step_lengths(10)))
    assert isinstance(res, FilterResult)
