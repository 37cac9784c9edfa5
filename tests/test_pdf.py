"""The PDF edition (`make pdf`, tools/build_pdf.py): it builds with no Sphinx or LaTeX warning, and its text and
images are the book's: every chapter, every figure, the glossary's Chinese, no raw widget text, no solutions.

The PDF is built once per session (fixture ``pdf_build`` in conftest.py) into _build/pdf/; the text is read back with
poppler's pdftotext and the images counted with pdfimages. Without TeX Live (xelatex, latexmk) or poppler the tests
are skipped, unless CI=true, where they fail (.ci/run installs them).
"""

from __future__ import annotations

import functools
import json
import os
import re
import shutil
import subprocess
import sys

import pytest

from book_paths import REPO, toc_docnames

sys.path.insert(0, str(REPO / "tools"))
import build_pdf as pdf_edition  # noqa: E402  (tools/ is not a package; named unlike book/_ext/pdf_edition.py)

pytestmark = pytest.mark.book

TOOLS = ("xelatex", "latexmk", "rsvg-convert", "pdftotext", "pdfimages", "pdffonts")

# LaTeX warnings that come from the classes and packages, not from the book, with the reason.
LATEX_NOISE = [
    # jupyterBook.cls loads inputenc, which xelatex does not need (its input is UTF-8 already).
    re.compile(r"Package inputenc Warning: inputenc package ignored with utf8 based engines"),
    # sphinx.sty loads cmap, a pdftex-only package, for every engine.
    re.compile(r"Package cmap Warning: pdftex not detected - exiting"),
    # jupyterBook.cls loads pgfplots without a compat level; the book draws no pgfplots.
    re.compile(r"Package pgfplots Warning: running in backwards compatibility mode"),
]
LATEX_PROBLEM = re.compile(r"Warning|Missing character|^! ")
# Text wider than the page by more than this runs visibly into the margin (a few points are invisible).
OVERFULL_LIMIT_PT = 20.0

# An object's repr where a rendering should be ("IPython" alone is legitimate: chapters import IPython.display).
RAW_OUTPUT = ["VBox(", "HBox(", "<IPython.", "<Figure size", "<matplotlib.", "Output()"]


def _tools_missing() -> list[str]:
    return [tool for tool in TOOLS if shutil.which(tool) is None]


@pytest.fixture(scope="module")
def pdf(pdf_build):
    missing = _tools_missing()
    if missing:
        reason = f"{', '.join(missing)} not installed (make pdf-deps)"
        if os.environ.get("CI", "").lower() == "true":
            pytest.fail(f"CI=true and {reason}: the PDF test must run in CI", pytrace=False)
        pytest.skip(reason)
    if pdf_build.returncode != 0 or not pdf_edition.PDF.is_file():
        tail = "\n".join(pdf_build.output.splitlines()[-60:])
        pytest.fail(f"`make pdf` failed (exit code {pdf_build.returncode}; log {pdf_edition.LOG}):\n{tail}",
                    pytrace=False)
    return pdf_build


@functools.lru_cache(maxsize=2)
def _text(raw: bool = False) -> str:
    """The PDF's text; ``raw=True`` keeps the order in which LaTeX wrote it, so a table cell that wraps onto several
    lines comes out whole (the default reading order interleaves the wrapped lines of neighbouring cells)."""
    return subprocess.run(["pdftotext", *(["-raw"] if raw else []), "-enc", "UTF-8", str(pdf_edition.PDF), "-"],
                          check=True, capture_output=True, text=True).stdout


_QUOTES = str.maketrans({"’": "'", "‘": "'", "“": '"', "”": '"'})


def _squashed(text: str) -> str:
    """Text without whitespace or hyphenation breaks, and with plain quotes (Sphinx prints typographic ones), for
    finding a phrase whatever the line breaks."""
    return re.sub(r"\s+", "", text.replace("-\n", "").translate(_QUOTES))


