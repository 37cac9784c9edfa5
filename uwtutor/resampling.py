r"""Resampling schemes for particle filters, with an explicit random generator.

Resampling replaces ``N`` weighted particles by ``N`` equally weighted ones, drawing particle ``i`` a random number
of times :math:`N_i` with :math:`E[N_i] = N w_i` (unbiasedness). The four classic schemes differ in how they draw
the ``N`` points :math:`p_1 \dots p_N` in :math:`[0, 1)` that are looked up in the cumulative weights
:math:`c_i = \sum_{l \le i} w_l`: point :math:`p` selects the particle ``i`` with :math:`c_{i-1} \le p < c_i`.

=============  ==========================================================  ====================================
scheme         points                                                      variance of :math:`N_i`
=============  ==========================================================  ====================================
multinomial    :math:`p_j = U_j`, ``N`` independent uniforms               :math:`N w_i (1 - w_i)` (largest)
stratified     :math:`p_j = (j - 1 + U_j) / N`, one uniform per stratum    smaller than multinomial
systematic     :math:`p_j = (j - 1 + U) / N`, one uniform shared           smallest in practice, not always
residual       :math:`\lfloor N w_i \rfloor` copies, the rest multinomial  smaller than multinomial
=============  ==========================================================  ====================================

Douc and Cappé (2005) compare them: residual and stratified resampling provably have a smaller conditional variance
than multinomial resampling; systematic resampling is the cheapest and usually the best, though counter-examples
exist. All four are unbiased.

.. rubric:: Conventions of this module

* Randomness only through the ``rng`` argument, a ``numpy.random.Generator``. Given the same uniforms, each
  function returns exactly the indices of the classic algorithm as written in filterpy
  (``filterpy.monte_carlo``), which draws them from the global ``numpy.random`` state instead.
  ``tests/test_resampling.py`` checks this with a Generator that replays the seeded global state.
* ``weights`` must be finite and >= 0 with a positive sum. Weights whose sum is within ``WEIGHT_SUM_TOL``
  (1e-9) of one are used as they are (so the indices match the textbook algorithms bit for bit); other weights
  are divided by their sum first, so unnormalized weights are fine.
* Round-off guard: the cumulative sum is set to exactly 1 from the last positive weight on, so a point near 1 can
  never select a particle of zero weight or fall off the end.
* Vectorized over particles (``numpy.searchsorted`` on the cumulative weights, no Python loop over particles).
  A 2-D ``weights`` of shape ``(M, N)`` resamples ``M`` independent particle sets (e.g. Monte Carlo runs) and
  returns ``(M, N)`` indices; row ``m`` equals what the 1-D call would return on row ``m`` with the generator
  in the same state (the rows are processed in order).

References
----------
Douc, R. and Cappé, O. (2005). Comparison of resampling schemes for particle filtering. *Proc. 4th Int. Symp.
on Image and Signal Processing and Analysis (ISPA)*, 64-69.

Arulampalam, M. S., Maskell, S., Gordon, N. and Clapp, T. (2002). A tutorial on particle filters for online
nonlinear/non-Gaussian Bayesian tracking. *IEEE Trans. Signal Processing* 50(2), 174-188 (Algorithm 2).

Liu, J. S. and Chen, R. (1998). Sequential Monte Carlo methods for dynamic systems. *J. American Statistical
Association* 93(443), 1032-1044 (residual resampling).

Labbe, R. *FilterPy*, ``filterpy.monte_carlo.resampling``. Its ``residual_resample`` computes the residual as
``weights - num_copies`` instead of ``N * weights - num_copies`` (filterpy issue #290); the version here uses
the correct residual.
"""

from __future__ import annotations

import functools
from typing import Any, Callable

import numpy as np
from numpy.typing import ArrayLike

from ._validate import as_float_array, as_rng

__all__ = [
    "WEIGHT_SUM_TOL",
    "Resampler",
    "multinomial_resample",
    "systematic_resample",
    "stratified_resample",
    "residual_resample",
    "effective_sample_size",
]

#: Weights that sum to one within this tolerance are used without renormalizing.
WEIGHT_SUM_TOL = 1e-9

_HUGE = 1e300        # weights above this are rescaled before summing
_ZERO_SUM = ("weights must have a positive sum (at least one particle with weight > 0); all weights are zero -- "
             "check the likelihood (use log-weights to avoid underflow)")

# Signature of a resampler: (weights, rng) -> indices.
Resampler = Callable[[np.ndarray, np.random.Generator], np.ndarray]


