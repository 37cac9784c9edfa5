"""``datasets.navigate``: the real-data filter in one call (heading, gyro bias and range scale in the state).

On a simulated log with a known scale and gyro bias it recovers both within its own 3 sigma; the smoother handles a
heading that crosses +-pi; bad input is named; and on the Plaza sets (when gtsam is installed) it does what the
position-only models could not: far better than odometry alone from one beacon.
"""

from __future__ import annotations

import numpy as np
import pytest

from uwtutor.datasets import RangeDataset, navigate
from uwtutor.models import OdometryMotion
from uwtutor.models.odometry import wrap_angle

BEACON = (60.0, 40.0)


def simulated_log(seed=0, *, scale=1.07, gyro_bias=-0.004, heading0=0.0, K=2401, dt=0.5, every=4, sigma_r=0.3,
                  turn_every=240):
    """A rover driving squares at 1 m/s; its gyro reports the turns plus ``gyro_bias * dt`` per step; one beacon
    ranged every ``every`` steps with a range scale ``scale``."""
    rng = np.random.default_rng(seed)
    turn = np.where(np.arange(K) % turn_every == 0, np.pi / 2, 0.0)
    turn[0] = 0.0
    distance = np.full(K, 1.0 * dt)
    distance[0] = 0.0
    true_odometry = np.column_stack([distance, turn])
    start = [0.0, 0.0, heading0]
    truth = RangeDataset(times=dt * np.arange(K), odometry=true_odometry, ranges=np.empty((0, 3)),
                         beacons={3: BEACON}, start=start).dead_reckoning()
    logged = true_odometry.copy()
    logged[1:, 0] += rng.normal(0.0, 0.01, K - 1)
    logged[1:, 1] += gyro_bias * dt + rng.normal(0.0, 1e-3 * np.sqrt(dt), K - 1)
    heard = np.arange(1, K, every)
    r = scale * np.linalg.norm(truth[heard, :2] - BEACON, axis=1) + rng.normal(0.0, sigma_r, heard.size)
    return RangeDataset(times=dt * np.arange(K), odometry=logged,
                        ranges=np.column_stack([dt * heard, np.full(heard.size, 3), r]), beacons={3: BEACON},
                        start=start, truth=truth)


def test_recovers_the_range_scale_and_the_gyro_bias_within_three_sigma():
    data = simulated_log()
    result = navigate(data, range_sigma=0.3)
    assert result.x.shape == (data.times.size, 5)
    sigma = np.sqrt(np.diagonal(result.P[-1]))
    assert abs(result.x[-1, 4] - 1.07) < 3 * sigma[4], (result.x[-1, 4], sigma[4])
    assert abs(result.x[-1, 3] - (-0.004)) < 3 * sigma[3], (result.x[-1, 3], sigma[3])
    assert sigma[4] < 0.01 and sigma[3] < 1e-3          # both are learnt, not left at their priors
    error = np.linalg.norm(result.x[:, :2] - data.truth[:, :2], axis=1)
    dead_reckoning = np.linalg.norm(data.dead_reckoning()[:, :2] - data.truth[:, :2], axis=1)
    assert np.sqrt(np.mean(error**2)) < 0.2 * np.sqrt(np.mean(dead_reckoning**2))


def test_leaving_out_the_states_the_log_needs_costs_accuracy():
    data = simulated_log(seed=1)
    full = navigate(data, range_sigma=0.3)
    no_scale = navigate(data, range_sigma=0.3, scale=False, gate=False)
    assert full.x.shape[-1] == 5 and no_scale.x.shape[-1] == 4

    def rmse(res):
        return np.sqrt(np.mean(np.sum((res.x[:, :2] - data.truth[:, :2]) ** 2, axis=1)))

    assert rmse(full) < 0.5 * rmse(no_scale)


def test_smoothing_beats_filtering_and_keeps_the_ends_equal():
    data = simulated_log(seed=2)
    filtered = navigate(data, range_sigma=0.3)
    smoothed = navigate(data, range_sigma=0.3, smooth=True)
    np.testing.assert_allclose(smoothed.x[-1], filtered.x[-1])
    np.testing.assert_array_equal(smoothed.innovations, filtered.innovations)

    def rmse(res):
        return np.sqrt(np.mean(np.sum((res.x[:, :2] - data.truth[:, :2]) ** 2, axis=1)))

    assert rmse(smoothed) < rmse(filtered)


