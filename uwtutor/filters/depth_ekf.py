r"""The extended Kalman filter for paper C's depth/speed/pitch model: the baseline of the grey particle filter.

State :math:`x = [z, v, \phi]^T` (depth [m], speed [m/s], pitch [rad], depth positive downwards so that a
positive pitch dives), sampling interval :math:`T`. Paper C's motion model (eq. (4)) adds the process noise
:math:`u_k = [u^z_k, u^v_k, u^\phi_k]^T \sim N(0, Q)` *inside* the kinematics:

.. math::

    z_k = z_{k-1} + (v_{k-1} + u^v_k) \sin(\phi_{k-1} + u^\phi_k)\, T + u^z_k, \qquad
    v_k = v_{k-1} + u^v_k, \qquad \phi_k = \phi_{k-1} + u^\phi_k,

which is exactly :math:`x_k = g(x_{k-1} + u_k)` with :math:`g(s) = [s_z + s_v \sin(s_\phi) T, s_v,
s_\phi]^T`. The sensors measure the state, :math:`y_k = x_k + w_k`, :math:`w_k \sim N(0, R_k)` (eq. (6)).
Linearizing :math:`g` at the estimate with the Jacobian

.. math::

    G_k = \frac{\partial g}{\partial s}\Big|_{\hat x_{k-1}} =
    \begin{bmatrix} 1 & T \sin\hat\phi_{k-1} & T \hat v_{k-1} \cos\hat\phi_{k-1} \\
                    0 & 1 & 0 \\ 0 & 0 & 1 \end{bmatrix}

gives the EKF (Bar-Shalom, Li and Kirubarajan 2001, sec. 10.3):

.. math::

    \hat x^-_k = g(\hat x_{k-1}), \qquad P^-_k = G_k (P_{k-1} + Q) G_k^T,

    y_k = z_k - \hat x^-_k, \qquad S_k = P^-_k + R_k, \qquad K_k = P^-_k S_k^{-1},

    \hat x_k = \hat x^-_k + K_k y_k, \qquad P_k = (I - K_k) P^-_k (I - K_k)^T + K_k R_k K_k^T

(Joseph form). The noise enters through the same Jacobian as the state, so :math:`G (P + Q) G^T` is the usual
:math:`F P F^T + L Q L^T` with :math:`L = F = G`.

The kinematics :math:`g` and :math:`G` are those of :mod:`uwtutor.models.depth`, which paper C's particle filters
use too. The filter follows the protocol of :mod:`uwtutor.filters.base` and is batch-aware: give ``x0`` a leading axis of
``M`` Monte Carlo runs and every step runs them all. ``R`` may change at any step (``run(..., Rs=...)``), which
turns it into the "EKF with the wavelet noise estimate" of the chapter on paper C.

References
----------
Bar-Shalom, Y., Li, X. R. and Kirubarajan, T. (2001). *Estimation with Applications to Tracking and Navigation*.
Wiley. Sections 5.2 (Joseph form) and 10.3 (EKF).

Li Ting, Zhao Dexin, Huang Zhiping and Su Shaojing (2013), paper C, eqs. (4)-(6); the EKF is its first baseline.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._validate import as_covariance, as_finite, as_float_array, as_positive
from ..models.depth import (DEFAULT_PROCESS_STD, DEFAULT_SENSOR_STD, depth_speed_pitch_jacobian,
                            depth_speed_pitch_kinematics)
from .base import FilterResult, run_filter

__all__ = ["DepthEKF"]

_N = 3


class DepthEKF:
    r"""EKF for the depth, speed and pitch of an AUV with all three measured (paper C's model), batch-aware.

    Equations in the module docstring.

    Parameters
    ----------
    x0 : array_like, shape (3,) or (M, 3)
        Initial estimate ``[depth, speed, pitch]`` [m, m/s, rad]; a leading axis runs ``M`` filters at once.
    P0 : array_like, shape (3, 3) or (M, 3, 3)
        Initial covariance (positive definite).
    Q : array_like, shape (3, 3), optional
        Covariance of :math:`[u^z, u^v, u^\phi]` per step (positive semi-definite); by default
        ``diag(DEFAULT_PROCESS_STD**2)`` of :mod:`uwtutor.models.depth`, the particle filters' default too.
    R : array_like, shape (3, 3) or (M, 3, 3), optional
        Sensor noise covariance (positive definite); assign ``R`` between steps to change it. By default
        ``diag(DEFAULT_SENSOR_STD**2)`` (paper C's R read as 0.2 m, 5 cm/s, 0.5 deg).
    T : float, optional
        Sampling interval [s]; 0.05 s in paper C.

    Attributes
    ----------
    x : ndarray
        Current estimate, shape (3,) or (M, 3).
    P : ndarray
        Current covariance, shape (3, 3) or (M, 3, 3).
    y : ndarray
        Innovation of the last update, shape (3,) or (M, 3); NaN for a missing sensor.
    S : ndarray
        Its covariance, shape (3, 3) or (M, 3, 3); NaN rows and columns for a missing sensor.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.filters import DepthEKF, DepthSpeedPitchModel
    >>> model = DepthSpeedPitchModel()
    >>> truth, meas = model.simulate(
    ...     [10.0, 1.5, 0.1], 400, np.random.default_rng(0)
    ... )
    >>> ekf = DepthEKF(
    ...     x0=meas[0], P0=model.R, Q=np.diag(model.process_std**2), R=model.R
    ... )
    >>> res = ekf.run(meas)
    >>> res.x.shape
    (400, 3)
    >>> # better than the 0.2 m sensor
    >>> bool(np.sqrt(np.mean((res.x[100:, 0] - truth[100:, 0]) ** 2)) < 0.2)
    True
    """

    extra_outputs: tuple[str, ...] = ()

    def __init__(self, x0: Any, P0: Any, Q: Any = None, R: Any = None, T: float = 0.05) -> None:
        self.T = float(as_positive("T", T))
        if Q is None:
            Q = np.diag(DEFAULT_PROCESS_STD**2)
        if R is None:
            R = np.diag(DEFAULT_SENSOR_STD**2)
        self.Q = as_covariance("Q", Q, _N, allow_singular=True)
        if self.Q.shape != (_N, _N):
            raise ValueError(f"Q must be one 3x3 matrix shared by all runs; got shape {self.Q.shape}")
        x = as_finite("x0", x0, ndim=(1, 2))
        if x.shape[-1] != _N:
            raise ValueError(f"x0 must be [depth, speed, pitch], shape (3,) or (M, 3); got shape {x.shape}")
        self.x = x.copy()
        P0 = as_covariance("P0", P0, _N)
        if P0.ndim == 3 and (x.ndim != 2 or P0.shape[0] != x.shape[0]):
            raise ValueError(f"P0 of shape {P0.shape} needs x0 of shape ({P0.shape[0]}, 3); got {x.shape}")
        self.P = np.broadcast_to(P0, x.shape[:-1] + (_N, _N)).copy()
        self.R = R
        self.x_prior, self.P_prior = self.x, self.P
        self.y = np.full(x.shape, np.nan)
        self.S = np.full(x.shape + (_N,), np.nan)
        self._step = -1                       # index of the current step (advanced by predict)
        self._R_schedule: np.ndarray | None = None

    @property
    def R(self) -> np.ndarray:
        """Sensor noise covariance, shape (3, 3) or (M, 3, 3)."""
        return self._R

    @R.setter
    def R(self, value: Any) -> None:
        R = as_covariance("R", value, _N)
        if R.ndim == 3 and (self.x.ndim != 2 or R.shape[0] != self.x.shape[0]):
            raise ValueError(f"R of shape {R.shape} needs one matrix per run: x has shape {self.x.shape}")
        self._R = R

    def predict(self, u: Any = None) -> None:
        r""":math:`\hat x^- = g(\hat x)`, :math:`P^- = G (P + Q) G^T`; the model takes no input (``u`` is None)."""
        if u is not None:
            raise ValueError("DepthEKF takes no control input: call predict() without u")
        G = depth_speed_pitch_jacobian(self.x, self.T)
        self.x = self.x_prior = depth_speed_pitch_kinematics(self.x, self.T)
        self.P = self.P_prior = G @ (self.P + self.Q) @ np.swapaxes(G, -1, -2)
        self._step += 1

    def update(self, z: Any) -> None:
        """Correct with the measurement ``z`` (shape (3,) or (M, 3)); NaN entries are missing sensors.

        Each run uses the sensors it has (rows of the identity as measurement matrix); a run with none keeps its
        prediction.
        """
        z = as_float_array("z", z)
        try:
            z = z.reshape(self.x.shape)
        except ValueError:
            raise ValueError(f"z must have shape {self.x.shape} (one [depth, speed, pitch] per run); "
                             f"got {z.shape}") from None
        if np.isinf(z).any():
            raise ValueError("z must be finite, or NaN for a missing measurement; got an infinite value")
        if self._R_schedule is not None:      # run(..., Rs=...): this step's R
            self.R = self._R_schedule[self._step]
        batched = self.x.ndim == 2
        x = self.x if batched else self.x[None]
        P = self.P if batched else self.P[None]
        zz = z if batched else z[None]
        present = np.isfinite(zz)
        if present.all():                                        # every sensor of every run: H = I
            S = P + self._R
            K = np.swapaxes(np.linalg.solve(S, np.swapaxes(P, -1, -2)), -1, -2)      # P S^-1 (S symmetric)
            A = np.eye(_N) - K
            y = zz - x
            x_new = x + (K @ y[..., None])[..., 0]
            P_new = A @ P @ np.swapaxes(A, -1, -2) + K @ self._R @ np.swapaxes(K, -1, -2)
            if batched:
                self.x, self.P, self.y, self.S = x_new, P_new, y, S
            else:
                self.x, self.P, self.y, self.S = x_new[0], P_new[0], y[0], S[0]
            return
        R = np.broadcast_to(self._R, (x.shape[0], _N, _N))
        y_out = np.full(x.shape, np.nan)
        S_out = np.full(x.shape + (_N,), np.nan)
        x_new, P_new = x.copy(), P.copy()
        patterns, inverse = np.unique(present, axis=0, return_inverse=True)
        for p, pattern in enumerate(patterns):
            if not pattern.any():
                continue
            runs = np.flatnonzero(inverse.reshape(-1) == p)
            sel = np.flatnonzero(pattern)
            H = np.eye(_N)[sel]                                  # (q, 3): the rows of the sensors present
            xr, Pr, Rr = x[runs], P[runs], R[runs][:, sel[:, None], sel]
            y = zz[runs][:, sel] - xr[:, sel]
            S = Pr[:, sel[:, None], sel] + Rr
            PHt = Pr[:, :, sel]                                  # P H^T
            K = np.swapaxes(np.linalg.solve(S, np.swapaxes(PHt, -1, -2)), -1, -2)
            A = np.eye(_N) - K @ H
            x_new[runs] = xr + (K @ y[..., None])[..., 0]
            P_new[runs] = A @ Pr @ np.swapaxes(A, -1, -2) + K @ Rr @ np.swapaxes(K, -1, -2)
            yy = np.full((runs.size, _N), np.nan)
            yy[:, sel] = y
            y_out[runs] = yy
            SS = np.full((runs.size, _N, _N), np.nan)
            SS[:, sel[:, None], sel] = S
            S_out[runs] = SS
        if batched:
            self.x, self.P, self.y, self.S = x_new, P_new, y_out, S_out
        else:
            self.x, self.P, self.y, self.S = x_new[0], P_new[0], y_out[0], S_out[0]

    def run(self, z: Any, u: Any = None, times: Any = None, *, Rs: Any = None) -> FilterResult:
        """Predict then update at every step; optionally with a new ``R`` at each step.

        Parameters
        ----------
        z : array_like, shape (K, 3) or (M, K, 3)
            Measurements (NaN: missing).
        u : None
            The model takes no input (the argument is there for the protocol's one ``run`` signature).
        times : array_like, shape (K,), optional
            Time stamps of the result (default ``0..K-1``).
        Rs : array_like, shape (K, 3, 3) or (M, K, 3, 3), optional
            The sensor noise covariance to use at each step (e.g. the wavelet estimates); the filter's ``R``
            otherwise. The filter is left with the last one.

        Returns
        -------
        FilterResult
            Estimates, covariances, predictions, innovations and their covariances, with the runs axis first when
            batched.
        """
        if u is not None:
            raise ValueError("DepthEKF takes no control input: call run(z) without u")
        if Rs is None:
            return run_filter(self, z, None, times)
        batched = self.x.ndim == 2
        zs = as_float_array("z", z)
        if zs.ndim != self.x.ndim + 1 or zs.shape[-1] != _N or (batched and zs.shape[0] != self.x.shape[0]):
            want = f"({self.x.shape[0]}, K, 3)" if batched else "(K, 3)"
            raise ValueError(f"z must have shape {want}: one [depth, speed, pitch] per step; got {zs.shape}")
        K = zs.shape[-2]
        Rs = as_float_array("Rs", Rs)
        shapes = [(K, _N, _N)] + ([(self.x.shape[0], K, _N, _N)] if batched else [])
        if Rs.shape not in shapes:
            raise ValueError(f"Rs must have shape {' or '.join(map(str, shapes))}: one covariance per step "
                             f"(and run); got {Rs.shape}")
        schedule = Rs if Rs.ndim == 3 else np.moveaxis(Rs, 1, 0)     # (K, [M,] 3, 3)
        for k in range(K):                    # every one a valid covariance, checked before the first step
            as_covariance(f"Rs[{k}]" if Rs.ndim == 3 else f"Rs[:, {k}]", schedule[k], _N)
        self._R_schedule = schedule
        self._step = -1
        try:
            return run_filter(self, z, None, times)
        finally:
            self._R_schedule = None
