r"""Outlier-robust Kalman filters (paper E): the range filter and the cascade filter on fixes.

Acoustic ranges carry **outliers**, isolated or in patches (multipath, a lost direct path), tens of metres off.
Paper E filters the range sequence to the mother ship with a Kalman filter and tests every range before using it;
a rejected range is replaced by an extrapolation. After the least-squares fixes it filters once more (the
*cascade* filter) with the same test.

Both filters are the generic engine (``uwtutor.filters.ExtendedKalmanFilter``) on a constant-velocity model
(:mod:`uwtutor.models.robust`) with a gate from :mod:`uwtutor.filters.gates`, where paper E's gates live too
(they can still be imported from here):

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

import numpy as np
from numpy.typing import ArrayLike

from .._validate import MAX_COORDINATE, as_covariance, as_finite, as_float_array, as_positive, as_range_array, as_scalar
from ..errors import UwtutorWarning, warn
from ..models.robust import ConstantVelocity, PositionMeasurement, step_lengths
from .base import FilterResult
from .engine import ExtendedKalmanFilter
from .gates import (RobustGate, SecondMomentGate, TestChoice, make_test,    # the gates live in filters.gates
                    moment_gate_interval)

__all__ = [
    "SecondMomentGate",
    "RobustGate",
    "moment_gate_interval",
    "make_test",
    "robust_track_kf",
    "robust_range_kf",
    "cascade_kf",
]

#: Fraction of rejected measurements above which robust_track_kf warns that the filter is locked out.
REJECTION_WARNING = 0.5


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


def robust_track_kf(z: ArrayLike, dt: float = 1.0, *, q: float, r: ArrayLike, test: TestChoice = "paper",
                    delta: float = 0.03, probability: float = 0.99, on_outlier: str = "predict",
                    reacquire: int | None = None, times: ArrayLike | None = None, x0: ArrayLike | None = None,
                    P0: ArrayLike | None = None, initial_rate_sigma: float = 5.0) -> FilterResult:
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


def robust_range_kf(ranges: ArrayLike, dt: float = 1.0, *, q: float = 2.0, r: ArrayLike = 2.0, delta: float = 0.03,
                    test: TestChoice = "paper", times: ArrayLike | None = None, probability: float = 0.99,
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


def cascade_kf(fixes: ArrayLike, dt: float = 1.0, *, q: float = 1e-4, r: ArrayLike, test: TestChoice = "chi2",
               delta: float = 0.03, probability: float = 0.99, on_outlier: str = "predict", reacquire: int | None = 20,
               times: ArrayLike | None = None) -> FilterResult:
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
