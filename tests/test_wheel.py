"""The package as a student installs it: a wheel built from this checkout, installed into a fresh environment.

The build goes the way ``python -m build`` goes, offline: the sdist is built from a copy of the checkout, then the
wheel from the unpacked sdist, by calling setuptools' PEP 517 hooks in a fresh process with the project
environment's setuptools (no build isolation, so nothing is downloaded). The build must print no warning.

The wheel is then installed with ``--no-deps`` into a new virtual environment made without pip; the dependencies
(numpy, nbformat, ...) come from the project's environment through a ``.pth`` file, which adds its site-packages
*after* the new environment's own (so the installed wheel, not the checkout's editable install, is what imports;
``.pth`` files inside that directory, such as the editable install's finder, are not processed). In that
environment, from a directory outside the checkout, ``uwtutor exercises DIR`` and ``python -m uwtutor exercises DIR``
must write every student notebook, identical to what the checkout's generator makes, with no solution left in it.

The wheel carries the student versions only: no file in it may hold a solution or hidden-test marker, a line of a
solution or of a hidden test, or an instructor note (the sdist, for instructors, has the sources and the notes), and
no grading code: no module of the instructor's grader (``exercises/labs/grader/uwtutor_grader``), no line of one, no
``check_part``; a student's environment (the installed wheel) cannot import a grader.

Last, what a student does (``pip install "uwtutor[lab]"``, then opens an exercise): the wheel is installed with its
``lab`` extra into a fresh virtual environment, offline, from a wheelhouse of the pinned versions
(``constraints.txt``) kept in the project's environment (``.venv/wheelhouse``, downloaded from PyPI on first use);
JupyterLab, jupyterlab-myst and the widgets' extension must be there, and a kernel of that environment runs the
first cells of an exercise notebook written by its ``uwtutor exercises``.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import sysconfig
import tarfile
import zipfile
from pathlib import Path

import nbformat
import pytest

import cpu_limits

from uwtutor.exercises.generate import make_student_version

REPO = Path(__file__).resolve().parents[1]
SOURCES = REPO / "exercises"
#: What the sdist is built from: the files setuptools reads (pyproject.toml, setup.py, MANIFEST.in, README.md)
#: and the two trees that end up in the wheel.
BUILD_INPUTS = ["pyproject.toml", "setup.py", "MANIFEST.in", "README.md", "LICENSE", "uwtutor", "exercises"]
IGNORED = shutil.ignore_patterns(".*", "__pycache__", "*.pyc", "*.egg-info", "gradebook.db")

BUILD_SCRIPT = r"""
import os, sys, tarfile
from pathlib import Path
import setuptools.build_meta as backend

dist = Path(sys.argv[1])
sdist = dist / backend.build_sdist(str(dist))
with tarfile.open(sdist) as tar:
    tar.extractall(dist / "unpacked", filter="data")
os.chdir(next((dist / "unpacked").iterdir()))
print("WHEEL=" + backend.build_wheel(str(dist)))
"""


def _clean_env(**extra: str) -> dict[str, str]:
    """The environment without anything that would point Python at the checkout or change what a build prints."""
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "PYTHONHOME", "PYTHONDONTWRITEBYTECODE", "PYTHONWARNINGS", "VIRTUAL_ENV")}
    env.update(extra)
    return env


def _run(args: list[str], cwd: Path, **kwargs) -> subprocess.CompletedProcess:
    proc = cpu_limits.run(args, cwd=cwd, capture_output=True, text=True, cpu_seconds=300, env=_clean_env(), **kwargs)
    assert proc.returncode == 0, f"{' '.join(map(str, args))} failed ({proc.returncode}):\n{proc.stdout}\n{proc.stderr}"
    return proc


def _student_files() -> set[str]:
    """What the wheel carries of the exercise tree: each exercise notebook and each lab notebook (student versions)."""
    from uwtutor.exercises.generate import list_exercise_sources, list_lab_sources

    found = {p.name for p in list_exercise_sources(SOURCES)}
    for lab, notebooks in list_lab_sources(SOURCES / "labs").items():
        found |= {f"labs/{lab}/{p.name}" for p in notebooks}
    return found


def _source_files() -> set[str]:
    """The exercise tree's files (relative paths) that the sdist must carry: all but hidden files and caches."""
    found = set()
    for path in SOURCES.rglob("*"):
        rel = path.relative_to(SOURCES)
        if path.is_file() and not any(p.startswith(".") or p == "__pycache__" for p in rel.parts) \
                and path.suffix != ".pyc" and path.name != "gradebook.db":
            found.add(rel.as_posix())
    return found


