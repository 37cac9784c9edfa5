"""Sphinx extension: what a reader meets on every page, in the HTML book and (for the code listings) in the PDF.

- **No plumbing in the listings.** A chapter's code cells end with ``glue(...)`` calls that hand numbers to the
  text (myst-nb), and cells with live widgets carry ``# NBVAL_IGNORE_OUTPUT`` for the notebook tests. The reader
  needs neither: :func:`strip_plumbing` removes them from the code *as shown* (HTML and PDF); the notebook keeps
  them, so nbval and ``glue`` work as before. A cell left with nothing to show loses its input block.
- **Downloads that lead to a live notebook** (HTML): the page's download menu offers the chapter's ``.ipynb``
  (the theme's), the PDF edition (when ``make pdf`` has built it; the theme's own ".pdf" only prints the page) and
  the wheel of the library the book was built with, copied into the HTML build (``_downloads/``; built into
  ``dist/`` by ``make dist`` or, if missing, here). The ``uwtutor-run-it`` directive writes how to install the
  wheel and open a chapter in JupyterLab; the frozen widgets' notes point at the same wheel.
- **Figures that open full size** (HTML): a tap on a figure, a frozen widget's picture or an animation's frame
  opens it at its own size (its display size: a notebook figure is a PNG of twice its pixels, sharp on a 3x screen,
  uwtutor.plotting.use_sharp_figures) in a view that pans both ways; Escape, the close button or a tap closes it.
  A figure given a width and a height keeps the width only (:class:`FiguresKeepTheirProportions`), so that a narrow
  column does not squash it. Lightbox extensions (lightbox2 and the like) fit the image to the window, which on a phone leaves the
  text as small as on the page: the point here is the opposite, so the dozen lines are our own.
- **Author-year labels in the bibliography** (HTML and PDF): the text cites "Zhu et al., 2019"
  (``bibtex_reference_style: author_year``), and the list now labels each entry the same way, instead of pybtex's
  alpha labels ("[ZHGL19]"): the formatting style ``uwtutor_author_year`` (``bibtex_default_style`` in _config.yml).
- **One declaration per inline script** (HTML): Sphinx 7.4 adds an inline script registered after the builder
  started twice (once as ``_JavaScript(None)`` when it is registered, once as ``_JavaScript('')`` in
  ``prepare_writing``; they compare unequal). sphinx-thebe registers ``const THEBE_JS_URL = ...`` that way, and the
  second copy throws "Identifier 'THEBE_JS_URL' has already been declared" on every page; sphinx-togglebutton's
  selector is doubled the same way. Each page keeps the first copy.
"""

from __future__ import annotations

import ast
import re
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

from docutils import nodes
from docutils.parsers.rst import Directive
from sphinx.application import Sphinx
from sphinx.transforms import SphinxTransform
from sphinx.util import logging

__version__ = "1.0"
logger = logging.getLogger(__name__)

ROOT = Path(__file__).resolve().parents[2]
DOWNLOADS = "_downloads"  # folder of the HTML build that holds the wheel and the PDF edition
PDF_EDITION = ROOT / "_build" / "pdf" / "uwtutor.pdf"  # written by tools/build_pdf.py (make pdf)
NBVAL_MARKER = re.compile(r"^\s*#\s*NBVAL_[A-Z_]+\s*$")


# --- plumbing out of the listings --------------------------------------------------------------------------------

def _is_glue(stmt: ast.stmt, names: set[str]) -> bool:
    """A statement that only hands values to the text: a call of ``glue`` (or of a function in ``names`` that does
    nothing else), the import of ``glue``, the definition of such a function, or a block of nothing else. A new such
    function's name is added to ``names``; so is one that computes values (assignments, no ``return``) for a glue
    call."""
    if isinstance(stmt, ast.Expr) and isinstance(stmt.value, ast.Call):
        func = stmt.value.func
        return (isinstance(func, ast.Name) and func.id in names) or (
            isinstance(func, ast.Attribute) and func.attr == "glue")
    if isinstance(stmt, ast.ImportFrom):
        return all(alias.name == "glue" for alias in stmt.names)
    if isinstance(stmt, (ast.For, ast.If, ast.With)):
        inner = list(stmt.body) + list(getattr(stmt, "orelse", []))
        return all(_is_glue(s, names) for s in inner)
    if isinstance(stmt, ast.FunctionDef):
        # only glue, or values computed (assignments, no return) for a glue call at the end
        body = [s for s in stmt.body if not (isinstance(s, ast.Expr) and isinstance(s.value, ast.Constant))]
        glued = [s for s in body if _is_glue(s, names)]
        rest = [s for s in body if s not in glued]
        if glued and all(isinstance(s, (ast.Assign, ast.AnnAssign)) for s in rest):
            names.add(stmt.name)
            return True
    return False


