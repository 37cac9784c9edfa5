"""The argument specification of every public callable of ``uwtutor`` (the robustness contract, issue 26).

How a target (``module:qualname``, see ``robustness_discovery``) finds its specification, in this order:

1. ``SPECS[key]`` -- a :class:`Spec`: a factory of valid keyword arguments (small: each call takes milliseconds),
   the kind of each argument (``robustness_kinds``: ``Real``, ``Covariance``, ``Int``, ``Rng``, ``Seed``,
   ``Choice``, ``Flag``, ``Func``, ``Instance``, ``Mapping``, ``Answer``, ``StudentFunc``), optionally how to call
   it (``call``, e.g. build a model then call its ``f``) and what a valid answer is (``check``).
2. ``RULES`` -- a family rule (e.g. every ``check_*`` of ``uwtutor.exercises.chNN``: its arguments are student
   answers or student functions). A new chapter's checkers are covered by the rule with no new line.
3. ``EXEMPT[key]`` or an ``EXEMPT_RULES`` pattern -- not called with user data, with the reason.
4. ``PENDING`` -- targets whose specification is still to be written (the debt as of issue 26, listed by name so
   that it can only shrink: a key that disappears from the package must be removed here).

A discovered target found in none of them fails ``test_every_public_callable_has_a_specification``.

To add a module: add one ``SPECS`` entry per public callable (copy a neighbour: most arguments reuse the kinds of
``KIND_BY_NAME``, so an entry is often a line of valid values), or a ``RULES`` entry for a family.
"""

from __future__ import annotations

import fnmatch
import functools
import inspect
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from robustness_kinds import (Answer, Choice, Covariance, Flag, Func, Instance, Int, Kind, Mapping, Model, Real, Rng,
                              Seed, StudentFunc)


@dataclass
class Spec:
    valid: Callable[[], dict[str, Any]]
    kinds: dict[str, Kind] = field(default_factory=dict)
    call: Callable[..., Any] | None = None           # default: the target itself, called with keyword arguments
    check: Callable[[Any, Any], list[str]] | None = None
    refused: Callable[[Any], bool] | None = None     # an answer that is itself a refusal (a checker's Feedback)
    crash_is_obscure: bool = False                    # checkers: any exception is a crash
    names: tuple[str, ...] = ()                       # other words an error may use for the argument
    per_argument: int | None = None                   # hostile values per argument (default PER_ARGUMENT)


#: The kind of an argument when a spec does not say (the same name means the same thing across the library).
KIND_BY_NAME: dict[str, Kind] = {
    "rng": Rng(), "seed": Seed(),
    "x0": Real(None), "P0": Covariance(definite=True), "Q": Covariance(), "R": Covariance(definite=True),
    "u": Real(None), "z": Real(None, "nonneg", nan_ok=True), "ranges": Real(None, "nonneg", nan_ok=True),
    "beacon": Real((2,)), "beacons": Real((None, 2)), "position": Real((2,)), "positions": Real((None, 2)),
    "sigma": Real((), "pos"), "dt": Real((), "pos"), "times": Real((None,)),
    "estimates": Real(None), "truth": Real(None), "covariances": Real(None),
    "n_runs": Int(minimum=1, unbounded_work=True), "n": Int(minimum=1, unbounded_work=True),
    "confidence": Real((), "open01"), "probability": Real((), "open01"), "delta": Real((), "open01"),
    "q": Real((), "nonneg"), "r": Real((), "pos"), "two_way": Flag(), "sound_speed": Real((), "pos"),
    "speed": Real((), "pos"), "radius": Real((), "pos"), "depth": Real((), "nonneg"),
    # a user's model with a bug in one method (complex, NaN, wrong shape, indefinite or non-symmetric Q/R)
    "motion": Model(), "measurement": Model(), "motions": Model(),
}


# --- shared valid inputs ----------------------------------------------------------------------------------------------
def _circle(K: int = 5):
    theta = np.linspace(0.0, 1.0, K + 1)
    track = np.column_stack([300.0 * np.cos(theta), 300.0 * np.sin(theta)])
    u = np.diff(track, axis=0)
    z = np.linalg.norm(track[1:], axis=1) + 0.3
    return track, track[0] + [3.0, -2.0], u, z


_TRACK, _X0, _U, _Z = _circle()
_BEACONS = np.array([[1000.0, 0.0], [0.0, 1000.0], [-1000.0, 0.0], [0.0, -1000.0]])
_RANGES = np.linalg.norm(np.array([30.0, -40.0]) - _BEACONS, axis=1) + 5.0


def _models():
    from uwtutor.models import DeadReckoning, RangeToBeacon
    return DeadReckoning(np.eye(2) * 0.1), RangeToBeacon((0.0, 0.0), R=1.0)


def _ekf_result():
    from uwtutor.filters import extended_kalman_filter
    motion, meas = _models()
    return extended_kalman_filter(motion, meas, _X0, np.eye(2) * 100.0, _U, _Z)


