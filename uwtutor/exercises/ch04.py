"""Checkers for the exercises of chapter 4, "The range-only EKF".

Each checker computes the expected value from the exercise's data (the constants below) with the library and
returns a ``Feedback`` that recognises the usual mistakes of that exercise:

===============================================  =======================================================================
checker                                          exercise
===============================================  =======================================================================
``check_range_jacobian(H)``                      the range Jacobian at a predicted position
``check_ekf_update(ekf_update)``                 one EKF update with one range, as a function (against ``RangeOnlyEKF``)
``check_nees(value)``                            the NEES of one estimate
``check_nees_bounds(bounds)``                    the 95 % chi-square interval of a mean NEES over 50 runs
``check_diagnosis(consistent, overconfident)``   which of three tuned filters is consistent, which overconfident
``check_ekf_run(ekf_run)``                       a whole EKF run over a range sequence (against ``range_only_ekf``)
===============================================  =======================================================================

The exercises themselves are in the repository's ``exercises/ch04_range_only_ekf.ipynb``.

References
----------
Bar-Shalom, Li and Kirubarajan (2001), sec. 5.4 (NEES and its chi-square test) and 10.3 (EKF).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from scipy import stats

from .._validate import as_int, as_seed, check_work
from .. import motion
from ..filters import RangeOnlyEKF, range_only_ekf
from .checks import (Case, _answer_shape, _check_nees_letters, _row_as_vector, check_array, check_function,
                     check_number)
from .feedback import Feedback

__all__ = [
    "check_range_jacobian",
    "check_ekf_update",
    "check_nees",
    "check_nees_bounds",
    "check_diagnosis",
    "check_ekf_run",
    "JACOBIAN_BEACON",
    "JACOBIAN_POSITION",
    "NEES_TRUTH",
    "NEES_ESTIMATE",
    "NEES_COVARIANCE",
    "BOUNDS_RUNS",
    "BOUNDS_STATES",
    "BOUNDS_CONFIDENCE",
    "DIAGNOSIS_FILTERS",
    "diagnosis_studies",
    "ekf_update_reference",
    "ekf_run_reference",
    "run_data",
    "RUN_SEED",
]

# -- the data of the exercises -----------------------------------------------------------------------------------------
#: Exercise 4.1: the beacon (m) ...
JACOBIAN_BEACON = (200.0, 100.0)
#: ... and the predicted position (m) where the Jacobian is evaluated.
JACOBIAN_POSITION = (500.0, -300.0)
#: Exercise 4.3: the true position (m), ...
NEES_TRUTH = (100.0, -200.0)
#: ... the estimate (m) ...
NEES_ESTIMATE = (105.0, -196.0)
#: ... and its covariance (m²).
NEES_COVARIANCE = ((16.0, 6.0), (6.0, 9.0))
#: Exercise 4.4: number of Monte Carlo runs, state dimension and two-sided confidence of the interval.
BOUNDS_RUNS = 50
BOUNDS_STATES = 2
BOUNDS_CONFIDENCE = 0.95
#: Exercise 4.5: the three filters' tuning (multiples of the true Q and R), keyed by the letter the notebook uses.
DIAGNOSIS_FILTERS = {"A": {"q_scale": 5.0, "r_scale": 25.0}, "B": {"q_scale": 0.02, "r_scale": 1.0},
                     "C": {"q_scale": 1.0, "r_scale": 1.0}}


# -- exercise 4.1: the Jacobian --------------------------------------------------------------------------------------
def check_range_jacobian(answer: Any) -> Feedback:
    r"""Check the range Jacobian :math:`H = (\hat x^- - b)^\mathsf{T} / \lVert \hat x^- - b\rVert` of exercise 4.1.

    Parameters
    ----------
    answer : array_like, shape (2,), or None
        The student's :math:`H` (as a 1-D array ``[dr/dx, dr/dy]``; a (1, 2) row is accepted too).

    Returns
    -------
    Feedback
        The verdict; the reversed direction (beacon minus position), the unnormalized difference, the gradient
        of the squared range, the position used without subtracting the beacon and swapped components are
        recognised.

    Examples
    --------
    >>> b, p = np.array(JACOBIAN_BEACON), np.array(JACOBIAN_POSITION)
    >>> check_range_jacobian(p - b).correct  # not divided by the range
    False
    >>> check_range_jacobian((p - b) / np.linalg.norm(p - b)).correct
    True
    """
    b = np.array(JACOBIAN_BEACON)
    p = np.array(JACOBIAN_POSITION)
    d = p - b
    expected = d / np.linalg.norm(d)
    answer = _row_as_vector(answer, 2)
    mistakes = [
        (-expected, "The range grows when the vehicle moves away from the beacon: H points from the beacon to the "
                    "vehicle, (x − b)/‖x − b‖."),
        (d, "Divide by the range: H is a unit vector (its length is 1)."),
        (2 * d, "That is the gradient of the squared range, 2(x − b); the range's gradient is (x − b)/‖x − b‖."),
        (p / np.linalg.norm(p), "Subtract the beacon's position first: the beacon is not at the origin here."),
        (expected[::-1], "The first component is ∂r/∂x = (x − b_x)/r, the second ∂r/∂y = (y − b_y)/r."),
    ]
    return check_array(answer, expected, rtol=1e-6, atol=1e-9, name="H", common_mistakes=mistakes,
                       hint="H = (x − b)/‖x − b‖ with x the predicted position and b the beacon.",
                       explanation="A unit vector along the line of sight: a range tells nothing across it.")


# -- exercise 4.2: one EKF update --------------------------------------------------------------------------------------
def ekf_update_reference(x: ArrayLike, P: ArrayLike, z: float, R: float,
                         beacon: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """The reference answer of exercise 4.2: ``RangeOnlyEKF``'s update with one range (no prediction).

    Parameters
    ----------
    x : array_like, shape (2,)
        Predicted position [m].
    P : array_like, shape (2, 2)
        Its covariance [m²].
    z : float
        Measured range [m].
    R : float
        Range noise variance [m²].
    beacon : array_like, shape (2,)
        Beacon position [m].

    Returns
    -------
    tuple of ndarray
        The updated position (2,) and covariance (2, 2).

    Examples
    --------
    >>> x, P = ekf_update_reference([300.0, 400.0], 100.0 * np.eye(2), z=505.0,
    ...                             R=4.0, beacon=[0.0, 0.0])
    >>> np.round(x, 2)  # pushed 4.81 m outwards, along the line of sight
    array([302.88, 403.85])
    >>> np.round(P, 2)
    array([[ 65.38, -46.15],
           [-46.15,  38.46]])
    """
    ekf = RangeOnlyEKF(x0=x, P0=P, Q=np.zeros((2, 2)), R=R, beacon=beacon)
    ekf.update(z)
    return np.array(ekf.x), np.array(ekf.P)


def _update_cases() -> list[Case]:
    P = np.array([[400.0, 50.0], [50.0, 100.0]])
    return [
        Case((np.array([300.0, 400.0]), P, 505.0, 4.0, np.array([0.0, 0.0])),
             label="beacon at the origin, range 5 m longer than predicted",
             hint="The innovation is z − h(x) (measured minus predicted): a range longer than predicted pushes "
                  "the estimate away from the beacon."),
        Case((np.array([300.0, 400.0]), P, 480.0, 4.0, np.array([-100.0, 50.0])),
             label="a beacon away from the origin",
             hint="Both h(x) = ‖x − b‖ and H = (x − b)ᵀ/‖x − b‖ use the beacon's position."),
        Case((np.array([-1200.0, 900.0]), np.diag([2500.0, 2500.0]), 1480.0, 0.49, np.array([0.0, 0.0])),
             label="a large prior uncertainty, a precise range",
             hint="S = H P Hᵀ + R, K = P Hᵀ / S, x⁺ = x + K (z − h(x)), P⁺ = (I − K H) P."),
        Case((np.array([10.0, -20.0]), P, 25.0, 9.0, np.array([0.0, 0.0])),
             label="close to the beacon",
             hint="Keep P symmetric: (I − K H) P is, in exact arithmetic; the Joseph form "
                  "(I − KH) P (I − KH)ᵀ + K R Kᵀ is, in floating point too."),
    ]


def _ekf_update_slip(*, no_s: bool = False, flipped: bool = False, no_beacon: bool = False,
                     unnormalized: bool = False, r_std: bool = False) -> Any:
    """An ``ekf_update`` written with one typical slip, for ``check_function``'s ``mistakes``."""

    def update(x: Any, P: Any, z: float, R: float, beacon: Any) -> tuple[np.ndarray, np.ndarray]:
        x, P = np.asarray(x, dtype=float), np.asarray(P, dtype=float)
        b = np.zeros(2) if no_beacon else np.asarray(beacon, dtype=float)
        predicted = float(np.linalg.norm(x - b))
        H = (x - b) if unnormalized else (x - b) / predicted
        S = H @ P @ H + (np.sqrt(R) if r_std else R)
        K = P @ H if no_s else P @ H / S
        innovation = predicted - z if flipped else z - predicted
        return x + K * innovation, (np.eye(2) - np.outer(K, H)) @ P

    return update


