"""Chapter 6 widget and study helpers: the maneuvering profile, the sensors, the filter study, the GPF explorer."""

from __future__ import annotations

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

from uwtutor.widgets import ch06  # noqa: E402


def test_profile_follows_the_kinematics_and_the_noise_schedule():
    p = ch06.maneuvering_depth_profile()
    assert p.n_steps == 1200 and p.T == 0.05
    np.testing.assert_allclose(p.times, 0.05 * np.arange(1, 1201))
    z, v, phi = p.truth.T
    np.testing.assert_allclose(np.diff(z), v[1:] * np.sin(phi[1:]) * p.T, atol=1e-12)
    assert z[0] == pytest.approx(10.0 + v[0] * np.sin(phi[0]) * p.T)
    assert np.degrees(phi.max()) == pytest.approx(20.0) and np.degrees(phi.min()) == pytest.approx(-25.0)
    nominal = ch06.PARAMETERS.sensor_std
    for time, factor in ((5.0, 1.0), (20.0, 3.0), (35.0, 1.0), (50.0, 0.5)):
        k = np.searchsorted(p.times, time)
        np.testing.assert_allclose(p.sensor_std[k], factor * nominal)
    assert p.maneuvering[p.mask(9.0, 10.0)].all() and not p.maneuvering[p.mask(15.0, 20.0)].any()
    assert set(p.segments) >= {"dive", "level", "climb", "noise x3 (2)", "noise x0.5 (4)"}
    part = p.between(6.0, 18.0)
    assert part.n_steps == 240 and part.times[0] == pytest.approx(6.0)
    assert part.segments["dive"] == (8.0, 18.0)


def test_profile_bad_input():
    with pytest.raises(ValueError, match="one entry more than noise_change_times"):
        ch06.maneuvering_depth_profile(noise_factors=(1.0, 2.0), noise_change_times=(10.0, 20.0))
    with pytest.raises(ValueError, match="noise_factors must be > 0"):
        ch06.maneuvering_depth_profile(noise_factors=(1.0, 0.0), noise_change_times=(10.0,))
    with pytest.raises(ValueError, match="noise_change_times must increase"):
        ch06.maneuvering_depth_profile(noise_factors=(1.0, 2.0, 3.0), noise_change_times=(20.0, 10.0))
    with pytest.raises(ValueError, match="at least 20 samples"):
        ch06.maneuvering_depth_profile(duration=0.5)
    with pytest.raises(ValueError, match="at least 20 samples"):
        ch06.maneuvering_depth_profile().between(10.0, 10.5)


def test_sensors_have_the_profile_noise():
    p = ch06.maneuvering_depth_profile()
    Z = ch06.simulate_depth_sensors(p, 200, np.random.default_rng(0))
    assert Z.shape == (200, 1200, 3)
    ratio = np.std(Z - p.truth, axis=0) / p.sensor_std
    assert np.mean(ratio) == pytest.approx(1.0, abs=0.01)
    with pytest.raises(TypeError, match="rng must be a numpy.random.Generator"):
        ch06.simulate_depth_sensors(p, 2, None)


def test_run_depth_study_runs_every_filter():
    p = ch06.maneuvering_depth_profile(duration=6.0, noise_factors=(1.0, 3.0), noise_change_times=(30.0,))
    Z = ch06.simulate_depth_sensors(p, 2, np.random.default_rng(1))
    study = ch06.run_depth_study(p, Z, ch06.FILTER_NAMES, n_particles=100)
    assert list(study.estimates) == list(ch06.FILTER_NAMES)
    for name, x in study.estimates.items():
        assert x.shape == (2, p.n_steps, 3), name
        assert np.isfinite(x).all(), name
        assert study.rmse(name).shape == (p.n_steps, 3)
        assert study.rmse_over(name).shape == (3,)
    assert set(study.ess) == {"MMPF", "GPF", "PF", "PF + wavelet R"}
    assert study.extras["GPF noise_std"].shape == (2, p.n_steps, 3)
    assert study.extras["MMPF mode_probabilities"].shape == (2, p.n_steps, 3)
    # the EKF with the wavelet R alone (no GPF to borrow the estimates from) computes them itself
    alone = ch06.run_depth_study(p, Z, ("EKF + wavelet R",))
    np.testing.assert_allclose(alone.estimates["EKF + wavelet R"], study.estimates["EKF + wavelet R"], rtol=1e-9)
    # same seed, same result
    again = ch06.run_depth_study(p, Z, ("GPF",), n_particles=100)
    np.testing.assert_array_equal(again.estimates["GPF"], study.estimates["GPF"])
    modes = ch06.run_depth_study(p, Z, ("MMPF",), n_particles=100, mmpf_targets_deg=(0.0, 15.0))
    assert modes.extras["MMPF mode_probabilities"].shape == (2, p.n_steps, 2)


