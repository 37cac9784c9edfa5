r"""Checkers for the exercises of chapter 2, "Range-only observability and the limits of accuracy".

Each checker takes the student's answer, computes the expected value from the exercise's data (the constants below)
with ``uwtutor.observability``, and returns a ``Feedback`` that recognises the usual mistakes of that exercise:

==================================================  ====================================================================
checker                                             exercise
==================================================  ====================================================================
``check_fisher_information(J)``                     2.1: the 2×2 Fisher information of three beacons, by hand
``check_rmse_bound(bound)``                         2.1: the RMSE bound :math:`\sqrt{\operatorname{tr} J^{-1}}` from it
``check_mirror_solutions(candidates)``              2.2: the two positions that fit two ranges and a displacement
``check_halving_turn_angle(angle_deg)``             2.3: the turn that halves the bound of a 10° turn (unknown current)
``check_straight_current_rank(rank)``               2.4: the rank of a straight track's Jacobian with an unknown current
``check_unobservable_direction(direction)``         2.4: a direction of the state that no range can see
``check_turned_current_rank(rank)``                 2.4: the rank once the track has turned
==================================================  ====================================================================

The exercises themselves are in the repository's ``exercises/ch02_observability.ipynb``.

References
----------
Y. Bar-Shalom, X. R. Li and T. Kirubarajan, *Estimation with Applications to Tracking and Navigation*, Wiley, 2001.
A. S. Gadre and D. J. Stilwell, "A complete solution to underwater navigation in the presence of unknown currents
based on range measurements from a single location", IROS 2005.
"""

from __future__ import annotations

import functools
import math
import warnings
from typing import Any

import numpy as np
from scipy.optimize import brentq

from .. import motion, observability
from .._validate import as_scalar
from .checks import _as_scalar, _is_unanswered, check_array, check_number, not_answered, parse_real_array
from .feedback import Feedback

__all__ = [
    "check_fisher_information",
    "check_rmse_bound",
    "check_mirror_solutions",
    "check_halving_turn_angle",
    "check_straight_current_rank",
    "check_unobservable_direction",
    "check_turned_current_rank",
    "turn_track",
    "turn_rmse_bound",
    "straight_current_jacobian",
    "FIX_POSITION",
    "FIX_BEACONS",
    "FIX_SIGMA",
    "MIRROR_BEACON",
    "MIRROR_DISPLACEMENT",
    "MIRROR_RANGES",
    "TURN_TIMES",
    "TURN_START",
    "TURN_SPEED",
    "TURN_TIME",
    "TURN_SIGMA",
    "REFERENCE_TURN_DEG",
    "CURRENT_TIMES",
    "CURRENT_START",
    "CURRENT_VELOCITY",
]

# -- the data of the exercises -----------------------------------------------------------------------------------------
#: The vehicle's position in exercise 2.1 (m) ...
FIX_POSITION = np.array([0.0, 0.0])
#: ... the three beacons (m), at bearings 0°, 90° and 225° from it ...
FIX_BEACONS = np.array([[1000.0, 0.0], [0.0, 500.0], [-800.0, -800.0]])
#: ... and the standard deviation of every range (m).
FIX_SIGMA = 2.0

#: The beacon of exercise 2.2 (m) ...
MIRROR_BEACON = np.array([200.0, -100.0])
#: ... the dead-reckoned displacement between the two ranges (m) ...
MIRROR_DISPLACEMENT = np.array([300.0, 100.0])
_MIRROR_TRUE_POSITION = np.array([-100.0, 400.0])
#: ... and the two ranges [before, after the displacement] (m), exact (computed from the true positions).
MIRROR_RANGES = np.array([np.hypot(*(_MIRROR_TRUE_POSITION - MIRROR_DISPLACEMENT - MIRROR_BEACON)),
                          np.hypot(*(_MIRROR_TRUE_POSITION - MIRROR_BEACON))])

