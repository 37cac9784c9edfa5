"""The code is lint-clean: ``ruff check`` with the rules of ``[tool.ruff]`` in pyproject.toml (pyflakes, pycodestyle,
bugbear, numpy's no-legacy-random rule), over the library, the tests, the benchmarks, the tools and the studies."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

import cpu_limits

REPO = Path(__file__).resolve().parents[1]
RUFF = Path(sys.executable).with_name("ruff")


def _ruff(*args: str, cwd: Path = REPO) -> subprocess.CompletedProcess:
    if not RUFF.exists():
        pytest.fail(f"ruff is not installed in {RUFF.parent} (it comes with the test extra: make setup)", pytrace=False)
    return cpu_limits.run([str(RUFF), "check", "--no-cache", *args], cwd=cwd, capture_output=True, text=True,
                          cpu_seconds=300)


def test_ruff_is_clean():
    proc = _ruff()
    assert proc.returncode == 0, f"ruff check found problems (fix them, or `ruff check --fix`):\n{proc.stdout}"


def test_the_rules_apply():
    """The configuration is the one read: an unused import, a legacy global random draw and a 121-column line fail."""
    probe = REPO / "tests" / "_lint_probe.py"
    probe.write_text("import os\nimport numpy as np\n\nx = np.random.rand(3)\ny = '" + "a" * 115 + "'\n")
    try:
        proc = _ruff(str(probe.relative_to(REPO)))
    finally:
        probe.unlink()
    assert proc.returncode == 1
    for rule in ("F401", "NPY002", "E501"):
        assert rule in proc.stdout, f"{rule} is not checked:\n{proc.stdout}"


def test_every_library_module_is_checked():
    """The book's and the exercises' folders are left out (notebooks), but not the library's own ``exercises`` and
    ``widgets`` packages: an exclude by folder name once hid ``uwtutor/exercises`` from the check."""
    proc = _ruff("--show-files")
    assert proc.returncode == 0, proc.stderr
    shown = {Path(line.strip()).resolve() for line in proc.stdout.splitlines() if line.strip().endswith(".py")}
    library = {p.resolve() for p in (REPO / "uwtutor").rglob("*.py")}
    missing = sorted(str(p.relative_to(REPO)) for p in library - shown)
    assert not missing, "library modules ruff does not check (see extend-exclude in pyproject.toml): " + \
        ", ".join(missing)
