"""The PDF edition's Sphinx extension (loaded by _config_pdf.yml only; does nothing for other builders).

- **Animations** (``FuncAnimation.to_jshtml()`` outputs, HTML with every frame as a PNG) print as some of their
  frames: up to four, evenly spaced, first and last included, each labelled with its number. LaTeX cannot show
  the HTML.
- **Live widgets** (``application/vnd.jupyter.widget-view+json``) print as one line that names the widget's
  controls and their starting values, and says that it runs in JupyterLab, in place of ``VBox(children=...``.
- Any other HTML-only output is a warning (and so fails the strict build): it would vanish from the page.
- **The Reference part** (notation, glossary, ...) becomes the appendices (``\\appendix`` before its part), and the
  root page (book/intro) an unnumbered chapter "Introduction".
- LaTeX set-up: fonts that have every character the book uses (DejaVu Sans Mono for code, Noto CJK for the
  glossary's Chinese through xeCJK), the bbm.sty stand-in (book/_ext/latex/), SVG through rsvg-convert
  (sphinxcontrib-svg2pdfconverter).
"""

from __future__ import annotations

import base64
import hashlib
import json
import os
import re
from pathlib import Path
from typing import Any

from docutils import nodes
from sphinx.application import Sphinx
from sphinx.config import Config
from sphinx.transforms import SphinxTransform
from sphinx.transforms.post_transforms import SphinxPostTransform
from sphinx.util import logging

__version__ = "1.0"
logger = logging.getLogger(__name__)

HERE = Path(__file__).resolve().parent
WIDGET_VIEW = "application/vnd.jupyter.widget-view+json"
WIDGET_STATE = "application/vnd.jupyter.widget-state+json"
APPENDIX_PART = "Reference"  # the caption in _toc.yml of the part printed as the appendices
ANIMATION_FRAMES = 4  # printed of each animation, each at the width of the page like any figure

# xelatex: Latin, Greek and mathematical symbols from the FreeFont family (Sphinx's default) except code, in DejaVu
# Sans Mono (FreeMono has no ✘ nor ✔). Chinese (the glossary, the papers' titles: only CJK Unified Ideographs) in Noto
# CJK through ucharclasses (which sphinx-jupyterbook-latex loads; xeCJK needs ctex, which Debian ships only in the 98 MB texlive-lang-chinese), with a
# line break allowed between two ideographs. The face is the Simplified Chinese one of Noto Serif CJK by its index in
# Debian's font collection (2, as `fc-list -v ":family=Noto Serif CJK SC"` says): by its family name, "Noto Serif CJK SC", xelatex loaded the
# Japanese face (tests/test_pdf.py checks the embedded font).
FONTPKG = r"""
\setmainfont{FreeSerif}[Extension=.otf, UprightFont=*, ItalicFont=*Italic, BoldFont=*Bold, BoldItalicFont=*BoldItalic]
\setsansfont{FreeSans}[Extension=.otf, UprightFont=*, ItalicFont=*Oblique, BoldFont=*Bold, BoldItalicFont=*BoldOblique]
\setmonofont{DejaVu Sans Mono}[Scale=0.9]
\newfontfamily\uwtutorCJKfont{NotoSerifCJK-Regular.ttc}[FontIndex=2, BoldFont=NotoSerifCJK-Bold.ttc, BoldFeatures={FontIndex=2}]
\PassOptionsToPackage{CJKUnifiedIdeographs}{ucharclasses}% loaded by sphinx-jupyterbook-latex's preamble
\AtBeginDocument{\setTransitionsFor{CJKUnifiedIdeographs}{\begingroup\uwtutorCJKfont}{\endgroup}}
\XeTeXlinebreaklocale "zh"
\XeTeXlinebreakskip = 0pt plus 1pt
% A character that no font has is logged (and fails tests/test_pdf.py) instead of vanishing silently.
\tracinglostchars=2
% Section titles with math (chapter 7's "Mis-set $\mathbf{Q}$ and $R$"): their PDF bookmarks keep the letters.
\AtBeginDocument{\pdfstringdefDisableCommands{\def\({}\def\){}\def\mathbf#1{#1}}}
"""


