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

See :mod:`uwtutor.metrics` for the definitions of the metrics and the chi-square bounds.

References
----------
Bar-Shalom, Y., Li, X. R. and Kirubarajan, T. (2001). *Estimation with Applications to Tracking and Navigation*.
Wiley. Section 5.4 (Monte Carlo consistency tests).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from . import metrics
from ._validate import as_finite, as_float_array
from .filters.base import FilterResult

__all__ = ["MonteCarloResult", "run_monte_carlo"]


@dataclass(frozen=True)
class MonteCarloResult:
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
        NEES averaged over the runs.
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
    """

    result: FilterResult
    truth: np.ndarray
    components: tuple[int, ...]
    errors: np.ndarray
    rmse: np.ndarray
    final_errors: np.ndarray
    nees: np.ndarray
    mean_nees: np.ndarray
    nees_bounds: tuple[float, float]
    nis: np.ndarray | None
    mean_nis: np.ndarray | None
    nis_bounds: tuple[np.ndarray, np.ndarray] | None
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
    def x(self) -> np.ndarray:
        """The per-run estimates ``result.x``, shape (M, K, n_state)."""
        return self.result.x

    @property
    def times(self) -> np.ndarray:
        """Time of each step, from the filter's result."""
        return self.result.times

    def final_error_cdf(self) -> tuple[np.ndarray, np.ndarray]:
        """Empirical CDF ``(values, probabilities)`` of the final error (see :func:`uwtutor.metrics.error_cdf`)."""
        return metrics.error_cdf(self.final_errors)

    def final_error_percentile(self, q: float) -> float:
        """The ``q``-th percentile (0-100) of the final error over the runs, e.g. ``q=95``."""
        q = float(as_finite("q", q))
        if not 0.0 <= q <= 100.0:
            raise ValueError(f"q must be a percentage between 0 and 100; got {q}")
        return float(np.nanpercentile(self.final_errors, q))

    def nees_fraction_within(self) -> float:
        """Fraction of the steps whose mean NEES lies inside ``nees_bounds`` (about ``confidence`` if consistent)."""
        return metrics.fraction_within(self.mean_nees, *self.nees_bounds)

    def nis_fraction_within(self) -> float:
        """Fraction of the steps (with a measurement) whose mean NIS lies inside ``nis_bounds``."""
        if self.mean_nis is None or self.nis_bounds is None:
            raise ValueError("this study has no NIS: the filter reported no innovations")
        return metrics.fraction_within(self.mean_nis, *self.nis_bounds)

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


def run_monte_carlo(filter_fn: Callable[..., FilterResult], truth: Any, /, *, components: Any = None,
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

    Parameters
    ----------
    filter_fn : callable
        A batched filter: ``filter_fn(**inputs)`` returns a :class:`~uwtutor.filters.base.FilterResult` (or
        any object with ``x`` (M, K, n_state) and ``P`` (M, K, n_state, n_state), and optionally
        ``innovations`` and ``innovation_cov``). A result without a runs axis counts as one run.
    truth : array_like, shape (K, n_state) or (M, K, n_state)
        The true states; ``(K, n_state)`` when every draw shares the same true trajectory.
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
    >>> M, K, q, r = 500, 400, 0.3, 2.0                    # DR noise std per step and range noise std [m]
    >>> theta = np.linspace(0.0, 2 * np.pi, K + 1)
    >>> track = 200.0 * np.column_stack([np.cos(theta), np.sin(theta)])
    >>> truth = np.broadcast_to(track[1:], (M, K, 2)) + np.cumsum(rng.normal(0.0, q, (M, K, 2)), axis=1)
    >>> u = np.diff(track, axis=0)                         # what the DR reports, the same for every run
    >>> z = np.linalg.norm(truth, axis=-1) + rng.normal(0.0, r, (M, K))
    >>> P0 = np.eye(2) * 25.0
    >>> x0 = track[0] + rng.multivariate_normal([0.0, 0.0], P0, M)
    >>> study = run_monte_carlo(range_only_ekf, truth, x0=x0, P0=P0, u=u, z=z, Q=np.eye(2) * q**2, R=r**2)
    >>> study.rmse.shape, study.final_errors.shape, study.mean_nees.shape
    ((400,), (500,), (400,))
    >>> bool(study.rmse[-1] < study.rmse[0])
    True
    >>> lo, hi = study.nees_bounds
    >>> bool(lo < np.mean(study.mean_nees) < hi)             # consistent: mean NEES close to 2
    True
    """
    if not callable(filter_fn):
        raise TypeError(f"filter_fn must be a batched filter function; got {filter_fn!r}")
    result = filter_fn(**inputs)
    if not (hasattr(result, "x") and hasattr(result, "P")):
        raise TypeError("filter_fn must return a FilterResult (or an object with arrays x and P); "
                        f"got {type(result).__name__}")
    x = as_float_array("result.x", result.x, ndim=(2, 3))
    P = as_float_array("result.P", result.P, ndim=(3, 4))
    if x.ndim == 2:
        x, P = x[None], P[None]
    n_state = x.shape[-1]
    if P.shape != x.shape + (n_state,):
        raise ValueError(f"the filter's P must have shape {x.shape + (n_state,)} to match its x; got {P.shape}")
    if components is None:
        comps = tuple(range(n_state))
    else:
        idx = np.atleast_1d(np.asarray(components))
        if idx.dtype.kind not in "iu" or idx.ndim != 1 or idx.size == 0 or idx.min() < 0 or idx.max() >= n_state:
            raise ValueError(f"components must be a non-empty list of state indices in 0..{n_state - 1}; "
                             f"got {components!r}")
        comps = tuple(int(i) for i in idx)
    t = as_finite("truth", truth, ndim=(2, 3))
    try:
        t = np.broadcast_to(t, x.shape)
    except ValueError:
        raise ValueError(f"truth must have shape (K, n) or (M, K, n) matching the filter's estimates {x.shape}; "
                         f"got {t.shape}") from None
    sel = list(comps)
    xs, ts = x[..., sel], t[..., sel]
    Ps = P[..., sel, :][..., :, sel] if len(sel) < n_state else P

    errors = metrics.estimation_errors(xs, ts)
    nees = metrics.nees(xs, Ps, ts)
    mean_nees, _ = metrics.average_over_runs(nees)
    nees_bounds = metrics.chi2_mean_bounds(len(sel), x.shape[0], confidence)

    nis = mean_nis = nis_bounds = None
    y = getattr(result, "innovations", None)
    S = getattr(result, "innovation_cov", None)
    if y is not None and S is not None:
        y = as_float_array("result.innovations", y)
        S = as_float_array("result.innovation_cov", S)
        if y.ndim == 2 and x.shape[0] == 1:
            y, S = y[None], S[None]
        nis = metrics.nis(y, S)
        mean_nis, counts = metrics.average_over_runs(nis)
        nis_bounds = metrics.chi2_mean_bounds(y.shape[-1], counts, confidence)

    return MonteCarloResult(
        result=result, truth=ts, components=comps, errors=errors, rmse=np.sqrt(np.mean(errors**2, axis=0)),
        final_errors=errors[:, -1], nees=nees, mean_nees=mean_nees, nees_bounds=nees_bounds, nis=nis,
        mean_nis=mean_nis, nis_bounds=nis_bounds, confidence=float(confidence),
    )
