"""The chapters and the exercises in a real JupyterLab, as a student uses them.

``jupyter lab`` from the project's environment serves a temporary directory on 127.0.0.1 (token, no browser, its
own settings, workspaces and runtime directories, autosave off) holding a copy of chapter 1 and the student
exercise notebooks written by ``uwtutor exercises``; Debian's Chromium, driven by Playwright, opens them with every
request that would leave 127.0.0.1 aborted and recorded (``benchmarks/jupyterlab_session.py``).

- The chapter renders through jupyterlab-myst: every admonition and exercise as a box, every solution folded
  (a closed ``<details>``, its text hidden until the reader opens it), math typeset by KaTeX, and no raw MyST
  markup (directive fences, ``:class: dropdown``, ``{cite}``, ``{term}``...) left in the rendered text.
- The chapter's sound-speed widget, once its cell has run, redraws its figure when a slider moves.
- In the student notebook a wrong answer to exercise 1.2 gets a ✘ with a hint, and the right one a ✔.

Screenshots go to ``_build/screenshots/jupyterlab-*.png``. Chromium or Playwright missing: the tests are skipped,
unless CI=true, where they fail.
"""

from __future__ import annotations

import importlib.util
import itertools
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import nbformat
import pytest

pytestmark = pytest.mark.browser

REPO = Path(__file__).resolve().parents[1]
SCREENSHOTS = REPO / "_build" / "screenshots"
CHAPTER = "ch01_positioning_and_errors.ipynb"
CHAPTER_PATH = f"book/{CHAPTER}"
EXERCISES_PATH = f"my-work/{CHAPTER}"
IMPORT_CELL = "from uwtutor import widgets"
WIDGET_CELL = "widgets.sound_speed_widget()"
#: Exercise 1.2 of the student notebook: its answer and check cells (found by their text), a wrong and a right answer.
ANSWER_CELL, CHECK_CELL = "t_two_way = 2.4", "ch01.check_two_way_range(range_m)"
SETUP = "c = 1500.0        # m/s\nt_two_way = 2.4   # s\n"
WRONG_ANSWER = SETUP + "range_m = c * t_two_way"          # forgets that the sound went out and back
RIGHT_ANSWER = SETUP + "range_m = c * t_two_way / 2"
#: Console errors jupyterlab-myst prints for references it cannot resolve inside one notebook (the bibliography and
#: the other chapters are other pages of the book); they are the differences from the HTML that the README lists.
KNOWN_CONSOLE_ERRORS = ("Cross reference target was not found", "Citation Not Found")
#: ... but not the glossary's terms (issue 25): each chapter carries the entries of the terms it cites, in a cell
#: that only JupyterLab shows (tools/chapter_glossaries.py), so that every {term} resolves there too.
UNEXCUSED = "Cross reference target was not found: term-"


def _excused(text: str) -> bool:
    return any(k in text for k in KNOWN_CONSOLE_ERRORS) and UNEXCUSED not in text

_spec = importlib.util.spec_from_file_location("uwtutor_jupyterlab_session",
                                               REPO / "benchmarks" / "jupyterlab_session.py")
lab = importlib.util.module_from_spec(_spec)
sys.modules[_spec.name] = lab                      # dataclasses look the module up while it is executed
_spec.loader.exec_module(lab)

_workspaces = itertools.count()


def _unavailable(reason: str):
    if os.environ.get("CI", "").lower() == "true":
        pytest.fail(f"CI=true and {reason}: the JupyterLab test must run in CI "
                    "(.ci/run installs Debian's chromium: apt-get install chromium)", pytrace=False)
    pytest.skip(reason)


def _screenshot(page, name: str) -> None:
    SCREENSHOTS.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=str(SCREENSHOTS / f"jupyterlab-{name}.png"))


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    """JupyterLab on a temporary root with a copy of chapter 1 and fresh student exercises; yields the session."""
    root = tmp_path_factory.mktemp("jupyterlab-root")
    (root / "book").mkdir()
    shutil.copy2(REPO / CHAPTER_PATH, root / CHAPTER_PATH)
    command = Path(sys.executable).with_name("uwtutor")
    subprocess.run([str(command), "exercises", str(root / "my-work")], check=True, capture_output=True, text=True)
    try:
        with lab.lab_session(root, tmp_path_factory.mktemp("jupyterlab-work")) as s:
            yield s
            assert not s.external, f"JupyterLab requested addresses off this machine: {sorted(set(s.external))}"
    except lab.Unavailable as exc:
        _unavailable(str(exc))


