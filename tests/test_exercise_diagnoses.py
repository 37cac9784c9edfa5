"""A corpus of typical wrong answers to the exercises of chapters 1-9, each with the diagnosis it deserves.

Every entry is a wrong answer a student writes (a number computed the wrong way, or a function with one slip, written
as student code), and a fragment of the hint that names *that* slip. The test asserts that the checker refuses the
answer and that its hint names the slip: a hint about another mistake, however true, is a misdiagnosis.

Run as a script (``python tests/test_exercise_diagnoses.py``) it prints how many entries get the right diagnosis;
with ``PYTHONPATH`` pointing at another checkout it measures that checkout's checkers on the same corpus.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import pytest
from scipy import stats

from uwtutor import lsq
from uwtutor.exercises import ch01, ch02, ch03, ch04, ch05, ch06, ch07, ch08, ch09


@dataclass(frozen=True)
class Slip:
    """One wrong answer: the exercise, what the student did, the checker's call, and the fragment of the right hint."""

    exercise: str
    slip: str
    run: Callable[[], Any]           # returns the checker's Feedback
    fragment: str


# -- chapter 1 ---------------------------------------------------------------------------------------------------------
def _mackenzie(t=10.0, s=35.0, d=1000.0, *, td3_sign=-1.0, td3=True, d_km=False, kelvin=False):
    d = d / 1000 if d_km else d
    t = t + 273.15 if kelvin else t
    return (1448.96 + 4.591 * t - 5.304e-2 * t**2 + 2.374e-4 * t**3 + 1.340 * (s - 35) + 1.630e-2 * d
            + 1.675e-7 * d**2 - 1.025e-2 * t * (s - 35) + (td3_sign * 7.139e-13 * t * d**3 if td3 else 0.0))


def _flag_with_itself(ranges, threshold):
    ranges = np.asarray(ranges, dtype=float)
    flags = np.zeros(len(ranges), dtype=bool)
    for i in range(len(ranges)):
        window = ranges[max(i - 3, 0):i + 4]            # the range itself inside its own window
        window = window[~np.isnan(window)]
        if np.isnan(ranges[i]) or window.size == 0:
            continue
        flags[i] = abs(ranges[i] - np.median(window)) > threshold
    return flags


_TRACK_T = np.arange(0.0, 3601.0, 600.0)
_THETA = np.radians(89.0)

CH01 = [
    Slip("1.1", "the sign of the T·D³ term flipped", lambda: ch01.check_sound_speed(_mackenzie(td3_sign=1.0)),
         "T·D³ term has a minus sign"),
    Slip("1.1", "the T·D³ term left out", lambda: ch01.check_sound_speed(_mackenzie(td3=False)),
         "T·D³ term is missing"),
    Slip("1.1", "depth in kilometres", lambda: ch01.check_sound_speed(_mackenzie(d_km=True)), "metres"),
    Slip("1.1", "temperature in kelvin", lambda: ch01.check_sound_speed(_mackenzie(kelvin=True)), "kelvin"),
    Slip("1.2", "the two-way time not halved", lambda: ch01.check_two_way_range(1500.0 * 2.4), "two-way"),
    Slip("1.2", "the range in kilometres", lambda: ch01.check_two_way_range(1500.0 * 2.4 / 2 / 1000), "kilometres"),
    Slip("1.3", "true minus estimated", lambda: ch01.check_sound_speed_range_error(3000.0 - 1470.0 * 3000.0 / 1500.0),
         "sign"),
    Slip("1.4", "degrees passed to np.sin", lambda: ch01.check_dr_drift(2.0 * 3600.0 * np.sin(1.0)), "radians"),
    Slip("1.4", "cos instead of sin", lambda: ch01.check_dr_drift(2.0 * 3600.0 * np.cos(np.radians(1.0))), "sideways"),
    Slip("1.4b", "east and north swapped",
         lambda: ch01.check_dr_track(np.column_stack((2 * _TRACK_T * np.sin(_THETA), 2 * _TRACK_T * np.cos(_THETA)))),
         "column"),
    Slip("1.4b", "np.arange without its end",
         lambda: ch01.check_dr_track(np.column_stack((2 * _TRACK_T[:-1] * np.cos(_THETA),
                                                      2 * _TRACK_T[:-1] * np.sin(_THETA)))), "np.arange"),
    Slip("1.5", "the range inside its own window", lambda: ch01.check_outlier_detector(_flag_with_itself),
         "Leave the range itself out"),
]


