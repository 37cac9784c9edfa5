"""Chapter 2 checkers: the right answers pass, the usual mistakes get the hint that explains them."""

from __future__ import annotations

import math

import numpy as np
import pytest

from uwtutor import motion, observability
from uwtutor.exercises import Feedback, ch02


def _text(fb: Feedback) -> str:
    return f"{fb.message}\n{fb.hint or ''}"


def _unit(p, b):
    d = np.asarray(p, float) - np.asarray(b, float)
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


# -- expected values computed here, independently of the checkers ------------------------------------------------------
H3 = _unit(ch02.FIX_POSITION, ch02.FIX_BEACONS)
J3 = H3.T @ H3 / ch02.FIX_SIGMA**2


def _mirror_pair():
    b, (r1, r2), u = ch02.MIRROR_BEACON, ch02.MIRROR_RANGES, ch02.MIRROR_DISPLACEMENT
    d = np.linalg.norm(u)
    e = u / d
    a = (r2**2 - r1**2 + d**2) / (2 * d)
    h = math.sqrt(r2**2 - a**2)
    perp = np.array([-e[1], e[0]])
    return np.array([b + a * e + h * perp, b + a * e - h * perp])


def _straight_h():
    pos = ch02.CURRENT_START + ch02.CURRENT_TIMES[:, None] * ch02.CURRENT_VELOCITY
    h = _unit(pos, [0.0, 0.0])
    return np.hstack([h, ch02.CURRENT_TIMES[:, None] * h])


def test_exercise_data_are_what_the_notebook_says():
    np.testing.assert_allclose(J3, [[0.375, 0.125], [0.125, 0.375]])
    np.testing.assert_allclose(_mirror_pair()[0], [-100.0, 400.0], atol=1e-9)   # the true position is one of them
    assert ch02.turn_track(0.0).positions[-1] == pytest.approx([900.0, 600.0])


@pytest.mark.parametrize("check, answer", [
    (ch02.check_fisher_information, J3),
    (ch02.check_fisher_information, J3.tolist()),
    (ch02.check_rmse_bound, math.sqrt(6.0)),
    (ch02.check_mirror_solutions, _mirror_pair()),
    (ch02.check_mirror_solutions, _mirror_pair()[::-1]),
    (ch02.check_straight_current_rank, 3),
    (ch02.check_straight_current_rank, np.int64(3)),
    (ch02.check_unobservable_direction, [-600.0, -1500.0, 0.0, 2.0]),
    (ch02.check_unobservable_direction, -2.5 * np.array([-600.0, -1500.0, 0.0, 2.0])),
    (ch02.check_turned_current_rank, 4),
])
def test_right_answers_pass(check, answer):
    fb = check(answer)
    assert fb.correct, _text(fb)


def test_the_halving_turn_angle():
    # independent: bisection on the bound computed with the library's track CRLB, state [x, y, Ux, Uy]
    def bound(a):
        tr = motion.turning_track(ch02.TURN_TIMES, ch02.TURN_START, 2.0, [0.0, math.radians(a)], [600.0])
        with pytest.warns(observability.UnobservableWarning):
            C = observability.track_crlb(tr.positions, (0.0, 0.0), 5.0, times=ch02.TURN_TIMES, unknown_current=True)
        return observability.rmse_bound(C[-1])

    target = bound(10.0) / 2
    lo, hi = 10.0, 60.0
    for _ in range(40):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if bound(mid) > target else (lo, mid)
    assert 20.0 < lo < 30.0
    assert ch02.check_halving_turn_angle(lo).correct
    assert ch02.check_halving_turn_angle(lo + 0.2).correct
    assert not ch02.check_halving_turn_angle(lo + 1.0).correct
    assert ch02.turn_rmse_bound(lo) == pytest.approx(target, rel=1e-6)


