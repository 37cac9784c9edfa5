r"""Hidden tests of the lab ``real_ranges_plaza`` (chapter 11): a mission rehearsed on the Plaza 2 log.

The lab treats the log as the rehearsal of an AUV mission: the truth is known on the first
``CALIBRATION_SECONDS`` only (a vehicle at the surface with GPS), the mission ranges to beacon ``BEACON`` alone,
one range every ``PERIOD`` seconds (an acoustic modem's rate). The references are computed here with uwtutor's
pieces (part B, as its task lists them) and :func:`uwtutor.datasets.navigate` (part C). Each part is checked against
the student's own earlier answers, so that one mistake is counted once: part B's filter with the student's ``s_cal``
(part A), part D's NEES from the student's own ``result_cal`` (part B). Parts B and D are graded in two checks each
(B1: the motion model, 1 point; B2: the filter's RMSE, 3 points; D1: the mean NEES, 2 points; D2: the fraction
inside, 1 point).

Recognised mistakes (the instructor notes list them): in A, a line with an offset, the mean of the ratios, or the
whole log instead of the calibration leg; in B, the library's default order (``order="move-first"`` left out), the
raw ranges (the scale not divided out) or part C's filter; in C, part B's filter, or the calibrated scale for the
filter's own; in D, the NEES of the pose instead of the position, the median instead of the mean, a percentage
instead of a fraction.
"""

from __future__ import annotations

from collections.abc import Iterator
from functools import lru_cache
from typing import Any

import numpy as np

from uwtutor.exercises.checks import check_number
from uwtutor.exercises.feedback import Feedback
from ._common import Answers, cached, fail

__all__ = ["PARTS", "REQUIRES", "reference", "SET", "BEACON", "PERIOD", "CALIBRATION_SECONDS"]

#: What grading this lab needs beyond uwtutor: the Plaza logs ship in GTSAM's wheel.
REQUIRES = {"gtsam": "uwtutor[data]"}

#: The log (Plaza 2), the mission's one beacon, its range period [s] and the calibration leg [s].
SET, BEACON, PERIOD, CALIBRATION_SECONDS = 2, 1, 8.0, 60.0


@lru_cache(maxsize=1)
def _data() -> Any:
    from uwtutor.datasets import plaza

    return plaza(SET)


def _leg() -> tuple[np.ndarray, np.ndarray]:
    """The ranges to ``BEACON`` and the true distances on the epochs of the calibration leg that have a range."""
    data = _data()
    leg = data.times <= data.times[0] + CALIBRATION_SECONDS
    r = data.ranges_on_epochs([BEACON])[leg, 0]
    d = data.true_ranges([BEACON])[leg, 0]
    heard = np.isfinite(r)
    return r[heard], d[heard]


def _rmse(x: np.ndarray) -> float:
    truth = _data().truth
    return float(np.sqrt(np.mean(np.sum((x[:, :2] - truth[:, :2]) ** 2, axis=1))))


def _calibrated(s_cal: float, order: str = "move-first") -> Any:
    """The filter of part B, built from the pieces its task lists: the scale ``s_cal`` divided out of the ranges,
    the state [x, y, heading, gyro bias] (``order`` is the task's, or the library's default for the mistake)."""
    from uwtutor.filters import ChiSquareGate, ReacquiringGate, extended_kalman_filter
    from uwtutor.models import BeaconRanges, OdometryMotion

    def run() -> Any:
        data = _data()
        dt = np.diff(data.times, prepend=data.times[0])
        motion = OdometryMotion(0.01 + 0.02 * np.abs(data.odometry[:, 0]), 1e-3 * np.sqrt(dt) + 1e-9,
                                gyro_bias=True, times=data.times, order=order, gyro_bias_walk=1e-4)
        measurement = BeaconRanges(data.beacon_positions([BEACON]), R=0.6**2, layout=motion.layout)
        x0, P0 = motion.layout.initial_state(data.start, data.start_cov, gyro_bias=(0.0, 0.01))
        z = data.ranges_on_epochs([BEACON], min_period=PERIOD) / s_cal
        gate = ReacquiringGate(ChiSquareGate(0.999, per_component=True), patience=10)
        return extended_kalman_filter(motion, measurement, x0, P0, data.odometry, z, times=data.times, gate=gate)

    return cached("real_ranges_plaza.calibrated", (float(s_cal), order), run)


def _navigate(**options: Any) -> Any:
    from uwtutor.datasets import navigate

    return cached("real_ranges_plaza.navigate", options,
                  lambda: navigate(_data(), [BEACON], min_period=PERIOD, **options))


