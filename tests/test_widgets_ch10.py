"""Chapter 10 widget: the comparison view reads the committed table (tested without a UI), its plot and its panel."""

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402

from uwtutor import methods  # noqa: E402
from uwtutor.widgets import ch10  # noqa: E402


def test_registered_compute_function_runs_at_its_defaults():
    assert ch10.COMPUTE_FUNCTIONS["ch10 comparison"] is ch10.comparison_view
    v = ch10.COMPUTE_FUNCTIONS["ch10 comparison"]()
    assert (v.scenario, v.condition) == ("circle", "white")
    assert v.methods == tuple(m for m in methods.names() if methods.get(m).runs_on("circle"))
    assert v.rmse.shape == (len(v.methods), len(v.times)) == (len(v.methods), 150)
    assert v.bound.shape == v.times.shape and (v.rmse > v.bound).all()
    assert v.n_runs == 1000


def test_view_is_the_tables_rows():
    table = methods.load_comparison()
    v = ch10.comparison_view("moving beacon", "current", table)
    assert "cooperative EKF" in v.methods and "ISFEKF" not in v.methods
    i = v.methods.index("cooperative EKF")
    row = table.row("cooperative EKF", "moving beacon", "current")
    assert v.median_final[i] == row["median_final_error"] and v.divergence[i] == row["divergence_fraction"]
    rmse, bound = table.curves("cooperative EKF", "moving beacon", "current")
    np.testing.assert_array_equal(v.rmse[i], rmse)
    np.testing.assert_array_equal(v.bound, bound)
    np.testing.assert_allclose(v.times, 10.0 * np.arange(1, 151))


@pytest.mark.parametrize("kw, match", [({"scenario": "square"}, "scenario must be one of"),
                                       ({"condition": "pink"}, "condition must be one of")])
def test_bad_input_names_the_argument(kw, match):
    with pytest.raises(ValueError, match=match):
        ch10.comparison_view(**kw)


def test_a_table_without_curves_is_refused_with_the_fix():
    table = methods.load_comparison()
    from dataclasses import replace
    with pytest.raises(ValueError, match="curves"):
        ch10.comparison_view(table=replace(table, rmse_curves=None))


def test_plot_and_panel():
    fig = ch10.plot_comparison_view(ch10.comparison_view("line", "outliers"))
    assert len(fig.axes) == 2
    plt.close(fig)
    panel = ch10.comparison_widget()
    assert len(panel.children) == 3
    controls = panel.children[0].children
    assert [c.description for c in controls] == ["scenario", "error condition", "highlight"]
    before = panel.children[2].children[0].value
    controls[1].value = "current"                  # redraws the same figure in place
    assert panel.children[2].children[0].value != before
    before = panel.children[2].children[0].value
    controls[2].value = "cooperative EKF"          # not on the line: nothing highlighted, no error
    assert panel.children[2].children[0].value == before
    controls[0].value = "moving beacon"
    assert panel.children[2].children[0].value != before
    plt.close("all")


def test_highlighting_a_method_that_is_not_there_is_refused_by_name():
    with pytest.raises(ValueError, match="method must be"):
        ch10.plot_comparison_view(ch10.comparison_view("line", "white"), method="cooperative EKF")
    plt.close("all")


def test_highlight_redraws_only_what_changes():
    view = ch10.comparison_view("circle", "white")
    fig = ch10.plot_comparison_view(view)
    chosen = view.methods[1]
    changed = ch10.update_comparison_view(fig, view, method=chosen)
    assert changed is not None and fig not in changed and fig.axes[1].yaxis in changed
    colors = [t.get_color() for t in fig.axes[1].get_yticklabels()]
    assert colors[1] == "C3" and all(c == "0.45" for i, c in enumerate(colors) if i != 1)
    plt.close(fig)
