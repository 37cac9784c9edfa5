"""Checkers for the exercises of chapter 1, "Underwater acoustic positioning and its errors".

Each checker takes the student's answer, computes the expected value from the exercise's data (the constants below),
and returns a ``Feedback`` that recognises the usual mistakes of that exercise:

============================================  ==========================================================================
checker                                       exercise
============================================  ==========================================================================
``check_sound_speed(speed)``                  Mackenzie (1981) sound speed at T = 10 °C, S = 35, D = 1000 m
``check_two_way_range(range_m)``              range from a two-way travel time of 2.4 s at 1500 m/s
``check_sound_speed_range_error(error)``      range error from assuming 1470 m/s when the sound travels at 1500 m/s
``check_dr_drift(cross_track)``               cross-track error after 1 h at 2 m/s with a 1° heading bias
``check_dr_track(track)``                     the true track of that vehicle as a (7, 2) array of (east, north)
``check_outlier_detector(flag_outliers)``     a moving-median outlier detector for a range series
============================================  ==========================================================================

The exercises themselves are in the repository's ``exercises/ch01_positioning_and_errors.ipynb``.

References
----------
K. V. Mackenzie, "Nine-term equation for sound speed in the oceans", J. Acoust. Soc. Am. 70(3), 807-812, 1981.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .checks import Case, check_array, check_function, check_number
from .feedback import Feedback

__all__ = [
    "check_sound_speed",
    "check_two_way_range",
    "check_sound_speed_range_error",
    "check_dr_drift",
    "check_dr_track",
    "check_outlier_detector",
    "SOUND_SPEED_CONDITIONS",
    "TWO_WAY_TIME",
    "NOMINAL_SOUND_SPEED",
    "ASSUMED_SOUND_SPEED",
    "TRUE_SOUND_SPEED",
    "TRUE_RANGE",
    "DR_SPEED",
    "DR_DURATION",
    "HEADING_BIAS_DEG",
    "TRACK_TIMES",
    "OUTLIER_HALF_WIDTH",
]

# -- the data of the exercises -----------------------------------------------------------------------------------------
#: The temperature (°C), salinity (PSU) and depth (m) of exercise 1.1, where the sound speed is computed.
SOUND_SPEED_CONDITIONS = {"temperature": 10.0, "salinity": 35.0, "depth": 1000.0}
#: ... and the tolerance of its answer (m/s): a rounding to two decimals passes, the smallest term left out does not.
SOUND_SPEED_ATOL = 0.005
#: The two-way travel time (s) measured in exercise 1.2 ...
TWO_WAY_TIME = 2.4
#: ... and the sound speed used to convert it (m/s).
NOMINAL_SOUND_SPEED = 1500.0
#: The sound speed the vehicle assumes in exercise 1.3 (m/s) ...
ASSUMED_SOUND_SPEED = 1470.0
#: ... the effective sound speed along the path (m/s) ...
TRUE_SOUND_SPEED = 1500.0
#: ... and the true range (m).
TRUE_RANGE = 3000.0
#: The vehicle's speed through the water in exercise 1.4, parts (a) and (b) (m/s) ...
DR_SPEED = 2.0
#: ... the duration of the dead-reckoning run (s) ...
DR_DURATION = 3600.0
#: ... and the heading bias of its compass (degrees).
HEADING_BIAS_DEG = 1.0
#: The times (s) of the rows of the track of exercise 1.4 (b).
TRACK_TIMES = np.arange(0.0, DR_DURATION + 1.0, 600.0)
#: In exercise 1.5, a range is compared with the median of its neighbours up to this many samples away on each side.
OUTLIER_HALF_WIDTH = 3


# -- exercise 1.1: Mackenzie's sound speed -----------------------------------------------------------------------------
def _mackenzie_terms(t: float, s: float, d: float, *, salinity_anomaly: bool = True) -> dict[str, float]:
    """The nine terms of Mackenzie's (1981) equation (with ``salinity_anomaly=False``: the mistake S for S - 35)."""
    ds = s - 35.0 if salinity_anomaly else s
    return {
        "constant": 1448.96,
        "T": 4.591 * t,
        "T2": -5.304e-2 * t ** 2,
        "T3": 2.374e-4 * t ** 3,
        "S": 1.340 * ds,
        "D": 1.630e-2 * d,
        "D2": 1.675e-7 * d ** 2,
        "TS": -1.025e-2 * t * ds,
        "TD3": -7.139e-13 * t * d ** 3,
    }