#: Exercise 4.2's typical slips, each with the hint that names it (``check_function`` recognises them).
_EKF_UPDATE_SLIPS = (
    (_ekf_update_slip(no_s=True),
     "Your gain lacks the division by the innovation variance: K = P Hᵀ / S with S = H P Hᵀ + R (a scalar for one "
     "range). Without it the correction has the units of P and ignores how noisy the range is."),
    (_ekf_update_slip(flipped=True),
     "The innovation is z − h(x) (measured minus predicted): a range longer than predicted pushes the estimate "
     "away from the beacon, not towards it."),
    (_ekf_update_slip(no_beacon=True),
     "Both h(x) = ‖x − b‖ and H = (x − b)ᵀ/‖x − b‖ use the beacon's position b; yours assumes it is at the origin."),
    (_ekf_update_slip(unnormalized=True),
     "H is the unit vector (x − b)ᵀ/‖x − b‖ (the derivative of a distance), not x − b itself."),
    (_ekf_update_slip(r_std=True),
     "R is the range noise *variance* (m²): S = H P Hᵀ + R, not + √R."),
)


def _compare_update(got: Any, expected: tuple[np.ndarray, np.ndarray]) -> Feedback:
    if not isinstance(got, (tuple, list)) or len(got) != 2:
        return Feedback(False, "Not yet: the function should return two things, `x_new, P_new`.",
                        hint="End it with `return x_new, P_new`.")
    x_new, P_new = got
    if _answer_shape(x_new) in ((2, 1), (1, 2)):          # read by the shared parser: a ragged list is explained
        x_new = np.ravel(np.asarray(x_new, dtype=float))
    fb = check_array(x_new, expected[0], rtol=1e-9, atol=1e-9, name="the updated position", units="m")
    if not fb:
        return fb
    fb = check_array(P_new, expected[1], rtol=1e-8, atol=1e-9, name="the updated covariance", units="m²",
                     common_mistakes=[])
    if fb or _answer_shape(P_new) != expected[1].shape:
        return fb
    # The position is right, so the innovation and the gain are: only the covariance step is wrong.
    P_arr = np.asarray(P_new, dtype=float)
    excess = P_arr - expected[1]
    if not np.allclose(P_arr, P_arr.T, rtol=1e-8, atol=1e-9):
        hint = ("Your position is right but your covariance is not symmetric: use P⁺ = (I − K H) P with H as a "
                "(1, 2) row and K as a (2, 1) column (an outer product), or the Joseph form.")
    elif np.trace(excess) > 0 and np.all(np.linalg.eigvalsh((excess + excess.T) / 2) > -1e-9 * np.trace(P_arr)):
        hint = ("Your position is right, so the innovation and the gain are; but your covariance is larger than the "
                "updated one. Did you return the prior P unchanged? A range shrinks the uncertainty along the line "
                "of sight: P⁺ = (I − K H) P.")
    else:
        hint = ("Your position is right, so the innovation and the gain are; the covariance step is off: "
                "P⁺ = (I − K H) P, with K H the (2, 2) outer product of the (2, 1) gain and the (1, 2) Jacobian.")
    return Feedback(False, fb.message, hint=hint, details={**fb.details, "diagnosed": True})


