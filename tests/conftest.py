"""Shared fixtures: the strict book build (used by the build and browser tests) and the table of contents."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import time
from pathlib import Path

import pytest

import cpu_limits

from book_paths import (BUILD_CMD, BUILD_DIR, BUILD_LOG, BUILD_TIMEOUT, HTML_DIR, REPO, _ANSI,  # noqa: F401 (re-exported)
                        jupyter_book_exe, toc_docnames)


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
        proc = cpu_limits.run(
            [jupyter_book_exe(), *BUILD_CMD],
            cwd=REPO,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            errors="replace",
            cpu_seconds=BUILD_TIMEOUT,
        )
    except subprocess.TimeoutExpired as exc:
        out = exc.stdout if isinstance(exc.stdout, str) else (exc.stdout or b"").decode(errors="replace")
        BUILD_LOG.write_text(out)
        pytest.fail(f"jupyter-book build used more than {BUILD_TIMEOUT} s of CPU time; partial log in {BUILD_LOG}")
    seconds = time.perf_counter() - start
    output = _ANSI.sub("", proc.stdout)
    BUILD_LOG.write_text(output)
    return BookBuild(proc.returncode, output, seconds)


# --- the PDF edition (tests/test_pdf.py) ------------------------------------------------------------------------------

@dataclasses.dataclass
class PdfBuild:
    returncode: int
    output: str  # what tools/build_pdf.py printed: Sphinx, then latexmk and xelatex
    seconds: float  # wall clock
    cpu_seconds: float  # user + system time of the build and its children (xelatex)


PDF_BUILD_TIMEOUT = 1800  # seconds of CPU time (tests/cpu_limits.py), not of the wall


@pytest.fixture(scope="session")
def pdf_build(tmp_path_factory, worker_id) -> PdfBuild:
    """Build the PDF edition once per test session (`make pdf`'s command), whichever worker asks first.

    The same pattern as ``book_build``: a file lock and a record shared by the xdist workers. The PDF build has its
    own output folder (_build/pdf/), so it may run while the HTML build runs in _build/.
    """
    if worker_id == "master":
        return _run_pdf_build()
    from filelock import FileLock

    shared = tmp_path_factory.getbasetemp().parent
    record = shared / "pdf-build.json"
    with FileLock(str(shared / "pdf-build.lock")):
        if record.exists():
            return PdfBuild(**json.loads(record.read_text()))
        build = _run_pdf_build()
        record.write_text(json.dumps(dataclasses.asdict(build)))
        return build


def _run_pdf_build() -> PdfBuild:
    import resource
    import sys

    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    try:
        proc = cpu_limits.run([sys.executable, str(REPO / "tools" / "build_pdf.py")], cwd=REPO,
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, errors="replace",
                              cpu_seconds=PDF_BUILD_TIMEOUT)
    except subprocess.TimeoutExpired:
        pytest.fail(f"the PDF build used more than {PDF_BUILD_TIMEOUT} s of CPU time", pytrace=False)
    seconds = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return PdfBuild(proc.returncode, _ANSI.sub("", proc.stdout), seconds, cpu)
