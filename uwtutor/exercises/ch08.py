r"""Checkers for the exercises of chapter 8, "Cooperative localization from a moving leader, with the current in the
state".

Each checker takes the student's answer, computes the expected value with ``uwtutor`` itself from the exercise's data
(the constants below), and returns a ``Feedback`` that recognises the usual mistakes of that exercise:

==================================================  ====================================================================
checker                                             exercise
==================================================  ====================================================================
``check_clock_range_error(error)``                  8.1: the range error of a clock with an offset and a drift
``check_resolve(func)``                             8.2: putting the whole seconds back into a travel time (a function)
``check_largest_prediction_error(error)``           8.2: how far the prediction may be off
``check_pair_jacobian(func)``                       8.3: the Jacobian of paper B's squared-range pair (a function)
``check_leader_errors(errors)``                     8.4: the median errors for the three leader patterns
``check_unobservable_pattern(name)``                8.4: which pattern leaves the state unobservable
==================================================  ====================================================================

The exercises themselves are in the repository's ``exercises/ch08_cooperative.ipynb``.

References
----------
"AUV cooperative localization method based on motion radius vector in the presence of unknown currents" (paper B).
"""

from __future__ import annotations

import functools
import warnings
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..errors import UnobservableWarning
from ..filters.cooperative import cooperative_ekf
from ..models.cooperative import SquaredRangePair
from ..owtt import clock_range_error, resolve_travel_time
from ..scenarios import paper_b
from .checks import Case, _a_type, _probe_student, check_array, check_function, check_number
from .feedback import Feedback

__all__ = [
    "check_clock_range_error",
    "resolve_reference",
    "check_resolve",
    "check_largest_prediction_error",
    "pair_jacobian_reference",
    "check_pair_jacobian",
    "leader_study",
    "check_leader_errors",
    "check_unobservable_pattern",
    "CLOCK_OFFSET",
    "CLOCK_DRIFT",
    "CLOCK_TIME",
    "SOUND_SPEED",
    "STUDY_SEED",
    "STUDY_RUNS",
    "LATE_WINDOW",
]

# -- the data of the exercises -----------------------------------------------------------------------------------------
#: Exercise 8.1: the follower's clock offset [s] ...
CLOCK_OFFSET = 0.4e-3
#: ... its drift [s/s] ...
CLOCK_DRIFT = 5e-6
#: ... the time since the synchronization [s] ...
CLOCK_TIME = 2000.0
#: ... and the sound speed of exercises 8.1 and 8.2 [m/s].
SOUND_SPEED = 1500.0

#: Exercise 8.4: the seed and the number of runs of the study, and the window of the medians [s].
STUDY_SEED = 8
STUDY_RUNS = 200
LATE_WINDOW = 1000.0


# -- exercise 8.1: what a clock costs ----------------------------------------------------------------------------------
def check_clock_range_error(answer: Any) -> Feedback:
    r"""Check :math:`c\,(\kappa_0 + \dot\kappa\,t)` for exercise 8.1.

    Parameters
    ----------
    answer : float or None
        The student's range error [m].

    Returns
    -------
    Feedback
        The verdict; the offset or the drift alone, a two-way halving and a millisecond slip are recognised.

    Examples
    --------
    >>> # the offset alone
    >>> check_clock_range_error(SOUND_SPEED * CLOCK_OFFSET).correct
    False
    >>> clock_error = CLOCK_OFFSET + CLOCK_DRIFT * CLOCK_TIME
    >>> check_clock_range_error(SOUND_SPEED * clock_error).correct
    True
    """
    c, e0, rate, t = SOUND_SPEED, CLOCK_OFFSET, CLOCK_DRIFT, CLOCK_TIME
    expected = float(clock_range_error(t, e0, rate, c))
    mistakes = {
        c * e0: "That is the offset alone: the drift adds κ̇·t = 5e-6 × 2000 s = 10 ms on top of it.",
        c * rate * t: "That is the drift alone: the offset of 0.4 ms is still there.",
        expected / 2: "One-way ranging: the travel time covers the distance once, r = c·τ, with no factor 1/2.",
        c * (e0 * 1e3 + rate * t): "The offset is 0.4 ms = 0.4e-3 s: convert it to seconds before adding.",
    }
    return check_number(answer, expected, rtol=1e-3, name="the range error", units="m", common_mistakes=mistakes,
                        hint="The clock error is κ = κ₀ + κ̇·t (seconds); the range error is c·κ.",
                        explanation="Every range is that much too long: a bias that no filter of ranges alone can "
                                    "remove, and it keeps growing with the drift.")