def check_ekf_update(func: Any) -> Feedback:
    r"""Check a student's ``ekf_update(x, P, z, R, beacon)`` returning the updated ``x, P``.

    It must equal ``RangeOnlyEKF.update`` (Joseph form or the simple form :math:`(I - KH)P`, which agree to
    rounding) on four cases.

    Parameters
    ----------
    func : callable or None
        The student's function.

    Returns
    -------
    Feedback
        The verdict, with the failing case and a hint.

    Examples
    --------
    >>> def no_update(x, P, z, R, beacon):
    ...     return np.asarray(x, dtype=float), np.asarray(P, dtype=float)
    >>> check_ekf_update(no_update).correct
    False
    >>> check_ekf_update(ekf_update_reference).correct
    True
    """
    return check_function(func, ekf_update_reference, _update_cases(), name="ekf_update",
                          compare=_compare_update, mistakes=_EKF_UPDATE_SLIPS,
                          hint="h(x) = ‖x − b‖, H = (x − b)ᵀ/h(x), S = H P Hᵀ + R, K = P Hᵀ/S, "
                               "x⁺ = x + K (z − h(x)), P⁺ = (I − K H) P.",
                          explanation="This is the update that filterpy's ExtendedKalmanFilter and "
                                      "uwtutor's RangeOnlyEKF run at every range.")


