"""Chapter 11 checkers: the right answers pass, the usual mistakes get the hint that explains them, bad input is
named, and the student version holds no solution."""

from __future__ import annotations

from pathlib import Path

import nbformat
import numpy as np
import pytest

pytest.importorskip("gtsam", reason="the Plaza data come with the gtsam wheel (uwtutor[data])")

from uwtutor.datasets import navigate, navigation_models, plaza  # noqa: E402
from uwtutor.exercises import Feedback, ch11  # noqa: E402
from uwtutor.exercises.generate import make_student_version  # noqa: E402
from uwtutor.exercises.nbgrader_meta import nbgrader_problems  # noqa: E402
from uwtutor.filters import ChiSquareGate, ReacquiringGate, extended_kalman_filter  # noqa: E402

SOURCE = Path(__file__).resolve().parents[1] / "exercises" / "ch11_real_data.ipynb"


def _text(fb: Feedback) -> str:
    return f"{fb.message}\n{fb.hint or ''}"


# -- expected values computed here, independently of the checkers ------------------------------------------------------
@pytest.fixture(scope="module")
def data():
    return plaza(2)


@pytest.fixture(scope="module")
def fit(data):
    r, d = data.ranges_on_epochs(), data.true_ranges()
    keep = ~np.isnan(r)
    r, d = r[keep], d[keep]
    s = np.sum(r * d) / np.sum(d * d)
    return {"s": s, "std": np.std(r - s * d), "r": r, "d": d}


@pytest.fixture(scope="module")
def drift_rate(data):
    diff = np.unwrap(data.dead_reckoning()[:, 2]) - np.unwrap(data.truth[:, 2])
    A = np.column_stack([data.times, np.ones(data.n_epochs)])
    return np.degrees(np.linalg.lstsq(A, diff, rcond=None)[0][0])


def _rmse(x, truth):
    return float(np.sqrt(np.mean(np.sum((x[:, :2] - truth[:, :2]) ** 2, axis=1))))


@pytest.fixture(scope="module")
def lockout(data):
    m = navigation_models(data, [5], scale_prior=0.002)
    args = (m.motion, m.measurement, m.x0, m.P0, data.odometry, m.z)
    locked = extended_kalman_filter(*args, times=data.times, gate=ChiSquareGate(0.99, per_component=True))
    back = extended_kalman_filter(*args, times=data.times,
                                  gate=ReacquiringGate(ChiSquareGate(0.99, per_component=True), patience=10))
    present = ~np.isnan(m.z[:, 0])
    accepted = locked.extras["accepted"].reshape(-1)
    return {"n": int(np.sum(present & ~accepted)), "epochs": int(np.sum(~accepted)),
            "locked": _rmse(locked.x, data.truth), "back": _rmse(back.x, data.truth)}


def test_exercise_data_are_what_the_notebook_says():
    assert (ch11.SET, ch11.GAIN_BEACONS, ch11.LOCKOUT_BEACON) == (2, "all", 5)
    assert (ch11.TIGHT_SCALE_PRIOR, ch11.STRICT_PROBABILITY, ch11.PATIENCE) == (0.002, 0.99, 10)
    source = SOURCE.read_text(encoding="utf-8")
    for name in ("ch11.LOCKOUT_BEACON", "ch11.TIGHT_SCALE_PRIOR", "ch11.STRICT_PROBABILITY", "ch11.PATIENCE"):
        assert name in source


def test_right_answers_pass(data, fit, drift_rate, lockout):
    gain = (_rmse(navigate(data, gyro_bias=True, scale=False).x, data.truth)
            / _rmse(navigate(data, gyro_bias=True, scale=True).x, data.truth))
    for check, answer in [(ch11.check_scale, fit["s"]), (ch11.check_scale, np.float32(fit["s"])),
                          (ch11.check_scale, [fit["s"]]), (ch11.check_residual_std, fit["std"]),
                          (ch11.check_drift_rate, drift_rate), (ch11.check_scale_gain, gain),
                          (ch11.check_rejected, lockout["n"]), (ch11.check_rejected, np.int64(lockout["n"])),
                          (ch11.check_locked_rmse, lockout["locked"]),
                          (ch11.check_reacquired_rmse, lockout["back"])]:
        fb = check(answer)
        assert fb.correct, (check.__name__, answer, fb.message, fb.hint)
        fb.assert_correct()
    assert 1.06 < fit["s"] < 1.08 and -0.4 < drift_rate < -0.2 and gain > 10
    assert lockout["n"] > 0.8 * np.sum(~np.isnan(data.ranges_on_epochs([5]))), "the strict gate locks out"
    assert lockout["back"] < 0.2 * lockout["locked"], "re-acquisition recovers"


