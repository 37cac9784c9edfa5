"""The thin ipywidgets layer shared by every widget of the book."""

from __future__ import annotations

from typing import Any, Callable

import matplotlib.pyplot as plt

__all__ = ["slider_panel"]


def slider_panel(sliders: dict[str, Any], draw: Callable[..., None]) -> Any:
    """Sliders above an output area; ``draw(**values)`` is called at start and whenever a slider is released."""
    import ipywidgets as w

    out = w.Output()

    def refresh(_change: Any = None) -> None:
        with out:
            out.clear_output(wait=True)
            draw(**{name: s.value for name, s in sliders.items()})
            plt.show()

    for s in sliders.values():
        s.observe(refresh, names="value")
    refresh()
    return w.VBox([w.HBox(list(sliders.values())[:3]), w.HBox(list(sliders.values())[3:]), out])
