r"""GM(1,1) grey prediction: fit a short positive series, grade the fit, forecast it.

Deng's grey model GM(1,1) (Deng 1982) forecasts a short series :math:`x^{(0)}(1), \dots, x^{(0)}(n)` of positive
values without a model of the system behind it. It works on the accumulated series
:math:`x^{(1)}(k) = \sum_{i \le k} x^{(0)}(i)` (the *accumulated generating operation*), which it fits with the
first-order "whitening" equation

.. math::

    \frac{\mathrm{d} x^{(1)}}{\mathrm{d} t} + a\, x^{(1)} = b,

with the *development coefficient* :math:`a` and the *grey input* :math:`b`. Discretized with the background values
:math:`z^{(1)}(k) = \alpha\, x^{(1)}(k) + (1 - \alpha)\, x^{(1)}(k-1)` (:math:`\alpha = 0.5` as a rule, paper C
eq. (10)), the equation reads :math:`x^{(0)}(k) + a\, z^{(1)}(k) = b` for :math:`k = 2 \dots n`, and least squares
gives

.. math::

    \begin{bmatrix} a \\ b \end{bmatrix} = (B^T B)^{-1} B^T Y, \qquad
    B = \begin{bmatrix} -z^{(1)}(2) & 1 \\ \vdots & \vdots \\ -z^{(1)}(n) & 1 \end{bmatrix}, \qquad
    Y = \begin{bmatrix} x^{(0)}(2) \\ \vdots \\ x^{(0)}(n) \end{bmatrix}.

The solution of the whitening equation through :math:`x^{(1)}(1) = x^{(0)}(1)` is the *time response*
(paper C eq. (11)), and differencing it restores the series:

.. math::

    \hat x^{(1)}(k+1) = \Bigl(x^{(0)}(1) - \frac{b}{a}\Bigr) e^{-a k} + \frac{b}{a}, \qquad
    \hat x^{(0)}(k+1) = \hat x^{(1)}(k+1) - \hat x^{(1)}(k)
                      = (1 - e^{a}) \Bigl(x^{(0)}(1) - \frac{b}{a}\Bigr) e^{-a k}, \quad k \ge 1.

Paper C's eq. (12) prints the factor as :math:`(1 - e^{-a})`; the difference of the two exponentials gives
:math:`(1 - e^{a})` (equivalently :math:`(e^{-a} - 1)\, e^{-a(k-1)}`). This module evaluates the equivalent form
:math:`(b - a x^{(0)}(1))\, \frac{e^{a} - 1}{a}\, e^{-a k}`, which stays exact as :math:`a \to 0` (where the
forecast becomes the constant :math:`b`).

Two conditions come with the model:

* **positivity** -- the accumulated series must grow, so every value must be > 0. A quantity that can be negative
  (the pitch of a vehicle) is shifted by a constant first, and the shift taken off the forecast;
* **the level-ratio test** -- the ratios :math:`\ell(k) = x^{(0)}(k-1) / x^{(0)}(k)` must lie in
  :math:`(e^{-2/(n+1)}, e^{2/(n+1)})` for the series to suit GM(1,1) (:func:`level_ratio_test`).

The fit is graded by the *posterior variance ratio* :math:`C_\mathrm{g} = S_\mathrm{e} / S_x` (standard deviation
of the residuals :math:`e_\mathrm{g}(k)` over that of the data; below 0.35 good, above 0.65 poor) and the
*small-error probability* :math:`p_\mathrm{g} = \Pr\{|e_\mathrm{g}(k) - \bar e_\mathrm{g}| < 0.6745\, S_x\}` (the
grey literature's :math:`C` and :math:`P`; the book's notation page renames them so that :math:`P` is never a
covariance).

:func:`fit_gm11` fits one series and returns a :class:`GM11` with all of this; :func:`gm11_forecast` and
:func:`rolling_gm11_forecast` are the vectorized forms that paper C's grey particle filter calls at every step.

References
----------
Deng, J. (1982). Control problems of grey systems. *Systems & Control Letters* 1(5), 288-294.

Liu, S. and Lin, Y. (2010). *Grey Systems: Theory and Applications*. Springer. Chapter on GM(1,1): the level-ratio
test and the posterior-variance grading.

Li Ting, Zhao Dexin, Huang Zhiping and Su Shaojing (2013), paper C, section 2.2, eqs. (7)-(12).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ._validate import as_finite, as_float_array, as_int, as_scalar, check_finite_result, check_work

__all__ = [
    "GM11",
    "LevelRatioTest",
    "fit_gm11",
    "level_ratio_test",
    "gm11_coefficients",
    "gm11_forecast",
    "gm11_next",
    "rolling_gm11_forecast",
]

_MIN_LENGTH = 4          # the usual minimum of the grey-systems literature (2 unknowns, n - 1 equations)


# --- validation -------------------------------------------------------------------------------------------------

def _background_weight(value: Any) -> float:
    w = as_scalar("background_weight", value)
    if not 0.0 <= w <= 1.0:
        raise ValueError(f"background_weight must lie in [0, 1] (0.5 is the usual choice); got {w}")
    return w


def _positive_series(name: str, value: Any, *, axis: int = -1, ndim: Any = None) -> np.ndarray:
    """A finite float array with at least 4 positive values along ``axis``."""
    x = as_finite(name, value, ndim=ndim)
    if x.ndim == 0:
        raise ValueError(f"{name} must be a series (an array of at least {_MIN_LENGTH} values); got a scalar")
    n = x.shape[axis]
    if n < _MIN_LENGTH:
        raise ValueError(f"{name} must hold at least {_MIN_LENGTH} values for GM(1,1); got {n}")
    bad = x <= 0
    if bad.any():
        idx = np.argwhere(bad)[0]
        where = f"index {int(idx[0])}" if idx.size == 1 else f"index {tuple(int(i) for i in idx)}"
        raise ValueError(f"{name} must be > 0 for GM(1,1) (its accumulated series must grow); got "
                         f"{x[tuple(idx)]:.6g} at {where}. Shift the series by a constant first "
                         "(e.g. series - series.min() + 1) and subtract the shift from the forecast")
    return x


# --- the vectorized core -----------------------------------------------------------------------------------------

def _coefficients(x0: np.ndarray, alpha: float) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares ``a``, ``b`` of series ``x0`` (..., n), batched over the leading axes.

    The normal equations of the two-column regression ``x0(k) = -a z(k) + b`` solved in centred form
    (``a = -cov(z, y) / var(z)``, ``b = mean(y) + a mean(z)``): the same numbers as paper C's eq. (10) with its sums,
    without the cancellation of ``(n-1) sum z^2 - (sum z)^2`` for long or large series.
    """
    # a is scale-free and b scales with the series: a series far from 1 (1e-320, 1e300) is fitted in units of its
    # largest value, where the sums of squares below neither underflow nor overflow (ordinary series are left alone)
    scale = np.maximum.reduce(x0, axis=-1, keepdims=True)
    extreme = (scale < 1e-100) | (scale > 1e100)
    if extreme.any():
        a, b = _coefficients(np.where(extreme, x0 / scale, x0), alpha)
        return a, np.where(extreme[..., 0], b * scale[..., 0], b)
    x1 = np.cumsum(x0, axis=-1)
    z = alpha * x1[..., 1:] + (1.0 - alpha) * x1[..., :-1]
    y = x0[..., 1:]
    m = y.shape[-1]
    z_mean = np.add.reduce(z, axis=-1, keepdims=True) / m        # (sums rather than .mean(): called every step
    y_mean = np.add.reduce(y, axis=-1, keepdims=True) / m        #  of the grey particle filter on tiny arrays)
    zc = z - z_mean
    yc = y - y_mean
    a = -np.add.reduce(zc * yc, axis=-1) / np.add.reduce(zc * zc, axis=-1)   # z strictly increases: var(z) > 0
    b = y_mean[..., 0] + a * z_mean[..., 0]
    return a, b


