"""Argument kinds, the hostile values each kind generates, and the judge of one hostile call (issue 26).

A *kind* says what an argument is (an array of coordinates, a positive scalar, an rng, a seed, a string choice, a
callable, a model object, a bool, a student's answer...). From the kind alone come the hostile values: each is a
:class:`Hostile` with a label, the value, and whether it **must be refused** (NaN where no missing value is meant,
a string, a complex number, a negative standard deviation...) or **may be accepted** provided the answer stays
valid (1e300 coordinates, a tiny variance, a negative coordinate).

The rule (:func:`judge`), for every hostile call:

* a ``ValueError``/``TypeError`` (or subclass: ``IllConditionedError``, ``LookupError`` for choices) whose message
  names the argument -> **ok**;
* any other exception, or a message that does not name the argument -> **obscure**;
* a ``BaseException`` that is not an ``Exception`` (``SystemExit``, a checker's ``StudentTimeout``...) or a call
  still running after the time limit -> **escape**;
* an answer for a must-refuse value (an ignored, coerced or truncated argument), or an answer with a NaN/infinity
  where the valid call's answer had none, or a covariance that is not symmetric PSD -> **silent**.
"""

from __future__ import annotations

import _thread
import copy
import dataclasses
import math
import threading
import time
import zlib
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np

#: Seconds of CPU time one call may use before it counts as a hang (the valid calls take milliseconds to a few
#: seconds of CPU; a student's endless loop is stopped by the checkers' own, shorter limit). CPU time, not wall time:
#: the verdict must not depend on how busy the machine is (see ``call_with_limit``).
CALL_LIMIT = 10.0
#: Hostile values tried per argument (a deterministic sample of the kind's list; the must-refuse ones first).
PER_ARGUMENT = 6


@dataclass(frozen=True)
class Hostile:
    label: str
    value: Any
    must_refuse: bool
    #: one of the classes of defect every argument is tried with (not left to the sample): an overflow, an empty
    #: batch, a column where a vector is meant, a scalar given as a one-element list or 2-D array, unbounded work
    always: bool = False


#: The labels tried on every argument whatever the sample (see ``Hostile.always``).
ALWAYS = ("huge", "beyond the coordinate bound", "empty", "extra axis", "one-element list", "one-element 2-D array",
          "10**12")


class _NoFloat:
    def __float__(self):
        raise RuntimeError("no float")

    def __repr__(self) -> str:
        return "<object without __float__>"


class _NoArray:
    """An answer numpy cannot read: its ``__array__`` raises (a checker must explain it, never crash on it)."""

    def __array__(self, *args, **kwargs):
        raise RuntimeError("no array")

    def __repr__(self) -> str:
        return "<object whose __array__ raises>"


def _pick(key: str, values: Sequence[Hostile], k: int) -> list[Hostile]:
    """The values of the defect classes every argument is tried with (``ALWAYS``), and a deterministic sample of
    ``k`` of the others (seeded by ``key``; the order does not depend on Python's hash seed)."""
    always = [h for h in values if h.always or h.label in ALWAYS]
    rest = [h for h in values if not (h.always or h.label in ALWAYS)]
    if len(rest) <= k:
        return always + rest
    start = zlib.crc32(key.encode()) % len(rest)
    rotated = rest[start:] + rest[:start]
    return always + rotated[:k]


# --- kinds ----------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Kind:
    """Base kind: no hostile value (an argument the contract does not mutate, e.g. an ``out=`` buffer)."""

    def hostile(self, valid: Any) -> list[Hostile]:
        return []


def _type_attacks(scalar: bool) -> list[Hostile]:
    out = [Hostile("string", "abc", True), Hostile("numeric string", "1.5", True),
           Hostile("complex", 1.0 + 2.0j, True), Hostile("None", None, True),
           Hostile("bool", True, True), Hostile("object", object(), True),
           Hostile("no __float__", _NoFloat(), True), Hostile("10**400", 10**400, True),
           Hostile("dict", {"a": 1}, True)]
    return out


