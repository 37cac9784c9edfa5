r"""The range to one beacon as a measurement model, the beacon fixed or moving.

The horizontal range from the vehicle at :math:`p = x[:2]` to the beacon at :math:`b_k` and its Jacobian are

.. math::

    h_k(x) = \lVert p - b_k \rVert \;(+\, x_j), \qquad
    H_k = \Big[\frac{(p - b_k)^T}{\lVert p - b_k \rVert},\; 0, \dots, 0 \;(,\, 1 \text{ at } j)\Big],

the first two entries of :math:`H_k` being the unit line of sight from the beacon to the vehicle, and the optional
:math:`x_j` a range bias carried in the state (paper A). A moving beacon -- a mother ship (paper E), a
leader AUV (paper B), the other boat of a lake trial (paper A) -- is given as one position per step.

.. rubric:: On the beacon

At :math:`p = b_k` the range is not differentiable and the line of sight is 0/0. :func:`line_of_sight` is the
library's one computation of it, and its one policy: there the range carries no information about the
direction, so its Jacobian row is zero and a warning says so. A filter then skips that run's update (predict
only; :class:`~uwtutor.errors.BeaconSingularityWarning`), a bound gives that range no information
(:class:`~uwtutor.errors.UnobservableWarning`), and a least-squares fix refuses a linearization point placed on a
beacon (an error: the point is the caller's choice). A measured range of zero from a prediction *near* the
beacon is an ordinary update.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._validate import as_covariance, as_finite, as_int
from .base import MeasurementModel

__all__ = ["RangeToBeacon", "MultiplicativeRange", "line_of_sight"]


def line_of_sight(positions: np.ndarray, beacon: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""Ranges, unit lines of sight and a "defined" mask from beacon(s) to positions.

    Parameters
    ----------
    positions : ndarray, shape (..., 2)
        Horizontal positions :math:`p`.
    beacon : ndarray, shape (2,) or broadcastable to ``positions``
        Beacon positions :math:`b`.

    Returns
    -------
    r : ndarray, shape (...)
        :math:`\lVert p - b \rVert`.
    los : ndarray, shape (..., 2)
        :math:`(p - b) / \lVert p - b \rVert`; zero where undefined.
    defined : ndarray of bool, shape (...)
        False where :math:`p = b` exactly.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.models.range import line_of_sight
    >>> r, los, ok = line_of_sight(np.array([[3.0, 4.0], [0.0, 0.0]]), np.zeros(2))
    >>> r, los, ok
    (array([5., 0.]), array([[0.6, 0.8],
           [0. , 0. ]]), array([ True, False]))
    """
    d = positions - beacon
    r = np.hypot(d[..., 0], d[..., 1])
    defined = r != 0.0                   # a NaN position stays NaN (it is not "on the beacon")
    safe = np.where(defined, r, 1.0)
    los = d / safe[..., None]
    return r, los, defined