def strip_plumbing(source: str, glue_names: set[str] | None = None) -> str:
    """The code of a cell as a reader sees it: without ``glue`` calls and nbval markers.

    A block (``for``, ``if``, ``with``) whose body is only glue goes with it, and so does a function that only calls
    ``glue``, with every call of it: pass the same set as ``glue_names`` for the cells of one notebook, in order, so
    that a later cell knows the functions of an earlier one. A comment line right above a removed statement goes too
    when it mentions glue. Code that is not valid Python loses only its markers.

    Examples
    --------
    >>> print(strip_plumbing('# NBVAL_IGNORE_OUTPUT\\nx = 2\\nglue("x", x, display=False)\\nx'))
    x = 2
    x
    >>> print(strip_plumbing('for k in (1, 2):\\n    glue(f"k{k}", k)\\ny = 1'))
    y = 1
    >>> names = set()
    >>> print(strip_plumbing('def g(name, v):\\n    glue(name, v)\\n\\nz = 3', names))
    z = 3
    >>> print(strip_plumbing('g("z", z)\\nprint(z)', names))
    print(z)
    """
    names = {"glue"} if glue_names is None else glue_names
    names.add("glue")
    lines = source.split("\n")
    drop = {i for i, line in enumerate(lines) if NBVAL_MARKER.match(line)}
    try:
        tree = ast.parse(source)
    except SyntaxError:
        tree = None

    def visit(body: list[ast.stmt]) -> None:
        gone = [s for s in body if _is_glue(s, names)]
        if len(gone) == len(body):  # a body cannot be empty: leave it whole
            gone = []
        for stmt in body:
            if stmt in gone:
                first, last = stmt.lineno - 1, stmt.end_lineno - 1
                drop.update(range(first, last + 1))
                above = first - 1
                while above >= 0 and lines[above].strip().startswith("#") and "glue" in lines[above].lower():
                    drop.add(above)
                    above -= 1
                continue
            for field in ("body", "orelse", "finalbody"):
                inner = getattr(stmt, field, None)
                if isinstance(inner, list) and inner and isinstance(inner[0], ast.stmt):
                    visit(inner)
            for handler in getattr(stmt, "handlers", []):
                visit(handler.body)

    if tree is not None:
        visit(tree.body)
    kept = [line for i, line in enumerate(lines) if i not in drop]
    text = re.sub(r"\n{3,}", "\n\n", "\n".join(kept))  # no double blank lines where a block went
    return text.strip("\n")


class FiguresKeepTheirProportions(SphinxTransform):
    """A notebook figure's PNG has twice its pixels and says its display size (width and height) in its output's
    metadata, which myst-nb puts on the image. Both as an inline style would squash it in a column narrower than its
    width (``max-width: 100%`` narrows it, the height stays): keep the width only, the height follows."""

    default_priority = 400

    def apply(self, **kwargs: Any) -> None:
        for image in self.document.findall(nodes.image):
            width, height = str(image.get("width", "")), str(image.get("height", ""))
            if width and height and not width.endswith("%"):
                del image["height"]


class HidePlumbing(SphinxTransform):
    """Strip glue calls and nbval markers from every notebook code cell as shown (HTML and PDF)."""

    default_priority = 400

    def apply(self, **kwargs: Any) -> None:
        names: set[str] = set()
        for source in list(self.document.findall(nodes.container)):
            if source.get("nb_element") != "cell_code_source":
                continue
            block = source.next_node(nodes.literal_block)
            if block is None:
                continue
            old = block.astext()
            new = strip_plumbing(old, names)
            if new == old:
                continue
            if new.strip():
                block.children = [nodes.Text(new)]
                block.rawsource = new
                continue
            cell = source.parent
            source.parent.remove(source)
            # A cell with neither code to show nor output (a cell of glue calls) goes altogether.
            if cell is not None and not any(isinstance(c, nodes.Element) for c in cell.children):
                cell.parent.remove(cell)


# --- author-year labels in the bibliography ------------------------------------------------------------------------

def author_year_label(entry: Any) -> str:
    """The label of a bibliography entry as the text cites it: "Zhu et al., 2019", "Zhou and Xi, 1990", "Urick,
    1983"; an entry without authors by its title ("<title>, 2019").

    Examples
    --------
    >>> from pybtex.database import Entry, Person
    >>> entry = Entry("article", fields={"year": "1990", "title": "T"}, persons={"author": [Person("Zhou, Donghua"),
    ...                                                                                 Person("Xi, Yugeng")]})
    >>> author_year_label(entry)
    'Zhou and Xi, 1990'
    """
    people = entry.persons.get("author") or entry.persons.get("editor") or []
    names = [" ".join(p.last_names) for p in people]
    if not names:
        who = entry.fields.get("organization") or str(entry.fields.get("title", entry.key)).replace("{", "").replace(
            "}", "")
    elif len(names) == 1:
        who = names[0]
    elif len(names) == 2:
        who = f"{names[0]} and {names[1]}"
    else:
        who = f"{names[0]} et al."
    year = entry.fields.get("year")
    return f"{who}, {year}" if year else who


