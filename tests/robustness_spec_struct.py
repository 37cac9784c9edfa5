"""The argument specifications of the ``struct`` share of the robustness contract (issue 26): the models, the
filters (the particle filters included), the pipelines and the real-data sets.

Each entry is a :class:`robustness_spec.Spec` (a factory of small valid keyword arguments and the kind of each
argument) or an exemption with its reason. A class is called through a small use of the object it builds
(``_motion_use``, ``_meas_use``...), so that a hostile value the constructor accepts must still give a valid
answer (finite; covariances symmetric PSD), not only an object.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any

import numpy as np

from robustness_kinds import Choice, Covariance, Flag, Instance, Int, Kind, Mapping, Model, Real, Rng, Seed
from robustness_spec import _U, _X0, _Z, Spec, _models, _small_log


# --- using a model once ------------------------------------------------------------------------------------------
@dataclass
class _Use:
    """What one use of a model gives: its prediction, Jacobian and noise (``cov``: checked symmetric PSD)."""
    value: Any
    jacobian: Any
    cov: Any


def _motion_use(model, x=None, u=None, k=0):
    """``f``, ``F``, ``Q`` of a motion model at one state of a single run."""
    x = np.ones((1, model.n)) if x is None else np.asarray(x, dtype=float)[None]
    f, F, Q = model.linearize(x, u, k)
    return _Use(np.asarray(f, dtype=float), np.asarray(F, dtype=float), np.asarray(Q, dtype=float))


def _meas_use(model, x=None, k=0):
    """``h``, ``H``, ``R`` of a measurement model at one state of a single run."""
    x = np.full((1, model.n), 3.0) if x is None else np.asarray(x, dtype=float)[None]
    h, H, _ = model.linearize(x, k)
    return _Use(np.asarray(h, dtype=float), np.asarray(H, dtype=float), np.asarray(model.R(x, k), dtype=float))


def _build(cls_path: str, use=_motion_use, **use_kw):
    """A ``call``: build the object from the keyword arguments, then use it once."""
    module, name = cls_path.rsplit(".", 1)

    def call(**kw):
        cls = getattr(__import__(module, fromlist=[name]), name)
        return use(cls(**kw), **use_kw)
    return call


@dataclass(frozen=True)
class _OptInt(Int):
    """An integer whose default is None (None is a valid value, not a hostile one)."""

    def hostile(self, valid):
        return [h for h in super().hostile(valid) if h.value is not None]


@dataclass(frozen=True)
class _OptCov(Covariance):
    """A covariance whose default is None (the model's own)."""

    def hostile(self, valid):
        return [h for h in super().hostile(valid) if h.value is not None]



def _fading_check(value, baseline):
    """The fading factor's numerator and denominator are undefined (NaN) where no range was used."""
    import robustness_kinds as rk
    return [p for p in rk.answer_problems(value, baseline) if "fading_numerator" not in p
            and "fading_denominator" not in p]


def _ekf_object():
    from uwtutor.filters import ExtendedKalmanFilter
    motion, meas = _models()
    return ExtendedKalmanFilter(motion, meas, _X0, np.eye(2) * 100.0)


def _run_object(cls_path: str):
    """A ``call``: build a step filter from the arguments but ``u`` and ``z``, then run it over them."""
    module, name = cls_path.rsplit(".", 1)

    def call(u, z, **kw):
        cls = getattr(__import__(module, fromlist=[name]), name)
        return cls(**kw).run(z, u)
    return call


def _coop():
    """Four steps of paper B's pair: the follower's DR displacements, the leader's broadcast positions."""
    from uwtutor.scenarios import paper_b
    p = paper_b.PARAMETERS
    t = np.arange(5.0)
    leader = np.column_stack([100.0 + 16.0 * t, 50.0 + 4.0 * t])
    return dict(x0=np.array([0.0, 0.0, 0.1, 0.0]), P0=np.diag([100.0, 100.0, 1.0, 1.0]),
                u=np.tile([16.0, 4.0], (4, 1)), leader=leader, dt=8.0, Q=np.asarray(p.Q), R=np.asarray(p.R))


def _coop_ranges():
    c = _coop()
    follower = np.vstack([c["x0"][:2], c["x0"][:2] + np.cumsum(c["u"], axis=0)])
    return np.linalg.norm(c["leader"] - follower, axis=1) + 0.5


def _steps(filt, ranges):
    """Drive a cooperative filter over its pairs of ranges (predict, update), collecting x and P."""
    from uwtutor.filters.cooperative import range_pairs
    xs, Ps = [], []
    for pair in range_pairs(ranges):
        filt.predict()
        filt.update(pair)
        xs.append(np.array(filt.x))
        Ps.append(np.array(filt.P))
    return _Run(np.array(xs), np.array(Ps))


@dataclass
class _Run:
    x: Any
    P: Any


def _gated(gate, offset=0.0):
    """The engine on the small circle with ``gate`` (a start ``offset`` metres off the track)."""
    from uwtutor.filters import extended_kalman_filter
    motion, meas = _models()
    return extended_kalman_filter(motion, meas, _X0 + offset, np.eye(2) * 100.0, _U, _Z, gate=gate)


def _lgm_use(model):
    x = np.ones((1, model.n))
    return _Use(np.asarray(model.motion.f(x, None, 0)), np.asarray(model.motion.F(x, None, 0)),
                np.asarray(model.measurement.R(x, 0)))


def _particles():
    return _X0 + np.random.default_rng(7).normal(0.0, 5.0, (20, 2))


def _run_particles(cls_path: str):
    module, name = cls_path.rsplit(".", 1)

    def call(**kw):
        cls = getattr(__import__(module, fromlist=[name]), name)
        return cls(**kw).run(_Z, _U)
    return call


def _depth():
    from uwtutor.models import DepthSensors, DepthSpeedPitch
    return DepthSpeedPitch(), DepthSensors()


_DEPTH_Z = np.array([[10.0, 1.5, 0.1], [10.1, 1.4, 0.12], [10.0, 1.6, 0.1], [10.2, 1.5, 0.11], [10.1, 1.5, 0.1],
                     [10.3, 1.6, 0.12], [10.2, 1.4, 0.1], [10.4, 1.5, 0.09], [10.3, 1.5, 0.1], [10.5, 1.6, 0.11],
                     [10.4, 1.5, 0.1], [10.6, 1.4, 0.12], [10.5, 1.5, 0.1], [10.7, 1.6, 0.1]])


def _depth_particles():
    return _DEPTH_Z[0] + np.random.default_rng(7).normal(0.0, 0.05, (20, 3))


def _run_depth(cls_path: str):
    module, name = cls_path.rsplit(".", 1)

    def call(**kw):
        cls = getattr(__import__(module, fromlist=[name]), name)
        return cls(**kw).run(_DEPTH_Z)
    return call


def _robust_gated(test=None, steps=None, **kw):
    """robust_track_kf's filter (a constant-velocity track of ranges) with a RobustGate built from the arguments."""
    from uwtutor.filters import extended_kalman_filter
    from uwtutor.filters.robust import RobustGate
    from uwtutor.models import ConstantVelocity, PositionMeasurement
    gate = RobustGate(test, steps, **kw)
    z = np.array([[100.0], [99.0], [98.1], [150.0], [96.0]])
    return extended_kalman_filter(ConstantVelocity(1, 0.01, np.r_[0.0, np.ones(4)]), PositionMeasurement(1, 2.0),
                                  np.array([100.0, -1.0]), np.diag([2.0, 1.0]), None, z, gate=gate)


def _fixes():
    t = np.arange(8.0)
    truth = np.column_stack([-1000.0 + t, -1000.0 + t])
    out = truth + np.random.default_rng(1).normal(0.0, 20.0, (8, 2))
    out[3] = np.nan
    return out



@functools.lru_cache(maxsize=1)
def _paper_c():
    from uwtutor.scenarios import paper_c
    return paper_c.make(np.random.default_rng(0), n_runs=1, duration=2.0)


@functools.lru_cache(maxsize=1)
def _approach():
    from uwtutor import scenarios
    return scenarios.approach_with_turn_scenario(np.random.default_rng(5), n_runs=1)


@functools.lru_cache(maxsize=1)
def _paper_a():
    from uwtutor.scenarios import paper_a
    return paper_a.make(np.random.default_rng(0), n_runs=1)


@functools.lru_cache(maxsize=1)
def _paper_e_dive():
    from uwtutor.scenarios import paper_e
    d = paper_e.make(np.random.default_rng(0))
    return d.ship_positions[0][:400], d.true_positions[0][:400], d.depth


@dataclass(frozen=True)
class _NoRangesOk(Real):
    """A dataset's range table: no range at all (shape (0, 3)) is documented as valid."""

    def hostile(self, valid):
        return [h for h in super().hostile(valid) if h.label != "empty"]


_POS = Real((), "pos")


@dataclass(frozen=True)
class _OptionalFlag(Flag):
    """A bool or None (navigate's gyro_bias and scale: None lets the log choose)."""

    def hostile(self, valid: Any) -> list[Any]:
        return [h for h in super().hostile(valid) if h.value is not None]
_NONNEG = Real((), "nonneg")
_COUNT = Int(minimum=1)


SPECS_STRUCT: dict[str, Spec] = {
    "uwtutor.datasets._core:square_log": Spec(
        lambda: dict(range_scale=1.05, range_offset=0.1),
        kinds=dict(range_scale=Real((), "pos"), range_offset=Real((), "nonneg"))),
    # --- models ------------------------------------------------------------------------------------------------------
    "uwtutor.models.base:ModelPair": Spec(
        lambda: dict(motion=_models()[0], measurement=_models()[1], x0=[3.0, 4.0], n_steps=3,
                     rng=np.random.default_rng(0)),
        kinds=dict(motion=Instance(), measurement=Instance(), x0=Real((2,)), n_steps=Int(minimum=1,
                                                                                       unbounded_work=True)),
        call=lambda motion, measurement, x0, n_steps, rng: __import__("uwtutor.models", fromlist=["ModelPair"])
        .ModelPair(motion, measurement).simulate(x0, n_steps, rng)),
    "uwtutor.models.bias:BiasRateDeadReckoning": Spec(
        lambda: dict(Q=np.diag([0.25, 0.25, 1e-3, 1e-4]), dt=5.0), call=_build("uwtutor.models.bias."
                                                                             "BiasRateDeadReckoning")),
    "uwtutor.models.bias:bias_rate_process_noise": Spec(
        lambda: dict(sigma_x=1.0, sigma_y=0.5, rate_sigma=0.01, dt=5.0),
        kinds=dict(sigma_x=_NONNEG, sigma_y=Real((), "nonneg", optional=True), rate_sigma=_NONNEG)),
    "uwtutor.models.bias:paper_a_process_noise": Spec(
        lambda: dict(sigma_x=1.0, sigma_y=0.5, sigma_bias=0.1),
        kinds=dict(sigma_x=_NONNEG, sigma_y=Real((), "nonneg", optional=True),
                   sigma_bias=Real((), "nonneg", optional=True))),
    "uwtutor.models.cooperative:CooperativeMotion": Spec(
        lambda: dict(dt=8.0, Q=np.eye(6) * 0.01),
        call=_build("uwtutor.models.cooperative.CooperativeMotion", u=np.array([[1.0, 2.0]]))),
    "uwtutor.models.cooperative:leader_range": Spec(
        lambda: dict(leader=np.array([[100.0, 0.0], [110.0, 5.0], [120.0, 8.0]]), variance=4.0),
        kinds=dict(leader=Real((None, 2)), variance=_POS),
        call=lambda **kw: _meas_use(__import__("uwtutor.models.cooperative", fromlist=["x"]).leader_range(**kw),
                                    k=1)),
    "uwtutor.models.cooperative:process_noise_map": Spec(lambda: dict(dt=8.0)),
    "uwtutor.models.depth:DepthSpeedPitch": Spec(
        lambda: dict(T=0.05, process_std=[0.01, 0.01, 0.01]),
        kinds=dict(T=_POS, process_std=Real((3,), "nonneg", optional=True)),
        call=_build("uwtutor.models.depth.DepthSpeedPitch", x=[10.0, 2.0, 0.1])),
    "uwtutor.models.depth:DepthSpeedPitchModel": Spec(
        lambda: dict(T=0.05, process_std=[0.01, 0.01, 0.01], R=np.eye(3) * 0.01),
        kinds=dict(T=_POS, process_std=Real((3,), "nonneg", optional=True), R=_OptCov(definite=True)),
        call=lambda **kw: (lambda p: (_motion_use(p.motion, x=[10.0, 2.0, 0.1]), _meas_use(p.measurement)))(
            __import__("uwtutor.models.depth", fromlist=["x"]).DepthSpeedPitchModel(**kw))),
    "uwtutor.models.depth:PitchManeuverModel": Spec(
        lambda: dict(pitch_target=0.2, time_constant=2.0, T=0.05, process_std=[0.01, 0.01, 0.01],
                     R=np.eye(3) * 0.01),
        kinds=dict(pitch_target=Real(()), time_constant=_POS, T=_POS,
                   process_std=Real((3,), "nonneg", optional=True), R=_OptCov(definite=True)),
        call=lambda **kw: (lambda p: (_motion_use(p.motion, x=[10.0, 2.0, 0.1]), _meas_use(p.measurement)))(
            __import__("uwtutor.models.depth", fromlist=["x"]).PitchManeuverModel(**kw))),
    "uwtutor.models.depth:depth_speed_pitch_jacobian": Spec(
        lambda: dict(s=np.array([10.0, 2.0, 0.1]), T=1.0), kinds=dict(s=Real((3,)), T=_POS)),
    "uwtutor.models.linear:DirectMeasurement": Spec(
        lambda: dict(n=3, indices=[0, 2], R=np.eye(2)),
        kinds=dict(n=Int(minimum=1), indices=Real((2,)), R=Covariance(definite=True)),
        call=_build("uwtutor.models.linear.DirectMeasurement", use=_meas_use)),
    "uwtutor.models.noise:per_run_generators": Spec(
        lambda: dict(rng=np.random.default_rng(0), n_runs=2, spawn=True),
        kinds=dict(spawn=Flag(), n_runs=Int(minimum=1, unbounded_work=True)),
        call=lambda **kw: np.array([g.standard_normal() for g in __import__(
            "uwtutor.models.noise", fromlist=["x"]).per_run_generators(**kw)])),
    "uwtutor.models.noise:standard_normal_per_run": Spec(
        lambda: dict(rngs=[np.random.default_rng(1), np.random.default_rng(2)], shape=(2, 3)),
        kinds=dict(rngs=Rng(), shape=Kind())),
    "uwtutor.models.odometry:OdometryMotion": Spec(
        lambda: dict(sigma_distance=0.02, sigma_heading=1e-3, gyro_bias=True, scale=True, range_bias=False,
                     dt=1.0, order="turn-first", gyro_bias_walk=1e-4, scale_walk=1e-5, range_bias_walk=0.0),
        kinds=dict(sigma_distance=Real((), "nonneg", vector_ok=True), sigma_heading=Real((), "nonneg",
                                                                                         vector_ok=True),
                   gyro_bias=Flag(), scale=Flag(), range_bias=Kind(), dt=Real((), "nonneg", vector_ok=True),
                   order=Choice(("turn-first", "move-first", "midpoint")), gyro_bias_walk=_NONNEG,
                   scale_walk=_NONNEG, range_bias_walk=_NONNEG),
        call=_build("uwtutor.models.odometry.OdometryMotion", x=[1.0, 2.0, 0.3, 1e-3, 1.0],
                    u=np.array([[1.0, 0.1]]))),
    "uwtutor.models.odometry:StateLayout": Spec(
        lambda: dict(n=6, heading=2, gyro_bias=3, scale=4, range_bias=(), extra={"clock": (5,)}),
        kinds=dict(n=Int(minimum=2), heading=_OptInt(minimum=2), gyro_bias=_OptInt(minimum=2),
                   scale=_OptInt(minimum=2), extra=Kind()),
        call=lambda **kw: __import__("uwtutor.models.odometry", fromlist=["x"]).StateLayout(**kw)),
    "uwtutor.models.odometry:wrap_angle": Spec(lambda: dict(angle=np.array([0.5, 4.0, -7.0])),
                                               kinds=dict(angle=Real((None,), extra_axis_ok=True))),
    "uwtutor.models.range:BeaconRanges": Spec(
        lambda: dict(beacons=np.array([[5.0, 12.0], [-4.0, 3.0]]), R=0.36, n=3, scale_index=2),
        kinds=dict(beacons=Real((None, 2)), R=Real((), "pos", vector_ok=True), n=Int(minimum=2),
                   scale_index=_OptInt(minimum=2)),
        call=_build("uwtutor.models.range.BeaconRanges", use=_meas_use, x=[1.0, 2.0, 1.05])),
    "uwtutor.models.range:MultiplicativeRange": Spec(
        lambda: dict(beacon=(0.0, 0.0), R=1.0, mu_gamma=1.02, sigma_gamma=1e-3, n=2),
        kinds=dict(R=Real((), "pos", vector_ok=True), mu_gamma=_POS, sigma_gamma=_NONNEG, n=_OptInt(minimum=2)),
        call=_build("uwtutor.models.range.MultiplicativeRange", use=_meas_use)),
    "uwtutor.models.range:NoiseSchedule": Spec(
        lambda: dict(name="R", R=np.array([1.0, 2.0, 3.0]), m=1),
        kinds=dict(name=Kind(), R=Real(None, "pos", nan_ok=True, extra_axis_ok=True), m=Int(minimum=1)),
        call=lambda **kw: np.asarray(__import__("uwtutor.models.range", fromlist=["x"]).NoiseSchedule(**kw)
                                     .at(1), dtype=float)),
    "uwtutor.models.robust:ConstantVelocity": Spec(
        lambda: dict(d=2, q=0.01, steps=np.array([0.0, 1.0, 1.0])),
        kinds=dict(d=Int(minimum=1), q=_NONNEG, steps=Real((None,), "nonneg")),
        call=_build("uwtutor.models.robust.ConstantVelocity", k=1)),
    "uwtutor.models.robust:PositionMeasurement": Spec(
        lambda: dict(d=2, R=np.eye(2) * 2.0),
        kinds=dict(d=Int(minimum=1), R=Covariance(definite=True)),
        call=_build("uwtutor.models.robust.PositionMeasurement", use=_meas_use)),
    "uwtutor.models.robust:step_lengths": Spec(
        lambda: dict(n_steps=4, dt=1.0, times=np.array([0.0, 1.0, 2.5, 4.0])),
        kinds=dict(n_steps=Int(minimum=1, unbounded_work=True), dt=_POS, times=Real((4,), optional=True))),
    # --- filters -----------------------------------------------------------------------------------------------------
    "uwtutor.filters.base:run_filter": Spec(
        lambda: dict(filt=_ekf_object(), z=_Z, u=_U, times=np.arange(5.0)),
        # the one step loop does not know what z measures (a range here): its kind is any real, NaN missing
        kinds=dict(filt=Instance(), z=Real((5,), nan_ok=True, extra_axis_ok=True), u=Real((5, 2), optional=True),
                   times=Real((5,), optional=True))),
    "uwtutor.filters.bias:BiasEKF": Spec(
        lambda: dict(x0=np.r_[_X0, 0.0], P0=np.diag([100.0, 100.0, 4.0]), Q=np.diag([0.1, 0.1, 0.01]), R=1.0,
                     beacon=(0.0, 0.0), u=_U, z=_Z),
        kinds=dict(x0=Real((3,)), u=Real((5, 2), optional=True), z=Real((5,), "nonneg", nan_ok=True,
                                                                        extra_axis_ok=True)),
        call=_run_object("uwtutor.filters.bias.BiasEKF")),
    "uwtutor.filters.bias:bias_ekf": Spec(
        lambda: dict(x0=np.r_[_X0, 0.0], P0=np.diag([100.0, 100.0, 4.0]), u=_U, z=_Z,
                     Q=np.diag([0.1, 0.1, 0.01]), R=1.0, beacon=(0.0, 0.0), times=np.arange(5.0)),
        kinds=dict(x0=Real((3,)), u=Real((5, 2), optional=True),
                   z=Real((5,), "nonneg", nan_ok=True, extra_axis_ok=True), times=Real((5,), optional=True))),
    "uwtutor.filters.cooperative:cooperative_ekf": Spec(
        lambda: dict(_coop(), z=_coop_ranges(), formulation="consistent", lost="step"),
        kinds=dict(x0=Real((4,)), u=Real((4, 2)), leader=Real((5, 2)), z=Real((5,), "nonneg", nan_ok=True),
                   dt=_POS, Q=Covariance(), R=Covariance(),
                   formulation=Choice(("consistent", "literal", "single_range")), lost=Choice(("step", "range"))),
        per_argument=4),
    "uwtutor.filters.cooperative:CooperativeEKF": Spec(
        lambda: dict(_coop(), formulation="consistent", range_variance=4.0, lost="range"),
        kinds=dict(x0=Real((4,)), u=Real((4, 2)), leader=Real((5, 2)), dt=_POS, Q=Covariance(),
                   R=Covariance(), formulation=Choice(("consistent", "literal", "single_range")),
                   range_variance=Real((), "pos", optional=True), lost=Choice(("step", "range"))),
        call=lambda **kw: _steps(__import__("uwtutor.filters.cooperative", fromlist=["x"]).CooperativeEKF(**kw),
                                 _coop_ranges()),
        per_argument=4),
    "uwtutor.filters.cooperative:range_pairs": Spec(
        lambda: dict(ranges=np.array([100.0, 110.0, np.nan, 120.0])),
        kinds=dict(ranges=Real((None,), "nonneg", nan_ok=True))),
    "uwtutor.filters.cooperative:leader_observations": Spec(
        lambda: dict(ranges=np.where(np.arange(5) == 2, np.nan, _coop_ranges()), leader=_coop()["leader"],
                     single_range=False),
        kinds=dict(ranges=Real((5,), "nonneg", nan_ok=True), leader=Real((5, 2)), single_range=Flag())),
    "uwtutor.filters.cooperative:relative_track_deviation": Spec(
        lambda: dict(u=np.tile([2.0, 0.5], (4, 1)), leader=_coop()["leader"], times=np.arange(5.0) * 8.0),
        kinds=dict(u=Real((4, 2)), leader=Real((5, 2)), times=Real((5,), optional=True))),
    "uwtutor.filters.ekf:RangeOnlyEKF": Spec(
        lambda: dict(x0=_X0, P0=np.eye(2) * 100.0, Q=np.eye(2) * 0.1, R=1.0, beacon=(0.0, 0.0), u=_U, z=_Z),
        kinds=dict(u=Real((5, 2), optional=True), z=Real((5,), "nonneg", nan_ok=True)),
        call=_run_object("uwtutor.filters.ekf.RangeOnlyEKF")),
    "uwtutor.filters.fading:FadingEKF": Spec(
        lambda: dict(x0=_X0, P0=np.eye(2) * 100.0, Q=np.eye(2) * 0.1, R=1.0, mu_gamma=0.98, sigma_gamma=1e-3,
                     rho=0.95, beta="range", fading=True, second_moment0=np.eye(2), beacon=(0.0, 0.0), u=_U, z=_Z),
        # mu_gamma, sigma_gamma: one per run is documented (a batch of runs)
        kinds=dict(mu_gamma=Real((), "pos", vector_ok=True), sigma_gamma=Real((), "nonneg", vector_ok=True),
                   rho=Real((), "open01"), beta=Kind(), fading=Flag(), second_moment0=_OptCov(),
                   u=Real((5, 2), optional=True), z=Real((5,), "nonneg", nan_ok=True)),
        call=_run_object("uwtutor.filters.fading.FadingEKF"), check=_fading_check),
    "uwtutor.filters.fading:range_factor_moments": Spec(
        lambda: dict(assumed_speed=1470.0, effective_speed=1500.0, speed_sigma=1.0),
        kinds=dict(assumed_speed=_POS, effective_speed=_POS, speed_sigma=_NONNEG)),
    "uwtutor.filters.gates:ChiSquareGate": Spec(
        lambda: dict(probability=0.99, per_component=False),
        kinds=dict(probability=Real((), "open01"), per_component=Flag()),
        call=lambda **kw: _gated(__import__("uwtutor.filters.gates", fromlist=["x"]).ChiSquareGate(**kw))),
    "uwtutor.filters.gates:ReacquiringGate": Spec(
        lambda: dict(test=None, patience=2, factor=10.0, states=[0, 1], force=True, max_variance=1e10),
        kinds=dict(test=Instance(optional=True), patience=Int(minimum=1), factor=Real((), "pos"),
                   states=Real((2,), optional=True), force=Flag(), max_variance=_POS),
        call=lambda **kw: _gated(__import__("uwtutor.filters.gates", fromlist=["x"]).ReacquiringGate(**kw),
                                 offset=60.0)),
    "uwtutor.filters.kalman:KalmanFilter": Spec(
        lambda: dict(F=[[1.0, 1.0], [0.0, 1.0]], H=[[1.0, 0.0]], Q=np.eye(2) * 0.01, R=[[4.0]], x0=[100.0, 0.0],
                     P0=np.diag([100.0, 1.0]), B=None),
        kinds=dict(F=Real((2, 2)), H=Real((1, 2)), x0=Real((2,))),
        call=lambda **kw: __import__("uwtutor.filters.kalman", fromlist=["x"]).KalmanFilter(**kw).run(
            [101.0, 99.5, np.nan, 100.2])),
    "uwtutor.filters.legacy:DepthEKF": Spec(
        lambda: dict(x0=[10.0, 1.5, 0.1], P0=np.eye(3) * 0.1, Q=np.eye(3) * 1e-4, R=np.eye(3) * 0.01, T=0.05),
        kinds=dict(x0=Real((3,)), Q=_OptCov(), R=_OptCov(definite=True), T=_POS),
        call=lambda **kw: __import__("uwtutor.filters.legacy", fromlist=["x"]).DepthEKF(**kw).run(
            np.array([[10.0, 1.5, 0.1], [10.1, 1.4, 0.12], [10.0, 1.6, 0.1]]))),
    "uwtutor.filters.legacy:LinearGaussianModel": Spec(
        lambda: dict(F=[[1.0, 1.0], [0.0, 1.0]], H=[[1.0, 0.0]], Q=np.eye(2) * 0.01, R=[[4.0]], B=None),
        kinds=dict(F=Real((2, 2)), H=Real((1, 2))),
        call=lambda **kw: _lgm_use(__import__("uwtutor.filters.legacy", fromlist=["x"]).LinearGaussianModel(**kw))),
    "uwtutor.filters.particle.bootstrap:BootstrapParticleFilter": Spec(
        lambda: dict(motion=_models()[0], measurement=_models()[1], particles=_particles(),
                     rng=np.random.default_rng(0), weights=np.full(20, 0.05), ess_threshold=0.5, roughening=0.2),
        kinds=dict(motion=Model(sampled=True), measurement=Model(optional=True, likelihood=True),
                   particles=Real((20, 2)),
                   # ess_threshold >= 1 is documented: resample at every measurement
                   weights=Real((20,), "nonneg", optional=True), ess_threshold=_NONNEG,
                   roughening=_NONNEG),
        call=_run_particles("uwtutor.filters.particle.bootstrap.BootstrapParticleFilter")),
    "uwtutor.filters.particle.grey:GreyParticleFilter": Spec(
        lambda: dict(motion=_depth()[0], measurement=_depth()[1], particles=_depth_particles(),
                     rng=np.random.default_rng(0), grey_fraction=0.1, grey_window=4, grey_std=[0.01, 0.01, 0.01],
                     grey_offset=[0.0, 0.0, 1.0], noise_window=12, wavelet="db2", adapt_noise=True,
                     min_noise_std=[1e-3, 1e-3, 1e-3]),
        kinds=dict(motion=Model(sampled=True), measurement=Model(optional=True), particles=Real((None, 3)),
                   grey_fraction=Real((), "prob"), grey_window=Int(minimum=4),
                   grey_std=Real((3,), "nonneg", optional=True), grey_offset=Real((3,), optional=True),
                   noise_window=Int(minimum=1), wavelet=Choice(), adapt_noise=Flag(),
                   min_noise_std=Real((3,), "pos", optional=True)),
        call=_run_depth("uwtutor.filters.particle.grey.GreyParticleFilter"), per_argument=4),
    "uwtutor.filters.particle.multiple_model:MultipleModelParticleFilter": Spec(
        lambda: dict(motions=[_depth()[0], _depth()[0]], measurement=_depth()[1], particles=_depth_particles(),
                     rng=np.random.default_rng(0), transition=[[0.9, 0.1], [0.2, 0.8]], modes=None,
                     mode_probabilities=[0.5, 0.5], ess_threshold=1.0),
        # mode_probabilities are normalized (documented, as the weights are); ess_threshold >= 1: always resample
        kinds=dict(motions=Model(sampled=True), measurement=Model(optional=True, likelihood=True),
                   particles=Real((None, 3)),
                   transition=Real((2, 2), "prob"), mode_probabilities=Real((2,), "nonneg", optional=True),
                   ess_threshold=_NONNEG),
        call=_run_depth("uwtutor.filters.particle.multiple_model.MultipleModelParticleFilter"), per_argument=4,
        names=("motion model",)),
    "uwtutor.filters.gates:RobustGate": Spec(
        lambda: dict(test=None, steps=np.r_[0.0, np.ones(4)], on_outlier="extrapolate", reacquire=3),
        kinds=dict(test=Instance(optional=True), steps=Real((None,), "nonneg"),
                   on_outlier=Choice(("predict", "extrapolate")), reacquire=_OptInt(minimum=3)),
        call=_robust_gated),
    "uwtutor.filters.gates:SecondMomentGate": Spec(
        lambda: dict(delta=0.03), kinds=dict(delta=Real((), "open01")),
        call=lambda **kw: _robust_gated(__import__("uwtutor.filters.robust", fromlist=["x"]).SecondMomentGate(**kw),
                                        np.r_[0.0, np.ones(4)])),
    "uwtutor.filters.robust:cascade_kf": Spec(
        lambda: dict(fixes=_fixes(), dt=1.0, q=1e-4, r=400.0, test="chi2", delta=0.03, probability=0.99,
                     on_outlier="predict", reacquire=20, times=np.arange(8.0)),
        kinds=dict(fixes=Real((8, 2), nan_ok=True), dt=_POS, q=_NONNEG, r=Real((), "pos", vector_ok=True),
                   test=Choice(("paper", "chi2", "none")), on_outlier=Choice(("predict", "extrapolate")),
                   reacquire=_OptInt(minimum=3), times=Real((8,), optional=True))),
    "uwtutor.filters.gates:moment_gate_interval": Spec(
        lambda: dict(z_pred=1500.0, S=4.0, delta=0.03),
        kinds=dict(z_pred=Real((), "pos", vector_ok=True), S=Real((), "nonneg", vector_ok=True))),
    "uwtutor.filters.robust:robust_track_kf": Spec(
        lambda: dict(z=_fixes(), dt=1.0, q=1e-4, r=400.0, test="paper", delta=0.03, probability=0.99,
                     on_outlier="predict", reacquire=None, times=np.arange(8.0),
                     x0=np.array([-1000.0, -1000.0, 1.0, 1.0]), P0=np.diag([400.0, 400.0, 25.0, 25.0]),
                     initial_rate_sigma=5.0),
        kinds=dict(z=Real((8, 2), nan_ok=True), dt=_POS, q=_NONNEG, r=Real((), "pos", vector_ok=True),
                   test=Choice(("paper", "chi2", "none")), on_outlier=Choice(("predict", "extrapolate")),
                   reacquire=_OptInt(minimum=3), times=Real((8,), optional=True), x0=Real((4,), optional=True),
                   P0=_OptCov(definite=True), initial_rate_sigma=_POS)),
    # --- pipelines ---------------------------------------------------------------------------------------------------
    "uwtutor.pipelines.depth_study:run_depth_study": Spec(
        lambda: dict(profile=_paper_c().profile, measurements=_paper_c().measurements, filters=("EKF", "GPF"),
                     n_particles=30, grey_fraction=0.1, grey_window=5, noise_window=12,
                     process_std=[0.01, 0.01, 0.0035], mmpf_targets_deg=(0.0, 20.0), mmpf_time_constant=1.0,
                     mmpf_stay=0.995, seed=0),
        kinds=dict(profile=Instance(), measurements=Real((None, 40, 3)), filters=Kind(),
                   n_particles=Int(minimum=1, unbounded_work=True), grey_fraction=Real((), "prob"),
                   grey_window=Int(minimum=4), noise_window=Int(minimum=1),
                   process_std=Real((3,), "nonneg", optional=True), mmpf_targets_deg=Kind(),
                   mmpf_time_constant=_POS, mmpf_stay=Real((), "prob"), seed=Seed()), per_argument=4),
    "uwtutor.pipelines.ls_fading:ls_fading_ekf": Spec(
        lambda: dict(ranges=_approach().ranges, dr_displacements=_approach().dr_displacements, Q=np.eye(2) * 0.81,
                     R=0.49, P0=np.eye(2) * 2500.0, mu_gamma="prelocation", sigma_gamma=1 / 1500, rho=0.95,
                     beta="range", fading=True, assumed_speed=1470.0, beacon=(0.0, 0.0), times=_approach().times,
                     n_consecutive=10, max_shift=50.0, min_heading_change=0.17),
        kinds=dict(ranges=Real((1, 151), "nonneg", nan_ok=True), dr_displacements=Real((1, 151, 2)),
                   mu_gamma=Kind(), sigma_gamma=_NONNEG, rho=Real((), "open01"), beta=Kind(), fading=Flag(),
                   assumed_speed=_POS, times=Real((151,), optional=True), n_consecutive=Int(minimum=1),
                   max_shift=_POS, min_heading_change=_NONNEG), per_argument=3),
    "uwtutor.pipelines.prepositioned:prepositioned_bias_ekf": Spec(
        lambda: dict(ranges=_paper_a().ranges[:, :600], dr_displacements=_paper_a().dr_displacements[:, :600],
                     provisional_start=_paper_a().true_positions[:, 0] + [150.0, 0.0],
                     Q=np.diag([1.0, 1.0, 1.0]), R=5.0, P0=np.eye(3), max_alpha=2.0, beacon=(0.0, 0.0),
                     iterations=3, times=np.arange(600.0)),
        kinds=dict(ranges=Real(None, "nonneg", nan_ok=True), dr_displacements=Real(None),
                   provisional_start=Real((1, 2)), R=Real((), "pos"), P0=_OptCov(definite=True), max_alpha=_POS,
                   iterations=Int(minimum=1, unbounded_work=True), times=Real((600,), optional=True)),
        per_argument=4),
    "uwtutor.pipelines.vmlbl:epoch_windows": Spec(
        lambda: dict(n_steps=10, spacing=3, n_epochs=4),
        kinds=dict(n_steps=Int(minimum=1, unbounded_work=True), spacing=Int(minimum=1), n_epochs=Int(minimum=3))),
    "uwtutor.pipelines.vmlbl:vmlbl_error_budget": Spec(
        lambda: dict(rng=np.random.default_rng(1), ship_positions=_paper_e_dive()[0], true_positions=_paper_e_dive()[1],
                     depth=_paper_e_dive()[2], spacing=20, levels=[1.0, 2.0], n_runs=100, n_epochs=4),
        kinds=dict(ship_positions=Real((400, 2)), true_positions=Real((400, 2)), depth=_NONNEG,
                   spacing=Int(minimum=1), levels=Real((None,), "pos"), n_runs=Int(minimum=1, unbounded_work=True),
                   n_epochs=Int(minimum=3)), per_argument=4),
    # --- real logs ---------------------------------------------------------------------------------------------------
    "uwtutor.datasets._core:RangeDataset": Spec(
        lambda: dict(times=_small_log().times, odometry=_small_log().odometry, ranges=_small_log().ranges[:10],
                     beacons={3: (5.0, 12.0), 7: (-4.0, 3.0)}, truth=_small_log().truth, start=[0.0, 0.0, 0.0],
                     start_cov=np.diag([0.01, 0.01, 3e-4]), name="square", notes=()),
        kinds=dict(times=Real((81,)), odometry=Real((81, 2)), ranges=_NoRangesOk((10, 3), "nonneg"), beacons=Mapping(),
                   truth=Real((81, 3), optional=True), start=Real((3,), optional=True),
                   start_cov=_OptCov(), name=Kind(), notes=Kind()),
        call=lambda **kw: (lambda d: (d.dead_reckoning(), d.ranges_on_epochs()))(
            __import__("uwtutor.datasets", fromlist=["x"]).RangeDataset(**kw)), per_argument=5),
    "uwtutor.datasets._plaza:plaza": Spec(
        lambda: dict(number=1), kinds=dict(number=Int(minimum=1, maximum=2)),
        call=lambda **kw: __import__("uwtutor.datasets", fromlist=["x"]).plaza(**kw).start),
    "uwtutor.datasets.navigation:navigate": Spec(
        lambda: dict(data=_small_log(), beacon_ids=[3], min_period=2.0, smooth=True, gyro_bias=True, scale=True,
                     range_sigma=0.6, distance_sigma=(0.01, 0.02), heading_noise=1e-3, gyro_bias_prior=0.01,
                     gyro_bias_walk=1e-4, scale_prior=0.1, scale_walk=1e-5, gate=True),
        kinds=dict(data=Instance(), beacon_ids=Kind(), min_period=Real((), "pos", optional=True), smooth=Flag(),
                   gyro_bias=_OptionalFlag(), scale=_OptionalFlag(), range_sigma=_POS,
                   distance_sigma=Real((2,), "nonneg"),
                   heading_noise=_POS, gyro_bias_prior=_POS, gyro_bias_walk=_POS, scale_prior=_POS,
                   scale_walk=_POS, gate=Flag()), per_argument=4),
}

EXEMPT_STRUCT: dict[str, str] = {
    "uwtutor.models.base:MotionModel": "an abstract base class, built with no argument; what a subclass returns "
                                       "(f, F, Q) is checked by the engine at every new array "
                                       "(tests/test_robustness_reproducers.py)",
    "uwtutor.models.base:MeasurementModel": "an abstract base class, built with no argument; what a subclass "
                                            "returns (h, H, R, the linearize mask) is checked by the engine "
                                            "(tests/test_robustness_reproducers.py)",
    "uwtutor.filters.base:Filter": "a typing.Protocol (the members every filter has), never instantiated; "
                                   "tests/test_filter_contract.py holds every filter to it",
    "uwtutor.filters.base:FilterResult": "a result container run_filter and every filter's run build",
    "uwtutor.filters.fading:FadingResult": "a result container fading_ekf and FadingEKF.run build",
    "uwtutor.filters.smoother:SmootherResult": "a result container rts_smoother builds",
    "uwtutor.filters.gates:Gate": "an abstract base class, built with no argument; what a subclass's accept "
                                  "returns is checked by the engine (tests/test_robustness_reproducers.py)",
    "uwtutor.pipelines.depth_study:DepthStudy": "a result container run_depth_study builds",
    "uwtutor.pipelines.ls_fading:LSFadingResult": "a result container ls_fading_ekf builds",
    "uwtutor.pipelines.staggered:StaggeredRun": "a result container filter_from_start_epochs builds",
    "uwtutor.pipelines.vmlbl:ErrorBudget": "a result container vmlbl_error_budget builds",
    "uwtutor.pipelines.vmlbl:VMLBLResult": "a result container or_vmlbl_kf builds",
    "uwtutor.filters.gates:GateContext": "the per-step values the engine hands a gate's accept (built by the "
                                         "engine from its own checked arrays, never by a user)",
}