def _reference_sound_speed(t: float, s: float, d: float) -> float:
    """The sound speed from ``uwtutor.acoustics.sound_speed``, or from the nine terms above if that is unavailable."""
    try:
        from uwtutor.acoustics import sound_speed
    except ImportError:
        return math.fsum(_mackenzie_terms(t, s, d).values())
    return float(np.asarray(sound_speed(t, s, d), dtype=float))


def check_sound_speed(answer: Any) -> Feedback:
    """Check the sound speed (m/s) at T = 10 °C, S = 35 PSU, D = 1000 m by Mackenzie's (1981) equation.

    Accepted within ``SOUND_SPEED_ATOL`` (0.005 m/s: a two-decimal rounding). Recognised mistakes: depth in
    kilometres, depth terms left out, S instead of S - 35, temperature in kelvin, a missing or sign-flipped T² or
    T·D³ term, a missing T³ or D² term, Medwin's (1975) formula.

    Parameters
    ----------
    answer : float or None
        The student's sound speed in m/s.

    Returns
    -------
    Feedback
        The verdict, with a hint for a recognised mistake.

    Examples
    --------
    >>> from uwtutor.acoustics import sound_speed
    >>> check_sound_speed(1500.0).correct
    False
    >>> right = float(sound_speed(10.0, 35.0, 1000.0))
    >>> check_sound_speed(right).correct
    True
    """
    t, s, d = (SOUND_SPEED_CONDITIONS[k] for k in ("temperature", "salinity", "depth"))
    expected = _reference_sound_speed(t, s, d)
    terms = _mackenzie_terms(t, s, d)
    total = math.fsum(terms.values())
    medwin = 1449.2 + 4.6 * t - 0.055 * t ** 2 + 0.00029 * t ** 3 + (1.34 - 0.01 * t) * (s - 35) + 0.016 * d
    depth_part = terms["D"] + terms["D2"] + terms["TD3"]
    mistakes = {
        math.fsum(_mackenzie_terms(t, s, d / 1000).values()):
            f"Depth goes into Mackenzie's equation in metres (D = {d:g}, not {d / 1000:g}): your value lacks "
            f"almost all of the depth contribution (about {depth_part:.1f} m/s here).",
        total - depth_part:
            "The depth terms (1.630e-2·D + 1.675e-7·D² − 7.139e-13·T·D³) are missing: sound speed grows with "
            "pressure, about 1.6 m/s per 100 m of depth.",
        math.fsum(_mackenzie_terms(t, s, d, salinity_anomaly=False).values()):
            "The salinity terms use the salinity anomaly (S − 35), not S: at S = 35 they vanish.",
        total + 1.340 * s:
            "The salinity term is 1.340·(S − 35), not 1.340·S: at S = 35 it vanishes.",
        math.fsum(_mackenzie_terms(t + 273.15, s, d).values()):
            "Temperature goes in degrees Celsius (T = 10), not kelvin.",
        total - terms["T2"]:
            f"The −5.304e-2·T² term is missing (it is {terms['T2']:.2f} m/s at {t:g} °C).",
        total - 2 * terms["T2"]:
            "The T² term has a minus sign: −5.304e-2·T².",
        medwin:
            "That is Medwin's (1975) simplified formula; this exercise asks for Mackenzie's (1981) nine-term "
            "equation, which gives a slightly different value here.",
        total - terms["T3"]:
            f"The 2.374e-4·T³ term is missing (about +{terms['T3']:.2f} m/s at {t:g} °C): small, but part of the "
            "equation.",
        total - terms["D2"]:
            f"The 1.675e-7·D² term is missing (about +{terms['D2']:.2f} m/s at {d:g} m).",
        total - terms["TD3"]:
            f"The −7.139e-13·T·D³ term is missing (about {terms['TD3']:.4f} m/s here): the smallest of the nine, "
            "but part of the equation.",
        total - 2 * terms["TD3"]:
            "The T·D³ term has a minus sign: −7.139e-13·T·D³.",
    }
    # A two-decimal rounding of the right value (at most 0.005 m/s off) passes; the smallest term, T·D³, left out
    # (0.007 m/s) or with its sign flipped (0.014 m/s) does not.
    return check_number(answer, expected, rtol=0.0, atol=SOUND_SPEED_ATOL, name="the sound speed", units="m/s",
                        common_mistakes=mistakes,
                        hint="Write out the nine terms one by one (T in °C, S in PSU, D in metres) and add them up; "
                             "print each term to compare it with its typical size.",
                        explanation="Mackenzie's equation is valid for 2-30 °C, 25-40 PSU and 0-8000 m.")


