"""The bootstrap particle filter on model pairs: agreement with the Kalman filter, the protocol, paper C's model,
the Gaussian likelihood with missing components, models with their own sampler and likelihood, bad input."""

import numpy as np
import pytest

from uwtutor.filters import (BootstrapParticleFilter, Filter, FilterResult, KalmanFilter, LinearGaussianModel,
                             ParticleDegeneracyError, run_filter)
from uwtutor.models import (DepthSensors, DepthSpeedPitch, DepthSpeedPitchModel, LinearMeasurement, LinearMotion,
                            MeasurementModel, ModelPair)
from uwtutor.resampling import multinomial_resample, residual_resample, stratified_resample


def constant_velocity_problem(K=40, seed=0):
    """A 2-state constant-velocity target observed in position: KF arguments, model pair and measurements."""
    dt, q, r = 1.0, 0.05, 4.0
    F = np.array([[1.0, dt], [0.0, 1.0]])
    Q = q * np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
    H = np.array([[1.0, 0.0]])
    R = np.array([[r]])
    rng = np.random.default_rng(seed)
    x = np.array([0.0, 1.0])
    zs = []
    for _ in range(K):
        x = F @ x + rng.multivariate_normal(np.zeros(2), Q)
        zs.append(H @ x + rng.normal(0.0, np.sqrt(r), 1))
    x0, P0 = np.array([0.0, 1.0]), np.diag([4.0, 0.25])
    return dict(F=F, H=H, Q=Q, R=R), (LinearMotion(F, Q), LinearMeasurement(H, R)), x0, P0, np.array(zs)


def test_mean_approaches_the_kalman_filter_as_n_grows():
    mats, pair, x0, P0, zs = constant_velocity_problem()
    kf = KalmanFilter(x0=x0, P0=P0, **mats).run(zs)
    sd = np.sqrt(np.diagonal(kf.P, axis1=-2, axis2=-1))
    errors = {}
    for N in (100, 1000, 10000):
        per_seed = []
        for seed in range(3):
            res = BootstrapParticleFilter.from_gaussian(*pair, x0, P0, N, np.random.default_rng(seed)).run(zs)
            per_seed.append(np.sqrt(np.mean(((res.x - kf.x) / sd) ** 2)))   # RMS error in KF std units
        errors[N] = np.mean(per_seed)
    # Monte Carlo error falls like 1/sqrt(N): a factor of about 3 per decade
    assert errors[1000] < 0.6 * errors[100]
    assert errors[10000] < 0.6 * errors[1000]
    assert errors[10000] < 0.05
    res = BootstrapParticleFilter.from_gaussian(*pair, x0, P0, 20000, np.random.default_rng(9)).run(zs)
    np.testing.assert_allclose(res.P[-10:], kf.P[-10:], rtol=0.1)            # covariances agree too


def test_follows_the_protocol():
    mats, pair, x0, P0, zs = constant_velocity_problem(K=15)
    pf = BootstrapParticleFilter.from_gaussian(*pair, x0, P0, 500, np.random.default_rng(1))
    assert isinstance(pf, Filter)
    res = pf.run(zs)
    assert isinstance(res, FilterResult)
    assert res.x.shape == (15, 2) and res.P.shape == (15, 2, 2)
    assert res.innovations.shape == (15, 1) and res.innovation_cov.shape == (15, 1, 1)
    assert res.extras["ess"].shape == (15,) and res.extras["resampled"].dtype == bool
    assert ((res.extras["ess"] >= 1.0) & (res.extras["ess"] <= 500.0 + 1e-9)).all()
    assert res.extras["resampled"].all()                                       # default: every step
    np.testing.assert_allclose(pf.weights, 1.0 / 500)
    assert pf.particles.shape == (500, 2) and pf.k == 14
    # x and P are the weighted mean and covariance of the particles
    pf.predict()
    np.testing.assert_allclose(pf.x, np.average(pf.particles, axis=0, weights=pf.weights))
    np.testing.assert_allclose(pf.P, np.cov(pf.particles.T, aweights=pf.weights, ddof=0))


