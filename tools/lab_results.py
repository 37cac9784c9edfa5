"""The results of the labs' own solutions that their model answers and instructor notes quote, stored so that the
prose contract can bind those numbers (``kind: data`` in ``tests/prose_manifest/exercises/labs/**``).

The lab notebooks are committed without outputs and nothing in them is glued, so a number such as "c_e is about
1481 m/s" in a model answer has no computation to point at. This tool runs each lab's solution (every code cell but
the test cells, solution markers taken out, in one namespace, as ``tests/test_lab_grading.py`` does), evaluates the
quantities listed in ``RESULTS`` in that namespace, and writes them to ``exercises/labs/solution_results.json``
(six significant digits: the text quotes two or three, and the last bits of a float sum must not decide a
committed value). ``tests/test_lab_results.py`` recomputes them and compares.

Usage::

    PYTHONPATH=. python tools/lab_results.py            # write exercises/labs/solution_results.json
    PYTHONPATH=. python tools/lab_results.py --check    # recompute and compare, exit 1 on a difference
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import re
import sys
import warnings
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parents[1]
LABS_DIR = REPO / "exercises" / "labs"
RESULTS_FILE = LABS_DIR / "solution_results.json"
#: Relative tolerance of ``--check`` (the stored values have six significant digits).
RTOL = 2e-6

#: lab -> quantity -> the expression that computes it in the namespace of the lab's solution (or a function of that
#: namespace, for a quantity that takes more than an expression). The names say what the text quotes; where the text
#: does arithmetic on a result (a better oscillator's drift, 1 m/s of speed error), the expression spells out that
#: arithmetic with the text's own numbers.
RESULTS: dict[str, dict[str, Any]] = {
    "range_error_budget": {
        "c_e": "c_e",
        "delta_c_over_c_e": "delta_c / c_e",
        "sound_speed_error_at_2500": "budget['sound speed']",
        "geometry_error_at_300": "float(geometry_range_error(300.0))",
        "clock_error_after_mission": "budget['clock']",
        "timing_noise": "budget['timing noise']",
        "error_per_metre_per_second_at_2500": "2500.0 * 1.0 / c_e",          # 1 m/s of error in c_e, at 2.5 km
        "clock_error_after_mission_at_0_05ppm": "c_e * 0.05e-6 * mission_hours * 3600.0",  # a 0.05 ppm oscillator
    },
    "ekf_consistency": {
        "average_nis_tuned": "nis_by_R[2.25]",
        "small_q_average_nis": "small_q[1]",
        "rmse_colleague": "rmse_colleague",
        "rmse_tuned": "rmse_tuned",
    },
    "observable_track": {
        "offset_pass_position_bound": "table['offset pass'][0]",
        "model_track_position_bound": "final_bounds(my_track)[0]",
        "model_track_bias_bound": "final_bounds(my_track)[1]",
    },
    "bias_tracking_iekf": {
        "bias_step": "float(np.sqrt(q_bias))",
        "rmse_ekf": "rmse_ekf",
        "rmse_iekf": "rmse_iekf",
        "bias_rmse_iekf": "bias_rmse_iekf",
        "rmse_direct": "rmse_direct",
        "rmse_prepositioned": "rmse_prepositioned",
        "median_start": "median_start",
        "median_start_minutes": "median_start * dt / 60.0",
        "k_start_run0": "k_start_run0",
        "nees_paper_a": "nees_paper_a",
        "nees_const": "nees_const",
        "nees_bound_low": "nees_bounds[0]",
        "nees_bound_high": "nees_bounds[1]",
        "rmse_iekf_const": "final_rmse(iekf_const)",
        "alpha_arc": "alpha_arc",
        "alpha_whole_arc": "float(lsq.precision_factor_history(track, buoy)[-1])",
    },
    "fading_sound_speed": {
        "range_excess": "mu_gamma - 1.0",
        "range_excess_nearest": "(mu_gamma - 1.0) * float(np.nanmin(scenario.true_ranges))",
        "range_excess_farthest": "(mu_gamma - 1.0) * float(np.nanmax(scenario.true_ranges))",
        "rmse_ekf": "rmse['EKF']",
        "rmse_multiplicative": "rmse['multiplicative EKF']",
        "rmse_multiplicative_mu_1": "rmse['multiplicative EKF, mu=1']",
        "rmse_isfekf_mu_1": "rmse['ISFEKF, mu=1']",
    },
    "cooperative_current": {
        "deviation_zigzag": "deviations['zigzag']",
        "current_error_zigzag": "cur_err['zigzag']",
        "current_error_zigzag_of_tide": "cur_err['zigzag'] / float(np.hypot(*params.current))",
        "position_error_zigzag": "pos_err['zigzag']",
        "current_error_parallel": "cur_err['parallel']",
        "current_error_parallel_of_tide": "cur_err['parallel'] / float(np.hypot(*params.current))",
        "position_error_parallel": "pos_err['parallel']",
        "claimed_sigma_parallel": "claimed_sigma['parallel']",
        "claimed_sigma_zigzag": "claimed_sigma['zigzag']",
        "overconfidence_parallel": "overconfidence['parallel']",
        "overconfidence_zigzag": "overconfidence['zigzag']",
        "clock_error_start": "float(clock_bias[0])",
        "clock_error_end": "clock_bias_end",
    },
    "depth_pf_vs_ekf": {
        "depth_sensor_rmse": "rmse_table['depth sensor']",
        "three_sigma_innovation_median": "3.0 * float(np.sqrt(np.median(ekf_result.innovation_cov[..., 0, 0])))",
        "detection_rate": "detection_rate",
        "false_alarm_rate": "false_alarm_rate",
    },
}

def _plaza_raw_rmse(ns: dict[str, Any]) -> float:
    """real_ranges_plaza: part B's filter on the raw ranges (no scale), the notes' "all" row."""
    z_raw = ns["data"].ranges_on_epochs([ns["BEACON"]], min_period=ns["PERIOD"])
    result = ns["extended_kalman_filter"](ns["motion"], ns["measurement"], ns["x0"], ns["P0"], ns["data"].odometry,
                                          z_raw, times=ns["data"].times, gate=ns["gate"])
    return float(ns["rmse"](result.x))


def _plaza_whole_log_scale(ns: dict[str, Any]) -> float:
    """real_ranges_plaza: the scale fitted through the origin on the whole log (the mistake the notes name)."""
    r = ns["data"].ranges_on_epochs([ns["BEACON"]])[:, 0]
    d = ns["data"].true_ranges([ns["BEACON"]])[:, 0]
    heard = np.isfinite(r)
    return float((r[heard] @ d[heard]) / (d[heard] @ d[heard]))


def _plaza_pose_nees(ns: dict[str, Any]) -> float:
    """real_ranges_plaza: the mean NEES of the pose (x, y, heading) of part B's filter, the mistake of part D."""
    result, truth = ns["result_cal"], ns["truth"]
    err = result.x[:, :3] - truth[:, :3]
    err[:, 2] = np.angle(np.exp(1j * err[:, 2]))
    return float(np.mean(np.einsum("ki,ki->k", err, np.linalg.solve(result.P[:, :3, :3], err[..., None])[..., 0])))


