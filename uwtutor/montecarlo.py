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
from ._validate import as_int
from .filters.base import FilterResult

__all__ = ["MonteCarloResult", "run_monte_carlo", "StudyResult", "run_study"]


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


# ---------------------------------------------------------------------------------------------------------------------
# studies that scale out: chunk by chunk from one seed, on any executor
# ---------------------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class _ChunkSums:
    """What one chunk of a study contributes: sums over its runs (never the runs themselves) and its final errors."""

    times: np.ndarray            # (K,)
    sq_errors: np.ndarray        # (K,)  sum over the chunk's runs of ||x_hat - x||^2
    nees: np.ndarray             # (K,)  sum of the NEES
    nees_dof: int                # number of scored components
    nis: np.ndarray | None       # (K,)  sum of the NIS over the runs with a measurement
    nis_counts: np.ndarray | None  # (K,) how many runs had one
    nis_dof: int
    final_errors: np.ndarray     # (n,)


def _study_chunk(draw: Callable[..., Any], estimate: Callable[..., Any], seed_sequence: np.random.SeedSequence,
                 n: int, components: tuple[int, ...] | None) -> _ChunkSums:
    """Draw ``n`` runs from their own Generator, filter them, and reduce them to sums (runs in a worker)."""
    rng = np.random.default_rng(seed_sequence)
    drawn = draw(rng, n)
    if not (isinstance(drawn, tuple) and len(drawn) == 2):
        raise TypeError(f"draw(rng, n) must return a pair (inputs, truth); got {type(drawn).__name__}")
    inputs, truth = drawn
    result = estimate(inputs)
    if not (hasattr(result, "x") and hasattr(result, "P")):
        raise TypeError("estimate(inputs) must return a FilterResult (or an object with arrays x and P); got "
                        f"{type(result).__name__}")
    x = as_float_array("estimate(inputs).x", result.x, ndim=(2, 3))
    P = as_float_array("estimate(inputs).P", result.P, ndim=(3, 4))
    if x.ndim == 2:
        x, P = x[None], P[None]
    if x.shape[0] != n:
        raise ValueError(f"estimate(inputs) must return the {n} runs that draw(rng, {n}) made (x of shape "
                         f"({n}, K, n_state)); got x of shape {x.shape}")
    n_state = x.shape[-1]
    if P.shape != x.shape + (n_state,):
        raise ValueError(f"estimate(inputs).P must have shape {x.shape + (n_state,)} to match its x; got {P.shape}")
    comps = tuple(range(n_state)) if components is None else components
    if max(comps) >= n_state:
        raise ValueError(f"components {list(comps)} name state indices beyond the {n_state} of the filter's state")
    sel = list(comps)
    t = as_finite("truth (from draw)", truth, ndim=(2, 3))
    if t.shape[-1] == n_state:
        t = t[..., sel]
    elif t.shape[-1] != len(sel):
        raise ValueError(f"truth (from draw) must hold the {n_state} state components or the {len(sel)} scored "
                         f"ones on its last axis; got shape {t.shape}")
    try:
        t = np.broadcast_to(t, x.shape[:-1] + (len(sel),))
    except ValueError:
        raise ValueError(f"truth (from draw) must have shape (K, d) or ({n}, K, d) with K = {x.shape[1]}; got "
                         f"{np.shape(truth)}") from None
    xs = x[..., sel]
    Ps = P[..., sel, :][..., :, sel] if len(sel) < n_state else P
    errors = metrics.estimation_errors(xs, t)
    nees = metrics.nees(xs, Ps, t)
    nis_sum = nis_counts = None
    nis_dof = 0
    y = getattr(result, "innovations", None)
    S = getattr(result, "innovation_cov", None)
    if y is not None and S is not None:
        y = as_float_array("estimate(inputs).innovations", y)
        S = as_float_array("estimate(inputs).innovation_cov", S)
        if y.ndim == 2:
            y, S = y[None], S[None]
        nis = metrics.nis(y, S)
        used = ~np.isnan(nis)
        nis_sum = np.where(used, nis, 0.0).sum(axis=0)
        nis_counts = used.sum(axis=0)
        nis_dof = int(y.shape[-1])
    times = np.asarray(getattr(result, "times", np.arange(x.shape[1], dtype=float)), dtype=float)
    return _ChunkSums(times=times, sq_errors=(errors**2).sum(axis=0), nees=nees.sum(axis=0), nees_dof=len(sel),
                      nis=nis_sum,
                      nis_counts=nis_counts, nis_dof=nis_dof, final_errors=errors[:, -1].copy())


