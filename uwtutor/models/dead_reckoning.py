r"""Dead reckoning as a motion model: the vehicle moves by the displacement its own sensors measured.

Between two ranging epochs the vehicle's horizontal position moves by the dead-reckoned (DR) displacement
:math:`u_k = [\Delta x_k, \Delta y_k]`, itself in error by the DR noise :math:`w_k`:

.. math::

    p_k = p_{k-1} + u_k + w_k, \qquad w_k \sim N(0, Q).

The state may carry more than the position: any further components (a range bias, paper A; a current,
paper B) are kept by the prediction and get their own rows of :math:`Q` (a random walk when their variance is
positive, a constant when it is zero). The position is always ``x[..., :2]``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .._validate import as_covariance
from .base import MotionModel

__all__ = ["DeadReckoning"]


class DeadReckoning(MotionModel):
    r"""Position moved by the DR displacement; further state components constant up to their process noise.

    .. math::

        f(x, u) = x + [u_x, u_y, 0, \dots, 0]^T, \qquad F = I_n.

    Parameters
    ----------
    Q : array_like, shape (n, n) or (K, n, n)
        Process noise covariance per step, positive semi-definite; its size sets the state size ``n >= 2``. One
        per step, ``(K, n, n)``, for a DR whose error changes along the run (step ``k`` uses ``Q[k]``).

    Examples
    --------
    A position plus a range bias (paper A's state):

    >>> import numpy as np
    >>> from uwtutor.models import DeadReckoning
    >>> dr = DeadReckoning(Q=np.diag([0.25, 0.25, 0.01]))
    >>> dr.n, dr.f(np.array([[100.0, 0.0, 3.0]]), np.array([2.0, 1.0]), 0)
    (3, array([[102.,   1.,   3.]]))
    """

    covariances_checked = True      # Q is checked when the model is made (one, or one per step)

    def __init__(self, Q: ArrayLike) -> None:
        self._Q = as_covariance("Q", Q, allow_singular=True)
        if self._Q.ndim not in (2, 3) or self._Q.shape[-1] < 2:
            raise ValueError("Q must be one (n, n) matrix with n >= 2 (the position comes first), or one per step "
                             f"(K, n, n); got shape {self._Q.shape}")
        self.n = self._Q.shape[-1]
        self._I = np.eye(self.n)

    @property
    def n_steps(self) -> int | None:
        """Number of steps a per-step ``Q`` covers (None for one ``Q`` for every step)."""
        return self._Q.shape[0] if self._Q.ndim == 3 else None

    def f(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        if u is None:
            return x.copy()
        u = np.asarray(u, dtype=float)
        if u.shape[-1:] != (2,):      # [dx, dy]: a (.., 1) displacement would be broadcast onto both axes
            raise ValueError(f"u must be the DR displacement [dx, dy] of the step (last axis of length 2); got "
                             f"shape {u.shape}")
        out = x.copy()
        out[..., :2] += u
        return out

    def F(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        return self._I

    def Q(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        if self._Q.ndim == 2:
            return self._Q
        if not 0 <= k < len(self._Q):
            raise IndexError(f"Q has {len(self._Q)} per-step matrices; step {k} is beyond them. Give one per step "
                             "of the run")
        return self._Q[k]
