r"""Verdicts that survive statistics: intervals for a study's numbers, paired comparisons, rankings that admit ties.

A Monte Carlo study of a navigation method ends with one final position error per run, :math:`e_j`,
:math:`j = 1..n`, and (for a method with a covariance) one final NEES :math:`\epsilon_j`. A few runs end far off
(a mirror image, a wrong start): they are **lost**, :math:`e_j > T` (:data:`LOST_THRESHOLD`, 50 m; a NaN estimate
counts as lost, with an infinite error). From the runs this module computes, each with an interval of probability
``confidence`` whose coverage ``tests/test_statistics.py`` checks by simulating studies of the book's shape (1000
runs, 0.1-2 % of them lost with errors from 50 m to 5 km):

=============================  ======================================================================================
statistic                      interval
=============================  ======================================================================================
median final error             distribution-free, from order statistics (the binomial count of runs below the median)
lost fraction :math:`k/n`      Wilson's score interval
converged RMSE                 RMSE of the runs within :math:`T`; normal interval on their mean square (bounded by
                               :math:`T^2`, so the central limit holds at a few hundred runs)
final RMSE                     mean square split into the converged part (normal) and the lost part, a weighted
                               Poisson sum (Fay and Feuer's gamma interval); **not estimable** below
                               :data:`MIN_LOST_FOR_RMSE` lost runs
median NEES                    order statistics, against :math:`\chi^2_d` median (1.39 for :math:`d = 2`)
=============================  ======================================================================================

Why the final RMSE is "not estimable" with few lost runs: :math:`\mathrm{RMSE}^2 = (1-p)\,\mu_c + p\,\mu_\ell`,
and with :math:`p` of 0.1-1 % the lost part is :math:`k \approx np` runs whose squared errors span four decades. A
study with no lost run cannot tell :math:`p = 0` from :math:`p = 0.3\,\%`, nor a study with two lost runs at 60 m
from a population whose lost runs reach 5 km; no interval computed from such a study keeps its coverage (the
percentile bootstrap covers the true RMSE in 28-75 % of simulated studies at :math:`p` = 0.1-1 %). Below
:data:`MIN_LOST_FOR_RMSE` lost runs the module therefore reports the events instead -- their count and Wilson
interval -- and the RMSE without them (the converged RMSE), which is estimable.

A **paired** comparison of two methods uses the same runs (common random numbers, as
:func:`uwtutor.montecarlo.compare` draws them): the difference of the medians (percentile bootstrap over the runs,
resampled in pairs), of the lost fractions (Newcombe's interval for paired proportions) and of the converged RMSEs
over the runs both methods kept (delta method). :func:`rank` orders methods by one criterion only where the paired
interval excludes zero, and calls the rest a tie; :func:`lost_verdict` says whether a lost fraction is clearly
below, clearly above or undecided against a limit (5 % in chapter 10).

References
----------
Wilson, E. B. (1927). Probable inference, the law of succession, and statistical inference. *JASA* 22, 209-212.
Brown, L. D., Cai, T. T. and DasGupta, A. (2001). Interval estimation for a binomial proportion. *Statistical
Science* 16, 101-133.
Newcombe, R. G. (1998). Improved confidence intervals for the difference between binomial proportions based on
paired data. *Statistics in Medicine* 17, 2635-2650 (method 10).
Fay, M. P. and Feuer, E. J. (1997). Confidence intervals for directly standardized rates: a method based on the
gamma distribution. *Statistics in Medicine* 16, 791-801.
David, H. A. and Nagaraja, H. N. (2003). *Order Statistics*, 3rd ed. Wiley. Section 7.1 (distribution-free
intervals for quantiles).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from scipy import stats

from ._validate import as_float_array, as_int, as_scalar

__all__ = ["LOST_THRESHOLD", "MIN_LOST_FOR_RMSE", "LOST_LIMIT", "Interval", "wilson_interval", "median_interval",
           "lost_fraction_interval", "converged_rmse_interval", "final_rmse_interval", "median_nees_interval",
           "CellStatistics", "cell_statistics", "PairedComparison", "paired_comparison", "Ranking", "rank",
           "lost_verdict"]

#: Final error [m] above which a run is lost (the divergence threshold of :func:`uwtutor.montecarlo.compare`).
LOST_THRESHOLD = 50.0
#: Fewest lost runs for which :func:`final_rmse_interval` gives an interval (below it: "not estimable"). Chosen by
#: the coverage simulation of ``tests/test_statistics.py``: with 10 or more lost runs the interval covers the true
#: RMSE in at least 93 % of the simulated studies whose lost errors spread from 50 m to 5 km.
MIN_LOST_FOR_RMSE = 10
#: Unseen events of the largest observed weight added to the upper end of the lost part's gamma interval. Fay and
#: Feuer add one, for weights known in advance; a lost run's weight (its squared error) is itself random and spreads
#: over four decades, and with one the interval covers 92.8-94.6 % of simulated studies at 1 % lost; with 1.5 it
#: covers 95-96 % (``studies/interval_coverage.py``).
UNSEEN_EVENTS = 1.5
#: The lost fraction chapter 10's advice accepts.
LOST_LIMIT = 0.05
#: Bootstrap resamples of the paired median difference.
N_BOOTSTRAP = 2000


# ---------------------------------------------------------------------------------------------------------------------
# the interval object
# ---------------------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Interval:
    """An estimate with its interval, or the reason there is none.

    Attributes
    ----------
    estimate : float
        The point estimate (NaN if there is none).
    lower : float
        The interval (NaN when not estimable).
    upper : float
        The interval (NaN when not estimable).
    method : str
        How the interval was computed (e.g. ``"Wilson"``).
    reason : str
        Empty when estimable; otherwise why the interval is not given.

    Examples
    --------
    >>> from uwtutor.statistics import Interval
    >>> iv = Interval(-0.06, -0.22, 0.07, "paired bootstrap")
    >>> iv.estimable, iv.excludes(0.0), str(iv)
    (True, False, '-0.06 [-0.22, 0.07]')
    """

    estimate: float
    lower: float
    upper: float
    method: str
    reason: str = ""

    @property
    def estimable(self) -> bool:
        """Whether the interval is given (finite or with an infinite end, but not NaN)."""
        return not self.reason and not (np.isnan(self.lower) or np.isnan(self.upper))

    def excludes(self, value: float = 0.0) -> bool:
        """Whether the interval is given and lies entirely on one side of ``value``."""
        return self.estimable and (self.lower > value or self.upper < value)

    def format(self, fmt: str = ".2f", scale: float = 1.0) -> str:
        """``"estimate [lower, upper]"`` with ``fmt`` (values times ``scale``), or the estimate and "not estimable"."""
        if not self.estimable:
            return f"{self.estimate * scale:{fmt}} (interval not estimable)"
        return f"{self.estimate * scale:{fmt}} [{self.lower * scale:{fmt}}, {self.upper * scale:{fmt}}]"

    def __str__(self) -> str:
        return self.format()


def _not_estimable(estimate: float, method: str, reason: str) -> Interval:
    return Interval(float(estimate), np.nan, np.nan, method, reason)


# ---------------------------------------------------------------------------------------------------------------------
# vectorized kernels (the last axis is the runs): what the public functions and the coverage test call
# ---------------------------------------------------------------------------------------------------------------------
def _alpha(confidence: Any) -> float:
    return 1.0 - as_scalar("confidence", confidence, domain="probability")


def _wilson(k: Any, n: Any, alpha: float) -> tuple[np.ndarray, np.ndarray]:
    r"""Wilson's score interval of :math:`k/n`, elementwise (lower end at most the exact one)."""
    k, n = np.asarray(k, dtype=float), np.asarray(n, dtype=float)
    z = stats.norm.ppf(1.0 - alpha / 2.0)
    p = k / n
    centre = (p + z**2 / (2 * n)) / (1 + z**2 / n)
    half = z / (1 + z**2 / n) * np.sqrt(p * (1 - p) / n + z**2 / (4 * n**2))
    # Wilson's lower end is too high for a handful of events (k = 3 of 1000 excludes p = 0.1 %: coverage 92 %;
    # Brown, Cai and DasGupta 2001): it is never taken above the exact (Clopper-Pearson) lower end
    with np.errstate(invalid="ignore"):
        exact_lower = np.where(k > 0, stats.beta.ppf(alpha / 2.0, np.maximum(k, 1), n - k + 1), 0.0)
    return np.clip(np.minimum(centre - half, exact_lower), 0.0, 1.0), np.clip(centre + half, 0.0, 1.0)


