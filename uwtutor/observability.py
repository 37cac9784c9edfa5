r"""Range-only observability and the limits of accuracy: Jacobians, Fisher information, the Cramér–Rao bound.

A range to a beacon at :math:`b` is :math:`r = \|p - b\| + \eta`, :math:`\eta \sim N(0, \sigma^2)`. Everything in this
module follows from its Jacobian, the unit line-of-sight vector

.. math::

    h(p) = \frac{\partial r}{\partial p} = \frac{(p - b)^\mathsf{T}}{\|p - b\|},

stacked over beacons (real ones, or the *virtual* beacons :math:`b - d_k` that dead reckoning makes of one beacon
pinged from several points of a track) and over the extra unknowns a chapter adds to the state: a constant range
bias :math:`\upsilon` (Liu et al., paper A: one more column of ones) or a constant current :math:`U` (paper B: a
column block :math:`(t_k - t_\mathrm{ref})\,h_k`). With the stacked Jacobian :math:`H` and independent range errors
of standard deviations :math:`\sigma_k`,

.. math::

    J = H^\mathsf{T} R^{-1} H = \sum_k \frac{h_k^\mathsf{T} h_k}{\sigma_k^2}, \qquad
    \operatorname{Cov}(\hat x) \succeq J^{-1} \quad\text{(the Cramér–Rao lower bound, CRLB)},

and :math:`J` is also the (linearized) observability Gramian of the range measurements: the state is locally
observable exactly when :math:`J` has full rank.

=====================================  ==============================================================================
``range_jacobian``                     unit line-of-sight vectors :math:`\partial r / \partial p`
``squared_range_jacobian``             :math:`\partial r^2 / \partial p = 2 (p - b)` (paper B measures :math:`r^2`)
``beacons_at_bearings``                beacons placed at given bearings and distances from a position
``virtual_beacons``                    :math:`b_k - (p_k - p_\mathrm{ref})`: one beacon seen from a whole track
``fisher_information``                 :math:`J` of a static position (and bias) ranged from several beacons
``position_crlb``                      the CRLB :math:`J^{-1}` of that position (and bias)
``cramer_rao_bound``                   :math:`J^{-1}` of any information matrix, infinite where :math:`J` is singular
``rmse_bound``                         :math:`\sqrt{\operatorname{tr}}` of the position block of a bound
``gdop``                               GDOP, :math:`\sqrt{\operatorname{tr}(H^\mathsf{T}H)^{-1}}`
``precision_factor``                   paper A's :math:`\alpha = \operatorname{tr}(X^\mathsf{T}X)^{-1}`
``track_jacobian``                     the stacked Jacobian of the ranges along a track (position, bias, current)
``track_fisher_information``           its information matrix, for the whole track or epoch by epoch
``track_crlb``                         the bound on the position at each epoch from the ranges so far
``observability_rank``                 the numerical rank of the information along a track, epoch by epoch
``numerical_rank``                     the rank of any matrix with a relative tolerance (columns scaled first)
``two_range_fix``                      the two mirror solutions of two ranges and one displacement
``mirror_point``                       the reflection of a point across a line through the beacon
``error_ellipse``                      points of a covariance ellipse, for plots
``posterior_crlb``                     the posterior bound of a filter with process noise (and bias, current)
``model_posterior_crlb``               the posterior bound of any motion/measurement model pair on a true track
=====================================  ==============================================================================

Degenerate geometry is a normal case, never a crash and never a silent finite number: a singular information
matrix gives a bound that is infinite along its unobservable directions, with an ``UnobservableWarning`` that names
them (silence it with ``warnings.catch_warnings`` when the degeneracy is expected).

References
----------
Y. Bar-Shalom, X. R. Li and T. Kirubarajan, *Estimation with Applications to Tracking and Navigation*, Wiley, 2001
(Fisher information and the CRLB for nonlinear measurements).
T. L. Song, "Observability of target tracking with range-only measurements", IEEE J. Oceanic Eng. 24(3), 1999.
A. S. Gadre and D. J. Stilwell, "A complete solution to underwater navigation in the presence of unknown currents
based on range measurements from a single location", IROS 2005.
G. Indiveri, D. De Palma and G. Parlangeli, "Single range localization in 3-D: observability and robustness issues",
IEEE Trans. Control Syst. Technol. 24(5), 2016.
P. Stoica and T. L. Marzetta, "Parameter estimation problems with singular information matrices", IEEE Trans.
Signal Process. 49(1), 2001 (the bound of the estimable parameters when the information is singular).
P. Tichavský, C. H. Muravchik and A. Nehorai, "Posterior Cramér–Rao bounds for discrete-time nonlinear filtering",
IEEE Trans. Signal Process. 46(5), 1998 (the posterior bound of a filter with process noise).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ._linalg import line_of_sight as _line_of_sight
from ._validate import (MAX_COORDINATE, PSD_RTOL, SYMMETRY_RTOL, as_covariance, as_finite, as_flag, as_float_array,
                        as_in_range, as_information, as_int, as_points, as_positive, as_scalar, common_runs)
from .errors import IllConditionedError, UnobservableWarning, warn
from .models.base import MeasurementModel, MotionModel

__all__ = [
    "DEFAULT_RTOL",
    "UnobservableWarning",
    "range_jacobian",
    "squared_range_jacobian",
    "beacons_at_bearings",
    "virtual_beacons",
    "fisher_information",
    "position_crlb",
    "cramer_rao_bound",
    "rmse_bound",
    "gdop",
    "precision_factor",
    "track_jacobian",
    "track_fisher_information",
    "track_crlb",
    "observability_rank",
    "numerical_rank",
    "two_range_fix",
    "mirror_point",
    "error_ellipse",
    "posterior_crlb",
    "model_posterior_crlb",
]

#: Relative tolerance on the singular values of a column-scaled Jacobian (on the square roots of the eigenvalues of
#: a diagonally scaled information matrix) below which a direction counts as unobservable, because its standard
#: deviation would be amplified more than a million times. Exact degeneracies give about 1e-8 here or less, so the
#: default separates them cleanly from poor but genuine geometry.
DEFAULT_RTOL = 1e-6

# Entries of the projector on the unobservable subspace below this count as zero (rounding).
_NULL_ENTRY_TOL = 1e-8




def _warn(message: str) -> None:
    """Emit an ``UnobservableWarning`` attributed to the first caller outside this module (the user's line)."""
    warn(message, UnobservableWarning)


# ---------------------------------------------------------------------------------------------------------------------
# validation helpers
# ---------------------------------------------------------------------------------------------------------------------
def _as_rtol(rtol: Any) -> float:
    r = as_scalar("rtol", rtol, domain="positive")
    if r >= 1:
        raise ValueError(f"rtol must be < 1 (a relative tolerance such as 1e-6); got {r}")
    return r


def _broadcast(name_a: str, a: np.ndarray, name_b: str, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    try:
        return np.broadcast_arrays(a, b)
    except ValueError:
        raise ValueError(f"{name_a} of shape {a.shape} does not broadcast against {name_b} of shape "
                         f"{b.shape}") from None


def _describe_direction(v: np.ndarray, labels: list[str]) -> str:
    v = v / np.max(np.abs(v))
    parts = [f"{c:+.2f} {lab}" for c, lab in zip(v, labels) if abs(c) > 5e-3]
    return "[" + ", ".join(parts) + "]"


def _state_labels(n: int, unknown_bias: bool = False, unknown_current: bool = False) -> list[str]:
    labels = ["x", "y"]
    if unknown_bias:
        labels.append("bias")
    if unknown_current:
        labels += ["Ux", "Uy"]
    if len(labels) != n:
        labels = [f"x{i}" for i in range(n)]
    return labels


# ---------------------------------------------------------------------------------------------------------------------
# Jacobians and geometry
# ---------------------------------------------------------------------------------------------------------------------
def range_jacobian(position: Any, beacons: Any) -> np.ndarray:
    r"""Jacobian of the horizontal range with respect to the vehicle position: the unit line-of-sight vector.

    .. math::

        \frac{\partial r_i}{\partial p} = \frac{(p - b_i)^\mathsf{T}}{\|p - b_i\|}
        = [\cos\varphi_i, \sin\varphi_i],

    :math:`\varphi_i` being the bearing of the vehicle seen from beacon :math:`i` (the row points from the beacon
    to the vehicle; its sign never matters in :math:`J = \sum h_i^\mathsf{T} h_i`).

    Parameters
    ----------
    position : array_like, shape (..., 2)
        Vehicle position(s) ``[x, y]`` [m].
    beacons : array_like, shape (..., 2)
        Beacon position(s) [m], broadcast against ``position`` (e.g. ``position`` of shape ``(2,)`` and ``beacons``
        of shape ``(N, 2)`` give ``N`` rows).

    Returns
    -------
    ndarray, shape (..., 2)
        The unit vectors, one per broadcast pair. Where the vehicle sits on a beacon the range is not
        differentiable: that row is zero (no information) and an ``UnobservableWarning`` says so.

    Examples
    --------
    >>> # + 0.0 turns -0.0 into 0.0
    >>> range_jacobian([0.0, 0.0], [[100.0, 0.0], [0.0, -50.0]]) + 0.0
    array([[-1.,  0.],
           [ 0.,  1.]])
    """
    p = as_points("position", position)
    b = as_points("beacons", beacons, nonempty=True)
    p, b = _broadcast("position", p, "beacons", b)
    _, los, defined = _line_of_sight(p, b)
    if not defined.all():
        _warn(f"the position coincides with a beacon at {int((~defined).sum())} place(s): the range is not "
              "differentiable there, so that range is given no information (a zero Jacobian row)")
    return los


def squared_range_jacobian(position: Any, beacons: Any) -> np.ndarray:
    r"""Jacobian of the squared horizontal range with respect to the vehicle position.

    .. math::

        \frac{\partial r_i^2}{\partial p} = 2\,(p - b_i)^\mathsf{T} = 2\,r_i\,\frac{\partial r_i}{\partial p}.

    Each row is the range Jacobian times :math:`2 r_i`, so the stacked Jacobians of ranges and of squared ranges
    have the same rank: measuring :math:`r^2` (paper B's cooperative filter, Indiveri and Parlangeli's observers)
    changes the noise model, not observability.

    Parameters
    ----------
    position : array_like, shape (..., 2)
        Vehicle position(s) [m].
    beacons : array_like, shape (..., 2)
        Beacon position(s) [m], broadcast against ``position``.

    Returns
    -------
    ndarray, shape (..., 2)
        :math:`2 (p - b_i)` [m].

    Examples
    --------
    >>> from uwtutor.observability import squared_range_jacobian
    >>> squared_range_jacobian([3.0, 4.0], [[1000.0, 0.0], [0.0, 1000.0]])
    array([[-1994.,     8.],
           [    6., -1992.]])
    """
    p = as_points("position", position)
    b = as_points("beacons", beacons, nonempty=True)
    p, b = _broadcast("position", p, "beacons", b)
    return 2.0 * (p - b)


def beacons_at_bearings(position: Any, bearings: Any, distances: Any = 1000.0) -> np.ndarray:
    r"""Beacons placed at given bearings and distances from a position: :math:`b_i = p + \rho_i [\cos\beta_i,
    \sin\beta_i]`.

    Parameters
    ----------
    position : array_like, shape (2,)
        The vehicle position [m].
    bearings : array_like, shape (N,)
        Bearing of each beacon seen from ``position`` [rad], counter-clockwise from +x (east).
    distances : float or array_like, shape (N,), default 1000
        Distance of each beacon [m], > 0.

    Returns
    -------
    ndarray, shape (N, 2)
        Beacon positions [m].

    Examples
    --------
    >>> beacons_at_bearings([0.0, 0.0], [0.0, np.pi / 2], 100.0).round(6)
    array([[100.,   0.],
           [  0., 100.]])
    """
    p = as_points("position", position)
    if p.shape != (2,):
        raise ValueError(f"position must have shape (2,); got {p.shape}")
    beta = as_finite("bearings", bearings, ndim=1, nonempty=True)
    rho = as_positive("distances", distances, max_abs=MAX_COORDINATE)
    if rho.ndim > 1 or (rho.ndim == 1 and rho.shape != beta.shape):
        raise ValueError(f"distances must be a number or have one entry per bearing ({beta.size}); got shape "
                         f"{rho.shape}")
    return p + np.asarray(rho)[..., None] * np.stack([np.cos(beta), np.sin(beta)], axis=-1)


def virtual_beacons(beacon: Any, positions: Any, reference: int = -1) -> np.ndarray:
    r"""The virtual beacons of a track: one beacon pinged from several epochs, seen from the reference epoch.

    If the vehicle is at :math:`p_k` at epoch :math:`k` and at :math:`p` at the reference epoch, write
    :math:`d_k = p_k - p` (known from dead reckoning). Then

    .. math::

        r_k = \|p_k - b_k\| = \|p - (b_k - d_k)\|,

    so the range of epoch :math:`k` is a range from the *reference* position to the virtual beacon
    :math:`b_k - d_k`: the beacon moved by the distance the vehicle has travelled since (Larsen's synthetic long
    baseline; paper E's virtual beacons, :math:`VB_i = AB_i + \sum v_n \delta t`).

    Parameters
    ----------
    beacon : array_like, shape (2,) or (K, 2)
        Beacon position [m], fixed or one per epoch (a moving beacon such as paper E's mother ship).
    positions : array_like, shape (K, 2)
        Vehicle positions at the epochs [m]; only their differences matter, so dead-reckoned positions do.
    reference : int, default -1
        Index of the epoch whose position the virtual beacons refer to (default: the last, "now").

    Returns
    -------
    ndarray, shape (K, 2)
        Virtual beacon positions [m]; the one of the reference epoch is the beacon itself.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.observability import virtual_beacons
    >>> # a vehicle moving east 10 m per epoch: the beacon seen from its last position
    >>> virtual_beacons((0.0, 0.0), np.array([[0.0, 100.0], [10.0, 100.0], [20.0, 100.0]]))
    array([[20.,  0.],
           [10.,  0.],
           [ 0.,  0.]])
    """
    p = as_points("positions", positions, min_ndim=2)
    if p.ndim != 2:
        raise ValueError(f"positions must have shape (K, 2); got {p.shape}")
    b = as_points("beacon", beacon)
    if b.shape not in ((2,), p.shape):
        raise ValueError(f"beacon must have shape (2,) or {p.shape} (one position per epoch); got {b.shape}")
    k = len(p)
    if k == 0:
        raise ValueError("positions must hold at least one epoch, shape (K, 2) with K >= 1; got shape (0, 2)")
    return b - (p - p[_as_reference(reference, k)])


# ---------------------------------------------------------------------------------------------------------------------
# Fisher information and the Cramér-Rao bound
# ---------------------------------------------------------------------------------------------------------------------
def _sigma_per_row(sigma: Any, shape: tuple[int, ...]) -> np.ndarray:
    # 1 / sigma^2 must stay a float64 (1e-300 .. 1e300) for the information to mean anything
    s = as_in_range("sigma", as_positive("sigma", sigma), 1e-150, 1e150)
    try:
        return np.broadcast_to(s, shape)
    except ValueError:
        raise ValueError(f"sigma must be a number or one standard deviation per range (shape {shape}); got shape "
                         f"{s.shape}") from None


def _static_rows(beacons: Any, position: Any, unknown_bias: bool) -> np.ndarray:
    """The stacked Jacobian rows (..., N, n) of ranges from ``position`` (..., 2) to ``beacons`` (..., N, 2)."""
    b = as_points("beacons", beacons, min_ndim=2)
    p = as_points("position", position)
    if b.shape[-2] == 0:
        raise ValueError("beacons must hold at least one beacon, shape (N, 2) with N >= 1")
    h = range_jacobian(p[..., None, :], b)
    if unknown_bias:
        h = np.concatenate([h, np.ones(h.shape[:-1] + (1,))], axis=-1)
    return h


def fisher_information(beacons: Any, position: Any, sigma: Any, unknown_bias: bool = False) -> np.ndarray:
    r"""Fisher information of a static position (and optionally a range bias) from ranges to several beacons.

    With range :math:`r_i = \|p - b_i\| + \upsilon + \eta_i`, :math:`\eta_i \sim N(0, \sigma_i^2)` independent,

    .. math::

        J = \sum_{i=1}^{N} \frac{h_i^\mathsf{T} h_i}{\sigma_i^2}, \qquad
        h_i = \left[\frac{(p - b_i)^\mathsf{T}}{\|p - b_i\|}\right] \text{ or, with the bias, }
        \left[\frac{(p - b_i)^\mathsf{T}}{\|p - b_i\|},\; 1\right].

    For :math:`N \ge 3` beacons evenly spaced in bearing, :math:`\sum \cos^2 = \sum \sin^2 = N/2` and the cross
    terms vanish, so :math:`J = \frac{N}{2\sigma^2} I` (and the bias adds an uncoupled :math:`N/\sigma^2`).
    The beacons may be virtual (``virtual_beacons``): that is how one beacon and a track give information.

    Parameters
    ----------
    beacons : array_like, shape (N, 2) or (..., N, 2)
        Beacon positions [m].
    position : array_like, shape (2,) or (..., 2)
        The (true) vehicle position where the information is evaluated [m]; leading axes broadcast against those
        of ``beacons`` (e.g. many positions at once).
    sigma : float or array_like, shape (N,) or (..., N)
        Standard deviation of each range error [m], > 0.
    unknown_bias : bool, default False
        Add a constant range bias :math:`\upsilon`, common to all ranges, to the unknowns (paper A's state).

    Returns
    -------
    ndarray, shape (..., 2, 2) or (..., 3, 3)
        :math:`J` [1/m²], state order ``[x, y]`` or ``[x, y, bias]``.

    Examples
    --------
    >>> b = beacons_at_bearings([0.0, 0.0], np.radians([0.0, 120.0, 240.0]))
    >>> fisher_information(b, [0.0, 0.0], sigma=2.0).round(12)
    array([[0.375, 0.   ],
           [0.   , 0.375]])
    """
    unknown_bias = as_flag("unknown_bias", unknown_bias)
    h = _static_rows(beacons, position, bool(unknown_bias))
    s = _sigma_per_row(sigma, h.shape[:-1])
    w = h / s[..., None]
    return np.einsum("...ki,...kj->...ij", w, w)


def _bound_batch(info: np.ndarray, rtol: float) -> tuple[np.ndarray, np.ndarray, list[tuple[int, np.ndarray]]]:
    """Bounds and ranks of a stack (..., n, n); the list holds (flat index, null vectors) of the singular ones."""
    n = info.shape[-1]
    flat = info.reshape(-1, n, n)
    bounds = np.empty_like(flat)
    ranks = np.full(len(flat), n, dtype=int)
    # scale to a unit diagonal (a state with no information keeps a zero row and column: a null direction)
    d = np.sqrt(np.clip(np.diagonal(flat, axis1=-2, axis2=-1), 0.0, None))
    safe = np.where(d > 0, d, 1.0)
    scaled = flat / (safe[:, :, None] * safe[:, None, :])
    lam, vec = np.linalg.eigh((scaled + np.swapaxes(scaled, -1, -2)) / 2)
    top = np.maximum(lam[:, -1], np.finfo(float).tiny)
    regular = np.all(lam > rtol ** 2 * top[:, None], axis=-1)
    if regular.any():
        lr, vr, dr = lam[regular], vec[regular], safe[regular]
        inv = np.einsum("kij,kj,klj->kil", vr, 1.0 / lr, vr) / (dr[:, :, None] * dr[:, None, :])
        bounds[regular] = (inv + np.swapaxes(inv, -1, -2)) / 2
    singular: list[tuple[int, np.ndarray]] = []
    # singular: grouped by the number m of null directions (eigh sorts them first, the m smallest eigenvalues)
    n_null = np.count_nonzero(lam <= rtol ** 2 * top[:, None], axis=-1)
    for m in range(1, n + 1):
        group = np.flatnonzero(~regular & (n_null == m))
        if group.size == 0:
            continue
        lg, vg, dg = lam[group], vec[group], safe[group]
        inv_l = np.where(np.arange(n) >= m, 1.0 / np.where(np.arange(n) >= m, lg, 1.0), 0.0)
        g = np.einsum("kij,kj,klj->kil", vg, inv_l, vg) / (dg[:, :, None] * dg[:, None, :])
        null = vg[:, :, :m] / dg[:, :, None]                       # null vectors in original coordinates
        q, _ = np.linalg.qr(null)
        proj = q @ np.swapaxes(q, -1, -2)
        keep = np.eye(n) - proj
        b = keep @ g @ keep
        b = (b + np.swapaxes(b, -1, -2)) / 2
        infinite = np.abs(proj) > _NULL_ENTRY_TOL
        b[infinite] = np.copysign(np.inf, proj[infinite])
        bounds[group] = b
        ranks[group] = n - m
        singular.extend((int(i), null[j]) for j, i in enumerate(group))
    singular.sort(key=lambda item: item[0])
    return bounds.reshape(info.shape), ranks.reshape(info.shape[:-2]), singular


def _warn_singular(singular: list[tuple[int, np.ndarray]], total: int, n: int, labels: list[str]) -> None:
    if not singular:
        return
    index, null = singular[0]
    dirs = "; ".join(_describe_direction(v, labels) for v in null.T)
    rank = n - null.shape[1]
    where = (f" (rank {rank} of {n})" if total == 1 else
             f" in {len(singular)} of {total} matrices (the first, index {index}, has rank {rank} of {n})")
    _warn(f"the Fisher information is singular{where}. Unobservable direction(s) in "
          f"({', '.join(labels)}): {dirs}. The bound is infinite along them (entries set to inf); only the "
          "finite entries are bounds of estimable quantities")


def cramer_rao_bound(information: Any, *, rtol: float = DEFAULT_RTOL) -> np.ndarray:
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


def position_crlb(beacons: Any, position: Any, sigma: Any, unknown_bias: bool = False, *,
                  rtol: float = DEFAULT_RTOL) -> np.ndarray:
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


def rmse_bound(covariance: Any) -> float | np.ndarray:
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


def gdop(beacons: Any, position: Any, unknown_bias: bool = False, *, rtol: float = DEFAULT_RTOL) -> float | np.ndarray:
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


def precision_factor(beacons: Any, position: Any, unknown_bias: bool = True) -> float | np.ndarray:
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
    from . import lsq        # a sibling of the same layer; imported here to keep the import graph one-way

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


# ---------------------------------------------------------------------------------------------------------------------
# along a track
# ---------------------------------------------------------------------------------------------------------------------
def _track_inputs(positions: Any, beacon: Any, times: Any, unknown_current: bool) -> tuple[np.ndarray, np.ndarray,
                                                                                            np.ndarray | None]:
    p = as_points("positions", positions, min_ndim=2)
    if p.ndim != 2 or len(p) == 0:
        raise ValueError(f"positions must have shape (K, 2) with K >= 1; got {p.shape}")
    b = as_points("beacon", beacon)
    if b.shape not in ((2,), p.shape):
        raise ValueError(f"beacon must have shape (2,) or {p.shape} (one position per epoch); got {b.shape}")
    t = None
    if unknown_current:
        if times is None:
            raise ValueError("times are needed with unknown_current=True: the current moves the vehicle by "
                             "U (t_k - t_ref)")
        t = as_finite("times", times, ndim=1)
        if len(t) != len(p):
            raise ValueError(f"times must have one entry per row of positions ({len(p)}); got {len(t)}")
    elif times is not None:
        t = as_finite("times", times, ndim=1)
        if len(t) != len(p):
            raise ValueError(f"times must have one entry per row of positions ({len(p)}); got {len(t)}")
    return p, b, t


def _track_rows(p: np.ndarray, b: np.ndarray, t: np.ndarray | None, unknown_bias: bool, unknown_current: bool,
                ref: int) -> np.ndarray:
    h = range_jacobian(p, b)
    cols = [h]
    if unknown_bias:
        cols.append(np.ones((len(p), 1)))
    if unknown_current:
        assert t is not None
        cols.append((t - t[ref])[:, None] * h)
    return np.concatenate(cols, axis=1)


def _as_reference(reference: Any, k: int) -> int:
    if isinstance(reference, bool) or not isinstance(reference, (int, np.integer)) or not -k <= reference < k:
        raise ValueError(f"reference must be an epoch index in [{-k}, {k - 1}]; got {reference!r}")
    return int(reference) % k


def track_jacobian(positions: Any, beacon: Any, *, times: Any = None, unknown_bias: bool = False,
                   unknown_current: bool = False, reference: int = -1) -> np.ndarray:
    r"""The stacked Jacobian of the ranges along a track with respect to the state at one epoch.

    The dead-reckoned displacements are taken as known, so the unknowns are the position :math:`p` at the
    reference epoch, optionally a constant range bias :math:`\upsilon` (paper A) and a constant current
    :math:`U` (paper B). The vehicle is at :math:`p_k = p + d_k + U (t_k - t_\mathrm{ref})` and measures
    :math:`r_k = \|p_k - b_k\| + \upsilon`, so row :math:`k` is

    .. math::

        \left[\; h_k,\;\; 1,\;\; (t_k - t_\mathrm{ref})\, h_k \;\right], \qquad
        h_k = \frac{(p_k - b_k)^\mathsf{T}}{\|p_k - b_k\|},

    with the bias and current blocks present only when asked for (state order ``[x, y, bias, Ux, Uy]``). The
    rows are evaluated on the true track: this is the local (linearized) observability matrix, and
    :math:`H^\mathsf{T} H / \sigma^2` is the Fisher information (``track_fisher_information``).

    Parameters
    ----------
    positions : array_like, shape (K, 2)
        True vehicle positions over ground at the ranging epochs [m].
    beacon : array_like, shape (2,) or (K, 2)
        Beacon position, fixed or one per epoch [m].
    times : array_like, shape (K,), optional
        Epoch times [s]; required with ``unknown_current``.
    unknown_bias : bool, default False
        Add the bias column.
    unknown_current : bool, default False
        Add the two current columns.
    reference : int, default -1
        The epoch whose position is the unknown (default: the last one).

    Returns
    -------
    ndarray, shape (K, n)
        :math:`H`, ``n`` = 2, 3, 4 or 5.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.observability import track_jacobian
    >>> theta = np.linspace(0.0, np.pi / 2, 3)
    >>> arc = 100.0 * np.column_stack([np.cos(theta), np.sin(theta)])
    >>> track_jacobian(arc, (0.0, 0.0), unknown_bias=True).round(3)
    array([[1.   , 0.   , 1.   ],
           [0.707, 0.707, 1.   ],
           [0.   , 1.   , 1.   ]])
    """
    unknown_bias = as_flag("unknown_bias", unknown_bias)
    unknown_current = as_flag("unknown_current", unknown_current)
    p, b, t = _track_inputs(positions, beacon, times, bool(unknown_current))
    ref = _as_reference(reference, len(p))
    return _track_rows(p, b, t, bool(unknown_bias), bool(unknown_current), ref)


def track_fisher_information(positions: Any, beacon: Any, sigma: Any, *, times: Any = None,
                             unknown_bias: bool = False, unknown_current: bool = False,
                             cumulative: bool = False) -> np.ndarray:
    r"""Fisher information of the ranges along a track (the observability Gramian weighted by the noise).

    .. math::

        J_k = \sum_{j \le k} \frac{H_j^\mathsf{T} H_j}{\sigma_j^2},

    :math:`H_j` the rows of ``track_jacobian`` taken with respect to the state at epoch :math:`k`. With
    ``cumulative=False`` only the last epoch's :math:`J_K` (all ranges, state now) is returned; with
    ``cumulative=True`` the stack :math:`J_1, \dots, J_K`: what the ranges so far say about the position *now*,
    the quantity a filter with perfect dead reckoning tracks. Referring the state to another epoch is an invertible
    linear change of variables (:math:`p_k = p_j + d_k - d_j + U(t_k - t_j)`), so the rank does not depend on it.

    Parameters
    ----------
    positions : array_like, shape (K, 2)
        True positions over ground at the ranging epochs [m].
    beacon : array_like, shape (2,) or (K, 2)
        Beacon position(s) [m].
    sigma : float or array_like, shape (K,)
        Range noise standard deviation(s) [m], > 0.
    times : array_like, shape (K,), optional
        Epoch times [s]; required with ``unknown_current``.
    unknown_bias, unknown_current : bool, default False
        The extra unknowns (see ``track_jacobian``).
    cumulative : bool, default False
        Return the information after every epoch.

    Returns
    -------
    ndarray, shape (n, n) or (K, n, n)
        Information matrices, state order ``[x, y, bias, Ux, Uy]`` (the blocks asked for).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.observability import track_fisher_information
    >>> theta = np.linspace(0.0, np.pi / 2, 5)
    >>> arc = 100.0 * np.column_stack([np.cos(theta), np.sin(theta)])
    >>> track_fisher_information(arc, (0.0, 0.0), sigma=1.0).round(3)
    array([[2.5  , 1.207],
           [1.207, 2.5  ]])
    >>> track_fisher_information(arc, (0.0, 0.0), sigma=1.0, cumulative=True).shape
    (5, 2, 2)
    """
    unknown_bias = as_flag("unknown_bias", unknown_bias)
    unknown_current = as_flag("unknown_current", unknown_current)
    cumulative = as_flag("cumulative", cumulative)
    p, b, t = _track_inputs(positions, beacon, times, bool(unknown_current))
    k = len(p)
    s = _sigma_per_row(sigma, (k,))
    rows = _track_rows(p, b, t, bool(unknown_bias), bool(unknown_current), 0) / s[:, None]
    if not cumulative:
        J0 = rows.T @ rows
        if not unknown_current:
            return J0
        return _refer_current(J0[None], (t[-1] - t[0])[None], bool(unknown_bias))[0]
    J0 = np.cumsum(np.einsum("ki,kj->kij", rows, rows), axis=0)
    if not unknown_current:
        return J0
    return _refer_current(J0, t - t[0], bool(unknown_bias))


def _refer_current(J0: np.ndarray, tau: np.ndarray, unknown_bias: bool) -> np.ndarray:
    """Refer information about [p_0, (bias), U] to [p_k, (bias), U], p_k = p_0 + (t_k - t_0) U + known."""
    n = J0.shape[-1]
    c = 3 if unknown_bias else 2
    T_inv = np.broadcast_to(np.eye(n), J0.shape).copy()
    T_inv[:, 0, c] = -tau
    T_inv[:, 1, c + 1] = -tau
    return np.einsum("kai,kab,kbj->kij", T_inv, J0, T_inv)


def track_crlb(positions: Any, beacon: Any, sigma: Any, *, times: Any = None, unknown_bias: bool = False,
               unknown_current: bool = False, rtol: float = DEFAULT_RTOL) -> np.ndarray:
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


def observability_rank(positions: Any, beacon: Any, *, times: Any = None, unknown_bias: bool = False,
                       unknown_current: bool = False, cumulative: bool = True,
                       rtol: float = DEFAULT_RTOL) -> int | np.ndarray:
    r"""Numerical rank of the range information along a track: how many state directions the ranges fix.

    The rank of the stacked Jacobian :math:`H_{1:k}` (``track_jacobian``), computed as the number of eigenvalues
    of the diagonally scaled information :math:`D^{-1} H^\mathsf{T} H D^{-1}` above ``rtol**2`` times the largest
    (the squared singular values of the column-scaled Jacobian, so units do not matter). Full rank means local
    observability. Theory to check it against (beacon fixed, dead reckoning exact):

    =============================  ==========  ==============  =================
    motion                         position    + bias          + current
    =============================  ==========  ==============  =================
    straight, radial (through b)   1           1               2
    straight, not radial           2           3               3
    one heading change, circle     2           3               4
    =============================  ==========  ==============  =================

    (after enough epochs: one epoch gives rank 1.) The straight track with a current fails because
    :math:`r_k^2 = \|p - b\|^2 + 2 (p - b)\cdot w\, t_k + \|w\|^2 t_k^2` (ground velocity :math:`w`) depends on three
    combinations of the four unknowns; rotating the position about the beacon together with the velocity
    (through the current) leaves all ranges unchanged.

    Parameters
    ----------
    positions : array_like, shape (K, 2)
        True positions over ground [m].
    beacon : array_like, shape (2,) or (K, 2)
        Beacon position(s) [m].
    times : array_like, shape (K,), optional
        Epoch times [s]; required with ``unknown_current``.
    unknown_bias, unknown_current : bool, default False
        The extra unknowns.
    cumulative : bool, default True
        Return the rank after every epoch (shape ``(K,)``); otherwise one int for the whole track.
    rtol : float, default ``DEFAULT_RTOL``
        Relative tolerance on the singular values of the column-scaled Jacobian.

    Returns
    -------
    int or ndarray of int, shape (K,)
        The rank(s), between 0 and ``n``.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.observability import observability_rank
    >>> theta = np.linspace(0.0, np.pi / 2, 5)
    >>> arc = 100.0 * np.column_stack([np.cos(theta), np.sin(theta)])
    >>> observability_rank(arc, (0.0, 0.0), unknown_bias=True)
    array([1, 2, 3, 3, 3])
    >>> observability_rank(arc, (0.0, 0.0), unknown_bias=True, cumulative=False)
    3
    """
    unknown_bias = as_flag("unknown_bias", unknown_bias)
    unknown_current = as_flag("unknown_current", unknown_current)
    cumulative = as_flag("cumulative", cumulative)
    J = track_fisher_information(positions, beacon, 1.0, times=times, unknown_bias=unknown_bias,
                                 unknown_current=unknown_current, cumulative=bool(cumulative))
    ranks = _information_rank(J, _as_rtol(rtol))
    return int(ranks) if ranks.ndim == 0 else ranks


def _information_rank(J: np.ndarray, rtol: float) -> np.ndarray:
    d = np.sqrt(np.clip(np.diagonal(J, axis1=-2, axis2=-1), 0.0, None))
    live = d > 0
    safe = np.where(live, d, 1.0)
    scaled = J / (safe[..., :, None] * safe[..., None, :])
    scaled = np.where(live[..., :, None] & live[..., None, :], scaled, 0.0)
    lam = np.linalg.eigvalsh((scaled + np.swapaxes(scaled, -1, -2)) / 2)
    top = np.maximum(lam.max(axis=-1, keepdims=True), np.finfo(float).tiny)
    return np.count_nonzero(lam > rtol ** 2 * top, axis=-1)


def numerical_rank(matrix: Any, *, rtol: float = DEFAULT_RTOL) -> int | np.ndarray:
    r"""The numerical rank of a matrix (or a stack), with its columns scaled to unit length first.

    Counts the singular values above ``rtol`` times the largest. Scaling the columns makes the answer independent
    of units: a Jacobian whose current columns are in seconds (thousands) next to position columns of order one is
    judged on its geometry, not its units. ``numpy.linalg.matrix_rank`` uses a tolerance of about
    :math:`\max(m, n)\,\epsilon\, s_\mathrm{max}` instead, which counts poorly conditioned geometry as full rank.

    Parameters
    ----------
    matrix : array_like, shape (..., m, n)
        E.g. a stacked Jacobian from ``track_jacobian``.
    rtol : float, default ``DEFAULT_RTOL``
        Relative tolerance.

    Returns
    -------
    int or ndarray of int
        The rank(s).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.observability import numerical_rank
    >>> numerical_rank([[1.0, 2.0], [2.0, 4.0], [0.0, 0.0]]), numerical_rank(np.eye(3))
    (1, 3)
    """
    A = as_finite("matrix", matrix, nonempty=True)
    if A.ndim < 2:
        raise ValueError(f"matrix must have at least 2 dimensions, shape (..., m, n); got {A.shape}")
    rtol = _as_rtol(rtol)
    norms = np.linalg.norm(A, axis=-2, keepdims=True)
    scaled = A / np.where(norms > 0, norms, 1.0)
    s = np.linalg.svd(scaled, compute_uv=False)
    top = np.maximum(s.max(axis=-1, keepdims=True), np.finfo(float).tiny) if s.shape[-1] else s
    ranks = np.count_nonzero(s > rtol * top, axis=-1)
    return int(ranks) if np.ndim(ranks) == 0 else ranks


# ---------------------------------------------------------------------------------------------------------------------
# two-range fix and its mirror solution
# ---------------------------------------------------------------------------------------------------------------------
def two_range_fix(beacon: Any, ranges: Any, displacement: Any) -> np.ndarray:
    r"""The two positions that fit two ranges to one beacon and the displacement between them (a mirror pair).

    The vehicle measures :math:`r_1` at :math:`p - u`, moves by the dead-reckoned :math:`u`, and measures
    :math:`r_2` at :math:`p`. So :math:`p` lies on the circle of radius :math:`r_2` about the beacon and on the
    circle of radius :math:`r_1` about the virtual beacon :math:`b + u`. Two circles meet in two points, mirror
    images across the line through the beacon along :math:`u`: with :math:`e = u/\|u\|`,
    :math:`e_\perp` = :math:`e` turned by +90°,

    .. math::

        a = \frac{r_2^2 - r_1^2 + \|u\|^2}{2\|u\|}, \qquad
        p_\pm = b + a\,e \pm \sqrt{r_2^2 - a^2}\; e_\perp .

    Nothing in two ranges tells them apart: a heading change (a third range from a displacement that is not
    parallel to :math:`u`) does (Zhu et al., 2019, paper D; paper E's VMLBL needs a sensible initial value for the
    same reason). If the displacement points along the line of sight the circles touch and :math:`p_+ = p_-`
    (radial motion: unique, but with no first-order information across the line of sight).

    Parameters
    ----------
    beacon : array_like, shape (2,)
        Beacon position [m].
    ranges : array_like, shape (2,)
        :math:`[r_1, r_2]`, the ranges before and after the displacement [m], >= 0.
    displacement : array_like, shape (2,)
        :math:`u`, the dead-reckoned displacement from the first ranging point to the second [m].

    Returns
    -------
    ndarray, shape (2, 2)
        Row 0 the solution to the left of the direction of travel, row 1 the one to the right. With noisy ranges
        the circles may miss each other: both rows are then the point on the line of centres that best fits the
        two ranges, with an ``UnobservableWarning``. A zero displacement gives NaN rows with a warning (the two
        circles are concentric: the position is anywhere on a circle).

    Examples
    --------
    >>> two_range_fix([0.0, 0.0], [500.0, 412.31056256], [200.0, 0.0]).round(3)
    array([[-100.,  400.],
           [-100., -400.]])
    """
    b = as_points("beacon", beacon)
    if b.shape != (2,):
        raise ValueError(f"beacon must have shape (2,); got {b.shape}")
    r = as_finite("ranges", ranges, shape=(2,), max_abs=MAX_COORDINATE)     # squared below: kept within float64
    if np.any(r < 0):
        raise ValueError(f"ranges must be >= 0; got {r.tolist()}")
    u = as_finite("displacement", displacement, shape=(2,), max_abs=MAX_COORDINATE)
    dist = float(np.hypot(*u))
    if dist == 0.0:
        _warn("the displacement is zero: both ranges are from the same point, so the position is only known "
              "to lie on a circle about the beacon; returning NaN")
        return np.full((2, 2), np.nan)
    r1, r2 = r
    e = u / dist
    e_perp = np.array([-e[1], e[0]])
    a = (r2 ** 2 - r1 ** 2 + dist ** 2) / (2.0 * dist)
    h2 = r2 ** 2 - a ** 2
    if h2 < 0:
        _warn(f"the two range circles do not meet (r1 = {r1:g} m, r2 = {r2:g} m, |u| = {dist:g} m): the ranges "
              "are inconsistent with the displacement (noise?). Returning the best point on the line of "
              "centres twice")
        # ranges r2 about b and r1 about b + u, on the line of centres: minimize (|s| - r2)^2 + (|s - dist| - r1)^2
        along = _best_on_line(r1, r2, dist)
        point = b + along * e
        return np.vstack([point, point])
    h = np.sqrt(h2)
    return np.vstack([b + a * e + h * e_perp, b + a * e - h * e_perp])


def _best_on_line(r1: float, r2: float, dist: float) -> float:
    """The abscissa s on the line of centres (b at 0, b + u at dist) minimizing (|s| - r2)^2 + (|s - dist| - r1)^2."""
    candidates = []
    for s1 in (1.0, -1.0):          # s = s1 |s|
        for s2 in (1.0, -1.0):      # s - dist = s2 |s - dist|
            # (s1 s - r2)^2 + (s2 (s - dist) - r1)^2 is quadratic in s: minimum at
            s = (s1 * r2 + dist + s2 * r1) / 2.0
            if s1 * s >= 0 and s2 * (s - dist) >= 0:
                candidates.append(s)
    candidates += [0.0, dist]
    cost = [(abs(s) - r2) ** 2 + (abs(s - dist) - r1) ** 2 for s in candidates]
    return float(candidates[int(np.argmin(cost))])


def mirror_point(point: Any, beacon: Any, direction: Any) -> np.ndarray:
    r"""Reflect points across the line through the beacon along ``direction``.

    .. math::

        p' = b + 2\,\big((p - b)\cdot e\big)\, e - (p - b), \qquad e = \frac{\text{direction}}{\|\text{direction}\|}.

    A straight track and its reflection across the line through the beacon parallel to it have the same ranges at
    every epoch: the mirror solution of a straight track.

    Parameters
    ----------
    point : array_like, shape (..., 2)
        Points to reflect [m].
    beacon : array_like, shape (2,)
        A point of the mirror line (the beacon) [m].
    direction : array_like, shape (2,)
        Direction of the mirror line (e.g. the track's velocity), not zero.

    Returns
    -------
    ndarray, shape (..., 2)
        The reflected points [m].

    Examples
    --------
    >>> from uwtutor.observability import mirror_point
    >>> # across the east-west line through the beacon
    >>> mirror_point([3.0, 4.0], (0.0, 0.0), (1.0, 0.0))
    array([ 3., -4.])
    """
    p = as_points("point", point)
    b = as_points("beacon", beacon)
    if b.shape != (2,):
        raise ValueError(f"beacon must have shape (2,); got {b.shape}")
    d = as_finite("direction", direction, shape=(2,))
    norm = float(np.hypot(*d))
    if norm == 0.0:
        raise ValueError("direction must not be zero: it sets the mirror line (use the track's velocity)")
    e = d / norm
    rel = p - b
    return b + 2.0 * (rel @ e)[..., None] * e - rel


def error_ellipse(covariance: Any, center: Any = (0.0, 0.0), scale: float = 1.0, n_points: int = 73) -> np.ndarray:
    r"""Points on the ellipse :math:`\{c + s\,x : x^\mathsf{T} C^{-1} x = 1\}` of a 2×2 covariance, for plotting.

    With ``scale=1`` it is the one-standard-deviation ellipse: its semi-axes are the square roots of the eigenvalues
    of :math:`C`, along its eigenvectors (for a Gaussian it holds 39 % of the probability; ``scale=2.4477`` gives
    95 %).

    Parameters
    ----------
    covariance : array_like, shape (2, 2)
        A finite, symmetric positive semi-definite covariance [m²] (e.g. the position block of a CRLB).
    center : array_like, shape (2,), default (0, 0)
        Centre of the ellipse [m].
    scale : float, default 1
        Magnification of the ellipse, > 0 (figures of kilometre-scale tracks magnify metre-scale bounds).
    n_points : int, default 73
        Number of points (the first is repeated at the end, so the curve is closed).

    Returns
    -------
    ndarray, shape (n_points, 2)
        The ellipse [m].

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.observability import error_ellipse
    >>> # standard deviations 2 m east and 1 m north, drawn at two sigma
    >>> e = error_ellipse(np.diag([4.0, 1.0]), center=(10.0, 0.0), scale=2.0)
    >>> e.shape, e.min(axis=0).round(3), e.max(axis=0).round(3)
    ((73, 2), array([ 6., -2.]), array([14.,  2.]))
    """
    C = as_covariance("covariance", as_finite("covariance", covariance, shape=(2, 2)), 2, allow_singular=True)
    c = as_finite("center", center, shape=(2,))
    s = as_scalar("scale", scale, domain="positive")
    n_points = as_int("n_points", n_points, minimum=3, maximum=10**6)
    lam, vec = np.linalg.eigh(C)            # C is symmetric (checked): eigh reads its lower triangle
    # eigenvalues within as_covariance's stated tolerance below 0 are round-off: their axis has length 0
    theta = np.linspace(0.0, 2 * np.pi, int(n_points))
    circle = np.stack([np.cos(theta), np.sin(theta)], axis=-1)
    return c + s * (circle * np.sqrt(np.clip(lam, 0.0, None))) @ vec.T


# ---------------------------------------------------------------------------------------------------------------------
# the posterior (Bayesian) Cramér-Rao bound of a filter with process noise
# ---------------------------------------------------------------------------------------------------------------------
def _pcrb_state_size(bias: bool, current: bool) -> int:
    return 2 + int(bias) + 2 * int(current)


def _pcrb_steps(times: Any, k: int, current: bool) -> np.ndarray | None:
    """The interval of each of the ``k`` steps (the current moves the vehicle by ``dt_k U`` in step k)."""
    if times is None:
        if current:
            raise ValueError("times are needed with current=True: each step moves the vehicle by dt_k U. Give the "
                             "K epoch times (the first step then lasts times[1] - times[0]) or K + 1 times starting "
                             "with the time of x0")
        return None
    t = as_finite("times", times, ndim=1)
    if len(t) in (k, k + 1) and np.any(np.diff(t) <= 0):      # checked even where the times are not used
        step = int(np.flatnonzero(np.diff(t) <= 0)[0])
        raise ValueError(f"times must increase strictly; times[{step + 1}] = {t[step + 1]:g} follows "
                         f"times[{step}] = {t[step]:g}")
    if len(t) == k + 1:
        if not current:
            return None
        dt = np.diff(t)
    elif len(t) == k:
        if not current:
            return None
        if k < 2:
            raise ValueError("with a single epoch give times as [t_x0, t_1] (K + 1 entries): the step before the "
                             "first epoch has no length otherwise")
        dt = np.diff(t, prepend=t[0] - (t[1] - t[0]))
    else:
        raise ValueError(f"times must have one entry per epoch ({k}), or {k + 1} entries starting with the time "
                         f"of x0; got {len(t)}")
    if np.any(dt <= 0):
        raise ValueError(f"times must increase strictly; step {int(np.flatnonzero(dt <= 0)[0])} has length "
                         f"{dt[dt <= 0][0]}")
    return dt


def _pcrb_process_noise(Q: Any, n: int, k: int) -> np.ndarray:
    """Q as (k, n, n): a position-only (2, 2) Q is embedded with zeros (a constant bias and current)."""
    q = as_covariance("Q", Q, allow_singular=True)
    if q.ndim not in (2, 3) or (q.ndim == 3 and q.shape[0] != k) or q.shape[-1] not in (2, n):
        raise ValueError(f"Q must be the process noise covariance of one step, shape (2, 2) (position only) or "
                         f"({n}, {n}) (the whole state), or one per step, shape ({k}, 2, 2) or ({k}, {n}, {n}); "
                         f"got {q.shape}")
    out = np.zeros((k, n, n))
    m = q.shape[-1]
    out[:, :m, :m] = q
    return out


def _pcrb_sigma(sigma: Any, shape: tuple[int, ...]) -> np.ndarray:
    """1/sigma^2 broadcast to ``shape`` (runs, epochs); sigma = inf means no range at that epoch."""
    s = as_float_array("sigma", sigma)
    bad = np.isnan(s) | (s <= 0)
    if bad.any():
        raise ValueError(f"sigma must be > 0 (np.inf for an epoch without a range); got {s[bad].flat[0]}")
    small = s < 1e-150
    if small.any():
        raise ValueError(f"sigma must be at least 1e-150 (1 / sigma^2 overflows float64 below it); got "
                         f"{s[small].flat[0]:.3g}. Change its units")
    try:
        s = np.broadcast_to(s, shape)
    except ValueError:
        raise ValueError(f"sigma must be a number, one value per epoch (K,) = ({shape[-1]},), or one per run and "
                         f"epoch {shape}; got shape {s.shape}") from None
    return 1.0 / s**2


def _sym(a: np.ndarray) -> np.ndarray:
    return (a + np.swapaxes(a, -1, -2)) / 2


def _spd_inverse(J: np.ndarray) -> np.ndarray:
    """Inverse of a stack of symmetric positive-definite matrices through their Cholesky factors."""
    L = np.linalg.cholesky(J)
    L_inv = np.linalg.solve(L, np.broadcast_to(np.eye(J.shape[-1]), J.shape))
    return np.swapaxes(L_inv, -1, -2) @ L_inv


def posterior_crlb(positions: Any, beacon: Any, sigma: Any, Q: Any, P0: Any, times: Any = None, *,
                   bias: bool = False, current: bool = False, full: bool = False,
                   mean_over_runs: bool = False) -> np.ndarray:
    r"""The posterior Cramér–Rao bound of dead reckoning with process noise and ranges to one beacon, epoch by epoch.

    The state :math:`x_k = [p_k,\; \upsilon,\; U]` (position; with ``bias`` a range bias, paper A; with
    ``current`` a constant current, paper B) moves linearly and is ranged with additive Gaussian noise:

    .. math::

        x_k = F_k x_{k-1} + [u_k, 0, 0] + w_k, \quad w_k \sim N(0, Q_k), \qquad
        F_k = \begin{bmatrix} I & 0 & \Delta t_k I \\ 0 & 1 & 0 \\ 0 & 0 & I \end{bmatrix},

    .. math::

        r_k = \lVert p_k - b_k \rVert + \upsilon + \eta_k, \quad \eta_k \sim N(0, \sigma_k^2).

    Tichavský, Muravchik and Nehorai (1998) bound the mean squared error matrix of *any* estimator of
    :math:`x_k` from the ranges up to epoch :math:`k` -- biased or not, the prior included -- by
    :math:`J_k^{-1}`, with the information :math:`J_k` given by a recursion. For a linear motion with additive
    Gaussian noise it reads

    .. math::

        J_0 = P_0^{-1}, \qquad
        J_k = \left(Q_k + F_k J_{k-1}^{-1} F_k^\mathsf{T}\right)^{-1}
              + \operatorname{E}\!\left[H_k^\mathsf{T} R_k^{-1} H_k\right], \qquad
        H_k = \left[\frac{(p_k - b_k)^\mathsf{T}}{\lVert p_k - b_k \rVert},\; 1,\; 0,\; 0\right],

    the information-form Kalman filter, whose linearization point is the *true* state: each step predicts with
    :math:`Q_k`, then adds that epoch's range information, as the filters do. With one range,
    :math:`H_k^\mathsf{T} R_k^{-1} H_k = H_k^\mathsf{T} H_k / \sigma_k^2` depends only on the bearing of the
    vehicle from the beacon. As :math:`Q \to 0` (and :math:`P_0^{-1} \to 0`), :math:`J_k` becomes the
    information of all the ranges so far about the state now, and the bound becomes chapter 2's static bound
    (``track_crlb``); process noise makes old ranges worth less and keeps the bound from shrinking to zero.

    .. rubric:: The expectation, evaluated on the true track

    The expectation is over the true states, which are random: the initial error (:math:`P_0`) and the process
    noise scatter the true positions about the nominal track, and each range's information
    :math:`H_k^\mathsf{T} H_k / \sigma_k^2` points along a bearing that scatters with them. By default it is
    evaluated at the given ``positions`` only: a first-order approximation, exact in the limit of a true track
    known to within a negligible fraction of the range to the beacon, whose error grows with the bearing
    scatter (spread of the true positions over the range). On a track that turns 150-250 m from the beacon
    and then runs out to 400 m, 4 m of scatter changes the bound by 0.2 %; 15 m (2 m of DR noise per step, 60
    steps) by 10-30 %, and
    the exact bound is then *lower*: the scatter spreads each range's information over several directions,
    most usefully where the nominal geometry leaves a direction unobserved (a radial leg). To evaluate the
    expectation properly, pass the sampled true tracks of a Monte Carlo study (``positions`` of shape
    ``(M, K, 2)``) with ``mean_over_runs=True``: :math:`\operatorname{E}[\cdot]` is then their mean, the
    Monte Carlo evaluation of the original paper, which converges to the exact bound as :math:`M` grows. That
    is the bound to set against an RMSE over runs whose true tracks differ.

    .. rubric:: Numerics

    The recursion never inverts :math:`J`: with :math:`\tilde J = F_k^{-\mathsf{T}} J_{k-1} F_k^{-1}` (``F_k``
    is unit triangular), :math:`(Q_k + \tilde J^{-1})^{-1} = \tilde J (I + Q_k \tilde J)^{-1}`, a solve with a
    matrix whose eigenvalues are all :math:`\ge 1`. This holds for a singular :math:`Q_k` (a constant bias or
    current; :math:`Q = 0`) and a nearly uninformative :math:`P_0`, and :math:`J` is symmetrized at every step.
    The bound itself is :math:`J_k^{-1}` through a Cholesky factor.

    Parameters
    ----------
    positions : array_like, shape (K, 2) or (M, K, 2)
        True vehicle positions :math:`p_k` at the K ranging epochs [m]; a leading axis of M runs gives one
        bound per run (or, with ``mean_over_runs``, their average information).
    beacon : array_like, shape (2,), (K, 2) or (M, K, 2)
        Beacon position: fixed, one per epoch (a moving beacon: a ship, a leader), or one per run and epoch [m].
    sigma : float or array_like, shape (K,) or (M, K)
        Range noise standard deviation(s) :math:`\sigma_k` [m], > 0; ``np.inf`` at an epoch without a range
        (predict only).
    Q : array_like, shape (2, 2), (n, n), (K, 2, 2) or (K, n, n)
        Process noise covariance of one step (positive semi-definite), or one per step. A (2, 2) ``Q`` is the
        dead-reckoning noise of the position; the bias and the current are then constant. A full (n, n) ``Q``
        lets them random-walk.
    P0 : array_like, shape (n, n) or (M, n, n)
        Covariance of :math:`x_0`, the state before the first step (positive definite); state order
        ``[x, y, bias, Ux, Uy]`` (the blocks asked for), ``n`` = 2, 3, 4 or 5.
    times : array_like, shape (K,) or (K + 1,), optional
        Epoch times [s], needed with ``current``: step :math:`k` lasts :math:`\Delta t_k = t_k - t_{k-1}`.
        With K entries the first step lasts ``times[1] - times[0]`` (a regular grid, :math:`x_0` one interval
        before the first epoch); with K + 1 entries the first is the time of :math:`x_0`.
    bias : bool, default False
        Add a range bias :math:`\upsilon` to the state (paper A).
    current : bool, default False
        Add a constant current :math:`U = [U_x, U_y]` that moves the vehicle by :math:`\Delta t_k U` in step
        :math:`k` (paper B).
    full : bool, default False
        Return the bound of the whole state, not only of the position.
    mean_over_runs : bool, default False
        With ``positions`` (and/or ``beacon``, ``sigma``) per run, evaluate the expectation as the mean of the
        range information over the runs and return one bound (``P0`` and ``Q`` are then shared).

    Returns
    -------
    ndarray, shape (K, 2, 2), or (M, K, 2, 2) per run
        The bound :math:`J_k^{-1}` on the position [m²] after epoch :math:`k`'s range; with ``full`` the whole
        ``(K, n, n)`` (or ``(M, K, n, n)``) bound. ``rmse_bound`` turns it into :math:`\sqrt{\operatorname{tr}}`
        of the position block, the bound that an RMSE over runs is compared with.

    Warns
    -----
    UnobservableWarning
        When a position coincides with the beacon: that range carries no information (its line of sight is
        undefined) and is skipped.

    See Also
    --------
    track_crlb : the static bound (no process noise, no prior), the limit of this one as Q -> 0.

    References
    ----------
    P. Tichavský, C. H. Muravchik and A. Nehorai, "Posterior Cramér–Rao bounds for discrete-time nonlinear
    filtering", IEEE Trans. Signal Process. 46(5), 1386–1396, 1998 (the information recursion, and its form
    for additive Gaussian noise and linear dynamics).

    Examples
    --------
    A vehicle circling a beacon at 200 m with dead-reckoning noise of 0.3 m per step and 2 m ranges: the bound
    settles where the range information of each step balances the drift.

    >>> import numpy as np
    >>> from uwtutor.observability import posterior_crlb, rmse_bound
    >>> theta = np.linspace(0.0, 2 * np.pi, 401)[1:]
    >>> track = 200.0 * np.column_stack([np.cos(theta), np.sin(theta)])
    >>> pcrb = posterior_crlb(
    ...     track, [0.0, 0.0], sigma=2.0, Q=0.3**2 * np.eye(2), P0=25.0 * np.eye(2)
    ... )
    >>> pcrb.shape
    (400, 2, 2)
    >>> bound = rmse_bound(pcrb)
    >>> print(
    ...     f"{bound[0]:.2f} m at the first epoch, {bound[-1]:.2f} m at the last"
    ... )
    5.34 m at the first epoch, 2.62 m at the last

    With an unknown range bias (paper A's three states), the full bound has the bias too:

    >>> full = posterior_crlb(
    ...     track,
    ...     [0.0, 0.0],
    ...     2.0,
    ...     0.3**2 * np.eye(2),
    ...     np.diag([25.0, 25.0, 4.0]),
    ...     bias=True,
    ...     full=True,
    ... )
    >>> full.shape, bool(rmse_bound(full[-1]) > bound[-1])
    ((400, 3, 3), True)
    """
    bias, current = bool(bias), bool(current)
    n = _pcrb_state_size(bias, current)
    p = as_points("positions", positions, min_ndim=2)
    if p.ndim not in (2, 3) or p.shape[-2] == 0:
        raise ValueError(f"positions must have shape (K, 2) or (M, K, 2) with K >= 1; got {p.shape}")
    K = p.shape[-2]
    b = as_points("beacon", beacon)
    if b.ndim > 3 or (b.ndim >= 2 and b.shape[-2] != K):
        raise ValueError(f"beacon must have shape (2,), ({K}, 2) (one position per epoch) or (M, {K}, 2); got "
                         f"{b.shape}")
    s_in = as_float_array("sigma", sigma)
    P0_arr = as_covariance("P0", P0)
    if P0_arr.ndim not in (2, 3) or P0_arr.shape[-1] != n:
        labels = ", ".join(_state_labels(n, bias, current))
        raise ValueError(f"P0 must be ({n}, {n}) or (M, {n}, {n}), the covariance of [{labels}] before the first "
                         f"step; got shape {P0_arr.shape}")
    # the runs axis: from positions, beacon, sigma and P0 (one of length 1 broadcasts)
    runs = common_runs({name: shape[0] if len(shape) == 1 else None
                        for name, shape in (("positions", p.shape[:-2]), ("beacon", b.shape[:-2]),
                                            ("sigma", np.shape(s_in)[:-1]), ("P0", P0_arr.shape[:-2]))},
                       broadcast_one=True)
    M = 1 if runs is None else runs
    batched = runs is not None
    if np.ndim(s_in) > 2:
        raise ValueError(f"sigma must be a number, shape ({K},) or (M, {K}); got shape {np.shape(s_in)}")
    info_scale = _pcrb_sigma(s_in, (M, K))                                   # 1 / sigma^2, (M, K)
    dt = _pcrb_steps(times, K, current)
    Qk = _pcrb_process_noise(Q, n, K)

    pb = np.broadcast_to(p, (M, K, 2))
    bb = np.broadcast_to(b, (M, K, 2))
    _, los, defined = _line_of_sight(pb, bb)
    if not defined.all():
        j, k = (int(i) for i in np.argwhere(~defined)[0])
        _warn(f"positions coincide with the beacon at {np.count_nonzero(~defined)} epoch(s) (the first: run {j}, "
              f"epoch {k}): the line of sight is undefined there, so those ranges add no information")
    h = np.zeros((M, K, n))
    h[..., :2] = los
    if bias:
        h[..., 2] = np.where(defined, 1.0, 0.0)
    info = np.einsum("mki,mkj->mkij", h, h) * info_scale[..., None, None]   # H^T R^-1 H, (M, K, n, n)

    if mean_over_runs:
        if P0_arr.ndim == 3 and M > 1:
            raise ValueError("mean_over_runs=True averages the range information over the runs: give one P0 of "
                             f"shape ({n}, {n}) for all of them")
        info = info.mean(axis=0, keepdims=True)
        M, batched = 1, False

    J = np.broadcast_to(_spd_inverse(P0_arr), (M, n, n)).copy()
    eye = np.eye(n)
    F_inv = np.broadcast_to(eye, (K, n, n)).copy()
    if current:
        c = 3 if bias else 2
        F_inv[:, 0, c] = F_inv[:, 1, c + 1] = -dt
    bounds = np.empty((M, K, n, n))
    for k in range(K):
        Jt = np.swapaxes(F_inv[k], -1, -2) @ J @ F_inv[k] if current else J      # F^-T J F^-1
        A = eye + Qk[k] @ Jt                                                     # eigenvalues >= 1
        J_pred = np.swapaxes(np.linalg.solve(np.swapaxes(A, -1, -2), Jt), -1, -2)  # Jt (I + Q Jt)^-1
        J = _sym(J_pred) + info[:, k]
        J = _sym(J)
        bounds[:, k] = _sym(_spd_inverse(J))
    out = bounds if full else bounds[..., :2, :2]
    return out if batched else out[0]


def _runs_axis(name: str, a: np.ndarray, single_ndim: int) -> int | None:
    return a.shape[0] if a.ndim == single_ndim + 1 else None


def _as_batch(value: Any, M: int, shape: tuple[int, ...], what: str) -> np.ndarray:
    """A model's matrix (shape) or (M,) + shape as (M,) + shape."""
    arr = np.asarray(value, dtype=float)
    if arr.shape == shape:
        return np.broadcast_to(arr, (M,) + shape)
    if arr.shape == (M,) + shape:
        return arr
    raise ValueError(f"{what} must have shape {shape} or {(M,) + shape}; got {arr.shape}")


def _measured_mask(measured: Any, M: int, K: int, m: int) -> np.ndarray:
    """``measured`` as a bool array (M, K, m): (K,), (K, m), (M, K) or (M, K, m); None: every component."""
    if measured is None:
        return np.ones((M, K, m), dtype=bool)
    arr = np.asarray(measured)
    if arr.dtype != bool:
        raise TypeError(f"measured must be a bool array, True where a measurement is present (e.g. "
                        f"np.isfinite(z)); got dtype {arr.dtype}")
    if arr.shape == (K,):
        out = arr[None, :, None]
    elif arr.shape == (K, m):
        out = arr[None]
    elif arr.ndim == 2 and arr.shape[1] == K:
        out = arr[:, :, None]
    elif arr.ndim == 3 and arr.shape[1:] == (K, m):
        out = arr
    else:
        raise ValueError(f"measured must have shape ({K},), ({K}, {m}), (M, {K}) or (M, {K}, {m}); got {arr.shape}")
    if out.shape[0] not in (1, M):
        raise ValueError(f"measured has {out.shape[0]} runs but the other inputs have {M}")
    return np.broadcast_to(out, (M, K, m))


def _predicted_information(J: np.ndarray, F: np.ndarray, Q: np.ndarray, k: int) -> np.ndarray:
    r""":math:`(Q + F J^{-1} F^T)^{-1}` for stacks (M, n, n), without inverting J when F is invertible."""
    eye = np.eye(J.shape[-1])
    try:
        F_inv = np.linalg.inv(F)
        ok = bool(np.isfinite(F_inv).all())
    except np.linalg.LinAlgError:
        ok = False
    if ok:
        Jt = np.swapaxes(F_inv, -1, -2) @ J @ F_inv                              # F^-T J F^-1
        A = eye + Q @ Jt                                                         # eigenvalues >= 1
        return np.swapaxes(np.linalg.solve(np.swapaxes(A, -1, -2), Jt), -1, -2)  # Jt (I + Q Jt)^-1
    P_pred = _sym(F @ _spd_inverse(J) @ np.swapaxes(F, -1, -2) + Q)               # a singular F: covariance form
    try:
        return _spd_inverse(P_pred)
    except np.linalg.LinAlgError:
        raise IllConditionedError(f"the predicted covariance F J^-1 F^T + Q is singular at step {k} (a singular "
                                  "F with a singular Q): the bound is infinite along some direction") from None


def model_posterior_crlb(motion: Any, measurement: Any, x0: Any, P0: Any, truth: Any, u: Any = None, *,
                         measured: Any = None, full: bool = False) -> np.ndarray:
    r"""The posterior Cramér–Rao bound of any motion/measurement model pair, along a given true track.

    For :math:`x_k = f(x_{k-1}, u_k) + w_k`, :math:`w_k \sim N(0, Q_k)`, and :math:`z_k = h_k(x_k) + v_k`,
    :math:`v_k \sim N(0, R_k)` -- the models of :mod:`uwtutor.models`, as the filters use them -- Tichavský,
    Muravchik and Nehorai (1998) bound the mean squared error of any estimator of :math:`x_k` by
    :math:`J_k^{-1}`, with the information recursion (their additive-Gaussian-noise form)

    .. math::

        J_0 = P_0^{-1}, \qquad
        J_k = \left(Q_k + F_k J_{k-1}^{-1} F_k^\mathsf{T}\right)^{-1} + H_k^\mathsf{T} R_k^{-1} H_k,

    with :math:`F_k = \partial f / \partial x` at the true :math:`x_{k-1}` (and the input :math:`u_k`),
    :math:`Q_k` and :math:`R_k` the models' noise there, and :math:`H_k = \partial h_k / \partial x` at the true
    :math:`x_k`. Components of :math:`z_k` that are not measured are skipped (:math:`H_k` and :math:`R_k`
    restricted to those measured, as the filters update); a step without any measurement only predicts. As in
    :func:`posterior_crlb` (its special case for dead reckoning with a range bias and a current), the expectation
    over the true states is evaluated on the one track given: a first-order approximation, good while the true
    track is known to a small fraction of the ranges; pass the sampled tracks of a Monte Carlo study (a runs
    axis) for one bound per track.

    The recursion never inverts :math:`J`: with :math:`\tilde J = F_k^{-\mathsf{T}} J_{k-1} F_k^{-1}`,
    :math:`(Q_k + \tilde J^{-1})^{-1} = \tilde J (I + Q_k \tilde J)^{-1}`, which holds for a singular
    :math:`Q_k` (constant states: a range scale, a bias) and a nearly uninformative :math:`P_0`; a singular
    :math:`F_k` falls back to the covariance form.

    Parameters
    ----------
    motion : uwtutor.models.MotionModel
        :math:`F` and :math:`Q` (``f`` itself is not used: the true states are given).
    measurement : uwtutor.models.MeasurementModel
        :math:`H` (through ``linearize``) and :math:`R`.
    x0 : array_like, shape (n,) or (M, n)
        The true state before the first step (where :math:`F_0` is evaluated).
    P0 : array_like, shape (n, n) or (M, n, n)
        The prior covariance of ``x0`` (positive definite).
    truth : array_like, shape (K, n) or (M, K, n)
        The true states after each step, where :math:`H_k` is evaluated (the epochs of the filter's ``x``).
    u : array_like, shape (K, p) or (M, K, p), optional
        The inputs of the steps (e.g. the odometry), as the filter gets them.
    measured : array_like of bool, optional
        Where a measurement is present: ``(K,)`` per step, ``(K, m)`` per component, or with a runs axis
        ``(M, K)``, ``(M, K, m)``; e.g. ``np.isfinite(z)``. Default: every component at every step.
    full : bool, default False
        Return the bound of the whole state, not only of the position ``x[..., :2]``.

    Returns
    -------
    ndarray, shape (K, 2, 2), or (K, n, n) with ``full``; a leading runs axis when an input had one
        The bound :math:`J_k^{-1}` after step :math:`k`'s measurement.

    Warns
    -----
    UnobservableWarning
        Where the model says its Jacobian is undefined for a measured component (a position on a beacon): that
        component adds no information.

    See Also
    --------
    posterior_crlb : the bound of dead reckoning with one range (and a bias, a current), in closed form.

    References
    ----------
    P. Tichavský, C. H. Muravchik and A. Nehorai, "Posterior Cramér–Rao bounds for discrete-time nonlinear
    filtering", IEEE Trans. Signal Process. 46(5), 1386–1396, 1998 (eqs. 21-22 and the additive Gaussian case).

    Examples
    --------
    Wheel odometry with a range scale, four beacons: the bound of the position and of the scale along a loop.

    >>> import numpy as np
    >>> from uwtutor.models import BeaconRanges, OdometryMotion
    >>> from uwtutor.observability import model_posterior_crlb, rmse_bound
    >>> motion = OdometryMotion(
    ...     sigma_distance=0.05, sigma_heading=0.01, scale=True
    ... )
    >>> ranges = BeaconRanges(
    ...     [[0.0, 0.0], [40.0, 0.0], [40.0, 30.0], [0.0, 30.0]],
    ...     R=0.1**2,
    ...     layout=motion.layout,
    ... )
    >>> # a circle of 100 m
    >>> u = np.tile([[1.0, 2 * np.pi / 100]], (100, 1))
    >>> x0 = np.array([20.0, 15.0 - 100 / (2 * np.pi), 0.0, 1.07])
    >>> truth = motion.integrate(x0, u)
    >>> bound = model_posterior_crlb(
    ...     motion, ranges, x0, np.diag([4.0, 4.0, 0.1, 0.01]), truth, u, full=True
    ... )
    >>> bound.shape
    (100, 4, 4)
    >>> print(
    ...     f"position {rmse_bound(bound[-1]):.2f} m, "
    ...     f"scale {np.sqrt(bound[-1, 3, 3]):.1e}"
    ... )
    position 0.07 m, scale 2.7e-04
    """
    if not isinstance(motion, MotionModel):
        raise TypeError(f"motion must be a uwtutor.models.MotionModel; got {type(motion).__name__}")
    if not isinstance(measurement, MeasurementModel):
        raise TypeError(f"measurement must be a uwtutor.models.MeasurementModel; got {type(measurement).__name__}")
    full = as_flag("full", full)
    n, m = motion.n, measurement.m
    if measurement.n != n:
        raise ValueError(f"the measurement model reads a state of size {measurement.n} but the motion model's state "
                         f"has size {n}: build both for the same state")
    x0 = as_finite("x0", x0, ndim=(1, 2))
    truth = as_finite("truth", truth, ndim=(2, 3), nonempty=True)
    for name, a in (("x0", x0), ("truth", truth)):
        if a.shape[-1] != n:
            raise ValueError(f"{name} must have {n} entries per state (the models' state size); got shape {a.shape}")
    K = truth.shape[-2]
    P0 = as_covariance("P0", P0, n)
    if P0.ndim not in (2, 3):
        raise ValueError(f"P0 must have shape ({n}, {n}) or (M, {n}, {n}); got {P0.shape}")
    if u is not None:
        u = as_finite("u", u, ndim=(2, 3))
        if u.shape[-2] != K:
            raise ValueError(f"u must give one input per step ({K} steps, as truth); got shape {u.shape}")
    runs = common_runs({"x0": _runs_axis("x0", x0, 1), "truth": _runs_axis("truth", truth, 2),
                        "P0": _runs_axis("P0", P0, 2), "u": None if u is None else _runs_axis("u", u, 2),
                        "measured": np.shape(measured)[0] if measured is not None and np.ndim(measured) == 3
                        else None})
    M = 1 if runs is None else runs
    batched = runs is not None
    xs = np.broadcast_to(truth, (M, K, n))
    x_prev = np.array(np.broadcast_to(x0, (M, n)))
    uu = None if u is None else (u if u.ndim == 3 else np.broadcast_to(u, (M,) + u.shape))
    present_all = _measured_mask(measured, M, K, m)

    J = np.array(np.broadcast_to(_spd_inverse(P0), (M, n, n)))
    bounds = np.empty((M, K, n, n))
    singular = 0
    for k in range(K):
        u_k = None if uu is None else uu[:, k]
        F = _as_batch(motion.F(x_prev, u_k, k), M, (n, n), f"{type(motion).__name__}.F")
        Q = _as_batch(motion.Q(x_prev, u_k, k), M, (n, n), f"{type(motion).__name__}.Q")
        for method, value in (("F", F), ("Q", Q)):
            if not np.isfinite(value).all():
                raise ValueError(f"{type(motion).__name__}.{method} returned a non-finite value at step {k}")
        J = _sym(_predicted_information(J, F, Q, k))
        x_k = np.ascontiguousarray(xs[:, k])
        present = present_all[:, k]
        if present.any():
            _, H, defined = measurement.linearize(x_k, k)
            H = np.asarray(H, dtype=float)
            if H.shape != (M, m, n):
                raise ValueError(f"{type(measurement).__name__}'s H must have shape ({M}, {m}, {n}); got {H.shape}")
            d = np.asarray(defined, dtype=bool)
            d = np.broadcast_to(d[:, None], (M, m)) if d.shape == (M,) else d
            if (present & ~d).any():
                singular += int((present & ~d).sum())
            present = present & d
            R = _as_batch(measurement.R(x_k, k), M, (m, m), f"{type(measurement).__name__}.R")
            bad = present & ~np.isfinite(H).all(axis=-1)
            if bad.any():
                raise ValueError(f"{type(measurement).__name__}.linearize returned a non-finite Jacobian at step {k} "
                                 f"(run {int(np.argwhere(bad)[0][0])}) where a measurement is present")
            both = present[:, :, None] & present[:, None, :]
            if (both & ~np.isfinite(R)).any():
                raise ValueError(f"{type(measurement).__name__}.R returned a non-finite value at step {k} where a "
                                 "measurement is present")
            Hm = np.where(present[:, :, None], H, 0.0)
            Rm = np.where(both, R, np.eye(m))
            J = J + np.swapaxes(Hm, -1, -2) @ np.linalg.solve(Rm, Hm)            # H^T R^-1 H
            J = _sym(J)
        bounds[:, k] = _sym(_spd_inverse(J))
        x_prev = x_k
    if singular:
        _warn(f"the Jacobian is undefined for {singular} measured component(s) (a position on a beacon): those "
              "measurements add no information")
    out = bounds if full else bounds[..., :2, :2]
    return out if batched else out[0]
