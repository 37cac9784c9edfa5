"""Range least squares: linearized (paper A's pre-positioning on a track) and nonlinear (the reference)."""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .._linalg import line_of_sight as _line_of_sight
from .._validate import MAX_COORDINATE, as_flag, as_finite, as_int, as_scalar, common_runs
from ..errors import IllConditionedWarning
from ._common import (as_ranges_and_beacons, as_thresholds, batched_lstsq, sigma_and_cov, unit_los,
                     warn_conditioning)

#: Largest number of Gauss-Newton steps accepted by ``linearized_lsq`` (it converges in a handful).
MAX_ITERATIONS = 1000
#: The loop stops once no run's step exceeds this fraction of the problem's size (positions and ranges).
CONVERGED_RTOL = 1e-12


@dataclass(frozen=True)
class LSQFix:
    r"""A least-squares fix with its quality (returned by ``linearized_lsq``, ``prepositioning``,
    ``nonlinear_lsq``).

    Shapes: ``N`` ranges, ``p`` unknowns (2, or 3 with the bias), and a leading runs axis ``M`` when the inputs had
    one.

    Attributes
    ----------
    estimate : ndarray, shape (p,) or (M, p)
        The unknowns ``[x, y]`` or ``[x, y, bias]`` [m]; NaN where the problem is singular.
    position : ndarray, shape (2,) or (M, 2)
        The position part of ``estimate`` [m].
    bias : ndarray or None
        The range bias [m], shape () or (M,); ``None`` without ``unknown_bias``.
    covariance : ndarray, shape (p, p) or (M, p, p)
        :math:`\sigma^2 (A^\mathsf{T}A)^{-1}` [m²], with the given ``sigma`` or, if none was given, the residual
        estimate :math:`\hat\sigma^2 = \sum e_i^2 / (N - p)` (NaN when :math:`N = p`).
    sigma : ndarray
        The :math:`\sigma` used there [m], shape () or (M,).
    alpha : ndarray
        Precision factor :math:`\operatorname{tr}(A^\mathsf{T}A)^{-1}`, shape () or (M,).
    condition_number : ndarray
        :math:`\kappa(A)`, shape () or (M,).
    noise_gain : ndarray
        :math:`\sqrt\alpha`: RMS error of the unknowns per unit of white range noise, shape () or (M,).
    residuals : ndarray, shape (N,) or (M, N)
        Range residuals at the fix, :math:`r_i - \lVert\hat p - b_i\rVert - \hat\upsilon` [m].
    design : ndarray, shape (N, p) or (M, N, p)
        The design matrix :math:`A` of the last linearization.
    iterations : int
        Gauss-Newton steps taken (``linearized_lsq``) or function evaluations (``nonlinear_lsq``).
    well_conditioned : ndarray
        Boolean, shape () or (M,): :math:`\kappa \le` ``max_condition`` and noise gain :math:`\le`
        ``max_noise_gain``.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.lsq import linearized_lsq
    >>> beacons = np.array([[1000.0, 0.0], [0.0, 1000.0], [-1000.0, 0.0], [0.0, -1000.0]])
    >>> r = np.linalg.norm(np.array([30.0, -40.0]) - beacons, axis=1) + 5.0
    >>> fix = linearized_lsq(r, beacons, provisional=[10.0, -30.0], iterations=3)
    >>> fix.estimate.round(3), fix.covariance.shape, fix.iterations
    (array([ 30., -40.,   5.]), (3, 3), 3)
    >>> bool(fix.well_conditioned), bool(fix.trusted())
    (True, True)
    """

    estimate: np.ndarray
    position: np.ndarray
    bias: np.ndarray | None
    covariance: np.ndarray
    sigma: np.ndarray
    alpha: np.ndarray
    condition_number: np.ndarray
    noise_gain: np.ndarray
    residuals: np.ndarray
    design: np.ndarray
    iterations: int
    well_conditioned: np.ndarray

    def trusted(self, max_alpha: float = 2.0) -> np.ndarray:
        r"""Paper A's acceptance test :math:`\alpha <` ``max_alpha`` (2 in the paper), per run."""
        return np.asarray(self.alpha < as_scalar("max_alpha", max_alpha, domain="positive"))


