"""Checkers for the exercises of chapter 6, "Particle filters for a maneuvering AUV's depth" (paper C).

Each checker takes the student's answer, computes the expected value from the exercise's data (the constants below)
with ``uwtutor``'s own implementation, and returns a ``Feedback`` that recognises the usual mistakes:

=============================================  ======================================================================
checker                                        exercise
=============================================  ======================================================================
``check_gm11_coefficients(a, b)``              GM(1,1) development coefficient and grey input of ``DEPTH_SERIES``
``check_grey_forecast(value)``                 the GM(1,1) forecast of the next depth reading
``check_mad_sigma(sigma)``                     the wavelet (MAD) noise estimate of ``NOISE_WINDOW``
``check_effective_sample_size(ess)``           the effective sample size of ``PARTICLE_WEIGHTS``
``check_systematic_resample(func)``            a systematic resampler ``func(weights, u) -> indices``
``check_q_smallest_eigenvalue(value)``         the smallest eigenvalue of paper C's process covariance as printed
``check_q_correlation(value)``                 the depth-speed correlation that matrix implies
``check_pf_step(func)``                        6.6: one whole bootstrap step written by the student (a function),
                                               against ``pf_step_reference`` (uwtutor's model, likelihood, resampler)
=============================================  ======================================================================

The exercises themselves are in the repository's ``exercises/ch06_particle_filters.ipynb``.

References
----------
Li Ting, Zhao Dexin, Huang Zhiping and Su Shaojing (2013), paper C; Donoho and Johnstone (1994); Douc, Cappé and
Moulines (2005).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..grey import fit_gm11
from ..wavelet import MAD_TO_SIGMA, detail_coefficients, noise_sigma
from .checks import Case, _as_scalar, check_array, check_function, check_number, not_answered
from .feedback import Feedback

__all__ = [
    "check_gm11_coefficients",
    "check_grey_forecast",
    "check_mad_sigma",
    "check_effective_sample_size",
    "check_systematic_resample",
    "check_q_smallest_eigenvalue",
    "check_q_correlation",
    "check_pf_step",
    "pf_step_reference",
    "DEPTH_SERIES",
    "NOISE_WINDOW",
    "PARTICLE_WEIGHTS",
    "Q_PRINTED",
]

# -- the data of the exercises -----------------------------------------------------------------------------------------
#: Six depth readings (m), one a second, for exercises 6.1 and 6.2.
DEPTH_SERIES = np.array([12.1, 12.6, 13.0, 13.5, 14.1, 14.6])


def _noise_window() -> np.ndarray:
    rng = np.random.default_rng(818)
    t = 0.05 * np.arange(50)
    return 12.0 + 0.9 * t - 0.2 * t**2 + rng.normal(0.0, 0.15, 50)


#: Fifty depth readings (m) of a vehicle starting a dive, with sensor noise of unknown level (exercise 6.3).
NOISE_WINDOW = _noise_window()
#: Unnormalized particle weights of exercise 6.4.
PARTICLE_WEIGHTS = np.array([0.5, 2.0, 1.0, 0.1, 3.0, 0.4])
#: Paper C's process noise covariance as printed, in the units m, cm/s and degrees (exercise 6.5).
Q_PRINTED = np.array([[0.2**2, 0.8**2, 0.6**2], [0.8**2, 1.0**2, 0.0], [0.6**2, 0.0, 0.5**2]])


def _both_numbers(a: Any, b: Any) -> tuple[float, float] | None:
    """Both answers as floats when both read as real numbers (the shared parser: never coerced, never a crash)."""
    x, problem_a = _as_scalar(a, "a", "a")
    y, problem_b = _as_scalar(b, "b", "b")
    return (x, y) if x is not None and y is not None and problem_a is None and problem_b is None else None


def _lstsq_ab(z: np.ndarray, y: np.ndarray, sign: float = -1.0) -> tuple[float, float]:
    B = np.column_stack([sign * z, np.ones(z.size)])
    a, b = np.linalg.lstsq(B, y, rcond=None)[0]
    return float(a), float(b)


# -- exercise 6.1: GM(1,1) coefficients --------------------------------------------------------------------------------
def check_gm11_coefficients(a: Any, b: Any) -> Feedback:
    """Check the GM(1,1) development coefficient ``a`` and grey input ``b`` of ``DEPTH_SERIES``.

    Expected: the least-squares solution of ``x0(k) + a z1(k) = b``, ``k = 2..6``, with background values
    ``z1(k) = 0.5 (x1(k) + x1(k-1))`` (computed by ``uwtutor.grey.fit_gm11``).

    Parameters
    ----------
    a : float or None
        The student's development coefficient.
    b : float or None
        The student's grey input.

    Returns
    -------
    Feedback
        The verdict; a flipped sign of the background column, the accumulated series on the right-hand side, a
        background weight of 1 or 0, a fit of the raw series without accumulation and rows starting at ``k = 1``
        are recognised.

    Examples
    --------
    >>> model = fit_gm11(DEPTH_SERIES)
    >>> check_gm11_coefficients(-model.a, model.b).correct  # the sign of a flipped
    False
    >>> check_gm11_coefficients(model.a, model.b).correct
    True
    """
    if a is None or a is Ellipsis or b is None or b is Ellipsis:
        return not_answered("the development coefficient `a` and the grey input `b` (two numbers)")
    x0 = DEPTH_SERIES
    model = fit_gm11(x0)
    x1 = np.cumsum(x0)
    z = 0.5 * (x1[1:] + x1[:-1])
    mistakes = [
        (_lstsq_ab(z, x0[1:], sign=+1.0),
         "The rows of B are [−z1(k), 1]: the equation is x0(k) + a·z1(k) = b, so z1 enters with a minus sign "
         "(your a has the wrong sign)."),
        (_lstsq_ab(z, x1[1:]),
         "The right-hand side Y holds the raw readings x0(2), ..., x0(n), not the accumulated series x1."),
        (_lstsq_ab(x1[1:], x0[1:]),
         "The background value is the mean of two neighbouring accumulated values, 0.5·(x1(k) + x1(k−1)), not "
         "x1(k) itself."),
        (_lstsq_ab(x1[:-1], x0[1:]),
         "The background value is the mean of two neighbouring accumulated values, 0.5·(x1(k) + x1(k−1)), not "
         "x1(k−1)."),
        (_lstsq_ab(0.5 * (x0[1:] + x0[:-1]), x0[1:]),
         "GM(1,1) works on the accumulated series x1 = cumsum(x0): the background values are means of x1, not of "
         "the raw readings."),
        (_lstsq_ab(np.concatenate([[x1[0]], z]), x0),
         "The equations run from k = 2 to n (five rows for six readings): there is no background value for k = 1."),
    ]
    pair = _both_numbers(a, b)
    if pair is not None:
        for (ma, mb), hint in mistakes:
            if math.isclose(pair[0], ma, rel_tol=1e-3, abs_tol=1e-6) and math.isclose(pair[1], mb, rel_tol=1e-3):
                return Feedback(False, f"Not yet: a = {pair[0]:.6g} and b = {pair[1]:.6g} come from a different "
                                       "system of equations.", hint=hint,
                                details={"answer": pair, "mistake": (ma, mb)})
    fb = check_number(a, model.a, rtol=1e-3, name="the development coefficient a",
                      hint="Build x1 = np.cumsum(x0), z1 = 0.5 * (x1[1:] + x1[:-1]), B = [−z1, 1] (one row per "
                           "k = 2..n) and Y = x0[1:], then solve with np.linalg.lstsq(B, Y, rcond=None).")
    if not fb:
        return fb
    fb_b = check_number(b, model.b, rtol=1e-3, name="the grey input b",
                        hint="b comes from the same least-squares solution as a: the second entry of "
                             "np.linalg.lstsq(B, Y, rcond=None)[0].")
    if not fb_b:
        return fb_b
    return Feedback(True, f"Correct: a = {model.a:.5f} and b = {model.b:.4f}. A negative a means a growing series: "
                          f"the depth grows by about {100 * (math.exp(-model.a) - 1):.1f} % per reading.",
                    details={"answer": pair})


# -- exercise 6.2: the forecast ----------------------------------------------------------------------------------------
def check_grey_forecast(value: Any) -> Feedback:
    """Check the GM(1,1) forecast (m) of the seventh reading of ``DEPTH_SERIES``.

    Expected: ``(1 - e^a) (x0(1) - b/a) e^{-6a}`` with the exercise 6.1 coefficients.

    Parameters
    ----------
    value : float or None
        The student's forecast in metres.

    Returns
    -------
    Feedback
        The verdict; paper C's misprinted factor ``(1 - e^{-a})``, the accumulated forecast not differenced, the
        fitted sixth value instead of the seventh and a wrong sign in the exponent are recognised.

    Examples
    --------
    >>> # the last reading, not a forecast
    >>> check_grey_forecast(DEPTH_SERIES[-1]).correct
    False
    >>> check_grey_forecast(fit_gm11(DEPTH_SERIES).forecast(1)[0]).correct
    True
    """
    x0 = DEPTH_SERIES
    model = fit_gm11(x0)
    a, b, n = model.a, model.b, x0.size
    expected = float(model.forecast(1)[0])
    c = x0[0] - b / a
    mistakes = {
        (1 - math.exp(-a)) * c * math.exp(-a * n):
            "That is paper C's eq. (12) as printed, with (1 − e^{−a}). Difference the two exponentials of the time "
            "response yourself: e^{−ak} − e^{−a(k−1)} = (1 − e^{a})·e^{−ak}.",
        c * math.exp(-a * n) + b / a:
            "That is the accumulated forecast x1̂(7). Restore the reading by differencing: x0̂(7) = x1̂(7) − x1̂(6).",
        (1 - math.exp(a)) * c * math.exp(-a * (n - 1)):
            "That is the model's value for the sixth reading (k = 5). The seventh reading is x0̂(k+1) with k = 6.",
        (1 - math.exp(a)) * c * math.exp(a * n):
            "The time response decays as e^{−ak}: check the sign in the exponent.",
    }
    return check_number(value, expected, rtol=1e-3, name="the forecast of the seventh depth", units="m",
                        common_mistakes=mistakes,
                        hint="x0̂(k+1) = (1 − e^{a})·(x0(1) − b/a)·e^{−ak} with k = 6 and the a, b of exercise 6.1.",
                        explanation="The readings grow by about half a metre per step, and so does the forecast.")


# -- exercise 6.3: the wavelet noise estimate --------------------------------------------------------------------------
def check_mad_sigma(sigma: Any) -> Feedback:
    """Check the noise standard deviation (m) of ``NOISE_WINDOW`` by the wavelet MAD estimate.

    Expected: ``median(|d|) / 0.6745`` over the db6 detail coefficients that lie inside the window
    (``uwtutor.wavelet.detail_coefficients(NOISE_WINDOW)``).

    Parameters
    ----------
    sigma : float or None
        The student's estimate in metres.

    Returns
    -------
    Feedback
        The verdict; a missing absolute value, multiplying by 0.6745, forgetting it, the standard deviation or the
        mean of the coefficients, PyWavelets' extended (symmetric) coefficients and the standard deviation of the
        raw readings are recognised.

    Examples
    --------
    >>> # the spread of the readings, dive included
    >>> check_mad_sigma(np.std(NOISE_WINDOW)).correct
    False
    >>> d = detail_coefficients(NOISE_WINDOW)
    >>> check_mad_sigma(np.median(np.abs(d)) / 0.6745).correct
    True
    """
    d = detail_coefficients(NOISE_WINDOW)
    expected = float(noise_sigma(NOISE_WINDOW))
    import pywt

    d_sym = np.asarray(pywt.dwt(NOISE_WINDOW, "db6")[1])
    mistakes = {
        float(np.median(d)) / MAD_TO_SIGMA:
            "Take the median of the absolute values, |d|: the coefficients are spread around zero, so their plain "
            "median is close to zero.",
        float(np.median(np.abs(d))) * MAD_TO_SIGMA:
            "Divide by 0.6745, do not multiply: the median of |N(0, σ²)| is 0.6745·σ, so σ = median / 0.6745.",
        float(np.median(np.abs(d))):
            "The median of |d| is 0.6745·σ for Gaussian noise: divide it by 0.6745.",
        float(np.std(d)):
            "That is the standard deviation of the coefficients, which a few spoiled coefficients can inflate; the "
            "estimate uses the median of their absolute values divided by 0.6745.",
        float(np.mean(np.abs(d))) / MAD_TO_SIGMA:
            "Use the median of |d|, not its mean: the median is what makes the estimate robust.",
        float(np.median(np.abs(d_sym))) / MAD_TO_SIGMA:
            "These are the coefficients of pywt.dwt with its default symmetric extension, which invents samples "
            "beyond the window's edges. Use only the coefficients whose filter lies inside the window: "
            "wavelet.detail_coefficients(window) (mode='valid').",
        float(np.std(NOISE_WINDOW)):
            "That is the spread of the readings themselves, which includes the vehicle's descent. The wavelet's "
            "detail coefficients remove the smooth part first.",
    }
    return check_number(sigma, expected, rtol=1e-3, name="the noise standard deviation", units="m",
                        common_mistakes=mistakes,
                        hint="d = wavelet.detail_coefficients(window) (db6), then np.median(np.abs(d)) / 0.6745.",
                        explanation="The readings were simulated with σ = 0.15 m; a single estimate from 20 "
                                    "coefficients scatters by about 25 % around the true value.")


# -- exercise 6.4: effective sample size and systematic resampling ----------------------------------------------------
def check_effective_sample_size(ess: Any) -> Feedback:
    """Check the effective sample size of ``PARTICLE_WEIGHTS`` (which are not normalized).

    Parameters
    ----------
    ess : float or None
        The student's effective sample size.

    Returns
    -------
    Feedback
        The verdict; weights used without normalizing, the sum of squares without the reciprocal, the number of
        particles and the reciprocal of the largest weight are recognised.

    Examples
    --------
    >>> w = PARTICLE_WEIGHTS
    >>> # weights not normalized
    >>> check_effective_sample_size(1 / np.sum(w ** 2)).correct
    False
    >>> check_effective_sample_size(1 / np.sum((w / w.sum()) ** 2)).correct
    True
    """
    w = PARTICLE_WEIGHTS
    wn = w / w.sum()
    expected = float(1.0 / np.sum(wn**2))
    mistakes = {
        float(1.0 / np.sum(w**2)):
            "Normalize the weights first (w / w.sum()): N_eff = 1 / Σ w_i² holds for weights that sum to one.",
        float(np.sum(wn**2)):
            "N_eff is the reciprocal of the sum of squared normalized weights: 1 / Σ w_i².",
        float(w.size):
            "N_eff equals the number of particles only when all weights are equal; here they are not.",
        float(1.0 / wn.max()):
            "1 / max(w) is how many copies of the heaviest particle would fill the set; the effective sample "
            "size is 1 / Σ w_i² of the normalized weights.",
    }
    return check_number(ess, expected, rtol=1e-3, name="the effective sample size", common_mistakes=mistakes,
                        hint="w = w / w.sum(); ess = 1 / np.sum(w**2).",
                        explanation="Of six particles, fewer than four effectively carry the estimate.")


def _systematic_reference(weights: Any, u: float) -> np.ndarray:
    w = np.asarray(weights, dtype=float)
    w = w / w.sum()
    c = np.cumsum(w)
    c[-1] = 1.0
    indices: np.ndarray = np.searchsorted(c, (np.arange(w.size) + u) / w.size, side="right")
    return indices


def _systematic_cases() -> list[Case]:
    rng = np.random.default_rng(2005)
    random_weights = rng.random(10)
    return [
        Case((np.array([0.1, 0.2, 0.3, 0.4]), 0.5), label="four weights, u = 0.5",
             hint="The N points are (j + u)/N for j = 0..N−1; each selects the first particle whose cumulative weight "
                  "exceeds it (np.searchsorted(np.cumsum(w), points, side='right'))."),
        Case((np.array([0.25, 0.25, 0.25, 0.25]), 0.0), label="equal weights, u = 0 (points on the boundaries)",
             hint="A point that equals a cumulative weight belongs to the next particle: use side='right' in "
                  "np.searchsorted, so that equal weights give one copy of each particle."),
        Case((np.array([1.0, 3.0, 0.0, 4.0]), 0.3), label="unnormalized weights with a zero",
             hint="Normalize the weights first (w / w.sum()); a particle of weight zero must never be selected."),
        Case((np.array([5.0]), 0.7), label="a single particle",
             hint="With one particle every point selects it: the result is [0]."),
        Case((np.array([0.97, 0.01, 0.01, 0.01]), 0.9), label="one dominant particle"),
        Case((random_weights, 0.123), label="ten random weights"),
        Case((np.array([0.2, 0.3, 0.5]), 0.999), label="u close to 1",
             hint="Points stay below 1 when 0 <= u < 1; set the last cumulative weight to exactly 1 so that rounding "
                  "cannot push a point past the end."),
    ]


def check_systematic_resample(func: Any) -> Feedback:
    """Check a student's ``systematic(weights, u)``: systematic resampling with a given uniform offset ``u``.

    The specification (also in the notebook): normalize the weights, form the points ``(j + u) / N`` for
    ``j = 0, ..., N-1`` and return, for each point, the index of the first particle whose cumulative weight is
    greater than the point (an integer array of length ``N``).

    Parameters
    ----------
    func : callable or None
        The student's function.

    Returns
    -------
    Feedback
        The verdict; a failing case is reported with its inputs, the expected indices and the student's.

    Examples
    --------
    >>> def systematic(weights, u):
    ...     w = np.asarray(weights, dtype=float)
    ...     c = np.cumsum(w / w.sum())
    ...     c[-1] = 1.0
    ...     points = (np.arange(w.size) + u) / w.size
    ...     return np.searchsorted(c, points, side="right")
    >>> # a point on a boundary goes to the wrong particle
    >>> def systematic_left(weights, u):
    ...     w = np.asarray(weights, dtype=float)
    ...     points = (np.arange(w.size) + u) / w.size
    ...     return np.searchsorted(np.cumsum(w / w.sum()), points)
    >>> check_systematic_resample(systematic_left).correct
    False
    >>> check_systematic_resample(systematic).correct
    True
    """
    return check_function(
        func, _systematic_reference, _systematic_cases(), name="systematic",
        compare=lambda got, expected: check_array(got, expected, name="the indices"),
        hint="Normalize, cumulate (np.cumsum), set the last cumulative weight to 1, then "
             "np.searchsorted(c, (np.arange(N) + u) / N, side='right').",
        explanation="One uniform number per step and a single pass over the particles: the cheapest resampler, and "
                    "usually the least noisy.")


# -- exercise 6.5: paper C's Q -----------------------------------------------------------------------------------------
def check_q_smallest_eigenvalue(value: Any) -> Feedback:
    """Check the smallest eigenvalue of paper C's process covariance as printed (``Q_PRINTED``).

    Parameters
    ----------
    value : float or None
        The student's smallest eigenvalue.

    Returns
    -------
    Feedback
        The verdict; the matrix of the unsquared entries, the largest eigenvalue, the determinant and the smallest
        diagonal entry are recognised.

    Examples
    --------
    >>> check_q_smallest_eigenvalue(np.diag(Q_PRINTED).min()).correct
    False
    >>> smallest = np.linalg.eigvalsh(Q_PRINTED)[0]
    >>> check_q_smallest_eigenvalue(smallest).correct
    True
    >>> bool(smallest < 0)  # so Q as printed is no covariance
    True
    """
    Q = Q_PRINTED
    expected = float(np.linalg.eigvalsh(Q)[0])
    unsquared = np.sqrt(Q)
    mistakes = {
        float(np.linalg.eigvalsh(unsquared)[0]):
            "The entries are printed as squares (0.8² = 0.64, 0.6² = 0.36, ...): build the matrix from the squared "
            "values.",
        float(np.linalg.eigvalsh(Q)[-1]):
            "That is the largest eigenvalue; the question is whether any eigenvalue is negative.",
        float(np.linalg.det(Q)):
            "That is the determinant (the product of the eigenvalues); compute the eigenvalues themselves with "
            "np.linalg.eigvalsh(Q).",
        float(np.diag(Q).min()):
            "The diagonal entries are variances, all positive; a matrix with a positive diagonal can still have a "
            "negative eigenvalue. Use np.linalg.eigvalsh(Q).",
    }
    return check_number(value, expected, rtol=1e-3, name="the smallest eigenvalue", common_mistakes=mistakes,
                        hint="np.linalg.eigvalsh(Q) returns the eigenvalues of a symmetric matrix in increasing order.",
                        explanation="A covariance matrix cannot have a negative eigenvalue: Q as printed is not a "
                                    "covariance.")


def check_q_correlation(value: Any) -> Feedback:
    """Check the correlation between the depth and the speed noise implied by ``Q_PRINTED``.

    Parameters
    ----------
    value : float or None
        The student's correlation coefficient.

    Returns
    -------
    Feedback
        The verdict; the covariance itself, division by the variances instead of the standard deviations, the
        unsquared entries and the depth-pitch pair are recognised.

    Examples
    --------
    >>> Q = Q_PRINTED
    >>> check_q_correlation(Q[0, 1]).correct  # the covariance
    False
    >>> check_q_correlation(Q[0, 1] / np.sqrt(Q[0, 0] * Q[1, 1])).correct
    True
    """
    Q = Q_PRINTED
    expected = float(Q[0, 1] / math.sqrt(Q[0, 0] * Q[1, 1]))
    mistakes = {
        float(Q[0, 1]): "That is the covariance; the correlation divides it by both standard deviations.",
        float(Q[0, 1] / (Q[0, 0] * Q[1, 1])):
            "Divide by the standard deviations sqrt(Q_zz)·sqrt(Q_vv), not by the variances.",
        float(math.sqrt(Q[0, 1]) / math.sqrt(Q[0, 0] * Q[1, 1])):
            "The covariance is the printed 0.8² = 0.64, not 0.8.",
        float(Q[0, 2] / math.sqrt(Q[0, 0] * Q[2, 2])):
            "That is the depth-pitch correlation (entries (0, 2)); the question asks for depth and speed, (0, 1).",
    }
    return check_number(value, expected, rtol=1e-3, name="the depth-speed correlation", common_mistakes=mistakes,
                        hint="ρ = Q[0, 1] / sqrt(Q[0, 0] · Q[1, 1]).",
                        explanation="A correlation must lie between −1 and 1, and it has no units, so no reading "
                                    "of the paper's units can make this Q valid.")


# -- exercise 6.6: one bootstrap particle-filter step, written by the student ------------------------------------------
#: Exercise 6.6: the sampling interval (s) and the sensor covariance (paper C's R, SI units) of the step ...
PF_STEP_T = 0.05
PF_STEP_R = np.diag([0.2, 0.05, math.radians(0.5)]) ** 2
#: ... paper C's process noise standard deviations (m, m/s, rad), the number of particles and the seed of the cases.
PF_STEP_PROCESS_STD = np.array([0.2, 0.01, math.radians(0.5)])
PF_STEP_PARTICLES, PF_STEP_SEED = 200, 606
#: ... and how far (m) the depth reading of the second case lies from its cloud: with paper C's 0.2 m depth noise
#: every log-likelihood is below about −1100 there, so np.exp of it is 0 for every particle unless it is shifted.
PF_STEP_FAR_OFFSET = 10.0


def pf_step_reference(particles: ArrayLike, z: ArrayLike, noise: ArrayLike, u: float, T: float,
                      R: ArrayLike) -> tuple[Any, Any, Any]:
    r"""One bootstrap step on paper C's model, built from ``uwtutor``'s pieces, with the randomness given.

    Predict :math:`x^{(i)}_k = g(x^{(i)}_{k-1} + w^{(i)}_k)` (``uwtutor.models.depth.DepthSpeedPitch.f``), weight by
    the Gaussian likelihood (``DepthSpeedPitchModel.log_likelihood``, normalized in log space), estimate the
    weighted mean, resample systematically with the offset ``u`` (``uwtutor.resampling.systematic_resample``).

    Parameters
    ----------
    particles : array_like, shape (N, 3)
        Equally weighted particles after the last resampling (depth m, speed m/s, pitch rad).
    z : array_like, shape (3,)
        The readings.
    noise : array_like, shape (N, 3)
        The process-noise draws :math:`w^{(i)}_k`, already scaled.
    u : float
        The uniform offset in [0, 1) of the systematic resampler.
    T : float
        Sampling interval [s].
    R : array_like, shape (3, 3)
        Sensor noise covariance.

    Returns
    -------
    tuple
        ``(estimate (3,), weights (N,), resampled (N, 3))``: the weighted mean, the normalized weights before
        resampling and the resampled particles.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> start = np.array([12.0, 1.8, 0.14])
    >>> particles = start + 0.1 * rng.standard_normal((50, 3))
    >>> noise = 0.01 * rng.standard_normal((50, 3))
    >>> z = [12.1, 1.8, 0.14]
    >>> est, w, resampled = pf_step_reference(particles, z, noise, 0.5, PF_STEP_T,
    ...                                       PF_STEP_R)
    >>> est.shape, w.shape, resampled.shape
    ((3,), (50,), (50, 3))
    >>> round(float(w.sum()), 9)
    1.0
    """
    from ..filters import DepthSpeedPitchModel
    from ..models.depth import DepthSpeedPitch
    from ..resampling import systematic_resample

    p = np.asarray(particles, dtype=float)
    moved = DepthSpeedPitch(T=T).f(p + np.asarray(noise, dtype=float), None, 0)
    logw = DepthSpeedPitchModel(T=T, R=R).log_likelihood(moved, np.asarray(z, dtype=float))
    w = np.exp(logw - logw.max())
    w /= w.sum()

    class _Offset:                                   # a "generator" that returns the given offset
        def random(self, shape: Any = None) -> Any:
            return np.full(shape, u) if shape is not None else u

    try:
        idx = systematic_resample(w, _Offset())      # type: ignore[arg-type]
    except (TypeError, ValueError):                   # a strict rng check: the same points by hand
        idx = np.minimum(np.searchsorted(np.cumsum(w), (np.arange(len(w)) + u) / len(w), side="right"),
                         len(w) - 1)
    return w @ moved, w, moved[idx]


def _pf_step_cases() -> list[Case]:
    rng = np.random.default_rng(PF_STEP_SEED)
    N = PF_STEP_PARTICLES
    start = np.array([12.0, 1.8, math.radians(8.0)])
    cases = []
    for label, spread, offset, hint in (
            ("a cloud around the truth, readings near it", 1.0, 0.0,
             "Predict g(x + w), weight by the likelihood at the moved particles, take the weighted mean, resample."),
            (f"a cloud {PF_STEP_FAR_OFFSET:g} m off in depth: every likelihood underflows to 0 unless the log-weights "
             "are shifted", 1.0, PF_STEP_FAR_OFFSET,
             "Weights in log space: log w = −½ (z − x)ᵀ R⁻¹ (z − x); subtract the largest before np.exp, or they "
             "all underflow to 0 (0/0 = NaN after normalizing)."),
            ("a wide cloud", 5.0, 0.0,
             "Systematic resampling: the N points (j + u)/N, j = 0..N−1, looked up in the cumulative weights "
             "(np.searchsorted(np.cumsum(w), points, side='right'))."),
    ):
        particles = start + spread * rng.standard_normal((N, 3)) * np.array([0.3, 0.05, math.radians(1.0)])
        noise = rng.standard_normal((N, 3)) * PF_STEP_PROCESS_STD
        z = start + np.array([offset, 0.0, 0.0]) + rng.standard_normal(3) * np.sqrt(np.diag(PF_STEP_R))
        u = float(rng.random())
        cases.append(Case((particles, z, noise, u, PF_STEP_T, PF_STEP_R), label=label, hint=hint))
    return cases


def _pf_step_slip(*, noise_after: bool = False, no_shift: bool = False, r_not_inverted: bool = False,
                  estimate_after: bool = False, unweighted: bool = False) -> Any:
    """A ``pf_step`` written with one typical slip, for ``check_function``'s ``mistakes``."""

    def step(particles: Any, z: Any, noise: Any, u: float, T: float, R: Any) -> tuple[Any, Any, Any]:
        p, w_noise, z_arr, R_arr = (np.asarray(a, dtype=float) for a in (particles, noise, z, R))
        s = p if noise_after else p + w_noise
        moved = np.column_stack((s[:, 0] + s[:, 1] * np.sin(s[:, 2]) * T, s[:, 1], s[:, 2]))
        if noise_after:
            moved = moved + w_noise
        d = z_arr - moved
        log_w = -0.5 * np.einsum("ni,ij,nj->n", d, R_arr if r_not_inverted else np.linalg.inv(R_arr), d)
        with np.errstate(all="ignore"):
            w = np.exp(log_w if no_shift else log_w - log_w.max())
            w = w / w.sum()
        idx = np.minimum(np.searchsorted(np.cumsum(w), (np.arange(len(w)) + u) / len(w), side="right"), len(w) - 1)
        resampled = moved[idx]
        estimate = (resampled.mean(axis=0) if estimate_after else moved.mean(axis=0) if unweighted
                    else w @ moved)
        return estimate, w, resampled

    return step


