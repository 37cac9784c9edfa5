"""Paper C's models (uwtutor.models.depth), the models' default sampler, and the batch-specific behaviour of the
particle filters."""

from __future__ import annotations

import numpy as np
import pytest

from uwtutor.filters import BootstrapParticleFilter, GreyParticleFilter, MultipleModelParticleFilter
from uwtutor.models import (DepthSensors, DepthSpeedPitch, DepthSpeedPitchModel, LinearMeasurement, LinearMotion,
                            PitchManeuver, PitchManeuverModel)
from uwtutor.models.depth import (DEFAULT_PROCESS_STD, depth_speed_pitch_jacobian, depth_speed_pitch_kinematics)
from uwtutor.models.noise import per_run_generators, psd_sqrt, standard_normal_per_run


def test_kinematics_and_jacobian():
    rng = np.random.default_rng(0)
    s = rng.normal([10.0, 1.5, 0.1], [1.0, 0.3, 0.2], (5, 3))
    g = depth_speed_pitch_kinematics(s, 0.5)
    np.testing.assert_allclose(g[:, 0], s[:, 0] + s[:, 1] * np.sin(s[:, 2]) * 0.5, rtol=1e-15)
    np.testing.assert_array_equal(g[:, 1:], s[:, 1:])
    # along another axis, and in place
    rows = s.T.copy()
    np.testing.assert_array_equal(depth_speed_pitch_kinematics(rows, 0.5, axis=0), g.T)
    out = depth_speed_pitch_kinematics(rows, 0.5, axis=0, out=rows)
    assert out is rows
    np.testing.assert_array_equal(rows, g.T)
    # the Jacobian against central differences
    G = depth_speed_pitch_jacobian(s, 0.5)
    h = 1e-6
    for j in range(3):
        e = np.zeros(3)
        e[j] = h
        num = (depth_speed_pitch_kinematics(s + e, 0.5) - depth_speed_pitch_kinematics(s - e, 0.5)) / (2 * h)
        np.testing.assert_allclose(G[:, :, j], num, atol=1e-8)


def test_motion_model_for_the_engine_and_the_particles():
    motion = DepthSpeedPitch(T=0.05, process_std=[0.1, 0.02, 0.01])
    x = np.array([[10.0, 1.5, 0.2], [20.0, 2.0, -0.1]])
    G = motion.F(x, None, 0)
    np.testing.assert_allclose(motion.Q(x, None, 0), G @ np.diag([0.1, 0.02, 0.01]) ** 2 @ np.swapaxes(G, 1, 2))
    np.testing.assert_array_equal(motion.f(x, None, 0), depth_speed_pitch_kinematics(x, 0.05))
    np.testing.assert_array_equal(DepthSpeedPitch().process_std, DEFAULT_PROCESS_STD)
    with pytest.raises(ValueError, match="no control input"):
        motion.f(x, [1.0], 0)
    # the sample is g(x + u) with u ~ N(0, diag(std^2)), drawn as (3, N) rows; states (M, n) or particles (M, N, n)
    p = np.random.default_rng(1).normal(size=(50, 3))
    u = np.random.default_rng(2).standard_normal((3, 50)).T * [0.1, 0.02, 0.01]
    drawn = motion.sample(p[None], None, 0, [np.random.default_rng(2)])[0]
    np.testing.assert_allclose(drawn, depth_speed_pitch_kinematics(p + u, 0.05), rtol=1e-15)
    np.testing.assert_array_equal(motion.sample(p[:1], None, 0, [np.random.default_rng(2)]),
                                  motion.sample(p[None, :1], None, 0, [np.random.default_rng(2)])[:, 0])
    # a correlated Q_u (process_cov) draws u = L eps
    cov = np.array([[0.01, 0.002, 0.0], [0.002, 0.0004, 0.0], [0.0, 0.0, 1e-4]])
    corr = DepthSpeedPitch(T=0.05, process_cov=cov)
    many = corr.sample(np.zeros((1, 200000, 3)), None, 0, [np.random.default_rng(3)])[0]
    np.testing.assert_allclose(np.cov(many[:, :2].T), cov[:2, :2], rtol=0.02, atol=3e-6)
    np.testing.assert_allclose(corr.Q(x, None, 0), G @ cov @ np.swapaxes(G, 1, 2))
    with pytest.raises(ValueError, match="process_std or process_cov, not both"):
        DepthSpeedPitch(process_std=[0.1, 0.1, 0.1], process_cov=cov)


