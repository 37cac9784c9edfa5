"""Input validation shared by every public function of ``uwtutor``.

Each helper checks one argument and raises an error that names the argument, says what was wrong and what to do
about it. Public functions call these at their boundary so that bad input never turns into a silent wrong answer
deep inside a filter.

The rules, in one place:

* **dtype** -- numbers and arrays of numbers are accepted (Python and numpy ints and floats, lists of them,
  objects with ``__array__``). Refused with a :class:`TypeError` naming the argument: strings (also numeric
  strings such as ``"3.0"``), complex numbers, ``None`` (also inside a list: use NaN for a missing value where
  that is allowed), bools (``True`` is not a number, and not an index), object arrays, dates.
  A list of rows of unequal lengths (ragged) and integers too large for float64 (``10**400``) are refused with a
  :class:`ValueError`.
* **finiteness and domain** -- :func:`as_finite`, :func:`as_positive`, :func:`as_nonnegative`,
  :func:`as_range_array`, :func:`as_in_range`; values whose products overflow float64 are refused by
  :func:`as_finite` with ``max_abs``.
* **shapes and batches** -- ``ndim``/``shape`` keywords, :func:`check_same_length`, :func:`check_same_shape`
  (no silent broadcasting of ``(K, 1)`` against ``(K, 2)``), ``nonempty`` (a sequence of length 0, ``M = 0`` runs,
  a 0x0 matrix are errors, not empty answers); :func:`common_runs`, the one rule for the leading runs axis ``M``
  that several inputs of one call may carry.
* **covariances** -- :func:`as_covariance`: square, symmetric to ``SYMMETRY_RTOL`` (relative), eigenvalues
  ``>= -PSD_RTOL * max|P|`` (semi-definite) or ``> 0`` (definite), entries ``<= MAX_COVARIANCE`` in magnitude
  (beyond it their products overflow float64). :func:`as_information` for information matrices.
* **flags, integers, seeds, objects** -- :func:`as_flag` (a real bool only: the string ``'False'`` is refused),
  :func:`as_int` (bools refused), :func:`as_rng`, :func:`as_seed`, :func:`as_instance`.

Examples
--------
>>> from uwtutor._validate import as_finite, as_flag
>>> as_finite("sigma", [1, 2.5])
array([1. , 2.5])
>>> as_finite("sigma", "2.5")  # doctest: +ELLIPSIS
Traceback (most recent call last):
    ...
TypeError: sigma must be numeric (a number or an array of numbers); got the string '2.5' (convert it with float() ...
>>> as_flag("fading", "False")
Traceback (most recent call last):
    ...
TypeError: fading must be True or False (a bool); got the string 'False'
"""

from __future__ import annotations

import numbers
from collections.abc import Mapping
from typing import Any

import numpy as np

__all__ = [
    "as_float_array",
    "as_finite",
    "as_positive",
    "as_nonnegative",
    "as_in_range",
    "as_range_array",
    "as_covariance",
    "as_information",
    "as_rng",
    "as_seed",
    "as_int",
    "as_index",
    "as_flag",
    "as_instance",
    "as_scalar",
    "as_choice",
    "as_callable",
    "as_bool_array",
    "check_model_covariance",
    "check_work",
    "check_finite_result",
    "check_same_length",
    "check_same_shape",
    "common_runs",
    "MAX_WORK",
    "SYMMETRY_RTOL",
    "PSD_RTOL",
    "MAX_COVARIANCE",
    "MAX_COORDINATE",
]

#: Relative tolerance of the symmetry test of a covariance: ``|P - P^T| <= SYMMETRY_RTOL * max(1, max|P|)``.
SYMMETRY_RTOL = 1e-9
#: A semi-definite covariance may have eigenvalues down to ``-PSD_RTOL * max(1, max|P|)`` (round-off).
PSD_RTOL = 1e-12
#: Largest covariance entry accepted: its square (formed by every filter update) stays below float64's 1.8e308.
MAX_COVARIANCE = 1e150


def _first_bad_index(mask: np.ndarray) -> str:
    """Describe where the first True of ``mask`` sits, e.g. ``'index 12'`` or ``'index (3, 1)'``."""
    idx = np.argwhere(mask)[0]
    return f"index {int(idx[0])}" if idx.size == 1 else f"index {tuple(int(i) for i in idx)}"


def _describe(value: Any) -> str:
    if isinstance(value, (str, bytes)):
        text: str | bytes = value
        if len(value) > 40:     # cut with an ellipsis of the value's own type (bytes + str is a TypeError)
            text = value[:37] + "..." if isinstance(value, str) else value[:37] + b"..."
        return f"the string {text!r}"
    return f"a {type(value).__name__}"


