r"""Accuracy and consistency metrics for Monte Carlo studies of a filter.

Conventions: ``M`` Monte Carlo runs, ``K`` steps, state size ``n``, measurement size ``m``. Estimates have shape
``(M, K, n)`` (a single run ``(K, n)`` is treated as ``M = 1``), covariances ``(M, K, n, n)``, the truth
``(K, n)`` (shared by every run) or ``(M, K, n)``.

Accuracy
    * :func:`estimation_errors` -- the error norm :math:`\lVert \hat x_{j,k} - x_{j,k} \rVert` of every run and step;
    * :func:`rmse_over_time` -- its root mean square over the runs, one value per step;
    * :func:`final_errors` and :func:`error_cdf` -- the distribution of the error at the last step (or any step),
      as an empirical cumulative distribution function.

Consistency (Bar-Shalom, Li and Kirubarajan 2001, sec. 5.4)
    * :func:`nees` -- normalized estimation error squared :math:`\epsilon_k = e_k^T P_k^{-1} e_k`;
    * :func:`nis` -- normalized innovation squared :math:`\nu_k = y_k^T S_k^{-1} y_k`;
    * :func:`average_over_runs` -- their mean over the runs (ignoring NaN: steps without a measurement);
    * :func:`chi2_mean_bounds` -- the two-sided chi-square acceptance interval for such a mean.

A consistent filter has :math:`\epsilon_k \sim \chi^2_n` and :math:`\nu_k \sim \chi^2_m`; the mean over ``M``
independent runs, times ``M``, is then :math:`\chi^2_{Mn}` (resp. :math:`\chi^2_{Mm}`), which gives the bounds.

References
----------
Bar-Shalom, Y., Li, X. R. and Kirubarajan, T. (2001). *Estimation with Applications to Tracking and Navigation*.
Wiley. Sections 5.4.2 (NEES, NIS and their chi-square tests) and 5.4.3 (Monte Carlo averages).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import stats

from ._linalg import positive_definite as _positive_definite, quadratic_form as _quadratic_form
from ._validate import MAX_COORDINATE, SYMMETRY_RTOL, as_finite, as_float_array, as_scalar

__all__ = [
    "estimation_errors",
    "rmse_over_time",
    "final_errors",
    "error_cdf",
    "nees",
    "nis",
    "positive_definite",
    "average_over_runs",
    "chi2_mean_bounds",
    "fraction_within",
]


def _estimates_and_truth(estimates: Any, truth: Any, components: Any) -> tuple[np.ndarray, np.ndarray]:
    """Validate ``estimates`` (K, n) / (M, K, n) and ``truth``; return both as (M, K, n') float arrays."""
    x = as_float_array("estimates", estimates, ndim=(2, 3))
    if x.ndim == 2:
        x = x[None]
    if x.size == 0:
        raise ValueError(f"estimates is empty (shape {x.shape}): there is nothing to score")
    with np.errstate(invalid="ignore"):
        big = np.abs(x) > MAX_COORDINATE          # also inf; NaN (no estimate, e.g. before a filter starts) is fine
    if big.any():
        raise ValueError(f"estimates must be finite (NaN where there is no estimate) and at most {MAX_COORDINATE:.0e} "
                         f"in magnitude (beyond it the squared errors overflow float64); got {x[big].flat[0]:.3g}. "
                         "Change their units")
    t = as_finite("truth", truth, ndim=(1, 2, 3), max_abs=MAX_COORDINATE)
    if t.ndim == 1 and x.shape[-1] == 1:          # (K,) for a scalar state
        t = t[:, None]
    # only the runs axis is shared (one truth for every run); nothing else is broadcast: a (K, 1) truth against
    # (K, 2) estimates is an error, not an error vector
    if t.shape not in (x.shape, x.shape[1:]):
        raise ValueError(f"truth must have shape {x.shape[1:]} (one truth for every run) or {x.shape} matching "
                         f"the estimates; got {np.shape(truth)}")
    t = np.broadcast_to(t, x.shape)
    if components is not None:
        idx = np.atleast_1d(np.asarray(components))
        if idx.dtype.kind not in "iu" or idx.ndim != 1 or idx.size == 0 or \
                idx.min() < -x.shape[-1] or idx.max() >= x.shape[-1]:
            raise ValueError(f"components must be a non-empty list of state indices below {x.shape[-1]}; "
                             f"got {components!r}")
        x, t = x[..., idx], t[..., idx]
    return x, t


def _without_covariance(vec: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """NaN where the covariance is entirely NaN (no covariance there, e.g. before a filter starts): the score is
    NaN there, as where the vector itself is NaN."""
    none = np.isnan(cov).all(axis=(-1, -2))
    return np.where(none[..., None], np.nan, vec) if none.any() else vec


def _check_used_covariances(name: str, P: np.ndarray, used: np.ndarray) -> None:
    """The covariances that score a finite vector must be finite, symmetric and positive definite (tolerances
    of :func:`uwtutor._validate.as_covariance`); the others (no measurement, NaN estimate) are not read."""
    if not used.any():
        return
    Pu = P[used]
    bad = ~np.isfinite(Pu)
    if bad.any():
        raise ValueError(f"{name} must be finite wherever it is used; got {Pu[bad].flat[0]} (a covariance may be "
                         "NaN only as a whole, meaning 'none', or where the vector it scores is NaN)")
    scale = np.maximum(1.0, np.abs(Pu).max(axis=(-1, -2)))[:, None, None]
    if (np.abs(Pu - np.swapaxes(Pu, -1, -2)) > SYMMETRY_RTOL * scale).any():
        raise ValueError(f"{name} must be symmetric; use (P + P.T) / 2 if it is only off by rounding")
    if not positive_definite(Pu).all():
        raise ValueError(f"{name} must be positive definite wherever it is used (a covariance); found one that "
                         "is not (negative variances, or a correlation beyond +-1)")


def _normalized_squares(name: str, covariances: Any, vectors: np.ndarray,
                        what: str) -> tuple[np.ndarray, np.ndarray]:
    """:math:`v^T C^{-1} v` of every run and step, the NEES and the NIS alike.

    ``vectors`` (M, K, n) are validated ``what``; ``covariances`` (M, K, n, n) or (K, n, n) are validated here,
    under ``name``. Returns the vectors with NaN where there is no covariance, and the quadratic forms (M, K).
    """
    C = as_float_array(name, covariances, ndim=(3, 4))
    if C.ndim == 3:
        C = C[None]
    if C.shape != vectors.shape + (vectors.shape[-1],):
        raise ValueError(f"{name} must have shape {vectors.shape + (vectors.shape[-1],)} to match the {what}; "
                         f"got {C.shape}")
    v = _without_covariance(vectors, C)
    _check_used_covariances(name, C, np.isfinite(v).all(axis=-1))
    with np.errstate(over="ignore", invalid="ignore"):
        return v, _quadratic_form(v, C, name)


def positive_definite(covariances: ArrayLike) -> NDArray[np.bool_]:
    """Which of the matrices ``(..., n, n)`` are positive definite, by the test the scores apply (Sylvester's
    criterion for n <= 2, a Cholesky factorization for larger ones; a NaN or infinite matrix is not).

    >>> import numpy as np
    >>> positive_definite(np.array([np.eye(2), np.zeros((2, 2))])).tolist()
    [True, False]
    """
    cov = as_float_array("covariances", covariances, nonempty=True)
    if cov.ndim < 2 or cov.shape[-1] != cov.shape[-2]:
        raise ValueError(f"covariances must be a square matrix or a stack of them, shape (..., n, n); got shape "
                         f"{cov.shape}")
    return _positive_definite(cov)


def estimation_errors(estimates: ArrayLike, truth: ArrayLike,
                      components: ArrayLike | None = None) -> NDArray[np.float64]:
    r"""Euclidean estimation error of every run and step, :math:`\lVert \hat x_{j,k} - x_{j,k} \rVert`.

    Parameters
    ----------
    estimates : array_like, shape (M, K, n) or (K, n)
        Filter estimates.
    truth : array_like, shape (K, n) or (M, K, n)
        True states (a ``(K, n)`` truth is shared by every run).
    components : sequence of int, optional
        State components to include, e.g. ``[0, 1]`` for the horizontal position of a state that also holds
        a range bias. All of them by default.

    Returns
    -------
    ndarray, shape (M, K)
        Error norms (``M = 1`` for a single run).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.metrics import estimation_errors
    >>> # M = 2 runs, K = 2 steps, truth at the origin
    >>> est = np.array([[[3.0, 4.0], [1.0, 0.0]], [[0.0, 0.0], [0.0, 2.0]]])
    >>> estimation_errors(est, np.zeros((2, 2)))
    array([[5., 1.],
           [0., 2.]])
    """
    x, t = _estimates_and_truth(estimates, truth, components)
    return np.linalg.norm(x - t, axis=-1)


def rmse_over_time(estimates: ArrayLike, truth: ArrayLike, components: ArrayLike | None = None) -> NDArray[np.float64]:
    r"""Root mean square error over the Monte Carlo runs, at each step.

    .. math::

        \mathrm{RMSE}_k = \sqrt{\frac{1}{M} \sum_{j=1}^{M} \lVert \hat x_{j,k} - x_{j,k} \rVert^2}

    Parameters
    ----------
    estimates, truth, components
        As in :func:`estimation_errors`.

    Returns
    -------
    ndarray, shape (K,)
        The RMSE of each step (with one run, the error norm itself).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.metrics import rmse_over_time
    >>> # M = 2 runs, K = 2 steps
    >>> est = np.array([[[3.0, 4.0], [0.0, 1.0]], [[0.0, 0.0], [1.0, 0.0]]])
    >>> rmse_over_time(est, np.zeros((2, 2)))
    array([3.53553391, 1.        ])
    """
    err = estimation_errors(estimates, truth, components)
    return np.sqrt(np.mean(err**2, axis=0))


def final_errors(estimates: ArrayLike, truth: ArrayLike, components: ArrayLike | None = None,
                 step: int = -1) -> NDArray[np.float64]:
    """Error norm of every run at one step (the last by default): the sample of the final-error distribution.

    Parameters
    ----------
    estimates, truth, components
        As in :func:`estimation_errors`.
    step : int, optional
        The step to look at (Python indexing; ``-1`` is the last).

    Returns
    -------
    ndarray, shape (M,)
        One error norm per run.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.metrics import final_errors
    >>> est = np.array([[[3.0, 4.0], [1.0, 0.0]], [[0.0, 0.0], [0.0, 2.0]]])
    >>> final_errors(est, np.zeros((2, 2)))
    array([1., 2.])
    >>> final_errors(est, np.zeros((2, 2)), step=0)
    array([5., 0.])
    """
    err = estimation_errors(estimates, truth, components)
    K = err.shape[1]
    if not isinstance(step, (int, np.integer)) or not -K <= step < K:
        raise ValueError(f"step must be an integer index into the {K} steps; got {step!r}")
    return err[:, step]


def error_cdf(errors: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    r"""Empirical cumulative distribution function of a sample of errors.

    Sorting the ``M`` finite values :math:`e_{(1)} \le \dots \le e_{(M)}` gives
    :math:`\hat F(e_{(i)}) = i / M`: the fraction of runs whose error is at most :math:`e_{(i)}`.
    Plot it as a step function (``plt.step(values, probabilities, where="post")``); read percentiles off it
    (the 95 % error is the first value whose probability reaches 0.95).

    Parameters
    ----------
    errors : array_like, shape (M,)
        Error sample, e.g. from :func:`final_errors`. NaN values (diverged runs) are dropped.

    Returns
    -------
    values : ndarray, shape (M',)
        The sorted finite errors.
    probabilities : ndarray, shape (M',)
        :math:`i / M'` for ``i = 1..M'``.

    Examples
    --------
    >>> from uwtutor.metrics import error_cdf
    >>> error_cdf([3.0, 1.0, 2.0, 4.0])
    (array([1., 2., 3., 4.]), array([0.25, 0.5 , 0.75, 1.  ]))
    """
    e = as_float_array("errors", errors, ndim=1)
    if np.isinf(e).any():
        raise ValueError("errors must be finite (NaN for a run without a value is dropped); got an infinite value")
    e = np.sort(e[~np.isnan(e)])
    if e.size == 0:
        raise ValueError("errors must contain at least one value that is not NaN")
    return e, np.arange(1, e.size + 1) / e.size


def nees(estimates: ArrayLike, covariances: ArrayLike, truth: ArrayLike) -> NDArray[np.float64]:
    r"""Normalized estimation error squared of every run and step.

    .. math::

        \epsilon_{j,k} = (x_{j,k} - \hat x_{j,k})^T P_{j,k}^{-1} (x_{j,k} - \hat x_{j,k})

    Under a consistent filter (errors zero-mean Gaussian with the covariance the filter claims)
    :math:`\epsilon_{j,k} \sim \chi^2_n`, mean ``n``.

    Parameters
    ----------
    estimates : array_like, shape (M, K, n) or (K, n)
        Filter estimates.
    covariances : array_like, shape (M, K, n, n) or (K, n, n)
        Their covariances (positive definite).
    truth : array_like, shape (K, n) or (M, K, n)
        True states.

    Returns
    -------
    ndarray, shape (M, K)
        NEES values (``M = 1`` for a single run).

    See Also
    --------
    chi2_mean_bounds : the acceptance interval of their mean over runs.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.metrics import nees
    >>> # one run, two steps, covariance 4 I: (9 + 16) / 4 and 1 / 4
    >>> est = np.array([[3.0, 4.0], [1.0, 0.0]])
    >>> nees(est, np.tile(np.eye(2) * 4.0, (2, 1, 1)), np.zeros((2, 2)))
    array([[6.25, 0.25]])
    """
    x, t = _estimates_and_truth(estimates, truth, None)
    _, out = _normalized_squares("covariances", covariances, t - x, "estimates")
    if np.isinf(out).any():
        raise ValueError("estimates, truth and covariances give a NEES that overflows float64 (errors near 1e154, "
                         "or a variance near 0): change their units")
    return out


def nis(innovations: ArrayLike, innovation_cov: ArrayLike) -> NDArray[np.float64]:
    r"""Normalized innovation squared of every run and step (NaN where no measurement was used).

    .. math::

        \nu_{j,k} = y_{j,k}^T S_{j,k}^{-1} y_{j,k}, \qquad \nu_{j,k} \sim \chi^2_m \text{ if consistent}.

    Unlike the NEES it needs no truth, so it can be checked on real data too.

    Parameters
    ----------
    innovations : array_like, shape (M, K, m) or (K, m)
        Innovations :math:`y = z - h(\hat x^-)` (NaN rows: no measurement at that step).
    innovation_cov : array_like, shape (M, K, m, m) or (K, m, m)
        Their covariances :math:`S`.

    Returns
    -------
    ndarray, shape (M, K)
        NIS values, NaN where the innovation is NaN.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.metrics import nis
    >>> # a range innovation of 2 m with S = 4 m^2, then no measurement
    >>> nis(np.array([[2.0], [np.nan]]), np.array([[[4.0]], [[4.0]]]))
    array([[ 1., nan]])
    """
    y = as_float_array("innovations", innovations, ndim=(2, 3))
    if np.isinf(y).any():
        raise ValueError("innovations must be finite (a NaN row: no measurement at that step); got an infinite value")
    if y.ndim == 2:
        y = y[None]
    y, out = _normalized_squares("innovation_cov", innovation_cov, y, "innovations")
    out[~np.isfinite(y).all(axis=-1)] = np.nan
    if np.isinf(out).any():
        raise ValueError("innovations and innovation_cov give a NIS that overflows float64 (innovations near "
                         "1e154, or a variance near 0): change their units")
    return out


def average_over_runs(values: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.int_]]:
    r"""Mean over the Monte Carlo runs of NEES or NIS values, step by step, ignoring NaN entries.

    .. math::

        \bar\epsilon_k = \frac{1}{M_k} \sum_{j \,:\, \epsilon_{j,k} \ne \mathrm{NaN}} \epsilon_{j,k}

    Parameters
    ----------
    values : array_like, shape (M, K)
        Per-run values, e.g. from :func:`nees` or :func:`nis`.

    Returns
    -------
    mean : ndarray, shape (K,)
        Mean over the runs (NaN at a step where every run is NaN).
    counts : ndarray of int, shape (K,)
        :math:`M_k`, the number of runs that entered each mean: pass it to :func:`chi2_mean_bounds`.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.metrics import average_over_runs
    >>> # the first run has no value at step 2
    >>> mean, counts = average_over_runs(np.array([[1.0, np.nan], [3.0, 2.0]]))
    >>> mean, counts
    (array([2., 2.]), array([2, 1]))
    """
    v = as_float_array("values", values, ndim=2, nonempty=True)
    if np.isinf(v).any():
        raise ValueError("values must be finite (NaN where a run has no value at that step); got an infinite value")
    ok = ~np.isnan(v)
    counts = ok.sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(ok, v, 0.0).sum(axis=0) / counts
    return np.where(counts > 0, mean, np.nan), counts


def chi2_mean_bounds(dof: int, n_runs: ArrayLike,
                     confidence: float = 0.95) -> tuple[float | NDArray[np.float64], float | NDArray[np.float64]]:
    r"""Two-sided chi-square acceptance interval for the mean of ``n_runs`` NEES or NIS values.

    If each value is :math:`\chi^2_d` (``d = dof``, the state size for the NEES, the measurement size for the
    NIS) and the ``M`` runs are independent, :math:`M \bar\epsilon \sim \chi^2_{Md}`, so with probability
    ``confidence`` the mean lies in

    .. math::

        \left[ \frac{\chi^2_{Md}(\alpha/2)}{M}, \; \frac{\chi^2_{Md}(1 - \alpha/2)}{M} \right],
        \qquad \alpha = 1 - \text{confidence},

    where :math:`\chi^2_{\nu}(p)` is the ``p`` quantile (``scipy.stats.chi2.ppf``). Bar-Shalom et al. (2001),
    sec. 5.4.2.

    Parameters
    ----------
    dof : int
        Degrees of freedom ``d`` of one value (>= 1).
    n_runs : int or array_like of int
        Number of runs ``M`` averaged (>= 1), or one count per step (from :func:`average_over_runs`).
    confidence : float, optional
        Probability of the interval, in (0, 1); 0.95 by default.

    Returns
    -------
    lower, upper : float or ndarray
        The bounds (arrays when ``n_runs`` is an array; NaN where a count is 0).

    Examples
    --------
    >>> from uwtutor.metrics import chi2_mean_bounds
    >>> lo, hi = chi2_mean_bounds(2, 50)      # NEES of a 2-D position, 50 runs
    >>> round(lo, 3), round(hi, 3)
    (1.484, 2.591)
    """
    if isinstance(dof, bool) or not isinstance(dof, (int, np.integer)) or not 1 <= dof <= 10**6:
        raise ValueError(f"dof must be a positive integer (state or measurement size, at most 1e6); got {dof!r}")
    conf = as_scalar("confidence", confidence)
    if not 0.0 < conf < 1.0:
        raise ValueError(f"confidence must lie strictly between 0 and 1; got {conf}")
    try:
        m = np.asarray(n_runs)
    except ValueError:
        raise ValueError("n_runs must be a positive integer (or an array of counts >= 0); got a ragged list") \
            from None
    if m.dtype.kind not in "iu" or np.any(m < 0) or (m.ndim == 0 and m < 1) or np.any(m > 10**12):
        raise ValueError(f"n_runs must be a positive integer (or an array of counts >= 0); got {n_runs!r}")
    alpha = 1.0 - conf
    with np.errstate(invalid="ignore", divide="ignore"):
        mf = np.where(m > 0, m, np.nan).astype(float)
        lower = stats.chi2.ppf(alpha / 2, mf * dof) / mf
        upper = stats.chi2.ppf(1 - alpha / 2, mf * dof) / mf
    if m.ndim == 0:
        return float(lower), float(upper)
    return lower, upper


def fraction_within(values: ArrayLike, lower: ArrayLike, upper: ArrayLike) -> float:
    """Fraction of the (non-NaN) ``values`` that lie within ``[lower, upper]`` (bounds broadcast).

    With 95 % bounds on the mean NEES of each step, a consistent filter keeps about 95 % of the steps inside.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.metrics import fraction_within
    >>> # the NaN is left out: 2 of the 3 values lie in [0.2, 2]
    >>> round(fraction_within([0.5, 1.2, 3.0, np.nan], 0.2, 2.0), 3)
    0.667
    """
    v = as_float_array("values", values)
    bounds = []
    for name, value in (("lower", lower), ("upper", upper)):
        b = as_float_array(name, value)
        if b.shape not in ((), v.shape, v.shape[-1:]):     # a scalar, one per value, or one per step
            raise ValueError(f"{name} must be a number or have the shape of values {v.shape} (or "
                             f"{v.shape[-1:]}); got {b.shape}")
        bounds.append(np.broadcast_to(b, v.shape))
    lo, hi = bounds
    ok = ~np.isnan(v) & ~np.isnan(lo) & ~np.isnan(hi)
    if not ok.any():
        raise ValueError("values, lower and upper must share at least one entry where none of them is NaN (a NaN "
                         "bound, from a step without runs, leaves that value out)")
    inside = (v[ok] >= lo[ok]) & (v[ok] <= hi[ok])
    return float(inside.mean())
