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
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
import tarfile
import zipfile
from pathlib import Path

import nbformat
import pytest

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
    proc = subprocess.run(args, cwd=cwd, capture_output=True, text=True, timeout=300, env=_clean_env(), **kwargs)
    assert proc.returncode == 0, f"{' '.join(map(str, args))} failed ({proc.returncode}):\n{proc.stdout}\n{proc.stderr}"
    return proc


def _source_files() -> set[str]:
    """The exercise tree's files (relative paths) that the wheel must carry: all but hidden files and caches."""
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
    proc = subprocess.run([sys.executable, "-c", BUILD_SCRIPT, str(dist)], cwd=src, capture_output=True, text=True,
                          timeout=300, env=_clean_env())
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
    assert shipped == _source_files()
    assert any(s.endswith(".ipynb") for s in shipped)
    assert "uwtutor/__main__.py" in names and "uwtutor/py.typed" in names
    assert not any(n.startswith(("tests/", "exercises/", "benchmarks/", "book/")) for n in names)
    assert "License-Expression: MIT" in metadata
    assert "uwtutor = uwtutor.exercises.cli:main" in entry_points
    with tarfile.open(sdist) as tar:
        in_sdist = {Path(n).relative_to(Path(n).parts[0]).as_posix() for n in tar.getnames() if "/" in n}
    assert {f"exercises/{s}" for s in _source_files()} <= in_sdist


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


def test_installed_wheel_reads_the_committed_real_data_study(installed, tmp_path):
    # chapter 11's runs travel with the library too (its widget reads them without gtsam or the Plaza files)
    python = installed / "bin" / "python"
    proc = _run([str(python), "-c", "from uwtutor.datasets.study import load_real_data_study as f; s = f(); "
                                    "print(len(s.table), s.grid['curves']['xy'].shape)"], cwd=tmp_path)
    from uwtutor.datasets.study import load_real_data_study
    study = load_real_data_study()
    assert proc.stdout.strip() == f"{len(study.table)} {study.grid['curves']['xy'].shape}"
