"""The committed results of ``make study`` (uwtutor/data/comparison*) are what the library computes today.

A sample of the rows is re-run from the file's own seed, runs and chunk size and must match it; the whole table
must cover every method on every scenario it claims under every condition, with the bounds of the suite.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest

from uwtutor import methods
from uwtutor.montecarlo import ComparisonTable
from uwtutor.scenarios import suite

DATA = Path(methods.__file__).parent / "data"


@pytest.fixture(scope="module")
def table() -> ComparisonTable:
    return methods.load_comparison()


@pytest.fixture(scope="module")
def run_info() -> dict:
    return json.loads((DATA / "comparison_run.json").read_text(encoding="utf-8"))


def test_load_comparison_reads_the_committed_files(table):
    again = ComparisonTable.from_csv(DATA / "comparison.csv", curves=DATA / "comparison_curves.npz")
    np.testing.assert_array_equal(again.final_rmse, table.final_rmse)
    np.testing.assert_array_equal(again.rmse_curves, table.rmse_curves)


def test_the_table_covers_every_claimed_pair_under_every_condition(table, run_info):
    expected = {(m, s, c) for m, scen in methods.claims().items() for s in scen for c in suite.CONDITIONS}
    got = list(zip(table.method.tolist(), table.scenario.tolist(), table.condition.tolist()))
    assert len(got) == len(set(got)) == len(expected) == run_info["rows"]
    assert set(got) == expected
    assert (table.n_runs == run_info["runs"]).all() and table.seed == run_info["seed"]
    assert table.chunk_size == run_info["chunk_size"]
    assert (table.n_steps == suite.PARAMETERS.n_epochs).all()


def test_the_bounds_in_the_table_are_the_suites(table):
    bounds = methods.suite_bounds()
    for i in range(len(table)):
        b = bounds[(table.scenario[i], table.condition[i])]
        np.testing.assert_allclose(table.bound_curves[i], b, rtol=1e-12)
        assert table.final_bound[i] == pytest.approx(b[-1], rel=1e-12)
        assert table.mean_bound[i] == pytest.approx(b.mean(), rel=1e-12)
        assert table.rmse_curves[i, -1] == pytest.approx(table.final_rmse[i], rel=1e-12)


SAMPLE = [
    ("EKF", "circle", "white"),
    ("IEKF", "line", "bias"),
    ("cooperative EKF", "moving beacon", "current"),
    ("OR-VMLBL-KF", "lawnmower", "outliers"),
    ("LS-ISFEKF", "turn", "sound speed"),
    ("particle filter", "moving beacon", "white"),
    ("gated EKF", "turn", "outliers"),
]


@pytest.mark.parametrize("method, scenario, condition", SAMPLE)
def test_a_sample_of_the_rows_reproduces(table, method, scenario, condition):
    stored = table.row(method, scenario, condition)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        again = methods.compare_suite(stored["n_runs"], table.seed, methods=[method], scenarios=[scenario],
                                      conditions=[condition], chunk_size=table.chunk_size, measure_cost=False)
    row = again.row(method, scenario, condition)
    for column in ComparisonTable.reproducible_columns:
        if isinstance(stored[column], str):
            assert row[column] == stored[column]
        elif np.isnan(stored[column]):
            assert np.isnan(row[column]), column
        else:
            assert row[column] == pytest.approx(stored[column], rel=1e-9), column
    rmse, _ = table.curves(method, scenario, condition)
    np.testing.assert_allclose(again.rmse_curves[0], rmse, rtol=1e-9)


def test_no_method_beats_the_bound_at_any_epoch(table):
    # The PCRB bounds the mean squared error of every estimator; the RMSE of 1000 runs carries a few per cent of
    # Monte Carlo error, and the closest any row comes is about 1.2 times the bound.
    ratio = table.rmse_curves / table.bound_curves
    assert np.isfinite(ratio).all()
    worst = np.unravel_index(np.argmin(ratio), ratio.shape)
    assert ratio.min() > 1.05, (table.method[worst[0]], table.scenario[worst[0]], table.condition[worst[0]])


def test_the_per_run_file_holds_the_tables_runs(table):
    # make study writes every row's runs beside the table: the interval columns are their statistics, and the
    # paired comparisons of chapter 10 are computed from them
    from uwtutor.statistics import cell_statistics

    runs = np.load(DATA / "comparison_runs.npz")
    assert runs["final_error"].shape == runs["final_nees"].shape == (len(table), int(table.n_runs[0]))
    assert list(runs["method"]) == list(table.method) and list(runs["condition"]) == list(table.condition)
    for i in range(len(table)):
        e = runs["final_error"][i].astype(float)
        assert np.median(np.where(np.isnan(e), np.inf, e)) == pytest.approx(float(table.median_final_error[i]),
                                                                           rel=1e-6)
        assert np.mean(~(e <= 50.0)) == pytest.approx(float(table.divergence_fraction[i]))
        if i % 23 == 0:                               # a sample: the columns are the statistics of the runs
            cell = cell_statistics(e, runs["final_nees"][i].astype(float))
            assert cell.n_lost == table.n_lost[i]
            assert cell.lost_fraction.upper == pytest.approx(table.divergence_fraction_upper[i])
            assert cell.median_nees.estimate == pytest.approx(table.median_nees[i], rel=1e-5, nan_ok=True)
