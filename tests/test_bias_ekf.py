"""Paper A's IEKF (bias_ekf / BiasEKF / prepositioned_bias_ekf) and its scenarios.

filterpy step by step (fixed and moving beacon), batched == single, the protocol, convergence on a circle with a
constant bias, the measured price of the bias state when there is no bias, the pre-positioning start, the lake
trial's moving-beacon / relative-frame equivalence, the bias-rate extension and bad input.
"""

import warnings
from dataclasses import replace

import numpy as np
import pytest
from filterpy.kalman import ExtendedKalmanFilter as FilterpyEKF

from uwtutor import lsq
from uwtutor.filters import (BiasEKF, Filter, FilterResult, bias_ekf, extended_kalman_filter, range_only_ekf,
                             run_filter)
from uwtutor.pipelines import prepositioned_bias_ekf
from uwtutor.models import (BiasRateDeadReckoning, RangeToBeacon, bias_rate_process_noise, paper_a_process_noise)
from uwtutor.scenarios import paper_a

TOL = dict(rtol=1e-9, atol=1e-9)
Q3 = np.diag([0.5, 0.4, 0.45])
R = 9.0


def circle_inputs(M=4, K=120, seed=0, moving=False, bias=12.0, missing=0.15):
    """A 1.2-turn arc round a fixed or moving beacon, ranges with a constant bias, some missing."""
    rng = np.random.default_rng(seed)
    theta = np.linspace(0.0, 1.2 * 2 * np.pi, K + 1)
    track = 800.0 * np.column_stack([np.cos(theta), np.sin(theta)]) + [50.0, -20.0]
    u = np.diff(track, axis=0)
    beacon = (np.column_stack([np.linspace(0.0, 300.0, K), 100.0 * np.sin(np.linspace(0.0, 4.0, K))])
              if moving else np.zeros(2))
    path = beacon if moving else np.broadcast_to(beacon, (K, 2))
    z = np.linalg.norm(track[1:] - path, axis=-1) + bias + rng.normal(0.0, 3.0, (M, K))
    z[rng.random((M, K)) < missing] = np.nan
    x0 = np.column_stack([track[0] + rng.normal(0.0, 20.0, (M, 2)), np.zeros(M)])
    P0 = np.diag([400.0, 400.0, 225.0])
    return x0, P0, u, z, beacon, track[1:]


def filterpy_iekf(x0, P0, u, z, beacon):
    """Paper A's 3-state EKF written out for filterpy: A = I3, B = [I2; 0], H = [(p - b)/r, 1]."""
    f = FilterpyEKF(dim_x=3, dim_z=1, dim_u=2)
    f.x = np.array(x0, float).reshape(3, 1)
    f.P = np.array(P0, float)
    f.F = np.eye(3)
    f.B = np.vstack([np.eye(2), np.zeros((1, 2))])
    f.Q = Q3
    f.R = np.array([[R]])
    out = {key: [] for key in ("x", "P", "x_prior", "P_prior")}
    for k, (uk, zk) in enumerate(zip(u, z)):
        b = beacon if beacon.ndim == 1 else beacon[k]

        def H(x, b=b):
            d = x[:2, 0] - b
            return np.array([[d[0] / np.hypot(*d), d[1] / np.hypot(*d), 1.0]])

        def hx(x, b=b):
            return np.array([[np.hypot(*(x[:2, 0] - b)) + x[2, 0]]])

        f.predict(u=np.asarray(uk).reshape(2, 1))
        out["x_prior"].append(f.x[:, 0].copy())
        out["P_prior"].append(f.P.copy())
        if np.isfinite(zk):
            f.update(np.array([[zk]]), HJacobian=H, Hx=hx)
        out["x"].append(f.x[:, 0].copy())
        out["P"].append(f.P.copy())
    return {key: np.array(v) for key, v in out.items()}


