"""Paper E's virtual-beacon (VMLBL) least-squares fix."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .._validate import MAX_COORDINATE, as_finite, common_runs
from ._common import as_thresholds, batched_lstsq, warn_conditioning


@dataclass(frozen=True)
class VirtualBeaconFix:
    r"""Paper E's virtual-beacon fix and its conditioning (returned by ``virtual_beacon_lsq``).

    Shapes: ``N`` epochs (paper E: 4) and a leading runs axis ``M`` when the inputs had one.

    Attributes
    ----------
    position : ndarray, shape (2,) or (M, 2)
        Horizontal position at the last epoch [m]; NaN where the problem is singular.
    virtual_beacons : ndarray, shape (N, 2) or (M, N, 2)
        :math:`b^\mathrm{v}_i = a_i + (p^\mathrm{DR}_N - p^\mathrm{DR}_i)` (paper E: :math:`VB_i = AB_i + (P_N -
        P_i)`) [m].
    design : ndarray, shape (N, 2) or (M, N, 2)
        :math:`A`, rows :math:`b^\mathrm{v}_{i+1} - b^\mathrm{v}_i` (cyclically: the last row is
        :math:`b^\mathrm{v}_1 - b^\mathrm{v}_N`).
    rhs : ndarray, shape (N,) or (M, N)
        :math:`g` (paper E: :math:`B`) [m²].
    condition_number : ndarray
        :math:`\kappa(A)`, shape () or (M,): large when the virtual beacons are nearly collinear.
    noise_gain : ndarray
        RMS horizontal position error per metre of white range noise, shape () or (M,):
        :math:`\sqrt{\operatorname{tr}(J J^\mathsf{T})}`, :math:`J = A^+ \partial g/\partial r`. It grows like
        range / baseline.
    residuals : ndarray, shape (N,) or (M, N)
        Range residuals at the fix,
        :math:`r_i - \lVert (\hat x, \hat y, z) - (b^\mathrm{v}_i, z^\mathrm{a}_i)\rVert` [m].
    well_conditioned : ndarray
        Boolean, shape () or (M,): condition number and noise gain below their limits.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.lsq import virtual_beacon_lsq
    >>> ship = np.array([[0.0, 0.0], [400.0, 100.0], [700.0, 400.0], [800.0, 800.0]])
    >>> sub = np.array([[-900.0, -1100.0], [-850.0, -1050.0], [-800.0, -1000.0],
    ...                 [-750.0, -950.0]])
    >>> r = np.sqrt(np.sum((ship - sub) ** 2, axis=1) + 1000.0**2)
    >>> fix = virtual_beacon_lsq(r, ship, sub, depth=1000.0)
    >>> fix.virtual_beacons.shape, fix.design.shape, bool(fix.well_conditioned)
    ((4, 2), (4, 2), True)
    >>> round(float(fix.condition_number), 2), bool(np.abs(fix.residuals).max() < 1e-6)
    (3.54, True)
    """

    position: np.ndarray
    virtual_beacons: np.ndarray
    design: np.ndarray
    rhs: np.ndarray
    condition_number: np.ndarray
    noise_gain: np.ndarray
    residuals: np.ndarray
    well_conditioned: np.ndarray


def check_slant_ranges(name: str, ranges: np.ndarray, vertical: Any) -> None:
    """Refuse slant ranges shorter than the vertical distance between the vehicle and the beacon: a slant range is
    at least that long, and a shorter one (ranges in the wrong units, or the wrong depth) would still give a fix
    that looks valid. A range may fall short by measurement noise near the point overhead: the tolerance is 1 % of
    the vertical distance, and at least 5 m."""
    dz = np.asarray(vertical, dtype=float)
    short = np.isfinite(ranges) & (ranges < dz - np.maximum(5.0, 0.01 * dz))
    if short.any():
        i = np.flatnonzero(short.ravel())[0]
        raise ValueError(f"{name} holds slant ranges shorter than the vertical distance to the beacon (the depth): "
                         f"{int(short.sum())} of them, e.g. {ranges.ravel()[i]:g} m against "
                         f"{np.broadcast_to(dz, ranges.shape).ravel()[i]:g} m. A slant range cannot be shorter: check "
                         "the units of the ranges and the depth")


def virtual_beacon_lsq(ranges: ArrayLike, beacon_positions: ArrayLike, dr_positions: ArrayLike, *,
                       depth: ArrayLike = 0.0,
                       beacon_depths: ArrayLike = 0.0, max_condition: float = 1e3,
                       max_noise_gain: float = 100.0) -> VirtualBeaconFix:
    r"""Paper E's virtual moving long baseline: a closed-form fix from N ranges to a moving beacon.

    The mother ship (the beacon) was at :math:`a_i` (paper E: :math:`AB_i`) at epoch :math:`i` and the
    submersible's dead reckoning at :math:`p^\mathrm{DR}_i` (:math:`P_i`). Shifting each ship position by the
    submersible's DR displacement from epoch :math:`i` to now makes a **virtual beacon**
    :math:`b^\mathrm{v}_i = a_i + (p^\mathrm{DR}_N - p^\mathrm{DR}_i)` (paper E, eq. 14: :math:`VB_i = AB_i +
    \sum_{n=i}^{3} v_n dt`) whose range from the *current* position is :math:`r_i`. With the depth :math:`z` known
    (pressure sensor) and the ship's transducer at depths :math:`z^\mathrm{a}_i`, the spheres
    :math:`\lVert (x, y, z) - (b^\mathrm{v}_i, z^\mathrm{a}_i)\rVert = r_i`,
    differenced pairwise around the cycle (1-2, 2-3, ..., N-1; paper E, eq. 16), are linear in :math:`(x, y)`:

    .. math::

        (x_{j} - x_i)\,x + (y_{j} - y_i)\,y = \frac{r_i^2 - r_{j}^2 + \ell_{j}^2 - \ell_i^2}{2}
        - z\,(z^\mathrm{a}_{j} - z^\mathrm{a}_i), \quad j = i + 1 \bmod N,
        \quad \ell_i^2 = x_i^2 + y_i^2 + (z^\mathrm{a}_i)^2,

    :math:`A p = g` (paper E: :math:`A X = B`), solved by least squares :math:`\hat p = A^+ g` (eq. 17). The
    cyclic rows sum to zero, so only :math:`N - 1` of them are independent (the last adds no information); the
    answer is still the least-squares one. When all :math:`z^\mathrm{a}_i` are equal (a surface ship) the depth
    cancels exactly.

    Conditioning: the rows of :math:`A` are the baselines between virtual beacons, so :math:`A` is singular when
    they are collinear, and the fix's sensitivity to the ranges (``noise_gain``) grows like range / baseline: a
    submersible that moves little between the epochs, compared with its range, gets a useless fix (paper E:
    lengthen the sampling interval).

    Parameters
    ----------
    ranges : array_like, shape (N,) or (M, N)
        Ranges at the N epochs [m] (slant ranges when depths are given), N >= 3.
    beacon_positions : array_like, shape (N, 2) or (M, N, 2)
        Horizontal beacon (ship) positions :math:`AB_i` at those epochs [m].
    dr_positions : array_like, shape (N, 2) or (M, N, 2)
        The vehicle's DR positions :math:`P_i` at those epochs [m] (only differences matter; last = now).
    depth : float, default 0
        Vehicle depth :math:`h` [m], positive down.
    beacon_depths : float or array_like, shape (N,), default 0
        Beacon depths :math:`z_i` [m] (0: a surface ship).
    max_condition : float, default 1e3
        Condition number of :math:`A` above which an ``IllConditionedWarning`` is given.
    max_noise_gain : float, default 100
        Noise gain [m per m] above which an ``IllConditionedWarning`` is given.

    Returns
    -------
    VirtualBeaconFix

    Warns
    -----
    IllConditionedWarning
        When the fix is unreliable (limits exceeded) or the problem is singular (NaN fix).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.lsq import virtual_beacon_lsq
    >>> ship = np.array(
    ...     [[0.0, 0.0], [400.0, 100.0], [700.0, 400.0], [800.0, 800.0]]
    ... )
    >>> sub = np.array(
    ...     [
    ...         [-900.0, -1100.0],
    ...         [-850.0, -1050.0],
    ...         [-800.0, -1000.0],
    ...         [-750.0, -950.0],
    ...     ]
    ... )
    >>> # slant ranges, sub at 1000 m
    >>> r = np.sqrt(np.sum((ship - sub) ** 2, axis=1) + 1000.0**2)
    >>> fix = virtual_beacon_lsq(r, ship, sub, depth=1000.0)
    >>> np.round(fix.position, 6)
    array([-750., -950.])
    """
    r = as_finite("ranges", ranges, ndim=(1, 2), max_abs=MAX_COORDINATE)
    if np.any(r < 0):
        raise ValueError(f"ranges must be >= 0; got {r[r < 0].flat[0]:g}")
    N = r.shape[-1]
    if N < 3:
        raise ValueError(f"virtual_beacon_lsq needs ranges at N >= 3 epochs (paper E uses 4); got {N}")
    ab = as_finite("beacon_positions", beacon_positions, ndim=(2, 3), max_abs=MAX_COORDINATE)
    P = as_finite("dr_positions", dr_positions, ndim=(2, 3), max_abs=MAX_COORDINATE)
    for name, arr in (("beacon_positions", ab), ("dr_positions", P)):
        if arr.shape[-2:] != (N, 2):
            raise ValueError(f"{name} must have shape ({N}, 2) or (M, {N}, 2), one position per entry of ranges "
                             f"({N}); got {arr.shape}")
    h = float(as_finite("depth", depth, ndim=0, max_abs=MAX_COORDINATE))
    z = as_finite("beacon_depths", beacon_depths, ndim=(0, 1), max_abs=MAX_COORDINATE)
    if z.ndim == 1 and z.shape != (N,):
        raise ValueError(f"beacon_depths must be a number or have shape ({N},); got {z.shape}")
    z = np.broadcast_to(z, (N,))
    check_slant_ranges("ranges", r, np.abs(h - z))
    mc, mg = as_thresholds(max_condition, max_noise_gain)
    M = common_runs(dict(ranges=r.shape[0] if r.ndim == 2 else None,
                         beacon_positions=ab.shape[0] if ab.ndim == 3 else None,
                         dr_positions=P.shape[0] if P.ndim == 3 else None))
    batched = M is not None
    Mb = M or 1
    r = np.broadcast_to(r, (Mb, N))
    ab = np.broadcast_to(ab, (Mb, N, 2))
    P = np.broadcast_to(P, (Mb, N, 2))

    vb = ab + (P[:, -1:, :] - P)
    nxt = np.roll(np.arange(N), -1)                                     # j = i + 1 (mod N)
    A = vb[:, nxt] - vb
    d2 = np.sum(vb**2, axis=-1) + z**2
    B = 0.5 * (r**2 - r[:, nxt] ** 2 + d2[:, nxt] - d2) - h * (z[nxt] - z)
    X, _, cond, _ = batched_lstsq(A, B)
    # sensitivity of X to the ranges: dB_i/dr_i = r_i, dB_i/dr_j = -r_j
    dBdr = np.zeros((Mb, N, N))
    rows = np.arange(N)
    dBdr[:, rows, rows] = r
    dBdr[:, rows, nxt] = -r[:, nxt]
    with np.errstate(invalid="ignore"):
        pinv = np.where(np.isfinite(cond)[:, None, None], np.linalg.pinv(A), np.nan)
        G = pinv @ dBdr
        gain = np.sqrt(np.sum(G**2, axis=(-2, -1)))
    gain = np.where(np.isfinite(cond), gain, np.inf)
    well = warn_conditioning(cond, gain, mc, mg, "the virtual-beacon least-squares problem")
    with np.errstate(invalid="ignore"):
        predicted = np.sqrt(np.sum((X[:, None, :] - vb) ** 2, axis=-1) + (h - z) ** 2)
    residuals = r - predicted

    def out(a: np.ndarray) -> np.ndarray:
        return a if batched else a[0]

    return VirtualBeaconFix(position=out(X), virtual_beacons=out(vb), design=out(A), rhs=out(B),
                            condition_number=out(cond), noise_gain=out(gain), residuals=out(residuals),
                            well_conditioned=out(well))
