r"""Cramér–Rao bounds from an information matrix: of a static fix, along a track, and the figures made of them.

:math:`\operatorname{Cov}(\hat x) \succeq J^{-1}`, infinite along the directions that :math:`J` leaves
unobserved (with an ``UnobservableWarning`` that names them); RMSE bound, GDOP, paper A's precision factor.
"""

from __future__ import annotations


import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validate import (
    PSD_RTOL,
    SYMMETRY_RTOL,
    as_flag,
    as_float_array,
    as_information,
    as_points,
)
from ..errors import IllConditionedError
from ._common import DEFAULT_RTOL, _as_rtol, _bound_batch, _state_labels, _warn, _warn_singular
from .information import fisher_information, track_fisher_information
from .jacobians import range_jacobian

__all__ = ["cramer_rao_bound", "position_crlb", "rmse_bound", "gdop", "precision_factor", "track_crlb"]


def cramer_rao_bound(information: ArrayLike, *, rtol: float = DEFAULT_RTOL) -> NDArray[np.float64]:
    r"""The Cramér–Rao lower bound :math:`J^{-1}` of an information matrix, infinite where :math:`J` is singular.

    Any unbiased estimator satisfies :math:`\operatorname{Cov}(\hat x) \succeq J^{-1}`. When :math:`J` is singular
    (an unobservable direction :math:`v`, :math:`Jv = 0`), no unbiased estimator of a quantity that moves along
    :math:`v` exists and its bound is infinite; the quantities orthogonal to every such :math:`v` keep the finite
    bound of the Moore–Penrose inverse (Stoica and Marzetta, 2001). This function returns the entrywise limit

    .. math::

        \lim_{\epsilon \to 0^+} (J + \epsilon I)^{-1} = J^{+} + \lim \tfrac{1}{\epsilon} P_\mathcal{N},

    i.e. :math:`J^+` where the projector :math:`P_\mathcal{N}` on the null space vanishes and :math:`\pm\infty`
    where it does not, with an ``UnobservableWarning`` naming the unobservable directions.

    Singularity is judged on the diagonally scaled matrix :math:`D^{-1} J D^{-1}`, :math:`D = \operatorname{diag}
    (\sqrt{J_{ii}})`, so the result does not depend on units (metres against metres per second): an eigenvalue
    below ``rtol**2`` times the largest counts as zero.

    Parameters
    ----------
    information : array_like, shape (..., n, n)
        Symmetric positive semi-definite information matrices.
    rtol : float, default ``DEFAULT_RTOL``
        Relative tolerance on the square roots of the scaled eigenvalues.

    Returns
    -------
    ndarray, shape (..., n, n)
        The bounds (covariances).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.observability import cramer_rao_bound
    >>> cramer_rao_bound(np.diag([4.0, 0.25]))
    array([[0.25, 0.  ],
           [0.  , 4.  ]])
    """
    J = as_information("information", information)     # finite, square, symmetric, PSD (indefinite: refused)
    rtol = _as_rtol(rtol)
    bounds, _, singular = _bound_batch(J, rtol)
    n = J.shape[-1]
    _warn_singular(singular, int(np.prod(J.shape[:-2], dtype=int)), n, _state_labels(n))
    return bounds


