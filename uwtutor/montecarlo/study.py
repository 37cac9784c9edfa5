"""Studies that scale out: chunk by chunk from one seed, on any executor, summed as they finish (``run_study``)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from .. import metrics
from .._validate import as_int
from ..filters.base import FilterResult
from ._scores import DEFAULT_DIVERGENCE_THRESHOLD, _as_components, _as_confidence, _score_runs, _StudyStatistics

__all__ = ["StudyResult", "run_study", "MAX_STUDY_RUNS"]


#: The most runs :func:`run_study` takes: it keeps each run's final error (8 bytes a run, 0.8 GB at the limit).
MAX_STUDY_RUNS = 10**8


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
    final_nees: np.ndarray       # (n,)  NEES at the last step (inf: collapsed covariance; NaN: none)


def _study_chunk(draw: Callable[..., Any], estimate: Callable[..., Any], seed_sequence: np.random.SeedSequence,
                 n: int, components: tuple[int, ...] | None) -> _ChunkSums:
    """Draw ``n`` runs from their own Generator, filter them, and reduce them to sums (runs in a worker)."""
    rng = np.random.default_rng(seed_sequence)
    drawn = draw(rng, n)
    if not (isinstance(drawn, tuple) and len(drawn) == 2):
        raise TypeError(f"draw(rng, n) must return a pair (inputs, truth); got {type(drawn).__name__}")
    inputs, truth = drawn
    result = estimate(inputs)
    scores = _score_runs(result, truth, components, producer="estimate", output="estimate(inputs)",
                         truth_name="truth (from draw)", n_runs=n)
    nis_sum = nis_counts = None
    if scores.nis is not None:
        used = ~np.isnan(scores.nis)
        nis_sum = np.where(used, scores.nis, 0.0).sum(axis=0)
        nis_counts = used.sum(axis=0)
    K = scores.errors.shape[1]
    times = np.asarray(getattr(result, "times", np.arange(K, dtype=float)), dtype=float)
    return _ChunkSums(times=times, sq_errors=(scores.errors**2).sum(axis=0), nees=scores.nees.sum(axis=0),
                      nees_dof=len(scores.components), nis=nis_sum, nis_counts=nis_counts, nis_dof=scores.nis_dof,
                      final_errors=scores.errors[:, -1].copy(), final_nees=scores.nees[:, -1].copy())


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
class StudyResult(_StudyStatistics):
    r"""The scores of a chunked Monte Carlo study (see :func:`run_study`): sums reduced over the runs.

    Unlike :class:`MonteCarloResult` it keeps no trajectory: only what the chunks were reduced to, so its size
    is :math:`O(K + M)` whatever the number of runs :math:`M`.

    Attributes
    ----------
    final_errors : ndarray, shape (M,)
        Error norm of every one of the M = ``n_runs`` runs at the last step, in run order (chunk by chunk).
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
    n_runs : int
        Number of Monte Carlo runs.
    chunk_size : int
        Runs per chunk.
    n_chunks : int
        Number of chunks.
    seed : int
        The root of the random streams: chunk ``i`` drew from ``SeedSequence(seed).spawn(n_chunks)[i]``.
    versions : dict of str
        Versions of uwtutor, NumPy, SciPy and Python that computed it.
    final_nees : ndarray, shape (M,), or None
        NEES of every run at the last step, in run order (inf where the covariance collapsed, NaN where the
        filter reports none): with ``final_errors``, what :mod:`uwtutor.statistics` reads.

    Examples
    --------
    A study of 300 runs in chunks of 100 keeps the final errors and the per-step sums, not the trajectories:

    >>> import numpy as np
    >>> from uwtutor.filters import range_only_ekf
    >>> from uwtutor.montecarlo import run_study
    >>> track = np.column_stack([np.linspace(100.0, 150.0, 51), np.full(51, 80.0)])
    >>> def draw(rng, n):
    ...     z = np.linalg.norm(track[1:], axis=1) + rng.normal(0.0, 1.0, (n, 50))
    ...     return dict(x0=track[0] + rng.normal(0.0, 3.0, (n, 2)), z=z), track[1:]
    >>> def estimate(inputs):
    ...     return range_only_ekf(inputs["x0"], np.eye(2) * 9.0,
    ...                           np.diff(track, axis=0), inputs["z"],
    ...                           np.eye(2) * 1e-4, 1.0)
    >>> study = run_study(draw, estimate, 300, seed=5, chunk_size=100)
    >>> study.n_runs, study.n_chunks, study.final_errors.shape, study.rmse.shape
    (300, 3, (300,), (50,))
    >>> sorted(study.as_dict())[:4]
    ['chunk_size', 'components', 'confidence', 'final_errors']
    """

    final_errors: np.ndarray
    rmse: np.ndarray
    mean_nees: np.ndarray
    nees_bounds: tuple[float | np.ndarray, float | np.ndarray]
    mean_nis: np.ndarray | None
    nis_bounds: tuple[float | np.ndarray, float | np.ndarray] | None
    times: np.ndarray
    components: tuple[int, ...]
    confidence: float
    n_runs: int
    chunk_size: int
    n_chunks: int
    seed: int
    versions: dict[str, str]
    final_nees: np.ndarray | None = None

    @property
    def n_steps(self) -> int:
        """Number of steps ``K``."""
        return len(self.rmse)

    def statistics(self, threshold: float = DEFAULT_DIVERGENCE_THRESHOLD) -> Any:
        """Every number of the study with its interval (:func:`uwtutor.statistics.cell_statistics` of its final
        errors and final NEES, ``threshold`` the lost-run threshold [m])."""
        from ..statistics import cell_statistics

        return cell_statistics(self.final_errors, self.final_nees, dof=len(self.components), threshold=threshold,
                               confidence=self.confidence)

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
    import pickle
    from concurrent.futures import ProcessPoolExecutor

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
    ...     return range_only_ekf(
    ...         inputs["x0"],
    ...         25.0 * np.eye(2),
    ...         np.diff(track, axis=0),
    ...         inputs["z"],
    ...         q**2 * np.eye(2),
    ...         r**2,
    ...     )
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
    if n_runs > MAX_STUDY_RUNS:
        raise ValueError(f"n_runs must be at most {MAX_STUDY_RUNS:.0e}: the study keeps every run's final error "
                         f"({8 * n_runs / 1e9:.3g} GB for {n_runs} runs); got {n_runs}. Split it into studies with "
                         "other seeds")
    chunk_size = as_int("chunk_size", chunk_size, minimum=1)
    seed = as_int("seed", seed, minimum=0)
    conf = _as_confidence(confidence)
    comps = _as_components(components)
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
    final_nees = np.empty(n_runs)
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
        final_nees[start:start + sizes[i]] = part.final_nees
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
        final_nees=final_nees,
    )
