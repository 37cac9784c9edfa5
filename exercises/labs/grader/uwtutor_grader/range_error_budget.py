"""Hidden tests of the lab ``range_error_budget`` (chapter 1): a fjord survey's range-error budget.

Parts C-E build on part B's ``c_e`` and part E on the functions of C and D: they are checked with the student's own
``c_e`` (when it is a number) and the student's own functions, so that a slip is counted once, in its own check.
Part B is graded in two checks (B1: ``c_e``, 1 point; B2: ``delta_c`` from the student's ``c_e``, 1 point) and part
D in two (D1: the geometry error, 1 point; D2: the clock error, 2 points).

Recognised mistakes (the instructor notes list them): the arithmetic mean of the whole cast for ``c_e``; the sign of
``delta_c``; scaling the horizontal range instead of the slant range; hours not converted to seconds (or 60 s per
hour) in the clock error; a ``dominant`` term that is not the largest.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
from scipy import optimize

from uwtutor import acoustics
from uwtutor.exercises.checks import check_array, check_number
from uwtutor.exercises.feedback import Feedback
from ._common import Answers, call, fail, own_function, own_number

__all__ = ["PARTS"]


def _c_e(ns: Answers) -> float:
    speeds = acoustics.sound_speed(ns["cast_temperature"], ns["cast_salinity"], ns["cast_depth"])
    return float(acoustics.effective_sound_speed(ns["cast_depth"], speeds, ns["z_vehicle"], ns["z_beacon"]))


def _student_c_e(ns: Answers) -> float:
    """The student's ``c_e`` (part B) when it is a number, else the reference: parts C-E are checked with it."""
    own = own_number(ns, "c_e")
    return _c_e(ns) if own is None else own


def _speed_error(x: np.ndarray, ns: Answers, c_e: float) -> np.ndarray:
    dz = ns["z_beacon"] - ns["z_vehicle"]
    return np.sqrt((np.hypot(x, dz) * ns["c_nav"] / c_e) ** 2 - dz**2) - x


def part_a(ns: Answers) -> Iterator[Feedback]:
    expected = acoustics.sound_speed(ns["cast_temperature"], ns["cast_salinity"], ns["cast_depth"])
    yield check_array(ns["profile_speeds"], expected, rtol=1e-6, name="profile_speeds", units="m/s",
                      hint="Pass temperature, salinity and depth of the cast, in that order, to `sound_speed`.",
                      reveal_expected=False)


def part_b1(ns: Answers) -> Iterator[Feedback]:
    c_e = _c_e(ns)
    whole_cast = float(np.mean(acoustics.sound_speed(ns["cast_temperature"], ns["cast_salinity"], ns["cast_depth"])))
    yield check_number(ns["c_e"], c_e, rtol=0, atol=0.01, name="c_e", units="m/s", common_mistakes={
        whole_cast: "That is the mean of the whole cast; the pulse crosses only the layers between 40 m and 180 m, "
                    "and its travel time averages the slowness 1/c (a harmonic mean)."},
        hint="The pulse crosses the layers between the vehicle and the transponder only; its travel time averages "
             "the slowness 1/c over that path.", reveal_expected=False)


def part_b2(ns: Answers) -> Iterator[Feedback]:
    c_e = _student_c_e(ns)
    yield check_number(ns["delta_c"], ns["c_nav"] - c_e, rtol=0, atol=0.01, name="delta_c", units="m/s",
                       common_mistakes={c_e - ns["c_nav"]: "The sign: Δc = c − c_e (assumed minus true)."},
                       hint="Δc = c − c_e, with your c_e.", reveal_expected=False)


def part_c(ns: Answers) -> Iterator[Feedback]:
    c_e = _student_c_e(ns)
    x_test = np.array([0.0, 150.0, 300.0, 1000.0, 2500.0, 4000.0])
    got, problem = call(ns["speed_range_error"], x_test.copy(), name="speed_range_error(x)")
    if problem is not None:
        yield problem
    horizontal = acoustics.sound_speed_error_range_bias(x_test, ns["c_nav"], c_e)
    yield check_array(got, _speed_error(x_test, ns, c_e), rtol=1e-6, atol=1e-6,
                      name="speed_range_error(x) on ranges from 0 to 4 km", units="m", common_mistakes=[
                          (horizontal, "That scales the horizontal range; the travel time is along the slant path, "
                                       "so scale the slant range and then take its horizontal part.")],
                      reveal_expected=False)