# -- exercise 1.2: two-way travel time ---------------------------------------------------------------------------------
def check_two_way_range(answer: Any) -> Feedback:
    """Check the range (m) from a two-way travel time of 2.4 s at 1500 m/s.

    Parameters
    ----------
    answer : float or None
        The student's one-way range in metres.

    Returns
    -------
    Feedback
        The verdict; the classic mistake (the whole two-way path, c·t) is recognised.

    Examples
    --------
    >>> # the whole two-way path
    >>> check_two_way_range(NOMINAL_SOUND_SPEED * TWO_WAY_TIME).correct
    False
    >>> check_two_way_range(NOMINAL_SOUND_SPEED * TWO_WAY_TIME / 2).correct
    True
    """
    c, t = NOMINAL_SOUND_SPEED, TWO_WAY_TIME
    expected = c * t / 2
    mistakes = {
        c * t: "Did you forget that a two-way travel time covers the path twice (to the beacon and back)? The "
               "range is half of c·t.",
        c / t: "You divided the speed by the time: a distance is speed × time (and then halved for a two-way "
               "path).",
        t / c: "Time divided by speed is not a distance: a distance is speed × time.",
        c * t / 4: "You halved twice: the two-way path is 2·r, so r = c·t/2.",
        c * t / 2 / 1000: "That is the range in kilometres; the answer is asked in metres.",
    }
    return check_number(answer, expected, rtol=1e-3, name="the range to the beacon", units="m",
                        common_mistakes=mistakes,
                        hint="Distance = speed × time, and a two-way time covers the range twice.",
                        explanation="A transponder's reply comes back along the same path, so r = c·t/2 (ignoring "
                                    "the beacon's turn-around delay).")


# -- exercise 1.3: a sound-speed error is a multiplicative range error -------------------------------------------------
def check_sound_speed_range_error(answer: Any) -> Feedback:
    r"""Check the range error (m, estimated − true) from assuming 1470 m/s when the sound travels at 1500 m/s, at 3 km.

    In the book's notation (``book/notation.md``) the vehicle assumes :math:`c` and the sound travels at the
    effective speed :math:`c_\mathrm{e}`: the travel time is :math:`\tau = r^\mathrm{true} / c_\mathrm{e}`, the vehicle
    computes :math:`r = c\,\tau`, so the error is :math:`r - r^\mathrm{true} = r^\mathrm{true}\,(c / c_\mathrm{e} - 1)`.

    Parameters
    ----------
    answer : float or None
        The student's range error in metres (estimated range minus true range).

    Returns
    -------
    Feedback
        The verdict; a flipped sign, the ratio taken with the wrong speed, the estimated range instead of its error,
        the speed error instead of the range error and a doubled (two-way) error are recognised.

    Examples
    --------
    >>> # a speed, not a range
    >>> speed_error = ASSUMED_SOUND_SPEED - TRUE_SOUND_SPEED
    >>> check_sound_speed_range_error(speed_error).correct
    False
    >>> estimated = ASSUMED_SOUND_SPEED * TRUE_RANGE / TRUE_SOUND_SPEED
    >>> check_sound_speed_range_error(estimated - TRUE_RANGE).correct
    True
    """
    c_a, c_t, r = ASSUMED_SOUND_SPEED, TRUE_SOUND_SPEED, TRUE_RANGE
    travel_time = r / c_t
    estimated = c_a * travel_time
    expected = estimated - r
    wrong_ratio = r * (c_t - c_a) / c_a
    mistakes = {
        -expected: "The sign: the error is estimated − true. The vehicle assumes a speed that is too low, so it "
                   "underestimates the range and the error is negative.",
        wrong_ratio: "You scaled with the assumed speed (Δc / c). The travel time is set by the effective "
                     "speed, τ = r_true / c_e; the vehicle then computes c · τ.",
        -wrong_ratio: "You scaled with the assumed speed (Δc / c). The travel time is set by the effective "
                      "speed, τ = r_true / c_e; the vehicle then computes c · τ.",
        estimated: "That is the range the vehicle computes; the task asks for its error, estimated − true.",
        c_a - c_t: "That is the sound-speed error in m/s; the task asks for the range error in metres.",
        2 * expected: "The error is on the one-way range: with a two-way time both the path and the time are "
                      "doubled, and halving gives back the one-way range with the same relative error.",
    }
    return check_number(answer, expected, rtol=1e-3, name="the range error", units="m", common_mistakes=mistakes,
                        hint="Compute the travel time with the effective speed c_e, the range the vehicle estimates "
                             "with its assumed speed c, and subtract the true range.",
                        explanation="A sound-speed error scales every range by c / c_e: a "
                                    "multiplicative error of −2 %, which grows with the range.")


