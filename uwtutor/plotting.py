"""Figure style and small plotting helpers shared by the chapters, so that chapter code reads as the idea it shows.

Nothing here computes anything a chapter relies on: the numbers come from the library's modelling modules.
"""

from __future__ import annotations

from binascii import b2a_base64
from typing import Any, cast

import re

import matplotlib.pyplot as plt
import numpy as np
from numpy.typing import ArrayLike

from ._validate import as_float_array, as_instance, as_point

__all__ = ["BOOK_STYLE", "use_book_style", "mark_beacon", "plot_track", "plain_log_ticks", "animation_html",
           "MIN_FONT_SIZE", "HIGHLIGHT_METHODS", "OTHERS_COLOR", "method_style", "method_legend", "legend_below",
           "legend_overlaps", "check_legends_on_display", "LEGEND_WARNING", "PIXEL_RATIO", "use_sharp_figures",
           "PALETTE_COLORS", "PALETTE_MAX_ERROR", "palette_png"]

#: The matplotlib settings of every figure in the book, readable at the width of its column (PNG output).
BOOK_STYLE: dict[str, Any] = {
    "figure.figsize": (7.0, 3.6),
    "figure.dpi": 100,
    "savefig.dpi": 100,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "font.size": 10,
    "legend.fontsize": 9,
    "legend.frameon": False,
    "image.cmap": "viridis",
}

#: Image pixels per figure pixel (``figure.dpi``) in the PNGs a notebook shows and in the frames of an animation:
#: 2, a "retina" PNG shown at half its pixel size (IPython records the display size in the output's metadata, which
#: the HTML book and JupyterLab honour). On a phone's 3x screen a figure opened full size gets 1.5 screen pixels per
#: image pixel instead of 3, and in the page the image is sampled down instead of up. Not SVG: nbval compares an SVG
#: output as text (coordinates to the last printed digit, a date), and a widget's live picture must stay fast.
PIXEL_RATIO = 2

#: A notebook figure's PNG is stored with a palette of this many colours (about a third of the bytes of the
#: full-colour PNG: a chapter's figures at PIXEL_RATIO then weigh less than at the figure's own resolution),
#: unless that changes some pixel by more than PALETTE_MAX_ERROR (of 255) in a channel: then in full colour.
PALETTE_COLORS = 256
PALETTE_MAX_ERROR = 24

#: The smallest font size (points) of any text in a book figure. A figure 7.8 inches wide at 100 dpi is shown at
#: about 0.96 of its size in the 1280 px layout, so 7 points there still read as 7.
MIN_FONT_SIZE = 7.0

#: The methods that figures comparing many of them single out, each in a colour of its own, the same in every
#: figure of the book; the others are drawn thin and grey behind them (eleven colours cannot be told apart).
HIGHLIGHT_METHODS = {"EKF": "C3", "IEKF": "C0", "particle filter": "C2", "cooperative EKF": "C1"}

#: How a notebook output says that a figure's legend covers data (:func:`check_legends_on_display`).
LEGEND_WARNING = "legend covers data"

#: The colour of the methods a comparison does not single out.
OTHERS_COLOR = "0.78"


def use_book_style() -> None:
    """Apply :data:`BOOK_STYLE` to matplotlib (call once at the top of a chapter); in a notebook, check every figure
    it shows for a legend that covers data (:func:`check_legends_on_display`).

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> from uwtutor.plotting import use_book_style
    >>> with plt.rc_context():
    ...     use_book_style()
    ...     plt.rcParams["figure.figsize"]
    [7.0, 3.6]
    """
    plt.rcParams.update(cast(Any, BOOK_STYLE))   # matplotlib's stubs type the keys as literals
    use_sharp_figures()
    check_legends_on_display()


