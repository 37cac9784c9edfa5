"""The strict book build: exit code 0, no warning or error in its output, every page of the
table of contents built, and HTML that loads nothing from outside the book.

The build runs once per session (fixture ``book_build`` in conftest.py) with the command of
``make book``; its full log is kept in ``_build/book-build.log``.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from book_paths import BUILD_LOG, HTML_DIR, toc_docnames

pytestmark = pytest.mark.book

# Lines that say WARNING or ERROR but come from outside the book, with the reason.
KNOWN_NOISE = [
    # ipykernel >= 7 logs this when a kernel is started over TCP (jupyter-cache/nbclient do so on
    # the loopback); it is the kernel's log, not a Sphinx warning.
    re.compile(r"^\[IPKernelApp\] WARNING \| Kernel is running over TCP without encryption"),
]
PROBLEM = re.compile(r"\b(WARNING|ERROR|CRITICAL)\b|Traceback \(most recent call last\)")

VENDOR = HTML_DIR / "_static" / "_vendor"


def _problem_lines(lines: list[str]) -> list[str]:
    return [ln for ln in lines if PROBLEM.search(ln) and not any(p.search(ln) for p in KNOWN_NOISE)]


def test_build_exit_code_is_zero(book_build):
    if book_build.returncode != 0:
        problems = _problem_lines(book_build.lines)
        shown = "\n".join(problems[:80]) or "\n".join(book_build.lines[-60:])
        pytest.fail(
            f"`jupyter-book build --all -W -n --keep-going .` exited with {book_build.returncode} "
            f"(full log: {BUILD_LOG}):\n{shown}",
            pytrace=False,
        )


def test_build_output_has_no_warning_or_error(book_build):
    problems = _problem_lines(book_build.lines)
    if problems:
        pytest.fail(
            f"{len(problems)} warning/error line(s) in the build output (full log: {BUILD_LOG}):\n"
            + "\n".join(problems[:200]),
            pytrace=False,
        )


@pytest.mark.parametrize("docname", toc_docnames())
def test_toc_page_was_built(book_build, docname):
    page = HTML_DIR / f"{docname}.html"
    assert page.is_file(), f"{docname} is in _toc.yml but {page.relative_to(HTML_DIR.parent.parent)} was not built"


# --- offline HTML ---------------------------------------------------------------------------

_EXTERNAL = r"""(?:https?:)?//"""
_TAG_URL = re.compile(
    r"""<(?P<tag>script|link|img|iframe|source|audio|video|embed|object)\b[^>]*?\s"""
    r"""(?P<attr>src|href|data|data-jupyter-widgets-cdn)\s*=\s*["'](?P<url>""" + _EXTERNAL + r"""[^"']*)""",
    re.IGNORECASE,
)
_CSS_URL = re.compile(r"""(?:url\(\s*["']?|@import\s+["'])(?P<url>""" + _EXTERNAL + r"""[^"')\s]*)""", re.IGNORECASE)


def _html_pages() -> list[Path]:
    return sorted(p for p in HTML_DIR.rglob("*.html") if VENDOR not in p.parents)


def test_html_loads_nothing_from_outside(book_build):
    pages = _html_pages()
    assert pages, f"no HTML in {HTML_DIR}"
    offenders = []
    for page in pages:
        text = page.read_text(encoding="utf-8", errors="replace")
        for m in _TAG_URL.finditer(text):
            offenders.append(f"{page.relative_to(HTML_DIR)}: <{m['tag']} {m['attr']}={m['url']}>")
        for m in re.finditer(r"<style\b[^>]*>(.*?)</style>", text, re.S | re.I):
            offenders += [f"{page.relative_to(HTML_DIR)}: <style> {u['url']}" for u in _CSS_URL.finditer(m[1])]
    for css in sorted((HTML_DIR / "_static").rglob("*.css")):
        for m in _CSS_URL.finditer(css.read_text(encoding="utf-8", errors="replace")):
            offenders.append(f"{css.relative_to(HTML_DIR)}: {m['url']}")
    if offenders:
        pytest.fail("the built HTML loads from outside the book:\n" + "\n".join(offenders[:100]), pytrace=False)


def test_vendored_assets_are_in_the_build(book_build):
    for rel in ("mathjax/tex-mml-chtml.js", "requirejs/require.js",
                "jupyter-widgets/embed-amd.js", "jupyter-widgets/widgets-setup.js"):
        assert (VENDOR / rel).is_file(), f"{VENDOR / rel} missing: book/_ext/offline_assets.py did not stage it"
    # Pages with math load the local MathJax, with a path that works from their directory.
    for page in _html_pages():
        text = page.read_text(encoding="utf-8", errors="replace")
        for m in re.finditer(r'<script[^>]*\ssrc="([^"]*(?:mathjax|require|embed-amd)[^"]*)"', text):
            target = (page.parent / m[1].split("?")[0]).resolve()
            assert target.is_file(), f"{page.relative_to(HTML_DIR)} loads {m[1]}, which does not exist"
