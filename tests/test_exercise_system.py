"""The exercise system: feedback, generic checkers, chapter-1 checkers, the student-version generator, the command."""

from __future__ import annotations

import dataclasses
import math
import re
import sys
from pathlib import Path

import nbformat
import numpy as np
import pytest

import cpu_limits
from nbformat.v4 import new_code_cell, new_markdown_cell, new_notebook, new_output

import uwtutor
from uwtutor.exercises import Case, Feedback, ch01, ch04, check_array, check_function, check_number
from uwtutor.exercises import generate
from uwtutor.exercises.checks import DEFAULT_HINT
from uwtutor.exercises.cli import main
from uwtutor.exercises.generate import (STUB_MESSAGE, ExerciseSourceError, list_exercise_sources,
                                        make_student_version, write_student_versions)

REPO = Path(__file__).resolve().parents[1]
SOURCE_DIR = REPO / "exercises"


def _text(fb: Feedback) -> str:
    return f"{fb.message}\n{fb.hint or ''}"


# =====================================================================================================================
# Feedback
# =====================================================================================================================
class TestFeedback:
    def test_truth_value_follows_correct(self):
        assert Feedback(True, "Correct: 1800 m.")
        assert not Feedback(False, "Not yet.", hint="Halve it.")

    def test_text_display_has_mark_message_and_hint(self):
        fb = Feedback(False, "Your answer is twice the expected value.", hint="A two-way time covers the path twice.")
        assert repr(fb) == str(fb)
        assert str(fb).startswith("✘ Your answer is twice")
        assert "Hint: A two-way time covers the path twice." in str(fb)
        assert str(Feedback(True, "Correct.")) == "✔ Correct."

    def test_rich_displays_escape_html_and_show_hint(self):
        fb = Feedback(False, "a < b & `x`", hint="use <code>")
        html = fb._repr_html_()
        assert "&lt; b &amp;" in html and "<code>x</code>" in html and "use &lt;code&gt;" in html
        assert "✘" in html and "Hint" in html
        assert "✔" in Feedback(True, "ok")._repr_html_()

    def test_html_renders_the_inline_markup_instead_of_showing_it(self):
        fb = Feedback(False, "That is eᵀ P e; the NEES weights the error with the *inverse* covariance.",
                      hint="Compare with χ²_{Mn}(q)/M, **not** with `P_k * 2`; x_{i+1} − x_i and e^{−ak}.")
        html = fb._repr_html_()
        assert "<em>inverse</em>" in html and "*inverse*" not in html
        assert "χ²<sub>Mn</sub>(q)/M" in html and "_{" not in html
        assert "<strong>not</strong>" in html
        assert "<code>P_k * 2</code>" in html  # code is left exactly as written
        assert "x<sub>i+1</sub> − x<sub>i</sub>" in html and "e<sup>−ak</sup>" in html
        assert "*" not in html.replace("<code>P_k * 2</code>", "")
        assert not hasattr(fb, "_repr_markdown_"), "one rich display (HTML), so no front end shows raw Markdown"

    def test_assert_correct_wraps_long_messages(self):
        fb = Feedback(False, "Not yet.", hint="word " * 60)
        with pytest.raises(AssertionError) as info:
            fb.assert_correct()
        lines = str(info.value).split("\n")
        assert len(lines) > 2 and all(len(line) <= 100 for line in lines)
        assert all(line.startswith("  ") for line in lines[1:])

    def test_frozen_and_validated(self):
        fb = Feedback(True, "ok")
        with pytest.raises(dataclasses.FrozenInstanceError):
            fb.correct = False  # type: ignore[misc]
        with pytest.raises(ValueError):
            Feedback(True, "  ")
        assert Feedback(1, "ok").correct is True  # coerced to bool

    def test_assert_correct(self):
        ok = Feedback(True, "ok")
        assert ok.assert_correct() is ok
        with pytest.raises(AssertionError, match="twice"):
            Feedback(False, "twice", hint="halve").assert_correct()


# =====================================================================================================================
# check_number
# =====================================================================================================================
class TestCheckNumber:
    kw = dict(name="the range", units="m")

    def test_correct_within_tolerance(self):
        fb = check_number(1800.5, 1800.0, rtol=1e-3, explanation="Half of c·t.", **self.kw)
        assert fb and fb.message == "Correct: the range is 1800.5 m. Half of c·t."
        assert not check_number(1802.0, 1800.0, rtol=1e-3, **self.kw)

    @pytest.mark.parametrize("answer", [None, ...])
    def test_not_answered(self, answer):
        fb = check_number(answer, 1800.0, **self.kw)
        assert not fb
        assert fb.message == "No answer yet: replace `None` with the range in m (a number)."
        assert "NotImplementedError" in fb.hint

    @pytest.mark.parametrize("answer, fragment", [
        ("1800", "Remove the quotes"),
        ("eighteen hundred", "the text 'eighteen hundred'"),
        (True, "a truth value"),
        ([1800.0, 900.0], "a list of 2 numbers"),
        (np.ones(3), "NumPy array of 3 numbers"),
        ([], "an empty list"),
        ({"r": 1800}, "a dict"),
        (print, "a function"),
        (object(), "the range should be a number"),
        (1800 + 2j, "complex"),
        (1800 + 0j, "the type is complex"),            # a complex type is a symptom even with a zero imaginary part
        (np.array([1800.0 + 0j]), "the type is complex"),
        (10**400, "too large for a floating-point number"),
        (float("nan"), "NaN"),
        (math.inf, "infinite"),
    ])
    def test_wrong_types_give_feedback_not_tracebacks(self, answer, fragment):
        fb = check_number(answer, 1800.0, **self.kw)
        assert isinstance(fb, Feedback) and not fb
        assert fragment in _text(fb)

    @pytest.mark.parametrize("answer", [np.float32(1800.0), np.int64(1800), np.array(1800.0), [1800.0],
                                        np.array([[1800.0]])])
    def test_number_like_answers_are_accepted(self, answer):
        assert check_number(answer, 1800.0, **self.kw)

    @pytest.mark.parametrize("answer, fragment, hint_fragment", [
        (-1800.0, "has the right size but the wrong sign", "sign convention"),
        (3600.0, "is twice the expected value", "factor of 2"),
        (900.0, "is half the expected value", "missing factor of 2"),
        (1.8, "is 1,000 times smaller than expected", "unit conversion"),
        (1_800_000.0, "is 1,000 times larger than expected", "unit conversion"),
        (-1.8, "has the wrong sign and is 1,000 times smaller", "Check the sign too"),
        (1800.9, "is close, but just outside the tolerance", "round"),
        (1890.0, "is 5.0 % too large", DEFAULT_HINT),
        (1350.0, "is 25 % too small", DEFAULT_HINT),
        (9000.0, "is about 5 times the expected value", DEFAULT_HINT),
        (0.0, "is zero", "initial value 0"),
    ])
    def test_generic_relations(self, answer, fragment, hint_fragment):
        fb = check_number(answer, 1800.0, rtol=1e-4, **self.kw)
        assert not fb
        assert fb.message.startswith("Not yet: your value for the range, ")
        assert fragment in fb.message
        assert hint_fragment in fb.hint

    def test_exercise_hint_replaces_the_default(self):
        assert check_number(1890.0, 1800.0, hint="Speed × time.").hint == "Speed × time."

    def test_common_mistake_wins_over_generic_relation(self):
        fb = check_number(3600.0, 1800.0, common_mistakes={3600.0: "Two-way!"}, **self.kw)
        assert fb.message == "Not yet: your value for the range, 3600 m, is twice the expected value."
        assert fb.hint == "Two-way!" and fb.details["mistake"] == 3600.0

    def test_expected_zero(self):
        assert check_number(0.0, 0.0, atol=1e-9)
        fb = check_number(2.0, 0.0, atol=0.1, units="m")
        assert "should be zero" in fb.message

    def test_misconfigured_checker_raises(self):
        with pytest.raises(ValueError):
            check_number(1.0, float("nan"))
        with pytest.raises(ValueError):
            check_number(1.0, 1.0, rtol=-1)


