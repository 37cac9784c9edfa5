"""The filter protocol, held over every Kalman-family filter of the library on its model pairs (the particle filters
have their own file, tests/test_filter_contract_pf.py, which runs paper C's pair in the engine too).

For each filter: it is a ``Filter``; ``run`` == ``run_filter`` == a hand loop of predict/update for every result
field and extra; a NaN measurement is predict only; run m of a batched filter == a single-run filter; P stays
symmetric positive semi-definite; bad input names the argument. Fast paths equal the generic engine.
"""

from dataclasses import dataclass
from typing import Any, Callable

import numpy as np
import pytest

from uwtutor.filters import (BiasEKF, ExtendedKalmanFilter, FadingEKF, Filter, FilterResult, KalmanFilter,
                             RangeOnlyEKF, bias_ekf, extended_kalman_filter, fading_ekf, range_only_ekf, run_filter)
from uwtutor.filters import CooperativeEKF, cooperative_ekf
from uwtutor.filters.cooperative import range_pairs
from uwtutor.filters.fading import FadingResult
from uwtutor.filters import DepthEKF, Gate, ReacquiringGate
from uwtutor.models import (BeaconRanges, DeadReckoning, DepthSensors, DepthSpeedPitch, DepthSpeedPitchModel,
                            OdometryMotion, PitchManeuver, RangeToBeacon)
from uwtutor.scenarios import paper_b

M, K = 4, 60


@dataclass
class Case:
    """How to build one filter (``make(batched)``) and the sequence it runs on."""

    name: str
    make: Callable[[bool], Any]
    z: np.ndarray            # (M, K) or (M, K, m)
    u: np.ndarray | None     # (M, K, p) or None
    result_type: type = FilterResult
    #: the functional form on the same sequence (single run or batched), where the family has one
    functional: Callable[[bool], FilterResult] | None = None


def _range_inputs(seed=0):
    rng = np.random.default_rng(seed)
    theta = np.linspace(0.0, 2 * np.pi, K + 1)
    track = 300.0 * np.column_stack([np.cos(theta), np.sin(theta)])
    u = np.broadcast_to(np.diff(track, axis=0), (M, K, 2)).copy() + rng.normal(0.0, 0.3, (M, K, 2))
    z = np.linalg.norm(track[1:], axis=1) + rng.normal(0.0, 2.0, (M, K))
    z[rng.random((M, K)) < 0.2] = np.nan
    x0 = track[0] + rng.normal(0.0, 20.0, (M, 2))
    return x0, u, z


X0, U, Z = _range_inputs()
X0_BIAS = np.column_stack([X0, np.zeros(M)])
Q2, Q3 = np.eye(2) * 0.1, np.diag([0.1, 0.1, 0.01])


def _pick(a, batched, m=0):
    return a if batched else a[m]


def _kf_case():
    rng = np.random.default_rng(4)
    z = np.cumsum(rng.normal(0.0, 1.0, (M, K)), axis=1)[..., None]
    z[rng.random((M, K)) < 0.2] = np.nan
    return Case("KalmanFilter", lambda b: KalmanFilter(F=[[1.0, 1.0], [0.0, 1.0]], H=[[1.0, 0.0]],
                                                       Q=np.diag([0.01, 0.04]), R=2.0,
                                                       x0=np.zeros((M, 2)) if b else np.zeros(2),
                                                       P0=np.eye(2) * 10.0), z, None)


def _engine_case(name, motion, measurement, x0, P0, z, u, gate=None):
    """A model pair on the generic engine, in its object form and its functional form."""
    return Case(name, lambda b: ExtendedKalmanFilter(motion, measurement, _pick(x0, b), P0,
                                                     gate=None if gate is None else gate()), z, u,
                functional=lambda b: extended_kalman_filter(motion, measurement, _pick(x0, b), P0, _pick(u, b),
                                                            _pick(z, b), gate=None if gate is None else gate()))


