"""The filter protocol held by the particle filters on every kind of model pair (single and batched), and by the
generic EKF on paper C's pair.

The cases are (filter family x model pair): paper C's depth/speed/pitch pair in the bootstrap, multiple-model and
grey particle filters and in the EKF engine; the range-only pair of chapter 10 (dead reckoning as the input ``u``,
one run per beacon path: a moving beacon is a measurement model input) in the bootstrap and multiple-model
filters; the odometry pair of the real logs (``OdometryMotion`` with a gyro bias and a range scale, four beacons
with missing ranges) in the bootstrap filter, plain and roughened; and a ``ModelPair`` given in place of the two
models.

For every filter: it is a ``Filter``; ``run`` == ``run_filter`` == a hand loop for every field and extra (same
seed); a NaN measurement means predict only and a NaN component is skipped; run ``m`` of a batch equals the single
run on the same generator; ``P`` is symmetric positive semi-definite; bad input names the argument; run block by
block equals run step by step; on a linear-Gaussian pair the particle filters approach the Kalman filter.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any, Callable

import numpy as np
import pytest

from uwtutor.filters import (BootstrapParticleFilter, ExtendedKalmanFilter, Filter, GreyParticleFilter, KalmanFilter,
                             MultipleModelParticleFilter, run_filter)
from uwtutor.models import (BeaconRanges, DeadReckoning, DepthSensors, DepthSpeedPitch, DepthSpeedPitchModel,
                            LinearMeasurement, LinearMotion, OdometryMotion, PitchManeuver, RangeToBeacon)
from uwtutor.montecarlo import run_monte_carlo

Q_STD = np.array([0.05, 0.01, np.radians(0.3)])
R = np.diag([0.2, 0.05, np.radians(0.5)]) ** 2
K = 80                              # steps: more than the GPF's windows (30 and 50), so every path runs
M = 3                               # runs of a batch
N = 200                             # particles
TRUE_X0 = np.array([10.0, 1.5, 0.1])
BEACONS = np.array([[0.0, 0.0], [40.0, 0.0], [40.0, 30.0], [0.0, 30.0]])


# --- the data of each kind of model -------------------------------------------------------------------------------

def _depth_data(n_runs: int = M, seed: int = 11) -> dict[str, Any]:
    """(n_runs, K, 3) readings of a diving vehicle, with missing readings: one whole step and single sensors."""
    model = DepthSpeedPitchModel(process_std=Q_STD, R=R)
    rng = np.random.default_rng(seed)
    Z = np.stack([model.simulate(TRUE_X0, K, rng)[1] for _ in range(n_runs)])
    Z[:, 20] = np.nan                        # no measurement at all: predict only
    Z[:, 40, 1] = np.nan                     # the speed sensor missing
    Z[0, 60, 2] = np.nan                     # the pitch sensor of run 0 only
    return dict(z=Z, u=None, x0=Z[:, 0].copy(), P0=R)


def _range_data(n_runs: int = M, seed: int = 3) -> dict[str, Any]:
    """Chapter 10's problem: a vehicle on an arc, DR displacements as the input (one sequence per run), ranges to a
    ship whose path differs from run to run, 20 % of the ranges missing and one step without any."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, np.pi, K + 1)
    track = 300.0 * np.column_stack([np.cos(t), np.sin(t)])
    ship = np.column_stack([np.linspace(0.0, 150.0, K), np.zeros(K)])[None] + rng.normal(0.0, 20.0, (n_runs, 1, 2))
    u = np.diff(track, axis=0)[None] + rng.normal(0.0, 0.5, (n_runs, K, 2))
    z = np.linalg.norm(track[1:] - ship, axis=-1) + rng.normal(0.0, 2.0, (n_runs, K))
    z[rng.random((n_runs, K)) < 0.2] = np.nan
    z[:, 20] = np.nan
    return dict(z=z, u=u, x0=track[0] + rng.normal(0.0, 10.0, (n_runs, 2)), P0=100.0 * np.eye(2), beacon=ship)