@dataclass(frozen=True)
class Real(Kind):
    """Real numbers: a scalar (``shape=()``) or an array of a given shape (``None`` for any length).

    ``domain``: ``"any"`` (coordinates), ``"nonneg"``, ``"pos"``, ``"prob"`` (in [0, 1]), ``"open01"`` ((0, 1)).
    ``nan_ok``: NaN is a documented value (a missing range). ``huge_ok``: values like 1e300 may be accepted
    (they must then give a finite answer or a clear refusal).
    """
    shape: tuple | None = ()
    domain: str = "any"
    nan_ok: bool = False
    inf_ok: bool = False         # +inf is a documented value (e.g. sigma = inf: no range at that epoch)
    vector_ok: bool = False      # a scalar argument that also takes an array (vectorized functions)
    extra_axis_ok: bool = False  # (K,) and (K, 1) both valid (a measurement of size 1)
    optional: bool = False       # None is the documented default

    def hostile(self, valid: Any) -> list[Hostile]:
        arr = np.asarray(valid, dtype=float)
        out = [h for h in _type_attacks(arr.ndim == 0) if not (self.optional and h.value is None)]

        def like(x: float) -> Any:
            if arr.ndim == 0:
                return x
            a = np.array(arr, dtype=float)
            a.flat[0] = x
            return a
        out += [Hostile("nan", like(math.nan), not self.nan_ok), Hostile("inf", like(math.inf), not self.inf_ok),
                Hostile("-inf", like(-math.inf), not self.inf_ok),
                Hostile("huge", like(1e300), False), Hostile("tiny", like(1e-300), False),
                # squares overflow float64 (1e400): refused by the coordinate bound or computed without overflow
                Hostile("beyond the coordinate bound", like(1e200), False)]
        if self.domain in ("nonneg", "pos", "prob", "open01"):
            out.append(Hostile("negative", like(-1.0), True))
        if self.domain in ("pos", "open01"):
            out.append(Hostile("zero", like(0.0), True))
        if self.domain in ("prob", "open01"):
            out.append(Hostile("above one", like(1.5), True))
        if arr.ndim == 0:
            out.append(Hostile("one-element list", [float(arr)], False))
            out.append(Hostile("one-element 2-D array", np.array([[float(arr)]]), False))
            out.append(Hostile("array", np.array([float(arr), float(arr)]), not self.vector_ok))
        else:
            out.append(Hostile("list with None", _with_none(arr).tolist(), True))
            out.append(Hostile("object array with None", _with_none(arr), True))
            out.append(Hostile("complex array", arr.astype(complex) + 1j, True))
            out.append(Hostile("string array", arr.astype(str), True))
            out.append(Hostile("empty", np.zeros((0,) + arr.shape[1:]), True))
            if self.shape is not None and all(s is not None for s in self.shape):
                out.append(Hostile("one extra row", np.concatenate([arr, arr[:1]]), True))
            out.append(Hostile("extra axis", arr[..., None], not self.extra_axis_ok))
        return out


def _with_none(arr: np.ndarray) -> np.ndarray:
    obj = arr.astype(object)
    obj.flat[0] = None
    return obj


@dataclass(frozen=True)
class Covariance(Kind):
    """A symmetric PSD matrix (``definite``: positive definite); its hostile values break symmetry and PSD."""
    definite: bool = False
    inf_ok: bool = False        # an infinite variance is a documented value (an unobservable direction)
    any_size: bool = False      # the function takes any n x n (e.g. reads the position block)
    optional: bool = False      # None is the documented default

    def hostile(self, valid: Any) -> list[Hostile]:
        P = np.atleast_2d(np.asarray(valid, dtype=float))
        n = P.shape[-1]
        out = [h for h in _type_attacks(False) if not (self.optional and h.value is None)]
        bad = np.array(P, dtype=float)
        bad[..., 0, 0] = -abs(bad[..., 0, 0]) - 1.0
        out.append(Hostile("indefinite", bad, True))
        if n > 1:
            ns = np.array(P, dtype=float)
            ns[..., 0, 1] += 1.0
            out.append(Hostile("non-symmetric", ns, True))
        out += [Hostile("nan", np.full_like(P, math.nan), True),
                Hostile("inf", np.full_like(P, math.inf), not self.inf_ok),
                Hostile("huge", P * 1e300, False), Hostile("tiny", P * 1e-300, False),
                Hostile("wrong size", np.eye(n + 1), not self.any_size), Hostile("complex", P.astype(complex), True),
                Hostile("negative definite", -np.eye(n), True)]
        if self.definite:
            out.append(Hostile("zero", np.zeros_like(P), True))
        return out