@pytest.mark.parametrize("moving", [False, True], ids=["fixed-beacon", "moving-beacon"])
def test_bias_ekf_equals_filterpy_step_by_step(moving):
    x0, P0, u, z, beacon, _ = circle_inputs(moving=moving)
    res = bias_ekf(x0, P0, u, z, Q3, R, beacon=beacon)
    assert res.x.shape == (4, 120, 3) and res.P.shape == (4, 120, 3, 3)
    for m in range(x0.shape[0]):
        ref = filterpy_iekf(x0[m], P0, u, z[m], beacon)
        for key in ref:
            np.testing.assert_allclose(getattr(res, key)[m], ref[key], **TOL, err_msg=f"{key}, run {m}")


def test_batched_equals_single_runs_with_a_per_run_beacon():
    x0, P0, u, z, beacon, _ = circle_inputs(moving=True)
    per_run = beacon[None] + np.arange(4.0)[:, None, None] * [5.0, -3.0]      # (M, K, 2): one path per run
    batched = bias_ekf(x0, P0, u, z, Q3, R, beacon=per_run)
    for m in range(4):
        single = bias_ekf(x0[m], P0, u, z[m], Q3, R, beacon=per_run[m])
        for key in ("x", "P", "x_prior", "P_prior", "innovations", "innovation_cov"):
            np.testing.assert_allclose(getattr(batched, key)[m], getattr(single, key), **TOL)
        np.testing.assert_array_equal(batched.extras["accepted"][m], single.extras["accepted"])


def test_class_follows_the_protocol_and_equals_the_functional_form():
    x0, P0, u, z, beacon, _ = circle_inputs()
    times = 5.0 * np.arange(z.shape[1])
    functional = bias_ekf(x0, P0, u, z, Q3, R, times=times)
    filt = BiasEKF(x0, P0, Q3, R)
    assert isinstance(filt, Filter)
    looped = run_filter(BiasEKF(x0, P0, Q3, R), z, u, times)
    ran = filt.run(z, u, times)
    hand = BiasEKF(x0, P0, Q3, R)
    xs = []
    for k in range(z.shape[1]):
        hand.predict(u[k])
        hand.update(z[:, k])
        xs.append(hand.x.copy())
    for res in (looped, ran):
        assert isinstance(res, FilterResult)
        for key in ("times", "x", "P", "x_prior", "P_prior", "innovations", "innovation_cov"):
            np.testing.assert_array_equal(getattr(res, key), getattr(functional, key))
        np.testing.assert_array_equal(res.extras["accepted"], functional.extras["accepted"])
    np.testing.assert_array_equal(np.stack(xs, axis=1), functional.x)
    np.testing.assert_array_equal(filt.bias, functional.x[:, -1, 2])
    missing = np.isnan(z)
    np.testing.assert_array_equal(functional.x[missing], functional.x_prior[missing])
    P = functional.P
    np.testing.assert_array_equal(P, np.swapaxes(P, -1, -2))
    assert np.linalg.eigvalsh(P).min() > 0


def circling(bias, M=100, K=1200, seed=1, dr=0.3):
    """A platform circling a buoy at 1500 m (a range every 5 s) with a constant range bias, noisy DR."""
    rng = np.random.default_rng(seed)
    theta = -np.pi / 2 + np.arange(K) * 10.0 / 1500.0
    track = 1500.0 * np.column_stack([np.cos(theta), np.sin(theta)])
    u = np.diff(track, axis=0, prepend=track[:1]) + rng.normal(0.0, dr, (M, K, 2))
    u[:, 0] = 0.0
    z = 1500.0 + bias + rng.normal(0.0, np.sqrt(5.0), (M, K))
    x0 = track[0] + rng.normal(0.0, 30.0, (M, 2))
    return track, u, z, x0


def rmse_tail(x, track, tail=400):
    return float(np.sqrt(np.mean(np.sum((x[:, -tail:, :2] - track[-tail:]) ** 2, axis=-1))))