def _ekf(**kw):
    from uwtutor.filters import extended_kalman_filter
    from uwtutor.models import DeadReckoning, RangeToBeacon
    return extended_kalman_filter(DeadReckoning(kw["Q"]), RangeToBeacon((0.0, 0.0), R=kw["R"]), kw["x0"], kw["P0"],
                                  kw["u"], kw["z"])


def _is_feedback_refusal(value: Any) -> bool:
    from uwtutor.exercises.feedback import Feedback
    return isinstance(value, Feedback) and not value.correct


def _feedback_check(value: Any, baseline: Any) -> list[str]:
    from uwtutor.exercises.feedback import Feedback
    if not isinstance(value, Feedback):
        return [f"a checker returned {type(value).__name__}, not Feedback"]
    if value.correct:
        return ["a hostile answer was judged correct"]
    return []


def _staggered():
    u = np.tile([1.0, 0.0], (2, 10, 1))
    truth = np.array([100.0, 50.0]) + np.cumsum(u, axis=1)
    return u, truth, np.linalg.norm(truth, axis=-1)


@functools.lru_cache(maxsize=1)
def _paper_e():
    from uwtutor.scenarios import paper_e
    return paper_e.make(np.random.default_rng(3))


@functools.lru_cache(maxsize=1)
def _small_log():
    """A square driven twice with ranges to two beacons and its truth (ranges 5 % long, 0.1 m offset): a
    RangeDataset whose filters take milliseconds."""
    from uwtutor.datasets import square_log
    return square_log(range_scale=1.05, range_offset=0.1)


def _batched_ekf(x0, z):
    """The range-only EKF on the small circle, batched over the runs of ``x0`` and ``z`` (a user's filter_fn)."""
    from uwtutor.filters import range_only_ekf
    return range_only_ekf(x0, np.eye(2) * 100.0, _U, z, np.eye(2) * 0.1, 1.0)


def _study_draw(rng, n):
    """``n`` runs of the small circle with noisy ranges: a user's draw(rng, n) -> (inputs, truth)."""
    z = _Z + rng.normal(0.0, 1.0, (n, len(_Z)))
    return dict(x0=np.tile(_X0, (n, 1)), z=np.abs(z)), _TRACK[1:]


def _study_estimate(inputs):
    return _batched_ekf(inputs["x0"], inputs["z"])


def _compare_scenario(rng, n):
    return n


def _compare_condition(rng, n):
    return _study_draw(rng, n)


_DATA = dict(data=Instance())
_OPT_POS = Real((), "pos", optional=True)


