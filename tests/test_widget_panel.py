"""The shared widget panel: one figure, drawn again in place and sent as PNG bytes when a control moves."""

import io

import ipywidgets as w
import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
from PIL import Image  # noqa: E402

from uwtutor import widgets  # noqa: E402
from uwtutor.plotting import PIXEL_RATIO  # noqa: E402
from uwtutor.widgets._panel import figure_png, keep, kept, rescale, slider_panel, wait_refined  # noqa: E402

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _line_panel(calls):
    """A panel over y = a x whose draw function records the figure it was given."""
    sliders = {"a": w.FloatSlider(value=1.0, min=-2.0, max=2.0, step=0.5, continuous_update=False),
               "label": w.Dropdown(options=["one", "two"], value="one")}

    def draw(fig, a, label):
        calls.append(fig)
        fig = fig or plt.figure(figsize=(3.0, 2.0), dpi=50)
        ax = fig.subplots()
        x = np.linspace(0.0, 1.0, 11)
        ax.plot(x, a * x, label=label)
        ax.set_ylim(-2.0, 2.0)
        return fig

    return sliders, slider_panel(sliders, draw)


def _pixels(png):
    return np.asarray(Image.open(io.BytesIO(png)))


def test_panel_redraws_the_same_figure_in_place():
    calls = []
    sliders, panel = _line_panel(calls)
    rows, area = panel.children[:2], panel.children[2]
    image, messages = area.children
    assert [c for row in rows for c in row.children] == list(sliders.values())
    assert isinstance(image, w.Image) and image.format == "png" and isinstance(messages, w.Output)
    assert bytes(image.value).startswith(PNG_SIGNATURE)
    # 3 x 2 inches at 50 dpi, drawn at PIXEL_RATIO image pixels per figure pixel and shown at the figure's size
    assert _pixels(bytes(image.value)).shape[:2] == (100 * PIXEL_RATIO, 150 * PIXEL_RATIO)
    assert Image.open(io.BytesIO(bytes(image.value))).info["dpi"] == pytest.approx((50 * PIXEL_RATIO,) * 2, abs=0.01)
    assert image.layout.width == "150px"                          # shown at its own size, not stretched
    assert calls == [None] and not plt.get_fignums()              # made once, and not left to pyplot to show again

    first = bytes(image.value)
    sliders["a"].value = -1.5
    second = bytes(image.value)
    assert second != first and not np.array_equal(_pixels(first), _pixels(second))
    sliders["label"].value = "two"
    assert len(calls) == 3 and calls[1] is calls[2] is not None   # the same figure each time, cleared
    assert len(calls[2].axes) == 1
    sliders["a"].value = 1.0
    sliders["label"].value = "one"
    assert bytes(image.value) == first                            # the same view gives the same picture


def test_a_failing_update_raises_outside_a_kernel():
    sliders = {"n": w.IntSlider(value=1, min=0, max=3)}

    def draw(fig, n):
        if n == 0:
            raise ValueError("n must be positive")
        fig = fig or plt.figure(figsize=(2.0, 2.0), dpi=40)
        fig.subplots().plot(range(n))
        return fig

    panel = slider_panel(sliders, draw)
    with pytest.raises(ValueError, match="positive"):
        sliders["n"].value = 0
    sliders["n"].value = 2                                        # and the next good value draws again
    assert bytes(panel.children[2].children[0].value).startswith(PNG_SIGNATURE)


def test_figure_png_keeps_the_resolution_and_one_canvas():
    fig = plt.figure(figsize=(2.0, 1.0), dpi=60)
    fig.subplots().plot([0, 1], [1, 0])
    png = figure_png(fig)
    canvas = fig.canvas
    assert _pixels(png).shape[:2] == (60, 120)
    assert figure_png(fig) == png and fig.canvas is canvas
    plt.close(fig)


