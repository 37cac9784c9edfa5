"""The package type-checks: ``mypy`` with the settings of ``[tool.mypy]`` in pyproject.toml, as a ratchet.

A module of ``uwtutor`` is either **clean** (no error) or listed in ``tests/mypy_pending.txt`` with the number of
errors it has today. The test fails when a clean module gets an error, when a listed module gets more errors than
its count, and when a listed module gets fewer (then lower its count, or remove the line at zero, so that the list
only shrinks). The modules of ``[[tool.mypy.overrides]]`` with the strict flags (every function annotated, no bare
generics, no ``Any`` returned where a type is declared) are checked strictly; a module joins them once it is clean
under ``mypy --strict``.

``python tests/test_types.py`` prints the current count of every module that has errors (the lines of the file).
"""

from __future__ import annotations

import re
import subprocess
import sys
import tomllib
from collections import Counter
from pathlib import Path

import pytest

import cpu_limits

REPO = Path(__file__).resolve().parents[1]
PENDING = Path(__file__).with_name("mypy_pending.txt")
ERROR = re.compile(r"^(uwtutor/[^:]+\.py):\d+(?::\d+)?: error: ")


def _mypy() -> subprocess.CompletedProcess:
    """mypy over the package (the files of ``[tool.mypy]``), with its cache in the repository's ``.mypy_cache``."""
    try:
        import mypy  # noqa: F401
    except ImportError:
        pytest.fail("mypy is not installed in this environment (it comes with the test extra: make setup)",
                    pytrace=False)
    return cpu_limits.run([sys.executable, "-m", "mypy", "--config-file", "pyproject.toml"], cwd=REPO,
                          capture_output=True, text=True, cpu_seconds=900)


def error_counts(output: str) -> Counter:
    """Errors per module file (``uwtutor/x.py``) in mypy's output."""
    return Counter(m.group(1) for m in map(ERROR.match, output.splitlines()) if m)


def read_pending(path: Path = PENDING) -> dict[str, int]:
    """``module-file count`` lines of the pending file (``#`` comments and blank lines skipped)."""
    out: dict[str, int] = {}
    for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        parts = line.split()
        if len(parts) != 2 or not parts[1].isdigit() or int(parts[1]) < 1:
            raise ValueError(f"{path.name} line {n}: expected 'uwtutor/module.py <errors >= 1>'; got {line!r}")
        if parts[0] in out:
            raise ValueError(f"{path.name} line {n}: {parts[0]} is listed twice")
        out[parts[0]] = int(parts[1])
    return out


def ratchet(counts: Counter, pending: dict[str, int]) -> list[str]:
    """What is wrong with ``counts`` against ``pending``: new errors, more errors, fewer errors (lower the count)."""
    problems = []
    for module, n in sorted(counts.items()):
        allowed = pending.get(module, 0)
        if n > allowed:
            what = "a clean module" if allowed == 0 else f"listed with {allowed}"
            problems.append(f"{module}: {n} error(s), {what}: fix the new ones")
    for module, allowed in sorted(pending.items()):
        n = counts.get(module, 0)
        if n < allowed:
            fix = "remove its line" if n == 0 else f"lower its count to {n}"
            problems.append(f"{module}: {n} error(s), listed with {allowed}: {fix} in tests/mypy_pending.txt")
    return problems


def test_the_package_type_checks_within_the_pending_counts():
    proc = _mypy()
    assert proc.returncode in (0, 1) and "error: " not in proc.stderr, \
        f"mypy did not run (exit {proc.returncode}):\n{proc.stdout}\n{proc.stderr}"
    problems = ratchet(error_counts(proc.stdout), read_pending())
    errors = "\n".join(line for line in proc.stdout.splitlines()
                       if ERROR.match(line) and any(line.startswith(p.split(":")[0]) for p in problems))
    assert not problems, "mypy's ratchet (tests/mypy_pending.txt):\n  " + "\n  ".join(problems) + \
        "\n\nthe errors of those modules:\n" + errors


def test_pending_lists_existing_modules():
    missing = sorted(m for m in read_pending() if not (REPO / m).is_file())
    assert not missing, f"tests/mypy_pending.txt lists modules that no longer exist (remove them): {missing}"


def test_strict_modules_are_not_pending():
    """A module checked strictly is clean: it cannot also be pending."""
    config = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["mypy"]
    strict = {m for o in config.get("overrides", []) if o.get("disallow_untyped_defs") for m in o["module"]}
    assert strict, "pyproject.toml has no [[tool.mypy.overrides]] block with the strict flags"
    pending = {m.removesuffix(".py").removesuffix("/__init__").replace("/", ".") for m in read_pending()}
    assert not strict & pending, f"modules both strict and pending: {sorted(strict & pending)}"


def test_the_ratchet_catches_each_change():
    """The rule itself: a new error, one more, one fewer, all fixed, unchanged."""
    pending = {"uwtutor/a.py": 3}
    assert ratchet(Counter({"uwtutor/a.py": 3}), pending) == []
    assert ratchet(Counter({"uwtutor/a.py": 3, "uwtutor/b.py": 1}), pending) == \
        ["uwtutor/b.py: 1 error(s), a clean module: fix the new ones"]
    assert ratchet(Counter({"uwtutor/a.py": 4}), pending) == \
        ["uwtutor/a.py: 4 error(s), listed with 3: fix the new ones"]
    assert "lower its count to 2" in ratchet(Counter({"uwtutor/a.py": 2}), pending)[0]
    assert "remove its line" in ratchet(Counter(), pending)[0]
    assert error_counts("uwtutor/a.py:12: error: x  [misc]\nuwtutor/a.py:13: note: y\nFound 1 error") == \
        Counter({"uwtutor/a.py": 1})


if __name__ == "__main__":
    for module, n in sorted(error_counts(_mypy().stdout).items()):
        print(module, n)
