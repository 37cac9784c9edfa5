"""The filter protocol held by paper C's filters: DepthEKF and the three particle filters (single and batched).

For every filter: it is a ``Filter``; ``run`` == ``run_filter`` == a hand loop for every field and extra (same
seed); a NaN measurement means predict only; run ``m`` of a batch equals the single run on the same generator;
``P`` is symmetric positive semi-definite; bad input names the argument; on a linear-Gaussian model the particle
filters approach the Kalman filter, and the DepthEKF equals the generic EKF engine on the same model.
"""

from __future__ import annotations

from dataclasses import fields

import numpy as np
import pytest

from uwtutor.filters import (BootstrapParticleFilter, DepthEKF, DepthSpeedPitchModel, ExtendedKalmanFilter, Filter,
                             GreyParticleFilter, KalmanFilter, LinearGaussianModel, MultipleModelParticleFilter,
                             PitchManeuverModel, run_filter)
from uwtutor.models import DepthSpeedPitch, DirectMeasurement
from uwtutor.montecarlo import run_monte_carlo

Q_STD = np.array([0.05, 0.01, np.radians(0.3)])
R = np.diag([0.2, 0.05, np.radians(0.5)]) ** 2
K = 80                              # steps: more than the GPF's windows (30 and 50), so every path runs
M = 3                               # runs of a batch
N = 200                             # particles
TRUE_X0 = np.array([10.0, 1.5, 0.1])


def _measurements(n_runs: int = M, seed: int = 11) -> np.ndarray:
    """(n_runs, K, 3) readings of a diving vehicle, with missing readings: one whole step and single sensors."""
    model = DepthSpeedPitchModel(process_std=Q_STD, R=R)
    rng = np.random.default_rng(seed)
    Z = np.stack([model.simulate(TRUE_X0, K, rng)[1] for _ in range(n_runs)])
    Z[:, 20] = np.nan                        # no measurement at all: predict only
    Z[:, 40, 1] = np.nan                     # the speed sensor missing
    Z[0, 60, 2] = np.nan                     # the pitch sensor of run 0 only
    return Z


Z = _measurements()


def _rngs(seed: int, n: int) -> list[np.random.Generator]:
    return list(np.random.default_rng(seed).spawn(n))


def _pf(x0, rng, n=N):
    return BootstrapParticleFilter.from_gaussian(DepthSpeedPitchModel(process_std=Q_STD, R=R), x0, R, n, rng)


def _pf_adaptive(x0, rng, n=N):
    return BootstrapParticleFilter.from_gaussian(DepthSpeedPitchModel(process_std=Q_STD, R=R), x0, R, n, rng,
                                                 ess_threshold=0.5)


def _mmpf(x0, rng, n=N):
    modes = [PitchManeuverModel(pitch_target=p, time_constant=1.0, process_std=Q_STD, R=R) for p in (0.0, 0.3, -0.3)]
    Pi = np.full((3, 3), 0.01) + np.eye(3) * 0.97
    return MultipleModelParticleFilter.from_gaussian(modes, x0, R, n, rng, transition=Pi)


def _gpf(x0, rng, n=N):
    return GreyParticleFilter.from_gaussian(DepthSpeedPitchModel(process_std=Q_STD, R=R), x0, R, n, rng,
                                            grey_offset=[0.0, 0.0, 1.0])


def _depth_ekf(x0, rng):                     # deterministic: rng unused
    return DepthEKF(x0=x0, P0=R, Q=np.diag(Q_STD**2), R=R)


FACTORIES = {"PF": _pf, "PF (ESS < N/2)": _pf_adaptive, "MMPF": _mmpf, "GPF": _gpf, "DepthEKF": _depth_ekf}


def _make(name: str, batched: bool, seed: int = 5):
    """The filter ``name`` with M runs (one spawned Generator each) or a single run (one Generator)."""
    if batched:
        return FACTORIES[name](Z[:, 0], _rngs(seed, M))
    return FACTORIES[name](Z[0, 0], np.random.default_rng(seed))


def _z(batched: bool) -> np.ndarray:
    return Z if batched else Z[0]


