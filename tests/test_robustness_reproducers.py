"""The reproducers of issue 26, one test each: values that come back from user code are checked (a model's Q/R,
a gate's verdict, a linearize mask, a student's answer or function), and the silent answers found by the outside
robustness run are now a clear error naming the argument (or, for a filter locked out, a warning).

The robustness contract (tests/test_robustness_contract.py) finds this class of bug on every public callable;
these tests pin the cases reported in the issue.
"""

from __future__ import annotations

import sys

import numpy as np
import pytest

from uwtutor import acoustics, grey, metrics, motion, observability as ob, owtt, reporting, wavelet
from uwtutor.errors import IllConditionedError, UwtutorWarning
from uwtutor.exercises import ch02, ch07, ch08, checks
from uwtutor.filters import extended_kalman_filter, fading_ekf, rts_smoother
from uwtutor.filters.gates import Gate, normalized_innovation_squared
from uwtutor.filters.robust import make_test, robust_range_kf
from uwtutor.pipelines.staggered import filter_from_start_epochs
from uwtutor.lsq import linearized_lsq
from uwtutor.models import DeadReckoning, RangeToBeacon, SquaredRangePair
from uwtutor.models.base import MotionModel
from uwtutor.models.cooperative import measurement_noise_map
from uwtutor.models.depth import depth_speed_pitch_kinematics
from uwtutor.models.range import line_of_sight
from uwtutor.pipelines import or_vmlbl_kf
from uwtutor.scenarios import paper_b, suite

K = 6
_TH = np.linspace(0.0, 1.0, K + 1)
TRACK = np.column_stack([300.0 * np.cos(_TH), 300.0 * np.sin(_TH)])
U = np.diff(TRACK, axis=0)
Z = np.linalg.norm(TRACK[1:], axis=1)


class _Motion(MotionModel):
    n = 2

    def __init__(self, Q):
        self._Q = np.asarray(Q, dtype=float)

    def f(self, x, u, k):
        return x + u

    def F(self, x, u, k):
        return np.eye(2)

    def Q(self, x, u, k):
        return self._Q


class _Range(RangeToBeacon):
    def __init__(self, R=1.0, mask=None):
        super().__init__((0.0, 0.0), R=1.0)
        self._R, self._mask = np.atleast_2d(R), mask

    def R(self, x, k):
        return self._R

    def linearize(self, x, k):
        z, H, defined = super().linearize(x, k)
        return z, H, (defined if self._mask is None else self._mask)


def _run(motion=None, measurement=None, gate=None):
    return extended_kalman_filter(motion or _Motion(np.eye(2) * 0.1), measurement or _Range(), TRACK[0] + 3.0,
                                  np.eye(2) * 100.0, U, Z, gate=gate)


# --- values returned by user code -------------------------------------------------------------------------------------
@pytest.mark.parametrize("Q, match", [
    ([[1.0, 0.0], [0.0, -1.0]], r"_Motion\.Q returned a matrix that is not positive semi-definite"),
    ([[1.0, 0.5], [0.0, 1.0]], r"_Motion\.Q returned a matrix that is not symmetric"),
])
def test_a_models_Q_is_checked_and_named(Q, match):
    with pytest.raises(ValueError, match=match):
        _run(motion=_Motion(Q))


def test_a_models_R_is_checked_and_named():
    with pytest.raises(ValueError, match=r"_Range\.R returned a matrix that is not positive semi-definite"):
        _run(measurement=_Range(R=-1.0))


def test_a_library_models_covariances_are_checked_once_a_subclass_that_overrides_them_every_step(monkeypatch):
    """The library's own models check their covariances when they are made (``covariances_checked``): the engine
    does not check them again at every step. A subclass of yours that overrides Q is checked like any user model."""
    from uwtutor import _validate
    from uwtutor.models import DeadReckoning

    calls = []
    real = _validate.check_model_covariance                 # the one check of every filter family
    monkeypatch.setattr(_validate, "check_model_covariance",
                        lambda name, value: calls.append(name) or real(name, value))
    K = len(Z)
    _run(motion=DeadReckoning(np.tile(np.eye(2) * 0.1, (K, 1, 1))), measurement=RangeToBeacon((0.0, 0.0), R=1.0))
    assert calls == []

    class Wobbly(DeadReckoning):
        def Q(self, x, u, k):
            return np.array([[0.1, 0.0], [0.0, -0.1 if k == 5 else 0.1]])

    with pytest.raises(ValueError, match=r"Wobbly\.Q returned a matrix that is not positive semi-definite"):
        _run(motion=Wobbly(np.eye(2)))
    assert calls.count("the motion model Wobbly.Q") == 6     # steps 0-5, each Q a new array


def test_a_linearize_mask_must_be_bools_of_the_right_shape():
    with pytest.raises(ValueError, match=r"linearize .* shape \(1,\) or \(1, 1\); got \(3,\)"):
        _run(measurement=_Range(mask=np.ones(3, dtype=bool)))
    with pytest.raises(TypeError, match=r"linearize .* must return bools"):
        _run(measurement=_Range(mask=np.array([0.3])))


