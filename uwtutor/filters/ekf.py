r"""The range-only extended Kalman filter for one beacon, batched over Monte Carlo runs.

The vehicle's horizontal position :math:`x_k = [x_k, y_k]^T` moves by the dead-reckoned (DR) displacement
:math:`u_k` between two ranging epochs and is observed through the horizontal range to a beacon at :math:`b`:

.. math::

    x_k = x_{k-1} + u_k + w_k, \quad w_k \sim N(0, Q), \qquad
    r_k = h(x_k) + v_k = \lVert x_k - b \rVert + v_k, \quad v_k \sim N(0, R).

The EKF linearizes :math:`h` at the prediction, :math:`H_k = (\hat x^-_k - b)^T / \lVert \hat x^-_k - b \rVert`
(the unit line-of-sight vector), and runs

.. math::

    \hat x^-_k = \hat x_{k-1} + u_k, \qquad P^-_k = P_{k-1} + Q,

    y_k = r_k - \lVert \hat x^-_k - b \rVert, \qquad S_k = H_k P^-_k H_k^T + R, \qquad K_k = P^-_k H_k^T / S_k,

    \hat x_k = \hat x^-_k + K_k y_k, \qquad P_k = (I - K_k H_k) P^-_k (I - K_k H_k)^T + K_k R K_k^T,

the covariance update in Joseph form. This is the plain EKF that papers A and D (Liu et al., "An improved EKF
positioning algorithm for underwater acoustic beacon"; Zhu et al. 2019) improve on, and the filter that filterpy's
``ExtendedKalmanFilter`` runs with :math:`F = I`.

This module is the *packed back-end* of the library's one extended Kalman filter: the engine
(:class:`~uwtutor.filters.engine.ExtendedKalmanFilter`) runs its loop and its steps whenever it is given this
model pair, ``DeadReckoning(Q)`` + ``RangeToBeacon(beacon, R)``, without a gate. Two forms name it:

* :func:`range_only_ekf` -- the functional form: a whole study of ``M`` runs of ``K`` steps in one call, a thin
  function over the engine;
* :class:`RangeOnlyEKF` -- the engine built from that pair, following the filter protocol of
  :mod:`uwtutor.filters.base` (``predict``, ``update``, ``x``, ``P``, ``y``, ``S``, ``run``), for teaching one step
  at a time.

.. rubric:: How it is made fast

The state is a 2-vector and the measurement a scalar, so every product is written out as 2x2 algebra on arrays
of length ``M`` (one entry per Monte Carlo run): about 60 array operations per step whatever ``M``. The filter
state of all runs lives in one ``(6, M)`` array (rows ``x, y, Pxx, Pxy, Pyx, Pyy``) and each step writes its
results straight into preallocated ``(K, 6, M)`` histories, which the result exposes as ``(M, K, 2)`` and
``(M, K, 2, 2)`` views without copying. Stacked ``@``/``einsum`` products are about five times slower for 2x2
matrices (a one-off measurement on the 2-core reference machine, 1000 runs x 1500 steps: about 0.5 s against
0.09 s; ``make bench`` does not repeat it), and a Python loop over runs (one filterpy filter per run) is several
hundred times slower (``make bench`` measures that one: "Speed-up over filterpy's EKF"). The tests of every
step -- a prediction on the beacon, a posterior that is not positive semi-definite -- are made on blocks of 32
steps at once, and a step that fails is done again with its own tests (the same numbers as step by step), so that
the study costs little more than the same arithmetic in plain numpy (``make bench``: "against the same EKF in
plain numpy").

.. rubric:: When the prediction sits on the beacon

At :math:`\hat x^-_k = b` the range is not differentiable and :math:`H_k` is undefined (0/0). The filter then
skips that run's update (the step is predict only, its innovation is NaN) and emits a
:class:`BeaconSingularityWarning`. A range of exactly zero from a prediction *near* the beacon is a normal update.

References
----------
Bar-Shalom, Y., Li, X. R. and Kirubarajan, T. (2001). *Estimation with Applications to Tracking and Navigation*.
Wiley. Sections 5.2 (Joseph form) and 10.3 (EKF).

Labbe, R. *FilterPy* (``filterpy.kalman.ExtendedKalmanFilter``) and *Kalman and Bayesian Filters in Python*,
chapter 11.
"""

