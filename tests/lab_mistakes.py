"""The typical-mistake students of the labs: each makes one slip the lab's instructor notes list, in one answer cell.

Shared by ``tests/test_lab_grading.py`` (scores them in this process) and ``tests/test_labs_nbgrader.py`` (scores
them under nbgrader). Each entry: the lab, (grade_id of the answer cell, the solution's text, the wrong text), the
autograded points the student gets (of 12), the test cells that fail, and a phrase their feedback must contain. A
slip costs the points of its own step only: later parts are checked against the student's own earlier answers. The
instructor notes state these scores.
"""

from __future__ import annotations

#: student -> (lab, (grade_id, right, wrong), points, failing test cells, phrase of the feedback)
TYPICAL_MISTAKES = {
    "c_e_whole_cast_mean": (
        "range_error_budget",
        ("B_answer", "c_e = effective_sound_speed(cast_depth, profile_speeds, z_vehicle, z_beacon)",
         "c_e = float(np.mean(profile_speeds))  # the cast's arithmetic mean"),
        11.0, {"B1_tests"}, "mean of the whole cast"),
    "horizontal_range_scaled": (
        "range_error_budget",
        ("C_answer", "    slant = np.hypot(x, dz)\n    slant_measured = slant * c_nav / c_e\n"
                     "    return np.sqrt(slant_measured**2 - dz**2) - x",
         "    return x * c_nav / c_e - x  # the horizontal range scaled"),
        9.0, {"C_tests"}, "scales the horizontal range"),
    "clock_in_hours": (
        "range_error_budget",
        ("D_answer", "c_e * clock_drift * 3600.0 * hours", "c_e * clock_drift * hours"),
        10.0, {"D2_tests"}, "convert the hours to seconds"),
    "no_square_root": (
        "observable_track",
        ("A_answer", "return float(np.sqrt(bound[0, 0] + bound[1, 1])), float(np.sqrt(bound[2, 2]))",
         "return float(bound[0, 0] + bound[1, 1]), float(np.sqrt(bound[2, 2]))"),
        10.0, {"A_tests"}, "Take the square root"),
    "bias_in_position_bound": (
        "observable_track",
        ("A_answer", "return float(np.sqrt(bound[0, 0] + bound[1, 1])), float(np.sqrt(bound[2, 2]))",
         "return float(np.sqrt(bound[0, 0] + bound[1, 1] + bound[2, 2])), float(np.sqrt(bound[2, 2]))"),
        10.0, {"A_tests"}, "uses the x and y entries only"),
    "nees_one_dof": (
        "ekf_consistency",
        ("A_answer", "nees_bounds = chi2_mean_bounds(2, n_runs)", "nees_bounds = chi2_mean_bounds(1, n_runs)"),
        11.0, {"A1_tests"}, "the bounds of a mean NEES bracket n = 2"),
    "nis_two_dof": (
        "ekf_consistency",
        ("B_answer", "nis_bounds = chi2_mean_bounds(1, n_runs)", "nis_bounds = chi2_mean_bounds(2, n_runs)"),
        11.0, {"B1_tests"}, "the bounds of a mean NIS bracket 1"),
    "best_r_smallest_nis": (
        "ekf_consistency",
        ("C_answer", "best_R = min(nis_by_R, key=lambda R: abs(nis_by_R[R] - 1.0))",
         "best_R = min(nis_by_R, key=nis_by_R.get)"),
        11.0, {"C2_tests"}, "not the NIS itself"),
    "mu_gamma_upside_down": (
        "fading_sound_speed",
        ("A_answer", "mu_gamma, sigma_gamma = range_factor_moments(c_nav, c_e, sigma_c)",
         "mu_gamma, sigma_gamma = c_e / c_nav, c_nav * sigma_c / c_e**2"),
        11.0, {"A1_tests"}, "mu_gamma > 1"),
    "true_on_measured": (
        "fading_sound_speed",
        ("D_answer", "mu_hat = float(np.sum(measured * true) / np.sum(true**2))",
         "mu_hat = float(np.sum(measured * true) / np.sum(measured**2))"),
        10.0, {"D1_tests"}, "regresses the true ranges on the measured ones"),
    "fading_in_multiplicative_ekf": (
        "fading_sound_speed",
        ("B_answer", '"multiplicative EKF": final_rmse(fading_ekf(*inputs, mu_gamma=mu_gamma, sigma_gamma=sigma_gamma, '
                     'fading=False)),',
         '"multiplicative EKF": final_rmse(fading_ekf(*inputs, mu_gamma=mu_gamma, sigma_gamma=sigma_gamma)),'),
        11.0, {"B2_tests"}, "a \"multiplicative EKF\" has `fading=False`"),
    "log_of_sum": (
        "depth_pf_vs_ekf",
        ("B_answer",
         "return np.logaddexp(np.log1p(-p) + log_normal(d, sigma), np.log(p) + log_normal(d, sigma_spike))",
         "return np.log((1 - p) * np.exp(log_normal(d, sigma)) + p * np.exp(log_normal(d, sigma_spike)))"),
        11.0, {"B2_tests"}, "must stay finite far out"),
    "spike_variance_alone": (
        "depth_pf_vs_ekf",
        ("C_answer", "R_inflated[0, 0] = (1 - spike_probability) * model.R[0, 0] + spike_probability * "
                     "(model.R[0, 0] + spike_sigma**2)",
         "R_inflated[0, 0] = spike_sigma**2"),
        10.0, {"C1_tests"}, "spike variance alone"),
    "clock_offset_alone": (
        "cooperative_current",
        ("A_answer", "clock_bias = owtt.clock_range_error(scenarios[\"zigzag\"].times, offset=clock_offset, "
                     "drift=clock_drift, sound_speed=c)",
         "clock_bias = np.full(scenarios[\"zigzag\"].times.shape, c * clock_offset)  # the offset alone"),
        10.0, {"A_tests"}, "the offset alone"),
    "nees_two_dof": (
        "bias_tracking_iekf",
        ("D_answer", "nees_bounds = chi2_mean_bounds(3, n_runs)", "nees_bounds = chi2_mean_bounds(2, n_runs)"),
        11.0, {"D1_tests"}, "its NEES has 3 degrees of freedom"),
    "summed_dr_variances": (
        "bias_tracking_iekf",
        ("A_answer", "Q_a = paper_a_process_noise(sigma_x, sigma_y)",
         "Q_a = paper_a_process_noise(sigma_x, sigma_y, sigma_bias=np.hypot(sigma_x, sigma_y))  # the sum"),
        10.0, {"A_tests"}, "not their sum"),
    "epochs_newest_first": (
        "outlier_rejection_vmlbl",
        ("D_answer", "epochs = k_fix - s * np.arange(3, -1, -1)", "epochs = k_fix - s * np.arange(4)  # newest first"),
        10.0, {"D1_tests"}, "List the epochs oldest first"),
    "raw_ranges_in_fix": (
        "outlier_rejection_vmlbl",
        ("D_answer", "fix = virtual_beacon_lsq(filtered[epochs]", "fix = virtual_beacon_lsq(ranges[epochs]"),
        10.0, {"D1_tests"}, "Use the filtered ranges"),
    "outlier_count_as_patch": (
        "outlier_rejection_vmlbl",
        ("C_answer", "longest_patch = max(length for _, length in runs_of_true(is_outlier))",
         "longest_patch = int(is_outlier.sum())"),
        11.0, {"C1_tests"}, "the number of outliers"),
    "affine_s_cal": (
        "real_ranges_plaza",
        ("A_answer", "s_cal = (r_leg @ d_leg) / (d_leg @ d_leg)",
         "s_cal = np.polyfit(d_leg, r_leg, 1)[0]  # a line with an offset"),
        10.0, {"A_tests"}, "Fit through the origin"),
    "no_move_first": (
        "real_ranges_plaza",
        ("B_answer", ' order="move-first",', ""),
        8.0, {"B1_tests", "B2_tests"}, 'order="move-first"` is left out'),
}
