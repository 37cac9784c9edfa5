"""What every lab grader shares: reading the notebook's names, running a part's checks, caching references.

A part's checks are a generator function ``part(ns)`` that yields one ``Feedback`` per check, cheapest first; the
first one that is not correct is the verdict (so an expensive reference is only computed when the cheap checks
pass). ``ns`` is an ``Answers``: the notebook's namespace, where a missing name stops the checks with a message that
says which cell to run. The references are computed by the library, inside these functions, so that the notebook
shows only the call; every checker is called with ``reveal_expected=False``.
"""

from __future__ import annotations

import hashlib
import textwrap
import warnings
from collections import OrderedDict
from collections.abc import Callable, Iterator, Mapping
from typing import Any

import numpy as np

from uwtutor.exercises.feedback import Feedback


#: Width the messages are wrapped at (nbgrader's feedback shows them in a fixed-width block).
WRAP = 100

Part = Callable[["Answers"], Iterator[Feedback]]


class NotDefined(LookupError):
    """A name the checks need is not defined in the notebook (the student has not run a cell)."""

    def __init__(self, name: str) -> None:
        super().__init__(name)
        self.name = name


class Answers:
    """Read-only access to a notebook's namespace: ``ns["name"]`` raises ``NotDefined`` for a missing name.

    Parameters
    ----------
    namespace : mapping
        The notebook's ``globals()`` (or any mapping of names to values).

    Examples
    --------
    >>> ns = Answers({"x": 1})
    >>> ns["x"]
    1
    >>> "y" in ns
    False
    """

    def __init__(self, namespace: Mapping[str, Any]) -> None:
        if not isinstance(namespace, Mapping):
            raise TypeError(f"namespace must be a mapping such as globals(); got {type(namespace).__name__}")
        self._ns = namespace

    def __getitem__(self, name: str) -> Any:
        try:
            return self._ns[name]
        except KeyError:
            raise NotDefined(name) from None

    def __contains__(self, name: str) -> bool:
        return name in self._ns

    def get(self, name: str, default: Any = None) -> Any:
        """The value of ``name``, or ``default`` when the notebook does not define it."""
        return self._ns.get(name, default)


def fail(message: str, hint: str | None = None) -> Feedback:
    """A failed check with its own message (``"Not yet: "`` is prepended)."""
    return Feedback(False, f"Not yet: {message}", hint=hint)


def _wrap(text: str | None) -> str | None:
    if text is None:
        return None
    return "\n".join(textwrap.fill(line, width=WRAP, break_long_words=False, break_on_hyphens=False)
                     if line.strip() else line for line in text.split("\n"))


def run_part(part: Part, namespace: Mapping[str, Any], label: str) -> Feedback:
    """Run a part's checks on a notebook's namespace; the first failing check is the verdict.

    Parameters
    ----------
    part : callable
        The part's generator of checks.
    namespace : mapping
        The notebook's ``globals()``.
    label : str
        How the part is called in messages, e.g. ``"part C"``.

    Returns
    -------
    Feedback
        The first check that is not correct, or a correct verdict when all pass. Warnings raised while checking
        (by the student's code or the references) are not shown.
    """
    answers = Answers(namespace)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            with np.errstate(all="ignore"):
                for feedback in part(answers):
                    if not feedback:
                        return Feedback(False, _wrap(feedback.message), hint=_wrap(feedback.hint),
                                        details=feedback.details)
    except NotDefined as missing:
        return Feedback(False, f"No answer yet: `{missing.name}` is not defined.",
                        hint=_wrap("Run the notebook's cells from the top down to this one (Run > Run All Above "
                                   "Selected Cell), then this one."), details={"answered": False})
    except NotImplementedError:
        return Feedback(False, f"No answer yet: a function of {label} still raises NotImplementedError.",
                        hint="Replace the `raise NotImplementedError(...)` line with your code, run that cell, then "
                             "this one.", details={"answered": False})
    except Exception as exc:  # an answer of an unexpected kind: feedback, never a crash of the grader
        text = str(exc).split("\n")[0][:160]
        return Feedback(False, _wrap(f"Not yet: checking {label} stopped on your answers with "
                                     f"{type(exc).__name__}{': ' + text if text else ''}."),
                        hint=_wrap("Check that every answer of this part has the type, keys and shape the task asks "
                                   "for, and that your functions run on other inputs than the task's."),
                        details={"exception": exc})
    return Feedback(True, f"Correct: {label} passes the hidden checks.")


# ---------------------------------------------------------------------------------------------------------------------
# references computed once per kernel (several parts and tests use the same filter run)
# ---------------------------------------------------------------------------------------------------------------------
_CACHE: OrderedDict[str, Any] = OrderedDict()
_CACHE_SIZE = 32


