"""The labs' hidden tests (``uwtutor_grader``, the instructor's package beside the lab sources): they name the
mistakes the instructor notes promise, and never show the answer.

Each lab's solution is run in this process (its given and answer cells, solution markers taken out; not its test
cells), then one answer at a time is replaced by a typical mistake and ``check_part`` must fail with the message the
lab's instructor notes promise (``exercises/labs/instructor-notes/NAME.md``, "recognised mistakes" and "common
mistakes"). nbgrader itself grades the labs in ``tests/test_labs_nbgrader.py``.
"""

from __future__ import annotations

import contextlib
import functools
import io
import re
import warnings
from pathlib import Path

import matplotlib
import nbformat
import numpy as np
import pytest
from scipy import stats

from uwtutor import acoustics, lsq
from uwtutor.exercises.feedback import Feedback
from uwtutor.exercises.generate import list_lab_sources
from uwtutor_grader import LAB_NAMES, LabDependencyMissing, check_part, lab_parts
from uwtutor.metrics import chi2_mean_bounds
from uwtutor.models.bias import paper_a_process_noise

from lab_mistakes import TYPICAL_MISTAKES

matplotlib.use("Agg")

LABS_DIR = Path(__file__).resolve().parents[1] / "exercises" / "labs"
_MARKER = re.compile(r"^\s*#+\s*(BEGIN|END)\s+SOLUTION\s*$")
_HIDDEN = re.compile(r"^[ \t]*### BEGIN HIDDEN TESTS[ \t]*\n(.*?)^[ \t]*### END HIDDEN TESTS", re.M | re.S)


@functools.lru_cache(maxsize=None)
def _solution(lab: str) -> dict:
    """The namespace of the lab's solution: every code cell but the test cells, run in order."""
    import matplotlib.pyplot as plt

    nb = nbformat.read(LABS_DIR / lab / f"{lab}.ipynb", as_version=4)
    ns: dict = {"__name__": "__lab__"}
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


def _with(lab: str, **answers) -> dict:
    return {**_solution(lab), **answers}


def _text(fb: Feedback) -> str:
    return " ".join(f"{fb.message} {fb.hint or ''}".split())


def _fails_with(lab: str, part: str, phrase: str, **answers) -> str:
    fb = check_part(lab, part, _with(lab, **answers))
    text = _text(fb)
    assert not fb, f"{lab} part {part} accepted the mistake"
    assert phrase in text, f"{lab} part {part}: {phrase!r} not in the feedback:\n{text}"
    return text


# -- the sources ------------------------------------------------------------------------------------------------------
def test_every_lab_has_a_grader():
    assert set(LAB_NAMES) == set(list_lab_sources(LABS_DIR))


@pytest.mark.parametrize("lab", LAB_NAMES)
def test_hidden_tests_are_only_a_call_to_the_library(lab):
    """A hidden test shows nothing but the call: the reference is computed in the library, not in the cell."""
    nb = nbformat.read(LABS_DIR / lab / f"{lab}.ipynb", as_version=4)
    parts = []
    for cell in nb.cells:
        for body in _HIDDEN.findall(cell.source):
            part = cell.metadata["nbgrader"]["grade_id"].split("_")[0]
            assert body == (f"from uwtutor_grader import check_part\n"
                            f"_verdict = check_part(\"{lab}\", \"{part}\", globals())\n"
                            f"assert _verdict, _verdict\n"), f"{lab}: a hidden test does more than call check_part"
            parts.append(part)
    assert tuple(parts) == lab_parts(lab), "every part with hidden checks is called once, in order"


def test_bad_lab_or_part_is_named():
    with pytest.raises(ValueError, match="lab must be one of"):
        check_part("no_such_lab", "A", {})
    with pytest.raises(ValueError, match="part must be one of A, B1, B2, C, D1, D2, E for the lab range_error_budget"):
        check_part("range_error_budget", "Z", {})
    with pytest.raises(TypeError, match="namespace must be a mapping"):
        check_part("range_error_budget", "A", [1, 2])


def test_a_missing_name_says_which_cells_to_run():
    fb = check_part("range_error_budget", "A", {})
    assert not fb and "is not defined" in fb.message and "Run the notebook's cells from the top" in fb.hint


