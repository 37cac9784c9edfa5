r"""Checkers for the exercises of chapter 10, "Every method on common ground, against the posterior Cramér–Rao
bound".

Each checker takes the student's answer, computes the expected value with ``uwtutor`` itself (the suite's bound
from :func:`uwtutor.scenarios.suite.crlb_inputs` and :func:`uwtutor.observability.posterior_crlb`, the committed
table from :func:`uwtutor.methods.load_comparison`), and returns a ``Feedback`` that recognises the usual mistakes of
that exercise:

==================================================  ====================================================================
checker                                             exercise
==================================================  ====================================================================
``check_final_bound(b_final)``                      10.1: the final bound :math:`B_K` of the line with a bias
``check_first_ratio(ratio)``                        10.1: the IEKF's RMSE over the bound at the first epoch
``check_final_efficiency(eff)``                     10.2: the EKF's final RMSE over the bound, on the line
``check_median_over_bound(ratio)``                  10.2: its median final error over the bound
``check_lost_runs(n)``                              10.2: the number of its runs that diverged
``check_method_choice(letter)``                     10.3: which method for an approach with a wrong sound speed, with
                                                    intervals
``check_pcrb_recursion(func)``                      10.4: the PCRB recursion written by the student (a function)
==================================================  ====================================================================

The exercises themselves are in the repository's ``exercises/ch10_comparison.ipynb``.

References
----------
P. Tichavský, C. H. Muravchik and A. Nehorai, "Posterior Cramér–Rao bounds for discrete-time nonlinear filtering",
IEEE Trans. Signal Process. 46(5), 1386–1396, 1998.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .. import methods
from ..observability import posterior_crlb, rmse_bound
from ..scenarios import suite
from .checks import Case, _probe_student, check_array, check_choice, check_function, check_number
from .feedback import Feedback

__all__ = [
    "check_final_bound",
    "check_first_ratio",
    "check_final_efficiency",
    "check_median_over_bound",
    "check_lost_runs",
    "check_method_choice",
    "check_pcrb_recursion",
    "pcrb_reference",
    "bound_variants",
    "choice_rows",
    "BOUND_SCENARIO",
    "BOUND_CONDITION",
    "START_METHOD",
    "TABLE_METHOD",
    "TABLE_SCENARIO",
    "TABLE_CONDITION",
    "CHOICE_SCENARIO",
    "CHOICE_CONDITION",
    "MAX_LOST",
    "CHOICES",
]

# -- the data of the exercises -----------------------------------------------------------------------------------------
#: Exercise 10.1: the (scenario, condition) whose bound is computed ...
BOUND_SCENARIO, BOUND_CONDITION = "line", "bias"
#: ... and the method (one with a bias state) whose RMSE is set against it at the first epoch.
START_METHOD = "IEKF"

#: Exercise 10.2: the row of the committed table that is read.
TABLE_METHOD, TABLE_SCENARIO, TABLE_CONDITION = "EKF", "line", "white"

#: Exercise 10.3: the cell of the situation, the largest fraction of runs that may be lost, and the options.
CHOICE_SCENARIO, CHOICE_CONDITION = "turn", "sound speed"
MAX_LOST = 0.05
CHOICES = {"A": "EKF", "B": "IEKF", "C": "LS-ISFEKF", "D": "gated EKF"}


def _pct(fraction: float) -> str:
    return f"{100 * fraction:.1f} %"


# -- exercise 10.1: the bound ------------------------------------------------------------------------------------------
def _rmse_curve(covariance: np.ndarray) -> np.ndarray:
    """The RMSE bound of a stack of covariances, as an array (``rmse_bound`` also takes a single one)."""
    return np.asarray(rmse_bound(covariance))


@lru_cache(maxsize=1)
def _variants() -> tuple[tuple[str, float], ...]:
    inputs = suite.crlb_inputs(BOUND_SCENARIO, BOUND_CONDITION)
    bound = _rmse_curve(posterior_crlb(**inputs))
    white = _rmse_curve(posterior_crlb(**suite.crlb_inputs(BOUND_SCENARIO, "white")))
    runs = suite.SCENARIOS[BOUND_SCENARIO](np.random.default_rng(0), 1)
    planned, beacon = runs.planned[1:], runs.beacon[0, 1:]
    plan_args = dict(sigma=inputs["sigma"], Q=inputs["Q"], P0=inputs["P0"], times=inputs["times"])
    on_plan = _rmse_curve(posterior_crlb(planned, beacon, bias=True, **plan_args))
    on_plan_no_bias = _rmse_curve(posterior_crlb(planned, beacon, sigma=inputs["sigma"], Q=inputs["Q"][:2, :2],
                                                P0=inputs["P0"][:2, :2]))
    one_track = _rmse_curve(posterior_crlb(inputs["positions"][0], inputs["beacon"][0], bias=True, **plan_args))
    per_run = _rmse_curve(posterior_crlb(**dict(inputs, mean_over_runs=False)))
    full = posterior_crlb(**dict(inputs, full=True))
    return (("final", float(bound[-1])), ("first", float(bound[0])), ("white", float(white[-1])),
            ("white_first", float(white[0])), ("planned", float(on_plan[-1])),
            ("planned_no_bias", float(on_plan_no_bias[-1])), ("one_track", float(one_track[-1])),
            ("mean_of_runs", float(np.mean(per_run[:, -1]))),
            ("variance", float(bound[-1] ** 2)), ("with_bias_variance", float(np.sqrt(np.trace(full[-1])))),
            ("prior", float(np.sqrt(np.trace(inputs["P0"][:2, :2])))))


def bound_variants() -> dict[str, float]:
    r"""The right final bound of exercise 10.1 and the values its usual mistakes give [m].

    Returns
    -------
    dict of str to float
        ``"final"``: :math:`B_K` of ``BOUND_SCENARIO`` under ``BOUND_CONDITION``, the expectation over the true
        tracks of ``suite.crlb_inputs``; ``"first"``: :math:`B_1`; ``"white"``, ``"white_first"``: the same without
        the bias state; ``"planned"``: the recursion on the planned track only (no expectation), with the bias
        state; ``"planned_no_bias"``: on the planned track without it; ``"one_track"``: on the first sampled true
        track only; ``"mean_of_runs"``: the mean of the per-track
        bounds (the bounds averaged instead of the information); ``"variance"``: :math:`B_K^2`;
        ``"with_bias_variance"``: :math:`\sqrt{\operatorname{tr}}` of the whole 3-state bound; ``"prior"``: the
        prior's RMS position error :math:`\sqrt{\operatorname{tr} P_0}`.

    Examples
    --------
    >>> # a few bounds over the suite's tracks: about a second, once per session
    >>> v = bound_variants()
    >>> bool(v["final"] > v["white"])  # the bias state costs accuracy
    True
    >>> bool(v["final"] < v["first"])
    True
    """
    return dict(_variants())


def check_final_bound(answer: Any) -> Feedback:
    r"""Check the final bound :math:`B_K = \sqrt{\operatorname{tr}\,[\mathbf J_K^{-1}]_{pp}}` of the line with a
    slowly varying bias (exercise 10.1).

    Parameters
    ----------
    answer : float or None
        The student's :math:`B_K` [m].

    Returns
    -------
    Feedback
        The verdict; the bound without the bias state, the recursion on the planned track (with and without the bias
        state) or on one true track, the mean of the per-track bounds, the first epoch's bound, :math:`B_K^2` and the
        trace with the bias variance are recognised.

    Examples
    --------
    >>> inputs = suite.crlb_inputs(BOUND_SCENARIO, BOUND_CONDITION)
    >>> bound = rmse_bound(posterior_crlb(**inputs))
    >>> check_final_bound(bound[0]).correct  # the first epoch's bound
    False
    >>> check_final_bound(bound[-1]).correct
    True
    """
    v = bound_variants()
    mistakes = {
        v["white"]: "That is the bound without the bias state (crlb_inputs(..., 'white')). Under the bias condition "
                    "an estimator must also estimate the bias: crlb_inputs(..., 'bias') adds it to the state "
                    "(bias=True, a 3 × 3 Q and P0).",
        v["planned"]: "That is the recursion on the planned track only: the expectation E[HᵀR⁻¹H] must run over "
                      "the true tracks, which scatter about the plan. Pass all of crlb_inputs' tracks with "
                      "mean_over_runs=True (posterior_crlb(**inputs) does it).",
        v["planned_no_bias"]: "That is the recursion on the planned track, without the bias state: two mistakes. Use "
                              "crlb_inputs(..., 'bias') and all its tracks: posterior_crlb(**inputs).",
        v["one_track"]: "That is the recursion on one true track (positions[0]): the expectation runs over all "
                        "of them. Pass every track with mean_over_runs=True (posterior_crlb(**inputs) does it).",
        v["mean_of_runs"]: "That averages the bounds of the tracks one by one (mean_over_runs=False). The PCRB "
                           "averages the *information* over the tracks, then inverts: keep mean_over_runs=True.",
        v["first"]: "That is the bound after the first range, B_1; the task asks for the last epoch, bound[-1].",
        v["variance"]: "That is B_K², in m²: the bound on the RMSE is the square root of the trace of the position "
                       "block (rmse_bound does it).",
        v["with_bias_variance"]: "That includes the bias variance in the trace: B_K is the bound on the *position* "
                                 "error, the x and y block only (rmse_bound keeps the first two states).",
    }
    return check_number(answer, v["final"], rtol=1e-3, name="the final bound B_K", units="m",
                        common_mistakes=mistakes,
                        hint=f"inputs = suite.crlb_inputs({BOUND_SCENARIO!r}, {BOUND_CONDITION!r}); "
                             "bound = rmse_bound(posterior_crlb(**inputs)); B_K is bound[-1].",
                        explanation=f"The bias state costs {v['final'] / v['white']:.2f} times the white-noise bound "
                                    f"({v['white']:.2f} m); the committed table's final_bound of this cell is the "
                                    "same number.")


def _first_ratios() -> dict[str, float]:
    table = methods.load_comparison()
    row = table.index(START_METHOD, BOUND_SCENARIO, BOUND_CONDITION)
    rmse = table.rmse_curves[row]
    v = bound_variants()
    return {"expected": float(rmse[0] / v["first"]), "final": float(rmse[-1] / v["final"]),
            "inverted": float(v["first"] / rmse[0]), "white": float(rmse[0] / v["white_first"]),
            "prior": float(rmse[0] / v["prior"]), "final_bound": float(rmse[0] / v["final"])}


def check_first_ratio(answer: Any) -> Feedback:
    r"""Check :math:`\mathrm{RMSE}_1 / B_1`, the IEKF's RMSE over the bound after the first range, on the line with a
    bias (exercise 10.1).

    :math:`\mathrm{RMSE}_1` is the first entry of the committed table's ``rmse_curves`` row of (``START_METHOD``,
    ``BOUND_SCENARIO``, ``BOUND_CONDITION``).

    Parameters
    ----------
    answer : float or None
        The student's ratio (dimensionless).

    Returns
    -------
    Feedback
        The verdict; the ratio at the last epoch, the inverted ratio, the white-noise bound, the final bound and the
        prior's RMS in the denominator are recognised.

    Examples
    --------
    >>> table = methods.load_comparison()
    >>> row = table.index(START_METHOD, BOUND_SCENARIO, BOUND_CONDITION)
    >>> rmse = table.rmse_curves[row]
    >>> inputs = suite.crlb_inputs(BOUND_SCENARIO, BOUND_CONDITION)
    >>> bound = rmse_bound(posterior_crlb(**inputs))
    >>> check_first_ratio(rmse[-1] / bound[-1]).correct  # the last epoch's ratio
    False
    >>> check_first_ratio(rmse[0] / bound[0]).correct
    True
    """
    r = _first_ratios()
    mistakes = {
        r["final"]: "That is the ratio at the last epoch (rmse[-1] / bound[-1]); the task asks for the first, index 0.",
        r["inverted"]: "That is B_1 / RMSE_1; the ratio asked for is the RMSE over the bound (≥ 1 for any method).",
        r["white"]: "That divides by the white-noise bound; use the bound of the bias condition, your `bound[0]`.",
        r["final_bound"]: "That divides the first RMSE by the *final* bound B_K; divide by B_1 = bound[0].",
        r["prior"]: "That divides by the prior's RMS error √tr P0; divide by the bound after the first range, "
                    "bound[0].",
    }
    return check_number(answer, r["expected"], rtol=2e-3, name="the ratio RMSE_1 / B_1", common_mistakes=mistakes,
                        hint=f"row = the index of the ({START_METHOD}, {BOUND_SCENARIO}, {BOUND_CONDITION}) row of "
                             "the table; table.rmse_curves[row][0] / bound[0].",
                        explanation=f"At the last epoch the same ratio is {r['final']:.2f}: the bound is loose at "
                                    "the start and tighter once the ranges have done their work.")


# -- exercise 10.2: reading the table ----------------------------------------------------------------------------------
def _table_row() -> dict[str, Any]:
    row: dict[str, Any] = methods.load_comparison().row(TABLE_METHOD, TABLE_SCENARIO, TABLE_CONDITION)
    return row


def check_final_efficiency(answer: Any) -> Feedback:
    r"""Check the final efficiency :math:`\mathrm{RMSE}_K / B_K` of the EKF on the line under white noise, from the
    committed table (exercise 10.2).

    Parameters
    ----------
    answer : float or None
        The student's ratio (dimensionless).

    Returns
    -------
    Feedback
        The verdict; the run-averaged efficiency, the inverted ratio, the median and the 95th percentile over the
        bound are recognised.

    Examples
    --------
    >>> table = methods.load_comparison()
    >>> row = table.row(TABLE_METHOD, TABLE_SCENARIO, TABLE_CONDITION)
    >>> # inverted
    >>> check_final_efficiency(row["final_bound"] / row["final_rmse"]).correct
    False
    >>> check_final_efficiency(row["final_rmse"] / row["final_bound"]).correct
    True
    """
    row = _table_row()
    expected = row["final_rmse"] / row["final_bound"]
    mistakes = {
        row["efficiency"]: "That is the `efficiency` column, the RMSE averaged over the run over the bound averaged "
                           "over the run; the task asks for the last epoch: final_rmse / final_bound.",
        row["final_bound"] / row["final_rmse"]: "That is the bound over the RMSE; the efficiency ratio is the RMSE "
                                                "over the bound (1 for an efficient estimator, larger otherwise).",
        row["median_final_error"] / row["final_bound"]: "That is the median final error over the bound (task (b)); "
                                                        "the efficiency uses the RMSE, final_rmse.",
        row["p95_final_error"] / row["final_bound"]: "That is the 95th percentile over the bound; use final_rmse.",
    }
    return check_number(answer, expected, rtol=1e-3, name="the final efficiency", common_mistakes=mistakes,
                        hint=f"row = table.row({TABLE_METHOD!r}, {TABLE_SCENARIO!r}, {TABLE_CONDITION!r}); "
                             "row['final_rmse'] / row['final_bound'].",
                        explanation="It is also the table's final_efficiency column.")


def check_median_over_bound(answer: Any) -> Feedback:
    r"""Check the median final error over the final bound, :math:`\operatorname{med}\lVert e_K \rVert / B_K`, of the
    EKF on the line under white noise (exercise 10.2).

    Parameters
    ----------
    answer : float or None
        The student's ratio (dimensionless).

    Returns
    -------
    Feedback
        The verdict; the final efficiency (RMSE over the bound), the inverted ratio and the median over the
        run-averaged bound are recognised.

    Examples
    --------
    >>> table = methods.load_comparison()
    >>> row = table.row(TABLE_METHOD, TABLE_SCENARIO, TABLE_CONDITION)
    >>> # the RMSE, not the median
    >>> check_median_over_bound(row["final_rmse"] / row["final_bound"]).correct
    False
    >>> median = row["median_final_error"]
    >>> check_median_over_bound(median / row["final_bound"]).correct
    True
    """
    row = _table_row()
    expected = row["median_final_error"] / row["final_bound"]
    mistakes = {
        row["final_rmse"] / row["final_bound"]: "That is the final RMSE over the bound (task (a)); this one uses the "
                                                "median final error, median_final_error.",
        row["final_bound"] / row["median_final_error"]: "That is the bound over the median; divide the median by the "
                                                        "bound.",
        row["median_final_error"] / row["mean_bound"]: "That divides by the bound averaged over the run (mean_bound); "
                                                       "use the final bound, final_bound.",
    }
    return check_number(answer, expected, rtol=1e-3, name="the median final error over the bound",
                        common_mistakes=mistakes,
                        hint="row['median_final_error'] / row['final_bound'].",
                        explanation=f"Against the final efficiency of {row['final_rmse'] / row['final_bound']:.2f}: "
                                    "the typical run ends close to the bound.")


def check_lost_runs(answer: Any) -> Feedback:
    """Check the number of runs of the EKF on the line under white noise whose final error is above the divergence
    threshold (50 m), from the committed table (exercise 10.2).

    Parameters
    ----------
    answer : int or None
        The student's count (of the row's ``n_runs`` runs).

    Returns
    -------
    Feedback
        The verdict; the fraction and the percentage instead of the count are recognised.

    Examples
    --------
    >>> from uwtutor import methods
    >>> row = methods.load_comparison().row("EKF", "line", "white")
    >>> bool(check_lost_runs(round(row["divergence_fraction"] * row["n_runs"])))
    True
    >>> print(check_lost_runs(row["divergence_fraction"]).hint)
    That is the fraction of the runs (divergence_fraction); the task asks how many runs: multiply by n_runs.
    """
    row = _table_row()
    count = row["divergence_fraction"] * row["n_runs"]
    expected = int(round(count))
    if abs(count - expected) > 1e-6:
        raise RuntimeError(f"the table's divergence fraction times its runs is not a whole number: {count!r}")
    fraction = row["divergence_fraction"]
    mistakes = {
        fraction: "That is the fraction of the runs (divergence_fraction); the task asks how many runs: multiply by "
                  "n_runs.",
        100 * fraction: "That is the percentage of the runs; the task asks how many runs of the row's n_runs.",
    }
    return check_number(answer, expected, rtol=0, atol=1e-6, name="the number of runs lost",
                        common_mistakes=mistakes,
                        hint="row['divergence_fraction'] * row['n_runs']; a run is lost when its final error is above "
                             "row['divergence_threshold'] (50 m).",
                        explanation=f"{expected} of {row['n_runs']} runs: {_pct(fraction)}.")


# -- exercise 10.3: which method when ----------------------------------------------------------------------------------
def choice_rows() -> dict[str, dict[str, Any]]:
    """The committed table's rows of the cell of exercise 10.3 (``CHOICE_SCENARIO``, ``CHOICE_CONDITION``), keyed by
    method (every method that runs on the scenario).

    Examples
    --------
    >>> rows = choice_rows()
    >>> set(CHOICES.values()) <= set(rows)  # every option is in the table's cell
    True
    >>> rows["EKF"]["scenario"], rows["EKF"]["condition"]
    ('turn', 'sound speed')
    """
    table = methods.load_comparison()
    hit = np.flatnonzero((table.scenario == CHOICE_SCENARIO) & (table.condition == CHOICE_CONDITION))
    rows = table.rows()
    return {rows[i]["method"]: rows[i] for i in hit}


def _choice_verdicts() -> tuple[dict[str, Any], Any]:
    """The lost-fraction verdicts of the options against ``MAX_LOST`` and the ranking, by median final error on the
    same runs, of the options whose lost fraction is clearly below it."""
    from ..statistics import lost_verdict

    table = methods.load_comparison()
    verdicts = {}
    for method in CHOICES.values():
        i = table.index(method, CHOICE_SCENARIO, CHOICE_CONDITION)
        verdicts[method] = (lost_verdict(int(table.n_lost[i]), int(table.n_runs[i]), MAX_LOST),
                            table.cell_statistics(method, CHOICE_SCENARIO, CHOICE_CONDITION))
    eligible = [m for m, (v, _) in verdicts.items() if v == "clearly below"]
    if not eligible:
        raise RuntimeError(f"no option loses clearly fewer than {_pct(MAX_LOST)} of the runs in ({CHOICE_SCENARIO}, "
                           f"{CHOICE_CONDITION}): the exercise needs a new cell")
    return verdicts, table.ranking(CHOICE_SCENARIO, CHOICE_CONDITION, "median", methods=eligible)


def check_method_choice(answer: Any) -> Feedback:
    """Check the method chosen for an approach with one turn and a wrong sound speed, when the mission needs a lost
    fraction *clearly* below ``MAX_LOST`` (exercise 10.3; a letter of ``CHOICES``).

    The right choice is read off the committed table with intervals (chapter 10's rule): keep the options whose lost
    fraction's 95 % Wilson interval lies below ``MAX_LOST`` (:func:`uwtutor.statistics.lost_verdict`), then take the
    lowest median final error; an option whose paired difference from it on the same runs contains zero is tied, and
    as right.

    Parameters
    ----------
    answer : str or None
        The student's letter, ``"A"`` to ``"D"``.

    Returns
    -------
    Feedback
        The verdict; each wrong option gets its own hint, with its numbers from the table: a lost fraction whose
        interval reaches above the limit (however low its median), and one within the limit that ends farther off
        (with the paired interval).

    Examples
    --------
    >>> print(check_method_choice(4))
    ✘ Not yet: the method for this situation should be one of the letters "A", "B", "C", "D"; got an int, 4.
      Hint: Write the letter in quotes, e.g. `choice = "A"`.
    """
    verdicts, ranking = _choice_verdicts()
    letters = {m: k for k, m in CHOICES.items()}
    best = ranking.best
    given = answer.strip() if isinstance(answer, str) else answer
    right = letters[best[0]]
    if isinstance(given, str) and given in CHOICES and CHOICES[given] in best:
        right = given                                   # a tie with the leader is as right
    mistakes = {}
    for key, method in CHOICES.items():
        verdict, cs = verdicts[method]
        lost, median = cs.lost_fraction.format(".1f", 100), cs.median_final_error.estimate
        if verdict != "clearly below":
            what = "straddles" if verdict == "undecided" else "lies above"
            mistakes[key] = (f"{key} ({method}) loses {lost} % of its runs: that interval {what} the "
                             f"{_pct(MAX_LOST)} the mission can afford, so 1000 runs cannot show it meets the limit, "
                             f"although its median final error is {median:.1f} m.")
        elif method not in best:
            iv = ranking.interval(method, ranking.order[0])
            mistakes[key] = (f"{key} ({method}) loses clearly fewer than one run in twenty ({lost} %), but on the same "
                             f"runs its median is {iv.format('.1f')} m above {ranking.order[0]}'s: the interval "
                             "excludes zero.")
    lead = verdicts[best[0]][1]
    explanation = (f"{best[0]} loses {lead.lost_fraction.format('.1f', 100)} % of the runs and ends at "
                   f"{lead.median_final_error.estimate:.1f} m in median.")
    tied = [m for m in best[1:] if m in letters]
    if tied:
        explanation += " Tied with it on the same runs: " + ", ".join(f"{letters[m]} ({m})" for m in tied) + "."
    return check_choice(answer, right, CHOICES, name="the method for this situation", common_mistakes=mistakes,
                        hint="Keep the methods whose lost fraction's interval (table.cell_statistics(...)"
                             ".lost_fraction) lies below 0.05, then compare their medians on the same runs "
                             "(table.paired(a, b, 'turn', 'sound speed').median_difference).",
                        explanation=explanation)


# -- exercise 10.4: the recursion by hand ------------------------------------------------------------------------------
def pcrb_reference(positions: ArrayLike, beacon: ArrayLike, sigma: float, Q: ArrayLike, P0: ArrayLike) -> np.ndarray:
    r"""The reference for exercise 10.4: :math:`\mathbf J_k^{-1}` after each epoch of one track (``F = I``), from
    :func:`uwtutor.observability.posterior_crlb`.

    Parameters
    ----------
    positions : array_like, shape (K, 2)
        The true positions at the ranging epochs [m].
    beacon : array_like, shape (2,)
        The beacon [m].
    sigma : float
        Range noise standard deviation [m].
    Q, P0 : array_like, shape (2, 2)
        Process noise per epoch and prior covariance [m²].

    Returns
    -------
    ndarray, shape (K, 2, 2)

    Examples
    --------
    >>> phi = np.radians(np.arange(12) * 15.0)
    >>> arc = 1000.0 * np.column_stack([np.cos(phi), np.sin(phi)])
    >>> P0 = 100.0 ** 2 * np.eye(2)
    >>> bounds = pcrb_reference(arc, [0.0, 0.0], 2.0, np.eye(2), P0)
    >>> bounds.shape
    (12, 2, 2)
    >>> bool(np.trace(bounds[-1]) < np.trace(bounds[0]))
    True
    """
    positions = np.asarray(positions, dtype=float)
    return posterior_crlb(positions, np.broadcast_to(np.asarray(beacon, float), positions.shape), float(sigma),
                          np.asarray(Q, float), np.asarray(P0, float))


def _pcrb_cases() -> list[Case]:
    phi = np.radians(np.arange(12) * 15.0)
    arc = 1000.0 * np.column_stack([np.cos(phi), np.sin(phi)])
    line = np.column_stack([np.linspace(-300.0, 300.0, 10), np.full(10, 400.0)])
    return [
        Case((arc, np.zeros(2), 2.0, np.eye(2), 100.0**2 * np.eye(2)), label="an arc of 12 epochs about the beacon",
             hint="Predict, then add the range's information: J = inv(Q + inv(J)) + h hᵀ / σ², h the unit line of "
                  "sight from the beacon to the true position; J₀ = inv(P0). Return inv(J) after each epoch."),
        Case((line, np.array([50.0, -20.0]), 3.0, 4.0 * np.eye(2), 50.0**2 * np.eye(2)),
             label="a straight pass, a beacon off the origin",
             hint="The line of sight is (p − b)/‖p − b‖: from the beacon, not from the origin."),
        Case((arc[:3], np.zeros(2), 1.0, np.zeros((2, 2)), 1e4 * np.eye(2)), label="no process noise (Q = 0)",
             hint="With Q = 0 the prediction leaves J unchanged: inv(0 + inv(J)) = J."),
    ]


def check_pcrb_recursion(func: Any) -> Feedback:
    r"""Check a student's ``pcrb(positions, beacon, sigma, Q, P0)`` against :func:`pcrb_reference` (exercise 10.4).

    Parameters
    ----------
    func : callable or None
        The student's function, returning :math:`\mathbf J_k^{-1}` of shape (K, 2, 2).

    Returns
    -------
    Feedback
        The verdict; returning the information :math:`\mathbf J_k` instead of its inverse, and forgetting the
        prediction (no :math:`\mathbf Q`), are recognised.

    Examples
    --------
    >>> def pcrb(positions, beacon, sigma, Q, P0):
    ...     J, out = np.linalg.inv(P0), []
    ...     for p in np.asarray(positions, dtype=float):
    ...         J = np.linalg.inv(Q + np.linalg.inv(J))  # predict
    ...         h = (p - beacon) / np.linalg.norm(p - beacon)
    ...         J = J + np.outer(h, h) / sigma ** 2  # add the range's information
    ...         out.append(np.linalg.inv(J))
    ...     return np.array(out)
    >>> # J_k, not the bound J_k⁻¹
    >>> def information(positions, beacon, sigma, Q, P0):
    ...     return np.linalg.inv(pcrb(positions, beacon, sigma, Q, P0))
    >>> check_pcrb_recursion(information).correct
    False
    >>> check_pcrb_recursion(pcrb).correct
    True
    """
    cases = _pcrb_cases()
    if callable(func):
        args = cases[0].args
        got, stopped = _probe_student(func, args, "pcrb_recursion")
        if stopped is not None:
            return stopped                         # a loop or sys.exit(), stopped within the time limit
        ref = pcrb_reference(*args)
        if got is not None and got.shape == ref.shape:
            if np.allclose(got, np.linalg.inv(ref), rtol=1e-6):
                return Feedback(False, "Not yet: that is the information J_k, not the bound J_k⁻¹.",
                                hint="Return np.linalg.inv(J) after each epoch.", details={"mistake": "information"})
            no_q = pcrb_reference(args[0], args[1], args[2], np.zeros((2, 2)), args[4])
            if np.allclose(got, no_q, rtol=1e-6):
                return Feedback(False, "Not yet: that is the bound without process noise: the prediction step "
                                       "J ← inv(Q + inv(J)) is missing, so old ranges never lose their weight.",
                                hint="Before adding each range's information, predict: J = inv(Q + inv(J)).",
                                details={"mistake": "no prediction"})
    compare = lambda got, expected: check_array(got, expected, rtol=1e-6, atol=1e-9, name="the bounds J_k⁻¹",  # noqa
                                                units="m²")
    return check_function(func, pcrb_reference, cases, name="pcrb", compare=compare,
                          hint="J₀ = inv(P0); for each epoch: J = inv(Q + inv(J)), then J += h hᵀ / σ² with h the "
                               "unit line of sight from the beacon; store inv(J).",
                          explanation="This is posterior_crlb on one track with F = I: the information filter of "
                                      "chapter 4 with the Jacobian taken at the true position.")