def use_sharp_figures() -> bool:
    """In a notebook, show figures as PNGs of :data:`PIXEL_RATIO` image pixels per figure pixel (IPython's
    ``retina`` format: the PNG at twice ``figure.dpi``, its display size in the output's metadata), stored with a
    palette (:func:`palette_png`). Outside IPython it does nothing.

    Returns
    -------
    bool
        Whether the notebook's figures are now shown sharp (an IPython kernel with matplotlib's inline backend).

    Examples
    --------
    >>> from uwtutor.plotting import use_sharp_figures
    >>> use_sharp_figures()  # outside a notebook
    False
    """
    try:
        from IPython import get_ipython
    except ImportError:  # pragma: no cover - IPython comes with matplotlib-inline
        return False
    shell = get_ipython()
    if shell is None or not hasattr(shell, "display_formatter"):
        return False
    # The inline backend is loaded lazily (at the first figure) and then registers the formats of its configuration:
    # load it now, and set the format in the configuration, so that a later load keeps it.
    plt.switch_backend(plt.get_backend())
    try:
        from matplotlib_inline.backend_inline import InlineBackend
    except ImportError:  # pragma: no cover - another backend: nothing to do
        return False
    from IPython.core.pylabtools import retina_figure, select_figure_formats
    from matplotlib.figure import Figure

    config = InlineBackend.instance()
    config.figure_formats = {"retina"}
    select_figure_formats(shell, config.figure_formats, **config.print_figure_kwargs)

    def sharp_png(fig: Any) -> Any:
        out = retina_figure(fig, base64=False, **config.print_figure_kwargs)
        if out is None:  # an empty figure: nothing shown
            return None
        png, metadata = out
        return b2a_base64(palette_png(png), newline=False).decode("ascii"), metadata

    shell.display_formatter.formatters["image/png"].for_type(Figure, sharp_png)
    return True


def palette_png(png: bytes, colors: int = PALETTE_COLORS, max_error: int = PALETTE_MAX_ERROR) -> bytes:
    """``png`` with a palette of ``colors`` colours, its resolution (pHYs) kept; ``png`` itself when that would
    change some pixel by more than ``max_error`` (of 255) in a channel (a smooth colour map, a photograph) or would
    not be smaller.

    A plot is a few colours and their antialiased edges: a palette (Pillow's ``FASTOCTREE`` quantizer, or
    ``MAXCOVERAGE`` where that moves a pixel too far; no dithering) keeps them within a few levels of 255 and takes
    about a third of the bytes or less.

    Examples
    --------
    >>> import io
    >>> import matplotlib.pyplot as plt
    >>> from PIL import Image
    >>> from uwtutor.plotting import palette_png
    >>> fig, ax = plt.subplots(figsize=(3.0, 2.0), dpi=100)
    >>> _ = ax.plot([0, 1, 2], [0, 1, 0], label="a line")
    >>> buffer = io.BytesIO()
    >>> fig.savefig(buffer, format="png", dpi=200)
    >>> plt.close(fig)
    >>> small = palette_png(buffer.getvalue())
    >>> len(small) < len(buffer.getvalue()) / 2
    True
    >>> image = Image.open(io.BytesIO(small))
    >>> image.mode, image.size, [round(d) for d in image.info["dpi"]]
    ('P', (600, 400), [200, 200])
    """
    import io

    from PIL import Image

    if not isinstance(png, (bytes, bytearray)) or not bytes(png[:8]) == b"\x89PNG\r\n\x1a\n":
        what = "bytes without the PNG signature" if isinstance(png, (bytes, bytearray)) else type(png).__name__
        raise ValueError(f"png must be the bytes of a PNG image (e.g. from fig.savefig(buffer, format='png')); "
                         f"got {what}")
    if isinstance(colors, bool) or not isinstance(colors, int) or not 2 <= colors <= 256:
        raise ValueError(f"colors must be an integer from 2 to 256 (a PNG palette); got {colors!r}")
    if isinstance(max_error, bool) or not isinstance(max_error, int) or not 0 <= max_error <= 255:
        raise ValueError(f"max_error must be an integer from 0 to 255; got {max_error!r}")
    with Image.open(io.BytesIO(bytes(png))) as source:
        dpi = source.info.get("dpi")
        rgb = source.convert("RGB")
    # the fast quantizer first; where it moves a pixel too far (areas blended with transparency), the one that
    # gives every colour cluster its share
    for method in (Image.Quantize.FASTOCTREE, Image.Quantize.MAXCOVERAGE):
        paletted = rgb.quantize(colors, method=method, dither=Image.Dither.NONE)
        error = np.abs(np.asarray(paletted.convert("RGB"), dtype=np.int16) - np.asarray(rgb, dtype=np.int16))
        if error.max(initial=0) <= max_error:
            break
    else:
        return png
    buffer = io.BytesIO()
    paletted.save(buffer, format="png", optimize=True, **({"dpi": dpi} if dpi else {}))
    return buffer.getvalue() if buffer.tell() < len(png) else png


