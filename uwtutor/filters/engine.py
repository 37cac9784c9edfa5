r"""The generic extended Kalman filter: any motion model, any measurement model, many runs at once.

Given a motion model (:math:`f`, :math:`F`, :math:`Q`) and a measurement model (:math:`h`, :math:`H`, :math:`R`)
from :mod:`uwtutor.models`, each step of the filter is

.. math::

    \hat x^-_k = f(\hat x_{k-1}, u_k), \qquad P^-_k = F_k P_{k-1} F_k^T + Q_k,
    \qquad F_k = \partial f / \partial x \,|_{\hat x_{k-1}},

    y_k = z_k - h_k(\hat x^-_k), \qquad S_k = H_k P^-_k H_k^T + R_k, \qquad K_k = P^-_k H_k^T S_k^{-1},
    \qquad H_k = \partial h_k / \partial x \,|_{\hat x^-_k},

    \hat x_k = \hat x^-_k + K_k y_k, \qquad
    P_k = (I - K_k H_k) P^-_k (I - K_k H_k)^T + K_k R_k K_k^T,

the covariance update in Joseph form, computed as written (not as an algebraically equal shortcut) and then
symmetrized, so that :math:`P_k` stays symmetric positive semi-definite under rounding
(Bar-Shalom, Li and Kirubarajan 2001, sec. 5.2).

.. rubric:: Missing components

A measurement vector may have some components and not others (four beacons, of which two answered). The update
then uses the components that are present, :math:`z_{k,\mathcal P}` with the rows :math:`H_{k,\mathcal P}` and
the block :math:`R_{k,\mathcal{PP}}`: the update a model of those components alone would make, and for a
diagonal :math:`R` the same as updating with them one scalar at a time. It is computed for all runs at once by
masking: the rows of :math:`H_k` of the missing components are set to zero and their rows and columns of
:math:`R_k` to those of the identity, which makes :math:`S_k` block-diagonal and the gain's columns of the
missing components exactly zero. The innovation of a missing component is NaN, and so are its row and column of
:math:`S_k`. A model's prediction or Jacobian may be NaN for a component that is not measured (it is never
used); where a measurement *is* present a non-finite value is an error that names the model's method and the
step.

Every array carries an axis of ``M`` Monte Carlo runs: one call filters a whole study. The covariances are held
runs-last, ``(n, n, M)``, so that each matrix product is one ``einsum`` over contiguous rows of length ``M``
(three times faster than ``@`` on stacks of small matrices); the attributes show them as ``(M, n, n)``. A NaN
measurement means "no measurement": that run's step is predict only (its gain is zero, its innovation NaN). A
*gate* (:mod:`uwtutor.filters.gates`) may reject measurements the same way, run by run (or component by component), and
then adjust the estimate of the rejected runs; per-step values the gate
names in its ``extra_outputs`` are recorded in the result's ``extras`` next to ``"accepted"``.

Two forms:

* :class:`ExtendedKalmanFilter` -- the object form of the filter protocol (``predict``, ``update``, ``run``);
* :func:`extended_kalman_filter` -- the functional form, a whole sequence in one call; it returns the same result as the
  object's ``run`` (it *is* that call).

The specialised filters of the library (the range-only EKF, paper A's bias EKF, paper B's cooperative EKF, the
robust range filter of paper E) are model pairs on this engine, or fast paths that must equal it
(``tests/test_filter_contract.py``).

.. rubric:: Back-ends

The engine picks its arithmetic by model type. The plain range-only pair -- ``DeadReckoning`` with a 2x2 ``Q`` (one,
or one per step) and ``RangeToBeacon`` on a 2-state without a bias, to a fixed or moving beacon -- without a gate
and without ``known_states`` runs on the *packed* back-end of :mod:`uwtutor.filters.ekf`: the same equations written
out as 2x2 algebra on arrays of length ``M``, the states of all runs packed in one ``(6, M)`` array, about five times
faster than the ``einsum`` products below. ``run`` runs it over whole sequences, ``predict`` and ``update`` one step
at a time (the same numbers, bit for bit); its covariance update is the Joseph form factored as
:math:`B - d K^\mathsf T` (with a line-of-sight fallback where float64 cannot carry the update), so its last bits
may differ from the generic form's. Every other pair, and that pair with a gate, runs the generic arithmetic.
:class:`~uwtutor.filters.ekf.RangeOnlyEKF` is this engine built from that pair.

References
----------
Bar-Shalom, Y., Li, X. R. and Kirubarajan, T. (2001). *Estimation with Applications to Tracking and Navigation*.
Wiley. Sections 5.2 and 10.3.

Labbe, R. *FilterPy* (``filterpy.kalman.ExtendedKalmanFilter``), the reference this engine is tested against.
"""

from __future__ import annotations

import copy
import dataclasses
import warnings
from typing import Any, cast

from numpy.typing import ArrayLike

import numpy as np

from .._validate import (MAX_COORDINATE, CovarianceCheck, as_bool_array, as_covariance, as_finite, as_flag,
                         as_float_array, as_model_output, check_model_covariance, common_runs, readonly)
from .._cancel import checkpoint
from .._linalg import psd_violations
from ..errors import BeaconSingularityWarning, IllConditionedError, warn
from ..models.base import MeasurementModel, MotionModel
from ..models.dead_reckoning import DeadReckoning
from ..models.range import RangeToBeacon
from ._packed import pack_runs_last, predict_step, unpack_runs_last, update_step
from .base import Configurable, FilterResult, _sequence_times, run_filter
from .gates import Gate, GateContext

__all__ = ["ExtendedKalmanFilter", "extended_kalman_filter"]


def _library(obj: Any) -> bool:
    """Whether ``obj`` is an instance of one of the library's own classes (not a user's subclass)."""
    return type(obj).__module__.startswith("uwtutor.")


def _initial_covariance(P0: Any, n: int, known_states: Any) -> np.ndarray:
    """``P0`` checked: positive definite, or with ``known_states`` (bool ``(n,)`` or ``(M, n)``) zero in the rows and
    columns of the states known exactly and positive definite on the others."""
    if known_states is None:
        return as_covariance("P0", P0, n)
    known = np.asarray(known_states)
    if known.dtype.kind != "b" or known.ndim not in (1, 2) or known.shape[-1] != n:
        raise ValueError(f"known_states must be bools, one per state ({n},) or per run and state (M, {n}); got "
                         f"{known.dtype} of shape {known.shape}")
    P = as_covariance("P0", P0, n, allow_singular=True)
    coupled = known[..., :, None] | known[..., None, :]
    if np.any(np.where(coupled, P, 0.0) != 0.0):
        raise ValueError("P0 must be 0 in the rows and columns of the known_states (a state known exactly has no "
                         "variance and no correlation)")
    as_covariance("P0 (on the states not known)", P + known[..., :, None] * np.eye(n), n)
    return P


def _check_model(name: str, model: Any, kind: type) -> None:
    if not isinstance(model, kind):
        raise TypeError(f"{name} must be a {kind.__module__}.{kind.__name__} (see uwtutor.models); "
                        f"got {type(model).__name__}")


def _real(name: str, value: Any) -> np.ndarray:
    """What a model returned, as a float array of real numbers (``_validate.as_model_output``)."""
    return as_model_output(_owner(name), value)


def _owner(name: str) -> str:
    """``"the model's F"`` for a model's method, the name itself when it already says whose value it is."""
    return name if name.startswith("the ") else f"the model's {name}"