def position_crlb(beacons: ArrayLike, position: ArrayLike, sigma: ArrayLike, unknown_bias: bool = False, *,
                  rtol: float = DEFAULT_RTOL) -> NDArray[np.float64]:
    r"""Cramér–Rao lower bound of a static position (and bias) ranged from the given beacons.

    The inverse of ``fisher_information``: :math:`C = J^{-1}`, a 2×2 covariance bound (3×3 with the bias, order
    ``[x, y, bias]``). Its trace gives the bound on the mean squared position error,
    :math:`\operatorname{E}\|\hat p - p\|^2 \ge C_{xx} + C_{yy}`, so :math:`\sqrt{C_{xx} + C_{yy}}` bounds the RMSE
    (``rmse_bound``). Two closed forms to check it against (equal :math:`\sigma`):

    * :math:`N \ge 3` beacons evenly spaced in bearing: :math:`C = \frac{2\sigma^2}{N} I`, RMSE bound
      :math:`2\sigma/\sqrt N`, with or without the bias;
    * two beacons whose bearings differ by :math:`\Delta`: :math:`\operatorname{tr} J = 2/\sigma^2`,
      :math:`\det J = \sin^2\!\Delta / \sigma^4`, RMSE bound :math:`\sqrt{2}\,\sigma / |\sin\Delta|`
      (:math:`\sqrt{8/3}\,\sigma = 1.6330\,\sigma` at 60°).

    Degenerate geometry (one beacon; all beacons on one line through the vehicle; two beacons with an unknown
    bias) gives a singular :math:`J`: the bound is returned with an ``UnobservableWarning``, infinite along the
    unobservable directions and finite for what can still be estimated (see ``cramer_rao_bound``).

    Parameters
    ----------
    beacons : array_like, shape (N, 2) or (..., N, 2)
        Beacon positions [m], real or virtual.
    position : array_like, shape (2,) or (..., 2)
        The vehicle position [m].
    sigma : float or array_like, shape (N,) or (..., N)
        Range noise standard deviation(s) [m], > 0.
    unknown_bias : bool, default False
        Estimate a constant range bias as well (paper A).
    rtol : float, default ``DEFAULT_RTOL``
        Tolerance of the singularity test (see ``cramer_rao_bound``).

    Returns
    -------
    ndarray, shape (..., 2, 2) or (..., 3, 3)
        The covariance bound [m²].

    Examples
    --------
    >>> from uwtutor.observability import beacons_at_bearings
    >>> b = beacons_at_bearings([0.0, 0.0], np.radians([0.0, 60.0]))
    >>> float(rmse_bound(position_crlb(b, [0.0, 0.0], sigma=1.0)))  # doctest: +ELLIPSIS
    1.6329931...
    """
    unknown_bias = as_flag("unknown_bias", unknown_bias)
    J = fisher_information(beacons, position, sigma, unknown_bias)
    bounds, _, singular = _bound_batch(J, _as_rtol(rtol))
    _refuse_negative_bounds(bounds)
    n = J.shape[-1]
    _warn_singular(singular, int(np.prod(J.shape[:-2], dtype=int)), n,
                   _state_labels(n, unknown_bias=bool(unknown_bias)))
    return bounds


def _refuse_negative_bounds(bounds: np.ndarray) -> None:
    """A bound is a covariance: a negative variance means float64 could not carry the computation."""
    diag = np.diagonal(bounds, axis1=-2, axis2=-1)
    if (diag < 0).any() or np.isnan(diag).any():
        raise IllConditionedError("the information matrix is too ill-conditioned for float64 (its inverse has "
                                  "negative or NaN variances): rescale sigma or the positions (e.g. kilometres)")


def rmse_bound(covariance: ArrayLike) -> float | np.ndarray:
    r"""The bound on the RMS position error: :math:`\sqrt{C_{xx} + C_{yy}}` of a bound :math:`C` (position first).

    Parameters
    ----------
    covariance : array_like, shape (..., n, n), n >= 2
        Covariance bounds whose first two states are ``x`` and ``y`` (e.g. from ``position_crlb``).

    Returns
    -------
    float or ndarray, shape (...)
        The RMSE bound [m]; infinite where either position variance is.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.observability import rmse_bound
    >>> # the position block of a [x, y, bias] covariance: sqrt(4 + 9)
    >>> round(rmse_bound(np.diag([4.0, 9.0, 0.5])), 4)
    3.6056
    >>> rmse_bound(np.array([np.eye(2), 4.0 * np.eye(2)])).round(4)
    array([1.4142, 2.8284])
    """
    C = as_float_array("covariance", covariance)
    if C.ndim < 2 or C.shape[-1] != C.shape[-2] or C.shape[-1] < 2:
        raise ValueError(f"covariance must be square with at least 2 states, shape (..., n, n); got {C.shape}")
    cxx, cxy, cyx, cyy = C[..., 0, 0], C[..., 0, 1], C[..., 1, 0], C[..., 1, 1]
    if np.isnan(cxx).any() or np.isnan(cyy).any():
        raise ValueError("covariance has NaN position variances")
    if (cxx < 0).any() or (cyy < 0).any():
        raise ValueError("covariance must be a covariance: its position variances must be >= 0 (an infinite "
                         "bound is +inf); got a negative one")
    finite = np.isfinite(cxx) & np.isfinite(cyy) & np.isfinite(cxy) & np.isfinite(cyx)
    with np.errstate(invalid="ignore"):
        scale = np.maximum(1.0, np.maximum(np.abs(cxx), np.abs(cyy)))
        asym = np.abs(cxy - cyx) > SYMMETRY_RTOL * scale
        indefinite = cxy * cyx > cxx * cyy * (1.0 + 1e-9) + PSD_RTOL * scale
    if (finite & asym).any():
        raise ValueError("covariance must be symmetric; use (C + C.T) / 2 if it is only off by rounding")
    if (finite & indefinite).any():
        raise ValueError("covariance must be positive semi-definite: its position block has a correlation beyond "
                         "+-1 (Cxy^2 > Cxx Cyy)")
    out = np.sqrt(cxx + cyy)
    return float(out) if out.ndim == 0 else out