def _digest(value: Any, h: Any) -> None:
    if isinstance(value, np.ndarray):
        h.update(f"nd{value.dtype.str}{value.shape}".encode())
        h.update(np.ascontiguousarray(value).tobytes())
    elif isinstance(value, (list, tuple)):
        h.update(f"{type(value).__name__}{len(value)}(".encode())
        for item in value:
            _digest(item, h)
        h.update(b")")
    elif isinstance(value, Mapping):
        h.update(f"map{len(value)}(".encode())
        for key in sorted(value, key=repr):
            _digest(key, h)
            _digest(value[key], h)
        h.update(b")")
    elif value is None or isinstance(value, (bool, int, float, complex, str, bytes, np.generic)):
        h.update(repr(value).encode())
    elif hasattr(value, "__dataclass_fields__"):
        h.update(type(value).__qualname__.encode())
        _digest({name: getattr(value, name) for name in value.__dataclass_fields__}, h)
    else:
        raise TypeError(f"cannot key a cached reference on a {type(value).__name__}")


def cached(name: str, inputs: Any, compute: Callable[[], Any]) -> Any:
    """``compute()``, remembered under ``name`` and the exact values of ``inputs`` (arrays hashed by content).

    Parameters
    ----------
    name : str
        What is computed (the lab and the quantity).
    inputs : object
        Everything the result depends on: arrays, numbers, tuples, dicts and dataclasses of them.
    compute : callable
        Computes the value when it is not cached.

    Returns
    -------
    object
        The value (the same object on a second call with equal inputs).

    Examples
    --------
    >>> import numpy as np
    >>> calls = []
    >>> f = lambda: calls.append(1) or 42
    >>> cached("doc", (np.arange(3),), f), cached("doc", (np.arange(3),), f), len(
    ...     calls
    ... )
    (42, 42, 1)
    """
    h = hashlib.blake2b(name.encode(), digest_size=20)
    _digest(inputs, h)
    key = h.hexdigest()
    if key in _CACHE:
        _CACHE.move_to_end(key)
        return _CACHE[key]
    value = compute()
    _CACHE[key] = value
    while len(_CACHE) > _CACHE_SIZE:
        _CACHE.popitem(last=False)
    return value


def call(func: Any, *args: Any, name: str) -> tuple[Any, Feedback | None]:
    """Call a student's function on the checks' own inputs: ``(result, None)``, or ``(None, feedback)`` when it
    raised (``NotImplementedError`` propagates: "not answered yet").

    Parameters
    ----------
    func : callable
        The student's function.
    *args
        Its arguments.
    name : str
        How the call is shown, e.g. ``"speed_range_error(x)"``.

    Returns
    -------
    tuple
        The result and ``None``, or ``None`` and a failed ``Feedback`` naming the exception.
    """
    if func is None:
        raise NotDefined(name.split("(")[0])
    if not callable(func):
        return None, fail(f"`{name.split('(')[0]}` is a {type(func).__name__}, not a function.",
                          hint="Define it with `def` in the answer cell and run that cell again.")
    try:
        return func(*args), None
    except NotImplementedError:
        raise
    except Exception as exc:
        text = str(exc).split("\n")[0][:160]
        return None, fail(f"`{name}` raised {type(exc).__name__}{': ' + text if text else ''} on the hidden test's "
                          "inputs.", hint="Your function must work on inputs other than the task's: numbers and "
                                          "arrays, and values at the edges of the range.")


def own_number(ns: Answers, name: str) -> float | None:
    """The student's answer ``name`` as a finite float, or ``None`` when it is missing or no usable number.

    The checks of a later part that builds on ``name`` run with this value (the student's own), so that a slip in
    the earlier part is counted once, in its own check.

    Examples
    --------
    >>> own_number(Answers({"c_e": 1487.3}), "c_e"), own_number(Answers({"c_e": None}), "c_e")
    (1487.3, None)
    >>> own_number(Answers({}), "c_e") is None
    True
    """
    try:
        value = float(ns.get(name))
    except (TypeError, ValueError):
        return None
    return value if np.isfinite(value) else None


def own_function(ns: Answers, name: str, *args: Any) -> Any:
    """The student's function ``name`` called on ``args``, or ``None`` when it is missing, raises or gives a
    non-finite result: a later part that uses that function is then checked against the student's own values.

    Examples
    --------
    >>> own_function(Answers({"f": lambda x: 2 * x}), "f", 3.0)
    6.0
    >>> own_function(Answers({"f": None}), "f", 3.0) is None
    True
    """
    func = ns.get(name)
    if not callable(func):
        return None
    try:
        with np.errstate(all="ignore"):
            value = np.asarray(func(*args), dtype=float)
    except Exception:  # the student's function's own failure is reported by its own part
        return None
    if not np.all(np.isfinite(value)):
        return None
    return float(value) if value.ndim == 0 else value


def own_interval(ns: Answers, name: str) -> tuple[float, float] | None:
    """The student's answer ``name`` as an interval ``(low, high)`` of finite numbers with ``low < high``, or
    ``None``: a later step that uses the interval (a fraction of epochs inside it) is checked with the student's own.

    Examples
    --------
    >>> own_interval(Answers({"b": (1.5, 2.6)}), "b"), own_interval(Answers({"b": (3, 1)}), "b")
    ((1.5, 2.6), None)
    """
    try:
        value = np.asarray(ns.get(name), dtype=float)
    except (TypeError, ValueError):
        return None
    if value.shape != (2,) or not np.all(np.isfinite(value)) or not value[0] < value[1]:
        return None
    return float(value[0]), float(value[1])