def _hand_loop(filt, z, batched):
    """The protocol by hand: predict, update, read the attributes."""
    names = ("x", "P", "x_prior", "P_prior", "y", "S") + tuple(filt.extra_outputs)
    rec = {name: [] for name in names}
    for k in range(z.shape[1] if batched else z.shape[0]):
        filt.predict()
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


PARAMS = [(name, batched) for name in FACTORIES for batched in (False, True)]
IDS = [f"{name}-{'batched' if b else 'single'}" for name, b in PARAMS]


@pytest.mark.parametrize("name, batched", PARAMS, ids=IDS)
def test_is_a_filter_with_the_protocols_shapes(name, batched):
    f = _make(name, batched)
    assert isinstance(f, Filter)
    lead = (M,) if batched else ()
    assert np.shape(f.x) == lead + (3,) and np.shape(f.P) == lead + (3, 3)
    assert np.shape(f.x_prior) == lead + (3,) and np.shape(f.P_prior) == lead + (3, 3)
    assert np.shape(f.y) == lead + (3,) and np.shape(f.S) == lead + (3, 3)
    assert isinstance(f.extra_outputs, tuple)


@pytest.mark.parametrize("name, batched", PARAMS, ids=IDS)
def test_run_equals_run_filter_equals_a_hand_loop(name, batched):
    z = _z(batched)
    res = _make(name, batched).run(z, times=0.05 * np.arange(1, K + 1))
    res_loop = run_filter(_make(name, batched), z, None, 0.05 * np.arange(1, K + 1))
    _assert_same_result(res, res_loop)
    hand = _hand_loop(_make(name, batched), z, batched)
    for field, key in (("x", "x"), ("P", "P"), ("x_prior", "x_prior"), ("P_prior", "P_prior"),
                       ("innovations", "y"), ("innovation_cov", "S")):
        np.testing.assert_array_equal(getattr(res, field), hand[key], err_msg=field)
    assert set(res.extras) == set(_make(name, batched).extra_outputs)
    for key in res.extras:
        np.testing.assert_array_equal(res.extras[key], hand[key], err_msg=key)
    np.testing.assert_array_equal(res.times, 0.05 * np.arange(1, K + 1))


@pytest.mark.parametrize("name, batched", PARAMS, ids=IDS)
def test_nan_measurement_is_predict_only(name, batched):
    z = _z(batched)
    f = _make(name, batched)
    for k in range(20):
        f.predict()
        f.update(z[:, k] if batched else z[k])
    weights = np.array(f.weights, copy=True) if hasattr(f, "weights") else None
    f.predict()
    x_prior, P_prior = np.array(f.x, copy=True), np.array(f.P, copy=True)
    f.update(z[:, 20] if batched else z[20])             # all NaN
    np.testing.assert_array_equal(f.x, x_prior)
    np.testing.assert_array_equal(f.P, P_prior)
    np.testing.assert_array_equal(f.x_prior, x_prior)
    assert np.isnan(f.y).all() and np.isnan(f.S).all()
    if weights is not None:
        assert not np.any(f.resampled)
        if name != "MMPF":                               # the MMPF's predict regroups its particles by mode
            np.testing.assert_array_equal(f.weights, weights)
    # a partly missing measurement: the innovation is NaN exactly for the missing sensor
    f.predict()
    z40 = z[:, 40] if batched else z[40]
    f.update(z40)
    np.testing.assert_array_equal(np.isnan(f.y), np.isnan(z40))


@pytest.mark.parametrize("name", list(FACTORIES))
def test_batched_run_m_equals_the_single_run_on_the_same_generator(name):
    batch = _make(name, True, seed=9).run(Z)
    for m in range(M):
        one = FACTORIES[name](Z[m, 0], _rngs(9, M)[m]).run(Z[m])
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


