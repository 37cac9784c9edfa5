"""The book's committed outputs carry no digit that depends on the CPU.

Two halves (issue 21). nbval re-runs every chapter with its kernels playing another CPU than the one that wrote
the outputs (``tools/cpu_variants.py``, applied in ``conftest.py``), which catches an output that shows round-off
when it happens to differ. This file checks what must hold whatever the round-off does: every number the prose
takes from a computation (a myst-nb ``glue`` record) is stored exactly as the prose shows it, so that what nbval
compares is the shown value, not its last bits (``uwtutor.reporting.as_shown``).
"""

from __future__ import annotations

import json
import re
from collections import defaultdict
from pathlib import Path

import nbformat
import pytest

from uwtutor.reporting import as_shown

from book_paths import REPO

BOOK = REPO / "book"
CHAPTERS = sorted(BOOK.glob("ch*.ipynb"))
GLUE_ROLE = re.compile(r"\{glue(?::[a-z]+)?\}`([^`]*)`")


def glue_records(nb) -> dict[str, str]:
    """Every glued name of a notebook and the text/plain repr of its value, as committed."""
    records = {}
    for cell in nb.cells:
        if cell.cell_type != "code":
            continue
        for output in cell.get("outputs", []):
            meta = output.get("metadata", {}).get("scrapbook")
            if meta:
                records[meta["name"]] = output["data"]["application/papermill.record/text/plain"]
    return records


def prose_formats(nb) -> dict[str, set[str]]:
    """Every ``{glue:text}`name:fmt``` of a notebook's Markdown: name -> the formats it is shown with."""
    formats: dict[str, set[str]] = defaultdict(set)
    for cell in nb.cells:
        if cell.cell_type == "markdown":
            for match in GLUE_ROLE.finditer(cell.source):
                name, _, fmt = match.group(1).partition(":")
                formats[name].add(fmt)
    return formats


def test_every_chapter_is_checked():
    assert len(CHAPTERS) >= 10, f"expected the ten chapters in {BOOK}, found {[p.name for p in CHAPTERS]}"


@pytest.mark.parametrize("path", CHAPTERS, ids=lambda p: p.stem)
def test_glued_floats_are_stored_as_the_prose_shows_them(path: Path):
    nb = nbformat.read(path, as_version=4)
    records, formats = glue_records(nb), prose_formats(nb)
    problems = []
    for name, fmts in sorted(formats.items()):
        if name not in records:
            problems.append(f"{name}: shown in the text but never glued")
            continue
        try:
            value = json.loads(records[name])
        except json.JSONDecodeError:
            continue  # a string (already text) or an object the text shows as it is
        if not isinstance(value, float):
            continue  # ints and strings have no round-off digits
        if len(fmts) > 1:
            problems.append(f"{name} is shown with the formats {sorted(fmts)}: a value rounded for one and shown "
                            "with another is rounded twice; use one format (or glue two names)")
        for fmt in fmts:
            if not fmt:
                problems.append(f"{name} = {value!r}: a float shown with no format prints its round-off digits")
            elif as_shown(value, fmt) != value:
                problems.append(f"{name} = {value!r} is shown as :{fmt} but glued with more digits: glue "
                                f"as_shown(value, {fmt!r}) (uwtutor.reporting)")
    assert not problems, f"{path.name}:\n  " + "\n  ".join(problems)


def test_the_check_fails_on_a_float_glued_with_its_round_off():
    """The rule above is not vacuous: the unrounded record of chapter 3 (commit 7438a42) breaks it."""
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_markdown_cell("spans {glue:text}`decades:.0f` decades"),
                nbformat.v4.new_code_cell("glue('decades', x)")]
    nb.cells[1].outputs = [nbformat.v4.new_output(
        "display_data", data={"application/papermill.record/text/plain": "9.787304763024217"},
        metadata={"scrapbook": {"name": "decades", "mime_prefix": "application/papermill.record/"}})]
    value = json.loads(glue_records(nb)["decades"])
    assert as_shown(value, ".0f") != value
    assert as_shown(as_shown(value, ".0f"), ".0f") == 10.0


def _cpu_variants():
    import importlib.util

    spec = importlib.util.spec_from_file_location("cpu_variants", REPO / "tools" / "cpu_variants.py")
    variants = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(variants)
    return variants


ROUND_OFF_PROBE = """
import numpy as np
a = np.random.default_rng(0).standard_normal((200, 200))
print(repr(float(np.linalg.inv(a)[0, 0])))
"""


def test_the_two_kernel_environments_are_two_cpus():
    """The same sum under MAKE and CHECK differs in its last bits: the nbval comparison crosses CPUs."""
    import platform
    import subprocess
    import sys

    if platform.machine() not in ("x86_64", "AMD64"):
        pytest.skip("the OpenBLAS kernels named in tools/cpu_variants.py are x86-64 kernels")
    variants = _cpu_variants()
    outputs = {}
    for label, variant in (("MAKE", variants.MAKE), ("CHECK", variants.CHECK)):
        env = variants.kernel_env(variant)
        env.pop("UWTUTOR_NATIVE_CPU", None)
        env.update(variant)
        proc = subprocess.run([sys.executable, "-c", ROUND_OFF_PROBE], env=env, capture_output=True, text=True,
                              check=True)
        outputs[label] = proc.stdout.strip()
    make, check = float(outputs["MAKE"]), float(outputs["CHECK"])
    assert make != check, "MAKE and CHECK gave the same bits: the kernels would not play two CPUs"
    assert abs(make - check) < 1e-9 * abs(make), "the two CPUs should differ in round-off only"


def test_nbval_does_not_sanitize_round_off():
    sanitizers = (REPO / "tests" / "nbval_sanitize.cfg").read_text()
    assert "papermill.record" not in sanitizers and r"\d{9})\d{3,}" not in sanitizers, (
        "nbval_sanitize.cfg must not hide round-off digits: fix the output instead")