CASES = [
    _kf_case(),
    Case("RangeOnlyEKF", lambda b: RangeOnlyEKF(_pick(X0, b), np.eye(2) * 400.0, Q2, 4.0), Z, U,
         functional=lambda b: range_only_ekf(_pick(X0, b), np.eye(2) * 400.0, _pick(U, b), _pick(Z, b), Q2, 4.0)),
    _engine_case("ExtendedKalmanFilter-range", DeadReckoning(Q2), RangeToBeacon((0.0, 0.0), R=4.0), X0,
                 np.eye(2) * 400.0, Z, U),
    _engine_case("ExtendedKalmanFilter-bias", DeadReckoning(Q3), RangeToBeacon((0.0, 0.0), R=4.0, n=3, bias_index=2),
                 X0_BIAS, np.diag([400.0, 400.0, 25.0]), Z + 3.0, U),
    _engine_case("ExtendedKalmanFilter-moving-beacon", DeadReckoning(Q2),
                 RangeToBeacon(np.column_stack([np.linspace(0, 200, K), np.zeros(K)]), R=4.0), X0,
                 np.eye(2) * 400.0, Z, U),
    Case("BiasEKF", lambda b: BiasEKF(_pick(X0_BIAS, b), np.diag([400.0, 400.0, 25.0]), Q3, 4.0), Z + 3.0, U,
         functional=lambda b: bias_ekf(_pick(X0_BIAS, b), np.diag([400.0, 400.0, 25.0]), _pick(U, b),
                                       _pick(Z + 3.0, b), Q3, 4.0)),
    Case("FadingEKF", lambda b: FadingEKF(_pick(X0, b), np.eye(2) * 400.0, Q2, 4.0, mu_gamma=0.98,
                                          sigma_gamma=1 / 1500), Z, U, FadingResult,
         functional=lambda b: fading_ekf(_pick(X0, b), np.eye(2) * 400.0, _pick(U, b), _pick(Z, b), Q2, 4.0,
                                         mu_gamma=0.98, sigma_gamma=1 / 1500)),
]
_COOP = paper_b.make(np.random.default_rng(5), M, packet_loss=0.2, duration=8.0 * K)
_COOP_P0 = np.diag([1e4, 1e4, 1.0, 1.0])


def _coop(formulation):
    """Paper B's cooperative EKF in one of its three formulations (the leader moves; 20 % of packets lost)."""
    def make(b):
        return CooperativeEKF(paper_b.PARAMETERS.x1, _COOP_P0, paper_b.PARAMETERS.Q, paper_b.PARAMETERS.R, dt=8.0,
                              u=_pick(_COOP.dr_displacements, b), leader=_pick(_COOP.leader_broadcast, b),
                              formulation=formulation)
    def functional(b):
        return cooperative_ekf(paper_b.PARAMETERS.x1, _COOP_P0, _pick(_COOP.dr_displacements, b),
                               _pick(_COOP.ranges, b), paper_b.PARAMETERS.Q, paper_b.PARAMETERS.R,
                               leader=_pick(_COOP.leader_broadcast, b), dt=8.0, formulation=formulation)
    pairs = range_pairs(_COOP.ranges)
    return Case(f"CooperativeEKF-{formulation}", make, pairs[..., 1] if formulation == "single_range" else pairs,
                _COOP.dr_displacements, functional=functional)


def _robust_case():
    """Paper E's range filter: the generic engine with its outlier gate (a patch of outliers, 10 % missing)."""
    from uwtutor.filters import RobustGate, SecondMomentGate
    from uwtutor.models import ConstantVelocity, PositionMeasurement
    from uwtutor.models.robust import step_lengths

    rng = np.random.default_rng(5)
    z = 1500.0 + np.cumsum(rng.normal(0.0, 1.0, (M, K)), axis=1)
    z[:, 20:26] += 80.0
    z[rng.random((M, K)) < 0.1] = np.nan
    steps = step_lengths(K, 1.0)
    return Case("ExtendedKalmanFilter-robust-gate", lambda b: ExtendedKalmanFilter(
        ConstantVelocity(1, 2.0, steps), PositionMeasurement(1, 2.0),
        np.column_stack([np.full(M, 1500.0), np.zeros(M)]) if b else np.array([1500.0, 0.0]),
        np.diag([2.0, 25.0]), gate=RobustGate(SecondMomentGate(0.03), steps, reacquire=5)), z[..., None], None)


def _coop_lost_range():
    """Paper B's filter with lost="range": a pair with one range lost updates with the other (the engine's rule)."""
    def make(b):
        return CooperativeEKF(paper_b.PARAMETERS.x1, _COOP_P0, paper_b.PARAMETERS.Q, paper_b.PARAMETERS.R, dt=8.0,
                              u=_pick(_COOP.dr_displacements, b), leader=_pick(_COOP.leader_broadcast, b),
                              lost="range")
    return Case("CooperativeEKF-consistent-lost-range", make, range_pairs(_COOP.ranges), _COOP.dr_displacements)


