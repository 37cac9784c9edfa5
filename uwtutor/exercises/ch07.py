"""Checkers for the exercises of chapter 7, "Tracking a slowly varying range bias".

Each checker computes the expected value from the exercise's data (the constants below) with the library and
returns a ``Feedback`` that recognises the usual mistakes of that exercise:

============================================  ========================================================================
checker                                       exercise
============================================  ========================================================================
``check_bias_noise(Q)``                       paper A's process noise with its rule for the bias
``check_augmented_jacobian(H)``               the Jacobian of the range plus bias at a predicted state
``check_weak_direction(v)``                   the direction of [x, y, bias] a short straight track hardly sees
``check_start_count(n)``                      how many ranges before the precision factor falls below a threshold
``check_bias_diagnosis(consistent, over)``    which of three bias filters is consistent, which overconfident
============================================  ========================================================================

The exercises themselves are in the repository's ``exercises/ch07_bias_tracking.ipynb``.

References
----------
Liu J., Han S., Xu J., Yang G. "An improved EKF positioning algorithm for underwater acoustic beacon" (paper A),
eqs. (1)-(2) and (10)-(11).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import lsq
from .._validate import as_int, as_scalar, as_seed, check_work
from ..filters import bias_ekf, extended_kalman_filter
from ..metrics import chi2_mean_bounds
from ..models import (BiasRateDeadReckoning, RangeToBeacon, bias_rate_process_noise, paper_a_process_noise)
from ..scenarios import paper_a
from .checks import (_answer_shape, _check_nees_letters, _row_as_vector, check_array, check_number, not_answered,
                     parse_real_array)
from .feedback import Feedback

__all__ = [
    "check_bias_noise",
    "check_augmented_jacobian",
    "check_weak_direction",
    "check_start_count",
    "check_bias_diagnosis",
    "NOISE_SIGMAS",
    "JACOBIAN_BEACON",
    "JACOBIAN_STATE",
    "straight_track",
    "START_RADIUS",
    "START_SPACING_DEG",
    "START_THRESHOLD",
    "DIAGNOSIS_FILTERS",
    "bias_diagnosis_studies",
]

# -- the data of the exercises -----------------------------------------------------------------------------------------
#: Exercise 7.1: DR error standard deviations per epoch along x and y [m].
NOISE_SIGMAS = (0.8, 0.6)
#: Exercise 7.2: the beacon [m] ...
JACOBIAN_BEACON = (100.0, -50.0)
#: ... and the predicted state [x, y, bias] [m].
JACOBIAN_STATE = (-700.0, 550.0, 12.0)
#: Exercise 7.4: a circle round the beacon at the origin (radius [m]), the bearing step between ranges [deg] and
#: the threshold on the precision factor.
START_RADIUS = 1500.0
START_SPACING_DEG = 0.4
START_THRESHOLD = 1.0
#: Exercise 7.5: the three bias filters run on a bias ramp of 0.03 m/s, keyed by the letter the notebook uses.
DIAGNOSIS_FILTERS = {
    "A": "paper A's random walk with its Q rule",
    "B": "a bias-rate state (BiasRateDeadReckoning)",
    "C": "paper A's random walk with a bias noise 20 times the rule's standard deviation",
}


def straight_track(n: int = 40) -> np.ndarray:
    """Exercise 7.3: ``n`` positions [m] every 10 m along a straight line about 2 km north-east of the beacon.

    The line runs across the line of sight, so the bearing from the beacon changes by about 11 degrees.

    Parameters
    ----------
    n : int, default 40
        Number of positions (>= 2).

    Returns
    -------
    ndarray, shape (n, 2)

    Examples
    --------
    >>> p = straight_track()
    >>> p.shape
    (40, 2)
    >>> round(float(np.linalg.norm(p[1] - p[0])), 6)  # 10 m apart
    10.0
    """
    n = as_int("n", n, minimum=2)
    check_work("n", 2 * n, "coordinates")
    s = 10.0 * (np.arange(n) - (n - 1) / 2.0)
    centre = 2000.0 * np.array([np.cos(np.pi / 4), np.sin(np.pi / 4)])
    across = np.array([-np.sin(np.pi / 4), np.cos(np.pi / 4)])
    line: np.ndarray = centre + s[:, None] * across
    return line


# -- exercise 7.1: Q ---------------------------------------------------------------------------------------------------
def check_bias_noise(answer: Any) -> Feedback:
    r"""Check paper A's :math:`\mathbf Q = \operatorname{diag}(\sigma_x^2, \sigma_y^2, q_\upsilon)`,
    :math:`q_\upsilon = (\sigma_x^2 + \sigma_y^2)/2`.

    Parameters
    ----------
    answer : array_like, shape (3, 3), or None
        The student's Q.

    Returns
    -------
    Feedback
        The verdict; standard deviations instead of variances, the mean standard deviation squared, the sum
        instead of the mean, and a 2x2 Q without the bias are recognised.

    Examples
    --------
    >>> sx, sy = NOISE_SIGMAS
    >>> # 2x2: the bias is missing
    >>> check_bias_noise(np.diag([sx ** 2, sy ** 2])).correct
    False
    >>> q_bias = (sx ** 2 + sy ** 2) / 2
    >>> check_bias_noise(np.diag([sx ** 2, sy ** 2, q_bias])).correct
    True
    """
    sx, sy = NOISE_SIGMAS
    expected = paper_a_process_noise(sx, sy)
    if _answer_shape(answer) == (2, 2):
        return Feedback(False, "Not yet: Q must be 3x3, one row and column per state [x, y, bias].",
                        hint="Add the bias row: Q = diag(σx², σy², q_υ).")
    mistakes = [
        (np.diag([sx, sy, (sx + sy) / 2]), "Those are standard deviations on the diagonal; Q holds variances."),
        (np.diag([sx**2, sy**2, ((sx + sy) / 2) ** 2]), "Paper A averages the *variances*: q_υ = (σx² + σy²)/2, "
                                                          "not the square of the mean standard deviation."),
        (np.diag([sx**2, sy**2, sx**2 + sy**2]), "Halve it: q_υ is the mean of σx² and σy², not their sum."),
        (np.diag([sx**2, sy**2, 0.0]), "A zero bias noise makes the bias a constant: paper A lets it wander by "
                                       "q_υ = (σx² + σy²)/2 per epoch."),
    ]
    return check_array(answer, expected, rtol=1e-9, atol=1e-12, name="Q", units="m²", common_mistakes=mistakes,
                       hint="Q = diag(σx², σy², (σx² + σy²)/2).",
                       explanation="Between close epochs paper A lets the bias change about as much as the DR "
                                   "position does.")


# -- exercise 7.2: the augmented Jacobian ------------------------------------------------------------------------------
def check_augmented_jacobian(answer: Any) -> Feedback:
    r"""Check :math:`\mathbf H = [(x - b_x)/r, (y - b_y)/r, 1]`, :math:`r = \lVert \mathbf p - \mathbf b\rVert`.

    Parameters
    ----------
    answer : array_like, shape (3,), or None
        The student's H (a (1, 3) row is accepted too).

    Returns
    -------
    Feedback
        The verdict; the position-only Jacobian with a 0 for the bias, the reversed direction, the range
        including the bias in the denominator, the beacon not subtracted and an unnormalized difference are
        recognised.

    Examples
    --------
    >>> d = np.array(JACOBIAN_STATE[:2]) - np.array(JACOBIAN_BEACON)
    >>> los = d / np.linalg.norm(d)
    >>> check_augmented_jacobian(np.r_[los, 0.0]).correct  # ∂r/∂υ is 1, not 0
    False
    >>> check_augmented_jacobian(np.r_[los, 1.0]).correct
    True
    """
    b = np.array(JACOBIAN_BEACON)
    x = np.array(JACOBIAN_STATE)
    model = RangeToBeacon(b, R=1.0, n=3, bias_index=2)
    expected = model.H(x[None], 0)[0, 0]
    d = x[:2] - b
    r = np.linalg.norm(d)
    answer = _row_as_vector(answer, 3)
    if _answer_shape(answer) == (2,):
        return Feedback(False, "Not yet: H needs one entry per state, three: ∂r/∂x, ∂r/∂y and ∂r/∂υ.",
                        hint="The range is ‖p − b‖ + υ, so ∂r/∂υ = 1.")
    mistakes = [
        (np.r_[d / r, 0.0], "The bias is added to the range: ∂r/∂υ = 1, not 0."),
        (np.r_[-d / r, 1.0], "The range grows when the vehicle moves away from the beacon: the first two entries "
                             "are (p − b)/‖p − b‖."),
        (np.r_[d / (r + x[2]), 1.0], "Divide by the geometric range ‖p − b‖, not by the range plus the bias: "
                                     "the bias does not depend on the position."),
        (np.r_[x[:2] / np.linalg.norm(x[:2]), 1.0], "Subtract the beacon's position: it is not at the origin "
                                                     "here."),
        (np.r_[d, 1.0], "Normalize the position part: it is the unit line of sight."),
    ]
    return check_array(answer, expected, rtol=1e-6, atol=1e-9, name="H", common_mistakes=mistakes,
                       hint="H = [(x − b_x)/r, (y − b_y)/r, 1] with r = ‖p − b‖ at the predicted position.",
                       explanation="The bias column is the same at every epoch: only a change of bearing tells a "
                                   "bias from a move along the line of sight.")


# -- exercise 7.3: the weak direction ----------------------------------------------------------------------------------
def _weak_direction() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    p = straight_track()
    los = p / np.linalg.norm(p, axis=1, keepdims=True)
    A = np.column_stack([los, np.ones(len(p))])
    _, _, vt = np.linalg.svd(A)
    _, _, vt_pos = np.linalg.svd(los)
    return vt[-1], vt[0], np.r_[vt_pos[-1], 0.0]


def check_weak_direction(answer: Any) -> Feedback:
    r"""Check the unit vector :math:`\mathbf v` of ``[x, y, bias]`` that the straight track's ranges hardly see.

    It is the right singular vector of the smallest singular value of the stacked Jacobian
    :math:`\mathbf A` (rows :math:`[\cos\varphi_k, \sin\varphi_k, 1]`); its sign is arbitrary. On a short arc it
    is close to :math:`[\cos\bar\varphi, \sin\bar\varphi, -1]/\sqrt 2`: moving along the line of sight while the
    bias shrinks by as much.

    Parameters
    ----------
    answer : array_like, shape (3,), or None
        The student's direction (either sign).

    Returns
    -------
    Feedback
        The verdict; the strongest direction, the position-only weak direction (across the line of sight), a
        vector that is not of unit length and one of the wrong size are recognised.

    Examples
    --------
    >>> p = straight_track()
    >>> los = p / np.linalg.norm(p, axis=1, keepdims=True)
    >>> A = np.column_stack([los, np.ones(len(p))])
    >>> _, _, vt = np.linalg.svd(A)
    >>> check_weak_direction(vt[0]).correct  # the direction seen best
    False
    >>> check_weak_direction(vt[-1]).correct
    True
    """
    weak, strong, across = _weak_direction()
    if answer is None or answer is Ellipsis:
        return not_answered("the unit vector [vx, vy, v_bias] (a NumPy array of 3 numbers)")
    v, refusal = parse_real_array(answer, "the direction")
    if refusal is not None:
        return refusal
    assert v is not None                             # no refusal: parse_real_array returned the array
    v = v.ravel()
    if v.shape != (3,):
        return Feedback(False, f"Not yet: the direction has one component per state [x, y, bias]: 3 numbers; got "
                               f"{v.size}.", hint="Take a row of Vt from np.linalg.svd(A) (A is N x 3).")
    if not np.isfinite(v).all():
        return Feedback(False, "Not yet: the direction has NaN or infinite components.",
                        hint="Build A from finite lines of sight (no position on the beacon).")
    norm = float(np.linalg.norm(v))
    if not 0.999 < norm < 1.001:
        return Feedback(False, f"Not yet: the direction should be a unit vector; its length is {norm:.4g}.",
                        hint="Divide by np.linalg.norm(v), or take it straight from the SVD.")
    cos = abs(float(v @ weak))
    if cos > 0.999:
        angle = np.degrees(np.arctan2(weak[1], weak[0]))
        return Feedback(True, f"Correct: v ≈ ±[{weak[0]:.3f}, {weak[1]:.3f}, {weak[2]:.3f}], along the line of sight "
                              f"(bearing {angle:.0f}°) with the bias going the other way: a vehicle a little further "
                              "out with a smaller bias gives almost the same ranges.")
    if abs(float(v @ strong)) > 0.999:
        return Feedback(False, "Not yet: that is the direction the ranges see *best* (the largest singular value).",
                        hint="np.linalg.svd returns the singular values in decreasing order: take the last row of Vt.")
    if abs(float(v @ across)) > 0.999:
        return Feedback(False, "Not yet: that is the weak direction of the position alone (across the line of "
                               "sight). With the bias column it is another one, weaker still.",
                        hint="Include the column of ones for the bias in A.")
    return Feedback(False, f"Not yet: your direction makes an angle of {np.degrees(np.arccos(min(cos, 1.0))):.0f}° "
                           "with the weakest one.",
                    hint="A = [los_x, los_y, 1] row by row (los = p/‖p‖, the beacon at the origin); "
                         "v = np.linalg.svd(A)[2][-1].")


# -- exercise 7.4: when to start ---------------------------------------------------------------------------------------
def _arc() -> np.ndarray:
    phi = np.radians(-90.0 + START_SPACING_DEG * np.arange(1000))
    return START_RADIUS * np.column_stack([np.cos(phi), np.sin(phi)])


def check_start_count(answer: Any) -> Feedback:
    r"""Check the number of ranges after which :math:`\alpha` first falls below ``START_THRESHOLD``.

    Parameters
    ----------
    answer : int or None
        The student's count (ranges, counted from 1).

    Returns
    -------
    Feedback
        The verdict; the 0-based index (one fewer), one more than the count, the count for paper A's threshold of 2,
        for ``<=`` instead of ``<`` when it differs, and for the position-only precision factor are recognised.

    Examples
    --------
    >>> phi = np.radians(-90.0 + START_SPACING_DEG * np.arange(1000))
    >>> track = START_RADIUS * np.column_stack([np.cos(phi), np.sin(phi)])
    >>> alpha = lsq.precision_factor_history(track)
    >>> index = int(np.argmax(alpha < START_THRESHOLD))
    >>> check_start_count(index).correct  # a 0-based index
    False
    >>> check_start_count(index + 1).correct
    True
    """
    track = _arc()
    alpha = lsq.precision_factor_history(track)
    n = int(np.argmax(alpha < START_THRESHOLD)) + 1
    n2 = int(np.argmax(alpha < 2.0)) + 1
    pos = lsq.precision_factor_history(track, unknown_bias=False)
    n_pos = int(np.argmax(pos < START_THRESHOLD)) + 1
    mistakes = {
        float(n - 1): "That is the 0-based index of the epoch; the question asks for the number of ranges (index + 1).",
        float(n_pos): "That is the precision factor of the position alone; paper A's has the bias column too "
                      "(unknown_bias=True, the default).",
        float(n + 1): "One range too many (an off-by-one, not a rounding): np.argmax(alpha < 1.0) is the 0-based "
                      "index of the first range with α < 1, and the count is that index + 1. Adding 2, or a track "
                      "with an extra starting point, gives one more.",
    }
    if n2 != n:
        mistakes[float(n2)] = f"That is the count for paper A's threshold α < 2; this exercise asks for α < " \
                              f"{START_THRESHOLD:g}."
    return check_number(answer, float(n), rtol=0.0, atol=0.5, name="the number of ranges", common_mistakes=mistakes,
                        hint="alpha = lsq.precision_factor_history(track); n = np.argmax(alpha < 1.0) + 1.",
                        explanation=f"The bearing has then turned by {START_SPACING_DEG * (n - 1):.0f}°: the "
                                    "threshold is a demand on the geometry, not on the number of ranges.")


# -- exercise 7.5: diagnosis -------------------------------------------------------------------------------------------
def bias_diagnosis_studies(n_runs: int = 40, n_obs: int = 1500, seed: int = 5,
                           rate: float = 0.03) -> dict[str, np.ndarray]:
    """The mean NEES (3 states: x, y, bias) over time of the three filters of exercise 7.5, keyed by letter.

    Paper A's simulation with DR noise 0.2 m and a bias ramp of ``rate`` m/s added to its ranges; every filter
    starts from the truth with :math:`P_0 = 100` I.

    Parameters
    ----------
    n_runs : int, default 40
        Monte Carlo runs (>= 2).
    n_obs : int, default 1500
        Ranges per run (>= 2).
    seed : int, default 5
        Seed.
    rate : float, default 0.03
        The bias ramp [m/s], between -1 and 1.

    Returns
    -------
    dict
        ``{"A": mean NEES (K,), "B": ..., "C": ..., "bounds": (lower, upper)}``.

    Examples
    --------
    >>> # a small study: the exercise uses the defaults
    >>> studies = bias_diagnosis_studies(n_runs=2, n_obs=50)
    >>> studies["A"].shape, len(studies["bounds"])
    ((50,), 2)
    """
    n_runs = as_int("n_runs", n_runs, minimum=2)
    n_obs = as_int("n_obs", n_obs, minimum=2)
    check_work("n_runs", 40 * n_runs * n_obs, "floats (n_runs x n_obs x 40: three filters of 3 and 4 states)")
    # a ramp beyond 1 m/s is a sound-speed error of 100 % (and its ranges soon turn negative)
    rate = as_scalar("rate", rate, low=-1.0, high=1.0)
    params = paper_a.PaperAParameters(dr_sigma=0.2, n_obs=n_obs)
    sc, bias = paper_a.make_with_truth(np.random.default_rng(as_seed("seed", seed)), n_runs, params)
    z = np.asarray(sc.ranges) + rate * sc.times
    if np.any(z < 0.0):
        raise ValueError(f"rate = {rate:g} m/s makes a measured range negative: a falling bias cannot exceed the "
                         "range (use a smaller ramp, or fewer ranges n_obs)")
    truth = np.concatenate([sc.true_positions, (bias + rate * sc.times)[..., None]], axis=-1)
    x0, P0, u = truth[:, 0], np.eye(3) * 100.0, sc.dr_displacements
    out: dict[str, Any] = {}
    out["A"] = bias_ekf(x0, P0, u, z, paper_a_process_noise(0.2), 5.0).nees(truth)
    ramp = extended_kalman_filter(BiasRateDeadReckoning(bias_rate_process_noise(0.2, rate_sigma=3e-4, dt=5.0), 5.0),
                                  RangeToBeacon((0.0, 0.0), 5.0, n=4, bias_index=2),
                                  np.column_stack([x0, np.zeros(n_runs)]), np.diag([100.0, 100.0, 100.0, 1e-3]),
                                  u, z)
    e = truth - ramp.x[..., :3]
    out["B"] = np.einsum("...i,...i->...", e, np.linalg.solve(ramp.P[..., :3, :3], e[..., None])[..., 0])
    out["C"] = bias_ekf(x0, P0, u, z, paper_a_process_noise(0.2, sigma_bias=20 * 0.2), 5.0).nees(truth)
    for key in "ABC":
        out[key] = out[key].mean(axis=0)
    out["bounds"] = chi2_mean_bounds(3, n_runs)
    return out


def _classify(studies: dict[str, Any]) -> tuple[str, str, str]:
    lo, hi = studies["bounds"]
    late = {k: float(np.mean(studies[k][len(studies[k]) // 3:])) for k in "ABC"}
    inside = {k: float(np.mean((studies[k] >= lo) & (studies[k] <= hi))) for k in "ABC"}
    consistent = max(inside, key=lambda k: inside[k])
    over = max(late, key=lambda k: late[k])
    under = min(late, key=lambda k: late[k])
    if not (late[over] > hi and late[under] < lo):
        raise RuntimeError("the exercise's filters are not clearly over- and underconfident: retune them")
    return consistent, over, under


def check_bias_diagnosis(consistent: Any, overconfident: Any) -> Feedback:
    """Check which filter of exercise 7.5 is consistent and which is overconfident (``"A"``, ``"B"`` or ``"C"``).

    The checker reruns the studies (``bias_diagnosis_studies``) and classifies them by their mean NEES against the
    95 % chi-square interval for 3 states.

    Parameters
    ----------
    consistent : str or None
        The letter of the consistent filter.
    overconfident : str or None
        The letter of the overconfident filter.

    Returns
    -------
    Feedback
        The verdict, with what each filter's NEES says.

    Examples
    --------
    >>> # one filter cannot be both (answered before any study runs)
    >>> check_bias_diagnosis("A", "A").correct
    False
    >>> studies = bias_diagnosis_studies()
    >>> lo, hi = studies["bounds"]
    >>> inside = {k: np.mean((studies[k] >= lo) & (studies[k] <= hi))
    ...           for k in "ABC"}
    >>> late = {k: np.mean(studies[k][len(studies[k]) // 3:]) for k in "ABC"}
    >>> consistent = max(inside, key=inside.get)
    >>> overconfident = max(late, key=late.get)
    >>> check_bias_diagnosis(consistent, overconfident).correct
    True
    """
    return _check_nees_letters(
        consistent, overconfident, sorted(DIAGNOSIS_FILTERS), lambda: _classify(bias_diagnosis_studies()),
        read="Mean NEES of a consistent 3-state filter: about 3, inside the band. Far above: the filter's P is too "
             "small for its errors (here, a bias that moves faster than its Q allows). Below: P too large.",
        correct=lambda c, o, u: (f"Correct: {c} ({DIAGNOSIS_FILTERS[c]}) is consistent; {o} ({DIAGNOSIS_FILTERS[o]}) "
                                 f"lags behind the ramp and is overconfident; {u} ({DIAGNOSIS_FILTERS[u]}) follows it "
                                 "but claims more uncertainty than it has."))