def _pdf_docnames() -> list[str]:
    excluded = set(pdf_edition.yaml.safe_load((REPO / "_config_pdf.yml").read_text()).get("pdf_exclude") or [])
    return [d for d in toc_docnames() if d not in excluded]


def _source(docname: str):
    for suffix in (".ipynb", ".md"):
        path = REPO / f"{docname}{suffix}"
        if path.exists():
            return path
    raise FileNotFoundError(docname)


def _markdown_of(docname: str) -> str:
    path = _source(docname)
    if path.suffix == ".md":
        return path.read_text(encoding="utf-8")
    nb = json.loads(path.read_text(encoding="utf-8"))
    return "\n\n".join("".join(c["source"]) for c in nb["cells"] if c["cell_type"] == "markdown")


def _title(docname: str) -> str:
    m = re.search(r"^# (.+)$", _markdown_of(docname), re.M)
    assert m, f"{docname} has no title"
    return re.sub(r"[`*_]", "", m[1]).strip()


# --- the build ---------------------------------------------------------------------------------------------------

def test_pdf_builds_without_sphinx_warnings(pdf):
    sphinx_part = pdf.output.split("Converting book latex into PDF")[0]
    problems = [ln for ln in sphinx_part.splitlines() if re.search(r"\b(WARNING|ERROR|CRITICAL)\b|Traceback", ln)]
    assert not problems, f"{len(problems)} Sphinx warning(s) in the PDF build:\n" + "\n".join(problems[:50])


def test_latex_log_has_no_warnings(pdf):
    log = (pdf_edition.LATEX_DIR / f"{pdf_edition.PDF_NAME}.log").read_text(encoding="utf-8", errors="replace")
    problems = [ln for ln in log.splitlines()
                if LATEX_PROBLEM.search(ln) and not any(p.search(ln) for p in LATEX_NOISE)]
    assert not problems, f"LaTeX warnings (log: {pdf_edition.LATEX_DIR}/uwtutor.log):\n" + "\n".join(problems[:50])
    overfull = [(float(m[1]), m[0]) for m in re.finditer(r"Overfull \\hbox \(([0-9.]+)pt too wide\).*", log)]
    wide = [line for width, line in overfull if width > OVERFULL_LIMIT_PT]
    assert not wide, f"{len(wide)} line(s) or table(s) run more than {OVERFULL_LIMIT_PT} pt off the page:\n" + \
        "\n".join(wide[:30])


def test_pdf_build_time_is_reported(pdf):
    # Not a gate (the machine is shared): a record in the test output (pytest -rA) of what the PDF adds to make test.
    print(f"PDF build: {pdf.seconds:.0f} s wall, {pdf.cpu_seconds:.0f} s CPU")
    assert pdf.cpu_seconds < 900, f"the PDF build used {pdf.cpu_seconds:.0f} s of CPU (it took about 150 s in 2026-12)"


# --- the content ---------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("docname", _pdf_docnames())
def test_every_page_of_the_toc_is_in_the_pdf(pdf, docname):
    title = _title(docname)
    assert _squashed(title).lower() in _squashed(_text()).lower(), f"{docname}'s title {title!r} is not in the PDF"


def test_api_reference_is_left_to_the_html(pdf):
    assert "book/api" not in _pdf_docnames()
    text = _squashed(_text())
    assert _squashed("API reference") in text, "the PDF's introduction should say where the API reference is"
    assert "automodule" not in text and _squashed("Generated from the docstrings") not in text


def test_no_raw_widget_or_object_text(pdf):
    text = _text()
    found = {s: text.count(s) for s in RAW_OUTPUT if s in text}
    assert not found, f"raw output text printed in the PDF (a widget or an object's repr): {found}"


def test_no_sentence_written_for_the_html_alone(pdf):
    """A printed page has no sliders to move and is not "the HTML book": the chapters' widget sentences name the
    edition they speak of."""
    text = " ".join(_text().split())
    for phrase in ("the HTML book shows", "Move the sliders", "Run the next cell in JupyterLab to get"):
        assert phrase not in text, f"an HTML-only sentence is printed: {phrase!r}"