def _odometry_inputs(seed=6):
    """Wheel odometry [distance, heading change] with a gyro bias, four beacons, ranges 7 % long, 30 % of the
    ranges missing one by one (so most epochs have some beacons and not others)."""
    rng = np.random.default_rng(seed)
    motion = OdometryMotion(0.02, 0.003, gyro_bias=True, scale=True, dt=0.5, gyro_bias_walk=1e-5)
    u_true = np.column_stack([np.full(K, 0.5), 0.06 + 0.04 * np.sin(np.arange(K) / 8)])
    truth = motion.integrate([20.0, 5.0, 0.0, 0.0, 1.07], u_true)
    u = u_true + rng.normal(0.0, [0.02, 0.003], (M, K, 2)) + [0.0, 0.002]
    z = 1.07 * np.linalg.norm(truth[:, None, :2] - _BEACONS, axis=-1) + rng.normal(0.0, 0.05, (M, K, 4))
    z[rng.random(z.shape) < 0.3] = np.nan
    z[:, ::9] = np.nan                                                         # some epochs with no range at all
    x0 = np.array([20.0, 5.0, 0.0, 0.0, 1.0]) + rng.normal(0.0, [0.5, 0.5, 0.05, 0.0, 0.0], (M, 5))
    return motion, x0, u, z


_BEACONS = np.array([[0.0, 0.0], [40.0, 0.0], [40.0, 30.0], [0.0, 30.0]])
_ODO_MOTION, _ODO_X0, _ODO_U, _ODO_Z = _odometry_inputs()
_ODO_P0 = np.diag([1.0, 1.0, 0.01, 1e-4, 0.01])


def _odometry_case(gate=None, name="ExtendedKalmanFilter-odometry-beacons"):
    return _engine_case(name, _ODO_MOTION, BeaconRanges(_BEACONS, R=0.05**2, layout=_ODO_MOTION.layout), _ODO_X0,
                        _ODO_P0, _ODO_Z, _ODO_U, gate)


def _depth_cases():
    """Paper C's models on the engine (its EKF): the depth/speed/pitch motion and a dive mode, the three sensors with
    single sensors and whole steps missing."""
    R = np.diag([0.2, 0.05, np.radians(0.5)]) ** 2
    std = np.array([0.05, 0.01, np.radians(0.3)])
    rng = np.random.default_rng(12)
    z = np.stack([DepthSpeedPitchModel(process_std=std, R=R).simulate([10.0, 1.5, 0.1], K, rng)[1] for _ in range(M)])
    z[:, 7] = np.nan
    z[rng.random(z.shape) < 0.1] = np.nan
    x0 = np.array([10.0, 1.5, 0.1]) + rng.normal(0.0, [0.2, 0.05, 0.01], (M, 3))
    return [Case("ExtendedKalmanFilter-depth-speed-pitch", lambda b: ExtendedKalmanFilter(
                DepthSpeedPitch(process_std=std), DepthSensors(R), _pick(x0, b), R), z, None),
            Case("DepthEKF", lambda b: DepthEKF(_pick(x0, b), R, Q=np.diag(std**2), R=R), z, None),
            Case("ExtendedKalmanFilter-pitch-maneuver", lambda b: ExtendedKalmanFilter(
                PitchManeuver(pitch_target=0.3, time_constant=1.0, process_std=std), DepthSensors(R), _pick(x0, b),
                R), z, None)]


CASES += [_coop(f) for f in ("consistent", "literal", "single_range")] + [_robust_case(), _coop_lost_range()]
CASES += _depth_cases()
CASES += [_odometry_case(), _odometry_case(lambda: ReacquiringGate(patience=1),
                                           "ExtendedKalmanFilter-odometry-reacquiring-gate")]
IDS = [c.name for c in CASES]


def _inputs(case, batched, m=0):
    z = case.z if batched else case.z[m]
    u = None if case.u is None else (case.u if batched else case.u[m])
    return z, u