def gdop(beacons: ArrayLike, position: ArrayLike, unknown_bias: bool = False, *,
         rtol: float = DEFAULT_RTOL) -> float | np.ndarray:
    r"""Geometric dilution of precision: :math:`\sqrt{\operatorname{tr}\,(H^\mathsf{T} H)^{-1}}`.

    The factor by which the geometry magnifies a unit range error: with equal, independent range errors
    :math:`\sigma`, the CRLB is :math:`\sigma^2 (H^\mathsf{T}H)^{-1}`, so without a bias the RMSE bound is
    :math:`\mathrm{GDOP}\cdot\sigma`. With ``unknown_bias`` the trace runs over all three unknowns (like the
    clock term of satellite navigation's GDOP), and its square is paper A's precision factor.

    Parameters
    ----------
    beacons : array_like, shape (N, 2) or (..., N, 2)
        Beacon positions [m].
    position : array_like, shape (2,) or (..., 2)
        Vehicle position [m].
    unknown_bias : bool, default False
        Include the bias column of ones in :math:`H`.
    rtol : float, default ``DEFAULT_RTOL``
        Tolerance of the singularity test; degenerate geometry gives ``inf`` with an ``UnobservableWarning``.

    Returns
    -------
    float or ndarray, shape (...)
        The GDOP (dimensionless).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.observability import gdop
    >>> beacons = np.array([[1000.0, 0.0], [0.0, 1000.0], [-1000.0, 0.0], [0.0, -1000.0]])
    >>> round(gdop(beacons, [0.0, 0.0]),
    ...       3), round(gdop(beacons, [0.0, 0.0], unknown_bias=True), 3)
    (1.0, 1.118)
    """
    unknown_bias = as_flag("unknown_bias", unknown_bias)
    J = fisher_information(beacons, position, 1.0, unknown_bias)
    bounds, _, singular = _bound_batch(J, _as_rtol(rtol))
    n = J.shape[-1]
    _warn_singular(singular, int(np.prod(J.shape[:-2], dtype=int)), n,
                   _state_labels(n, unknown_bias=bool(unknown_bias)))
    out = np.sqrt(np.trace(bounds, axis1=-2, axis2=-1))
    return float(out) if out.ndim == 0 else out


def precision_factor(beacons: ArrayLike, position: ArrayLike, unknown_bias: bool = True) -> float | np.ndarray:
    r"""Paper A's precision factor :math:`\alpha = \operatorname{tr}\,(X^\mathsf{T} X)^{-1} = \sum_i 1/\lambda_i`
    of a geometry: beacons (or a track's virtual beacons) and a vehicle position.

    Liu et al. (paper A) linearize the ranges about a provisional position and regress the range residuals on
    the rows :math:`X_i = [h_i, 1]` (line of sight and bias); the LS error covariance is
    :math:`\sigma^2 (X^\mathsf{T}X)^{-1}`, which is exactly the CRLB of position and bias for white range noise.
    So :math:`\alpha\sigma^2 = \operatorname{tr}(\mathrm{CRLB})`: the bound on the summed mean squared errors of
    :math:`x`, :math:`y` and the bias, and :math:`\alpha = \mathrm{GDOP}^2` with the bias. Paper A trusts the fix
    (and starts its filter) once :math:`\alpha < 2`. With ``unknown_bias=False`` it is the position-only GDOP
    squared.

    This function builds the rows :math:`X_i` from the geometry and hands them to
    :func:`uwtutor.lsq.precision_factor`, the library's one computation of :math:`\alpha` (and its one rule for a
    singular geometry).

    Parameters
    ----------
    beacons : array_like, shape (N, 2) or (..., N, 2)
        Beacon positions [m]: for a track, its virtual beacons.
    position : array_like, shape (2,) or (..., 2)
        Vehicle position [m].
    unknown_bias : bool, default True
        Include the bias column (paper A's regressor).

    Returns
    -------
    float or ndarray, shape (...)
        :math:`\alpha` (dimensionless); ``inf`` where the geometry is degenerate, with an ``UnobservableWarning``.

    Examples
    --------
    Four beacons at right angles, with the bias: :math:`X^\mathsf T X = \operatorname{diag}(2, 2, 4)`.

    >>> import numpy as np
    >>> from uwtutor.observability import precision_factor
    >>> beacons = np.array(
    ...     [[100.0, 0.0], [0.0, 100.0], [-100.0, 0.0], [0.0, -100.0]]
    ... )
    >>> round(precision_factor(beacons, [0.0, 0.0]), 12)
    1.25
    """
    unknown_bias = as_flag("unknown_bias", unknown_bias)
    from .. import lsq  # a sibling of the same layer; imported here to keep the import graph one-way

    b = as_points("beacons", beacons, min_ndim=2, nonempty=True)
    p = as_points("position", position)
    h = range_jacobian(p[..., None, :], b)
    X = np.concatenate([h, np.ones(h.shape[:-1] + (1,))], axis=-1) if unknown_bias else h
    alpha = np.asarray(lsq.precision_factor(X), dtype=float)
    degenerate = ~np.isfinite(alpha)
    if degenerate.any():
        what = "position and bias" if unknown_bias else "the position"
        where = "" if alpha.ndim == 0 else f" at {int(degenerate.sum())} of {alpha.size} geometries"
        _warn(f"the ranges leave {what} unobservable{where}: the precision factor is infinite. "
              "observability.position_crlb names the unobservable direction(s)")
    return float(alpha) if alpha.ndim == 0 else alpha


