"""Interactive figures of the book: a pure compute function, a plot function and a thin ipywidgets layer each.

The compute functions take plain parameters and return a small dataclass of arrays; they are tested without a UI and
timed by the benchmark suite (``make bench``) through ``COMPUTE_FUNCTIONS``. The ``*_widget`` functions only wire
sliders to compute and plot (``slider_panel``). In the static HTML book a widget cannot recompute, so each chapter
follows a widget with a precomputed view drawn by the same plot function.

One module per chapter; the names of each are re-exported here.
"""

from __future__ import annotations

from typing import Any, Callable

from . import ch01
from .ch01 import *  # noqa: F401,F403

__all__ = ["COMPUTE_FUNCTIONS", *ch01.__all__]

#: Zero-argument callables running each widget's computation at its default parameters (timed by ``make bench``).
COMPUTE_FUNCTIONS: dict[str, Callable[[], Any]] = {
    "ch01 sound speed": ch01.sound_speed_view,
    "ch01 range errors": ch01.range_error_view,
}
