"""Paper B's cooperative EKF: models, filter family on the generic engine, observability warning, scenario."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from uwtutor.errors import UnobservableWarning
from uwtutor.filters import cooperative_ekf, extended_kalman_filter
from uwtutor.filters.cooperative import (FORMULATIONS, CooperativeEKF, leader_observations, range_pairs,
                                        relative_track_deviation)
from uwtutor.models.cooperative import (CooperativeMotion, SquaredRangePair, leader_range, measurement_noise_map,
                                        process_noise_map)
from uwtutor.observability import observability_rank
from uwtutor.scenarios import paper_b

P = paper_b.PARAMETERS
EXACT = dict(range_sigma=0.0, leader_sigma=0.0, dr_speed_sigma=0.0, dr_heading_sigma=0.0)
Q_SMALL = np.diag([1e-6, 1e-6, 1e-6, 1e-6, 1e-10, 1e-10])
R_SMALL = np.diag([1e-2] * 6 + [1e-6, 1e-6, 1e-10, 1e-10])
P0 = np.diag([1e4, 1e4, 1.0, 1.0])
ROT = np.array([[0.0, -1.0], [1.0, 0.0]])


def _quiet(func, *args, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UnobservableWarning)
        return func(*args, **kw)


def _run(sc, i=None, **kw):
    u, leader, z = sc.dr_displacements, sc.leader_broadcast, sc.ranges
    if i is not None:
        u, leader, z = u[i], leader[i], z[i]
    x0 = kw.pop("x0", P.x1)
    return cooperative_ekf(x0, kw.pop("P0", P0), u, z, kw.pop("Q", P.Q), kw.pop("R", P.R), leader=leader,
                           dt=P.interval, **kw)


# -- the models --------------------------------------------------------------------------------------------------------
def paper_h(xk, v, dt):
    """Paper B's eq. (3) as printed: the pair as a function of the state before the move and the noisy terms v."""
    x, y, xm0, ym0, xm1, ym1, dx, dy, ux, uy = v
    return np.array([(x - xm0) ** 2 + (y - ym0) ** 2,
                     (x + dx + dt * ux - xm1) ** 2 + (y + dy + dt * uy - ym1) ** 2])


def numerical_jacobian(fun, x, eps=1e-6):
    x = np.asarray(x, float)
    cols = []
    for i in range(len(x)):
        d = np.zeros_like(x)
        d[i] = eps * max(1.0, abs(x[i]))
        cols.append((fun(x + d) - fun(x - d)) / (2 * d[i]))
    return np.stack(cols, axis=-1)


def test_process_noise_map_is_the_jacobian_of_the_motion_in_the_noise():
    dt = 8.0
    x, u = np.array([100.0, -50.0, 0.4, 0.6]), np.array([15.0, 3.0])

    def moved(w):   # w = [x, y, dx, dy, Ux, Uy] perturbations, paper B's omega
        return np.array([x[0] + w[0] + u[0] + w[2] + dt * (x[2] + w[4]), x[1] + w[1] + u[1] + w[3] + dt * (x[3] + w[5]),
                         x[2] + w[4], x[3] + w[5]])

    np.testing.assert_allclose(numerical_jacobian(moved, np.zeros(6)), process_noise_map(dt), atol=1e-8)
    motion = CooperativeMotion(dt, P.Q)
    G = process_noise_map(dt)
    np.testing.assert_allclose(motion.Q(None, None, 0), G @ P.Q @ G.T)
    np.testing.assert_allclose(motion.f(x[None], u[None], 0)[0], moved(np.zeros(6)))
    np.testing.assert_allclose(motion.F(None, None, 0),
                               numerical_jacobian(lambda s: motion.f(s[None], u[None], 0)[0], x))


def test_measurement_noise_map_is_paper_b_eq_12():
    dt = 8.0
    v = np.array([120.0, -40.0, 900.0, 300.0, 910.0, 320.0, 16.0, 2.0, 0.5, 0.4])
    L = numerical_jacobian(lambda w: paper_h(None, w, dt), v)
    a = v[:2] - v[2:4]
    c = v[:2] + v[6:8] + dt * v[8:10] - v[4:6]
    np.testing.assert_allclose(measurement_noise_map(a, c, dt), L, rtol=1e-7, atol=1e-6)


