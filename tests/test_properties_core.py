"""Property tests of the library core: bad input gets a clear error or a valid answer, never a silent one.

Three families:

* **argument mutations** -- every public function of the core modules is called with valid arguments, then with
  one argument replaced by a hostile value (a string, a numeric string, complex, None, a list holding None, a
  bool, an object, NaN, infinity, 1e300, 10**400, an empty array, a ragged list, a wrong shape). Each call must
  raise a ``TypeError``/``ValueError`` whose message names the argument, or return an answer that is as finite
  as the valid call's answer (no new NaN or infinity). ``test_mutation_table_counts`` enumerates every mutation;
  the hypothesis tests below search combinations.
* **covariances** -- the range EKF, the fading EKF and the generic engine keep P symmetric positive
  semi-definite (or refuse the input with ``IllConditionedError``) for any P0 scale from 1e-6 to 1e150, any R
  from 1e-8 to 1e6 and tiny Q, and over 1e5 steps of accurate ranges.
* **checkers** -- hostile answers and hostile student functions get feedback (never a crash, never "correct"),
  within a time limit.

Every hypothesis test is derandomized with a bounded number of examples (reproducible, and a few seconds each).
"""

from __future__ import annotations

import sys
import time
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from uwtutor import _validate as v
from uwtutor import acoustics, metrics, motion, observability as ob, ranging
from uwtutor.errors import IllConditionedError, UwtutorWarning
from uwtutor.exercises.checks import check_array, check_function, check_number
from uwtutor.exercises.feedback import Feedback
from uwtutor.filters import ExtendedKalmanFilter, Gate, extended_kalman_filter, fading_ekf, range_only_ekf
from uwtutor.lsq import linearized_lsq
from uwtutor.models import DeadReckoning, LinearMeasurement, LinearMotion, RangeToBeacon

PROPS = settings(max_examples=60, deadline=None, derandomize=True, database=None,
                 suppress_health_check=[HealthCheck.too_slow])


class _NoFloat:
    def __float__(self):
        raise RuntimeError("no float")


# --- the hostile values -------------------------------------------------------------------------------------------

HOSTILE = {
    "string": "abc",
    "numeric string": "1.5",
    "complex": 1.0 + 2.0j,
    "complex array": np.array([1.0 + 0j, 2.0 + 0j]),
    "None": None,
    "list with None": [1.0, None],
    "bool": True,
    "bool array": np.array([True, False]),
    "object": object(),
    "no __float__": _NoFloat(),
    "nan": float("nan"),
    "inf": float("inf"),
    "-inf": -float("inf"),
    "1e300": 1e300,
    "10**400": 10**400,
    "empty": np.zeros(0),
    "0x0": np.zeros((0, 0)),
    "ragged": [[1.0, 2.0], [3.0]],
    "negative": -1.0,
    "wrong shape (K, 1)": np.ones((5, 1)),
    "dict": {"a": 1},
}


def _circle(K=5, M=None):
    theta = np.linspace(0.0, 1.0, K + 1)
    track = np.column_stack([300.0 * np.cos(theta), 300.0 * np.sin(theta)])
    u = np.diff(track, axis=0)
    z = np.linalg.norm(track[1:], axis=1) + 0.3
    if M:
        return track, np.tile(track[0], (M, 1)), np.tile(u, (M, 1, 1)), np.tile(z, (M, 1))
    return track, track[0] + [3.0, -2.0], u, z


_TRACK, _X0, _U, _Z = _circle()
_EST = _TRACK[1:] + 1.0
_COV = np.tile(np.eye(2) * 4.0, (5, 1, 1))
_BEACONS = np.array([[1000.0, 0.0], [0.0, 1000.0], [-1000.0, 0.0], [0.0, -1000.0]])
_RANGES = np.linalg.norm(np.array([30.0, -40.0]) - _BEACONS, axis=1) + 5.0

