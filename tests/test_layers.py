"""The library's layers, one way: every import inside ``uwtutor`` points to the same layer or to one on its left.

Data flow (book/library_design.md): a scenario makes measurements, models describe them, filters turn them into a
result, least squares and bounds start and judge filters, pipelines chain them, real logs and studies run them, and
the presentation (figures, widgets, exercise checkers) reads the results. An import against that flow -- a scenario
that runs filters, a filter that computes least-squares fixes, an exercise checker that builds a widget -- is what
makes a layout hard to see at a glance, so it fails here. Private names (``_x``) of another module are not imported
either: what two modules share lives in the foundation (``_validate``, ``_linalg``) under a public name.

The imports are read from the source (``ast``), including those inside functions, so a deferred import does not
hide a cycle.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "uwtutor"

#: The layers, left to right: a module may import its own layer and the layers to its left.
LAYERS: list[tuple[str, frozenset[str]]] = [
    ("foundation", frozenset({"_validate", "_linalg", "_cancel", "errors", "reporting"})),
    ("physics and simulation", frozenset({"acoustics", "motion", "ranging", "owtt", "scenarios", "grey", "wavelet",
                                          "resampling"})),
    ("models", frozenset({"models"})),
    ("filters", frozenset({"filters"})),
    ("least squares, bounds and metrics", frozenset({"lsq", "observability", "metrics", "statistics"})),
    ("pipelines", frozenset({"pipelines"})),
    ("real logs", frozenset({"datasets"})),
    ("studies", frozenset({"montecarlo", "methods"})),
    ("figures", frozenset({"plotting"})),
    ("widgets", frozenset({"widgets"})),
    ("exercises", frozenset({"exercises", "__main__"})),
]
#: Pairs of the same or neighbouring layers that must still not import each other (left -> right never; these are
#: the top's siblings): an exercise checker computes its reference with the library, never through a widget.
SEPARATE = {("exercises", "widgets")}
#: Imports against the flow that are known and not yet mended, each with its reason. The list may only shrink.
KNOWN: dict[tuple[str, str], str] = {}
#: The package root only exposes the version and the subpackages; it is not a layer.
ROOT = "__init__"


def _layer_of(top: str) -> int:
    for index, (_, members) in enumerate(LAYERS):
        if top in members:
            return index
    raise KeyError(top)


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _imports(path: Path, module: str) -> list[tuple[str, int, tuple[str, ...]]]:
    """(imported module, line, names) for every import of ``uwtutor`` in the file of ``module``, relative ones
    resolved."""
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            names = tuple(alias.name for alias in node.names)
            if target == "uwtutor":              # from .. import lsq: each name is a module of its own
                found += [(f"uwtutor.{name}", node.lineno, ()) for name in names if name != "__version__"]
            elif target.startswith("uwtutor."):
                found.append((target, node.lineno, names))
        elif isinstance(node, ast.Import):
            found += [(alias.name, node.lineno, ()) for alias in node.names if alias.name.startswith("uwtutor.")]
    return found


def _top(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ROOT


SOURCES = sorted(p for p in PACKAGE.rglob("*.py"))


def test_every_module_has_a_layer():
    tops = {_top(_module_name(p)) for p in SOURCES} - {ROOT}
    unplaced = sorted(t for t in tops if not any(t in members for _, members in LAYERS))
    assert not unplaced, f"put these modules in a layer of tests/test_layers.py (and library_design.md): {unplaced}"


def _against_the_flow(path: Path, module: str) -> list[str]:
    here = _top(module)
    if here == ROOT:
        return []
    wrong = []
    for target, line, _ in _imports(path, module):
        there = _top(target)
        if there in (ROOT, here):
            continue
        pair = (LAYERS[_layer_of(here)][0], LAYERS[_layer_of(there)][0])
        if (module, target) in KNOWN:
            continue
        if _layer_of(there) > _layer_of(here) or pair in SEPARATE:
            wrong.append(f"line {line}: {target} ({pair[1]}) from {pair[0]}")
    return wrong


def _private_imports(path: Path, module: str) -> list[str]:
    wrong = []
    for target, line, names in _imports(path, module):
        if _top(target) == _top(module):        # within a subpackage its modules share their private helpers
            continue
        wrong += [f"line {line}: {name} from {target}" for name in names
                  if name.startswith("_") and not name.startswith("__")]
    return wrong


@pytest.mark.parametrize("path", SOURCES, ids=lambda p: str(p.relative_to(PACKAGE.parent)))
def test_imports_point_left(path):
    wrong = _against_the_flow(path, _module_name(path))
    assert not wrong, f"{path.name} imports against the flow:\n  " + "\n  ".join(wrong)


@pytest.mark.parametrize("path", SOURCES, ids=lambda p: str(p.relative_to(PACKAGE.parent)))
def test_no_private_name_of_another_module(path):
    wrong = _private_imports(path, _module_name(path))
    assert not wrong, f"{path.name} imports private names (move what is shared to _validate or _linalg):\n  " + \
        "\n  ".join(wrong)


def test_known_exceptions_still_exist():
    """An exception that was mended must leave ``KNOWN`` (so that the list only shrinks)."""
    for module, target in KNOWN:
        path = PACKAGE.parent / (module.replace(".", "/") + ".py")
        assert any(t == target for t, _, _ in _imports(path, module)), f"{module} no longer imports {target}: " \
            "remove it from KNOWN"


def test_the_rules_catch_imports_against_the_flow(tmp_path):
    """The checks themselves, on a probe module: a scenario that runs a filter, a deferred import of a pipeline, a
    private name of another module, an exercise checker that builds a widget."""
    probe = tmp_path / "probe.py"
    probe.write_text("from ..filters import range_only_ekf\nfrom ..motion import _private, Track\n\n\n"
                     "def f():\n    from .. import pipelines\n")
    assert _against_the_flow(probe, "uwtutor.scenarios.probe") == [
        "line 1: uwtutor.filters (filters) from physics and simulation",
        "line 6: uwtutor.pipelines (pipelines) from physics and simulation"]
    assert _private_imports(probe, "uwtutor.scenarios.probe") == ["line 2: _private from uwtutor.motion"]
    probe.write_text("from ..widgets.ch04 import ekf_view\nfrom ..filters import RangeOnlyEKF\n")
    assert _against_the_flow(probe, "uwtutor.exercises.probe") == [
        "line 1: uwtutor.widgets.ch04 (widgets) from exercises"]
