r"""The posterior (Bayesian) Cramér–Rao bound of a filter with process noise (Tichavský et al. 1998)."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validate import (
    as_covariance,
    as_finite,
    as_flag,
    as_float_array,
    as_points,
    common_runs,
)
from ..errors import IllConditionedError
from ..models.base import MeasurementModel, MotionModel
from ..models.blocks import MAX_STEP, BlockMotion, Current, Position, RandomWalk, StateBlock
from ..models.range import RangeToBeacon
from ._common import _state_labels, _warn

__all__ = ["posterior_crlb", "model_posterior_crlb"]

#: Largest finite range noise accepted [m]: its square, the variance the range model holds, stays within 1e150.
_MAX_SIGMA = 1e75


def _pcrb_state_size(bias: bool, current: bool) -> int:
    return 2 + int(bias) + 2 * int(current)


def _pcrb_steps(times: Any, k: int, current: bool) -> np.ndarray | None:
    """The interval of each of the ``k`` steps (the current moves the vehicle by ``dt_k U`` in step k)."""
    if times is None:
        if current:
            raise ValueError("times are needed with current=True: each step moves the vehicle by dt_k U. Give the "
                             "K epoch times (the first step then lasts times[1] - times[0]) or K + 1 times starting "
                             "with the time of x0")
        return None
    t = as_finite("times", times, ndim=1)
    if len(t) in (k, k + 1) and np.any(np.diff(t) <= 0):      # checked even where the times are not used
        step = int(np.flatnonzero(np.diff(t) <= 0)[0])
        raise ValueError(f"times must increase strictly; times[{step + 1}] = {t[step + 1]:g} follows "
                         f"times[{step}] = {t[step]:g}")
    if len(t) == k + 1:
        if not current:
            return None
        dt = np.diff(t)
    elif len(t) == k:
        if not current:
            return None
        if k < 2:
            raise ValueError("with a single epoch give times as [t_x0, t_1] (K + 1 entries): the step before the "
                             "first epoch has no length otherwise")
        dt = np.diff(t, prepend=t[0] - (t[1] - t[0]))
    else:
        raise ValueError(f"times must have one entry per epoch ({k}), or {k + 1} entries starting with the time "
                         f"of x0; got {len(t)}")
    # dt > 0 here: the times were checked to increase strictly above
    if np.any(dt > MAX_STEP):
        raise ValueError(f"times must be in seconds: step {int(np.flatnonzero(dt > MAX_STEP)[0])} lasts "
                         f"{dt.max():.3g} s, beyond the motion models' bound of {MAX_STEP:g} s")
    return dt


def _pcrb_process_noise(Q: Any, n: int, k: int) -> np.ndarray:
    """Q as (n, n), or (k, n, n) one per step: a position-only Q is embedded with zeros (a constant bias and
    current)."""
    q = as_covariance("Q", Q, allow_singular=True)
    if q.ndim not in (2, 3) or (q.ndim == 3 and q.shape[0] != k) or q.shape[-1] not in (2, n):
        raise ValueError(f"Q must be the process noise covariance of one step, shape (2, 2) (position only) or "
                         f"({n}, {n}) (the whole state), or one per step, shape ({k}, 2, 2) or ({k}, {n}, {n}); "
                         f"got {q.shape}")
    out = np.zeros(q.shape[:-2] + (n, n))
    m = q.shape[-1]
    out[..., :m, :m] = q
    return out


def _pcrb_sigma(sigma: Any, shape: tuple[int, int]) -> tuple[Any, np.ndarray]:
    r"""The range variance :math:`R_k = \sigma_k^2` as :class:`~uwtutor.models.RangeToBeacon` takes it, and where a
    range is present ``(M, K)`` (``sigma = inf``: no range at that epoch)."""
    s = as_float_array("sigma", sigma)
    bad = np.isnan(s) | (s <= 0)
    if bad.any():
        raise ValueError(f"sigma must be > 0 (np.inf for an epoch without a range); got {s[bad].flat[0]}")
    small = s < 1e-150
    if small.any():
        raise ValueError(f"sigma must be at least 1e-150 (1 / sigma^2 overflows float64 below it); got "
                         f"{s[small].flat[0]:.3g}. Change its units")
    large = np.isfinite(s) & (s > _MAX_SIGMA)
    if large.any():
        raise ValueError(f"sigma must be at most {_MAX_SIGMA:g} (its square, the range variance, is bounded by "
                         f"{_MAX_SIGMA**2:g}), or np.inf for an epoch without a range; got {s[large].flat[0]:.3g}. "
                         "Change its units")
    try:
        measured = np.broadcast_to(np.isfinite(s), shape)
    except ValueError:
        raise ValueError(f"sigma must be a number, one value per epoch (K,) = ({shape[-1]},), or one per run and "
                         f"epoch {shape}; got shape {s.shape}") from None
    if s.ndim < 2 or s.shape[0] == 1:                      # the same in every run: (K,), NaN where no range
        row = np.broadcast_to(s, shape)[0]
        return np.where(np.isfinite(row), row**2, np.nan), measured
    # one per run and epoch, (M, K, 1, 1); 1 stands in where there is no range (the mask skips it)
    per_run = np.broadcast_to(s, shape)
    return (np.where(np.isfinite(per_run), per_run, 1.0) ** 2)[..., None, None], measured


class _GivenProcessNoise(MotionModel):
    r"""Linear blocks' :math:`f` and :math:`F` with the process noise :math:`Q_k` given step by step.

    :func:`posterior_crlb` takes the noise of each step as its caller gives it: one matrix for every step or one
    per step, and a whole-state one may couple the position with the bias and the current. The blocks' own noise
    cannot say that (it is block diagonal, and a random walk's grows with the step's length in seconds), so the
    blocks give the state and its transition, and ``Q`` is the caller's, ``(n, n)`` or ``(K, n, n)``. The blocks
    are linear, so :math:`F_k` depends on the step's length alone: it is assembled once per length.
    """

    covariances_checked = True          # checked (symmetric PSD) by posterior_crlb

    def __init__(self, motion: BlockMotion, Q: np.ndarray) -> None:
        self.motion, self.n, self._Q = motion, motion.n, Q
        self._origin = np.zeros((1, motion.n))
        self._F: dict[float, np.ndarray] = {}

    def f(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        return self.motion.f(x, u, k)

    def F(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        dt = self.motion.dt(k)
        if dt not in self._F:
            self._F[dt] = self.motion.F(self._origin, None, k)
        return self._F[dt]

    def Q(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        return self._Q if self._Q.ndim == 2 else self._Q[k]


def _dead_reckoning_state(bias: bool, current: bool, dt: np.ndarray | None, Q: np.ndarray) -> _GivenProcessNoise:
    """The state ``[x, y, (bias), (Ux, Uy)]`` from the blocks: a position moved by the DR displacement (and carried
    by the current over ``dt``), a range bias and a current, constant but for the per-step noise ``Q``."""
    blocks: list[StateBlock] = [Position(np.zeros((2, 2)), current="current" if current else None)]
    if bias:
        blocks.append(RandomWalk("range_bias"))
    if current:
        blocks.append(Current())
    return _GivenProcessNoise(BlockMotion(*blocks, dt=dt), Q)


def _sym(a: np.ndarray) -> np.ndarray:
    return (a + np.swapaxes(a, -1, -2)) / 2


def _spd_inverse(J: np.ndarray) -> np.ndarray:
    """Inverse of a stack of symmetric positive-definite matrices through their Cholesky factors."""
    L = np.linalg.cholesky(J)
    L_inv = np.linalg.solve(L, np.broadcast_to(np.eye(J.shape[-1]), J.shape))
    return np.swapaxes(L_inv, -1, -2) @ L_inv


def posterior_crlb(positions: ArrayLike, beacon: ArrayLike, sigma: ArrayLike, Q: ArrayLike, P0: ArrayLike,
                   times: ArrayLike | None = None, *,
                   bias: bool = False, current: bool = False, full: bool = False,
                   mean_over_runs: bool = False) -> NDArray[np.float64]:
    r"""The posterior Cramér–Rao bound of dead reckoning with process noise and ranges to one beacon, epoch by epoch.

    The state :math:`x_k = [p_k,\; \upsilon,\; U]` (position; with ``bias`` a range bias, paper A; with
    ``current`` a constant current, paper B) moves linearly and is ranged with additive Gaussian noise:

    .. math::

        x_k = F_k x_{k-1} + [u_k, 0, 0] + w_k, \quad w_k \sim N(0, Q_k), \qquad
        F_k = \begin{bmatrix} I & 0 & \Delta t_k I \\ 0 & 1 & 0 \\ 0 & 0 & I \end{bmatrix},

    .. math::

        r_k = \lVert p_k - b_k \rVert + \upsilon + \eta_k, \quad \eta_k \sim N(0, \sigma_k^2).

    Tichavský, Muravchik and Nehorai (1998) bound the mean squared error matrix of *any* estimator of
    :math:`x_k` from the ranges up to epoch :math:`k` -- biased or not, the prior included -- by
    :math:`J_k^{-1}`, with the information :math:`J_k` given by a recursion. For a linear motion with additive
    Gaussian noise it reads

    .. math::

        J_0 = P_0^{-1}, \qquad
        J_k = \left(Q_k + F_k J_{k-1}^{-1} F_k^\mathsf{T}\right)^{-1}
              + \operatorname{E}\!\left[H_k^\mathsf{T} R_k^{-1} H_k\right], \qquad
        H_k = \left[\frac{(p_k - b_k)^\mathsf{T}}{\lVert p_k - b_k \rVert},\; 1,\; 0,\; 0\right],

    the information-form Kalman filter, whose linearization point is the *true* state: each step predicts with
    :math:`Q_k`, then adds that epoch's range information, as the filters do. With one range,
    :math:`H_k^\mathsf{T} R_k^{-1} H_k = H_k^\mathsf{T} H_k / \sigma_k^2` depends only on the bearing of the
    vehicle from the beacon. As :math:`Q \to 0` (and :math:`P_0^{-1} \to 0`), :math:`J_k` becomes the
    information of all the ranges so far about the state now, and the bound becomes chapter 2's static bound
    (``track_crlb``); process noise makes old ranges worth less and keeps the bound from shrinking to zero.

    .. rubric:: The expectation, evaluated on the true track

    The expectation is over the true states, which are random: the initial error (:math:`P_0`) and the process
    noise scatter the true positions about the nominal track, and each range's information
    :math:`H_k^\mathsf{T} H_k / \sigma_k^2` points along a bearing that scatters with them. By default it is
    evaluated at the given ``positions`` only: a first-order approximation, exact in the limit of a true track
    known to within a negligible fraction of the range to the beacon, whose error grows with the bearing
    scatter (spread of the true positions over the range). On a track that turns 150-250 m from the beacon
    and then runs out to 400 m, 4 m of scatter changes the bound by 0.2 %; 15 m (2 m of DR noise per step, 60
    steps) by 10-30 %, and
    the exact bound is then *lower*: the scatter spreads each range's information over several directions,
    most usefully where the nominal geometry leaves a direction unobserved (a radial leg). To evaluate the
    expectation properly, pass the sampled true tracks of a Monte Carlo study (``positions`` of shape
    ``(M, K, 2)``) with ``mean_over_runs=True``: :math:`\operatorname{E}[\cdot]` is then their mean, the
    Monte Carlo evaluation of the original paper, which converges to the exact bound as :math:`M` grows. That
    is the bound to set against an RMSE over runs whose true tracks differ.

    .. rubric:: Numerics

    The recursion never inverts :math:`J`: with :math:`\tilde J = F_k^{-\mathsf{T}} J_{k-1} F_k^{-1}` (``F_k``
    is unit triangular), :math:`(Q_k + \tilde J^{-1})^{-1} = \tilde J (I + Q_k \tilde J)^{-1}`, a solve with a
    matrix whose eigenvalues are all :math:`\ge 1`. This holds for a singular :math:`Q_k` (a constant bias or
    current; :math:`Q = 0`) and a nearly uninformative :math:`P_0`, and :math:`J` is symmetrized at every step.
    The bound itself is :math:`J_k^{-1}` through a Cholesky factor.

    .. rubric:: The models

    This function is a front end: it builds the models and runs :func:`model_posterior_crlb`'s recursion. The
    state is assembled from the library's blocks (:mod:`uwtutor.models.blocks`): a
    :class:`~uwtutor.models.blocks.Position` carried by a :class:`~uwtutor.models.blocks.Current` over
    :math:`\Delta t_k`, and a :class:`~uwtutor.models.blocks.RandomWalk` named ``range_bias``; the ranges are the
    filters' own model, :class:`~uwtutor.models.range.RangeToBeacon` with :math:`R_k = \sigma_k^2`, evaluated at
    the true positions. The process noise is ``Q`` as given, step by step: it may couple the position with the bias
    and the current, which the blocks' own (block-diagonal) noise cannot express.

    Parameters
    ----------
    positions : array_like, shape (K, 2) or (M, K, 2)
        True vehicle positions :math:`p_k` at the K ranging epochs [m]; a leading axis of M runs gives one
        bound per run (or, with ``mean_over_runs``, their average information).
    beacon : array_like, shape (2,), (K, 2) or (M, K, 2)
        Beacon position: fixed, one per epoch (a moving beacon: a ship, a leader), or one per run and epoch [m].
    sigma : float or array_like, shape (K,) or (M, K)
        Range noise standard deviation(s) :math:`\sigma_k` [m], > 0 (at most 1e75); ``np.inf`` at an epoch
        without a range (predict only).
    Q : array_like, shape (2, 2), (n, n), (K, 2, 2) or (K, n, n)
        Process noise covariance of one step (positive semi-definite), or one per step. A (2, 2) ``Q`` is the
        dead-reckoning noise of the position; the bias and the current are then constant. A full (n, n) ``Q``
        lets them random-walk.
    P0 : array_like, shape (n, n) or (M, n, n)
        Covariance of :math:`x_0`, the state before the first step (positive definite); state order
        ``[x, y, bias, Ux, Uy]`` (the blocks asked for), ``n`` = 2, 3, 4 or 5.
    times : array_like, shape (K,) or (K + 1,), optional
        Epoch times [s], needed with ``current``: step :math:`k` lasts :math:`\Delta t_k = t_k - t_{k-1}`.
        With K entries the first step lasts ``times[1] - times[0]`` (a regular grid, :math:`x_0` one interval
        before the first epoch); with K + 1 entries the first is the time of :math:`x_0`.
    bias : bool, default False
        Add a range bias :math:`\upsilon` to the state (paper A).
    current : bool, default False
        Add a constant current :math:`U = [U_x, U_y]` that moves the vehicle by :math:`\Delta t_k U` in step
        :math:`k` (paper B).
    full : bool, default False
        Return the bound of the whole state, not only of the position.
    mean_over_runs : bool, default False
        With ``positions`` (and/or ``beacon``, ``sigma``) per run, evaluate the expectation as the mean of the
        range information over the runs and return one bound (``P0`` and ``Q`` are then shared).

    Returns
    -------
    ndarray, shape (K, 2, 2), or (M, K, 2, 2) per run
        The bound :math:`J_k^{-1}` on the position [m²] after epoch :math:`k`'s range; with ``full`` the whole
        ``(K, n, n)`` (or ``(M, K, n, n)``) bound. ``rmse_bound`` turns it into :math:`\sqrt{\operatorname{tr}}`
        of the position block, the bound that an RMSE over runs is compared with.

    Warns
    -----
    UnobservableWarning
        When a position coincides with the beacon: that range carries no information (its line of sight is
        undefined) and is skipped.

    See Also
    --------
    track_crlb : the static bound (no process noise, no prior), the limit of this one as Q -> 0.

    References
    ----------
    P. Tichavský, C. H. Muravchik and A. Nehorai, "Posterior Cramér–Rao bounds for discrete-time nonlinear
    filtering", IEEE Trans. Signal Process. 46(5), 1386–1396, 1998 (the information recursion, and its form
    for additive Gaussian noise and linear dynamics).

    Examples
    --------
    A vehicle circling a beacon at 200 m with dead-reckoning noise of 0.3 m per step and 2 m ranges: the bound
    settles where the range information of each step balances the drift.

    >>> import numpy as np
    >>> from uwtutor.observability import posterior_crlb, rmse_bound
    >>> theta = np.linspace(0.0, 2 * np.pi, 401)[1:]
    >>> track = 200.0 * np.column_stack([np.cos(theta), np.sin(theta)])
    >>> pcrb = posterior_crlb(
    ...     track, [0.0, 0.0], sigma=2.0, Q=0.3**2 * np.eye(2), P0=25.0 * np.eye(2)
    ... )
    >>> pcrb.shape
    (400, 2, 2)
    >>> bound = rmse_bound(pcrb)
    >>> print(
    ...     f"{bound[0]:.2f} m at the first epoch, {bound[-1]:.2f} m at the last"
    ... )
    5.34 m at the first epoch, 2.62 m at the last

    With an unknown range bias (paper A's three states), the full bound has the bias too:

    >>> full = posterior_crlb(
    ...     track,
    ...     [0.0, 0.0],
    ...     2.0,
    ...     0.3**2 * np.eye(2),
    ...     np.diag([25.0, 25.0, 4.0]),
    ...     bias=True,
    ...     full=True,
    ... )
    >>> full.shape, bool(rmse_bound(full[-1]) > bound[-1])
    ((400, 3, 3), True)
    """
    bias, current = bool(bias), bool(current)
    n = _pcrb_state_size(bias, current)
    p = as_points("positions", positions, min_ndim=2)
    if p.ndim not in (2, 3) or p.shape[-2] == 0:
        raise ValueError(f"positions must have shape (K, 2) or (M, K, 2) with K >= 1; got {p.shape}")
    K = p.shape[-2]
    b = as_points("beacon", beacon)
    if b.ndim > 3 or (b.ndim >= 2 and b.shape[-2] != K):
        raise ValueError(f"beacon must have shape (2,), ({K}, 2) (one position per epoch) or (M, {K}, 2); got "
                         f"{b.shape}")
    s_in = as_float_array("sigma", sigma)
    P0_arr = as_covariance("P0", P0)
    if P0_arr.ndim not in (2, 3) or P0_arr.shape[-1] != n:
        labels = ", ".join(_state_labels(n, bias, current))
        raise ValueError(f"P0 must be ({n}, {n}) or (M, {n}, {n}), the covariance of [{labels}] before the first "
                         f"step; got shape {P0_arr.shape}")
    # the runs axis: from positions, beacon, sigma and P0 (one of length 1 broadcasts)
    runs = common_runs({name: shape[0] if len(shape) == 1 else None
                        for name, shape in (("positions", p.shape[:-2]), ("beacon", b.shape[:-2]),
                                            ("sigma", np.shape(s_in)[:-1]), ("P0", P0_arr.shape[:-2]))},
                       broadcast_one=True)
    M = 1 if runs is None else runs
    if np.ndim(s_in) > 2:
        raise ValueError(f"sigma must be a number, shape ({K},) or (M, {K}); got shape {np.shape(s_in)}")
    R, measured = _pcrb_sigma(s_in, (M, K))
    dt = _pcrb_steps(times, K, current)
    Qk = _pcrb_process_noise(Q, n, K)

    # the models: the state from the blocks, the filters' range model; the bound is the general recursion's
    motion = _dead_reckoning_state(bias, current, dt, Qk)
    ranges = RangeToBeacon(b, R, state=motion.motion, bias="range_bias" if bias else None)
    truth = np.zeros((M, K, n))                # the range's H reads the position only (the bias adds a 1)
    truth[..., :2] = p
    bounds, undefined = _posterior_bounds(motion, ranges, truth[:, 0], P0_arr, truth, None, measured[..., None],
                                          bool(mean_over_runs))
    if undefined.any():
        j, k = (int(i) for i in np.argwhere(undefined[..., 0])[0])
        _warn(f"positions coincide with the beacon at {np.count_nonzero(undefined)} epoch(s) (the first: run {j}, "
              f"epoch {k}): the line of sight is undefined there, so those ranges add no information")
    out = bounds if full else bounds[..., :2, :2]
    return out if runs is not None and not mean_over_runs else out[0]


def _runs_axis(name: str, a: np.ndarray, single_ndim: int) -> int | None:
    return a.shape[0] if a.ndim == single_ndim + 1 else None


def _model_matrix(value: Any, M: int, shape: tuple[int, ...], what: str) -> np.ndarray:
    """A model's matrix: ``shape`` (shared by every run, kept so: one product, not M) or ``(M,) + shape``."""
    arr = np.asarray(value, dtype=float)
    if arr.shape == shape or arr.shape == (M,) + shape:
        return arr
    raise ValueError(f"{what} must have shape {shape} or {(M,) + shape}; got {arr.shape}")


def _measured_mask(measured: Any, M: int, K: int, m: int) -> np.ndarray:
    """``measured`` as a bool array (M, K, m): (K,), (K, m), (M, K) or (M, K, m); None: every component."""
    if measured is None:
        return np.ones((M, K, m), dtype=bool)
    arr = np.asarray(measured)
    if arr.dtype != bool:
        raise TypeError(f"measured must be a bool array, True where a measurement is present (e.g. "
                        f"np.isfinite(z)); got dtype {arr.dtype}")
    if arr.shape == (K,):
        out = arr[None, :, None]
    elif arr.shape == (K, m):
        out = arr[None]
    elif arr.ndim == 2 and arr.shape[1] == K:
        out = arr[:, :, None]
    elif arr.ndim == 3 and arr.shape[1:] == (K, m):
        out = arr
    else:
        raise ValueError(f"measured must have shape ({K},), ({K}, {m}), (M, {K}) or (M, {K}, {m}); got {arr.shape}")
    if out.shape[0] not in (1, M):
        raise ValueError(f"measured has {out.shape[0]} runs but the other inputs have {M}")
    return np.broadcast_to(out, (M, K, m))


def _inverse_or_none(F: np.ndarray) -> np.ndarray | None:
    """:math:`F^{-1}` (a stack of them), or None where ``F`` is singular."""
    try:
        F_inv = np.linalg.inv(F)
    except np.linalg.LinAlgError:
        return None
    return F_inv if np.isfinite(F_inv).all() else None


def _predicted_information(J: np.ndarray, F: np.ndarray, F_inv: np.ndarray | None, Q: np.ndarray,
                           k: int) -> np.ndarray:
    r""":math:`(Q + F J^{-1} F^T)^{-1}` for stacks (M, n, n), without inverting J when F is invertible (``F_inv``)."""
    if F_inv is not None:
        Jt = np.swapaxes(F_inv, -1, -2) @ J @ F_inv                              # F^-T J F^-1
        A = np.eye(J.shape[-1]) + Q @ Jt                                         # eigenvalues >= 1
        return np.swapaxes(np.linalg.solve(np.swapaxes(A, -1, -2), Jt), -1, -2)  # Jt (I + Q Jt)^-1
    P_pred = _sym(F @ _spd_inverse(J) @ np.swapaxes(F, -1, -2) + Q)               # a singular F: covariance form
    try:
        return _spd_inverse(P_pred)
    except np.linalg.LinAlgError:
        raise IllConditionedError(f"the predicted covariance F J^-1 F^T + Q is singular at step {k} (a singular "
                                  "F with a singular Q): the bound is infinite along some direction") from None


def _measurement_information(measurement: MeasurementModel, x_k: np.ndarray, k: int, present: np.ndarray, M: int,
                             m: int, n: int) -> tuple[np.ndarray | None, np.ndarray]:
    r""":math:`H_k^\mathsf{T} R_k^{-1} H_k` ``(M, n, n)`` of the components ``present`` (M, m) at the true ``x_k``
    (None: none), and which present components had an undefined Jacobian ``(M, m)`` (they add nothing)."""
    if not present.any():
        return None, np.zeros_like(present)
    _, H, defined = measurement.linearize(x_k, k)
    H = np.asarray(H, dtype=float)
    if H.shape != (M, m, n):
        raise ValueError(f"{type(measurement).__name__}'s H must have shape ({M}, {m}, {n}); got {H.shape}")
    d = np.asarray(defined, dtype=bool)
    d = np.broadcast_to(d[:, None], (M, m)) if d.shape == (M,) else d
    undefined = present & ~d
    present = present & d
    everywhere = bool(present.all())
    if not np.isfinite(H).all():
        bad = present & ~np.isfinite(H).all(axis=-1)
        if bad.any():
            raise ValueError(f"{type(measurement).__name__}.linearize returned a non-finite Jacobian at step {k} "
                             f"(run {int(np.argwhere(bad)[0][0])}) where a measurement is present")
    Hm = H if everywhere else np.where(present[:, :, None], H, 0.0)
    R = _model_matrix(measurement.R(x_k, k), M, (m, m), f"{type(measurement).__name__}.R")
    if m == 1:                          # one component (a range): H^T H / R, without a solve per run
        var = R[..., 0, 0]
        usable = np.isfinite(var) & (var > 0)
        if not (usable if var.ndim == 0 else usable | ~present[:, 0]).all():
            raise ValueError(f"{type(measurement).__name__}.R returned a variance that is not finite and > 0 at "
                             f"step {k} where a measurement is present")
        weight = 1.0 / var if var.ndim == 0 else np.divide(1.0, var, out=np.zeros(M), where=usable)[:, None, None]
        h = Hm[:, 0]
        return (h[:, :, None] * h[:, None, :]) * weight, undefined
    R = np.broadcast_to(R, (M, m, m))
    both = present[:, :, None] & present[:, None, :]
    if (both & ~np.isfinite(R)).any():
        raise ValueError(f"{type(measurement).__name__}.R returned a non-finite value at step {k} where a "
                         "measurement is present")
    Rm = np.where(both, R, np.eye(m))
    return np.swapaxes(Hm, -1, -2) @ np.linalg.solve(Rm, Hm), undefined           # H^T R^-1 H


def _posterior_bounds(motion: MotionModel, measurement: MeasurementModel, x0: np.ndarray, P0: np.ndarray,
                      truth: np.ndarray, u: np.ndarray | None, present: np.ndarray,
                      mean_over_runs: bool) -> tuple[np.ndarray, np.ndarray]:
    r"""The posterior information recursion (Tichavský et al. 1998, additive Gaussian noise), the one both bounds run.

    :math:`J_0 = P_0^{-1}`; step :math:`k` predicts, :math:`J \leftarrow (Q_k + F_k J^{-1} F_k^\mathsf{T})^{-1}`,
    with :math:`F_k` and :math:`Q_k` of ``motion`` at the true ``x_{k-1}`` (``x0`` ``(M, n)``, then ``truth``
    ``(M, K, n)``) and the input ``u`` ``(M, K, p)``; then adds the information of the components ``present``
    ``(M, K, m)``, :math:`H_k^\mathsf{T} R_k^{-1} H_k` at the true :math:`x_k` -- with ``mean_over_runs``, its mean
    over the runs (the expectation over the true states, evaluated on the M sampled tracks; :math:`F_k` and
    :math:`Q_k` must then be the same in every run). Returns the bounds :math:`J_k^{-1}` ``(M, K, n, n)`` (``(1, K,
    n, n)`` with ``mean_over_runs``) and where a present component's Jacobian was undefined ``(M, K, m)``.
    """
    M, K, n = truth.shape
    m = present.shape[-1]
    name = type(motion).__name__
    if mean_over_runs and P0.ndim == 3 and P0.shape[0] > 1:
        raise ValueError("mean_over_runs=True averages the measurement information over the runs: give one P0 of "
                         f"shape ({n}, {n}) for all of them")
    J = np.array(np.broadcast_to(_spd_inverse(P0), (1 if mean_over_runs else M, n, n)))
    information = np.empty((J.shape[0], K, n, n))
    undefined = np.zeros((M, K, m), dtype=bool)
    checked: dict[str, np.ndarray] = {}     # copies of the last F and Q checked: most models repeat them
    F_inv = None
    states = np.ascontiguousarray(np.swapaxes(truth, 0, 1))      # (K, M, n): each step's states contiguous
    for k in range(K):
        u_k = None if u is None else u[:, k]
        x_prev = x0 if k == 0 else states[k - 1]
        F = _model_matrix(motion.F(x_prev, u_k, k), M, (n, n), f"{name}.F")
        Q = _model_matrix(motion.Q(x_prev, u_k, k), M, (n, n), f"{name}.Q")
        for method, value in (("F", F), ("Q", Q)):
            last = checked.get(method)
            if last is not None and last.shape == value.shape and np.array_equal(last, value):
                continue
            if not np.isfinite(value).all():
                raise ValueError(f"{name}.{method} returned a non-finite value at step {k}")
            if mean_over_runs and value.ndim == 3 and not (value == value[:1]).all():
                raise ValueError(f"mean_over_runs=True averages the measurement information over the runs, which "
                                 f"needs one prediction for all of them; but {name}.{method} differs between the "
                                 f"runs' true states at step {k} (a nonlinear motion): leave mean_over_runs False "
                                 "for one bound per run")
            if method == "F":
                F_inv = _inverse_or_none(value[:1] if mean_over_runs and value.ndim == 3 else value)
            checked[method] = value.copy()          # a copy: a model may reuse its array for the next step
        if mean_over_runs:                                  # the same in every run (checked): one prediction
            F, Q = (a[:1] if a.ndim == 3 else a for a in (F, Q))
        J = _sym(_predicted_information(J, F, F_inv, Q, k))
        increment, undefined[:, k] = _measurement_information(measurement, states[k], k, present[:, k], M, m, n)
        if increment is not None:
            J = _sym(J + (increment.mean(axis=0, keepdims=True) if mean_over_runs else increment))
        information[:, k] = J
    return _sym(_spd_inverse(information)), undefined


def model_posterior_crlb(motion: Any, measurement: Any, x0: ArrayLike, P0: ArrayLike, truth: ArrayLike,
                         u: ArrayLike | None = None, *,
                         measured: ArrayLike | None = None, full: bool = False,
                         mean_over_runs: bool = False) -> NDArray[np.float64]:
    r"""The posterior Cramér–Rao bound of any motion/measurement model pair, along a given true track.

    For :math:`x_k = f(x_{k-1}, u_k) + w_k`, :math:`w_k \sim N(0, Q_k)`, and :math:`z_k = h_k(x_k) + v_k`,
    :math:`v_k \sim N(0, R_k)` -- the models of :mod:`uwtutor.models`, as the filters use them -- Tichavský,
    Muravchik and Nehorai (1998) bound the mean squared error of any estimator of :math:`x_k` by
    :math:`J_k^{-1}`, with the information recursion (their additive-Gaussian-noise form)

    .. math::

        J_0 = P_0^{-1}, \qquad
        J_k = \left(Q_k + F_k J_{k-1}^{-1} F_k^\mathsf{T}\right)^{-1} + H_k^\mathsf{T} R_k^{-1} H_k,

    with :math:`F_k = \partial f / \partial x` at the true :math:`x_{k-1}` (and the input :math:`u_k`),
    :math:`Q_k` and :math:`R_k` the models' noise there, and :math:`H_k = \partial h_k / \partial x` at the true
    :math:`x_k`. Components of :math:`z_k` that are not measured are skipped (:math:`H_k` and :math:`R_k`
    restricted to those measured, as the filters update); a step without any measurement only predicts. As in
    :func:`posterior_crlb` (its front end for dead reckoning with a range bias and a current), the expectation
    over the true states is evaluated on the one track given: a first-order approximation, good while the true
    track is known to a small fraction of the ranges; pass the sampled tracks of a Monte Carlo study (a runs
    axis) for one bound per track, or with ``mean_over_runs`` for the Monte Carlo evaluation of the expectation:

    .. math::

        \operatorname{E}\!\left[H_k^\mathsf{T} R_k^{-1} H_k\right] \approx
        \frac{1}{M} \sum_{j=1}^{M} H_k^\mathsf{T} R_k^{-1} H_k \Big|_{x_k = x_k^{(j)}},

    one bound from the M tracks (exact as M grows, for a motion whose :math:`F_k` and :math:`Q_k` do not depend
    on the state: a linear one).

    The recursion never inverts :math:`J`: with :math:`\tilde J = F_k^{-\mathsf{T}} J_{k-1} F_k^{-1}`,
    :math:`(Q_k + \tilde J^{-1})^{-1} = \tilde J (I + Q_k \tilde J)^{-1}`, which holds for a singular
    :math:`Q_k` (constant states: a range scale, a bias) and a nearly uninformative :math:`P_0`; a singular
    :math:`F_k` falls back to the covariance form.

    Parameters
    ----------
    motion : uwtutor.models.MotionModel
        :math:`F` and :math:`Q` (``f`` itself is not used: the true states are given).
    measurement : uwtutor.models.MeasurementModel
        :math:`H` (through ``linearize``) and :math:`R`.
    x0 : array_like, shape (n,) or (M, n)
        The true state before the first step (where :math:`F_0` is evaluated).
    P0 : array_like, shape (n, n) or (M, n, n)
        The prior covariance of ``x0`` (positive definite).
    truth : array_like, shape (K, n) or (M, K, n)
        The true states after each step, where :math:`H_k` is evaluated (the epochs of the filter's ``x``).
    u : array_like, shape (K, p) or (M, K, p), optional
        The inputs of the steps (e.g. the odometry), as the filter gets them.
    measured : array_like of bool, optional
        Where a measurement is present: ``(K,)`` per step, ``(K, m)`` per component, or with a runs axis
        ``(M, K)``, ``(M, K, m)``; e.g. ``np.isfinite(z)``. Default: every component at every step.
    full : bool, default False
        Return the bound of the whole state, not only of the position (the motion model's ``position`` slot
        when it has one, else ``x[..., :2]``).
    mean_over_runs : bool, default False
        With a runs axis (the sampled true tracks), average the measurement information over the runs and return
        one bound. ``P0`` must then be shared, and the motion's :math:`F_k` and :math:`Q_k` the same in every run.

    Returns
    -------
    ndarray, shape (K, 2, 2), or (K, n, n) with ``full``; a leading runs axis when an input had one (and
    ``mean_over_runs`` is False)
        The bound :math:`J_k^{-1}` after step :math:`k`'s measurement.

    Warns
    -----
    UnobservableWarning
        Where the model says its Jacobian is undefined for a measured component (a position on a beacon): that
        component adds no information.

    See Also
    --------
    posterior_crlb : the bound of dead reckoning with one range (and a bias, a current): a front end of this one.

    References
    ----------
    P. Tichavský, C. H. Muravchik and A. Nehorai, "Posterior Cramér–Rao bounds for discrete-time nonlinear
    filtering", IEEE Trans. Signal Process. 46(5), 1386–1396, 1998 (eqs. 21-22 and the additive Gaussian case).

    Examples
    --------
    Wheel odometry with a range scale, four beacons: the bound of the position and of the scale along a loop.

    >>> import numpy as np
    >>> from uwtutor.models import BeaconRanges, OdometryMotion
    >>> from uwtutor.observability import model_posterior_crlb, rmse_bound
    >>> motion = OdometryMotion(
    ...     sigma_distance=0.05, sigma_heading=0.01, scale=True
    ... )
    >>> ranges = BeaconRanges(
    ...     [[0.0, 0.0], [40.0, 0.0], [40.0, 30.0], [0.0, 30.0]],
    ...     R=0.1**2,
    ...     layout=motion.layout,
    ... )
    >>> # a circle of 100 m
    >>> u = np.tile([[1.0, 2 * np.pi / 100]], (100, 1))
    >>> x0 = np.array([20.0, 15.0 - 100 / (2 * np.pi), 0.0, 1.07])
    >>> truth = motion.integrate(x0, u)
    >>> bound = model_posterior_crlb(
    ...     motion, ranges, x0, np.diag([4.0, 4.0, 0.1, 0.01]), truth, u, full=True
    ... )
    >>> bound.shape
    (100, 4, 4)
    >>> print(
    ...     f"position {rmse_bound(bound[-1]):.2f} m, "
    ...     f"scale {np.sqrt(bound[-1, 3, 3]):.1e}"
    ... )
    position 0.07 m, scale 2.7e-04

    The expectation over the true tracks, evaluated on 50 sampled ones (dead reckoning is linear, so its
    prediction is the same for all of them): one bound.

    >>> from uwtutor.models import DeadReckoning, RangeToBeacon
    >>> rng = np.random.default_rng(0)
    >>> theta = np.linspace(0.0, np.pi, 60)
    >>> arc = 200.0 * np.column_stack([np.cos(theta), np.sin(theta)])
    >>> tracks = arc + np.cumsum(rng.normal(0.0, 0.5, (50, 60, 2)), axis=1)
    >>> mean = model_posterior_crlb(
    ...     DeadReckoning(0.25 * np.eye(2)),
    ...     RangeToBeacon((0.0, 0.0), R=4.0),
    ...     tracks[:, 0],
    ...     25.0 * np.eye(2),
    ...     tracks,
    ...     mean_over_runs=True,
    ... )
    >>> mean.shape, f"{rmse_bound(mean[-1]):.1f} m"
    ((60, 2, 2), '2.5 m')
    """
    if not isinstance(motion, MotionModel):
        raise TypeError(f"motion must be a uwtutor.models.MotionModel; got {type(motion).__name__}")
    if not isinstance(measurement, MeasurementModel):
        raise TypeError(f"measurement must be a uwtutor.models.MeasurementModel; got {type(measurement).__name__}")
    full = as_flag("full", full)
    mean_over_runs = as_flag("mean_over_runs", mean_over_runs)
    n, m = motion.n, measurement.m
    if measurement.n != n:
        raise ValueError(f"the measurement model reads a state of size {measurement.n} but the motion model's state "
                         f"has size {n}: build both for the same state")
    x0 = as_finite("x0", x0, ndim=(1, 2))
    truth = as_finite("truth", truth, ndim=(2, 3), nonempty=True)
    for name, a in (("x0", x0), ("truth", truth)):
        if a.shape[-1] != n:
            raise ValueError(f"{name} must have {n} entries per state (the models' state size); got shape {a.shape}")
    K = truth.shape[-2]
    P0 = as_covariance("P0", P0, n)
    if P0.ndim not in (2, 3):
        raise ValueError(f"P0 must have shape ({n}, {n}) or (M, {n}, {n}); got {P0.shape}")
    if u is not None:
        u = as_finite("u", u, ndim=(2, 3))
        if u.shape[-2] != K:
            raise ValueError(f"u must give one input per step ({K} steps, as truth); got shape {u.shape}")
    runs = common_runs({"x0": _runs_axis("x0", x0, 1), "truth": _runs_axis("truth", truth, 2),
                        "P0": _runs_axis("P0", P0, 2), "u": None if u is None else _runs_axis("u", u, 2),
                        "measured": np.shape(measured)[0] if measured is not None and np.ndim(measured) == 3
                        else None})
    M = 1 if runs is None else runs
    bounds, undefined = _posterior_bounds(motion, measurement, np.array(np.broadcast_to(x0, (M, n))), P0,
                                          np.broadcast_to(truth, (M, K, n)),
                                          None if u is None else np.broadcast_to(u, (M,) + u.shape[-2:]),
                                          _measured_mask(measured, M, K, m), mean_over_runs)
    if undefined.any():
        _warn(f"the Jacobian is undefined for {np.count_nonzero(undefined)} measured component(s) (a position on a "
              "beacon): those measurements add no information")
    # the position: the motion model's slot of that name when its state is built from blocks, else x[..., :2]
    pos = motion.slot("position") if isinstance(motion, BlockMotion) and "position" in motion.slots else np.arange(2)
    out = bounds if full else bounds[..., pos[:, None], pos]
    return out if runs is not None and not mean_over_runs else out[0]
