"""The labs are nbgrader assignments: nbgrader itself generates, autogrades and writes feedback on each of them.

One temporary nbgrader course (its own sqlite gradebook) holds every lab folder of ``exercises/labs/`` as an
assignment, so that nbgrader starts three times in all (not three times per lab): ``nbgrader generate_assignment``,
then ``nbgrader autograde`` of three submissions of every lab:

- ``solution``: the instructor's source with the solution markers taken out: it must get every autograded point;
- ``blank``: the released version, unanswered: it must get no point;
- ``wrong``: the solution with one typical mistake (listed in ``MISTAKES``): some points, not all;

and ``nbgrader generate_feedback`` writes the HTML feedback, which must name what failed and show no answer. The labs
run in full (they are written to take seconds). Also tested: the metadata nbgrader reads, the released version, and
``uwtutor labs DIR`` (the student versions made without nbgrader).

Time (``time .venv/bin/python -m pytest tests/test_labs_nbgrader.py``, on two cores shared with other work, so the
CPU time is the steadier measure): one course per lab (24 nbgrader processes, two courses at a time) took 170-280 s
of CPU (250-790 s wall); the one course takes 100-125 s of CPU (110-280 s wall). Of that, autograding the 24
submissions is about 85 %: a kernel per notebook and each lab's own compute (1-6 s; depth_pf_vs_ekf is the
heaviest). Two courses of four labs side by side were measured too: no faster on a loaded machine and more CPU,
and ``make test`` already keeps both cores busy (pytest-xdist).
"""

from __future__ import annotations

import copy
import html
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import nbformat
import pytest

import cpu_limits
from lab_mistakes import TYPICAL_MISTAKES

nbgrader_api = pytest.importorskip("nbgrader.api", reason="nbgrader is in the test extra: pip install -e '.[test]'")

from uwtutor.exercises.cli import main  # noqa: E402
from uwtutor.exercises.generate import CODE_STUB, list_lab_sources, write_lab_versions  # noqa: E402
from uwtutor_grader import lab_parts  # noqa: E402
from uwtutor.exercises.nbgrader_meta import SCHEMA_VERSION, nbgrader_problems, total_points  # noqa: E402

LABS_DIR = Path(__file__).resolve().parents[1] / "exercises" / "labs"
LABS = list_lab_sources(LABS_DIR)

#: The typical-mistake students (tests/lab_mistakes.py): the first of each lab is its ``wrong`` student, whose
#: feedback is also checked for answers shown; every one must score exactly the points the instructor notes state.
MISTAKES = {}
MORE_MISTAKES: dict = {}
for _student, (_lab, _change, _points, _cells, _phrase) in TYPICAL_MISTAKES.items():
    if _lab not in MISTAKES:
        MISTAKES[_lab] = (_change, _points, _phrase)
    else:
        MORE_MISTAKES.setdefault(_lab, []).append((_student, _change, _points, _phrase))
#: The grader's package (the instructor's; not in uwtutor's wheel), for the kernels nbgrader starts.
GRADER_DIR = LABS_DIR / "grader"

_SOLUTION_MARKER = re.compile(r"^\s*#+\s*(BEGIN|END)\s+SOLUTION\s*$")


def test_every_lab_has_a_mistake_listed():
    assert set(MISTAKES) == set(LABS), "add a typical wrong answer to MISTAKES for every lab"


def _solution_version(nb: nbformat.NotebookNode) -> nbformat.NotebookNode:
    """The source with its solution markers removed: what a student who gets everything right hands in."""
    nb = copy.deepcopy(nb)
    for cell in nb.cells:
        cell.source = "\n".join(line for line in cell.source.split("\n") if not _SOLUTION_MARKER.match(line))
    return nb


