"""Tests of uwtutor.scenarios: the generic builder, the three paper scenarios and the Scenario container."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from uwtutor.motion import circle_track, s_turn_track, straight_track
from uwtutor.ranging import GaussianNoise, Outliers, SoundSpeedMismatch, reception_times
from uwtutor.scenarios import (Scenario, ScenarioRun, approach_with_turn_scenario, circling_scenario,
                               make_scenario, ship_and_submersible_scenario)

BUILDERS = [circling_scenario, approach_with_turn_scenario, ship_and_submersible_scenario]
FIELDS = ["true_positions", "dr_displacements", "beacon_positions", "true_ranges", "ranges", "range_errors",
          "outlier_mask"]


def assert_shapes(sc: Scenario, m: int, k: int) -> None:
    assert (sc.n_runs, sc.n_steps) == (m, k)
    assert sc.times.shape == (k,)
    for name in ("true_positions", "dr_displacements", "beacon_positions"):
        assert getattr(sc, name).shape == (m, k, 2), name
    for name in ("true_ranges", "ranges", "range_errors", "outlier_mask"):
        assert getattr(sc, name).shape == (m, k), name


# --- make_scenario ---------------------------------------------------------------------------------------------

def test_make_scenario_without_errors_is_consistent_with_the_geometry():
    track = circle_track(np.arange(0.0, 500.0, 5.0), 800.0, 2.0, center=(100.0, 50.0))
    sc = make_scenario(track, (10.0, -20.0), None, np.random.default_rng(0), n_runs=3, description="check")
    assert_shapes(sc, 3, 100)
    assert sc.description == "check"
    np.testing.assert_allclose(sc.true_ranges, np.hypot(*(track.positions - [10.0, -20.0]).T)[None].repeat(3, 0))
    np.testing.assert_array_equal(sc.ranges, sc.true_ranges)
    np.testing.assert_array_equal(sc.range_errors, 0.0)
    np.testing.assert_allclose(sc.dr_positions, sc.true_positions, atol=1e-9)
    np.testing.assert_array_equal(sc.dr_displacements[:, 0], 0.0)
    assert not sc.outlier_mask.any()


def test_make_scenario_ranges_are_true_plus_errors_and_dr_noise_has_sigma():
    track = straight_track(np.arange(0.0, 1000.0, 2.0), (-500.0, 300.0), 1.0, 0.0)
    sc = make_scenario(track, (0.0, 0.0), GaussianNoise(2.0), np.random.default_rng(1), n_runs=400, dr_sigma=0.9)
    np.testing.assert_allclose(sc.ranges, sc.true_ranges + sc.range_errors)
    assert sc.range_errors.std() == pytest.approx(2.0, rel=0.01)
    dr_err = sc.dr_displacements[:, 1:] - np.diff(track.positions, axis=0)
    assert dr_err.std() == pytest.approx(0.9, rel=0.01)
    # runs are independent draws
    assert abs(np.corrcoef(sc.range_errors[0], sc.range_errors[1])[0, 1]) < 0.15


def test_make_scenario_with_a_moving_beacon():
    times = np.arange(0.0, 300.0)
    ship = s_turn_track(times, (0.0, 0.0), 2.0, 0.0, 0.01, 100.0)
    auv = straight_track(times, (500.0, 500.0), 1.0, 1.0)
    sc = make_scenario(auv, ship, None, np.random.default_rng(0), n_runs=2)
    np.testing.assert_allclose(sc.beacon_positions[1], ship.positions)
    np.testing.assert_allclose(sc.true_ranges[0], np.hypot(*(auv.positions - ship.positions).T))


def test_make_scenario_separates_dr_and_range_streams():
    track = straight_track(np.arange(0.0, 100.0), (-500.0, 300.0), 1.0, 0.0)
    a = make_scenario(track, (0, 0), GaussianNoise(1.0), np.random.default_rng(2), n_runs=2, dr_sigma=0.0)
    b = make_scenario(track, (0, 0), GaussianNoise(1.0), np.random.default_rng(2), n_runs=2, dr_sigma=1.0)
    np.testing.assert_array_equal(a.range_errors, b.range_errors)


def test_make_scenario_measures_its_ranges_with_the_one_policy():
    # issue 27: an error larger than the range gives |true + error|, as ranging.measure_ranges does
    track = straight_track(np.arange(0.0, 10.0), (5.0, 0.0), 0.1, 0.0)
    sc = make_scenario(track, (0.0, 0.0), Outliers((0.0,), 10, 50.0, two_sided=True), np.random.default_rng(0),
                       n_runs=5)
    assert (sc.true_ranges + sc.range_errors < 0).any()
    assert (sc.ranges >= 0).all()
    np.testing.assert_array_equal(sc.ranges, np.abs(sc.true_ranges + sc.range_errors))


@pytest.mark.parametrize("kwargs, exc, name", [
    ({"track": np.zeros((5, 2))}, TypeError, "track"),
    ({"beacon": (0.0, np.nan)}, ValueError, "beacon"),
    ({"beacon": (0.0, 0.0, 0.0)}, ValueError, "beacon"),
    ({"error": 1.0}, TypeError, "error"),
    ({"rng": 1}, TypeError, "rng"),
    ({"n_runs": 0}, ValueError, "n_runs"),
    ({"n_runs": None}, TypeError, "n_runs"),
    ({"dr_sigma": -0.1}, ValueError, "dr_sigma"),
    ({"description": 3}, TypeError, "description"),
])
def test_make_scenario_rejects_bad_input(kwargs, exc, name):
    args = {"track": straight_track(np.arange(10.0), (100.0, 0.0), 1.0, 0.0), "beacon": (0.0, 0.0),
            "error": GaussianNoise(1.0), "rng": np.random.default_rng(0)}
    args.update(kwargs)
    with pytest.raises(exc, match=name):
        make_scenario(args.pop("track"), args.pop("beacon"), args.pop("error"), args.pop("rng"), **args)


# --- the Scenario container ------------------------------------------------------------------------------------

def test_scenario_run_returns_one_run_without_the_runs_axis():
    sc = approach_with_turn_scenario(np.random.default_rng(0), n_runs=4)
    r = sc.run(2)
    assert isinstance(r, ScenarioRun) and r.index == 2 and r.n_steps == sc.n_steps
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(r, name), getattr(sc, name)[2])
    np.testing.assert_array_equal(r.dr_positions, sc.dr_positions[2])
    assert sc.run(-1).index == 3
    with pytest.raises(IndexError):
        sc.run(4)
    with pytest.raises(TypeError, match="i must be an integer"):
        sc.run(1.0)


def test_scenario_arrays_are_read_only():
    sc = circling_scenario(np.random.default_rng(0), duration=100.0)
    for name in FIELDS + ["times"]:
        with pytest.raises(ValueError):
            getattr(sc, name)[..., 0] = 0


def test_scenario_validates_hand_built_arrays():
    m, k = 2, 5
    good = dict(times=np.arange(k, dtype=float), true_positions=np.zeros((m, k, 2)),
                dr_displacements=np.zeros((m, k, 2)), beacon_positions=np.zeros((m, k, 2)),
                true_ranges=np.ones((m, k)), ranges=np.ones((m, k)), range_errors=np.zeros((m, k)))
    sc = Scenario(**good)
    assert sc.description == "" and sc.outlier_mask.shape == (m, k) and not sc.outlier_mask.any()
    # NaN marks a missing range (e.g. a dropped ping) and is accepted
    dropped = dataclasses.replace(sc, ranges=np.where(np.arange(k) == 2, np.nan, 1.0) * np.ones((m, k)))
    assert np.isnan(dropped.ranges[:, 2]).all()
    for name, bad in [("times", np.arange(k - 1, dtype=float)), ("dr_displacements", np.zeros((m, k, 3))),
                      ("beacon_positions", np.zeros((m + 1, k, 2))), ("true_ranges", -np.ones((m, k))),
                      ("ranges", np.full((m, k), np.inf)), ("range_errors", np.zeros(k)),
                      ("outlier_mask", np.zeros((m, k)))]:
        with pytest.raises(ValueError, match=name if name != "times" else "true_positions"):
            Scenario(**{**good, name: bad})


# --- paper scenarios -------------------------------------------------------------------------------------------

@pytest.mark.parametrize("builder", BUILDERS)
def test_paper_scenarios_reproducible_and_batched(builder):
    a = builder(np.random.default_rng(42), n_runs=3)
    b = builder(np.random.default_rng(42), n_runs=3)
    c = builder(np.random.default_rng(43), n_runs=3)
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert not np.array_equal(a.ranges, c.ranges)
    assert not np.array_equal(a.dr_displacements, c.dr_displacements)
    # M runs with independent noise on a shared true track
    np.testing.assert_array_equal(a.true_positions[0], a.true_positions[2])
    assert not np.array_equal(a.range_errors[0], a.range_errors[1])
    assert not np.array_equal(a.dr_displacements[0], a.dr_displacements[1])
    np.testing.assert_allclose(a.ranges, a.true_ranges + a.range_errors)
    np.testing.assert_allclose(a.true_ranges, np.hypot(*np.moveaxis(a.true_positions - a.beacon_positions, -1, 0)))
    assert a.description


def test_circling_scenario_shapes_and_error_budget():
    sc = circling_scenario(np.random.default_rng(0), n_runs=200)
    assert_shapes(sc, 200, 2001)
    np.testing.assert_allclose(sc.true_ranges, 1500.0)
    np.testing.assert_allclose(np.diff(sc.times), 5.0)
    # mean error = gamma r + bias mean = 7.5 + 5
    assert sc.range_errors.mean() == pytest.approx(12.5, abs=0.5)
    # white + slow parts: std^2 = 5 + 3^2
    assert sc.range_errors.std() == pytest.approx(np.sqrt(14.0), rel=0.05)


def test_approach_with_turn_scenario_matches_paper_d():
    sc = approach_with_turn_scenario(np.random.default_rng(0), n_runs=500)
    assert_shapes(sc, 500, 151)
    # reception times: pings every 10 s delayed by the travel time, hence not equally spaced
    pings = np.arange(151) * 10.0
    np.testing.assert_allclose(sc.times - pings, sc.true_ranges[0] / 1500.0, rtol=1e-9)
    assert np.ptp(np.diff(sc.times)) > 1e-3
    t_r, r = reception_times(pings, (0.0, 0.0), lambda t: np.stack([np.interp(t, sc.times, sc.true_positions[0, :, 0]),
                                                                    np.interp(t, sc.times, sc.true_positions[0, :, 1])],
                                                                   axis=-1), 1500.0)
    np.testing.assert_allclose(t_r[1:-1], sc.times[1:-1], atol=1e-6)
    speeds = np.hypot(*np.diff(sc.true_positions[0], axis=0).T) / np.diff(sc.times)
    np.testing.assert_allclose(speeds[speeds > 1.99], 2.0)               # 2 m/s except across the turn's chord
    headings = np.arctan2(*np.diff(sc.true_positions[0], axis=0).T[::-1])
    assert np.rad2deg(headings[-1] - headings[0]) == pytest.approx(45.0)  # one heading change
    assert sc.true_ranges[0, -1] < sc.true_ranges[0, 0]                   # approach
    # multiplicative error: mean -2 % of the range; DR noise variance 0.81
    rel = sc.range_errors / sc.true_ranges
    assert rel.mean() == pytest.approx(-0.02, abs=2e-4)
    dr_err = sc.dr_displacements[:, 1:] - np.diff(sc.true_positions, axis=1)
    assert dr_err.var() == pytest.approx(0.81, rel=0.03)
    model = SoundSpeedMismatch()
    resid = sc.range_errors - model.mean_error(sc.true_ranges)
    np.testing.assert_allclose(resid.var(axis=0).mean(),
                               np.mean(model.error_std(sc.true_ranges[0]) ** 2 + 0.49), rtol=0.05)


def test_ship_and_submersible_scenario_matches_paper_e():
    sc = ship_and_submersible_scenario(np.random.default_rng(0), n_runs=20)
    assert_shapes(sc, 20, 1201)
    np.testing.assert_allclose(np.diff(sc.times), 1.0)
    np.testing.assert_allclose(np.diff(sc.true_positions[0], axis=0), 1.0)        # 1 m/s north and east
    ship = s_turn_track(sc.times, (0.0, 0.0), 2 * np.sqrt(2), np.pi / 4, -np.deg2rad(0.3), 600.0)
    np.testing.assert_allclose(sc.beacon_positions[5], ship.positions)
    expected = np.zeros(1201, dtype=bool)
    expected[300:310] = expected[700:720] = True
    np.testing.assert_array_equal(sc.outlier_mask, np.broadcast_to(expected, (20, 1201)))
    big = np.abs(sc.range_errors) > 40.0
    np.testing.assert_array_equal(big, sc.outlier_mask)
    assert np.all(sc.range_errors[:, 300:310] > 40.0)
    assert (sc.range_errors[:, 700:720] < -40.0).any()
    assert sc.range_errors[:, ~expected].std() == pytest.approx(np.sqrt(2.0), rel=0.05)
    assert sc.true_ranges.min() > 1000.0


def test_ship_scenario_rejects_mismatched_outlier_lists():
    with pytest.raises(ValueError, match="same length"):
        ship_and_submersible_scenario(np.random.default_rng(0), outlier_counts=(10,))


@pytest.mark.parametrize("builder, kwargs, exc, name", [
    (circling_scenario, {"radius": -1.0}, ValueError, "radius"),
    (circling_scenario, {"gamma": 2.0}, ValueError, "gamma"),
    (circling_scenario, {"interval": 0.0}, ValueError, "interval"),
    (circling_scenario, {"bias_time_constant": 0.0}, ValueError, "time_constant"),
    (approach_with_turn_scenario, {"headings": (0.0,)}, ValueError, "headings"),
    (approach_with_turn_scenario, {"assumed_speed": np.nan}, ValueError, "assumed_speed"),
    (approach_with_turn_scenario, {"duration": -5.0}, ValueError, "duration"),
    (ship_and_submersible_scenario, {"sub_velocity": (1.0,)}, ValueError, "sub_velocity"),
    (ship_and_submersible_scenario, {"outlier_amplitude": -80.0}, ValueError, "amplitude"),
    (ship_and_submersible_scenario, {"n_runs": 0}, ValueError, "n_runs"),
])
def test_paper_scenarios_reject_bad_input(builder, kwargs, exc, name):
    with pytest.raises(exc, match=name):
        builder(np.random.default_rng(0), **kwargs)


@pytest.mark.parametrize("builder", BUILDERS)
def test_paper_scenarios_require_a_generator(builder):
    with pytest.raises(TypeError, match="rng"):
        builder(0)



def test_paper_d_make_takes_a_parameter_set_as_params():
    from uwtutor.scenarios import paper_d

    quiet = paper_d.PaperDParameters(R=0.0, speed_sigma=0.0, Q=0.0)
    sc = paper_d.make(np.random.default_rng(1), 2, params=quiet, duration=200.0)
    # no noise, no speed scatter: the errors are the pure scale error of the mean speed
    np.testing.assert_allclose(sc.range_errors, (quiet.mu_gamma_true - 1.0) * sc.true_ranges, rtol=1e-9)
    np.testing.assert_allclose(sc.dr_displacements[:, 1:], np.diff(sc.true_positions, axis=1), atol=1e-9)
    # the default is the paper's own set, and the same seed gives the same draws
    same = paper_d.make(np.random.default_rng(1), 2, duration=200.0)
    np.testing.assert_array_equal(same.ranges,
                                  paper_d.make(np.random.default_rng(1), 2, paper_d.PARAMETERS, duration=200.0).ranges)
    with pytest.raises(TypeError, match="params must be a uwtutor.scenarios.paper_d.PaperDParameters"):
        paper_d.make(np.random.default_rng(0), 1, params={"R": 0.0})


def test_suite_geometries_count_their_runs_as_n_runs():
    from uwtutor.scenarios import suite

    for name, scenario in suite.SCENARIOS.items():
        by_position = scenario(np.random.default_rng(3), 2)
        by_keyword = scenario(np.random.default_rng(3), n_runs=2, params=suite.PARAMETERS)
        assert by_position.n_runs == 2, name
        np.testing.assert_array_equal(by_position.positions, by_keyword.positions)
    with pytest.raises(ValueError, match="n_runs must be"):
        suite.circle(np.random.default_rng(0), 0)
    # crlb_inputs passes its n_tracks as the scenario's n_runs, and names its own argument when it is too many
    with pytest.raises(ValueError, match="n_tracks asks for"):
        suite.crlb_inputs("circle", "white", n_tracks=10**8)