# -- chapter 2 ---------------------------------------------------------------------------------------------------------
def _fisher(power=2.0):
    J = np.zeros((2, 2))
    for b in ch02.FIX_BEACONS:
        h = (ch02.FIX_POSITION - b) / np.linalg.norm(ch02.FIX_POSITION - b)
        J += np.outer(h, h) / ch02.FIX_SIGMA**power
    return J


def _right_fisher():
    return _fisher()


CH02 = [
    Slip("2.1a", "σ not squared", lambda: ch02.check_fisher_information(_fisher(1.0)), "σ²"),
    Slip("2.1a", "no division by σ²", lambda: ch02.check_fisher_information(_fisher(0.0)), "σ²"),
    Slip("2.1b", "the trace of the inverse without its root",
         lambda: ch02.check_rmse_bound(np.trace(np.linalg.inv(_right_fisher()))), "square root"),
    Slip("2.1b", "the inverse of the trace of J",
         lambda: ch02.check_rmse_bound(np.sqrt(1 / np.trace(_right_fisher()))), "Invert the matrix first"),
]


# -- chapter 3 ---------------------------------------------------------------------------------------------------------
def _quarter_design(radians=True, bias=True):
    phi = np.radians(ch03.QUARTER_TURN_BEARINGS_DEG) if radians else np.array(ch03.QUARTER_TURN_BEARINGS_DEG)
    return np.column_stack([np.cos(phi), np.sin(phi)] + ([np.ones(4)] if bias else []))


def _alpha(**kw):
    A = _quarter_design(**kw)
    return float(np.trace(np.linalg.inv(A.T @ A)))


def _n_trusted_index():
    times = 5.0 * np.arange(600)
    from uwtutor import motion
    track = motion.circle_track(times, radius=1500.0, speed=2.0, start_angle=-np.pi / 2)
    return int(np.argmax(lsq.precision_factor_history(track.positions) < 2.0))


def cost_assumed_divisor(travel_times, dr_offsets, bearing, speed_error, assumed_speed):
    tau, D = np.asarray(travel_times, dtype=float), np.asarray(dr_offsets, dtype=float)
    c_e = assumed_speed - speed_error
    p = c_e * tau[0] * np.array([np.cos(bearing), np.sin(bearing)]) + D
    return np.sum((np.linalg.norm(p, axis=1) / assumed_speed - tau) ** 2)       # divides by the assumed c


def cost_root(travel_times, dr_offsets, bearing, speed_error, assumed_speed):
    tau, D = np.asarray(travel_times, dtype=float), np.asarray(dr_offsets, dtype=float)
    c_e = assumed_speed - speed_error
    p = c_e * tau[0] * np.array([np.cos(bearing), np.sin(bearing)]) + D
    return np.sqrt(np.sum((np.linalg.norm(p, axis=1) / c_e - tau) ** 2))       # √L


def cost_flipped(travel_times, dr_offsets, bearing, speed_error, assumed_speed):
    tau, D = np.asarray(travel_times, dtype=float), np.asarray(dr_offsets, dtype=float)
    c_e = assumed_speed + speed_error                                            # c_e = c + Δc
    p = c_e * tau[0] * np.array([np.cos(bearing), np.sin(bearing)]) + D
    return np.sum((np.linalg.norm(p, axis=1) / c_e - tau) ** 2)


def cost_ranges(travel_times, dr_offsets, bearing, speed_error, assumed_speed):
    tau, D = np.asarray(travel_times, dtype=float), np.asarray(dr_offsets, dtype=float)
    c_e = assumed_speed - speed_error
    p = c_e * tau[0] * np.array([np.cos(bearing), np.sin(bearing)]) + D
    return np.sum((np.linalg.norm(p, axis=1) - c_e * tau) ** 2)                  # ranges, not times


def vmlbl_reversed(ranges, virtual_beacons, depth, beacon_depths):
    r, vb, za = (np.asarray(a, dtype=float) for a in (ranges, virtual_beacons, beacon_depths))
    j = np.roll(np.arange(len(r)), -1)
    d2 = np.sum(vb**2, axis=1) + za**2
    return vb - vb[j], -(0.5 * (r**2 - r[j] ** 2 + d2[j] - d2) - depth * (za[j] - za))   # this minus next