def test_a_gate_returning_a_float_does_not_count_as_true():
    class Fuzzy(Gate):
        def accept(self, ctx):
            return np.full(ctx.y.shape[0], 0.3)
    with pytest.raises(TypeError, match=r"the gate Fuzzy\.accept must return bools .*0\.3"):
        _run(gate=Fuzzy())


# --- a student's answer and a student's function ----------------------------------------------------------------------
def test_checkers_refuse_a_complex_or_string_right_answer():
    x0, y0 = ch02.CURRENT_START
    wx, wy = ch02.CURRENT_VELOCITY
    right = np.array([-y0, x0, -wy, wx])
    assert ch02.check_unobservable_direction(right).correct
    for wrong in (right + 5j, right.astype(str), [str(v) for v in right]):
        fb = ch02.check_unobservable_direction(wrong)
        assert not fb.correct and ("complex" in fb.message or "not a number" in fb.message)
    weak = ch07._weak_direction()[0]
    assert ch07.check_weak_direction(weak).correct
    for wrong in (weak + 5j, "abc", weak.astype(object).tolist() + [None], np.array([1, "a"], object), 1 + 2j):
        fb = ch07.check_weak_direction(wrong)
        assert not fb.correct


def test_parse_real_array_is_the_shared_parser():
    arr, fb = checks.parse_real_array([1.0, 2.0], "v", (2,))
    assert fb is None and arr.tolist() == [1.0, 2.0]
    for bad in (np.ones(2) + 0j, ["1", "2"], [1.0, None], object(), "x"):
        arr, fb = checks.parse_real_array(bad, "v", (2,))
        assert arr is None and not fb.correct


def _loop(*args):
    while True:
        pass


def test_check_pair_jacobian_calls_the_student_within_the_time_limit(monkeypatch):
    monkeypatch.setattr(checks, "TIME_LIMIT", 0.3)
    fb = ch08.check_pair_jacobian(_loop)
    assert not fb.correct and "still running" in fb.message
    fb = ch08.check_pair_jacobian(lambda *a: sys.exit(3))
    assert not fb.correct and "sys.exit" in fb.message


def test_run_student_catches_loops_exits_and_errors(monkeypatch):
    monkeypatch.setattr(checks, "TIME_LIMIT", 0.2)
    assert checks.run_student(lambda a: 2 * a, 3.0) == (6.0, None)
    for func in (_loop, lambda: sys.exit(), lambda: 1 / 0, 42, None):
        value, fb = checks.run_student(func, name="f")
        assert value is None and not fb.correct


def test_the_isfekf_step_checker_refuses_a_complex_or_text_right_answer():
    """It read the student's x, P, V... with np.asarray(dtype=float): a complex x and a P of strings passed."""
    from uwtutor.exercises import ch05
    ref = ch05.isfekf_step_reference

    def returning(index, change):
        def step(*args):
            out = list(ref(*args))
            out[index] = change(out[index])
            return tuple(out)
        return step
    assert ch05.check_isfekf_step(ref).correct
    for index, change, word in ((0, lambda x: x + 5j, "complex"),
                                (1, lambda P: np.asarray(P).astype(str), "not a number"), (4, complex, "complex")):
        fb = ch05.check_isfekf_step(returning(index, change))
        assert not fb.correct and word in fb.message


def test_the_jacobian_checkers_explain_a_ragged_or_unreadable_answer():
    """Their probe for a (1, n) row called np.shape(answer), which raises on a ragged list."""
    from uwtutor.exercises import ch04

    class Unreadable:
        def __array__(self, *args, **kwargs):
            raise RuntimeError("no array")
    for check in (ch04.check_range_jacobian, ch07.check_augmented_jacobian, ch07.check_bias_noise):
        for answer in ([[1.0, 2.0], [3.0]], [[1.0, [2.0], 3.0]], (np.ones(2), np.ones(3)), Unreadable()):
            fb = check(answer)
            assert not fb.correct and fb.message
    # a (1, n) row is still read as the vector
    p, b = np.array(ch04.JACOBIAN_POSITION), np.array(ch04.JACOBIAN_BEACON)
    assert ch04.check_range_jacobian([(p - b) / np.linalg.norm(p - b)]).correct


def test_the_nees_letter_checkers_read_the_letters_before_the_study(monkeypatch):
    """One shared checker for exercises 4.5 and 7.5: an answer that is no letter never runs the Monte Carlo study."""
    from uwtutor.exercises import ch04

    def no_study(*args, **kwargs):
        raise AssertionError("the study ran")
    monkeypatch.setattr(ch04, "diagnosis_studies", no_study)
    monkeypatch.setattr(ch07, "bias_diagnosis_studies", no_study)
    for check in (ch04.check_diagnosis, ch07.check_bias_diagnosis):
        for answers in ((None, "A"), ("A", 1 + 2j), ("a", "B"), ("B", "B"), ("A", "D")):
            assert not check(*answers).correct