def track_crlb(positions: ArrayLike, beacon: ArrayLike, sigma: ArrayLike, *, times: ArrayLike | None = None,
               unknown_bias: bool = False,
               unknown_current: bool = False, rtol: float = DEFAULT_RTOL) -> NDArray[np.float64]:
    r"""The CRLB of the state at every epoch of a track, from the ranges up to that epoch.

    The inverse (``cramer_rao_bound``) of ``track_fisher_information(..., cumulative=True)``: entry ``k`` bounds
    the covariance of any unbiased estimate of the current position (and bias, current) from ranges
    :math:`1, \dots, k` with perfect dead reckoning. Epochs where the state is not yet observable (the first, or
    a whole straight track with an unknown current) have infinite entries; the ``UnobservableWarning`` is emitted
    once, for the first such epoch.

    Parameters
    ----------
    positions : array_like, shape (K, 2)
        True positions over ground [m].
    beacon : array_like, shape (2,) or (K, 2)
        Beacon position(s) [m].
    sigma : float or array_like, shape (K,)
        Range noise standard deviation(s) [m].
    times : array_like, shape (K,), optional
        Epoch times [s]; required with ``unknown_current``.
    unknown_bias, unknown_current : bool, default False
        The extra unknowns.
    rtol : float, default ``DEFAULT_RTOL``
        Tolerance of the singularity test.

    Returns
    -------
    ndarray, shape (K, n, n)
        Covariance bounds, state order ``[x, y, bias, Ux, Uy]`` (the blocks asked for).

    Examples
    --------
    The bound along a quarter circle about the beacon: infinite after one range, then shrinking.

    >>> import numpy as np
    >>> from uwtutor.observability import rmse_bound, track_crlb
    >>> theta = np.linspace(0.0, np.pi / 2, 5)
    >>> arc = 100.0 * np.column_stack([np.cos(theta), np.sin(theta)])
    >>> import warnings
    >>> with warnings.catch_warnings():
    ...     warnings.simplefilter("ignore")
    ...     bound = track_crlb(arc, (0.0, 0.0), sigma=1.0)
    >>> bound.shape, rmse_bound(bound).round(3)
    ((5, 2, 2), array([  inf, 3.696, 1.945, 1.321, 1.021]))
    """
    unknown_bias = as_flag("unknown_bias", unknown_bias)
    unknown_current = as_flag("unknown_current", unknown_current)
    J = track_fisher_information(positions, beacon, sigma, times=times, unknown_bias=unknown_bias,
                                 unknown_current=unknown_current, cumulative=True)
    bounds, _, singular = _bound_batch(J, _as_rtol(rtol))
    n = J.shape[-1]
    _warn_singular(singular, len(J), n, _state_labels(n, bool(unknown_bias), bool(unknown_current)))
    return bounds