CH03 = [
    Slip("3.1", "the trace of AᵀA", lambda: ch03.check_precision_factor(
        np.trace(_quarter_design().T @ _quarter_design())), "inverse"),
    Slip("3.1", "degrees into np.cos", lambda: ch03.check_precision_factor(_alpha(radians=False)), "radians"),
    Slip("3.1", "no bias column", lambda: ch03.check_precision_factor(_alpha(bias=False)), "column of ones"),
    Slip("3.1", "√α", lambda: ch03.check_precision_factor(math.sqrt(_alpha())), "√α"),
    Slip("3.2", "the 0-based index", lambda: ch03.check_ranges_until_trusted(_n_trusted_index()), "0-based index"),
    Slip("3.2", "the elapsed time", lambda: ch03.check_ranges_until_trusted(5.0 * _n_trusted_index()), "seconds"),
    Slip("3.3", "rows this epoch minus the next", lambda: ch03.check_vmlbl_system(vmlbl_reversed), "next epoch minus"),
    Slip("3.4", "divided by the assumed c", lambda: ch03.check_travel_time_cost(cost_assumed_divisor),
         "effective speed c_e = c − Δc, not by the assumed c"),
    Slip("3.4", "√L returned", lambda: ch03.check_travel_time_cost(cost_root), "√L"),
    Slip("3.4", "c_e = c + Δc", lambda: ch03.check_travel_time_cost(cost_flipped), "c_e = c − Δc: with"),
    Slip("3.4", "ranges compared", lambda: ch03.check_travel_time_cost(cost_ranges), "not ranges"),
]


# -- chapter 4 ---------------------------------------------------------------------------------------------------------
def update_without_s(x, P, z, R, beacon):
    x, P, b = np.asarray(x, float), np.asarray(P, float), np.asarray(beacon, float)
    h = np.linalg.norm(x - b)
    H = (x - b) / h
    K = P @ H                                                   # the division by S forgotten
    return x + K * (z - h), (np.eye(2) - np.outer(K, H)) @ P


def update_flipped(x, P, z, R, beacon):
    x, P, b = np.asarray(x, float), np.asarray(P, float), np.asarray(beacon, float)
    h = np.linalg.norm(x - b)
    H = (x - b) / h
    S = H @ P @ H + R
    K = P @ H / S
    return x + K * (h - z), (np.eye(2) - np.outer(K, H)) @ P    # predicted minus measured


def update_origin(x, P, z, R, beacon):
    x, P = np.asarray(x, float), np.asarray(P, float)
    h = np.linalg.norm(x)                                       # the beacon taken at the origin
    H = x / h
    S = H @ P @ H + R
    K = P @ H / S
    return x + K * (z - h), (np.eye(2) - np.outer(K, H)) @ P


def update_keeps_p(x, P, z, R, beacon):
    x, P, b = np.asarray(x, float), np.asarray(P, float), np.asarray(beacon, float)
    h = np.linalg.norm(x - b)
    H = (x - b) / h
    K = P @ H / (H @ P @ H + R)
    return x + K * (z - h), P                                   # the covariance not updated


def update_std(x, P, z, R, beacon):
    x, P, b = np.asarray(x, float), np.asarray(P, float), np.asarray(beacon, float)
    h = np.linalg.norm(x - b)
    H = (x - b) / h
    S = H @ P @ H + np.sqrt(R)                                  # the standard deviation for the variance
    K = P @ H / S
    return x + K * (z - h), (np.eye(2) - np.outer(K, H)) @ P


def _loop(x0, P0, u, z, Q, R, beacon, *, add_q=True, carry_p=True, predict_first=True, store_prior=False):
    x, P = np.array(x0, dtype=float), np.array(P0, dtype=float)
    out = np.empty((len(z), 2))
    for k in range(len(z)):
        if not carry_p:
            P = np.array(P0, dtype=float)                        # P0 again at every epoch
        if not predict_first and not np.isnan(z[k]):
            x, P = update_correct(x, P, z[k], R, beacon)
        x, P = x + u[k], (P + Q if add_q else P)
        out[k] = x
        if predict_first and not store_prior and not np.isnan(z[k]):
            x, P = update_correct(x, P, z[k], R, beacon)
            out[k] = x
    return out


def update_correct(x, P, z, R, beacon):
    d = x - np.asarray(beacon, dtype=float)
    h = np.linalg.norm(d)
    H = d / h
    K = P @ H / (H @ P @ H + R)
    return x + K * (z - h), (np.eye(2) - np.outer(K, H)) @ P


