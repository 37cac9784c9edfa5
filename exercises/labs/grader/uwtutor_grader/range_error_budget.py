"""Hidden tests of the lab ``range_error_budget`` (chapter 1): a fjord survey's range-error budget.

Recognised mistakes (the instructor notes list them): the arithmetic mean of the whole cast for ``c_e``; the sign of
``delta_c``; scaling the horizontal range instead of the slant range; hours not converted to seconds (or 60 s per
hour) in the clock error.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
from scipy import optimize

from uwtutor import acoustics
from uwtutor.exercises.checks import check_array, check_number
from uwtutor.exercises.feedback import Feedback
from ._common import Answers, call, fail

__all__ = ["PARTS"]


def _c_e(ns: Answers) -> float:
    speeds = acoustics.sound_speed(ns["cast_temperature"], ns["cast_salinity"], ns["cast_depth"])
    return float(acoustics.effective_sound_speed(ns["cast_depth"], speeds, ns["z_vehicle"], ns["z_beacon"]))


def _speed_error(x: np.ndarray, ns: Answers, c_e: float) -> np.ndarray:
    dz = ns["z_beacon"] - ns["z_vehicle"]
    return np.sqrt((np.hypot(x, dz) * ns["c_nav"] / c_e) ** 2 - dz**2) - x


def part_a(ns: Answers) -> Iterator[Feedback]:
    expected = acoustics.sound_speed(ns["cast_temperature"], ns["cast_salinity"], ns["cast_depth"])
    yield check_array(ns["profile_speeds"], expected, rtol=1e-6, name="profile_speeds", units="m/s",
                      hint="Pass temperature, salinity and depth of the cast, in that order, to `sound_speed`.",
                      reveal_expected=False)


def part_b(ns: Answers) -> Iterator[Feedback]:
    c_e = _c_e(ns)
    whole_cast = float(np.mean(acoustics.sound_speed(ns["cast_temperature"], ns["cast_salinity"], ns["cast_depth"])))
    yield check_number(ns["c_e"], c_e, rtol=0, atol=0.01, name="c_e", units="m/s", common_mistakes={
        whole_cast: "That is the mean of the whole cast; the pulse crosses only the layers between 40 m and 180 m, "
                    "and its travel time averages the slowness 1/c (a harmonic mean)."},
        hint="The pulse crosses the layers between the vehicle and the transponder only; its travel time averages "
             "the slowness 1/c over that path.", reveal_expected=False)
    yield check_number(ns["delta_c"], ns["c_nav"] - c_e, rtol=0, atol=0.01, name="delta_c", units="m/s",
                       common_mistakes={c_e - ns["c_nav"]: "The sign: Δc = c − c_e (assumed minus true)."},
                       reveal_expected=False)


def part_c(ns: Answers) -> Iterator[Feedback]:
    c_e = _c_e(ns)
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


def part_d(ns: Answers) -> Iterator[Feedback]:
    dz = ns["z_beacon"] - ns["z_vehicle"]
    x_test = np.array([0.0, 300.0, 1000.0, 2500.0])
    got, problem = call(ns["geometry_range_error"], x_test.copy(), name="geometry_range_error(x)")
    if problem is not None:
        yield problem
    yield check_array(got, np.hypot(x_test, dz) - x_test, rtol=1e-9, atol=1e-9, name="geometry_range_error(x)",
                      units="m", reveal_expected=False)
    c_e = _c_e(ns)
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


def part_e(ns: Answers) -> Iterator[Feedback]:
    c_e = _c_e(ns)
    budget = ns["budget"]
    if not isinstance(budget, dict):
        yield fail(f"budget is a {type(budget).__name__}; it must be a dict of the four terms.")
    expected = {"sound speed": float(_speed_error(np.array(2500.0), ns, c_e)),
                "geometry": float(np.hypot(2500.0, ns["z_beacon"] - ns["z_vehicle"]) - 2500.0),
                "clock": c_e * ns["clock_drift"] * 3600.0 * ns["mission_hours"],
                "timing noise": c_e * ns["timing_sigma"]}
    for term, value in expected.items():
        if term not in budget:
            yield fail(f"budget has no term {term!r}.", hint=f"The keys are {', '.join(map(repr, expected))}.")
        yield check_number(budget[term], value, rtol=1e-3, name=f"budget[{term!r}]", units="m",
                           reveal_expected=False)
    largest = max(expected, key=lambda t: abs(expected[t]))
    if ns["dominant"] != largest:
        yield fail(f"dominant = {ns['dominant']!r} is not the largest term of your budget.",
                   hint="dominant is the key of the term with the largest size.")
    yield check_number(ns["max_range"], optimize.brentq(lambda x: _speed_error(x, ns, c_e) - 5.0, 300.0, 2500.0),
                       rtol=1e-3, name="max_range", units="m",
                       hint="Find the root of `speed_range_error(x) - 5` between 300 m and 2500 m.",
                       reveal_expected=False)
    yield Feedback(True, "Correct.")


PARTS = {"A": part_a, "B": part_b, "C": part_c, "D": part_d, "E": part_e}
