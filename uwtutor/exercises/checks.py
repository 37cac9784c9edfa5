"""Generic building blocks for answer checkers that say what is wrong and hint at why.

Four checkers cover the exercises of the book:

- ``check_number`` for a single number: it recognises the exercise's known wrong answers (``common_mistakes``),
  then a wrong sign, a factor of 2 and a power of ten (a unit conversion), then says how far off the answer is;
- ``check_array`` for an array: it reports a wrong shape (and suggests a transpose), NaNs, swapped columns, and
  otherwise the worst element; with a boolean ``expected`` it compares flags and names the missed and the false ones;
- ``check_function`` for a function the student wrote: it runs it on test cases (``Case``) against a reference and
  reports the first failing case with its inputs, the expected result and the student's result; an exception raised
  by the student's code is caught and reported with the line it came from; the exercise's typical slips
  (``mistakes``, functions that make one mistake each) are run on the failing case, and the hint of the slip the
  student's result matches beats the case's own, generic hint;
- ``check_choice`` for a multiple-choice answer given as a capital letter: it asks for the capital when the letter is
  written in lower case and for the letter when the option's text is given, names the letters when the answer is none
  of them, and gives each wrong option its own hint (``read_letter`` does the reading, for other checkers too).

None of them ever raises because of the *answer*: ``None`` (not answered yet), a string, a list of the wrong length or a
function that crashes all give a ``Feedback`` with ``correct=False`` and a helpful message. They do raise ``ValueError``
or ``TypeError`` when the *checker* is misconfigured (an ``expected`` that is not finite, no test cases...).

Examples
--------
>>> from uwtutor.exercises.checks import check_number
>>> check_number(
...     3600.0,
...     1800.0,
...     name="the range",
...     units="m",
...     common_mistakes={
...         3600.0: "A two-way travel time covers the path twice."
...     },
... )
✘ Not yet: your value for the range, 3600 m, is twice the expected value.
  Hint: A two-way travel time covers the path twice.
>>> check_number(1800.2, 1800.0, name="the range", units="m")
✔ Correct: the range is 1800.2 m.
"""

from __future__ import annotations

import copy
import inspect
import math
import numbers
import contextlib
import dataclasses
import reprlib
import signal
import sys
import threading
import time
import traceback
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, cast

import numpy as np

from .feedback import Feedback

__all__ = ["Case", "check_number", "check_array", "check_choice", "check_function", "not_answered", "read_letter",
           "DEFAULT_HINT", "parse_real_array", "run_student"]

#: The hint given when an answer is wrong and no more specific cause is recognised.
DEFAULT_HINT = "Re-read the task: check the formula, each input and its units."

_NOT_YET = "Not yet: "
#: Seconds a student's function may run on one test case (the reference takes milliseconds); see ``time_limit``.
TIME_LIMIT = 5.0
#: A student's function that waits without using the CPU is stopped after this many times ``TIME_LIMIT`` on the wall.
WALL_FACTOR = 20.0
_PACKAGE_DIR = str(Path(__file__).resolve().parents[1])


# ---------------------------------------------------------------------------------------------------------------------
# formatting
# ---------------------------------------------------------------------------------------------------------------------
def _fmt(x: float, digits: int = 6) -> str:
    """A number with up to ``digits`` significant digits: ``1506.26``, ``7200``, ``-60``."""
    x = float(x)
    if x == 0:
        return "0"
    return f"{x:.{digits}g}"


def _with_units(x: float, units: str, digits: int = 6) -> str:
    return f"{_fmt(x, digits)} {units}".rstrip()


def _percent(p: float) -> str:
    p = abs(p) * 100
    if p >= 10:
        return f"{p:.0f} %"
    if p >= 1:
        return f"{p:.1f} %"
    return f"{p:.2g} %"


def _fmt_value(value: Any) -> str:
    """A short, readable rendering of a test input or result (arrays printed compactly)."""
    if isinstance(value, np.ndarray) or (isinstance(value, (list, tuple)) and value
                                         and all(isinstance(v, numbers.Number) for v in value)):
        try:
            arr = np.asarray(value)
            if arr.dtype.kind in "biuf":
                return np.array2string(arr, separator=", ", threshold=30, edgeitems=5, precision=3,
                                       floatmode="maxprec", suppress_small=True, max_line_width=100)
        except (TypeError, ValueError):
            pass
    if isinstance(value, (float, np.floating)) and math.isfinite(value):
        return _fmt(float(value))
    short = reprlib.Repr()
    short.maxstring = 80
    short.maxother = 80
    return short.repr(value)


def _fmt_index(idx: tuple[int, ...]) -> str:
    if len(idx) == 1:
        return str(int(idx[0]))
    return "(" + ", ".join(str(int(i)) for i in idx) + ")"


def _list_indices(indices: Sequence[tuple[int, ...]], limit: int = 5) -> str:
    shown = [_fmt_index(i) for i in indices[:limit]]
    word = "index" if len(indices) == 1 else "indices"
    if len(indices) > limit:
        return f"{word} {', '.join(shown)}, ... ({len(indices)} in all)"
    if len(shown) > 1:
        return f"{word} {', '.join(shown[:-1])} and {shown[-1]}"
    return f"{word} {shown[0]}"


def _type_name(value: Any) -> str:
    if isinstance(value, np.ndarray):
        return "NumPy array"
    return type(value).__name__


# ---------------------------------------------------------------------------------------------------------------------
# answers that are not (yet) numbers
# ---------------------------------------------------------------------------------------------------------------------
def not_answered(what: str) -> Feedback:
    """The feedback for an exercise whose answer is still ``None`` (or ``...``).

    Parameters
    ----------
    what : str
        What the answer should be, e.g. ``"the two-way range in metres (a number)"``.

    Returns
    -------
    Feedback
        Not correct, with a message that asks for the answer and a hint on where to write it.

    Examples
    --------
    >>> fb = not_answered("the two-way range in metres (a number)")
    >>> fb.correct
    False
    >>> print(fb.message)
    No answer yet: replace `None` with the two-way range in metres (a number).
    """
    return Feedback(False, f"No answer yet: replace `None` with {what}.",
                    hint="Write your code in the answer cell above (where it says `# YOUR CODE HERE`), delete the "
                         "`raise NotImplementedError(...)` line, then run that cell and this one again.",
                    details={"answered": False})


def _is_unanswered(answer: Any) -> bool:
    return answer is None or answer is Ellipsis


def _wrong_type(answer: Any, name: str, kind: str = "a number") -> Feedback | None:
    """Feedback for an answer that is text, a truth value, a function or a container of the wrong kind, else None."""
    if isinstance(answer, (bool, np.bool_)):
        return Feedback(False, f"Your answer is {bool(answer)}, a truth value; {name} should be {kind}.",
                        hint="Did you assign the result of a comparison (`==`, `<`) instead of the quantity itself?")
    if isinstance(answer, (str, bytes)):
        text = answer.decode(errors="replace") if isinstance(answer, bytes) else answer
        try:
            float(text.strip())
        except ValueError:
            return Feedback(False, f"Your answer is the text {text!r}; {name} should be {kind}.",
                            hint="Assign the result of your calculation, not text.")
        return Feedback(False, f"Your answer is the text {text!r} (a string, in quotes); {name} should be {kind}.",
                        hint=f"Remove the quotes: write {text.strip()} rather than {text!r}.")
    if callable(answer):
        fname = getattr(answer, "__name__", "it")
        return Feedback(False, f"Your answer is a function (`{fname}`); {name} should be {kind}.",
                        hint=f"Call it and assign its result, e.g. `{fname}(...)` with the inputs of the task.")
    if isinstance(answer, (dict, set, frozenset)):
        return Feedback(False, f"Your answer is a {type(answer).__name__}; {name} should be {kind}.",
                        hint="Give the value itself, not a dictionary or a set.")
    return None


def _as_scalar(answer: Any, name: str, what: str) -> tuple[float | None, Feedback | None]:
    """Turn ``answer`` into a float, or explain why it cannot be one (``what`` describes the answer if missing)."""
    if _is_unanswered(answer):
        return None, not_answered(what)
    wrong = _wrong_type(answer, name)
    if wrong is not None:
        return None, wrong
    if isinstance(answer, (numbers.Number, np.number)):
        if isinstance(answer, (complex, np.complexfloating)):
            if answer.imag != 0:
                return None, Feedback(False, f"Your answer, {answer}, is a complex number; {name} should be real.",
                                      hint="A square root of a negative number? Check the signs under the root.")
            return None, _complex_zero_imag(name)
        try:
            return float(cast(numbers.Real, answer)), None    # complex numbers were answered above
        except OverflowError:
            return None, _too_large(answer, name)
        except Exception:
            pass
    if isinstance(answer, (list, tuple, np.ndarray)) or hasattr(answer, "__array__"):
        try:
            arr = np.asarray(answer)
        except Exception:
            arr = np.asarray([None], dtype=object)
        kind = _type_name(answer)
        if arr.dtype.kind == "c" and arr.size == 1:
            value = complex(arr.reshape(()))
            if value.imag != 0:
                return None, Feedback(False, f"Your answer, {value}, is a complex number; {name} should be real.",
                                      hint="A square root of a negative number? Check the signs under the root.")
            return None, _complex_zero_imag(name)
        if arr.dtype.kind not in "iuf" or arr.size == 0:
            if arr.size == 0:
                return None, Feedback(False, f"Your answer is an empty {kind}; {name} should be a number.",
                                      hint="Assign the number itself, not a container.")
            if arr.dtype.kind == "b" and arr.size == 1:
                return None, _wrong_type(bool(arr.reshape(())), name)
            return None, Feedback(False, f"Your answer is a {kind} that does not hold a number; "
                                         f"{name} should be a single number.",
                                  hint="Assign the number itself.")
        if arr.size == 1:
            return float(arr.reshape(())), None
        return None, Feedback(False, f"Your answer is a {kind} of {arr.size} numbers (shape {arr.shape}); "
                                     f"{name} should be a single number.",
                              hint="If you computed it for several cases, give the one the task asks for "
                                   "(for example the last one, `values[-1]`).")
    try:
        return float(answer), None
    except OverflowError:
        return None, _too_large(answer, name)
    except Exception as exc:        # any object: its __float__ may raise anything, and must not crash the check
        return None, Feedback(False, f"Your answer is {_a_type(answer)}; {name} should be a number.",
                              hint="Assign the number itself." + _conversion_failure(exc))


