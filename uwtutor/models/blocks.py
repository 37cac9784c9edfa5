r"""A state built from blocks: one motion model assembled block by block, measurement models that read slots by name.

Every augmented filter of the book adds a few states next to the position: a range bias (paper A), a bias and
its rate, a gyro bias and a range scale (a real log), a current (paper B), a clock. Here each of them is a
**block** -- a small piece of state with a name, its own motion and its own process noise -- and
:class:`BlockMotion` stacks them into one :class:`~uwtutor.models.base.MotionModel`:

.. math::

    x = \begin{bmatrix} x^{(1)} \\ \vdots \\ x^{(B)} \end{bmatrix}, \qquad
    f(x) = \begin{bmatrix} f^{(1)}(x^{(1)}, x^{(\mathcal R_1)}, u_k) \\ \vdots \end{bmatrix}, \qquad
    F = \begin{bmatrix} F^{(1)} & \cdots & \partial f^{(1)}/\partial x^{(j)} & \cdots \\ & \ddots & & \end{bmatrix},
    \qquad Q = \operatorname{blkdiag}(Q^{(1)}, \dots, Q^{(B)}),

where block :math:`i` may read the states of the blocks :math:`\mathcal R_i` it names (the pose reads the gyro
bias that turns it; a position reads the current that carries it): their columns of :math:`F` are the block's
partial derivatives. The noises of different blocks are independent, so :math:`Q` is block diagonal, and
``sample`` draws each block's noise in turn from the same per-run streams.

A block knows its **slots** by name: the block's own name (all its components) and the named parts it declares
(the pose has ``position`` and ``heading``). :meth:`BlockMotion.slot` turns a name into indices, and a measurement
model built on :class:`BlockMeasurement` declares the slots it reads (``reads``) and finds them there -- no index
is written twice, and adding a block never moves another model's index by hand. The precedents: Stone Soup's
combined linear-Gaussian transition model (block-diagonal transitions) and its measurement models' ``mapping``;
GTSAM's keys, by which a factor names the variables it reads.

The whole thing is a motion model and a measurement model like every other of the library: it runs in
:func:`uwtutor.filters.engine.extended_kalman_filter`, the smoother and the particle filters unchanged. The blocks
reproduce the library's hand-assembled models to the last bit where they describe the same state
(``tests/test_blocks.py``): :class:`~uwtutor.models.odometry.OdometryMotion` with a gyro bias and a range scale,
:class:`~uwtutor.models.bias.BiasRateDeadReckoning`, :class:`~uwtutor.models.range.BeaconRanges`,
:class:`~uwtutor.models.dead_reckoning.DeadReckoning` and :class:`~uwtutor.models.range.RangeToBeacon` (paper A's
pair, its slots named or given by index).

References
----------
Bar-Shalom Y., Li X. R., Kirubarajan T. (2001). *Estimation with Applications to Tracking and Navigation*, Wiley,
sec. 6.3 (the discretized white-noise acceleration block of :class:`OffsetAndRate`).
Farrell, J. A. (2008). *Aided Navigation: GPS with High Rate Sensors*. McGraw-Hill. Sec. 4.9 (state augmentation
with sensor biases, scale factors and a clock's offset and rate).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from .._validate import as_choice, as_covariance, as_finite, as_instance, as_int, as_nonnegative
from .base import MeasurementModel, MotionModel
from .noise import per_run_generators, psd_sqrt, standard_normal_per_run

if TYPE_CHECKING:                   # the index form of a state; odometry imports this module
    from .odometry import StateLayout

__all__ = ["StateBlock", "OdometryPose", "Position", "RandomWalk", "Current", "OffsetAndRate", "BlockMotion",
           "BlockMeasurement"]

#: Largest standard deviation accepted: its square (a variance) stays within the covariances' bound, 1e150.
_MAX_STD = 1e75
#: Longest step accepted [s]: a rate's noise q dt^3 / 3 stays finite (the posterior bound checks its times by it too).
MAX_STEP = 1e50


#: The orders of operations :class:`OdometryPose` (and :class:`~uwtutor.models.odometry.OdometryMotion`) knows,
#: with the fraction :math:`c` of the step's turn taken before the move.
ORDERS = {"turn-first": 1.0, "move-first": 0.0, "midpoint": 0.5}


def _wrap(a: np.ndarray) -> np.ndarray:
    """:func:`wrap_angle` without its checks: the models' per-step kernel (their states are float arrays)."""
    return (a + np.pi) % (2.0 * np.pi) - np.pi


def _odometry_input(u: Any) -> tuple[np.ndarray, np.ndarray]:
    """The distance and heading change of one step's odometry ``u`` (last axis [distance, heading change]), checked
    (shared by :class:`OdometryMotion` and the odometry pose block of :mod:`uwtutor.models.blocks`)."""
    if u is None:
        raise ValueError("u must be the odometry of the step, [distance, heading change] (m, rad); got None. "
                         "Pass the odometry as the filter's u")
    u = np.asarray(u, dtype=float)
    if u.shape[-1:] != (2,):
        raise ValueError(f"u must be the odometry [distance, heading change] of the step (last axis of length "
                         f"2); got shape {u.shape}")
    return u[..., 0], u[..., 1]


def _per_step(name: str, value: Any) -> np.ndarray:
    """A number or one value per step (K,), >= 0."""
    arr = as_nonnegative(name, value, ndim=(0, 1), max_abs=_MAX_STD)
    if arr.ndim == 1 and arr.size == 0:
        raise ValueError(f"{name} is empty: give a number or one value per step")
    return arr


