"""Robustness specifications of ``uwtutor.statistics`` and the study runner's additions (see robustness_spec.py)."""

from __future__ import annotations

import numpy as np

from robustness_kinds import Choice, Instance, Int, Real, Seed
from robustness_spec import Spec
from robustness_spec_core import _method

_E = np.r_[np.linspace(1.0, 9.0, 18), 80.0, 400.0]          # 20 runs, 2 lost
_F = np.r_[np.linspace(1.5, 9.5, 18), 60.0, 30.0]
_NEES = np.linspace(0.2, 6.0, 20)
# NaN or +inf: a lost run (an estimate that diverged); any number of runs
_ERR = Real((None,), "nonneg", nan_ok=True, inf_ok=True)


_ERR_KINDS = dict(errors=_ERR, threshold=Real((), "pos"))


def _intervals_honest(value, baseline):
    """Every Interval in the answer: NaN only where it says why (not estimable), never silently."""
    from dataclasses import fields, is_dataclass

    from uwtutor.statistics import Interval

    items = value if isinstance(value, tuple) else (value,)
    problems = []
    for item in items:
        found = [item] if isinstance(item, Interval) else \
            [getattr(item, f.name) for f in fields(item)] if is_dataclass(item) else []
        for iv in found:
            if isinstance(iv, Interval) and not iv.reason and not np.all(np.isfinite([iv.lower, iv.upper])) \
                    and not (iv.upper == np.inf and np.isfinite(iv.lower)):
                problems.append(f"an interval with NaN and no reason: {iv!r}")
    return problems


def _square_log():
    from uwtutor.datasets import square_log
    return square_log()


SPECS_STATS: dict[str, Spec] = {
    "uwtutor.statistics:wilson_interval": Spec(lambda: dict(k=2, n=1000, confidence=0.95),
                                               kinds=dict(k=Int(minimum=0), n=Int(minimum=1))),
    "uwtutor.statistics:median_interval": Spec(lambda: dict(values=_E, confidence=0.95),
                                               kinds=dict(values=Real((None,), nan_ok=True, inf_ok=True)),
                                               check=_intervals_honest),
    "uwtutor.statistics:lost_fraction_interval": Spec(lambda: dict(errors=_E, threshold=50.0, confidence=0.95),
                                                      kinds=_ERR_KINDS, check=_intervals_honest),
    "uwtutor.statistics:converged_rmse_interval": Spec(lambda: dict(errors=_E, threshold=50.0, confidence=0.95),
                                                       kinds=_ERR_KINDS, check=_intervals_honest),
    "uwtutor.statistics:final_rmse_interval": Spec(lambda: dict(errors=_E, threshold=50.0, confidence=0.95),
                                                   kinds=_ERR_KINDS, check=_intervals_honest),
    "uwtutor.statistics:median_nees_interval": Spec(lambda: dict(nees=_NEES, dof=2, confidence=0.95),
                                                    kinds=dict(nees=Real((20,), "nonneg", nan_ok=True),
                                                               dof=Int(minimum=1)), check=_intervals_honest),
    "uwtutor.statistics:cell_statistics": Spec(
        lambda: dict(final_errors=_E, final_nees=_NEES, dof=2, threshold=50.0, confidence=0.95),
        kinds=dict(final_errors=_ERR, final_nees=Real((20,), "nonneg", nan_ok=True, optional=True),
                   dof=Int(minimum=1), threshold=Real((), "pos")), check=_intervals_honest),
    "uwtutor.statistics:paired_comparison": Spec(
        lambda: dict(errors_a=_E, errors_b=_F, threshold=50.0, confidence=0.95, seed=0, n_bootstrap=200),
        kinds=dict(errors_a=_ERR, errors_b=_ERR, threshold=Real((), "pos"), seed=Seed(),
                   n_bootstrap=Int(minimum=100)), check=_intervals_honest),
    "uwtutor.statistics:rank": Spec(lambda: dict(errors={"A": _E, "B": _F}, criterion="median", threshold=50.0),
                                    kinds=dict(errors=Instance(), criterion=Choice(), threshold=Real((), "pos"))),
    "uwtutor.statistics:lost_verdict": Spec(lambda: dict(k=39, n=1000, limit=0.05, confidence=0.95),
                                            kinds=dict(k=Int(minimum=0), n=Int(minimum=1),
                                                       limit=Real((), "open01"))),
    "uwtutor.methods:gated_ekf": _method("gated_ekf"),
    "uwtutor.methods:dataset_inputs": Spec(
        lambda: dict(data=_square_log(), beacon_id=3, schedules=None, min_period=None, method_seed=0),
        kinds=dict(data=Instance(), beacon_id=Int(), schedules=Instance(optional=True),
                   min_period=Real((), "pos", optional=True), method_seed=Seed())),
    "uwtutor.methods:log_draw": Spec(
        lambda: dict(data=_square_log(), beacon_id=3, schedules=np.ones((2, 81), bool)),
        kinds=dict(data=Instance(), beacon_id=Int(), schedules=Instance()), check=lambda v, b: []),
}

EXEMPT_STATS: dict[str, str] = {
    "uwtutor.statistics:Interval": "a result container the statistics build",
    "uwtutor.statistics:CellStatistics": "a result container cell_statistics builds (specified)",
    "uwtutor.statistics:PairedComparison": "a result container paired_comparison builds (specified)",
    "uwtutor.statistics:Ranking": "a result container rank builds (specified)",
    "uwtutor.montecarlo.comparison:BestInCell": "a result container ComparisonTable.best builds",
}