# -- exercise 1.4 (a) and (b): dead-reckoning drift --------------------------------------------------------------------
def check_dr_drift(answer: Any) -> Feedback:
    """Check the cross-track error (m) after 1 h at 2 m/s with a 1° heading bias.

    The vehicle travels ``d = v T`` along a course 1° off the intended one, so it ends ``d sin(1°)`` to the side.

    Parameters
    ----------
    answer : float or None
        The student's cross-track error in metres.

    Returns
    -------
    Feedback
        The verdict; degrees passed to a function that takes radians, the along-track distance, 1 h taken as
        60 s and a forgotten speed are recognised.

    Examples
    --------
    >>> import math
    >>> d = DR_SPEED * DR_DURATION
    >>> # degrees given to sin
    >>> check_dr_drift(d * math.sin(HEADING_BIAS_DEG)).correct
    False
    >>> check_dr_drift(d * math.sin(math.radians(HEADING_BIAS_DEG))).correct
    True
    """
    d = DR_SPEED * DR_DURATION
    bias = math.radians(HEADING_BIAS_DEG)
    expected = d * math.sin(bias)
    radians_hint = ("NumPy's and Python's trigonometric functions take radians: convert the angle first "
                    "(`np.radians(1)` or `np.deg2rad(1)`).")
    mistakes = {
        d * math.sin(HEADING_BIAS_DEG): radians_hint,
        d * math.cos(HEADING_BIAS_DEG): radians_hint + " And the sideways component is d·sin(θ), not d·cos(θ).",
        d: "That is (about) the whole distance travelled. The cross-track error is the sideways component, "
           "d·sin(1°); if you used sin θ ≈ θ, the angle must be in radians (1° = π/180 rad).",
        d * (1 - math.cos(bias)): "That is how much shorter the progress along the intended course is, "
                                  "d·(1 − cos 1°); the cross-track error is the sideways component, d·sin(1°).",
        DR_SPEED * 60 * math.sin(bias): "One hour is 3600 s, not 60.",
        DR_DURATION * math.sin(bias): "The distance travelled is speed × time = 2 m/s × 3600 s.",
    }
    return check_number(answer, expected, rtol=1e-3, name="the cross-track error", units="m",
                        common_mistakes=mistakes,
                        hint="Distance travelled d = speed × time; the sideways offset is d·sin(heading bias), with "
                             "the angle in radians.",
                        explanation="A 1° compass bias makes about 1.7 % of the distance travelled: dead reckoning "
                                    "drifts without bound, which is why it needs acoustic fixes.")


def _true_track(times: np.ndarray, bias_deg: float) -> np.ndarray:
    """East and north of a vehicle heading theta = 90° - bias (counter-clockwise from east, as in the book)."""
    heading = np.radians(90.0 - bias_deg)
    distance = DR_SPEED * times
    return np.column_stack((distance * np.cos(heading), distance * np.sin(heading)))


