"""Chapter 10 checkers: the right answers pass, the usual mistakes get the hint that explains them, bad input is
named, and the student version holds no solution."""

from __future__ import annotations

from pathlib import Path

import nbformat
import numpy as np
import pytest

from uwtutor import methods
from uwtutor.exercises import Feedback, ch10, check_choice
from uwtutor.exercises.generate import make_student_version
from uwtutor.exercises.nbgrader_meta import nbgrader_problems
from uwtutor.observability import posterior_crlb, rmse_bound
from uwtutor.scenarios import suite

SOURCE = Path(__file__).resolve().parents[1] / "exercises" / "ch10_comparison.ipynb"


def _text(fb: Feedback) -> str:
    return f"{fb.message}\n{fb.hint or ''}"


# -- expected values computed here, independently of the checkers ------------------------------------------------------
@pytest.fixture(scope="module")
def bound():
    return rmse_bound(posterior_crlb(**suite.crlb_inputs("line", "bias")))


@pytest.fixture(scope="module")
def table():
    return methods.load_comparison()


def _row(table, method, scenario, condition):
    hit = (table.method == method) & (table.scenario == scenario) & (table.condition == condition)
    (index,) = np.flatnonzero(hit)
    return index


def test_exercise_data_are_what_the_notebook_says(table):
    assert (ch10.BOUND_SCENARIO, ch10.BOUND_CONDITION, ch10.START_METHOD) == ("line", "bias", "IEKF")
    assert (ch10.TABLE_METHOD, ch10.TABLE_SCENARIO, ch10.TABLE_CONDITION) == ("EKF", "line", "white")
    assert (ch10.CHOICE_SCENARIO, ch10.CHOICE_CONDITION, ch10.MAX_LOST) == ("turn", "sound speed", 0.05)
    assert ch10.CHOICES == {"A": "EKF", "B": "IEKF", "C": "LS-ISFEKF", "D": "gated EKF"}
    source = SOURCE.read_text()
    for letter, method in ch10.CHOICES.items():
        assert f"| {letter} | {method} |" in source
        assert methods.get(method).runs_on("turn")
    assert set(ch10.choice_rows()) >= set(ch10.CHOICES.values())


def test_the_table_bound_is_the_recomputed_bound(bound, table):
    i = _row(table, "IEKF", "line", "bias")
    np.testing.assert_allclose(table.bound_curves[i], bound, rtol=1e-9)


def test_right_answers_pass(bound, table):
    i = _row(table, "IEKF", "line", "bias")
    row = table.rows()[_row(table, "EKF", "line", "white")]
    letter = next(k for k, m in ch10.CHOICES.items() if m == _expected_choice(table)[0])
    n_lost = row["divergence_fraction"] * row["n_runs"]
    for check, answer in [(ch10.check_final_bound, bound[-1]), (ch10.check_final_bound, np.float32(bound[-1])),
                          (ch10.check_final_bound, [bound[-1]]),
                          (ch10.check_first_ratio, table.rmse_curves[i, 0] / bound[0]),
                          (ch10.check_final_efficiency, row["final_rmse"] / row["final_bound"]),
                          (ch10.check_final_efficiency, row["final_efficiency"]),
                          (ch10.check_median_over_bound, row["median_final_error"] / row["final_bound"]),
                          (ch10.check_lost_runs, round(n_lost)), (ch10.check_lost_runs, n_lost),
                          (ch10.check_lost_runs, np.int64(round(n_lost))),
                          (ch10.check_method_choice, letter), (ch10.check_method_choice, f" {letter} ")]:
        fb = check(answer)
        assert fb.correct, (check.__name__, answer, fb.message, fb.hint)
        fb.assert_correct()