# -- exercise 4.3: NEES ----------------------------------------------------------------------------------------------
def check_nees(answer: Any) -> Feedback:
    r"""Check the NEES :math:`e^\mathsf{T} P^{-1} e` of exercise 4.3, :math:`e = x - \hat x`.

    Parameters
    ----------
    answer : float or None
        The student's NEES.

    Returns
    -------
    Feedback
        The verdict; :math:`e^\mathsf{T} P e`, :math:`\lVert e\rVert^2`, the square root, the diagonal of
        :math:`P` alone (correlation ignored) and the sum of squared standardized components are recognised.

    Examples
    --------
    >>> e = np.array(NEES_TRUTH) - np.array(NEES_ESTIMATE)
    >>> P = np.array(NEES_COVARIANCE)
    >>> check_nees(e @ P @ e).correct  # P instead of its inverse
    False
    >>> check_nees(e @ np.linalg.solve(P, e)).correct
    True
    """
    e = np.array(NEES_TRUTH) - np.array(NEES_ESTIMATE)
    P = np.array(NEES_COVARIANCE)
    expected = float(e @ np.linalg.solve(P, e))
    mistakes = {
        float(e @ P @ e): "That is eᵀ P e; the NEES weights the error with the *inverse* covariance, eᵀ P⁻¹ e.",
        float(e @ e): "That is ‖e‖², in m²; the NEES divides by the covariance and has no units.",
        float(np.sqrt(expected)): "That is the square root (a Mahalanobis distance); the NEES is its square.",
        float(np.sum(e**2 / np.diag(P))): "Dividing each component by its own variance ignores the correlation: "
                                          "use the full inverse, np.linalg.inv(P) or np.linalg.solve(P, e).",
    }
    # rtol 3e-3: a NEES rounded to three significant digits (2.23) passes; every recognised slip is far off
    return check_number(answer, expected, rtol=3e-3, name="the NEES", common_mistakes=mistakes,
                        hint="e = truth − estimate, NEES = e @ np.linalg.solve(P, e).",
                        explanation="For a consistent filter it follows a chi-square distribution with 2 degrees of "
                                    "freedom: mean 2.")