def test_pitch_maneuver_model_is_paper_cs_with_the_pitch_pulled():
    m = PitchManeuver(pitch_target=0.3, time_constant=2.0, T=0.5, process_std=(0.1, 0.2, 0.05))
    particles = np.array([[10.0, 1.5, 0.1], [20.0, 2.0, -0.2]])
    out = m.sample(particles[None], None, 0, [np.random.default_rng(0)])[0]
    uz, uv, uphi = np.random.default_rng(0).standard_normal((3, 2)) * np.array([[0.1], [0.2], [0.05]])
    gain = 1 - np.exp(-0.5 / 2.0)
    phi_bar = particles[:, 2] + gain * (0.3 - particles[:, 2])
    v = particles[:, 1] + uv
    phi = phi_bar + uphi
    np.testing.assert_allclose(out[:, 2], phi)
    np.testing.assert_allclose(out[:, 1], v)
    np.testing.assert_allclose(out[:, 0], particles[:, 0] + v * np.sin(phi) * 0.5 + uz)
    np.testing.assert_array_equal(particles, [[10.0, 1.5, 0.1], [20.0, 2.0, -0.2]])     # input untouched
    # for the EKF: f, its Jacobian (central differences) and Q = G Q_u G^T at the pulled state
    h = 1e-6
    F = m.F(particles, None, 0)
    for j in range(3):
        e = np.zeros(3)
        e[j] = h
        num = (m.f(particles + e, None, 0) - m.f(particles - e, None, 0)) / (2 * h)
        np.testing.assert_allclose(F[:, :, j], num, atol=1e-8)
    pulled = particles.copy()
    pulled[:, 2] = phi_bar
    G = depth_speed_pitch_jacobian(pulled, 0.5)
    np.testing.assert_allclose(m.Q(particles, None, 0), G @ np.diag([0.1, 0.2, 0.05]) ** 2 @ np.swapaxes(G, 1, 2))
    with pytest.raises(ValueError, match="time_constant must be > 0"):
        PitchManeuver(time_constant=0.0)
    assert PitchManeuverModel(pitch_target=0.3).pitch_target == 0.3


def test_the_default_sampler_draws_f_plus_a_psd_root_of_q():
    """x_k = f(x, u) + L eps with L L^T = Q, also for a singular Q (a constant state), Q per run or per particle."""
    motion = LinearMotion(F=[[1.0, 1.0], [0.0, 1.0]], Q=[[0.0, 0.0], [0.0, 0.0]], B=[[1.0], [0.0]])
    x = np.random.default_rng(0).normal(size=(2, 5, 2))
    u = np.array([[[0.5]], [[-1.0]]])                                  # one input per run, (M, 1, p)
    out = motion.sample(x, u, 0, [np.random.default_rng(1), np.random.default_rng(2)])
    np.testing.assert_allclose(out, x @ motion._F.T + u @ motion._B.T)  # Q = 0: exactly f
    Q = np.array([[4.0, 2.0], [2.0, 1.0]])                             # rank 1: the noise lies on one line
    L = psd_sqrt(Q)
    np.testing.assert_allclose(L @ L.T, Q, atol=1e-12)
    w = LinearMotion(np.eye(2), Q).sample(np.zeros((1, 20000, 2)), None, 0, [np.random.default_rng(3)])[0]
    np.testing.assert_allclose(np.cov(w.T), Q, rtol=0.05, atol=0.02)
    np.testing.assert_allclose(w[:, 0], 2.0 * w[:, 1], atol=1e-9)

    class PerParticle(LinearMotion):                                    # Q grows with |x|
        def Q(self, x, u, k):
            return np.abs(x[..., 0])[..., None, None] * np.eye(2)

    xs = np.stack([np.full((20000, 2), 1.0), np.full((20000, 2), 9.0)])
    drawn = PerParticle(np.eye(2), np.eye(2)).sample(xs, None, 0, [np.random.default_rng(4), np.random.default_rng(5)])
    np.testing.assert_allclose(drawn.std(axis=1), [[1.0, 1.0], [3.0, 3.0]], rtol=0.03)


