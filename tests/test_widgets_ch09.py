"""Chapter 9 widget: the OR-VMLBL-KF view's compute function (tested without a UI), its plot and its panel."""

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402

from uwtutor.filters import robust_range_kf  # noqa: E402
from uwtutor.scenarios import paper_e  # noqa: E402
from uwtutor.widgets import ch09  # noqa: E402
from widget_refinement import moved_pictures  # noqa: E402


def test_registered_compute_function_runs_at_its_defaults():
    assert ch09.COMPUTE_FUNCTIONS["ch09 OR-VMLBL-KF"] is ch09.outlier_view
    v = ch09.COMPUTE_FUNCTIONS["ch09 OR-VMLBL-KF"]()
    K = len(v.times)
    assert K == 1201 and v.outlier.sum() == 30
    for name in ("range_error", "plain_error", "robust_error", "outlier", "flagged"):
        assert getattr(v, name).shape == (K,)
    assert v.fix_error.shape == v.track_error.shape == v.fix_times.shape
    assert v.summary["flagged"] == 1.0 and v.summary["good_flagged"] == 0.0
    assert v.summary["rms_track"] < v.summary["rms_fix"]


def test_view_is_reproducible_and_matches_the_library():
    a = ch09.outlier_view(pattern="isolated", seed=3)
    b = ch09.outlier_view(pattern="isolated", seed=3)
    np.testing.assert_array_equal(a.robust_error, b.robust_error)
    # the view's standard KF is robust_range_kf without a test, on the view's ranges
    truth = paper_e.make(np.random.default_rng(3), 1).true_slant_ranges[0]      # the geometry needs no draws
    plain = robust_range_kf(truth + a.range_error, 1.0, test="none")
    np.testing.assert_allclose(plain.x[:, 0] - truth, a.plain_error, rtol=0, atol=1e-9)
    # a much wider test lets outliers through
    wide = ch09.outlier_view(pattern="isolated", seed=3, delta=0.3)
    assert wide.summary["flagged"] < a.summary["flagged"]


def test_standard_kf_is_pulled_off_and_the_robust_one_is_not():
    v = ch09.outlier_view()
    patch = v.outlier
    assert np.max(np.abs(v.plain_error[patch])) > 40.0
    assert np.max(np.abs(v.robust_error[patch])) < 15.0


def test_a_long_consistent_patch_is_taken_for_the_truth_by_reacquisition():
    v = ch09.outlier_view(pattern="long patch")
    assert v.summary["flagged"] < 0.5                     # the documented cost of re-acquisition after 20
    off = ch09.outlier_view(pattern="long patch", reacquire=False)
    assert off.summary["flagged"] == 1.0


@pytest.mark.parametrize("kw", [{"amplitude": -1.0}, {"pattern": "burst"}, {"delta": 0.0}, {"spacing": 5},
                                {"spacing": 400}, {"test": "median"}, {"reacquire": 1}, {"seed": -1}])
def test_bad_input_names_the_argument(kw):
    name = next(iter(kw))
    with pytest.raises((ValueError, TypeError), match=name):
        ch09.outlier_view(**kw)


def test_plot_and_panel():
    fig = ch09.plot_outlier_view(ch09.outlier_view(spacing=50))
    assert len(fig.axes) == 2
    plt.close(fig)
    panel = ch09.outlier_widget()
    assert len(panel.children) == 3
    plt.close("all")


def test_a_new_spacing_reuses_the_range_filter_and_gives_the_same_view(monkeypatch):
    monkeypatch.setattr(ch09, "_RANGE_RUNS", {})
    ch09.outlier_view(amplitude=60.0, spacing=200)                # the range filter kept
    reused = ch09.outlier_view(amplitude=60.0, spacing=250)
    monkeypatch.setattr(ch09, "_RANGE_RUNS", {})
    fresh = ch09.outlier_view(amplitude=60.0, spacing=250)
    for name in ("robust_error", "flagged", "fix_error", "track_error"):
        np.testing.assert_array_equal(getattr(reused, name), getattr(fresh, name))
    assert reused.summary == fresh.summary


def test_the_first_picture_shows_the_new_ranges_and_the_refined_one_is_as_computed_at_once(monkeypatch):
    early = ch09._measured_view(150.0, "paper", 0.03, 100, "paper", True)
    full = ch09.outlier_view(amplitude=150.0)
    assert not early.filtered and full.filtered
    np.testing.assert_array_equal(early.range_error, full.range_error)
    np.testing.assert_array_equal(early.outlier, full.outlier)
    assert np.isnan(early.robust_error).all() and not early.flagged.any() and np.isnan(early.summary["rms_fix"])

    coarse, refined, at_once = moved_pictures(monkeypatch, ch09.outlier_widget,
                                              lambda panel: panel.children[0].children[0], 150.0)   # outlier size
    assert refined == at_once and coarse != at_once
    plt.close("all")


def test_a_full_answer_cancelled_mid_way_keeps_nothing_half_done(monkeypatch):
    # the widget's refinement for a setting the reader has left stops at a filter loop's checkpoint: nothing of it
    # may stay in the caches, and the setting computed later is the one computed in one go
    from uwtutor._cancel import Cancelled, cancel_when

    monkeypatch.setattr(ch09, "_RANGE_RUNS", {})
    monkeypatch.setattr(ch09, "_PLAIN", {})
    calls = []
    with cancel_when(lambda: calls.append(1) and False):
        whole = ch09.outlier_view(amplitude=120.0, pattern="isolated")
    (range_run,) = ch09._RANGE_RUNS.values()
    ch09._RANGE_RUNS.clear()
    ch09._PLAIN.clear()
    # stopped in the range filter (it runs first), then in the standard KF (it runs last)
    for stop_at in (10, len(calls) - 10):
        asked = []
        with pytest.raises(Cancelled), cancel_when(lambda: asked.append(1) or len(asked) >= stop_at):
            ch09.outlier_view(amplitude=120.0, pattern="isolated")
        assert ch09._PLAIN == {}
        kept = list(ch09._RANGE_RUNS.values())          # the range filter's run: kept only once complete
        if stop_at == 10:
            assert kept == []
        else:
            np.testing.assert_array_equal(kept[0].x, range_run.x)
    again = ch09.outlier_view(amplitude=120.0, pattern="isolated")
    for name in ("robust_error", "plain_error", "fix_error", "track_error", "flagged"):
        np.testing.assert_array_equal(getattr(again, name), getattr(whole, name))
    assert again.summary == whole.summary