def test_an_answer_of_the_wrong_kind_is_feedback_not_a_crash():
    fb = check_part("fading_sound_speed", "B1", _with("fading_sound_speed", rmse=42.0))
    assert not fb and "stopped on your answers" in fb.message


# -- every promised mistake is named ----------------------------------------------------------------------------------
def test_range_error_budget_mistakes():
    lab = "range_error_budget"
    ns = _solution(lab)
    c_e = ns["c_e"]
    _fails_with(lab, "B1", "mean of the whole cast", c_e=float(np.mean(ns["profile_speeds"])))
    _fails_with(lab, "B2", "The sign: Δc = c − c_e", delta_c=c_e - ns["c_nav"])
    _fails_with(lab, "C", "scales the horizontal range",
                speed_range_error=lambda x: acoustics.sound_speed_error_range_bias(np.asarray(x, dtype=float),
                                                                                   ns["c_nav"], c_e))
    _fails_with(lab, "D2", "convert the hours to seconds",
                clock_range_error=lambda h: c_e * ns["clock_drift"] * np.asarray(h, dtype=float))
    _fails_with(lab, "D2", "An hour is 3600 s, not 60 s",
                clock_range_error=lambda h: c_e * ns["clock_drift"] * 60.0 * np.asarray(h, dtype=float))
    text = _fails_with(lab, "E", "is not the largest term", dominant="clock")
    assert "sound speed" not in text, "the feedback does not say which term is the largest"


def test_observable_track_mistakes():
    lab = "observable_track"
    ns = _solution(lab)
    from uwtutor.observability import track_crlb

    def with_bias(track):
        b = track_crlb(track.positions, ns["beacon"], ns["sigma_r"], unknown_bias=True)[-1]
        return float(np.sqrt(np.trace(b))), float(np.sqrt(b[2, 2]))

    def squared(track):
        b = track_crlb(track.positions, ns["beacon"], ns["sigma_r"], unknown_bias=True)[-1]
        return float(b[0, 0] + b[1, 1]), float(b[2, 2])

    _fails_with(lab, "A", "uses the x and y entries only", final_bounds=with_bias)
    _fails_with(lab, "A", "Take the square root", final_bounds=squared)
    _fails_with(lab, "B", "smallest to the largest position bound", ranking=list(reversed(ns["ranking"])))
    straight = ns["candidates"]["offset pass"]
    _fails_with(lab, "D", "is not below 0.75 m", my_track=straight)


def test_ekf_consistency_mistakes():
    lab = "ekf_consistency"
    n_runs = _solution(lab)["n_runs"]
    _fails_with(lab, "A1", "has 2 degrees of freedom", nees_bounds=chi2_mean_bounds(1, n_runs))
    _fails_with(lab, "B1", "its NIS has 1 degree of freedom", nis_bounds=chi2_mean_bounds(2, n_runs))
    _fails_with(lab, "C2", "closest to 1", best_R=9.0)


def test_fading_sound_speed_mistakes():
    lab = "fading_sound_speed"
    ns = _solution(lab)
    _fails_with(lab, "A1", "Upside down", mu_gamma=ns["c_e"] / ns["c_nav"])
    from uwtutor.filters import fading_ekf

    sc = ns["scenario"]
    inputs = (ns["x0"], ns["P0"], sc.dr_displacements, sc.ranges, ns["Q"], ns["R"])
    rmse = dict(ns["rmse"])
    rmse["multiplicative EKF"] = ns["final_rmse"](fading_ekf(*inputs, mu_gamma=ns["mu_gamma"],
                                                              sigma_gamma=ns["sigma_gamma"], fading=True))
    _fails_with(lab, "B2", "`fading=False`", rmse=rmse)
    assert check_part(lab, "B1", _with(lab, rmse=rmse)), "a slip in one entry must cost that entry only"
    rmse = dict(ns["rmse"])
    rmse["multiplicative EKF, mu=1"] = ns["final_rmse"](fading_ekf(*inputs, mu_gamma=1.0, fading=False))
    _fails_with(lab, "B3", "Pass `sigma_gamma` too", rmse=rmse)
    measured, true = sc.ranges[:, :60], sc.true_ranges[:, :60]
    _fails_with(lab, "D1", "regresses the true ranges on the measured ones",
                mu_hat=float(np.sum(measured * true) / np.sum(measured**2)))
    _fails_with(lab, "D1", "run 0 only", mu_hat=float(np.sum(measured[0] * true[0]) / np.sum(true[0] ** 2)))
    _fails_with(lab, "D1", "the whole mission",
                mu_hat=float(np.nansum(sc.ranges * sc.true_ranges) / np.nansum(sc.true_ranges**2)))
    # part B computed with the student's own (upside-down) mu_gamma of part A: correct, the slip counts in A1 only
    own = dict(ns["rmse"])
    own["multiplicative EKF"] = ns["final_rmse"](fading_ekf(*inputs, mu_gamma=ns["c_e"] / ns["c_nav"],
                                                             sigma_gamma=ns["sigma_gamma"], fading=False))
    assert all(check_part(lab, part, _with(lab, rmse=own, mu_gamma=ns["c_e"] / ns["c_nav"]))
               for part in ("B1", "B2", "B3", "B4"))