def test_the_pattern_checker_reads_any_answer_before_its_study(monkeypatch):
    """ch08.check_unobservable_pattern tested `answer in LEADER_PATTERNS` after an 8 s study: an array answer
    crashed it (an elementwise ==), hidden by its exemption from the contract; now it is read first."""
    def no_study():
        raise AssertionError("the study ran")
    monkeypatch.setattr(ch08, "_study", no_study)
    for answer in (np.ones(3), np.zeros(0), "Zigzag", 1, ["straight"]):
        fb = ch08.check_unobservable_pattern(answer)
        assert not fb.correct and "is not a leader pattern" in fb.message


def test_final_rmse_refuses_a_run_that_diverged():
    from uwtutor.exercises import ch05
    truth = np.zeros((3, 4, 2))
    est = truth + 1.0
    assert ch05.final_rmse(est, truth) == pytest.approx(np.sqrt(2.0))
    est[1, -1, 0] = np.nan
    with pytest.raises(ValueError, match="estimates hold NaN or infinity at the last epoch in 1 run"):
        ch05.final_rmse(est, truth)
    est[1, -1, 0] = 1.0
    est[1, 0, 0] = np.nan                            # before the last epoch: not read (a filter not started yet)
    assert ch05.final_rmse(est, truth) == pytest.approx(np.sqrt(2.0))
    with pytest.raises(ValueError, match="truth must have shape"):
        ch05.final_rmse(est, truth[..., :1])


def test_threshold_innovation_names_beta_and_the_steady_terms():
    from uwtutor.exercises import ch05
    with pytest.raises(ValueError, match="beta must be finite"):
        ch05.threshold_innovation(np.inf)
    with pytest.raises(ValueError, match="steady must have exactly the keys"):
        ch05.threshold_innovation(1.0, {"rho": 0.95})
    with pytest.raises(ValueError, match=r"steady\['rho'\] must lie in \(0, 1\]"):
        ch05.threshold_innovation(1.0, dict(ch05.STEADY, rho=1.5))
    # a weakening factor so small that every innovation makes lambda > 1: the threshold is 0, not a math error
    assert ch05.threshold_innovation(0.0, dict(ch05.STEADY, R=100.0)) == 0.0


# --- the silent answers of the report, now refused by name ------------------------------------------------------------
def _raises(exc, match, fn, *args, **kwargs):
    with pytest.raises(exc, match=match):
        fn(*args, **kwargs)


