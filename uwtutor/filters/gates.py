r"""Gates: accept or reject an innovation before it corrects the estimate (outlier rejection).

A gate sees, at each update, the innovation :math:`y_k`, its covariance :math:`S_k` and the rest of the
linearization (a :class:`GateContext`) and says, run by run, whether the measurement is to be used. A rejected
measurement leaves that run at its prediction, as a missing one would; the gate's :meth:`Gate.after_update`
hook may then change the estimate further (paper E replaces it by a linear extrapolation).

:class:`ChiSquareGate` is the classic test: under a consistent filter the normalized innovation squared
:math:`\nu_k = y_k^T S_k^{-1} y_k` follows :math:`\chi^2_m`, so a measurement with
:math:`\nu_k > \chi^2_m(1 - \alpha)` is improbable at the level :math:`\alpha`
(Bar-Shalom, Li and Kirubarajan 2001, sec. 5.4).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .._linalg import quadratic_form
from .._validate import as_finite

__all__ = ["Gate", "GateContext", "ChiSquareGate", "normalized_innovation_squared"]


@dataclass(frozen=True)
class GateContext:
    """What a gate sees at one update, for all runs at once (runs axis ``M`` first).

    Attributes
    ----------
    k : int
        Index of the step.
    z : ndarray, shape (M, m)
        Measurement (NaN rows: no measurement for that run).
    z_pred : ndarray, shape (M, m)
        Predicted measurement.
    y : ndarray, shape (M, m)
        Innovation (NaN rows: no measurement for that run).
    S : ndarray, shape (M, m, m)
        Innovation covariance.
    H : ndarray, shape (M, m, n)
        Measurement Jacobian at the prediction.
    R : ndarray, shape (m, m) or (M, m, m)
        Measurement noise covariance.
    x_prior : ndarray, shape (M, n)
        The prediction.
    P_prior : ndarray, shape (M, n, n)
        Its covariance.
    """

    k: int
    z: np.ndarray
    z_pred: np.ndarray
    y: np.ndarray
    S: np.ndarray
    H: np.ndarray
    R: np.ndarray
    x_prior: np.ndarray
    P_prior: np.ndarray


def normalized_innovation_squared(y: np.ndarray, S: np.ndarray) -> np.ndarray:
    r""":math:`\nu = y^T S^{-1} y` over stacked innovations ``(..., m)`` and covariances ``(..., m, m)``.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.filters.gates import normalized_innovation_squared
    >>> normalized_innovation_squared(np.array([[2.0]]), np.array([[[4.0]]]))
    array([1.])
    """
    return quadratic_form(y, S, "S")


class Gate:
    """Base class of gates: accept everything (override :meth:`accept`, and :meth:`after_update` if needed)."""

    def accept(self, ctx: GateContext) -> np.ndarray:
        """A bool array ``(M,)``: True where the run's measurement is to be used."""
        return np.ones(ctx.y.shape[0], dtype=bool)

    def after_update(self, x: np.ndarray, P: np.ndarray, accepted: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        """Called after every update with the posterior ``x`` (M, n), ``P`` (M, n, n) and the accepted mask
        (False also where there was no measurement); returns the estimate to keep. Default: unchanged."""
        return x, P


class ChiSquareGate(Gate):
    r"""Accept a measurement when its NIS is below the chi-square quantile :math:`\chi^2_m(p)`.

    Parameters
    ----------
    probability : float, optional
        The quantile ``p`` (default 0.99: a consistent filter rejects 1 % of good measurements).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.filters import ChiSquareGate, GateContext
    >>> gate = ChiSquareGate(0.99)
    >>> round(gate.threshold(1), 3)
    6.635
    >>> y = np.array([[1.0], [10.0]]); S = np.full((2, 1, 1), 4.0)
    >>> ctx = GateContext(k=0, z=y, z_pred=0 * y, y=y, S=S, H=np.ones((2, 1, 2)), R=np.eye(1),
    ...                   x_prior=np.zeros((2, 2)), P_prior=np.tile(np.eye(2), (2, 1, 1)))
    >>> gate.accept(ctx)
    array([ True, False])
    """

    def __init__(self, probability: Any = 0.99) -> None:
        p = float(as_finite("probability", probability))
        if not 0.0 < p < 1.0:
            raise ValueError(f"probability must lie strictly between 0 and 1, e.g. 0.99; got {p}")
        self.probability = p

    def threshold(self, m: int) -> float:
        """The NIS threshold for a measurement of size ``m``."""
        from scipy import stats      # imported when needed: scipy.stats is heavy and most filters never gate

        return float(stats.chi2.ppf(self.probability, m))

    def accept(self, ctx: GateContext) -> np.ndarray:
        nis = normalized_innovation_squared(ctx.y, ctx.S)
        with np.errstate(invalid="ignore"):
            return nis <= self.threshold(ctx.y.shape[-1])
