"""Where the book and its build live, and the pages of its table of contents: shared by the tests.

A module of its own (not conftest.py), because two conftest.py files -- tests/ and book/ -- are both imported as
``conftest`` by pytest, and ``from conftest import ...`` would get whichever came first.
"""

from __future__ import annotations

import contextlib
import re
import shutil
import socket
import subprocess
import sys
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
BUILD_DIR = REPO / "_build"
HTML_DIR = BUILD_DIR / "html"
BUILD_LOG = BUILD_DIR / "book-build.log"
BUILD_TIMEOUT = 3600  # seconds of CPU time (tests/cpu_limits.py), not of the wall

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


@contextlib.contextmanager
def serve_directory(directory: Path) -> Iterator[str]:
    """Serve ``directory`` with ``python -m http.server`` on a free port of 127.0.0.1; yields the base URL.

    Waits for the server's own event, the line ``Serving HTTP on ...`` it prints once it listens (or the end of its
    output if it failed), not for a number of seconds: a busy machine only makes the wait longer.
    """
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    server = subprocess.Popen([sys.executable, "-u", "-m", "http.server", "--bind", "127.0.0.1", "--directory",
                               str(directory), str(port)], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                              text=True)
    base = f"http://127.0.0.1:{port}/"
    try:
        first = server.stdout.readline()          # blocks until the server listens, or exits (then: "")
        if not first.startswith("Serving HTTP"):
            raise RuntimeError(f"python -m http.server did not start on port {port}: {first!r}")
        threading.Thread(target=server.stdout.read, daemon=True).start()    # keep its log pipe from filling
        yield base
    finally:
        server.terminate()
        try:
            server.wait(timeout=10)
        except subprocess.TimeoutExpired:
            server.kill()