def linearized_lsq(ranges: Any, beacons: Any, provisional: ArrayLike, *, unknown_bias: bool = True, iterations: int = 1,
                   sigma: Any = None, max_condition: float = 1e3, max_noise_gain: float = 100.0) -> LSQFix:
    r"""Range least squares linearized about a provisional position (paper A's pre-positioning step).

    Model :math:`r_i = \lVert p - b_i\rVert + \upsilon + \eta_i` (the bias :math:`\upsilon` only with
    ``unknown_bias``). Each Gauss-Newton step linearizes at the current estimate :math:`(p_0, \upsilon_0)`:

    .. math::

        y_i = r_i - \lVert p_0 - b_i\rVert - \upsilon_0, \qquad a_i = \Big[\frac{(p_0 - b_i)^\mathsf{T}}
        {\lVert p_0 - b_i\rVert},\ 1\Big], \qquad
        \begin{bmatrix}\delta p \\ \delta\upsilon\end{bmatrix} = (A^\mathsf{T}A)^{-1}A^\mathsf{T}y,

    then :math:`p_0 \leftarrow p_0 + \delta p`, :math:`\upsilon_0 \leftarrow \upsilon_0 + \delta\upsilon`
    (starting from :math:`\upsilon_0 = 0`). Paper A takes one step (``iterations=1``); more steps converge to the
    nonlinear least-squares fix when the problem is well conditioned. The sign convention is the one above (the
    correction is *added* to the provisional position); paper A's extracted eqs. (3)-(9) mix two conventions.

    The solution uses the SVD of :math:`A` (no normal equations), so :math:`\alpha` and :math:`\kappa(A)` come out
    accurately even when the geometry is poor.

    Parameters
    ----------
    ranges : array_like, shape (N,) or (M, N)
        Measured ranges [m], >= 0.
    beacons : array_like, shape (N, 2) or (M, N, 2)
        The beacon of each range [m]: real beacons, or virtual beacons of a track (see ``prepositioning``).
    provisional : array_like, shape (2,) or (M, 2)
        The provisional position :math:`p_0` [m] (not on a beacon).
    unknown_bias : bool, default True
        Estimate a constant range bias (paper A's third unknown).
    iterations : int, default 1
        Largest number of Gauss-Newton steps (1 to ``MAX_ITERATIONS`` = 1000); the loop stops earlier once no
        run moves by more than ``1e-12`` of the problem's size (``LSQFix.iterations`` is the number taken).
    sigma : float or array_like, optional
        Range noise standard deviation [m] for the covariance; estimated from the residuals when omitted.
    max_condition : float, default 1e3
        Condition number above which an ``IllConditionedWarning`` is given.
    max_noise_gain : float, default 100
        Noise gain :math:`\sqrt\alpha` above which an ``IllConditionedWarning`` is given.

    Returns
    -------
    LSQFix
        The fix, its covariance, :math:`\alpha`, :math:`\kappa(A)` and residuals, with a runs axis if any input had
        one.

    Warns
    -----
    IllConditionedWarning
        When :math:`\kappa(A) >` ``max_condition`` or :math:`\sqrt\alpha >` ``max_noise_gain``, and when a problem
        is singular (its fix is then NaN).

    Examples
    --------
    Four beacons around the vehicle, ranges 5 m too long (a bias), provisional position 20 m off:

    >>> import numpy as np
    >>> from uwtutor.lsq import linearized_lsq
    >>> beacons = np.array(
    ...     [[1000.0, 0.0], [0.0, 1000.0], [-1000.0, 0.0], [0.0, -1000.0]]
    ... )
    >>> truth = np.array([30.0, -40.0])
    >>> r = np.linalg.norm(truth - beacons, axis=1) + 5.0
    >>> fix = linearized_lsq(r, beacons, provisional=[10.0, -30.0], iterations=3)
    >>> np.round(fix.position, 6), round(float(fix.bias), 6), round(
    ...     float(fix.alpha), 3
    ... )
    (array([ 30., -40.]), 5.0, 1.251)
    """
    unknown_bias = as_flag("unknown_bias", unknown_bias)
    r, b = as_ranges_and_beacons(ranges, beacons)
    p0 = as_finite("provisional", provisional, ndim=(1, 2), max_abs=MAX_COORDINATE)
    if p0.shape[-1] != 2:
        raise ValueError(f"provisional must be a position [x, y], shape (2,) or (M, 2); got {p0.shape}")
    steps = as_int("iterations", iterations, minimum=1, maximum=MAX_ITERATIONS)
    mc, mg = as_thresholds(max_condition, max_noise_gain)
    M = common_runs(dict(ranges=r.shape[0] if r.ndim == 2 else None, beacons=b.shape[0] if b.ndim == 3 else None,
                         provisional=p0.shape[0] if p0.ndim == 2 else None))
    batched = M is not None
    Mb = M or 1
    N = r.shape[-1]
    r = np.broadcast_to(r, (Mb, N))
    b = np.broadcast_to(b, (Mb, N, 2))
    p = np.array(np.broadcast_to(p0, (Mb, 2)), dtype=float)
    n_unknowns = 3 if unknown_bias else 2
    bias = np.zeros(Mb)
    taken = 0
    for taken in range(1, steps + 1):  # noqa: B007 (after the loop, taken is the number of steps made)
        h, rho = unit_los(p[:, None, :], b, "the provisional position (or an iterate)")
        h = np.nan_to_num(h)                     # a run made NaN by a singular step stays singular (and NaN)
        A = np.concatenate([h, np.ones((Mb, N, 1))], axis=-1) if unknown_bias else h
        y = r - rho - bias[:, None]
        delta, alpha, cond, inv_normal = batched_lstsq(A, y)
        p = p + delta[:, :2]
        if unknown_bias:
            bias = bias + delta[:, 2]
        # converged: no run moved by more than 1e-12 of its distance scale (a NaN run is singular: not waited on)
        moved = np.abs(delta).max(axis=-1)
        if not np.any(moved > CONVERGED_RTOL * (1.0 + np.abs(p).max(axis=-1) + rho.max(axis=-1))):
            break
    gain = np.sqrt(alpha)
    well = warn_conditioning(cond, gain, mc, mg, "the linearized least-squares problem")
    with np.errstate(invalid="ignore"):
        predicted = _line_of_sight(p[:, None, :], b)[0] + (bias[:, None] if unknown_bias else 0.0)
    residuals = r - predicted
    s, cov = sigma_and_cov(sigma, residuals, n_unknowns, inv_normal)
    estimate = np.concatenate([p, bias[:, None]], axis=-1) if unknown_bias else p

    def out(a: np.ndarray) -> np.ndarray:
        return a if batched else a[0]

    return LSQFix(estimate=out(estimate), position=out(p), bias=out(bias) if unknown_bias else None,
                  covariance=out(cov), sigma=out(s), alpha=out(alpha), condition_number=out(cond),
                  noise_gain=out(gain), residuals=out(residuals), design=out(A), iterations=taken,
                  well_conditioned=out(well))


