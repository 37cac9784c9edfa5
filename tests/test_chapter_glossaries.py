"""tools/chapter_glossaries.py: the glossary entries a chapter cites, as a cell that only JupyterLab shows.

jupyterlab-myst renders a notebook on its own, so a ``{term}`` whose entry is on the glossary page logs "Cross
reference target was not found" and is a dead link; a MyST glossary in the notebook resolves it (measured in a real
JupyterLab: chapter 1 logs 0 such errors instead of 198, its 17 term links all live). The cell is tagged
``remove-cell``, which myst-nb skips before parsing, so the HTML book and its strict build are unchanged.
"""

from __future__ import annotations

import importlib.util
import re
import shutil
from pathlib import Path

import nbformat

REPO = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("chapter_glossaries", REPO / "tools" / "chapter_glossaries.py")
tool = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(tool)
CHAPTER = REPO / "book" / "ch01_positioning_and_errors.ipynb"


def test_reads_every_entry_of_the_glossary_page():
    entries = tool.read_glossary()
    assert len(entries) > 40
    assert entries["long baseline"][0] == "long baseline" and "长基线" in entries["long baseline"][1]
    assert "cramér-rao lower bound" in entries and "cramér–rao lower bound" in entries   # two terms, one entry
    assert entries["auv"][0] == "AUV"


def test_adds_one_removed_cell_with_the_cited_terms_and_is_idempotent(tmp_path):
    path = tmp_path / CHAPTER.name
    shutil.copy(CHAPTER, path)
    original = nbformat.read(path, as_version=4)
    original.cells = [c for c in original.cells if c.metadata.get("uwtutor") != tool.MARK]   # the chapter without it
    nbformat.write(original, path)
    assert tool.main([str(path)]) == 0
    nb = nbformat.read(path, as_version=4)
    assert len(nb.cells) == len(original.cells) + 1
    at = tool.POSITION
    assert [c.source for c in nb.cells[:at] + nb.cells[at + 1:]] == [c.source for c in original.cells], \
        "no other cell is touched"
    cell = nb.cells[at]
    assert nb.cells[0].source == original.cells[0].source, "the chapter's title stays first"
    assert cell.cell_type == "markdown" and cell.metadata["tags"] == ["remove-cell"]
    cited = {tool._key(m.group(2) or m.group(1)) for c in original.cells if c.cell_type == "markdown"
             for m in re.finditer(r"\{term\}`([^`<]+?)(?:\s*<([^>]+)>)?`", c.source)}
    listed = {tool._key(line) for line in cell.source.split("```{glossary}")[1].split("\n")
              if line and not line.startswith((":", " ", "`"))}
    assert cited and listed == cited
    body = cell.source.split("```{glossary}")[1]
    assert not re.search(r"\{[a-z:]+\}`", body), "roles inside definitions would need targets of their own"
    assert tool.main(["--check", str(path)]) == 0 and tool.main([str(path)]) == 0
    assert nbformat.read(path, as_version=4) == nb, "a second run changes nothing"
    # a chapter that cites one term fewer gets a new cell in place of the old one, not a second one
    first = next(i for i, c in enumerate(nb.cells) if "{term}`long baseline`" in c.source)
    nb.cells[first].source = nb.cells[first].source.replace("{term}`long baseline`", "long baseline")
    nbformat.write(nb, path)
    assert tool.main(["--check", str(path)]) == 1
    assert tool.main([str(path)]) == 0
    again = nbformat.read(path, as_version=4)
    assert len(again.cells) == len(nb.cells) and "\nlong baseline\n" not in again.cells[at].source
    # a chapter whose cell is still at the end (where the tool used to write it) gets it moved, not doubled
    moved = nbformat.read(path, as_version=4)
    moved.cells = moved.cells[:at] + moved.cells[at + 1:] + [moved.cells[at]]
    nbformat.write(moved, path)
    assert tool.main(["--check", str(path)]) == 1 and tool.main([str(path)]) == 0
    assert nbformat.read(path, as_version=4) == again


CHAPTERS = sorted((REPO / "book").glob("ch[0-9][0-9]_*.ipynb"))


def test_every_chapter_carries_the_entries_of_the_terms_it_cites():
    """Issue 25: in JupyterLab every {term} of a chapter resolves to an entry in the chapter itself (no console error,
    a live link); in the HTML book the cell is removed and the roles link to the glossary page as before."""
    assert len(CHAPTERS) >= 10
    assert tool.main(["--check", *map(str, CHAPTERS)]) == 0, "run tools/chapter_glossaries.py book/ch*.ipynb"
    with_terms = 0
    for path in CHAPTERS:
        nb = nbformat.read(path, as_version=4)
        generated = [i for i, c in enumerate(nb.cells) if c.metadata.get("uwtutor") == tool.MARK]
        cited = tool._targets(nb)
        if not cited:
            assert not generated, f"{path.name} cites no term but has a glossary cell"
            continue
        with_terms += 1
        assert generated == [tool.POSITION], f"{path.name}: one glossary cell, right after the first"
        cell = nb.cells[tool.POSITION]
        assert cell.cell_type == "markdown" and "remove-cell" in cell.metadata["tags"], \
            "the HTML book must not show the cell (nor see a second definition of a term)"
        listed = {tool._key(line) for line in cell.source.split("```{glossary}")[1].split("\n")
                  if line and not line.startswith((":", " ", "`"))}
        assert listed == set(cited), path.name
        # the chapter's own text keeps its roles: the HTML still links each term to the glossary page
        assert any("{term}`" in c.source for i, c in enumerate(nb.cells) if c.cell_type == "markdown"
                   and i != tool.POSITION)
    assert with_terms >= 7
