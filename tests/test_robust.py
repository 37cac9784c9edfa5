"""Paper E's robust range filter, its gates and the cascade filter: exactness, outlier rates, lock-out, recovery."""

from __future__ import annotations

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter as FilterpyKF

from uwtutor.errors import UwtutorWarning
from uwtutor.filters import ExtendedKalmanFilter, GateContext, run_filter
from uwtutor.filters.robust import (RobustGate, SecondMomentGate, cascade_kf, moment_gate_interval,
                                    robust_range_kf, robust_track_kf)
from uwtutor.models.robust import ConstantVelocity, PositionMeasurement, step_lengths
from uwtutor.ranging import Outliers
from uwtutor.scenarios import paper_e


def _clean_dive(n_runs=5, seed=0):
    return paper_e.make(np.random.default_rng(seed), n_runs, outlier_onsets=(), outlier_counts=(),
                        outlier_two_sided=())


def _longest_run(flags):
    best = cur = np.zeros(flags.shape[0], dtype=int)
    for k in range(flags.shape[1]):
        cur = np.where(flags[:, k], cur + 1, 0)
        best = np.maximum(best, cur)
    return best


# -- no outliers: the gated filter is the plain Kalman filter, number for number ---------------------------------------
@pytest.mark.parametrize("test, kw", [("paper", {}), ("chi2", {"probability": 1 - 1e-12})])
@pytest.mark.parametrize("on_outlier", ["predict", "extrapolate"])
def test_without_outliers_the_gated_filter_is_the_plain_kf(test, kw, on_outlier):
    z = _clean_dive().slant_ranges
    plain = robust_range_kf(z, 1.0, test="none")
    gated = robust_range_kf(z, 1.0, test=test, on_outlier=on_outlier, **kw)
    assert not gated.extras["rejected"].any()                 # the premise: nothing was rejected
    for name in ("x", "P", "x_prior", "P_prior", "innovations", "innovation_cov"):
        np.testing.assert_array_equal(getattr(gated, name), getattr(plain, name), err_msg=name)


def test_plain_range_kf_equals_filterpy_step_by_step():
    z = _clean_dive(1).slant_ranges[0]
    res = robust_range_kf(z, 1.0, test="none", q=2.0, r=2.0)
    kf = FilterpyKF(dim_x=2, dim_z=1)
    kf.x = np.array([z[0], 0.0])
    kf.P = np.diag([2.0, 25.0])
    kf.F = np.array([[1.0, 1.0], [0.0, 1.0]])
    kf.Q = 2.0 * np.array([[0.25, 0.5], [0.5, 1.0]])
    kf.H = np.array([[1.0, 0.0]])
    kf.R = np.array([[2.0]])
    for k, zk in enumerate(z):
        if k > 0:                                             # step 0: the initial state is at the first epoch
            kf.predict()
        kf.update(zk)
        np.testing.assert_allclose(res.x[k], kf.x, rtol=0, atol=1e-9)
        np.testing.assert_allclose(res.P[k], kf.P, rtol=0, atol=1e-9)


# -- paper E's test ----------------------------------------------------------------------------------------------------
def _ctx(z, z_pred, S):
    z = np.asarray(z, float).reshape(-1, 1)
    zp = np.broadcast_to(np.asarray(z_pred, float).reshape(-1, 1), z.shape)
    M = z.shape[0]
    return GateContext(k=0, z=z, z_pred=zp, y=z - zp, S=np.broadcast_to(np.reshape(S, (-1, 1, 1)), (M, 1, 1)),
                       H=np.ones((M, 1, 2)), R=np.eye(1), x_prior=np.zeros((M, 2)),
                       P_prior=np.tile(np.eye(2), (M, 1, 1)))


@pytest.mark.parametrize("z_pred, S, delta", [(1500.0, 4.0, 0.03), (300.0, 50.0, 0.03), (2000.0, 2.0, 0.01)])
def test_second_moment_gate_is_the_closed_form_interval(z_pred, S, delta):
    lo, hi = moment_gate_interval(z_pred, S, delta)
    eps = 1e-6
    y = np.array([lo - eps, lo + eps, 0.0, hi - eps, hi + eps])
    verdict = SecondMomentGate(delta).accept(_ctx(z_pred + y, z_pred, S))
    assert verdict.tolist() == [False, True, True, True, False]
    # and it is a gate of about delta/2 of the range
    assert lo == pytest.approx(-delta / 2 * z_pred, rel=0.05) and hi == pytest.approx(delta / 2 * z_pred, rel=0.05)


def test_second_moment_gate_rejects_the_prediction_itself_when_S_is_large():
    # D = S + zp² > zp² / (1 - delta) once S > delta zp² / (1 - delta): z = zp falls outside the gate
    zp, delta = 1500.0, 0.03
    S_edge = delta * zp**2 / (1 - delta)
    v = SecondMomentGate(delta).accept(_ctx([zp, zp], zp, np.array([0.99 * S_edge, 1.01 * S_edge])))
    assert v.tolist() == [True, False]


