r"""The bootstrap particle filter on any motion/measurement model pair, vectorized over particles and runs.

A particle filter represents the posterior :math:`p(x_k \mid z_{1:k})` by ``N`` samples (particles)
:math:`x^{(i)}_k` with weights :math:`w^{(i)}_k`. The bootstrap (SIR) filter of Gordon et al. (1993) proposes from the
motion model and weighs by the likelihood of the measurement (Arulampalam et al. 2002, Algorithm 4):

.. math::

    x^{(i)}_k \sim p(x_k \mid x^{(i)}_{k-1}, u_k), \qquad
    w^{(i)}_k \propto w^{(i)}_{k-1}\, p(z_k \mid x^{(i)}_k), \qquad \sum_i w^{(i)}_k = 1,

    \hat x_k = \sum_i w^{(i)}_k x^{(i)}_k, \qquad P_k = \sum_i w^{(i)}_k (x^{(i)}_k - \hat x_k)(x^{(i)}_k - \hat x_k)^T,

then resamples (draws ``N`` particles with probabilities :math:`w^{(i)}_k` and resets the weights to :math:`1/N`)
every step, or only when the effective sample size :math:`N_\mathrm{eff} = 1/\sum_i (w^{(i)}_k)^2` falls below a
threshold.

.. rubric:: The models are the EKF's

The filter takes the same pair of models as the generic EKF (:mod:`uwtutor.models`; Stone Soup's separation of
models from algorithms): a :class:`~uwtutor.models.base.MotionModel` draws the particles of the next step,

.. math::

    x^{(i)}_k = f(x^{(i)}_{k-1}, u_k, k) + L_k \varepsilon^{(i)}, \qquad \varepsilon^{(i)} \sim N(0, I),
    \qquad L_k L_k^\mathsf{T} = Q_k,

(:meth:`~uwtutor.models.base.MotionModel.sample`; :math:`Q_k` may be singular, and a model may draw its own way:
the odometry's noise in its inputs, paper C's noise inside its kinematics), and a
:class:`~uwtutor.models.base.MeasurementModel` weighs them by the Gaussian likelihood of :math:`h` and :math:`R`
(:meth:`~uwtutor.models.base.MeasurementModel.log_likelihood`; a model may bring a non-Gaussian one),

.. math::

    \log p(z_k \mid x^{(i)}_k) = -\tfrac12\, y^{(i)\mathsf T} R_{k,\mathcal{PP}}^{-1}\, y^{(i)} + c, \qquad
    y^{(i)} = z_{k,\mathcal P} - h_{k,\mathcal P}(x^{(i)}_k),

over the components :math:`\mathcal P` of :math:`z_k` that are present: a NaN component is marginalised out (a
beacon that did not answer), and a measurement that is all NaN leaves the weights as they were (predict only).
The step index :math:`k` reaches both models (a beacon that moves, per-step noise), and so does the input
:math:`u_k`, shared by every run or one per run. So one model pair runs in the EKF, this filter, the RTS smoother
and the posterior Cramér-Rao bound (:func:`uwtutor.observability.model_posterior_crlb`). A
:class:`~uwtutor.models.base.ModelPair` may stand for the two models.

A constant state (a gyro bias, a range scale) or a likelihood much narrower than the prediction makes the
resampled copies of a few particles all the cloud has left (sample impoverishment); the roughening of Gordon et
al. (1993) -- jitter of a size set by the cloud's own spread after each resampling -- keeps them apart
(``roughening=0.1`` on the real logs, ``tests/test_particle_real_data.py``).

The estimate of a state with an angle (a heading) is its circular mean: the filter takes the model's
``difference`` and ``normalize`` (:meth:`~uwtutor.models.base.MotionModel.difference`), so that a cloud that
straddles :math:`\pm\pi` has its mean there, not at 0.

.. rubric:: Batches of runs

Every filter here runs ``M`` independent Monte Carlo runs at once, the way the Kalman family does: particles
``(M, N, n)``, weights ``(M, N)``, estimates ``x`` ``(M, n)`` and ``P`` ``(M, n, n)``, measurements ``(M, m)``
per step (``from_gaussian(..., x0 of shape (M, n))`` or ``n_runs=M``). A single run keeps the shapes without the
runs axis (``x`` ``(n,)``, particles ``(N, n)``) and is the ``M = 1`` case of the same code. Each run draws from
its own ``numpy.random.Generator``: give a sequence of ``M`` Generators, or one Generator, which is then split
with :meth:`numpy.random.Generator.spawn`. Run ``m`` of a batch is then, draw for draw, the single-run filter
given the same ``m``-th Generator (``tests/test_filter_contract_pf.py`` checks it); a single run given one
Generator uses it directly. The particles are stored component-major, ``(M, n, N)``: each component of a run is
one contiguous row, which is what the models' arithmetic reads.

The two other particle filters of paper C change how particles are proposed:
:class:`~uwtutor.filters.particle.multiple_model.MultipleModelParticleFilter` (a motion model per mode) and
:class:`~uwtutor.filters.particle.grey.GreyParticleFilter` (grey-forecast particles).

References
----------
Arulampalam, M. S., Maskell, S., Gordon, N. and Clapp, T. (2002). A tutorial on particle filters for online
nonlinear/non-Gaussian Bayesian tracking. *IEEE Trans. Signal Processing* 50(2), 174-188.

Gordon, N. J., Salmond, D. J. and Smith, A. F. M. (1993). Novel approach to nonlinear/non-Gaussian Bayesian
state estimation. *IEE Proceedings F* 140(2), 107-113.
"""

from __future__ import annotations

import copy
import functools
import math
from typing import Any, Sequence

from numpy.typing import ArrayLike

import numpy as np

from ..._validate import (MAX_COORDINATE, CovarianceCheck, as_covariance, as_finite, as_float_array, as_int,
                          as_model_output, as_nonnegative, as_rng, as_scalar, readonly)
from ...errors import UwtutorWarning, warn
from ...models.base import MeasurementModel, ModelPair, MotionModel
from ...models.noise import RunGenerators, gaussian_log_likelihood, per_run_generators, psd_sqrt
from ...resampling import WEIGHT_SUM_TOL, Resampler, systematic_resample
from ..base import Configurable, FilterResult

__all__ = ["BootstrapParticleFilter", "ParticleDegeneracyError", "ParticleCollapseWarning"]


class ParticleDegeneracyError(RuntimeError):
    """Every particle got zero likelihood: the particle cloud has lost the measurement."""


class ParticleCollapseWarning(UwtutorWarning):
    """After an update one particle holds (almost) all the weight: the effective sample size fell below
    ``COLLAPSE_ESS``, and the next resampling copies that particle ``N`` times. The estimate then rests on one
    sample: the measurement lies far outside the predicted particles (a wrong ``z`` or ``R``, too little process
    noise, too few particles)."""


#: An effective sample size below this after an update is a collapse onto one particle (the largest weight is then
#: above 0.995); when, in addition, even the best particle is more than ``sqrt(COLLAPSE_NIS)`` = 100 standard
#: deviations from the measurement (its normalized innovation squared above ``COLLAPSE_NIS``), no particle explains
#: the measurement at all and the filter warns with :class:`ParticleCollapseWarning`. (Sample degeneracy, chapter 6
#: -- an SIS filter that never resamples, a cloud a few sigma off after a manoeuvre -- also ends on one particle, on
#: one that still explains the data within tens of sigma: the effective sample size reports it, not a warning.)
COLLAPSE_ESS = 1.01
COLLAPSE_NIS = 1e4

