"""The methods registry and the common suite of chapter 10: every method runs on every scenario it claims."""

from __future__ import annotations

import pickle
import warnings

import numpy as np
import pytest

from uwtutor import methods
from uwtutor.filters import FilterResult
from uwtutor.observability import posterior_crlb, rmse_bound
from uwtutor.scenarios import suite

CLAIMED = [(m, s) for m, scen in methods.claims().items() for s in scen]


def _draw(scenario: str, condition: str, n: int, seed: int = 11):
    rng = np.random.default_rng(seed)
    return suite.CONDITIONS[condition](rng, suite.SCENARIOS[scenario](rng, n))


@pytest.mark.parametrize("condition", list(suite.CONDITIONS))
@pytest.mark.parametrize("method, scenario", CLAIMED)
def test_every_method_runs_on_every_scenario_it_claims(method, scenario, condition):
    inputs, truth = _draw(scenario, condition, 4)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")              # geometry warnings are part of what the table measures
        res = methods.get(method)(inputs)
    assert isinstance(res, FilterResult)
    n, K = inputs.n_runs, inputs.n_epochs
    assert res.x.shape[:2] == (n, K) and res.x.shape[-1] >= 2
    assert res.P.shape == res.x.shape + (res.x.shape[-1],)
    np.testing.assert_array_equal(res.times, inputs.times)
    assert np.isfinite(res.x[..., :2]).all(), "every epoch has a position estimate (DR before a late start)"
    P = res.P[..., :2, :2]
    has_cov = np.isfinite(P).all(axis=(-1, -2))
    if method == "grid pre-location":
        assert not has_cov.any()                      # no covariance of its own: NaN, not invented
    else:
        assert has_cov.all()
        np.testing.assert_allclose(P, np.swapaxes(P, -1, -2), atol=1e-9 * np.abs(P).max())
        assert (np.linalg.eigvalsh(P) >= -1e-9 * np.abs(P).max()).all()
    assert truth.shape == (n, K, 2)


def test_claims_match_the_needs():
    claims = methods.claims()
    assert claims["cooperative EKF"] == ["moving beacon"]
    for name in ("grid pre-location", "pre-positioned IEKF", "SFEKF", "ISFEKF", "LS-ISFEKF"):
        assert "moving beacon" not in claims[name] and len(claims[name]) == 4
    for name in ("EKF", "IEKF", "LS pre-positioning", "OR-VMLBL-KF", "particle filter", "gated EKF"):
        assert claims[name] == list(suite.SCENARIOS)
    assert len(methods.names()) == len(set(methods.names())) == 12


def test_a_method_refuses_a_scenario_it_does_not_claim():
    with pytest.raises(ValueError, match="needs a fixed beacon"):
        methods.run("ISFEKF", "moving beacon", "white", np.random.default_rng(0), 2)
    with pytest.raises(ValueError, match="moving beacon"):
        methods.isfekf(_draw("moving beacon", "white", 2)[0])
    with pytest.raises(ValueError, match="needs a leader"):
        methods.run("cooperative EKF", "circle", "white", np.random.default_rng(0), 2)