#: The ranging epochs of exercise 2.3 (s), every 10 s for 20 min ...
TURN_TIMES = np.arange(0.0, 1200.0 + 1e-9, 10.0)
#: ... the start of the track (m), whose first leg runs due east ...
TURN_START = (-1500.0, 600.0)
#: ... its speed (m/s) ...
TURN_SPEED = 2.0
#: ... the time of the heading change (s) ...
TURN_TIME = 600.0
#: ... the range noise (m) ...
TURN_SIGMA = 5.0
#: ... and the turn (degrees, to the left) whose bound is to be halved.
REFERENCE_TURN_DEG = 10.0

#: The ranging epochs of exercise 2.4 (s) ...
CURRENT_TIMES = np.arange(0.0, 1200.0 + 1e-9, 10.0)
#: ... the start of the straight track (m), beacon at the origin ...
CURRENT_START = np.array([-1500.0, 600.0])
#: ... and its ground velocity (m/s), 2 m/s due east.
CURRENT_VELOCITY = np.array([2.0, 0.0])


# -- exercise 2.1: Fisher information and the bound of three beacons --------------------------------------------------
def _unit_rows(position: np.ndarray, beacons: np.ndarray) -> np.ndarray:
    d = position - beacons
    directions: np.ndarray = d / np.linalg.norm(d, axis=1, keepdims=True)
    return directions


def check_fisher_information(answer: Any) -> Feedback:
    r"""Check the 2×2 Fisher information of exercise 2.1: :math:`J = \sum_i h_i^\mathsf{T} h_i / \sigma^2`.

    Parameters
    ----------
    answer : array_like or None
        The student's matrix [1/m²].

    Returns
    -------
    Feedback
        The verdict; the bound instead of the information, a missing :math:`1/\sigma^2`, :math:`\sigma` instead of
        :math:`\sigma^2`, line-of-sight vectors that are not unit vectors and the sum of :math:`h_i` instead of its
        outer products are recognised.

    Examples
    --------
    >>> from uwtutor import observability
    >>> check_fisher_information(np.eye(2)).correct
    False
    >>> J = observability.fisher_information(FIX_BEACONS, FIX_POSITION, FIX_SIGMA)
    >>> check_fisher_information(J).correct
    True
    """
    expected = observability.fisher_information(FIX_BEACONS, FIX_POSITION, FIX_SIGMA)
    h = _unit_rows(FIX_POSITION, FIX_BEACONS)
    raw = FIX_POSITION - FIX_BEACONS
    unscaled = h.T @ h
    s = h.sum(axis=0)
    mistakes = [
        (np.linalg.inv(expected), "That is the inverse of the information: the Cramér–Rao bound (the task's second "
                                  "part). The information itself is the sum of h_iᵀ h_i / σ²."),
        (unscaled, "Divide by the range variance σ² = 4 m²: each range carries information 1/σ² along its line of "
                   "sight."),
        (unscaled / FIX_SIGMA, "Divide by the variance σ² = 4 m², not by the standard deviation σ = 2 m."),
        (unscaled * FIX_SIGMA ** 2, "Divide by σ², do not multiply: noisier ranges carry less information."),
        (raw.T @ raw / FIX_SIGMA ** 2, "Use unit line-of-sight vectors h_i = (p − b_i)/‖p − b_i‖: the derivative of a "
                                       "range does not grow with the distance."),
        (np.outer(s, s) / FIX_SIGMA ** 2, "Sum the outer products h_iᵀ h_i of the rows, not the rows themselves: "
                                          "J = Σ h_iᵀ h_i / σ²."),
    ]
    return check_array(answer, expected, rtol=1e-6, atol=1e-9, name="the Fisher information", units="1/m²",
                       common_mistakes=mistakes,
                       hint="Build h_i = (p − b_i)/‖p − b_i‖ for each beacon (here (−1, 0), (0, −1) and "
                            "(1, 1)/√2), then add up h_iᵀ h_i (`np.outer(h, h)`) and divide by σ².",
                       explanation="The cross terms come only from the beacon at 225°: two beacons at right angles "
                                   "alone would give a diagonal matrix.")