def test_depth_pf_vs_ekf_mistakes():
    lab = "depth_pf_vs_ekf"
    ns = _solution(lab)

    def ess_unnormalised(weights):
        w = np.asarray(weights, dtype=float)
        return float(1.0 / np.sum(w**2))

    def log_of_sum(d, sigma, p, sigma_spike):
        d = np.asarray(d, dtype=float)
        def pdf(x, s):
            return np.exp(-0.5 * (x / s) ** 2) / (s * np.sqrt(2 * np.pi))

        return np.log((1 - p) * pdf(d, sigma) + p * pdf(d, sigma_spike))

    def no_constants(d, sigma, p, sigma_spike):
        d = np.asarray(d, dtype=float)
        return np.logaddexp(np.log1p(-p) - 0.5 * (d / sigma) ** 2, np.log(p) - 0.5 * (d / sigma_spike) ** 2)

    def shifted(d, sigma, p, sigma_spike):
        return ns["mixture_log_likelihood"](d, sigma, p, sigma_spike) + 0.5 * np.log(2 * np.pi)

    _fails_with(lab, "A", "Normalise the weights first", ess=ess_unnormalised)
    text = _fails_with(lab, "B2", "must stay finite far out", mixture_log_likelihood=log_of_sum)
    assert "np.logaddexp" in text
    _fails_with(lab, "B1", "normalising constants", mixture_log_likelihood=no_constants)
    _fails_with(lab, "B1", "normalising constants", mixture_log_likelihood=shifted)
    from uwtutor.filters import DepthEKF

    model, meas = ns["model"], ns["measurements"]
    R = model.R.copy()
    R[0, 0] = ns["spike_sigma"] ** 2
    table = dict(ns["rmse_table"])
    table["EKF, inflated R"] = ns["depth_rmse"](DepthEKF(x0=meas[:, 0], P0=model.R, Q=ns["Q"], R=R).run(meas).x)
    _fails_with(lab, "C1", "spike variance alone", rmse_table=table)
    inflated = DepthEKF(x0=meas[:, 0], P0=model.R, Q=ns["Q"], R=ns["R_inflated"]).run(meas)
    flags = np.abs(inflated.innovations[..., 0]) > 3.0 * np.sqrt(inflated.innovation_cov[..., 0, 0])
    _fails_with(lab, "D", "inflated R", flags=flags)
    _fails_with(lab, "D", "fraction not flagged", false_alarm_rate=1.0 - ns["false_alarm_rate"])