def test_constant_bias_converges_and_beats_the_plain_ekf():
    track, u, z, x0 = circling(bias=40.0)
    Q = paper_a_process_noise(0.3)
    iekf = bias_ekf(np.column_stack([x0, np.zeros(len(x0))]), np.diag([900.0, 900.0, 2500.0]), u, z, Q, 5.0)
    ekf = range_only_ekf(x0, np.eye(2) * 900.0, u, z, Q[:2, :2], 5.0)
    bias_err = iekf.x[:, -400:, 2] - 40.0
    assert abs(bias_err.mean()) < 3.0 and np.sqrt(np.mean(bias_err**2)) < 6.0
    assert abs(iekf.x[:, 50, 2].mean() - 40.0) > 3 * abs(bias_err.mean())           # it did have to converge
    e_iekf, e_ekf = rmse_tail(iekf.x, track), rmse_tail(ekf.x, track)
    assert e_iekf < 0.3 * e_ekf, (e_iekf, e_ekf)
    # the bias state's +-2 sigma covers the truth about as often as it should
    sigma_b = np.sqrt(iekf.P[:, -400:, 2, 2])
    assert 0.85 < np.mean(np.abs(bias_err) < 2 * sigma_b) <= 1.0


def test_price_of_the_bias_state_without_a_bias():
    track, u, z, x0 = circling(bias=0.0)
    Q = paper_a_process_noise(0.3)
    iekf = bias_ekf(np.column_stack([x0, np.zeros(len(x0))]), np.diag([900.0, 900.0, 25.0]), u, z, Q, 5.0)
    ekf = range_only_ekf(x0, np.eye(2) * 900.0, u, z, Q[:2, :2], 5.0)
    e_iekf, e_ekf = rmse_tail(iekf.x, track), rmse_tail(ekf.x, track)
    # one more unknown costs accuracy, but only a little once the bearing has turned
    assert e_ekf <= e_iekf < 1.5 * e_ekf, (e_iekf, e_ekf)
    assert abs(iekf.x[:, -400:, 2].mean()) < 1.0


def test_prepositioned_start_is_the_least_squares_fix_then_the_filter():
    sc = paper_a.make(np.random.default_rng(3), n_runs=6, params=paper_a.PaperAParameters(n_obs=600))
    z = np.array(sc.ranges)
    z[:, 100:110] = np.nan                                   # a silence before the start
    z[2, 300:305] = np.nan                                   # and one run with its own gap
    u = np.asarray(sc.dr_displacements)
    start = np.asarray(sc.true_positions[:, 0]) + [120.0, -60.0]
    Q = paper_a_process_noise(1.0)
    res = prepositioned_bias_ekf(start, np.eye(3), u, z, Q, 5.0, times=sc.times)
    started = res.extras["started"]
    k0 = np.argmax(started, axis=1)
    provisional = start[:, None] + np.cumsum(u, axis=1)
    for m in range(6):
        ok = np.isfinite(z[m, :k0[m] + 1])
        alpha = lsq.precision_factor_history(provisional[m, :k0[m] + 1][ok])
        assert alpha[-1] < 2.0 <= alpha[-2]                  # the first epoch with alpha < 2
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", lsq.IllConditionedWarning)
            fix = lsq.prepositioning(z[m, :k0[m] + 1][ok], provisional[m, :k0[m] + 1][ok], provisional[m, k0[m]],
                                     iterations=3, sigma=np.sqrt(5.0))
        np.testing.assert_allclose(res.x[m, k0[m]], fix.estimate, **TOL)
        assert np.isnan(res.x[m, :k0[m]]).all() and not res.extras["accepted"][m, :k0[m] + 1].any()
        after = bias_ekf(fix.estimate, np.eye(3), u[m, k0[m] + 1:], z[m, k0[m] + 1:], Q, 5.0)
        np.testing.assert_allclose(res.x[m, k0[m] + 1:], after.x, **TOL)
        np.testing.assert_allclose(res.P[m, k0[m] + 1:], after.P, **TOL)
        np.testing.assert_array_equal(res.extras["accepted"][m, k0[m] + 1:], after.extras["accepted"])
    err = np.linalg.norm(res.x[:, -1, :2] - sc.true_positions[:, -1], axis=-1)
    assert np.sqrt(np.mean(err**2)) < 40.0


