r"""Paper A's improved EKF (IEKF): the range-only EKF with the slowly varying range bias in its state.

**Model** (Liu et al., paper A, eqs. 1-2). The range error :math:`\xi_k = \eta_k + \upsilon_k` is white noise
:math:`\eta_k \sim N(0, R)` plus a slowly varying bias :math:`\upsilon_k`; the bias joins the state as a random
walk,

.. math::

    \mathbf X_k = [x_k, y_k, \upsilon_k]^\mathsf T = \mathbf X_{k-1} + [\Delta x_k, \Delta y_k, 0]^\mathsf T
    + \boldsymbol\omega_k, \quad \boldsymbol\omega_k \sim N(\mathbf 0, \mathbf Q), \qquad
    r_k = \lVert \mathbf p_k - \mathbf b_k \rVert + \upsilon_k + \eta_k,

    \mathbf H_k = \Big[\frac{(\hat{\mathbf p}^-_k - \mathbf b_k)^\mathsf T}{\lVert \hat{\mathbf p}^-_k -
    \mathbf b_k \rVert},\ 1\Big],

with :math:`\mathbf Q = \operatorname{diag}(\sigma_x^2, \sigma_y^2, q_\upsilon)` and paper A's rule
:math:`q_\upsilon = (\sigma_x^2 + \sigma_y^2)/2` (``uwtutor.models.bias.paper_a_process_noise``). The
beacon :math:`\mathbf b_k` is fixed or moves (one position per epoch). The filter is the generic engine
(``uwtutor.filters.ExtendedKalmanFilter``) on the model pair ``DeadReckoning(Q, names=("range_bias",))`` +
``RangeToBeacon(beacon, R, state=motion, bias="range_bias")`` (:func:`bias_model_pair`): this module only names
it.

**Start.** The bias makes the filter sensitive to its initial value: paper A first computes a least-squares
fix of position and bias on the dead-reckoned track (``uwtutor.lsq.prepositioning``) and starts the filter
only once that fix's precision factor :math:`\alpha = \operatorname{tr}(\mathbf A^\mathsf T\mathbf A)^{-1}` is
below 2 (:func:`~uwtutor.pipelines.prepositioned.prepositioned_bias_ekf`).

Forms: :func:`bias_ekf` runs one run or ``M`` runs over whole sequences in one call; :class:`BiasEKF` is the same filter
one step at a time (the filter protocol); :func:`~uwtutor.pipelines.prepositioned.prepositioned_bias_ekf` is paper A's
"pre-positioning, then IEKF" for a batch of runs.

References
----------
Liu J., Han S., Xu J., Yang G. "An improved EKF positioning algorithm for underwater acoustic beacon" (paper A),
sec. 1.1 (eqs. 1-2) and sec. 1.2 (eqs. 3-11).
Grewal M. S., Andrews A. P. (2015). *Kalman Filtering: Theory and Practice with MATLAB*, 4th ed., Wiley-IEEE
Press (state augmentation for correlated noise; paper A's ref. [13]).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .._validate import MAX_COORDINATE, as_covariance, as_finite, as_range_array, readonly
from ._packed import range_variances
from ..models import DeadReckoning, RangeToBeacon
from .base import FilterResult
from .engine import ExtendedKalmanFilter, extended_kalman_filter
from .gates import Gate

__all__ = ["bias_ekf", "BiasEKF", "bias_model_pair"]


def bias_model_pair(Q: ArrayLike, R: ArrayLike, beacon: ArrayLike = (0.0, 0.0),
                    n_steps: int | None = None) -> tuple[DeadReckoning, RangeToBeacon]:
    r"""Paper A's model pair on the state :math:`[x, y, b]`: dead reckoning with a random-walk range bias, and the
    range plus the bias, :math:`z = \lVert p - b_\mathrm{beacon}\rVert + b + v` -- what :func:`bias_ekf` runs, for
    any other filter family (the particle filters, the smoother, the posterior Cramér-Rao bound).

    Parameters
    ----------
    Q : array_like, shape (3, 3) or (K, 3, 3)
        Process noise of :math:`[x, y, b]` per step (positive semi-definite); one per step needs ``n_steps``.
    R : float or array_like, shape (K,)
        Range noise variance (> 0); one per step needs ``n_steps``.
    beacon : array_like, shape (2,), (K, 2) or (M, K, 2)
        The beacon, fixed or one position per step.
    n_steps : int, optional
        ``K``, when ``Q`` or ``R`` give one value per step.

    Returns
    -------
    tuple
        ``(DeadReckoning, RangeToBeacon)``: the state's slots ``position`` and ``range_bias``, the range reading
        both by name.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.filters.bias import bias_model_pair
    >>> motion, measurement = bias_model_pair(
    ...     np.diag([0.25, 0.25, 0.01]), 4.0, beacon=(100.0, 0.0)
    ... )
    >>> measurement.h(np.array([[0.0, 0.0, 2.0]]), 0)
    array([[102.]])
    >>> motion.slots, measurement.reads
    (('position', 'range_bias'), ('position', 'bias'))
    """
    Q = as_covariance("Q", Q, 3, allow_singular=True)
    if Q.shape != (3, 3) and not (n_steps is not None and Q.shape == (n_steps, 3, 3)):
        per = f", or one per step ({n_steps}, 3, 3)" if n_steps is not None else ""
        raise ValueError(f"Q must be one 3x3 matrix diag(sigma_x^2, sigma_y^2, sigma_bias^2) for the state "
                         f"[x, y, bias]{per}; got shape {Q.shape}")
    R = range_variances(R, n_steps)
    motion = DeadReckoning(Q, names=("range_bias",))
    return motion, RangeToBeacon(beacon, R, state=motion, bias="range_bias")


def bias_ekf(x0: ArrayLike, P0: ArrayLike, u: ArrayLike, z: ArrayLike, Q: ArrayLike, R: ArrayLike,
             beacon: ArrayLike = (0.0, 0.0), times: ArrayLike | None = None, *, gate: Gate | None = None,
             keep_priors: bool = True) -> FilterResult:
    r"""Run paper A's IEKF (state ``[x, y, bias]``) over whole sequences, one run or ``M`` at once.

    Each step ``k`` predicts with the DR displacement ``u[..., k, :]`` (the bias is kept, its variance grows by
    ``Q[2, 2]``) and updates with the range ``z[..., k]`` (equations in the module docstring). A NaN range
    means no reply: predict only. ``Q`` and ``R`` may change from step to step; a ``gate`` tests each range
    before it is used.

    Parameters
    ----------
    x0 : array_like, shape (3,) or (M, 3)
        Initial ``[x, y, bias]`` [m].
    P0 : array_like, shape (3, 3) or (M, 3, 3)
        Its covariance, positive definite [m²] (paper A: the identity).
    u : array_like, shape (K, 2) or (M, K, 2)
        DR displacement from epoch ``k - 1`` to epoch ``k`` [m].
    z : array_like, shape (K,) or (M, K)
        Measured ranges [m], NaN where missing.
    Q : array_like, shape (3, 3) or (K, 3, 3)
        Process noise per epoch (e.g. ``uwtutor.models.bias.paper_a_process_noise``) [m²]; or one per epoch.
    R : float or array_like, shape (K,)
        Variance of the white part :math:`\eta_k` of the range error [m²], > 0; or one per epoch (NaN allowed
        where there is no range).
    beacon : array_like, shape (2,), (K, 2) or (M, K, 2), optional
        Beacon position: fixed (the origin by default), one per epoch, or one per run and epoch (a moving
        beacon, e.g. the other boat of paper A's lake trial).
    times : array_like, shape (K,), optional
        Epoch times for the result (default ``0..K-1``).
    gate : uwtutor.filters.Gate, optional
        An outlier test on each innovation (e.g. ``ReacquiringGate()``); None uses every range.
    keep_priors : bool, default True
        False: the result's ``x_prior`` and ``P_prior`` are None (the other fields unchanged, bit for bit), for a
        study that needs only the estimates: they are almost half of the result's memory.

    Returns
    -------
    FilterResult
        ``x`` (…, K, 3) with the bias estimate in ``x[..., 2]``, ``P`` (…, K, 3, 3), the priors, innovations
        (…, K, 1) and their covariances, ``extras["accepted"]`` (…, K) (and the gate's per-step outputs).

    Raises
    ------
    ValueError
        On wrong shapes, non-finite inputs, a ``Q`` that is not 3x3 positive semi-definite, ``R <= 0`` or a
        ``P0`` that is not positive definite (the message names the argument).

    Warns
    -----
    uwtutor.errors.BeaconSingularityWarning
        When a prediction falls exactly on the beacon (that run's update is skipped).

    See Also
    --------
    BiasEKF : the same filter step by step.
    uwtutor.pipelines.prepositioned.prepositioned_bias_ekf : paper A's least-squares start, then this filter.
    uwtutor.filters.ekf.range_only_ekf : the plain EKF (no bias state).

    Examples
    --------
    A platform circling a buoy, ranges 30 m too long; the bias is found and the position stays close:

    >>> import numpy as np
    >>> from uwtutor.filters import bias_ekf
    >>> from uwtutor.models.bias import paper_a_process_noise
    >>> angle = np.linspace(0.0, 2 * np.pi, 401)
    >>> track = 1500.0 * np.column_stack([np.cos(angle), np.sin(angle)])
    >>> u = np.diff(track, axis=0, prepend=track[:1])
    >>> z = 1500.0 + 30.0 + np.random.default_rng(0).normal(0.0, 2.0, 401)
    >>> res = bias_ekf(
    ...     [track[0, 0] + 20.0, 0.0, 0.0],
    ...     np.diag([400.0, 400.0, 900.0]),
    ...     u,
    ...     z,
    ...     Q=paper_a_process_noise(0.1),
    ...     R=4.0,
    ... )
    >>> bool(abs(res.x[-1, 2] - 30.0) < 2.0), bool(
    ...     np.linalg.norm(res.x[-1, :2] - track[-1]) < 3.0
    ... )
    (True, True)
    """
    x0 = as_finite("x0", x0, max_abs=MAX_COORDINATE)
    if u is None:
        raise TypeError("u (the dead-reckoned displacements, shape (K, 2) or (M, K, 2)) is required: give "
                        "np.zeros((K, 2)) for a vehicle that does not move")
    uu = as_finite("u", u, ndim=(2, 3), max_abs=MAX_COORDINATE)
    K = uu.shape[-2]
    # measured ranges: >= 0, NaN missing; one per step of u, (K,) or (M, K) as for range_only_ekf
    zz = as_range_array("z", z, allow_nan=True, ndim=(1, 2), max_abs=MAX_COORDINATE)
    if zz.shape[-1] != K:
        raise ValueError(f"z must hold one range per step of u, shape ({K},) or (M, {K}); got shape {zz.shape}")
    motion, measurement = bias_model_pair(Q, R, beacon, zz.shape[-1] if zz.ndim else None)
    return extended_kalman_filter(motion, measurement, x0, P0, uu, zz, times=times, gate=gate, keep_priors=keep_priors)


class BiasEKF(ExtendedKalmanFilter):
    r"""Paper A's IEKF one step at a time: the generic engine on the bias model pair (see :func:`bias_ekf`).

    Parameters
    ----------
    x0 : array_like, shape (3,) or (M, 3)
        Initial ``[x, y, bias]`` [m].
    P0 : array_like, shape (3, 3) or (M, 3, 3)
        Its covariance [m²].
    Q : array_like, shape (3, 3)
        Process noise per epoch [m²].
    R : float
        White range noise variance [m²].
    beacon : array_like, shape (2,), (K, 2) or (M, K, 2), optional
        Beacon position, fixed or one per epoch (then step ``k`` uses ``beacon[..., k, :]``).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.filters import BiasEKF
    >>> filt = BiasEKF(
    ...     [1000.0, 0.0, 0.0],
    ...     np.eye(3) * 100.0,
    ...     Q=np.diag([0.25, 0.25, 0.25]),
    ...     R=5.0,
    ... )
    >>> filt.predict([0.0, 10.0])
    >>> filt.update(1012.0)
    >>> filt.x.shape, filt.P.shape, round(float(filt.bias), 3)
    ((3,), (3, 3), 5.83)
    """

    _parameters = ("Q", "R", "beacon")

    def __init__(self, x0: ArrayLike, P0: ArrayLike, Q: ArrayLike, R: float, beacon: ArrayLike = (0.0, 0.0)) -> None:
        x0 = as_finite("x0", x0, max_abs=MAX_COORDINATE)
        motion, measurement = bias_model_pair(Q, R, beacon)
        super().__init__(motion, measurement, x0, P0)
        self._config = dict(Q=Q, R=R, beacon=beacon)

    def _apply(self, name: str, value: Any) -> None:
        """A new ``Q``, ``R`` or ``beacon`` (base.Configurable): the model pair is built again with it, checked
        as in the constructor, and used from the next step on."""
        config = dict(self._config, **{name: value})
        self._use_models(*bias_model_pair(config["Q"], config["R"], config["beacon"]), name)
        self._config = config

    @property
    def Q(self) -> np.ndarray:
        """Process noise of ``[x, y, bias]`` per step (3, 3) (read-only; assign a new one to change it)."""
        return readonly(np.array(self._config["Q"], dtype=float))

    @property
    def R(self) -> float:
        """Range noise variance (assign a new one to change it)."""
        return range_variances(self._config["R"])

    @property
    def beacon(self) -> np.ndarray:
        """Beacon position, as given (read-only; assign a new one to change it)."""
        return readonly(np.array(self._config["beacon"], dtype=float))

    def update(self, z: ArrayLike) -> None:
        """Correct the estimate with the measured range ``z`` (>= 0; NaN: no reply, predict only)."""
        super().update(as_range_array("z", z, allow_nan=True, max_abs=MAX_COORDINATE))

    @property
    def bias(self) -> np.ndarray:
        """The current bias estimate [m], ``()`` or ``(M,)``."""
        return self.x[..., 2]