def _with_mistake(nb: nbformat.NotebookNode, grade_id: str, right: str, wrong: str) -> nbformat.NotebookNode:
    nb = _solution_version(nb)
    cells = [c for c in nb.cells if c.metadata.get("nbgrader", {}).get("grade_id") == grade_id]
    assert len(cells) == 1 and right in cells[0].source, f"{grade_id}: {right!r} not found (update MISTAKES)"
    cells[0].source = cells[0].source.replace(right, wrong)
    return nb


def _nbgrader(course: Path, *args: str, first_on_path: Path | None = None,
             expect_failure: bool = False) -> subprocess.CompletedProcess:
    """Run nbgrader in ``course``; its kernels import the grader (and ``first_on_path`` before anything else). It
    must succeed, or with ``expect_failure`` fail."""
    path = [str(GRADER_DIR), *filter(None, os.environ.get("PYTHONPATH", "").split(os.pathsep))]
    if first_on_path is not None:
        path.insert(0, str(first_on_path))
    env = dict(os.environ, PATH=str(Path(sys.executable).parent) + os.pathsep + os.environ.get("PATH", ""),
               PYTHONPATH=os.pathsep.join(path))
    env.pop("JUPYTER_CONFIG_DIR", None)
    result = cpu_limits.run([sys.executable, "-m", "nbgrader", *args], cwd=course, env=env, capture_output=True,
                            text=True, cpu_seconds=900)
    assert (result.returncode != 0) == expect_failure, \
        f"nbgrader {' '.join(args)} returned {result.returncode}:\n{result.stdout[-4000:]}\n{result.stderr[-4000:]}"
    return result


def _answered_copy(copy_nb: nbformat.NotebookNode, solution: nbformat.NotebookNode) -> nbformat.NotebookNode:
    """A student's copy (``uwtutor labs``) with every answer cell filled in as the solution fills it."""
    answers = {c.metadata["nbgrader"]["grade_id"]: c.source for c in solution.cells
               if c.metadata.get("nbgrader", {}).get("solution")}
    nb = copy.deepcopy(copy_nb)
    for cell in nb.cells:
        grade_id = cell.metadata.get("nbgrader", {}).get("grade_id")
        if grade_id in answers:
            cell.source = answers[grade_id]
    return nb


