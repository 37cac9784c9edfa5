r"""Checkers for the exercises of chapter 11, "Real ranges: the book's methods on a robot's log, against a factor
graph".

Each checker takes the student's answer, computes the expected value with ``uwtutor`` itself (the Plaza logs of
:func:`uwtutor.datasets.plaza`, :func:`uwtutor.datasets.navigate` and the models of
:func:`uwtutor.datasets.navigation_models`, the committed study of
:func:`uwtutor.datasets.study.load_real_data_study`), and returns a ``Feedback`` that recognises the usual mistakes of
that exercise:

==========================================  ============================================================================
checker                                     exercise
==========================================  ============================================================================
``check_scale(s)``                          11.1: the range scale of Plaza 2 by least squares against the truth
``check_residual_std(sigma)``               11.1: the standard deviation of the ranges after the scale
``check_drift_rate(rate)``                  11.2: the heading drift rate of Plaza 2's odometry [deg/s]
``check_scale_gain(gain)``                  11.3: the gain of the scale state (RMSE without it over RMSE with it)
``check_rejected(n)``                       11.4: the ranges a strict gate rejects from a filter too sure of its scale
``check_locked_rmse(rmse)``                 11.4: that filter's RMSE
``check_reacquired_rmse(rmse)``             11.4: the RMSE with re-acquisition
==========================================  ============================================================================

The exercises themselves are in the repository's ``exercises/ch11_real_data.ipynb``. The references are computed once
per kernel (the filters of exercise 11.4 take a few seconds).
"""

from __future__ import annotations

from dataclasses import replace
from functools import lru_cache
from typing import Any

import numpy as np

from .checks import check_number
from .feedback import Feedback

__all__ = [
    "check_scale", "check_residual_std", "check_drift_rate", "check_scale_gain", "check_rejected",
    "check_locked_rmse", "check_reacquired_rmse", "scale_variants", "drift_variants", "lockout_runs",
    "SET", "GAIN_BEACONS", "LOCKOUT_BEACON", "TIGHT_SCALE_PRIOR", "STRICT_PROBABILITY", "PATIENCE",
]

#: The log of every exercise: Plaza 2.
SET = 2
#: Exercise 11.3: the beacons (all four) and the logged rate.
GAIN_BEACONS = "all"
#: Exercise 11.4: the beacon, the prior standard deviation of the scale that is too tight, the gate's probability
#: and the re-acquisition's patience.
LOCKOUT_BEACON = 5
TIGHT_SCALE_PRIOR = 0.002
STRICT_PROBABILITY = 0.99
PATIENCE = 10


@lru_cache(maxsize=1)
def _data() -> Any:
    from ..datasets import plaza

    return plaza(SET)


# -- exercise 11.1: the scale ------------------------------------------------------------------------------------------
@lru_cache(maxsize=1)
def _scale_variants() -> tuple[tuple[str, float], ...]:
    data = _data()
    r, d = data.ranges_on_epochs(), data.true_ranges()
    ok = np.isfinite(r)
    r, d = r[ok], d[ok]
    s = float(r @ d / (d @ d))
    slope, offset = np.polyfit(d, r, 1)
    res = r - s * d
    affine = r - (slope * d + offset)
    return (("scale", s), ("mean_ratio", float(np.mean(r / d))), ("affine_slope", float(slope)),
            ("inverse", float(r @ r / (r @ d))), ("reversed", float(r @ d / (r @ r))),
            ("median_ratio", float(np.median(r / d))), ("percent", 100.0 * (s - 1.0)), ("excess", s - 1.0),
            ("std", float(res.std())), ("std_unscaled", float((r - d).std())),
            ("rms_unscaled", float(np.sqrt(np.mean((r - d) ** 2)))),
            ("std_affine", float(affine.std())), ("variance", float(res.var())),
            ("rms", float(np.sqrt(np.mean(res**2)))), ("standard_error", float(np.sqrt(res.var() / (d @ d)))))