def part_d1(ns: Answers) -> Iterator[Feedback]:
    dz = ns["z_beacon"] - ns["z_vehicle"]
    x_test = np.array([0.0, 300.0, 1000.0, 2500.0])
    got, problem = call(ns["geometry_range_error"], x_test.copy(), name="geometry_range_error(x)")
    if problem is not None:
        yield problem
    yield check_array(got, np.hypot(x_test, dz) - x_test, rtol=1e-9, atol=1e-9, name="geometry_range_error(x)",
                      units="m", reveal_expected=False)


def part_d2(ns: Answers) -> Iterator[Feedback]:
    c_e = _student_c_e(ns)
    h_test = np.array([0.5, 1.0, 6.0, 10.0])
    got, problem = call(ns["clock_range_error"], h_test.copy(), name="clock_range_error(hours)")
    if problem is not None:
        yield problem
    drift = ns["clock_drift"]
    yield check_array(got, c_e * drift * 3600.0 * h_test, rtol=1e-3, name="clock_range_error(hours)", units="m",
                      common_mistakes=[(c_e * drift * h_test, "The drift is per second: convert the hours to seconds."),
                                       (c_e * drift * 60 * h_test, "An hour is 3600 s, not 60 s.")],
                      hint="The clock offset after t seconds is the drift times t; the range error converts it with "
                           "c_e.", reveal_expected=False)


def _own_or(ns: Answers, name: str, x: float, reference: float) -> float:
    """The student's function ``name`` at ``x`` (part E is computed from the functions of C and D), or
    ``reference`` when that function is unusable."""
    own = own_function(ns, name, x)
    return reference if own is None or np.ndim(own) != 0 else float(own)


def part_e(ns: Answers) -> Iterator[Feedback]:
    c_e = _student_c_e(ns)
    budget = ns["budget"]
    if not isinstance(budget, dict):
        yield fail(f"budget is a {type(budget).__name__}; it must be a dict of the four terms.")
    dz = ns["z_beacon"] - ns["z_vehicle"]
    expected = {"sound speed": _own_or(ns, "speed_range_error", 2500.0, float(_speed_error(np.array(2500.0), ns, c_e))),
                "geometry": _own_or(ns, "geometry_range_error", 2500.0, float(np.hypot(2500.0, dz) - 2500.0)),
                "clock": _own_or(ns, "clock_range_error", ns["mission_hours"],
                                 c_e * ns["clock_drift"] * 3600.0 * ns["mission_hours"]),
                "timing noise": c_e * ns["timing_sigma"]}
    for term, value in expected.items():
        if term not in budget:
            yield fail(f"budget has no term {term!r}.", hint=f"The keys are {', '.join(map(repr, expected))}.")
        yield check_number(budget[term], value, rtol=1e-3, name=f"budget[{term!r}]", units="m",
                           hint="Each term at 2.5 km (the clock after `mission_hours`), from your functions of parts C "
                                "and D; the timing noise is c_e times the timing σ.", reveal_expected=False)
    largest = max(expected, key=lambda t: abs(expected[t]))
    if ns["dominant"] != largest:
        yield fail(f"dominant = {ns['dominant']!r} is not the largest term of your budget.",
                   hint="dominant is the key of the term with the largest size.")

    def reference_error(x: float) -> float:
        return float(_speed_error(np.array(x), ns, c_e))

    def own_error(x: float) -> float:
        return _own_or(ns, "speed_range_error", x, reference_error(x))

    error = own_error if (own_error(300.0) - 5.0) * (own_error(2500.0) - 5.0) < 0 else reference_error
    yield check_number(ns["max_range"], optimize.brentq(lambda x: error(x) - 5.0, 300.0, 2500.0),
                       rtol=1e-3, name="max_range", units="m",
                       hint="Find the root of `speed_range_error(x) - 5` between 300 m and 2500 m.",
                       reveal_expected=False)
    yield Feedback(True, "Correct.")


PARTS = {"A": part_a, "B1": part_b1, "B2": part_b2, "C": part_c, "D1": part_d1, "D2": part_d2, "E": part_e}