def _is_latex(app: Sphinx) -> bool:
    return getattr(app, "builder", None) is not None and app.builder.format == "latex"


# --- animations and widgets --------------------------------------------------------------------------------------

_FRAME = re.compile(r'frames\[(\d+)\]\s*=\s*"data:image/png;base64,([^"]*)"')


def animation_frames(html: str) -> list[bytes]:
    """The PNG frames of a ``to_jshtml()`` animation, in order (empty if ``html`` is not one)."""
    found = sorted((int(i), data) for i, data in _FRAME.findall(html))
    return [base64.b64decode(data.replace("\\n", "").replace("\n", "")) for _, data in found]


def frame_picks(n: int, n_max: int = ANIMATION_FRAMES) -> list[int]:
    """Up to ``n_max`` frame indices of ``n``, evenly spaced, first and last included."""
    if n <= n_max:
        return list(range(n))
    return sorted({round(k * (n - 1) / (n_max - 1)) for k in range(n_max)})


def _widget_models(app: Sphinx, docname: str) -> dict[str, Any]:
    path = Path(app.env.doc2path(docname))
    if path.suffix != ".ipynb":
        return {}
    nb = json.loads(path.read_text(encoding="utf-8"))
    return nb.get("metadata", {}).get("widgets", {}).get(WIDGET_STATE, {}).get("state", {})


def _fmt(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:g}"
    return str(value)


def widget_controls(models: dict[str, Any], model_id: str) -> list[str]:
    """The controls of a widget view, in display order, as 'description = value' strings."""
    controls: list[str] = []
    seen: set[str] = set()

    def walk(mid: str) -> None:
        if mid in seen or mid not in models:
            return
        seen.add(mid)
        state = models[mid].get("state", {})
        name = models[mid].get("model_name", "")
        desc = str(state.get("description", "")).strip()
        if name.endswith(("SliderModel", "DropdownModel", "ToggleButtonsModel", "CheckboxModel",
                          "RadioButtonsModel", "SelectModel", "TextModel", "FloatTextModel", "IntTextModel")):
            # ipywidgets 8 saves a selection's labels as _options_labels (its options are not in the state)
            labels = state.get("_options_labels", state.get("options"))
            if labels is not None and state.get("index") is not None:
                value = labels[state["index"]]
            elif labels is not None:  # a selection widget whose value matches no option (ipywidgets: index None)
                value = "(nothing selected)"
            else:
                value = state.get("value")
            controls.append(f"{desc} = {_fmt(value)}" if desc else _fmt(value))
        for value in state.values():
            for item in value if isinstance(value, list) else [value]:
                if isinstance(item, str) and item.startswith("IPY_MODEL_"):
                    walk(item[len("IPY_MODEL_"):])

    walk(model_id)
    return controls