def mark_beacon(ax: Any, position: ArrayLike = (0.0, 0.0), label: str = "beacon") -> None:
    """Draw a beacon as a black triangle at ``position`` (x east, y north, metres).

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> from uwtutor.plotting import mark_beacon
    >>> fig, ax = plt.subplots()
    >>> mark_beacon(ax, (100.0, 50.0))
    >>> ax.lines[0].get_xydata().tolist(), ax.lines[0].get_label()
    ([[100.0, 50.0]], 'beacon')
    >>> plt.close(fig)
    """
    x, y = as_point("position", position)
    ax.plot([x], [y], marker="^", color="black", markersize=9, linestyle="none", label=label)


def plot_track(ax: Any, positions: ArrayLike, label: str | None = None, **style: Any) -> None:
    """Plot a 2-D track given as an array of shape (K, 2), with a dot at its start, on equal axes.

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> import numpy as np
    >>> from uwtutor.plotting import plot_track
    >>> fig, ax = plt.subplots()
    >>> plot_track(ax, np.array([[0.0, 0.0], [10.0, 5.0], [20.0, 0.0]]), label="truth")
    >>> len(ax.lines), ax.get_xlabel()
    (2, 'x east [m]')
    >>> plt.close(fig)
    """
    p = as_float_array("positions", positions, ndim=2, nonempty=True)
    if p.shape[1] != 2:
        raise ValueError(f"positions must have shape (K, 2) (one [x, y] per row); got {p.shape}")
    if np.isinf(p).any():
        raise ValueError("positions must be finite (NaN, which leaves a gap in the line, is allowed); got an "
                         "infinite value")
    (line,) = ax.plot(p[:, 0], p[:, 1], label=label, **style)
    ax.plot(p[0, 0], p[0, 1], "o", color=line.get_color(), markersize=4)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x east [m]")
    ax.set_ylabel("y north [m]")


# matplotlib's HTML animation template links Font Awesome 4 from a CDN for its buttons. The book must load nothing
# from outside (it is read offline, at sea), and its theme already bundles Font Awesome, whose ``fa fa-play``-style
# classes the buttons use, so the link is dropped rather than vendored a second time.
_CDN_STYLESHEET = re.compile(r"<link[^>]*href=\"https?://[^\"]*font-awesome[^\"]*\"[^>]*>\s*", re.IGNORECASE)
#: The player's picture in matplotlib's HTML animation template (``<img id="_anim_img{id}">``).
_PLAYER_IMAGE = re.compile(r'<img id="_anim_img[0-9a-f]*">')
#: A frame of the player: ``frames[i] = "data:image/png;base64,..."`` (base64 lines joined by backslash-newlines).
_FRAME = re.compile(r'(frames\[\d+\]\s*=\s*"data:image/png;base64,)([^"]*)"')


def _palette_frame(match: Any) -> str:
    from base64 import b64decode

    png = b64decode(match.group(2).replace("\\\n", "").replace("\n", ""))
    return match.group(1) + b2a_base64(palette_png(png), newline=False).decode("ascii") + '"'


