r"""Checkers for the exercises of chapter 9, "The virtual moving long baseline" (paper E).

Each checker takes the student's answer, computes the expected value from the exercise's data (the constants below)
with ``uwtutor`` itself, and returns a ``Feedback`` that recognises the usual mistakes of that exercise:

==================================================  ====================================================================
checker                                             exercise
==================================================  ====================================================================
``check_gate_upper(y_max)``                         9.1: the largest innovation paper E's test accepts
``check_equivalent_nis(nis)``                       9.1: the NIS threshold that gate amounts to
``check_virtual_beacons(vb)``                       9.2: four virtual beacons from the ship's and the DR positions
``check_good_rejected(n)``                          9.3: the good ranges lost to a lock-out
``check_within_ten_percent(fraction)``              9.4: the trial's statistic, on a simulated dive
==================================================  ====================================================================

The exercises themselves are in the repository's ``exercises/ch09_virtual_baseline.ipynb``.

References
----------
Paper E (VMLBL for the manned submersible *Jiaolong*), secs. 1.1-1.3 and 2.
"""

from __future__ import annotations

import functools
import warnings
from typing import Any

import numpy as np
from scipy import stats

from ..errors import IllConditionedWarning, UwtutorWarning
from ..filters.robust import moment_gate_interval, robust_range_kf
from ..pipelines import or_vmlbl_kf
from ..scenarios import paper_e
from .checks import check_array, check_number
from .feedback import Feedback

__all__ = [
    "check_gate_upper",
    "check_equivalent_nis",
    "check_virtual_beacons",
    "check_good_rejected",
    "check_gate_by_hand",
    "check_within_ten_percent",
    "lockout_dive",
    "study",
    "Z_PRED",
    "S_INNOV",
    "DELTA",
    "SHIP",
    "DR",
    "LOCKOUT_SEED",
    "STUDY_SEED",
    "STUDY_SPACING",
]

# -- the data of the exercises -----------------------------------------------------------------------------------------
#: Exercise 9.1: the predicted range (m), the innovation variance (m²) and paper E's tolerance.
Z_PRED = 2000.0
S_INNOV = 3.0
DELTA = 0.03

#: ... and the relative tolerance of its y_max: a rounding to centimetres passes, the approximation δẑ/2 does not.
GATE_UPPER_RTOL = 1e-3

#: Exercise 9.2: the ship's positions at four epochs (m) ...
SHIP = np.array([[0.0, 0.0], [250.0, 180.0], [420.0, 460.0], [380.0, 800.0]])
#: ... and the submersible's DR positions at the same epochs (m).
DR = np.array([[-900.0, -1100.0], [-830.0, -1030.0], [-760.0, -960.0], [-690.0, -890.0]])

#: Exercise 9.3: the seed of the dive (``paper_e.make(default_rng(LOCKOUT_SEED))``, paper E's outliers).
LOCKOUT_SEED = 1

#: Exercise 9.4: the seed of the dive and the spacing of the fix's epochs (s).
STUDY_SEED = 58
STUDY_SPACING = 40


