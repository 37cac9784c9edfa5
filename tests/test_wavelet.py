"""Wavelet (MAD) noise estimation (uwtutor.wavelet): vanishing moments, PyWavelets agreement, accuracy, bad input."""

from __future__ import annotations

import numpy as np
import pytest
import pywt

from uwtutor import wavelet


def random_polynomial(degree, n=50, seed=0):
    rng = np.random.default_rng(seed)
    t = np.linspace(-1.0, 1.0, n)
    return np.polynomial.polynomial.polyval(t, rng.normal(size=degree + 1) * 5.0)


@pytest.mark.parametrize("degree", range(6))
def test_db6_removes_every_polynomial_up_to_degree_5(degree):
    p = random_polynomial(degree, seed=degree)
    d = wavelet.detail_coefficients(p, "db6")
    assert np.abs(d).max() < 1e-11 * max(1.0, np.abs(p).max())


def test_db6_does_not_remove_degree_6_and_fewer_moments_do_not_remove_degree_5():
    k = np.arange(50.0)
    # a degree-6 polynomial in the sample index leaves a constant detail: 6! c6 times the 6th moment of the filter
    d6 = wavelet.detail_coefficients(1e-6 * k**6, "db6")
    g = np.asarray(pywt.Wavelet("db6").dec_hi)
    moment6 = np.sum(g * np.arange(12.0) ** 6)
    np.testing.assert_allclose(d6, 1e-6 * moment6, rtol=1e-6)
    assert abs(moment6) > 100
    assert np.abs(wavelet.detail_coefficients(1e-4 * k**5, "db5")).min() > 1e-3
    assert pywt.Wavelet("db6").vanishing_moments_psi == 6


@pytest.mark.parametrize("name", ["db6", "haar", "db2", "sym5", "coif1", "bior2.2"])
def test_valid_coefficients_are_the_interior_of_pywt(name):
    x = np.random.default_rng(1).normal(size=61)
    d = wavelet.detail_coefficients(x, name)
    L = pywt.Wavelet(name).dec_len
    full = pywt.dwt(x, name, mode="zero")[1]                 # c[2i+1] of the full convolution
    first = (L - 1) // 2                                     # first coefficient with the whole filter inside
    assert d.size == (x.size - L) // 2 + 1
    np.testing.assert_allclose(d, full[first:first + d.size], atol=1e-12)


def test_other_modes_are_pywt():
    x = np.random.default_rng(2).normal(size=(3, 50))
    np.testing.assert_allclose(wavelet.detail_coefficients(x, "db6", mode="symmetric"),
                               pywt.dwt(x, "db6", mode="symmetric", axis=-1)[1])
    assert wavelet.detail_coefficients(x[0]).shape == (20,)                    # 50 samples, db6: 20 inside


def test_accuracy_on_noise_over_a_polynomial_trend():
    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 1.0, 50)
    trend = 10.0 + 4.0 * t - 3.0 * t**2 + 6.0 * t**5              # a degree-5 trend, large against the noise
    for sigma in (0.05, 0.3, 2.0):
        windows = trend + rng.normal(0.0, sigma, (4000, 50))
        est = wavelet.noise_sigma(windows)
        assert est.shape == (4000,)
        # unbiased to a few percent (the median of 20 |N| has a small-sample bias of about 1.5 %) ...
        assert est.mean() == pytest.approx(sigma, rel=0.03)
        # ... with the spread of a median of 20 coefficients (about 1.17 / sqrt(20) = 0.26)
        assert est.std() / sigma == pytest.approx(0.26, abs=0.04)
    # a long record: very accurate
    tt = np.linspace(-1.0, 1.0, 20000)
    long = 100.0 * tt**3 + rng.normal(0.0, 0.2, tt.size)
    assert wavelet.noise_sigma(long) == pytest.approx(0.2, rel=0.02)


def test_symmetric_extension_is_biased_and_valid_is_not():
    rng = np.random.default_rng(4)
    windows = 10.0 + 0.05 * np.arange(50) + rng.normal(0.0, 0.2, (4000, 50))
    assert wavelet.noise_sigma(windows).mean() == pytest.approx(0.2, rel=0.03)
    assert wavelet.noise_sigma(windows, mode="zero").mean() > 0.25                # edges add invented signal