def _a_type(value: Any) -> str:
    kind = _type_name(value)
    return ("an " if kind[:1].lower() in "aeiou" else "a ") + kind


def _conversion_failure(exc: BaseException) -> str:
    text = str(exc)
    return f" (Turning it into a number failed with {type(exc).__name__}{': ' + text[:80] if text else ''}.)"


def _too_large(answer: Any, name: str) -> Feedback:
    digits = len(str(abs(int(answer)))) if isinstance(answer, (int, np.integer)) else None
    size = f" ({digits} digits)" if digits else ""
    return Feedback(False, f"Not yet: your value for {name} is an integer too large for a floating-point number{size}: "
                           "the largest is about 1.8e308.",
                    hint="An exponent gone wrong (`**` instead of `*`?) or an integer computation that grew without "
                         "bound: print the intermediate results.")


def _complex_zero_imag(name: str) -> Feedback:
    return Feedback(False, f"Not yet: {name} holds complex numbers (their imaginary parts are zero, but the type is "
                           "complex); it should be real.",
                    hint="Something made the result complex (`np.sqrt` of a complex input, `np.fft`, `np.roots`...): "
                         "keep the real part with `np.real(...)` once you are sure the imaginary part is zero.")


def _non_finite(value: float, name: str) -> Feedback | None:
    if math.isnan(value):
        return Feedback(False, f"Not yet: your value for {name} is NaN (not a number).",
                        hint="NaN comes from an undefined operation (0/0, the square root of a negative number...) or "
                             "from a NaN among the inputs: print the intermediate results to see where it appears.")
    if math.isinf(value):
        return Feedback(False, f"Not yet: your value for {name} is infinite.",
                        hint="A division by zero? Check the denominators.")
    return None


# ---------------------------------------------------------------------------------------------------------------------
# how a wrong number relates to the right one
# ---------------------------------------------------------------------------------------------------------------------
_SIGN_HINT = "Check the sign convention of the task (for example, error = estimated value − true value)."
_TWICE_HINT = "Look for a factor of 2 too many (a two-way path, a diameter instead of a radius...)."
_HALF_HINT = "Look for a missing factor of 2."
#: The hint of a near miss: a guess (rounding), weaker than any diagnosis of a slip.
_NEAR_MISS_HINT = ("Did you round an intermediate value or a constant? Keep full precision until the end, and check "
                   "that no small term is missing.")
#: Relations that name the slip (a sign, a factor of 2, a power of ten): a diagnosis of the value itself.
_DIAGNOSING_HINTS = (_SIGN_HINT, _TWICE_HINT, _HALF_HINT)


def _diagnoses(relation_hint: str | None) -> bool:
    """Whether a hint of :func:`_relation` names the slip (sign, factor of 2, power of ten), not a mere guess."""
    return relation_hint is not None and (relation_hint.startswith(_DIAGNOSING_HINTS)
                                          or relation_hint.startswith("A factor of "))


def _power_hint(k: int, units: str) -> str:
    inunits = f" and the answer in {units}" if units else ""
    return (f"A factor of {10 ** k:,} usually comes from a unit conversion (metres and kilometres, seconds and "
            f"milliseconds...): check that every input is in SI units{inunits}.")


def _relation(a: float, e: float, *, rtol: float, atol: float, units: str,
              reveal: bool = True) -> tuple[str, str | None]:
    """How the answer ``a`` relates to the expected ``e`` (``e != 0``), with a hint when the relation is telling.

    With ``reveal=False`` a relation that names a mistake (a wrong sign, a factor of 2, a power of ten) is kept, but
    nothing is said from which ``e`` could be worked out: no distance, tolerance, percentage or ratio.
    """

    def close(target: float) -> bool:
        return abs(a - target) <= atol + max(rtol, 1e-12) * abs(target)

    if close(-e):
        return "has the right size but the wrong sign", _SIGN_HINT
    if close(2 * e):
        return "is twice the expected value", _TWICE_HINT
    if close(e / 2):
        return "is half the expected value", _HALF_HINT
    if a == 0:          # before the powers of ten: with an absolute tolerance 0 is "close" to e / 10**k
        return "is zero, which it should not be", ("Did a variable keep its initial value 0, or an integer "
                                                   "division (`//`) round the result down to 0?")
    for k in range(1, 10):
        for sign, prefix, hint_extra in ((1, "", ""), (-1, "has the wrong sign and ", " Check the sign too.")):
            if close(sign * e * 10 ** k):
                return f"{prefix}is {10 ** k:,} times larger than expected", _power_hint(k, units) + hint_extra
            if close(sign * e / 10 ** k):
                return f"{prefix}is {10 ** k:,} times smaller than expected", _power_hint(k, units) + hint_extra
    tol = atol + rtol * abs(e)
    if not reveal:
        if abs(a - e) <= 10 * tol:
            return "is close, but outside the tolerance", _NEAR_MISS_HINT
        if (a > 0) != (e > 0):
            return "has the wrong sign", _SIGN_HINT
        return f"is too {'large' if abs(a) > abs(e) else 'small'}{' in size' if e < 0 else ''}", None
    if abs(a - e) <= 10 * tol:
        return (f"is close, but just outside the tolerance (off by {_with_units(a - e, units, 3)}; "
                f"the tolerance is ±{_with_units(tol, units, 3)})", _NEAR_MISS_HINT)
    ratio = a / e
    if ratio < 0:
        size = abs(ratio)
        if size >= 3:
            return f"has the wrong sign and is about {size:.3g} times the expected size", None
        if size <= 1 / 3:
            return f"has the wrong sign and is about {1 / size:.3g} times smaller than the expected size", None
        return f"has the wrong sign (and its size is off by {_percent(size - 1)})", None
    if ratio >= 3:
        return f"is about {ratio:.3g} times the expected value", None
    if ratio <= 1 / 3:
        return f"is about {1 / ratio:.3g} times smaller than the expected value", None
    if e > 0:
        return f"is {_percent(ratio - 1)} too {'large' if a > e else 'small'}", None
    return f"is {_percent(ratio - 1)} {'larger' if abs(a) > abs(e) else 'smaller'} in size than expected", None