# --- the table --------------------------------------------------------------------------------------------------------
SPECS: dict[str, Spec] = {
    # filters
    "uwtutor.filters.ekf:range_only_ekf": Spec(
        lambda: dict(x0=_X0, P0=np.eye(2) * 100.0, u=_U, z=_Z, Q=np.eye(2) * 0.1, R=1.0, beacon=(0.0, 0.0))),
    "uwtutor.filters.fading:fading_ekf": Spec(
        lambda: dict(x0=_X0, P0=np.eye(2) * 100.0, u=_U, z=_Z, Q=np.eye(2) * 0.1, R=1.0, mu_gamma=0.98,
                     sigma_gamma=1e-3, rho=0.95, fading=True, second_moment0=np.eye(2)),
        kinds=dict(mu_gamma=Real((), "pos", vector_ok=True), sigma_gamma=Real((), "nonneg"), rho=Real((), "open01"),
                   fading=Flag(),
                   second_moment0=Covariance(optional=True))),
    "uwtutor.filters.engine:extended_kalman_filter": Spec(
        lambda: dict(x0=_X0, P0=np.eye(2) * 100.0, u=_U, z=_Z, Q=np.eye(2) * 0.1, R=1.0), call=_ekf,
        kinds=dict(z=Real(None, "nonneg", nan_ok=True, extra_axis_ok=True)), names=("motion", "state size")),
    "uwtutor.filters.engine:ExtendedKalmanFilter": Spec(
        lambda: dict(motion=_models()[0], measurement=_models()[1], x0=_X0, P0=np.eye(2)),
        kinds=dict(motion=Model(), measurement=Model()), names=("model",),
        call=lambda **kw: __import__("uwtutor.filters", fromlist=["x"]).ExtendedKalmanFilter(**kw).run(_Z, _U)),
    "uwtutor.filters.smoother:rts_smoother": Spec(
        lambda: dict(result=_ekf_result(), motion=_models()[0], u=_U),
        kinds=dict(result=Instance(), motion=Instance(), u=Real((5, 2)))),
    "uwtutor.filters.robust:robust_range_kf": Spec(
        lambda: dict(ranges=np.array([100.0, 101.0, 102.5, 104.0, 180.0, 106.0, 107.0]), dt=1.0, q=2.0, r=2.0,
                     delta=0.03, test="paper", probability=0.99),
        kinds=dict(ranges=Real((None,), "nonneg", nan_ok=True), test=Choice(("paper", "chi2", "none")))),
    "uwtutor.filters.gates:make_test": Spec(
        lambda: dict(test="chi2", delta=0.03, probability=0.99),
        kinds=dict(test=Choice(("paper", "chi2", "none"))), check=lambda v, b: []),
    "uwtutor.filters.gates:normalized_innovation_squared": Spec(
        lambda: dict(y=np.ones((5, 1)), S=np.ones((5, 1, 1)) * 2.0),
        kinds=dict(y=Real((5, 1)), S=Covariance(definite=True))),
    "uwtutor.pipelines.staggered:filter_from_start_epochs": Spec(
        lambda: dict(filter_fn=__import__("uwtutor.filters", fromlist=["fading_ekf"]).fading_ekf, start=[2, 5],
                     x_start=_staggered()[1][[0, 1], [2, 5]], P_start=np.eye(2), u=_staggered()[0],
                     z=_staggered()[2], Q=np.eye(2) * 0.01, R=1.0, per_run={"mu_gamma": [1.0, 0.99]}),
        kinds=dict(filter_fn=Func(), start=Real((2,)), x_start=Real((2, 2), nan_ok=True),
                   P_start=Covariance(definite=True),
                   # z is whatever filter_fn takes, and filter_fn checks the epochs it is given (a negative range is
                   # refused there, by the name z: tests/test_staggered.py); epochs before a run's start are unused
                   u=Real((2, 10, 2)), z=Real((2, 10), nan_ok=True),
                   per_run=Mapping({"mu_gamma": [1.0, 1.0, 1.0]}))),
    # models
    # DeadReckoning and RangeToBeacon (block models: their slot names) are in robustness_spec_blocks
    "uwtutor.filters.bias:bias_model_pair": Spec(
        lambda: dict(Q=np.diag([0.25, 0.25, 0.01]), R=4.0, beacon=(10.0, 0.0))),
    "uwtutor.models.depth:PitchManeuver": Spec(
        lambda: dict(pitch_target=0.2, time_constant=2.0, T=0.05, process_std=[0.01, 0.01, 0.01]),
        kinds=dict(pitch_target=Real(()), time_constant=Real((), "pos"), T=Real((), "pos"),
                   process_std=Real((3,), "nonneg", optional=True))),
    "uwtutor.models.depth:DepthSensors": Spec(lambda: dict(R=np.eye(3) * 0.01),
                                              kinds=dict(R=Covariance(definite=True, optional=True))),
    "uwtutor.models.linear:LinearMotion": Spec(lambda: dict(F=np.eye(2), Q=np.eye(2)), kinds=dict(F=Real((2, 2)))),
    "uwtutor.models.linear:LinearMeasurement": Spec(lambda: dict(H=[[1.0, 0.0]], R=[[1.0]]),
                                                    kinds=dict(H=Real((1, 2)))),
    "uwtutor.models.range:line_of_sight": Spec(lambda: dict(positions=_TRACK, beacon=np.zeros(2))),
    "uwtutor.models.cooperative:measurement_noise_map": Spec(
        lambda: dict(a=np.array([[3.0, 4.0]]), c=np.array([[1.0, 2.0]]), dt=8.0),
        kinds=dict(a=Real((1, 2)), c=Real((1, 2)))),
    "uwtutor.models.cooperative:SquaredRangePair": Spec(
        lambda: dict(leader=np.array([[[100.0, 0.0], [110.0, 5.0]]]), displacements=np.array([[1.0, 2.0]]), dt=8.0,
                     R=np.eye(10), literal=False),
        kinds=dict(leader=Real(None), displacements=Real((1, 2)), R=Covariance(definite=True), literal=Flag())),
    "uwtutor.models.depth:depth_speed_pitch_kinematics": Spec(
        lambda: dict(s=np.array([10.0, 2.0, 0.1]), T=1.0), kinds=dict(s=Real((3,)), T=Real((), "pos"))),
    # the exercise checkers' shared helpers (student answers and functions)
    "uwtutor.exercises.checks:check_number": Spec(
        lambda: dict(answer=None, expected=1.0), kinds=dict(answer=Answer()), check=_feedback_check,
        refused=_is_feedback_refusal, crash_is_obscure=True),
    "uwtutor.exercises.checks:check_array": Spec(
        lambda: dict(answer=None, expected=np.ones(3)), kinds=dict(answer=Answer()), check=_feedback_check,
        refused=_is_feedback_refusal, crash_is_obscure=True),
    "uwtutor.exercises.checks:check_choice": Spec(
        lambda: dict(answer=None, expected="a", options={"a": "first", "b": "second"}), kinds=dict(answer=Answer()),
        check=_feedback_check, refused=_is_feedback_refusal, crash_is_obscure=True),
    "uwtutor.exercises.checks:check_function": Spec(
        lambda: dict(func=None, reference=lambda x: 2.0 * x, cases=[(1.0,), (2.0,)]),
        kinds=dict(func=StudentFunc()), check=_feedback_check, refused=_is_feedback_refusal, crash_is_obscure=True),
    "uwtutor.exercises.checks:parse_real_array": Spec(
        lambda: dict(answer=None, name="the answer", shape=(2,)), kinds=dict(answer=Answer()),
        check=lambda v, b: _feedback_check(v[1], b[1]) if v[0] is None else ["an array came back"],
        refused=lambda v: v[0] is None, crash_is_obscure=True),
    "uwtutor.exercises.checks:read_letter": Spec(
        lambda: dict(answer=None, letters=("A", "B", "C")), kinds=dict(answer=Answer()),
        check=lambda v, b: _feedback_check(v[1], b[1]) if v[0] is None else ["a letter came back"],
        refused=lambda v: v[0] is None, crash_is_obscure=True),
    "uwtutor.exercises.checks:run_student": Spec(
        lambda: dict(func=None), kinds=dict(func=StudentFunc(returns_ok=True)),
        check=lambda v, b: _feedback_check(v[1], b[1]) if v[1] is not None else [],
        refused=lambda v: v[1] is not None, crash_is_obscure=True),
    # Monte Carlo studies (the filter and the draws are the user's functions)
    "uwtutor.montecarlo.batch:run_monte_carlo": Spec(
        lambda: dict(filter_fn=_batched_ekf, truth=np.broadcast_to(_TRACK[1:], (3, 5, 2)),
                     x0=np.tile(_X0, (3, 1)), z=np.tile(_Z, (3, 1)), components=[0, 1], confidence=0.95),
        call=lambda filter_fn, truth, **kw: __import__("uwtutor.montecarlo", fromlist=["x"]).run_monte_carlo(
            filter_fn, truth, **kw),
        kinds=dict(filter_fn=Func(), truth=Real((3, 5, 2)), x0=Real((3, 2)), z=Real((3, 5), "nonneg", nan_ok=True),
                   components=Real((2,), optional=True))),   # None: every component (the default)
    "uwtutor.montecarlo.study:run_study": Spec(
        lambda: dict(draw=_study_draw, estimate=_study_estimate, n_runs=4, seed=1, chunk_size=2, executor=None,
                     components=[0, 1], confidence=0.95),
        kinds=dict(draw=Func(), estimate=Func(), chunk_size=Int(minimum=1), executor=Instance(optional=True),
                   components=Real((2,), optional=True))),
    "uwtutor.montecarlo.comparison:scenario_draw": Spec(
        lambda: dict(scenario=_study_draw, condition=lambda rng, runs: runs),
        kinds=dict(scenario=Func(), condition=Func()), check=lambda v, b: []),
    "uwtutor.montecarlo.comparison:compare": Spec(
        lambda: dict(methods={"ekf": _study_estimate}, scenarios={"circle": _compare_scenario},
                     conditions={"gauss": _compare_condition}, n_runs=4, seed=1, chunk_size=2),
        kinds=dict(methods=Mapping({"ekf": 3}), scenarios=Mapping({"circle": "abc"}),
                   conditions=Mapping({"gauss": None}), chunk_size=Int(minimum=1))),
    # metrics
    "uwtutor.metrics:nees": Spec(lambda: dict(estimates=_TRACK[1:] + 1.0, covariances=np.tile(np.eye(2) * 4, (5, 1, 1)),
                                              truth=_TRACK[1:]),
                                 kinds=dict(covariances=Covariance(definite=True))),
    "uwtutor.metrics:rmse_over_time": Spec(lambda: dict(estimates=_TRACK[1:] + 1.0, truth=_TRACK[1:])),
    "uwtutor.metrics:estimation_errors": Spec(lambda: dict(estimates=_TRACK[1:] + 1.0, truth=_TRACK[1:])),
    "uwtutor.metrics:final_errors": Spec(lambda: dict(estimates=_TRACK[1:] + 1.0, truth=_TRACK[1:])),
    "uwtutor.metrics:error_cdf": Spec(lambda: dict(errors=[1.0, 2.0, 3.0]),
                                      kinds=dict(errors=Real((None,), nan_ok=True))),
    "uwtutor.metrics:chi2_mean_bounds": Spec(lambda: dict(dof=2, n_runs=50, confidence=0.95),
                                             kinds=dict(dof=Int(minimum=1), n_runs=Real((), "pos", vector_ok=True))),
    "uwtutor.metrics:nis": Spec(lambda: dict(innovations=np.ones((5, 1)), innovation_cov=np.ones((5, 1, 1))),
                                kinds=dict(innovations=Real((5, 1), nan_ok=True),
                                           innovation_cov=Covariance(definite=True))),
    "uwtutor.metrics:average_over_runs": Spec(lambda: dict(values=np.ones((3, 5))),
                                              kinds=dict(values=Real((None, 5), nan_ok=True))),
    "uwtutor.metrics:fraction_within": Spec(lambda: dict(values=np.ones(5), lower=0.0, upper=2.0),
                                            kinds=dict(values=Real((None,), nan_ok=True, inf_ok=True), lower=Real(()),
                                                       upper=Real(()))),
    # observability
    "uwtutor.observability.bounds:cramer_rao_bound": Spec(lambda: dict(information=np.eye(2) * 2.0),
                                                   kinds=dict(information=Covariance(definite=True, any_size=True))),
    "uwtutor.observability.bounds:rmse_bound": Spec(lambda: dict(covariance=np.eye(2) * 2.0),
                                             kinds=dict(covariance=Covariance(inf_ok=True, any_size=True)),
                                             check=lambda v, b: ["NaN bound"] if np.isnan(v).any() else []),
    "uwtutor.observability.geometry:error_ellipse": Spec(
        lambda: dict(covariance=np.eye(2) * 2.0, center=(0.0, 0.0), scale=2.0),
        kinds=dict(covariance=Covariance(), center=Real((2,)), scale=Real((), "pos"))),
    "uwtutor.observability.jacobians:range_jacobian": Spec(lambda: dict(position=[30.0, -40.0], beacons=_BEACONS)),
    "uwtutor.observability.bounds:position_crlb": Spec(
        lambda: dict(beacons=_BEACONS, position=[30.0, -40.0], sigma=1.0)),
    "uwtutor.observability.information:fisher_information": Spec(lambda: dict(beacons=_BEACONS, position=[30.0, -40.0],
                                                                  sigma=1.0)),
    "uwtutor.observability.bounds:gdop": Spec(lambda: dict(beacons=_BEACONS, position=[30.0, -40.0])),
    "uwtutor.observability.posterior:posterior_crlb": Spec(
        lambda: dict(positions=_TRACK, beacon=np.zeros(2), sigma=1.0, Q=np.eye(2) * 0.1, P0=np.eye(2) * 100.0,
                     times=np.arange(6.0)),
        kinds=dict(times=Real((6,), optional=True), P0=Covariance(definite=True), sigma=Real((), "pos", inf_ok=True,
                                                                                       vector_ok=True))),
    # least squares, acoustics, grey
    "uwtutor.lsq:linearized_lsq": Spec(
        lambda: dict(ranges=_RANGES, beacons=_BEACONS, provisional=[10.0, -30.0], iterations=3),
        kinds=dict(ranges=Real((4,), "nonneg"), provisional=Real((2,)), iterations=Int(minimum=1))),
    "uwtutor.acoustics:range_from_travel_time": Spec(lambda: dict(travel_time=1.0, sound_speed=1500.0, two_way=False),
                                                     kinds=dict(travel_time=Real((), "nonneg", vector_ok=True),
                                                                sound_speed=Real((), "pos", vector_ok=True))),
    "uwtutor.acoustics:travel_time_from_range": Spec(lambda: dict(slant_range=1500.0, sound_speed=1500.0, two_way=True),
                                                     kinds=dict(slant_range=Real((), "nonneg", vector_ok=True),
                                                                sound_speed=Real((), "pos", vector_ok=True))),
    "uwtutor.acoustics:sound_speed": Spec(lambda: dict(temperature=10.0, salinity=35.0, depth=100.0),
                                          kinds=dict(temperature=Real((), vector_ok=True),
                                                     salinity=Real((), "nonneg", vector_ok=True),
                                                     # outside Mackenzie's 0-8000 m: a documented warning
                                                     depth=Real((), vector_ok=True))),
    "uwtutor.acoustics:range_factor": Spec(lambda: dict(assumed_speed=1500.0, true_speed=1470.0),
                                           kinds=dict(assumed_speed=Real((), "pos", vector_ok=True),
                                                      true_speed=Real((), "pos", vector_ok=True))),
    "uwtutor.ranging:horizontal_range": Spec(lambda: dict(positions=_TRACK, beacon=(0.0, 0.0))),
    "uwtutor.ranging:slant_range": Spec(lambda: dict(positions=_TRACK, beacon=(0.0, 0.0), depth_difference=50.0),
                                        kinds=dict(depth_difference=Real((), vector_ok=True))),
    "uwtutor.motion:straight_track": Spec(lambda: dict(times=np.arange(5.0), start=(0.0, 0.0), speed=2.0,
                                                       heading=0.3),
                                          kinds=dict(start=Real((2,)), heading=Real(()), speed=Real((), "nonneg"))),
    "uwtutor.motion:circle_track": Spec(lambda: dict(times=np.arange(5.0), radius=300.0, speed=2.0),
                                        kinds=dict(speed=Real((), "nonneg"))),    # 0: a vehicle holding station
    "uwtutor.grey:gm11_next": Spec(lambda: dict(series=np.array([10.0, 11.0, 12.5, 13.0, 14.2])),
                                   kinds=dict(series=Real((None,), "pos"))),
    # scenarios and pipelines
    "uwtutor.scenarios.suite:circle": Spec(lambda: dict(rng=np.random.default_rng(0), n_runs=2)),
    "uwtutor.scenarios.suite:crlb_inputs": Spec(
        lambda: dict(scenario="circle", condition="white", n_tracks=3, seed=1998),
        kinds=dict(scenario=Choice(), condition=Choice(), n_tracks=Int(minimum=1, unbounded_work=True))),
    "uwtutor.scenarios.paper_b:make": Spec(lambda: dict(rng=np.random.default_rng(0), n_runs=1, interval=8.0),
                                           kinds=dict(interval=Real((), "pos"))),
    "uwtutor.scenarios.paper_b:matched_tuning": Spec(lambda: dict(position_noise=1.0, current_noise=0.001),
                                                     kinds=dict(position_noise=Real((), "pos"),
                                                                current_noise=Real((), "pos"))),
    # 200 epochs of paper E's dive: 0.6 s a call, so 3 values an argument
    "uwtutor.pipelines.vmlbl:or_vmlbl_kf": Spec(
        lambda: (lambda d: dict(ranges=d.slant_ranges[0][:200], ship_positions=d.ship_positions[0][:200],
                                dr_positions=d.dr_positions[0][:200], depth=d.depth, spacing=20))(_paper_e()),
        kinds=dict(ranges=Real((None,), "nonneg", nan_ok=True), ship_positions=Kind(), dr_positions=Kind(),
                   depth=Real((), "nonneg"), spacing=Kind()), per_argument=3),
    # real logs (chapter 11): the book's earlier methods, GTSAM's graph, the study's measures, on a small log
    "uwtutor.datasets.navigation:navigation_models": Spec(
        lambda: dict(data=_small_log(), beacon_ids=[3], min_period=2.0, gyro_bias=True, scale=True, range_sigma=0.6,
                     distance_sigma=(0.01, 0.02), heading_noise=1e-3, gyro_bias_prior=0.01, gyro_bias_walk=1e-4,
                     scale_prior=0.1, scale_walk=1e-5),
        kinds=dict(data=Instance(), beacon_ids=Kind(), min_period=_OPT_POS, gyro_bias=Flag(), scale=Flag(),
                   range_sigma=Real((), "pos"), distance_sigma=Real((2,), "nonneg"), heading_noise=Real((), "pos"),
                   gyro_bias_prior=Real((), "pos"), gyro_bias_walk=Real((), "pos"), scale_prior=Real((), "pos"),
                   scale_walk=Real((), "pos"))),
    "uwtutor.datasets.baselines:world_displacements": Spec(lambda: dict(data=_small_log()), kinds=_DATA),
    "uwtutor.datasets.baselines:displacement_covariance": Spec(
        lambda: dict(data=_small_log(), distance_sigma=(0.01, 0.02)),
        kinds=dict(data=Instance(), distance_sigma=Real((2,), "nonneg"))),
    "uwtutor.datasets.baselines:position_ekf": Spec(
        lambda: dict(data=_small_log(), beacon_ids=[3, 7], min_period=2.0, range_sigma=0.6,
                     distance_sigma=(0.01, 0.02)),
        kinds=dict(data=Instance(), beacon_ids=Kind(), min_period=_OPT_POS, range_sigma=Real((), "pos"),
                   distance_sigma=Real((2,), "nonneg"))),
    "uwtutor.datasets.baselines:bias_iekf": Spec(
        lambda: dict(data=_small_log(), beacon_ids=[3], range_sigma=0.6, bias_sigma=5.0),
        kinds=dict(data=Instance(), beacon_ids=Kind(), range_sigma=Real((), "pos"), bias_sigma=Real((), "pos"))),
    "uwtutor.datasets.baselines:fading_filter": Spec(
        lambda: dict(data=_small_log(), beacon_ids=[3], mu_gamma=1.05, sigma_gamma=0.003, range_sigma=0.6),
        kinds=dict(data=Instance(), beacon_ids=Kind(), mu_gamma=Real((), "pos"), sigma_gamma=Real((), "nonneg"),
                   range_sigma=Real((), "pos"))),
    "uwtutor.datasets.baselines:vmlbl_filter": Spec(
        lambda: dict(data=_small_log(), beacon_ids=[3], spacing=4.0, range_q=30.0, fix_q=1.0, range_sigma=0.6),
        kinds=dict(data=Instance(), beacon_ids=Kind(), spacing=Real((), "pos"), range_q=Real((), "pos"),
                   fix_q=Real((), "pos"), range_sigma=Real((), "pos")), per_argument=3),
    "uwtutor.datasets.baselines:particle_filter": Spec(
        lambda: dict(data=_small_log(), beacon_ids=[3], rng=np.random.default_rng(0), n_particles=50,
                     range_sigma=0.6),
        kinds=dict(data=Instance(), beacon_ids=Kind(), n_particles=Int(minimum=1, unbounded_work=True),
                   range_sigma=Real((), "pos"))),
    "uwtutor.datasets.factor_graph:gtsam_map": Spec(
        lambda: dict(data=_small_log(), beacon_ids=[3, 7], range_scale=1.05, range_sigma=0.6,
                     distance_sigma=(0.01, 0.02), across_sigma=0.002, heading_noise=0.01, max_iterations=20),
        kinds=dict(data=Instance(), beacon_ids=Kind(), range_scale=Real((), "pos"), range_sigma=Real((), "pos"),
                   distance_sigma=Real((2,), "nonneg"), across_sigma=Real((), "pos"), heading_noise=Real((), "pos"),
                   max_iterations=Int(minimum=1, unbounded_work=True)), per_argument=4),
    "uwtutor.datasets.study:error_summary": Spec(
        lambda: dict(positions=_TRACK + 1.0, truth=_TRACK, within=2.0),
        kinds=dict(positions=Real((6, 2)), truth=Real((6, 2)), within=Real((), "pos"))),
    "uwtutor.datasets.study:nees": Spec(
        lambda: dict(x=np.array([[1.0, 0.0, 0.1], [0.5, 0.2, -0.1]]), P=np.tile(np.diag([1.0, 2.0, 0.01]), (2, 1, 1)),
                     truth=np.zeros((2, 3)), components="pose"),
        kinds=dict(x=Real((2, 3)), P=Kind(), truth=Real((2, 3)), components=Choice())),
    "uwtutor.datasets.study:measured_scale": Spec(lambda: dict(data=_small_log()), kinds=_DATA),
    "uwtutor.datasets.study:most_heard_beacon": Spec(lambda: dict(data=_small_log()), kinds=_DATA),
    "uwtutor.datasets.study:without_scale": Spec(lambda: dict(data=_small_log(), scale=1.05),
                                                 kinds=dict(data=Instance(), scale=Real((), "pos"))),
    "uwtutor.datasets.study:with_true_heading": Spec(lambda: dict(data=_small_log()), kinds=_DATA),
    "uwtutor.widgets.ch11:real_data_view": Spec(
        lambda: dict(beacon="5", period=10.0, states="+ scale"),
        kinds=dict(beacon=Choice(), period=Real((), "pos", optional=True), states=Choice())),
}


