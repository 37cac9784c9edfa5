"""uwtutor.lsq: precision factor, linearized / nonlinear LS, paper D's grid pre-location, paper E's VMLBL fix."""

import warnings

import numpy as np
import pytest
from scipy.optimize import least_squares

from uwtutor import lsq, motion, scenarios
from uwtutor.lsq import IllConditionedWarning


def bearings_design(deg, bias=True):
    phi = np.radians(deg)
    cols = [np.cos(phi), np.sin(phi)] + ([np.ones_like(phi)] if bias else [])
    return np.column_stack(cols)


# --- precision factor and condition number ------------------------------------------------------------------------

def test_precision_factor_closed_forms():
    assert lsq.precision_factor(bearings_design([0.0, 90.0, 180.0, 270.0])) == pytest.approx(1.25)
    # N beacons evenly spaced with a bias: A^T A = diag(N/2, N/2, N), alpha = 4/N + 1/N
    for n in (3, 5, 12):
        A = bearings_design(np.arange(n) * 360.0 / n)
        assert lsq.precision_factor(A) == pytest.approx(5.0 / n)


def test_precision_factor_is_trace_of_inverse_and_sum_of_inverse_eigenvalues():
    rng = np.random.default_rng(0)
    A = rng.normal(size=(7, 3))
    normal = A.T @ A
    alpha = lsq.precision_factor(A)
    assert alpha == pytest.approx(np.trace(np.linalg.inv(normal)), rel=1e-12)
    assert alpha == pytest.approx(np.sum(1.0 / np.linalg.eigvalsh(normal)), rel=1e-12)
    # it is the variance sum of the LS estimate under unit white noise (the CRLB trace)
    assert isinstance(alpha, float)


def test_precision_factor_and_condition_are_batched():
    rng = np.random.default_rng(1)
    A = rng.normal(size=(4, 6, 3))
    alpha = lsq.precision_factor(A)
    cond = lsq.condition_number(A)
    assert alpha.shape == cond.shape == (4,)
    for m in range(4):
        assert alpha[m] == pytest.approx(lsq.precision_factor(A[m]))
        assert cond[m] == pytest.approx(np.linalg.cond(A[m]))


def test_singular_designs_give_infinity():
    assert lsq.precision_factor(bearings_design([10.0, 10.0, 10.0])) == np.inf      # no change of bearing
    assert lsq.condition_number(bearings_design([10.0, 10.0, 10.0])) == np.inf
    assert lsq.precision_factor(bearings_design([0.0, 90.0])) == np.inf             # fewer rows than unknowns
    assert lsq.precision_factor(np.zeros((4, 2))) == np.inf
    assert lsq.condition_number(np.eye(3)) == pytest.approx(1.0)


