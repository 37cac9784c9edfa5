"""The checkers of chapter 6's exercises: right answers pass, each recognised mistake gets its own hint."""

from __future__ import annotations

import math

import numpy as np
import pytest
import pywt

from uwtutor import grey, wavelet
from uwtutor.exercises import ch06


def text(fb):
    return f"{fb.message}\n{fb.hint or ''}"


# -- the right answers, computed the way a student would -----------------------------------------------------------
X0 = ch06.DEPTH_SERIES
X1 = np.cumsum(X0)
Z1 = 0.5 * (X1[1:] + X1[:-1])
A, B = np.linalg.lstsq(np.column_stack([-Z1, np.ones(5)]), X0[1:], rcond=None)[0]
FORECAST = (1 - np.exp(A)) * (X0[0] - B / A) * np.exp(-6 * A)
D = wavelet.detail_coefficients(ch06.NOISE_WINDOW)
SIGMA = np.median(np.abs(D)) / 0.6745
W = ch06.PARTICLE_WEIGHTS / ch06.PARTICLE_WEIGHTS.sum()
ESS = 1 / np.sum(W**2)


def systematic(weights, u):
    w = np.asarray(weights, dtype=float)
    w = w / w.sum()
    c = np.cumsum(w)
    c[-1] = 1.0
    return np.searchsorted(c, (np.arange(w.size) + u) / w.size, side="right")


def test_right_answers_pass():
    assert ch06.check_gm11_coefficients(A, B)
    assert ch06.check_grey_forecast(FORECAST)
    assert ch06.check_mad_sigma(SIGMA)
    assert ch06.check_effective_sample_size(ESS)
    assert ch06.check_systematic_resample(systematic)
    assert ch06.check_q_smallest_eigenvalue(np.linalg.eigvalsh(ch06.Q_PRINTED)[0])
    assert ch06.check_q_correlation(ch06.Q_PRINTED[0, 1] / np.sqrt(ch06.Q_PRINTED[0, 0] * ch06.Q_PRINTED[1, 1]))
    # numpy scalars and one-element arrays are fine
    assert ch06.check_gm11_coefficients(np.float64(A), np.array([B]))
    # the expected values are uwtutor's own
    m = grey.fit_gm11(X0)
    assert (A, B) == pytest.approx((m.a, m.b)) and FORECAST == pytest.approx(m.forecast(1)[0])
    assert SIGMA == pytest.approx(wavelet.noise_sigma(ch06.NOISE_WINDOW), rel=1e-4)


def test_unanswered():
    for fb in (ch06.check_gm11_coefficients(None, None), ch06.check_grey_forecast(None), ch06.check_mad_sigma(None),
               ch06.check_effective_sample_size(None), ch06.check_systematic_resample(None),
               ch06.check_q_smallest_eigenvalue(None), ch06.check_q_correlation(None)):
        assert not fb and fb.message.startswith("No answer yet")


def lstsq(z, y, sign=-1.0):
    return tuple(np.linalg.lstsq(np.column_stack([sign * z, np.ones(z.size)]), y, rcond=None)[0])


@pytest.mark.parametrize("pair, words", [
    (lstsq(Z1, X0[1:], +1.0), "minus sign"),
    (lstsq(Z1, X1[1:]), "not the accumulated series"),
    (lstsq(X1[1:], X0[1:]), "not x1(k) itself"),
    (lstsq(X1[:-1], X0[1:]), "not x1(k−1)"),
    (lstsq(0.5 * (X0[1:] + X0[:-1]), X0[1:]), "means of x1, not of the raw readings"),
    (lstsq(np.concatenate([[X1[0]], Z1]), X0), "no background value for k = 1"),
])
def test_gm11_mistakes(pair, words):
    assert not (math.isclose(pair[0], A, rel_tol=1e-2) and math.isclose(pair[1], B, rel_tol=1e-2))
    fb = ch06.check_gm11_coefficients(*pair)
    assert not fb and words in text(fb)


def test_gm11_partly_right():
    fb = ch06.check_gm11_coefficients(A, B + 1.0)
    assert not fb and "the grey input b" in fb.message
    fb = ch06.check_gm11_coefficients(A * 1.5, B)
    assert not fb and "the development coefficient a" in fb.message


@pytest.mark.parametrize("value, words", [
    ((1 - np.exp(-A)) * (X0[0] - B / A) * np.exp(-6 * A), "eq. (12) as printed"),
    ((X0[0] - B / A) * np.exp(-6 * A) + B / A, "accumulated forecast"),
    ((1 - np.exp(A)) * (X0[0] - B / A) * np.exp(-5 * A), "sixth reading"),
    ((1 - np.exp(A)) * (X0[0] - B / A) * np.exp(6 * A), "sign in the exponent"),
])
def test_forecast_mistakes(value, words):
    assert abs(value - FORECAST) > 0.01 * abs(FORECAST)
    fb = ch06.check_grey_forecast(value)
    assert not fb and words in text(fb)