# --- family rules -----------------------------------------------------------------------------------------------------
def _checker_spec(obj: Callable) -> Spec:
    """Every checker of a chapter: each required argument is a student answer (``func``: a student function)."""
    params = [p.name for p in inspect.signature(obj).parameters.values() if p.default is p.empty]
    kinds = {n: (StudentFunc() if n == "func" else Answer()) for n in params}
    return Spec(lambda: {n: None for n in params}, kinds=kinds, check=_feedback_check,
                refused=_is_feedback_refusal, crash_is_obscure=True)


RULES: list[tuple[str, Callable[[Callable], Spec], str]] = [
    ("uwtutor.exercises.ch[0-9]*:check_*", _checker_spec, "a chapter's checker takes student answers / functions"),
]

#: Not called with user data (or not callable with it in a test), each with its reason.
EXEMPT_RULES: list[tuple[str, str]] = [
    ("uwtutor.widgets.*:*_widget", "UI only: builds ipywidgets around a tested compute function"),
    ("uwtutor.widgets.*:show*", "UI only: displays a figure"),
    ("uwtutor.widgets.*:plot_*", "UI only: draws a view on matplotlib axes"),
    ("uwtutor.widgets.*:*_animation", "UI only: renders a matplotlib animation for the static book"),
    ("uwtutor.widgets._panel:*", "UI only: the layout helper of every widget"),
    ("uwtutor.exercises.cli:*", "command line: argv parsing, tested in tests/test_exercise_system.py"),
    ("uwtutor.exercises.generate:*", "file generation from notebooks: tested in tests/test_exercise_system.py"),
    ("uwtutor.exercises.nbgrader_meta:*", "notebook metadata: tested in tests/test_labs_nbgrader.py"),
    ("uwtutor.errors:*", "the warning helper: its message is library text, not user data"),
]

