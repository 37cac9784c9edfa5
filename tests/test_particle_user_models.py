"""A particle model a user wrote for one run (particles (N, n), a measurement (m,), one Generator) keeps working
in the batched particle filters: they call its overrides run by run."""

import numpy as np

from uwtutor.filters import BootstrapParticleFilter, DepthSpeedPitchModel


class OneRunLikelihood(DepthSpeedPitchModel):
    """The built-in Gaussian likelihood, rewritten the way a student writes it: for one run only."""

    def log_likelihood(self, particles, z):
        assert particles.ndim == 2 and z.ndim == 1, "called with one run's particles and measurement"
        residual = self.measure(particles) - z
        return -0.5 * np.sum((residual / np.sqrt(np.diag(self.R))) ** 2, axis=1)


class OneRunMotion(DepthSpeedPitchModel):
    """A motion model written for one run: a random walk, one Generator."""

    def propagate(self, particles, u, rng):
        assert particles.ndim == 2 and isinstance(rng, np.random.Generator)
        return particles + rng.normal(0.0, 0.01, particles.shape)


def _data(n_runs=3, steps=120):
    model = DepthSpeedPitchModel()
    meas = np.stack([model.simulate([20.0, 1.5, 0.05], steps, np.random.default_rng(s))[1] for s in range(n_runs)])
    return model, meas


def test_one_run_likelihood_equals_the_built_in_one_single_and_batched():
    model, meas = _data()
    for m in range(meas.shape[0]):
        ref = BootstrapParticleFilter.from_gaussian(model, meas[m, 0], model.R, 200, np.random.default_rng(m)).run(meas[m])
        own = BootstrapParticleFilter.from_gaussian(OneRunLikelihood(), meas[m, 0], model.R, 200,
                                                    np.random.default_rng(m)).run(meas[m])
        np.testing.assert_allclose(own.x, ref.x, rtol=1e-9, atol=1e-9)
    batched = BootstrapParticleFilter.from_gaussian(OneRunLikelihood(), meas[:, 0], model.R, 200,
                                                    np.random.default_rng(9)).run(meas)
    assert batched.x.shape == (3, meas.shape[1], 3) and np.isfinite(batched.x).all()


def test_one_run_motion_model_is_called_run_by_run_with_its_own_generator():
    model, meas = _data()
    batched = BootstrapParticleFilter.from_gaussian(OneRunMotion(), meas[:, 0], model.R, 100,
                                                    np.random.default_rng(4)).run(meas)
    assert batched.x.shape == (3, meas.shape[1], 3) and np.isfinite(batched.x).all()
    single = BootstrapParticleFilter.from_gaussian(OneRunMotion(), meas[0, 0], model.R, 100,
                                                   np.random.default_rng(4)).run(meas[0])
    assert single.x.shape == (meas.shape[1], 3)