def _grade_all(course: Path) -> dict:
    """One course with every lab: generate them, autograde three students, write their feedback; report the scores."""
    (course / "source").mkdir(parents=True)
    # the course configuration shipped with the labs, with this course's id, root and gradebook
    shipped = (LABS_DIR / "nbgrader_config.py").read_text(encoding="utf-8")
    (course / "nbgrader_config.py").write_text(
        shipped.replace('"uwtutor-labs"', '"uwtutor-labs-test"') + "\n"
        f"c.CourseDirectory.root = {str(course)!r}\n"
        f"c.CourseDirectory.db_url = 'sqlite:///{course / 'gradebook.db'}'\n"
        "c.ExecutePreprocessor.timeout = 600\n", encoding="utf-8")
    for lab in LABS:
        shutil.copytree(LABS_DIR / lab, course / "source" / lab)
    _nbgrader(course, "generate_assignment", "*")     # every folder of source/ (one assignment each)
    copies = course.parent / "uwtutor-labs-copies"       # what `uwtutor labs DIR` gives a student
    assert main(["labs", str(copies)]) == 0
    for lab, notebooks in LABS.items():
        (right_id, right, wrong), _, _ = MISTAKES[lab]
        for path in notebooks:
            source = nbformat.read(path, as_version=4)
            released = nbformat.read(course / "release" / lab / path.name, as_version=4)
            has_mistake = any(c.metadata.get("nbgrader", {}).get("grade_id") == right_id and right in c.source
                              for c in source.cells)
            submissions = {"solution": _solution_version(source), "blank": released,
                           "wrong": _with_mistake(source, right_id, right, wrong) if has_mistake
                           else _solution_version(source),
                           "copy": _answered_copy(nbformat.read(copies / lab / path.name, as_version=4),
                                                  _solution_version(source))}
            for student, (grade_id, right_text, wrong_text), _, _ in MORE_MISTAKES.get(lab, []):
                submissions[student] = _with_mistake(source, grade_id, right_text, wrong_text)
            for student, nb in submissions.items():
                folder = course / "submitted" / student / lab
                folder.mkdir(parents=True, exist_ok=True)
                nbformat.write(nb, folder / path.name)
    autograde = _nbgrader(course, "autograde", "*")
    _nbgrader(course, "generate_feedback", "*")
    results: dict = {}
    with nbgrader_api.Gradebook(f"sqlite:///{course / 'gradebook.db'}") as gradebook:
        for lab, notebooks in LABS.items():
            scores: dict = {}
            students = ["solution", "blank", "wrong", "copy"] + [m[0] for m in MORE_MISTAKES.get(lab, [])]
            for student in students:
                auto = maximum = 0.0
                manual_pending = 0
                for path in notebooks:
                    submission = gradebook.find_submission_notebook(path.stem, lab, student)
                    for grade in submission.grades:
                        if grade.cell.cell_type == "code":
                            auto += grade.auto_score or 0.0
                            maximum += grade.max_score
                        elif grade.needs_manual_grade:
                            manual_pending += 1
                scores[student] = {"auto": auto, "max": maximum, "manual_pending": manual_pending}
            results[lab] = {"course": course, "scores": scores}
    results["_autograde_log"] = autograde.stdout + autograde.stderr
    # the grading environment without gtsam: a stand-in package that fails to import, first on the kernels' path
    missing = course.parent / "without-gtsam"
    (missing / "gtsam").mkdir(parents=True)
    (missing / "gtsam" / "__init__.py").write_text("raise ImportError('gtsam is not installed (test stand-in)')\n")
    folder = course / "submitted" / "no_gtsam" / "real_ranges_plaza"
    folder.mkdir(parents=True)
    for path in LABS["real_ranges_plaza"]:
        nbformat.write(_solution_version(nbformat.read(path, as_version=4)), folder / path.name)
    no_gtsam = _nbgrader(course, "autograde", "real_ranges_plaza", "--student", "no_gtsam", first_on_path=missing)
    results["_no_gtsam_log"] = no_gtsam.stdout + no_gtsam.stderr
    # a copy without nbgrader's metadata (an older uwtutor's `uwtutor labs`, or re-typed), answered right
    lab = "ekf_consistency"
    folder = course / "submitted" / "no_metadata" / lab
    folder.mkdir(parents=True)
    for path in LABS[lab]:
        nb = _answered_copy(nbformat.read(copies / lab / path.name, as_version=4),
                            _solution_version(nbformat.read(path, as_version=4)))
        for cell in nb.cells:
            cell.metadata.pop("nbgrader", None)
        nbformat.write(nb, folder / path.name)
    refused = _nbgrader(course, "autograde", lab, "--student", "no_metadata", expect_failure=True)
    results["_no_metadata"] = {"log": refused.stdout + refused.stderr, "returncode": refused.returncode,
                               "autograded": (course / "autograded" / "no_metadata" / lab).exists()}
    return results


@pytest.fixture(scope="module")
def graded(tmp_path_factory):
    """Every lab graded by nbgrader in one course."""
    return _grade_all(tmp_path_factory.mktemp("nbgrader-course") / "course")


def _feedback_text(course: Path, student: str, lab: str, stem: str) -> str:
    """The text of a feedback page (tags removed, entities decoded, white space collapsed)."""
    page = (course / "feedback" / student / lab / f"{stem}.html").read_text(encoding="utf-8")
    return " ".join(html.unescape(re.sub(r"<[^>]+>", " ", page)).split())


