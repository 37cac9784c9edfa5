"""Small linear-algebra kernels shared across layers (kept here so that no layer imports one to its right)."""

from __future__ import annotations

import numpy as np

__all__ = ["quadratic_form"]


def quadratic_form(vec: np.ndarray, cov: np.ndarray, name: str) -> np.ndarray:
    r""":math:`v^T C^{-1} v` over stacked vectors ``(..., n)`` and matrices ``(..., n, n)``; explicit for n <= 2.

    NaN where the vector has a NaN (no measurement); an error naming ``name`` where a matrix that is used is not
    positive definite. The NEES, the NIS and the chi-square gate all call this one function.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor._linalg import quadratic_form
    >>> quadratic_form(np.array([[2.0, 0.0], [np.nan, 1.0]]), np.tile(np.eye(2) * 4.0, (2, 1, 1)), "S")
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
        if np.any((det <= 0) & np.isfinite(vec).all(axis=-1)):
            raise ValueError(f"{name} must be positive definite wherever it is used; found a matrix with "
                             "determinant <= 0")
        with np.errstate(divide="ignore", invalid="ignore"):
            return num / det
    out = np.full(vec.shape[:-1], np.nan)
    ok = np.isfinite(vec).all(axis=-1)
    if ok.any():
        try:
            sol = np.linalg.solve(cov[ok], vec[ok][..., None])[..., 0]
        except np.linalg.LinAlgError:
            raise ValueError(f"{name} must be positive definite wherever it is used; found a singular "
                             "matrix") from None
        out[ok] = np.einsum("...i,...i->...", vec[ok], sol)
    return out
