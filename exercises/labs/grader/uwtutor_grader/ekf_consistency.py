"""Hidden tests of the lab ``ekf_consistency`` (chapter 4): a mis-tuned range-only EKF, its NEES and NIS.

Each step is checked with the student's own earlier answers: the fraction inside the bounds with the student's own
bounds, ``best_R`` with the student's own ``average_nis``, parts D and E with the student's ``best_R`` (when it is
one of the grid values), so that a slip is counted once. Parts A-C are graded in two checks each: A1 the NEES bounds
(1 point), A2 the mean NEES and the fraction inside (2); B1 the NIS bounds (1), B2 the mean NIS and the fraction
inside (1); C1 ``average_nis`` (2), C2 ``best_R`` (1).

Recognised mistakes (the instructor notes list them): ``chi2_mean_bounds`` with one degree of freedom for the 2-D
NEES, or two for the scalar NIS; ``best_R`` away from the grid value whose NIS is closest to 1 (the smallest NIS).
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from uwtutor.filters import range_only_ekf
from uwtutor.metrics import average_over_runs, chi2_mean_bounds, fraction_within, nees, nis
from uwtutor.exercises.checks import check_array, check_number
from uwtutor.exercises.feedback import Feedback
from ._common import Answers, call, cached, fail, own_function, own_interval

__all__ = ["PARTS"]


def _ekf(ns: Answers, Q: np.ndarray, R: float) -> object:
    sc = ns["scenario"]
    key = (ns["x0"], ns["P0"], sc.dr_displacements, sc.ranges, ns["beacon"], np.asarray(Q, dtype=float), float(R))
    return cached("ekf_consistency.ekf", key, lambda: range_only_ekf(ns["x0"], ns["P0"], sc.dr_displacements,
                                                                      sc.ranges, Q, R, beacon=ns["beacon"]))


def _average_nis(ns: Answers, R: float) -> float:
    r = _ekf(ns, ns["Q_colleague"], R)
    return float(np.nanmean(nis(r.innovations, r.innovation_cov)))


def part_a1(ns: Answers) -> Iterator[Feedback]:
    n_runs = ns["n_runs"]
    yield check_array(np.asarray(ns["nees_bounds"], dtype=float), np.asarray(chi2_mean_bounds(2, n_runs), dtype=float),
                      rtol=1e-6, name="nees_bounds", common_mistakes=[
                          (np.asarray(chi2_mean_bounds(1, n_runs)), "The NEES of a 2-D position has 2 degrees of "
                                                                    "freedom (chi2_mean_bounds(2, ...)).")],
                      hint="The 95 % interval of a mean of n_runs NEES values of a 2-D position.",
                      reveal_expected=False)


def part_a2(ns: Answers) -> Iterator[Feedback]:
    bounds = own_interval(ns, "nees_bounds") or chi2_mean_bounds(2, ns["n_runs"])
    result = _ekf(ns, ns["Q_colleague"], ns["R_colleague"])
    mean = average_over_runs(nees(result.x, result.P, ns["scenario"].true_positions))[0]
    yield check_array(ns["mean_nees"], mean, rtol=1e-6, name="mean_nees",
                      hint="The colleague's EKF on all runs; the NEES against `scenario.true_positions`, averaged over "
                           "the runs at each epoch (`average_over_runs`).", reveal_expected=False)
    yield check_number(ns["nees_inside"], fraction_within(mean, *bounds), rtol=1e-9, atol=1e-9, name="nees_inside",
                       hint="The fraction of epochs whose mean NEES lies inside your nees_bounds (`fraction_within`).",
                       reveal_expected=False)


def part_b1(ns: Answers) -> Iterator[Feedback]:
    n_runs = ns["n_runs"]
    yield check_array(np.asarray(ns["nis_bounds"], dtype=float), np.asarray(chi2_mean_bounds(1, n_runs), dtype=float),
                      rtol=1e-6, name="nis_bounds", common_mistakes=[
                          (np.asarray(chi2_mean_bounds(2, n_runs)), "A range is one number: its NIS has 1 degree of "
                                                                    "freedom (chi2_mean_bounds(1, ...)).")],
                      hint="The 95 % interval of a mean of n_runs NIS values of one range.", reveal_expected=False)


def part_b2(ns: Answers) -> Iterator[Feedback]:
    bounds = own_interval(ns, "nis_bounds") or chi2_mean_bounds(1, ns["n_runs"])
    result = _ekf(ns, ns["Q_colleague"], ns["R_colleague"])
    mean = average_over_runs(nis(result.innovations, result.innovation_cov))[0]
    yield check_array(ns["mean_nis"], mean, rtol=1e-6, name="mean_nis",
                      hint="The NIS of the colleague's EKF (`result.innovations`, `result.innovation_cov`), averaged "
                           "over the runs at each epoch.", reveal_expected=False)
    yield check_number(ns["nis_inside"], fraction_within(mean, *bounds), atol=1e-9, name="nis_inside",
                       hint="The fraction of epochs whose mean NIS lies inside your nis_bounds (`fraction_within`).",
                       reveal_expected=False)


def part_c1(ns: Answers) -> Iterator[Feedback]:
    for R in (0.25, 4.0):
        got, problem = call(ns["average_nis"], R, name=f"average_nis({R})")
        if problem is not None:
            yield problem
        yield check_number(got, _average_nis(ns, R), rtol=1e-6, name=f"average_nis({R})",
                           hint="Run the EKF with Q_colleague and this R on all runs; average the NIS over the runs "
                                "and the epochs (`np.nanmean`).", reveal_expected=False)


def part_c2(ns: Answers) -> Iterator[Feedback]:
    values = {}
    for R in ns["R_grid"]:
        own = own_function(ns, "average_nis", R)      # part C1's function, the student's own
        values[R] = float(own) if own is not None and np.ndim(own) == 0 else _average_nis(ns, R)
    if ns["best_R"] != min(values, key=lambda R: abs(values[R] - 1.0)):
        smallest = min(values, key=values.get)
        yield fail(f"best_R = {ns['best_R']!r} is not the grid value whose average NIS is closest to 1.",
                   hint="Compare |average_nis(R) − 1| over R_grid, not the NIS itself"
                        + (" (that R has the smallest NIS)." if ns["best_R"] == smallest else "."))
    yield Feedback(True, "Correct.")


def _tuned_R(ns: Answers) -> float:
    """The student's ``best_R`` (part C) when it is one of the grid values, else the grid value whose average NIS is
    closest to 1: parts D and E run the filter with it."""
    grid = list(ns["R_grid"])
    best = ns.get("best_R")
    return float(best) if best in grid else min(grid, key=lambda R: abs(_average_nis(ns, R) - 1.0))


def part_d(ns: Answers) -> Iterator[Feedback]:
    small_q = ns["small_q"]
    r = _ekf(ns, np.eye(2) * 0.1**2, _tuned_R(ns))
    yield check_number(small_q[0], float(np.mean(nees(r.x, r.P, ns["scenario"].true_positions))), rtol=1e-6,
                       name="the average NEES", hint="Q = 0.1² I and your tuned R (best_R); the NEES averaged over "
                                                     "every run and epoch.", reveal_expected=False)
    yield check_number(small_q[1], float(np.nanmean(nis(r.innovations, r.innovation_cov))), rtol=1e-6,
                       name="the average NIS", reveal_expected=False)


def part_e(ns: Answers) -> Iterator[Feedback]:
    truth = ns["scenario"].true_positions

    def rmse(R: float) -> float:
        r = _ekf(ns, ns["Q_colleague"], R)
        return float(np.sqrt(np.mean(np.sum((r.x - truth) ** 2, axis=-1)[:, -100:])))

    yield check_number(ns["rmse_colleague"], rmse(ns["R_colleague"]), rtol=1e-6, name="rmse_colleague", units="m",
                       hint="The RMS position error over all runs and the last 100 epochs.", reveal_expected=False)
    yield check_number(ns["rmse_tuned"], rmse(_tuned_R(ns)), rtol=1e-6, name="rmse_tuned", units="m",
                       hint="The same EKF with the tuned R of part C.", reveal_expected=False)


PARTS = {"A1": part_a1, "A2": part_a2, "B1": part_b1, "B2": part_b2, "C1": part_c1, "C2": part_c2, "D": part_d,
         "E": part_e}