def _s_cal_reference() -> float:
    r, d = _leg()
    return float(r @ d / (d @ d))


def _student_scale(ns: Answers) -> tuple[float | None, Feedback | None]:
    """The student's ``s_cal`` as a usable number, or a failed check that says why it cannot be used."""
    s_cal = ns["s_cal"]
    try:
        value = float(np.asarray(s_cal, dtype=float).reshape(()))
    except (TypeError, ValueError):
        return None, fail("`s_cal` (part A) is not one number, and this part divides the ranges by it.",
                          hint="Finish part A first.")
    if not np.isfinite(value) or not 0.5 < value < 2.0:
        return None, fail("`s_cal` (part A) is not a usable range scale, and this part divides the ranges by it.",
                          hint="Finish part A first: the scale is a little above 1.")
    return value, None


def part_a(ns: Answers) -> Iterator[Feedback]:
    r, d = _leg()
    data = _data()
    all_r, all_d = data.ranges_on_epochs([BEACON])[:, 0], data.true_ranges([BEACON])[:, 0]
    heard = np.isfinite(all_r)
    yield check_number(ns["s_cal"], _s_cal_reference(), rtol=1e-6, name="s_cal", reveal_expected=False,
                       common_mistakes={
                           float(np.polyfit(d, r, 1)[0]): "That is the slope of a line with an offset: the model "
                                                          "r = s d has none. Fit through the origin.",
                           float(np.mean(r / d)): "That is the mean of the ratios r/d; least squares weighs each "
                                                  "range by its distance.",
                           float(all_r[heard] @ all_d[heard] / (all_d[heard] @ all_d[heard])):
                               "That uses the whole log; the truth is known on the calibration leg only."},
                       hint="Keep the epochs of the calibration leg that have a range (not NaN), then least squares "
                            "of r = s d through the origin.")


_ORDER_HINT = ("The odometry of the Plaza logs moves, then turns: pass order=\"move-first\" to OdometryMotion (the "
               "library's default is turn-first, chapter 11).")


def part_b1(ns: Answers) -> Iterator[Feedback]:
    motion = ns["motion"]
    names = getattr(getattr(motion, "layout", None), "names", None)
    if names != ("x", "y", "heading", "gyro_bias"):
        yield fail(f"the state of `motion` is {names}, not [x, y, heading, gyro_bias].",
                   hint="OdometryMotion(..., gyro_bias=True) and no scale: the scale is divided out of the ranges.")
    order = getattr(motion, "order", None)
    if order != "move-first":
        yield fail(f"`motion` takes the steps in the order {order!r}: `order=\"move-first\"` is left out.",
                   hint=_ORDER_HINT)
    yield Feedback(True, "Correct.")


def part_b2(ns: Answers) -> Iterator[Feedback]:
    s_cal, problem = _student_scale(ns)
    if problem is not None:
        yield problem
        return
    mistakes = {_rmse(_calibrated(s_cal, order="turn-first").x): "That is the filter with the library's default "
                "order of operations (turn-first): `order=\"move-first\"` is left out of OdometryMotion, and the "
                "Plaza odometry moves, then turns.",
                _rmse(_navigate(scale=False).x): "That is the filter on the raw ranges: divide them by your s_cal "
                                                 "first.",
                _rmse(_navigate().x): "That is the filter with a scale state (part C)."}
    yield check_number(ns["rmse_cal"], _rmse(_calibrated(s_cal).x), rtol=1e-4, name="rmse_cal", units="m",
                       reveal_expected=False, common_mistakes=mistakes,
                       hint="Check the ranges (beacon 1, one per 8 s, divided by s_cal), the noise of each step, the "
                            "order of operations, the initial state and the gate, and that the RMSE runs over every "
                            "epoch.")


def part_c(ns: Answers) -> Iterator[Feedback]:
    estimated = _navigate()
    mistakes = {}
    s_cal = ns.get("s_cal")
    if s_cal is not None and np.ndim(s_cal) == 0 and np.isfinite(float(s_cal)):
        mistakes[float(s_cal)] = ("That is your calibrated scale (part A); the task asks for the filter's own "
                                  "estimate at the last epoch.")
    yield check_number(ns["rmse_est"], _rmse(estimated.x), rtol=1e-4, name="rmse_est", units="m",
                       reveal_expected=False,
                       common_mistakes={_rmse(_calibrated(_s_cal_reference()).x): "That is the calibrated filter of "
                                                                                  "part B."},
                       hint="navigate(data, [BEACON], min_period=PERIOD) with its default states, on the raw ranges; "
                            "the RMSE over every epoch.")
    yield check_number(ns["scale_end"], float(estimated.x[-1, 4]), rtol=1e-5, name="scale_end",
                       reveal_expected=False, common_mistakes=mistakes,
                       hint="The scale is the fifth state of [x, y, heading, gyro bias, scale]; take its last epoch.")


