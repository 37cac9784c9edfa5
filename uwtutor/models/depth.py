r"""Paper C's depth, speed and pitch models: one copy, used by the generic EKF and by the particle filters.

State :math:`x = [z, v, \phi]^T` (depth [m], positive downwards; speed [m/s]; pitch [rad], positive nose
down, so that a positive pitch dives), sampling interval :math:`T`. Paper C's motion model (eq. (4)) adds the
process noise :math:`u_k = [u^z_k, u^v_k, u^\phi_k]^T \sim N(0, Q)` *inside* the kinematics:

.. math::

    z_k = z_{k-1} + (v_{k-1} + u^v_k) \sin(\phi_{k-1} + u^\phi_k)\, T + u^z_k, \qquad
    v_k = v_{k-1} + u^v_k, \qquad \phi_k = \phi_{k-1} + u^\phi_k,

which is exactly :math:`x_k = g(x_{k-1} + u_k)` with

.. math::

    g(s) = \begin{bmatrix} s_z + s_v \sin(s_\phi)\, T \\ s_v \\ s_\phi \end{bmatrix}, \qquad
    G = \frac{\partial g}{\partial s} =
    \begin{bmatrix} 1 & T \sin s_\phi & T s_v \cos s_\phi \\ 0 & 1 & 0 \\ 0 & 0 & 1 \end{bmatrix}.

A particle filter draws :math:`u_k` and applies :math:`g` (:meth:`DepthSpeedPitch.sample`); an EKF linearizes
:math:`g` at the estimate, and since the noise enters through the same map its prediction is
:math:`P^-_k = G (P_{k-1} + Q) G^T` (:meth:`DepthSpeedPitch.F` and :meth:`DepthSpeedPitch.Q`, which returns
:math:`G Q G^T`). The sensors measure the state itself, :math:`y_k = x_k + w_k`, :math:`w_k \sim N(0, R_k)`
(eq. (6); :class:`DepthSensors`).

The models of the chapter on paper C:

=============================  ===========================================================================
:class:`DepthSpeedPitch`       the motion model above (eq. (4))
:class:`PitchManeuver`         the same with the pitch drawn towards a target: one mode of a maneuver
                               (cruise, dive, climb) for the multiple-model particle filter
:class:`DepthSensors`          the three sensors (eq. (6)), with a fixed :math:`R`, one per step, or one per
                               run and step (the wavelet estimates of the grey particle filter)
:class:`DepthSpeedPitchModel`  motion and sensors in one :class:`~uwtutor.models.base.ModelPair`, with
                               :meth:`~uwtutor.models.base.ModelPair.simulate`
:class:`PitchManeuverModel`    the same for :class:`PitchManeuver`
=============================  ===========================================================================

The one model pair runs in every filter: ``extended_kalman_filter(DepthSpeedPitch(), DepthSensors(), ...)`` is
paper C's EKF (its first baseline), ``BootstrapParticleFilter.from_gaussian(DepthSpeedPitch(), DepthSensors(),
...)`` its particle filter, and :class:`~uwtutor.filters.particle.grey.GreyParticleFilter` and
:class:`~uwtutor.filters.particle.multiple_model.MultipleModelParticleFilter` take the same models.

References
----------
Li Ting, Zhao Dexin, Huang Zhiping and Su Shaojing (2013). A method for self-estimating the depth of maneuvering
AUV based on the grey particle filter. *Journal of National University of Defense Technology* 35(5), 185-190
(paper C), eqs. (4)-(6).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validate import as_covariance, as_finite, as_nonnegative, as_scalar
from .base import ModelPair, MotionModel
from .linear import DirectMeasurement
from .noise import per_run_generators, psd_sqrt, standard_normal_per_run

__all__ = [
    "DEFAULT_PROCESS_STD",
    "DEFAULT_SENSOR_STD",
    "depth_speed_pitch_kinematics",
    "depth_speed_pitch_jacobian",
    "DepthSpeedPitch",
    "PitchManeuver",
    "DepthSensors",
    "DepthSpeedPitchModel",
    "PitchManeuverModel",
]

#: Default standard deviations of :math:`u^z, u^v, u^\phi` per step, in m, m/s and rad; illustrative values
#: (paper C's printed process covariance is not a covariance matrix; its diagonal is in
#: :mod:`uwtutor.scenarios.paper_c`).
DEFAULT_PROCESS_STD = np.array([0.01, 0.01, 0.0035])
DEFAULT_PROCESS_STD.flags.writeable = False
#: Largest sampling interval and standard deviation accepted: the variances they make stay within 1e150.
_MAX_STD = 1e75

#: Default sensor noise standard deviations in m, m/s and rad, from paper C's
#: :math:`R = \mathrm{diag}(0.2^2, 5^2, 0.5^2)` (printed without units, read as 0.2 m, 5 cm/s and 0.5 deg).
DEFAULT_SENSOR_STD = np.array([0.2, 0.05, np.radians(0.5)])
DEFAULT_SENSOR_STD.flags.writeable = False


def depth_speed_pitch_kinematics(s: ArrayLike, T: float, axis: int = -1, *,
                                 out: np.ndarray | None = None) -> np.ndarray:
    r"""Paper C's kinematics :math:`g(s) = [s_z + s_v \sin(s_\phi) T,\ s_v,\ s_\phi]` of states ``s``.

    Parameters
    ----------
    s : array_like
        States (or states plus process noise), depth, speed and pitch along ``axis``.
    T : float
        Sampling interval [s].
    axis : int, optional
        The axis of the three components (the last by default; a particle filter that stores its particles
        component-major passes ``-2``).
    out : ndarray, optional
        Where to write the result (may be ``s`` itself: then only the depth is changed, in place).

    Returns
    -------
    ndarray
        :math:`g(s)`, the shape of ``s``.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.models.depth import depth_speed_pitch_kinematics
    >>> # 2 m/s at 30 deg for 0.5 s
    >>> depth_speed_pitch_kinematics(np.array([10.0, 2.0, np.pi / 6]), 0.5)
    array([10.5       ,  2.        ,  0.52359878])
    """
    s = as_finite("s", s)
    if s.ndim == 0 or s.shape[axis % s.ndim if s.ndim else 0] != 3:
        raise ValueError(f"s must hold depth, speed and pitch (3 components) along axis {axis}; got shape {s.shape}")
    T = as_scalar("T", T, domain="positive")
    if out is not None and (not isinstance(out, np.ndarray) or out.shape != s.shape or out.dtype != np.float64):
        raise ValueError(f"out must be a float64 array of the shape of s {s.shape}; got "
                         f"{getattr(out, 'shape', type(out).__name__)}")
    return _kinematics(s, T, axis, out)


def _kinematics(s: np.ndarray, T: float, axis: int = -1, out: np.ndarray | None = None) -> np.ndarray:
    """:func:`depth_speed_pitch_kinematics` without the checks (the filters' per-step path)."""
    if out is None:
        out = s.copy()
    elif out is not s:
        out[...] = s
    ax = axis % s.ndim
    if ax == 1 and s.ndim == 3:                                  # (M, 3, N): the particle filters' rows
        dz = np.sin(s[:, 2])
        dz *= s[:, 1]
        dz *= T
        out[:, 0] += dz
        return out

    lead = (slice(None),) * ax                                   # index component i as lead + (i,)
    dz = np.sin(s[lead + (2,)])
    dz *= s[lead + (1,)]
    dz *= T
    out[lead + (0,)] += dz
    return out


def depth_speed_pitch_jacobian(s: ArrayLike, T: float) -> NDArray[np.float64]:
    r"""The Jacobian :math:`G = \partial g / \partial s` of :func:`depth_speed_pitch_kinematics` at states ``s``.

    Parameters
    ----------
    s : array_like, shape (..., 3)
        States ``[depth, speed, pitch]``.
    T : float
        Sampling interval [s].

    Returns
    -------
    ndarray, shape (..., 3, 3)

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.models.depth import depth_speed_pitch_jacobian
    >>> depth_speed_pitch_jacobian(np.array([10.0, 2.0, 0.0]), 0.5)
    array([[1., 0., 1.],
           [0., 1., 0.],
           [0., 0., 1.]])
    """
    s = as_finite("s", s)
    if s.ndim == 0 or s.shape[-1] != 3:
        raise ValueError(f"s must have shape (..., 3) (depth, speed, pitch); got {s.shape}")
    T = as_scalar("T", T, domain="positive")
    return _jacobian(s, T)


def _jacobian(s: np.ndarray, T: float) -> np.ndarray:
    """:func:`depth_speed_pitch_jacobian` without the checks."""
    v, phi = s[..., 1], s[..., 2]
    G = np.zeros(s.shape[:-1] + (3, 3))
    G[..., 0, 0] = G[..., 1, 1] = G[..., 2, 2] = 1.0
    G[..., 0, 1] = T * np.sin(phi)
    G[..., 0, 2] = T * v * np.cos(phi)
    return G


class DepthSpeedPitch(MotionModel):
    r"""Paper C's depth/speed/pitch motion model for the Kalman family and the particle filters.

    :math:`x_k = g(x_{k-1} + u_k)`, :math:`u_k \sim N(0, Q_u)` (equations in the module docstring); for an EKF
    :math:`f = g`, :math:`F = G` and :meth:`Q` returns :math:`G Q_u G^T`, so that the engine's :math:`F P F^T + Q`
    is paper C's :math:`G (P + Q_u) G^T`; a particle filter draws :math:`u_k` and applies :math:`g`
    (:meth:`sample`), which is exact.

    Parameters
    ----------
    T : float, optional
        Sampling interval [s]; 0.05 s in paper C.
    process_std : array_like, shape (3,), optional
        Standard deviations :math:`\sigma` of :math:`u^z, u^v, u^\phi` per step [m, m/s, rad], independent:
        :math:`Q_u = \mathrm{diag}(\sigma^2)`. :data:`DEFAULT_PROCESS_STD` by default: illustrative values, since
        paper C's printed process covariance is not a valid covariance matrix (not positive semi-definite; its
        diagonal is in :mod:`uwtutor.scenarios.paper_c`).
    process_cov : array_like, shape (3, 3), optional
        :math:`Q_u` itself (positive semi-definite), instead of ``process_std``, for correlated noise.

    Attributes
    ----------
    process_std : ndarray, shape (3,)
        :math:`\sqrt{\mathrm{diag}(Q_u)}`.
    process_cov : ndarray, shape (3, 3)
        :math:`Q_u`.

    References
    ----------
    Li Ting et al. (2013), paper C, eq. (4).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.models import DepthSpeedPitch
    >>> motion = DepthSpeedPitch(T=0.5, process_std=[0.0, 0.0, 0.0])
    >>> motion.f(np.array([[10.0, 2.0, np.pi / 6]]), None, 0)
    array([[10.5       ,  2.        ,  0.52359878]])
    >>> # no noise: g(x)
    >>> motion.sample(
    ...     np.array([[[10.0, 2.0, np.pi / 6]]]),
    ...     None,
    ...     0,
    ...     [np.random.default_rng(0)],
    ... )
    array([[[10.5       ,  2.        ,  0.52359878]]])
    """

    n = 3
    covariances_checked = True      # Q = G Q_u G^T of a Q_u checked (positive semi-definite) when the model is made

    def __init__(self, T: float = 0.05, process_std: ArrayLike | None = None, *,
                 process_cov: ArrayLike | None = None) -> None:
        # T and the standard deviations up to 1e75: the variances they make stay within the covariances' 1e150
        self.T = as_scalar("T", T, domain="positive", high=_MAX_STD)
        if process_cov is not None:
            if process_std is not None:
                raise ValueError("give process_std or process_cov, not both")
            cov = as_covariance("process_cov", process_cov, 3, allow_singular=True)
            if cov.ndim != 2:
                raise ValueError(f"process_cov must be one 3x3 matrix shared by all runs; got shape {cov.shape}")
            self.process_cov = cov.copy()
            self.process_std = np.sqrt(np.diag(cov))
        else:
            std = DEFAULT_PROCESS_STD if process_std is None else process_std
            self.process_std = as_nonnegative("process_std", std, shape=(3,), max_abs=_MAX_STD).copy()
            self.process_cov = np.diag(self.process_std**2)
        diagonal = np.count_nonzero(self.process_cov - np.diag(np.diag(self.process_cov))) == 0
        self._root = None if diagonal else psd_sqrt(self.process_cov)      # L with L L^T = Q_u (correlated)

    def _no_input(self, u: Any) -> None:
        if u is not None:
            raise ValueError("the depth/speed/pitch model takes no control input: predict without u")

    def _pre(self, x: np.ndarray, axis: int = -1) -> np.ndarray:
        """The state before the kinematics of the step (the identity here; a maneuver pulls the pitch)."""
        return x

    def f(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        self._no_input(u)
        return _kinematics(np.asarray(self._pre(x), dtype=float), self.T)

    def F(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        return _jacobian(np.asarray(x, dtype=float), self.T)

    def Q(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        G = _jacobian(np.asarray(self._pre(x), dtype=float), self.T)
        Q: np.ndarray = G @ self.process_cov @ np.swapaxes(G, -1, -2)
        return Q

    def sample_rows(self, rows: np.ndarray, rng: Any) -> np.ndarray:
        r"""Draw :math:`x_k = g(x_{k-1} + u_k)` for states stored component-major, ``rows`` of shape (M, 3, N).

        ``rng`` is one Generator per run (a sequence of ``M``; a Generator when ``M = 1``); run ``m`` draws its
        ``(3, N)`` noise from its own generator. Returns a new (M, 3, N) array.
        """
        M = rows.shape[0]
        rngs = rng if type(rng) is tuple and len(rng) == M else per_run_generators(rng, M, spawn=False)
        noise = standard_normal_per_run(rngs, rows.shape[1:])      # rows u^z, u^v, u^phi of every run
        if self._root is None:
            noise *= self.process_std[:, None]
        else:
            noise = self._root @ noise
        s = np.add(rows, noise, out=noise)                       # z + u^z, v_k = v + u^v, phi_k = phi + u^phi
        return _kinematics(s, self.T, axis=-2, out=s)

    def sample(self, x: np.ndarray, u: Any, k: int, rng: Any) -> np.ndarray:
        r"""Draw the next states of states ``x`` of shape (M, N, 3) (or (M, 3)): :math:`g(x + u)`,
        :math:`u \sim N(0, Q_u)`, run ``m`` from ``rng[m]`` (noise inside the kinematics, as in paper C)."""
        self._no_input(u)
        x = np.asarray(x, dtype=float)
        if x.ndim == 2:
            return self.sample(x[:, None, :], None, k, rng)[:, 0, :]
        return self.sample_rows(self._pre(x).swapaxes(-1, -2), rng).swapaxes(-1, -2)


class PitchManeuver(DepthSpeedPitch):
    r"""Paper C's depth/speed/pitch model with the pitch drawn towards a target: one mode of a maneuver.

    Before the step of :class:`DepthSpeedPitch`, the pitch relaxes towards ``pitch_target`` with time
    constant :math:`\tau`:

    .. math::

        \bar\phi_{k-1} = \phi_{k-1} + (1 - e^{-T/\tau})\,(\phi^* - \phi_{k-1}),

    then :math:`z_k = z_{k-1} + (v_{k-1} + u^v_k) \sin(\bar\phi_{k-1} + u^\phi_k)\, T + u^z_k`,
    :math:`v_k = v_{k-1} + u^v_k`, :math:`\phi_k = \bar\phi_{k-1} + u^\phi_k`. With the depth
    :math:`z` positive downwards, a positive pitch makes the vehicle go deeper (nose down). Three such models with
    targets 0 (cruise), :math:`+\phi_d` (dive) and :math:`-\phi_c` (climb) make the mode set of the
    multiple-model particle filter of the chapter on paper C (McGinnity and Irwin 2000). For an EKF,
    :math:`F = G(\bar x)\,\mathrm{diag}(1, 1, e^{-T/\tau})`.

    Parameters
    ----------
    pitch_target : float, optional
        :math:`\phi^*` [rad]; 0 by default (cruise at constant depth).
    time_constant : float, optional
        :math:`\tau` [s] (> 0); 2 s by default.
    T, process_std, process_cov
        As in :class:`DepthSpeedPitch`.

    References
    ----------
    McGinnity, S. and Irwin, G. W. (2000). Multiple model bootstrap filter for maneuvering target tracking. *IEEE
    Trans. Aerospace and Electronic Systems* 36(3), 1006-1012.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.models import PitchManeuver
    >>> dive = PitchManeuver(
    ...     pitch_target=0.3,
    ...     time_constant=1.0,
    ...     T=0.05,
    ...     process_std=[0.0, 0.0, 0.0],
    ... )
    >>> dive.sample(
    ...     np.array([[[10.0, 2.0, 0.0]]]), None, 0, [np.random.default_rng(0)]
    ... ).round(5)
    array([[[10.00146,  2.     ,  0.01463]]])
    """

    def __init__(self, pitch_target: float = 0.0, time_constant: float = 2.0, T: float = 0.05,
                 process_std: ArrayLike | None = None, *, process_cov: ArrayLike | None = None) -> None:
        super().__init__(T=T, process_std=process_std, process_cov=process_cov)
        self.pitch_target = as_scalar("pitch_target", pitch_target)
        self.time_constant = as_scalar("time_constant", time_constant, domain="positive")
        self._gain = -math.expm1(-self.T / self.time_constant)

    def _pre(self, x: np.ndarray, axis: int = -1) -> np.ndarray:
        pulled = np.array(x, dtype=float)
        pitch = pulled[..., 2]
        pitch += self._gain * (self.pitch_target - pitch)
        return pulled

    def F(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        G = _jacobian(np.asarray(self._pre(x), dtype=float), self.T)
        G[..., 2] *= 1.0 - self._gain                          # d(pulled pitch) / d(pitch) = e^{-T/tau}
        return G


class DepthSensors(DirectMeasurement):
    r"""Paper C's depth, speed and pitch sensors: :math:`y_k = x_k + w_k`, :math:`w_k \sim N(0, R_k)` (eq. (6)).

    Parameters
    ----------
    R : array_like, optional
        The sensor noise: one ``(3, 3)`` covariance, one per step ``(K, 3, 3)`` (or ``(K, 3)`` variances), or one
        per run and step ``(M, K, 3, 3)`` (e.g. the wavelet estimates of each run). By default
        ``diag(DEFAULT_SENSOR_STD**2)``: paper C's :math:`R = \mathrm{diag}(0.2^2, 5^2, 0.5^2)`, printed without
        units, read as 0.2 m, 5 cm/s and 0.5 deg.

    References
    ----------
    Li Ting et al. (2013), paper C, eq. (6).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.models import DepthSensors
    >>> sensors = DepthSensors()
    >>> x = np.array([[12.0, 1.5, 0.1]])
    >>> sensors.h(x, 0) is x, np.sqrt(np.diag(sensors.R(x, 0))).round(4)
    (True, array([0.2   , 0.05  , 0.0087]))
    """

    def __init__(self, R: ArrayLike | None = None) -> None:
        super().__init__(3, [0, 1, 2], np.diag(DEFAULT_SENSOR_STD**2) if R is None else R)


class DepthSpeedPitchModel(ModelPair):
    r"""Paper C's model in one object: :class:`DepthSpeedPitch` and :class:`DepthSensors` (Li et al., paper C).

    State :math:`x_k = [z_k, v_k, \phi_k]^T` (depth [m], speed [m/s], pitch [rad]), sampling interval ``T``:

    .. math::

        z_k = z_{k-1} + (v_{k-1} + u^v_k) \sin(\phi_{k-1} + u^\phi_k)\, T + u^z_k, \qquad
        v_k = v_{k-1} + u^v_k, \qquad \phi_k = \phi_{k-1} + u^\phi_k,

    with independent Gaussian :math:`u^z_k, u^v_k, u^\phi_k` (standard deviations ``process_std``); the sensors
    measure the state directly, :math:`y_k = x_k + w_k`, :math:`w_k \sim N(0, R)`. Every filter takes it in place
    of the two models (``motion``, ``measurement``).

    Parameters
    ----------
    T : float, optional
        Sampling interval [s]; 0.05 s in paper C.
    process_std : array_like, shape (3,), optional
        Standard deviations of :math:`u^z, u^v, u^\phi` per step [m, m/s, rad]
        (:data:`DEFAULT_PROCESS_STD` by default).
    R : array_like, shape (3, 3), optional
        Sensor noise covariance (:class:`DepthSensors`' default by default); assign a new one at any time.

    Attributes
    ----------
    motion : DepthSpeedPitch
    measurement : DepthSensors

    References
    ----------
    Li Ting et al. (2013), paper C, eqs. (4)-(6).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.filters import BootstrapParticleFilter
    >>> from uwtutor.models import DepthSpeedPitchModel
    >>> rng = np.random.default_rng(3)
    >>> model = DepthSpeedPitchModel()
    >>> truth, meas = model.simulate([10.0, 1.5, 0.1], 200, rng)
    >>> pf = BootstrapParticleFilter.from_gaussian(
    ...     model, meas[0], model.R, 500, rng
    ... )
    >>> res = pf.run(meas)
    >>> res.x.shape, res.extras["ess"].shape
    ((200, 3), (200,))
    >>> # better than the depth sensor
    >>> bool(np.sqrt(np.mean((res.x[50:, 0] - truth[50:, 0]) ** 2)) < 0.2)
    True
    """

    motion: DepthSpeedPitch                         # the pair's models: paper C's
    _measurement: DepthSensors

    def __init__(self, T: float = 0.05, process_std: ArrayLike | None = None, R: ArrayLike | None = None) -> None:
        super().__init__(self._motion(T, process_std), DepthSensors(R))
        self._check_R()

    def _motion(self, T: float, process_std: ArrayLike | None) -> DepthSpeedPitch:
        return DepthSpeedPitch(T=T, process_std=process_std)

    def _check_R(self) -> None:
        R = self._measurement._R
        if R is None or R.shape != (3, 3):
            raise ValueError("R must be one 3x3 covariance (depth, speed, pitch sensors); got "
                             f"{'a per-step R' if R is None else R.shape}")

    @property
    def T(self) -> float:
        """Sampling interval [s]."""
        return self.motion.T

    @property
    def process_std(self) -> np.ndarray:
        """Standard deviations of the process noise per step [m, m/s, rad]."""
        return self.motion.process_std

    @property
    def R(self) -> np.ndarray:
        """Sensor noise covariance ``(3, 3)`` (positive definite)."""
        R = self._measurement._R
        assert R is not None                        # one (3, 3) covariance: _check_R refuses any other
        return R

    @R.setter
    def R(self, value: ArrayLike | None) -> None:
        self._measurement = DepthSensors(value)
        self._check_R()


class PitchManeuverModel(DepthSpeedPitchModel):
    r"""One mode of a maneuver in one object: :class:`PitchManeuver` and :class:`DepthSensors`.

    The pitch relaxes towards ``pitch_target`` with time constant :math:`\tau` before each step of paper C's model
    (equations in :class:`PitchManeuver`); a list of such models (cruise, dive, climb) is the mode set of
    :class:`~uwtutor.filters.particle.multiple_model.MultipleModelParticleFilter`.

    Parameters
    ----------
    pitch_target : float, optional
        :math:`\phi^*` [rad]; 0 by default.
    time_constant : float, optional
        :math:`\tau` [s] (> 0); 2 s by default.
    T, process_std, R
        As in :class:`DepthSpeedPitchModel`.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.models import PitchManeuverModel
    >>> dive = PitchManeuverModel(
    ...     pitch_target=0.3,
    ...     time_constant=1.0,
    ...     T=0.05,
    ...     process_std=[0.0, 0.0, 0.0],
    ... )
    >>> dive.motion.f(np.array([[10.0, 2.0, 0.0]]), None, 0).round(5)
    array([[10.00146,  2.     ,  0.01463]])
    """

    motion: PitchManeuver

    def __init__(self, pitch_target: float = 0.0, time_constant: float = 2.0, T: float = 0.05,
                 process_std: ArrayLike | None = None, R: ArrayLike | None = None) -> None:
        self._maneuver = (pitch_target, time_constant)
        super().__init__(T=T, process_std=process_std, R=R)

    def _motion(self, T: float, process_std: ArrayLike | None) -> PitchManeuver:
        target, tau = self._maneuver
        return PitchManeuver(pitch_target=target, time_constant=tau, T=T, process_std=process_std)

    @property
    def pitch_target(self) -> float:
        """:math:`\\phi^*` [rad]."""
        return self.motion.pitch_target

    @property
    def time_constant(self) -> float:
        """:math:`\\tau` [s]."""
        return self.motion.time_constant
