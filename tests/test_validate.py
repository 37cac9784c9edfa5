"""The shared input checks: each names the argument and says what to do."""

import numpy as np
import pytest
from hypothesis import given, strategies as st
from hypothesis.extra.numpy import arrays

from uwtutor import _validate as v


def test_finite_reports_the_first_bad_index():
    with pytest.raises(ValueError, match=r"ranges must be finite; got nan at index 2"):
        v.as_finite("ranges", [1.0, 2.0, np.nan, np.inf])


def test_positive_and_nonnegative():
    with pytest.raises(ValueError, match=r"sound_speed must be > 0; got -1500.0"):
        v.as_positive("sound_speed", -1500.0)
    with pytest.raises(ValueError, match=r"sigma must be >= 0"):
        v.as_nonnegative("sigma", [0.0, -0.1])
    assert v.as_nonnegative("sigma", 0.0) == 0.0


def test_range_array_allows_nan_only_when_asked():
    with pytest.raises(ValueError, match="ranges must be finite and >= 0; got nan at index 1"):
        v.as_range_array("ranges", [1.0, np.nan])
    out = v.as_range_array("ranges", [1.0, np.nan], allow_nan=True)
    assert np.isnan(out[1])
    with pytest.raises(ValueError, match="use NaN for a missing range; got -3.0 at index 0"):
        v.as_range_array("ranges", [-3.0, 1.0], allow_nan=True)
    with pytest.raises(ValueError, match="got inf"):
        v.as_range_array("ranges", [np.inf], allow_nan=True)


def test_shapes():
    with pytest.raises(ValueError, match=r"positions must have shape \(any, 2\); got \(3, 3\)"):
        v.as_float_array("positions", np.zeros((3, 3)), shape=(None, 2))
    with pytest.raises(ValueError, match=r"times must have 1 dimension"):
        v.as_float_array("times", np.zeros((2, 2)), ndim=1)
    with pytest.raises(TypeError, match="times must be numeric"):
        v.as_float_array("times", "soon")
    with pytest.raises(ValueError, match="same length.*times has 3, ranges has 2"):
        v.check_same_length(times=np.zeros(3), ranges=np.zeros(2))


def test_common_runs_agrees_or_names_every_runs_axis():
    # no input has a runs axis: no runs axis in the answer either
    assert v.common_runs({}) is None
    assert v.common_runs({"x0": None, "z": None}) is None
    # the inputs without one are shared by every run; those with one must agree
    assert v.common_runs({"x0": None, "P0": 5, "z": 5}) == 5
    with pytest.raises(ValueError, match="disagree on the number of runs M: x0 has 3, z has 4$"):
        v.common_runs({"x0": 3, "u": None, "z": 4})
    # a runs axis of length 1 is a run of its own unless it may broadcast
    with pytest.raises(ValueError, match="P0 has 1, z has 4"):
        v.common_runs({"P0": 1, "z": 4})
    assert v.common_runs({"P0": 1, "z": 4, "sigma": 1}, broadcast_one=True) == 4
    assert v.common_runs({"P0": 1, "sigma": 1}, broadcast_one=True) == 1
    with pytest.raises(ValueError, match="positions has 2, beacon has 1, P0 has 3"):
        v.common_runs({"positions": 2, "beacon": 1, "P0": 3}, broadcast_one=True)


def test_covariance_checks():
    assert v.as_covariance("R", 4.0, 1).shape == (1, 1)
    with pytest.raises(ValueError, match="P must be a square matrix"):
        v.as_covariance("P", np.zeros((2, 3)))
    with pytest.raises(ValueError, match="Q must be 3x3 to match the state"):
        v.as_covariance("Q", np.eye(2), 3)
    with pytest.raises(ValueError, match="P must be positive definite; its smallest eigenvalue"):
        v.as_covariance("P", [[1.0, 0.0], [0.0, 0.0]])
    v.as_covariance("Q", [[1.0, 0.0], [0.0, 0.0]], allow_singular=True)   # semi-definite is fine for Q


def test_rng_and_int():
    with pytest.raises(TypeError, match="rng must be a numpy.random.Generator"):
        v.as_rng(np.random.RandomState(0))
    with pytest.raises(TypeError, match="n_runs must be an integer"):
        v.as_int("n_runs", 2.5)
    with pytest.raises(ValueError, match="n_runs must be >= 1"):
        v.as_int("n_runs", 0, minimum=1)
    assert v.as_int("n_runs", np.int64(3)) == 3


@given(arrays(float, st.integers(1, 6), elements=st.floats(allow_nan=True, allow_infinity=True)))
def test_as_finite_accepts_exactly_the_finite_arrays(a):
    if np.isfinite(a).all():
        np.testing.assert_array_equal(v.as_finite("a", a), a)
    else:
        with pytest.raises(ValueError, match="a must be finite"):
            v.as_finite("a", a)


@given(st.lists(st.floats(-3, 3), min_size=4, max_size=4))
def test_gram_matrices_are_accepted_as_covariances(values):
    A = np.array(values).reshape(2, 2)
    P = A @ A.T + 1e-3 * np.eye(2)
    np.testing.assert_array_equal(v.as_covariance("P", P, 2), P)


@pytest.mark.parametrize("layout", ["C", "F", "strided"])
def test_large_arrays_get_the_same_answers_as_small_ones(layout):
    """Arrays of more than 1000 elements are first tested in one quick pass (blocks' minima and maxima); a bad
    element anywhere, in the last block too, still gets the full check and its message."""
    base = np.random.default_rng(0).uniform(0.0, 100.0, (300, 400))
    for where in ((0, 0), (150, 7), (299, 399)):
        for bad, message in ((np.nan, "must be finite; got nan"), (np.inf, "must be finite; got inf"),
                             (-np.inf, "must be finite; got -inf"), (2e150, "at most 1e\\+150 in magnitude"),
                             (-2e150, "at most 1e\\+150 in magnitude")):
            a = base.copy()
            a[where] = bad
            a = {"C": a, "F": np.asfortranarray(a), "strided": np.repeat(a, 2, axis=1)[:, ::2]}[layout]
            with pytest.raises(ValueError, match=message):
                v.as_finite("u", a, max_abs=1e150)
        for bad, message in ((np.inf, "finite and >= 0; use NaN"), (-1.0, "finite and >= 0; use NaN"),
                             (-np.inf, "finite and >= 0; use NaN"), (2e150, "at most 1e\\+150")):
            a = base.copy()
            a[where] = bad
            with pytest.raises(ValueError, match=message):
                v.as_range_array("z", a, allow_nan=True, max_abs=1e150)
        a = base.copy()
        a[where] = np.nan
        assert v.as_range_array("z", a, allow_nan=True) is a                     # NaN: a missing range
        with pytest.raises(ValueError, match="z must be finite and >= 0; got nan"):
            v.as_range_array("z", a)
    assert v.as_finite("u", base, max_abs=1e150) is base and v.as_range_array("z", base) is base
    assert v.as_range_array("z", np.full(2000, np.nan), allow_nan=True).shape == (2000,)   # all missing
    with pytest.raises(ValueError, match="must be finite"):
        v.as_finite("u", np.full(2000, np.nan))


@pytest.mark.parametrize("value", ["a" * 50, b"a" * 50])
def test_a_long_string_is_named_cut_short(value):
    """A long str or bytes is refused with its first 37 characters (bytes were cut with a str suffix: a TypeError
    inside the message itself)."""
    with pytest.raises(TypeError, match=r"x must be numeric .* got the string b?'a{37}\.\.\.'"):
        v.as_finite("x", value)