_COLLAPSE = ("the particle cloud collapsed onto one particle at step {k}{which}: effective sample size {ess:.3g} of "
             "{N} particles, and the measurement lies more than 100 standard deviations from every predicted particle: "
             "check z and the measurement "
             "noise R, or give the filter more process noise, more particles or roughening (the estimate now rests "
             "on one sample)")


_LOST = ("every particle has zero likelihood for this measurement{which}: the particles have lost the track. Use more "
         "particles, a larger process noise, or check the measurement and R")


#: Particles per block of runs that ``run`` moves through all steps together (a block stays in cache).
_BLOCK_PARTICLES = 10_000

_any = functools.partial(np.logical_or.reduce, axis=None)      # a.any() / a.all() without numpy's Python wrappers
_all = functools.partial(np.logical_and.reduce, axis=None)


def _rows(values: np.ndarray) -> np.ndarray:
    """``(M, N, k) -> (M, k, N)``: each component of every run contiguous (a view when it already is)."""
    return values.swapaxes(-1, -2)


def _check_model(name: str, model: Any, kind: type) -> None:
    if not isinstance(model, kind):
        raise TypeError(f"{name} must be a {kind.__module__}.{kind.__name__} (see uwtutor.models), or give one "
                        f"uwtutor.models.ModelPair in place of motion and measurement; got {type(model).__name__}")


def _shift_for_pair(second: Any, rest: tuple[Any, ...]) -> tuple[Any, ...]:
    """The arguments named ``rest`` when one ModelPair stood for two models: the positional ones (the leading
    slots that are set, from ``second`` on) shift one name to the right; the ones given by keyword stay."""
    slots = (second,) + tuple(rest)
    p = 0
    while p < len(slots) and slots[p] is not None:
        p += 1
    if p == len(slots):
        raise TypeError("too many positional arguments: one ModelPair stands for both motion and measurement")
    return tuple(slots[i - 1] if i <= p else slots[i] for i in range(1, len(slots)))


def _split_pair(first: Any, second: Any, rest: tuple[Any, ...]) -> tuple[Any, Any, tuple[Any, ...]]:
    """``(motion, measurement, rest)`` from a filter's leading arguments, where one ModelPair may stand for the
    first two (the positional arguments after it then mean the next names)."""
    if isinstance(first, ModelPair):
        return first.motion, first.measurement, _shift_for_pair(second, rest)
    return first, second, rest


def _whitened_log_likelihood(hx_rows: np.ndarray, z: np.ndarray, R: np.ndarray, whiten: np.ndarray,
                            diagonal: bool, complete: bool = False) -> np.ndarray:
    r""":math:`-\tfrac12 (z - h)^T R^{-1} (z - h)` for every particle of every run, ``(M, N)``: the fast path of
    the Gaussian likelihood, with the whitening computed once for an ``R`` that does not change.

    ``hx_rows`` (M, m, N); ``z`` (M, m), NaN entries missing; ``R`` (m, m) or (M, m, m); ``whiten`` the
    reciprocal standard deviations (m,) or (M, m) when ``diagonal``, else :math:`W` (m, m) or (M, m, m) with
    :math:`W^T = L^{-1}`, :math:`L L^T = R`. A run with every entry missing gets 0 (its weights do not change).
    ``complete`` says that the caller knows ``z`` has no NaN entry.
    """
    if diagonal and hx_rows.shape[0] == 1 and (complete or _all(z == z)):   # one run, nothing missing: 2-D
        d = hx_rows[0] - z[0][:, None]
        d *= whiten.reshape(-1, 1)
        d *= d
        out = np.add.reduce(d, axis=0)
        out *= -0.5
        return out[None]
    missing = np.isnan(z)
    if not _any(missing):              # rows (M, m, N): contiguous per component
        d = hx_rows - z[..., None]
        if diagonal:
            d *= whiten[..., None]
        else:
            d = np.swapaxes(whiten, -1, -2) @ d
    elif diagonal:                     # independent components: the marginal drops the missing ones' terms
        d = hx_rows - z[..., None]
        d *= whiten[..., None]
        d = np.where(missing[..., None], 0.0, d)
    else:
        M, m, N = hx_rows.shape
        d = np.zeros((M, m, N))
        Rb = np.broadcast_to(R, (M, m, m))
        for run in range(M):
            present = ~missing[run]
            if not present.any():
                continue
            L = np.linalg.cholesky(Rb[run][np.ix_(present, present)])
            d[run, :present.sum()] = np.linalg.solve(L, hx_rows[run][present] - z[run, present, None])
    d *= d
    out = np.add.reduce(d, axis=1)
    out *= -0.5
    return out


@functools.lru_cache(maxsize=16)
def _strata(N: int) -> np.ndarray:
    """A read-only ``0.0, 1.0, ..., N - 1`` (the strata of systematic resampling), cached."""
    a = np.arange(N, dtype=float)
    a.flags.writeable = False
    return a