def test_same_seed_same_result_and_the_model_pair_form():
    mats, pair, x0, P0, zs = constant_velocity_problem(K=10)
    runs = [BootstrapParticleFilter.from_gaussian(*pair, x0, P0, 300, np.random.default_rng(5)).run(zs)
            for _ in range(2)]
    np.testing.assert_array_equal(runs[0].x, runs[1].x)
    # one ModelPair in place of the two models (chapter 6's LinearGaussianModel) is the same filter, draw for draw,
    # its other arguments given by position or by name
    for model in (ModelPair(*pair), LinearGaussianModel(**mats)):
        for make in (lambda: BootstrapParticleFilter.from_gaussian(model, x0, P0, 300, np.random.default_rng(5)),
                     lambda: BootstrapParticleFilter.from_gaussian(model, x0, P0, n_particles=300,
                                                                   rng=np.random.default_rng(5)),
                     lambda: BootstrapParticleFilter.from_gaussian(model, x0=x0, P0=P0, n_particles=300,
                                                                   rng=np.random.default_rng(5))):
            np.testing.assert_array_equal(make().run(zs).x, runs[0].x)
    start = np.random.default_rng(7).normal(size=(50, 2))
    a = BootstrapParticleFilter(ModelPair(*pair), start, np.random.default_rng(1)).run(zs)
    b = BootstrapParticleFilter(ModelPair(*pair), start, rng=np.random.default_rng(1)).run(zs)
    c = BootstrapParticleFilter(*pair, start, np.random.default_rng(1)).run(zs)
    np.testing.assert_array_equal(a.x, c.x)
    np.testing.assert_array_equal(b.x, c.x)


def test_ess_threshold_controls_resampling():
    mats, pair, x0, P0, zs = constant_velocity_problem(K=30)
    adaptive = BootstrapParticleFilter.from_gaussian(*pair, x0, P0, 1000, np.random.default_rng(2),
                                                     ess_threshold=0.5).run(zs)
    flags, ess = adaptive.extras["resampled"], adaptive.extras["ess"]
    assert 0 < flags.sum() < 30
    np.testing.assert_array_equal(flags, ess < 500.0)
    never = BootstrapParticleFilter.from_gaussian(*pair, x0, P0, 1000, np.random.default_rng(2),
                                                  ess_threshold=0.0).run(zs)
    assert not never.extras["resampled"].any()
    assert never.extras["ess"][-1] < 0.5 * never.extras["ess"][0]             # sequential IS degenerates


@pytest.mark.parametrize("resampler", [multinomial_resample, stratified_resample, residual_resample])
def test_pluggable_resampler(resampler):
    mats, pair, x0, P0, zs = constant_velocity_problem(K=20)
    kf = KalmanFilter(x0=x0, P0=P0, **mats).run(zs)
    res = BootstrapParticleFilter.from_gaussian(*pair, x0, P0, 4000, np.random.default_rng(3),
                                                resampler=resampler).run(zs)
    assert np.max(np.abs(res.x[:, 0] - kf.x[:, 0]) / np.sqrt(kf.P[:, 0, 0])) < 0.25


def test_missing_measurement_keeps_the_weights():
    mats, pair, x0, P0, _ = constant_velocity_problem()
    pf = BootstrapParticleFilter.from_gaussian(*pair, x0, P0, 200, np.random.default_rng(0), ess_threshold=0.0)
    pf.predict()
    pf.update([1.0])
    w, x = pf.weights.copy(), pf.x.copy()
    pf.update([np.nan])
    np.testing.assert_array_equal(pf.weights, w)
    np.testing.assert_array_equal(pf.x, x)
    assert np.isnan(pf.y).all() and np.isnan(pf.S).all() and not pf.resampled


def test_partly_missing_measurement_uses_the_other_sensors():
    rng = np.random.default_rng(4)
    pf = BootstrapParticleFilter.from_gaussian(DepthSpeedPitch(), DepthSensors(), [10.0, 1.0, 0.0],
                                               np.diag([1.0, 0.01, 0.001]), 2000, rng)
    pf.predict()
    pf.update([12.0, np.nan, np.nan])                                          # depth only
    assert np.isnan(pf.y[1:]).all() and np.isfinite(pf.y[0])
    assert np.isfinite(pf.S[0, 0]) and np.isnan(pf.S[1:, :]).all() and np.isnan(pf.S[:, 1:]).all()
    assert 10.5 < pf.x[0] < 12.1                                               # pulled towards the 12 m reading