def test_usual_mistakes_get_their_hint(data, fit, drift_rate, lockout):
    r, d = fit["r"], fit["d"]
    cases = [
        (ch11.check_scale, np.mean(r / d), "mean of the ratios"),
        (ch11.check_scale, np.polyfit(d, r, 1)[0], "offset"),
        (ch11.check_scale, np.sum(d * r) / np.sum(r * r), "slope of d on r"),
        (ch11.check_scale, 100 * (fit["s"] - 1), "percent"),
        (ch11.check_residual_std, np.std(r - d), "without the scale"),
        (ch11.check_residual_std, fit["std"] ** 2, "variance"),
        (ch11.check_drift_rate, np.radians(drift_rate), "rad/s"),
        (ch11.check_drift_rate, 60 * drift_rate, "per minute"),
        (ch11.check_rejected, lockout["epochs"], "epochs without any range"),
        (ch11.check_locked_rmse, lockout["back"], "re-acquisition"),
        (ch11.check_reacquired_rmse, lockout["locked"], "without re-acquisition"),
    ]
    raw = data.dead_reckoning()[:, 2] - data.truth[:, 2]           # each heading wrapped: jumps of 2 pi
    cases.append((ch11.check_drift_rate, np.degrees(np.polyfit(data.times, raw, 1)[0]), "np.unwrap"))
    for check, answer, words in cases:
        fb = check(answer)
        assert not fb.correct and words in _text(fb), (check.__name__, answer, _text(fb))
    v = ch11.scale_variants()
    assert len({round(x, 7) for x in (v["scale"], v["mean_ratio"], v["affine_slope"], v["inverse"])}) == 4, \
        "the recognised mistakes must differ from the answer by more than the tolerance"


def test_another_estimator_of_the_scale_is_named_first(fit):
    """The mean of the ratios is a choice of formula, not a near miss: the message leads with it; a printout of the
    right value copied back is called rounded, not a wrong formula."""
    r, d = fit["r"], fit["d"]
    fb = ch11.check_scale(np.mean(r / d))
    assert fb.message.startswith("Not yet: ") and "the mean of the ratios r/d" in fb.message, fb.message
    assert "close" not in fb.message.lower(), fb.message
    rounded = ch11.check_scale(round(fit["s"], 4))
    assert not rounded.correct and "rounded to 4 decimals" in rounded.message, rounded.message
    assert ch11.check_scale(round(fit["s"], 6)).correct


def test_scale_gain_mistakes(data):
    g = ch11.check_scale_gain
    grid = {s: _rmse(navigate(data, gyro_bias=gb, scale=sc).x, data.truth)
            for s, (gb, sc) in {"gyro": (True, False), "both": (True, True)}.items()}
    fb = g(grid["both"] / grid["gyro"])
    assert not fb.correct and "without over with" in _text(fb)
    fb = g(grid["gyro"] - grid["both"])
    assert not fb.correct and "difference" in _text(fb)


@pytest.mark.parametrize("check", [ch11.check_scale, ch11.check_residual_std, ch11.check_drift_rate,
                                   ch11.check_scale_gain, ch11.check_rejected, ch11.check_locked_rmse,
                                   ch11.check_reacquired_rmse])
def test_bad_numbers_are_named(check):
    assert "No answer yet" in _text(check(None))
    assert "NaN" in _text(check(float("nan")))
    assert "quotes" in _text(check("1.07"))
    for answer in (None, float("nan"), "1.07", True, [1.0, 2.0]):
        assert not check(answer).correct


def test_source_carries_nbgrader_metadata_and_the_student_version_has_no_solution():
    source = nbformat.read(SOURCE, as_version=4)
    assert nbgrader_problems(source) == []
    assert all(not c.get("outputs") for c in source.cells if c.cell_type == "code")
    kinds = [c.metadata["nbgrader"]["grade_id"].rsplit("_", 1)[-1].rstrip("0123456789")
             for c in source.cells if "nbgrader" in c.metadata]
    assert kinds.count("check") == 7 and kinds.count("answer") == 6 and kinds.count("written") == 2
    student = make_student_version(SOURCE)
    text = "\n".join(c.source for c in student.cells)
    for marker in ("BEGIN SOLUTION", "END SOLUTION", "HIDDEN TESTS", "assert_correct"):
        assert marker not in text
    for solution in ("(r @ d) / (d @ d)", "np.polyfit(data.times, drift, 1)", "without_scale / with_scale",
                     "present & ~locked",
                     "ReacquiringGate(ChiSquareGate(ch11.STRICT_PROBABILITY, per_component=True),\n",
                     "the only information"):
        assert solution not in text, solution
    code = "\n".join(c.source for c in student.cells if c.cell_type == "code")
    assert code.count("# YOUR CODE HERE") == 6 and code.count("raise NotImplementedError") == 6
    assert text.count("YOUR ANSWER HERE") == 2
    for name in ("s_hat", "sigma_r", "drift_rate", "gain", "n_rejected", "rmse_locked", "rmse_reacquired"):
        assert f"{name} = None" in text