def test_consistent_jacobian_is_the_chain_rule_of_paper_b_eq_11():
    dt = 8.0
    leader = np.array([[900.0, 300.0], [910.0, 320.0]])
    u = np.array([[16.0, 2.0]])
    pair = SquaredRangePair(leader, u, dt, P.R)
    x_next = np.array([150.0, -30.0, 0.5, 0.4])            # the state after the move
    H = pair.H(x_next[None], 0)[0]
    np.testing.assert_allclose(H, numerical_jacobian(lambda s: pair.h(s[None], 0)[0], x_next), rtol=1e-7)
    # the same as paper B's dh/dx_k (at the state before the move) times dx_k/dx_(k+1)
    xk = np.concatenate([x_next[:2] - u[0] - dt * x_next[2:], x_next[2:]])
    H_paper = numerical_jacobian(lambda s: paper_h(None, [s[0], s[1], *leader[0], *leader[1], *u[0], s[2], s[3]], dt),
                                 xk)
    back = np.eye(4)
    back[0, 2] = back[1, 3] = -dt
    np.testing.assert_allclose(H, H_paper @ back, rtol=1e-7, atol=1e-3)
    # and the predicted pair is paper B's eq. (15), h at the previous estimate
    np.testing.assert_allclose(pair.h(x_next[None], 0)[0], paper_h(None, [*xk[:2], *leader[0], *leader[1], *u[0],
                                                                          *xk[2:]], dt))


def test_literal_jacobian_evaluates_paper_b_at_the_prediction():
    dt = 8.0
    leader = np.array([[900.0, 300.0], [910.0, 320.0]])
    u = np.array([[16.0, 2.0]])
    lit = SquaredRangePair(leader, u, dt, P.R, literal=True)
    x_next = np.array([150.0, -30.0, 0.5, 0.4])
    H_paper_at_pred = numerical_jacobian(
        lambda s: paper_h(None, [s[0], s[1], *leader[0], *leader[1], *u[0], s[2], s[3]], dt), x_next)
    np.testing.assert_allclose(lit.H(x_next[None], 0)[0], H_paper_at_pred, rtol=1e-7)
    np.testing.assert_allclose(lit.h(x_next[None], 0), SquaredRangePair(leader, u, dt, P.R).h(x_next[None], 0))


def test_single_range_model_uses_the_leader_at_the_end_of_the_interval():
    leader = np.array([[0.0, 0.0], [100.0, 0.0], [200.0, 0.0]])
    model = leader_range(leader, 4.0)
    x = np.array([[130.0, 40.0, 0.5, 0.5]])
    np.testing.assert_allclose(model.h(x, 0), [[50.0]])
    np.testing.assert_allclose(model.H(np.array([[170.0, 40.0, 0.5, 0.5]]), 1)[0], [[-0.6, 0.8, 0.0, 0.0]],
                               atol=1e-12)


# -- the filter --------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("pattern", ["zigzag", "circling"])
def test_exact_ranges_and_dr_give_the_current_and_the_track(pattern):
    sc = paper_b.make(np.random.default_rng(0), 1, leader_pattern=pattern, **EXACT)
    res = _run(sc, 0, Q=Q_SMALL, R=R_SMALL)
    truth = sc.true_states
    assert np.max(np.abs(res.x[-1, 2:] - truth[-1, 2:])) < 0.01
    assert np.all(np.abs(res.x[-50:, 2:] - truth[-50:, 2:]) < 0.01)
    assert np.linalg.norm(res.x[-1, :2] - truth[-1, :2]) < 5.0
    # from 100 m off at the start
    assert np.linalg.norm(P.x1[:2] - sc.true_positions[0]) > 100.0


