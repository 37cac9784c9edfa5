"""Fading EKFs for multiplicative range noise (paper D): the equations, the special cases, the fading behaviour.

The batched 2x2 algebra is checked against a literal per-run transcription of paper D's equations (with matrices);
the multiplicative filter with mu = 1, sigma = 0 against the plain EKF; the object form against the functional form;
and the fading factor's behaviour under a correct model and after a jump of the state.
"""

import dataclasses

import numpy as np
import pytest

from uwtutor import lsq, metrics, scenarios
from uwtutor.filters.ekf import range_only_ekf
from uwtutor.filters.fading import FadingEKF, fading_ekf, range_factor_moments
from uwtutor.pipelines import LSFadingResult, ls_fading_ekf

TOL = dict(rtol=1e-6, atol=1e-6)
Q_D = np.eye(2) * 0.81
R_D = 0.49
MU_D, SIGMA_D = 0.98, 1.0 / 1500.0


def reference(x0, P0, u, z, Q, R, mu, sigma, rho, beta, fading=True, Xi0=None, beacon=(0.0, 0.0)):
    """Paper D's eqs. (13)-(27) for one run, literally, with 2x2 matrices.

    Eq. (24), P = (I - mu K C) P-, is written in the algebraically equal Joseph form: with the huge fading
    factors of the first steps the two forms differ by more than rounding (the covariance is ill-conditioned).
    """
    b = np.asarray(beacon, float)
    x = np.asarray(x0, float).copy()
    P = np.asarray(P0, float).copy()
    m = x.copy()
    Xi = P + np.outer(x, x) if Xi0 is None else np.asarray(Xi0, float).copy()
    V = None
    out = {k: [] for k in ("x", "P", "lam", "beta", "y", "S")}
    Q_all, R_all = np.asarray(Q, float), np.asarray(R, float)
    for k, (uk, zk) in enumerate(zip(u, z)):
        Q = Q_all[k] if Q_all.ndim == 3 else Q_all                             # one per step, or shared
        R = float(R_all[k]) if R_all.ndim == 1 else float(R_all)
        uk = np.asarray(uk, float)
        Xi = Xi + np.outer(m, uk) + np.outer(uk, m) + np.outer(uk, uk) + Q      # eq. (15)
        m = m + uk                                                             # eq. (14)
        xp = x + uk                                                            # eq. (13)
        if np.isnan(zk):
            x, P = xp, P + Q
            for key, val in (("lam", 1.0), ("beta", np.nan), ("y", np.nan), ("S", np.nan)):
                out[key].append(val)
        else:
            r = np.linalg.norm(xp - b)
            C = ((xp - b) / r)[None, :]                                        # 1 x 2
            d = float(-(C @ b)[0])
            T = max(float((C @ Xi @ C.T)[0, 0] + 2 * (C @ m)[0] * d + d * d), 0.0)
            zt = zk - mu * r                                                   # eq. (16)
            V = zt**2 if V is None else (rho * V + zt**2) / (1 + rho)          # eq. (20)
            bet = float((C @ m)[0]) + d if beta == "range" else beta           # eq. (27)
            Mk = V - sigma**2 * T - mu**2 * float((C @ Q @ C.T)[0, 0]) - bet * R   # eq. (26)
            Nk = mu**2 * float((C @ P @ C.T)[0, 0])                            # eq. (19)
            lam = max(1.0, Mk / Nk) if fading else 1.0                         # eq. (17)
            Pp = lam * P + Q                                                   # eq. (21)
            Rd = sigma**2 * T + mu**2 * float((C @ Pp @ C.T)[0, 0]) + R        # eq. (22)
            K = (mu / Rd) * (Pp @ C.T)                                         # eq. (23)
            A = np.eye(2) - mu * K @ C                                         # eq. (24), Joseph form
            P = A @ Pp @ A.T + (sigma**2 * T + R) * (K @ K.T)
            x = xp + K[:, 0] * zt                                              # eq. (25)
            for key, val in (("lam", lam), ("beta", bet), ("y", zt), ("S", Rd)):
                out[key].append(val)
        out["x"].append(x.copy())
        out["P"].append(P.copy())
    return {k: np.array(v) for k, v in out.items()}