def _fitted_coefficients(x0: np.ndarray, alpha: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_coefficients` of a user's series, refused by name when float64 cannot fit it (values that span
    more orders of magnitude than float64 resolves, e.g. 1e300 next to 10: the accumulated series is flat)."""
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        a, b = _coefficients(x0, alpha)
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        raise ValueError("series cannot be fitted by GM(1,1) in float64: its values span too many orders of magnitude "
                         "(its accumulated series does not grow in floating point). Rescale or split it")
    return a, b


def _expm1_over(a: np.ndarray) -> np.ndarray:
    """``(e^a - 1) / a``, equal to 1 at ``a = 0`` (no division by zero)."""
    a = np.asarray(a, dtype=float)
    out = np.ones_like(a)
    np.divide(np.expm1(a), a, out=out, where=a != 0.0)
    return out


def _restored(x0_first: np.ndarray, a: np.ndarray, b: np.ndarray, k: np.ndarray) -> np.ndarray:
    r""":math:`\hat x^{(0)}(k+1) = (b - a x^{(0)}(1)) \frac{e^a - 1}{a} e^{-a k}` for ``k >= 1`` (broadcast)."""
    a_ = a[..., None]
    return ((b - a * x0_first) * _expm1_over(a))[..., None] * np.exp(-a_ * k)


# --- results ------------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class LevelRatioTest:
    r"""The level-ratio (class-ratio) test of a series for GM(1,1).

    Attributes
    ----------
    ratios : ndarray, shape (n - 1,)
        :math:`\ell(k) = x^{(0)}(k-1) / x^{(0)}(k)`, ``k = 2 .. n``.
    lower : float
        :math:`e^{-2/(n+1)}`.
    upper : float
        :math:`e^{2/(n+1)}`.
    passed : bool
        Whether every ratio lies strictly between ``lower`` and ``upper``.

    Examples
    --------
    >>> from uwtutor.grey import level_ratio_test
    >>> test = level_ratio_test([2.874, 3.278, 3.337, 3.390, 3.679])
    >>> test.ratios.round(3), round(test.lower, 3), round(test.upper, 3)
    (array([0.877, 0.982, 0.984, 0.921]), 0.717, 1.396)
    >>> bool(test)
    True
    """

    ratios: np.ndarray
    lower: float
    upper: float
    passed: bool

    def __bool__(self) -> bool:
        return self.passed


@dataclass(frozen=True)
class GM11:
    r"""A GM(1,1) model fitted to a series by :func:`fit_gm11`.

    Attributes
    ----------
    series : ndarray, shape (n,)
        The original series :math:`x^{(0)}`.
    a : float
        Development coefficient (negative for a growing series).
    b : float
        Grey input.
    background_weight : float
        :math:`\alpha` of the background values.
    accumulated : ndarray, shape (n,)
        :math:`x^{(1)}`, the cumulative sum of the series.
    background : ndarray, shape (n - 1,)
        Background values :math:`z^{(1)}(k)`, ``k = 2 .. n``.
    fitted : ndarray, shape (n,)
        Restored values :math:`\hat x^{(0)}(k)`, ``k = 1 .. n`` (the first equals :math:`x^{(0)}(1)`).
    residuals : ndarray, shape (n,)
        :math:`e_\mathrm{g}(k) = x^{(0)}(k) - \hat x^{(0)}(k)` (the first is 0).
    relative_errors : ndarray, shape (n,)
        :math:`|e_\mathrm{g}(k)| / x^{(0)}(k)`.
    posterior_variance_ratio : float
        :math:`C_\mathrm{g} = S_\mathrm{e} / S_x`, population standard deviations of the residuals and of the series
        (0 when the series is constant).
    small_error_probability : float
        :math:`p_\mathrm{g}`, the share of residuals with :math:`|e_\mathrm{g}(k) - \bar e_\mathrm{g}| < 0.6745\, S_x`.
    level_ratio : LevelRatioTest
        The level-ratio test of the series.

    Examples
    --------
    >>> from uwtutor.grey import fit_gm11
    >>> m = fit_gm11([2.874, 3.278, 3.337, 3.390, 3.679])
    >>> m.n, round(m.posterior_variance_ratio, 3), round(m.small_error_probability, 2)
    (5, 0.212, 1.0)
    >>> float(m.time_response(0.0)), m.level_ratio.passed
    (2.874, True)
    """

    series: np.ndarray
    a: float
    b: float
    background_weight: float
    accumulated: np.ndarray
    background: np.ndarray
    fitted: np.ndarray
    residuals: np.ndarray
    relative_errors: np.ndarray
    posterior_variance_ratio: float
    small_error_probability: float
    level_ratio: LevelRatioTest

    @property
    def n(self) -> int:
        """Length of the fitted series."""
        return self.series.size

    def time_response(self, k: ArrayLike) -> np.ndarray:
        r"""The accumulated-series model :math:`\hat x^{(1)}(k+1) = (x^{(0)}(1) - b/a) e^{-ak} + b/a`.

        Parameters
        ----------
        k : array_like of float
            Steps from the start (``k = 0`` gives :math:`x^{(0)}(1)`); any real ``k >= 0``.

        Returns
        -------
        ndarray
            :math:`\hat x^{(1)}(k+1)`, shape of ``k``. Evaluated as
            :math:`x^{(0)}(1) + (b - a x^{(0)}(1))\, k\, \frac{1 - e^{-ak}}{ak}`, exact as ``a`` tends to 0.
        """
        k = as_finite("k", k)
        if (k < 0).any():
            raise ValueError("k must be >= 0 (steps after the first value of the series)")
        x1 = self.series[0]
        with np.errstate(over="ignore", invalid="ignore"):
            out = x1 + (self.b - self.a * x1) * k * _expm1_over(-self.a * k)
        return check_finite_result(out, "k", what="the GM(1,1) time response")

    def forecast(self, steps: int = 1) -> np.ndarray:
        r"""The next ``steps`` values :math:`\hat x^{(0)}(n+1), \dots, \hat x^{(0)}(n+\text{steps})`.

        Parameters
        ----------
        steps : int, optional
            How many values beyond the end of the series (default 1).

        Returns
        -------
        ndarray, shape (steps,)
        """
        steps = as_int("steps", steps, minimum=1)
        check_work("steps", steps, "forecasts")
        k = np.arange(self.n, self.n + steps, dtype=float)
        with np.errstate(over="ignore", invalid="ignore"):
            out = _restored(np.asarray(self.series[0]), np.asarray(self.a), np.asarray(self.b), k)
        return check_finite_result(out, "steps", what="the GM(1,1) forecast")


# --- public functions ---------------------------------------------------------------------------------------------

def level_ratio_test(series: ArrayLike) -> LevelRatioTest:
    r"""The level-ratio test: is :math:`x^{(0)}(k-1)/x^{(0)}(k) \in (e^{-2/(n+1)}, e^{2/(n+1)})` for every ``k``?

    A series that fails is too steep or too irregular for GM(1,1); shifting it by a constant (which flattens the
    ratios towards 1) or smoothing it usually makes it pass (Liu and Lin 2010).

    Parameters
    ----------
    series : array_like, shape (n,)
        A positive series, ``n >= 4``.

    Returns
    -------
    LevelRatioTest

    Examples
    --------
    >>> from uwtutor.grey import level_ratio_test
    >>> bool(level_ratio_test([2.874, 3.278, 3.337, 3.390, 3.679]))
    True
    >>> bool(level_ratio_test([1.0, 3.0, 9.0, 27.0]))
    False
    """
    x0 = _positive_series("series", series, ndim=1)
    n = x0.size
    ratios = x0[:-1] / x0[1:]
    lower, upper = float(np.exp(-2.0 / (n + 1))), float(np.exp(2.0 / (n + 1)))
    return LevelRatioTest(ratios=ratios, lower=lower, upper=upper,
                          passed=bool(np.all((ratios > lower) & (ratios < upper))))


def fit_gm11(series: ArrayLike, *, background_weight: float = 0.5) -> GM11:
    r"""Fit GM(1,1) to a positive series by least squares (paper C, eqs. (7)-(12)).

    Parameters
    ----------
    series : array_like, shape (n,)
        The series :math:`x^{(0)}(1 \dots n)`: finite, > 0, ``n >= 4``.
    background_weight : float, optional
        :math:`\alpha` in :math:`z^{(1)}(k) = \alpha x^{(1)}(k) + (1 - \alpha) x^{(1)}(k-1)`; 0.5 (paper C).

    Returns
    -------
    GM11
        ``a``, ``b``, the fitted series, residuals, the posterior variance ratio, the small-error probability, the
        level-ratio test, and ``forecast(steps)``.

    Raises
    ------
    ValueError
        If the series has fewer than 4 values, is not finite, or has a value <= 0 (shift it first).

    Notes
    -----
    For an exactly geometric series :math:`x^{(0)}(k) = c\, q^{k-1}` the discrete equation holds exactly with
    :math:`a = 2(1-q)/(1+q)` and :math:`b = 2c/(1+q)` (for :math:`\alpha = 0.5`), while the restored series grows
    by :math:`e^{-a}` per step, which is close to, but not exactly, :math:`q`: GM(1,1) is biased even on the
    series it should fit best. ``tests/test_grey.py`` checks both facts.

    Examples
    --------
    The classic textbook series of the grey-systems literature:

    >>> from uwtutor.grey import fit_gm11
    >>> m = fit_gm11([2.874, 3.278, 3.337, 3.390, 3.679])
    >>> round(m.a, 5), round(m.b, 4)
    (-0.0372, 3.0654)
    >>> m.fitted.round(3)
    array([2.874, 3.232, 3.355, 3.482, 3.614])
    >>> m.forecast(2).round(3)
    array([3.751, 3.893])
    """
    alpha = _background_weight(background_weight)
    x0 = _positive_series("series", series, ndim=1)
    a_arr, b_arr = _fitted_coefficients(x0, alpha)
    a, b = float(a_arr), float(b_arr)
    x1 = np.cumsum(x0)
    z = alpha * x1[1:] + (1.0 - alpha) * x1[:-1]
    n = x0.size
    fitted = np.empty(n)
    fitted[0] = x0[0]
    fitted[1:] = _restored(np.asarray(x0[0]), a_arr, b_arr, np.arange(1.0, n))
    residuals = x0 - fitted
    unit = float(np.max(x0))                 # C and P are scale-free: computed in units of the series' largest
    s1 = float(np.std(x0 / unit))            # value, so that 1e300 or 1e-320 neither overflow nor underflow
    s2 = float(np.std(residuals / unit))
    C = s2 / s1 if s1 > 0 else 0.0
    P = (float(np.mean(np.abs(residuals / unit - (residuals / unit).mean()) < 0.6745 * s1)) if s1 > 0 else 1.0)
    for part in (x1, z, fitted, residuals):       # the accumulated series of values near 1.8e308 overflows
        check_finite_result(part, "series", what="the GM(1,1) fit (its accumulated series)")
    return GM11(series=x0.copy(), a=a, b=b, background_weight=alpha, accumulated=x1, background=z,
                fitted=fitted, residuals=residuals, relative_errors=np.abs(residuals) / x0,
                posterior_variance_ratio=C, small_error_probability=P, level_ratio=level_ratio_test(x0))


def gm11_coefficients(series: ArrayLike, *, background_weight: float = 0.5) -> tuple[np.ndarray, np.ndarray]:
    """The GM(1,1) coefficients ``a`` and ``b`` of many series at once (the last axis is time).

    Parameters
    ----------
    series : array_like, shape (..., n)
        Positive series, ``n >= 4``.
    background_weight : float, optional
        :math:`\\alpha` of the background values (0.5).

    Returns
    -------
    a : ndarray, shape (...)
        Development coefficients.
    b : ndarray, shape (...)
        Grey inputs.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.grey import gm11_coefficients
    >>> a, b = gm11_coefficients(
    ...     np.array([[2.874, 3.278, 3.337, 3.390, 3.679], [1.0, 2.0, 3.0, 4.0, 5.0]])
    ... )
    >>> a.round(4), b.round(4)
    (array([-0.0372, -0.2811]), array([3.0654, 1.6024]))
    """
    alpha = _background_weight(background_weight)
    x0 = _positive_series("series", series)
    return _fitted_coefficients(x0, alpha)


def gm11_forecast(series: ArrayLike, steps: int = 1, *, background_weight: float = 0.5) -> np.ndarray:
    r"""Fit GM(1,1) to each series along the last axis and forecast the next ``steps`` values.

    The vectorized form of ``fit_gm11(s).forecast(steps)`` for a stack of series: paper C's grey particle filter
    forecasts the depth, speed and (shifted) pitch from their last ``L`` measurements in one call.

    Parameters
    ----------
    series : array_like, shape (..., n)
        Positive series, ``n >= 4``.
    steps : int, optional
        Number of values to forecast (default 1).
    background_weight : float, optional
        :math:`\alpha` of the background values (0.5).

    Returns
    -------
    ndarray, shape (..., steps)
        :math:`\hat x^{(0)}(n+1), \dots, \hat x^{(0)}(n + \text{steps})` of each series.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.grey import gm11_forecast
    >>> gm11_forecast(
    ...     np.array(
    ...         [[2.874, 3.278, 3.337, 3.390, 3.679], [5.0, 5.0, 5.0, 5.0, 5.0]]
    ...     )
    ... ).round(3)
    array([[3.751],
           [5.   ]])
    """
    alpha = _background_weight(background_weight)
    steps = as_int("steps", steps, minimum=1)
    x0 = _positive_series("series", series)
    check_work("steps", steps * (x0.size // x0.shape[-1]), "forecasts")
    a, b = _fitted_coefficients(x0, alpha)
    n = x0.shape[-1]
    with np.errstate(over="ignore", invalid="ignore"):
        # a work guard: the forecast grows or decays monotonically, so its ends say whether it overflows, before
        # the steps are computed (10**8 steps of a growing series: refused at once, not after gigabytes)
        ends = _restored(x0[..., 0], a, b, np.array([float(n), float(n + steps - 1)]))
        check_finite_result(ends, "series", "steps", what="the GM(1,1) forecast")
        out = _restored(x0[..., 0], a, b, np.arange(n, n + steps, dtype=float))
    return check_finite_result(out, "series", "steps", what="the GM(1,1) forecast")


def gm11_next(series: ArrayLike) -> np.ndarray:
    r"""The one-step GM(1,1) forecast :math:`\hat x^{(0)}(n+1)` of each series along the last axis, lean.

    The same numbers as ``gm11_forecast(series, 1)[..., 0]`` (background weight 0.5), with one check only
    (every value finite and > 0): the form a filter calls at every step on windows it has already assembled,
    such as the grey particle filter's last ``L`` measurements of every sensor of every run.

    Parameters
    ----------
    series : ndarray, shape (..., n)
        Positive, finite series, ``n >= 4``.

    Returns
    -------
    ndarray, shape (...)

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.grey import gm11_next
    >>> gm11_next(
    ...     np.array(
    ...         [[2.874, 3.278, 3.337, 3.390, 3.679], [5.0, 5.0, 5.0, 5.0, 5.0]]
    ...     )
    ... ).round(3)
    array([3.751, 5.   ])
    """
    x0 = as_float_array("series", series)       # dtype checks; NaN and <= 0 refused below
    if x0.ndim == 0 or x0.shape[-1] < _MIN_LENGTH:
        raise ValueError(f"series must hold at least {_MIN_LENGTH} values along its last axis for GM(1,1); "
                         f"got shape {x0.shape}")
    if not np.minimum.reduce(x0, axis=None) > 0.0:          # also False for NaN
        raise ValueError("series must be finite and > 0 for GM(1,1) (shift it by a constant first); got a value "
                         "<= 0 or NaN")
    n = x0.shape[-1]
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        a, b = _coefficients(x0, 0.5)
        out = _restored(x0[..., 0], a, b, np.array([float(n)]))[..., 0]
    if not np.all(np.isfinite(out)):
        raise ValueError("series gives a GM(1,1) forecast that overflows float64 (values near 1e308, a series "
                         "that grows too fast for its length, or values that span too many orders of magnitude): "
                         "rescale the series")
    return out


def rolling_gm11_forecast(series: ArrayLike, window: int, *, offset: float = 0.0,
                          background_weight: float = 0.5) -> np.ndarray:
    r"""One-step GM(1,1) forecasts along a series, each from the ``window`` values before it.

    ``out[..., k]`` is the forecast of ``series[..., k]`` made from ``series[..., k - window : k]`` (shifted by
    ``offset`` before the fit and back after it); the first ``window`` entries are NaN (not enough history).
    This is the grey forecast of paper C's eq. (21) at every step.

    Parameters
    ----------
    series : array_like, shape (..., K)
        The series (time along the last axis).
    window : int
        Number of past values per fit, ``L`` (30 in paper C), at least 4.
    offset : float, optional
        Constant added before fitting so that every window is positive (e.g. for a pitch angle); 0 by default.
    background_weight : float, optional
        :math:`\alpha` of the background values (0.5).

    Returns
    -------
    ndarray, shape (..., K)

    Raises
    ------
    ValueError
        If a window (after the offset) holds a value <= 0 or a non-finite value.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.grey import rolling_gm11_forecast
    >>> s = np.array([10.0, 11.0, 12.5, 13.0, 14.2, 15.1, 16.3])
    >>> rolling_gm11_forecast(s, window=4).round(2)
    array([  nan,   nan,   nan,   nan, 14.27, 15.04, 16.32])
    """
    x = as_finite("series", series)
    if x.ndim == 0:
        raise ValueError("series must be an array of values along its last axis; got a scalar")
    if x.shape[-1] == 0:
        raise ValueError(f"series must hold at least one value along its last axis; got shape {x.shape}")
    L = as_int("window", window, minimum=_MIN_LENGTH)
    c = as_scalar("offset", offset)
    K = x.shape[-1]
    out = np.full(x.shape, np.nan)
    if K <= L:
        return out
    windows = np.lib.stride_tricks.sliding_window_view(x[..., :-1] + c, L, axis=-1)   # (..., K - L, L)
    out[..., L:] = gm11_forecast(windows, 1, background_weight=background_weight)[..., 0] - c
    return out
