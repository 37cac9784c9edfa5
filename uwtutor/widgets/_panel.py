"""The thin ipywidgets layer shared by every widget of the book: sliders above one figure, redrawn in place.

An update does the least a new picture needs: the compute function runs, the *same* matplotlib figure is cleared
and drawn again by the chapter's plot function, and the PNG goes to an ``ipywidgets.Image`` as bytes (one comm
message, no base64). The older way, a fresh figure per update shown by ``plt.show()`` inside an ``Output``
widget, also created and destroyed a pyplot figure, laid the page out twice (``bbox_inches="tight"`` redraws the
figure to measure it) and made JupyterLab tear down and rebuild the output area; ``make bench`` measures both
what the kernel spends and what a person waits in JupyterLab (see the Performance appendix).
"""

from __future__ import annotations

import io
from typing import Any, Callable

import matplotlib.pyplot as plt

__all__ = ["slider_panel", "figure_png"]


def figure_png(fig: Any) -> bytes:
    """The figure as PNG bytes at its own resolution (``fig.dpi``), drawn by an Agg canvas kept on the figure.

    The canvas (and so its renderer and text caches) is made once per figure rather than once per picture, as
    ``savefig`` on an inline-backend figure would; the PNG is compressed lightly (level 1: the bytes go to a
    browser on the same machine or network, where encoding time matters more than size).
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
    buffer = io.BytesIO()
    canvas.print_png(buffer, pil_kwargs={"compress_level": 1})
    return buffer.getvalue()


def slider_panel(sliders: dict[str, Any], draw: Callable[..., Any]) -> Any:
    """Sliders (and other controls) above one figure that is redrawn whenever a control's value changes.

    Parameters
    ----------
    sliders : dict of str to ipywidgets.ValueWidget
        The controls, by the name of the parameter each sets; the first three in a row, the others in a second
        row. Sliders should have
        ``continuous_update=False`` (an update on release, not on every pixel of a drag).
    draw : callable
        ``draw(fig, **values)`` draws the view for these parameter values into ``fig`` and returns the figure.
        ``fig`` is ``None`` on the first call (``draw`` makes the figure, at the size it wants) and, after that,
        that same figure, cleared.

    Returns
    -------
    ipywidgets.VBox
        The two rows of controls, then the figure area: a ``VBox`` of the figure (an ``ipywidgets.Image``) and an
        ``Output`` that shows the error, if a computation fails, until the next update succeeds.
    """
    import ipywidgets as w

    values = lambda: {name: s.value for name, s in sliders.items()}  # noqa: E731
    fig = draw(None, **values())
    plt.close(fig)                      # off pyplot's list: the inline backend must not show it a second time
    width_px = round(fig.get_figwidth() * fig.dpi)
    # Shown at its own size (a flex box would stretch it to the cell's width, blurred), narrower on a narrow screen.
    image = w.Image(value=figure_png(fig), format="png",
                    layout=w.Layout(width=f"{width_px}px", max_width="100%", height="auto"))
    messages = w.Output()
    state = {"failed": False}

    def refresh(_change: Any = None) -> None:
        try:
            fig.clear()
            draw(fig, **values())
            image.value = figure_png(fig)
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
    return w.VBox([w.HBox(controls[:3]), w.HBox(controls[3:]), w.VBox([image, messages])])