def test_every_widget_prints_its_note(pdf):
    n_widgets = 0
    for docname in _pdf_docnames():
        path = _source(docname)
        if path.suffix == ".ipynb":
            nb = json.loads(path.read_text(encoding="utf-8"))
            n_widgets += sum("application/vnd.jupyter.widget-view+json" in o.get("data", {})
                             for c in nb["cells"] if c["cell_type"] == "code" for o in c.get("outputs", []))
    assert n_widgets > 0
    notes = _squashed(_text()).count(_squashed("An interactive widget: it runs in JupyterLab"))
    assert notes == n_widgets, f"{n_widgets} widgets in the chapters, {notes} printed notes"


def _image_outputs() -> tuple[int, int]:
    """(PNG outputs, to_jshtml animations) of the chapters in the PDF, outside removed cells."""
    pngs = animations = 0
    for docname in _pdf_docnames():
        path = _source(docname)
        if path.suffix != ".ipynb":
            continue
        for cell in json.loads(path.read_text(encoding="utf-8"))["cells"]:
            tags = set(cell.get("metadata", {}).get("tags", []))
            if cell["cell_type"] != "code" or tags & {"remove-output", "remove-cell"}:
                continue
            for out in cell.get("outputs", []):
                data = out.get("data", {})
                pngs += "image/png" in data
                animations += "image/png" not in data and "frames[0]" in "".join(data.get("text/html", ""))
    return pngs, animations


def test_every_figure_and_animation_is_printed(pdf):
    listing = subprocess.run(["pdfimages", "-list", str(pdf_edition.PDF)], check=True, capture_output=True,
                             text=True).stdout.splitlines()[2:]
    images = [ln for ln in listing if ln.split()[2] == "image"]
    pngs, animations = _image_outputs()
    assert animations > 0
    assert len(images) >= pngs + animations, (
        f"{len(images)} images in the PDF for {pngs} figures and {animations} animations in the chapters")
    sheets = _squashed(_text()).count(_squashed("of them here."))
    assert sheets == animations, f"{animations} animations in the chapters, {sheets} printed as frames in the PDF"


_SOLUTION = re.compile(r"```\{solution\}[^\n]*\n(.*?)\n```", re.S)


def _outside_solutions(docname: str) -> str:
    """A page's text without its solutions: prose, code and the outputs' text."""
    path = _source(docname)
    if path.suffix == ".md":
        return _SOLUTION.sub("", path.read_text(encoding="utf-8"))
    parts = []
    for cell in json.loads(path.read_text(encoding="utf-8"))["cells"]:
        parts.append(_SOLUTION.sub("", "".join(cell["source"])))
        for out in cell.get("outputs", []):
            parts.append("".join(out.get("text", "")) + "".join(out.get("data", {}).get("text/plain", "")))
    return "\n".join(parts)


def _solutions() -> list[str]:
    """A plain-prose line of each solution of the chapters that is nowhere else on its page (a solution may repeat
    a sentence that a code cell prints); roles, math and code lines are skipped."""
    lines = []
    for docname in _pdf_docnames():
        elsewhere = _squashed(_outside_solutions(docname))
        for body in _SOLUTION.findall(_markdown_of(docname)):
            for line in body.splitlines():
                line = line.strip()
                if (line.startswith(":") or len(line) < 50 or re.search(r"[`$\\{}|*_\[\]]", line)
                        or _squashed(line[:50]) in elsewhere):
                    continue
                lines.append(line[:50])
                break
    return lines


def test_solutions_are_not_printed(pdf):
    text = _squashed(_text())
    solutions = _solutions()
    assert len(solutions) >= 15, "the chapters' solutions were not found in the sources"
    printed = [s for s in solutions if _squashed(s) in text]
    assert not printed, f"{len(printed)} solutions printed in the PDF, e.g. {printed[:3]}"
    assert "Solution to Exercise" not in _text()
    assert _text().count("Exercise") >= 40