def test_prepositioning_never_trusted_leaves_the_run_unstarted():
    sc = paper_a.make(np.random.default_rng(4), n_runs=2, params=paper_a.PaperAParameters(n_obs=60))
    res = prepositioned_bias_ekf(sc.true_positions[:, 0], None, sc.dr_displacements, sc.ranges,
                                 paper_a_process_noise(1.0), 5.0)
    assert not res.extras["started"].any() and np.isnan(res.x).all()


def test_lake_trial_moving_beacon_equals_the_relative_frame():
    trial = paper_a.make_lake_trial(np.random.default_rng(5), n_runs=3)
    rel, u_rel = trial.relative()
    start = rel[0] + [30.0, -20.0]
    Q = paper_a_process_noise(0.7)
    x0 = np.column_stack([start + trial.sender_gnss[:, 0], np.zeros(3)])     # each run's own GNSS fix
    moving = bias_ekf(x0, np.eye(3) * 100.0,
                      trial.receiver_displacements, trial.ranges, Q, 9.0, beacon=trial.sender_gnss)
    relative = bias_ekf(np.r_[start, 0.0], np.eye(3) * 100.0, u_rel, trial.ranges, Q, 9.0)
    np.testing.assert_allclose(moving.x[..., :2] - trial.sender_gnss, relative.x[..., :2], rtol=0, atol=1e-8)
    np.testing.assert_allclose(moving.x[..., 2], relative.x[..., 2], rtol=0, atol=1e-8)
    np.testing.assert_allclose(moving.P, relative.P, rtol=1e-9, atol=1e-9)
    assert np.isnan(trial.ranges[:, trial.group == 0]).all() and np.isfinite(trial.ranges[:, trial.group > 0]).all()


def test_bias_rate_state_follows_a_ramp_the_random_walk_cannot():
    params = paper_a.PaperAParameters(dr_sigma=0.2, n_obs=2000)
    sc, bias = paper_a.make_with_truth(np.random.default_rng(6), n_runs=60, params=params)
    rate = 0.03                                               # m/s: the range opening under a 1 % scale error
    z = np.asarray(sc.ranges) + rate * sc.times
    truth_bias = bias + rate * sc.times
    tp = np.asarray(sc.true_positions)
    x0 = np.column_stack([tp[:, 0], truth_bias[:, 0]])
    P0 = np.diag([100.0, 100.0, 100.0])
    walk = bias_ekf(x0, P0, sc.dr_displacements, z, paper_a_process_noise(0.2), 5.0)
    motion = BiasRateDeadReckoning(bias_rate_process_noise(0.2, rate_sigma=3e-4, dt=5.0), dt=5.0)
    ramp = extended_kalman_filter(motion, RangeToBeacon((0.0, 0.0), 5.0, n=4, bias_index=2),
                                  np.column_stack([x0, np.zeros(60)]), np.diag([100.0, 100.0, 100.0, 1e-3]),
                                  sc.dr_displacements, z)
    truth3 = np.concatenate([tp, truth_bias[..., None]], axis=-1)
    nees_walk = walk.nees(truth3)[:, 1000:].mean()
    e = truth3 - ramp.x[..., :3]
    nees_ramp = np.einsum("...i,...i->...", e, np.linalg.solve(ramp.P[..., :3, :3], e[..., None])[..., 0])
    assert nees_walk > 10 * 3.0                                # far outside a 3-dof chi-square
    assert nees_ramp[:, 1000:].mean() < 4.5
    assert abs(ramp.x[:, -1, 3].mean() - rate) < 0.2 * rate         # the OU part of the bias has slopes too
    assert rmse_tail(ramp.x, tp[0]) < 0.5 * rmse_tail(walk.x, tp[0])