# =====================================================================================================================
# check_array
# =====================================================================================================================
class TestCheckArray:
    expected = np.column_stack((np.arange(5.0), 10 + np.arange(5.0)))  # shape (5, 2)

    def test_correct(self):
        fb = check_array(self.expected.tolist(), self.expected, name="the track")
        assert fb and "Correct" in fb.message

    def test_transposed_shape(self):
        fb = check_array(self.expected.T, self.expected, name="the track")
        assert not fb
        assert "expected shape (5, 2), got (2, 5): transpose?" in fb.message
        assert "`.T`" in fb.hint

    def test_one_row_short_points_at_arange(self):
        fb = check_array(self.expected[:-1], self.expected, name="the track")
        assert "one row short" in fb.message and "np.arange" in fb.hint

    def test_other_shapes(self):
        assert "arranged differently" in check_array(self.expected.ravel(), self.expected).message
        assert "3 values instead of 4" in check_array([1.0, 2.0, 3.0], [1.0, 2.0, 3.0, 4.0]).message
        assert "a single value" in check_array(3.0, self.expected).message

    def test_nan_reported_with_index(self):
        answer = self.expected.copy()
        answer[3, 1] = np.nan
        fb = check_array(answer, self.expected, name="the track")
        assert "contains NaN (not a number) at index (3, 1)" in fb.message

    def test_missing_values_compare_equal(self):
        assert check_array([1.0, np.nan], [1.0, np.nan])
        assert "where NaN (a missing value) is expected" in check_array([1.0, 0.0], [1.0, np.nan]).message

    def test_worst_element(self):
        answer = self.expected.copy()
        answer[2, 0] += 0.5
        answer[4, 1] += 5.0
        fb = check_array(answer, self.expected, name="the track", units="m", rtol=1e-6)
        assert fb.message == ("Not yet: 2 of 10 elements of the track are off; the worst is at index (4, 1): "
                              "got 19 m, expected 14 m.")
        assert fb.details["worst_index"] == (4, 1) and fb.details["n_wrong"] == 2

    @pytest.mark.parametrize("transform, fragment", [
        (lambda e: -e, "wrong sign everywhere"),
        (lambda e: 2 * e, "twice the expected array"),
        (lambda e: e / 1000, "1,000 times smaller"),
        (lambda e: e[:, ::-1], "columns in reverse order"),
        (lambda e: e[::-1], "reverse order"),
    ])
    def test_whole_array_relations(self, transform, fragment):
        fb = check_array(transform(self.expected), self.expected)
        assert not fb and fragment in fb.message

    def test_square_transpose(self):
        e = np.array([[1.0, 2.0], [3.0, 4.0]])
        assert "transpose of the expected array" in check_array(e.T, e).message

    def test_common_mistakes(self):
        wrong = self.expected + 1.0
        fb = check_array(wrong, self.expected, common_mistakes=[(wrong, "You added one.")])
        assert fb.hint == "You added one."

    @pytest.mark.parametrize("answer, fragment", [
        (None, "No answer yet: replace `None` with the array (an array of shape (5, 2))"),
        ("abc", "the text 'abc'"),
        ([[1.0, 2.0], [3.0]], "cannot be turned into an array"),
        ([[1.0, None]] * 5, "contains None at index (0, 1)"),
        (np.ones((5, 2), dtype=bool), "True/False values; expected numbers"),
    ])
    def test_wrong_types(self, answer, fragment):
        fb = check_array(answer, self.expected)
        assert not fb and fragment in fb.message

    def test_boolean_flags(self):
        expected = np.array([False, True, False, False, True])
        assert check_array([0, 1, 0, 0, 1], expected)
        fb = check_array([False, False, True, False, True], expected, name="the flags")
        assert fb.message == ("Not yet: the flags flags index 2, which should not be flagged and misses index 1, "
                              "which should be flagged (2 of 5 flags differ).")
        assert fb.details["false_alarms"] == [(2,)] and fb.details["misses"] == [(1,)]

    def test_boolean_flags_indices_and_values(self):
        expected = np.array([False, True, False, False, True])
        assert "list of positions (indices)" in check_array(np.flatnonzero(expected), expected).message
        assert "True/False flags, but it holds numbers" in check_array([3.5, 1, 2, 0, 7], expected).message


# =====================================================================================================================
# check_function
# =====================================================================================================================
def _ref_double(x):
    return 2 * np.asarray(x, dtype=float)