# ---------------------------------------------------------------------------------------------------------------------
# check_number
# ---------------------------------------------------------------------------------------------------------------------
def check_number(answer: Any, expected: float, *, rtol: float = 1e-3, atol: float = 0.0, name: str = "the answer",
                 units: str = "", common_mistakes: Mapping[float, str] | None = None, hint: str | None = None,
                 explanation: str | None = None, reveal_expected: bool = True) -> Feedback:
    """Check a single number against the expected value and explain a wrong one.

    The answer is accepted when ``abs(answer - expected) <= atol + rtol * abs(expected)``. A wrong answer is first
    compared with the exercise's known wrong answers (``common_mistakes``, same tolerance); then with a wrong sign, a
    factor of 2 and a power of ten (a unit conversion); a near miss (within ten tolerances) is called close; otherwise
    the message says how far off the answer is (in % or as a ratio) and shows ``hint``.

    Parameters
    ----------
    answer : object
        The student's answer. ``None`` (or ``...``) means "not answered yet". A one-element array or list is accepted
        as its element; text, truth values, functions and longer arrays get a message explaining what is expected.
    expected : float
        The right value (finite).
    rtol, atol : float
        Relative and absolute tolerance.
    name : str
        What the number is, with its article, e.g. ``"the two-way range"``; used in the messages.
    units : str
        The units the answer is expected in, e.g. ``"m"``; shown after the numbers.
    common_mistakes : mapping of float to str, optional
        Known wrong answers of this exercise, each with the hint that explains it (the likely cause).
    hint : str, optional
        The hint shown when no specific cause is recognised (default ``DEFAULT_HINT``).
    explanation : str, optional
        A sentence appended to the message of a correct answer (why it is right, what it means).
    reveal_expected : bool
        ``False`` for a graded (hidden) test: the message then gives nothing from which the expected value could be
        worked out (no percentage, ratio, distance or tolerance; "should be zero" becomes "is not right"), only the
        student's own value, a recognised mistake and the hint.

    Returns
    -------
    Feedback
        ``correct`` is true when the answer is within tolerance; ``details`` holds ``answer`` (as a float),
        ``relative_error`` and, for a recognised mistake, ``mistake`` (its value).

    Raises
    ------
    ValueError
        If ``expected`` is not a finite number or a tolerance is negative (a bug in the checker, not in the answer).

    Examples
    --------
    >>> check_number(-60.0, 60.0, name="the range error", units="m")
    ✘ Not yet: your value for the range error, -60 m, has the right size but the wrong sign.
      Hint: Check the sign convention of the task (for example, error = estimated value − true value).
    >>> check_number(
    ...     1510.0, 1480.0, name="c_e", units="m/s", reveal_expected=False
    ... )
    ✘ Not yet: your value for c_e, 1510 m/s, is too large.
      Hint: Re-read the task: check the formula, each input and its units.
    """
    e = float(expected)
    if not math.isfinite(e):
        raise ValueError(f"expected must be a finite number; got {expected!r}")
    if rtol < 0 or atol < 0:
        raise ValueError(f"rtol and atol must be >= 0; got rtol={rtol}, atol={atol}")
    what = f"{name} in {units} (a number)" if units else f"{name} (a number)"
    a, problem = _as_scalar(answer, name, what)
    if problem is not None:
        return problem
    assert a is not None
    problem = _non_finite(a, name)
    if problem is not None:
        return problem
    rel = (a - e) / abs(e) if e != 0 else math.inf if a != e else 0.0
    details: dict[str, Any] = {"answer": a, "relative_error": rel}
    tol = atol + rtol * abs(e)
    if abs(a - e) <= tol:
        message = f"Correct: {name} is {_with_units(a, units)}."
        if explanation:
            message += " " + explanation
        return Feedback(True, message, details=details)

    subject = f"{_NOT_YET}your value for {name}, {_with_units(a, units)},"
    for value, mistake_hint in (common_mistakes or {}).items():
        v = float(value)
        if abs(a - v) <= atol + rtol * abs(v):
            relation = "is not right"
            if e != 0 and reveal_expected:
                relation, relation_hint = _relation(a, e, rtol=rtol, atol=atol, units=units)
                if relation_hint == _NEAR_MISS_HINT:    # a recognised slip is no rounding: do not call it "close"
                    relation = f"is off by {_with_units(a - e, units, 3)}, a known slip rather than a rounding"
            return Feedback(False, f"{subject} {relation}.", hint=mistake_hint,
                            details={**details, "mistake": v, "diagnosed": True})
    if e == 0:
        should = f"should be zero (within ±{_with_units(atol, units)})" if reveal_expected else "is not right"
        return Feedback(False, f"{subject} {should}.", hint=hint or DEFAULT_HINT, details=details)
    relation, special_hint = _relation(a, e, rtol=rtol, atol=atol, units=units, reveal=reveal_expected)
    if _diagnoses(special_hint):
        details["diagnosed"] = True
    elif special_hint == _NEAR_MISS_HINT:
        details["near_miss"] = True
    return Feedback(False, f"{subject} {relation}.", hint=special_hint or hint or DEFAULT_HINT, details=details)


# ---------------------------------------------------------------------------------------------------------------------
# check_choice
# ---------------------------------------------------------------------------------------------------------------------
def read_letter(answer: Any, letters: Sequence[str], *, name: str = "the answer",
                options: Mapping[str, str] | None = None,
                example: str = "choice") -> tuple[str | None, Feedback | None]:
    """Read an answer that must be one of the capital ``letters``, as the question asks.

    Surrounding spaces are ignored. Anything else is not accepted, but explained, without saying whether the choice
    would be right: a letter in lower case (``"b"`` for ``"B"``), the text of an option instead of its letter, the
    letter in brackets or with a full stop, a number, a letter that is not an option.

    Parameters
    ----------
    answer : object
        The student's answer; ``None`` (or ``...``) means "not answered yet".
    letters : sequence of str
        The capital letters of the options, e.g. ``("A", "B", "C")``.
    name : str
        What the letter names, e.g. ``"the consistent filter"``; used in the messages.
    options : mapping of str to str, optional
        The options' texts by letter, to recognise an answer that gives the text.
    example : str
        The variable the student assigns, shown in the hints (``choice = "A"``).

    Returns
    -------
    tuple
        ``(letter, None)`` for an accepted letter, ``(None, feedback)`` otherwise.

    Examples
    --------
    >>> read_letter("B", "ABC")
    ('B', None)
    >>> print(
    ...     read_letter(
    ...         "b",
    ...         "ABC",
    ...         name="the overconfident filter",
    ...         example="overconfident",
    ...     )[1]
    ... )
    ✘ Not yet: the overconfident filter is asked as a capital letter: write "B", not 'b'.
      Hint: The options are the capital letters "A", "B", "C"; Python tells "b" from "B": `overconfident = "B"`.
    """
    keys = list(letters)
    listed = ", ".join(f'"{k}"' for k in keys)
    if _is_unanswered(answer):
        return None, not_answered(f"the letter of {name} (one of {listed})")
    first = f'`{example} = "{keys[0]}"`'
    if not isinstance(answer, str):
        return None, Feedback(False, f"Not yet: {name} should be one of the letters {listed}; got "
                                     f"{_a_type(answer)}, {_fmt_value(answer)}.",
                              hint=f"Write the letter in quotes, e.g. {first}.")
    text = answer.strip()
    if text in keys:
        return text, None
    bare = text.strip("()[]. ")
    if bare.upper() in keys and bare != bare.upper():
        letter = bare.upper()
        return None, Feedback(False, f'Not yet: {name} is asked as a capital letter: write "{letter}", not '
                                     f"{answer!r}.",
                              hint=f'The options are the capital letters {listed}; Python tells "{bare}" from '
                                   f'"{letter}": `{example} = "{letter}"`.', details={"case": letter})
    if bare in keys:
        return None, Feedback(False, f'Not yet: write the letter alone, "{bare}", not {answer!r}.',
                              hint=f'Only the letter, in quotes: `{example} = "{bare}"`.', details={"bare": bare})
    for key, option in (options or {}).items():
        if text.casefold() == str(option).strip().casefold():
            return None, Feedback(False, f"Not yet: {name} is asked as the letter of an option; {answer!r} is the "
                                         f'text of option "{key}".',
                                  hint=f'Give its letter: `{example} = "{key}"`.', details={"text_of": key})
    return None, Feedback(False, f"Not yet: {name} should be one of the letters {listed}; got {answer!r}.",
                          hint=f"Write the letter in quotes, e.g. {first}.")


def check_choice(answer: Any, expected: str, options: Mapping[str, str], *, name: str = "the answer",
                 common_mistakes: Mapping[str, str] | None = None, hint: str | None = None,
                 explanation: str | None = None) -> Feedback:
    """Check a multiple-choice answer given as the capital letter of an option, and explain a wrong choice.

    The answer must be the letter as the question asks (surrounding spaces aside): a lower-case letter, the option's
    text or ``"(B)"`` gets a message that asks for the capital letter alone, without judging the choice
    (``read_letter``); anything else (a number, a truth value, a letter that is not an option) a message listing the
    letters.

    Parameters
    ----------
    answer : object
        The student's answer; ``None`` (or ``...``) means "not answered yet".
    expected : str
        The key of the right option (computed by the checker).
    options : mapping of str to str
        The options, key (a letter such as ``"A"``) to the text the task shows.
    name : str
        What is being chosen, with its article, e.g. ``"the method for this situation"``.
    common_mistakes : mapping of str to str, optional
        Hints for wrong options, keyed like ``options``: why that choice is tempting and what it misses.
    hint : str, optional
        The hint for a wrong option without a specific one (default ``DEFAULT_HINT``).
    explanation : str, optional
        A sentence appended to the message of the right choice.

    Returns
    -------
    Feedback
        ``details`` holds ``answer`` (the key chosen) when the answer names an option.

    Raises
    ------
    ValueError
        If ``options`` is empty, a key is not a non-empty string, two keys differ only by case, or ``expected`` is not
        a key (a bug in the checker, not in the answer).

    Examples
    --------
    >>> options = {"A": "the EKF", "B": "the particle filter"}
    >>> check_choice("B", "B", options, name="the method")
    ✔ Correct: B, the particle filter.
    >>> check_choice("the particle filter", "B", options, name="the method")
    ✘ Not yet: the method is asked as the letter of an option; 'the particle filter' is the text of option "B".
      Hint: Give its letter: `choice = "B"`.
    >>> check_choice("C", "B", options, name="the method")
    ✘ Not yet: the method should be one of the letters "A", "B"; got 'C'.
      Hint: Write the letter in quotes, e.g. `choice = "A"`.
    """
    if not options:
        raise ValueError("options must hold at least one option")
    keys = list(options)
    if not all(isinstance(k, str) and k.strip() for k in keys):
        raise ValueError(f"the keys of options must be non-empty strings; got {keys!r}")
    if len({k.upper() for k in keys}) != len(keys):
        raise ValueError(f"the keys of options must differ in more than case; got {keys!r}")
    if expected not in options:
        raise ValueError(f"expected must be one of the keys of options {keys}; got {expected!r}")
    key, problem = read_letter(answer, keys, name=name, options=options)
    if problem is not None:
        return problem
    assert key is not None
    details = {"answer": key}
    if key == expected:
        message = f"Correct: {key}, {options[key]}."
        if explanation:
            message += " " + explanation
        return Feedback(True, message, details=details)
    specific = (common_mistakes or {}).get(key)
    if specific is not None:
        details["mistake"] = key
    return Feedback(False, f"Not yet: {key}, {options[key]}, is not {name}.",
                    hint=specific or hint or DEFAULT_HINT, details=details)