def scale_variants() -> dict[str, float]:
    r"""The right answers of exercise 11.1 and the values its usual mistakes give.

    Returns
    -------
    dict of str to float
        ``"scale"``: :math:`\hat s = \sum r_j d_j / \sum d_j^2` over every range of Plaza 2 on the epochs;
        ``"mean_ratio"``, ``"median_ratio"``: the mean and median of :math:`r_j / d_j`; ``"affine_slope"``: the slope
        of a straight line with an offset; ``"inverse"``, ``"reversed"``: the regressions the wrong way round;
        ``"percent"``, ``"excess"``: :math:`100(\hat s - 1)` and :math:`\hat s - 1`; ``"std"``: the standard deviation
        of :math:`r_j - \hat s d_j`; ``"std_unscaled"``, ``"rms_unscaled"``: of :math:`r_j - d_j`; ``"std_affine"``:
        after the straight line; ``"variance"``; ``"rms"``: the RMS of :math:`r_j - \hat s d_j` (the mean included);
        ``"standard_error"``: :math:`\sqrt{\widehat{\operatorname{var}}(r - \hat s d) / \sum d_j^2}`, the standard
        error of :math:`\hat s` (the ranges taken as independent).

    Examples
    --------
    >>> import pytest
    >>> # the Plaza data come with the gtsam wheel
    >>> _ = pytest.importorskip("gtsam")
    >>> v = scale_variants()
    >>> bool(1.0 < v["scale"] < 1.1), bool(v["std"] < v["std_unscaled"])
    (True, True)
    """
    return dict(_scale_variants())


def check_scale(answer: Any) -> Feedback:
    r"""Check the range scale :math:`\hat s` of Plaza 2 (exercise 11.1 a): least squares through the origin of the
    ranges on the epochs against the true distances there.

    Examples
    --------
    >>> import pytest
    >>> _ = pytest.importorskip("gtsam")
    >>> from uwtutor.exercises import ch11
    >>> bool(ch11.check_scale(ch11.scale_variants()["scale"]))
    True
    >>> print(  # doctest: +ELLIPSIS
    ...     ch11.check_scale(ch11.scale_variants()["affine_slope"]).hint
    ... )
    That is the slope of a straight line with an offset...
    """
    v = scale_variants()
    mistakes = {
        v["mean_ratio"]: "That is the mean of the ratios r/d: each ratio is weighted alike, so the short ranges, "
                         "whose ratio is noisiest, count as much as the long ones. Least squares of r = s d weighs "
                         "each range by its distance: s = Σ r d / Σ d².",
        v["median_ratio"]: "That is the median of the ratios r/d; the task asks for the least-squares "
                           "s = Σ r d / Σ d².",
        v["affine_slope"]: "That is the slope of a straight line with an offset (np.polyfit(d, r, 1)[0]); the model "
                           "has no offset, r = s d: fit through the origin, s = Σ r d / Σ d².",
        v["inverse"]: "That regresses the wrong way round (d on r), then inverts: s is the slope of r on d, "
                      "Σ r d / Σ d².",
        v["reversed"]: "That is the slope of d on r (about 1/s): the ranges are the measurements, the distances the "
                       "regressor: s = Σ r d / Σ d².",
        v["percent"]: "That is 100 (s − 1), the excess in percent; the task asks for the scale itself (about 1.07).",
        v["excess"]: "That is s − 1; the task asks for the scale itself, the factor on the distance.",
    }
    se = v["standard_error"]
    for value in (v["mean_ratio"], v["median_ratio"], v["affine_slope"], v["inverse"]):
        # these estimate the same scale about as well: say so, next to what the task asked for
        mistakes[value] += (f" (As an estimate of the scale it lies {abs(value - v['scale']) / se:.1f} standard "
                            f"errors from the least-squares one, whose standard error is {se:.1e}: the data cannot "
                            "tell them apart; the task asks for the least-squares formula.)")
    rounded = _rounded_scale(answer, v["scale"], 0.1 * se)
    if rounded is not None:
        # a printout copied back (1.0697 also lies within a tenth of a standard error of the mean ratio: a rounded
        # least-squares value is the likelier reading, and is not called a wrong formula)
        return Feedback(False, f"Not yet: {answer!r} is the least-squares scale rounded to {rounded} decimals.",
                        hint="Give the value as computed (s_hat = (r @ d) / (d @ d)), not a printout of it: the "
                             "check compares it to a tenth of its standard error.",
                        details={"answer": float(answer), "rounded": rounded})
    # a tenth of the standard error: any correct computation of the formula passes, an estimate by another
    # formula (all of them 0.1 to 0.8 standard errors away) is named
    feedback = check_number(answer, v["scale"], rtol=0.0, atol=0.1 * se, name="the range scale s",
                            common_mistakes=mistakes,
                        hint="r = data.ranges_on_epochs(), d = data.true_ranges(); keep the entries where r is "
                             "not NaN; s = (r @ d) / (d @ d).",
                        explanation=f"Every range is that many times the true distance, on every beacon: a scale, "
                                    f"not an offset. Its standard error is {se:.1e} (the ranges taken as "
                                    "independent): the fourth decimal is the last that means something.")
    estimator = _ESTIMATOR_NAMES.get(next((k for k, value in v.items()
                                           if value == feedback.details.get("mistake")), ""))
    if estimator is not None:
        # another estimator of the scale is a choice of formula, not a slip: the message names it first
        feedback = replace(feedback, message=f"Not yet: {feedback.details['answer']:.6g} is {estimator}, not the "
                                             "least-squares slope through the origin that the task asks for.")
    return feedback


