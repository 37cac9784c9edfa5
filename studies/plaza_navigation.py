"""navigate on the real Plaza logs, judged over range schedules: odometry alone, navigate's default (the states
chosen from the log) and each of its candidates, the RTS smoother and GTSAM's MAP on the same model.

For Plaza 1 and 2, each beacon alone and all four, at the logged rate and at one range every ``--period`` seconds
(default 10 s): every offset of the thinning (0, 1, ..., period - 1 s after the first epoch), each a schedule of
the same log, and both kinds of thinning, "per beacon" (each beacon thinned on its own) and "in total" (one range
per period to any beacon; the same as per beacon with one beacon, so run for all four only). A source of runs is
log x beacons x schedule (:func:`runs`); each run gives every method's RMSE (:func:`run_methods`); a cell's runs are
paired (every method on the same schedules), and the table gives the median and the range over the offsets, and
the paired verdicts of the default against odometry alone and against the best candidate (uwtutor.statistics).

    .venv/bin/python studies/plaza_navigation.py --runs RUNS.jsonl      # the whole study (hours; run it with nice)
    .venv/bin/python studies/plaza_navigation.py --sets 2 --beacons 5 --offsets 3 --no-gtsam   # a small case
    .venv/bin/python studies/plaza_navigation.py --offset-list 1 2 --no-full-rate --runs MORE.jsonl  # more offsets
    .venv/bin/python studies/plaza_navigation.py --summarize RUNS.jsonl MORE.jsonl --complete-offsets \
        --csv uwtutor/data/real_data_schedules.csv --overwrite               # the table, and chapter 11's file

``--runs`` appends every run as a JSON line as soon as it is done, so a study cut short keeps its runs;
``--summarize`` merges runs files (a run written twice counts once), ``--complete-offsets`` keeps only the offsets
run in every cell of a log (every cell of a log then has the same schedules). The offsets of one log are schedules
of one realisation (the same odometry, noise and track), not independent trials: the paired verdicts say whether a
method beats another on this log whatever the schedule, not on another log. ``make study-schedules`` runs it all.

Deterministic (no randomness): the same command prints the same table.
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
import time
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from uwtutor.datasets import CANDIDATES, RangeDataset, navigate, plaza
from uwtutor.filters import rts_smoother

ODOMETRY = "odometry alone"
DEFAULT = "navigate"
RTS = "navigate, RTS"
GRAPH = "GTSAM, same model"


def rmse(positions: np.ndarray, truth: np.ndarray) -> float:
    e = np.hypot(*(np.asarray(positions)[:, :2] - truth[:, :2]).T)
    return float(np.sqrt(np.mean(e**2)))


def runs(data: RangeDataset, beacons: list[int], period: float, offsets: list[float],
         full_rate: bool = True) -> Iterator[dict[str, Any]]:
    """The source of runs of one (log, beacons): the logged rate, then every offset of each kind of thinning."""
    if full_rate:
        yield {"rate": "full", "thinning": "", "offset": 0.0, "min_period": None}
    kinds = ["per beacon"] + (["in total"] if len(beacons) > 1 else [])
    for kind in kinds:
        for offset in offsets:
            yield {"rate": f"{period:g} s", "thinning": kind, "offset": float(offset), "min_period": period}


def run_methods(data: RangeDataset, beacons: list[int], schedule: dict[str, Any], gtsam: bool) -> dict[str, Any]:
    """Every method's RMSE on one run (log x beacons x schedule), the states chosen and their evidence."""
    options = dict(min_period=schedule["min_period"], offset=schedule["offset"],
                   thinning=schedule["thinning"] or "per beacon")
    truth = data.truth
    result = navigate(data, beacons, **options)
    nav_runs = result.candidates
    out: dict[str, Any] = {ODOMETRY: rmse(data.dead_reckoning(), truth), DEFAULT: rmse(result.x, truth)}
    for name, run in nav_runs.items():
        out[f"navigate: {name}"] = rmse(run.x, truth)
    smoothed = rts_smoother(result, result.models.motion, result.models.u)
    out[RTS] = rmse(smoothed.x, truth)
    if gtsam:
        from uwtutor.datasets.factor_graph import gtsam_map

        with_bias, with_scale = CANDIDATES[result.chosen]
        out[GRAPH] = rmse(gtsam_map(data, beacons, gyro_bias=with_bias, scale=with_scale, **options).poses, truth)
    out["chosen"] = result.chosen
    out["evidence"] = result.evidence
    out["n_ranges"] = int(np.isfinite(result.extras["ranges"]).sum())
    return out


