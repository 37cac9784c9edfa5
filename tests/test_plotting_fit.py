"""The figure helpers that keep the book's figures readable at the page's width (issue 24)."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402

from uwtutor.plotting import (HIGHLIGHT_METHODS, MIN_FONT_SIZE, OTHERS_COLOR, legend_below,  # noqa: E402
                              method_legend, method_style)


def test_highlighted_methods_have_distinct_colours_and_the_others_are_grey():
    colours = [method_style(m)["color"] for m in HIGHLIGHT_METHODS]
    assert len(set(colours)) == len(colours)
    assert OTHERS_COLOR not in colours
    assert method_style("SFEKF")["color"] == OTHERS_COLOR
    assert method_style("EKF")["lw"] > method_style("SFEKF")["lw"]


def test_method_legend_names_the_others_and_the_extras():
    handles, labels = method_legend(7, extra=(("bound (PCRB)", {"color": "k", "ls": "--"}),))
    assert labels == [*HIGHLIGHT_METHODS, "the seven others", "bound (PCRB)"]
    assert len(handles) == len(labels)
    assert handles[len(HIGHLIGHT_METHODS)].get_color() == OTHERS_COLOR


def test_legend_below_is_off_the_data_and_readable():
    fig, ax = plt.subplots(figsize=(3.0, 2.5), layout="constrained")
    ax.plot([0, 1], [0, 1], label="a line")
    ax.set_xlabel("time [s]")
    legend = legend_below(ax)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    assert legend.get_window_extent(renderer).y1 < ax.get_window_extent(renderer).y0
    assert legend.get_window_extent(renderer).y1 < ax.xaxis.label.get_window_extent(renderer).y0
    assert all(t.get_fontsize() >= MIN_FONT_SIZE for t in legend.get_texts())
    plt.close(fig)
