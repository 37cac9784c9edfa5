r"""Paper C's depth, speed and pitch kinematics: one copy, used by its EKF and by its particle filters.

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
:math:`G Q G^T`). The sensors measure the state itself (:class:`~uwtutor.models.linear.DirectMeasurement`).

References
----------
Li Ting, Zhao Dexin, Huang Zhiping and Su Shaojing (2013). A method for self-estimating the depth of maneuvering
AUV based on the grey particle filter. *Journal of National University of Defense Technology* 35(5), 185-190
(paper C), eqs. (4)-(6).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._validate import as_finite, as_nonnegative, as_positive, as_scalar
from .base import MotionModel
from .noise import per_run_generators, standard_normal_per_run

__all__ = [
    "DEFAULT_PROCESS_STD",
    "DEFAULT_SENSOR_STD",
    "depth_speed_pitch_kinematics",
    "depth_speed_pitch_jacobian",
    "DepthSpeedPitch",
]

#: Default standard deviations of :math:`u^z, u^v, u^\phi` per step, in m, m/s and rad; illustrative values
#: (paper C's printed process covariance is not a covariance matrix; its diagonal is in :mod:`uwtutor.scenarios.paper_c`).
DEFAULT_PROCESS_STD = np.array([0.01, 0.01, 0.0035])
DEFAULT_PROCESS_STD.flags.writeable = False

#: Default sensor noise standard deviations in m, m/s and rad, from paper C's
#: :math:`R = \mathrm{diag}(0.2^2, 5^2, 0.5^2)` (printed without units, read as 0.2 m, 5 cm/s and 0.5 deg).
DEFAULT_SENSOR_STD = np.array([0.2, 0.05, np.radians(0.5)])
DEFAULT_SENSOR_STD.flags.writeable = False


def depth_speed_pitch_kinematics(s: Any, T: float, axis: int = -1, *, out: np.ndarray | None = None) -> np.ndarray:
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

    lead = (slice(None),) * ax                                   # index component i as lead + (i,)
    dz = np.sin(s[lead + (2,)])
    dz *= s[lead + (1,)]
    dz *= T
    out[lead + (0,)] += dz
    return out


def depth_speed_pitch_jacobian(s: Any, T: float) -> np.ndarray:
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

    :math:`x_k = g(x_{k-1} + u_k)`, :math:`u_k \sim N(0, \mathrm{diag}(\sigma^2))` (equations in the module
    docstring); for an EKF :math:`f = g`, :math:`F = G` and :meth:`Q` returns :math:`G\, \mathrm{diag}(\sigma^2)
    G^T`, so that the engine's :math:`F P F^T + Q` is paper C's :math:`G (P + Q) G^T`.

    Parameters
    ----------
    T : float, optional
        Sampling interval [s]; 0.05 s in paper C.
    process_std : array_like, shape (3,), optional
        Standard deviations :math:`\sigma` of :math:`u^z, u^v, u^\phi` per step [m, m/s, rad];
        :data:`DEFAULT_PROCESS_STD` by default.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.models import DepthSpeedPitch
    >>> motion = DepthSpeedPitch(T=0.5, process_std=[0.0, 0.0, 0.0])
    >>> motion.f(np.array([[10.0, 2.0, np.pi / 6]]), None, 0)
    array([[10.5       ,  2.        ,  0.52359878]])
    >>> # no noise: g(x)
    >>> motion.sample(np.array([[10.0, 2.0, np.pi / 6]]), np.random.default_rng(0))
    array([[10.5       ,  2.        ,  0.52359878]])
    """

    n = 3

    def __init__(self, T: float = 0.05, process_std: Any = None) -> None:
        self.T = float(as_positive("T", T))
        std = DEFAULT_PROCESS_STD if process_std is None else process_std
        self.process_std = as_nonnegative("process_std", std, shape=(3,)).copy()
        self.process_cov = np.diag(self.process_std**2)

    def f(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        if u is not None:
            raise ValueError("the depth/speed/pitch model takes no control input: predict without u")
        return _kinematics(np.asarray(x, dtype=float), self.T)

    def F(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        return _jacobian(np.asarray(x, dtype=float), self.T)

    def Q(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        G = _jacobian(np.asarray(x, dtype=float), self.T)
        return G @ self.process_cov @ np.swapaxes(G, -1, -2)

    def sample_rows(self, rows: np.ndarray, rng: Any) -> np.ndarray:
        r"""Draw :math:`x_k = g(x_{k-1} + u_k)` for states stored component-major, ``rows`` of shape (M, 3, N).

        ``rng`` is one Generator per run (a sequence of ``M``; a Generator when ``M = 1``); run ``m`` draws its
        ``(3, N)`` noise from its own generator. Returns a new (M, 3, N) array.
        """
        M = rows.shape[0]
        rngs = rng if type(rng) is tuple and len(rng) == M else per_run_generators(rng, M, spawn=False)
        noise = standard_normal_per_run(rngs, rows.shape[1:])      # rows u^z, u^v, u^phi of every run
        noise *= self.process_std[:, None]
        s = np.add(rows, noise, out=noise)                       # z + u^z, v_k = v + u^v, phi_k = phi + u^phi
        return _kinematics(s, self.T, axis=-2, out=s)

    def sample(self, x: Any, rng: Any) -> np.ndarray:
        r"""Draw the next states of states ``x`` of shape (..., 3): :math:`g(x + u)`, :math:`u \sim N(0, Q)`.

        ``x`` of shape (N, 3) draws from the Generator ``rng``; (M, N, 3) from one generator per run.
        """
        x = np.asarray(x, dtype=float)
        single = x.ndim <= 2
        batch = x.reshape((1,) + x.shape[-2:] if x.ndim == 2 else ((1, 1, 3) if x.ndim == 1 else x.shape))
        out = np.swapaxes(self.sample_rows(np.swapaxes(batch, -1, -2), rng), -1, -2)
        return out.reshape(x.shape) if single else out