@pytest.mark.parametrize("name", ["PF", "MMPF", "GPF"])
def test_one_generator_is_split_with_spawn(name):
    """A single Generator given to a batch of M > 1 runs is split into rng.spawn(M)."""
    a = FACTORIES[name](Z[:, 0], np.random.default_rng(4)).run(Z)
    b = FACTORIES[name](Z[:, 0], _rngs(4, M)).run(Z)
    _assert_same_result(a, b)
    one = FACTORIES[name](Z[1, 0], np.random.default_rng(4).spawn(M)[1]).run(Z[1])
    np.testing.assert_allclose(a.x[1], one.x, rtol=1e-9, atol=1e-12)
    # and the runs of a batch are not copies of each other
    c = FACTORIES[name](np.broadcast_to(Z[0, 0], (M, 3)), np.random.default_rng(4)).run(np.broadcast_to(Z[0], Z.shape))
    assert not np.array_equal(c.x[0], c.x[1])


@pytest.mark.parametrize("name, batched", PARAMS, ids=IDS)
def test_covariances_are_symmetric_positive_semidefinite(name, batched):
    res = _make(name, batched).run(_z(batched))
    for P in (res.P, res.P_prior):
        np.testing.assert_allclose(P, np.swapaxes(P, -1, -2), rtol=0, atol=1e-12 * np.abs(P).max())
        assert np.linalg.eigvalsh(P).min() >= -1e-12 * np.abs(P).max()
    S = res.innovation_cov
    ok = np.isfinite(S).all(axis=(-1, -2))
    assert np.linalg.eigvalsh(S[ok]).min() > 0


@pytest.mark.parametrize("name", list(FACTORIES))
def test_bad_input_names_the_argument(name):
    for batched in (False, True):
        f = _make(name, batched)
        with pytest.raises(ValueError, match="z must"):
            f.run(np.zeros((M, K, 2)) if batched else np.zeros((K, 2)))
        with pytest.raises(ValueError, match="z must"):
            f.update(np.zeros(5))
        with pytest.raises(ValueError, match="z must be finite"):
            f.update(np.full((M, 3) if batched else 3, np.inf))
        with pytest.raises(ValueError, match="times must"):
            f.run(_z(batched), times=np.arange(K + 1))
        with pytest.raises(ValueError, match="control input|u must|u was given"):
            f.run(_z(batched), u=np.zeros((K, 1)))
    with pytest.raises(ValueError, match="x0"):
        FACTORIES[name](np.array([1.0, np.nan, 0.0]), np.random.default_rng(0))
    if name != "DepthEKF":
        with pytest.raises(ValueError, match="rng must be a sequence of 3"):
            FACTORIES[name](Z[:, 0], _rngs(0, 2))
        with pytest.raises(TypeError, match="rng must be a numpy.random.Generator"):
            FACTORIES[name](Z[:, 0], 7)
        with pytest.raises(ValueError, match=r"particles must keep the 3 runs"):
            _make(name, True).particles = np.zeros((2, N, 3))


def test_depth_ekf_rs_run_equals_a_hand_loop_and_checks_rs():
    Rs = np.broadcast_to(R, Z.shape + (3,)) * np.linspace(0.5, 2.0, K)[None, :, None, None]
    res = _depth_ekf(Z[:, 0], None).run(Z, Rs=Rs)
    f = _depth_ekf(Z[:, 0], None)
    for k in range(K):
        f.predict()
        f.R = Rs[:, k]
        f.update(Z[:, k])
        np.testing.assert_array_equal(res.x[:, k], f.x)
        np.testing.assert_array_equal(res.P[:, k], f.P)
        np.testing.assert_array_equal(res.x_prior[:, k], f.x_prior)
        np.testing.assert_array_equal(res.P_prior[:, k], f.P_prior)
        np.testing.assert_array_equal(res.innovation_cov[:, k], f.S)
    bad = Rs.copy()
    bad[1, 7] = -np.eye(3)
    g = _depth_ekf(Z[:, 0], None)
    with pytest.raises(ValueError, match=r"Rs\[:, 7\]"):
        g.run(Z, Rs=bad)
    np.testing.assert_array_equal(g.x, Z[:, 0])               # checked before the first step
    with pytest.raises(ValueError, match="Rs must have shape"):
        g.run(Z, Rs=Rs[:, :-1])


