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
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._linalg import quadratic_form
from .._validate import MAX_COORDINATE, as_bool_array, as_finite, as_flag, as_float_array, as_int, as_scalar

__all__ = ["Gate", "GateContext", "ChiSquareGate", "ReacquiringGate", "normalized_innovation_squared"]


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

    def __init__(self, probability: Any = 0.99, *, per_component: bool = False) -> None:
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
                return ctx.y**2 / var <= self.threshold(1)            # NaN (missing): False
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

    def __init__(self, test: Gate | None = None, *, patience: int = 5, factor: Any = 10.0,
                 states: Any = None, force: bool = True, max_variance: Any = 1e10) -> None:
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
        if states is not None:
            idx = [as_int("states", i, minimum=0) for i in np.atleast_1d(np.asarray(states)).tolist()]
            if not idx or len(set(idx)) != len(idx):
                raise ValueError(f"states must be distinct state indices; got {idx}")
            states = np.array(idx)
        self.states = states
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
