"""The filter protocol that every filter of ``uwtutor`` follows.

A filter holds its estimate in two attributes,

* ``x`` -- the state estimate, shape ``(n,)`` for one run or ``(M, n)`` for ``M`` Monte Carlo runs at once;
* ``P`` -- its covariance, shape ``(n, n)`` or ``(M, n, n)``;

and moves it with two methods,

* ``predict(u=None)`` -- propagate the estimate one step with the motion model and the control input ``u``
  (for single-beacon navigation: the dead-reckoned displacement since the last step);
* ``update(z)`` -- correct it with the measurement ``z``. A NaN measurement means "no measurement at this step":
  the filter then keeps its prediction. After ``update`` the filter exposes the innovation ``y`` and its
  covariance ``S`` (NaN when there was nothing to update with).

:func:`run_filter` drives any such filter over a sequence of inputs and measurements and collects a
:class:`FilterResult`. Chapters call ``run_filter`` (or a filter's own ``run`` helper); the predict/update steps
stay visible for teaching.

Filters with extra outputs (fading factors, outlier flags, particle weights...) subclass :class:`FilterResult`
and list the attribute names in their ``extra_outputs`` class attribute so that :func:`run_filter` records them.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Any, Protocol, runtime_checkable

import numpy as np

from .._validate import as_float_array, as_int

__all__ = ["Filter", "FilterResult", "run_filter"]


@runtime_checkable
class Filter(Protocol):
    """Structural type of a uwtutor filter (see the module docstring)."""

    x: np.ndarray
    P: np.ndarray

    def predict(self, u: Any = None) -> None:  # pragma: no cover - protocol
        ...

    def update(self, z: Any) -> None:  # pragma: no cover - protocol
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
    x_prior : ndarray
        The prediction of the state before each step's update (same shape as ``x``).
    P_prior : ndarray
        The covariance of that prediction (same shape as ``P``).
    innovations : ndarray, shape (K, m) or (M, K, m)
        Measurement minus predicted measurement; NaN where no measurement was used.
    innovation_cov : ndarray, shape (K, m, m) or (M, K, m, m)
        Covariance ``S`` of each innovation; NaN where no measurement was used.
    extras : dict of ndarray
        Per-step outputs particular to a filter (e.g. ``"fading_factor"``), each with the time axis first.
    """

    times: np.ndarray
    x: np.ndarray
    P: np.ndarray
    x_prior: np.ndarray
    P_prior: np.ndarray
    innovations: np.ndarray
    innovation_cov: np.ndarray
    extras: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def n_steps(self) -> int:
        """Number of steps K."""
        return len(self.times)

    def nis(self) -> np.ndarray:
        """Normalized innovation squared ``y^T S^-1 y`` per step (NaN where no measurement was used).

        Under a consistent filter it follows a chi-square distribution with ``m`` degrees of freedom.
        """
        y = self.innovations
        S = self.innovation_cov
        out = np.full(y.shape[:-1], np.nan)
        ok = np.isfinite(y).all(axis=-1)
        if ok.any():
            sol = np.linalg.solve(S[ok], y[ok][..., None])[..., 0]
            out[ok] = np.einsum("...i,...i->...", y[ok], sol)
        return out

    def nees(self, truth: Any) -> np.ndarray:
        """Normalized estimation error squared ``e^T P^-1 e`` per step, with ``e = truth - x``.

        ``truth`` must broadcast against ``x``; under a consistent filter NEES follows a chi-square
        distribution with ``n`` degrees of freedom.
        """
        truth = as_float_array("truth", truth)
        try:
            err = np.broadcast_to(truth, self.x.shape) - self.x
        except ValueError:
            raise ValueError(f"truth must broadcast to the estimates' shape {self.x.shape}; got {truth.shape}") from None
        sol = np.linalg.solve(self.P, err[..., None])[..., 0]
        return np.einsum("...i,...i->...", err, sol)

    def as_dict(self) -> dict[str, np.ndarray]:
        """The arrays of this result by name (extras included), e.g. for saving with :func:`numpy.savez`."""
        out = {f.name: getattr(self, f.name) for f in fields(self) if f.name != "extras"}
        out.update(self.extras)
        return out