# -- exercise 8.2: the whole second ------------------------------------------------------------------------------------
def resolve_reference(wrapped: ArrayLike, predicted_range: ArrayLike) -> np.ndarray:
    r"""The reference for exercise 8.2: ``uwtutor.owtt.resolve_travel_time`` with :math:`c` = 1500 m/s and
    :math:`T_\mathrm{s}` = 1 s.

    Parameters
    ----------
    wrapped : array_like
        Travel times modulo 1 s [s].
    predicted_range : array_like
        Predicted ranges [m].

    Returns
    -------
    ndarray
        The travel times [s].

    Examples
    --------
    >>> resolve_reference([0.25, 0.9], [1875.0, 1350.0])
    array([1.25, 0.9 ])
    """
    return np.asarray(resolve_travel_time(wrapped, predicted_range, SOUND_SPEED, 1.0), dtype=float)


def _resolve_cases() -> list[Case]:
    return [
        Case((np.array([0.25, 0.9, 0.1]), np.array([1875.0, 1350.0, 150.0])),
             label="predictions right on the truth",
             hint="Add the whole seconds n = round((r̂ / c − τ_w) / 1 s) to the wrapped travel time."),
        Case((np.array([0.25, 0.25]), np.array([2500.0, 1300.0])),
             label="predictions 625 m off on either side",
             hint="Round to the *nearest* whole second (np.round), not down (np.floor) or up."),
        Case((np.array([0.95, 0.02]), np.array([100.0, 20.0])),
             label="short ranges, where the prediction is below the wrapped value",
             hint="The number of whole seconds cannot be negative: take max(0, n)."),
        Case((np.array([0.6, 0.4, 0.3]), np.array([4400.0, 2200.0, 6480.0])),
             label="several whole seconds (ranges of 2 to 6.5 km)",
             hint="The prediction gives the travel time r̂ / c; convert with c = 1500 m/s."),
    ]


def check_resolve(func: Any) -> Feedback:
    r"""Check a student's ``resolve(wrapped, predicted_range)`` (exercise 8.2).

    Parameters
    ----------
    func : callable or None
        The student's function.

    Returns
    -------
    Feedback
        The verdict; the failing case names the usual cause (floor instead of round, a negative count, the range
        not converted to a time).

    Examples
    --------
    >>> def resolve_floor(wrapped, predicted_range):  # rounds down
    ...     w = np.asarray(wrapped, dtype=float)
    ...     n = np.floor(np.asarray(predicted_range) / SOUND_SPEED - w)
    ...     return w + np.maximum(0, n)
    >>> def resolve(wrapped, predicted_range):
    ...     w = np.asarray(wrapped, dtype=float)
    ...     n = np.round(np.asarray(predicted_range) / SOUND_SPEED - w)
    ...     return w + np.maximum(0, n)
    >>> check_resolve(resolve_floor).correct
    False
    >>> check_resolve(resolve).correct
    True
    """
    return check_function(
        func, resolve_reference, _resolve_cases(), name="resolve",
        compare=lambda got, expected: check_array(got, expected, rtol=1e-9, atol=1e-12, name="the travel times",
                                                  units="s"),
        hint="τ = τ_w + n·(1 s), n = max(0, round((r̂ / c − τ_w) / 1 s)).",
        explanation="A prediction within half a period of the truth rounds to the right whole second.")