def test_chinese_glossary_terms_extract(pdf):
    terms = set(re.findall(r"[\u4e00-\u9fff]{2,}", (REPO / "book" / "glossary.md").read_text(encoding="utf-8")))
    assert len(terms) > 20
    text = _squashed(_text())
    missing = sorted(t for t in terms if t not in text)
    assert not missing, f"{len(missing)} Chinese terms of the glossary are not in the PDF's text: {missing[:10]}"


def test_reference_part_prints_as_appendices(pdf):
    text = _text()
    for docname in ("book/notation", "book/glossary"):
        assert re.search(r"Appendix\s+[A-F]\s*\n*\s*" + re.escape(_title(docname)), text) or \
            re.search(r"[A-F]\s+" + re.escape(_title(docname)), text), f"{docname} is not an appendix"


# --- the reader's defects (each once seen in a built PDF) ------------------------------------------------------------

def _tex() -> str:
    return (pdf_edition.LATEX_DIR / f"{pdf_edition.PDF_NAME}.tex").read_text(encoding="utf-8")


def test_no_glue_call_or_nbval_marker_in_a_listing(pdf):
    """The code as printed is what the reader needs: the glue calls that hand numbers to the text and the notebook
    tests' markers stay in the notebooks (book/_ext/reader_edition.py strips them from the listings)."""
    text = _text()
    assert "glue(" not in text, f"{text.count('glue(')} glue( calls printed"
    assert "NBVAL" not in text, f"{text.count('NBVAL')} nbval markers printed"


def _tables_of(markdown: str) -> list[list[str]]:
    """The first cells of the rows of each Markdown table of a page (header and separator left out)."""
    tables, rows = [], []
    for line in markdown.splitlines() + [""]:
        if line.startswith("|"):
            rows.append(line.strip("|").split("|")[0].strip())
        elif rows:
            tables.append([r for r in rows[2:] if r])
            rows = []
    return tables


def test_no_table_row_is_lost(pdf):
    """Every row of every table of the Markdown pages is printed: a table longer than a page breaks across pages
    (the 29 rows under "Where the papers use other symbols" once ran off the page, four of them lost, with no LaTeX
    warning)."""
    def plain(text: str) -> str:  # a narrow column hyphenates: compare without hyphens
        return _squashed(text).replace("-", "").replace("\u2010", "")

    text = plain(_text(raw=True))
    missing = []
    n_rows = 0
    for docname in _pdf_docnames():
        if _source(docname).suffix != ".md":
            continue
        for rows in _tables_of(_source(docname).read_text(encoding="utf-8")):
            for first in rows:
                cell = re.sub(r"[`*]|\$[^$]*\$|\{[a-z]+\}|<[^>]*>", "", first)
                cell = re.sub(r"\\[A-Za-z]+", "", cell).strip()
                if len(cell) < 4:
                    continue
                n_rows += 1
                if plain(cell) not in text:
                    missing.append(f"{docname}: {first[:60]!r}")
    assert n_rows > 50
    assert not missing, f"{len(missing)} table rows not in the PDF:\n" + "\n".join(missing[:20])


def test_long_tables_can_break_across_pages(pdf):
    """A table that could be longer than a page is a longtable (it breaks); LaTeX gives no warning otherwise."""
    tex = _tex()
    stuck = []
    for env in ("tabulary", "tabular"):
        for m in re.finditer(r"\\begin\{%s\}(.*?)\\end\{%s\}" % (env, env), tex, re.S):
            rows = m[1].count("\\\\")
            if rows > 20 or len(m[1]) > 6000:
                stuck.append(f"{env} of {rows} rows: {m[1][:80]!r}")
    assert not stuck, "tables that cannot break across pages:\n" + "\n".join(stuck)


