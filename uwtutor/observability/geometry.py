"""Geometry of one beacon: the two mirror fixes of two ranges and a displacement, the mirror point, an error ellipse."""

from __future__ import annotations


import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validate import (
    MAX_COORDINATE,
    as_covariance,
    as_finite,
    as_int,
    as_points,
    as_scalar,
)
from ._common import _warn

__all__ = ["two_range_fix", "mirror_point", "error_ellipse"]


def two_range_fix(beacon: ArrayLike, ranges: ArrayLike, displacement: ArrayLike) -> NDArray[np.float64]:
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


def mirror_point(point: ArrayLike, beacon: ArrayLike, direction: ArrayLike) -> NDArray[np.float64]:
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


def error_ellipse(covariance: ArrayLike, center: ArrayLike = (0.0, 0.0), scale: float = 1.0,
                  n_points: int = 73) -> NDArray[np.float64]:
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
