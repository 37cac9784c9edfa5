"""filters.RelativeRangeModel: the range-only particle model in coordinates relative to the beacon."""

import numpy as np
import pytest

from uwtutor.filters import BootstrapParticleFilter, RelativeRangeModel

Q, R = np.eye(2), 4.0


def _ranges(n_runs, K=40, seed=3):
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, np.pi, K + 1)
    track = 300.0 * np.column_stack([np.cos(t), np.sin(t)])
    z = np.linalg.norm(track[1:], axis=-1) + rng.normal(0.0, 2.0, (n_runs, K))
    return track, z


def test_measure_and_propagate():
    model = RelativeRangeModel(Q, R)
    p = np.array([[[3.0, 4.0], [0.0, -2.0]]])                       # (M=1, N=2, 2)
    np.testing.assert_allclose(model.measure(p), [[[5.0], [2.0]]])
    moved = model.propagate(p, np.array([[1.0, 1.0]]), [np.random.default_rng(0)])
    zero_noise = RelativeRangeModel(np.zeros((2, 2)), R).propagate(p, np.array([[1.0, 1.0]]),
                                                                   [np.random.default_rng(0)])
    np.testing.assert_allclose(zero_noise, p + 1.0)
    assert moved.shape == p.shape and not np.allclose(moved, zero_noise)


def test_batched_run_equals_the_single_runs_on_the_same_generators():
    track, z = _ranges(3)
    u = np.broadcast_to(np.diff(track, axis=0), (3,) + np.diff(track, axis=0).shape)
    seeds = np.random.SeedSequence(8).spawn(3)
    batch = BootstrapParticleFilter.from_gaussian(RelativeRangeModel(Q, R), np.tile(track[0], (3, 1)),
                                                  100.0 * np.eye(2), 200,
                                                  [np.random.default_rng(s) for s in seeds]).run(z[..., None], u)
    for m in range(3):
        single = BootstrapParticleFilter.from_gaussian(RelativeRangeModel(Q, R), track[0], 100.0 * np.eye(2), 200,
                                                       np.random.default_rng(seeds[m]))
        np.testing.assert_allclose(single.run(z[m, :, None], u[m]).x, batch.x[m], rtol=0, atol=1e-9)


def test_the_filter_follows_the_track():
    track, z = _ranges(1, seed=5)
    pf = BootstrapParticleFilter.from_gaussian(RelativeRangeModel(Q, R), track[0] + [10.0, -10.0],
                                               100.0 * np.eye(2), 1000, np.random.default_rng(2))
    res = pf.run(z[0, :, None], np.diff(track, axis=0))
    assert np.linalg.norm(res.x[-1] - track[-1]) < 10.0


@pytest.mark.parametrize("kw, match", [({"Q": np.full((2, 2), np.nan)}, "Q"), ({"R": np.eye(2)}, "R must be one")])
def test_bad_input_names_the_argument(kw, match):
    args = dict(Q=Q, R=R) | kw
    with pytest.raises(ValueError, match=match):
        RelativeRangeModel(**args)