#: (label, function, valid keyword arguments): every public function of the core modules that takes numbers.
CALLS = [
    ("range_only_ekf", range_only_ekf, dict(x0=_X0, P0=np.eye(2) * 100.0, u=_U, z=_Z, Q=np.eye(2) * 0.1, R=1.0,
                                            beacon=(0.0, 0.0))),
    ("fading_ekf", fading_ekf, dict(x0=_X0, P0=np.eye(2) * 100.0, u=_U, z=_Z, Q=np.eye(2) * 0.1, R=1.0,
                                    mu_gamma=0.98, sigma_gamma=1e-3, rho=0.95, fading=True)),
    ("extended_kalman_filter", lambda x0, P0, u, z, Q, R: extended_kalman_filter(
        DeadReckoning(Q), RangeToBeacon((0.0, 0.0), R=R), x0, P0, u, z),
     dict(x0=_X0, P0=np.eye(2) * 100.0, u=_U, z=_Z, Q=np.eye(2) * 0.1, R=1.0)),
    ("ExtendedKalmanFilter", lambda x0, P0: ExtendedKalmanFilter(DeadReckoning(np.eye(2)),
                                                                  RangeToBeacon((0.0, 0.0), R=1.0), x0, P0),
     dict(x0=_X0, P0=np.eye(2))),
    ("DeadReckoning", DeadReckoning, dict(Q=np.eye(2))),
    ("RangeToBeacon", RangeToBeacon, dict(beacon=(0.0, 0.0), R=1.0)),
    ("LinearMotion", LinearMotion, dict(F=np.eye(2), Q=np.eye(2))),
    ("LinearMeasurement", LinearMeasurement, dict(H=[[1.0, 0.0]], R=[[1.0]])),
    ("metrics.nees", metrics.nees, dict(estimates=_EST, covariances=_COV, truth=_TRACK[1:])),
    ("metrics.nis", metrics.nis, dict(innovations=np.ones((5, 1)), innovation_cov=np.ones((5, 1, 1)))),
    ("metrics.rmse_over_time", metrics.rmse_over_time, dict(estimates=_EST, truth=_TRACK[1:])),
    ("metrics.estimation_errors", metrics.estimation_errors, dict(estimates=_EST, truth=_TRACK[1:])),
    ("metrics.final_errors", metrics.final_errors, dict(estimates=_EST, truth=_TRACK[1:])),
    ("metrics.error_cdf", metrics.error_cdf, dict(errors=[1.0, 2.0, 3.0])),
    ("metrics.chi2_mean_bounds", metrics.chi2_mean_bounds, dict(dof=2, n_runs=50, confidence=0.95)),
    ("ob.position_crlb", ob.position_crlb, dict(beacons=_BEACONS, position=[30.0, -40.0], sigma=1.0)),
    ("ob.fisher_information", ob.fisher_information, dict(beacons=_BEACONS, position=[30.0, -40.0], sigma=1.0)),
    ("ob.cramer_rao_bound", ob.cramer_rao_bound, dict(information=np.eye(2) * 2.0)),
    ("ob.rmse_bound", ob.rmse_bound, dict(covariance=np.eye(2) * 2.0)),
    ("ob.error_ellipse", ob.error_ellipse, dict(covariance=np.eye(2) * 2.0, center=(0.0, 0.0), scale=2.0)),
    ("ob.gdop", ob.gdop, dict(beacons=_BEACONS, position=[30.0, -40.0])),
    ("ob.range_jacobian", ob.range_jacobian, dict(position=[30.0, -40.0], beacons=_BEACONS)),
    ("linearized_lsq", linearized_lsq, dict(ranges=_RANGES, beacons=_BEACONS, provisional=[10.0, -30.0],
                                            iterations=3)),
    ("acoustics.sound_speed", acoustics.sound_speed, dict(temperature=10.0, salinity=35.0, depth=100.0)),
    ("acoustics.range_from_travel_time", acoustics.range_from_travel_time,
     dict(travel_time=1.0, sound_speed=1500.0, two_way=False)),
    ("acoustics.travel_time_from_range", acoustics.travel_time_from_range,
     dict(slant_range=1500.0, sound_speed=1500.0, two_way=True)),
    ("acoustics.range_factor", acoustics.range_factor, dict(assumed_speed=1500.0, true_speed=1470.0)),
    ("ranging.horizontal_range", ranging.horizontal_range, dict(positions=_TRACK, beacon=(0.0, 0.0))),
    ("ranging.slant_range", ranging.slant_range, dict(positions=_TRACK, beacon=(0.0, 0.0), depth_difference=50.0)),
    ("motion.straight_track", motion.straight_track, dict(times=np.arange(5.0), start=(0.0, 0.0), speed=2.0,
                                                          heading=0.3)),
    ("motion.circle_track", motion.circle_track, dict(times=np.arange(5.0), radius=300.0, speed=2.0)),
    ("metrics.average_over_runs", metrics.average_over_runs, dict(values=np.ones((3, 5)))),
    ("metrics.fraction_within", metrics.fraction_within, dict(values=np.ones(5), lower=0.0, upper=2.0)),
]

# Where a hostile value is a legitimate input, the function's answer must still be finite (checked), so these
# are not skipped; only documented meanings are exempt: NaN is "a missing range" in ``z``/``ranges``.
NAN_MEANS_MISSING = {"z"}


