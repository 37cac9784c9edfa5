"""The checkers of chapters 3 and 4: right answers pass, the usual mistakes get their specific hints."""

import numpy as np
import pytest
from filterpy.kalman import ExtendedKalmanFilter
from scipy import stats

from uwtutor import lsq
from uwtutor.exercises import ch03, ch04

# --- chapter 3 ----------------------------------------------------------------------------------------------------


def quarter_turn_design(bias=True):
    phi = np.radians(ch03.QUARTER_TURN_BEARINGS_DEG)
    return np.column_stack([np.cos(phi), np.sin(phi)] + ([np.ones(4)] if bias else []))


def test_precision_factor_checker():
    A = quarter_turn_design()
    alpha = np.trace(np.linalg.inv(A.T @ A))
    assert ch03.check_precision_factor(alpha)
    assert ch03.check_precision_factor(np.sum(1.0 / np.linalg.eigvalsh(A.T @ A)))
    assert not ch03.check_precision_factor(None).correct
    assert "No answer yet" in ch03.check_precision_factor(None).message
    fb = ch03.check_precision_factor(np.trace(A.T @ A))
    assert not fb and "inverse" in fb.hint
    fb = ch03.check_precision_factor(np.sqrt(alpha))
    assert not fb and "√α" in fb.hint
    fb = ch03.check_precision_factor(lsq.precision_factor(quarter_turn_design(bias=False)))
    assert not fb and "column of ones" in fb.hint
    inv = np.linalg.inv(A.T @ A)
    assert "position block" in ch03.check_precision_factor(inv[0, 0] + inv[1, 1]).hint
    phi = np.array(ch03.QUARTER_TURN_BEARINGS_DEG)
    deg = np.column_stack([np.cos(phi), np.sin(phi), np.ones(4)])
    assert "radians" in ch03.check_precision_factor(lsq.precision_factor(deg)).hint
    assert "text" in ch03.check_precision_factor("26.5").message


def test_ranges_until_trusted_checker():
    alpha = ch03._circle_alpha(600)
    n = int(np.argmax(alpha < 2.0)) + 1
    assert alpha[n - 1] < 2.0 <= alpha[n - 2]
    assert ch03.check_ranges_until_trusted(n)
    assert "0-based index" in ch03.check_ranges_until_trusted(n - 1).hint
    at_one = int(np.argmax(alpha < 1.0)) + 1
    assert "α < 2" in ch03.check_ranges_until_trusted(at_one).hint
    assert "seconds" in ch03.check_ranges_until_trusted(5.0 * (n - 1)).hint
    assert not ch03.check_ranges_until_trusted(n + 10)


def test_vmlbl_system_reference_agrees_with_lsq():
    ship = np.array([[0.0, 0.0], [400.0, 100.0], [700.0, 400.0], [800.0, 800.0]])
    sub = np.array([[-900.0, -1100.0], [-850.0, -1050.0], [-800.0, -1000.0], [-750.0, -950.0]])
    z = np.array([0.0, 3.0, 6.0, 1.0])
    vb = ship + (sub[-1] - sub)
    r = np.sqrt(np.sum((sub[-1] - vb) ** 2, axis=1) + (900.0 - z) ** 2)
    A, B = ch03.vmlbl_system_reference(r, vb, 900.0, z)
    fix = lsq.virtual_beacon_lsq(r, ship, sub, depth=900.0, beacon_depths=z)
    np.testing.assert_allclose(A, fix.design)
    np.testing.assert_allclose(B, fix.rhs)
    np.testing.assert_allclose(np.linalg.lstsq(A, B, rcond=None)[0], sub[-1], atol=1e-6)


def test_vmlbl_system_checker_recognises_mistakes():
    ref = ch03.vmlbl_system_reference
    assert ch03.check_vmlbl_system(ref)
    assert not ch03.check_vmlbl_system(None)

    def no_cycle(r, vb, h, z):
        A, B = ref(r, vb, h, z)
        return A[:-1], B[:-1]

    def sign(r, vb, h, z):
        A, B = ref(r, vb, h, z)
        return A, -B

    def double(r, vb, h, z):
        A, B = ref(r, vb, h, z)
        return A, 2 * B

    def fixed_four(r, vb, h, z):
        j = np.array([1, 2, 3, 0])
        r, vb, z = (np.asarray(a, float) for a in (r, vb, z))
        d2 = np.sum(vb**2, 1) + z**2
        return vb[j] - vb, 0.5 * (r**2 - r[j] ** 2 + d2[j] - d2) - h * (z[j] - z)

    def only_a(r, vb, h, z):
        return ref(r, vb, h, z)[0]

    assert "closes the cycle" in ch03.check_vmlbl_system(no_cycle).hint
    assert "this epoch's squared range" in ch03.check_vmlbl_system(sign).hint
    assert "Divide the bracket by 2" in ch03.check_vmlbl_system(double).hint
    fb = ch03.check_vmlbl_system(fixed_four)
    assert not fb and "five epochs" in fb.message
    assert "return two things" in ch03.check_vmlbl_system(only_a).message