EXEMPT: dict[str, str] = {
    # figure helpers of the book (presentation layer), each tested in tests/test_plotting_fit.py
    "uwtutor.plotting:method_style": "the line style of a method's name in the book's comparison figures (a "
                                     "lookup: any name gets a style)",
    "uwtutor.plotting:method_legend": "legend entries for the book's comparison figures",
    "uwtutor.plotting:legend_below": "places the legend of a matplotlib axes under it",
    # the reference solutions and the data of the exercises that build a whole step (5.5, 6.6, 10.4): what the
    # checkers compare a student's function with, called only on the checkers' own cases
    "uwtutor.exercises.ch05:isfekf_step_reference": "the reference step exercise 5.5's checker replays; its inputs "
                                                    "are the checker's own",
    "uwtutor.exercises.ch05:isfekf_step_run": "no arguments: the data of exercise 5.5 (covered by its tests)",
    "uwtutor.exercises.ch06:pf_step_reference": "the reference step exercise 6.6's checker compares with; its "
                                                "inputs are the checker's own",
    "uwtutor.exercises.ch10:pcrb_reference": "the reference recursion exercise 10.4's checker compares with; its "
                                             "inputs are the checker's own",
    "uwtutor.exercises.feedback:Feedback": "the verdict object the checkers build (library-internal values)",
    # chapter 11: the study over the Plaza logs (minutes; tests/test_real_data_study.py re-runs a sample), its
    # containers, the exercises' data and the slow checkers
    "uwtutor.datasets.study:navigation_run": "a study step over a whole Plaza log (seconds): tested in "
                                             "tests/test_real_data_study.py",
    "uwtutor.datasets.study:navigation_grid": "the widget grid's study (minutes): make study-real",
    "uwtutor.datasets.study:method_table": "the method table's study (minutes): make study-real",
    "uwtutor.datasets.study:ablation_table": "the ablation's study (minutes): make study-real",
    "uwtutor.datasets.study:gtsam_sweep": "GTSAM's heading-noise sweep (minutes): make study-real",
    "uwtutor.datasets.study:run_real_data_study": "the whole study (about 15 minutes): make study-real",
    "uwtutor.datasets.study:load_real_data_study": "no arguments: reads the committed files",
    "uwtutor.datasets.study:fixes_within": "takes a run of baselines.vmlbl_filter (library-made values); tested "
                                           "in tests/test_real_data_study.py",
    "uwtutor.datasets.study:RealDataStudy": "the committed study's container, built by run_real_data_study or load",
    "uwtutor.datasets.baselines:BaselineRun": "a result container the baselines build",
    "uwtutor.montecarlo.batch:MonteCarloResult": "a result container run_monte_carlo builds (its scores are checked "
    "there)",
    "uwtutor.montecarlo.study:StudyResult": "a result container run_study builds (its scores are checked there)",
    "uwtutor.montecarlo.comparison:ComparisonTable": "the table container compare builds (and from_csv reads back)",
    "uwtutor.datasets.factor_graph:GraphSolution": "a result container gtsam_map builds",
    "uwtutor.datasets.navigation:NavigationModels": "a container navigation_models builds",
    "uwtutor.datasets.navigation:NavigationResult": "a result container navigate builds",
    "uwtutor.widgets.ch11:RealDataView": "a view container real_data_view builds",
    "uwtutor.exercises.ch11:scale_variants": "no arguments: the data of exercise 11.1 (covered by its tests)",
    "uwtutor.exercises.ch11:drift_variants": "no arguments: the data of exercise 11.2 (covered by its tests)",
    "uwtutor.exercises.ch11:lockout_runs": "no arguments: the runs of exercise 11.4 (covered by its tests)",
    "uwtutor._linalg:line_of_sight": "the unchecked kernel of uwtutor.models.range:line_of_sight (specified), on "
                                     "the filters', least squares' and bounds' per-step path: their inputs are "
                                     "checked once",
    "uwtutor.models.noise:psd_sqrt": "the models' square root of their own covariance, checked once by the model "
                                     "(documented as unchecked: a per-step kernel)",
    "uwtutor.models.noise:gaussian_noise": "the samplers' kernel: called by the models with their own checked square "
                                           "roots and the filters' per-run generators, never with user data",
    "uwtutor.models.noise:gaussian_log_likelihood": "the particle filters' weighting kernel: called with the models' "
                                                    "own predictions and checked R, never with user data",
}


