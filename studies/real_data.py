"""Chapter 11's study: the book's methods, ``navigate`` and GTSAM's batch solution on the CMU Plaza logs.

Writes, into ``--out`` (``uwtutor/data`` by default: package data, read by
``uwtutor.datasets.study.load_real_data_study()`` from a source tree and from an installed wheel alike):

* ``real_data.json`` -- the method table (Plaza 1 and 2, the most-heard beacon and all four, logged rate and one range
  per beacon every 10 s), the ablation (each position-only method on the log as it is, with the range scale removed,
  with the heading from the truth, with both), GTSAM's sweep over the heading noise of its odometry factors, the
  widget grid's measures and how it was all computed;
* ``real_data_curves.npz`` -- the widget grid's curves (``navigate`` on Plaza 2 for every beacon, range period and
  set of estimated states), one value a second.

Run it with ``make study-real`` (about 15 minutes on a busy 2-core machine). It is deterministic (the particle filter
draws from a fixed seed); ``tests/test_real_data_study.py`` re-runs a sample of it and matches. Chapter 11 and its
widget read the files; the chapter re-runs the runs it shows and checks them against these.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

from uwtutor.datasets.study import STUDY_FILES, run_real_data_study


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parents[1] / "uwtutor" / "data",
                        help="output directory (default: uwtutor/data)")
    parser.add_argument("--overwrite", action="store_true", help="replace existing result files")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    existing = [str(args.out / name) for name in STUDY_FILES.values() if (args.out / name).exists()]
    if existing and not args.overwrite:
        print(f"refusing to replace {', '.join(existing)}: pass --overwrite (make study-real does)", file=sys.stderr)
        return 2
    start = time.perf_counter()

    def progress(message: str) -> None:
        print(f"[{time.perf_counter() - start:7.1f} s] {message}", flush=True)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")      # geometry warnings of single runs are part of what is measured
        study = run_real_data_study(progress)
    study.save(args.out)
    print(f"wrote {', '.join(STUDY_FILES.values())} into {args.out} in {time.perf_counter() - start:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