class PrintableOutputs(SphinxTransform):
    """For the LaTeX builder: give animations and widget views a printable rendering in their mime bundle.

    Runs while a page is read (after myst-nb has put every mime type of an output in a ``mime_bundle``), so that the
    frames are collected as an image of the page like any other; myst-nb's SelectMimeType then picks the
    added ``image/png`` (or ``text/plain`` note) for LaTeX, by its usual priority.
    """

    default_priority = 500

    def apply(self, **kwargs: Any) -> None:
        if not _is_latex(self.app):
            return
        models = None
        for bundle in list(self.document.findall(nodes.container)):
            if bundle.get("nb_element") != "mime_bundle":
                continue
            by_type = {child.get("mime_type"): child for child in bundle.children}
            if WIDGET_VIEW in by_type:
                if models is None:
                    models = _widget_models(self.app, self.env.docname)
                self._widget(bundle, by_type, models)
            elif "text/html" in by_type and not ({"image/png", "image/jpeg", "text/latex"} & by_type.keys()):
                html = by_type["text/html"].astext()
                frames = animation_frames(html)
                if frames:
                    self._animation(bundle, by_type, frames)
                else:
                    logger.warning("pdf_edition: an HTML-only output has no printable form; it would vanish from "
                                   "the PDF (give it an image/png or text/latex rendering)", location=bundle)

    def _animation(self, bundle: nodes.container, by_type: dict, frames: list[bytes]) -> None:
        out_dir = Path(self.app.outdir).parent / "pdf_fallbacks"
        out_dir.mkdir(parents=True, exist_ok=True)
        picks = frame_picks(len(frames))
        container = nodes.container(mime_type="image/png")
        container += nodes.paragraph("", "", nodes.emphasis(
            "", f"An animation of {len(frames)} frames in the HTML book and in JupyterLab; "
                f"{len(picks)} of them here."))
        for i in picks:
            name = f"frame-{hashlib.sha1(frames[i]).hexdigest()[:16]}.png"
            (out_dir / name).write_bytes(frames[i])
            # Sphinx reads a URI that starts with "/" as relative to the source folder (as myst-nb writes its own).
            uri = "/" + os.path.relpath((out_dir / name).resolve(), self.app.srcdir)
            container += nodes.image(uri=uri, alt=f"frame {i + 1} of {len(frames)}")
            container += nodes.paragraph("", "", nodes.emphasis("", f"Frame {i + 1} of {len(frames)}."))
        for child in list(bundle.children):
            bundle.remove(child)
        bundle += container

    def _widget(self, bundle: nodes.container, by_type: dict, models: dict[str, Any]) -> None:
        try:
            model_id = json.loads(by_type[WIDGET_VIEW].astext().split(">", 1)[1].rsplit("<", 1)[0])["model_id"]
        except (IndexError, ValueError, KeyError, TypeError):
            model_id = ""
        controls = widget_controls(models, model_id)
        text = "An interactive widget: it runs in JupyterLab (make lab)"
        text += "; its controls start at " + "; ".join(controls) + "." if controls else "."
        note = nodes.paragraph("", "", nodes.emphasis("", text))
        container = nodes.container(mime_type="text/plain")
        container += note
        for child in list(bundle.children):
            bundle.remove(child)
        bundle += container


# --- long tables ---------------------------------------------------------------------------------------------------

#: A table of more rows than this, or of more text (characters), prints as a ``longtable``, which breaks across
#: pages: Sphinx's own cut-off (30 rows) let the 29 rows of wrapped text under "Where the papers use other symbols"
#: run off the page, with no LaTeX warning. A longtable of a few rows costs nothing.
LONG_TABLE_ROWS = 15
LONG_TABLE_CHARS = 1500


