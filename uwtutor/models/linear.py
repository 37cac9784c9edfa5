r"""Linear-Gaussian motion and measurement models: :math:`x_k = F x_{k-1} + B u_k + w_k`, :math:`z_k = H x_k + v_k`.

On these models the extended Kalman filter *is* the Kalman filter, which is how the contract test checks every
Gaussian filter of the library against :class:`~uwtutor.filters.kalman.KalmanFilter`. :class:`DirectMeasurement`
(:math:`H` selects some state components) is the "measure the state itself" case, e.g. chapter 1's range
sequence or paper E's cascade filter on position fixes.
"""

from __future__ import annotations

import copy
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .._validate import as_covariance, as_finite, as_int
from .base import MeasurementModel, MotionModel

__all__ = ["LinearMotion", "LinearMeasurement", "DirectMeasurement"]


class LinearMotion(MotionModel):
    r"""Linear motion :math:`x_k = F x_{k-1} + B u_k + w_k`, :math:`w_k \sim N(0, Q)`.

    Parameters
    ----------
    F : array_like, shape (n, n)
        State transition matrix.
    Q : array_like, shape (n, n)
        Process noise covariance (positive semi-definite).
    B : array_like, shape (n, p), optional
        Input matrix; ``None``: the model takes no input.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.models import LinearMotion
    >>> cv = LinearMotion(F=[[1.0, 1.0], [0.0, 1.0]], Q=np.diag([0.0, 0.01]))
    >>> cv.f(np.array([[10.0, 2.0]]), None, 0)
    array([[12.,  2.]])
    """

    def __init__(self, F: ArrayLike, Q: ArrayLike, B: ArrayLike | None = None) -> None:
        self._F = as_finite("F", F, ndim=2, max_abs=1e75)     # F P F^T stays finite for P up to 1e150
        n = self._F.shape[0]
        if self._F.shape != (n, n):
            raise ValueError(f"F must be square, shape (n, n); got {self._F.shape}")
        self.n = n
        self._Q = as_covariance("Q", Q, n, allow_singular=True)
        if self._Q.ndim != 2:
            raise ValueError(f"Q must be one ({n}, {n}) matrix; got shape {self._Q.shape}")
        self._B = None if B is None else as_finite("B", B, ndim=2)
        if self._B is not None and self._B.shape[0] != n:
            raise ValueError(f"B must have {n} rows to match F; got shape {self._B.shape}")

    def f(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        out = x @ self._F.T
        if u is not None:
            if self._B is None:
                raise ValueError("u was given but this motion model has no input matrix B")
            out = out + np.asarray(u, dtype=float) @ self._B.T
        return out

    def F(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        return self._F

    def Q(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        return self._Q


class LinearMeasurement(MeasurementModel):
    r"""Linear measurement :math:`z_k = H x_k + v_k`, :math:`v_k \sim N(0, R_k)`.

    Parameters
    ----------
    H : array_like, shape (m, n)
        Measurement matrix.
    R : array_like
        Measurement noise covariance (positive definite): ``(m, m)`` (a scalar for m = 1), or one per step or per
        run and step, as :class:`~uwtutor.models.range.NoiseSchedule` reads them (``(K, m, m)``, ``(K,)`` or
        ``(K, m)`` variances, ``(M, K, m, m)``).

    Examples
    --------
    >>> from uwtutor.models import LinearMeasurement
    >>> LinearMeasurement(H=[[1.0, 0.0]], R=4.0).R(None, 0)
    array([[4.]])
    """

    def __init__(self, H: ArrayLike, R: ArrayLike) -> None:
        from .range import NoiseSchedule

        self._H = as_finite("H", H, ndim=2)
        self.m, self.n = self._H.shape
        R_arr = as_finite("R", R)           # a clear message for text or a dict; NoiseSchedule checks the rest
        if R_arr.ndim == 2 and R_arr.shape != (self.m, self.m) and not (R_arr.shape[1] == self.m and self.m > 1):
            raise ValueError(f"R must be one ({self.m}, {self.m}) matrix to match H (or one per step); got shape "
                             f"{R_arr.shape}")
        self._noise = NoiseSchedule("R", R, self.m)
        #: The one covariance of every step, ``(m, m)`` (None for a per-step or per-run ``R``).
        self._R = self._noise.constant

    @property
    def n_steps(self) -> int | None:
        """Number of steps a per-step ``R`` covers (None for one ``R``)."""
        return self._noise.n_steps

    @property
    def n_runs(self) -> int | None:
        """Number of runs of a per-run ``R`` (None when shared by every run)."""
        return self._noise.n_runs

    def select_runs(self, runs: Any) -> "LinearMeasurement":
        """The same model for the runs ``runs`` of a per-run ``R`` (a particle filter takes its runs block by
        block)."""
        out = copy.copy(self)
        out._noise = self._noise.select_runs(runs)
        return out

    def h(self, x: np.ndarray, k: int) -> np.ndarray:
        return x @ self._H.T

    def H(self, x: np.ndarray, k: int) -> np.ndarray:
        return np.broadcast_to(self._H, x.shape[:-1] + self._H.shape)

    def R(self, x: np.ndarray | None, k: int) -> np.ndarray:      # x unused (None will do): R is not the state's
        return self._R if self._R is not None else self._noise.at(k)


class DirectMeasurement(LinearMeasurement):
    r"""Measure some components of the state directly: :math:`z = x[\text{indices}] + v`.

    Parameters
    ----------
    n : int
        Size of the state.
    indices : sequence of int
        The measured components, in the order of the measurement vector.
    R : array_like, shape (m, m), or a scalar for m = 1
        Measurement noise covariance (positive definite), ``m = len(indices)``.

    Examples
    --------
    >>> from uwtutor.models import DirectMeasurement
    >>> DirectMeasurement(n=4, indices=[0, 1], R=[[4.0, 0.0], [0.0, 4.0]])._H
    array([[1., 0., 0., 0.],
           [0., 1., 0., 0.]])

    Measuring the whole state in order, :math:`h(x)` is ``x`` itself (no copy, no product):

    >>> import numpy as np
    >>> x = np.zeros((1, 2))
    >>> DirectMeasurement(n=2, indices=[0, 1], R=1.0).h(x, 0) is x
    True
    """

    def __init__(self, n: int, indices: Any, R: ArrayLike) -> None:
        n = as_int("n", n, minimum=1)
        idx = [as_int("indices", i, minimum=0) for i in np.atleast_1d(np.asarray(indices)).tolist()]
        if not idx or max(idx) >= n or len(set(idx)) != len(idx):
            raise ValueError(f"indices must be distinct state components in 0..{n - 1}; got {idx}")
        H = np.zeros((len(idx), n))
        H[np.arange(len(idx)), idx] = 1.0
        super().__init__(H, R)
        self.indices = np.array(idx)
        self._identity = idx == list(range(n))

    def h(self, x: np.ndarray, k: int) -> np.ndarray:
        return x if self._identity else x[..., self.indices]
