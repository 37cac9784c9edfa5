"""The range-only EKF: batched == single run == object form == filterpy, consistency, and bad input."""

import warnings

import numpy as np
import pytest
from filterpy.kalman import ExtendedKalmanFilter
from hypothesis import given, settings
from hypothesis import strategies as st

from uwtutor import metrics
from uwtutor.filters import BeaconSingularityWarning, RangeOnlyEKF, range_only_ekf

TOL = dict(rtol=1e-9, atol=1e-9)


def circling_study(M=6, K=120, seed=0, radius=300.0, centre=(150.0, 0.0), q=0.4, r=2.0, p0=20.0,
                   missing=0.15, beacon=(0.0, 0.0)):
    """A vehicle circling near the beacon: truth, DR displacements, ranges (some missing) and filter inputs."""
    rng = np.random.default_rng(seed)
    theta = np.linspace(0.0, 3 * np.pi, K + 1)
    track = np.asarray(centre) + radius * np.column_stack([np.cos(theta), np.sin(theta)])
    truth = track[1:] + np.cumsum(rng.normal(0.0, q, (M, K, 2)), axis=1)
    u = np.broadcast_to(np.diff(track, axis=0), (M, K, 2)).copy()
    z = np.linalg.norm(truth - np.asarray(beacon), axis=-1) + rng.normal(0.0, r, (M, K))
    z[rng.random((M, K)) < missing] = np.nan
    P0 = np.eye(2) * p0**2
    x0 = track[0] + rng.normal(0.0, p0, (M, 2))
    return dict(x0=x0, P0=P0, u=u, z=z, Q=np.eye(2) * q**2, R=r**2, beacon=np.asarray(beacon, float)), truth


def filterpy_run(x0, P0, u, z, Q, R, beacon):
    """filterpy's ExtendedKalmanFilter (F = B = I) stepped in a Python loop over one run."""
    b = np.asarray(beacon, float).reshape(2, 1)

    def hx(x):
        return np.array([[np.linalg.norm(x - b)]])

    def jac(x):
        d = (x - b)[:, 0]
        return (d / np.linalg.norm(d))[None, :]

    ekf = ExtendedKalmanFilter(dim_x=2, dim_z=1, dim_u=2)
    ekf.x = np.array(x0, float).reshape(2, 1)
    ekf.P = np.array(P0, float)
    ekf.F = np.eye(2)
    ekf.B = np.eye(2)
    ekf.Q = np.array(Q, float)
    ekf.R = np.array([[R]])
    out = {k: [] for k in ("x", "P", "x_prior", "P_prior", "y", "S")}
    for uk, zk in zip(u, z):
        ekf.predict(u=np.asarray(uk).reshape(2, 1))
        out["x_prior"].append(ekf.x[:, 0].copy())
        out["P_prior"].append(ekf.P.copy())
        if np.isnan(zk):
            out["y"].append(np.nan)
            out["S"].append(np.nan)
        else:
            ekf.update(np.array([[zk]]), jac, hx)
            out["y"].append(ekf.y[0, 0])
            out["S"].append(ekf.S[0, 0])
        out["x"].append(ekf.x[:, 0].copy())
        out["P"].append(ekf.P.copy())
    return {k: np.array(v) for k, v in out.items()}


# --- agreement of the implementations --------------------------------------------------------------------------

@pytest.mark.parametrize("beacon", [(0.0, 0.0), (120.0, -40.0)])
def test_batched_equals_filterpy_loop(beacon):
    inputs, _ = circling_study(M=5, K=150, seed=3, beacon=beacon)
    assert np.isnan(inputs["z"]).any()
    res = range_only_ekf(**inputs)
    for m in range(5):
        ref = filterpy_run(inputs["x0"][m], inputs["P0"], inputs["u"][m], inputs["z"][m], inputs["Q"],
                           inputs["R"], inputs["beacon"])
        np.testing.assert_allclose(res.x[m], ref["x"], **TOL)
        np.testing.assert_allclose(res.P[m], ref["P"], **TOL)
        np.testing.assert_allclose(res.x_prior[m], ref["x_prior"], **TOL)
        np.testing.assert_allclose(res.P_prior[m], ref["P_prior"], **TOL)
        np.testing.assert_allclose(res.innovations[m, :, 0], ref["y"], **TOL)    # NaN where missing, too
        np.testing.assert_allclose(res.innovation_cov[m, :, 0, 0], ref["S"], **TOL)


