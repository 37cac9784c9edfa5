"""Chapter 10's Monte Carlo uncertainty: the per-run final errors and final NEES behind chosen rows of the comparison.

``comparison.csv`` keeps, per row, numbers over 1000 runs (RMSE, median, lost fraction); an interval for them needs
the runs themselves. This study re-draws exactly the runs of the committed table for the rows chapter 10 discusses
(every white-noise row, and the rows its prose quotes under the other conditions): the same seed and chunk size,
chunk ``i`` drawn from ``SeedSequence(seed).spawn(n_chunks)[i]`` as ``montecarlo.run_study`` does, so that each
row's median and lost fraction equal the committed table's (checked here before writing). It writes
``uwtutor/data/comparison_runs.npz``: ``method``, ``scenario``, ``condition`` (one entry per row), and
``final_error`` and ``final_nees`` of shape ``(rows, runs)`` (float32; the NEES of the position at the last epoch,
NaN for a method without a covariance or a run whose covariance is not positive definite).

Run it with ``python studies/comparison_runs.py`` (about three minutes on one core).
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np

from uwtutor import methods, metrics
from uwtutor.montecarlo import scenario_draw
from uwtutor.scenarios import suite

#: The rows besides the white-noise ones: (method, scenario, condition) quoted by chapter 10.
QUOTED = [
    ("EKF", "circle", "sound speed"), ("IEKF", "circle", "sound speed"),
    ("LS pre-positioning", "circle", "sound speed"),
    ("LS-ISFEKF", "turn", "sound speed"), ("EKF", "turn", "sound speed"), ("IEKF", "turn", "sound speed"),
    ("LS pre-positioning", "turn", "sound speed"),
    ("EKF", "lawnmower", "bias"), ("IEKF", "lawnmower", "bias"), ("EKF", "line", "bias"), ("IEKF", "line", "bias"),
    ("EKF", "turn", "outliers"), ("IEKF", "turn", "outliers"), ("ISFEKF", "line", "outliers"),
    ("particle filter", "turn", "outliers"), ("particle filter", "line", "outliers"),
    ("LS pre-positioning", "turn", "outliers"), ("OR-VMLBL-KF", "lawnmower", "outliers"),
    ("cooperative EKF", "moving beacon", "current"), ("EKF", "moving beacon", "current"),
    ("particle filter", "moving beacon", "current"),
    ("LS pre-positioning", "circle", "current"), ("EKF", "lawnmower", "current"), ("EKF", "circle", "current"),
]


def rows(table) -> list[tuple[str, str, str]]:
    white = [(m, s, "white") for m, s, c in zip(table.method, table.scenario, table.condition) if c == "white"]
    return white + [r for r in QUOTED if r not in white]


def final_runs(method: str, scenario: str, condition: str, n_runs: int, seed: int, chunk_size: int):
    draw = scenario_draw(suite.SCENARIOS[scenario], suite.CONDITIONS[condition])
    estimate = methods.REGISTRY[method].estimate
    sizes = [chunk_size] * (n_runs // chunk_size) + ([n_runs % chunk_size] if n_runs % chunk_size else [])
    errors, nees = [], []
    for size, stream in zip(sizes, np.random.SeedSequence(seed).spawn(len(sizes))):
        inputs, truth = draw(np.random.default_rng(stream), size)
        res = estimate(inputs)
        truth = np.broadcast_to(truth, res.x[..., :2].shape[:1] + np.shape(truth)[-2:])
        e = res.x[:, -1, :2] - truth[:, -1, :2]
        errors.append(np.linalg.norm(e, axis=-1))
        if res.P is None:
            nees.append(np.full(size, np.nan))
        else:
            P = np.asarray(res.P)[:, -1, :2, :2]
            ok = metrics.positive_definite(P)
            safe = np.where(ok[:, None, None], P, np.eye(2))
            value = np.einsum("mi,mi->m", e, np.linalg.solve(safe, e[..., None])[..., 0])
            nees.append(np.where(ok, value, np.nan))
    return np.concatenate(errors), np.concatenate(nees)


def main() -> int:
    table = methods.load_comparison()
    n_runs, seed, chunk = int(table.n_runs[0]), int(table.seed), int(table.chunk_size)
    out = {"method": [], "scenario": [], "condition": [], "final_error": [], "final_nees": []}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for m, s, c in rows(table):
            err, nees = final_runs(m, s, c, n_runs, seed, chunk)
            hit = (table.method == m) & (table.scenario == s) & (table.condition == c)
            lost = np.where(np.isnan(err), np.inf, err)
            median, frac = float(np.median(lost)), float(np.mean(~(err <= 50.0)))
            want = float(table.median_final_error[hit][0]), float(table.divergence_fraction[hit][0])
            if not (np.isclose(median, want[0], rtol=1e-9) and np.isclose(frac, want[1])):
                print(f"{m}, {s}, {c}: median {median} / lost {frac} differ from the table's {want}", file=sys.stderr)
                return 1
            for key, value in (("method", m), ("scenario", s), ("condition", c), ("final_error", err),
                               ("final_nees", nees)):
                out[key].append(value)
            print(f"{m:20s} {s:14s} {c:12s} median {median:8.2f} m, lost {100 * frac:5.1f} %", flush=True)
    path = Path(__file__).resolve().parents[1] / "uwtutor" / "data" / "comparison_runs.npz"
    np.savez_compressed(path, method=np.array(out["method"]), scenario=np.array(out["scenario"]),
                        condition=np.array(out["condition"]),
                        final_error=np.array(out["final_error"], dtype=np.float32),
                        final_nees=np.array(out["final_nees"], dtype=np.float32))
    print(f"wrote {path} ({len(out['method'])} rows x {n_runs} runs)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
