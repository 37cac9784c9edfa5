#!/usr/bin/env python3
"""The prose contract: every number typed by hand in the book is bound to a computation or listed with its source.

``tools/prose_numbers.py`` finds the numbers typed by hand in the Markdown of every page (book chapters and pages,
exercise notebooks, labs and their instructor notes). A number shown through a ``{glue:text}`` role is bound to its
computation and is not typed by hand. Every other one must be listed in the page's **manifest**, one YAML file per
page so that two people editing two chapters never touch the same manifest:

    tests/prose_manifest/<page path without its suffix>.yml
    e.g. tests/prose_manifest/book/ch05_multiplicative_noise.yml for book/ch05_multiplicative_noise.ipynb

Manifest format::

    page: book/ch01_positioning_and_errors.ipynb
    numbers:
    - number: '1500'                        # the token exactly as typed ("1,500", "2 %", "−0.4", "5x")
      text: a ping every 10 s for 1500 s    # words of the page around it (whitespace collapsed; glue roles
                                            #   and math as typed); it must contain the number, which it places
      kind: parameter                       # one of the kinds below
      code: duration = 1500.0               # ...and the fields that kind needs
      why: optional free text

Kinds and what the test checks (``check_page``):

``parameter``  a value the chapter sets. ``code``: a fragment of one line of the page's code cells (or of ``file``,
               a path from the repository root, for a value set in the library) that still exists and holds a
               literal equal to the number (``scale``: typed = literal x scale, e.g. 0.001 for "3 km" from
               ``3000.0``; a percent may be the literal x 100).
``rounding``   a rounding of a glued value. ``glue``: the glue name (``other_notebook_stem::name`` for another
               page's glue). The test reads the value stored in the page's committed outputs and checks that the
               typed number is that value rounded to the decimals typed, or, for an integer typed with trailing
               zeros ("300"), to its significant figures (``scale`` as above; a percent may be the fraction x 100;
               the sign is not compared: "2 m short" restates -2).
``printed``    a number a code cell prints. ``output``: a fragment of one committed text output of the page that
               holds it; the number must be one of the fragment's numbers, rounded as for ``rounding``.
``data``       a value of a committed data file. ``file`` (JSON) and ``key`` (dotted path, list indices as
               numbers); checked as a rounding.
``paper``      a paper's figure. ``paper``: A-E (the five papers, see /work/shared/papers.md and the book's
               bibliography) or a key of book/references.bib; ``place``: where in it (section, table, figure, eq.).
``constant``   a physical constant, a conversion or a standard value (e.g. 1500 m/s for sound in sea water).
               ``source``: what it is and where it comes from.
``definition`` a number that defines the example or the text (a chosen round value that no code sets, a bound
               the text states, a threshold). ``source``: what it defines.
``label``      a number that names something (an exercise, a chapter, a section of a book, a list item, a date).
               ``source``: what it names.

A number is unclassified when no entry matches it: the test fails and lists it with a draft entry. An entry that
matches no number any more (the text changed) fails too, as does an entry whose check fails (a code line that
changed, a glued value that no longer rounds to the number).

Drafting (for a page someone rewrote, or a new page)::

    python tools/prose_manifest.py --draft book/ch05_multiplicative_noise.ipynb [more pages]
    python tools/prose_manifest.py --check [pages]          # the test's verdict, page by page

``--draft`` keeps every entry that still matches a number, drops the stale ones (and says which), and adds an entry
for each new number: a ``parameter`` when a code line sets that literal, a ``printed`` or ``rounding`` when an
output or a glued value shows it, ``paper`` when the sentence names a paper (the place left as ``TODO``), and
``kind: TODO`` otherwise. A draft is a proposal: read each added entry against the page (a literal in the code may be
another 20 than the text's), fill in every ``TODO``, and where a number restates a result, glue it instead.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from dataclasses import dataclass
from pathlib import Path

import yaml

sys.path.insert(0, str(Path(__file__).resolve().parent))
from prose_numbers import REPO, Occurrence, contract_pages, decimals, occurrences, token_value  # noqa: E402

MANIFEST_DIR = REPO / "tests" / "prose_manifest"
KINDS = {
    "parameter": ("code",),
    "rounding": ("glue",),
    "printed": ("output",),
    "data": ("file", "key"),
    "paper": ("paper", "place"),
    "constant": ("source",),
    "definition": ("source",),
    "label": ("source",),
}
PAPERS = {"A", "B", "C", "D", "E"}
LITERAL = re.compile(r"(?<![\w.])[-+]?(?:\d[\d_]*\.?\d*(?:[eE][-+]?\d+)?|\.\d+(?:[eE][-+]?\d+)?)(?![\w.])")
TEXT_NUMBER = re.compile(r"(?<![\w.])[-+−]?\d[\d,]*\.?\d*(?:[eE][-+]?\d+)?")


# ---------------------------------------------------------------------------------------------------------------
# What a page's notebook holds: code lines, text outputs, glued values.

@dataclass
class Notebook:
    code_lines: list[str]
    outputs: list[str]
    glue: dict[str, str]


def read_notebook(path: Path) -> Notebook:
    if path.suffix != ".ipynb":
        return Notebook([], [], {})
    nb = json.loads(path.read_text(encoding="utf-8"))
    lines: list[str] = []
    outputs: list[str] = []
    glue: dict[str, str] = {}
    for cell in nb.get("cells", []):
        if cell.get("cell_type") != "code":
            continue
        lines.extend("".join(cell.get("source", "")).splitlines())
        for out in cell.get("outputs", []):
            record = out.get("metadata", {}).get("scrapbook")
            data = out.get("data", {})
            if record:
                text = data.get(record.get("mime_prefix", "") + "text/plain")
                if text is not None:
                    glue[record["name"]] = "".join(text)
            elif out.get("output_type") == "stream":
                outputs.append("".join(out.get("text", "")))
            elif "text/plain" in data:
                outputs.append("".join(data["text/plain"]))
    return Notebook(lines, outputs, glue)


_NOTEBOOKS: dict[Path, Notebook] = {}


def notebook(path: Path) -> Notebook:
    if path not in _NOTEBOOKS:
        _NOTEBOOKS[path] = read_notebook(path)
    return _NOTEBOOKS[path]


def glued_value(text: str) -> float | None:
    """The number a stored glue record shows (``"3.6"``, ``"np.float64(3.6)"``, ``"'0.63'"``), or None."""
    text = text.strip().strip("'\"")
    text = re.sub(r"^np\.\w+\((.*)\)$", r"\1", text).strip("'\"")
    try:
        return float(text.replace("−", "-").replace(",", ""))
    except ValueError:
        return None


# ---------------------------------------------------------------------------------------------------------------
# The checks.

def rounds_to(token: str, value: float, scale: float = 1.0) -> bool:
    """Is the typed ``token`` the number ``value`` (times ``scale``) rounded as typed?

    Rounded to the decimals typed; an integer typed with trailing zeros ("300", "1,200") may also be rounded to its
    significant figures. The sign is not compared; a percent token may be a fraction x 100.
    """
    typed = abs(token_value(token))
    candidates = [abs(value * scale)]
    if token.endswith("%"):
        candidates.append(abs(value * scale * 100))
    ndp = decimals(token)
    for v in candidates:
        if abs(float(format(v, f".{ndp}f")) - typed) <= 1e-9 * max(1.0, typed):
            return True
        if ndp == 0 and typed >= 10:
            digits = str(int(typed))
            zeros = len(digits) - len(digits.rstrip("0"))
            for j in range(1, zeros + 1):
                if abs(round(v, -j) - typed) <= 1e-9 * typed:
                    return True
    return False


def literal_matches(token: str, literal: str, scale: float = 1.0) -> bool:
    typed = token_value(token)
    value = float(literal.replace("_", ""))
    options = [value * scale]
    if token.endswith("%"):
        options.append(value * scale * 100)
    return any(abs(abs(v) - abs(typed)) <= 1e-9 * max(1.0, abs(typed)) for v in options)


def _page_path(page: str) -> Path:
    return REPO / page


def _resolve_glue(page: str, name: str) -> tuple[float | None, str]:
    if "::" in name:
        stem, key = name.split("::", 1)
        matches = sorted(REPO.glob(f"**/{stem}.ipynb"))
        matches = [m for m in matches if "_build" not in m.parts and ".ipynb_checkpoints" not in m.parts]
        if not matches:
            return None, f"no notebook {stem}.ipynb for glue {name!r}"
        store = notebook(matches[0]).glue
    else:
        key = name
        store = notebook(_page_path(page)).glue
    if key not in store:
        return None, f"glue {name!r} is not in the committed outputs"
    value = glued_value(store[key])
    if value is None:
        return None, f"glue {name!r} stores {store[key]!r}, not a number"
    return value, ""


def _json_key(data, key: str):
    for part in key.split("."):
        data = data[int(part)] if isinstance(data, list) else data[part]
    return data


def check_entry(page: str, entry: dict) -> str:
    """The problem with one manifest entry ('' when it holds): its fields, and its source against the page."""
    token = str(entry.get("number", ""))
    kind = entry.get("kind")
    if kind not in KINDS:
        return f"kind {kind!r} is not one of {sorted(KINDS)}"
    for field in KINDS[kind]:
        value = str(entry.get(field, "")).strip()
        if not value or value.upper() == "TODO":
            return f"{kind} entry needs its {field!r}"
    try:
        scale = float(entry.get("scale", 1.0))
    except (TypeError, ValueError):
        return f"scale must be a number; got {entry.get('scale')!r}"
    if kind == "parameter":
        fragment = str(entry["code"])
        where = REPO / entry["file"] if "file" in entry else _page_path(page)
        if not where.exists():
            return f"file {entry['file']!r} does not exist"
        lines = (notebook(where).code_lines if where.suffix == ".ipynb"
                 else where.read_text(encoding="utf-8").splitlines())
        if not any(fragment in line for line in lines):
            return f"no code line contains {fragment!r} any more"
        if not any(literal_matches(token, lit, scale) for lit in LITERAL.findall(fragment)):
            return f"the code {fragment!r} holds no literal equal to {token}"
    elif kind == "rounding":
        value, problem = _resolve_glue(page, str(entry["glue"]))
        if problem:
            return problem
        if not rounds_to(token, value, scale):
            return f"{token} is not a rounding of glue {entry['glue']!r} = {value!r}"
    elif kind == "printed":
        fragment = str(entry["output"])
        texts = notebook(_page_path(page)).outputs
        if not any(fragment in re.sub(r"\s+", " ", t) or fragment in t for t in texts):
            return f"no committed output contains {fragment!r} any more"
        numbers = TEXT_NUMBER.findall(fragment)
        if not any(rounds_to(token, token_value(n), scale) for n in numbers if re.search(r"\d", n)):
            return f"{token} is not a rounding of a number of the output {fragment!r}"
    elif kind == "data":
        path = REPO / entry["file"]
        if not path.exists():
            return f"data file {entry['file']!r} does not exist"
        try:
            value = float(_json_key(json.loads(path.read_text(encoding="utf-8")), str(entry["key"])))
        except (KeyError, IndexError, ValueError, TypeError) as exc:
            return f"key {entry['key']!r} of {entry['file']} gives no number ({exc!r})"
        if not rounds_to(token, value, scale):
            return f"{token} is not a rounding of {entry['file']}:{entry['key']} = {value!r}"
    elif kind == "paper":
        paper = str(entry["paper"])
        if paper not in PAPERS and not re.search(r"@\w+\{" + re.escape(paper) + ",",
                                                   (REPO / "book" / "references.bib").read_text(encoding="utf-8")):
            return f"paper {paper!r} is neither A-E nor a key of book/references.bib"
    return ""


# ---------------------------------------------------------------------------------------------------------------
# Matching entries to the numbers of a page.

def manifest_path(page: str) -> Path:
    return MANIFEST_DIR / Path(page).with_suffix(".yml")


def load_manifest(page: str) -> list[dict]:
    path = manifest_path(page)
    if not path.exists():
        return []
    data = yaml.safe_load(path.read_text(encoding="utf-8")) or {}
    if data.get("page", page) != page:
        raise ValueError(f"{path} says page {data.get('page')!r}, but it is the manifest of {page!r}")
    entries = data.get("numbers") or []
    for entry in entries:
        entry["number"] = str(entry.get("number", ""))
        entry["text"] = re.sub(r"\s+", " ", str(entry.get("text", ""))).strip()
    return entries


def covers(entry: dict, occ: Occurrence) -> bool:
    """Does ``entry`` name this occurrence: same token, and its text around the token's place?"""
    if entry["number"] != occ.token or not entry["text"]:
        return False
    text = entry["text"]
    i = occ.flat.find(text, max(0, occ.end - len(text)))
    while 0 <= i <= occ.start:
        if i + len(text) >= occ.end:
            return True
        i = occ.flat.find(text, i + 1)
    return False


