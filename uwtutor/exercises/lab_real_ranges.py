r"""Checkers of the lab ``real_ranges_plaza`` (chapter 11): a calibration leg, a filter built from the library's
pieces, one beacon at an acoustic rate, and its consistency.

The lab treats the Plaza 2 log as the rehearsal of an AUV mission: the truth is available for the first
``CALIBRATION_SECONDS`` only (a vehicle at the surface with GPS), the mission ranges to beacon ``BEACON`` alone,
one range every ``PERIOD`` seconds (an acoustic modem's rate). Each checker computes its reference with the
library (:func:`uwtutor.datasets.navigate` and its models) and returns a :class:`~uwtutor.exercises.Feedback`; the
lab's hidden tests assert ``.correct`` with a message of their own, so that a student's feedback never shows a
reference value.

============================================  ==========================================================================
checker                                       part
============================================  ==========================================================================
``check_calibration(s_cal)``                  A: the scale of the calibration leg, least squares through the origin
``check_calibrated_rmse(rmse)``               B: the RMSE of the filter with the calibrated scale divided out
``check_estimated_rmse(rmse)``                C: the RMSE of the filter that estimates the scale
``check_scale_end(s)``                        C: that filter's final scale estimate
``check_nees_mean(v)``                        D: the mean position NEES of the calibrated filter
``check_nees_inside(f)``                      D: the fraction of its epochs inside the 95 % interval of chi-square(2)
============================================  ==========================================================================
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any

import numpy as np

from .checks import check_number
from .feedback import Feedback

__all__ = ["check_calibration", "check_calibrated_rmse", "check_estimated_rmse", "check_scale_end",
           "check_nees_mean", "check_nees_inside", "reference", "SET", "BEACON", "PERIOD", "CALIBRATION_SECONDS"]

#: The log (Plaza 2), the mission's one beacon, its range period [s] and the calibration leg [s].
SET, BEACON, PERIOD, CALIBRATION_SECONDS = 2, 1, 8.0, 60.0


@lru_cache(maxsize=1)
def _data() -> Any:
    from ..datasets import plaza

    return plaza(SET)


def _leg(data: Any) -> tuple[np.ndarray, np.ndarray]:
    """The ranges to ``BEACON`` and the true distances on the epochs of the calibration leg."""
    leg = data.times <= data.times[0] + CALIBRATION_SECONDS
    r = data.ranges_on_epochs([BEACON])[leg, 0]
    d = data.true_ranges([BEACON])[leg, 0]
    ok = np.isfinite(r)
    return r[ok], d[ok]


def _rmse(x: np.ndarray, truth: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum((x[:, :2] - truth[:, :2]) ** 2, axis=1))))


@lru_cache(maxsize=1)
def _reference() -> dict[str, float]:
    from scipy import stats

    from ..datasets import navigate
    from ..datasets.study import nees, without_scale

    data = _data()
    r, d = _leg(data)
    s_cal = float(r @ d / (d @ d))
    calibrated = navigate(without_scale(data, s_cal), [BEACON], min_period=PERIOD, scale=False)
    estimated = navigate(data, [BEACON], min_period=PERIOD)
    e = nees(calibrated.x, calibrated.P, data.truth, "position")
    lo, hi = stats.chi2.ppf([0.025, 0.975], 2)
    raw = navigate(data, [BEACON], min_period=PERIOD, scale=False)
    pose = nees(calibrated.x, calibrated.P, data.truth, "pose")
    return {"s_cal": s_cal, "affine": float(np.polyfit(d, r, 1)[0]), "mean_ratio": float(np.mean(r / d)),
            "all_ranges": float(np.nansum(data.ranges_on_epochs([BEACON]) * data.true_ranges([BEACON]))
                                / np.nansum(np.where(np.isfinite(data.ranges_on_epochs([BEACON])),
                                                     data.true_ranges([BEACON]) ** 2, 0.0))),
            "rmse_cal": _rmse(calibrated.x, data.truth), "rmse_est": _rmse(estimated.x, data.truth),
            "rmse_raw": _rmse(raw.x, data.truth), "scale_end": float(estimated.x[-1, 4]),
            "nees_mean": float(np.mean(e)), "nees_inside": float(np.mean((e >= lo) & (e <= hi))),
            "nees_pose_mean": float(np.mean(pose)), "nees_median": float(np.median(e))}


def reference() -> dict[str, float]:
    """The lab's reference values (for the instructor notes and the tests; the hidden tests never print them)."""
    return dict(_reference())


