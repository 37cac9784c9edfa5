"""Chapter 2 widget: the observability view's compute function (tested without a UI), its plot and its panel."""

import warnings

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

from uwtutor import observability, widgets  # noqa: E402
from uwtutor.widgets import ch02  # noqa: E402


def test_defaults_are_registered_and_run_for_every_track():
    # How fast they run is measured by `make bench` (bench_widgets), never timed here: a busy machine is slow.
    assert widgets.COMPUTE_FUNCTIONS["ch02 observability"] is ch02.observability_view
    for track in ch02.TRACK_CHOICES:
        view = ch02.observability_view(track=track, state="position + current")
        assert view.track == track


def test_ranks_follow_theory_for_each_track():
    expected = {  # final rank of (position, + bias, + current)
        "circle": (2, 3, 4), "straight": (2, 3, 3), "straight + turn": (2, 3, 4), "lawnmower": (2, 3, 4),
        "radial": (1, 1, 2),
    }
    for track, ranks in expected.items():
        view = ch02.observability_view(track=track)
        assert tuple(int(view.ranks[s][-1]) for s in ch02.STATE_CHOICES) == ranks, track
        assert view.n_states == {"position": 2, "position + bias": 3, "position + current": 4}
        for state, r in zip(ch02.STATE_CHOICES, ranks):   # the bound is finite exactly when the rank is full
            assert np.isfinite(view.rmse[state][-1]) == (r == view.n_states[state])


def test_mirror_track_fits_until_the_heading_changes():
    view = ch02.observability_view(track="straight + turn", turn_angle_deg=60.0)
    before = view.times <= 600.0
    assert np.max(np.abs(view.mirror_misfit[before])) < 1e-9
    assert np.min(np.abs(view.mirror_misfit[view.times >= 700.0])) > 100.0
    # a straight track never betrays its mirror, and neither does a reversal along the same line
    assert np.max(np.abs(ch02.observability_view(track="straight").mirror_misfit)) < 1e-9
    assert np.max(np.abs(ch02.observability_view(turn_angle_deg=180.0).mirror_misfit)) < 1e-9
    # the mirror track is the reflection of the true start across the line through the beacon along the heading
    np.testing.assert_allclose(view.mirror_positions[0], [-1500.0, -600.0])


def test_bounds_scale_with_sigma_and_match_the_library():
    a = ch02.observability_view(sigma=2.0, state="position + bias")
    b = ch02.observability_view(sigma=6.0, state="position + bias")
    np.testing.assert_allclose(b.rmse["position"][1:], 3 * a.rmse["position"][1:], rtol=1e-9)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", observability.UnobservableWarning)
        C = observability.track_crlb(a.positions, a.beacon, 2.0, unknown_bias=True)
    np.testing.assert_allclose(a.crlb[-1], C[-1][:2, :2])
    assert a.crlb.shape == (len(a.times), 2, 2)


def test_turn_angle_is_ignored_by_other_tracks_and_inputs_are_validated():
    a = ch02.observability_view(track="circle", turn_angle_deg=30.0)
    b = ch02.observability_view(track="circle", turn_angle_deg=150.0)
    np.testing.assert_array_equal(a.positions, b.positions)
    with pytest.raises(ValueError, match="track must be one of"):
        ch02.observability_view(track="zigzag")
    with pytest.raises(ValueError, match="state must be one of"):
        ch02.observability_view(state="bias")
    with pytest.raises(ValueError, match="sigma must be > 0"):
        ch02.observability_view(sigma=0.0)


def test_no_warning_escapes_the_compute_function():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for track in ch02.TRACK_CHOICES:
            ch02.observability_view(track=track, turn_angle_deg=0.0)


def test_plot_and_widget_build():
    import matplotlib.pyplot as plt

    fig = ch02.plot_observability_view(ch02.observability_view())
    assert len(fig.axes) == 4
    fig = ch02.plot_observability_view(ch02.observability_view(track="radial", state="position + current"))
    assert len(fig.axes) == 4
    panel = ch02.observability_widget()
    assert len(panel.children) == 3
    plt.close("all")


def test_other_unknowns_and_tracks_update_in_place():
    # choosing other unknowns or another track recolours, adds or removes the ellipses of the figure drawn, with
    # no new axes: the figure is the same as one drawn for the new setting, ellipse for ellipse
    import matplotlib.pyplot as plt
    from matplotlib.colors import to_rgba

    from uwtutor.widgets._panel import kept

    fig = ch02.plot_observability_view(ch02.observability_view())
    axes = list(fig.axes)
    for setting in (dict(state="position + bias"), dict(track="lawnmower", state="position + bias"),
                    dict(track="circle", state="position + current")):
        view = ch02.observability_view(**setting)
        changed = ch02.update_observability_view(fig, view)
        assert changed is not None and fig not in changed and fig.axes == axes, setting
        fresh = ch02.plot_observability_view(view)
        ellipses, expected = kept(fig)["ellipses"], kept(fresh)["ellipses"]
        assert len(ellipses) == len(expected) > 0
        for line, ref in zip(ellipses, expected):
            assert np.array_equal(line.get_xydata(), ref.get_xydata())
            assert to_rgba(line.get_color()) == to_rgba(ref.get_color())
        legend_texts = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
        assert legend_texts == [t.get_text() for t in fresh.axes[0].get_legend().get_texts()]
        plt.close(fresh)
    plt.close(fig)