# -- exercise 4.4: chi-square bounds ---------------------------------------------------------------------------------
def check_nees_bounds(answer: Any) -> Feedback:
    r"""Check the two-sided 95 % acceptance interval of the mean NEES over 50 runs of a 2-state filter.

    :math:`M \bar\epsilon \sim \chi^2_{Mn}`, so the interval is
    :math:`[\chi^2_{Mn}(0.025), \chi^2_{Mn}(0.975)]/M`.

    Parameters
    ----------
    answer : array_like, shape (2,), or None
        The student's ``[lower, upper]``.

    Returns
    -------
    Feedback
        The verdict; the bounds of a single run (n degrees of freedom), bounds not divided by M, M instead of M·n
        degrees of freedom, one-sided quantiles and the normal approximation are recognised.

    Examples
    --------
    >>> from scipy import stats
    >>> M, n = BOUNDS_RUNS, BOUNDS_STATES
    >>> # one run's bounds
    >>> check_nees_bounds(stats.chi2.ppf([0.025, 0.975], n)).correct
    False
    >>> check_nees_bounds(stats.chi2.ppf([0.025, 0.975], M * n) / M).correct
    True
    """
    M, n, conf = BOUNDS_RUNS, BOUNDS_STATES, BOUNDS_CONFIDENCE
    tail = (1.0 - conf) / 2.0
    expected = stats.chi2.ppf([tail, 1.0 - tail], M * n) / M
    mistakes = [
        (stats.chi2.ppf([tail, 1.0 - tail], n), "Those are the bounds of one run's NEES (n degrees of freedom); the "
                                                "mean over M runs has M·n degrees of freedom, divided by M."),
        (stats.chi2.ppf([tail, 1.0 - tail], M * n), "Divide by M: the bounds are for the *mean* NEES, "
                                                    "χ²_{Mn}(q)/M."),
        (stats.chi2.ppf([1.0 - conf, conf], M * n) / M, "A two-sided 95 % interval leaves 2.5 % in each tail: "
                                                        "quantiles 0.025 and 0.975."),
        (stats.chi2.ppf([tail, 1.0 - tail], M) / M, "Those are χ²_M quantiles: M degrees of freedom counts one per "
                                                    "run, but each run's NEES has n = 2 (one per state), so the "
                                                    "sum over M runs has M·n."),
        (stats.chi2.ppf([tail, 1.0 - tail], M), "Those are χ²_M quantiles, not divided by M: the sum of M runs' "
                                                "NEES has M·n degrees of freedom (n per run), and the mean is "
                                                "that sum divided by M."),
        (n + np.array([-1.96, 1.96]) * np.sqrt(2 * n / M), "That is the normal approximation; use the chi-square "
                                                           "quantiles (scipy.stats.chi2.ppf)."),
    ]
    # rtol 4e-3: bounds rounded to three significant digits ([1.48, 2.59]) pass; the nearest slip, the normal
    # approximation, is 1.4 % off
    return check_array(answer, expected, rtol=4e-3, name="the interval", common_mistakes=mistakes,
                       hint="Use scipy.stats.chi2.ppf([0.025, 0.975], M * n) / M.",
                       explanation="A consistent filter's mean NEES stays inside it at about 95 % of the epochs.")


# -- exercise 4.5: diagnosis ------------------------------------------------------------------------------------------
def diagnosis_studies(n_runs: int = 50, seed: int = 4) -> dict[str, Any]:
    r"""The three Monte Carlo studies of exercise 4.5, keyed by letter.

    Each runs the range-only EKF over the same ``n_runs`` draws of paper D's approach (DR noise variance 0.81 m²,
    white range noise variance 0.49 m², a 30 m initial error per axis) with the ``q_scale`` and ``r_scale`` of
    ``DIAGNOSIS_FILTERS`` on its assumed :math:`\mathbf Q` and :math:`R` (chapter 4's widget, at those settings).

    Parameters
    ----------
    n_runs : int, default 50
        Monte Carlo runs per filter (>= 2).
    seed : int, default 4
        Seed (the same draws for the three filters), a non-negative integer.

    Returns
    -------
    dict
        ``{"A": MonteCarloResult, "B": ..., "C": ...}`` (:func:`uwtutor.montecarlo.run_monte_carlo`).

    Examples
    --------
    >>> studies = diagnosis_studies(n_runs=20)
    >>> sorted(studies)
    ['A', 'B', 'C']
    >>> len(studies["A"].mean_nees) == len(studies["B"].mean_nees)
    True
    """
    from .. import scenarios
    from ..filters import range_only_ekf
    from ..montecarlo import run_monte_carlo

    n_runs = as_int("n_runs", n_runs, minimum=2)                 # a NEES mean and its interval need two runs
    check_work("n_runs", 10 * n_runs * 151, "floats (n_runs x the approach's 151 epochs x 10)")
    seed = as_seed("seed", seed)
    dr_variance, range_variance, initial_error = 0.81, 0.49, 30.0
    studies = {}
    for letter, tuning in DIAGNOSIS_FILTERS.items():
        rng = np.random.default_rng(seed)
        runs = scenarios.approach_with_turn_scenario(rng, n_runs=n_runs, assumed_speed=1500.0, speed_sigma=0.0,
                                                     noise_sigma=np.sqrt(range_variance),
                                                     dr_sigma=np.sqrt(dr_variance))
        truth = np.array(runs.true_positions[0])
        start = truth[0] + initial_error * rng.standard_normal((n_runs, 2))
        studies[letter] = run_monte_carlo(range_only_ekf, truth, x0=start, P0=np.eye(2) * initial_error**2,
                                          u=runs.dr_displacements, z=np.maximum(runs.ranges, 0.0),
                                          Q=np.eye(2) * tuning["q_scale"] * dr_variance,
                                          R=tuning["r_scale"] * range_variance, times=runs.times)
    return studies