@pytest.fixture
def open_page(session):
    """Open a notebook (in a workspace of its own, so that no other tab is restored into it); closed afterwards."""
    pages = []
    errors: list[str] = []

    def opener(path: str):
        page = lab.open_notebook(session, path, workspace=f"test-{next(_workspaces)}")
        page.on("console", lambda m: errors.append(m.text) if m.type == "error" and not _excused(m.text) else None)
        page.on("pageerror", lambda exc: errors.append(f"uncaught: {exc}"))
        pages.append(page)
        return page

    opener.errors = errors
    yield opener
    for page in pages:
        page.close()


def _markdown_cells() -> list[str]:
    nb = nbformat.read(REPO / CHAPTER_PATH, as_version=4)
    return [c.source for c in nb.cells if c.cell_type == "markdown"]


def _markdown_sources() -> str:
    return "\n".join(_markdown_cells())


def _directives(text: str, names: str) -> list[str]:
    """The bodies of the directives ``names`` (a regex alternation) fenced with ``` or :::."""
    pattern = re.compile(r"^(?P<fence>`{3,}|:{3,})\{(?:" + names + r")\}[^\n]*\n(?P<body>.*?)^(?P=fence)\s*$",
                         re.M | re.S)
    return [m.group("body") for m in pattern.finditer(text)]


#: What jupyterlab-myst rendered (into a ``div.myst`` in place of each Markdown cell's editor).
RENDERED_FACTS = r"""() => {
  const rendered = Array.from(document.querySelectorAll(
      '.jp-NotebookPanel:not(.lm-mod-hidden) .jp-MarkdownCell.jp-mod-rendered .myst'));
  const q = (sel) => rendered.flatMap(r => Array.from(r.querySelectorAll(sel)));
  const prose = rendered.map(r => {           // the text outside code and typeset math
    const copy = r.cloneNode(true);
    copy.querySelectorAll('code, pre, .katex, .katex-display').forEach(e => e.remove());
    return copy.textContent;
  }).join('\n');
  return {
    cells: rendered.length,
    text: rendered.map(r => r.innerText).join('\n'),
    rawTex: (prose.match(/[^\n]{0,40}(\$|\\[A-Za-z]+)[^\n]{0,40}/g) || []),
    admonitions: q('aside.myst-admonition').length,
    exercises: q('aside.myst-exercise').length,
    solutions: q('details.myst-exercise').length,
    openSolutions: q('details.myst-exercise[open]').length,
    math: q('.katex').length,
    mathErrors: q('.katex-error').map(e => e.textContent.slice(0, 80)),
  };
}"""


def _settled_facts(page, markdown_cells: int, timeout_s: float = 60.0, interval_ms: int = 500) -> dict:
    """RENDERED_FACTS once jupyterlab-myst has rendered every Markdown cell and two reads ``interval_ms`` apart agree.

    The notebook is shown before jupyterlab-myst has finished: it renders the cells one by one, asynchronously, so a
    read taken at once can miss a box (a CI run on a quiet machine counted 3 of chapter 1's 4 admonitions).
    """
    deadline = time.monotonic() + timeout_s
    previous = None
    while True:
        facts = page.evaluate(RENDERED_FACTS)
        if facts["cells"] >= markdown_cells and facts == previous:
            return facts
        if time.monotonic() > deadline:
            return facts                 # the assertions that follow say what is missing
        previous = facts
        page.wait_for_timeout(interval_ms)


