"""Chapter 5 checkers: the right answers pass, the usual mistakes get the hint that explains them."""

from __future__ import annotations

import math

import numpy as np
import pytest

from uwtutor import scenarios
from uwtutor.exercises import Feedback, ch05
from uwtutor.filters.ekf import range_only_ekf
from uwtutor.filters.fading import fading_ekf


def _text(fb: Feedback) -> str:
    return f"{fb.message}\n{fb.hint or ''}"


# -- expected values computed here, independently of the checkers ------------------------------------------------------
MU = 1480.0 / 1510.0
SIGMA = 2.0 / 1510.0
MEAN_ERROR = 2500.0 * (1480.0 / 1510.0 - 1.0)
VBAR = 0.5 + 0.78 + 1.78 + 0.49


def fading_factors(innovations, predicted, subtracted, rho):
    """A vectorized-as-possible solution, written independently of the checker's reference."""
    z2 = np.asarray(innovations, float) ** 2
    V = np.empty_like(z2)
    V[0] = z2[0]
    for k in range(1, len(z2)):
        V[k] = (rho * V[k - 1] + z2[k]) / (1 + rho)
    return np.maximum(1.0, (V - np.asarray(subtracted)) / np.asarray(predicted))


def test_exercise_data_are_what_the_notebook_says():
    assert (ch05.ASSUMED_SPEED, ch05.EFFECTIVE_SPEED, ch05.SPEED_SIGMA, ch05.TRUE_RANGE) == (1480.0, 1510.0, 2.0,
                                                                                            2500.0)
    assert ch05.STEADY == {"N": 0.5, "CQC": 0.78, "mult": 1.78, "R": 0.49, "rho": 0.95}
    assert ch05.threshold_innovation(1.0) == pytest.approx(math.sqrt(VBAR))
    assert ch05.threshold_innovation(2000.0) == pytest.approx(math.sqrt(VBAR + 1.95 * 1999 * 0.49))
    assert ch05.threshold_innovation(2000.0) == pytest.approx(43.74, abs=0.01)


@pytest.mark.parametrize("check, answer", [
    (ch05.check_mu_gamma, MU),
    (ch05.check_mu_gamma, 1 + (1480.0 - 1510.0) / 1510.0),
    (ch05.check_mu_gamma, 1 + (1480.0 - 1510.0) / 1480.0),     # first order with the assumed speed
    (ch05.check_sigma_gamma, SIGMA),
    (ch05.check_sigma_gamma, 1480.0 * 2.0 / 1510.0**2),
    (ch05.check_sigma_gamma, 2.0 / 1480.0),
    (ch05.check_mean_range_error, MEAN_ERROR),
    (ch05.check_threshold_beta_one, math.sqrt(VBAR)),
    (ch05.check_threshold_beta_range, math.sqrt(VBAR + 1.95 * 1999 * 0.49)),
    (ch05.check_fading_factors, fading_factors),
    (ch05.check_fading_factors, ch05.fading_factors_reference),
])
def test_right_answers_pass(check, answer):
    fb = check(answer)
    assert fb.correct, _text(fb)


def test_the_final_rmse_study():
    # the study recomputed here from the library, independently of the checker
    rng = np.random.default_rng(ch05.STUDY_SEED)
    sc = scenarios.approach_with_turn_scenario(rng, n_runs=ch05.STUDY_RUNS)
    angle = rng.uniform(0.0, 2 * np.pi, ch05.STUDY_RUNS)
    x0 = sc.true_positions[:, 0] + 30.0 * np.column_stack([np.cos(angle), np.sin(angle)])
    P0, Q = np.eye(2) * 900.0, np.eye(2) * 0.81

    def rmse(x):
        return float(np.sqrt(np.mean(np.sum((x[:, -1] - sc.true_positions[:, -1]) ** 2, axis=-1))))

    args = (x0, P0, sc.dr_displacements, sc.ranges, Q, 0.49)
    e = rmse(range_only_ekf(*args).x)
    m = rmse(fading_ekf(*args, mu_gamma=0.98, sigma_gamma=1 / 1500, fading=False).x)
    i = rmse(fading_ekf(*args, mu_gamma=0.98, sigma_gamma=1 / 1500, rho=0.95, beta="range").x)
    assert m == pytest.approx(i)                # the lesson of the exercise: fading never acts from 30 m
    assert e > 2 * m
    fb = ch05.check_final_rmse(e, m, i)
    assert fb.correct, _text(fb)
    study = ch05.study()
    np.testing.assert_allclose(study["x0"], x0)
    # mistakes
    err = np.linalg.norm(range_only_ekf(*args).x - sc.true_positions, axis=-1)
    assert "mean error" in _text(ch05.check_final_rmse(float(err[:, -1].mean()), m, i))
    assert "all epochs" in _text(ch05.check_final_rmse(float(np.sqrt(np.mean(err**2))), m, i))
    wrong = rmse(fading_ekf(*args, mu_gamma=1.02, sigma_gamma=1 / 1500, fading=False).x)
    fb = ch05.check_final_rmse(e, wrong, i)
    assert not fb.correct and "rmse_mult" in fb.message and "sign slip" in _text(fb)
    assert "No answer yet" in _text(ch05.check_final_rmse(e, m, None))


