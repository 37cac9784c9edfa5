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

__all__ = [
    "UwtutorWarning",
    "GeometryWarning",
    "BeaconSingularityWarning",
    "UnobservableWarning",
    "IllConditionedWarning",
    "IllConditionedError",
    "warn",
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
    frame = sys._getframe(1)
    level = 2                       # 1 would be this function, 2 its caller
    while frame is not None and frame.f_globals.get("__name__", "").startswith("uwtutor."):
        frame = frame.f_back
        level += 1
    warnings.warn(message, category, stacklevel=level)
