"""The CPU time of importing uwtutor, each import in a fresh interpreter.

``import uwtutor`` and ``import uwtutor.filters`` are what every user pays before the first line of their own code
runs; the heavy dependencies (``scipy.stats``, PyWavelets, gtsam, dask) are imported where they are used, so that
these stay under the target. CPU time (``time.process_time`` of the child) rather than wall time, so that a busy
machine does not change the figure much; the median of ``repeats`` fresh processes is kept.

``python benchmarks/import_time.py`` prints the table; ``benchmarks/run.py`` calls :func:`bench_import_time`.
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]

#: The modules timed, and the target of each (seconds of CPU).
MODULES = {"uwtutor": 0.3, "uwtutor.filters": 0.3, "uwtutor.widgets": None}

_PROBE = ("import time, sys; t = time.process_time(); import {module}; "
          "sys.stdout.write(repr(time.process_time() - t))")


def import_cpu_seconds(module: str, repeats: int = 5) -> float:
    """The median CPU time of ``import module`` in ``repeats`` fresh interpreters (this checkout's uwtutor)."""
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    times = []
    for _ in range(repeats):
        out = subprocess.run([sys.executable, "-c", _PROBE.format(module=module)], capture_output=True, text=True,
                             env=env, check=True, cwd=ROOT)
        times.append(float(out.stdout))
    return statistics.median(times)


def bench_import_time(repeats: int = 5) -> dict[str, Any]:
    """``{"import_cpu_s": {module: seconds}}`` for every module of :data:`MODULES`."""
    return {"import_cpu_s": {module: import_cpu_seconds(module, repeats) for module in MODULES}}


def rows(results: dict[str, Any]) -> list[tuple[str, str, str, str]]:
    """Table rows (benchmark, measured, target, status) for ``benchmarks/run.py``'s table."""
    out = []
    for module, seconds in results.get("import_cpu_s", {}).items():
        target = MODULES.get(module)
        status = "–" if target is None else ("PASS" if seconds <= target else "MISS")
        out.append((f"`import {module}`, CPU time in a fresh interpreter (median)", f"{seconds:.3f} s",
                    "–" if target is None else f"≤ {target:g} s", status))
    return out


if __name__ == "__main__":
    for row in rows(bench_import_time()):
        print(" | ".join(row))
