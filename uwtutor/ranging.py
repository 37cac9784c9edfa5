r"""Range measurements and their error models.

A measured range is the true range plus an error, :math:`r_k = \|p_k - b_k\| + e_k`. The papers differ mainly in
what they assume about :math:`e_k`, and each assumption is a small model here:

==========================  ===================================================================================
``GaussianNoise``           white, additive: every paper
``SoundSpeedMismatch``      multiplicative, from converting travel time with the wrong sound speed
                            (Zhu et al. (2019), paper D; the :math:`\gamma r_k` term of paper A)
``SlowBias``                slowly varying bias, low-pass filtered white noise plus a mean (Liu et al., paper A)
``Outliers``                patches of gross errors (paper E)
==========================  ===================================================================================

Every model is an immutable dataclass with one method, ``sample(true_ranges, times, rng, n_runs=None)``,
returning the additive error for each epoch: shape ``(K,)``, or ``(M, K)`` for ``M`` Monte Carlo runs. Models add
up: ``GaussianNoise(0.7) + SoundSpeedMismatch()`` is a ``RangeErrorSum`` whose error is the sum of the parts'
errors, each part drawing its randomness from the same ``rng`` in turn. (The models are not exceptions: the library's
exceptions and warnings live in :mod:`uwtutor.errors`. Until the next release the models' former names
``SoundSpeedError`` and ``CompositeError`` still import, with a ``DeprecationWarning``.)

``sample_with_mask`` returns the error together with a boolean mask of the epochs hit by an outlier, from the
*same* random draw, so that an outlier detector can be scored against the truth (the mask is all False for
models without outliers). ``measure_ranges`` adds the errors to true ranges (a negative sum is read as
its magnitude: the library's one policy for measured ranges, shared by ``add_range_errors``); ``horizontal_range``,
``slant_range`` and ``reception_times`` compute the true geometry.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ._validate import (MAX_COORDINATE, as_finite, as_flag, as_float_array, as_int, as_n_runs, as_points,
                        as_position_function, as_positive, as_range_array, as_rng, as_scalar, as_times, check_work,
                        with_runs)
from .acoustics import range_factor
from .errors import deprecated_aliases

__all__ = [
    "RangeErrorModel",
    "RangeErrorSum",
    "GaussianNoise",
    "SoundSpeedMismatch",
    "SlowBias",
    "Outliers",
    "measure_ranges",
    "add_range_errors",
    "horizontal_range",
    "slant_range",
    "reception_times",
]


def _prepare(true_ranges: Any, times: Any, rng: Any, n_runs: Any) -> tuple[np.ndarray, np.ndarray,
                                                                           np.random.Generator, bool]:
    """Validate the arguments of ``sample``; return ranges with a runs axis ``(M, K)``, times, rng, squeeze flag."""
    r = as_range_array("true_ranges", true_ranges, ndim=(1, 2))
    t = as_times("times", times)
    if r.shape[-1] != len(t):
        raise ValueError(f"true_ranges must have one range per epoch along its last axis: it has {r.shape[-1]}, "
                         f"times has {len(t)}")
    rng = as_rng(rng)
    m = as_n_runs(n_runs)
    if m is not None:
        check_work("n_runs", m * r.shape[-1], "range errors (n_runs x the epochs)")
    batch, single = with_runs("true_ranges", r, m, core_ndim=1)
    return batch, t, rng, single


class RangeErrorModel:
    """Base class of the range error models: ``sample``, ``sample_with_mask`` and ``+``.

    A subclass implements ``_draw(true_ranges, times, rng)`` for validated ``(M, K)`` ranges and returns
    ``(errors, outlier_mask)``, both ``(M, K)``.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.ranging import GaussianNoise, RangeErrorModel
    >>> model = GaussianNoise(1.0)
    >>> isinstance(model, RangeErrorModel)
    True
    >>> e, hit = model.sample_with_mask(
    ...     np.full(4, 500.0), np.arange(4.0), np.random.default_rng(0)
    ... )
    >>> e.shape, bool(hit.any())
    ((4,), False)
    """

    def sample(self, true_ranges: Any, times: Any, rng: np.random.Generator, n_runs: Any = None) -> np.ndarray:
        """Draw the additive range errors.

        Parameters
        ----------
        true_ranges : array_like, shape (K,) or (M, K)
            True ranges [m], finite and >= 0 (multiplicative models scale with them).
        times : array_like, shape (K,)
            Epoch times [s], strictly increasing (time-correlated models use the actual steps).
        rng : numpy.random.Generator
            Source of randomness.
        n_runs : int, optional
            Number of Monte Carlo runs ``M``. ``(K,)`` ranges are then shared by all runs, each with its own
            errors; ``(M, K)`` ranges must hold ``M`` runs. ``None`` keeps the shape of ``true_ranges``.

        Returns
        -------
        ndarray, shape (K,) or (M, K)
            Errors [m] to add to the true ranges.
        """
        return self.sample_with_mask(true_ranges, times, rng, n_runs)[0]

    def sample_with_mask(self, true_ranges: ArrayLike, times: ArrayLike, rng: np.random.Generator,
                         n_runs: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Like ``sample``, and also return which epochs carry an outlier (same arguments).

        Returns
        -------
        errors : ndarray, shape (K,) or (M, K)
            Errors [m] to add to the true ranges.
        outlier_mask : ndarray of bool, same shape
            True where an ``Outliers`` component hit the epoch.
        """
        r, t, rng, single = _prepare(true_ranges, times, rng, n_runs)
        err, mask = self._draw(r, t, rng)
        return (err[0], mask[0]) if single else (err, mask)

    def _draw(self, true_ranges: np.ndarray, times: np.ndarray,
              rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover - abstract
        raise NotImplementedError

    def __add__(self, other: Any) -> RangeErrorSum:
        if not isinstance(other, RangeErrorModel):
            return NotImplemented
        return RangeErrorSum(_parts(self) + _parts(other))

    def __radd__(self, other: Any) -> RangeErrorModel:
        # Lets ``sum(models)`` work: sum starts from 0.
        if isinstance(other, int) and other == 0:
            return self
        return NotImplemented


def _parts(model: RangeErrorModel) -> tuple[RangeErrorModel, ...]:
    return model.parts if isinstance(model, RangeErrorSum) else (model,)


@dataclass(frozen=True)
class RangeErrorSum(RangeErrorModel):
    """Sum of several error models, usually made with ``+``: ``GaussianNoise(1.0) + SlowBias(5.0, 3.0, 600.0)``.

    Parameters
    ----------
    parts : tuple of RangeErrorModel
        The components; each draws from the shared ``rng`` in this order. The outlier mask is the union of the
        components' masks.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.ranging import GaussianNoise, RangeErrorSum, SlowBias
    >>> model = GaussianNoise(1.0) + SlowBias(5.0, 3.0, 600.0)
    >>> isinstance(model, RangeErrorSum), len(model.parts)
    (True, 2)
    >>> e = model.sample(
    ...     np.full(50, 1000.0), 10.0 * np.arange(50), np.random.default_rng(0), n_runs=400
    ... )
    >>> # the bias's mean, 5 m
    >>> bool(abs(e.mean() - 5.0) < 0.5)
    True
    """

    parts: tuple[RangeErrorModel, ...]

    def __post_init__(self) -> None:
        if isinstance(self.parts, RangeErrorModel) or not isinstance(self.parts, (tuple, list)):
            raise TypeError("parts must be a tuple of range error models, e.g. (GaussianNoise(1.0), SlowBias(5.0, "
                            f"3.0, 600.0)); got {type(self.parts).__name__}")
        parts = tuple(self.parts)
        if not parts:
            raise ValueError("parts must hold at least one error model")
        for i, p in enumerate(parts):
            if not isinstance(p, RangeErrorModel):
                raise TypeError(f"parts[{i}] must be a range error model (e.g. GaussianNoise); got {type(p).__name__}")
        object.__setattr__(self, "parts", parts)

    def _draw(self, true_ranges: np.ndarray, times: np.ndarray,
              rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        err = np.zeros(true_ranges.shape)
        mask = np.zeros(true_ranges.shape, dtype=bool)
        for part in self.parts:
            e, m = part._draw(true_ranges, times, rng)
            err += e
            mask |= m
        return err, mask


@dataclass(frozen=True)
class GaussianNoise(RangeErrorModel):
    r"""Additive white Gaussian range noise, :math:`e_k \sim N(0, \sigma^2)` independent across epochs and runs.

    Parameters
    ----------
    sigma : float
        Standard deviation :math:`\sigma` [m], >= 0 (0 gives error-free ranges).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.ranging import GaussianNoise
    >>> e = GaussianNoise(0.7).sample(
    ...     np.full(5, 1000.0), np.arange(5.0), np.random.default_rng(1), n_runs=3
    ... )
    >>> e.shape
    (3, 5)
    """

    sigma: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "sigma", as_scalar("sigma", self.sigma, domain="nonnegative"))

    def _draw(self, true_ranges: np.ndarray, times: np.ndarray,
              rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        return self.sigma * rng.standard_normal(true_ranges.shape), np.zeros(true_ranges.shape, dtype=bool)


@dataclass(frozen=True)
class SoundSpeedMismatch(RangeErrorModel):
    r"""Multiplicative range error from an uncertain sound speed (Zhu et al. (2019), paper D).

    Each ping travels at a true effective speed :math:`c_{\mathrm{e},k} \sim \mathcal{N}(\bar c_\mathrm{e},
    \sigma_c^2)` (drawn independently per ping and run; ``true_speed`` is :math:`\bar c_\mathrm{e}`); the vehicle
    converts the travel time :math:`r^\mathrm{true}_k / c_{\mathrm{e},k}` with its assumed speed :math:`c`, so

    .. math::

        r_k = \gamma_k r^\mathrm{true}_k, \quad \gamma_k = \frac{c}{c_{\mathrm{e},k}}, \qquad
        e_k = r^\mathrm{true}_k (\gamma_k - 1).

    To first order in :math:`\sigma_c / \bar c_\mathrm{e}` the error has

    .. math::

        \mathrm{E}[e_k] \approx \frac{c - \bar c_\mathrm{e}}{\bar c_\mathrm{e}}\, r^\mathrm{true}_k, \qquad
        \mathrm{std}[e_k] \approx \frac{c}{\bar c_\mathrm{e}}\,\frac{\sigma_c}{\bar c_\mathrm{e}}\, r^\mathrm{true}_k,

    both growing with the range: multiplicative noise. Paper D writes the same model as
    :math:`R_i = (1 + a_i) R'_i` with :math:`a_i \sim N(\Delta c/c', (\sigma_c/c')^2)` (:math:`c'` is the book's
    :math:`c_\mathrm{e}`); the factor :math:`c/\bar c_\mathrm{e}` in the standard deviation (0.98 for the paper's
    numbers) is the difference between putting the randomness in the true speed (here) or in the assumed one
    (paper D). With ``speed_sigma=0`` the model is the pure scale error :math:`(\mu_\gamma - 1)\, r^\mathrm{true}_k`
    of Liu et al., paper A (its :math:`\gamma r_k`).

    Parameters
    ----------
    true_speed : float, default 1500
        Mean true effective sound speed :math:`c` [m/s], > 0.
    assumed_speed : float, default 1470
        Speed :math:`c_a` the vehicle converts with [m/s], > 0 (paper D: 30 m/s systematic error).
    speed_sigma : float, default 1
        Ping-to-ping standard deviation :math:`\sigma_c` of the true speed [m/s], >= 0 and below a tenth of
        ``true_speed`` (so that a drawn speed is never near zero).

    Examples
    --------
    >>> from uwtutor.ranging import SoundSpeedMismatch
    >>> model = SoundSpeedMismatch()
    >>> round(model.scale_error, 3), round(model.mean_error(1000.0), 1)
    (-0.02, -20.0)
    >>> round(model.error_std(1000.0), 3)
    0.653
    """

    true_speed: float = 1500.0
    assumed_speed: float = 1470.0
    speed_sigma: float = 1.0

    def __post_init__(self) -> None:
        c = as_scalar("true_speed", self.true_speed, domain="positive")
        ca = as_scalar("assumed_speed", self.assumed_speed, domain="positive")
        sc = as_scalar("speed_sigma", self.speed_sigma, domain="nonnegative")
        if sc >= 0.1 * c:
            raise ValueError(f"speed_sigma must be below a tenth of true_speed ({0.1 * c:g} m/s); got {sc:g}")
        object.__setattr__(self, "true_speed", c)
        object.__setattr__(self, "assumed_speed", ca)
        object.__setattr__(self, "speed_sigma", sc)

    @property
    def scale_error(self) -> float:
        r""":math:`\gamma = c_a/c - 1`, the relative range error at the mean speed (-0.02 for paper D)."""
        return range_factor(self.assumed_speed, self.true_speed)[0] - 1.0

    def mean_error(self, true_range: ArrayLike) -> float | np.ndarray:
        r"""First-order mean error :math:`(c_a - c)/c \cdot r` [m] at true range(s) ``true_range``."""
        r = as_range_array("true_range", true_range)
        out = self.scale_error * r
        return float(out) if out.ndim == 0 else out

    def error_std(self, true_range: ArrayLike) -> float | np.ndarray:
        r"""First-order standard deviation :math:`(c_a/c)(\sigma_c/c) \cdot r` [m] at true range(s) ``true_range``."""
        r = as_range_array("true_range", true_range)
        out = range_factor(self.assumed_speed, self.true_speed, self.speed_sigma)[1] * r
        return float(out) if out.ndim == 0 else out

    def _draw(self, true_ranges: np.ndarray, times: np.ndarray,
              rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        c_true = self.true_speed + self.speed_sigma * rng.standard_normal(true_ranges.shape)
        gamma, _ = range_factor(self.assumed_speed, c_true)
        return true_ranges * (gamma - 1.0), np.zeros(true_ranges.shape, dtype=bool)


@dataclass(frozen=True)
class SlowBias(RangeErrorModel):
    r"""Slowly varying range bias: a mean plus low-pass filtered white noise (Liu et al., paper A).

    The bias :math:`\upsilon_k` is a mean :math:`\mu_\upsilon` plus an Ornstein-Uhlenbeck process :math:`s_k` with
    correlation time :math:`T_\upsilon` and stationary standard deviation :math:`\sigma_\upsilon`, discretized
    exactly for the actual (possibly uneven) epoch steps:

    .. math::

        \upsilon_k = \mu_\upsilon + s_k, \qquad s_k = \phi_k s_{k-1} + \sigma_\upsilon\sqrt{1 - \phi_k^2}\;\epsilon_k,
        \qquad \phi_k = e^{-(t_k - t_{k-1})/T_\upsilon}, \qquad \epsilon_k \sim N(0, 1),

    started from its stationary distribution :math:`s_0 \sim N(0, \sigma_\upsilon^2)`. Hence
    :math:`\mathrm{corr}(s_k, s_j) = e^{-|t_k - t_j|/T_\upsilon}` and :math:`\mathrm{std}(s_k) = \sigma_\upsilon` at
    every epoch. Paper A's "slowly varying noise :math:`\mu_k` with mean :math:`\rho`" (:math:`\rho` is the book's
    :math:`\mu_\upsilon`); its filter models it as a random walk, which is the limit :math:`T_\upsilon \to \infty`
    over a short window.

    Parameters
    ----------
    mean : float
        Constant part :math:`\mu_\upsilon` [m].
    sigma : float
        Stationary standard deviation :math:`\sigma_\upsilon` [m], >= 0.
    time_constant : float
        Correlation time :math:`T_\upsilon` [s], > 0.

    Notes
    -----
    The recursion loops over epochs (vectorized across runs); a 1000-run, 2000-epoch batch takes a few
    milliseconds.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.ranging import SlowBias
    >>> b = SlowBias(mean=5.0, sigma=3.0, time_constant=600.0).sample(
    ...     np.full(20, 1000.0), 10.0 * np.arange(20), np.random.default_rng(1), n_runs=2000
    ... )
    >>> # stationary: mean 5 m and std 3 m at every epoch
    >>> bool(abs(b.mean() - 5.0) < 0.3), bool(abs(b[:, -1].std() - 3.0) < 0.3)
    (True, True)
    >>> # consecutive epochs 10 s apart: correlation exp(-10/600)
    >>> round(float(np.corrcoef(b[:, 9], b[:, 10])[0, 1]), 2)
    0.98
    """

    mean: float
    sigma: float
    time_constant: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "mean", as_scalar("mean", self.mean))
        object.__setattr__(self, "sigma", as_scalar("sigma", self.sigma, domain="nonnegative"))
        object.__setattr__(self, "time_constant", as_scalar("time_constant", self.time_constant, domain="positive"))

    def _draw(self, true_ranges: np.ndarray, times: np.ndarray,
              rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        m, k = true_ranges.shape
        steps = np.diff(times) / self.time_constant
        phi = np.exp(-steps)
        gain = self.sigma * np.sqrt(-np.expm1(-2.0 * steps))   # sigma*sqrt(1 - phi^2), accurate for short steps
        eps = rng.standard_normal((k, m))                      # time-major: each step reads one contiguous row
        b = np.empty((k, m))
        b[0] = self.sigma * eps[0]
        for i in range(1, k):
            b[i] = phi[i - 1] * b[i - 1] + gain[i - 1] * eps[i]
        return self.mean + b.T, np.zeros((m, k), dtype=bool)


@dataclass(frozen=True)
class Outliers(RangeErrorModel):
    r"""Gross range errors: patches of consecutive outliers and/or isolated random ones (paper E).

    * **Patches.** At each onset time the first epoch at or after it and the next ``count - 1`` epochs get an
      error of ``amplitude``: always ``+amplitude`` when one-sided, ``+amplitude`` or ``-amplitude`` with equal
      probability, independently per epoch, when ``two_sided``. Paper E's simulation: 10 one-sided outliers of
      80 m at 300 s and 20 two-sided ones at 700 s, i.e.
      ``Outliers((300.0,), 10, 80.0) + Outliers((700.0,), 20, 80.0, two_sided=True)``.
    * **Isolated.** With ``probability`` :math:`p`, each epoch of each run is also hit independently with
      probability :math:`p` (same amplitude and sign rule).

    Overlapping hits count once. Epochs that are not hit get exactly zero error.

    Parameters
    ----------
    onset_times : float or sequence of float
        Times [s] at which patches start (may be empty); stored as a tuple.
    count : int
        Number of consecutive epochs per patch, >= 1 (a patch is cut short at the last epoch).
    amplitude : float
        Outlier size [m], >= 0.
    two_sided : bool, default False
        Random sign per hit epoch instead of always positive.
    probability : float, optional
        Probability in [0, 1] of an isolated outlier at any epoch; ``None`` for none.

    Notes
    -----
    Which epochs were hit is returned by ``sample_with_mask``. ``outlier_mask(times, rng, n_runs)`` gives the
    same mask on its own: it makes the same draws, in the same order (the hit epochs first, then the signs), so
    it reproduces the mask of ``sample_with_mask`` called with a generator in the same state.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.ranging import Outliers
    >>> model = Outliers((300.0,), 10, 80.0)
    >>> e, hit = model.sample_with_mask(
    ...     np.full(600, 1500.0), np.arange(600.0), np.random.default_rng(0)
    ... )
    >>> int(hit.sum()), np.unique(e).tolist(), int(np.argmax(hit))
    (10, [0.0, 80.0], 300)
    """

    onset_times: tuple[float, ...]
    count: int
    amplitude: float
    two_sided: bool = False
    probability: float | None = None

    def __post_init__(self) -> None:
        onsets = np.atleast_1d(as_finite("onset_times", self.onset_times, ndim=(0, 1)))
        object.__setattr__(self, "onset_times", tuple(float(x) for x in onsets))
        object.__setattr__(self, "count", as_int("count", self.count, minimum=1))
        object.__setattr__(self, "amplitude", as_scalar("amplitude", self.amplitude, domain="nonnegative"))
        object.__setattr__(self, "two_sided", as_flag("two_sided", self.two_sided))
        if self.probability is not None:
            p = as_scalar("probability", self.probability)
            if not 0.0 <= p <= 1.0:
                raise ValueError(f"probability must lie in [0, 1]; got {p:g}")
            object.__setattr__(self, "probability", p)

    def _mask(self, times: np.ndarray, rng: np.random.Generator, m: int) -> np.ndarray:
        k = len(times)
        # Patches: +1 where a patch starts, -1 one past its end; a running sum > 0 marks the covered epochs.
        first = np.searchsorted(times, np.asarray(self.onset_times, dtype=float), side="left")
        marks = np.zeros(k + 1)
        np.add.at(marks, first, 1.0)
        np.add.at(marks, np.minimum(first + self.count, k), -1.0)
        patches = np.cumsum(marks[:k]) > 0
        mask = np.broadcast_to(patches, (m, k))
        if self.probability:
            mask = mask | (rng.random((m, k)) < self.probability)
        return np.array(mask)

    def outlier_mask(self, times: ArrayLike, rng: np.random.Generator, n_runs: int | None = None) -> np.ndarray:
        """Epochs hit by an outlier, as ``sample_with_mask`` would draw them from ``rng`` in the same state.

        Parameters
        ----------
        times : array_like, shape (K,)
            Epoch times [s], strictly increasing.
        rng : numpy.random.Generator
            Source of randomness (only used when ``probability`` is set).
        n_runs : int, optional
            Number of runs ``M``; ``None`` for a single run.

        Returns
        -------
        ndarray of bool, shape (K,) or (M, K)
        """
        t = as_times("times", times)
        rng = as_rng(rng)
        n = as_n_runs(n_runs)
        mask = self._mask(t, rng, 1 if n is None else n)
        return mask[0] if n is None else mask

    def _draw(self, true_ranges: np.ndarray, times: np.ndarray,
              rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        mask = self._mask(times, rng, true_ranges.shape[0])
        sign = np.where(rng.random(mask.shape) < 0.5, -1.0, 1.0) if self.two_sided else 1.0
        return np.where(mask, self.amplitude * sign, 0.0), mask


def measure_ranges(true_ranges: ArrayLike, times: ArrayLike, error: RangeErrorModel | None, rng: np.random.Generator,
                   n_runs: int | None = None, *, return_errors: bool = False) -> Any:
    r"""Measured ranges: true ranges plus the errors drawn from ``error``, :math:`r_k = |r^\mathrm{true}_k + e_k|`.

    This is the library's one maker of measured ranges: every scenario draws its ranges here, or, when it draws
    the errors of several sources from separate streams, adds them with :func:`add_range_errors`, which applies
    the same policy.

    **The policy for a negative sum.** A measured range is a length, the sound speed times a travel time, so it is
    never negative. When an error is larger than the range and of opposite sign (a two-sided outlier close to the
    beacon, absurd noise levels), the sum :math:`r^\mathrm{true}_k + e_k` is negative and the measurement is read
    as its magnitude. This keeps the size of the error (a 50 m error at 10 m gives 40 m, not 0 m) and never
    produces a value that no ranging system can report and every filter refuses. Clipping at zero is not used:
    it piles such measurements at exactly zero, as if the vehicle sat on the beacon. Whenever the sum is
    non-negative (every epoch of realistic ranges) the measured range is exactly :math:`r^\mathrm{true}_k + e_k`.

    Parameters
    ----------
    true_ranges : array_like, shape (K,) or (M, K)
        True ranges [m], finite and >= 0.
    times : array_like, shape (K,)
        Epoch times [s], strictly increasing.
    error : RangeErrorModel or None
        Error model (``None``: error-free ranges).
    rng : numpy.random.Generator
        Source of randomness (the draws are those of ``error.sample_with_mask`` with the same generator).
    n_runs : int, optional
        Number of Monte Carlo runs ``M`` (see ``RangeErrorModel.sample``).
    return_errors : bool, default False
        Also return the drawn errors and the outlier mask.

    Returns
    -------
    ranges : ndarray, shape (K,) or (M, K)
        Measured ranges [m], >= 0.
    errors : ndarray, same shape
        Only with ``return_errors``: the errors :math:`e_k` drawn from ``error`` (zeros for ``None``).
    outlier_mask : ndarray of bool, same shape
        Only with ``return_errors``: the epochs hit by an ``Outliers`` component.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.ranging import GaussianNoise, SoundSpeedMismatch, measure_ranges
    >>> rng = np.random.default_rng(3)
    >>> r = measure_ranges(
    ...     np.full(150, 2000.0),
    ...     np.arange(150.0),
    ...     SoundSpeedMismatch() + GaussianNoise(0.7),
    ...     rng,
    ... )
    >>> # 1470/1500 of the true range on average
    >>> bool(abs(r.mean() - 1960.0) < 1.0)
    True

    A two-sided outlier of 50 m at a true range of 10 m gives 60 m or 40 m, never a negative range:

    >>> from uwtutor.ranging import Outliers
    >>> r, e, hit = measure_ranges(
    ...     np.full(4, 10.0),
    ...     np.arange(4.0),
    ...     Outliers((0.0,), 4, 50.0, two_sided=True),
    ...     np.random.default_rng(0),
    ...     return_errors=True,
    ... )
    >>> e.tolist(), r.tolist()
    ([50.0, -50.0, -50.0, -50.0], [60.0, 40.0, 40.0, 40.0])
    """
    if error is not None and not isinstance(error, RangeErrorModel):
        raise TypeError(f"error must be a range error model (e.g. GaussianNoise(1.0)) or None; "
                        f"got {type(error).__name__}")
    full = as_flag("return_errors", return_errors)
    r, t, rng, single = _prepare(true_ranges, times, rng, n_runs)
    if error is None:
        err, mask = np.zeros(r.shape), np.zeros(r.shape, dtype=bool)
    else:
        err, mask = error._draw(r, t, rng)
    measured = _fold(r + err)
    if single:
        measured, err, mask = measured[0], err[0], mask[0]
    return (measured, err, mask) if full else measured


def _fold(total: np.ndarray) -> np.ndarray:
    """The policy of :func:`measure_ranges`: a negative sum of a true range and its errors is read as its size."""
    return np.abs(total)


def add_range_errors(true_ranges: ArrayLike, *errors: Any) -> np.ndarray:
    r"""Measured ranges from true ranges and errors drawn elsewhere, with the policy of :func:`measure_ranges`.

    :math:`r_k = |(\ldots((r^\mathrm{true}_k + e^{(1)}_k) + e^{(2)}_k) \ldots)|`: the errors are added in the order
    given, then a negative sum is read as its magnitude (see :func:`measure_ranges` for why). For a scenario that
    draws the parts of its range error from separate random streams (paper A's three parts, paper B's clock
    error and noise) or adds its errors to another geometry (paper E's slant ranges).

    Parameters
    ----------
    true_ranges : array_like
        True ranges [m], finite and >= 0.
    *errors : array_like
        One or more range errors [m], each of the shape of ``true_ranges`` or broadcasting into it (``(K,)``
        against ``(M, K)`` runs, or the other way round). NaN marks an epoch without a measurement and stays NaN.

    Returns
    -------
    ndarray
        Measured ranges [m], >= 0 (NaN where an error is NaN), of the broadcast shape.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.ranging import add_range_errors
    >>> add_range_errors([100.0, 20.0, 5.0], [1.5, np.nan, -8.0]).tolist()
    [101.5, nan, 3.0]
    """
    total = as_range_array("true_ranges", true_ranges, max_abs=MAX_COORDINATE)
    if not errors:
        raise TypeError("add_range_errors needs at least one array of errors after true_ranges")
    for i, value in enumerate(errors):
        name = "errors" if len(errors) == 1 else f"errors[{i}]"
        e = as_float_array(name, value)
        if np.isinf(e).any():
            raise ValueError(f"{name} must be finite (NaN marks a missing measurement); got an infinity")
        big = np.abs(e) > MAX_COORDINATE
        if big.any():
            raise ValueError(f"{name} must be at most {MAX_COORDINATE:.0e} m in magnitude; got "
                             f"{e[big].flat[0]:.3g}. Change its units")
        try:
            shape = np.broadcast_shapes(total.shape, e.shape)
        except ValueError:
            shape = None
        if shape not in (total.shape, e.shape):     # (K,) against (M, K) is a batch; (K, 1) against (K,) is not
            raise ValueError(f"{name} of shape {e.shape} does not match true_ranges of shape {total.shape} "
                             "(one error per range, or a batch of runs (M, K) of them)")
        total = total + e
    return _fold(total)


def horizontal_range(positions: ArrayLike, beacon: ArrayLike) -> float | np.ndarray:
    r"""Horizontal range :math:`\|p - b\|` between positions and a beacon.

    Parameters
    ----------
    positions : array_like, shape (..., 2)
        Vehicle positions [m], e.g. ``(K, 2)`` or ``(M, K, 2)``.
    beacon : array_like, shape (2,) or (..., 2)
        Beacon position(s) [m]; broadcasts against ``positions`` (a moving beacon: one position per epoch).

    Returns
    -------
    float or ndarray, shape (...)
        Ranges [m]; a float for a single position.

    Examples
    --------
    >>> from uwtutor.ranging import horizontal_range
    >>> horizontal_range([[3.0, 4.0], [6.0, 8.0]], (0.0, 0.0)).tolist()
    [5.0, 10.0]
    >>> horizontal_range([3.0, 4.0], (0.0, 0.0))
    5.0
    """
    p = as_points("positions", positions, nonempty=True)
    b = as_points("beacon", beacon, nonempty=True)
    try:
        d = p - b
    except ValueError:
        raise ValueError(f"beacon of shape {b.shape} does not broadcast against positions of shape {p.shape}") from None
    out = np.hypot(d[..., 0], d[..., 1])
    return float(out) if out.ndim == 0 else out


def slant_range(positions: ArrayLike, beacon: ArrayLike, depth_difference: ArrayLike) -> float | np.ndarray:
    r"""Straight-line range with a depth difference :math:`\Delta z`: :math:`\sqrt{\|p - b\|^2 + \Delta z^2}`.

    Parameters
    ----------
    positions : array_like, shape (..., 2)
        Vehicle horizontal positions [m].
    beacon : array_like, shape (2,) or (..., 2)
        Beacon horizontal position(s) [m].
    depth_difference : float or array_like
        Depth of the vehicle minus depth of the beacon [m] (sign irrelevant); broadcasts against the
        horizontal ranges.

    Returns
    -------
    float or ndarray
        Slant ranges [m].

    Examples
    --------
    >>> from uwtutor.ranging import slant_range
    >>> slant_range([3.0, 4.0], (0.0, 0.0), 12.0)
    13.0
    """
    h = np.asarray(horizontal_range(positions, beacon))
    dz = as_finite("depth_difference", depth_difference)
    try:
        out = np.hypot(h, dz)
    except ValueError:
        raise ValueError(f"depth_difference of shape {dz.shape} does not broadcast against the ranges of shape "
                         f"{h.shape}") from None
    return float(out) if out.ndim == 0 else out


def reception_times(ping_times: ArrayLike, beacon_position_at: Any, vehicle_position_at: Any, sound_speed: float,
                    max_iter: int = 50, tol: ArrayLike = 1e-9) -> tuple[np.ndarray, np.ndarray]:
    r"""When a moving vehicle hears each ping, and the true range the ping travelled.

    A ping leaves the beacon at :math:`t_p` and reaches the vehicle at :math:`t_r` such that

    .. math::

        \|p_v(t_r) - p_b(t_p)\| = c\,(t_r - t_p).

    The fixed-point iteration :math:`t_r \leftarrow t_p + \|p_v(t_r) - p_b(t_p)\|/c`, started from
    :math:`t_r = t_p`, contracts by a factor of at most :math:`v/c` per step (about :math:`10^{-3}`), so it
    converges in a handful of iterations. Zhu et al. (2019), paper D, ping every 10 s: the reception times are
    then not equally spaced.

    Parameters
    ----------
    ping_times : array_like, shape (K,)
        Emission times [s].
    beacon_position_at : callable or array_like, shape (2,)
        Beacon position: a fixed point, or a function mapping an array of times to positions of shape
        ``times.shape + (2,)`` (e.g. ``Track.position_at``).
    vehicle_position_at : callable or array_like, shape (2,)
        Vehicle position, same conventions.
    sound_speed : float
        Sound speed :math:`c` [m/s], > 0.
    max_iter : int, default 50
        Maximum number of iterations.
    tol : float, default 1e-9
        Convergence threshold on the largest change of any reception time [s], > 0.

    Returns
    -------
    reception_times : ndarray, shape (K,)
        :math:`t_r` [s].
    ranges : ndarray, shape (K,)
        :math:`c\,(t_r - t_p)`, the true (horizontal) ranges at reception [m].

    Raises
    ------
    RuntimeError
        If the iteration has not converged after ``max_iter`` iterations (a vehicle nearly as fast as sound).

    Examples
    --------
    A vehicle 1500 m from the beacon moving straight away at 2 m/s hears a ping after :math:`1500/(c - v)`:

    >>> import numpy as np
    >>> from uwtutor.ranging import reception_times
    >>> vehicle = lambda t: np.stack([1500.0 + 2.0 * t, 0.0 * t], axis=-1)
    >>> t_r, r = reception_times([0.0], (0.0, 0.0), vehicle, 1500.0)
    >>> bool(np.isclose(t_r[0], 1500.0 / 1498.0))
    True
    """
    tp = as_finite("ping_times", ping_times, ndim=1)
    beacon_at = as_position_function("beacon_position_at", beacon_position_at)
    vehicle_at = as_position_function("vehicle_position_at", vehicle_position_at)
    c = as_scalar("sound_speed", sound_speed, domain="positive")
    n_iter = as_int("max_iter", max_iter, minimum=1)
    tol = float(as_positive("tol", tol, ndim=0))

    pb = beacon_at(tp)

    def travelled(t_r: np.ndarray) -> np.ndarray:
        try:
            d = vehicle_at(t_r) - pb
        except ValueError as exc:        # e.g. positions beyond 1e150 m at times far in the future
            raise ValueError(f"{exc} (at the reception times the iteration reached from ping_times, "
                             f"{np.min(tp, initial=0.0):.3g} to {np.max(tp, initial=0.0):.3g} s: check the units of "
                             "ping_times, sound_speed and the position functions)") from None
        return np.hypot(d[..., 0], d[..., 1])

    t_r = tp
    for _ in range(n_iter):
        t_new = tp + travelled(t_r) / c
        change = np.max(np.abs(t_new - t_r), initial=0.0)
        t_r = t_new
        if change <= tol:
            break
    else:
        raise RuntimeError(f"reception_times did not converge in {n_iter} iterations (last change {change:.3g} s); "
                           "is the vehicle or beacon moving at a speed close to the sound speed?")
    return t_r, c * (t_r - tp)


#: The former names (one release): range error models are not exceptions, so their names no longer end in "Error".
__getattr__ = deprecated_aliases(__name__, {"SoundSpeedError": "SoundSpeedMismatch", "CompositeError": "RangeErrorSum"})
