"""Monte Carlo studies: run_monte_carlo on the batched EKF and on a filter with known output."""

import numpy as np
import pytest

from uwtutor import metrics
from uwtutor.filters import FilterResult, range_only_ekf
from uwtutor.montecarlo import MonteCarloResult, run_monte_carlo


def ekf_draws(M=200, K=250, seed=7, q=0.3, r=2.0):
    """M draws of a vehicle circling a beacon at 200 m: DR noise in the truth, noisy ranges, some missing."""
    rng = np.random.default_rng(seed)
    theta = np.linspace(0.0, 2 * np.pi, K + 1)
    track = 200.0 * np.column_stack([np.cos(theta), np.sin(theta)])
    truth = track[1:] + np.cumsum(rng.normal(0.0, q, (M, K, 2)), axis=1)
    z = np.linalg.norm(truth, axis=-1) + rng.normal(0.0, r, (M, K))
    z[rng.random((M, K)) < 0.1] = np.nan
    P0 = np.eye(2) * 25.0
    x0 = track[0] + rng.multivariate_normal([0.0, 0.0], P0, M)
    return truth, dict(x0=x0, P0=P0, u=np.diff(track, axis=0), z=z, Q=np.eye(2) * q**2, R=r**2)


def test_ekf_study_is_consistent_and_scores_match_metrics():
    truth, inputs = ekf_draws()
    study = run_monte_carlo(range_only_ekf, truth, **inputs)
    assert isinstance(study, MonteCarloResult)
    assert study.n_runs == 200 and study.n_steps == 250
    res = study.result
    assert res.x.shape == (200, 250, 2)
    np.testing.assert_allclose(study.rmse, metrics.rmse_over_time(res.x, truth))
    np.testing.assert_allclose(study.final_errors, np.linalg.norm(res.x[:, -1] - truth[:, -1], axis=-1))
    np.testing.assert_allclose(study.nees, metrics.nees(res.x, res.P, truth))
    assert study.nees_bounds == metrics.chi2_mean_bounds(2, 200)
    assert study.nees_fraction_within() > 0.85
    assert study.nis_fraction_within() > 0.85
    lo, hi = study.nis_bounds
    assert lo.shape == hi.shape == (250,)
    values, probs = study.final_error_cdf()
    assert values.shape == (200,) and probs[-1] == 1.0
    assert study.final_error_percentile(50) == pytest.approx(np.median(study.final_errors))
    summary = study.summary()
    assert set(summary) >= {"final_rmse", "final_error_p95", "mean_nees", "nees_fraction_within", "mean_nis"}
    assert 1.7 < summary["mean_nees"] < 2.3 and 0.85 < summary["mean_nis"] < 1.15
    np.testing.assert_array_equal(study.times, np.arange(250.0))


def test_truth_shared_by_every_run():
    truth, inputs = ekf_draws(M=3, K=20)
    shared = truth[0]
    inputs = {**inputs, "z": np.broadcast_to(np.linalg.norm(shared, axis=-1), (3, 20))}
    a = run_monte_carlo(range_only_ekf, shared, **inputs)
    b = run_monte_carlo(range_only_ekf, np.broadcast_to(shared, (3, 20, 2)), **inputs)
    np.testing.assert_array_equal(a.errors, b.errors)
    assert a.nis.shape == (3, 20)


def known_filter(M=4, K=3, n=3):
    """A 'filter' returning fixed estimates: x = truth + 1 in every component, P = I, innovations 2, S = 4."""
    def fn(offset):
        x = np.zeros((M, K, n)) + offset
        P = np.broadcast_to(np.eye(n), (M, K, n, n)).copy()
        y = np.full((M, K, 1), 2.0)
        y[0, 1] = np.nan
        S = np.full((M, K, 1, 1), 4.0)
        return FilterResult(times=np.arange(K, dtype=float), x=x, P=P, x_prior=x, P_prior=P, innovations=y,
                            innovation_cov=S)
    return fn


def test_scores_of_a_known_filter_and_components():
    study = run_monte_carlo(known_filter(), np.zeros((3, 3)), offset=1.0)
    np.testing.assert_allclose(study.errors, np.sqrt(3.0))
    np.testing.assert_allclose(study.mean_nees, 3.0)
    np.testing.assert_allclose(study.mean_nis, 1.0)
    np.testing.assert_array_equal(study.nis_bounds[0][1] == metrics.chi2_mean_bounds(1, 3)[0], True)
    assert study.nees_bounds == metrics.chi2_mean_bounds(3, 4)
    position = run_monte_carlo(known_filter(), np.zeros((3, 3)), components=[0, 1], offset=1.0)
    assert position.components == (0, 1) and position.truth.shape == (4, 3, 2)
    np.testing.assert_allclose(position.errors, np.sqrt(2.0))
    np.testing.assert_allclose(position.mean_nees, 2.0)
    assert position.nees_bounds == metrics.chi2_mean_bounds(2, 4, 0.95)
    looser = run_monte_carlo(known_filter(), np.zeros((3, 3)), confidence=0.99, offset=1.0)
    assert looser.nees_bounds[0] < study.nees_bounds[0] and looser.nees_bounds[1] > study.nees_bounds[1]


def test_single_run_result_counts_as_one_run():
    truth, inputs = ekf_draws(M=1, K=50)
    one = {**inputs, "x0": inputs["x0"][0], "z": inputs["z"][0]}
    study = run_monte_carlo(range_only_ekf, truth[0], **one)
    assert study.n_runs == 1 and study.nees.shape == (1, 50) and study.nis.shape == (1, 50)


