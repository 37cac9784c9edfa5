"""Chapter 7 checkers: the right answers pass, the usual mistakes get the hint that explains them."""

from __future__ import annotations

import numpy as np
import pytest

from uwtutor.exercises import Feedback, ch07


def _text(fb: Feedback) -> str:
    return f"{fb.message}\n{fb.hint or ''}"


# -- expected values computed here, independently of the checkers ------------------------------------------------------
Q_RIGHT = np.diag([0.64, 0.36, 0.5])
D = np.array([-800.0, 600.0])                   # (-700, 550) - (100, -50)
H_RIGHT = np.array([-0.8, 0.6, 1.0])


def weak_direction():
    p = ch07.straight_track()
    phi = np.arctan2(p[:, 1], p[:, 0])
    A = np.column_stack([np.cos(phi), np.sin(phi), np.ones(len(p))])
    w, V = np.linalg.eigh(A.T @ A)              # smallest eigenvalue first
    return V[:, 0]


def start_count(threshold=1.0, bias=True):
    phi = np.radians(-90.0 + 0.4 * np.arange(1000))
    rows = np.column_stack([np.cos(phi), np.sin(phi)] + ([np.ones(1000)] if bias else []))
    for n in range(1, 1001):
        N = rows[:n].T @ rows[:n]
        if np.linalg.matrix_rank(N) == N.shape[0] and np.trace(np.linalg.inv(N)) < threshold:
            return n
    raise AssertionError("never")


def test_exercise_data_are_what_the_notebook_says():
    assert ch07.NOISE_SIGMAS == (0.8, 0.6)
    assert ch07.JACOBIAN_BEACON == (100.0, -50.0) and ch07.JACOBIAN_STATE == (-700.0, 550.0, 12.0)
    p = ch07.straight_track()
    assert p.shape == (40, 2) and np.allclose(np.diff(p, axis=0), np.diff(p, axis=0)[0])
    assert np.linalg.norm(np.diff(p, axis=0)[0]) == pytest.approx(10.0)
    assert (ch07.START_RADIUS, ch07.START_SPACING_DEG, ch07.START_THRESHOLD) == (1500.0, 0.4, 1.0)
    assert set(ch07.DIAGNOSIS_FILTERS) == {"A", "B", "C"}


def test_weak_direction_is_along_the_line_of_sight_against_the_bias():
    v = weak_direction()
    mid = ch07.straight_track()[20] / np.linalg.norm(ch07.straight_track()[20])
    expected = np.r_[mid, -1.0] / np.sqrt(2.0)
    assert abs(v @ expected) > 0.999


@pytest.mark.parametrize("check, answer", [
    (ch07.check_bias_noise, Q_RIGHT),
    (ch07.check_augmented_jacobian, H_RIGHT),
    (ch07.check_augmented_jacobian, H_RIGHT[None]),
    (ch07.check_weak_direction, weak_direction()),
    (ch07.check_weak_direction, -weak_direction()),
    (ch07.check_start_count, start_count()),
])
def test_right_answers_pass(check, answer):
    fb = check(answer)
    assert fb.correct, _text(fb)


def test_start_count_is_a_demand_on_the_geometry():
    assert start_count() > start_count(2.0) > 1
    fb = ch07.check_start_count(start_count())
    assert "turned by" in fb.message


@pytest.mark.parametrize("check, answer, fragment", [
    (ch07.check_bias_noise, np.diag([0.8, 0.6, 0.7]), "standard deviations"),
    (ch07.check_bias_noise, np.diag([0.64, 0.36, 0.49]), "average"),
    (ch07.check_bias_noise, np.diag([0.64, 0.36, 1.0]), "Halve"),
    (ch07.check_bias_noise, np.diag([0.64, 0.36, 0.0]), "constant"),
    (ch07.check_bias_noise, np.diag([0.64, 0.36]), "3x3"),
    (ch07.check_augmented_jacobian, np.array([-0.8, 0.6, 0.0]), "not 0"),
    (ch07.check_augmented_jacobian, np.array([0.8, -0.6, 1.0]), "grows"),
    (ch07.check_augmented_jacobian, np.r_[D / (1000.0 + 12.0), 1.0], "geometric range"),
    (ch07.check_augmented_jacobian, np.array([-0.8, 0.6]), "three"),
    (ch07.check_augmented_jacobian, np.r_[D, 1.0], "Normalize"),
    (ch07.check_weak_direction, np.r_[np.array([-1.0, 1.0]) / np.sqrt(2.0), 0.0], "position alone"),
    (ch07.check_weak_direction, 2 * weak_direction(), "unit vector"),
    (ch07.check_weak_direction, np.ones(2), "3 numbers"),
    (ch07.check_weak_direction, np.array([0.0, 0.0, 1.0]), "angle"),
    (ch07.check_start_count, start_count() - 1, "0-based"),
    (ch07.check_start_count, start_count() + 1, "off-by-one"),
    (ch07.check_start_count, start_count(2.0), "α < 2"),
    (ch07.check_start_count, start_count(bias=False), "position alone"),
])
def test_mistakes_get_their_hint(check, answer, fragment):
    fb = check(answer)
    assert not fb.correct
    assert fragment in _text(fb), _text(fb)


def test_strongest_direction_is_recognised():
    p = ch07.straight_track()
    phi = np.arctan2(p[:, 1], p[:, 0])
    A = np.column_stack([np.cos(phi), np.sin(phi), np.ones(len(p))])
    strongest = np.linalg.eigh(A.T @ A)[1][:, -1]
    fb = ch07.check_weak_direction(strongest)
    assert not fb.correct and "best" in fb.message


def test_diagnosis_studies_and_checker():
    studies = ch07.bias_diagnosis_studies()
    lo, hi = studies["bounds"]
    late = {k: studies[k][500:].mean() for k in "ABC"}
    assert late["A"] > 10 * hi                  # the random walk lags the ramp
    assert lo < late["B"] < hi                  # the rate state follows it
    assert late["C"] < lo                       # a huge bias noise follows it, claiming too much uncertainty
    assert ch07.check_bias_diagnosis("B", "A").correct
    assert ch07.check_bias_diagnosis(" b ", "a").correct
    for c, o, fragment in (("A", "A", "both"), ("B", "C", "below"), ("C", "A", "not the consistent"),
                           ("B", "x", "letters"), (None, "A", "No answer")):
        fb = ch07.check_bias_diagnosis(c, o)
        assert not fb.correct and fragment in _text(fb), _text(fb)


@pytest.mark.parametrize("check", [ch07.check_bias_noise, ch07.check_augmented_jacobian, ch07.check_weak_direction,
                                   ch07.check_start_count])
def test_unanswered(check):
    fb = check(None)
    assert not fb.correct and "No answer yet" in fb.message