def _load_pending() -> frozenset[str]:
    import pathlib
    path = pathlib.Path(__file__).with_name("robustness_pending.txt")
    return frozenset(line.strip() for line in path.read_text().splitlines()
                     if line.strip() and not line.startswith("#"))


#: Targets whose specification is not written yet (the debt recorded by issue 26; the list may only shrink).
PENDING: frozenset[str] = _load_pending()


def lookup(key: str, obj: Callable) -> tuple[str, Any]:
    """``("spec", Spec)``, ``("exempt", reason)``, ``("pending", None)`` or ``("missing", None)`` for a target."""
    if key in SPECS:
        return "spec", SPECS[key]
    if key in EXEMPT:
        return "exempt", EXEMPT[key]
    for pattern, factory, _ in RULES:
        if fnmatch.fnmatchcase(key, pattern):
            return "spec", factory(obj)
    for pattern, reason in EXEMPT_RULES:
        if fnmatch.fnmatchcase(key, pattern):
            return "exempt", reason
    if key in PENDING:
        return "pending", None
    return "missing", None


def kinds_of(spec: Spec, valid: dict[str, Any]) -> dict[str, Kind]:
    """The kind of every argument of the valid call (the spec's own, else ``KIND_BY_NAME``; unknown: no mutation)."""
    return {name: spec.kinds.get(name, KIND_BY_NAME.get(name, Kind())) for name in valid}
