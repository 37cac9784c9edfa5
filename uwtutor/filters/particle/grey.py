r"""The grey particle filter (GPF) of paper C: grey-forecast particles and a wavelet-estimated noise level.

Paper C (Li et al. 2013) estimates the depth, speed and pitch of a maneuvering AUV whose sensors measure the state
directly (:math:`h(x) = x`). Its filter is the bootstrap filter
(:class:`~uwtutor.filters.particle.bootstrap.BootstrapParticleFilter`) with two changes:

* a share of the particles (1 in 10) is drawn around a GM(1,1) forecast of the last ``L`` measurements
  (:mod:`uwtutor.grey`) instead of from the motion model, which keeps particles near the measurements through a
  maneuver the motion model does not know;
* the likelihood uses a measurement noise measured online, sensor by sensor, by the wavelet MAD estimate
  (:mod:`uwtutor.wavelet`), which follows a noise level that changes.

It takes the same model pair as the EKF -- paper C's :class:`~uwtutor.models.depth.DepthSpeedPitch` and
:class:`~uwtutor.models.depth.DepthSensors` -- and follows the filter protocol with a runs axis, as every filter here.

References
----------
Li Ting, Zhao Dexin, Huang Zhiping and Su Shaojing (2013). A method for self-estimating the depth of maneuvering
AUV based on the grey particle filter. *Journal of National University of Defense Technology* 35(5), 185-190
(paper C), section 2.4, eqs. (17)-(24).

Deng Julong (1982). Control problems of grey systems. *Systems & Control Letters* 1(5), 288-294 (GM(1,1)).

Donoho, D. L. and Johnstone, I. M. (1994). Ideal spatial adaptation by wavelet shrinkage. *Biometrika* 81(3),
425-455 (the MAD noise estimate).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..._validate import (as_finite, as_flag, as_int, as_model_output, as_nonnegative, as_positive, as_scalar,
                          check_model_covariance, readonly)
from ...models.base import MeasurementModel, ModelPair, MotionModel
from ...models.noise import RunGenerators
from ...grey import gm11_next
from ...resampling import Resampler, systematic_resample
from ...wavelet import as_wavelet, detail_matrix, mad_sigma
from .bootstrap import (BootstrapParticleFilter, _all, _any, _check_model, _rows, _whitened_log_likelihood,
                        _whitening)

__all__ = ["GreyParticleFilter"]


class GreyParticleFilter(BootstrapParticleFilter):
    r"""Grey particle filter (GPF) of paper C: grey-forecast particles and a wavelet-estimated noise level.

    The sensors measure the state directly (:math:`h(x) = x`). Each step (paper C, section 2.4):

    1. **Sampling** (eq. (20)-(22)). :math:`N_\mathrm{std} = N - N_\mathrm{grey}` particles are drawn from the
       motion model as in the bootstrap filter (from a random subset of the equally weighted particles
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
    motion : uwtutor.models.MotionModel
        How the particles move, e.g. :class:`~uwtutor.models.depth.DepthSpeedPitch`.
    measurement : uwtutor.models.MeasurementModel
        A model that measures the state directly, :math:`h(x) = x`, with one :math:`R` to start from, e.g.
        :class:`~uwtutor.models.depth.DepthSensors`. The filter keeps its own per-run :math:`R_k` and leaves the model's
        alone. A :class:`~uwtutor.models.base.ModelPair` may stand for ``motion`` and ``measurement``.
    particles : array_like, shape (N, n) or (M, N, n)
        Initial particles (of ``M`` runs).
    rng : numpy.random.Generator or sequence of numpy.random.Generator
        Source of all randomness, one per run as in the bootstrap filter.
    grey_fraction : float, optional
        :math:`N_\mathrm{grey} / N`, in [0, 1); 0.1 (paper C's 1:9). 0 turns the grey sampling off.
    grey_window : int, optional
        ``L``, measurements per GM(1,1) fit (>= 4); 30 in paper C.
    grey_std : array_like, shape (n,), optional
        Standard deviations of the noise added to the grey forecast; by default the motion model's
        ``process_std`` (paper C uses the process noise :math:`Q_k`).
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
    >>> from uwtutor.filters import GreyParticleFilter
    >>> from uwtutor.models import (
    ...     DepthSensors,
    ...     DepthSpeedPitch,
    ...     DepthSpeedPitchModel,
    ... )
    >>> rng = np.random.default_rng(5)
    >>> truth, meas = DepthSpeedPitchModel().simulate([10.0, 1.5, 0.1], 300, rng)
    >>> sensors = DepthSensors()
    >>> gpf = GreyParticleFilter.from_gaussian(
    ...     DepthSpeedPitch(),
    ...     sensors,
    ...     meas[0],
    ...     sensors.R(None, 0),
    ...     500,
    ...     rng,
    ...     grey_offset=[0.0, 0.0, 1.0],
    ... )
    >>> res = gpf.run(meas)
    >>> int(res.extras["grey_used"].sum()), res.extras["noise_std"].shape
    (270, (300, 3))
    """

    extra_outputs = ("ess", "resampled", "noise_std", "grey_used", "grey_forecast")
    # paper C's settings size the filter's buffers (windows, wavelet matrix, grey particles): fixed once built
    _fixed = BootstrapParticleFilter._fixed + ("grey_fraction", "n_grey", "grey_window", "grey_std", "grey_offset",
                                                "noise_window", "wavelet", "adapt_noise", "min_noise_std")
    _run_state = BootstrapParticleFilter._run_state + ("_noise_std", "_R_runs", "_whiten_runs", "_estimated",
                                                       "_history", "_grey_used", "_grey_forecast")

    def _can_split(self) -> bool:
        return self._R_diag and super()._can_split()      # whitening vectors of one shape in every block

    def __init__(self, motion: MotionModel | ModelPair, measurement: Any = None, particles: ArrayLike | None = None,
                 rng: RunGenerators | None = None, *,
                 grey_fraction: float = 0.1, grey_window: int = 30, grey_std: ArrayLike | None = None,
                 grey_offset: ArrayLike | None = None, noise_window: int = 50, wavelet: str = "db6",
                 adapt_noise: bool = True, min_noise_std: ArrayLike | None = None,
                 resampler: Resampler = systematic_resample, weights: ArrayLike | None = None) -> None:
        motion, measurement, (particles, rng) = self._split_models(motion, measurement, (particles, rng))
        _check_model("motion", motion, MotionModel)
        _check_model("measurement", measurement, MeasurementModel)
        n = getattr(motion, "n", None)
        probe = (np.arange(1.0, (n or 0) + 1.0) * 0.37)[None, None, :]
        direct = (isinstance(n, int) and getattr(measurement, "m", None) == n
                  and np.array_equal(np.asarray(measurement.h(probe, 0), dtype=float), probe))
        if not direct or not isinstance(n, int):          # (direct holds only for an int n)
            raise ValueError("GreyParticleFilter needs a measurement model that measures the state directly (h(x) = "
                             f"x, e.g. uwtutor.models.DepthSensors); got {type(measurement).__name__} with "
                             f"{getattr(measurement, 'm', '?')} measurements of {n} states")
        R0 = as_model_output(f"the measurement model {type(measurement).__name__}.R", measurement.R(probe, 0))
        if R0.shape == (n, n):
            check_model_covariance(f"the measurement model {type(measurement).__name__}.R", R0)
        if R0.shape != (n, n):
            raise ValueError(f"GreyParticleFilter starts from one R ({n}, {n}) for every run; the measurement "
                             f"model's R has shape {R0.shape}")
        super().__init__(motion, measurement, particles, rng, weights=weights, resampler=resampler,
                         ess_threshold=1.0)
        M, N = self._w.shape
        frac = as_scalar("grey_fraction", grey_fraction)
        if not 0.0 <= frac < 1.0:
            raise ValueError(f"grey_fraction must lie in [0, 1) (paper C: 0.1); got {frac}")
        self.grey_fraction = frac
        self.n_grey = int(round(frac * N))
        self.grey_window = as_int("grey_window", grey_window, minimum=4)
        if grey_std is None:
            grey_std = getattr(motion, "process_std", None)
            if grey_std is None:
                raise ValueError("grey_std must be given for a motion model without a process_std attribute")
        self.grey_std = as_nonnegative("grey_std", grey_std, shape=(n,), max_abs=1e75)   # its square stays finite
        self.grey_offset = (np.zeros(n) if grey_offset is None
                            else as_finite("grey_offset", grey_offset, shape=(n,)))
        self._wavelet = as_wavelet(wavelet)
        self.noise_window = as_int("noise_window", noise_window, minimum=self._wavelet.dec_len)
        # the valid finest-scale DWT of a window is linear in it: one (window, n_coefficients) matrix
        self._dwt_matrix = detail_matrix(self.noise_window, self._wavelet)
        self.adapt_noise = as_flag("adapt_noise", adapt_noise)
        sd0 = np.sqrt(np.diag(R0))
        self.min_noise_std = (0.01 * sd0 if min_noise_std is None
                              else as_positive("min_noise_std", min_noise_std, shape=(n,), max_abs=1e75))
        self._noise_std = np.tile(sd0, (M, 1))
        # the R_k of each run: the model's R until the run's first wavelet estimate, diagonal after it
        self._R_runs = np.tile(R0, (M, 1, 1))
        white, self._R_diag = _whitening(R0)
        self._whiten_runs = np.tile(white, (M,) + (1,) * white.ndim)
        self._estimated = np.zeros(M, dtype=bool)
        self._history = np.full((M, n, max(self.grey_window, self.noise_window)), np.nan)
        self._grey_used = np.zeros(M, dtype=bool)
        self._grey_forecast = np.full((M, n), np.nan)

    noise_std = property(lambda self: readonly(self._out(self._noise_std).copy()),
                         doc="Sensor noise standard deviations used by the last update, (n,) or (M, n).")
    grey_forecast = property(lambda self: readonly(self._out(self._grey_forecast).copy()),
                             doc="The last grey forecast, (n,) or (M, n) (NaN when none was made).")

    @property
    def grey_used(self) -> Any:
        """Whether the last ``predict`` drew grey particles (a bool, or an (M,) array for a batch)."""
        return readonly(self._grey_used.copy()) if self._batched else bool(self._grey_used[0])

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

    def _sample_runs(self, rows: np.ndarray, u: Any, runs: Any) -> np.ndarray:
        """Move ``rows`` (R, n, count) of the runs ``runs`` with the motion model, each from its own Generator."""
        runs = np.asarray(runs)
        every = runs.size == self.n_runs
        rngs = self.rngs if every else tuple(self.rngs[r] for r in runs)
        if u is not None and np.ndim(u) == 3 and not every:
            u = u[runs]
        return self._sample(self.motion, rows, u, self.k, rngs)

    def _predict(self, u: Any) -> None:
        """Draw ``N - N_grey`` particles from the motion model and ``N_grey`` around the grey forecast."""
        self.k += 1
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
                self._rows_p = self._sample_runs(self._rows_p, u, np.arange(M))
            else:
                self._rows_p[plain] = self._sample_runs(self._rows_p[plain], u, plain)
        if every or _any(grey):
            runs: range | np.ndarray = range(M) if every else np.flatnonzero(grey)
            unequal = [r for r in runs if not self._uniform[r]]
            if unequal:                       # the subset below must come from equally weighted particles
                self._resample(unequal)
            n_std = N - self.n_grey
            new = np.empty((len(runs), n, N))                    # component-major particles, as everywhere else
            for i, r in enumerate(runs):
                new[i, :, :n_std] = self._rows_p[r].take(self.rngs[r].permutation(N)[:n_std], axis=1)
            new[:, :, :n_std] = self._sample_runs(new[:, :, :n_std], u, runs)
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

    def _measurement_noise(self, x: np.ndarray, k: int) -> np.ndarray:
        return self._R_runs

    def _log_weights(self, x: np.ndarray, hx: np.ndarray, z: np.ndarray, R: np.ndarray, k: int) -> np.ndarray:
        return _whitened_log_likelihood(_rows(hx), z, self._R_runs, self._whiten_runs, self._R_diag)

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