def test_bias_tracking_iekf_mistakes():
    lab = "bias_tracking_iekf"
    ns = _solution(lab)
    sx, sy = ns["sigma_x"], ns["sigma_y"]
    _fails_with(lab, "A", "not their sum", q_bias=sx**2 + sy**2)
    _fails_with(lab, "A", "averages the variances", q_bias=sx * sy)
    on_truth = lsq.precision_factor_history(ns["track"], ns["buoy"])
    text = _fails_with(lab, "C1", "*true* track", alpha_run0=on_truth, k_start_run0=int(np.argmax(on_truth < 2.0)))
    assert "provisional" in text
    _fails_with(lab, "C1", "`np.argmax` of an all-False array is 0", k_start_run0=0)
    from uwtutor.filters import bias_ekf

    x0 = np.column_stack([ns["start_poor"], np.zeros(ns["n_runs"])])
    matched = bias_ekf(x0, ns["P0_good"], ns["dr"], ns["ranges"], ns["Q_a"], ns["R"], beacon=ns["buoy"])
    _fails_with(lab, "C2", "`np.eye(3)`", rmse_direct=ns["final_rmse"](matched))
    _fails_with(lab, "D1", "3 degrees of freedom", nees_bounds=chi2_mean_bounds(2, ns["n_runs"]))
    _fails_with(lab, "E", "α is infinite", alpha_radial=1e6)


def test_cooperative_current_mistakes():
    lab = "cooperative_current"
    ns = _solution(lab)
    t = ns["scenarios"]["zigzag"].times
    offset, drift = ns["clock_offset"], ns["clock_drift"]
    _fails_with(lab, "A", "the offset alone", clock_bias=np.full(t.shape, ns["c"] * offset))
    _fails_with(lab, "A", "c = 1480 m/s, not 1500 m/s", clock_bias=1500.0 * (offset + drift * t))
    from uwtutor.observability import observability_rank

    sc = ns["scenarios"]["zigzag"]
    position_only = int(observability_rank(sc.true_positions, sc.leader_positions, times=sc.times)[-1])
    _fails_with(lab, "B", "rank of the position alone", ranks={**ns["ranks"], "zigzag": position_only})
    history = observability_rank(sc.true_positions, sc.leader_positions, times=sc.times, unknown_current=True)
    early = next(int(r) for r in history if int(r) != int(history[-1]))
    _fails_with(lab, "B", "after the last epoch", ranks={**ns["ranks"], "zigzag": early})
    from uwtutor.filters import cooperative_ekf

    tuning, params = ns["tuning"], ns["params"]
    truth_fed = cooperative_ekf(sc.initial_estimate(), tuning.P1, sc.dr_displacements, sc.ranges, tuning.Q, tuning.R,
                                leader=sc.leader_positions, dt=params.interval)
    _fails_with(lab, "C", "true positions", cur_err={**ns["cur_err"], "zigzag": ns["current_rmse"](truth_fed, sc)})
    res = ns["results"]["zigzag"]
    position_block = float(np.sqrt(np.mean(np.trace(res.P[:, -1, :2, :2], axis1=-2, axis2=-1))))
    _fails_with(lab, "D", "That is the position block", claimed_sigma={**ns["claimed_sigma"], "zigzag": position_block})


def test_outlier_rejection_vmlbl_mistakes():
    lab = "outlier_rejection_vmlbl"
    ns = _solution(lab)

    def small_s(z, z_pred, S, delta=0.03):
        return -delta * z_pred / 2, delta * z_pred / 2, bool(abs(z - z_pred) <= delta * z_pred / 2)

    def no_s(z, z_pred, S, delta=0.03):
        lower = float(np.sqrt((1 - delta) * z_pred**2) - z_pred)
        upper = float(np.sqrt((1 + delta) * z_pred**2) - z_pred)
        return lower, upper, bool(lower <= z - z_pred <= upper)

    _fails_with(lab, "A", "small-S approximation", paper_gate=small_s)
    _fails_with(lab, "A", "D = S + z_pred²", paper_gate=no_s)
    from uwtutor.filters import robust_range_kf
    from uwtutor.lsq import virtual_beacon_lsq

    is_outlier = ns["is_outlier"]
    counts = {}
    for test in ("paper", "chi2"):
        flagged = robust_range_kf(ns["ranges"], test=test).extras["outlier"]
        counts[test] = {"flagged": int(flagged.sum()), "missed": int(np.sum(is_outlier & ~flagged)),
                        "false": int(np.sum(flagged & ~is_outlier))}
    _fails_with(lab, "B", "pass reacquire=None", counts=counts)
    _fails_with(lab, "C1", "the number of outliers", longest_patch=int(is_outlier.sum()))
    _fails_with(lab, "C1", "longest_patch + 5", n_reacquire=20)
    filtered = robust_range_kf(ns["ranges"], q=ns["q"], r=ns["r"], delta=ns["delta"], test="paper",
                               reacquire=30).x[:, 0]
    k, ship, dr, truth = ns["k_fix"], ns["ship"], ns["dr"], ns["truth"]

    def fix_error(ranges, epochs):
        fix = virtual_beacon_lsq(ranges[epochs], ship[epochs], dr[epochs], depth=ns["depth"])
        return float(np.linalg.norm(fix.position - truth[k]))

    warnings.simplefilter("ignore")          # the 10 s spacing is ill-conditioned: that is the lab's point
    newest_first = {s: fix_error(filtered, k - s * np.arange(4)) for s in (10, 60)}
    _fails_with(lab, "D1", "List the epochs oldest first", fix_errors=newest_first)
    raw = {s: fix_error(ns["ranges"], k - s * np.arange(3, -1, -1)) for s in (10, 60)}
    _fails_with(lab, "D1", "Use the filtered ranges", fix_errors=raw)