def test_depth_speed_pitch_model_equations():
    motion = DepthSpeedPitch(T=0.5, process_std=(0.1, 0.2, 0.05))
    particles = np.array([[10.0, 1.5, 0.2], [20.0, 2.0, -0.1]])
    out = motion.sample(particles[None], None, 0, [np.random.default_rng(0)])[0]
    uz, uv, uphi = np.random.default_rng(0).standard_normal((3, 2)) * np.array([[0.1], [0.2], [0.05]])
    v = particles[:, 1] + uv
    phi = particles[:, 2] + uphi
    np.testing.assert_allclose(out[:, 1], v)
    np.testing.assert_allclose(out[:, 2], phi)
    np.testing.assert_allclose(out[:, 0], particles[:, 0] + v * np.sin(phi) * 0.5 + uz)
    assert DepthSensors().h(particles, 0) is particles
    with pytest.raises(ValueError, match="takes no control input"):
        motion.sample(particles[None], [1.0], 0, [np.random.default_rng(0)])


def test_particle_filter_tracks_paper_c_model_better_than_the_sensors():
    model = DepthSpeedPitchModel()
    rng = np.random.default_rng(11)
    truth, meas = model.simulate([20.0, 1.5, -0.05], 400, rng)
    assert truth.shape == meas.shape == (400, 3)
    res = BootstrapParticleFilter.from_gaussian(model.motion, model.measurement, meas[0], model.R, 1000,
                                                rng).run(meas)
    rmse = np.sqrt(np.mean((res.x[100:] - truth[100:]) ** 2, axis=0))
    sensor_sd = np.sqrt(np.diag(model.R))
    assert (rmse < 0.7 * sensor_sd).all()


def test_the_pairs_R_can_be_assigned():
    model = DepthSpeedPitchModel()
    model.R = np.diag([0.5, 0.01, 0.001])
    np.testing.assert_array_equal(model.R, np.diag([0.5, 0.01, 0.001]))
    np.testing.assert_array_equal(model.measurement.R(None, 0), np.diag([0.5, 0.01, 0.001]))
    with pytest.raises(ValueError, match="R must be positive definite"):
        model.R = np.diag([0.5, 0.0, 0.001])


def test_degenerate_likelihood_raises():
    class Hopeless(LinearMeasurement):
        def log_likelihood(self, x, z, k):
            return np.full(x.shape[:-1], -np.inf)                 # (M, N): every particle of every run

    pf = BootstrapParticleFilter(LinearMotion([[1.0]], [[1.0]]), Hopeless([[1.0]], 1.0), np.zeros((10, 1)),
                                 np.random.default_rng(0))
    with pytest.raises(ParticleDegeneracyError, match="lost the track"):
        pf.update([0.0])


def test_a_model_with_its_own_sampler_and_likelihood():
    """A model's own ``sample`` and ``log_likelihood`` (here a drift and a heavy-tailed likelihood) are what the
    filter uses: it tracks through Cauchy measurement noise better than the measurements."""
    class Cauchy(LinearMeasurement):
        def log_likelihood(self, x, z, k):
            y = z[:, None, :] - self.h(x, k)
            return np.where(np.isnan(y), 0.0, -np.log1p(y * y)).sum(axis=-1)       # NaN components skipped

    class Drift(LinearMotion):
        calls = 0

        def sample(self, x, u, k, rng):
            Drift.calls += 1
            return x + 1.0 + np.stack([r.normal(0.0, 0.1, x.shape[1:]) for r in rng])

    truth = np.arange(1.0, 41.0)
    z = truth + np.random.default_rng(0).standard_cauchy(40) * 0.5
    res = BootstrapParticleFilter.from_gaussian(Drift([[1.0]], [[0.0]]), Cauchy([[1.0]], 1.0), [0.0], [[1.0]],
                                                2000, np.random.default_rng(1)).run(z)
    assert Drift.calls == 40
    assert np.median(np.abs(res.x[10:, 0] - truth[10:])) < 0.5 * np.median(np.abs(z[10:] - truth[10:]))


