"""The Performance page shows exactly the committed benchmark results (no speed is asserted here)."""

import copy
import importlib.util
import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def load_bench():
    spec = importlib.util.spec_from_file_location("uwtutor_bench_run", ROOT / "benchmarks" / "run.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


bench = load_bench()


def committed_results():
    return json.loads((ROOT / "benchmarks" / "results.json").read_text(encoding="utf-8"))


def test_page_table_matches_the_committed_results():
    page = (ROOT / "book" / "appendix_performance.md").read_text(encoding="utf-8")
    assert bench.page_table(page) == bench.render_table(committed_results()), (
        "book/appendix_performance.md is out of date with benchmarks/results.json: "
        "run `python benchmarks/run.py --save` and commit both files")


def test_results_record_the_machine_and_the_targets():
    results = committed_results()
    assert set(results["widget_updates_ms"]) == set(bench.widget_factories()), "a widget is missing from the results"
    assert {"cpu_count", "numpy", "date", "python"} <= set(results["machine"])
    targets = {k: list(v) for k, v in bench.TARGETS.items()}
    assert results["targets"] == {k: targets[k] for k in results["targets"]}, "a target changed since --save"
    added = set(targets) - set(results["targets"])          # a benchmark added since the results were saved
    assert not added & set(results), "a measurement is saved without its target"
    assert results["sizes"] == {"ekf_runs": 1000, "ekf_steps": 1500, "pf_particles": 1000, "pf_steps": 2000}


def test_table_marks_targets(tmp_path):
    results = copy.deepcopy(committed_results())
    results["ekf_study_s"] = 9.0
    results["pf_steps_per_s"] = 1e6
    results["ekf_vs_numpy_ratio"] = results["pf_vs_numpy_ratio"] = 1.1     # the committed ones may miss
    results["peak_memory_mb"] = 100.0
    results["targets"] = {k: list(v) for k, v in bench.TARGETS.items()}
    results["navigate_plaza2_s"], results["navigate_plaza2_epochs"] = 0.5, 4091    # the committed ones may miss
    results["odometry_ekf_s"], results["generic_ekf_speedup_vs_filterpy"] = 0.5, 100.0
    results["import_rows"] = []     # the committed import times may miss (their rows are import_time.rows')
    for key in [k for k in results if k.startswith("single_") and k.endswith("_ratio")]:
        results[key] = 1.5
    results["first_visit"] = {"ch09 w": {"size": {"first_ms": 300.0, "first_cpu_ms": 250.0, "cached_ms": 2.0},
                                         "pattern": {"first_ms": 90.0, "first_cpu_ms": 80.0, "cached_ms": 1.0}}}
    results["widgets_ms"] = {"slow one": 400.0}
    results["widget_updates_ms"] = {"ch09 quick_widget": 40.0, "ch09 slow_widget": 90.0}
    results["widget_latency"] = {
        "ch09 quick_widget": {"median_ms": 120.0, "max_ms": 130.0, "legacy_median_ms": 300.0, "legacy_max_ms": 310.0},
        "ch09 slow_widget": {"median_ms": 180.0, "max_ms": 200.0, "legacy_median_ms": 400.0, "legacy_max_ms": 450.0},
    }
    table = bench.render_table(results)
    # the EKF time, the slow compute, the slow widget, the slow control on a first visit
    assert table.count("| MISS |") == 4
    assert "Widget “slow one”" in table
    first = next(row for row in table.splitlines() if "ch09 w”" in row)
    assert "“size”" in first and "| 300 ms |" in first and "CPU 250 ms" in first and "| MISS |" in first
    navigate = next(row for row in table.splitlines() if row.startswith("| navigate on the real Plaza 2 log"))
    assert "| 0.50 s |" in navigate and "| PASS |" in navigate
    quick = next(row for row in table.splitlines() if "ch09 quick_widget" in row)
    assert "| 120 ms |" in quick and "| PASS |" in quick and "in the kernel 40 ms" in quick and "300 ms" in quick
    slow = next(row for row in table.splitlines() if "ch09 slow_widget" in row)
    assert "| 180 ms |" in slow and "| MISS |" in slow
    results["widget_latency"], results["widget_latency_note"] = {}, "not measured in JupyterLab (--no-browser)"
    table = bench.render_table(results)
    assert "| 40 ms |" in table and "in the kernel only" in table and "--no-browser" in table
    results["widgets_ms"], results["widgets_note"] = {}, "no uwtutor.widgets module: no widgets registered"
    assert "no widgets registered" in bench.render_table(results)
    page = tmp_path / "page.md"
    page.write_text(f"# P\n\nintro\n\n{bench.START_MARKER}\nold\n{bench.END_MARKER}\n\nafter\n", encoding="utf-8")
    bench.update_page(results, page)
    text = page.read_text(encoding="utf-8")
    assert bench.page_table(text) == bench.render_table(results)
    assert text.startswith("# P\n\nintro\n\n") and text.endswith("\n\nafter\n")
    with pytest.raises(ValueError, match="must contain the markers"):
        bench.page_table("no markers here")


def test_every_control_is_reported_beside_its_time_before():
    latency = {"ch09 w_widget": {"controls": {"size": {"kind": "slider", "median_ms": 120.0, "max_ms": 140.0},
                                              "test": {"kind": "dropdown", "median_ms": 180.0, "max_ms": 900.0}},
                                 "median_ms": 180.0, "max_ms": 900.0}}
    baseline = {"commit": "0123456789abcdef", "widgets": {"ch09 w_widget": {"size": 700.0}}}
    table = bench.render_latency_table(latency, 5, baseline)
    size = next(row for row in table.splitlines() if "| size |" in row)
    assert "| 120 ms | 140 ms | 700 ms | PASS |" in size
    test = next(row for row in table.splitlines() if "| test |" in row)
    assert "| 180 ms | 900 ms | – | MISS |" in test
    assert "0123456789" in table and "5 moves" in table
    results = copy.deepcopy(committed_results())
    results["widget_updates_ms"] = {"ch09 w_widget": 30.0}
    results["widget_latency"] = latency
    rows = [row for row in bench.render_table(results).splitlines() if "ch09 w_widget" in row]
    assert len(rows) == 2 and "control “size”" in rows[0] and "| 120 ms |" in rows[0] and "| MISS |" in rows[1]


def test_the_committed_latency_baseline_names_every_widget():
    baseline = bench.latency_baseline()
    assert len(baseline["commit"]) == 40
    assert set(baseline["widgets"]) == set(bench.widget_factories())


def test_ratio_rows_against_plain_numpy():
    """The two ratios to plain numpy (of the CPU times; the wall times and their ratio beside) get a row each,
    marked against their target of 1.2 (rows absent from results saved before these benchmarks existed)."""
    results = copy.deepcopy(committed_results())
    for key in ("ekf_vs_numpy_ratio", "pf_vs_numpy_ratio"):
        results.pop(key, None)
    assert "plain numpy" not in bench.render_table(results)
    results["targets"] = {k: list(v) for k, v in bench.TARGETS.items()}
    results.update({"ekf_vs_numpy_s": 0.118, "ekf_numpy_s": 0.100, "ekf_vs_numpy_ratio": 1.19,
                    "ekf_vs_numpy_max_rel_diff": 0.0, "pf_vs_numpy_s": 0.26,
                    "pf_numpy_s": 0.20, "pf_vs_numpy_ratio": 1.30, "pf_vs_numpy_max_rel_diff": 3e-12})
    rows = [row for row in bench.render_table(results).splitlines() if "plain numpy" in row]
    assert len(rows) == 2
    assert "| 1.19× | ≤ 1.2× | PASS |" in rows[0] and "0.118 s against 0.100 s of wall time (1.18×)" in rows[0]
    assert "bit for bit" in rows[0] and "ratio of the CPU times" in rows[0]
    assert "| 1.30× | ≤ 1.2× | MISS |" in rows[1] and "within 3e-12 relative" in rows[1]


def test_plain_numpy_references_do_the_library_s_work():
    """The plain-numpy filters of the ratio benchmarks give the library's outputs (here bit for bit) on a small
    problem, with missing ranges; a wrong output is caught by the benchmark's own check."""
    import numpy as np

    from uwtutor.filters import BootstrapParticleFilter, range_only_ekf
    from uwtutor.models import DepthSpeedPitchModel

    plain = bench._plain_numpy()
    inputs = bench.ekf_study_inputs(M=30, K=80, seed=3)
    lib = range_only_ekf(**inputs)
    ref = plain.range_only_ekf(*[inputs[k] for k in ("x0", "P0", "u", "z", "Q", "R")])
    assert np.isnan(ref["y"]).any() and plain.assert_ekf_agrees(lib, ref) == 0.0
    ref["P"][40, 0, 7] *= 1.0 + 1e-6
    with pytest.raises(AssertionError, match="differs from the plain-numpy reference"):
        plain.assert_ekf_agrees(lib, ref)
    model = DepthSpeedPitchModel()
    _, z = model.simulate([20.0, 1.5, 0.05], 60, np.random.default_rng(1))
    res = BootstrapParticleFilter.from_gaussian(model.motion, model.measurement, z[0], model.R, 200,
                                                np.random.default_rng(2)).run(z)
    ref = plain.bootstrap_pf(z[0], model.R, z, 200, np.random.default_rng(2), model.motion.T,
                             model.motion.process_std, model.R)
    assert plain.assert_pf_agrees(res, ref) == 0.0


def test_plain_generic_ekf_is_the_engine_bit_for_bit():
    """The reference of the single-run ratios: the engine's arithmetic for one run, on navigate's kind of model pair
    (some of the four ranges missing: the masked update) and on the bias pair; a changed output is caught."""
    import numpy as np

    from uwtutor.filters import bias_ekf, extended_kalman_filter
    from uwtutor.filters.bias import bias_model_pair

    plain = bench._plain_numpy()
    odo = bench.odometry_inputs(K=200, seed=4)
    lib = extended_kalman_filter(odo["motion"], odo["measurement"], odo["x0"], odo["P0"], odo["u"], odo["z"])
    ref = plain.generic_ekf(odo["motion"], odo["measurement"], odo["x0"], odo["P0"], odo["u"], odo["z"])
    pairs = [(lib.x, ref["x"]), (lib.P, ref["P"]), (lib.innovations, ref["y"]), (lib.innovation_cov, ref["S"])]
    bench._bit_for_bit(pairs, "navigate's model")
    study = bench.ekf_study_inputs(M=1, K=100, seed=2)
    Q = np.diag([0.25, 0.25, 0.01])
    x0 = np.append(study["x0"][0], 0.0)
    lib = bias_ekf(x0, np.eye(3) * 400.0, study["u"][0], study["z"][0], Q, study["R"])
    ref = plain.generic_ekf(*bias_model_pair(Q, study["R"], (0.0, 0.0), 100), x0, np.eye(3) * 400.0,
                            study["u"][0], study["z"][0])
    bench._bit_for_bit([(lib.x, ref["x"]), (lib.P_prior, ref["P_prior"])], "bias EKF")
    ref["x"][50, 1] += 1e-9
    with pytest.raises(AssertionError, match="bit for bit"):
        bench._bit_for_bit([(lib.x, ref["x"])], "bias EKF")


def test_first_visit_moves_to_values_never_seen():
    import ipywidgets as w

    spec = importlib.util.spec_from_file_location("first_visit", ROOT / "benchmarks" / "first_visit.py")
    first_visit = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(first_visit)
    slider = w.FloatSlider(value=0.0, min=-0.05, max=0.05, step=0.005)
    assert first_visit.new_values(slider) == pytest.approx([0.005, 0.01, 0.015])
    near_top = w.IntSlider(value=290, min=10, max=300, step=10)
    assert first_visit.new_values(near_top) == [280, 270, 260]           # towards the farther end
    log = w.FloatLogSlider(value=0.03, base=10, min=-3.0, max=-0.5, step=0.1)
    values = first_visit.new_values(log)
    assert len(values) == 3 and all(v < 0.03 for v in values) and len(set(values)) == 3
    choice = w.Dropdown(options=["a", "b", "c"], value="b")
    assert first_visit.new_values(choice) == ["c", "a"]
    assert first_visit.new_values(w.Checkbox(value=True)) == [False]
    table = first_visit.render({"ch99 demo": {"x": {"first_ms": 150.0, "first_cpu_ms": 90.0, "cached_ms": 1.0},
                                              "y": {"first_ms": 20.0, "first_cpu_ms": 15.0, "cached_ms": 1.0}}})
    assert "| ch99 demo | x | 150 (90) | 1 | MISS |" in table