def _durations(times: Any, dt: Any) -> tuple[np.ndarray | None, int | None]:
    """Step lengths Delta t_k (K,) or a scalar array, and the number of steps they fix (None if any)."""
    if times is not None and dt is not None:
        raise ValueError("give times or dt, not both")
    if dt is not None:
        d = as_nonnegative("dt", dt, ndim=(0, 1))
        return d, (len(d) if d.ndim == 1 else None)
    if times is None:
        return None, None
    t = as_finite("times", times, ndim=1, nonempty=True)
    steps = np.diff(t)
    if np.any(steps < 0):
        k = int(np.flatnonzero(steps < 0)[0]) + 1
        raise ValueError(f"times must not decrease; times[{k}] = {t[k]:g} comes before times[{k - 1}] = {t[k - 1]:g}")
    # x0 is the state at times[0], so the first step lasts 0 s (a dataset's start pose, its odometry row 0 the
    # motion up to times[0]); give dt instead to let the first step last longer.
    return np.concatenate([[0.0], steps]), len(t)


def _displacement(u: Any) -> np.ndarray:
    """A step's DR displacement ``u`` (last axis [dx, dy]), checked: a (.., 1) one would broadcast onto both axes."""
    u = np.asarray(u, dtype=float)
    if u.shape[-1:] != (2,):
        raise ValueError(f"u must be the DR displacement [dx, dy] of the step (last axis of length 2); got shape "
                         f"{u.shape}")
    return u


def _name(value: Any, what: str = "name") -> str:
    if not isinstance(value, str) or not value.isidentifier():
        raise ValueError(f"{what} must be a slot name (a Python identifier such as 'clock'); got {value!r}")
    return value


class StateBlock:
    r"""One named piece of the state: its components, its motion, its process noise.

    A block of your own sets ``name``, ``components`` (one label per component), optionally ``fields`` (named
    parts, ``{name: local indices}``), ``reads`` (the slots of other blocks its motion reads) and ``noise_size``
    (the number of standard normal draws :meth:`sample` takes), and implements :meth:`linearize`. The default
    :meth:`sample` draws :math:`f + L\varepsilon`, :math:`L L^\mathsf{T} = Q` (Cholesky, or the
    eigendecomposition when :math:`Q` is singular).

    Examples
    --------
    A depth that sinks at a known rate of 0.1 m/s, with a random walk:

    >>> import numpy as np
    >>> from uwtutor.models import BlockMotion, StateBlock
    >>> class Sinking(StateBlock):
    ...     name, components, noise_size = "depth", ("z",), 1
    ...     def linearize(self, own, reads, u, k, dt):
    ...         F = np.ones(own.shape[:-1] + (1, 1))
    ...         return own + 0.1 * dt, F, {}, np.array([[0.01 * dt]])
    >>> BlockMotion(Sinking(), dt=2.0).f(np.array([[5.0]]), None, 0)
    array([[5.2]])
    """

    name: str = ""
    components: tuple[str, ...] = ()
    fields: dict[str, tuple[int, ...]] = {}
    reads: tuple[str, ...] = ()
    #: local indices of the components that are angles (wrapped to [-pi, pi))
    angles: tuple[int, ...] = ()
    noise_size: int = 0
    #: Whether the block needs real step lengths, as a rate in its state does; BlockMotion then needs times or dt
    needs_time: bool = False
    #: Whether f is linear, F x (+ the displacement u when ``moved_by_input``), with F and Q that depend on the
    #: step length alone: BlockMotion then assembles F and Q once when every step has the same length
    linear: bool = False
    moved_by_input: bool = False

    @property
    def size(self) -> int:
        """Number of components."""
        return len(self.components)

    def linearize(self, own: np.ndarray, reads: dict[str, np.ndarray], u: Any, k: int,
                  dt: float) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray], np.ndarray]:
        r"""The block's prediction and its derivatives in one step.

        Parameters
        ----------
        own : ndarray, shape (..., s)
            The block's own components.
        reads : dict of str to ndarray
            The components of each slot named in ``reads``, ``(..., r)``.
        u : array_like or None
            The input of step ``k`` (every block gets the same one; a block that takes none ignores it).
        k : int
            The index of the step.
        dt : float
            The length of the step [s] (1 when the motion has no times).

        Returns
        -------
        f : ndarray, shape (..., s)
        F : ndarray, shape (..., s, s) or (s, s)
            :math:`\partial f / \partial x^{\text{own}}`.
        F_reads : dict of str to ndarray, shape (..., s, r) or (s, r)
            :math:`\partial f / \partial x^{\text{slot}}` for each slot read.
        Q : ndarray, shape (..., s, s) or (s, s)
        """
        raise NotImplementedError

    def sample(self, own: np.ndarray, reads: dict[str, np.ndarray], u: Any, k: int, dt: float,
               eps: np.ndarray) -> np.ndarray:
        r"""Draw the block's next components from ``noise_size`` standard normal draws ``eps`` ``(..., q)``."""
        f, _, _, Q = self.linearize(own, reads, u, k, dt)
        L = psd_sqrt(np.asarray(Q, dtype=float))
        return f + np.einsum("...ij,...j->...i", L, eps)

    def step_counts(self) -> dict[str, int]:
        """The number of steps each of the block's per-step arguments covers, by argument name (none by default)."""
        return {}

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r}: {', '.join(self.components)})"