def _odometry_data(n_runs: int = M, seed: int = 6) -> dict[str, Any]:
    """Wheel odometry [distance, heading change] with a gyro bias, four beacons, ranges 7 % long, 30 % of the ranges
    missing one by one, and some epochs without any."""
    rng = np.random.default_rng(seed)
    motion = OdometryMotion(0.0, 0.0, gyro_bias=True, scale=True, dt=0.5)
    u_true = np.column_stack([np.full(K, 0.5), 0.06 + 0.04 * np.sin(np.arange(K) / 8)])
    truth = motion.integrate([20.0, 5.0, 0.0, 0.004, 1.07], u_true)
    u = u_true + rng.normal(0.0, [0.02, 0.003], (n_runs, K, 2)) + [0.0, 0.002]
    z = 1.07 * np.linalg.norm(truth[:, None, :2] - BEACONS, axis=-1) + rng.normal(0.0, 0.05, (n_runs, K, 4))
    z[rng.random(z.shape) < 0.3] = np.nan
    z[:, ::9] = np.nan
    z[:, 20] = np.nan                        # the step the tests read as predict only
    x0 = np.array([20.0, 5.0, 0.0, 0.0, 1.0]) + rng.normal(0.0, [0.3, 0.3, 0.02, 0.0, 0.0], (n_runs, 5))
    return dict(z=z, u=u, x0=x0, P0=np.diag([0.25, 0.25, 0.004, 1e-5, 0.01]))


# --- the filters --------------------------------------------------------------------------------------------------

def _pick(a, sel):
    return a[sel]


def _depth_pf(d, sel, rng, n=N, **kw):
    return BootstrapParticleFilter.from_gaussian(DepthSpeedPitch(process_std=Q_STD), DepthSensors(R), d["x0"][sel],
                                                 R, n, rng, **kw)


def _depth_mmpf(d, sel, rng, n=N):
    modes = [PitchManeuver(pitch_target=p, time_constant=1.0, process_std=Q_STD) for p in (0.0, 0.3, -0.3)]
    Pi = np.full((3, 3), 0.01) + np.eye(3) * 0.97
    return MultipleModelParticleFilter.from_gaussian(modes, DepthSensors(R), d["x0"][sel], R, n, rng, transition=Pi)


def _depth_gpf(d, sel, rng, n=N):
    return GreyParticleFilter.from_gaussian(DepthSpeedPitch(process_std=Q_STD), DepthSensors(R), d["x0"][sel], R, n,
                                            rng, grey_offset=[0.0, 0.0, 1.0])


def _depth_pair_pf(d, sel, rng, n=N):
    """The same filter with one ModelPair in place of the two models."""
    return BootstrapParticleFilter.from_gaussian(DepthSpeedPitchModel(process_std=Q_STD, R=R), d["x0"][sel], R, n,
                                                 rng)


def _depth_ekf(d, sel, rng, n=None):              # deterministic: rng unused
    return ExtendedKalmanFilter(DepthSpeedPitch(process_std=Q_STD), DepthSensors(R), d["x0"][sel], R)


def _range_pf(d, sel, rng, n=N):
    """Chapter 10's particle filter: the EKF's range-only pair, the DR displacement as input, per-run beacon path."""
    return BootstrapParticleFilter.from_gaussian(DeadReckoning(np.eye(2) * 0.25),
                                                 RangeToBeacon(d["beacon"][sel], R=4.0), d["x0"][sel], d["P0"], n,
                                                 rng, ess_threshold=0.5)


def _range_mmpf(d, sel, rng, n=N):
    modes = [DeadReckoning(np.eye(2) * 0.1), DeadReckoning(np.eye(2) * 2.0)]      # calm and disturbed DR
    return MultipleModelParticleFilter.from_gaussian(modes, RangeToBeacon(d["beacon"][sel], R=4.0), d["x0"][sel],
                                                     d["P0"], n, rng, transition=[[0.95, 0.05], [0.1, 0.9]])


