"""The names renamed by issue 27 ("Names") still import for one release, with a DeprecationWarning naming the new one.

Each old name is read the two ways a user's code reads it (``module.OLD`` and ``from module import OLD``); it must
warn, name its replacement, and give the new object. The old names are not in the modules' ``__all__``, and a name
that never existed still raises AttributeError.
"""

from __future__ import annotations

import importlib
import warnings

import pytest

#: (module, old name, new name): the old name gives the very object of the new one.
RENAMED = [
    ("uwtutor.ranging", "SoundSpeedError", "SoundSpeedMismatch"),
    ("uwtutor.ranging", "CompositeError", "RangeErrorSum"),
    ("uwtutor.scenarios.paper_d", "PaperD", "PaperDParameters"),
    ("uwtutor.scenarios.paper_e", "PaperE", "PaperEParameters"),
    ("uwtutor.scenarios.paper_b", "PAPER_B", "PARAMETERS"),
    ("uwtutor.scenarios.suite", "SUITE", "PARAMETERS"),
]


def _read(module_name: str, old: str):
    module = importlib.import_module(module_name)
    with pytest.warns(DeprecationWarning) as caught:
        value = getattr(module, old)
    return value, [str(w.message) for w in caught]


@pytest.mark.parametrize("module_name, old, new", RENAMED)
def test_old_name_warns_and_is_the_new_object(module_name, old, new):
    module = importlib.import_module(module_name)
    value, messages = _read(module_name, old)
    assert value is getattr(module, new)
    assert any(f"{module_name}.{old} is deprecated" in m and f"use {module_name}.{new}" in m for m in messages)
    assert old not in module.__all__ and new in module.__all__


@pytest.mark.parametrize("module_name, old, new", RENAMED)
def test_from_import_of_an_old_name_warns(module_name, old, new):
    namespace: dict = {}
    with pytest.warns(DeprecationWarning, match=f"use {module_name}.{new}"):
        exec(f"from {module_name} import {old}", namespace)
    assert namespace[old] is getattr(importlib.import_module(module_name), new)


@pytest.mark.parametrize("module_name", sorted({m for m, _, _ in RENAMED}))
def test_an_unknown_name_is_still_an_attribute_error(module_name):
    module = importlib.import_module(module_name)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(AttributeError, match="has no attribute 'NoSuchName'"):
            module.NoSuchName  # noqa: B018


def test_the_warning_points_at_the_callers_line():
    with pytest.warns(DeprecationWarning) as caught:
        importlib.import_module("uwtutor.ranging").SoundSpeedError  # noqa: B018
    assert caught[0].filename == __file__


@pytest.mark.parametrize("module_name", ["uwtutor.scenarios.paper_c", "uwtutor.widgets.ch06"])
def test_paper_c_dict_is_the_parameters_as_a_dict(module_name):
    """``PAPER_C`` was a dict made by ``as_dict()``: the old name still gives that dict (a fresh copy)."""
    import numpy as np

    from uwtutor.scenarios import paper_c

    value, messages = _read(module_name, "PAPER_C")
    assert any("use uwtutor.scenarios.paper_c.PARAMETERS.as_dict()" in m for m in messages)
    expected = paper_c.PARAMETERS.as_dict()
    assert isinstance(value, dict) and set(value) == set(expected)
    for name, v in expected.items():
        np.testing.assert_array_equal(value[name], v)
    value["sensor_std"][0] = -1.0                           # a copy: the parameters themselves stay the paper's
    assert paper_c.PARAMETERS.sensor_std[0] == 0.2


def test_paper_c_make_parameters_keyword_is_params():
    import numpy as np

    from uwtutor.scenarios import paper_c

    p = paper_c.PaperCParameters(T=0.1)
    with pytest.warns(DeprecationWarning, match="use params="):
        old = paper_c.make(np.random.default_rng(0), 1, parameters=p, duration=6.0)
    new = paper_c.make(np.random.default_rng(0), 1, params=p, duration=6.0)
    assert old.parameters is new.parameters is p
    np.testing.assert_array_equal(old.measurements, new.measurements)
    with pytest.raises(TypeError, match="give the parameters once"):
        paper_c.make(np.random.default_rng(0), 1, params=p, parameters=p)


@pytest.mark.parametrize("module_name, cls", [
    ("uwtutor.scenarios.paper_a", "PaperAParameters"), ("uwtutor.scenarios.paper_b", "PaperBParameters"),
    ("uwtutor.scenarios.paper_c", "PaperCParameters"), ("uwtutor.scenarios.paper_d", "PaperDParameters"),
    ("uwtutor.scenarios.paper_e", "PaperEParameters"), ("uwtutor.scenarios.suite", "SuiteParameters"),
])
def test_every_scenario_module_calls_its_default_set_parameters(module_name, cls):
    """The naming scheme: a ``<Name>Parameters`` class and its default instance ``PARAMETERS``, both public."""
    module = importlib.import_module(module_name)
    assert isinstance(module.PARAMETERS, getattr(module, cls))
    assert {"PARAMETERS", cls} <= set(module.__all__)


OLD_NAMES = {"SoundSpeedError", "CompositeError", "PaperD", "PaperE", "PAPER_B", "SUITE", "PAPER_C"}
REPO = importlib.import_module("pathlib").Path(__file__).resolve().parents[1]


def _old_names_used(source: str) -> set[str]:
    """The old names a piece of Python reads (as a name, an attribute or an import), by its syntax tree."""
    import ast

    found = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Name) and node.id in OLD_NAMES:
            found.add(node.id)
        elif isinstance(node, ast.Attribute) and node.attr in OLD_NAMES:
            found.add(node.attr)
        elif isinstance(node, ast.ImportFrom):
            found |= {alias.name for alias in node.names if alias.name in OLD_NAMES}
    return found


def test_the_check_sees_an_old_name():
    assert _old_names_used("from uwtutor.ranging import GaussianNoise, SoundSpeedError\nP = suite.SUITE") == {
        "SoundSpeedError", "SUITE"}
    assert not _old_names_used('__getattr__ = deprecated_aliases(__name__, {"PAPER_B": "PARAMETERS"})')


def test_nothing_in_the_project_reads_an_old_name():
    """The library, the tests, the studies, the tools, the book and the exercises use the new names only (an old
    name would warn in a reader's notebook)."""
    import json

    offenders = []
    for folder in ("uwtutor", "tests", "studies", "benchmarks", "tools"):
        for path in sorted((REPO / folder).rglob("*.py")):
            if path.name != "test_deprecated_names.py":
                used = _old_names_used(path.read_text(encoding="utf-8"))
                offenders += [f"{path.relative_to(REPO)}: {sorted(used)}"] if used else []
    for path in sorted([*(REPO / "book").rglob("*.ipynb"), *(REPO / "exercises").rglob("*.ipynb")]):
        if ".ipynb_checkpoints" in path.parts:
            continue
        for index, cell in enumerate(json.loads(path.read_text(encoding="utf-8"))["cells"]):
            if cell["cell_type"] != "code":
                continue
            source = "".join(cell["source"])
            code = "\n".join("" if line.lstrip().startswith(("%", "!")) else line for line in source.splitlines())
            try:
                used = _old_names_used(code)
            except SyntaxError:                              # a student stub or a cell magic: read it as text
                used = {name for name in OLD_NAMES if name in source}
            offenders += [f"{path.relative_to(REPO)} cell {index}: {sorted(used)}"] if used else []
    assert not offenders, "use the new names (see RENAMED):\n  " + "\n  ".join(offenders)
