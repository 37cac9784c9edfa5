"""Tests of uwtutor.acoustics: Mackenzie (1981) sound speed, travel time <-> range, effective sound speed."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from uwtutor.acoustics import (effective_sound_speed, range_from_travel_time, sound_speed,
                               sound_speed_error_range_bias, travel_time_from_range)

temperature = st.floats(2.0, 30.0)
salinity = st.floats(25.0, 40.0)
depth = st.floats(0.0, 8000.0)


# --- sound_speed -----------------------------------------------------------------------------------------------

def test_mackenzie_check_value():
    # Mackenzie (1981): T = 25 degC, S = 35, D = 1000 m -> 1550.744 m/s
    assert sound_speed(25.0, 35.0, 1000.0) == pytest.approx(1550.744, abs=5e-4)


def test_sound_speed_returns_float_for_scalars_and_broadcasts():
    assert isinstance(sound_speed(10, 35, 0), float)
    c = sound_speed(np.array([5.0, 10.0, 15.0])[:, None], 35.0, np.array([0.0, 500.0]))
    assert c.shape == (3, 2)
    assert c[1, 1] == pytest.approx(sound_speed(10.0, 35.0, 500.0))


def test_sound_speed_no_warning_inside_validity_range():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sound_speed([2.0, 30.0], [25.0, 40.0], [0.0, 8000.0])


@pytest.mark.parametrize("args, name", [((35.0, 35.0, 100.0), "temperature"), ((10.0, 20.0, 100.0), "salinity"),
                                        ((10.0, 35.0, 9000.0), "depth"), ((10.0, 35.0, -1.0), "depth")])
def test_sound_speed_warns_outside_validity_range(args, name):
    with pytest.warns(UserWarning, match=f"{name} outside the validity range"):
        c = sound_speed(*args)
    assert np.isfinite(c)


@pytest.mark.parametrize("args, name", [((np.nan, 35.0, 0.0), "temperature"), ((10.0, np.inf, 0.0), "salinity"),
                                        ((10.0, 35.0, [0.0, np.nan]), "depth")])
def test_sound_speed_rejects_non_finite(args, name):
    with pytest.raises(ValueError, match=name):
        sound_speed(*args)


def test_sound_speed_rejects_non_numeric_and_unbroadcastable():
    with pytest.raises(TypeError, match="temperature"):
        sound_speed("warm", 35.0, 0.0)
    with pytest.raises(ValueError, match="broadcast"):
        sound_speed([10.0, 11.0], 35.0, [0.0, 1.0, 2.0])


@given(temperature, temperature, salinity, depth)
@settings(deadline=None)
def test_sound_speed_increases_with_temperature(t1, t2, s, d):
    lo, hi = sorted((t1, t2))
    assert sound_speed(hi, s, d) >= sound_speed(lo, s, d) - 1e-9


@given(temperature, salinity, salinity, depth)
@settings(deadline=None)
def test_sound_speed_increases_with_salinity(t, s1, s2, d):
    lo, hi = sorted((s1, s2))
    assert sound_speed(t, hi, d) >= sound_speed(t, lo, d) - 1e-9


@given(temperature, salinity, depth, depth)
@settings(deadline=None)
def test_sound_speed_increases_with_depth(t, s, d1, d2):
    lo, hi = sorted((d1, d2))
    assert sound_speed(t, s, hi) >= sound_speed(t, s, lo) - 1e-9


@given(temperature, salinity, depth)
@settings(deadline=None)
def test_sound_speed_is_in_a_physical_range(t, s, d):
    assert 1400.0 < sound_speed(t, s, d) < 1700.0


# --- travel time <-> range -------------------------------------------------------------------------------------

def test_range_from_travel_time_one_and_two_way():
    assert range_from_travel_time(2.0, 1500.0) == 3000.0
    assert range_from_travel_time(2.0, 1500.0, two_way=True) == 1500.0
    assert travel_time_from_range(3000.0, 1500.0) == 2.0
    assert travel_time_from_range(1500.0, 1500.0, two_way=True) == 2.0
    r = range_from_travel_time([0.0, 1.0], [1500.0, 1480.0])
    np.testing.assert_allclose(r, [0.0, 1480.0])


@given(st.floats(0.0, 1e5), st.floats(1300.0, 1700.0), st.booleans())
@settings(deadline=None)
def test_travel_time_round_trip(r, c, two_way):
    tau = travel_time_from_range(r, c, two_way=two_way)
    assert range_from_travel_time(tau, c, two_way=two_way) == pytest.approx(r, rel=1e-12, abs=1e-9)


@given(st.floats(0.0, 100.0), st.floats(1300.0, 1700.0))
@settings(deadline=None)
def test_range_round_trip(tau, c):
    r = range_from_travel_time(tau, c)
    assert travel_time_from_range(r, c) == pytest.approx(tau, rel=1e-12, abs=1e-12)


@pytest.mark.parametrize("tau, c, name", [(-1.0, 1500.0, "travel_time"), (np.nan, 1500.0, "travel_time"),
                                          (1.0, 0.0, "sound_speed"), (1.0, -1500.0, "sound_speed"),
                                          (1.0, np.nan, "sound_speed")])
def test_range_from_travel_time_rejects_bad_input(tau, c, name):
    with pytest.raises(ValueError, match=name):
        range_from_travel_time(tau, c)


@pytest.mark.parametrize("r, c, name", [(-1.0, 1500.0, "slant_range"), (np.inf, 1500.0, "slant_range"),
                                        ([1.0, np.nan], 1500.0, "slant_range"), (1.0, -1.0, "sound_speed")])
def test_travel_time_from_range_rejects_bad_input(r, c, name):
    with pytest.raises(ValueError, match=name):
        travel_time_from_range(r, c)


# --- effective sound speed -------------------------------------------------------------------------------------

def test_effective_sound_speed_constant_profile():
    z = [0.0, 100.0, 2000.0]
    assert effective_sound_speed(z, [1490.0] * 3, 10.0, 1500.0) == pytest.approx(1490.0, rel=1e-14)


def test_effective_sound_speed_linear_profile_closed_form():
    # dz * g / ln(c2 / c1) with g = (c2 - c1) / dz
    c1, c2, dz = 1500.0, 1520.0, 1000.0
    g = (c2 - c1) / dz
    assert effective_sound_speed([0.0, dz], [c1, c2], 0.0, dz) == pytest.approx(dz * g / np.log(c2 / c1), rel=1e-13)
    # a partial path inside the layer: same formula with the speeds at its ends
    ca, cb = c1 + g * 200.0, c1 + g * 700.0
    assert effective_sound_speed([0.0, dz], [c1, c2], 700.0, 200.0) == pytest.approx(500.0 * g / np.log(cb / ca),
                                                                                    rel=1e-12)


@given(st.floats(1400.0, 1600.0), st.floats(1400.0, 1600.0), st.floats(10.0, 5000.0))
@settings(deadline=None)
def test_effective_sound_speed_linear_profile_property(c1, c2, dz):
    got = effective_sound_speed([0.0, dz], [c1, c2], 0.0, dz)
    # the closed form dz g / ln(c2/c1), written with log1p so that the reference itself is accurate for c2 ~ c1
    x = (c2 - c1) / c1
    expected = c1 if c1 == c2 else c1 * x / np.log1p(x)
    assert got == pytest.approx(expected, rel=1e-12)
    # and it lies between the end speeds (a mean)
    assert min(c1, c2) - 1e-9 <= got <= max(c1, c2) + 1e-9


def test_effective_sound_speed_equal_depths_returns_local_speed():
    z, c = [0.0, 100.0, 200.0], [1500.0, 1480.0, 1490.0]
    assert effective_sound_speed(z, c, 150.0, 150.0) == pytest.approx(1485.0)
    assert effective_sound_speed(z, c, 0.0, 0.0) == pytest.approx(1500.0)


def test_effective_sound_speed_is_symmetric_and_vectorized():
    z, c = [0.0, 50.0, 300.0, 1000.0], [1510.0, 1495.0, 1485.0, 1490.0]
    a = effective_sound_speed(z, c, [0.0, 100.0, 500.0], 900.0)
    b = effective_sound_speed(z, c, 900.0, [0.0, 100.0, 500.0])
    assert a.shape == (3,)
    np.testing.assert_allclose(a, b, rtol=1e-14)


def test_effective_sound_speed_matches_numerical_harmonic_mean():
    z, c = [0.0, 50.0, 300.0, 1000.0], [1510.0, 1495.0, 1485.0, 1490.0]
    zz = np.linspace(20.0, 800.0, 200001)
    slowness = 1.0 / np.interp(zz, z, c)
    integral = np.sum((slowness[1:] + slowness[:-1]) / 2 * np.diff(zz))
    assert effective_sound_speed(z, c, 20.0, 800.0) == pytest.approx((800.0 - 20.0) / integral, rel=1e-9)


def test_effective_sound_speed_single_point_profile():
    assert effective_sound_speed([100.0], [1500.0], 100.0, 100.0) == 1500.0


@pytest.mark.parametrize("z, c, z1, z2, name", [
    ([0.0, 100.0], [1500.0], 0.0, 50.0, "profile_speeds"),
    ([0.0, 100.0], [1500.0, -1.0], 0.0, 50.0, "profile_speeds"),
    ([0.0, np.nan], [1500.0, 1490.0], 0.0, 50.0, "profile_depths"),
    ([100.0, 0.0], [1500.0, 1490.0], 0.0, 50.0, "profile_depths"),
    ([[0.0, 100.0]], [1500.0, 1490.0], 0.0, 50.0, "profile_depths"),
    ([0.0, 100.0], [1500.0, 1490.0], -10.0, 50.0, "source_depth"),
    ([0.0, 100.0], [1500.0, 1490.0], 0.0, 150.0, "receiver_depth"),
    ([0.0, 100.0], [1500.0, 1490.0], np.nan, 50.0, "source_depth"),
    ([], [], 0.0, 0.0, "profile_depths"),
])
def test_effective_sound_speed_rejects_bad_input(z, c, z1, z2, name):
    with pytest.raises(ValueError, match=name):
        effective_sound_speed(z, c, z1, z2)


# --- sound-speed range bias ------------------------------------------------------------------------------------

def test_sound_speed_error_range_bias_paper_d_numbers():
    # 1470 m/s assumed for a true 1500 m/s: 2 % short
    assert sound_speed_error_range_bias(1000.0, 1470.0, 1500.0) == pytest.approx(-20.0)
    np.testing.assert_allclose(sound_speed_error_range_bias([0.0, 3000.0], 1470.0, 1500.0), [0.0, -60.0])


@given(st.floats(0.0, 1e4), st.floats(1300.0, 1700.0), st.floats(1300.0, 1700.0))
@settings(deadline=None)
def test_sound_speed_error_range_bias_is_the_conversion_error(r, ca, ct):
    measured = range_from_travel_time(travel_time_from_range(r, ct), ca)
    assert sound_speed_error_range_bias(r, ca, ct) == pytest.approx(measured - r, rel=1e-9, abs=1e-9)


@pytest.mark.parametrize("args, name", [((-1.0, 1470.0, 1500.0), "true_range"), ((1.0, 0.0, 1500.0), "assumed_speed"),
                                        ((1.0, 1470.0, np.nan), "true_speed")])
def test_sound_speed_error_range_bias_rejects_bad_input(args, name):
    with pytest.raises(ValueError, match=name):
        sound_speed_error_range_bias(*args)