def test_run_depth_study_bad_input():
    p = ch06.maneuvering_depth_profile(duration=3.0)
    Z = ch06.simulate_depth_sensors(p, 1, np.random.default_rng(1))
    with pytest.raises(ValueError, match="filters must be names from"):
        ch06.run_depth_study(p, Z, ("UKF",))
    with pytest.raises(ValueError, match=r"measurements must have shape \(M, 60, 3\)"):
        ch06.run_depth_study(p, Z[:, :10], ("EKF",))
    with pytest.raises(ValueError, match="mmpf_stay must lie in"):
        ch06.run_depth_study(p, Z, ("MMPF",), mmpf_stay=1.5)


def test_gpf_view_at_its_defaults():
    v = ch06.gpf_view()
    assert v.times.shape == (240,) and v.truth.shape == (240, 3)
    assert set(v.estimates) == {"EKF", "GPF"} and v.rmse["GPF"].shape == (3,)
    assert v.n_particles == 200 and v.n_grey == 20
    assert v.ess.shape == (240,) and (v.ess <= 200 + 1e-9).all()
    # the noise changes at 13 s by the chosen factor
    k = np.searchsorted(v.times, 14.0)
    np.testing.assert_allclose(v.true_noise_std[k], 3.0 * ch06.PARAMETERS.sensor_std)
    # reproducible, and the GPF beats the EKF in depth when the noise triples
    w = ch06.gpf_view()
    np.testing.assert_array_equal(v.estimates["GPF"], w.estimates["GPF"])
    assert v.rmse["GPF"][0] < v.rmse["EKF"][0]
    with pytest.raises(ValueError, match="noise_change must be >= 0.001"):
        ch06.gpf_view(noise_change=0.0)
    with pytest.raises(ValueError, match="noise_window must be at most the dive's 240 samples"):
        ch06.gpf_view(noise_window=10**12)
    with pytest.raises(ValueError, match="n_particles must be >= 10"):
        ch06.gpf_view(n_particles=5)


def test_widget_builds_and_plot_draws():
    import matplotlib.pyplot as plt

    panel = ch06.gpf_widget()
    assert len(panel.children) == 3
    fig = ch06.plot_gpf_view(ch06.gpf_view(n_particles=50))
    assert len(fig.axes) == 4
    plt.close("all")


def test_compute_functions_registry():
    assert set(ch06.COMPUTE_FUNCTIONS) == {"ch06 grey particle filter"}
    for fn in ch06.COMPUTE_FUNCTIONS.values():
        assert fn() is not None


def test_paper_c_scenario_module_holds_the_papers_content():
    from uwtutor.pipelines import DepthStudy, run_depth_study
    from uwtutor.scenarios import paper_c

    p = paper_c.PaperCParameters()
    assert (p.T, p.n_particles, p.n_grey, p.grey_window, p.noise_window, p.polynomial_order, p.wavelet) == (
        0.05, 1000, 100, 30, 50, 5, "db6")
    np.testing.assert_allclose(p.sensor_std, [0.2, 0.05, np.radians(0.5)])
    np.testing.assert_allclose(p.process_std, [0.2, 0.01, np.radians(0.5)])
    np.testing.assert_allclose(p.R, np.diag(p.sensor_std**2))
    assert np.linalg.eigvalsh(p.Q_as_printed).min() < 0             # the printed Q is not a covariance
    for name, value in p.as_dict().items():                        # the module's default set is the paper's
        np.testing.assert_array_equal(getattr(paper_c.PARAMETERS, name), value)
    # the widget module shows the same objects under the chapter's names
    assert ch06.PARAMETERS is paper_c.PARAMETERS and ch06.run_depth_study is run_depth_study
    assert ch06.maneuvering_depth_profile is paper_c.maneuvering_depth_profile
    assert ch06.DepthStudy is DepthStudy and ch06.FILTER_NAMES == paper_c.FILTER_NAMES
    # make(rng, n_runs) is the chapter's profile and sensor draws
    sc = paper_c.make(np.random.default_rng(2013), 3)
    profile = ch06.maneuvering_depth_profile()
    np.testing.assert_array_equal(sc.truth, profile.truth)
    np.testing.assert_array_equal(sc.measurements,
                                  ch06.simulate_depth_sensors(profile, 3, np.random.default_rng(2013)))
    assert sc.n_runs == 3 and sc.parameters.T == p.T and sc.profile.T == p.T
    short = paper_c.make(np.random.default_rng(0), 2, duration=6.0, noise_factors=(1.0, 2.0),
                         noise_change_times=(30.0,))
    assert short.measurements.shape == (2, 120, 3)
    with pytest.raises(TypeError, match="params must be a PaperCParameters"):
        paper_c.make(np.random.default_rng(0), 1, params={"T": 0.1})