def plain_log_ticks(ax: Any, axis: str = "y") -> None:
    """Label a logarithmic axis with plain numbers (1, 2, 5, 10, 20...) instead of powers of ten.

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> from uwtutor.plotting import plain_log_ticks
    >>> fig, ax = plt.subplots()
    >>> _ = ax.semilogy([1, 2, 3], [3.0, 30.0, 300.0])
    >>> plain_log_ticks(ax)
    >>> ax.yaxis.get_major_formatter()(20.0, 0)
    '20'
    >>> plt.close(fig)
    """
    from matplotlib.ticker import FixedLocator, FuncFormatter, NullFormatter

    if axis not in ("x", "y"):
        raise ValueError(f"axis must be 'x' or 'y'; got {axis!r}")
    target = ax.yaxis if axis == "y" else ax.xaxis
    lo, hi = ax.get_ylim() if axis == "y" else ax.get_xlim()
    decades = np.log10(hi / max(lo, 1e-300))
    lo_exp, hi_exp = int(np.floor(np.log10(max(lo, 1e-300)))), int(np.ceil(np.log10(hi)))

    def multiples(mantissas: tuple[float, ...]) -> list[float]:
        return [m * 10.0**e for e in range(lo_exp, hi_exp + 1) for m in mantissas if lo <= m * 10.0**e <= hi]

    if decades < 1.7:                                  # up to a decade and a half: 1, 1.5, 2, 3, 5, 7 x 10^n
        ticks = multiples((1.0, 1.5, 2.0, 3.0, 5.0, 7.0))
        if len(ticks) < 3:                             # a very narrow range: every integer multiple
            ticks = multiples(tuple(float(m) for m in range(1, 10)))
    elif decades < 3.0:
        ticks = multiples((1.0, 2.0, 5.0))
    else:
        ticks = multiples((1.0,))
    target.set_major_locator(FixedLocator(ticks))
    target.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    target.set_minor_formatter(NullFormatter())


def method_style(method: str, highlight: dict[str, str] | None = None) -> dict[str, Any]:
    """Line style of ``method`` in a figure comparing many methods: its own colour if it is highlighted, grey else.

    Parameters
    ----------
    method : str
        The method's name (as in :mod:`uwtutor.methods`).
    highlight : dict of str to str, optional
        The highlighted methods and their colours; :data:`HIGHLIGHT_METHODS` by default.

    Returns
    -------
    dict
        ``color``, ``lw`` and ``zorder``, to pass to ``ax.plot``: highlighted lines thicker and in front.

    Examples
    --------
    >>> from uwtutor.plotting import method_style
    >>> method_style("EKF")
    {'color': 'C3', 'lw': 1.3, 'zorder': 3}
    >>> method_style("SFEKF")
    {'color': '0.78', 'lw': 0.7, 'zorder': 2}
    """
    chosen = HIGHLIGHT_METHODS if highlight is None else highlight
    if method in chosen:
        return {"color": chosen[method], "lw": 1.3, "zorder": 3}
    return {"color": OTHERS_COLOR, "lw": 0.7, "zorder": 2}


def method_legend(n_others: int, highlight: dict[str, str] | None = None,
                  extra: tuple[tuple[str, dict[str, Any]], ...] = ()) -> tuple[list[Any], list[str]]:
    """Legend entries of a figure drawn with :func:`method_style`: one per highlighted method, one for the others.

    Parameters
    ----------
    n_others : int
        How many methods are drawn grey (the legend says "the N others").
    highlight : dict of str to str, optional
        As in :func:`method_style`.
    extra : tuple of (label, line style) pairs
        More entries after these (a bound, for instance: ``(("bound", {"color": "k", "ls": "--"}),)``).

    Returns
    -------
    handles, labels
        For ``ax.legend(handles, labels)`` or ``fig.legend(handles, labels)``.

    Examples
    --------
    >>> from uwtutor.plotting import method_legend
    >>> handles, labels = method_legend(3, highlight={"EKF": "C3"})
    >>> labels
    ['EKF', 'the three others']
    """
    from matplotlib.lines import Line2D

    chosen = HIGHLIGHT_METHODS if highlight is None else highlight
    entries = [(name, method_style(name, chosen)) for name in chosen]
    if n_others:
        words = {1: "one", 2: "two", 3: "three", 4: "four", 5: "five", 6: "six", 7: "seven", 8: "eight", 9: "nine"}
        entries.append((f"the {words.get(n_others, n_others)} others" if n_others > 1 else "the other",
                        {"color": OTHERS_COLOR, "lw": 0.7}))
    entries.extend(extra)
    handles = [Line2D([], [], **{k: v for k, v in style.items() if k != "zorder"}) for _, style in entries]
    return handles, [label for label, _ in entries]