from robustness_spec_core import SPECS_CORE, EXEMPT_CORE  # noqa: E402
SPECS.update(SPECS_CORE); EXEMPT.update(EXEMPT_CORE)  # noqa: E702
from robustness_spec_scen import SPECS_SCEN, EXEMPT_SCEN  # noqa: E402
SPECS.update(SPECS_SCEN); EXEMPT.update(EXEMPT_SCEN)  # noqa: E702
from robustness_spec_struct import SPECS_STRUCT, EXEMPT_STRUCT  # noqa: E402
SPECS.update(SPECS_STRUCT); EXEMPT.update(EXEMPT_STRUCT)  # noqa: E702
from robustness_spec_ex import SPECS_EX, EXEMPT_EX  # noqa: E402
SPECS.update(SPECS_EX); EXEMPT.update(EXEMPT_EX)  # noqa: E702
from robustness_spec_blocks import SPECS_BLOCKS, EXEMPT_BLOCKS  # noqa: E402
SPECS.update(SPECS_BLOCKS); EXEMPT.update(EXEMPT_BLOCKS)  # noqa: E702
from robustness_spec_stats import SPECS_STATS, EXEMPT_STATS  # noqa: E402
SPECS.update(SPECS_STATS); EXEMPT.update(EXEMPT_STATS)  # noqa: E702