def check_largest_prediction_error(answer: Any) -> Feedback:
    r"""Check :math:`c\,T_\mathrm{s}/2` = 750 m for exercise 8.2.

    Parameters
    ----------
    answer : float or None
        The largest prediction error that still resolves correctly [m].

    Returns
    -------
    Feedback
        The verdict; a whole period (1500 m) and the answer in seconds are recognised.

    Examples
    --------
    >>> check_largest_prediction_error(SOUND_SPEED * 1.0).correct  # a whole period
    False
    >>> check_largest_prediction_error(SOUND_SPEED * 1.0 / 2).correct
    True
    """
    expected = SOUND_SPEED * 1.0 / 2.0
    mistakes = {
        2 * expected: "A whole period is 1500 m, but the rounding picks the *nearest* whole second: beyond half a "
                      "period it picks the neighbouring one.",
        0.5: "That is in seconds; the task asks for metres (multiply by c).",
    }
    return check_number(answer, expected, rtol=1e-3, name="the largest prediction error", units="m",
                        common_mistakes=mistakes, hint="The rounding is right while |r̂/c − τ| < T_s / 2.",
                        explanation="Dead reckoning drifts that far in about 18 minutes with paper B's current.")


# -- exercise 8.3: the consistent Jacobian -----------------------------------------------------------------------------
def pair_jacobian_reference(x_pred: ArrayLike, leader_k: ArrayLike, leader_k1: ArrayLike, u_k: ArrayLike,
                            dt: float) -> np.ndarray:
    r"""The reference for exercise 8.3: the Jacobian of :math:`[r_k^2, r_{k+1}^2]` at the predicted state, from
    ``uwtutor.models.cooperative.SquaredRangePair``.

    Parameters
    ----------
    x_pred : array_like, shape (4,)
        :math:`[x, y, U_x, U_y]` after the move.
    leader_k, leader_k1 : array_like, shape (2,)
        The leader at the two epochs [m].
    u_k : array_like, shape (2,)
        The DR displacement over the interval [m].
    dt : float
        :math:`\delta t` [s].

    Returns
    -------
    ndarray, shape (2, 4)

    Examples
    --------
    >>> x_pred, u_k = [0.0, 0.0, 0.0, 0.0], [0.0, 0.0]
    >>> H = pair_jacobian_reference(x_pred, [100.0, 0.0], [0.0, 100.0], u_k, 10.0)
    >>> # rows 2 s_k (and −2 δt s_k for the current), 2 s_(k+1)
    >>> np.round(H, 6) + 0.0
    array([[-200.,    0., 2000.,    0.],
           [   0., -200.,    0.,    0.]])
    """
    leader = np.stack([np.asarray(leader_k, float), np.asarray(leader_k1, float)])
    pair = SquaredRangePair(leader, np.asarray(u_k, float)[None], dt, np.eye(10))
    H: np.ndarray = pair.H(np.asarray(x_pred, float)[None], 0)[0]
    return H


def _jacobian_cases() -> list[Case]:
    return [
        Case((np.array([150.0, -30.0, 0.5, 0.4]), np.array([900.0, 300.0]), np.array([910.0, 320.0]),
              np.array([16.0, 2.0]), 8.0), label="a leader 800 m away, paper B's interval",
              hint="The first range was taken before the move: s_k = p − u_k − δt·U − p^M_k, and it is the first row "
                   "that depends on the current, through −δt·U."),
        Case((np.array([0.0, 0.0, 0.0, 0.0]), np.array([100.0, 0.0]), np.array([0.0, 100.0]),
              np.array([0.0, 0.0]), 10.0), label="no current, no motion, the leader on two axes",
              hint="Row 2 is 2(p − p^M_(k+1)) in x and y and zero for the current."),
        Case((np.array([50.0, 50.0, -0.3, 0.7]), np.array([-200.0, 400.0]), np.array([-190.0, 410.0]),
              np.array([-5.0, 12.0]), 4.0), label="another interval, a negative current component",
              hint="The current columns of row 1 are −2·δt·a, with δt of this case."),
    ]


