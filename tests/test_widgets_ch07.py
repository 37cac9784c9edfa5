"""Chapter 7 widget: the bias-tracking view's compute function (tested without a UI), its plot and its panel."""

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402

from uwtutor import widgets  # noqa: E402
from uwtutor.pipelines import prepositioned_bias_ekf  # noqa: E402
from uwtutor.models import paper_a_process_noise  # noqa: E402
from uwtutor.scenarios import paper_a  # noqa: E402
from uwtutor.widgets import ch07  # noqa: E402
from widget_refinement import moved_pictures  # noqa: E402


def test_registered_compute_function_runs_at_its_defaults():
    assert widgets.COMPUTE_FUNCTIONS["ch07 bias tracking"] is ch07.bias_tracking_view
    view = ch07.bias_tracking_view()
    K = len(view.times)
    assert K == 2000 and view.n_runs == 30
    assert view.truth.shape == (K, 2) and view.estimate.shape == (K, 3)
    for name in ("bias_sigma", "true_bias", "rmse", "rmse_unstarted"):
        assert getattr(view, name).shape == (K,)
    k0 = view.start_epochs
    assert k0.shape == (30,) and (k0 > 100).all() and (k0 < 400).all()
    assert np.isnan(view.estimate[:k0[0]]).all() and np.isfinite(view.estimate[k0[0]:]).all()
    assert np.isnan(view.rmse[:k0.max()]).all() and np.isfinite(view.rmse[k0.max():]).all()
    assert view.final_rmse < 30.0