@dataclass(frozen=True)
class Int(Kind):
    minimum: int | None = None
    maximum: int | None = None
    #: an upper bound on the work the count implies: 10**12 must be refused (or answer quickly)
    unbounded_work: bool = False

    def hostile(self, valid: Any) -> list[Hostile]:
        out = [Hostile("float", 1.5, True), Hostile("string", "3", True), Hostile("bool", True, True),
               Hostile("None", None, True), Hostile("complex", 1 + 1j, True), Hostile("nan", math.nan, True),
               Hostile("one-element list", [valid], True)]
        if self.minimum is not None:
            out.append(Hostile("below minimum", self.minimum - 1, True))
        if self.maximum is not None:
            out.append(Hostile("above maximum", self.maximum + 1, True))
        if self.unbounded_work:
            out.append(Hostile("10**12", 10**12, True))
        return out


@dataclass(frozen=True)
class Rng(Kind):
    def hostile(self, valid: Any) -> list[Hostile]:
        return [Hostile("None", None, True), Hostile("int seed", 42, True),
                Hostile("RandomState", np.random.RandomState(0), True), Hostile("string", "abc", True),
                Hostile("numpy module", np.random, True)]


@dataclass(frozen=True)
class Seed(Kind):
    def hostile(self, valid: Any) -> list[Hostile]:
        return [Hostile("None (OS entropy)", None, True), Hostile("negative", -1, True), Hostile("float", 1.5, True),
                Hostile("string", "42", True), Hostile("bool", True, True),
                Hostile("Generator", np.random.default_rng(0), True)]


@dataclass(frozen=True)
class Choice(Kind):
    options: tuple = ()

    def hostile(self, valid: Any) -> list[Hostile]:
        return [Hostile("unknown name", "no-such-choice", True), Hostile("int", 1, True), Hostile("None", None, True),
                Hostile("list", [valid], True), Hostile("bytes", str(valid).encode(), True)]


@dataclass(frozen=True)
class Flag(Kind):
    def hostile(self, valid: Any) -> list[Hostile]:
        return [Hostile("string 'False'", "False", True), Hostile("int 0", 0, True), Hostile("None", None, True),
                Hostile("float 1.0", 1.0, True), Hostile("array", np.array([True, False]), True)]


@dataclass(frozen=True)
class Func(Kind):
    def hostile(self, valid: Any) -> list[Hostile]:
        return [Hostile("int", 42, True), Hostile("string", "abc", True), Hostile("None", None, True)]


@dataclass(frozen=True)
class Instance(Kind):
    """A library object (a model, a result, parameters): hostile values of the wrong type."""
    optional: bool = False

    def hostile(self, valid: Any) -> list[Hostile]:
        out = [Hostile("object", object(), True), Hostile("string", "abc", True), Hostile("int", 1, True)]
        if not self.optional:
            out.append(Hostile("None", None, True))
        return out


# --- a user's model whose outputs are hostile (the filters must check what a model returns, not only what a user
# passes them) ---------------------------------------------------------------------------------------------------

def _complex(a: np.ndarray) -> np.ndarray:
    return a.astype(complex) + 1e-3j


def _with_nan(a: np.ndarray) -> np.ndarray:
    b = np.array(a, dtype=float)
    b.flat[0] = math.nan
    return b


def _short(a: np.ndarray) -> np.ndarray:
    return a[..., :-1]


def _indefinite(C: np.ndarray) -> np.ndarray:
    b = np.array(C, dtype=float)
    b[..., 0, 0] = -abs(b[..., 0, 0]) - 1.0
    return b


def _non_symmetric(C: np.ndarray) -> np.ndarray:
    b = np.array(C, dtype=float)
    b[..., 0, -1] += 1.0 + abs(b[..., 0, -1])
    return b


def _one_size_too_big(C: np.ndarray) -> np.ndarray:
    n = C.shape[-1]
    b = np.zeros(C.shape[:-2] + (n + 1, n + 1))
    b[..., :n, :n] = C
    b[..., n, n] = 1.0
    return b


