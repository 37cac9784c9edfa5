"""Every value a printed solution gives (the book's ``{solution}`` blocks of chapters 1-9) passes its own checker.

The solutions in the exercise notebooks are code, run by ``tests/test_exercise_notebooks.py`` (each check cell must
show a ✔). The book prints its solutions as text, with rounded numbers: "√6 = 2.449", "α ≈ 26.5". Each such number
is read from the text here and fed to the checker of its exercise, so that a student who copies the book's rounding
is told it is right, and a printed value that is wrong fails this test. Every solution block is listed: either with
the values it prints, or with the reason it prints none a checker could take.
"""

from __future__ import annotations

import json
import re
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from uwtutor.exercises import ch01, ch02, ch03, ch04, ch05, ch06, ch07, ch08, ch09

BOOK = Path(__file__).resolve().parents[1] / "book"
_NUMBER = r"(−?-?[0-9][0-9.]*(?:\\times10\^\{?−?-?[0-9]+\}?)?)"


def _float(text: str) -> float:
    text = text.replace("−", "-")
    if "\\times10^" in text:
        mantissa, exponent = text.split("\\times10^")
        return float(mantissa) * 10.0 ** float(exponent.strip("{}"))
    return float(text)


def solution_blocks() -> dict[str, str]:
    """The text of every ``{solution}`` block of chapters 1-9, by the label of its exercise."""
    blocks: dict[str, str] = {}
    for path in sorted(BOOK.glob("ch0[1-9]_*.ipynb")):
        for cell in json.loads(path.read_text(encoding="utf-8"))["cells"]:
            if cell["cell_type"] != "markdown":
                continue
            for match in re.finditer(r"```\{solution\} (\S+)\n(.*?)```", "".join(cell["source"]), re.S):
                blocks[match.group(1)] = match.group(2)
    return blocks


@dataclass(frozen=True)
class Printed:
    """A value a solution prints: the pattern that finds it (one group per number) and how its checker takes it."""

    label: str
    pattern: str
    check: Callable[[list[float]], Any]