def methods_of(gtsam: bool) -> list[str]:
    return [ODOMETRY, DEFAULT] + [f"navigate: {n}" for n in CANDIDATES] + [RTS] + ([GRAPH] if gtsam else [])


def summarize(cell_runs: list[dict[str, Any]], methods: list[str]) -> dict[str, Any]:
    """Median and range over a cell's runs for every method; how often the default is worse than odometry alone;
    its excess over the best candidate of each run; the paired verdicts of the default against odometry alone, the
    best candidate and the graph, and of the graph against the smoother (median difference, 95 % paired bootstrap)."""
    table = {m: np.array([r.get(m, np.nan) for r in cell_runs]) for m in methods}
    candidates = np.array([[r[f"navigate: {n}"] for n in CANDIDATES] for r in cell_runs])
    best = candidates.min(axis=1)
    out = {m: {"median": float(np.nanmedian(v)) if np.isfinite(v).any() else float("nan"),
               "min": float(np.nanmin(v)) if np.isfinite(v).any() else float("nan"),
               "max": float(np.nanmax(v)) if np.isfinite(v).any() else float("nan")} for m, v in table.items()}
    out["n_runs"] = len(cell_runs)
    out["default_worse_than_odometry"] = int(np.sum(table[DEFAULT] > table[ODOMETRY]))
    out["default_over_best"] = {"median": float(np.median(table[DEFAULT] - best)),
                                "max": float(np.max(table[DEFAULT] - best))}
    out["chosen"] = {n: sum(r["chosen"] == n for r in cell_runs) for n in CANDIDATES}
    try:
        from uwtutor import statistics
    except ImportError:         # the statistics module comes with the study runner
        return out
    if len(cell_runs) >= 6:
        versus = {"odometry alone": table[ODOMETRY], "best candidate": best}
        if np.isfinite(table[GRAPH]).all() if GRAPH in table else False:
            versus[GRAPH] = table[GRAPH]
        pairs = [(DEFAULT, table[DEFAULT], name, other) for name, other in versus.items()]
        if GRAPH in versus:
            pairs.append((GRAPH, table[GRAPH], RTS, table[RTS]))
        for a_name, a, name, other in pairs:
            paired = statistics.paired_comparison(a, other, names=(a_name, name), threshold=1e9)
            interval = paired.interval("median")
            out[f"{a_name} vs {name}"] = {"verdict": paired.verdict("median"), "estimate": interval.estimate,
                                          "lower": interval.lower, "upper": interval.upper}
    return out


