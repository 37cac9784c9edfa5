r"""Checkers for the exercises of chapter 5, "Multiplicative range noise and fading-memory filters".

Each checker takes the student's answer, computes the expected value from the exercise's data (the constants below)
with ``uwtutor`` itself, and returns a ``Feedback`` that recognises the usual mistakes of that exercise:

==================================================  ====================================================================
checker                                             exercise
==================================================  ====================================================================
``check_mu_gamma(mu)``                              5.1: the mean multiplicative range factor from two sound speeds
``check_sigma_gamma(sigma)``                        5.1: its standard deviation
``check_mean_range_error(error)``                   5.1: the mean range error at 2500 m
``check_fading_factors(func)``                      5.2: the fading factor with a forgetting factor (a function)
``check_threshold_beta_one(z)``                     5.3: the smallest gross error that makes the fading factor act,
                                                    with :math:`\beta = 1` ...
``check_threshold_beta_range(z)``                   5.3: ... and with paper D's :math:`\beta \approx 2000`
``check_final_rmse(rmse_ekf, rmse_mult, ...)``      5.4: where the ISFEKF's advantage comes from
``check_isfekf_step(func)``                         5.5: one whole ISFEKF step written by the student (a function),
                                                    replayed against ``FadingEKF``
==================================================  ====================================================================

The exercises themselves are in the repository's ``exercises/ch05_multiplicative_noise.ipynb``.

References
----------
Zhu Z., Han S., Guo Z., Liu J. (2019). Single beacon location algorithm based on nonlinear fading filter under
multiplicative noise background. J. Electronics & Information Technology 41(1), 165-171 (paper D).

Zhou D., Xi Y. (1990). Suboptimal fading extended Kalman filtering for nonlinear systems. Control and Decision
5(5), 1-6.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import scenarios
from .._validate import as_scalar
from ..filters.ekf import range_only_ekf
from ..filters.fading import fading_ekf, range_factor_moments
from ..metrics import final_errors
from .checks import Case, _probe_student, check_array, check_function, check_number, parse_real_array, run_student
from .feedback import Feedback

__all__ = [
    "check_isfekf_step",
    "isfekf_step_reference",
    "isfekf_step_run",
    "check_mu_gamma",
    "check_sigma_gamma",
    "check_mean_range_error",
    "check_fading_factors",
    "fading_factors_reference",
    "check_threshold_beta_one",
    "check_threshold_beta_range",
    "threshold_innovation",
    "study",
    "final_rmse",
    "check_final_rmse",
    "ASSUMED_SPEED",
    "EFFECTIVE_SPEED",
    "SPEED_SIGMA",
    "TRUE_RANGE",
    "STEADY",
    "BETA_RANGE",
    "STUDY_SEED",
    "STUDY_RUNS",
    "STUDY_INITIAL_ERROR",
]

# -- the data of the exercises -----------------------------------------------------------------------------------------
#: Exercise 5.1: the speed the vehicle converts travel times with (m/s) ...
ASSUMED_SPEED = 1480.0
#: ... the mean true effective sound speed (m/s) ...
EFFECTIVE_SPEED = 1510.0
#: ... its standard deviation from ping to ping (m/s) ...
SPEED_SIGMA = 2.0
#: ... and the true range at which the mean error is asked (m).
TRUE_RANGE = 2500.0

#: Exercise 5.3: a converged filter at about 2000 m from the beacon (all in m²): the terms of the fading rule,
#: :math:`\mathcal N_k = \mu_\gamma^2 C P_{k-1} C^T`, :math:`\mu_\gamma^2 C Q C^T`, :math:`\sigma_\gamma^2 T_k`, the
#: range noise variance :math:`R`, and the forgetting factor :math:`\rho`.
STEADY: dict[str, float] = {"N": 0.5, "CQC": 0.78, "mult": 1.78, "R": 0.49, "rho": 0.95}
#: ... and paper D's weakening factor there, about the predicted range (m).
BETA_RANGE = 2000.0

#: Exercise 5.4: the Monte Carlo study (seed, number of runs, initial error in m).
STUDY_SEED = 2019
STUDY_RUNS = 200
STUDY_INITIAL_ERROR = 30.0


# -- exercise 5.1: the multiplicative factor ---------------------------------------------------------------------------
def check_mu_gamma(answer: Any) -> Feedback:
    r"""Check :math:`\mu_\gamma = c / c_\mathrm e = 1 + \Delta c / c_\mathrm e` for exercise 5.1.

    Parameters
    ----------
    answer : float or None
        The student's mean factor (dimensionless).

    Returns
    -------
    Feedback
        The verdict; paper D's sign slip :math:`1 - \Delta c / c_\mathrm e`, the inverse ratio and
        :math:`\Delta c / c_\mathrm e` without the 1 are recognised.

    Examples
    --------
    >>> # the inverse ratio
    >>> check_mu_gamma(EFFECTIVE_SPEED / ASSUMED_SPEED).correct
    False
    >>> check_mu_gamma(ASSUMED_SPEED / EFFECTIVE_SPEED).correct
    True
    """
    c, ce = ASSUMED_SPEED, EFFECTIVE_SPEED
    expected, _ = range_factor_moments(c, ce, SPEED_SIGMA)
    dc = c - ce
    too_long = ("The factor must be below 1: the vehicle assumes a speed that is too low, so it converts a travel "
                "time into a range that is too short. Your value is what paper D's eq. (30) prints (a sign slip), "
                "or the ratio upside down: the measured range is c·τ = (c / c_e)·r, assumed speed over true one.")
    mistakes = {
        1.0 - dc / ce: too_long,
        ce / c: too_long,
        dc / ce: "That is the relative error γ − 1; the factor itself is 1 + Δc / c_e.",
        -dc / ce: "That is minus the relative error; the factor itself is 1 + Δc / c_e, with Δc = c − c_e < 0 "
                  "here.",
    }
    first_order = 1.0 + dc / c                     # dividing by the assumed speed: the same to first order
    explanation = (f"The ranges are {100 * (1 - expected):.2f} % short on average. Writing 1 + Δc / c instead "
                   "(dividing by the assumed speed) is the same to first order.")
    a = answer if isinstance(answer, (int, float)) and not isinstance(answer, bool) else None
    try:
        a = None if a is None or not math.isfinite(float(a)) else float(a)
    except OverflowError:                          # an int beyond any float: check_number below explains
        a = None
    if a is not None and abs(a - first_order) <= _MU_RTOL * abs(first_order):
        return check_number(answer, first_order, rtol=_MU_RTOL, name="μ_γ", explanation=explanation)
    mistakes[round(expected, 2)] = (
        "That is μ_γ rounded to two decimals (the chapter's 0.98 is 1470/1500 rounded). Here the speeds are "
        f"{c:g} and {ce:g} m/s: give c / c_e to at least four digits.")
    return check_number(answer, expected, rtol=_MU_RTOL, name="μ_γ", common_mistakes=mistakes,
                        hint="A range is the travel time times the assumed speed: r_meas = c·τ with τ = r / c_e.",
                        explanation=explanation)


#: Relative tolerance of μ_γ: 4 significant digits pass (0.9801), the two-decimal 0.98 does not.
_MU_RTOL = 5e-5


def check_sigma_gamma(answer: Any) -> Feedback:
    r"""Check :math:`\sigma_\gamma \approx \sigma_c / c_\mathrm e` for exercise 5.1 (first-order forms accepted).

    Parameters
    ----------
    answer : float or None
        The student's standard deviation of the factor (dimensionless).

    Returns
    -------
    Feedback
        The verdict; the variance instead of the standard deviation, :math:`\sigma_c` itself and a factor of
        :math:`c` too many are recognised.

    Examples
    --------
    >>> check_sigma_gamma(SPEED_SIGMA).correct  # σ_c itself, in m/s
    False
    >>> check_sigma_gamma(SPEED_SIGMA / EFFECTIVE_SPEED).correct
    True
    """
    c, ce, sc = ASSUMED_SPEED, EFFECTIVE_SPEED, SPEED_SIGMA
    _, expected = range_factor_moments(c, ce, sc)
    mistakes = {
        (sc / ce) ** 2: "That is the variance σ_γ²; the task asks for the standard deviation σ_γ.",
        sc: "That is σ_c, in m/s; divide by the sound speed to make it a relative (dimensionless) spread.",
        sc / ce**2: "Divide σ_c by the speed once: γ ≈ 1 + (Δc + δc)/c_e, so σ_γ ≈ σ_c / c_e.",
    }
    return check_number(answer, expected, rtol=0.05, name="σ_γ", common_mistakes=mistakes,
                        hint="γ ≈ 1 + (Δc + δc) / c_e with δc ~ N(0, σ_c²): its spread is that of δc / c_e.",
                        explanation="σ_c / c_e, c·σ_c / c_e² and σ_c / c all agree to first order (within a few "
                                    "%).")


def check_mean_range_error(answer: Any) -> Feedback:
    r"""Check the mean range error :math:`(\mu_\gamma - 1)\, r` at ``TRUE_RANGE`` for exercise 5.1.

    Parameters
    ----------
    answer : float or None
        The student's mean error, measured minus true [m].

    Returns
    -------
    Feedback
        The verdict; the wrong sign and the error of the measured (not true) range are recognised.

    Examples
    --------
    >>> mu = ASSUMED_SPEED / EFFECTIVE_SPEED
    >>> # the mean measured range, not its error
    >>> check_mean_range_error(mu * TRUE_RANGE).correct
    False
    >>> check_mean_range_error((mu - 1.0) * TRUE_RANGE).correct
    True
    """
    mu, _ = range_factor_moments(ASSUMED_SPEED, EFFECTIVE_SPEED, SPEED_SIGMA)
    expected = (mu - 1.0) * TRUE_RANGE
    mistakes = {
        -expected: "Measured minus true: the ranges are short, so the mean error is negative.",
        mu * TRUE_RANGE: "That is the mean measured range; the error is the measured range minus the true one.",
    }
    return check_number(answer, expected, rtol=2e-3, name="the mean range error", units="m",
                        common_mistakes=mistakes, hint="The mean measured range is μ_γ·r; subtract r.",
                        explanation="It grows in proportion to the range: multiplicative noise.")


# -- exercise 5.2: the fading factor -----------------------------------------------------------------------------------
def fading_factors_reference(innovations: ArrayLike, predicted: ArrayLike, subtracted: ArrayLike,
                             rho: float) -> np.ndarray:
    r"""The fading factors of a sequence of scalar innovations (paper D, eqs. 17-20; Zhou and Xi 1990).

    .. math::

        V_1 = \tilde z_1^2, \quad V_k = \frac{\rho V_{k-1} + \tilde z_k^2}{1 + \rho}, \qquad
        \lambda_k = \max\Big(1, \frac{V_k - s_k}{\mathcal N_k}\Big),

    with :math:`s_k` the terms subtracted in :math:`\mathcal M_k` (:math:`\sigma_\gamma^2 T_k + \mu_\gamma^2
    C Q C^T + \beta_k R`).

    Parameters
    ----------
    innovations : array_like, shape (K,)
        :math:`\tilde z_k` [m].
    predicted : array_like, shape (K,)
        :math:`\mathcal N_k` [m²], > 0.
    subtracted : array_like, shape (K,)
        :math:`s_k` [m²].
    rho : float
        Forgetting factor in (0, 1].

    Returns
    -------
    ndarray, shape (K,)
        :math:`\lambda_k`.

    Examples
    --------
    >>> innovations = [0.5, 4.0, 0.5]
    >>> lam = fading_factors_reference(innovations, [0.5] * 3, [2.5] * 3, 0.95)
    >>> # a large innovation at step 2 lifts the factor for a while
    >>> np.round(lam, 2)
    array([ 1.  , 11.65,  3.37])
    """
    z = np.asarray(innovations, dtype=float)
    n = np.asarray(predicted, dtype=float)
    s = np.asarray(subtracted, dtype=float)
    lam = np.empty_like(z)
    V = 0.0
    for k in range(len(z)):
        V = z[k] ** 2 if k == 0 else (rho * V + z[k] ** 2) / (1.0 + rho)
        lam[k] = max(1.0, (V - s[k]) / n[k])
    return lam


def _fading_cases() -> list[Case]:
    quiet_z = np.array([0.8, -1.1, 0.3, 1.5, -0.6, 0.9])
    s_quiet = np.full(6, 2.5)
    return [
        Case((quiet_z, np.full(6, 0.5), s_quiet, 0.95),
             label="small innovations (the model is right): every λ must be 1",
             hint="λ = max(1, M/N): a fading factor never shrinks the covariance, so it is never below 1."),
        Case((np.array([12.0]), np.array([0.5]), np.array([2.5]), 0.95),
             label="a single step: V₁ is the first innovation squared",
             hint="Start the recursion with V₁ = y₁² (paper D, eq. 20), not with V = 0."),
        Case((np.array([1.0, 20.0, 1.0, 1.0, 1.0]), np.full(5, 0.5), np.full(5, 2.5), 0.5),
             label="a gross error at step 2 with ρ = 0.5",
             hint="The forgetting factor weighs the *old* value: V_k = (ρ V_{k−1} + y_k²) / (1 + ρ)."),
        Case((np.array([3.0, -4.0, 8.0, -2.0]), np.array([0.4, 0.6, 0.8, 1.0]), np.array([1.0, 2.0, 3.0, 4.0]),
              1.0),
             label="ρ = 1 (no forgetting) and terms that change every step",
             hint="Use the k-th entry of `predicted` and `subtracted` at step k."),
    ]


def _fading_factors_slip(innovations: Any, predicted: Any, subtracted: Any, rho: float) -> np.ndarray:
    """The precedence slip λ_k = max(1, V_k/N_k − s_k) (the division before the subtraction)."""
    z = np.asarray(innovations, dtype=float)
    lam = np.empty_like(z)
    V = 0.0
    for k in range(len(z)):
        V = z[k] ** 2 if k == 0 else (rho * V + z[k] ** 2) / (1.0 + rho)
        lam[k] = max(1.0, V / predicted[k] - subtracted[k])
    return lam


def check_fading_factors(func: Any) -> Feedback:
    r"""Check a student's ``fading_factors(innovations, predicted, subtracted, rho)`` (exercise 5.2).

    The specification is that of ``fading_factors_reference``; the input arrays must not be modified.

    Parameters
    ----------
    func : callable or None
        The student's function.

    Returns
    -------
    Feedback
        The verdict; the first failing case is reported with its inputs, the expected and the student's factors,
        and a hint aimed at the mistake that case catches (no ``max``, a wrong start, a wrong weighting).

    Examples
    --------
    >>> # forgets that λ is at least 1
    >>> def no_max(innovations, predicted, subtracted, rho):
    ...     z = np.asarray(innovations, dtype=float)
    ...     n = np.asarray(predicted, dtype=float)
    ...     s = np.asarray(subtracted, dtype=float)
    ...     V = np.empty_like(z)
    ...     V[0] = z[0] ** 2
    ...     for k in range(1, len(z)):
    ...         V[k] = (rho * V[k - 1] + z[k] ** 2) / (1 + rho)
    ...     return (V - s) / n
    >>> check_fading_factors(no_max).correct
    False
    >>> check_fading_factors(fading_factors_reference).correct
    True
    """
    if callable(func):
        # the slip λ = V/N − s passes some cases and fails with the hint of another: recognise it first
        args = (np.array([12.0, 3.0]), np.array([0.5, 0.8]), np.array([2.5, 1.5]), 0.95)
        got, stopped = _probe_student(func, args, "fading_factors")
        if stopped is not None:
            return stopped                         # a loop or sys.exit(), stopped within the time limit
        if (got is not None and got.shape == (2,)
                and np.allclose(got, _fading_factors_slip(*args), rtol=1e-9)
                and not np.allclose(got, fading_factors_reference(*args), rtol=1e-9)):
            return Feedback(False, "Not yet: your fading factors are max(1, V/N − s); the rule is "
                                   "max(1, (V − s)/N).",
                            hint="Subtract the terms s_k from V_k first, then divide by N_k: "
                                 "lam = max(1.0, (V - s[k]) / n[k]) (mind the parentheses).",
                            details={"answer": got.tolist()})
    return check_function(
        func, fading_factors_reference, _fading_cases(), name="fading_factors",
        compare=lambda got, expected: check_array(got, expected, rtol=1e-9, atol=1e-12, name="the fading factors"),
        hint="Loop over the steps: update V with the forgetting factor, then λ = max(1, (V − s) / N).",
        explanation="One large innovation lifts V for a few steps (its weight decays like (ρ/(1+ρ))^j), so λ "
                    "stays above 1 after it too.")


# -- exercise 5.3: the weakening factor as a threshold -----------------------------------------------------------------
def threshold_innovation(beta: float, steady: dict[str, float] | None = None) -> float:
    r"""The smallest :math:`|\tilde z_k|` that makes :math:`\lambda_k > 1` when :math:`V_{k-1}` sits at its
    expected value :math:`\bar V = \mathcal N + \mu_\gamma^2 CQC^T + \sigma_\gamma^2 T + R` (exercise 5.3).

    :math:`\lambda_k > 1 \iff V_k > \bar V + (\beta - 1) R` and :math:`V_k = (\rho \bar V + \tilde z_k^2)/(1 +
    \rho)`, so

    .. math::

        |\tilde z_k| > \sqrt{\bar V + (1 + \rho)(\beta - 1) R}.

    Parameters
    ----------
    beta : float
        Weakening factor (>= 0).
    steady : dict, optional
        The terms (default ``STEADY``): ``N`` > 0, ``CQC`` >= 0, ``mult`` >= 0, ``R`` > 0 [m²] and ``rho`` in
        (0, 1].

    Returns
    -------
    float
        The threshold [m]; 0 when the right-hand side is negative (a weakening factor so small that every
        innovation makes :math:`\lambda_k > 1`).

    Examples
    --------
    >>> round(threshold_innovation(1.0), 2)
    1.88
    >>> bool(threshold_innovation(BETA_RANGE) > 20 * threshold_innovation(1.0))
    True
    """
    b = as_scalar("beta", beta, domain="nonnegative")
    st = STEADY if steady is None else _steady_terms(steady)
    vbar = st["N"] + st["CQC"] + st["mult"] + st["R"]
    return math.sqrt(max(vbar + (1.0 + st["rho"]) * (b - 1.0) * st["R"], 0.0))


def _steady_terms(steady: Any) -> dict[str, float]:
    """``steady`` as a dict of the five terms of ``STEADY``, each checked under its name (``steady['R']``...)."""
    if not isinstance(steady, Mapping):
        raise TypeError(f"steady must be a dict with the keys {list(STEADY)}; got {type(steady).__name__}")
    if set(steady) != set(STEADY):
        raise ValueError(f"steady must have exactly the keys {list(STEADY)}; got {list(steady)}")
    domains = {"N": "positive", "CQC": "nonnegative", "mult": "nonnegative", "R": "positive", "rho": "positive"}
    out = {key: as_scalar(f"steady[{key!r}]", steady[key], domain=domain) for key, domain in domains.items()}
    if out["rho"] > 1.0:
        raise ValueError(f"steady['rho'] must lie in (0, 1]; got {out['rho']:g}")
    return out


def _threshold_mistakes(beta: float) -> dict[float, str]:
    st = STEADY
    vbar = st["N"] + st["CQC"] + st["mult"] + st["R"]
    out = {
        threshold_innovation(beta) ** 2: "That is the threshold on y² (m²); take the square root for metres.",
        math.sqrt(vbar + (beta - 1.0) * st["R"]): "One innovation enters V with weight 1/(1 + ρ): y² must exceed "
                                                  "(1 + ρ) times the margin, not the margin itself.",
    }
    if beta == 1.0:
        out[math.sqrt((1.0 + st["rho"]) * vbar)] = ("V_{k−1} = V̄ keeps its weight ρ/(1 + ρ): y² > V̄ + "
                                                    "(1 + ρ)(β − 1)R, not (1 + ρ)(V̄ + (β − 1)R).")
    else:
        out[math.sqrt(vbar + (1.0 + st["rho"]) * (beta - 1.0))] = ("The weakening factor multiplies R = "
                                                                    f"{st['R']} m²: the margin is (β − 1)·R.")
    return out


def check_threshold_beta_one(answer: Any) -> Feedback:
    r"""Check the threshold innovation of exercise 5.3 with :math:`\beta = 1` (Zhou and Xi's filter).

    Parameters
    ----------
    answer : float or None
        The student's threshold [m].

    Returns
    -------
    Feedback
        The verdict; the square, a missing :math:`1 + \rho` and a misplaced one are recognised.

    Examples
    --------
    >>> # m², not m
    >>> check_threshold_beta_one(threshold_innovation(1.0) ** 2).correct
    False
    >>> check_threshold_beta_one(threshold_innovation(1.0)).correct
    True
    """
    expected = threshold_innovation(1.0)
    # rtol 3e-3: a threshold rounded to three significant digits (1.88 m) passes
    return check_number(answer, expected, rtol=3e-3, name="the threshold with β = 1", units="m",
                        common_mistakes=_threshold_mistakes(1.0),
                        hint="With V_{k−1} = V̄, λ_k > 1 exactly when V_k > V̄ + (β − 1)R; solve for y_k.",
                        explanation="With β = 1 any innovation larger than its own standard deviation √V̄ triggers "
                                    "the fading factor: about a third of all steps under a correct model.")


def check_threshold_beta_range(answer: Any) -> Feedback:
    r"""Check the threshold innovation of exercise 5.3 with paper D's :math:`\beta = 2000` (about the range).

    Parameters
    ----------
    answer : float or None
        The student's threshold [m].

    Returns
    -------
    Feedback
        The verdict; the square, a missing :math:`1 + \rho` and :math:`\beta` not multiplied by :math:`R` are
        recognised.

    Examples
    --------
    >>> # the threshold of β = 1
    >>> check_threshold_beta_range(threshold_innovation(1.0)).correct
    False
    >>> check_threshold_beta_range(threshold_innovation(BETA_RANGE)).correct
    True
    """
    expected = threshold_innovation(BETA_RANGE)
    return check_number(answer, expected, rtol=2e-3, name=f"the threshold with β = {BETA_RANGE:g}", units="m",
                        common_mistakes=_threshold_mistakes(BETA_RANGE),
                        hint="Same rule, with β = 2000: V_k must exceed V̄ + (β − 1)R.",
                        explanation=f"About {expected / threshold_innovation(1.0):.0f} times the threshold of "
                                    "β = 1: the weakening factor turns the fading rule into a gate for gross errors, "
                                    "and it grows like the square root of the range.")


# -- exercise 5.4: EKF, multiplicative EKF, ISFEKF ---------------------------------------------------------------------
def study() -> dict[str, Any]:
    """The Monte Carlo study of exercise 5.4: paper D's scenario, ``STUDY_RUNS`` runs, a start
    ``STUDY_INITIAL_ERROR`` metres off in a random direction.

    Returns
    -------
    dict
        ``x0`` (M, 2), ``P0`` (2, 2), ``u`` (M, K, 2), ``z`` (M, K), ``Q`` (2, 2), ``R`` (float), ``truth``
        (M, K, 2) and ``times`` (K,).

    Examples
    --------
    >>> s = study()
    >>> s["z"].shape == (STUDY_RUNS, s["times"].size)
    True
    >>> s["x0"].shape, s["truth"].shape[-1]
    ((200, 2), 2)
    """
    rng = np.random.default_rng(STUDY_SEED)
    sc = scenarios.approach_with_turn_scenario(rng, n_runs=STUDY_RUNS)
    angle = rng.uniform(0.0, 2.0 * np.pi, STUDY_RUNS)
    d0 = STUDY_INITIAL_ERROR
    x0 = sc.true_positions[:, 0] + d0 * np.column_stack([np.cos(angle), np.sin(angle)])
    return {"x0": x0, "P0": np.eye(2) * d0**2, "u": np.array(sc.dr_displacements), "z": np.array(sc.ranges),
            "Q": np.eye(2) * 0.81, "R": 0.49, "truth": np.array(sc.true_positions), "times": np.array(sc.times)}


def final_rmse(estimates: ArrayLike, truth: ArrayLike) -> float:
    r"""RMS over the runs of the position error at the last epoch [m].

    Parameters
    ----------
    estimates : array_like, shape (M, K, 2) or (K, 2)
        Filter estimates of ``M`` runs (or one run); only the last epoch is read (NaN before it, where a filter
        has not started, is fine).
    truth : array_like, shape (M, K, 2) or (K, 2)
        True positions (a ``(K, 2)`` truth is shared by every run).

    Returns
    -------
    float
        :math:`\sqrt{\frac{1}{M}\sum_j \lVert \hat x_{j,K} - x_{j,K} \rVert^2}`.

    Raises
    ------
    ValueError
        If an estimate at the last epoch is NaN or infinite (a run that diverged has no final error).

    Examples
    --------
    >>> truth = np.zeros((4, 2))
    >>> estimates = truth + [3.0, 4.0]  # 5 m off at every epoch
    >>> final_rmse(estimates, truth)
    5.0
    """
    err = final_errors(estimates, truth)
    if not np.all(np.isfinite(err)):
        bad = np.flatnonzero(~np.isfinite(err))
        raise ValueError(f"estimates hold NaN or infinity at the last epoch in {bad.size} run(s) (the first: run "
                         f"{bad[0]}): a run that diverged has no final error; look at that run")
    return float(np.sqrt(np.mean(err**2)))


def _study_results() -> dict[str, np.ndarray]:
    s = study()
    mu, sigma = range_factor_moments(1470.0, 1500.0, 1.0)
    common = (s["x0"], s["P0"], s["u"], s["z"], s["Q"], s["R"])
    return {
        "ekf": range_only_ekf(*common).x,
        "mult": fading_ekf(*common, mu_gamma=mu, sigma_gamma=sigma, fading=False).x,
        "isfekf": fading_ekf(*common, mu_gamma=mu, sigma_gamma=sigma, rho=0.95, beta="range").x,
        "truth": s["truth"],
    }


def check_final_rmse(rmse_ekf: Any, rmse_mult: Any, rmse_isfekf: Any) -> Feedback:
    r"""Check the three final RMS errors of exercise 5.4 (EKF, multiplicative-noise EKF without fading, ISFEKF).

    Parameters
    ----------
    rmse_ekf : float or None
        Final RMSE of the additive-noise EKF [m].
    rmse_mult : float or None
        Final RMSE of the multiplicative-noise EKF, ``fading=False`` [m].
    rmse_isfekf : float or None
        Final RMSE of the ISFEKF [m].

    Returns
    -------
    Feedback
        The first of the three that is wrong, with a hint (the mean error instead of the RMS error, the RMSE over
        all epochs instead of the last one, the paper's :math:`\mu_\gamma = 1.02`); correct when all three are.

    Examples
    --------
    >>> from uwtutor.filters.ekf import range_only_ekf
    >>> from uwtutor.filters.fading import fading_ekf, range_factor_moments
    >>> s = study()
    >>> args = (s["x0"], s["P0"], s["u"], s["z"], s["Q"], s["R"])
    >>> mu, sigma = range_factor_moments(1470.0, 1500.0, 1.0)
    >>> e = final_rmse(range_only_ekf(*args).x, s["truth"])
    >>> mult = fading_ekf(*args, mu_gamma=mu, sigma_gamma=sigma, fading=False)
    >>> m = final_rmse(mult.x, s["truth"])
    >>> isfekf = fading_ekf(*args, mu_gamma=mu, sigma_gamma=sigma, rho=0.95,
    ...                     beta="range")
    >>> i = final_rmse(isfekf.x, s["truth"])
    >>> check_final_rmse(e, m, 2 * i).correct  # the ISFEKF's RMSE doubled
    False
    >>> check_final_rmse(e, m, i).correct
    True
    """
    res = _study_results()
    truth = res["truth"]
    labels = {"ekf": ("rmse_ekf", "the EKF's final RMSE"), "mult": ("rmse_mult", "the multiplicative EKF's final RMSE"),
              "isfekf": ("rmse_isfekf", "the ISFEKF's final RMSE")}
    answers = {"ekf": rmse_ekf, "mult": rmse_mult, "isfekf": rmse_isfekf}
    expected = {key: final_rmse(res[key], truth) for key in answers}
    for key, answer in answers.items():
        x = res[key]
        err = np.linalg.norm(x - truth, axis=-1)
        mistakes = {
            float(np.mean(err[:, -1])): "That is the mean error; the RMSE is the square root of the mean squared "
                                        "error: np.sqrt(np.mean(err**2)).",
            float(np.sqrt(np.mean(err**2))): "That is the RMSE over all epochs; the task asks for the last epoch "
                                             "only (index -1).",
            float(np.median(err[:, -1])): "That is the median error; the task asks for the root mean square.",
        }
        if key != "ekf":
            s = study()
            wrong_mu = fading_ekf(s["x0"], s["P0"], s["u"], s["z"], s["Q"], s["R"], mu_gamma=1.02,
                                  sigma_gamma=1 / 1500, fading=(key == "isfekf"))
            mistakes[final_rmse(wrong_mu.x, truth)] = ("μ_γ = 1.02 is paper D's sign slip: 1470 m/s assumed "
                                                       "against 1500 m/s true makes the ranges 2 % short, "
                                                       "μ_γ = 0.98.")
        if key == "isfekf":
            s = study()
            beta_one_hint = (
                "That is the filter with β = 1 (Zhou and Xi's fading rule, no weakening factor): every innovation "
                "larger than its own standard deviation fades the filter. Paper D's ISFEKF weakens the rule with "
                "β of about the range: beta=\"range\".")
            # the task's rounded μ_γ = 0.98, σ_γ = 1/1500 and the moments of the study (with β = 1 they differ)
            for mu, sigma in ((0.98, 1 / 1500), range_factor_moments(1470.0, 1500.0, 1.0)):
                beta_one = fading_ekf(s["x0"], s["P0"], s["u"], s["z"], s["Q"], s["R"], mu_gamma=mu,
                                      sigma_gamma=sigma, rho=0.95, beta=1.0)
                mistakes.setdefault(final_rmse(beta_one.x, truth), beta_one_hint)
        fb = check_number(answer, expected[key], rtol=1e-3, name=labels[key][1], units="m", common_mistakes=mistakes,
                          hint="Run the filter on the study, then `ch05.final_rmse(result.x, s['truth'])`.")
        if not fb.correct:
            return Feedback(False, f"`{labels[key][0]}`: {fb.message}", hint=fb.hint, details=fb.details)
    return Feedback(True, f"Correct: EKF {expected['ekf']:.1f} m, multiplicative EKF {expected['mult']:.1f} m, "
                          f"ISFEKF {expected['isfekf']:.1f} m.",
                    details={"expected": expected})


# -- exercise 5.5: one ISFEKF step, written by the student -------------------------------------------------------------
#: Exercise 5.5: the filter constants (paper D's simulation; beacon at the origin) ...
ISF_STEP_CONSTANTS: dict[str, float] = {"mu_gamma": 0.98, "sigma_gamma": 1.0 / 1500.0, "rho": 0.95, "R": 0.49,
                                        "q": 0.81}
#: ... the seed of the run the checker replays, its initial error (m) and the number of steps it compares.
ISF_STEP_SEED, ISF_STEP_INITIAL_ERROR, ISF_STEP_STEPS = 2019, 150.0, 12


def isfekf_step_reference(x: ArrayLike, P: ArrayLike, m: ArrayLike, Xi: ArrayLike, V: float | None, u: ArrayLike,
                          z: float, Q: ArrayLike, R: float, mu_gamma: float, sigma_gamma: float,
                          rho: float) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
                                               NDArray[np.float64], float, float]:
    r"""One step of paper D's ISFEKF for a beacon at the origin, in the order of chapter 5's box.

    Parameters
    ----------
    x, P : array_like, shapes (2,), (2, 2)
        :math:`\hat{\mathbf x}_{k-1|k-1}`, :math:`\mathbf P_{k-1|k-1}` [m, m²].
    m, Xi : array_like, shapes (2,), (2, 2)
        :math:`\mathbf m_{k-1}`, :math:`\boldsymbol\Xi_{k-1}`.
    V : float or None
        :math:`V_{k-1}` [m²], ``None`` before the first range.
    u : array_like, shape (2,)
        :math:`\mathbf u_k` [m].
    z : float
        :math:`z_k` [m] (finite).
    Q, R, mu_gamma, sigma_gamma, rho
        The filter's constants.

    Returns
    -------
    tuple
        ``(x, P, m, Xi, V, lam)`` after the step: :math:`\hat{\mathbf x}_{k|k}`, :math:`\mathbf P_{k|k}`,
        :math:`\mathbf m_k`, :math:`\boldsymbol\Xi_k`, :math:`V_k` and the fading factor :math:`\lambda_k`.

    Examples
    --------
    >>> d = isfekf_step_run()
    >>> x, P, m, Xi, V, lam = isfekf_step_reference(
    ...     d["x0"], d["P0"], d["x0"], d["P0"] + np.outer(d["x0"], d["x0"]), None,
    ...     d["u"][0], d["z"][0], d["Q"],
    ...     0.49, mu_gamma=0.98, sigma_gamma=1 / 1500, rho=0.95)
    >>> x.shape, P.shape, bool(lam >= 1.0)
    ((2,), (2, 2), True)
    """
    x, P, m, Xi, u, Q = (np.asarray(a, dtype=float) for a in (x, P, m, Xi, u, Q))
    Xi_k: NDArray[np.float64] = Xi + np.outer(m, u) + np.outer(u, m) + np.outer(u, u) + Q    # 1. moments (old m)
    m_k: NDArray[np.float64] = m + u
    x_pred = x + u                                                          # 2. predicted mean, linearization
    r = float(np.hypot(*x_pred))
    H = x_pred / r                                                          # d_k = 0 (beacon at the origin)
    T = max(float(H @ Xi_k @ H), 0.0)
    y = z - mu_gamma * r                                                    # 3. innovation and its power
    V = y * y if V is None else (rho * V + y * y) / (1.0 + rho)
    beta = float(H @ m_k)                                                   # 4. fading factor
    num = V - sigma_gamma ** 2 * T - mu_gamma ** 2 * float(H @ Q @ H) - beta * R
    den = mu_gamma ** 2 * float(H @ P @ H)
    lam = max(1.0, num / den) if den > 0.0 else 1.0
    P_pred = lam * P + Q                                                    # 5. predicted covariance
    noise = sigma_gamma ** 2 * T + R                                        # 6. update (Joseph form)
    S = mu_gamma ** 2 * float(H @ P_pred @ H) + noise
    K = (mu_gamma / S) * (P_pred @ H)
    A = np.eye(2) - mu_gamma * np.outer(K, H)
    return x_pred + K * y, A @ P_pred @ A.T + noise * np.outer(K, K), m_k, Xi_k, V, lam


def isfekf_step_run() -> dict[str, Any]:
    """The run exercise 5.5's checker replays: one run of paper D's approach, started ``ISF_STEP_INITIAL_ERROR`` off.

    Returns
    -------
    dict
        ``x0``, ``P0`` (the start), ``u`` (K, 2) and ``z`` (K,) for ``K = ISF_STEP_STEPS``, and ``Q`` (2, 2).

    Examples
    --------
    >>> d = isfekf_step_run()
    >>> d["u"].shape, d["z"].shape
    ((12, 2), (12,))
    """
    rng = np.random.default_rng(ISF_STEP_SEED)
    sc = scenarios.approach_with_turn_scenario(rng, n_runs=1)
    angle = rng.uniform(0.0, 2 * np.pi)
    d0 = ISF_STEP_INITIAL_ERROR
    x0 = np.asarray(sc.true_positions)[0, 0] + d0 * np.array([np.cos(angle), np.sin(angle)])
    K = ISF_STEP_STEPS
    return {"x0": x0, "P0": np.eye(2) * d0 ** 2, "u": np.asarray(sc.dr_displacements)[0, :K],
            "z": np.asarray(sc.ranges)[0, :K], "Q": np.eye(2) * ISF_STEP_CONSTANTS["q"]}


def check_isfekf_step(func: Any) -> Feedback:
    r"""Check a student's ``isfekf_step(x, P, m, Xi, V, u, z, Q, R, mu_gamma, sigma_gamma, rho)`` (exercise 5.5).

    The function is run for ``ISF_STEP_STEPS`` steps of one run of paper D's approach from 150 m off (the first
    steps have large fading factors), its estimate, covariance and fading factor compared at every step with
    ``uwtutor.filters.FadingEKF`` (``beta="range"``) and its moments and innovation power with
    ``isfekf_step_reference``. The first disagreement is reported with a hint aimed at that part of the step.

    Parameters
    ----------
    func : callable or None
        The student's function, returning ``(x, P, m, Xi, V, lam)``.

    Returns
    -------
    Feedback
        The verdict.

    Examples
    --------
    >>> # always λ = 1
    >>> def no_fading(x, P, m, Xi, V, u, z, Q, R, mu_gamma, sigma_gamma, rho):
    ...     out = isfekf_step_reference(x, P, m, Xi, V, u, z, Q, R, mu_gamma,
    ...                                 sigma_gamma, rho)
    ...     return out[:5] + (1.0,)
    >>> check_isfekf_step(no_fading).correct
    False
    >>> check_isfekf_step(isfekf_step_reference).correct
    True
    """
    from ..filters.fading import FadingEKF
    from .checks import _is_unanswered, not_answered
    if _is_unanswered(func):
        return not_answered("isfekf_step")
    if not callable(func):
        return Feedback(False, f"Not yet: isfekf_step should be a function; got {type(func).__name__}.",
                        hint="Define it with def isfekf_step(x, P, m, Xi, V, u, z, Q, R, mu_gamma, sigma_gamma, rho):")
    c = ISF_STEP_CONSTANTS
    d = isfekf_step_run()
    Q, R = d["Q"], c["R"]
    lib = FadingEKF(d["x0"], d["P0"], Q, R, mu_gamma=c["mu_gamma"], sigma_gamma=c["sigma_gamma"], rho=c["rho"],
                    beta="range")
    # (x, P, m, Xi, V): V is None before the first range
    state: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float | None] = (
        d["x0"].copy(), d["P0"].copy(), d["x0"].copy(), d["P0"] + np.outer(d["x0"], d["x0"]), None)
    ref_state = state
    hints = {
        "m": "Moments first: m_k = m_{k−1} + u_k, and Ξ_k = Ξ_{k−1} + m_{k−1}u_kᵀ + u_k m_{k−1}ᵀ + u_k u_kᵀ + Q, "
             "with the *old* m in the cross terms.",
        "Xi": "Ξ_k = Ξ_{k−1} + m_{k−1}u_kᵀ + u_k m_{k−1}ᵀ + u_k u_kᵀ + Q: use m_{k−1} (before adding u_k) in the "
              "cross terms, and add Q.",
        "V": "The innovation is y = z − μ_γ‖x̂_{k|k−1}‖ (with the *predicted* position). V starts as y² at the first "
             "range (V is None), then V = (ρ V_{k−1} + y²)/(1 + ρ).",
        "lam": "λ = max(1, M/N) with M = V − σ_γ²T − μ_γ² H Q Hᵀ − β R, β = H m_k (the moments, not the estimate), "
               "and N = μ_γ² H P_{k−1|k−1} Hᵀ (the *previous posterior*, before fading and before Q).",
        "P": "Predict the covariance with the fading factor, P_{k|k−1} = λ P_{k−1|k−1} + Q (not λ(P + Q)); then "
             "S = σ_γ²T + μ_γ² H P_{k|k−1} Hᵀ + R, K = (μ_γ/S) P_{k|k−1} Hᵀ and the Joseph form with the noise "
             "σ_γ²T + R.",
        "x": "x̂_{k|k} = x̂_{k|k−1} + K y with K = (μ_γ/S) P_{k|k−1} Hᵀ: the gain carries a factor μ_γ.",
    }
    for k in range(ISF_STEP_STEPS):
        u, z = d["u"][k], float(d["z"][k])
        x, P, m, Xi, V = state
        try:
            out, stopped = run_student(func, np.array(x), np.array(P), np.array(m), np.array(Xi), V, u.copy(), z,
                                       Q.copy(), R, c["mu_gamma"], c["sigma_gamma"], c["rho"], name="isfekf_step",
                                       reraise=(NotImplementedError,))
        except NotImplementedError:
            return Feedback(False, "No answer yet: `isfekf_step` still raises NotImplementedError.",
                            hint="Replace the `raise NotImplementedError(...)` line in its body with your code, run "
                                 "that cell and this one again.")
        if stopped is not None:                    # a loop, sys.exit() or an exception, stopped within the limit
            return Feedback(False, f"{stopped.message} (at step {k})",
                            hint="Run it by hand on the first step of `ch05.isfekf_step_run()` and read the trace.",
                            details=stopped.details)
        if not isinstance(out, tuple) or len(out) != 6:
            return Feedback(False, "Not yet: isfekf_step should return a tuple of six: (x, P, m, Xi, V, lam).",
                            hint="End the function with return x, P, m, Xi, V, lam.")
        ref = isfekf_step_reference(*ref_state, u, z, Q, R, c["mu_gamma"], c["sigma_gamma"], c["rho"])
        lib.predict(u)
        lib.update(z)
        expected = {"m": ref[2], "Xi": ref[3], "V": ref[4], "lam": float(lib.fading_factor),
                    "P": lib.P, "x": lib.x}
        got = dict(zip(("x", "P", "m", "Xi", "V", "lam"), out))
        for name in ("m", "Xi", "V", "lam", "P", "x"):
            e = np.asarray(expected[name], dtype=float)
            # complex numbers, text, None inside or the wrong shape: refused by name, never coerced
            g, refusal = parse_real_array(got[name], name, e.shape)
            if refusal is not None:
                return Feedback(False, f"{refusal.message} (at step {k})", hint=refusal.hint,
                                details={"step": k, "quantity": name})
            assert g is not None                   # parse_real_array gives an array where it refuses nothing
            if g.shape != e.shape or not np.allclose(g, e, rtol=1e-4, atol=1e-8 * max(1.0, float(np.max(np.abs(e))))):
                return Feedback(False, f"Not yet: at step {k} your {name} is {np.round(g, 4).tolist()}, the library's "
                                       f"{np.round(e, 4).tolist()} (steps before it agree).",
                                hint=hints[name], details={"step": k, "quantity": name})
        state = (np.array(out[0]), np.array(out[1]), np.array(out[2]), np.array(out[3]), out[4])   # all real: checked
        ref_state = ref[:5]
    return Feedback(True, f"Correct: your ISFEKF step reproduces uwtutor's FadingEKF (x, P and λ at every step) and "
                          f"the moments m, Ξ and V over {ISF_STEP_STEPS} steps, large early fading factors included.")