def _overfull_in_tables() -> list[str]:
    """Overfull boxes of the LaTeX log that fall inside a table of the .tex (a cell's text past its column)."""
    tex_lines = _tex().splitlines()
    inside = [False] * (len(tex_lines) + 2)
    depth = 0
    for i, line in enumerate(tex_lines, start=1):
        depth += len(re.findall(r"\\begin\{(longtable|tabulary|tabular)\*?\}", line))
        inside[i] = depth > 0
        depth -= len(re.findall(r"\\end\{(longtable|tabulary|tabular)\*?\}", line))
    log = (pdf_edition.LATEX_DIR / f"{pdf_edition.PDF_NAME}.log").read_text(encoding="utf-8", errors="replace")
    found = []
    for m in re.finditer(r"Overfull \\hbox \(([0-9.]+)pt too wide\) (?:in paragraph|in alignment) at lines "
                         r"(\d+)--(\d+)", log):
        first = int(m[2])
        if first < len(inside) and inside[first] and float(m[1]) > 1.0:
            found.append(f"{m[1]} pt at .tex line {first}: {tex_lines[first - 1][:70]!r}")
    return found


def test_no_text_past_a_table_cell(pdf):
    """No cell's text runs past its column (PASS/MISS once stuck out of the performance table, the library-design
    table clipped its first column)."""
    found = _overfull_in_tables()
    assert not found, f"{len(found)} overfull boxes in tables:\n" + "\n".join(found[:20])


def test_every_widget_line_names_real_values(pdf):
    """Each printed widget line gives its controls' starting values: a dropdown's label, not None (ipywidgets 8
    saves a dropdown's labels as _options_labels and no options)."""
    text = " ".join(_text().split())
    lines = re.findall(r"An interactive widget: it runs in JupyterLab.*?\.(?= [A-Z]|$)", text)
    assert lines
    bad = [line for line in lines if "= None" in line]
    assert not bad, f"{len(bad)} widget lines print None:\n" + "\n".join(bad)
    labels = []
    for docname in _pdf_docnames():
        path = _source(docname)
        if path.suffix != ".ipynb":
            continue
        state = json.loads(path.read_text(encoding="utf-8")).get("metadata", {}).get("widgets", {}).get(
            "application/vnd.jupyter.widget-state+json", {}).get("state", {})
        for model in state.values():
            s = model.get("state", {})
            if s.get("_options_labels") and s.get("index") is not None and s.get("description"):
                labels.append(f"{s['description']} = {s['_options_labels'][s['index']]}")
    assert labels
    printed = _squashed(" ".join(lines))
    missing = [label for label in labels if _squashed(label) not in printed]
    assert not missing, f"dropdown values not printed: {missing}"


def test_bibliography_is_a_numbered_appendix_in_the_texts_citation_style(pdf):
    text = _text()
    heading = re.search(r"Appendix\s+([A-H])\s*\n+\s*Bibliography", text) or re.search(
        r"\n([A-H])\s+Bibliography\s*\n", text)
    assert heading, "the bibliography is not a lettered appendix"
    after = text[heading.end():]
    # the list follows its introduction, in the same appendix, labelled as the text cites ("Zhu et al., 2019")
    assert re.search(r"Zhu et al\.,\s+2019", after[:20000]), "the list is not under the bibliography's heading"
    alpha = re.findall(r"\[[A-Z][A-Za-z+]{1,5}\d\d[a-z]?\]", text)
    assert not alpha, f"alpha labels printed (the text cites author-year): {sorted(set(alpha))[:10]}"
    assert not re.search(r"\n\s*Bibliography\s*\n(?!.*Appendix)", text[:2000]), "an unnumbered Bibliography chapter"


def _figure_resolutions() -> dict[tuple[int, int], set[float]]:
    """The resolution (dpi, from each PNG's pHYs chunk, as matplotlib writes it) of the PNGs the LaTeX build
    includes, by their size in pixels: a figure drawn at ``figure.dpi`` or a "retina" PNG of twice as many pixels."""
    from PIL import Image

    found: dict[tuple[int, int], set[float]] = {}
    for path in pdf_edition.LATEX_DIR.glob("*.png"):
        with Image.open(path) as image:
            dpi = image.info.get("dpi")
            found.setdefault(image.size, set()).add(float(dpi[0]) if dpi else float("nan"))
    return found