def _track_beacons(dr_positions: np.ndarray, beacon: np.ndarray) -> np.ndarray:
    """Virtual beacons b - (P_i - P_now) of a DR track (..., N, 2) seen from its last epoch."""
    return beacon - (dr_positions - dr_positions[..., -1:, :])


def prepositioning(ranges: Any, dr_positions: ArrayLike, provisional: ArrayLike, beacon: ArrayLike = (0.0, 0.0), *,
                   unknown_bias: bool = True, iterations: int = 1, sigma: Any = None, max_condition: float = 1e3,
                   max_noise_gain: float = 100.0) -> LSQFix:
    r"""Paper A's pre-positioning: a least-squares fix of the *current* position from a whole DR track of ranges.

    The vehicle measured :math:`r_1, \dots, r_K` at epochs where dead reckoning put it at :math:`p^\mathrm{DR}_1, \dots,
    p^\mathrm{DR}_K` (only the differences matter). Its position at epoch :math:`i` is :math:`p + d_i`, :math:`d_i =
    p^\mathrm{DR}_i - p^\mathrm{DR}_K`, so the range of epoch :math:`i` is a range from the current position :math:`p`
    to the **virtual beacon** :math:`b^\mathrm{v}_i = b - d_i` (paper A "back-propagates the provisional position to
    every past epoch with the DR displacements"; the two views are the same equations). The fix is then
    ``linearized_lsq`` on those virtual beacons, with paper A's bias column by default.

    Parameters
    ----------
    ranges : array_like, shape (N,) or (M, N)
        Ranges of the epochs so far [m].
    dr_positions : array_like, shape (N, 2) or (M, N, 2)
        DR positions at those epochs [m] (e.g. ``np.cumsum(dr_displacements, axis=-2)``).
    provisional : array_like, shape (2,) or (M, 2)
        Provisional *current* position [m].
    beacon : array_like, shape (2,), optional
        The beacon [m] (the origin by default).
    unknown_bias : bool, default True
        Estimate paper A's constant range bias.
    iterations : int, default 1
        Gauss-Newton steps (paper A: one).
    sigma : float, optional
        Range noise standard deviation for the covariance (estimated from the residuals when omitted).
    max_condition : float, default 1e3
        See ``linearized_lsq``.
    max_noise_gain : float, default 100
        See ``linearized_lsq``.

    Returns
    -------
    LSQFix
        The fix of the current position (epoch N) and its quality; ``fix.trusted()`` is paper A's test
        :math:`\alpha < 2`.

    Warns
    -----
    IllConditionedWarning
        As ``linearized_lsq``: typically in the first epochs, before the bearing to the beacon has changed.

    Examples
    --------
    Ranges with a 2 m bias along half a circle of 300 m about the beacon; dead reckoning knows only the
    displacements, and the provisional current position is 9 m off:

    >>> import numpy as np
    >>> from uwtutor.lsq import prepositioning
    >>> theta = np.linspace(0.0, np.pi, 12)
    >>> track = 300.0 * np.column_stack([np.cos(theta), np.sin(theta)])
    >>> r = np.linalg.norm(track, axis=1) + 2.0
    >>> fix = prepositioning(r, track - track[0], provisional=track[-1] + [8.0, -5.0],
    ...                      iterations=3)
    >>> bool(np.allclose(fix.position, track[-1], atol=1e-6)), round(float(fix.bias), 3)
    (True, 2.0)
    >>> round(float(fix.alpha), 3), bool(fix.trusted())
    (1.147, True)
    """
    unknown_bias = as_flag("unknown_bias", unknown_bias)
    # the virtual beacons b - (P - P[-1]) stay within MAX_COORDINATE
    P = as_finite("dr_positions", dr_positions, ndim=(2, 3), max_abs=MAX_COORDINATE / 4)
    if P.shape[-1] != 2:
        raise ValueError(f"dr_positions must have shape (N, 2) or (M, N, 2); got {P.shape}")
    b = as_finite("beacon", beacon, shape=(2,), max_abs=MAX_COORDINATE / 4)
    n_ranges = np.shape(ranges)[-1] if np.ndim(ranges) else None
    if n_ranges is not None and P.shape[-2] != n_ranges:
        raise ValueError(f"dr_positions must give one DR position per range: {P.shape[-2]} rows of dr_positions for "
                         f"{n_ranges} ranges")
    mc, mg = as_thresholds(max_condition, max_noise_gain)
    with warnings.catch_warnings():
        # judged again below, so that the warning names this problem and points at the caller
        warnings.simplefilter("ignore", IllConditionedWarning)
        fix = linearized_lsq(ranges, _track_beacons(P, b), provisional, unknown_bias=unknown_bias,
                             iterations=iterations, sigma=sigma, max_condition=mc, max_noise_gain=mg)
    warn_conditioning(fix.condition_number, fix.noise_gain, mc, mg, "the pre-positioning problem")
    return fix