def _gate_estimate(gate: Any, out: Any, x_in: np.ndarray, P_in: np.ndarray, M: int, n: int
                   ) -> tuple[np.ndarray, np.ndarray]:
    """What a gate's ``after_update`` returned, checked: a pair of real arrays of the filter's shapes; a new x must be
    finite and a new P symmetric positive semi-definite (the same arrays back, or a library gate's, are trusted)."""
    name = f"the gate {type(gate).__name__}.after_update"
    if not (isinstance(out, tuple) and len(out) == 2):
        raise TypeError(f"{name} must return the pair (x, P); got {type(out).__name__}")
    x_out, P_out = out
    x, P = _real(f"{name} (its x)", x_out), _real(f"{name} (its P)", P_out)
    if x.shape != (M, n) or P.shape != (M, n, n):
        raise ValueError(f"the gate's after_update must return x ({M}, {n}) and P ({M}, {n}, {n})")
    if not getattr(gate, "estimates_checked", False):
        if x_out is not x_in and not np.isfinite(x).all():
            raise ValueError(f"{name} returned a non-finite x")
        if P_out is not P_in:
            check_model_covariance(f"{name} (its P)", P)
    return x, P


def _batched_matrix(name: str, value: Any, M: int, shape: tuple[int, ...]) -> np.ndarray:
    """A model's matrix as ``(M,) + shape`` (broadcast when shared by every run)."""
    arr = _real(name, value)
    if arr.shape == shape:
        return arr
    if arr.shape == (M,) + shape:
        return arr
    raise ValueError(f"the model's {name} must have shape {shape} or {(M,) + shape}; got {arr.shape}")


def _not_finite_error(model: Any, method: str, k: int, where: tuple[int, ...], what: str) -> ValueError:
    """The error for a model that returned NaN or infinity where its value is used."""
    at = ", ".join(f"{name} {i}" for name, i in zip(("run", "component"), where))
    return ValueError(f"{type(model).__name__}.{method} returned a non-finite value at step {k} ({at}){what}: "
                      "the filter cannot use it. Check the model there (a NaN beacon position or parameter, a "
                      "table that does not cover this step)")


def _defined_mask(defined: Any, M: int, m: int) -> np.ndarray:
    """A model's "defined" mask, per run (M,) or per component (M, m), as (M, m) (bools only: 0.3 is refused)."""
    if defined is True or defined is np.True_:        # a model with no singular point may say so once
        return np.ones((M, m), dtype=bool)
    d = as_bool_array("the measurement model's linearize (its mask of defined values)", defined, ((M,), (M, m)))
    if d.shape == (M, m):
        return d
    return np.repeat(d[:, None], m, axis=1)


_CovarianceCheck = CovarianceCheck                   # the shared check (uwtutor._validate)