def _expected_choice(table):
    """Computed here from the runs, independently of the checker: the options whose lost fraction's Wilson interval
    (95 %) lies below 5 %, then the lowest median and the options tied with it on the same runs (paired bootstrap)."""
    from uwtutor.statistics import paired_comparison, wilson_interval

    errors = table.cell_errors("turn", "sound speed", list(ch10.CHOICES.values()))
    eligible = [m for m, e in errors.items()
                if wilson_interval(int(np.sum(~(e <= 50.0))), e.size).upper < 0.05]
    medians = {m: np.median(np.where(np.isnan(errors[m]), np.inf, errors[m])) for m in eligible}
    lead = min(medians, key=medians.get)
    tied = [m for m in eligible if m != lead
            and not paired_comparison(errors[m], errors[lead]).median_difference.excludes(0.0)]
    return [lead] + tied


def test_the_choice_is_not_the_lowest_median(table):
    """The exercise is only worth asking while the lowest median of the options cannot show it meets the limit."""
    rows = ch10.choice_rows()
    medians = {m: rows[m]["median_final_error"] for m in ch10.CHOICES.values()}
    lowest = min(medians, key=medians.get)
    assert lowest not in _expected_choice(table)
    fb = ch10.check_method_choice(next(k for k, m in ch10.CHOICES.items() if m == lowest))
    assert not fb.correct and "the mission can afford" in fb.hint


def _planned_bound(bias):
    inputs = suite.crlb_inputs("line", "bias")
    runs = suite.line(np.random.default_rng(0), 1)
    kw = dict(sigma=inputs["sigma"], Q=inputs["Q"], P0=inputs["P0"]) if bias else \
        dict(sigma=inputs["sigma"], Q=inputs["Q"][:2, :2], P0=inputs["P0"][:2, :2])
    return rmse_bound(posterior_crlb(runs.planned[1:], runs.beacon[0, 1:], bias=bias, **kw))[-1]


def test_bound_mistakes_get_their_hint(bound):
    inputs = suite.crlb_inputs("line", "bias")
    white = rmse_bound(posterior_crlb(**suite.crlb_inputs("line", "white")))[-1]
    per_track = rmse_bound(posterior_crlb(**dict(inputs, mean_over_runs=False)))[:, -1]
    full = posterior_crlb(**dict(inputs, full=True))[-1]
    cases = [
        (white, "without the bias state"),
        (_planned_bound(True), "planned track only"),
        (_planned_bound(False), "two mistakes"),
        (rmse_bound(posterior_crlb(inputs["positions"][0], inputs["beacon"][0], inputs["sigma"], inputs["Q"],
                                   inputs["P0"], bias=True))[-1], "one true track"),
        (np.mean(per_track), "*information*"),
        (bound[0], "last epoch"),
        (bound[-1] ** 2, "square root"),
        (np.sqrt(np.trace(full)), "bias variance"),
    ]
    for answer, words in cases:
        fb = ch10.check_final_bound(answer)
        assert not fb.correct and words in _text(fb), (answer, _text(fb))
    assert not ch10.check_final_bound(bound).correct and "150 numbers" in _text(ch10.check_final_bound(bound))


def test_first_ratio_mistakes_get_their_hint(bound, table):
    rmse = table.rmse_curves[_row(table, "IEKF", "line", "bias")]
    white = rmse_bound(posterior_crlb(**suite.crlb_inputs("line", "white")))
    for answer, words in [(rmse[-1] / bound[-1], "last epoch"), (bound[0] / rmse[0], "over the bound"),
                          (rmse[0] / white[0], "white-noise bound"), (rmse[0] / bound[-1], "*final* bound"),
                          (rmse[0] / np.sqrt(2 * suite.PARAMETERS.start_sigma**2), "prior")]:
        fb = ch10.check_first_ratio(answer)
        assert not fb.correct and words in _text(fb), (answer, _text(fb))