#: The other estimators of the scale a student may compute, as the message names them.
_ESTIMATOR_NAMES = {"mean_ratio": "the mean of the ratios r/d", "median_ratio": "the median of the ratios r/d",
                    "affine_slope": "the slope of a straight line with an offset",
                    "inverse": "the inverse of the slope of d on r", "reversed": "the slope of d on r"}


def _rounded_scale(answer: Any, scale: float, tolerance: float) -> int | None:
    """The number of decimals (3 to 5) to which ``answer`` is ``scale`` rounded, if it is, and further from it than
    ``tolerance``."""
    if isinstance(answer, (bool, np.bool_)) or not isinstance(answer, (int, float, np.floating)):
        return None
    if abs(float(answer) - scale) <= tolerance:
        return None
    for decimals in (3, 4, 5):
        if float(answer) == round(scale, decimals) != scale:
            return decimals
    return None


def check_residual_std(answer: Any) -> Feedback:
    r"""Check the standard deviation of :math:`r_j - \hat s d_j` over every range of Plaza 2 (exercise 11.1 b).

    Examples
    --------
    >>> import pytest
    >>> # the Plaza data come with the gtsam wheel
    >>> _ = pytest.importorskip("gtsam")
    >>> from uwtutor.datasets import plaza
    >>> data = plaza(SET)
    >>> r, d = data.ranges_on_epochs(), data.true_ranges()
    >>> r, d = r[np.isfinite(r)], d[np.isfinite(r)]
    >>> s = r @ d / (d @ d)
    >>> check_residual_std((r - d).std()).correct  # without the scale
    False
    >>> check_residual_std((r - s * d).std()).correct
    True
    """
    v = scale_variants()
    mistakes = {
        v["std_unscaled"]: "That is the spread of r − d, without the scale: the 7 % scale adds a part that grows with "
                           "the distance. Take r − s d with your s.",
        v["rms_unscaled"]: "That is the RMS of r − d, without the scale. Take the standard deviation of r − s d.",
        v["std_affine"]: "That is the spread after a straight line with an offset; use the scale through the origin "
                         "of part (a).",
        v["variance"]: "That is the variance (m²); the task asks for the standard deviation (m).",
    }
    return check_number(answer, v["std"], rtol=2e-3, name="the residual standard deviation", units="m",
                        common_mistakes=mistakes, hint="residual = r - s * d; residual.std().",
                        explanation="That is the σ_r a filter should be given once the scale is in its model.")


# -- exercise 11.2: the heading drift ----------------------------------------------------------------------------------
@lru_cache(maxsize=1)
def _drift_variants() -> tuple[tuple[str, float], ...]:
    data = _data()
    dr = data.dead_reckoning()
    t = data.times
    drift = np.unwrap(dr[:, 2]) - np.unwrap(data.truth[:, 2])
    wrapped = (dr[:, 2] - data.truth[:, 2] + np.pi) % (2 * np.pi) - np.pi
    rate = float(np.polyfit(t, np.degrees(drift), 1)[0])
    return (("rate", rate), ("radians", float(np.polyfit(t, drift, 1)[0])),
            ("endpoints", float(np.degrees(drift[-1] - drift[0]) / (t[-1] - t[0]))),
            ("wrapped", float(np.polyfit(t, np.degrees(wrapped), 1)[0])),
            ("no_unwrap", float(np.polyfit(t, np.degrees(dr[:, 2] - data.truth[:, 2]), 1)[0])),
            ("per_minute", 60.0 * rate), ("total", float(np.degrees(drift[-1] - drift[0]))))