def test_view_matches_the_library_and_is_reproducible():
    a = ch07.bias_tracking_view(n_runs=5, n_obs=800, seed=2, initial_error=100.0)
    b = ch07.bias_tracking_view(n_runs=5, n_obs=800, seed=2, initial_error=100.0)
    np.testing.assert_array_equal(a.estimate, b.estimate)
    # recomputed here: the same draws, the same start, the same filter
    rng = np.random.default_rng(2)
    params = paper_a.PaperAParameters(n_obs=800)
    sc, bias = paper_a.make_with_truth(rng, 5, params)
    d = rng.normal(size=(5, 2))
    start = sc.true_positions[0, 0] + 100.0 * d / np.linalg.norm(d, axis=1, keepdims=True)
    res = prepositioned_bias_ekf(start, np.eye(3), sc.dr_displacements, sc.ranges, paper_a_process_noise(1.0),
                                 5.0)
    np.testing.assert_allclose(a.estimate, res.x[0], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(a.true_bias, bias[0])
    np.testing.assert_array_equal(a.start_epochs, np.argmax(res.extras["started"], axis=1))


def test_a_fast_drift_and_a_strict_threshold_do_what_the_chapter_says():
    base = ch07.bias_tracking_view(n_runs=10, n_obs=1500)
    drift = ch07.bias_tracking_view(n_runs=10, n_obs=1500, drift_rate=0.03)
    assert drift.final_rmse > 1.3 * base.final_rmse
    late = ch07.bias_tracking_view(n_runs=10, n_obs=1500, max_alpha=0.5)
    assert late.start_epochs.min() > base.start_epochs.max()
    # with a good guess the paper's start from epoch 0 is fine; from 300 m off it is still far off at epoch 400
    far = ch07.bias_tracking_view(n_runs=10, n_obs=1500, initial_error=300.0)
    assert far.rmse_unstarted[400] > 2 * far.rmse[400]


@pytest.mark.parametrize("kw, match", [
    (dict(drift_rate=np.nan), "drift_rate must be finite"),
    (dict(initial_error=-1.0), "initial_error must be >= 0"),
    (dict(max_alpha=0.0), "max_alpha must be > 0"),
    (dict(n_runs=1), "n_runs must be >= 2"),
    (dict(n_obs=100), "n_obs must be >= 600"),
    (dict(drift_rate=5.0), "drift_rate must be <= 1"),
    (dict(drift_rate=-0.5, n_runs=2, n_obs=2000), "drift_rate = -0.5 m/s makes the measured range negative"),
    (dict(initial_error=1e300), "initial_error must be <= 1e"),
    (dict(n_runs=10**12), "n_runs asks for"),
])
def test_bad_parameters(kw, match):
    with pytest.raises(ValueError, match=match):
        ch07.bias_tracking_view(**kw)


def test_plot_and_panel():
    view = ch07.bias_tracking_view(n_runs=3, n_obs=600)
    fig = ch07.plot_bias_tracking_view(view)
    assert len(fig.axes) == 3
    plt.close(fig)
    panel = ch07.bias_tracking_widget()
    assert type(panel).__name__ == "VBox"
    plt.close("all")


def _within(ax, values):
    lo, hi = sorted(ax.get_ylim())
    finite = np.asarray(values)[np.isfinite(values)]
    return lo <= finite.min() and finite.max() <= hi


def test_updated_panels_follow_the_data():
    # the bias panel kept its limits at a small drift, then must grow with the bias of a larger one; the RMSE panel
    # must show the start of a larger initial error (limits set to keep them must not switch autoscaling off)
    small = dict(n_runs=4, n_obs=1000)
    fig = ch07.plot_bias_tracking_view(ch07.bias_tracking_view(**small))
    _, ax_b, ax_r = fig.axes[:3]
    for rate in (0.005, 0.03, 0.05):
        view = ch07.bias_tracking_view(drift_rate=rate, **small)
        ch07.update_bias_tracking_view(fig, view)
        assert _within(ax_b, view.true_bias), (rate, ax_b.get_ylim(), np.nanmax(view.true_bias))
        assert _within(ax_b, view.estimate[:, 2])
    for d0 in (160.0, 300.0, 500.0):
        view = ch07.bias_tracking_view(drift_rate=0.05, initial_error=d0, **small)
        ch07.update_bias_tracking_view(fig, view)
        assert _within(ax_r, view.rmse_unstarted), (d0, ax_r.get_ylim(), view.rmse_unstarted[0])
        assert _within(ax_r, view.rmse)
    plt.close(fig)


def test_the_early_view_is_the_full_view_on_its_epochs(monkeypatch):
    # the widget's first answer for a new setting: the same runs, filters over the first epochs only
    monkeypatch.setattr(ch07, "_CURVES", {})               # nothing at hand yet
    first = ch07._early_view(0.01, 200.0, 2.0)
    first_full = ch07.bias_tracking_view(drift_rate=0.01, initial_error=200.0)
    # an α move: the IEKF from the start at hand, whole; the pre-positioned one over more epochs
    later = ch07._early_view(0.01, 200.0, 3.0)
    full_later = ch07.bias_tracking_view(drift_rate=0.01, initial_error=200.0, max_alpha=3.0)
    for early, full, E in ((first, first_full, ch07.EARLY_EPOCHS[0]), (later, full_later, ch07.EARLY_EPOCHS[1])):
        assert early.epochs_run == E and full.epochs_run is None and np.isnan(early.final_rmse)
        for name in ("estimate", "bias_sigma", "rmse", "true_bias"):
            np.testing.assert_array_equal(getattr(early, name)[:E], getattr(full, name)[:E])
            assert np.isnan(getattr(early, name)[E:]).all()
        K = len(full.times)
        assert np.array_equal(early.start_epochs, np.where(full.start_epochs < E, full.start_epochs, K))
    np.testing.assert_array_equal(first.rmse_unstarted[:200], first_full.rmse_unstarted[:200])
    assert np.isnan(first.rmse_unstarted[200:]).all()
    np.testing.assert_array_equal(later.rmse_unstarted, full_later.rmse_unstarted)


def test_the_panel_refined_in_the_background_ends_as_computed_at_once(monkeypatch):
    coarse, refined, at_once = moved_pictures(monkeypatch, ch07.bias_tracking_widget,
                                              lambda panel: panel.children[0].children[1], 160.0)   # initial error
    assert refined == at_once and coarse != at_once
    plt.close("all")


def test_a_full_answer_cancelled_mid_way_keeps_nothing_half_done(monkeypatch):
    # the widget's refinement for a setting the reader has left stops at a filter loop's checkpoint: nothing of it
    # may stay in the caches, and the setting computed later is the one computed in one go
    from uwtutor._cancel import Cancelled, cancel_when

    small = dict(drift_rate=0.02, initial_error=120.0, n_runs=4, n_obs=800)
    monkeypatch.setattr(ch07, "_CURVES", {})
    calls = []
    with cancel_when(lambda: calls.append(1) and False):
        whole = ch07.bias_tracking_view(**small)
    ch07._CURVES.clear()
    # stopped in the pre-positioned IEKF (it runs first), then in the IEKF from the start (it runs last)
    for stop_at in (10, len(calls) - 10):
        asked = []
        with pytest.raises(Cancelled), cancel_when(lambda: asked.append(1) or len(asked) >= stop_at):
            ch07.bias_tracking_view(**small)
        assert ch07._CURVES == {}
    again = ch07.bias_tracking_view(**small)
    for name in ("estimate", "bias_sigma", "rmse", "rmse_unstarted", "start_epochs"):
        np.testing.assert_array_equal(getattr(again, name), getattr(whole, name))