def test_travel_time_cost_checker():
    def cost(tau, D, theta, dc, c):
        ce = c - dc
        p = ce * tau[0] * np.array([np.cos(theta), np.sin(theta)]) + np.asarray(D)
        return float(np.sum((np.linalg.norm(p, axis=1) / ce - np.asarray(tau)) ** 2))

    def wrong_sign(tau, D, theta, dc, c):
        return cost(tau, D, theta, -dc, c)

    def ranges(tau, D, theta, dc, c):
        ce = c - dc
        p = ce * tau[0] * np.array([np.cos(theta), np.sin(theta)]) + np.asarray(D)
        return float(np.sum((np.linalg.norm(p, axis=1) - ce * np.asarray(tau)) ** 2))

    assert ch03.check_travel_time_cost(cost)
    fb = ch03.check_travel_time_cost(wrong_sign)
    assert not fb and "c_e = c − Δc" in fb.hint
    fb = ch03.check_travel_time_cost(ranges)
    assert not fb
    assert not ch03.check_travel_time_cost(None)


def test_travel_time_cost_reference_is_the_library_cost():
    tau = np.array([2.0, 1.99, 1.98, 1.975])
    D = np.array([[0.0, 0.0], [20.0, 0.0], [40.0, 2.0], [55.0, 15.0]])
    ref = ch03.travel_time_cost_reference(tau, D, 3.5, -30.0, 1470.0)
    ce = 1500.0
    p = ce * tau[0] * np.array([np.cos(3.5), np.sin(3.5)]) + D
    assert ref == pytest.approx(np.sum((np.linalg.norm(p, axis=1) / ce - tau) ** 2), rel=1e-10)


# --- chapter 4 ----------------------------------------------------------------------------------------------------

def test_range_jacobian_checker():
    assert ch04.check_range_jacobian([0.6, -0.8])
    assert ch04.check_range_jacobian([[0.6, -0.8]])
    assert "from the beacon to the vehicle" in ch04.check_range_jacobian([-0.6, 0.8]).hint
    assert "unit vector" in ch04.check_range_jacobian([300.0, -400.0]).hint
    assert "squared range" in ch04.check_range_jacobian([600.0, -800.0]).hint
    p = np.array(ch04.JACOBIAN_POSITION)
    assert "beacon's position" in ch04.check_range_jacobian(p / np.linalg.norm(p)).hint
    assert not ch04.check_range_jacobian(None)


def numpy_update(x, P, z, R, beacon):
    x = np.asarray(x, float)
    d = x - np.asarray(beacon, float)
    h = np.linalg.norm(d)
    H = d / h
    S = H @ P @ H + R
    K = P @ H / S
    return x + K * (z - h), (np.eye(2) - np.outer(K, H)) @ P


