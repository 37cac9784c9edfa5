#!/usr/bin/env python3
"""Find every number typed by hand in the prose of the book, the exercises and the labs.

A number in a page's text either comes from a computation (then it is bound to it with myst-nb's ``glue``, or
printed by a cell) or is a fixed fact (a parameter the chapter sets, a paper's figure, a constant, a definition).
This module finds the numerals of the Markdown cells (of a notebook) or of a Markdown page that are NOT inside a
glue role, inline or display math, a code span, a citation or cross-reference role, a link target, a directive
option or a heading; each comes with its place in the cell's text, so that ``tools/prose_manifest.py`` can say
where it comes from and ``tests/test_prose_contract.py`` can hold every one of them to its source.

    python tools/prose_numbers.py book/                 # every notebook and .md under book/
    python tools/prose_numbers.py book/ch04*.ipynb      # one chapter
    python tools/prose_numbers.py --count book/ exercises/

Output: FILE:CELL  NUMBER  ... the sentence ...   (cells counted from 0, as nbformat does).

Small counting words (the integers 0 to 12, list numbers) and years (1900-2099) are not reported: they are the
words of a sentence, not results.
"""

from __future__ import annotations

import json
import re
import sys
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

# The pages the contract covers, as globs from the repository root.
PAGE_GLOBS = ("book/*.ipynb", "book/*.md", "exercises/*.ipynb", "exercises/*.md",
              "exercises/labs/**/*.ipynb", "exercises/labs/**/*.md")

STRIP = [
    # A block a program writes and its own test checks against its data (the appendix's benchmark table, from
    # benchmarks/results.json, checked by tests/test_benchmarks.py): generated, not typed by hand.
    re.compile(r"<!-- ([A-Z][A-Z-]*):START -->.*?<!-- \1:END -->", re.S),
    re.compile(r"\{glue(?::[a-z]*)?\}`[^`]*`"),                                      # glued values
    re.compile(r"\{(?:cite(?::[a-z]+)?|doc|ref|numref|eq|term|download|prf:ref|label|math)\}`[^`]*`"),
    re.compile(r"\$\$.*?\$\$", re.S),                                                # display math
    re.compile(r"\\begin\{.*?\\end\{[^}]*\}", re.S),
    re.compile(r"(?<!\\)\$[^$\n]+?\$"),                                              # inline math
    re.compile(r"```.*?```", re.S),                    # fenced blocks (directives' options stay out too)
    re.compile(r"`[^`\n]*`"),                                                        # code spans
    re.compile(r"\]\([^)]*\)"),                                                      # link targets
    re.compile(r"^\s*:[a-z-]+:.*$", re.M),                                           # directive options
    re.compile(r"^#+ .*$", re.M),                                                    # headings
    re.compile(r"<[^>]+>"),                                                          # html tags
    re.compile(r"^\([A-Za-z0-9_:-]+\)=\s*$", re.M),                                 # MyST targets (label)=
]
# a number, with thousands written "1,500" or "10 000" (a space or a thin space before each group of three)
NUMBER = re.compile(r"(?<![\w.])[-−+]?\d[\d,]*(?:(?<=\d)[ \u2009\u202f]\d{3}(?![\w.]))*(?:\.\d+)?"
                    r"(?:\s?(?:%|°|×|x(?=\s)))?(?![\w])")
BORING = re.compile(r"^(?:[0-9]|1[0-2])$")            # small counting words: one to twelve, list numbers
YEAR = re.compile(r"^(?:19|20)\d\d$")


@dataclass(frozen=True)
class Occurrence:
    """One hand-typed number: the page, the cell (0-based; 0 for a Markdown page), the token and its place."""

    page: str           # path relative to the repository root, with "/"
    cell: int
    token: str          # as typed, e.g. "1,500", "2 %", "−0.4"
    start: int          # offset of the token in ``flat`` (the cell's text with runs of whitespace made one space)
    end: int
    flat: str           # the cell's whole text, whitespace collapsed (glue roles and math included)

    @property
    def value(self) -> float:
        return token_value(self.token)

    @property
    def percent(self) -> bool:
        return self.token.endswith("%")

    def sentence(self, width: int = 160) -> str:
        """The sentence around the number (at most ``width`` characters either side)."""
        start = max(self.flat.rfind(". ", 0, self.start) + 2, self.start - width, 0)
        end = self.flat.find(". ", self.end)
        end = len(self.flat) if end < 0 else min(end + 1, self.end + width)
        return self.flat[start:end].strip()