class RandomWalk(StateBlock):
    r"""Components that stay constant up to a random walk: a range bias, a range scale, a gyro bias.

    .. math::

        x_k = x_{k-1} + w_k, \qquad w_k \sim N(0,\; q\,\Delta t_k\,I), \qquad q = \texttt{walk}^2,

    or :math:`w_k \sim N(0, Q_k)` with the covariance of each step given directly (``Q``: components whose walks
    are correlated, or change from step to step, as the further components of
    :class:`~uwtutor.models.dead_reckoning.DeadReckoning`).

    Parameters
    ----------
    name : str
        The slot name (``"scale"``, ``"gyro_bias"``, ``"range_bias"``).
    walk : float, default 0
        :math:`\sqrt q`: the standard deviation the components wander by in one second (per step when the motion
        has no times); 0 for a constant.
    size : int, default 1
        Number of components (e.g. one range bias per beacon).
    Q : array_like, shape (size, size) or (K, size, size), optional
        The covariance of one step's walk [unit²], positive semi-definite, instead of ``walk``: one for every step,
        or one per step (step ``k`` uses ``Q[k]``).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.models import BlockMotion, RandomWalk
    >>> motion = BlockMotion(RandomWalk("scale", walk=1e-3), dt=4.0)
    >>> motion.f(np.array([[1.02]]), None, 0), motion.Q(np.array([[1.02]]), None, 0)
    (array([[1.02]]), array([[4.e-06]]))
    >>> # two range biases whose walks are correlated, the covariance of a step given whole
    >>> biases = BlockMotion(RandomWalk("range_bias", size=2, Q=[[0.02, 0.01], [0.01, 0.02]]))
    >>> biases.Q(np.zeros((1, 2)), None, 0)
    array([[0.02, 0.01],
           [0.01, 0.02]])
    """

    linear = True

    def __init__(self, name: str, walk: ArrayLike = 0.0, *, size: int = 1, Q: ArrayLike | None = None) -> None:
        self.name = _name(name)
        size = as_int("size", size, minimum=1)
        self.components = (self.name,) if size == 1 else tuple(f"{self.name}_{j}" for j in range(size))
        self.q = float(as_nonnegative("walk", walk, ndim=0, max_abs=_MAX_STD)) ** 2
        self._eye = np.eye(size)
        self.cov: np.ndarray | None = None
        if Q is not None:
            if self.q > 0:
                raise ValueError("give walk (a density per second) or Q (the covariance of each step), not both")
            cov = as_covariance("Q", Q, size, allow_singular=True)
            if cov.ndim not in (2, 3):
                raise ValueError(f"Q must be one ({size}, {size}) covariance or one per step ({size} components); "
                                 f"got shape {cov.shape}")
            self.cov = cov
            self.linear = cov.ndim == 2              # a per-step Q is not a constant of the step length
        given = self.cov is not None and bool(np.any(self.cov))
        self.noise_size = size if self.q > 0 or given else 0      # a constant draws nothing

    def linearize(self, own: np.ndarray, reads: dict[str, np.ndarray], u: Any, k: int,
                  dt: float) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray], np.ndarray]:
        noise = self._eye * (self.q * dt) if self.cov is None else _step_of("Q", self.cov, k)
        return np.array(own, dtype=float), self._eye, {}, noise

    def sample(self, own: np.ndarray, reads: dict[str, np.ndarray], u: Any, k: int, dt: float,
               eps: np.ndarray) -> np.ndarray:
        if not self.noise_size:
            return np.array(own, dtype=float)
        if self.cov is not None:
            return super().sample(own, reads, u, k, dt, eps)
        return own + eps * (np.sqrt(self.q) * np.sqrt(dt))

    def step_counts(self) -> dict[str, int]:
        """The number of steps a per-step ``Q`` covers (none for one ``Q`` or a ``walk``)."""
        return {"Q": len(self.cov)} if self.cov is not None and self.cov.ndim == 3 else {}


class Current(RandomWalk):
    r"""A horizontal water current :math:`[c_x, c_y]` [m/s], constant up to a random walk; a :class:`Position`
    built with ``current="current"`` drifts with it.

    Examples
    --------
    >>> from uwtutor.models import Current
    >>> Current(walk=0.001).components
    ('current_x', 'current_y')
    """

    def __init__(self, walk: ArrayLike = 0.0, *, name: str = "current") -> None:
        super().__init__(name, walk, size=2)
        self.components = (f"{self.name}_x", f"{self.name}_y")


class OffsetAndRate(StateBlock):
    r"""An offset and its rate: a clock (offset [s], drift [s/s]) or a bias that opens steadily (m, m/s).

    .. math::

        \begin{bmatrix} \delta_k \\ \dot\delta_k \end{bmatrix} =
        \begin{bmatrix} 1 & \Delta t_k \\ 0 & 1 \end{bmatrix}
        \begin{bmatrix} \delta_{k-1} \\ \dot\delta_{k-1} \end{bmatrix} + w_k, \qquad
        Q_k = q_r \begin{bmatrix} \Delta t_k^3/3 & \Delta t_k^2/2 \\ \Delta t_k^2/2 & \Delta t_k \end{bmatrix}
        + q_o \begin{bmatrix} \Delta t_k & 0 \\ 0 & 0 \end{bmatrix}

    (the rate a random walk of density :math:`q_r`, integrated into the offset: Bar-Shalom et al. 2001, sec. 6.3;
    :math:`q_o` a random walk of the offset itself, a clock's white frequency noise).

    Parameters
    ----------
    name : str
        The slot name (``"clock"``, ``"range_bias"``).
    rate_walk : float
        :math:`\sqrt{q_r}`: how fast the rate wanders (per √s).
    offset_walk : float, default 0
        :math:`\sqrt{q_o}`: how fast the offset wanders on its own (per √s).

    Examples
    --------
    A clock 1 ms fast that gains 20 µs every second, after 10 s:

    >>> import numpy as np
    >>> from uwtutor.models import BlockMotion, OffsetAndRate
    >>> clock = BlockMotion(OffsetAndRate("clock", rate_walk=1e-8), dt=10.0)
    >>> clock.slot("clock_offset"), clock.f(np.array([[1e-3, 20e-6]]), None, 0)
    (array([0]), array([[1.2e-03, 2.0e-05]]))
    """

    noise_size = 2
    needs_time = True
    linear = True

    def __init__(self, name: str, rate_walk: ArrayLike, *, offset_walk: ArrayLike = 0.0) -> None:
        self.name = _name(name)
        self.components = (f"{self.name}_offset", f"{self.name}_rate")
        self.fields = {self.components[0]: (0,), self.components[1]: (1,)}
        self.q_rate = float(as_nonnegative("rate_walk", rate_walk, ndim=0, max_abs=_MAX_STD)) ** 2
        self.q_offset = float(as_nonnegative("offset_walk", offset_walk, ndim=0, max_abs=_MAX_STD)) ** 2

    def linearize(self, own: np.ndarray, reads: dict[str, np.ndarray], u: Any, k: int,
                  dt: float) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray], np.ndarray]:
        F = np.array([[1.0, dt], [0.0, 1.0]])
        Q = self.q_rate * np.array([[dt**3 / 3.0, dt**2 / 2.0], [dt**2 / 2.0, dt]])
        Q[0, 0] += self.q_offset * dt
        return own @ F.T, F, {}, Q


