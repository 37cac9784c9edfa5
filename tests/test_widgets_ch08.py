"""Chapter 8 widget: the cooperative view's compute function (tested without a UI), its plot and its panel."""

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402

from uwtutor.filters import cooperative_ekf  # noqa: E402
from uwtutor.scenarios import paper_b  # noqa: E402
from uwtutor.widgets import ch08  # noqa: E402
from widget_refinement import moved_pictures  # noqa: E402


def test_registered_compute_function_runs_at_its_defaults():
    assert ch08.COMPUTE_FUNCTIONS["ch08 cooperative EKF"] is ch08.cooperative_view
    view = ch08.COMPUTE_FUNCTIONS["ch08 cooperative EKF"]()
    K = len(view.times)
    assert view.n_runs == 100 and K == 312
    for name in ("estimate", "current_estimate", "current_sigma"):
        assert getattr(view, name).shape == (K, 2)
    for name in ("truth", "leader", "dr"):
        assert getattr(view, name).shape == (K + 1, 2)
    assert view.median_error.shape == (K,)
    assert np.all(view.current_sigma > 0)
    assert 0.0 <= view.lost_fraction <= 1.0
    # the defaults: a zigzag leader, the matched filter, paper B's current
    assert view.pattern == "zigzag" and not view.unobservable
    np.testing.assert_allclose(view.current, (0.5, 0.5), atol=1e-4)
    assert view.late_median_error < 30.0


def test_view_comes_from_the_library():
    view = ch08.cooperative_view(n_runs=5, seed=2, tuning="paper B")
    sc = paper_b.make(np.random.default_rng(2), 5, paper_b.PaperBParameters(current=view.current))
    tu = paper_b.paper_tuning()
    res = cooperative_ekf(sc.params.x1, tu.P1, sc.dr_displacements, sc.ranges, tu.Q, tu.R, leader=sc.leader_broadcast,
                          dt=8.0)
    np.testing.assert_allclose(view.estimate, res.x[0, :, :2])
    np.testing.assert_allclose(view.current_sigma, np.sqrt(np.diagonal(res.P[0], axis1=-2, axis2=-1)[:, 2:]))
    err = np.linalg.norm(res.x[..., :2] - sc.true_positions[1:], axis=-1)
    np.testing.assert_allclose(view.median_error, np.median(err, axis=0))


def test_parallel_leader_is_flagged_and_worse():
    par = ch08.cooperative_view(pattern="parallel", n_runs=20)
    zz = ch08.cooperative_view(pattern="zigzag", n_runs=20)
    assert par.unobservable and not zz.unobservable
    assert par.late_median_error > 10 * zz.late_median_error


def test_interval_and_packet_loss_change_the_view():
    slow = ch08.cooperative_view(interval=16.0, n_runs=5)
    assert len(slow.times) == 156 and slow.times[1] - slow.times[0] == 16.0
    lossy = ch08.cooperative_view(packet_loss=0.5, n_runs=5)
    base = ch08.cooperative_view(n_runs=5)
    assert not np.allclose(lossy.estimate, base.estimate)


def test_view_is_reproducible():
    a = ch08.cooperative_view(n_runs=4, seed=3)
    b = ch08.cooperative_view(n_runs=4, seed=3)
    np.testing.assert_array_equal(a.estimate, b.estimate)


@pytest.mark.parametrize("kw, err", [
    (dict(pattern="spiral"), ValueError),
    (dict(tuning="mine"), ValueError),
    (dict(current=3.0), ValueError),
    (dict(interval=7.5), ValueError),
    (dict(packet_loss=0.95), ValueError),
    (dict(n_runs=0), ValueError),
])
def test_bad_parameters(kw, err):
    with pytest.raises(err):
        ch08.cooperative_view(**kw)


def test_plot_and_panel():
    view = ch08.cooperative_view(n_runs=5)
    fig = ch08.plot_cooperative_view(view)
    assert len(fig.axes) == 3
    plt.close(fig)
    panel = ch08.cooperative_widget()
    assert type(panel).__name__ == "VBox"
    plt.close("all")


def _error_tick_labels(fig):
    ax = fig.axes[2]
    fig.canvas.draw()
    lo, hi = sorted(ax.get_ylim())
    ticks = ax.yaxis.get_major_ticks() + ax.yaxis.get_minor_ticks()
    return [t.label1.get_text() for t in ticks if lo <= t.get_loc() <= hi and t.label1.get_text()]


def test_median_error_labels_stay_short():
    # plain numbers at 1, 2 and 5 times a power of ten, never matplotlib's 2×10² on the minor ticks of an axis that
    # spans less than a decade (they crowded the axis label)
    view = ch08.cooperative_view(n_runs=5)
    fig = ch08.plot_cooperative_view(view)
    for setting in (dict(), dict(pattern="parallel"), dict(pattern="parallel", tuning="paper B")):
        if setting:
            ch08.update_cooperative_view(fig, ch08.cooperative_view(n_runs=5, **setting))
        labels = _error_tick_labels(fig)
        assert len(labels) >= 2, (setting, labels)
        assert all(len(s) <= 4 and "$" not in s and float(s) / 10 ** np.floor(np.log10(float(s))) in (1, 2, 5)
                   for s in labels), (setting, labels)
    plt.close(fig)


def test_the_early_view_is_the_full_view_on_its_steps():
    # the widget's first answer for a new setting: the same runs, the filter over the first steps only
    E = ch08.EARLY_STEPS
    for setting in (dict(pattern="zigzag", current=0.7071, interval=8, packet_loss=0.2, tuning="paper B"),
                    dict(pattern="parallel", current=1.0, interval=4, packet_loss=0.0, tuning="matched")):
        early = ch08._early_view(**setting)
        full = ch08.cooperative_view(n_runs=ch08.WIDGET_RUNS, **setting)
        assert early.epochs_run == E and full.epochs_run is None
        assert np.isnan(early.late_median_error) and np.isnan(early.lost_fraction) and not early.unobservable
        for name in ("estimate", "current_estimate", "current_sigma", "median_error"):
            np.testing.assert_array_equal(getattr(early, name)[:E], getattr(full, name)[:E])
            assert np.isnan(getattr(early, name)[E:]).all()
        for name in ("times", "truth", "leader", "dr"):
            np.testing.assert_array_equal(getattr(early, name), getattr(full, name))
    # a run no longer than the steps asked for (δt = 60 s: 41 steps) is run whole
    assert ch08._view("zigzag", 0.7071, 60.0, 0.0, "matched", 5, 0, 41).epochs_run is None


def test_the_panel_refined_in_the_background_ends_as_computed_at_once(monkeypatch):
    coarse, refined, at_once = moved_pictures(monkeypatch, ch08.cooperative_widget,
                                              lambda panel: panel.children[1].children[1], "paper B")   # tuning
    assert refined == at_once and coarse != at_once
    plt.close("all")
