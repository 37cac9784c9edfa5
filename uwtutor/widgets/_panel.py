"""The thin ipywidgets layer shared by every widget of the book: controls above one figure, updated in place.

An update does the least a new picture needs. A setting of the controls shown before is shown again from the
pictures the panel keeps (the last ``PICTURES_KEPT``, by control values). Otherwise the chapter's compute function
runs (each widget keeps its results in a small cache keyed by the control values). Then, where the chapter gives
an ``update`` function, the artists of the figure already drawn take the new data in place (``set_data``,
``set_offsets``, ``set_text``): no axes, ticks or layout are made again. The picture is then drawn *by blitting*:
the figure without the artists that change (axes, ticks, labels, grid: the "background") is drawn once and kept as
pixels; each update restores those pixels and draws only the changed artists on them, unless the axes themselves
changed (limits, scale, position), which draws the background again: of those axes alone when what they cover meets
no other axes. ``rescale`` keeps limits while the data fits them (in whole decades on a log axis, if asked), so that
most moves of a control keep the background. The PNG goes to an ``ipywidgets.Image`` as bytes (one comm message, no
base64), lightly compressed. Without ``update``, the figure is cleared and drawn again by
the chapter's plot function. ``make bench`` times every control of every widget in JupyterLab.

A widget whose full answer takes longer than a reader should wait (a long filter run) may give a *coarse* answer
first (``slider_panel``'s ``refine``): in a live kernel the panel shows the coarse picture at once, labelled as such by
the widget, and computes the full answer in one background thread; when it is done, and if the controls still hold
that setting, the full picture replaces the coarse one. A refinement for a setting left meanwhile is dropped: if it
is still computing, the library's filter loops stop it at their next step (``uwtutor._cancel``), so that the next
setting's coarse picture does not share the interpreter with it; a result it completed stays in the widget's cache.
The full picture is drawn from the axes as they were before the coarse one, so it is the picture the panel draws
without refinement. Outside a kernel (tests, scripts, the book's static pages) and with
``REFINE_IN_BACKGROUND = False`` the full answer is computed at once, as without ``refine``.
"""

from __future__ import annotations

import functools
import struct
import sys
import threading
import traceback
import zlib
from collections import OrderedDict
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any, Callable, Sequence

import matplotlib.pyplot as plt
from matplotlib.figure import Figure
import numpy as np

from .._cancel import Cancelled, cancel_when
from ..plotting import LEGEND_WARNING, PIXEL_RATIO, legend_overlaps

__all__ = ["slider_panel", "figure_png", "BlitRenderer", "keep", "kept", "rescale", "snap_to_decades",
           "wait_refined", "REFINE_IN_BACKGROUND"]

#: Whether a panel with ``refine`` shows a coarse answer at once and computes the full one in a background thread:
#: ``None`` (the default) does so only inside a live IPython kernel; ``False`` computes the full answer at once
#: (deterministic: tests, scripts, executing the book); ``True`` always refines in the background (the benchmark).
REFINE_IN_BACKGROUND: bool | None = None


def _agg_canvas(fig: Figure) -> Any:
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    return fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)


def _png_chunk(kind: bytes, data: bytes) -> bytes:
    """One PNG chunk: length, type, data, and the CRC-32 of type and data (PNG specification, section 5.3)."""
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def _encode_png(canvas: Any) -> bytes:
    """The pixels of ``canvas`` (an Agg canvas already drawn) as PNG bytes (RGB, 8 bits), compressed lightly.

    The rows go to zlib at level 1 unfiltered (filter type 0): the bytes go to a browser on the same machine or
    network, where encoding time matters more than size, and a figure's flat background compresses well without
    the per-row filter search of a general encoder (which took over half the time of an update's PNG). The
    picture's resolution is written as ``savefig`` writes it (``pHYs``): what a reader of the picture sizes it by.

    Examples
    --------
    >>> import io
    >>> from PIL import Image
    >>> from matplotlib.figure import Figure
    >>> fig = Figure(figsize=(2.0, 1.0), dpi=50)
    >>> _ = fig.subplots().plot([0, 1], [0, 1])
    >>> canvas = _agg_canvas(fig)
    >>> canvas.draw()
    >>> image = Image.open(io.BytesIO(_encode_png(canvas)))
    >>> image.size, image.mode, [round(d) for d in image.info["dpi"]]
    ((100, 50), 'RGB', [50, 50])
    """
    width, height = canvas.get_width_height(physical=True)
    rgba = np.asarray(canvas.buffer_rgba())
    rows = np.empty((height, 1 + 3 * width), dtype=np.uint8)
    rows[:, 0] = 0                                      # each row's filter type: none
    rows[:, 1:].reshape(height, width, 3)[...] = rgba[..., :3]
    per_metre = int(canvas.figure.dpi / 0.0254 + 0.5)
    return b"".join([
        b"\x89PNG\r\n\x1a\n",
        _png_chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)),
        _png_chunk(b"pHYs", struct.pack(">IIB", per_metre, per_metre, 1)),
        _png_chunk(b"IDAT", zlib.compress(rows.tobytes(), 1)),
        _png_chunk(b"IEND", b""),
    ])