# -- the sources ------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("lab", LABS)
def test_lab_metadata_is_what_nbgrader_needs(lab):
    for path in LABS[lab]:
        nb = nbformat.read(path, as_version=4)
        assert nbgrader_problems(nb) == []
        metas = [c.metadata["nbgrader"] for c in nb.cells if "nbgrader" in c.metadata]
        assert all(m["schema_version"] == SCHEMA_VERSION for m in metas)
        ids = [m["grade_id"] for m in metas]
        assert len(ids) == len(set(ids))
        auto, manual = total_points(nb)
        assert auto >= 10 and manual >= 1, "a lab has autograded parts and a manually graded written answer"
        sources = [c.source for c in nb.cells]
        assert any("### BEGIN HIDDEN TESTS" in s for s in sources), "a lab has hidden tests"
        assert any(c.cell_type == "markdown" and c.metadata.get("nbgrader", {}).get("solution")
                   and c.metadata["nbgrader"].get("grade") for c in nb.cells), "a lab has a written answer"
        assert "Learning goals" in nb.cells[0].source
        assert all(not c.get("outputs") for c in nb.cells if c.cell_type == "code"), "commit sources without outputs"
    assert (LABS_DIR / "instructor-notes" / f"{lab}.md").is_file(), "every lab has instructor notes beside it"


@pytest.mark.parametrize("lab", LABS)
def test_labs_use_only_the_public_api(lab):
    for path in LABS[lab]:
        for cell in nbformat.read(path, as_version=4).cells:
            if cell.cell_type == "code":
                assert not re.search(r"uwtutor(\.\w+)*\._", cell.source), "a lab imports a private uwtutor name"
                assert "np.random.seed" not in cell.source and "np.random.normal" not in cell.source


# -- nbgrader's verdicts ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("lab", LABS)
def test_solution_gets_every_autograded_point(graded, lab):
    scores = graded[lab]["scores"]["solution"]
    assert scores["max"] > 0 and scores["auto"] == scores["max"], scores
    assert scores["manual_pending"] >= 1, "the written answer waits for the instructor"


@pytest.mark.parametrize("lab", LABS)
def test_a_uwtutor_labs_copy_answered_right_gets_every_point(graded, lab):
    """A student who works in the copy `uwtutor labs` wrote (the wheel's copy is the same file: tests/test_wheel.py)
    is graded by nbgrader like one who got nbgrader's release."""
    scores = graded[lab]["scores"]["copy"]
    assert scores["max"] > 0 and scores["auto"] == scores["max"], scores


@pytest.mark.parametrize("lab, student, expected, phrase", [(lab, m[0], m[2], m[3]) for lab in sorted(MORE_MISTAKES)
                                                            for m in MORE_MISTAKES[lab]])
def test_a_slip_costs_its_own_part_only(graded, lab, student, expected, phrase):
    scores = graded[lab]["scores"][student]
    assert scores["auto"] == expected, f"{lab}: {student} got {scores['auto']} of {scores['max']}, not {expected}"
    course = graded[lab]["course"]
    for path in LABS[lab]:
        assert " ".join(html.unescape(phrase).split()) in _feedback_text(course, student, lab, path.stem)


def test_a_missing_lab_dependency_is_an_error_in_the_log(graded):
    """Autograding real_ranges_plaza where gtsam cannot be imported says so in nbgrader's own output, with what to
    install, instead of a quiet zero."""
    log = graded["_no_gtsam_log"]
    assert "cannot grade the lab real_ranges_plaza: the package 'gtsam' is not installed" in log, log[-3000:]
    assert 'pip install "uwtutor[data]"' in log


def test_a_copy_without_nbgrader_metadata_is_refused_loudly(graded):
    """A student's copy whose cells lost nbgrader's metadata would get no hidden test and 0 points in silence; the
    course configuration (exercises/labs/nbgrader_config.py) refuses it: autograde fails, its log says why and
    what to do, and no autograded notebook (no score) is written."""
    refused = graded["_no_metadata"]
    log = " ".join(refused["log"].split())
    assert refused["returncode"] != 0
    assert "no_metadata/ekf_consistency/ekf_consistency.ipynb has no nbgrader metadata at all" in log, log[-3000:]
    assert "missing: A1_tests, A2_tests" in log and "nbgrader would run none of their tests and score them 0" in log
    assert "Ask the student to copy their answers into a fresh copy" in log
    assert not refused["autograded"]