def check_calibration(answer: Any) -> Feedback:
    """Part A: the range scale of the calibration leg, least squares of the ranges on the true distances through the
    origin (beacon ``BEACON``, the epochs of the first ``CALIBRATION_SECONDS``)."""
    ref = _reference()
    return check_number(answer, ref["s_cal"], rtol=1e-6, name="the calibrated scale",
                        common_mistakes={
                            ref["affine"]: "That is the slope of a line with an offset: the model r = s d has none. "
                                           "Fit through the origin: s = Σ r d / Σ d².",
                            ref["mean_ratio"]: "That is the mean of the ratios r/d; least squares weighs the ranges by "
                                               "their distance: s = Σ r d / Σ d².",
                            ref["all_ranges"]: "That uses the whole log; the truth is known on the calibration leg "
                                               "only (the first 60 s)."},
                        hint="Keep the epochs with times <= times[0] + 60 and a range (not NaN); s = (r @ d) / (d @ d).")


def check_calibrated_rmse(answer: Any) -> Feedback:
    """Part B: the RMS position error of the filter built from the library's pieces, the calibrated scale divided
    out of the ranges, one range every ``PERIOD`` s to ``BEACON``."""
    ref = _reference()
    return check_number(answer, ref["rmse_cal"], rtol=1e-4, name="the RMSE of the calibrated filter", units="m",
                        common_mistakes={ref["rmse_raw"]: "That is the filter on the raw ranges: divide them by your "
                                                          "calibrated scale first.",
                                         ref["rmse_est"]: "That is the filter with a scale state (part C)."},
                        hint="z = data.ranges_on_epochs([BEACON], min_period=PERIOD) / s_cal; the state [x, y, heading, "
                             "gyro bias]; the RMSE over every epoch.")


def check_estimated_rmse(answer: Any) -> Feedback:
    """Part C: the RMS position error of the filter with the scale in the state, on the raw ranges."""
    ref = _reference()
    return check_number(answer, ref["rmse_est"], rtol=1e-4, name="the RMSE of the filter with a scale state",
                        units="m", common_mistakes={ref["rmse_cal"]: "That is the calibrated filter of part B."},
                        hint="navigate(data, [BEACON], min_period=PERIOD): the default states, the raw ranges.")


def check_scale_end(answer: Any) -> Feedback:
    """Part C: the final scale estimate of that filter."""
    ref = _reference()
    return check_number(answer, ref["scale_end"], rtol=1e-5, name="the final scale estimate",
                        common_mistakes={ref["s_cal"]: "That is your calibrated scale (part A); the task asks for the "
                                                       "filter's own estimate at the last epoch, x[-1, 4]."},
                        hint="result.x[-1, 4] (the state is [x, y, heading, gyro bias, scale]).")


def check_nees_mean(answer: Any) -> Feedback:
    """Part D: the mean over the epochs of the position NEES of the calibrated filter."""
    ref = _reference()
    return check_number(answer, ref["nees_mean"], rtol=1e-4, name="the mean position NEES",
                        common_mistakes={ref["nees_pose_mean"]: "That is the NEES of the pose [x, y, heading]; the task "
                                                                "asks for the position [x, y] only.",
                                         ref["nees_median"]: "That is the median; the task asks for the mean."},
                        hint="e = truth[:, :2] - x[:, :2]; the NEES at each epoch is e P⁻¹ e with P the 2 × 2 position "
                             "block of the covariance.")


def check_nees_inside(answer: Any) -> Feedback:
    """Part D: the fraction of the epochs whose position NEES lies in the two-sided 95 % interval of chi-square(2)."""
    ref = _reference()
    return check_number(answer, ref["nees_inside"], rtol=1e-4, name="the fraction inside the interval",
                        common_mistakes={100 * ref["nees_inside"]: "That is a percentage; the task asks for a fraction."},
                        hint="lo, hi = scipy.stats.chi2.ppf([0.025, 0.975], 2); np.mean((nees >= lo) & (nees <= hi)).")
