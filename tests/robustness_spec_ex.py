"""The robustness contract's specifications of the exercises' data and helpers and of the widgets' views (issue 26).

Each widget factory (``*_view``) takes the values its sliders set, and a reader may call it with any value: its
valid call here is the smallest the factory allows (few runs, few particles), so that the contract stays fast.
The exercises' helpers a student calls in the notebooks (``ch02.turn_track``, ``ch05.final_rmse``...) are
specified too; what is exempt is data with no argument, a reference solution that only its checker calls with the
checker's own cases, and a container that a view function builds.
"""

from __future__ import annotations

import importlib
from typing import Callable

import numpy as np

from robustness_kinds import Answer, Choice, Covariance, Flag, Instance, Int, Mapping, Real
from robustness_spec import Spec, _checker_spec

_RUNS = Int(minimum=1, unbounded_work=True)


def _steady() -> dict:
    from uwtutor.exercises.ch05 import STEADY
    return dict(STEADY)


def _ch05_study_arrays() -> dict:
    truth = np.zeros((3, 4, 2))
    truth[..., 0] = np.arange(4.0)
    estimates = truth + np.array([1.0, -2.0])
    return dict(estimates=estimates, truth=truth)


def _bound_check(value, baseline) -> list[str]:
    """An RMSE bound: a float >= 0, ``inf`` for a track that does not turn (the current is unobservable)."""
    ok = isinstance(value, float) and not np.isnan(value) and value >= 0.0
    return [] if ok else [f"the bound is {value!r}, not a number >= 0 (or inf)"]


def _answered(key: str, right: Callable[[], dict], per_argument: int | None = None) -> Spec:
    """A checker of several answers, called with the right ones and one hostile answer at a time: the rule's
    spec leaves the others ``None`` ("not answered yet", checked first), which never reaches the parsing of the
    rest (ch06's GM(1,1) checker crashed on an unreadable ``a`` only once ``b`` was given)."""
    spec = _checker_spec(_target(key))
    return Spec(right, kinds=spec.kinds, check=spec.check, refused=spec.refused, crash_is_obscure=True,
                per_argument=per_argument or len(Answer().hostile(None)))


def _target(key: str) -> Callable:
    module, name = key.split(":")
    return getattr(importlib.import_module(module), name)


def _gm11_right() -> dict:
    from uwtutor.exercises.ch06 import DEPTH_SERIES
    from uwtutor.grey import fit_gm11
    model = fit_gm11(DEPTH_SERIES)
    return dict(a=model.a, b=model.b)


def _final_rmse_right() -> dict:
    from uwtutor.exercises import ch05
    res = ch05._study_results()
    return {f"rmse_{k}": ch05.final_rmse(res[k], res["truth"]) for k in ("ekf", "mult", "isfekf")}