CASES = [Case((np.array([1.0, 2.0]),), label="two values"), (np.array([0.0, -3.0, 5.0]),), {"x": np.arange(4.0)}]


class TestCheckFunction:
    def test_passes(self):
        fb = check_function(lambda x: 2 * np.asarray(x), _ref_double, CASES, name="double", explanation="Well done.")
        assert fb and fb.message == "Correct: `double` passes all 3 test cases. Well done."

    def test_first_failing_case_is_reported_with_inputs(self):
        def double(x):
            x = np.asarray(x, dtype=float)
            return 2 * x if x.size < 3 else 3 * x

        fb = check_function(double, _ref_double, CASES)
        assert not fb
        assert fb.message.startswith("Not yet: case 2 of 3 fails:")
        assert "Inputs: x = [ 0., -3.,  5.]" in fb.message
        assert "Expected: [ 0., -6., 10.]" in fb.message and "Got: [ 0., -9., 15.]" in fb.message
        assert "the worst is at index 2: got 15, expected 10" in fb.message
        assert fb.details["case"] == 1

    def test_exception_is_caught_and_located(self):
        def double(x):
            y = x[10]  # IndexError
            return y

        fb = check_function(double, _ref_double, CASES)
        assert not fb
        assert "`double` raised IndexError" in fb.message and "case 1 of 3 (two values)" in fb.message
        assert "Where: line" in fb.message and "y = x[10]" in fb.message
        assert "index is out of range" in fb.hint
        assert isinstance(fb.details["exception"], IndexError)

    def test_not_implemented_means_not_answered(self):
        def double(x):
            raise NotImplementedError()

        fb = check_function(double, _ref_double, CASES)
        assert fb.message == "No answer yet: `double` still raises NotImplementedError."

    def test_none_not_callable_missing_return_mutation(self):
        assert check_function(None, _ref_double, CASES, name="double").message.startswith("No answer yet: define")
        assert "is an int, not a function" in check_function(3, _ref_double, CASES, name="double").message
        fb = check_function(lambda x: None, _ref_double, CASES, name="double")
        assert "returned None" in fb.message and "`return`" in fb.hint

        def double(x):
            x *= 2
            return x

        fb = check_function(double, _ref_double, CASES)
        assert "changed its input `x` in place" in fb.message
        assert check_function(double, _ref_double, CASES, allow_mutation=True)

    def test_wrong_signature_and_wrong_return_type(self):
        fb = check_function(lambda: 0, _ref_double, CASES, name="double")
        assert "raised TypeError" in fb.message and fb.hint == "`double` must accept the arguments (x) in this order."
        fb = check_function(lambda x: {"a": 1}, _ref_double, CASES, name="double")
        assert "`double` returned a dict; the result should be an array of shape (2,)" in fb.message
        fb = check_function(lambda x: (v for v in x), _ref_double, CASES, name="double")
        assert "`double` returned a generator" in fb.message

    def test_case_hint_and_scalar_results(self):
        cases = [Case((2.0,), label="two", hint="Square it.")]
        fb = check_function(lambda x: x * 3, lambda x: x * x, cases, name="square")
        assert fb.hint == "Square it." and "case 1 of 1 (two) fails" in fb.message

    def test_misconfigured(self):
        with pytest.raises(ValueError):
            check_function(abs, abs, [])
        with pytest.raises(TypeError):
            check_function(abs, abs, [3.0])


# =====================================================================================================================
# chapter 1
# =====================================================================================================================
def mackenzie(t, s, d):
    """Mackenzie (1981), written out independently of the package."""
    return (1448.96 + 4.591 * t - 5.304e-2 * t**2 + 2.374e-4 * t**3 + 1.340 * (s - 35) + 1.630e-2 * d
            + 1.675e-7 * d**2 - 1.025e-2 * t * (s - 35) - 7.139e-13 * t * d**3)


SPEED = mackenzie(10.0, 35.0, 1000.0)
DRIFT = 7200 * math.sin(math.radians(1))
TRACK = np.column_stack((2 * np.arange(0, 3601, 600) * math.sin(math.radians(1)),
                         2 * np.arange(0, 3601, 600) * math.cos(math.radians(1))))

CORRECT = [
    (ch01.check_sound_speed, SPEED),
    (ch01.check_two_way_range, 1800.0),
    (ch01.check_sound_speed_range_error, -60.0),
    (ch01.check_dr_drift, DRIFT),
    (ch01.check_dr_track, TRACK),
]