def _assert_same(a: FilterResult, b: FilterResult, exact=True):
    check = np.testing.assert_array_equal if exact else (
        lambda x, y, err_msg="": np.testing.assert_allclose(x, y, rtol=1e-10, atol=1e-10, err_msg=err_msg))
    for field in ("times", "x", "P", "x_prior", "P_prior", "innovations", "innovation_cov"):
        check(getattr(a, field), getattr(b, field), err_msg=field)
    assert a.extras.keys() == b.extras.keys()
    for name in a.extras:
        check(a.extras[name], b.extras[name], err_msg=name)


@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_is_a_filter_with_the_declared_result_type(case):
    filt = case.make(True)
    assert isinstance(filt, Filter)
    z, u = _inputs(case, True)
    res = filt.run(z, u)
    assert type(res) is case.result_type and type(res) is getattr(filt, "result_type", FilterResult)
    assert set(res.extras) == set(filt.extra_outputs)


@pytest.mark.parametrize("batched", [False, True], ids=["single", "batched"])
@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_run_equals_run_filter_equals_a_hand_loop(case, batched):
    z, u = _inputs(case, batched)
    times = np.arange(K) * 2.0
    by_run = case.make(batched).run(z, u, times)
    by_loop = run_filter(case.make(batched), z, u, times)
    _assert_same(by_run, by_loop)

    filt = case.make(batched)
    rec = {name: [] for name in ("x", "P", "x_prior", "P_prior", "y", "S") + tuple(filt.extra_outputs)}
    for k in range(K):
        filt.predict(None if u is None else u[..., k, :])
        filt.update(z[:, k] if batched else z[k])
        for name in rec:
            rec[name].append(np.array(getattr(filt, name)))
    axis = 1 if batched else 0
    for name, field in (("x", "x"), ("P", "P"), ("x_prior", "x_prior"), ("P_prior", "P_prior")):
        np.testing.assert_array_equal(getattr(by_run, field), np.stack(rec[name], axis), err_msg=name)
    np.testing.assert_array_equal(by_run.innovations.reshape(-1), np.stack(rec["y"], axis).reshape(-1))
    np.testing.assert_array_equal(by_run.innovation_cov.reshape(-1), np.stack(rec["S"], axis).reshape(-1))
    for name in filt.extra_outputs:
        np.testing.assert_array_equal(by_run.extras[name], np.stack(rec[name], axis), err_msg=name)
    # the filter is left at the last step, as the loop leaves it
    np.testing.assert_array_equal(case.make(batched).run(z, u).x[..., -1, :], filt.x)


FUNCTIONAL = [c for c in CASES if c.functional is not None]


@pytest.mark.parametrize("batched", [False, True], ids=["single", "batched"])
@pytest.mark.parametrize("case", FUNCTIONAL, ids=[c.name for c in FUNCTIONAL])
def test_functional_form_equals_the_object_run(case, batched):
    """``range_only_ekf``, ``bias_ekf``, ``fading_ekf``, ``cooperative_ekf`` and ``extended_kalman_filter`` give
    the object form's run, field for field (the packed fast paths to round-off)."""
    z, u = _inputs(case, batched)
    by_function = case.functional(batched)
    by_object = case.make(batched).run(z, u, by_function.times)      # the same clock (cooperative: 8 s steps)
    assert type(by_function) is type(by_object)
    _assert_same(by_function, by_object, exact=False)


def test_every_family_with_a_functional_form_is_checked_in_it():
    names = {c.name.split("-")[0] for c in FUNCTIONAL}
    assert names >= {"RangeOnlyEKF", "BiasEKF", "FadingEKF", "CooperativeEKF", "ExtendedKalmanFilter"}


@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_nan_measurement_is_predict_only(case):
    """No component: predict only. A missing component: its innovation is NaN (the others may update)."""
    z, u = _inputs(case, True)
    res = case.make(True).run(z, u)
    present = np.isfinite(z).reshape(M, K, -1)
    missing = ~present.any(axis=-1)
    assert missing.any() and (~missing).any()
    np.testing.assert_array_equal(res.x[missing], res.x_prior[missing])
    assert np.isnan(res.innovations[missing]).all()
    assert np.isnan(res.innovations[~present]).all()
    used = res.extras.get("accepted", res.extras.get("updated", ~missing))   # a gate may reject some present
    assert not used[missing].any() and np.isfinite(res.innovations[used & present.all(axis=-1)]).all()
    assert np.isfinite(res.innovations[used]).any(axis=-1).all()