# -- exercise 9.1: the gate --------------------------------------------------------------------------------------------
def check_gate_upper(answer: Any) -> Feedback:
    r"""Check the largest innovation :math:`y_\mathrm{max} = \sqrt{(1+\delta)(S + \hat z^2)} - \hat z` (exercise 9.1).

    Accepted within ``GATE_UPPER_RTOL`` (0.1 %, a rounding to centimetres): the first-order approximation
    :math:`\delta\hat z/2` (0.7 % too large, an innovation the test rejects) is recognised, not accepted.

    Parameters
    ----------
    answer : float or None
        The student's :math:`y_\mathrm{max}` [m].

    Returns
    -------
    Feedback
        The verdict; :math:`\delta \hat z` (no square root), the lower edge of the gate (with either sign), the
        largest accepted *range* and the interval in m² are recognised.

    Examples
    --------
    >>> lo, hi = moment_gate_interval(Z_PRED, S_INNOV, DELTA)
    >>> check_gate_upper(DELTA * Z_PRED).correct  # δẑ: z compared instead of z²
    False
    >>> z_max = np.sqrt((1 + DELTA) * (S_INNOV + Z_PRED ** 2))
    >>> check_gate_upper(z_max - Z_PRED).correct
    True
    """
    lo, hi = moment_gate_interval(Z_PRED, S_INNOV, DELTA)
    D = S_INNOV + Z_PRED**2
    lower_edge = ("That is the lower edge of the gate, where z² = (1 − δ)D: the most negative innovation accepted. "
                  "The gate is symmetric in z², not in z, so the upper edge, z² = (1 + δ)D, is a little closer to ẑ.")
    mistakes = {
        float(lo): lower_edge,
        float(-lo): lower_edge,
        DELTA * Z_PRED: "That is δ·ẑ. The test compares z², not z, with D(1 ± δ): a relative tolerance δ on the "
                        "square is about δ/2 on the range itself.",
        float(np.sqrt((1 + DELTA) * D)): "That is the largest range the test accepts; the innovation is that range "
                                         "minus the prediction ẑ.",
        DELTA * D: "That is the half-width of the interval for z² (in m²); take the square root of (1 + δ)D and "
                   "subtract ẑ.",
        float(np.sqrt(DELTA * D)): "√(δD) is not the gate: solve z² = (1 + δ)D for z, then y = z − ẑ.",
        DELTA * Z_PRED / 2: "That is the first-order approximation δẑ/2; an innovation of that size lies just "
                            "outside the gate (z² exceeds (1 + δ)D). Solve z² = (1 + δ)D for z exactly and "
                            "subtract ẑ.",
    }
    return check_number(answer, float(hi), rtol=GATE_UPPER_RTOL, name="the largest accepted innovation", units="m",
                        common_mistakes=mistakes,
                        hint="Accepted means (1 − δ)D ≤ z² ≤ (1 + δ)D with D = S + ẑ²; write z = ẑ + y.",
                        explanation=f"About δẑ/2 = {DELTA * Z_PRED / 2:g} m: a gate of 1.5 % of the range, "
                                    "whatever S is.")


def check_equivalent_nis(answer: Any) -> Feedback:
    r"""Check the NIS threshold :math:`y_\mathrm{max}^2 / S` of paper E's gate (exercise 9.1).

    Parameters
    ----------
    answer : float or None
        The student's threshold (dimensionless).

    Returns
    -------
    Feedback
        The verdict; the gate in standard deviations (not squared), the chi-square quantile and
        :math:`y_\mathrm{max}^2` without dividing by :math:`S` are recognised.

    Examples
    --------
    >>> _, y_max = moment_gate_interval(Z_PRED, S_INNOV, DELTA)
    >>> check_equivalent_nis(y_max ** 2).correct  # in m², not divided by S
    False
    >>> check_equivalent_nis(y_max ** 2 / S_INNOV).correct
    True
    """
    _, hi = moment_gate_interval(Z_PRED, S_INNOV, DELTA)
    expected = float(hi**2 / S_INNOV)
    mistakes = {
        float(hi / np.sqrt(S_INNOV)): "That is the gate in standard deviations of the innovation, y_max/√S; the "
                                      "NIS is its square.",
        float(stats.chi2.ppf(0.99, 1)): "That is the chi-square gate's threshold at 99 %; the task asks what paper "
                                        "E's test amounts to.",
        float(hi**2): "That is y_max² in m²; the NIS divides by S.",
    }
    return check_number(answer, expected, rtol=0.03, name="the equivalent NIS threshold", common_mistakes=mistakes,
                        hint="The NIS of a scalar innovation is y²/S.",
                        explanation=f"The chi-square gate at 99 % stops at {stats.chi2.ppf(0.99, 1):.2f}: paper E's "
                                    "test lets through innovations of many standard deviations.")


