"""The warnings of ``uwtutor``, in one hierarchy.

Every warning the library emits is a :class:`UwtutorWarning`, so one line silences (or, in a test, raises) them
all::

    warnings.filterwarnings("error", category=uwtutor.errors.UwtutorWarning)

The geometry warnings -- a range Jacobian that is undefined, a state direction the ranges cannot see, a least
squares problem too ill-conditioned to trust -- share the subclass :class:`GeometryWarning`.

Examples
--------
>>> import warnings
>>> from uwtutor.errors import (
...     BeaconSingularityWarning,
...     GeometryWarning,
...     UwtutorWarning,
... )
>>> issubclass(BeaconSingularityWarning, GeometryWarning) and issubclass(
...     GeometryWarning, UwtutorWarning
... )
True
"""

from __future__ import annotations

import sys
import warnings
from types import FrameType
from typing import Any, Callable

__all__ = [
    "UwtutorWarning",
    "GeometryWarning",
    "BeaconSingularityWarning",
    "UnobservableWarning",
    "IllConditionedWarning",
    "IllConditionedError",
    "warn",
    "deprecated_aliases",
]


class UwtutorWarning(UserWarning):
    """Base class of every warning emitted by ``uwtutor``."""


class GeometryWarning(UwtutorWarning):
    """The geometry of vehicle and beacon(s) makes part of the answer unreliable."""


class BeaconSingularityWarning(GeometryWarning):
    """A predicted position fell exactly on the beacon, where the range Jacobian is undefined; update skipped."""


class UnobservableWarning(GeometryWarning):
    """The geometry does not determine every unknown: an information matrix is singular, or a fix is ambiguous.

    The functions that emit it still return their result (a bound that is infinite along the unobservable
    directions, NaN candidates for a fix that does not exist), so a notebook can show the degenerate case.
    """


class IllConditionedWarning(GeometryWarning):
    """A least-squares problem is ill-conditioned or singular: its fix is unreliable (or NaN when singular).

    The message gives the condition number and the noise gain (precision factor) so that the caller can judge;
    silence it with ``warnings.catch_warnings`` when ill-conditioning is expected (e.g. the first epochs of a
    pre-positioning loop).
    """


class IllConditionedError(ValueError, ArithmeticError):
    """An input asks for more precision than float64 carries (e.g. a covariance update with a dynamic range above
    ~1e16): the computation is refused instead of returning a covariance that is not positive semi-definite.

    A :class:`ValueError`, since the fix is a change of input (the message says which).
    """


def warn(message: str, category: type[Warning] = UwtutorWarning) -> None:
    """Emit a warning attributed to the first caller outside ``uwtutor`` (the user's line, not the library's).

    Examples
    --------
    >>> import warnings
    >>> from uwtutor.errors import UwtutorWarning, warn
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     warn("something to know", UwtutorWarning)
    >>> caught[0].category.__name__
    'UwtutorWarning'
    """
    frame: FrameType | None = sys._getframe(1)
    level = 2                       # 1 would be this function, 2 its caller
    while frame is not None and frame.f_globals.get("__name__", "").startswith("uwtutor."):
        frame = frame.f_back
        level += 1
    warnings.warn(message, category, stacklevel=level)


def _attribute_of(module: str, name: str) -> Callable[[], Any]:
    """A function that reads ``module.name`` when called (the module may not be fully imported yet)."""
    def value() -> Any:
        return getattr(sys.modules[module], name)
    return value


def deprecated_aliases(module: str, aliases: dict[str, Any]) -> Callable[[str], Any]:
    """A module-level ``__getattr__`` (PEP 562) that keeps the old names of renamed objects importable for one release.

    ``aliases`` maps each old name to its new one (a name of the same module), or to a pair ``(replacement,
    value)``: the text the warning recommends and a function of no arguments that returns what the old name gives.
    Reading an old name emits a :class:`DeprecationWarning` naming the replacement, attributed to the caller's line
    (see :func:`warn`); the old names are not in the module's ``__all__``. Any other missing name raises
    :class:`AttributeError` as usual.

    Parameters
    ----------
    module : str
        The ``__name__`` of the module that assigns the result to its ``__getattr__``.
    aliases : dict
        ``{old: new}`` or ``{old: (replacement, value)}``.

    Returns
    -------
    callable
        The module's ``__getattr__``.

    Examples
    --------
    >>> import types, warnings
    >>> from uwtutor.errors import deprecated_aliases
    >>> mod = types.ModuleType("demo")
    >>> mod.NEW = 42
    >>> mod.__getattr__ = deprecated_aliases("demo", {"OLD": ("demo.NEW", lambda: mod.NEW)})
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     value = mod.OLD
    >>> value, caught[0].category.__name__
    (42, 'DeprecationWarning')
    >>> print(caught[0].message)
    demo.OLD is deprecated and will be removed in the next release: use demo.NEW
    """
    if not isinstance(module, str):
        raise TypeError(f"module must be the module's __name__ (a string); got {type(module).__name__}")
    if not isinstance(aliases, dict) or not all(isinstance(old, str) for old in aliases):
        raise TypeError("aliases must be a dict from old names (strings) to new names or (replacement, value) pairs")
    table: dict[str, tuple[str, Callable[[], Any]]] = {}
    for old, new in aliases.items():
        if isinstance(new, str):
            table[old] = (f"{module}.{new}", _attribute_of(module, new))
        elif isinstance(new, tuple) and len(new) == 2 and isinstance(new[0], str) and callable(new[1]):
            table[old] = new
        else:
            raise TypeError(f"aliases[{old!r}] must be a new name (a string) or a (replacement, value) pair; got "
                            f"{type(new).__name__}")

    def __getattr__(name: str) -> Any:
        if name not in table:
            raise AttributeError(f"module {module!r} has no attribute {name!r}")
        replacement, value = table[name]
        warn(f"{module}.{name} is deprecated and will be removed in the next release: use {replacement}",
             DeprecationWarning)
        return value()

    return __getattr__
