"""List the parameters of uwtutor's public API that are annotated ``Any`` (the honest type is usually narrower).

The public API is what each public module of the package (no part of its name starting with ``_``) exports in its
``__all__``: its functions, and for its classes
the constructor and the public methods the class defines itself (each callable counted once, in the module that
defines it, however many packages re-export it). A parameter counts when its annotation is ``Any`` (or ``Any |
None``, the same thing to a type checker); ``*args: Any`` and ``**kwargs: Any`` are not counted (arguments passed
on to another callable, whose own signature types them).

The exercises' checkers take a student's answer, which may be anything a student types: the parameters of the
``check_*`` functions of ``uwtutor.exercises``, and the answers their helpers take (a parameter named ``answer``;
the student's function that ``run_student`` runs), are counted apart, as answers, and not listed.

Usage::

    python tools/any_params.py            # the count, and every parameter annotated Any (module.callable(param))
    python tools/any_params.py --count    # the counts only
    python tools/any_params.py --write-pending   # rewrite tests/any_params_pending.txt (the ratchet's list)

``tests/test_any_params.py`` holds the list to ``tests/any_params_pending.txt``: a new parameter annotated Any fails
(give it its type), and so does a listed one that no longer is (remove its line, or ``--write-pending``).
"""

from __future__ import annotations

import argparse
import importlib
import inspect
import pkgutil
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterator

REPO = Path(__file__).resolve().parents[1]
PENDING = REPO / "tests" / "any_params_pending.txt"
HEADER = ("# The public parameters of uwtutor annotated Any (tools/any_params.py), a ratchet\n"
          "# (tests/test_any_params.py): give a new parameter its type rather than adding it here; remove a line\n"
          "# when its parameter gets one.\n")
ANY = {"Any", "typing.Any", "Any | None", "None | Any", "Optional[Any]", "typing.Optional[typing.Any]"}


@dataclass
class Census:
    """Public parameters (``*args``/``**kwargs`` left out): all of them, those annotated Any, and the student
    answers among the latter."""

    total: int = 0
    any_params: list[str] = field(default_factory=list)
    answers: list[str] = field(default_factory=list)


def _is_any(annotation: Any) -> bool:
    if annotation is Any:
        return True
    return isinstance(annotation, str) and annotation.replace("typing.", "").strip() in ANY


def _modules(package: str = "uwtutor") -> Iterator[Any]:
    root = importlib.import_module(package)
    yield root
    for info in pkgutil.walk_packages(root.__path__, package + "."):
        if not any(part.startswith("_") for part in info.name.split(".")):       # a private module: not the API
            yield importlib.import_module(info.name)


def _public_callables(module: Any) -> Iterator[tuple[str, Callable[..., Any]]]:
    """``(qualified name, callable)`` of what ``module`` exports and defines itself."""
    for name in getattr(module, "__all__", ()):
        obj = getattr(module, name, None)
        if getattr(obj, "__module__", None) != module.__name__:
            continue                                      # re-exported: counted where it is defined
        if inspect.isclass(obj):
            if "__init__" in obj.__dict__:
                yield f"{module.__name__}.{name}", obj.__init__
            for attr, member in obj.__dict__.items():
                if attr.startswith("_"):
                    continue
                if isinstance(member, (classmethod, staticmethod)):
                    member = member.__func__
                if inspect.isfunction(member):
                    yield f"{module.__name__}.{name}.{attr}", member
        elif inspect.isfunction(obj):
            yield f"{module.__name__}.{name}", obj


#: Parameters of the checkers' helpers that hold a student's answer, by callable.
ANSWER_PARAMETERS = {"uwtutor.exercises.checks.run_student": ("func",)}


def _is_answer(qualname: str, parameter: str) -> bool:
    """A student's answer: a parameter of an exercise checker (``uwtutor.exercises...check_*``), or an ``answer``
    (or one of ``ANSWER_PARAMETERS``) of their helpers."""
    if not qualname.startswith("uwtutor.exercises."):
        return False
    return (qualname.rsplit(".", 1)[-1].startswith("check_") or parameter == "answer"
            or parameter in ANSWER_PARAMETERS.get(qualname, ()))


def census(package: str = "uwtutor") -> Census:
    out = Census()
    seen: set[int] = set()
    for module in _modules(package):
        for qualname, func in _public_callables(module):
            if id(func) in seen:
                continue
            seen.add(id(func))
            try:
                params = inspect.signature(func).parameters.values()
            except (TypeError, ValueError):              # a builtin without a signature
                continue
            for p in params:
                if p.name in ("self", "cls") or p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD):
                    continue
                out.total += 1
                if _is_any(p.annotation):
                    (out.answers if _is_answer(qualname, p.name) else out.any_params).append(f"{qualname}({p.name})")
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--count", action="store_true", help="print the counts only")
    parser.add_argument("--write-pending", action="store_true", help=f"rewrite {PENDING.relative_to(REPO)}")
    args = parser.parse_args(argv)
    sys.path.insert(0, str(REPO))
    c = census()
    if args.write_pending:
        PENDING.write_text(HEADER + "".join(f"{line}\n" for line in sorted(c.any_params)), encoding="utf-8")
    if not args.count:
        print("\n".join(sorted(c.any_params)))
    share = 100.0 * (len(c.any_params) + len(c.answers)) / max(c.total, 1)
    print(f"{len(c.any_params)} public parameters annotated Any (besides {len(c.answers)} student answers of the "
          f"exercise checkers), of {c.total} public parameters ({share:.0f} % Any in all)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
