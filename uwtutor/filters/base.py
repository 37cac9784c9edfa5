"""The filter protocol that every filter of ``uwtutor`` follows, and the one loop that runs them.

A filter holds its estimate in attributes that mean the same thing in every filter,

* ``x`` -- the state estimate, shape ``(n,)`` for one run or ``(M, n)`` for ``M`` Monte Carlo runs at once;
* ``P`` -- its covariance, shape ``(n, n)`` or ``(M, n, n)`` (for a particle filter: the weighted moments of
  its particles);
* ``x_prior``, ``P_prior`` -- the prediction the last update started from, as the filter finally used it (a
  fading filter's ``P_prior`` includes its fading factor);
* ``y``, ``S`` -- the innovation of the last update and its covariance, ``(m,)`` and ``(m, m)`` (runs axis first
  when batched), NaN where there was nothing to update with;
* ``extra_outputs`` -- the names of further per-step attributes the filter records (fading factors, outlier
  flags, effective sample sizes...);

One rule holds for all of them: what a filter shows is **read-only** (writing into ``f.x`` raises, so a change is
never silently lost or slipped past the checks), and it does not change with later steps (keep it as a snapshot). A
Kalman-family filter takes a new estimate by assignment, ``f.x = ...`` or ``f.P = ...``, checked like its
constructor's ``x0`` and ``P0`` (the fading filter between steps only); a particle filter's ``x`` and ``P`` are the
moments of its particles, so a new state is given as ``f.particles = ...`` (or ``f.weights``), and they follow.

It moves its estimate with two methods,

* ``predict(u=None)`` -- propagate the estimate one step with the motion model and the input ``u``
  (for single-beacon navigation: the dead-reckoned displacement since the last step);
* ``update(z)`` -- correct it with the measurement ``z``. A NaN measurement means "no measurement at this step":
  the filter then keeps its prediction.

``run(z, u=None, times=None)`` runs it over a whole sequence and returns a :class:`FilterResult` (or a
subclass), the same, field for field, as :func:`run_filter` ``(filt, z, u, times)``, the library's one step loop.
A filter may run its sequence faster than that loop (the packed range-only EKF does), but its result must equal
the loop's: ``tests/test_filter_contract.py`` holds every filter to this.

The same rule holds for a filter's **configuration** (``Configurable``): its noise covariances ``Q`` and ``R``
and its other parameters either take effect when assigned (``f.Q = ...`` is checked like the constructor's ``Q``,
and everything computed from it is computed again, so the next step uses it) or refuse the assignment with a
message saying to build a new filter; they are shown read-only (``f.Q[0, 0] = 1`` raises). The diagnostics of the
last step (``y``, ``S`` and the ``extra_outputs``) are read-only: assigning them raises.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field, fields
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike

from .._cancel import checkpoint
from .._linalg import quadratic_form
from .._validate import as_float_array, as_int

__all__ = ["Filter", "FilterResult", "run_filter"]


class Configurable:
    """The configuration rule of every filter: assigned parameters take effect or are refused; diagnostics are
    read-only.

    A filter class names, after its constructor has run:

    * ``_parameters`` -- attributes that take effect when assigned: ``f.Q = value`` calls ``f._apply(name, value)``,
      which validates the value as the constructor does and computes again what depends on it;
    * ``_fixed`` -- attributes fixed at construction (a model, a formulation): assigning one raises
      ``AttributeError`` saying to build a new filter;
    * ``_diagnostics`` -- what the last step computed (``y``, ``S``; the ``extra_outputs`` always are): assigning
      raises ``AttributeError``; the filter itself sets them with :meth:`_set_diagnostic`.

    The rule starts to hold when the constructor of the filter's own class returns.
    """

    _parameters: tuple[str, ...] = ()
    _fixed: tuple[str, ...] = ()
    _diagnostics: tuple[str, ...] = ()

    #: every name the rule governs (computed per class); an instance may add more (a gate's extra outputs)
    _ruled: frozenset[str] = frozenset()

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        cls._ruled = frozenset(cls._parameters + cls._fixed + cls._diagnostics + tuple(getattr(cls, "extra_outputs",
                                                                                             ())))
        init = cls.__dict__.get("__init__")
        if init is None:
            return

        @functools.wraps(init)
        def __init__(self: Any, *args: Any, **kw: Any) -> None:
            init(self, *args, **kw)
            if type(self).__init__ is __init__:          # the constructor of the filter's own class has returned
                object.__setattr__(self, "_configured", True)
        cls.__init__ = __init__                             # type: ignore[method-assign]

    def __setattr__(self, name: str, value: Any) -> None:
        # the filters' own state is private (``_x``, ``_P``...): it passes at the cost of one comparison
        if name[0] != "_" and (name in self._ruled or name in self.__dict__.get("_extra_ruled", ())) \
                and self.__dict__.get("_configured", False):
            self._assign(name, value)
            return
        object.__setattr__(self, name, value)

    def _assign(self, name: str, value: Any) -> None:
        cls = type(self).__name__
        if name in self._parameters:
            self._apply(name, value)
            return
        if name in self._fixed:
            raise AttributeError(f"{name} of a {cls} is fixed when the filter is built (everything the filter "
                                 f"computes depends on it): build a new {cls} with the {name} you want")
        raise AttributeError(f"{name} of a {cls} is what the last step computed (read-only); to change the filter, "
                             "assign its state (x, P) or its parameters")

    def _apply(self, name: str, value: Any) -> None:
        """Validate a new value of the parameter ``name`` and compute again what depends on it."""
        raise NotImplementedError(f"{type(self).__name__} lists {name} in _parameters but does not apply it")

    def _set_diagnostic(self, name: str, value: Any) -> None:
        """Set a diagnostic of the last step (shown read-only)."""
        if isinstance(value, np.ndarray):
            value = value.view()
            value.flags.writeable = False
        object.__setattr__(self, name, value)


@runtime_checkable
class Filter(Protocol):
    """Structural type of a uwtutor filter (see the module docstring for what each member means).

    Examples
    --------
    A Kalman filter has every member of the protocol, so the one step loop runs it:

    >>> import numpy as np
    >>> from uwtutor.filters import Filter, KalmanFilter, run_filter
    >>> kf = KalmanFilter.constant_velocity(
    ...     dt=1.0, q=0.01, r=4.0, x0=[0.0, 1.0], P0=np.eye(2)
    ... )
    >>> isinstance(kf, Filter)
    True
    >>> run_filter(kf, [1.2, 1.9, 3.1]).x.shape
    (3, 2)
    """

    # read-only in the protocol (a filter shows them read-only; a Kalman-family filter may also accept ``f.x = ...``)
    @property
    def x(self) -> np.ndarray: ...  # pragma: no cover - protocol

    @property
    def P(self) -> np.ndarray: ...  # pragma: no cover - protocol

    @property
    def x_prior(self) -> np.ndarray: ...  # pragma: no cover - protocol

    @property
    def P_prior(self) -> np.ndarray: ...  # pragma: no cover - protocol

    @property
    def y(self) -> np.ndarray: ...  # pragma: no cover - protocol

    @property
    def S(self) -> np.ndarray: ...  # pragma: no cover - protocol

    extra_outputs: tuple[str, ...]

    def predict(self, u: ArrayLike | None = None) -> None:  # pragma: no cover - protocol
        ...

    def update(self, z: ArrayLike) -> None:  # pragma: no cover - protocol
        ...

    def run(self, z: ArrayLike, u: ArrayLike | None = None,
            times: ArrayLike | None = None) -> "FilterResult":  # pragma: no cover - protocol
        ...


@dataclass(frozen=True)
class FilterResult:
    """Everything a filter run produced, as plain arrays with the time axis first after any runs axis.

    Attributes
    ----------
    times : ndarray, shape (K,)
        Time of each step (step indices when no times were given).
    x : ndarray, shape (K, n) or (M, K, n)
        Posterior state estimate after each step's update.
    P : ndarray, shape (K, n, n) or (M, K, n, n)
        Posterior covariance after each step.
    x_prior : ndarray or None
        The prediction of the state before each step's update (same shape as ``x``); None from a run asked not
        to keep it (``keep_priors=False``).
    P_prior : ndarray or None
        The covariance of that prediction (same shape as ``P``), or None as ``x_prior``.
    innovations : ndarray, shape (K, m) or (M, K, m)
        Measurement minus predicted measurement; NaN where no measurement was used.
    innovation_cov : ndarray, shape (K, m, m) or (M, K, m, m)
        Covariance ``S`` of each innovation; NaN where no measurement was used.
    extras : dict of ndarray
        Per-step outputs particular to a filter (e.g. ``"fading_factor"``), each with the time axis first. A
        result built on another may keep it here too (``navigate(smooth=True)`` keeps the filter's own result
        under ``"filtered"``).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.filters import extended_kalman_filter
    >>> from uwtutor.models import DeadReckoning, RangeToBeacon
    >>> u = np.tile([1.0, 0.0], (4, 1))
    >>> truth = np.array([10.0, 20.0]) + np.cumsum(u, axis=0)
    >>> res = extended_kalman_filter(
    ...     DeadReckoning(np.eye(2) * 0.01),
    ...     RangeToBeacon((0.0, 0.0), R=1.0),
    ...     [12.0, 18.0],
    ...     np.eye(2) * 25.0,
    ...     u,
    ...     np.linalg.norm(truth, axis=1),
    ... )
    >>> res.n_steps, res.x.shape, res.P.shape, res.innovations.shape
    (4, (4, 2), (4, 2, 2), (4, 1))
    >>> # one NIS per step, and the measurements used
    >>> res.nis().shape, res.extras["accepted"].tolist()
    ((4,), [True, True, True, True])
    """

    times: np.ndarray
    x: np.ndarray
    P: np.ndarray
    x_prior: np.ndarray | None
    P_prior: np.ndarray | None
    innovations: np.ndarray
    innovation_cov: np.ndarray
    extras: dict[str, Any] = field(default_factory=dict)

    @property
    def n_steps(self) -> int:
        """Number of steps K."""
        return len(self.times)

    def priors(self) -> tuple[np.ndarray, np.ndarray]:
        """``(x_prior, P_prior)``, or a ValueError when the filter ran with ``keep_priors=False`` (then both are None).

        Examples
        --------
        >>> import numpy as np
        >>> x, P = np.zeros((2, 1)), np.ones((2, 1, 1))
        >>> res = FilterResult(np.arange(2.0), x, P, None, None, x, P)
        >>> res.priors()
        Traceback (most recent call last):
        ...
        ValueError: this result has no priors (x_prior, P_prior): run the filter with ...
        """
        if self.x_prior is None or self.P_prior is None:
            raise ValueError("this result has no priors (x_prior, P_prior): run the filter with keep_priors=True "
                             "(the default)")
        return self.x_prior, self.P_prior

    def nis(self) -> np.ndarray:
        """Normalized innovation squared ``y^T S^-1 y`` per step (NaN where no measurement was used).

        Under a consistent filter it follows a chi-square distribution with ``m`` degrees of freedom.
        """
        out = quadratic_form(self.innovations, self.innovation_cov, "innovation_cov")
        out[~np.isfinite(self.innovations).all(axis=-1)] = np.nan
        return out

    def nees(self, truth: ArrayLike) -> np.ndarray:
        """Normalized estimation error squared ``e^T P^-1 e`` per step, with ``e = truth - x``.

        ``truth`` must broadcast against ``x``; under a consistent filter NEES follows a chi-square
        distribution with ``n`` degrees of freedom.
        """
        truth = as_float_array("truth", truth)
        try:
            err = np.broadcast_to(truth, self.x.shape) - self.x
        except ValueError:
            raise ValueError(f"truth must broadcast to the estimates' shape {self.x.shape}; "
                             f"got {truth.shape}") from None
        return quadratic_form(err, self.P, "P")

    def as_dict(self) -> dict[str, np.ndarray]:
        """The arrays of this result by name (extras included), e.g. for saving with :func:`numpy.savez`."""
        out = {f.name: getattr(self, f.name) for f in fields(self) if f.name != "extras"}
        out.update(self.extras)
        return out


def _measurement_size(z: np.ndarray, batched: bool) -> int:
    """Length m of one measurement vector in a sequence ``z`` of shape (K,), (K, m), (M, K) or (M, K, m)."""
    per_step = z.ndim - (2 if batched else 1)
    return 1 if per_step == 0 else z.shape[-1]


def _sequence_times(n_steps: int, times: ArrayLike | None) -> np.ndarray:
    """Validated time stamps ``(K,)`` of a run of ``n_steps`` steps (``0..K-1`` when ``times`` is None)."""
    as_int("the number of steps K", n_steps, minimum=1)
    if times is None:
        return np.arange(n_steps, dtype=float)
    stamps = as_float_array("times", times, ndim=1)
    if not np.isfinite(stamps).all():
        raise ValueError("times must be finite")
    if len(stamps) != n_steps:
        raise ValueError(f"times must have one entry per step ({n_steps}); got {len(stamps)}")
    return stamps


def run_filter(filt: Filter, z: ArrayLike, u: ArrayLike | None = None, times: ArrayLike | None = None) -> FilterResult:
    """Run ``filt`` over a measurement sequence: at each step ``predict(u[k])`` then ``update(z[k])``.

    This is the library's one step loop: every filter's ``run`` gives the same result as this function.

    Parameters
    ----------
    filt : Filter
        Any object following the protocol; it is advanced in place and left at the last step.
    z : array_like, shape (K,) or (K, m)
        Measurements, one row per step; with a batched filter (``filt.x`` of shape ``(M, n)``) the runs axis
        comes first: ``(M, K)`` or ``(M, K, m)``. NaN rows mean "no measurement": predict only.
    u : array_like, optional
        Inputs, one per step, passed to ``predict``: ``(K, p)``, or ``(M, K, p)`` for a batched filter
        (``(K, p)`` is then shared by every run); ``None`` predicts without input.
    times : array_like, shape (K,), optional
        Time stamps for the result; defaults to the step indices ``0..K-1``.

    Returns
    -------
    FilterResult
        Of the type the filter names in its ``result_type`` attribute (``FilterResult`` by default), with the
        estimates after each step, the priors as the filter used them, and the per-step attributes named in
        ``filt.extra_outputs`` in ``extras``.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.filters import KalmanFilter, run_filter
    >>> kf = KalmanFilter.constant_velocity(
    ...     dt=1.0, q=0.01, r=4.0, x0=[100.0, 0.0], P0=np.diag([100.0, 1.0])
    ... )
    >>> result = run_filter(kf, [101.0, 99.5, 100.7, np.nan, 100.2])
    >>> result.x.shape, result.innovations.shape
    ((5, 2), (5, 1))
    >>> # the missing measurement: predict only
    >>> bool(np.isnan(result.innovations[3, 0]))
    True
    """
    missing = [name for name in ("x", "P", "predict", "update") if not hasattr(filt, name)]
    if missing:
        raise TypeError(f"filt must be a filter (an object with predict, update, x and P, e.g. "
                        f"uwtutor.filters.ExtendedKalmanFilter); got {type(filt).__name__}, which has no "
                        f"{', '.join(missing)}")
    batched = np.ndim(filt.x) == 2
    z = as_float_array("z", z)
    step_axis = 1 if batched else 0
    if z.ndim <= step_axis:
        raise ValueError(f"z must have a step axis at position {step_axis}; got shape {z.shape}")
    if batched and z.shape[0] != np.shape(filt.x)[0]:
        raise ValueError(f"z must have one row of measurements per run ({np.shape(filt.x)[0]} runs); "
                         f"got shape {z.shape}")
    n_steps = z.shape[step_axis]
    u_shared = False                      # a batched filter may take one input sequence (K, p) for every run
    if u is not None:
        u = as_float_array("u", u)
        u_shared = batched and u.ndim == 2
        u_axis = 0 if u_shared else step_axis
        if u.ndim <= u_axis or u.shape[u_axis] != n_steps:
            raise ValueError(f"u must give one input per step of z ({n_steps} steps along axis {u_axis}); "
                             f"got shape {u.shape} (z has shape {z.shape})")
    times = _sequence_times(n_steps, times)

    m = _measurement_size(z, batched)
    extra_names = tuple(getattr(filt, "extra_outputs", ()))
    runs = np.shape(filt.x)[0] if batched else 1
    names = ("x", "P", "x_prior", "P_prior", "y", "S") + extra_names
    history: dict[str, np.ndarray] = {}          # step-major buffers (K, ...), allocated at the first step
    for k in range(n_steps):
        checkpoint()                                # a widget's refinement no longer wanted stops here
        filt.predict(None if u is None else (u[:, k] if batched and not u_shared else u[k]))
        filt.update(z[:, k] if batched else z[k])
        values = {name: getattr(filt, name) for name in names}
        if k == 0 and np.size(values["y"]) != runs * m and np.size(values["y"]) % runs == 0:
            m = np.size(values["y"]) // runs      # a step's observation that carries more than it measures (inputs)
        y_shape = (runs, m) if batched else (m,)
        values["y"] = np.reshape(values["y"], y_shape)
        values["S"] = np.reshape(values["S"], y_shape + (m,))
        if k == 0:
            for name, value in values.items():
                value = np.asarray(value, dtype=None if name in extra_names else float)
                history[name] = np.empty((n_steps,) + value.shape, dtype=value.dtype)
        for name, value in values.items():
            history[name][k] = value
    # seen runs-first (M, K, ...) when batched: a view of the step-major buffers, not a second copy
    stacked = {name: np.moveaxis(h, 0, 1) if batched else h for name, h in history.items()}
    result_type = getattr(filt, "result_type", FilterResult)
    return result_type(
        times=times,
        x=stacked["x"], P=stacked["P"], x_prior=stacked["x_prior"], P_prior=stacked["P_prior"],
        innovations=stacked["y"], innovation_cov=stacked["S"],
        extras={name: stacked[name] for name in extra_names},
    )
