"""Chapter 11's schedule study as committed: the chapter's CSV is the runs file's runs, and every cell of a log has
the same schedules (studies/plaza_navigation.py --summarize ... --complete-offsets --csv ...)."""

import csv
import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CSV_FILE = ROOT / "uwtutor" / "data" / "real_data_schedules.csv"
RUNS_FILE = ROOT / "studies" / "plaza_navigation_runs.jsonl"
KEY = ("set", "beacons", "rate", "thinning", "offset")


@pytest.fixture(scope="module")
def rows():
    with CSV_FILE.open(encoding="utf-8") as f:
        return list(csv.DictReader(f))


def test_every_row_is_a_committed_run(rows):
    runs = {}
    for line in RUNS_FILE.read_text(encoding="utf-8").splitlines():
        r = json.loads(line)
        runs[tuple(str(r[k]) for k in KEY)] = {**runs.get(tuple(str(r[k]) for k in KEY), {}), **r}
    assert rows, "the CSV has no runs"
    for row in rows:
        run = runs[tuple(row[k] for k in KEY)]
        assert row["chosen"] == run["chosen"]
        for method, value in row.items():
            if method in KEY or method in ("chosen", "n_ranges") or value == "":
                continue
            assert float(value) == pytest.approx(run[method], abs=1e-4), (row, method)


def test_every_cell_of_a_log_has_the_same_schedules(rows):
    offsets = {}
    for row in rows:
        if row["rate"] != "full":
            cell = (row["set"], row["rate"], row["beacons"], row["thinning"])
            offsets.setdefault(cell, set()).add(float(row["offset"]))
    by_log = {}
    for (log, rate, *_), found in offsets.items():
        by_log.setdefault((log, rate), []).append(frozenset(found))
    assert by_log
    for log, sets in by_log.items():
        assert len(set(sets)) == 1, (log, sets)
