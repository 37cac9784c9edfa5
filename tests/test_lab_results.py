"""The labs' solution results that their texts quote (exercises/labs/solution_results.json, bound by the prose
manifests as ``kind: data``) are what the labs' solutions compute now (tools/lab_results.py)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))
import lab_results  # noqa: E402  (tools/lab_results.py)


@pytest.mark.parametrize("lab", sorted(lab_results.RESULTS))
def test_stored_solution_results_are_recomputed(lab):
    stored = json.loads(lab_results.RESULTS_FILE.read_text(encoding="utf-8"))
    if lab == "real_ranges_plaza":
        pytest.importorskip("gtsam", reason="the Plaza logs come with gtsam: pip install -e '.[data]'")
    computed = lab_results.compute([lab])
    assert lab_results.differences({lab: stored.get(lab, {})}, computed) == []


def test_a_changed_result_is_reported():
    stored = {"lab": {"x": 1.0, "gone": 2.0}}
    assert lab_results.differences(stored, {"lab": {"x": 1.0 + 1e-4, "new": 3.0}}) == [
        "lab.gone: no longer computed", "lab.new: not stored", "lab.x: stored 1.0, computed 1.0001"]
    assert lab_results.differences(stored, {"lab": {"x": 1.0 + 1e-7, "gone": 2.0}}) == []