from __future__ import annotations

import dataclasses
from typing import Any

from numpy.typing import ArrayLike

import numpy as np

from .._cancel import checkpoint
from .._validate import MAX_COORDINATE, as_finite, as_flag, as_range_array, common_runs, readonly
from ..errors import BeaconSingularityWarning
from ..models.dead_reckoning import DeadReckoning
from ..models.range import RangeToBeacon
from .base import FilterResult
from .engine import ExtendedKalmanFilter, extended_kalman_filter
from .gates import Gate
from ._packed import (N_ROWS, beacon_path, check_variances_where_measured, first_unsound, fixed_beacon,
                      initial_state, noise_parameters, predict_step, result_fields, runs_first, sequence_inputs,
                      steps_and_times, update_step)

__all__ = ["range_only_ekf", "RangeOnlyEKF", "BeaconSingularityWarning"]


# --- the engine shared by range_only_ekf and RangeOnlyEKF.run ----------------------------------------------------

#: Steps run before their posteriors are tested together (see ``_run``).
_BLOCK_STEPS = 32


def _run(s0: np.ndarray, u: np.ndarray, z: np.ndarray, q4: np.ndarray, R: Any,
         beacon: tuple[float, float] | np.ndarray, times: np.ndarray,
         batched: bool, keep_priors: bool = True) -> tuple[FilterResult, np.ndarray, np.ndarray]:
    """Run K steps from the packed states ``s0`` (6, M). ``u`` is (M, K, 2) or (K, 2); ``z`` (M, K) or (K,);
    ``q4`` (4, 1), or (K, 4, 1) one per step; ``R`` a float, or (K,) one per step (finite);
    ``beacon`` a fixed ``(bx, by)`` or a path of shape (K, 2, M) or (K, 2, 1), one position per step.

    Returns the result (shapes with or without the runs axis, as ``batched`` says), the last packed state and the
    last packed prediction. The engine (:class:`~uwtutor.filters.engine.ExtendedKalmanFilter`) runs this loop for the
    plain range-only pair.
    """
    M = s0.shape[1]
    K = len(times)
    # Step-major copies of the inputs so that every step reads contiguous memory.
    if u.ndim == 3:
        u_steps = np.ascontiguousarray(np.moveaxis(u, 0, -1))       # (K, 2, M)
    else:
        u_steps = u[:, :, None]                                       # (K, 2, 1): the same for every run
    z_fill = np.array(np.broadcast_to(z, (M, K)).T, order="C")     # (K, M), our own copy
    use = np.isfinite(z_fill).astype(float)                         # (K, M): 1.0 where a range is used
    z_fill[use == 0.0] = 0.0                                        # any finite value: the gain is 0 there

    prior = np.empty((K, N_ROWS, M))
    post = np.empty((K, N_ROWS, M))
    innov = np.empty((K, M))
    innov_var = np.empty((K, M))
    q_steps = q4.ndim == 3
    R_steps = isinstance(R, np.ndarray)
    if isinstance(beacon, tuple):                   # a fixed beacon (None at the origin: the update's shortcut)
        path = None
        at: tuple[float, float] | None = None if beacon == (0.0, 0.0) else beacon
    else:                                           # a path, one position per step
        path, at = beacon, None

    def steps(first: int, end: int, guard: bool) -> None:
        s = s0 if first == 0 else post[first - 1]
        for k in range(first, end):
            p, use_k = prior[k], use[k]
            predict_step(s, u_steps[k], q4[k] if q_steps else q4, p)
            s = post[k]
            applied = update_step(p, z_fill[k], use_k, float(R[k]) if R_steps else R,
                                  at if path is None else (path[k, 0], path[k, 1]), s, innov[k], innov_var[k],
                                  guard)
            if applied is not use_k:                # a prediction fell on the beacon
                use[k] = applied

    # Blocks of steps without the per-step tests (a prediction on the beacon, a posterior that is not PSD); the
    # posteriors of the block are then tested at once, and the steps from the first that fails are done again
    # with the tests, which is what a step-by-step run does there (the same numbers, warnings and errors): the
    # steps before it are the same arithmetic with tests that pass. A prediction on the beacon makes a NaN (0/0,
    # not reported in the block: the step done again warns) and so fails the test.
    for start in range(0, K, _BLOCK_STEPS):
        checkpoint()                                # a widget's refinement no longer wanted stops here
        end = min(start + _BLOCK_STEPS, K)
        with np.errstate(invalid="ignore", divide="ignore"):
            steps(start, end, guard=False)
        bad = first_unsound(post[start:end])
        if bad is not None:
            steps(start + bad, end, guard=True)
    unused = use == 0.0
    innov[unused] = np.nan
    innov_var[unused] = np.nan

    fields = result_fields(times, post, prior, innov, innov_var, batched, keep_priors)
    result = FilterResult(**fields, extras={"updated": runs_first(~unused.T, batched)})
    return result, post[-1].copy(), prior[-1].copy()