# -- exercise 9.2: virtual beacons -------------------------------------------------------------------------------------
def check_virtual_beacons(answer: Any) -> Feedback:
    r"""Check :math:`\mathbf b^\mathrm v_i = \mathbf a_i - \mathbf d_i` with
    :math:`\mathbf d_i = \mathbf p^\mathrm{DR}_i - \mathbf p^\mathrm{DR}_4`, for ``SHIP`` and ``DR`` (exercise 9.2).

    Parameters
    ----------
    answer : array_like, shape (4, 2), or None
        The student's virtual beacons [m], oldest first.

    Returns
    -------
    Feedback
        The verdict; the shift with the wrong sign (a_i + d_i) and the shift from the first epoch are recognised.

    Examples
    --------
    >>> # the ship moved backwards
    >>> check_virtual_beacons(SHIP - (DR[-1] - DR)).correct
    False
    >>> check_virtual_beacons(SHIP + (DR[-1] - DR)).correct
    True
    """
    expected = SHIP + (DR[-1] - DR)
    mistakes = [
        (SHIP - (DR[-1] - DR), "The ship must be moved *forward* by the submersible's displacement since epoch i "
                               "(b_i = a_i − d_i, with d_i = p_i − p_4 from the DR): the old range was taken from "
                               "a point that many metres behind."),
        (SHIP + (DR - DR[0]), "The shift is the displacement from epoch i to *now* (epoch 4), not from the first "
                              "epoch to epoch i."),
    ]
    return check_array(answer, expected, rtol=0, atol=1e-6, name="the array of virtual beacons", units="m",
                       common_mistakes=mistakes,
                       hint="Paper E, eq. (14): VB_i = AB_i + (sum of the submersible's moves from epoch i to now).",
                       explanation="The last virtual beacon is the ship itself; every old range is now a range from "
                                   "the current position.")


# -- exercise 9.3: the lock-out ----------------------------------------------------------------------------------------
def lockout_dive() -> paper_e.Dive:
    """The dive of exercise 9.3 (one run, paper E's parameters and outliers).

    Examples
    --------
    >>> dive = lockout_dive()
    >>> dive.slant_ranges.shape == dive.outlier_mask.shape
    True
    """
    return paper_e.make(np.random.default_rng(LOCKOUT_SEED), 1)


def check_good_rejected(answer: Any) -> Feedback:
    """Check the number of good ranges the literal method (no re-acquisition) rejects on ``lockout_dive()``
    (exercise 9.3).

    Parameters
    ----------
    answer : int or None
        The student's count.

    Returns
    -------
    Feedback
        The verdict; counting the outliers too, counting with the default re-acquisition, and one too many (an
        off-by-one) are recognised.

    Examples
    --------
    >>> dive = lockout_dive()
    >>> good = ~dive.outlier_mask[0]
    >>> with warnings.catch_warnings():
    ...     # the lock-out is the point of the exercise
    ...     warnings.simplefilter("ignore", UwtutorWarning)
    ...     literal = robust_range_kf(dive.slant_ranges[0], 1.0, reacquire=None)
    >>> rejected = literal.extras["rejected"]
    >>> # the outliers counted too
    >>> check_good_rejected(int(np.sum(rejected))).correct
    False
    >>> check_good_rejected(int(np.sum(rejected & good))).correct
    True
    """
    expected, all_rejected, default_rejected, default_outlier, first, last = _good_rejected_counts()
    mistakes: dict[float, str] = {
        all_rejected: "That counts every rejected range, the 30 outliers included; keep "
                      "only the epochs where outlier_mask is False.",
        default_rejected: "That is with the default re-acquisition after 20 "
                          "rejections; the task asks for reacquire=None.",
        default_outlier: "That is the default filter's final classification, after "
                         "re-acquisition cleared its window; use reacquire=None.",
    }
    mistakes.setdefault(expected + 1, f"One too many (an off-by-one, not a rounding): the good ranges rejected run "
                                      f"from epoch {first} to epoch {last}, both included. Counting from the last "
                                      f"outlier (epoch {first - 1}), or last − first + 2, gives one more; count with "
                                      f"np.sum(rejected & good).")
    return check_number(answer, expected, rtol=0, atol=0.5, name="the number of good ranges rejected",
                        common_mistakes=mistakes,
                        hint="Use extras['rejected'] and the dive's outlier_mask (True on the outliers).",
                        explanation="All of them come after the patch of 20 at 700 s: the prediction drifted out of "
                                    "the ±δr/2 gate before the patch ended.")


@functools.lru_cache(maxsize=1)
def _good_rejected_counts() -> tuple[int, int, int, int, int, int]:
    """The expected count of exercise 9.3, the counts of its recognised mistakes, and the first and last epochs of
    the good ranges rejected (computed once: 6 s)."""
    dive = lockout_dive()
    z = dive.slant_ranges[0]
    good = ~np.asarray(dive.outlier_mask[0])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UwtutorWarning)       # the lock-out is the point of the exercise
        literal = robust_range_kf(z, 1.0, reacquire=None)
        default = robust_range_kf(z, 1.0)
    first, last = np.flatnonzero(literal.extras["rejected"] & good)[[0, -1]]
    return (int(np.sum(literal.extras["rejected"] & good)), int(np.sum(literal.extras["rejected"])),
            int(np.sum(default.extras["rejected"] & good)), int(np.sum(default.extras["outlier"] & good)),
            int(first), int(last))