# -- outlier rates and lock-out ----------------------------------------------------------------------------------------
def _outlier_dive(n_runs, seed, count=15):
    """Paper E's dive with isolated outliers (2 %) and two patches: one-sided of ``count`` and two-sided of 10."""
    dive = _clean_dive(n_runs, seed)
    rng = np.random.default_rng(seed + 100)
    error = (Outliers((300.0,), count, 80.0) + Outliers((700.0,), 10, 80.0, two_sided=True)
             + Outliers((), 1, 80.0, two_sided=True, probability=0.02))
    e, mask = error.sample_with_mask(np.asarray(dive.true_slant_ranges[0]), np.asarray(dive.times), rng,
                                     n_runs=n_runs)
    return dive.slant_ranges + e, mask, dive.true_slant_ranges


@pytest.mark.parametrize("kw", [{}, {"test": "chi2", "q": 0.01}])
def test_outliers_flagged_and_good_ranges_kept_even_after_a_patch_of_15(kw):
    z, mask, truth = _outlier_dive(40, 1)
    res = robust_range_kf(z, 1.0, **kw)
    flagged = res.extras["outlier"]
    good = ~mask
    assert flagged[mask].mean() >= 0.90
    assert flagged[good].mean() <= 0.02
    after = np.zeros_like(mask)
    after[:, 315:415] = True                                   # the 100 epochs after the patch of 15
    assert flagged[good & after].mean() <= 0.02
    # no lock-out: at the end every run tracks the range again
    assert np.all(np.abs(res.x[:, -1, 0] - truth[:, -1]) < 10.0)


def test_the_literal_paper_method_locks_out_and_reacquisition_recovers():
    dive = paper_e.make(np.random.default_rng(2), 60)
    good = ~np.asarray(dive.outlier_mask)
    literal = robust_range_kf(dive.slant_ranges, 1.0, reacquire=None)
    lost = _longest_run(literal.extras["rejected"] & good)
    assert (lost >= 30).sum() >= 5                              # the failure mode of paper E's q = 2
    recovered = robust_range_kf(dive.slant_ranges, 1.0, reacquire=20)
    assert recovered.extras["reacquired"][lost >= 30].any(axis=1).all()
    assert _longest_run(recovered.extras["rejected"] & good).max() <= 25
    assert (recovered.extras["rejected"] & good).sum() < 0.2 * (literal.extras["rejected"] & good).sum()
    assert np.all(np.abs(recovered.x[:, -1, 0] - dive.true_slant_ranges[:, -1]) < 10.0)


def test_reacquisition_restarts_from_a_line_through_the_rejected_ranges():
    t = np.arange(120.0)
    truth = 1800.0 - 1.2 * t
    z = truth + np.random.default_rng(3).normal(0.0, np.sqrt(2.0), t.size)
    x0 = np.array([truth[0] + 150.0, 0.0])                      # a start 150 m off: every range looks wrong
    res = robust_track_kf(z[:, None], 1.0, q=0.01, r=2.0, test="paper", reacquire=15, x0=x0,
                          P0=np.diag([2.0, 0.01]))
    k = int(np.flatnonzero(res.extras["reacquired"])[0])
    assert k == 14 and res.extras["rejected"][:15].all()
    assert not res.extras["outlier"][:15].any()                 # reclassified as good
    assert abs(res.x[k, 0] - truth[k]) < 3.0 and abs(res.x[k, 1] + 1.2) < 0.2
    with pytest.warns(UwtutorWarning, match="rejected 120 of 120 measurements"):     # locked out: said so
        never = robust_track_kf(z[:, None], 1.0, q=0.01, r=2.0, test="paper", reacquire=None, x0=x0,
                                P0=np.diag([2.0, 0.01]))
    assert never.extras["rejected"].all()


def test_reacquisition_does_not_take_scattered_outliers_for_the_truth():
    t = np.arange(100.0)
    z = 1500.0 + 0.5 * t + np.random.default_rng(4).normal(0.0, 1.0, 100)
    z[40:70] += 80.0 * np.where(np.arange(30) % 2 == 0, 1.0, -1.0)   # 30 alternating outliers
    res = robust_range_kf(z, 1.0, q=0.01, reacquire=10)
    assert not res.extras["reacquired"].any()
    assert res.extras["outlier"][40:70].all() and not res.extras["outlier"][70:].any()


def test_extrapolate_is_paper_eq_12():
    t = np.arange(60.0)
    z = 1500.0 + 2.0 * t + np.random.default_rng(5).normal(0.0, 1.0, 60)
    z[30] += 80.0
    res = robust_range_kf(z, 1.0, on_outlier="extrapolate")
    assert res.extras["rejected"].tolist() == [k == 30 for k in range(60)]
    np.testing.assert_allclose(res.x[30], 2 * res.x[29] - res.x[28])
    np.testing.assert_allclose(res.P[30], res.P_prior[30])
    pred = robust_range_kf(z, 1.0, on_outlier="predict")
    np.testing.assert_allclose(pred.x[30], pred.x_prior[30])