def figure_png(fig: Figure) -> bytes:
    """The figure as PNG bytes at its own resolution (``fig.dpi``), drawn by an Agg canvas kept on the figure.

    The canvas (and so its renderer and text caches) is made once per figure rather than once per picture, as
    ``savefig`` on an inline-backend figure would.

    Examples
    --------
    >>> from matplotlib.figure import Figure
    >>> fig = Figure(figsize=(2.0, 1.0), dpi=50)
    >>> _ = fig.subplots().plot([0, 1], [0, 1])
    >>> figure_png(fig)[1:4]
    b'PNG'
    """
    canvas = _agg_canvas(fig)
    canvas.draw()
    return _encode_png(canvas)


def keep(fig: Figure, **artists: Any) -> Figure:
    """Remember the artists a plot function made on ``fig`` by name, for its ``update`` function; returns ``fig``.

    Examples
    --------
    >>> from matplotlib.figure import Figure
    >>> fig = Figure()
    >>> (line,) = fig.subplots().plot([0, 1], [0, 1])
    >>> keep(fig, line=line) is fig
    True
    """
    setattr(fig, "_uwtutor_artists", artists)      # noqa: B010 - an attribute of our own on matplotlib's Figure
    return fig


def kept(fig: Figure) -> dict[str, Any] | None:
    """The artists ``keep`` remembered on ``fig`` (``None`` if it has none).

    Examples
    --------
    >>> from matplotlib.figure import Figure
    >>> fig = Figure()
    >>> (line,) = fig.subplots().plot([0, 1], [0, 1])
    >>> kept(keep(fig, line=line))["line"] is line, kept(Figure())
    (True, None)
    """
    return getattr(fig, "_uwtutor_artists", None)


def _decades(lo: float, hi: float) -> tuple[float, float]:
    """The whole decades (as powers of ten, in log10 units) that enclose ``lo`` to ``hi`` (log10 units)."""
    return float(np.floor(min(lo, hi) + 1e-9)), float(np.ceil(max(lo, hi) - 1e-9))


def snap_to_decades(*axes: Any, axis: str = "y") -> None:
    """Widen the limits of each log ``axis`` ("x" or "y") of ``axes`` outwards to whole decades, as
    ``rescale(..., decades=True)`` keeps them: a plot function calls it last so that the first updates of its
    figure keep these limits (and the pixels of its background). Autoscaling stays as it was.

    Examples
    --------
    >>> from matplotlib.figure import Figure
    >>> ax = Figure().subplots()
    >>> _ = ax.semilogy([0, 1], [2.0, 30.0])
    >>> snap_to_decades(ax)
    >>> [float(v) for v in ax.get_ylim()]
    [1.0, 100.0]
    """
    for ax in axes:
        get, set_ = (ax.get_xlim, ax.set_xlim) if axis == "x" else (ax.get_ylim, ax.set_ylim)
        scale = ax.get_xscale() if axis == "x" else ax.get_yscale()
        v0, v1 = get()
        if scale != "log" or min(v0, v1) <= 0:
            continue
        d0, d1 = _decades(*np.log10([v0, v1]))
        set_(10.0**d0, 10.0**d1, auto=None)


