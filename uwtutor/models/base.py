r"""The two kinds of model every Kalman-family filter of ``uwtutor`` is made of.

A filter never knows what it filters: it asks a **motion model** how the state moves between two epochs and a
**measurement model** what a measurement should be, and both answer for a whole batch of Monte Carlo runs at
once. A new method of the book is a pair of models plus a filter family, never a new loop.

Shapes inside the engine always carry a leading runs axis ``M`` (a single run is ``M = 1``):

========================  =====================================================================================
``x``                     states, ``(M, n)``
``u``                     the input of one step, ``(p,)`` (shared by every run) or ``(M, p)``, or ``None``
``k``                     the 0-based index of the step (used by models with per-epoch parameters,
                          e.g. a beacon that moves)
``F``, ``Q``              ``(n, n)`` (shared) or ``(M, n, n)``
``z``, ``h(x)``           ``(M, m)``
``H``, ``R``              ``(M, m, n)``; ``(m, m)`` or ``(M, m, m)``
========================  =====================================================================================

A motion model with a noise map :math:`W` (noise entering through some other space, as in paper B) returns
:math:`W Q W^T` from :meth:`MotionModel.Q`; a measurement model with a noise map :math:`V` returns
:math:`V R V^T` from :meth:`MeasurementModel.R`. A filter asks for :math:`f, F, Q` at once through
:meth:`MotionModel.linearize` and for :math:`h, H` through :meth:`MeasurementModel.linearize`; override them when
the pieces share work.

A measurement vector may have components missing at a step (NaN in ``z``, e.g. a beacon that did not answer):
the filters update with the components present, and a model may return NaN for the components that are not
measured (its Jacobian row, its prediction, its noise).
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["MotionModel", "MeasurementModel"]


class MotionModel:
    r"""How the state moves in one step: :math:`x_k = f(x_{k-1}, u_k) + w_k`, :math:`w_k \sim N(0, Q_k)`.

    Subclasses set ``n`` and implement :meth:`f`, :meth:`F` and :meth:`Q`.

    Attributes
    ----------
    n : int
        Size of the state.
    """

    n: int = 0

    def f(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        """The predicted states ``(M, n)`` of the states ``x`` ``(M, n)`` moved by the input ``u`` of step ``k``."""
        raise NotImplementedError

    def F(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        r"""The Jacobian :math:`\partial f / \partial x` at ``x``: ``(n, n)`` or ``(M, n, n)``."""
        raise NotImplementedError

    def Q(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        """The process noise covariance of step ``k`` in state space: ``(n, n)`` or ``(M, n, n)``."""
        raise NotImplementedError

    def linearize(self, x: np.ndarray, u: Any, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``f``, ``F`` and ``Q`` of one step at once (what a filter's prediction needs); override it when the three
        share work (a heading's sine and cosine), as :class:`~uwtutor.models.odometry.OdometryMotion` does."""
        F = self.F(x, u, k)
        Q = self.Q(x, u, k)
        return self.f(x, u, k), F, Q

    def difference(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        r"""The difference ``a - b`` of two states ``(..., n)``; a model with an angle in its state wraps it (the
        smoother's correction must not see a heading jump by :math:`2\pi` where it crosses :math:`\pm\pi`)."""
        return a - b

    def normalize(self, x: np.ndarray) -> np.ndarray:
        """A state ``(..., n)`` put back in its canonical range (an angle wrapped); the identity by default."""
        return x


class MeasurementModel:
    r"""What a measurement should be: :math:`z_k = h_k(x_k) + v_k`, :math:`v_k \sim N(0, R_k)`.

    Subclasses set ``m`` and ``n`` and implement :meth:`h`, :meth:`H` and :meth:`R`; a model whose
    Jacobian is undefined somewhere (the range on the beacon) overrides :meth:`linearize` and reports it there.

    Attributes
    ----------
    m : int
        Size of one measurement.
    n : int
        Size of the state the model reads.
    """

    m: int = 1
    n: int = 0

    def h(self, x: np.ndarray, k: int) -> np.ndarray:
        """The predicted measurements ``(M, m)`` of the states ``x`` ``(M, n)`` at step ``k``."""
        raise NotImplementedError

    def H(self, x: np.ndarray, k: int) -> np.ndarray:
        r"""The Jacobian :math:`\partial h / \partial x` at ``x``: ``(M, m, n)``."""
        raise NotImplementedError

    def R(self, x: np.ndarray, k: int) -> np.ndarray:
        """The measurement noise covariance at step ``k``: ``(m, m)`` or ``(M, m, m)``."""
        raise NotImplementedError

    def linearize(self, x: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Predicted measurement ``(M, m)``, Jacobian ``(M, m, n)`` and a mask ``(M,)`` of the runs where both are
        defined -- or ``(M, m)``, component by component. Where the mask is False the filter skips the update of
        that run (or component) and warns. A component that is not measured at step ``k`` may be NaN here: the
        filters never use it."""
        return self.h(x, k), self.H(x, k), np.ones(x.shape[0], dtype=bool)

    def residual(self, z: np.ndarray, z_pred: np.ndarray) -> np.ndarray:
        """The innovation ``z - z_pred`` (override for angles or other wrapped quantities)."""
        return z - z_pred
