"""Chapter 6's filters: resampler unbiasedness, PF -> KF as N grows, the MMPF, the GPF, and paper C's EKF (the generic
engine on paper C's model pair) against filterpy."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from filterpy.kalman import ExtendedKalmanFilter

from uwtutor import grey, resampling, wavelet
from uwtutor import filters as uf
from uwtutor.filters import (BootstrapParticleFilter, DepthEKF, Filter, FilterResult, GreyParticleFilter, KalmanFilter,
                             MultipleModelParticleFilter, extended_kalman_filter, run_filter)
from uwtutor.models import (DepthSensors, DepthSpeedPitch, DepthSpeedPitchModel, LinearMeasurement, LinearMotion,
                            PitchManeuver, PitchManeuverModel)

SCHEMES = [resampling.multinomial_resample, resampling.stratified_resample, resampling.systematic_resample,
           resampling.residual_resample]
R_PAPER = np.diag([0.2**2, 0.05**2, np.radians(0.5) ** 2])
Q_STD = np.array([0.2, 0.01, np.radians(0.5)])


# --- resampling ----------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("resample", SCHEMES, ids=lambda f: f.__name__)
def test_resamplers_are_unbiased(resample):
    """E[copies of particle i] = N w_i, so the resampled mean of any function equals its weighted mean on average."""
    rng = np.random.default_rng(11)
    N = 50
    w = rng.gamma(0.3, size=N)                       # uneven weights, several near zero
    w /= w.sum()
    values = rng.normal(size=N)
    draws = 20000
    counts = np.zeros((draws, N))
    for d in range(draws):
        counts[d] = np.bincount(resample(w, rng), minlength=N)
    assert (counts.sum(axis=1) == N).all()
    mean = counts.mean(axis=0)
    # copy counts: each within 5 standard errors of N w_i (a binomial bound on the spread, so it holds for all)
    bound = 5 * np.sqrt(N * w * (1 - w) / draws) + 1e-12
    assert (np.abs(mean - N * w) <= bound).all()
    # a function of the particles: the resampled mean is unbiased for the weighted mean
    rmean = counts @ values / N
    se = rmean.std() / np.sqrt(draws)
    assert abs(rmean.mean() - w @ values) < 4 * se + 1e-12
    # particles of weight zero are never copied
    w0 = w.copy()
    w0[::7] = 0.0
    assert not np.isin(resample(w0 / w0.sum(), rng), np.arange(N)[::7]).any()


def test_multinomial_adds_the_most_variance():
    rng = np.random.default_rng(12)
    w = rng.gamma(0.5, size=200)
    w /= w.sum()
    var = {}
    for resample in SCHEMES:
        counts = np.array([np.bincount(resample(w, rng), minlength=w.size) for _ in range(3000)])
        var[resample.__name__] = counts.var(axis=0).mean()
    assert var["multinomial_resample"] == pytest.approx(np.mean(200 * w * (1 - w)), rel=0.1)
    for name in ("stratified_resample", "systematic_resample", "residual_resample"):
        assert var[name] < 0.5 * var["multinomial_resample"]


# --- particle filter -> Kalman filter ---------------------------------------------------------------------------------

def scalar_problem(K=30, seed=0):
    rng = np.random.default_rng(seed)
    x, zs = 0.0, []
    for _ in range(K):
        x += rng.normal(0.0, 1.0)
        zs.append(x + rng.normal(0.0, 2.0))
    return np.array(zs)


@pytest.mark.parametrize("kind", ["bootstrap", "mmpf with one mode", "gpf without grey or wavelet"])
def test_particle_filters_converge_to_the_kalman_filter_as_n_grows(kind):
    zs = scalar_problem()
    mats = dict(F=[[1.0]], H=[[1.0]], Q=[[1.0]], R=[[4.0]])
    kf = KalmanFilter(x0=[0.0], P0=[[10.0]], **mats).run(zs)
    motion, measurement = LinearMotion(mats["F"], mats["Q"]), LinearMeasurement(mats["H"], mats["R"])

    def make(N, seed):
        rng = np.random.default_rng(seed)
        if kind == "bootstrap":
            return BootstrapParticleFilter.from_gaussian(motion, measurement, [0.0], [[10.0]], N, rng)
        if kind == "mmpf with one mode":
            return MultipleModelParticleFilter.from_gaussian([motion], measurement, [0.0], [[10.0]], N, rng,
                                                             transition=[[1.0]])
        return GreyParticleFilter.from_gaussian(motion, measurement, [0.0], [[10.0]], N, rng, grey_fraction=0.0,
                                                adapt_noise=False, grey_std=[1.0])

    gaps = {}
    for N in (100, 1000, 10000):
        gaps[N] = np.mean([np.sqrt(np.mean((make(N, s).run(zs).x - kf.x) ** 2 / kf.P[:, 0])) for s in range(3)])
    assert gaps[1000] < 0.6 * gaps[100]
    assert gaps[10000] < 0.6 * gaps[1000]
    assert gaps[10000] < 0.05


def test_gpf_without_grey_and_wavelet_is_the_bootstrap_filter_bit_for_bit():
    model = DepthSpeedPitchModel(process_std=Q_STD, R=R_PAPER)
    truth, meas = model.simulate([10.0, 1.5, 0.05], 120, np.random.default_rng(0))
    a = BootstrapParticleFilter.from_gaussian(model, meas[0], R_PAPER, 300, np.random.default_rng(1)).run(meas)
    b = GreyParticleFilter.from_gaussian(model, meas[0], R_PAPER, 300, np.random.default_rng(1), grey_fraction=0.0,
                                         adapt_noise=False).run(meas)
    np.testing.assert_array_equal(a.x, b.x)
    np.testing.assert_array_equal(a.extras["ess"], b.extras["ess"])


# --- the MMPF ------------------------------------------------------------------------------------------------------

def test_mmpf_mode_switching_follows_the_transition_matrix():
    models = [DepthSpeedPitch(process_std=Q_STD) for _ in range(3)]
    cycle = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])        # 0 -> 1 -> 2 -> 0
    rng = np.random.default_rng(0)
    f = MultipleModelParticleFilter(models, DepthSensors(), np.zeros((30, 3)), rng, transition=cycle,
                                    modes=np.arange(30) % 3)
    before = np.bincount(f.modes, minlength=3)
    f.predict()
    np.testing.assert_array_equal(np.bincount(f.modes, minlength=3), np.roll(before, 1))
    # a random chain: the empirical transition frequencies match the matrix
    Pi = np.array([[0.8, 0.15, 0.05], [0.1, 0.7, 0.2], [0.3, 0.3, 0.4]])
    f = MultipleModelParticleFilter(models, DepthSensors(), np.zeros((30000, 3)), rng, transition=Pi,
                                    modes=np.zeros(30000, int))
    f.predict()
    np.testing.assert_allclose(np.bincount(f.modes, minlength=3) / 30000, Pi[0], atol=0.01)
    np.testing.assert_allclose(f.mode_probabilities.sum(), 1.0)


def test_mmpf_resampling_carries_the_modes_and_recognizes_a_dive():
    modes = [PitchManeuver(pitch_target=np.radians(p), time_constant=1.0, process_std=Q_STD)
             for p in (0.0, 20.0, -20.0)]
    Pi = np.full((3, 3), 0.0025) + np.eye(3) * (0.995 - 0.0025)
    truth, meas = PitchManeuverModel(pitch_target=np.radians(20.0), time_constant=1.0, process_std=Q_STD / 10,
                                     R=R_PAPER).simulate([10.0, 1.5, 0.0], 300, np.random.default_rng(2))
    f = MultipleModelParticleFilter.from_gaussian(modes, DepthSensors(R_PAPER), meas[0], R_PAPER, 1000,
                                                  np.random.default_rng(3), transition=Pi,
                                                  mode_probabilities=[1.0, 0.0, 0.0])
    assert (f.modes == 0).all()
    res = f.run(meas)
    mu = res.extras["mode_probabilities"]
    assert mu.shape == (300, 3)
    np.testing.assert_allclose(mu.sum(axis=1), 1.0)
    assert mu[-100:, 1].mean() > 0.8                                 # the dive mode wins
    assert res.extras["resampled"].all()
    # resampling copies each particle's mode with it
    drawn = {}

    def recording(w, rng):
        drawn["idx"] = resampling.systematic_resample(w, rng)
        return drawn["idx"]

    f.resampler = recording
    f.predict()
    before = f.modes.copy()
    f.update(meas[-1])
    np.testing.assert_array_equal(f.modes, before[drawn["idx"]])
    # and the posterior mode probabilities (recorded before resampling) agree with the resampled share of each mode
    np.testing.assert_allclose(np.bincount(f.modes, minlength=3) / 1000, f.mode_probabilities, atol=2e-3)


def test_mmpf_bad_input():
    m, sensors = DepthSpeedPitch(), DepthSensors()
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="row-stochastic"):
        MultipleModelParticleFilter([m, m], sensors, np.zeros((5, 3)), rng, transition=[[0.5, 0.4], [0.5, 0.5]])
    with pytest.raises(ValueError, match=r"transition must have shape \(2, 2\)"):
        MultipleModelParticleFilter([m, m], sensors, np.zeros((5, 3)), rng, transition=np.eye(3))
    with pytest.raises(ValueError, match="share the state size and the measurement noise"):
        MultipleModelParticleFilter([DepthSpeedPitchModel(), DepthSpeedPitchModel(R=np.eye(3))], np.zeros((5, 3)),
                                    rng, transition=np.eye(2))
    with pytest.raises(ValueError, match=r"motions\[1\] has 1 states"):
        MultipleModelParticleFilter([m, LinearMotion([[1.0]], [[1.0]])], sensors, np.zeros((5, 3)), rng,
                                    transition=np.eye(2))
    with pytest.raises(TypeError, match="non-empty list of motion models"):
        MultipleModelParticleFilter([], sensors, np.zeros((5, 3)), rng, transition=np.eye(1))
    with pytest.raises(TypeError, match=r"motions\[1\] must be a uwtutor.models.base.MotionModel"):
        MultipleModelParticleFilter([m, sensors], sensors, np.zeros((5, 3)), rng, transition=np.eye(2))
    with pytest.raises(ValueError, match=r"modes must be integers in 0..1 of shape \(5,\)"):
        MultipleModelParticleFilter([m, m], sensors, np.zeros((5, 3)), rng, transition=np.eye(2),
                                    modes=[0, 1, 2, 0, 1])
    with pytest.raises(ValueError, match="mode_probabilities must have a positive sum"):
        MultipleModelParticleFilter([m, m], sensors, np.zeros((5, 3)), rng, transition=np.eye(2),
                                    mode_probabilities=[0, 0])
    # chapter 6's form: a list of PitchManeuverModel pairs stands for the modes and their one measurement model
    pairs = [PitchManeuverModel(pitch_target=p) for p in (0.0, 0.3)]
    f = MultipleModelParticleFilter(pairs, np.zeros((5, 3)), rng, transition=np.eye(2))
    assert [type(x).__name__ for x in f.motions] == ["PitchManeuver", "PitchManeuver"]


# --- the grey particle filter ----------------------------------------------------------------------------------------

def gpf_setup(K=150, seed=0, N=400, **kw):
    model = DepthSpeedPitchModel(process_std=Q_STD, R=R_PAPER)
    truth, meas = model.simulate([10.0, 1.5, -0.05], K, np.random.default_rng(seed))
    f = GreyParticleFilter.from_gaussian(model, meas[0], R_PAPER, N, np.random.default_rng(seed + 1),
                                         grey_offset=[0.0, 0.0, 1.0], **kw)
    return model, truth, meas, f


def test_gpf_grey_forecast_and_noise_estimate_are_the_library_functions():
    model, truth, meas, f = gpf_setup()
    res = f.run(meas)
    assert isinstance(f, Filter) and isinstance(res, FilterResult)
    used = res.extras["grey_used"]
    assert not used[:30].any() and used[30:].all()                  # L = 30 readings needed first
    fc = res.extras["grey_forecast"]
    for k in (30, 77, 149):
        shifted = meas[k - 30:k] + [0.0, 0.0, 1.0]
        expected = grey.gm11_forecast(shifted.T)[:, 0] - [0.0, 0.0, 1.0]
        np.testing.assert_allclose(fc[k], expected, rtol=1e-12)
    sd = res.extras["noise_std"]
    np.testing.assert_allclose(sd[:49], np.tile(np.sqrt(np.diag(R_PAPER)), (49, 1)))   # nominal until 50 exist
    for k in (49, 100, 149):
        np.testing.assert_allclose(sd[k], np.maximum(wavelet.noise_sigma(meas[k - 49:k + 1].T),
                                                     0.01 * np.sqrt(np.diag(R_PAPER))), rtol=1e-12)
    # the likelihood used that noise level: S = weighted covariance of the particles + R_k
    np.testing.assert_allclose(np.diag(res.innovation_cov[-1]) - np.diag(res.P_prior[-1]), sd[-1] ** 2, rtol=1e-9)
    assert f.n_grey == 40
    assert np.sqrt(np.mean((res.x[60:] - truth[60:]) ** 2, axis=0)).tolist() < np.sqrt(np.diag(R_PAPER)).tolist()


def test_gpf_draws_the_grey_share_around_the_forecast():
    model, truth, meas, f = gpf_setup(K=40, N=1000, grey_std=[1e-6, 1e-6, 1e-6])
    for k in range(39):
        f.predict()
        f.update(meas[k])
    f.predict()
    assert f.grey_used
    close = np.all(np.abs(f.particles - f.grey_forecast) < 1e-4, axis=1)
    assert close.sum() == 100                                          # exactly N_grey particles sit on it
    np.testing.assert_allclose(f.weights, 1e-3)


def test_gpf_adapts_to_a_noise_change_and_leaves_the_users_model_alone():
    model = DepthSpeedPitchModel(process_std=Q_STD, R=R_PAPER)
    # a smooth truth (little process noise), so that the readings' noise is the sensors' alone
    smooth = DepthSpeedPitchModel(process_std=Q_STD / 100, R=R_PAPER)
    truth, meas = smooth.simulate([10.0, 1.5, 0.0], 600, np.random.default_rng(4))
    noisy = meas.copy()
    noisy[300:] = truth[300:] + 3 * (meas[300:] - truth[300:])           # three times noisier after step 300
    res = GreyParticleFilter.from_gaussian(model, noisy[0], R_PAPER, 500, np.random.default_rng(5),
                                           grey_offset=[0, 0, 1.0]).run(noisy)
    sd = res.extras["noise_std"]
    nominal = np.sqrt(np.diag(R_PAPER))
    np.testing.assert_allclose(np.median(sd[100:300], axis=0) / nominal, 1.0, atol=0.15)
    np.testing.assert_allclose(np.median(sd[400:], axis=0) / nominal, 3.0, atol=0.45)
    np.testing.assert_array_equal(model.R, R_PAPER)                     # the filter worked on a copy


def test_gpf_missing_readings():
    model, truth, meas, f = gpf_setup(K=120)
    meas = meas.copy()
    meas[80, 2] = np.nan
    res = f.run(meas)
    used = res.extras["grey_used"]
    assert not used[81:111].any() and used[111:].all()                  # the missing pitch is in the window
    sd = res.extras["noise_std"]
    np.testing.assert_array_equal(sd[80:119, 2], sd[79, 2])            # pitch estimate frozen while NaN in window
    assert not np.array_equal(sd[80:119, 0], np.full(39, sd[79, 0]))   # the other sensors keep estimating


def test_gpf_bad_input():
    model = DepthSpeedPitchModel()
    rng = np.random.default_rng(0)
    p = np.zeros((10, 3))
    with pytest.raises(ValueError, match=r"grey_fraction must lie in \[0, 1\)"):
        GreyParticleFilter(model, p, rng, grey_fraction=1.0)
    with pytest.raises(ValueError, match="grey_window must be >= 4"):
        GreyParticleFilter(model, p, rng, grey_window=3)
    with pytest.raises(ValueError, match="noise_window must be >= 12"):
        GreyParticleFilter(model, p, rng, noise_window=10)
    with pytest.raises(ValueError, match=r"grey_offset must have shape \(3\)"):
        GreyParticleFilter(model, p, rng, grey_offset=[1.0])
    with pytest.raises(ValueError, match="measures the state directly"):
        GreyParticleFilter(LinearMotion(np.eye(2), np.eye(2)), LinearMeasurement([[1.0, 0.0]], 1.0), np.zeros((5, 2)),
                           rng)
    with pytest.raises(ValueError, match="measures the state directly"):
        GreyParticleFilter(LinearMotion(np.eye(2), np.eye(2)), LinearMeasurement([[0.0, 1.0], [1.0, 0.0]], 1.0),
                           np.zeros((5, 2)), rng)
    with pytest.raises(ValueError, match="grey_std must be given for a motion model without a process_std"):
        GreyParticleFilter(LinearMotion([[1.0]], [[1.0]]), LinearMeasurement([[1.0]], [[1.0]]), np.zeros((5, 1)), rng)
    with pytest.raises(ValueError, match=r"starts from one R \(3, 3\)"):
        GreyParticleFilter(DepthSpeedPitch(), DepthSensors(np.tile(np.eye(3), (2, 4, 1, 1))), p, rng)
    with pytest.raises(ValueError, match="wavelet must be the name"):
        GreyParticleFilter(model, p, rng, wavelet="nope")


def test_run_records_subclass_extras_like_run_filter():
    model, truth, meas, f = gpf_setup(K=70)
    g = copy.deepcopy(f)
    a = f.run(meas)
    b = run_filter(g, meas)
    for key in ("noise_std", "grey_used", "grey_forecast"):
        np.testing.assert_array_equal(a.extras[key], b.extras[key])
    np.testing.assert_array_equal(a.x, b.x)


# --- paper C's EKF: the generic engine on paper C's pair -------------------------------------------------------------

class FilterpyDepthEKF(ExtendedKalmanFilter):
    """filterpy's EKF with paper C's nonlinear prediction: F = G, Q = G Q G^T at each step."""

    def __init__(self, T, Q):
        super().__init__(dim_x=3, dim_z=3)
        self.T, self.Qu = T, Q

    def predict_step(self):
        z, v, phi = self.x[:, 0]
        G = np.array([[1.0, self.T * np.sin(phi), self.T * v * np.cos(phi)], [0, 1, 0], [0, 0, 1]])
        self.F = G
        self.Q = G @ self.Qu @ G.T
        self.predict()

    def predict_x(self, u=0):
        z, v, phi = self.x[:, 0]
        self.x = np.array([[z + v * np.sin(phi) * self.T], [v], [phi]])


def _engine(x0, R=R_PAPER, sensors=None):
    return uf.ExtendedKalmanFilter(DepthSpeedPitch(process_std=Q_STD), sensors or DepthSensors(R), x0, R_PAPER)


def test_paper_c_ekf_equals_filterpy_step_by_step():
    model = DepthSpeedPitchModel(process_std=Q_STD, R=R_PAPER)
    truth, meas = model.simulate([10.0, 1.5, 0.3], 200, np.random.default_rng(0))
    Q = np.diag(Q_STD**2)
    ref = FilterpyDepthEKF(0.05, Q)
    ref.x = meas[0].reshape(3, 1).copy()
    ref.P = R_PAPER.copy()
    ref.R = R_PAPER.copy()
    for ours in (_engine(meas[0]), DepthEKF(x0=meas[0], P0=R_PAPER, Q=Q, R=R_PAPER)):     # the engine; its old name
        ref.x = meas[0].reshape(3, 1).copy()
        ref.P = R_PAPER.copy()
        for z in meas:
            ours.predict()
            ref.predict_step()
            np.testing.assert_allclose(ours.x, ref.x[:, 0], rtol=1e-10, atol=1e-12)
            np.testing.assert_allclose(ours.P, ref.P, rtol=1e-9, atol=1e-14)
            ours.update(z)
            ref.update(z.reshape(3, 1), HJacobian=lambda x: np.eye(3), Hx=lambda x: x)
            np.testing.assert_allclose(ours.x, ref.x[:, 0], rtol=1e-10, atol=1e-12)
            np.testing.assert_allclose(ours.P, ref.P, rtol=1e-8, atol=1e-14)
            np.testing.assert_allclose(ours.y, ref.y[:, 0], rtol=1e-9, atol=1e-12)


def test_paper_c_ekf_batched_runs_equal_single_runs_and_missing_readings():
    model = DepthSpeedPitchModel(process_std=Q_STD, R=R_PAPER)
    rng = np.random.default_rng(1)
    meas = np.stack([model.simulate([10.0, 1.5, 0.1], 80, rng)[1] for _ in range(4)])
    meas[1, 10] = np.nan                      # everything missing
    meas[2, 20, 1] = np.nan                   # the speed sensor missing
    meas[3, 20, [0, 2]] = np.nan              # depth and pitch missing, same step as run 2
    batched = _engine(meas[:, 0]).run(meas)
    assert batched.x.shape == (4, 80, 3) and batched.P.shape == (4, 80, 3, 3)
    for m in range(4):
        single = _engine(meas[m, 0]).run(meas[m])
        np.testing.assert_allclose(batched.x[m], single.x, rtol=1e-12)
        np.testing.assert_allclose(batched.innovations[m], single.innovations, rtol=1e-12)
    assert np.isnan(batched.innovations[1, 10]).all()
    np.testing.assert_array_equal(batched.x[1, 10], batched.x_prior[1, 10])          # predict only
    assert np.isnan(batched.innovations[2, 20, 1]) and np.isfinite(batched.innovations[2, 20, [0, 2]]).all()
    assert np.isnan(batched.innovation_cov[2, 20, 1]).all() and np.isfinite(batched.innovation_cov[2, 20, 0, 0])
    # a sensor missing: the update with the other two equals a KF update with H = rows of I
    ekf = _engine(meas[2, 0])
    for k in range(20):
        ekf.predict()
        ekf.update(meas[2, k])
    ekf.predict()
    xp, Pp = ekf.x.copy(), ekf.P.copy()
    H = np.eye(3)[[0, 2]]
    S = H @ Pp @ H.T + H @ R_PAPER @ H.T
    K = Pp @ H.T @ np.linalg.inv(S)
    ekf.update(meas[2, 20])
    np.testing.assert_allclose(ekf.x, xp + K @ (meas[2, 20, [0, 2]] - xp[[0, 2]]), rtol=1e-10)


def test_paper_c_ekf_with_an_R_per_step_and_per_run():
    """DepthSensors takes one R per step (K, 3, 3) or per run and step (M, K, 3, 3): the EKF with the wavelet
    estimates of the grey particle filter."""
    model = DepthSpeedPitchModel(process_std=Q_STD, R=R_PAPER)
    truth, meas = model.simulate([10.0, 1.5, 0.1], 50, np.random.default_rng(2))
    Rs = np.broadcast_to(R_PAPER * 4.0, (50, 3, 3))
    a = _engine(meas[0], sensors=DepthSensors(Rs)).run(meas)
    b = _engine(meas[0], sensors=DepthSensors(R_PAPER * 4.0)).run(meas)
    np.testing.assert_allclose(a.x, b.x, rtol=1e-12)
    batch = np.stack([meas, meas])
    per_run = np.stack([np.broadcast_to(R_PAPER, (50, 3, 3)), Rs])
    c = extended_kalman_filter(DepthSpeedPitch(process_std=Q_STD), DepthSensors(per_run), batch[:, 0], R_PAPER,
                               None, batch)
    np.testing.assert_allclose(c.x[1], b.x, rtol=1e-12)
    np.testing.assert_allclose(c.x[0], _engine(meas[0]).run(meas).x, rtol=1e-12)
    with pytest.raises(ValueError, match="the measurement model has 2"):
        extended_kalman_filter(DepthSpeedPitch(), DepthSensors(per_run), np.zeros((3, 3)), R_PAPER, None,
                               np.zeros((3, 50, 3)))
    with pytest.raises(IndexError, match="R has 50 per-step values; step 50 is beyond them"):
        DepthSensors(Rs).R(None, 50)


def test_paper_c_ekf_bad_input():
    Q = np.diag(Q_STD**2)
    with pytest.raises(ValueError, match=r"x0 must be \[depth, speed, pitch\]"):
        DepthEKF([1.0, 2.0], R_PAPER, Q, R_PAPER)
    with pytest.raises(ValueError, match="Q must be positive semi-definite"):     # DepthEKF's own name for it
        DepthEKF([1.0, 2.0, 0.0], R_PAPER, np.array([[0.04, 0.64, 0.36], [0.64, 1, 0], [0.36, 0, 0.25]]), R_PAPER)
    with pytest.raises(ValueError, match="R must be positive definite"):
        DepthEKF([1.0, 2.0, 0.0], R_PAPER, Q, np.diag([1.0, 0.0, 1.0]))
    with pytest.raises(ValueError, match="R must be one 3x3 covariance"):
        DepthEKF([1.0, 2.0, 0.0], R_PAPER, Q, np.tile(R_PAPER, (5, 1, 1)))
    ekf = _engine(np.array([1.0, 2.0, 0.0]))
    with pytest.raises(ValueError, match="takes no control input"):
        ekf.predict([1.0])
    with pytest.raises(ValueError, match=r"z must be one measurement per run, shape \(3,\)"):
        ekf.update([1.0, 2.0])
    with pytest.raises(ValueError, match="finite, or NaN"):
        ekf.update([1.0, np.inf, 0.0])