# ---------------------------------------------------------------------------------------------------------------------
# check_array
# ---------------------------------------------------------------------------------------------------------------------
def _as_array(answer: Any, name: str, expected: np.ndarray) -> tuple[np.ndarray | None, Feedback | None]:
    """Turn ``answer`` into an array comparable with ``expected``, or explain why it cannot be."""
    boolean = expected.dtype == bool
    what = f"{name} (an array of shape {expected.shape})"
    if _is_unanswered(answer):
        return None, not_answered(what)
    if isinstance(answer, (str, bytes, dict, set, frozenset)) or callable(answer):
        fb = _wrong_type(answer, name, f"an array of shape {expected.shape}")
        assert fb is not None
        return None, fb
    try:
        arr = np.asarray(answer)
    except (TypeError, ValueError):
        return None, Feedback(False, f"{_NOT_YET}{name} cannot be turned into an array of numbers.",
                              hint="Its rows probably have different lengths: every row needs the same number of "
                                   "elements.")
    except Exception as exc:        # an object whose __array__ / __len__ raises: feedback, never a crash
        return None, Feedback(False, f"{_NOT_YET}{name} ({_a_type(answer)}) cannot be turned into an array of "
                                     "numbers.",
                              hint="Build the array itself, e.g. with `np.array(...)`." + _conversion_failure(exc))
    if arr.dtype.kind == "O" and arr.ndim == 0:
        return None, Feedback(False, f"Your answer is a {_type_name(answer)}; {name} should be an array of shape "
                                     f"{expected.shape}.",
                              hint="Build the array itself, e.g. with `np.array(...)` or `np.column_stack(...)`.")
    if arr.dtype.kind in "OUSV":
        for idx, item in np.ndenumerate(arr):
            if item is None or isinstance(item, (str, bytes, bool, np.bool_)) or not isinstance(item, numbers.Number):
                shown = repr(str(item)) if isinstance(item, str) else repr(item)
                where = f" at index {_fmt_index(idx)}" if idx else ""
                return None, Feedback(False, f"{_NOT_YET}{name} contains {shown}{where}, "
                                             "which is not a number.",
                                      hint="Every element must be a number (use NaN for a missing value).")
        try:
            arr = arr.astype(complex) if any(isinstance(v, complex) for v in arr.flat) else arr.astype(float)
        except OverflowError:
            big = next((v for v in arr.flat if isinstance(v, int) and abs(v) > 1.7e308), None)
            return None, _too_large(big if big is not None else 0, name)
        except Exception as exc:
            return None, Feedback(False, f"{_NOT_YET}{name} holds elements that cannot be turned into numbers.",
                                  hint="Every element must be a number." + _conversion_failure(exc))
    if arr.dtype.kind == "c":
        if np.any(arr.imag != 0):
            return None, Feedback(False, f"Not yet: {name} contains complex numbers.",
                                  hint="A square root of a negative number? Check the signs under the root.")
        return None, _complex_zero_imag(name)
    if arr.ndim == 0 and expected.ndim > 0:
        return None, Feedback(False, f"Not yet: {name} is a single value; expected an array of shape "
                                     f"{expected.shape}.",
                              hint="Compute one value per element (a NumPy expression on arrays, or a loop that "
                                   "fills an array).")
    if boolean:
        if arr.dtype.kind in "iu" and arr.ndim == 1 and expected.ndim == 1 and arr.shape != expected.shape \
                and np.all((arr >= 0) & (arr < expected.size)):
            return None, Feedback(False, f"{_NOT_YET}{name} looks like a list of positions (indices), not one "
                                         "True/False flag per element.",
                                  hint="Return a boolean mask as long as the input: "
                                       "`mask = np.zeros(n, dtype=bool)`, then `mask[i] = True`.")
        if arr.dtype.kind in "iuf" and arr.size and not np.all(np.isin(arr, (0, 1))):
            return None, Feedback(False, f"Not yet: {name} should hold True/False flags, but it holds numbers "
                                         f"such as {_fmt(arr.flat[np.flatnonzero(~np.isin(arr, (0, 1)))[0]])}.",
                                  hint="Return a boolean array (for example start from "
                                       "`np.zeros(len(x), dtype=bool)` and set the flagged elements to True), not "
                                       "the values themselves.")
        if arr.dtype.kind in "biuf":
            arr = arr.astype(bool)
    elif arr.dtype.kind == "b":
        return None, Feedback(False, f"Not yet: {name} holds True/False values; expected numbers.",
                              hint="Did you assign the result of a comparison instead of the quantity itself?")
    else:
        arr = arr.astype(float)
    return arr, None


def _shape_feedback(arr: np.ndarray, expected: np.ndarray, name: str) -> Feedback:
    got, want = arr.shape, expected.shape
    prefix = f"{_NOT_YET}{name} has the wrong shape: expected shape {want}, got {got}"
    if arr.ndim == 2 and expected.ndim == 2 and got == want[::-1]:
        return Feedback(False, prefix + ": transpose?",
                        hint="Use `.T` to transpose it, or build it with `np.column_stack(...)` (1-D arrays side by "
                             "side as columns) rather than `np.array([...])` or `np.vstack(...)` (one row each).",
                        details={"shape": got})
    if arr.ndim and got[0] == want[0] - 1 and got[1:] == want[1:]:
        short = f"{got[0]} values instead of {want[0]}" if arr.ndim == 1 else "one row short"
        return Feedback(False, prefix + f": {short}.",
                        hint="`np.arange(start, stop, step)` leaves out `stop`: use `np.arange(start, stop + step, "
                             "step)` or `np.linspace(start, stop, n)`, and check the ends of your loops.",
                        details={"shape": got})
    if arr.size == expected.size:
        if np.squeeze(arr).shape == np.squeeze(expected).shape:
            fix = "remove the extra axis of length 1 (`np.squeeze`, `.ravel()`) or add the missing one"
        else:
            fix = "check how you stacked or reshaped it"
        return Feedback(False, prefix + f": the same number of elements ({arr.size}), arranged differently.",
                        hint=f"Arrange the elements as the task asks: {fix}.", details={"shape": got})
    if arr.ndim == 1 and expected.ndim == 1:
        return Feedback(False, prefix + f": {got[0]} values instead of {want[0]}.",
                        hint="Check the range of your loop or of `np.arange` (which leaves out its end).",
                        details={"shape": got})
    return Feedback(False, prefix + ".", hint="Compare the number of rows and columns with the task.",
                    details={"shape": got})


def _array_relation(arr: np.ndarray, exp: np.ndarray, rtol: float, atol: float) -> tuple[str, str | None] | None:
    """A whole-array relation between a wrong answer and the expected array (wrong sign, factor, transpose...)."""

    def close(candidate: np.ndarray) -> bool:
        return candidate.shape == exp.shape and bool(np.allclose(candidate, exp, rtol=rtol, atol=atol, equal_nan=True))

    if not np.any(exp[np.isfinite(exp)] != 0):
        return None
    if close(-arr):
        return "has the right size but the wrong sign everywhere", _SIGN_HINT
    if close(arr / 2):
        return "is twice the expected array everywhere", _TWICE_HINT
    if close(arr * 2):
        return "is half the expected array everywhere", _HALF_HINT
    for k in range(1, 10):
        if close(arr / 10 ** k):
            return f"is {10 ** k:,} times larger than expected everywhere", _power_hint(k, "")
        if close(arr * 10 ** k):
            return f"is {10 ** k:,} times smaller than expected everywhere", _power_hint(k, "")
    if arr.ndim == 2 and arr.shape[0] == arr.shape[1] and close(arr.T):
        return "is the transpose of the expected array", "Swap rows and columns (`.T`): check which axis is which."
    if arr.ndim == 2 and arr.shape[1] > 1 and close(arr[:, ::-1]):
        return "has its columns in reverse order", "Check the order of the columns the task asks for."
    if arr.ndim >= 1 and arr.shape[0] > 1 and close(arr[::-1]):
        return "is in reverse order", "Check the order the task asks for (first element first)."
    return None


