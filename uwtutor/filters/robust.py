r"""Outlier-robust Kalman filters (paper E): the range filter, the cascade filter on fixes, and their gates.

Acoustic ranges carry **outliers**, isolated or in patches (multipath, a lost direct path), tens of metres off.
Paper E filters the range sequence to the mother ship with a Kalman filter and tests every range before using it;
a rejected range is replaced by an extrapolation. After the least-squares fixes it filters once more (the
*cascade* filter) with the same test.

Both filters are the generic engine (``uwtutor.filters.ExtendedKalmanFilter``) on a constant-velocity model
(:mod:`uwtutor.models.robust`) with a gate (``uwtutor.filters.gates``):

===============================  ==================================================================================
``SecondMomentGate(delta)``      paper E's test :math:`H_0`: :math:`z z^T \in [D(1-\delta), D(1+\delta)]`,
                                 :math:`D = S + \hat z \hat z^T` (eqs. 10-11)
``ChiSquareGate(p)``             the classic test on the NIS :math:`y^T S^{-1} y \le \chi^2_m(p)`
``RobustGate(test, ...)``        a test plus what to do with a rejected measurement (paper E's linear extrapolation,
                                 eq. 12, or the prediction) and, optionally, **re-acquisition** after a lock-out
``robust_range_kf``              the range filter with paper E's defaults (q = r = 2, :math:`\delta` = 0.03)
``cascade_kf``                   the same filter on 2-D position fixes
``moment_gate_interval``         the innovations paper E's test accepts, in closed form
===============================  ==================================================================================

**What paper E's test is.** For a scalar range with prediction :math:`\hat z` and innovation covariance
:math:`S`, :math:`D = S + \hat z^2` and the test accepts :math:`z` when
:math:`\sqrt{(1-\delta)D} \le z \le \sqrt{(1+\delta)D}`. With :math:`S \ll \hat z^2` and :math:`z = \hat z + y`,

.. math::

    |y| \lesssim \frac{\delta}{2}\,\hat z :

a gate of about :math:`\delta/2` of the range, 22.5 m at 1.5 km for :math:`\delta = 0.03`, whatever the filter's
uncertainty. The chi-square gate's width, :math:`\sqrt{\chi^2_1(p)\,S}`, follows the uncertainty instead and
ignores the range. (For an ``m``-vector the test compares :math:`z^T z` with :math:`\operatorname{tr} D`; it then
depends on where the origin of the coordinates is, which is why the cascade filter uses the chi-square gate by
default.)

**Lock-out.** Every gate fails the same way: while a patch of outliers is rejected the filter runs on its
prediction; if the prediction drifts out of the gate before the patch ends, the good ranges that follow are
rejected too, for ever. ``RobustGate(reacquire=n)`` watches for that: after ``n`` consecutive rejections it fits
a straight line to the ``n`` rejected measurements, and if they lie on it (their residuals pass a chi-square test
at ``1 - 1e-3``) it restarts the state from that line. A patch of consistent outliers longer than ``n`` would be
taken for the truth, so ``n`` must exceed the longest such patch one wants to reject; each recovery costs ``n``
epochs.

References
----------
Paper E (VMLBL for the manned submersible *Jiaolong*), sec. 1.1, eqs. (1)-(12), and sec. 1.3.
Bar-Shalom, Y., Li, X. R. and Kirubarajan, T. (2001). *Estimation with Applications to Tracking and Navigation*.
Wiley. Section 5.4 (gating).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validate import (MAX_COORDINATE, as_bool_array, as_covariance, as_finite, as_float_array, as_int,
                        as_nonnegative, as_positive, as_range_array, as_scalar)
from ..errors import UwtutorWarning, warn
from ..models.robust import ConstantVelocity, PositionMeasurement, step_lengths
from .base import FilterResult
from .engine import ExtendedKalmanFilter
from .gates import ChiSquareGate, Gate, GateContext

__all__ = [
    "SecondMomentGate",
    "RobustGate",
    "moment_gate_interval",
    "make_test",
    "robust_track_kf",
    "robust_range_kf",
    "cascade_kf",
]

#: The tests ``robust_range_kf`` and ``cascade_kf`` know by name.
TESTS = ("paper", "chi2", "none")
#: Fraction of rejected measurements above which robust_track_kf warns that the filter is locked out.
REJECTION_WARNING = 0.5
#: What a rejected measurement is replaced by.
ON_OUTLIER = ("predict", "extrapolate")


class SecondMomentGate(Gate):
    r"""Paper E's outlier test :math:`H_0` (eqs. 10-11): the measurement's second moment against its prediction.

    With the prediction :math:`\hat z = H\hat x^-` and :math:`S = H P^- H^T + R`, the expected second moment of
    the measurement is :math:`D = S + \hat z \hat z^T`; the measurement is accepted (no outlier) when

    .. math::

        (1 - \delta)\,\operatorname{tr} D \;\le\; z^T z \;\le\; (1 + \delta)\,\operatorname{tr} D,

    which for a scalar range is paper E's :math:`z z^T \in [D(1-\delta), D(1+\delta)]`.
    (:func:`moment_gate_interval` gives the accepted innovations.)

    Parameters
    ----------
    delta : float, default 0.03
        The tolerance :math:`\delta`, in (0, 1) (paper E: 0.03).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.filters import GateContext
    >>> from uwtutor.filters.robust import SecondMomentGate
    >>> z = np.array([[1510.0], [1530.0]])
    >>> zp = np.full((2, 1), 1500.0)
    >>> S = np.full((2, 1, 1), 4.0)
    >>> ctx = GateContext(
    ...     k=0,
    ...     z=z,
    ...     z_pred=zp,
    ...     y=z - zp,
    ...     S=S,
    ...     H=np.ones((2, 1, 2)),
    ...     R=np.eye(1),
    ...     x_prior=np.zeros((2, 2)),
    ...     P_prior=np.tile(np.eye(2), (2, 1, 1)),
    ... )
    >>> # 10 m in, 30 m out (the gate is about 22.5 m)
    >>> SecondMomentGate(0.03).accept(ctx)
    array([ True, False])
    """

    def __init__(self, delta: Any = 0.03) -> None:
        d = as_scalar("delta", delta)
        if not 0.0 < d < 1.0:
            raise ValueError(f"delta must lie strictly between 0 and 1 (paper E uses 0.03); got {d:g}")
        self.delta = d

    def accept(self, ctx: GateContext) -> np.ndarray:
        present = ctx.present
        if present is None or present.all():
            zz = np.sum(ctx.z**2, axis=-1)
            D = np.trace(ctx.S, axis1=-2, axis2=-1) + np.sum(ctx.z_pred**2, axis=-1)
        else:                                      # the components present (a run with none is rejected)
            zz = np.where(present.any(axis=-1), np.sum(np.where(present, ctx.z, 0.0) ** 2, axis=-1), np.nan)
            D = (np.sum(np.where(present, np.diagonal(ctx.S, axis1=-2, axis2=-1), 0.0), axis=-1)
                 + np.sum(np.where(present, ctx.z_pred, 0.0) ** 2, axis=-1))
        with np.errstate(invalid="ignore"):
            return (zz >= (1.0 - self.delta) * D) & (zz <= (1.0 + self.delta) * D)


def moment_gate_interval(z_pred: ArrayLike, S: ArrayLike,
                         delta: Any = 0.03) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    r"""The innovations :math:`y = z - \hat z` that paper E's test accepts for a scalar measurement :math:`z > 0`.

    .. math::

        \sqrt{(1-\delta)(S + \hat z^2)} - \hat z \;\le\; y \;\le\; \sqrt{(1+\delta)(S + \hat z^2)} - \hat z,
        \qquad \text{about } \pm\frac{\delta}{2}\hat z \text{ when } S \ll \hat z^2 .

    Parameters
    ----------
    z_pred : array_like
        Predicted measurement :math:`\hat z` [m], > 0.
    S : array_like
        Innovation variance [m²], >= 0 (broadcast against ``z_pred``).
    delta : float, default 0.03
        Paper E's tolerance.

    Returns
    -------
    lower, upper : ndarray
        The accepted interval of the innovation [m].

    Examples
    --------
    >>> from uwtutor.filters.robust import moment_gate_interval
    >>> lo, hi = moment_gate_interval(1500.0, 4.0)
    >>> round(float(lo), 2), round(float(hi), 2)
    (-22.67, 22.34)
    """
    zp = as_positive("z_pred", z_pred, max_abs=MAX_COORDINATE)
    S = as_float_array("S", S)
    if not np.all(np.isfinite(S)) or np.any(S < 0):
        raise ValueError("S must be finite and >= 0 (an innovation variance)")
    d = SecondMomentGate(delta).delta
    D = S + zp**2
    return np.sqrt((1.0 - d) * D) - zp, np.sqrt((1.0 + d) * D) - zp


def make_test(test: Any, *, delta: Any = 0.03, probability: Any = 0.99) -> Gate | None:
    """The gate named by ``test``: ``"paper"`` (``SecondMomentGate(delta)``), ``"chi2"``
    (``ChiSquareGate(probability)``), ``"none"`` (None: every measurement used), or a ``Gate`` itself.

    ``delta`` and ``probability`` are checked whichever test uses them, so that a bad value is never silently
    ignored (``make_test("chi2", delta=nan)`` is refused).

    Examples
    --------
    >>> from uwtutor.filters.robust import make_test
    >>> type(make_test("paper", delta=0.03)).__name__
    'SecondMomentGate'
    >>> gate = make_test("chi2", probability=0.99)
    >>> type(gate).__name__, round(gate.threshold(1), 3)
    ('ChiSquareGate', 6.635)
    >>> make_test("none") is None
    True
    """
    paper, chi2 = SecondMomentGate(delta), ChiSquareGate(probability)      # both checked, whichever is used
    if isinstance(test, Gate):
        return test
    if not isinstance(test, str) or test not in TESTS:
        raise ValueError(f"test must be one of {list(TESTS)} or a uwtutor.filters.Gate; got {test!r}")
    return {"paper": paper, "chi2": chi2, "none": None}[test]


class RobustGate(Gate):
    r"""An outlier test plus what to do with what it rejects, for a constant-velocity state :math:`[p, v]`.

    A rejected measurement leaves the run at its prediction (``on_outlier="predict"``; for a constant-velocity
    state that *is* a linear extrapolation at the estimated rate) or, with ``on_outlier="extrapolate"``, at paper
    E's eq. (12), :math:`\hat x_k = 2\hat x_{k-1} - \hat x_{k-2}` (the whole state extrapolated from the last two
    estimates; the covariance stays the prediction's). With ``reacquire=n``, after ``n`` consecutive rejections the
    ``n`` rejected measurements are fitted with a straight line in time,
    :math:`z_j \approx a + b\,(t_j - t_k)`; if :math:`\sum_j \lVert z_j - a - b (t_j - t_k)\rVert^2_{R^{-1}} \le
    \chi^2_{d(n-2)}(1 - 10^{-3})` the run restarts from :math:`\hat x_k = [a, b]` with the least-squares
    covariance of the fit, and those ``n`` measurements are classed as good after all.

    The gate keeps per-run memory; it is reset at step 0, so one object can serve one run of a filter at a time.

    Parameters
    ----------
    test : Gate or None
        The accept/reject rule (e.g. ``SecondMomentGate``, ``ChiSquareGate``); None accepts everything.
    steps : array_like, shape (K,)
        The step lengths of the run (``models.robust.step_lengths``), to know the epochs' times.
    on_outlier : {"predict", "extrapolate"}, default "predict"
        What a rejected run's estimate becomes.
    reacquire : int or None, default None
        ``n`` >= 3 for re-acquisition after ``n`` consecutive rejections; None: never (a lock-out is permanent).

    Attributes
    ----------
    rejected : list of ndarray
        Per step, bool ``(M,)``: the test rejected the measurement.
    reacquired : list of ndarray
        Per step, bool ``(M,)``: the run was restarted.
    cleared : list of tuple
        The ``(run, step)`` pairs of rejected measurements reclassified as good by a re-acquisition.

    Examples
    --------
    Paper E's test on a range track with a spike at step 3: rejected, and predicted through:

    >>> import numpy as np
    >>> from uwtutor.filters import extended_kalman_filter
    >>> from uwtutor.filters.robust import RobustGate, SecondMomentGate
    >>> from uwtutor.models import ConstantVelocity, PositionMeasurement
    >>> from uwtutor.models.robust import step_lengths
    >>> steps = step_lengths(6)
    >>> gate = RobustGate(SecondMomentGate(0.03), steps)
    >>> z = np.array([1000.0, 999.0, 998.1, 1150.0, 996.0, 995.1])
    >>> res = extended_kalman_filter(
    ...     ConstantVelocity(1, 0.01, steps),
    ...     PositionMeasurement(1, 2.0),
    ...     [1000.0, -1.0],
    ...     np.diag([2.0, 1.0]),
    ...     None,
    ...     z,
    ...     gate=gate,
    ... )
    >>> res.extras["accepted"].tolist()
    [True, True, True, False, True, True]
    >>> # the spike's step: the prediction [m]
    >>> round(float(res.x[3, 0]), 1)
    997.1
    """

    estimates_checked = True      # the engine's own estimate, extrapolated or restarted from a fit

    def __init__(self, test: Gate | None, steps: ArrayLike, *, on_outlier: str = "predict",
                 reacquire: int | None = None) -> None:
        if test is not None and not isinstance(test, Gate):
            raise TypeError(f"test must be a uwtutor.filters.Gate or None; got {type(test).__name__}")
        if on_outlier not in ON_OUTLIER:
            raise ValueError(f"on_outlier must be one of {ON_OUTLIER}; got {on_outlier!r}")
        if reacquire is not None:
            reacquire = as_int("reacquire", reacquire, minimum=3)
        self.test, self.on_outlier, self.reacquire = test, on_outlier, reacquire
        # step lengths (models.robust.step_lengths): finite, >= 0, one per epoch
        self.times = np.cumsum(as_nonnegative("steps", steps, ndim=1, nonempty=True, max_abs=MAX_COORDINATE))
        self.rejected: list[np.ndarray] = []
        self.reacquired: list[np.ndarray] = []
        self.cleared: list[tuple[int, int]] = []

    def _reset(self, M: int, d: int) -> None:
        n = self.reacquire or 1
        self.rejected, self.reacquired, self.cleared = [], [], []
        self._x1 = self._x2 = None
        self._count = np.zeros(M, dtype=int)
        self._zbuf = np.zeros((M, n, d))
        self._kbuf = np.zeros((M, n), dtype=int)

    def accept(self, ctx: GateContext) -> np.ndarray:
        M, d = ctx.z.shape
        if ctx.k == 0 or not hasattr(self, "_count") or self._count.shape[0] != M:
            self._reset(M, d)
        has = np.isfinite(ctx.z).all(axis=-1)
        verdict = (np.ones(M, dtype=bool) if self.test is None else
                   as_bool_array(f"the gate {type(self.test).__name__}.accept", self.test.accept(ctx), ((M,),)))
        self._pending = (ctx.k, has & ~verdict, np.array(ctx.z), np.asarray(ctx.R))
        return verdict

    def after_update(self, x: np.ndarray, P: np.ndarray, accepted: np.ndarray,
                     k: int) -> tuple[np.ndarray, np.ndarray]:
        _, rejected, z, R = self._pending
        M, n_state = x.shape
        d = z.shape[1]
        x, P = x.copy(), P.copy()
        if self.on_outlier == "extrapolate" and self._x2 is not None and rejected.any():
            x[rejected] = 2.0 * self._x1[rejected] - self._x2[rejected]
        reacq = np.zeros(M, dtype=bool)
        if self.reacquire is not None:
            n = self.reacquire
            self._count[accepted] = 0
            rows = np.flatnonzero(rejected)
            slot = self._count[rows] % n
            self._zbuf[rows, slot] = z[rows]
            self._kbuf[rows, slot] = k
            self._count[rows] += 1
            due = rows[self._count[rows] >= n]              # only runs whose measurement was just rejected
            if due.size:
                ok, x_fit, P_fit = self._refit(due, R, k, n, d, n_state)
                good = due[ok]
                reacq[good] = True
                x[good], P[good] = x_fit[ok], P_fit[ok]
                for run in good:
                    self.cleared.extend((int(run), int(j)) for j in self._kbuf[run])
                self._count[good] = 0
        self.rejected.append(rejected)
        self.reacquired.append(reacq)
        self._x2, self._x1 = self._x1, x.copy()
        return x, P

    def _refit(self, runs: np.ndarray, R: np.ndarray, k: int, n: int, d: int,
               n_state: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Line fits through the buffered measurements of ``runs``: (ok, x, P) for those runs."""
        if n_state != 2 * d:
            raise ValueError("RobustGate's re-acquisition (a line fit through the rejected measurements) needs a "
                             "constant-velocity state [position, velocity] whose position is measured: a state of "
                             f"size {2 * d} for measurements of size {d}; got {n_state}. For any other state use "
                             "uwtutor.filters.ReacquiringGate (covariance inflation after repeated rejections)")
        t = self.times[self._kbuf[runs]] - self.times[k]                     # (m, n)
        A = np.stack([np.ones_like(t), t], axis=-1)                          # (m, n, 2)
        G = np.swapaxes(A, -1, -2) @ A                                       # (m, 2, 2)
        coef = np.linalg.solve(G, np.swapaxes(A, -1, -2) @ self._zbuf[runs])  # (m, 2, d)
        res = self._zbuf[runs] - A @ coef
        Rm = np.broadcast_to(R, (len(R) if R.ndim == 3 else 1, d, d))
        var = np.diagonal(Rm, axis1=-2, axis2=-1)
        var = var[runs] if var.shape[0] > 1 else np.broadcast_to(var, (len(runs), d))
        chi = np.sum(res**2 / var[:, None, :], axis=(1, 2))
        from scipy import stats          # imported where used: scipy.stats costs about 1 s of CPU to import
        ok = chi <= stats.chi2.ppf(1.0 - 1e-3, d * (n - 2))
        x_new = coef.reshape(len(runs), 2 * d)                               # [a (d), b (d)]
        C = np.linalg.inv(G)
        P_new = np.einsum("mij,ma,ab->miajb", C, var, np.eye(d)).reshape(len(runs), 2 * d, 2 * d)
        P_new = 0.5 * (P_new + np.swapaxes(P_new, -1, -2))
        return ok, x_new, P_new