SPECS_EX: dict[str, Spec] = {
    # exercises: the helpers a student calls in the notebooks
    "uwtutor.exercises.ch02:turn_track": Spec(lambda: dict(turn_deg=20.0), kinds=dict(turn_deg=Real(()))),
    "uwtutor.exercises.ch02:turn_rmse_bound": Spec(lambda: dict(turn_deg=20.0), kinds=dict(turn_deg=Real(())),
                                                   check=_bound_check),
    "uwtutor.exercises.ch04:diagnosis_studies": Spec(lambda: dict(n_runs=2, seed=4),
                                                     kinds=dict(n_runs=Int(minimum=2, unbounded_work=True)),
                                                     per_argument=4),
    # the hostile values change the first epoch, which is not read (NaN where a filter has not started); a NaN at
    # the last epoch is refused: tests/test_robustness_reproducers.py
    "uwtutor.exercises.ch05:final_rmse": Spec(_ch05_study_arrays,
                                              kinds=dict(estimates=Real((3, 4, 2), nan_ok=True, inf_ok=True),
                                                         truth=Real((3, 4, 2)))),
    # checkers of several answers: the others right, so that each answer's own parsing is reached
    "uwtutor.exercises.ch06:check_gm11_coefficients": _answered("uwtutor.exercises.ch06:check_gm11_coefficients",
                                                                _gm11_right),
    # (its study takes 0.1 s a call: 4 hostile answers each here; all 20 of the kind pass too)
    "uwtutor.exercises.ch05:check_final_rmse": _answered("uwtutor.exercises.ch05:check_final_rmse", _final_rmse_right,
                                                         per_argument=4),
    "uwtutor.exercises.ch04:check_diagnosis": _answered("uwtutor.exercises.ch04:check_diagnosis",
                                                        lambda: dict(consistent="A", overconfident="A")),
    # the checker reads the letters before it runs its study (7 s): every hostile answer is refused at once
    "uwtutor.exercises.ch07:check_bias_diagnosis": _answered("uwtutor.exercises.ch07:check_bias_diagnosis",
                                                             lambda: dict(consistent="A", overconfident="A")),
    "uwtutor.exercises.ch05:threshold_innovation": Spec(
        lambda: dict(beta=2.0, steady=_steady()),
        kinds=dict(beta=Real((), "nonneg"),
                   steady=Mapping({"rho": 1.5, "N": -1.0, "R": float("nan"), "CQC": "abc"}))),
    "uwtutor.exercises.ch07:bias_diagnosis_studies": Spec(
        lambda: dict(n_runs=2, n_obs=20, seed=5, rate=0.03),
        kinds=dict(n_runs=Int(minimum=2, unbounded_work=True), n_obs=Int(minimum=2, unbounded_work=True),
                   rate=Real(())), per_argument=4),
    "uwtutor.exercises.ch07:straight_track": Spec(lambda: dict(n=40), kinds=dict(n=Int(minimum=2,
                                                                                       unbounded_work=True))),
    # widgets: the compute function behind each slider
    "uwtutor.widgets.ch01:sound_speed_view": Spec(
        lambda: dict(temperature=10.0, salinity=35.0, depth=1000.0),
        kinds=dict(temperature=Real(()), salinity=Real((), "nonneg"), depth=Real((), "nonneg"))),
    "uwtutor.widgets.ch01:range_error_view": Spec(
        lambda: dict(noise_sigma=0.7, assumed_speed=1470.0, bias_mean=5.0, bias_sigma=3.0, bias_time_constant=200.0,
                     outlier_amplitude=80.0, seed=1),
        kinds=dict(noise_sigma=Real((), "nonneg"), assumed_speed=Real((), "pos"), bias_mean=Real(()),
                   bias_sigma=Real((), "nonneg"), bias_time_constant=Real((), "pos"), outlier_amplitude=Real(()))),
    "uwtutor.widgets.ch02:observability_view": Spec(
        lambda: dict(track="straight + turn", turn_angle_deg=60.0, sigma=5.0, state="position"),
        kinds=dict(track=Choice(), turn_angle_deg=Real(()), state=Choice())),
    "uwtutor.widgets.ch03:precision_view": Spec(
        lambda: dict(n_obs=20, turn_deg=90.0, radius=1500.0, noise_sigma=2.0, bias=10.0, n_runs=5, seed=0),
        kinds=dict(n_obs=Int(minimum=1, unbounded_work=True), turn_deg=Real((), "pos"), radius=Real((), "pos"),
                   noise_sigma=Real((), "pos"), bias=Real(()), n_runs=_RUNS)),
    "uwtutor.widgets.ch03:prelocation_view": Spec(
        lambda: dict(bearing_step_deg=10.0, speed_step=25.0, epoch=5, seed=0),
        kinds=dict(bearing_step_deg=Real((), "pos"), speed_step=Real((), "pos"),
                   epoch=Int(minimum=2, unbounded_work=True))),
    "uwtutor.widgets.ch03:covariance_ellipse": Spec(
        lambda: dict(cov=np.array([[4.0, 1.0], [1.0, 2.0]]), scale=2.0, n=10),
        kinds=dict(cov=Covariance(), scale=Real((), "pos"), n=Int(minimum=2, unbounded_work=True)),
        check=lambda v, b: [] if np.all(np.isfinite(v)) else ["the ellipse has NaN/inf points"]),
    "uwtutor.widgets.ch04:ekf_view": Spec(
        lambda: dict(initial_error=30.0, q_scale=1.0, r_scale=1.0, bias=0.0, n_runs=2, seed=0, n_shown=1),
        kinds=dict(initial_error=Real((), "pos"), q_scale=Real((), "pos"), r_scale=Real((), "pos"), bias=Real(()),
                   n_runs=Int(minimum=2, unbounded_work=True),
                   n_shown=Int(minimum=0))),  # the first min(n_shown, n_runs) runs are kept: no work
    "uwtutor.widgets.ch05:fading_view": Spec(
        lambda: dict(assumed_dc=-30.0, rho=0.95, weakening=True, initial_error=150.0, n_runs=2, seed=0),
        kinds=dict(assumed_dc=Real(()), rho=Real((), "open01"), weakening=Flag(), initial_error=Real((), "pos"),
                   n_runs=_RUNS), per_argument=4),
    "uwtutor.widgets.ch06:gpf_view": Spec(
        lambda: dict(n_particles=10, grey_fraction=0.1, noise_window=50, noise_change=3.0, seed=1),
        kinds=dict(n_particles=Int(minimum=10, unbounded_work=True), grey_fraction=Real((), "prob"),
                   noise_window=Int(minimum=12, unbounded_work=True), noise_change=Real((), "pos")), per_argument=4),
    "uwtutor.widgets.ch07:bias_tracking_view": Spec(
        lambda: dict(drift_rate=0.0, initial_error=150.0, max_alpha=2.0, n_runs=2, n_obs=600, seed=0),
        kinds=dict(drift_rate=Real(()), initial_error=Real((), "nonneg"), max_alpha=Real((), "pos"),
                   n_runs=Int(minimum=2, unbounded_work=True), n_obs=Int(minimum=600, unbounded_work=True)),
        per_argument=3),
    "uwtutor.widgets.ch08:cooperative_view": Spec(
        lambda: dict(pattern="zigzag", current=0.7071, interval=8.0, packet_loss=0.0, tuning="matched", n_runs=2,
                     seed=0),
        kinds=dict(pattern=Choice(), current=Real((), "nonneg"), interval=Real((), "pos"),
                   packet_loss=Real((), "prob"), tuning=Choice(), n_runs=_RUNS), per_argument=3),
    "uwtutor.widgets.ch09:outlier_view": Spec(
        lambda: dict(amplitude=80.0, pattern="paper", delta=0.03, spacing=100, test="paper", reacquire=True, seed=0),
        kinds=dict(amplitude=Real((), "nonneg"), pattern=Choice(), delta=Real((), "open01"),
                   spacing=Int(minimum=10, maximum=300), test=Choice(), reacquire=Flag()), per_argument=3),
    "uwtutor.widgets.ch10:comparison_view": Spec(
        lambda: dict(scenario="circle", condition="white", table=None),
        kinds=dict(scenario=Choice(), condition=Choice(), table=Instance(optional=True))),
}