def check_rmse_bound(answer: Any) -> Feedback:
    r"""Check the RMSE bound of exercise 2.1: :math:`\sqrt{\operatorname{tr} J^{-1}}` (m).

    Parameters
    ----------
    answer : float or None
        The student's bound in metres.

    Returns
    -------
    Feedback
        The verdict; the trace without the square root, the square root of a single variance, of the determinant,
        of the largest eigenvalue, and :math:`1/\sqrt{\operatorname{tr} J}` are recognised.

    Examples
    --------
    >>> from uwtutor import observability
    >>> J = observability.fisher_information(FIX_BEACONS, FIX_POSITION, FIX_SIGMA)
    >>> # m², without the square root
    >>> check_rmse_bound(np.trace(np.linalg.inv(J))).correct
    False
    >>> check_rmse_bound(np.sqrt(np.trace(np.linalg.inv(J)))).correct
    True
    """
    J = observability.fisher_information(FIX_BEACONS, FIX_POSITION, FIX_SIGMA)
    C = np.linalg.inv(J)
    expected = math.sqrt(np.trace(C))
    mistakes = {
        float(np.trace(C)): "That is the mean squared error bound (m²): take its square root for metres.",
        math.sqrt(C[0, 0]): "That bounds the error in x only: the position error adds both axes, "
                            "sqrt(C_xx + C_yy).",
        math.sqrt(np.linalg.det(C)): "The determinant measures the area of the error ellipse, not the mean squared "
                                     "error: use the trace (the sum of the diagonal).",
        math.sqrt(np.linalg.eigvalsh(C).max()): "That is the longest semi-axis of the error ellipse; the RMSE bound "
                                                "adds both axes: sqrt(trace).",
        1.0 / math.sqrt(np.trace(J)): "Invert the matrix first, then take the trace: tr(J⁻¹) is not 1/tr(J).",
        math.sqrt(np.trace(C)) * FIX_SIGMA: "J already contains σ²: its inverse is in m², so do not multiply by σ "
                                            "again.",
    }
    # rtol 1e-3: a bound computed by hand and rounded to four significant digits (√6 = 2.449) passes
    return check_number(answer, expected, rtol=1e-3, name="the RMSE bound", units="m", common_mistakes=mistakes,
                        hint="Invert J (`np.linalg.inv`), add its diagonal (`np.trace`) and take the square root.",
                        explanation=f"No unbiased fix from these three ranges can do better than "
                                    f"{expected:.3f} m RMS: about {expected / FIX_SIGMA:.2f} σ.")