def check_array(answer: Any, expected: Any, *, rtol: float = 1e-6, atol: float = 0.0, name: str = "the array",
                units: str = "", common_mistakes: Iterable[tuple[Any, str]] | None = None, hint: str | None = None,
                explanation: str | None = None, reveal_expected: bool = True) -> Feedback:
    """Check an array against the expected array and explain a wrong one.

    Elements are compared with ``numpy.isclose(answer, expected, rtol, atol, equal_nan=True)`` (a NaN where NaN is
    expected, a missing value, is right). The checks, in order: the answer can be an array of numbers; its shape
    (a transposed ``(2, K)`` for ``(K, 2)`` is named as such, so is a row too few); NaN or infinite elements where
    numbers are expected; the exercise's known wrong arrays (``common_mistakes``); a wrong sign, a factor of 2, a
    power of ten, a transpose, reversed columns or order; otherwise the worst element (relative to the tolerance) and
    the number of wrong elements.

    With a boolean ``expected`` the answer must hold flags (booleans, or 0 and 1); the message names the elements
    flagged by mistake and those missed. A 1-D integer answer of another length is recognised as a list of indices.

    Parameters
    ----------
    answer : object
        The student's array (anything ``numpy.asarray`` accepts). ``None`` means "not answered yet".
    expected : array_like
        The right array (numbers, possibly NaN for missing values, or booleans).
    rtol, atol : float
        Relative and absolute tolerance for numeric arrays.
    name : str
        What the array is, e.g. ``"the track"``; used in the messages.
    units : str
        Units of the elements, shown after the numbers.
    common_mistakes : iterable of (array_like, str), optional
        Known wrong arrays of this exercise, each with the hint that explains it.
    hint : str, optional
        The hint shown when no specific cause is recognised.
    explanation : str, optional
        A sentence appended to the message of a correct answer.
    reveal_expected : bool
        ``False`` for a graded (hidden) test: the message then shows no expected element (only the student's own
        worst element), and for flags only how many differ, not which.

    Returns
    -------
    Feedback
        ``details`` holds the answer's ``shape`` and, for a numeric array with wrong elements, ``n_wrong`` and
        ``worst_index``.

    Examples
    --------
    >>> import numpy as np
    >>> fb = check_array(np.zeros((2, 5)), np.ones((5, 2)), name="the track")
    >>> print(fb.message)
    Not yet: the track has the wrong shape: expected shape (5, 2), got (2, 5): transpose?
    """
    exp = np.asarray(expected)
    boolean = exp.dtype == bool
    if not boolean:
        exp = exp.astype(float)
    if rtol < 0 or atol < 0:
        raise ValueError(f"rtol and atol must be >= 0; got rtol={rtol}, atol={atol}")
    arr, problem = _as_array(answer, name, exp)
    if problem is not None:
        return problem
    assert arr is not None
    if arr.shape != exp.shape:
        return _shape_feedback(arr, exp, name)
    details: dict[str, Any] = {"shape": arr.shape}
    if boolean:
        return _compare_flags(arr, exp, name, hint, explanation, details, reveal_expected)

    nan_where_number = np.isnan(arr) & ~np.isnan(exp)
    if nan_where_number.any():
        where = [tuple(i) for i in np.argwhere(nan_where_number)]
        return Feedback(False, f"{_NOT_YET}{name} contains NaN (not a number) at {_list_indices(where)}, where a "
                               "number is expected.",
                        hint="NaN comes from an undefined operation (0/0, the square root of a negative number...), "
                             "from a NaN among the inputs, or from an array made with `np.empty` and never filled.",
                        details=details)
    number_where_nan = ~np.isnan(arr) & np.isnan(exp)
    if number_where_nan.any():
        where = [tuple(i) for i in np.argwhere(number_where_nan)]
        return Feedback(False, f"{_NOT_YET}{name} has a number at {_list_indices(where)}, where NaN (a missing "
                               "value) is expected.",
                        hint="A missing input should give a missing output: do not replace NaN by 0.", details=details)
    inf_where_finite = np.isinf(arr) & ~np.isinf(exp)
    if inf_where_finite.any():
        where = [tuple(i) for i in np.argwhere(inf_where_finite)]
        return Feedback(False, f"{_NOT_YET}{name} is infinite at {_list_indices(where)}.",
                        hint="A division by zero? Check the denominators.", details=details)

    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        diff = np.abs(arr - exp)
        same = (np.isnan(arr) & np.isnan(exp)) | (np.isinf(exp) & (arr == exp))
        tol = atol + rtol * np.abs(exp)
        ok = same | (diff <= tol)
        if ok.all():
            message = f"Correct: {name} is right (shape {arr.shape})."
            if explanation:
                message += " " + explanation
            return Feedback(True, message, details=details)
        excess = np.where(ok, 0.0, diff / np.maximum(tol, np.finfo(float).tiny))
    worst = tuple(int(i) for i in np.unravel_index(int(np.argmax(excess)), arr.shape))
    n_wrong = int((~ok).sum())
    details.update(n_wrong=n_wrong, worst_index=worst)

    with np.errstate(all="ignore"):
        relation = _array_relation(arr, exp, rtol, atol)
        for candidate, mistake_hint in common_mistakes or ():
            cand = np.asarray(candidate, dtype=float)
            if cand.shape == arr.shape and np.allclose(arr, cand, rtol=rtol, atol=atol, equal_nan=True):
                text = relation[0] if relation else f"has {n_wrong} of {arr.size} elements off"
                return Feedback(False, f"{_NOT_YET}{name} {text}.", hint=mistake_hint,
                                details={**details, "diagnosed": True})
    if relation is not None:
        return Feedback(False, f"{_NOT_YET}{name} {relation[0]}.", hint=relation[1] or hint or DEFAULT_HINT,
                        details={**details, "diagnosed": relation[1] is not None})
    u = f" {units}" if units else ""
    verb = "is" if n_wrong == 1 else "are"
    expected_text = f", expected {_fmt(exp[worst])}{u}" if reveal_expected else ""
    return Feedback(False, f"{_NOT_YET}{n_wrong} of {arr.size} elements of {name} {verb} off; the worst is at index "
                           f"{_fmt_index(worst)}: got {_fmt(arr[worst])}{u}{expected_text}.",
                    hint=hint or DEFAULT_HINT, details=details)


def _compare_flags(arr: np.ndarray, exp: np.ndarray, name: str, hint: str | None, explanation: str | None,
                   details: dict[str, Any], reveal: bool = True) -> Feedback:
    false_alarms = [tuple(i) for i in np.argwhere(arr & ~exp)]
    misses = [tuple(i) for i in np.argwhere(~arr & exp)]
    if not false_alarms and not misses:
        message = f"Correct: all {arr.size} flags of {name} are right."
        if explanation:
            message += " " + explanation
        return Feedback(True, message, details=details)
    parts = []
    if false_alarms:
        parts.append(f"flags {_list_indices(false_alarms)}, which should not be flagged")
    if misses:
        parts.append(f"misses {_list_indices(misses)}, which should be flagged")
    n_wrong = len(false_alarms) + len(misses)
    details.update(n_wrong=n_wrong, false_alarms=false_alarms, misses=misses)
    if not reveal:
        return Feedback(False, f"{_NOT_YET}{n_wrong} of {arr.size} flags of {name} differ ({len(false_alarms)} set "
                               f"where they should not be, {len(misses)} missed).",
                        hint=hint or DEFAULT_HINT, details=details)
    return Feedback(False, f"{_NOT_YET}{name} {' and '.join(parts)} ({n_wrong} of {arr.size} flags differ).",
                    hint=hint or DEFAULT_HINT, details=details)


# ---------------------------------------------------------------------------------------------------------------------
# check_function
# ---------------------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Case:
    """One test case for ``check_function``: the arguments, a label and an optional hint.

    Parameters
    ----------
    args : tuple
        Positional arguments.
    kwargs : dict
        Keyword arguments.
    label : str, optional
        What the case tests, e.g. ``"an outlier in the first sample"``; shown when the case fails.
    hint : str, optional
        The hint shown when this case fails (the likely cause), instead of the general one.

    Examples
    --------
    >>> case = Case((np.array([1.0, 2.0]), 5.0), label="two ranges", hint="Use both ranges.")
    >>> len(case.args), case.label
    (2, 'two ranges')
    """

    args: tuple = ()
    kwargs: dict[str, Any] = field(default_factory=dict, hash=False)
    label: str | None = None
    hint: str | None = None


def _as_case(case: Any) -> Case:
    if isinstance(case, Case):
        return case
    if isinstance(case, tuple):
        return Case(args=case)
    if isinstance(case, Mapping):
        return Case(kwargs=dict(case))
    raise TypeError(f"each test case must be a Case, a tuple of positional arguments or a dict of keyword arguments; "
                    f"got {type(case).__name__}")


_EXCEPTION_HINTS: tuple[tuple[type[BaseException], str], ...] = (
    (IndexError, "An index is out of range: check the first and the last elements (where some neighbours do not "
                 "exist) and the ends of your loops."),
    (KeyError, "A key is missing from a dictionary: print the keys to see what is there."),
    (ZeroDivisionError, "A division by zero: which denominator can be 0 for these inputs?"),
    (UnboundLocalError, "A variable is used before it is given a value on some path through the function (inside an "
                        "`if` that was not taken?)."),
    (NameError, "A name is not defined: is it spelt the same everywhere, and did you run the cell that defines it?"),
    (TypeError, "A value has the wrong type, or a function got the wrong number of arguments: print the types "
                "(`type(x)`) of your variables."),
    (ValueError, "A function got a value it cannot handle: check the shapes and lengths of your arrays "
                 "(`x.shape`)."),
    (AttributeError, "An object does not have the attribute or method you used: print its type (`type(x)`)."),
    (RecursionError, "The function calls itself without end: check its stopping condition."),
)