def _systematic_own_weights(w: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """:func:`uwtutor.resampling.systematic_resample` of a filter's own 1-D weights, which its update made finite,
    >= 0 and normalized, so that they need no check at every step: the same draw from ``rng`` and the same indices
    (``tests/test_resampling.py`` holds the two together)."""
    total = float(np.add.reduce(w))
    if abs(total - 1.0) > WEIGHT_SUM_TOL:         # normalize what is not, as the public function does
        w = w / total
    N = w.shape[-1]
    points = _strata(N) + rng.random()           # the draw of rng.random((1,)), as a float
    points /= N
    c = np.add.accumulate(w)
    if w[-1] > 0.0:                               # exactly 1 from the last positive weight on
        c[-1] = 1.0
    else:
        c[N - 1 - int(np.argmax(w[::-1] > 0.0)):] = 1.0
    return c.searchsorted(points, side="right")


def _whitening(R: np.ndarray) -> tuple[np.ndarray, bool]:
    """The whitening of ``_whitened_log_likelihood`` for one ``(m, m)`` covariance and whether it is diagonal."""
    diagonal = bool(np.all(R == np.diag(np.diag(R))))
    return (1.0 / np.sqrt(np.diag(R)) if diagonal else np.linalg.inv(np.linalg.cholesky(R)).T), diagonal


class BootstrapParticleFilter(Configurable):
    r"""Bootstrap (SIR) particle filter on a motion/measurement model pair, vectorized over its ``N`` particles and
    over ``M`` runs, with a pluggable resampler.

    Each step: ``predict(u)`` draws every particle from the motion model
    (:meth:`~uwtutor.models.base.MotionModel.sample`); ``update(z)`` multiplies the weights by the likelihood (in
    log space, so tiny likelihoods do not underflow; NaN components of ``z`` marginalised out), records the
    estimate, the effective sample size :math:`N_\mathrm{eff} = 1/\sum_i w_i^2` and the innovation, then resamples
    when :math:`N_\mathrm{eff} < \tau N` with :math:`\tau` = ``ess_threshold`` (always when ``ess_threshold >=
    1``). Equations in the module docstring (Arulampalam et al. 2002, Algorithms 2 and 4). Every run of a batch
    does this on its own particles with its own random stream (module docstring, *Batches of runs*).

    Parameters
    ----------
    motion : uwtutor.models.MotionModel
        How the particles move (the EKF's motion model: :math:`f` and :math:`Q`, or its own ``sample``).
    measurement : uwtutor.models.MeasurementModel
        What is measured (:math:`h` and :math:`R`, or its own ``log_likelihood``). A
        :class:`~uwtutor.models.base.ModelPair` may be given in place of ``motion`` and ``measurement``:
        ``BootstrapParticleFilter(pair, particles, rng)``.
    particles : array_like, shape (N, n) or (M, N, n)
        Initial particles of one run, or of ``M`` runs.
    rng : numpy.random.Generator or sequence of numpy.random.Generator
        Source of all randomness (motion noise and resampling): one Generator, or one per run (a single
        Generator is split with ``rng.spawn(M)`` for ``M > 1`` runs).
    weights : array_like, shape (N,) or (M, N), optional
        Initial weights (normalized here); equal by default.
    resampler : callable, optional
        ``resampler(weights, rng) -> indices`` on the ``(N,)`` weights of one run;
        :func:`uwtutor.resampling.systematic_resample` by default. Any function of :mod:`uwtutor.resampling`
        fits, and so does a wrapper of a filterpy resampler
        (``lambda w, rng: filterpy.monte_carlo.systematic_resample(w)``).
    ess_threshold : float, optional
        Resample when :math:`N_\mathrm{eff} <` ``ess_threshold`` :math:`\cdot N`. 1.0 (the default, as in paper C)
        resamples after every measurement, 0.5 is a common adaptive choice, 0 never resamples (plain
        sequential importance sampling, which degenerates). A step without a measurement never resamples.
    roughening : float, optional
        :math:`K` of the roughening of Gordon et al. (1993), 0 (none) by default: after each resampling, component
        :math:`j` of every particle gets independent jitter :math:`N(0, (K E_j N^{-1/n})^2)`, :math:`E_j` the spread
        (max - min) of that component over the run's particles (an angle's through the motion model's
        ``difference``). It keeps the copies of a resampled particle apart where the motion noise does not -- in
        constant states (a gyro bias, a range scale) and when precise measurements make the likelihood much
        narrower than the prediction -- at the price of a slightly wider posterior. The paper uses 0.2.

    Attributes
    ----------
    particles : ndarray, shape (N, n) or (M, N, n)
        Current particles.
    weights : ndarray, shape (N,) or (M, N)
        Their normalized weights.
    x : ndarray, shape (n,) or (M, n)
        Weighted mean of the particles (after ``update``: the posterior mean, before any resampling).
    P : ndarray, shape (n, n) or (M, n, n)
        Weighted covariance of the particles.
    y : ndarray, shape (m,) or (M, m)
        Innovation :math:`z - \sum_i w_i h(x^{(i)})` of the last update (NaN where nothing was measured).
    S : ndarray, shape (m, m) or (M, m, m)
        Its covariance: the weighted covariance of :math:`h(x^{(i)})` plus ``R`` (NaN where nothing was measured).
    x_prior : ndarray
        The weighted mean of the predicted particles of the current step.
    P_prior : ndarray
        Their weighted covariance.
    ess : float or ndarray of shape (M,)
        Effective sample size after the last update (before resampling).
    resampled : bool or ndarray of shape (M,)
        Whether the last update resampled.
    rngs : tuple of numpy.random.Generator
        The generator of each run.
    k : int
        Index of the current step (``-1`` before the first ``predict``), passed to the models.

    Examples
    --------
    A scalar random walk observed in noise, checked against the exact (Kalman) answer:

    >>> import numpy as np
    >>> from uwtutor.filters import BootstrapParticleFilter, KalmanFilter
    >>> from uwtutor.models import LinearMeasurement, LinearMotion
    >>> rng = np.random.default_rng(0)
    >>> zs = np.cumsum(rng.normal(0.0, 1.0, 30)) + rng.normal(0.0, 2.0, 30)
    >>> motion, measurement = LinearMotion(
    ...     F=[[1.0]], Q=[[1.0]]
    ... ), LinearMeasurement(H=[[1.0]], R=4.0)
    >>> pf = BootstrapParticleFilter.from_gaussian(
    ...     motion, measurement, [0.0], [[10.0]], 20000, rng
    ... )
    >>> kf = KalmanFilter(
    ...     F=[[1.0]], H=[[1.0]], Q=[[1.0]], R=[[4.0]], x0=[0.0], P0=[[10.0]]
    ... )
    >>> bool(np.max(np.abs(pf.run(zs).x - kf.run(zs).x)) < 0.1)
    True

    Four runs at once, each with its own stream; run 2 is the single-run filter on the same stream:

    >>> Z = np.stack([zs, zs + 1.0, zs - 1.0, zs])
    >>> batch = BootstrapParticleFilter.from_gaussian(
    ...     motion,
    ...     measurement,
    ...     [0.0],
    ...     [[10.0]],
    ...     500,
    ...     np.random.default_rng(1),
    ...     n_runs=4,
    ... )
    >>> res = batch.run(Z)
    >>> res.x.shape, res.extras["ess"].shape
    ((4, 30, 1), (4, 30))
    >>> one = BootstrapParticleFilter.from_gaussian(
    ...     motion,
    ...     measurement,
    ...     [0.0],
    ...     [[10.0]],
    ...     500,
    ...     np.random.default_rng(1).spawn(4)[2],
    ... )
    >>> bool(np.allclose(one.run(Z[2]).x, res.x[2]))
    True

    The range-only problem of chapter 4 with dead reckoning as the input and a beacon that moves (the EKF's
    models): the particles hold the position well after a few ranges.

    >>> from uwtutor.models import DeadReckoning, RangeToBeacon
    >>> theta = np.linspace(0.0, np.pi, 41)
    >>> track = 300.0 * np.column_stack([np.cos(theta), np.sin(theta)])
    >>> # the beacon's path
    >>> ship = np.column_stack([np.linspace(0.0, 100.0, 40), np.zeros(40)])
    >>> z = np.linalg.norm(track[1:] - ship, axis=1) + rng.normal(0.0, 2.0, 40)
    >>> pf = BootstrapParticleFilter.from_gaussian(
    ...     DeadReckoning(np.eye(2)),
    ...     RangeToBeacon(ship, R=4.0),
    ...     track[0],
    ...     100.0 * np.eye(2),
    ...     2000,
    ...     np.random.default_rng(2),
    ... )
    >>> bool(
    ...     np.linalg.norm(pf.run(z, np.diff(track, axis=0)).x[-1] - track[-1])
    ...     < 10.0
    ... )
    True
    """

    #: Per-step outputs recorded by :func:`uwtutor.filters.base.run_filter` in ``FilterResult.extras``.
    extra_outputs: tuple[str, ...] = ("ess", "resampled")
    # the configuration rule (base.Configurable): these take effect when assigned; the models and generators are
    # fixed (a new state is given as particles or weights); y and S are read-only
    _parameters: tuple[str, ...] = ("resampler", "ess_threshold", "roughening")
    _fixed: tuple[str, ...] = ("motion", "measurement", "rng", "rngs", "n", "m")
    _diagnostics: tuple[str, ...] = ("y", "S")
    result_type = FilterResult
    resampler: Resampler                            # the parameters, set by _apply
    ess_threshold: float
    roughening: float
    _rows_p: np.ndarray                             # the particles, component-major (M, n, N): set by particles
    _x: np.ndarray                                  # their weighted moments (M, n), (M, n, n): set by _set_estimate
    _P: np.ndarray

    # measurement: the particles when motion is a ModelPair (the positional arguments after a pair shift one name)
    def __init__(self, motion: MotionModel | ModelPair, measurement: Any = None, particles: ArrayLike | None = None,
                 rng: RunGenerators | None = None, *,
                 weights: ArrayLike | None = None, resampler: Resampler = systematic_resample,
                 ess_threshold: float = 1.0, roughening: float = 0.0) -> None:
        motion, measurement, (particles, rng) = _split_pair(motion, measurement, (particles, rng))
        self._set_models(motion, measurement)
        p = as_finite("particles", particles, ndim=(2, 3), max_abs=MAX_COORDINATE)
        self._batched = p.ndim == 3
        self._w = np.empty((0, 0))
        self.particles = p
        M = self._rows_p.shape[0]
        self._check_runs(M)
        if isinstance(rng, np.random.Generator):
            rng = as_rng(rng)
        self.rngs = per_run_generators(rng, M)
        if weights is not None:
            self.weights = weights
        for name, value in (("resampler", resampler), ("ess_threshold", ess_threshold), ("roughening", roughening)):
            self._apply(name, value)
        m = self.m
        self.k = -1
        self._y = np.full((M, m), np.nan)
        self._S = np.full((M, m, m), np.nan)
        self._ess = 1.0 / np.einsum("ij,ij->i", self._w, self._w)
        self._resampled = np.zeros(M, dtype=bool)
        self._prior_moments = False
        self._complete = False                  # whether the measurement of the current update has no NaN
        self._sequence_complete = False         # set by run() for a sequence without NaN
        self._white_key: bytes | None = None
        self._set_estimate()
        self._xp, self._Pp = self._x, self._P

    # --- the models -------------------------------------------------------------------------------------------------

    def _apply(self, name: str, value: Any) -> None:
        """Set ``resampler``, ``ess_threshold`` or ``roughening``, checked (the constructor's arguments; assigned
        later, they take effect from the next update: base.Configurable)."""
        if name == "resampler":
            if not callable(value):
                raise TypeError(f"resampler must be a function (weights, rng) -> indices; got {value!r}")
        elif name == "ess_threshold":
            value = as_scalar("ess_threshold", value, domain="nonnegative")
        else:
            value = as_scalar("roughening", value, domain="nonnegative")
            if value > 10.0:      # the jitter is K times the cloud's spread: beyond 10 it is no posterior
                raise ValueError(f"roughening must be at most 10 (Gordon et al.'s K, about 0.2: the jitter is K times "
                                 f"the spread of the particles); got {value:g}")
        object.__setattr__(self, name, value)

    @classmethod
    def _split_models(cls, first: Any, second: Any, rest: tuple[Any, ...]) -> tuple[Any, Any, tuple[Any, ...]]:
        """The motion model(s), the measurement model and the other leading arguments (a ModelPair may stand for
        the two models)."""
        return _split_pair(first, second, rest)

    def _set_models(self, motion: Any, measurement: Any) -> None:
        _check_model("motion", motion, MotionModel)
        _check_model("measurement", measurement, MeasurementModel)
        if measurement.n != motion.n:
            raise ValueError(f"the measurement model reads a state of size {measurement.n} but the motion model's "
                             f"state has size {motion.n}: build both for the same state")
        self.motion, self.measurement = motion, measurement
        self.n, self.m = motion.n, measurement.m
        # a user model's R is checked as the EKF engine checks it (real, symmetric PSD), once per distinct array
        self._check_R = CovarianceCheck(f"the measurement model {type(measurement).__name__}.R", measurement, "R")
        # the circular mean where the state has an angle (the model's difference wraps it)
        self._circular = type(motion).difference is not MotionModel.difference
        # the built-in Gaussian likelihood: computed here, with the whitening kept while R does not change
        self._gaussian = (type(measurement).log_likelihood is MeasurementModel.log_likelihood
                          and type(measurement).residual is MeasurementModel.residual)

    def _models(self) -> list[tuple[str, Any]]:
        return [("motion", self.motion), ("measurement", self.measurement)]

    def _check_runs(self, M: int) -> None:
        for name, model in self._models():
            runs = getattr(model, "n_runs", None)
            if runs is not None and runs != M:
                raise ValueError(f"the {name} model ({type(model).__name__}) holds parameters for {runs} runs but "
                                 f"the particles are of {M} run(s): give one set of particles per run")

    @classmethod
    def from_gaussian(cls, motion: Any, measurement: Any = None,       # as cls takes them (a sequence for the MMPF)
                      x0: ArrayLike | None = None, P0: ArrayLike | None = None,
                      n_particles: int | None = None, rng: RunGenerators | None = None, *, n_runs: int | None = None,
                      **kwargs: Any) -> "BootstrapParticleFilter":
        """A filter whose ``n_particles`` initial particles of each run are drawn from :math:`N(x_0, P_0)`.

        Parameters
        ----------
        motion, measurement : MotionModel, MeasurementModel
            The model pair (the list of mode motion models of
            :class:`~uwtutor.filters.particle.multiple_model.MultipleModelParticleFilter`), or one
            :class:`~uwtutor.models.base.ModelPair` in their place: ``from_gaussian(pair, x0, P0, N, rng)``.
        x0 : array_like, shape (n,) or (M, n)
            Mean of the initial particles; ``(M, n)`` makes ``M`` runs, one mean each.
        P0 : array_like, shape (n, n) or (M, n, n)
            Covariance of the initial particles (positive semi-definite), shared or one per run.
        n_particles : int
            ``N``.
        rng : numpy.random.Generator or sequence of numpy.random.Generator
            One Generator, or one per run (a single Generator is split with ``rng.spawn(M)`` for ``M > 1``).
            Run ``m`` draws its initial particles from its own generator, then keeps it for the filter.
        n_runs : int, optional
            ``M``: a batched filter of ``M`` runs even for ``x0`` of shape ``(n,)`` (shared by every run).
        **kwargs
            Further constructor arguments (``weights``, ``resampler``, ``ess_threshold``, ...).
        """
        motion, measurement, (x0, P0, n_particles, rng) = cls._split_models(motion, measurement,
                                                                            (x0, P0, n_particles, rng))
        x0 = as_finite("x0", x0, ndim=(1, 2))
        n = x0.shape[-1]
        if n_runs is None:
            batched, M = x0.ndim == 2, (x0.shape[0] if x0.ndim == 2 else 1)
        else:
            batched, M = True, as_int("n_runs", n_runs, minimum=1)
            if x0.ndim == 2 and x0.shape[0] != M:
                raise ValueError(f"x0 must have shape ({n},) or ({M}, {n}) for n_runs={M}; got {x0.shape}")
        P0 = as_covariance("P0", P0, n, allow_singular=True)
        if P0.ndim == 3 and (not batched or P0.shape[0] != M):
            raise ValueError(f"P0 of shape {P0.shape} needs {P0.shape[0]} runs (x0 of shape ({P0.shape[0]}, {n}) "
                             f"or n_runs={P0.shape[0]}); got {M} run(s)")
        N = as_int("n_particles", n_particles, minimum=1)
        rngs = per_run_generators(as_rng(rng) if isinstance(rng, np.random.Generator) else rng, M)
        X0 = np.broadcast_to(x0, (M, n))
        roots = [psd_sqrt(P0)] * M if P0.ndim == 2 else [psd_sqrt(Pm) for Pm in P0]
        particles = np.empty((M, N, n))
        for m in range(M):
            particles[m] = X0[m] + rngs[m].standard_normal((N, n)) @ roots[m].T
        if not batched:
            return cls(motion, measurement, particles[0], rngs[0], **kwargs)
        return cls(motion, measurement, particles, rngs, **kwargs)

    # --- shapes: runs axis inside, removed for a single run outside ------------------------------------------------

    def _out(self, a: np.ndarray) -> Any:
        """What the protocol's attributes show: a read-only view (the moments follow the particles: set those)."""
        shown = a if self._batched else a[0]
        return readonly(shown) if isinstance(shown, np.ndarray) else shown       # a scalar is immutable

    @property
    def n_runs(self) -> int:
        """Number of runs ``M`` (1 for a single-run filter)."""
        return self._rows_p.shape[0]

    @property
    def n_particles(self) -> int:
        """Number of particles ``N`` per run."""
        return self._rows_p.shape[2]

    @property
    def rng(self) -> Any:
        """The Generator of a single-run filter (the tuple of per-run Generators of a batched one)."""
        return self.rngs if self._batched else self.rngs[0]

    @property
    def particles(self) -> np.ndarray:
        """The particles, shape (N, n) or (M, N, n), stored component-major (each state component contiguous).

        Assigning a new set with a different ``N`` resets the weights to ``1/N``.
        """
        return self._out(_rows(self._rows_p))

    @particles.setter
    def particles(self, value: ArrayLike) -> None:
        p = as_finite("particles", value, ndim=3 if self._batched else 2, max_abs=MAX_COORDINATE)
        pb = p if self._batched else p[None]
        n = self.n
        if pb.shape[2] != n or pb.shape[1] < 1 or pb.shape[0] < 1:
            want = "(M, N, {n})" if self._batched else "(N, {n})"
            raise ValueError(f"particles must have shape {want.format(n=n)} with N >= 1 for this model; "
                             f"got {p.shape}")
        if hasattr(self, "_rows_p") and pb.shape[0] != self._rows_p.shape[0]:
            raise ValueError(f"particles must keep the {self._rows_p.shape[0]} runs of this filter; got {p.shape}")
        self._rows_p = np.ascontiguousarray(_rows(pb))
        self._prior_moments = False
        if self._w.shape != pb.shape[:2]:
            M, N = pb.shape[:2]
            self._w = np.full((M, N), 1.0 / N)
            self._uniform = np.ones(M, dtype=bool)
        if hasattr(self, "_x"):                       # made (not in __init__): x and P follow the new particles
            self._set_estimate()

    @property
    def weights(self) -> np.ndarray:
        """Normalized particle weights, shape (N,) or (M, N); assigned weights are checked and normalized, and
        ``x``, ``P`` become their weighted moments."""
        return self._out(self._w)

    @weights.setter
    def weights(self, value: ArrayLike) -> None:
        shape = self._w.shape if self._batched else self._w.shape[1:]
        w = as_nonnegative("weights", value)
        if w.shape != shape:
            raise ValueError(f"weights must have shape {shape} (one weight for each of the particles); got "
                             f"{w.shape}")
        w = w.reshape(self._w.shape)
        total = w.sum(axis=1, keepdims=True)
        if not (total > 0).all():
            raise ValueError("weights must have a positive sum (at least one particle with weight > 0) in every run")
        self._w = w / total
        self._uniform = np.zeros(self._w.shape[0], dtype=bool)
        self._prior_moments = False
        self._set_estimate()                          # x and P follow the new weights

    @property
    def x(self) -> np.ndarray:
        """Weighted mean of the particles, (n,) or (M, n); read-only, it follows ``particles`` and ``weights``."""
        return self._out(self._x)

    @x.setter
    def x(self, value: Any) -> None:
        raise AttributeError("a particle filter's x is the weighted mean of its particles: assign particles (or "
                             "weights) instead, e.g. f.particles = f.particles + shift")

    @property
    def P(self) -> np.ndarray:
        """Weighted covariance of the particles, (n, n) or (M, n, n); read-only, it follows the particles."""
        return self._out(self._P)

    @P.setter
    def P(self, value: Any) -> None:
        raise AttributeError("a particle filter's P is the weighted covariance of its particles: assign particles "
                             "(or weights) instead")
    x_prior = property(lambda self: self._out(self._xp),
                       doc="Weighted mean of the predicted particles of this step, (n,) or (M, n).")
    P_prior = property(lambda self: self._out(self._Pp),
                       doc="Weighted covariance of the predicted particles of this step.")
    y = property(lambda self: self._out(self._y), doc="Innovation of the last update, (m,) or (M, m).")
    S = property(lambda self: self._out(self._S), doc="Innovation covariance of the last update.")

    @property
    def ess(self) -> Any:
        """Effective sample size after the last update (a float, or an (M,) array for a batch)."""
        return readonly(self._ess.copy()) if self._batched else float(self._ess[0])

    @property
    def resampled(self) -> Any:
        """Whether the last update resampled (a bool, or an (M,) array for a batch)."""
        return readonly(self._resampled.copy()) if self._batched else bool(self._resampled[0])

    # --- moments ----------------------------------------------------------------------------------------------------

    def _moments(self, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Weighted mean (M, k) and covariance (M, k, k) of ``rows`` (M, k, N) under the current weights."""
        w = self._w
        if rows.shape[0] == 1:                       # one run: plain 2-D products
            r, ww = rows[0], w[0]
            mean = r @ ww
            d = r - mean[:, None]
            return mean[None], ((d * ww) @ d.T)[None]
        mean = np.matmul(rows, w[..., None])[..., 0]
        d = rows - mean[..., None]
        return mean, np.matmul(d * w[:, None, :], np.swapaxes(d, -1, -2))

    def _state_moments(self, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The weighted mean and covariance of the particles; for a state with an angle, the mean about the first
        particle of each run through the motion model's ``difference`` and ``normalize`` (a circular mean)."""
        if not self._circular:
            return self._moments(rows)
        x = _rows(rows)
        ref = x[:, :1, :]
        # the differences from a reference particle, angles wrapped (a cloud narrower than pi unwrapped about it);
        # their weighted mean and covariance are those of the cloud, the mean then moved back by ref
        mean_d, cov = self._moments(_rows(self.motion.difference(x, ref)))
        return self.motion.normalize(ref[:, 0, :] + mean_d), cov

    def _set_estimate(self) -> None:
        self._x, self._P = self._state_moments(self._rows_p) if self._circular else self._moments(self._rows_p)

    def _set_prior(self) -> None:
        self._set_estimate()
        self._xp, self._Pp = self._x, self._P
        self._prior_moments = True

    # --- the algorithm ----------------------------------------------------------------------------------------------

    def _step_input(self, u: Any) -> Any:
        """The input of one step as the models take it: ``None``, ``(p,)`` shared, or ``(M, 1, p)`` per run."""
        if u is None:
            return None
        u = as_finite("u", u)
        M = self.n_runs
        if u.ndim == 1:
            return u
        if u.ndim == 2 and self._batched and u.shape[0] == M:
            return u[:, None, :]
        want = f"(p,) or ({M}, p)" if self._batched else "(p,)"
        raise ValueError(f"u must be the input of one step, shape {want}; got {u.shape}")

    def _sample(self, motion: MotionModel, rows: np.ndarray, u: Any, k: int, rngs: Sequence[np.random.Generator],
                name: str = "motion") -> np.ndarray:
        """Move ``rows`` (R, n, count) with ``motion.sample`` (one Generator per run); returns new rows."""
        x = rows.swapaxes(-1, -2)
        new = motion.sample(x, u, k, rngs)
        if type(motion).sample is not MotionModel.sample:     # a model's own draw (the default one checks itself)
            new = as_model_output(f"the {name} model {type(motion).__name__}.sample", new)
            if new.shape == x.shape and not _all(np.isfinite(new)):
                raise ValueError(f"the {name} model {type(motion).__name__}.sample returned a non-finite particle at "
                                 f"step {k}: check the model there")
        if getattr(new, "shape", None) != x.shape:
            raise ValueError(f"{name} model's sample ({type(motion).__name__}) must return particles of shape "
                             f"{x.shape}; got {np.shape(new)}")
        out = new.swapaxes(-1, -2)
        return out if out.flags.c_contiguous else np.ascontiguousarray(out)

    def predict(self, u: ArrayLike | None = None) -> None:
        """Draw every particle from the motion model (its ``sample``); ``x``, ``P`` follow, and ``x_prior``,
        ``P_prior`` keep the moments of the predicted particles.

        ``u`` is the input of this step: ``(p,)``, or ``(M, p)`` with one row per run; ``None`` for none.
        """
        self._predict(self._step_input(u))

    def _predict(self, u: Any) -> None:
        """:meth:`predict` with the input already checked and aligned (``None``, ``(p,)`` or ``(M, 1, p)``)."""
        self.k += 1
        self._rows_p = self._sample(self.motion, self._rows_p, u, self.k, self.rngs)
        self._set_prior()

    def update(self, z: ArrayLike) -> None:
        """Weight the particles by the likelihood of ``z`` (shape (m,), or (M, m) for a batch; NaN entries are
        missing), then resample where the effective sample size calls for it."""
        m = self.m
        M = self.n_runs
        z = as_float_array("z", z)
        want = (M, m) if self._batched else (m,)
        batch_shapes = ((M, m), (M,)) if m == 1 else ((M, m),)
        if z.size != M * m or (self._batched and z.shape not in batch_shapes):
            raise ValueError(f"z must have shape {want}: {m} measurement value(s)"
                             f"{' per run' if self._batched else ''}; got shape {z.shape}")
        if _any(np.isinf(z)):
            raise ValueError("z must be finite, or NaN for a missing measurement; got an infinite value")
        self._update(z.reshape(M, m))

    def _measurement_noise(self, x: np.ndarray, k: int) -> np.ndarray:
        """The measurement noise covariance of this update: (m, m), (M, m, m) or (M, N, m, m), checked."""
        name = f"the measurement model {type(self.measurement).__name__}.R"
        R = as_model_output(name, self.measurement.R(x, k))
        m, (M, N) = self.m, x.shape[:2]
        if R.shape not in ((m, m), (M, m, m), (M, N, m, m)):
            raise ValueError(f"{name} must return shape ({m}, {m}), ({M}, {m}, {m}) or ({M}, {N}, {m}, {m}) for "
                             f"{m} measurement value(s); got {R.shape}")
        self._check_R(R)
        return R

    def _log_weights(self, x: np.ndarray, hx: np.ndarray, z: np.ndarray, R: np.ndarray, k: int) -> np.ndarray:
        """Log-likelihood (M, N) of ``z`` (M, m) for the particles ``x`` (M, N, n) with predictions ``hx``."""
        if not self._gaussian:
            name = f"the measurement model {type(self.measurement).__name__}.log_likelihood"
            logw = as_model_output(name, self.measurement.log_likelihood(x, z, k))
            if logw.shape == self._w.shape and (_any(np.isnan(logw)) or _any(np.isposinf(logw))):
                raise ValueError(f"{name} returned NaN or +inf: a log-likelihood is a real number or -inf (zero "
                                 "likelihood)")
            return logw
        if R.ndim == 2:                                   # one R for every run: whiten once while it stays
            key = R.tobytes()
            if key != self._white_key:
                self._white, self._white_diag = _whitening(R)
                self._white_key = key
            return _whitened_log_likelihood(hx.swapaxes(-1, -2), z, R, self._white, self._white_diag,
                                            self._complete)
        return gaussian_log_likelihood(hx, z, R)

    def _update(self, z: np.ndarray) -> None:
        """:meth:`update` for a measurement already checked: shape (M, m), no infinite entry."""
        M, m = z.shape
        k = max(self.k, 0)
        reuse = self._prior_moments
        self._prior_moments = False
        self._resampled = np.zeros(M, dtype=bool)
        if self._sequence_complete:                       # run() found no NaN in the whole sequence
            missing, self._complete = None, True
        else:
            missing = np.isnan(z)
            self._complete = not _any(missing)            # for the likelihood: no component missing
        none: np.ndarray | None = None
        if missing is not None and not self._complete:
            none = missing.all(axis=1)                       # runs without any measurement: predict only
            if none.all():
                self._y = np.full((M, m), np.nan)
                self._S = np.full((M, m, m), np.nan)
                return
        view = self._rows_p.swapaxes(-1, -2)
        hx, R = self._innovation_statistics(view, z, k, reuse, missing)
        w, top = self._reweighted(self._weighted_log_likelihood(view, hx, z, R, k), none)
        self._w = w
        self._uniform = np.zeros(M, dtype=bool) if none is None else self._uniform & none
        self._set_estimate()
        ess = np.array([1.0 / (w[0] @ w[0])]) if M == 1 else 1.0 / np.einsum("ij,ij->i", w, w)
        if none is not None:
            ess[none] = self._ess[none]
        self._ess = ess
        self._warn_of_collapse(ess, top, none, R, k)
        if self.ess_threshold >= 1.0:
            due = range(M) if none is None else np.flatnonzero(~none)
        else:
            low = ess < self.ess_threshold * w.shape[1]
            due = np.flatnonzero(low if none is None else low & ~none)
        if len(due):
            self._resample(due)

    def _innovation_statistics(self, view: np.ndarray, z: np.ndarray, k: int, reuse: bool,
                               missing: np.ndarray | None) -> tuple[Any, np.ndarray]:
        """Set ``y`` and ``S`` from the predicted particles (NaN where ``missing``); return their ``h(x)`` and R."""
        m = z.shape[1]
        hx = self.measurement.h(view, k)
        if hx is not view:
            hx = as_model_output(f"the measurement model {type(self.measurement).__name__}.h", hx)
        if hx is not view and getattr(hx, "shape", None) != view.shape[:-1] + (m,):
            raise ValueError(f"the measurement model's h ({type(self.measurement).__name__}) must return shape "
                             f"{view.shape[:-1] + (m,)} for particles {view.shape}; got {np.shape(hx)}")
        # h(x) = x: the moments of the predicted particles are already known
        hx_mean, hx_cov = (self._x, self._P) if (reuse and hx is view) else self._moments(_rows(hx))
        R = self._measurement_noise(view, k)
        y = self.measurement.residual(z, hx_mean)
        if R.ndim == 4:                                   # one R per particle: its weighted mean
            S = hx_cov + np.einsum("mn,mnij->mij", self._w, R)
        else:
            S = hx_cov + R
        if not self._complete and missing is not None:
            y[missing] = np.nan
            S[missing[:, :, None] | missing[:, None, :]] = np.nan
        self._y, self._S = y, S
        return hx, R

    def _weighted_log_likelihood(self, view: np.ndarray, hx: Any, z: np.ndarray, R: np.ndarray,
                                 k: int) -> np.ndarray:
        """The logs (M, N) of the new weights before normalizing: w_i <- w_i p(z | x_i), in log space."""
        logw = self._log_weights(view, hx, z, R, k)
        if getattr(logw, "shape", None) != self._w.shape:
            raise ValueError(f"the measurement model's log_likelihood must return one value per particle and run, "
                             f"shape {self._w.shape}; got {np.shape(logw)}")
        if not _all(self._uniform):
            with np.errstate(divide="ignore"):
                logw = logw + np.where(self._uniform[:, None], 0.0, np.log(self._w))
        return logw

    def _reweighted(self, logw: np.ndarray, none: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """The normalized weights (M, N) and each run's largest log (M, 1); the runs in ``none`` keep theirs."""
        M = logw.shape[0]
        if M == 1 and none is None:                       # one run: the same arithmetic on its row
            top1 = np.maximum.reduce(logw[0])
            if not math.isfinite(top1):
                raise self._lost(logw, "")
            w = logw - top1                               # a new array: the model's output is left alone
            np.exp(w, out=w)
            w /= np.add.reduce(w[0])
            return w, np.array([[top1]])
        top = np.maximum.reduce(logw, axis=1, keepdims=True)
        if none is None and _all(np.isfinite(top)):        # every run has a particle with a likelihood
            lost = None
        else:
            lost = ~np.isfinite(top[:, 0]) if none is None else ~np.isfinite(top[:, 0]) & ~none
        if lost is not None and _any(lost):
            which = f" (run {int(np.flatnonzero(lost)[0])})" if self._batched else ""
            raise self._lost(logw, which)
        if none is not None:
            top = np.where(none[:, None], 0.0, top)
        w = logw - top                                    # a new array: the model's output is left alone
        np.exp(w, out=w)
        w /= np.add.reduce(w, axis=1, keepdims=True)
        if none is not None:                              # nothing measured: weights as they were
            w[none] = self._w[none]
        return w, top

    def _warn_of_collapse(self, ess: np.ndarray, top: np.ndarray, none: np.ndarray | None, R: np.ndarray,
                          k: int) -> None:
        """Warn where the cloud collapsed onto one particle because the measurement is far from every particle."""
        # (an SIS filter that never resamples also ends on one particle, but on one that explains the data: that is
        # not warned about)
        collapsed = ess < COLLAPSE_ESS if none is None else (ess < COLLAPSE_ESS) & ~none
        N = self._w.shape[1]
        if N > 1 and _any(collapsed) and self._gaussian and R.ndim < 4:
            collapsed &= top[:, 0] < -0.5 * COLLAPSE_NIS        # the best particle's own -NIS/2 (no constant)
        else:
            collapsed[:] = False
        if _any(collapsed):
            run = int(np.flatnonzero(collapsed)[0])
            warn(_COLLAPSE.format(k=k, which=f" (run {run})" if self._batched else "", ess=float(ess[run]), N=N),
                 ParticleCollapseWarning)

    def _lost(self, logw: np.ndarray, which: str) -> Exception:
        """The error for an update where no particle has a likelihood: the model's fault when it made a NaN (an h
        or R that is NaN there), else the cloud's (:class:`ParticleDegeneracyError`)."""
        if _any(np.isnan(logw)):
            return ValueError(f"the measurement model {type(self.measurement).__name__} gave NaN log-likelihoods at "
                              f"step {max(self.k, 0)}{which} (its h or R is NaN there): check the model")
        return ParticleDegeneracyError(_LOST.format(which=which))

    def _resample(self, runs: Any = None) -> None:
        """Draw ``N`` particles with the resampler in each of ``runs`` (all by default) and reset their weights
        to ``1/N``."""
        runs = range(self.n_runs) if runs is None else runs
        N = self._rows_p.shape[2]
        # the default resampler on the filter's own weights (checked and normalized by the update) needs no check
        resample = _systematic_own_weights if self.resampler is systematic_resample else self.resampler
        w, rngs = self._w, self.rngs
        for r in runs:
            self._take(r, resample(w[r], rngs[r]))
            w[r].fill(1.0 / N)
            self._uniform[r] = True
            self._resampled[r] = True
            if self.roughening > 0.0:
                self._roughen(r)

    def _roughen(self, run: int) -> None:
        r"""Gordon et al.'s roughening of run ``run``'s resampled particles: component :math:`j` of every particle
        gets :math:`N(0, (K E_j N^{-1/n})^2)`, :math:`E_j` its spread (max - min) over the particles, an angle's as
        the motion model's differences from one particle."""
        rows = self._rows_p[run]                                      # (n, N)
        n, N = rows.shape
        x = _rows(rows[None])                                         # (1, N, n)
        d = self.motion.difference(x, x[:, :1]) if self._circular else x
        spread = np.ptp(d[0], axis=0)
        jitter = self.rngs[run].standard_normal((n, N))
        jitter *= (self.roughening * N ** (-1.0 / n) * spread)[:, None]
        rows = rows + jitter
        if self._circular:
            rows = _rows(np.asarray(self.motion.normalize(_rows(rows[None])), dtype=float))[0]
        self._rows_p[run] = rows

    def _take(self, run: int, idx: np.ndarray) -> None:
        """Keep the particles ``idx`` of run ``run`` (a subclass moves what else its particles carry)."""
        if self._rows_p.shape[0] == 1:
            self._rows_p = self._rows_p.take(idx, axis=2)
        else:
            self._rows_p[run] = self._rows_p[run].take(idx, axis=1)

    # --- whole sequences --------------------------------------------------------------------------------------------

    #: The per-run state, each array with the runs axis first (a subclass adds its own).
    _run_state: tuple[str, ...] = ("_rows_p", "_w", "_uniform", "_x", "_P", "_xp", "_Pp", "_y", "_S", "_ess",
                                   "_resampled")

    def _blocks(self) -> list[slice]:
        """Blocks of runs of about ``_BLOCK_PARTICLES`` particles that :meth:`run` takes one after the other
        (never a block of one run: that run would take the one-run arithmetic of the whole-batch products)."""
        M = self.n_runs
        size = max(2, _BLOCK_PARTICLES // self.n_particles)
        if not self._batched or M < 2 * size or not self._can_split():
            return [slice(0, M)]
        starts = list(range(0, M, size))
        if M - starts[-1] < 2:
            starts.pop()
        return [slice(a, b) for a, b in zip(starts, starts[1:] + [M])]

    def _can_split(self) -> bool:
        """Whether the runs can go block by block: every model with per-run parameters can select its runs."""
        return all(getattr(model, "n_runs", None) is None or hasattr(model, "select_runs")
                   for _, model in self._models())

    def _block(self, block: slice) -> "BootstrapParticleFilter":
        """A filter over the runs ``block`` (copies of their state; the same generators; the models' parameters of
        those runs)."""
        part = copy.copy(self)
        for name in self._run_state:
            setattr(part, name, getattr(self, name)[block].copy())
        object.__setattr__(part, "rngs", self.rngs[block])        # fixed for users (base.Configurable), not here
        for name, model in self._models():
            if getattr(model, "n_runs", None) is not None:
                object.__setattr__(part, name, model.select_runs(block))
        return part

    def _join(self, parts: Sequence["BootstrapParticleFilter"]) -> None:
        """Take the state of consecutive blocks of runs back (after :meth:`run`)."""
        for name in self._run_state:
            setattr(self, name, np.concatenate([getattr(p, name) for p in parts]))
        self._prior_moments = all(p._prior_moments for p in parts)
        self.k = parts[-1].k

    def run(self, z: ArrayLike, u: ArrayLike | None = None, times: ArrayLike | None = None) -> FilterResult:
        """Predict with ``u[k]`` then update with ``z[k]`` at every step; return the history.

        The same result, field for field, as :func:`uwtutor.filters.base.run_filter` ``(self, z, u, times)``
        (``tests/test_filter_contract_pf.py``), with the inputs checked once for the whole sequence instead of at
        every step: ``z`` of shape (K, m), or (K,) when m = 1, with the runs axis first for a batch (M, K, m);
        NaN entries missing; ``u`` one input per step, (K, p), or (M, K, p) for a batch, or ``None``. The
        ``extras`` hold ``"ess"`` and ``"resampled"`` and every further attribute a subclass names in
        ``extra_outputs`` (time axis first after any runs axis). The filter is left at the last step.
        """
        M, m = self.n_runs, self.m
        zs = as_float_array("z", z)
        batched = self._batched
        if zs.ndim == 1 + batched and m == 1:
            zs = zs[..., None]
        want = f"({M}, K, {m})" if batched else f"(K, {m})"
        if zs.ndim != 2 + batched or zs.shape[-1] != m or zs.shape[-2] < 1 or (batched and zs.shape[0] != M):
            raise ValueError(f"z must have shape {want} with K >= 1: one measurement per step"
                             f"{' and run' if batched else ''}; got {zs.shape}")
        if _any(np.isinf(zs)):
            raise ValueError("z must be finite, or NaN for a missing measurement; got an infinite value")
        K = zs.shape[-2]
        u_steps = None
        if u is not None:
            us = as_finite("u", u)
            shared = not batched or us.ndim == 2
            axis = 0 if shared else 1
            if us.ndim != 2 + (not shared) or us.shape[axis] != K or (not shared and us.shape[0] != M):
                raise ValueError(f"u must give one input per step ({K} steps along axis {axis})"
                                 f"{'' if shared else f' for each of the {M} runs'}; got shape {us.shape}")
            u_steps = us if shared else np.moveaxis(us, 1, 0)[:, :, None, :]      # (K, p) or (K, M, 1, p)
        if times is None:
            times = np.arange(K, dtype=float)
        else:
            times = as_float_array("times", times, ndim=1)
            if not np.isfinite(times).all():
                raise ValueError("times must be finite")
            if len(times) != K:
                raise ValueError(f"times must have one entry per step ({K}); got {len(times)}")
        z_steps = zs.reshape(M, K, m).transpose(1, 0, 2)          # (K, M, m)
        per_run_u = u_steps is not None and u_steps.ndim == 4
        n = self._rows_p.shape[1]
        x, xp = np.empty((K, M, n)), np.empty((K, M, n))
        P, Pp = np.empty((K, M, n, n)), np.empty((K, M, n, n))
        y, S = np.empty((K, M, m)), np.empty((K, M, m, m))
        ess, resampled = np.empty((K, M)), np.empty((K, M), dtype=bool)
        names = [name for name in self.extra_outputs if name not in ("ess", "resampled")]
        others: dict[str, list[np.ndarray]] = {name: [] for name in names}      # one (K, ...) stack per block
        blocks = self._blocks()
        parts = []
        self._sequence_complete = not _any(np.isnan(zs))     # then no step needs to look for missing values
        try:
            for block in blocks:
                # the runs are independent: a block of them goes through every step before the next block, so that
                # its arrays stay in cache (the same numbers as all runs at once, checked by the contract test)
                f = self if len(blocks) == 1 else self._block(block)
                values: dict[str, list[np.ndarray]] = {name: [] for name in names}
                # the block's slices of the inputs and histories, (K, runs of the block, ...), made once
                zb, xb, Pb, xpb, Ppb = z_steps[:, block], x[:, block], P[:, block], xp[:, block], Pp[:, block]
                yb, Sb, essb, resb = y[:, block], S[:, block], ess[:, block], resampled[:, block]
                for k in range(K):
                    uk = None if u_steps is None else (u_steps[k][block] if per_run_u else u_steps[k])
                    f._predict(uk)
                    f._update(zb[k])
                    xb[k], Pb[k], xpb[k], Ppb[k] = f._x, f._P, f._xp, f._Pp
                    yb[k], Sb[k] = f._y, f._S
                    essb[k], resb[k] = f._ess, f._resampled
                    for name in names:
                        values[name].append(np.array(getattr(f, name), copy=True))
                for name in names:
                    others[name].append(np.stack(values[name]))
                parts.append(f)
        finally:
            self._sequence_complete = False
        if len(blocks) > 1:
            self._join(parts)

        def out(a: np.ndarray) -> np.ndarray:            # (K, M, ...) -> (M, K, ...) or (K, ...)
            return np.ascontiguousarray(np.swapaxes(a, 0, 1)) if batched else a[:, 0]

        extras = {"ess": out(ess), "resampled": out(resampled)}
        for name, stacks in others.items():
            extras[name] = (np.ascontiguousarray(np.swapaxes(np.concatenate(stacks, axis=1), 0, 1)) if batched
                            else stacks[0])
        extras = {name: extras[name] for name in self.extra_outputs}
        return self.result_type(times=times, x=out(x), P=out(P), x_prior=out(xp), P_prior=out(Pp),
                                innovations=out(y), innovation_cov=out(S), extras=extras)
