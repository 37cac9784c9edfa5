"""Chapter 10's comparison: every registered method on every scenario and error condition of the common suite.

Writes, into ``--out`` (``uwtutor/data`` by default: package data, so that ``uwtutor.methods.load_comparison()``
reads them from a source tree and from an installed wheel alike):

* ``comparison.csv`` -- the table (``uwtutor.montecarlo.ComparisonTable.to_csv``: one row per method, scenario and
  condition, its seed, chunk size and versions in the header);
* ``comparison_curves.npz`` -- each row's RMSE and bound over the epochs (``ComparisonTable.to_npz``);
* ``comparison_runs.npz`` -- each row's final error and final NEES of every run (``ComparisonTable.to_runs_npz``):
  the paired comparisons and rankings of chapter 10 (``uwtutor.statistics``);
* ``comparison_run.json`` -- how it was computed: runs, seed, chunk size, workers, wall time, CPU.

Run it with ``make study`` (1000 runs per row; the five scenarios on a process pool of one worker per core, each
scenario's rows in one worker). The reproducible columns depend
only on ``--runs``, ``--seed`` and ``--chunk-size``, not on ``--workers``; ``tests/test_study.py`` re-runs a sample
of the rows and matches them. The chapter reads the files and never recomputes the table.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
import warnings
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from functools import partial

from uwtutor import methods
from uwtutor.montecarlo import ComparisonTable
from uwtutor.scenarios import suite

def _one_scenario(runs: int, seed: int, chunk_size: int, scenario: str) -> ComparisonTable:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return methods.compare_suite(runs, seed, scenarios=[scenario], chunk_size=chunk_size)


#: The study's defaults: the numbers of the committed results.
RUNS, SEED, CHUNK_SIZE = 1000, 20261201, 500


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=RUNS, help="Monte Carlo runs per row (default %(default)s)")
    parser.add_argument("--seed", type=int, default=SEED, help="root seed (default %(default)s)")
    parser.add_argument("--chunk-size", type=int, default=CHUNK_SIZE, help="runs per chunk (default %(default)s)")
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1,
                        help="processes (default: one per CPU); 1 runs in this process")
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parents[1] / "uwtutor" / "data",
                        help="output directory (default: uwtutor/data)")
    parser.add_argument("--overwrite", action="store_true", help="replace existing result files")
    args = parser.parse_args(argv)

    args.out.mkdir(parents=True, exist_ok=True)
    paths = {k: args.out / f"comparison{k}" for k in (".csv", "_curves.npz", "_runs.npz", "_run.json")}
    existing = [str(p) for p in paths.values() if p.exists()]
    if existing and not args.overwrite:
        print(f"refusing to replace {', '.join(existing)}: pass --overwrite (make study does)", file=sys.stderr)
        return 2
    start, cpu0 = time.perf_counter(), time.process_time()
    with warnings.catch_warnings():
        # the geometry warnings of single filters (a beacon passed at a few metres, an unobservable stretch)
        # are what the table measures; thousands of them would bury the summary
        warnings.simplefilter("ignore")
        if args.workers > 1:
            # one scenario per task: a row's two chunks are too few to keep the workers busy, and every row's study
            # depends on nothing else, so the scenarios' tables, in order, are the whole table
            job = partial(_one_scenario, args.runs, args.seed, args.chunk_size)
            with ProcessPoolExecutor(args.workers) as pool:
                table = ComparisonTable.concatenate(pool.map(job, list(suite.SCENARIOS)))
        else:
            table = methods.compare_suite(args.runs, args.seed, chunk_size=args.chunk_size)
    wall = time.perf_counter() - start
    table.to_csv(paths[".csv"], overwrite=True)
    table.to_npz(paths["_curves.npz"], overwrite=True)
    table.to_runs_npz(paths["_runs.npz"], overwrite=True)
    run = {"runs": args.runs, "seed": args.seed, "chunk_size": args.chunk_size, "workers": args.workers,
           "rows": len(table), "wall_seconds": round(wall, 1),
           "parent_cpu_seconds": round(time.process_time() - cpu0, 1),
           "cpu": platform.processor() or platform.machine(), "cpu_count": os.cpu_count(),
           "versions": table.versions}
    paths["_run.json"].write_text(json.dumps(run, indent=2, sort_keys=True) + "\n", encoding="utf-8")
    print(f"{len(table)} rows x {args.runs} runs in {wall:.0f} s on {args.workers} worker(s): "
          + ", ".join(str(p) for p in paths.values()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