MISTAKES = [
    # (checker, wrong answer, fragment of the message, fragment of the hint)
    (ch01.check_sound_speed, mackenzie(10, 35, 1), "too small", "in metres"),
    (ch01.check_sound_speed, SPEED - (1.630e-2 * 1000 + 1.675e-7 * 1e6 - 7.139e-13 * 10 * 1e9), "too small",
     "depth terms (1.630e-2·D"),  # told apart from depth in km (0.016 m/s away) by the 0.005 m/s tolerance
    (ch01.check_sound_speed, SPEED + 1.340 * 35, "too large", "not 1.340·S"),
    (ch01.check_sound_speed, mackenzie(10, 70, 1000), "too large", "(S − 35), not S"),
    (ch01.check_sound_speed, mackenzie(283.15, 35, 1000), "", "not kelvin"),
    (ch01.check_sound_speed, SPEED + 5.304, "too large", "T² term is missing"),
    (ch01.check_sound_speed, SPEED + 2 * 5.304, "too large", "has a minus sign"),
    (ch01.check_sound_speed, SPEED - 2.374e-4 * 1000, "too small", "T³ term is missing"),
    (ch01.check_sound_speed, SPEED - 1.675e-7 * 1e6, "too small", "D² term is missing"),
    (ch01.check_sound_speed, 1449.2 + 46.0 - 5.5 + 0.29 + 16.0, "too small", "Medwin"),
    (ch01.check_two_way_range, 3600.0, "is twice the expected value",
     "forget that a two-way travel time covers the path twice"),
    (ch01.check_two_way_range, 625.0, "too small", "divided the speed by the time"),
    (ch01.check_two_way_range, 2.4 / 1500, "smaller", "not a distance"),
    (ch01.check_two_way_range, 900.0, "half", "halved twice"),
    (ch01.check_two_way_range, 1.8, "1,000 times smaller", "kilometres"),
    (ch01.check_sound_speed_range_error, 60.0, "wrong sign", "estimated − true"),
    (ch01.check_sound_speed_range_error, 3000 * 30 / 1470, "wrong sign", "scaled with the assumed speed"),
    (ch01.check_sound_speed_range_error, -3000 * 30 / 1470, "larger in size", "scaled with the assumed speed"),
    (ch01.check_sound_speed_range_error, 2940.0, "wrong sign", "the range the vehicle computes"),
    (ch01.check_sound_speed_range_error, -30.0, "half", "sound-speed error in m/s"),
    (ch01.check_sound_speed_range_error, -120.0, "twice", "one-way range"),
    (ch01.check_dr_drift, 7200 * math.sin(1.0), "times the expected value", "take radians"),
    (ch01.check_dr_drift, 7200 * math.cos(1.0), "times the expected value", "take radians"),
    (ch01.check_dr_drift, 7200.0, "times the expected value", "whole distance travelled"),
    (ch01.check_dr_drift, 7200 * math.cos(math.radians(1)), "times the expected value", "whole distance"),
    (ch01.check_dr_drift, 7200 * (1 - math.cos(math.radians(1))), "smaller", "along the intended course"),
    (ch01.check_dr_drift, 120 * math.sin(math.radians(1)), "60 times smaller", "3600 s"),
    (ch01.check_dr_drift, DRIFT / 2, "half", "2 m/s × 3600 s"),
    (ch01.check_dr_drift, DRIFT / 1000, "1,000 times smaller", "unit conversion"),
    (ch01.check_dr_track, TRACK.T, "transpose?", "`.T`"),
    (ch01.check_dr_track, TRACK[:-1], "one row short", "np.arange"),
    (ch01.check_dr_track, TRACK[:, ::-1], "columns in reverse order", "counter-clockwise from east"),
    (ch01.check_dr_track, TRACK * [-1, 1], "elements off", "east coordinate grows"),
    (ch01.check_dr_track, np.column_stack((2 * np.arange(0, 3601, 600) * math.sin(1),
                                           2 * np.arange(0, 3601, 600) * math.cos(1))), "off", "radians"),
]


class TestChapter1:
    @pytest.mark.parametrize("checker, answer", CORRECT, ids=[c.__name__ for c, _ in CORRECT])
    def test_correct_answer(self, checker, answer):
        fb = checker(answer)
        assert fb, str(fb)
        assert fb.message.startswith("Correct:") and fb.hint is None

    @pytest.mark.parametrize("checker, answer, fragment, hint_fragment", MISTAKES,
                             ids=[f"{m[0].__name__}-{i}" for i, m in enumerate(MISTAKES)])
    def test_known_mistakes(self, checker, answer, fragment, hint_fragment):
        fb = checker(answer)
        assert not fb
        assert fragment in fb.message, str(fb)
        assert hint_fragment in fb.hint, str(fb)

    @pytest.mark.parametrize("checker", [c for c, _ in CORRECT] + [ch01.check_outlier_detector])
    def test_not_answered(self, checker):
        fb = checker(None)
        assert not fb and fb.message.startswith("No answer yet:")
        assert fb.details.get("answered") is False

    @pytest.mark.parametrize("checker", [c for c, _ in CORRECT])
    @pytest.mark.parametrize("answer", ["1800", "abc", [1.0, 2.0, 3.0], True, {}])
    def test_wrong_types(self, checker, answer):
        fb = checker(answer)
        assert isinstance(fb, Feedback) and not fb
        assert fb.hint

    def test_sound_speed_matches_the_library(self):
        acoustics = pytest.importorskip("uwtutor.acoustics")
        assert acoustics.sound_speed(10.0, 35.0, 1000.0) == pytest.approx(SPEED, abs=1e-9)

    def test_sound_speed_tolerance(self):
        assert ch01.check_sound_speed(round(SPEED, 2))
        assert not ch01.check_sound_speed(SPEED + 0.05)

    def test_exercise_constants(self):
        assert ch01.TRACK_TIMES.tolist() == [0, 600, 1200, 1800, 2400, 3000, 3600]
        assert ch01.check_dr_track(TRACK).correct
        assert TRACK[-1, 0] == pytest.approx(DRIFT)

    # -- the outlier detector ------------------------------------------------------------------------------------
    @staticmethod
    def flag_outliers(ranges, threshold):
        ranges = np.asarray(ranges, dtype=float)
        flags = np.zeros(len(ranges), dtype=bool)
        for i in range(len(ranges)):
            neighbours = np.concatenate((ranges[max(i - 3, 0):i], ranges[i + 1:i + 4]))
            neighbours = neighbours[~np.isnan(neighbours)]
            if not np.isnan(ranges[i]) and neighbours.size:
                flags[i] = abs(ranges[i] - np.median(neighbours)) > threshold
        return flags

    def test_outlier_detector_accepts_a_correct_solution(self):
        fb = ch01.check_outlier_detector(self.flag_outliers)
        assert fb, str(fb)
        assert "passes all 11 test cases" in fb.message

    def test_outlier_cases_flag_exactly_the_planted_outliers(self):
        planted = {"one isolated outlier": [8], "an outlier in the first range": [0],
                   "an outlier in the last range": [19], "a range that is too short": [5],
                   "a patch of two outliers in a row": [10, 11], "a missing range (NaN) next to an outlier": [7],
                   "two ranges, each the other's only neighbour": [0, 1]}
        cases = ch01._outlier_cases()
        labels = [c.label for c in cases]
        assert len(labels) == len(set(labels))
        for case in cases:
            flagged = np.flatnonzero(self.flag_outliers(*case.args)).tolist()
            assert flagged == planted.get(case.label, []), case.label

    @pytest.mark.parametrize("variant, message_fragment, hint_fragment", [
        ("mean", "case 2 of 11 (one isolated outlier) fails", "median"),
        ("nan_median", "(a missing range (NaN) next to an outlier) fails", "np.isnan"),
        (">=", "(a jump of exactly the threshold is not flagged) fails", "strictly greater"),
        ("fixed_threshold", "(a larger threshold", "`threshold` argument"),
        ("no_abs", "(a range that is too short) fails", "either way"),
        ("crash_at_end", "raised IndexError", "index is out of range"),
        ("indices", "list of positions (indices)", "boolean mask"),
        ("no_return", "returned None", "`return`"),
        ("in_place", "changed its input `ranges` in place", "copy"),
        ("not_implemented", "No answer yet: `flag_outliers` still raises NotImplementedError", "raise"),
    ])
    def test_outlier_detector_mistakes(self, variant, message_fragment, hint_fragment):
        good = self.flag_outliers

        def flag_outliers(ranges, threshold):
            if variant == "not_implemented":
                raise NotImplementedError()
            if variant == "indices":
                return np.flatnonzero(good(ranges, threshold))
            if variant == "no_return":
                good(ranges, threshold)
                return None
            if variant == "fixed_threshold":
                return good(ranges, 5.0)
            if variant == "in_place":
                flags = good(ranges, threshold)
                ranges[flags] = np.nan
                return flags
            r = np.asarray(ranges, dtype=float)
            flags = np.zeros(len(r), dtype=bool)
            for i in range(len(r)):
                if variant == "crash_at_end":
                    window = np.array([r[i - 1], r[i + 1]])
                else:
                    window = np.concatenate((r[max(i - 3, 0):i], r[i + 1:i + 4]))
                if variant != "nan_median":
                    window = window[~np.isnan(window)]
                if window.size == 0:
                    continue
                centre = np.mean(window) if variant == "mean" else np.median(window)
                jump = r[i] - centre if variant == "no_abs" else abs(r[i] - centre)
                flags[i] = jump >= threshold if variant == ">=" else jump > threshold
            return flags

        with np.errstate(all="ignore"):
            fb = ch01.check_outlier_detector(flag_outliers)
        assert not fb
        assert message_fragment in fb.message, str(fb)
        assert hint_fragment in fb.hint, str(fb)


