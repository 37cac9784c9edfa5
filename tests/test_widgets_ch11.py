"""Chapter 11 widget: the view picks the committed runs (tested without a UI), its plot and its panel."""

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402

from uwtutor.datasets.study import GRID_BEACONS, GRID_PERIODS, GRID_STATES, load_real_data_study  # noqa: E402
from uwtutor.widgets import ch11  # noqa: E402


def test_registered_compute_function_runs_at_its_defaults():
    assert ch11.COMPUTE_FUNCTIONS["ch11 real data"] is ch11.real_data_view
    v = ch11.COMPUTE_FUNCTIONS["ch11 real data"]()
    assert (v.beacon, v.period, v.states) == ("5", None, "+ scale and gyro bias")
    K = v.times.size
    assert K == 410 and v.truth.shape == v.estimate.shape == v.dead_reckoning.shape == (K, 2)
    for curve in (v.error, v.error_rts, v.scale, v.scale_sigma):
        assert curve.shape == (K,)
    assert list(v.beacons) == [5] and sorted(v.all_beacons) == [0, 1, 5, 6]
    assert 1.06 < v.measured_scale < 1.08 and abs(v.scale[-1] - v.measured_scale) < 0.01
    assert v.summary["rmse"] < 5.0 and v.rts_rmse <= v.summary["rmse"]


def test_view_is_the_studys_grid():
    study = load_real_data_study()
    for beacon, period, states in [("all", 10.0, "+ scale"), ("1", 30.0, "pose only"), ("6", 5.0, "+ gyro bias")]:
        v = ch11.real_data_view(beacon, period, states, study=study)
        i, j, k = GRID_BEACONS.index(beacon), GRID_PERIODS.index(period), GRID_STATES.index(states)
        np.testing.assert_array_equal(v.error, study.grid["curves"]["error"][i, j, k])
        assert v.summary["rmse"] == study.grid["measures"]["filter_rmse"][i, j, k]
        assert (np.isnan(v.scale).all()) == ("scale" not in states)
    assert len(ch11.real_data_view("all").beacons) == 4


def test_the_error_curve_is_the_distance_between_estimate_and_truth():
    v = ch11.real_data_view("1", None, "+ scale and gyro bias")
    np.testing.assert_allclose(v.error, np.hypot(*(v.estimate - v.truth).T), rtol=1e-5, atol=1e-4)


@pytest.mark.parametrize("kw, match", [({"beacon": "7"}, "beacon must be one of"),
                                       ({"period": 20.0}, "period must be one of"),
                                       ({"states": "all"}, "states must be one of")])
def test_bad_input_names_the_argument(kw, match):
    with pytest.raises(ValueError, match=match):
        ch11.real_data_view(**kw)


def test_plot_and_panel():
    fig = ch11.plot_real_data_view(ch11.real_data_view("all", 10.0, "pose only"))
    assert len(fig.axes) == 3
    plt.close(fig)
    panel = ch11.real_data_widget()
    assert len(panel.children) == 3
    controls = panel.children[0].children
    assert [c.description for c in controls] == ["beacon", "ranges", "states"]
    before = panel.children[2].children[0].value
    controls[1].value = 30.0                        # redraws the same figure in place
    assert panel.children[2].children[0].value != before
    before = panel.children[2].children[0].value
    controls[2].value = "pose only"
    assert panel.children[2].children[0].value != before
    controls[0].value = "all"
    plt.close("all")


def test_switching_the_scale_estimate_on_and_off_updates_in_place():
    # the scale panel's band, estimate, note and legend follow the states without drawing the figure anew
    fig = ch11.plot_real_data_view(ch11.real_data_view("5", None, "+ scale and gyro bias"))
    axes = list(fig.axes)
    for states in ("pose only", "+ scale", "+ gyro bias"):
        view = ch11.real_data_view("5", None, states)
        changed = ch11.update_real_data_view(fig, view)
        assert changed is not None and fig not in changed and fig.axes == axes, states
        fresh = ch11.plot_real_data_view(view)

        def shown(f):
            ax_s = f.axes[2]
            texts = [t.get_text() for t in ax_s.texts if t.get_visible()]
            legends = [[t.get_text() for t in lg.get_texts()] for lg in [ax_s.get_legend(), *ax_s.artists]
                       if lg.get_visible()]
            return texts, legends

        assert shown(fig) == shown(fresh), states
        plt.close(fresh)
    plt.close(fig)