def _odometry_pf(d, sel, rng, n=N, **kw):
    """The real-data pair: odometry with a gyro bias and a range scale (no walk: a constant state), 4 beacons."""
    motion = OdometryMotion(0.02, 0.003, gyro_bias=True, scale=True, dt=0.5, gyro_bias_walk=1e-4)
    return BootstrapParticleFilter.from_gaussian(motion, BeaconRanges(BEACONS, R=0.05**2 * 4, layout=motion.layout),
                                                 d["x0"][sel], d["P0"], n, rng, ess_threshold=0.5, **kw)


@dataclass
class Case:
    name: str
    make: Callable[..., Any]
    data: Callable[..., dict]
    particles: bool = True


CASES = [
    Case("PF", _depth_pf, _depth_data),
    Case("PF (ESS < N/2)", lambda d, sel, rng, n=N: _depth_pf(d, sel, rng, n, ess_threshold=0.5), _depth_data),
    Case("PF (ModelPair)", _depth_pair_pf, _depth_data),
    Case("MMPF", _depth_mmpf, _depth_data),
    Case("GPF", _depth_gpf, _depth_data),
    Case("EKF (paper C pair)", _depth_ekf, _depth_data, particles=False),
    Case("PF range input", _range_pf, _range_data),
    Case("MMPF range input", _range_mmpf, _range_data),
    Case("PF odometry", _odometry_pf, _odometry_data),
    Case("PF odometry (roughened)", lambda d, sel, rng, n=N: _odometry_pf(d, sel, rng, n, roughening=0.1),
         _odometry_data),
]
BY_NAME = {c.name: c for c in CASES}
DATA = {c.name: c.data() for c in CASES}
PARTICLE_CASES = [c.name for c in CASES if c.particles]


def _rngs(seed: int, n: int) -> list[np.random.Generator]:
    return list(np.random.default_rng(seed).spawn(n))


def _make(name: str, batched: bool, seed: int = 5, m: int = 0):
    """The filter ``name`` with M runs (one spawned Generator each) or the single run ``m`` (one Generator)."""
    case, d = BY_NAME[name], DATA[name]
    if batched:
        return case.make(d, slice(None), _rngs(seed, M))
    return case.make(d, m, np.random.default_rng(seed))


def _inputs(name: str, batched: bool, m: int = 0):
    d = DATA[name]
    z, u = d["z"], d["u"]
    if batched:
        return z, u
    return z[m], None if u is None else u[m]


def _hand_loop(filt, z, u, batched):
    """The protocol by hand: predict, update, read the attributes."""
    names = ("x", "P", "x_prior", "P_prior", "y", "S") + tuple(filt.extra_outputs)
    rec = {name: [] for name in names}
    for k in range(z.shape[1] if batched else z.shape[0]):
        filt.predict(None if u is None else u[..., k, :])
        filt.update(z[:, k] if batched else z[k])
        for name in names:
            rec[name].append(np.array(getattr(filt, name), copy=True))
    return {name: np.stack(v, axis=1 if batched else 0) for name, v in rec.items()}


def _assert_same_result(a, b):
    assert type(a) is type(b)
    for f in fields(a):
        if f.name != "extras":
            np.testing.assert_array_equal(getattr(a, f.name), getattr(b, f.name), err_msg=f.name)
    assert list(a.extras) == list(b.extras)
    for name in a.extras:
        assert a.extras[name].dtype == b.extras[name].dtype, name
        np.testing.assert_array_equal(a.extras[name], b.extras[name], err_msg=name)


PARAMS = [(c.name, batched) for c in CASES for batched in (False, True)]
IDS = [f"{name}-{'batched' if b else 'single'}" for name, b in PARAMS]