def _exception_hint(exc: BaseException) -> str:
    for kind, text in _EXCEPTION_HINTS:
        if isinstance(exc, kind):
            return text
    return "Read the error message and the line it points to."


def _where(exc: BaseException) -> str | None:
    """The line of the student's code where ``exc`` was raised (skipping this package and installed libraries)."""
    frames = traceback.extract_tb(exc.__traceback__)[1:]  # the first frame is check_function itself
    own = [f for f in frames
           if not f.filename.startswith(_PACKAGE_DIR) and "site-packages" not in f.filename
           and "dist-packages" not in f.filename and not f.filename.startswith("<frozen")]
    if not own:
        return None
    frame = own[-1]
    line = (frame.line or "").strip()
    return f"line {frame.lineno} of your code" + (f": `{line}`" if line else "")


def _same(a: Any, b: Any) -> bool:
    """Whether an input is unchanged by the call (used to detect in-place modification)."""
    try:
        if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
            a_arr, b_arr = np.asarray(a), np.asarray(b)
            if a_arr.shape != b_arr.shape or a_arr.dtype != b_arr.dtype:
                return False
            if a_arr.dtype.kind in "fc":
                return bool(np.array_equal(a_arr, b_arr, equal_nan=True))
            return bool(np.array_equal(a_arr, b_arr))
        if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
            return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
        result = a == b
        if isinstance(result, bool):
            return result or (isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b))
        return True
    except Exception:  # an exotic object that cannot be compared: assume it is unchanged
        return True


def _default_compare(got: Any, expected: Any, rtol: float, atol: float, reveal: bool = True) -> Feedback:
    if isinstance(expected, (numbers.Real, np.number)) and not isinstance(expected, (bool, np.bool_)):
        return check_number(got, cast(float, expected), rtol=rtol, atol=atol, name="the result",
                            reveal_expected=reveal)
    if isinstance(expected, (np.ndarray, list, tuple)):
        return check_array(got, expected, rtol=rtol, atol=atol, name="the result", reveal_expected=reveal)
    try:
        equal = bool(got == expected)
    except Exception:
        equal = False
    if equal:
        return Feedback(True, "Correct.")
    return Feedback(False, f"{_NOT_YET}the result is {_fmt_value(got)}"
                           + (f", expected {_fmt_value(expected)}." if reveal else ", which is not right."))


def _judge(got: Any, expected: Any, compare: Callable[[Any, Any], Feedback] | None, rtol: float, atol: float,
           case: Case, names: list[str], args: tuple, kwargs: dict, allow_mutation: bool,
           reveal: bool = True) -> Feedback | tuple:
    """The verdict on one case: ``("mutated", name)``, ``("none",)`` or the comparison's Feedback."""
    if not allow_mutation:
        for key, original, passed in [*zip(names, case.args, args),
                                      *((k, case.kwargs[k], kwargs[k]) for k in case.kwargs)]:
            if not _same(original, passed):
                return ("mutated", key)
    if got is None and expected is not None:
        return ("none",)
    return compare(got, expected) if compare is not None else _default_compare(got, expected, rtol, atol, reveal)


class StudentTimeout(BaseException):
    """Raised inside a student's function that ran past the time limit (a BaseException, so that the student's own
    ``except Exception`` cannot swallow it)."""


@contextlib.contextmanager
def time_limit(seconds: float):
    """Stop the code run inside this block with :class:`StudentTimeout` once it has used ``seconds`` of CPU time.

    CPU time (of this process), not time on the wall: on a busy machine a correct function takes longer on the wall
    but not more CPU, so it is never stopped for the machine's load; an endless loop uses CPU and is stopped. Code
    that waits without using the CPU (``time.sleep``, ``input()``) is stopped after ``WALL_FACTOR * seconds`` on the
    wall. In the main thread on a POSIX system (a Jupyter kernel) interval timers (``ITIMER_PROF`` for the CPU,
    ``ITIMER_REAL`` for the wall) interrupt any Python code, even a ``while True: pass``; elsewhere a trace function
    checks the clocks at every line of Python code. Neither can interrupt a single long call into compiled code: it
    is stopped when it returns.
    """
    cpu_deadline = time.process_time() + seconds
    wall_deadline = time.monotonic() + WALL_FACTOR * seconds
    if hasattr(signal, "setitimer") and threading.current_thread() is threading.main_thread():
        def _alarm(signum, frame):
            raise StudentTimeout
        previous = {sig: signal.signal(sig, _alarm) for sig in (signal.SIGPROF, signal.SIGALRM)}
        signal.setitimer(signal.ITIMER_PROF, seconds)
        signal.setitimer(signal.ITIMER_REAL, WALL_FACTOR * seconds)
        try:
            yield
        finally:
            signal.setitimer(signal.ITIMER_PROF, 0)
            signal.setitimer(signal.ITIMER_REAL, 0)
            for sig, handler in previous.items():
                signal.signal(sig, handler)
        return
    previous_trace = sys.gettrace()

    def _trace(frame, event, arg):
        if time.process_time() > cpu_deadline or time.monotonic() > wall_deadline:
            raise StudentTimeout
        return _trace
    sys.settrace(_trace)
    try:
        yield
    finally:
        sys.settrace(previous_trace)


def _recognise_slip(got: Any, case: Case, mistakes: Sequence[tuple[Callable[..., Any], str]],
                    compare: Callable[[Any, Any], Feedback] | None, rtol: float, atol: float, reveal: bool,
                    time_limit_s: float) -> tuple[int, str] | None:
    """The first of the checker's known slips (``mistakes``) whose result on ``case`` the student's result matches.

    Each slip is a function written like the reference but with one typical mistake; it runs on fresh copies of
    the case's arguments and its result is compared with the student's as the reference's would be. A slip that
    raises, or a comparison that fails or takes too long, simply does not match. Returns ``(index, hint)``.
    """
    for index, (slipped, slip_hint) in enumerate(mistakes):
        try:
            wrong = slipped(*copy.deepcopy(case.args), **copy.deepcopy(case.kwargs))
            if wrong is None:
                continue
            with time_limit(time_limit_s):
                same = (compare(got, wrong) if compare is not None
                        else _default_compare(got, wrong, rtol, atol, reveal))
        except (Exception, StudentTimeout):       # noqa: BLE001 - an unmatched slip, never a crash
            continue
        if isinstance(same, Feedback) and same.correct:
            return index, slip_hint
    return None


def _best_hint(verdict: Feedback, slip: tuple[int, str] | None, case_hint: str | None,
               general_hint: str | None) -> str:
    """The hint of a failing case, the most specific diagnosis of the wrong value first.

    1. a known slip of the exercise that reproduces the student's result (``mistakes`` of :func:`check_function`);
    2. the comparison's diagnosis of the value itself (a known wrong value, a wrong sign, a factor of 2, a power of
       ten: ``details["diagnosed"]``), then any other hint of the comparison about this value (the part of the
       result that is wrong, a NaN, a shape), but for the mere guess of a rounding;
    3. the case's hint (what this case tests), then that guess, the checker's general hint, the default.
    """
    if slip is not None:
        return slip[1]
    specific = verdict.hint if verdict.hint not in (None, DEFAULT_HINT) else None
    if specific and not verdict.details.get("near_miss"):
        return specific
    return case_hint or specific or general_hint or DEFAULT_HINT