PRINTED = [
    Printed("ex-ch01-sound-speed", r"= " + _NUMBER + r"\$ m/s", lambda v: ch01.check_sound_speed(v[0])),
    Printed("ex-ch01-two-way", r"= " + _NUMBER + r"\$ m\. Answering", lambda v: ch01.check_two_way_range(v[0])),
    Printed("ex-ch01-speed-error", r"- 1\) = " + _NUMBER + r"\$ m",
            lambda v: ch01.check_sound_speed_range_error(v[0])),
    Printed("ex-ch01-drift", r"\\approx " + _NUMBER + r"\$ m", lambda v: ch01.check_dr_drift(v[0])),
    Printed("ex-ch02-fisher", r"\\mathbf\{J\} = \\begin\{bmatrix\} " + _NUMBER + r" & " + _NUMBER + r" \\\\ "
            + _NUMBER + r" & " + _NUMBER,
            lambda v: ch02.check_fisher_information(np.reshape(v, (2, 2)))),
    Printed("ex-ch02-fisher", r"\\sqrt\{6\} = " + _NUMBER + r"\$ m", lambda v: ch02.check_rmse_bound(v[0])),
    Printed("ex-ch02-mirror", r"solutions are \$\(" + _NUMBER + r", " + _NUMBER + r"\)\$ and \$\(" + _NUMBER + r", "
            + _NUMBER + r"\)\$", lambda v: ch02.check_mirror_solutions(np.reshape(v, (2, 2)))),
    Printed("ex-ch02-turn", r"root is \$\\theta = " + _NUMBER + r"°", lambda v: ch02.check_halving_turn_angle(v[0])),
    Printed("ex-ch02-current", r"`observability.numerical_rank`\), the rank is " + _NUMBER,
            lambda v: ch02.check_straight_current_rank(int(v[0]))),
    Printed("ex-ch02-current", r"After the turn the rank is " + _NUMBER,
            lambda v: ch02.check_turned_current_rank(int(v[0]))),
    Printed("ex-ch03-alpha", r"\\alpha \\approx " + _NUMBER + r"\$", lambda v: ch03.check_precision_factor(v[0])),
    Printed("ex-ch04-jacobian", r"\\mathbf\{H\} = \(" + _NUMBER + r", " + _NUMBER + r"\)",
            lambda v: ch04.check_range_jacobian(np.array(v))),
    Printed("ex-ch04-nees", r"\\approx\s+" + _NUMBER + r"\$", lambda v: ch04.check_nees(v[0])),
    Printed("ex-ch04-bounds", r"\\approx \[" + _NUMBER + r", " + _NUMBER + r"\]",
            lambda v: ch04.check_nees_bounds(np.array(v))),
    Printed("ex-ch05-factor", r"\\mu_\\gamma = c/c_\\mathrm\{e\} = 1480/1510 = " + _NUMBER,
            lambda v: ch05.check_mu_gamma(v[0])),
    Printed("ex-ch05-factor", r"2/1510 =\s+" + _NUMBER, lambda v: ch05.check_sigma_gamma(v[0])),
    Printed("ex-ch05-factor", r"\\cdot 2500 = " + _NUMBER + r"\$ m", lambda v: ch05.check_mean_range_error(v[0])),
    Printed("ex-ch05-gate", r"\n" + _NUMBER + r" m for \$\\beta = 1\$", lambda v: ch05.check_threshold_beta_one(v[0])),
    Printed("ex-ch05-gate", r"and " + _NUMBER + r" m for \$\\beta = 2000\$",
            lambda v: ch05.check_threshold_beta_range(v[0])),
    Printed("ex-ch06-gm11", r"\$a \\approx " + _NUMBER + r"\$.*?\$b \\approx " + _NUMBER + r"\$ m",
            lambda v: ch06.check_gm11_coefficients(v[0], v[1])),
    Printed("ex-ch06-forecast", r"\\approx " + _NUMBER + r"\$ m, the trend", lambda v: ch06.check_grey_forecast(v[0])),
    Printed("ex-ch06-resampling", r"\\approx " + _NUMBER + r"\$ of 6",
            lambda v: ch06.check_effective_sample_size(v[0])),
    Printed("ex-ch06-q", r"smallest eigenvalue is about " + _NUMBER, lambda v: ch06.check_q_smallest_eigenvalue(v[0])),
    Printed("ex-ch06-q", r"= " + _NUMBER + r"\$\. No", lambda v: ch06.check_q_correlation(v[0])),
    Printed("ex-ch07-q", r"\\operatorname\{diag\}\(" + _NUMBER + r", " + _NUMBER + r", " + _NUMBER + r"\)",
            lambda v: ch07.check_bias_noise(np.diag(v))),
    Printed("ex-ch07-jacobian", r"\\mathbf\{H\} = \[" + _NUMBER + r", " + _NUMBER + r", " + _NUMBER + r"\]",
            lambda v: ch07.check_augmented_jacobian(np.array(v))),
    Printed("ex-ch07-weak", r"\\approx \\pm\[" + _NUMBER + r", " + _NUMBER + r", " + _NUMBER + r"\]",
            lambda v: ch07.check_weak_direction(np.array(v))),
    Printed("ex-ch07-start", r"\+ 1` gives " + _NUMBER + r" ranges", lambda v: ch07.check_start_count(int(v[0]))),
    Printed("ex-ch08-clock", r"c\\,\\kappa = " + _NUMBER + r"\$ m", lambda v: ch08.check_clock_range_error(v[0])),
    Printed("ex-ch08-ambiguity", r"half a period, " + _NUMBER + r" m",
            lambda v: ch08.check_largest_prediction_error(v[0])),
    Printed("ex-ch09-gate", r"- \\hat z \\approx " + _NUMBER + r"\$ m", lambda v: ch09.check_gate_upper(v[0])),
    Printed("ex-ch09-gate", r"y_\\mathrm\{max\}\^2/S \\approx " + _NUMBER, lambda v: ch09.check_equivalent_nis(v[0])),
    Printed("ex-ch09-lock", r"`: " + _NUMBER + r" good ranges", lambda v: ch09.check_good_rejected(int(v[0]))),
    Printed("ex-ch09-ten", r"about " + _NUMBER + r" for the fixes", lambda v: ch09.check_within_ten_percent(v[0])),
]

