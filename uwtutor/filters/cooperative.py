r"""Paper B's cooperative EKF: a follower's position and the unknown current from ranges to a moving leader.

A thin filter family on the generic engine: ``CooperativeMotion`` and ``SquaredRangePair`` (or ``leader_range``) from
:mod:`uwtutor.models.cooperative` run by :class:`~uwtutor.filters.engine.ExtendedKalmanFilter`. With
:math:`\mathbf{G}` and :math:`\mathbf{L}` the noise maps of the models (paper B's :math:`\mathbf{W}` and
:math:`\mathbf{V}`), a step from epoch :math:`k` to :math:`k + 1` is (paper B, eqs. 13-18, with the Joseph form of
the covariance update)

.. math::

    \hat{\mathbf{x}}_{k+1|k} = f(\hat{\mathbf{x}}_k, \mathbf{u}_k), \qquad
    \mathbf{P}_{k+1|k} = \mathbf{F}\mathbf{P}_k\mathbf{F}^\mathsf{T} + \mathbf{G}\mathbf{Q}\mathbf{G}^\mathsf{T},

    \mathbf{K}_{k+1} = \mathbf{P}_{k+1|k}\mathbf{H}^\mathsf{T}
        \left(\mathbf{L}\mathbf{R}\mathbf{L}^\mathsf{T} + \mathbf{H}\mathbf{P}_{k+1|k}\mathbf{H}^\mathsf{T}\right)^{-1},
    \qquad
    \hat{\mathbf{x}}_{k+1} = \hat{\mathbf{x}}_{k+1|k} + \mathbf{K}_{k+1}\left(\mathbf{z}_{k+1} -
        h(\hat{\mathbf{x}}_{k+1|k})\right),

with :math:`\mathbf{z}_{k+1} = [r_k^2, r_{k+1}^2]` and the Jacobians at the prediction. Three formulations share the
code: ``"consistent"`` (the measurement written as a function of the predicted state), ``"literal"`` (paper B's
eqs. 11-12 evaluated at the predicted state as printed) and ``"single_range"`` (only :math:`r_{k+1}`, a plain
range-only EKF to a moving beacon).

A lost message (a NaN range) makes the step predict only: for the pair, by default, a NaN at either end of the
interval (``lost="step"``: paper B's measurement is the pair, and this is what chapter 8's numbers use). With
``lost="range"`` the pair formulations follow the engine's general rule instead: the step updates with the range
that did arrive (the squared range at the other end, with its block of
:math:`\mathbf{L}\mathbf{R}\mathbf{L}^\mathsf{T}`).

When the follower's motion relative to the leader is a straight line (a leader that keeps a parallel course), the
ranges cannot tell the truth from a rotation of the follower about the leader together with its relative velocity,
and so the current (chapter 2): the covariance does not shrink along that direction. ``CooperativeEKF`` (and so
``cooperative_ekf``) emits an ``UnobservableWarning`` when the relative track the filter is given departs from a
straight line by less than the range noise (``relative_track_deviation``).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validate import MAX_COORDINATE, as_covariance, as_finite, as_positive, as_range_array, as_scalar, common_runs
from ..models.cooperative import CooperativeMotion, SquaredRangePair, leader_range
from ..errors import UnobservableWarning, warn
from .base import Configurable, FilterResult, run_filter
from .engine import ExtendedKalmanFilter

__all__ = ["cooperative_ekf", "CooperativeEKF", "range_pairs", "relative_track_deviation", "FORMULATIONS"]

#: The formulations of paper B's filter that ``CooperativeEKF`` runs.
FORMULATIONS = ("consistent", "literal", "single_range")
#: What a pair with one range lost does: the whole step is predict only, or the other range is used.
LOST_POLICIES = ("step", "range")



def range_pairs(ranges: ArrayLike) -> NDArray[np.float64]:
    r"""The measurements of paper B's steps, :math:`[r_k, r_{k+1}]` for :math:`k = 0, \dots, K - 1`.

    Parameters
    ----------
    ranges : array_like, shape (K + 1,) or (M, K + 1)
        Ranges at the epochs [m], NaN for a lost message.

    Returns
    -------
    ndarray, shape (K, 2) or (M, K, 2)

    Examples
    --------
    >>> from uwtutor.filters.cooperative import range_pairs
    >>> range_pairs([100.0, 110.0, 120.0])
    array([[100., 110.],
           [110., 120.]])
    """
    r = as_range_array("ranges", ranges, allow_nan=True, ndim=(1, 2), max_abs=MAX_COORDINATE)
    if r.shape[-1] < 2:
        raise ValueError(f"ranges must hold at least two epochs (one interval); got shape {r.shape}")
    return np.stack([r[..., :-1], r[..., 1:]], axis=-1)


def relative_track_deviation(u: ArrayLike, leader: ArrayLike, times: ArrayLike | None = None) -> float | np.ndarray:
    r"""How far the follower's track relative to the leader bends away from a straight line at constant speed.

    The filter knows the follower's DR track :math:`\mathbf{q}_k = \sum_{j < k} \mathbf{u}_j` and the leader's
    broadcast positions :math:`\mathbf{p}^\mathrm{M}_k`. The follower over ground is
    :math:`\mathbf{p}_0 + \mathbf{q}_k + t_k\mathbf{U}`, so the ranges see the relative position
    :math:`\mathbf{s}_k = \mathbf{p}_0 + t_k\mathbf{U} + \mathbf{q}_k - \mathbf{p}^\mathrm{M}_k`. If
    :math:`\mathbf{q}_k - \mathbf{p}^\mathrm{M}_k` is exactly affine in :math:`t_k`, so is :math:`\mathbf{s}_k =
    \mathbf{s}_0 + \dot{\mathbf{s}}\,t_k` whatever :math:`\mathbf{p}_0` and :math:`\mathbf{U}`, and
    :math:`r_k^2 = \lVert \mathbf{s}_0 + \dot{\mathbf{s}}\,t_k \rVert^2` fixes only :math:`\lVert\mathbf{s}_0\rVert`,
    :math:`\mathbf{s}_0\cdot\dot{\mathbf{s}}` and :math:`\lVert\dot{\mathbf{s}}\rVert`: turning the relative position
    and the relative velocity together (the follower about the leader, the current with it) leaves every range
    unchanged. This function returns the RMS distance of :math:`\mathbf{q}_k - \mathbf{p}^\mathrm{M}_k` from its
    least-squares line in time; the rotation is observable only when it clearly exceeds the range noise.

    Parameters
    ----------
    u : array_like, shape (K, 2) or (M, K, 2)
        DR displacements [m].
    leader : array_like, shape (K + 1, 2) or (M, K + 1, 2)
        The leader's broadcast positions [m].
    times : array_like, shape (K + 1,), optional
        Epoch times [s] (default: equally spaced).

    Returns
    -------
    float or ndarray, shape (M,)
        The RMS deviation [m].

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.filters.cooperative import relative_track_deviation
    >>> t = np.arange(11.0)
    >>> # parallel, same speed
    >>> leader = np.column_stack([2.0 * t + 500.0, 0.0 * t])
    >>> u = np.tile([2.0, 0.0], (10, 1))
    >>> round(relative_track_deviation(u, leader), 9)
    0.0
    """
    d = as_finite("u", u, ndim=(2, 3), max_abs=MAX_COORDINATE)
    b = as_finite("leader", leader, ndim=(2, 3), max_abs=MAX_COORDINATE)
    if d.shape[-1] != 2 or b.shape[-1] != 2 or b.shape[-2] != d.shape[-2] + 1:
        raise ValueError(f"u must have shape (..., K, 2) and leader (..., K + 1, 2); got {d.shape} and {b.shape}")
    k1 = b.shape[-2]
    t = np.arange(k1, dtype=float) if times is None else as_finite("times", times, shape=(k1,))
    q = np.concatenate([np.zeros(d.shape[:-2] + (1, 2)), np.cumsum(d, axis=-2)], axis=-2)
    rel = q - b                                                   # (..., K + 1, 2)
    A = np.column_stack([np.ones(k1), t - t.mean()])              # (K + 1, 2)
    hat = A @ np.linalg.pinv(A)                                   # projector on {alpha + beta t}
    resid = rel - np.einsum("ij,...jc->...ic", hat, rel)
    dev = np.sqrt(np.mean(np.sum(resid**2, axis=-1), axis=-1))
    return float(dev) if dev.ndim == 0 else dev


def _warn_straight(deviation: Any, noise: float) -> None:
    dev = np.atleast_1d(deviation)
    flags = dev < noise
    if flags.any():
        runs = "the run" if dev.size == 1 else f"{int(flags.sum())} of {dev.size} runs"
        warn(f"the state is not observable in {runs}: the follower's track relative to the leader departs from a "
             f"straight line by only {float(np.min(dev)):.3g} m RMS, less than the range noise ({noise:.3g} m), so "
             "the ranges cannot tell a rotation of the follower about the leader (with the current turning along) "
             "from the truth. Make the leader turn (zigzag or circle) instead of keeping a parallel course",
             UnobservableWarning)


def _check_inputs(x0: Any, P0: Any, u: Any, leader: Any,
                  n_runs: int | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Validate the inputs; a single x0 is repeated over the runs of any batched input."""
    x = as_finite("x0", x0, ndim=(1, 2), max_abs=MAX_COORDINATE)
    if x.shape[-1] != 4:
        raise ValueError(f"x0 must be [x, y, Ux, Uy] (last axis of length 4); got shape {x.shape}")
    P = as_covariance("P0", P0, 4)
    d = as_finite("u", u, ndim=(2, 3), max_abs=MAX_COORDINATE)
    if d.shape[-1] != 2:
        raise ValueError(f"u must hold DR displacements [dx, dy] (last axis 2); got shape {d.shape}")
    b = as_finite("leader", leader, ndim=(2, 3), max_abs=MAX_COORDINATE)
    if b.shape[-1] != 2 or b.shape[-2] != d.shape[-2] + 1:
        raise ValueError(f"leader must have shape (..., K + 1, 2) with K = {d.shape[-2]} intervals (one position per "
                         f"ranging epoch); got {b.shape}")
    M = common_runs(dict(x0=len(x) if x.ndim == 2 else None, P0=len(P) if P.ndim == 3 else None,
                         u=len(d) if d.ndim == 3 else None, leader=len(b) if b.ndim == 3 else None, ranges=n_runs))
    if M is not None and x.ndim == 1:
        x = np.broadcast_to(x, (M, 4)).copy()
    return x, P, d, b