def _student_filter(ns: Answers) -> Any:
    """The student's own part-B filter when it is a usable result (so that a mistake in B is not counted in D),
    else the reference filter with the student's scale (or the reference scale)."""
    result = ns.get("result_cal")
    x, P = getattr(result, "x", None), getattr(result, "P", None)
    K = len(_data().times)
    try:
        x, P = np.asarray(x, dtype=float), np.asarray(P, dtype=float)
        if x.ndim == 2 and x.shape[0] == K and x.shape[1] >= 2 and P.shape == (K, x.shape[1], x.shape[1]) \
                and np.all(np.isfinite(x[:, :2])) and np.all(np.isfinite(P[:, :2, :2])):
            return result
    except (TypeError, ValueError):
        pass
    s_cal, problem = _student_scale(ns)
    return _calibrated(_s_cal_reference() if problem is not None else s_cal)


def _nees_of(result: Any, states: str) -> np.ndarray:
    from uwtutor.datasets.study import nees

    return nees(np.asarray(result.x, dtype=float), np.asarray(result.P, dtype=float), _data().truth, states)


def part_d1(ns: Answers) -> Iterator[Feedback]:
    result = _student_filter(ns)
    e = _nees_of(result, "position")
    mistakes = {float(np.median(e)): "That is the median; the task asks for the mean."}
    if np.shape(result.x)[1] >= 3:
        mistakes[float(np.mean(_nees_of(result, "pose")))] = ("That is the NEES of the pose [x, y, heading]; the "
                                                               "task asks for the position [x, y] only.")
    yield check_number(ns["nees_mean"], float(np.mean(e)), rtol=1e-4, name="nees_mean", reveal_expected=False,
                       common_mistakes=mistakes,
                       hint="The error of [x, y] against the truth and the 2 x 2 position block of your "
                            "result_cal.P, at every epoch.")


def part_d2(ns: Answers) -> Iterator[Feedback]:
    from scipy import stats

    e = _nees_of(_student_filter(ns), "position")
    lo, hi = stats.chi2.ppf([0.025, 0.975], 2)
    inside = float(np.mean((e >= lo) & (e <= hi)))
    yield check_number(ns["nees_inside"], inside, rtol=1e-4, name="nees_inside", reveal_expected=False,
                       common_mistakes={100 * inside: "That is a percentage; the task asks for a fraction."},
                       hint="The two-sided 95 % interval of chi-square with 2 degrees of freedom, and the fraction "
                            "of the epochs of your result_cal whose NEES lies in it.")


def reference() -> dict[str, float]:
    """The lab's reference answers, for the instructor (the hidden tests never print them).

    Returns
    -------
    dict
        ``s_cal``, ``rmse_cal``, ``rmse_est``, ``scale_end``, ``nees_mean`` and ``nees_inside``.

    Examples
    --------
    >>> import pytest
    >>> # the Plaza data come with the gtsam wheel
    >>> _ = pytest.importorskip("gtsam")
    >>> ref = reference()  # three filters on Plaza 2: about three seconds
    >>> sorted(ref)
    ['nees_inside', 'nees_mean', 'rmse_cal', 'rmse_est', 's_cal', 'scale_end']
    >>> bool(1.0 < ref["s_cal"] < 1.1)  # the ranges are a few percent too long
    True
    """
    s_cal = _s_cal_reference()
    calibrated, estimated = _calibrated(s_cal), _navigate()
    e = _nees_of(calibrated, "position")
    from scipy import stats

    lo, hi = stats.chi2.ppf([0.025, 0.975], 2)
    return {"s_cal": s_cal, "rmse_cal": _rmse(calibrated.x), "rmse_est": _rmse(estimated.x),
            "scale_end": float(estimated.x[-1, 4]), "nees_mean": float(np.mean(e)),
            "nees_inside": float(np.mean((e >= lo) & (e <= hi)))}


PARTS = {"A": part_a, "B1": part_b1, "B2": part_b2, "C": part_c, "D1": part_d1, "D2": part_d2}