def test_paper_a_process_noise_rule():
    np.testing.assert_allclose(paper_a_process_noise(1.0, 2.0), np.diag([1.0, 4.0, 2.5]))
    np.testing.assert_allclose(paper_a_process_noise(1.0, sigma_bias=3.0), np.diag([1.0, 1.0, 9.0]))
    Q = bias_rate_process_noise(0.5, rate_sigma=0.1, dt=2.0)
    np.testing.assert_allclose(Q[2:, 2:], 0.01 * np.array([[8.0 / 3.0, 2.0], [2.0, 2.0]]))
    assert np.linalg.eigvalsh(Q).min() >= -1e-15


def test_variance_split_keeps_the_total():
    base = paper_a.PaperAParameters(bias_mean=0.0, gamma=0.0, noise_variance=1e-6, n_obs=1500)
    for share in (0.0, 0.3, 1.0):
        p = paper_a.variance_split(share, 20.0, params=base, mean_range=1500.0)
        assert p.bias_sigma**2 + (p.gamma_sigma * 1500.0) ** 2 == pytest.approx(400.0)
        sc, bias = paper_a.make_with_truth(np.random.default_rng(7), n_runs=400, params=p)
        r = np.asarray(sc.true_ranges)
        mult = np.asarray(sc.range_errors) - bias              # the white multiplicative part
        assert np.var(mult / r) * 1500.0**2 == pytest.approx((1 - share) * 400.0, rel=0.05, abs=0.5)
        assert np.var(bias) == pytest.approx(share * 400.0, rel=0.1, abs=0.5)


def test_random_turns_are_towards_the_buoy_and_keep_circling():
    track = paper_a.random_turn_track(np.random.default_rng(8), np.arange(0.0, 15000.0, 5.0))
    heading = np.unwrap(track.headings)
    turns = np.diff(heading)
    assert (turns >= -1e-12).all() and (turns > 1e-6).sum() > 50           # left turns only (counter-clockwise)
    bearing = np.unwrap(np.arctan2(track.positions[:, 1], track.positions[:, 0]))
    assert bearing[-1] - bearing[0] > 2 * 2 * np.pi                          # more than two laps


def test_circle_option_reuses_the_circling_scenario_geometry():
    from uwtutor.scenarios import circling_scenario
    p = paper_a.PaperAParameters(track="circle", n_obs=400)
    sc = paper_a.make(np.random.default_rng(9), n_runs=2, params=p)
    ref = circling_scenario(np.random.default_rng(0), 1, duration=5.0 * 399)
    np.testing.assert_allclose(sc.true_positions[0], ref.true_positions[0])


@pytest.mark.parametrize("kwargs, match", [
    (dict(Q=np.eye(2)), "Q must be 3x3"),
    (dict(Q=-np.eye(3)), "Q must be positive semi-definite"),
    (dict(R=0.0), "R must be"),
    (dict(P0=np.diag([1.0, 1.0, -1.0])), "P0 must be positive definite"),
    (dict(x0=[np.nan, 0.0, 0.0]), "x0 must be finite"),
    (dict(x0=[0.0, 0.0]), "x0 must have 3 entries"),
])
def test_bad_input_names_the_argument(kwargs, match):
    args = dict(x0=[1000.0, 0.0, 0.0], P0=np.eye(3), u=np.zeros((5, 2)), z=np.full(5, 1000.0), Q=Q3, R=R)
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        bias_ekf(**args)


def test_bad_scenario_parameters():
    with pytest.raises(ValueError, match="track must be"):
        paper_a.PaperAParameters(track="square")
    with pytest.raises(ValueError, match="gamma must lie|gamma is a relative"):
        paper_a.PaperAParameters(gamma=0.7)
    with pytest.raises(ValueError, match="no random multiplicative"):
        paper_a.PaperAParameters(track="circle", gamma_sigma=0.001)
    with pytest.raises(ValueError, match="bias_share"):
        paper_a.variance_split(1.5)
    with pytest.raises(TypeError, match="params must be a PaperAParameters"):
        paper_a.make(np.random.default_rng(0), 1, params=replace)
    with pytest.raises(ValueError, match="group_noise"):
        paper_a.LakeTrialParameters(group_noise=(1.0, 0.0, 1.0, 1.0))