def drift_variants() -> dict[str, float]:
    r"""The right answer of exercise 11.2 and the values its usual mistakes give.

    Returns
    -------
    dict of str to float
        ``"rate"``: the slope [deg/s] of the least-squares line through the unwrapped difference of the odometry's
        heading and the truth's against time; ``"radians"``: in rad/s; ``"endpoints"``: the total drift over the
        duration; ``"wrapped"``: the slope of the difference wrapped to :math:`[-\pi, \pi)`; ``"no_unwrap"``: of the
        raw difference; ``"per_minute"``; ``"total"``: the drift at the end [deg].

    Examples
    --------
    >>> import pytest
    >>> # the Plaza data come with the gtsam wheel
    >>> _ = pytest.importorskip("gtsam")
    >>> v = drift_variants()
    >>> round(v["per_minute"] / v["rate"], 9)
    60.0
    >>> round(float(v["radians"] / np.radians(v["rate"])), 9)
    1.0
    """
    return dict(_drift_variants())


def check_drift_rate(answer: Any) -> Feedback:
    """Check the heading drift rate of Plaza 2's odometry in degrees per second (exercise 11.2).

    Examples
    --------
    >>> import pytest
    >>> _ = pytest.importorskip("gtsam")
    >>> from uwtutor.exercises import ch11
    >>> bool(ch11.check_drift_rate(ch11.drift_variants()["rate"]))
    True
    """
    v = drift_variants()
    mistakes = {
        v["radians"]: "That is in rad/s; the task asks for degrees per second (np.degrees).",
        v["no_unwrap"]: "The headings are wrapped to ±π: their raw difference jumps by 2π whenever one of them "
                        "crosses ±π. Unwrap each heading (np.unwrap) before differencing.",
        v["per_minute"]: "That is per minute; the task asks for degrees per second.",
        v["total"]: "That is the drift at the end of the run; the rate is the slope of the drift against time.",
    }
    return check_number(answer, v["rate"], rtol=2e-3, name="the drift rate", units="deg/s", common_mistakes=mistakes,
                        hint="drift = np.unwrap(dr[:, 2]) - np.unwrap(truth[:, 2]); "
                             "np.polyfit(times, np.degrees(drift), 1)[0].",
                        explanation=f"The end-to-end estimate, {v['endpoints']:.3f} deg/s, is close to the fitted "
                                    "slope (the line uses every epoch, the end-to-end only two): the drift is "
                                    "steady, the signature of a gyro bias.")


# -- exercise 11.3: the gain of the scale state ------------------------------------------------------------------------
def _grid_rmse(states: str, part: str = "filter", key: str = "rmse") -> float:
    from ..datasets.study import GRID_BEACONS, GRID_PERIODS, GRID_STATES, load_real_data_study

    m = load_real_data_study().grid["measures"][f"{part}_{key}"]
    return float(m[GRID_BEACONS.index(GAIN_BEACONS), GRID_PERIODS.index(None), GRID_STATES.index(states)])