def _register_bibliography_style() -> None:
    from pybtex.plugin import register_plugin
    from pybtex.style.formatting.alpha import Style as AlphaStyle
    from pybtex.style.labels import BaseLabelStyle

    class AuthorYearLabels(BaseLabelStyle):
        def format_labels(self, sorted_entries: Any) -> Any:
            labels = [author_year_label(e) for e in sorted_entries]
            count: dict[str, int] = {}
            for label in labels:
                count[label] = count.get(label, 0) + 1
            seen: dict[str, int] = {}
            for label in labels:  # two works of the same authors and year: 2019a, 2019b
                if count[label] > 1:
                    seen[label] = seen.get(label, 0) + 1
                    yield label + "abcdefghijklmnopqrstuvwxyz"[seen[label] - 1]
                else:
                    yield label

    class AuthorYearStyle(AlphaStyle):
        default_label_style = "uwtutor_author_year"

    register_plugin("pybtex.style.labels", "uwtutor_author_year", AuthorYearLabels, force=True)
    register_plugin("pybtex.style.formatting", "uwtutor_author_year", AuthorYearStyle, force=True)


# --- downloads: the wheel and the PDF edition ---------------------------------------------------------------------

def _version() -> str:
    text = (ROOT / "pyproject.toml").read_text(encoding="utf-8")
    match = re.search(r'^version\s*=\s*"([^"]+)"', text, re.MULTILINE)
    if not match:
        raise RuntimeError("reader_edition: no version = \"...\" in pyproject.toml")
    return match.group(1)


def wheel_name() -> str:
    """The file name of the library's wheel at the version of pyproject.toml."""
    return f"uwtutor-{_version()}-py3-none-any.whl"


def ensure_wheel(dist: Path = ROOT / "dist") -> Path:
    """The wheel in ``dist/`` (as ``make dist`` builds it), built here without dependencies if it is missing."""
    wheel = dist / wheel_name()
    if not wheel.is_file():
        logger.info(f"reader_edition: building {wheel.name} into {dist} (make dist does the same)")
        subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "--quiet",
                        "--wheel-dir", str(dist), str(ROOT)], check=True)
        shutil.rmtree(ROOT / "build", ignore_errors=True)  # setuptools' work folder
        if not wheel.is_file():
            raise RuntimeError(f"reader_edition: pip wheel did not write {wheel}")
    return wheel


def _on_builder_inited(app: Sphinx) -> None:
    if app.builder.format == "html":
        ensure_wheel()
        if not PDF_EDITION.is_file():
            logger.info("reader_edition: no PDF edition at _build/pdf/uwtutor.pdf (make pdf): the download menus "
                        "leave it out")


def _on_build_finished(app: Sphinx, exception: Exception | None) -> None:
    if exception is not None or app.builder.format != "html":
        return
    out = Path(app.outdir) / DOWNLOADS
    out.mkdir(parents=True, exist_ok=True)
    shutil.copy2(ensure_wheel(), out / wheel_name())
    if PDF_EDITION.is_file():
        shutil.copy2(PDF_EDITION, out / PDF_EDITION.name)


def _on_page_context(app: Sphinx, pagename: str, templatename: str, context: dict, doctree: Any) -> None:
    # One copy of each inline script (see the module's docstring).
    scripts = context.get("script_files")
    if isinstance(scripts, list):
        seen: set[tuple] = set()
        for asset in list(scripts):
            key = (getattr(asset, "filename", asset) or "", tuple(sorted(getattr(asset, "attributes", {}).items())))
            if key in seen:
                scripts.remove(asset)
            seen.add(key)
    buttons = context.get("header_buttons")
    if not isinstance(buttons, list):
        return
    root = context["pathto"](DOWNLOADS, 1)
    for group in buttons:
        if group.get("label") != "download-buttons":
            continue
        items = [b for b in group["buttons"] if b.get("label") != "download-pdf-button"]
        if PDF_EDITION.is_file():
            items.append({"type": "link", "url": f"{root}/{PDF_EDITION.name}", "text": "book .pdf",
                          "tooltip": "The PDF edition of the whole book", "icon": "fas fa-file-pdf",
                          "label": "download-book-pdf-button"})
        items.append({"type": "link", "url": f"{root}/{wheel_name()}", "text": ".whl",
                      "tooltip": "The uwtutor library this book was built with (pip install it, see the "
                                 "introduction)", "icon": "fas fa-box", "label": "download-wheel-button"})
        group["buttons"] = items
    # The frozen widgets' notes and the figure viewer read the wheel's address from here.
    context.setdefault("metatags", "")
    context["metatags"] += f'\n<meta name="uwtutor-wheel" content="{root}/{wheel_name()}">'