def test_table_mistakes_get_their_hint(table):
    row = table.row("EKF", "line", "white")
    efficiency = [(row["efficiency"], "`efficiency` column"), (row["final_bound"] / row["final_rmse"], "bound over"),
                  (row["median_final_error"] / row["final_bound"], "task (b)"),
                  (row["p95_final_error"] / row["final_bound"], "95th percentile")]
    median = [(row["final_rmse"] / row["final_bound"], "task (a)"),
              (row["final_bound"] / row["median_final_error"], "bound over the median"),
              (row["median_final_error"] / row["mean_bound"], "mean_bound")]
    lost = [(row["divergence_fraction"], "fraction"), (100 * row["divergence_fraction"], "percentage")]
    for check, cases in [(ch10.check_final_efficiency, efficiency), (ch10.check_median_over_bound, median),
                         (ch10.check_lost_runs, lost)]:
        for answer, words in cases:
            fb = check(answer)
            assert not fb.correct and words in _text(fb), (check.__name__, answer, _text(fb))


def test_wrong_choices_get_their_numbers():
    rows = ch10.choice_rows()
    n_wrong = 0
    for letter, method in ch10.CHOICES.items():
        fb = ch10.check_method_choice(letter)
        if fb.correct:
            continue
        r = rows[method]
        assert f"{100 * r['divergence_fraction']:.1f} [" in fb.hint
        assert ("clearly fewer" in fb.hint) == (r["divergence_fraction_upper"] < ch10.MAX_LOST)
        assert fb.details["mistake"] == letter and fb.message.startswith(f"Not yet: {letter}, {method},")
        n_wrong += 1
    assert n_wrong == len(ch10.CHOICES) - len(_expected_choice(methods.load_comparison()))


@pytest.mark.parametrize("check", [ch10.check_final_bound, ch10.check_first_ratio, ch10.check_final_efficiency,
                                   ch10.check_median_over_bound, ch10.check_lost_runs])
def test_bad_numbers_are_named(check):
    assert "No answer yet" in _text(check(None))
    assert "NaN" in _text(check(float("nan")))
    assert "infinite" in _text(check(np.inf))
    assert "quotes" in _text(check("6.4"))
    assert "truth value" in _text(check(True))
    assert "function" in _text(check(rmse_bound))
    for answer in (None, float("nan"), "6.4", True, [1.0, 2.0]):
        assert not check(answer).correct


def test_bad_choices_are_named():
    assert "No answer yet" in _text(ch10.check_method_choice(None))
    for answer, words in [(2, "an int"), ("E", "'E'"), (float("nan"), "a float"), (["B"], "a list"),
                          (True, "a bool")]:
        fb = ch10.check_method_choice(answer)
        assert not fb.correct and '"A", "B", "C", "D"' in fb.message and words in fb.message, (answer, fb.message)
        assert "in quotes" in fb.hint


def test_check_choice_refuses_a_misconfigured_checker():
    with pytest.raises(ValueError, match="expected"):
        check_choice("A", "Z", {"A": "x", "B": "y"})
    with pytest.raises(ValueError, match="at least one"):
        check_choice("A", "A", {})
    with pytest.raises(ValueError, match="case"):
        check_choice("A", "A", {"A": "x", "a": "y"})
    with pytest.raises(ValueError, match="non-empty strings"):
        check_choice("A", "A", {"A": "x", "": "y"})


def test_check_choice_gives_the_wrong_option_its_hint():
    options = {"A": "the EKF", "B": "the particle filter", "C": "the IEKF"}
    fb = check_choice("A", "B", options, name="the method", common_mistakes={"A": "It loses runs."}, hint="Generic.")
    assert not fb.correct and fb.hint == "It loses runs." and fb.details == {"answer": "A", "mistake": "A"}
    fb = check_choice("C", "B", options, name="the method", common_mistakes={"A": "It loses runs."}, hint="Generic.")
    assert not fb.correct and fb.hint == "Generic." and "mistake" not in fb.details
    assert check_choice(" B ", "B", options, explanation="Why.").message.endswith("Why.")


@pytest.mark.parametrize("answer, asks, letter", [("b", "capital letter", "B"), ("a", "capital letter", "A"),
                                                  ("(b)", "capital letter", "B"), ("b.", "capital letter", "B"),
                                                  ("(B)", "letter alone", "B"),
                                                  ("The Particle Filter", "text of option", "B"),
                                                  ("the IEKF", "text of option", "C")])
