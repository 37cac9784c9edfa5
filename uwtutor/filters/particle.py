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

Two are ready: :class:`DepthSpeedPitchModel`, the depth/speed/pitch model of Li et al. (paper C, the grey particle
filter), and :class:`LinearGaussianModel`, on which the particle filter can be checked against the Kalman filter.
The chapter on paper C builds the multiple-model and grey particle filters on :class:`BootstrapParticleFilter`:
override :meth:`BootstrapParticleFilter.predict` to change how particles are proposed (e.g. replace a share of
them by grey-prediction particles), or give the model a mode column for switching dynamics.

References
----------
Arulampalam, M. S., Maskell, S., Gordon, N. and Clapp, T. (2002). A tutorial on particle filters for online
nonlinear/non-Gaussian Bayesian tracking. *IEEE Trans. Signal Processing* 50(2), 174-188.

Gordon, N. J., Salmond, D. J. and Smith, A. F. M. (1993). Novel approach to nonlinear/non-Gaussian Bayesian
state estimation. *IEE Proceedings F* 140(2), 107-113.

Li Ting, Zhao Dexin, Huang Zhiping and Su Shaojing, grey particle filter for the depth of a maneuvering AUV
(paper C).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .._validate import as_covariance, as_finite, as_float_array, as_int, as_nonnegative, as_positive, as_rng
from ..resampling import Resampler, systematic_resample
from .base import FilterResult

__all__ = [
    "ParticleModel",
    "DepthSpeedPitchModel",
    "LinearGaussianModel",
    "BootstrapParticleFilter",
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
        """Draw every particle from the motion model (``model.propagate``); ``x``, ``P`` follow."""
        new = self.model.propagate(self._particles, u, self.rng)
        if new.shape != self._particles.shape:
            raise ValueError(f"model.propagate must return particles of shape {self._particles.shape}; "
                             f"got {new.shape}")
        self._particles = new
        self._set_estimate()
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

    def run(self, zs: Any, us: Any = None, times: Any = None) -> FilterResult:
        """Predict with ``us[k]`` then update with ``zs[k]`` at every step; return the history.

        Same result as :func:`uwtutor.filters.base.run_filter` (``zs`` of shape (K, m), or (K,) when m = 1,
        NaN entries missing; ``us`` one input per step or ``None``), checked once for the whole sequence rather
        than step by step. The ``extras`` of the :class:`~uwtutor.filters.base.FilterResult` hold ``"ess"``
        (K,) and ``"resampled"`` (K,). The filter is left at the last step.
        """
        m = self.model.n_measurements
        zs = as_float_array("zs", zs)
        if zs.ndim == 1 and m == 1:
            zs = zs[:, None]
        if zs.ndim != 2 or zs.shape[1] != m or zs.shape[0] < 1:
            raise ValueError(f"zs must have shape (K, {m}) with K >= 1: one measurement per step; got {zs.shape}")
        if np.isinf(zs).any():
            raise ValueError("zs must be finite, or NaN for a missing measurement; got an infinite value")
        K = zs.shape[0]
        if us is not None and len(us) != K:
            raise ValueError(f"us must give one input per step ({K} steps); got {len(us)}")
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
        return FilterResult(times=times, x=x, P=P, x_prior=xp, P_prior=Pp, innovations=y, innovation_cov=S,
                            extras={"ess": ess, "resampled": resampled})