def plan(sets: list[int], beacon_args: list[str] | None, period: float,
         offsets: list[float], full_rate: bool = True) -> Iterator[tuple[int, list[int], dict[str, Any]]]:
    """Every run of the study, the cheap and the first offset of every cell first (so that a study cut short
    still has every cell once)."""
    logs = {n: plaza(n) for n in sets}
    choices = {}
    for n, data in logs.items():
        choices[n] = [[b] for b in data.beacon_ids] + [list(data.beacon_ids)]
        if beacon_args is not None:
            choices[n] = [list(data.beacon_ids) if b == "all" else [int(b)] for b in beacon_args]
    schedules = {}
    for n in sets:
        for beacons in choices[n]:
            for schedule in runs(logs[n], beacons, period, offsets, full_rate):
                schedules.setdefault((schedule["offset"], schedule["rate"] != "full"), []).append((n, beacons,
                                                                                                 schedule))
    for key in sorted(schedules, key=lambda k: (k[0], not k[1])):
        yield from schedules[key]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sets", type=int, nargs="+", default=[1, 2], help="Plaza logs (default: 1 2)")
    parser.add_argument("--beacons", nargs="+", default=None, help="beacon ids and/or 'all' (default: each, all)")
    parser.add_argument("--period", type=float, default=10.0, help="range period [s] (default 10)")
    parser.add_argument("--offsets", type=int, default=None, help="offsets 0, 1, ... (default: every second of "
                                                                    "the period)")
    parser.add_argument("--offset-step", type=float, default=1.0, help="seconds between offsets (default 1)")
    parser.add_argument("--offset-list", type=float, nargs="+", default=None,
                        help="these offsets [s] instead (e.g. to add offsets to a study run before)")
    parser.add_argument("--no-gtsam-full-all", action="store_true",
                        help="leave out GTSAM at the logged rate with all four beacons (its slowest graphs)")
    parser.add_argument("--no-gtsam", action="store_true", help="leave out GTSAM's same-model graph")
    parser.add_argument("--no-full-rate", action="store_true",
                        help="leave out the logged rate (when adding another period to a study)")
    parser.add_argument("--runs", type=Path, default=None, help="append every run as a JSON line here")
    parser.add_argument("--summarize", type=Path, nargs="+", default=None,
                        help="only print the table of runs files written before")
    parser.add_argument("--out", type=Path, default=None, help="write the cells and every run as JSON here")
    parser.add_argument("--complete-offsets", action="store_true",
                        help="with --summarize: keep a thinned offset only where it was run in every cell of its "
                             "log and period (a study cut short then gives every cell of a log the same schedules)")
    parser.add_argument("--csv", type=Path, default=None,
                        help="write every run as one CSV row here (RMSEs to 0.1 mm; the chapter's file: "
                             "uwtutor/data/real_data_schedules.csv)")
    parser.add_argument("--overwrite", action="store_true", help="replace --out or --csv if it exists")
    args = parser.parse_args(argv)
    for path in (args.out, args.csv):
        if path is not None and path.exists() and not args.overwrite:
            print(f"refusing to replace {path}: pass --overwrite", file=sys.stderr)
            return 2
    if args.summarize is not None:
        # a run written twice (a study resumed or extended) counts once: the later file's values win
        merged: dict[tuple[Any, ...], dict[str, Any]] = {}
        for path in args.summarize:
            for line in path.read_text(encoding="utf-8").splitlines():
                if line:
                    r = json.loads(line)
                    key = (r["set"], r["beacons"], r["rate"], r["thinning"], r["offset"])
                    merged[key] = {**merged.get(key, {}), **r}
        done = list(merged.values())
        if args.complete_offsets:
            done = complete_offsets(done)
    else:
        done = []
        gtsam = not args.no_gtsam
        n_offsets = int(round(args.period / args.offset_step)) if args.offsets is None else args.offsets
        offsets = [float(o * args.offset_step) for o in range(n_offsets)]
        if args.offset_list is not None:
            offsets = [float(o) for o in args.offset_list]
        start = time.perf_counter()
        for number, beacons, schedule in plan(args.sets, args.beacons, args.period, offsets,
                                               not args.no_full_rate):
            data = plaza(number)
            skip = args.no_gtsam_full_all and schedule["rate"] == "full" and len(beacons) > 1
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                result = run_methods(data, beacons, schedule, gtsam and not skip)
            result.update(schedule, set=f"Plaza {number}", beacons="all 4" if len(beacons) > 1 else str(beacons[0]))
            done.append(result)
            if args.runs is not None:
                with args.runs.open("a", encoding="utf-8") as f:
                    f.write(json.dumps(result) + "\n")
            print(f"[{time.perf_counter() - start:6.0f} s] Plaza {number} {beacons} {schedule['rate']} "
                  f"{schedule['thinning']} offset {schedule['offset']:g}: default {result[DEFAULT]:.2f} m "
                  f"({result['chosen']}), odometry {result[ODOMETRY]:.2f} m", file=sys.stderr, flush=True)
    methods = [m for m in methods_of(True) if any(m in r for r in done)]
    by_cell: dict[tuple[str, str, str, str], list[dict[str, Any]]] = {}
    for r in done:
        by_cell.setdefault((r["set"], r["beacons"], r["rate"], r["thinning"]), []).append(r)
    order = sorted(by_cell, key=lambda c: (c[0], c[1] == "all 4", c[1], c[2] != "full", c[3]))
    cells = [{"set": c[0], "beacons": c[1], "rate": c[2], "thinning": c[3],
              "summary": summarize(by_cell[c], methods), "runs": by_cell[c]} for c in order]
    print_table(cells, methods)
    if args.out is not None:
        args.out.write_text(json.dumps({"methods": methods, "cells": cells}, indent=1) + "\n", encoding="utf-8")
    if args.csv is not None:
        write_csv(args.csv, [r for cell in cells for r in cell["runs"]], methods)
    return 0