def range_only_ekf(x0: ArrayLike, P0: ArrayLike, u: ArrayLike, z: ArrayLike, Q: ArrayLike, R: ArrayLike,
                   beacon: ArrayLike = (0.0, 0.0), times: ArrayLike | None = None, *,
                   gate: Gate | None = None, keep_priors: bool = True) -> FilterResult:
    r"""Run the range-only EKF over whole range sequences, for one run or ``M`` Monte Carlo runs at once.

    Each step ``k`` predicts :math:`\hat x^-_k = \hat x_{k-1} + u_k`, :math:`P^-_k = P_{k-1} + Q_k` and, when the
    range ``z[..., k]`` is not NaN, updates with it (equations in the module docstring, Joseph-form covariance).
    A NaN range means "no reply at this epoch": that step is predict only. ``Q`` and ``R`` may change from step
    to step; a ``gate`` tests each range before it is used.

    Parameters
    ----------
    x0 : array_like, shape (2,) or (M, 2)
        Initial position estimate [m]; one shared by all runs, or one per run.
    P0 : array_like, shape (2, 2) or (M, 2, 2)
        Initial covariance (positive definite) [m^2].
    u : array_like, shape (K, 2) or (M, K, 2)
        Dead-reckoned displacement ``[dx, dy]`` from epoch ``k - 1`` to epoch ``k`` [m] (finite).
    z : array_like, shape (K,) or (M, K)
        Measured horizontal ranges [m]: finite and >= 0, or NaN where missing.
    Q : array_like, shape (2, 2) or (K, 2, 2)
        Process (DR) noise covariance per step, positive semi-definite [m^2]; or one per step.
    R : float or array_like, shape (1, 1) or (K,)
        Range noise variance, > 0 [m^2]; or one per step (NaN allowed at a step without a range).
    beacon : array_like, shape (2,), (K, 2) or (M, K, 2), optional
        Horizontal beacon position [m], the origin by default; or one position per epoch for a beacon that
        moves (a ship, a leader vehicle), shared by every run or one path per run.
    times : array_like, shape (K,), optional
        Epoch times for the result (default ``0..K-1``).
    gate : uwtutor.filters.Gate, optional
        An outlier test on each innovation (e.g. ``ChiSquareGate(0.99)``, or ``ReacquiringGate()``, which cannot
        lock out). The filter then runs on the generic engine (``uwtutor.filters.extended_kalman_filter``, the
        same arithmetic to rounding) and ``extras`` also holds the gate's per-step outputs.
    keep_priors : bool, default True
        False: the result's ``x_prior`` and ``P_prior`` are None (the other fields unchanged, bit for bit), for a
        study that needs only the estimates: they are almost half of the result's memory.

    Returns
    -------
    FilterResult
        With a runs axis ``M`` first if any input had one (the others are shared by all runs):
        ``x`` (M, K, 2), ``P`` (M, K, 2, 2), ``x_prior``, ``P_prior`` (the predictions), ``innovations``
        (M, K, 1) and ``innovation_cov`` (M, K, 1, 1) (NaN where no range was used), and
        ``extras["updated"]`` (M, K), True where the step used a range. Unbatched inputs give the same
        arrays without the runs axis. They are views into shared buffers (nothing is copied): copy one before
        changing it in place. With a ``gate``, ``extras["updated"]`` is False where the gate rejected the range.

    Raises
    ------
    ValueError
        On a wrong shape, a NaN or infinite ``x0``/``u``, a negative or infinite range, a ``Q`` that is not
        positive semi-definite or an ``R``/``P0`` that is not positive definite; the message names the argument.

    Warns
    -----
    BeaconSingularityWarning
        When a predicted position is exactly on the beacon (the update of that run is skipped).

    See Also
    --------
    RangeOnlyEKF : the same filter one step at a time.

    Notes
    -----
    The runs are independent: run ``m`` of a batched call equals a single-run call with ``x0[m]``, ``P0[m]``,
    ``u[m]`` and ``z[m]`` to rounding, and both equal filterpy's ``ExtendedKalmanFilter`` (with ``F = B = I``)
    stepped in a Python loop (checked in ``tests/test_ekf.py``).

    References
    ----------
    Bar-Shalom, Li and Kirubarajan (2001), sec. 5.2 and 10.3; filterpy ``ExtendedKalmanFilter`` (R. Labbe);
    Zhu et al. 2019 (paper D), the EKF baseline of its Fig. 5.

    Examples
    --------
    A vehicle circling a beacon at 300 m, 100 Monte Carlo runs of 500 epochs in one call:

    >>> import numpy as np
    >>> from uwtutor.filters import range_only_ekf
    >>> rng = np.random.default_rng(1)
    >>> M, K = 100, 500
    >>> theta = np.linspace(0.0, 4 * np.pi, K + 1)
    >>> track = 300.0 * np.column_stack([np.cos(theta), np.sin(theta)])
    >>> truth = track[1:]
    >>> # noisy dead reckoning
    >>> u = np.diff(track, axis=0) + rng.normal(0.0, 0.5, (M, K, 2))
    >>> # noisy ranges
    >>> z = np.linalg.norm(truth, axis=1) + rng.normal(0.0, 2.0, (M, K))
    >>> # some epochs without a reply
    >>> z[:, ::7] = np.nan
    >>> x0 = track[0] + rng.normal(0.0, 20.0, (M, 2))
    >>> res = range_only_ekf(
    ...     x0, np.eye(2) * 400.0, u, z, Q=np.eye(2) * 0.25, R=4.0
    ... )
    >>> res.x.shape, res.P.shape, res.innovations.shape
    ((100, 500, 2), (100, 500, 2, 2), (100, 500, 1))
    >>> bool(
    ...     np.sqrt(np.mean(np.sum((res.x[:, -1] - truth[-1]) ** 2, axis=-1)))
    ...     < 5.0
    ... )
    True
    """
    x0, P0, u, z, times, run_sizes = sequence_inputs(x0, P0, u, z, times)
    Q_arr, R_val, q4 = noise_parameters(Q, R, len(times))
    R_val = check_variances_where_measured(R_val, z)
    if gate is not None:
        return _gated(x0, P0, u, z, Q_arr, R_val, beacon, times, gate, keep_priors)
    b, run_sizes["beacon"] = beacon_path(beacon, len(times))
    M = common_runs(run_sizes)
    keep_priors = as_flag("keep_priors", keep_priors)
    # the engine on the plain range pair, which runs this module's loop (_run): the inputs are checked already, so the
    # loop is given them with the packed Q, R and beacon
    filt = ExtendedKalmanFilter(DeadReckoning(Q_arr), RangeToBeacon(beacon, R_val),
                                x0 if M is None else np.broadcast_to(x0, (M, 2)), P0)
    return _checked(filt._packed_steps(u, z, times, keep_priors, noise=(q4, R_val, b), key="updated"))