def check_pair_jacobian(func: Any) -> Feedback:
    r"""Check a student's ``pair_jacobian(x_pred, leader_k, leader_k1, u_k, dt)`` (exercise 8.3).

    Parameters
    ----------
    func : callable or None
        The student's function.

    Returns
    -------
    Feedback
        The verdict; paper B's literal Jacobian (evaluated at the prediction as printed) and the Jacobian of the
        ranges instead of the squared ranges are recognised.

    Examples
    --------
    >>> def zeros(x_pred, leader_k, leader_k1, u_k, dt):
    ...     return np.zeros((2, 4))
    >>> check_pair_jacobian(zeros).correct
    False
    >>> check_pair_jacobian(pair_jacobian_reference).correct
    True
    """
    cases = _jacobian_cases()
    x, b0, b1, u, dt = cases[0].args
    literal = SquaredRangePair(np.stack([b0, b1]), u[None], dt, np.eye(10), literal=True).H(x[None], 0)[0]
    if callable(func):
        got, refusal = _probe_student(func, (x, b0, b1, u, dt), "pair_jacobian")
        if refusal is not None:
            return refusal                  # a loop or sys.exit(): no need to run it on every case
        if got is not None and got.shape == literal.shape and np.allclose(got, literal, rtol=1e-9, atol=1e-9):
            return Feedback(False, "Not yet: that is paper B's Jacobian evaluated at the predicted state as printed "
                                   "(eq. 11 with x_(k+1|k) in place of x_k).",
                            hint="The predicted state is *after* the move. Write r_k² through p_k = p − u_k − δt·U: "
                                 "the current then appears in row 1 (as −2δt·s_k), and row 2 has none.",
                            details={"mistake": "literal"})
        if got is not None and got.shape == literal.shape:
            ref = pair_jacobian_reference(x, b0, b1, u, dt)
            ranges = np.linalg.norm(ref[:, :2], axis=-1)          # |2 s| = 2 r on each row
            if np.allclose(got * ranges[:, None], ref, rtol=1e-6, atol=1e-9):
                return Feedback(False, "Not yet: that is the Jacobian of the ranges [r_k, r_(k+1)], each row divided "
                                       "by 2r; paper B measures the squared ranges.",
                                hint="d(r²)/dx = 2s, not s/‖s‖: drop the division by the range (the rows are "
                                     "[2s_k, −2δt·s_k] and [2s_(k+1), 0, 0]).",
                                details={"mistake": "ranges"})
    compare = lambda got, expected: check_array(got, expected, rtol=1e-9, atol=1e-9, name="the Jacobian")  # noqa
    return check_function(func, pair_jacobian_reference, cases, name="pair_jacobian", compare=compare,
                          hint="Rows [2s_k, −2δt·s_k] and [2s_(k+1), 0, 0] with s_k = p − u_k − δt·U − p^M_k and "
                               "s_(k+1) = p − p^M_(k+1).",
                          explanation="This is paper B's eq. (11) at the previous estimate times ∂x_k/∂x_(k+1).")


# -- exercise 8.4: which leader? ---------------------------------------------------------------------------------------
@functools.lru_cache(maxsize=1)
def _study() -> dict[str, tuple[float, bool]]:
    out = {}
    tune = paper_b.matched_tuning()
    for pattern in paper_b.LEADER_PATTERNS:
        sc = paper_b.make(np.random.default_rng(STUDY_SEED), STUDY_RUNS, leader_pattern=pattern)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", UnobservableWarning)
            res = cooperative_ekf(sc.initial_estimate(), u=sc.dr_displacements, z=sc.ranges,
                                  leader=sc.leader_broadcast, dt=sc.params.interval, **tune.as_kwargs())
        err = np.linalg.norm(res.x[..., :2] - sc.true_positions[1:], axis=-1)
        late = sc.times[1:] >= sc.times[-1] - LATE_WINDOW
        out[pattern] = (float(np.median(err[:, late])), any(issubclass(w.category, UnobservableWarning)
                                                            for w in caught))
    return out