@dataclass
class PageReport:
    page: str
    unclassified: list[Occurrence]
    stale: list[dict]
    broken: list[tuple[dict, str]]
    bound: dict[str, int]


def check_page(page_path: Path) -> PageReport:
    page = page_path.resolve().relative_to(REPO).as_posix()
    entries = load_manifest(page)
    used = [False] * len(entries)
    unclassified: list[Occurrence] = []
    bound: dict[str, int] = {}
    for occ in occurrences(page_path):
        for k, entry in enumerate(entries):
            if covers(entry, occ):
                used[k] = True
                bound[entry.get("kind", "?")] = bound.get(entry.get("kind", "?"), 0) + 1
                break
        else:
            unclassified.append(occ)
    stale = [e for e, u in zip(entries, used) if not u]
    broken = [(e, p) for e, u in zip(entries, used) if u for p in [check_entry(page, e)] if p]
    return PageReport(page, unclassified, stale, broken, bound)


# ---------------------------------------------------------------------------------------------------------------
# Drafting.

def excerpt(occ: Occurrence, same: list[Occurrence]) -> str:
    """A few words around the number, long enough to tell it from the page's other occurrences of the same token
    (the words before it, after it, or both; a table row "| 1000 | 1000 |" needs the one-sided kinds)."""
    flat = occ.flat

    def left(words: int) -> int:
        start = occ.start
        for _ in range(words):
            j = flat.rfind(" ", 0, max(0, start - 1))
            if j < 0:
                return 0
            start = j + 1
        return start

    def right(words: int) -> int:
        end = occ.end
        for _ in range(words):
            j = flat.find(" ", end + 1)
            if j < 0:
                return len(flat)
            end = j
        return end

    text = flat[left(2):right(2)].strip()
    for words in (2, 3, 4, 6, 9, 14, 30):
        for a, b in ((left(words), right(words)), (left(words), occ.end), (occ.start, right(words))):
            candidate = flat[a:b].strip()
            entry = {"number": occ.token, "text": candidate}
            if sum(covers(entry, other) for other in same) == 1:
                return candidate
    return text