def _flat_items(value: Any, limit: int = 100_000):
    """Yield the leaves of nested lists/tuples (for naming the first bad element)."""
    stack = [value]
    seen = 0
    while stack and seen < limit:
        item = stack.pop()
        if isinstance(item, (list, tuple)):
            stack.extend(reversed(item))
        else:
            seen += 1
            yield item


def _bad_element(name: str, value: Any) -> None:
    """Raise the error for the first leaf of ``value`` that is not a real number (if any)."""
    for item in _flat_items(value):
        if item is None:
            raise TypeError(f"{name} contains None; use a number (or NaN, where a missing value is allowed)")
        if isinstance(item, (bool, np.bool_)):
            raise TypeError(f"{name} contains the bool {item!r}; pass a number (1.0 / 0.0) if you mean one")
        if isinstance(item, (str, bytes)):
            raise TypeError(f"{name} must hold numbers; it contains {_describe(item)} (convert it with float())")
        if isinstance(item, (complex, np.complexfloating)):
            raise TypeError(f"{name} must be real; it contains the complex number {item!r}")
        if isinstance(item, np.ndarray):
            continue
        if not isinstance(item, numbers.Real):
            raise TypeError(f"{name} must hold numbers; it contains {_describe(item)}")


def as_float_array(name: str, value: Any, *, ndim: int | tuple[int, ...] | None = None,
                   shape: tuple[int | None, ...] | None = None, nonempty: bool = False) -> np.ndarray:
    """Convert ``value`` to a float array, checking its dtype, its number of dimensions or its shape.

    ``shape`` may use ``None`` for an axis of any length, e.g. ``(None, 2)`` for an array of 2-D points; with
    ``nonempty`` an array with no element (``K = 0`` steps, ``M = 0`` runs) is refused. The dtype rules are in
    the module docstring (strings, complex, None, bools and objects are refused by name).
    """
    if value is None:
        raise TypeError(f"{name} must be numeric (a number or an array of numbers); got None")
    if isinstance(value, (str, bytes)):
        raise TypeError(f"{name} must be numeric (a number or an array of numbers); got {_describe(value)} "
                        "(convert it with float() if you mean the number)")
    if isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be a number; got the bool {value!r} (pass 1.0 or 0.0 if you mean a number)")
    if isinstance(value, (complex, np.complexfloating)):
        raise TypeError(f"{name} must be a real number; got the complex number {value!r}")
    if isinstance(value, (dict, set, frozenset)):
        raise TypeError(f"{name} must be numeric (a number or an array of numbers); got a {type(value).__name__}")
    try:
        raw = np.asarray(value)
    except ValueError as exc:                     # ragged nested lists (numpy >= 1.24)
        raise ValueError(f"{name} must be a rectangular array of numbers; its rows have different lengths "
                         f"({exc})") from None
    except Exception as exc:                      # an object whose __array__/__len__ fails
        raise TypeError(f"{name} must be numeric (a number or an array of numbers); got {_describe(value)} "
                        f"that numpy cannot read ({type(exc).__name__})") from None
    kind = raw.dtype.kind
    if kind in "fiu":
        arr = raw.astype(float, copy=False) if kind != "f" or raw.dtype != np.float64 else raw
    elif kind == "b":
        raise TypeError(f"{name} must hold numbers, not bools (got a bool array of shape {raw.shape}); "
                        "use arr.astype(float) if you mean 1.0/0.0")
    elif kind == "c":
        raise TypeError(f"{name} must be real; got a complex array of shape {raw.shape} "
                        "(pass np.real(...) if the imaginary part is meant to be zero)")
    elif kind in "US":
        raise TypeError(f"{name} must hold numbers; got strings (dtype {raw.dtype}); convert them with float()")
    elif kind == "O":
        _bad_element(name, value)
        _bad_element(name, list(raw.flat) if raw.ndim else [raw.item()])   # inside object arrays too (None is
        #                                                                    # never a missing value: NaN is)
        try:
            arr = raw.astype(float)
        except OverflowError:
            raise ValueError(f"{name} holds an integer too large for float64 (the largest float is about "
                             "1.8e308)") from None
        except (TypeError, ValueError) as exc:
            raise TypeError(f"{name} must be numeric (a number or an array of numbers); got {_describe(value)} whose "
                            f"elements numpy cannot convert to float ({exc})") from None
    else:
        raise TypeError(f"{name} must be numeric (a number or an array of numbers); got an array of dtype {raw.dtype}")
    if ndim is not None:
        allowed = (ndim,) if isinstance(ndim, int) else ndim
        if arr.ndim not in allowed:
            want = " or ".join(str(n) for n in allowed)
            raise ValueError(f"{name} must have {want} dimension(s); got shape {arr.shape}")
    if shape is not None:
        if arr.ndim != len(shape) or any(s is not None and s != a for s, a in zip(shape, arr.shape)):
            want = "(" + ", ".join("any" if s is None else str(s) for s in shape) + ")"
            raise ValueError(f"{name} must have shape {want}; got {arr.shape}")
    if nonempty and arr.size == 0:
        raise ValueError(f"{name} is empty (shape {arr.shape}); it needs at least one element along every axis")
    return arr