# =====================================================================================================================
# the generator
# =====================================================================================================================
def _source_notebook() -> nbformat.NotebookNode:
    answer = new_code_cell(
        "x = None\n### BEGIN SOLUTION\nx = 42\n### END SOLUTION",
        metadata={"tags": ["answer"], "nbgrader": {"solution": True}, "scrolled": True},
        execution_count=3, outputs=[new_output("stream", name="stdout", text="secret\n")])
    function = new_code_cell(
        "def f(a):\n    b = a + 1\n    ### BEGIN SOLUTION\n    return b * 2\n    ### END SOLUTION")
    check = new_code_cell(
        "### BEGIN HIDDEN TESTS\nassert x == 42\n### END HIDDEN TESTS\ncheck(x)", execution_count=4,
        outputs=[new_output("execute_result", data={"text/plain": "✔ Correct"}, execution_count=4)])
    hidden_only = new_code_cell("### BEGIN HIDDEN TESTS\nassert f(1) == 4\n### END HIDDEN TESTS")
    written = new_markdown_cell("*Your answer:*\n\n### BEGIN SOLUTION\nBecause 42.\n### END SOLUTION")
    plain = new_markdown_cell("# Title\n\n### A heading, not a marker")
    return new_notebook(cells=[plain, answer, function, check, hidden_only, written], metadata={
        "kernelspec": {"name": "python3", "display_name": "Python 3", "language": "python"},
        "language_info": {"name": "python", "version": "3.11.9", "codemirror_mode": {"name": "ipython"}},
        "widgets": {"state": {}}, "celltoolbar": "Create Assignment"})


class TestGenerator:
    def test_solutions_replaced_hidden_tests_removed_outputs_cleared(self):
        src = _source_notebook()
        before = nbformat.writes(src)
        nb = make_student_version(src)
        assert nbformat.writes(src) == before  # the source is untouched
        sources = [c.source for c in nb.cells]
        stub = f"raise NotImplementedError({STUB_MESSAGE!r})"
        assert sources[1] == f"x = None\n# YOUR CODE HERE\n{stub}"
        assert sources[2] == f"def f(a):\n    b = a + 1\n    # YOUR CODE HERE\n    {stub}"
        assert sources[3] == "check(x)"
        assert sources[4] == "*Your answer:*\n\nYOUR ANSWER HERE"
        assert len(nb.cells) == 5  # the hidden-tests-only cell is gone
        assert sources[0] == "# Title\n\n### A heading, not a marker"
        text = nbformat.writes(nb)
        for leaked in ("x = 42", "secret", "BEGIN", "END SOLUTION", "HIDDEN", "b * 2", "Because"):
            assert leaked not in text
        for cell in nb.cells:
            if cell.cell_type == "code":
                assert cell.outputs == [] and cell.execution_count is None
        assert nb.cells[1].metadata == {"tags": ["answer"]}
        assert nb.cells[2].metadata == {}
        # the kernelspec and language_info as JupyterLab writes them when the kernel starts: opening the student
        # version does not mark it modified (the source's "Python 3" and its Python 3.11.9 are replaced)
        from ipykernel.ipkernel import IPythonKernel

        assert nb.metadata == {"kernelspec": {"name": "python3", "display_name": "Python 3 (ipykernel)",
                                              "language": "python"},
                               "language_info": IPythonKernel.language_info}
        nbformat.validate(nb)

    def test_another_kernel_keeps_its_kernelspec(self):
        src = _source_notebook()
        src.metadata["kernelspec"] = {"name": "ir", "display_name": "R", "language": "R"}
        src.metadata["language_info"] = {"name": "R", "version": "4.4.1"}
        nb = make_student_version(src)
        assert nb.metadata == {"kernelspec": {"name": "ir", "display_name": "R", "language": "R"},
                               "language_info": {"name": "R"}}


def test_every_source_carries_the_kernelspec_jupyterlab_writes():
    from uwtutor.exercises.generate import KERNELSPEC

    sources = list(SOURCE_DIR.glob("*.ipynb")) + list(SOURCE_DIR.glob("labs/*/*.ipynb"))
    assert len(sources) > 10
    for path in sources:
        assert nbformat.read(path, as_version=4).metadata["kernelspec"] == KERNELSPEC, path.name


