r"""Monte Carlo studies of a filter in one call: run ``M`` draws batched, then score them.

A Monte Carlo study runs a filter on ``M`` independent draws of the noise (dead reckoning, ranges, initial
error...) and summarizes how it did: its accuracy (RMSE over time, the distribution of the final error) and its
consistency (does the covariance it reports match the errors it makes? mean NEES and NIS against chi-square
bounds). :func:`run_monte_carlo` does both for any *batched* filter function -- one that takes the inputs of all
``M`` runs stacked along a leading axis and returns a :class:`~uwtutor.filters.base.FilterResult` with
``x`` of shape ``(M, K, n)`` -- such as :func:`uwtutor.filters.ekf.range_only_ekf`. A 1000-run, 1500-step study of
the range-only EKF takes about a tenth of a second (``make bench``).

The draws themselves are made by the caller with an explicit ``numpy.random.Generator``, so a study is exactly
reproducible and the same draws can be fed to several filters for a fair comparison (common random numbers).

The package holds one module per product: :mod:`~uwtutor.montecarlo.batch` (one batched study,
:func:`run_monte_carlo`), :mod:`~uwtutor.montecarlo.study` (a study chunk by chunk on any executor,
:func:`run_study`) and :mod:`~uwtutor.montecarlo.comparison` (methods on scenarios and conditions, :func:`compare`
and its :class:`ComparisonTable`); every name is imported from ``uwtutor.montecarlo`` itself.

See :mod:`uwtutor.metrics` for the definitions of the metrics and the chi-square bounds.

References
----------
Bar-Shalom, Y., Li, X. R. and Kirubarajan, T. (2001). *Estimation with Applications to Tracking and Navigation*.
Wiley. Section 5.4 (Monte Carlo consistency tests).
"""

from __future__ import annotations

from ._scores import DEFAULT_DIVERGENCE_THRESHOLD
from .batch import MonteCarloResult, run_monte_carlo
from .comparison import BestInCell, ComparisonTable, compare, scenario_draw
from .study import MAX_STUDY_RUNS, StudyResult, run_study

__all__ = ["MonteCarloResult", "run_monte_carlo", "StudyResult", "run_study", "ComparisonTable", "BestInCell",
           "compare", "scenario_draw", "DEFAULT_DIVERGENCE_THRESHOLD", "MAX_STUDY_RUNS"]