def test_sliding_estimate_equals_the_estimate_of_each_window():
    rng = np.random.default_rng(5)
    x = rng.normal(size=(2, 3, 300))
    for window in (50, 51, 12):
        s = wavelet.sliding_noise_sigma(x, window)
        assert s.shape == x.shape
        assert np.isnan(s[..., :window - 1]).all()
        for k in (window - 1, 150, 299):
            np.testing.assert_allclose(s[..., k], wavelet.noise_sigma(x[..., k - window + 1:k + 1]), rtol=1e-12)
    s = wavelet.sliding_noise_sigma(x[0, 0], 50, mode="symmetric")
    assert s[120] == pytest.approx(wavelet.noise_sigma(x[0, 0, 71:121], mode="symmetric"))


def test_sliding_estimate_tracks_a_change_and_handles_missing_samples():
    rng = np.random.default_rng(6)
    k = np.arange(3000)
    sd = np.where(k < 1500, 0.1, 0.4)
    x = np.sin(k / 80.0) + rng.normal(0.0, sd)
    s = wavelet.sliding_noise_sigma(x, 50)
    assert np.mean(s[100:1500]) == pytest.approx(0.1, rel=0.05)
    assert np.mean(s[1549:]) == pytest.approx(0.4, rel=0.05)
    x[700] = np.nan
    s = wavelet.sliding_noise_sigma(x, 50)
    assert np.isnan(s[700:750]).all() and np.isfinite(s[699]) and np.isfinite(s[750])
    assert np.isnan(wavelet.sliding_noise_sigma(x[:30], 50)).all()              # shorter than one window


def test_bad_input():
    with pytest.raises(ValueError, match="wavelet must be the name of a discrete wavelet"):
        wavelet.noise_sigma(np.zeros(50), "db99x")
    with pytest.raises(ValueError, match="mode must be 'valid' or a PyWavelets"):
        wavelet.noise_sigma(np.zeros(50), mode="mirror")
    with pytest.raises(ValueError, match="at least 12 samples"):
        wavelet.noise_sigma(np.zeros(11))
    with pytest.raises(ValueError, match="signal must be finite"):
        wavelet.noise_sigma([np.nan] * 20)
    with pytest.raises(ValueError, match="window must be >= 12"):
        wavelet.sliding_noise_sigma(np.zeros(100), window=10)
    with pytest.raises(ValueError, match="finite, or NaN"):
        wavelet.sliding_noise_sigma(np.full(100, np.inf))
    with pytest.raises(ValueError, match="got a scalar"):
        wavelet.sliding_noise_sigma(1.0)


def test_mad_sigma_is_the_median_absolute_coefficient_over_0_6745():
    rng = np.random.default_rng(3)
    for shape in ((20,), (3, 20), (4, 2, 21)):
        d = rng.normal(size=shape)
        np.testing.assert_array_equal(wavelet.mad_sigma(d), np.median(np.abs(d), axis=-1) / wavelet.MAD_TO_SIGMA)
    d = rng.normal(size=(7, 5))
    np.testing.assert_array_equal(wavelet.mad_sigma(d, axis=0), np.median(np.abs(d), axis=0) / wavelet.MAD_TO_SIGMA)
    # noise_sigma is mad_sigma of the valid detail coefficients
    x = rng.normal(0.0, 0.3, (5, 50))
    np.testing.assert_array_equal(wavelet.noise_sigma(x), wavelet.mad_sigma(wavelet.detail_coefficients(x)))
    with pytest.raises(ValueError, match="coefficients must be finite"):
        wavelet.mad_sigma([1.0, np.nan])
    with pytest.raises(ValueError, match="at least one coefficient"):
        wavelet.mad_sigma(np.zeros((3, 0)))


@pytest.mark.parametrize("name", ["db6", "haar", "sym4", "db3"])
def test_detail_matrix_is_the_valid_dwt_as_a_matrix(name):
    x = np.random.default_rng(4).normal(size=(6, 40))
    D = wavelet.detail_matrix(40, name)
    np.testing.assert_allclose(x @ D, wavelet.detail_coefficients(x, name), rtol=0, atol=1e-12)
    assert wavelet.as_wavelet(name).name == name
    with pytest.raises(ValueError, match="n_samples must be >="):
        wavelet.detail_matrix(wavelet.as_wavelet(name).dec_len - 1, name)
    with pytest.raises(ValueError, match="wavelet must be the name"):
        wavelet.as_wavelet("nope")
