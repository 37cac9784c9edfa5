"""Hidden tests of the lab ``observable_track`` (chapter 2): the CRLB of position and range bias along tracks.

Part B builds on part A's ``final_bounds``: its table is checked against the student's own function (when it runs),
so that a slip in part A is counted once, in part A.

Recognised mistakes (the instructor notes list them): the bias variance included in the position bound; the square
root forgotten (variances instead of standard deviations); a finite bound for the radial track; a ranking by another
key; a track of one's own whose bounds miss the targets.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from uwtutor.motion import circle_track, lawnmower_track, s_turn_track, straight_track
from uwtutor.observability import track_crlb
from uwtutor.exercises.checks import check_number
from uwtutor.exercises.feedback import Feedback
from ._common import Answers, call, fail, own_function

__all__ = ["PARTS"]


def _bounds(ns: Answers, positions: np.ndarray) -> np.ndarray:
    return track_crlb(np.asarray(positions), ns["beacon"], ns["sigma_r"], unknown_bias=True)


def _final(ns: Answers, positions: np.ndarray) -> tuple[float, float]:
    b = _bounds(ns, positions)[-1]
    return float(np.sqrt(b[0, 0] + b[1, 1])), float(np.sqrt(b[2, 2]))


def part_a(ns: Answers) -> Iterator[Feedback]:
    times, speed = ns["times"], ns["speed"]
    final_bounds = ns["final_bounds"]
    tracks = {"a circle of 500 m": circle_track(times, 500.0, speed),
              "an S-turn track": s_turn_track(times, (300.0, -700.0), speed, 1.0, np.radians(0.8), 150.0),
              "a lawnmower": lawnmower_track(times, (-500.0, 200.0), speed, 600.0, 150.0)}
    for label, track in tracks.items():
        got, problem = call(final_bounds, track, name="final_bounds(track)")
        if problem is not None:
            yield problem
        if not (isinstance(got, tuple) and len(got) == 2):
            yield fail(f"final_bounds returned {type(got).__name__} on {label}; it returns a tuple "
                       "(position_bound, bias_bound).")
        pos, bias = _final(ns, track.positions)
        yield check_number(got[0], pos, rtol=1e-6, name=f"the position bound on {label}", units="m", common_mistakes={
            float(np.sqrt(pos**2 + bias**2)): "The position bound uses the x and y entries only, not the bias.",
            pos**2: "Take the square root: the CRLB bounds variances (m²)."},
            hint="√(C_xx + C_yy) of the CRLB at the last epoch, with the bias unknown.", reveal_expected=False)
        yield check_number(got[1], bias, rtol=1e-6, name=f"the bias bound on {label}", units="m",
                           common_mistakes={bias**2: "Take the square root of the variance bound."},
                           reveal_expected=False)
    got, problem = call(final_bounds, straight_track(times, (-2000.0, 0.0), speed, 0.0), name="final_bounds(track)")
    if problem is not None:
        yield problem
    if not np.isinf(got[0]):
        yield fail("a track straight at the beacon leaves the position unobservable: its bound is inf.",
                   hint="Does your function turn the library's inf into a number?")
    yield Feedback(True, "Correct.")


def part_b(ns: Answers) -> Iterator[Feedback]:
    candidates, table, ranking = ns["candidates"], ns["table"], ns["ranking"]
    pos = {}
    for name, track in candidates.items():
        own = own_function(ns, "final_bounds", track)       # part A's function, the student's own (None if inf)
        pos[name] = float(own[0]) if own is not None and np.shape(own) == (2,) else _final(ns, track.positions)[0]
    for name in candidates:
        if name not in table:
            yield fail(f"table has no entry {name!r}.")
        got = table[name][0]
        if not (np.isinf(pos[name]) and np.isinf(got)):
            yield check_number(got, pos[name], rtol=1e-6, name=f"the position bound of table[{name!r}]", units="m",
                               hint="table maps each name to final_bounds(track) (your function of part A).",
                               reveal_expected=False)
    if list(ranking) != sorted(pos, key=pos.get):
        yield fail("ranking is not ordered from the smallest to the largest position bound.",
                   hint="Sort the names by their position bound, the first element of each entry of table.")
    if sorted(ns["unobservable"]) != sorted(n for n in pos if np.isinf(pos[n])):
        yield fail("unobservable should list the names whose position bound is infinite.")
    yield Feedback(True, "Correct.")


def part_c(ns: Answers) -> Iterator[Feedback]:
    times = ns["times"]
    b = _bounds(ns, ns["candidates"]["offset pass"].positions)
    p = np.sqrt(b[:, 0, 0] + b[:, 1, 1])
    if ns["t_good"] != times[np.argmax(p < 2.0)]:
        yield fail(f"t_good = {ns['t_good']} s is not the first epoch with a position bound below 2 m.",
                   hint="The position bound √(C_xx + C_yy) along the whole offset pass (track_crlb gives one bound "
                        "per epoch), then the time of the first epoch where it is below 2 m.")
    yield Feedback(True, "Correct.")


def part_d(ns: Answers) -> Iterator[Feedback]:
    pos, bias = _final(ns, ns["my_track"].positions)
    if not pos < 0.75:
        yield fail(f"the position bound of my_track, {pos:.3f} m, is not below 0.75 m.",
                   hint="Turn more (a larger change of bearing seen from the beacon), and stay close to it.")
    if not bias < 0.45:
        yield fail(f"the bias bound of my_track, {bias:.3f} m, is not below 0.45 m.",
                   hint="The bias separates from the range only where the line of sight turns.")
    yield Feedback(True, "Correct.")


PARTS = {"A": part_a, "B": part_b, "C": part_c, "D": part_d}