def token_value(token: str) -> float:
    """The number a token stands for: ``"1,500"`` -> 1500, ``"−2 %"`` -> -2, ``"3x"`` -> 3."""
    core = re.sub(r"\s?(?:%|°|×|x)$", "", token.strip()).replace("−", "-").replace(",", "")
    core = re.sub(r"[ \u2009\u202f]", "", core)
    return float(core)


def decimals(token: str) -> int:
    """Digits after the decimal point as typed (``"0.49"`` -> 2, ``"1500"`` -> 0)."""
    core = re.sub(r"\s?(?:%|°|×|x)$", "", token.strip())
    return len(core.split(".", 1)[1]) if "." in core else 0


def markdown_cells(path: Path):
    """``(cell index, text)`` of every Markdown cell of a notebook; ``(0, text)`` for a Markdown page."""
    if path.suffix == ".ipynb":
        nb = json.loads(path.read_text(encoding="utf-8"))
        for i, cell in enumerate(nb.get("cells", [])):
            if cell.get("cell_type") == "markdown":
                yield i, "".join(cell.get("source", ""))
    else:
        yield 0, path.read_text(encoding="utf-8")


def _collapse(text: str) -> tuple[str, list[int]]:
    """``text`` with every run of whitespace made one space, and the offset in it of each character of ``text``."""
    out: list[str] = []
    where: list[int] = []
    previous_space = False
    for ch in text:
        space = ch.isspace()
        if space and previous_space:
            where.append(len(out) - 1)
            continue
        where.append(len(out))
        out.append(" " if space else ch)
        previous_space = space
    where.append(len(out))
    return "".join(out), where


def hand_numbers_in_text(text: str):
    """``(token, start, end, flat)``: the hand-typed numbers of one cell's text, placed in its collapsed text."""
    masked = text
    for pattern in STRIP:
        masked = pattern.sub(lambda m: " " * len(m.group(0)), masked)
    flat, where = _collapse(text)
    for m in NUMBER.finditer(masked):
        token = m.group(0).strip()
        start = m.start() + (len(m.group(0)) - len(m.group(0).lstrip()))
        if token.endswith(","):                      # "chapter 6, approximates": the comma is the sentence's
            token = token.rstrip(",")
        end = start + len(token)
        if not token or BORING.match(token.lstrip("-−+")) or YEAR.match(token):
            continue
        yield token, where[start], where[end - 1] + 1, flat


def occurrences(path: Path, root: Path = REPO) -> list[Occurrence]:
    """Every hand-typed number of a page."""
    rel = path.resolve().relative_to(root.resolve()).as_posix()
    return [Occurrence(rel, i, token, start, end, flat)
            for i, text in markdown_cells(path)
            for token, start, end, flat in hand_numbers_in_text(text)]


def contract_pages(root: Path = REPO) -> list[Path]:
    """Every page the prose contract covers, sorted."""
    found: set[Path] = set()
    for pattern in PAGE_GLOBS:
        found.update(p for p in root.glob(pattern)
                     if "_build" not in p.parts and ".ipynb_checkpoints" not in p.parts)
    return sorted(found)


def main(argv: list[str]) -> int:
    count_only = "--count" in argv
    args = [a for a in argv if not a.startswith("--")] or ["book"]
    files: list[Path] = []
    for a in args:
        p = Path(a)
        files += sorted(p.rglob("*.ipynb")) + sorted(p.rglob("*.md")) if p.is_dir() else [p]
    files = [f for f in files if "_build" not in f.parts and ".ipynb_checkpoints" not in f.parts]
    total = 0
    for f in files:
        rows = occurrences(f, Path.cwd()) if f.resolve().is_relative_to(Path.cwd()) else occurrences(f, f.parent)
        total += len(rows)
        if count_only:
            print(f"{len(rows):5d}  {f}")
            continue
        for row in rows:
            print(f"{f}:{row.cell}  {row.token}  ... {row.sentence()}")
    print(f"{total} hand-written numbers in {len(files)} files", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