@pytest.mark.parametrize("label, exc, match, call", [
    ("fading second moment", ValueError, "second_moment0 must be positive semi-definite",
     lambda: fading_ekf(TRACK[0], np.eye(2) * 100, U, Z, np.eye(2) * 0.1, 1.0, second_moment0=-np.eye(2))),
    ("pcrb tiny sigma", ValueError, "sigma must be at least 1e-150",
     lambda: ob.posterior_crlb(TRACK, np.zeros(2), 1e-300, np.eye(2) * 0.1, np.eye(2) * 100.0)),
    ("pcrb decreasing times", ValueError, "times must increase strictly",
     lambda: ob.posterior_crlb(TRACK, np.zeros(2), 1.0, np.eye(2) * 0.1, np.eye(2) * 100.0,
                               times=np.arange(K + 1.0)[::-1])),
    ("crlb_inputs seed None", TypeError, "seed must be an integer seed",
     lambda: suite.crlb_inputs("circle", "white", n_tracks=2, seed=None)),
    ("crlb_inputs scenario list", ValueError, "scenario must be one of",
     lambda: suite.crlb_inputs(["circle"], "white", n_tracks=2)),
    ("robust probability ignored", TypeError, "probability must be numeric",
     lambda: robust_range_kf(Z, test="paper", probability="abc")),
    ("make_test delta ignored", ValueError, "delta must be finite",
     lambda: make_test("chi2", delta=np.nan)),
    ("make_test one-element list", ValueError, "probability must be a single number",
     lambda: make_test("chi2", probability=[0.9])),
    ("per_run truncated", ValueError, r"per_run\['mu_gamma'\] must have one value per run",
     lambda: filter_from_start_epochs(fading_ekf, [1, 2], TRACK[[1, 2]], np.eye(2), np.tile(U, (2, 1, 1)),
                                      np.tile(Z, (2, 1)), Q=np.eye(2) * 0.1, R=1.0,
                                      per_run={"mu_gamma": [1.0, 2.0, 3.0]})),
    ("filter_fn not callable", TypeError, "filter_fn must be a function",
     lambda: filter_from_start_epochs(3, [1, 2], TRACK[[1, 2]], np.eye(2), np.tile(U, (2, 1, 1)),
                                      np.tile(Z, (2, 1)))),
    ("literal 'False'", TypeError, "literal must be True or False",
     lambda: SquaredRangePair(np.zeros((2, 2)) + [[100.0, 0.0]], np.ones((1, 2)), 8.0, np.eye(10),
                              literal="False")),
    ("line_of_sight NaN beacon", ValueError, "beacon must be finite",
     lambda: line_of_sight(TRACK, [np.nan, 0.0])),
    ("noise map NaN", ValueError, "a must be finite", lambda: measurement_noise_map([np.nan, 1.0], [1.0, 1.0], 8.0)),
    ("kinematics string T", TypeError, "T must be numeric",
     lambda: depth_speed_pitch_kinematics(np.array([10.0, 2.0, 0.1]), "1.5")),
    ("NIS None inside", TypeError, "y contains None",
     lambda: normalized_innovation_squared([[None]], np.ones((1, 1, 1)))),
    ("matched_tuning NaN", ValueError, "position_noise must be finite",
     lambda: paper_b.matched_tuning(position_noise=np.nan)),
    ("or_vmlbl_kf negative depth", ValueError, "depth must be >= 0",
     lambda: or_vmlbl_kf(TRACK[1:], Z, ship_positions=TRACK[1:], depth=-10.0)),
    ("None inside an object array", TypeError, "z contains None",
     lambda: extended_kalman_filter(DeadReckoning(np.eye(2)), RangeToBeacon((0.0, 0.0), R=1.0), TRACK[0],
                                    np.eye(2), U, np.array([None] + list(Z[1:]), dtype=object))),
    ("travel time overflow", ValueError, "the range overflows float64",
     lambda: acoustics.range_from_travel_time(1e307, 1e5)),
    ("position_crlb 1e300", ValueError, "position must be at most",
     lambda: ob.position_crlb(np.eye(2) * 1000.0, [1e300, 0.0], 1.0)),
    ("lsq 1e300", ValueError, "beacons must be at most",
     lambda: linearized_lsq([1.0, 2.0, 3.0], np.eye(3, 2) * 1e300, [0.0, 0.0])),
    ("paper_b tiny interval", ValueError, "interval must lie between dr_step and duration",
     lambda: paper_b.make(np.random.default_rng(0), 1, interval=1e-300)),
    ("paper_b one-element interval", ValueError, "interval must be a single number",
     lambda: paper_b.make(np.random.default_rng(0), 1, interval=[8.0])),
    ("suite unbounded work", ValueError, r"n_runs asks for .* use fewer, or run them in chunks",
     lambda: suite.circle(np.random.default_rng(0), 10**8)),
    ("metrics 1e300 estimate", ValueError, "estimates must be finite .* and at most",
     lambda: metrics.rmse_over_time(TRACK + [1e300, 0.0], TRACK)),
    ("metrics 1e300 truth", ValueError, "truth must be at most",
     lambda: metrics.estimation_errors(TRACK, TRACK * 1e300)),
    ("NEES overflow", ValueError, "NEES that overflows",
     lambda: metrics.nees(TRACK + 1e100, np.tile(np.eye(2) * 1e-150, (K + 1, 1, 1)), TRACK)),
    ("gm11_next 1e300 beside 11", ValueError, "series gives a GM\\(1,1\\) forecast that overflows",
     lambda: grey.gm11_next([1e300, 11.0, 12.5, 13.0, 14.2])),
    ("gm11 coefficients 1e-300 beside 1e300", ValueError, "series cannot be fitted by GM\\(1,1\\) in float64",
     lambda: grey.gm11_coefficients([1e300, 11.0, 12.5, 13.0, 1e-300])),
    ("gm11 forecast overflow", ValueError, "the GM\\(1,1\\) forecast overflows float64",
     lambda: grey.gm11_forecast([1.0, 10.0, 100.0, 1e3, 1e4], 4000)),
    ("gm11 one-element background_weight", ValueError, "background_weight must be a single number",
     lambda: grey.fit_gm11([10.0, 11.0, 12.5, 13.0], background_weight=[0.5])),
    ("observability one-element rtol", ValueError, "rtol must be a single number",
     lambda: ob.numerical_rank(np.eye(2), rtol=[1e-6])),
    ("two_range_fix overflow", ValueError, "displacement must be at most",
     lambda: ob.two_range_fix([0.0, 0.0], [100.0, 104.0], [1e300, 0.0])),
    ("owtt clock offset named", TypeError, "clock_offset must be numeric",
     lambda: owtt.simulate_owtt([0.0, 1.0], (0.0, 0.0), (1500.0, 0.0), clock_offset="abc")),
    ("dead reckoning unbounded runs", ValueError, "n_runs asks for",
     lambda: motion.dead_reckoning(motion.straight_track(np.arange(5.0), (0.0, 0.0), 1.0, 0.0),
                                   np.random.default_rng(0), n_runs=10**12)),
    ("wavelet as an int", TypeError, "wavelet must be the name of a discrete wavelet",
     lambda: wavelet.noise_sigma(np.ones(20), wavelet=6)),
    ("below_or_value bad fmt", ValueError, "fmt must be a float format",
     lambda: reporting.below_or_value(1e-12, fmt="no-such")),
])
def test_reported_silent_answers_are_refused(label, exc, match, call):
    with pytest.raises(exc, match=match):
        call()


