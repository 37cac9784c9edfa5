"""Figure style and small plotting helpers shared by the chapters, so that chapter code reads as the idea it shows.

Nothing here computes anything a chapter relies on: the numbers come from the library's modelling modules.
"""

from __future__ import annotations

from typing import Any

import re

import matplotlib.pyplot as plt
import numpy as np

__all__ = ["BOOK_STYLE", "use_book_style", "mark_beacon", "plot_track", "plain_log_ticks", "animation_html"]

#: The matplotlib settings of every figure in the book, readable at the width of its column (PNG output).
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


# matplotlib's HTML animation template links Font Awesome 4 from a CDN for its buttons. The book must load nothing
# from outside (it is read offline, at sea), and its theme already bundles Font Awesome, whose ``fa fa-play``-style
# classes the buttons use, so the link is dropped rather than vendored a second time.
_CDN_STYLESHEET = re.compile(r"<link[^>]*href=\"https?://[^\"]*font-awesome[^\"]*\"[^>]*>\s*", re.IGNORECASE)


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
    """
    from IPython.display import HTML

    if default_mode not in ("loop", "once", "reflect"):
        raise ValueError(f"default_mode must be 'loop', 'once' or 'reflect'; got {default_mode!r}")
    return HTML(_CDN_STYLESHEET.sub("", animation.to_jshtml(default_mode=default_mode)))