def _arrays(out):
    """Every float array in a result (dataclass fields, tuples, dicts, models' attributes are not searched)."""
    if isinstance(out, np.ndarray) and out.dtype.kind in "fc":
        yield out
    elif isinstance(out, float):
        yield np.asarray(out)
    elif isinstance(out, (tuple, list)):
        for item in out:
            yield from _arrays(item)
    elif isinstance(out, dict):
        for item in out.values():
            yield from _arrays(item)
    elif hasattr(out, "__dataclass_fields__"):
        for name in out.__dataclass_fields__:
            yield from _arrays(getattr(out, name))


def _nonfinite_count(out) -> int:
    return sum(int((~np.isfinite(a)).sum()) for a in _arrays(out))


def _call(label, func, kwargs, arg, value, baseline_nonfinite):
    """'clear' (a TypeError/ValueError naming ``arg``), 'valid' (no new NaN/inf), or a failure description."""
    bad = dict(kwargs)
    bad[arg] = value
    try:
        with np.errstate(all="raise"), warnings.catch_warnings():
            warnings.simplefilter("ignore", UwtutorWarning)     # e.g. Mackenzie's extrapolation warning
            out = func(**bad)
    except (TypeError, ValueError) as exc:
        if arg in str(exc):
            return "clear", None
        if any(other in str(exc) for other in kwargs):   # an agreement error naming the argument it disagrees with
            return "clear (names another argument)", None
        return "obscure", f"{label}({arg}={value!r:.40}): {type(exc).__name__}: {exc}"
    except Exception as exc:      # FloatingPointError, LinAlgError, AttributeError...: not a clear error
        return "obscure", f"{label}({arg}={value!r:.40}): {type(exc).__name__}: {exc}"
    allowed = baseline_nonfinite + (int(np.size(value)) if arg in NAN_MEANS_MISSING else 0)
    if _nonfinite_count(out) > allowed:
        return "silent", f"{label}({arg}={value!r:.40}) returned NaN/inf silently"
    return "valid", None


def _baseline(func, kwargs):
    with np.errstate(all="raise"):
        return _nonfinite_count(func(**kwargs))


COUNTS: dict[str, int] = {}


def test_mutation_table_counts():
    """Every (function, argument, hostile value) of the table: a clear error or a valid answer."""
    failures = []
    counts = {"cases": 0, "clear": 0, "clear (names another argument)": 0, "valid": 0, "obscure": 0, "silent": 0}
    for label, func, kwargs in CALLS:
        base = _baseline(func, kwargs)
        for arg in kwargs:
            for _label, value in HOSTILE.items():
                verdict, why = _call(label, func, kwargs, arg, value, base)
                counts["cases"] += 1
                counts[verdict] += 1
                if why:
                    failures.append(why)
    COUNTS.update(counts)
    print("\nmutation table:", counts)
    assert counts["cases"] > 1500
    assert not failures, "\n".join(failures[:40]) + f"\n... {len(failures)} in all"


# --- hypothesis: the validation layer itself ----------------------------------------------------------------------

_leaf = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**400, 10**400), st.none(),
                  st.booleans(), st.text(max_size=3), st.complex_numbers(max_magnitude=1e3))
_nested = st.recursive(_leaf, lambda inner: st.lists(inner, max_size=3), max_leaves=8)


@PROPS
@given(_nested)
def test_as_finite_accepts_only_real_finite_rectangular_numbers(value):
    try:
        arr = v.as_finite("value", value)
    except (TypeError, ValueError) as exc:
        assert str(exc).startswith("value")
        return
    assert arr.dtype == np.float64 and np.isfinite(arr).all()
    leaves = list(v._flat_items(value)) if isinstance(value, list) else [value]
    for leaf in leaves:     # nothing but real numbers got through
        assert isinstance(leaf, (int, float)) and not isinstance(leaf, bool)


@PROPS
@given(st.lists(st.floats(-1e3, 1e3), min_size=4, max_size=4), st.floats(-1.0, 1.0))
def test_as_covariance_accepts_exactly_symmetric_psd(values, skew):
    A = np.array(values).reshape(2, 2)
    P = A + A.T
    P[0, 1] += skew * 1e-3 * max(1.0, np.abs(P).max())
    try:
        out = v.as_covariance("P", P, 2, allow_singular=True)
    except ValueError as exc:
        assert str(exc).startswith("P must be")
        asym = abs(P[0, 1] - P[1, 0]) > v.SYMMETRY_RTOL * max(1.0, np.abs(P).max())
        assert asym or np.linalg.eigvalsh((P + P.T) / 2).min() < 0
        return
    assert np.allclose(out, out.T) and np.linalg.eigvalsh(out).min() >= -v.PSD_RTOL * max(1.0, np.abs(P).max())


