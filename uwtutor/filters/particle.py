r"""The bootstrap particle filter, vectorized over particles, and the models it runs on.

A particle filter represents the posterior :math:`p(x_k \mid z_{1:k})` by ``N`` samples (particles)
:math:`x^i_k` with weights :math:`w^i_k`. The bootstrap (SIR) filter of Gordon et al. (1993) proposes from the
motion model and weights by the likelihood (Arulampalam et al. 2002, Algorithm 4):

.. math::

    x^i_k \sim p(x_k \mid x^i_{k-1}), \qquad
    w^i_k \propto w^i_{k-1}\, p(z_k \mid x^i_k), \qquad \sum_i w^i_k = 1,

    \hat x_k = \sum_i w^i_k x^i_k, \qquad P_k = \sum_i w^i_k (x^i_k - \hat x_k)(x^i_k - \hat x_k)^T,

then resamples (draws ``N`` particles with probabilities :math:`w^i_k` and resets the weights to :math:`1/N`)
every step, or only when the effective sample size :math:`N_\mathrm{eff} = 1/\sum_i (w^i_k)^2` falls below a
threshold.

Models are separate from the algorithm (as in Stone Soup): a model is an object with

* ``propagate(particles, u, rng)`` -- draw from the motion model, ``(N, n) -> (N, n)``;
* ``measure(particles)`` -- the noise-free measurement :math:`h(x)`, ``(N, n) -> (N, m)``;
* ``R`` -- the measurement noise covariance ``(m, m)``, and ``log_likelihood(particles, z)``
  (:class:`ParticleModel` provides the Gaussian one).

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
import math
from typing import Any, Sequence

import numpy as np

from .._validate import as_covariance, as_finite, as_float_array, as_int, as_nonnegative, as_positive, as_rng
from ..grey import _coefficients as _gm11_coefficients
from ..grey import _restored as _gm11_restored
from ..resampling import Resampler, systematic_resample
from ..wavelet import MAD_TO_SIGMA, _valid_details, _wavelet
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


class ParticleModel:
    r"""Base class of particle-filter models: Gaussian measurement noise and its log-likelihood.

    Subclasses implement ``propagate`` and ``measure`` and set ``n_states`` and ``R``.

    .. math::

        \log p(z \mid x^i) = -\tfrac12 (z - h(x^i))^T R^{-1} (z - h(x^i)) + \text{const}

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
        self._whiten_column = self._whiten[:, None] if self._R_is_diag else None

    @property
    def n_measurements(self) -> int:
        """Size ``m`` of a measurement."""
        return self._R.shape[0]

    def _set_noise_std(self, std: np.ndarray) -> None:
        """Set a diagonal ``R = diag(std**2)`` from positive, finite standard deviations (no further checks).

        The fast path of :class:`GreyParticleFilter`, which sets a new ``R`` at every step.
        """
        self._R = np.diag(std * std)
        self._R_is_diag = True
        self._whiten = 1.0 / std
        self._whiten_column = self._whiten[:, None]

    def propagate(self, particles: np.ndarray, u: Any, rng: np.random.Generator) -> np.ndarray:
        """Draw every particle's next state from the motion model (``(N, n) -> (N, n)``)."""
        raise NotImplementedError

    def measure(self, particles: np.ndarray) -> np.ndarray:
        """The noise-free measurement :math:`h(x)` of every particle (``(N, n) -> (N, m)``)."""
        raise NotImplementedError

    def log_likelihood(self, particles: np.ndarray, z: np.ndarray) -> np.ndarray:
        """Gaussian log-likelihood of the measurement ``z`` (m,) for every particle, up to a constant (N,)."""
        missing = np.isnan(z)
        if not missing.any():                     # work on rows (m, N): contiguous for column-major particles
            d = self.measure(particles).T - z[:, None]
            if self._R_is_diag:
                d *= self._whiten_column
            else:
                d = self._whiten.T @ d
        else:
            present = ~missing
            L = np.linalg.cholesky(self._R[np.ix_(present, present)])
            d = np.linalg.solve(L, self.measure(particles).T[present] - z[present, None])
        d *= d
        out = np.add.reduce(d, axis=0)
        out *= -0.5
        return out