class RangeToBeacon(MeasurementModel):
    r"""Horizontal range to a fixed or moving beacon, optionally plus a bias state (equations in the module).

    Parameters
    ----------
    beacon : array_like, shape (2,), (K, 2) or (M, K, 2)
        Beacon position: fixed, one per step ``k`` (shared by every run), or one per run and step.
    R : float or array_like, shape (1, 1)
        Range noise variance (> 0) [m^2].
    n : int, optional
        Size of the state (default 2); the position is ``x[..., :2]``.
    bias_index : int, optional
        Index of a state component added to the range (a range bias, paper A); ``None`` for none.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.models import RangeToBeacon
    >>> ship = np.array([[0.0, 0.0], [10.0, 0.0]])          # the beacon moves 10 m east between two steps
    >>> model = RangeToBeacon(ship, R=4.0)
    >>> x = np.array([[30.0, 40.0]])
    >>> model.h(x, 0), model.h(x, 1)
    (array([[50.]]), array([[44.72135955]]))
    >>> RangeToBeacon((0.0, 0.0), R=4.0, n=3, bias_index=2).H(np.array([[3.0, 4.0, 1.5]]), 0)
    array([[[0.6, 0.8, 1. ]]])
    """

    m = 1

    def __init__(self, beacon: Any, R: Any, *, n: int = 2, bias_index: int | None = None) -> None:
        b = as_finite("beacon", beacon, ndim=(1, 2, 3), nonempty=True, max_abs=1e150)
        if b.shape[-1] != 2:
            raise ValueError(f"beacon must hold horizontal positions [x, y]: shape (2,), (K, 2) or (M, K, 2); "
                             f"got {b.shape}")
        self.beacon = b
        self.n = as_int("n", n, minimum=2)
        R_arr = as_covariance("R", R, 1)
        if R_arr.shape != (1, 1):
            raise ValueError(f"R must be the range variance, a scalar or a 1x1 matrix; got shape {R_arr.shape}")
        self._R = R_arr
        if bias_index is not None:
            bias_index = as_int("bias_index", bias_index, minimum=2)
            if bias_index >= self.n:
                raise ValueError(f"bias_index must index the state (0..{self.n - 1}); got {bias_index}")
        self.bias_index = bias_index

    @property
    def n_steps(self) -> int | None:
        """Number of steps the beacon path covers (``None`` for a fixed beacon)."""
        return None if self.beacon.ndim == 1 else self.beacon.shape[-2]

    @property
    def n_runs(self) -> int | None:
        """Number of runs of a per-run beacon path (``None`` when shared by every run)."""
        return self.beacon.shape[0] if self.beacon.ndim == 3 else None

    def beacon_at(self, k: int) -> np.ndarray:
        """The beacon position(s) of step ``k``: ``(2,)`` or ``(M, 2)``."""
        if self.beacon.ndim == 1:
            return self.beacon
        K = self.beacon.shape[-2]
        if not 0 <= k < K:
            raise IndexError(f"the beacon path has {K} positions; step {k} is beyond it. Give one beacon "
                             "position per step of the run")
        return self.beacon[k] if self.beacon.ndim == 2 else self.beacon[:, k]

    def linearize(self, x: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        r, los, defined = line_of_sight(x[..., :2], self.beacon_at(k))
        H = np.zeros(x.shape[:-1] + (1, self.n))
        H[..., 0, :2] = los
        z = r[..., None]
        if self.bias_index is not None:
            H[..., 0, self.bias_index] = 1.0
            z = z + x[..., self.bias_index:self.bias_index + 1]
        return z, H, defined

    def h(self, x: np.ndarray, k: int) -> np.ndarray:
        return self.linearize(x, k)[0]

    def H(self, x: np.ndarray, k: int) -> np.ndarray:
        return self.linearize(x, k)[1]

    def R(self, x: np.ndarray, k: int) -> np.ndarray:
        return self._R


class MultiplicativeRange(RangeToBeacon):
    r"""A range scaled by a random factor, as a sound-speed error makes it (papers A and D):

    .. math::

        z_k = \gamma_k \lVert p - b_k \rVert + v_k, \qquad \gamma_k \sim N(\mu_\gamma, \sigma_\gamma^2), \quad
        v_k \sim N(0, R),

    linearized at the prediction as :math:`h = \mu_\gamma r`, :math:`H = \mu_\gamma\,(p - b)^T / r` and a noise
    variance :math:`\sigma_\gamma^2 r^2 + R` evaluated at the predicted range :math:`r` (the multiplicative part
    grows with the range). This is the plain EKF for multiplicative noise; paper D's fading filter
    (:func:`uwtutor.filters.fading.fading_ekf`) evaluates :math:`E[r^2]` from moments it carries instead, and adds
    the fading factor.

    Parameters
    ----------
    beacon : array_like, shape (2,), (K, 2) or (M, K, 2)
        Beacon position(s), as for :class:`RangeToBeacon`.
    R : float
        Additive range noise variance (> 0) [m^2].
    mu_gamma : float
        Mean of the range factor (> 0), e.g. :func:`uwtutor.acoustics.range_factor`'s.
    sigma_gamma : float
        Its standard deviation (>= 0).
    n : int, optional
        Size of the state (default 2).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.models import MultiplicativeRange
    >>> model = MultiplicativeRange((0.0, 0.0), R=0.49, mu_gamma=0.98, sigma_gamma=1 / 1500)
    >>> x = np.array([[3000.0, 4000.0]])
    >>> model.h(x, 0), model.R(x, 0)
    (array([[4900.]]), array([[[11.60111111]]]))
    """

    def __init__(self, beacon: Any, R: Any, mu_gamma: Any, sigma_gamma: Any, *, n: int = 2) -> None:
        super().__init__(beacon, R, n=n)
        mu = float(as_finite("mu_gamma", mu_gamma, ndim=0))
        sigma = float(as_finite("sigma_gamma", sigma_gamma, ndim=0))
        if not mu > 0.0:
            raise ValueError(f"mu_gamma must be > 0 (the mean range factor, about 1); got {mu:g}")
        if sigma < 0.0:
            raise ValueError(f"sigma_gamma must be >= 0 (a standard deviation); got {sigma:g}")
        self.mu_gamma, self.sigma_gamma = mu, sigma

    def linearize(self, x: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        z, H, defined = super().linearize(x, k)
        return self.mu_gamma * z, self.mu_gamma * H, defined

    def R(self, x: np.ndarray, k: int) -> np.ndarray:
        r, _, _ = line_of_sight(x[..., :2], self.beacon_at(k))
        return (self.sigma_gamma**2 * r**2 + self._R[0, 0])[:, None, None]