def test_depth_ekf_equals_the_generic_ekf_engine_on_paper_cs_model():
    """G (P + Q) G^T of DepthEKF is the engine's F P F^T + W Q W^T with W = F = G (the one model of models.depth)."""
    z = np.nan_to_num(Z, nan=0.0) + np.where(np.isnan(Z), Z[:, :1], 0.0)   # complete readings for the engine
    ours = _depth_ekf(z[:, 0], None).run(z)
    motion = DepthSpeedPitch(T=0.05, process_std=Q_STD)
    engine = ExtendedKalmanFilter(motion, DirectMeasurement(3, [0, 1, 2], R), z[:, 0], R).run(z)
    for f in ("x", "P", "x_prior", "P_prior", "innovations", "innovation_cov"):
        np.testing.assert_allclose(getattr(ours, f), getattr(engine, f), rtol=1e-9, atol=1e-12, err_msg=f)


# --- on a linear-Gaussian model the particle filters approach the Kalman filter ------------------------------------

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
    model = LinearGaussianModel(F=F_CV, H=H, Q=Q_CV, R=Rm)
    gaps = {}
    for n_particles in (200, 5000):
        def make(rng, n_runs):
            if kind == "PF":
                return BootstrapParticleFilter.from_gaussian(model, X0_CV, P0_CV, n_particles, rng, n_runs=n_runs)
            if kind == "MMPF":                # two identical modes: the mixture is the same linear-Gaussian model
                return MultipleModelParticleFilter.from_gaussian([model, model], X0_CV, P0_CV, n_particles, rng,
                                                                 n_runs=n_runs, transition=[[0.9, 0.1], [0.2, 0.8]])
            return GreyParticleFilter.from_gaussian(model, X0_CV, P0_CV, n_particles, rng, n_runs=n_runs,
                                                    grey_fraction=0.0, adapt_noise=False, grey_std=[1.0, 1.0])
        res = make(np.random.default_rng(3), 4).run(np.broadcast_to(zs, (4,) + zs.shape))
        gaps[n_particles] = np.mean([_gap(res.x[m], kf) for m in range(4)])
    # Monte Carlo error of the mean shrinks like 1/sqrt(N): 25 times the particles, about 5 times closer
    assert gaps[5000] < 0.1
    assert gaps[5000] < gaps[200] / 2.5


def test_run_monte_carlo_scores_a_batched_particle_filter():
    """run_monte_carlo takes a batched PF as it takes a batched EKF: one call, M runs, NEES and NIS."""
    rng = np.random.default_rng(21)
    n_runs, K_cv = 40, 30
    model = LinearGaussianModel(F=F_CV, H=H_CV, Q=Q_CV, R=R_CV)
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
        return BootstrapParticleFilter.from_gaussian(model, X0_CV, P0_CV, 1000, np.random.default_rng(seed),
                                                     n_runs=z.shape[0]).run(z)

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


@pytest.mark.parametrize("name", ["PF", "PF (ESS < N/2)", "MMPF", "GPF"])
def test_run_in_blocks_of_runs_equals_run_filter_and_leaves_the_same_state(name):
    """``run`` takes a large batch block by block (blocks of >= 2 runs of about 10 000 particles): the same
    result, field for field, as run_filter's whole-batch steps, and the same filter afterwards."""
    M7, N7 = 7, 3000                       # blocks of 3 runs: [0, 3) and [3, 7) (never a block of one run)
    z = _measurements(n_runs=M7, seed=13)[:, :40]

    a, b = (FACTORIES[name](z[:, 0], _rngs(6, M7), N7) for _ in range(2))
    assert [(s.start, s.stop) for s in a._blocks()] == [(0, 3), (3, 7)]
    _assert_same_result(a.run(z), run_filter(b, z))
    for f in (a, b):                       # one more step from the state each left behind
        f.predict()
        f.update(z[:, 5])
    for attr in ("x", "P", "x_prior", "P_prior", "y", "S", "weights", "particles") + tuple(a.extra_outputs):
        np.testing.assert_array_equal(getattr(a, attr), getattr(b, attr), err_msg=attr)