def _fragment_around(line: str, m: re.Match) -> str:
    """The ``name = literal`` (or ``name=literal``) part of a code line, else the stripped line."""
    left = line[:m.start()]
    a = re.search(r"[\w.\[\]'\"]+\s*[=:]\s*[(\[]?\s*$", left)
    if a:
        return line[a.start():m.end()].strip()
    return line.strip()


def draft_entry(occ: Occurrence, same: list[Occurrence]) -> dict:
    entry: dict = {"number": occ.token, "text": excerpt(occ, same)}
    page_path = _page_path(occ.page)
    nb = notebook(page_path)
    significant = decimals(occ.token) > 0 or len(str(int(abs(occ.value))).strip("0")) >= 2
    # 1. a literal a code line sets
    best = None
    for line in nb.code_lines:
        code = line.split("#", 1)[0]
        for m in LITERAL.finditer(code):
            literal = float(m.group(0).replace("_", ""))
            wanted = occ.value / 100 if occ.percent else occ.value
            if abs(literal - wanted) > 1e-9 * max(1.0, abs(wanted)):
                continue
            fragment = _fragment_around(code, m)
            if fragment == code.strip():          # not `name = literal`: a literal in passing, likely another number
                continue
            score = len(fragment) < 60
            if best is None or score > best[0]:
                best = (score, fragment)
    if best is not None:
        entry.update(kind="parameter", code=best[1])
        return entry
    # 2. a glued value that rounds to it
    if significant:
        for name, text in nb.glue.items():
            value = glued_value(text)
            if value is not None and rounds_to(occ.token, value):
                entry.update(kind="rounding", glue=name)
                return entry
        # 3. a printed number
        for out in nb.outputs:
            for line in out.splitlines():
                for n in TEXT_NUMBER.finditer(line):
                    if rounds_to(occ.token, token_value(n.group(0))):
                        lo, hi = max(0, n.start() - 25), min(len(line), n.end() + 10)
                        entry.update(kind="printed", output=line[lo:hi].strip())
                        return entry
    sentence = occ.sentence()
    paper = re.search(r"\bpapers? ([A-E])\b", sentence)
    if paper:
        entry.update(kind="paper", paper=paper.group(1), place="TODO")
        return entry
    entry.update(kind="TODO", source="TODO")
    return entry