def _versions() -> dict[str, str]:
    import platform
    from importlib import metadata

    import scipy

    try:
        uw = metadata.version("uwtutor")
    except metadata.PackageNotFoundError:                       # pragma: no cover - run from a source tree
        uw = "unknown"
    return {"uwtutor": uw, "numpy": np.__version__, "scipy": scipy.__version__,
            "python": platform.python_version()}


@dataclass(frozen=True)
class StudyResult:
    r"""The scores of a chunked Monte Carlo study (see :func:`run_study`): sums reduced over the runs.

    Unlike :class:`MonteCarloResult` it keeps no trajectory: only what the chunks were reduced to, so its size
    is :math:`O(K + M)` whatever the number of runs :math:`M`.

    Attributes
    ----------
    final_errors : ndarray, shape (n_runs,)
        Error norm of every run at the last step, in run order (chunk by chunk).
    rmse : ndarray, shape (K,)
        :math:`\mathrm{RMSE}_k = \sqrt{\frac1M \sum_j \lVert \hat x_{j,k} - x_{j,k} \rVert^2}`.
    mean_nees : ndarray, shape (K,)
        NEES averaged over the runs, :math:`\bar\epsilon_k`.
    nees_bounds : tuple of float
        Chi-square interval ``(lower, upper)`` of ``mean_nees`` at probability ``confidence``.
    mean_nis : ndarray, shape (K,), or None
        NIS averaged over the runs that had a measurement at each step; ``None`` if the filter reports no
        innovations.
    nis_bounds : tuple of ndarray, or None
        Interval of ``mean_nis`` at each step (each step's own number of runs).
    times : ndarray, shape (K,)
        Time of each step, from the filter's result.
    components : tuple of int
        The scored state components.
    confidence : float
        Probability of the intervals.
    n_runs, chunk_size, n_chunks : int
        The study's size and how it was cut.
    seed : int
        The root of the random streams: chunk ``i`` drew from ``SeedSequence(seed).spawn(n_chunks)[i]``.
    versions : dict of str
        Versions of uwtutor, NumPy, SciPy and Python that computed it.
    """

    final_errors: np.ndarray
    rmse: np.ndarray
    mean_nees: np.ndarray
    nees_bounds: tuple[float, float]
    mean_nis: np.ndarray | None
    nis_bounds: tuple[np.ndarray, np.ndarray] | None
    times: np.ndarray
    components: tuple[int, ...]
    confidence: float
    n_runs: int
    chunk_size: int
    n_chunks: int
    seed: int
    versions: dict[str, str]

    @property
    def n_steps(self) -> int:
        """Number of steps ``K``."""
        return len(self.rmse)

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

    def as_dict(self) -> dict[str, Any]:
        """The numbers and the metadata by name (e.g. for :func:`numpy.savez` or a results file)."""
        return {f: getattr(self, f) for f in self.__dataclass_fields__}


def _as_executor(executor: Any) -> Any:
    if executor is not None and not callable(getattr(executor, "submit", None)):
        raise TypeError("executor must have a submit(fn, *args) method returning a future (a concurrent.futures "
                        "executor, or distributed.Client(...).get_executor()); got "
                        f"{type(executor).__name__}")
    return executor


def _check_picklable(executor: Any, **functions: Any) -> None:
    """A process pool pickles the functions it runs: say which one cannot be, and what to use instead."""
    from concurrent.futures import ProcessPoolExecutor
    import pickle

    if not isinstance(executor, ProcessPoolExecutor):
        return
    for name, fn in functions.items():
        try:
            pickle.dumps(fn)
        except Exception as exc:  # noqa: BLE001 - pickling raises several types
            raise TypeError(f"{name} must be picklable to run on a process pool (a module-level function, or "
                            f"functools.partial of one; not a lambda or a local function); pickling {fn!r} "
                            f"failed: {exc}") from None


def _chunk_sizes(n_runs: int, chunk_size: int) -> list[int]:
    full, rest = divmod(n_runs, chunk_size)
    return [chunk_size] * full + ([rest] if rest else [])