def _hand_gate_rejected(z: np.ndarray, *, on_range: bool = False, no_s: bool = False, update_rejected: bool = False,
                        from_first: bool = False) -> np.ndarray:
    """Exercise 9.3(b)'s range filter and gate written out (the task's recipe), or with one typical slip.

    ``on_range``: δ applied to z instead of z² ((1 − δ)√D ≤ z ≤ (1 + δ)√D); ``no_s``: D = ẑ² without S;
    ``update_rejected``: the update made even on a rejected range; ``from_first``: the gate tried on the first
    range too (the start itself).
    """
    dt, q, r = 1.0, 2.0, 2.0
    F = np.array([[1.0, dt], [0.0, 1.0]])
    Q = q * np.array([[dt**4 / 4, dt**3 / 2], [dt**3 / 2, dt**2]])
    x, P = np.array([z[0], 0.0]), np.diag([r, 25.0])
    rejected = np.zeros(len(z), dtype=bool)
    for k in range(0 if from_first else 1, len(z)):
        if k > 0:
            x, P = F @ x, F @ P @ F.T + Q
        S = P[0, 0] + r
        D = (0.0 if no_s else S) + x[0] ** 2
        if on_range:
            accepted = (1 - DELTA) * np.sqrt(D) <= z[k] <= (1 + DELTA) * np.sqrt(D)
        else:
            accepted = (1 - DELTA) * D <= z[k] ** 2 <= (1 + DELTA) * D
        rejected[k] = not accepted
        if accepted or update_rejected:
            K = P[:, 0] / S
            x = x + K * (z[k] - x[0])
            P = P - np.outer(K, P[0])
    return rejected


@functools.lru_cache(maxsize=1)
def _hand_gate_counts() -> dict[str, int]:
    """The good ranges rejected by the gate of exercise 9.3(b) as the task writes it and with each slip."""
    dive = lockout_dive()
    z = np.asarray(dive.slant_ranges[0], dtype=float)
    good = ~np.asarray(dive.outlier_mask[0])
    counts = {"right": int(np.sum(_hand_gate_rejected(z) & good)),
              "all": int(np.sum(_hand_gate_rejected(z)))}
    for slip in ("on_range", "no_s", "update_rejected"):
        counts[slip] = int(np.sum(_hand_gate_rejected(z, **{slip: True}) & good))
    return counts


def check_gate_by_hand(answer: Any) -> Feedback:
    """Check the number of good ranges rejected by the range filter and gate written by hand (exercise 9.3(b)).

    The count must equal that of ``robust_range_kf(..., reacquire=None)`` (task (a)); the hints are those of a
    gate written by hand: δ applied to the range instead of its square, D without S, an update made on a rejected
    range, the outliers counted too.

    Parameters
    ----------
    answer : int or None
        The student's count.

    Returns
    -------
    Feedback
        The verdict, with a hint for a recognised slip of the hand-written gate.

    Examples
    --------
    >>> dive = lockout_dive()
    >>> z = np.asarray(dive.slant_ranges[0])
    >>> good = ~np.asarray(dive.outlier_mask[0])
    >>> check_gate_by_hand(int(np.sum(_hand_gate_rejected(z) & good))).correct
    True
    """
    expected = _good_rejected_counts()[0]
    counts = _hand_gate_counts()
    if counts["right"] != expected:
        raise RuntimeError(f"the gate written out counts {counts['right']} good ranges rejected, robust_range_kf "
                           f"{expected}: the recipe of exercise 9.3(b) no longer matches the library")
    hints = {
        "all": "That counts every rejected range, the outliers included; keep only the good ones "
               "(rejected & good).",
        "on_range": "Your gate applies δ to the range: (1 − δ)√D ≤ z ≤ (1 + δ)√D is about twice as wide as paper "
                    "E's test, which applies it to the square: (1 − δ)D ≤ z² ≤ (1 + δ)D.",
        "no_s": "D = S + ẑ², with S = P₁₁ + R the innovation variance: the test compares z² with the expected value "
                "of z², not with ẑ² alone.",
        "update_rejected": "A rejected range must not update the filter: keep the prediction (x, P) and go on to "
                           "the next range.",
    }
    mistakes: dict[float, str] = {}
    for key, text in hints.items():
        if counts[key] != expected:
            mistakes.setdefault(float(counts[key]), text)
    return check_number(answer, expected, rtol=0, atol=0.5, name="the number of good ranges your gate rejected",
                        common_mistakes=mistakes,
                        hint="Follow the recipe step by step: predict, S = P₁₁ + R, D = S + ẑ², test z² against "
                             "(1 ± δ)D, update only when accepted; then count rejected & good.",
                        explanation="The same count as robust_range_kf(..., reacquire=None): that is all paper E's "
                                    "test is.")