def test_the_smoother_wraps_a_heading_that_crosses_pi():
    """Westward, the heading lives at +-pi: a difference taken without wrapping would jump by 2 pi."""
    data = simulated_log(seed=3, heading0=np.pi - 1e-3, gyro_bias=0.0, turn_every=10**6)
    smoothed = navigate(data, range_sigma=0.3, smooth=True)
    heading_error = wrap_angle(smoothed.x[:, 2] - data.truth[:, 2])
    assert np.abs(heading_error).max() < 0.3          # not 2 pi: no jump where the heading wraps
    assert ((smoothed.x[:, 2] >= -np.pi) & (smoothed.x[:, 2] < np.pi)).all()
    # and through the smoother directly: the model's difference is what is wrapped
    motion = OdometryMotion(0.1, 0.01)
    np.testing.assert_allclose(motion.difference(np.array([0, 0, -np.pi + 0.01]), np.array([0, 0, np.pi - 0.01])),
                               [0, 0, 0.02], atol=1e-12)
    np.testing.assert_allclose(motion.normalize(np.array([1.0, 2.0, 3 * np.pi / 2])), [1.0, 2.0, -np.pi / 2])


def test_an_acoustic_rate_uses_fewer_ranges():
    data = simulated_log(seed=4, every=1)
    full = navigate(data, range_sigma=0.3)
    sparse = navigate(data, range_sigma=0.3, min_period=10.0)
    used = np.isfinite(full.extras["ranges"]).sum(), np.isfinite(sparse.extras["ranges"]).sum()
    assert used[1] < used[0] / 15
    intervals = np.diff(data.times[np.isfinite(sparse.extras["ranges"][:, 0])])
    assert intervals.min() >= 10.0 - 0.5


@pytest.mark.parametrize("kwargs, message", [
    ({"range_sigma": 0.0}, "range_sigma"),
    ({"range_sigma": np.nan}, "range_sigma"),
    ({"heading_noise": -1.0}, "heading_noise"),
    ({"distance_sigma": (0.0, 0.02)}, r"distance_sigma\[0\]"),
    ({"distance_sigma": (0.01,)}, "distance_sigma"),
    ({"scale_prior": 0.0}, "scale_prior"),
    ({"gyro_bias_walk": -1e-4}, "gyro_bias_walk"),
    ({"beacon_ids": [99]}, "99"),
    ({"min_period": -1.0}, "min_period"),
])
def test_bad_input_is_named(kwargs, message):
    data = simulated_log(K=41, turn_every=20)
    with pytest.raises(ValueError, match=message):
        navigate(data, **kwargs)


def test_data_must_be_a_dataset_with_a_start():
    with pytest.raises(TypeError, match="RangeDataset"):
        navigate({"times": [0.0]})
    no_start = RangeDataset(times=[0.0, 1.0], odometry=[[0.0, 0.0], [1.0, 0.0]], ranges=np.empty((0, 3)),
                            beacons={1: (0.0, 0.0)})
    with pytest.raises(ValueError, match="start pose"):
        navigate(no_start)


# -- the Plaza sets (gtsam's wheel) ------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def plaza2():
    pytest.importorskip("gtsam", reason="the Plaza logs come with the optional extra uwtutor[data]")
    from uwtutor.datasets import plaza

    return plaza(2)


def _rmse(positions, truth):
    return float(np.sqrt(np.mean(np.sum((positions - truth[:, :2]) ** 2, axis=1))))


def test_plaza2_one_beacon_beats_odometry_alone_and_four_beacons_reach_decimetres(plaza2):
    odometry_alone = _rmse(plaza2.dead_reckoning()[:, :2], plaza2.truth)
    assert odometry_alone > 20.0                               # the heading drifts by more than 100 degrees
    for beacon in plaza2.beacons:
        one = navigate(plaza2, [beacon])
        assert _rmse(one.x[:, :2], plaza2.truth) < 0.15 * odometry_alone, beacon
        assert 1.06 < one.x[-1, 4] < 1.08, beacon              # the radios' range scale
    four = navigate(plaza2)
    assert _rmse(four.x[:, :2], plaza2.truth) < 0.5
    assert abs(four.x[-1, 4] - 1.07) < 0.005
