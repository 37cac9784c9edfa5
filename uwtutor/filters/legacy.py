r"""Two names kept for chapter 6 and the depth lab, each now a model pair on the library's one engine.

Chapter 6 (``book/ch06_particle_filters.ipynb``) and the lab ``exercises/labs/depth_pf_vs_ekf`` import these
names from :mod:`uwtutor.filters`; new code uses the model pairs directly:

=============================  ===================================================================================
:class:`DepthEKF`              ``ExtendedKalmanFilter(DepthSpeedPitch(T, process_cov=Q), DepthSensors(R), x0, P0)``:
                               paper C's EKF is the generic engine on paper C's models
                               (:mod:`uwtutor.models.depth`), not a second EKF
:class:`LinearGaussianModel`   ``ModelPair(LinearMotion(F, Q, B), LinearMeasurement(H, R))``: the linear-Gaussian
                               model on which a particle filter is checked against the Kalman filter
=============================  ===================================================================================

(``DepthSpeedPitchModel`` and ``PitchManeuverModel``, which the same notebooks import from :mod:`uwtutor.filters`,
live in :mod:`uwtutor.models.depth`.)
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .._validate import MAX_COORDINATE, as_covariance, as_finite, readonly
from ..models.base import ModelPair
from ..models.depth import DepthSensors, DepthSpeedPitch
from ..models.linear import LinearMeasurement, LinearMotion
from .engine import ExtendedKalmanFilter

__all__ = ["DepthEKF", "LinearGaussianModel"]


def _depth_models(Q: ArrayLike | None, R: ArrayLike | None, T: float) -> tuple[DepthSpeedPitch, DepthSensors]:
    """Paper C's model pair for :class:`DepthEKF`, its arguments checked."""
    if Q is not None:                          # named Q here (the motion model calls it process_cov)
        Q = as_covariance("Q", Q, 3, allow_singular=True)
    motion = DepthSpeedPitch(T=T) if Q is None else DepthSpeedPitch(T=T, process_cov=Q)
    sensors = DepthSensors(R)
    if sensors._R is None or sensors._R.shape != (3, 3):
        raise ValueError("R must be one 3x3 covariance (depth, speed, pitch sensors); for per-step or per-run "
                         "noise use extended_kalman_filter(DepthSpeedPitch(...), DepthSensors(R), ...)")
    return motion, sensors


