"""The coverage of ``uwtutor.statistics``'s 95 % intervals, and of the percentile bootstrap, on simulated studies.

The population of ``tests/test_statistics.py``: 1000 runs per study, converged final errors Rayleigh (3 m per axis),
a fraction p of lost runs with errors log-uniform from 50 m to 5 km. For each p, ``--studies`` studies are drawn
and each interval is checked against the population's true value. Prints one line per p and statistic.

    python studies/interval_coverage.py --studies 4000 --boot-studies 400
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from scipy import stats

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from test_statistics import N_RUNS, population, true_median, true_rmse  # noqa: E402

from uwtutor import statistics as st  # noqa: E402

ALPHA = 0.05


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--studies", type=int, default=4000)
    parser.add_argument("--boot-studies", type=int, default=400)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args(argv)
    rng = np.random.default_rng(args.seed)
    print(f"{args.studies} studies of {N_RUNS} runs per p (bootstrap: {args.boot_studies}, 1000 resamples)")
    for p in (0.001, 0.002, 0.005, 0.01, 0.02, 0.05):
        e = population(rng, p, args.studies)
        t = true_rmse(p)
        rmse, lo, hi, n_lost = st._final_rmse_bounds(e, st.LOST_THRESHOLD, ALPHA)
        ok = ~np.isnan(lo)
        hit = (lo <= t) & (t <= hi)
        med, mlo, mhi = st._median_bounds(e, ALPHA)
        m = true_median(p)
        clo, chi = st._converged_rmse_bounds(e, st.LOST_THRESHOLD, ALPHA)[1:3]
        k = np.sum(e > st.LOST_THRESHOLD, axis=1)
        wlo, whi = st._wilson(k, N_RUNS, ALPHA)
        boot_hits = 0
        for study in e[: args.boot_studies]:
            idx = rng.integers(0, N_RUNS, (1000, N_RUNS))
            b = np.sqrt(np.mean(study[idx] ** 2, axis=1))
            blo, bhi = np.percentile(b, [2.5, 97.5])
            boot_hits += blo <= t <= bhi
        conv_t = np.sqrt(2.0) * 3.0
        print(f"p = {100 * p:4.1f} %: final RMSE {t:6.1f} m: estimable in {ok.mean():5.1%} of studies, covered in "
              f"{hit[ok].mean() if ok.any() else np.nan:6.1%} of those | percentile bootstrap "
              f"{boot_hits / args.boot_studies:6.1%} | median {np.mean((mlo <= m) & (m <= mhi)):6.1%} | converged "
              f"RMSE {np.mean((clo <= conv_t) & (conv_t <= chi)):6.1%} | lost fraction (Wilson) "
              f"{np.mean((wlo <= p) & (p <= whi)):6.1%}")
    nees = 1.6 * rng.chisquare(2, (args.studies, N_RUNS))
    _, nlo, nhi = st._median_bounds(nees, ALPHA)
    tn = 1.6 * stats.chi2.median(2)
    print(f"median NEES (1.6 x chi2_2): covered in {np.mean((nlo <= tn) & (tn <= nhi)):.1%}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