def check_function(func: Any, reference: Callable[..., Any], cases: Iterable[Any], *, name: str | None = None,
                   compare: Callable[[Any, Any], Feedback] | None = None, rtol: float = 1e-6, atol: float = 0.0,
                   hint: str | None = None, explanation: str | None = None,
                   allow_mutation: bool = False, time_limit_s: float | None = None,
                   reveal_expected: bool = True,
                   mistakes: Sequence[tuple[Callable[..., Any], str]] = ()) -> Feedback:
    """Run a student's function on test cases and report the first case where it disagrees with a reference.

    For each case the reference and the student's function are called on separate deep copies of the arguments.
    An exception raised by the student's code is caught and reported with its type, its message, the failing case
    and the line it came from (``NotImplementedError`` means "not answered yet"). Returning ``None`` is reported as a
    forgotten ``return``; modifying an input array in place is reported unless ``allow_mutation``.

    Parameters
    ----------
    func : object
        The student's function. ``None`` means "not answered yet"; anything not callable gets a message.
    reference : callable
        The reference implementation; its parameter names label the inputs in the messages.
    cases : iterable
        Test cases: ``Case`` objects, tuples of positional arguments or dicts of keyword arguments.
    name : str, optional
        The function's name as the student knows it (default: ``func.__name__``).
    compare : callable, optional
        ``compare(got, expected) -> Feedback``; the default uses ``check_number`` for numbers, ``check_array`` for
        arrays (boolean arrays compared as flags) and ``==`` otherwise. When the comparison recognises the cause of a
        wrong value, it says so with ``details["diagnosed"] = True``. The hint of a failing case is, in this order:
        a recognised slip (``mistakes``), the comparison's hint about the wrong value (unless it only guesses a
        rounding, ``details["near_miss"]``), the case's hint, the general ``hint``.
    rtol, atol : float
        Tolerances of the default comparison.
    hint : str, optional
        The hint shown when a case fails and neither the case nor the comparison gives a more specific one.
    explanation : str, optional
        A sentence appended to the message when every case passes.
    allow_mutation : bool
        Whether the function may modify its input arrays in place (default: no).
    time_limit_s : float, optional
        Seconds (default: the module's ``TIME_LIMIT``, read at each call) the student's function (and the reading
        of what it returned) may take on one case before it is stopped and reported as too slow (an endless loop);
        ``sys.exit()`` in the student's code is reported too.
    reveal_expected : bool
        ``False`` for a graded (hidden) test: a failing case then shows its inputs and what the function returned,
        but not the expected result (the default comparison also keeps it out of its message).
    mistakes : sequence of (callable, str)
        The exercise's typical slips, each a function with the reference's signature that makes one mistake, and
        the hint that explains it. When the student's result on a failing case matches a slip's result (by the
        same comparison), that hint is given: a diagnosis of the actual wrong value beats a per-case hint.

    Returns
    -------
    Feedback
        For a failure, ``details`` holds ``case`` (its index from 0), ``label``, ``inputs``, ``expected`` and ``got``
        (or ``exception``), and ``slip`` (the index in ``mistakes``) when a known slip was recognised.

    Raises
    ------
    ValueError
        If there are no cases (a bug in the checker).

    Examples
    --------
    >>> def reference(x):
    ...     return 2.0 * x
    >>> check_function(lambda x: x + x, reference, [(1.0,), (2.5,)], name="double")
    ✔ Correct: `double` passes all 2 test cases.
    >>> fb = check_function(
    ...     lambda x: 3.0 * x, reference, [Case((1.0,), label="one")], name="double"
    ... )
    >>> print(fb.message)
    Not yet: case 1 of 1 (one) fails: your value for the result, 3, is 50 % too large.
    Inputs: x = 1
    Expected: 2
    Got: 3
    >>> slips = [(lambda x: x + 1.0, "You added one instead of doubling.")]
    >>> fb = check_function(
    ...     lambda x: x + 1.0, reference,
    ...     [Case((3.0,), hint="Double the input.")], name="double", mistakes=slips,
    ... )
    >>> fb.hint  # the recognised slip, not the case's generic hint
    'You added one instead of doubling.'
    """
    case_list = [_as_case(c) for c in cases]
    if time_limit_s is None:
        time_limit_s = TIME_LIMIT
    if not (isinstance(time_limit_s, (int, float)) and not isinstance(time_limit_s, bool) and 0 < time_limit_s < 1e6):
        raise ValueError(f"time_limit_s must be a number of seconds in (0, 1e6); got {time_limit_s!r}")
    if not case_list:
        raise ValueError("check_function needs at least one test case")
    fname = name or getattr(func, "__name__", None) or "your function"
    refusal = _not_a_function(func, fname)
    if refusal is not None:
        return refusal
    param_names = _positional_names(reference)
    n = len(case_list)
    for i, case in enumerate(case_list):
        label = f" ({case.label})" if case.label else ""
        names = [param_names[j] if j < len(param_names) else f"argument {j + 1}" for j in range(len(case.args))]
        inputs = dict(zip(names, case.args)) | dict(case.kwargs)
        shown_inputs = ", ".join(f"{k} = {_fmt_value(v)}" for k, v in inputs.items())
        where_case = f"case {i + 1} of {n}{label}"
        expected = reference(*copy.deepcopy(case.args), **copy.deepcopy(case.kwargs))
        args, kwargs = copy.deepcopy(case.args), copy.deepcopy(case.kwargs)
        report = _CaseReport(fname, where_case, shown_inputs,
                             {"case": i, "label": case.label, "inputs": inputs, "expected": expected})
        got, failure = _call_student(func, args, kwargs, report, time_limit_s)
        if failure is not None:
            return failure
        try:
            with time_limit(time_limit_s):       # the returned object's own methods (__float__, __eq__...) run here
                verdict = _judge(got, expected, compare, rtol, atol, case, names, args, kwargs, allow_mutation,
                                 reveal_expected)
        except StudentTimeout:
            verdict = ("unreadable", f"reading what `{fname}` returned ({_a_type(got)}) took more than "
                       f"{time_limit_s:g} s")
        except Exception as exc:
            verdict = ("unreadable", f"`{fname}` returned {_a_type(got)} that could not be compared with the "
                       f"expected value ({type(exc).__name__}: {str(exc)[:80]})")
        if isinstance(verdict, tuple):
            failure = _unjudged(verdict, got, report, reveal_expected)
            if failure is not None:
                return failure
        elif not verdict:
            slip = _recognise_slip(got, case, mistakes, compare, rtol, atol, reveal_expected, time_limit_s)
            return _wrong_value(verdict, got, slip, case.hint, hint, report, reveal_expected)
    message = f"Correct: `{fname}` passes all {n} test cases."
    if explanation:
        message += " " + explanation
    return Feedback(True, message)


@dataclass(frozen=True)
class _CaseReport:
    """What :func:`check_function`'s messages about one case name, and the details each failure of it carries."""

    fname: str
    where: str
    inputs: str
    details: dict[str, Any]


def _not_a_function(func: Any, fname: str) -> Feedback | None:
    """The Feedback for an answer that is not a function yet (``None``, or not callable), else None."""
    if _is_unanswered(func):
        return Feedback(False, f"No answer yet: define the function `{fname}` (replace `None` with it).",
                        hint="Write it in the answer cell above, run that cell, then this one.",
                        details={"answered": False})
    if not callable(func):
        article = "an" if _type_name(func)[0].lower() in "aeiou" else "a"
        return Feedback(False, f"`{fname}` is {article} {_type_name(func)}, not a function.",
                        hint=f"Define it with `def {fname}(...):` and run that cell again.")
    return None