def test_parallel_leader_leaves_the_state_unobservable_and_the_filter_says_so():
    sc = paper_b.make(np.random.default_rng(0), 1, leader_pattern="parallel", **EXACT)
    # chapter 2's rank: two of the four directions only
    ranks = observability_rank(sc.true_positions, sc.leader_positions, times=sc.times, unknown_current=True)
    assert ranks[-1] == 2
    x0 = np.concatenate([sc.true_positions[0], sc.true_currents[0]])
    with pytest.warns(UnobservableWarning, match="not observable"):
        res = _run(sc, 0, x0=x0, Q=Q_SMALL, R=R_SMALL)
    # started on the truth, the filter stays on it, and its covariance does not shrink across the line of sight:
    # neither the bearing of the follower from the leader nor the current across it
    los = sc.true_positions[-1] - sc.leader_positions[-1]
    los /= np.linalg.norm(los)
    across = ROT @ los
    final = res.P[-1]
    assert across @ final[2:, 2:] @ across > 0.5 * (across @ P0[2:, 2:] @ across)
    assert across @ final[:2, :2] @ across > 0.5 * (across @ P0[:2, :2] @ across)
    # with a zigzagging leader both shrink by orders of magnitude
    zz = paper_b.make(np.random.default_rng(0), 1, **EXACT)
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnobservableWarning)       # and no warning
        res_zz = _run(zz, 0, x0=x0, Q=Q_SMALL, R=R_SMALL)
    assert np.max(np.linalg.eigvalsh(res_zz.P[-1][2:, 2:])) < 1e-3 * np.min(np.diag(P0[2:, 2:]))


def test_warning_is_raised_for_noisy_parallel_runs_only():
    par = paper_b.make(np.random.default_rng(3), 20, leader_pattern="parallel")
    dev = relative_track_deviation(par.dr_displacements, par.leader_broadcast)
    assert dev.shape == (20,) and np.all(dev < 15.0)
    with pytest.warns(UnobservableWarning, match="20 of 20 runs"):
        _run(par)
    zz = paper_b.make(np.random.default_rng(3), 20)
    assert np.all(relative_track_deviation(zz.dr_displacements, zz.leader_broadcast) > 100.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnobservableWarning)
        _run(zz)


def test_warning_points_at_the_callers_line():
    par = paper_b.make(np.random.default_rng(3), 2, leader_pattern="parallel")
    with pytest.warns(UnobservableWarning) as record:
        _run(par)
    assert record[0].filename == __file__


@pytest.mark.parametrize("formulation", FORMULATIONS)
def test_nan_range_is_predict_only(formulation):
    sc = paper_b.make(np.random.default_rng(5), 1)
    r = np.array(sc.ranges[0])
    r[40] = np.nan
    kw = dict(formulation=formulation)
    res = cooperative_ekf(P.x1, P0, sc.dr_displacements[0], r, P.Q, P.R, leader=sc.leader_broadcast[0], dt=P.interval,
                          **kw)
    # step k uses ranges k and k + 1: the pair loses steps 39 and 40, the single range only step 39
    lost = [39, 40] if formulation != "single_range" else [39]
    for k in range(36, 44):
        used = k not in lost
        assert bool(res.extras["accepted"][k]) is used
        if not used:
            np.testing.assert_array_equal(res.x[k], res.x_prior[k])
            np.testing.assert_array_equal(res.P[k], res.P_prior[k])
            assert np.all(np.isnan(res.innovations[k]))