@pytest.mark.parametrize("check, answer, hint_fragment", [
    (ch05.check_mu_gamma, 1 - (1480.0 - 1510.0) / 1510.0, "sign slip"),
    (ch05.check_mu_gamma, 1510.0 / 1480.0, "upside down"),
    (ch05.check_mu_gamma, 1510.0 / 1480.0, "below 1"),
    (ch05.check_mu_gamma, (1480.0 - 1510.0) / 1510.0, "γ − 1"),
    (ch05.check_sigma_gamma, SIGMA**2, "variance"),
    (ch05.check_sigma_gamma, 2.0, "dimensionless"),
    (ch05.check_sigma_gamma, 2.0 / 1510.0**2, "once"),
    (ch05.check_mean_range_error, -MEAN_ERROR, "negative"),
    (ch05.check_mean_range_error, MU * 2500.0, "mean measured range"),
    (ch05.check_threshold_beta_one, VBAR, "square root"),
    (ch05.check_threshold_beta_range, VBAR + 1.95 * 1999 * 0.49, "square root"),
    (ch05.check_threshold_beta_range, math.sqrt(VBAR + 1999 * 0.49), "1/(1 + ρ)"),
    (ch05.check_threshold_beta_one, math.sqrt(1.95 * VBAR), "keeps its weight"),
    (ch05.check_threshold_beta_range, math.sqrt(VBAR + 1.95 * 1999), "multiplies R"),
])
def test_mistakes_get_their_hint(check, answer, hint_fragment):
    fb = check(answer)
    assert not fb.correct
    assert hint_fragment in _text(fb), _text(fb)


def _no_max(z, n, s, rho):
    out, V = [], 0.0
    for k in range(len(z)):
        V = z[k] ** 2 if k == 0 else (rho * V + z[k] ** 2) / (1 + rho)
        out.append((V - s[k]) / n[k])
    return np.array(out)


def _zero_start(z, n, s, rho):
    out, V = [], 0.0
    for k in range(len(z)):
        V = (rho * V + z[k] ** 2) / (1 + rho)
        out.append(max(1.0, (V - s[k]) / n[k]))
    return np.array(out)


def _swapped_weights(z, n, s, rho):
    out, V = [], 0.0
    for k in range(len(z)):
        V = z[k] ** 2 if k == 0 else (V + rho * z[k] ** 2) / (1 + rho)
        out.append(max(1.0, (V - s[k]) / n[k]))
    return np.array(out)


def _first_terms_only(z, n, s, rho):
    out, V = [], 0.0
    for k in range(len(z)):
        V = z[k] ** 2 if k == 0 else (rho * V + z[k] ** 2) / (1 + rho)
        out.append(max(1.0, (V - s[0]) / n[0]))
    return np.array(out)


def _in_place(z, n, s, rho):
    z[:] = z**2
    return fading_factors(np.sqrt(z), n, s, rho)


@pytest.mark.parametrize("func, fragment", [
    (_no_max, "never below 1"),
    (_zero_start, "V₁ = y₁²"),
    (_swapped_weights, "*old* value"),
    (_first_terms_only, "k-th entry"),
    (_in_place, "in place"),
    (lambda z, n, s, rho: None, "return"),
])
def test_fading_function_mistakes(func, fragment):
    fb = ch05.check_fading_factors(func)
    assert not fb.correct
    assert fragment in _text(fb), _text(fb)