def complete_offsets(done: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The runs at the logged rate, and the thinned runs of the offsets run in every cell of their log and period."""
    cells_of: dict[tuple[str, str], set[tuple[str, str]]] = {}
    offsets_of: dict[tuple[str, str, float], set[tuple[str, str]]] = {}
    for r in done:
        if r["rate"] != "full":
            cells_of.setdefault((r["set"], r["rate"]), set()).add((r["beacons"], r["thinning"]))
            offsets_of.setdefault((r["set"], r["rate"], r["offset"]), set()).add((r["beacons"], r["thinning"]))
    return [r for r in done if r["rate"] == "full"
            or offsets_of[(r["set"], r["rate"], r["offset"])] == cells_of[(r["set"], r["rate"])]]


CSV_KEYS = ["set", "beacons", "rate", "thinning", "offset", "n_ranges", "chosen"]


def write_csv(path: Path, done: list[dict[str, Any]], methods: list[str]) -> None:
    """Every run as one row: the schedule, the states navigate chose, every method's RMSE [m] to 0.1 mm (empty
    where a method was not run)."""
    with path.open("w", encoding="utf-8", newline="") as f:
        writer = csv.writer(f, lineterminator="\n")
        writer.writerow(CSV_KEYS + methods)
        for r in done:
            writer.writerow([r[k] for k in CSV_KEYS]
                            + [f"{r[m]:.4f}" if m in r and np.isfinite(r[m]) else "" for m in methods])


def print_table(cells: list[dict[str, Any]], methods: list[str]) -> None:
    short = {ODOMETRY: "odometry", DEFAULT: "default", RTS: "RTS", GRAPH: "GTSAM",
             **{f"navigate: {n}": n.replace("+ scale and gyro bias", "+ both") for n in CANDIDATES}}
    print("RMSE [m] over the schedules of each cell: median [min-max] (one value at the logged rate)")
    print(f"{'set':8} {'beacons':7} {'rate':5} {'thinning':10} {'n':>3} " + " ".join(f"{short[m]:>19}" for m in methods)
          + "  worse/odo  chosen")
    for cell in cells:
        s = cell["summary"]
        parts = []
        for m in methods:
            v = s[m]
            parts.append(f"{v['median']:6.2f}" + (f" [{v['min']:5.2f}-{v['max']:5.2f}]" if s["n_runs"] > 1
                                                  else " " * 14))
        chosen = ", ".join(f"{n} x{c}" for n, c in s["chosen"].items() if c)
        print(f"{cell['set']:8} {cell['beacons']:7} {cell['rate']:5} {cell['thinning'] or '-':10} {s['n_runs']:3d} "
              + " ".join(f"{p:>19}" for p in parts) + f"  {s['default_worse_than_odometry']:3d}      {chosen}")
    for cell in cells:
        s = cell["summary"]
        verdicts = [f"{v['verdict']} ({v['estimate']:+.2f} m, [{v['lower']:+.2f}, {v['upper']:+.2f}])"
                    for k, v in s.items() if " vs " in k]
        if verdicts:
            print(f"{cell['set']} {cell['beacons']} {cell['rate']} {cell['thinning']}: " + "; ".join(verdicts))


if __name__ == "__main__":
    sys.exit(main())
