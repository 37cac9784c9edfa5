r"""A filter started at its own epoch in every run, all runs in one call: the second stage of "a least-squares
start, then a filter".

Papers A and D trust a least-squares fix only once a test passes (paper A: the precision factor below 2; paper
D: a pre-location that is stable after a turn), and then start their filter from it. The epoch of that start
differs from run to run. :func:`filter_from_start_epochs` shifts every run so that its filter begins at step 0,
runs any batched functional filter once over all of them, and :meth:`StaggeredRun.at_epochs` maps the results back
to the epochs. ``uwtutor.pipelines.ls_fading_ekf`` (paper D) and ``uwtutor.pipelines.prepositioned_bias_ekf``
(paper A) are built on it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Generic, TypeVar

import numpy as np
from numpy.typing import ArrayLike

from .._validate import MAX_COORDINATE, as_callable, as_covariance, as_finite, as_flag, as_float_array
from ..filters.base import FilterResult

__all__ = ["StaggeredRun", "filter_from_start_epochs"]

#: The result type of the filter that was run (FilterResult or a subclass: FadingResult...)
ResultT = TypeVar("ResultT", bound=FilterResult)


@dataclass(frozen=True)
class StaggeredRun(Generic[ResultT]):
    """A filter started at a different epoch in every run (returned by :func:`filter_from_start_epochs`).

    Attributes
    ----------
    start : ndarray of int, shape (M,)
        The start epoch of each run: its filter's first step is epoch ``start + 1``; ``K`` for a run that never
        started.
    runs : ndarray of int
        The runs that were filtered (those with a finite starting state; a run that never started is filtered
        over padding only, and none of its filter's values is read).
    filter_result : FilterResult
        The filter's own run over ``runs``, in *filter time*: step ``j`` of the ``i``-th filtered run is epoch
        ``start[runs[i]] + 1 + j`` (steps past the last epoch are padding without measurements).
    n_epochs : int
        Number of epochs ``K`` (the filter's steps, unless ``filter_from_start_epochs`` was asked to
        ``trim_padding``).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.filters import range_only_ekf
    >>> from uwtutor.pipelines import filter_from_start_epochs
    >>> u = np.tile([1.0, 0.0], (2, 6, 1))
    >>> truth = np.array([100.0, 50.0]) + np.cumsum(u, axis=1)
    >>> run = filter_from_start_epochs(
    ...     range_only_ekf,
    ...     [1, 3],
    ...     truth[[0, 1], [1, 3]],
    ...     np.eye(2),
    ...     u,
    ...     np.linalg.norm(truth, axis=-1),
    ...     Q=np.eye(2) * 0.01,
    ...     R=1.0,
    ... )
    >>> run.start.tolist(), run.n_epochs
    ([1, 3], 6)
    >>> run.after_start.astype(int)
    array([[0, 0, 1, 1, 1, 1],
           [0, 0, 0, 0, 1, 1]])
    """

    start: np.ndarray
    runs: np.ndarray
    filter_result: ResultT
    n_epochs: int

    @property
    def after_start(self) -> np.ndarray:
        """``(M, K)``: True at the epochs after each run's start (where the filter's estimate applies)."""
        return np.arange(self.n_epochs)[None, :] > self.start[:, None]

    def at_epochs(self, values: ArrayLike, before: ArrayLike) -> np.ndarray:
        """A filter-time array of ``filter_result`` (its runs axis first) in epoch time, ``(M, K, ...)``:
        the filter's value after each run's start epoch and ``before`` (a scalar or an ``(M, K, ...)`` array) up
        to and including it, and in the runs that were not filtered."""
        M, K = self.start.shape[0], self.n_epochs
        values = np.asarray(values)
        out = np.array(np.broadcast_to(before, (M, K) + values.shape[2:]), dtype=np.result_type(values, before))
        starts = self.start[self.runs]
        i, k = np.nonzero(np.arange(K)[None, :] > starts[:, None])    # (filtered run, epoch) after each start
        out[self.runs[i], k] = values[i, k - starts[i] - 1]             # epoch k is filter step k - start - 1
        return out


def filter_from_start_epochs(filter_fn: Callable[..., ResultT], start: ArrayLike, x_start: ArrayLike,
                             P_start: ArrayLike, u: ArrayLike, z: ArrayLike, *,
                             per_run: dict[str, ArrayLike] | None = None, trim_padding: bool = False,
                             **kwargs: Any) -> StaggeredRun[ResultT]:
    r"""Run a batched filter in every run from its own start epoch, all runs in one call.

    Papers A and D start their filters only when a least-squares fix can be trusted (paper A: the precision
    factor below 2; paper D: a stable pre-location after a turn), and that epoch differs from run to run. Each run
    is shifted so that its filter's step 0 is epoch ``start + 1``, from the fix ``x_start`` with ``P_start``; the
    tail is padded with steps that have no measurement (predict only) and is never read. :meth:`StaggeredRun.at_epochs`
    maps any result array back to epoch time.

    Parameters
    ----------
    filter_fn : callable
        A functional filter of the library's argument order, ``filter_fn(x0, P0, u, z, **kwargs)``, batched over
        runs (e.g. :func:`uwtutor.filters.fading.fading_ekf`, :func:`uwtutor.filters.bias.bias_ekf`).
    start : array_like of int, shape (M,)
        The start epoch of each run, ``0 <= start <= K``; ``K`` (or more) for a run that never starts.
    x_start : array_like, shape (M, n)
        The state each run starts from (the fix at its start epoch); a run whose ``x_start`` is not finite is
        not filtered (at least one must be finite).
    P_start : array_like, shape (n, n) or (M, n, n)
        Its covariance.
    u : array_like, shape (M, K, p)
        The inputs of every epoch.
    z : array_like, shape (M, K) or (M, K, m)
        The measurements of every epoch (NaN: none).
    per_run : dict, optional
        Further filter arguments with a runs axis first (e.g. paper D's ``mu_gamma`` of each run): they are
        passed for the filtered runs only.
    trim_padding : bool, default False
        True: the filter runs only the :math:`K - 1 - \min_i s_i` steps the earliest-starting filtered run needs
        (at least one), not ``K``: the padding no epoch reads is left out (the values at the epochs are the same,
        bit for bit: a filter step depends on the steps before it only). ``filter_result`` is then that much
        shorter, and no further argument may have a steps axis (it would no longer match ``u`` and ``z``).
    **kwargs
        Further filter arguments shared by every run.

    Returns
    -------
    StaggeredRun

    Examples
    --------
    Two runs, started at epochs 2 and 5, of the range-only EKF:

    >>> import numpy as np
    >>> from uwtutor.filters import range_only_ekf
    >>> from uwtutor.pipelines import filter_from_start_epochs
    >>> u = np.tile([1.0, 0.0], (2, 10, 1))
    >>> truth = np.array([100.0, 50.0]) + np.cumsum(u, axis=1)
    >>> z = np.linalg.norm(truth, axis=-1)
    >>> run = filter_from_start_epochs(
    ...     range_only_ekf,
    ...     [2, 5],
    ...     truth[[0, 1], [2, 5]],
    ...     np.eye(2),
    ...     u,
    ...     z,
    ...     Q=np.eye(2) * 0.01,
    ...     R=1.0,
    ... )
    >>> x = run.at_epochs(run.filter_result.x, np.nan)
    >>> bool(
    ...     np.isnan(x[0, :3]).all()
    ...     and np.isfinite(x[0, 3:]).all()
    ...     and np.isnan(x[1, :6]).all()
    ... )
    True
    """
    as_callable("filter_fn", filter_fn, "a functional filter such as uwtutor.filters.fading_ekf")
    u = as_finite("u", u, ndim=3)
    z = as_float_array("z", z)
    if np.isinf(z).any():
        raise ValueError("z must be finite, or NaN for a missing measurement; got an infinite value")
    M, K = u.shape[:2]
    if z.shape[:2] != (M, K):
        raise ValueError(f"z must have the runs and epochs of u, ({M}, {K}, ...); got shape {z.shape}")
    given = np.asarray(start)
    if given.shape != (M,) or given.dtype.kind not in "iu":
        raise ValueError(f"start must hold one integer epoch per run, shape ({M},); got {given!r}")
    if (given < 0).any():
        raise ValueError("start must be >= 0 (an epoch index)")
    first = np.minimum(given, K).astype(int)
    x_start = as_float_array("x_start", x_start, ndim=2)
    if x_start.shape[0] != M:
        raise ValueError(f"x_start must have one row per run ({M}); got shape {x_start.shape}")
    if np.any(np.abs(x_start[np.isfinite(x_start)]) > MAX_COORDINATE):
        raise ValueError(f"x_start must be at most {MAX_COORDINATE:.0e} in magnitude (beyond it the filter overflows "
                         "float64). Change its units")
    if np.isinf(x_start).any():
        raise ValueError("x_start must be finite, or NaN for a run that never starts; got an infinite value")
    P_start = as_covariance("P_start", P_start, x_start.shape[1])
    if P_start.ndim not in (2, 3) or (P_start.ndim == 3 and P_start.shape[0] != M):
        raise ValueError(f"P_start must have shape (n, n) or ({M}, n, n); got {P_start.shape}")
    if per_run is not None and not isinstance(per_run, dict):
        raise TypeError(f"per_run must be a dict of filter arguments with a runs axis first; got "
                        f"{type(per_run).__name__}")
    for name, value in (per_run or {}).items():
        if np.shape(value)[:1] != (M,):
            raise ValueError(f"per_run[{name!r}] must have one value per run first (M = {M}); got shape "
                             f"{np.shape(value)} (nothing is truncated or broadcast)")
    runs = np.flatnonzero(np.isfinite(x_start).all(axis=1))
    if runs.size == 0:
        raise ValueError("no run has a finite x_start: there is nothing to filter (a run that never started "
                         "should be left out, or given its last fix)")
    rows = runs[:, None]
    steps = max(1, K - 1 - int(first[runs].min())) if as_flag("trim_padding", trim_padding) else K
    idx = first[rows] + 1 + np.arange(steps)[None, :]
    inside = idx < K
    idx_c = np.minimum(idx, K - 1)
    pad = (slice(None), slice(None)) + (None,) * (z.ndim - 2)
    z_shift = np.where(inside[pad], z[rows, idx_c], np.nan)
    u_shift = np.where(inside[..., None], u[rows, idx_c], 0.0)
    P0 = P_start if P_start.ndim == 2 else P_start[runs]
    extra = {name: np.asarray(value)[runs] for name, value in (per_run or {}).items()}
    result = filter_fn(x_start[runs], P0, u_shift, z_shift, **kwargs, **extra)
    return StaggeredRun(start=first, runs=runs, filter_result=result, n_epochs=K)