@pytest.mark.parametrize("check", [ch05.check_mu_gamma, ch05.check_sigma_gamma, ch05.check_mean_range_error,
                                   ch05.check_threshold_beta_one, ch05.check_threshold_beta_range,
                                   ch05.check_fading_factors])
@pytest.mark.parametrize("answer", [None, "3", float("nan"), True])
def test_unanswered_and_odd_answers_get_feedback_not_tracebacks(check, answer):
    fb = check(answer)
    assert isinstance(fb, Feedback) and not fb.correct


def test_fading_reference_matches_the_library_filter():
    """The exercise's lambda rule is the library's: feed it the library's own terms and compare."""
    rng = np.random.default_rng(4)
    sc = scenarios.approach_with_turn_scenario(rng, n_runs=1)
    x0 = sc.true_positions[0, 0] + [60.0, -40.0]
    res = fading_ekf(x0, np.eye(2) * 5000.0, sc.dr_displacements[0], sc.ranges[0], np.eye(2) * 0.81, 0.49,
                     mu_gamma=0.98, sigma_gamma=1 / 1500, rho=0.95, beta=1.0)
    ex = res.extras
    subtracted = ex["innovation_power"] - ex["fading_numerator"]     # sigma^2 T + mu^2 CQC + beta R
    lam = ch05.fading_factors_reference(res.innovations[:, 0], ex["fading_denominator"], subtracted, 0.95)
    np.testing.assert_allclose(lam, res.fading_factor, rtol=1e-9)


# -- exercise 5.5: one ISFEKF step -------------------------------------------------------------------------------------
def test_isfekf_step_reference_equals_the_library_over_a_whole_run():
    from uwtutor.filters.fading import FadingEKF
    rng = np.random.default_rng(ch05.ISF_STEP_SEED)         # the checker's run, all 151 steps
    sc = scenarios.approach_with_turn_scenario(rng, n_runs=1)
    angle = rng.uniform(0.0, 2 * np.pi)
    c = ch05.ISF_STEP_CONSTANTS
    Q = np.eye(2) * c["q"]
    x0 = np.asarray(sc.true_positions)[0, 0] + 150.0 * np.array([np.cos(angle), np.sin(angle)])
    P0 = np.eye(2) * 150.0**2
    np.testing.assert_array_equal(x0, ch05.isfekf_step_run()["x0"])
    lib = FadingEKF(x0, P0, Q, c["R"], mu_gamma=c["mu_gamma"], sigma_gamma=c["sigma_gamma"], rho=c["rho"],
                    beta="range")
    state = (x0, P0, x0, P0 + np.outer(x0, x0), None)
    lams = []
    for u, z in zip(np.asarray(sc.dr_displacements)[0], np.asarray(sc.ranges)[0]):
        lib.predict(u)
        lib.update(z)
        out = ch05.isfekf_step_reference(*state, u, float(z), Q, c["R"], c["mu_gamma"], c["sigma_gamma"], c["rho"])
        np.testing.assert_allclose(out[0], lib.x, rtol=1e-5, atol=1e-3)
        np.testing.assert_allclose(out[5], float(lib.fading_factor), rtol=1e-4)
        lams.append(out[5])
        state = out[:5]
    assert max(lams) > 100.0          # the run exercises the fading rule


def test_isfekf_step_checker_accepts_the_reference_and_names_slips():
    assert ch05.check_isfekf_step(ch05.isfekf_step_reference).correct

    def no_fading(*args):
        return (*ch05.isfekf_step_reference(*args)[:5], 1.0)

    fb = ch05.check_isfekf_step(no_fading)
    assert not fb.correct and fb.details["quantity"] == "lam"

    def estimate_not_moments(x, P, m, Xi, V, u, z, Q, R, mu, sg, rho):
        # the weakening factor taken from the estimate instead of the moments
        return ch05.isfekf_step_reference(x, P, x, Xi, V, u, z, Q, R, mu, sg, rho)

    fb = ch05.check_isfekf_step(estimate_not_moments)
    assert not fb.correct
    assert not ch05.check_isfekf_step(None).correct
    assert not ch05.check_isfekf_step(lambda *a: (1, 2)).correct


def test_isfekf_step_checker_says_not_answered_for_the_stub():
    def stub(*args):
        raise NotImplementedError()

    fb = ch05.check_isfekf_step(stub)
    assert not fb.correct and fb.message.startswith("No answer yet")
