r"""Wheel (or any body-frame) odometry as a motion model: a pose moved by a distance and a heading change.

Real logs do not come as world-frame displacements. A wheeled robot's odometry, a DVL with a compass or a gyro,
gives at each step :math:`k` the distance travelled :math:`d_k` and the change of heading :math:`\Delta\theta_k`
in the body frame, from epoch :math:`k - 1` to epoch :math:`k`: the input :math:`u_k = [d_k, \Delta\theta_k]`.
The state carries the heading :math:`\theta` (radians, counter-clockwise from the x axis) next to the position:

.. math::

    x = [x, y, \theta \;(, b_g) \;(, s) \;(, \upsilon_1, \dots)]^\mathsf{T},

optionally with a **gyro bias** :math:`b_g` [rad/s], a **range scale** :math:`s` (a sound-speed error, or a UWB
clock that runs fast: every range is :math:`s` times the true distance) and one or several **range biases**
:math:`\upsilon` [m]. The motion keeps :math:`s` and :math:`\upsilon` constant (up to their random walks): they
are there so that one motion model serves the augmented filters, and the measurement model
(:class:`~uwtutor.models.range.BeaconRanges`) reads them. The model is built from the state blocks of
:mod:`uwtutor.models.blocks` (a pose and random walks), each reachable by its slot name; a :class:`StateLayout`
gives the same slots as indices, for a measurement model made without the motion model.

.. rubric:: The motion

A gyro bias is a *rate*: the heading change a biased gyro reports over a step of :math:`\Delta t_k` seconds is
the true one plus :math:`b_g\,\Delta t_k`. The heading and the position then move as

.. math::

    \theta_k = \theta_{k-1} + \delta_k, \qquad \delta_k = \Delta\theta_k - b_{g,k-1}\,\Delta t_k,

    p_k = p_{k-1} + d_k \begin{bmatrix} \cos\alpha_k \\ \sin\alpha_k \end{bmatrix}, \qquad
    \alpha_k = \theta_{k-1} + c\,\delta_k,

with :math:`c` the **order of operations**, a documented choice (``order``):

=================  ======  ==========================================================================
``"turn-first"``   c = 1   turn by :math:`\delta_k`, then move :math:`d_k` along the *new* heading
                           (the default)
``"move-first"``   c = 0   move along the *old* heading, then turn
``"midpoint"``     c = ½   move along the mean heading of the step (the chord of an arc of constant
                           turn rate: exact to second order when the log's steps are long turns)
=================  ======  ==========================================================================

The heading is wrapped to :math:`[-\pi, \pi)` after every prediction. The Jacobian
:math:`F = \partial f / \partial x` is the identity plus

.. math::

    F_{x\theta} = -d_k \sin\alpha_k, \quad F_{y\theta} = d_k \cos\alpha_k, \quad
    F_{x b} = c\,\Delta t_k\,d_k \sin\alpha_k, \quad F_{y b} = -c\,\Delta t_k\,d_k\cos\alpha_k, \quad
    F_{\theta b} = -\Delta t_k .

.. rubric:: The noise

The odometry is in error by :math:`n_k \sim N(0, \Sigma_u)`, :math:`\Sigma_u = \operatorname{diag}(\sigma_{d,k}^2,
\sigma_{\theta,k}^2)` (the distance and heading-change noise of one step), which enters through the Jacobian
with respect to the input,

.. math::

    G_k = \frac{\partial f}{\partial u} = \begin{bmatrix} \cos\alpha_k & -c\,d_k \sin\alpha_k \\
    \sin\alpha_k & c\,d_k\cos\alpha_k \\ 0 & 1 \\ 0 & 0 \end{bmatrix}, \qquad
    Q_k = G_k \Sigma_u G_k^\mathsf{T} + \operatorname{diag}(0, 0, 0, q_b\,\Delta t_k, q_s\,\Delta t_k,
    q_\upsilon\,\Delta t_k),

the last terms the random walks of the bias, scale and range-bias states (spectral densities :math:`q`, per
second; per step when the model has no times). Everything is evaluated at the estimate, for all ``M`` runs at
once (``f`` ``(M, n)``, ``F`` and ``Q`` ``(M, n, n)``).

.. rubric:: A filter over a dataset, in a few lines

With ``data`` a ``uwtutor.datasets.RangeDataset`` (its ``odometry`` the per-step ``[distance, heading
change]``, row ``k`` the motion from ``times[k-1]`` to ``times[k]``), a filter with a gyro bias and a range
scale is::

    motion = OdometryMotion(0.02, 0.005, gyro_bias=True, scale=True, times=data.times,
                            gyro_bias_walk=1e-5, scale_walk=1e-6)
    ranges = BeaconRanges(data.beacon_positions(ids), R=0.1**2, layout=motion.layout)
    x0, P0 = motion.layout.initial_state(data.start, data.start_cov,
                                         gyro_bias=(0.0, 0.01), scale=(1.0, 0.1))
    result = extended_kalman_filter(motion, ranges, x0, P0, data.odometry,
                                    data.ranges_on_epochs(ids), times=data.times,
                                    gate=ReacquiringGate())

References
----------
Thrun, S., Burgard, W. and Fox, D. (2005). *Probabilistic Robotics*. MIT Press. Chapter 5 (odometry motion
models; the input-noise Jacobian), sec. 7.4 (the EKF with an odometry model).
Farrell, J. A. (2008). *Aided Navigation: GPS with High Rate Sensors*. McGraw-Hill. Sec. 4.9 (gyro bias as a
rate; state augmentation with sensor biases and scale factors).
"""

