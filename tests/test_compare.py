"""compare: a tidy table of methods x scenarios x conditions, each row one run_study."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from uwtutor.filters import extended_kalman_filter, range_only_ekf
from uwtutor.models import DeadReckoning, RangeToBeacon
from uwtutor.montecarlo import ComparisonTable, compare, run_study, scenario_draw
from uwtutor.observability import posterior_crlb, rmse_bound

K, N_RUNS = 100, 300
Q_STD, R_STD, P0_STD, BIAS = 0.2, 1.5, 5.0, 4.0


def _circle_track() -> np.ndarray:
    t = np.linspace(0.0, 1.5 * np.pi, K + 1)
    return 250.0 * np.column_stack([np.cos(t), np.sin(t)])


def _line_track() -> np.ndarray:
    return np.column_stack([np.linspace(-300.0, 300.0, K + 1), np.full(K + 1, 120.0)])


def _runs(track: np.ndarray, rng: np.random.Generator, n: int) -> dict:
    drift = np.concatenate([np.zeros((n, 1, 2)), np.cumsum(rng.normal(0.0, Q_STD, (n, K, 2)), axis=1)], axis=1)
    return {"truth": track + drift, "u": np.diff(track, axis=0)}


def circle(rng, n):
    return _runs(_circle_track(), rng, n)


def line(rng, n):
    return _runs(_line_track(), rng, n)


def _measure(rng, runs, bias):
    truth = runs["truth"]
    n = len(truth)
    z = np.linalg.norm(truth[:, 1:], axis=-1) + bias + rng.normal(0.0, R_STD, (n, K))
    x0 = truth[:, 0] + rng.normal(0.0, P0_STD, (n, 2))
    return {"x0": x0, "z": z, "u": runs["u"]}, truth[:, 1:]


def white(rng, runs):
    return _measure(rng, runs, 0.0)


def biased(rng, runs):
    return _measure(rng, runs, BIAS)


def ekf(inputs):
    return range_only_ekf(inputs["x0"], P0_STD**2 * np.eye(2), inputs["u"], inputs["z"], Q_STD**2 * np.eye(2),
                          R_STD**2)


def bias_ekf(inputs):
    x0 = np.column_stack([inputs["x0"], np.zeros(len(inputs["x0"]))])
    return extended_kalman_filter(DeadReckoning(np.diag([Q_STD**2, Q_STD**2, 1e-6])),
                                  RangeToBeacon([0.0, 0.0], R=R_STD**2, n=3, bias_index=2), x0,
                                  np.diag([P0_STD**2, P0_STD**2, 25.0]), inputs["u"], inputs["z"])


METHODS = {"EKF": ekf, "bias EKF": bias_ekf}
SCENARIOS = {"circle": circle, "line": line}
CONDITIONS = {"white": white, "bias": biased}


def _bounds():
    out = {}
    for name, track in (("circle", _circle_track()), ("line", _line_track())):
        out[(name, "white")] = rmse_bound(posterior_crlb(track[1:], [0.0, 0.0], R_STD, Q_STD**2 * np.eye(2),
                                                         P0_STD**2 * np.eye(2)))
        out[(name, "bias")] = rmse_bound(posterior_crlb(track[1:], [0.0, 0.0], R_STD, Q_STD**2 * np.eye(2),
                                                        np.diag([P0_STD**2, P0_STD**2, 25.0]), bias=True))
    return out


@pytest.fixture(scope="module")
def table():
    return compare(METHODS, SCENARIOS, CONDITIONS, N_RUNS, seed=8, chunk_size=150, bounds=_bounds())


def test_one_row_per_method_scenario_and_condition(table):
    assert len(table) == 8
    assert [(r["scenario"], r["condition"], r["method"]) for r in table.rows()] == [
        (s, c, m) for s in SCENARIOS for c in CONDITIONS for m in METHODS]
    for column in table.columns:
        assert len(getattr(table, column)) == 8, column
    assert set(table.columns) == set(table.reproducible_columns) | set(table.timing_columns)
    assert table.seed == 8 and table.chunk_size == 150 and "numpy" in table.versions


def test_each_row_is_the_study_of_its_pair(table):
    bounds = _bounds()
    for s_name, scenario in SCENARIOS.items():
        for c_name, condition in CONDITIONS.items():
            for m_name, method in METHODS.items():
                study = run_study(scenario_draw(scenario, condition), method, N_RUNS, seed=8, chunk_size=150,
                                  components=(0, 1))
                row = table.row(m_name, s_name, c_name)
                b = bounds[(s_name, c_name)]
                assert row["final_rmse"] == study.rmse[-1]
                assert row["mean_rmse"] == study.rmse.mean()
                assert row["efficiency"] == study.rmse.mean() / b.mean()
                assert row["final_efficiency"] == study.rmse[-1] / b[-1]
                assert row["nees_fraction"] == study.nees_fraction_within()
                assert row["mean_nees"] == study.mean_nees.mean()
                assert row["divergence_fraction"] == np.mean(study.final_errors > row["divergence_threshold"])
                assert row["n_runs"] == N_RUNS and row["n_steps"] == K


def test_what_the_table_says_is_what_is_expected(table):
    # no method beats the posterior bound (up to Monte Carlo error) and the filters keep up with it in white noise
    assert np.all(table.efficiency > 0.9)
    for s in SCENARIOS:
        assert table.row("EKF", s, "white")["efficiency"] < 2.0
        assert table.row("EKF", s, "white")["nees_fraction"] > 0.5
    # a 4 m range bias: the filter that estimates it ends closer than the one that does not
    for s in SCENARIOS:
        assert table.row("bias EKF", s, "bias")["final_rmse"] < table.row("EKF", s, "bias")["final_rmse"]
    assert table.row("bias EKF", "circle", "bias")["final_rmse"] < 0.5 * table.row("EKF", "circle", "bias")[
        "final_rmse"]
    assert np.all(table.divergence_fraction == 0.0)                 # none of these cases loses the track
    assert np.all(np.isfinite(table.cost_per_step) & (table.cost_per_step > 0))


def test_divergence_threshold_only_and_no_bound():
    t = compare({"EKF": ekf}, {"circle": circle}, {"white": white}, 100, seed=2, chunk_size=100,
                divergence_threshold={"circle": 1e-3}, measure_cost=False)
    assert t.divergence_fraction[0] == 1.0 and t.divergence_threshold[0] == 1e-3
    assert np.isnan(t.efficiency[0]) and np.isnan(t.final_bound[0]) and np.isnan(t.cost_per_step[0])
    t = compare(METHODS, SCENARIOS, {"white": white}, 50, seed=2, chunk_size=50, only={"bias EKF": ["circle"]},
                measure_cost=False)
    assert [(r["method"], r["scenario"]) for r in t.rows()] == [("EKF", "circle"), ("bias EKF", "circle"),
                                                               ("EKF", "line")]


def test_the_same_numbers_on_an_executor_and_only_the_cost_differs():
    bounds = {key: b for key, b in _bounds().items() if key[0] == "line"}
    kwargs = dict(n_runs=120, seed=5, chunk_size=40, bounds=bounds)
    here = compare(METHODS, {"line": line}, CONDITIONS, **kwargs)
    with ThreadPoolExecutor(max_workers=2) as pool:
        there = compare(METHODS, {"line": line}, CONDITIONS, executor=pool, **kwargs)
    for column in here.reproducible_columns:
        np.testing.assert_array_equal(getattr(here, column), getattr(there, column), err_msg=column)


def test_csv_round_trip_and_no_overwrite(table, tmp_path):
    path = tmp_path / "table.csv"
    table.to_csv(path)
    back = ComparisonTable.from_csv(path)
    for column in table.columns:
        np.testing.assert_array_equal(getattr(back, column), getattr(table, column), err_msg=column)
    assert (back.seed, back.chunk_size, back.confidence, back.versions) == \
           (table.seed, table.chunk_size, table.confidence, table.versions)
    assert path.read_text().startswith("# uwtutor.montecarlo.compare table\n")
    with pytest.raises(FileExistsError, match="overwrite=True"):
        table.to_csv(path)
    table.to_csv(path, overwrite=True)
    with pytest.raises(KeyError, match="no row for method 'PF'"):
        table.row("PF", "circle", "white")


def test_markdown_table(table):
    text = table.to_markdown(["method", "scenario", "condition", "final_rmse", "efficiency"], digits=2)
    lines = text.splitlines()
    assert lines[0] == "| method | scenario | condition | final_rmse | efficiency |"
    assert lines[1] == "|:---|:---|:---|---:|---:|"
    assert len(lines) == 2 + len(table)
    first = table.rows()[0]
    assert lines[2] == (f"| {first['method']} | {first['scenario']} | {first['condition']} | "
                        f"{first['final_rmse']:.2g} | {first['efficiency']:.2g} |")
    assert "cost_per_step" not in table.to_markdown()          # timings stay out of notebook outputs by default
    with pytest.raises(ValueError, match="unknown column"):
        table.to_markdown(["rmse"])


@pytest.mark.parametrize("kwargs, error, match", [
    (dict(methods={}), TypeError, "methods must be a non-empty dict"),
    (dict(methods={"EKF": 1}), TypeError, r"methods\['EKF'\] must be a function"),
    (dict(scenarios=[circle]), TypeError, "scenarios must be a non-empty dict"),
    (dict(only={"PF": ["circle"]}), ValueError, "only names the method 'PF'"),
    (dict(only={"EKF": ["spiral"]}), ValueError, "not in scenarios: \\['spiral'\\]"),
    (dict(bounds={"spiral": np.ones(K)}), ValueError, "bounds has the key 'spiral'"),
    (dict(bounds={"circle": np.ones(K - 1)}), ValueError, "has 99 steps; the studies have 100"),
    (dict(bounds=np.ones(K)), TypeError, "bounds must be a dict"),
    (dict(divergence_threshold=-1.0), ValueError, "divergence_threshold must be > 0"),
    (dict(n_runs=0), ValueError, "n_runs must be >= 1"),
])
def test_bad_input_is_named(kwargs, error, match):
    args = dict(methods={"EKF": ekf}, scenarios={"circle": circle}, conditions={"white": white}, n_runs=20, seed=1,
                measure_cost=False)
    args.update(kwargs)
    with pytest.raises(error, match=match):
        compare(**args)