#: Exercise 6.6's typical slips, each with the hint that names it (``check_function`` recognises them).
_PF_STEP_SLIPS = (
    (_pf_step_slip(noise_after=True),
     "Predict g(x + w): add the noise *before* the kinematics (the speed and pitch noise enter the depth equation), "
     "z ← z + (v + w_v)·sin(φ + w_φ)·T + w_z; adding it after g leaves them out."),
    (_pf_step_slip(no_shift=True),
     "Every likelihood underflowed: np.exp(log w) is 0 for every particle here, and 0/0 = NaN after normalizing. "
     "Subtract the largest log-weight before np.exp (it cancels when you normalize)."),
    (_pf_step_slip(r_not_inverted=True),
     "The exponent is −½ (z − x)ᵀ R⁻¹ (z − x): divide by the variances (np.linalg.inv(R)), do not multiply by R."),
    (_pf_step_slip(estimate_after=True),
     "That is the mean of the resampled particles: the estimate is the weighted mean Σ w_i x_i of the moved "
     "particles, taken *before* resampling (resampling only adds noise to it)."),
    (_pf_step_slip(unweighted=True),
     "That is the plain mean of the moved particles: weight each by w_i, Σ w_i x_i."),
)


def _compare_pf_step(got: Any, expected: Any) -> Feedback:
    if not isinstance(got, tuple) or len(got) != 3:
        return Feedback(False, "Not yet: pf_step should return a tuple of three: (estimate, weights, resampled).",
                        hint="End the function with return estimate, weights, resampled.")
    for name, g, e, hint in zip(
            ("the weights", "the estimate", "the resampled particles"), (got[1], got[0], got[2]),
            (expected[1], expected[0], expected[2]),
            ("The weight of a particle is its likelihood p(z | x) (the bootstrap proposal is the motion model), "
             "normalized to sum 1: w ∝ exp(−½ (z − x)ᵀ R⁻¹ (z − x)) at the *moved* particles.",
             "The estimate is the weighted mean Σ w_i x_i, taken before resampling.",
             "Resample with the given offset u: points (j + u)/N for j = 0..N−1, particle i drawn where the "
             "cumulative weights first exceed a point.")):
        fb = check_array(g, e, rtol=1e-7, atol=1e-12, name=name, hint=hint)
        if not fb.correct:
            return fb
    return Feedback(True, "Correct.")