class Position(StateBlock):
    r"""A horizontal position moved by a dead-reckoned displacement :math:`u_k = [\Delta x_k, \Delta y_k]`, and
    carried by a current when it reads one.

    .. math::

        p_k = p_{k-1} + u_k \;(+\, \Delta t_k\, c_{k-1}) + w_k, \qquad w_k \sim N(0, Q).

    Parameters
    ----------
    Q : array_like, shape (2, 2) or (K, 2, 2)
        The DR noise of one step [m²] (as :class:`~uwtutor.models.dead_reckoning.DeadReckoning`'s): one for every
        step, or one per step (step ``k`` uses ``Q[k]``).
    current : str, optional
        The slot of a :class:`Current` the position drifts with.
    name : str, default "position"

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.models import BlockMotion, Current, Position
    >>> motion = BlockMotion(
    ...     Position(np.eye(2) * 0.25, current="current"), Current(), dt=10.0
    ... )
    >>> motion.names
    ('x', 'y', 'current_x', 'current_y')
    >>> motion.f(np.array([[0.0, 0.0, 0.1, 0.0]]), np.array([2.0, 1.0]), 0)
    array([[3. , 1. , 0.1, 0. ]])
    """

    noise_size = 2
    components = ("x", "y")
    linear = moved_by_input = True

    def __init__(self, Q: ArrayLike, *, current: str | None = None, name: str = "position") -> None:
        self.name = _name(name)
        self.Q = as_covariance("Q", Q, 2, allow_singular=True)
        if self.Q.ndim not in (2, 3):
            raise ValueError(f"Q must be one 2x2 matrix (the DR noise of every step) or one per step (K, 2, 2); got "
                             f"shape {self.Q.shape}")
        self.linear = self.Q.ndim == 2               # a per-step Q is not a constant of the step length
        self.reads = () if current is None else (_name(current, "current"),)
        self.needs_time = current is not None
        self._eye = np.eye(2)

    def linearize(self, own: np.ndarray, reads: dict[str, np.ndarray], u: Any, k: int,
                  dt: float) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray], np.ndarray]:
        f = np.array(own, dtype=float)
        if u is not None:
            f = f + _displacement(u)
        F_reads = {}
        if self.reads:
            f = f + dt * reads[self.reads[0]]
            F_reads[self.reads[0]] = self._eye * dt
        return f, self._eye, F_reads, _step_of("Q", self.Q, k)

    def step_counts(self) -> dict[str, int]:
        """The number of steps a per-step ``Q`` covers (none for one ``Q``)."""
        return {"Q": len(self.Q)} if self.Q.ndim == 3 else {}