def leader_study() -> dict[str, float]:
    r"""The expected answer of exercise 8.4: for each leader pattern, the median position error over the runs and the
    last ``LATE_WINDOW`` seconds [m] (``STUDY_RUNS`` runs, seed ``STUDY_SEED``, ``paper_b.matched_tuning``).

    Returns
    -------
    dict of str to float

    Examples
    --------
    >>> # 200 runs per pattern: about a second, once per session
    >>> errors = leader_study()
    >>> sorted(errors)
    ['circling', 'parallel', 'zigzag']
    >>> bool(errors["parallel"] > 10 * errors["zigzag"])
    True
    """
    return {name: err for name, (err, _) in _study().items()}


def check_leader_errors(answer: Any) -> Feedback:
    r"""Check the median errors of exercise 8.4, a dict ``{"zigzag": ..., "parallel": ..., "circling": ...}`` [m].

    Parameters
    ----------
    answer : dict or None
        The student's medians.

    Returns
    -------
    Feedback
        The first pattern whose value is wrong (the mean instead of the median, all epochs instead of the last
        1000 s are recognised); correct when all three are.

    Examples
    --------
    >>> # an entry per pattern is needed
    >>> check_leader_errors({"zigzag": 1.0}).correct
    False
    >>> check_leader_errors(leader_study()).correct
    True
    """
    if answer is None:
        return Feedback(False, "No answer yet: fill the dict `errors` with one median per leader pattern.",
                        hint="Run cooperative_ekf for each pattern, then np.median over the runs and the late epochs.")
    if not isinstance(answer, dict):
        return Feedback(False, f"`errors` must be a dict from pattern name to metres; got a {type(answer).__name__}.")
    missing = [p for p in paper_b.LEADER_PATTERNS if p not in answer]
    if missing:
        return Feedback(False, f"`errors` has no entry for {', '.join(missing)}.",
                        hint=f"Use the keys {', '.join(paper_b.LEADER_PATTERNS)}.")
    expected = leader_study()
    for pattern in paper_b.LEADER_PATTERNS:
        fb = check_number(answer[pattern], expected[pattern], rtol=1e-3, name=f"the median error for {pattern}",
                          units="m", hint=f"Use {STUDY_RUNS} runs with seed {STUDY_SEED}, the matched tuning, and the "
                                          f"epochs of the last {LATE_WINDOW:.0f} s; take the median, not the mean.")
        if not fb.correct:
            return fb
    return Feedback(True, "Correct: " + ", ".join(f"{p} {v:.1f} m" for p, v in expected.items()) + ".",
                    details={"expected": expected})


def check_unobservable_pattern(answer: Any) -> Feedback:
    r"""Check the name of the leader pattern that leaves the state unobservable (exercise 8.4).

    Parameters
    ----------
    answer : str or None
        One of ``paper_b.LEADER_PATTERNS``.

    Returns
    -------
    Feedback

    Examples
    --------
    >>> # no such pattern: answered before the study runs
    >>> check_unobservable_pattern("spiral").correct
    False
    >>> errors = leader_study()
    >>> # the pattern whose error grows
    >>> check_unobservable_pattern(max(errors, key=errors.get)).correct
    True
    """
    # the answer is read before the study runs (8 s the first time): a name that is no pattern is answered at once
    if answer is None or answer is Ellipsis:
        return Feedback(False, "No answer yet: set `unobservable` to the name of a pattern.")
    if not isinstance(answer, str) or answer not in paper_b.LEADER_PATTERNS:   # never `in` on any object: an
        shown = repr(answer) if isinstance(answer, str) else _a_type(answer)      # array's == is elementwise
        return Feedback(False, f"{shown} is not a leader pattern; choose one of "
                               f"{', '.join(paper_b.LEADER_PATTERNS)}.",
                        hint='Give the name in quotes, e.g. `unobservable = "' + paper_b.LEADER_PATTERNS[0] + '"`.')
    flagged = [p for p, (_, warned) in _study().items() if warned]
    if answer in flagged:
        return Feedback(True, f"Correct: with a {answer} leader the relative track is straight (here a point), the "
                              "rank of the information stays at 2 and the filter emits an UnobservableWarning.")
    return Feedback(False, f"Not yet: the {answer} leader bends the relative track, so the ranges see position and "
                           "current.", hint="Which pattern keeps the follower's position relative to the leader "
                                            "constant? Look for the UnobservableWarning.")