# -- exercise 2.2: the mirror solutions of a two-range fix -------------------------------------------------------------
def check_mirror_solutions(answer: Any) -> Feedback:
    r"""Check the two candidate positions (a ``(2, 2)`` array, one per row, in any order) of exercise 2.2.

    The vehicle measured ``MIRROR_RANGES[0]`` at :math:`p - u`, moved by ``MIRROR_DISPLACEMENT`` :math:`u` and
    measured ``MIRROR_RANGES[1]`` at :math:`p`; both rows must satisfy both ranges.

    Parameters
    ----------
    answer : array_like or None
        The student's two candidates for the current position :math:`p` [m].

    Returns
    -------
    Feedback
        The verdict; the previous positions instead of the current ones, the virtual beacon on the wrong side
        (:math:`b - u`), swapped ranges, a single point and swapped coordinates are recognised.

    Examples
    --------
    >>> from uwtutor import observability
    >>> pair = observability.two_range_fix(MIRROR_BEACON, MIRROR_RANGES,
    ...                                    MIRROR_DISPLACEMENT)
    >>> # one point: two circles meet twice
    >>> check_mirror_solutions(pair[0]).correct
    False
    >>> check_mirror_solutions(pair[::-1]).correct  # both, in either order
    True
    """
    b, r, u = MIRROR_BEACON, MIRROR_RANGES, MIRROR_DISPLACEMENT
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", observability.UnobservableWarning)
        expected = observability.two_range_fix(b, r, u)
        wrong_side = observability.two_range_fix(b, r, -u)
        swapped = observability.two_range_fix(b, r[::-1], u)
    if _is_unanswered(answer):
        return not_answered("the two candidate positions (an array of shape (2, 2), one position per row)")
    arr, refusal = parse_real_array(answer, "the pair of candidates")
    if refusal is not None:
        return refusal
    if arr is not None and arr.shape == (2,):
        return Feedback(False, "Not yet: you gave one position; two circles that cross meet in two points.",
                        hint="Both intersections fit both ranges equally well: give both, one per row, "
                             "`np.array([p_plus, p_minus])`.")
    if arr is not None and arr.shape == (2, 2) and np.all(np.isfinite(arr)):
        # either order is right: compare with the expected rows in the order closest to the answer
        direct = np.abs(arr - expected).max()
        flipped = np.abs(arr - expected[::-1]).max()
        if flipped < direct:
            expected, wrong_side, swapped = expected[::-1], wrong_side[::-1], swapped[::-1]
    mistakes = [
        (expected - u, "Those are where the vehicle was at the first range. The task asks for the current position: "
                       "add the displacement u."),
        (wrong_side, "The first range is to the virtual beacon b + u, not b − u: the vehicle was at p − u, so "
                     "‖(p − u) − b‖ = ‖p − (b + u)‖."),
        (wrong_side[::-1], "The first range is to the virtual beacon b + u, not b − u: the vehicle was at p − u, so "
                           "‖(p − u) − b‖ = ‖p − (b + u)‖."),
        (swapped, "The ranges are swapped: the first range (before the displacement) belongs to the virtual beacon "
                  "b + u, the second (now) to the beacon itself."),
        (swapped[::-1], "The ranges are swapped: the first range (before the displacement) belongs to the virtual "
                        "beacon b + u, the second (now) to the beacon itself."),
    ]
    return check_array(answer, expected, rtol=0.0, atol=0.05, name="the pair of candidates", units="m",
                       common_mistakes=mistakes,
                       hint="Intersect the circle of radius r₂ about b with the circle of radius r₁ about b + u: "
                            "a = (r₂² − r₁² + ‖u‖²)/(2‖u‖) along e = u/‖u‖, then ± sqrt(r₂² − a²) across it.",
                       explanation="The two rows are mirror images across the line through the beacon along u: "
                                   "nothing in two ranges tells them apart.")


# -- exercise 2.3: the turn that halves the bound ----------------------------------------------------------------------
def turn_track(turn_deg: float) -> motion.Track:
    """The track of exercise 2.3: due east from ``TURN_START`` at 2 m/s, turning left by ``turn_deg`` at 600 s.

    ``turn_deg`` is a single finite number of degrees (negative: a turn to the right).

    Examples
    --------
    >>> track = turn_track(30.0)
    >>> track.positions.shape == (TURN_TIMES.size, 2)
    True
    >>> np.round(track.positions[0], 1)
    array([-1500.,   600.])
    """
    turn = as_scalar("turn_deg", turn_deg)
    return motion.turning_track(TURN_TIMES, start=TURN_START, speed=TURN_SPEED,
                                headings=[0.0, math.radians(turn)], turn_times=[TURN_TIME])


def turn_rmse_bound(turn_deg: float) -> float:
    """RMSE bound (m) on the final position of ``turn_track(turn_deg)`` with an unknown constant current.

    The bound is ``inf`` for a track that does not turn (``turn_deg`` 0, or a multiple of 360): a straight track
    cannot see the current.

    Examples
    --------
    >>> print(turn_rmse_bound(0.0))  # a straight track cannot see the current
    inf
    >>> bool(turn_rmse_bound(20.0) < turn_rmse_bound(10.0))
    True
    """
    track = turn_track(turn_deg)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", observability.UnobservableWarning)
        bound = observability.track_crlb(track.positions, (0.0, 0.0), TURN_SIGMA, times=TURN_TIMES,
                                         unknown_current=True)
    return float(observability.rmse_bound(bound[-1]))


@functools.lru_cache(maxsize=1)
def _halving_angle() -> float:
    target = turn_rmse_bound(REFERENCE_TURN_DEG) / 2
    return float(brentq(lambda a: turn_rmse_bound(a) - target, REFERENCE_TURN_DEG, 60.0, xtol=1e-8))


@functools.lru_cache(maxsize=1)
def _best_turn() -> float:
    angles = np.arange(REFERENCE_TURN_DEG, 180.0 + 1e-9, 1.0)
    return float(angles[np.argmin([turn_rmse_bound(a) for a in angles])])


