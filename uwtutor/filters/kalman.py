"""The linear Kalman filter, written to the uwtutor filter protocol.

It is the smallest filter that shows the protocol (``x``, ``P``, ``predict``, ``update``, a ``run`` helper that
returns a :class:`~uwtutor.filters.base.FilterResult`) and chapter 1 uses it to smooth a sequence of ranges.
The arithmetic is batch-aware: give ``x0`` a leading axis of ``M`` Monte Carlo runs and every step runs them all.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._validate import as_covariance, as_finite, as_float_array, as_positive
from .base import FilterResult, run_filter

__all__ = ["KalmanFilter"]


class KalmanFilter:
    r"""Linear Kalman filter :math:`x_k = F x_{k-1} + B u_k + w_k`, :math:`z_k = H x_k + v_k`.

    With :math:`w_k \sim N(0, Q)` and :math:`v_k \sim N(0, R)` the filter alternates

    .. math::

        \hat x^-_k = F \hat x_{k-1} + B u_k, \qquad P^-_k = F P_{k-1} F^T + Q,

        y_k = z_k - H \hat x^-_k, \qquad S_k = H P^-_k H^T + R, \qquad K_k = P^-_k H^T S_k^{-1},

        \hat x_k = \hat x^-_k + K_k y_k, \qquad
        P_k = (I - K_k H) P^-_k (I - K_k H)^T + K_k R K_k^T,

    the last in Joseph form, which keeps ``P`` symmetric and positive definite under rounding
    (Bar-Shalom, Li and Kirubarajan 2001, sec. 5.2).

    Parameters
    ----------
    F : array_like, shape (n, n)
        State transition matrix.
    H : array_like, shape (m, n)
        Measurement matrix.
    Q : array_like, shape (n, n)
        Process noise covariance (positive semi-definite).
    R : array_like, shape (m, m) or scalar
        Measurement noise covariance (positive definite).
    x0 : array_like, shape (n,) or (M, n)
        Initial state estimate; a leading axis runs ``M`` independent filters at once.
    P0 : array_like, shape (n, n) or (M, n, n)
        Initial covariance (positive definite).
    B : array_like, shape (n, p), optional
        Control-input matrix; ``None`` means the filter takes no input.

    Attributes
    ----------
    x, P : ndarray
        Current estimate and covariance.
    y, S : ndarray
        Innovation and its covariance from the last ``update`` (NaN if it had no measurement).

    Examples
    --------
    Smooth noisy ranges to a beacon that the vehicle approaches at 1.5 m/s:

    >>> import numpy as np
    >>> from uwtutor.filters import KalmanFilter
    >>> rng = np.random.default_rng(0)
    >>> true_range = 1000.0 - 1.5 * np.arange(50)
    >>> ranges = true_range + rng.normal(0.0, 3.0, 50)
    >>> kf = KalmanFilter.constant_velocity(dt=1.0, q=0.01, r=9.0, x0=[ranges[0], 0.0], P0=np.diag([9.0, 4.0]))
    >>> result = kf.run(ranges)
    >>> bool(abs(result.x[-1, 1] + 1.5) < 0.3)   # the range rate is recovered
    True
    """

    def __init__(self, F: Any, H: Any, Q: Any, R: Any, x0: Any, P0: Any, B: Any = None) -> None:
        self.F = as_finite("F", F, ndim=2)
        n = self.F.shape[0]
        if self.F.shape != (n, n):
            raise ValueError(f"F must be square; got shape {self.F.shape}")
        self.H = as_finite("H", H, ndim=2)
        if self.H.shape[1] != n:
            raise ValueError(f"H must have {n} columns to match F; got shape {self.H.shape}")
        m = self.H.shape[0]
        self.Q = as_covariance("Q", Q, n, allow_singular=True)
        self.R = as_covariance("R", R, m)
        self.B = None if B is None else as_finite("B", B, ndim=2)
        if self.B is not None and self.B.shape[0] != n:
            raise ValueError(f"B must have {n} rows to match F; got shape {self.B.shape}")
        self.x = as_finite("x0", x0, ndim=(1, 2)).copy()
        if self.x.shape[-1] != n:
            raise ValueError(f"x0 must have {n} entries per run to match F; got shape {self.x.shape}")
        P0 = as_covariance("P0", P0, n)
        self.P = np.broadcast_to(P0, self.x.shape[:-1] + (n, n)).copy()
        self.y = np.full(self.x.shape[:-1] + (m,), np.nan)
        self.S = np.full(self.x.shape[:-1] + (m, m), np.nan)

    @classmethod
    def constant_velocity(cls, dt: float, q: float, r: float, x0: Any, P0: Any) -> "KalmanFilter":
        r"""A filter for a scalar that changes at a nearly constant rate, observed directly.

        State :math:`[s, \dot s]`; the rate follows a discrete white-noise acceleration model with spectral
        density ``q``: :math:`Q = q \begin{bmatrix} dt^3/3 & dt^2/2 \\ dt^2/2 & dt \end{bmatrix}`;
        the measurement :math:`z = s + v`, :math:`v \sim N(0, r)`.
        Chapter 1 uses it on a sequence of ranges (state: range and range rate).

        Parameters
        ----------
        dt : float
            Time between measurements (s).
        q : float
            Process noise spectral density (units of s squared per second cubed), >= 0.
        r : float
            Measurement noise variance, > 0.
        x0 : array_like, shape (2,) or (M, 2)
            Initial value and rate.
        P0 : array_like, shape (2, 2)
            Initial covariance.
        """
        dt = float(as_positive("dt", dt))
        q = float(as_finite("q", q))
        if q < 0:
            raise ValueError(f"q must be >= 0; got {q}")
        F = np.array([[1.0, dt], [0.0, 1.0]])
        Q = q * np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
        return cls(F=F, H=[[1.0, 0.0]], Q=Q, R=[[float(as_positive("r", r))]], x0=x0, P0=P0)

    def predict(self, u: Any = None) -> None:
        """Propagate ``x`` and ``P`` one step: ``x = F x + B u``, ``P = F P F^T + Q``."""
        self.x = self.x @ self.F.T
        if u is not None:
            if self.B is None:
                raise ValueError("u was given but this filter has no control-input matrix B")
            self.x = self.x + as_finite("u", u) @ self.B.T
        self.P = self.F @ self.P @ self.F.T + self.Q

    def update(self, z: Any) -> None:
        """Correct the estimate with the measurement ``z`` (shape (m,), or (M, m) when batched; NaN: skip).

        A batched filter updates only the runs whose measurement is finite.
        """
        m = self.H.shape[0]
        z = as_float_array("z", z).reshape(self.x.shape[:-1] + (m,))
        if np.isinf(z).any():
            raise ValueError("z must be finite, or NaN for a missing measurement; got an infinite value")
        has = np.isfinite(z).all(axis=-1)
        self.y = np.full(z.shape, np.nan)
        self.S = np.full(z.shape + (m,), np.nan)
        if not has.any():
            return
        x, P, zk = self.x[has], self.P[has], z[has]
        HT = self.H.T
        y = zk - x @ HT
        S = self.H @ P @ HT + self.R
        # K = P H^T S^-1, computed as a solve against the symmetric S rather than an explicit inverse
        K = np.swapaxes(np.linalg.solve(S, (P @ HT).swapaxes(-1, -2)), -1, -2)
        I_KH = np.eye(P.shape[-1]) - K @ self.H
        self.x[has] = x + (K @ y[..., None])[..., 0]
        self.P[has] = I_KH @ P @ I_KH.swapaxes(-1, -2) + K @ self.R @ K.swapaxes(-1, -2)
        self.y[has] = y
        self.S[has] = S

    def run(self, zs: Any, us: Any = None, times: Any = None) -> FilterResult:
        """Predict then update at every step; see :func:`~uwtutor.filters.base.run_filter`."""
        return run_filter(self, zs, us, times)