def rescale(*axes: Any, keep_within: float = 0.5, headroom: float = 0.15, decades: bool = False,
            spare_decades: float = 1.0) -> None:
    """Fit each axes' limits to its data again after ``set_data``, as the first drawing did, but keep the limits it
    has while the data fits in them and spans at least ``keep_within`` of them on both axes (in log units on a log
    axis; on either axis for an equal-aspect axes that fits its limits to the data, whose other axis is set by the
    aspect): then the axes, and the pixels kept of them, stay as they are (see ``BlitRenderer``). When the limits
    do change, an axis whose data outgrew them gets ``headroom`` (a fraction of the span) on each side, so that the
    next step the same way usually fits. With ``decades``, a log axis instead takes whole decades around its data
    and keeps them while the data fits and they are at most ``spare_decades`` more than the data needs: a curve
    that moves within its decades (most moves of a slider) leaves the axes as they are.

    Examples
    --------
    >>> from matplotlib.figure import Figure
    >>> ax = Figure().subplots()
    >>> (line,) = ax.plot([0, 1], [0, 1])
    >>> # the data outgrew the x limits: refit, with headroom
    >>> line.set_data([0, 10], [0, 1])
    >>> rescale(ax)
    >>> [round(float(v), 2) for v in ax.get_xlim()]
    [-2.15, 12.15]
    >>> # fits and spans over half of them: the limits are kept
    >>> line.set_data([0, 8], [0, 1])
    >>> rescale(ax)
    >>> [round(float(v), 2) for v in ax.get_xlim()]
    [-2.15, 12.15]
    >>> # a log axis in decades: kept while the data fits, then whole decades again
    >>> ax.set_yscale("log")
    >>> line.set_data([0, 8], [2.0, 30.0])
    >>> rescale(ax, decades=True)
    >>> [float(v) for v in ax.get_ylim()]
    [1.0, 100.0]
    >>> line.set_data([0, 8], [3.0, 60.0])
    >>> rescale(ax, decades=True)
    >>> [float(v) for v in ax.get_ylim()]
    [1.0, 100.0]
    >>> line.set_data([0, 8], [3.0, 600.0])
    >>> rescale(ax, decades=True)
    >>> [float(v) for v in ax.get_ylim()]
    [1.0, 1000.0]
    """
    for ax in axes:
        # An equal-aspect axes that fits its limits to the data ("datalim") would re-centre kept limits on the
        # data at every draw: while its limits are kept it keeps its box instead, and fits them again after.
        if getattr(ax, "_uwtutor_datalim", False) or (ax.get_aspect() != "auto"
                                                      and ax.get_adjustable() == "datalim"):
            ax._uwtutor_datalim = True
            ax.set_adjustable("datalim")
        datalim = getattr(ax, "_uwtutor_datalim", False)
        old = (ax.get_xlim(), ax.get_ylim())
        ax.relim()
        ax.autoscale_view()
        new = (ax.get_xlim(), ax.get_ylim())
        scales = (ax.get_xscale(), ax.get_yscale())
        fits, spans, grow = [True, True], [True, True], [False, False]
        snapped: list[tuple[float, float] | None] = [None, None]
        for i, ((o0, o1), (n0, n1), scale) in enumerate(zip(old, new, scales)):
            if scale == "log":
                if min(o0, o1, n0, n1) <= 0:
                    fits[i] = False
                    continue
                o0, o1, n0, n1 = np.log10([o0, o1, n0, n1])
            lo, hi = min(o0, o1), max(o0, o1)
            fits[i] = inside = lo <= min(n0, n1) and max(n0, n1) <= hi
            if decades and scale == "log":
                d0, d1 = snapped[i] = _decades(n0, n1)
                spans[i] = (hi - lo) <= d1 - d0 + spare_decades + 1e-9
            else:
                spans[i] = abs(n1 - n0) >= keep_within * (hi - lo)
            grow[i] = not inside
        # the data must fit on both axes; on an equal-aspect axes one axis spanned is enough (the aspect widens
        # the other to match the box, so its data can span a small part of it however the limits are chosen)
        keep = all(fits) and (any(spans) if datalim else all(spans))
        # auto=None: limits set here keep the axes' autoscaling as it was (set_xlim alone would turn it off, and the
        # next change of the data could not move them any more)
        if keep:
            ax.set_xlim(*old[0], auto=None)
            ax.set_ylim(*old[1], auto=None)
            if datalim:
                ax.set_adjustable("box")
            continue
        if datalim and scales == ("linear", "linear"):
            ax.apply_aspect()                           # the frame a draw would give, then room on all sides
            (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
            ax.set_xlim(x0 - headroom * (x1 - x0), x1 + headroom * (x1 - x0), auto=None)
            ax.set_ylim(y0 - headroom * (y1 - y0), y1 + headroom * (y1 - y0), auto=None)
            ax.set_adjustable("box")                    # the same ratio: the box stays where it is
            continue
        for i, ((n0, n1), scale) in enumerate(zip(new, scales)):
            if (i == 0 and ax.get_autoscalex_on() is False) or (i == 1 and ax.get_autoscaley_on() is False):
                continue
            whole = snapped[i]
            if whole is not None:                       # whole decades, grown or shrunk
                limits = (10.0 ** whole[0], 10.0 ** whole[1])
            elif not grow[i]:
                continue
            elif scale == "log":
                if min(n0, n1) <= 0:
                    continue
                l0, l1 = np.log10([n0, n1])
                pad = headroom * (l1 - l0)
                limits = (10 ** (l0 - pad), 10 ** (l1 + pad))
            elif scale == "linear":
                pad = headroom * (n1 - n0)
                limits = (n0 - pad, n1 + pad)
            else:
                continue
            (ax.set_xlim if i == 0 else ax.set_ylim)(*limits, auto=None)


def _axes_signature(fig: Figure) -> tuple:
    """What the background of ``fig`` depends on besides its static artists: each axes' position, limits, scales
    (after the axes' aspect is applied, as drawing does)."""
    for ax in fig.axes:
        ax.apply_aspect()
    return tuple((tuple(np.round(ax.get_position().bounds, 6)), ax.get_xscale(), ax.get_yscale(),
                  tuple(ax.get_xlim()), tuple(ax.get_ylim())) for ax in fig.axes)


def _same_background(a: tuple | None, b: tuple, tolerance: float = 2e-3) -> bool:
    """Whether two ``_axes_signature`` are the same picture: same axes, positions and scales, and limits that differ
    by less than ``tolerance`` of their span (a fraction of a pixel; in decades on a log axis). An axes with an
    equal aspect re-centres its limits by a hair when its data moves; that alone does not redraw the background."""
    if a is None or len(a) != len(b):
        return False
    for (pos_a, xs_a, ys_a, *lims_a), (pos_b, xs_b, ys_b, *lims_b) in zip(a, b):
        if pos_a != pos_b or xs_a != xs_b or ys_a != ys_b:
            return False
        for (a0, a1), (b0, b1), scale in zip(lims_a, lims_b, (xs_a, ys_a)):
            if scale == "log":
                if min(a0, a1, b0, b1) <= 0:
                    return False
                a0, a1, b0, b1 = np.log10([a0, a1, b0, b1])
            span = abs(a1 - a0)
            if not (abs(a0 - b0) <= tolerance * span and abs(a1 - b1) <= tolerance * span):
                return False
    return True


def _axes_boxes(ax: Any, renderer: Any) -> list[Any]:
    """The rectangles (display units, whole pixels with a pixel to spare) that cover what ``ax`` draws: its frame,
    and each of its axis (ticks and labels), titles, legends and texts that reach outside the frame. Finer than
    one bounding box (a legend below a map and the neighbour's tick labels beside it can share no pixel while their
    common bounding box would)."""
    from matplotlib.transforms import Bbox

    frame = ax.get_window_extent(renderer)
    found = [frame]
    for artist in [ax.xaxis, ax.yaxis, *ax.get_default_bbox_extra_artists()]:
        box = artist.get_tightbbox(renderer)
        if box is None or not (box.width > 0 and box.height > 0) or not np.all(np.isfinite(box.extents)):
            continue
        if frame.x0 <= box.x0 and box.x1 <= frame.x1 and frame.y0 <= box.y0 and box.y1 <= frame.y1:
            continue                                # inside the frame: covered by it
        found.append(box)
    return [Bbox([[np.floor(b.x0) - 1, np.floor(b.y0) - 1], [np.ceil(b.x1) + 1, np.ceil(b.y1) + 1]]) for b in found]


class BlitRenderer:
    """PNGs of one figure whose ``dynamic`` artists change between pictures, drawn over a kept background.

    ``png(dynamic)`` marks the artists ``dynamic`` as animated (so a plain draw leaves them out), draws the rest of
    the figure only when the axes changed since the last picture (or on the first), and otherwise restores its
    pixels; then it draws the dynamic artists over it. When only some axes changed, and the area each of them
    covers (with its tick labels, title and legend, before and after) meets no other axes' area, only those axes
    are drawn again and put into the kept pixels (``_redraw_axes``); otherwise the whole background is drawn.
    ``png(None)`` draws everything (the figure was made anew), and so does a ``dynamic`` that holds the figure itself
    (its artists changed in place all over: colours, tick labels).

    Examples
    --------
    >>> from matplotlib.figure import Figure
    >>> fig = Figure(figsize=(2.0, 1.0), dpi=50)
    >>> (line,) = fig.subplots().plot([0, 1], [0, 1])
    >>> renderer = BlitRenderer(fig)
    >>> first = renderer.png(None)               # everything drawn
    >>> line.set_ydata([1, 0])
    >>> # the background drawn once and kept, the line drawn over it
    >>> second = renderer.png([line])
    >>> renderer.background is not None, first != second
    (True, True)
    """

    def __init__(self, fig: Figure) -> None:
        self.fig = fig
        self.canvas = _agg_canvas(fig)
        self.background: Any = None
        self.signature: tuple | None = None
        self.dynamic: list[Any] = []
        self.left_out: list[Any] = []               # the dynamic artists the kept background was drawn without
        self.regions: list[list[Any]] | None = None  # what each axes covers in the kept background

    def png(self, dynamic: Sequence[Any] | None) -> bytes:
        if not self._background(dynamic):          # drawn anew, or changed all over: a full draw
            return figure_png(self.fig)
        renderer = self.canvas.get_renderer()
        for artist in sorted(self.dynamic, key=lambda a: a.get_zorder()):
            if artist.get_visible():
                artist.draw(renderer)
        return _encode_png(self.canvas)

    def prime(self, dynamic: Sequence[Any] | None) -> None:
        """Draw and keep the background for these ``dynamic`` artists now (e.g. when the panel is built), so that
        the first update only draws them over it."""
        self._background(dynamic)
        for artist in self.dynamic:
            artist.set_animated(False)

    def _background(self, dynamic: Sequence[Any] | None) -> bool:
        """The background for ``dynamic`` in the canvas (drawn, or restored when the axes are as they were);
        False when the picture needs a full draw instead."""
        for artist in self.dynamic:                  # the last picture's dynamic artists: back to normal
            artist.set_animated(False)
        if dynamic is None or self.fig in dynamic:     # drawn anew, or changed all over: a full draw
            self.background, self.signature, self.dynamic, self.left_out = None, None, [], []
            return False
        self.dynamic = [a for a in dynamic if a is not None]
        for artist in self.dynamic:
            artist.set_animated(True)
        signature = _axes_signature(self.fig)
        if self.background is None or not _same_background(self.signature, signature):
            if not self._redraw_axes(signature):
                self.canvas.draw()                  # everything but the dynamic artists
                self.background, self.signature = self.canvas.copy_from_bbox(self.fig.bbox), signature
                self.left_out = list(self.dynamic)
                renderer = self.canvas.get_renderer()
                self.regions = [_axes_boxes(ax, renderer) for ax in self.fig.axes]
        else:
            self.canvas.restore_region(self.background)
            # an artist left out of the kept background but not changed this time is drawn all the same (else it
            # would vanish from the picture), unless it has been removed from the figure since
            self.dynamic += [a for a in self.left_out if a not in self.dynamic and a.figure is not None]
        return True

    def _redraw_axes(self, signature: tuple) -> bool:
        """Draw again, into the kept background, only the axes whose limits changed (``signature``: the figure's
        ``_axes_signature`` now); False, with the kept background left as it was, when the whole figure must be
        drawn instead: no background yet, axes moved or rescaled, figure-level artists, or a changed axes' area
        that meets another axes' area.

        The changed axes are drawn (without their dynamic artists) on the bare figure, and the rectangles they
        cover, before or after (``_axes_boxes``), are copied from that drawing over the kept pixels. Within those
        rectangles nothing else is drawn, so the result is the picture a whole draw would give, at the cost of
        those axes alone.
        """
        from matplotlib.transforms import Bbox

        fig, old = self.fig, self.signature
        if self.background is None or self.regions is None or old is None or len(old) != len(signature) \
                or len(self.regions) != len(fig.axes):
            return False
        changed = [i for i, (a, b) in enumerate(zip(old, signature)) if not _same_background((a,), (b,))]
        if not changed or len(changed) == len(signature) or any(old[i][:3] != signature[i][:3] for i in changed):
            return False
        if any(child is not fig.patch and child not in fig.axes for child in fig.get_children()):
            return False
        renderer = self.canvas.get_renderer()
        renderer.clear()
        fig.patch.draw(renderer)
        axes = [fig.axes[i] for i in changed]
        for ax in sorted(axes, key=lambda a: a.get_zorder()):
            ax.draw(renderer)                       # its dynamic artists (animated) are left out, as in a full draw
        regions = list(self.regions)
        boxes = []
        for i, ax in zip(changed, axes):
            regions[i] = _axes_boxes(ax, renderer)
            boxes += self.regions[i] + regions[i]   # before and after
        within = fig.bbox
        boxes = [b for b in (Bbox.intersection(b, within) for b in boxes) if b is not None and b.width > 0
                 and b.height > 0]
        others = [b for j in range(len(fig.axes)) if j not in changed for b in self.regions[j]]
        for box in boxes:
            for other in others:
                meet = Bbox.intersection(box, other)
                if meet is not None and meet.width > 0 and meet.height > 0:
                    return False
        parts = [self.canvas.copy_from_bbox(box) for box in boxes]
        self.canvas.restore_region(self.background)
        for part in parts:
            self.canvas.restore_region(part)
        self.background, self.signature, self.regions = self.canvas.copy_from_bbox(fig.bbox), signature, regions
        # the kept pixels now leave out this picture's dynamic artists in the changed axes, and the earlier ones
        # elsewhere
        self.left_out = [a for a in self.left_out if getattr(a, "axes", None) not in axes] + list(self.dynamic)
        return True


#: How many pictures a panel keeps, by control values, to show again at once (about 60 kB each).
PICTURES_KEPT = 64


def _key(values: dict[str, Any]) -> tuple:
    """The control values as a key of the pictures kept (unhashable values by their text)."""
    out = []
    for name, value in values.items():
        try:
            hash(value)
        except TypeError:
            value = repr(value)
        out.append((name, value))
    return tuple(out)


def _in_kernel() -> bool:
    """Whether this code runs inside an IPython kernel (where a reader moves the controls), not a plain process."""
    try:
        from IPython import get_ipython
    except ImportError:  # pragma: no cover - IPython comes with ipywidgets
        return False
    shell = get_ipython()
    return shell is not None and getattr(shell, "kernel", None) is not None


def _refine_in_background() -> bool:
    return _in_kernel() if REFINE_IN_BACKGROUND is None else bool(REFINE_IN_BACKGROUND)


def _axes_state(fig: Figure) -> list[tuple]:
    """What an ``update`` reads of the axes besides the data (limits, autoscaling, the equal-aspect state kept by
    ``rescale``): taken before a coarse picture and put back before the full one, which ``rescale`` then fits as
    it would have without the coarse picture."""
    return [(ax, ax.get_xlim(), ax.get_ylim(), ax.get_autoscalex_on(), ax.get_autoscaley_on(), ax.get_adjustable(),
             getattr(ax, "_uwtutor_datalim", None)) for ax in fig.axes]


def _restore_axes(state: list[tuple]) -> None:
    for ax, xlim, ylim, auto_x, auto_y, adjustable, datalim in state:
        ax.set_xlim(*xlim, auto=None)
        ax.set_ylim(*ylim, auto=None)
        ax.set_autoscalex_on(auto_x)
        ax.set_autoscaley_on(auto_y)
        ax.set_adjustable(adjustable)
        if datalim is None:
            ax.__dict__.pop("_uwtutor_datalim", None)
        else:
            ax._uwtutor_datalim = datalim


class _Refiner:
    """The background side of a panel with ``refine``: one worker thread (made at the first refinement), the
    number of the latest setting (a refinement for an older one is dropped), and the lock every use of the figure
    takes (the reader's updates and the worker's full picture never draw at the same time)."""

    def __init__(self) -> None:
        self.lock = threading.RLock()
        self.generation = 0
        self.executor: ThreadPoolExecutor | None = None
        self.pending: list[Future] = []

    def submit(self, task: Callable[[], None]) -> None:
        if self.executor is None:
            self.executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix="uwtutor-refine")
        self.pending = [f for f in self.pending if not f.done()] + [self.executor.submit(task)]

    def wait(self, timeout: float | None = None) -> bool:
        """Wait for every refinement submitted so far; True if none is left running."""
        for future in list(self.pending):
            try:
                future.result(timeout)
            except TimeoutError:
                return False
        return all(f.done() for f in self.pending)


