r"""The bootstrap particle filter, vectorized over particles, and the models it runs on.

A particle filter represents the posterior :math:`p(x_k \mid z_{1:k})` by ``N`` samples (particles)
:math:`x^{(i)}_k` with weights :math:`w^{(i)}_k`. The bootstrap (SIR) filter of Gordon et al. (1993) proposes from the
motion model and weights by the likelihood (Arulampalam et al. 2002, Algorithm 4):

.. math::

    x^{(i)}_k \sim p(x_k \mid x^{(i)}_{k-1}), \qquad
    w^{(i)}_k \propto w^{(i)}_{k-1}\, p(z_k \mid x^{(i)}_k), \qquad \sum_i w^{(i)}_k = 1,

    \hat x_k = \sum_i w^{(i)}_k x^{(i)}_k, \qquad P_k = \sum_i w^{(i)}_k (x^{(i)}_k - \hat x_k)(x^{(i)}_k - \hat x_k)^T,

then resamples (draws ``N`` particles with probabilities :math:`w^{(i)}_k` and resets the weights to :math:`1/N`)
every step, or only when the effective sample size :math:`N_\mathrm{eff} = 1/\sum_i (w^{(i)}_k)^2` falls below a
threshold.

Models are separate from the algorithm (as in Stone Soup): a model is an object with

* ``propagate(particles, u, rng)`` -- draw from the motion model, ``(M, N, n) -> (M, N, n)`` with one
  Generator per run (a single run may also be given as ``(N, n)`` with one Generator);
* ``measure(particles)`` -- the noise-free measurement :math:`h(x)`, ``(..., N, n) -> (..., N, m)``;
* ``R`` -- the measurement noise covariance ``(m, m)``, and ``log_likelihood(particles, z)``
  (:class:`ParticleModel` provides the Gaussian one), ``(M, N, n), (M, m) -> (M, N)``.

.. rubric:: Batches of runs

Every filter here runs ``M`` independent Monte Carlo runs at once, the way the Kalman family does: particles
``(M, N, n)``, weights ``(M, N)``, estimates ``x`` ``(M, n)`` and ``P`` ``(M, n, n)``, measurements ``(M, m)``
per step (``from_gaussian(..., x0 of shape (M, n))`` or ``n_runs=M``). A single run keeps the shapes without the
runs axis (``x`` ``(n,)``, particles ``(N, n)``) and is the ``M = 1`` case of the same code. Each run draws from
its own ``numpy.random.Generator``: give a sequence of ``M`` Generators, or one Generator, which is then split
with :meth:`numpy.random.Generator.spawn`. Run ``m`` of a batch is then, draw for draw, the single-run filter
given the same ``m``-th Generator (``tests/test_filter_contract_pf.py`` checks it); a single run given one
Generator uses it directly.

Ready models: :class:`DepthSpeedPitchModel`, the depth/speed/pitch model of Li et al. (paper C, the grey particle
filter); :class:`PitchManeuverModel`, the same with the pitch drawn towards a target (one maneuver: cruise, dive or
climb); and :class:`LinearGaussianModel`, on which the particle filter can be checked against the Kalman filter.

Two filters of paper C build on :class:`BootstrapParticleFilter` by changing how particles are proposed:

* :class:`MultipleModelParticleFilter` (MMPF) -- every particle also carries the index of a motion model
  (a *mode*), which switches as a Markov chain before each step; the weights then give the mode probabilities
  (McGinnity and Irwin 2000; Boers and Driessen 2003);
* :class:`GreyParticleFilter` (GPF, paper C) -- a share of the particles (1 in 10) is drawn around a GM(1,1)
  forecast of the last ``L`` measurements (:mod:`uwtutor.grey`) instead of from the motion model, and the
  likelihood uses a measurement noise measured online by the wavelet MAD estimate (:mod:`uwtutor.wavelet`).

The kinematics of paper C's models are those of :mod:`uwtutor.models.depth`, which its EKF
(:class:`~uwtutor.filters.depth_ekf.DepthEKF`) uses too.

References
----------
Arulampalam, M. S., Maskell, S., Gordon, N. and Clapp, T. (2002). A tutorial on particle filters for online
nonlinear/non-Gaussian Bayesian tracking. *IEEE Trans. Signal Processing* 50(2), 174-188.

Gordon, N. J., Salmond, D. J. and Smith, A. F. M. (1993). Novel approach to nonlinear/non-Gaussian Bayesian
state estimation. *IEE Proceedings F* 140(2), 107-113.

Li Ting, Zhao Dexin, Huang Zhiping and Su Shaojing (2013). A method for self-estimating the depth of maneuvering
AUV based on the grey particle filter. *Journal of National University of Defense Technology* 35(5), 185-190
(paper C).

McGinnity, S. and Irwin, G. W. (2000). Multiple model bootstrap filter for maneuvering target tracking. *IEEE
Trans. Aerospace and Electronic Systems* 36(3), 1006-1012.

Boers, Y. and Driessen, J. N. (2003). Interacting multiple model particle filter. *IEE Proceedings - Radar, Sonar
and Navigation* 150(5), 344-349.
"""

from __future__ import annotations

import copy
import functools
import math
from typing import Any, Sequence

import numpy as np

from .._validate import as_covariance, as_finite, as_float_array, as_int, as_nonnegative, as_positive, as_rng
from ..grey import gm11_next
from ..models.depth import DEFAULT_PROCESS_STD, DEFAULT_SENSOR_STD, DepthSpeedPitch
from ..models.noise import per_run_generators, standard_normal_per_run
from ..resampling import Resampler, systematic_resample
from ..wavelet import as_wavelet, detail_matrix, mad_sigma
from .base import FilterResult

__all__ = [
    "ParticleModel",
    "DepthSpeedPitchModel",
    "PitchManeuverModel",
    "LinearGaussianModel",
    "BootstrapParticleFilter",
    "MultipleModelParticleFilter",
    "GreyParticleFilter",
    "ParticleDegeneracyError",
]


class ParticleDegeneracyError(RuntimeError):
    """Every particle got zero likelihood: the particle cloud has lost the measurement."""


def _sqrt_psd(name: str, Q: np.ndarray) -> np.ndarray:
    """A matrix ``L`` with ``L L^T = Q`` for a positive semi-definite ``Q`` (Cholesky when it exists)."""
    try:
        return np.linalg.cholesky(Q)
    except np.linalg.LinAlgError:
        vals, vecs = np.linalg.eigh(Q)
        return vecs * np.sqrt(np.clip(vals, 0.0, None))


def _as_batch(particles: Any) -> tuple[np.ndarray, bool]:
    """Particles as ``(M, N, n)`` and whether they were one run ``(N, n)``."""
    p = np.asarray(particles, dtype=float)
    return (p[None], True) if p.ndim == 2 else (p, False)


#: Particles per block of runs that ``run`` moves through all steps together (a block stays in cache).
_BLOCK_PARTICLES = 10_000

_any = functools.partial(np.logical_or.reduce, axis=None)      # a.any() / a.all() without numpy's Python wrappers
_all = functools.partial(np.logical_and.reduce, axis=None)


def _takes_runs_axis(model: Any, name: str) -> bool:
    """Whether ``model``'s method ``name`` takes a runs axis (M, N, n): the library's models do, and so does a
    model class that sets ``handles_runs_axis = True``. A method a user overrode for one run -- particles (N, n),
    a measurement (m,), one Generator, as before particle filters were batched -- is called run by run."""
    if getattr(type(model), "handles_runs_axis", False):
        return True
    method = getattr(type(model), name, None)
    return method is None or getattr(method, "__module__", "").startswith("uwtutor.")


def _measure(model: Any, particles: np.ndarray) -> np.ndarray:
    """``model.measure`` of particles (M, N, n), run by run for a single-run override."""
    if _takes_runs_axis(model, "measure"):
        return model.measure(particles)
    return np.stack([np.asarray(model.measure(p), dtype=float) for p in particles])


def _rows(values: np.ndarray) -> np.ndarray:
    """``(M, N, k) -> (M, k, N)``: each component of every run contiguous (a view when it already is)."""
    return values.swapaxes(-1, -2)