@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_batched_run_m_equals_single_run_m(case):
    z, u = _inputs(case, True)
    batched = case.make(True).run(z, u)
    for m in (0, M - 1):
        zs, us = _inputs(case, False, m)
        single = case.make(False)
        # start it from run m's initial state; build it for run m where that is not all a run has of its own (the
        # fading filter's moments start from x0, the cooperative filter holds run m's leader track)
        if isinstance(single, ExtendedKalmanFilter) and not isinstance(single, (FadingEKF, CooperativeEKF)):
            single.x = np.array(case.make(True).x[m])
        else:                                             # build it for run m
            single = _single_from_batched(case, m)
        res = single.run(zs, us)
        for field in ("x", "P", "x_prior", "P_prior", "innovations", "innovation_cov"):
            np.testing.assert_allclose(getattr(batched, field)[m], getattr(res, field), rtol=1e-10, atol=1e-10,
                                       err_msg=field)
        for name in batched.extras:
            np.testing.assert_allclose(batched.extras[name][m], res.extras[name], rtol=1e-10, atol=1e-10)


def _single_from_batched(case, m):
    """The single-run filter of run ``m`` for filters whose state cannot be assigned (packed fast paths)."""
    if case.name == "RangeOnlyEKF":
        return RangeOnlyEKF(X0[m], np.eye(2) * 400.0, Q2, 4.0)
    if case.name == "FadingEKF":
        return FadingEKF(X0[m], np.eye(2) * 400.0, Q2, 4.0, mu_gamma=0.98, sigma_gamma=1 / 1500)
    if case.name.startswith("CooperativeEKF"):
        formulation, _, lost = case.name.split("-", 1)[1].partition("-lost-")
        return CooperativeEKF(paper_b.PARAMETERS.x1, _COOP_P0, paper_b.PARAMETERS.Q, paper_b.PARAMETERS.R, dt=8.0,
                              u=_COOP.dr_displacements[m], leader=_COOP.leader_broadcast[m], formulation=formulation,
                              lost=lost or "step")
    raise AssertionError(case.name)


@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_covariances_stay_symmetric_psd(case):
    z, u = _inputs(case, True)
    res = case.make(True).run(z, u)
    for P in (res.P, res.P_prior):
        np.testing.assert_array_equal(P, np.swapaxes(P, -1, -2))
        assert np.linalg.eigvalsh(P).min() >= -1e-9 * np.abs(P).max()


@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_bad_input_names_the_argument(case):
    z, u = _inputs(case, True)
    with pytest.raises(ValueError, match=r"\bz\b"):
        case.make(True).run(z[:2], u)
    if u is not None:
        with pytest.raises(ValueError, match=r"\bu\b"):
            case.make(True).run(z, u[:, :3])
        with pytest.raises(ValueError, match=r"\bu\b"):
            case.make(True).predict(np.full(u.shape[:1] + (u.shape[-1],), np.nan))
    filt = case.make(True)
    filt.predict(None if u is None else u[:, 0])
    with pytest.raises(ValueError, match=r"\bz\b"):
        filt.update(np.full(M + 1, 1.0))


# --- fast paths equal the generic engine ---------------------------------------------------------------------

class _AcceptAll(Gate):
    """A gate that accepts every range: it puts the plain range pair on the engine's generic arithmetic."""

    def accept(self, ctx):
        return np.ones(ctx.y.shape[0], dtype=bool)


def test_packed_range_ekf_equals_the_generic_engine():
    fast = range_only_ekf(X0, np.eye(2) * 400.0, U, Z, Q2, 4.0, beacon=(10.0, -5.0))
    generic = extended_kalman_filter(DeadReckoning(Q2), RangeToBeacon((10.0, -5.0), R=4.0), X0, np.eye(2) * 400.0,
                                     U, Z, gate=_AcceptAll())
    for field in ("x", "P", "x_prior", "P_prior", "innovations", "innovation_cov"):
        np.testing.assert_allclose(getattr(fast, field), getattr(generic, field), rtol=1e-10, atol=1e-9)
    np.testing.assert_array_equal(fast.extras["updated"], generic.extras["accepted"])


_SHIP = np.column_stack([np.linspace(0.0, 200.0, K), np.linspace(-50.0, 50.0, K)])
_PER_STEP_Q = np.stack([Q2 * (1.0 + 0.01 * k) for k in range(K)])
_PER_STEP_R = np.where(np.isnan(Z).all(axis=0), np.nan, 4.0 + 0.05 * np.arange(K))