def check_pf_step(func: Any) -> Feedback:
    r"""Check a student's ``pf_step(particles, z, noise, u, T, R)`` (exercise 6.6) against ``pf_step_reference``.

    Three cases (a cloud near the readings, one ``PF_STEP_FAR_OFFSET`` m off in depth where every weight underflows
    without the log-space shift, a wide one); for each the weights, the estimate and the resampled particles are
    compared, in that order, with the step built from ``uwtutor``'s model, likelihood and systematic resampler.

    Parameters
    ----------
    func : callable or None
        The student's function, returning ``(estimate, weights, resampled)``.

    Returns
    -------
    Feedback
        The verdict, with the first failing case and a hint aimed at its part of the step.

    Examples
    --------
    >>> # every particle weighted alike
    >>> def no_weights(particles, z, noise, u, T, R):
    ...     est, w, resampled = pf_step_reference(particles, z, noise, u, T, R)
    ...     return est, np.full(len(w), 1 / len(w)), resampled
    >>> check_pf_step(no_weights).correct
    False
    >>> check_pf_step(pf_step_reference).correct
    True
    """
    return check_function(
        func, pf_step_reference, _pf_step_cases(), name="pf_step", compare=_compare_pf_step, mistakes=_PF_STEP_SLIPS,
        hint="Four lines of algebra: move (g(x + w)), weight (likelihood, log space, normalize), estimate "
             "(weighted mean), resample (systematic with the given u).",
        explanation="This is one step of uwtutor's BootstrapParticleFilter on paper C's model, with the random "
                    "draws made visible.")