def _gaussian_log_likelihood(hx_rows: np.ndarray, z: np.ndarray, R: np.ndarray, whiten: np.ndarray,
                             diagonal: bool) -> np.ndarray:
    r""":math:`-\tfrac12 (z - h)^T R^{-1} (z - h)` for every particle of every run, ``(M, N)``.

    ``hx_rows`` (M, m, N); ``z`` (M, m), NaN entries missing; ``R`` (m, m) or (M, m, m); ``whiten`` the
    reciprocal standard deviations (m,) or (M, m) when ``diagonal``, else :math:`W` (m, m) or (M, m, m) with
    :math:`W^T = L^{-1}`, :math:`L L^T = R`. A run with every entry missing gets 0 (its weights do not change).
    """
    missing = np.isnan(z)
    if not _any(missing):              # rows (M, m, N): contiguous per component
        d = hx_rows - z[..., None]
        if diagonal:
            d *= whiten[..., None]
        else:
            d = np.swapaxes(whiten, -1, -2) @ d
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


class ParticleModel:
    r"""Base class of particle-filter models: Gaussian measurement noise and its log-likelihood.

    Subclasses implement ``propagate`` and ``measure`` and set ``n_states`` and ``R``. The filters call them
    with a runs axis, particles ``(M, N, n)``; a subclass whose methods are written for one run (particles
    ``(N, n)``, a measurement ``(m,)``, one Generator) works too: the filters then call them run by run. Set
    ``handles_runs_axis = True`` on a subclass whose overrides take the runs axis themselves (faster).

    .. math::

        \log p(z \mid x^{(i)}) = -\tfrac12 (z - h(x^{(i)}))^T R^{-1} (z - h(x^{(i)})) + \text{const}

    NaN entries of ``z`` are missing sensor readings: the likelihood uses the other entries (the marginal of
    the Gaussian), and a measurement that is entirely NaN leaves the weights unchanged.

    Attributes
    ----------
    n_states : int
        Size ``n`` of the state.
    R : ndarray, shape (m, m)
        Measurement noise covariance; assign a new one at any time (e.g. an online noise estimate).
    """

    n_states: int = 0

    def __init__(self, R: Any) -> None:
        self.R = R

    @property
    def R(self) -> np.ndarray:
        """Measurement noise covariance ``(m, m)`` (positive definite)."""
        return self._R

    @R.setter
    def R(self, value: Any) -> None:
        R = as_covariance("R", value)
        if R.ndim != 2:
            raise ValueError(f"R must be one (m, m) matrix; got shape {R.shape}")
        self._R = R
        self._R_is_diag = bool(np.all(R == np.diag(np.diag(R))))
        self._whiten = 1.0 / np.sqrt(np.diag(R)) if self._R_is_diag else np.linalg.inv(np.linalg.cholesky(R)).T

    @property
    def n_measurements(self) -> int:
        """Size ``m`` of a measurement."""
        return self._R.shape[0]

    def propagate(self, particles: np.ndarray, u: Any, rng: Any) -> np.ndarray:
        """Draw every particle's next state from the motion model.

        ``particles`` (M, N, n) with ``rng`` a sequence of ``M`` Generators (run ``m`` draws from ``rng[m]``),
        or one run (N, n) with one Generator; returns the same shape.
        """
        raise NotImplementedError

    def measure(self, particles: np.ndarray) -> np.ndarray:
        """The noise-free measurement :math:`h(x)` of every particle (``(..., N, n) -> (..., N, m)``)."""
        raise NotImplementedError

    def log_likelihood(self, particles: np.ndarray, z: np.ndarray) -> np.ndarray:
        """Gaussian log-likelihood of ``z``, up to a constant: (N, n), (m,) -> (N,) or (M, N, n), (M, m) -> (M, N)."""
        p, single = _as_batch(particles)
        zz = np.asarray(z, dtype=float).reshape(p.shape[0], -1)
        out = _gaussian_log_likelihood(_rows(self.measure(p)), zz, self._R, self._whiten, self._R_is_diag)
        return out[0] if single else out


