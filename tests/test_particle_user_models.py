"""Models a user writes: a ModelPair whose likelihood is written for one run (particles (N, n), a measurement (m,)),
the way the lab depth_pf_vs_ekf has students write it, keeps working in the batched particle filters (they call it
run by run); a motion model with its own batched sampler is what the filters draw from."""

import numpy as np
import pytest

from uwtutor.filters import BootstrapParticleFilter, DepthSpeedPitchModel
from uwtutor.models import DepthSensors, DepthSpeedPitch, MotionModel


class OneRunLikelihood(DepthSpeedPitchModel):
    """The built-in Gaussian likelihood, rewritten the way a student writes it: for one run only."""

    def log_likelihood(self, particles, z):
        assert particles.ndim == 2 and z.ndim == 1, "called with one run's particles and measurement"
        residual = self.measure(particles) - z
        return -0.5 * np.sum((residual / np.sqrt(np.diag(self.R))) ** 2, axis=1)


class RandomWalk(MotionModel):
    """A motion model a user writes with its own sampler (and no Jacobian): a random walk, one Generator per run."""

    n = 3
    calls = 0

    def sample(self, x, u, k, rng):
        RandomWalk.calls += 1
        assert x.ndim == 3 and len(rng) == x.shape[0]
        return x + np.stack([r.normal(0.0, 0.01, x.shape[1:]) for r in rng])


def _data(n_runs=3, steps=120):
    model = DepthSpeedPitchModel()
    meas = np.stack([model.simulate([20.0, 1.5, 0.05], steps, np.random.default_rng(s))[1] for s in range(n_runs)])
    return model, meas


def test_one_run_likelihood_equals_the_built_in_one_single_and_batched():
    model, meas = _data()
    for m in range(meas.shape[0]):
        ref = BootstrapParticleFilter.from_gaussian(model, meas[m, 0], model.R, 200,
                                                    np.random.default_rng(m)).run(meas[m])
        own = BootstrapParticleFilter.from_gaussian(OneRunLikelihood(), meas[m, 0], model.R, 200,
                                                    np.random.default_rng(m)).run(meas[m])
        np.testing.assert_allclose(own.x, ref.x, rtol=1e-9, atol=1e-9)
    batched = BootstrapParticleFilter.from_gaussian(OneRunLikelihood(), meas[:, 0], model.R, 200,
                                                    np.random.default_rng(9)).run(meas)
    ref = BootstrapParticleFilter.from_gaussian(model, meas[:, 0], model.R, 200, np.random.default_rng(9)).run(meas)
    np.testing.assert_allclose(batched.x, ref.x, rtol=1e-9, atol=1e-9)


def test_one_run_likelihood_skips_a_run_without_a_measurement():
    model, meas = _data(n_runs=2, steps=20)
    meas[1, 5] = np.nan
    res = BootstrapParticleFilter.from_gaussian(OneRunLikelihood(), meas[:, 0], model.R, 100,
                                                np.random.default_rng(1)).run(meas)
    assert not res.extras["resampled"][1, 5] and res.extras["resampled"][0, 5]
    np.testing.assert_array_equal(res.x[1, 5], res.x_prior[1, 5])


def test_a_one_run_likelihood_of_the_wrong_shape_is_named():
    class Wrong(DepthSpeedPitchModel):
        def log_likelihood(self, particles, z):
            return np.zeros(3)

    model, meas = _data(n_runs=1, steps=3)
    pf = BootstrapParticleFilter.from_gaussian(Wrong(), meas[0, 0], model.R, 50, np.random.default_rng(0))
    pf.predict()
    with pytest.raises(ValueError, match=r"Wrong.log_likelihood must return one value per particle of the run, "
                                         r"shape \(50,\)"):
        pf.update(meas[0, 0])


def test_a_motion_model_with_its_own_sampler_is_what_the_filter_draws_from():
    model, meas = _data()
    RandomWalk.calls = 0
    batched = BootstrapParticleFilter.from_gaussian(RandomWalk(), DepthSensors(), meas[:, 0], model.R, 100,
                                                    np.random.default_rng(4)).run(meas)
    assert batched.x.shape == (3, meas.shape[1], 3) and np.isfinite(batched.x).all()
    assert RandomWalk.calls == meas.shape[1]                     # one call per step for all runs at once
    single = BootstrapParticleFilter.from_gaussian(RandomWalk(), DepthSensors(), meas[0, 0], model.R, 100,
                                                   np.random.default_rng(4).spawn(3)[0]).run(meas[0])
    np.testing.assert_allclose(single.x, batched.x[0], rtol=1e-12)
    # the depth sensor's noise is 0.2 m: a random walk of 1 cm per step follows the slow dive within it
    assert np.sqrt(np.mean((single.x[:, 0] - meas[0, :, 0]) ** 2)) < 0.3
    with pytest.raises(NotImplementedError):                    # it has no f: the Kalman family cannot use it
        RandomWalk().f(np.zeros((1, 3)), None, 0)
    assert isinstance(DepthSpeedPitch(), MotionModel)