def check_dr_track(answer: Any) -> Feedback:
    """Check the true track (m) of the vehicle of exercise 1.4: a ``(7, 2)`` array of (east, north) positions.

    The vehicle starts at the origin believing it heads due north (θ = 90°, headings counter-clockwise from east
    as everywhere in the book) but actually heads θ = 89°, 1° east of north; the rows are the times
    0, 600, ..., 3600 s, and a row is (east, north) = d (cos θ, sin θ) with d = v t.

    Parameters
    ----------
    answer : array_like or None
        The student's track, one row per time, columns east then north.

    Returns
    -------
    Feedback
        The verdict; a transposed ``(2, 7)`` array, a missing row, swapped columns, degrees used as radians, the
        bias with the wrong sign and times in minutes are recognised.

    Examples
    --------
    >>> import numpy as np
    >>> theta = np.radians(90.0 - HEADING_BIAS_DEG)
    >>> d = DR_SPEED * TRACK_TIMES
    >>> east, north = d * np.cos(theta), d * np.sin(theta)
    >>> check_dr_track(np.vstack((east, north))).correct  # transposed, (2, 7)
    False
    >>> check_dr_track(np.column_stack((east, north))).correct
    True
    """
    expected = _true_track(TRACK_TIMES, HEADING_BIAS_DEG)
    theta_deg = 90.0 - HEADING_BIAS_DEG
    in_radians = np.column_stack((DR_SPEED * TRACK_TIMES * math.cos(theta_deg),
                                  DR_SPEED * TRACK_TIMES * math.sin(theta_deg)))
    mistakes = [
        (expected[:, ::-1], "East and north are swapped. Either the columns are in the wrong order (east first, "
                            "then north: east = d·cos θ, north = d·sin θ), or you used θ = 1°: θ is counted "
                            "counter-clockwise from east, so 1° east of north is θ = 90° − 1° = 89°."),
        (in_radians, "NumPy's trigonometric functions take radians: use `np.radians(1)`."),
        (_true_track(TRACK_TIMES, -HEADING_BIAS_DEG), "The vehicle actually heads 1° east of north, so its east "
                                                      "coordinate grows: it is positive."),
        (_true_track(TRACK_TIMES / 60, HEADING_BIAS_DEG), "The times are in seconds (0 to 3600 s), not minutes."),
    ]
    return check_array(answer, expected, rtol=1e-4, atol=1e-6, name="the track", units="m",
                       common_mistakes=mistakes,
                       hint="Each row is (east, north) = d(t)·(cos θ, sin θ) with d(t) = 2 m/s × t and θ = 89° in "
                            "radians; `np.column_stack((east, north))` builds the array.",
                       explanation="Its last row's east coordinate is the cross-track error of part (a).")


# -- exercise 1.5: outliers --------------------------------------------------------------------------------------------
def _flag_outliers_reference(ranges: Any, threshold: float) -> np.ndarray:
    """The reference detector: True where a range differs from the median of its valid neighbours by > threshold."""
    r = np.asarray(ranges, dtype=float)
    flags = np.zeros(r.shape, dtype=bool)
    k = OUTLIER_HALF_WIDTH
    for i in range(r.size):
        window = np.concatenate((r[max(i - k, 0):i], r[i + 1:i + 1 + k]))
        window = window[~np.isnan(window)]
        if np.isnan(r[i]) or window.size == 0:
            continue
        flags[i] = abs(r[i] - np.median(window)) > threshold
    return flags