def run_without_q(x0, P0, u, z, Q, R, beacon):
    return _loop(x0, P0, u, z, Q, R, beacon, add_q=False)


def run_resetting_p(x0, P0, u, z, Q, R, beacon):
    return _loop(x0, P0, u, z, Q, R, beacon, carry_p=False)


def run_update_first(x0, P0, u, z, Q, R, beacon):
    return _loop(x0, P0, u, z, Q, R, beacon, predict_first=False)


def run_storing_priors(x0, P0, u, z, Q, R, beacon):
    return _loop(x0, P0, u, z, Q, R, beacon, store_prior=True)


def _check_run(func):
    return ch04.check_ekf_run(func)        # exercise 4.6 (no checker before it was added)


_E43 = np.array([100.0, -200.0]) - np.array([105.0, -196.0])
_P43 = np.array([[16.0, 6.0], [6.0, 9.0]])
_D41 = np.array([500.0, -300.0]) - np.array([200.0, 100.0])

CH04 = [
    Slip("4.1", "not normalized", lambda: ch04.check_range_jacobian(_D41), "unit"),
    Slip("4.1", "b − x", lambda: ch04.check_range_jacobian(-_D41 / np.linalg.norm(_D41)), "x − b"),
    Slip("4.2", "a gain without S", lambda: ch04.check_ekf_update(update_without_s), "division by the innovation"),
    Slip("4.2", "the innovation flipped", lambda: ch04.check_ekf_update(update_flipped), "measured minus predicted"),
    Slip("4.2", "the beacon at the origin", lambda: ch04.check_ekf_update(update_origin), "beacon's position b"),
    Slip("4.2", "P not updated", lambda: ch04.check_ekf_update(update_keeps_p), "prior P unchanged"),
    Slip("4.2", "√R for R", lambda: ch04.check_ekf_update(update_std), "variance"),
    Slip("4.3", "P not inverted", lambda: ch04.check_nees(_E43 @ _P43 @ _E43), "inverse"),
    Slip("4.3", "the root of the NEES", lambda: ch04.check_nees(math.sqrt(_E43 @ np.linalg.solve(_P43, _E43))),
         "square"),
    Slip("4.4", "not divided by M", lambda: ch04.check_nees_bounds(stats.chi2.ppf([0.025, 0.975], 100)), "M"),
    Slip("4.4", "the one-dimensional quantiles", lambda: ch04.check_nees_bounds(stats.chi2.ppf([0.025, 0.975], 2)),
         "M·n"),
    Slip("4.6", "no Q in the prediction", lambda: _check_run(run_without_q), "P ← P + Q"),
    Slip("4.6", "P0 at every epoch", lambda: _check_run(run_resetting_p), "Carry P"),
    Slip("4.6", "update before predict", lambda: _check_run(run_update_first), "Predict first"),
    Slip("4.6", "the predictions stored", lambda: _check_run(run_storing_priors), "Those are the predictions"),
]


# -- chapter 5 ---------------------------------------------------------------------------------------------------------
def _study_rmses(beta: Any = "range"):
    from uwtutor.filters.ekf import range_only_ekf
    from uwtutor.filters.fading import fading_ekf
    s = ch05.study()
    args = (s["x0"], s["P0"], s["u"], s["z"], s["Q"], s["R"])
    e = ch05.final_rmse(range_only_ekf(*args).x, s["truth"])
    m = ch05.final_rmse(fading_ekf(*args, mu_gamma=0.98, sigma_gamma=1 / 1500, fading=False).x, s["truth"])
    i = ch05.final_rmse(fading_ekf(*args, mu_gamma=0.98, sigma_gamma=1 / 1500, rho=0.95, beta=beta).x, s["truth"])
    return e, m, i


CH05 = [
    Slip("5.1", "c_e / c upside down", lambda: ch05.check_mu_gamma(ch05.EFFECTIVE_SPEED / ch05.ASSUMED_SPEED),
         "c / c_e"),
    Slip("5.1", "(1 − μ_γ) r", lambda: ch05.check_mean_range_error(
        (1 - ch05.ASSUMED_SPEED / ch05.EFFECTIVE_SPEED) * ch05.TRUE_RANGE), "Measured minus true"),
    Slip("5.3", "the threshold on z̃²", lambda: ch05.check_threshold_beta_one(ch05.threshold_innovation(1.0) ** 2),
         "square root"),
    Slip("5.4", "the ISFEKF with β = 1", lambda: ch05.check_final_rmse(*_study_rmses(beta=1.0)), "β = 1"),
]