def test_rts_smoother_refuses_an_indefinite_filter_covariance():
    motion = DeadReckoning(np.eye(2) * 0.1)
    res = extended_kalman_filter(motion, RangeToBeacon((0.0, 0.0), R=1.0), TRACK[0] + 3.0, np.eye(2) * 100.0, U, Z)
    P = res.P.copy()
    P[2] = [[1.0, 0.0], [0.0, -1.0]]
    import dataclasses
    with pytest.raises(ValueError, match="result.P must be positive semi-definite"):
        rts_smoother(dataclasses.replace(res, P=P), motion, U)


def test_rts_smoother_names_a_singular_prediction():
    motion = DeadReckoning(np.zeros((2, 2)))
    res = extended_kalman_filter(motion, RangeToBeacon((0.0, 0.0), R=1.0), TRACK[0] + 3.0, np.eye(2) * 100.0, U, Z)
    import dataclasses
    Pp = res.P_prior.copy()
    Pp[3] = 0.0
    with pytest.raises(IllConditionedError, match="result.P_prior is singular"):
        rts_smoother(dataclasses.replace(res, P_prior=Pp), motion, U)


def test_a_locked_out_robust_filter_says_so():
    from uwtutor.filters.robust import robust_track_kf
    t = np.arange(120.0)
    z = 1800.0 - 1.2 * t + np.random.default_rng(3).normal(0.0, np.sqrt(2.0), t.size)
    with pytest.warns(UwtutorWarning, match=r"rejected 120 of 120 measurements"):   # a start 150 m off
        robust_track_kf(z[:, None], 1.0, q=0.01, r=2.0, test="paper", reacquire=None,
                        x0=np.array([z[0] + 150.0, 0.0]), P0=np.diag([2.0, 0.01]))


def test_rts_smoother_after_a_huge_P0_and_a_tiny_R_says_why():
    """P0 = 1e12 I with R <= 1e-6: the smoothed covariance cannot be formed in float64; the error says so and
    what to change, instead of numpy's raw ``LinAlgError: Singular matrix``."""
    motion = DeadReckoning(np.eye(2) * 0.1)
    for R in (1e-6, 1e-12):
        res = extended_kalman_filter(motion, RangeToBeacon((0.0, 0.0), R=R), TRACK[0] + 3.0, np.eye(2) * 1e12, U, Z)
        with pytest.raises(IllConditionedError, match="start from a smaller P0 or a larger R"):
            rts_smoother(res, motion, U)


def test_a_locked_out_robust_range_filter_says_so():
    z = 1000.0 + np.cumsum(np.random.default_rng(0).normal(0.0, 3.0, 300))   # a range that wanders 3 m a step
    with pytest.warns(UwtutorWarning, match=r"rejected \d+ of 300 measurements: the filter is locked out"):
        robust_range_kf(z, 1.0, q=0.0, r=1e-12)


# --- the struct share of the contract: models, filters, pipelines, real logs ------------------------------------------
def _depth_study_call(**kw):
    from uwtutor.pipelines.depth_study import run_depth_study
    from uwtutor.scenarios import paper_c
    sc = paper_c.make(np.random.default_rng(0), n_runs=1, duration=2.0)
    return run_depth_study(sc.profile, sc.measurements, ("EKF",), **kw)


def _small_log():
    from uwtutor.datasets import RangeDataset
    K = 41
    odo = np.column_stack([np.r_[0.0, np.ones(K - 1)], np.zeros(K)])
    truth = np.column_stack([np.arange(K, dtype=float), np.zeros(K), np.zeros(K)])
    r = np.linalg.norm(truth[1::2, :2] - [5.0, 12.0], axis=1)
    ranges = np.column_stack([np.arange(1.0, K, 2), np.full(r.size, 3), r])
    return RangeDataset(times=np.arange(K, dtype=float), odometry=odo, ranges=ranges, beacons={3: (5.0, 12.0)},
                        truth=truth)