from __future__ import annotations

import copy
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validate import as_choice, as_covariance, as_finite, as_flag, as_int, as_nonnegative
from .blocks import (_MAX_STD, ORDERS, BlockMotion, OdometryPose, RandomWalk, StateBlock, _durations, _name, _wrap)
from .noise import per_run_generators, standard_normal_per_run

__all__ = ["StateLayout", "OdometryMotion", "wrap_angle", "ORDERS"]

def wrap_angle(angle: ArrayLike) -> NDArray[np.float64]:
    r"""Angles wrapped to :math:`[-\pi, \pi)` [rad].

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.models.odometry import wrap_angle
    >>> wrap_angle(np.array([3 * np.pi / 2, -np.pi, np.pi, 0.1]))
    array([-1.57079633, -3.14159265, -3.14159265,  0.1       ])
    """
    return _wrap(as_finite("angle", angle, nonempty=True))


def _index(name: str, value: Any, n: int, taken: dict[int, str]) -> int:
    i = as_int(name, value, minimum=2)
    if i >= n:
        raise ValueError(f"{name} must index the state (2..{n - 1}; 0 and 1 are the position); got {i}")
    if i in taken:
        raise ValueError(f"{name} = {i} is already the index of {taken[i]}: give each state its own index")
    taken[i] = name
    return i


#: The slots :class:`StateLayout` names by its fields (an ``extra`` slot may not take one of these names).
_FIELD_SLOTS = frozenset({"position", "heading", "gyro_bias", "scale", "range_bias", "x", "y"})