def test_check_choice_asks_for_the_capital_letter_without_judging_the_choice(answer, asks, letter):
    """The question asks for a capital letter: "b", "(B)" or an option's text are not accepted, and the message says
    what to write, the same whether that option is right or not."""
    options = {"A": "the EKF", "B": "the particle filter", "C": "the IEKF"}
    fb = check_choice(answer, "B", options, name="the method", common_mistakes={"A": "It loses runs."})
    assert not fb.correct and asks in fb.message and f'"{letter}"' in fb.message + fb.hint
    assert "answer" not in fb.details and "right" not in fb.message and "It loses runs" not in (fb.hint or "")
    wrong = check_choice(answer, "A", options, name="the method")
    assert (wrong.message, wrong.hint) == (fb.message, fb.hint), "the message does not tell right from wrong"


def test_method_choice_asks_for_the_letter_of_iekf():
    fb = ch10.check_method_choice("IEKF")
    assert not fb and 'text of option "B"' in fb.message
    assert not ch10.check_method_choice("b") and "capital letter" in ch10.check_method_choice("b").message


def test_source_carries_nbgrader_metadata_and_the_student_version_has_no_solution():
    source = nbformat.read(SOURCE, as_version=4)
    assert nbgrader_problems(source) == []
    assert all(not c.get("outputs") for c in source.cells if c.cell_type == "code")
    kinds = [c.metadata["nbgrader"]["grade_id"].rsplit("_", 1)[-1].rstrip("0123456789")
             for c in source.cells if "nbgrader" in c.metadata]
    assert kinds.count("check") == 7 and kinds.count("answer") == 7 and kinds.count("written") == 3
    student = make_student_version(SOURCE)
    text = "\n".join(c.source for c in student.cells)
    for marker in ("BEGIN SOLUTION", "END SOLUTION", "HIDDEN TESTS", "assert_correct"):
        assert marker not in text
    for solution in ("rmse_bound(posterior_crlb(**inputs))", "rmse[0] / bound[0]", 'ekf_line["final_rmse"]',
                     "divergence_fraction\"] * ", "min(allowed", "mirror image", "line of sight $\\mathbf{e}_1$",
                     "np.outer(h, h) / sigma**2", "Jensen"):
        assert solution not in text, solution
    code = "\n".join(c.source for c in student.cells if c.cell_type == "code")
    assert code.count("# YOUR CODE HERE") == 7 and code.count("raise NotImplementedError") == 7
    assert text.count("YOUR ANSWER HERE") == 3
    for name in ("b_final", "ratio_first", "efficiency_final", "median_ratio", "n_lost", "choice"):
        assert f"{name} = None" in text


def _pcrb(positions, beacon, sigma, Q, P0):
    J = np.linalg.inv(P0)
    out = []
    for p in positions:
        J = np.linalg.inv(Q + np.linalg.inv(J))
        h = (p - beacon) / np.linalg.norm(p - beacon)
        J = J + np.outer(h, h) / sigma**2
        out.append(np.linalg.inv(J))
    return np.array(out)


def test_pcrb_recursion_by_hand():
    assert ch10.check_pcrb_recursion(_pcrb).correct
    no_q = ch10.check_pcrb_recursion(lambda p, b, s, Q, P0: _pcrb(p, b, s, 0 * Q, P0))
    assert not no_q.correct and "prediction" in str(no_q)
    info = ch10.check_pcrb_recursion(lambda *a: np.linalg.inv(_pcrb(*a)))
    assert not info.correct and "information" in str(info)
    origin = ch10.check_pcrb_recursion(lambda p, b, s, Q, P0: _pcrb(p, 0 * b, s, Q, P0))
    assert not origin.correct and "from the beacon" in str(origin)
    assert not ch10.check_pcrb_recursion(None).correct