def test_a_measurement_noise_per_particle_keeps_its_log_determinant():
    """Where R depends on the state (a range with multiplicative noise), the likelihood keeps -1/2 log det R."""
    from uwtutor.models import MultiplicativeRange
    from uwtutor.models.noise import gaussian_log_likelihood

    model = MultiplicativeRange((0.0, 0.0), R=1.0, mu_gamma=1.0, sigma_gamma=0.1)
    x = np.array([[[30.0, 40.0], [60.0, 80.0]]])                        # ranges 50 and 100
    R = model.R(x, 0)
    assert R.shape == (1, 2, 1, 1)
    ll = model.log_likelihood(x, np.array([[70.0]]), 0)
    var = np.array([26.0, 101.0])
    np.testing.assert_allclose(ll[0], -0.5 * (70.0 - np.array([50.0, 100.0])) ** 2 / var - 0.5 * np.log(var))
    np.testing.assert_array_equal(gaussian_log_likelihood(np.zeros((2, 3, 1)), np.array([[np.nan], [1.0]]),
                                                          np.eye(1))[0], 0.0)


def test_per_run_generators():
    rngs = per_run_generators(np.random.default_rng(5), 3)
    ref = np.random.default_rng(5).spawn(3)
    assert [r.random() for r in rngs] == [r.random() for r in ref]
    one = np.random.default_rng(5)
    assert per_run_generators(one, 1)[0] is one
    with pytest.raises(ValueError, match="sequence of 2 Generators"):
        per_run_generators(one, 2, spawn=False)
    with pytest.raises(ValueError, match="sequence of 3"):
        per_run_generators([one, one], 3)
    with pytest.raises(TypeError, match="rng must be a numpy.random.Generator"):
        per_run_generators(5, 3)
    a = standard_normal_per_run([np.random.default_rng(1), np.random.default_rng(2)], (4,))
    np.testing.assert_array_equal(a[1], np.random.default_rng(2).standard_normal(4))


def test_batched_shapes_weights_and_particles():
    model = DepthSpeedPitchModel()
    pf = BootstrapParticleFilter.from_gaussian(model, [10.0, 1.5, 0.1], model.R, 50, np.random.default_rng(0),
                                               n_runs=4)
    assert pf.particles.shape == (4, 50, 3) and pf.weights.shape == (4, 50) and pf.n_runs == 4
    assert pf.x.shape == (4, 3) and pf.P.shape == (4, 3, 3) and len(pf.rngs) == 4 and pf.ess.shape == (4,)
    w = np.ones((4, 50))
    w[2, :25] = 0.0
    pf.weights = w
    np.testing.assert_allclose(pf.weights.sum(axis=1), 1.0)
    np.testing.assert_allclose(pf.x[2], pf.particles[2, 25:].mean(axis=0))
    with pytest.raises(ValueError, match=r"weights must have shape \(4, 50\)"):
        pf.weights = np.ones(50)
    with pytest.raises(ValueError, match="positive sum"):
        pf.weights = np.where(np.arange(4)[:, None] == 1, 0.0, 1.0) * np.ones((4, 50))
    pf.particles = np.zeros((4, 20, 3))
    assert pf.n_particles == 20 and pf.weights.shape == (4, 20)
    with pytest.raises(ValueError, match=r"particles must have shape \(M, N, 3\)"):
        pf.particles = np.zeros((4, 20, 2))
    # per-run x0 and P0
    x0 = np.array([[10.0, 1.5, 0.1], [50.0, 1.0, 0.0]])
    P0 = np.stack([model.R, model.R * 4])
    pf = BootstrapParticleFilter.from_gaussian(model, x0, P0, 4000, np.random.default_rng(1))
    np.testing.assert_allclose(pf.x, x0, atol=0.05)
    np.testing.assert_allclose(np.diagonal(pf.P, axis1=1, axis2=2), np.diagonal(P0, axis1=1, axis2=2), rtol=0.1)
    with pytest.raises(ValueError, match=r"x0 must have shape \(3,\) or \(5, 3\)"):
        BootstrapParticleFilter.from_gaussian(model, x0, model.R, 10, np.random.default_rng(1), n_runs=5)
    with pytest.raises(ValueError, match="P0 of shape"):
        BootstrapParticleFilter.from_gaussian(model, x0[0], P0, 10, np.random.default_rng(1))


