"""Shared fixtures: the strict book build (used by the build and browser tests) and the table of contents."""

from __future__ import annotations

import dataclasses
import json
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
BUILD_DIR = REPO / "_build"
HTML_DIR = BUILD_DIR / "html"
BUILD_LOG = BUILD_DIR / "book-build.log"
BUILD_TIMEOUT = 3600  # seconds; the notebooks run in this build unless cached

# The build command of `make book`, in the strict form: warnings are errors (-W), nitpicky
# cross-references (-n), every warning reported (--keep-going), every page re-read (--all: without
# it an unchanged page with a warning is not re-read and the rebuild passes).
BUILD_CMD = ["build", "--all", "-W", "-n", "--keep-going", "."]

_ANSI = re.compile(r"\x1b\[[0-9;]*[A-Za-z]")


def jupyter_book_exe() -> str:
    """The jupyter-book of the running interpreter's environment (the project's venv)."""
    beside = Path(sys.executable).with_name("jupyter-book")
    if beside.exists():
        return str(beside)
    found = shutil.which("jupyter-book")
    if not found:
        pytest.fail("jupyter-book is not installed in this environment: run `make setup`")
    return found


def toc_docnames(toc_path: Path = REPO / "_toc.yml") -> list[str]:
    """Every page of the book's table of contents, root first, in reading order."""
    import yaml  # PyYAML: a dependency of jupyter-book

    toc = yaml.safe_load(toc_path.read_text(encoding="utf-8"))
    names: list[str] = [toc["root"]]

    def walk(node):
        if isinstance(node, dict):
            if "file" in node:
                names.append(node["file"])
            for key in ("parts", "chapters", "sections", "subtrees", "entries"):
                if key in node:
                    walk(node[key])
        elif isinstance(node, list):
            for item in node:
                walk(item)

    walk({k: v for k, v in toc.items() if k != "root"})
    # Drop source suffixes: _toc.yml may name `book/ch01.ipynb` or `book/ch01`.
    return [re.sub(r"\.(md|ipynb|rst)$", "", n) for n in names]


@dataclasses.dataclass
class BookBuild:
    returncode: int
    output: str  # stdout and stderr, interleaved, ANSI colours removed
    seconds: float
    html_dir: Path = HTML_DIR

    @property
    def lines(self) -> list[str]:
        return self.output.splitlines()


@pytest.fixture(scope="session")
def book_build(tmp_path_factory, worker_id) -> BookBuild:
    """Run the strict Jupyter Book build once per test session, whichever worker asks first.

    Under pytest-xdist each worker has its own session fixtures; the build tests and the browser tests may
    run in two workers, and two builds in one ``_build/`` would trample each other. The first worker to ask
    builds under a file lock and records the result; the others wait for the lock and read it.
    """
    if worker_id == "master":  # no xdist: this process is the whole session
        return _run_book_build()
    from filelock import FileLock

    shared = tmp_path_factory.getbasetemp().parent  # one folder for every worker of this run
    record = shared / "book-build.json"
    with FileLock(str(shared / "book-build.lock")):
        if record.exists():
            data = json.loads(record.read_text())
            return BookBuild(data["returncode"], data["output"], data["seconds"])
        build = _run_book_build()
        record.write_text(json.dumps({"returncode": build.returncode, "output": build.output,
                                      "seconds": build.seconds}))
        return build


def _run_book_build() -> BookBuild:
    BUILD_DIR.mkdir(exist_ok=True)
    start = time.perf_counter()
    try:
        proc = subprocess.run(
            [jupyter_book_exe(), *BUILD_CMD],
            cwd=REPO,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            errors="replace",
            timeout=BUILD_TIMEOUT,
        )
    except subprocess.TimeoutExpired as exc:
        out = exc.stdout if isinstance(exc.stdout, str) else (exc.stdout or b"").decode(errors="replace")
        BUILD_LOG.write_text(out)
        pytest.fail(f"jupyter-book build took more than {BUILD_TIMEOUT} s; partial log in {BUILD_LOG}")
    seconds = time.perf_counter() - start
    output = _ANSI.sub("", proc.stdout)
    BUILD_LOG.write_text(output)
    return BookBuild(proc.returncode, output, seconds)
