"""Paper E's OR-VMLBL-KF pipeline and error budget: exact fixes without noise, stages, batching, Fig. 6."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from uwtutor import lsq
from uwtutor.errors import IllConditionedWarning
from uwtutor.pipelines import NoUsableFixError, epoch_windows, or_vmlbl_kf, vmlbl_error_budget
from uwtutor.scenarios import paper_e

NO_OUTLIERS = {"outlier_onsets": (), "outlier_counts": (), "outlier_two_sided": ()}


def test_noise_free_virtual_beacon_fixes_are_exact():
    dive = paper_e.make(np.random.default_rng(0), 1, range_noise_variance=0.0, dr_sigma=0.0, **NO_OUTLIERS)
    truth = np.asarray(dive.true_positions[0])
    out = or_vmlbl_kf(dive.dr_positions[0], dive.true_slant_ranges[0], ship_positions=dive.ship_positions[0],
                      depth=dive.depth,
                      preprocess=False)
    np.testing.assert_allclose(out.fixes, truth[out.now], rtol=0, atol=1e-6)
    # the DR positions need only be right up to a constant offset
    shifted = or_vmlbl_kf(dive.dr_positions[0] + [500.0, -70.0], dive.true_slant_ranges[0],
                          ship_positions=dive.ship_positions[0],
                          depth=dive.depth, preprocess=False)
    np.testing.assert_allclose(shifted.fixes, truth[out.now], rtol=0, atol=1e-6)


def test_epoch_windows():
    now, index = epoch_windows(1201, 100)
    assert now[0] == 300 and now[-1] == 1200 and index.shape == (901, 4)
    assert index[0].tolist() == [0, 100, 200, 300]
    np.testing.assert_array_equal(index[:, -1], now)
    with pytest.raises(ValueError, match="needs 4 epochs 100 steps apart"):
        epoch_windows(250, 100)


def test_pipeline_stages_and_their_gains():
    dive = paper_e.make(np.random.default_rng(58), 20)
    out = or_vmlbl_kf(dive.dr_positions, dive.slant_ranges, ship_positions=dive.ship_positions, depth=dive.depth,
                      smooth=True)
    raw = or_vmlbl_kf(dive.dr_positions, dive.slant_ranges, ship_positions=dive.ship_positions, depth=dive.depth,
                      preprocess=False)
    truth = np.asarray(dive.true_positions)[:, out.now]

    def rms(p):
        return float(np.sqrt(np.nanmean(np.sum((p - truth) ** 2, axis=-1))))

    # outlier rejection, then the cascade filter, then the smoother: each stage helps
    assert rms(raw.fixes) > 2 * rms(out.fixes)
    assert rms(out.fixes) > 2 * rms(out.filtered)
    assert rms(out.filtered) > rms(out.smoothed.x[..., :2])
    assert out.ranges.extras["outlier"][np.asarray(dive.outlier_mask)].mean() > 0.99
    np.testing.assert_array_equal(out.fix_times, dive.times[out.now])
    assert out.fix_cov.shape == (20, len(out.now), 2, 2)


def test_pipeline_batched_run_equals_single_run():
    dive = paper_e.make(np.random.default_rng(5), 3)
    batch = or_vmlbl_kf(dive.dr_positions, dive.slant_ranges, ship_positions=dive.ship_positions, depth=dive.depth,
                        smooth=True)
    single = or_vmlbl_kf(dive.dr_positions[2], dive.slant_ranges[2], ship_positions=dive.ship_positions[2],
                         depth=dive.depth,
                         smooth=True)
    np.testing.assert_allclose(single.fixes, batch.fixes[2], rtol=0, atol=1e-9)
    np.testing.assert_allclose(single.filtered, batch.filtered[2], rtol=0, atol=1e-9)
    np.testing.assert_allclose(single.smoothed.x, batch.smoothed.x[2], rtol=0, atol=1e-9)
    np.testing.assert_array_equal(single.track.extras["outlier"], batch.track.extras["outlier"][2])


def test_pipeline_bad_input():
    dive = paper_e.make(np.random.default_rng(5), 1)
    with pytest.raises(ValueError, match="ship_positions must have one horizontal position per range"):
        or_vmlbl_kf(dive.dr_positions[0], dive.slant_ranges[0], ship_positions=dive.ship_positions[0][:-1],
                    depth=dive.depth)
    with pytest.raises(ValueError, match="ranges must be finite and >= 0"):
        or_vmlbl_kf(dive.dr_positions[0], -dive.slant_ranges[0], ship_positions=dive.ship_positions[0],
                    depth=dive.depth)


def test_error_budget_is_linear_in_each_source_and_blind_to_the_depth():
    dive = paper_e.make(np.random.default_rng(0))
    levels = np.array([1.0, 2.0, 4.0])
    b = vmlbl_error_budget(np.random.default_rng(1), dive.ship_positions[0], dive.true_positions[0],
                           depth=dive.depth, levels=levels, n_runs=6000)
    assert b.sources == ("virtual beacon", "range", "depth") and b.runs_per_level == 2000
    vb, rng_, depth = b.rms
    for row in (vb, rng_):                                      # linear: twice the error, twice the position error
        np.testing.assert_allclose(row / levels, row[0], rtol=0.1)
    assert b.slope[1] > b.slope[0] > 5.0
    assert np.all(depth < 1e-6)                                 # a surface ship: the depth cancels
    # the same geometry with the fix computed directly: the range slope is the noise gain's
    now, index = epoch_windows(len(dive.times), 100)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", lsq.IllConditionedWarning)
        ship, truth = np.asarray(dive.ship_positions[0]), np.asarray(dive.true_positions[0])
        r = np.hypot(np.linalg.norm(truth[index] - ship[index], axis=-1), dive.depth)
        gain = lsq.virtual_beacon_lsq(r, ship[index], truth[index], depth=dive.depth).noise_gain
    assert b.slope[1] == pytest.approx(np.sqrt(np.mean(gain**2)), rel=0.1)


def _suite_ranges(scenario, n, seed):
    from uwtutor.scenarios import suite

    rng = np.random.default_rng(seed)
    inputs, _ = suite.white(rng, suite.SCENARIOS[scenario](rng, n))
    return inputs.z, inputs.beacon, inputs.dr_track(), inputs.times


@pytest.mark.filterwarnings("ignore:the virtual-beacon least-squares problem is singular")
def test_runs_without_any_fix_get_a_nan_track_and_a_warning():
    # a straight DR track to a fixed beacon has collinear virtual beacons in every window: no fix at all
    z_c, b_c, dr_c, t = _suite_ranges("circle", 3, 1)
    z_l, b_l, dr_l, _ = _suite_ranges("line", 2, 1)
    z, b, dr = (np.concatenate(pair) for pair in ((z_c, z_l), (b_c, b_l), (dr_c, dr_l)))
    alone = or_vmlbl_kf(dr_c, z_c, ship_positions=b_c, depth=0.0, times=t, spacing=20, range_options=dict(test="chi2"))
    with pytest.warns(IllConditionedWarning, match="2 of 5 runs have no usable virtual-beacon fix"):
        mixed = or_vmlbl_kf(dr, z, ship_positions=b, depth=0.0, times=t, spacing=20, range_options=dict(test="chi2"))
    assert np.isnan(mixed.track.x[3:]).all() and np.isfinite(mixed.track.x[:3]).all()
    np.testing.assert_array_equal(mixed.track.x[:3], alone.track.x)     # the other runs are unaffected
    assert not mixed.track.extras["accepted"][3:].any()


@pytest.mark.filterwarnings("ignore:the virtual-beacon least-squares problem is singular")
def test_no_fix_in_any_run_is_a_clear_error():
    z, b, dr, t = _suite_ranges("line", 2, 1)
    with pytest.raises(NoUsableFixError, match="no run has a single usable virtual-beacon fix"):
        or_vmlbl_kf(dr, z, ship_positions=b, depth=0.0, times=t, spacing=20)
    assert issubclass(NoUsableFixError, ValueError)


def test_a_filtered_range_below_zero_near_the_beacon_is_read_as_zero():
    # closing on the beacon at 5 m/s and stopping there: the constant-velocity range filter overshoots below zero
    t = np.arange(1.0, 201.0)
    z = np.abs(np.maximum(300.0 - 5.0 * t, 0.0) + np.random.default_rng(0).normal(0.0, 2.0, (3, t.size)))
    angle = 2.0 * np.pi * t / t.size
    ship = 50.0 * np.column_stack([np.cos(angle), np.sin(angle)])     # a ship that moves: the fixes exist
    dr = np.column_stack([np.minimum(5.0 * t, 300.0) - 300.0, np.zeros_like(t)])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IllConditionedWarning)        # the fixes themselves are not the point
        out = or_vmlbl_kf(dr, z, ship_positions=ship, depth=0.0, times=t, spacing=10)
    raw = out.ranges.x[..., 0]
    assert (raw < 0).any()                      # the case the clipping is for
    np.testing.assert_array_equal(out.used_ranges, np.maximum(raw, 0.0))


def test_pipeline_reuses_a_range_filter_result():
    # another spacing on the same ranges: the range filter's result given back gives the same answer
    dive = paper_e.make(np.random.default_rng(5), 2)
    args = dict(ship_positions=dive.ship_positions, depth=dive.depth, spacing=60)
    for i in (None, 1):                                   # batched, and one run
        pick = (lambda a: a) if i is None else (lambda a: a[i])
        kw = {**args, "ship_positions": pick(dive.ship_positions)}
        first = or_vmlbl_kf(pick(dive.dr_positions), pick(dive.slant_ranges), **{**kw, "spacing": 100})
        again = or_vmlbl_kf(pick(dive.dr_positions), pick(dive.slant_ranges), **kw, range_result=first.ranges)
        fresh = or_vmlbl_kf(pick(dive.dr_positions), pick(dive.slant_ranges), **kw)
        np.testing.assert_array_equal(again.filtered, fresh.filtered)
        np.testing.assert_array_equal(again.fixes, fresh.fixes)
        np.testing.assert_array_equal(again.ranges.x, fresh.ranges.x)
        np.testing.assert_array_equal(again.ranges.extras["outlier"], fresh.ranges.extras["outlier"])
    one = fresh.ranges                                    # after the loop: run 1's result, without a runs axis
    with pytest.raises(ValueError, match="preprocess=False"):
        or_vmlbl_kf(dive.dr_positions[1], dive.slant_ranges[1], **{**args, "ship_positions": dive.ship_positions[1]},
                    range_result=one, preprocess=False)
    with pytest.raises(ValueError, match="range_result"):
        or_vmlbl_kf(dive.dr_positions, dive.slant_ranges, **args, range_result=one)     # one run's, for two