def _check_weights(weights: Any) -> np.ndarray:
    """Validate weights (N,) or (M, N) and return them normalized along the last axis."""
    w = as_float_array("weights", weights, ndim=(1, 2))
    if w.shape[-1] == 0:
        raise ValueError("weights must hold at least one particle weight; got an empty array")
    if w.size == 0:
        raise ValueError(f"weights has no runs (shape {w.shape}): give at least one run, or drop the runs axis")
    top = np.maximum.reduce(w, axis=None)       # NaN if any weight is NaN
    if not (np.minimum.reduce(w, axis=None) >= 0.0 and top < _HUGE):    # also False for NaN and inf
        bad = ~np.isfinite(w) | (w < 0)
        if bad.any():
            idx = tuple(int(i) for i in np.argwhere(bad)[0])
            where = f"index {idx[0]}" if len(idx) == 1 else f"index {idx}"
            raise ValueError(f"weights must be finite and >= 0; got {w[idx]} at {where}")
        w = w / top                             # finite but huge: rescale so that the sum cannot overflow
    if w.ndim == 1:                             # the common case, with scalar arithmetic
        total = float(np.add.reduce(w))
        if total <= 0.0:
            raise ValueError(_ZERO_SUM)
        return w if abs(total - 1.0) <= WEIGHT_SUM_TOL else w / total
    total = w.sum(axis=-1, keepdims=True)
    if (total <= 0.0).any():
        raise ValueError(_ZERO_SUM)
    return w if np.abs(total - 1.0).max() <= WEIGHT_SUM_TOL else w / total


@functools.lru_cache(maxsize=16)
def _arange(N: int) -> np.ndarray:
    """A read-only ``0.0, 1.0, ..., N - 1`` (the strata of systematic and stratified resampling), cached."""
    a = np.arange(N, dtype=float)
    a.flags.writeable = False
    return a


def _strata(weights: Any, rng: Any, *, one_offset: bool) -> np.ndarray:
    """Indices drawn at the points ``(j + U_j)/N``, ``j = 0 .. N-1``: one point in each of ``N`` equal strata of
    ``[0, 1)``, with an independent uniform per stratum (stratified) or ``one_offset`` shared by all (systematic)."""
    w = _check_weights(weights)
    rng = as_rng(rng)
    N = w.shape[-1]
    if one_offset:
        offsets = rng.random(w.shape[:-1] + (1,))
        points = _arange(N) + (offsets if w.ndim == 2 else offsets[0])
    else:
        points = rng.random(w.shape)
        points += _arange(N)
    points /= N
    return _search(w, points)


def _cumulative(w: np.ndarray) -> np.ndarray:
    """Cumulative sum of normalized 1-D weights, exactly 1 from the last positive weight on."""
    c = np.add.accumulate(w)
    if w[-1] > 0.0:
        c[-1] = 1.0
    else:                                     # trailing zero weights: never select them
        c[w.size - 1 - int(np.argmax(w[::-1] > 0.0)):] = 1.0
    return c


