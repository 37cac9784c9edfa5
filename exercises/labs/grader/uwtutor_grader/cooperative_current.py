"""Hidden tests of the lab ``cooperative_current`` (chapter 8, paper B): a glider following a survey AUV in a tide.

Recognised mistakes (the instructor notes list them): the clock's offset alone, without the drift; 1500 m/s instead
of the glider's 1480 m/s; the rank without ``unknown_current=True``, or not after the last epoch; the true leader
positions instead of the broadcast ones; the position block of P for the current's σ.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from uwtutor.filters import cooperative_ekf
from uwtutor.filters.cooperative import relative_track_deviation
from uwtutor.observability import observability_rank
from uwtutor.exercises.checks import check_array, check_number
from uwtutor.exercises.feedback import Feedback
from ._common import Answers, cached, fail

__all__ = ["PARTS"]


def part_a(ns: Answers) -> Iterator[Feedback]:
    t = ns["scenarios"]["zigzag"].times
    offset, drift, c = ns["clock_offset"], ns["clock_drift"], ns["c"]
    expected = c * (offset + drift * t)
    yield check_array(ns["clock_bias"], expected, rtol=1e-9, name="clock_bias", units="m", common_mistakes=[
        (np.full_like(t, c * offset), "That is the offset alone: the drift adds c·(dκ/dt)·t, which grows with t."),
        (1500.0 * (offset + drift * t), "Convert with the glider's c = 1480 m/s, not 1500 m/s.")],
        hint="The clock is ahead by κ0 + κ̇ t at time t; a range converts it with c.", reveal_expected=False)
    yield check_number(ns["clock_bias_end"], expected[-1], rtol=1e-9, name="clock_bias_end", units="m",
                       hint="The value at the last epoch of clock_bias.", reveal_expected=False)


def _ranks(sc: object, **kwargs: object) -> np.ndarray:
    return observability_rank(sc.true_positions, sc.leader_positions, times=sc.times, **kwargs)


def part_b(ns: Answers) -> Iterator[Feedback]:
    ranks, deviations, patterns = ns["ranks"], ns["deviations"], ns["patterns"]
    for p, sc in ns["scenarios"].items():
        history = _ranks(sc, unknown_current=True)
        if ranks[p] != int(history[-1]):
            if ranks[p] == int(_ranks(sc)[-1]):
                yield fail(f"ranks[{p!r}] = {ranks[p]} is the rank of the position alone.",
                           hint="Pass unknown_current=True: the state is the position *and* the current, four "
                                "components.")
            if ranks[p] in set(int(r) for r in history[:-1]):
                yield fail(f"ranks[{p!r}] = {ranks[p]} is not the rank after the last epoch.",
                           hint="The information grows with every epoch: take the last element of the history.")
            yield fail(f"ranks[{p!r}] = {ranks[p]} is not right.",
                       hint="The rank after the last epoch, with unknown_current=True and the leader's positions as "
                            "the (moving) beacon.")
        yield check_number(deviations[p], float(relative_track_deviation(sc.dr_displacements[0],
                                                                         sc.leader_broadcast[0])),
                           rtol=1e-6, name=f"deviations[{p!r}]", units="m",
                           hint="Run 0's DR displacements and the leader's broadcast positions.",
                           reveal_expected=False)
    if sorted(ns["observable"]) != sorted(p for p in patterns if ranks[p] == 4):
        yield fail("observable should list the patterns whose rank is 4.")
    yield Feedback(True, "Correct.")


def _result(ns: Answers, p: str, leader: str = "leader_broadcast") -> object:
    sc, tuning, params = ns["scenarios"][p], ns["tuning"], ns["params"]
    key = (sc.dr_displacements, getattr(sc, leader), sc.ranges, tuning.P1, tuning.Q, tuning.R, params.interval,
           sc.initial_estimate())
    return cached("cooperative_current.ekf", key, lambda: cooperative_ekf(
        sc.initial_estimate(), tuning.P1, sc.dr_displacements, sc.ranges, tuning.Q, tuning.R,
        leader=getattr(sc, leader), dt=params.interval))


def part_c(ns: Answers) -> Iterator[Feedback]:
    cur_err, pos_err = ns["cur_err"], ns["pos_err"]
    current_rmse, position_rmse = ns["current_rmse"], ns["position_rmse"]
    for p, sc in ns["scenarios"].items():
        res = _result(ns, p)
        value = current_rmse(res, sc)
        mistakes = {}
        try:
            off = not np.isclose(float(cur_err[p]), value, rtol=1e-3)
        except (TypeError, ValueError):
            off = False
        if off:
            mistakes[current_rmse(_result(ns, p, "leader_positions"), sc)] = (
                "That filter uses the leader's true positions (`leader_positions`); the glider only hears what the "
                "leader broadcasts (`leader_broadcast`).")
        yield check_number(cur_err[p], value, rtol=1e-3, name=f"cur_err[{p!r}]", units="m/s", common_mistakes=mistakes,
                           hint="All runs, the matched tuning, the broadcast positions (not the true ones).",
                           reveal_expected=False)
        yield check_number(pos_err[p], position_rmse(res, sc), rtol=1e-3, name=f"pos_err[{p!r}]", units="m",
                           reveal_expected=False)


def part_d(ns: Answers) -> Iterator[Feedback]:
    claimed, over = ns["claimed_sigma"], ns["overconfidence"]
    for p in ns["patterns"]:
        res = ns["results"][p]
        if not hasattr(res, "P") or not hasattr(res, "x"):
            yield fail(f"results[{p!r}] of part C is not a filter result: finish part C first.")
        claim = float(np.sqrt(np.mean(np.trace(res.P[:, -1, 2:, 2:], axis1=-2, axis2=-1))))
        actual = float(np.sqrt(np.mean(np.sum((res.x[:, -1, 2:] - ns["scenarios"][p].true_states[-1, 2:]) ** 2,
                                              axis=-1))))
        yield check_number(claimed[p], claim, rtol=1e-3, name=f"claimed_sigma[{p!r}]", units="m/s", common_mistakes={
            float(np.sqrt(np.mean(np.trace(res.P[:, -1, :2, :2], axis1=-2, axis2=-1)))):
                "That is the position block: the current is the last two states, P[..., 2:, 2:]."},
            hint="The square root of the mean (over the runs) of the trace of the current's block of P at the last "
                 "epoch.", reveal_expected=False)
        yield check_number(over[p], actual / claim, rtol=1e-3, name=f"overconfidence[{p!r}]",
                           hint="The actual RMS current error at the last epoch (not an average over epochs) divided "
                                "by the claimed σ.", reveal_expected=False)


PARTS = {"A": part_a, "B": part_b, "C": part_c, "D": part_d}
