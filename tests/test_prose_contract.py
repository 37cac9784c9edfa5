"""The prose contract: every number typed by hand in the book's text is bound to a computation or listed.

``tools/prose_numbers.py`` finds the numbers typed by hand in the Markdown of every chapter, page, exercise
notebook and lab; a number shown through ``{glue:text}`` is bound to its computation and is not one of them. Each
of the others must be listed in its page's manifest (``tests/prose_manifest/<page>.yml``, format in
``tools/prose_manifest.py``) with its kind and source, and the source is checked: the code line that sets a
parameter still exists and holds the number, a rounding of a glued value still rounds to it, a printed number is
still printed. A new unlisted number fails, and so does an entry whose number left the text.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tools"))
import prose_manifest as contract  # noqa: E402  (tools/prose_manifest.py: the manifests and their checks)
import prose_numbers as numbers  # noqa: E402  (tools/prose_numbers.py: the finder)

PAGES = contract.contract_pages()
CHAPTER = REPO / "book" / "ch01_positioning_and_errors.ipynb"
#: Pages whose manifests still hold ``kind: TODO`` entries, each with the reason (one line a page: the page, two
#: spaces, the reason). On such a page every other number must be bound, and the TODO entries must say in ``why``
#: what computes them; a page that has none left must leave the list, so it only shrinks.
PENDING_FILE = REPO / "tests" / "prose_pending.txt"
PENDING = {line.split("  ", 1)[0].strip(): line.split("  ", 1)[1].strip()
           for line in PENDING_FILE.read_text(encoding="utf-8").splitlines()
           if line.strip() and not line.startswith("#")}


def _todo(entry: dict) -> bool:
    return entry.get("kind") == "TODO"


@pytest.mark.parametrize("page", PAGES, ids=[p.relative_to(REPO).as_posix() for p in PAGES])
def test_every_hand_typed_number_is_bound_or_listed(page):
    report = contract.check_page(page)
    relative = page.relative_to(REPO).as_posix()
    if relative in PENDING:
        todo = [e for e, _ in report.broken if _todo(e)]
        assert todo, f"{relative} has no TODO entry left: remove it from {PENDING_FILE.name}"
        unexplained = [e["number"] for e in todo if not str(e.get("why", "")).strip()]
        assert not unexplained, f"{relative}: TODO entries must say in 'why' what computes them: {unexplained}"
        report.broken[:] = [(e, p) for e, p in report.broken if not _todo(e)]
    lines = []
    for occ in report.unclassified:
        entry = contract.draft_entry(occ, [o for o in contract.occurrences(page) if o.token == occ.token])
        lines.append(f"unclassified (cell {occ.cell}): {occ.token!r} in ...{occ.sentence(60)}...\n"
                     f"    draft: {entry}")
    lines += [f"stale entry (its number left the text): {e['number']!r} in {e['text']!r}" for e in report.stale]
    lines += [f"entry {e['number']!r} in {e['text']!r}: {problem}" for e, problem in report.broken]
    assert not lines, (f"{report.page}: {len(lines)} problems with its hand-typed numbers "
                       f"(bind them with glue, or list them in {contract.manifest_path(report.page)}; "
                       f"`python tools/prose_manifest.py --draft {report.page}` drafts the entries):\n"
                       + "\n".join(lines))


def test_every_pending_page_exists():
    pages = {p.relative_to(REPO).as_posix() for p in PAGES}
    assert set(PENDING) <= pages, f"pending pages that are not pages: {sorted(set(PENDING) - pages)}"


def test_every_manifest_belongs_to_a_page():
    pages = {contract.manifest_path(p.relative_to(REPO).as_posix()) for p in PAGES}
    orphans = [m for m in contract.MANIFEST_DIR.rglob("*.yml") if m not in pages]
    assert not orphans, f"manifests of pages that no longer exist: {orphans}"


def test_the_finder_skips_glue_math_code_and_small_counting_words():
    text = ("A ping every 10 s for 1500 s, {glue:text}`x:.1f` m, $r = 2500$ m, `n_runs=300`, "
            "{cite}`paper2019` and 7 runs; in 2019 a 2 % error, chapter 6, and −0.4 m.")
    tokens = [t for t, *_ in numbers.hand_numbers_in_text(text)]
    assert tokens == ["1500", "2 %", "−0.4"]


def test_rounding_is_checked_to_the_digits_typed():
    assert contract.rounds_to("0.63", 0.6349)
    assert not contract.rounds_to("0.63", 0.6351)
    assert contract.rounds_to("290", 288.9)             # an integer with trailing zeros: its significant figures
    assert not contract.rounds_to("280", 288.9)
    assert contract.rounds_to("2 %", 0.0204)            # a percent from a fraction
    assert contract.rounds_to("3", 3000.0, scale=0.001)
    assert contract.rounds_to("−1.3", 1.3)              # the sign is the sentence's
    assert not contract.rounds_to("1.30", 1.294)


def test_an_entry_whose_source_changed_is_reported():
    page = CHAPTER.relative_to(REPO).as_posix()
    gone = {"number": "1470", "text": "x", "kind": "parameter", "code": "assumed_speed = 1234.0"}
    assert "no code line contains" in contract.check_entry(page, gone)
    wrong_glue = {"number": "9.9", "text": "x", "kind": "rounding", "glue": "ch01_dc_dT"}
    assert "is not a rounding of glue" in contract.check_entry(page, wrong_glue)
    missing = {"number": "5", "text": "x", "kind": "paper", "paper": "D", "place": "TODO"}
    assert "needs its 'place'" in contract.check_entry(page, missing)
    assert "is not one of" in contract.check_entry(page, {"number": "5", "text": "x", "kind": "TODO"})


def test_an_entry_names_one_place_in_the_text():
    occ = next(o for o in contract.occurrences(CHAPTER) if o.token == "1470")
    assert contract.covers({"number": "1470", "text": occ.flat[occ.start - 8:occ.end + 4]}, occ)
    assert not contract.covers({"number": "1470", "text": "assumes 1470 km"}, occ)
    assert not contract.covers({"number": "147", "text": "assumes 1470"}, occ)