def _classify(studies: dict[str, Any]) -> tuple[str, str, str]:
    mean = {k: float(np.nanmean(v.mean_nees)) for k, v in studies.items()}
    lo, hi = next(iter(studies.values())).nees_bounds
    consistent = max(studies, key=lambda k: studies[k].nees_fraction_within())
    overconfident = max(mean, key=lambda k: mean[k])
    underconfident = min(mean, key=lambda k: mean[k])
    if not (mean[overconfident] > hi and mean[underconfident] < lo):
        raise RuntimeError("the exercise's filters are not clearly over- and underconfident: retune them")
    return consistent, overconfident, underconfident


def check_diagnosis(consistent: Any, overconfident: Any) -> Feedback:
    """Check which filter of exercise 4.5 is consistent and which is overconfident (letters ``"A"``, ``"B"``, ``"C"``).

    The checker reruns the three studies (``diagnosis_studies``) and classifies them by their mean NEES against
    the 95 % interval: the consistent one stays inside, the overconfident one (its P too small) lies far above, the
    underconfident one below.

    Parameters
    ----------
    consistent : str or None
        The letter of the consistent filter.
    overconfident : str or None
        The letter of the overconfident filter.

    Returns
    -------
    Feedback
        The verdict, with a hint on how to read a NEES curve.

    Examples
    --------
    >>> studies = diagnosis_studies()
    >>> mean = {k: float(np.nanmean(s.mean_nees)) for k, s in studies.items()}
    >>> consistent = max(studies, key=lambda k: studies[k].nees_fraction_within())
    >>> overconfident = max(mean, key=mean.get)
    >>> check_diagnosis(overconfident, consistent).correct
    False
    >>> check_diagnosis(consistent, overconfident).correct
    True
    >>> check_diagnosis("A", "A").correct  # one filter cannot be both
    False
    """
    def correct(c: str, o: str, u: str) -> str:
        over, under = DIAGNOSIS_FILTERS[o], DIAGNOSIS_FILTERS[u]
        return (f"Correct: {c} is consistent and {o} overconfident (its Q is {over['q_scale']:g} times the true DR "
                f"noise); {u} is underconfident (its Q and R are {under['q_scale']:g} and {under['r_scale']:g} "
                "times the true ones).")

    return _check_nees_letters(
        consistent, overconfident, sorted(DIAGNOSIS_FILTERS), lambda: _classify(diagnosis_studies()),
        read="A consistent filter's mean NEES stays inside the green band (about 2 for a 2-state filter); far above "
             "it the filter claims a smaller P than its real errors (overconfident); below, a larger one "
             "(underconfident).",
        correct=correct, underconfident=" (its P is larger than its errors)")


# -- exercise 4.6: a whole EKF run -------------------------------------------------------------------------------------
#: Exercise 4.6: the seed of the run the notebook gives (``run_data()``) and of the checker's other cases.
RUN_SEED = 46


