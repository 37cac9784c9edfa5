"""Figures sharp on a 3x screen: a notebook shows each figure as a PNG of PIXEL_RATIO pixels per figure pixel, with
its display size in the output's metadata and a palette (uwtutor.plotting.use_sharp_figures, palette_png)."""

from __future__ import annotations

import io
import json
import subprocess
import sys

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from PIL import Image  # noqa: E402

from uwtutor.plotting import PALETTE_MAX_ERROR, PIXEL_RATIO, palette_png  # noqa: E402


def _png(fig, dpi):
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=dpi)
    plt.close(fig)
    return buffer.getvalue()


def _rgb(png):
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=int)


def test_a_plot_keeps_its_pixels_and_resolution_in_half_the_bytes():
    fig, ax = plt.subplots(figsize=(7.0, 3.6), dpi=100)
    x = np.linspace(0.0, 10.0, 400)
    for k in range(3):
        ax.plot(x, np.sin(x + k), label=f"curve {k}")
    ax.legend()
    png = _png(fig, 200)
    small = palette_png(png)
    assert len(small) < len(png) / 2
    image = Image.open(io.BytesIO(small))
    assert image.mode == "P" and image.size == (1400, 720)
    assert image.info["dpi"] == pytest.approx((200.0, 200.0), abs=0.01)
    assert np.abs(_rgb(small) - _rgb(png)).max() <= PALETTE_MAX_ERROR


def test_a_palette_never_moves_a_pixel_more_than_allowed():
    """Lines over an area blended with transparency (thousands of colours): a palette PNG within PALETTE_MAX_ERROR
    of the PNG, or the PNG itself when no palette is close enough."""
    fig, ax = plt.subplots(figsize=(7.0, 3.6), dpi=100)
    x = np.linspace(0.0, 10.0, 400)
    for k in range(5):
        ax.plot(x, np.sin(x + k), label=f"curve {k}")
    ax.fill_between(x, -0.2, 0.2, alpha=0.3)
    ax.legend()
    png = _png(fig, 200)
    small = palette_png(png)
    assert small != png and len(small) < len(png) / 2  # (the fast quantizer moves some pixel 40 levels here)
    assert np.abs(_rgb(small) - _rgb(png)).max() <= PALETTE_MAX_ERROR
    assert palette_png(png, max_error=0) == png  # no palette keeps every pixel: the PNG as it is


def test_an_animation_has_sharp_frames_shown_at_the_figure_size():
    import base64
    import re

    from matplotlib.animation import FuncAnimation

    from uwtutor.plotting import animation_html

    fig, ax = plt.subplots(figsize=(6.0, 3.0), dpi=50)
    (line,) = ax.plot([0.0, 1.0], [0.0, 0.0])
    ax.set_ylim(-0.5, 2.5)
    html = animation_html(FuncAnimation(fig, lambda i: line.set_ydata([0.0, float(i)]), frames=3)).data
    plt.close(fig)
    assert re.search(r'<img id="_anim_img[0-9a-f]*" width="300">', html)
    frames = re.findall(r'frames\[\d+\] = "data:image/png;base64,([^"]*)"', html)
    assert len(frames) == 3
    for frame in frames:
        image = Image.open(io.BytesIO(base64.b64decode(frame)))
        assert image.size == (300 * PIXEL_RATIO, 150 * PIXEL_RATIO) and image.mode == "P"


def test_a_picture_a_palette_would_change_is_kept_as_it_is():
    rng = np.random.default_rng(7)
    fig, ax = plt.subplots(figsize=(2.0, 2.0), dpi=100)
    ax.imshow(rng.random((60, 60, 3)))  # thousands of unrelated colours
    png = _png(fig, 100)
    assert palette_png(png) == png


@pytest.mark.parametrize("bad, message", [(b"GIF89a", "PNG signature"), ("a.png", "got str")])
def test_not_a_png_is_refused_by_name(bad, message):
    with pytest.raises(ValueError, match=f"png must be the bytes of a PNG image.*{message}"):
        palette_png(bad)


KERNEL_LIKE = r"""
import json, base64, io
from IPython.core.interactiveshell import InteractiveShell
shell = InteractiveShell.instance()
import matplotlib.pyplot as plt
from uwtutor.plotting import use_book_style
use_book_style()
fig, ax = plt.subplots()
ax.plot([0, 1], [0, 1], label="a line")
data, metadata = shell.display_formatter.format(fig)
from PIL import Image
image = Image.open(io.BytesIO(base64.b64decode(data["image/png"])))
print(json.dumps({"size": image.size, "mode": image.mode, "dpi": image.info.get("dpi"),
                  "metadata": metadata.get("image/png"), "figure": [fig.get_figwidth(), fig.get_figheight(),
                                                                    fig.dpi]}))
"""


def test_a_notebook_shows_figures_at_twice_their_pixels_and_their_own_size():
    """In an IPython shell (a subprocess: the shell is a process-wide singleton), use_book_style makes the figure
    formatter give a palette PNG of PIXEL_RATIO x the figure's pixels, whose metadata says the figure's own size."""
    out = subprocess.run([sys.executable, "-c", KERNEL_LIKE], capture_output=True, text=True, check=True,
                         env={"MPLBACKEND": "module://matplotlib_inline.backend_inline",
                              **{k: v for k, v in __import__("os").environ.items() if k != "MPLBACKEND"}})
    facts = json.loads(out.stdout.strip().splitlines()[-1])
    width_in, height_in, dpi = facts["figure"]
    assert facts["mode"] == "P"
    assert facts["dpi"] == pytest.approx([dpi * PIXEL_RATIO] * 2, abs=0.01)
    # bbox_inches="tight" trims the margins: the display size is half the pixels, within the figure's size
    width, height = facts["size"]
    assert facts["metadata"] == {"width": width // PIXEL_RATIO, "height": height // PIXEL_RATIO}
    assert width_in * dpi * 0.7 < facts["metadata"]["width"] <= width_in * dpi