def test_grader_doctests():
    """The grader's own examples run (it is not under uwtutor/, whose doctests `make test` runs)."""
    import doctest
    import importlib

    import uwtutor_grader

    for name in ("", "._common", ".course", *(f".{lab}" for lab in LAB_NAMES if lab != "real_ranges_plaza")):
        module = importlib.import_module(f"uwtutor_grader{name}")
        result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
        assert result.failed == 0, f"{module.__name__}: {result.failed} doctest(s) failed"
    assert uwtutor_grader.lab_requirements("real_ranges_plaza") == {"gtsam": "uwtutor[data]"}


def test_a_missing_dependency_stops_grading_with_a_message(monkeypatch, capfd):
    """Grading a lab whose package is missing raises (never a quiet zero) and says so on the process's stderr."""
    monkeypatch.setitem(__import__("sys").modules, "gtsam", None)      # import gtsam -> ImportError
    with pytest.raises(LabDependencyMissing, match=r"cannot grade the lab real_ranges_plaza: the package 'gtsam'.*"
                                                   r"pip install \"uwtutor\[data\]\""):
        check_part("real_ranges_plaza", "A", {})
    assert "[uwtutor_grader] ERROR | cannot grade the lab real_ranges_plaza" in capfd.readouterr().err


def test_bias_tracking_iekf_a_slip_in_a_costs_a_only():
    """Parts B-D run on the student's own Q_a: the sum of the DR variances in A fails A and nothing else."""
    lab = "bias_tracking_iekf"
    ns = _solution(lab)
    wrong = _with(lab)
    wrong["Q_a"] = paper_a_process_noise(ns["sigma_x"], ns["sigma_y"], sigma_bias=float(np.sqrt(
        ns["sigma_x"] ** 2 + ns["sigma_y"] ** 2)))
    wrong["q_bias"] = float(wrong["Q_a"][2, 2])
    run = dict(_student_runs(lab, wrong))
    assert "Paper A's rule is the mean of the two DR variances" in _text(check_part(lab, "A", run))
    for part in ("B", "C1", "C2", "D1", "D2", "E"):
        fb = check_part(lab, part, run)
        assert fb, f"part {part}: {fb}"


def _student_runs(lab: str, ns: dict) -> dict:
    """Re-run the answer cells of ``lab`` after part A on ``ns`` (a student who carries part A's answer on)."""
    import matplotlib.pyplot as plt

    nb = nbformat.read(LABS_DIR / lab / f"{lab}.ipynb", as_version=4)
    ns = dict(ns)
    started = False
    with contextlib.redirect_stdout(io.StringIO()), np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for index, cell in enumerate(nb.cells):
            meta = cell.metadata.get("nbgrader", {})
            if meta.get("grade_id") == "A_answer":
                started = True
                continue
            if not started or cell.cell_type != "code" or (meta.get("grade") and not meta.get("solution")):
                continue
            source = "\n".join(line for line in cell.source.split("\n") if not _MARKER.match(line))
            source = "\n".join(line for line in source.split("\n") if not re.match(r"^\w+ = None$", line))
            exec(compile(source, f"{lab}[{index}]", "exec"), ns)
            plt.close("all")
    return ns


