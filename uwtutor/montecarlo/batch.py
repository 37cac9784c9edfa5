"""One batched Monte Carlo study of a filter: all ``M`` runs in one call, then scored (``run_monte_carlo``)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import metrics
from ..filters.base import FilterResult
from ._scores import _as_components, _as_confidence, _score_runs, _StudyStatistics

__all__ = ["MonteCarloResult", "run_monte_carlo"]


@dataclass(frozen=True)
class MonteCarloResult(_StudyStatistics):
    r"""The trajectories and the scores of a Monte Carlo study (see :func:`run_monte_carlo`).

    Shapes: ``M`` runs, ``K`` steps, ``n`` state components scored (all, or the chosen ``components``),
    ``m`` measurement size.

    Attributes
    ----------
    result : FilterResult
        What the filter returned: the per-run trajectories ``result.x`` (M, K, n_state), ``result.P``, the
        innovations, and any extras.
    truth : ndarray, shape (M, K, n)
        The true states of the scored components, broadcast to every run.
    components : tuple of int
        Indices of the scored state components.
    errors : ndarray, shape (M, K)
        Error norm :math:`\lVert \hat x_{j,k} - x_{j,k} \rVert` of every run and step.
    rmse : ndarray, shape (K,)
        RMSE over the runs at each step.
    final_errors : ndarray, shape (M,)
        Error norm of every run at the last step (the sample of the final-error distribution).
    nees : ndarray, shape (M, K)
        NEES of every run and step over the scored components.
    mean_nees : ndarray, shape (K,)
        NEES averaged over the runs (NaN at a step where a run's estimate is NaN).
    nees_bounds : tuple of float
        Two-sided chi-square acceptance interval ``(lower, upper)`` of ``mean_nees`` (``n`` degrees of freedom
        per run).
    nis : ndarray, shape (M, K), or None
        NIS of every run and step (NaN where no measurement was used); ``None`` if the filter reports no
        innovations.
    mean_nis : ndarray, shape (K,), or None
        NIS averaged over the runs that had a measurement at that step.
    nis_bounds : tuple of ndarray, or None
        Acceptance interval of ``mean_nis`` at each step (each step's own number of runs).
    confidence : float
        Probability of the acceptance intervals.

    Examples
    --------
    Twenty runs of the range-only EKF on a straight leg past a beacon at the origin:

    >>> import numpy as np
    >>> from uwtutor.filters import range_only_ekf
    >>> from uwtutor.montecarlo import run_monte_carlo
    >>> rng = np.random.default_rng(1)
    >>> track = np.column_stack([np.linspace(100.0, 150.0, 51), np.full(51, 80.0)])
    >>> z = np.linalg.norm(track[1:], axis=1) + rng.normal(0.0, 1.0, (20, 50))
    >>> x0 = track[0] + rng.normal(0.0, 3.0, (20, 2))
    >>> study = run_monte_carlo(range_only_ekf, track[1:], x0=x0, P0=np.eye(2) * 9.0,
    ...                         u=np.diff(track, axis=0), z=z, Q=np.eye(2) * 1e-4, R=1.0)
    >>> study.n_runs, study.n_steps, study.errors.shape
    (20, 50, (20, 50))
    >>> bool(study.rmse[-1] < study.rmse[0])
    True
    """

    result: FilterResult
    truth: np.ndarray
    components: tuple[int, ...]
    errors: np.ndarray
    rmse: np.ndarray
    final_errors: np.ndarray
    nees: np.ndarray
    mean_nees: np.ndarray
    nees_bounds: tuple[float | np.ndarray, float | np.ndarray]
    nis: np.ndarray | None
    mean_nis: np.ndarray | None
    nis_bounds: tuple[float | np.ndarray, float | np.ndarray] | None
    confidence: float

    @property
    def n_runs(self) -> int:
        """Number of Monte Carlo runs ``M``."""
        return self.errors.shape[0]

    @property
    def n_steps(self) -> int:
        """Number of steps ``K``."""
        return self.errors.shape[1]

    @property
    def x(self) -> NDArray[np.float64]:
        """The per-run estimates ``result.x``, shape (M, K, n_state)."""
        return self.result.x

    @property
    def times(self) -> NDArray[np.float64]:
        """Time of each step, from the filter's result."""
        return self.result.times

    def final_error_cdf(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Empirical CDF ``(values, probabilities)`` of the final error (see :func:`uwtutor.metrics.error_cdf`)."""
        return metrics.error_cdf(self.final_errors)

    def summary(self) -> dict[str, float]:
        """Headline numbers: final RMSE, median and 95th-percentile final error, time-averaged mean NEES/NIS
        and the fractions of steps inside their bounds."""
        out = {
            "n_runs": float(self.n_runs),
            "n_steps": float(self.n_steps),
            "final_rmse": float(self.rmse[-1]),
            "final_error_median": self.final_error_percentile(50.0),
            "final_error_p95": self.final_error_percentile(95.0),
            "mean_nees": float(np.nanmean(self.mean_nees)),
            "nees_fraction_within": self.nees_fraction_within(),
        }
        if self.mean_nis is not None:
            out["mean_nis"] = float(np.nanmean(self.mean_nis))
            out["nis_fraction_within"] = self.nis_fraction_within()
        return out


def run_monte_carlo(filter_fn: Callable[..., FilterResult], truth: ArrayLike, /, *, components: ArrayLike | None = None,
                    confidence: float = 0.95, **inputs: Any) -> MonteCarloResult:
    r"""Run a batched filter over ``M`` Monte Carlo draws and score the runs.

    Calls ``filter_fn(**inputs)`` once -- the inputs carry the ``M`` draws along their leading axis -- then
    computes, against ``truth``:

    * the error norms, the RMSE over time :math:`\mathrm{RMSE}_k = \sqrt{\frac1M \sum_j \lVert \hat x_{j,k} -
      x_{j,k} \rVert^2}` and the final-error sample;
    * the NEES :math:`\epsilon_{j,k} = e^T P^{-1} e` of every run and step, its mean over runs and the chi-square
      interval :math:`[\chi^2_{Mn}(\alpha/2), \chi^2_{Mn}(1 - \alpha/2)]/M` that the mean of a consistent filter
      stays inside with probability ``confidence`` at each step;
    * the same for the NIS when the result carries innovations (the runs without a measurement at a step are
      left out of that step's mean and bounds).

    The scores are those of :func:`run_study`, computed by the same code: a run whose estimate is NaN makes the
    RMSE and the mean NEES NaN (divergence is not hidden), and a covariance that has collapsed (not positive
    definite, e.g. a particle cloud reduced to one particle) gives that run an infinite NEES at that step.

    Parameters
    ----------
    filter_fn : callable
        A batched filter: ``filter_fn(**inputs)`` returns a :class:`~uwtutor.filters.base.FilterResult` (or
        any object with ``x`` (M, K, n_state) and ``P`` (M, K, n_state, n_state), and optionally
        ``innovations`` and ``innovation_cov``). A result without a runs axis counts as one run.
    truth : array_like, shape (K, d) or (M, K, d)
        The true states; ``(K, d)`` when every draw shares the same true trajectory. ``d`` is the state size
        ``n_state`` or the number of scored ``components``.
    components : sequence of int, optional
        State components to score (errors and NEES), e.g. ``[0, 1]`` for the position of a state that also
        holds a bias. All of them by default.
    confidence : float, optional
        Probability of the chi-square intervals (0.95 by default).
    **inputs
        Passed to ``filter_fn`` unchanged (so a filter argument cannot be called ``components`` or
        ``confidence``; wrap such a filter in a ``lambda``).

    Returns
    -------
    MonteCarloResult

    See Also
    --------
    uwtutor.metrics : the metrics and their definitions.

    Examples
    --------
    500 runs of the range-only EKF on a vehicle circling a beacon at 200 m, with noisy dead reckoning and ranges:

    >>> import numpy as np
    >>> from uwtutor.filters import range_only_ekf
    >>> from uwtutor.montecarlo import run_monte_carlo
    >>> rng = np.random.default_rng(7)
    >>> # DR noise std per step and range noise std [m]
    >>> M, K, q, r = 500, 400, 0.3, 2.0
    >>> theta = np.linspace(0.0, 2 * np.pi, K + 1)
    >>> track = 200.0 * np.column_stack([np.cos(theta), np.sin(theta)])
    >>> truth = np.broadcast_to(track[1:], (M, K, 2)) + np.cumsum(
    ...     rng.normal(0.0, q, (M, K, 2)), axis=1
    ... )
    >>> # what the DR reports, the same for every run
    >>> u = np.diff(track, axis=0)
    >>> z = np.linalg.norm(truth, axis=-1) + rng.normal(0.0, r, (M, K))
    >>> P0 = np.eye(2) * 25.0
    >>> x0 = track[0] + rng.multivariate_normal([0.0, 0.0], P0, M)
    >>> study = run_monte_carlo(
    ...     range_only_ekf,
    ...     truth,
    ...     x0=x0,
    ...     P0=P0,
    ...     u=u,
    ...     z=z,
    ...     Q=np.eye(2) * q**2,
    ...     R=r**2,
    ... )
    >>> study.rmse.shape, study.final_errors.shape, study.mean_nees.shape
    ((400,), (500,), (400,))
    >>> bool(study.rmse[-1] < study.rmse[0])
    True
    >>> lo, hi = study.nees_bounds
    >>> # consistent: mean NEES close to 2
    >>> bool(lo < np.mean(study.mean_nees) < hi)
    True
    """
    if not callable(filter_fn):
        raise TypeError(f"filter_fn must be a batched filter function; got {filter_fn!r}")
    comps = _as_components(components)
    conf = _as_confidence(confidence)
    result = filter_fn(**inputs)
    scores = _score_runs(result, truth, comps, producer="filter_fn", output="filter_fn(**inputs)",
                         truth_name="truth")
    mean_nis = nis_bounds = None
    if scores.nis is not None:
        mean_nis, counts = metrics.average_over_runs(scores.nis)
        nis_bounds = metrics.chi2_mean_bounds(scores.nis_dof, counts, conf)
    errors = scores.errors
    return MonteCarloResult(
        result=result, truth=scores.truth, components=scores.components, errors=errors,
        rmse=np.sqrt(np.mean(errors**2, axis=0)), final_errors=errors[:, -1], nees=scores.nees,
        mean_nees=scores.nees.mean(axis=0),
        nees_bounds=metrics.chi2_mean_bounds(len(scores.components), errors.shape[0], conf), nis=scores.nis,
        mean_nis=mean_nis, nis_bounds=nis_bounds, confidence=conf,
    )