class OdometryPose(StateBlock):
    r"""A pose :math:`[x, y, \theta]` moved by body-frame odometry :math:`u_k = [d_k, \Delta\theta_k]`, turned by
    the gyro bias it reads, if any.

    The kinematics and the noise are :class:`~uwtutor.models.odometry.OdometryMotion`'s (see there):
    :math:`\delta_k = \Delta\theta_k - b_{g}\Delta t_k`, :math:`\alpha_k = \theta_{k-1} + c\,\delta_k`,
    :math:`p_k = p_{k-1} + d_k[\cos\alpha_k, \sin\alpha_k]`, :math:`\theta_k = \theta_{k-1} + \delta_k`, and
    :math:`Q_k = G_k \operatorname{diag}(\sigma_{d,k}^2, \sigma_{\theta,k}^2) G_k^\mathsf{T}` with :math:`G_k =
    \partial f / \partial u`; the gyro bias's own random walk is its block's (:class:`RandomWalk`).

    Parameters
    ----------
    sigma_distance, sigma_heading : float or array_like, shape (K,)
        The odometry's noise per step [m], [rad].
    order : {"turn-first", "move-first", "midpoint"}, default "turn-first"
    gyro_bias : str, optional
        The slot of the gyro bias [rad/s] that turns the heading (then the motion needs times or dt).
    name : str, default "pose"
        The block's name; its parts are the slots ``position`` (x, y) and ``heading``.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.models import BlockMotion, OdometryPose, RandomWalk
    >>> motion = BlockMotion(
    ...     OdometryPose(0.1, 0.01, gyro_bias="gyro_bias"),
    ...     RandomWalk("gyro_bias", 1e-5),
    ...     dt=2.0,
    ... )
    >>> motion.slot("position"), motion.slot("gyro_bias")
    (array([0, 1]), array([3]))
    >>> # a measured turn of 0.02 rad that is all bias (0.01 rad/s over 2 s)
    >>> motion.f(np.array([[0.0, 0.0, 0.0, 0.01]]), np.array([5.0, 0.02]), 0)
    array([[5.  , 0.  , 0.  , 0.01]])
    """

    components = ("x", "y", "heading")
    fields = {"position": (0, 1), "heading": (2,)}
    angles = (2,)
    noise_size = 2

    def __init__(self, sigma_distance: ArrayLike, sigma_heading: ArrayLike, *, order: str = "turn-first",
                 gyro_bias: str | None = None, name: str = "pose") -> None:
        self.name = _name(name)
        self.order = as_choice("order", order, ORDERS)
        self._c = ORDERS[order]
        self.sigma_distance = _per_step("sigma_distance", sigma_distance)
        self.sigma_heading = _per_step("sigma_heading", sigma_heading)
        self.reads = () if gyro_bias is None else (_name(gyro_bias, "gyro_bias"),)
        self.needs_time = gyro_bias is not None

    # The arithmetic of the pose, written once. ``x`` is any state whose first three components are this pose
    # (the block's own components, or a whole state that starts with the pose, as OdometryMotion's does): the
    # fused path of OdometryMotion and the block-by-block path of BlockMotion call the same lines.
    def _step(self, x: np.ndarray, bias: Any, u: Any, dt: float) -> tuple[Any, Any, np.ndarray, np.ndarray]:
        """Distance d_k, turn delta_k, and cos, sin of the move heading alpha_k (``bias`` the gyro bias or None)."""
        d, turn = _odometry_input(u)
        if bias is not None:
            turn = turn - bias * dt
        alpha = x[..., 2] + self._c * turn if self._c else x[..., 2]
        return d, turn, np.cos(alpha), np.sin(alpha)

    @staticmethod
    def _moved(x: np.ndarray, d: Any, turn: Any, ca: np.ndarray, sa: np.ndarray) -> np.ndarray:
        """``x`` with the pose moved by the step (the other components copied)."""
        f = np.array(x, dtype=float)
        f[..., 0] += d * ca
        f[..., 1] += d * sa
        f[..., 2] = _wrap(x[..., 2] + turn)
        return f

    def _jacobian(self, x: np.ndarray, eye: np.ndarray, bias: int | None, d: Any, ca: np.ndarray, sa: np.ndarray,
                  dt: float) -> np.ndarray:
        """:math:`F` ``(..., n, n)``, ``n = len(eye)``: the identity plus the pose's rows (``bias`` the column of
        the gyro bias, or None)."""
        F = np.repeat(eye[None], x.shape[0], axis=0) if x.ndim == 2 else np.tile(eye, x.shape[:-1] + (1, 1))
        ds, dc = d * sa, d * ca
        F[..., 0, 2] = -ds
        F[..., 1, 2] = dc
        if bias is not None:
            F[..., 0, bias] = self._c * dt * ds
            F[..., 1, bias] = -self._c * dt * dc
            F[..., 2, bias] = -dt
        return F

    def _input_jacobian(self, x: np.ndarray, n: int, d: Any, ca: np.ndarray, sa: np.ndarray) -> np.ndarray:
        r""":math:`G = \partial f / \partial u` ``(..., n, 2)`` (zero below the pose)."""
        G = np.zeros(x.shape[:-1] + (n, 2))
        G[..., 0, 0], G[..., 1, 0] = ca, sa
        G[..., 0, 1], G[..., 1, 1] = -self._c * d * sa, self._c * d * ca
        G[..., 2, 1] = 1.0
        return G

    def _noise(self, G: np.ndarray, k: int) -> np.ndarray:
        r""":math:`G \Sigma_u G^\mathsf{T}`, the odometry noise of step ``k`` through ``G``."""
        var = np.array([_at(self.sigma_distance, k) ** 2, _at(self.sigma_heading, k) ** 2])
        return (G * var) @ np.swapaxes(G, -1, -2)

    def _noisy(self, u: Any, k: int, eps: np.ndarray) -> np.ndarray:
        """Each particle's own noisy reading of the odometry: ``u`` plus the noise of step ``k`` times ``eps``."""
        d, dth = _odometry_input(u)
        noisy = np.empty(eps.shape[:-1] + (2,))
        np.multiply(eps[..., 0], _at(self.sigma_distance, k), out=noisy[..., 0])
        np.multiply(eps[..., 1], _at(self.sigma_heading, k), out=noisy[..., 1])
        noisy[..., 0] += d                             # (p,) shared, or (M, 1, p) per run: broadcast
        noisy[..., 1] += dth
        return noisy

    def linearize(self, own: np.ndarray, reads: dict[str, np.ndarray], u: Any, k: int,
                  dt: float) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray], np.ndarray]:
        bias = reads[self.reads[0]] if self.reads else None
        x = own if bias is None else np.concatenate([own, bias], axis=-1)      # [x, y, theta (, b_g)]
        d, turn, ca, sa = self._step(x, None if bias is None else bias[..., 0], u, dt)
        F = self._jacobian(x, np.eye(x.shape[-1]), None if bias is None else 3, d, ca, sa, dt)
        F_reads = {} if bias is None else {self.reads[0]: F[..., :3, 3:]}
        Q = self._noise(self._input_jacobian(x, 3, d, ca, sa), k)
        return self._moved(own, d, turn, ca, sa), F[..., :3, :3], F_reads, Q

    def sample(self, own: np.ndarray, reads: dict[str, np.ndarray], u: Any, k: int, dt: float,
               eps: np.ndarray) -> np.ndarray:
        """Each particle moves by its own noisy reading of the odometry through the exact kinematics (the
        sample odometry motion model, Thrun et al. 2005, sec. 5.4)."""
        bias = reads[self.reads[0]][..., 0] if self.reads else None
        return self._moved(own, *self._step(own, bias, self._noisy(u, k, eps), dt))

    def step_counts(self) -> dict[str, int]:
        """The number of steps each per-step noise covers, by argument name (none when both are one number)."""
        return {name: len(a) for name, a in (("sigma_distance", self.sigma_distance),
                                             ("sigma_heading", self.sigma_heading)) if a.ndim == 1}


def _step_of(name: str, a: np.ndarray, k: int) -> np.ndarray:
    """Step ``k``'s matrix of ``a``: one ``(s, s)`` for every step, or ``(K, s, s)`` one per step."""
    if a.ndim == 2:
        return a
    if not 0 <= k < len(a):
        raise IndexError(f"{name} has {len(a)} per-step matrices; step {k} is beyond them. Give one per step of the "
                         "run")
    return a[k]


def _at(a: np.ndarray, k: int) -> float:
    if a.ndim == 0:
        return float(a)
    if not 0 <= k < len(a):
        raise IndexError(f"step {k} is beyond the {len(a)} steps of the per-step noise")
    return float(a[k])