_FLOAT_MAX = float(np.finfo(float).max)


def _all_within(arr: np.ndarray, low: float, high: float, ignore_nan: bool = False) -> bool:
    """Whether every element of ``arr`` lies in ``[low, high]`` (a NaN never does, unless ``ignore_nan``; an array
    of NaNs only is never within): the quick test of a valid array, one pass through memory with no temporary
    array (the minimum and the maximum of blocks that stay in cache). False says only "look closer"."""
    smallest, largest = (np.fmin.reduce, np.fmax.reduce) if ignore_nan else (np.minimum.reduce, np.maximum.reduce)
    if not (arr.flags.c_contiguous or arr.flags.f_contiguous):
        return bool(smallest(arr, axis=None) >= low and largest(arr, axis=None) <= high)
    flat = arr.ravel(order="K")                       # a view
    block = 1 << 16
    for start in range(0, flat.size, block):
        part = flat[start:start + block]
        if not (smallest(part) >= low and largest(part) <= high):
            return False
    return True


def as_finite(name: str, value: Any, *, max_abs: float | None = None, **shape_kw: Any) -> np.ndarray:
    """A float array with no NaN or infinity (see :func:`as_float_array` for the shape keywords).

    With ``max_abs``, magnitudes above it are refused too (values whose squares or products would overflow).
    """
    arr = as_float_array(name, value, **shape_kw)
    limit = _FLOAT_MAX if max_abs is None else max_abs
    if arr.size > 1000 and _all_within(arr, -limit, limit):       # large and valid: one quick pass
        return arr
    bad = ~np.isfinite(arr)
    if bad.any():
        where = _first_bad_index(bad) if arr.ndim else "the value"
        raise ValueError(f"{name} must be finite; got {arr[bad].flat[0]} at {where}")
    if max_abs is not None:
        big = np.abs(arr) > max_abs
        if big.any():
            where = _first_bad_index(big) if arr.ndim else "the value"
            raise ValueError(f"{name} must be at most {max_abs:.3g} in magnitude (beyond it the computation "
                             f"overflows float64); got {arr[big].flat[0]:.3g} at {where}. Change its units")
    return arr


def as_positive(name: str, value: Any, **shape_kw: Any) -> np.ndarray:
    """A finite array whose every element is > 0 (sound speeds, standard deviations that cannot be zero...)."""
    arr = as_finite(name, value, **shape_kw)
    bad = arr <= 0
    if bad.any():
        where = _first_bad_index(bad) if arr.ndim else "the value"
        raise ValueError(f"{name} must be > 0; got {arr[bad].flat[0]} at {where}")
    return arr


def as_nonnegative(name: str, value: Any, **shape_kw: Any) -> np.ndarray:
    """A finite array whose every element is >= 0 (standard deviations, durations, ...)."""
    arr = as_finite(name, value, **shape_kw)
    bad = arr < 0
    if bad.any():
        where = _first_bad_index(bad) if arr.ndim else "the value"
        raise ValueError(f"{name} must be >= 0; got {arr[bad].flat[0]} at {where}")
    return arr


def as_in_range(name: str, value: Any, low: float, high: float, *, closed: tuple[bool, bool] = (True, True),
                **shape_kw: Any) -> np.ndarray:
    """A finite array within ``[low, high]`` (``closed`` says which ends are included), e.g. a probability."""
    arr = as_finite(name, value, **shape_kw)
    bad = (arr < low if closed[0] else arr <= low) | (arr > high if closed[1] else arr >= high)
    if bad.any():
        where = _first_bad_index(bad) if arr.ndim else "the value"
        interval = ("[" if closed[0] else "(") + f"{low:g}, {high:g}" + ("]" if closed[1] else ")")
        raise ValueError(f"{name} must lie in {interval}; got {arr[bad].flat[0]:g} at {where}")
    return arr


#: Largest coordinate or range a filter accepts [m]: squares and products of such values stay finite in float64.
MAX_COORDINATE = 1e150