@pytest.mark.parametrize("label, exc, match, call", [
    ("bias_ekf negative range", ValueError, "z must be finite and >= 0",
     lambda: __import__("uwtutor.filters", fromlist=["x"]).bias_ekf(
         np.r_[TRACK[0], 0.0], np.eye(3) * 100.0, U, -Z, np.eye(3) * 0.1, 1.0)),
    ("DepthEKF names its Q", ValueError, "^Q must be positive semi-definite",
     lambda: __import__("uwtutor.filters", fromlist=["x"]).DepthEKF([10.0, 1.5, 0.1], np.eye(3), -np.eye(3))),
    ("CooperativeEKF range_variance", TypeError, "range_variance must be numeric",
     lambda: __import__("uwtutor.filters.cooperative", fromlist=["x"]).CooperativeEKF(
         np.zeros(4), np.eye(4), np.eye(6), np.eye(10), dt=8.0, u=np.ones((2, 2)), leader=np.ones((3, 2)) * 100.0,
         range_variance="4")),
    ("wrap_angle None", TypeError, "angle contains None",
     lambda: __import__("uwtutor.models", fromlist=["x"]).wrap_angle([0.5, None])),
    ("step_lengths dt with times", TypeError, "dt must be numeric",
     lambda: __import__("uwtutor.models.robust", fromlist=["x"]).step_lengths(3, dt="1", times=[0.0, 1.0, 2.0])),
    ("per_run_generators spawn", TypeError, "spawn must be True or False",
     lambda: __import__("uwtutor.models.noise", fromlist=["x"]).per_run_generators(
         np.random.default_rng(0), 2, spawn="False")),
    ("OdometryMotion huge sigma", ValueError, "sigma_distance must be at most",
     lambda: __import__("uwtutor.models", fromlist=["x"]).OdometryMotion(1e300, 1e-3)),
    ("run_depth_study ignored parameter", TypeError, "mmpf_time_constant must be numeric",
     lambda: _depth_study_call(mmpf_time_constant=None)),
    ("navigate smooth 'False'", TypeError, "smooth must be True or False",
     lambda: __import__("uwtutor.datasets", fromlist=["x"]).navigate(_small_log(), smooth="False")),
    ("RobustGate NaN step", ValueError, "steps must be finite",
     lambda: __import__("uwtutor.filters.robust", fromlist=["x"]).RobustGate(None, [0.0, np.nan, 1.0])),
    ("robust_track_kf P0 of the wrong size", ValueError, r"P0 must be 2x2",
     lambda: __import__("uwtutor.filters.robust", fromlist=["x"]).robust_track_kf(Z[:, None], q=0.01, r=2.0,
                                                                                 P0=np.eye(4))),
    ("range_factor_moments names effective_speed", ValueError, "effective_speed must lie in",
     lambda: __import__("uwtutor.filters.fading", fromlist=["x"]).range_factor_moments(1470.0, 1e300)),
    ("weights of other particles", ValueError, r"one weight for each of the particles",
     lambda: __import__("uwtutor.filters", fromlist=["x"]).BootstrapParticleFilter(
         DeadReckoning(np.eye(2)), RangeToBeacon((0.0, 0.0), R=1.0), np.zeros((5, 2)), np.random.default_rng(0),
         weights=np.ones(4))),
])
def test_struct_share_silent_answers_are_refused(label, exc, match, call):
    with pytest.raises(exc, match=match):
        call()


def test_prepositioned_start_names_a_max_alpha_that_accepts_a_singular_fix():
    from uwtutor.pipelines import prepositioned_bias_ekf
    from uwtutor.scenarios import paper_a
    sc = paper_a.make(np.random.default_rng(0), n_runs=1)
    args = (sc.true_positions[:, 0] + [150.0, 0.0], None, sc.dr_displacements[:, :600], sc.ranges[:, :600], np.eye(3),
            5.0)
    assert np.isfinite(prepositioned_bias_ekf(*args, max_alpha=2.0).x[:, -1]).all()
    with pytest.raises(ValueError, match="max_alpha = 1e\\+300 accepted a fix that is singular"):
        prepositioned_bias_ekf(*args, max_alpha=1e300)


def test_the_engine_refuses_a_negative_range_of_a_range_model():
    """A model that measures ranges (``nonnegative = True``: RangeToBeacon, BeaconRanges, and a model of yours that
    sets it) gets no negative range through the engine, as range_only_ekf does not; a model of other measurements
    may take negative values."""
    from uwtutor.filters import ExtendedKalmanFilter
    from uwtutor.models import LinearMeasurement, LinearMotion
    z = Z.copy()
    z[2] = -1.0
    with pytest.raises(ValueError, match=r"z must be >= 0 \(RangeToBeacon measures ranges; .*\); got -1 at index 2"):
        extended_kalman_filter(DeadReckoning(np.eye(2)), RangeToBeacon((0.0, 0.0), R=1.0), TRACK[0], np.eye(2), U, z)
    filt = ExtendedKalmanFilter(DeadReckoning(np.eye(2)), RangeToBeacon((0.0, 0.0), R=1.0), TRACK[0], np.eye(2))
    with pytest.raises(ValueError, match="z must be >= 0"):
        filt.run(z, U)
    res = extended_kalman_filter(LinearMotion(F=[[1.0]], Q=[[1.0]]), LinearMeasurement(H=[[1.0]], R=1.0), [0.0],
                                 [[1.0]], None, [-1.0, -2.0, np.nan])
    assert np.isfinite(res.x).all()


@pytest.mark.parametrize("f, F, exc, match", [
    (lambda x, u: x + u + 1j, None, TypeError, r"the model's f must return real numbers; .*complex128 \(complex"),
    (None, "abc", TypeError, r"the model's F must return real numbers; got an array of dtype <U3"),
    (lambda x, u: np.array([[None, 1.0]], dtype=object), None, TypeError, "it returned NoneType None"),
])
def test_what_a_motion_model_returns_is_real(f, F, exc, match):
    """A complex f is refused (numpy would drop its imaginary part with a warning), a string F by the model's name
    for it, not by numpy's conversion error."""
    class Odd(_Motion):
        def f(self, x, u, k):
            return x + u if f is None else f(x, u)

        def F(self, x, u, k):
            return np.eye(2) if F is None else F
    with pytest.raises(exc, match=match):
        _run(motion=Odd(np.eye(2) * 0.1))