def check_scale_gain(answer: Any) -> Feedback:
    r"""Check the gain of the scale state, :math:`\mathrm{RMSE}` of ``navigate(data, gyro_bias=True, scale=False)``
    over that of ``navigate(data, gyro_bias=True, scale=True)`` on Plaza 2 with all four beacons at the logged rate
    (exercise 11.3).

    The reference is the committed study's grid (:func:`uwtutor.datasets.study.load_real_data_study`), the same
    runs.

    Examples
    --------
    >>> from uwtutor.datasets.study import (
    ...     GRID_BEACONS, GRID_PERIODS, GRID_STATES, load_real_data_study)
    >>> rmse = load_real_data_study().grid["measures"]["filter_rmse"]
    >>> cell = rmse[GRID_BEACONS.index(GAIN_BEACONS), GRID_PERIODS.index(None)]
    >>> without = cell[GRID_STATES.index("+ gyro bias")]
    >>> with_scale = cell[GRID_STATES.index("+ scale and gyro bias")]
    >>> check_scale_gain(with_scale / without).correct  # the ratio upside down
    False
    >>> check_scale_gain(without / with_scale).correct
    True
    """
    without = _grid_rmse("+ gyro bias")
    with_both = _grid_rmse("+ scale and gyro bias")
    mistakes = {
        with_both / without: "That is the RMSE with the scale state over the RMSE without it; the gain is without over "
                             "with (> 1 when the state helps).",
        _grid_rmse("+ gyro bias", "smoother") / _grid_rmse("+ scale and gyro bias", "smoother"):
            "Those are the smoother's RMSEs (smooth=True); the task asks for the filter's.",
        _grid_rmse("+ gyro bias", key="median") / _grid_rmse("+ scale and gyro bias", key="median"):
            "That is the ratio of the medians; the task asks for the ratio of the RMSEs.",
        _grid_rmse("pose only") / _grid_rmse("+ scale"):
            "That is the scale state's gain without the gyro bias state (pose only against pose and scale); the task "
            "keeps the gyro bias in both runs.",
        without - with_both: "That is the difference of the RMSEs (in metres); the gain is their ratio.",
    }
    return check_number(answer, without / with_both, rtol=2e-3, name="the gain of the scale state",
                        common_mistakes=mistakes,
                        hint="rmse(navigate(data, gyro_bias=True, scale=False).x) / "
                             "rmse(navigate(data, gyro_bias=True, scale=True).x), both with all four beacons and "
                             "every range.",
                        explanation="Without the scale state the 7 % scale is explained away by the other states: "
                                    "the gyro bias learns a false drift.")


# -- exercise 11.4: a gate that locks out ------------------------------------------------------------------------------
@lru_cache(maxsize=1)
def _lockout() -> dict[str, Any]:
    from ..datasets import navigation_models
    from ..datasets.study import error_summary
    from ..filters import ChiSquareGate, ReacquiringGate, extended_kalman_filter

    data = _data()
    m = navigation_models(data, [LOCKOUT_BEACON], scale_prior=TIGHT_SCALE_PRIOR)
    args = (m.motion, m.measurement, m.x0, m.P0, data.odometry, m.z)
    locked = extended_kalman_filter(*args, times=data.times, gate=ChiSquareGate(STRICT_PROBABILITY,
                                                                                   per_component=True))
    back = extended_kalman_filter(*args, times=data.times,
                                  gate=ReacquiringGate(ChiSquareGate(STRICT_PROBABILITY, per_component=True),
                                                       patience=PATIENCE))
    present = np.isfinite(m.z)
    accepted = np.asarray(locked.extras["accepted"]).reshape(present.shape)
    accepted_back = np.asarray(back.extras["accepted"]).reshape(present.shape)
    return {"rejected": int(np.sum(present & ~accepted)), "accepted": int(np.sum(present & accepted)),
            "not_accepted": int(np.sum(~accepted)), "ranges": int(present.sum()),
            "rejected_back": int(np.sum(present & ~accepted_back)),
            "locked": error_summary(locked.x, data.truth), "back": error_summary(back.x, data.truth)}


def lockout_runs() -> dict[str, Any]:
    """Exercise 11.4's runs: the strict gate's counts (``rejected``, ``accepted``, ``not_accepted`` epochs,
    ``ranges``, ``rejected_back`` with re-acquisition) and the error summaries ``locked`` and ``back``.

    Examples
    --------
    >>> import pytest
    >>> # the Plaza data come with the gtsam wheel
    >>> _ = pytest.importorskip("gtsam")
    >>> # two filters on Plaza 2: about two seconds, once per session
    >>> r = lockout_runs()
    >>> r["rejected"] + r["accepted"] == r["ranges"]
    True
    >>> bool(r["back"]["rmse"] < r["locked"]["rmse"])  # re-acquisition helps
    True
    """
    return _lockout()