def test_shared_inputs_broadcast_over_runs():
    inputs, _ = circling_study(M=4, K=30, seed=8)
    full = range_only_ekf(**inputs)
    shared_x0 = range_only_ekf(inputs["x0"][0], inputs["P0"], inputs["u"], inputs["z"], inputs["Q"], inputs["R"])
    assert shared_x0.x.shape == (4, 30, 2)
    np.testing.assert_allclose(shared_x0.x[0], full.x[0], **TOL)
    shared_u = range_only_ekf(inputs["x0"], np.broadcast_to(inputs["P0"], (4, 2, 2)), inputs["u"][0],
                              inputs["z"], inputs["Q"], inputs["R"])
    np.testing.assert_allclose(shared_u.x, full.x, **TOL)           # u is the same in every run here


def test_missing_range_predicts_only():
    inputs, _ = circling_study(M=2, K=20, seed=4, missing=0.0)
    inputs["z"][:, 5] = np.nan
    res = range_only_ekf(**inputs)
    np.testing.assert_array_equal(res.x[:, 5], res.x_prior[:, 5])
    np.testing.assert_array_equal(res.P[:, 5], res.P_prior[:, 5])
    assert np.isnan(res.innovations[:, 5]).all() and np.isnan(res.innovation_cov[:, 5]).all()
    assert not res.extras["updated"][:, 5].any() and res.extras["updated"][:, 4].all()
    np.testing.assert_array_equal(res.x_prior[:, 6], res.x[:, 5] + inputs["u"][:, 6])
    ekf = RangeOnlyEKF([10.0, 0.0], np.eye(2), np.eye(2) * 0.1, 1.0)
    ekf.predict([1.0, 0.0])
    x, P = ekf.x, ekf.P
    ekf.update(np.nan)
    np.testing.assert_array_equal(ekf.x, x)
    np.testing.assert_array_equal(ekf.P, P)
    assert np.isnan(ekf.y).all() and np.isnan(ekf.S).all()


def test_covariance_stays_symmetric_positive_definite():
    inputs, _ = circling_study(M=20, K=300, seed=9, r=0.01, p0=200.0)     # very precise ranges: stiff updates
    res = range_only_ekf(**inputs)
    np.testing.assert_array_equal(res.P[..., 0, 1], res.P[..., 1, 0])
    assert (np.linalg.eigvalsh(res.P) > 0).all()


def test_prediction_on_the_beacon_skips_the_update_with_a_warning():
    u = np.array([[-10.0, 0.0], [5.0, 0.0], [5.0, 0.0]])
    z = np.array([3.0, 4.0, 8.0])
    with pytest.warns(BeaconSingularityWarning, match="exactly on the beacon"):
        res = range_only_ekf([10.0, 0.0], np.eye(2) * 4.0, u, z, np.eye(2) * 0.1, 1.0)
    assert np.isfinite(res.x).all() and np.isfinite(res.P).all()
    np.testing.assert_array_equal(res.x[0], [0.0, 0.0])                  # step 0: predict only
    np.testing.assert_array_equal(res.P[0], res.P_prior[0])
    assert np.isnan(res.innovations[0]).all()
    assert list(res.extras["updated"]) == [False, True, True]
    ekf = RangeOnlyEKF([3.0, 4.0], np.eye(2), np.eye(2), 1.0, beacon=(3.0, 4.0))
    with pytest.warns(BeaconSingularityWarning):
        ekf.update(2.0)
    np.testing.assert_array_equal(ekf.x, [3.0, 4.0])
    with warnings.catch_warnings():                                      # no range: nothing to warn about
        warnings.simplefilter("error")
        ekf.update(np.nan)


