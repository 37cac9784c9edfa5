r"""Gates: accept or reject an innovation before it corrects the estimate (outlier rejection).

A gate sees, at each update, the innovation :math:`y_k`, its covariance :math:`S_k` and the rest of the
linearization (a :class:`GateContext`) and says, run by run -- or component by component, an array ``(M, m)`` --
whether the measurement is to be used. A rejected measurement leaves that run at its prediction, as a missing
one would; the gate's :meth:`Gate.after_update` hook may then change the estimate further (paper E replaces it by
a linear extrapolation; :class:`ReacquiringGate` inflates the covariance). Per-step values a gate names in its
``extra_outputs`` attribute are recorded by the filter next to its own.

:class:`ChiSquareGate` is the classic test: under a consistent filter the normalized innovation squared
:math:`\nu_k = y_k^T S_k^{-1} y_k` follows :math:`\chi^2_m`, so a measurement with
:math:`\nu_k > \chi^2_m(1 - \alpha)` is improbable at the level :math:`\alpha`
(Bar-Shalom, Li and Kirubarajan 2001, sec. 5.4). With components missing, :math:`\nu_k` and the degrees of
freedom are those of the components present.

.. rubric:: Lock-out, and getting out of it

Every gate can lock out: while measurements are rejected the filter runs on its prediction, and if the
prediction drifts away faster than its covariance grows (a heading error the model does not know, a wrong start),
the good measurements that follow are rejected too, for ever. :class:`ReacquiringGate` wraps any test and, after
``patience`` consecutive rejections of a run, inflates that run's covariance by a factor (the whole of it, or
the blocks named): the predicted innovation covariance grows with it until the measurements pass again. It works
for any state; paper E's line-fit re-acquisition (``uwtutor.filters.RobustGate``) needs a constant-velocity state.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, Sequence, TypeAlias

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._linalg import quadratic_form
from .._validate import (MAX_COORDINATE, as_bool_array, as_finite, as_flag, as_float_array, as_int, as_nonnegative,
                         as_positive, as_scalar)

__all__ = ["Gate", "GateContext", "ChiSquareGate", "ReacquiringGate", "normalized_innovation_squared",
           "SecondMomentGate", "RobustGate", "moment_gate_interval", "make_test"]


@dataclass(frozen=True)
class GateContext:
    """What a gate sees at one update, for all runs at once (runs axis ``M`` first).

    Attributes
    ----------
    k : int
        Index of the step.
    z : ndarray, shape (M, m)
        Measurement (NaN: that component, or the whole row, is missing).
    z_pred : ndarray, shape (M, m)
        Predicted measurement.
    y : ndarray, shape (M, m)
        Innovation (NaN where the component is missing).
    S : ndarray, shape (M, m, m)
        Innovation covariance. The rows and columns of missing components are no covariances: in a run with some
        components present they are those of the identity (so that :math:`y_0^T S^{-1} y_0`, with :math:`y_0` the
        innovation with zeros in place of the NaNs, is the NIS of the components present).
    H : ndarray, shape (M, m, n)
        Measurement Jacobian at the prediction.
    R : ndarray, shape (m, m) or (M, m, m)
        Measurement noise covariance.
    x_prior : ndarray, shape (M, n)
        The prediction.
    P_prior : ndarray, shape (M, n, n)
        Its covariance.
    present : ndarray of bool, shape (M, m), optional
        Which components are measured (and usable); None means "every finite component of ``z``".

    Examples
    --------
    What a gate sees at each step (here, the first step of a one-run filter):

    >>> import numpy as np
    >>> from uwtutor.filters import Gate, extended_kalman_filter
    >>> from uwtutor.models import DeadReckoning, RangeToBeacon
    >>> seen = []
    >>> class Spy(Gate):
    ...     def accept(self, ctx):
    ...         seen.append(ctx)
    ...         return np.ones(ctx.y.shape[0], dtype=bool)
    >>> _ = extended_kalman_filter(
    ...     DeadReckoning(np.eye(2) * 0.01),
    ...     RangeToBeacon((0.0, 0.0), R=1.0),
    ...     [3.0, 4.0],
    ...     np.eye(2),
    ...     np.zeros((1, 2)),
    ...     [6.0],
    ...     gate=Spy(),
    ... )
    >>> ctx = seen[0]
    >>> ctx.k, ctx.z.tolist(), ctx.z_pred.tolist(), ctx.y.tolist()
    (0, [[6.0]], [[5.0]], [[1.0]])
    >>> # S = H P H^T + R
    >>> np.round(ctx.S, 3).tolist()
    [[[2.01]]]
    """

    k: int
    z: np.ndarray
    z_pred: np.ndarray
    y: np.ndarray
    S: np.ndarray
    H: np.ndarray
    R: np.ndarray
    x_prior: np.ndarray
    P_prior: np.ndarray
    present: np.ndarray | None = None

    def present_mask(self) -> np.ndarray:
        """``present``, or the finite components of ``z`` when it was not given: ``(M, m)``."""
        return np.isfinite(self.z) if self.present is None else self.present


def normalized_innovation_squared(y: ArrayLike, S: ArrayLike) -> NDArray[np.float64]:
    r""":math:`\nu = y^T S^{-1} y` over stacked innovations ``(..., m)`` and covariances ``(..., m, m)``.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.filters.gates import normalized_innovation_squared
    >>> normalized_innovation_squared(np.array([[2.0]]), np.array([[[4.0]]]))
    array([1.])
    """
    y = as_float_array("y", y, nonempty=True)
    S = as_float_array("S", S, nonempty=True)
    if y.ndim < 1 or S.ndim != y.ndim + 1 or S.shape[-2:] != (y.shape[-1], y.shape[-1]) \
            or S.shape[:-2] != y.shape[:-1]:
        raise ValueError(f"y (..., m) and S (..., m, m) must agree: got y of shape {y.shape} and S of shape "
                         f"{S.shape}")
    if np.isinf(y).any():
        raise ValueError("y must be finite (NaN marks a missing innovation); got an infinite value")
    if (np.abs(y) > MAX_COORDINATE).any():
        raise ValueError(f"y must be at most {MAX_COORDINATE:.0e} in magnitude (its square overflows float64 beyond "
                         "it); change its units")
    return quadratic_form(y, S, "S")


class Gate:
    """Base class of gates: accept everything (override :meth:`accept`, and :meth:`after_update` if needed).

    A gate may name per-step attributes in ``extra_outputs`` (each an array ``(M,)``, set by :meth:`accept` or
    :meth:`after_update`): the filter records them in its result's ``extras``.

    Examples
    --------
    A gate of your own: accept a range only when it is shorter than 1000 m (one decision per run):

    >>> import numpy as np
    >>> from uwtutor.filters import Gate, extended_kalman_filter
    >>> from uwtutor.models import DeadReckoning, RangeToBeacon
    >>> class ShortRanges(Gate):
    ...     def accept(self, ctx):
    ...         return ctx.z[:, 0] < 1000.0
    >>> res = extended_kalman_filter(
    ...     DeadReckoning(np.eye(2) * 0.01),
    ...     RangeToBeacon((0.0, 0.0), R=1.0),
    ...     [100.0, 0.0],
    ...     np.eye(2) * 25.0,
    ...     np.zeros((3, 2)),
    ...     [100.0, 5000.0, 101.0],
    ...     gate=ShortRanges(),
    ... )
    >>> res.extras["accepted"].tolist()
    [True, False, True]
    """

    extra_outputs: tuple[str, ...] = ()
    #: True for a library gate whose :meth:`after_update` keeps the covariance symmetric positive semi-definite by
    #: construction (it scales it by positive factors, or restarts from a fit): the engine does not check what it
    #: returns. A gate of your own leaves it False, and a new ``x`` or ``P`` it returns is checked.
    estimates_checked: bool = False

    def accept(self, ctx: GateContext) -> np.ndarray:
        """A bool array ``(M,)`` -- True where the run's measurement is to be used -- or ``(M, m)``, component by
        component."""
        return np.ones(ctx.y.shape[0], dtype=bool)

    def after_update(self, x: np.ndarray, P: np.ndarray, accepted: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        """Called after every update with the posterior ``x`` (M, n), ``P`` (M, n, n) and the accepted mask
        (False also where there was no measurement); returns the estimate to keep. Default: unchanged."""
        return x, P


class ChiSquareGate(Gate):
    r"""Accept a measurement when its NIS is below the chi-square quantile :math:`\chi^2_m(p)`.

    With some components missing, the NIS is that of the components present and ``m`` their number. With
    ``per_component=True`` each component is tested on its own, :math:`y_i^2 / S_{ii} \le \chi^2_1(p)`, and only
    the components that fail are dropped (an outlier on one beacon does not throw away the ranges to the others).

    Parameters
    ----------
    probability : float, optional
        The quantile ``p`` (default 0.99: a consistent filter rejects 1 % of good measurements).
    per_component : bool, optional
        Test each component separately (default False: the whole vector).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.filters import ChiSquareGate, GateContext
    >>> gate = ChiSquareGate(0.99)
    >>> round(gate.threshold(1), 3)
    6.635
    >>> y = np.array([[1.0], [10.0]]); S = np.full((2, 1, 1), 4.0)
    >>> ctx = GateContext(
    ...     k=0,
    ...     z=y,
    ...     z_pred=0 * y,
    ...     y=y,
    ...     S=S,
    ...     H=np.ones((2, 1, 2)),
    ...     R=np.eye(1),
    ...     x_prior=np.zeros((2, 2)),
    ...     P_prior=np.tile(np.eye(2), (2, 1, 1)),
    ... )
    >>> gate.accept(ctx)
    array([ True, False])
    """

    def __init__(self, probability: float = 0.99, *, per_component: bool = False) -> None:
        p = as_scalar("probability", probability)
        if not 0.0 < p < 1.0:
            raise ValueError(f"probability must lie strictly between 0 and 1, e.g. 0.99; got {p}")
        self.probability = p
        self.per_component = as_flag("per_component", per_component)
        self._thresholds: dict[int, float] = {}

    def threshold(self, m: int) -> float:
        """The NIS threshold for a measurement of size ``m`` (an integer >= 1: the degrees of freedom)."""
        if m not in self._thresholds or type(m) is not int:
            m = as_int("m", m, minimum=1)
        if m not in self._thresholds:
            from scipy import stats      # imported when needed: scipy.stats is heavy and most filters never gate

            self._thresholds[m] = float(stats.chi2.ppf(self.probability, m))
        return self._thresholds[m]

    def accept(self, ctx: GateContext) -> np.ndarray:
        if self.per_component:
            var = np.diagonal(ctx.S, axis1=-2, axis2=-1)
            with np.errstate(invalid="ignore", divide="ignore"):
                inside: np.ndarray = ctx.y**2 / var <= self.threshold(1)      # NaN (missing): False
            return inside
        present = ctx.present
        if present is None or present.all():
            nis = normalized_innovation_squared(ctx.y, ctx.S)
            with np.errstate(invalid="ignore"):
                return nis <= self.threshold(ctx.y.shape[-1])
        count = present.sum(axis=-1)                    # the NIS of the components present (S: identity elsewhere)
        S = np.where(count[:, None, None] > 0, ctx.S, np.eye(ctx.S.shape[-1]))
        nis = normalized_innovation_squared(np.where(present, ctx.y, 0.0), S)
        limit = np.array([self.threshold(int(c)) if c else -np.inf for c in count])
        return nis <= limit


class ReacquiringGate(Gate):
    r"""A gate that cannot lock out: any test, plus covariance inflation and a forced update after repeated rejections.

    Each run counts the consecutive steps at which it had a measurement and the ``test`` rejected all of it (a
    step without a measurement neither counts nor resets; a used measurement resets). When the count reaches
    ``patience`` the run is taken to be lost rather than facing outliers:

    1. its covariance is inflated, :math:`P \leftarrow D P D` with :math:`D = \operatorname{diag}(d_i)`,
       :math:`d_i = \sqrt{\lambda}` on the ``states`` (all of them by default) and 1 elsewhere -- a congruence,
       so :math:`P` stays symmetric positive semi-definite and its correlations are kept;
    2. with ``force`` (the default), its next measurement is used whatever the test says: with the inflated
       covariance that update is close to a least-squares fix from the measurement, which brings the estimate
       back to where the measurements are.

    Then the count starts again: a run still rejected ``patience`` steps later is inflated (by :math:`\lambda`
    again) and forced again, so a lock-out lasts a few times ``patience`` steps, never for ever. Forcing matters
    for vector measurements: several accurate ranges that disagree with a wrong linearization point keep a large
    NIS along the directions the inflated states do not reach, however large the inflation. Inflating the
    position block only (``states=[0, 1]``) keeps what the filter knows of the other states (a heading, a bias);
    the whole state (the default) works whatever the model. A variance is never inflated beyond
    ``max_variance``.

    The price: after ``patience`` consecutive rejections the next measurement is believed, outlier or not.
    Choose ``patience`` longer than the patches of outliers to reject and short enough to recover in time.

    Parameters
    ----------
    test : Gate, optional
        The accept/reject rule (default ``ChiSquareGate(0.99)``); it may decide per run or per component, and its
        own ``after_update`` runs first.
    patience : int, default 5
        Consecutive rejections before an inflation (>= 1).
    factor : float, default 10
        :math:`\lambda` > 1, the factor on the inflated variances.
    states : sequence of int, optional
        The state components to inflate (default: all).
    force : bool, default True
        Use the next measurement after an inflation without testing it.
    max_variance : float, default 1e10
        No variance is inflated beyond this (in the state's units squared).

    Attributes
    ----------
    rejected : ndarray of bool, shape (M,)
        Whether the run's measurement (all of its components) was rejected at the last step.
    inflated : ndarray of bool, shape (M,)
        Whether the run's covariance was inflated at the last step.
    forced : ndarray of bool, shape (M,)
        Whether the run's measurement was used without the test at the last step.

    Examples
    --------
    A filter started 60 m off with a covariance that says 1 m: the chi-square gate alone rejects nearly every
    range and ends as far off as it started; with re-acquisition it finds the track:

    >>> import numpy as np
    >>> from uwtutor.filters import (
    ...     ChiSquareGate,
    ...     ReacquiringGate,
    ...     extended_kalman_filter,
    ... )
    >>> from uwtutor.models import DeadReckoning, RangeToBeacon
    >>> theta = np.linspace(0.0, 2 * np.pi, 201)
    >>> track = 200.0 * np.column_stack([np.cos(theta), np.sin(theta)])
    >>> z = np.linalg.norm(track[1:], axis=1) + np.random.default_rng(0).normal(
    ...     0.0, 1.0, 200
    ... )
    >>> args = (
    ...     DeadReckoning(0.01 * np.eye(2)),
    ...     RangeToBeacon((0.0, 0.0), R=1.0),
    ...     track[0] + [60.0, 0.0],
    ...     np.eye(2),
    ...     np.diff(track, axis=0),
    ...     z,
    ... )
    >>> locked = extended_kalman_filter(*args, gate=ChiSquareGate(0.99))
    >>> int(locked.extras["accepted"].sum()), round(
    ...     float(np.linalg.norm(locked.x[-1] - track[-1]))
    ... )
    (6, 60)
    >>> res = extended_kalman_filter(
    ...     *args, gate=ReacquiringGate(ChiSquareGate(0.99), patience=5)
    ... )
    >>> np.flatnonzero(res.extras["inflated"]).tolist(), np.flatnonzero(
    ...     res.extras["forced"]
    ... ).tolist()
    ([4, 10], [5, 11])
    >>> bool(res.extras["accepted"][12:].all()), bool(
    ...     np.linalg.norm(res.x[-1] - track[-1]) < 1.0
    ... )
    (True, True)
    """

    estimates_checked = True      # P scaled by positive factors only: it stays positive semi-definite

    extra_outputs = ("rejected", "inflated", "forced")

    def __init__(self, test: Gate | None = None, *, patience: int = 5, factor: ArrayLike = 10.0,
                 states: Sequence[int] | None = None, force: bool = True, max_variance: ArrayLike = 1e10) -> None:
        if test is None:
            test = ChiSquareGate(0.99)
        if not isinstance(test, Gate):
            raise TypeError(f"test must be a uwtutor.filters.Gate (e.g. ChiSquareGate(0.99)); got "
                            f"{type(test).__name__}")
        self.test = test
        self.patience = as_int("patience", patience, minimum=1)
        lam = float(as_finite("factor", factor, ndim=0))
        if not lam > 1.0:
            raise ValueError(f"factor must be > 1 (the covariance is multiplied by it); got {lam:g}")
        self.factor = lam
        self.states: np.ndarray | None = None          # the indices (k,), or None for all
        if states is not None:
            idx = [as_int("states", i, minimum=0) for i in np.atleast_1d(np.asarray(states)).tolist()]
            if not idx or len(set(idx)) != len(idx):
                raise ValueError(f"states must be distinct state indices; got {idx}")
            self.states = np.array(idx)
        self.force = as_flag("force", force)
        cap = float(as_finite("max_variance", max_variance, ndim=0))
        if not cap > 0:
            raise ValueError(f"max_variance must be > 0; got {cap:g}")
        self.max_variance = cap
        self._reset(0)

    def _reset(self, M: int) -> None:
        self.rejected = np.zeros(M, dtype=bool)
        self.inflated = np.zeros(M, dtype=bool)
        self.forced = np.zeros(M, dtype=bool)
        self._count = np.zeros(M, dtype=int)
        self._due = np.zeros(M, dtype=bool)                  # inflated, its next measurement to be forced

    def accept(self, ctx: GateContext) -> np.ndarray:
        M = ctx.y.shape[0]
        if ctx.k == 0 or self._count.shape != (M,):                  # a new run of the filter
            self._reset(M)
        present = ctx.present_mask()
        has = present.any(axis=-1)
        verdict = as_bool_array(f"the gate {type(self.test).__name__}.accept", self.test.accept(ctx),
                                ((M,), present.shape))
        forced = self._due & has
        if forced.any():
            verdict = verdict | (forced[:, None] & present if verdict.shape == present.shape else forced)
            self._due &= ~forced
        self.forced = forced
        used = (verdict & present).any(axis=-1) if verdict.shape == present.shape else verdict & has
        self._pending = has & ~used
        return verdict

    def after_update(self, x: np.ndarray, P: np.ndarray, accepted: np.ndarray,
                     k: int) -> tuple[np.ndarray, np.ndarray]:
        x, P = self.test.after_update(x, P, accepted, k)
        rejected = self._pending & ~accepted
        self._count[accepted] = 0
        self._count[rejected] += 1
        due = self._count >= self.patience
        if due.any():
            n = P.shape[-1]
            if self.states is not None and self.states.max() >= n:
                raise ValueError(f"states must index the state (0..{n - 1}); got {self.states.tolist()}")
            chosen = np.zeros(n, dtype=bool)
            chosen[slice(None) if self.states is None else self.states] = True
            P = np.array(P)
            var = np.diagonal(P[due], axis1=-2, axis2=-1)                          # (due, n)
            d = np.where(chosen & (var * self.factor <= self.max_variance), np.sqrt(self.factor), 1.0)
            P[due] *= d[:, :, None] * d[:, None, :]
            self._count[due] = 0
            if self.force:
                self._due |= due
        self.rejected, self.inflated = rejected, due
        return x, P


#: The tests ``robust_range_kf`` and ``cascade_kf`` know by name.
TESTS = ("paper", "chi2", "none")


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
    >>> from uwtutor.filters.gates import SecondMomentGate
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

    def __init__(self, delta: float = 0.03) -> None:
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
            inside: np.ndarray = (zz >= (1.0 - self.delta) * D) & (zz <= (1.0 + self.delta) * D)
        return inside


def moment_gate_interval(z_pred: ArrayLike, S: ArrayLike,
                         delta: float = 0.03) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
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
    >>> from uwtutor.filters.gates import moment_gate_interval
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


#: What :func:`make_test` takes: a test by its name, or a :class:`Gate` itself.
TestChoice: TypeAlias = 'Literal["paper", "chi2", "none"] | Gate'


def make_test(test: TestChoice, *, delta: float = 0.03, probability: float = 0.99) -> Gate | None:
    """The gate named by ``test``: ``"paper"`` (``SecondMomentGate(delta)``), ``"chi2"``
    (``ChiSquareGate(probability)``), ``"none"`` (None: every measurement used), or a ``Gate`` itself.

    ``delta`` and ``probability`` are checked whichever test uses them, so that a bad value is never silently
    ignored (``make_test("chi2", delta=nan)`` is refused).

    Examples
    --------
    >>> from uwtutor.filters.gates import make_test
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
    >>> from uwtutor.filters.gates import RobustGate, SecondMomentGate
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
        self._x1: np.ndarray | None = None         # the last two estimates (eq. 12's extrapolation)
        self._x2: np.ndarray | None = None

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
        if self.on_outlier == "extrapolate" and self._x1 is not None and self._x2 is not None and rejected.any():
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
