"""nbgrader's cell metadata on the exercise and lab sources: check it, and add it to a source that lacks it.

nbgrader (``nbgrader generate_assignment``) reads each cell's ``metadata["nbgrader"]``; a marker such as
``### BEGIN SOLUTION`` in a cell without the right metadata makes it refuse the notebook. The kinds of cell, as
nbgrader's "Create Assignment" toolbar calls them, and their metadata (schema version 3):

=====================  ========  =======  ========  =========================================================
kind                   solution  grade    locked    used for
=====================  ========  =======  ========  =========================================================
autograded answer      true      false    false     an answer cell (tag ``answer``) with a solution region
autograder tests       false     true     true      a check cell (tag ``check``): visible and hidden tests
manually graded answer true      true     false     a written answer (Markdown with a solution region)
read-only              false     false    true      given code or text the student must not change
=====================  ========  =======  ========  =========================================================

Graded cells carry ``points``; every nbgrader cell carries a ``grade_id`` unique in its notebook. The student
versions made by ``uwtutor exercises`` / ``uwtutor labs`` do not need any of this (they work from the markers alone);
the metadata is for instructors who hand the same sources to nbgrader.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from typing import Any

import nbformat

__all__ = ["SCHEMA_VERSION", "nbgrader_problems", "add_nbgrader_metadata", "total_points"]

#: The nbgrader cell-metadata schema the sources use (nbgrader 0.9).
SCHEMA_VERSION = 3

_SOLUTION = re.compile(r"^\s*#+\s*BEGIN\s+SOLUTION\s*$", re.MULTILINE)
_HIDDEN = re.compile(r"^\s*#+\s*BEGIN\s+HIDDEN\s+TESTS\s*$", re.MULTILINE)
_GRADE_ID = re.compile(r"^[A-Za-z0-9_-]+$")


def _meta(cell: Any) -> dict[str, Any] | None:
    meta = cell.get("metadata", {}).get("nbgrader")
    return dict(meta) if meta is not None else None


def nbgrader_problems(nb: Mapping[str, Any]) -> list[str]:
    """What nbgrader would object to in a source notebook (an empty list when nothing).

    Checked: a cell with a solution region is a solution cell; a cell with hidden tests is a grade cell (autograder
    tests); every nbgrader cell has schema version 3 and a ``grade_id`` made of letters, digits, ``_`` and ``-``,
    unique in the notebook; a grade cell has non-negative ``points``; a test cell (grade, not solution) is a code
    cell and is locked; a written answer is a Markdown cell.

    Parameters
    ----------
    nb : nbformat.NotebookNode or dict
        The source notebook.

    Returns
    -------
    list of str
        One sentence per problem, naming the cell by its index.

    Examples
    --------
    >>> import nbformat
    >>> nb = nbformat.v4.new_notebook(cells=[
    ...     nbformat.v4.new_markdown_cell("## Exercise 1.1"),
    ...     nbformat.v4.new_code_cell(
    ...         "x = None\\n### BEGIN SOLUTION\\nx = 2\\n### END SOLUTION"),
    ... ])
    >>> nbgrader_problems(nb)
    ['cell 1 (code) has a solution region but no nbgrader metadata (it must be a solution cell)']
    >>> nb.cells[1].metadata["tags"] = ["answer"]
    >>> nbgrader_problems(add_nbgrader_metadata(nb, prefix="ex1"))
    []
    """
    problems = []
    seen: dict[str, int] = {}
    for index, cell in enumerate(nb["cells"]):
        source = cell.get("source", "")
        if isinstance(source, list):
            source = "".join(source)
        meta = _meta(cell)
        where = f"cell {index} ({cell['cell_type']})"
        has_solution = bool(_SOLUTION.search(source))
        has_hidden = bool(_HIDDEN.search(source))
        if meta is None:
            if has_solution:
                problems.append(f"{where} has a solution region but no nbgrader metadata (it must be a solution cell)")
            if has_hidden:
                problems.append(f"{where} has hidden tests but no nbgrader metadata (it must be a test cell)")
            continue
        if meta.get("schema_version") != SCHEMA_VERSION:
            problems.append(f"{where}: schema_version is {meta.get('schema_version')!r}, not {SCHEMA_VERSION}")
        grade_id = meta.get("grade_id")
        if not isinstance(grade_id, str) or not _GRADE_ID.match(grade_id):
            problems.append(f"{where}: grade_id {grade_id!r} must be letters, digits, '_' or '-'")
        elif grade_id in seen:
            problems.append(f"{where}: grade_id {grade_id!r} is already used by cell {seen[grade_id]}")
        else:
            seen[grade_id] = index
        solution, grade, locked = bool(meta.get("solution")), bool(meta.get("grade")), bool(meta.get("locked"))
        if has_solution and not solution:
            problems.append(f"{where} has a solution region but is not a solution cell")
        if has_hidden and not grade:
            problems.append(f"{where} has hidden tests but is not a grade cell")
        if grade:
            points = meta.get("points")
            if not isinstance(points, (int, float)) or isinstance(points, bool) or points < 0:
                problems.append(f"{where}: a grade cell needs points >= 0; got {points!r}")
        if grade and not solution:
            if cell["cell_type"] != "code":
                problems.append(f"{where}: autograder tests must be a code cell")
            if not locked:
                problems.append(f"{where}: autograder tests should be locked (students must not edit them)")
        if grade and solution and cell["cell_type"] != "markdown" and not has_solution:
            problems.append(f"{where}: a manually graded answer needs a solution region")
        if solution and locked:
            problems.append(f"{where}: a solution cell cannot be locked")
    return problems


def total_points(nb: Mapping[str, Any]) -> tuple[float, float]:
    """The points of a notebook: (autograded, manually graded).

    Parameters
    ----------
    nb : nbformat.NotebookNode or dict
        A notebook with nbgrader metadata.

    Returns
    -------
    tuple of float
        The points of the autograder-test cells and those of the manually graded answers.

    Examples
    --------
    >>> import nbformat
    >>> nb = nbformat.v4.new_notebook(cells=[
    ...     nbformat.v4.new_markdown_cell("## Exercise 1.1"),
    ...     nbformat.v4.new_code_cell(
    ...         "x = None\\n### BEGIN SOLUTION\\nx = 2\\n### END SOLUTION",
    ...                               metadata={"tags": ["answer"]}),
    ...     nbformat.v4.new_code_cell("assert x == 2",
    ...                               metadata={"tags": ["check"]}),
    ... ])
    >>> total_points(nb)  # no nbgrader metadata yet
    (0.0, 0.0)
    >>> total_points(add_nbgrader_metadata(nb, prefix="ex1", points=2.0))
    (2.0, 0.0)
    """
    auto = manual = 0.0
    for cell in nb["cells"]:
        meta = _meta(cell) or {}
        if meta.get("grade"):
            if meta.get("solution"):
                manual += float(meta.get("points", 0))
            else:
                auto += float(meta.get("points", 0))
    return auto, manual


def add_nbgrader_metadata(nb: nbformat.NotebookNode, *, prefix: str, points: float = 1.0, written_points: float = 1.0,
                          overwrite: bool = False) -> nbformat.NotebookNode:
    """Give a source notebook nbgrader's metadata, from its tags and markers (an authoring aid).

    Cells tagged ``answer`` become autograded answers, cells tagged ``check`` autograder tests worth ``points``,
    Markdown cells with a solution region manually graded answers worth ``written_points``. Grade ids are
    ``{prefix}_{section}_{kind}`` where ``section`` comes from the last ``## Exercise X.Y`` heading above the cell
    (``1_4`` for "Exercise 1.4", a letter added for a part such as "1.4 (b)"), made unique with a counter.

    Parameters
    ----------
    nb : nbformat.NotebookNode
        The source notebook (modified in place and returned).
    prefix : str
        The start of every grade id, e.g. ``"ex1"``.
    points, written_points : float
        Points of each check cell and of each written answer.
    overwrite : bool
        Replace metadata a cell already has (default: keep it).

    Returns
    -------
    nbformat.NotebookNode
        ``nb``, with ``metadata["nbgrader"]`` on the cells above.

    Examples
    --------
    >>> import nbformat
    >>> nb = nbformat.v4.new_notebook(cells=[
    ...     nbformat.v4.new_markdown_cell("## Exercise 1.4 (b)"),
    ...     nbformat.v4.new_code_cell(
    ...         "x = None\\n### BEGIN SOLUTION\\nx = 2\\n### END SOLUTION",
    ...                               metadata={"tags": ["answer"]}),
    ...     nbformat.v4.new_code_cell("assert x == 2",
    ...                               metadata={"tags": ["check"]}),
    ... ])
    >>> nb = add_nbgrader_metadata(nb, prefix="ex1")
    >>> [c.metadata["nbgrader"]["grade_id"] for c in nb.cells[1:]]
    ['ex1_1_4b_answer', 'ex1_1_4b_check']
    >>> nbgrader_problems(nb)
    []
    """
    section = "intro"
    used: set[str] = {m["grade_id"] for c in nb.cells if (m := _meta(c)) and "grade_id" in m}
    heading = re.compile(r"^#{2,3}\s+Exercise\s+(\d+)\.(\d+)\s*(?:\(([a-z])\))?", re.MULTILINE)

    def unique(base: str) -> str:
        name, n = base, 2
        while name in used:
            name, n = f"{base}{n}", n + 1
        used.add(name)
        return name

    for cell in nb.cells:
        if cell.cell_type == "markdown":
            found = heading.search(cell.source)
            if found:
                section = f"{found.group(1)}_{found.group(2)}" + (found.group(3) or "")
        tags = cell.metadata.get("tags", [])
        if "nbgrader" in cell.metadata and not overwrite:
            continue
        base = {"schema_version": SCHEMA_VERSION, "task": False}
        if cell.cell_type == "code" and "answer" in tags:
            meta = {**base, "grade": False, "locked": False, "solution": True,
                    "grade_id": unique(f"{prefix}_{section}_answer")}
        elif cell.cell_type == "code" and "check" in tags:
            meta = {**base, "grade": True, "locked": True, "solution": False, "points": points,
                    "grade_id": unique(f"{prefix}_{section}_check")}
        elif cell.cell_type == "markdown" and _SOLUTION.search(cell.source):
            meta = {**base, "grade": True, "locked": False, "solution": True, "points": written_points,
                    "grade_id": unique(f"{prefix}_{section}_written")}
        else:
            continue
        cell.metadata["nbgrader"] = nbformat.NotebookNode(meta)
    return nb