def test_bad_input():
    motion, sensors = DepthSpeedPitch(), DepthSensors()
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match=r"particles must have shape \(N, 3\)"):
        BootstrapParticleFilter(motion, sensors, np.zeros((10, 2)), rng)
    with pytest.raises(ValueError, match="particles must be finite"):
        BootstrapParticleFilter(motion, sensors, np.full((10, 3), np.nan), rng)
    with pytest.raises(TypeError, match="rng must be a numpy.random.Generator"):
        BootstrapParticleFilter(motion, sensors, np.zeros((10, 3)), None)
    with pytest.raises(ValueError, match="weights must be >= 0"):
        BootstrapParticleFilter(motion, sensors, np.zeros((3, 3)), rng, weights=[1.0, -1.0, 1.0])
    with pytest.raises(ValueError, match="weights must have a positive sum"):
        BootstrapParticleFilter(motion, sensors, np.zeros((3, 3)), rng, weights=[0.0, 0.0, 0.0])
    with pytest.raises(TypeError, match="resampler must be a function"):
        BootstrapParticleFilter(motion, sensors, np.zeros((3, 3)), rng, resampler="systematic")
    with pytest.raises(ValueError, match="ess_threshold must be >= 0"):
        BootstrapParticleFilter(motion, sensors, np.zeros((3, 3)), rng, ess_threshold=-0.5)
    with pytest.raises(TypeError, match="motion must be a uwtutor.models.base.MotionModel"):
        BootstrapParticleFilter(sensors, sensors, np.zeros((3, 3)), rng)
    with pytest.raises(TypeError, match="measurement must be a uwtutor.models.base.MeasurementModel"):
        BootstrapParticleFilter(motion, motion, np.zeros((3, 3)), rng)
    with pytest.raises(ValueError, match="reads a state of size 2 but the motion model's state has size 3"):
        BootstrapParticleFilter(motion, LinearMeasurement([[1.0, 0.0]], 1.0), np.zeros((3, 3)), rng)
    with pytest.raises(TypeError, match="too many positional arguments"):
        BootstrapParticleFilter(DepthSpeedPitchModel(), np.zeros((3, 3)), rng, rng)
    pf = BootstrapParticleFilter(motion, sensors, np.zeros((3, 3)), rng)
    with pytest.raises(ValueError, match=r"z must have shape \(3,\): 3 measurement value"):
        pf.update([1.0, 2.0])
    with pytest.raises(ValueError, match="z must be finite, or NaN"):
        pf.update([1.0, np.inf, 0.0])
    with pytest.raises(ValueError, match=r"u must be the input of one step, shape \(p,\)"):
        pf.predict(np.zeros((2, 2)))
    with pytest.raises(ValueError, match="process_std must be >= 0"):
        DepthSpeedPitch(process_std=(0.1, -0.1, 0.1))
    with pytest.raises(ValueError, match="R must be one 3x3"):
        DepthSpeedPitchModel(R=np.ones((5, 3, 3)) * np.eye(3))
    with pytest.raises(ValueError, match="Q must be positive semi-definite"):
        LinearGaussianModel(F=np.eye(2), H=[[1.0, 0.0]], Q=-np.eye(2), R=1.0)

    class Wrong(LinearMeasurement):               # a model whose h drops the particles axis
        def h(self, x, k):
            return x[:, 0, :] @ self._H.T

    f = BootstrapParticleFilter(LinearMotion([[1.0]], [[1.0]]), Wrong([[1.0]], 1.0), np.zeros((4, 1)), rng)
    with pytest.raises(ValueError, match=r"measurement model's h \(Wrong\) must return shape \(1, 4, 1\)"):
        f.update([0.0])


