"""Resident memory of a chapter's kernel after Run All, and after each cell (to find what holds it).

Usage: ``python tools/kernel_memory.py book/ch07_bias_tracking.ipynb [...] [--json OUT]``

Each notebook runs in a fresh ``python3`` kernel (as JupyterLab's Run All would, without writing the outputs back);
after every code cell the kernel process's resident set size (RSS, ``psutil``) is read. The report gives the RSS
after the last cell and the cells that grew it by more than 50 MiB. The numbers are one measurement on this
machine (RSS depends on the allocator and the BLAS library's threads): compare chapters with each other, not
across machines.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import nbformat
import psutil
from nbclient import NotebookClient

MIB = 2**20


def measure(path: Path) -> dict:
    nb = nbformat.read(path, as_version=4)
    client = NotebookClient(nb, timeout=1800, kernel_name="python3", resources={"metadata": {"path": str(path.parent)}})
    steps = []
    with client.setup_kernel():
        process = psutil.Process(client.km.provisioner.process.pid)
        before = process.memory_info().rss
        for index, cell in enumerate(nb.cells):
            if cell.cell_type != "code":
                continue
            client.execute_cell(cell, index)
            steps.append((index, process.memory_info().rss))
    growth = []
    previous = before
    for index, rss in steps:
        if rss - previous > 50 * MIB:
            growth.append({"cell": index, "grew_mib": round((rss - previous) / MIB), "first_line":
                           nb.cells[index].source.strip().split("\n")[0][:90]})
        previous = rss
    return {"notebook": path.name, "rss_after_run_all_mib": round(steps[-1][1] / MIB) if steps else None,
            "peak_after_a_cell_mib": round(max(r for _, r in steps) / MIB) if steps else None, "growth": growth}


def main(argv: list[str]) -> int:
    out = None
    if "--json" in argv:
        i = argv.index("--json")
        out = Path(argv[i + 1])
        argv = argv[:i] + argv[i + 2:]
    if not argv:
        print(__doc__)
        return 2
    results = []
    for name in argv:
        result = measure(Path(name))
        results.append(result)
        print(json.dumps(result), flush=True)
        if out is not None:
            out.write_text(json.dumps(results, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