@pytest.mark.parametrize("name, batched", PARAMS, ids=IDS)
def test_is_a_filter_with_the_protocols_shapes(name, batched):
    f = _make(name, batched)
    assert isinstance(f, Filter)
    n, m = DATA[name]["x0"].shape[-1], DATA[name]["z"].reshape(M, K, -1).shape[-1]
    lead = (M,) if batched else ()
    assert np.shape(f.x) == lead + (n,) and np.shape(f.P) == lead + (n, n)
    assert np.shape(f.x_prior) == lead + (n,) and np.shape(f.P_prior) == lead + (n, n)
    assert np.shape(f.y) == lead + (m,) and np.shape(f.S) == lead + (m, m)
    assert isinstance(f.extra_outputs, tuple)


@pytest.mark.parametrize("name, batched", PARAMS, ids=IDS)
def test_run_equals_run_filter_equals_a_hand_loop(name, batched):
    z, u = _inputs(name, batched)
    times = 0.05 * np.arange(1, K + 1)
    res = _make(name, batched).run(z, u, times=times)
    res_loop = run_filter(_make(name, batched), z, u, times)
    _assert_same_result(res, res_loop)
    hand = _hand_loop(_make(name, batched), z, u, batched)
    for field, key in (("x", "x"), ("P", "P"), ("x_prior", "x_prior"), ("P_prior", "P_prior")):
        np.testing.assert_array_equal(getattr(res, field), hand[key], err_msg=field)
    np.testing.assert_array_equal(res.innovations.reshape(-1), hand["y"].reshape(-1))
    np.testing.assert_array_equal(res.innovation_cov.reshape(-1), hand["S"].reshape(-1))
    assert set(res.extras) == set(_make(name, batched).extra_outputs)
    for key in res.extras:
        np.testing.assert_array_equal(res.extras[key], hand[key], err_msg=key)
    np.testing.assert_array_equal(res.times, times)


@pytest.mark.parametrize("name, batched", PARAMS, ids=IDS)
def test_nan_measurement_is_predict_only(name, batched):
    z, u = _inputs(name, batched)
    zz = z.reshape(z.shape[:2 if batched else 1] + (-1,))
    f = _make(name, batched)
    for k in range(20):
        f.predict(None if u is None else u[..., k, :])
        f.update(z[:, k] if batched else z[k])
    weights = np.array(f.weights, copy=True) if hasattr(f, "weights") else None
    f.predict(None if u is None else u[..., 20, :])
    x_prior, P_prior = np.array(f.x, copy=True), np.array(f.P, copy=True)
    f.update(z[:, 20] if batched else z[20])             # all NaN
    np.testing.assert_array_equal(f.x, x_prior)
    np.testing.assert_array_equal(f.P, P_prior)
    np.testing.assert_array_equal(f.x_prior, x_prior)
    assert np.isnan(f.y).all() and np.isnan(f.S).all()
    if weights is not None:
        assert not np.any(f.resampled)
        if not name.startswith("MMPF"):                  # the MMPF's predict regroups its particles by mode
            np.testing.assert_array_equal(f.weights, weights)
    # partly missing measurements: the innovation is NaN exactly for the missing components, and the others update
    res = _make(name, batched).run(z, u)
    present = np.isfinite(zz)
    np.testing.assert_array_equal(np.isnan(res.innovations), ~present)
    some = present.any(axis=-1) & ~present.all(axis=-1)
    if some.any():
        assert not np.array_equal(res.x[some], res.x_prior[some])