# -- chapter 6 ---------------------------------------------------------------------------------------------------------
def _pf(particles, z, noise, u, T, R, *, noise_after=False, shift=True, invert=True, estimate_after=False):
    particles, z, noise, R = (np.asarray(a, dtype=float) for a in (particles, z, noise, R))
    s = particles if noise_after else particles + noise
    moved = np.column_stack((s[:, 0] + s[:, 1] * np.sin(s[:, 2]) * T, s[:, 1], s[:, 2]))
    if noise_after:
        moved = moved + noise
    d = z - moved
    log_w = -0.5 * np.einsum("ni,ij,nj->n", d, np.linalg.inv(R) if invert else R, d)
    with np.errstate(all="ignore"):
        weights = np.exp(log_w - log_w.max() if shift else log_w)
        weights /= weights.sum()
    N = len(weights)
    idx = np.searchsorted(np.cumsum(weights), (np.arange(N) + u) / N, side="right")
    resampled = moved[np.minimum(idx, N - 1)]
    estimate = resampled.mean(axis=0) if estimate_after else weights @ moved
    return estimate, weights, resampled


def pf_estimate_after(particles, z, noise, u, T, R):
    return _pf(particles, z, noise, u, T, R, estimate_after=True)


def pf_r_not_inverted(particles, z, noise, u, T, R):
    return _pf(particles, z, noise, u, T, R, invert=False)


def pf_noise_after(particles, z, noise, u, T, R):
    return _pf(particles, z, noise, u, T, R, noise_after=True)


def pf_no_shift(particles, z, noise, u, T, R):
    return _pf(particles, z, noise, u, T, R, shift=False)


def systematic_multinomial(weights, u):
    w = np.asarray(weights, dtype=float)
    return np.random.default_rng(0).choice(w.size, w.size, p=w / w.sum())


CH06 = [
    Slip("6.4", "the weights not normalized", lambda: ch06.check_effective_sample_size(
        1.0 / np.sum(ch06.PARTICLE_WEIGHTS**2)), "Normalize the weights"),
    Slip("6.5", "the covariance not divided by the deviations", lambda: ch06.check_q_correlation(
        ch06.Q_PRINTED[0, 1]), "both standard deviations"),
    Slip("6.6", "the estimate after resampling", lambda: ch06.check_pf_step(pf_estimate_after),
         "taken *before* resampling"),
    Slip("6.6", "R not inverted", lambda: ch06.check_pf_step(pf_r_not_inverted), "R⁻¹"),
    Slip("6.6", "the noise after the kinematics", lambda: ch06.check_pf_step(pf_noise_after), "*before* the kinem"),
    Slip("6.6", "no shift of the log-weights", lambda: ch06.check_pf_step(pf_no_shift), "underflow"),
]


# -- chapters 7 to 9 ---------------------------------------------------------------------------------------------------
_D72 = np.array([-700.0, 550.0]) - np.array([100.0, -50.0])


def _hand_gate(*, on_range=False):
    dive = ch09.lockout_dive()
    z = np.asarray(dive.slant_ranges[0])
    good = ~np.asarray(dive.outlier_mask[0])
    dt, q, r, delta = 1.0, 2.0, 2.0, ch09.DELTA
    F = np.array([[1.0, dt], [0.0, 1.0]])
    Q = q * np.array([[dt**4 / 4, dt**3 / 2], [dt**3 / 2, dt**2]])
    x, P = np.array([z[0], 0.0]), np.diag([r, 25.0])
    rejected = np.zeros(len(z), dtype=bool)
    for k in range(1, len(z)):
        x, P = F @ x, F @ P @ F.T + Q
        S = P[0, 0] + r
        D = S + x[0] ** 2
        if on_range:                                             # δ on z instead of z²
            accepted = (1 - delta) * np.sqrt(D) <= z[k] <= (1 + delta) * np.sqrt(D)
        else:
            accepted = (1 - delta) * D <= z[k] ** 2 <= (1 + delta) * D
        if accepted:
            K = P[:, 0] / S
            x = x + K * (z[k] - x[0])
            P = P - np.outer(K, P[0])
        else:
            rejected[k] = True
    return int(np.sum(rejected & good))


def _check_by_hand(n):
    checker = getattr(ch09, "check_gate_by_hand", ch09.check_good_rejected)    # before: 9.3(a)'s checker
    return checker(n)