_NO_ARGUMENTS = "no arguments: the data of exercise {} (covered by its tests in tests/test_exercises_{}.py)"
_REFERENCE = ("the reference solution exercise {}'s checker compares a student's function with; called only on the "
              "checker's own cases (tests/test_exercises_{}.py)")
_VIEW = "a view container built by {} (library-made values, never called with user data)"

EXEMPT_EX: dict[str, str] = {
    "uwtutor.exercises.ch02:straight_current_jacobian": _NO_ARGUMENTS.format("2.4", "ch02"),
    "uwtutor.exercises.ch05:study": _NO_ARGUMENTS.format("5.4", "ch05"),
    "uwtutor.exercises.ch08:leader_study": _NO_ARGUMENTS.format("8.4", "ch08"),
    "uwtutor.exercises.ch09:lockout_dive": _NO_ARGUMENTS.format("9.3", "ch09"),
    "uwtutor.exercises.ch09:study": _NO_ARGUMENTS.format("9.4", "ch09"),
    "uwtutor.exercises.ch10:bound_variants": _NO_ARGUMENTS.format("10.1", "ch10"),
    "uwtutor.exercises.ch10:choice_rows": _NO_ARGUMENTS.format("10.3", "ch10"),
    "uwtutor.exercises.ch03:travel_time_cost_reference": _REFERENCE.format("3.4", "ch03_ch04"),
    "uwtutor.exercises.ch03:vmlbl_system_reference": _REFERENCE.format("3.3", "ch03_ch04"),
    "uwtutor.exercises.ch04:ekf_update_reference": _REFERENCE.format("4.2", "ch03_ch04"),
    "uwtutor.exercises.ch04:ekf_run_reference": _REFERENCE.format("4.6", "ch03_ch04"),
    "uwtutor.exercises.ch04:run_data": _NO_ARGUMENTS.format("4.6", "ch03_ch04"),
    "uwtutor.exercises.ch05:fading_factors_reference": _REFERENCE.format("5.2", "ch05"),
    "uwtutor.exercises.ch08:pair_jacobian_reference": _REFERENCE.format("8.3", "ch08"),
    "uwtutor.exercises.ch08:resolve_reference": _REFERENCE.format("8.2", "ch08"),
    "uwtutor.exercises.checks:Case": "a test case a checker builds from its own values (the checkers' author's, "
                                     "never a student's); check_function's handling of cases is tested in "
                                     "tests/test_exercise_system.py",
    "uwtutor.exercises.checks:not_answered": "builds the Feedback for an unanswered exercise from the checker's own "
                                             "text (never a student's value)",
    "uwtutor.widgets.ch01:SoundSpeedView": _VIEW.format("sound_speed_view"),
    "uwtutor.widgets.ch01:RangeErrorView": _VIEW.format("range_error_view"),
    "uwtutor.widgets.ch02:ObservabilityView": _VIEW.format("observability_view"),
    "uwtutor.widgets.ch03:PrecisionView": _VIEW.format("precision_view"),
    "uwtutor.widgets.ch03:PrelocationView": _VIEW.format("prelocation_view"),
    "uwtutor.widgets.ch04:EKFView": _VIEW.format("ekf_view"),
    "uwtutor.widgets.ch05:FadingView": _VIEW.format("fading_view"),
    "uwtutor.widgets.ch06:GPFView": _VIEW.format("gpf_view"),
    "uwtutor.widgets.ch07:BiasTrackingView": _VIEW.format("bias_tracking_view"),
    "uwtutor.widgets.ch08:CooperativeView": _VIEW.format("cooperative_view"),
    "uwtutor.widgets.ch09:OutlierView": _VIEW.format("outlier_view"),
    "uwtutor.widgets.ch10:ComparisonView": _VIEW.format("comparison_view"),
}