@dataclass(frozen=True)
class StateLayout:
    r"""Which component of the state is what: the contract between a motion and a measurement model.

    The position is always ``x[..., :2]`` (the library's convention); the other slots are optional, each at the
    indices given (one for the heading, the gyro bias and the scale; one or several for the range biases and an
    ``extra`` slot). Build one with :meth:`odometry` (the state of :class:`OdometryMotion`) or :meth:`position`
    (the dead-reckoning state of :class:`~uwtutor.models.dead_reckoning.DeadReckoning`), or give the indices yourself.

    A layout names its slots as a motion model built from blocks does (:attr:`slots`, :meth:`slot`, the
    ``position`` and each further state by its field's name), so a measurement model reads either one
    (:class:`~uwtutor.models.blocks.BlockMeasurement`): the layout is the same state given by its indices, for a
    measurement model made apart from its motion model. ``StateLayout.position(range_bias=True)`` has the slots of
    ``DeadReckoning(Q, names=("range_bias",))``; with the motion model at hand, pass it (``state=motion``).

    Parameters
    ----------
    n : int
        Size of the state (>= 2).
    heading : int, optional
        Index of the heading :math:`\theta` [rad].
    gyro_bias : int, optional
        Index of the gyro bias :math:`b_g` [rad/s].
    scale : int, optional
        Index of the range scale :math:`s` (dimensionless, about 1).
    range_bias : tuple of int, optional
        Indices of the range biases [m]: one shared by every beacon, or one per beacon (in the order of the
        measurement model's beacons).
    extra : dict of str to int or tuple of int, optional
        Any further slot by its name and indices, e.g. ``{"clock": (3, 4)}`` for a clock's offset and rate: the
        slots of blocks the fields above do not name (a measurement model reads them by name, as it reads a
        :class:`~uwtutor.models.blocks.BlockMotion`'s).

    Examples
    --------
    >>> from uwtutor.models import StateLayout
    >>> layout = StateLayout.odometry(gyro_bias=True, scale=True)
    >>> layout.n, layout.names
    (5, ('x', 'y', 'heading', 'gyro_bias', 'scale'))
    >>> StateLayout.position(range_bias=True).names
    ('x', 'y', 'range_bias')

    A slot the fields do not name, given by its indices:

    >>> clocked = StateLayout(n=5, scale=2, extra={"clock": (3, 4)})
    >>> clocked.slots, clocked.slot("clock"), clocked.names
    (('position', 'scale', 'clock'), array([3, 4]), ('x', 'y', 'scale', 'clock_0', 'clock_1'))
    """

    n: int
    heading: int | None = None
    gyro_bias: int | None = None
    scale: int | None = None
    range_bias: tuple[int, ...] = ()
    extra: Mapping[str, int | Sequence[int]] = field(default_factory=dict, compare=False)
    # extra as ((name, indices), ...), checked: what the layout compares and hashes
    _extra: tuple[tuple[str, tuple[int, ...]], ...] = field(init=False, repr=False, default=())

    def __post_init__(self) -> None:
        n = as_int("n", self.n, minimum=2)
        taken: dict[int, str] = {}
        for name in ("heading", "gyro_bias", "scale"):
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, _index(name, value, n, taken))
        rb = self.range_bias
        rb = () if rb is None else (rb,) if isinstance(rb, (int, np.integer)) else tuple(rb)
        object.__setattr__(self, "range_bias", tuple(_index(f"range_bias[{j}]", i, n, taken)
                                                     for j, i in enumerate(rb)))
        object.__setattr__(self, "_extra", self._extra_slots(self.extra, n, taken))
        if self.gyro_bias is not None and self.heading is None:
            raise ValueError("a gyro_bias state needs a heading state (the bias turns the heading): give heading")
        object.__setattr__(self, "n", n)

    @staticmethod
    def _extra_slots(extra: Any, n: int, taken: dict[int, str]) -> tuple[tuple[str, tuple[int, ...]], ...]:
        """``extra`` as ``((name, indices), ...)``: hashable, so that the layout stays a frozen value."""
        pairs = extra.items() if isinstance(extra, Mapping) else extra
        try:
            pairs = [(name, idx) for name, idx in pairs]
        except (TypeError, ValueError):
            raise TypeError(f"extra must map slot names to indices, e.g. {{'clock': (3, 4)}}; got {extra!r}") from None
        out: list[tuple[str, tuple[int, ...]]] = []
        for name, idx in pairs:
            name = _name(name, "extra's slot name")
            if name in _FIELD_SLOTS:
                raise ValueError(f"extra names the slot {name!r}, which is a field of StateLayout: give it as "
                                 f"{name}=... instead")
            if name in {slot for slot, _ in out}:
                raise ValueError(f"extra names the slot {name!r} twice")
            idx = (idx,) if isinstance(idx, (int, np.integer)) else tuple(idx)
            if not idx:
                raise ValueError(f"extra slot {name!r} has no index: give at least one")
            out.append((name, tuple(_index(f"extra[{name!r}]", i, n, taken) for i in idx)))
        return tuple(out)

    @classmethod
    def odometry(cls, *, gyro_bias: bool = False, scale: bool = False, range_bias: Any = False) -> "StateLayout":
        """The state ``[x, y, heading (, gyro_bias) (, scale) (, range biases)]``, in that order.

        ``range_bias`` is False (none), True (one shared by every beacon) or a number of range biases (one per
        beacon).
        """
        return cls._build(3, heading=2, gyro_bias=gyro_bias, scale=scale, range_bias=range_bias)

    @classmethod
    def position(cls, *, scale: bool = False, range_bias: Any = False) -> "StateLayout":
        """The state ``[x, y (, scale) (, range biases)]`` of dead reckoning in world-frame displacements."""
        return cls._build(2, heading=None, gyro_bias=False, scale=scale, range_bias=range_bias)

    @classmethod
    def _build(cls, n: int, *, heading: int | None, gyro_bias: Any, scale: Any, range_bias: Any) -> "StateLayout":
        idx: dict[str, Any] = {"heading": heading}
        if as_flag("gyro_bias", gyro_bias):
            idx["gyro_bias"], n = n, n + 1
        if as_flag("scale", scale):
            idx["scale"], n = n, n + 1
        if isinstance(range_bias, (bool, np.bool_)):
            count = int(range_bias)
        else:
            count = as_int("range_bias", range_bias, minimum=0)
        idx["range_bias"] = tuple(range(n, n + count))
        return cls(n=n + count, **idx)

    @property
    def names(self) -> tuple[str, ...]:
        """The name of each state component, in order; the components of a slot of several are numbered
        (``range_bias_0``, ``range_bias_1``)."""
        names = ["x", "y"] + ["?"] * (self.n - 2)
        for name in ("heading", "gyro_bias", "scale"):
            if getattr(self, name) is not None:
                names[getattr(self, name)] = name
        for slot, idx in (("range_bias", self.range_bias),) + self._extra:
            for j, i in enumerate(idx):
                names[i] = slot if len(idx) == 1 else f"{slot}_{j}"
        return tuple(names)

    @property
    def slots(self) -> tuple[str, ...]:
        """The slot names of the state (as :attr:`~uwtutor.models.blocks.BlockMotion.slots`): ``position``, and
        ``heading``, ``gyro_bias``, ``scale``, ``range_bias`` when the layout has them, then the ``extra`` slots."""
        return (("position",) + tuple(name for name in ("heading", "gyro_bias", "scale")
                                      if getattr(self, name) is not None)
                + (("range_bias",) if self.range_bias else ()) + tuple(slot for slot, _ in self._extra))

    def slot(self, name: str) -> np.ndarray:
        """The indices of a slot, so that a measurement model reads a layout as it reads a
        :class:`~uwtutor.models.blocks.BlockMotion` (:class:`~uwtutor.models.blocks.BlockMeasurement`).

        Examples
        --------
        >>> from uwtutor.models import StateLayout
        >>> StateLayout.odometry(scale=True, range_bias=2).slot("range_bias")
        array([4, 5])
        """
        if name not in self.slots:
            raise KeyError(f"no slot {name!r} in this layout; its slots are {list(self.slots)}")
        return np.array(self._indices(name))

    def _indices(self, name: str) -> tuple[int, ...]:
        if name == "position":
            return (0, 1)
        if name == "range_bias":
            return self.range_bias
        extra = dict(self._extra)
        return extra[name] if name in extra else (int(getattr(self, name)),)

    def initial_state(self, start: Any, start_cov: Any, **further: Any) -> tuple[np.ndarray, np.ndarray]:
        r"""The initial state and covariance: a start pose and its covariance, augmented with the extra states.

        Parameters
        ----------
        start : array_like, shape (q,) or (M, q)
            The first ``q`` components of the state (``[x, y]``, or ``[x, y, heading]`` for an odometry state).
        start_cov : array_like, shape (q, q)
            Their covariance (positive definite).
        **further : (mean, std)
            One pair per further slot of the layout: ``gyro_bias=(0.0, 0.01)`` [rad/s], ``scale=(1.0, 0.1)``,
            ``range_bias=(0.0, 1.0)`` [m], and each ``extra`` slot by its name: numbers shared by the slot's
            components, or one per component (``clock=([0.0, 0.0], [1e-3, 1e-4])``). Each is uncorrelated with the
            rest.

        Returns
        -------
        x0 : ndarray, shape (n,) or (M, n)
        P0 : ndarray, shape (n, n)

        Examples
        --------
        >>> import numpy as np
        >>> from uwtutor.models import StateLayout
        >>> layout = StateLayout.odometry(scale=True)
        >>> x0, P0 = layout.initial_state(
        ...     [1.0, 2.0, 0.5], np.diag([1.0, 1.0, 0.01]), scale=(1.0, 0.1)
        ... )
        >>> x0, np.diag(P0)
        (array([1. , 2. , 0.5, 1. ]), array([1.  , 1.  , 0.01, 0.01]))
        """
        lead = self.heading + 1 if self.heading is not None else 2
        s = as_finite("start", start, ndim=(1, 2))
        if s.shape[-1] != lead:
            raise ValueError(f"start must hold the first {lead} states {list(self.names[:lead])}; got shape "
                             f"{s.shape}")
        C = as_covariance("start_cov", start_cov, lead)
        if C.ndim != 2:
            raise ValueError(f"start_cov must be one ({lead}, {lead}) matrix; got shape {C.shape}")
        wanted = set(self.slots) - {"position", "heading"}
        if set(further) != wanted:
            missing, unknown = sorted(wanted - set(further)), sorted(set(further) - wanted)
            raise ValueError(f"initial_state needs (mean, std) for each further state of the layout {sorted(wanted)}; "
                             + (f"missing {missing}" if missing else "") + ("; " if missing and unknown else "")
                             + (f"not in the layout: {unknown}" if unknown else ""))
        x0 = np.zeros(s.shape[:-1] + (self.n,))
        P0 = np.zeros((self.n, self.n))
        x0[..., :lead] = s
        P0[:lead, :lead] = C
        for name, pair in further.items():
            idx = self._indices(name)
            pair = as_finite(name, pair)
            if pair.shape not in ((2,), (2, len(idx))):
                raise ValueError(f"{name} must be (mean, std), numbers or one per component of the slot "
                                 f"({len(idx)}); got shape {pair.shape}")
            if np.any(pair[1] <= 0):
                raise ValueError(f"{name} must be (mean, std) with std > 0; got std {np.min(pair[1]):g}")
            x0[..., idx] = pair[0]
            P0[idx, idx] = pair[1] ** 2
        if lead < self.n and np.any(np.all(P0[lead:, lead:] == 0, axis=1)):
            unnamed = [self.names[i] for i in range(lead, self.n) if P0[i, i] == 0]
            raise ValueError(f"the layout has states without an initial value: {unnamed}")
        return x0, P0


