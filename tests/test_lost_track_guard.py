"""navigate's lost-track warning as chapter 11 reports it: uwtutor/data/lost_track_guard.csv is what
studies/lost_track_guard.py computes, and the warning fires exactly where the gate rejected more than
LOST_TRACK_REJECTED of the ranging epochs."""

import csv
import warnings
from pathlib import Path

import numpy as np
import pytest

from uwtutor.datasets.navigation import LOST_TRACK_REJECTED

ROOT = Path(__file__).resolve().parents[1]
CSV_FILE = ROOT / "uwtutor" / "data" / "lost_track_guard.csv"


@pytest.fixture(scope="module")
def rows():
    with CSV_FILE.open(encoding="utf-8") as f:
        return list(csv.DictReader(f))


def test_the_file_covers_the_schedules_of_the_study(rows):
    count = {}
    for row in rows:
        count[row["rate"]] = count.get(row["rate"], 0) + 1
    # per log: 5 cells at the logged rate; per thinned rate 5 cells per beacon and one "in total", times the offsets
    assert count == {"full": 10, "5 s": 2 * 6 * 5, "10 s": 2 * 6 * 10, "30 s": 2 * 6 * 10}


def test_a_run_warns_exactly_when_the_gate_rejected_more_than_the_threshold(rows):
    for row in rows:
        epochs, rejected = int(row["epochs"]), int(row["rejected"])
        assert (row["warned"] == "True") == (epochs >= 10 and rejected > LOST_TRACK_REJECTED * epochs), row


@pytest.mark.parametrize("key", [("Plaza 2", "5", "per beacon", "30 s", "12.0"),       # lost: warned
                                 ("Plaza 2", "5", "per beacon", "30 s", "15.0")])      # kept: quiet
def test_committed_rows_are_what_navigate_computes(rows, key):
    pytest.importorskip("gtsam", reason="the Plaza logs come with the optional extra uwtutor[data]")
    from uwtutor.datasets import navigate, plaza

    row = next(r for r in rows if (r["set"], r["beacons"], r["thinning"], r["rate"], r["offset"]) == key)
    data = plaza(int(key[0][-1]))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = navigate(data, [int(key[1])], min_period=float(key[3].split()[0]), offset=float(key[4]))
    error = float(np.sqrt(np.mean(np.sum((result.x[:, :2] - data.truth[:, :2]) ** 2, axis=1))))
    assert error == pytest.approx(float(row["rmse"]), abs=1e-3)
    assert int(np.count_nonzero(result.extras["rejected"])) == int(row["rejected"])
    assert int(np.isfinite(result.extras["ranges"]).any(axis=1).sum()) == int(row["epochs"])
    assert any("lost the track" in str(w.message) for w in caught) == (row["warned"] == "True")