def _masked(H: np.ndarray, R: np.ndarray, present: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """H (M, m, n) with the rows of the missing components zero, R (M, m, m) with their rows and columns those of
    the identity: the update with these is the update with the present components alone."""
    m = present.shape[1]
    H = np.where(present[:, :, None], H, 0.0)
    both = present[:, :, None] & present[:, None, :]
    R = np.where(both, R, _EYES[m] if m in _EYES else _EYES.setdefault(m, np.eye(m)))
    return H, R


_EYES: dict[int, np.ndarray] = {}


# The covariances of all runs are held runs-last, (n, n, M): every product below is then an einsum over
# contiguous length-M rows, about three times faster than ``@`` on (M, n, n) stacks of small matrices (numpy's
# stacked matmul pays a per-matrix overhead; measured 27 vs 81 microseconds for M = 1000 3x3 products). The
# public attributes show them runs-first, (M, n, n), as views.

def _runs_last(a: np.ndarray) -> np.ndarray:
    """A stack (M, i, j) as a contiguous (i, j, M) array."""
    return np.ascontiguousarray(a.transpose(1, 2, 0))


def _runs_first(a: np.ndarray) -> np.ndarray:
    """A runs-last (i, j, M) array seen as the stack (M, i, j) (a view)."""
    return a.transpose(2, 0, 1)


def _mm(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Run by run ``a @ b`` of runs-last arrays (i, k, M) and (k, j, M) (or (k, j, 1))."""
    out: np.ndarray = np.einsum("ikm,kjm->ijm", a, b)
    return out


def _mm_t(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Run by run ``a @ b^T`` of runs-last arrays (i, k, M) and (j, k, M)."""
    out: np.ndarray = np.einsum("ikm,jkm->ijm", a, b)
    return out


def _transposed(a: np.ndarray) -> np.ndarray:
    """The stacked transpose of ``a`` (..., i, j) as a contiguous array."""
    return np.ascontiguousarray(np.swapaxes(a, -1, -2))


def _refuse_lost_psd(P: np.ndarray, R: np.ndarray, k: int) -> None:
    """Raise where the Joseph update could not keep P (runs-last) positive semi-definite in float64."""
    bad = psd_violations(P)
    if bad.any():
        m = int(np.argmax(bad))
        raise IllConditionedError(
            f"the covariance lost positive semi-definiteness at the update of step {k} (run {m}: diagonal "
            f"{np.diag(P[:, :, m])}, R diagonal {np.diag(R[:, :, min(m, R.shape[-1] - 1)])}): the ratio of the "
            "predicted variances to R exceeds what float64's 16 digits can carry. Start from a smaller P0 (an "
            "honest initial uncertainty) or use a larger R")


def _innovation_covariance(P: np.ndarray, H: np.ndarray, R: np.ndarray
                           ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """H and R runs-last, P H^T (n, m, M) and S = H P H^T + R (m, m, M), for P runs-last and H (M, m, n)."""
    Hc = _runs_last(H)                                           # (m, n, M)
    Rc = R[:, :, None] if R.ndim == 2 else _runs_last(R)         # (m, m, 1) or (m, m, M)
    PHT = _mm_t(P, Hc)                                           # P H^T, (n, m, M)
    S = _mm(Hc, PHT) + Rc                                        # H P H^T + R, (m, m, M)
    return Hc, Rc, PHT, S


def _joseph_update(x: np.ndarray, P: np.ndarray, PHT: np.ndarray, S: np.ndarray, Hc: np.ndarray, Rc: np.ndarray,
                   use: np.ndarray, y_used: np.ndarray, eye: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The posterior x (M, n) and P (n, n, M) from the gain of the runs in ``use`` (the others keep the prior)."""
    if S.shape[0] == 1:
        gain = PHT / S[0, 0]                                     # K = P H^T / S, (n, 1, M)
    else:                                                        # K = P H^T S^-1 (S symmetric)
        gain = _runs_last(_transposed(np.linalg.solve(_runs_first(S), _runs_first(PHT).swapaxes(-1, -2))))
    gain *= use                                                  # zero gain: the run keeps its prediction
    x_post = x + np.einsum("ijm,mj->mi", gain, y_used)
    A = eye[:, :, None] - _mm(gain, Hc)                          # I - K H, (n, n, M)
    # Joseph form as written: A P A^T + K R K^T, a sum of two positive semi-definite terms
    P_post = _mm_t(_mm(A, P), A)
    P_post += _mm_t(_mm(gain, Rc), gain)
    P_post += P_post.transpose(1, 0, 2)                          # symmetrize: (P + P^T) / 2
    P_post *= 0.5
    return x_post, P_post


class ExtendedKalmanFilter(Configurable):
    r"""The generic batched extended Kalman filter (equations in the module docstring).

    Parameters
    ----------
    motion : uwtutor.models.MotionModel
        How the state moves: :math:`f`, :math:`F`, :math:`Q`.
    measurement : uwtutor.models.MeasurementModel
        What is measured: :math:`h`, :math:`H`, :math:`R`.
    x0 : array_like, shape (n,) or (M, n)
        Initial state; a leading axis runs ``M`` filters at once.
    P0 : array_like, shape (n, n) or (M, n, n)
        Initial covariance (positive definite).
    gate : uwtutor.filters.Gate, optional
        Accepts or rejects each innovation before it is used (outlier rejection); ``None`` uses every
        finite measurement.

    Attributes
    ----------
    x : ndarray
        Current estimate, ``(n,)`` or ``(M, n)``.
    P : ndarray
        Its covariance, ``(n, n)`` or ``(M, n, n)``.
    x_prior : ndarray
        The prediction of the current step (equal to ``x`` before the first ``predict``).
    P_prior : ndarray
        Its covariance (equal to ``P`` before the first ``predict``).
    y : ndarray
        Innovation of the last update, ``(m,)`` or ``(M, m)`` (NaN where no measurement was used).
    S : ndarray
        Its covariance, ``(m, m)`` or ``(M, m, m)`` (NaN where no measurement was used).
    accepted : ndarray of bool
        Whether the last update used a measurement, ``()`` or ``(M,)``.
    k : int
        Index of the current step (``-1`` before the first ``predict``); the models read it for per-epoch
        parameters such as a moving beacon.

    Examples
    --------
    A vehicle circling a beacon, 3 runs, its position observed by the range to the beacon:

    >>> import numpy as np
    >>> from uwtutor.filters import ExtendedKalmanFilter
    >>> from uwtutor.models import DeadReckoning, RangeToBeacon
    >>> theta = np.linspace(0.0, 2 * np.pi, 101)
    >>> track = 300.0 * np.column_stack([np.cos(theta), np.sin(theta)])
    >>> rng = np.random.default_rng(0)
    >>> z = np.linalg.norm(track[1:], axis=1) + rng.normal(0.0, 2.0, (3, 100))
    >>> filt = ExtendedKalmanFilter(
    ...     DeadReckoning(np.eye(2) * 0.25),
    ...     RangeToBeacon((0.0, 0.0), R=4.0),
    ...     x0=np.tile(track[0] + [20.0, -15.0], (3, 1)),
    ...     P0=np.eye(2) * 900.0,
    ... )
    >>> result = filt.run(z, u=np.diff(track, axis=0))
    >>> result.x.shape, result.P.shape, result.extras["accepted"].shape
    ((3, 100, 2), (3, 100, 2, 2), (3, 100))
    >>> bool(np.all(np.linalg.norm(result.x[:, -1] - track[-1], axis=-1) < 10.0))
    True
    """

    extra_outputs: tuple[str, ...] = ("accepted",)
    result_type = FilterResult
    # the configuration rule (base.Configurable): the models and the gate are fixed once the filter is built
    _fixed: tuple[str, ...] = ("motion", "measurement", "gate", "n", "m")
    _diagnostics: tuple[str, ...] = ("y", "S", "accepted")

    def __init__(self, motion: MotionModel, measurement: MeasurementModel, x0: ArrayLike, P0: ArrayLike,
                 gate: Gate | None = None, *, known_states: ArrayLike | None = None) -> None:
        _check_model("motion", motion, MotionModel)
        _check_model("measurement", measurement, MeasurementModel)
        if gate is not None and not isinstance(gate, Gate):
            raise TypeError(f"gate must be a uwtutor.filters.Gate (or None); got {type(gate).__name__}")
        n = motion.n
        if measurement.n != n:
            raise ValueError(f"the measurement model reads a state of size {measurement.n} but the motion model's "
                             f"state has size {n}: build both for the same state")
        self.motion, self.measurement, self.gate = motion, measurement, gate
        self.n, self.m = n, measurement.m
        x0 = as_finite("x0", x0, ndim=(1, 2), nonempty=True)
        if x0.shape[-1] != n:
            raise ValueError(f"x0 must have {n} entries per run (the models' state size); got shape {x0.shape}")
        P0 = _initial_covariance(P0, n, known_states)
        if P0.ndim not in (2, 3):
            raise ValueError(f"P0 must have shape ({n}, {n}) or (M, {n}, {n}); got {P0.shape}")
        M = common_runs(dict(x0=x0.shape[0] if x0.ndim == 2 else None, P0=P0.shape[0] if P0.ndim == 3 else None))
        self._batched = M is not None
        self._M = M or 1
        self._x = np.array(np.broadcast_to(x0, (self._M, n)))
        self._P = _runs_last(np.broadcast_to(P0, (self._M, n, n)))      # (n, n, M): see _runs_last
        self._x_prior = self._x.copy()
        self._P_prior = self._P.copy()
        self._y = np.full((self._M, self.m), np.nan)
        self._S = np.full((self._M, self.m, self.m), np.nan)
        self._accepted = np.zeros(self._M, dtype=bool)
        self._eye = np.eye(n)
        self._known_states = known_states is not None     # a start with exact states: the generic back-end
        self.k = -1
        self._check_Q = _CovarianceCheck(f"the motion model {type(motion).__name__}.Q", motion, "Q")
        self._check_R = _CovarianceCheck(f"the measurement model {type(measurement).__name__}.R", measurement, "R")
        gate_outputs = tuple(getattr(gate, "extra_outputs", ())) if gate is not None else ()
        clash = set(gate_outputs) & set(dir(type(self))) if gate_outputs else set()
        if clash:
            raise ValueError(f"the gate's extra_outputs {sorted(clash)} clash with the filter's own attributes: "
                             "rename them")
        self._gate_outputs = gate_outputs
        if gate_outputs:
            self.extra_outputs = type(self).extra_outputs + gate_outputs
            self._extra_ruled = frozenset(gate_outputs)          # read-only diagnostics too (base.Configurable)

    def _use_models(self, motion: MotionModel, measurement: MeasurementModel, parameter: str) -> None:
        """Run from the next step on with a new model pair of the same sizes, built by a subclass from a new value
        of its ``parameter`` (``KalmanFilter.Q = ...``: base.Configurable)."""
        if (motion.n, measurement.n, measurement.m) != (self.n, self.n, self.m):
            raise ValueError(f"{parameter} must keep the filter's sizes (state {self.n}, measurement {self.m}); "
                             f"got a model pair with state {motion.n} and measurement {measurement.m}: build a new "
                             f"{type(self).__name__} for other sizes")
        object.__setattr__(self, "motion", motion)
        object.__setattr__(self, "measurement", measurement)
        self._check_Q = _CovarianceCheck(f"the motion model {type(motion).__name__}.Q", motion, "Q")
        self._check_R = _CovarianceCheck(f"the measurement model {type(measurement).__name__}.R", measurement, "R")

    def __getattr__(self, name: str) -> Any:
        # the per-step values a gate names in its extra_outputs, read from the gate (runs axis as for x)
        if name in self.__dict__.get("_gate_outputs", ()):
            value = np.asarray(getattr(self.gate, name))
            if value.shape[:1] != (self._M,):           # before the gate's first step: nothing flagged yet
                value = np.zeros((self._M,) + value.shape[1:], dtype=value.dtype)
            return self._out(value)
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    # -- state access (views of the filter's arrays; assignment is validated) --
    def _out(self, a: np.ndarray) -> np.ndarray:
        """What the protocol's attributes show: a read-only view (write a new ``x`` or ``P`` by assignment)."""
        shown = a if self._batched else a[0]
        return readonly(shown) if isinstance(shown, np.ndarray) else shown       # a scalar is immutable

    @property
    def n_runs(self) -> int:
        """Number of runs ``M`` (1 for an unbatched filter)."""
        return self._M

    @property
    def x(self) -> np.ndarray:
        """Current estimate, ``(n,)`` or ``(M, n)``."""
        return self._out(self._x)

    @x.setter
    def x(self, value: Any) -> None:
        x = as_finite("x", value)
        if x.shape not in ((self.n,), (self._M, self.n)):
            raise ValueError(f"x must have shape ({self.n},) or ({self._M}, {self.n}); got {x.shape}")
        self._x = np.array(np.broadcast_to(x, (self._M, self.n)))

    @property
    def P(self) -> np.ndarray:
        """Current covariance, ``(n, n)`` or ``(M, n, n)``."""
        return self._out(_runs_first(self._P))

    @P.setter
    def P(self, value: Any) -> None:
        P = as_covariance("P", value, self.n)
        if P.shape not in ((self.n, self.n), (self._M, self.n, self.n)):
            raise ValueError(f"P must have shape ({self.n}, {self.n}) or ({self._M}, {self.n}, {self.n}); "
                             f"got {P.shape}")
        self._P = _runs_last(np.broadcast_to(P, (self._M, self.n, self.n)))

    @property
    def x_prior(self) -> np.ndarray:
        """The prediction of the current step, ``(n,)`` or ``(M, n)``."""
        return self._out(self._x_prior)

    @property
    def P_prior(self) -> np.ndarray:
        """The covariance of that prediction, ``(n, n)`` or ``(M, n, n)``."""
        return self._out(_runs_first(self._P_prior))

    @property
    def y(self) -> np.ndarray:
        """Innovation of the last update, ``(m,)`` or ``(M, m)`` (NaN: no measurement used)."""
        return self._out(self._y)

    @property
    def S(self) -> np.ndarray:
        """Its covariance, ``(m, m)`` or ``(M, m, m)`` (NaN: no measurement used)."""
        return self._out(self._S)

    @property
    def accepted(self) -> np.ndarray:
        """Whether the last update used a measurement, ``()`` or ``(M,)``."""
        return self._out(self._accepted)

    # -- the protocol --
    def _step_input(self, u: Any) -> np.ndarray | None:
        if u is None:
            return None
        step = as_finite("u", u)
        if step.ndim == 0 or step.ndim > 2 or (step.ndim == 2 and (not self._batched or step.shape[0] != self._M)):
            want = f"(p,) or ({self._M}, p)" if self._batched else "(p,)"
            raise ValueError(f"u must be the input of one step, shape {want}; got {step.shape}")
        return step

    def predict(self, u: ArrayLike | None = None) -> None:
        """Predict one step: ``x- = f(x, u)``, ``P- = F P F^T + Q`` (``u`` of shape (p,) or (M, p), or None)."""
        u = self._step_input(u)
        if not (self._packed_kernel() and self._packed_predict(u)):
            self._predict(u)

    def _predict(self, u: np.ndarray | None, deferred: bool = False) -> None:
        """The prediction; ``deferred``: leave out the test that f, F and Q are finite (``_run_steps`` tests the
        priors of the whole run instead: a non-finite f, F or Q makes them non-finite)."""
        self.k += 1
        k = self.k
        M, n = self._M, self.n
        x, P = self._x, self._P
        x_new, F, Q = self.motion.linearize(x, u, k)
        F = _batched_matrix("F", F, M, (n, n))
        Q = _batched_matrix("Q", Q, M, (n, n))
        x_new = _real("f", x_new)
        if x_new.shape != (M, n):
            raise ValueError(f"the motion model's f must return shape ({M}, {n}); got {x_new.shape}")
        if not deferred:
            for method, value in (("f", x_new), ("F", F), ("Q", Q)):
                if not np.isfinite(value).all():
                    bad = np.argwhere(~np.isfinite(value))[0]
                    where = (int(bad[0]),) if value.ndim == 3 or method == "f" else ()
                    raise _not_finite_error(self.motion, method, k, where, "")
        self._check_Q(Q)
        if F.ndim == 2 and np.array_equal(F, self._eye):         # dead reckoning: F = I
            P_new = P.copy()
        elif F.ndim == 2:                                         # one F for every run: F P F^T by BLAS
            P_new = np.einsum("ikm,jk->ijm", np.tensordot(F, P, axes=(1, 0)), F)
        else:
            Fc = _runs_last(F)
            P_new = _mm_t(_mm(Fc, P), Fc)
        P_new += Q[:, :, None] if Q.ndim == 2 else _runs_last(Q)
        P_new += P_new.transpose(1, 0, 2)                          # symmetrize: (P + P^T) / 2
        P_new *= 0.5
        self._x = self._x_prior = x_new
        self._P = self._P_prior = P_new

    def _measurement(self, z: Any) -> np.ndarray:
        given = as_float_array("z", z)
        m, M = self.m, self._M
        if given.size == m and (given.ndim <= 1 or not self._batched):
            zm = np.broadcast_to(given.reshape(1, m), (M, m))
        elif self._batched and given.shape in ((M, m),) + (((M,),) if m == 1 else ()):
            zm = given.reshape(M, m)
        else:
            want = f"({M}, {m})" + (f" or ({M},)" if m == 1 else "") if self._batched else f"({m},)"
            raise ValueError(f"z must be one measurement per run, shape {want}; got {given.shape}")
        if np.isinf(zm).any():
            raise ValueError("z must be finite, or NaN for a missing measurement; got an infinite value")
        return zm

    def update(self, z: ArrayLike) -> None:
        """Correct the estimate with ``z`` (``(m,)`` or a scalar; ``(M, m)`` or ``(M,)`` batched); NaN: no update
        (a NaN component: the update uses the components that are present)."""
        z = self._measurement(z)
        if not (self._packed_kernel() and self._packed_update(z)):
            self._update(z)

    def _update(self, z: np.ndarray, deferred: bool = False) -> None:
        """The update with ``z`` (M, m) as ``_measurement`` returns it; ``deferred``: leave out the test that the
        posterior covariance is positive semi-definite (``_run_steps`` tests those of the whole run at once and
        keeps them in ``_P_tested``)."""
        k = max(self.k, 0)
        M, n, m = self._M, self.n, self.m
        x, P = self._x, self._P
        z_pred, H, R, defined = self._linearized(x, k)
        present = self._usable(np.isfinite(z), defined)              # (M, m)
        finite = self._check_used_values(present, z_pred, H, R, k)
        if finite:
            self._check_R(R)
        has = cast(np.ndarray, present.any(axis=1))
        # A run with some components missing, or values that are not finite where nothing is measured: zero rows
        # of H and identity rows of R, so that the update is the one with the present components. (Runs with all or
        # none of their components take the plain path, as they always did: the gain of the latter is zeroed.)
        masked = not finite or bool((has & ~present.all(axis=1)).any())
        if masked:
            H, R = _masked(H, R, present)
        Hc, Rc, PHT, S = _innovation_covariance(P, H, R)
        y = self.measurement.residual(z, z_pred)
        use, used = has, present                                     # per run (M,), per component (M, m)
        if self.gate is not None:
            use, used = self._gate_verdict(self.gate, GateContext(
                k=k, z=z, z_pred=z_pred, y=np.where(present, y, np.nan), S=_runs_first(S), H=H, R=R, x_prior=x,
                P_prior=_runs_first(P), present=present), has)
            narrowed = use & (used != present).any(axis=1)           # some of a run's components rejected
            if narrowed.any():                                       # mask those too, then recompute S
                H, R = _masked(H, np.broadcast_to(R, (M, m, m)), np.where(use[:, None], used, present))
                Hc, Rc, PHT, S = _innovation_covariance(P, H, R)
                masked = True
        used = used & use[:, None]
        x_post, P_post = _joseph_update(x, P, PHT, S, Hc, Rc, use, np.where(used, y, 0.0), self._eye)
        if deferred:
            self._P_tested = P_post
        else:
            _refuse_lost_psd(P_post, Rc, k)
        S = _runs_first(S)
        if self.gate is not None:
            P_in = _runs_first(P_post)
            x_post, P_first = _gate_estimate(self.gate, self.gate.after_update(x_post, P_in, use.copy(), k), x_post,
                                             P_in, M, n)
            P_post = _runs_last(P_first)
        self._x, self._P = x_post, P_post
        if not masked:
            self._y = np.where(use[:, None], y, np.nan)
            self._S = np.where(use[:, None, None], S, np.nan)
        else:
            self._y = np.where(used, y, np.nan)
            self._S = np.where(used[:, :, None] & used[:, None, :], S, np.nan)
        self._accepted = use

    def _linearized(self, x: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, Any]:
        """The measurement model's prediction (M, m), Jacobian (M, m, n), noise and "defined" mask, shapes checked."""
        M, n, m = self._M, self.n, self.m
        z_pred, H, defined = self.measurement.linearize(x, k)
        z_pred = _real("h", z_pred)
        if z_pred.size != M * m:
            raise ValueError(f"the measurement model's h must return shape ({M}, {m}); got {z_pred.shape}")
        z_pred = z_pred.reshape(M, m)
        H = _real("H", H)
        if H.shape != (M, m, n):
            raise ValueError(f"the measurement model's H must have shape ({M}, {m}, {n}); got {H.shape}")
        R = _batched_matrix("R", self.measurement.R(x, k), M, (m, m))
        return z_pred, H, R, defined

    def _usable(self, present: np.ndarray, defined: Any) -> np.ndarray:
        """The components (M, m) measured where the model is defined; a warning where a measured one is not."""
        mask = _defined_mask(defined, self._M, self.m)
        if mask.all():
            return present
        if (present & ~mask).any():
            per_run = bool((mask == mask[:, :1]).all())
            warn("the predicted position is exactly on the beacon, where the range Jacobian is undefined: "
                 + ("the update is skipped for that step (predict only)" if per_run else
                    "that range is skipped at this step (the others are used)"), BeaconSingularityWarning)
        usable: np.ndarray = present & mask
        return usable

    def _gate_verdict(self, gate: Gate, ctx: GateContext, has: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The gate's accept, checked: which runs (M,) and which components (M, m) the update uses."""
        M, m = self._M, self.m
        verdict = as_bool_array(f"the gate {type(gate).__name__}.accept", gate.accept(ctx), ((M,), (M, m)))
        present = ctx.present_mask()
        if verdict.shape == (M,):
            return has & verdict, present
        if verdict.shape == (M, m):
            used = present & verdict
            return used.any(axis=1), used
        raise ValueError(f"the gate's accept must return a bool array of shape ({M},) or ({M}, {m}); got "
                         f"{verdict.shape}")

    def _check_used_values(self, present: np.ndarray, z_pred: np.ndarray, H: np.ndarray, R: np.ndarray,
                           k: int) -> bool:
        """Refuse a non-finite prediction, Jacobian row or noise where a measurement is present (elsewhere it is
        never used); return whether every value is finite."""
        with np.errstate(over="ignore", invalid="ignore"):
            if np.isfinite(z_pred.sum() + H.sum() + R.sum()):        # one test for the usual case
                return True
        if np.isfinite(z_pred).all() and np.isfinite(H).all() and np.isfinite(R).all():
            return True                                               # finite, only their sum overflowed
        model = self.measurement
        own = type(model).linearize is not MeasurementModel.linearize
        what = " where a measurement is present"
        bad = present & ~np.isfinite(z_pred)
        if bad.any():
            raise _not_finite_error(model, "linearize" if own else "h", k, tuple(int(i) for i in np.argwhere(bad)[0]),
                                    what)
        bad = present & ~np.isfinite(H).all(axis=-1)
        if bad.any():
            raise _not_finite_error(model, "linearize" if own else "H", k, tuple(int(i) for i in np.argwhere(bad)[0]),
                                    what)
        Rb = np.broadcast_to(R, (len(present),) + R.shape[-2:])
        bad = present[:, :, None] & present[:, None, :] & ~np.isfinite(Rb)
        if bad.any():
            run, i, _ = (int(v) for v in np.argwhere(bad)[0])
            raise _not_finite_error(model, "R", k, (run, i), what)
        return False

    def run(self, z: ArrayLike, u: ArrayLike | None = None, times: ArrayLike | None = None, *,
            keep_priors: bool = True) -> FilterResult:
        """Predict with ``u[..., k, :]`` then update with ``z[..., k]`` for every step (see
        :func:`~uwtutor.filters.base.run_filter`); the filter is left at the last step.

        ``z`` has shape (K,) or (K, m) -- (M, K) or (M, K, m) for a batched filter -- with NaN for missing
        measurements; ``u`` has shape (K, p) or (M, K, p), or is None. ``keep_priors=False``: the result's
        ``x_prior`` and ``P_prior`` are None (see :func:`extended_kalman_filter`).
        """
        z = as_float_array("z", z)
        _check_nonnegative(self.measurement, z)
        keep_priors = as_flag("keep_priors", keep_priors)
        packed = self._packed_run(z, u, times, keep_priors)           # the plain range pair: the packed back-end
        if packed is not None:
            return packed
        fast = self._run_steps(z, u, times, keep_priors)
        if fast is not None:
            return fast
        result = run_filter(self, z, u, times)
        return result if keep_priors else dataclasses.replace(result, x_prior=None, P_prior=None)

    def _run_steps(self, z: np.ndarray, u: Any, times: Any, keep_priors: bool = True) -> FilterResult | None:
        """``run_filter(self, z, u, times)`` with the per-step cost of its checks taken out, or None where it does
        not apply (then ``run_filter`` runs the steps, and says what is wrong with the inputs, if anything is).

        The same arithmetic, step by step (``_predict`` and ``_update``), recorded into arrays allocated once. What
        ``predict``, ``update`` and ``run_filter`` test at every step is tested here once for the whole run, before
        (the inputs: shapes, u finite, z not infinite) or after (every prior finite, every posterior covariance
        PSD, as ``_refuse_lost_psd`` tests it; a non-finite f, F or Q shows in the priors). Anything out of the
        ordinary -- a test that fails, an exception, a warning -- puts the filter (and its gate) back as they were
        and returns None: ``run_filter`` then runs the steps with every check in its place and raises or warns
        at the step where it should. So the result is bit for bit ``run_filter``'s, and so is every error.

        It applies to the library's own models and gates (whose methods keep no state between calls, so that a
        run can be done again), and to this class or a subclass that leaves ``predict``, ``update`` and the
        recorded attributes alone. Without ``keep_priors`` the priors are summed step by step for the test
        instead of being recorded.
        """
        if not self._plain_steps():
            return None
        M, m, n = self._M, self.m, self.n
        z_steps = self._run_measurements(z)
        if z_steps is None:
            return None
        K = len(z_steps)
        u_steps = None
        if u is not None:
            u_steps = self._u_steps(as_float_array("u", u), K)
            if u_steps is None:
                return None
        try:
            times = _sequence_times(K, times)
        except (TypeError, ValueError):
            return None
        saved = (self._x, self._P, self._x_prior, self._P_prior, self._y, self._S, self._accepted, self.k)
        gate_state = copy.deepcopy(self.gate.__dict__) if self.gate is not None else None
        x = np.empty((K, M, n))
        P = np.empty((K, M, n, n))
        x_prior: np.ndarray | None = np.empty_like(x) if keep_priors else None
        P_prior: np.ndarray | None = np.empty_like(P) if keep_priors else None
        prior_sum = 0.0                                          # without keep_priors: the priors' finiteness test
        y = np.empty((K, M, m))
        S = np.empty((K, M, m, m))
        accepted = np.empty((K, M), dtype=bool)
        tested = np.empty((n, n, K, M))                          # the posteriors before a gate, runs-last
        extra = self._gate_outputs
        extras: dict[str, list[Any]] = {name: [] for name in extra}
        try:
            # the caller's warning filters stay: a warning they would show is recorded (and the steps are run
            # again by run_filter, which shows it), one they ignore is ignored, one they turn into an error raises
            with warnings.catch_warnings(record=True) as caught:
                for k in range(K):
                    checkpoint()                                 # a widget's refinement no longer wanted stops here
                    self._predict(None if u_steps is None else u_steps[k], deferred=True)
                    if x_prior is not None and P_prior is not None:
                        x_prior[k] = self._x_prior
                        P_prior[k] = _runs_first(self._P_prior)
                    else:
                        prior_sum += self._x_prior.sum() + self._P_prior.sum()
                    self._update(z_steps[k], deferred=True)
                    tested[:, :, k] = self._P_tested
                    x[k] = self._x
                    P[k] = _runs_first(self._P)
                    y[k] = self._y
                    S[k] = self._S
                    accepted[k] = self._accepted
                    for name in extra:
                        extras[name].append(np.array(getattr(self, name)))
            with np.errstate(over="ignore", invalid="ignore"):
                if x_prior is not None and P_prior is not None:
                    prior_sum = x_prior.sum() + P_prior.sum()
                sound = not caught and bool(np.isfinite(prior_sum)) and \
                    not psd_violations(tested.reshape(n, n, K * M)).any()
        except Exception:
            sound = False
        if not sound:
            self._restore(saved, gate_state)
            return None
        fields = dict(x=x, P=P, x_prior=x_prior, P_prior=P_prior, innovations=y, innovation_cov=S)
        return self._as_result(times, fields, {"accepted": accepted, **{name: np.stack(v) for name, v in
                                                                         extras.items()}})

    def _plain_steps(self) -> bool:
        """Whether ``_run_steps`` applies: the library's own models and gate, and this class's steps and attributes."""
        cls = type(self)
        if not (cls.predict is ExtendedKalmanFilter.predict and cls.update is ExtendedKalmanFilter.update
                and cls._out is ExtendedKalmanFilter._out and _library(self.motion)
                and _library(self.measurement) and (self.gate is None or _library(self.gate))):
            return False
        extra = tuple(name for name in self.extra_outputs if name != "accepted")
        return extra == self._gate_outputs and all(getattr(cls, name) is getattr(ExtendedKalmanFilter, name)
                                                   for name in ("x", "P", "x_prior", "P_prior", "y", "S", "accepted"))

    def _run_measurements(self, z: np.ndarray) -> np.ndarray | None:
        """The measurements of a run's steps (K, M, m) as ``update(z[k])`` sees them; None where ``z`` has no step
        axis of its own, another number of runs, a shape ``update`` does not take, or an infinite value."""
        batched = self._batched
        step_axis = 1 if batched else 0
        if z.ndim <= step_axis or (batched and z.shape[0] != self._M) or z.shape[step_axis] < 1:
            return None
        z_steps = self._z_steps(z, z.shape[step_axis])
        if z_steps is None or np.isinf(z).any():
            return None
        return z_steps

    def _z_steps(self, z: np.ndarray, K: int) -> np.ndarray | None:
        """The K steps' measurements (K, M, m) as ``update(z[k])`` sees them; None for a shape it does not take."""
        batched, M, m = self._batched, self._M, self.m
        z_step = z.shape[1:] if not batched else (M,) + z.shape[2:]          # the shape update(z[k]) sees
        steps = np.moveaxis(z, 1, 0) if batched else z
        if int(np.prod(z_step)) == m and (len(z_step) <= 1 or not batched):
            return np.broadcast_to(steps.reshape(K, 1, m), (K, M, m))
        if batched and z_step in ((M, m),) + (((M,),) if m == 1 else ()):
            return steps.reshape(K, M, m)
        return None

    def _u_steps(self, u: np.ndarray, K: int) -> np.ndarray | None:
        """The K steps' inputs, steps first, as ``predict(u[k])`` sees them; None if not finite or not its shape."""
        batched, M = self._batched, self._M
        u_shared = batched and u.ndim == 2
        u_axis = 0 if u_shared else (1 if batched else 0)
        if u.ndim <= u_axis or u.shape[u_axis] != K or not np.isfinite(u).all():
            return None
        u_step = u.shape[1:] if u_shared or not batched else (u.shape[0],) + u.shape[2:]
        if len(u_step) == 0 or len(u_step) > 2 or (len(u_step) == 2 and (not batched or u_step[0] != M)):
            return None
        return u if u_shared or not batched else np.moveaxis(u, 1, 0)

    def _restore(self, saved: tuple[Any, ...], gate_state: dict[str, Any] | None) -> None:
        """Put the filter's state and its gate's back as ``_run_steps`` found them."""
        (self._x, self._P, self._x_prior, self._P_prior, self._y, self._S, self._accepted, self.k) = saved
        if gate_state is not None:
            self.gate.__dict__.clear()
            self.gate.__dict__.update(gate_state)

    def _as_result(self, times: np.ndarray, fields: dict[str, np.ndarray | None],
                   recorded: dict[str, np.ndarray]) -> FilterResult:
        """The result from the step-first arrays (K, M, ...): runs first, or no runs axis for an unbatched filter."""
        batched = self._batched
        stacked: dict[str, Any] = {name: None if h is None else np.moveaxis(h, 0, 1) if batched else h[:, 0]
                                   for name, h in fields.items()}
        if not batched:
            recorded = {**recorded, "accepted": recorded["accepted"][:, 0]}
        return self.result_type(times=times, **stacked,
                                extras={name: np.moveaxis(h, 0, 1) if batched else h for name, h in recorded.items()})

    # -- the packed back-end (filters.ekf) of the plain range-only pair --
    #: True in a subclass whose predict, update and run check their arguments by their own rules and then run this
    #: class's steps (``RangeOnlyEKF``): the packed back-end applies to it as to this class
    _engine_steps = False

    def _packed_kernel(self) -> bool:
        """Whether this filter runs on the packed 2x2 back-end (module docstring, "Back-ends"): the library's
        ``DeadReckoning`` on a 2-state and ``RangeToBeacon`` without a bias, no gate, no known states, and this
        class's steps (or those of a subclass that declares ``_engine_steps``)."""
        if self.gate is not None or self._known_states or self.n != 2:
            return False
        motion, measurement = self.motion, self.measurement
        if type(motion) is not DeadReckoning or type(measurement) is not RangeToBeacon \
                or measurement.bias_index is not None:
            return False
        return type(self)._engine_steps or self._plain_steps()

    def _packed_bounded(self, *arrays: np.ndarray) -> bool:
        """Whether the state and ``arrays`` (NaN allowed) lie within the coordinate bound that the packed arithmetic
        squares without overflow (``_validate.MAX_COORDINATE``, which ``range_only_ekf`` asks of its inputs); beyond
        it the generic arithmetic, whose ranges are computed without overflow, runs the step."""
        return all(not (np.abs(a) > MAX_COORDINATE).any() for a in (self._x,) + arrays)

    def _packed_process_noise(self, first: int, K: int) -> np.ndarray | None:
        """``Q`` of steps ``first..first+K-1`` packed as ``[Qxx, Qxy, Qxy, Qyy]``: a (4, 1) column, or (K, 4, 1) for a
        per-step ``Q``; None where the model has no ``Q`` for one of them (the generic step then says so)."""
        motion = cast(DeadReckoning, self.motion)                  # _packed_kernel has checked the type
        steps = motion.n_steps
        if steps is None:
            Q = motion.Q(self._x, None, first)
            return np.array([Q[0, 0], Q[0, 1], Q[0, 1], Q[1, 1]]).reshape(4, 1)
        if first < 0 or first + K > steps:
            return None
        Q = np.stack([motion.Q(self._x, None, k) for k in range(first, first + K)])
        return np.stack([Q[:, 0, 0], Q[:, 0, 1], Q[:, 0, 1], Q[:, 1, 1]], axis=1)[:, :, None]

    def _packed_measurement(self, first: int, K: int, present: np.ndarray
                            ) -> tuple[Any, tuple[float, float] | np.ndarray] | None:
        """The range variance of steps ``first..first+K-1`` (a float, or (K,) one per step) and the beacon (a fixed
        ``(bx, by)``, or a step-major path (K, 2, M) or (K, 2, 1)), as the packed back-end takes them; None where the
        model has none for a step, an ``R`` per run, or a NaN ``R`` where a range is present (``present`` (K, M)):
        the generic steps then raise what they raise there."""
        measurement, M = cast(RangeToBeacon, self.measurement), self._M     # checked by _packed_kernel
        b = measurement.beacon
        beacon: tuple[float, float] | np.ndarray
        if not self._packed_bounded(b):
            return None
        if b.ndim == 1:
            beacon = (float(b[0]), float(b[1]))
        elif first < 0 or first + K > b.shape[-2] or (b.ndim == 3 and b.shape[0] != M):
            return None
        elif b.ndim == 2:
            beacon = np.ascontiguousarray(b[first:first + K, :, None])
        else:
            beacon = np.ascontiguousarray(np.moveaxis(b[:, first:first + K], 0, -1))
        try:
            R_steps = [measurement.R(self._x, k) for k in range(first, first + K)]
        except IndexError:
            return None
        if any(np.shape(R) != (1, 1) for R in R_steps):
            return None
        if all(R is R_steps[0] for R in R_steps):           # one variance for every step
            R = float(R_steps[0][0, 0])
            return (R, beacon) if np.isfinite(R) else None
        R_var = np.array([R[0, 0] for R in R_steps])
        missing = np.isnan(R_var)
        if missing.any():
            if (missing[:, None] & present).any():
                return None
            R_var[missing] = 1.0                            # any finite value: no range is used at those steps
        return R_var, beacon

    def _packed_state(self) -> np.ndarray:
        """The filter's state as the packed back-end holds it: one (6, M) array."""
        return pack_runs_last(self._x, self._P)

    def _set_packed_state(self, post: np.ndarray, prior: np.ndarray) -> None:
        """The filter's state (and its prediction) from the packed posterior and prior (6, M)."""
        self._x, self._P = unpack_runs_last(post)
        self._x_prior, self._P_prior = unpack_runs_last(prior)

    def _packed_predict(self, u: np.ndarray | None) -> bool:
        """``predict`` on the packed back-end; False (nothing done) where it does not apply to ``u`` or the step."""
        M = self._M
        if u is None:
            u_col = np.zeros((2, 1))
        elif u.shape == (2,):
            u_col = u[:, None]
        elif u.shape == (M, 2) and self._batched:
            u_col = u.T
        else:
            return False
        q4 = self._packed_process_noise(self.k + 1, 1) if self._packed_bounded(u_col) else None
        if q4 is None:
            return False
        self.k += 1
        out = np.empty((6, M))
        predict_step(self._packed_state(), u_col, q4[0] if q4.ndim == 3 else q4, out)
        self._set_packed_state(out, out)
        return True

    def _packed_update(self, z: np.ndarray) -> bool:
        """``update`` with ``z`` (M, 1) on the packed back-end; False (nothing done) where it does not apply."""
        M = self._M
        has = np.isfinite(z[:, 0])
        found = self._packed_measurement(max(self.k, 0), 1, has[None, :]) if self._packed_bounded(z) else None
        if found is None:
            return False
        R, beacon = found
        if isinstance(R, np.ndarray):
            R = float(R[0])
        if not isinstance(beacon, tuple):
            beacon = (beacon[0, 0], beacon[0, 1])
        out = np.empty((6, M))
        y = np.empty(M)
        S = np.empty(M)
        prior = self._packed_state()
        used = update_step(prior, np.where(has, z[:, 0], 0.0), has.astype(float), R, beacon, out, y, S)
        unused = used == 0.0
        y[unused] = np.nan
        S[unused] = np.nan
        self._x, self._P = unpack_runs_last(out)
        self._y, self._S, self._accepted = y[:, None], S[:, None, None], ~unused
        return True

    def _packed_run(self, z: np.ndarray, u: Any, times: Any, keep_priors: bool) -> FilterResult | None:
        """``run`` on the packed back-end (:func:`uwtutor.filters.ekf._run`, the loop of ``range_only_ekf``), or None
        where it does not apply (another model pair, a gate; inputs that ``run_filter`` must judge step by step)."""
        if not self._packed_kernel():
            return None
        batched = self._batched
        z_steps = self._run_measurements(z)
        if z_steps is None:
            return None
        K = len(z_steps)
        if u is None:
            u_in = np.zeros((K, 2))
        else:
            u_steps = self._u_steps(as_float_array("u", u), K)
            if u_steps is None or u_steps.shape[-1] != 2:
                return None
            u_in = u_steps if u_steps.ndim == 2 else np.moveaxis(u_steps, 0, 1)     # (K, 2) or (M, K, 2)
        try:
            times = _sequence_times(K, times)
        except (TypeError, ValueError):
            return None
        if not self._packed_bounded(z, u_in):
            return None
        z_runs = z_steps[:, :, 0]                                                   # (K, M)
        return self._packed_steps(u_in, z_runs.T if batched else z_runs[:, 0], times, keep_priors)

    def _packed_steps(self, u: np.ndarray, z: np.ndarray, times: np.ndarray, keep_priors: bool,
                      noise: tuple[np.ndarray, Any, Any] | None = None, key: str = "accepted") -> FilterResult | None:
        """The packed loop over checked inputs: ``u`` (K, 2) or (M, K, 2), ``z`` (K,) or (M, K) (finite or NaN);
        ``noise``: the packed ``Q``, ``R`` and beacon when the caller has them already (``range_only_ekf``); ``key``:
        the name of the result's extra that says which steps used a range. Leaves the filter at the last step; None
        where the models have no parameters for these steps."""
        from .ekf import _run                   # deferred: filters.ekf builds RangeOnlyEKF on this module

        K, first = len(times), self.k + 1
        if noise is None:
            q4 = self._packed_process_noise(first, K)
            present = np.isfinite(np.broadcast_to(z, (self._M, K))).T
            found = self._packed_measurement(first, K, present)
            if q4 is None or found is None:
                return None
            noise = (q4, *found)
        q4, R, beacon = noise
        result, post, prior = _run(self._packed_state(), u, z, q4, R, beacon, times, self._batched, keep_priors)
        self._set_packed_state(post, prior)
        self.k += K
        y, S, updated = result.innovations, result.innovation_cov, result.extras["updated"]
        self._y = np.array(y[..., -1, :], ndmin=2)
        self._S = np.array(S[..., -1, :, :], ndmin=3)
        self._accepted = np.array(updated[..., -1], ndmin=1)
        return result if key == "updated" else dataclasses.replace(result, extras={key: updated})


def extended_kalman_filter(motion: MotionModel, measurement: MeasurementModel, x0: ArrayLike, P0: ArrayLike,
                           u: ArrayLike | None, z: ArrayLike, *,
        times: ArrayLike | None = None, gate: Gate | None = None, known_states: ArrayLike | None = None,
        keep_priors: bool = True) -> FilterResult:
    r"""Run the generic extended Kalman filter over whole sequences, one run or ``M`` at once.

    The functional form of :class:`ExtendedKalmanFilter`: the argument order of every functional filter of the
    library, ``(x0, P0, u, z, ...)``, after the two models.

    Parameters
    ----------
    motion, measurement : MotionModel, MeasurementModel
        The model pair (see :mod:`uwtutor.models`).
    x0 : array_like, shape (n,) or (M, n)
        Initial state.
    P0 : array_like, shape (n, n) or (M, n, n)
        Initial covariance.
    u : array_like, shape (K, p) or (M, K, p), or None
        The input of each step (e.g. the DR displacement).
    z : array_like, shape (K,), (K, m), (M, K) or (M, K, m)
        The measurements, NaN where missing (predict only); for a vector, a NaN component is missing (the update
        uses the others). A scalar measurement may come as a column (K, 1) when ``u`` or ``times`` has K steps.
    times : array_like, shape (K,), optional
        Time stamps for the result.
    gate : Gate, optional
        Outlier test applied to each innovation.
    known_states : array_like of bool, shape (n,) or (M, n), optional
        States known exactly at the start: ``P0`` is 0 in their rows and columns (and positive definite on the
        others). A known state whose process noise is 0 stays known: its gain and its rows of ``P`` stay exactly
        0, so the other states see the model with that state fixed. Runs that pin different states are variants
        of one model stepped as one batch (:func:`uwtutor.datasets.navigate` runs its candidate models so).
    keep_priors : bool, default True
        Keep the predictions ``x_prior`` and ``P_prior`` in the result. False: they are None and every other
        field is the same, bit for bit. They are almost half of a result's memory; a study that needs only the
        estimates (or their errors, or NEES) can leave them out. The smoother needs them.

    Returns
    -------
    FilterResult
        ``x`` (…, K, n), ``P`` (…, K, n, n), the priors, ``innovations`` (…, K, m), ``innovation_cov``
        (…, K, m, m) and ``extras["accepted"]`` (…, K), True where a measurement was used.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.filters import extended_kalman_filter
    >>> from uwtutor.models import DeadReckoning, RangeToBeacon
    >>> u = np.tile([1.0, 0.0], (50, 1))                       # 1 m east per step
    >>> truth = np.array([50.0, 100.0]) + np.cumsum(u, axis=0)
    >>> ship = (
    ...     truth
    ...     + [0.0, -300.0]
    ...     + np.column_stack([np.zeros(50), np.linspace(0, 50, 50)])
    ... )
    >>> # exact ranges to a moving beacon
    >>> z = np.linalg.norm(truth - ship, axis=1)
    >>> res = extended_kalman_filter(
    ...     DeadReckoning(np.eye(2) * 0.01),
    ...     RangeToBeacon(ship, R=1.0),
    ...     [60.0, 90.0],
    ...     np.eye(2) * 100.0,
    ...     u,
    ...     z,
    ... )
    >>> bool(np.linalg.norm(res.x[-1] - truth[-1]) < np.linalg.norm([10.0, 10.0]))
    True
    """
    _check_model("motion", motion, MotionModel)
    _check_model("measurement", measurement, MeasurementModel)
    x0 = as_finite("x0", x0, ndim=(1, 2), nonempty=True)
    if x0.shape[-1] != motion.n:          # before any broadcasting: (M, 1) must not become (M, n)
        raise ValueError(f"x0 must have {motion.n} entries per run (the models' state size); got shape {x0.shape}")
    P0 = _initial_covariance(P0, motion.n, known_states)
    z = as_float_array("z", z, nonempty=True)
    if u is not None:
        u = as_finite("u", u)
    # A scalar measurement given as a column (K, 1) -- e.g. the ranges to one beacon taken from a table of several --
    # is one run of K steps, not K runs of one step, when u or times say the run has K steps.
    steps_hint = u.shape[-2] if u is not None and u.ndim >= 2 else (None if times is None else np.size(times))
    if measurement.m == 1 and z.ndim == 2 and z.shape[1] == 1 and z.shape[0] == steps_hint != 1:
        z = z[:, 0]
    # The runs axis may come from any input; the others are shared by every run.
    single_z_ndim = 1 if measurement.m == 1 else 2
    sizes = {
        "x0": x0.shape[0] if x0.ndim == 2 else None,
        "P0": P0.shape[0] if P0.ndim == 3 else None,
        "known_states": np.asarray(known_states).shape[0] if np.ndim(np.asarray(known_states)) == 2 else None,
        "z": z.shape[0] if z.ndim > single_z_ndim else None,
        "u": u.shape[0] if u is not None and u.ndim == 3 else None,
        "the measurement model": getattr(measurement, "n_runs", None),
        "the motion model": getattr(motion, "n_runs", None),
    }
    M = common_runs(sizes)
    if M is not None:
        x0 = np.broadcast_to(x0, (M, motion.n))
        if z.ndim == single_z_ndim:
            z = np.broadcast_to(z, (M,) + z.shape)
        if u is not None and u.ndim == 2:
            u = np.broadcast_to(u, (M,) + u.shape)
    filt = ExtendedKalmanFilter(motion, measurement, x0, P0, gate=gate, known_states=known_states)
    return filt.run(z, u, times, keep_priors=keep_priors)


def _check_nonnegative(measurement: MeasurementModel, z: np.ndarray) -> None:
    """Refuse a negative measurement of a model that measures ranges (``measurement.nonnegative``), by name."""
    if getattr(measurement, "nonnegative", False):
        negative = z < 0                                         # NaN (a missing range) compares False
        if negative.any():
            where = tuple(int(i) for i in np.argwhere(negative)[0])
            at = "the value" if not where else f"index {where if len(where) > 1 else where[0]}"
            raise ValueError(f"z must be >= 0 ({type(measurement).__name__} measures ranges; NaN marks a missing "
                             f"one); got {z[where]:g} at {at}")