def legend_below(ax: Any, ncol: int = 1, drop: float = 0.45, **kwargs: Any) -> Any:
    """Put the legend of ``ax`` under its x label, off the data.

    ``drop`` is the distance in inches from the bottom of the axes to the top of the legend (room for the tick
    labels and the x label). Draw the figure with ``layout="constrained"`` (or ``bbox_inches="tight"``, as the
    notebook's PNGs are) so that the legend is kept inside the image. ``kwargs`` go to ``ax.legend``; the font is
    :data:`MIN_FONT_SIZE` unless given.

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> from uwtutor.plotting import legend_below
    >>> fig, ax = plt.subplots(layout="constrained")
    >>> _ = ax.plot([0, 1], [0, 1], label="a line")
    >>> legend = legend_below(ax, ncol=2)
    >>> [t.get_text() for t in legend.get_texts()]
    ['a line']
    >>> plt.close(fig)
    """
    from matplotlib.transforms import ScaledTranslation

    kwargs.setdefault("fontsize", MIN_FONT_SIZE)
    shift = ScaledTranslation(0.0, -drop, ax.figure.dpi_scale_trans)
    return ax.legend(loc="upper center", bbox_to_anchor=(0.5, 0.0), bbox_transform=ax.transAxes + shift,
                     ncol=ncol, **kwargs)


def animation_html(animation: Any, default_mode: str = "loop") -> Any:
    """An animation as self-contained HTML for the book: frames embedded, no stylesheet fetched from a CDN.

    Parameters
    ----------
    animation : matplotlib.animation.Animation
        The animation to render (with ``to_jshtml``).
    default_mode : str
        ``"loop"``, ``"once"`` or ``"reflect"``: what the player does at the last frame.

    Returns
    -------
    IPython.display.HTML
        The player, ready to be the last expression of a notebook cell.

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> from matplotlib.animation import FuncAnimation
    >>> from uwtutor.plotting import animation_html
    >>> fig, ax = plt.subplots(figsize=(1.0, 1.0), dpi=20)
    >>> (line,) = ax.plot([0.0, 1.0], [0.0, 0.0])
    >>> anim = FuncAnimation(fig, lambda i: line.set_ydata([0.0, float(i)]), frames=2)
    >>> html = animation_html(anim, default_mode="once")
    >>> plt.close(fig)
    >>> "<img" in html.data, "font-awesome" in html.data
    (True, False)
    >>> 'width="20"' in html.data  # frames of 40 pixels (PIXEL_RATIO), shown 20 wide
    True
    """
    from IPython.display import HTML
    from matplotlib.animation import Animation

    as_instance("animation", animation, Animation, "e.g. a matplotlib.animation.FuncAnimation")
    if default_mode not in ("loop", "once", "reflect"):
        raise ValueError(f"default_mode must be 'loop', 'once' or 'reflect'; got {default_mode!r}")
    # every frame's legend is checked as it is drawn (check_legends_on_display sees only figures shown whole)
    fig = animation._fig
    covered: list[str] = []
    checking = [False]

    def check_frame(event: Any) -> None:
        if not checking[0]:
            checking[0] = True
            try:
                covered.extend(p for p in legend_overlaps(fig) if p not in covered)
            finally:
                checking[0] = False

    cid = fig.canvas.mpl_connect("draw_event", check_frame)
    try:  # frames of PIXEL_RATIO image pixels per figure pixel, shown at the figure's size (as use_sharp_figures)
        with plt.rc_context({"savefig.dpi": fig.dpi * PIXEL_RATIO}):
            html = animation.to_jshtml(default_mode=default_mode)
    finally:
        fig.canvas.mpl_disconnect(cid)
    width = round(fig.get_figwidth() * fig.dpi)
    html = _PLAYER_IMAGE.sub(lambda m: f'{m.group(0)[:-1]} width="{width}">', html, count=1)
    html = _FRAME.sub(_palette_frame, html)  # each frame with a palette, as a notebook's figures
    if covered:
        import sys

        for problem in covered:
            print(f"{LEGEND_WARNING} (animation): {problem}", file=sys.stderr)
    return HTML(_CDN_STYLESHEET.sub("", html))


