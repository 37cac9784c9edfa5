"""Every public callable of ``uwtutor`` has a running example in its docstring (issue 27).

The targets are those of the robustness contract (``robustness_discovery.discover``: every function and class of
every ``__all__``, found by walking the package, so a new public name is covered the day it is added). A docstring
example is a ``>>>`` line, which ``make test`` runs (``--doctest-modules uwtutor``); a class may carry it in its
own docstring or in its constructor's.

``tests/examples_pending.txt`` lists the callables still without one (the chapter-specific exercise checkers
and widget factories, whose running examples are the chapters' notebooks that nbval re-runs). The list may
only shrink: an entry that gains an example, or disappears, must be removed.
"""

from __future__ import annotations

import inspect
import pathlib

import robustness_discovery as disc

PENDING_FILE = pathlib.Path(__file__).with_name("examples_pending.txt")


def _pending() -> set[str]:
    return {line.strip() for line in PENDING_FILE.read_text().splitlines()
            if line.strip() and not line.startswith("#")}


def has_example(obj) -> bool:
    """Whether the docstring of ``obj`` (or, for a class, of its ``__init__``) holds a doctest line."""
    docs = [inspect.getdoc(obj) or ""]
    if inspect.isclass(obj):
        docs.append(inspect.getdoc(obj.__init__) or "" if "__init__" in vars(obj) else "")
    return any(">>>" in doc for doc in docs)


TARGETS = disc.discover()


def test_every_public_callable_has_a_running_example():
    missing = sorted(k for k, obj in TARGETS.items() if not has_example(obj) and k not in _pending())
    assert not missing, ("public callables without a docstring example (add an Examples section whose lines run as "
                         "doctests):\n  " + "\n  ".join(missing))


def test_pending_examples_list_only_shrinks():
    pending = _pending()
    gone = sorted(pending - set(TARGETS))
    assert not gone, "remove from tests/examples_pending.txt (no longer public): " + ", ".join(gone)
    done = sorted(k for k in pending if k in TARGETS and has_example(TARGETS[k]))
    assert not done, "these have an example now: remove them from tests/examples_pending.txt: " + ", ".join(done)


def test_the_check_sees_a_missing_example():
    def documented():
        """Twice x.

        >>> documented()
        """

    def undocumented():
        """Twice x, with no example."""

    assert has_example(documented) and not has_example(undocumented)