@pytest.mark.parametrize("value", ["False", "True", 0, 1, None, "no", np.array([True])])
def test_flags_are_real_bools(value):
    with pytest.raises(TypeError, match="fading must be True or False"):
        v.as_flag("fading", value)
    with pytest.raises(TypeError, match="fading must be True or False"):
        fading_ekf(_X0, np.eye(2), _U, _Z, np.eye(2), 1.0, fading=value)


# --- covariances stay PSD or the input is refused -----------------------------------------------------------------

def _psd_ok(P: np.ndarray) -> bool:
    P = np.asarray(P)
    sym = np.array_equal(P, np.swapaxes(P, -1, -2))
    ev = np.linalg.eigvalsh(P)
    scale = np.maximum(1.0, np.abs(ev).max(axis=-1))
    return bool(sym and np.isfinite(P).all() and (ev[..., 0] >= -1e-12 * scale).all())


class _AcceptEvery(Gate):
    """A gate that accepts every range: the plain range pair then runs on the engine's generic arithmetic (without a
    gate it runs on the packed back-end, which range_only_ekf tests)."""

    def accept(self, ctx):
        return np.ones(ctx.y.shape[0], dtype=bool)


def _engine(x0, P0, u, z, Q, R):
    return extended_kalman_filter(DeadReckoning(Q), RangeToBeacon((0.0, 0.0), R=R), x0, P0, u, z,
                                  gate=_AcceptEvery())


FILTERS = {"range_only_ekf": range_only_ekf,
           "fading_ekf": lambda *a: fading_ekf(*a, sigma_gamma=1e-4),
           "engine": _engine}


@pytest.mark.parametrize("filt", list(FILTERS))
@PROPS
@given(p0_exp=st.integers(-6, 150), r_exp=st.integers(-8, 6), q_exp=st.integers(-14, 0))
def test_covariance_stays_psd_or_is_refused(filt, p0_exp, r_exp, q_exp):
    track, x0, u, z = _circle(K=40, M=2)
    try:
        res = FILTERS[filt](x0, np.eye(2) * 10.0**p0_exp, u, z, np.eye(2) * 10.0**q_exp, 10.0**r_exp)
    except IllConditionedError as exc:
        assert "P0" in str(exc) and "R" in str(exc)          # it says what to change
        return
    assert _psd_ok(res.P) and _psd_ok(res.P_prior)


def test_issue_cases_huge_p0_tiny_r():
    """P0 = 1e12 I with R = 1e-6, and P0 = 1e150 I: PSD (no negative variance) for the packed range filters; the
    generic engine (literal Joseph form) carries 1e12 and refuses 1e150 with an error that says what to change."""
    track, x0, u, z = _circle(K=200)
    with pytest.raises(IllConditionedError, match="smaller P0"):
        _engine(x0, np.eye(2) * 1e150, u, z, np.eye(2) * 1e-12, 1e-6)
    for P0 in (1e12, 1e150):
        for name, f in FILTERS.items():
            if name == "engine" and P0 > 1e12:
                continue
            res = f(x0, np.eye(2) * P0, u, z, np.eye(2) * 1e-12, 1e-6)
            assert _psd_ok(res.P), (name, P0)
            assert np.diagonal(res.P, axis1=-2, axis2=-1).min() > 0.0, (name, P0)
            np.testing.assert_allclose(res.x[-1], track[-1], atol=1.0)   # the ranges carry a 0.3 m bias


def test_long_runs_stay_psd():
    """1e5 steps of accurate ranges (sigma 1 mm), tiny Q, P0 = 1e8 I: the packed filters over 1e5 steps
    (2 runs), the generic engine over 2e4 steps x 5 runs (1e5 run-steps)."""
    def inputs(K, M, seed=0):
        rng = np.random.default_rng(seed)
        theta = np.linspace(0.0, 40 * np.pi, K + 1)
        track = np.column_stack([800.0 * np.cos(theta), 500.0 * np.sin(theta)])
        u = np.tile(np.diff(track, axis=0), (M, 1, 1))
        z = np.linalg.norm(track[1:], axis=1) + rng.normal(0.0, 1e-3, (M, K))
        return track, np.tile(track[0] + [50.0, -50.0], (M, 1)), u, z

    for name, K, M in (("range_only_ekf", 100_000, 2), ("fading_ekf", 100_000, 2), ("engine", 20_000, 5)):
        track, x0, u, z = inputs(K, M)
        res = FILTERS[name](x0, np.eye(2) * 1e8, u, z, np.eye(2) * 1e-12, 1e-6)
        assert _psd_ok(res.P[:, ::97]) and _psd_ok(res.P[:, -1]), name
        assert np.isfinite(res.x).all(), name
        assert np.abs(res.x[:, -1] - track[-1]).max() < 0.1, name