def _initial_state(z: np.ndarray, var: np.ndarray, rate_sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """x0 = [first finite measurement of each run, zero rate], P0 = diag(var, rate_sigma²)."""
    M, K, d = z.shape
    finite = np.isfinite(z).all(axis=-1)
    if not finite.any(axis=1).all():
        bad = int(np.flatnonzero(~finite.any(axis=1))[0])
        raise ValueError(f"run {bad} has no finite measurement at all: nothing to start the filter from")
    first = np.argmax(finite, axis=1)
    x0 = np.concatenate([z[np.arange(M), first], np.zeros((M, d))], axis=-1)
    P0 = np.zeros((M, 2 * d, 2 * d))
    idx = np.arange(d)
    P0[:, idx, idx] = var
    P0[:, d + idx, d + idx] = rate_sigma**2
    return x0, P0


def robust_track_kf(z: ArrayLike, dt: Any = 1.0, *, q: Any, r: ArrayLike, test: Any = "paper", delta: Any = 0.03,
                    probability: Any = 0.99, on_outlier: str = "predict", reacquire: int | None = None,
                    times: ArrayLike | None = None, x0: ArrayLike | None = None, P0: ArrayLike | None = None,
                    initial_rate_sigma: Any = 5.0) -> FilterResult:
    r"""A constant-velocity Kalman filter on a sequence of ``d``-vectors, with an outlier test (paper E).

    The state is :math:`[p, v]` (``models.robust.ConstantVelocity`` with acceleration variance ``q``), the
    measurement its position part with covariance ``r``; each measurement passes the ``test`` first (see
    :class:`RobustGate` for what happens to a rejected one). ``robust_range_kf`` (d = 1) and ``cascade_kf``
    (d = 2) are this function with paper E's settings.

    Parameters
    ----------
    z : array_like, shape (K, d) or (M, K, d)
        The measurements, NaN where missing (predict only).
    dt : float, default 1
        Time between epochs [s] (ignored when ``times`` is given).
    q : float
        Acceleration variance [(units/s²)²].
    r : float or array_like
        Measurement noise covariance: a variance (every component), ``(d, d)``, ``(K, d, d)`` or
        ``(M, K, d, d)``.
    test : {"paper", "chi2", "none"} or Gate, default "paper"
        The outlier test (``make_test``).
    delta, probability : float
        Parameters of the paper's test and of the chi-square gate.
    on_outlier : {"predict", "extrapolate"}, default "predict"
        See :class:`RobustGate`.
    reacquire : int or None, default None
        Re-acquisition after that many consecutive rejections (see :class:`RobustGate`).
    times : array_like, shape (K,), optional
        Epoch times [s], strictly increasing.
    x0, P0 : array_like, optional
        Initial state ``(2d,)``/``(M, 2d)`` and covariance; default: the first finite measurement, zero rate,
        covariance ``diag(r, initial_rate_sigma²)``.
    initial_rate_sigma : float, default 5
        Standard deviation of the initial rate [units/s] for the default ``P0``.

    Returns
    -------
    FilterResult
        The engine's result with, in ``extras`` (each ``(K,)`` or ``(M, K)``): ``"accepted"`` (measurement used),
        ``"rejected"`` (the test said no), ``"outlier"`` (rejected and not reclassified as good by a
        re-acquisition) and ``"reacquired"`` (the state was restarted at that step).

    Examples
    --------
    A range that closes at 1.2 m/s with one wild value at step 5:

    >>> import numpy as np
    >>> from uwtutor.filters.robust import robust_track_kf
    >>> t = np.arange(10.0)
    >>> z = 1800.0 - 1.2 * t
    >>> z[5] += 80.0
    >>> res = robust_track_kf(z[:, None], 1.0, q=0.01, r=2.0)
    >>> np.flatnonzero(res.extras["outlier"]).tolist()
    [5]
    >>> # the estimated range rate [m/s]
    >>> round(float(res.x[-1, 1]), 1)
    -1.2
    """
    zz = as_float_array("z", z, ndim=(2, 3), nonempty=True)
    if times is not None and np.size(times) != zz.shape[-2]:
        raise ValueError(f"times must have one entry per epoch of z ({zz.shape[-2]}, its axis -2); got "
                         f"{np.size(times)}")
    if np.isinf(zz).any():
        raise ValueError("z must be finite, or NaN for a missing measurement; got an infinite value")
    if (np.abs(zz) > MAX_COORDINATE).any():
        raise ValueError(f"z must be at most {MAX_COORDINATE:.0e} in magnitude (its square overflows float64 beyond "
                         "it); change its units")
    batched = zz.ndim == 3
    zb = zz if batched else zz[None]
    M, K, d = zb.shape
    steps = step_lengths(K, dt, times)
    R = as_float_array("r", r)
    if R.ndim == 0:
        R = float(as_positive("r", R)) * np.eye(d)
    measurement = PositionMeasurement(d, R)
    if measurement.n_runs is not None and measurement.n_runs != M:
        raise ValueError(f"r has {measurement.n_runs} runs but z has {M}")
    motion = ConstantVelocity(d, q, steps)
    Rk = np.asarray(measurement.R(None, 0))
    var0 = np.diagonal(Rk, axis1=-2, axis2=-1)
    # its square is a variance of P0: within [1e-150, 1e150]
    rate = as_scalar("initial_rate_sigma", initial_rate_sigma, domain="positive", low=1e-75, high=1e75)
    x_init, P_init = _initial_state(zb, var0, rate)
    if x0 is not None:
        x0 = as_finite("x0", x0, max_abs=MAX_COORDINATE)
        if x0.shape not in ((2 * d,), (M, 2 * d)):
            raise ValueError(f"x0 must have shape ({2 * d},) or ({M}, {2 * d}) (positions, then rates); got {x0.shape}")
        x_init = np.broadcast_to(x0, (M, 2 * d))
    if P0 is not None:
        P0 = as_covariance("P0", P0, 2 * d)
        if P0.shape not in ((2 * d, 2 * d), (M, 2 * d, 2 * d)):
            raise ValueError(f"P0 must have shape ({2 * d}, {2 * d}) or ({M}, {2 * d}, {2 * d}); got {P0.shape}")
        P_init = np.broadcast_to(P0, (M, 2 * d, 2 * d))
    gate = make_test(test, delta=delta, probability=probability)
    robust = RobustGate(gate, steps, on_outlier=on_outlier, reacquire=reacquire)
    filt = ExtendedKalmanFilter(motion, measurement, x_init, P_init, gate=robust)
    res = filt.run(zb, times=np.cumsum(steps) if times is None else times)
    rejected = np.stack(robust.rejected, axis=1)
    outlier = rejected.copy()
    for run, step in robust.cleared:
        outlier[run, step] = False
    present = np.isfinite(zb).all(axis=-1)
    n_present, n_out = int(present.sum()), int((outlier & present).sum())
    if n_present and n_out > REJECTION_WARNING * n_present:
        warn(f"the outlier test rejected {n_out} of {n_present} measurements: the filter is locked out, not "
             "filtering. Its noise (q, r) is probably far too small for the data (q=0 or r near 0 makes every "
             "new measurement an outlier); check q, r and the test's delta/probability", UwtutorWarning)
    extras = dict(res.extras, rejected=rejected, outlier=outlier, reacquired=np.stack(robust.reacquired, axis=1))
    fields = {f.name: getattr(res, f.name) for f in dataclasses.fields(res) if f.name not in ("times", "extras")}
    if not batched:
        fields = {name: a[0] for name, a in fields.items()}
        extras = {name: a[0] for name, a in extras.items()}
    return FilterResult(times=res.times, extras=extras, **fields)


def robust_range_kf(ranges: ArrayLike, dt: Any = 1.0, *, q: Any = 2.0, r: Any = 2.0, delta: Any = 0.03,
                    test: Any = "paper", times: ArrayLike | None = None, probability: Any = 0.99,
                    on_outlier: str = "predict", reacquire: int | None = 20) -> FilterResult:
    r"""Paper E's range preprocessing: a Kalman filter on the range sequence that rejects outliers (sec. 1.1).

    State :math:`[r_k, \dot r_k]`, constant velocity with acceleration variance ``q``, ranges of variance ``r``
    (paper E: both 2); each range passes paper E's test :math:`H_0`
    (:math:`z^2 \in [D(1-\delta), D(1+\delta)]`, :class:`SecondMomentGate`) or, with ``test="chi2"``, the NIS gate.
    A rejected range leaves the filter at its prediction, a linear extrapolation at the estimated rate
    (``on_outlier="extrapolate"``: paper E's eq. 12 on the whole state), and after ``reacquire`` consecutive
    rejections that lie on a straight line the filter restarts from them (:class:`RobustGate`; None: never).

    Parameters
    ----------
    ranges : array_like, shape (K,) or (M, K)
        Measured ranges [m], >= 0, NaN where missing.
    dt : float, default 1
        Time between ranges [s] (paper E: 1 s); ignored when ``times`` is given.
    q, r : float, default 2
        Process (acceleration) and measurement noise variances (paper E's "variance 2").
    delta : float, default 0.03
        Paper E's tolerance :math:`\delta`.
    test : {"paper", "chi2", "none"} or Gate, default "paper"
        The outlier test; ``"none"`` is the standard Kalman filter.
    times : array_like, shape (K,), optional
        Epoch times [s].
    probability : float, default 0.99
        Quantile of the chi-square gate.
    on_outlier : {"predict", "extrapolate"}, default "predict"
        What a rejected range is replaced by.
    reacquire : int or None, default 20
        Consecutive rejections before a re-acquisition is tried.

    Returns
    -------
    FilterResult
        ``x[..., 0]`` the filtered range, ``x[..., 1]`` its rate; ``extras["outlier"]`` True where a range was
        rejected (see :func:`robust_track_kf` for the other extras).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.filters import robust_range_kf
    >>> t = np.arange(200.0)
    >>> truth = 1500.0 + 2.0 * t
    >>> z = truth + np.random.default_rng(0).normal(0.0, np.sqrt(2.0), 200)
    >>> # a patch of ten outliers
    >>> z[100:110] += 80.0
    >>> res = robust_range_kf(z, 1.0)
    >>> int(res.extras["outlier"].sum()), np.flatnonzero(
    ...     res.extras["outlier"]
    ... ).tolist() == list(range(100, 110))
    (10, True)
    >>> bool(np.max(np.abs(res.x[:, 0] - truth)) < 10.0)
    True
    """
    rr = as_range_array("ranges", ranges, allow_nan=True, ndim=(1, 2), nonempty=True, max_abs=MAX_COORDINATE)
    if rr.ndim == 2 and rr.shape[1] == 1 and rr.shape[0] > 1:
        raise ValueError(f"ranges has shape {rr.shape}, a column: that would be {rr.shape[0]} runs of one range each. "
                         f"Give shape ({rr.shape[0]},) for one run of {rr.shape[0]} ranges (ranges.ravel()), or "
                         "(M, K) for M runs of K ranges")
    bad = np.isfinite(rr) & (rr < 0)
    if bad.any() or np.isinf(rr).any():
        where = np.flatnonzero((bad | np.isinf(rr)).ravel())[0]
        raise ValueError(f"ranges must be finite and >= 0 (NaN for a missing range); got {rr.ravel()[where]:g} "
                         f"at flat index {where}")
    return robust_track_kf(rr[..., None], dt, q=q, r=r, test=test, delta=delta, probability=probability,
                           on_outlier=on_outlier, reacquire=reacquire, times=times)


def cascade_kf(fixes: ArrayLike, dt: Any = 1.0, *, q: Any = 1e-4, r: ArrayLike, test: Any = "chi2", delta: Any = 0.03,
               probability: Any = 0.99, on_outlier: str = "predict", reacquire: int | None = 20,
               times: Any = None) -> FilterResult:
    r"""Paper E's cascade Kalman filter on the least-squares fixes (sec. 1.3), with an outlier test.

    State :math:`[x, y, v_x, v_y]`, constant velocity with acceleration variance ``q`` (the submersible holds
    its course: a small ``q``); the fixes, of covariance ``r`` (one per epoch if given so), pass the ``test``
    first. Paper E uses "the same test" as for the ranges; the default here is the chi-square gate, because the
    second-moment test on a position depends on where the coordinates' origin is (module docstring).

    Parameters
    ----------
    fixes : array_like, shape (K, 2) or (M, K, 2)
        Position fixes [m], NaN where there is none (e.g. a singular least-squares problem).
    dt : float, default 1
        Time between fixes [s]; ignored when ``times`` is given.
    q : float, default 1e-4
        Acceleration variance [(m/s²)²] (chosen: paper E does not give it).
    r : float or array_like
        Fix covariance [m²]: a variance, ``(2, 2)``, ``(K, 2, 2)`` or ``(M, K, 2, 2)``.
    test, delta, probability, on_outlier, reacquire, times
        As for :func:`robust_track_kf`.

    Returns
    -------
    FilterResult
        ``x[..., :2]`` the filtered positions, ``x[..., 2:]`` the velocities; extras as for
        :func:`robust_track_kf`.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.filters import cascade_kf
    >>> t = np.arange(300.0)
    >>> truth = np.column_stack([-1000.0 + t, -1000.0 + t])
    >>> fixes = truth + np.random.default_rng(1).normal(0.0, 20.0, (300, 2))
    >>> res = cascade_kf(fixes, 1.0, r=400.0)
    >>> def rms(e): return float(np.sqrt(np.mean(np.sum(e ** 2, axis=-1))))
    >>> rms(fixes[100:] - truth[100:]) > 5 * rms(res.x[100:, :2] - truth[100:])
    True
    """
    f = as_float_array("fixes", fixes, ndim=(2, 3), nonempty=True)
    if f.shape[-1] != 2:
        raise ValueError(f"fixes must be horizontal positions, shape (K, 2) or (M, K, 2); got {f.shape}")
    if np.isinf(f).any():
        raise ValueError("fixes must be finite, or NaN where there is no fix; got an infinite value")
    if (np.abs(f) > MAX_COORDINATE).any():
        raise ValueError(f"fixes must be at most {MAX_COORDINATE:.0e} m in magnitude; change their units")
    if times is not None and np.size(times) != f.shape[-2]:
        raise ValueError(f"times must have one entry per fix ({f.shape[-2]} in fixes); got {np.size(times)}")
    return robust_track_kf(f, dt, q=q, r=r, test=test, delta=delta, probability=probability,
                           on_outlier=on_outlier, reacquire=reacquire, times=times)
