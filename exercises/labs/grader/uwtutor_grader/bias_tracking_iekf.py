"""Hidden tests of the lab ``bias_tracking_iekf`` (chapter 7, paper A): a drifting transponder delay.

Parts B-D build on part A's ``Q_a``: they are checked with the student's own ``Q_a`` (when it is a usable 3 x 3
covariance), so that a slip in part A costs part A only. Part C is graded in two checks (C1: the precision factor
and the start epoch of run 0, 1 point; C2: the two filters from the poor start, 2 points), and part D in two (D1:
the NEES bounds, 1 point; D2: the two mean NEES and the fraction inside the student's own bounds, 1 point).

Recognised mistakes (the instructor notes list them): the sum or the product of the DR variances for ``q_bias``;
the precision factor of part C on the *true* track instead of
the provisional one; ``argmax`` of an all-False array; the direct start with ``P0_good`` instead of the identity;
``chi2_mean_bounds`` with 2 degrees of freedom for the 3-state NEES; a finite ``alpha_radial``.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from uwtutor import lsq
from uwtutor.filters import bias_ekf, range_only_ekf
from uwtutor.pipelines import prepositioned_bias_ekf
from uwtutor.metrics import average_over_runs, chi2_mean_bounds, fraction_within, nees
from uwtutor.models.bias import paper_a_process_noise
from uwtutor.exercises.checks import check_array, check_number
from uwtutor.exercises.feedback import Feedback
from ._common import Answers, cached, fail, own_interval

__all__ = ["PARTS"]

def _q(ns: Answers) -> np.ndarray:
    return paper_a_process_noise(ns["sigma_x"], ns["sigma_y"])


def _inputs(ns: Answers) -> tuple:
    return (ns["dr"], ns["ranges"], ns["R"], ns["buoy"], ns["sigma_x"], ns["sigma_y"])


def _iekf(ns: Answers, start: str, P0: np.ndarray, Q: np.ndarray) -> object:
    x0 = np.column_stack([ns[start], np.zeros(len(ns[start]))])
    return cached("bias_tracking_iekf.iekf", (_inputs(ns), ns[start], P0, Q),
                  lambda: bias_ekf(x0, P0, ns["dr"], ns["ranges"], Q, ns["R"], beacon=ns["buoy"]))


def _student_q(ns: Answers) -> np.ndarray:
    """The student's ``Q_a`` (part A) when it is a usable 3 x 3 covariance, else paper A's: parts B-D are checked
    with it, so that a mistake in part A is not counted again."""
    try:
        Q_a = np.asarray(ns.get("Q_a"), dtype=float)
    except (TypeError, ValueError):
        return _q(ns)
    if Q_a.shape != (3, 3) or not np.all(np.isfinite(Q_a)) or not np.allclose(Q_a, Q_a.T) \
            or np.linalg.eigvalsh(Q_a).min() < 0:
        return _q(ns)
    return Q_a


def part_a(ns: Answers) -> Iterator[Feedback]:
    sx, sy = ns["sigma_x"], ns["sigma_y"]
    yield check_number(ns["q_bias"], (sx**2 + sy**2) / 2, rtol=1e-9, name="q_bias", units="m²", common_mistakes={
        sx**2 + sy**2: "Paper A's rule is the mean of the two DR variances, not their sum.",
        sx * sy: "The rule averages the variances (σ_x² and σ_y²), not the product of the standard deviations."},
        hint="Paper A's rule for close epochs: q_υ = (σ_x² + σ_y²)/2.", reveal_expected=False)
    yield check_array(ns["Q_a"], _q(ns), rtol=1e-9, name="Q_a", hint="Q_a = diag(σ_x², σ_y², q_υ).",
                      reveal_expected=False)


def part_b(ns: Answers) -> Iterator[Feedback]:
    Q = _student_q(ns)
    final_rmse = ns["final_rmse"]
    ekf = cached("bias_tracking_iekf.ekf", (_inputs(ns), ns["start_good"], ns["P0_good"], Q),
                 lambda: range_only_ekf(ns["start_good"], ns["P0_good"][:2, :2], ns["dr"], ns["ranges"], Q[:2, :2],
                                        ns["R"], beacon=ns["buoy"]))
    yield check_number(ns["rmse_ekf"], final_rmse(ekf), rtol=1e-6, name="rmse_ekf", units="m",
                       hint="The plain EKF from `start_good` with `P0_good[:2, :2]`, `Q_a[:2, :2]` and `R`, all runs "
                            "in one call.", reveal_expected=False)
    iekf = _iekf(ns, "start_good", ns["P0_good"], Q)
    yield check_number(ns["rmse_iekf"], final_rmse(iekf), rtol=1e-6, name="rmse_iekf", units="m",
                       hint="The IEKF from `[start_good, 0]` with `P0_good`, `Q_a` and `R`.", reveal_expected=False)
    bias = float(np.sqrt(np.mean((iekf.x[:, -100:, 2] - ns["delay_bias"][:, -100:]) ** 2)))
    yield check_number(ns["bias_rmse_iekf"], bias, rtol=1e-6, name="bias_rmse_iekf", units="m",
                       hint="Compare x[..., 2] with delay_bias over all runs and the last 100 epochs.",
                       reveal_expected=False)


def part_c1(ns: Answers) -> Iterator[Feedback]:
    start_poor, dr, buoy = ns["start_poor"], ns["dr"], ns["buoy"]
    provisional = start_poor[0] + np.cumsum(dr[0], axis=0)
    alpha = lsq.precision_factor_history(provisional, buoy)
    on_truth = lsq.precision_factor_history(ns["track"], buoy)
    truth_hint = ("That is the precision factor of the *true* track; the boat does not know it. The task asks for "
                  "run 0's provisional track: start_poor[0] carried by the cumulative sum of dr[0].")
    yield check_array(ns["alpha_run0"], alpha, rtol=1e-6, name="alpha_run0", common_mistakes=[(on_truth, truth_hint)],
                      hint="α after each epoch along run 0's provisional (dead-reckoned) track, "
                           "`lsq.precision_factor_history`.", reveal_expected=False)
    k = ns["k_start_run0"]
    first = int(np.argmax(alpha < 2.0))
    if k != first:
        if alpha[0] >= 2.0 and k == 0:
            yield fail("k_start_run0 = 0, but α is not below 2 at epoch 0.",
                       hint="`np.argmax` of an all-False array is 0: check that some epoch is below 2 before "
                            "trusting it.")
        yield fail(f"k_start_run0 = {k} is not the first epoch where your α is below 2.",
                   hint="Take the FIRST epoch where α is below 2 (epochs count from 0), as an int.")
    yield Feedback(True, "Correct.")


def part_c2(ns: Answers) -> Iterator[Feedback]:
    start_poor, dr, buoy = ns["start_poor"], ns["dr"], ns["buoy"]
    Q, final_rmse = _student_q(ns), ns["final_rmse"]
    direct = _iekf(ns, "start_poor", np.eye(3), Q)
    matched = None
    try:
        off = not np.isclose(float(ns["rmse_direct"]), final_rmse(direct), rtol=1e-6)
    except (TypeError, ValueError):
        off = True
    if off:
        matched = final_rmse(_iekf(ns, "start_poor", ns["P0_good"], Q))
    yield check_number(ns["rmse_direct"], final_rmse(direct), rtol=1e-6, name="rmse_direct", units="m",
                       common_mistakes={} if matched is None else {
                           matched: "That start uses `P0_good`; as in paper A the filter is given P0 = I "
                                    "(`np.eye(3)`) here, which is what makes the poor start fail."},
                       hint="`bias_ekf` from `[start_poor, 0]` with `np.eye(3)`, started at epoch 0.",
                       reveal_expected=False)
    pre = cached("bias_tracking_iekf.prepositioned", (_inputs(ns), start_poor, Q),
                 lambda: prepositioned_bias_ekf(start_poor, np.eye(3), dr, ns["ranges"], Q, ns["R"],
                                                max_alpha=2.0, beacon=buoy))
    yield check_number(ns["rmse_prepositioned"], final_rmse(pre), rtol=1e-6, name="rmse_prepositioned", units="m",
                       hint="`prepositioned_bias_ekf` on all runs from `start_poor` with P0=np.eye(3) and "
                            "max_alpha=2.0.", reveal_expected=False)
    yield check_number(ns["median_start"], float(np.median(np.argmax(pre.extras["started"], axis=1))), rtol=1e-9,
                       name="median_start", hint="Each run's start is the first True of its row of "
                                                 "`extras['started']`; take the median over the runs.",
                       reveal_expected=False)


def part_d1(ns: Answers) -> Iterator[Feedback]:
    n_runs = ns["n_runs"]
    bounds = chi2_mean_bounds(3, n_runs)
    yield check_array(np.asarray(ns["nees_bounds"], dtype=float), np.asarray(bounds, dtype=float), rtol=1e-6,
                      name="nees_bounds", common_mistakes=[
                          (np.asarray(chi2_mean_bounds(2, n_runs)),
                           "The state [x, y, bias] has 3 components: its NEES has 3 degrees of freedom "
                           "(chi2_mean_bounds(3, ...)).")],
                      hint="The 95 % interval of a mean of n_runs NEES values of a 3-state filter.",
                      reveal_expected=False)


def part_d2(ns: Answers) -> Iterator[Feedback]:
    K = ns["K"]
    bounds = own_interval(ns, "nees_bounds") or chi2_mean_bounds(3, ns["n_runs"])
    Q = _student_q(ns)
    true_state = ns["true_state"]
    paper_a = _iekf(ns, "start_good", ns["P0_good"], Q)
    const = _iekf(ns, "start_good", ns["P0_good"], paper_a_process_noise(ns["sigma_x"], ns["sigma_y"],
                                                                          sigma_bias=0.02))
    mean_a = average_over_runs(nees(paper_a.x, paper_a.P, true_state))[0]
    mean_c = average_over_runs(nees(const.x, const.P, true_state))[0]
    half = "Average the mean NEES over the second half of the epochs, K // 2 to the end."
    yield check_number(ns["nees_paper_a"], float(np.mean(mean_a[K // 2:])), rtol=1e-6, name="nees_paper_a",
                       hint=half + " Your IEKF of part B, against `true_state`.", reveal_expected=False)
    yield check_number(ns["nees_const"], float(np.mean(mean_c[K // 2:])), rtol=1e-6, name="nees_const",
                       hint=half + " The colleague's IEKF runs exactly as in part B but with `Q_const`.",
                       reveal_expected=False)
    yield check_number(ns["inside_const"], fraction_within(mean_c[K // 2:], *bounds), atol=1e-9,
                       name="inside_const", hint="The fraction of the second half's epochs where the colleague's mean "
                                                 "NEES lies inside your nees_bounds (`fraction_within`).",
                       reveal_expected=False)


def part_e(ns: Answers) -> Iterator[Feedback]:
    alpha_arc = float(lsq.precision_factor_history(ns["track"][:150], ns["buoy"])[-1])
    yield check_number(ns["alpha_arc"], alpha_arc, rtol=1e-6, name="alpha_arc",
                       hint="The precision factor after the 150th epoch of `track[:150]` (the true positions).",
                       reveal_expected=False)
    if np.isfinite(ns["alpha_radial"]):
        yield fail("alpha_radial is finite.",
                   hint="On a radial leg every row is [1, 0, 1]: AᵀA is singular and α is infinite "
                        "(precision_factor_history returns inf).")
    if ns["radial_observable"] is not False:
        yield fail("radial_observable should say whether position and delay can be told apart radially.",
                   hint="With one line of sight the range and the delay add up: can they be separated?")
    yield Feedback(True, "Correct.")


PARTS = {"A": part_a, "B": part_b, "C1": part_c1, "C2": part_c2, "D1": part_d1, "D2": part_d2,
         "E": part_e}