def check_halving_turn_angle(answer: Any) -> Feedback:
    r"""Check the turn (degrees, to the left) whose final RMSE bound is half that of a 10° turn (exercise 2.3).

    Parameters
    ----------
    answer : float or None
        The student's turn angle in degrees.

    Returns
    -------
    Feedback
        The verdict; the naive doubling (20°), an answer in radians and the angle of the smallest bound are
        recognised.

    Examples
    --------
    >>> from scipy.optimize import brentq
    >>> # doubling the turn
    >>> check_halving_turn_angle(2 * REFERENCE_TURN_DEG).correct
    False
    >>> half = turn_rmse_bound(REFERENCE_TURN_DEG) / 2
    >>> def excess(a):
    ...     return turn_rmse_bound(a) - half
    >>> angle = brentq(excess, REFERENCE_TURN_DEG, 60.0)
    >>> check_halving_turn_angle(angle).correct
    True
    """
    expected = _halving_angle()
    doubled = 2 * REFERENCE_TURN_DEG
    mistakes = {
        doubled: f"Doubling the turn does not quite halve the bound: at {doubled:g}° it is "
                 f"{turn_rmse_bound(doubled):.1f} m, not {turn_rmse_bound(REFERENCE_TURN_DEG) / 2:.1f} m. The bound "
                 "falls like 1/θ only for small turns: compute it and search (e.g. `scipy.optimize.brentq`).",
        math.radians(expected): "That looks like radians: give the angle in degrees.",
        _best_turn(): "That is the turn with the smallest bound; the task asks for the first turn whose bound is half "
                      "that of the 10° turn.",
    }
    a, problem = _as_scalar(answer, "the turn angle", "the turn angle in degrees (a number)")
    if problem is not None:
        return problem
    if a is not None and math.isfinite(a) and not REFERENCE_TURN_DEG <= a <= 180.0 \
            and not any(abs(a - v) <= 0.3 for v in mistakes):
        return Feedback(False, f"Not yet: a turn of {a:g}° is outside the range searched, {REFERENCE_TURN_DEG:g}° to "
                               "180° to the left.",
                        hint="A turn to the left is a positive angle (counter-clockwise); search between "
                             f"{REFERENCE_TURN_DEG:g}° and 60°, where the bound falls steadily.")
    return check_number(answer, expected, rtol=0.0, atol=0.3, name="the turn angle", units="degrees",
                        common_mistakes=mistakes,
                        hint="Write a function bound(θ) with `turn_track`, `observability.track_crlb(..., "
                             "unknown_current=True)` and `observability.rmse_bound`, then solve bound(θ) = "
                             "bound(10°)/2 between 10° and 60°.",
                        explanation=f"A straight track cannot see the current at all; a {expected:.1f}° turn "
                                    "already brings the bound to half that of a 10° turn.")


# -- exercise 2.4: a straight track with an unknown current is unobservable -------------------------------------------
def straight_current_jacobian() -> np.ndarray:
    r"""The reference Jacobian of exercise 2.4: rows :math:`[h_k, t_k h_k]` for the state :math:`[x_0, y_0, U_x,
    U_y]` at :math:`t = 0`, along the straight track :math:`p_k = p_0 + v t_k` (true current zero).

    Examples
    --------
    >>> H = straight_current_jacobian()
    >>> H.shape == (CURRENT_TIMES.size, 4)
    True
    >>> int(np.linalg.matrix_rank(H))  # one direction of the state is unobservable
    3
    """
    positions = CURRENT_START + CURRENT_TIMES[:, None] * CURRENT_VELOCITY
    return observability.track_jacobian(positions, (0.0, 0.0), times=CURRENT_TIMES, unknown_current=True,
                                        reference=0)


def _check_rank(answer: Any, expected: int, name: str, mistakes: dict[float, str], explanation: str) -> Feedback:
    a, problem = _as_scalar(answer, name, f"{name} (an integer)")
    if problem is not None:
        return problem
    assert a is not None
    if math.isfinite(a) and a != round(a):
        return Feedback(False, f"Not yet: a rank is a whole number; you gave {a:g}.",
                        hint="Count the singular values above the tolerance, e.g. with `np.linalg.matrix_rank(H)`.")
    return check_number(answer, float(expected), rtol=0.0, atol=0.0, name=name, common_mistakes=mistakes,
                        hint="Build H with one row [h_k, t_k h_k] per range and take `np.linalg.matrix_rank(H)`.",
                        explanation=explanation)