@pytest.fixture(scope="module")
def build(tmp_path_factory):
    """Build the sdist and the wheel; returns (wheel path, sdist path, build output)."""
    pytest.importorskip("setuptools", minversion="77", reason="the build needs setuptools >= 77 (run make setup)")
    root = tmp_path_factory.mktemp("wheel-build")
    src, dist = root / "src", root / "dist"
    src.mkdir()
    dist.mkdir()
    for name in BUILD_INPUTS:
        path = REPO / name
        if path.is_dir():
            shutil.copytree(path, src / name, ignore=IGNORED)
        else:
            shutil.copy2(path, src / name)
    proc = cpu_limits.run([sys.executable, "-c", BUILD_SCRIPT, str(dist)], cwd=src, capture_output=True, text=True,
                          cpu_seconds=300, env=_clean_env())
    output = proc.stdout + proc.stderr
    assert proc.returncode == 0, f"the build failed:\n{output}"
    wheel = dist / output.split("WHEEL=")[-1].strip().splitlines()[0]
    sdist = next(dist.glob("*.tar.gz"))
    return wheel, sdist, output


@pytest.fixture(scope="module")
def installed(build, tmp_path_factory):
    """A fresh venv with the wheel installed (no deps); returns its directory."""
    wheel, _, _ = build
    venv = tmp_path_factory.mktemp("wheel-venv") / "venv"
    _run([sys.executable, "-m", "venv", "--without-pip", str(venv)], cwd=venv.parent)
    python = venv / "bin" / "python"
    purelib = Path(_run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                        cwd=venv.parent).stdout.strip())
    ours = {sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"]}
    (purelib / "zz_uwtutor_test_dependencies.pth").write_text("".join(f"{p}\n" for p in sorted(ours)))
    _run([sys.executable, "-m", "pip", "--python", str(python), "--disable-pip-version-check", "install",
          "--no-deps", "--no-index", "--quiet", str(wheel)], cwd=venv.parent)
    return venv


def test_build_prints_no_warning(build):
    _, _, output = build
    warnings = [line for line in output.splitlines() if "warn" in line.lower()]
    assert not warnings, "the build warned:\n" + "\n".join(warnings)


def test_wheel_carries_the_exercise_sources_and_the_metadata(build):
    wheel, sdist, _ = build
    with zipfile.ZipFile(wheel) as zf:
        names = zf.namelist()
        metadata = zf.read(next(n for n in names if n.endswith(".dist-info/METADATA"))).decode()
        entry_points = zf.read(next(n for n in names if n.endswith(".dist-info/entry_points.txt"))).decode()
    prefix = "uwtutor/_data/exercises/"
    shipped = {n[len(prefix):] for n in names if n.startswith(prefix) and not n.endswith("/")}
    assert shipped == _student_files(), "the wheel carries the student versions of the notebooks, and nothing else"
    with zipfile.ZipFile(wheel) as zf:
        for name in shipped:
            notebook = nbformat.reads(zf.read(prefix + name).decode("utf-8"), as_version=4)
            expected = make_student_version(SOURCES / name, nbgrader=name.startswith("labs/"))
            assert notebook == expected, f"{name} is not the generator's student version"
    assert "uwtutor/__main__.py" in names and "uwtutor/py.typed" in names
    assert not any(n.startswith(("tests/", "exercises/", "benchmarks/", "book/")) for n in names)
    assert "License-Expression: MIT" in metadata
    assert "uwtutor = uwtutor.exercises.cli:main" in entry_points
    with tarfile.open(sdist) as tar:
        in_sdist = {Path(n).relative_to(Path(n).parts[0]).as_posix() for n in tar.getnames() if "/" in n}
    assert {f"exercises/{s}" for s in _source_files()} <= in_sdist, "the sdist carries the sources (instructors)"
    assert any(n.startswith("exercises/labs/instructor-notes/") for n in in_sdist)


_MARKERS = ("BEGIN SOLUTION", "END SOLUTION", "BEGIN HIDDEN TESTS", "END HIDDEN TESTS")
_REGION = re.compile(r"^[ \t]*#+ *BEGIN (SOLUTION|HIDDEN TESTS)[ \t]*\n(.*?)^[ \t]*#+ *END \1", re.M | re.S)


def _secret_lines() -> dict[str, set[str]]:
    """Lines that must not leave the repository: of solutions and hidden tests (those that appear nowhere else in
    the sources, given code and visible tests of every notebook), and of the instructor notes."""
    from uwtutor.exercises.generate import list_exercise_sources, list_lab_sources

    notebooks = list_exercise_sources(SOURCES) + [p for nbs in list_lab_sources(SOURCES / "labs").values() for p in nbs]
    sources = [c.source for path in notebooks for c in nbformat.read(path, as_version=4).cells]
    public = "\n".join(_REGION.sub("", source) for source in sources)
    secret: dict[str, set[str]] = {"solution": set(), "hidden test": set(), "instructor note": set()}
    for source in sources:
        for kind, body in _REGION.findall(source):
            secret["solution" if kind == "SOLUTION" else "hidden test"] |= {
                line.strip() for line in body.split("\n") if len(line.strip()) >= 20 and line.strip() not in public}
    for note in (SOURCES / "labs" / "instructor-notes").glob("*.md"):
        secret["instructor note"] |= {line.strip() for line in note.read_text(encoding="utf-8").split("\n")
                                      if len(line.strip()) >= 40}
    return secret


def test_wheel_holds_no_solution_hidden_test_or_instructor_note(build):
    """The notebooks and data of the wheel hold no marker and no line of a solution or hidden test; no file of the
    wheel holds a line of an instructor note, or a marked region of a source. (The library's modules may name the
    markers: the generator and the graders work with them.)"""
    wheel, _, _ = build
    secret = _secret_lines()
    assert all(secret.values()), "nothing to look for: the sources have changed shape"
    found = []
    with zipfile.ZipFile(wheel) as zf:
        for name in zf.namelist():
            if "instructor" in name.lower():
                found.append(f"{name}: an instructor's file")
            try:
                text = zf.read(name).decode("utf-8")
            except UnicodeDecodeError:
                continue
            if name.startswith("uwtutor/_data/") or name.endswith(".ipynb"):
                if name.endswith(".ipynb"):
                    text = "\n".join(c.source for c in nbformat.reads(text, as_version=4).cells)
                found += [f"{name}: {marker!r}" for marker in _MARKERS if marker in text]
                found += [f"{name}: a line of a {kind}: {line!r}" for kind in ("solution", "hidden test")
                          for line in secret[kind] if line in text]
            for kind, body in _REGION.findall(text):
                if any(line.strip() in secret["solution"] | secret["hidden test"] for line in body.split("\n")):
                    found.append(f"{name}: a marked {kind.lower()} region of a source")
            found += [f"{name}: a line of an instructor note: {line[:60]!r}" for line in secret["instructor note"]
                      if line in text]
    assert not found, "the wheel gives students what is the instructor's:\n" + "\n".join(found[:20])


GRADER = SOURCES / "labs" / "grader" / "uwtutor_grader"


def _grader_lines() -> set[str]:
    """The grader's own code lines (>= 30 characters; imports, comments and doctest lines out) that appear nowhere in
    the library or in a notebook's given code, task text and visible tests: what only the grader says."""
    public = "\n".join(p.read_text(encoding="utf-8") for p in (REPO / "uwtutor").rglob("*.py"))
    notebooks = [p for p in SOURCES.rglob("*.ipynb") if ".ipynb_checkpoints" not in p.parts]
    public += "\n".join(_REGION.sub("", c.source) for p in notebooks for c in nbformat.read(p, as_version=4).cells)
    lines = set()
    for module in GRADER.glob("*.py"):
        for line in module.read_text(encoding="utf-8").split("\n"):
            line = line.strip()
            if len(line) >= 30 and not line.startswith(("from ", "import ", "#", '"""', ">>>", "...")) \
                    and line not in public:
                lines.add(line)
    return lines


def test_wheel_holds_no_grading_code(build):
    """The hidden tests and the code computing their references stay with the instructor: no file of the wheel is or
    quotes the grader (naming it, as the READMEs do, is fine)."""
    wheel, sdist, _ = build
    secret = _grader_lines()
    assert len(secret) > 200, "the grader has changed shape: update this test"
    found = []
    with zipfile.ZipFile(wheel) as zf:
        names = zf.namelist()
        found += [f"{n}: a grader's file" for n in names
                  if "uwtutor_grader" in n or "/grader/" in n or ("/labs/" in n and n.endswith(".py"))]
        for name in names:
            try:
                text = zf.read(name).decode("utf-8")
            except UnicodeDecodeError:
                continue
            found += [f"{name}: {word!r}" for word in ("check_part(", "def part_") if word in text]
            found += [f"{name}: a line of the grader: {line[:70]!r}" for line in secret if line in text]
    assert not found, "the wheel ships grading code:\n" + "\n".join(found[:20])
    with tarfile.open(sdist) as tar:         # the instructor's distribution carries the grader
        assert any(n.endswith("exercises/labs/grader/uwtutor_grader/real_ranges_plaza.py") for n in tar.getnames())


def test_installed_wheel_cannot_grade(installed, tmp_path):
    """A student's environment cannot pre-grade a lab: the grader and the old module of hidden tests are absent."""
    python = installed / "bin" / "python"
    probe = ("import importlib.util as u; print([m for m in ('uwtutor_grader', 'uwtutor.exercises.labs') "
             "if u.find_spec(m) is not None])")
    env = _clean_env()
    proc = subprocess.run([str(python), "-c", probe], cwd=tmp_path, capture_output=True, text=True, timeout=120,
                          env=env)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "[]", proc.stdout


def test_installed_package_is_the_wheel_not_the_checkout(installed, tmp_path):
    python = installed / "bin" / "python"
    proc = _run([str(python), "-c", "import uwtutor, uwtutor.exercises.generate as g; "
                                    "print(uwtutor.__file__); print(g.exercise_source_dir())"], cwd=tmp_path)
    module, sources = (Path(line) for line in proc.stdout.split())
    assert module.is_relative_to(installed) and sources.is_relative_to(installed)
    assert not module.is_relative_to(REPO)


@pytest.mark.parametrize("command", [["bin/uwtutor"], ["bin/python", "-m", "uwtutor"]],
                         ids=["uwtutor", "python -m uwtutor"])
def test_commands_write_student_notebooks_without_solutions(installed, tmp_path, command):
    dest = tmp_path / "my-work"
    proc = _run([str(installed / command[0]), *command[1:], "exercises", str(dest)], cwd=tmp_path)
    expected = sorted(p.name for p in SOURCES.glob("*.ipynb"))
    assert expected and sorted(p.name for p in dest.glob("*.ipynb")) == expected
    assert f"Wrote {len(expected)} notebook" in proc.stdout
    for name in expected:
        text = (dest / name).read_text(encoding="utf-8")
        assert "BEGIN SOLUTION" not in text and "END SOLUTION" not in text and "HIDDEN TESTS" not in text
        student = nbformat.reads(text, as_version=4)
        assert student == make_student_version(SOURCES / name), f"{name} differs from the checkout's student version"
        assert any("YOUR CODE HERE" in c.source for c in student.cells)
    again = _run([str(installed / command[0]), *command[1:], "exercises", str(dest)], cwd=tmp_path)
    assert "Skipped" in again.stdout                          # a second run never overwrites the student's work


def test_wheel_carries_the_license(build):
    import zipfile

    wheel, _, _ = build
    with zipfile.ZipFile(wheel) as zf:
        names = zf.namelist()
        licence = [n for n in names if n.endswith("LICENSE")]
        assert licence, "the wheel has no LICENSE file"
        assert "MIT License" in zf.read(licence[0]).decode("utf-8")


def test_installed_wheel_reads_the_committed_comparison(installed, tmp_path):
    # chapter 10's table travels with the library: methods.load_comparison() works from a wheel, outside the checkout
    python = installed / "bin" / "python"
    proc = _run([str(python), "-c", "from uwtutor import methods; t = methods.load_comparison(); "
                                    "import uwtutor; print(uwtutor.__file__); print(len(t), t.rmse_curves.shape)"],
                cwd=tmp_path)
    module, shape = proc.stdout.strip().splitlines()
    assert Path(module).is_relative_to(installed)
    from uwtutor import methods
    table = methods.load_comparison()
    assert shape == f"{len(table)} {table.rmse_curves.shape}"


def test_installed_wheel_writes_the_labs(installed, tmp_path):
    from uwtutor.exercises.generate import list_lab_sources

    dest = tmp_path / "labs"
    proc = _run([str(installed / "bin" / "uwtutor"), "labs", str(dest)], cwd=tmp_path)
    labs = list_lab_sources(SOURCES / "labs")
    assert f"Wrote {sum(len(nbs) for nbs in labs.values())} notebooks" in proc.stdout
    for lab, notebooks in labs.items():
        for path in notebooks:
            student = nbformat.read(dest / lab / path.name, as_version=4)
            assert student == make_student_version(path, nbgrader=True)
            assert any(c.metadata.get("nbgrader", {}).get("points") for c in student.cells), \
                "a lab's copy carries nbgrader's metadata (without it autograde scores 0)"
    assert not (dest / "instructor-notes").exists()


# -- pip install "uwtutor[lab]": what a student needs to open the exercises --------------------------------------------
WHEELHOUSE = Path(sys.prefix) / "wheelhouse"


def _requirements(metadata: str, extra: str) -> list[str]:
    """The wheel's requirements without an extra and those of ``extra`` (markers dropped; self-references out)."""
    found = []
    for line in metadata.splitlines():
        if not line.startswith("Requires-Dist: "):
            continue
        requirement, _, marker = line[len("Requires-Dist: "):].partition(";")
        marker = marker.strip()
        if requirement.strip().startswith("uwtutor"):
            continue
        if not marker or marker.replace("'", '"') == f'extra == "{extra}"':
            found.append(requirement.strip())
    return found


@pytest.fixture(scope="module")
def lab_venv(build, tmp_path_factory):
    """A fresh venv (with pip) and ``pip install WHEEL[lab]`` into it, offline from the wheelhouse."""
    wheel, _, _ = build
    with zipfile.ZipFile(wheel) as zf:
        metadata = zf.read(next(n for n in zf.namelist() if n.endswith(".dist-info/METADATA"))).decode()
    requirements = _requirements(metadata, "lab")
    assert any(r.startswith("jupyterlab") for r in requirements) and any(r.startswith("ipykernel")
                                                                         for r in requirements)
    venv = tmp_path_factory.mktemp("lab-venv") / "venv"
    _run([sys.executable, "-m", "venv", str(venv)], cwd=venv.parent)
    python = str(venv / "bin" / "python")
    install = [python, "-m", "pip", "install", "--disable-pip-version-check", "--quiet", "--no-compile", "--no-index",
               "--find-links", str(WHEELHOUSE), "--only-binary", ":all:", f"{wheel}[lab]"]
    proc = cpu_limits.run(install, cwd=venv.parent, capture_output=True, text=True, cpu_seconds=600, env=_clean_env())
    if proc.returncode != 0:        # the wheelhouse lacks a pinned version: fetch the missing wheels once
        download = [sys.executable, "-m", "pip", "download", "--disable-pip-version-check", "--quiet", "--dest",
                    str(WHEELHOUSE), "--only-binary", ":all:", "-c", str(REPO / "constraints.txt"), *requirements]
        fetched = cpu_limits.run(download, cwd=REPO, capture_output=True, text=True, cpu_seconds=600, env=_clean_env())
        if fetched.returncode != 0:
            if os.environ.get("CI", "").lower() == "true":
                pytest.fail(f"cannot fill the wheelhouse {WHEELHOUSE} from PyPI:\n{fetched.stderr[-2000:]}")
            pytest.skip(f"the wheelhouse {WHEELHOUSE} lacks wheels and PyPI cannot be reached")
        _run(install, cwd=venv.parent)
    return venv


def test_lab_extra_gives_a_student_jupyterlab_and_a_kernel(lab_venv, tmp_path):
    bin_dir = lab_venv / "bin"
    assert (bin_dir / "jupyter-lab").exists(), "pip install 'uwtutor[lab]' must bring JupyterLab"
    extensions = re.sub(r"\x1b\[[0-9;]*m", "", _run([str(bin_dir / "jupyter"), "labextension", "list"],
                                                    cwd=tmp_path).stderr)
    for name in ("jupyterlab-myst", "@jupyter-widgets/jupyterlab-manager"):
        assert re.search(re.escape(name) + r" v\S+ enabled", extensions), f"{name} missing:\n{extensions}"
    assert "nbgrader" not in extensions and "jupytext" not in extensions
    # a student's first exercise notebook, as `uwtutor exercises` writes it, run by the environment's own kernel
    _run([str(bin_dir / "uwtutor"), "exercises", str(tmp_path / "my-work")], cwd=tmp_path)
    script = r"""
import sys, nbformat
from nbclient import NotebookClient
nb = nbformat.read(sys.argv[1], as_version=4)
first = next(i for i, c in enumerate(nb.cells) if "answer" in c.metadata.get("tags", []))
probe = "import sys, uwtutor; print(sys.executable); print(uwtutor.__file__)"
nb.cells = nb.cells[:first] + [nbformat.v4.new_code_cell(probe)]
NotebookClient(nb, timeout=300, kernel_name="python3").execute()
errors = [o for c in nb.cells for o in c.get("outputs", []) if o.output_type == "error"]
assert not errors, errors
print(nb.cells[-1].outputs[0].text)
"""
    notebook = tmp_path / "my-work" / "ch01_positioning_and_errors.ipynb"
    proc = _run([str(bin_dir / "python"), "-c", script, str(notebook)], cwd=tmp_path)
    kernel_python, module = proc.stdout.split()[-2:]
    assert Path(kernel_python).parent == bin_dir, "the kernel is the lab environment's Python"
    assert Path(module).is_relative_to(lab_venv), "the kernel imports the installed wheel"


def test_installed_wheel_reads_the_committed_real_data_study(installed, tmp_path):
    # chapter 11's runs travel with the library too (its widget reads them without gtsam or the Plaza files)
    python = installed / "bin" / "python"
    proc = _run([str(python), "-c", "from uwtutor.datasets.study import load_real_data_study as f; s = f(); "
                                    "print(len(s.table), s.grid['curves']['xy'].shape)"], cwd=tmp_path)
    from uwtutor.datasets.study import load_real_data_study
    study = load_real_data_study()
    assert proc.stdout.strip() == f"{len(study.table)} {study.grid['curves']['xy'].shape}"