def approach(M=8, seed=0, initial_error=20.0, **kw):
    """Paper D's scenario and a start ``initial_error`` metres off in a random direction per run."""
    sc = scenarios.approach_with_turn_scenario(np.random.default_rng(seed), n_runs=M, **kw)
    rng = np.random.default_rng(seed + 100)
    ang = rng.uniform(0.0, 2 * np.pi, M)
    x0 = sc.true_positions[:, 0] + initial_error * np.column_stack([np.cos(ang), np.sin(ang)])
    return sc, x0, np.eye(2) * initial_error**2


def consistent_study(M=200, K=150, seed=7, jump_at=None, jump=(0.0, 0.0), beacon=(0.0, 0.0)):
    """A correctly specified additive model: truth = DR + process noise, ranges = truth + N(0, R)."""
    rng = np.random.default_rng(seed)
    t = np.arange(K + 1)
    track = np.column_stack([-2000.0 + 2.0 * 10 * t, 800.0 - 10.0 * t])   # straight, 10 s per step
    heading_change = t >= K // 3                                            # one turn
    track[heading_change] = track[K // 3] + np.column_stack([0.0 * t, 20.0 * (t - K // 3)])[heading_change]
    u = np.broadcast_to(np.diff(track, axis=0), (M, K, 2)).copy()
    truth = track[1:] + np.cumsum(rng.normal(0.0, 0.9, (M, K, 2)), axis=1)
    if jump_at is not None:
        truth[:, jump_at:] += np.asarray(jump)
    z = np.linalg.norm(truth - np.asarray(beacon), axis=-1) + rng.normal(0.0, 0.7, (M, K))
    P0 = np.eye(2) * 25.0
    x0 = track[0] + rng.multivariate_normal([0.0, 0.0], P0, M)
    return x0, P0, u, z, truth


# --- the equations -------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("beta", ["range", 1.0, 3.0])
@pytest.mark.parametrize("beacon", [(0.0, 0.0), (150.0, -80.0)])
def test_batched_equals_literal_equations(beta, beacon):
    """A correctly specified model started close to the truth: the fading factor stays moderate, so the two
    implementations agree to rounding."""
    x0, P0, u, z, _ = consistent_study(M=4, K=120, seed=1, beacon=beacon)
    z[:, [5, 40, 41, 90]] = np.nan                      # missing replies: predict only
    mu = np.array([0.98, 0.99, 1.0, 1.01])
    res = fading_ekf(x0, P0, u, z, Q_D, R_D, mu_gamma=mu, sigma_gamma=SIGMA_D, rho=0.9, beta=beta, beacon=beacon)
    assert res.fading_factor.max() > 1.0                # the fading branch is exercised
    for m in range(4):
        ref = reference(x0[m], P0, u[m], z[m], Q_D, R_D, mu[m], SIGMA_D, 0.9, beta, beacon=beacon)
        np.testing.assert_allclose(res.x[m], ref["x"], **TOL)
        np.testing.assert_allclose(res.P[m], ref["P"], **TOL)
        np.testing.assert_allclose(res.fading_factor[m], ref["lam"], rtol=1e-6)
        used = np.isfinite(z[m])
        np.testing.assert_allclose(res.weakening_factor[m][used], ref["beta"][used], rtol=1e-9)
        np.testing.assert_allclose(res.innovations[m, :, 0], ref["y"], **TOL)
        np.testing.assert_allclose(res.innovation_cov[m, :, 0, 0], ref["S"], rtol=1e-6)
    assert np.all(res.fading_factor[np.isnan(z)] == 1.0)
    assert np.all(res.extras["updated"] == np.isfinite(z))
    assert np.isnan(res.extras["fading_numerator"][np.isnan(z)]).all()
    # V is kept through a missing range
    np.testing.assert_array_equal(res.extras["innovation_power"][:, 40], res.extras["innovation_power"][:, 39])


def test_per_step_q_and_r_equal_the_literal_equations():
    """One Q and one R per step (a log whose steps differ): the batched filter follows eqs. (13)-(27) step by step,
    a NaN variance where no range arrived is allowed, and constant per-step values give the shared-noise filter."""
    x0, P0, u, z, _ = consistent_study(M=3, K=90, seed=3)
    z[:, [4, 30]] = np.nan
    K = z.shape[1]
    Q = np.einsum("k,ij->kij", np.linspace(0.3, 1.5, K), Q_D)
    Q[:, 0, 1] = Q[:, 1, 0] = 0.05
    R = np.linspace(0.2, 1.0, K)
    R[[4, 30]] = np.nan
    res = fading_ekf(x0, P0, u, z, Q, R, mu_gamma=MU_D, sigma_gamma=SIGMA_D, rho=0.9)
    assert res.fading_factor.max() > 1.0
    for m in range(3):
        ref = reference(x0[m], P0, u[m], z[m], Q, np.nan_to_num(R, nan=1.0), MU_D, SIGMA_D, 0.9, "range")
        np.testing.assert_allclose(res.x[m], ref["x"], **TOL)
        np.testing.assert_allclose(res.P[m], ref["P"], **TOL)
        np.testing.assert_allclose(res.fading_factor[m], ref["lam"], rtol=1e-6)
    shared = fading_ekf(x0, P0, u, z, Q_D, R_D, mu_gamma=MU_D, sigma_gamma=SIGMA_D)
    tiled = fading_ekf(x0, P0, u, z, np.tile(Q_D, (K, 1, 1)), np.full(K, R_D), mu_gamma=MU_D, sigma_gamma=SIGMA_D)
    np.testing.assert_array_equal(tiled.x, shared.x)
    np.testing.assert_array_equal(tiled.P, shared.P)
    with pytest.raises(ValueError, match="R is NaN at step 5, where a range is present"):
        fading_ekf(x0, P0, u, z, Q_D, np.r_[np.ones(5), np.nan, np.ones(K - 6)])
    with pytest.raises(ValueError, match=r"Q must be one 2x2 matrix shared by all runs, or one per step \(90, 2, 2\)"):
        fading_ekf(x0, P0, u, z, np.tile(Q_D, (K + 1, 1, 1)), R_D)


def test_batched_equals_literal_equations_with_huge_fading_factors():
    """Paper D's scenario from 150 m off with beta = 1: the fading factors reach the thousands and the covariance
    becomes ill-conditioned, so rounding differences grow to about a millimetre; the equations still agree."""
    sc, x0, P0 = approach(M=3, seed=1, initial_error=150.0)
    res = fading_ekf(x0, P0, sc.dr_displacements, sc.ranges, Q_D, R_D, mu_gamma=MU_D, sigma_gamma=SIGMA_D,
                     beta=1.0)
    assert res.fading_factor.max() > 100.0
    for m in range(3):
        ref = reference(x0[m], P0, sc.dr_displacements[m], sc.ranges[m], Q_D, R_D, MU_D, SIGMA_D, 0.95, 1.0)
        np.testing.assert_allclose(res.x[m], ref["x"], rtol=0, atol=2e-3)
        np.testing.assert_allclose(res.fading_factor[m], ref["lam"], rtol=1e-3)


def test_literal_second_moment_of_the_paper_is_supported():
    sc, x0, P0 = approach(M=3, seed=2)
    res = fading_ekf(x0, P0, sc.dr_displacements, sc.ranges, Q_D, R_D, mu_gamma=MU_D, sigma_gamma=SIGMA_D,
                     second_moment0=P0)
    for m in range(3):
        ref = reference(x0[m], P0, sc.dr_displacements[m], sc.ranges[m], Q_D, R_D, MU_D, SIGMA_D, 0.95, "range",
                        Xi0=P0)
        np.testing.assert_allclose(res.x[m], ref["x"], **TOL)
    assert np.all(res.extras["multiplicative_variance"] >= 0.0)      # E[(Cx + d)^2] is clipped at zero


# --- special cases -------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("beacon", [(0.0, 0.0), (150.0, -80.0)])
def test_mu_one_sigma_zero_without_fading_is_the_plain_ekf(beacon):
    sc, x0, P0 = approach(M=6, seed=3, initial_error=150.0)
    z = np.array(sc.ranges)
    z[:, 10:14] = np.nan
    ekf = range_only_ekf(x0, P0, sc.dr_displacements, z, Q_D, R_D, beacon=beacon)
    fad = fading_ekf(x0, P0, sc.dr_displacements, z, Q_D, R_D, mu_gamma=1.0, sigma_gamma=0.0, fading=False,
                     beacon=beacon)
    for name in ("x", "P", "x_prior", "P_prior", "innovations", "innovation_cov"):
        np.testing.assert_array_equal(getattr(fad, name), getattr(ekf, name), err_msg=name)
    np.testing.assert_array_equal(fad.fading_factor, 1.0)


def test_fading_that_never_triggers_gives_the_plain_ekf():
    sc, x0, P0 = approach(M=6, seed=4)
    ekf = range_only_ekf(x0, P0, sc.dr_displacements, sc.ranges, Q_D, R_D)
    fad = fading_ekf(x0, P0, sc.dr_displacements, sc.ranges, Q_D, R_D, beta=1e12)   # M < 0 always
    np.testing.assert_array_equal(fad.fading_factor, 1.0)
    np.testing.assert_allclose(fad.x, ekf.x, rtol=0, atol=1e-9)
    np.testing.assert_allclose(fad.P, ekf.P, rtol=1e-12, atol=1e-9)


def test_object_form_single_run_and_predict_only_steps():
    sc, x0, P0 = approach(M=1, seed=6)
    u, z = sc.dr_displacements[0], np.array(sc.ranges[0])
    z[7] = np.nan
    ref = fading_ekf(x0[0], P0, u, z, Q_D, R_D, mu_gamma=MU_D, sigma_gamma=SIGMA_D)
    f = FadingEKF(x0[0], P0, Q_D, R_D, mu_gamma=MU_D, sigma_gamma=SIGMA_D)
    for k in range(12):
        f.predict(u[k])
        if k == 7:
            continue                       # no range: the next predict makes step 7 predict only
        f.update(z[k])
        assert f.x.shape == (2,) and f.P.shape == (2, 2) and f.y.shape == (1,) and f.S.shape == (1, 1)
        np.testing.assert_allclose(f.x, ref.x[k], rtol=0, atol=1e-9)
        assert float(f.fading_factor) == pytest.approx(ref.fading_factor[k])
    f.predict(None)
    f.update(np.nan)                       # NaN: predict only, innovation NaN, lambda 1
    assert np.isnan(f.y).all() and float(f.fading_factor) == 1.0


# --- behaviour of the fading factor --------------------------------------------------------------------------------

@pytest.mark.parametrize("beta", [1.0, 2.0, "range"])
def test_correct_model_keeps_the_fading_factor_at_one_most_of_the_time(beta):
    x0, P0, u, z, truth = consistent_study()
    res = fading_ekf(x0, P0, u, z, Q_D, R_D, beta=beta)
    lam = res.fading_factor
    assert np.all(lam >= 1.0)
    assert np.mean(lam == 1.0) > 0.5, np.mean(lam == 1.0)
    if beta == "range":
        assert np.mean(lam == 1.0) > 0.95


@pytest.mark.parametrize("beta", [1.0, "range"])
def test_fading_factor_exceeds_one_right_after_a_jump_of_the_state(beta):
    k_jump = 100
    x0, P0, u, z, truth = consistent_study(jump_at=k_jump, jump=(120.0, -90.0))
    res = fading_ekf(x0, P0, u, z, Q_D, R_D, beta=beta)
    lam = res.fading_factor
    assert np.mean(lam[:, k_jump] > 1.0) > 0.9
    assert np.median(lam[:, k_jump]) > 10.0
    assert np.mean(lam[:, k_jump - 10:k_jump] == 1.0) > 0.5         # it was quiet before


def test_weakening_factor_is_about_the_predicted_range():
    sc, x0, P0 = approach(M=20, seed=8)
    res = fading_ekf(x0, P0, sc.dr_displacements, sc.ranges, Q_D, R_D, mu_gamma=MU_D, sigma_gamma=SIGMA_D)
    m = x0[:, None, :] + np.cumsum(sc.dr_displacements, axis=1)     # the prior mean: DR from the start
    beta = res.weakening_factor
    assert np.all(beta <= np.linalg.norm(m, axis=-1) + 1e-9)          # C m <= |m| ...
    predicted = np.linalg.norm(res.x_prior, axis=-1)
    assert np.median(np.abs(beta / predicted - 1.0)) < 0.05           # ... and close to the predicted range
    const = fading_ekf(x0, P0, sc.dr_displacements, sc.ranges, Q_D, R_D, beta=2.5)
    np.testing.assert_array_equal(const.weakening_factor, 2.5)


def test_multiplicative_model_is_consistent_and_the_additive_one_is_not():
    sc, x0, P0 = approach(M=300, seed=9, initial_error=10.0)
    mult = fading_ekf(x0, P0, sc.dr_displacements, sc.ranges, Q_D, R_D, mu_gamma=MU_D, sigma_gamma=SIGMA_D,
                      fading=False)
    add = range_only_ekf(x0, P0, sc.dr_displacements, sc.ranges, Q_D, R_D)
    late = slice(30, None)
    nis_mult = np.nanmean(metrics.nis(mult.innovations, mult.innovation_cov)[:, late])
    nis_add = np.nanmean(metrics.nis(add.innovations, add.innovation_cov)[:, late])
    assert 0.7 < nis_mult < 1.4, nis_mult
    assert nis_add > 1.8, nis_add
    assert metrics.rmse_over_time(mult.x, sc.true_positions)[-1] < 0.5 * metrics.rmse_over_time(
        add.x, sc.true_positions)[-1]


def test_range_factor_moments():
    mu, sigma = range_factor_moments(1470.0, 1500.0, 1.0)
    assert mu == pytest.approx(0.98) and sigma == pytest.approx(0.98 / 1500)
    assert range_factor_moments(1500.0, 1500.0, 0.0) == (1.0, 0.0)
    mu, _ = range_factor_moments(1530.0, 1500.0, 0.0)
    assert mu == pytest.approx(1.02)                      # too fast an assumed speed: ranges too long
    with pytest.raises(ValueError, match="assumed_speed"):
        range_factor_moments(0.0, 1500.0, 1.0)
    with pytest.raises(ValueError, match="speed_sigma"):
        range_factor_moments(1470.0, 1500.0, -1.0)


# --- LS-EKF and LS-ISFEKF ------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def ls_study():
    sc = scenarios.approach_with_turn_scenario(np.random.default_rng(11), n_runs=12)
    pre = lsq.grid_prelocation(ranges=sc.ranges, dr_displacements=sc.dr_displacements)
    acc = lsq.prelocation_acceptance(pre.start, sc.dr_displacements)
    return sc, pre, acc


def test_ls_fading_ekf_starts_from_the_accepted_prelocation(ls_study):
    sc, pre, acc = ls_study
    P0 = np.eye(2) * 50.0**2
    res = ls_fading_ekf(P0, sc.dr_displacements, sc.ranges, Q_D, R_D, sigma_gamma=SIGMA_D, times=sc.times,
                        prelocation=pre, acceptance=acc)
    assert isinstance(res, LSFadingResult)
    assert res.x.shape == (12, sc.n_steps, 2) and res.P.shape == (12, sc.n_steps, 2, 2)
    assert res.accepted.all()
    np.testing.assert_array_equal(res.start_epoch, acc.epoch)
    np.testing.assert_array_equal(res.mu_gamma, pre.range_scale[np.arange(12), acc.epoch])
    for m in (0, 5):
        k0 = acc.epoch[m]
        np.testing.assert_array_equal(res.x[m, :k0 + 1], pre.position[m, :k0 + 1])
        assert np.isnan(res.P[m, :k0 + 1]).all() and np.isnan(res.fading_factor[m, :k0 + 1]).all()
        by_hand = fading_ekf(pre.position[m, k0], P0, sc.dr_displacements[m, k0 + 1:], sc.ranges[m, k0 + 1:],
                             Q_D, R_D, mu_gamma=pre.range_scale[m, k0], sigma_gamma=SIGMA_D)
        np.testing.assert_allclose(res.x[m, k0 + 1:], by_hand.x, rtol=0, atol=1e-9)
        np.testing.assert_allclose(res.fading_factor[m, k0 + 1:], by_hand.fading_factor, rtol=1e-12)
    # the same grid search is found again when not given
    again = ls_fading_ekf(P0, sc.dr_displacements[:3], sc.ranges[:3], Q_D, R_D, sigma_gamma=SIGMA_D)
    np.testing.assert_allclose(again.x, res.x[:3], rtol=0, atol=1e-9)


def test_ls_ekf_is_the_plain_ekf_after_the_prelocation(ls_study):
    sc, pre, acc = ls_study
    P0 = np.eye(2) * 50.0**2
    res = ls_fading_ekf(P0, sc.dr_displacements, sc.ranges, Q_D, R_D, mu_gamma=1.0, sigma_gamma=0.0, fading=False,
                        prelocation=pre, acceptance=acc)
    np.testing.assert_array_equal(res.mu_gamma, 1.0)
    m, k0 = 2, acc.epoch[2]
    ekf = range_only_ekf(pre.position[m, k0], P0, sc.dr_displacements[m, k0 + 1:], sc.ranges[m, k0 + 1:], Q_D, R_D)
    np.testing.assert_allclose(res.x[m, k0 + 1:], ekf.x, rtol=0, atol=1e-9)
    np.testing.assert_allclose(res.P[m, k0 + 1:], ekf.P, rtol=1e-9, atol=1e-9)


def test_ls_fading_ekf_without_acceptance_keeps_the_prelocation(ls_study):
    sc, pre, acc = ls_study
    epoch = np.array(acc.epoch)
    epoch[[1, 4]] = -1
    never = dataclasses.replace(acc, epoch=epoch, accepted=epoch >= 0)
    res = ls_fading_ekf(np.eye(2) * 2500.0, sc.dr_displacements, sc.ranges, Q_D, R_D, prelocation=pre,
                        acceptance=never)
    assert not res.accepted[1] and not res.accepted[4] and res.accepted[0]
    np.testing.assert_array_equal(res.x[1], pre.position[1])
    assert np.isnan(res.P[4]).all()


def test_ls_fading_ekf_bad_input(ls_study):
    sc, pre, acc = ls_study
    P0 = np.eye(2) * 2500.0
    with pytest.raises(ValueError, match="prelocation"):
        ls_fading_ekf(P0, sc.dr_displacements[:5], sc.ranges[:5], Q_D, R_D, prelocation=pre)
    with pytest.raises(ValueError, match="acceptance"):
        ls_fading_ekf(P0, sc.dr_displacements, sc.ranges, Q_D, R_D, prelocation=pre,
                      acceptance=dataclasses.replace(acc, epoch=acc.epoch[:3]))
    with pytest.raises(ValueError, match="mu_gamma"):
        ls_fading_ekf(P0, sc.dr_displacements, sc.ranges, Q_D, R_D, mu_gamma="paper", prelocation=pre,
                      acceptance=acc)
    with pytest.raises(ValueError, match="dr_displacements"):
        ls_fading_ekf(P0, sc.dr_displacements[:, :-1], sc.ranges, Q_D, R_D, prelocation=pre, acceptance=acc)
    with pytest.raises(ValueError, match="P0"):
        ls_fading_ekf(np.eye(3), sc.dr_displacements, sc.ranges, Q_D, R_D, prelocation=pre, acceptance=acc)


# --- bad input ------------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("kw, match", [
    (dict(rho=0.0), "rho"),
    (dict(rho=1.5), "rho"),
    (dict(rho=np.nan), "rho"),
    (dict(beta="paper"), "beta"),
    (dict(beta=-1.0), "beta"),
    (dict(mu_gamma=0.0), "mu_gamma"),
    (dict(mu_gamma=[1.0, 1.0, 1.0]), "runs"),
    (dict(sigma_gamma=-0.1), "sigma_gamma"),
    (dict(second_moment0=np.eye(3)), "second_moment0"),
    (dict(second_moment0=[[1.0, 2.0], [0.0, 1.0]]), "symmetric"),
])
def test_bad_parameters_are_named(kw, match):
    sc, x0, P0 = approach(M=4, seed=12)
    with pytest.raises(ValueError, match=match):
        fading_ekf(x0, P0, sc.dr_displacements, sc.ranges, Q_D, R_D, **kw)


