r"""The Rauch–Tung–Striebel smoother: every estimate of a stored run improved by the measurements that came after.

A filter estimates the state at epoch :math:`k` from the measurements up to :math:`k`. When the data are stored
and processed after the fact (paper E's ranges are), the estimate at :math:`k` may use *all* of them. For a
linear-Gaussian model the Rauch–Tung–Striebel (RTS) smoother gives that estimate exactly, in one backward pass
over the filter's own output (Rauch, Tung and Striebel 1965; Särkkä 2013, sec. 8.2):

.. math::

    C_k = P_k F_{k+1}^T (P^-_{k+1})^{-1}, \qquad
    \hat x^s_k = \hat x_k + C_k(\hat x^s_{k+1} - \hat x^-_{k+1}), \qquad
    P^s_k = P_k + C_k (P^s_{k+1} - P^-_{k+1}) C_k^T,

from :math:`\hat x^s_{K-1} = \hat x_{K-1}`, :math:`P^s_{K-1} = P_{K-1}`. Here :math:`\hat x_k, P_k` are the
filter's posteriors, :math:`\hat x^-_{k+1}, P^-_{k+1}` its predictions and :math:`F_{k+1}` the Jacobian of the
motion model at :math:`\hat x_k` (the extended RTS smoother for a nonlinear model). The smoother reads the
predictions *as the filter made them* from its :class:`~uwtutor.filters.base.FilterResult`, so a gate that changed
an estimate (a rejected measurement, a re-acquisition) is carried through consistently.

On a linear-Gaussian model the smoothed estimates are the solution of the batch least-squares problem over the
whole trajectory (tested in ``tests/test_smoother.py``). ``filterpy``'s ``rts_smoother`` takes ``F`` and ``Q`` and
recomputes the predictions itself, which is not what an EKF or a gated filter did.

References
----------
Rauch, H. E., Tung, F. and Striebel, C. T. (1965). Maximum likelihood estimates of linear dynamic systems.
AIAA Journal 3(8), 1445-1450.

Särkkä, S. (2013). *Bayesian Filtering and Smoothing*. Cambridge University Press. Sections 8.2 and 9.1.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .._validate import as_covariance, as_finite
from ..errors import IllConditionedError
from ..models.base import MotionModel
from .base import FilterResult

__all__ = ["SmootherResult", "rts_smoother"]


@dataclass(frozen=True)
class SmootherResult:
    """The smoothed estimates of a filter run (returned by :func:`rts_smoother`).

    Attributes
    ----------
    times : ndarray, shape (K,)
        The filter's times.
    x : ndarray, shape (K, n) or (M, K, n)
        Smoothed states :math:`\\hat x^s_k`.
    P : ndarray, shape (K, n, n) or (M, K, n, n)
        Their covariances :math:`P^s_k`.
    gain : ndarray, shape (K, n, n) or (M, K, n, n)
        The smoother gains :math:`C_k` (the last one is zero).
    filtered : FilterResult
        The filter run that was smoothed.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.filters import extended_kalman_filter, rts_smoother
    >>> from uwtutor.models import DeadReckoning, RangeToBeacon
    >>> motion = DeadReckoning(np.eye(2) * 0.01)
    >>> u = np.tile([1.0, 0.0], (4, 1))
    >>> truth = np.array([10.0, 20.0]) + np.cumsum(u, axis=0)
    >>> res = extended_kalman_filter(
    ...     motion,
    ...     RangeToBeacon((0.0, 0.0), R=1.0),
    ...     [12.0, 18.0],
    ...     np.eye(2) * 25.0,
    ...     u,
    ...     np.linalg.norm(truth, axis=1),
    ... )
    >>> sm = rts_smoother(res, motion, u)
    >>> sm.x.shape, sm.gain.shape, sm.filtered is res
    ((4, 2), (4, 2, 2), True)
    >>> # the last epoch has no future: smoothed = filtered
    >>> bool(np.allclose(sm.x[-1], res.x[-1]))
    True
    """

    times: np.ndarray
    x: np.ndarray
    P: np.ndarray
    gain: np.ndarray
    filtered: FilterResult


def rts_smoother(result: FilterResult, motion: MotionModel, u: ArrayLike | None = None) -> SmootherResult:
    r"""Smooth a filter run backwards with the Rauch–Tung–Striebel recursion (equations in the module docstring).

    Parameters
    ----------
    result : FilterResult
        A run of a Kalman-family filter (e.g. the generic engine's) with ``x``, ``P``, ``x_prior`` and
        ``P_prior``, shapes ``(K, n)`` or ``(M, K, n)``.
    motion : uwtutor.models.MotionModel
        The motion model the filter used (for :math:`F_{k+1}` at :math:`\hat x_k`).
    u : array_like, shape (K, p) or (M, K, p), optional
        The inputs the filter was run with (when the Jacobian depends on them).

    Returns
    -------
    SmootherResult

    Examples
    --------
    A constant-velocity range sequence: the smoother beats the filter everywhere but at the end, where they agree.

    >>> import numpy as np
    >>> from uwtutor.filters import KalmanFilter, rts_smoother
    >>> from uwtutor.models import LinearMotion
    >>> rng = np.random.default_rng(0)
    >>> truth = 1500.0 - 1.5 * np.arange(100.0)
    >>> z = truth + rng.normal(0.0, 2.0, 100)
    >>> F, Q = np.array([[1.0, 1.0], [0.0, 1.0]]), np.diag([1e-4, 1e-4])
    >>> kf = KalmanFilter(
    ...     F=F,
    ...     H=[[1.0, 0.0]],
    ...     Q=Q,
    ...     R=[[4.0]],
    ...     x0=[z[0], 0.0],
    ...     P0=np.diag([4.0, 4.0]),
    ... )
    >>> filtered = kf.run(z)
    >>> smoothed = rts_smoother(filtered, LinearMotion(F, Q))
    >>> def rms(e): return float(np.sqrt(np.mean(e ** 2)))
    >>> rms(smoothed.x[:, 0] - truth) < rms(filtered.x[:, 0] - truth)
    True
    >>> bool(np.allclose(smoothed.x[-1], filtered.x[-1]))
    True
    """
    if not isinstance(result, FilterResult):
        raise TypeError(f"result must be a uwtutor.filters.FilterResult (a filter's run); got {type(result).__name__}")
    if not isinstance(motion, MotionModel):
        raise TypeError(f"motion must be a uwtutor.models.MotionModel; got {type(motion).__name__}")
    x = np.asarray(result.x, dtype=float)
    batched = x.ndim == 3
    xb = x if batched else x[None]
    M, K, n = xb.shape
    if n != motion.n:
        raise ValueError(f"the result's state has size {n} but the motion model's has {motion.n}")

    if result.x_prior is None or result.P_prior is None:
        raise ValueError("result has no priors (x_prior, P_prior): run the filter with keep_priors=True (the "
                         "default) to smooth it")

    def runs(a: Any) -> np.ndarray:
        arr = np.asarray(a, dtype=float)
        return arr if batched else arr[None]

    P, xp, Pp = runs(result.P), runs(result.x_prior), runs(result.P_prior)
    # the filter's covariances are the smoother's input: symmetric PSD (an indefinite P would come out negative
    # definite), checked once here rather than trusted
    as_covariance("result.P", P, n, allow_singular=True)
    as_covariance("result.P_prior", Pp, n, allow_singular=True)
    if u is not None:
        u = as_finite("u", u)
        if u.ndim == 2:
            u = np.broadcast_to(u, (M,) + u.shape)
        if u.ndim != 3 or u.shape[:2] != (M, K):
            raise ValueError(f"u must have one input per step, shape (K, p) or (M, K, p) with K = {K}; "
                             f"got {np.shape(u)}")
    xs = xb.copy()
    Ps = P.copy()
    C = np.zeros((M, K, n, n))
    for k in range(K - 2, -1, -1):
        F = np.broadcast_to(np.asarray(motion.F(xb[:, k], None if u is None else u[:, k + 1], k + 1), dtype=float),
                            (M, n, n))
        # C = P F^T (P-)^-1, computed as the transpose of (P-)^-1 F P (P- symmetric)
        try:
            Ck = np.swapaxes(np.linalg.solve(Pp[:, k + 1], F @ P[:, k]), -1, -2)
        except np.linalg.LinAlgError:
            raise IllConditionedError(
                f"result.P_prior is singular to float64 precision at step {k + 1}: the smoother gain "
                "P F^T (P-)^-1 does not exist. This happens when the filter's covariance spans more than ~1e16 "
                "(e.g. P0 = 1e12 I with R <= 1e-6): start from a smaller P0 (a least-squares fix) or a larger R, or "
                "give the motion model some process noise Q") from None
        # the model's own difference and normalization: a heading wraps at +-pi
        step = motion.difference(xs[:, k + 1], xp[:, k + 1])
        xs[:, k] = motion.normalize(xb[:, k] + (Ck @ step[..., None])[..., 0])
        Pk = P[:, k] + Ck @ (Ps[:, k + 1] - Pp[:, k + 1]) @ np.swapaxes(Ck, -1, -2)
        Ps[:, k] = 0.5 * (Pk + np.swapaxes(Pk, -1, -2))
        C[:, k] = Ck
    lost = np.linalg.eigvalsh(Ps).min(axis=-1) < -1e-9 * np.maximum(1.0, np.abs(Ps).max(axis=(-1, -2)))
    if lost.any():
        j, k = (int(i) for i in np.argwhere(lost)[0])
        raise IllConditionedError(f"the smoothed covariance lost positive semi-definiteness (run {j}, step {k}): the "
                                  "filter's covariances are too ill-conditioned for float64 (a P0 far above R); start "
                                  "from a smaller P0 or a larger R")

    def out(a: np.ndarray) -> np.ndarray:
        return a if batched else a[0]

    return SmootherResult(times=result.times, x=out(xs), P=out(Ps), gain=out(C), filtered=result)