def _measurement_size(z: np.ndarray, batched: bool) -> int:
    """Length m of one measurement vector in a sequence ``z`` of shape (K,), (K, m), (M, K) or (M, K, m)."""
    per_step = z.ndim - (2 if batched else 1)
    return 1 if per_step == 0 else z.shape[-1]


def run_filter(filt: Filter, zs: Any, us: Any = None, times: Any = None) -> FilterResult:
    """Run ``filt`` over a measurement sequence: at each step ``predict(us[k])`` then ``update(zs[k])``.

    Parameters
    ----------
    filt : Filter
        Any object following the protocol; it is advanced in place and left at the last step.
    zs : array_like, shape (K,) or (K, m)
        Measurements, one row per step; with a batched filter (``filt.x`` of shape ``(M, n)``) the runs axis
        comes first: ``(M, K)`` or ``(M, K, m)``. NaN rows mean "no measurement": predict only.
    us : array_like, optional
        Control inputs, one per step (the step axis after any runs axis), passed to ``predict``.
        ``None`` predicts without input.
    times : array_like, shape (K,), optional
        Time stamps for the result; defaults to the step indices ``0..K-1``.

    Returns
    -------
    FilterResult
        The estimates after each step; per-step extras named in ``filt.extra_outputs`` are recorded too.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.filters import KalmanFilter, run_filter
    >>> kf = KalmanFilter.constant_velocity(dt=1.0, q=0.01, r=4.0, x0=[100.0, 0.0], P0=np.diag([100.0, 1.0]))
    >>> result = run_filter(kf, [101.0, 99.5, 100.7, np.nan, 100.2])
    >>> result.x.shape, result.innovations.shape
    ((5, 2), (5, 1))
    """
    batched = np.ndim(filt.x) == 2
    zs = as_float_array("zs", zs)
    step_axis = 1 if batched else 0
    if zs.ndim <= step_axis:
        raise ValueError(f"zs must have a step axis at position {step_axis}; got shape {zs.shape}")
    n_steps = zs.shape[step_axis]
    if us is not None:
        us = as_float_array("us", us)
        if us.ndim <= step_axis or us.shape[step_axis] != n_steps:
            raise ValueError(f"us must give one input per step ({n_steps} steps along axis {step_axis}); "
                             f"got shape {us.shape}")
    if times is None:
        times = np.arange(n_steps, dtype=float)
    else:
        times = as_float_array("times", times, ndim=1)
        if len(times) != n_steps:
            raise ValueError(f"times must have one entry per step ({n_steps}); got {len(times)}")
    as_int("number of steps", n_steps, minimum=1)

    m = _measurement_size(zs, batched)
    extra_names = tuple(getattr(filt, "extra_outputs", ()))
    xs, Ps, xps, Pps, ys, Ss = [], [], [], [], [], []
    extras: dict[str, list[np.ndarray]] = {name: [] for name in extra_names}
    for k in range(n_steps):
        filt.predict(None if us is None else (us[:, k] if batched else us[k]))
        xps.append(np.array(filt.x, copy=True))
        Pps.append(np.array(filt.P, copy=True))
        filt.update(zs[:, k] if batched else zs[k])
        xs.append(np.array(filt.x, copy=True))
        Ps.append(np.array(filt.P, copy=True))
        y = np.asarray(filt.y, dtype=float)
        S = np.asarray(filt.S, dtype=float)
        ys.append(y.reshape(y.shape[:1] + (m,) if batched else (m,)))
        Ss.append(S.reshape(S.shape[:1] + (m, m) if batched else (m, m)))
        for name in extra_names:
            extras[name].append(np.array(getattr(filt, name), copy=True))

    axis = 1 if batched else 0
    return FilterResult(
        times=times,
        x=np.stack(xs, axis=axis),
        P=np.stack(Ps, axis=axis),
        x_prior=np.stack(xps, axis=axis),
        P_prior=np.stack(Pps, axis=axis),
        innovations=np.stack(ys, axis=axis),
        innovation_cov=np.stack(Ss, axis=axis),
        extras={name: np.stack(vals, axis=axis) for name, vals in extras.items()},
    )