@pytest.mark.parametrize("beacon, Q, R", [
    ((10.0, -5.0), Q2, 4.0),
    ((0.0, 0.0), Q2, 4.0),
    (_SHIP, Q2, 4.0),                                                       # a moving beacon, shared by the runs
    (_SHIP[None] + np.arange(M)[:, None, None], Q2, 4.0),                   # one path per run
    ((10.0, -5.0), _PER_STEP_Q, _PER_STEP_R),                               # Q and R per step (NaN R: no range)
], ids=["fixed", "origin", "moving", "moving-per-run", "per-step-noise"])
@pytest.mark.parametrize("batched", [False, True], ids=["single", "batched"])
def test_the_engine_runs_the_plain_range_pair_on_the_packed_back_end(beacon, Q, R, batched):
    """extended_kalman_filter on DeadReckoning + RangeToBeacon (no bias, no gate) is range_only_ekf, bit for bit;
    so is the engine stepped by hand, and RangeOnlyEKF is that engine."""
    if not batched and np.ndim(beacon) == 3:
        beacon = beacon[0]
    x0, u, z = _pick(X0, batched), _pick(U, batched), _pick(Z, batched)
    fast = range_only_ekf(x0, np.eye(2) * 400.0, u, z, Q, R, beacon=beacon)
    pair = (DeadReckoning(Q), RangeToBeacon(beacon, R=R))
    engine = extended_kalman_filter(*pair, x0, np.eye(2) * 400.0, u, z)
    for field in ("times", "x", "P", "x_prior", "P_prior", "innovations", "innovation_cov"):
        assert np.array_equal(getattr(fast, field), getattr(engine, field), equal_nan=True), field
    assert list(fast.extras) == ["updated"] and list(engine.extras) == ["accepted"]
    np.testing.assert_array_equal(fast.extras["updated"], engine.extras["accepted"])
    filt = ExtendedKalmanFilter(*pair, x0, np.eye(2) * 400.0)
    for k in range(K):
        filt.predict(u[..., k, :])
        filt.update(z[..., k])
        assert np.array_equal(filt.x, engine.x[..., k, :]) and np.array_equal(filt.P, engine.P[..., k, :, :])
    assert filt.k == K - 1
    assert issubclass(RangeOnlyEKF, ExtendedKalmanFilter)
    with pytest.raises(ValueError, match="R returned a non-finite value at step 1"):   # NaN R, a range present
        extended_kalman_filter(DeadReckoning(Q2), RangeToBeacon((0.0, 0.0), R=np.where(np.arange(K) == 1, np.nan,
                                                                                          4.0)),
                               X0, np.eye(2) * 400.0, U, np.where(np.isnan(Z), 100.0, Z))


def test_the_packed_back_end_continues_from_where_the_filter_stands():
    """run after some steps: the moving beacon and the per-step Q are read from the filter's step on."""
    pair = (DeadReckoning(_PER_STEP_Q), RangeToBeacon(_SHIP, R=4.0))
    whole = ExtendedKalmanFilter(*pair, X0, np.eye(2) * 400.0).run(Z, U)
    filt = ExtendedKalmanFilter(*pair, X0, np.eye(2) * 400.0)
    first = filt.run(Z[:, :20], U[:, :20])
    rest = filt.run(Z[:, 20:], U[:, 20:])
    for field in ("x", "P", "x_prior", "P_prior", "innovations", "innovation_cov"):
        joined = np.concatenate([getattr(first, field), getattr(rest, field)], axis=1)
        assert np.array_equal(joined, getattr(whole, field), equal_nan=True), field
    assert filt.k == K - 1
    with pytest.raises(IndexError, match="step 60 is beyond"):          # beyond the schedule: the generic step's error
        filt.run(Z[:, :3], U[:, :3])


def test_fading_ekf_without_fading_or_multiplicative_noise_equals_the_generic_engine():
    fast = fading_ekf(X0, np.eye(2) * 400.0, U, Z, Q2, 4.0, mu_gamma=1.0, sigma_gamma=0.0, fading=False,
                      beacon=(10.0, -5.0))
    generic = extended_kalman_filter(DeadReckoning(Q2), RangeToBeacon((10.0, -5.0), R=4.0), X0, np.eye(2) * 400.0,
                                     U, Z)
    for field in ("x", "P", "x_prior", "P_prior", "innovations", "innovation_cov"):
        np.testing.assert_allclose(getattr(fast, field), getattr(generic, field), rtol=1e-10, atol=1e-9)