class CooperativeEKF(Configurable):
    r"""Paper B's cooperative EKF, one step at a time (the protocol's ``predict`` / ``update``).

    Parameters
    ----------
    x0 : array_like, shape (4,) or (M, 4)
        Initial :math:`[x, y, U_x, U_y]` at epoch 0 [m, m/s].
    P0 : array_like, shape (4, 4) or (M, 4, 4)
        Its covariance.
    u : array_like, shape (K, 2) or (M, K, 2)
        DR displacements through the water over each interval [m].
    leader : array_like, shape (K + 1, 2) or (M, K + 1, 2)
        The leader's broadcast positions at the ranging epochs [m].
    dt : float
        :math:`\delta t` [s].
    Q : array_like, shape (6, 6)
        Paper B's :math:`\mathbf{Q}` over :math:`[x, y, \Delta x, \Delta y, U_x, U_y]`.
    R : array_like, shape (10, 10)
        Paper B's :math:`\mathbf{R}` (unused by ``"single_range"``).
    formulation : {"consistent", "literal", "single_range"}, default "consistent"
        See the module docstring.
    range_variance : float, optional
        The range variance of ``"single_range"`` [m²]; default :math:`R_{11} + R_{33}` (paper B's variances of the
        follower's and the leader's x, as they enter a range).
    lost : {"step", "range"}, default "step"
        A pair with one range lost: predict only (``"step"``), or update with the other range (``"range"``, the
        engine's rule for a vector with missing components).

    Attributes
    ----------
    relative_track_deviation : float or ndarray
        ``relative_track_deviation(u, leader)`` [m]; below ``range_noise`` the constructor warns.
    range_noise : float
        The standard deviation of a range that the filter assumes [m].

    Notes
    -----
    ``update(z)`` takes the step's measurement, NaN where a message was lost: the two ranges :math:`[r_k, r_{k+1}]`
    (shape (2,) or (M, 2)) for the pair formulations, which square them (``y`` and ``S`` in m² and m⁴), or the range
    :math:`r_{k+1}` (a scalar or (M,)) for ``"single_range"`` (``y`` in m). ``predict()`` without an argument uses
    the displacement of the current step from ``u``.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.filters.cooperative import CooperativeEKF
    >>> from uwtutor.scenarios import paper_b
    >>> sc = paper_b.make(np.random.default_rng(0), n_runs=1)
    >>> p = paper_b.PARAMETERS
    >>> f = CooperativeEKF(
    ...     p.x1,
    ...     np.diag([1e4, 1e4, 1.0, 1.0]),
    ...     sc.dr_displacements[0],
    ...     sc.leader_broadcast[0],
    ...     p.interval,
    ...     p.Q,
    ...     p.R,
    ... )
    >>> f.predict(); f.update(sc.ranges[0, :2])
    >>> f.x.shape, f.y.shape
    ((4,), (2,))
    """

    def __init__(self, x0: ArrayLike, P0: ArrayLike, u: ArrayLike, leader: ArrayLike, dt: Any, Q: ArrayLike,
                 R: ArrayLike, *, formulation: str = "consistent", range_variance: Any = None, lost: str = "step",
                 _n_runs: int | None = None) -> None:
        if formulation not in FORMULATIONS:
            raise ValueError(f"formulation must be one of {FORMULATIONS}; got {formulation!r}")
        if lost not in LOST_POLICIES:
            raise ValueError(f"lost must be one of {LOST_POLICIES} (a pair with one range lost: predict only, or "
                             f"update with the other range); got {lost!r}")
        self.lost = lost
        if range_variance is not None:      # checked whatever the formulation (only "single_range" uses it)
            range_variance = as_scalar("range_variance", range_variance, domain="positive")
        x, P, d, b = _check_inputs(x0, P0, u, leader, _n_runs)
        self.formulation = formulation
        self.u = d
        self.P0 = P
        motion = CooperativeMotion(dt, Q)
        R10 = as_covariance("R", R, 10, allow_singular=True)
        if formulation == "single_range":
            var = R10[0, 0] + R10[2, 2] if range_variance is None else range_variance
            measurement = leader_range(b, var)
            self.range_noise = float(np.sqrt(measurement.R(None, 0)[0, 0]))
        else:
            measurement = SquaredRangePair(b, d, dt, R10, literal=formulation == "literal")
            self.range_noise = float(np.sqrt(R10[0, 0] + R10[2, 2]))
        self.relative_track_deviation = relative_track_deviation(d, b)
        _warn_straight(self.relative_track_deviation, self.range_noise)
        self.motion, self.measurement = motion, measurement
        self._engine = ExtendedKalmanFilter(motion, measurement, x, P)

    # -- the protocol's state, read from the engine ---------------------------------------------------------------
    @property
    def x(self) -> np.ndarray:
        """Current estimate, shape (4,) or (M, 4) (read-only; assign a new one to set it)."""
        return self._engine.x

    @x.setter
    def x(self, value: Any) -> None:
        self._engine.x = value

    @property
    def P(self) -> np.ndarray:
        """Its covariance, shape (4, 4) or (M, 4, 4) (read-only; assign a new one to set it)."""
        return self._engine.P

    @P.setter
    def P(self, value: Any) -> None:
        self._engine.P = value

    @property
    def x_prior(self) -> np.ndarray:
        """The last prediction."""
        return self._engine.x_prior

    @property
    def P_prior(self) -> np.ndarray:
        """Its covariance."""
        return self._engine.P_prior

    @property
    def y(self) -> np.ndarray:
        """The last innovation (m² for the pair, m for the single range), NaN where no update was made."""
        return self._engine.y

    @property
    def S(self) -> np.ndarray:
        """Its covariance."""
        return self._engine.S

    @property
    def accepted(self) -> np.ndarray:
        """Whether the last update used a measurement, ``()`` or ``(M,)``."""
        return self._engine.accepted

    @property
    def k(self) -> int:
        """Index of the current step (-1 before the first ``predict``)."""
        return self._engine.k

    #: Per-step attributes recorded in a result's ``extras`` (the protocol's ``extra_outputs``).
    extra_outputs = ("accepted",)
    result_type = FilterResult
    # the configuration rule (base.Configurable): the models are built from these at construction (the leader's
    # track and the DR displacements are in them), so none can change afterwards; y, S, accepted are read-only
    _fixed = ("Q", "R", "dt", "leader", "u", "P0", "formulation", "lost", "range_variance", "range_noise",
              "relative_track_deviation", "motion", "measurement")
    _diagnostics = ("y", "S", "accepted")

    def _measurement(self, z: Any) -> np.ndarray:
        z = as_range_array("z", z, allow_nan=True)
        if self.formulation == "single_range":
            return z
        if z.shape[-1:] != (2,):
            raise ValueError(f"z must be the two ranges [r_k, r_(k+1)] of the step, shape (2,) or (M, 2); got shape "
                             f"{z.shape}")
        if self.lost == "step":                   # a lost end makes the whole pair missing
            z = np.where(np.isnan(z).any(axis=-1, keepdims=True), np.nan, z)
        return np.square(z)

    def predict(self, u: Any = None) -> None:
        """Predict over the next interval with ``u`` (default: the displacement of this step from ``u``)."""
        if u is None:
            k = self._engine.k + 1
            if k >= self.u.shape[-2]:
                raise IndexError(f"no DR displacement for step {k}: u holds {self.u.shape[-2]} intervals")
            u = self.u[..., k, :]
        self._engine.predict(u)

    def update(self, z: Any) -> None:
        """Update with this step's measurement (NaN = predict only): the ranges ``[r_k, r_(k+1)]`` at both ends of
        the interval for the pair formulations, the range ``r_(k+1)`` for ``"single_range"``."""
        self._engine.update(self._measurement(z))

    def run(self, z: Any, u: Any = None, times: Any = None) -> FilterResult:
        """Run every step (``run_filter``): ``z`` the measurements of the steps, ``(K, 2)``/``(M, K, 2)`` range pairs
        (``range_pairs(ranges)``) or, for ``"single_range"``, ``(K,)``/``(M, K)`` ranges; ``u`` the displacements
        (default: those given at construction)."""
        return run_filter(self, z, self.u if u is None else u, times)