_PART_LABEL = re.compile(r'<a href="#(?P<gid>\w+?)_(?:tests|written)">(?P<label>[^<]*)</a>')


@pytest.mark.parametrize("lab", LABS)
def test_feedback_names_each_graded_cell_by_its_part(graded, lab):
    """The course's feedback template names each test cell by its part ("Part B, check B1"), not "Test cell"."""
    course = graded[lab]["course"]
    for path in LABS[lab]:
        source = nbformat.read(path, as_version=4)
        graded_ids = [c.metadata["nbgrader"]["grade_id"] for c in source.cells
                      if c.metadata.get("nbgrader", {}).get("grade")]
        for student in ("solution", "wrong"):
            page = (course / "feedback" / student / lab / f"{path.stem}.html").read_text(encoding="utf-8")
            assert "Test cell</a>" not in page and "Written response</a>" not in page
            labels = {m["gid"]: m["label"] for m in _PART_LABEL.finditer(page)}
            for gid in graded_ids:
                part = gid.split("_")[0]
                expected = f"Part {part}" if len(part) == 1 else f"Part {part[0]}, check {part}"
                if gid.endswith("_written"):
                    expected += " (written)"
                assert labels.get(part) == expected, f"{lab} {student}: {gid} is labelled {labels.get(part)!r}"


@pytest.mark.parametrize("lab", LABS)
def test_released_version_gets_no_point(graded, lab):
    assert graded[lab]["scores"]["blank"]["auto"] == 0.0, graded[lab]["scores"]["blank"]


@pytest.mark.parametrize("lab", LABS)
def test_typical_wrong_answer_gets_some_points(graded, lab):
    scores = graded[lab]["scores"]["wrong"]
    expected = MISTAKES[lab][1]
    assert 0 < scores["auto"] < scores["max"]
    assert scores["auto"] == expected, \
        f"{lab}: the wrong answer got {scores['auto']} of {scores['max']}, not {expected}"


@pytest.mark.parametrize("lab", LABS)
def test_feedback_is_written_and_names_the_failure(graded, lab):
    course = graded[lab]["course"]
    for path in LABS[lab]:
        for student in ("solution", "blank", "wrong"):
            page = course / "feedback" / student / lab / f"{path.stem}.html"
            assert page.is_file(), f"no feedback for {student}"
        wrong = (course / "feedback" / "wrong" / lab / f"{path.stem}.html").read_text(encoding="utf-8")
        phrase = " ".join(html.unescape(MISTAKES[lab][2]).split())
        assert phrase in _feedback_text(course, "wrong", lab, path.stem), \
            "the feedback shows the failing test's message"
        assert "output_error" in wrong
        solution = (course / "feedback" / "solution" / lab / f"{path.stem}.html").read_text(encoding="utf-8")
        assert "output_error" not in solution, "the solution's feedback shows an error"


_REGION = re.compile(r"^[ \t]*### BEGIN (SOLUTION|HIDDEN TESTS)[ \t]*\n(.*?)^[ \t]*### END \1", re.M | re.S)