class DepthEKF(ExtendedKalmanFilter):
    r"""Paper C's EKF: the generic :class:`~uwtutor.filters.engine.ExtendedKalmanFilter` on paper C's models.

    The motion :class:`~uwtutor.models.depth.DepthSpeedPitch` (:math:`x_k = g(x_{k-1} + u_k)`, :math:`u_k \sim
    N(0, Q)`: the engine's :math:`F P F^T + G Q G^T` is paper C's :math:`G (P + Q) G^T`) and the sensors
    :class:`~uwtutor.models.depth.DepthSensors` (:math:`y_k = x_k + w_k`, :math:`w_k \sim N(0, R)`; a missing
    sensor is skipped, the others update). Li et al. (2013), paper C, eqs. (4)-(6).

    Parameters
    ----------
    x0 : array_like, shape (3,) or (M, 3)
        Initial estimate ``[depth, speed, pitch]`` [m, m/s, rad]; a leading axis runs ``M`` filters at once.
    P0 : array_like, shape (3, 3) or (M, 3, 3)
        Initial covariance (positive definite).
    Q : array_like, shape (3, 3), optional
        Covariance of :math:`[u^z, u^v, u^\phi]` per step (positive semi-definite); by default
        ``diag(DEFAULT_PROCESS_STD**2)`` of :mod:`uwtutor.models.depth`.
    R : array_like, shape (3, 3), optional
        Sensor noise covariance (positive definite); paper C's by default.
    T : float, optional
        Sampling interval [s]; 0.05 s in paper C.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.filters import DepthEKF
    >>> from uwtutor.models import DepthSpeedPitchModel
    >>> model = DepthSpeedPitchModel()
    >>> truth, meas = model.simulate(
    ...     [10.0, 1.5, 0.1], 400, np.random.default_rng(0)
    ... )
    >>> res = DepthEKF(
    ...     x0=meas[0], P0=model.R, Q=np.diag(model.process_std**2), R=model.R
    ... ).run(meas)
    >>> res.x.shape
    (400, 3)
    >>> # better than the 0.2 m sensor
    >>> bool(np.sqrt(np.mean((res.x[100:, 0] - truth[100:, 0]) ** 2)) < 0.2)
    True
    """

    def __init__(self, x0: ArrayLike, P0: ArrayLike, Q: ArrayLike | None = None, R: ArrayLike | None = None,
                 T: float = 0.05) -> None:
        motion, sensors = _depth_models(Q, R, T)
        x = as_finite("x0", x0, max_abs=MAX_COORDINATE)
        if x.ndim not in (1, 2) or x.shape[-1] != 3:
            raise ValueError(f"x0 must be [depth, speed, pitch], shape (3,) or (M, 3); got shape {x.shape}")
        super().__init__(motion, sensors, x0, P0)
        self._config = dict(Q=Q, R=R, T=T)

    _parameters = ("Q", "R", "T")
    motion: DepthSpeedPitch                         # the engine's model pair: paper C's
    measurement: DepthSensors

    def _apply(self, name: str, value: Any) -> None:
        """A new ``Q``, ``R`` or ``T`` (base.Configurable): the models are built again with it, checked as in the
        constructor, and used from the next step on."""
        config = dict(self._config, **{name: value})
        self._use_models(*_depth_models(**config), name)
        self._config = config

    @property
    def Q(self) -> np.ndarray | None:
        """The covariance of the motion noise per step, or None for the default; assign a new one to change it."""
        return None if self._config["Q"] is None else readonly(np.array(self._config["Q"], dtype=float))

    @property
    def R(self) -> np.ndarray:
        """Sensor noise covariance (3, 3) (read-only; assign a new one to change it)."""
        R = self.measurement._R
        assert R is not None                        # one (3, 3) covariance: _depth_models refuses any other
        return readonly(R)

    @property
    def T(self) -> float:
        """Sampling interval [s] (assign a new one to change it)."""
        return self.motion.T


class LinearGaussianModel(ModelPair):
    r"""The linear-Gaussian model :math:`x_k = F x_{k-1} + B u_k + w_k`, :math:`z_k = H x_k + v_k` as one
    :class:`~uwtutor.models.base.ModelPair` (chapter 6's name).

    With :math:`w_k \sim N(0, Q)` and :math:`v_k \sim N(0, R)` the exact posterior is the Kalman filter's, which
    makes this pair the reference test of a particle filter. It is ``ModelPair(LinearMotion(F, Q, B),
    LinearMeasurement(H, R))``.

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
    B : array_like, shape (n, p), optional
        Control-input matrix (``None``: no input).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.filters import (
    ...     BootstrapParticleFilter,
    ...     KalmanFilter,
    ...     LinearGaussianModel,
    ... )
    >>> rng = np.random.default_rng(0)
    >>> zs = np.cumsum(rng.normal(0.0, 1.0, 30)) + rng.normal(0.0, 2.0, 30)
    >>> model = LinearGaussianModel(F=[[1.0]], H=[[1.0]], Q=[[1.0]], R=[[4.0]])
    >>> pf = BootstrapParticleFilter.from_gaussian(
    ...     model, [0.0], [[10.0]], 20000, rng
    ... )
    >>> kf = KalmanFilter(
    ...     F=[[1.0]], H=[[1.0]], Q=[[1.0]], R=[[4.0]], x0=[0.0], P0=[[10.0]]
    ... )
    >>> bool(np.max(np.abs(pf.run(zs).x - kf.run(zs).x)) < 0.1)
    True
    """

    def __init__(self, F: ArrayLike, H: ArrayLike, Q: ArrayLike, R: ArrayLike, B: ArrayLike | None = None) -> None:
        motion = LinearMotion(F, Q, B)
        measurement = LinearMeasurement(H, R)
        if measurement.n != motion.n:
            raise ValueError(f"H must have {motion.n} columns to match F; got shape {measurement._H.shape}")
        super().__init__(motion, measurement)
        self._linear = measurement
        self.F, self.H, self.Q, self.B = motion._F, measurement._H, motion._Q, motion._B

    @property
    def R(self) -> np.ndarray:
        """Measurement noise covariance ``(m, m)``."""
        return self._linear.R(None, 0)