@pytest.mark.parametrize("name", [c.name for c in CASES])
def test_batched_run_m_equals_the_single_run_on_the_same_generator(name):
    z, u = _inputs(name, True)
    batch = _make(name, True, seed=9).run(z, u)
    for m in range(M):
        case, d = BY_NAME[name], DATA[name]
        zm, um = _inputs(name, False, m)
        one = case.make(d, m, _rngs(9, M)[m]).run(zm, um)
        for f in fields(one):
            if f.name in ("extras", "times"):
                continue
            np.testing.assert_allclose(getattr(batch, f.name)[m], getattr(one, f.name), rtol=1e-9, atol=1e-12,
                                       err_msg=f"{f.name} of run {m}")
        for key, value in one.extras.items():
            if value.dtype == bool:                      # decisions (resampling, grey sampling) are identical
                np.testing.assert_array_equal(batch.extras[key][m], value, err_msg=key)
            else:
                np.testing.assert_allclose(batch.extras[key][m], value, rtol=1e-9, atol=1e-12, err_msg=key)


@pytest.mark.parametrize("name", ["PF", "MMPF", "GPF", "PF range input", "PF odometry"])
def test_one_generator_is_split_with_spawn(name):
    """A single Generator given to a batch of M > 1 runs is split into rng.spawn(M)."""
    case, d = BY_NAME[name], DATA[name]
    z, u = _inputs(name, True)
    a = case.make(d, slice(None), np.random.default_rng(4)).run(z, u)
    b = case.make(d, slice(None), _rngs(4, M)).run(z, u)
    _assert_same_result(a, b)
    zm, um = _inputs(name, False, 1)
    one = case.make(d, 1, np.random.default_rng(4).spawn(M)[1]).run(zm, um)
    np.testing.assert_allclose(a.x[1], one.x, rtol=1e-9, atol=1e-12)
    # and the runs of a batch are not copies of each other
    same = dict(d, x0=np.broadcast_to(d["x0"][0], d["x0"].shape),
                **({"beacon": np.broadcast_to(d["beacon"][0], d["beacon"].shape)} if "beacon" in d else {}))
    c = case.make(same, slice(None), np.random.default_rng(4)).run(
        np.broadcast_to(z[0], z.shape), None if u is None else np.broadcast_to(u[0], u.shape))
    assert not np.array_equal(c.x[0], c.x[1])


@pytest.mark.parametrize("name, batched", PARAMS, ids=IDS)
def test_covariances_are_symmetric_positive_semidefinite(name, batched):
    z, u = _inputs(name, batched)
    res = _make(name, batched).run(z, u)
    for P in (res.P, res.P_prior):
        np.testing.assert_allclose(P, np.swapaxes(P, -1, -2), rtol=0, atol=1e-12 * np.abs(P).max())
        assert np.linalg.eigvalsh(P).min() >= -1e-12 * np.abs(P).max()
    S = res.innovation_cov
    ok = np.isfinite(S).all(axis=(-1, -2))
    assert np.linalg.eigvalsh(S[ok]).min() > 0


@pytest.mark.parametrize("name", [c.name for c in CASES])
def test_bad_input_names_the_argument(name):
    case, d = BY_NAME[name], DATA[name]
    m = d["z"].reshape(M, K, -1).shape[-1]
    for batched in (False, True):
        z, u = _inputs(name, batched)
        f = _make(name, batched)
        with pytest.raises(ValueError, match="z must"):
            f.run(np.zeros((M, K, m + 1)) if batched else np.zeros((K, m + 1)), u)
        with pytest.raises(ValueError, match="z must"):
            f.update(np.zeros(5 * m + 1))
        with pytest.raises(ValueError, match="z must be finite"):
            f.update(np.full((M, m) if batched else m, np.inf))
        with pytest.raises(ValueError, match="times must"):
            f.run(z, u, times=np.arange(K + 1))
        if u is None:                                    # paper C's model takes no input
            with pytest.raises(ValueError, match="control input|u must"):
                f.run(z, u=np.zeros((K, 1)))
        else:
            with pytest.raises(ValueError, match=r"\bu\b"):
                f.run(z, u[..., :3, :])
            with pytest.raises(ValueError, match=r"\bu\b"):
                _make(name, batched).predict(np.full(u.shape[:-2] + (u.shape[-1],), np.nan))
    x0 = d["x0"][0].copy()
    x0[1] = np.nan
    with pytest.raises(ValueError, match="x0"):
        case.make(dict(d, x0=np.stack([x0] * M)), 0, np.random.default_rng(0))
    if case.particles:
        with pytest.raises(ValueError, match="rng must be a sequence of 3"):
            case.make(d, slice(None), _rngs(0, 2))
        with pytest.raises(TypeError, match="rng must be a numpy.random.Generator"):
            case.make(d, slice(None), 7)
        with pytest.raises(ValueError, match=r"particles must keep the 3 runs"):
            _make(name, True).particles = np.zeros((2, N, d["x0"].shape[-1]))


