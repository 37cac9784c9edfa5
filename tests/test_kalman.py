"""The linear Kalman filter and the filter protocol (run_filter, FilterResult)."""

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter as FilterpyKF

from uwtutor.filters import FilterResult, KalmanFilter, run_filter


def make_cv(x0=(100.0, -1.0), **kw):
    args = dict(dt=2.0, q=0.05, r=9.0, x0=x0, P0=np.diag([25.0, 1.0]))
    args.update(kw)
    return KalmanFilter.constant_velocity(**args)


def noisy_ranges(seed=1, n=40):
    rng = np.random.default_rng(seed)
    return 100.0 - 1.2 * 2.0 * np.arange(n) + rng.normal(0.0, 3.0, n)


def test_matches_filterpy_step_by_step():
    zs = noisy_ranges()
    ours = make_cv()
    ref = FilterpyKF(dim_x=2, dim_z=1)
    ref.x = np.array([[100.0], [-1.0]])
    ref.P = np.diag([25.0, 1.0])
    ref.F, ref.H, ref.Q, ref.R = ours.F.copy(), ours.H.copy(), ours.Q.copy(), ours.R.copy()
    for z in zs:
        ours.predict()
        ref.predict()
        ours.update(z)
        ref.update(z)
        np.testing.assert_allclose(ours.x, ref.x[:, 0], rtol=0, atol=1e-9)
        np.testing.assert_allclose(ours.P, ref.P, rtol=0, atol=1e-9)
        np.testing.assert_allclose(ours.y, ref.y[:, 0], rtol=0, atol=1e-9)
        np.testing.assert_allclose(ours.S, ref.S, rtol=0, atol=1e-9)


def test_control_input_moves_the_prediction():
    kf = KalmanFilter(F=np.eye(2), H=[[1.0, 0.0]], Q=np.eye(2), R=1.0, x0=[0.0, 0.0], P0=np.eye(2),
                      B=np.eye(2))
    kf.predict([3.0, -4.0])
    np.testing.assert_array_equal(kf.x, [3.0, -4.0])
    with pytest.raises(ValueError, match="no input matrix B"):
        make_cv().predict([1.0, 2.0])


def test_result_fields_and_consistency_statistics():
    rng = np.random.default_rng(3)
    n_runs, n_steps = 400, 60
    truth = 100.0 - 2.0 * np.arange(n_steps)                    # a constant rate: the model is right
    zs = truth + rng.normal(0.0, 3.0, (n_runs, n_steps))
    # x0 describes the state one step before the first measurement (the filter predicts, then updates)
    x0 = np.column_stack([truth[0] + 2.0 + rng.normal(0, 5.0, n_runs), -2.0 + rng.normal(0, 1.0, n_runs)])
    kf = KalmanFilter.constant_velocity(dt=1.0, q=1e-6, r=9.0, x0=x0, P0=np.diag([25.0, 1.0]))
    result = kf.run(zs, times=np.arange(n_steps))
    assert isinstance(result, FilterResult) and result.n_steps == n_steps
    nis = result.nis()
    assert nis.shape == (n_runs, n_steps)
    assert abs(np.mean(nis) - 1.0) < 0.1                         # chi-square with 1 dof has mean 1
    states = np.stack([truth, np.full(n_steps, -2.0)], axis=-1)
    nees = result.nees(states)
    assert abs(np.mean(nees) - 2.0) < 0.2                        # chi-square with 2 dof has mean 2
    assert set(result.as_dict()) >= {"x", "P", "innovations", "times"}


def test_run_filter_validates_its_inputs():
    with pytest.raises(ValueError, match="times must have one entry per step"):
        run_filter(make_cv(), [1.0, 2.0, 3.0], times=[0.0, 1.0])
    with pytest.raises(ValueError, match="u must give one input per step"):
        run_filter(make_cv(), [1.0, 2.0, 3.0], u=np.zeros((2, 1)))
    with pytest.raises(ValueError, match="truth must broadcast"):
        make_cv().run([1.0, 2.0]).nees(np.zeros((5, 2)))


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(Q=[[1.0, 0.0], [0.0, -1.0]]), "Q must be positive semi-definite"),
        (dict(R=[[0.0]]), "R must be positive definite"),
        (dict(P0=[[1.0, 2.0], [2.0, 1.0]]), "P0 must be positive definite"),
        (dict(P0=[[1.0, 0.5], [0.0, 1.0]]), "P0 must be symmetric"),
        (dict(x0=[np.nan, 0.0]), "x0 must be finite"),
        (dict(x0=[1.0, 2.0, 3.0]), "x0 must have 2 entries"),
        (dict(H=[[1.0, 0.0, 0.0]]), "H must have 2 columns"),
        (dict(F=[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]), "F must be square"),
    ],
)
def test_bad_construction_is_rejected_clearly(kwargs, message):
    args = dict(F=np.eye(2), H=[[1.0, 0.0]], Q=np.eye(2), R=[[1.0]], x0=[0.0, 0.0], P0=np.eye(2))
    args.update(kwargs)
    with pytest.raises(ValueError, match=message):
        KalmanFilter(**args)


def test_bad_measurements_are_rejected_clearly():
    kf = make_cv()
    kf.predict()
    with pytest.raises(ValueError, match="z must be finite, or NaN"):
        kf.update(np.inf)
    with pytest.raises(ValueError, match="dt must be > 0"):
        make_cv(dt=-1.0)
    with pytest.raises(ValueError, match="q must be >= 0"):
        make_cv(q=-0.1)