def test_ekf_update_reference_equals_filterpy_to_1e9():
    for case in ch04._update_cases():
        x, P, z, R, b = case.args
        ekf = ExtendedKalmanFilter(dim_x=2, dim_z=1)
        ekf.x = np.array(x, float).reshape(2, 1)
        ekf.P = np.array(P, float)
        ekf.R = np.array([[R]])
        bb = np.asarray(b, float).reshape(2, 1)
        ekf.update(np.array([[z]]), lambda s: ((s - bb) / np.linalg.norm(s - bb)).T,
                   lambda s: np.array([[np.linalg.norm(s - bb)]]))
        x_ref, P_ref = ch04.ekf_update_reference(x, P, z, R, b)
        np.testing.assert_allclose(x_ref, ekf.x[:, 0], rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(P_ref, ekf.P, rtol=1e-9, atol=1e-9)


def test_ekf_update_checker():
    assert ch04.check_ekf_update(numpy_update)

    def flipped(x, P, z, R, b):
        xn, Pn = numpy_update(x, P, z, R, b)
        return 2 * np.asarray(x, float) - xn, Pn

    def no_r(x, P, z, R, b):
        return numpy_update(x, P, z, 1e-12, b)

    def x_only(x, P, z, R, b):
        return numpy_update(x, P, z, R, b)[0]

    fb = ch04.check_ekf_update(flipped)
    assert not fb and "z − h(x)" in fb.hint
    assert not ch04.check_ekf_update(no_r)
    assert "return two things" in ch04.check_ekf_update(x_only).message
    assert not ch04.check_ekf_update(None)


def test_nees_checker():
    e = np.array(ch04.NEES_TRUTH) - np.array(ch04.NEES_ESTIMATE)
    P = np.array(ch04.NEES_COVARIANCE)
    assert ch04.check_nees(e @ np.linalg.inv(P) @ e)
    assert "inverse" in ch04.check_nees(e @ P @ e).hint
    assert "no units" in ch04.check_nees(e @ e).hint
    assert "correlation" in ch04.check_nees(np.sum(e**2 / np.diag(P))).hint


def test_nees_bounds_checker():
    good = stats.chi2.ppf([0.025, 0.975], 100) / 50
    assert ch04.check_nees_bounds(good)
    assert "M·n degrees of freedom" in ch04.check_nees_bounds(stats.chi2.ppf([0.025, 0.975], 2)).hint
    assert "Divide by M" in ch04.check_nees_bounds(stats.chi2.ppf([0.025, 0.975], 100)).hint
    assert "2.5 %" in ch04.check_nees_bounds(stats.chi2.ppf([0.05, 0.95], 100) / 50).hint
    assert not ch04.check_nees_bounds(good[::-1])


def test_diagnosis_checker():
    studies = ch04.diagnosis_studies()
    consistent, over, under = ch04._classify(studies)
    assert {consistent, over, under} == {"A", "B", "C"}
    assert ch04.check_diagnosis(consistent, over)
    assert ch04.check_diagnosis(consistent, f" {over} ")
    lower = ch04.check_diagnosis(consistent.lower(), over)
    assert not lower and "capital letter" in lower.message and f'"{consistent}"' in lower.message
    assert "underconfident" in ch04.check_diagnosis(consistent, under).message
    assert "both" in ch04.check_diagnosis(over, over).message
    assert not ch04.check_diagnosis(under, over)
    assert "letters" in ch04.check_diagnosis("D", over).message
    assert "No answer yet" in ch04.check_diagnosis(None, over).message


# --- exercise 4.6: a whole EKF run --------------------------------------------------------------------------------
def _student_update(x, P, z, R, beacon):
    d = x - np.asarray(beacon, dtype=float)
    h = np.linalg.norm(d)
    H = d / h
    K = P @ H / (H @ P @ H + R)
    return x + K * (z - h), (np.eye(2) - np.outer(K, H)) @ P


def test_ekf_run_checker_accepts_a_loop_written_by_hand():
    def ekf_run(x0, P0, u, z, Q, R, beacon):
        x, P = np.array(x0, dtype=float), np.array(P0, dtype=float)
        out = np.empty((len(z), 2))
        for k in range(len(z)):
            x, P = x + u[k], P + Q
            if not np.isnan(z[k]):
                x, P = _student_update(x, P, z[k], R, beacon)
            out[k] = x
        return out

    assert ch04.check_ekf_run(ekf_run).correct
    d = ch04.run_data()
    est = ekf_run(d["x0"], d["P0"], d["u"], d["z"], d["Q"], d["R"], d["beacon"])
    assert np.linalg.norm(d["x0"] - d["truth"][0]) == pytest.approx(40.0)
    assert np.linalg.norm(est[-1] - d["truth"][-1]) < 10.0          # the run converges from its 40 m start


def test_ekf_run_checker_names_the_slips():
    def no_nan_check(x0, P0, u, z, Q, R, beacon):
        x, P = np.array(x0, dtype=float), np.array(P0, dtype=float)
        out = np.empty((len(z), 2))
        for k in range(len(z)):
            x, P = x + u[k], P + Q
            x, P = _student_update(x, P, z[k], R, beacon)             # a NaN range poisons the rest
            out[k] = x
        return out

    def update_then_predict(x0, P0, u, z, Q, R, beacon):
        x, P = np.array(x0, dtype=float), np.array(P0, dtype=float)
        out = np.empty((len(z), 2))
        for k in range(len(z)):
            if not np.isnan(z[k]):
                x, P = _student_update(x, P, z[k], R, beacon)
            x, P = x + u[k], P + Q
            out[k] = x
        return out

    fb = ch04.check_ekf_run(no_nan_check)
    assert not fb and "NaN" in fb.message and "missing replies" not in fb.hint
    fb = ch04.check_ekf_run(update_then_predict)
    assert not fb and "Predict first" in fb.hint