@pytest.mark.parametrize("lab", LABS)
def test_feedback_shows_no_answer(graded, lab):
    """A student who failed every part gets feedback with no line of the solution (the blank submission; the wrong
    one is the solution with a mistake), and no submission's feedback shows a grader-side frame."""
    course = graded[lab]["course"]
    for path in LABS[lab]:
        source = nbformat.read(path, as_version=4)
        # given code, visible tests and the task's text (which may spell out a call over two lines), spaces dropped
        outside = re.sub(r"\s+", "", "\n".join(_REGION.sub("", c.source) for c in source.cells))
        solution_lines = {line.strip() for c in source.cells for kind, body in _REGION.findall(c.source)
                          if kind == "SOLUTION" for line in body.split("\n")
                          if len(line.strip()) >= 25 and re.sub(r"\s+", "", line) not in outside}
        assert solution_lines, f"{lab}: no solution line to look for"
        for student in ("blank", "wrong"):
            text = _feedback_text(course, student, lab, path.stem)
            code = re.sub(r"\s+", "", text)       # highlighted code: every token in a tag of its own
            shown = [line for line in solution_lines if re.sub(r"\s+", "", line) in code]
            assert student == "wrong" or not shown, f"{lab}: the {student} feedback shows solution lines: {shown[:3]}"
            assert "uwtutor_grader/" not in text and "uwtutor/exercises" not in text and "site-packages" not in text, \
                "a grader-side frame is shown"
            assert f'_verdict=check_part("{lab}",' in code
            # every hidden test shown (in its cell, and in a traceback's context lines, which may stop inside it) is
            # the call and nothing else
            chunks = text.split("### BEGIN HIDDEN TESTS")[1:]
            assert len(chunks) >= len(lab_parts(lab))
            calls = [re.sub(r"\d+", "", f'fromuwtutor_graderimportcheck_part_verdict=check_part("{lab}","{part}",'
                                        'globals())assert_verdict,_verdict') for part in lab_parts(lab)]
            for chunk in chunks:
                region = re.split(r"### END HIDDEN TESTS|\w+Error :|Traceback|Cell In", chunk)[0]
                body = re.sub(r"\s+|\d+|---->", "", region)
                assert any(call.startswith(body) for call in calls), \
                    f"{lab}: a hidden test shows more than the call: {region[:300]}"


def test_checksum_warnings_name_only_cells_with_hidden_tests(graded):
    """nbgrader warns "Attribute 'checksum' for cell ... has changed!" when it puts the hidden tests back into a
    submitted test cell (labs/README.md says so): every such warning names a test cell that has hidden tests."""
    log = graded["_autograde_log"]
    named = set(re.findall(r"Attribute 'checksum' for cell (\S+) has changed", log))
    assert named, "nbgrader no longer warns about restored test cells: update exercises/labs/README.md"
    with_hidden = {c.metadata["nbgrader"]["grade_id"] for nbs in LABS.values() for path in nbs
                   for c in nbformat.read(path, as_version=4).cells if "BEGIN HIDDEN TESTS" in c.source}
    assert named <= with_hidden, named - with_hidden


@pytest.mark.parametrize("lab", LABS)
def test_unanswered_lab_fails_only_where_answers_are_missing(graded, lab):
    """In the graded blank version, given cells run (or stop at NotImplementedError); tests fail by assertion."""
    course = graded[lab]["course"]
    for path in LABS[lab]:
        nb = nbformat.read(course / "autograded" / "blank" / lab / path.name, as_version=4)
        for index, cell in enumerate(nb.cells):
            errors = [o.ename for o in cell.get("outputs", []) if o.output_type == "error"]
            meta = cell.metadata.get("nbgrader", {})
            allowed = {"NotImplementedError", "AssertionError"} if meta.get("grade") else {"NotImplementedError"}
            assert set(errors) <= allowed, f"cell {index} ({meta.get('grade_id')}) raised {errors}"


@pytest.mark.parametrize("lab", LABS)
def test_released_version_has_no_solution_and_no_hidden_test(graded, lab):
    course = graded[lab]["course"]
    for path in LABS[lab]:
        released = nbformat.read(course / "release" / lab / path.name, as_version=4)
        text = "\n".join(c.source for c in released.cells)
        assert "BEGIN SOLUTION" not in text and "HIDDEN TESTS" not in text
        assert CODE_STUB[1] in text and "YOUR ANSWER HERE" in text


