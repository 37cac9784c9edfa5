r"""Motion models with a range-bias state (Liu et al., paper A), batched over Monte Carlo runs.

Paper A augments the dead-reckoning (DR) state with the slowly varying part :math:`\upsilon_k` of the range
error, so that the filter estimates it instead of mistaking it for position:

.. math::

    \mathbf X_k = \begin{bmatrix} x_k \\ y_k \\ \upsilon_k \end{bmatrix}
    = \mathbf A\,\mathbf X_{k-1} + \begin{bmatrix} \Delta x_k \\ \Delta y_k \\ 0 \end{bmatrix} + \boldsymbol\omega_k,
    \qquad \mathbf A = \mathbf I_3, \qquad \boldsymbol\omega_k \sim N(\mathbf 0, \mathbf Q),

    r_k = \sqrt{(x_k - b_{x,k})^2 + (y_k - b_{y,k})^2} + \upsilon_k + \eta_k, \qquad
    \mathbf H_k = \Big[\frac{x_k - b_{x,k}}{r_k},\ \frac{y_k - b_{y,k}}{r_k},\ 1\Big]

(paper A, eq. 1, with the beacon :math:`\mathbf b_k` at the origin there). The bias is a random walk: between
close epochs :math:`\upsilon_k = \upsilon_{k-1}` up to the noise :math:`q_\upsilon` (paper A's
:math:`\sigma_\upsilon^2`), which paper A sets to
:math:`q_\upsilon = (\sigma_x^2 + \sigma_y^2)/2` (:func:`paper_a_process_noise`).

Paper A's model pair is ``uwtutor.models.DeadReckoning(Q, names=("range_bias",))`` with a 3x3 ``Q`` (the bias is
carried as a random walk) and ``uwtutor.models.RangeToBeacon(beacon, R, state=motion, bias="range_bias")`` (by
index, ``n=3, bias_index=2``); the filter is the generic engine
(``uwtutor.filters.bias_ekf``). This module adds paper A's rule for ``Q`` and, beyond the paper,
:class:`BiasRateDeadReckoning`: a bias *rate* :math:`\dot\upsilon` in the state (a constant-velocity model for
the bias), for biases that drift faster than a random walk with paper A's :math:`q_\upsilon` can follow.

References
----------
Liu J., Han S., Xu J., Yang G. "An improved EKF positioning algorithm for underwater acoustic beacon" (paper A),
sec. 1.1, eqs. (1)-(2).
Bar-Shalom Y., Li X. R., Kirubarajan T. (2001). *Estimation with Applications to Tracking and Navigation*, Wiley,
sec. 6.3 (the discretized white-noise acceleration model used for the bias rate).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validate import as_covariance, as_nonnegative, as_positive
from .base import MotionModel
from .blocks import _MAX_STD, BlockMotion, OffsetAndRate, Position

__all__ = ["BiasRateDeadReckoning", "paper_a_process_noise", "bias_rate_process_noise"]


def paper_a_process_noise(sigma_x: Any, sigma_y: Any = None, sigma_bias: Any = None) -> NDArray[np.float64]:
    r"""Paper A's process noise :math:`\mathbf Q = \operatorname{diag}(\sigma_x^2, \sigma_y^2, q_\upsilon)`.

    :math:`\sigma_x, \sigma_y` are the DR errors per epoch; when ``sigma_bias`` is not given the bias noise follows
    paper A's rule for close epochs, :math:`q_\upsilon = (\sigma_x^2 + \sigma_y^2)/2`: between two nearby
    epochs the bias changes about as much as the position error does (paper A, sec. 1.1). Give ``sigma_bias``
    explicitly when the epochs are far apart (the paper says to increase it then).

    Parameters
    ----------
    sigma_x : float
        DR error standard deviation per epoch along x [m], >= 0.
    sigma_y : float, optional
        The same along y (default: ``sigma_x``).
    sigma_bias : float, optional
        Standard deviation of the bias change per epoch [m]; default from the rule above.

    Returns
    -------
    ndarray, shape (3, 3)

    Examples
    --------
    >>> from uwtutor.models.bias import paper_a_process_noise
    >>> paper_a_process_noise(1.0, 0.5)
    array([[1.   , 0.   , 0.   ],
           [0.   , 0.25 , 0.   ],
           [0.   , 0.   , 0.625]])
    """
    sx = float(as_nonnegative("sigma_x", sigma_x, ndim=0, max_abs=_MAX_STD))
    sy = sx if sigma_y is None else float(as_nonnegative("sigma_y", sigma_y, ndim=0, max_abs=_MAX_STD))
    sb2 = (sx**2 + sy**2) / 2.0 if sigma_bias is None else float(as_nonnegative("sigma_bias", sigma_bias, ndim=0,
                                                                                 max_abs=_MAX_STD)) ** 2
    return np.diag([sx**2, sy**2, sb2])


def bias_rate_process_noise(sigma_x: Any, sigma_y: Any = None, *, rate_sigma: Any,
                            dt: Any) -> NDArray[np.float64]:
    r"""Process noise of :class:`BiasRateDeadReckoning`: DR noise plus a white-noise bias *acceleration*.

    The bias rate :math:`\dot\upsilon` receives white noise of spectral density :math:`q = \sigma_a^2` over each
    step :math:`\Delta t`, which gives the discretized white-noise acceleration block (Bar-Shalom et al. 2001,
    eq. 6.2.3-8)

    .. math::

        \mathbf Q_\upsilon = q \begin{bmatrix} \Delta t^3/3 & \Delta t^2/2 \\ \Delta t^2/2 & \Delta t \end{bmatrix},
        \qquad \mathbf Q = \operatorname{blkdiag}(\sigma_x^2, \sigma_y^2, \mathbf Q_\upsilon).

    Parameters
    ----------
    sigma_x, sigma_y : float
        DR error per epoch [m] (``sigma_y`` defaults to ``sigma_x``).
    rate_sigma : float
        :math:`\sigma_a` [m s^-3/2]: how fast the bias rate itself may wander.
    dt : float
        Epoch interval :math:`\Delta t` [s], > 0.

    Returns
    -------
    ndarray, shape (4, 4)

    Examples
    --------
    >>> from uwtutor.models.bias import bias_rate_process_noise
    >>> bias_rate_process_noise(1.0, rate_sigma=0.01, dt=5.0)[2:, 2:].round(6)
    array([[0.004167, 0.00125 ],
           [0.00125 , 0.0005  ]])
    """
    sx = float(as_nonnegative("sigma_x", sigma_x, ndim=0, max_abs=_MAX_STD))
    sy = sx if sigma_y is None else float(as_nonnegative("sigma_y", sigma_y, ndim=0, max_abs=_MAX_STD))
    q = float(as_nonnegative("rate_sigma", rate_sigma, ndim=0, max_abs=_MAX_STD)) ** 2
    h = float(as_positive("dt", dt, ndim=0, max_abs=1e50))          # q dt^3 / 3 stays finite
    Q = np.zeros((4, 4))
    Q[0, 0], Q[1, 1] = sx**2, sy**2
    Q[2:, 2:] = q * np.array([[h**3 / 3.0, h**2 / 2.0], [h**2 / 2.0, h]])
    return Q


class BiasRateDeadReckoning(BlockMotion):
    r"""DR position and a bias that drifts at an estimated rate: state :math:`[x, y, \upsilon, \dot\upsilon]`.

    .. math::

        f(\mathbf X, \mathbf u) = \begin{bmatrix} x + \Delta x \\ y + \Delta y \\ \upsilon + \Delta t\,\dot\upsilon
        \\ \dot\upsilon \end{bmatrix}, \qquad
        \mathbf F = \begin{bmatrix} \mathbf I_2 & \mathbf 0 \\ \mathbf 0 & \begin{bmatrix} 1 & \Delta t \\ 0 & 1
        \end{bmatrix} \end{bmatrix}.

    Not in paper A: the book's extension for a bias that changes faster than paper A's random walk allows
    (a sound-speed profile warming through the day, a range that opens steadily under a :math:`\gamma r_k` error).
    Use with ``RangeToBeacon(beacon, R, state=motion, bias="bias_offset")`` (the offset is the range bias) and
    :func:`bias_rate_process_noise`.

    It is the :class:`~uwtutor.models.blocks.BlockMotion` of a :class:`~uwtutor.models.blocks.Position` and an
    :class:`~uwtutor.models.blocks.OffsetAndRate` named ``bias`` (slots ``position``, ``bias``, ``bias_offset``,
    ``bias_rate``), with its process noise given whole: ``Q`` may correlate the position and the bias, so it
    replaces the blocks' own noises, and ``sample`` draws :math:`f + L\varepsilon`, :math:`L L^\mathsf{T} = Q`.

    Parameters
    ----------
    Q : array_like, shape (4, 4)
        Process noise per epoch, positive semi-definite.
    dt : float
        Epoch interval [s], > 0 (epochs are taken as equally spaced).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.models.bias import (
    ...     BiasRateDeadReckoning,
    ...     bias_rate_process_noise,
    ... )
    >>> motion = BiasRateDeadReckoning(
    ...     bias_rate_process_noise(0.5, rate_sigma=0.01, dt=5.0), dt=5.0
    ... )
    >>> motion.f(np.array([[0.0, 0.0, 5.0, 0.1]]), np.array([[1.0, 2.0]]), 0)
    array([[1. , 2. , 5.5, 0.1]])
    >>> motion.slot("bias_rate")
    array([3])
    """

    # no angle in the state: the plain differences and mean (a particle filter's estimate is then the plain mean)
    difference = MotionModel.difference
    normalize = MotionModel.normalize

    def __init__(self, Q: ArrayLike, dt: Any) -> None:
        Q = as_covariance("Q", Q, 4, allow_singular=True)
        if Q.shape != (4, 4):
            raise ValueError(f"Q must be one 4x4 matrix (the same at every epoch); got shape {Q.shape}")
        dt = float(as_positive("dt", dt, ndim=0))
        super().__init__(Position(Q[:2, :2]), OffsetAndRate("bias", rate_walk=0.0), dt=dt)
        assert self._constant is not None               # linear blocks, one step length: F is a constant
        self._constant = (self._constant[0], Q)         # the noise given whole

    def sample(self, x: np.ndarray, u: Any, k: int, rng: Any) -> np.ndarray:
        """:math:`f + L\\varepsilon` with the whole ``Q`` (it may correlate the blocks)."""
        return MotionModel.sample(self, x, u, k, rng)