@pytest.mark.parametrize("check, answer, hint_fragment", [
    (ch02.check_fisher_information, np.linalg.inv(J3), "Cramér–Rao bound"),
    (ch02.check_fisher_information, J3 * 4.0, "Divide by the range variance"),
    (ch02.check_fisher_information, J3 * 2.0, "not by the standard deviation"),
    (ch02.check_fisher_information, J3 * 16.0, "do not multiply"),
    (ch02.check_fisher_information, (ch02.FIX_POSITION - ch02.FIX_BEACONS).T
     @ (ch02.FIX_POSITION - ch02.FIX_BEACONS) / 4.0, "unit line-of-sight"),
    (ch02.check_fisher_information, np.outer(H3.sum(0), H3.sum(0)) / 4.0, "outer products"),
    (ch02.check_fisher_information, J3[0], "shape"),
    (ch02.check_rmse_bound, 6.0, "square root"),
    (ch02.check_rmse_bound, math.sqrt(3.0), "x only"),
    (ch02.check_rmse_bound, math.sqrt(8.0), "determinant"),
    (ch02.check_rmse_bound, 2.0, "longest semi-axis"),
    (ch02.check_rmse_bound, 1 / math.sqrt(0.75), "Invert the matrix first"),
    (ch02.check_mirror_solutions, _mirror_pair() - ch02.MIRROR_DISPLACEMENT, "first range"),
    (ch02.check_mirror_solutions, _mirror_pair()[0], "one position"),
    (ch02.check_mirror_solutions, _mirror_pair()[:, ::-1], ""),
    (ch02.check_halving_turn_angle, 20.0, "Doubling the turn"),
    (ch02.check_halving_turn_angle, -24.3, "to the left"),
    (ch02.check_straight_current_rank, 4, "Rank 4 would make"),
    (ch02.check_straight_current_rank, 2, "t_k h_k"),
    (ch02.check_straight_current_rank, 2.5, "whole number"),
    (ch02.check_unobservable_direction, [0.0, 0.0, 0.0, 0.0], "zero vector"),
    (ch02.check_unobservable_direction, [-600.0, -1500.0, 0.0, 0.0], "the velocity must turn with it"),
    (ch02.check_unobservable_direction, [0.0, 0.0, 0.0, 2.0], "turn the start point"),
    (ch02.check_unobservable_direction, [-600.0, -1500.0, 0.0, -2.0], "same way"),
    (ch02.check_unobservable_direction, [1.0, 2.0, 3.0], "shape (4,)"),
    (ch02.check_turned_current_rank, 3, "follow the turn"),
])
def test_mistakes_get_their_hint(check, answer, hint_fragment):
    fb = check(answer)
    assert not fb.correct
    assert hint_fragment in _text(fb), _text(fb)


def test_mirror_mistakes_with_the_virtual_beacon_on_the_wrong_side_and_swapped_ranges():
    import warnings

    b, r, u = ch02.MIRROR_BEACON, ch02.MIRROR_RANGES, ch02.MIRROR_DISPLACEMENT
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", observability.UnobservableWarning)
        wrong_side = observability.two_range_fix(b, r, -u)
        swapped = observability.two_range_fix(b, r[::-1], u)
    assert "b + u, not b − u" in _text(ch02.check_mirror_solutions(wrong_side))
    assert "b + u, not b − u" in _text(ch02.check_mirror_solutions(wrong_side[::-1]))
    assert "swapped" in _text(ch02.check_mirror_solutions(swapped))


@pytest.mark.parametrize("check", [ch02.check_fisher_information, ch02.check_rmse_bound, ch02.check_mirror_solutions,
                                   ch02.check_halving_turn_angle, ch02.check_straight_current_rank,
                                   ch02.check_unobservable_direction, ch02.check_turned_current_rank])
@pytest.mark.parametrize("answer", [None, "3", float("nan"), True])
def test_unanswered_and_odd_answers_get_feedback_not_tracebacks(check, answer):
    fb = check(answer)
    assert isinstance(fb, Feedback) and not fb.correct
    if answer is None:
        assert "No answer yet" in fb.message


def test_the_singular_vector_of_the_students_matrix_is_accepted():
    H = _straight_h()
    assert np.linalg.matrix_rank(H) == 3
    v = np.linalg.svd(H)[2][-1]
    assert np.linalg.norm(H @ v) < 1e-9 * np.linalg.norm(H)
    assert ch02.check_unobservable_direction(v).correct