@pytest.mark.parametrize("call, match", [
    (lambda: methods.get("EKF2"), "no method called 'EKF2'"),
    (lambda: methods.run("EKF", "square", "white", np.random.default_rng(0)), "scenario must be one of"),
    (lambda: methods.run("EKF", "circle", "pink", np.random.default_rng(0)), "condition must be one of"),
    (lambda: methods.run("EKF", "circle", "white", np.random.default_rng(0), 0), "n_runs"),
    (lambda: methods.compare_suite(10, 1, scenarios=["square"]), "scenarios must be names"),
    (lambda: methods.compare_suite(10, 1, methods=["cooperative EKF"], scenarios=["circle"]), "none of the methods"),
    (lambda: suite.crlb_inputs("circle", "pink"), "condition must be one of"),
])
def test_bad_names_are_refused_by_name(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_a_method_takes_suite_inputs_only():
    with pytest.raises(TypeError, match="SuiteInputs"):
        methods.ekf({"z": np.zeros((2, 3))})
    with pytest.raises(TypeError, match="SuiteRuns"):
        suite.white(np.random.default_rng(0), np.zeros((2, 3, 2)))


def test_the_suite_draws_are_reproducible_and_shared_by_the_methods():
    a, ta = _draw("turn", "outliers", 5, seed=3)
    b, tb = _draw("turn", "outliers", 5, seed=3)
    for name in ("x0", "u", "z", "z0", "beacon"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert a.method_seed == b.method_seed
    c, _ = _draw("turn", "outliers", 5, seed=4)
    assert not np.array_equal(a.z, c.z)
    # the particle filter draws from the inputs' seed only: the same inputs give the same estimates
    np.testing.assert_array_equal(methods.particle_filter(a).x, methods.particle_filter(b).x)


def test_the_runs_follow_the_filters_model():
    p = suite.PARAMETERS
    runs = suite.SCENARIOS["circle"](np.random.default_rng(2), 2000)
    start_error = runs.positions[:, 0] - runs.planned[0]
    np.testing.assert_allclose(start_error.std(axis=0), p.start_sigma, rtol=0.05)
    steps = np.diff(runs.positions - runs.planned, axis=1)        # p_k = p_{k-1} + u_k + w_k
    np.testing.assert_allclose(steps.std(axis=(0, 1)), p.dr_sigma, rtol=0.01)
    assert abs(np.corrcoef(steps[:, 3, 0], steps[:, 4, 0])[0, 1]) < 0.1
    inputs, truth = suite.white(np.random.default_rng(3), runs)
    np.testing.assert_array_equal(inputs.x0, np.broadcast_to(runs.planned[0], (2000, 2)))
    np.testing.assert_allclose(inputs.dr_track(), np.broadcast_to(runs.planned[1:], (2000, 150, 2)), atol=1e-9)


def test_the_conditions_corrupt_what_they_say():
    p = suite.PARAMETERS
    runs = suite.SCENARIOS["circle"](np.random.default_rng(0), 400)
    true_r = np.linalg.norm(runs.positions[:, 1:] - runs.beacon[:, 1:], axis=-1)
    white, truth = suite.white(np.random.default_rng(1), runs)
    np.testing.assert_array_equal(truth, runs.positions[:, 1:])
    assert abs(np.std(white.z - true_r) - p.range_sigma) < 0.05
    speed, _ = suite.sound_speed(np.random.default_rng(1), runs)
    assert abs(np.mean(speed.z / true_r) - p.assumed_speed / p.true_speed) < 1e-3
    biased, _ = suite.bias(np.random.default_rng(1), runs)
    assert abs(np.mean(biased.z - true_r) - p.bias_mean) < 1.0
    bad, _ = suite.outliers(np.random.default_rng(1), runs)
    hit = np.abs(bad.z - true_r) > 40.0
    assert 0.03 < hit.mean() < 0.03 + 10 / 150 + 0.01
    drift, carried = suite.current(np.random.default_rng(1), runs)
    elapsed = runs.times[1:, None] - runs.times[0]
    drift_expected = np.broadcast_to(np.asarray(p.current_velocity) * elapsed, carried.shape)
    np.testing.assert_allclose(carried - runs.positions[:, 1:], drift_expected, atol=1e-9)
    np.testing.assert_array_equal(drift.u, white.u)           # the DR does not see the current
    drifted_r = np.linalg.norm(carried - runs.beacon[:, 1:], axis=-1)
    assert abs(np.std(drift.z - drifted_r) - p.range_sigma) < 0.05


def test_the_moving_beacon_changes_bearing_without_a_turn():
    runs = suite.moving_beacon(np.random.default_rng(0), 1)
    rel = runs.planned - runs.beacon[0]
    bearing = np.unwrap(np.arctan2(rel[:, 1], rel[:, 0]))
    assert np.ptp(bearing) > np.pi / 2
    heading = np.arctan2(*np.diff(runs.planned, axis=0)[:, ::-1].T)
    assert np.ptp(heading) == 0.0


@pytest.mark.parametrize("scenario", list(suite.SCENARIOS))
def test_the_bounds_shrink_and_the_extra_states_cost_information(scenario):
    bounds = methods.suite_bounds([scenario])
    white = bounds[(scenario, "white")]
    p = suite.PARAMETERS
    assert white[0] < np.hypot(p.start_sigma, p.start_sigma)           # the first range already informs
    assert white[-1] < 0.3 * white[0]
    for harder in ("bias", "sound speed"):      # the same tracks, less information (the current moves the tracks)
        assert (bounds[(scenario, harder)] >= white - 1e-9).all()
    np.testing.assert_array_equal(bounds[(scenario, "outliers")], white)
    direct = rmse_bound(posterior_crlb(**suite.crlb_inputs(scenario, "bias")))
    np.testing.assert_array_equal(direct, bounds[(scenario, "bias")])


def test_the_bound_averages_the_information_over_the_scattered_tracks():
    # The expectation is over the true tracks: one range at 1 km, bearings scattered by about 100 m / 1 km, gives
    # the tangential direction an information of E[sin^2] / sigma_r^2, which the average reproduces.
    p = suite.PARAMETERS
    args = suite.crlb_inputs("circle", "white", n_tracks=4000, seed=5)
    pos = args["positions"][:, 0]
    e = pos / np.linalg.norm(pos, axis=-1, keepdims=True)
    info = np.einsum("mi,mj->ij", e, e) / len(e) / p.range_sigma**2 + np.linalg.inv(p.P0 + p.Q)
    expected = np.sqrt(np.trace(np.linalg.inv(info)))
    bound = rmse_bound(posterior_crlb(**args))
    assert bound[0] == pytest.approx(expected, rel=1e-9)
    # evaluated on the planned track alone, the tangential direction would keep the prior: no bound at all
    planned = rmse_bound(posterior_crlb(**dict(args, positions=args["positions"][:1], mean_over_runs=False)))[0]
    assert planned[0] > 4 * bound[0]


def test_the_registered_functions_are_picklable_for_a_process_pool():
    for m in methods.REGISTRY.values():
        assert pickle.loads(pickle.dumps(m.estimate)) is m.estimate
    for f in list(suite.SCENARIOS.values()) + list(suite.CONDITIONS.values()):
        assert pickle.loads(pickle.dumps(f)) is f


def test_a_late_start_navigates_by_dead_reckoning_until_it_starts():
    inputs, _ = _draw("line", "white", 6)
    res = methods.ls_isfekf(inputs)         # a straight line never passes paper D's turn test
    started = res.extras["started"]
    assert not started.any()
    np.testing.assert_allclose(res.x, inputs.dr_track())
    np.testing.assert_allclose(res.P, np.broadcast_to(inputs.dr_covariance(), res.P.shape))