# --- statistics -------------------------------------------------------------------------------------------------

def test_consistency_nees_and_nis_within_chi2_bounds():
    M, K = 300, 400
    inputs, truth = circling_study(M=M, K=K, seed=21, radius=250.0, centre=(400.0, 0.0), q=0.3, r=1.5,
                                   p0=10.0, missing=0.1)
    res = range_only_ekf(**inputs)
    mean_nees, _ = metrics.average_over_runs(metrics.nees(res.x, res.P, truth))
    lo, hi = metrics.chi2_mean_bounds(2, M)
    assert metrics.fraction_within(mean_nees, lo, hi) >= 0.85
    lo_all, hi_all = metrics.chi2_mean_bounds(2, M * K, confidence=0.999)  # the grand mean, looser: correlated
    assert 0.9 * lo_all < mean_nees.mean() < 1.1 * hi_all
    mean_nis, counts = metrics.average_over_runs(metrics.nis(res.innovations, res.innovation_cov))
    nis_lo, nis_hi = metrics.chi2_mean_bounds(1, counts)
    assert metrics.fraction_within(mean_nis, nis_lo, nis_hi) >= 0.85
    np.testing.assert_allclose(res.nees(truth), metrics.nees(res.x, res.P, truth), rtol=1e-10)


def test_filter_converges_on_a_circling_track():
    inputs, truth = circling_study(M=50, K=300, seed=1, missing=0.0)
    res = range_only_ekf(**inputs)
    rmse = metrics.rmse_over_time(res.x, truth)
    assert rmse[-1] < 0.3 * rmse[0]


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), M=st.integers(1, 4), K=st.integers(1, 25))
def test_property_batched_runs_are_independent(seed, M, K):
    rng = np.random.default_rng(seed)
    x0 = rng.normal(0.0, 100.0, (M, 2))
    u = rng.normal(0.0, 5.0, (M, K, 2))
    z = np.abs(rng.normal(50.0, 30.0, (M, K)))
    z[rng.random((M, K)) < 0.3] = np.nan
    Q = np.diag(rng.uniform(0.0, 2.0, 2))
    res = range_only_ekf(x0, np.eye(2) * 50.0, u, z, Q, 4.0)
    assert res.x.shape == (M, K, 2)
    for m in range(M):
        one = range_only_ekf(x0[m], np.eye(2) * 50.0, u[m], z[m], Q, 4.0)
        np.testing.assert_allclose(res.x[m], one.x, **TOL)
    assert (np.linalg.eigvalsh(res.P) > 0).all()


# --- bad input --------------------------------------------------------------------------------------------------

def good_args(M=2, K=5):
    return dict(x0=np.zeros((M, 2)) + [100.0, 0.0], P0=np.eye(2), u=np.ones((M, K, 2)),
                z=np.full((M, K), 100.0), Q=np.eye(2) * 0.1, R=1.0)


@pytest.mark.parametrize("change, message", [
    (dict(x0=[1.0, 2.0, 3.0]), "x0 must be a horizontal position"),
    (dict(x0=[np.nan, 0.0]), "x0 must be finite"),
    (dict(P0=np.eye(3)), "P0 must be 2x2"),
    (dict(P0=-np.eye(2)), "P0 must be positive definite"),
    (dict(u=np.ones((2, 5, 3))), "u must hold displacements"),
    (dict(u=np.ones((5,))), "u must have 2 or 3 dimension"),
    (dict(u=np.full((2, 5, 2), np.nan)), "u must be finite"),
    (dict(z=np.full((2, 4), 100.0)), "z must have one range per step"),
    (dict(z=np.full((2, 5), -1.0)), "z must be finite and >= 0"),
    (dict(z=np.full((2, 5), np.inf)), "z must be finite and >= 0"),
    (dict(z=np.full((3, 5), 100.0)), "disagree on the number of runs"),
    (dict(Q=[[1.0, 2.0], [2.0, 1.0]]), "Q must be positive semi-definite"),
    (dict(Q=[[1.0, 0.5], [0.0, 1.0]]), "Q must be symmetric"),
    (dict(Q=np.eye(3)), "Q must be 2x2"),
    (dict(R=0.0), "R must be positive definite"),
    (dict(R=-1.0), "R must be positive definite"),
    (dict(R=np.eye(2)), "R must be 1x1"),
    (dict(beacon=(0.0, 0.0, 0.0)), "beacon must be a position"),
    (dict(u=np.ones((2, 0, 2)), z=np.ones((2, 0))), "number of steps K must be >= 1"),
])
def test_bad_input_names_the_argument(change, message):
    args = good_args()
    args.update(change)
    with pytest.raises(ValueError, match=message):
        range_only_ekf(**args)