def test_execute_notebooks_writes_the_kernelspec_jupyterlab_writes(tmp_path):
    """tools/execute_notebooks.py (make notebooks): the chapters get the kernelspec JupyterLab writes, the kernel's
    language_info, and lose jupytext's left-over metadata."""
    import importlib.util

    from ipykernel.ipkernel import IPythonKernel

    from uwtutor.exercises.generate import KERNELSPEC

    spec = importlib.util.spec_from_file_location("execute_notebooks", REPO / "tools" / "execute_notebooks.py")
    tool = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tool)
    path = tmp_path / "chapter.ipynb"
    nbformat.write(new_notebook(cells=[new_code_cell("print(6 * 7)")], metadata={
        "kernelspec": {"name": "python3", "display_name": "Python 3", "language": "python"},
        "jupytext": {"notebook_metadata_filter": "-all"}}), path)
    tool.execute(path)
    nb = nbformat.read(path, as_version=4)
    assert nb.metadata["kernelspec"] == KERNELSPEC and "jupytext" not in nb.metadata
    assert nb.metadata["language_info"] == IPythonKernel.language_info
    assert nb.cells[0].outputs[0].text == "42\n"

    def test_accepts_a_path(self, tmp_path):
        path = tmp_path / "src.ipynb"
        nbformat.write(_source_notebook(), path)
        assert "YOUR CODE HERE" in make_student_version(path).cells[1].source

    @pytest.mark.parametrize("source, fragment", [
        ("### BEGIN SOLUTION\nx = 1", "without a matching '### END SOLUTION'"),
        ("x = 1\n### END SOLUTION", "with no open region"),
        ("### BEGIN SOLUTION\n### BEGIN SOLUTION\n### END SOLUTION", "cannot be nested"),
        ("### BEGIN HIDDEN TESTS\n### END SOLUTION", "with an open '### BEGIN HIDDEN TESTS'"),
        ("x = 1  ### BEGIN SOLUTION\n### END SOLUTION", "on a line of its own"),
    ])
    def test_malformed_markers(self, source, fragment):
        nb = new_notebook(cells=[new_markdown_cell("intro"), new_code_cell(source)])
        with pytest.raises(ExerciseSourceError, match="cell 1") as info:
            make_student_version(nb)
        assert fragment in str(info.value)

    def test_repository_sources_have_solutions_and_no_outputs(self):
        sources = list_exercise_sources()
        assert SOURCE_DIR / "ch01_positioning_and_errors.ipynb" in sources
        for path in sources:
            src = nbformat.read(path, as_version=4)
            nbformat.validate(src)
            n_solutions = sum(c.source.count("### BEGIN SOLUTION") for c in src.cells if c.cell_type == "code")
            assert n_solutions >= 4, path.name
            assert all(not c.get("outputs") for c in src.cells if c.cell_type == "code"), \
                f"{path.name}: commit sources without outputs"
            student = make_student_version(path)
            text = nbformat.writes(student)
            stubs = sum(c.source.count("# YOUR CODE HERE") for c in student.cells if c.cell_type == "code")
            assert stubs == n_solutions
            assert "BEGIN SOLUTION" not in text and "HIDDEN TESTS" not in text and ".assert_correct()" not in text

    def test_ch01_student_version_hides_each_solution(self):
        student = nbformat.writes(make_student_version(SOURCE_DIR / "ch01_positioning_and_errors.ipynb"))
        for solution_line in ("c * t_two_way / 2", "np.sin(np.radians(bias_deg))", "np.median(neighbours)",
                              "np.column_stack((distance", "c_assumed * t_one_way - R_true"):
            assert solution_line not in student


class TestWriteStudentVersions:
    @pytest.fixture
    def sources(self, tmp_path):
        src = tmp_path / "src"
        src.mkdir()
        nbformat.write(_source_notebook(), src / "a.ipynb")
        nbformat.write(_source_notebook(), src / "b.ipynb")
        (src / "notes.txt").write_text("not a notebook")
        return src

    def test_writes_then_skips_then_overwrites(self, sources, tmp_path):
        dest = tmp_path / "work" / "deep"
        report = write_student_versions(sources, dest)
        assert [p.name for p in report.written] == ["a.ipynb", "b.ipynb"] and not report.skipped
        assert sorted(p.name for p in dest.iterdir()) == ["a.ipynb", "b.ipynb"]
        (dest / "a.ipynb").write_text("my work")
        report = write_student_versions(sources, dest)
        assert not report.written and [p.name for p in report.skipped] == ["a.ipynb", "b.ipynb"]
        assert (dest / "a.ipynb").read_text() == "my work"
        assert "never overwritten" in str(report) and "a.ipynb" in str(report)
        (dest / "b.ipynb").unlink()
        report = write_student_versions(sources, dest)
        assert [p.name for p in report.written] == ["b.ipynb"] and [p.name for p in report.skipped] == ["a.ipynb"]
        report = write_student_versions(sources, dest, overwrite=True)
        assert len(report.written) == 2 and len(report.overwritten) == 2
        assert "YOUR CODE HERE" in (dest / "a.ipynb").read_text()
        assert not list(dest.glob(".*.tmp"))

    def test_only_selected_names(self, sources, tmp_path):
        report = write_student_versions(sources, tmp_path / "w", names=["b.ipynb"])
        assert [p.name for p in report.written] == ["b.ipynb"]
        with pytest.raises(FileNotFoundError, match="available: a.ipynb, b.ipynb"):
            write_student_versions(sources, tmp_path / "w", names=["zzz.ipynb"])

    def test_refuses_the_source_directory_and_files(self, sources, tmp_path):
        with pytest.raises(ValueError, match="source directory"):
            write_student_versions(sources, sources, overwrite=True)
        (tmp_path / "file").write_text("x")
        with pytest.raises(NotADirectoryError):
            write_student_versions(sources, tmp_path / "file")

    def test_malformed_source_writes_nothing(self, sources, tmp_path):
        nbformat.write(new_notebook(cells=[new_code_cell("### BEGIN SOLUTION")]), sources / "c.ipynb")
        dest = tmp_path / "w"
        with pytest.raises(ExerciseSourceError, match="c.ipynb"):
            write_student_versions(sources, dest)
        assert not dest.exists() or not list(dest.iterdir())

    def test_missing_sources(self, tmp_path, monkeypatch):
        with pytest.raises(FileNotFoundError, match="does not exist"):
            list_exercise_sources(tmp_path / "nope")
        (tmp_path / "empty").mkdir()
        with pytest.raises(FileNotFoundError, match="no exercise notebooks"):
            list_exercise_sources(tmp_path / "empty")
        # a wheel install: no exercises/ beside the package
        monkeypatch.setattr(uwtutor, "__file__", str(tmp_path / "site" / "uwtutor" / "__init__.py"))
        with pytest.raises(FileNotFoundError, match="--source"):
            generate.exercise_source_dir()