# --- metrics and bounds refuse what is not a covariance -----------------------------------------------------------

@PROPS
@given(st.lists(st.floats(-10.0, 10.0), min_size=3, max_size=3), st.sampled_from([1.0, -1.0]))
def test_nees_and_nis_refuse_non_covariances(abc, sign):
    a, b, d = abc
    P = np.array([[a, b], [b, d]]) * sign
    cov = np.tile(P, (4, 1, 1))
    est = np.zeros((4, 2))
    truth = np.ones((4, 2))
    pd = a * sign > 0 and a * d - b * b > 0          # the exact 2x2 test (Sylvester), in the same arithmetic
    for f in (lambda: metrics.nees(est, cov, truth), lambda: metrics.nis(np.ones((4, 2)), cov)):
        if pd:
            out = f()
            assert np.isfinite(out).all() and (out >= 0).all()
        else:
            with pytest.raises(ValueError, match="must be positive definite"):
                f()


@PROPS
@given(st.floats(1e-200, 1e200), st.floats(-1.0, 1.0))
def test_position_crlb_is_a_covariance_or_refused(sigma, offset):
    try:
        C = ob.position_crlb(_BEACONS, [30.0 + offset, -40.0], sigma)
    except ValueError as exc:
        assert "sigma" in str(exc)
        return
    assert _psd_ok(C) and (np.diag(C) > 0).all()


def test_truth_is_never_broadcast_but_over_runs():
    est = np.zeros((3, 5, 2))
    with pytest.raises(ValueError, match="truth must have shape"):
        metrics.rmse_over_time(est, np.zeros((5, 1)))
    assert metrics.rmse_over_time(est, np.zeros((5, 2))).shape == (5,)


# --- checkers: feedback, never a crash and never "correct", within a time limit ----------------------------------

_hostile_answers = st.one_of(
    st.complex_numbers(allow_nan=False, allow_infinity=False).filter(lambda c: c.imag != 0),
    st.lists(st.text(min_size=1, max_size=3), min_size=1, max_size=3),
    st.lists(st.one_of(st.none(), st.text(max_size=2)), min_size=1, max_size=3),
    st.integers(10**309, 10**400),
    st.lists(st.one_of(st.floats(allow_nan=False, allow_infinity=False),
                       st.lists(st.floats(allow_nan=False, allow_infinity=False), min_size=1, max_size=3)),
             min_size=1, max_size=3),                                    # ragged or nested lists of floats
    st.just(_NoFloat()), st.just([_NoFloat(), 1.0]), st.just(np.array([2.0 + 0j, 1.0 + 0j])),
    st.just(float("nan")), st.just(float("inf")),
)


@PROPS
@given(_hostile_answers)
def test_checkers_give_feedback_to_hostile_answers(answer):
    for fb in (check_number(answer, 2.0), check_array(answer, np.array([2.0, 1.0]))):
        assert isinstance(fb, Feedback) and fb.message
    # a flat list of floats may be right for check_array; nothing else here can be
    if not (isinstance(answer, list) and all(isinstance(x, float) for x in answer)):
        assert not check_array(answer, np.array([2.0, 1.0]))
    assert not check_number(answer, 2.0) or answer == 2.0


def _ref(x):
    return 2.0 * x


def _endless(x):
    while True:
        pass


def _stubborn(x):                    # swallows ordinary exceptions: the time limit is a BaseException
    while True:
        try:
            while True:
                pass
        except Exception:
            pass


def _exits(x):
    sys.exit(0)


class _SlowFloat:
    def __float__(self):
        while True:
            pass


@pytest.mark.parametrize("func, fragment", [
    (_endless, "still running"), (_stubborn, "still running"), (_exits, "sys.exit()"),
    (lambda x: _NoFloat(), "should be a number"), (lambda x: _SlowFloat(), "took more than"),
    (lambda x: np.array([2.0 * x + 0j]), "complex"), (lambda x: ["2"], "does not hold a number"),
    (lambda x: 10**400, "too large"), (lambda x: [[1.0], [2.0, 3.0]], "does not hold a number"),
])
def test_check_function_survives_hostile_students(func, fragment):
    start = time.process_time()
    fb = check_function(func, _ref, [(1.0,)], time_limit_s=0.5)
    assert not fb and fragment in fb.message
    assert time.process_time() - start < 5.0          # stopped: CPU time, whatever the machine's load