def run_data() -> dict[str, Any]:
    """The data of exercise 4.6: a vehicle that runs at 2 m/s and turns left by 60° after 300 s, ranging every 10 s
    (60 epochs, the beacon at the origin, the DR and range noise drawn with ``RUN_SEED``).

    Returns
    -------
    dict
        ``x0`` (2,) a start 40 m off, ``P0`` (2, 2), ``u`` (n, 2) the DR displacements (noisy; the first zero),
        ``z`` (n,) the ranges (noisy, NaN where missing), ``Q`` (2, 2), ``R`` (float), ``beacon`` (2,) and
        ``truth`` (n, 2).

    Examples
    --------
    >>> d = run_data()
    >>> d["z"].shape, d["u"].shape, d["truth"].shape
    ((60,), (60, 2), (60, 2))
    """
    return _run_data(RUN_SEED)


def _run_data(seed: int, n: int = 60, beacon: Any = (0.0, 0.0), missing: Any = ()) -> dict[str, Any]:
    """``run_data()`` with another seed, length, beacon, or epochs without a reply (the checker's other cases)."""
    rng = np.random.default_rng(seed)
    times = 10.0 * np.arange(n)
    track = motion.turning_track(times, start=(-900.0, 400.0), speed=2.0, headings=np.radians([0.0, 60.0]),
                                 turn_times=[300.0])
    truth = np.asarray(track.positions, dtype=float)
    b = np.asarray(beacon, dtype=float)
    q, sigma_r = 0.5, 1.5
    u = np.diff(truth, axis=0, prepend=truth[:1]) + np.vstack([np.zeros((1, 2)), rng.normal(0.0, q, (n - 1, 2))])
    z = np.linalg.norm(truth - b, axis=1) + rng.normal(0.0, sigma_r, n)
    z[np.asarray(missing, dtype=int)] = np.nan
    return {"x0": truth[0] + np.array([32.0, -24.0]), "P0": np.eye(2) * 40.0**2, "u": u, "z": z,
            "Q": np.eye(2) * q**2, "R": sigma_r**2, "beacon": b, "truth": truth}


def ekf_run_reference(x0: ArrayLike, P0: ArrayLike, u: ArrayLike, z: ArrayLike, Q: ArrayLike, R: float,
                      beacon: ArrayLike) -> np.ndarray:
    """The reference answer of exercise 4.6: ``range_only_ekf``'s estimates, one row per epoch.

    Parameters
    ----------
    x0 : array_like, shape (2,)
        Initial estimate [m].
    P0 : array_like, shape (2, 2)
        Its covariance [m²].
    u : array_like, shape (K, 2)
        DR displacements from epoch k − 1 to epoch k [m].
    z : array_like, shape (K,)
        Ranges [m], NaN where there was no reply (predict only).
    Q : array_like, shape (2, 2)
        Process noise covariance per step [m²].
    R : float
        Range noise variance [m²].
    beacon : array_like, shape (2,)
        Beacon position [m].

    Returns
    -------
    ndarray, shape (K, 2)
        The estimate after each epoch's update.

    Examples
    --------
    >>> d = run_data()
    >>> est = ekf_run_reference(d["x0"], d["P0"], d["u"], d["z"], d["Q"], d["R"], d["beacon"])
    >>> bool(np.linalg.norm(est[-1] - d["truth"][-1]) < 10.0)
    True
    """
    return np.array(range_only_ekf(x0, P0, u, z, Q, R, beacon=beacon).x)


def _run_cases() -> list[Case]:
    cases = []
    variants: tuple[tuple[str, dict[str, Any]], ...] = (
        ("the notebook's run", {}),
        ("a beacon away from the origin", {"seed": RUN_SEED + 1, "beacon": (150.0, -250.0)}),
        ("three epochs without a reply (NaN ranges)", {"seed": RUN_SEED + 2, "missing": (7, 8, 31)}))
    for label, kw in variants:
        d = _run_data(**{"seed": RUN_SEED, **kw})
        cases.append(Case((d["x0"], d["P0"], d["u"], d["z"], d["Q"], d["R"], d["beacon"]), label=label))
    return cases


