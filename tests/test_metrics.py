"""Metrics: RMSE, final-error CDF, NEES/NIS and their chi-square bounds."""

import numpy as np
import pytest
from scipy import stats

from uwtutor import metrics
from uwtutor.filters import FilterResult


def random_spd(rng, shape, n):
    A = rng.normal(size=shape + (n, n))
    return A @ np.swapaxes(A, -1, -2) + n * np.eye(n)


def test_rmse_by_hand():
    est = np.array([[[3.0, 4.0], [1.0, 1.0]], [[0.0, 0.0], [1.0, -1.0]]])      # M = 2, K = 2
    truth = np.array([[0.0, 0.0], [1.0, 0.0]])
    np.testing.assert_allclose(metrics.estimation_errors(est, truth), [[5.0, 1.0], [0.0, 1.0]])
    np.testing.assert_allclose(metrics.rmse_over_time(est, truth), [np.sqrt(12.5), 1.0])
    np.testing.assert_allclose(metrics.rmse_over_time(est, truth, components=[0]), [np.sqrt(4.5), 0.0])
    np.testing.assert_allclose(metrics.final_errors(est, truth), [1.0, 1.0])
    np.testing.assert_allclose(metrics.final_errors(est, truth, step=0), [5.0, 0.0])
    np.testing.assert_allclose(metrics.rmse_over_time(est[0], truth), [5.0, 1.0])     # one run
    np.testing.assert_allclose(metrics.rmse_over_time(est, np.broadcast_to(truth, (2, 2, 2))),
                               metrics.rmse_over_time(est, truth))


def test_error_cdf():
    values, probs = metrics.error_cdf([2.0, np.nan, 1.0, 3.0])
    np.testing.assert_array_equal(values, [1.0, 2.0, 3.0])
    np.testing.assert_allclose(probs, [1 / 3, 2 / 3, 1.0])
    with pytest.raises(ValueError, match="at least one value"):
        metrics.error_cdf([np.nan])


@pytest.mark.parametrize("n", [1, 2, 3])
def test_nees_matches_a_linear_solve(n):
    rng = np.random.default_rng(n)
    x = rng.normal(size=(4, 6, n))
    truth = rng.normal(size=(6, n))
    P = random_spd(rng, (4, 6), n)
    e = truth - x
    expected = np.einsum("...i,...i->...", e, np.linalg.solve(P, e[..., None])[..., 0])
    np.testing.assert_allclose(metrics.nees(x, P, truth), expected, rtol=1e-12)
    res = FilterResult(times=np.arange(6.0), x=x, P=P, x_prior=x, P_prior=P,
                       innovations=np.zeros((4, 6, 1)), innovation_cov=np.ones((4, 6, 1, 1)))
    np.testing.assert_allclose(metrics.nees(x, P, truth), res.nees(truth), rtol=1e-12)
    np.testing.assert_allclose(metrics.nees(x[0], P[0], truth), expected[:1], rtol=1e-12)


@pytest.mark.parametrize("m", [1, 2, 3])
def test_nis_with_missing_measurements(m):
    rng = np.random.default_rng(10 + m)
    y = rng.normal(size=(3, 5, m))
    S = random_spd(rng, (3, 5), m)
    y[1, 2] = np.nan
    S[1, 2] = np.nan
    out = metrics.nis(y, S)
    assert np.isnan(out[1, 2]) and np.isfinite(np.delete(out.ravel(), 7)).all()
    ok = np.isfinite(y).all(axis=-1)
    expected = np.einsum("...i,...i->...", y[ok], np.linalg.solve(S[ok], y[ok][..., None])[..., 0])
    np.testing.assert_allclose(out[ok], expected, rtol=1e-12)


def test_average_over_runs_ignores_nan():
    v = np.array([[1.0, np.nan, 2.0], [3.0, np.nan, np.nan]])
    mean, counts = metrics.average_over_runs(v)
    np.testing.assert_array_equal(counts, [2, 0, 1])
    np.testing.assert_allclose(mean, [2.0, np.nan, 2.0])


def test_chi2_bounds_formula_and_coverage():
    lo, hi = metrics.chi2_mean_bounds(2, 50, confidence=0.9)
    assert lo == pytest.approx(stats.chi2.ppf(0.05, 100) / 50)
    assert hi == pytest.approx(stats.chi2.ppf(0.95, 100) / 50)
    # coverage: means of 50 chi-square(2) values fall inside about 90 % of the time
    rng = np.random.default_rng(0)
    means = rng.chisquare(2, size=(20000, 50)).mean(axis=1)
    inside = metrics.fraction_within(means, lo, hi)
    assert abs(inside - 0.9) < 5 * np.sqrt(0.9 * 0.1 / 20000)
    lo_k, hi_k = metrics.chi2_mean_bounds(1, np.array([10, 0, 40]))
    assert np.isnan(lo_k[1]) and np.isnan(hi_k[1])
    assert lo_k[0] == pytest.approx(metrics.chi2_mean_bounds(1, 10)[0])
    assert hi_k[2] < hi_k[0]                                                    # more runs: tighter


def test_fraction_within():
    assert metrics.fraction_within([1.0, 2.0, 3.0, np.nan], 1.5, 3.0) == pytest.approx(2 / 3)
    assert metrics.fraction_within([1.0, 2.0], [0.0, 2.5], [1.5, 3.0]) == 0.5


@pytest.mark.parametrize("call, message", [
    (lambda: metrics.rmse_over_time(np.zeros((2, 3, 2)), np.zeros((4, 2))), "truth must have shape"),
    (lambda: metrics.rmse_over_time(np.zeros((2, 3, 2)), np.zeros((3, 2)), components=[2]), "components must"),
    (lambda: metrics.rmse_over_time(np.zeros(3), np.zeros(3)), "estimates must have 2 or 3 dimension"),
    (lambda: metrics.rmse_over_time(np.zeros((3, 2)), np.full((3, 2), np.nan)), "truth must be finite"),
    (lambda: metrics.final_errors(np.zeros((3, 2)), np.zeros((3, 2)), step=5), "step must be an integer"),
    (lambda: metrics.nees(np.zeros((3, 2)), np.zeros((3, 2, 2)), np.ones((3, 2))), "positive definite"),
    (lambda: metrics.nees(np.zeros((3, 2)), np.zeros((3, 3, 3)), np.ones((3, 2))), "covariances must have"),
    (lambda: metrics.nees(np.zeros((3, 3)), np.zeros((3, 3, 3)), np.ones((3, 3))), "positive definite"),
    (lambda: metrics.nis(np.ones((3, 1)), np.zeros((3, 1, 1))), "positive definite"),
    (lambda: metrics.nis(np.ones((3, 1)), np.ones((3, 2, 2))), "innovation_cov must have"),
    (lambda: metrics.chi2_mean_bounds(0, 10), "dof must be a positive integer"),
    (lambda: metrics.chi2_mean_bounds(2, 0), "n_runs must be a positive integer"),
    (lambda: metrics.chi2_mean_bounds(2, 2.5), "n_runs must be a positive integer"),
    (lambda: metrics.chi2_mean_bounds(2, 10, confidence=1.0), "confidence must lie strictly"),
    (lambda: metrics.fraction_within([np.nan], 0.0, 1.0), "at least one entry"),
])
def test_bad_input(call, message):
    with pytest.raises(ValueError, match=message):
        call()
