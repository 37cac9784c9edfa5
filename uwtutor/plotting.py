"""Figure style and small plotting helpers shared by the chapters, so that chapter code reads as the idea it shows.

Nothing here computes anything a chapter relies on: the numbers come from the library's modelling modules.
"""

from __future__ import annotations

from typing import Any

import matplotlib.pyplot as plt
import numpy as np

__all__ = ["BOOK_STYLE", "use_book_style", "mark_beacon", "plot_track"]

#: matplotlib settings of every figure in the book: readable at the book's column width, PNG output.
BOOK_STYLE = {
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


def use_book_style() -> None:
    """Apply :data:`BOOK_STYLE` to matplotlib (call once at the top of a chapter)."""
    plt.rcParams.update(BOOK_STYLE)


def mark_beacon(ax: Any, position: Any = (0.0, 0.0), label: str = "beacon") -> None:
    """Draw a beacon as a black triangle at ``position`` (x east, y north, metres)."""
    x, y = np.asarray(position, dtype=float)
    ax.plot([x], [y], marker="^", color="black", markersize=9, linestyle="none", label=label)


def plot_track(ax: Any, positions: Any, label: str | None = None, **style: Any) -> None:
    """Plot a 2-D track given as an array of shape (K, 2), with a dot at its start, on equal axes."""
    p = np.asarray(positions, dtype=float)
    (line,) = ax.plot(p[:, 0], p[:, 1], label=label, **style)
    ax.plot(p[0, 0], p[0, 1], "o", color=line.get_color(), markersize=4)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x east [m]")
    ax.set_ylabel("y north [m]")