# =====================================================================================================================
# the command
# =====================================================================================================================
NAME = "ch01_positioning_and_errors.ipynb"


class TestCommand:
    def test_next_step_says_how_to_get_jupyterlab_when_it_is_missing(self, tmp_path, capsys, monkeypatch):
        from uwtutor.exercises import cli

        monkeypatch.setattr(cli, "jupyterlab_available", lambda: False)
        assert main(["exercises", str(tmp_path / "a")]) == 0
        out = capsys.readouterr().out
        assert 'pip install "uwtutor[lab]"' in out and "JupyterLab is not installed" in out
        assert main(["labs", str(tmp_path / "b"), "--lab", "ekf_consistency"]) == 0
        assert 'pip install "uwtutor[lab]"' in capsys.readouterr().out
        monkeypatch.setattr(cli, "jupyterlab_available", lambda: True)
        assert main(["exercises", str(tmp_path / "c")]) == 0
        out = capsys.readouterr().out
        assert f"jupyter lab {tmp_path / 'c'}" in out and "pip install" not in out

    def test_writes_skips_and_forces(self, tmp_path, capsys):
        dest = tmp_path / "my-work"
        assert main(["exercises", str(dest)]) == 0
        out = capsys.readouterr().out
        n_sources = len(generate.list_exercise_sources())
        plural = "notebook" if n_sources == 1 else "notebooks"
        assert f"Wrote {n_sources} {plural}" in out and NAME in out and "jupyter lab" in out
        student = dest / NAME
        assert "# YOUR CODE HERE" in student.read_text()

        student.write_text("my precious work")
        assert main(["exercises", str(dest)]) == 0
        out = capsys.readouterr().out
        assert student.read_text() == "my precious work"
        skipped = "1 notebook that already exists" if n_sources == 1 else f"{n_sources} notebooks that already exist"
        assert "Wrote nothing" in out and f"Skipped {skipped}" in out and NAME in out
        assert "--force" in out and "rename or delete your copy" in out

        assert main(["exercises", str(dest), "--force"]) == 0
        out = capsys.readouterr().out
        assert "(overwritten)" in out
        assert "# YOUR CODE HERE" in student.read_text()

    def test_explicit_source(self, tmp_path, capsys):
        src = tmp_path / "src"
        src.mkdir()
        nbformat.write(_source_notebook(), src / "lab.ipynb")
        assert main(["exercises", str(tmp_path / "w"), "--source", str(src)]) == 0
        assert (tmp_path / "w" / "lab.ipynb").exists()
        assert not (tmp_path / "w" / NAME).exists()

    @pytest.mark.parametrize("argv", [[], ["exercises"], ["--bogus"], ["exercises", "d", "--bogus"], ["frobnicate"]])
    def test_usage_errors_exit_2(self, argv, capsys, tmp_path, monkeypatch):
        monkeypatch.chdir(tmp_path)
        assert main(argv) == 2
        assert "usage: uwtutor" in capsys.readouterr().err
        assert not (tmp_path / "d").exists()

    def test_bad_paths_exit_2(self, tmp_path, capsys):
        assert main(["exercises", str(tmp_path / "w"), "--source", str(tmp_path / "missing")]) == 2
        assert "does not exist" in capsys.readouterr().err
        (tmp_path / "file").write_text("x")
        assert main(["exercises", str(tmp_path / "file")]) == 2
        assert "is not a directory" in capsys.readouterr().err
        assert (tmp_path / "file").read_text() == "x"

    def test_help(self, capsys):
        assert main(["--help"]) == 0
        out = capsys.readouterr().out
        assert "usage: uwtutor" in out and "exercises" in out
        assert main(["exercises", "--help"]) == 0
        out = capsys.readouterr().out
        assert "--force" in out and "--source" in out and "never overwritten" in out
        assert main(["--version"]) == 0
        assert uwtutor.__version__ in capsys.readouterr().out

    def test_console_script(self, tmp_path):
        exe = Path(sys.executable).with_name("uwtutor")
        if not exe.exists():
            exe = REPO / ".venv" / "bin" / "uwtutor"
        if not exe.exists():
            pytest.skip("the uwtutor console script is not installed (pip install -e .)")
        dest = tmp_path / "work"
        first = cpu_limits.run([str(exe), "exercises", str(dest)], capture_output=True, text=True, cpu_seconds=120)
        assert first.returncode == 0, first.stderr
        assert NAME in first.stdout
        (dest / NAME).write_text("mine")
        second = cpu_limits.run([str(exe), "exercises", str(dest)], capture_output=True, text=True, cpu_seconds=120)
        assert second.returncode == 0, second.stderr
        assert "Skipped" in second.stdout and (dest / NAME).read_text() == "mine"
        forced = cpu_limits.run([str(exe), "exercises", str(dest), "--force"], capture_output=True, text=True,
                                cpu_seconds=120)
        assert forced.returncode == 0 and "YOUR CODE HERE" in (dest / NAME).read_text()
        usage = cpu_limits.run([str(exe), "exercises"], capture_output=True, text=True, cpu_seconds=120)
        assert usage.returncode == 2 and "usage:" in usage.stderr


# -- the two checker bugs found by trying the notebooks ----------------------------------------------------------------
def test_outlier_checker_rejects_a_window_that_holds_the_range_itself():
    def window_with_itself(ranges, threshold):
        r = np.asarray(ranges, dtype=float)
        flags = np.zeros(len(r), dtype=bool)
        for i in range(len(r)):
            window = r[max(i - 3, 0):i + 4]  # the range itself is in its own window
            window = window[~np.isnan(window)]
            if np.isnan(r[i]) or window.size < 2:
                continue
            flags[i] = abs(r[i] - np.median(window)) > threshold
        return flags

    assert list(window_with_itself(np.array([100.0, 200.0]), 60.0)) == [False, False]  # the reported case
    fb = ch01.check_outlier_detector(window_with_itself)
    assert not fb
    assert "each the other's only neighbour" in fb.message
    assert "Leave the range itself out of its window" in fb.hint