def wait_refined(panel: Any, timeout: float | None = None) -> bool:
    """Wait until the background refinements of ``panel`` (made by ``slider_panel`` with ``refine``) are done;
    True when none is left running (also for a panel without refinement).

    Examples
    --------
    >>> import ipywidgets as w
    >>> from matplotlib.figure import Figure
    >>> def draw(fig, a):
    ...     fig = fig or Figure(figsize=(2.0, 1.5), dpi=50)
    ...     fig.add_subplot().plot([0, 1], [0, a])
    ...     return fig
    >>> wait_refined(slider_panel({"a": w.FloatSlider(value=1.0)}, draw))
    True
    """
    refiner = getattr(panel, "_uwtutor_refiner", None)
    return True if refiner is None else refiner.wait(timeout)


def slider_panel(sliders: dict[str, Any], draw: Callable[..., Any],
                 update: Callable[..., Sequence[Any] | None] | None = None,
                 refine: Callable[..., Callable[[], Any] | None] | None = None) -> Any:
    """Sliders (and other controls) above one figure that is updated whenever a control's value changes.

    Parameters
    ----------
    sliders : dict of str to ipywidgets.ValueWidget
        The controls, by the name of the parameter each sets; the first three in a row, the others in a second
        row. Sliders should have ``continuous_update=False`` (an update on release, not on every pixel of a drag).
    draw : callable
        ``draw(fig, **values)`` draws the view for these parameter values into ``fig`` and returns the figure.
        ``fig`` is ``None`` on the first call (``draw`` makes the figure, at the size it wants) and, after that,
        that same figure, cleared (when there is no ``update``, or ``update`` declines).
    update : callable, optional
        ``update(fig, **values)`` puts the view for these values into the artists of ``fig`` as ``draw`` left them
        and returns every artist it changed (they are drawn over the kept background, see ``BlitRenderer``; the
        figure itself among them draws it all again, in place), or ``None`` when the figure must be made anew (the
        panel then clears it and calls ``draw``).
    refine : callable, optional
        ``refine(**values)`` returns ``None`` when the full answer for these values is at hand (cached), or else a
        zero-argument callable that computes it into the widget's cache (it must be safe to run in another thread
        while the controls move, and keep a result only once it is complete: when the controls leave the setting
        it is stopped at the next ``uwtutor._cancel.checkpoint`` of the library's loops). With ``refine``, ``draw``
        and ``update`` take a keyword ``coarse``: ``True`` asks for the widget's coarse answer, labelled as such in
        the figure. When refining in the background (see ``REFINE_IN_BACKGROUND``) a new setting is drawn coarse at
        once and the full picture follows; otherwise the callable is run at once and the full picture drawn, as
        without ``refine``. ``wait_refined(panel)`` waits for the full picture.

    Returns
    -------
    ipywidgets.VBox
        The two rows of controls, then the figure area: a ``VBox`` of the figure (an ``ipywidgets.Image``) and an
        ``Output`` that shows the error, if a computation fails, until the next update succeeds.

    Examples
    --------
    >>> import ipywidgets as w
    >>> from matplotlib.figure import Figure
    >>> def draw(fig, slope):
    ...     fig = fig or Figure(figsize=(2.0, 1.5), dpi=50)
    ...     fig.add_subplot().plot([0, 1], [0, slope])
    ...     return fig
    >>> slope = w.FloatSlider(value=1.0, min=-2.0, max=2.0, continuous_update=False)
    >>> panel = slider_panel({"slope": slope}, draw)
    >>> image = panel.children[2].children[0]
    >>> before = image.value
    >>> # the figure is drawn again for the new value
    >>> slope.value = -1.0
    >>> image.value != before
    True
    """
    import ipywidgets as w

    values = lambda: {name: s.value for name, s in sliders.items()}  # noqa: E731
    mode = {} if refine is None else {"coarse": False}  # the keyword draw and update take with refine
    fig = draw(None, **values(), **mode)
    plt.close(fig)                      # off pyplot's list: the inline backend must not show it a second time
    for problem in legend_overlaps(fig):  # as for a notebook's figures (check_legends_on_display): the first view
        print(f"{LEGEND_WARNING} (widget): {problem}", file=sys.stderr)  # is the one the HTML book shows
    width_px = round(fig.get_figwidth() * fig.dpi)
    # Drawn at PIXEL_RATIO image pixels per figure pixel and shown at the figure's size, as the notebooks' figures
    # are (uwtutor.plotting.use_sharp_figures): sharp on a phone's 3x screen and in the book's full-size view.
    fig.set_dpi(fig.dpi * PIXEL_RATIO)
    renderer = BlitRenderer(fig)
    # Shown at its own size (a flex box would stretch it to the cell's width, blurred), narrower on a narrow screen.
    image = w.Image(value=renderer.png(None), format="png",
                    layout=w.Layout(width=f"{width_px}px", max_width="100%", height="auto"))
    if update is not None:      # the background of the first update drawn now, while the reader reads
        renderer.prime(update(fig, **values(), **mode))
    messages = w.Output()
    state = {"failed": False}
    shown: OrderedDict[tuple, bytes] = OrderedDict([(_key(values()), bytes(image.value))])
    refiner = _Refiner()

    def picture(current: dict[str, Any], coarse: bool, anew: bool = False) -> tuple[bytes, bool]:
        """The PNG of ``current`` (coarse or full), drawn in place where ``update`` can, else anew; and whether it
        was drawn anew."""
        kw = {"coarse": coarse} if refine is not None else {}
        dynamic = None if anew or update is None or state["failed"] else update(fig, **current, **kw)
        if dynamic is None:
            fig.clear()
            draw(fig, **current, **kw)
        return renderer.png(dynamic), dynamic is None

    def keep_picture(key: tuple, png: bytes) -> None:
        image.value = shown[key] = png
        if len(shown) > PICTURES_KEPT:
            shown.popitem(last=False)

    def refined(key: tuple, generation: int, current: dict[str, Any], job: Callable[[], Any],
                axes: list[tuple], anew: bool) -> None:
        """In the worker: the full answer for ``current``, drawn if the controls still hold it."""
        if refiner.generation != generation:            # left before its turn came: computed if visited again
            return
        try:
            # left while computing: the library's loops stop at their next checkpoint, so that the next setting's
            # coarse picture does not share the interpreter with a full answer no longer wanted
            with cancel_when(lambda: refiner.generation != generation):
                job()
            with refiner.lock:
                if refiner.generation != generation:    # left while computing: the result waits in the cache
                    return
                if not anew:
                    _restore_axes(axes)                 # fitted from where the coarse picture started
                png, drawn_anew = picture(current, coarse=False, anew=anew)
                keep_picture(key, png)
                if drawn_anew and update is not None:   # the next update's background drawn now, in the worker
                    renderer.prime(update(fig, **current, coarse=False))
        except Cancelled:                               # nothing kept: computed again if visited again
            return
        except Exception:                               # no caller to raise to: shown under the figure
            state["failed"] = True
            messages.clear_output(wait=True)
            messages.append_stderr(traceback.format_exc())

    def refresh(_change: Any = None) -> None:
        current = values()
        key = _key(current)
        with refiner.lock:
            refiner.generation += 1
            try:
                if key in shown and not state["failed"]:   # a view shown before (a dropdown's option, a slider's
                    shown.move_to_end(key)                  # earlier value): its picture again
                    image.value = shown[key]
                    return
                job = None if refine is None else refine(**current)
                if job is not None and not _refine_in_background():
                    job()                               # the full answer now: no coarse picture
                    job = None
                if job is None:
                    png, _ = picture(current, coarse=False)
                    keep_picture(key, png)
                else:
                    axes = _axes_state(fig)
                    png, anew = picture(current, coarse=True)
                    image.value = png                   # not kept: the full picture will be
                    refiner.submit(functools.partial(refined, key, refiner.generation, current, job, axes, anew))
            except Exception:
                state["failed"] = True
                with messages:              # in a kernel, the Output widget shows the traceback and swallows it
                    messages.clear_output(wait=True)
                    raise                   # outside a kernel the error goes on to the caller
                return
            if state["failed"]:
                state["failed"] = False
                messages.clear_output()

    for s in sliders.values():
        s.observe(refresh, names="value")
    controls = list(sliders.values())
    panel = w.VBox([w.HBox(controls[:3]), w.HBox(controls[3:]), w.VBox([image, messages])])
    panel._uwtutor_refiner = refiner                    # for wait_refined
    return panel