def test_chapter_renders_admonitions_folded_solutions_math_and_roles(open_page):
    source = _markdown_sources()
    admonitions = _directives(source, "admonition|note|tip|hint|important|warning|caution|attention|danger|error"
                                      "|seealso")
    exercises = _directives(source, "exercise")
    solutions = _directives(source, "solution")
    assert admonitions and exercises and solutions, "chapter 1 lost its admonitions, exercises or solutions"
    assert all(":class: dropdown" in body for body in solutions), "a solution of chapter 1 is not folded in the HTML"

    page = open_page(CHAPTER_PATH)
    facts = _settled_facts(page, markdown_cells=len(_markdown_cells()))
    _screenshot(page, "chapter")
    assert facts["admonitions"] == len(admonitions)
    assert facts["exercises"] == len(exercises)
    assert facts["solutions"] == len(solutions) and facts["openSolutions"] == 0
    assert facts["math"] > 0 and not facts["mathErrors"]
    raw = [m for m in ("```", ":::", "{admonition}", "{exercise}", "{solution}", ":class: dropdown", ":label:",
                       "{cite}", "{term}", "{doc}", "{ref}", "$$", "\\begin{")
           if m in facts["text"]]
    assert not raw, f"raw MyST markup in the rendered chapter: {raw}"
    assert not facts["rawTex"], "TeX left untypeset (a $ or a \\command outside math and code):\n  " + \
        "\n  ".join(facts["rawTex"])

    # A solution's text is hidden until its summary is clicked, like the HTML's dropdown.
    first = page.locator(".jp-MarkdownCell .myst details.myst-exercise").first
    body = first.locator(".myst-exercise-body")
    assert not body.is_visible()
    first.locator("summary").click()
    body.wait_for(state="visible", timeout=10_000)
    first.scroll_into_view_if_needed()
    _screenshot(page, "chapter-solution-open")
    assert not open_page.errors, f"console errors: {open_page.errors}"


def test_widget_cell_runs_and_redraws_when_a_slider_moves(open_page):
    page = open_page(CHAPTER_PATH)
    lab.run_cell(page, lab.cell_index(page, IMPORT_CELL))
    index = lab.cell_index(page, WIDGET_CELL)
    cell = lab.run_cell(page, index)
    figure = cell.locator(".jp-OutputArea img").first
    figure.wait_for(timeout=60_000)
    readout = cell.locator(".widget-slider .widget-readout").first
    value_before, picture_before = readout.inner_text(), figure.screenshot()
    lab.slider_latency(page, index)                            # waits until the new figure is painted
    figure = cell.locator(".jp-OutputArea img").first
    assert readout.inner_text() != value_before
    assert figure.screenshot() != picture_before, "the figure did not change when the slider moved"
    assert cell.locator(".jp-OutputArea-output[data-mime-type='application/vnd.jupyter.stderr']").count() == 0
    cell.scroll_into_view_if_needed()
    _screenshot(page, "widget")
    assert not open_page.errors, f"console errors: {open_page.errors}"


def _check_output(page, answer: str) -> str:
    answer_cell = lab.cell_index(page, ANSWER_CELL)
    lab.set_cell_source(page, answer_cell, answer)
    lab.run_cell(page, answer_cell)
    check = lab.run_cell(page, lab.cell_index(page, CHECK_CELL))
    return check.locator(".jp-OutputArea").inner_text()


def test_student_exercise_gives_a_hint_for_a_wrong_answer_and_accepts_the_right_one(open_page):
    page = open_page(EXERCISES_PATH)
    lab.run_cell(page, lab.cell_index(page, "from uwtutor.exercises import ch01"))
    wrong = _check_output(page, WRONG_ANSWER)
    _screenshot(page, "exercise-wrong")
    assert "✘" in wrong and "Hint" in wrong and "✔" not in wrong, wrong
    right = _check_output(page, RIGHT_ANSWER)
    _screenshot(page, "exercise-right")
    assert "✔" in right and "✘" not in right, right
    assert not open_page.errors, f"console errors: {open_page.errors}"


def test_opening_a_student_notebook_does_not_mark_it_modified(open_page):
    """JupyterLab rewrites a notebook's kernelspec and language_info when its kernel starts; a student version made by
    `uwtutor exercises` carries them as JupyterLab writes them, so it is not "modified" before the student types."""
    page = open_page(EXERCISES_PATH)
    page.wait_for_timeout(1000)                 # the kernel's info reply has been applied by now
    state = page.evaluate("""() => { const w = window.jupyterapp.shell.currentWidget;
        return {dirty: w.context.model.dirty, kernelspec: w.context.model.getMetadata('kernelspec')}; }""")
    assert state["kernelspec"]["display_name"] == "Python 3 (ipykernel)"
    assert state["dirty"] is False, "the student notebook is marked modified on opening"
    assert not open_page.errors, f"console errors: {open_page.errors}"
