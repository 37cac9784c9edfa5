"""Chapter 9 checkers: the right answers pass, the usual mistakes get the hint that explains them."""

from __future__ import annotations

import numpy as np
import pytest

from uwtutor.exercises import Feedback, ch09
from uwtutor.filters import robust_range_kf
from uwtutor.scenarios import paper_e


def _text(fb: Feedback) -> str:
    return f"{fb.message}\n{fb.hint or ''}"


# -- expected values computed here, independently of the checkers ------------------------------------------------------
D = 3.0 + 2000.0**2
Y_MAX = np.sqrt(1.03 * D) - 2000.0
Y_MIN = np.sqrt(0.97 * D) - 2000.0                       # the lower edge of the gate
VB = ch09.SHIP + (ch09.DR[-1] - ch09.DR)


def _good_rejected(reacquire):
    dive = paper_e.make(np.random.default_rng(1), 1)
    res = robust_range_kf(dive.slant_ranges[0], 1.0, reacquire=reacquire)
    good = ~np.asarray(dive.outlier_mask[0])
    return res, good


def test_exercise_data_are_what_the_notebook_says():
    assert (ch09.Z_PRED, ch09.S_INNOV, ch09.DELTA) == (2000.0, 3.0, 0.03)
    assert ch09.LOCKOUT_SEED == 1 and (ch09.STUDY_SEED, ch09.STUDY_SPACING) == (58, 40)
    assert Y_MAX == pytest.approx(29.78, abs=0.01)
    np.testing.assert_array_equal(VB[-1], ch09.SHIP[-1])


def test_right_answers_pass():
    for check, answer in [(ch09.check_gate_upper, Y_MAX), (ch09.check_gate_upper, round(Y_MAX, 2)),
                          (ch09.check_equivalent_nis, Y_MAX**2 / 3.0), (ch09.check_virtual_beacons, VB),
                          (ch09.check_virtual_beacons, VB.tolist())]:
        fb = check(answer)
        assert fb.correct, _text(fb)
    literal, good = _good_rejected(None)
    n = int(np.sum(literal.extras["rejected"] & good))
    assert n > 20                                           # the dive really locks out
    assert ch09.check_good_rejected(n).correct
    s = ch09.study()
    err = np.linalg.norm(s["result"].fixes - s["truth"], axis=-1)
    fraction = float(np.mean(err <= 0.1 * s["slant"]))
    assert 0.5 < fraction < 0.99                            # the exercise is not trivial
    assert ch09.check_within_ten_percent(fraction).correct


@pytest.mark.parametrize("check, answer, fragment", [
    (ch09.check_gate_upper, 0.03 * 2000.0, "δ/2"),
    (ch09.check_gate_upper, np.sqrt(1.03 * D), "minus the prediction"),
    (ch09.check_gate_upper, 0.03 * D, "m²"),
    (ch09.check_gate_upper, Y_MIN, "lower edge"),
    (ch09.check_gate_upper, round(-Y_MIN, 2), "lower edge"),
    (ch09.check_equivalent_nis, Y_MAX / np.sqrt(3.0), "square"),
    (ch09.check_equivalent_nis, 6.634896601021214, "chi-square gate"),
    (ch09.check_equivalent_nis, Y_MAX**2, "divides by S"),
    (ch09.check_virtual_beacons, ch09.SHIP - (ch09.DR[-1] - ch09.DR), "forward"),
    (ch09.check_virtual_beacons, ch09.SHIP + (ch09.DR - ch09.DR[0]), "to *now*"),
])
def test_mistakes_get_their_hint(check, answer, fragment):
    fb = check(answer)
    assert not fb.correct
    assert fragment in _text(fb), _text(fb)


def test_lockout_and_ten_percent_mistakes():
    literal, good = _good_rejected(None)
    default, _ = _good_rejected(20)
    assert "outliers included" in _text(ch09.check_good_rejected(int(literal.extras["rejected"].sum())))
    assert "re-acquisition" in _text(ch09.check_good_rejected(int(np.sum(default.extras["rejected"] & good))))
    s = ch09.study()
    err = np.linalg.norm(s["result"].fixes - s["truth"], axis=-1)
    fraction = float(np.mean(err <= 0.1 * s["slant"]))
    assert "percentage" in _text(ch09.check_within_ten_percent(100 * fraction))
    assert "10 m" in _text(ch09.check_within_ten_percent(float(np.mean(err <= 10.0))))
    assert "No answer yet" in _text(ch09.check_within_ten_percent(None))
    assert ch09.check_within_ten_percent(round(fraction, 2)).correct          # the task asks for no precision
    n = int(np.sum(literal.extras["rejected"] & good))
    assert "off-by-one" in _text(ch09.check_good_rejected(n + 1))


def test_the_approximation_of_the_gate_is_not_its_edge():
    """δẑ/2 = 30 m lies outside the gate (30² > (1 + δ)D − ...): 9.1 asks for the largest innovation accepted."""
    z = ch09.Z_PRED + 0.03 * 2000.0 / 2
    assert z**2 > (1 + ch09.DELTA) * (ch09.S_INNOV + ch09.Z_PRED**2)          # the test rejects it
    fb = ch09.check_gate_upper(0.03 * 2000.0 / 2)
    assert not fb.correct and "first-order approximation" in fb.hint


def test_gate_by_hand_has_its_own_hints():
    """9.3(b) is checked with the count of (a), but its hints are those of a gate written by hand."""
    counts = ch09._hand_gate_counts()
    n = counts["right"]
    assert ch09.check_gate_by_hand(n).correct
    assert "applies δ to the range" in ch09.check_gate_by_hand(counts["on_range"]).hint
    assert "D = S + ẑ²" in ch09.check_gate_by_hand(counts["no_s"]).hint
    assert "must not update" in ch09.check_gate_by_hand(counts["update_rejected"]).hint
    assert "outliers included" in ch09.check_gate_by_hand(counts["all"]).hint
    assert "reacquire" not in ch09.check_gate_by_hand(counts["on_range"]).hint