class DepthSpeedPitchModel(ParticleModel):
    r"""Depth, speed and pitch of an AUV with all three measured (paper C, Li et al.).

    State :math:`x_k = [z_k, v_k, \varphi_k]^T` (depth [m], speed [m/s], pitch [rad]), sampling interval ``T``:

    .. math::

        z_k = z_{k-1} + (v_{k-1} + u^v_k) \sin(\varphi_{k-1} + u^\varphi_k)\, T + u^z_k, \qquad
        v_k = v_{k-1} + u^v_k, \qquad \varphi_k = \varphi_{k-1} + u^\varphi_k,

    with independent Gaussian :math:`u^z_k, u^v_k, u^\varphi_k` (standard deviations ``process_std``); the speed
    and pitch noise of step ``k`` enter the depth equation too. The sensors measure the state directly:
    :math:`y_k = x_k + w_k`, :math:`w_k \sim N(0, R)`.

    Parameters
    ----------
    T : float, optional
        Sampling interval [s]; 0.05 s in paper C.
    process_std : array_like, shape (3,), optional
        Standard deviations of :math:`u^z, u^v, u^\varphi` per step [m, m/s, rad].
        The default ``(0.01, 0.01, 0.0035)`` is illustrative: the paper's process covariance is not a valid
        covariance matrix (not positive semi-definite), so a diagonal one is used instead.
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
    >>> pf = BootstrapParticleFilter.from_gaussian(model, meas[0], model.R, 500, rng)
    >>> res = pf.run(meas)
    >>> res.x.shape, res.extras["ess"].shape
    ((200, 3), (200,))
    >>> bool(np.sqrt(np.mean((res.x[50:, 0] - truth[50:, 0]) ** 2)) < 0.2)   # better than the depth sensor
    True
    """

    n_states = 3

    def __init__(self, T: float = 0.05, process_std: Any = (0.01, 0.01, 0.0035),
                 R: Any = None) -> None:
        self.T = float(as_positive("T", T))
        self.process_std = as_nonnegative("process_std", process_std, shape=(3,))
        self._std_column = self.process_std[:, None]
        if R is None:
            R = np.diag([0.2**2, 0.05**2, np.radians(0.5) ** 2])
        super().__init__(R)
        if self.n_measurements != 3:
            raise ValueError(f"R must be 3x3 (depth, speed, pitch sensors); got {self.R.shape}")

    def propagate(self, particles: np.ndarray, u: Any, rng: np.random.Generator) -> np.ndarray:
        """One step of the motion model for every particle; ``u`` must be ``None`` (the model has no input)."""
        if u is not None:
            raise ValueError("DepthSpeedPitchModel takes no control input: call predict() without u")
        noise = rng.standard_normal((3, particles.shape[0]))     # rows u^z, u^v, u^phi
        noise *= self._std_column
        rows = np.add(particles.T, noise, out=noise)             # z + u^z, v_k = v + u^v, phi_k = phi + u^phi
        dz = np.sin(rows[2])
        dz *= rows[1]
        dz *= self.T
        rows[0] += dz                                            # z_k = z + v_k sin(phi_k) T + u^z
        return rows.T                                            # (N, 3), column-major like the input

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

        \bar\varphi_{k-1} = \varphi_{k-1} + (1 - e^{-T/\tau})\,(\varphi^* - \varphi_{k-1}),

    then :math:`z_k = z_{k-1} + (v_{k-1} + u^v_k) \sin(\bar\varphi_{k-1} + u^\varphi_k)\, T + u^z_k`,
    :math:`v_k = v_{k-1} + u^v_k`, :math:`\varphi_k = \bar\varphi_{k-1} + u^\varphi_k`. With the depth
    :math:`z` positive downwards, a positive pitch makes the vehicle go deeper (nose down). Three such models with
    targets 0 (cruise), :math:`+\varphi_d` (dive) and :math:`-\varphi_c` (climb) make the mode set of the
    multiple-model particle filter of the chapter on paper C.

    Parameters
    ----------
    pitch_target : float, optional
        :math:`\varphi^*` [rad]; 0 by default (cruise at constant depth).
    time_constant : float, optional
        :math:`\tau` [s] (> 0); 2 s by default.
    T : float, optional
        Sampling interval [s].
    process_std : array_like, shape (3,), optional
        Standard deviations of :math:`u^z, u^v, u^\varphi` per step [m, m/s, rad].
    R : array_like, shape (3, 3), optional
        Sensor noise covariance (as in :class:`DepthSpeedPitchModel`).
    """

    def __init__(self, pitch_target: float = 0.0, time_constant: float = 2.0, T: float = 0.05,
                 process_std: Any = (0.01, 0.01, 0.0035), R: Any = None) -> None:
        super().__init__(T=T, process_std=process_std, R=R)
        self.pitch_target = float(as_finite("pitch_target", pitch_target))
        self.time_constant = float(as_positive("time_constant", time_constant))
        self._gain = -math.expm1(-self.T / self.time_constant)

    def propagate(self, particles: np.ndarray, u: Any, rng: np.random.Generator) -> np.ndarray:
        """Pull every particle's pitch towards the target, then one step of :class:`DepthSpeedPitchModel`."""
        pulled = np.array(particles, dtype=float, order="F")
        pitch = pulled[:, 2]
        pitch += self._gain * (self.pitch_target - pitch)
        return super().propagate(pulled, u, rng)


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

    def propagate(self, particles: np.ndarray, u: Any, rng: np.random.Generator) -> np.ndarray:
        """:math:`x^i_k = F x^i_{k-1} + B u_k + w^i_k` for every particle."""
        out = particles @ self.F.T + rng.standard_normal(particles.shape) @ self._Q_sqrt_T
        if u is not None:
            if self.B is None:
                raise ValueError("u was given but this model has no control-input matrix B")
            out += as_finite("u", u) @ self.B.T
        return out

    def measure(self, particles: np.ndarray) -> np.ndarray:
        """:math:`h(x) = H x` for every particle."""
        return particles @ self.H.T