def as_range_array(name: str, value: Any, *, allow_nan: bool = False, max_abs: float | None = None,
                   **shape_kw: Any) -> np.ndarray:
    """Measured ranges: finite and >= 0. With ``allow_nan`` a NaN marks a missing measurement (predict only).

    ``None`` is never a missing range (it is refused by name): write NaN.
    """
    arr = as_float_array(name, value, **shape_kw)
    if arr.size > 1000 and _all_within(arr, 0.0, _FLOAT_MAX if max_abs is None else max_abs, ignore_nan=allow_nan):
        return arr                                    # large and valid: one quick pass
    bad = np.isinf(arr) if allow_nan else ~np.isfinite(arr)
    bad |= arr < 0
    if bad.any():
        where = _first_bad_index(bad) if arr.ndim else "the value"
        missing = "; use NaN for a missing range" if allow_nan else ""
        raise ValueError(f"{name} must be finite and >= 0{missing}; got {arr[bad].flat[0]} at {where}")
    if max_abs is not None:
        big = arr > max_abs
        if big.any():
            raise ValueError(f"{name} must be at most {max_abs:.3g} (beyond it the computation overflows float64); "
                             f"got {arr[big].flat[0]:.3g} at {_first_bad_index(big) if arr.ndim else 'the value'}. "
                             "Change its units")
    return arr


def _check_square(name: str, M: np.ndarray, n: int | None, *, empty: str = "", size: str = "") -> None:
    """``M`` is a non-empty stack ``(..., n, n)`` of square matrices (any size when ``n`` is None); ``empty`` and
    ``size`` end the messages of an empty stack and of a wrong size."""
    if M.ndim < 2 or M.shape[-1] != M.shape[-2]:
        raise ValueError(f"{name} must be a square matrix; got shape {M.shape}")
    if M.size == 0:
        raise ValueError(f"{name} is empty (shape {M.shape}){empty}")
    if n is not None and M.shape[-1] != n:
        raise ValueError(f"{name} must be {n}x{n}{size}; got {M.shape[-2]}x{M.shape[-1]}")


def as_covariance(name: str, value: Any, n: int | None = None, *, allow_singular: bool = False) -> np.ndarray:
    """A symmetric positive-definite (or, with ``allow_singular``, semi-definite) ``(n, n)`` matrix.

    A scalar is accepted for ``n == 1``. Stacks ``(..., n, n)`` are checked matrix by matrix (an empty stack or a
    0x0 matrix is refused). Tolerances: symmetric to ``SYMMETRY_RTOL * max(1, max|P|)``; semi-definite means every
    eigenvalue ``>= -PSD_RTOL * max(1, max|P|)``; entries at most ``MAX_COVARIANCE`` in magnitude.
    """
    P = as_finite(name, value)
    if P.ndim == 0:
        P = P.reshape(1, 1)
    _check_square(name, P, n, empty="; a covariance needs at least one row (and one run)", size=" to match the state")
    peak = float(np.max(np.abs(P)))
    if peak > MAX_COVARIANCE:
        raise ValueError(f"{name} has an entry of {peak:.3g}, above {MAX_COVARIANCE:.0e}: the filter's products of "
                         "such variances overflow float64. An unknown start needs no more than a variance a few "
                         "orders of magnitude above the area's size squared (e.g. 1e8 m^2)")
    scale = max(1.0, peak)
    if P.shape[-1] == 1:
        # 1x1 matrices (a stack of variances, e.g. one range's noise per run and step): symmetric, and the entry is
        # the eigenvalue -- the same verdict as below without an eigen-decomposition per matrix
        eig_min = float(P.min())
    else:
        Pt = np.swapaxes(P, -1, -2)
        # np.allclose's test written out (P is finite here): the same verdict without its NaN and infinity
        # handling, which is most of the cost of checking a small matrix
        if not (np.abs(P - Pt) <= 1e-12 * scale + SYMMETRY_RTOL * np.abs(Pt)).all():
            raise ValueError(f"{name} must be symmetric; use (P + P.T) / 2 if it is only off by rounding")
        eig_min = np.linalg.eigvalsh(P).min()
    tol = -PSD_RTOL * scale if allow_singular else 0.0
    if (eig_min < tol) if allow_singular else (eig_min <= tol):
        kind = "positive semi-definite" if allow_singular else "positive definite"
        raise ValueError(f"{name} must be {kind}; its smallest eigenvalue is {eig_min:.3g}. "
                         "Check the variances on its diagonal and that correlations lie within [-1, 1]")
    return P


