"""The linear Kalman filter, written to the uwtutor filter protocol.

It is the smallest filter that shows the protocol (``x``, ``P``, ``predict``, ``update``, a ``run`` helper that
returns a :class:`~uwtutor.filters.base.FilterResult`) and chapter 1 uses it to smooth a sequence of ranges.
It is the generic engine (:class:`~uwtutor.filters.engine.ExtendedKalmanFilter`) on a linear model pair, so it is
batch-aware: give ``x0`` a leading axis of ``M`` Monte Carlo runs and every step runs them all.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .._validate import as_scalar, readonly
from ..models.linear import LinearMeasurement, LinearMotion
from .engine import ExtendedKalmanFilter

__all__ = ["KalmanFilter"]


class KalmanFilter(ExtendedKalmanFilter):
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
    x : ndarray
        Current estimate, ``(n,)`` or ``(M, n)``.
    P : ndarray
        Its covariance.
    x_prior : ndarray
        The prediction of the current step.
    P_prior : ndarray
        Its covariance.
    y : ndarray
        Innovation of the last ``update`` (NaN if it had no measurement).
    S : ndarray
        Its covariance (NaN if it had no measurement).
    F : ndarray
        State transition matrix.
    H : ndarray
        Measurement matrix.
    Q : ndarray
        Process noise covariance.
    R : ndarray
        Measurement noise covariance.
    B : ndarray or None
        Control-input matrix (None without input).

    Notes
    -----
    ``F``, ``H``, ``Q``, ``R`` and ``B`` are shown read-only; assigning one takes effect from the next step, checked
    as in the constructor (``kf.R = 4.0`` runs exactly as ``KalmanFilter(..., R=4.0)``). ``y`` and ``S`` are
    read-only.

    Examples
    --------
    Smooth noisy ranges to a beacon that the vehicle approaches at 1.5 m/s:

    >>> import numpy as np
    >>> from uwtutor.filters import KalmanFilter
    >>> rng = np.random.default_rng(0)
    >>> true_range = 1000.0 - 1.5 * np.arange(50)
    >>> ranges = true_range + rng.normal(0.0, 3.0, 50)
    >>> kf = KalmanFilter.constant_velocity(
    ...     dt=1.0, q=0.01, r=9.0, x0=[ranges[0], 0.0], P0=np.diag([9.0, 4.0])
    ... )
    >>> result = kf.run(ranges)
    >>> def rms(e): return float(np.sqrt(np.mean(e ** 2)))
    >>> # raw, filtered
    >>> round(rms(ranges - true_range), 2), round(
    ...     rms(result.x[:, 0] - true_range), 2
    ... )
    (2.76, 1.69)
    """

    def __init__(self, F: ArrayLike, H: ArrayLike, Q: ArrayLike, R: ArrayLike, x0: ArrayLike, P0: ArrayLike,
                 B: ArrayLike | None = None) -> None:
        motion = LinearMotion(F, Q, B)
        measurement = LinearMeasurement(H, R)
        if measurement._R is None:
            raise ValueError(f"R must be one ({measurement.m}, {measurement.m}) matrix; got shape {np.shape(R)} (for "
                             "a noise per step, run extended_kalman_filter with a LinearMeasurement)")
        if measurement.n != motion.n:
            raise ValueError(f"H must have {motion.n} columns to match F; got shape {measurement._H.shape}")
        super().__init__(motion, measurement, x0, P0)
        self._show_models()

    _parameters = ("F", "H", "Q", "R", "B")
    motion: LinearMotion                            # the engine's model pair, linear here
    measurement: LinearMeasurement

    def _show_models(self) -> None:
        shown = dict(F=self.motion._F, Q=self.motion._Q, B=self.motion._B, H=self.measurement._H,
                     R=self.measurement._R)
        for name, value in shown.items():
            object.__setattr__(self, name, None if value is None else readonly(value))

    def _apply(self, name: str, value: Any) -> None:
        """A new ``F``, ``H``, ``Q``, ``R`` or ``B`` (base.Configurable): the model pair is built again with it,
        checked as in the constructor, and used from the next step on."""
        config = dict(F=self.F, H=self.H, Q=self.Q, R=self.R, B=self.B)
        config[name] = value
        motion = LinearMotion(config["F"], config["Q"], config["B"])
        measurement = LinearMeasurement(config["H"], config["R"])
        if measurement._R is None:
            raise ValueError(f"R must be one ({measurement.m}, {measurement.m}) matrix; got shape "
                             f"{np.shape(config['R'])}")
        if name == "B" and (self.B is None) != (motion._B is None):
            raise ValueError("B cannot be added or removed after construction (the filter's input changes): build "
                             "a new KalmanFilter")
        self._use_models(motion, measurement, name)
        self._show_models()

    @classmethod
    def constant_velocity(cls, dt: float, q: float, r: float, x0: ArrayLike, P0: ArrayLike) -> "KalmanFilter":
        r"""A filter for a scalar that changes at a nearly constant rate, observed directly.

        State :math:`[s, \dot s]`; the rate is driven by *continuous* white-noise acceleration of power spectral
        density ``q``, which integrated over one step gives
        :math:`Q = q \begin{bmatrix} dt^3/3 & dt^2/2 \\ dt^2/2 & dt \end{bmatrix}`
        (Bar-Shalom, Li and Kirubarajan 2001, sec. 6.2.2: the continuous white-noise acceleration model);
        the measurement :math:`z = s + v`, :math:`v \sim N(0, r)`.
        Chapter 1 uses it on a sequence of ranges (state: range and range rate).

        Parameters
        ----------
        dt : float
            Time between measurements (s).
        q : float
            Power spectral density of the acceleration noise, >= 0, in (unit of s)^2 per s^3: m^2/s^3 for a
            range in metres. Over one step it adds ``q dt`` to the rate's variance.
        r : float
            Measurement noise variance, > 0.
        x0 : array_like, shape (2,) or (M, 2)
            Initial value and rate.
        P0 : array_like, shape (2, 2)
            Initial covariance.
        """
        dt = as_scalar("dt", dt, domain="positive")
        q = as_scalar("q", q, domain="nonnegative")
        r = as_scalar("r", r, domain="positive")
        F = np.array([[1.0, dt], [0.0, 1.0]])
        Q = q * np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
        return cls(F=F, H=[[1.0, 0.0]], Q=Q, R=[[r]], x0=x0, P0=P0)