RESULTS["real_ranges_plaza"] = {
    "calibration_ranges": "int(heard.sum())",
    "s_cal": "s_cal",
    "s_cal_excess": "s_cal - 1.0",
    "s_cal_with_offset": "float(np.polyfit(d_leg, r_leg, 1)[0])",
    "s_cal_whole_log": _plaza_whole_log_scale,
    "rmse_cal": "rmse_cal",
    "rmse_raw": _plaza_raw_rmse,
    "rmse_est": "rmse_est",
    "scale_end": "scale_end",
    "nees_mean": "nees_mean",
    "nees_mean_excess": "nees_mean / 2.0 - 1.0",
    "nees_inside": "nees_inside",
    "pose_nees_mean": _plaza_pose_nees,
}

def _outlier_gate_at_lockout(ns: dict[str, Any]) -> tuple[float, float]:
    """outlier_rejection_vmlbl: paper E's accepted interval's lower end at the lock-out's first epoch, and that
    range's innovation (the cell after part C prints both)."""
    k, run = ns["lockout_start"], ns["no_reacq"]
    predicted = float(run.x_prior[k, 0])
    innovation_variance = float(run.P_prior[k, 0, 0]) + ns["r"]
    lower, _, _ = ns["paper_gate"](float(ns["ranges"][k]), predicted, innovation_variance, ns["delta"])
    return lower, float(ns["ranges"][k]) - predicted


def _outlier_second_lockout(ns: dict[str, Any]) -> float:
    """outlier_rejection_vmlbl: the first epoch of the run of rejected ranges that the second re-acquisition ends."""
    rejected = np.asarray(ns["with_reacq"].extras["rejected"], dtype=bool)
    k = int(np.flatnonzero(ns["with_reacq"].extras["reacquired"])[1]) - 1
    while k > 0 and rejected[k - 1]:
        k -= 1
    return float(k)


def _rms(errors: Any) -> float:
    return float(np.sqrt(np.mean(np.square(errors))))