_VECTOR_ATTACKS = (("complex", _complex), ("NaN", _with_nan), ("one component short", _short))
_COVARIANCE_ATTACKS = (("complex", _complex), ("indefinite", _indefinite), ("non-symmetric", _non_symmetric),
                       ("one size too big", _one_size_too_big), ("NaN", _with_nan))


def corrupted_model(model: Any, method: str, corrupt: Callable[[np.ndarray], np.ndarray]) -> Any:
    """A copy of ``model`` whose ``method`` returns ``corrupt(what the model returned)``: a user's subclass with a
    bug in one method (its class is defined here, so no filter trusts it as a library model)."""
    cls = type(model)
    original = getattr(cls, method)

    def hostile_method(self, *args, **kwargs):
        return corrupt(np.asarray(original(self, *args, **kwargs)))
    hostile_cls = type(f"Hostile{cls.__name__}", (cls,), {method: hostile_method, "__module__": __name__})
    new = copy.copy(model)
    new.__dict__.pop("_covariance_checks", None)        # checks made for the original model are not this one's
    new.__class__ = hostile_cls
    return new


@dataclass(frozen=True)
class Model(Kind):
    """A motion or measurement model of ``uwtutor.models`` (or a list of motion models, one per mode): its hostile
    values are the wrong types, and the valid model with one method returning a complex, NaN, wrong-shaped, or
    (for ``Q``/``R``) indefinite or non-symmetric value -- a filter must refuse each by name, never run on it.

    ``likelihood``: the target weighs by the model's ``log_likelihood`` (a particle filter), so it is attacked too.
    """
    optional: bool = False
    likelihood: bool = False
    #: the target draws particles with the motion model's ``sample`` (a particle filter), not ``f`` and ``Q`` alone
    sampled: bool = False

    def hostile(self, valid: Any) -> list[Hostile]:
        from uwtutor.models.base import MeasurementModel, MotionModel
        out = [Hostile("object", object(), True), Hostile("string", "abc", True)]
        if not self.optional:
            out.append(Hostile("None", None, True))
        if isinstance(valid, (list, tuple)) and valid:              # modes: the first one is a user's buggy model
            return out + [Hostile(f"mode 0: {h.label}", [h.value, *valid[1:]], True)
                          for h in self.hostile(valid[0]) if h.label.startswith(("f ", "Q ", "sample "))]

        def covariance_attacks(size: int) -> tuple:
            return tuple(a for a in _COVARIANCE_ATTACKS if size > 1 or a[0] != "non-symmetric")
        if isinstance(valid, MotionModel):
            if self.sampled and type(valid).sample is not MotionModel.sample:     # the model draws its own way
                methods = {"sample": _VECTOR_ATTACKS}
            else:
                methods = {"f": _VECTOR_ATTACKS, "Q": covariance_attacks(valid.n)}
        elif isinstance(valid, MeasurementModel):
            methods = {"h": _VECTOR_ATTACKS, "R": covariance_attacks(valid.m)}
            if self.likelihood:
                methods["log_likelihood"] = _VECTOR_ATTACKS
        else:
            return out
        for method, attacks in methods.items():
            for label, corrupt in attacks:
                out.append(Hostile(f"{method} returns {label}", corrupted_model(valid, method, corrupt), True))
        return out


@dataclass(frozen=True)
class Mapping(Kind):
    """A dict of options (``per_run``, ``range_options``): unknown keys and wrong-length values."""
    entries: dict = field(default_factory=dict)

    def hostile(self, valid: Any) -> list[Hostile]:
        out = [Hostile("unknown key", {"no_such_option": 1.0}, True), Hostile("string", "abc", True),
               Hostile("list", [1, 2], True)]
        for key, wrong in self.entries.items():
            out.append(Hostile(f"{key}: {wrong!r}", {key: wrong}, True))
        return out