def as_information(name: str, value: Any, n: int | None = None) -> np.ndarray:
    """A Fisher information matrix: finite, square, symmetric and positive semi-definite (it may be singular).

    An indefinite matrix is not an information matrix (a sum of ``H^T R^-1 H`` terms never is): it is refused
    instead of being reported as singular. The tolerances are those of :func:`as_covariance`, without its bound on
    the entries.
    """
    J = as_finite(name, value)
    _check_square(name, J, n)
    scale = max(1.0, float(np.max(np.abs(J))))
    if not np.allclose(J, np.swapaxes(J, -1, -2), rtol=SYMMETRY_RTOL, atol=1e-12 * scale):
        raise ValueError(f"{name} must be symmetric (an information matrix is); use (J + J.T) / 2 if it is only "
                         "off by rounding")
    with np.errstate(over="ignore", invalid="ignore"):
        eig = np.linalg.eigvalsh(J / scale)
    if not np.all(np.isfinite(eig)):
        raise ValueError(f"{name} cannot be decomposed in float64 (entries up to {scale:.3g}); rescale it")
    if eig.min() < -1e-10:
        raise ValueError(f"{name} must be positive semi-definite (an information matrix is a sum of H^T R^-1 H "
                         f"terms); its smallest eigenvalue is {eig.min() * scale:.3g}. Check how it was built")
    return J


def as_rng(rng: Any) -> np.random.Generator:
    """Insist on an explicit :class:`numpy.random.Generator` so that every result is reproducible."""
    if not isinstance(rng, np.random.Generator):
        raise TypeError("rng must be a numpy.random.Generator, e.g. numpy.random.default_rng(42); "
                        f"got {type(rng).__name__}. uwtutor never uses the global random state")
    return rng


def as_seed(name: str, value: Any) -> int:
    """A seed: a non-negative integer (``None``, which would draw OS entropy, is refused: results must repeat)."""
    if value is None:
        raise TypeError(f"{name} must be an integer seed such as 42; None would draw a different result every "
                        "time")
    return as_int(name, value, minimum=0)


def as_int(name: str, value: Any, *, minimum: int | None = None, maximum: int | None = None) -> int:
    """An integer (``numpy`` integers accepted; bools, floats and strings refused), optionally within bounds."""
    if isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be an integer; got the bool {value!r}")
    if not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an integer; got {value!r} ({type(value).__name__})"
                        + (" -- convert it with int()" if isinstance(value, (float, str)) else ""))
    if minimum is not None and value < minimum:
        raise ValueError(f"{name} must be >= {minimum}; got {value}")
    if maximum is not None and value > maximum:
        raise ValueError(f"{name} must be <= {maximum}; got {value}")
    return int(value)


def as_index(name: str, value: Any, size: int) -> int:
    """An index into an axis of length ``size`` (negative indices count from the end; bools refused)."""
    i = as_int(name, value)
    if not -size <= i < size:
        raise ValueError(f"{name} must be an index in [{-size}, {size - 1}]; got {i}")
    return i % size