def _median_rank(n: int, alpha: float) -> int:
    """The 1-based rank ``l`` of the lower end of the distribution-free median interval ``[x_(l), x_(n-l+1)]``
    (0 when ``n`` is too small for any)."""
    return int(stats.binom.ppf(alpha / 2.0, n, 0.5))


def _median_bounds(values: np.ndarray, alpha: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Median and its order-statistic interval over the last axis (NaN-free input; +inf allowed)."""
    n = values.shape[-1]
    xs = np.sort(values, axis=-1)
    med = np.median(xs, axis=-1)
    rank = _median_rank(n, alpha)
    if rank < 1:
        nan = np.full(med.shape, np.nan)
        return med, nan, nan
    return med, xs[..., rank - 1], xs[..., n - rank]


def _converged_rmse_bounds(errors: np.ndarray, threshold: float, alpha: float
                           ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(estimate, lower, upper, n_converged) of the RMSE of the runs within ``threshold``, over the last axis."""
    kept = errors <= threshold
    n_c = kept.sum(axis=-1)
    sq = np.where(kept, errors, 0.0) ** 2
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = sq.sum(axis=-1) / n_c
        var = (np.where(kept, (sq - mean[..., None]) ** 2, 0.0)).sum(axis=-1) / (n_c - 1)
        half = stats.norm.ppf(1.0 - alpha / 2.0) * np.sqrt(var / n_c)
    return np.sqrt(mean), np.sqrt(np.maximum(mean - half, 0.0)), np.sqrt(mean + half), n_c


def _final_rmse_bounds(errors: np.ndarray, threshold: float, alpha: float
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    r"""(RMSE, lower, upper, n_lost) over the last axis; the interval is NaN below ``MIN_LOST_FOR_RMSE`` lost runs
    and where an error is infinite.

    :math:`\mathrm{MSE} = A + B`, :math:`A = \frac1n\sum_{e_j \le T} e_j^2` (normal interval at level
    :math:`\alpha/2`) and :math:`B = \sum_{e_j > T} w_j`, :math:`w_j = e_j^2/n`, a weighted sum of rare events:
    Fay and Feuer's gamma interval at level :math:`\alpha/2` (:math:`y = \sum w`, :math:`v = \sum w^2`,
    :math:`w_M = \max w`, :math:`u` = ``UNSEEN_EVENTS``; lower :math:`G^{-1}(\alpha/4;\, y^2/v,\, v/y)`, upper
    :math:`G^{-1}(1-\alpha/4;\, (y+u w_M)^2/(v+u w_M^2),\, (v+u w_M^2)/(y+u w_M))`). The two ends add
    (Bonferroni).
    """
    n = errors.shape[-1]
    lost = ~(errors <= threshold)
    n_lost = lost.sum(axis=-1)
    with np.errstate(invalid="ignore", over="ignore"):
        rmse = np.sqrt(np.mean(errors**2, axis=-1))
        conv = np.where(lost, 0.0, errors) ** 2
        A = conv.mean(axis=-1)
        sA = conv.std(axis=-1, ddof=1) / np.sqrt(n)
        w = np.where(lost, errors, 0.0) ** 2 / n
        y, v, wM = w.sum(axis=-1), (w**2).sum(axis=-1), w.max(axis=-1)
        ok = (n_lost >= MIN_LOST_FOR_RMSE) & np.isfinite(y) & (v > 0)
        ys, vs, wMs = np.where(ok, y, 1.0), np.where(ok, v, 1.0), np.where(ok, wM, 1.0)
        z = stats.norm.ppf(1.0 - alpha / 4.0)
        B_lo = stats.gamma.ppf(alpha / 4.0, ys**2 / vs, scale=vs / ys)
        xw = UNSEEN_EVENTS * wMs
        B_hi = stats.gamma.ppf(1.0 - alpha / 4.0, (ys + xw) ** 2 / (vs + UNSEEN_EVENTS * wMs**2),
                               scale=(vs + UNSEEN_EVENTS * wMs**2) / (ys + xw))
        lower = np.where(ok, np.sqrt(np.maximum(A - z * sA, 0.0) + B_lo), np.nan)
        upper = np.where(ok, np.sqrt(A + z * sA + B_hi), np.nan)
    return rmse, lower, upper, n_lost


def _newcombe_paired(b: ArrayLike, c: ArrayLike, a: ArrayLike, d: ArrayLike, alpha: float
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""Newcombe's method 10 for :math:`p_1 - p_2` of paired proportions: ``a`` both, ``b`` only the first,
    ``c`` only the second, ``d`` neither."""
    a, b, c, d = (np.asarray(t, dtype=float) for t in (a, b, c, d))
    n = a + b + c + d
    p1, p2 = (a + b) / n, (a + c) / n
    l1, u1 = _wilson(a + b, n, alpha)
    l2, u2 = _wilson(a + c, n, alpha)
    den = (a + b) * (c + d) * (a + c) * (b + d)
    with np.errstate(invalid="ignore", divide="ignore"):
        phi = np.where(den > 0, (a * d - b * c) / np.sqrt(np.where(den > 0, den, 1.0)), 0.0)
    delta = np.sqrt(np.maximum((p1 - l1) ** 2 - 2 * phi * (p1 - l1) * (u2 - p2) + (u2 - p2) ** 2, 0.0))
    eps = np.sqrt(np.maximum((u1 - p1) ** 2 - 2 * phi * (u1 - p1) * (p2 - l2) + (p2 - l2) ** 2, 0.0))
    diff = p1 - p2
    return diff, diff - delta, diff + eps


def _as_errors(name: str, value: Any) -> np.ndarray:
    """Final errors, one per run (>= 0): NaN (an estimate that diverged to NaN) becomes +inf, a lost run."""
    e = as_float_array(name, value, ndim=1)
    if e.size < 2:
        raise ValueError(f"{name} must hold the final errors of at least 2 runs; got {e.size}")
    if np.any(e < 0):
        raise ValueError(f"{name} must be error norms (>= 0); got {float(e[e < 0][0])} at index "
                         f"{int(np.flatnonzero(e < 0)[0])}")
    return np.where(np.isnan(e), np.inf, e)


def _as_threshold(threshold: Any) -> float:
    return as_scalar("threshold", threshold, domain="positive", high=1e150)


# ---------------------------------------------------------------------------------------------------------------------
# one statistic, one interval
# ---------------------------------------------------------------------------------------------------------------------
def wilson_interval(k: int, n: int, confidence: float = 0.95) -> Interval:
    r"""Wilson's score interval of a proportion :math:`k/n`.

    .. math::

        \frac{\hat p + z^2/2n \pm z\sqrt{\hat p(1-\hat p)/n + z^2/4n^2}}{1 + z^2/n}, \qquad z = \Phi^{-1}(1-\alpha/2).

    It keeps its coverage near :math:`k = 0` and :math:`k = n`, where the normal (Wald) interval collapses. Its
    lower end is never above the exact (Clopper-Pearson) one: for a handful of events Wilson's lower end is too high
    (Brown, Cai and DasGupta 2001) and, at 0.1 % of 1000 runs, would cover in 92 % of studies only.

    Examples
    --------
    Two lost runs of 1000:

    >>> from uwtutor.statistics import wilson_interval
    >>> wilson_interval(2, 1000).format(".2f", scale=100)
    '0.20 [0.02, 0.73]'
    """
    n = as_int("n", n, minimum=1)
    k = as_int("k", k, minimum=0, maximum=n)
    lo, hi = _wilson(k, n, _alpha(confidence))
    return Interval(k / n, float(lo), float(hi), "Wilson")


def lost_fraction_interval(errors: ArrayLike, threshold: float = LOST_THRESHOLD, confidence: float = 0.95) -> Interval:
    """The fraction of runs lost (final error above ``threshold``, or NaN), with Wilson's interval.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.statistics import lost_fraction_interval
    >>> e = np.r_[np.full(995, 3.0), np.full(5, 400.0)]
    >>> lost_fraction_interval(e).format(".1f", scale=100)
    '0.5 [0.2, 1.2]'
    """
    e = _as_errors("errors", errors)
    thr = _as_threshold(threshold)
    return wilson_interval(int(np.sum(~(e <= thr))), e.size, confidence)


def median_interval(values: ArrayLike, confidence: float = 0.95) -> Interval:
    r"""The median of a sample with its distribution-free interval :math:`[x_{(l)}, x_{(n-l+1)}]`.

    :math:`l` is the largest rank with :math:`P(\mathrm{Bin}(n, \tfrac12) < l) \le \alpha/2`: the interval holds
    the population median with probability at least ``confidence`` whatever the distribution (continuous), lost
    runs included (a NaN counts as +inf, the worst).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.statistics import median_interval
    >>> x = np.random.default_rng(0).exponential(1.0, 1000)
    >>> iv = median_interval(x)
    >>> iv.method, bool(iv.lower < np.log(2) < iv.upper)
    ('order statistics', True)
    """
    x = as_float_array("values", values, ndim=1)
    if x.size == 0:
        raise ValueError("values must hold at least one value")
    x = np.where(np.isnan(x), np.inf, x)
    med, lo, hi = _median_bounds(x, _alpha(confidence))
    if np.isnan(lo):
        return _not_estimable(float(med), "order statistics", f"{x.size} values are too few for an interval at "
                                                              f"{1 - _alpha(confidence):.0%}")
    return Interval(float(med), float(lo), float(hi), "order statistics")


def converged_rmse_interval(errors: ArrayLike, threshold: float = LOST_THRESHOLD, confidence: float = 0.95) -> Interval:
    r"""The RMSE of the runs within ``threshold`` (the converged runs), with a normal interval on their mean square.

    The squared errors of the converged runs are bounded by :math:`T^2`, so their mean is normal to a good
    approximation at a few hundred runs; the interval is :math:`\sqrt{\bar s \pm z\, s_s/\sqrt{n_c}}`.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.statistics import converged_rmse_interval
    >>> rng = np.random.default_rng(1)
    >>> e = np.r_[np.hypot(*rng.normal(0.0, 3.0, (2, 998))), 400.0, 900.0]
    >>> iv = converged_rmse_interval(e)
    >>> bool(iv.lower < 3.0 * np.sqrt(2) < iv.upper)
    True
    """
    e = _as_errors("errors", errors)
    thr = _as_threshold(threshold)
    est, lo, hi, n_c = _converged_rmse_bounds(e, thr, _alpha(confidence))
    if n_c < 2:
        return _not_estimable(float(est), "normal", f"{int(n_c)} converged runs: too few")
    return Interval(float(est), float(lo), float(hi), "normal")


def final_rmse_interval(errors: ArrayLike, threshold: float = LOST_THRESHOLD, confidence: float = 0.95) -> Interval:
    r"""The final RMSE over all the runs, with an interval that survives a few lost runs -- or the reason it is not
    estimable.

    The mean square is split into the converged part (runs within ``threshold``; a normal interval) and the lost
    part, a sum of rare events with weights :math:`e_j^2/n` (Fay and Feuer's gamma interval for a weighted Poisson
    sum); each at level :math:`\alpha/2`, their ends added. With fewer than :data:`MIN_LOST_FOR_RMSE` lost runs (none
    included: a study cannot tell no loss from a loss of a few per thousand) the RMSE rests on too few events and no
    interval keeps its coverage: it is reported "not estimable", with the count of lost runs; quote the lost
    fraction and the converged RMSE instead.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.statistics import final_rmse_interval
    >>> rng = np.random.default_rng(2)
    >>> ok = np.hypot(*rng.normal(0.0, 3.0, (2, 1000)))
    >>> two_lost = np.r_[ok[:998], 300.0, 700.0]
    >>> final_rmse_interval(two_lost).reason
    'rests on 2 lost runs of 1000 (fewer than 10): quote the lost fraction and the converged RMSE'
    >>> many = np.r_[ok[:980], rng.uniform(60.0, 600.0, 20)]
    >>> iv = final_rmse_interval(many)
    >>> iv.estimable, bool(iv.lower < iv.estimate < iv.upper)
    (True, True)
    """
    e = _as_errors("errors", errors)
    thr = _as_threshold(threshold)
    rmse, lo, hi, n_lost = _final_rmse_bounds(e, thr, _alpha(confidence))
    method = "converged normal + lost gamma (Fay-Feuer)"
    if not np.isfinite(rmse):
        return _not_estimable(float(rmse), method, "a run's estimate is NaN or infinite: the RMSE is infinite")
    if n_lost < MIN_LOST_FOR_RMSE:
        return _not_estimable(float(rmse), method,
                              f"rests on {int(n_lost)} lost runs of {e.size} (fewer than {MIN_LOST_FOR_RMSE}): quote "
                              "the lost fraction and the converged RMSE")
    return Interval(float(rmse), float(lo), float(hi), method)


def median_nees_interval(nees: ArrayLike, dof: int = 2, confidence: float = 0.95) -> tuple[Interval, float]:
    r"""The median of the final NEES over the runs, with its order-statistic interval, and its reference: the median
    of :math:`\chi^2_d`, ``scipy.stats.chi2.median(dof)`` (1.39 for ``dof = 2``, :math:`2\ln 2`).

    A consistent filter's median NEES is near the reference; above it the filter is overconfident, below it
    cautious. A NaN NEES (a covariance that is not positive definite) counts as +inf; a sample of NaN only (a
    method with no covariance) is not estimable.

    Returns
    -------
    interval : Interval
    reference : float

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.statistics import median_nees_interval
    >>> eps = np.random.default_rng(3).chisquare(2, 1000)
    >>> iv, ref = median_nees_interval(eps)
    >>> round(ref, 2), bool(iv.lower < ref < iv.upper)
    (1.39, True)
    """
    x = as_float_array("nees", nees, ndim=1)
    if x.size == 0:
        raise ValueError("nees must hold the NEES of at least one run (NaN for a run without a covariance); got none")
    if np.isinf(x).any():
        raise ValueError(f"nees must be finite, or NaN for a run without a covariance; got {float(x[np.isinf(x)][0])} "
                         f"at index {int(np.flatnonzero(np.isinf(x))[0])}")
    if np.any(x < 0):
        raise ValueError(f"nees must be >= 0 (a NEES is a quadratic form); got {float(x[x < 0][0])} at index "
                         f"{int(np.flatnonzero(x < 0)[0])}")
    dof = as_int("dof", dof, minimum=1)
    ref = float(stats.chi2.median(dof))
    if np.isnan(x).all():
        return _not_estimable(np.nan, "order statistics", "no covariance: no NEES"), ref
    return median_interval(x, confidence), ref


# ---------------------------------------------------------------------------------------------------------------------
# a cell of a study
# ---------------------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class CellStatistics:
    """The numbers of one cell (method x scenario x condition) of a study, each with its interval.

    Attributes
    ----------
    n_runs : int
    n_lost : int
        Runs whose final error is above ``threshold`` (or NaN).
    threshold : float
    final_rmse : Interval
    median_final_error : Interval
    converged_rmse : Interval
    lost_fraction : Interval
    median_nees : Interval
    nees_reference : float
        The :math:`\\chi^2_d` median the median NEES is compared with.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.statistics import cell_statistics
    >>> rng = np.random.default_rng(4)
    >>> e = np.r_[np.hypot(*rng.normal(0.0, 3.0, (2, 997))), 80.0, 300.0, 900.0]
    >>> cell = cell_statistics(e)
    >>> cell.n_lost, cell.final_rmse.estimable, cell.lost_fraction.format(".1f", 100)
    (3, False, '0.3 [0.1, 0.9]')
    """

    n_runs: int
    n_lost: int
    threshold: float
    final_rmse: Interval
    median_final_error: Interval
    converged_rmse: Interval
    lost_fraction: Interval
    median_nees: Interval
    nees_reference: float

    def as_columns(self) -> dict[str, float]:
        """The numbers as the columns of :class:`uwtutor.montecarlo.ComparisonTable` (``*_lower``/``*_upper``)."""
        out: dict[str, float] = {}
        for name, iv in (("final_rmse", self.final_rmse), ("median_final_error", self.median_final_error),
                         ("converged_rmse", self.converged_rmse), ("divergence_fraction", self.lost_fraction),
                         ("median_nees", self.median_nees)):
            if name in ("converged_rmse", "median_nees"):
                out[name] = iv.estimate
            out[f"{name}_lower"] = iv.lower
            out[f"{name}_upper"] = iv.upper
        out["n_lost"] = float(self.n_lost)
        out["nees_median_reference"] = self.nees_reference
        return out


def cell_statistics(final_errors: ArrayLike, final_nees: ArrayLike | None = None, *, dof: int = 2,
                    threshold: float = LOST_THRESHOLD, confidence: float = 0.95) -> CellStatistics:
    """Every number of a cell with its interval, from the runs' final errors (and final NEES).

    Parameters
    ----------
    final_errors : array_like, shape (n,)
        Final position error of every run [m] (NaN or +inf: the estimate diverged, a lost run).
    final_nees : array_like, shape (n,), optional
        Final NEES of every run (NaN: no covariance). ``None``: no NEES.
    dof : int, default 2
        Degrees of freedom of the NEES (the scored components).
    threshold : float, default ``LOST_THRESHOLD``
        Final error [m] above which a run is lost.
    confidence : float, default 0.95

    Returns
    -------
    CellStatistics

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.statistics import cell_statistics
    >>> rng = np.random.default_rng(5)
    >>> e = np.hypot(*rng.normal(0.0, 2.0, (2, 500)))
    >>> c = cell_statistics(e, rng.chisquare(2, 500))
    >>> c.n_lost, c.median_nees.estimable, round(c.nees_reference, 2)
    (0, True, 1.39)
    """
    e = _as_errors("final_errors", final_errors)
    thr = _as_threshold(threshold)
    if final_nees is None:
        nees_iv, ref = _not_estimable(np.nan, "order statistics", "no NEES given"), float(stats.chi2.median(dof))
    else:
        nees = as_float_array("final_nees", final_nees, ndim=1)
        if nees.size != e.size:
            raise ValueError(f"final_nees must hold one value per run ({e.size}); got {nees.size}")
        nees_iv, ref = median_nees_interval(nees, dof, confidence)
    lost = lost_fraction_interval(e, thr, confidence)
    return CellStatistics(n_runs=e.size, n_lost=int(np.sum(~(e <= thr))), threshold=thr,
                          final_rmse=final_rmse_interval(e, thr, confidence),
                          median_final_error=median_interval(e, confidence),
                          converged_rmse=converged_rmse_interval(e, thr, confidence), lost_fraction=lost,
                          median_nees=nees_iv, nees_reference=ref)


# ---------------------------------------------------------------------------------------------------------------------
# two methods on the same runs
# ---------------------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PairedComparison:
    """Method ``a`` minus method ``b`` on the same runs (negative: ``a`` is better).

    Attributes
    ----------
    a : str
        The two methods' names.
    b : str
        The two methods' names.
    n_runs : int
    median_difference : Interval
        :math:`\\operatorname{med} e^a - \\operatorname{med} e^b` [m], paired percentile bootstrap.
    lost_difference : Interval
        Difference of the lost fractions, Newcombe's paired interval.
    converged_rmse_difference : Interval
        Difference of the RMSEs over the runs both kept (within the threshold) [m], delta method.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.statistics import paired_comparison
    >>> rng = np.random.default_rng(6)
    >>> common = np.hypot(*rng.normal(0.0, 3.0, (2, 1000)))
    >>> pc = paired_comparison(common, 1.2 * common, names=("EKF", "SFEKF"))
    >>> pc.verdict("median")
    'EKF below SFEKF'
    >>> pc.verdict("lost")
    'tie'
    """

    a: str
    b: str
    n_runs: int
    median_difference: Interval
    lost_difference: Interval
    converged_rmse_difference: Interval

    def interval(self, criterion: str) -> Interval:
        """The interval of ``criterion``: ``"median"``, ``"lost"`` or ``"converged_rmse"``."""
        try:
            return {"median": self.median_difference, "lost": self.lost_difference,
                    "converged_rmse": self.converged_rmse_difference}[criterion]
        except KeyError:
            raise ValueError(f"criterion must be 'median', 'lost' or 'converged_rmse'; got {criterion!r}") from None

    def verdict(self, criterion: str) -> str:
        """``"a below b"``, ``"a above b"`` (lower is better for every criterion), or ``"tie"``."""
        iv = self.interval(criterion)
        if iv.excludes(0.0):
            return f"{self.a} below {self.b}" if iv.upper < 0 else f"{self.a} above {self.b}"
        return "tie"


def paired_comparison(errors_a: ArrayLike, errors_b: ArrayLike, *, names: tuple[str, str] = ("a", "b"),
                      threshold: float = LOST_THRESHOLD, confidence: float = 0.95, seed: int = 0,
                      n_bootstrap: int = N_BOOTSTRAP) -> PairedComparison:
    r"""Compare two methods on the same runs: ``errors_a[j]`` and ``errors_b[j]`` are their final errors on run ``j``.

    * **median**: :math:`\operatorname{med} e^a - \operatorname{med} e^b`, percentile bootstrap over the runs
      resampled in pairs (``n_bootstrap`` resamples from ``default_rng(seed)``; lost runs count as +inf);
    * **lost fraction**: :math:`(b - c)/n` with :math:`b` the runs only ``a`` lost, :math:`c` those only ``b`` lost,
      Newcombe's interval (method 10), which uses the pairing through the correlation of the two losses;
    * **converged RMSE**: :math:`\sqrt{\bar s_a} - \sqrt{\bar s_b}` over the runs both kept, with the delta-method
      variance :math:`g^\mathsf T \Sigma g / n_c`, :math:`g = (1/2\sqrt{\bar s_a}, -1/2\sqrt{\bar s_b})`,
      :math:`\Sigma` the covariance of the paired squared errors.

    Parameters
    ----------
    errors_a, errors_b : array_like, shape (n,)
        Final errors of the two methods on the same ``n`` runs [m].
    names : pair of str
        Their names, for the verdicts.
    threshold : float, default ``LOST_THRESHOLD``
    confidence : float, default 0.95
    seed : int, default 0
        Seed of the bootstrap's generator (the result is reproducible).
    n_bootstrap : int, default ``N_BOOTSTRAP``

    Returns
    -------
    PairedComparison

    Examples
    --------
    Two methods that differ by less than their noise on the same runs are tied:

    >>> import numpy as np
    >>> from uwtutor.statistics import paired_comparison
    >>> rng = np.random.default_rng(7)
    >>> common = np.hypot(*rng.normal(0.0, 3.0, (2, 1000)))
    >>> a = common + rng.normal(0.0, 0.5, 1000).clip(-1, 1)
    >>> b = common + rng.normal(0.0, 0.5, 1000).clip(-1, 1)
    >>> pc = paired_comparison(np.abs(a), np.abs(b), names=("EKF", "ISFEKF"))
    >>> pc.verdict("median"), pc.median_difference.excludes(0.0)
    ('tie', False)
    """
    ea = _as_errors("errors_a", errors_a)
    eb = _as_errors("errors_b", errors_b)
    if ea.size != eb.size:
        raise ValueError(f"errors_a and errors_b must hold the same runs (paired); got {ea.size} and {eb.size} runs")
    if not (isinstance(names, tuple) and len(names) == 2 and all(isinstance(s, str) for s in names)):
        raise TypeError(f"names must be a pair of str; got {names!r}")
    thr = _as_threshold(threshold)
    alpha = _alpha(confidence)
    seed = as_int("seed", seed, minimum=0)
    n_boot = as_int("n_bootstrap", n_bootstrap, minimum=100, maximum=10**5)
    n = ea.size
    med = _paired_median_difference(ea, eb, alpha, np.random.default_rng(seed), n_boot)
    la, lb = ~(ea <= thr), ~(eb <= thr)
    diff, lo, hi = _newcombe_paired(np.sum(la & ~lb), np.sum(~la & lb), np.sum(la & lb), np.sum(~la & ~lb), alpha)
    lost = Interval(float(diff), float(lo), float(hi), "Newcombe paired")
    conv = _paired_converged_difference(ea, eb, thr, alpha)
    return PairedComparison(names[0], names[1], n, med, lost, conv)


def _paired_median_difference(ea: np.ndarray, eb: np.ndarray, alpha: float, rng: np.random.Generator,
                              n_boot: int) -> Interval:
    method = "paired percentile bootstrap"
    est = float(np.median(ea) - np.median(eb)) if np.isfinite(np.median(ea)) or np.isfinite(np.median(eb)) \
        else np.nan
    if not np.isfinite(est):
        return _not_estimable(est, method, "a median is infinite: half the runs or more are lost")
    n = ea.size
    diffs = np.empty(n_boot)
    for start in range(0, n_boot, 200):                  # 200 resamples at a time: memory n x 200
        idx = rng.integers(0, n, (min(200, n_boot - start), n))
        with np.errstate(invalid="ignore"):
            diffs[start:start + len(idx)] = np.median(ea[idx], axis=1) - np.median(eb[idx], axis=1)
    diffs = np.where(np.isnan(diffs), np.inf, diffs)     # inf - inf: both medians lost in that resample
    ds = np.sort(diffs)
    lo = ds[int(np.floor(alpha / 2 * (n_boot - 1)))]
    hi = ds[int(np.ceil((1 - alpha / 2) * (n_boot - 1)))]
    return Interval(est, float(lo), float(hi), method)


def _paired_converged_difference(ea: np.ndarray, eb: np.ndarray, thr: float, alpha: float) -> Interval:
    method = "delta method over the runs both kept"
    both = (ea <= thr) & (eb <= thr)
    n_c = int(both.sum())
    if n_c < 10:
        return _not_estimable(np.nan, method, f"{n_c} runs kept by both methods: too few")
    sa, sb = ea[both] ** 2, eb[both] ** 2
    ma, mb = sa.mean(), sb.mean()
    d = float(np.sqrt(ma) - np.sqrt(mb))
    if ma == 0 or mb == 0:
        return _not_estimable(d, method, "a converged RMSE is zero")
    cov = np.cov(np.vstack([sa, sb]))
    g = np.array([0.5 / np.sqrt(ma), -0.5 / np.sqrt(mb)])
    half = stats.norm.ppf(1 - alpha / 2) * np.sqrt(max(float(g @ cov @ g), 0.0) / n_c)
    return Interval(d, float(d - half), float(d + half), method)


# ---------------------------------------------------------------------------------------------------------------------
# rankings that refuse ties
# ---------------------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Ranking:
    """Methods of one cell ordered by a criterion, where the paired intervals allow it.

    Attributes
    ----------
    criterion : str
        ``"median"``, ``"lost"`` or ``"converged_rmse"``.
    order : tuple of str
        The methods by their point estimate, best first.
    estimates : dict
        Each method's point estimate of the criterion.
    best : tuple of str
        The leader and every method tied with it (paired interval containing zero).
    comparisons : dict
        ``(a, b) -> PairedComparison`` for the pairs compared so far (``a`` before ``b`` in ``order``): the leader with
        every other method and each method with the next; any other pair is compared when asked
        (:meth:`relation`, :meth:`interval`).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.statistics import rank
    >>> rng = np.random.default_rng(8)
    >>> base = np.hypot(*rng.normal(0.0, 3.0, (2, 1000)))
    >>> # B: errors of the same law as A's; C: half again as large as A's
    >>> b = np.hypot(*rng.normal(0.0, 3.0, (2, 1000)))
    >>> r = rank({"A": base, "B": b, "C": base * 1.5}, "median")
    >>> r.best, r.relation("A", "C"), r.relation("A", "B")
    (('A', 'B'), 'below', 'tie')
    """

    criterion: str
    order: tuple[str, ...]
    estimates: dict[str, float]
    best: tuple[str, ...]
    comparisons: dict[tuple[str, str], PairedComparison] = field(repr=False)
    _compare: Any = field(default=None, repr=False, compare=False)

    def _pair(self, a: str, b: str) -> tuple[PairedComparison, float]:
        for key, sign in (((a, b), 1.0), ((b, a), -1.0)):
            if key in self.comparisons:
                return self.comparisons[key], sign
        if a not in self.order or b not in self.order or self._compare is None:
            raise KeyError(f"no comparison of {a!r} and {b!r} in this ranking (methods: {list(self.order)})")
        first, second = (a, b) if self.order.index(a) < self.order.index(b) else (b, a)
        self.comparisons[first, second] = self._compare(first, second)
        return self._pair(a, b)

    def relation(self, a: str, b: str) -> str:
        """``"below"`` (``a`` better), ``"above"`` or ``"tie"``, from the paired interval of ``a`` and ``b``."""
        iv = self.interval(a, b)
        if not iv.excludes(0.0):
            return "tie"
        return "below" if iv.upper < 0 else "above"

    def interval(self, a: str, b: str) -> Interval:
        """The paired interval of ``a`` minus ``b`` for the criterion."""
        pc, sign = self._pair(a, b)
        iv = pc.interval(self.criterion)
        if sign > 0:
            return iv
        return Interval(-iv.estimate, -iv.upper, -iv.lower, iv.method, iv.reason)


def rank(errors: dict[str, Any], criterion: str = "median", *, threshold: float = LOST_THRESHOLD,
         confidence: float = 0.95, seed: int = 0) -> Ranking:
    """Order the methods of one cell by ``criterion``, calling a tie every pair whose paired interval contains zero.

    Parameters
    ----------
    errors : dict of str to array_like
        ``method name -> final errors`` on the **same** runs.
    criterion : {"median", "lost", "converged_rmse"}
    threshold, confidence, seed
        As in :func:`paired_comparison`.

    Returns
    -------
    Ranking
        ``best`` holds the leader and the methods tied with it; ``relation(a, b)`` any pair's verdict.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.statistics import rank
    >>> rng = np.random.default_rng(9)
    >>> base = np.hypot(*rng.normal(0.0, 3.0, (2, 1000)))
    >>> rank({"EKF": base, "LS": 2 * base}, "median").best
    ('EKF',)
    """
    if not isinstance(errors, dict) or len(errors) < 1:
        raise TypeError(f"errors must be a non-empty dict method name -> final errors; got {type(errors).__name__}")
    if criterion not in ("median", "lost", "converged_rmse"):
        raise ValueError(f"criterion must be 'median', 'lost' or 'converged_rmse'; got {criterion!r}")
    thr = _as_threshold(threshold)
    arrays = {name: _as_errors(f"errors[{name!r}]", e) for name, e in errors.items()}
    sizes = {e.size for e in arrays.values()}
    if len(sizes) != 1:
        raise ValueError(f"every method's errors must hold the same runs; got sizes {sorted(sizes)}")
    point = {}
    for name, e in arrays.items():
        if criterion == "median":
            point[name] = float(np.median(e))
        elif criterion == "lost":
            point[name] = float(np.mean(~(e <= thr)))
        else:
            kept = e[e <= thr]
            point[name] = float(np.sqrt(np.mean(kept**2))) if kept.size else np.inf
    order = tuple(sorted(point, key=lambda m: (point[m], list(point).index(m))))

    def compare(a: str, b: str) -> PairedComparison:
        return paired_comparison(arrays[a], arrays[b], names=(a, b), threshold=thr, confidence=confidence, seed=seed)

    leader = order[0]
    pairs = [(leader, b) for b in order[1:]] + [(a, b) for a, b in zip(order[1:], order[2:])]
    comps = {pair: compare(*pair) for pair in pairs}
    best = (leader,) + tuple(b for b in order[1:] if not comps[leader, b].interval(criterion).excludes(0.0))
    return Ranking(criterion, order, point, best, comps, compare)


def lost_verdict(k: int, n: int, limit: float = LOST_LIMIT, confidence: float = 0.95) -> str:
    """Whether a lost fraction :math:`k/n` is ``"clearly below"``, ``"clearly above"`` or ``"undecided"`` against
    ``limit``, from its Wilson interval.

    Examples
    --------
    >>> from uwtutor.statistics import lost_verdict
    >>> lost_verdict(39, 1000), lost_verdict(20, 1000), lost_verdict(90, 1000)
    ('undecided', 'clearly below', 'clearly above')
    """
    limit = as_scalar("limit", limit, domain="probability")
    iv = wilson_interval(k, n, confidence)
    if iv.upper < limit:
        return "clearly below"
    if iv.lower > limit:
        return "clearly above"
    return "undecided"
