"""Interactive figures of the book: a pure compute function, a plot function and a thin ipywidgets layer each.

The compute functions take plain parameters and return a small dataclass of arrays; they are tested without a UI and
timed by the benchmark suite (``make bench``) through ``COMPUTE_FUNCTIONS``. The ``*_widget`` functions only wire
sliders to compute and plot (``slider_panel``, which redraws one figure in place; ``make bench`` also times each
widget's update in JupyterLab). In the static HTML book a widget cannot recompute, so each chapter
follows a widget with a precomputed view drawn by the same plot function.

One module per chapter (``ch01``, ``ch02``, ...). Each lists its public names in ``__all__``, which are re-exported
here, and its computations at default parameters in its own ``COMPUTE_FUNCTIONS``, which are merged here.
"""

from __future__ import annotations

import importlib
import pkgutil
import re
from typing import Any, Callable

#: Zero-argument callables running each widget's computation at its default parameters (timed by ``make bench``),
#: collected from every chapter module.
COMPUTE_FUNCTIONS: dict[str, Callable[[], Any]] = {}

__all__ = ["COMPUTE_FUNCTIONS"]


def _collect_chapter_modules() -> None:
    """Import every ``chNN`` module of this package, re-export its names and merge its registry."""
    names = sorted(m.name for m in pkgutil.iter_modules(__path__) if re.fullmatch(r"ch\d\d", m.name))
    for name in names:
        module = importlib.import_module(f".{name}", __name__)
        for key, compute in getattr(module, "COMPUTE_FUNCTIONS", {}).items():
            if key in COMPUTE_FUNCTIONS:
                raise ImportError(f"widget computation {key!r} is registered twice (again in {name})")
            COMPUTE_FUNCTIONS[key] = compute
        for attr in module.__all__:
            if attr == "COMPUTE_FUNCTIONS":
                continue
            if attr in globals() and globals()[attr] is not getattr(module, attr):
                raise ImportError(f"uwtutor.widgets.{name} exports {attr!r}, a name another chapter already uses")
            globals()[attr] = getattr(module, attr)
            __all__.append(attr)


_collect_chapter_modules()