def check_straight_current_rank(answer: Any) -> Feedback:
    r"""Check the rank (3) of the ranges' Jacobian along the straight track of exercise 2.4, with an unknown current.

    Parameters
    ----------
    answer : int or None
        The student's rank.

    Returns
    -------
    Feedback
        The verdict; full rank 4 (a wrong Jacobian) and 2 (current columns without the factor :math:`t_k`) are
        recognised.

    Examples
    --------
    >>> check_straight_current_rank(4).correct
    False
    >>> H = straight_current_jacobian()
    >>> check_straight_current_rank(np.linalg.matrix_rank(H)).correct
    True
    """
    expected = int(observability.numerical_rank(straight_current_jacobian()))
    mistakes = {
        4.0: "Rank 4 would make the straight track observable. Check the Jacobian: the row of range k is "
             "[h_k, t_k h_k] with the unit vector h_k = p_k/‖p_k‖ at the true position p_k = p_0 + v t_k.",
        2.0: "Rank 2 means the current columns copy the position columns: the current moves the vehicle by U t_k, "
             "so its columns are t_k h_k, not h_k.",
        1.0: "Rank 1 would mean every row is the same direction: use the line of sight of each epoch, "
             "h_k = p_k/‖p_k‖, which turns as the vehicle passes the beacon.",
    }
    return _check_rank(answer, expected, "the rank", mistakes,
                       "Three of four: r_k² depends on the unknowns only through ‖p₀‖², p₀·w and ‖w‖² (w the "
                       "ground velocity), so one direction is invisible.")


def check_unobservable_direction(answer: Any) -> Feedback:
    r"""Check a direction :math:`\Delta x = [\delta x_0, \delta y_0, \delta U_x, \delta U_y]` with
    :math:`H \Delta x = 0` (ex. 2.4).

    Any non-zero multiple of the rotation direction is right: turn the start point about the beacon and the
    ground velocity :math:`\dot p` with it (through the current), :math:`\Delta x \propto [-y_0, x_0, -\dot y, \dot x]`.

    Parameters
    ----------
    answer : array_like or None
        The student's 4-vector (m, m, m/s, m/s).

    Returns
    -------
    Feedback
        The verdict; the zero vector, a rotation of the position alone, a change of the current alone and the
        wrong sense of rotation for the current are recognised.

    Examples
    --------
    >>> x0, y0 = CURRENT_START
    >>> wx, wy = CURRENT_VELOCITY
    >>> # the start point turned alone
    >>> check_unobservable_direction([-y0, x0, 0.0, 0.0]).correct
    False
    >>> # and the velocity with it
    >>> check_unobservable_direction([-y0, x0, -wy, wx]).correct
    True
    """
    H = straight_current_jacobian()
    x0, y0 = CURRENT_START
    wx, wy = CURRENT_VELOCITY
    expected = np.array([-y0, x0, -wy, wx])
    if _is_unanswered(answer):
        return not_answered("a direction [δx₀, δy₀, δU_x, δU_y] (an array of 4 numbers)")
    v, refusal = parse_real_array(answer, "the direction")
    if refusal is not None:
        return refusal
    assert v is not None                             # no refusal: parse_real_array returned the array
    if v.shape != (4,):
        return Feedback(False, f"Not yet: the direction must have shape (4,) (δx₀, δy₀, δU_x, δU_y); got shape "
                               f"{v.shape}.",
                        hint="One entry per unknown, in the order of the columns of H; `.ravel()` a column vector.")
    if not np.all(np.isfinite(v)):
        return Feedback(False, "Not yet: the direction contains NaN or infinity.",
                        hint="Check the computation (a division by zero?).")
    scale = np.linalg.norm(H, axis=0)
    vs = v * scale                                   # the direction in the units of the column-scaled Jacobian
    if np.linalg.norm(vs) == 0:
        return Feedback(False, "Not yet: the zero vector changes nothing, so it is trivially invisible; the task asks "
                               "for a non-zero direction.",
                        hint="Think of rotating the whole track about the beacon: the start point and the velocity.")
    residual = np.linalg.norm((H / scale) @ vs) / np.linalg.norm(vs)
    if residual < 1e-7:
        return Feedback(True, "Correct: H v = 0, so moving the state along this direction changes no range (to first "
                              "order, and here exactly). It rotates the start point about the beacon and the ground "
                              "velocity with it, the current absorbing the change of velocity.",
                        details={"residual": residual})
    pos_only = np.array([-y0, x0, 0.0, 0.0])
    cur_only = np.array([0.0, 0.0, -wy, wx])
    wrong_sense = np.array([-y0, x0, wy, -wx])

    def parallel(a: np.ndarray, b: np.ndarray) -> bool:
        a, b = a * scale, b * scale
        return bool(abs(abs(a @ b) - np.linalg.norm(a) * np.linalg.norm(b)) <= 1e-9 * np.linalg.norm(a)
                    * np.linalg.norm(b))

    hint = ("Rotate the track about the beacon: the start point by δp₀ = (−y₀, x₀)·δθ and the ground velocity by "
            "δw = (−w_y, w_x)·δθ; only the current can change the ground velocity. Or take the right singular "
            "vector of H for its smallest singular value (`np.linalg.svd`).")
    if parallel(v, pos_only):
        hint = ("Rotating the start point alone changes the ranges later on: the velocity must turn with it, and "
                "only the current can turn it, so δU = (−w_y, w_x)·δθ.")
    elif parallel(v, cur_only):
        hint = "Changing the current alone moves the later positions: turn the start point about the beacon too."
    elif parallel(v, wrong_sense):
        hint = "The current must turn the velocity the same way as the start point turns: δU = (−w_y, w_x)·δθ."
    return Feedback(False, f"Not yet: H v is not zero (relative size {residual:.2g}), so some range changes along "
                           "this direction.", hint=hint, details={"residual": residual, "expected": expected})


