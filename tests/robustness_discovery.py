"""Discovery of the public surface of ``uwtutor`` for the robustness contract (issue 26).

Every module and subpackage of ``uwtutor`` is imported (``pkgutil.walk_packages``) and every name of its
``__all__`` that is a function or a class is a *target*. A target is identified by where it is defined
(``module:qualname``), so a function re-exported by a package (``uwtutor.filters.fading_ekf``) is one target.
Like scikit-learn's ``all_estimators``, nothing is listed by hand: a module added later is covered on the
day it is added, and a public callable without an entry in the specification table fails the contract.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
from types import ModuleType
from typing import Callable, Iterable

#: Modules whose ``__all__`` is not walked, each with its reason.
SKIPPED_MODULES = {
    "uwtutor.__main__": "the command-line entry point (python -m uwtutor); its main() is tested in tests/test_cli*",
    "uwtutor._validate": "the validation layer itself (its helpers are tested in tests/test_validate.py; they "
                         "raise by design)",
}


def iter_modules(package: str = "uwtutor") -> Iterable[ModuleType]:
    """Import and yield the package and every module below it (sorted by name)."""
    root = importlib.import_module(package)
    yield root
    names = sorted(info.name for info in pkgutil.walk_packages(root.__path__, prefix=package + "."))
    for name in names:
        if name not in SKIPPED_MODULES:
            yield importlib.import_module(name)


def target_key(obj: Callable) -> str:
    """``module:qualname`` of where ``obj`` is defined (one key per function or class, whatever re-exports it)."""
    return f"{obj.__module__}:{obj.__qualname__}"


def discover(package: str = "uwtutor", modules: Iterable[ModuleType] | None = None) -> dict[str, Callable]:
    """Every public callable (function or class) of every ``__all__``, keyed by :func:`target_key`.

    Exceptions (warning classes, constants) are not callables of the API: classes deriving from
    ``BaseException`` are left out (they are raised, not called with user data).
    """
    found: dict[str, Callable] = {}
    for module in (iter_modules(package) if modules is None else modules):
        if module.__name__ in SKIPPED_MODULES:
            continue
        for name in getattr(module, "__all__", ()):
            obj = getattr(module, name)
            if not (inspect.isfunction(obj) or inspect.isclass(obj) or inspect.isbuiltin(obj)):
                continue
            if inspect.isclass(obj) and issubclass(obj, BaseException):
                continue
            if not getattr(obj, "__module__", "").startswith(package) and modules is None:
                continue          # a name re-exported from numpy/scipy is not ours to specify
            found.setdefault(target_key(obj), obj)
    return dict(sorted(found.items()))