def nonlinear_lsq(ranges: Any, beacons: Any, initial: ArrayLike, *, unknown_bias: bool = False, sigma: Any = None,
                  max_condition: float = 1e3, max_noise_gain: float = 100.0) -> LSQFix:
    r"""Nonlinear range least squares with ``scipy.optimize.least_squares``: the reference of the linearized forms.

    Minimizes :math:`\sum_i \big(r_i - \lVert p - b_i\rVert - \upsilon\big)^2` over :math:`p` (and the bias
    :math:`\upsilon` with ``unknown_bias``) with the Levenberg-Marquardt method (trust-region reflective when there
    are fewer ranges than unknowns), from ``initial``, with the analytic Jacobian. The quality numbers
    (:math:`\alpha`, :math:`\kappa`, covariance) use the Jacobian at the solution. One problem at a time: loop for
    a batch (the linearized form, ``linearized_lsq``, is batched).

    Parameters
    ----------
    ranges : array_like, shape (N,)
        Measured ranges [m].
    beacons : array_like, shape (N, 2)
        Beacon (or virtual beacon) of each range [m].
    initial : array_like, shape (2,) or (3,)
        Starting point: a position, or position and bias with ``unknown_bias`` (bias 0 if only a position).
    unknown_bias : bool, default False
        Estimate a constant range bias.
    sigma : float, optional
        Range noise standard deviation for the covariance (estimated from the residuals when omitted).
    max_condition : float, default 1e3
        See ``linearized_lsq``.
    max_noise_gain : float, default 100
        See ``linearized_lsq``.

    Returns
    -------
    LSQFix
        ``iterations`` holds the number of function evaluations.

    Warns
    -----
    IllConditionedWarning
        As ``linearized_lsq``, judged at the solution.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.lsq import nonlinear_lsq
    >>> beacons = np.array([[1000.0, 0.0], [0.0, 1000.0], [-1000.0, 0.0]])
    >>> r = np.linalg.norm(np.array([30.0, -40.0]) - beacons, axis=1)
    >>> np.round(nonlinear_lsq(r, beacons, initial=[0.0, 0.0]).position, 6)
    array([ 30., -40.])
    """
    unknown_bias = as_flag("unknown_bias", unknown_bias)
    from scipy.optimize import least_squares

    r, b = as_ranges_and_beacons(ranges, beacons)
    if r.ndim != 1 or b.ndim != 2:
        raise ValueError("nonlinear_lsq solves one problem: ranges of shape (N,) and beacons of shape (N, 2); "
                         "loop over runs, or use linearized_lsq for a batch")
    n_unknowns = 3 if unknown_bias else 2
    x0 = as_finite("initial", initial, ndim=1)
    if x0.shape == (2,) and unknown_bias:
        x0 = np.append(x0, 0.0)
    if x0.shape != (n_unknowns,):
        raise ValueError(f"initial must have shape (2,){' or (3,)' if unknown_bias else ''}; got {x0.shape}")
    mc, mg = as_thresholds(max_condition, max_noise_gain)
    N = len(r)

    def residual(x: np.ndarray) -> np.ndarray:
        return _line_of_sight(x[:2], b)[0] + (x[2] if unknown_bias else 0.0) - r

    def jacobian(x: np.ndarray) -> np.ndarray:
        h = _line_of_sight(x[:2], b)[1]          # at a beacon: a zero row (a measure-zero case)
        return np.column_stack([h, np.ones(N)]) if unknown_bias else h

    method = "lm" if N >= n_unknowns else "trf"
    sol = least_squares(residual, x0, jac=jacobian, method=method, xtol=1e-12, ftol=1e-12, gtol=1e-12)
    A = jacobian(sol.x)
    _, alpha, cond, inv_normal = batched_lstsq(A[None], np.zeros((1, N)))
    alpha, cond, inv_normal = alpha[0], cond[0], inv_normal[0]
    gain = np.sqrt(alpha)
    well = warn_conditioning(cond, gain, mc, mg, "the nonlinear least-squares problem")[0]
    residuals = -sol.fun
    s, cov = sigma_and_cov(sigma, residuals, n_unknowns, inv_normal)
    x = sol.x.copy()
    return LSQFix(estimate=x, position=x[:2].copy(), bias=np.asarray(x[2]) if unknown_bias else None,
                  covariance=cov, sigma=np.asarray(s), alpha=np.asarray(alpha), condition_number=np.asarray(cond),
                  noise_gain=np.asarray(gain), residuals=residuals, design=A, iterations=int(sol.nfev),
                  well_conditioned=np.asarray(well))