def test_real_ranges_plaza_move_first_left_out():
    """Leaving out order="move-first" in B is named in both of B's checks, and part D, computed from the student's
    own result_cal, stays correct."""
    lab = "real_ranges_plaza"
    ns = _solution(lab)
    from uwtutor.filters import extended_kalman_filter
    from uwtutor.models import OdometryMotion

    data = ns["data"]
    dt = np.diff(data.times, prepend=data.times[0])
    motion = OdometryMotion(0.01 + 0.02 * np.abs(data.odometry[:, 0]), 1e-3 * np.sqrt(dt) + 1e-9, gyro_bias=True,
                            times=data.times, gyro_bias_walk=1e-4)                    # order left out
    result = extended_kalman_filter(motion, ns["measurement"], ns["x0"], ns["P0"], data.odometry, ns["z"],
                                    times=data.times, gate=ns["gate"])
    student = _with(lab, motion=motion, result_cal=result, rmse_cal=ns["rmse"](result.x))
    assert student["rmse_cal"] != pytest.approx(ns["rmse_cal"], rel=1e-3), "the mistake changes the RMSE"
    _fails_with(lab, "B1", 'order="move-first"` is left out', motion=motion)
    wrong_b = {k: student[k] for k in ("motion", "result_cal", "rmse_cal")}
    _fails_with(lab, "B2", "default order of operations (turn-first)", **wrong_b)
    err = result.x[:, :2] - ns["truth"][:, :2]
    e = np.einsum("ki,ki->k", err, np.linalg.solve(result.P[:, :2, :2], err[..., None])[..., 0])
    lo, hi = stats.chi2.ppf([0.025, 0.975], 2)
    own = {**student, "nees_mean": float(np.mean(e)), "nees_inside": float(np.mean((e >= lo) & (e <= hi)))}
    assert check_part(lab, "D1", own) and check_part(lab, "D2", own), "a correct D on the student's own filter"
    assert check_part(lab, "C", own)


def test_real_ranges_plaza_mistakes():
    lab = "real_ranges_plaza"
    ns = _solution(lab)
    from uwtutor_grader import real_ranges_plaza as grader

    ref = grader.reference()
    assert ns["s_cal"] == pytest.approx(ref["s_cal"], rel=1e-9) and ns["rmse_cal"] == pytest.approx(ref["rmse_cal"])
    r, d = ns["r_leg"], ns["d_leg"]
    _fails_with(lab, "A", "line with an offset", s_cal=np.polyfit(d, r, 1)[0])
    _fails_with(lab, "A", "mean of the ratios", s_cal=np.mean(r / d))
    _fails_with(lab, "B2", "filter with a scale state", rmse_cal=ns["rmse_est"])
    _fails_with(lab, "B2", "raw ranges", rmse_cal=grader._rmse(grader._navigate(scale=False).x))
    _fails_with(lab, "C", "calibrated filter of part B", rmse_est=ns["rmse_cal"])
    _fails_with(lab, "C", "your calibrated scale", scale_end=ns["s_cal"])
    _fails_with(lab, "D2", "a percentage", nees_inside=100 * ns["nees_inside"])
    _fails_with(lab, "D1", "the median", nees_mean=float(np.median(ns["nees_k"])))
    _fails_with(lab, "B2", "not a usable range scale", s_cal=float("nan"))
    # a mistake in A is not counted again in B: the reference of B is run with the student's own scale
    affine = float(np.polyfit(d, r, 1)[0])
    assert not check_part(lab, "A", _with(lab, s_cal=affine))
    fb = check_part(lab, "B2", _with(lab, s_cal=affine, rmse_cal=grader._rmse(grader._calibrated(affine).x)))
    assert fb, fb