def _ekf_run_slip(*, no_q: bool = False, reset_p: bool = False, update_first: bool = False,
                  priors: bool = False, no_u: bool = False) -> Any:
    """An ``ekf_run`` written with one typical slip, for ``check_function``'s ``mistakes``."""

    def run(x0: Any, P0: Any, u: Any, z: Any, Q: Any, R: float, beacon: Any) -> np.ndarray:
        x, P0_arr = np.array(x0, dtype=float), np.array(P0, dtype=float)
        P, u_arr, z_arr, Q_arr = P0_arr.copy(), np.asarray(u, float), np.asarray(z, float), np.asarray(Q, float)
        out = np.empty((len(z_arr), 2))
        right_update = _ekf_update_slip()                # exercise 4.2's update, without a slip

        def update(x: np.ndarray, P: np.ndarray, zk: float) -> tuple[np.ndarray, np.ndarray]:
            return (x, P) if np.isnan(zk) else right_update(x, P, zk, R, beacon)

        for k in range(len(z_arr)):
            if reset_p:
                P = P0_arr.copy()
            if update_first:
                x, P = update(x, P, z_arr[k])
            x = x if no_u else x + u_arr[k]
            P = P if no_q else P + Q_arr
            out[k] = x
            if not update_first and not priors:
                x, P = update(x, P, z_arr[k])
                out[k] = x
        return out

    return run


#: Exercise 4.6's typical slips, each with the hint that names it (``check_function`` recognises them).
_EKF_RUN_SLIPS = (
    (_ekf_run_slip(no_q=True),
     "The prediction adds the process noise: P ← P + Q. Without it P only shrinks, the gain goes to zero and the "
     "filter stops listening to the ranges while the DR drifts."),
    (_ekf_run_slip(reset_p=True),
     "Carry P from one epoch to the next: each update starts from the covariance the last one left (plus Q), not "
     "from P0 again."),
    (_ekf_run_slip(update_first=True),
     "Predict first, then update: range k was taken at epoch k, after the displacement u_k, so it must correct "
     "the *predicted* position x + u_k."),
    (_ekf_run_slip(priors=True),
     "Those are the predictions (before each update): store the estimate after the range of the epoch has "
     "corrected it."),
    (_ekf_run_slip(no_u=True),
     "The prediction moves the estimate by the dead-reckoned displacement: x ← x + u_k (u[0] is zero, so the "
     "first step is the start itself)."),
)


def check_ekf_run(func: Any) -> Feedback:
    r"""Check a student's ``ekf_run(x0, P0, u, z, Q, R, beacon)`` (exercise 4.6) against ``range_only_ekf``.

    At each epoch :math:`k`: predict :math:`\hat x \leftarrow \hat x + u_k`, :math:`P \leftarrow P + Q`; if
    :math:`z_k` is not NaN, update with it (exercise 4.2's update); store the estimate. Three runs: the notebook's,
    a beacon away from the origin, and one with three missing replies.

    Parameters
    ----------
    func : callable or None
        The student's function, returning the ``(K, 2)`` estimates.

    Returns
    -------
    Feedback
        The verdict, with the first failing case and a hint for a recognised slip (no Q, P reset to P0, update
        before predict, the predictions stored, the displacement left out).

    Examples
    --------
    >>> check_ekf_run(ekf_run_reference).correct
    True
    >>> def frozen(x0, P0, u, z, Q, R, beacon):  # never moves
    ...     return np.tile(np.asarray(x0, dtype=float), (len(z), 1))
    >>> check_ekf_run(frozen).correct
    False
    """
    return check_function(func, ekf_run_reference, _run_cases(), name="ekf_run", rtol=1e-7, atol=1e-6,
                          mistakes=_EKF_RUN_SLIPS,
                          hint="For each epoch: x ← x + u_k, P ← P + Q; then, if z_k is not NaN, the update of "
                               "exercise 4.2; store x in row k.",
                          explanation="range_only_ekf runs exactly this loop (for many runs at once, with the Joseph "
                                      "form); chapter 4's figures are its output.")