def draft(page_path: Path) -> tuple[list[dict], list[dict], int]:
    """The page's manifest entries after drafting: kept + new; and the stale entries dropped; and the new count."""
    page = page_path.resolve().relative_to(REPO).as_posix()
    entries = load_manifest(page)
    occs = occurrences(page_path)
    used = [False] * len(entries)
    result: list[dict] = []
    added = 0
    for occ in occs:
        for k, entry in enumerate(entries):
            if covers(entry, occ):
                if not used[k]:
                    result.append(entry)
                used[k] = True
                break
        else:
            same = [o for o in occs if o.token == occ.token]
            result.append(draft_entry(occ, same))
            added += 1
    stale = [e for e, u in zip(entries, used) if not u]
    return result, stale, added


def dump(page: str, entries: list[dict]) -> str:
    head = (f"# Prose manifest of {page}: every number typed by hand in its text, with its source.\n"
            f"# Format and kinds: tools/prose_manifest.py (draft with --draft, verdict with --check).\n")
    body = yaml.safe_dump({"page": page, "numbers": entries}, sort_keys=False, allow_unicode=True, width=118)
    return head + body


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--draft", action="store_true", help="write a draft manifest for each page")
    parser.add_argument("--stdout", action="store_true", help="with --draft: print instead of writing")
    parser.add_argument("--check", action="store_true", help="check pages against their manifests")
    parser.add_argument("pages", nargs="*", help="pages (default: every page of the contract)")
    args = parser.parse_args(argv)
    pages = [Path(p).resolve() for p in args.pages] or contract_pages()
    status = 0
    for path in pages:
        page = path.relative_to(REPO).as_posix()
        if args.draft:
            entries, stale, added = draft(path)
            text = dump(page, entries)
            if args.stdout:
                print(text)
            elif entries or manifest_path(page).exists():
                manifest_path(page).parent.mkdir(parents=True, exist_ok=True)
                manifest_path(page).write_text(text, encoding="utf-8")
            todo = sum(1 for e in entries if "TODO" in (e.get("kind"), e.get("place"), e.get("source")))
            print(f"{page}: {len(entries)} entries ({added} new, {todo} with TODO), {len(stale)} stale dropped",
                  file=sys.stderr)
            for e in stale:
                print(f"    dropped: {e['number']!r} in {e['text']!r}", file=sys.stderr)
        else:
            report = check_page(path)
            problems = len(report.unclassified) + len(report.stale) + len(report.broken)
            status |= bool(problems)
            print(f"{page}: bound {sum(report.bound.values())} {report.bound}, {len(report.unclassified)} "
                  f"unclassified, {len(report.stale)} stale, {len(report.broken)} broken")
            for occ in report.unclassified:
                print(f"    unclassified cell {occ.cell}: {occ.token!r} ... {occ.sentence(60)}")
            for e in report.stale:
                print(f"    stale: {e['number']!r} in {e['text']!r}")
            for e, p in report.broken:
                print(f"    broken: {e['number']!r} in {e['text']!r}: {p}")
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