def test_fading_p_prior_includes_the_fading_factor_under_run_filter():
    """run_filter records the prior the update used: with lambda > 1 it is lambda P + Q, as fading_ekf says."""
    functional = fading_ekf(X0, np.eye(2) * 400.0, U, Z, Q2, 4.0, mu_gamma=0.98, sigma_gamma=1 / 1500)
    looped = run_filter(FadingEKF(X0, np.eye(2) * 400.0, Q2, 4.0, mu_gamma=0.98, sigma_gamma=1 / 1500), Z, U)
    assert (functional.fading_factor > 1.0).any()
    np.testing.assert_allclose(looped.P_prior, functional.P_prior, rtol=1e-12, atol=1e-9)
    assert isinstance(looped, FadingResult) and len(looped.extras) == 7


def test_ls_fading_result_is_a_filter_result_and_run_monte_carlo_scores_its_nis():
    from uwtutor.pipelines import LSFadingResult, ls_fading_ekf
    from uwtutor.montecarlo import run_monte_carlo
    from uwtutor.scenarios import paper_d

    sc = paper_d.make(np.random.default_rng(5), n_runs=20)
    study = run_monte_carlo(lambda **kw: ls_fading_ekf(**kw), sc.true_positions, ranges=sc.ranges,
                            dr_displacements=sc.dr_displacements, Q=np.eye(2) * 0.81, R=0.49, P0=np.eye(2) * 2500.0,
                            sigma_gamma=1 / 1500, times=sc.times)
    res = study.result
    assert isinstance(res, LSFadingResult) and isinstance(res, FilterResult)
    after = np.arange(sc.ranges.shape[1])[None, :] > res.start_epoch[:, None]
    assert np.isfinite(study.nis[after & res.extras["updated"]]).all()
    assert np.isnan(study.nis[~after]).all()
    np.testing.assert_array_equal(res.fading_factor, res.extras["fading_factor"])


# --- one rule for the state a filter shows (issue 27) ------------------------------------------------------------

@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_state_is_read_only_and_set_by_assignment(case):
    """What a filter shows is read-only: writing into ``x`` raises (never a change silently lost, or one that
    bypasses validation). A new ``x`` or ``P`` is given by assignment, validated, and the run starts from it."""
    z, u = _inputs(case, True)
    filt = case.make(True)
    filt.predict(None if u is None else u[:, 0])
    filt.update(z[:, 0])
    for name in ("x", "P", "x_prior", "P_prior"):
        with pytest.raises(ValueError, match="read-only"):
            getattr(filt, name)[...] += 1.0
    before = filt.x
    kept = before.copy()
    shifted = before + 1.0
    filt.x = shifted
    np.testing.assert_array_equal(filt.x, shifted)
    np.testing.assert_array_equal(before, kept)                   # a value shown earlier is not changed by it
    filt.P = 2.0 * filt.P
    with pytest.raises(ValueError, match=r"\bx\b"):
        filt.x = np.full_like(shifted, np.nan)
    with pytest.raises(ValueError, match=r"\bP\b"):
        filt.P = -filt.P

    plain, moved = case.make(True), case.make(True)
    moved.x = moved.x + 5.0
    a, b = plain.run(z, u), moved.run(z, u)
    assert not np.allclose(a.x_prior[:, 0], b.x_prior[:, 0])      # the first prediction starts from the new x


def test_fading_state_is_set_between_steps_only():
    """The fading filter computes its step at the update from the estimate it started from: x is set between
    steps, not between a predict and its update."""
    filt = FadingEKF(X0, np.eye(2) * 400.0, Q2, 4.0, mu_gamma=0.98, sigma_gamma=1 / 1500)
    filt.predict(U[:, 0])
    with pytest.raises(RuntimeError, match="before predict or after update"):
        filt.x = X0
    filt.update(Z[:, 0])
    filt.x = X0
    np.testing.assert_array_equal(filt.x, X0)


# --- one rule for a filter's configuration (its parameters and its diagnostics) ---------------------------------

