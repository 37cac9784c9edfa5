"""Tests of uwtutor.ranging: error models, their composition, range geometry and reception times."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from uwtutor.motion import straight_track
from uwtutor.ranging import (RangeErrorSum, GaussianNoise, Outliers, RangeErrorModel, SlowBias, SoundSpeedMismatch,
                             add_range_errors, horizontal_range, measure_ranges, reception_times, slant_range)

K = 50
TIMES = np.arange(float(K))
RANGES = np.linspace(500.0, 3000.0, K)

ALL_MODELS = [
    GaussianNoise(1.0),
    SoundSpeedMismatch(),
    SlowBias(2.0, 3.0, 20.0),
    Outliers((10.0,), 5, 80.0, two_sided=True, probability=0.05),
    GaussianNoise(0.5) + SlowBias(0.0, 1.0, 5.0) + Outliers((3.0,), 2, 50.0),
]


# --- the common contract ---------------------------------------------------------------------------------------

@pytest.mark.parametrize("model", ALL_MODELS, ids=lambda m: type(m).__name__)
def test_sample_shapes(model):
    rng = np.random.default_rng(0)
    assert model.sample(RANGES, TIMES, rng).shape == (K,)
    assert model.sample(RANGES, TIMES, rng, n_runs=7).shape == (7, K)
    batch = np.broadcast_to(RANGES, (4, K))
    assert model.sample(batch, TIMES, rng).shape == (4, K)
    assert model.sample(batch, TIMES, rng, n_runs=4).shape == (4, K)
    err, mask = model.sample_with_mask(RANGES, TIMES, rng, n_runs=3)
    assert err.shape == mask.shape == (3, K) and mask.dtype == bool


@pytest.mark.parametrize("model", ALL_MODELS, ids=lambda m: type(m).__name__)
def test_sample_reproducible_and_runs_independent(model):
    a = model.sample(RANGES, TIMES, np.random.default_rng(5), n_runs=3)
    b = model.sample(RANGES, TIMES, np.random.default_rng(5), n_runs=3)
    c = model.sample(RANGES, TIMES, np.random.default_rng(6), n_runs=3)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    assert not np.array_equal(a[0], a[1])
    # sample and sample_with_mask draw the same errors
    np.testing.assert_array_equal(a, model.sample_with_mask(RANGES, TIMES, np.random.default_rng(5), n_runs=3)[0])


@pytest.mark.parametrize("model", ALL_MODELS, ids=lambda m: type(m).__name__)
@pytest.mark.parametrize("ranges, times, rng, n_runs, exc, name", [
    (np.full(K, np.nan), TIMES, np.random.default_rng(0), None, ValueError, "true_ranges"),
    (-RANGES, TIMES, np.random.default_rng(0), None, ValueError, "true_ranges"),
    (np.full(K, np.inf), TIMES, np.random.default_rng(0), None, ValueError, "true_ranges"),
    (RANGES[:-1], TIMES, np.random.default_rng(0), None, ValueError, "true_ranges"),
    (np.zeros((2, 3, K)), TIMES, np.random.default_rng(0), None, ValueError, "true_ranges"),
    (RANGES, TIMES[::-1], np.random.default_rng(0), None, ValueError, "times"),
    (RANGES, TIMES[:, None], np.random.default_rng(0), None, ValueError, "times"),
    (RANGES, TIMES, 0, None, TypeError, "rng"),
    (RANGES, TIMES, np.random.default_rng(0), 0, ValueError, "n_runs"),
    (np.zeros((2, K)), TIMES, np.random.default_rng(0), 3, ValueError, "n_runs"),
])
def test_sample_rejects_bad_input(model, ranges, times, rng, n_runs, exc, name):
    with pytest.raises(exc, match=name):
        model.sample(ranges, times, rng, n_runs=n_runs)


def test_models_are_frozen():
    with pytest.raises(AttributeError):
        GaussianNoise(1.0).sigma = 2.0


# --- composition -----------------------------------------------------------------------------------------------

def test_composite_is_the_sum_of_its_parts():
    a, b, c = GaussianNoise(1.0), SoundSpeedMismatch(), SlowBias(1.0, 2.0, 10.0)
    total = a + b + c
    assert isinstance(total, RangeErrorSum) and total.parts == (a, b, c)   # flattened
    assert (a + (b + c)).parts == (a, b, c)
    assert sum([a, b, c]) == total
    # the same draws in the same order: sum of the parts' samples from one generator
    rng = np.random.default_rng(9)
    parts = [m.sample(RANGES, TIMES, rng, n_runs=2) for m in (a, b, c)]
    np.testing.assert_allclose(total.sample(RANGES, TIMES, np.random.default_rng(9), n_runs=2), sum(parts))


def test_composite_rejects_bad_parts():
    with pytest.raises(TypeError, match="parts"):
        RangeErrorSum((GaussianNoise(1.0), 3.0))
    with pytest.raises(ValueError, match="parts"):
        RangeErrorSum(())
    with pytest.raises(TypeError):
        GaussianNoise(1.0) + 1.0


def test_custom_model_subclass():
    class Constant(RangeErrorModel):
        def _draw(self, true_ranges, times, rng):
            return np.full(true_ranges.shape, 3.0), np.zeros(true_ranges.shape, dtype=bool)

    err = (Constant() + GaussianNoise(0.0)).sample(RANGES, TIMES, np.random.default_rng(0))
    np.testing.assert_array_equal(err, 3.0)


# --- GaussianNoise ---------------------------------------------------------------------------------------------

def test_gaussian_noise_statistics():
    e = GaussianNoise(0.7).sample(np.full(1000, 100.0), np.arange(1000.0), np.random.default_rng(1), n_runs=200)
    assert e.std() == pytest.approx(0.7, rel=0.01)
    assert abs(e.mean()) < 0.01
    np.testing.assert_array_equal(GaussianNoise(0.0).sample(RANGES, TIMES, np.random.default_rng(0)), 0.0)


@pytest.mark.parametrize("sigma", [-1.0, np.nan, np.inf, [1.0, 2.0]])
def test_gaussian_noise_rejects_bad_sigma(sigma):
    with pytest.raises(ValueError, match="sigma"):
        GaussianNoise(sigma)


# --- SoundSpeedMismatch -------------------------------------------------------------------------------------------

def test_sound_speed_error_mean_and_std_match_samples():
    model = SoundSpeedMismatch(true_speed=1500.0, assumed_speed=1470.0, speed_sigma=1.0)
    r = np.array([500.0, 2000.0])
    e = model.sample(r, [0.0, 1.0], np.random.default_rng(2), n_runs=200_000)
    # sample mean within 5 standard errors; sample std within 1 %
    se = model.error_std(r) / np.sqrt(200_000)
    np.testing.assert_array_less(np.abs(e.mean(axis=0) - model.mean_error(r)), 5 * se)
    np.testing.assert_allclose(e.std(axis=0), model.error_std(r), rtol=0.01)
    assert model.mean_error(1000.0) == pytest.approx(-20.0)
    assert model.error_std(1500.0) == pytest.approx(0.98)
    assert model.scale_error == pytest.approx(-0.02)


def test_sound_speed_error_without_scatter_is_a_scale_error():
    model = SoundSpeedMismatch(1500.0, 1515.0, 0.0)
    np.testing.assert_allclose(model.sample(RANGES, TIMES, np.random.default_rng(0)), 0.01 * RANGES)


def test_sound_speed_error_draws_one_speed_per_ping():
    e = SoundSpeedMismatch(1500.0, 1500.0, 5.0).sample(np.full(K, 1000.0), TIMES, np.random.default_rng(0))
    assert len(np.unique(e)) == K


@pytest.mark.parametrize("kwargs, name", [
    ({"true_speed": 0.0}, "true_speed"), ({"assumed_speed": -1.0}, "assumed_speed"),
    ({"speed_sigma": -1.0}, "speed_sigma"), ({"speed_sigma": 200.0}, "speed_sigma"),
    ({"true_speed": np.nan}, "true_speed"),
])
def test_sound_speed_error_rejects_bad_parameters(kwargs, name):
    with pytest.raises(ValueError, match=name):
        SoundSpeedMismatch(**kwargs)


def test_sound_speed_error_mean_rejects_negative_range():
    with pytest.raises(ValueError, match="true_range"):
        SoundSpeedMismatch().mean_error(-1.0)
    with pytest.raises(ValueError, match="true_range"):
        SoundSpeedMismatch().error_std(np.nan)


# --- SlowBias --------------------------------------------------------------------------------------------------

def test_slow_bias_stationary_std_and_autocorrelation():
    tau, sigma = 30.0, 3.0
    times = np.arange(0.0, 600.0, 2.0)
    e = SlowBias(5.0, sigma, tau).sample(np.full(len(times), 1000.0), times, np.random.default_rng(4), n_runs=4000)
    b = e - 5.0
    # stationary from the first epoch on
    np.testing.assert_allclose(b.std(axis=0)[[0, 100, -1]], sigma, rtol=0.05)
    assert b.mean() == pytest.approx(0.0, abs=0.1)
    for lag in (1, 5, 15, 30):
        rho = np.mean(b[:, :-lag] * b[:, lag:]) / sigma**2
        assert rho == pytest.approx(np.exp(-2.0 * lag / tau), abs=0.02)


def test_slow_bias_uneven_steps():
    times = np.array([0.0, 1.0, 50.0, 50.5])
    e = SlowBias(0.0, 1.0, 10.0).sample(np.ones(4), times, np.random.default_rng(0), n_runs=100_000)
    corr = np.corrcoef(e.T)
    np.testing.assert_allclose([corr[0, 1], corr[1, 2], corr[2, 3]], np.exp(-np.diff(times) / 10.0), atol=0.01)
    np.testing.assert_allclose(e.std(axis=0), 1.0, rtol=0.01)


def test_slow_bias_without_noise_is_the_mean():
    np.testing.assert_array_equal(SlowBias(4.0, 0.0, 10.0).sample(RANGES, TIMES, np.random.default_rng(0)), 4.0)


@pytest.mark.parametrize("args, name", [((np.nan, 1.0, 1.0), "mean"), ((0.0, -1.0, 1.0), "sigma"),
                                        ((0.0, 1.0, 0.0), "time_constant"), ((0.0, 1.0, np.inf), "time_constant")])
def test_slow_bias_rejects_bad_parameters(args, name):
    with pytest.raises(ValueError, match=name):
        SlowBias(*args)


# --- Outliers --------------------------------------------------------------------------------------------------

def test_outlier_patches_paper_e():
    times = np.arange(0.0, 1201.0)
    model = Outliers((300.0,), 10, 80.0) + Outliers((700.0,), 20, 80.0, two_sided=True)
    err, mask = model.sample_with_mask(np.full(len(times), 1500.0), times, np.random.default_rng(0), n_runs=50)
    expected = np.zeros(len(times), dtype=bool)
    expected[300:310] = expected[700:720] = True
    np.testing.assert_array_equal(mask, np.broadcast_to(expected, mask.shape))
    np.testing.assert_array_equal(err[:, 300:310], 80.0)
    assert set(np.unique(err[:, 700:720])) == {-80.0, 80.0}
    np.testing.assert_array_equal(err[:, ~expected], 0.0)


def test_outlier_patch_starts_at_first_epoch_after_onset_and_is_cut_at_the_end():
    times = np.array([0.0, 2.5, 5.0, 7.5, 10.0])
    mask = Outliers((3.0, 9.0), 2, 10.0).outlier_mask(times, np.random.default_rng(0))
    np.testing.assert_array_equal(mask, [False, False, True, True, True])
    assert not Outliers((20.0,), 3, 10.0).outlier_mask(times, np.random.default_rng(0)).any()


def test_isolated_outliers_rate_and_mask_consistency():
    model = Outliers((), 1, 50.0, two_sided=True, probability=0.1)
    ranges = np.full(2000, 1000.0)
    times = np.arange(2000.0)
    err, mask = model.sample_with_mask(ranges, times, np.random.default_rng(8), n_runs=20)
    assert mask.mean() == pytest.approx(0.1, abs=0.01)
    np.testing.assert_array_equal(err != 0, mask)
    assert np.mean(err[mask] > 0) == pytest.approx(0.5, abs=0.03)
    # outlier_mask makes the same draws as sample_with_mask
    np.testing.assert_array_equal(model.outlier_mask(times, np.random.default_rng(8), n_runs=20), mask)
    # and so does a composite: the mask is the union of the parts'
    comp = GaussianNoise(1.0) + model
    err2, mask2 = comp.sample_with_mask(ranges, times, np.random.default_rng(8), n_runs=20)
    assert mask2.mean() == pytest.approx(0.1, abs=0.01)
    assert np.all(np.abs(err2[mask2]) > 30.0)


def test_outliers_accept_scalar_onset():
    assert Outliers(300.0, 10, 80.0).onset_times == (300.0,)


@pytest.mark.parametrize("args, kwargs, exc, name", [
    (((np.nan,), 1, 1.0), {}, ValueError, "onset_times"),
    (((1.0,), 0, 1.0), {}, ValueError, "count"),
    (((1.0,), 2.5, 1.0), {}, TypeError, "count"),
    (((1.0,), 1, -1.0), {}, ValueError, "amplitude"),
    (((1.0,), 1, 1.0), {"probability": 1.5}, ValueError, "probability"),
    (((1.0,), 1, 1.0), {"probability": np.nan}, ValueError, "probability"),
])
def test_outliers_reject_bad_parameters(args, kwargs, exc, name):
    with pytest.raises(exc, match=name):
        Outliers(*args, **kwargs)


def test_outlier_mask_rejects_bad_input():
    with pytest.raises(ValueError, match="times"):
        Outliers((1.0,), 1, 1.0).outlier_mask([0.0, np.nan], np.random.default_rng(0))
    with pytest.raises(TypeError, match="rng"):
        Outliers((1.0,), 1, 1.0).outlier_mask([0.0, 1.0], 1)


# --- measure_ranges --------------------------------------------------------------------------------------------

def test_measure_ranges_adds_the_errors():
    model = GaussianNoise(1.0) + SoundSpeedMismatch()
    measured = measure_ranges(RANGES, TIMES, model, np.random.default_rng(3), n_runs=5)
    np.testing.assert_allclose(measured - RANGES, model.sample(RANGES, TIMES, np.random.default_rng(3), n_runs=5))
    np.testing.assert_array_equal(measure_ranges(RANGES, TIMES, None, np.random.default_rng(0)), RANGES)


def test_measure_ranges_reads_a_negative_sum_as_its_magnitude():
    # issue 27: one policy for every measured range of the library -- |true range + error|, never negative
    model = Outliers((0.0,), 5, 50.0, two_sided=True)
    measured, errors, hit = measure_ranges(np.full(5, 10.0), np.arange(5.0), model, np.random.default_rng(0),
                                           n_runs=10, return_errors=True)
    drawn, mask = model.sample_with_mask(np.full(5, 10.0), np.arange(5.0), np.random.default_rng(0), n_runs=10)
    np.testing.assert_array_equal(errors, drawn)
    np.testing.assert_array_equal(hit, mask)
    assert (drawn < -10.0).any() and measured.min() == pytest.approx(40.0)
    np.testing.assert_array_equal(measured, np.abs(10.0 + drawn))
    # the same draws as without return_errors
    np.testing.assert_array_equal(measure_ranges(np.full(5, 10.0), np.arange(5.0), model,
                                                 np.random.default_rng(0), n_runs=10), measured)


def test_add_range_errors_applies_the_same_policy_in_the_order_given():
    true = np.array([100.0, 20.0, 5.0])
    clock = np.array([0.1, 0.2, 0.3])
    noise = np.array([[1.5, np.nan, -8.0], [-0.5, 2.0, 1.0]])
    r = add_range_errors(true, clock, noise)
    np.testing.assert_array_equal(r, np.abs(true + clock + noise))
    assert np.isnan(r[0, 1]) and r[0, 2] == pytest.approx(2.7)


@pytest.mark.parametrize("args, exc, name", [
    (([1.0, -2.0], [0.0, 0.0]), ValueError, "true_ranges"),
    (([1.0, 2.0], [0.0, np.inf]), ValueError, "errors"),
    (([1.0, 2.0], [0.0, 0.0, 0.0]), ValueError, "errors"),
    (([1.0, 2.0], [[0.0], [0.0]]), ValueError, "errors"),
    (([1.0, 2.0], [0.0, 0.0], "abc"), TypeError, r"errors\[1\]"),
    (([1.0, 2.0],), TypeError, "at least one"),
])
def test_add_range_errors_names_bad_input(args, exc, name):
    with pytest.raises(exc, match=name):
        add_range_errors(*args)


@pytest.mark.parametrize("ranges, error, name, exc", [
    (np.full(K, np.nan), None, "true_ranges", ValueError),
    (RANGES, "gaussian", "error", TypeError),
    (RANGES[:3], GaussianNoise(1.0), "true_ranges", ValueError),
])
def test_measure_ranges_rejects_bad_input(ranges, error, name, exc):
    with pytest.raises(exc, match=name):
        measure_ranges(ranges, TIMES, error, np.random.default_rng(0))


# --- geometry --------------------------------------------------------------------------------------------------

def test_horizontal_and_slant_range():
    p = np.array([[3.0, 4.0], [0.0, 0.0], [-6.0, 8.0]])
    np.testing.assert_allclose(horizontal_range(p, (0.0, 0.0)), [5.0, 0.0, 10.0])
    assert horizontal_range((4.0, 5.0), (1.0, 1.0)) == 5.0
    batch = np.broadcast_to(p, (2, 3, 2))
    moving = np.array([[0.0, 0.0], [0.0, 1.0], [-6.0, 0.0]])
    np.testing.assert_allclose(horizontal_range(batch, moving), [[5.0, 1.0, 8.0]] * 2)
    np.testing.assert_allclose(slant_range(p, (0.0, 0.0), 12.0), [13.0, 12.0, np.hypot(10.0, 12.0)])
    np.testing.assert_allclose(slant_range(p, (0.0, 0.0), [0.0, 1.0, 0.0]), [5.0, 1.0, 10.0])


@pytest.mark.parametrize("call, name", [
    (lambda: horizontal_range(np.zeros((3, 3)), (0.0, 0.0)), "positions"),
    (lambda: horizontal_range(np.zeros((3, 2)), (0.0, np.nan)), "beacon"),
    (lambda: horizontal_range(np.zeros((3, 2)), np.zeros((4, 2))), "beacon"),
    (lambda: horizontal_range(5.0, (0.0, 0.0)), "positions"),
    (lambda: slant_range(np.zeros((3, 2)), (0.0, 0.0), np.nan), "depth_difference"),
    (lambda: slant_range(np.zeros((3, 2)), (0.0, 0.0), [1.0, 2.0]), "depth_difference"),
])
def test_range_geometry_rejects_bad_input(call, name):
    with pytest.raises(ValueError, match=name):
        call()


# --- reception times -------------------------------------------------------------------------------------------

@given(st.floats(300.0, 10_000.0), st.floats(-10.0, 10.0), st.floats(1400.0, 1600.0))
@settings(max_examples=50, deadline=None)
def test_reception_time_radial_closed_form(x0, v, c):
    # vehicle on the x axis moving radially at v (away from the beacon at the origin if v > 0): x(t) = x0 + v t,
    # so x0 + v t_r = c (t_r - t_p) gives t_r - t_p = x(t_p) / (c - v)
    vehicle = lambda t: np.stack([x0 + v * t, np.zeros_like(t)], axis=-1)   # noqa: E731
    tp = np.array([0.0, 10.0, 20.0])
    t_r, r = reception_times(tp, (0.0, 0.0), vehicle, c)
    expected = (x0 + v * tp) / (c - v)
    np.testing.assert_allclose(t_r - tp, expected, rtol=1e-9)
    np.testing.assert_allclose(r, c * expected, rtol=1e-9)


def test_reception_times_with_tracks_and_moving_beacon():
    times = np.arange(0.0, 200.0, 1.0)
    ship = straight_track(times, (0.0, 0.0), 3.0, 0.0)
    auv = straight_track(times, (1000.0, 500.0), 1.5, 2.0)
    t_r, r = reception_times(np.arange(0.0, 150.0, 10.0), ship.position_at, auv.position_at, 1490.0)
    gap = np.hypot(*(auv.position_at(t_r) - ship.position_at(np.arange(0.0, 150.0, 10.0))).T)
    np.testing.assert_allclose(gap, r, rtol=1e-10)
    assert np.all(t_r > np.arange(0.0, 150.0, 10.0))


def test_reception_times_rejects_bad_input():
    vehicle = lambda t: np.stack([1000.0 + t, 0.0 * t], axis=-1)   # noqa: E731
    with pytest.raises(ValueError, match="ping_times"):
        reception_times([0.0, np.nan], (0.0, 0.0), vehicle, 1500.0)
    with pytest.raises(ValueError, match="sound_speed"):
        reception_times([0.0], (0.0, 0.0), vehicle, -1500.0)
    with pytest.raises(ValueError, match="beacon_position_at"):
        reception_times([0.0], (0.0, 0.0, 0.0), vehicle, 1500.0)
    with pytest.raises(ValueError, match="vehicle_position_at"):
        reception_times([0.0], (0.0, 0.0), lambda t: np.zeros(np.shape(t) + (3,)), 1500.0)
    with pytest.raises(ValueError, match="tol"):
        reception_times([0.0], (0.0, 0.0), vehicle, 1500.0, tol=0.0)
    with pytest.raises(ValueError, match="max_iter"):
        reception_times([0.0], (0.0, 0.0), vehicle, 1500.0, max_iter=0)


def test_reception_times_reports_non_convergence():
    fast = lambda t: np.stack([1000.0 + 1499.0 * t, 0.0 * t], axis=-1)   # noqa: E731
    with pytest.raises(RuntimeError, match="converge"):
        reception_times([0.0], (0.0, 0.0), fast, 1500.0, max_iter=5)
