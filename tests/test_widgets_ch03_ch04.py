"""Chapters 3 and 4 widgets: the compute functions (no UI), the plots and the sliders' construction."""

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

from uwtutor import lsq  # noqa: E402
from uwtutor.widgets import ch03, ch04  # noqa: E402


def test_precision_view_agrees_with_lsq():
    v = ch03.precision_view()
    assert v.positions.shape == (236, 2) and v.alpha_history.shape == (236,)
    assert v.alpha == pytest.approx(v.alpha_history[-1])
    assert v.alpha == pytest.approx(1.0, abs=0.05)                   # 236 ranges over 90 degrees (paper A, Fig. 2)
    # white noise only: the Monte Carlo RMS error matches the prediction from (A^T A)^-1
    assert v.rmse == pytest.approx(v.predicted_rmse, rel=0.15)
    assert v.well_conditioned
    phi = np.radians(np.linspace(-90.0, 0.0, 236))
    A = np.column_stack([np.cos(phi), np.sin(phi), np.ones(236)])
    assert v.alpha == pytest.approx(lsq.precision_factor(A), rel=1e-9)


def test_precision_view_reports_poor_geometry():
    v = ch03.precision_view(n_obs=10, turn_deg=2.0)
    assert v.alpha > 1e4 and not v.well_conditioned
    singular = ch03.precision_view(n_obs=2, turn_deg=10.0)
    assert np.isinf(singular.alpha) and np.isnan(singular.rmse)
    more = ch03.precision_view(n_obs=236, turn_deg=180.0)
    assert more.alpha < v.alpha and more.alpha < ch03.precision_view().alpha


def test_precision_view_rejects_bad_input():
    with pytest.raises(ValueError, match="n_obs must be >= 1"):
        ch03.precision_view(n_obs=0)
    with pytest.raises(ValueError, match="turn_deg must be >= 1"):
        ch03.precision_view(turn_deg=1e-300)          # an arc of no width: no fix, not a NaN view
    with pytest.raises(ValueError, match="bias must be above -radius"):
        ch03.precision_view(radius=100.0, bias=-100.0)
    with pytest.raises(ValueError, match="radius must be <= 1e"):
        ch03.precision_view(radius=1e300)


def test_prelocation_view_before_and_after_the_turn():
    before = ch03.prelocation_view(epoch=60)
    after = ch03.prelocation_view(epoch=150)
    assert before.log_cost.shape == (180, 26) and before.bearing_profile.shape == (180,)
    assert before.runner_up is not None                              # the mirror valley
    assert after.error < 60.0 < before.error
    assert abs(after.best[0] - after.truth[0]) <= 4.0
    assert after.estimated_track.shape == (151, 2) and before.estimated_track.shape == (61, 2)
    # the grid steps change the grid
    fine = ch03.prelocation_view(bearing_step_deg=1.0, speed_step=5.0, epoch=150)
    assert fine.log_cost.shape == (360, 51)
    assert before.mirror_bearing_deg == pytest.approx((2 * 15.0 - before.truth[0]) % 360.0, abs=0.5)


def test_prelocation_view_rejects_bad_input():
    with pytest.raises(ValueError, match="bearing_step_deg must lie in"):
        ch03.prelocation_view(bearing_step_deg=0.1)
    with pytest.raises(ValueError, match="epoch must be below"):
        ch03.prelocation_view(epoch=151)
    with pytest.raises(ValueError, match="epoch must be >= 2"):
        ch03.prelocation_view(epoch=1)


def test_ekf_view_is_consistent_when_tuned_and_not_otherwise():
    good = ch04.ekf_view(initial_error=10.0, n_runs=100)
    lo, hi = good.nees_bounds
    assert lo < np.nanmean(good.mean_nees) < hi and good.nees_fraction_within > 0.8
    assert good.estimates.shape == (8, 151, 2) and good.rmse.shape == (151,)
    over = ch04.ekf_view(q_scale=0.02)
    assert np.nanmean(over.mean_nees) > hi
    biased = ch04.ekf_view(bias=20.0)
    assert np.nanmean(biased.mean_nees) > 10 * hi
    assert ch04.ekf_view(seed=3).rmse[-1] == ch04.ekf_view(seed=3).rmse[-1]


def test_ekf_view_rejects_bad_input():
    with pytest.raises(ValueError, match="initial_error must be >= 0.001"):
        ch04.ekf_view(initial_error=1e-300)           # P0 would underflow to 0
    with pytest.raises(ValueError, match="r_scale must be <= 1e"):
        ch04.ekf_view(r_scale=1e300)                  # R would overflow the filter's products
    with pytest.raises(ValueError, match="n_runs asks for"):
        ch04.ekf_view(n_runs=10**12)
    with pytest.raises(ValueError, match="n_runs must be >= 2"):
        ch04.ekf_view(n_runs=1)


def test_compute_functions_run_at_their_defaults():
    for module in (ch03, ch04):
        assert module.COMPUTE_FUNCTIONS
        for name, compute in module.COMPUTE_FUNCTIONS.items():
            assert name.startswith(module.__name__.rsplit(".", 1)[-1])
            assert compute() is not None


def test_plots_draw_and_widgets_build():
    import matplotlib.pyplot as plt

    fig = ch03.plot_precision_view(ch03.precision_view(n_obs=50, turn_deg=30.0))
    assert len(fig.axes) == 2
    plt.close(fig)
    fig = ch03.plot_precision_view(ch03.precision_view(n_obs=2, turn_deg=10.0))     # singular: a message
    plt.close(fig)
    fig = ch03.plot_prelocation_view(ch03.prelocation_view())
    assert len(fig.axes) == 3                                                      # map, colour bar, track
    plt.close(fig)
    fig = ch04.plot_ekf_view(ch04.ekf_view(n_runs=10))
    assert len(fig.axes) == 3
    plt.close(fig)
    for build in (ch03.precision_widget, ch03.prelocation_widget, ch04.ekf_widget):
        panel = build()
        assert len(panel.children) == 3
        plt.close("all")


def test_plain_log_ticks_and_covariance_ellipse():
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    ax.semilogy([1, 2, 3], [12.0, 20.0, 31.0])
    ch04.plain_log_ticks(ax)
    fig.canvas.draw()
    labels = [t.get_text() for t in ax.get_yticklabels() if t.get_text()]
    assert labels and all("10^" not in s and "times" not in s for s in labels)
    with pytest.raises(ValueError, match="axis must be 'x' or 'y'"):
        ch04.plain_log_ticks(ax, axis="z")
    plt.close(fig)
    ell = ch03.covariance_ellipse(np.diag([4.0, 1.0]), scale=2.0, n=50)
    assert ell.shape == (50, 2)
    assert np.max(np.abs(ell[:, 0])) == pytest.approx(4.0, rel=1e-3)
    assert np.max(np.abs(ell[:, 1])) == pytest.approx(2.0, rel=1e-2)
    with pytest.raises(ValueError, match="covariance must have shape"):
        ch03.covariance_ellipse(np.eye(3))