_D_GATE = ch09.S_INNOV + ch09.Z_PRED**2

CH07_09 = [
    Slip("7.1", "standard deviations for variances", lambda: ch07.check_bias_noise(
        np.diag([0.8, 0.6, (0.8 + 0.6) / 2])), "variances"),
    Slip("7.2", "∂r/∂υ = 0", lambda: ch07.check_augmented_jacobian(np.r_[_D72 / np.linalg.norm(_D72), 0.0]),
         "∂r/∂υ = 1"),
    Slip("8.1", "the offset alone", lambda: ch08.check_clock_range_error(1500.0 * 0.4e-3), "drift"),
    Slip("8.1", "the offset in milliseconds", lambda: ch08.check_clock_range_error(1500.0 * (0.4 + 5e-6 * 2000)),
         "0.4e-3 s"),
    Slip("9.1", "the approximation δẑ/2", lambda: ch09.check_gate_upper(ch09.DELTA * ch09.Z_PRED / 2),
         "first-order approximation"),
    Slip("9.1", "the lower edge", lambda: ch09.check_gate_upper(
        ch09.Z_PRED - math.sqrt((1 - ch09.DELTA) * _D_GATE)), "lower edge"),
    Slip("9.1", "δẑ", lambda: ch09.check_gate_upper(ch09.DELTA * ch09.Z_PRED), "δ·ẑ"),
    Slip("9.1b", "y_max/√S", lambda: ch09.check_equivalent_nis(
        (math.sqrt((1 + ch09.DELTA) * _D_GATE) - ch09.Z_PRED) / math.sqrt(ch09.S_INNOV)), "square"),
    Slip("9.2", "the ship moved backwards", lambda: ch09.check_virtual_beacons(ch09.SHIP - (ch09.DR[-1] - ch09.DR)),
         "*forward*"),
    Slip("9.3b", "δ on z instead of z²", lambda: _check_by_hand(_hand_gate(on_range=True)), "applies δ to the range"),
]

CORPUS = CH01 + CH02 + CH03 + CH04 + CH05 + CH06 + CH07_09


def diagnose(slip: Slip) -> tuple[bool, str]:
    """Whether the checker refuses the wrong answer with the right hint, and its feedback as text."""
    if slip.exercise == "4.6" and not hasattr(ch04, "check_ekf_run"):
        return False, "no checker for this exercise"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fb = slip.run()
    text = f"{fb.message}\n{fb.hint}"
    return (not fb.correct) and slip.fragment in (fb.hint or ""), text


@pytest.mark.parametrize("slip", CORPUS, ids=[f"{s.exercise}-{s.slip}" for s in CORPUS])
def test_each_slip_gets_its_own_hint(slip):
    right, text = diagnose(slip)
    assert right, f"{slip.exercise}, {slip.slip}: expected a hint with {slip.fragment!r}, got\n{text}"


def test_a_known_slip_is_not_called_a_rounding():
    """A conceptual mistake that lands near the answer (3.2's index, 1.1's T·D³ sign) is not 'close'."""
    for fb in (ch03.check_ranges_until_trusted(_n_trusted_index()), ch01.check_sound_speed(_mackenzie(td3_sign=1.0))):
        assert not fb.correct
        assert "close" not in fb.message and "a known slip rather than a rounding" in fb.message


@pytest.mark.parametrize("slip", CORPUS, ids=[f"{s.exercise}-{s.slip}" for s in CORPUS])
def test_no_slip_is_led_by_close_but(slip):
    """Every wrong answer of the corpus is a conceptual slip: its message never opens with "is close, but (just)
    outside the tolerance", which would send the student looking for a rounding."""
    _, text = diagnose(slip)
    assert "close, but" not in text.split("\n")[0], text


if __name__ == "__main__":
    results = [(s, *diagnose(s)) for s in CORPUS]
    for s, right, text in results:
        if not right:
            print(f"MISDIAGNOSED {s.exercise} ({s.slip}):\n  {text.replace(chr(10), chr(10) + '  ')}")
    print(f"{sum(r for _, r, _ in results)} of {len(results)} wrong answers get the right diagnosis")
    old = [(s, r) for s, r, t in results if t != "no checker for this exercise" and s.exercise != "4.6"]
    print(f"{sum(r for _, r in old)} of {len(old)} for the exercises that had a checker before exercise 4.6")