# --- student answers and student code (exercise checkers) -------------------------------------------------------------
@dataclass(frozen=True)
class Answer(Kind):
    """A student's answer to a checker: any Python object. The checker must return a Feedback that is not
    "correct" (complex and strings are refused with a teaching message), never raise, never hang."""

    def hostile(self, valid: Any) -> list[Hostile]:
        return [Hostile(lbl, val, True) for lbl, val in [
            ("string", "abc"), ("numeric string", "1.5"), ("complex", 1 + 2j), ("complex array", np.ones(3) + 1j),
            ("list with None", [1.0, None]), ("object", object()), ("no __float__", _NoFloat()),
            ("nan", math.nan), ("inf", math.inf), ("10**400", 10**400), ("ragged", [[1.0, 2.0], [3.0]]),
            ("dict", {"a": 1}), ("function", len), ("bool", True), ("empty", np.zeros(0)),
            ("string array", np.array(["1", "2"])), ("huge", 1e300), ("object array", np.array([1, "a"], object)),
            ("unreadable __array__", _NoArray()), ("tuple of ragged arrays", (np.ones(2), np.ones(3))),
        ]]


def _loops(*args, **kwargs):
    while True:
        pass


def _exits(*args, **kwargs):
    import sys
    sys.exit(3)


def _returns_string(*args, **kwargs):
    return "abc"


def _returns_complex(*args, **kwargs):
    return np.ones(4) + 1j


def _raises(*args, **kwargs):
    raise ValueError("student bug")


def _returns_none(*args, **kwargs):
    return None


@dataclass(frozen=True)
class StudentFunc(Kind):
    """A student's function given to a checker: endless loops, ``sys.exit()``, strings, complex, exceptions.

    ``returns_ok``: a runner (not a judge) may hand back whatever the function returned."""
    returns_ok: bool = False

    def hostile(self, valid: Any) -> list[Hostile]:
        return [Hostile(f.__name__.lstrip("_"), f, not (self.returns_ok and f.__name__.startswith("_returns")))
                for f in (_loops, _exits, _returns_string, _returns_complex, _raises, _returns_none)] + \
               [Hostile("not callable", 42, True)]


# --- running one call and judging it --------------------------------------------------------------------------------
class CallTimeout(Exception):
    pass


#: A call that uses no CPU for this many times its CPU limit (a deadlock, a sleep) also counts as a hang.
WALL_BACKSTOP_FACTOR = 60.0
#: How often the watchdog reads the process's CPU clock [s].
_POLL = 0.05


def call_with_limit(fn: Callable[[], Any], seconds: float = CALL_LIMIT) -> tuple[str, Any]:
    """Run ``fn()``; return ``("ok", value)``, ``("raised", exc)``, ``("escaped", exc)`` or ``("hung", None)``.

    A hang is judged by **CPU time**, not by the clock on the wall: a watchdog thread reads the CPU time of this
    process (``time.process_time``) and interrupts the main thread (``_thread.interrupt_main``, which stops any
    Python loop without touching SIGALRM, the checkers' own time limit) once the call has used ``seconds`` of it.
    On a busy machine the call gets less of the CPU and takes longer on the wall, but it uses the same CPU time, so
    the verdict does not depend on the machine's load. A call that uses no CPU at all (a sleep, a deadlock) is
    stopped after ``WALL_BACKSTOP_FACTOR * seconds`` on the wall.
    """
    fired = threading.Event()
    done = threading.Event()
    cpu_start, wall_start = time.process_time(), time.monotonic()

    def _watch():
        while not done.wait(_POLL):
            if (time.process_time() - cpu_start > seconds
                    or time.monotonic() - wall_start > WALL_BACKSTOP_FACTOR * seconds):
                fired.set()
                _thread.interrupt_main()
                return
    watchdog = threading.Thread(target=_watch, daemon=True)
    watchdog.start()
    try:
        try:
            value = fn()
        finally:
            done.set()
            watchdog.join()
    except KeyboardInterrupt as exc:
        if fired.is_set():
            return "hung", None
        return "escaped", exc
    except Exception as exc:                     # noqa: BLE001 - judged by the caller
        return "raised", exc
    except BaseException as exc:                 # noqa: BLE001 - SystemExit and friends escaping a library call
        return "escaped", exc
    if fired.is_set():
        return "hung", None
    return "ok", value