def test_figure_text_is_at_least_six_and_a_half_points(pdf):
    """The chapters' figures have 7-pt text at the smallest, drawn at the PNG's resolution (its pHYs: 100 dpi at
    the figure's own size, 200 for a "retina" PNG): printed at x ppi, that text is 7 * dpi / x pt high, which must be
    6.5 pt or more (it was 5.2-5.6 pt). An image whose resolution is unknown fails."""
    from uwtutor.plotting import MIN_FONT_SIZE

    listing = subprocess.run(["pdfimages", "-list", str(pdf_edition.PDF)], check=True, capture_output=True,
                             text=True).stdout.splitlines()[2:]
    resolutions = _figure_resolutions()
    printed = [(int(ln.split()[3]), int(ln.split()[4]), float(ln.split()[12])) for ln in listing
               if ln.split()[2] == "image" and int(ln.split()[3]) >= 400]
    assert len(printed) > 50
    sizes, unknown = [], []
    for width, height, ppi in printed:
        dpis = resolutions.get((width, height), set())
        if not dpis or any(d != d for d in dpis):  # not a PNG of the build, or one without pHYs
            unknown.append(f"{width}x{height}")
            continue
        sizes.append(MIN_FONT_SIZE * min(dpis) / ppi)  # two PNGs of one size: the smaller text
    assert not unknown, f"{len(unknown)} printed images of unknown resolution: {unknown[:5]}"
    small = sorted(size for size in sizes if size < 6.5)
    assert not small, f"{len(small)} of {len(sizes)} figures print 7-pt text under 6.5 pt (smallest {small[0]:.2f} pt)"


def test_running_foot_fits_one_line(pdf):
    """A long chapter title (chapter 6's) is shortened in the running foot, which holds one line."""
    tex = _tex()
    for m in re.finditer(r"\\chapter\{([^{}]*(?:\{[^{}]*\}[^{}]*)*)\}", tex):
        title = re.sub(r"\\[A-Za-z]+|[{}]", "", m[1])
        if len(title) > 50:
            after = tex[m.end():m.end() + 400]
            assert "\\chaptermark{" in after, f"chapter {title[:60]!r} has no short running title"


def test_chinese_is_set_in_a_simplified_chinese_face(pdf):
    """The glossary's Chinese is set in the Simplified Chinese face of Noto CJK.

    The faces of a Noto CJK collection share one CFF font, named for Japanese ("NotoSerifCJKjp-Regular"), so
    pdffonts shows that name whatever the face; the faces differ in which glyph a character maps to (their cmaps).
    What xelatex loaded is in its log as ``[FILE.ttc:INDEX]``: the face at that index must be the SC one.
    """
    from fontTools.ttLib import TTCollection

    log = (pdf_edition.LATEX_DIR / f"{pdf_edition.PDF_NAME}.log").read_text(encoding="utf-8", errors="replace")
    loaded = set(re.findall(r"\[([^\]\[]*CJK[^\]\[]*\.ttc):(\d+)\]", log.replace("\n", "")))
    assert loaded, "no Noto CJK face loaded by xelatex"
    for name, index in sorted(loaded):
        files = subprocess.run(["fc-list", "-f", "%{file}\\n"], capture_output=True, text=True).stdout.split()
        path = next((f for f in files if f.endswith("/" + name)), None)
        assert path is not None, f"{name} is not among the system's fonts (fc-list)"
        faces = TTCollection(path).fonts
        face = faces[int(index)]["name"].getDebugName(6)
        assert face.endswith("CJKsc-Regular") or face.endswith("CJKsc-Bold"), f"{name}:{index} is {face}, not SC"