def test_run_depth_study_batches_the_runs_like_single_runs():
    """Run m of the study's batched filters is the single-run filter seeded seed + m."""
    from uwtutor.filters import GreyParticleFilter
    from uwtutor.scenarios import paper_c

    sc = paper_c.make(np.random.default_rng(5), 2, duration=6.0)
    from uwtutor.pipelines import run_depth_study

    study = run_depth_study(sc.profile, sc.measurements, ("GPF",), n_particles=100, seed=3)
    R = paper_c.PaperCParameters().R
    from uwtutor.models import DepthSensors, DepthSpeedPitch

    motion, sensors = DepthSpeedPitch(T=0.05, process_std=paper_c.PARAMETERS.process_std), DepthSensors(R)
    for m in range(2):
        one = GreyParticleFilter.from_gaussian(motion, sensors, sc.measurements[m, 0], R, 100,
                                               np.random.default_rng(3 + m),
                                               grey_offset=[0.0, 0.0, paper_c.PITCH_OFFSET]).run(sc.measurements[m])
        np.testing.assert_allclose(study.estimates["GPF"][m], one.x, rtol=1e-9, atol=1e-12)


def test_a_new_noise_change_runs_on_from_the_kept_state_bit_for_bit(monkeypatch):
    # the readings before the change are the same for every change: the widget keeps both filters' state there and
    # runs them over the readings after it only; the views must be those of one run over the whole dive
    from uwtutor.filters import GreyParticleFilter, extended_kalman_filter
    from uwtutor.models.depth import DepthSensors, DepthSpeedPitch
    from uwtutor.scenarios.paper_c import PARAMETERS, PITCH_OFFSET

    monkeypatch.setattr(ch06, "_BEFORE_CHANGE", {})
    ch06._dive_and_ekf.cache_clear()
    first = ch06.gpf_view(n_particles=120, noise_change=2.0)        # runs whole, keeps the state at the change
    assert {key[0] for key in ch06._BEFORE_CHANGE} == {"EKF", "GPF"}
    for factor in (0.5, 4.75):                                      # run on from the state kept
        view = ch06.gpf_view(n_particles=120, noise_change=factor)
        profile, z, _ = ch06._dive_and_ekf(factor, 1)
        np.testing.assert_array_equal(z[:ch06._split(profile)], first.measurements[:ch06._split(profile)])
        assert not np.array_equal(z, first.measurements)
        R = np.diag(PARAMETERS.sensor_std ** 2)
        motion, sensors = DepthSpeedPitch(T=profile.T, process_std=PARAMETERS.process_std), DepthSensors(R)
        ekf = extended_kalman_filter(motion, sensors, z[0], R, None, z)
        gpf = GreyParticleFilter.from_gaussian(motion, sensors, z[0], R, 120, np.random.default_rng(1001),
                                               grey_fraction=0.1, noise_window=50,
                                               grey_offset=[0.0, 0.0, PITCH_OFFSET]).run(z)
        assert view.estimates["EKF"].tobytes() == ekf.x.tobytes()
        assert view.estimates["GPF"].tobytes() == gpf.x.tobytes()
        assert view.ess.tobytes() == gpf.extras["ess"].tobytes()
        assert view.noise_std.tobytes() == gpf.extras["noise_std"].tobytes()
    ch06._dive_and_ekf.cache_clear()
