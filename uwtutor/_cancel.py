"""Cooperative cancellation of a long computation that runs in a background thread.

A widget computes a setting's full answer in a worker thread while the reader already looks at a coarse picture
(``uwtutor.widgets._panel.slider_panel``'s ``refine``). When the reader moves on, that answer is no longer wanted,
but a Python thread cannot be stopped from outside, and while it runs it takes turns with the reader's next coarse
picture for the interpreter (the GIL): the next picture comes late. So the library's long loops -- the steps of a
filter run -- call :func:`checkpoint` once per step or per block of steps; inside :func:`cancel_when` in that thread,
the checkpoint asks the test given there and raises :class:`Cancelled` once it says the work is no longer wanted.
Everywhere else (the book, the tests, a script, the widget's own thread) the checkpoint reads one thread-local
attribute and returns: a few tens of nanoseconds, against tens of microseconds for a filter step, and it changes
no number.

A cancelled computation leaves nothing half done behind it as long as it keeps its results only once they are
complete (``functools.lru_cache`` does; so does a dict filled after the call). A filter *object* run in that
thread is left at the step it reached, as after a ``KeyboardInterrupt``: the library functions that make their
own filter (``bias_ekf``, ``robust_range_kf``, ...) leave nothing behind.
"""

from __future__ import annotations

import contextlib
import threading
from typing import Callable, Iterator

__all__ = ["Cancelled", "cancel_when", "checkpoint"]


class Cancelled(BaseException):
    """The computation was cancelled at a :func:`checkpoint` (its result is no longer wanted).

    A ``BaseException``, as ``KeyboardInterrupt`` is, so that the library's ``except Exception`` fallbacks (which
    would start the work again by a slower path) let it through to the one who asked for the cancellation.
    """


class _ThreadState(threading.local):
    #: The test of the innermost ``cancel_when`` in this thread (None: no cancellation here).
    wanted_no_more: Callable[[], bool] | None = None


_state = _ThreadState()


def checkpoint() -> None:
    """Raise :class:`Cancelled` if this thread runs inside :func:`cancel_when` and its test says stop; else return.

    Called by the library's long loops between steps (or blocks of steps), where stopping leaves no half-made
    result outside the loop's own arrays. Outside ``cancel_when`` it only reads a thread-local attribute.

    Examples
    --------
    >>> checkpoint()                        # no cancellation asked for in this thread: returns at once
    >>> with cancel_when(lambda: True):
    ...     try:
    ...         checkpoint()
    ...     except Cancelled:
    ...         print("cancelled")
    cancelled
    """
    test = _state.wanted_no_more
    if test is not None and test():
        raise Cancelled


def cancel_when(test: Callable[[], bool]) -> contextlib.AbstractContextManager[None]:
    """Within the block, in this thread, every :func:`checkpoint` raises :class:`Cancelled` once ``test()`` is true.

    Parameters
    ----------
    test : callable
        ``test()`` returns True when the computation's result is no longer wanted. It is called at every
        checkpoint (up to several thousand times per second of filtering), so it should be cheap: read a flag or
        compare two counters. Other threads are not affected; blocks nest (the inner test applies inside).

    Examples
    --------
    >>> import threading
    >>> stop = threading.Event()
    >>> def long_loop():
    ...     for step in range(1000):
    ...         checkpoint()
    ...         if step == 10:
    ...             stop.set()          # another thread would do this: the reader moved on
    ...     return "done"
    >>> try:
    ...     with cancel_when(stop.is_set):
    ...         long_loop()
    ... except Cancelled:
    ...     print("stopped early")
    stopped early
    >>> long_loop()                     # outside the block, nothing stops it
    'done'
    """
    if not callable(test):
        raise TypeError(f"test must be a callable returning True when the work is no longer wanted; got {test!r}")
    return _cancelling(test)


@contextlib.contextmanager
def _cancelling(test: Callable[[], bool]) -> Iterator[None]:
    outer = _state.wanted_no_more
    _state.wanted_no_more = test
    try:
        yield
    finally:
        _state.wanted_no_more = outer
