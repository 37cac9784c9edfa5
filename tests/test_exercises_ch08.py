"""Chapter 8 checkers: the right answers pass, the usual mistakes get the hint that explains them."""

from __future__ import annotations

import numpy as np
import pytest

from uwtutor.exercises import Feedback, ch08


def _text(fb: Feedback) -> str:
    return f"{fb.message}\n{fb.hint or ''}"


# -- expected values computed here, independently of the checkers ------------------------------------------------------
RANGE_ERROR = 1500.0 * (0.4e-3 + 5e-6 * 2000.0)        # 15.6 m


def resolve(wrapped, predicted_range):
    """An independent solution of exercise 8.2."""
    w = np.asarray(wrapped, float)
    n = np.rint(np.asarray(predicted_range, float) / 1500.0 - w)
    return w + np.where(n < 0, 0.0, n)


def pair_jacobian(x_pred, leader_k, leader_k1, u_k, dt):
    """An independent solution of exercise 8.3, by central differences of the squared ranges."""
    def h(x):
        p_prev = x[:2] - u_k - dt * x[2:]
        return np.array([np.sum((p_prev - leader_k) ** 2), np.sum((x[:2] - leader_k1) ** 2)])
    x = np.asarray(x_pred, float)
    cols = []
    for i in range(4):
        d = np.zeros(4)
        d[i] = 1e-4
        cols.append((h(x + d) - h(x - d)) / 2e-4)
    return np.stack(cols, axis=1)


def literal_jacobian(x_pred, leader_k, leader_k1, u_k, dt):
    """Paper B's eq. (11) evaluated at the predicted state, as printed."""
    p, U = x_pred[:2], x_pred[2:]
    a = p - leader_k
    c = p + u_k + dt * U - leader_k1
    return np.array([[*(2 * a), 0.0, 0.0], [*(2 * c), *(2 * dt * c)]])


def test_exercise_data_are_what_the_notebook_says():
    assert (ch08.CLOCK_OFFSET, ch08.CLOCK_DRIFT, ch08.CLOCK_TIME, ch08.SOUND_SPEED) == (0.4e-3, 5e-6, 2000.0, 1500.0)
    assert (ch08.STUDY_SEED, ch08.STUDY_RUNS, ch08.LATE_WINDOW) == (8, 200, 1000.0)
    assert RANGE_ERROR == pytest.approx(15.6)


@pytest.mark.parametrize("check, answer", [
    (ch08.check_clock_range_error, RANGE_ERROR),
    (ch08.check_resolve, resolve),
    (ch08.check_resolve, ch08.resolve_reference),
    (ch08.check_largest_prediction_error, 750.0),
    (ch08.check_pair_jacobian, pair_jacobian),
    (ch08.check_pair_jacobian, ch08.pair_jacobian_reference),
    (ch08.check_unobservable_pattern, "parallel"),
])
def test_right_answers_pass(check, answer):
    fb = check(answer)
    assert fb.correct, str(fb)


def range_jacobian(x, b0, b1, u, dt):
    # the Jacobian of the ranges, not of the squared ranges: each row divided by 2r
    J = ch08.pair_jacobian_reference(x, b0, b1, u, dt)
    return J / np.linalg.norm(J[:, :2], axis=-1)[:, None]


@pytest.mark.parametrize("check, answer, words", [
    (ch08.check_clock_range_error, 1500.0 * 0.4e-3, "offset alone"),
    (ch08.check_clock_range_error, 1500.0 * 5e-6 * 2000.0, "drift alone"),
    (ch08.check_clock_range_error, RANGE_ERROR / 2, "One-way"),
    (ch08.check_largest_prediction_error, 1500.0, "nearest"),
    (ch08.check_largest_prediction_error, 0.5, "seconds"),
    (ch08.check_resolve, lambda w, r: np.asarray(w) + np.floor(np.asarray(r) / 1500.0 - np.asarray(w)), "nearest"),
    (ch08.check_resolve, lambda w, r: np.asarray(w) + np.round(np.asarray(r) / 1500.0 - np.asarray(w)), "negative"),
    (ch08.check_pair_jacobian, literal_jacobian, "as printed"),
    (ch08.check_pair_jacobian, range_jacobian, "squared ranges"),
    (ch08.check_unobservable_pattern, "zigzag", "bends"),
    (ch08.check_unobservable_pattern, "square", "not a leader pattern"),
])
def test_usual_mistakes_get_their_hint(check, answer, words):
    fb = check(answer)
    assert not fb.correct
    assert words in _text(fb), _text(fb)


def test_no_answer_yet():
    for check in (ch08.check_clock_range_error, ch08.check_resolve, ch08.check_pair_jacobian,
                  ch08.check_leader_errors, ch08.check_unobservable_pattern):
        fb = check(None)
        assert not fb.correct and "answer" in fb.message.lower()


def test_leader_study_and_its_checker():
    expected = ch08.leader_study()
    assert set(expected) == {"zigzag", "parallel", "circling"}
    # the parallel leader is far worse than the two that turn
    assert expected["parallel"] > 10 * max(expected["zigzag"], expected["circling"])
    assert ch08.check_leader_errors(dict(expected)).correct
    wrong = dict(expected, zigzag=2 * expected["zigzag"])
    fb = ch08.check_leader_errors(wrong)
    assert not fb.correct and "zigzag" in fb.message
    fb = ch08.check_leader_errors({"zigzag": 1.0})
    assert not fb.correct and "parallel" in fb.message
    assert not ch08.check_leader_errors([1, 2, 3]).correct