def _leaves(obj: Any, path: str = "", depth: int = 0):
    """Numeric leaves of an answer: arrays and numbers inside tuples, lists, dicts and dataclasses."""
    if depth > 4:
        return
    if isinstance(obj, (bool, np.bool_, str, bytes)) or obj is None:
        return
    if isinstance(obj, np.ndarray):
        if obj.dtype.kind in "fc":
            yield path, obj
        return
    if isinstance(obj, (float, np.floating, complex)):
        yield path, np.asarray(obj)
        return
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        for f in dataclasses.fields(obj):
            yield from _leaves(getattr(obj, f.name, None), f"{path}.{f.name}", depth + 1)
        return
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from _leaves(v, f"{path}[{k!r}]", depth + 1)
        return
    if isinstance(obj, (tuple, list)) and len(obj) < 50:
        for i, v in enumerate(obj):
            yield from _leaves(v, f"{path}[{i}]", depth + 1)


_COV_NAMES = ("P", "P_prior", "S", "covariance", "cov", "P_smoothed", "bound", "crlb")
#: Per-step values that are NaN by definition where a measurement is missing or rejected (predict only).
_MISSING_OK = ("y", "S", "innovations", "innovation_cov", "nis", "ranges", "['fading_numerator']",
               "['fading_denominator']")


def answer_problems(answer: Any, baseline: Any) -> list[str]:
    """What is invalid in ``answer`` compared with the valid call's ``baseline`` (empty list: valid)."""
    base = {p: a for p, a in _leaves(baseline)}
    problems = []
    for path, arr in _leaves(answer):
        if arr.dtype.kind == "c":
            problems.append(f"{path or 'answer'} is complex")
            continue
        nonfinite = ~np.isfinite(arr)
        if path.rsplit(".", 1)[-1] in _MISSING_OK:
            nonfinite = np.isinf(arr)
        if nonfinite.any():
            ref = base.get(path)
            ref_bad = (~np.isfinite(ref)).any() if isinstance(ref, np.ndarray) and ref.dtype.kind == "f" else False
            if not ref_bad:
                problems.append(f"{path or 'answer'} has {int(nonfinite.sum())} NaN/inf")
                continue
        name = path.rsplit(".", 1)[-1]
        if name in _COV_NAMES and arr.ndim >= 2 and arr.shape[-1] == arr.shape[-2] and np.all(np.isfinite(arr)):
            scale = max(1.0, float(np.max(np.abs(arr))))
            if not np.allclose(arr, np.swapaxes(arr, -1, -2), rtol=1e-9, atol=1e-9 * scale):
                problems.append(f"{path} is not symmetric")
            elif np.linalg.eigvalsh(arr).min() < -1e-9 * scale:
                problems.append(f"{path} is not positive semi-definite")
    return problems


@dataclass
class Verdict:
    target: str
    argument: str
    label: str
    outcome: str          # ok | silent | obscure | escape
    detail: str = ""

    def __str__(self) -> str:
        return f"{self.target}({self.argument}={self.label}): {self.outcome} -- {self.detail}"


ACCEPTED_ERRORS = (ValueError, TypeError, LookupError)


def judge(target: str, argument: str, hostile: Hostile, status: str, value: Any, baseline: Any,
          validate_answer: Callable[[Any, Any], list[str]] | None = None,
          names: Sequence[str] = ()) -> Verdict:
    """Apply the rule (module docstring) to one hostile call."""
    def v(outcome: str, detail: str = "") -> Verdict:
        return Verdict(target, argument, hostile.label, outcome, detail)
    if status == "hung":
        return v("escape", f"still running after {CALL_LIMIT:g} s of CPU time")
    if status == "escaped":
        return v("escape", f"{type(value).__name__} escaped")
    if status == "raised":
        exc = value
        text = str(exc)
        named = any(n in text for n in (argument, *names))
        if isinstance(exc, ACCEPTED_ERRORS) and named:
            return v("ok")
        return v("obscure", f"{type(exc).__name__}: {text[:160]}")
    problems = (validate_answer or answer_problems)(value, baseline)
    if problems:
        return v("silent", "; ".join(problems)[:200])
    if hostile.must_refuse:
        return v("silent", "accepted (an answer for a value that must be refused)")
    return v("ok")