def _inside(box: Any, points: Any) -> bool:
    """Whether any of the display-space ``points`` (shape (K, 2)) lies in ``box``."""
    p = np.asarray(points, dtype=float).reshape(-1, 2)
    return bool(((p[:, 0] >= box.x0) & (p[:, 0] <= box.x1) & (p[:, 1] >= box.y0) & (p[:, 1] <= box.y1)).any())


def _covers(artist: Any, box: Any) -> bool:
    """Whether the display-space box ``box`` covers part of ``artist`` (a line, a collection or a patch of an axes)."""
    from matplotlib.collections import PathCollection, PolyCollection, LineCollection
    from matplotlib.lines import Line2D

    if isinstance(artist, Line2D):
        path = artist.get_transform().transform_path(artist.get_path())
        line = artist.get_linestyle() not in ("None", "none", "", " ") and path.intersects_bbox(box, filled=False)
        marker = artist.get_marker() not in (None, "None", "none", "", " ")
        return bool(line or (marker and _inside(box, path.vertices)))
    if isinstance(artist, PathCollection):  # scatter: markers at offsets
        points = np.asarray(artist.get_offset_transform().transform(artist.get_offsets()))
        return _inside(box, points)
    if isinstance(artist, (PolyCollection, LineCollection)):  # fill_between, error bars, segments
        transform = artist.get_transform()
        filled = isinstance(artist, PolyCollection)
        return any(transform.transform_path(p).intersects_bbox(box, filled=filled) for p in artist.get_paths())
    if hasattr(artist, "get_path") and hasattr(artist, "get_fill"):  # bars, circles, polygons
        path = artist.get_transform().transform_path(artist.get_path())
        return bool(path.intersects_bbox(box, filled=artist.get_fill()))
    return False  # images, meshes, text: not data here