#: Solution blocks with no value a checker takes, and why.
NOT_CHECKED = {
    "ex-ch01-outliers": "a written answer (which members of a burst the rule misses)",
    "ex-ch02-two-beacons": "exercise 2.5, for pencil and paper (no checker)",
    "ex-ch02-bias": "exercise 2.6, for pencil and paper (no checker)",
    "ex-ch03-count": "its numbers are glued from the chapter's computation (ch03_n_two, ch03_n_one)",
    "ex-ch03-vmlbl": "code for a function; the notebook's solution runs it through its checker",
    "ex-ch03-cost": "code for a function; the notebook's solution runs it through its checker",
    "ex-ch04-update": "code for a function; the notebook's solution runs it through its checker",
    "ex-ch04-run": "code for a function; the notebook's solution runs it through its checker",
    "ex-ch04-diagnosis": "letters chosen from a study; the notebook's solution runs them through the checker",
    "ex-ch05-fading": "code for a function; the notebook's solution runs it through its checker",
    "ex-ch05-ablation": "rounded descriptions of three RMSEs: test_ablation_solution_rounds_the_checked_values",
    "ex-ch05-step": "code for a function; the notebook's solution runs it through its checker",
    "ex-ch06-mad": "the formula only (the value depends on the window of the notebook)",
    "ex-ch06-pf-step": "code for a function; the notebook's solution runs it through its checker",
    "ex-ch07-diagnosis": "letters chosen from a study; the notebook's solution runs them through the checker",
    "ex-ch08-jacobian": "code for a function; the notebook's solution runs it through its checker",
    "ex-ch08-leader": "a study's medians described in words (hundreds of metres against metres)",
    "ex-ch09-vb": "a formula; the notebook's solution runs it through its checker",
}


@pytest.fixture(scope="module")
def blocks():
    return solution_blocks()


@pytest.mark.parametrize("printed", PRINTED, ids=[f"{p.label}-{i}" for i, p in enumerate(PRINTED)])
def test_printed_solution_passes_its_checker(printed, blocks):
    assert printed.label in blocks, f"no solution block {printed.label!r} in the book"
    match = re.search(printed.pattern, blocks[printed.label], re.S)
    assert match, f"{printed.label}: the printed value ({printed.pattern!r}) is no longer in the solution"
    values = [_float(g) for g in match.groups()]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fb = printed.check(values)
    assert fb.correct, f"{printed.label} prints {values}, which its checker refuses:\n{fb}"


def test_every_solution_block_is_accounted_for(blocks):
    checked = {p.label for p in PRINTED}
    missing = sorted(set(blocks) - checked - set(NOT_CHECKED))
    assert not missing, f"solution blocks with neither a checked value nor a reason: {missing}"
    stale = sorted(label for label in NOT_CHECKED if label not in blocks)
    assert not stale, f"listed solution blocks that are gone: {stale}"


def test_ablation_solution_rounds_the_checked_values(blocks):
    """Exercise 5.4's solution describes the three RMSEs as 'about 28 m' and 'about 9.6 m': the rounding of the
    values its checker accepts."""
    from uwtutor.filters.ekf import range_only_ekf
    from uwtutor.filters.fading import fading_ekf

    text = blocks["ex-ch05-ablation"]
    match = re.search(r"About " + _NUMBER + r" m for the EKF and about " + _NUMBER + r" m for the other two", text)
    assert match
    ekf_shown, other_shown = match.group(1), match.group(2)
    s = ch05.study()
    args = (s["x0"], s["P0"], s["u"], s["z"], s["Q"], s["R"])
    ekf = ch05.final_rmse(range_only_ekf(*args).x, s["truth"])
    mult = ch05.final_rmse(fading_ekf(*args, mu_gamma=0.98, sigma_gamma=1 / 1500, fading=False).x, s["truth"])
    isfekf = ch05.final_rmse(fading_ekf(*args, mu_gamma=0.98, sigma_gamma=1 / 1500, rho=0.95, beta="range").x,
                             s["truth"])
    assert ch05.check_final_rmse(ekf, mult, isfekf).correct
    for shown, value in ((ekf_shown, ekf), (other_shown, mult), (other_shown, isfekf)):
        decimals = len(shown.split(".")[1]) if "." in shown else 0
        assert round(value, decimals) == pytest.approx(float(shown)), (shown, value)