def _outlier_cases() -> list[Case]:
    rng = np.random.default_rng(1981)
    n = 20
    base = 1200.0 + 1.0 * np.arange(n) + rng.normal(0.0, 0.3, n)  # a vehicle closing in, 1 m per ping, 0.3 m noise
    threshold = 5.0

    def planted(changes: dict[int, float]) -> np.ndarray:
        r = base.copy()
        for i, value in changes.items():
            r[i] = np.nan if np.isnan(value) else r[i] + value
        return r

    ends_hint = ("At the ends a range has fewer neighbours: use those that exist (slices such as "
                 "`r[max(i - 3, 0):i]` and `r[i + 1:i + 4]` stop at the ends by themselves).")
    return [
        Case((base.copy(), threshold), label="clean ranges, nothing to flag",
             hint="With no outlier nothing should be flagged: compare `abs(r[i] - median) > threshold`, with the "
                  "median of the neighbours only."),
        Case((planted({8: 40.0}), threshold), label="one isolated outlier",
             hint="Compare each range with the median of its neighbours (`np.median`), which a single outlier cannot "
                  "drag away, and leave the range itself out of its window."),
        Case((planted({5: -12.0}), threshold), label="a range that is too short",
             hint="A jump can go either way: compare the absolute difference, `abs(...)`."),
        Case((np.array([100.0, 200.0]), 60.0), label="two ranges, each the other's only neighbour",
             hint="Leave the range itself out of its window: with it in, both windows are [100, 200], whose median "
                  "150 is within 60 m of each range, so neither is flagged; each range's only neighbour is the "
                  "other, 100 m away."),
        Case((planted({0: 30.0}), threshold), label="an outlier in the first range", hint=ends_hint),
        Case((planted({n - 1: 25.0}), threshold), label="an outlier in the last range", hint=ends_hint),
        Case((planted({10: 35.0, 11: 33.0}), threshold), label="a patch of two outliers in a row",
             hint="Use the median of all neighbours within 3 samples on each side (up to six values): with two "
                  "outliers among six neighbours the median is still a good range, the mean is not."),
        Case((planted({6: np.nan, 7: 30.0}), threshold), label="a missing range (NaN) next to an outlier",
             hint="A NaN in the window makes `np.median` return NaN: leave NaNs out (`w = w[~np.isnan(w)]`). A "
                  "missing range itself is never flagged."),
        Case((planted({8: 12.0}), 20.0), label="a larger threshold: a 12 m jump is now accepted",
             hint="Use the `threshold` argument rather than a fixed number."),
        Case((np.array([1000.0, 1000.0, 1000.0, 1005.0, 1000.0, 1000.0, 1000.0]), 5.0),
             label="a jump of exactly the threshold is not flagged",
             hint="Flag only jumps strictly greater than the threshold (`>`, not `>=`)."),
        Case((np.array([1000.0]), threshold), label="a single range (no neighbours)",
             hint="A range without neighbours cannot be compared with them: leave it unflagged (and do not take the "
                  "median of an empty window)."),
    ]


def check_outlier_detector(func: Any) -> Feedback:
    """Check a student's ``flag_outliers(ranges, threshold)`` on series with isolated and patchy outliers.

    The specification (also in the notebook): return a boolean array as long as ``ranges``, True where
    ``abs(ranges[i] - median(neighbours)) > threshold``; the neighbours of ``i`` are the non-NaN ranges among
    ``ranges[i-3], ..., ranges[i-1], ranges[i+1], ..., ranges[i+3]`` that exist. A NaN range, or one without valid
    neighbours, is never flagged. The input must not be modified.

    Parameters
    ----------
    func : callable or None
        The student's function.

    Returns
    -------
    Feedback
        The verdict; a failing case is reported with its inputs, the expected flags and the student's.

    Examples
    --------
    >>> import numpy as np
    >>> def flag_all(ranges, threshold):
    ...     return np.ones(len(ranges), dtype=bool)
    >>> check_outlier_detector(flag_all).correct
    False
    >>> def flag_outliers(ranges, threshold):
    ...     r = np.asarray(ranges, dtype=float)
    ...     flags = np.zeros(r.shape, dtype=bool)
    ...     for i in range(r.size):
    ...         w = np.concatenate((r[max(i - 3, 0):i], r[i + 1:i + 4]))
    ...         w = w[~np.isnan(w)]
    ...         if not np.isnan(r[i]) and w.size:
    ...             flags[i] = abs(r[i] - np.median(w)) > threshold
    ...     return flags
    >>> check_outlier_detector(flag_outliers).correct
    True
    """
    return check_function(
        func, _flag_outliers_reference, _outlier_cases(), name="flag_outliers",
        compare=lambda got, expected: check_array(got, expected, name="the result"),
        hint="Re-read the specification: the median of up to three valid neighbours on each side, the range itself "
             "left out, and a strict `>` against the threshold.",
        explanation="A moving median shrugs off isolated outliers and short patches; longer bursts (multipath that "
                    "lasts several pings) need a wider window or a robust filter.")