def test_a_measurement_of_the_wrong_size_is_named():
    class Twice(_Range):
        def linearize(self, x, k):
            z, H, defined = super().linearize(x, k)
            return np.hstack([z, z]), H, defined
    with pytest.raises(ValueError, match=r"the measurement model's h must return shape \(1, 1\); got \(1, 2\)"):
        _run(measurement=Twice())


@pytest.mark.parametrize("returned, exc, match", [
    (lambda x, P: (x, -P), ValueError, r"the gate Odd\.after_update \(its P\) returned a matrix that is not positive"),
    (lambda x, P: (x * np.nan, P), ValueError, r"the gate Odd\.after_update returned a non-finite x"),
    (lambda x, P: (x, P + 0j), TypeError, r"the gate Odd\.after_update \(its P\) must return real numbers"),
    (lambda x, P: None, TypeError, r"the gate Odd\.after_update must return the pair \(x, P\); got NoneType"),
])
def test_what_a_gate_after_update_returns_is_checked(returned, exc, match):
    """A gate of yours that changes the estimate: its new P is checked (not blamed on R at the next update), its x
    (not blamed on the motion model), its dtype and the pair itself."""
    class Odd(Gate):
        def after_update(self, x, P, accepted, k):
            return returned(x, P)
    with pytest.raises(exc, match=match):
        _run(gate=Odd())


def test_a_composed_test_gate_returning_a_float_does_not_count_as_true():
    from uwtutor.filters import ReacquiringGate
    from uwtutor.filters.robust import RobustGate

    class Fuzzy(Gate):
        def accept(self, ctx):
            return np.full(ctx.y.shape[0], 0.3)
    with pytest.raises(TypeError, match=r"the gate Fuzzy\.accept must return bools"):
        _run(gate=ReacquiringGate(Fuzzy()))
    with pytest.raises(TypeError, match=r"the gate Fuzzy\.accept must return bools"):
        _run(gate=RobustGate(Fuzzy(), np.r_[0.0, np.ones(K - 1)]))


def test_a_squared_range_pair_whose_paths_disagree_on_the_runs_is_refused():
    """Per-run leader and displacement paths of different run counts: refused when the model is made (its n_runs
    read None, 'shared by every run', before)."""
    import numpy as np
    import pytest

    from uwtutor.models import SquaredRangePair

    K = 5
    with pytest.raises(ValueError, match="runs M: leader has 3, displacements has 4"):
        SquaredRangePair(np.zeros((3, K + 1, 2)), np.ones((4, K, 2)), 8.0, np.eye(10))
    assert SquaredRangePair(np.zeros((3, K + 1, 2)), np.ones((K, 2)), 8.0, np.eye(10)).n_runs == 3


# --- the reproducers of issue 37 (the contract finds each class; these pin the reported cases) -----------------------

def _pf(model, n=200, seed=0):
    from uwtutor.filters import BootstrapParticleFilter
    return BootstrapParticleFilter.from_gaussian(model, [0.0, 0.0], np.eye(2), n, np.random.default_rng(seed))


class _UserQ(DeadReckoning):
    """A user's motion model whose Q is returned by ``make_Q`` (complex, indefinite, non-symmetric, 3x3)."""

    def __init__(self, make_Q):
        super().__init__(np.eye(2))
        self._make_Q = make_Q

    def Q(self, x, u, k):
        return self._make_Q()


@pytest.mark.parametrize("make_Q, match", [
    (lambda: np.eye(2) * (1 + 1e-3j), "real numbers"),
    (lambda: np.diag([1.0, -1.0]), "not positive semi-definite"),
    (lambda: np.array([[1.0, 0.5], [0.0, 1.0]]), "not symmetric"),
    (lambda: np.eye(3), r"\(2, 2\) matrices"),
])
def test_particle_filters_check_a_user_models_q_as_the_ekf_does(make_Q, match):
    from uwtutor.models import ModelPair
    pf = _pf(ModelPair(_UserQ(make_Q), RangeToBeacon((100.0, 0.0), R=4.0)))
    with pytest.raises((ValueError, TypeError), match=match):
        pf.predict()


def test_particle_filter_checks_r_and_h_of_a_user_model():
    from uwtutor.models import ModelPair

    class BadR(RangeToBeacon):
        def R(self, x, k):
            return np.eye(2)                              # 2x2 for m = 1

    class ComplexH(RangeToBeacon):
        def h(self, x, k):
            return super().h(x, k) + 1e-3j
    for model, match in ((BadR((100.0, 0.0), R=4.0), r"must return shape \(1, 1\)"),
                         (ComplexH((100.0, 0.0), R=4.0), "real numbers")):
        pf = _pf(ModelPair(DeadReckoning(np.eye(2)), model))
        pf.predict()
        with pytest.raises((ValueError, TypeError), match=match):
            pf.update([100.0])