def test_a_per_run_model_refuses_another_number_of_runs():
    d = DATA["PF range input"]
    with pytest.raises(ValueError, match="measurement model .*RangeToBeacon.* holds parameters for 3 runs"):
        BootstrapParticleFilter.from_gaussian(DeadReckoning(np.eye(2)), RangeToBeacon(d["beacon"], R=4.0),
                                              d["x0"][0], d["P0"], 10, np.random.default_rng(0), n_runs=2)


def test_one_paper_c_pair_runs_in_every_family():
    """One DepthSpeedPitch/DepthSensors pair: the EKF engine, the PF, the MMPF (with it as its one mode) and the GPF
    all run on it and all beat the depth sensor; the ModelPair form equals the two-model form draw for draw."""
    model = DepthSpeedPitchModel(process_std=Q_STD, R=R)
    rng = np.random.default_rng(8)
    sims = [model.simulate(TRUE_X0, 200, rng) for _ in range(M)]
    truth, z = np.stack([s[0] for s in sims]), np.stack([s[1] for s in sims])
    motion, sensors = model.motion, model.measurement
    results = {
        "EKF": ExtendedKalmanFilter(motion, sensors, z[:, 0], R).run(z),
        "PF": BootstrapParticleFilter.from_gaussian(motion, sensors, z[:, 0], R, 500, _rngs(2, M)).run(z),
        "MMPF": MultipleModelParticleFilter.from_gaussian([motion], sensors, z[:, 0], R, 500, _rngs(2, M),
                                                          transition=[[1.0]]).run(z),
        "GPF": GreyParticleFilter.from_gaussian(motion, sensors, z[:, 0], R, 500, _rngs(2, M),
                                                grey_offset=[0.0, 0.0, 1.0]).run(z),
    }
    sensor_rmse = np.sqrt(np.mean((z[:, 50:, 0] - truth[:, 50:, 0]) ** 2))
    for name, res in results.items():
        rmse = np.sqrt(np.mean((res.x[:, 50:, 0] - truth[:, 50:, 0]) ** 2))
        assert rmse < 0.7 * sensor_rmse, name
    pair = BootstrapParticleFilter.from_gaussian(model, z[:, 0], R, 500, _rngs(2, M)).run(z)
    _assert_same_result(pair, results["PF"])


# --- run block by block ---------------------------------------------------------------------------------------

@pytest.mark.parametrize("name", ["PF", "PF (ESS < N/2)", "MMPF", "GPF", "PF range input"])
def test_run_in_blocks_of_runs_equals_run_filter_and_leaves_the_same_state(name):
    """``run`` takes a large batch block by block (blocks of >= 2 runs of about 10 000 particles), a per-run model
    restricted to the block's runs (``select_runs``): the same result, field for field, as run_filter's whole-batch
    steps, and the same filter afterwards."""
    M7, N7 = 7, 3000                       # blocks of 3 runs: [0, 3) and [3, 7) (never a block of one run)
    case = BY_NAME[name]
    d = case.data(7, 13)
    d["z"], d["u"] = d["z"][:, :40], None if d["u"] is None else d["u"][:, :40]
    a, b = (case.make(d, slice(None), _rngs(6, M7), N7) for _ in range(2))
    assert [(s.start, s.stop) for s in a._blocks()] == [(0, 3), (3, 7)]
    _assert_same_result(a.run(d["z"], d["u"]), run_filter(b, d["z"], d["u"]))
    for f in (a, b):                       # one more step from the state each left behind
        f.predict(None if d["u"] is None else d["u"][:, 5])
        f.update(d["z"][:, 5])
    for attr in ("x", "P", "x_prior", "P_prior", "y", "S", "weights", "particles", "k") + tuple(a.extra_outputs):
        np.testing.assert_array_equal(getattr(a, attr), getattr(b, attr), err_msg=attr)


