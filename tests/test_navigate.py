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


def test_a_filter_that_lost_the_track_between_sparse_ranges_says_so(plaza2):
    # one range every 30 s from beacon 5, the schedule starting 12 s in: the gate rejects most ranging epochs and
    # the estimate ends worse than the odometry alone (studies/plaza_navigation.py's 30 s schedules)
    with pytest.warns(UserWarning, match="lost the track") as caught:
        lost = navigate(plaza2, [5], min_period=30.0, offset=12.0)
    assert _rmse(lost.x[:, :2], plaza2.truth) > _rmse(plaza2.dead_reckoning()[:, :2], plaza2.truth)
    message = next(str(w.message) for w in caught if "lost the track" in str(w.message))
    assert "dead_reckoning()" in message and " of " in message
    # one range every 10 s from the same beacon: the filter keeps the track and says nothing of it
    import warnings

    with warnings.catch_warnings(record=True) as quiet:
        warnings.simplefilter("always")
        kept = navigate(plaza2, [5], min_period=10.0)
    assert not [w for w in quiet if "lost the track" in str(w.message)]
    assert _rmse(kept.x[:, :2], plaza2.truth) < 5.0
    # without the gate there is nothing to count
    with warnings.catch_warnings(record=True) as ungated:
        warnings.simplefilter("always")
        navigate(plaza2, [5], min_period=30.0, offset=12.0, gate=False)
    assert not [w for w in ungated if "lost the track" in str(w.message)]


# -- the states chosen from the log ------------------------------------------------------------------------------------
def test_the_default_chooses_the_candidate_the_ranges_make_most_likely():
    data = simulated_log(seed=5, K=1201)
    result = navigate(data, range_sigma=0.3)
    from uwtutor.datasets import CANDIDATES

    assert set(result.evidence) == set(CANDIDATES) == set(result.candidates)
    penalized = {name: value - sum(CANDIDATES[name]) for name, value in result.evidence.items()}
    assert result.chosen == max(penalized, key=penalized.get)
    # a log with a scale and a gyro bias: both states, and the returned run is that candidate's
    assert result.chosen == "+ scale and gyro bias"
    np.testing.assert_array_equal(result.x, result.candidates[result.chosen].x)
    assert result.state_names == ("x", "y", "heading", "gyro_bias", "scale")


def test_explicit_switches_restrict_the_candidates():
    data = simulated_log(seed=6, K=401)
    assert set(navigate(data, range_sigma=0.3, gyro_bias=False).evidence) == {"pose only", "+ scale"}
    both = navigate(data, range_sigma=0.3, gyro_bias=True, scale=True)
    assert set(both.evidence) == {"+ scale and gyro bias"} and both.chosen == "+ scale and gyro bias"
    assert navigate(data, range_sigma=0.3, scale=False, gyro_bias=False).x.shape[-1] == 3


def test_every_candidate_is_scored_on_every_range_even_those_its_gate_rejected():
    from uwtutor.datasets.navigation import _log_predictive, navigation_models

    data = simulated_log(seed=7, K=401)
    result = navigate(data, range_sigma=0.3, scale=False, gyro_bias=False)     # 7 % long ranges: many rejected
    assert int(result.extras["rejected"].sum()) > 0
    nav = navigation_models(data, range_sigma=0.3, scale=False, gyro_bias=False)
    score, per_range = _log_predictive(nav, result)
    assert per_range.size == np.isfinite(nav.z).any(axis=1).sum()          # every epoch with a range
    assert score == pytest.approx(result.evidence["pose only"])


def test_implausible_headings_are_reported():
    data = simulated_log(seed=8, K=401)
    degrees = RangeDataset(times=data.times, odometry=np.column_stack([data.odometry[:, 0],
                                                                        np.degrees(data.odometry[:, 1])]),
                           ranges=data.ranges, beacons=dict(data.beacons), start=data.start, heading_unit="deg")
    np.testing.assert_allclose(degrees.odometry, data.odometry, atol=1e-12)
    with pytest.warns(UserWarning, match="heading_unit='deg'"):
        wrong = RangeDataset(times=data.times, odometry=degrees.odometry * [1.0, 180.0 / np.pi],
                             ranges=data.ranges, beacons=dict(data.beacons), start=data.start)
    with pytest.warns(UserWarning, match="disagree with the odometry|far from 1"):
        navigate(wrong, range_sigma=0.3)


def test_clockwise_from_north_is_converted():
    data = simulated_log(seed=9, K=801, turn_every=100)
    truth = data.truth.copy()
    truth[:, 2] = np.pi / 2 - truth[:, 2]
    compass = RangeDataset(times=data.times, odometry=data.odometry * [1.0, -1.0], ranges=data.ranges,
                           beacons=dict(data.beacons), truth=truth, heading_convention="cw-from-north")
    np.testing.assert_allclose(compass.odometry, data.odometry, atol=1e-12)
    np.testing.assert_allclose(wrap_angle(compass.truth[:, 2] - data.truth[:, 2]), 0.0, atol=1e-12)
    with pytest.warns(UserWarning, match="opposite senses"):
        RangeDataset(times=data.times, odometry=data.odometry * [1.0, -1.0], ranges=data.ranges,
                     beacons=dict(data.beacons), truth=data.truth)


def test_plaza1_without_drift_the_default_leaves_out_the_gyro_bias_and_beats_odometry():
    pytest.importorskip("gtsam", reason="the Plaza logs come with the optional extra uwtutor[data]")
    from uwtutor.datasets import plaza

    data = plaza(1)
    alone = _rmse(data.dead_reckoning()[:, :2], data.truth)
    result = navigate(data, [6], min_period=10.0)
    assert result.chosen == "+ scale"
    assert _rmse(result.x[:, :2], data.truth) < 0.6 * alone
    assert _rmse(result.candidates["+ scale and gyro bias"].x[:, :2], data.truth) > alone   # what it avoided


def test_gtsam_same_model_finds_the_scale_and_bias_and_isam2_agrees():
    pytest.importorskip("gtsam")
    from uwtutor.datasets.factor_graph import gtsam_map

    data = simulated_log(seed=10, K=801)
    batch = gtsam_map(data, range_sigma=0.3)
    incremental = gtsam_map(data, range_sigma=0.3, solver="isam2")
    assert batch.scale[-1] == pytest.approx(1.07, abs=0.01)
    assert batch.gyro_bias[-1] == pytest.approx(-0.004, abs=0.001)
    assert batch.n_poses < data.n_epochs                  # the biased odometry is pre-integrated between ranges
    assert _rmse(batch.poses[:, :2], data.truth) < 0.5
    assert np.abs(incremental.poses[:, :2] - batch.poses[:, :2]).max() < 0.05
    huber = gtsam_map(data, range_sigma=0.3, robust="huber")     # Gaussian ranges: a Huber kernel costs little
    assert _rmse(huber.poses[:, :2], data.truth) < 1.25 * _rmse(batch.poses[:, :2], data.truth)


def test_the_readme_real_data_example_runs(capsys):
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "README.md").read_text(encoding="utf-8")
    section = text[text.index("## Real data"):]
    code = section[section.index("```python") + len("```python"):section.index("```\n", section.index("```python") + 9)]
    assert len(code.strip().splitlines()) <= 12
    namespace: dict = {}
    exec(compile(code, "README.md", "exec"), namespace)
    assert namespace["result"].chosen == "+ scale"
    assert "+ scale" in capsys.readouterr().out