@pytest.mark.parametrize("formulation", FORMULATIONS)
def test_the_functional_form_is_its_model_pair_on_the_engine(formulation):
    """(That the class equals the functional form, run for run and step by step, is the contract test's.)"""
    sc = paper_b.make(np.random.default_rng(7), 2, packet_loss=0.1)
    res = _run(sc, formulation=formulation)
    pairs = range_pairs(sc.ranges)
    np.testing.assert_allclose(res.times, P.interval * np.arange(1, sc.n_steps + 1))
    # the same model pair on the engine's functional form
    motion = CooperativeMotion(P.interval, P.Q)
    if formulation == "single_range":
        meas, z = leader_range(sc.leader_broadcast, P.R[0, 0] + P.R[2, 2]), pairs[..., 1]
    else:
        meas, z = SquaredRangePair(sc.leader_broadcast, sc.dr_displacements, P.interval, P.R,
                                   literal=formulation == "literal"), pairs**2
    # the family's default: a pair with one range lost is predict only (the engine would use the other range)
    z_step = z if formulation == "single_range" else np.where(np.isnan(z).any(-1, keepdims=True), np.nan, z)
    eng = extended_kalman_filter(motion, meas, np.tile(P.x1, (2, 1)), P0, sc.dr_displacements, z_step)
    np.testing.assert_allclose(eng.x, res.x, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(eng.innovations, res.innovations, rtol=1e-12, atol=1e-6)
    # lost="range": the engine's rule, the range that arrived is used
    partial = np.isnan(z).any(-1) & ~np.isnan(z).all(-1) if formulation != "single_range" else None
    by_range = _run(sc, formulation=formulation, lost="range")
    eng = extended_kalman_filter(motion, meas, np.tile(P.x1, (2, 1)), P0, sc.dr_displacements, z)
    np.testing.assert_allclose(eng.x, by_range.x, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(eng.innovations, by_range.innovations, rtol=1e-12, atol=1e-6)
    if partial is not None:
        assert partial.any() and by_range.extras["accepted"][partial].all()
        assert not res.extras["accepted"][partial].any()


def test_paper_b_pair_uses_each_range_twice():
    # the measurement of step k + 1 starts with the range that ended step k
    pairs = range_pairs(np.array([10.0, 20.0, 30.0, np.nan]))
    np.testing.assert_array_equal(pairs[:2, 1], pairs[1:3, 0])
    assert np.isnan(pairs[2, 1])


@pytest.mark.parametrize("kw, err, match", [
    (dict(x0=np.zeros(3)), ValueError, "x0"),
    (dict(P0=-np.eye(4)), ValueError, "P0"),
    (dict(Q=np.eye(4)), ValueError, "Q"),
    (dict(R=np.eye(6)), ValueError, "R"),
    (dict(formulation="exact"), ValueError, "formulation"),
    (dict(dt=0.0), ValueError, "dt"),
])
def test_bad_input_names_the_argument(kw, err, match):
    sc = paper_b.make(np.random.default_rng(9), 1)
    args = dict(x0=P.x1, P0=P0, u=sc.dr_displacements[0], leader=sc.leader_broadcast[0], z=sc.ranges[0],
                dt=P.interval, Q=P.Q, R=P.R)
    args.update(kw)
    with pytest.raises(err, match=match):
        cooperative_ekf(**args)


def test_bad_sequences_name_the_argument():
    sc = paper_b.make(np.random.default_rng(9), 2)
    u, b, r = sc.dr_displacements, sc.leader_broadcast, sc.ranges
    with pytest.raises(ValueError, match=r"\bz\b"):
        cooperative_ekf(P.x1, P0, u[0], -r[0], P.Q, P.R, leader=b[0], dt=P.interval)
    with pytest.raises(ValueError, match="leader"):
        cooperative_ekf(P.x1, P0, u[0], r[0], P.Q, P.R, leader=b[0, :-1], dt=P.interval)
    with pytest.raises(ValueError, match="z must hold"):
        cooperative_ekf(P.x1, P0, u[0], r[0, :-1], P.Q, P.R, leader=b[0], dt=P.interval)
    with pytest.raises(ValueError, match="number of runs"):
        cooperative_ekf(P.x1, P0, u, r, P.Q, P.R, leader=b[:1], dt=P.interval)
    # the order of the earlier versions (leader and dt by position) fails loudly, never silently
    with pytest.raises(TypeError):
        cooperative_ekf(P.x1, P0, u[0], b[0], r[0], P.interval, P.Q, P.R)
    filt = CooperativeEKF(P.x1, P0, P.Q, P.R, dt=P.interval, u=u[0], leader=b[0])
    with pytest.raises(ValueError, match="z must be the two ranges"):
        filt.update(100.0)


# -- the scenario ------------------------------------------------------------------------------------------------------
def test_scenario_holds_paper_b_values():
    assert (P.speed, P.duration, P.depth, P.dr_step, P.interval, P.current) == (2.0, 2500.0, 10.0, 1.0, 8.0,
                                                                                  (0.5, 0.5))
    np.testing.assert_array_equal(P.x1, [10.0, -100.0, 0.0, 0.0])
    np.testing.assert_array_equal(np.diag(P.P1), [1e8, 1e8, 1e7, 1e7])
    np.testing.assert_allclose(np.diag(P.Q), [100.0, 100.0, 4.0, 4.0, 0.0025, 0.0025])
    np.testing.assert_allclose(np.diag(P.R), [100.0] * 6 + [4.0, 4.0, 0.0025, 0.0025])
    assert P.n_epochs == 313


def test_scenario_geometry_and_noise():
    sc = paper_b.make(np.random.default_rng(10), 4)
    np.testing.assert_allclose(sc.true_ranges, np.linalg.norm(sc.true_positions - sc.leader_positions, axis=-1))
    # the truth drifts with the current: over ground = through the water + U t
    np.testing.assert_allclose(sc.true_positions[-1], [2.0 * sc.times[-1], 0.0] + 0.5 * sc.times[-1])
    exact = paper_b.make(np.random.default_rng(10), 2, **EXACT)
    np.testing.assert_allclose(exact.ranges, np.broadcast_to(exact.true_ranges, (2, 313)))
    np.testing.assert_allclose(exact.dr_displacements[0], np.tile([16.0, 0.0], (312, 1)), atol=1e-9)
    np.testing.assert_allclose((sc.ranges - sc.true_ranges).std(), 5.0, rtol=0.1)
    again = paper_b.make(np.random.default_rng(10), 4)
    np.testing.assert_array_equal(again.ranges, sc.ranges)


def test_scenario_options_beyond_the_paper():
    lossy = paper_b.make(np.random.default_rng(11), 200, packet_loss=0.3)
    assert np.isnan(lossy.ranges).mean() == pytest.approx(0.3, abs=0.01)
    change = paper_b.make(np.random.default_rng(11), 1, current_after=(-0.3, 0.2), change_time=1200.0)
    np.testing.assert_allclose(change.true_currents[change.times < 1200.0], 0.5)
    np.testing.assert_allclose(change.true_currents[change.times >= 1200.0], [[-0.3, 0.2]] * int(
        np.sum(change.times >= 1200.0)))
    drift = paper_b.make(np.random.default_rng(11), 1, leader_sigma=0.0, leader_drift=(0.01, 0.0))
    np.testing.assert_allclose(drift.leader_broadcast[0] - drift.leader_positions, np.column_stack(
        [0.01 * drift.times, 0.0 * drift.times]))
    a, b = paper_b.make_followers(np.random.default_rng(12), 3, [((0.0, 0.0), 0.0), ((0.0, 800.0), 0.0)])
    np.testing.assert_array_equal(a.leader_broadcast, b.leader_broadcast)
    assert not np.allclose(a.ranges, b.ranges)
    clock = paper_b.make(np.random.default_rng(13), 1, owtt=True, clock_offset=1e-3, **EXACT)
    np.testing.assert_allclose(clock.ranges[0] - clock.true_ranges, 1.5)
    assert np.all(clock.times > 8.0 * np.arange(313))                       # reception after sending
    wrapped = paper_b.make(np.random.default_rng(13), 1, owtt=True, ambiguity_period=1.0)
    assert np.nanmax(wrapped.ranges) < 1500.0 and wrapped.true_ranges.max() > 1500.0


@pytest.mark.parametrize("kw, err", [
    (dict(leader_pattern="spiral"), ValueError),
    (dict(packet_loss=1.0), ValueError),
    (dict(interval=7.5), ValueError),
    (dict(current_after=(0.1, 0.1)), ValueError),
    (dict(ambiguity_period=1.0), ValueError),
    (dict(wrong_name=1.0), TypeError),
])
def test_scenario_rejects_bad_parameters(kw, err):
    with pytest.raises(err):
        paper_b.make(np.random.default_rng(0), 1, **kw)


@pytest.mark.parametrize("formulation", FORMULATIONS)
def test_bad_steps_name_the_argument(formulation):
    """(run == run_filter == a hand loop is the contract test's.)"""
    sc = paper_b.make(np.random.default_rng(12), 3, packet_loss=0.2)
    pairs = range_pairs(sc.ranges)
    z = pairs[..., 1] if formulation == "single_range" else pairs

    def make():
        return CooperativeEKF(P.x1, P0, P.Q, P.R, dt=P.interval, u=sc.dr_displacements, leader=sc.leader_broadcast,
                              formulation=formulation)

    assert set(make().extra_outputs) == {"accepted"}
    with pytest.raises(ValueError, match=r"\bz\b"):
        make().run(z[:2])
    with pytest.raises(ValueError, match=r"\bu\b"):
        make().run(z, sc.dr_displacements[:, :3])
    filt = make()
    with pytest.raises(ValueError, match=r"\bu\b"):
        filt.predict(np.full((3, 2), np.nan))
    filt.predict()
    with pytest.raises(ValueError, match=r"\bz\b"):
        filt.update(np.full(4, 1.0))


def test_tunings():
    paper = paper_b.paper_tuning()
    np.testing.assert_array_equal(paper.P1, P.P1)
    np.testing.assert_array_equal(paper.Q, P.Q)
    assert paper.range_variance == P.R[0, 0] + P.R[2, 2]
    tu = paper_b.matched_tuning()
    # one interval of DR: 8 steps of 1 s with 0.05 m/s of speed noise (2 m/s x 1 deg of heading noise is less)
    assert tu.Q[2, 2] == pytest.approx(8 * 0.05**2)
    # the pair's range variance is twice the single range's (each range enters two pairs)
    assert tu.R[0, 0] + tu.R[2, 2] == pytest.approx(2 * tu.range_variance)
    assert tu.range_variance == pytest.approx(P.range_sigma**2 + P.leader_sigma**2)
    assert tu.P1[0, 0] == pytest.approx(np.hypot(10.0, 100.0) ** 2)
    kw = tu.as_kwargs()
    assert set(kw) == {"P0", "Q", "R", "range_variance"}


def test_followers_start_with_the_same_initial_error():
    a, b = paper_b.make_followers(np.random.default_rng(1), 2, [((0.0, 0.0), 0.0), ((0.0, -600.0), 0.3)])
    np.testing.assert_allclose(a.initial_estimate(), P.x1)
    np.testing.assert_allclose(b.initial_estimate()[:2] - b.true_positions[0], P.x1[:2])
    with pytest.raises(ValueError, match="followers"):
        paper_b.make_followers(np.random.default_rng(1), 2, [])


# -- the leader as a step's input (no sequences in the constructor) ----------------------------------------------------
def _same(a, b):
    for field in ("times", "x", "P", "x_prior", "P_prior", "innovations", "innovation_cov"):
        assert np.array_equal(getattr(a, field), getattr(b, field), equal_nan=True), field
    assert a.extras.keys() == b.extras.keys()
    for name in a.extras:
        assert np.array_equal(a.extras[name], b.extras[name]), name


@pytest.mark.parametrize("lost", ["step", "range"])
@pytest.mark.parametrize("formulation", FORMULATIONS)
@pytest.mark.parametrize("batched", [False, True], ids=["single", "batched"])
def test_without_sequences_the_filter_gives_the_same_numbers(formulation, lost, batched):
    """The filter built without sequences, given each step's displacement and leader positions, is the filter built
    over the whole run, bit for bit: by run and by hand, one run or a batch (a batch with one leader track per run)."""
    sc = paper_b.make(np.random.default_rng(21), 3, packet_loss=0.2, duration=8.0 * 40)
    pick = (lambda a: a) if batched else (lambda a: a[1])
    u, b, r = pick(sc.dr_displacements), pick(sc.leader_broadcast), pick(sc.ranges)
    single = formulation == "single_range"
    kw = dict(formulation=formulation, lost=lost, range_variance=9.0 if single else None)
    whole = _quiet(CooperativeEKF, P.x1, P0, P.Q, P.R, dt=P.interval, u=u, leader=b, **kw)
    pairs = range_pairs(r)
    by_whole = whole.run(pairs[..., 1] if single else pairs)
    x0 = np.tile(P.x1, (3, 1)) if batched else P.x1       # without sequences, the runs axis comes from x0 or P0
    stepwise = CooperativeEKF(x0, P0, P.Q, P.R, dt=P.interval, **kw)
    assert stepwise.u is None and stepwise.relative_track_deviation is None
    obs = leader_observations(r, b, single_range=single)
    _same(_quiet(stepwise.run, obs, u), by_whole)
    # one step at a time, the observation of the step carrying the leader's positions
    by_hand = CooperativeEKF(x0, P0, P.Q, P.R, dt=P.interval, **kw)
    again = _quiet(CooperativeEKF, P.x1, P0, P.Q, P.R, dt=P.interval, u=u, leader=b, **kw)
    for k in range(u.shape[-2]):
        by_hand.predict(u[..., k, :])
        by_hand.update(obs[..., k, :])
        again.predict()
        again.update(pairs[..., k, 1] if single else pairs[..., k, :])
        for name in ("x", "P", "x_prior", "P_prior", "y", "S", "accepted"):
            assert np.array_equal(getattr(by_hand, name), getattr(again, name), equal_nan=True), (k, name)


def test_without_sequences_inputs_are_checked_and_the_straight_track_warns_in_run():
    filt = CooperativeEKF(P.x1, P0, P.Q, P.R, dt=P.interval)
    with pytest.raises(TypeError, match="u .* is required"):
        filt.predict()
    with pytest.raises(RuntimeError, match="predict"):
        filt.update([100.0, 110.0, 0.0, 0.0, 8.0, 0.0])
    filt.predict([1.0, 0.0])
    with pytest.raises(ValueError, match="z must be the step's observation"):
        filt.update([100.0, 110.0])
    with pytest.raises(ValueError, match="leader positions"):
        filt.update([100.0, 110.0, np.nan, 0.0, 8.0, 0.0])
    with pytest.raises(TypeError, match="u and leader together"):
        CooperativeEKF(P.x1, P0, P.Q, P.R, dt=P.interval, u=np.ones((3, 2)))
    with pytest.raises(TypeError, match="dt"):
        CooperativeEKF(P.x1, P0, P.Q, P.R)
    with pytest.raises(TypeError, match="dt .* is required"):
        CooperativeEKF(P.x1, P0, P.Q, P.R, dt=None)
    # a leader on a parallel course: the filter built step by step warns when run over the track
    sc = paper_b.make(np.random.default_rng(3), 1, **EXACT, leader_pattern="parallel")
    obs = leader_observations(sc.ranges[0], sc.leader_broadcast[0])
    with pytest.warns(UnobservableWarning):
        CooperativeEKF(P.x1, P0, P.Q, P.R, dt=P.interval).run(obs, sc.dr_displacements[0])


def test_leader_observations():
    obs = leader_observations([[1.0, 2.0, np.nan]], [[0.0, 0.0], [1.0, 0.0], [2.0, 1.0]])
    np.testing.assert_array_equal(obs, [[[1.0, 2.0, 0.0, 0.0, 1.0, 0.0], [2.0, np.nan, 1.0, 0.0, 2.0, 1.0]]])
    single = leader_observations([1.0, 2.0, 3.0], [[0.0, 0.0], [1.0, 0.0], [2.0, 1.0]], single_range=True)
    np.testing.assert_array_equal(single, [[2.0, 1.0, 0.0], [3.0, 2.0, 1.0]])
    with pytest.raises(ValueError, match="leader must have shape"):
        leader_observations([1.0, 2.0, 3.0], [[0.0, 0.0], [1.0, 0.0]])