@pytest.mark.parametrize("name", [n for n in widgets.__all__ if n.endswith("_widget")])
def test_every_book_widget_updates_its_figure(name):
    panel = getattr(widgets, name)()
    controls = [c for row in panel.children[:2] for c in row.children]
    sliders = [c for c in controls if isinstance(c, (w.FloatSlider, w.IntSlider, w.FloatLogSlider))]
    image = panel.children[2].children[0]
    before = bytes(image.value)
    if not sliders:                               # a widget of choices only (chapter 10): the next option
        choice = next(c for c in controls if isinstance(c, w.Dropdown))
        options = list(choice.options)
        choice.value = options[(options.index(choice.value) + 1) % len(options)]
        assert bytes(image.value).startswith(PNG_SIGNATURE) and bytes(image.value) != before
        assert not plt.get_fignums()
        return
    slider = sliders[0]
    if isinstance(slider, w.FloatLogSlider):
        slider.value = slider.base ** (np.log(slider.value) / np.log(slider.base) + slider.step)
    else:
        slider.value = min(slider.value + slider.step, slider.max) if slider.value < slider.max else slider.min
    assert bytes(image.value).startswith(PNG_SIGNATURE) and bytes(image.value) != before
    assert not plt.get_fignums()


def test_rescale_keeps_autoscaling_on_after_keeping_limits():
    from matplotlib.figure import Figure

    from uwtutor.widgets._panel import rescale

    ax = Figure().subplots()
    (line,) = ax.plot([0, 1], [0, 10])
    line.set_data([0, 1], [1, 9])              # fits and spans most of the limits: kept
    before = ax.get_ylim()
    rescale(ax)
    assert ax.get_ylim() == before and ax.get_autoscaley_on()
    line.set_data([0, 1], [0, 100])            # then outgrows them: they must follow
    rescale(ax)
    assert ax.get_ylim()[1] >= 100.0


def _refined_panel(monkeypatch, background, work=lambda a: None):
    """A panel over y = a x whose full answer is computed by ``refine`` (counted, after ``work(a)``) and whose
    coarse answer is a flat line; background refinement as asked."""
    from uwtutor.widgets import _panel

    monkeypatch.setattr(_panel, "REFINE_IN_BACKGROUND", background)
    sliders = {"a": w.FloatSlider(value=1.0, min=-2.0, max=2.0, step=0.5, continuous_update=False)}
    full, jobs = {}, []

    def answer(a, coarse):
        return full[a] if a in full or not coarse else 0.0

    def draw(fig, a, coarse):
        fig = fig or plt.figure(figsize=(3.0, 2.0), dpi=50)
        ax = fig.subplots()
        ax.plot([0.0, 1.0], [0.0, answer(a, coarse)])
        ax.set_title("coarse" if coarse and a not in full else "full")
        return keep(fig, line=ax.lines[0])

    def update(fig, a, coarse):
        line = kept(fig)["line"]
        line.set_ydata([0.0, answer(a, coarse)])
        fig.axes[0].set_title("coarse" if coarse and a not in full else "full")
        rescale(fig.axes[0])
        return [line, fig.axes[0].title]

    def refine(a):
        if a in full:
            return None
        return lambda: (work(a), jobs.append(a), full.setdefault(a, float(a)))

    full[1.0] = 1.0
    return sliders, slider_panel(sliders, draw, update, refine=refine), jobs


def _full_png(a):
    """The picture of the same panel moved to ``a`` with no refinement (computed at once)."""
    sliders = {"a": w.FloatSlider(value=1.0, min=-2.0, max=2.0, step=0.5, continuous_update=False)}

    def draw(fig, a):
        fig = fig or plt.figure(figsize=(3.0, 2.0), dpi=50)
        ax = fig.subplots()
        ax.plot([0.0, 1.0], [0.0, a])
        ax.set_title("full")
        return keep(fig, line=ax.lines[0])

    def update(fig, a):
        kept(fig)["line"].set_ydata([0.0, a])
        fig.axes[0].set_title("full")
        rescale(fig.axes[0])
        return [kept(fig)["line"], fig.axes[0].title]

    panel = slider_panel(sliders, draw, update)
    sliders["a"].value = a
    return bytes(panel.children[2].children[0].value)


def test_refine_outside_a_kernel_computes_the_full_answer_at_once(monkeypatch):
    sliders, panel, jobs = _refined_panel(monkeypatch, None)     # no kernel here: as REFINE_IN_BACKGROUND = False
    image = panel.children[2].children[0]
    sliders["a"].value = 2.0
    assert jobs == [2.0] and wait_refined(panel)
    assert bytes(image.value) == _full_png(2.0)


