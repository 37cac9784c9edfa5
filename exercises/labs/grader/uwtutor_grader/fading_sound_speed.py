"""Hidden tests of the lab ``fading_sound_speed`` (chapter 5, paper D): a thermocline's sound-speed error.

Parts B-D build on part A's ``mu_gamma`` and ``sigma_gamma``, and part D's filter on its ``mu_hat``: they are checked
with the student's own values (when they are numbers), so that a slip is counted once, in its own check. Part A is
graded in two checks (A1: ``mu_gamma``, 1 point; A2: ``sigma_gamma``, 1 point), part B in four (B1-B4: one filter
each, 1 point) and part D in two (D1: ``mu_hat``, 2 points; D2: the calibrated filter, 1 point).

Recognised mistakes (the instructor notes list them): ``c_e / c`` for μγ (upside down); ``fading=True`` for a
"multiplicative EKF" entry; the calibration regressing the true ranges on the measured ones, using one run only, or
the whole mission instead of the first 60 epochs.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from uwtutor.filters import fading_ekf, range_only_ekf
from uwtutor.exercises.checks import check_number
from uwtutor.exercises.feedback import Feedback
from ._common import Answers, cached, fail, own_number

__all__ = ["PARTS"]


def _moments(ns: Answers) -> tuple[float, float]:
    c_nav, c_e = ns["c_nav"], ns["c_e"]
    return c_nav / c_e, c_nav * ns["sigma_c"] / c_e**2


def _student_moments(ns: Answers) -> tuple[float, float]:
    """The student's ``mu_gamma`` and ``sigma_gamma`` (part A) where each is a usable number (μγ > 0, σγ ≥ 0), else
    the reference's: parts B-D are checked with them."""
    mu, sg = _moments(ns)
    own_mu, own_sg = own_number(ns, "mu_gamma"), own_number(ns, "sigma_gamma")
    return (mu if own_mu is None or own_mu <= 0 else own_mu), (sg if own_sg is None or own_sg < 0 else own_sg)


def _off(answer: object, value: float) -> bool:
    """Whether a numeric answer is outside the checks' tolerance (an answer that is no number: not judged here)."""
    try:
        return not np.isclose(float(answer), value, rtol=1e-3)
    except (TypeError, ValueError):
        return False


def _run(ns: Answers, kind: str, **kwargs: object) -> float:
    sc = ns["scenario"]
    inputs = (ns["x0"], ns["P0"], sc.dr_displacements, sc.ranges, ns["Q"], ns["R"])

    def compute() -> float:
        if kind == "ekf":
            return ns["final_rmse"](range_only_ekf(*inputs))
        return ns["final_rmse"](fading_ekf(*inputs, **kwargs))

    return cached("fading_sound_speed." + kind, (inputs, sc.true_positions, kwargs), compute)


def part_a1(ns: Answers) -> Iterator[Feedback]:
    mu, _ = _moments(ns)
    yield check_number(ns["mu_gamma"], mu, rtol=1e-9, name="mu_gamma", common_mistakes={
        ns["c_e"] / ns["c_nav"]: "Upside down: the vehicle reports c·τ with τ = r/c_e, so γ = c/c_e."},
        hint="The ranges are scaled by the ratio of the assumed to the true speed.", reveal_expected=False)


def part_a2(ns: Answers) -> Iterator[Feedback]:
    _, sg = _moments(ns)
    yield check_number(ns["sigma_gamma"], sg, rtol=1e-3, name="sigma_gamma",
                       hint="To first order σγ = (c/c_e)(σ_c/c_e).", reveal_expected=False)


#: Part B's four entries, one check (one point) each: the filter and its arguments, given part A's moments.
B_ENTRIES = {
    "B1": "EKF",
    "B2": "multiplicative EKF",
    "B3": "multiplicative EKF, mu=1",
    "B4": "ISFEKF, mu=1",
}


def _b_filter(name: str, mu: float, sg: float) -> tuple[str, dict[str, object]]:
    """The kind of filter and the arguments part B's entry ``name`` asks for."""
    return {
        "EKF": ("ekf", {}),
        "multiplicative EKF": ("fading", {"mu_gamma": mu, "sigma_gamma": sg, "fading": False}),
        "multiplicative EKF, mu=1": ("fading", {"mu_gamma": 1.0, "sigma_gamma": sg, "fading": False}),
        "ISFEKF, mu=1": ("fading", {"mu_gamma": 1.0, "sigma_gamma": sg}),
    }[name]