def as_flag(name: str, value: Any) -> bool:
    """A real bool (``numpy.bool_`` accepted). The string ``'False'`` and the integer ``0`` are refused."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    shown = _describe(value) if isinstance(value, str) else repr(value)
    raise TypeError(f"{name} must be True or False (a bool); got {shown}")


def as_instance(name: str, value: Any, kind: type | tuple[type, ...], hint: str = "") -> Any:
    """``value`` if it is an instance of ``kind``; a :class:`TypeError` naming the argument otherwise."""
    if not isinstance(value, kind):
        kinds = kind if isinstance(kind, tuple) else (kind,)
        want = " or ".join(f"{k.__module__}.{k.__qualname__}" for k in kinds)
        raise TypeError(f"{name} must be a {want}{(' (' + hint + ')') if hint else ''}; got {type(value).__name__}")
    return value


def check_same_length(**arrays: np.ndarray) -> int:
    """Check that the given arrays agree on the length of their first axis and return it."""
    lengths = {name: len(a) for name, a in arrays.items()}
    if len(set(lengths.values())) > 1:
        described = ", ".join(f"{name} has {n}" for name, n in lengths.items())
        raise ValueError(f"arrays must have the same length along their first axis: {described}")
    return next(iter(lengths.values()))


def check_same_shape(**arrays: np.ndarray) -> tuple[int, ...]:
    """Check that the given arrays have exactly the same shape (no broadcasting of (K, 1) against (K, 2))."""
    shapes = {name: np.shape(a) for name, a in arrays.items()}
    if len(set(shapes.values())) > 1:
        described = ", ".join(f"{name} has shape {s}" for name, s in shapes.items())
        raise ValueError(f"the arrays must have the same shape (nothing is broadcast): {described}")
    return next(iter(shapes.values()))


def common_runs(sizes: Mapping[str, int | None], *, broadcast_one: bool = False) -> int | None:
    """The number of runs ``M`` shared by the inputs of one call that carry a leading runs axis.

    ``sizes`` maps each input's name to the length of its runs axis, or to ``None`` where the input has none (one
    value shared by every run). The inputs that have one must agree; the result is ``None`` when none has one.
    With ``broadcast_one``, a runs axis of length 1 stands for every run (it broadcasts, as in numpy) and ``M`` is
    the largest length.

    >>> common_runs({"x0": None, "z": 4})
    4
    >>> common_runs({"x0": 1, "z": 4}, broadcast_one=True)
    4
    >>> common_runs({"x0": 3, "z": 4})
    Traceback (most recent call last):
        ...
    ValueError: the inputs with a leading runs axis disagree on the number of runs M: x0 has 3, z has 4
    """
    given = {name: m for name, m in sizes.items() if m is not None}
    if not given:
        return None
    empty = [name for name, m in given.items() if m == 0]
    if empty:
        raise ValueError(f"{empty[0]} has no runs (a runs axis of length 0): give at least one run, or drop the "
                         "runs axis")
    distinct = set(given.values()) - ({1} if broadcast_one else set())
    if len(distinct) > 1:
        described = ", ".join(f"{name} has {m}" for name, m in given.items())
        raise ValueError(f"the inputs with a leading runs axis disagree on the number of runs M: {described}")
    return max(given.values())


def as_scalar(name: str, value: Any, *, domain: str = "finite", low: float | None = None,
              high: float | None = None) -> float:
    """One real number (a Python float): a one-element list or array is refused by name, not by numpy's
    "only 0-dimensional arrays can be converted" error.

    ``domain``: ``"finite"``, ``"positive"`` (> 0), ``"nonnegative"`` (>= 0) or ``"probability"`` (in (0, 1));
    ``low``/``high`` add inclusive bounds.

    >>> as_scalar("interval", [8.0])
    Traceback (most recent call last):
        ...
    ValueError: interval must be a single number; got an array of shape (1,) (write 8.0, not [8.0])
    """
    arr = as_float_array(name, value)
    if arr.ndim != 0:
        shown = f" (write {float(arr.flat[0])!r}, not [{float(arr.flat[0])!r}])" if arr.size == 1 else ""
        raise ValueError(f"{name} must be a single number; got an array of shape {arr.shape}{shown}")
    if domain == "positive":
        x = float(as_positive(name, arr))
    elif domain == "nonnegative":
        x = float(as_nonnegative(name, arr))
    elif domain == "probability":
        x = float(as_in_range(name, arr, 0.0, 1.0, closed=(False, False)))
    else:
        x = float(as_finite(name, arr))
    if low is not None and x < low:
        raise ValueError(f"{name} must be >= {low:g}; got {x:g}")
    if high is not None and x > high:
        raise ValueError(f"{name} must be <= {high:g}; got {x:g}")
    return x


# --- epochs, points and runs axes (the motion, ranging, scenario and dataset modules share them) ----------------

def readonly(arr: np.ndarray) -> np.ndarray:
    """A read-only view of ``arr``: frozen dataclasses should not be changed through their arrays either."""
    view = arr.view()
    view.flags.writeable = False
    return view


def as_times(name: str, value: Any) -> np.ndarray:
    """Epoch times: a finite 1-D array with at least one element, strictly increasing."""
    t = as_finite(name, value, ndim=1)
    if t.size == 0:
        raise ValueError(f"{name} must hold at least one time")
    steps = np.diff(t)
    if np.any(steps <= 0):
        k = int(np.argmax(steps <= 0)) + 1
        raise ValueError(f"{name} must be strictly increasing; {name}[{k}] = {t[k]:g} follows {t[k - 1]:g}")
    return t


def as_point(name: str, value: Any) -> np.ndarray:
    """A 2-D point or vector, shape ``(2,)``."""
    return as_finite(name, value, shape=(2,))


def as_n_runs(n_runs: Any) -> int | None:
    """``None`` (no runs axis) or a number of Monte Carlo runs >= 1."""
    return None if n_runs is None else as_int("n_runs", n_runs, minimum=1)


def with_runs(name: str, arr: np.ndarray, n_runs: int | None, core_ndim: int) -> tuple[np.ndarray, bool]:
    """Give ``arr`` (one run: ``core_ndim`` axes; a batch: one more) a leading runs axis.

    Returns the batched array (possibly a broadcast view) and whether the caller should drop the runs axis again
    (single-run input and ``n_runs is None``).
    """
    if arr.ndim == core_ndim:
        m = 1 if n_runs is None else n_runs
        return np.broadcast_to(arr, (m,) + arr.shape), n_runs is None
    if arr.ndim == core_ndim + 1:
        if n_runs is not None and arr.shape[0] != n_runs:
            raise ValueError(f"{name} holds {arr.shape[0]} runs along its first axis but n_runs={n_runs}; "
                             "pass n_runs=None to keep the runs of the input")
        return arr, False
    raise ValueError(f"{name} must have {core_ndim} dimension(s) (one run) or {core_ndim + 1} (a batch of runs); "
                     f"got shape {arr.shape}")


def as_points(name: str, value: Any, *, min_ndim: int = 1, nonempty: bool = False) -> np.ndarray:
    """2-D points ``[x, y]`` on the last axis, finite and within ``MAX_COORDINATE``; at least ``min_ndim`` axes
    (and no empty axis when ``nonempty``; otherwise the caller says what an empty set of points means)."""
    p = as_finite(name, value, max_abs=MAX_COORDINATE, nonempty=nonempty)
    if p.ndim < max(min_ndim, 1) or p.shape[-1] != 2:
        want = "(2,)" if min_ndim <= 1 else "(N, 2)"
        raise ValueError(f"{name} must hold 2-D points [x, y] on its last axis, e.g. shape {want}; got shape "
                         f"{p.shape}")
    return p


def as_position_function(name: str, value: Any) -> Any:
    """A callable ``t -> (..., 2)`` (its output checked at each call) or a fixed ``(2,)`` position, as such a
    callable."""
    if callable(value):
        def at(t: np.ndarray) -> np.ndarray:
            return as_points(f"the output of {name}", value(t), nonempty=True)
        return at
    fixed = as_finite(name, value, shape=(2,), max_abs=MAX_COORDINATE)
    return lambda t: np.broadcast_to(fixed, np.shape(t) + (2,))


def as_per_run_scalar(name: str, value: Any, *, minimum: float, strict: bool) -> tuple[Any, int | None]:
    r"""A scalar or one value per run (shape (M,)), finite and > (or >=) ``minimum``: ``(value, None)`` or
    ``(array, M)``. A strict one (a factor such as paper D's :math:`\mu_\gamma`) is also refused below 1e-3."""
    # the factor gamma ~ c / c_e is near 1: 1e3 is far beyond any sound-speed error and keeps mu^2 P finite
    arr = as_finite(name, value, ndim=(0, 1), max_abs=1e3, nonempty=True)
    bad = arr <= minimum if strict else arr < minimum
    if np.any(bad):
        rel = ">" if strict else ">="
        raise ValueError(f"{name} must be {rel} {minimum:g}; got {arr[bad].flat[0]:g}")
    if strict and np.any(arr < 1e-3):      # a factor near 0 (1e-300) empties the covariance: refused by name
        raise ValueError(f"{name} must be at least 1e-3 (the factor c / c_e is near 1; a tiny factor collapses the "
                         f"covariance); got {arr[arr < 1e-3].flat[0]:g}")
    if arr.ndim == 0:
        return float(arr), None
    return arr, arr.shape[0]


def as_choice(name: str, value: Any, options: Any) -> str:
    """One of the strings ``options`` (a list, not a value that merely compares equal; unhashables refused)."""
    choices = list(options)
    if not isinstance(value, str) or value not in choices:
        shown = _describe(value) if isinstance(value, (str, bytes)) else repr(value)
        raise ValueError(f"{name} must be one of {choices}; got {shown}")
    return value


def as_callable(name: str, value: Any, hint: str = "") -> Any:
    """``value`` if it is callable; a :class:`TypeError` naming the argument otherwise."""
    if not callable(value):
        raise TypeError(f"{name} must be a function{(' (' + hint + ')') if hint else ''}; got "
                        f"{_describe(value) if isinstance(value, str) else type(value).__name__}")
    return value


def as_bool_array(name: str, value: Any, shapes: tuple[tuple[int, ...], ...]) -> np.ndarray:
    """A decision returned by user code (a gate's verdict, a model's "defined" mask): bools only, of one of
    ``shapes``. A float such as 0.3 is refused instead of counting as True.
    """
    arr = np.asarray(value)
    if arr.dtype.kind != "b":
        raise TypeError(f"{name} must return bools (True/False), not dtype {arr.dtype}"
                        + (f" (e.g. {arr.flat[0]!r})" if arr.size else "")
                        + ": return a comparison such as `nis <= threshold`")
    if arr.shape not in shapes:
        want = " or ".join(str(s) for s in shapes)
        raise ValueError(f"{name} must return a bool array of shape {want}; got {arr.shape}")
    return arr


def as_model_output(owner: str, value: Any) -> np.ndarray:
    """What a user's model returned (``f``, ``h``, ``Q``, ``R``, a log-likelihood), as a float array: real numbers
    only -- a complex value is refused, not cut to its real part; a string or an object by name, not by numpy's
    conversion error. ``owner`` says whose value it is (``"the model's F"``, ``"DeadReckoning.Q"``). Every filter
    family (the EKF engine, the particle filters, the models' own ``sample``) reads model outputs through it."""
    arr = np.asarray(value)
    kind = arr.dtype.kind
    if kind == "O":                                  # numbers held as objects: converted when they all are real
        for v in arr.flat:
            if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, float, np.integer, np.floating)):
                raise TypeError(f"{owner} must return real numbers; it returned {type(v).__name__} {v!r}")
        return arr.astype(float)
    if kind not in "fiu":
        raise TypeError(f"{owner} must return real numbers; got an array of dtype {arr.dtype}"
                        + (" (complex: its imaginary part would be dropped)" if kind == "c" else ""))
    return arr.astype(float, copy=False)


