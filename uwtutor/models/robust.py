r"""Models of paper E's two Kalman filters: a constant-velocity state observed directly.

Paper E filters twice. First the **range sequence** to the mother ship (state: range and range rate), then the
**position fixes** of the virtual-beacon least squares (state: horizontal position and velocity). Both are a
constant-velocity state of ``d`` dimensions, :math:`x = [p, v]` (:math:`p, v \in \mathbb R^d`), whose position
part is measured:

.. math::

    x_k = \begin{bmatrix} I & \Delta_k I \\ 0 & I \end{bmatrix} x_{k-1} + w_k, \qquad
    Q_k = q \begin{bmatrix} \Delta_k^4/4\, I & \Delta_k^3/2\, I \\ \Delta_k^3/2\, I & \Delta_k^2\, I
    \end{bmatrix}, \qquad z_k = [I\ 0]\, x_k + v_k,\quad v_k \sim N(0, R_k),

the discrete white-noise-acceleration model (Bar-Shalom, Li and Kirubarajan 2001, sec. 6.3.3): a random
acceleration of variance :math:`q` held over each step :math:`\Delta_k`. The first step of a run has
:math:`\Delta_0 = 0` (the initial state is the state at the first epoch), so its prediction is the identity.

:class:`ConstantVelocity` is the motion model (any step lengths); :class:`PositionMeasurement` is
:math:`z = [I\ 0]x + v` with a covariance that may change from epoch to epoch (a least-squares fix comes with its
own), which ``uwtutor.models.DirectMeasurement`` with its single :math:`R` does not allow.

References
----------
Bar-Shalom, Y., Li, X. R. and Kirubarajan, T. (2001). *Estimation with Applications to Tracking and Navigation*.
Wiley. Section 6.3.3.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validate import (MAX_COVARIANCE, as_covariance, as_finite, as_float_array, as_int, as_nonnegative,
                         as_scalar, check_finite_result, check_work)
from .base import MeasurementModel, MotionModel

__all__ = ["ConstantVelocity", "PositionMeasurement", "step_lengths"]


def step_lengths(n_steps: int, dt: Any = 1.0, times: ArrayLike | None = None) -> NDArray[np.float64]:
    r"""The step lengths :math:`\Delta_k` of a run, shape ``(K,)``, with :math:`\Delta_0 = 0`.

    Parameters
    ----------
    n_steps : int
        Number of epochs K.
    dt : float, default 1
        The constant step [s] (used when ``times`` is None), > 0.
    times : array_like, shape (K,), optional
        Epoch times [s], strictly increasing.

    Returns
    -------
    ndarray, shape (K,)

    Examples
    --------
    >>> from uwtutor.models.robust import step_lengths
    >>> step_lengths(4, dt=2.0), step_lengths(3, times=[0.0, 1.0, 3.5])
    (array([0., 2., 2., 2.]), array([0. , 1. , 2.5]))
    """
    K = as_int("n_steps", n_steps, minimum=1)
    # checked even when times is given (never ignored silently); 1e30 s bounds any clock and keeps q dt^4 finite
    step = as_scalar("dt", dt, domain="positive", high=1e30)
    if times is None:
        check_work("n_steps", K)
        out = np.full(K, step)
    else:
        t = as_finite("times", times, ndim=1, max_abs=1e30)
        if len(t) != K:
            raise ValueError(f"times must have one entry per epoch (n_steps = {K}); got {len(t)}")
        out = np.diff(t, prepend=t[:1])
        if K > 1 and np.any(out[1:] <= 0):
            raise ValueError("times must be strictly increasing")
    out[0] = 0.0
    return out


class ConstantVelocity(MotionModel):
    r"""Constant velocity in ``d`` dimensions with white-noise acceleration (equations in the module docstring).

    Parameters
    ----------
    d : int
        Number of position components (1: a range; 2: a horizontal position).
    q : float
        Variance of the random acceleration :math:`q` [(m/s²)²], >= 0.
    steps : array_like, shape (K,)
        Step lengths :math:`\Delta_k` [s] (see :func:`step_lengths`); step ``k`` of the filter uses
        ``steps[k]``.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.models.robust import ConstantVelocity, step_lengths
    >>> cv = ConstantVelocity(d=1, q=2.0, steps=step_lengths(3, dt=1.0))
    >>> cv.f(np.array([[1500.0, -2.0]]), None, 1), cv.Q(None, None, 1)
    (array([[1498.,   -2.]]), array([[0.5, 1. ],
           [1. , 2. ]]))
    """

    #: Q is positive semi-definite by construction (q >= 0 times a Gram matrix of the steps), so the filter does not
    #: check it again at each step.
    covariances_checked = True

    def __init__(self, d: int, q: Any, steps: ArrayLike) -> None:
        self.d = as_int("d", d, minimum=1)
        self.n = 2 * self.d
        self.q = float(as_nonnegative("q", q, ndim=0, max_abs=MAX_COVARIANCE))
        steps = as_nonnegative("steps", steps, ndim=1, nonempty=True)
        self.steps = steps
        d, K = self.d, len(steps)
        self._F = np.tile(np.eye(2 * d), (K, 1, 1))
        self._F[:, :d, d:] = steps[:, None, None] * np.eye(d)
        blocks = np.stack([np.stack([steps**4 / 4, steps**3 / 2], -1), np.stack([steps**3 / 2, steps**2], -1)], -2)
        with np.errstate(over="ignore", invalid="ignore"):
            self._Q = self.q * np.einsum("kij,ab->kiajb", blocks, np.eye(d)).reshape(K, 2 * d, 2 * d)
        check_finite_result(self._Q, "q", "steps", what="the process noise q * steps**4 / 4")

    def _step(self, k: int) -> int:
        if not 0 <= k < len(self.steps):
            raise IndexError(f"step {k} is beyond the {len(self.steps)} step lengths this model was built with")
        return k

    def f(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        return x @ self._F[self._step(k)].T

    def F(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        return self._F[self._step(k)]

    def Q(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        return self._Q[self._step(k)]


class PositionMeasurement(MeasurementModel):
    r"""The position part of a constant-velocity state, measured: :math:`z_k = [I\ 0]\,x_k + v_k`.

    Parameters
    ----------
    d : int
        Number of position components (the state has ``2 d``).
    R : array_like
        Measurement noise covariance: ``(d, d)`` (or a scalar for d = 1) for every epoch, ``(K, d, d)`` one per
        epoch, or ``(M, K, d, d)`` one per run and epoch. Each must be symmetric positive definite.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.models.robust import PositionMeasurement
    >>> pm = PositionMeasurement(2, np.array([np.eye(2), 4 * np.eye(2)]))
    >>> pm.h(np.array([[3.0, 4.0, 1.0, 0.0]]), 1), float(pm.R(None, 1)[0, 0])
    (array([[3., 4.]]), 4.0)
    """

    covariances_checked = True      # R is checked (symmetric positive definite) when the model is made

    def __init__(self, d: int, R: ArrayLike) -> None:
        self.d = self.m = as_int("d", d, minimum=1)
        self.n = 2 * self.d
        R = as_float_array("R", R)
        if R.ndim == 0 or (self.d == 1 and R.ndim == 1):
            R = R.reshape(R.shape + (1, 1))
        if R.ndim < 2 or R.ndim > 4 or R.shape[-2:] != (self.d, self.d):
            raise ValueError(f"R must have shape ({self.d}, {self.d}), (K, {self.d}, {self.d}) or "
                             f"(M, K, {self.d}, {self.d}); got {R.shape}")
        self._R = as_covariance("R", R, self.d)
        self.n_runs = R.shape[0] if R.ndim == 4 else None
        H = np.zeros((self.d, self.n))
        H[:, : self.d] = np.eye(self.d)
        self._H = H

    def h(self, x: np.ndarray, k: int) -> np.ndarray:
        return x[..., : self.d]

    def H(self, x: np.ndarray, k: int) -> np.ndarray:
        return np.broadcast_to(self._H, (x.shape[0],) + self._H.shape)

    def R(self, x: np.ndarray | None, k: int) -> np.ndarray:      # x unused (None will do)
        if self._R.ndim == 2:
            return self._R
        if self._R.ndim == 3:
            return self._R[k]
        return self._R[:, k]                    # (M, d, d): one per run