def test_object_form_bad_input():
    ekf = RangeOnlyEKF([100.0, 0.0], np.eye(2), np.eye(2), 1.0)
    with pytest.raises(ValueError, match="u must have shape"):
        ekf.predict([1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="z must be finite and >= 0"):
        ekf.update(-3.0)
    with pytest.raises(ValueError, match="z must have shape"):
        ekf.update([1.0, 2.0])
    with pytest.raises(ValueError, match="R must be positive definite"):
        RangeOnlyEKF([0.0, 1.0], np.eye(2), np.eye(2), 0.0)
    with pytest.raises(ValueError, match="P must be positive definite"):
        ekf.P = np.zeros((2, 2))
    ekf.x = [1.0, 2.0]
    ekf.P = np.eye(2) * 3.0
    np.testing.assert_array_equal(ekf.x, [1.0, 2.0])
    np.testing.assert_array_equal(ekf.P, np.eye(2) * 3.0)


def test_blocks_of_steps_equal_one_step_at_a_time():
    """range_only_ekf runs blocks of steps and tests their posteriors together; a step that fails the test -- a
    prediction exactly on the beacon (step 39, warned once), updates that only the line-of-sight form keeps PSD
    (P0 = 1e150 I with R = 1e-6, first range at step 40) -- is done again with the step's own tests. The result is
    the object form's, predict and update one step at a time, bit for bit."""
    M, K = 3, 100
    rng = np.random.default_rng(4)
    x0 = np.array([[10.0, 0.0], [300.0, 40.0], [-200.0, 90.0]])
    u = np.tile([-0.25, 0.0], (M, K, 1))                      # run 0 reaches the beacon at step 39 exactly
    z = np.linalg.norm(x0[:, None, :] + np.cumsum(u, axis=1), axis=-1) + rng.normal(0.0, 1.0, (M, K))
    z[0, :39] = np.nan                                          # predict only until then: no update moves run 0
    z[0, 39] = 5.0
    for P0, R, first in ((np.eye(2) * 400.0, 4.0, 0), (np.eye(2) * 1e150, 1e-6, 40)):
        z_case = z.copy()
        z_case[1:, :first] = np.nan
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            res = range_only_ekf(x0, P0, u, z_case, np.eye(2) * 1e-12, R)
        one = RangeOnlyEKF(x0, P0, np.eye(2) * 1e-12, R)
        with warnings.catch_warnings(record=True) as caught_one:
            warnings.simplefilter("always")
            for k in range(K):
                one.predict(u[:, k])
                one.update(z_case[:, k])
                np.testing.assert_array_equal(res.x[:, k], one.x)
                np.testing.assert_array_equal(res.P[:, k], one.P)
                np.testing.assert_array_equal(res.innovations[:, k], one.y)
                np.testing.assert_array_equal(res.extras["updated"][:, k], one.updated)
        beacon = [w for w in caught if issubclass(w.category, BeaconSingularityWarning)]
        assert len(beacon) == len([w for w in caught_one if issubclass(w.category, BeaconSingularityWarning)]) == 1
        assert not res.extras["updated"][0, 39] and np.isnan(res.innovations[0, 39, 0])