def test_per_run_and_shared_inputs_of_a_linear_model():
    motion, measurement = LinearMotion(F=[[1.0]], Q=[[1e-12]], B=[[1.0]]), LinearMeasurement(H=[[1.0]], R=[[1.0]])
    pf = BootstrapParticleFilter.from_gaussian(motion, measurement, [0.0], [[1e-12]], 10, np.random.default_rng(0),
                                               n_runs=3)
    pf.predict(np.array([[1.0], [2.0], [3.0]]))              # one input per run
    np.testing.assert_allclose(pf.x[:, 0], [1.0, 2.0, 3.0], atol=1e-4)
    pf.predict(np.array([0.5]))                              # one input shared by every run
    np.testing.assert_allclose(pf.x[:, 0], [1.5, 2.5, 3.5], atol=1e-4)
    res = pf.run(np.full((3, 4), np.nan), u=np.ones((4, 1)))  # (K, p) shared, as run_filter allows; no updates
    assert res.x.shape == (3, 4, 1)
    np.testing.assert_allclose(res.x[:, :, 0], [[2.5, 3.5, 4.5, 5.5], [3.5, 4.5, 5.5, 6.5], [4.5, 5.5, 6.5, 7.5]],
                               atol=1e-4)
    res = pf.run(np.full((3, 2), np.nan), u=np.arange(6.0).reshape(3, 2, 1))   # (M, K, p): one sequence per run
    np.testing.assert_allclose(res.x[:, -1, 0], [5.5 + 1.0, 6.5 + 5.0, 7.5 + 9.0], atol=1e-4)
    with pytest.raises(ValueError, match="u must give one input per step"):
        pf.run(np.zeros((3, 4)), u=np.ones((5, 1)))
    with pytest.raises(ValueError, match="u must give one input per step .* for each of the 3 runs"):
        pf.run(np.zeros((3, 4)), u=np.ones((2, 4, 1)))
    with pytest.raises(ValueError, match="u must be finite"):
        pf.run(np.zeros((3, 4)), u=np.full((4, 1), np.nan))


def test_batched_mmpf_and_gpf_extras():
    R = DepthSpeedPitchModel().R
    modes = [PitchManeuver(pitch_target=p) for p in (0.0, 0.3)]
    mm = MultipleModelParticleFilter.from_gaussian(modes, DepthSensors(), [10.0, 1.5, 0.0], R, 100,
                                                   np.random.default_rng(0), n_runs=2,
                                                   transition=[[0.95, 0.05], [0.05, 0.95]],
                                                   mode_probabilities=[0.25, 0.75])
    assert mm.modes.shape == (2, 100) and mm.mode_probabilities.shape == (2, 2)
    np.testing.assert_allclose(mm.mode_probabilities.sum(axis=1), 1.0)
    assert 0.6 < mm.mode_probabilities[:, 1].mean() < 0.9
    with pytest.raises(ValueError, match=r"shape \(2, 100\)"):
        MultipleModelParticleFilter(modes, DepthSensors(), mm.particles, mm.rngs, transition=np.eye(2),
                                    modes=np.zeros(100, int))
    model = DepthSpeedPitchModel()
    truth, z = model.simulate([10.0, 1.5, 0.1], 120, np.random.default_rng(3))
    Z = np.stack([z, z + 0.01])
    Z[1, 70, 0] = np.nan                                     # run 1's depth window holds a gap for 50 steps
    g = GreyParticleFilter.from_gaussian(model, Z[:, 0], model.R, 200, np.random.default_rng(1),
                                         grey_offset=[0.0, 0.0, 1.0])
    res = g.run(Z)
    assert res.extras["grey_used"].shape == (2, 120) and res.extras["noise_std"].shape == (2, 120, 3)
    used = res.extras["grey_used"]
    assert not used[:, :30].any() and used[0, 30:].all()
    assert not used[1, 71:101].any() and used[1, 101:].all()   # no grey forecast while the gap is in the window
    sd = res.extras["noise_std"]
    np.testing.assert_array_equal(sd[1, 71:120, 0], sd[1, 70, 0])   # depth estimate frozen while the gap is in it
    assert (sd[1, 71:, 1] != sd[1, 70, 1]).any()                    # the other sensors go on
    np.testing.assert_array_equal(model.R, DepthSpeedPitchModel().R)   # the user's model is left alone