def _checked(result: FilterResult | None) -> FilterResult:
    """The packed loop's result (it always runs when given its parameters)."""
    assert result is not None
    return result


def _updated(result: FilterResult) -> FilterResult:
    """The engine's result with its ``accepted`` named ``updated``, as the range-only EKF has always called it."""
    extras = dict(result.extras)
    return dataclasses.replace(result, extras={"updated": extras.pop("accepted"), **extras})


def _gated(x0: np.ndarray, P0: np.ndarray, u: np.ndarray, z: np.ndarray, Q: np.ndarray, R: Any, beacon: Any,
           times: np.ndarray, gate: Any, keep_priors: bool) -> FilterResult:
    """The range-only EKF with a gate: the generic engine on DeadReckoning(Q) + RangeToBeacon(beacon, R), its
    ``accepted`` reported as ``updated`` (the key of the fast path)."""
    if not isinstance(gate, Gate):
        raise TypeError(f"gate must be a uwtutor.filters.Gate (e.g. ChiSquareGate(0.99)) or None; got "
                        f"{type(gate).__name__}")
    return _updated(extended_kalman_filter(DeadReckoning(Q), RangeToBeacon(beacon, R), x0, P0, u, z, times=times,
                                           gate=gate, keep_priors=keep_priors))


class RangeOnlyEKF(ExtendedKalmanFilter):
    r"""The range-only EKF as an object: ``predict(u)``, ``update(z)``, one step at a time.

    The engine (:class:`~uwtutor.filters.engine.ExtendedKalmanFilter`) built from the model pair
    ``DeadReckoning(Q)`` + ``RangeToBeacon(beacon, R)``, which it runs on its packed 2x2 back-end (this module's step
    functions): predict :math:`\hat x^- = \hat x + u`, :math:`P^- = P + Q`; update with the range
    :math:`r = \lVert x - b \rVert + v`, :math:`H = (\hat x^- - b)^T / \lVert \hat x^- - b \rVert`, Joseph form.
    Same model and same arithmetic as :func:`range_only_ekf`; what it adds to the engine is the range filter's
    argument checks, its parameters ``Q``, ``R`` and ``beacon`` (assignable) and the name ``updated`` (the engine's
    ``accepted``).

    Parameters
    ----------
    x0 : array_like, shape (2,) or (M, 2)
        Initial position estimate; a leading axis runs ``M`` filters at once.
    P0 : array_like, shape (2, 2) or (M, 2, 2)
        Initial covariance (positive definite).
    Q : array_like, shape (2, 2)
        Process noise covariance per step (positive semi-definite).
    R : float
        Range noise variance (> 0).
    beacon : array_like, shape (2,), optional
        Beacon position, the origin by default.

    Attributes
    ----------
    x : ndarray
        Current estimate, shape (2,) or (M, 2) (assignable).
    P : ndarray
        Current covariance, shape (2, 2) or (M, 2, 2) (assignable).
    x_prior : ndarray
        The prediction of the current step (a copy).
    P_prior : ndarray
        Its covariance (a copy).
    y : ndarray
        Innovation of the last update, shape (1,) or (M, 1) (NaN where no range was used).
    S : ndarray
        Its variance, shape (1, 1) or (M, 1, 1) (NaN where no range was used).
    updated : ndarray of bool
        Whether the last update used a range, shape () or (M,).
    Q, R, beacon
        The model parameters (read-only arrays). Assigning one takes effect from the next step: it is checked as
        in the constructor, ``ekf.Q = 100 * np.eye(2)`` runs exactly as ``RangeOnlyEKF(..., Q=100 * np.eye(2))``.
        ``y``, ``S`` and ``updated`` are read-only (what the last update computed).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.filters import RangeOnlyEKF
    >>> ekf = RangeOnlyEKF(
    ...     x0=[100.0, 10.0], P0=np.eye(2) * 100.0, Q=np.eye(2) * 0.1, R=4.0
    ... )
    >>> ekf.predict([0.0, 5.0])
    >>> ekf.x
    array([100.,  15.])
    >>> ekf.update(102.0)
    >>> bool(ekf.x[0] > 100.0), ekf.y.shape, ekf.S.shape
    (True, (1,), (1, 1))
    """

    extra_outputs = ("updated",)
    result_type = FilterResult
    _parameters = ("Q", "R", "beacon")
    _diagnostics: tuple[str, ...] = ("y", "S", "accepted", "updated")
    _engine_steps = True                # its steps are the engine's (on the packed back-end), after its own checks

    def __init__(self, x0: ArrayLike, P0: ArrayLike, Q: ArrayLike, R: ArrayLike,
                 beacon: ArrayLike = (0.0, 0.0)) -> None:
        x0, P0 = initial_state(x0, P0)
        Q_checked, R_checked, q4 = noise_parameters(Q, R)
        b = fixed_beacon(beacon)
        super().__init__(DeadReckoning(Q_checked), RangeToBeacon(b, R_checked), x0, P0)
        self._set_parameters(Q_checked, R_checked, q4, b)

    # -- configuration: assigned parameters take effect (base.Configurable) --
    def _set_parameters(self, Q: np.ndarray, R: float, q4: np.ndarray, beacon: tuple[float, float]) -> None:
        object.__setattr__(self, "Q", readonly(Q))
        object.__setattr__(self, "R", R)
        object.__setattr__(self, "beacon", readonly(np.array(beacon)))
        self._noise = (q4, R, beacon)                   # what the packed loop takes: computed again with Q, R, beacon

    def _apply(self, name: str, value: Any) -> None:
        """A new ``Q``, ``R`` or ``beacon``, checked as in the constructor: the model pair is built again with it and
        used from the next step on."""
        Q, R, beacon = self.Q, self.R, self._noise[2]
        if name == "beacon":
            beacon = fixed_beacon(value)
        Q, R, q4 = noise_parameters(value if name == "Q" else Q, value if name == "R" else R)
        self._use_models(DeadReckoning(Q), RangeToBeacon(beacon, R), name)
        self._set_parameters(Q, R, q4, beacon)

    @property
    def updated(self) -> np.ndarray:
        """Whether the last update used a range, shape () or (M,) (the engine's ``accepted``)."""
        return self._out(self._accepted)

    def _bad_shape(self, name: str, shape: tuple[int, ...], single: str) -> np.ndarray:
        raise ValueError(f"{name} must have shape {single} or (M, ...) with M = {self._M}; got {shape}")

    # -- the protocol: the range filter's checks, then the engine's step --
    def predict(self, u: ArrayLike | None = None) -> None:
        """Move the estimate by the DR displacement ``u`` (shape (2,) or (M, 2); ``None``: no move), ``P += Q``."""
        if u is not None:
            u = as_finite("u", u, max_abs=MAX_COORDINATE)
            if u.shape != (2,) and not (self._batched and u.shape == (self._M, 2)):
                self._bad_shape("u", u.shape, "(2,)")
        super().predict(u)

    def update(self, z: ArrayLike) -> None:
        """Correct the estimate with the range ``z`` (scalar, or shape (M,) when batched; NaN: no update)."""
        z = as_range_array("z", z, allow_nan=True, max_abs=MAX_COORDINATE)
        if not (z.size == 1 and z.ndim <= 1) and (z.shape != (self._M,) or not self._batched):
            self._bad_shape("z", z.shape, "() (a scalar)")
        super().update(z)

    def run(self, z: ArrayLike, u: ArrayLike | None = None, times: ArrayLike | None = None, *,
            keep_priors: bool = True) -> FilterResult:
        """Predict with ``u[..., k, :]`` then update with ``z[..., k]`` for every step; return the history.

        ``z`` has shape (K,) or, for a batched filter, (M, K) (NaN: predict only); ``u`` has shape (K, 2)
        or (M, K, 2) (``None``: no displacement). The filter is left at the last step. Uses the same loop
        as :func:`range_only_ekf`, so the result is identical to calling it with this filter's state.
        """
        z = as_range_array("z", z, allow_nan=True, ndim=(2 if self._batched else 1, 1), max_abs=MAX_COORDINATE)
        if z.ndim == 2 and z.shape[0] != self._M:
            self._bad_shape("z", z.shape, "(K,)")
        K = z.shape[-1]
        if u is None:
            u = np.zeros((K, 2))
        u = as_finite("u", u, ndim=(3 if self._batched else 2, 2))
        if u.shape[-2:] != (K, 2) or (u.ndim == 3 and u.shape[0] != self._M):
            self._bad_shape("u", u.shape, f"({K}, 2), one input per step of z")
        times = steps_and_times(K, times)
        return _checked(self._packed_steps(u, z, times, as_flag("keep_priors", keep_priors), noise=self._noise,
                                           key="updated"))
