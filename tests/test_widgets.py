"""The widgets' compute functions (tested without a UI) and the widget layer's construction."""

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

from uwtutor import acoustics, widgets  # noqa: E402


def test_sound_speed_view_agrees_with_the_equation():
    view = widgets.sound_speed_view(temperature=12.0, salinity=34.0, depth=500.0)
    assert view.speed == pytest.approx(acoustics.sound_speed(12.0, 34.0, 500.0))
    # the sensitivities are derivatives of the nine-term equation, checked here against its analytic derivative
    dT = 4.591 - 2 * 5.304e-2 * 12 + 3 * 2.374e-4 * 144 - 1.025e-2 * (34 - 35) - 7.139e-13 * 500**3
    assert view.sensitivity["temperature"] == pytest.approx(dT, rel=1e-6)
    assert view.sensitivity["salinity"] == pytest.approx(1.340 - 1.025e-2 * 12, rel=1e-6)
    assert view.range_error_per_km == pytest.approx(1000 * (1500 / view.speed - 1))
    assert view.speed_vs_depth.shape == view.depths.shape


def test_sound_speed_view_rejects_bad_input():
    with pytest.raises(ValueError, match="depth must be >= 0"):
        widgets.sound_speed_view(depth=-10.0)
    with pytest.raises(ValueError, match="temperature must be finite"):
        widgets.sound_speed_view(temperature=np.nan)


def test_range_error_view_components_add_up():
    view = widgets.range_error_view()
    parts = [e for name, e in view.errors.items() if name != "total"]
    np.testing.assert_allclose(sum(parts), view.errors["total"])
    assert set(view.errors) == {"additive", "multiplicative", "slow bias", "outliers", "total"}
    # the assumed 1470 m/s against a true 1500 m/s makes ranges 2 % short on average
    ratio = view.errors["multiplicative"] / view.true_ranges
    assert np.mean(ratio) == pytest.approx(1470 / 1500 - 1, abs=2e-3)
    assert np.count_nonzero(view.errors["outliers"]) == 13


def test_range_error_view_is_reproducible_and_seeded():
    a, b, c = widgets.range_error_view(seed=3), widgets.range_error_view(seed=3), widgets.range_error_view(seed=4)
    np.testing.assert_array_equal(a.errors["total"], b.errors["total"])
    assert not np.array_equal(a.errors["total"], c.errors["total"])


def test_registered_compute_functions_run_at_their_defaults():
    assert widgets.COMPUTE_FUNCTIONS
    for name, compute in widgets.COMPUTE_FUNCTIONS.items():
        assert compute() is not None, name


def test_widgets_build_and_plot_functions_draw():
    import matplotlib.pyplot as plt

    for build in (widgets.sound_speed_widget, widgets.range_error_widget):
        panel = build()
        assert len(panel.children) == 3
    fig = widgets.plot_sound_speed_view(widgets.sound_speed_view())
    assert len(fig.axes) == 2
    fig = widgets.plot_range_error_view(widgets.range_error_view())
    assert len(fig.axes) == 2
    plt.close("all")


def test_range_error_view_refuses_an_unseeded_run():
    """seed=None would draw OS entropy: every figure of the book must be reproducible."""
    import pytest

    from uwtutor import widgets

    with pytest.raises(TypeError, match="seed must be an integer"):
        widgets.range_error_view(seed=None)


@pytest.mark.parametrize("chapter, compute, update", [
    ("ch01", "sound_speed_view", "update_sound_speed_view"),
    ("ch01", "range_error_view", "update_range_error_view"),
    ("ch03", "precision_view", "update_precision_view"),
    ("ch04", "ekf_view", "update_ekf_view"),
    ("ch11", "real_data_view", "update_real_data_view"),
])
def test_an_update_on_a_figure_its_plot_did_not_draw_asks_for_a_new_drawing(chapter, compute, update):
    # an update puts a new view into the artists its plot function kept; on any other figure it returns None,
    # which makes the panel draw the figure anew (it used to fail on the missing artists)
    from importlib import import_module

    from matplotlib.figure import Figure

    module = import_module(f"uwtutor.widgets.{chapter}")
    view = getattr(module, compute)()
    fig = Figure()
    fig.subplots(1, 2)
    assert getattr(module, update)(fig, view) is None
    drawn = getattr(module, f"plot_{compute}")(view)
    assert getattr(module, update)(drawn, view)          # on its own figure: the artists that changed