def test_result_without_innovations_has_no_nis():
    class Bare:
        def __init__(self):
            self.x = np.zeros((2, 4, 2))
            self.P = np.broadcast_to(np.eye(2), (2, 4, 2, 2))
            self.times = np.arange(4.0)

    study = run_monte_carlo(lambda: Bare(), np.ones((4, 2)))
    assert study.nis is None and study.mean_nis is None and "mean_nis" not in study.summary()
    with pytest.raises(ValueError, match="no NIS"):
        study.nis_fraction_within()


@pytest.mark.parametrize("call, error, message", [
    (lambda: run_monte_carlo("ekf", np.zeros((3, 3))), TypeError, "filter_fn must be"),
    (lambda: run_monte_carlo(known_filter(), np.zeros((5, 3)), offset=0.0), ValueError, "truth must have shape"),
    (lambda: run_monte_carlo(known_filter(), np.full((3, 3), np.nan), offset=0.0), ValueError,
     "truth must be finite"),
    (lambda: run_monte_carlo(known_filter(), np.zeros((3, 3)), components=[3], offset=0.0), ValueError,
     "components must be"),
    (lambda: run_monte_carlo(known_filter(), np.zeros((3, 3)), confidence=1.5, offset=0.0), ValueError,
     "confidence must lie"),
    (lambda: run_monte_carlo(lambda: object(), np.zeros((3, 3))), TypeError, "filter_fn must return a FilterResult"),
])
def test_bad_input(call, error, message):
    with pytest.raises(error, match=message):
        call()


def test_percentile_range():
    study = run_monte_carlo(known_filter(), np.zeros((3, 3)), offset=1.0)
    with pytest.raises(ValueError, match="q must be a percentage"):
        study.final_error_percentile(120)


def test_a_truth_that_only_broadcasts_is_refused():
    """A (K, 1) truth against (K, 2) estimates is a mistake, not something to broadcast."""
    import numpy as np
    import pytest

    from uwtutor.filters import range_only_ekf
    from uwtutor.montecarlo import run_monte_carlo

    K = 20
    u = np.tile([1.0, 0.0], (K, 1))
    z = np.linalg.norm(np.array([100.0, 50.0]) + np.cumsum(u, axis=0), axis=1)
    with pytest.raises(ValueError, match="truth must have shape"):
        run_monte_carlo(range_only_ekf, np.zeros((K, 1)), x0=np.full((3, 2), 100.0), P0=np.eye(2), u=u, z=z,
                        Q=np.eye(2) * 0.1, R=1.0)


# --- one scoring for both studies (issue 27): run_monte_carlo and run_study score a result with the same code -------
def _fixed_result(x, P):
    from types import SimpleNamespace
    return SimpleNamespace(x=x, P=P, times=np.arange(x.shape[1], dtype=float))


def _both_studies(x, P, truth):
    """Score the same fixed result with run_monte_carlo and with a one-chunk run_study."""
    from uwtutor.montecarlo import run_study

    def draw(rng, n):
        return None, truth

    mc = run_monte_carlo(lambda: _fixed_result(x, P), truth)
    st = run_study(draw, lambda inputs: _fixed_result(x, P), x.shape[0], seed=0, chunk_size=x.shape[0])
    return mc, st


def test_both_studies_give_the_same_scores():
    truth, inputs = ekf_draws(M=6, K=30)
    res = range_only_ekf(**inputs)
    mc, st = _both_studies(res.x, res.P, truth)
    np.testing.assert_allclose(st.rmse, mc.rmse, rtol=1e-14)
    np.testing.assert_allclose(st.mean_nees, mc.mean_nees, rtol=1e-14)
    np.testing.assert_array_equal(st.final_errors, mc.final_errors)
    assert st.nees_bounds == mc.nees_bounds


def test_a_collapsed_covariance_gives_an_infinite_nees_in_both_studies():
    """A zero covariance (a particle cloud reduced to one particle) is a result: NEES = inf, not an exception."""
    x = np.ones((3, 4, 2))
    P = np.broadcast_to(np.eye(2), (3, 4, 2, 2)).copy()
    P[1, 2] = 0.0
    mc, st = _both_studies(x, P, np.zeros((4, 2)))
    assert np.isinf(mc.nees[1, 2]) and np.isfinite(np.delete(mc.nees.ravel(), 1 * 4 + 2)).all()
    assert np.isinf(mc.mean_nees[2]) and np.isinf(st.mean_nees[2])
    np.testing.assert_array_equal(np.delete(mc.mean_nees, 2), np.delete(st.mean_nees, 2))


def test_a_diverged_run_makes_the_mean_nees_nan_in_both_studies():
    """A NaN estimate is not hidden by leaving its run out of the mean."""
    x = np.ones((3, 4, 2))
    x[0, 3] = np.nan
    P = np.broadcast_to(np.eye(2), (3, 4, 2, 2)).copy()
    mc, st = _both_studies(x, P, np.zeros((4, 2)))
    assert np.isnan(mc.mean_nees[3]) and np.isnan(st.mean_nees[3])
    assert np.isnan(mc.rmse[3]) and np.isnan(st.rmse[3])
    np.testing.assert_array_equal(mc.mean_nees[:3], np.full(3, 2.0))