def _positional_names(reference: Callable[..., Any]) -> list[str]:
    """The names of the reference's positional parameters (they label the inputs in the messages); [] if unknown."""
    try:
        return [p.name for p in inspect.signature(reference).parameters.values()
                if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    except (TypeError, ValueError):
        return []


def _call_student(func: Callable[..., Any], args: tuple, kwargs: dict, report: _CaseReport,
                  time_limit_s: float) -> tuple[Any, Feedback | None]:
    """The student's result on one case, ``(got, None)``, or ``(None, feedback)`` saying why there is none."""
    fname, where_case, shown_inputs, base_details = report.fname, report.where, report.inputs, report.details
    try:
        with time_limit(time_limit_s):
            return func(*args, **kwargs), None
    except StudentTimeout:
        return None, Feedback(
            False, f"{_NOT_YET}`{fname}` was still running after {time_limit_s:g} s on {where_case} and was "
                   "stopped.\nInputs: " + shown_inputs,
            hint="An endless loop? Check that every `while` loop changes what its condition tests, and that a "
                 "recursion reaches its base case.",
            details={**base_details, "timeout": time_limit_s})
    except SystemExit as exc:
        return None, Feedback(
            False, f"{_NOT_YET}`{fname}` called `sys.exit()` (or `exit()`/`quit()`) on {where_case}, which would "
                   f"stop the whole notebook (exit code {exc.code!r}).\nInputs: " + shown_inputs,
            hint="Return a value instead of exiting; to signal a bad input, raise an exception such as "
                 "`ValueError`.",
            details={**base_details, "exception": exc})
    except NotImplementedError:
        return None, Feedback(
            False, f"No answer yet: `{fname}` still raises NotImplementedError.",
            hint="Replace the `raise NotImplementedError(...)` line in its body with your code, run that cell, "
                 "then this one.",
            details={**base_details, "answered": False})
    except Exception as exc:  # the student's code failed: report it, never crash the checker
        where = _where(exc)
        message = (f"{_NOT_YET}`{fname}` raised {type(exc).__name__}: {exc} on {where_case}."
                   f"\nInputs: {shown_inputs}")
        if where:
            message += f"\nWhere: {where}"
            exc_hint = _exception_hint(exc)
        elif isinstance(exc, TypeError) and "argument" in str(exc):  # raised by the call itself
            exc_hint = f"`{fname}` must accept the arguments ({', '.join(base_details['inputs'])}) in this order."
        else:
            exc_hint = _exception_hint(exc)
        return None, Feedback(False, message, hint=exc_hint, details={**base_details, "exception": exc})


def _unjudged(verdict: tuple, got: Any, report: _CaseReport, reveal_expected: bool) -> Feedback | None:
    """The Feedback for a result that could not be compared: unreadable, an input changed in place, or None."""
    fname, where_case, base_details = report.fname, report.where, report.details
    if verdict[0] == "unreadable":
        return Feedback(False, f"{_NOT_YET}{where_case} fails: {verdict[1]}.\nInputs: {report.inputs}"
                               + (f"\nExpected: {_fmt_value(base_details['expected'])}" if reveal_expected else ""),
                        hint="Return a number or a NumPy array of numbers, as the task asks.",
                        details={**base_details, "got": got})
    if verdict[0] == "mutated":
        key = verdict[1]
        return Feedback(False, f"{_NOT_YET}`{fname}` changed its input `{key}` in place on {where_case}.",
                        hint="Work on a copy (for example `x = np.array(x, dtype=float)` makes one), so "
                             "that the caller's data stay untouched.",
                        details={**base_details, "got": got})
    if verdict[0] == "none":
        return Feedback(False, f"{_NOT_YET}`{fname}` returned None on {where_case}.",
                        hint="Did you forget the `return` statement at the end of the function?",
                        details={**base_details, "got": got})
    return None


def _wrong_value(verdict: Feedback, got: Any, slip: tuple[int, str] | None, case_hint: str | None,
                 general_hint: str | None, report: _CaseReport, reveal_expected: bool) -> Feedback:
    """The Feedback for a wrong result: the comparison's diagnosis, the inputs, expected and got, the best hint."""
    fname = report.fname
    core = verdict.message.removeprefix(_NOT_YET).removeprefix("No answer yet: ")
    if core.startswith("Your answer is "):
        core = f"`{fname}` returned " + core.removeprefix("Your answer is ")
    message = (f"{_NOT_YET}{report.where} fails: {core}\nInputs: {report.inputs}"
               + (f"\nExpected: {_fmt_value(report.details['expected'])}" if reveal_expected else "")
               + f"\nGot: {_fmt_value(got)}")
    if slip is not None and verdict.details.get("near_miss"):     # a known slip is no rounding
        message = message.replace(core, f"`{fname}` returned {_fmt_value(got)}, which is not a rounding "
                                        "of the expected result but a known slip (see the hint).")
    best_hint = _best_hint(verdict, slip, case_hint, general_hint)
    extra = {} if slip is None else {"slip": slip[0]}
    return Feedback(False, message, hint=best_hint,
                    details={**report.details, "got": got, "comparison": verdict, **extra})


# ---------------------------------------------------------------------------------------------------------------------
# Shared by every checker: one parser of real answers, one time-limited runner of student code
# ---------------------------------------------------------------------------------------------------------------------
def parse_real_array(answer: Any, name: str, shape: tuple[int, ...] | None = None,
                     what: str | None = None) -> tuple[np.ndarray | None, Feedback | None]:
    """A student's answer as a float array, or the Feedback that says why it is not one.

    Real numbers only: complex numbers (even with a zero imaginary part), strings, None inside, bools, functions
    and objects are refused with a teaching message (never silently converted: ``np.asarray(w + 5j, dtype=float)``
    would drop the imaginary part). With ``shape`` the shape is checked too (a column vector is not raveled).

    Examples
    --------
    >>> arr, fb = parse_real_array(
    ...     np.array([1.0, 2.0]) + 5j, "the direction", (2,)
    ... )
    >>> arr is None, fb.correct
    (True, False)
    """
    if _is_unanswered(answer):
        return None, not_answered(what or f"{name} (an array of numbers)")
    template = np.zeros(shape if shape is not None else (1,))
    arr, fb = _as_array(answer, name, template)
    if fb is not None:
        if shape is None:               # the template's shape (1,) means "any shape": do not show it
            fb = dataclasses.replace(fb, message=fb.message.replace("an array of shape (1,)", "an array of numbers"))
        return None, fb
    assert arr is not None                          # no refusal: _as_array returned the array
    if shape is not None and arr.shape != tuple(shape):
        return None, _shape_feedback(arr, template, name)
    return arr, None


def run_student(func: Any, *args: Any, name: str = "your function", time_limit_s: float | None = None,
                reraise: tuple[type[BaseException], ...] = ()) -> tuple[Any, Feedback | None]:
    """Call a student's function within the time limit: ``(value, None)``, or ``(None, Feedback)`` when it is
    not a function, runs past ``time_limit_s`` (default ``TIME_LIMIT``), calls ``sys.exit()`` or raises (but the
    exception types in ``reraise``, which the caller answers itself, e.g. a stub's ``NotImplementedError``).

    Every checker that calls student code outside :func:`check_function` goes through this function, so that a
    loop never hangs the notebook and ``sys.exit()`` never escapes.

    Examples
    --------
    >>> import sys
    >>> value, fb = run_student(lambda: sys.exit(1), name="f")
    >>> value is None and "sys.exit" in fb.message
    True
    """
    limit = TIME_LIMIT if time_limit_s is None else time_limit_s
    if _is_unanswered(func):
        return None, Feedback(False, f"No answer yet: define the function `{name}`.", details={"answered": False})
    if not callable(func):
        return None, Feedback(False, f"`{name}` is {_a_type(func)}, not a function.",
                              hint=f"Define it with `def {name}(...):` and run that cell again.")
    try:
        with time_limit(limit):
            return func(*args), None
    except reraise:
        raise
    except StudentTimeout:
        return None, Feedback(False, f"{_NOT_YET}`{name}` was still running after {limit:g} s and was stopped.",
                              hint="An endless loop? Check that every `while` loop changes what its condition "
                                   "tests.", details={"timeout": limit})
    except SystemExit as exc:
        return None, Feedback(False, f"{_NOT_YET}`{name}` called `sys.exit()` (exit code {exc.code!r}), which would "
                                     "stop the whole notebook.",
                              hint="Return a value instead; to signal a bad input, raise an exception such as "
                                   "`ValueError`.", details={"exception": exc})
    except Exception as exc:  # noqa: BLE001 - the student's code failed: feedback, never a crash
        return None, Feedback(False, f"{_NOT_YET}`{name}` raised {type(exc).__name__}: {exc}.",
                              hint=_exception_hint(exc), details={"exception": exc})


# ---------------------------------------------------------------------------------------------------------------------
# Shared by the chapters' checkers (private to the exercises: each chapter module imports what it needs)
# ---------------------------------------------------------------------------------------------------------------------
def _row_as_vector(answer: Any, n: int) -> Any:
    """A ``(1, n)`` row (a Jacobian written as a 1 x n matrix) as its ``(n,)`` vector; any other answer unchanged.

    The answer is read by :func:`parse_real_array`, so that a ragged list, an object whose ``__array__`` fails or
    a string never crashes the probe: the checker's own parser then explains what is wrong with it.
    """
    if _is_unanswered(answer):
        return answer
    arr, _ = parse_real_array(answer, "the answer")
    return arr[0] if arr is not None and arr.shape == (1, n) else answer


def _answer_shape(answer: Any) -> tuple[int, ...] | None:
    """The shape of an answer that reads as an array of real numbers (:func:`parse_real_array`), else ``None``."""
    if _is_unanswered(answer):
        return None
    arr, _ = parse_real_array(answer, "the answer")
    return None if arr is None else arr.shape


def _probe_student(func: Any, args: Sequence[Any], name: str) -> tuple[np.ndarray | None, Feedback | None]:
    """Run a student's function once, before :func:`check_function`, to recognise a known mistake from its result.

    Returns ``(result, None)`` with the result read as a real array (``None`` when it is not one, or when the
    function raised: ``check_function`` then reports that case by case), or ``(None, feedback)`` when the function
    ran past the time limit or called ``sys.exit()``: a loop is not run again on every case. The arrays among
    ``args`` are copied, so the function cannot change the checker's own.
    """
    copies = [np.copy(a) if isinstance(a, np.ndarray) else a for a in args]
    value, stopped = run_student(func, *copies, name=name)
    if stopped is not None:
        if "timeout" in stopped.details or isinstance(stopped.details.get("exception"), SystemExit):
            return None, stopped
        return None, None
    got, _ = parse_real_array(value, "the result")
    return got, None


def _check_nees_letters(consistent: Any, overconfident: Any, letters: Sequence[str],
                        classify: Callable[[], tuple[str, str, str]], *, read: str,
                        correct: Callable[[str, str, str], str], underconfident: str = "") -> Feedback:
    """Check which of the filters of a NEES study is consistent and which overconfident (exercises 4.5 and 7.5).

    The letters are read first (:func:`read_letter`), so that an answer that is no letter, or the same letter
    twice, is explained without running the study; ``classify()`` then gives the right letters
    ``(consistent, overconfident, underconfident)``. ``read`` is the hint on how to read a NEES curve,
    ``correct(c, o, u)`` the message of the right answer, ``underconfident`` what the underconfident filter's
    curve means (appended to "it is underconfident").
    """
    chosen = {}
    for role, value in (("consistent", consistent), ("overconfident", overconfident)):
        chosen[role], problem = read_letter(value, letters, name=f"the {role} filter", example=role)
        if problem is not None:
            return problem
    c, o = chosen["consistent"], chosen["overconfident"]
    if c == o:
        return Feedback(False, "Not yet: one filter cannot be both consistent and overconfident.", hint=read)
    right_c, right_o, right_u = classify()
    if c == right_c and o == right_o:
        return Feedback(True, correct(right_c, right_o, right_u))
    if o == right_u:
        return Feedback(False, f"Not yet: {o}'s NEES lies *below* the band: it is underconfident{underconfident}, "
                               "not overconfident.", hint=read)
    if c != right_c:
        return Feedback(False, f"Not yet: {c} is not the consistent one: look at which curve stays inside the band.",
                        hint=read)
    return Feedback(False, f"Not yet: {o} is not the overconfident one.", hint=read)