class OdometryMotion(BlockMotion):
    r"""A pose moved by body-frame odometry ``u = [distance, heading change]``, with optional bias states.

    Equations in the module docstring: heading and position moved in the order ``order``, the gyro bias
    :math:`b_g` (a rate, rad/s) taken off the heading change, scale and range biases kept constant; the noise is
    the odometry noise through :math:`G = \partial f / \partial u` plus random walks.

    It is a :class:`~uwtutor.models.blocks.BlockMotion` of named blocks: an
    :class:`~uwtutor.models.blocks.OdometryPose` (``pose``, with the slots ``position`` and ``heading``) and one
    :class:`~uwtutor.models.blocks.RandomWalk` for each of ``gyro_bias``, ``scale`` and ``range_bias`` it has, so
    ``motion.slot("scale")`` finds a state by name. Its ``f``, ``F``, ``Q`` and ``sample`` run the pose block's
    arithmetic on the whole state at once (one call instead of one per block: the hot path of
    :func:`~uwtutor.datasets.navigate`), which gives the same bits as the block-by-block assembly.

    Parameters
    ----------
    sigma_distance : float or array_like, shape (K,)
        Standard deviation of the distance of one step :math:`\sigma_{d,k}` [m], >= 0; one per step is allowed
        (e.g. proportional to the distance: ``0.01 + 0.02 * abs(odometry[:, 0])``).
    sigma_heading : float or array_like, shape (K,)
        Standard deviation of the heading change of one step :math:`\sigma_{\theta,k}` [rad], >= 0.
    gyro_bias : bool, default False
        Add a gyro bias state [rad/s] (then ``times`` or ``dt`` is needed: the bias turns the heading by
        :math:`b_g\,\Delta t_k`).
    scale : bool, default False
        Add a range scale state (constant up to ``scale_walk``), read by the range model.
    range_bias : bool or int, default False
        Add a range bias state (True: one shared; an int: that many, one per beacon), read by the range model.
    times : array_like, shape (K,), optional
        Epoch times [s], non-decreasing: step ``k`` lasts ``times[k] - times[k - 1]``. The state before the first
        step is the state at ``times[0]``, so the first step lasts 0 s (a dataset's start pose, its odometry row
        0 the motion up to ``times[0]``).
    dt : float or array_like, shape (K,), optional
        The step lengths :math:`\Delta t_k` [s] directly, instead of ``times`` (e.g. to give the first step a
        length).
    order : {"turn-first", "move-first", "midpoint"}, default "turn-first"
        The order of operations within a step (module docstring).
    gyro_bias_walk : float, default 0
        :math:`\sqrt{q_b}` [rad/s/√s]: how fast the gyro bias wanders (0: a constant).
    scale_walk : float, default 0
        :math:`\sqrt{q_s}` [1/√s] for the scale.
    range_bias_walk : float, default 0
        :math:`\sqrt{q_\upsilon}` [m/√s] for the range biases.

    Attributes
    ----------
    layout : StateLayout
        Which index is what (pass it to the range model).
    n : int
        Size of the state.
    n_steps : int or None
        Number of steps the per-step arrays cover (None when every parameter is one number).
    pose : OdometryPose
        The pose block (its noise ``sigma_distance``, ``sigma_heading`` and ``order`` are the model's).
    blocks : tuple of StateBlock
        The pose and the random walks, in the order of the state.

    Examples
    --------
    A quarter turn, then 10 m along the new heading (turn first, the default):

    >>> import numpy as np
    >>> from uwtutor.models import OdometryMotion
    >>> motion = OdometryMotion(sigma_distance=0.1, sigma_heading=0.01)
    >>> motion.f(
    ...     np.array([[0.0, 0.0, 0.0]]), np.array([10.0, np.pi / 2]), 0
    ... ).round(6)
    array([[ 0.      , 10.      ,  1.570796]])
    >>> OdometryMotion(0.1, 0.01, order="move-first").f(
    ...     np.array([[0.0, 0.0, 0.0]]), np.array([10.0, np.pi / 2]), 0
    ... ).round(6)
    array([[10.      ,  0.      ,  1.570796]])

    With a gyro bias of 0.01 rad/s over 2 s steps, a measured heading change of 0.02 rad is no turn at all:

    >>> biased = OdometryMotion(0.1, 0.01, gyro_bias=True, dt=2.0)
    >>> biased.layout.names, biased.slot("gyro_bias")
    (('x', 'y', 'heading', 'gyro_bias'), array([3]))
    >>> biased.f(np.array([[0.0, 0.0, 0.0, 0.01]]), np.array([5.0, 0.02]), 0)
    array([[5.  , 0.  , 0.  , 0.01]])
    """

    def __init__(self, sigma_distance: ArrayLike, sigma_heading: ArrayLike, *, gyro_bias: bool = False,
                 scale: bool = False, range_bias: Any = False, times: ArrayLike | None = None,
                 dt: ArrayLike | None = None, order: str = "turn-first", gyro_bias_walk: Any = 0.0,
                 scale_walk: Any = 0.0, range_bias_walk: Any = 0.0) -> None:
        as_choice("order", order, ORDERS)
        self.layout = StateLayout.odometry(gyro_bias=gyro_bias, scale=scale, range_bias=range_bias)
        pose = OdometryPose(sigma_distance, sigma_heading, order=order,
                            gyro_bias="gyro_bias" if self.layout.gyro_bias is not None else None)
        durations, steps_from_times = _durations(times, dt)
        if self.layout.gyro_bias is not None and durations is None:
            raise ValueError("a gyro bias is a rate (rad/s): give times (the epoch times, s) or dt (the step "
                             "lengths, s) so that the model knows how long each step lasts")
        walks = {"gyro_bias": (gyro_bias_walk, self.layout.gyro_bias is not None, 1),
                 "scale": (scale_walk, self.layout.scale is not None, 1),
                 "range_bias": (range_bias_walk, bool(self.layout.range_bias), len(self.layout.range_bias))}
        blocks: list[StateBlock] = [pose]
        for name, (value, present, size) in walks.items():
            walk = RandomWalk(name, as_nonnegative(f"{name}_walk", value, ndim=0, max_abs=_MAX_STD),
                              size=max(size, 1))
            if walk.q > 0 and not present:
                raise ValueError(f"{name}_walk was given but the state has no {name} (set {name}=True)")
            if present:
                blocks.append(walk)
        super().__init__(*blocks, times=times, dt=dt)
        self.pose = pose
        self.order, self._c = pose.order, pose._c
        self.sigma_distance, self.sigma_heading = pose.sigma_distance, pose.sigma_heading
        variances = np.zeros(self.n)                        # q per second (or per step), on the diagonal
        for block, own in zip(self.blocks, self._own):
            if isinstance(block, RandomWalk):
                variances[own] = block.q
        self._set_walks(variances)
        self._eye = np.eye(self.n)
        self._bias = self.layout.gyro_bias

    def _set_walks(self, walk: np.ndarray) -> None:
        """Keep the walks' variances per second, ``(n,)`` shared by every run or ``(M, n)`` one row per run."""
        self._walk = walk
        self._has_walk = bool(walk.any())
        self._walking = np.flatnonzero(walk if walk.ndim == 1 else walk.any(axis=0))   # the states with a walk
        self._walk_std = np.sqrt(walk[..., self._walking])                             # its std per 1 s
        self._walk_diag = walk[..., :, None] * np.eye(self.n)
        if walk.ndim == 2:
            self.n_runs = walk.shape[0]

    def _with_walks_per_run(self, walks: np.ndarray) -> "OdometryMotion":
        """This model for ``M`` runs at once, run ``m`` with the random walks ``walks[m]`` ``(M, n)`` [per √s] on
        the states (0 elsewhere; a state without a walk stays at its start when its variance starts at 0).

        It lets several variants of one model -- some states pinned, others free -- run as the runs of one
        batched filter (:func:`uwtutor.datasets.navigate`'s candidate models): the engine then steps them all at
        the per-step cost of one.
        """
        walks = np.asarray(walks, dtype=float)
        if walks.ndim != 2 or walks.shape[1] != self.n or not (np.isfinite(walks).all() and (walks >= 0).all()):
            raise ValueError(f"walks must be finite and >= 0, one row of {self.n} per run; got shape {walks.shape}")
        out = copy.copy(self)
        out._set_walks(walks**2)
        return out

    # -- the fused path: the pose block's arithmetic on the whole state, the walks on the diagonal --
    def _parts(self, x: np.ndarray, u: Any, k: int) -> tuple[Any, Any, np.ndarray, np.ndarray, float]:
        """Distance d_k, turn delta_k, cos and sin of the move heading alpha_k, and dt of step k."""
        dt = self.dt(self._checked_step(k))
        bias = x[..., self._bias] if self._bias is not None else None
        return self.pose._step(x, bias, u, dt) + (dt,)

    def _Q(self, G: np.ndarray, k: int, dt: float) -> np.ndarray:
        Q = self.pose._noise(G, k)                               # G Sigma_u G^T
        if self._has_walk:
            Q += self._walk_diag * dt
        return Q

    def f(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        d, turn, ca, sa, _ = self._parts(x, u, k)
        return self.pose._moved(x, d, turn, ca, sa)

    def F(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        d, _, ca, sa, dt = self._parts(x, u, k)
        return self.pose._jacobian(x, self._eye, self._bias, d, ca, sa, dt)

    def G(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        r"""The Jacobian :math:`G = \partial f / \partial u` with respect to the odometry, ``(M, n, 2)``."""
        d, _, ca, sa, _ = self._parts(x, u, k)
        return self.pose._input_jacobian(x, self.n, d, ca, sa)

    def Q(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        d, _, ca, sa, dt = self._parts(x, u, k)
        return self._Q(self.pose._input_jacobian(x, self.n, d, ca, sa), k, dt)

    def linearize(self, x: np.ndarray, u: Any, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        d, turn, ca, sa, dt = self._parts(x, u, k)
        return (self.pose._moved(x, d, turn, ca, sa), self.pose._jacobian(x, self._eye, self._bias, d, ca, sa, dt),
                self._Q(self.pose._input_jacobian(x, self.n, d, ca, sa), k, dt))

    def sample(self, x: np.ndarray, u: Any, k: int, rng: Any) -> np.ndarray:
        r"""Draw the next poses of particles ``x`` ``(M, N, n)`` with the noise in the odometry itself.

        Each particle moves by its own noisy reading of the step, :math:`\tilde d = d_k + \sigma_{d,k}
        \varepsilon_1`, :math:`\widetilde{\Delta\theta} = \Delta\theta_k + \sigma_{\theta,k}\varepsilon_2`,
        through the exact :math:`f` (the sample odometry motion model of Thrun et al. 2005, sec. 5.4), and the
        bias, scale and range-bias states take their random walks, :math:`\sqrt{q\,\Delta t_k}\,\varepsilon`.
        The :math:`Q_k = G_k \Sigma_u G_k^\mathsf{T} + \dots` of the Kalman filters is the linearization of this
        draw; a state without a walk does not move (its :math:`Q` is singular). Run ``m`` draws
        :math:`\varepsilon`, ``(N, 2 + w)`` (w the states with a walk), from ``rng[m]``: the draws of
        :meth:`BlockMotion.sample <uwtutor.models.blocks.BlockMotion.sample>` on the same blocks.

        Examples
        --------
        >>> import numpy as np
        >>> from uwtutor.models import OdometryMotion
        >>> # the scale has no walk: it stays
        >>> motion = OdometryMotion(0.1, 0.01, scale=True)
        >>> x = np.tile([0.0, 0.0, 0.0, 1.07], (1, 1000, 1))
        >>> new = motion.sample(
        ...     x, np.array([10.0, 0.0]), 0, [np.random.default_rng(0)]
        ... )
        >>> round(float(new[0, :, 0].std()), 2), bool(np.all(new[..., 3] == 1.07))
        (0.1, True)
        """
        k = self._checked_step(k)
        walking = self._walking
        eps = standard_normal_per_run(per_run_generators(rng, x.shape[0], spawn=False),
                                      x.shape[1:-1] + (2 + walking.size,))
        out = self.f(x, self.pose._noisy(u, k, eps), k)
        if walking.size:
            std = self._walk_std if self._walk_std.ndim == 1 else self._walk_std[:, None, :]
            out[..., walking] += eps[..., 2:] * (std * np.sqrt(self.dt(k)))
        return out

    def integrate(self, x0: Any, u: Any) -> np.ndarray:
        r"""Dead reckoning: the states :math:`x_1, \dots, x_K` that the odometry alone gives from ``x0`` (no noise).

        Parameters
        ----------
        x0 : array_like, shape (n,) or (M, n)
            The state before the first step.
        u : array_like, shape (K, 2) or (M, K, 2)
            The odometry of each step.

        Returns
        -------
        ndarray, shape (K, n) or (M, K, n)

        Examples
        --------
        >>> import numpy as np
        >>> from uwtutor.models import OdometryMotion
        >>> # 10 m, then a left turn, 4 times
        >>> square = np.tile([[10.0, 0.0], [0.0, np.pi / 2]], (4, 1))
        >>> (
        ...     OdometryMotion(0.0, 0.0)
        ...     .integrate([0.0, 0.0, 0.0], square)[-1]
        ...     .round(9)
        ...     + 0.0
        ... )
        array([0., 0., 0.])
        """
        x = as_finite("x0", x0, ndim=(1, 2))
        if x.shape[-1] != self.n:
            raise ValueError(f"x0 must have {self.n} entries {list(self.layout.names)}; got shape {x.shape}")
        uu = as_finite("u", u, ndim=(2, 3))
        if uu.shape[-1] != 2:
            raise ValueError(f"u must hold [distance, heading change] per step, shape (K, 2) or (M, K, 2); got "
                             f"{uu.shape}")
        single = x.ndim == 1 and uu.ndim == 2
        M = max(x.shape[0] if x.ndim == 2 else 1, uu.shape[0] if uu.ndim == 3 else 1)
        state = np.array(np.broadcast_to(x, (M, self.n)))
        K = uu.shape[-2]
        out = np.empty((M, K, self.n))
        for k in range(K):
            state = self.f(state, uu[:, k] if uu.ndim == 3 else uu[k], k)
            out[:, k] = state
        return out[0] if single else out
