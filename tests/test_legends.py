"""Legends never cover data: ``uwtutor.plotting.legend_overlaps`` on figures built to cover or not, and every figure
the chapters show.

Each chapter calls ``use_book_style()``, which makes the notebook check every figure it displays (static figures and
the figures a widget draws) and print a ``legend covers data: ...`` line under a figure whose legend covers data.
nbval re-runs the chapters and compares every text output with the committed one, so a new overlap fails there; the
committed outputs themselves must hold no such line (test below).
"""

from __future__ import annotations

import json
import re

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from book_paths import REPO  # noqa: E402
from uwtutor.plotting import LEGEND_WARNING, legend_below, legend_overlaps  # noqa: E402

CHAPTERS = sorted((REPO / "book").glob("ch*.ipynb"))


@pytest.fixture
def ax():
    fig, ax = plt.subplots(figsize=(4, 3), dpi=100)
    yield ax
    plt.close(fig)


def test_a_line_under_the_legend_is_found(ax):
    x = np.linspace(0, 1, 50)
    ax.plot(x, np.ones_like(x), label="flat at the top")
    ax.set_ylim(0, 1.05)
    ax.legend(loc="upper center")
    assert legend_overlaps(ax.figure) == ["axes 1: the legend ('flat at the top', ...) covers 'flat at the top'"]


def test_room_above_the_data_clears_it(ax):
    x = np.linspace(0, 1, 50)
    ax.plot(x, x**2, label="rising")
    ax.legend(loc="upper right")
    ax.set_ylim(0, 1)
    assert legend_overlaps(ax.figure), "the curve ends in the top right corner, under the legend"
    ax.set_ylim(0, 3)
    assert legend_overlaps(ax.figure) == []


def test_markers_and_filled_bands_count(ax):
    ax.scatter([0.05], [0.95], label="a point in the corner")
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1)
    ax.legend(loc="upper left")
    assert any("PathCollection" in p or "corner" in p for p in legend_overlaps(ax.figure))
    ax.collections[0].remove()
    ax.fill_between([0, 1], [0.8, 0.8], [1.0, 1.0], alpha=0.2, label="band")
    ax.legend(loc="upper right")
    assert any("band" in p for p in legend_overlaps(ax.figure))


def test_a_legend_below_the_axes_covers_nothing(ax):
    x = np.linspace(0, 1, 50)
    ax.plot(x, np.zeros_like(x), label="along the bottom")
    legend_below(ax)
    assert legend_overlaps(ax.figure) == []


def test_a_figure_legend_is_checked_against_every_axes():
    fig, (a, b) = plt.subplots(1, 2, figsize=(6, 3), dpi=100)
    x = np.linspace(0, 1, 50)
    a.plot(x, 0 * x + 1, label="a")
    b.plot(x, 0 * x + 1, label="b")
    a.set_ylim(0, 1.05)
    b.set_ylim(0, 1.05)
    fig.legend(loc="upper right", bbox_to_anchor=(0.9, 0.88))
    try:
        found = legend_overlaps(fig)
        assert any(p.startswith("axes 2") for p in found), found
    finally:
        plt.close(fig)


def test_an_animation_reports_a_frame_whose_legend_covers_data(capsys):
    from matplotlib.animation import FuncAnimation

    from uwtutor.plotting import animation_html

    fig, ax = plt.subplots(figsize=(3, 2), dpi=40)
    (line,) = ax.plot([0, 1], [0, 0], label="moving")
    ax.set_ylim(0, 1)
    ax.legend(loc="center")
    anim = FuncAnimation(fig, lambda i: line.set_ydata([0.5 * i, 0.5 * i]), frames=2)
    animation_html(anim)
    plt.close(fig)
    assert f"{LEGEND_WARNING} (animation)" in capsys.readouterr().err  # frame 1: the line through the legend


def test_bad_input_names_the_argument():
    with pytest.raises((TypeError, ValueError), match="fig"):
        legend_overlaps("not a figure")


@pytest.mark.parametrize("chapter", CHAPTERS, ids=lambda p: p.stem)
def test_no_committed_figure_has_a_legend_over_its_data(chapter):
    nb = json.loads(chapter.read_text(encoding="utf-8"))
    found = []
    for index, cell in enumerate(nb["cells"]):
        for out in cell.get("outputs", []):
            text = "".join(out.get("text", "")) if out.get("output_type") == "stream" else ""
            found += [f"cell {index}: {line}" for line in text.splitlines() if line.startswith(LEGEND_WARNING)]
    # a widget draws into an Output widget: what it printed is in the saved widget state
    state = json.dumps(nb.get("metadata", {}).get("widgets", {}))
    found += [f"a widget's view: {m}" for m in set(re.findall(LEGEND_WARNING + r"[^\\\"]*", state))]
    assert not found, f"{chapter.name}: figures whose legend covers data:\n" + "\n".join(found)


def test_a_widget_says_when_its_first_view_has_a_legend_over_its_data(capsys):
    """The first view of a widget is the one the HTML book shows: slider_panel checks it as a notebook's figures
    are checked, on stderr (so that it is in the committed cell output that the test above reads)."""
    import ipywidgets as w

    from uwtutor.widgets._panel import slider_panel

    def draw(fig, level):
        fig = fig or plt.figure()
        ax = fig.subplots()
        ax.plot([0, 1], [level, level], label="high")
        ax.plot([0, 1], [0, 0], label="low")
        ax.legend(loc="upper right")
        return fig

    slider_panel({"level": w.FloatSlider(value=1.0, min=0.5, max=1.0)}, draw)
    assert f"{LEGEND_WARNING} (widget): axes 1: the legend ('high', ...) covers 'high'" in capsys.readouterr().err