# -- uwtutor labs: the same sources without nbgrader ------------------------------------------------------------------
def test_uwtutor_labs_writes_student_versions_and_never_clobbers(tmp_path, capsys):
    dest = tmp_path / "labs"
    assert main(["labs", str(dest)]) == 0
    for lab, notebooks in LABS.items():
        for path in notebooks:
            student = nbformat.read(dest / lab / path.name, as_version=4)
            text = "\n".join(c.source for c in student.cells)
            assert "BEGIN SOLUTION" not in text and "HIDDEN TESTS" not in text
            assert CODE_STUB[1] in text and "YOUR ANSWER HERE" in text
            source = {c.metadata["nbgrader"]["grade_id"]: c.metadata["nbgrader"]
                      for c in nbformat.read(path, as_version=4).cells if "nbgrader" in c.metadata}
            copied = {c.metadata["nbgrader"]["grade_id"]: c.metadata["nbgrader"]
                      for c in student.cells if "nbgrader" in c.metadata}
            assert copied.keys() == source.keys(), "the copy keeps nbgrader's metadata"
            assert all(copied[g].get("points") == source[g].get("points") for g in copied)
            assert all(not c.get("outputs") for c in student.cells if c.cell_type == "code")
    assert not (dest / "instructor-notes").exists(), "instructor notes are not a lab"
    mine = dest / "ekf_consistency" / "ekf_consistency.ipynb"
    mine.write_text(mine.read_text(encoding="utf-8").replace("Q_colleague", "Q_mine"), encoding="utf-8")
    capsys.readouterr()
    assert main(["labs", str(dest)]) == 0
    out = capsys.readouterr().out
    assert f"Skipped {sum(len(nbs) for nbs in LABS.values())} notebooks" in out
    assert "ekf_consistency/ekf_consistency.ipynb" in out
    assert "Q_mine" in mine.read_text(encoding="utf-8"), "a student's work is never overwritten"
    assert main(["labs", str(dest), "--lab", "ekf_consistency", "--force"]) == 0
    assert "Q_mine" not in mine.read_text(encoding="utf-8")


def test_uwtutor_labs_errors(tmp_path, capsys):
    assert main(["labs", str(tmp_path / "x"), "--lab", "no_such_lab"]) == 2
    assert "no lab named no_such_lab" in capsys.readouterr().err
    a_file = tmp_path / "file"
    a_file.write_text("x")
    assert main(["labs", str(a_file)]) == 2
    assert main(["labs", str(tmp_path / "y"), "--source", str(tmp_path / "nowhere")]) == 2
    with pytest.raises(ValueError, match="source directory"):
        write_lab_versions(LABS_DIR, LABS_DIR)


# -- the project's JupyterLab is a student's: nbgrader is installed for these tests, not shown ------------------------
def _jupyter(*args: str) -> str:
    env = {k: v for k, v in os.environ.items() if not k.startswith(("JUPYTER", "JPY_"))}
    proc = cpu_limits.run([str(Path(sys.executable).with_name("jupyter")), *args], capture_output=True, text=True,
                          cpu_seconds=120, env=env)
    assert proc.returncode == 0, proc.stderr
    return re.sub(r"\x1b\[[0-9;]*m", "", proc.stdout + proc.stderr)


def test_nbgrader_extensions_are_disabled_in_the_project_environment():
    """`make setup` disables nbgrader's JupyterLab extension and server extensions (`make lab` is a student's view:
    no nbgrader menu, no "Create Assignment" sidebar); jupytext, whose extension fails under JupyterLab 4.5, is gone."""
    if not Path(sys.executable).with_name("jupyter").exists():
        pytest.skip("no jupyter in this environment")
    labextensions = _jupyter("labextension", "list")
    assert re.search(r"@jupyter/nbgrader v\S+ disabled", labextensions), labextensions
    assert "jupytext" not in labextensions, "jupytext's extension does not load under JupyterLab 4.5: run make setup"
    server = _jupyter("server", "extension", "list")
    listed = re.findall(r"^\s*(nbgrader\.server_extensions\.\w+) (enabled|disabled)", server, re.M)
    assert listed and all(state == "disabled" for _, state in listed), listed