class BootstrapParticleFilter:
    r"""Bootstrap (SIR) particle filter, vectorized over its ``N`` particles, with a pluggable resampler.

    Each step: ``predict(u)`` draws every particle from the motion model; ``update(z)`` multiplies the weights by
    the likelihood (in log space, so tiny likelihoods do not underflow), records the estimate, the effective
    sample size :math:`N_\mathrm{eff} = 1/\sum_i w_i^2` and the innovation, then resamples when
    :math:`N_\mathrm{eff} < \tau N` with :math:`\tau` = ``ess_threshold`` (always when ``ess_threshold >= 1``).
    Equations in the module docstring (Arulampalam et al. 2002, Algorithms 2 and 4).

    Parameters
    ----------
    model : ParticleModel
        The motion and measurement model (``propagate``, ``measure``, ``log_likelihood``, ``R``).
    particles : array_like, shape (N, n)
        Initial particles.
    rng : numpy.random.Generator
        Source of all randomness (motion noise and resampling).
    weights : array_like, shape (N,), optional
        Initial weights (normalized here); equal by default.
    resampler : callable, optional
        ``resampler(weights, rng) -> indices``; :func:`uwtutor.resampling.systematic_resample` by default.
        Any function of :mod:`uwtutor.resampling` fits, and so does a wrapper of a filterpy resampler
        (``lambda w, rng: filterpy.monte_carlo.systematic_resample(w)``).
    ess_threshold : float, optional
        Resample when :math:`N_\mathrm{eff} <` ``ess_threshold`` :math:`\cdot N`. 1.0 (the default, as in paper C)
        resamples after every measurement, 0.5 is a common adaptive choice, 0 never resamples (plain
        sequential importance sampling, which degenerates). A step without a measurement never resamples.

    Attributes
    ----------
    particles : ndarray, shape (N, n)
        Current particles.
    weights : ndarray, shape (N,)
        Their normalized weights.
    x : ndarray, shape (n,)
        Weighted mean of the particles (after ``update``: the posterior mean, before any resampling).
    P : ndarray, shape (n, n)
        Weighted covariance of the particles.
    y : ndarray, shape (m,)
        Innovation :math:`z - \sum_i w_i h(x^i)` of the last update (NaN where nothing was measured).
    S : ndarray, shape (m, m)
        Its covariance: the weighted covariance of :math:`h(x^i)` plus ``R`` (NaN where nothing was measured).
    x_prior : ndarray
        The weighted mean of the predicted particles of the current step.
    P_prior : ndarray
        Their weighted covariance.
    ess : float
        Effective sample size after the last update (before resampling).
    resampled : bool
        Whether the last update resampled.

    Examples
    --------
    A scalar random walk observed in noise, checked against the exact (Kalman) answer:

    >>> import numpy as np
    >>> from uwtutor.filters import BootstrapParticleFilter, KalmanFilter, LinearGaussianModel
    >>> rng = np.random.default_rng(0)
    >>> zs = np.cumsum(rng.normal(0.0, 1.0, 30)) + rng.normal(0.0, 2.0, 30)
    >>> model = LinearGaussianModel(F=[[1.0]], H=[[1.0]], Q=[[1.0]], R=[[4.0]])
    >>> pf = BootstrapParticleFilter.from_gaussian(model, [0.0], [[10.0]], 20000, rng)
    >>> kf = KalmanFilter(F=[[1.0]], H=[[1.0]], Q=[[1.0]], R=[[4.0]], x0=[0.0], P0=[[10.0]])
    >>> bool(np.max(np.abs(pf.run(zs).x - kf.run(zs).x)) < 0.1)
    True
    """

    #: Per-step outputs recorded by :func:`uwtutor.filters.base.run_filter` in ``FilterResult.extras``.
    extra_outputs = ("ess", "resampled")

    def __init__(self, model: ParticleModel, particles: Any, rng: np.random.Generator, *, weights: Any = None,
                 resampler: Resampler = systematic_resample, ess_threshold: float = 1.0) -> None:
        self.model = model
        self.rng = as_rng(rng)
        self._n_states = getattr(model, "n_states", None)
        self._weights = np.empty(0)
        self.particles = particles
        if weights is not None:
            self.weights = weights
        if not callable(resampler):
            raise TypeError(f"resampler must be a function (weights, rng) -> indices; got {resampler!r}")
        self.resampler = resampler
        self.ess_threshold = float(as_nonnegative("ess_threshold", ess_threshold))
        m = model.n_measurements
        self.y = np.full(m, np.nan)
        self.S = np.full((m, m), np.nan)
        self.ess = 1.0 / float(self._weights @ self._weights)
        self.resampled = False
        self._prior_moments = False
        self._set_estimate()
        self.x_prior, self.P_prior = self.x, self.P

    @classmethod
    def from_gaussian(cls, model: ParticleModel, x0: Any, P0: Any, n_particles: int, rng: np.random.Generator,
                      **kwargs: Any) -> "BootstrapParticleFilter":
        """A filter whose ``n_particles`` initial particles are drawn from :math:`N(x_0, P_0)`.

        Further keyword arguments (``weights``, ``resampler``, ``ess_threshold``) go to the constructor.
        """
        x0 = as_finite("x0", x0, ndim=1)
        P0 = as_covariance("P0", P0, x0.size, allow_singular=True)
        N = as_int("n_particles", n_particles, minimum=1)
        rng = as_rng(rng)
        particles = x0 + rng.standard_normal((N, x0.size)) @ _sqrt_psd("P0", P0).T
        return cls(model, particles, rng, **kwargs)

    @property
    def particles(self) -> np.ndarray:
        """The particles, shape (N, n), stored column-major (each state component contiguous).

        Assigning a new set with a different ``N`` resets the weights to ``1/N``.
        """
        return self._particles

    @particles.setter
    def particles(self, value: Any) -> None:
        p = as_finite("particles", value, ndim=2)
        n = self._n_states or p.shape[1]
        if p.shape[1] != n or p.shape[0] < 1:
            raise ValueError(f"particles must have shape (N, {n}) with N >= 1 for this model; got {p.shape}")
        self._particles = np.asfortranarray(p)
        self._prior_moments = False
        if self._weights.shape != (p.shape[0],):
            self._weights = np.full(p.shape[0], 1.0 / p.shape[0])
            self._uniform = True

    @property
    def weights(self) -> np.ndarray:
        """Normalized particle weights, shape (N,); assigned weights are checked and normalized."""
        return self._weights

    @weights.setter
    def weights(self, value: Any) -> None:
        N = self.n_particles
        w = as_nonnegative("weights", value, shape=(N,))
        total = w.sum()
        if not total > 0:
            raise ValueError("weights must have a positive sum (at least one particle with weight > 0)")
        self._weights = w / total
        self._uniform = False
        self._prior_moments = False

    @property
    def n_particles(self) -> int:
        """Number of particles ``N``."""
        return self._particles.shape[0]

    def _weighted_moments(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Weighted mean (n,) and covariance (n, n) of ``values`` (N, n)."""
        vt = values.T
        mean = vt @ self._weights
        d = vt - mean[:, None]
        return mean, (d * self._weights) @ d.T

    def _set_estimate(self) -> None:
        self.x, self.P = self._weighted_moments(self._particles)

    def predict(self, u: Any = None) -> None:
        """Draw every particle from the motion model (``model.propagate``); ``x``, ``P`` follow, and
        ``x_prior``, ``P_prior`` keep the moments of the predicted particles."""
        new = self.model.propagate(self._particles, u, self.rng)
        if new.shape != self._particles.shape:
            raise ValueError(f"model.propagate must return particles of shape {self._particles.shape}; "
                             f"got {new.shape}")
        self._particles = new
        self._set_estimate()
        self.x_prior, self.P_prior = self.x, self.P
        self._prior_moments = True

    def update(self, z: Any) -> None:
        """Weight the particles by the likelihood of ``z`` (shape (m,); NaN entries are missing), then resample
        if the effective sample size calls for it."""
        m = self.model.n_measurements
        z = as_float_array("z", z).reshape(-1)
        if z.shape != (m,):
            raise ValueError(f"z must hold {m} measurement value(s); got shape {z.shape}")
        if np.isinf(z).any():
            raise ValueError("z must be finite, or NaN for a missing measurement; got an infinite value")
        self._update(z)

    def _update(self, z: np.ndarray) -> None:
        """:meth:`update` for a measurement already checked: shape (m,), no infinite entry."""
        m = z.shape[0]
        missing = np.isnan(z)
        all_present = not missing.any()
        reuse = self._prior_moments
        self._prior_moments = False
        self.resampled = False
        if not all_present and missing.all():
            self.y = np.full(m, np.nan)
            self.S = np.full((m, m), np.nan)
            return

        # innovation statistics from the predicted particles (h(x) = x: the moments are already known)
        hx = self.model.measure(self._particles)
        hx_mean, hx_cov = (self.x, self.P) if (reuse and hx is self._particles) else self._weighted_moments(hx)
        self.y = z - hx_mean
        self.S = hx_cov + self.model.R
        if not all_present:
            self.y[missing] = np.nan
            self.S[missing, :] = np.nan
            self.S[:, missing] = np.nan

        # reweight in log space: w_i <- w_i p(z | x_i)
        logw = self.model.log_likelihood(self._particles, z)
        if not self._uniform:
            with np.errstate(divide="ignore"):
                logw = logw + np.log(self._weights)
        top = float(np.maximum.reduce(logw))
        if not math.isfinite(top):
            raise ParticleDegeneracyError(
                "every particle has zero likelihood for this measurement: the particles have lost the track. "
                "Use more particles, a larger process noise, or check the measurement and R")
        w = logw - top                                  # a new array: the model's output is left alone
        np.exp(w, out=w)
        w /= np.add.reduce(w)
        self._weights = w
        self._uniform = False
        self._set_estimate()
        self.ess = 1.0 / float(w @ w)
        if self.ess_threshold >= 1.0 or self.ess < self.ess_threshold * self.n_particles:
            self._resample()

    def _resample(self) -> None:
        """Draw ``N`` particles with the resampler and reset the weights to ``1/N``."""
        idx = self.resampler(self._weights, self.rng)
        self._particles = self._particles.T.take(idx, axis=1).T          # stays column-major
        N = self._particles.shape[0]
        self._weights = np.empty(N)
        self._weights.fill(1.0 / N)
        self._uniform = True
        self.resampled = True

    def run(self, z: Any, u: Any = None, times: Any = None) -> FilterResult:
        """Predict with ``u[k]`` then update with ``z[k]`` at every step; return the history.

        Same result as :func:`uwtutor.filters.base.run_filter` (``z`` of shape (K, m), or (K,) when m = 1,
        NaN entries missing; ``u`` one input per step or ``None``), checked once for the whole sequence rather
        than step by step. The ``extras`` of the :class:`~uwtutor.filters.base.FilterResult` hold ``"ess"``
        (K,) and ``"resampled"`` (K,), and every further attribute a subclass names in ``extra_outputs``
        (time axis first). The filter is left at the last step.
        """
        m = self.model.n_measurements
        zs, us = as_float_array("z", z), u
        if zs.ndim == 1 and m == 1:
            zs = zs[:, None]
        if zs.ndim != 2 or zs.shape[1] != m or zs.shape[0] < 1:
            raise ValueError(f"z must have shape (K, {m}) with K >= 1: one measurement per step; got {zs.shape}")
        if np.isinf(zs).any():
            raise ValueError("z must be finite, or NaN for a missing measurement; got an infinite value")
        K = zs.shape[0]
        if us is not None and len(us) != K:
            raise ValueError(f"u must give one input per step ({K} steps); got {len(us)}")
        if times is None:
            times = np.arange(K, dtype=float)
        else:
            times = as_finite("times", times, ndim=1)
            if len(times) != K:
                raise ValueError(f"times must have one entry per step ({K}); got {len(times)}")
        n = self._particles.shape[1]
        x, xp = np.empty((K, n)), np.empty((K, n))
        P, Pp = np.empty((K, n, n)), np.empty((K, n, n))
        y, S = np.empty((K, m)), np.empty((K, m, m))
        ess, resampled = np.empty(K), np.empty(K, dtype=bool)
        others: dict[str, list[np.ndarray]] = {name: [] for name in self.extra_outputs
                                               if name not in ("ess", "resampled")}
        for k in range(K):
            self.predict(None if us is None else us[k])
            xp[k] = self.x
            Pp[k] = self.P
            self._update(zs[k])
            x[k] = self.x
            P[k] = self.P
            y[k] = self.y
            S[k] = self.S
            ess[k] = self.ess
            resampled[k] = self.resampled
            for name, values in others.items():
                values.append(np.array(getattr(self, name), copy=True))
        extras = {"ess": ess, "resampled": resampled}
        extras.update({name: np.stack(values) for name, values in others.items()})
        return FilterResult(times=times, x=x, P=P, x_prior=xp, P_prior=Pp, innovations=y, innovation_cov=S,
                            extras=extras)


class MultipleModelParticleFilter(BootstrapParticleFilter):
    r"""Multiple-model (jump-Markov) bootstrap particle filter: every particle carries a motion mode.

    ``J`` motion models (the *modes*, e.g. cruise, dive and climb) share one measurement model. Particle ``i``
    carries a mode :math:`r^i_k \in \{0, \dots, J-1\}` that switches as a Markov chain with transition matrix
    :math:`\Pi_{jl} = \Pr(r_k = l \mid r_{k-1} = j)` before each step, and moves with its mode's model
    (McGinnity and Irwin 2000):

    .. math::

        r^i_k \sim \Pi_{r^i_{k-1}, \cdot}, \qquad x^i_k \sim p(x_k \mid x^i_{k-1}, r^i_k), \qquad
        w^i_k \propto w^i_{k-1}\, p(z_k \mid x^i_k), \qquad
        \mu^j_k = \sum_{i:\, r^i_k = j} w^i_k .

    The estimate is the weighted mean over all particles (the mixture of the modes' estimates by their
    probabilities :math:`\mu^j_k`); resampling copies the modes with the particles. Everything else (likelihood,
    effective sample size, resampling rule, missing measurements) is that of :class:`BootstrapParticleFilter`.

    Parameters
    ----------
    models : sequence of ParticleModel
        The ``J`` mode models; same state size and same measurement noise ``R`` (the likelihood is shared).
    particles : array_like, shape (N, n)
        Initial particles.
    rng : numpy.random.Generator
        Source of all randomness (mode switches, motion noise, resampling).
    transition : array_like, shape (J, J)
        Mode transition matrix: entries >= 0, each row summing to 1.
    modes : array_like of int, shape (N,), optional
        Initial mode of each particle; drawn from ``mode_probabilities`` when not given.
    mode_probabilities : array_like, shape (J,), optional
        Initial mode probabilities (equal by default); used only when ``modes`` is not given.
    weights : array_like, shape (N,), optional
        Initial weights; equal by default.
    resampler : callable, optional
        ``resampler(weights, rng) -> indices`` (systematic by default).
    ess_threshold : float, optional
        As in :class:`BootstrapParticleFilter` (1.0: resample at every measurement).

    Attributes
    ----------
    modes : ndarray of int, shape (N,)
        Current mode of each particle.
    mode_probabilities : ndarray, shape (J,)
        :math:`\mu^j` after the last step (after ``update``: the posterior, before any resampling).
    models : list of ParticleModel
        The mode models.
    transition : ndarray, shape (J, J)
        The transition matrix.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.filters import MultipleModelParticleFilter, PitchManeuverModel
    >>> modes = [PitchManeuverModel(pitch_target=p) for p in (0.0, 0.3, -0.3)]    # cruise, dive, climb
    >>> Pi = np.full((3, 3), 0.005) + np.eye(3) * 0.985
    >>> rng = np.random.default_rng(0)
    >>> truth, meas = PitchManeuverModel(pitch_target=0.3).simulate([10.0, 1.5, 0.0], 200, rng)
    >>> mmpf = MultipleModelParticleFilter.from_gaussian(modes, meas[0], modes[0].R, 600, rng, transition=Pi)
    >>> res = mmpf.run(meas)
    >>> res.extras["mode_probabilities"].shape
    (200, 3)
    >>> int(np.argmax(res.extras["mode_probabilities"][-50:].mean(axis=0)))     # the dive mode wins
    1
    """

    extra_outputs = ("ess", "resampled", "mode_probabilities")

    def __init__(self, models: Sequence[ParticleModel], particles: Any, rng: np.random.Generator, *,
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
        self._modes = np.empty(0, dtype=np.intp)
        super().__init__(first, particles, rng, weights=weights, resampler=resampler, ess_threshold=ess_threshold)
        N = self.n_particles
        if modes is not None:
            m = np.asarray(modes)
            if m.shape != (N,) or m.dtype.kind not in "iu" or (m < 0).any() or (m >= J).any():
                raise ValueError(f"modes must be {N} integers in 0..{J - 1} (one per particle); got {modes!r}")
            self._modes = m.astype(np.intp)
        else:
            if mode_probabilities is None:
                p = np.full(J, 1.0 / J)
            else:
                p = as_nonnegative("mode_probabilities", mode_probabilities, shape=(J,))
                if not p.sum() > 0:
                    raise ValueError("mode_probabilities must have a positive sum")
                p = p / p.sum()
            self._modes = np.minimum(np.searchsorted(np.cumsum(p), self.rng.random(N), side="right"), J - 1)
        self._set_estimate()

    @property
    def modes(self) -> np.ndarray:
        """Mode index of each particle, shape (N,)."""
        return self._modes

    @property
    def n_modes(self) -> int:
        """Number of modes ``J``."""
        return len(self.models)

    def _set_estimate(self) -> None:
        super()._set_estimate()
        if self._modes.shape == self._weights.shape:
            self.mode_probabilities = np.bincount(self._modes, weights=self._weights, minlength=self.n_modes)
        else:                                     # during construction, before the modes exist
            self.mode_probabilities = np.full(self.n_modes, np.nan)

    def predict(self, u: Any = None) -> None:
        """Switch every particle's mode (Markov chain), then move it with its mode's model."""
        N = self.n_particles
        n = self._particles.shape[1]
        draws = self.rng.random(N)
        new_modes = np.minimum((draws[:, None] >= self._cum_transition[self._modes]).sum(axis=1), self.n_modes - 1)
        # group the particles by mode (their order carries no meaning) so that each model moves one block
        order = np.argsort(new_modes, kind="stable")
        counts = np.bincount(new_modes, minlength=self.n_modes)
        grouped = self._particles[order]
        pieces, start = [], 0
        for j, (model, count) in enumerate(zip(self.models, counts)):
            if count:
                moved = model.propagate(grouped[start:start + count], u, self.rng)
                if moved.shape != (count, n):
                    raise ValueError(f"models[{j}].propagate must return particles of shape {(count, n)}; "
                                     f"got {moved.shape}")
                pieces.append(moved)
                start += count
        self._particles = np.asfortranarray(np.concatenate(pieces))
        self._modes = new_modes[order].astype(np.intp)
        if not self._uniform:
            self._weights = self._weights[order]
        self._set_estimate()
        self._prior_moments = True

    def _resample(self) -> None:
        """Resample particles and their modes together; weights reset to ``1/N``."""
        idx = self.resampler(self._weights, self.rng)
        self._particles = self._particles.T.take(idx, axis=1).T
        self._modes = self._modes.take(idx)
        N = self._particles.shape[0]
        self._weights = np.full(N, 1.0 / N)
        self._uniform = True
        self.resampled = True


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
       \hat\sigma^2_{v}, \hat\sigma^2_{\varphi})`, and the weights are the Gaussian likelihoods under
       :math:`R_k`. Until a window is full (or when it holds a missing value) the sensor keeps its last estimate,
       initially the model's ``R``.
    3. **Estimate and resampling** (eq. (24)): weighted mean, then resampling at every step.

    Parameters
    ----------
    model : ParticleModel
        Motion and measurement model with :math:`h(x) = x` (``n_measurements == n_states``), e.g.
        :class:`DepthSpeedPitchModel`. The filter works on a copy, whose ``R`` it replaces at every step.
    particles : array_like, shape (N, n)
        Initial particles.
    rng : numpy.random.Generator
        Source of all randomness.
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
    weights : array_like, shape (N,), optional
        Initial weights; equal by default.

    Attributes
    ----------
    noise_std : ndarray, shape (n,)
        Sensor noise standard deviations used by the last update.
    grey_used : bool
        Whether the last ``predict`` drew grey particles.
    grey_forecast : ndarray, shape (n,)
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
    >>> gpf = GreyParticleFilter.from_gaussian(model, meas[0], model.R, 500, rng, grey_offset=[0.0, 0.0, 1.0])
    >>> res = gpf.run(meas)
    >>> int(res.extras["grey_used"].sum()), res.extras["noise_std"].shape
    (270, (300, 3))
    """

    extra_outputs = ("ess", "resampled", "noise_std", "grey_used", "grey_forecast")

    def __init__(self, model: ParticleModel, particles: Any, rng: np.random.Generator, *,
                 grey_fraction: float = 0.1, grey_window: int = 30, grey_std: Any = None, grey_offset: Any = None,
                 noise_window: int = 50, wavelet: str = "db6", adapt_noise: bool = True,
                 min_noise_std: Any = None, resampler: Resampler = systematic_resample,
                 weights: Any = None) -> None:
        if model.n_measurements != model.n_states:
            raise ValueError("GreyParticleFilter needs a model that measures its state directly (h(x) = x, "
                             f"n_measurements == n_states); got {model.n_measurements} measurements of "
                             f"{model.n_states} states")
        model = copy.copy(model)
        super().__init__(model, particles, rng, weights=weights, resampler=resampler, ess_threshold=1.0)
        n = model.n_states
        N = self.n_particles
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
        self._wavelet = _wavelet(wavelet)
        self.noise_window = as_int("noise_window", noise_window, minimum=self._wavelet.dec_len)
        # the valid finest-scale DWT of a window is linear in it: one (window, n_coefficients) matrix
        identity = np.eye(self.noise_window)
        self._dwt_matrix = _valid_details(identity, self._wavelet)[:, self._wavelet.dec_len % 2::2]
        n_coef = self._dwt_matrix.shape[1]
        self._median_slice = slice((n_coef - 1) // 2, n_coef // 2 + 1)
        self.adapt_noise = bool(adapt_noise)
        self._R0 = model.R.copy()
        sd0 = np.sqrt(np.diag(self._R0))
        self.min_noise_std = (0.01 * sd0 if min_noise_std is None
                              else as_positive("min_noise_std", min_noise_std, shape=(n,)))
        self.noise_std = sd0.copy()
        self._history = np.full((n, max(self.grey_window, self.noise_window)), np.nan)
        self.grey_used = False
        self.grey_forecast = np.full(n, np.nan)

    def _grey_prediction(self) -> np.ndarray | None:
        """GM(1,1) one-step forecast of every component from its last ``L`` measurements, or None."""
        window = self._history[:, -self.grey_window:] + self.grey_offset[:, None]
        if not np.minimum.reduce(window, axis=None) > 0.0:       # also False when a reading is missing (NaN)
            return None
        a, b = _gm11_coefficients(window, 0.5)
        return _gm11_restored(window[:, 0], a, b, np.array([float(self.grey_window)]))[:, 0] - self.grey_offset

    def predict(self, u: Any = None) -> None:
        """Draw ``N - N_grey`` particles from the motion model and ``N_grey`` around the grey forecast."""
        forecast = self._grey_prediction() if self.n_grey > 0 else None
        if forecast is None:
            self.grey_used = False
            self.grey_forecast = np.full(self._particles.shape[1], np.nan)
            super().predict(u)
            return
        if not self._uniform:                  # the subset below must come from equally weighted particles
            self._resample()
        N = self.n_particles
        n = self._particles.shape[1]
        n_std = N - self.n_grey
        keep = self.rng.permutation(N)[:n_std]
        moved = self.model.propagate(self._particles.T.take(keep, axis=1).T, u, self.rng)
        if moved.shape != (n_std, n):
            raise ValueError(f"model.propagate must return particles of shape {(n_std, n)}; got {moved.shape}")
        rows = np.empty((n, N))                                  # column-major particles, as everywhere else
        rows[:, :n_std] = moved.T
        grey = self.rng.standard_normal((n, self.n_grey))
        grey *= self.grey_std[:, None]
        grey += forecast[:, None]
        rows[:, n_std:] = grey
        self._particles = rows.T
        self.grey_used = True
        self.grey_forecast = forecast
        self._set_estimate()
        self._prior_moments = True

    def _update(self, z: np.ndarray) -> None:
        hist = self._history
        hist[:, :-1] = hist[:, 1:]
        hist[:, -1] = z
        if self.adapt_noise:
            window = hist[:, -self.noise_window:]
            full = np.isfinite(window).all(axis=1)
            if full.any():
                d = np.abs(window[full] @ self._dwt_matrix)              # detail coefficients, (sensors, n)
                d.sort(axis=1)
                middle = d[:, self._median_slice]
                sigma = np.add.reduce(middle, axis=1) / (middle.shape[1] * MAD_TO_SIGMA)   # median |d| / 0.6745
                self.noise_std = self.noise_std.copy()
                self.noise_std[full] = np.maximum(sigma, self.min_noise_std[full])
                self.model._set_noise_std(self.noise_std)
        super()._update(z)