# --- on a linear-Gaussian pair the particle filters approach the Kalman filter ------------------------------------

F_CV = np.array([[1.0, 1.0], [0.0, 1.0]])
Q_CV = 0.05 * np.array([[1 / 3, 1 / 2], [1 / 2, 1.0]])
H_CV, R_CV = np.array([[1.0, 0.0]]), np.array([[4.0]])
X0_CV, P0_CV = np.array([0.0, 1.0]), np.diag([4.0, 0.25])


def _cv_data(H: np.ndarray = H_CV, R_std: np.ndarray = np.array([2.0]), K_cv: int = 40) -> np.ndarray:
    """Measurements ``H x + v`` of a constant-velocity track drawn from the model."""
    rng = np.random.default_rng(0)
    x, zs = X0_CV.copy(), []
    for _ in range(K_cv):
        x = F_CV @ x + rng.multivariate_normal(np.zeros(2), Q_CV)
        zs.append(H @ x + rng.normal(0.0, 1.0, len(R_std)) * R_std)
    return np.array(zs)


def _gap(pf_x, kf):
    """RMS over steps and components of (PF - KF) / KF standard deviation."""
    sd = np.sqrt(np.diagonal(kf.P, axis1=-2, axis2=-1))
    return float(np.sqrt(np.mean(((pf_x - kf.x) / sd) ** 2)))


@pytest.mark.parametrize("kind", ["PF", "MMPF", "GPF"])
def test_particle_filters_approach_the_kalman_filter_on_a_linear_gaussian_model(kind):
    if kind == "GPF":                       # the GPF needs h(x) = x: both states measured, for the KF too
        H, Rm = np.eye(2), np.diag([4.0, 1.0])
    else:
        H, Rm = H_CV, R_CV
    zs = _cv_data(H, np.sqrt(np.diag(Rm)))
    kf = KalmanFilter(F=F_CV, H=H, Q=Q_CV, R=Rm, x0=X0_CV, P0=P0_CV).run(zs)
    motion, measurement = LinearMotion(F_CV, Q_CV), LinearMeasurement(H, Rm)
    gaps = {}
    for n_particles in (200, 5000):
        def make(rng, n_runs):
            if kind == "PF":
                return BootstrapParticleFilter.from_gaussian(motion, measurement, X0_CV, P0_CV, n_particles, rng,
                                                             n_runs=n_runs)
            if kind == "MMPF":                # two identical modes: the mixture is the same linear-Gaussian model
                return MultipleModelParticleFilter.from_gaussian([motion, motion], measurement, X0_CV, P0_CV,
                                                                 n_particles, rng, n_runs=n_runs,
                                                                 transition=[[0.9, 0.1], [0.2, 0.8]])
            return GreyParticleFilter.from_gaussian(motion, measurement, X0_CV, P0_CV, n_particles, rng,
                                                    n_runs=n_runs, grey_fraction=0.0, adapt_noise=False,
                                                    grey_std=[1.0, 1.0])
        res = make(np.random.default_rng(3), 4).run(np.broadcast_to(zs, (4,) + zs.shape))
        gaps[n_particles] = np.mean([_gap(res.x[m], kf) for m in range(4)])
    # Monte Carlo error of the mean shrinks like 1/sqrt(N): 25 times the particles, about 5 times closer
    assert gaps[5000] < 0.1
    assert gaps[5000] < gaps[200] / 2.5