def constructor_arguments(make, batched):
    """``(cls, arguments)``: the class ``make(batched)`` builds and the arguments its constructor received."""
    import inspect
    from unittest import mock

    cls = type(make(batched))
    original = cls.__init__
    signature = inspect.signature(original)
    seen: dict = {}

    def spy(self, *args, **kwargs):
        if not seen:                                   # the outermost constructor (a subclass calls its parent's)
            seen.update(signature.bind(self, *args, **kwargs).arguments)
        original(self, *args, **kwargs)
    with mock.patch.object(cls, "__init__", spy):
        make(batched)
    seen.pop("self")
    return cls, seen


def constructed_with(make, batched, name, value):
    """``make(batched)`` with the constructor argument ``name`` replaced by ``value`` (everything else, random
    generators included, made afresh as ``make`` makes it)."""
    import inspect
    from unittest import mock

    cls = type(make(batched))
    original = cls.__init__
    signature = inspect.signature(original)
    done = []

    def spy(self, *args, **kwargs):
        if not done:                                   # the outermost constructor only
            done.append(True)
            bound = signature.bind(self, *args, **kwargs)
            bound.arguments[name] = value
            return original(*bound.args, **bound.kwargs)
        return original(self, *args, **kwargs)
    with mock.patch.object(cls, "__init__", spy):
        return make(batched)


def changed(name, value):
    """Another valid value of a parameter: 1.5 times it (a beacon 5 m away, 0.1 for a zero, another resampler)."""
    if callable(value):
        from uwtutor.resampling import stratified_resample
        return stratified_resample
    new = np.asarray(value, dtype=float) * 1.5
    if name == "beacon":
        return new + 5.0
    return new if np.any(new) else np.full_like(new, 0.1)


#: Constructor arguments that are the filter's state or inputs, not its configuration.
NOT_CONFIGURATION = {"x0", "P0", "particles", "weights", "modes", "mode_probabilities"}


def check_configuration_rule(make, batched, run):
    """The rule of base.Configurable for the filter ``make(batched)``: every constructor parameter is either
    assignable (and then runs exactly as a filter constructed with the new value) or fixed (assignment refused); the
    diagnostics are read-only; a parameter is shown read-only. ``run(filt)`` returns its result on a sequence."""
    filt = make(batched)
    cls, arguments = constructor_arguments(make, batched)
    parameters, fixed = set(cls._parameters), set(cls._fixed)
    unruled = {a for a in arguments if not a.startswith("_")} - parameters - fixed - NOT_CONFIGURATION
    assert not unruled, f"{cls.__name__}: constructor parameters neither assignable nor fixed: {sorted(unruled)}"
    for name in ("y", "S") + tuple(filt.extra_outputs):
        with pytest.raises(AttributeError, match="read-only"):
            setattr(filt, name, getattr(filt, name))
        shown = getattr(filt, name)
        if isinstance(shown, np.ndarray):
            with pytest.raises(ValueError, match="read-only"):
                shown[...] = 0
    for name in sorted(fixed):
        with pytest.raises(AttributeError, match="build a new"):
            setattr(make(batched), name, getattr(filt, name, None))
    plain = run(make(batched))
    for name in sorted(parameters):
        if arguments.get(name) is None:
            continue
        shown = getattr(filt, name)
        if isinstance(shown, np.ndarray) and shown.ndim:
            with pytest.raises(ValueError, match="read-only"):
                shown[...] = 0
        new = changed(name, arguments[name])
        assigned = make(batched)
        setattr(assigned, name, new)
        by_assignment = run(assigned)
        by_constructor = run(constructed_with(make, batched, name, new))
        _assert_same(by_assignment, by_constructor)
        assert not np.allclose(by_assignment.x, plain.x, equal_nan=True), f"{name} assigned had no effect"
        bad = "not a function" if callable(new) else np.full_like(np.asarray(new, dtype=float), np.nan)
        with pytest.raises((ValueError, TypeError), match=name):
            setattr(make(batched), name, bad)


@pytest.mark.parametrize("batched", [False, True], ids=["single", "batched"])
@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_configuration_takes_effect_or_is_refused(case, batched):
    """Q, R and every parameter: assigned, the filter runs as one constructed with the new value (nothing computed
    from the old one is kept: RangeOnlyEKF's packed Q), or the assignment raises; y, S and the extra outputs are
    read-only."""
    z, u = _inputs(case, batched)
    check_configuration_rule(lambda b: case.make(b), batched, lambda f: f.run(z, u))