def run_study(draw: Callable[[np.random.Generator, int], tuple[Any, Any]], estimate: Callable[[Any], FilterResult],
              n_runs: int, *, seed: int, chunk_size: int = 1000, executor: Any = None, components: Any = None,
              confidence: float = 0.95) -> StudyResult:
    r"""A Monte Carlo study of any size, chunk by chunk from one seed, serially or on any executor.

    The ``n_runs`` runs are cut into chunks of ``chunk_size`` (the last may be shorter). Chunk :math:`i` gets
    its own generator, ``numpy.random.default_rng(SeedSequence(seed).spawn(n_chunks)[i])``, draws its runs
    with ``draw(rng, n)``, filters them with ``estimate(inputs)`` and is reduced at once to sums over its runs:
    for each step :math:`k`

    .. math::

        \sum_j \lVert \hat x_{j,k} - x_{j,k} \rVert^2, \qquad \sum_j \epsilon_{j,k}, \qquad
        \sum_{j \in \mathcal M_k} \nu_{j,k}, \; |\mathcal M_k|,

    (squared errors, NEES, NIS over the runs :math:`\mathcal M_k` with a measurement) plus its final errors.
    The study adds the chunks' sums **in chunk order**, whatever order the chunks finished in, and returns
    :math:`\mathrm{RMSE}_k = \sqrt{\frac1M\sum}`, the mean NEES and NIS and their chi-square intervals (see
    :func:`run_monte_carlo` and :mod:`uwtutor.metrics`). Hence:

    * **the same numbers on any executor**, bit for bit, for the same ``seed`` and ``chunk_size``: in this
      process (``executor=None``), on a ``concurrent.futures.ProcessPoolExecutor`` or on a Dask cluster
      (``distributed.Client(...).get_executor()``, the optional ``uwtutor[scale]``). Another ``chunk_size``
      draws other runs (other streams): equally valid, not the same numbers;
    * **memory bounded by one chunk** (times the number of chunks in flight on an executor), not by ``n_runs``:
      no array of ``n_runs`` trajectories is ever built; the result holds :math:`O(K)` numbers and the
      ``n_runs`` final errors.

    A run whose estimate is NaN makes the RMSE and the mean NEES NaN: divergence is not hidden.

    Parameters
    ----------
    draw : callable
        ``draw(rng, n) -> (inputs, truth)``: ``n`` independent runs drawn with the generator ``rng`` only.
        ``truth`` has shape ``(n, K, d)`` or ``(K, d)`` (shared), ``d`` the filter's state size or the number
        of scored ``components``.
    estimate : callable
        ``estimate(inputs) -> FilterResult``: the batched filter, ``x`` of shape ``(n, K, n_state)``.
    n_runs : int
        Number of Monte Carlo runs, >= 1.
    seed : int
        Root seed (>= 0) of every random number of the study.
    chunk_size : int, default 1000
        Runs per chunk: the unit of work sent to a worker and the bound on memory.
    executor : concurrent.futures.Executor-like, optional
        Anything with ``submit(fn, *args)`` returning a future; ``None`` runs the chunks here, one by one. On a
        process pool ``draw`` and ``estimate`` must be picklable: module-level functions or
        ``functools.partial`` of them (a Dask cluster also takes lambdas, through cloudpickle).
    components : sequence of int, optional
        State components scored, e.g. ``(0, 1)`` for the position of a state that also carries a bias. All of
        them by default.
    confidence : float, default 0.95
        Probability of the NEES and NIS intervals.

    Returns
    -------
    StudyResult

    See Also
    --------
    run_monte_carlo : one batch, keeping every trajectory (for plots of single runs).

    Examples
    --------
    The circling vehicle of :func:`run_monte_carlo`, 3000 runs in chunks of 1000. ``draw`` and ``estimate``
    are module-level functions in real code (so that a process pool can pickle them):

    >>> import numpy as np
    >>> from uwtutor.filters import range_only_ekf
    >>> from uwtutor.montecarlo import run_study
    >>> K, q, r = 200, 0.3, 2.0
    >>> theta = np.linspace(0.0, np.pi, K + 1)
    >>> track = 200.0 * np.column_stack([np.cos(theta), np.sin(theta)])
    >>> def draw(rng, n):
    ...     truth = track[1:] + np.cumsum(rng.normal(0.0, q, (n, K, 2)), axis=1)
    ...     z = np.linalg.norm(truth, axis=-1) + rng.normal(0.0, r, (n, K))
    ...     x0 = track[0] + rng.normal(0.0, 5.0, (n, 2))
    ...     return dict(x0=x0, z=z), truth
    >>> def estimate(inputs):
    ...     return range_only_ekf(inputs["x0"], 25.0 * np.eye(2), np.diff(track, axis=0), inputs["z"],
    ...                           q**2 * np.eye(2), r**2)
    >>> study = run_study(draw, estimate, 3000, seed=2026, chunk_size=1000)
    >>> study.final_errors.shape, study.rmse.shape, study.n_chunks
    ((3000,), (200,), 3)
    >>> lo, hi = study.nees_bounds
    >>> bool(lo < study.mean_nees[-50:].mean() < hi)
    True

    The same seed and chunk size give the same numbers, bit for bit, on a process pool or a Dask cluster
    (``run_study(..., executor=pool)``).
    """
    if not callable(draw):
        raise TypeError(f"draw must be a function draw(rng, n) -> (inputs, truth); got {draw!r}")
    if not callable(estimate):
        raise TypeError(f"estimate must be a function estimate(inputs) -> FilterResult; got {estimate!r}")
    n_runs = as_int("n_runs", n_runs, minimum=1)
    chunk_size = as_int("chunk_size", chunk_size, minimum=1)
    seed = as_int("seed", seed, minimum=0)
    conf = float(as_finite("confidence", confidence))
    if not 0.0 < conf < 1.0:
        raise ValueError(f"confidence must lie strictly between 0 and 1; got {conf}")
    comps = None
    if components is not None:
        idx = np.atleast_1d(np.asarray(components))
        if idx.dtype.kind not in "iu" or idx.ndim != 1 or idx.size == 0 or idx.min() < 0 \
                or len(set(idx.tolist())) != idx.size:
            raise ValueError(f"components must be a non-empty list of distinct state indices >= 0; got "
                             f"{components!r}")
        comps = tuple(int(i) for i in idx)
    executor = _as_executor(executor)
    _check_picklable(executor, draw=draw, estimate=estimate)

    sizes = _chunk_sizes(n_runs, chunk_size)
    streams = np.random.SeedSequence(seed).spawn(len(sizes))
    if executor is None:
        partials = (_study_chunk(draw, estimate, s, n, comps) for s, n in zip(streams, sizes))
    else:
        futures = [executor.submit(_study_chunk, draw, estimate, s, n, comps) for s, n in zip(streams, sizes)]
        partials = (f.result() for f in futures)          # in chunk order, whatever order they finish in

    final_errors = np.empty(n_runs)
    total: dict[str, Any] = {}
    start = 0
    for i, part in enumerate(partials):
        if i == 0:
            total = dict(times=part.times, sq=part.sq_errors.copy(), nees=part.nees.copy(),
                         nis=None if part.nis is None else part.nis.copy(),
                         nis_n=None if part.nis_counts is None else part.nis_counts.copy(), nis_dof=part.nis_dof,
                         dof=part.nees_dof)
        else:
            if part.sq_errors.shape != total["sq"].shape:
                raise ValueError(f"every chunk must have the same number of steps K; chunk 0 has "
                                 f"{len(total['sq'])}, chunk {i} has {len(part.sq_errors)}")
            total["sq"] += part.sq_errors
            total["nees"] += part.nees
            if (part.nis is None) != (total["nis"] is None):
                raise ValueError(f"chunk {i} disagrees with chunk 0 on whether the filter reports innovations")
            if part.nis is not None:
                total["nis"] += part.nis
                total["nis_n"] += part.nis_counts
        final_errors[start:start + sizes[i]] = part.final_errors
        start += sizes[i]
        if executor is not None:
            futures[i] = None                               # let the finished chunk go

    d = total["dof"]
    mean_nis = nis_bounds = None
    if total["nis"] is not None:
        with np.errstate(invalid="ignore", divide="ignore"):
            mean_nis = np.where(total["nis_n"] > 0, total["nis"] / np.maximum(total["nis_n"], 1), np.nan)
        nis_bounds = metrics.chi2_mean_bounds(total["nis_dof"], total["nis_n"], conf)
    return StudyResult(
        final_errors=final_errors, rmse=np.sqrt(total["sq"] / n_runs), mean_nees=total["nees"] / n_runs,
        nees_bounds=metrics.chi2_mean_bounds(d, n_runs, conf), mean_nis=mean_nis, nis_bounds=nis_bounds,
        times=total["times"], components=comps if comps is not None else tuple(range(d)), confidence=conf,
        n_runs=n_runs, chunk_size=chunk_size, n_chunks=len(sizes), seed=seed, versions=_versions(),
    )