def test_run_monte_carlo_scores_a_batched_particle_filter():
    """run_monte_carlo takes a batched PF as it takes a batched EKF: one call, M runs, NEES and NIS."""
    rng = np.random.default_rng(21)
    n_runs, K_cv = 40, 30
    motion, measurement = LinearMotion(F_CV, Q_CV), LinearMeasurement(H_CV, R_CV)
    x0 = X0_CV + rng.multivariate_normal(np.zeros(2), P0_CV, n_runs)
    truth = np.empty((n_runs, K_cv, 2))
    z = np.empty((n_runs, K_cv, 1))
    for m in range(n_runs):
        x = x0[m]
        for k in range(K_cv):
            x = F_CV @ x + rng.multivariate_normal(np.zeros(2), Q_CV)
            truth[m, k] = x
            z[m, k] = H_CV @ x + rng.normal(0.0, 2.0, 1)

    def pf(z, seed):
        return BootstrapParticleFilter.from_gaussian(motion, measurement, X0_CV, P0_CV, 1000,
                                                     np.random.default_rng(seed), n_runs=z.shape[0]).run(z)

    study = run_monte_carlo(pf, truth, z=z, seed=1)
    assert study.result.x.shape == (n_runs, K_cv, 2)
    assert study.nis is not None and study.nis.shape == (n_runs, K_cv)
    kf = [KalmanFilter(F=F_CV, H=H_CV, Q=Q_CV, R=R_CV, x0=X0_CV, P0=P0_CV).run(z[m]) for m in range(n_runs)]
    kf_rmse = np.sqrt(np.mean([np.sum((r.x - truth[m]) ** 2, axis=-1) for m, r in enumerate(kf)], axis=0))
    # the PF's accuracy is the Kalman filter's (the optimum here), within Monte Carlo error
    np.testing.assert_allclose(study.rmse[5:], kf_rmse[5:], rtol=0.1)
    # and it is consistent: its time-averaged mean NEES is near n = 2 (the chi-square mean)
    assert 1.5 < float(np.mean(study.mean_nees)) < 2.6
    assert 0.7 < float(np.nanmean(study.mean_nis)) < 1.4


@pytest.mark.parametrize("name", PARTICLE_CASES)
def test_moments_are_read_only_and_follow_the_particles(name):
    """One rule for the state a filter shows (issue 27): a particle filter's x and P are the moments of its
    particles, read-only (a write raises, so x and the particles never part ways); a new state is given through
    the particles (or the weights), and x follows them."""
    z, u = _inputs(name, True)
    filt = _make(name, True)
    filt.predict(None if u is None else u[:, 0])
    filt.update(z[:, 0])
    for attribute in ("x", "P", "x_prior", "P_prior", "particles", "weights"):
        with pytest.raises(ValueError, match="read-only"):
            getattr(filt, attribute)[...] *= 1.0
    for attribute in ("x", "P"):
        with pytest.raises(AttributeError, match="particles"):
            setattr(filt, attribute, getattr(filt, attribute))
    moved = filt.particles + 1.0
    filt.particles = moved
    mean = np.einsum("mn,mnk->mk", filt.weights, moved)
    np.testing.assert_allclose(filt.x, mean, rtol=1e-12, atol=1e-9)


@pytest.mark.parametrize("batched", [False, True], ids=["single", "batched"])
@pytest.mark.parametrize("name", [c.name for c in CASES])
def test_configuration_takes_effect_or_is_refused(name, batched):
    """The rule of the Kalman family (tests/test_filter_contract.py) for the particle filters: resampler,
    ess_threshold and roughening take effect when assigned (the run equals that of a filter built with them); the
    models, generators and paper C's settings refuse assignment; y, S and the extra outputs are read-only."""
    from test_filter_contract import check_configuration_rule
    z, u = _inputs(name, batched)
    check_configuration_rule(lambda b: _make(name, b), batched, lambda f: f.run(z, u))