class CovarianceCheck:
    """Checks a covariance returned by a user's model (real, symmetric PSD: :func:`check_model_covariance`) once per
    distinct array: a model that returns the same Q at every step pays for one eigendecomposition, not one per step.
    A library model whose covariances are checked when it is made (``covariances_checked``) is not checked again at
    each step -- unless a subclass of yours overrides the method, whose values are then checked like any user
    model's."""

    def __init__(self, name: str, model: Any = None, method: str = "") -> None:
        self.name = name
        self._seen: np.ndarray | None = None
        own = getattr(type(model), method, None)
        self._trusted = bool(getattr(model, "covariances_checked", False)) and own is not None and \
            getattr(own, "__module__", "").startswith("uwtutor.")

    def __call__(self, value: np.ndarray) -> None:
        if self._trusted or value is self._seen:
            return
        check_model_covariance(self.name, value)
        self._seen = value


def check_model_covariance(name: str, value: np.ndarray) -> None:
    """A covariance a user's model returned (``Q``, ``R``): real, finite, symmetric and positive semi-definite,
    matrix by matrix; the error names the model method (``name``) rather than the filter's own arguments."""
    C = as_model_output(name, value)
    if C.ndim < 2 or C.shape[-1] != C.shape[-2]:
        raise ValueError(f"{name} returned an array of shape {C.shape}, not a square matrix")
    if not np.isfinite(C).all():
        raise ValueError(f"{name} returned a non-finite value")
    scale = max(1.0, float(np.max(np.abs(C)))) if C.size else 1.0
    if not np.allclose(C, np.swapaxes(C, -1, -2), rtol=SYMMETRY_RTOL, atol=1e-12 * scale):
        raise ValueError(f"{name} returned a matrix that is not symmetric; return (Q + Q.T) / 2 if it is only off "
                         "by rounding")
    eig_min = float(np.linalg.eigvalsh(C).min())
    if eig_min < -PSD_RTOL * scale * 1e3:
        raise ValueError(f"{name} returned a matrix that is not positive semi-definite (smallest eigenvalue "
                         f"{eig_min:.3g}): a covariance has variances >= 0 and correlations within [-1, 1]")