class BlockMotion(MotionModel):
    r"""A motion model assembled from state blocks: :math:`f`, :math:`F`, :math:`Q` and ``sample`` block by block.

    The state is the blocks' components in the order given (module docstring for the equations). Each block is
    reachable by its slots: :meth:`slot` gives the indices of a block (by its name) or of a named part of one
    (``position``, ``heading``, ``clock_offset``).

    Parameters
    ----------
    *blocks : StateBlock
        The blocks, in the order of the state; names and named parts must be unique, and every slot a block reads
        must be one of them.
    times : array_like, shape (K,), optional
        Epoch times [s]: step ``k`` lasts ``times[k] - times[k - 1]`` (the first step 0 s), as
        :class:`~uwtutor.models.odometry.OdometryMotion`.
    dt : float or array_like, shape (K,), optional
        The step lengths [s] directly, instead of ``times``. Without either, every step lasts 1 (a random walk's
        density is then per step), which a block with a rate refuses.

    Attributes
    ----------
    n : int
    names : tuple of str
        The label of each component.
    blocks : tuple of StateBlock

    Examples
    --------
    Dead reckoning with a range bias that opens steadily -- the state of
    :class:`~uwtutor.models.bias.BiasRateDeadReckoning`, from two blocks:

    >>> import numpy as np
    >>> from uwtutor.models import BlockMotion, OffsetAndRate, Position
    >>> motion = BlockMotion(
    ...     Position(np.eye(2) * 0.25), OffsetAndRate("bias", rate_walk=0.01), dt=5.0
    ... )
    >>> motion.names
    ('x', 'y', 'bias_offset', 'bias_rate')
    >>> motion.f(np.array([[0.0, 0.0, 5.0, 0.1]]), np.array([1.0, 2.0]), 0)
    array([[1. , 2. , 5.5, 0.1]])
    >>> x0, P0 = motion.initial_state(
    ...     position=([0.0, 0.0], [1.0, 1.0]), bias=([0.0, 0.0], [2.0, 0.1])
    ... )
    >>> x0, np.diag(P0)
    (array([0., 0., 0., 0.]), array([1.  , 1.  , 4.  , 0.01]))
    """

    covariances_checked = True      # every block's Q is assembled from variances checked when it was made

    def __init__(self, *blocks: StateBlock, times: ArrayLike | None = None, dt: ArrayLike | None = None) -> None:
        if not blocks:
            raise ValueError("BlockMotion needs at least one block (e.g. Position(Q) or OdometryPose(...))")
        for i, block in enumerate(blocks):
            as_instance(f"blocks[{i}]", block, StateBlock, "e.g. Position, OdometryPose, RandomWalk, OffsetAndRate")
        self.blocks = tuple(blocks)
        self._slots: dict[str, np.ndarray] = {}
        self._own: list[np.ndarray] = []
        start = 0
        for block in self.blocks:
            own = np.arange(start, start + block.size)
            named = {block.name: own, **{part: own[list(local)] for part, local in block.fields.items()}}
            for slot, idx in named.items():
                if slot in self._slots:
                    raise ValueError(f"two blocks are both called {slot!r}: give each block and part its own name "
                                     "(name=...)")
                self._slots[slot] = idx
            self._own.append(own)
            start += block.size
        self.n = start
        for block in self.blocks:
            for slot in block.reads:
                if slot not in self._slots:
                    raise ValueError(f"block {block.name!r} reads the slot {slot!r}, which no block provides; the "
                                     f"slots are {sorted(self._slots)}")
        self.names = tuple(c for block in self.blocks for c in block.components)
        self._dt, steps = _durations(times, dt)
        if self._dt is not None and np.any(self._dt > MAX_STEP):
            raise ValueError(f"{'dt' if dt is not None else 'times'} gives a step longer than {MAX_STEP:g} s (a "
                             f"rate's noise grows as dt^3): give the step lengths in seconds")
        untimed = [b.name for b in self.blocks if b.needs_time]
        if self._dt is None and untimed:
            raise ValueError(f"the blocks {untimed} hold a rate: give times (the epoch times, s) or dt (the step "
                             "lengths, s)")
        counted = [(name, block.name, count) for block in self.blocks for name, count in block.step_counts().items()]
        # an argument name that two blocks take (each Position or RandomWalk its Q) is told by its block
        shared = {name for name, _, _ in counted if sum(other == name for other, _, _ in counted) > 1}
        sizes = {(f"{owner}'s {name}" if name in shared else name): count for name, owner, count in counted}
        if steps is not None:
            sizes["times" if times is not None else "dt"] = steps
        if len(set(sizes.values())) > 1:
            described = ", ".join(f"{name} has {count}" for name, count in sizes.items())
            raise ValueError(f"the per-step arguments disagree on the number of steps K: {described}")
        self.n_steps: int | None = next(iter(sizes.values()), None)
        self._per_step = ", ".join(sizes)
        angles = [int(own[i]) for block, own in zip(self.blocks, self._own) for i in block.angles]
        # one angle (a heading) indexed by its int: a view, not a copy
        self._angles: Any = angles[0] if len(angles) == 1 else np.array(angles, int) if angles else None
        self._noise = np.cumsum([0] + [block.noise_size for block in self.blocks])
        # Linear blocks over steps of one length (a position, random walks, offsets and rates): F and Q are
        # constants, assembled once, and f is the one product F x plus the displacement
        self._constant: tuple[np.ndarray, np.ndarray] | None = None
        if all(block.linear for block in self.blocks) and (self._dt is None or self._dt.ndim == 0):
            _, F, Q = self._assemble(np.zeros((1, self.n)), None, 0)
            self._constant = (F, Q)
        self._moved = [slice(int(own[0]), int(own[0]) + 2) for block, own in zip(self.blocks, self._own)
                       if block.moved_by_input]

    def slot(self, name: str) -> np.ndarray:
        """The indices of a slot: a block's name or the name of one of its parts.

        Examples
        --------
        >>> import numpy as np
        >>> from uwtutor.models import BlockMotion, Position, RandomWalk
        >>> BlockMotion(Position(np.eye(2)), RandomWalk("scale")).slot("scale")
        array([2])
        """
        if name not in self._slots:
            raise KeyError(f"no slot {name!r} in this state; its slots are {sorted(self._slots)}")
        return self._slots[name]

    @property
    def slots(self) -> tuple[str, ...]:
        """Every slot name of the state."""
        return tuple(self._slots)

    def _checked_step(self, k: int) -> int:
        if self.n_steps is not None and not 0 <= k < self.n_steps:
            raise IndexError(f"step {k} is beyond the {self.n_steps} steps this model's per-step arguments cover "
                             f"({self._per_step})")
        return k

    def dt(self, k: int) -> float:
        """The length :math:`\\Delta t_k` of step ``k`` [s] (1 when the motion has no times)."""
        if self._dt is None:
            return 1.0
        return float(self._dt if self._dt.ndim == 0 else self._dt[self._checked_step(k)])

    def _reads(self, block: StateBlock, x: np.ndarray) -> dict[str, np.ndarray]:
        return {slot: x[..., self._slots[slot]] for slot in block.reads}

    def linearize(self, x: np.ndarray, u: Any, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if self._constant is None:
            return self._assemble(x, u, k)
        F, Q = self._constant
        f = np.asarray(x, dtype=float) @ F.T
        if u is not None and self._moved:
            u = _displacement(u)
            for moved in self._moved:
                f[..., moved] += u
        return f, F, Q

    def _assemble(self, x: np.ndarray, u: Any, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """f, F and Q block by block."""
        x = np.asarray(x, dtype=float)
        dt = self.dt(k)
        f = np.empty_like(x)
        parts = [block.linearize(x[..., own], self._reads(block, x), u, k, dt)
                 for block, own in zip(self.blocks, self._own)]
        # one shared (n, n) F and Q when every block gives a shared one; (..., n, n) otherwise
        shared = all(np.ndim(Fb) == 2 and np.ndim(Qb) == 2 and all(np.ndim(J) == 2 for J in Fr.values())
                     for _, Fb, Fr, Qb in parts)
        lead = () if shared else x.shape[:-1]
        F = np.zeros(lead + (self.n, self.n))
        Q = np.zeros(lead + (self.n, self.n))
        for (fb, Fb, F_reads, Qb), own in zip(parts, self._own):
            sl = slice(own[0], own[-1] + 1)
            f[..., sl] = fb
            F[..., sl, sl] = Fb
            Q[..., sl, sl] = Qb
            for slot, J in F_reads.items():
                F[..., sl, self._slots[slot]] = J
        return f, F, Q

    def f(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        return self.linearize(x, u, k)[0]

    def F(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        return self._constant[0] if self._constant is not None else self._assemble(x, u, k)[1]

    def Q(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        return self._constant[1] if self._constant is not None else self._assemble(x, u, k)[2]

    def sample(self, x: np.ndarray, u: Any, k: int, rng: Any) -> np.ndarray:
        r"""Draw the next states block by block: each block takes its ``noise_size`` standard normal draws, in the
        order of the blocks, from run ``m``'s stream ``rng[m]`` (one Generator per run)."""
        x = np.asarray(x, dtype=float)
        eps = standard_normal_per_run(per_run_generators(rng, x.shape[0], spawn=False),
                                      x.shape[1:-1] + (int(self._noise[-1]),))
        dt = self.dt(k)
        out = np.empty_like(x)
        for j, (block, own) in enumerate(zip(self.blocks, self._own)):
            out[..., own] = block.sample(x[..., own], self._reads(block, x), u, k, dt,
                                         eps[..., self._noise[j]:self._noise[j + 1]])
        return out

    def difference(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        d = np.asarray(a, dtype=float) - np.asarray(b, dtype=float)
        if self._angles is not None:
            d[..., self._angles] = _wrap(d[..., self._angles])
        return d

    def normalize(self, x: np.ndarray) -> np.ndarray:
        out = np.array(x, dtype=float)
        if self._angles is not None:
            out[..., self._angles] = _wrap(out[..., self._angles])
        return out

    def initial_state(self, **slots: Any) -> tuple[np.ndarray, np.ndarray]:
        r"""The initial state and a diagonal covariance from ``slot=(mean, std)`` for every component.

        Parameters
        ----------
        **slots : (array_like, array_like)
            For each slot, its mean and standard deviation (numbers, or one per component of the slot); together
            the slots must cover every component once.

        Returns
        -------
        x0 : ndarray, shape (n,)
        P0 : ndarray, shape (n, n)

        Examples
        --------
        >>> import numpy as np
        >>> from uwtutor.models import BlockMotion, OdometryPose, RandomWalk
        >>> motion = BlockMotion(OdometryPose(0.1, 0.01), RandomWalk("scale"))
        >>> x0, P0 = motion.initial_state(
        ...     pose=([0.0, 0.0, 0.5], [1.0, 1.0, 0.1]), scale=(1.0, 0.05)
        ... )
        >>> x0, np.sqrt(np.diag(P0))
        (array([0. , 0. , 0.5, 1. ]), array([1.  , 1.  , 0.1 , 0.05]))
        """
        x0 = np.zeros(self.n)
        std = np.zeros(self.n)
        given = np.zeros(self.n, dtype=int)
        for name, pair in slots.items():
            idx = self.slot(name)
            if not isinstance(pair, (tuple, list)) or len(pair) != 2:
                raise ValueError(f"{name} must be a pair (mean, std); got {pair!r}")
            mean = as_finite(f"{name} mean", pair[0], ndim=(0, 1))
            sd = as_nonnegative(f"{name} std", pair[1], ndim=(0, 1), max_abs=_MAX_STD)
            for what, arr in (("mean", mean), ("std", sd)):
                if arr.ndim == 1 and arr.size != idx.size:
                    raise ValueError(f"{name} {what} must be a number or {idx.size} values (one per component of "
                                     f"the slot); got {arr.size}")
            if np.any(sd == 0):
                raise ValueError(f"{name} std must be > 0 (a state the filter may correct); got {sd}")
            x0[idx] = mean
            std[idx] = sd
            given[idx] += 1
        if np.any(given != 1):
            missing = [self.names[i] for i in np.flatnonzero(given == 0)]
            twice = [self.names[i] for i in np.flatnonzero(given > 1)]
            raise ValueError("initial_state needs (mean, std) for every component exactly once: "
                             + (f"missing {missing}" if missing else "") + (f" given twice {twice}" if twice else "")
                             + f"; the slots are {list(self.slots)}")
        return x0, np.diag(std**2)


class BlockMeasurement(MeasurementModel):
    r"""A measurement model that reads the slots it names, wherever they are in the state.

    A subclass lists the slots it needs in ``reads`` (class attribute, or set before calling this ``__init__``)
    and reads them through :meth:`read`; ``columns`` gives the state indices of a slot, for the columns of its
    Jacobian. ``slots`` maps a name the model uses to the name of the slot in the state, for a state whose blocks
    are named otherwise (``slots={"clock": "receiver_clock"}``). A subclass of a model that sets ``reads`` itself
    (:class:`~uwtutor.models.range.BlockRanges`) adds a slot after that model's ``__init__`` with
    :meth:`add_read`.

    A subclass defines ``m`` (the size of one measurement), ``h`` and ``R``, and either ``H`` or ``linearize``
    (the prediction, the Jacobian and where it is defined, in one call; the default computes it from ``h`` and
    ``H``). With ``linearize``, ``h`` must give the same prediction: the particle filters and the model contract
    call it.

    Parameters
    ----------
    state : BlockMotion or StateLayout
        The motion model whose state the measurement reads (its :meth:`BlockMotion.slot` resolves the names), or
        a :class:`~uwtutor.models.odometry.StateLayout` (the slots of a state given by its indices).
    slots : dict of str to str, optional
        Renames: the model's name -> the state's slot name.

    Examples
    --------
    A compass that reads the heading slot:

    >>> import numpy as np
    >>> from uwtutor.models import BlockMeasurement, BlockMotion, OdometryPose, RandomWalk
    >>> class Compass(BlockMeasurement):
    ...     reads, m = ("heading",), 1
    ...     def h(self, x, k):
    ...         return self.read(x, "heading")
    ...     def H(self, x, k):
    ...         H = np.zeros(x.shape[:-1] + (1, self.n))
    ...         H[..., 0, self.columns["heading"]] = 1.0
    ...         return H
    ...     def R(self, x, k):
    ...         return np.array([[0.01]])
    >>> motion = BlockMotion(RandomWalk("scale"), OdometryPose(0.1, 0.01))
    >>> Compass(motion).h(np.array([[1.0, 5.0, 6.0, 0.3]]), 0)
    array([[0.3]])
    """

    reads: tuple[str, ...] = ()

    def __init__(self, state: Any, *, slots: dict[str, str] | None = None) -> None:
        if not isinstance(state, BlockMotion) and not all(hasattr(state, a) for a in ("n", "slots", "slot")):
            raise TypeError(f"state must be the BlockMotion whose slots this model reads (or a StateLayout); got "
                            f"{type(state).__name__}")
        renames = dict(slots or {})
        unknown = set(renames) - set(self.reads)
        if unknown:
            raise ValueError(f"slots renames {sorted(unknown)}, which this model does not read; it reads "
                             f"{list(self.reads)}")
        self.n = state.n
        self.columns: dict[str, np.ndarray] = {}
        for name in self.reads:
            self._find(state, name, renames.get(name, name))

    def add_read(self, state: BlockMotion | StateLayout, name: str, target: str | None = None) -> np.ndarray:
        """Read one more slot: the state's slot ``target`` (default ``name``) becomes ``columns[name]``, and
        ``name`` joins ``reads``. For a subclass whose base class sets ``reads`` in its own ``__init__``.

        Returns
        -------
        ndarray of int
            The slot's indices in the state.

        Examples
        --------
        >>> import numpy as np
        >>> from uwtutor.models import BlockMotion, BlockRanges, OffsetAndRate, Position
        >>> state = BlockMotion(
        ...     Position(np.eye(2)), OffsetAndRate("clock", rate_walk=1e-7), dt=1.0
        ... )
        >>> ranges = BlockRanges([[0.0, 0.0]], 0.25, state)
        >>> ranges.add_read(state, "clock"), ranges.reads
        (array([2, 3]), ('position', 'clock'))
        """
        name = _name(name, "name")
        target = name if target is None else _name(target, "target")
        self._find(state, name, target)
        if name not in self.reads:
            self.reads = tuple(self.reads) + (name,)
        return self.columns[name]

    def _find(self, state: Any, name: str, target: str) -> None:
        """Put the indices of the state's slot ``target`` in ``columns[name]``, or say which slots there are."""
        if target not in state.slots:
            what = f"the slot {name!r}" if target == name else f"its {name} from the slot {target!r}"
            fix = f"map the name with slots={{{name!r}: ...}}" if target == name else "name a slot the state has"
            raise ValueError(f"{type(self).__name__} reads {what}, which the state does not have (its slots are "
                             f"{list(state.slots)}); add the block, or {fix}")
        self.columns[name] = state.slot(target)

    def read(self, x: np.ndarray, name: str) -> np.ndarray:
        """The components of slot ``name`` of the states ``x`` ``(..., n)``: ``(..., size of the slot)``."""
        return x[..., self.columns[name]]

    def H(self, x: np.ndarray, k: int) -> np.ndarray:
        if type(self).linearize is MeasurementModel.linearize:     # neither given: the default would call H again
            raise NotImplementedError(f"{type(self).__name__} must define H(x, k) or linearize(x, k): the "
                                      "measurement's Jacobian")
        return self.linearize(x, k)[1]
