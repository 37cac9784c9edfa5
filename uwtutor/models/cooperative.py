r"""Paper B's models: dead reckoning with an unknown current, through a process-noise map, and the squared-range pair
to a moving leader, through a measurement-noise map; plus the plain single range to the leader for comparison.

State :math:`\mathbf{x}_k = [x_k, y_k, U_x, U_y]^\mathsf{T}`: the follower's position and the current. Over one
cooperative interval :math:`\delta t` the follower moves by its dead-reckoned displacement (paper B's motion radius
vector) :math:`\mathbf{u}_k` through the water and by :math:`\delta t\,\mathbf{U}` with the water (paper B, eq. 2):

.. math::

    \mathbf{p}_{k+1} = \mathbf{p}_k + \mathbf{u}_k + \delta t\,\mathbf{U}_k, \qquad \mathbf{U}_{k+1} = \mathbf{U}_k .

Paper B lets the noise enter through the 6-vector :math:`\mathbf{w} = [x, y, \Delta x, \Delta y, U_x, U_y]` with
the map :math:`\mathbf{G} = \partial f / \partial \mathbf{w}` (its :math:`\mathbf{W}`, eq. 10), so the state-space
process noise is :math:`\mathbf{G}\mathbf{Q}\mathbf{G}^\mathsf{T}`. Its measurement is the pair of squared ranges
from the follower to the leader's broadcast positions at the two ends of the interval,
:math:`\mathbf{z}_{k+1} = [r_k^2, r_{k+1}^2]` (eq. 3), with noise through the 10-vector
:math:`\mathbf{v} = [x, y, x^\mathrm{M}_k, y^\mathrm{M}_k, x^\mathrm{M}_{k+1}, y^\mathrm{M}_{k+1}, \Delta x, \Delta y,
U_x, U_y]` and the map :math:`\mathbf{L} = \partial h / \partial \mathbf{v}` (its :math:`\mathbf{V}`, eq. 12):
:math:`\mathbf{L}\mathbf{R}\mathbf{L}^\mathsf{T}`.

=============================  =======================================================================================
``CooperativeMotion``          :math:`f`, :math:`\mathbf{F}` (eq. 9), :math:`\mathbf{G}\mathbf{Q}\mathbf{G}^\mathsf{T}`
``SquaredRangePair``           :math:`h`, :math:`\mathbf{H}` and :math:`\mathbf{L}\mathbf{R}\mathbf{L}^\mathsf{T}`, as a
                               function of the state *after* the move (``literal=False``), or with paper B's
                               Jacobians evaluated at the predicted state as printed (``literal=True``)
``leader_range``               the single range :math:`r_{k+1} = \lVert \mathbf{p}_{k+1} - \mathbf{p}^\mathrm{M}_{k+1}
                               \rVert` with a scalar variance (the plain range-only EKF of chapter 4, moving beacon)
=============================  =======================================================================================

**One consistent formulation.** The engine updates the *predicted* state :math:`\mathbf{x}_{k+1}`, so the pair is
written as a function of it, the position at the start of the interval being
:math:`\mathbf{p}_k = \mathbf{p}_{k+1} - \mathbf{u}_k - \delta t\,\mathbf{U}`:

.. math::

    h(\mathbf{x}_{k+1}) = \begin{bmatrix} \lVert \mathbf{s}_k \rVert^2 \\ \lVert \mathbf{s}_{k+1} \rVert^2
    \end{bmatrix},
    \quad \mathbf{s}_k = \mathbf{p}_{k+1} - \mathbf{u}_k - \delta t\,\mathbf{U} - \mathbf{p}^\mathrm{M}_k,
    \quad \mathbf{s}_{k+1} = \mathbf{p}_{k+1} - \mathbf{p}^\mathrm{M}_{k+1},
    \qquad
    \mathbf{H} = \begin{bmatrix} 2\mathbf{s}_k^\mathsf{T} & -2\,\delta t\,\mathbf{s}_k^\mathsf{T} \\
                                 2\mathbf{s}_{k+1}^\mathsf{T} & \mathbf{0} \end{bmatrix},

the chain rule applied to paper B's :math:`\partial h / \partial \mathbf{x}_k` (eq. 11). Evaluated at the
prediction, :math:`\mathbf{s}_k` and :math:`\mathbf{s}_{k+1}` are the vectors paper B's eqs. (11)-(12) contain when
those
are evaluated at the previous estimate :math:`\hat{\mathbf{x}}_k`; :math:`\mathbf{L}` is paper B's :math:`\mathbf{V}`
with these :math:`\mathbf{s}_k`, :math:`\mathbf{s}_{k+1}`. The literal reading substitutes the predicted state for
:math:`\mathbf{x}_k` in eqs. (11)-(12): :math:`\mathbf{s}_k^\mathrm{lit} = \mathbf{p}_{k+1} - \mathbf{p}^\mathrm{M}_k`,
:math:`\mathbf{s}_{k+1}^\mathrm{lit} = \mathbf{p}_{k+1} + \mathbf{u}_k + \delta t\,\mathbf{U} -
\mathbf{p}^\mathrm{M}_{k+1}`
(the move counted twice) and a current column on the second row instead of the first.

Shapes: a state batch is ``(M, 4)``; the leader's positions ``(K + 1, 2)`` or ``(M, K + 1, 2)`` and the
displacements ``(K, 2)`` or ``(M, K, 2)`` are held by the model and indexed by the step ``k`` (step ``k`` goes from
epoch ``k`` to epoch ``k + 1``).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validate import (MAX_COORDINATE, as_covariance, as_finite, as_flag, as_positive, as_scalar,
                         check_same_shape, common_runs)
from .base import MeasurementModel, MotionModel
from .blocks import BlockMotion, Current, Position
from .range import RangeToBeacon

__all__ = ["CooperativeMotion", "SquaredRangePair", "leader_range", "process_noise_map", "measurement_noise_map"]


def _interval(dt: Any) -> float:
    return float(as_positive("dt", dt, ndim=0, max_abs=1e75))      # dt^2 times a variance stays finite


def process_noise_map(dt: Any) -> NDArray[np.float64]:
    r"""Paper B's process-noise map :math:`\mathbf{G}` (its :math:`\mathbf{W}`, eq. 10), shape (4, 6).

    .. math::

        \mathbf{G} = \begin{bmatrix} 1 & 0 & 1 & 0 & \delta t & 0 \\ 0 & 1 & 0 & 1 & 0 & \delta t \\
                                     0 & 0 & 0 & 0 & 1 & 0 \\ 0 & 0 & 0 & 0 & 0 & 1 \end{bmatrix}

    Examples
    --------
    >>> from uwtutor.models.cooperative import process_noise_map
    >>> process_noise_map(8.0)[0]
    array([1., 0., 1., 0., 8., 0.])
    """
    d = _interval(dt)
    G = np.zeros((4, 6))
    G[0, 0] = G[1, 1] = G[0, 2] = G[1, 3] = 1.0
    G[0, 4] = G[1, 5] = d
    G[2, 4] = G[3, 5] = 1.0
    return G


def measurement_noise_map(a: ArrayLike, c: ArrayLike, dt: Any) -> NDArray[np.float64]:
    r"""Paper B's measurement-noise map :math:`\mathbf{L}` (its :math:`\mathbf{V}`, eq. 12) for the vectors
    :math:`\mathbf{s}_k` (the follower relative to the leader at epoch :math:`k`) and :math:`\mathbf{s}_{k+1}` (at
    epoch :math:`k + 1`).

    Columns follow :math:`\mathbf{v} = [x, y, x^\mathrm{M}_k, y^\mathrm{M}_k, x^\mathrm{M}_{k+1}, y^\mathrm{M}_{k+1},
    \Delta x, \Delta y, U_x, U_y]`:

    .. math::

        \mathbf{L} = \begin{bmatrix} 2\mathbf{s}_k^\mathsf{T} & -2\mathbf{s}_k^\mathsf{T} & \mathbf{0} & \mathbf{0}
                                      & \mathbf{0} \\
                                      2\mathbf{s}_{k+1}^\mathsf{T} & \mathbf{0} & -2\mathbf{s}_{k+1}^\mathsf{T}
                                      & 2\mathbf{s}_{k+1}^\mathsf{T} & 2\,\delta t\,\mathbf{s}_{k+1}^\mathsf{T}
                       \end{bmatrix}.

    Parameters
    ----------
    a, c : array_like, shape (2,) or (M, 2)
        :math:`\mathbf{s}_k` and :math:`\mathbf{s}_{k+1}` [m].
    dt : float
        :math:`\delta t` [s].

    Returns
    -------
    ndarray, shape (2, 10) or (M, 2, 10)

    Examples
    --------
    >>> from uwtutor.models.cooperative import measurement_noise_map
    >>> L = measurement_noise_map([3.0, 4.0], [1.0, 2.0], dt=8.0)
    >>> L.shape
    (2, 10)
    >>> # the first row: 2 s_k^T, then -2 s_k^T
    >>> L[0, :4]
    array([ 6.,  8., -6., -8.])
    """
    a = as_finite("a", a, max_abs=MAX_COORDINATE, ndim=(1, 2))
    c = as_finite("c", c, max_abs=MAX_COORDINATE, ndim=(1, 2))
    check_same_shape(a=a, c=c)
    if a.shape[-1] != 2 or a.size == 0:
        raise ValueError(f"a and c must have shape (2,) or (M, 2); got {a.shape}")
    return _noise_map(a, c, _interval(dt))


def _noise_map(a: np.ndarray, c: np.ndarray, d: float) -> np.ndarray:
    """:func:`measurement_noise_map` without the checks (the filter's per-step path)."""
    L = np.zeros(np.broadcast_shapes(a.shape, c.shape)[:-1] + (2, 10))
    L[..., 0, 0:2] = 2.0 * a
    L[..., 0, 2:4] = -2.0 * a
    L[..., 1, 0:2] = 2.0 * c
    L[..., 1, 4:6] = -2.0 * c
    L[..., 1, 6:8] = 2.0 * c
    L[..., 1, 8:10] = 2.0 * d * c
    return L


def _per_step(name: str, value: Any, n_epochs_extra: int) -> np.ndarray:
    arr = as_finite(name, value, nonempty=True)
    if arr.ndim not in (2, 3) or arr.shape[-1] != 2:
        raise ValueError(f"{name} must have shape (K{'+1' if n_epochs_extra else ''}, 2) or "
                         f"(M, K{'+1' if n_epochs_extra else ''}, 2); got {arr.shape}")
    return arr


class CooperativeMotion(BlockMotion):
    r"""Dead reckoning with an unknown constant current, paper B's eqs. (2), (9) and (10).

    .. math::

        f(\mathbf{x}, \mathbf{u}) = \begin{bmatrix} \mathbf{p} + \mathbf{u} + \delta t\,\mathbf{U} \\ \mathbf{U}
        \end{bmatrix}, \qquad
        \mathbf{F} = \begin{bmatrix} \mathbf{I} & \delta t\,\mathbf{I} \\ \mathbf{0} & \mathbf{I} \end{bmatrix},
        \qquad \text{process noise } \mathbf{G}\mathbf{Q}\mathbf{G}^\mathsf{T}.

    The :class:`~uwtutor.models.blocks.BlockMotion` of a :class:`~uwtutor.models.blocks.Position` carried by a
    :class:`~uwtutor.models.blocks.Current` (slots ``position``, ``current``), with the process noise given whole
    (:math:`\mathbf{G}` correlates the position and the current).

    Parameters
    ----------
    dt : float
        The cooperative interval :math:`\delta t` [s], > 0.
    Q : array_like, shape (6, 6)
        Paper B's :math:`\mathbf{Q}` over :math:`[x, y, \Delta x, \Delta y, U_x, U_y]`, symmetric PSD.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.models.cooperative import CooperativeMotion
    >>> m = CooperativeMotion(
    ...     8.0, np.diag([100.0, 100.0, 4.0, 4.0, 0.05**2, 0.05**2])
    ... )
    >>> m.f(np.array([[0.0, 0.0, 0.5, 0.5]]), np.array([[16.0, 0.0]]), 0)
    array([[20. ,  4. ,  0.5,  0.5]])
    >>> round(float(m.Q(None, None, 0)[0, 0]), 2)       # 100 + 4 + 8^2 x 0.05^2
    104.16
    """

    # no angle in the state: the plain differences and mean (a particle filter's estimate is then the plain mean)
    difference = MotionModel.difference
    normalize = MotionModel.normalize
    covariances_checked = False     # G Q G^T is checked by the engine, as before the blocks

    def __init__(self, dt: Any, Q: ArrayLike) -> None:
        interval = _interval(dt)
        self.Q6 = as_covariance("Q", Q, 6, allow_singular=True)
        self.noise_map = process_noise_map(interval)
        noise = self.noise_map @ self.Q6 @ self.noise_map.T
        super().__init__(Position(noise[:2, :2], current="current"), Current(), dt=interval)
        assert self._constant is not None               # linear blocks, one step length: F is a constant
        self._constant = (self._constant[0], noise)     # the noise given whole: it correlates the two blocks

    def sample(self, x: np.ndarray, u: Any, k: int, rng: Any) -> np.ndarray:
        """:math:`f + L\\varepsilon` with the whole :math:`G Q G^\\mathsf{T}` (it correlates the blocks)."""
        return MotionModel.sample(self, x, u, k, rng)


class SquaredRangePair(MeasurementModel):
    r"""Paper B's measurement: the squared ranges to the leader at both ends of a cooperative interval.

    See the module docstring for :math:`h`, :math:`\mathbf{H}` and the noise map; the measurement noise covariance is
    :math:`\mathbf{L}\mathbf{R}\mathbf{L}^\mathsf{T}` (shape (2, 2) per run), recomputed at every linearization.

    Parameters
    ----------
    leader : array_like, shape (K + 1, 2) or (M, K + 1, 2)
        The leader's broadcast positions at the ranging epochs [m].
    displacements : array_like, shape (K, 2) or (M, K, 2)
        The follower's DR displacements :math:`\mathbf{u}_k` over each interval [m].
    dt : float
        :math:`\delta t` [s].
    R : array_like, shape (10, 10)
        Paper B's :math:`\mathbf{R}`, symmetric PSD.
    literal : bool, default False
        Evaluate paper B's eqs. (11)-(12) at the predicted state as printed, instead of the consistent Jacobian.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.models.cooperative import SquaredRangePair
    >>> leader = np.array([[0.0, 0.0], [0.0, 0.0]])
    >>> pair = SquaredRangePair(leader, np.array([[30.0, 40.0]]), 10.0, np.eye(10))
    >>> # moved from the leader's position to 50 m away
    >>> x = np.array([[30.0, 40.0, 0.0, 0.0]])
    >>> pair.h(x, 0)
    array([[   0., 2500.]])
    """

    m = 2
    n = 4
    covariances_checked = True      # R = L R_10 L^T of an R_10 checked (positive semi-definite) when the model is made

    def __init__(self, leader: ArrayLike, displacements: ArrayLike, dt: Any, R: ArrayLike,
                 literal: bool = False) -> None:
        self.leader = _per_step("leader", leader, 1)
        self.displacements = _per_step("displacements", displacements, 0)
        if self.leader.shape[-2] != self.displacements.shape[-2] + 1:
            raise ValueError(f"leader must hold one position more than displacements (K + 1 epochs, K intervals); "
                             f"got {self.leader.shape[-2]} and {self.displacements.shape[-2]}")
        self._n_runs = common_runs({name: a.shape[0] if a.ndim == 3 else None
                                    for name, a in (("leader", self.leader), ("displacements", self.displacements))})
        self.dt = _interval(dt)
        self.R10 = as_covariance("R", R, 10, allow_singular=True)
        self.literal = as_flag("literal", literal)

    def _vectors(self, x: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(a, c) of the consistent formulation and (a, c) where the Jacobians are evaluated."""
        b0 = self.leader[..., k, :]
        b1 = self.leader[..., k + 1, :]
        u = self.displacements[..., k, :]
        if x.ndim == 3:                        # particles (M, N, 4): a run's values broadcast over its particles
            b0, b1, u = (v[:, None, :] if v.ndim == 2 else v for v in (b0, b1, u))
        p, U = x[..., :2], x[..., 2:]
        a = p - u - self.dt * U - b0
        c = p - b1
        if not self.literal:
            return a, c, a, c
        return a, c, p - b0, p + u + self.dt * U - b1

    def h(self, x: np.ndarray, k: int) -> np.ndarray:
        a, c, _, _ = self._vectors(x, k)
        return np.stack([np.sum(a * a, axis=-1), np.sum(c * c, axis=-1)], axis=-1)

    def H(self, x: np.ndarray, k: int) -> np.ndarray:
        _, _, a, c = self._vectors(x, k)
        H = np.zeros(np.broadcast_shapes(a.shape, c.shape)[:-1] + (2, 4))
        H[..., 0, :2] = 2.0 * a
        H[..., 1, :2] = 2.0 * c
        if self.literal:
            H[..., 1, 2:] = 2.0 * self.dt * c
        else:
            H[..., 0, 2:] = -2.0 * self.dt * a
        return H

    def noise_map(self, x: np.ndarray, k: int) -> np.ndarray:
        r""":math:`\mathbf{L}` at ``x`` for step ``k``, shape (M, 2, 10)."""
        _, _, a, c = self._vectors(x, k)
        return _noise_map(a, c, self.dt)

    def R(self, x: np.ndarray, k: int) -> np.ndarray:
        L = self.noise_map(x, k)
        return L @ self.R10 @ np.swapaxes(L, -1, -2)

    def linearize(self, x: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        z = self.h(x, k)
        return z, self.H(x, k), np.ones(z.shape[:-1], dtype=bool)

    @property
    def n_runs(self) -> int | None:
        """Number of runs of per-run leader or displacement paths (``None`` when shared by every run)."""
        return self._n_runs


def leader_range(leader: ArrayLike, variance: Any) -> RangeToBeacon:
    r"""The plain range to the leader at the end of each interval, :math:`r_{k+1} = \lVert \mathbf{p}_{k+1} -
    \mathbf{p}^\mathrm{M}_{k+1} \rVert`, for the 4-state :math:`[x, y, U_x, U_y]`: the library's
    :class:`~uwtutor.models.range.RangeToBeacon` on the leader's positions of epochs 1..K (step ``k`` ends at epoch
    ``k + 1``), :math:`\mathbf{H} = [\mathbf{e}^\mathsf{T}, 0, 0]` with :math:`\mathbf{e}` the unit line of sight.

    Parameters
    ----------
    leader : array_like, shape (K + 1, 2) or (M, K + 1, 2)
        The leader's broadcast positions at the ranging epochs [m].
    variance : float
        Variance of a range [m²], > 0: range noise plus the leader's position error along the line of sight.

    Returns
    -------
    RangeToBeacon

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.models.cooperative import leader_range
    >>> model = leader_range(np.array([[0.0, 0.0], [10.0, 0.0]]), 25.0)
    >>> model.h(np.array([[40.0, 40.0, 0.5, 0.5]]), 0)
    array([[50.]])
    """
    b = _per_step("leader", leader, 1)
    if b.shape[-2] < 2:
        raise ValueError(f"leader must hold K + 1 >= 2 positions (the start, then one per ranging epoch); got shape "
                         f"{b.shape}")
    return RangeToBeacon(b[..., 1:, :], R=as_scalar("variance", variance, domain="positive"), n=4)