def _pair_cases():
    """(name, motion, measurement, x0 (M, n), P0, u, z, true positions (M, K, 2) or (M, K, 1)) for every kind of
    model pair of the library beyond paper C's and the odometry's (those have the contract test)."""
    from uwtutor.filters.cooperative import range_pairs
    from uwtutor.models import (BiasRateDeadReckoning, ConstantVelocity, CooperativeMotion, DeadReckoning,
                                MultiplicativeRange, PositionMeasurement, RangeToBeacon, SquaredRangePair)
    from uwtutor.models.robust import step_lengths
    from uwtutor.scenarios import paper_b

    rng = np.random.default_rng(0)
    K, M = 60, 3
    theta = np.linspace(0, np.pi, K + 1)
    track = 300 * np.column_stack([np.cos(theta), np.sin(theta)])
    u = np.diff(track, axis=0)[None] + rng.normal(0, 0.3, (M, K, 2))
    z = np.linalg.norm(track[1:], axis=1) + rng.normal(0, 2.0, (M, K))
    x0 = np.tile(track[0], (M, 1))
    truth = np.broadcast_to(track[1:], (M, K, 2))
    cases = [("DeadReckoning + MultiplicativeRange", DeadReckoning(np.eye(2) * 0.1),
              MultiplicativeRange((0, 0), 4.0, 1.0, 1e-3), x0, np.eye(2) * 100, u, z, truth),
             ("BiasRateDeadReckoning + RangeToBeacon(bias)",
              BiasRateDeadReckoning(np.diag([0.1, 0.1, 0.01, 1e-4]), 1.0),
              RangeToBeacon((0, 0), 4.0, n=4, bias_index=2), np.column_stack([x0, np.zeros((M, 2))]),
              np.diag([100, 100, 4.0, 0.01]), u, z + 3.0, truth)]
    cv = ConstantVelocity(1, 0.1, step_lengths(K, 1.0))                  # a singular Q: acceleration noise only
    xs = np.array([300.0, -5.0]) + rng.normal(0.0, [2.0, 5.0], (M, 2))
    states = np.empty((M, K, 2))                                          # a truth drawn from the model
    for m in range(M):
        x = xs[m][None, None]
        for k in range(K):
            x = cv.sample(x, None, k, [rng])
            states[m, k] = x[0, 0]
    cases.append(("ConstantVelocity + PositionMeasurement", cv, PositionMeasurement(1, 4.0),
                  np.tile([300.0, -5.0], (M, 1)), np.diag([4.0, 25.0]), None,
                  states[..., :1] + rng.normal(0.0, 2.0, (M, K, 1)), states[..., :1]))
    sc = paper_b.make(np.random.default_rng(5), M, duration=8.0 * 40)       # a leader per run: per-run parameters
    p = paper_b.PARAMETERS
    cases.append(("CooperativeMotion + SquaredRangePair", CooperativeMotion(8.0, p.Q),
                  SquaredRangePair(sc.leader_broadcast, sc.dr_displacements, 8.0, p.R), np.tile(p.x1, (M, 1)),
                  np.diag([1e4, 1e4, 1.0, 1.0]), sc.dr_displacements, range_pairs(sc.ranges) ** 2,
                  np.broadcast_to(sc.true_states[:, :2], (M, 40, 2))))
    return cases


@pytest.mark.parametrize("case", _pair_cases(), ids=lambda c: c[0])
def test_every_kind_of_model_pair_runs_in_the_particle_filter_as_in_the_ekf(case):
    """The library's other model pairs (state-dependent R, a bias state, a singular Q, per-run leader paths) run
    in the batched PF as they run in the EKF engine, and the PF is about as accurate."""
    from uwtutor.filters import extended_kalman_filter

    name, motion, measurement, x0, P0, u, z, truth = case
    ekf = extended_kalman_filter(motion, measurement, x0, P0, u, z)
    pf = BootstrapParticleFilter.from_gaussian(motion, measurement, x0, P0, 2000, np.random.default_rng(1),
                                               ess_threshold=0.5).run(z, u)
    assert pf.x.shape == ekf.x.shape and np.isfinite(pf.x).all()
    d = truth.shape[-1]
    late = slice(truth.shape[1] // 2, None)
    error = {n: float(np.mean(np.linalg.norm(r.x[:, late, :d] - truth[:, late], axis=-1))) for n, r in
             (("EKF", ekf), ("PF", pf))}
    assert error["PF"] < 1.5 * error["EKF"] + 1.0, error