def _printed_text(node: nodes.Node) -> str:
    """About the text a cell prints: a formula's LaTeX source is some three times longer than what it prints."""
    parts = []
    for child in node.findall(nodes.Text):
        inside_math = any(isinstance(a, (nodes.math, nodes.math_block)) for a in _ancestors(child))
        text = child.astext()
        # a formula does not break: one "word" (no spaces) of a third of its source's length
        parts.append(text[: max(1, len(text) // 3)].replace(" ", "_") if inside_math else text)
    return "".join(parts)


def _ancestors(node: nodes.Node):
    parent = node.parent
    while parent is not None:
        yield parent
        parent = parent.parent


#: About how many characters of the body font a line of the text block holds (17 cm at 10 pt).
LINE_CHARS = 90


def column_widths(texts: list[list[str]], line: int = LINE_CHARS) -> list[float]:
    """Widths (in characters) for the columns of a table whose cells hold ``texts`` (rows of cell texts).

    Each column wants its longest text (6 to 60 characters) and needs its longest word plus room for the cell's
    padding; when the wants do not fit ``line``, the columns give up what they want beyond what they need, in
    proportion, so that no word is wider than its column (tabulary left "Plaza" and "Unit" 3 to 6 pt past theirs,
    and a narrow last column of a longtable "PASS").

    Examples
    --------
    >>> [round(w) for w in column_widths([["Physics and simulation", "x " * 40], ["Unit", "m"]], line=40)]
    [16, 24]
    """
    ncol = max(len(r) for r in texts)
    want, need = [6.0] * ncol, [4.0] * ncol
    for row in texts:
        for i, text in enumerate(row):
            word = max((len(w) for w in text.split()), default=0)
            need[i] = max(need[i], word + 3.0)
            want[i] = max(want[i], min(60.0, len(text)), need[i])
    if sum(want) <= line:
        return want
    if sum(need) >= line:  # even the words do not fit: share the line by the words
        return need
    spare = (line - sum(need)) / (sum(want) - sum(need))
    return [n + (w - n) * spare for w, n in zip(want, need)]


#: LaTeX sizes a wide table may be set in, with their size in points (the body is 10 pt).
TABLE_FONTS = (("small", 9.0), ("footnotesize", 8.0), ("scriptsize", 7.0))


def table_font(texts: list[list[str]], line: int = LINE_CHARS) -> tuple[str, int]:
    """The LaTeX size (``""`` for the body's) in which a table's longest words fit side by side, and how many
    characters of that size a line holds.

    A table of many columns (chapter 11's ten) cannot give each its longest word at 10 pt: the columns were then
    shared in proportion and "Plaza" ran 3 pt past its cell. The smallest size tried is 7 pt; a table whose words do
    not fit even then keeps it and its words share the line (:func:`column_widths`).

    Examples
    --------
    >>> table_font([["Physics", "m"]])
    ('', 90)
    >>> table_font([["schedules", "odometry"] * 4])
    ('small', 100)
    """
    need = [0.0] * max(len(r) for r in texts)
    for row in texts:
        for i, text in enumerate(row):
            need[i] = max(need[i], max((len(w) for w in text.split()), default=0) + 3.0, 4.0)
    if sum(need) <= line:
        return "", line
    for size, points in TABLE_FONTS:
        chars = int(line * 10.0 / points)
        if sum(need) <= chars:
            return size, chars
    return TABLE_FONTS[-1][0], int(line * 10.0 / TABLE_FONTS[-1][1])


class LongTableWidths(SphinxTransform):
    """For the LaTeX builder: give every table of three columns or more widths that fit its words
    (:func:`column_widths`), and make a long table (LONG_TABLE_ROWS, LONG_TABLE_CHARS) a ``longtable``.

    Sphinx sets a longtable's columns ``l`` (one line each) unless widths are given, and the notation's and the
    performance appendix's tables then ran hundreds of points off the page; tabulary, for the others, can leave a
    column narrower than its longest word.
    """

    default_priority = 510

    def apply(self, **kwargs: Any) -> None:
        if not _is_latex(self.app):
            return
        for table in self.document.findall(nodes.table):
            tgroup = table.next_node(nodes.tgroup)
            if tgroup is None or "colwidths-given" in table["classes"]:
                continue
            rows = list(tgroup.findall(nodes.row))
            colspecs = [c for c in tgroup.children if isinstance(c, nodes.colspec)]
            long = len(rows) > LONG_TABLE_ROWS or len(table.astext()) > LONG_TABLE_CHARS
            if not colspecs or (len(colspecs) < 3 and not long):
                continue
            if long:
                table["classes"].append("longtable")
            texts = [[_printed_text(e) for e in row.children if isinstance(e, nodes.entry)] for row in rows]
            texts = [t for t in texts if t]
            size, line = table_font(texts)
            for colspec, width in zip(colspecs, column_widths(texts, line=line)):
                colspec["colwidth"] = max(1, round(width * 10))
            table["classes"].append("colwidths-given")
            if size:  # a group around the table sets it in the smaller face
                table.parent.insert(table.parent.index(table), nodes.raw("", rf"\begingroup\{size}", format="latex"))
                table.parent.insert(table.parent.index(table) + 1, nodes.raw("", r"\endgroup", format="latex"))


# --- the Reference part as the appendices ------------------------------------------------------------------------

# Sphinx numbers figures, tables, code blocks and equations with \arabic{chapter}: after \appendix, "Table D.1" and
# not "Table 4.1" in appendix D.
APPENDIX_LATEX = r"""\appendix
\renewcommand{\thefigure}{\thechapter.\arabic{figure}}
\renewcommand{\thetable}{\thechapter.\arabic{table}}
\renewcommand{\theliteralblock}{\thechapter.\arabic{literalblock}}
\renewcommand{\theequation}{\thechapter.\arabic{equation}}
"""


class ReferencePartAsAppendix(SphinxPostTransform):
    """``\\appendix`` before the part captioned APPENDIX_PART: its chapters print as Appendix A, B, ..."""

    builders = ("latex",)
    default_priority = 800  # after sphinx-jupyterbook-latex has turned the toctree captions into parts (700)

    def run(self, **kwargs: Any) -> None:
        for node in list(self.document.findall(nodes.section)):
            title = node.next_node(nodes.title)
            if (node.get("docname") == APPENDIX_PART and title is not None
                    and title.astext() == APPENDIX_PART):
                wrapper = node.parent.parent  # compound(toctree-wrapper) > start_of_file > section
                wrapper.parent.insert(wrapper.parent.index(wrapper), nodes.raw("", APPENDIX_LATEX, format="latex"))
                return


class RootAsIntroduction(SphinxPostTransform):
    """The root page (book/intro, whose title is the book's) prints after the contents as an unnumbered chapter
    "Introduction", listed in the contents and in the running heads (which would otherwise say CONTENTS)."""

    builders = ("latex",)
    default_priority = 800

    def run(self, **kwargs: Any) -> None:
        root = self.config.root_doc
        for section in self.document.findall(nodes.section):
            if section.get("docname") == root:
                heading = "\\chapter*{Introduction}\\markboth{Introduction}{Introduction}" \
                          "\\addcontentsline{toc}{chapter}{Introduction}\n"
                index = next((i + 1 for i, child in enumerate(section.children)
                              if isinstance(child, nodes.title)), 0)
                section.insert(index, nodes.raw("", heading, format="latex"))
                return


class BibliographyInItsAppendix(SphinxPostTransform):
    """The list of references inside the bibliography's own page (an appendix, numbered like the others), under its
    introduction, rather than as an unnumbered chapter after the last page.

    Sphinx gathers every citation of the book into one ``thebibliography`` node at the end of the document (its
    BibliographyTransform, priority 750); this moves that node to the end of BIBLIOGRAPHY_DOC's section, and
    PREAMBLE_LATEX makes the list start there without a chapter heading or a contents line of its own.
    """

    builders = ("latex",)
    default_priority = 760

    def run(self, **kwargs: Any) -> None:
        from sphinx import addnodes
        from sphinx.builders.latex.nodes import thebibliography

        lists = list(self.document.findall(thebibliography))
        target = next((n for n in self.document.findall(addnodes.start_of_file)
                       if n.get("docname") == BIBLIOGRAPHY_DOC), None)
        section = target.next_node(nodes.section) if target is not None else None
        if not lists or section is None:
            return
        for node in lists:
            node.parent.remove(node)
            section += node


#: A chapter title longer than this (characters) is shortened in the running foot, which holds one line.
RUNNING_TITLE_MAX = 50


def running_title(title: str, limit: int = RUNNING_TITLE_MAX) -> str:
    """A chapter's title for the running foot: the title itself if short, else its part before a colon, else its
    first words within ``limit`` characters.

    Examples
    --------
    >>> running_title("Particle filters for a maneuvering AUV's depth: the multiple-model and the grey particle filter")
    "Particle filters for a maneuvering AUV's depth"
    >>> running_title("A" * 10)
    'AAAAAAAAAA'
    """
    if len(title) <= limit:
        return title
    head = title.split(":", 1)[0].strip()
    if len(head) <= limit:
        return head
    words, out = head.split(), ""
    for word in words:
        if len(out) + len(word) + 1 > limit - 1:
            break
        out = f"{out} {word}".strip()
    return out + "…"


class ShortRunningTitles(SphinxPostTransform):
    r"""A chapter whose title is too long for one line of the running foot gets a short one (:func:`running_title`),
    set with ``\chaptermark`` right after its heading."""

    builders = ("latex",)
    default_priority = 800

    def run(self, **kwargs: Any) -> None:
        from sphinx import addnodes
        from sphinx.util.texescape import escape

        for start in self.document.findall(addnodes.start_of_file):
            section = start.next_node(nodes.section)
            title = section.next_node(nodes.title) if section is not None else None
            if title is None or len(title.astext()) <= RUNNING_TITLE_MAX:
                continue
            short = escape(running_title(title.astext()))
            section.insert(section.index(title) + 1, nodes.raw("", f"\\chaptermark{{{short}}}\n", format="latex"))


BIBLIOGRAPHY_DOC = "book/bibliography"
#: The side margins (Sphinx's default is an inch) and how far, both sides together, a figure may spread into them.
#: The book's figures are drawn 7.5 to 8 inches wide at 100 dpi, with 7-pt text at the smallest
#: (uwtutor.plotting.MIN_FONT_SIZE); shrunk to Sphinx's 15.9 cm text width they printed it at 5.2-5.6 pt. In 17 cm
#: of text (a cell's output is indented a little) and 3 cm more they print at 0.93 of their size or more: 6.5 pt or
#: more (tests/test_pdf.py).
SIDE_MARGIN_CM = 2.0
FIGURE_SPILL_CM = 3.0

PREAMBLE_LATEX = r"""
\makeatletter
% The list of references sits in its appendix (BibliographyInItsAppendix): no chapter heading, no contents line.
\renewenvironment{sphinxthebibliography}[1]
  {\begingroup\let\chapter\@gobbletwo\let\addcontentsline\@gobblethree\begin{thebibliography}{#1}}
  {\end{thebibliography}\endgroup}
% A figure wider than the text may spread SPILLcm (in all) into the margins (centred), before Sphinx scales it down.
\renewcommand*{\sphinxincludegraphics}[2][]{%
  \begingroup
  \setbox0\hbox{\linewidth\dimexpr\linewidth+SPILLcm\relax\sphinxsafeincludegraphics[#1]{#2}}%
  \ifdim\wd0>\linewidth\makebox[\linewidth][c]{\box0}\else\box0\fi
  \endgroup}
\makeatother
""".replace("SPILL", f"{FIGURE_SPILL_CM:g}")


# --- set-up --------------------------------------------------------------------------------------------------------

def _on_config_inited(app: Sphinx, config: Config) -> None:
    elements = dict(config.latex_elements or {})
    elements.setdefault("fontpkg", FONTPKG)
    elements.setdefault("papersize", "a4paper")
    elements.setdefault("sphinxsetup", f"hmargin={{{SIDE_MARGIN_CM:g}cm,{SIDE_MARGIN_CM:g}cm}}")
    elements["preamble"] = elements.get("preamble", "") + PREAMBLE_LATEX
    config.latex_elements = elements
    extra = list(config.latex_additional_files or [])
    stub = str(HERE / "latex" / "bbm.sty")
    if stub not in extra:
        extra.append(stub)
    config.latex_additional_files = extra


def setup(app: Sphinx) -> dict[str, Any]:
    app.setup_extension("sphinxcontrib.rsvgconverter")
    app.connect("config-inited", _on_config_inited)
    app.add_transform(PrintableOutputs)
    app.add_transform(LongTableWidths)
    app.add_post_transform(ReferencePartAsAppendix)
    app.add_post_transform(RootAsIntroduction)
    app.add_post_transform(BibliographyInItsAppendix)
    app.add_post_transform(ShortRunningTitles)
    return {"version": __version__, "parallel_read_safe": True, "parallel_write_safe": True}