# -- exercise 9.4: the 10 % statistic ----------------------------------------------------------------------------------
def study() -> dict[str, Any]:
    """The dive and the OR-VMLBL-KF run of exercise 9.4: ``{"dive", "result", "truth", "slant"}`` (the true
    positions and slant ranges at the fixes' epochs).

    Examples
    --------
    >>> s = study()
    >>> s["result"].fixes.shape == s["truth"].shape
    True
    >>> s["slant"].shape == s["truth"].shape[:1]
    True
    """
    dive = paper_e.make(np.random.default_rng(STUDY_SEED), 1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IllConditionedWarning)
        result = or_vmlbl_kf(dive.dr_positions[0], dive.slant_ranges[0], ship_positions=dive.ship_positions[0],
                             depth=dive.depth,
                             spacing=STUDY_SPACING)
    return {"dive": dive, "result": result, "truth": np.asarray(dive.true_positions[0])[result.now],
            "slant": np.asarray(dive.true_slant_ranges[0])[result.now]}


@functools.lru_cache(maxsize=1)
def _cached_study() -> dict[str, Any]:
    """``study()`` computed once for the checker (the student's own copy stays theirs)."""
    return study()


def check_within_ten_percent(answer: Any) -> Feedback:
    """Check the fraction of OR-VMLBL fixes of ``study()`` whose error is at most 10 % of the slant range
    (exercise 9.4).

    Parameters
    ----------
    answer : float or None
        The student's fraction, between 0 and 1.

    Returns
    -------
    Feedback
        The verdict; a fraction rounded to two decimals is accepted (the task gives no precision); a percentage
        instead of a fraction, the horizontal range instead of the slant range, the cascade filter's fixes and an
        absolute 10 m are recognised.

    Examples
    --------
    >>> s = study()
    >>> err = np.linalg.norm(s["result"].fixes - s["truth"], axis=-1)
    >>> fraction = np.mean(err <= 0.1 * s["slant"])
    >>> check_within_ten_percent(100 * fraction).correct  # a percentage
    False
    >>> check_within_ten_percent(fraction).correct
    True
    """
    s = _cached_study()
    err = np.linalg.norm(s["result"].fixes - s["truth"], axis=-1)
    track = np.linalg.norm(s["result"].filtered - s["truth"], axis=-1)
    horizontal = np.linalg.norm(s["truth"] - np.asarray(s["dive"].ship_positions[0])[s["result"].now], axis=-1)
    expected = float(np.mean(err <= 0.1 * s["slant"]))
    mistakes = {
        100 * expected: "That is a percentage; give the fraction (between 0 and 1).",
        float(np.mean(err <= 0.1 * horizontal)): "That uses the horizontal distance to the ship; the ranges (and "
                                                 "the usual USBL specification) are slant ranges.",
        float(np.mean(track <= 0.1 * s["slant"])): "That is OR-VMLBL-KF (result.filtered); the task asks for the "
                                                   "fixes themselves (result.fixes).",
        float(np.mean(err <= 10.0)): "That counts errors under 10 m; '10 %' is relative to the range.",
    }
    return check_number(answer, expected, rtol=0, atol=0.005, name="the fraction within 10 %",
                        common_mistakes=mistakes,
                        hint="Error = distance between result.fixes and the true positions; compare it with 0.1 × "
                             "the true slant range at the same epochs.",
                        explanation="With the epochs only 40 s apart the fixes are noisy; the cascade filter "
                                    "brings the statistic close to 1.")