@pytest.mark.parametrize("value, words", [
    (np.median(D) / 0.6745, "absolute values"),
    (np.median(np.abs(D)) * 0.6745, "do not multiply"),
    (np.median(np.abs(D)), "divide it by 0.6745"),
    (np.std(D), "standard deviation of the coefficients"),
    (np.mean(np.abs(D)) / 0.6745, "not its mean"),
    (np.median(np.abs(pywt.dwt(ch06.NOISE_WINDOW, "db6")[1])) / 0.6745, "symmetric extension"),
    (np.std(ch06.NOISE_WINDOW), "spread of the readings"),
])
def test_mad_mistakes(value, words):
    assert abs(value - SIGMA) > 0.01 * SIGMA
    fb = ch06.check_mad_sigma(value)
    assert not fb and words in text(fb)


@pytest.mark.parametrize("value, words", [
    (1 / np.sum(ch06.PARTICLE_WEIGHTS**2), "Normalize the weights first"),
    (np.sum(W**2), "reciprocal"),
    (6.0, "only when all weights are equal"),
    (1 / W.max(), "1 / max(w)"),
])
def test_ess_mistakes(value, words):
    fb = ch06.check_effective_sample_size(value)
    assert not fb and words in text(fb)


def test_systematic_mistakes():
    def left(weights, u):
        w = np.asarray(weights, float) / np.sum(weights)
        return np.searchsorted(np.cumsum(w), (np.arange(w.size) + u) / w.size, side="left")

    def unnormalized(weights, u):
        c = np.cumsum(np.asarray(weights, float))
        return np.searchsorted(c, (np.arange(c.size) + u) / c.size, side="right")

    def crashes(weights, u):
        raise IndexError("list index out of range")

    fb = ch06.check_systematic_resample(left)
    assert not fb and "side='right'" in text(fb)
    fb = ch06.check_systematic_resample(unnormalized)
    assert not fb and "Normalize the weights first" in text(fb)
    fb = ch06.check_systematic_resample(crashes)
    assert not fb and "IndexError" in text(fb)
    assert ch06.check_systematic_resample(lambda w, u: list(systematic(w, u)))       # a list is fine


@pytest.mark.parametrize("value, words", [
    (np.linalg.eigvalsh(np.sqrt(ch06.Q_PRINTED))[0], "printed as squares"),
    (np.linalg.eigvalsh(ch06.Q_PRINTED)[-1], "largest eigenvalue"),
    (np.linalg.det(ch06.Q_PRINTED), "determinant"),
    (0.04, "positive diagonal"),
])
def test_eigenvalue_mistakes(value, words):
    fb = ch06.check_q_smallest_eigenvalue(value)
    assert not fb and words in text(fb)


@pytest.mark.parametrize("value, words", [
    (0.64, "That is the covariance"),
    (16.0, "not by the variances"),
    (4.0, "not 0.8"),
    (3.6, "depth-pitch"),
])
def test_correlation_mistakes(value, words):
    fb = ch06.check_q_correlation(value)
    assert not fb and words in text(fb)


# -- exercise 6.6: one bootstrap step ----------------------------------------------------------------------------------
def test_pf_step_reference_is_the_library_filter_step():
    """With the same draws, the reference step is BootstrapParticleFilter's predict + update + resample."""
    from uwtutor.filters import BootstrapParticleFilter, DepthSpeedPitchModel

    model = DepthSpeedPitchModel(T=ch06.PF_STEP_T, process_std=ch06.PF_STEP_PROCESS_STD, R=ch06.PF_STEP_R)
    rng = np.random.default_rng(5)
    particles = np.array([12.0, 1.8, 0.14]) + rng.standard_normal((300, 3)) * np.array([0.3, 0.05, 0.02])
    z = np.array([12.1, 1.82, 0.15])
    pf = BootstrapParticleFilter(model, particles.copy(), np.random.default_rng(9))
    pf.predict()
    moved = pf.particles.copy()
    pf.update(z)
    # the library's draws, recovered from its moved particles: only the depth row depends on the noise nonlinearly
    noise = np.empty_like(particles)
    noise[:, 1:] = moved[:, 1:] - particles[:, 1:]
    noise[:, 0] = moved[:, 0] - particles[:, 0] - moved[:, 1] * np.sin(moved[:, 2]) * ch06.PF_STEP_T
    est, w, _ = ch06.pf_step_reference(particles, z, noise, 0.5, ch06.PF_STEP_T, ch06.PF_STEP_R)
    np.testing.assert_allclose(est, pf.x, rtol=1e-9, atol=1e-12)


def test_pf_step_checker():
    assert ch06.check_pf_step(ch06.pf_step_reference).correct

    def noise_after_kinematics(particles, z, noise, u, T, R):
        est, w, res = ch06.pf_step_reference(particles, z, np.zeros_like(noise), u, T, R)
        return ch06.pf_step_reference(particles + 0.0, z, noise * 1.5, u, T, R)

    assert not ch06.check_pf_step(noise_after_kinematics).correct
    assert not ch06.check_pf_step(None).correct
    assert not ch06.check_pf_step(lambda *a: (1, 2)).correct