class DepthSpeedPitchModel(ParticleModel):
    r"""Depth, speed and pitch of an AUV with all three measured (paper C, Li et al.).

    State :math:`x_k = [z_k, v_k, \phi_k]^T` (depth [m], speed [m/s], pitch [rad]), sampling interval ``T``:

    .. math::

        z_k = z_{k-1} + (v_{k-1} + u^v_k) \sin(\phi_{k-1} + u^\phi_k)\, T + u^z_k, \qquad
        v_k = v_{k-1} + u^v_k, \qquad \phi_k = \phi_{k-1} + u^\phi_k,

    with independent Gaussian :math:`u^z_k, u^v_k, u^\phi_k` (standard deviations ``process_std``); the speed
    and pitch noise of step ``k`` enter the depth equation too. The sensors measure the state directly:
    :math:`y_k = x_k + w_k`, :math:`w_k \sim N(0, R)`. The kinematics are
    the motion model :class:`uwtutor.models.depth.DepthSpeedPitch` (``motion``), shared with :class:`~uwtutor.filters.depth_ekf.DepthEKF`.

    Parameters
    ----------
    T : float, optional
        Sampling interval [s]; 0.05 s in paper C.
    process_std : array_like, shape (3,), optional
        Standard deviations of :math:`u^z, u^v, u^\phi` per step [m, m/s, rad].
        The default :data:`uwtutor.models.depth.DEFAULT_PROCESS_STD` ``(0.01, 0.01, 0.0035)`` is illustrative:
        the paper's process covariance is not a valid covariance matrix (not positive semi-definite), so a
        diagonal one is used instead (paper C's diagonal: :mod:`uwtutor.scenarios.paper_c`).
    R : array_like, shape (3, 3), optional
        Sensor noise covariance. Paper C gives :math:`R = \mathrm{diag}(0.2^2, 5^2, 0.5^2)` without units; the
        default reads it as 0.2 m, 5 cm/s and 0.5 deg, i.e. ``diag(0.2**2, 0.05**2, radians(0.5)**2)``.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.filters import BootstrapParticleFilter, DepthSpeedPitchModel
    >>> rng = np.random.default_rng(3)
    >>> model = DepthSpeedPitchModel()
    >>> truth, meas = model.simulate([10.0, 1.5, 0.1], 200, rng)
    >>> pf = BootstrapParticleFilter.from_gaussian(
    ...     model, meas[0], model.R, 500, rng
    ... )
    >>> res = pf.run(meas)
    >>> res.x.shape, res.extras["ess"].shape
    ((200, 3), (200,))
    >>> # better than the depth sensor
    >>> bool(np.sqrt(np.mean((res.x[50:, 0] - truth[50:, 0]) ** 2)) < 0.2)
    True
    """

    n_states = 3

    def __init__(self, T: float = 0.05, process_std: Any = None, R: Any = None) -> None:
        self.motion = DepthSpeedPitch(T=T, process_std=DEFAULT_PROCESS_STD if process_std is None else process_std)
        self.T = self.motion.T
        self.process_std = self.motion.process_std
        if R is None:
            R = np.diag(DEFAULT_SENSOR_STD**2)
        super().__init__(R)
        if self.n_measurements != 3:
            raise ValueError(f"R must be 3x3 (depth, speed, pitch sensors); got {self.R.shape}")

    def propagate(self, particles: np.ndarray, u: Any, rng: Any) -> np.ndarray:
        """One step of the motion model for every particle; ``u`` must be ``None`` (the model has no input)."""
        if u is not None:
            raise ValueError("DepthSpeedPitchModel takes no control input: call predict() without u")
        p, single = _as_batch(particles)
        out = _rows(self.motion.sample_rows(_rows(p), rng))        # (M, N, 3), each component contiguous
        return out[0] if single else out

    def measure(self, particles: np.ndarray) -> np.ndarray:
        """All three states are measured: :math:`h(x) = x`."""
        return particles

    def simulate(self, x0: Any, n_steps: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """A true trajectory drawn from the model and its measurements.

        Parameters
        ----------
        x0 : array_like, shape (3,)
            State before the first step.
        n_steps : int
            Number of steps ``K``.
        rng : numpy.random.Generator
            Source of the process and sensor noise.

        Returns
        -------
        truth : ndarray, shape (K, 3)
            States after each step.
        measurements : ndarray, shape (K, 3)
            ``truth`` plus sensor noise drawn from ``R``.
        """
        x = as_finite("x0", x0, shape=(3,))[None, :]
        K = as_int("n_steps", n_steps, minimum=1)
        rng = as_rng(rng)
        truth = np.empty((K, 3))
        for k in range(K):
            x = self.propagate(x, None, rng)
            truth[k] = x[0]
        noise = rng.standard_normal((K, 3)) @ np.linalg.cholesky(self.R).T
        return truth, truth + noise


class PitchManeuverModel(DepthSpeedPitchModel):
    r"""Paper C's depth/speed/pitch model with the pitch drawn towards a target: one mode of a maneuver.

    Before the step of :class:`DepthSpeedPitchModel`, the pitch relaxes towards ``pitch_target`` with time
    constant :math:`\tau`:

    .. math::

        \bar\phi_{k-1} = \phi_{k-1} + (1 - e^{-T/\tau})\,(\phi^* - \phi_{k-1}),

    then :math:`z_k = z_{k-1} + (v_{k-1} + u^v_k) \sin(\bar\phi_{k-1} + u^\phi_k)\, T + u^z_k`,
    :math:`v_k = v_{k-1} + u^v_k`, :math:`\phi_k = \bar\phi_{k-1} + u^\phi_k`. With the depth
    :math:`z` positive downwards, a positive pitch makes the vehicle go deeper (nose down). Three such models with
    targets 0 (cruise), :math:`+\phi_d` (dive) and :math:`-\phi_c` (climb) make the mode set of the
    multiple-model particle filter of the chapter on paper C.

    Parameters
    ----------
    pitch_target : float, optional
        :math:`\phi^*` [rad]; 0 by default (cruise at constant depth).
    time_constant : float, optional
        :math:`\tau` [s] (> 0); 2 s by default.
    T : float, optional
        Sampling interval [s].
    process_std : array_like, shape (3,), optional
        Standard deviations of :math:`u^z, u^v, u^\phi` per step [m, m/s, rad].
    R : array_like, shape (3, 3), optional
        Sensor noise covariance (as in :class:`DepthSpeedPitchModel`).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.filters import PitchManeuverModel
    >>> dive = PitchManeuverModel(
    ...     pitch_target=0.3,
    ...     time_constant=1.0,
    ...     T=0.05,
    ...     process_std=[0.0, 0.0, 0.0],
    ... )
    >>> dive.propagate(
    ...     np.array([[10.0, 2.0, 0.0]]), None, np.random.default_rng(0)
    ... ).round(5)
    array([[10.00146,  2.     ,  0.01463]])
    """

    def __init__(self, pitch_target: float = 0.0, time_constant: float = 2.0, T: float = 0.05,
                 process_std: Any = None, R: Any = None) -> None:
        super().__init__(T=T, process_std=process_std, R=R)
        self.pitch_target = float(as_finite("pitch_target", pitch_target))
        self.time_constant = float(as_positive("time_constant", time_constant))
        self._gain = -math.expm1(-self.T / self.time_constant)

    def propagate(self, particles: np.ndarray, u: Any, rng: Any) -> np.ndarray:
        """Pull every particle's pitch towards the target, then one step of :class:`DepthSpeedPitchModel`."""
        pulled = np.array(particles, dtype=float)
        pitch = pulled[..., 2]
        pitch += self._gain * (self.pitch_target - pitch)
        return super().propagate(pulled, u, rng)


class RelativeRangeModel(ParticleModel):
    r"""Range-only navigation to one beacon, in coordinates relative to the beacon: :math:`s_k = p_k - b_k`.

    .. math::

        s_k = s_{k-1} + u_k - (b_k - b_{k-1}) + w_k, \quad w_k \sim N(0, Q), \qquad
        z_k = \lVert s_k \rVert + \eta_k, \quad \eta_k \sim N(0, R).

    Relative to the beacon, a beacon that moves (a ship or a leader broadcasting its position) only changes the
    input: give ``u`` minus the beacon's displacement, and add :math:`b_k` back to the estimates
    (:func:`uwtutor.methods.particle_filter` does both). The likelihood is a ring of radius :math:`z_k` about the
    beacon, so the particles can hold the two mirror solutions of a straight track at once, which no Gaussian
    filter can.

    Parameters
    ----------
    Q : array_like, shape (2, 2)
        DR noise covariance per step [m²] (positive semi-definite).
    R : float or array_like, shape (1, 1)
        Range noise variance [m²].

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.filters import RelativeRangeModel
    >>> model = RelativeRangeModel(np.eye(2), 4.0)
    >>> model.measure(np.array([[3.0, 4.0]])).tolist()
    [[5.0]]
    """

    n_states = 2
    handles_runs_axis = True

    def __init__(self, Q: Any, R: Any) -> None:
        self.Q = as_covariance("Q", Q, 2, allow_singular=True)
        self._Q_sqrt_T = _sqrt_psd("Q", self.Q).T
        super().__init__(np.atleast_2d(np.asarray(R, dtype=float)))
        if self.n_measurements != 1:
            raise ValueError(f"R must be one range variance (a number or a 1x1 matrix); got shape {self.R.shape}")

    def propagate(self, particles: np.ndarray, u: Any, rng: Any) -> np.ndarray:
        r""":math:`s^{(i)}_k = s^{(i)}_{k-1} + u_k + w^{(i)}_k`; ``u`` is ``(2,)`` or ``(M, 2)`` (relative motion)."""
        p, single = _as_batch(particles)
        rngs = per_run_generators(rng, p.shape[0], spawn=False)
        out = p + standard_normal_per_run(rngs, p.shape[1:]) @ self._Q_sqrt_T
        if u is not None:
            step = as_finite("u", u)
            out += step[:, None, :] if step.ndim == 2 else step
        return out[0] if single else out

    def measure(self, particles: np.ndarray) -> np.ndarray:
        r""":math:`h(s) = \lVert s \rVert` for every particle, ``(..., N, 2) -> (..., N, 1)``."""
        return np.sqrt(np.einsum("...i,...i->...", particles, particles))[..., None]


class LinearGaussianModel(ParticleModel):
    r"""Linear-Gaussian model :math:`x_k = F x_{k-1} + B u_k + w_k`, :math:`z_k = H x_k + v_k`.

    With :math:`w_k \sim N(0, Q)` and :math:`v_k \sim N(0, R)` the exact posterior is the Kalman filter's
    (:class:`uwtutor.filters.kalman.KalmanFilter`), which makes this model the reference test of a particle filter.

    Parameters
    ----------
    F : array_like, shape (n, n)
        State transition matrix.
    H : array_like, shape (m, n)
        Measurement matrix.
    Q : array_like, shape (n, n)
        Process noise covariance (positive semi-definite).
    R : array_like, shape (m, m) or scalar
        Measurement noise covariance (positive definite).
    B : array_like, shape (n, p), optional
        Control-input matrix (``None``: no input).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.filters import LinearGaussianModel
    >>> walk = LinearGaussianModel(
    ...     F=[[1.0]], H=[[1.0]], Q=[[0.0]], R=[[1.0]], B=[[1.0]]
    ... )
    >>> # no noise: F x + B u
    >>> walk.propagate(np.zeros((2, 1)), [0.5], np.random.default_rng(0))
    array([[0.5],
           [0.5]])
    """

    def __init__(self, F: Any, H: Any, Q: Any, R: Any, B: Any = None) -> None:
        self.F = as_finite("F", F, ndim=2)
        n = self.F.shape[0]
        if self.F.shape != (n, n):
            raise ValueError(f"F must be square; got shape {self.F.shape}")
        self.n_states = n
        self.H = as_finite("H", H, ndim=2)
        if self.H.shape[1] != n:
            raise ValueError(f"H must have {n} columns to match F; got shape {self.H.shape}")
        self.Q = as_covariance("Q", Q, n, allow_singular=True)
        self._Q_sqrt_T = _sqrt_psd("Q", self.Q).T
        super().__init__(R)
        if self.n_measurements != self.H.shape[0]:
            raise ValueError(f"R must be {self.H.shape[0]}x{self.H.shape[0]} to match H; got {self.R.shape}")
        self.B = None if B is None else as_finite("B", B, ndim=2)
        if self.B is not None and self.B.shape[0] != n:
            raise ValueError(f"B must have {n} rows to match F; got shape {self.B.shape}")

    def propagate(self, particles: np.ndarray, u: Any, rng: Any) -> np.ndarray:
        """:math:`x^{(i)}_k = F x^{(i)}_{k-1} + B u_k + w^{(i)}_k` for every particle.

        ``u`` is one input ``(p,)`` shared by every run, or ``(M, p)``, one per run.
        """
        p, single = _as_batch(particles)
        rngs = per_run_generators(rng, p.shape[0], spawn=False)
        noise = standard_normal_per_run(rngs, p.shape[1:])
        if p.shape[0] == 1:                                   # one run: plain 2-D products
            out = (p[0] @ self.F.T + noise[0] @ self._Q_sqrt_T)[None]
        else:
            out = p @ self.F.T + noise @ self._Q_sqrt_T
        if u is not None:
            if self.B is None:
                raise ValueError("u was given but this model has no control-input matrix B")
            Bu = as_finite("u", u) @ self.B.T
            out += Bu[:, None, :] if Bu.ndim == 2 else Bu
        return out[0] if single else out

    def measure(self, particles: np.ndarray) -> np.ndarray:
        """:math:`h(x) = H x` for every particle."""
        return particles @ self.H.T


class BootstrapParticleFilter:
    r"""Bootstrap (SIR) particle filter, vectorized over its ``N`` particles and over ``M`` runs, with a pluggable
    resampler.

    Each step: ``predict(u)`` draws every particle from the motion model; ``update(z)`` multiplies the weights by
    the likelihood (in log space, so tiny likelihoods do not underflow), records the estimate, the effective
    sample size :math:`N_\mathrm{eff} = 1/\sum_i w_i^2` and the innovation, then resamples when
    :math:`N_\mathrm{eff} < \tau N` with :math:`\tau` = ``ess_threshold`` (always when ``ess_threshold >= 1``).
    Equations in the module docstring (Arulampalam et al. 2002, Algorithms 2 and 4). Every run of a batch does
    this on its own particles with its own random stream (module docstring, *Batches of runs*).

    Parameters
    ----------
    model : ParticleModel
        The motion and measurement model (``propagate``, ``measure``, ``log_likelihood``, ``R``).
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

    Examples
    --------
    A scalar random walk observed in noise, checked against the exact (Kalman) answer:

    >>> import numpy as np
    >>> from uwtutor.filters import (
    ...     BootstrapParticleFilter,
    ...     KalmanFilter,
    ...     LinearGaussianModel,
    ... )
    >>> rng = np.random.default_rng(0)
    >>> zs = np.cumsum(rng.normal(0.0, 1.0, 30)) + rng.normal(0.0, 2.0, 30)
    >>> model = LinearGaussianModel(F=[[1.0]], H=[[1.0]], Q=[[1.0]], R=[[4.0]])
    >>> pf = BootstrapParticleFilter.from_gaussian(
    ...     model, [0.0], [[10.0]], 20000, rng
    ... )
    >>> kf = KalmanFilter(
    ...     F=[[1.0]], H=[[1.0]], Q=[[1.0]], R=[[4.0]], x0=[0.0], P0=[[10.0]]
    ... )
    >>> bool(np.max(np.abs(pf.run(zs).x - kf.run(zs).x)) < 0.1)
    True

    Four runs at once, each with its own stream; run 2 is the single-run filter on the same stream:

    >>> Z = np.stack([zs, zs + 1.0, zs - 1.0, zs])
    >>> batch = BootstrapParticleFilter.from_gaussian(
    ...     model, [0.0], [[10.0]], 500, np.random.default_rng(1), n_runs=4
    ... )
    >>> res = batch.run(Z)
    >>> res.x.shape, res.extras["ess"].shape
    ((4, 30, 1), (4, 30))
    >>> one = BootstrapParticleFilter.from_gaussian(
    ...     model, [0.0], [[10.0]], 500, np.random.default_rng(1).spawn(4)[2]
    ... )
    >>> bool(np.allclose(one.run(Z[2]).x, res.x[2]))
    True
    """

    #: Per-step outputs recorded by :func:`uwtutor.filters.base.run_filter` in ``FilterResult.extras``.
    extra_outputs: tuple[str, ...] = ("ess", "resampled")
    result_type = FilterResult

    def __init__(self, model: ParticleModel, particles: Any, rng: Any, *, weights: Any = None,
                 resampler: Resampler = systematic_resample, ess_threshold: float = 1.0) -> None:
        self.model = model
        self._n_states = getattr(model, "n_states", None)
        p = as_finite("particles", particles, ndim=(2, 3))
        self._batched = p.ndim == 3
        self._w = np.empty((0, 0))
        self.particles = p
        M = self._rows_p.shape[0]
        if isinstance(rng, np.random.Generator):
            rng = as_rng(rng)
        self.rngs = per_run_generators(rng, M)
        if weights is not None:
            self.weights = weights
        if not callable(resampler):
            raise TypeError(f"resampler must be a function (weights, rng) -> indices; got {resampler!r}")
        self.resampler = resampler
        self.ess_threshold = float(as_nonnegative("ess_threshold", ess_threshold))
        m = model.n_measurements
        self._y = np.full((M, m), np.nan)
        self._S = np.full((M, m, m), np.nan)
        self._ess = 1.0 / np.einsum("ij,ij->i", self._w, self._w)
        self._resampled = np.zeros(M, dtype=bool)
        self._prior_moments = False
        self._set_estimate()
        self._xp, self._Pp = self._x, self._P

    @classmethod
    def from_gaussian(cls, model: Any, x0: Any, P0: Any, n_particles: int, rng: Any, *, n_runs: int | None = None,
                      **kwargs: Any) -> "BootstrapParticleFilter":
        """A filter whose ``n_particles`` initial particles of each run are drawn from :math:`N(x_0, P_0)`.

        Parameters
        ----------
        model : ParticleModel (or the list of mode models of :class:`MultipleModelParticleFilter`)
            Passed to the constructor.
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
        roots = [_sqrt_psd("P0", P0)] * M if P0.ndim == 2 else [_sqrt_psd("P0", Pm) for Pm in P0]
        particles = np.empty((M, N, n))
        for m in range(M):
            particles[m] = X0[m] + rngs[m].standard_normal((N, n)) @ roots[m].T
        if not batched:
            return cls(model, particles[0], rngs[0], **kwargs)
        return cls(model, particles, rngs, **kwargs)

    # --- shapes: runs axis inside, removed for a single run outside ------------------------------------------------

    def _out(self, a: np.ndarray) -> Any:
        return a if self._batched else a[0]

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
    def particles(self, value: Any) -> None:
        p = as_finite("particles", value, ndim=3 if self._batched else 2)
        pb = p if self._batched else p[None]
        n = self._n_states or pb.shape[2]
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

    @property
    def weights(self) -> np.ndarray:
        """Normalized particle weights, shape (N,) or (M, N); assigned weights are checked and normalized, and
        ``x``, ``P`` become their weighted moments."""
        return self._out(self._w)

    @weights.setter
    def weights(self, value: Any) -> None:
        shape = self._w.shape if self._batched else self._w.shape[1:]
        w = as_nonnegative("weights", value, shape=shape).reshape(self._w.shape)
        total = w.sum(axis=1, keepdims=True)
        if not (total > 0).all():
            raise ValueError("weights must have a positive sum (at least one particle with weight > 0) in every run")
        self._w = w / total
        self._uniform = np.zeros(self._w.shape[0], dtype=bool)
        self._prior_moments = False
        self._set_estimate()                          # x and P follow the new weights

    x = property(lambda self: self._out(self._x), doc="Weighted mean of the particles, (n,) or (M, n).")
    P = property(lambda self: self._out(self._P), doc="Weighted covariance of the particles, (n, n) or (M, n, n).")
    x_prior = property(lambda self: self._out(self._xp), doc="Weighted mean of the predicted particles of this step, (n,) or (M, n).")
    P_prior = property(lambda self: self._out(self._Pp), doc="Weighted covariance of the predicted particles of this step.")
    y = property(lambda self: self._out(self._y), doc="Innovation of the last update, (m,) or (M, m).")
    S = property(lambda self: self._out(self._S), doc="Innovation covariance of the last update.")

    @property
    def ess(self) -> Any:
        """Effective sample size after the last update (a float, or an (M,) array for a batch)."""
        return self._ess.copy() if self._batched else float(self._ess[0])

    @property
    def resampled(self) -> Any:
        """Whether the last update resampled (a bool, or an (M,) array for a batch)."""
        return self._resampled.copy() if self._batched else bool(self._resampled[0])

    # --- the algorithm ----------------------------------------------------------------------------------------------

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

    def _set_estimate(self) -> None:
        self._x, self._P = self._moments(self._rows_p)

    def _set_prior(self) -> None:
        self._set_estimate()
        self._xp, self._Pp = self._x, self._P
        self._prior_moments = True

    def _per_run_input(self, u: Any, runs: np.ndarray) -> Any:
        """The inputs of the selected runs: ``u`` shared (p,), or the rows of a per-run ``u`` (M, p)."""
        if u is None or not self._batched or np.ndim(u) < 2:
            return u
        return np.asarray(u)[runs]

    def _propagate(self, model: ParticleModel, rows: np.ndarray, u: Any, runs: np.ndarray,
                   name: str = "model") -> np.ndarray:
        """Move ``rows`` (R, n, count) of the runs ``runs`` with ``model``; returns new rows (R, n, count)."""
        rngs = self.rngs if len(runs) == len(self.rngs) else tuple(self.rngs[r] for r in runs)
        u_runs = None if u is None else self._per_run_input(u, runs)
        if _takes_runs_axis(model, "propagate"):
            new = model.propagate(rows.swapaxes(-1, -2), u_runs, rngs)
        else:                                   # a single-run override: (N, n), that run's input, its Generator
            per_run = u_runs is not None and self._batched and np.ndim(u_runs) >= 2
            new = np.stack([np.asarray(model.propagate(p, u_runs[i] if per_run else u_runs, rngs[i]), dtype=float)
                            for i, p in enumerate(rows.swapaxes(-1, -2))])
        want = (rows.shape[0], rows.shape[2], rows.shape[1])
        if getattr(new, "shape", None) != want:
            raise ValueError(f"{name}.propagate must return particles of shape {want}; got {np.shape(new)}")
        out = new.swapaxes(-1, -2)
        return out if out.flags.c_contiguous else np.ascontiguousarray(out)

    def predict(self, u: Any = None) -> None:
        """Draw every particle from the motion model (``model.propagate``); ``x``, ``P`` follow, and
        ``x_prior``, ``P_prior`` keep the moments of the predicted particles.

        ``u`` is the input of this step: ``(p,)``, or ``(M, p)`` with one row per run; ``None`` for none.
        """
        self._rows_p = self._propagate(self.model, self._rows_p, u, range(self._rows_p.shape[0]))
        self._set_prior()

    def update(self, z: Any) -> None:
        """Weight the particles by the likelihood of ``z`` (shape (m,), or (M, m) for a batch; NaN entries are
        missing), then resample where the effective sample size calls for it."""
        m = self.model.n_measurements
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

    def _log_weights(self, particles: np.ndarray, z: np.ndarray) -> np.ndarray:
        """Log-likelihood (M, N) of ``z`` (M, m) for the particles (M, N, n)."""
        model = self.model
        if type(model).log_likelihood is ParticleModel.log_likelihood:     # the Gaussian one, without wrappers
            return _gaussian_log_likelihood(_rows(_measure(model, particles)), z, model._R, model._whiten,
                                            model._R_is_diag)
        if _takes_runs_axis(model, "log_likelihood"):
            return model.log_likelihood(particles, z)
        return np.stack([np.asarray(model.log_likelihood(p, zr), dtype=float) for p, zr in zip(particles, z)])

    def _measurement_cov(self) -> np.ndarray:
        """The measurement noise covariance of this update: (m, m) or (M, m, m)."""
        return self.model.R

    def _update(self, z: np.ndarray) -> None:
        """:meth:`update` for a measurement already checked: shape (M, m), no infinite entry."""
        M, m = z.shape
        missing = np.isnan(z)
        reuse = self._prior_moments
        self._prior_moments = False
        self._resampled = np.zeros(M, dtype=bool)
        if not _any(missing):
            none = None
        else:
            none = missing.all(axis=1)                       # runs without any measurement: predict only
            if none.all():
                self._y = np.full((M, m), np.nan)
                self._S = np.full((M, m, m), np.nan)
                return

        # innovation statistics from the predicted particles (h(x) = x: the moments are already known)
        view = _rows(self._rows_p)
        hx = _measure(self.model, view)
        hx_mean, hx_cov = (self._x, self._P) if (reuse and hx is view) else self._moments(_rows(hx))
        y = z - hx_mean
        S = hx_cov + self._measurement_cov()
        if none is not None:
            y[missing] = np.nan
            S[missing[:, :, None] | missing[:, None, :]] = np.nan
        self._y, self._S = y, S

        # reweight in log space: w_i <- w_i p(z | x_i)
        logw = self._log_weights(view, z)
        if getattr(logw, "shape", None) != self._w.shape:
            raise ValueError(f"model.log_likelihood must return one value per particle and run, shape "
                             f"{self._w.shape}; got {np.shape(logw)}")
        if not _all(self._uniform):
            with np.errstate(divide="ignore"):
                logw = logw + np.where(self._uniform[:, None], 0.0, np.log(self._w))
        top = np.maximum.reduce(logw, axis=1, keepdims=True)
        lost = ~np.isfinite(top[:, 0]) if none is None else ~np.isfinite(top[:, 0]) & ~none
        if _any(lost):
            which = f" (run {int(np.flatnonzero(lost)[0])})" if self._batched else ""
            raise ParticleDegeneracyError(
                f"every particle has zero likelihood for this measurement{which}: the particles have lost the "
                "track. Use more particles, a larger process noise, or check the measurement and R")
        if none is not None:
            top = np.where(none[:, None], 0.0, top)
        w = logw - top                                    # a new array: the model's output is left alone
        np.exp(w, out=w)
        w /= np.add.reduce(w, axis=1, keepdims=True)
        if none is not None:                              # nothing measured: weights as they were
            w[none] = self._w[none]
        self._w = w
        self._uniform = np.zeros(M, dtype=bool) if none is None else self._uniform & none
        self._set_estimate()
        ess = np.array([1.0 / float(w[0] @ w[0])]) if M == 1 else 1.0 / np.einsum("ij,ij->i", w, w)
        if none is not None:
            ess[none] = self._ess[none]
        self._ess = ess
        if self.ess_threshold >= 1.0:
            due = range(M) if none is None else np.flatnonzero(~none)
        else:
            low = ess < self.ess_threshold * w.shape[1]
            due = np.flatnonzero(low if none is None else low & ~none)
        if len(due):
            self._resample(due)

    def _resample(self, runs: Any = None) -> None:
        """Draw ``N`` particles with the resampler in each of ``runs`` (all by default) and reset their weights
        to ``1/N``."""
        runs = range(self.n_runs) if runs is None else runs
        N = self.n_particles
        for r in runs:
            idx = self.resampler(self._w[r], self.rngs[r])
            self._take(r, idx)
            self._w[r].fill(1.0 / N)
            self._uniform[r] = True
            self._resampled[r] = True

    def _take(self, run: int, idx: np.ndarray) -> None:
        """Keep the particles ``idx`` of run ``run`` (a subclass moves what else its particles carry)."""
        if self._rows_p.shape[0] == 1:
            self._rows_p = self._rows_p.take(idx, axis=2)
        else:
            self._rows_p[run] = self._rows_p[run].take(idx, axis=1)

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
        return True

    def _block(self, block: slice) -> "BootstrapParticleFilter":
        """A filter over the runs ``block`` (copies of their state; the same generators)."""
        part = copy.copy(self)
        for name in self._run_state:
            setattr(part, name, getattr(self, name)[block].copy())
        part.rngs = self.rngs[block]
        return part

    def _join(self, parts: Sequence["BootstrapParticleFilter"]) -> None:
        """Take the state of consecutive blocks of runs back (after :meth:`run`)."""
        for name in self._run_state:
            setattr(self, name, np.concatenate([getattr(p, name) for p in parts]))
        self._prior_moments = all(p._prior_moments for p in parts)

    def run(self, z: Any, u: Any = None, times: Any = None) -> FilterResult:
        """Predict with ``u[k]`` then update with ``z[k]`` at every step; return the history.

        The same result, field for field, as :func:`uwtutor.filters.base.run_filter` ``(self, z, u, times)``
        (``tests/test_filter_contract_pf.py``), with the inputs checked once for the whole sequence instead of at
        every step: ``z`` of shape (K, m), or (K,) when m = 1, with the runs axis first for a batch (M, K, m);
        NaN entries missing; ``u`` one input per step, (K, p), or (M, K, p) for a batch, or ``None``. The
        ``extras`` hold ``"ess"`` and ``"resampled"`` and every further attribute a subclass names in
        ``extra_outputs`` (time axis first after any runs axis). The filter is left at the last step.
        """
        M, m = self.n_runs, self.model.n_measurements
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
            us = as_float_array("u", u)
            shared = not batched or us.ndim == 2
            axis = 0 if shared else 1
            if us.ndim <= axis or us.shape[axis] != K:
                raise ValueError(f"u must give one input per step ({K} steps along axis {axis}); got shape "
                                 f"{us.shape}")
            u_steps = us if shared else np.moveaxis(us, 1, 0)
        if times is None:
            times = np.arange(K, dtype=float)
        else:
            times = as_float_array("times", times, ndim=1)
            if not np.isfinite(times).all():
                raise ValueError("times must be finite")
            if len(times) != K:
                raise ValueError(f"times must have one entry per step ({K}); got {len(times)}")
        z_steps = zs.reshape(M, K, m).transpose(1, 0, 2)          # (K, M, m)
        per_run_u = u_steps is not None and batched and u_steps.ndim == 3
        n = self._rows_p.shape[1]
        x, xp = np.empty((K, M, n)), np.empty((K, M, n))
        P, Pp = np.empty((K, M, n, n)), np.empty((K, M, n, n))
        y, S = np.empty((K, M, m)), np.empty((K, M, m, m))
        ess, resampled = np.empty((K, M)), np.empty((K, M), dtype=bool)
        names = [name for name in self.extra_outputs if name not in ("ess", "resampled")]
        others: dict[str, list[np.ndarray]] = {name: [] for name in names}      # one (K, ...) stack per block
        blocks = self._blocks()
        parts = []
        for block in blocks:
            # the runs are independent: a block of them goes through every step before the next block, so that
            # its arrays stay in cache (the same numbers as all runs at once, checked by the contract test)
            f = self if len(blocks) == 1 else self._block(block)
            values: dict[str, list[np.ndarray]] = {name: [] for name in names}
            for k in range(K):
                uk = None if u_steps is None else (u_steps[k][block] if per_run_u else u_steps[k])
                f.predict(uk)
                f._update(z_steps[k][block])
                x[k, block], P[k, block], xp[k, block], Pp[k, block] = f._x, f._P, f._xp, f._Pp
                y[k, block], S[k, block] = f._y, f._S
                ess[k, block], resampled[k, block] = f._ess, f._resampled
                for name in names:
                    values[name].append(np.array(getattr(f, name), copy=True))
            for name in names:
                others[name].append(np.stack(values[name]))
            parts.append(f)
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


class MultipleModelParticleFilter(BootstrapParticleFilter):
    r"""Multiple-model (jump-Markov) bootstrap particle filter: every particle carries a motion mode.

    ``J`` motion models (the *modes*, e.g. cruise, dive and climb) share one measurement model. Particle ``i``
    carries a mode :math:`r^{(i)}_k \in \{0, \dots, J-1\}` that switches as a Markov chain with transition matrix
    :math:`\Pi_{jl} = \Pr(r_k = l \mid r_{k-1} = j)` before each step, and moves with its mode's model
    (McGinnity and Irwin 2000):

    .. math::

        r^{(i)}_k \sim \Pi_{r^{(i)}_{k-1}, \cdot}, \qquad x^{(i)}_k \sim p(x_k \mid x^{(i)}_{k-1}, r^{(i)}_k), \qquad
        w^{(i)}_k \propto w^{(i)}_{k-1}\, p(z_k \mid x^{(i)}_k), \qquad
        \mu^j_k = \sum_{i:\, r^{(i)}_k = j} w^{(i)}_k .

    The estimate is the weighted mean over all particles (the mixture of the modes' estimates by their
    probabilities :math:`\mu^j_k`); resampling copies the modes with the particles. Everything else (likelihood,
    effective sample size, resampling rule, missing measurements) is that of :class:`BootstrapParticleFilter`.

    Parameters
    ----------
    models : sequence of ParticleModel
        The ``J`` mode models; same state size and same measurement noise ``R`` (the likelihood is shared).
    particles : array_like, shape (N, n) or (M, N, n)
        Initial particles (of ``M`` runs).
    rng : numpy.random.Generator or sequence of numpy.random.Generator
        Source of all randomness (mode switches, motion noise, resampling), one per run as in
        :class:`BootstrapParticleFilter`.
    transition : array_like, shape (J, J)
        Mode transition matrix: entries >= 0, each row summing to 1.
    modes : array_like of int, shape (N,) or (M, N), optional
        Initial mode of each particle; drawn from ``mode_probabilities`` when not given.
    mode_probabilities : array_like, shape (J,), optional
        Initial mode probabilities (equal by default); used only when ``modes`` is not given.
    weights : array_like, shape (N,) or (M, N), optional
        Initial weights; equal by default.
    resampler : callable, optional
        ``resampler(weights, rng) -> indices`` (systematic by default).
    ess_threshold : float, optional
        As in :class:`BootstrapParticleFilter` (1.0: resample at every measurement).

    Attributes
    ----------
    modes : ndarray of int, shape (N,) or (M, N)
        Current mode of each particle.
    mode_probabilities : ndarray, shape (J,) or (M, J)
        :math:`\mu^j` after the last step (after ``update``: the posterior, before any resampling).
    models : list of ParticleModel
        The mode models.
    transition : ndarray, shape (J, J)
        The transition matrix.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.filters import MultipleModelParticleFilter, PitchManeuverModel
    >>> # cruise, dive, climb
    >>> modes = [PitchManeuverModel(pitch_target=p) for p in (0.0, 0.3, -0.3)]
    >>> Pi = np.full((3, 3), 0.005) + np.eye(3) * 0.985
    >>> rng = np.random.default_rng(0)
    >>> truth, meas = PitchManeuverModel(pitch_target=0.3).simulate(
    ...     [10.0, 1.5, 0.0], 200, rng
    ... )
    >>> mmpf = MultipleModelParticleFilter.from_gaussian(
    ...     modes, meas[0], modes[0].R, 600, rng, transition=Pi
    ... )
    >>> res = mmpf.run(meas)
    >>> res.extras["mode_probabilities"].shape
    (200, 3)
    >>> # the dive mode wins
    >>> int(np.argmax(res.extras["mode_probabilities"][-50:].mean(axis=0)))
    1
    """

    extra_outputs = ("ess", "resampled", "mode_probabilities")
    _run_state = BootstrapParticleFilter._run_state + ("_modes", "_mu")

    def __init__(self, models: Sequence[ParticleModel], particles: Any, rng: Any, *,
                 transition: Any, modes: Any = None, mode_probabilities: Any = None, weights: Any = None,
                 resampler: Resampler = systematic_resample, ess_threshold: float = 1.0) -> None:
        models = list(models) if isinstance(models, (list, tuple)) else [models]
        if not models or not all(isinstance(m, ParticleModel) for m in models):
            raise TypeError("models must be a non-empty list of ParticleModel objects (one per mode)")
        first = models[0]
        for j, m in enumerate(models[1:], start=1):
            if m.n_states != first.n_states or m.R.shape != first.R.shape or not np.allclose(m.R, first.R):
                raise ValueError(f"models must share the state size and the measurement noise R (one likelihood "
                                 f"for all modes); model {j} differs from model 0")
        J = len(models)
        Pi = as_nonnegative("transition", transition, shape=(J, J))
        rows = Pi.sum(axis=1)
        if np.abs(rows - 1.0).max() > 1e-9:
            raise ValueError(f"transition must be row-stochastic (each row sums to 1); its rows sum to {rows}")
        self.models = models
        self.transition = Pi / rows[:, None]
        self._cum_transition = np.cumsum(self.transition, axis=1)
        self._modes = np.empty((0, 0), dtype=np.intp)
        super().__init__(first, particles, rng, weights=weights, resampler=resampler, ess_threshold=ess_threshold)
        M, N = self._w.shape
        if modes is not None:
            m = np.asarray(modes)
            want = (M, N) if self._batched else (N,)
            if m.shape != want or m.dtype.kind not in "iu" or (m < 0).any() or (m >= J).any():
                raise ValueError(f"modes must be integers in 0..{J - 1} of shape {want} (one per particle); "
                                 f"got {modes!r}")
            self._modes = m.astype(np.intp).reshape(M, N)
        else:
            if mode_probabilities is None:
                p = np.full(J, 1.0 / J)
            else:
                p = as_nonnegative("mode_probabilities", mode_probabilities, shape=(J,))
                if not p.sum() > 0:
                    raise ValueError("mode_probabilities must have a positive sum")
                p = p / p.sum()
            cum = np.cumsum(p)
            self._modes = np.stack([np.minimum(np.searchsorted(cum, r.random(N), side="right"), J - 1)
                                    for r in self.rngs])
        self._set_estimate()

    @property
    def modes(self) -> np.ndarray:
        """Mode index of each particle, shape (N,) or (M, N)."""
        return self._out(self._modes)

    @property
    def n_modes(self) -> int:
        """Number of modes ``J``."""
        return len(self.models)

    @property
    def mode_probabilities(self) -> np.ndarray:
        r""":math:`\mu^j` of each run: (J,) or (M, J)."""
        return self._out(self._mu)

    def _set_estimate(self) -> None:
        super()._set_estimate()
        J = self.n_modes
        if self._modes.shape != self._w.shape:                 # during construction, before the modes exist
            self._mu = np.full((self._w.shape[0], J), np.nan)
        elif self._w.shape[0] == 1:
            self._mu = np.bincount(self._modes[0], weights=self._w[0], minlength=J)[None]
        else:
            M = self._w.shape[0]
            flat = (self._modes + J * np.arange(M)[:, None]).ravel()
            self._mu = np.bincount(flat, weights=self._w.ravel(), minlength=M * J).reshape(M, J)

    def predict(self, u: Any = None) -> None:
        """Switch every particle's mode (Markov chain), then move it with its mode's model (run by run)."""
        J = self.n_modes
        for r in range(self.n_runs):
            draws = self.rngs[r].random(self.n_particles)
            new_modes = np.minimum((draws[:, None] >= self._cum_transition[self._modes[r]]).sum(axis=1), J - 1)
            # group the particles by mode (their order carries no meaning) so that each model moves one block
            order = np.argsort(new_modes, kind="stable")
            counts = np.bincount(new_modes, minlength=J)
            grouped = self._rows_p[r].take(order, axis=1)
            pieces, start = [], 0
            for j, (model, count) in enumerate(zip(self.models, counts)):
                if count:
                    block = grouped[None, :, start:start + count]
                    pieces.append(self._propagate(model, block, u, np.array([r]), name=f"models[{j}]")[0])
                    start += count
            self._rows_p[r] = np.concatenate(pieces, axis=1)
            self._modes[r] = new_modes[order]
            if not self._uniform[r]:
                self._w[r] = self._w[r][order]
        self._set_prior()

    def _take(self, run: int, idx: np.ndarray) -> None:
        """Resampling copies the modes with the particles."""
        super()._take(run, idx)
        self._modes[run] = self._modes[run].take(idx)


class GreyParticleFilter(BootstrapParticleFilter):
    r"""Grey particle filter (GPF) of paper C: grey-forecast particles and a wavelet-estimated noise level.

    The sensors measure the state directly (:math:`h(x) = x`). Each step (paper C, section 2.4):

    1. **Sampling** (eq. (20)-(22)). :math:`N_\mathrm{std} = N - N_\mathrm{grey}` particles are drawn from the
       motion model as in :class:`BootstrapParticleFilter` (from a random subset of the equally weighted particles
       left by the last resampling); the other :math:`N_\mathrm{grey}` are drawn around the GM(1,1) forecast
       :math:`x^\mathrm{grey}_k` of each measured component from its last ``L`` measurements
       (:func:`uwtutor.grey.gm11_forecast`):

       .. math::

           x^j_k = x^\mathrm{grey}_k + u^j_k, \quad u^j_k \sim N(0, \mathrm{diag}(\sigma_\mathrm{grey}^2)),
           \qquad j = N_\mathrm{std} + 1, \dots, N.

       A component that can be <= 0 (the pitch) is shifted by ``grey_offset`` for the fit. Until ``L``
       measurements are available (or when one of them is missing, or a shifted window is not positive), all
       ``N`` particles come from the motion model.
    2. **Weighting** (eq. (17)-(19), (23)). The measurement noise of each sensor is estimated from its last
       ``noise_window`` measurements (the window ends at the current one) by the wavelet MAD estimate
       (:func:`uwtutor.wavelet.noise_sigma`, ``db6``), :math:`R_k = \mathrm{diag}(\hat\sigma^2_{z},
       \hat\sigma^2_{v}, \hat\sigma^2_{\phi})`, and the weights are the Gaussian likelihoods under
       :math:`R_k`. Until a window is full (or when it holds a missing value) the sensor keeps its last estimate,
       initially the model's ``R``.
    3. **Estimate and resampling** (eq. (24)): weighted mean, then resampling at every step.

    Parameters
    ----------
    model : ParticleModel
        Motion and measurement model with :math:`h(x) = x` (``n_measurements == n_states``), e.g.
        :class:`DepthSpeedPitchModel`. The filter keeps its own per-run :math:`R_k` and leaves the model's alone.
    particles : array_like, shape (N, n) or (M, N, n)
        Initial particles (of ``M`` runs).
    rng : numpy.random.Generator or sequence of numpy.random.Generator
        Source of all randomness, one per run as in :class:`BootstrapParticleFilter`.
    grey_fraction : float, optional
        :math:`N_\mathrm{grey} / N`, in [0, 1); 0.1 (paper C's 1:9). 0 turns the grey sampling off.
    grey_window : int, optional
        ``L``, measurements per GM(1,1) fit (>= 4); 30 in paper C.
    grey_std : array_like, shape (n,), optional
        Standard deviations of the noise added to the grey forecast; by default the model's ``process_std``
        (paper C uses the process noise :math:`Q_k`).
    grey_offset : array_like, shape (n,), optional
        Shift added to each component before its GM(1,1) fit (and removed after); zeros by default. Give the pitch
        a shift larger than any pitch the vehicle reaches, e.g. 1 rad.
    noise_window : int, optional
        Length of the wavelet window (50 in paper C), at least the wavelet's filter length.
    wavelet : str, optional
        ``"db6"`` (paper C: six vanishing moments against a local polynomial of degree 5).
    adapt_noise : bool, optional
        ``True`` (default): weight with the wavelet :math:`R_k`; ``False``: keep the model's ``R``.
    min_noise_std : array_like, shape (n,), optional
        Floor of the estimated standard deviations (keeps :math:`R_k` positive definite); by default 1 % of the
        model's initial ones.
    resampler : callable, optional
        ``resampler(weights, rng) -> indices`` (systematic by default).
    weights : array_like, shape (N,) or (M, N), optional
        Initial weights; equal by default.

    Attributes
    ----------
    noise_std : ndarray, shape (n,) or (M, n)
        Sensor noise standard deviations used by the last update.
    grey_used : bool or ndarray of shape (M,)
        Whether the last ``predict`` drew grey particles.
    grey_forecast : ndarray, shape (n,) or (M, n)
        The last grey forecast (NaN when none was made).
    n_grey : int
        :math:`N_\mathrm{grey}`.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.filters import DepthSpeedPitchModel, GreyParticleFilter
    >>> model = DepthSpeedPitchModel()
    >>> rng = np.random.default_rng(5)
    >>> truth, meas = model.simulate([10.0, 1.5, 0.1], 300, rng)
    >>> gpf = GreyParticleFilter.from_gaussian(
    ...     model, meas[0], model.R, 500, rng, grey_offset=[0.0, 0.0, 1.0]
    ... )
    >>> res = gpf.run(meas)
    >>> int(res.extras["grey_used"].sum()), res.extras["noise_std"].shape
    (270, (300, 3))
    """

    extra_outputs = ("ess", "resampled", "noise_std", "grey_used", "grey_forecast")
    _run_state = BootstrapParticleFilter._run_state + ("_noise_std", "_R_runs", "_whiten_runs", "_estimated",
                                                       "_history", "_grey_used", "_grey_forecast")

    def _can_split(self) -> bool:
        return self._R_diag              # whitening vectors of one shape in every block

    def __init__(self, model: ParticleModel, particles: Any, rng: Any, *,
                 grey_fraction: float = 0.1, grey_window: int = 30, grey_std: Any = None, grey_offset: Any = None,
                 noise_window: int = 50, wavelet: str = "db6", adapt_noise: bool = True,
                 min_noise_std: Any = None, resampler: Resampler = systematic_resample,
                 weights: Any = None) -> None:
        if model.n_measurements != model.n_states:
            raise ValueError("GreyParticleFilter needs a model that measures its state directly (h(x) = x, "
                             f"n_measurements == n_states); got {model.n_measurements} measurements of "
                             f"{model.n_states} states")
        super().__init__(model, particles, rng, weights=weights, resampler=resampler, ess_threshold=1.0)
        n = model.n_states
        M, N = self._w.shape
        frac = float(as_finite("grey_fraction", grey_fraction))
        if not 0.0 <= frac < 1.0:
            raise ValueError(f"grey_fraction must lie in [0, 1) (paper C: 0.1); got {frac}")
        self.grey_fraction = frac
        self.n_grey = int(round(frac * N))
        self.grey_window = as_int("grey_window", grey_window, minimum=4)
        if grey_std is None:
            if not hasattr(model, "process_std"):
                raise ValueError("grey_std must be given for a model without a process_std attribute")
            grey_std = model.process_std
        self.grey_std = as_nonnegative("grey_std", grey_std, shape=(n,))
        self.grey_offset = (np.zeros(n) if grey_offset is None
                            else as_finite("grey_offset", grey_offset, shape=(n,)))
        self._wavelet = as_wavelet(wavelet)
        self.noise_window = as_int("noise_window", noise_window, minimum=self._wavelet.dec_len)
        # the valid finest-scale DWT of a window is linear in it: one (window, n_coefficients) matrix
        self._dwt_matrix = detail_matrix(self.noise_window, self._wavelet)
        self.adapt_noise = bool(adapt_noise)
        R0 = model.R.copy()
        sd0 = np.sqrt(np.diag(R0))
        self.min_noise_std = (0.01 * sd0 if min_noise_std is None
                              else as_positive("min_noise_std", min_noise_std, shape=(n,)))
        self._noise_std = np.tile(sd0, (M, 1))
        # the R_k of each run: the model's R until the run's first wavelet estimate, diagonal after it
        self._R_runs = np.tile(R0, (M, 1, 1))
        self._R_diag = model._R_is_diag
        self._whiten_runs = np.tile(model._whiten, (M,) + (1,) * model._whiten.ndim)
        self._estimated = np.zeros(M, dtype=bool)
        self._history = np.full((M, n, max(self.grey_window, self.noise_window)), np.nan)
        self._grey_used = np.zeros(M, dtype=bool)
        self._grey_forecast = np.full((M, n), np.nan)

    noise_std = property(lambda self: self._out(self._noise_std).copy(),
                         doc="Sensor noise standard deviations used by the last update, (n,) or (M, n).")
    grey_forecast = property(lambda self: self._out(self._grey_forecast).copy(),
                             doc="The last grey forecast, (n,) or (M, n) (NaN when none was made).")

    @property
    def grey_used(self) -> Any:
        """Whether the last ``predict`` drew grey particles (a bool, or an (M,) array for a batch)."""
        return self._grey_used.copy() if self._batched else bool(self._grey_used[0])

    def _grey_prediction(self) -> tuple[np.ndarray, np.ndarray]:
        """GM(1,1) one-step forecast (M, n) of every component from its last ``L`` measurements, and the mask
        (M,) of the runs where one could be made (a full, positive window)."""
        window = self._history[..., -self.grey_window:] + self.grey_offset[:, None]
        M = window.shape[0]
        ok = np.minimum.reduce(window.reshape(M, -1), axis=1) > 0.0   # also False when a reading is missing (NaN)
        if _all(ok):
            return gm11_next(window) - self.grey_offset, ok
        forecast = np.full(window.shape[:2], np.nan)
        if _any(ok):
            forecast[ok] = gm11_next(window[ok]) - self.grey_offset
        return forecast, ok

    def predict(self, u: Any = None) -> None:
        """Draw ``N - N_grey`` particles from the motion model and ``N_grey`` around the grey forecast."""
        M, N = self._w.shape
        n = self._rows_p.shape[1]
        if self.n_grey > 0:
            forecast, grey = self._grey_prediction()
        else:
            forecast, grey = np.full((M, n), np.nan), np.zeros(M, dtype=bool)
        every = _all(grey)
        if not every:
            plain = np.flatnonzero(~grey)
            if plain.size == M:
                self._rows_p = self._propagate(self.model, self._rows_p, u, range(M))
            else:
                self._rows_p[plain] = self._propagate(self.model, self._rows_p[plain], u, plain)
        if every or _any(grey):
            runs = range(M) if every else np.flatnonzero(grey)
            unequal = [r for r in runs if not self._uniform[r]]
            if unequal:                       # the subset below must come from equally weighted particles
                self._resample(unequal)
            n_std = N - self.n_grey
            new = np.empty((len(runs), n, N))                    # component-major particles, as everywhere else
            for i, r in enumerate(runs):
                new[i, :, :n_std] = self._rows_p[r].take(self.rngs[r].permutation(N)[:n_std], axis=1)
            new[:, :, :n_std] = self._propagate(self.model, new[:, :, :n_std], u, runs)
            grey_rows = np.empty((len(runs), n, self.n_grey))
            for i, r in enumerate(runs):
                self.rngs[r].standard_normal(out=grey_rows[i])
            grey_rows *= self.grey_std[:, None]
            grey_rows += (forecast if every else forecast[runs])[:, :, None]
            new[:, :, n_std:] = grey_rows
            if every:
                self._rows_p = new
            else:
                self._rows_p[runs] = new
        self._grey_used = grey
        self._grey_forecast = forecast
        self._set_prior()

    def _measurement_cov(self) -> np.ndarray:
        return self._R_runs

    def _log_weights(self, particles: np.ndarray, z: np.ndarray) -> np.ndarray:
        return _gaussian_log_likelihood(_rows(_measure(self.model, particles)), z, self._R_runs,
                                        self._whiten_runs, self._R_diag)

    def _update(self, z: np.ndarray) -> None:
        hist = self._history
        hist[..., :-1] = hist[..., 1:]
        hist[..., -1] = z
        if self.adapt_noise:
            window = hist[..., -self.noise_window:]
            full = ~np.isnan(np.add.reduce(window, axis=2))             # (M, sensors): a window without a gap
            if _all(full):
                sigma = mad_sigma(window @ self._dwt_matrix)            # median |d| / 0.6745, (M, sensors)
                self._noise_std = np.maximum(sigma, self.min_noise_std)
                runs = np.ones(full.shape[0], dtype=bool)
            elif _any(full):
                sigma = mad_sigma(window[full] @ self._dwt_matrix)      # (count,)
                self._noise_std = self._noise_std.copy()
                self._noise_std[full] = np.maximum(sigma, np.broadcast_to(self.min_noise_std, full.shape)[full])
                runs = np.logical_or.reduce(full, axis=1)
            if _any(full):
                sd = self._noise_std[runs]
                m = sd.shape[1]
                diag = np.arange(m)
                R_new = np.zeros(sd.shape + (m,))
                R_new[:, diag, diag] = sd * sd
                every = _all(runs)
                self._R_runs = R_new if every else self._R_runs.copy()
                if not every:
                    self._R_runs[runs] = R_new
                if self._R_diag and every:
                    self._whiten_runs = 1.0 / sd
                    self._estimated = runs
                    super()._update(z)
                    return
                self._whiten_runs = self._whiten_runs.copy()
                if self._R_diag:
                    self._whiten_runs[runs] = 1.0 / sd
                else:                             # a non-diagonal initial R: whitening matrices until every run
                    W = np.zeros_like(R_new)      # has its own (diagonal) estimate
                    W[:, diag, diag] = 1.0 / sd
                    self._whiten_runs[runs] = W
                    if (self._estimated | runs).all():
                        self._whiten_runs = np.diagonal(self._whiten_runs, axis1=1, axis2=2).copy()
                        self._R_diag = True
                self._estimated |= runs
        super()._update(z)