def check_turned_current_rank(answer: Any) -> Feedback:
    r"""Check the rank (4) of the Jacobian once the track of exercise 2.4 has turned by 90° at 600 s.

    Parameters
    ----------
    answer : int or None
        The student's rank.

    Returns
    -------
    Feedback
        The verdict; an unchanged rank 3 (the turn left out of the positions) is recognised.

    Examples
    --------
    >>> from uwtutor import motion, observability
    >>> check_turned_current_rank(3).correct
    False
    >>> track = motion.turning_track(CURRENT_TIMES, start=CURRENT_START, speed=2.0,
    ...                              headings=[0.0, np.pi / 2], turn_times=[600.0])
    >>> H = observability.track_jacobian(track.positions, (0.0, 0.0),
    ...                                  times=CURRENT_TIMES,
    ...                                  unknown_current=True, reference=0)
    >>> check_turned_current_rank(np.linalg.matrix_rank(H)).correct
    True
    """
    times = CURRENT_TIMES
    track = motion.turning_track(times, start=CURRENT_START, speed=float(np.hypot(*CURRENT_VELOCITY)),
                                 headings=[math.atan2(CURRENT_VELOCITY[1], CURRENT_VELOCITY[0]),
                                           math.atan2(CURRENT_VELOCITY[1], CURRENT_VELOCITY[0]) + math.pi / 2],
                                 turn_times=[600.0])
    H = observability.track_jacobian(track.positions, (0.0, 0.0), times=times, unknown_current=True, reference=0)
    expected = int(observability.numerical_rank(H))
    mistakes = {
        3.0: "Still 3: did the positions p_k follow the turn? After 600 s the vehicle heads north, so the lines of "
             "sight h_k and the times t_k no longer fit the straight-line pattern.",
        2.0: "Rank 2 means the current columns copy the position columns: they are t_k h_k, not h_k.",
    }
    return _check_rank(answer, expected, "the rank", mistakes,
                       "Full rank: after the turn the squared ranges follow a different quadratic in time, and the "
                       "rotation that hid the current on the straight track no longer fits both legs.")