def _search(w: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Index ``i`` with ``c[i-1] <= p < c[i]`` for every point, row by row for 2-D inputs."""
    if w.ndim == 1:
        return _cumulative(w).searchsorted(points, side="right")
    out = np.empty(points.shape, dtype=np.intp)
    for m in range(w.shape[0]):               # loop over particle sets, never over particles
        out[m] = _cumulative(w[m]).searchsorted(points[m], side="right")
    return out


def multinomial_resample(weights: ArrayLike, rng: np.random.Generator) -> np.ndarray:
    r"""Multinomial resampling: ``N`` independent draws from the weights.

    Draws :math:`U_j \sim U[0, 1)`, ``j = 1..N``, and selects the particle whose cumulative-weight interval
    holds each, so :math:`(N_1 \dots N_N) \sim \mathrm{Multinomial}(N; w_1 \dots w_N)`. Simple, unbiased, and
    the noisiest of the four schemes (Douc and Cappé 2005).

    Parameters
    ----------
    weights : array_like, shape (N,) or (M, N)
        Particle weights (finite, >= 0, positive sum; normalized here if needed).
    rng : numpy.random.Generator
        Source of the ``N`` uniforms (per row).

    Returns
    -------
    ndarray of int, shape (N,) or (M, N)
        Indices of the selected particles, in the order of the draws.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.resampling import multinomial_resample
    >>> idx = multinomial_resample([0.1, 0.0, 0.9], np.random.default_rng(0))
    >>> idx.shape, bool(1 in idx)
    ((3,), False)
    """
    w = _check_weights(weights)
    rng = as_rng(rng)
    return _search(w, rng.random(w.shape))


def stratified_resample(weights: Any, rng: np.random.Generator) -> np.ndarray:
    r"""Stratified resampling: one uniform draw in each of ``N`` equal strata of ``[0, 1)``.

    Points :math:`p_j = (j - 1 + U_j)/N` with independent :math:`U_j \sim U[0, 1)`; the sorted points give
    sorted indices. Unbiased, with a smaller variance than multinomial resampling (Douc and Cappé 2005).

    Parameters
    ----------
    weights : array_like, shape (N,) or (M, N)
        Particle weights (finite, >= 0, positive sum; normalized here if needed).
    rng : numpy.random.Generator
        Source of the ``N`` uniforms (per row).

    Returns
    -------
    ndarray of int, shape (N,) or (M, N)
        Indices of the selected particles, in increasing order.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.resampling import stratified_resample
    >>> stratified_resample([0.5, 0.25, 0.25, 0.0], np.random.default_rng(1))
    array([0, 0, 1, 2])
    """
    return _strata(weights, rng, one_offset=False)


def systematic_resample(weights: Any, rng: np.random.Generator) -> np.ndarray:
    r"""Systematic resampling: ``N`` evenly spaced points with one random offset.

    Points :math:`p_j = (j - 1 + U)/N` with a single :math:`U \sim U[0, 1)`, so particle ``i`` is drawn
    :math:`\lfloor N w_i \rfloor` or :math:`\lceil N w_i \rceil` times. The cheapest scheme (one uniform) and
    usually the least noisy; the default of :class:`uwtutor.filters.particle.bootstrap.BootstrapParticleFilter`
    (Arulampalam et al. 2002, Algorithm 2).

    Parameters
    ----------
    weights : array_like, shape (N,) or (M, N)
        Particle weights (finite, >= 0, positive sum; normalized here if needed).
    rng : numpy.random.Generator
        Source of the one uniform (per row).

    Returns
    -------
    ndarray of int, shape (N,) or (M, N)
        Indices of the selected particles, in increasing order.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.resampling import systematic_resample
    >>> systematic_resample([0.5, 0.25, 0.25, 0.0], np.random.default_rng(1))
    array([0, 0, 1, 2])
    """
    return _strata(weights, rng, one_offset=True)


def _residual_1d(w: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    N = w.size
    scaled = N * w
    copies = np.floor(scaled).astype(np.intp)
    deterministic = np.repeat(np.arange(N), copies)
    n_rest = N - deterministic.size
    if n_rest == 0:
        return deterministic
    rest = scaled - copies                    # fractional parts, sum = n_rest up to rounding
    rest /= rest.sum()
    return np.concatenate([deterministic, _search(rest, rng.random(n_rest))])


def residual_resample(weights: ArrayLike, rng: np.random.Generator) -> np.ndarray:
    r"""Residual resampling: :math:`\lfloor N w_i \rfloor` deterministic copies, the remainder multinomial.

    Each particle is first copied :math:`\lfloor N w_i \rfloor` times; the remaining
    :math:`R = N - \sum_i \lfloor N w_i \rfloor` draws are multinomial with the residual weights
    :math:`\bar w_i = (N w_i - \lfloor N w_i \rfloor)/R` (Liu and Chen 1998). Unbiased, with a smaller variance
    than multinomial resampling (Douc and Cappé 2005).

    Parameters
    ----------
    weights : array_like, shape (N,) or (M, N)
        Particle weights (finite, >= 0, positive sum; normalized here if needed).
    rng : numpy.random.Generator
        Source of the ``R`` uniforms (per row; none when every :math:`N w_i` is an integer).

    Returns
    -------
    ndarray of int, shape (N,) or (M, N)
        The deterministic copies in increasing order, then the ``R`` multinomial draws in draw order
        (the layout of filterpy's ``residual_resample``).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.resampling import residual_resample
    >>> # floor(4 w) = 2, 1, 0, 0 copies, then one multinomial draw from the residual weights
    >>> residual_resample([0.5, 0.3, 0.2, 0.0], np.random.default_rng(1))
    array([0, 0, 1, 2])
    """
    w = _check_weights(weights)
    rng = as_rng(rng)
    if w.ndim == 1:
        return _residual_1d(w, rng)
    return np.stack([_residual_1d(row, rng) for row in w])


def effective_sample_size(weights: ArrayLike) -> float | np.ndarray:
    r"""Effective sample size :math:`N_\mathrm{eff} = 1 / \sum_i w_i^2` of normalized weights.

    ``N`` for equal weights, 1 when a single particle holds all the weight (Arulampalam et al. 2002, eq. (51)).

    Parameters
    ----------
    weights : array_like, shape (N,) or (M, N)
        Particle weights (normalized here if needed).

    Returns
    -------
    float or ndarray of shape (M,)

    Examples
    --------
    >>> from uwtutor.resampling import effective_sample_size
    >>> effective_sample_size([0.25, 0.25, 0.25, 0.25])
    4.0
    >>> round(effective_sample_size([0.7, 0.1, 0.1, 0.1]), 3)
    1.923
    """
    w = _check_weights(weights)
    ess = 1.0 / np.sum(w * w, axis=-1)
    return float(ess) if w.ndim == 1 else ess