def test_ekf_update_checker_names_a_forgotten_covariance_update():
    def forgot_P(x, P, z, R, beacon):
        x, P, b = np.asarray(x, float), np.asarray(P, float), np.asarray(beacon, float)
        predicted = np.linalg.norm(x - b)
        H = (x - b) / predicted
        S = H @ P @ H + R
        K = P @ H / S
        return x + K * (z - predicted), P  # P not updated

    fb = ch04.check_ekf_update(forgot_P)
    assert not fb
    assert "updated covariance" in fb.message
    assert "prior P unchanged" in fb.hint and "innovation is z − h(x)" not in fb.hint
    assert fb.details["comparison"].details["diagnosed"]


# -- nbgrader accepts the exercise sources ----------------------------------------------------------------------------
def test_exercise_sources_carry_nbgrader_metadata():
    from uwtutor.exercises.nbgrader_meta import nbgrader_problems, total_points

    for path in list_exercise_sources():
        nb = nbformat.read(path, as_version=4)
        assert nbgrader_problems(nb) == [], path.name
        auto, manual = total_points(nb)
        assert auto > 0 and manual > 0, path.name
        for cell in nb.cells:
            tags = cell.metadata.get("tags", [])
            if "answer" in tags or "check" in tags:
                assert "nbgrader" in cell.metadata, f"{path.name}: a tagged cell without nbgrader metadata"


def test_nbgrader_problems_finds_what_nbgrader_refuses():
    from uwtutor.exercises.nbgrader_meta import add_nbgrader_metadata, nbgrader_problems

    nb = nbformat.v4.new_notebook(cells=[
        nbformat.v4.new_markdown_cell("## Exercise 9.1: x"),
        nbformat.v4.new_code_cell("x = None\n### BEGIN SOLUTION\nx = 1\n### END SOLUTION",
                                  metadata={"tags": ["answer"]}),
        nbformat.v4.new_code_cell("### BEGIN HIDDEN TESTS\nassert x == 1\n### END HIDDEN TESTS",
                                  metadata={"tags": ["check"]}),
        nbformat.v4.new_markdown_cell("### BEGIN SOLUTION\nbecause\n### END SOLUTION"),
    ])
    problems = nbgrader_problems(nb)
    assert any("solution region but no nbgrader metadata" in p for p in problems)
    assert any("hidden tests but no nbgrader metadata" in p for p in problems)
    add_nbgrader_metadata(nb, prefix="ex")
    assert nbgrader_problems(nb) == []
    assert [c.metadata["nbgrader"]["grade_id"] for c in nb.cells[1:]] == ["ex_9_1_answer", "ex_9_1_check",
                                                                         "ex_9_1_written"]
    nb.cells[2].metadata["nbgrader"]["grade_id"] = "ex_9_1_answer"
    nb.cells[2].metadata["nbgrader"]["locked"] = False
    nb.cells[1].metadata["nbgrader"]["schema_version"] = 1
    problems = "\n".join(nbgrader_problems(nb))
    assert "already used by cell 1" in problems and "should be locked" in problems and "schema_version is 1" in problems


def test_nbgrader_generates_the_exercise_assignment(tmp_path):
    """nbgrader generate_assignment takes the exercise sources as they are (it refused them before the metadata)."""
    pytest.importorskip("nbgrader", reason="nbgrader is in the test extra")
    import os
    import shutil
    import sys

    (tmp_path / "source" / "exercises").mkdir(parents=True)
    for path in list_exercise_sources():
        shutil.copy(path, tmp_path / "source" / "exercises")
    (tmp_path / "nbgrader_config.py").write_text(
        f"c = get_config()\nc.CourseDirectory.root = {str(tmp_path)!r}\n"
        f"c.CourseDirectory.db_url = 'sqlite:///{tmp_path / 'gradebook.db'}'\n", encoding="utf-8")
    env = dict(os.environ, PATH=str(Path(sys.executable).parent) + os.pathsep + os.environ.get("PATH", ""))
    result = cpu_limits.run([sys.executable, "-m", "nbgrader", "generate_assignment", "exercises", "--create"],
                            cwd=tmp_path, env=env, capture_output=True, text=True, cpu_seconds=600)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    released = sorted(p.name for p in (tmp_path / "release" / "exercises").glob("*.ipynb"))
    assert released == [p.name for p in list_exercise_sources()]
    for name in released:
        text = (tmp_path / "release" / "exercises" / name).read_text(encoding="utf-8")
        assert "BEGIN SOLUTION" not in text and "HIDDEN TESTS" not in text and "YOUR CODE HERE" in text


def test_an_empty_dir_argument_is_refused_not_taken_for_the_current_directory(tmp_path, monkeypatch, capsys):
    from uwtutor.exercises.cli import main

    monkeypatch.chdir(tmp_path)
    for command in ("exercises", "labs"):
        assert main([command, ""]) == 2
        assert "DIR is empty" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_the_instruction_names_the_stub_line_the_notebooks_have():
    """Every exercise notebook's text that tells the student which line to delete quotes the stub as the student
    version has it (`raise NotImplementedError('not answered yet: …')`), not nbgrader's bare `raise
    NotImplementedError()`."""
    stub_start = f"raise NotImplementedError({STUB_MESSAGE!r}"[:len("raise NotImplementedError('not answered yet:")]
    root = Path(__file__).resolve().parents[1] / "exercises"
    told = 0
    for path in sorted(root.glob("ch*.ipynb")):
        for cell in nbformat.read(path, as_version=4).cells:
            if cell.cell_type != "markdown":
                continue
            for quoted in re.findall(r"delete the line `([^`]*)`", " ".join(cell.source.split())):
                told += 1
                assert quoted.startswith(stub_start), f"{path.name}: 'delete the line `{quoted}`'"
    assert told >= 11, "every chapter's exercise notebook says which line to delete"
