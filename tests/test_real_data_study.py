"""Chapter 11's study: a sample of the committed runs re-run and matched; the pieces it is made of."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

gtsam = pytest.importorskip("gtsam", reason="the Plaza data and GTSAM come with uwtutor[data]")

from uwtutor.datasets import RangeDataset, navigate, navigation_models, plaza  # noqa: E402
from uwtutor.datasets import baselines, study as st  # noqa: E402
from uwtutor.datasets.factor_graph import gtsam_map  # noqa: E402
from uwtutor.filters import ChiSquareGate, ReacquiringGate, extended_kalman_filter  # noqa: E402


@pytest.fixture(scope="module")
def P2():
    return plaza(2)


@pytest.fixture(scope="module")
def committed():
    return st.load_real_data_study()


def test_committed_study_is_complete(committed):
    methods = {(r["set"], r["method"], r["beacons"], r["rate"]) for r in committed.table}
    for s in ("Plaza 1", "Plaza 2"):
        for rate in ("full", "10 s"):
            for m in st.TABLE_METHODS:
                assert (s, m, "one", rate) in methods
            for m in ("odometry alone", "EKF", "IEKF", "navigate", "navigate, RTS", "GTSAM, scale removed"):
                assert (s, m, "four", rate) in methods
    assert {(r["method"], r["variant"]) for r in committed.ablation} == {
        (m, v) for m in st.ABLATION_METHODS + ("GTSAM",) for v in st.ABLATION_VARIANTS}
    shape = (len(st.GRID_BEACONS), len(st.GRID_PERIODS), len(st.GRID_STATES))
    assert committed.grid["measures"]["filter_rmse"].shape == shape
    assert committed.grid["curves"]["xy"].shape == shape + (410, 2)
    assert committed.info["most_heard_beacon"] == {"Plaza 1": 0, "Plaza 2": 5}
    with pytest.raises(KeyError, match="no table row"):
        committed.row("Plaza 2", "ISFEKF", "four")


def test_a_sample_of_the_table_reproduces(P2, committed):
    scale = st.measured_scale(P2)
    runs = {
        ("EKF", "one", "full"): baselines.position_ekf(P2, [5]).positions,
        ("EKF", "four", "10 s"): baselines.position_ekf(P2, min_period=10.0).positions,
        ("OR-VMLBL-KF", "one", "full"): baselines.vmlbl_filter(P2, [5]).positions,
        ("particle filter", "one", "10 s"): baselines.particle_filter(
            P2, [5], rng=np.random.default_rng(st.PF_SEED), min_period=10.0).positions,
        ("GTSAM, scale removed", "four", "full"): gtsam_map(P2, range_scale=scale, model="pose").poses,
    }
    for (method, beacons, rate), x in runs.items():
        row = committed.row("Plaza 2", method, beacons, rate)
        got = st.error_summary(x, P2.truth)
        for key in ("rmse", "median", "final", "within"):
            assert got[key] == pytest.approx(row[key], rel=1e-4, abs=1e-5), (method, beacons, rate, key)


def test_a_sample_of_the_grid_and_the_sweep_reproduce(P2, committed):
    run = st.navigation_run(P2, "1", 10.0, "+ scale")
    i, j, k = st.GRID_BEACONS.index("1"), st.GRID_PERIODS.index(10.0), st.GRID_STATES.index("+ scale")
    for key in ("rmse", "median", "nees_position", "consistent_pose"):
        assert run["filter"][key] == pytest.approx(committed.grid["measures"][f"filter_{key}"][i, j, k], rel=1e-4)
    assert run["smoother"]["rmse"] == pytest.approx(committed.grid["measures"]["smoother_rmse"][i, j, k], rel=1e-4)
    np.testing.assert_allclose(run["curves"]["error"], committed.grid["curves"]["error"][i, j, k], rtol=1e-4,
                               atol=1e-4)
    row = next(r for r in committed.sweep if r["beacon"] == "all" and r["heading_noise"] == 1e-3
               and not r["scale_removed"] and r["initial"] == "dead reckoning")
    assert st.error_summary(gtsam_map(P2, heading_noise=1e-3, model="pose").poses, P2.truth)["rmse"] == pytest.approx(
        row["rmse"], rel=1e-4)


def test_the_committed_findings_the_chapter_states(committed):
    one = committed.row("Plaza 2", "navigate")
    assert one["rmse"] < 3.0 < 20.0 < committed.row("Plaza 2", "EKF")["rmse"]
    assert committed.row("Plaza 2", "navigate", "four")["rmse"] < 0.5
    ab = {(r["method"], r["variant"]): r["rmse"] for r in committed.ablation}
    for m in st.ABLATION_METHODS:
        assert ab[(m, "true heading")] < ab[(m, "as logged")], m
    assert ab[("EKF", "both")] < 2.0
    truth_start = [r for r in committed.sweep if r["initial"] == "truth"]
    for r in truth_start:         # the graph's optimum, whatever the start
        same = next(s for s in committed.sweep if s["initial"] == "dead reckoning" and s["beacon"] == r["beacon"]
                    and s["scale_removed"] == r["scale_removed"] and s["heading_noise"] == r["heading_noise"])
        assert r["rmse"] == pytest.approx(same["rmse"], rel=0.05)


def test_save_and_load_round_trip(tmp_path, committed):
    committed.save(tmp_path)
    again = st.RealDataStudy.load(tmp_path)
    assert again.table == committed.table and again.ablation == committed.ablation and again.info == committed.info
    for key, value in committed.grid["curves"].items():
        np.testing.assert_array_equal(again.grid["curves"][key], value)
    json.loads((tmp_path / st.STUDY_FILES["json"]).read_text())


# -- the pieces --------------------------------------------------------------------------------------------------------
def test_navigation_models_are_what_navigate_filters_with(P2):
    m = navigation_models(P2, [1], min_period=10.0)
    mine = extended_kalman_filter(m.motion, m.measurement, m.x0, m.P0, P2.odometry, m.z, times=P2.times,
                                  gate=ReacquiringGate(ChiSquareGate(0.999, per_component=True), patience=10))
    theirs = navigate(P2, [1], min_period=10.0, smooth=True)
    # the same model and gate, so the same numbers up to the order of floating-point sums (BLAS kernels differ from
    # one CPU to the next): a different model or gate would differ by centimetres to metres, not 1e-9 m
    np.testing.assert_allclose(mine.x, theirs.extras["filtered"].x, rtol=0, atol=1e-9)
    np.testing.assert_allclose(theirs.x_prior, mine.x_prior, rtol=0, atol=1e-9)
    assert not np.array_equal(theirs.x, mine.x), "smooth=True returns the smoothed x"
    with pytest.raises(ValueError, match="start pose"):
        navigation_models(dataclasses.replace(P2, start=None, truth=None))


def test_single_beacon_methods_refuse_several(P2):
    for method in (baselines.fading_filter, baselines.vmlbl_filter):
        with pytest.raises(ValueError, match="one beacon"):
            method(P2, [0, 1])
    with pytest.raises(ValueError, match="one beacon"):
        baselines.particle_filter(P2, rng=np.random.default_rng(0))
    with pytest.raises(TypeError, match="rng must be"):
        baselines.particle_filter(P2, [1], rng=1)


def test_baselines_on_a_clean_log_are_good():
    # a square driven twice, exact odometry, ranges to one beacon without error: the position-only methods work
    K = 801
    turn = np.where(np.arange(K) % 100 == 1, np.pi / 2, 0.0)
    turn[:2] = 0.0
    odo = np.column_stack([np.r_[0.0, np.full(K - 1, 0.5)], turn])
    track = RangeDataset(times=0.5 * np.arange(K), odometry=odo, ranges=np.zeros((0, 3)), beacons={3: (10.0, 30.0)},
                         start=[0.0, 0.0, 0.0]).dead_reckoning()
    heard = np.arange(1, K, 2)
    r = np.hypot(*(track[heard, :2] - [10.0, 30.0]).T)
    data = RangeDataset(times=0.5 * np.arange(K), odometry=odo,
                        ranges=np.column_stack([0.5 * heard, np.full(heard.size, 3), r]), beacons={3: (10.0, 30.0)},
                        truth=track)
    for run in (baselines.position_ekf(data), baselines.bias_iekf(data), baselines.fading_filter(data),
                baselines.particle_filter(data, rng=np.random.default_rng(1))):
        assert st.error_summary(run.positions, track)["rmse"] < 0.5, run.name
    np.testing.assert_allclose(baselines.world_displacements(data).sum(axis=0), track[-1, :2] - track[0, :2],
                               atol=1e-9)


def test_log_variants_and_measures(P2):
    s = st.measured_scale(P2)
    clean = st.without_scale(P2, s)
    assert st.measured_scale(clean) == pytest.approx(1.0, abs=1e-12)
    heading = st.with_true_heading(P2)
    assert np.abs(np.angle(np.exp(1j * (heading.dead_reckoning()[:, 2] - P2.truth[:, 2])))).max() < 1e-9
    assert st.most_heard_beacon(P2) == 5
    x = np.array([[0.0, 0.0, np.pi - 0.1]] * 2)
    P = np.tile(np.diag([1.0, 4.0, 0.01]), (2, 1, 1))
    truth = np.array([[1.0, 2.0, -np.pi + 0.1]] * 2)
    np.testing.assert_allclose(st.nees(x, P, truth), 1.0 + 1.0 + 4.0)
    np.testing.assert_allclose(st.nees(x, P, truth, "position"), 2.0)
    np.testing.assert_allclose(st.nees(x, P, truth, "heading"), 4.0)
    with pytest.raises(ValueError, match="components must be"):
        st.nees(x, P, truth, "scale")
