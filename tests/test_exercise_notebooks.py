"""Every exercise source runs with all its checks correct, and its student version runs up to its first exercise.

For each notebook in ``exercises/``:

- the **source** (with solutions) is executed with nbclient; no cell may fail (the hidden tests call
  ``.assert_correct()``), and every check cell must display a correct ``Feedback`` (its text starts with ✔);
- the **student version** is executed with errors allowed: the first error must be the ``NotImplementedError`` of the
  first answer cell (``# YOUR CODE HERE``), and every error must be such a ``NotImplementedError`` raised by an
  answer cell; every check cell must display a ``Feedback`` that is not correct (never a traceback).
"""

from __future__ import annotations

import re
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

from uwtutor.exercises.feedback import CORRECT_MARK, WRONG_MARK
from uwtutor.exercises.generate import make_student_version

REPO = Path(__file__).resolve().parents[1]
SOURCES = sorted((REPO / "exercises").glob("*.ipynb"))
STUB = "# YOUR CODE HERE"
# the last line of a check cell: a call of a checker, e.g. ``ch01.check_two_way_range(range_m)``
_CHECK_CALL = re.compile(r"^\s*(\w+\.)*check_\w+\(.*\)\s*$")


def _execute(nb: nbformat.NotebookNode, cwd: Path, *, allow_errors: bool) -> nbformat.NotebookNode:
    client = NotebookClient(nb, kernel_name="python3", timeout=300, allow_errors=allow_errors,
                            resources={"metadata": {"path": str(cwd)}})
    client.execute()
    return nb


def _is_check_cell(cell: nbformat.NotebookNode) -> bool:
    if cell.cell_type != "code":
        return False
    lines = [line for line in cell.source.splitlines() if line.strip() and not line.lstrip().startswith("#")]
    return bool(lines) and _CHECK_CALL.match(lines[-1]) is not None and "check" in cell.metadata.get("tags", [])


def _displayed_text(cell: nbformat.NotebookNode) -> str:
    results = [o for o in cell.outputs if o.output_type == "execute_result"]
    return results[-1]["data"].get("text/plain", "") if results else ""


def _errors(nb: nbformat.NotebookNode) -> list[tuple[int, str, str]]:
    return [(i, o.ename, o.evalue) for i, cell in enumerate(nb.cells) if cell.cell_type == "code"
            for o in cell.outputs if o.output_type == "error"]


def test_there_are_exercise_sources():
    assert SOURCES, "no exercise notebooks in exercises/"


@pytest.mark.parametrize("source", SOURCES, ids=[p.stem for p in SOURCES])
def test_source_runs_and_every_check_is_correct(source, tmp_path):
    nb = _execute(nbformat.read(source, as_version=4), tmp_path, allow_errors=False)
    check_cells = [(i, c) for i, c in enumerate(nb.cells) if _is_check_cell(c)]
    tagged = [i for i, c in enumerate(nb.cells) if "check" in c.metadata.get("tags", [])]
    assert [i for i, _ in check_cells] == tagged, "every cell tagged 'check' must end with a check_...(...) call"
    answers = [c for c in nb.cells if c.cell_type == "code" and "### BEGIN SOLUTION" in c.source]
    assert len(check_cells) >= len(answers) >= 1
    for index, cell in check_cells:
        shown = _displayed_text(cell)
        assert shown.startswith(CORRECT_MARK), f"{source.name}, cell {index}: the check shows\n{shown or '(nothing)'}"


@pytest.mark.parametrize("source", SOURCES, ids=[p.stem for p in SOURCES])
def test_student_version_runs_up_to_its_first_exercise(source, tmp_path):
    student = make_student_version(source)
    nbformat.write(student, tmp_path / source.name)  # a student version as the command writes it
    nb = _execute(nbformat.read(tmp_path / source.name, as_version=4), tmp_path, allow_errors=True)

    exercise_cells = [i for i, c in enumerate(nb.cells) if c.cell_type == "code" and STUB in c.source]
    assert exercise_cells, "the student version has no exercise"
    errors = _errors(nb)
    assert errors, "the student version should stop at its first unanswered exercise"

    first_index, first_name, _ = errors[0]
    assert first_name == "NotImplementedError", f"cell {first_index} failed first, with {errors[0]}"
    assert first_index == exercise_cells[0], (
        f"the first error is in cell {first_index}, but the first exercise is cell {exercise_cells[0]}")
    for index, name, value in errors:
        assert name == "NotImplementedError" and index in exercise_cells, (
            f"cell {index} fails with {name}: {value} (only the answer cells may fail in a student version)")

    check_cells = [(i, c) for i, c in enumerate(nb.cells) if _is_check_cell(c)]
    assert check_cells
    for index, cell in check_cells:
        shown = _displayed_text(cell)
        assert shown.startswith(WRONG_MARK) and "No answer yet" in shown, (
            f"cell {index} of the student version shows\n{shown or '(nothing)'}")
