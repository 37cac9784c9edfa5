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

**The leader as a step's input.** The leader's position at each epoch is not a sequence fixed when the filter is
built: like a variable of a factor graph (GTSAM's range factor takes the keys it joins), it is an input of each
step's measurement. ``CooperativeEKF(x0, P0, Q, R, dt=...)`` holds no sequence: ``predict(u)`` takes the
step's DR displacement and ``update(z)`` the step's observation, the ranges *and* the leader's broadcast positions,
``[r_k, r_{k+1}, x^M_k, y^M_k, x^M_{k+1}, y^M_{k+1}]`` for the pair formulations or ``[r_{k+1}, x^M_{k+1},
y^M_{k+1}]`` for ``"single_range"`` (:func:`leader_observations` builds them from whole sequences); the measurement
model of the step is built from them. Given the whole run instead (``CooperativeEKF(x0, P0, Q, R, dt=..., u=...,
leader=...)``, the form ``cooperative_ekf`` uses), the filter builds the models over the whole run, and
``predict()`` and ``update(z)`` with the two ranges read the step's displacement and leader positions from them;
both forms give the same numbers, bit for bit (``tests/test_cooperative.py``).

When the follower's motion relative to the leader is a straight line (a leader that keeps a parallel course), the
ranges cannot tell the truth from a rotation of the follower about the leader together with its relative velocity,
and so the current (chapter 2): the covariance does not shrink along that direction. ``CooperativeEKF`` (and so
``cooperative_ekf``) emits an ``UnobservableWarning`` when the relative track the filter is given departs from a
straight line by less than the range noise (``relative_track_deviation``); built without the sequences, it
does so in ``run``, which has them.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validate import (MAX_COORDINATE, as_covariance, as_finite, as_flag, as_float_array, as_positive,
                        as_range_array, as_scalar, common_runs)
from ..models.base import MeasurementModel
from ..models.cooperative import CooperativeMotion, SquaredRangePair, leader_range
from ..models.range import RangeToBeacon
from ..errors import UnobservableWarning, warn
from .base import FilterResult, run_filter
from .engine import ExtendedKalmanFilter

__all__ = ["cooperative_ekf", "CooperativeEKF", "range_pairs", "leader_observations", "relative_track_deviation",
           "FORMULATIONS"]

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
    return _pairs(_epoch_ranges("ranges", ranges))


def _pairs(r: np.ndarray) -> np.ndarray:
    """``[r_k, r_(k+1)]`` for each interval of checked epoch ranges."""
    return np.stack([r[..., :-1], r[..., 1:]], axis=-1)


def _epoch_ranges(name: str, ranges: Any) -> np.ndarray:
    """The ranges of the epochs ``(K + 1,)`` or ``(M, K + 1)``, checked under the caller's name for them."""
    r = as_range_array(name, ranges, allow_nan=True, ndim=(1, 2), max_abs=MAX_COORDINATE)
    if r.shape[-1] < 2:
        raise ValueError(f"{name} must hold the ranges of at least two epochs (one interval); got shape {r.shape}")
    return r


def leader_observations(ranges: ArrayLike, leader: ArrayLike, *, single_range: bool = False) -> NDArray[np.float64]:
    r"""The observations of paper B's steps with the leader's positions in them: what ``update(z)`` of a
    :class:`CooperativeEKF` built without sequences takes, step by step.

    Step :math:`k` (from epoch :math:`k` to :math:`k + 1`) observes :math:`[r_k, r_{k+1}, x^M_k, y^M_k, x^M_{k+1},
    y^M_{k+1}]`: the two ranges and the leader's broadcast positions at both ends; for ``"single_range"``,
    :math:`[r_{k+1}, x^M_{k+1}, y^M_{k+1}]`.

    Parameters
    ----------
    ranges : array_like, shape (K + 1,) or (M, K + 1)
        Ranges at the epochs [m], NaN for a lost message.
    leader : array_like, shape (K + 1, 2) or (M, K + 1, 2)
        The leader's broadcast positions at the epochs [m].
    single_range : bool, default False
        The observations of the ``"single_range"`` formulation.

    Returns
    -------
    ndarray, shape (K, 6) or (M, K, 6); (K, 3) or (M, K, 3) with ``single_range``

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.filters.cooperative import leader_observations
    >>> leader_observations([100.0, 110.0], [[0.0, 0.0], [8.0, 0.0]])
    array([[100., 110.,   0.,   0.,   8.,   0.]])
    >>> leader_observations([100.0, 110.0], [[0.0, 0.0], [8.0, 0.0]], single_range=True)
    array([[110.,   8.,   0.]])
    """
    pairs = range_pairs(ranges)
    single_range = as_flag("single_range", single_range)
    b = as_finite("leader", leader, ndim=(2, 3), max_abs=MAX_COORDINATE)
    if b.shape[-1] != 2 or b.shape[-2] != pairs.shape[-2] + 1:
        raise ValueError(f"leader must have shape (..., K + 1, 2) with K + 1 = {pairs.shape[-2] + 1} epochs, one "
                         f"position per range; got {b.shape}")
    M = common_runs(dict(ranges=len(pairs) if pairs.ndim == 3 else None, leader=len(b) if b.ndim == 3 else None))
    shape = pairs.shape[:-1] if M is None else (M,) + pairs.shape[-2:-1]
    pairs = np.broadcast_to(pairs, shape + (2,))
    b = np.broadcast_to(b, shape[:-1] + b.shape[-2:])
    if single_range:
        return np.concatenate([pairs[..., 1:], b[..., 1:, :]], axis=-1)
    return np.concatenate([pairs, b[..., :-1, :], b[..., 1:, :]], axis=-1)


class _StepMeasurement(MeasurementModel):
    """The measurement model of the current step, built from that step's inputs (the leader's positions, the
    displacement): what a :class:`CooperativeEKF` without sequences hands to the engine. It answers for whatever
    step the engine is at with the one interval it holds."""

    def __init__(self, m: int) -> None:
        self.n, self.m = 4, m
        self.model: MeasurementModel | None = None

    def _step(self) -> MeasurementModel:
        if self.model is None:
            raise RuntimeError("update(z) of a CooperativeEKF built without sequences needs the step's observation "
                               "with the leader's positions (leader_observations), after predict(u)")
        return self.model

    def linearize(self, x: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return self._step().linearize(x, 0)

    def h(self, x: np.ndarray, k: int) -> np.ndarray:
        return self._step().h(x, 0)

    def H(self, x: np.ndarray, k: int) -> np.ndarray:
        return self._step().H(x, 0)

    def R(self, x: np.ndarray, k: int) -> np.ndarray:
        return self._step().R(x, 0)

    def residual(self, z: np.ndarray, z_pred: np.ndarray) -> np.ndarray:
        return self._step().residual(z, z_pred)


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


def _check_start(x0: Any, P0: Any) -> tuple[np.ndarray, np.ndarray]:
    """The initial state and its covariance, checked (a filter built without the whole run)."""
    x = as_finite("x0", x0, ndim=(1, 2), max_abs=MAX_COORDINATE)
    if x.shape[-1] != 4:
        raise ValueError(f"x0 must be [x, y, Ux, Uy] (last axis of length 4); got shape {x.shape}")
    P = as_covariance("P0", P0, 4)
    M = common_runs(dict(x0=len(x) if x.ndim == 2 else None, P0=len(P) if P.ndim == 3 else None))
    if M is not None and x.ndim == 1:
        x = np.broadcast_to(x, (M, 4)).copy()
    return x, P


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


class CooperativeEKF(ExtendedKalmanFilter):
    r"""Paper B's cooperative EKF, one step at a time (the protocol's ``predict`` / ``update``).

    Built as the other EKFs are, ``CooperativeEKF(x0, P0, Q, R, dt=...)``, it holds no sequence and takes each
    step's inputs when the step comes: ``predict(u)`` the DR displacement, ``update(z)`` the ranges and the leader's
    positions (the module docstring, :func:`leader_observations`). Given the whole run as well (``u=`` and
    ``leader=``, the form :func:`cooperative_ekf` uses), it builds the models over the whole run and reads each
    step's displacement and leader positions from them. Both give the same numbers.

    Parameters
    ----------
    x0 : array_like, shape (4,) or (M, 4)
        Initial :math:`[x, y, U_x, U_y]` at epoch 0 [m, m/s].
    P0 : array_like, shape (4, 4) or (M, 4, 4)
        Its covariance.
    Q : array_like, shape (6, 6)
        Paper B's :math:`\mathbf{Q}` over :math:`[x, y, \Delta x, \Delta y, U_x, U_y]`.
    R : array_like, shape (10, 10)
        Paper B's :math:`\mathbf{R}` (``"single_range"`` uses it only for its default ``range_variance``).
    dt : float
        :math:`\delta t` [s].
    u : array_like, shape (K, 2) or (M, K, 2), optional
        The whole run's DR displacements through the water over each interval [m] (with ``leader``); None: given
        step by step to ``predict``.
    leader : array_like, shape (K + 1, 2) or (M, K + 1, 2), optional
        The whole run's leader broadcast positions at the ranging epochs [m] (with ``u``); None: given step by step
        in the observations of ``update``.
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
    relative_track_deviation : float or ndarray or None
        ``relative_track_deviation(u, leader)`` [m]; below ``range_noise`` the constructor warns (None for a filter
        built without the whole run: its ``run`` tests the track it is given).
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
    >>> from uwtutor.filters.cooperative import CooperativeEKF, leader_observations
    >>> from uwtutor.scenarios import paper_b
    >>> sc = paper_b.make(np.random.default_rng(0), n_runs=1)
    >>> p = paper_b.PARAMETERS
    >>> f = CooperativeEKF(
    ...     p.x1,
    ...     np.diag([1e4, 1e4, 1.0, 1.0]),
    ...     p.Q,
    ...     p.R,
    ...     dt=p.interval,
    ...     u=sc.dr_displacements[0],
    ...     leader=sc.leader_broadcast[0],
    ... )
    >>> f.predict(); f.update(sc.ranges[0, :2])
    >>> f.x.shape, f.y.shape
    ((4,), (2,))

    The same step with the leader's positions as the step's input, the filter holding no sequence:

    >>> g = CooperativeEKF(p.x1, np.diag([1e4, 1e4, 1.0, 1.0]), p.Q, p.R, dt=p.interval)
    >>> obs = leader_observations(sc.ranges[0], sc.leader_broadcast[0])
    >>> g.predict(sc.dr_displacements[0, 0]); g.update(obs[0])
    >>> bool(np.array_equal(g.x, f.x)), obs.shape
    (True, (312, 6))
    """

    def __init__(self, x0: ArrayLike, P0: ArrayLike, Q: ArrayLike, R: ArrayLike, *, dt: float,
                 u: ArrayLike | None = None, leader: ArrayLike | None = None, formulation: str = "consistent",
                 range_variance: float | None = None, lost: str = "step", _n_runs: int | None = None) -> None:
        if formulation not in FORMULATIONS:
            raise ValueError(f"formulation must be one of {FORMULATIONS}; got {formulation!r}")
        if lost not in LOST_POLICIES:
            raise ValueError(f"lost must be one of {LOST_POLICIES} (a pair with one range lost: predict only, or "
                             f"update with the other range); got {lost!r}")
        if dt is None:
            raise TypeError("dt (the interval between ranging epochs, s) is required: CooperativeEKF(x0, P0, Q, R, "
                            "dt=...)")
        if (u is None) != (leader is None):
            raise TypeError("give u and leader together (the whole run: the models are built over it), or neither "
                            "(then predict(u) and update(z) take each step's displacement and leader positions)")
        self.lost = lost
        if range_variance is not None:      # checked whatever the formulation (only "single_range" uses it)
            range_variance = as_scalar("range_variance", range_variance, domain="positive")
        self.formulation = formulation
        self._sequences = u is not None
        self.u: np.ndarray | None = None
        if u is not None:
            x, P, d, b = _check_inputs(x0, P0, u, leader, _n_runs)
            self.u = d
        else:
            x, P = _check_start(x0, P0)
        self.P0 = P
        motion = CooperativeMotion(dt, Q)
        R10 = as_covariance("R", R, 10, allow_singular=True)
        self._dt, self._R10 = dt, R10
        self._u_step: np.ndarray | None = None          # the displacement of the step's prediction (no sequences)
        if formulation == "single_range":
            self._variance = R10[0, 0] + R10[2, 2] if range_variance is None else range_variance
            self.range_noise = float(np.sqrt(as_scalar("variance", self._variance, domain="positive")))
        else:
            self.range_noise = float(np.sqrt(R10[0, 0] + R10[2, 2]))
        measurement: MeasurementModel
        self._step_model: _StepMeasurement | None = None
        self.relative_track_deviation: float | np.ndarray | None = None
        if u is None:
            measurement = self._step_model = _StepMeasurement(1 if formulation == "single_range" else 2)
        else:
            if formulation == "single_range":
                measurement = leader_range(b, self._variance)
            else:
                measurement = SquaredRangePair(b, d, dt, R10, literal=formulation == "literal")
            self.relative_track_deviation = relative_track_deviation(d, b)
            _warn_straight(self.relative_track_deviation, self.range_noise)
        super().__init__(motion, measurement, x, P)

    result_type = FilterResult
    # the configuration rule (base.Configurable): the models are built from these at construction (the leader's
    # track and the DR displacements are in them), so none can change afterwards; y, S, accepted are read-only
    _fixed = ExtendedKalmanFilter._fixed + ("Q", "R", "dt", "leader", "u", "P0", "formulation", "lost",
                                            "range_variance", "range_noise", "relative_track_deviation")

    def _squared(self, z: Any) -> np.ndarray:
        z = as_range_array("z", z, allow_nan=True)
        if self.formulation == "single_range":
            return z
        if z.shape[-1:] != (2,):
            raise ValueError(f"z must be the two ranges [r_k, r_(k+1)] of the step, shape (2,) or (M, 2); got shape "
                             f"{z.shape}")
        if self.lost == "step":                   # a lost end makes the whole pair missing
            z = np.where(np.isnan(z).any(axis=-1, keepdims=True), np.nan, z)
        return np.square(z)

    def _step_inputs(self, z: Any) -> tuple[np.ndarray, MeasurementModel]:
        """The ranges of a step's observation ``z`` (see :func:`leader_observations`), the step's measurement model
        built from its leader positions and the displacement of the step's prediction."""
        pair = self.formulation != "single_range"
        width = 6 if pair else 3
        obs = as_float_array("z", z)
        if obs.shape[-1:] != (width,) or obs.ndim > 2:
            what = "[r_k, r_(k+1), xL_k, yL_k, xL_(k+1), yL_(k+1)]" if pair else "[r_(k+1), xL_(k+1), yL_(k+1)]"
            raise ValueError(f"z must be the step's observation {what}, shape ({width},) or (M, {width}) (see "
                             f"leader_observations: this filter was built without the leader's track); got shape "
                             f"{obs.shape}")
        leader = as_finite("z (its leader positions)", obs[..., 2 if pair else 1:], max_abs=MAX_COORDINATE)
        if pair:
            if self._u_step is None:
                raise RuntimeError("call predict(u) before update(z): the pair's measurement model needs the step's "
                                   "displacement")
            model: MeasurementModel = SquaredRangePair(leader.reshape(leader.shape[:-1] + (2, 2)),
                                                       self._u_step[..., None, :], self._dt, self._R10,
                                                       literal=self.formulation == "literal")
            return obs[..., :2], model
        b = leader if leader.ndim == 1 else leader[:, None, :]
        return obs[..., 0], RangeToBeacon(b, R=self._variance, n=4)

    def predict(self, u: ArrayLike | None = None) -> None:
        """Predict over the next interval with the DR displacement ``u`` (built with the whole run: by default the
        displacement of this step from it)."""
        if u is None:
            whole = self.u
            if whole is None:
                raise TypeError("u (the step's DR displacement [dx, dy], shape (2,) or (M, 2)) is required: this "
                                "filter was built without the whole run")
            k = self.k + 1
            if k >= whole.shape[-2]:
                raise IndexError(f"no DR displacement for step {k}: u holds {whole.shape[-2]} intervals")
            u = whole[..., k, :]
        super().predict(u)
        if not self._sequences:
            self._u_step = as_finite("u", u)

    def update(self, z: ArrayLike) -> None:
        """Update with this step's measurement (NaN = predict only): the ranges ``[r_k, r_(k+1)]`` at both ends of
        the interval for the pair formulations, the range ``r_(k+1)`` for ``"single_range"``, followed, for a filter
        built without the whole run, by the leader's positions (:func:`leader_observations`)."""
        if self._step_model is not None:
            z, self._step_model.model = self._step_inputs(z)
        super().update(self._squared(z))

    def run(self, z: ArrayLike, u: ArrayLike | None = None, times: ArrayLike | None = None, *,
            keep_priors: bool = True) -> FilterResult:
        """Run every step (``run_filter``): ``z`` the measurements of the steps, ``(K, 2)``/``(M, K, 2)`` range pairs
        (``range_pairs(ranges)``) or, for ``"single_range"``, ``(K,)``/``(M, K)`` ranges, followed by the leader's
        positions for a filter built without the whole run (``leader_observations(ranges, leader)``, which also
        gives this filter the track whose straightness it tests); ``u`` the displacements (default: those given at
        construction). ``keep_priors=False``: the result's priors are None."""
        if not self._sequences:
            if u is None:
                raise TypeError("u (the DR displacements of the steps) is required: this filter was built without "
                                "the whole run")
            obs = as_float_array("z", z)
            if obs.ndim >= 2 and obs.shape[-1] == 6 and self.formulation != "single_range":
                # the leader's track at epochs 0..K, from the observations: the straightness test of the constructor
                leader = np.concatenate([obs[..., :1, 2:4], obs[..., 4:6]], axis=-2)
                _warn_straight(relative_track_deviation(u, leader), self.range_noise)
        keep_priors = as_flag("keep_priors", keep_priors)
        result = run_filter(self, z, self.u if u is None else u, times)
        return result if keep_priors else dataclasses.replace(result, x_prior=None, P_prior=None)


def cooperative_ekf(x0: ArrayLike, P0: ArrayLike, u: ArrayLike, z: ArrayLike, Q: ArrayLike, R: ArrayLike,
                    times: ArrayLike | None = None, *, leader: ArrayLike, dt: float, formulation: str = "consistent",
                    range_variance: float | None = None, lost: str = "step") -> FilterResult:
    r"""Run paper B's cooperative EKF over a whole run (or ``M`` runs at once).

    The argument order is the other EKFs' (``range_only_ekf(x0, P0, u, z, Q, R, ...)``): the leader's track is
    an input of the measurement model, given by name with the interval ``dt``.

    Parameters
    ----------
    x0 : array_like, shape (4,) or (M, 4)
        Initial :math:`[x, y, U_x, U_y]` at the epoch of ``z[..., 0]``.
    P0 : array_like, shape (4, 4) or (M, 4, 4)
        Its covariance.
    u : array_like, shape (K, 2) or (M, K, 2)
        The follower's DR displacement through the water over each interval (paper B's motion radius vector) [m].
    z : array_like, shape (K + 1,) or (M, K + 1)
        The ranges to the leader at the epochs [m]; NaN = lost message.
    Q : array_like, shape (6, 6)
        Paper B's :math:`\mathbf{Q}`.
    R : array_like, shape (10, 10)
        Paper B's :math:`\mathbf{R}`.
    times : array_like, shape (K,), optional
        Times of epochs 1..K (default :math:`k\,\delta t`).
    leader : array_like, shape (K + 1, 2) or (M, K + 1, 2)
        The leader's broadcast positions at the ranging epochs [m].
    dt : float
        :math:`\delta t` [s].
    formulation : {"consistent", "literal", "single_range"}, default "consistent"
        See ``CooperativeEKF``.
    range_variance : float, optional
        For ``"single_range"``.
    lost : {"step", "range"}, default "step"
        See ``CooperativeEKF``.

    Returns
    -------
    FilterResult
        ``x[..., k, :]`` is the state at the epoch of ``z[..., k + 1]``; ``extras["accepted"]`` marks the steps
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
    ...     sc.ranges,
    ...     p.Q,
    ...     p.R,
    ...     leader=sc.leader_broadcast,
    ...     dt=p.interval,
    ... )
    >>> res.x.shape
    (4, 312, 4)
    """
    pairs = _pairs(_epoch_ranges("z", z))
    if u is None or leader is None:
        raise TypeError(f"{'u' if u is None else 'leader'} is required: cooperative_ekf runs the whole run (for one "
                        "step at a time, CooperativeEKF takes each step's displacement and leader positions)")
    filt = CooperativeEKF(x0, P0, Q, R, dt=dt, u=u, leader=leader, formulation=formulation,
                          range_variance=range_variance, lost=lost, _n_runs=len(pairs) if pairs.ndim == 3 else None)
    intervals = np.shape(u)[-2]
    if pairs.shape[-2] != intervals:
        raise ValueError(f"z must hold K + 1 = {intervals + 1} ranges (one more than u's intervals); "
                         f"got {pairs.shape[-2] + 1}")
    if times is None:
        times = float(as_positive("dt", dt, ndim=0)) * np.arange(1, pairs.shape[-2] + 1)
    return filt.run(pairs[..., 1] if formulation == "single_range" else pairs, times=times)