def test_bad_data_are_named():
    sc, x0, P0 = approach(M=4, seed=13)
    z = np.array(sc.ranges)
    z[1, 3] = -5.0
    with pytest.raises(ValueError, match="z must be finite and >= 0"):
        fading_ekf(x0, P0, sc.dr_displacements, z, Q_D, R_D)
    with pytest.raises(ValueError, match="u must"):
        fading_ekf(x0, P0, sc.dr_displacements[..., :1], sc.ranges, Q_D, R_D)
    with pytest.raises(ValueError, match="one range per step"):
        fading_ekf(x0, P0, sc.dr_displacements, sc.ranges[:, :-1], Q_D, R_D)
    with pytest.raises(ValueError, match="R"):
        fading_ekf(x0, P0, sc.dr_displacements, sc.ranges, Q_D, -1.0)
    with pytest.raises(TypeError, match="fading"):
        fading_ekf(x0, P0, sc.dr_displacements, sc.ranges, Q_D, R_D, fading="yes")


def test_object_form_misuse():
    f = FadingEKF([1000.0, 0.0], np.eye(2) * 100.0, Q_D, R_D)
    with pytest.raises(RuntimeError, match="predict"):
        f.update(1000.0)
    f.predict([0.0, 0.0])
    with pytest.raises(RuntimeError, match="pending"):
        f.run(np.full(3, 1000.0))
    with pytest.raises(ValueError, match="u must"):
        f.predict([1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="z must"):
        f.update([1000.0, 1000.0])


def test_fading_ekf_is_the_engine_with_the_fading_back_end():
    """FadingEKF is an ExtendedKalmanFilter on the pair DeadReckoning + RangeToBeacon whose steps are the fading
    loop's: stepped by hand, run, and fading_ekf give the same numbers, bit for bit."""
    from uwtutor.filters import ExtendedKalmanFilter
    from uwtutor.models import DeadReckoning, RangeToBeacon

    sc, x0, P0 = approach(M=3, seed=4)
    u, z = sc.dr_displacements, np.array(sc.ranges)
    z[:, 5] = np.nan
    kw = dict(mu_gamma=MU_D, sigma_gamma=SIGMA_D, beacon=(20.0, -10.0))
    ref = fading_ekf(x0, P0, u, z, Q_D, R_D, **kw)
    f = FadingEKF(x0, P0, Q_D, R_D, **kw)
    assert isinstance(f, ExtendedKalmanFilter)
    assert type(f.motion) is DeadReckoning and type(f.measurement) is RangeToBeacon
    for k in range(20):
        f.predict(u[:, k])
        f.update(z[:, k])
        assert np.array_equal(f.x, ref.x[:, k]) and np.array_equal(f.P, ref.P[:, k]), k
        assert np.array_equal(f.fading_factor, ref.fading_factor[:, k])
        np.testing.assert_array_equal(f.updated, f.accepted)
    assert f.k == 19
    rest = f.run(z[:, 20:], u[:, 20:])
    assert np.array_equal(rest.x, ref.x[:, 20:]) and np.array_equal(rest.P_prior, ref.P_prior[:, 20:])
    assert f.k == z.shape[1] - 1
    assert f.run(z[:, :3], u[:, :3], keep_priors=False).x_prior is None