def cooperative_ekf(x0: ArrayLike, P0: ArrayLike, u: ArrayLike, leader: ArrayLike, ranges: ArrayLike, dt: Any,
                    Q: ArrayLike, R: ArrayLike, times: ArrayLike | None = None, *, formulation: str = "consistent",
                    range_variance: Any = None, lost: str = "step") -> FilterResult:
    r"""Run paper B's cooperative EKF over a whole run (or ``M`` runs at once).

    Parameters
    ----------
    x0 : array_like, shape (4,) or (M, 4)
        Initial :math:`[x, y, U_x, U_y]` at the epoch of ``ranges[..., 0]``.
    P0 : array_like, shape (4, 4) or (M, 4, 4)
        Its covariance.
    u : array_like, shape (K, 2) or (M, K, 2)
        The follower's DR displacement through the water over each interval (paper B's motion radius vector) [m].
    leader : array_like, shape (K + 1, 2) or (M, K + 1, 2)
        The leader's broadcast positions at the ranging epochs [m].
    ranges : array_like, shape (K + 1,) or (M, K + 1)
        Ranges at the epochs [m]; NaN = lost message.
    dt : float
        :math:`\delta t` [s].
    Q : array_like, shape (6, 6)
        Paper B's :math:`\mathbf{Q}`.
    R : array_like, shape (10, 10)
        Paper B's :math:`\mathbf{R}`.
    times : array_like, shape (K,), optional
        Times of epochs 1..K (default :math:`k\,\delta t`).
    formulation : {"consistent", "literal", "single_range"}, default "consistent"
        See ``CooperativeEKF``.
    range_variance : float, optional
        For ``"single_range"``.
    lost : {"step", "range"}, default "step"
        See ``CooperativeEKF``.

    Returns
    -------
    FilterResult
        ``x[..., k, :]`` is the state at the epoch of ``ranges[..., k + 1]``; ``extras["accepted"]`` marks the steps
        with an update.

    Warns
    -----
    UnobservableWarning
        Where the relative track is straight within the range noise (a leader on a parallel course).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.filters import cooperative_ekf
    >>> from uwtutor.scenarios import paper_b
    >>> sc = paper_b.make(np.random.default_rng(0), n_runs=4)
    >>> p = paper_b.PARAMETERS
    >>> res = cooperative_ekf(
    ...     p.x1,
    ...     np.diag([1e4, 1e4, 1.0, 1.0]),
    ...     sc.dr_displacements,
    ...     sc.leader_broadcast,
    ...     sc.ranges,
    ...     p.interval,
    ...     p.Q,
    ...     p.R,
    ... )
    >>> res.x.shape
    (4, 312, 4)
    """
    pairs = range_pairs(ranges)
    filt = CooperativeEKF(x0, P0, u, leader, dt, Q, R, formulation=formulation, range_variance=range_variance,
                          lost=lost, _n_runs=len(pairs) if pairs.ndim == 3 else None)
    if pairs.shape[-2] != filt.u.shape[-2]:
        raise ValueError(f"ranges must hold K + 1 = {filt.u.shape[-2] + 1} epochs (one more than u's intervals); "
                         f"got {pairs.shape[-2] + 1}")
    if times is None:
        times = float(as_positive("dt", dt, ndim=0)) * np.arange(1, pairs.shape[-2] + 1)
    return filt.run(pairs[..., 1] if formulation == "single_range" else pairs, times=times)