def test_refine_in_the_background_shows_coarse_then_the_same_full_picture(monkeypatch):
    import threading

    sliders, panel, jobs = _refined_panel(monkeypatch, True)
    image = panel.children[2].children[0]
    gate = threading.Event()
    refiner = panel._uwtutor_refiner
    refiner.submit(gate.wait)                     # the worker busy: the coarse picture is seen before the full one
    sliders["a"].value = 2.0
    coarse = bytes(image.value)
    assert jobs == [] and coarse != _full_png(2.0)
    gate.set()
    assert wait_refined(panel, timeout=30.0)
    assert jobs == [2.0] and bytes(image.value) == _full_png(2.0)   # as computed at once, limits included
    sliders["a"].value = 1.0
    sliders["a"].value = 2.0                      # kept: no new work
    assert jobs == [2.0] and bytes(image.value) == _full_png(2.0)


def test_a_refinement_left_behind_is_not_shown(monkeypatch):
    import threading

    sliders, panel, jobs = _refined_panel(monkeypatch, True)
    image = panel.children[2].children[0]
    gate = threading.Event()
    panel._uwtutor_refiner.submit(gate.wait)
    sliders["a"].value = 2.0                      # its refinement waits behind the gate ...
    sliders["a"].value = -2.0                     # ... and a newer setting comes first
    gate.set()
    assert wait_refined(panel, timeout=30.0)
    assert jobs == [-2.0]                         # the older setting's work skipped, not drawn over the newer
    assert bytes(image.value) == _full_png(-2.0)


def test_a_refinement_still_computing_when_the_setting_is_left_stops(monkeypatch):
    import threading

    from uwtutor._cancel import checkpoint

    started, stopped = threading.Event(), []

    def work(a):                                  # the answer for 2.0 is long: a filter's loop, a checkpoint a step
        if a != 2.0:
            return
        started.set()
        try:
            for _ in range(30_000):               # about 30 s unless stopped: the test fails, it does not hang
                checkpoint()
                threading.Event().wait(0.001)
        except BaseException:
            stopped.append(a)
            raise

    sliders, panel, jobs = _refined_panel(monkeypatch, True, work)
    image = panel.children[2].children[0]
    sliders["a"].value = 2.0
    assert started.wait(30.0)                     # the worker computes the long answer ...
    sliders["a"].value = -2.0                     # ... and the reader moves on: it is no longer wanted
    assert wait_refined(panel, timeout=10.0)      # it stopped at its next checkpoint, and -2.0 was refined
    assert stopped == [2.0] and jobs == [-2.0]
    assert bytes(image.value) == _full_png(-2.0)
    assert not panel.children[2].children[1].outputs   # a cancellation is not an error shown under the figure


def _two_panels():
    """A figure of two axes side by side, a line in each, and the reference picture maker: a whole background
    drawn without the dynamic artists, then those drawn over it (what the renderer gave before any kept pixels)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.0, 2.0), dpi=60)
    left, right = fig.subplots(1, 2, gridspec_kw={"wspace": 0.5})   # room between them for the tick labels
    (a,) = left.plot([0, 1], [0, 1])
    (b,) = right.plot([0, 1], [1, 0])
    legend = right.legend(["b"], loc="lower left")
    return fig, left, right, a, b, legend


def _whole(fig, dynamic):
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    for artist in dynamic:
        artist.set_animated(True)
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    for artist in sorted(dynamic, key=lambda x: x.get_zorder()):
        artist.draw(renderer)
    return np.asarray(canvas.buffer_rgba())[..., :3].copy()


def test_redrawing_only_the_changed_axes_gives_the_picture_of_a_whole_draw():
    from uwtutor.widgets._panel import BlitRenderer

    fig, left, right, a, b, _ = _two_panels()
    renderer = BlitRenderer(fig)
    renderer.png(None)
    renderer.prime([a, b])
    whole_draws = []
    draw = renderer.canvas.draw
    renderer.canvas.draw = lambda: whole_draws.append(1) or draw()
    a.set_ydata([0, 50])                       # the left axes' limits change (new ticks); the right's do not
    left.set_ylim(0, 50)
    png = renderer.png([a, b])
    assert not whole_draws                     # only the left axes was drawn again
    assert np.array_equal(_pixels(png), _whole(fig, [a, b]))


def test_an_artist_left_out_of_the_kept_background_is_still_drawn():
    # the legend was dynamic when the background was kept; a later update that leaves it out must still show it
    from uwtutor.widgets._panel import BlitRenderer

    fig, left, right, a, b, legend = _two_panels()
    renderer = BlitRenderer(fig)
    renderer.png(None)
    renderer.prime([a, b, legend])
    b.set_ydata([0.5, 0.2])
    png = renderer.png([a, b])
    assert np.array_equal(_pixels(png), _whole(fig, [a, b, legend]))