def _part_b_entry(ns: Answers, name: str) -> Iterator[Feedback]:
    rmse = ns["rmse"]
    if name not in rmse:
        yield fail(f"rmse has no entry {name!r}.")
    mu, sg = _student_moments(ns)
    kind, kwargs = _b_filter(name, mu, sg)
    value = _run(ns, kind, **kwargs)
    off = _off(rmse[name], value)
    mistakes = {}
    if off and kwargs.get("fading") is False:
        mistakes[_run(ns, kind, **{**kwargs, "fading": True})] = (
            "That is the filter with fading: a \"multiplicative EKF\" has `fading=False`.")
    if off and kwargs.get("sigma_gamma"):
        mistakes[_run(ns, kind, **{k: v for k, v in kwargs.items() if k != "sigma_gamma"})] = (
            "Pass `sigma_gamma` too: without it the filter has no multiplicative variance.")
    yield check_number(rmse[name], value, rtol=1e-3, name=f"rmse[{name!r}]", units="m", common_mistakes=mistakes,
                       hint="Check the filter's arguments against the task: mu_gamma, sigma_gamma (yours, of part "
                            "A) and fading.",
                       reveal_expected=False)


def part_b1(ns: Answers) -> Iterator[Feedback]:
    return _part_b_entry(ns, B_ENTRIES["B1"])


def part_b2(ns: Answers) -> Iterator[Feedback]:
    return _part_b_entry(ns, B_ENTRIES["B2"])


def part_b3(ns: Answers) -> Iterator[Feedback]:
    return _part_b_entry(ns, B_ENTRIES["B3"])


def part_b4(ns: Answers) -> Iterator[Feedback]:
    return _part_b_entry(ns, B_ENTRIES["B4"])


def part_c(ns: Answers) -> Iterator[Feedback]:
    _, sg = _student_moments(ns)
    by_rho = ns["rmse_by_rho"]
    values = {rho: _run(ns, "fading", mu_gamma=1.0, sigma_gamma=sg, rho=rho) for rho in ns["rho_grid"]}
    for rho, value in values.items():
        if rho not in by_rho:
            yield fail(f"rmse_by_rho has no entry for ρ = {rho}.")
        yield check_number(by_rho[rho], value, rtol=1e-3, name=f"rmse_by_rho[{rho}]", units="m",
                           hint="The ISFEKF with mu_gamma=1, your sigma_gamma of part A and this rho.",
                           reveal_expected=False)
    if ns["best_rho"] != min(values, key=values.get):
        yield fail(f"best_rho = {ns['best_rho']!r} does not have the smallest RMSE.",
                   hint="best_rho is the key of rmse_by_rho with the smallest value, not the value itself.")
    yield Feedback(True, "Correct.")


def part_d1(ns: Answers) -> Iterator[Feedback]:
    sc = ns["scenario"]
    measured, true = sc.ranges[:, :60], sc.true_ranges[:, :60]
    mu_hat = float(np.sum(measured * true) / np.sum(true**2))
    yield check_number(ns["mu_hat"], mu_hat, rtol=1e-7, name="mu_hat", common_mistakes={
        float(np.sum(measured * true) / np.sum(measured**2)): "That regresses the true ranges on the measured ones: "
                                                               "the model is measured ≈ μ · true.",
        float(np.sum(measured[0] * true[0]) / np.sum(true[0] ** 2)): "That uses run 0 only: the task asks for the "
                                                                     "first 60 epochs of all runs.",
        float(np.nansum(sc.ranges * sc.true_ranges) / np.nansum(sc.true_ranges**2)):
            "That uses the whole mission: only the first 60 epochs (the calibration leg) have known true ranges."},
        hint="μ̂ = Σ r_k r_k^true / Σ (r_k^true)² over the first 60 epochs of all runs.", reveal_expected=False)


def part_d2(ns: Answers) -> Iterator[Feedback]:
    _, sg = _student_moments(ns)
    mu_hat = own_number(ns, "mu_hat")
    if mu_hat is None or mu_hat <= 0:
        sc = ns["scenario"]
        measured, true = sc.ranges[:, :60], sc.true_ranges[:, :60]
        mu_hat = float(np.sum(measured * true) / np.sum(true**2))
    yield check_number(ns["rmse_calibrated"], _run(ns, "fading", mu_gamma=mu_hat, sigma_gamma=sg, fading=False),
                       rtol=1e-3, name="rmse_calibrated", units="m",
                       hint="The multiplicative EKF (fading=False) with mu_gamma=mu_hat and your sigma_gamma of part A.",
                       reveal_expected=False)


PARTS = {"A1": part_a1, "A2": part_a2, "B1": part_b1, "B2": part_b2, "B3": part_b3, "B4": part_b4, "C": part_c,
         "D1": part_d1, "D2": part_d2}