def check_rejected(answer: Any) -> Feedback:
    """Check the number of ranges the strict chi-square gate rejects from the filter too sure of its scale
    (exercise 11.4 a).

    Examples
    --------
    >>> import pytest
    >>> # the Plaza data come with the gtsam wheel
    >>> _ = pytest.importorskip("gtsam")
    >>> r = lockout_runs()
    >>> check_rejected(r["accepted"]).correct  # the ranges accepted, not rejected
    False
    >>> check_rejected(r["ranges"] - r["accepted"]).correct
    True
    """
    r = lockout_runs()
    mistakes = {
        r["not_accepted"]: "That counts every epoch whose range was not used, the epochs without any range included "
                           "(extras['accepted'] is False there too). Count where a range was present: "
                           "np.isfinite(z) & ~accepted.",
        r["accepted"]: "That is the number of ranges the gate accepted; the task asks how many it rejected.",
        r["rejected_back"]: "That is the count with re-acquisition (part b); part (a) runs the ChiSquareGate alone.",
    }
    return check_number(answer, r["rejected"], rtol=0.0, atol=0.5, name="the number of rejected ranges",
                        common_mistakes=mistakes,
                        hint="rejected = np.isfinite(models.z) & ~result.extras['accepted'].reshape(models.z.shape); "
                             "rejected.sum().",
                        explanation=f"{r['rejected']} of the {r['ranges']} ranges: the filter believes its scale "
                                    "within 0.2 %, so every range 7 % long looks like an outlier, and it never learns "
                                    "otherwise. That is a lock-out.")


def check_locked_rmse(answer: Any) -> Feedback:
    """Check the RMS position error of the locked-out filter (exercise 11.4 a).

    Examples
    --------
    >>> import pytest
    >>> # the Plaza data come with the gtsam wheel
    >>> _ = pytest.importorskip("gtsam")
    >>> r = lockout_runs()
    >>> check_locked_rmse(r["locked"]["median"]).correct  # the median error
    False
    >>> check_locked_rmse(r["locked"]["rmse"]).correct
    True
    """
    r = lockout_runs()
    mistakes = {r["locked"]["median"]: "That is the median error; the task asks for the RMSE.",
                r["back"]["rmse"]: "That is the RMSE with re-acquisition (part b).",
                r["locked"]["final"]: "That is the final error; the task asks for the RMSE over every epoch."}
    return check_number(answer, r["locked"]["rmse"], rtol=2e-3, name="the RMSE of the locked-out filter", units="m",
                        common_mistakes=mistakes,
                        hint="np.sqrt(np.mean(np.sum((result.x[:, :2] - truth[:, :2]) ** 2, axis=1))).")


def check_reacquired_rmse(answer: Any) -> Feedback:
    """Check the RMS position error with re-acquisition (exercise 11.4 b).

    Examples
    --------
    >>> import pytest
    >>> # the Plaza data come with the gtsam wheel
    >>> _ = pytest.importorskip("gtsam")
    >>> r = lockout_runs()
    >>> # without re-acquisition
    >>> check_reacquired_rmse(r["locked"]["rmse"]).correct
    False
    >>> check_reacquired_rmse(r["back"]["rmse"]).correct
    True
    """
    r = lockout_runs()
    mistakes = {r["back"]["median"]: "That is the median error; the task asks for the RMSE.",
                r["locked"]["rmse"]: "That is the RMSE without re-acquisition (part a): wrap the ChiSquareGate in a "
                                     f"ReacquiringGate(..., patience={PATIENCE}).",
                r["back"]["final"]: "That is the final error; the task asks for the RMSE over every epoch."}
    return check_number(answer, r["back"]["rmse"], rtol=2e-3, name="the RMSE with re-acquisition", units="m",
                        common_mistakes=mistakes,
                        hint=f"gate = ReacquiringGate(ChiSquareGate({STRICT_PROBABILITY}, per_component=True), "
                             f"patience={PATIENCE}); the same models and inputs as part (a).",
                        explanation=f"From {r['locked']['rmse']:.0f} m to {r['back']['rmse']:.1f} m: after "
                                    f"{PATIENCE} rejected epochs in a row the covariance is inflated, the scale is "
                                    "free to move, and the next range is used.")