RESULTS["outlier_rejection_vmlbl"] = {
    "paper_flagged": "counts['paper']['flagged']",
    "paper_false": "counts['paper']['false']",
    "chi2_flagged": "counts['chi2']['flagged']",
    "chi2_missed": "counts['chi2']['missed']",
    "chi2_false": "counts['chi2']['false']",
    "gate_half_width_at_largest_range": "delta * float(np.nanmax(ranges)) / 2.0",   # paper E's gate, about δẑ/2
    "lockout_start": "lockout_start",
    "gate_lower_at_lockout": lambda ns: _outlier_gate_at_lockout(ns)[0],
    "innovation_at_lockout": lambda ns: _outlier_gate_at_lockout(ns)[1],
    "rms_no_reacquisition": "rms_after['no re-acquisition']",
    "recovered_at": "recovered_at",
    "rms_reacquisition": "rms_after['re-acquisition']",
    "rms_prediction_only": lambda ns: _rms(ns["with_reacq"].x[ns["lockout_start"]:ns["recovered_at"], 0]
                                           - ns["true_ranges"][ns["lockout_start"]:ns["recovered_at"]]),
    "rms_after_restart": lambda ns: _rms(ns["with_reacq"].x[ns["recovered_at"]:, 0]
                                         - ns["true_ranges"][ns["recovered_at"]:]),
    "second_lockout_start": _outlier_second_lockout,
    "second_recovery": "float(np.flatnonzero(with_reacq.extras['reacquired'])[1])",
    "fix_error_10": "fix_errors[10]",
    "noise_gain_10": "noise_gains[10]",
    "fix_error_60": "fix_errors[60]",
    "noise_gain_60": "noise_gains[60]",
}

_MARKER = re.compile(r"^\s*#+\s*(BEGIN|END)\s+SOLUTION\s*$")


def solution_namespace(lab: str) -> dict[str, Any]:
    """The namespace of ``lab``'s solution: every code cell but the test cells, solution markers removed, in order.

    Parameters
    ----------
    lab : str
        The lab's folder name in ``exercises/labs/``.

    Returns
    -------
    dict
        The notebook's globals after its last cell.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import nbformat

    nb = nbformat.read(LABS_DIR / lab / f"{lab}.ipynb", as_version=4)
    ns: dict[str, Any] = {"__name__": "__lab__"}
    with contextlib.redirect_stdout(io.StringIO()), np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for index, cell in enumerate(nb.cells):
            meta = cell.metadata.get("nbgrader", {})
            if cell.cell_type != "code" or (meta.get("grade") and not meta.get("solution")):
                continue
            source = "\n".join(line for line in cell.source.split("\n") if not _MARKER.match(line))
            exec(compile(source, f"{lab}[{index}]", "exec"), ns)
            plt.close("all")
    return ns


def compute(labs: list[str] | None = None) -> dict[str, dict[str, float]]:
    """The quantities of ``RESULTS`` (of ``labs``, default all), each to six significant digits."""
    results: dict[str, dict[str, float]] = {}
    for lab in labs or sorted(RESULTS):
        ns = solution_namespace(lab)
        results[lab] = {name: float(f"{float(what(ns) if callable(what) else eval(what, ns)):.6g}")  # noqa: S307
                        for name, what in RESULTS[lab].items()}
    return results


def differences(stored: dict, computed: dict) -> list[str]:
    """Where ``stored`` and ``computed`` disagree (a missing or extra quantity, or a value beyond ``RTOL``)."""
    problems = []
    for lab in sorted(set(stored) | set(computed)):
        old, new = stored.get(lab, {}), computed.get(lab, {})
        for name in sorted(set(old) | set(new)):
            if name not in old or name not in new:
                problems.append(f"{lab}.{name}: {'not stored' if name not in old else 'no longer computed'}")
            elif not np.isclose(old[name], new[name], rtol=RTOL, atol=0.0):
                problems.append(f"{lab}.{name}: stored {old[name]!r}, computed {new[name]!r}")
    return problems


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true", help="recompute and compare with the stored file")
    args = parser.parse_args(argv)
    computed = compute()
    if args.check:
        stored = json.loads(RESULTS_FILE.read_text(encoding="utf-8"))
        problems = differences(stored, computed)
        print("\n".join(problems) or f"{RESULTS_FILE.relative_to(REPO)} matches the labs' solutions")
        return 1 if problems else 0
    RESULTS_FILE.write_text(json.dumps(computed, indent=1, sort_keys=True) + "\n", encoding="utf-8")
    print(f"wrote {RESULTS_FILE.relative_to(REPO)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