def legend_overlaps(fig: Any) -> list[str]:
    """What the legends of ``fig`` cover: the drawn data (lines, markers, filled areas, bars) under each legend box.

    Each legend's box (its window extent, frame or not) is clipped to each axes it lies on, and tested against the
    display-space paths of that axes' artists: a line or an area edge that crosses the box, a marker or an area
    inside it. Images (a heat map fills its axes) and text are not data here. Legends placed outside the axes
    (:func:`legend_below`) cover nothing.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        A figure, drawn or not (it is drawn once to place the legends).

    Returns
    -------
    list of str
        One line per covered artist: the axes' title or position, the legend's first entry and the artist's label.
        Empty when no legend covers data.

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> from uwtutor.plotting import legend_overlaps
    >>> fig, ax = plt.subplots()
    >>> _ = ax.plot([0, 1], [1, 1], label="high")
    >>> _ = ax.plot([0, 1], [0, 0], label="low")
    >>> _ = ax.legend(loc="upper right")
    >>> legend_overlaps(fig)
    ["axes 1: the legend ('high', ...) covers 'high'"]
    >>> ax.set_ylim(-0.1, 2.0)
    (-0.1, 2.0)
    >>> legend_overlaps(fig)
    []
    >>> plt.close(fig)
    """
    from matplotlib.figure import Figure
    from matplotlib.transforms import Bbox

    as_instance("fig", fig, Figure, "e.g. the figure of plt.subplots()")
    fig.draw_without_rendering()  # places legends and layout on any canvas (a closed figure's too)
    # every legend against every axes: a legend placed outside its own axes may land on a neighbour's data
    legends = [(ax.get_legend(), list(fig.axes)) for ax in fig.axes if ax.get_legend() is not None]
    legends += [(legend, list(fig.axes)) for legend in fig.legends]
    found: list[str] = []
    for legend, axes in legends:
        if not legend.get_visible():
            continue
        box = legend.get_window_extent().padded(-1.0)  # a pixel of tolerance on each side
        texts = [t.get_text() for t in legend.get_texts()]
        for index, ax in enumerate(fig.axes):
            if ax not in axes or not ax.get_visible():
                continue
            inside = Bbox.intersection(box, ax.bbox)
            if inside is None or inside.width <= 0 or inside.height <= 0:
                continue
            name = f"axes {index + 1}" + (f" ({ax.get_title()!r})" if ax.get_title() else "")
            for artist in [*ax.lines, *ax.collections, *ax.patches]:
                if artist.get_visible() and _covers(artist, inside):
                    label = artist.get_label()
                    what = repr(label) if label and not label.startswith("_") else type(artist).__name__
                    found.append(f"{name}: the legend ({texts[0]!r}, ...) covers {what}" if texts else
                                 f"{name}: a legend covers {what}")
    return found


def check_legends_on_display() -> bool:
    """In a notebook, warn under every figure whose legend covers data (see :func:`legend_overlaps`).

    Wraps the PNG formatter that matplotlib's inline backend registers for figures, so that each figure the notebook
    shows is checked as it is drawn: a line on stderr (:data:`LEGEND_WARNING` and what is covered) appears under it,
    and nbval, which compares every cell's text output with the committed one, fails on it (tests/test_legends.py
    fails on a committed one). Outside IPython it does nothing.

    Returns
    -------
    bool
        Whether the check is on (an IPython kernel with a PNG formatter for figures).

    Examples
    --------
    >>> from uwtutor.plotting import check_legends_on_display
    >>> check_legends_on_display()  # outside a notebook
    False
    """
    try:
        from IPython import get_ipython
    except ImportError:  # pragma: no cover - IPython comes with matplotlib-inline
        return False
    shell = get_ipython()
    if shell is None or not hasattr(shell, "display_formatter"):
        return False

    # The inline backend registers its figure formatter when it is loaded, which matplotlib does lazily (at the
    # first figure): load it now. And check before every cell that the wrapper is still there (a notebook may
    # register the formatter again, e.g. with set_matplotlib_formats).
    plt.switch_backend(plt.get_backend())
    if not getattr(shell, "_uwtutor_legend_hook", False):
        shell.events.register("pre_run_cell", lambda *args: _wrap_figure_formatter(shell))
        shell._uwtutor_legend_hook = True
    return _wrap_figure_formatter(shell)


def _wrap_figure_formatter(shell: Any) -> bool:
    from matplotlib.figure import Figure

    formatter = shell.display_formatter.formatters["image/png"]
    try:
        draw = formatter.lookup_by_type(Figure)
    except KeyError:
        return False
    if getattr(draw, "_uwtutor_checks_legends", False):
        return True

    def checked(fig: Any) -> Any:
        import sys

        for problem in legend_overlaps(fig):  # plain text: a warning's file path would differ between machines
            print(f"{LEGEND_WARNING}: {problem}", file=sys.stderr)
        return draw(fig)

    checked._uwtutor_checks_legends = True  # type: ignore[attr-defined]
    formatter.for_type(Figure, checked)
    return True

