r"""Numbers for the text: a computed value as the page shows it, and a round-off as a bound.

A chapter binds every number of its prose to the computation that made it (myst-nb ``glue``), and its committed
outputs are compared with a fresh run on another machine (nbval). The last bits of a floating-point sum depend
on the CPU and on the BLAS kernel it runs (an AMD and an Intel machine, or ``OPENBLAS_CORETYPE=Haswell`` and
``Sandybridge``, differ at about :math:`10^{-16}` relative, and an ill-conditioned step amplifies that to
:math:`10^{-9}`), so an output that shows those bits is a test that fails on someone else's machine. Two rules
keep the outputs portable:

* glue a number **as the text shows it** (:func:`as_shown`): the value rounded with the same format the prose
  uses, so that what is stored, compared and printed is what the reader sees;
* print a quantity that is zero up to round-off **as a bound** (:func:`below_or_value`), never as its noise.
"""

from __future__ import annotations

import math
from typing import Any

from numpy.typing import ArrayLike

from ._validate import as_float_array

__all__ = ["as_shown", "below_or_value"]


def _real(name: str, value: Any) -> float:
    arr = as_float_array(name, value)           # strings, bools, complex and None refused by name
    if arr.size != 1:
        raise TypeError(f"{name} must be one real number; got {value!r}")
    return float(arr.reshape(()))


def _format(name: str, number: float, fmt: Any) -> str:
    """``format(number, fmt)``, with an error naming ``name`` when ``fmt`` is not a float format."""
    if not isinstance(fmt, str):
        raise TypeError(f"{name} must be a format specification string such as '.3g'; got {type(fmt).__name__}")
    try:
        return format(number, fmt)
    except (ValueError, TypeError) as exc:
        raise ValueError(f"{name} must be a float format specification such as '.3g' or '.1f'; got {fmt!r} "
                         f"({exc})") from None


def as_shown(value: ArrayLike, fmt: str) -> float:
    """The number ``value`` rounded exactly as the format ``fmt`` shows it, as a float.

    Parameters
    ----------
    value : real scalar
        The computed number (a Python or numpy scalar, or a one-element array).
    fmt : str
        The format specification the text uses for it, as in ``{glue:text}`key:.1f```: fixed point
        (``".1f"``, ``"+.0f"``), percent (``".0%"``, the value is a fraction) or exponent (``".0e"``).

    Returns
    -------
    float
        ``float(format(value, fmt))`` (for a percent format, the shown percentage divided by 100), so that
        ``format(as_shown(v, fmt), fmt) == format(v, fmt)``. NaN and infinities are returned unchanged.

    Raises
    ------
    ValueError
        If ``fmt`` is not a fixed-point, percent or exponent format.
    TypeError
        If ``value`` is not a real scalar.

    Examples
    --------
    >>> as_shown(184.20232392533, ".0f")
    184.0
    >>> as_shown(0.3038768295, ".0%")
    0.3
    >>> as_shown(7.078e-13, ".0e")
    7e-13
    >>> format(as_shown(2.4036338664, ".1f"), ".1f")
    '2.4'
    """
    number = _real("value", value)
    if not isinstance(fmt, str) or not fmt or fmt[-1] not in "fFeE%":
        raise ValueError(f"fmt must be a fixed-point, percent or exponent format such as '.1f', '.0%' or '.0e'; "
                         f"got {fmt!r}")
    if not math.isfinite(number):
        return number
    text = _format("fmt", number, fmt)
    if fmt.endswith("%"):
        return float(text[:-1]) / 100.0
    return float(text)


def below_or_value(value: ArrayLike, bound: float = 1e-9, fmt: str = ".3g") -> str:
    """Text for a quantity that may be zero up to round-off: ``"< bound"`` when it is, the value otherwise.

    A slope, a residual or a difference that vanishes in exact arithmetic comes out as round-off
    (:math:`10^{-13}` here, :math:`10^{-12}` on another CPU). Printing that noise makes an output that
    changes from machine to machine; printing the bound it stays under does not.

    Parameters
    ----------
    value : real scalar
        The computed quantity.
    bound : float, optional
        The magnitude under which ``value`` counts as zero (default ``1e-9``).
    fmt : str, optional
        The format of ``value`` when it is above the bound (default ``".3g"``).

    Returns
    -------
    str

    Examples
    --------
    >>> below_or_value(7.08e-13)
    '< 1e-09'
    >>> below_or_value(10.449, fmt=".1f")
    '10.4'
    """
    number = _real("value", value)
    limit = _real("bound", bound)
    if not (math.isfinite(limit) and limit > 0):
        raise ValueError(f"bound must be a finite positive number; got {bound!r}")
    text = _format("fmt", number, fmt)          # checked even when the bound is printed instead
    if math.isfinite(number) and abs(number) < limit:
        return f"< {limit:.0e}"
    return text
