r"""Wavelet (MAD) estimation of the noise level of a smooth signal, in one window or sliding along it.

A sensor reading is a smooth signal plus noise, :math:`y_k = s_k + w_k`. Over a short window the signal is close to
a polynomial of low degree :math:`M` (Weierstrass; paper C eq. (13)). A wavelet with :math:`p > M` vanishing
moments has a high-pass (detail) filter :math:`g` with :math:`\sum_j j^q g_j = 0` for :math:`q = 0 \dots p-1`, so
it maps any polynomial of degree below :math:`p` to exactly zero: the finest-scale detail coefficients of
:math:`y` are then the detail coefficients of the noise alone,

.. math::

    d_i = \sum_j g_j\, y_{2i+1-j} = \sum_j g_j\, w_{2i+1-j},

and since the filter is orthonormal (:math:`\sum_j g_j^2 = 1`) white noise of standard deviation :math:`\sigma`
gives coefficients of standard deviation :math:`\sigma`. Their median absolute value, divided by
:math:`\Phi^{-1}(3/4) \approx 0.6745`, estimates :math:`\sigma` robustly: a few coefficients spoiled by a kink of
the signal cannot move the median far (Donoho and Johnstone 1994; paper C eq. (17)):

.. math::

    \hat\sigma = \frac{\operatorname{median}_i |d_i|}{0.6745}.

Paper C takes :math:`M = 5` and the Daubechies wavelet with six vanishing moments, ``db6`` (filter length 12), on a
window of 50 samples that slides along each sensor's record, and uses :math:`\hat\sigma^2` as that sensor's
measurement noise variance :math:`R_k` (eq. (18)).

.. rubric:: Edges of a short window

PyWavelets' ``dwt`` extends the signal beyond its ends (``mode="symmetric"`` and the others), and the extension of a
polynomial is not the same polynomial: the coefficients whose filter straddles an edge do not vanish. On a window
of 50 samples ``db6`` gives 30 coefficients of which 10 straddle an edge, and on a steep trend they pull the median
up. The default ``mode="valid"`` keeps only the coefficients whose filter lies entirely inside the window (20 of
the 30 for ``db6`` on 50 samples; the same numbers as the interior of ``pywt.dwt``), computed here from
PyWavelets' filter bank because PyWavelets has no such mode. Any PyWavelets mode name can still be passed.

References
----------
Donoho, D. L. and Johnstone, I. M. (1994). Ideal spatial adaptation by wavelet shrinkage. *Biometrika* 81(3),
425-455 (the MAD estimate of the noise level, section 4.2).

Li Ting, Zhao Dexin, Huang Zhiping and Su Shaojing (2013), paper C, section 2.3, eqs. (13)-(18).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from ._validate import as_finite, as_float_array, as_index, as_int, check_work

if TYPE_CHECKING:                       # only for the annotations: PyWavelets is imported where it is used
    import pywt

__all__ = [
    "MAD_TO_SIGMA",
    "as_wavelet",
    "mad_sigma",
    "detail_coefficients",
    "detail_matrix",
    "noise_sigma",
    "sliding_noise_sigma",
]

#: :math:`\Phi^{-1}(3/4)`: the median of :math:`|N(0, \sigma^2)|` is this times :math:`\sigma` (paper C: 0.6745).
MAD_TO_SIGMA = 0.6744897501960817


def _pywt() -> Any:
    """PyWavelets, imported where it is used: only paper C's noise estimate needs it, so the rest of the library
    (and ``import uwtutor.widgets``) works without it."""
    try:
        import pywt
    except ImportError as exc:
        raise ImportError("the wavelet noise estimate (paper C) needs PyWavelets: pip install PyWavelets") from exc
    return pywt


def as_wavelet(wavelet: Any) -> pywt.Wavelet:
    """The PyWavelets discrete wavelet named by ``wavelet`` (or ``wavelet`` itself), with a clear error otherwise.

    Parameters
    ----------
    wavelet : str or pywt.Wavelet
        A discrete wavelet of PyWavelets, e.g. ``"db6"`` (paper C), ``"haar"`` or ``"sym4"``.

    Returns
    -------
    pywt.Wavelet
        Its ``dec_len`` is the filter length: the shortest window the wavelet can analyse.

    Examples
    --------
    >>> from uwtutor.wavelet import as_wavelet
    >>> w = as_wavelet("db6")
    >>> w.dec_len, w.vanishing_moments_psi
    (12, 6)
    """
    pywt = _pywt()
    if isinstance(wavelet, pywt.Wavelet):
        return wavelet
    if not isinstance(wavelet, str):
        raise TypeError(f"wavelet must be the name of a discrete wavelet of PyWavelets (a str such as 'db6') or a "
                        f"pywt.Wavelet; got {type(wavelet).__name__}")
    try:
        w = pywt.Wavelet(wavelet)
    except (ValueError, TypeError, AttributeError):       # AttributeError: a list or a number, not a name
        raise ValueError(f"wavelet must be the name of a discrete wavelet of PyWavelets (e.g. 'db6', 'haar', "
                         f"'sym4'; see pywt.wavelist(kind='discrete')); got {wavelet!r}") from None
    return w


def _mode(mode: Any) -> str:
    pywt = _pywt()
    if mode == "valid" or mode in pywt.Modes.modes:
        return mode
    raise ValueError(f"mode must be 'valid' or a PyWavelets signal-extension mode ({', '.join(pywt.Modes.modes)}); "
                     f"got {mode!r}")


def _valid_details(x: np.ndarray, w: pywt.Wavelet) -> np.ndarray:
    """Every finest-scale detail coefficient of ``x`` (..., N) whose filter lies inside the signal, at every shift.

    Entry ``j`` is :math:`\\sum_i g_i x_{L-1+j-i}` (the full convolution at position ``L-1+j``); the DWT of a
    window starting at ``s`` keeps the positions ``m`` with ``m - s`` odd, i.e. every other entry.
    """
    g = np.asarray(w.dec_hi)
    windows = np.lib.stride_tricks.sliding_window_view(x, g.size, axis=-1)   # (..., N - L + 1, L)
    return windows @ g[::-1]


def mad_sigma(coefficients: ArrayLike, axis: int = -1) -> float | np.ndarray:
    r"""The MAD estimate :math:`\hat\sigma = \operatorname{median}_i |d_i| / 0.6745` of detail coefficients.

    The one place of the library where the median absolute detail coefficient becomes a noise level (paper C
    eq. (17); Donoho and Johnstone 1994): :func:`noise_sigma`, :func:`sliding_noise_sigma` and the grey particle
    filter all call it. The median is that of :func:`numpy.median`, from a partial sort (:func:`numpy.partition`).

    Parameters
    ----------
    coefficients : array_like
        Detail coefficients :math:`d_i` (finite), e.g. from :func:`detail_coefficients`.
    axis : int, optional
        The axis of the coefficients (the last by default).

    Returns
    -------
    float or ndarray
        :math:`\hat\sigma` for every slice along ``axis``.

    Examples
    --------
    >>> from uwtutor.wavelet import mad_sigma
    >>> # median |d| = 0.7
    >>> round(float(mad_sigma([0.5, -1.0, 0.2, 2.0, -0.7])), 4)
    1.0378
    """
    d = as_float_array("coefficients", coefficients)
    if d.ndim == 0:
        raise ValueError("coefficients must hold at least one coefficient; got a single number (pass a list)")
    axis = as_index("axis", axis, d.ndim)
    if d.shape[axis] == 0:
        raise ValueError(f"coefficients must hold at least one coefficient along axis {axis}; got shape {d.shape}")
    if not np.isfinite(np.add.reduce(d, axis=None)):
        raise ValueError("coefficients must be finite (no NaN or infinite value)")
    a = np.abs(d) if axis in (-1, d.ndim - 1) else np.moveaxis(np.abs(d), axis, -1)
    n = a.shape[-1]
    half = n // 2
    if n % 2:                                           # numpy.median's own steps, without its overhead
        median = np.partition(a, half, axis=-1)[..., half]
    else:
        middle = np.partition(a, (half - 1, half), axis=-1)[..., half - 1:half + 1]
        median = np.add.reduce(middle, axis=-1) / 2.0
    sigma = median / MAD_TO_SIGMA
    return float(sigma) if np.ndim(sigma) == 0 else sigma


def detail_matrix(n_samples: int, wavelet: Any = "db6") -> np.ndarray:
    r"""The matrix :math:`D` with ``window @ D == detail_coefficients(window, wavelet)`` for windows of ``n_samples``.

    The valid finest-scale DWT is linear in the window, so a filter that analyses a sliding window at every step
    (the grey particle filter, for every sensor of every run) does it with one matrix product.

    Parameters
    ----------
    n_samples : int
        Window length, at least the wavelet's filter length (12 for ``db6``).
    wavelet : str or pywt.Wavelet, optional
        ``"db6"`` by default (paper C).

    Returns
    -------
    ndarray, shape (n_samples, n_coefficients)
        ``n_coefficients = (n_samples - L) // 2 + 1`` for filter length ``L``.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.wavelet import detail_coefficients, detail_matrix
    >>> x = np.random.default_rng(0).normal(size=50)
    >>> D = detail_matrix(50)
    >>> D.shape, bool(np.allclose(x @ D, detail_coefficients(x)))
    ((50, 20), True)
    """
    w = as_wavelet(wavelet)
    n = as_int("n_samples", n_samples, minimum=w.dec_len)
    check_work("n_samples", n * n, "matrix entries")
    return _valid_details(np.eye(n), w)[:, w.dec_len % 2::2]


def detail_coefficients(signal: ArrayLike, wavelet: Any = "db6", mode: str = "valid") -> np.ndarray:
    r"""The finest-scale detail coefficients of a signal (one level of the discrete wavelet transform).

    Parameters
    ----------
    signal : array_like, shape (..., N)
        The signal, time along the last axis (finite).
    wavelet : str or pywt.Wavelet, optional
        A discrete wavelet of PyWavelets; ``"db6"`` (six vanishing moments) by default.
    mode : str, optional
        ``"valid"`` (default): only the coefficients whose filter lies inside the signal, i.e. ``pywt.dwt``'s
        coefficients ``(L-2)//2 ... `` up to the last one that does not reach past the end (filter length ``L``).
        Any other value is a PyWavelets extension mode passed to ``pywt.dwt``.

    Returns
    -------
    ndarray, shape (..., n_coefficients)
        For ``"valid"``: :math:`d_i = \sum_j g_j x_{2i+1-j}` for every odd ``2i+1`` from ``L-1`` to ``N-1``
        (``L`` even), i.e. ``(N - L) // 2 + 1`` coefficients.

    Examples
    --------
    A polynomial of degree 5 has no detail at all for ``db6``:

    >>> import numpy as np
    >>> from uwtutor.wavelet import detail_coefficients
    >>> t = np.linspace(-1.0, 1.0, 50)
    >>> d = detail_coefficients(3 - t + 2 * t**2 - t**3 + 0.5 * t**4 + t**5)
    >>> d.shape, bool(np.abs(d).max() < 1e-12)
    ((20,), True)
    """
    w = as_wavelet(wavelet)
    mode = _mode(mode)
    x = as_finite("signal", signal)
    if x.ndim == 0 or x.shape[-1] < w.dec_len:
        raise ValueError(f"signal must hold at least {w.dec_len} samples along its last axis for {w.name} "
                         f"(its filter length); got shape {x.shape}")
    if mode != "valid":
        return np.asarray(_pywt().dwt(x, w, mode=mode, axis=-1)[1])
    # pywt.dwt keeps the odd positions 2i+1 of the full convolution; the valid ones start at L - 1.
    start = w.dec_len % 2                    # 0 when L - 1 is odd (every Daubechies wavelet)
    return _valid_details(x, w)[..., start::2]


def noise_sigma(signal: ArrayLike, wavelet: Any = "db6", mode: str = "valid") -> float | np.ndarray:
    r"""MAD estimate of the standard deviation of white noise on a locally smooth signal.

    .. math::

        \hat\sigma = \operatorname{median}_i |d_i| \,/\, 0.6745

    over the finest-scale detail coefficients :math:`d_i` (:func:`detail_coefficients`). Exact in the mean for
    Gaussian noise on a polynomial of degree below the wavelet's number of vanishing moments (degree <= 5 for
    ``db6``); a kink or a step of the signal spoils the few coefficients around it, which the median ignores.

    Parameters
    ----------
    signal : array_like, shape (..., N)
        The signal, time along the last axis; at least as long as the wavelet filter (12 for ``db6``), and in
        practice a few times longer: the estimate's relative standard error is about
        :math:`1.17 / \sqrt{n_\mathrm{coefficients}}`.
    wavelet : str or pywt.Wavelet, optional
        ``"db6"`` by default (paper C).
    mode : str, optional
        ``"valid"`` (default) or a PyWavelets extension mode (see :func:`detail_coefficients`).

    Returns
    -------
    float or ndarray of shape (...)
        The estimate for each signal.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.wavelet import noise_sigma
    >>> rng = np.random.default_rng(0)
    >>> t = np.arange(2000) * 0.05
    >>> depth = 10 + 0.8 * t - 0.01 * t**2 + rng.normal(0.0, 0.2, t.size)
    >>> round(float(noise_sigma(depth)), 2)
    0.2
    """
    return mad_sigma(detail_coefficients(signal, wavelet, mode))


def sliding_noise_sigma(signal: ArrayLike, window: int = 50, wavelet: Any = "db6", mode: str = "valid") -> np.ndarray:
    r"""The MAD noise estimate of :func:`noise_sigma` in a window that slides along the signal (paper C, 2.3).

    ``out[..., k]`` is ``noise_sigma(signal[..., k - window + 1 : k + 1])``: the window *ends* at sample ``k``, so
    the estimate uses no future sample (it lags a change of the noise level by up to ``window`` samples). The
    first ``window - 1`` entries, and every entry whose window holds a NaN (a missing sample), are NaN.

    Parameters
    ----------
    signal : array_like, shape (..., K)
        The signal, time along the last axis; NaN marks a missing sample.
    window : int, optional
        Window length (50 in paper C); at least the wavelet's filter length.
    wavelet : str or pywt.Wavelet, optional
        ``"db6"`` by default.
    mode : str, optional
        ``"valid"`` (default) or a PyWavelets extension mode.

    Returns
    -------
    ndarray, shape (..., K)

    Examples
    --------
    The noise doubles half-way; the estimate follows, one window late:

    >>> import numpy as np
    >>> from uwtutor.wavelet import sliding_noise_sigma
    >>> rng = np.random.default_rng(1)
    >>> k = np.arange(4000)
    >>> sd = np.where(k < 2000, 0.1, 0.2)
    >>> s = sliding_noise_sigma(np.sin(k / 50) + rng.normal(0.0, sd), window=50)
    >>> bool(np.isnan(s[:49]).all()), round(float(np.mean(s[49:2000])), 2), round(
    ...     float(np.mean(s[2049:])), 2
    ... )
    (True, 0.1, 0.2)
    """
    w = as_wavelet(wavelet)
    mode = _mode(mode)
    x = as_float_array("signal", signal)
    if x.ndim == 0:
        raise ValueError("signal must be an array with time along its last axis; got a scalar")
    if x.shape[-1] == 0:
        raise ValueError(f"signal must hold at least one sample along its last axis; got shape {x.shape}")
    if np.isinf(x).any():
        raise ValueError("signal must be finite, or NaN for a missing sample; got an infinite value")
    n = as_int("window", window, minimum=w.dec_len)
    K = x.shape[-1]
    out = np.full(x.shape, np.nan)
    if K < n:
        return out
    missing = np.isnan(x)
    filled = np.where(missing, 0.0, x)
    if mode == "valid":
        details = _valid_details(filled, w)                       # (..., K - L + 1): position m = L - 1 + j
        # the window [s, s + n) keeps the positions m with m - s odd: entries j = s, s + 2, ... when L is even
        per_window = np.lib.stride_tricks.sliding_window_view(details, n - w.dec_len + 1,
                                                              axis=-1)[..., w.dec_len % 2::2]
    else:
        windows = np.lib.stride_tricks.sliding_window_view(filled, n, axis=-1)
        per_window = np.asarray(_pywt().dwt(windows, w, mode=mode, axis=-1)[1])
    sigma = np.asarray(mad_sigma(per_window))                                 # (..., K - n + 1)
    if missing.any():
        counts = np.lib.stride_tricks.sliding_window_view(missing, n, axis=-1).any(axis=-1)
        sigma[counts] = np.nan
    out[..., n - 1:] = sigma
    return out