class RunItDirective(Directive):
    """``uwtutor-run-it``: how to get the chapters running in JupyterLab from this HTML book (its wheel)."""

    has_content = False

    def run(self) -> list[nodes.Node]:
        env = self.state.document.settings.env
        wheel = wheel_name()
        docdepth = env.docname.count("/")
        href = "../" * docdepth + f"{DOWNLOADS}/{wheel}"
        para = nodes.paragraph()
        para += nodes.Text("This book carries the library it was built with: download ")
        para += nodes.reference("", wheel, refuri=href, internal=False, classes=["uwtutor-wheel-link"])
        para += nodes.Text(" (also in each page's download menu, with the chapter's notebook), then, in a terminal:")
        code = (f'python -m pip install "./{wheel}[lab]"\n'
                "uwtutor exercises my-work      # fresh exercise notebooks, never over yours\n"
                "jupyter lab                    # open a chapter's .ipynb (download menu) or my-work/")
        block = nodes.literal_block(code, code, language="bash")
        return [para, block]


# --- figures that open full size ---------------------------------------------------------------------------------

FIGURE_VIEWER_JS = r"""
(function () {
  "use strict";
  var SELECTOR = "div.cell_output img, figure img, div.figure img";
  // The width in CSS px that shows the image at its own size: a figure's PNG has twice its pixels (a "retina" PNG)
  // and says its size in its width attribute (a notebook figure) or its style (a widget's picture, a layout width).
  function natural(img) {
    var attr = parseFloat(img.getAttribute("width"));
    if (attr > 0 && !/%/.test(img.getAttribute("width"))) return attr;
    var styled = /^([0-9.]+)px$/.exec(img.style.width || "");
    return styled ? parseFloat(styled[1]) : img.naturalWidth;
  }
  function open(img) {
    var view = document.createElement("div");
    view.className = "uwtutor-zoom";
    view.setAttribute("role", "dialog");
    view.setAttribute("aria-label", "Figure at full size");
    var big = document.createElement("img");
    big.src = img.currentSrc || img.src;
    big.alt = img.alt || "";
    big.style.width = natural(img) + "px";
    var close = document.createElement("button");
    close.type = "button";
    close.className = "uwtutor-zoom-close";
    close.setAttribute("aria-label", "Close");
    close.textContent = "\u00d7";
    view.appendChild(big);
    view.appendChild(close);
    function shut() { view.remove(); document.removeEventListener("keydown", key); img.focus(); }
    function key(e) { if (e.key === "Escape") shut(); }
    close.addEventListener("click", shut);
    view.addEventListener("click", function (e) { if (e.target === view) shut(); });
    document.addEventListener("keydown", key);
    document.body.appendChild(view);
    close.focus();
  }
  function wire() {
    document.querySelectorAll(SELECTOR).forEach(function (img) {
      // an animation's picture opens too: the frame it shows at the tap
      if (img.closest("a") || img.closest(".anim-state, .jupyter-widgets") ||
          img.dataset.uwtutorZoom) return;
      img.dataset.uwtutorZoom = "1";
      img.classList.add("uwtutor-zoomable");
      img.tabIndex = 0;
      img.setAttribute("role", "button");
      img.setAttribute("aria-label", (img.alt ? img.alt + ": " : "") + "open the figure at full size");
      img.addEventListener("click", function () { open(img); });
      img.addEventListener("keydown", function (e) { if (e.key === "Enter") open(img); });
    });
  }
  // A frozen widget's picture is drawn after the page loads: a click on any output picture opens it too.
  document.addEventListener("click", function (e) {
    var img = e.target;
    if (img.tagName === "IMG" && !img.dataset.uwtutorZoom && img.closest("div.cell_output .jupyter-widgets")) {
      open(img);
    }
  });
  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", wire);
  else wire();
})();
"""


def setup(app: Sphinx) -> dict[str, Any]:
    _register_bibliography_style()
    app.add_transform(HidePlumbing)
    app.add_transform(FiguresKeepTheirProportions)
    app.add_directive("uwtutor-run-it", RunItDirective)
    app.connect("builder-inited", _on_builder_inited)
    app.connect("build-finished", _on_build_finished)
    app.connect("html-page-context", _on_page_context, priority=900)  # after the theme's buttons (501)
    app.add_js_file(None, body=FIGURE_VIEWER_JS)
    return {"version": __version__, "parallel_read_safe": True, "parallel_write_safe": True}