# -- no answer in the feedback ----------------------------------------------------------------------------------------
def test_feedback_never_shows_the_expected_value():
    lab = "range_error_budget"
    ns = _solution(lab)
    c_e = ns["c_e"]
    for wrong in (c_e + 0.05, c_e * 1.004, c_e + 40.0, c_e * 3.5, -c_e / 7):
        text = _text(check_part(lab, "B1", _with(lab, c_e=wrong)))
        assert not re.search(r"\d+(\.\d+)? ?%", text), f"a percentage tells the answer: {text}"
        hidden = ["times the expected", "off by", "tolerance is", "expected"]
        if abs(wrong - c_e) > 1:          # a near miss shows the student's own value, which is close to the answer
            hidden += [f"{c_e:.6g}", f"{c_e:.2f}", f"{c_e:.1f}"]
        for shown in hidden:
            assert shown not in text, f"{shown!r} in the feedback of c_e = {wrong}: {text}"
    text = _text(check_part(lab, "A", _with(lab, profile_speeds=ns["profile_speeds"] + np.arange(9.0))))
    assert "expected" not in text and f"{ns['profile_speeds'][8]:.6g}" not in text
    lab = "bias_tracking_iekf"
    ns = _solution(lab)
    text = _text(check_part(lab, "C1", _with(lab, k_start_run0=ns["k_start_run0"] + 3)))
    assert str(ns["k_start_run0"]) not in text.replace(str(ns["k_start_run0"] + 3), "")
    lab = "depth_pf_vs_ekf"
    ns = _solution(lab)
    flags = ns["flags"].copy()
    flags[0, :5] = ~flags[0, :5]
    text = _text(check_part(lab, "D", _with(lab, flags=flags)))
    assert "5 of 4800 flags of flags differ" in text and "indices" not in text and "index" not in text


# -- what each typical-mistake student scores (tests/lab_mistakes.py; nbgrader confirms in test_labs_nbgrader) ------
def _graded_cells(lab: str, change: tuple[str, str, str] | None = None) -> dict[str, tuple[float, str | None]]:
    """Run the lab's solution (with ``change`` = (grade_id, right, wrong) applied) cell by cell, test cells included,
    as nbgrader's autograde does: each test cell's points, and the error that stopped it (``None`` if it passed)."""
    import matplotlib.pyplot as plt

    nb = nbformat.read(LABS_DIR / lab / f"{lab}.ipynb", as_version=4)
    ns: dict = {"__name__": "__lab__"}
    cells: dict[str, tuple[float, str | None]] = {}
    for index, cell in enumerate(nb.cells):
        if cell.cell_type != "code":
            continue
        meta = cell.metadata.get("nbgrader", {})
        source = "\n".join(line for line in cell.source.split("\n") if not _MARKER.match(line))
        if change is not None and meta.get("grade_id") == change[0]:
            assert change[1] in source, f"{lab}: {change[1]!r} is not in {change[0]} (update tests/lab_mistakes.py)"
            source = source.replace(change[1], change[2])
        error = None
        try:
            with contextlib.redirect_stdout(io.StringIO()), np.errstate(all="ignore"), warnings.catch_warnings():
                warnings.simplefilter("ignore")
                exec(compile(source, f"{lab}[{index}]", "exec"), ns)
        except Exception as exc:  # a failing test cell scores 0, as in nbgrader
            error = f"{type(exc).__name__}: {exc}"
        plt.close("all")
        if meta.get("grade") and cell.cell_type == "code":
            cells[meta["grade_id"]] = (float(meta["points"]), error)
    return cells


@pytest.mark.parametrize("student", sorted(TYPICAL_MISTAKES))
def test_a_typical_mistake_costs_its_own_step_only(student):
    """Each typical-mistake student of the instructor notes loses the points of the step with the slip, and no
    other: the later parts are checked against the student's own earlier answers."""
    lab, change, points, failing, phrase = TYPICAL_MISTAKES[student]
    if lab == "real_ranges_plaza":
        pytest.importorskip("gtsam", reason="the Plaza logs come with gtsam: pip install -e '.[data]'")
    cells = _graded_cells(lab, change)
    failed = {gid for gid, (_, error) in cells.items() if error is not None}
    assert failed == failing, {gid: cells[gid][1] for gid in failed}
    assert sum(p for p, error in cells.values() if error is None) == points
    assert any(phrase in " ".join(cells[gid][1].split()) for gid in failing), "the feedback names the mistake"
    assert not any("close, but" in cells[gid][1] for gid in failing), "a conceptual slip is not called a rounding"
