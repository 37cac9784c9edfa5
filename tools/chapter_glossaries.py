"""Give each chapter the glossary entries of the terms it uses, for JupyterLab only (the HTML book leaves them out).

Usage: ``python tools/chapter_glossaries.py [--check] book/chNN_*.ipynb ...``

In the HTML book a ``{term}`` role links to the glossary page. In JupyterLab, jupyterlab-myst renders each notebook
on its own: a ``{term}`` whose entry is on another page is a dead link, and each one logs "Cross reference target was
not found: term-..." in the browser's console (16 to 23 per chapter). A MyST glossary *in the notebook* resolves
them: the roles become links to the entries, with a preview on hover.

So this tool writes, as the chapter's second cell (right after the title and the introduction), a Markdown cell
"Terms used in this chapter" holding a MyST
``{glossary}`` (definition-list syntax, which jupyterlab-myst reads) of every term the chapter's Markdown cites,
copied from ``book/glossary.md`` (roles inside a definition turned into their text, so that they need no target of
their own). The cell is tagged ``remove-cell``: myst-nb skips such a cell before parsing it, so the HTML book is
unchanged and Sphinx never sees a second definition of a term. The cell is found again by its metadata
(``uwtutor.generated == "glossary"``) and replaced, never duplicated; no other cell is touched.

Why near the top and not at the end: JupyterLab's default windowing mode ("contentVisibility", and "full" and
"defer" alike) renders the cells from the top as they come into view, and jupyterlab-myst resolves a reference only
against cells it has already parsed. With the entries in the last cell, every rendering of an earlier cell logged
"Cross reference target was not found: term-..." (156 messages for chapter 1 in one opening), and a click on a term
scrolled towards an entry whose position the browser had only estimated, landing thousands of pixels away. In the
second cell the entries are parsed before the text that cites them (only terms cited in the first cell itself can
miss them, once) and a click scrolls to a cell whose place is known.

``--check`` writes nothing and exits 1 when a chapter's cell is missing or out of date (for a test).
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

import nbformat

GLOSSARY = Path(__file__).resolve().parents[1] / "book" / "glossary.md"
MARK = {"generated": "glossary"}
TERM_ROLE = re.compile(r"\{term\}`([^`]+)`")
ANY_ROLE = re.compile(r"\{[a-z:]+\}`([^`<]*?)(?:\s*<[^>]+>)?`")
TITLE = "## Terms used in this chapter"


def _key(term: str) -> str:
    return " ".join(term.split()).casefold()


def read_glossary(path: Path = GLOSSARY) -> dict[str, tuple[str, str]]:
    """The entries of the glossary page: key (the term, case-folded) -> (the term as written, its definition)."""
    text = path.read_text(encoding="utf-8")
    match = re.search(r"^```\{glossary\}[^\n]*\n(.*?)^```\s*$", text, re.M | re.S)
    if match is None:
        raise SystemExit(f"no glossary directive in {path}")
    entries: dict[str, tuple[str, str]] = {}
    terms: list[str] = []
    body: list[str] = []

    def flush() -> None:
        definition = "\n".join(line.strip() for line in body).strip()
        for term in terms:
            entries[_key(term)] = (term, definition)

    for line in match.group(1).split("\n"):
        if not line.strip():
            if body:
                body.append("")
            continue
        if line[0].isspace():
            body.append(line)
        else:
            if body:
                flush()
                terms, body = [], []
            terms.append(line.strip())
    if terms:
        flush()
    return entries


def _targets(nb: nbformat.NotebookNode) -> list[str]:
    """The glossary keys the chapter's Markdown cites, in the order of first use."""
    seen: dict[str, None] = {}
    for cell in nb.cells:
        if cell.cell_type != "markdown" or cell.metadata.get("uwtutor") == MARK:
            continue
        for role in TERM_ROLE.findall(cell.source):
            inner = re.search(r"<([^>]+)>\s*$", role)
            seen.setdefault(_key(inner.group(1) if inner else role), None)
    return list(seen)


def glossary_cell(nb: nbformat.NotebookNode, entries: dict[str, tuple[str, str]]) -> nbformat.NotebookNode | None:
    """The generated cell for ``nb`` (``None`` when the chapter cites no term)."""
    keys = _targets(nb)
    missing = [k for k in keys if k not in entries]
    if missing:
        raise SystemExit(f"terms not in {GLOSSARY.name}: {', '.join(missing)}")
    if not keys:
        return None
    lines = [TITLE, "", "From the book's glossary (in the HTML book, each term links to its page).", "",
             "```{glossary}"]
    for key in sorted(keys, key=lambda k: entries[k][0].casefold()):
        term, definition = entries[key]
        plain = ANY_ROLE.sub(lambda m: m.group(1), definition).split("\n")
        lines.append(term)
        lines.append(": " + plain[0])
        lines.extend(("  " + line) if line else "" for line in plain[1:])
        lines.append("")
    lines[-1] = "```"
    cell = nbformat.v4.new_markdown_cell("\n".join(lines))
    cell.metadata = nbformat.NotebookNode({"tags": ["remove-cell"], "uwtutor": dict(MARK)})
    cell.pop("id", None)
    return cell


#: Where the generated cell goes: after the chapter's first cell (its title and introduction).
POSITION = 1


def update(nb: nbformat.NotebookNode, entries: dict[str, tuple[str, str]]) -> bool:
    """Put the generated cell after the first cell of ``nb`` (replacing an earlier one, wherever it is); return
    whether ``nb`` changed."""
    old = [i for i, c in enumerate(nb.cells) if c.metadata.get("uwtutor") == MARK]
    new = glossary_cell(nb, entries)
    if old and new is not None and old == [POSITION] and nb.cells[POSITION].source == new.source:
        return False
    if not old and new is None:
        return False
    kept = [c for c in nb.cells if c.metadata.get("uwtutor") != MARK]
    if new is not None:
        if old:
            new["id"] = nb.cells[old[0]].get("id")
        elif nb.nbformat_minor >= 5:
            new["id"] = "uwtutor-terms"
        kept.insert(min(POSITION, len(kept)), new)
    nb.cells = kept
    return True


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("notebooks", nargs="+", type=Path)
    parser.add_argument("--check", action="store_true", help="write nothing; exit 1 if a chapter is out of date")
    args = parser.parse_args(argv)
    entries = read_glossary()
    stale = []
    for path in args.notebooks:
        nb = nbformat.read(path, as_version=4)
        if update(nb, entries):
            stale.append(path)
            if not args.check:
                nbformat.write(nb, path)
                print(f"updated {path}")
    if args.check and stale:
        print("out of date (run tools/chapter_glossaries.py on them): " + ", ".join(map(str, stale)))
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