def test_a_measurement_far_outside_every_particle_warns_of_the_collapse():
    from uwtutor.filters import BootstrapParticleFilter, LinearGaussianModel, ParticleCollapseWarning
    pf = BootstrapParticleFilter.from_gaussian(LinearGaussianModel([[1]], [[1]], [[1e-6]], [[1e-6]]), [0.0], [[1.0]],
                                               1000, np.random.default_rng(0))
    pf.predict()
    with pytest.warns(ParticleCollapseWarning, match="collapsed onto one particle"):
        pf.update([1e6])
    assert pf.ess < 1.01


def test_assigned_configuration_takes_effect():
    from uwtutor.filters import KalmanFilter, RangeOnlyEKF
    ekf, fresh = (RangeOnlyEKF([100.0, 10.0], np.eye(2) * 100.0, Q, 4.0) for Q in (np.eye(2), np.eye(2) * 100.0))
    ekf.Q = 100 * np.eye(2)
    ekf.predict([0.0, 5.0])
    fresh.predict([0.0, 5.0])
    np.testing.assert_array_equal(ekf.P, fresh.P)                 # the packed Q was computed again
    with pytest.raises(AttributeError, match="read-only"):
        ekf.y = np.zeros(1)
    kf = KalmanFilter(F=[[1.0]], H=[[1.0]], Q=[[1.0]], R=[[1.0]], x0=[0.0], P0=[[1.0]])
    kf.R = [[100.0]]
    kf.predict()
    kf.update([10.0])
    assert kf.x[0] == pytest.approx(10.0 * 2.0 / 102.0)             # K = 2 / (2 + 100)
    with pytest.raises(ValueError, match="read-only"):
        kf.Q[0, 0] = 5.0


@pytest.mark.parametrize("call, match", [
    (lambda: or_vmlbl_kf(TRACK[1:], np.ones(K), ship_positions=TRACK[1:], depth=1000.0), "shorter than the vertical"),
    (lambda: robust_range_kf(Z[:, None]), r"a column"),
    (lambda: __import__("uwtutor.filters", fromlist=["x"]).bias_ekf([300.0, 0.0, 0.0], np.eye(3), U, Z[:, None],
                                                                    np.eye(3), 4.0), r"shape \(6,\) or \(M, 6\)"),
    (lambda: __import__("uwtutor.filters", fromlist=["x"]).bias_ekf([300.0, 0.0, 0.0], np.eye(3), None, Z,
                                                                    np.eye(3), 4.0), "does not move"),
    (lambda: __import__("uwtutor.filters", fromlist=["x"]).bias_ekf([1.5e303, 0.0, 0.0], np.eye(3), U, Z,
                                                                    np.eye(3), 4.0), "x0 must be at most"),
    (lambda: __import__("uwtutor.filters", fromlist=["x"]).ChiSquareGate().threshold(0), "m must be >= 1"),
    (lambda: __import__("uwtutor.filters", fromlist=["x"]).ChiSquareGate().threshold(2.5), "m must be an integer"),
    (lambda: line_of_sight(np.array([[np.nan, 1.0]]), np.zeros(2)), "positions must be finite"),
    (lambda: owtt.clock_error(1e300, 1e300, 1e300), "overflows"),
    (lambda: grey.fit_gm11([1e308] * 4), "overflows"),
    (lambda: __import__("uwtutor.datasets", fromlist=["x"]).square_log(range_scale=1e300), "range_scale"),
    (lambda: grey.gm11_forecast([1, 2, 3, 4], 10**8), "overflows"),
    (lambda: __import__("uwtutor.scenarios", fromlist=["x"]).circling_scenario(np.random.default_rng(0), interval=1e-4,
                                                                               duration=1e4), "duration / interval"),
    (lambda: __import__("uwtutor.filters", fromlist=["x"]).range_only_ekf([1.0, 0.0], np.eye(2), np.zeros((5, 2)),
                                                                         np.zeros((0, 5)), np.eye(2), 1.0), "no runs"),
    (lambda: linearized_lsq(np.zeros(0), np.zeros((0, 2)), [0.0, 0.0]), "ranges is empty"),
    (lambda: __import__("uwtutor.resampling", fromlist=["x"]).systematic_resample(np.zeros((0, 5)),
                                                                                  np.random.default_rng(0)), "no runs"),
    (lambda: __import__("uwtutor.filters", fromlist=["x"]).KalmanFilter.constant_velocity(
        dt=[1.0], q=0.1, r=1.0, x0=[0.0, 0.0], P0=np.eye(2)), r"write 1.0, not \[1.0\]"),
])
def test_issue_37_reproducers_get_a_clear_error(call, match):
    with pytest.raises((ValueError, TypeError), match=match):
        call()