# -- the protocol: hand loop, NaN, batch, covariances, errors ----------------------------------------------------------
def test_engine_with_robust_gate_run_equals_a_hand_loop_and_nan_is_predict_only():
    z = _outlier_dive(3, 7)[0][:, :400]
    z[:, 50] = np.nan
    steps = step_lengths(400, 1.0)
    x0 = np.column_stack([z[:, 0], np.zeros(3)])
    P0 = np.diag([2.0, 25.0])

    def make():
        return ExtendedKalmanFilter(ConstantVelocity(1, 2.0, steps), PositionMeasurement(1, 2.0), x0, P0,
                                    gate=RobustGate(SecondMomentGate(0.03), steps, reacquire=20))

    via_run = run_filter(make(), z)
    filt = make()
    for k in range(400):
        filt.predict()
        filt.update(z[:, k])
        np.testing.assert_array_equal(filt.x, via_run.x[:, k])
    np.testing.assert_array_equal(via_run.x[:, 50], via_run.x_prior[:, 50])       # NaN: predict only
    assert not via_run.extras["accepted"][:, 50].any()
    fn = robust_range_kf(z, 1.0)
    assert not fn.extras["rejected"][:, 50].any()               # a missing range is not an outlier
    np.testing.assert_allclose(fn.x, via_run.x)


def test_batched_run_m_equals_single_run_m_and_P_stays_psd():
    z, _, _ = _outlier_dive(4, 8)
    batch = robust_range_kf(z, 1.0)
    for m in range(4):
        single = robust_range_kf(z[m], 1.0)
        np.testing.assert_allclose(single.x, batch.x[m], rtol=0, atol=1e-9)
        np.testing.assert_array_equal(single.extras["outlier"], batch.extras["outlier"][m])
    P = batch.P
    np.testing.assert_allclose(P, np.swapaxes(P, -1, -2))
    assert np.linalg.eigvalsh(P).min() > 0


def test_cascade_filter_smooths_fixes_and_rejects_jumps():
    t = np.arange(400.0)
    truth = np.column_stack([-1000.0 + t, -1000.0 + t])
    fixes = truth + np.random.default_rng(9).normal(0.0, 15.0, (400, 2))
    fixes[200:205] += [300.0, -200.0]
    res = cascade_kf(fixes, 1.0, r=225.0)
    assert res.extras["outlier"][200:205].all()
    err = np.linalg.norm(res.x[100:, :2] - truth[100:], axis=-1)
    raw = np.linalg.norm(fixes[100:] - truth[100:], axis=-1)
    assert np.sqrt(np.mean(err**2)) < 0.3 * np.sqrt(np.mean(raw**2))
    per_epoch = cascade_kf(fixes, 1.0, r=np.broadcast_to(225.0 * np.eye(2), (400, 2, 2)))
    np.testing.assert_allclose(per_epoch.x, res.x)


@pytest.mark.parametrize("kwargs, match", [
    ({"ranges": [1500.0, -3.0, 1490.0]}, "ranges must be finite and >= 0"),
    ({"ranges": [1500.0, np.inf, 1490.0]}, "ranges must be finite"),
    ({"ranges": [[np.nan, np.nan], [1.0, 2.0]]}, "run 0 has no finite measurement"),
    ({"delta": 1.5}, "delta must lie strictly between 0 and 1"),
    ({"test": "median"}, "test must be one of"),
    ({"on_outlier": "ignore"}, "on_outlier must be one of"),
    ({"reacquire": 2}, "reacquire must be >= 3"),
    ({"dt": 0.0}, "dt must be > 0"),
    ({"r": -1.0}, "r must be"),
    ({"times": [0.0, 2.0, 1.0]}, "strictly increasing"),
])
def test_bad_input_names_the_argument(kwargs, match):
    args = {"ranges": [1500.0, 1501.0, 1502.0], "dt": 1.0}
    args.update(kwargs)
    with pytest.raises((ValueError, TypeError), match=match):
        robust_range_kf(args.pop("ranges"), args.pop("dt"), **args)


def test_noise_model_of_the_scenario_is_the_papers():
    p = paper_e.PaperEParameters()
    assert (p.q, p.r, p.delta, p.outlier_amplitude, p.outlier_counts, p.budget_runs) == (2.0, 2.0, 0.03, 80.0,
                                                                                         (10, 20), 50_000)
    dive = paper_e.make(np.random.default_rng(0), 2)
    np.testing.assert_allclose(np.std(dive.scenario.range_errors[~np.asarray(dive.outlier_mask)]),
                               np.sqrt(2.0), rtol=0.05)


def test_a_missing_range_inside_a_long_rejection_streak_is_predict_only():
    t = np.arange(100.0)
    z = 1500.0 + 0.5 * t + np.random.default_rng(6).normal(0.0, 1.0, 100)
    z[40:80] += 80.0 * np.where(np.arange(40) % 2 == 0, 1.0, -1.0)   # 40 scattered outliers: fits keep failing
    z[60] = np.nan
    res = robust_range_kf(z, 1.0, q=0.01, reacquire=10)
    np.testing.assert_array_equal(res.x[60], res.x_prior[60])
    assert not res.extras["rejected"][60] and not res.extras["reacquired"].any()