def test_run_helper_equals_the_generic_driver():
    model = DepthSpeedPitchModel()
    truth, meas = model.simulate([5.0, 1.0, 0.1], 60, np.random.default_rng(0))
    meas[10] = np.nan
    meas[20, 1] = np.nan
    a = BootstrapParticleFilter.from_gaussian(model, meas[0], model.R, 300, np.random.default_rng(1)).run(meas)
    b = run_filter(BootstrapParticleFilter.from_gaussian(model, meas[0], model.R, 300, np.random.default_rng(1)),
                   meas)
    for name in ("x", "P", "x_prior", "P_prior", "innovations", "innovation_cov"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    np.testing.assert_array_equal(a.extras["ess"], b.extras["ess"])
    np.testing.assert_array_equal(a.extras["resampled"], b.extras["resampled"])
    assert not a.extras["resampled"][10] and np.isnan(a.innovations[10]).all()
    with pytest.raises(ValueError, match=r"z must have shape \(K, 3\)"):
        BootstrapParticleFilter.from_gaussian(model, meas[0], model.R, 10, np.random.default_rng(1)).run(meas[:, :2])
    with pytest.raises(ValueError, match="u must give one input per step"):
        BootstrapParticleFilter.from_gaussian(model, meas[0], model.R, 10, np.random.default_rng(1)).run(
            meas, u=[[0.0]])


@pytest.mark.parametrize("R", [np.diag([0.5, 2.0, 0.1]), [[2.0, 0.3, 0.1], [0.3, 1.0, -0.2], [0.1, -0.2, 0.5]]])
def test_gaussian_log_likelihood(R):
    """The measurement model's likelihood (and the filter's fast path) is -(1/2) y^T R^-1 y, and the marginal of the
    components present when some are NaN."""
    sensors = DepthSensors(R)
    rng = np.random.default_rng(6)
    particles = rng.normal(size=(1, 50, 3))
    z = np.array([0.3, -0.2, 0.1])
    d = z - particles[0]
    expected = -0.5 * np.einsum("ij,ij->i", d, np.linalg.solve(np.asarray(R), d.T).T)
    np.testing.assert_allclose(sensors.log_likelihood(particles, z[None], 0)[0], expected, rtol=1e-12)
    z_part = np.array([0.3, np.nan, 0.1])                     # the marginal of the present sensors
    keep = [0, 2]
    Rk = np.asarray(R)[np.ix_(keep, keep)]
    dk = d[:, keep]
    expected_part = -0.5 * np.einsum("ij,ij->i", dk, np.linalg.solve(Rk, dk.T).T)
    np.testing.assert_allclose(sensors.log_likelihood(particles, z_part[None], 0)[0], expected_part, rtol=1e-12)
    # the filter weighs with the same numbers (its fast path whitens once)
    for zz, ll in ((z, expected), (z_part, expected_part)):
        pf = BootstrapParticleFilter(DepthSpeedPitch(), sensors, particles[0], rng, ess_threshold=0.0)
        pf.update(zz)
        w = np.exp(ll - ll.max())
        np.testing.assert_allclose(pf.weights, w / w.sum(), rtol=1e-10)
    # a pair's one-run likelihood is its measurement model's
    pair = DepthSpeedPitchModel(R=R)
    np.testing.assert_allclose(pair.log_likelihood(particles[0], z_part), expected_part, rtol=1e-12)
    assert isinstance(pair.measurement, MeasurementModel) and isinstance(pair, ModelPair)


def test_the_step_index_and_the_input_reach_both_models():
    """predict passes k = 0, 1, ... and u to the motion model's sample; update passes the same k to h, R and the
    likelihood (a beacon that moves, a noise per step read row k)."""
    seen = []

    class Motion(LinearMotion):
        def sample(self, x, u, k, rng):
            seen.append(("sample", k, None if u is None else np.asarray(u).tolist()))
            return super().sample(x, u, k, rng)

    class Measurement(LinearMeasurement):
        def h(self, x, k):
            seen.append(("h", k))
            return super().h(x, k)

        def R(self, x, k):
            seen.append(("R", k))
            return super().R(x, k)

    pf = BootstrapParticleFilter.from_gaussian(Motion([[1.0]], [[0.1]], B=[[1.0]]),
                                               Measurement([[1.0]], [1.0, 2.0, 3.0]), [0.0], [[1.0]], 100,
                                               np.random.default_rng(0), n_runs=2)
    pf.run(np.zeros((2, 3)), u=np.array([[[1.0], [2.0], [3.0]], [[4.0], [5.0], [6.0]]]))
    assert [e for e in seen if e[0] == "sample"] == [("sample", k, [[[1.0 + k]], [[4.0 + k]]]) for k in range(3)]
    assert [e[1] for e in seen if e[0] in ("h", "R")] == [0, 0, 1, 1, 2, 2]
    assert pf.k == 2
    with pytest.raises(IndexError, match="R has 3 per-step values; step 3 is beyond them"):
        pf.predict([0.0])
        pf.update([0.0, 0.0])