def test_precision_factor_rejects_bad_input():
    with pytest.raises(ValueError, match="A must be a design matrix"):
        lsq.precision_factor([1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="A must be finite"):
        lsq.precision_factor([[1.0, np.nan], [0.0, 1.0]])
    with pytest.raises(TypeError, match="A must be numeric"):
        lsq.condition_number("abc")


def test_precision_factor_history_matches_the_batch_formula():
    rng = np.random.default_rng(2)
    pos = rng.normal(0.0, 500.0, (30, 2)) + [2000.0, 0.0]
    hist = lsq.precision_factor_history(pos)
    assert hist.shape == (30,)
    assert np.all(np.isinf(hist[:2]))                    # 1 and 2 rows cannot fix 3 unknowns
    for k in (3, 10, 30):
        h = pos[:k] / np.linalg.norm(pos[:k], axis=1, keepdims=True)
        A = np.column_stack([h, np.ones(k)])
        assert hist[k - 1] == pytest.approx(lsq.precision_factor(A), rel=1e-9)
    # without the bias, two rows with different bearings are enough
    assert np.isfinite(lsq.precision_factor_history(pos, unknown_bias=False)[1])
    # batched over runs, and a beacon that is not at the origin
    batch = lsq.precision_factor_history(np.stack([pos, pos + 100.0]), beacon=(100.0, 100.0))
    np.testing.assert_allclose(batch[1], hist, rtol=1e-12)


def test_precision_factor_falls_to_one_after_a_quarter_turn_of_paper_a_circle():
    """Paper A, Fig. 2: alpha reaches 1 after about 200 observations, when the bearing has turned about 90 deg."""
    sc = scenarios.circling_scenario(np.random.default_rng(0))
    alpha = lsq.precision_factor_history(sc.true_positions[0])
    first_one = int(np.argmax(alpha < 1.0)) + 1
    bearing = np.unwrap(np.arctan2(sc.true_positions[0, :, 1], sc.true_positions[0, :, 0]))
    turned = np.degrees(bearing[first_one - 1] - bearing[0])
    assert 200 <= first_one <= 250 and 85.0 <= turned <= 95.0
    assert np.all(np.diff(alpha[np.isfinite(alpha)]) <= 1e-12)          # more ranges never hurt


def test_precision_factor_history_rejects_bad_input():
    with pytest.raises(ValueError, match="positions must have shape"):
        lsq.precision_factor_history(np.zeros((5, 3)))
    with pytest.raises(ValueError, match="beacon must have shape"):
        lsq.precision_factor_history(np.ones((5, 2)), beacon=np.zeros(3))
    with pytest.raises(ValueError, match="coincides with a beacon"):
        lsq.precision_factor_history(np.zeros((5, 2)))


# --- linearized and nonlinear least squares -----------------------------------------------------------------------

BEACONS = np.array([[1000.0, 0.0], [0.0, 1000.0], [-1000.0, 0.0], [0.0, -1000.0], [700.0, 700.0]])
TRUTH = np.array([30.0, -40.0])


def test_linearized_lsq_one_step_is_paper_a_regression():
    r = np.linalg.norm(TRUTH - BEACONS, axis=1) + 5.0
    p0 = np.array([10.0, -30.0])
    fix = lsq.linearized_lsq(r, BEACONS, p0)
    rho = np.linalg.norm(p0 - BEACONS, axis=1)
    A = np.column_stack([(p0 - BEACONS) / rho[:, None], np.ones(5)])
    beta = np.linalg.lstsq(A, r - rho, rcond=None)[0]
    np.testing.assert_allclose(fix.position, p0 + beta[:2], rtol=1e-12)   # the correction is *added*
    assert float(fix.bias) == pytest.approx(beta[2])
    np.testing.assert_allclose(fix.design, A)
    assert float(fix.alpha) == pytest.approx(lsq.precision_factor(A))
    assert float(fix.noise_gain) == pytest.approx(np.sqrt(float(fix.alpha)))
    assert fix.iterations == 1 and bool(fix.well_conditioned)


def test_linearized_lsq_iterates_to_the_exact_fix_and_bias():
    r = np.linalg.norm(TRUTH - BEACONS, axis=1) + 5.0
    fix = lsq.linearized_lsq(r, BEACONS, [200.0, 150.0], iterations=6)
    np.testing.assert_allclose(fix.position, TRUTH, atol=1e-9)
    assert float(fix.bias) == pytest.approx(5.0, abs=1e-9)
    np.testing.assert_allclose(fix.residuals, 0.0, atol=1e-9)
    np.testing.assert_allclose(fix.estimate, [*TRUTH, 5.0], atol=1e-9)
    no_bias = lsq.linearized_lsq(r - 5.0, BEACONS, [200.0, 150.0], unknown_bias=False, iterations=6)
    assert no_bias.bias is None and no_bias.estimate.shape == (2,)
    np.testing.assert_allclose(no_bias.position, TRUTH, atol=1e-9)


def test_linearized_lsq_covariance_matches_monte_carlo():
    rng = np.random.default_rng(3)
    M, sigma = 4000, 2.0
    r = np.linalg.norm(TRUTH - BEACONS, axis=1) + 5.0 + rng.normal(0.0, sigma, (M, 5))
    fix = lsq.linearized_lsq(r, BEACONS, TRUTH, iterations=3, sigma=sigma)
    assert fix.position.shape == (M, 2) and fix.covariance.shape == (M, 3, 3)
    emp = np.cov(fix.estimate.T)
    np.testing.assert_allclose(emp, fix.covariance[0], rtol=0.1, atol=0.05)
    # alpha sigma^2 is the mean squared error summed over the three unknowns
    mse = np.mean(np.sum((fix.estimate - [*TRUTH, 5.0]) ** 2, axis=1))
    assert mse == pytest.approx(float(fix.alpha[0]) * sigma**2, rel=0.08)
    # without sigma it is estimated from the residuals (N - p = 2 degrees of freedom)
    est = lsq.linearized_lsq(r, BEACONS, TRUTH, iterations=3)
    assert np.mean(est.sigma**2) == pytest.approx(sigma**2, rel=0.08)


def test_linearized_lsq_batch_equals_loop():
    rng = np.random.default_rng(4)
    r = np.linalg.norm(TRUTH - BEACONS, axis=1) + rng.normal(0.0, 1.0, (6, 5))
    p0 = TRUTH + rng.normal(0.0, 30.0, (6, 2))
    batch = lsq.linearized_lsq(r, BEACONS, p0, iterations=2)
    for m in range(6):
        single = lsq.linearized_lsq(r[m], BEACONS, p0[m], iterations=2)
        np.testing.assert_allclose(batch.estimate[m], single.estimate, rtol=1e-12)
        np.testing.assert_allclose(batch.covariance[m], single.covariance, rtol=1e-12)


def test_linearized_lsq_singular_gives_nan_and_warns():
    beacons = np.array([[1000.0, 0.0], [2000.0, 0.0], [3000.0, 0.0]])   # all on one line through the vehicle
    r = np.array([1000.0, 2000.0, 3000.0])
    with pytest.warns(IllConditionedWarning, match="singular"):
        fix = lsq.linearized_lsq(r, beacons, [0.0, 0.0])
    assert np.all(np.isnan(fix.position)) and np.isinf(fix.alpha) and not bool(fix.well_conditioned)
    # in a batch only the singular run is NaN
    good = np.linalg.norm(TRUTH - BEACONS[:3], axis=1)
    with pytest.warns(IllConditionedWarning, match="in 1 of its 2 stacked problems"):
        mixed = lsq.linearized_lsq(np.stack([r, good]), np.stack([beacons, BEACONS[:3]]), np.zeros((2, 2)),
                                   unknown_bias=False)
    assert np.isnan(mixed.position[0]).all() and np.isfinite(mixed.position[1]).all()


def test_linearized_lsq_ill_conditioned_warns_but_returns_a_fix():
    # ten ranges over 2 degrees of bearing: the bias and the range direction are nearly confounded
    phi = np.radians(np.linspace(-90.0, -88.0, 10))
    beacons = -1500.0 * np.column_stack([np.cos(phi), np.sin(phi)])
    r = np.full(10, 1500.0)
    with pytest.warns(IllConditionedWarning, match="ill-conditioned.*condition number"):
        fix = lsq.linearized_lsq(r, beacons, [5.0, 5.0])
    assert np.all(np.isfinite(fix.position)) and float(fix.condition_number) > 1e3
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        lsq.linearized_lsq(r, beacons, [5.0, 5.0], max_condition=1e7, max_noise_gain=1e9)


def test_linearized_lsq_rejects_bad_input():
    r = np.linalg.norm(TRUTH - BEACONS, axis=1)
    with pytest.raises(ValueError, match="one beacon per range"):
        lsq.linearized_lsq(r[:4], BEACONS, TRUTH)
    with pytest.raises(ValueError, match="ranges must be >= 0"):
        lsq.linearized_lsq(-r, BEACONS, TRUTH)
    with pytest.raises(ValueError, match="provisional must be a position"):
        lsq.linearized_lsq(r, BEACONS, [1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="coincides with a beacon"):
        lsq.linearized_lsq(r, BEACONS, BEACONS[0])
    with pytest.raises(ValueError, match="iterations must be >= 1"):
        lsq.linearized_lsq(r, BEACONS, TRUTH, iterations=0)
    with pytest.raises(ValueError, match="disagree on the number of runs"):
        lsq.linearized_lsq(np.stack([r, r]), BEACONS, np.zeros((3, 2)))
    with pytest.raises(ValueError, match="max_condition must be >= 1"):
        lsq.linearized_lsq(r, BEACONS, TRUTH, max_condition=0.5)
    with pytest.raises(ValueError, match="sigma must be > 0"):
        lsq.linearized_lsq(r, BEACONS, TRUTH, sigma=0.0)


def test_lsq_fix_trusted_is_paper_a_test():
    fix = lsq.linearized_lsq(np.linalg.norm(TRUTH - BEACONS, axis=1), BEACONS, TRUTH)
    assert bool(fix.trusted()) == (float(fix.alpha) < 2.0)
    assert not bool(fix.trusted(max_alpha=0.1))


def test_prepositioning_uses_virtual_beacons_of_the_track():
    times = 5.0 * np.arange(120)
    track = motion.circle_track(times, 1500.0, 2.0, start_angle=-np.pi / 2)
    r = np.linalg.norm(track.positions, axis=1) + 8.0
    dr = track.positions - track.positions[0] + [123.0, -45.0]       # DR positions: only differences matter
    fix = lsq.prepositioning(r, dr, track.positions[-1] + [60.0, -40.0], iterations=5)
    np.testing.assert_allclose(fix.position, track.positions[-1], atol=1e-6)
    assert float(fix.bias) == pytest.approx(8.0, abs=1e-6)
    vb = -(dr - dr[-1])
    same = lsq.linearized_lsq(r, vb, track.positions[-1] + [60.0, -40.0], iterations=5)
    np.testing.assert_allclose(fix.estimate, same.estimate, rtol=1e-12)
    with pytest.warns(IllConditionedWarning, match="pre-positioning problem"):
        lsq.prepositioning(r[:8], dr[:8], track.positions[7] + [10.0, 0.0])
    with pytest.raises(ValueError, match="dr_positions must have shape"):
        lsq.prepositioning(r, dr[:, :1], track.positions[-1])


def test_nonlinear_lsq_is_the_reference():
    rng = np.random.default_rng(5)
    r = np.linalg.norm(TRUTH - BEACONS, axis=1) + 3.0 + rng.normal(0.0, 1.0, 5)
    nls = lsq.nonlinear_lsq(r, BEACONS, [150.0, 100.0], unknown_bias=True)
    lin = lsq.linearized_lsq(r, BEACONS, [150.0, 100.0], iterations=8)
    np.testing.assert_allclose(nls.estimate, lin.estimate, atol=1e-7)
    direct = least_squares(lambda x: np.linalg.norm(x[:2] - BEACONS, axis=1) + x[2] - r, [0.0, 0.0, 0.0])
    np.testing.assert_allclose(nls.estimate, direct.x, atol=1e-6)
    assert nls.covariance.shape == (3, 3) and nls.iterations >= 1
    assert float(nls.alpha) == pytest.approx(lsq.precision_factor(nls.design))
    plain = lsq.nonlinear_lsq(r - 3.0, BEACONS, [150.0, 100.0])
    assert plain.bias is None and plain.estimate.shape == (2,)


def test_nonlinear_lsq_rejects_batches_and_bad_initial_values():
    r = np.linalg.norm(TRUTH - BEACONS, axis=1)
    with pytest.raises(ValueError, match="solves one problem"):
        lsq.nonlinear_lsq(np.stack([r, r]), BEACONS, TRUTH)
    with pytest.raises(ValueError, match="initial must have shape"):
        lsq.nonlinear_lsq(r, BEACONS, [1.0, 2.0, 3.0])


# --- paper D's grid pre-location ----------------------------------------------------------------------------------

def approach(sigma_tau=0.0, seed=0, K=151, turn=70):
    """Paper D-like approach: exact DR, travel times at 1500 m/s (+ noise); assumed speed 1470."""
    times = 10.0 * np.arange(K)
    track = motion.turning_track(times, start=(-3000.0, -1500.0), speed=2.0,
                                 headings=np.radians([15.0, 60.0]), turn_times=[10.0 * turn])
    tau = np.hypot(*track.positions.T) / 1500.0
    tau = tau + np.random.default_rng(seed).normal(0.0, sigma_tau, K) if sigma_tau else tau
    u = np.diff(track.positions, axis=0, prepend=track.positions[:1])
    return track, tau, u


def brute_force_cost(tau, u, theta, dc, c=1470.0):
    ce = c - dc
    p0 = ce * tau[0] * np.array([np.cos(theta), np.sin(theta)])
    p = p0 + np.cumsum(u, axis=0) - u[0]
    return np.sum((np.linalg.norm(p, axis=1) / ce - tau) ** 2)


def test_prelocation_cost_equals_a_brute_force_loop():
    _, tau, u = approach(sigma_tau=3e-4)
    thetas = np.radians([200.0, 206.0, 210.0])
    dcs = np.array([-60.0, -30.0, 0.0])
    cost = lsq.prelocation_cost(tau, u, thetas, dcs)
    assert cost.shape == (3, 3)
    for i, th in enumerate(thetas):
        for j, dc in enumerate(dcs):
            assert cost[i, j] == pytest.approx(brute_force_cost(tau, u, th, dc), rel=1e-9)


def test_grid_prelocation_finds_the_true_cell_after_the_turn():
    track, tau, u = approach()
    theta0 = np.arctan2(track.positions[0, 1], track.positions[0, 0])
    thetas = theta0 + np.radians(np.arange(-40.0, 40.5, 1.0))
    dcs = 1470.0 - np.arange(1550.0, 1299.0, -10.0)
    pre = lsq.grid_prelocation(tau, u, thetas, dcs)
    assert pre.bearing.shape == (151,) and pre.start.shape == (151, 2) and pre.cost_map.shape == (81, 26)
    assert pre.bearing[-1] == pytest.approx(theta0) and pre.speed_error[-1] == pytest.approx(-30.0)
    assert pre.effective_speed[-1] == pytest.approx(1500.0) and pre.range_scale[-1] == pytest.approx(0.98)
    np.testing.assert_allclose(pre.position[-1], track.positions[-1], atol=1e-6)
    np.testing.assert_allclose(pre.position, pre.start + (np.cumsum(u, axis=0) - u[0]))
    assert pre.cost[-1] == pytest.approx(0.0, abs=1e-20)
    assert np.all(np.diff(pre.cost) >= -1e-18)                  # the minimum cost grows as epochs are added


def test_grid_prelocation_mirror_fits_as_well_before_the_turn():
    track, tau, u = approach()
    theta0 = np.arctan2(track.positions[0, 1], track.positions[0, 0])
    mirror = 2 * np.radians(15.0) - theta0                      # reflection across the first leg's direction
    cost_before = lsq.prelocation_cost(tau[:60], u[:60], [theta0, mirror], [-30.0])
    cost_after = lsq.prelocation_cost(tau, u, [theta0, mirror], [-30.0])
    assert cost_before[0, 0] < 1e-20 and cost_before[1, 0] < 1e-18        # both fit a straight leg exactly
    assert cost_after[1, 0] > 1e6 * max(cost_after[0, 0], 1e-24)          # the turn betrays the mirror


def test_grid_prelocation_batch_equals_single_runs_and_ranges_equal_travel_times():
    sc = scenarios.approach_with_turn_scenario(np.random.default_rng(1), n_runs=3)
    grid = dict(bearing_grid=np.radians(np.arange(0.0, 360.0, 5.0)), speed_error_grid=[-50.0, -30.0, -10.0])
    batch = lsq.grid_prelocation(ranges=sc.ranges, dr_displacements=sc.dr_displacements, **grid)
    for m in range(3):
        single = lsq.grid_prelocation(sc.ranges[m] / 1470.0, sc.dr_displacements[m], **grid)
        np.testing.assert_allclose(batch.start[m], single.start)
        np.testing.assert_allclose(batch.cost_map[m], single.cost_map, rtol=1e-12)
    # a small chunk size gives the same answer (runs are processed in chunks)
    old = lsq.prelocation._GRID_CHUNK_ELEMENTS
    try:
        lsq.prelocation._GRID_CHUNK_ELEMENTS = 1
        chunked = lsq.grid_prelocation(ranges=sc.ranges, dr_displacements=sc.dr_displacements, **grid)
    finally:
        lsq.prelocation._GRID_CHUNK_ELEMENTS = old
    np.testing.assert_array_equal(chunked.bearing, batch.bearing)


def test_grid_prelocation_default_grid_on_paper_d_scenario():
    sc = scenarios.approach_with_turn_scenario(np.random.default_rng(2), n_runs=30)
    pre = lsq.grid_prelocation(ranges=sc.ranges, dr_displacements=sc.dr_displacements)
    assert pre.cost_map.shape == (30, 180, 26)
    err = np.linalg.norm(pre.position[:, -1] - sc.true_positions[:, -1], axis=-1)
    assert np.median(err) < 60.0
    # ranges converted with 1470 m/s are ~2 % short: mu_gamma = c / c_e ~ 0.98, Delta c = c - c_e ~ -30 m/s
    assert np.median(pre.range_scale[:, -1]) == pytest.approx(0.98, abs=0.01)
    assert np.median(pre.speed_error[:, -1]) == pytest.approx(-30.0, abs=10.0)


def test_grid_prelocation_skips_missing_epochs():
    _, tau, u = approach(sigma_tau=3e-4)
    thetas = np.radians(np.arange(180.0, 240.0, 2.0))
    gapped = tau.copy()
    gapped[[5, 50, 100]] = np.nan
    # the same cost with the missing epochs left out (DR offsets, not displacements, are what matter)
    D = np.cumsum(u, 0)
    kept = np.delete(D, [5, 50, 100], 0)
    u_kept = np.diff(kept, axis=0, prepend=kept[:1])
    full = lsq.grid_prelocation(np.delete(tau, [5, 50, 100]), u_kept, thetas, [-30.0, -20.0])
    with_gaps = lsq.grid_prelocation(gapped, u, thetas, [-30.0, -20.0])
    np.testing.assert_allclose(with_gaps.cost_map, full.cost_map, rtol=1e-10)


def test_grid_prelocation_rejects_bad_input():
    _, tau, u = approach()
    grid = dict(bearing_grid=[0.0, 1.0], speed_error_grid=[-30.0])
    with pytest.raises(ValueError, match="exactly one of travel_times and ranges"):
        lsq.grid_prelocation(tau, u, ranges=tau * 1470.0, **grid)
    with pytest.raises(ValueError, match="exactly one of travel_times and ranges"):
        lsq.grid_prelocation(dr_displacements=u, **grid)
    with pytest.raises(TypeError, match="dr_displacements is required"):
        lsq.grid_prelocation(tau, **grid)
    bad = tau.copy()
    bad[0] = np.nan
    with pytest.raises(ValueError, match="at epoch 0"):
        lsq.grid_prelocation(bad, u, **grid)
    with pytest.raises(ValueError, match="must be finite and >= 0"):
        lsq.grid_prelocation(-tau, u, **grid)
    with pytest.raises(ValueError, match="one row per epoch"):
        lsq.grid_prelocation(tau, u[:-1], **grid)
    with pytest.raises(ValueError, match="must stay below assumed_speed"):
        lsq.grid_prelocation(tau, u, bearing_grid=[0.0], speed_error_grid=[1500.0])
    with pytest.raises(ValueError, match="must not be empty"):
        lsq.grid_prelocation(tau, u, bearing_grid=[], speed_error_grid=[-30.0])


# --- paper D's acceptance -----------------------------------------------------------------------------------------

def test_prelocation_acceptance_needs_a_turn_then_k_stable_estimates():
    track, tau, u = approach()
    K = len(tau)
    starts = np.zeros((K, 2))
    starts[:75] = np.random.default_rng(0).normal(0.0, 500.0, (75, 2))       # jumping before and just after
    acc = lsq.prelocation_acceptance(starts, u)
    assert 70 <= int(acc.turn_epoch) <= 73                                 # the turn is at epoch 70
    # epochs 75..84 are the first 10 consecutive shifts < 50 m (the shift at 75 is from the jumpy 74: not small)
    assert bool(acc.accepted) and int(acc.epoch) == 85
    assert acc.shifts.shape == (K,) and np.isnan(acc.shifts[0])
    # a straight track never qualifies, however stable the estimates
    straight = np.tile(u[1], (K, 1))
    never = lsq.prelocation_acceptance(np.zeros((K, 2)), straight)
    assert not bool(never.accepted) and int(never.epoch) == -1 and int(never.turn_epoch) == -1
    # K and D are the paper's knobs
    assert int(lsq.prelocation_acceptance(starts, u, n_consecutive=7).epoch) == 82
    assert not bool(lsq.prelocation_acceptance(starts + np.arange(K)[:, None] * 60.0, u).accepted)


def test_prelocation_acceptance_is_batched_and_ignores_dr_noise_on_one_step():
    rng = np.random.default_rng(1)
    _, _, u = approach()
    K = len(u)
    noisy = u + rng.normal(0.0, 0.9, (200, K, 2))                          # paper D's DR noise
    straight = np.broadcast_to(u[1], (200, K, 2)) + rng.normal(0.0, 0.9, (200, K, 2))
    acc = lsq.prelocation_acceptance(np.zeros((200, K, 2)), noisy)
    assert acc.accepted.all() and np.all((acc.turn_epoch >= 70) & (acc.turn_epoch <= 74))
    false = lsq.prelocation_acceptance(np.zeros((200, K, 2)), straight)
    assert not false.accepted.any()                                       # no false turn from DR noise


def test_prelocation_acceptance_rejects_bad_input():
    _, _, u = approach()
    with pytest.raises(ValueError, match="same number of epochs"):
        lsq.prelocation_acceptance(np.zeros((10, 2)), u)
    with pytest.raises(ValueError, match="n_consecutive must be >= 1"):
        lsq.prelocation_acceptance(np.zeros_like(u), u, n_consecutive=0)
    with pytest.raises(ValueError, match="max_shift must be > 0"):
        lsq.prelocation_acceptance(np.zeros_like(u), u, max_shift=-1.0)


# --- paper E's virtual-beacon least squares -----------------------------------------------------------------------

SHIP = np.array([[0.0, 0.0], [400.0, 100.0], [700.0, 400.0], [800.0, 800.0]])
SUB = np.array([[-900.0, -1100.0], [-850.0, -1050.0], [-800.0, -1000.0], [-750.0, -950.0]])


def slant(ship, sub, depth, ship_depths=0.0):
    vb = ship + (sub[-1] - sub)
    return np.sqrt(np.sum((sub[-1] - vb) ** 2, axis=-1) + (depth - ship_depths) ** 2)


def test_virtual_beacon_lsq_exact_fix_and_system():
    r = slant(SHIP, SUB, 1000.0)
    fix = lsq.virtual_beacon_lsq(r, SHIP, SUB, depth=1000.0)
    np.testing.assert_allclose(fix.position, SUB[-1], atol=1e-6)
    np.testing.assert_allclose(fix.virtual_beacons, SHIP + (SUB[-1] - SUB))
    np.testing.assert_allclose(fix.residuals, 0.0, atol=1e-6)
    # cyclic rows: they sum to zero (only N - 1 are independent)
    np.testing.assert_allclose(fix.design.sum(axis=0), 0.0, atol=1e-9)
    assert fix.rhs.sum() == pytest.approx(0.0, abs=1e-6)
    # with a surface ship the depth cancels from the differenced equations (any depth the ranges allow)
    other = lsq.virtual_beacon_lsq(r, SHIP, SUB, depth=1200.0)
    np.testing.assert_allclose(other.position, fix.position, atol=1e-9)
    # but a slant range shorter than the depth is impossible: refused, not turned into a fix
    with pytest.raises(ValueError, match="shorter than the vertical distance"):
        lsq.virtual_beacon_lsq(r, SHIP, SUB, depth=3000.0)


def test_virtual_beacon_lsq_with_beacon_depths():
    z = np.array([0.0, 8.0, 15.0, 4.0])
    r = slant(SHIP, SUB, 1000.0, z)
    fix = lsq.virtual_beacon_lsq(r, SHIP, SUB, depth=1000.0, beacon_depths=z)
    np.testing.assert_allclose(fix.position, SUB[-1], atol=1e-6)


def test_virtual_beacon_noise_gain_matches_monte_carlo():
    rng = np.random.default_rng(6)
    r = slant(SHIP, SUB, 1000.0)
    M, sigma = 5000, 1.0
    fix = lsq.virtual_beacon_lsq(r + rng.normal(0.0, sigma, (M, 4)), SHIP, SUB, depth=1000.0)
    rms = np.sqrt(np.mean(np.sum((fix.position - SUB[-1]) ** 2, axis=-1)))
    assert rms == pytest.approx(float(fix.noise_gain[0]) * sigma, rel=0.05)


def test_virtual_beacon_lsq_warns_when_the_baseline_is_short():
    # the ship and the submersible move in parallel: the virtual beacons barely spread out
    ship = np.array([[0.0, 0.0], [2.0, 2.0], [4.0, 4.1], [6.0, 6.3]])
    sub = np.array([[-1000.0, -1000.0], [-999.0, -999.0], [-998.0, -998.0], [-997.0, -997.0]])
    r = slant(ship, sub, 1000.0)
    with pytest.warns(IllConditionedWarning, match="ill-conditioned.*noise gain"):
        fix = lsq.virtual_beacon_lsq(r, ship, sub, depth=1000.0)
    assert float(fix.noise_gain) > 100.0 and not bool(fix.well_conditioned)
    # collinear virtual beacons: singular, NaN fix
    line = np.array([[0.0, 0.0], [10.0, 10.0], [20.0, 20.0], [30.0, 30.0]])
    with pytest.warns(IllConditionedWarning, match="singular"):
        bad = lsq.virtual_beacon_lsq(slant(line, np.zeros((4, 2)) - 500.0, 800.0), line,
                                     np.zeros((4, 2)) - 500.0, depth=800.0)
    assert np.isnan(bad.position).all() and np.isinf(bad.noise_gain)


def test_virtual_beacon_lsq_is_batched():
    rng = np.random.default_rng(7)
    r = slant(SHIP, SUB, 1000.0) + rng.normal(0.0, 1.0, (5, 4))
    batch = lsq.virtual_beacon_lsq(r, SHIP, SUB, depth=1000.0)
    for m in range(5):
        single = lsq.virtual_beacon_lsq(r[m], SHIP, SUB, depth=1000.0)
        np.testing.assert_allclose(batch.position[m], single.position, rtol=1e-12)
    assert batch.condition_number.shape == (5,)


def test_virtual_beacon_lsq_rejects_bad_input():
    r = slant(SHIP, SUB, 1000.0)
    with pytest.raises(ValueError, match="N >= 3 epochs"):
        lsq.virtual_beacon_lsq(r[:2], SHIP[:2], SUB[:2])
    with pytest.raises(ValueError, match="beacon_positions must have shape"):
        lsq.virtual_beacon_lsq(r, SHIP[:3], SUB)
    with pytest.raises(ValueError, match="beacon_depths must be a number or have shape"):
        lsq.virtual_beacon_lsq(r, SHIP, SUB, beacon_depths=[0.0, 1.0])
    with pytest.raises(ValueError, match="ranges must be >= 0"):
        lsq.virtual_beacon_lsq(-r, SHIP, SUB)


def test_warning_class_is_a_user_warning():
    assert issubclass(IllConditionedWarning, UserWarning)
    assert lsq.SINGULAR_RTOL < 1e-5
