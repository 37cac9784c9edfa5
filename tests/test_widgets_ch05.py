"""Chapter 5 widget: the fading-filter view's compute function (tested without a UI), its plot and its panel."""

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402

from uwtutor.filters.fading import fading_ekf  # noqa: E402
from uwtutor.widgets import ch05  # noqa: E402


def test_registered_compute_function_runs_at_its_defaults():
    assert ch05.COMPUTE_FUNCTIONS["ch05 fading filter"] is ch05.fading_view
    view = ch05.COMPUTE_FUNCTIONS["ch05 fading filter"]()
    K = len(view.times)
    assert view.n_runs == 100 and K == 151
    for name in ("x_fading", "x_ekf", "truth"):
        assert getattr(view, name).shape == (K, 2)
    for name in ("rmse_fading", "rmse_ekf", "median_fading", "median_ekf", "fading_factor", "weakening_factor"):
        assert getattr(view, name).shape == (K,)
    assert np.all(view.fading_factor >= 1.0)
    assert 0.0 <= view.fraction_faded <= 1.0
    assert set(view.steady_rmse) == set(view.steady_median) == {"fading", "ekf"}


def test_view_is_reproducible_and_matches_the_library():
    a = ch05.fading_view(initial_error=40.0, n_runs=20, seed=3)
    b = ch05.fading_view(initial_error=40.0, n_runs=20, seed=3)
    np.testing.assert_array_equal(a.x_fading, b.x_fading)
    np.testing.assert_array_equal(a.rmse_ekf, b.rmse_ekf)
    # the weakening factor of paper D is about the predicted range; beta = 1 when it is off
    assert np.median(a.weakening_factor) > 500.0
    off = ch05.fading_view(initial_error=40.0, n_runs=20, seed=3, weakening=False)
    np.testing.assert_array_equal(off.weakening_factor, 1.0)
    assert off.fraction_faded > a.fraction_faded


def test_right_sound_speed_beats_the_additive_ekf_from_a_good_start():
    view = ch05.fading_view(initial_error=20.0, n_runs=50)
    assert view.steady_median["fading"] < 0.5 * view.steady_median["ekf"]
    wrong = ch05.fading_view(assumed_dc=30.0, initial_error=20.0, n_runs=50)   # paper D's printed sign
    assert wrong.steady_median["fading"] > view.steady_median["fading"]


def test_steady_summaries_follow_their_definition():
    view = ch05.fading_view(n_runs=10, initial_error=30.0)
    late = view.times >= ch05.STEADY_FROM
    # the RMS over runs and late epochs equals the RMS over the late epochs of the per-epoch RMS curve
    assert view.steady_rmse["ekf"] == pytest.approx(np.sqrt(np.mean(view.rmse_ekf[late] ** 2)))


@pytest.mark.parametrize("kw, err", [
    (dict(assumed_dc=500.0), ValueError),
    (dict(initial_error=0.0), ValueError),
    (dict(rho=0.0), ValueError),
    (dict(n_runs=0), ValueError),
    (dict(weakening="yes"), TypeError),
])
def test_bad_parameters(kw, err):
    with pytest.raises(err):
        ch05.fading_view(**kw)


def test_plot_and_panel():
    view = ch05.fading_view(n_runs=10)
    fig = ch05.plot_fading_view(view)
    assert len(fig.axes) == 3
    plt.close(fig)
    panel = ch05.fading_widget()
    assert type(panel).__name__ == "VBox"
    plt.close("all")


def test_fading_factor_of_the_displayed_run_comes_from_the_filter():
    view = ch05.fading_view(n_runs=5, seed=1, initial_error=60.0)
    rng = np.random.default_rng(1)
    from uwtutor import scenarios
    sc = scenarios.approach_with_turn_scenario(rng, n_runs=5)
    angle = rng.uniform(0.0, 2 * np.pi, 5)
    x0 = sc.true_positions[:, 0] + 60.0 * np.column_stack([np.cos(angle), np.sin(angle)])
    res = fading_ekf(x0, np.eye(2) * 3600.0, sc.dr_displacements, sc.ranges, np.eye(2) * 0.81, 0.49,
                     mu_gamma=1 - 30 / 1500, sigma_gamma=1 / 1500, rho=0.95, beta="range")
    np.testing.assert_allclose(view.fading_factor, res.fading_factor[0])
    np.testing.assert_allclose(view.x_fading, res.x[0])


def test_switching_the_weakening_factor_updates_in_place():
    view = ch05.fading_view(n_runs=5)
    fig = ch05.plot_fading_view(view)
    other = ch05.fading_view(n_runs=5, weakening=False)
    changed = ch05.update_fading_view(fig, other)
    assert changed is not None and fig not in changed
    fresh = ch05.plot_fading_view(other)
    for ax, ref in zip(fig.axes[:2], fresh.axes[:2]):
        assert [t.get_text() for t in ax.get_legend().get_texts()] == \
            [t.get_text() for t in ref.get_legend().get_texts()]
    plt.close(fig)
    plt.close(fresh)