#: Most float64 values an input may ask a function to allocate (8e8 bytes); beyond it use chunks (montecarlo).
MAX_WORK = 10**8


def check_work(name: str, n_values: Any, what: str = "values") -> None:
    """Refuse a count whose work (``n_values`` floats) exceeds :data:`MAX_WORK`, with the fix, before numpy's
    MemoryError or an endless run."""
    if n_values > MAX_WORK:
        raise ValueError(f"{name} asks for {float(n_values):.3g} {what} (above {MAX_WORK:.0e}, about "
                         f"{8 * MAX_WORK / 1e9:.1f} GB): use fewer, or run them in chunks "
                         "(uwtutor.montecarlo)")


def check_finite_result(result: Any, *names: str, what: str = "the result") -> Any:
    """Refuse a computed result that overflowed (inf) or became NaN from finite inputs, naming the inputs that
    caused it: an overflow is an input in the wrong units, never a silent ``inf``.

    >>> with np.errstate(over="ignore"):
    ...     r = np.array([1e308]) * 10
    >>> check_finite_result(  # doctest: +ELLIPSIS
    ...     r, "travel_time", "sound_speed", what="the range"
    ... )
    Traceback (most recent call last):
        ...
    ValueError: the range overflows float64 for these travel_time and sound_speed (...): change their units
    """
    if not np.all(np.isfinite(result)):
        raise ValueError(f"{what} overflows float64 for these {' and '.join(names)} (a value beyond 1.8e308): change "
                         "their units")
    return result
