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

import copy
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .._linalg import line_of_sight as _line_of_sight
from .._linalg import distances
from .._validate import MAX_COORDINATE, as_covariance, as_finite, as_float_array, as_int
from .blocks import BlockMeasurement, BlockMotion, _name
from .odometry import StateLayout

__all__ = ["RangeToBeacon", "MultiplicativeRange", "BeaconRanges", "BlockRanges", "NoiseSchedule", "line_of_sight"]


def line_of_sight(positions: np.ndarray, beacon: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""Ranges, unit lines of sight and a "defined" mask from beacon(s) to positions.

    Parameters
    ----------
    positions : ndarray, shape (..., 2)
        Horizontal positions :math:`p` (finite: a missing position has no line of sight).
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
    positions = as_finite("positions", positions, nonempty=True, max_abs=MAX_COORDINATE)
    if positions.ndim < 1 or positions.shape[-1] != 2:
        raise ValueError(f"positions must have shape (..., 2) (x, y); got {positions.shape}")
    beacon = as_finite("beacon", beacon, max_abs=MAX_COORDINATE)
    if beacon.ndim < 1 or beacon.shape[-1] != 2:
        raise ValueError(f"beacon must have shape (2,) or (..., 2); got {beacon.shape}")
    try:
        np.broadcast_shapes(positions.shape, beacon.shape)
    except ValueError:
        raise ValueError(f"beacon {beacon.shape} does not broadcast against positions {positions.shape}") from None
    return _line_of_sight(positions, beacon)


class RangeToBeacon(BlockMeasurement):
    r"""Horizontal range to a fixed or moving beacon, optionally plus a bias state (equations in the module).

    The range reads the state's ``position`` slot and, when it has one, a bias slot: found by name in the motion
    model (``state=motion``, as every :class:`~uwtutor.models.blocks.BlockMeasurement`), or given by indices
    (``n``, ``bias_index``: the position ``x[..., :2]`` and the bias ``x[..., bias_index]``, the
    :class:`~uwtutor.models.odometry.StateLayout` of the state).

    Parameters
    ----------
    beacon : array_like, shape (2,), (K, 2) or (M, K, 2)
        Beacon position: fixed, one per step ``k`` (shared by every run), or one per run and step.
    R : float or array_like, shape (1, 1) or (K,)
        Range noise variance (> 0) [m^2]; or one per step, ``(K,)`` (NaN allowed at steps without a range).
    n : int, optional
        Size of the state (default 2), without ``state``; the position is ``x[..., :2]``.
    bias_index : int, optional
        Index of a state component added to the range (a range bias, paper A), without ``state``; ``None`` for
        none.
    state : BlockMotion or StateLayout, optional
        The motion model whose state the range reads (e.g. ``DeadReckoning(Q, names=("range_bias",))``), instead
        of ``n`` and ``bias_index``: the slots are found by name.
    bias : str, optional
        With ``state``: the slot of the range bias (one component) added to the range.
    position : str, default "position"
        With ``state``: the slot of the horizontal position (two components, x before y).

    Attributes
    ----------
    n : int
        Size of the state.
    bias_index : int or None
        The index of the bias in the state (None without one), however it was given.
    columns : dict
        The indices (an integer array) of each slot read, by name: ``position`` and, with a bias, ``bias``.

    See Also
    --------
    BeaconRanges : ranges to several beacons at once, with a range scale and biases in the state.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.models import DeadReckoning, RangeToBeacon
    >>> # the beacon moves 10 m east between two steps
    >>> ship = np.array([[0.0, 0.0], [10.0, 0.0]])
    >>> model = RangeToBeacon(ship, R=4.0)
    >>> x = np.array([[30.0, 40.0]])
    >>> model.h(x, 0), model.h(x, 1)
    (array([[50.]]), array([[44.72135955]]))
    >>> RangeToBeacon((0.0, 0.0), R=4.0, n=3, bias_index=2).H(
    ...     np.array([[3.0, 4.0, 1.5]]), 0
    ... )
    array([[[0.6, 0.8, 1. ]]])

    The same pair with the bias found by name in the motion model:

    >>> motion = DeadReckoning(np.diag([0.25, 0.25, 0.01]), names=("range_bias",))
    >>> RangeToBeacon((0.0, 0.0), R=4.0, state=motion, bias="range_bias").H(
    ...     np.array([[3.0, 4.0, 1.5]]), 0
    ... )
    array([[[0.6, 0.8, 1. ]]])
    """

    nonnegative = True          # measured ranges: the engine refuses a negative one

    covariances_checked = True      # R is a schedule checked when the model is made

    m = 1

    def __init__(self, beacon: ArrayLike, R: ArrayLike, *, n: int | None = None, bias_index: int | None = None,
                 state: BlockMotion | StateLayout | None = None, bias: str | None = None,
                 position: str = "position") -> None:
        if isinstance(beacon, dict):
            raise TypeError("beacon must be one beacon's position [x, y] (or its path); got a dict of beacons. For "
                            "ranges to several beacons at once use uwtutor.models.BeaconRanges(beacons, R)")
        b = as_finite("beacon", beacon, ndim=(1, 2, 3), nonempty=True, max_abs=1e150)
        if b.shape[-1] != 2:
            raise ValueError(f"beacon must hold horizontal positions [x, y]: shape (2,), (K, 2) or (M, K, 2); "
                             f"got {b.shape}")
        self.beacon = b
        if state is not None and (n is not None or bias_index is not None):
            raise ValueError("give state (the motion model whose slots the range reads) or the indices n and "
                             "bias_index, not both")
        if state is None and bias is not None:
            raise ValueError(f"bias={bias!r} names a slot of a state: give the motion model as state=... (or the "
                             "bias by its index, bias_index=...)")
        self._noise = NoiseSchedule("R", R, 1)
        self._R = self._noise.constant
        if state is None:
            size = as_int("n", 2 if n is None else n, minimum=2)
            if bias_index is not None:
                bias_index = as_int("bias_index", bias_index, minimum=2)
                if bias_index >= size:
                    raise ValueError(f"bias_index must index the state (0..{size - 1}); got {bias_index}")
                bias = "range_bias"
            state = StateLayout(n=size, range_bias=() if bias_index is None else (bias_index,))
        self.reads = ("position",) + (("bias",) if bias is not None else ())
        renames = {"position": _name(position, "position")}
        if bias is not None:
            renames["bias"] = _name(bias, "bias")
        super().__init__(state, slots=renames)
        pos = self.columns["position"]
        if pos.size != 2 or pos[1] <= pos[0]:
            raise ValueError(f"the position slot {position!r} must have 2 components, x before y; it has the "
                             f"indices {pos.tolist()}")
        if bias is not None and self.columns["bias"].size != 1:
            raise ValueError(f"the bias slot {bias!r} must have 1 component (the range bias); it has "
                             f"{self.columns['bias'].size}")
        self.bias_index = int(self.columns["bias"][0]) if bias is not None else None
        # the position read through a slice when its columns are adjacent (a view, not a copy: x[..., :2] for the
        # library's states)
        self._pos: Any = slice(int(pos[0]), int(pos[0]) + 2) if pos[1] == pos[0] + 1 else pos

    @property
    def n_steps(self) -> int | None:
        """Number of steps the beacon path covers (``None`` for a fixed beacon)."""
        return None if self.beacon.ndim == 1 else self.beacon.shape[-2]

    @property
    def n_runs(self) -> int | None:
        """Number of runs of a per-run beacon path (``None`` when shared by every run)."""
        return self.beacon.shape[0] if self.beacon.ndim == 3 else None

    def select_runs(self, runs: Any) -> "RangeToBeacon":
        """The same model for the runs ``runs`` (a slice or indices) of a per-run beacon path: what a particle filter
        takes when it moves its runs block by block."""
        out = copy.copy(self)
        if self.beacon.ndim == 3:
            out.beacon = self.beacon[runs]
        return out

    def beacon_at(self, k: int) -> np.ndarray:
        """The beacon position(s) of step ``k``: ``(2,)`` or ``(M, 2)``."""
        if self.beacon.ndim == 1:
            return self.beacon
        K = self.beacon.shape[-2]
        if not 0 <= k < K:
            raise IndexError(f"the beacon path has {K} positions; step {k} is beyond it. Give one beacon "
                             "position per step of the run")
        return self.beacon[k] if self.beacon.ndim == 2 else self.beacon[:, k]

    def _beacon_for(self, x: np.ndarray, k: int) -> np.ndarray:
        """The beacon of step ``k`` aligned with states ``(M, n)`` or particles ``(M, N, n)``."""
        b = self.beacon_at(k)
        if b.ndim == 2 and x.ndim == 3:                  # one per run: broadcast over the particles of each run
            b = b[:, None, :]
        return b

    def linearize(self, x: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        r, los, defined = _line_of_sight(x[..., self._pos], self._beacon_for(x, k))
        H = np.zeros(x.shape[:-1] + (1, self.n))
        H[..., 0, self._pos] = los
        z = r[..., None]
        if self.bias_index is not None:
            H[..., 0, self.bias_index] = 1.0
            z = z + x[..., self.bias_index:self.bias_index + 1]
        return z, H, defined

    def h(self, x: np.ndarray, k: int) -> np.ndarray:
        z = distances(x[..., self._pos], self._beacon_for(x, k))[..., None]
        if self.bias_index is not None:
            z = z + x[..., self.bias_index:self.bias_index + 1]
        return z

    def H(self, x: np.ndarray, k: int) -> np.ndarray:
        return self.linearize(x, k)[1]

    def R(self, x: np.ndarray, k: int) -> np.ndarray:
        return self._noise.at(k)


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
        Size of the state (default 2), without ``state``.
    state : BlockMotion or StateLayout, optional
        The state whose ``position`` slot the range reads (as for :class:`RangeToBeacon`).
    position : str, default "position"
        The name of the position slot in ``state``.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.models import MultiplicativeRange
    >>> model = MultiplicativeRange(
    ...     (0.0, 0.0), R=0.49, mu_gamma=0.98, sigma_gamma=1 / 1500
    ... )
    >>> x = np.array([[3000.0, 4000.0]])
    >>> model.h(x, 0), model.R(x, 0)
    (array([[4900.]]), array([[[11.60111111]]]))

    The same range on a state built from blocks, the position read by name wherever it sits:

    >>> from uwtutor.models import BlockMotion, Position, RandomWalk
    >>> motion = BlockMotion(RandomWalk("scale"), Position(np.eye(2)))
    >>> on_blocks = MultiplicativeRange(
    ...     (0.0, 0.0), R=0.49, mu_gamma=0.98, sigma_gamma=1 / 1500, state=motion
    ... )
    >>> on_blocks.h(np.array([[1.0, 3000.0, 4000.0]]), 0)
    array([[4900.]])
    """

    def __init__(self, beacon: ArrayLike, R: ArrayLike, mu_gamma: float, sigma_gamma: float, *, n: int | None = None,
                 state: BlockMotion | StateLayout | None = None, position: str = "position") -> None:
        super().__init__(beacon, R, n=n, state=state, position=position)
        # the factor c / c_e is near 1: 1e3 is far beyond any sound-speed error (as for the fading filter's)
        mu = float(as_finite("mu_gamma", mu_gamma, ndim=0, max_abs=1e3))
        sigma = float(as_finite("sigma_gamma", sigma_gamma, ndim=0, max_abs=1e3))
        if not mu > 0.0:
            raise ValueError(f"mu_gamma must be > 0 (the mean range factor, about 1); got {mu:g}")
        if sigma < 0.0:
            raise ValueError(f"sigma_gamma must be >= 0 (a standard deviation); got {sigma:g}")
        self.mu_gamma, self.sigma_gamma = mu, sigma

    def linearize(self, x: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        z, H, defined = super().linearize(x, k)
        return self.mu_gamma * z, self.mu_gamma * H, defined

    def h(self, x: np.ndarray, k: int) -> np.ndarray:
        return self.mu_gamma * super().h(x, k)

    def R(self, x: np.ndarray, k: int) -> np.ndarray:
        r""":math:`\sigma_\gamma^2 r^2 + R` at each state: ``(M, 1, 1)``, or ``(M, N, 1, 1)`` for particles."""
        r, _, _ = _line_of_sight(x[..., self._pos], self._beacon_for(x, k))
        return (self.sigma_gamma**2 * r**2 + self._noise.at(k)[0, 0])[..., None, None]


class NoiseSchedule:
    r"""A measurement noise covariance that may change from step to step: what a model's ``R(x, k)`` returns.

    Parameters
    ----------
    name : str
        The argument's name, for the error messages.
    R : float or array_like
        One of

        * a number: the variance of every component [unit²], > 0;
        * ``(m, m)``: one covariance (symmetric positive definite) for every step;
        * ``(K,)``: one variance per step, the same for every component;
        * ``(K, m)``: one variance per step and component (``m`` must then differ from ``K``; give per-step
          matrices ``(K, m, m)`` when it does not);
        * ``(K, m, m)``: one covariance per step;
        * ``(M, K, m, m)``: one covariance per run and step (e.g. noise levels estimated online, run by run).

        Per-step variances may be NaN at a step (or for a component) without a measurement; a filter refuses a NaN
        where a measurement is present.
    m : int
        Size of one measurement.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.models.range import NoiseSchedule
    >>> # (K, m): per step and beacon
    >>> R = NoiseSchedule("R", [[0.1, 0.2], [np.nan, 0.3], [0.1, 0.1]], 2)
    >>> R.n_steps, R.at(1)
    (3, array([[nan, 0. ],
           [0. , 0.3]]))
    >>> NoiseSchedule("R", 4.0, 2).at(7)
    array([[4., 0.],
           [0., 4.]])
    """

    def __init__(self, name: str, R: ArrayLike, m: int) -> None:
        self.name, self.m = name, as_int("m", m, minimum=1)
        arr = as_float_array(name, R)
        self.constant: np.ndarray | None = None
        self._variances: np.ndarray | None = None
        self._matrices: np.ndarray | None = None
        if arr.ndim == 0:
            self.constant = float(as_covariance(name, arr, 1)[0, 0]) * np.eye(m)
        elif arr.ndim == 2 and arr.shape == (m, m):
            try:
                self.constant = as_covariance(name, arr, m)
            except ValueError as exc:
                raise ValueError(f"{exc} (a ({m}, {m}) {name} is one covariance for every step; for per-step "
                                 f"variances of a run of {m} steps give ({m}, {m}, {m}) diagonal matrices)") from None
        elif arr.ndim == 1 or (arr.ndim == 2 and arr.shape[1] == m):
            var = arr[:, None] * np.ones(m) if arr.ndim == 1 else arr
            if var.shape[0] == 0:
                raise ValueError(f"{name} is empty: give a variance, or one per step")
            bad = np.isinf(var) | (var <= 0)
            if bad.any():
                k, j = (int(i) for i in np.argwhere(bad)[0])
                raise ValueError(f"{name} must hold variances > 0 (NaN at a step without a measurement); got "
                                 f"{var[k, j]:g} at step {k}" + (f", component {j}" if m > 1 else ""))
            self._variances = np.ascontiguousarray(var)
        elif arr.ndim == 3 and arr.shape[1:] == (m, m):
            self._matrices = as_covariance(name, arr, m)
        elif arr.ndim == 4 and arr.shape[2:] == (m, m):
            # one per run and step, held step-major: at(k) is one contiguous (M, m, m) block
            self._matrices = np.ascontiguousarray(np.swapaxes(as_covariance(name, arr, m), 0, 1))
        else:
            per = "(K,), (K, m)" if m > 1 else "(K,)"
            raise ValueError(f"{name} must be a variance, a ({m}, {m}) covariance, or one per step: {per} variances "
                             f"or (K, {m}, {m}) covariances, or (M, K, {m}, {m}) per run and step (m = {m} "
                             f"components); got shape {arr.shape}")
        if self._variances is not None:
            self._eye = np.eye(m, dtype=bool)

    @property
    def n_steps(self) -> int | None:
        """Number of steps covered (None for one covariance for every step)."""
        per_step = self._variances if self._variances is not None else self._matrices
        return None if per_step is None else per_step.shape[0]

    @property
    def n_runs(self) -> int | None:
        """Number of runs of a per-run schedule ``(M, K, m, m)`` (None when shared by every run)."""
        return self._matrices.shape[1] if self._matrices is not None and self._matrices.ndim == 4 else None

    def select_runs(self, runs: Any) -> "NoiseSchedule":
        """The schedule of the runs ``runs`` (a slice or indices) of a per-run schedule (itself otherwise)."""
        if self.n_runs is None or self._matrices is None:
            return self
        out = copy.copy(self)
        out._matrices = np.ascontiguousarray(self._matrices[:, runs])
        return out

    def at(self, k: int) -> np.ndarray:
        """The covariance ``(m, m)`` of step ``k`` (``(M, m, m)`` for a per-run schedule)."""
        if self.constant is not None:
            return self.constant
        K = self.n_steps
        assert K is not None                # not a constant: per-step variances or matrices
        if not 0 <= k < K:
            raise IndexError(f"{self.name} has {K} per-step values; step {k} is beyond them. Give one per step of "
                             "the run")
        if self._matrices is not None:
            return self._matrices[k]
        assert self._variances is not None
        out = np.zeros((self.m, self.m))
        np.fill_diagonal(out, self._variances[k])
        return out


def _beacon_table(beacons: Any) -> tuple[tuple[Any, ...], np.ndarray]:
    """Beacon ids and positions (B, 2) from a dict id -> (x, y), an array (B, 2) or one position (2,)."""
    if isinstance(beacons, dict):
        if not beacons:
            raise ValueError("beacons is an empty dict: give at least one beacon id -> (x, y)")
        ids = tuple(beacons)
        try:
            pos = as_finite("beacons", [beacons[i] for i in ids], ndim=2, max_abs=1e150)
        except (TypeError, ValueError) as exc:
            raise type(exc)(f"beacons must map each beacon id to its position (x, y): {exc}") from None
    else:
        pos = as_finite("beacons", beacons, ndim=(1, 2), nonempty=True, max_abs=1e150)
        if pos.ndim == 1:
            pos = pos[None]
        ids = tuple(range(len(pos)))
    if pos.shape[-1] != 2:
        raise ValueError(f"beacons must hold horizontal positions (x, y): a dict id -> (x, y), shape (B, 2) or (2,); "
                         f"got positions of shape {pos.shape}")
    return ids, pos


class BlockRanges(BlockMeasurement):
    r"""Ranges to beacons at known positions, read from the ``position`` slot, with an optional range scale and
    range bias read from theirs: :math:`z_{k,j} = s\,\lVert p_k - b_j \rVert + \upsilon_j + v_{k,j}`.

    :class:`~uwtutor.models.range.BeaconRanges` on a block state (the same ``h``, ``H`` and ``R``): the slots are
    found by name, not given as indices.

    Parameters
    ----------
    beacons : array_like, shape (B, 2), or dict of id to (x, y)
        The beacons, one measurement component each.
    R : float or array_like
        The range noise: a variance, ``(B, B)``, or one per step (as ``BeaconRanges``).
    state : BlockMotion or StateLayout
        The state whose slots the ranges read (the motion model, or its slots by index).
    scale : str, optional
        The slot of a range scale (e.g. ``"scale"``).
    bias : str, optional
        The slot of the range bias: one component shared by every beacon, or one per beacon.
    position : str, default "position"

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.models import BlockMotion, BlockRanges, OdometryPose, RandomWalk
    >>> motion = BlockMotion(OdometryPose(0.1, 0.01), RandomWalk("scale"))
    >>> ranges = BlockRanges([[0.0, 0.0], [10.0, 0.0]], 0.01, motion, scale="scale")
    >>> ranges.h(np.array([[3.0, 4.0, 0.0, 1.1]]), 0)
    array([[5.5       , 8.86848352]])
    """

    covariances_checked = True      # R goes through NoiseSchedule, checked when the model is made
    nonnegative = True

    def __init__(self, beacons: Mapping[Any, ArrayLike] | ArrayLike, R: ArrayLike, state: BlockMotion | StateLayout,
                 *, scale: str | None = None, bias: str | None = None, position: str = "position") -> None:
        self.beacon_ids, self.beacons = _beacon_table(beacons)
        self.m = len(self.beacons)
        self._scale, self._bias = scale is not None, bias is not None
        self.reads = ("position",) + (("scale",) if self._scale else ()) + (("bias",) if self._bias else ())
        renames = {"position": _name(position, "position")}
        renames.update({"scale": _name(scale, "scale")} if self._scale else {})
        renames.update({"bias": _name(bias, "bias")} if self._bias else {})
        super().__init__(state, slots=renames)
        if self.columns["position"].size != 2:
            raise ValueError(f"the position slot {position!r} must have 2 components (x, y); it has "
                             f"{self.columns['position'].size}")
        if self._scale and self.columns["scale"].size != 1:
            raise ValueError(f"the scale slot {scale!r} must have 1 component; it has {self.columns['scale'].size}")
        if self._bias and self.columns["bias"].size not in (1, self.m):
            raise ValueError(f"the bias slot {bias!r} must have 1 component (shared) or {self.m} (one per beacon); "
                             f"it has {self.columns['bias'].size}")
        self._bias_cols = (np.resize(self.columns["bias"], self.m) if self._bias else None)
        self._noise = NoiseSchedule("R", R, self.m)
        pos = self.columns["position"]
        # the position read through a slice when its two columns are adjacent (a view, not a copy), the scale
        # through its one column
        self._pos: Any = slice(int(pos[0]), int(pos[0]) + 2) if pos[1] == pos[0] + 1 else pos
        self._scale_col = int(self.columns["scale"][0]) if self._scale else None

    @property
    def n_steps(self) -> int | None:
        """Number of steps a per-step ``R`` covers (None when it is one for every step)."""
        return self._noise.n_steps

    def linearize(self, x: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Predicted ranges ``(M, B)``, Jacobian ``(M, B, n)`` and a mask ``(M, B)``, False where the position is
        exactly on a beacon (that component's Jacobian is undefined)."""
        r, los, defined = _line_of_sight(x[..., None, self._pos], self.beacons)  # (M, B), (M, B, 2), (M, B)
        H = np.zeros(r.shape + (self.n,))
        if self._scale_col is None:
            z = r
            H[..., self._pos] = los
        else:
            s = x[..., self._scale_col, None]
            z = s * r
            H[..., self._pos] = s[..., None] * los
            H[..., self._scale_col] = r
        if self._bias_cols is not None:
            z = z + x[..., self._bias_cols]
            H[..., np.arange(self.m), self._bias_cols] = 1.0
        return z, H, defined

    def h(self, x: np.ndarray, k: int) -> np.ndarray:
        z = distances(x[..., None, self._pos], self.beacons)                   # (..., B)
        if self._scale_col is not None:
            z *= x[..., self._scale_col, None]
        if self._bias_cols is not None:
            z += x[..., self._bias_cols]
        return z

    def R(self, x: np.ndarray, k: int) -> np.ndarray:
        return self._noise.at(k)


class BeaconRanges(BlockRanges):
    r"""Ranges to one beacon or several at once, with an optional range scale and range bias(es) in the state.

    For beacons :math:`b_1, \dots, b_B` at known, fixed positions the measurement of step :math:`k` is the vector

    .. math::

        z_{k,j} = s\,\lVert p_k - b_j \rVert + \upsilon_j + v_{k,j}, \qquad v_k \sim N(0, R_k), \qquad
        j = 1, \dots, B,

    with :math:`s` the range scale (1 without a scale state: a sound-speed error or a clock that runs fast
    makes every range :math:`s` times the distance) and :math:`\upsilon_j` a range bias (0 without one; one
    shared by every beacon or one per beacon). Its Jacobian row :math:`j` is

    .. math::

        H_{k,j} = \Big[\, s\,\frac{(p - b_j)^\mathsf{T}}{\lVert p - b_j \rVert},\; \dots,\;
        \lVert p - b_j \rVert \text{ at the scale},\; \dots,\; 1 \text{ at } \upsilon_j \,\Big].

    A beacon that did not answer at an epoch is a NaN component of :math:`z_k`: the filters update with the
    components that are present (:class:`~uwtutor.filters.engine.ExtendedKalmanFilter`). The state layout -- which index
    is the scale, which the bias -- comes from a :class:`~uwtutor.models.odometry.StateLayout` (``layout=``, e.g. the
    motion model's ``motion.layout``) or from the indices; with the motion model at hand, :class:`BlockRanges`
    (``BlockRanges(beacons, R, state=motion, scale="scale", bias="range_bias")``) reads the same slots by name.

    Parameters
    ----------
    beacons : dict or array_like
        The beacon positions [m]: a dict id -> (x, y) (the order of the dict is the order of the components), an
        array ``(B, 2)``, or one position ``(2,)``.
    R : float or array_like
        Range noise: a variance [m²] for every beacon and step, a ``(B, B)`` covariance, or per step: ``(K,)``
        variances shared by the beacons, ``(K, B)`` per beacon, or ``(K, B, B)`` (see :class:`NoiseSchedule`;
        NaN allowed where there is no range). The model's ``R(x, k)`` reads row ``k``.
    layout : StateLayout, optional
        Where the scale and the range bias(es) are in the state (and its size).
    n : int, optional
        Size of the state, without ``layout`` (default 2 plus nothing).
    scale_index : int, optional
        Index of the range scale, without ``layout``.
    bias_index : int or sequence of int, optional
        Index of one range bias shared by every beacon, or ``B`` indices (one per beacon), without ``layout``.

    Attributes
    ----------
    beacon_ids : tuple
        The ids of the beacons, in the order of the components (0..B-1 for an array).
    beacons : ndarray, shape (B, 2)
        Their positions.

    Examples
    --------
    Four beacons, a state ``[x, y, heading, scale]``, the ranges 7 % long:

    >>> import numpy as np
    >>> from uwtutor.models import BeaconRanges, StateLayout
    >>> beacons = {
    ...     "A": (0.0, 0.0),
    ...     "B": (30.0, 0.0),
    ...     "C": (30.0, 40.0),
    ...     "D": (0.0, 40.0),
    ... }
    >>> model = BeaconRanges(
    ...     beacons, R=0.01, layout=StateLayout.odometry(scale=True)
    ... )
    >>> # [x, y, heading, scale]
    >>> x = np.array([[3.0, 4.0, 0.3, 1.07]])
    >>> # 1.07 x (5, 27.295, 45, 36.125)
    >>> model.h(x, 0).round(3)
    array([[ 5.35 , 29.205, 48.15 , 38.654]])
    >>> # d/dx, d/dy, d/dheading, d/dscale
    >>> model.H(x, 0)[0, 0].round(3)
    array([0.642, 0.856, 0.   , 5.   ])
    """

    def __init__(self, beacons: Mapping[Any, ArrayLike] | ArrayLike, R: ArrayLike, *, layout: StateLayout | None = None,
                 n: int | None = None, scale_index: int | None = None,
                 bias_index: int | Sequence[int] | None = None) -> None:
        B = len(_beacon_table(beacons)[1])
        if layout is not None:
            if not isinstance(layout, StateLayout):
                raise TypeError(f"layout must be a uwtutor.models.StateLayout (e.g. motion.layout); got "
                                f"{type(layout).__name__}")
            if n is not None or scale_index is not None or bias_index is not None:
                raise ValueError("give layout or the indices (n, scale_index, bias_index), not both")
            n, scale_index, bias = layout.n, layout.scale, layout.range_bias
        else:
            n = 2 if n is None else n
            bias = () if bias_index is None else tuple(np.atleast_1d(np.asarray(bias_index)).tolist())
        n = as_int("n", n, minimum=2)
        taken: dict[int, str] = {}
        for name, i in [("scale_index", scale_index)] + [(f"bias_index[{j}]", i) for j, i in enumerate(bias)]:
            if i is None:
                continue
            i = as_int(name, i, minimum=2)
            if i >= n or i in taken:
                raise ValueError(f"{name} must be a free index of the state (2..{n - 1}, 0 and 1 being the "
                                 f"position); got {i}" + (f", already {taken[i]}" if i in taken else ""))
            taken[i] = name
        if len(bias) not in (0, 1, B):
            raise ValueError(f"the range biases must be one shared by every beacon or one per beacon ({B}); got "
                             f"{len(bias)} bias states")
        self.scale_index = None if scale_index is None else int(scale_index)
        self.bias_index = tuple(int(i) for i in bias)
        if layout is None:
            layout = StateLayout(n=n, scale=self.scale_index, range_bias=self.bias_index)
        super().__init__(beacons, R, layout, scale=None if self.scale_index is None else "scale",
                         bias="range_bias" if self.bias_index else None)
