"""navigate's lost-track warning, judged on every schedule of the Plaza logs: does it fire where the filter ends worse
than the odometry alone, and only there?

For Plaza 1 and 2, each beacon alone and all four (thinned per beacon and in total), at the logged rate and at one
range every 5 s (offsets 0-4 s), 10 s (offsets 0-9 s) and 30 s (offsets 0, 3, ..., 27 s) -- the schedules of
``studies/plaza_navigation.py`` -- run ``navigate`` at its defaults and record the RMSE, the odometry's, the ranging
epochs, how many of them the gate rejected, and whether navigate warned of a lost track
(:data:`uwtutor.datasets.navigation.LOST_TRACK_REJECTED`). Chapter 11 reads the CSV.

    .venv/bin/python studies/lost_track_guard.py --csv uwtutor/data/lost_track_guard.csv --overwrite   # ~10 min
    .venv/bin/python studies/lost_track_guard.py --summarize uwtutor/data/lost_track_guard.csv          # the table

Deterministic (no randomness): the same command writes the same file.
"""

from __future__ import annotations

import argparse
import csv
import sys
import warnings
from pathlib import Path

import numpy as np

from uwtutor.datasets import navigate, plaza

#: (rate label, min_period, offsets): the schedules of studies/plaza_navigation.py.
RATES = (("full", None, (0.0,)), ("5 s", 5.0, tuple(float(o) for o in range(5))),
         ("10 s", 10.0, tuple(float(o) for o in range(10))), ("30 s", 30.0, tuple(float(o) for o in range(0, 30, 3))))
BEACON_SETS = ([0], [1], [5], [6], [0, 1, 5, 6])
FIELDS = ["set", "beacons", "thinning", "rate", "offset", "rmse", "odometry", "epochs", "rejected", "warned"]


def rmse(positions: np.ndarray, truth: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum((positions[:, :2] - truth[:, :2]) ** 2, axis=1))))


def run(number: int) -> list[dict[str, object]]:
    """Every schedule of one log."""
    data = plaza(number)
    odometry = rmse(data.dead_reckoning(), data.truth)
    rows = []
    for beacons in BEACON_SETS:
        for rate, period, offsets in RATES:
            kinds = ["per beacon"] + (["in total"] if len(beacons) > 1 and period is not None else [])
            for kind in kinds:
                for offset in offsets:
                    with warnings.catch_warnings(record=True) as caught:
                        warnings.simplefilter("always")
                        result = navigate(data, beacons, min_period=period, offset=offset, thinning=kind)
                    rows.append({"set": f"Plaza {number}", "beacons": "all 4" if len(beacons) > 1 else str(beacons[0]),
                                 "thinning": kind, "rate": rate, "offset": offset,
                                 "rmse": round(rmse(result.x, data.truth), 4), "odometry": round(odometry, 4),
                                 "epochs": int(np.isfinite(result.extras["ranges"]).any(axis=1).sum()),
                                 "rejected": int(np.count_nonzero(result.extras["rejected"])),
                                 "warned": any("lost the track" in str(w.message) for w in caught)})
    return rows


def summarize(rows: list[dict[str, object]]) -> str:
    head = ("rate", "runs", "warned", "worse", "worse, warned", "most rejected, unwarned")
    lines = [" ".join(f"{h:>{w}}" for h, w in zip(head, (5, 5, 7, 6, 14, 24)))]
    for rate, _, _ in RATES:
        r = [row for row in rows if row["rate"] == rate]
        warned = [row for row in r if row["warned"] in (True, "True")]
        worse = [row for row in r if float(row["rmse"]) > float(row["odometry"])]
        caught = [row for row in worse if row in warned]
        quiet = [int(row["rejected"]) / max(1, int(row["epochs"])) for row in r if row not in warned]
        lines.append(f"{rate:>5} {len(r):>5} {len(warned):>7} {len(worse):>6} {len(caught):>14} "
                     f"{100 * max(quiet, default=0.0):>23.1f}%")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--csv", type=Path, help="write every run here")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing --csv file")
    parser.add_argument("--summarize", type=Path, help="print the table of a CSV written before")
    args = parser.parse_args(argv)
    if args.summarize is not None:
        with open(args.summarize, newline="", encoding="utf-8") as f:
            print(summarize(list(csv.DictReader(f))))
        return 0
    if args.csv is not None and args.csv.exists() and not args.overwrite:
        print(f"{args.csv} exists: pass --overwrite to replace it", file=sys.stderr)
        return 2
    rows = run(1) + run(2)
    if args.csv is not None:
        with open(args.csv, "w", newline="", encoding="utf-8") as f:
            writer = csv.DictWriter(f, fieldnames=FIELDS, lineterminator="\n")
            writer.writeheader()
            writer.writerows(rows)
    print(summarize(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
