"""Small linear-algebra kernels shared across layers (kept here so that no layer imports one to its right)."""

from __future__ import annotations

import numpy as np

__all__ = ["quadratic_form", "positive_definite", "psd_violations", "line_of_sight", "distances"]


def line_of_sight(positions: np.ndarray, beacon: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Ranges, unit lines of sight and where they are defined, without checks: the per-step path of the filters,
    least squares and bounds (:func:`uwtutor.models.range.line_of_sight` is the checked public form).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor._linalg import line_of_sight
    >>> r, los, defined = line_of_sight(np.array([[3.0, 4.0], [0.0, 0.0]]), np.zeros(2))
    >>> r, los[0], defined
    (array([5., 0.]), array([0.6, 0.8]), array([ True, False]))
    """
    d = positions - beacon
    r = _length(d, "hypot")
    defined = r != 0.0                   # a NaN position stays NaN (it is not "on the beacon")
    safe = np.where(defined, r, 1.0)
    los = d / safe[..., None]
    return r, los, defined


def distances(positions: np.ndarray, beacon: np.ndarray, formula: str = "hypot") -> np.ndarray:
    r"""The ranges :math:`\lVert p - b \rVert` over the last axis (2 or 3 coordinates; broadcast), without checks:
    the distance the measurement models, least squares, bounds, scenarios and datasets all compute here.

    ``formula="hypot"`` (the default, and the only form :func:`line_of_sight` uses) takes ``np.hypot`` of the
    coordinates, one after the other: rounded once per coordinate, and no overflow or underflow of the squares.
    ``formula="norm"`` is the square root of the sum of the squares, exactly as ``np.linalg.norm(p - b, axis=-1)``
    computes it. The two differ in the last bit (one ulp) for about one range in six, and a simulation's draws
    depend on its true ranges: the scenarios written with the norm keep it, so that their runs (and the book's
    numbers) stay the same, bit for bit.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor._linalg import distances
    >>> distances(np.array([[3.0, 4.0], [6.0, 8.0]]), np.zeros(2))
    array([ 5., 10.])
    >>> distances(np.array([3.0, 4.0, 12.0]), np.zeros(3))         # a slant range
    np.float64(13.0)
    """
    return _length(positions - beacon, formula)


def _length(d: np.ndarray, formula: str) -> np.ndarray:
    """The Euclidean length of ``d`` over its last axis by ``formula`` (:func:`distances`)."""
    if formula == "norm":
        return np.linalg.norm(d, axis=-1)
    if formula != "hypot":
        raise ValueError(f'formula must be "hypot" or "norm"; got {formula!r}')
    r = np.hypot(d[..., 0], d[..., 1])
    for i in range(2, d.shape[-1]):                  # a third coordinate: the slant range from the horizontal one
        r = np.hypot(r, d[..., i])
    return r


def positive_definite(cov: np.ndarray) -> np.ndarray:
    """Which of the stacked matrices ``(..., n, n)`` are positive definite, by the test of :func:`quadratic_form`:
    Sylvester's criterion (:math:`C_{00} > 0`, :math:`C_{00}C_{11} - C_{01}^2 > 0`) for n <= 2, a Cholesky
    factorization for larger ones. A NaN or infinite matrix is not.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor._linalg import positive_definite
    >>> positive_definite(np.array([np.eye(2), [[1.0, 2.0], [2.0, 1.0]]]))
    array([ True, False])
    """
    cov = np.asarray(cov, dtype=float)
    n = cov.shape[-1]
    if n <= 2:
        if n == 1:
            det = cov[..., 0, 0]
        else:
            det = cov[..., 0, 0] * cov[..., 1, 1] - cov[..., 0, 1] * cov[..., 0, 1]
        return (det > 0) & (cov[..., 0, 0] > 0) & np.isfinite(det)
    flat = cov.reshape((-1, n, n))
    ok = np.isfinite(flat).all(axis=(-1, -2))
    try:
        np.linalg.cholesky(np.where(ok[:, None, None], flat, np.eye(n)))      # all at once: the usual case
        return ok.reshape(cov.shape[:-2])
    except np.linalg.LinAlgError:
        pass
    for i in np.flatnonzero(ok):
        try:
            np.linalg.cholesky(flat[i])
        except np.linalg.LinAlgError:
            ok[i] = False
    return ok.reshape(cov.shape[:-2])


def quadratic_form(vec: np.ndarray, cov: np.ndarray, name: str) -> np.ndarray:
    r""":math:`v^T C^{-1} v` over stacked vectors ``(..., n)`` and matrices ``(..., n, n)``; explicit for n <= 2.

    NaN where the vector has a NaN (no measurement); an error naming ``name`` where a matrix that is used is not
    positive definite. The NEES, the NIS and the chi-square gate all call this one function.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor._linalg import quadratic_form
    >>> quadratic_form(
    ...     np.array([[2.0, 0.0], [np.nan, 1.0]]),
    ...     np.tile(np.eye(2) * 4.0, (2, 1, 1)),
    ...     "S",
    ... )
    array([ 1., nan])
    """
    n = vec.shape[-1]
    if n <= 2:
        if n == 1:
            det = cov[..., 0, 0]
            num = vec[..., 0] ** 2
        else:
            a, b, d = cov[..., 0, 0], cov[..., 0, 1], cov[..., 1, 1]
            e0, e1 = vec[..., 0], vec[..., 1]
            det = a * d - b * b
            num = d * e0 * e0 - 2.0 * b * e0 * e1 + a * e1 * e1
        used = np.isfinite(vec).all(axis=-1)
        if np.any(~positive_definite(cov) & used):
            raise ValueError(f"{name} must be positive definite wherever it is used; found a matrix that is not "
                             "(determinant or variance <= 0, or not finite)")
        with np.errstate(divide="ignore", invalid="ignore"):
            return num / det
    out = np.full(vec.shape[:-1], np.nan)
    ok = np.isfinite(vec).all(axis=-1)
    if ok.any():
        c = cov[ok]
        if not np.isfinite(c).all():
            raise ValueError(f"{name} must be finite wherever it is used")
        try:
            L = np.linalg.cholesky(c)                 # fails unless positive definite
        except np.linalg.LinAlgError:
            raise ValueError(f"{name} must be positive definite wherever it is used; found a matrix that is "
                             "not") from None
        w = np.linalg.solve(L, vec[ok][..., None])[..., 0]     # v^T C^-1 v = |L^-1 v|^2
        out[ok] = np.einsum("...i,...i->...", w, w)
    return out


def psd_violations(P: np.ndarray, rtol: float = 1e-9) -> np.ndarray:
    r"""Runs whose covariance, held runs-last ``(n, n, M)``, is visibly not positive semi-definite: a bool ``(M,)``.

    The test (cheap enough for every filter step): every entry finite, every variance :math:`P_{ii} \ge 0` and
    every 2x2 principal minor :math:`P_{ii}P_{jj} - P_{ij}^2 \ge -\mathrm{rtol}\, P_{ii}P_{jj}`. For ``n = 2`` it
    is exactly "PSD to within rounding"; for larger ``n`` it is necessary (it catches a lost variance or a
    correlation beyond +-1, the way round-off breaks a covariance), not sufficient.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor._linalg import psd_violations
    >>> # two runs, runs-last
    >>> P = np.stack([np.eye(2), [[1.0, 2.0], [2.0, 1.0]]], axis=-1)
    >>> psd_violations(P)
    array([False,  True])
    """
    if _looks_psd(P, rtol):
        return np.zeros(P.shape[-1], dtype=bool)
    n = P.shape[0]
    diag = np.einsum("iim->im", P)
    finite = np.isfinite(P).all(axis=(0, 1))
    bad = ~finite | (diag < 0.0).any(axis=0)
    if n > 1:
        with np.errstate(over="ignore", invalid="ignore"):
            rows, cols = np.triu_indices(n, 1)
            prod = diag[rows] * diag[cols]
            off = P[rows, cols]
            bad |= (prod - off * off < -rtol * prod).any(axis=0)
    return bad


_PAIRS: dict[int, tuple[np.ndarray, np.ndarray]] = {}


def _looks_psd(P: np.ndarray, rtol: float) -> bool:
    """The fast all-runs form of :func:`psd_violations` (a handful of array operations): True if no run fails."""
    n = P.shape[0]
    diag = np.einsum("iim->im", P)
    with np.errstate(over="ignore", invalid="ignore"):
        if not (np.isfinite(P.sum()) and diag.min() >= 0.0):
            return False
        if n == 1:
            return True
        rows, cols = _PAIRS.get(n) or _PAIRS.setdefault(n, np.triu_indices(n, 1))
        prod = diag[rows] * diag[cols]
        off = P[rows, cols]
        return bool((prod - off * off >= -rtol * prod).all())
