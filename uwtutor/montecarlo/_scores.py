"""What the three study products share: scoring a batched filter result against the truth, the statistics of a
study's final errors, the divergence threshold."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import metrics
from .._validate import as_finite, as_float_array, as_scalar

#: Final position error [m] above which :func:`compare` counts a run as diverged, or lost (see its docstring).
DEFAULT_DIVERGENCE_THRESHOLD = 50.0


class _StudyStatistics:
    """The statistics read off a study's final errors and mean NEES/NIS (shared by the two study results)."""

    final_errors: np.ndarray
    mean_nees: np.ndarray
    nees_bounds: tuple[float | np.ndarray, float | np.ndarray]
    mean_nis: np.ndarray | None
    nis_bounds: tuple[float | np.ndarray, float | np.ndarray] | None

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


def _as_confidence(confidence: Any) -> float:
    """The probability of the chi-square intervals, strictly between 0 and 1."""
    conf = as_scalar("confidence", confidence)           # a one-element list is refused by name
    if not 0.0 < conf < 1.0:
        raise ValueError(f"confidence must lie strictly between 0 and 1; got {conf}")
    return conf


def _as_components(components: Any) -> tuple[int, ...] | None:
    """``components`` as a tuple of distinct state indices >= 0 (``None``: all of them)."""
    if components is None:
        return None
    idx = np.atleast_1d(np.asarray(components))
    if idx.dtype.kind not in "iu" or idx.ndim != 1 or idx.size == 0 or idx.min() < 0 \
            or len(set(idx.tolist())) != idx.size:
        raise ValueError(f"components must be a non-empty list of distinct state indices >= 0; got {components!r}")
    return tuple(int(i) for i in idx)


@dataclass(frozen=True)
class _RunScores:
    """The per-run scores of one batch of runs: what both studies reduce (see :func:`_score_runs`)."""

    truth: np.ndarray            # (M, K, d) the scored components of the truth, broadcast to every run
    components: tuple[int, ...]  # the scored state components (d of them)
    errors: np.ndarray           # (M, K) error norms
    nees: np.ndarray             # (M, K) NEES (inf where the covariance collapsed, NaN where the estimate is NaN)
    nis: np.ndarray | None       # (M, K) NIS (NaN where no measurement was used), None without innovations
    nis_dof: int                 # measurement size (0 without innovations)


def _score_runs(result: Any, truth: Any, components: tuple[int, ...] | None, *, producer: str, output: str,
                truth_name: str, n_runs: int | None = None) -> _RunScores:
    """Validate a batched filter's result against the truth and score every run and step, once for both studies.

    ``producer`` names the function that made the result in errors (``"filter_fn"``, ``"estimate"``),
    ``output`` the result itself (``"filter_fn(**inputs)"``), ``truth_name`` the truth; ``n_runs`` is the
    number of runs the result must hold (``None``: any). The truth holds every state component or only the
    scored ones on its last axis, shared ``(K, d)`` or per run ``(M, K, d)``.
    """
    if not (hasattr(result, "x") and hasattr(result, "P")):
        raise TypeError(f"{producer} must return a FilterResult (or an object with arrays x and P); got "
                        f"{type(result).__name__}")
    x = as_float_array(f"{output}.x", result.x, ndim=(2, 3))
    P = as_float_array(f"{output}.P", result.P, ndim=(3, 4))
    if x.ndim == 2:
        x, P = x[None], P[None]
    if n_runs is not None and x.shape[0] != n_runs:
        raise ValueError(f"{producer} must return the {n_runs} runs that were drawn (x of shape ({n_runs}, K, "
                         f"n_state)); got x of shape {x.shape}")
    n_state = x.shape[-1]
    if P.shape != x.shape + (n_state,):
        raise ValueError(f"{output}.P must have shape {x.shape + (n_state,)} to match its x; got {P.shape}")
    comps = tuple(range(n_state)) if components is None else components
    if max(comps) >= n_state:
        raise ValueError(f"components must be state indices in 0..{n_state - 1}: {list(comps)} names one beyond "
                         f"the {n_state} of the filter's state")
    sel = list(comps)
    t = as_finite(truth_name, truth, ndim=(2, 3))
    if t.shape[-1] == n_state:
        t = t[..., sel]
    elif t.shape[-1] != len(sel):
        raise ValueError(f"{truth_name} must have shape (K, d) or (M, K, d) and hold the {n_state} state "
                         f"components or the {len(sel)} scored ones on its last axis (d); got shape {t.shape}")
    if t.shape[:-1] not in ((x.shape[1],), x.shape[:-1]):     # broadcast over runs only: never (K, 1) against (K, 2)
        raise ValueError(f"{truth_name} must have shape (K, n) or (M, K, n) matching the filter's estimates "
                         f"{x.shape}; got {np.shape(truth)}")
    t = np.broadcast_to(t, x.shape[:-1] + (len(sel),))
    xs = x[..., sel]
    Ps = P[..., sel, :][..., :, sel] if len(sel) < n_state else P
    errors = metrics.estimation_errors(xs, t)
    # A covariance that has collapsed (a particle cloud reduced to one particle: zero variance) is a result, not
    # bad input: the filter claims a certainty it does not have, so that run's NEES at that step is infinite.
    finite = np.isfinite(Ps).all(axis=(-1, -2))
    collapsed = finite & ~metrics.positive_definite(np.where(finite[..., None, None], Ps, np.eye(Ps.shape[-1])))
    nees = metrics.nees(xs, np.where(collapsed[..., None, None], np.nan, Ps), t)
    nees[collapsed & np.isfinite(errors)] = np.inf
    nis = None
    nis_dof = 0
    y = getattr(result, "innovations", None)
    S = getattr(result, "innovation_cov", None)
    if y is not None and S is not None:
        y = as_float_array(f"{output}.innovations", y)
        S = as_float_array(f"{output}.innovation_cov", S)
        if y.ndim == 2 and x.shape[0] == 1:
            y, S = y[None], S[None]
        nis = metrics.nis(y, S)
        nis_dof = int(y.shape[-1])
    return _RunScores(truth=t, components=comps, errors=errors, nees=nees, nis=nis, nis_dof=nis_dof)
