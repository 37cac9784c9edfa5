r"""Fading-memory range-only EKFs for multiplicative range noise (paper D's ISFEKF and LS-ISFEKF), batched.

**Model** (Zhu et al. 2019, paper D, eqs. 10-11). The horizontal position :math:`\mathbf x_k` moves by the
dead-reckoned displacement :math:`\mathbf u_k` and is observed through a range whose error grows with the range
(a sound-speed error):

.. math::

    \mathbf x_k = \mathbf x_{k-1} + \mathbf u_k + \mathbf w_k, \quad \mathbf w_k \sim N(0, \mathbf Q), \qquad
    z_k = \gamma_k\, h(\mathbf x_k) + v_k, \quad \gamma_k \sim N(\mu_\gamma, \sigma_\gamma^2),\
    v_k \sim N(0, R),

with :math:`h(\mathbf x) = \lVert \mathbf x - \mathbf b\rVert`. A vehicle converting travel times with a speed
:math:`c` while the true effective speed is :math:`c_\mathrm e` measures :math:`\gamma_k \approx c / c_\mathrm e`:
:math:`\mu_\gamma = 0.98` for paper D's 1470 against 1500 m/s (see :func:`range_factor_moments`).

**Linearization** at the prediction :math:`\hat{\mathbf x}^-_k`: :math:`h(\mathbf x) \approx \mathbf C_k \mathbf x
+ d_k` with :math:`\mathbf C_k = (\hat{\mathbf x}^-_k - \mathbf b)^\mathsf T / \lVert\hat{\mathbf x}^-_k -
\mathbf b\rVert` and :math:`d_k = h(\hat{\mathbf x}^-_k) - \mathbf C_k\hat{\mathbf x}^-_k = -\mathbf C_k\mathbf b`
(zero for a beacon at the origin). The multiplicative noise then adds
:math:`\sigma_\gamma^2\,\mathrm E[(\mathbf C_k\mathbf x_k + d_k)^2]` to the innovation variance, which needs the
prior mean :math:`\mathbf m_k` and second moment :math:`\boldsymbol\Xi_k` of the state (paper D's
:math:`\mathbf J_i`, :math:`\mathbf S_i`, eqs. 14-15):

.. math::

    \mathbf m_k = \mathbf m_{k-1} + \mathbf u_k, \qquad
    \boldsymbol\Xi_k = \boldsymbol\Xi_{k-1} + \mathbf m_{k-1}\mathbf u_k^\mathsf T + \mathbf u_k
    \mathbf m_{k-1}^\mathsf T + \mathbf u_k\mathbf u_k^\mathsf T + \mathbf Q,

    T_k = \mathbf C_k\boldsymbol\Xi_k\mathbf C_k^\mathsf T + 2 (\mathbf C_k\mathbf m_k) d_k + d_k^2
    = \mathrm E[(\mathbf C_k\mathbf x_k + d_k)^2].

**Fading factor** (Zhou and Xi 1990; paper D eqs. 16-21). With the innovation
:math:`\tilde z_k = z_k - \mu_\gamma h(\hat{\mathbf x}^-_k)` and its power estimated with a forgetting factor
:math:`0 < \rho \le 1`,

.. math::

    V_1 = \tilde z_1^2, \qquad V_k = \frac{\rho V_{k-1} + \tilde z_k^2}{1 + \rho},

    \mathcal M_k = V_k - \sigma_\gamma^2 T_k - \mu_\gamma^2 \mathbf C_k\mathbf Q\mathbf C_k^\mathsf T - \beta_k R,
    \qquad \mathcal N_k = \mu_\gamma^2\, \mathbf C_k \mathbf P_{k-1}\mathbf C_k^\mathsf T,
    \qquad \lambda_k = \max(1, \mathcal M_k / \mathcal N_k),

    \mathbf P^-_k = \lambda_k \mathbf P_{k-1} + \mathbf Q .

:math:`\mathcal M_k/\mathcal N_k` compares the innovation power actually seen with the power the filter predicts
from its own covariance: when the model is right, :math:`\mathrm E[V_k] = \mu_\gamma^2\mathbf C_k
\mathbf P^-_k\mathbf C_k^\mathsf T + \sigma_\gamma^2 T_k + R`, so :math:`\mathrm E[\mathcal M_k] \approx
\mathcal N_k + (1 - \beta_k) R` and :math:`\lambda_k` stays at 1 unless the innovations are larger than they
should be (a wrong model, a jump of the state); then :math:`\lambda_k > 1` inflates the prediction's covariance,
the gain grows and the filter forgets the past faster.

**Weakening factor** :math:`\beta_k`. Zhou and Xi's filter uses a constant :math:`\beta \ge 1` to make
:math:`\lambda_k` less eager. Paper D's ISFEKF (eq. 27) sets :math:`\beta_k = \mathbf C_k\mathbf m_k` (here
:math:`\mathbf C_k\mathbf m_k + d_k = \mathbf C_k(\mathbf m_k - \mathbf b)`, the same for a beacon at the origin
and invariant to moving the frame): about the predicted range, hundreds to thousands. Then
:math:`\beta_k R \gg R`, and :math:`\lambda_k > 1` only when the smoothed innovation power exceeds its expected
value by about :math:`R\,h(\hat{\mathbf x}^-_k)` square metres: a range-dependent threshold that lets the filter
fade near the beacon but suppresses fading after one gross range error far from it.

**Update** (eqs. 22-25, covariance in Joseph form):

.. math::

    R_\delta = \sigma_\gamma^2 T_k + \mu_\gamma^2 \mathbf C_k\mathbf P^-_k\mathbf C_k^\mathsf T + R, \qquad
    \mathbf K_k = \frac{\mu_\gamma}{R_\delta}\mathbf P^-_k\mathbf C_k^\mathsf T, \qquad
    \hat{\mathbf x}_k = \hat{\mathbf x}^-_k + \mathbf K_k\tilde z_k,

    \mathbf P_k = (\mathbf I - \mu_\gamma\mathbf K_k\mathbf C_k)\mathbf P^-_k
    (\mathbf I - \mu_\gamma\mathbf K_k\mathbf C_k)^\mathsf T + \mathbf K_k (\sigma_\gamma^2 T_k + R)
    \mathbf K_k^\mathsf T .

This is the range-only EKF's update for the scaled range :math:`z_k / \mu_\gamma` with noise variance
:math:`(\sigma_\gamma^2 T_k + R)/\mu_\gamma^2`, and this module calls exactly that update (the step functions of
``uwtutor.filters.ekf``). Hence with :math:`\mu_\gamma = 1`, :math:`\sigma_\gamma = 0` and ``fading=False``
the filter *is* the plain EKF, number for number.

Special cases, by parameters:

=============================================  =====================================================================
filter                                         parameters
=============================================  =====================================================================
plain EKF (additive noise)                     ``mu_gamma=1, sigma_gamma=0, fading=False``
suboptimal fading EKF (Zhou and Xi 1990)       ``mu_gamma=1, sigma_gamma=0, beta=1.0``
fading EKF for multiplicative noise (paper D)  ``mu_gamma, sigma_gamma, beta=1.0``
ISFEKF (paper D)                               ``mu_gamma, sigma_gamma, beta="range"``
LS-EKF, LS-ISFEKF (paper D)                    :func:`~uwtutor.pipelines.ls_fading.ls_fading_ekf` (grid-search start,
                                               then one of the above)
=============================================  =====================================================================

Forms: :func:`fading_ekf` runs ``M`` Monte Carlo runs of ``K`` steps in one call (explicit 2x2 algebra on arrays of
length ``M``, like ``uwtutor.filters.ekf``: 1000 runs of 151 steps take a few tens of milliseconds);
:class:`FadingEKF` follows the filter protocol (``predict``, ``update``, ``x``, ``P``, ``y``, ``S``, ``run``)
with the same arithmetic; :func:`~uwtutor.pipelines.ls_fading.ls_fading_ekf` adds paper D's least-squares pre-location
(``uwtutor.lsq``).

Notes on paper D's text (see chapter 5): its eq. (30) writes :math:`\mu_\gamma = 1 - (1470 - 1500)/1500 = 1.02`,
but its own model (eqs. 2-4) gives ranges 2 % *short*, :math:`\mu_\gamma = 0.98`; and it starts the second moment
at :math:`\mathbf S_1 = \mathbf P_1`, while a second moment is :math:`\mathbf P_1 + \hat{\mathbf x}_1
\hat{\mathbf x}_1^\mathsf T` (the default here, ``second_moment0=None``). With :math:`\mathbf S_1 = \mathbf P_1`
the term :math:`T_k` can turn negative; it is clipped at zero.

References
----------
Zhu Z., Han S., Guo Z., Liu J. (2019). Single beacon location algorithm based on nonlinear fading filter under
multiplicative noise background. J. Electronics & Information Technology 41(1), 165-171 (paper D), eqs. (10)-(27).

Zhou D., Xi Y. (1990). Suboptimal fading extended Kalman filtering for nonlinear systems. Control and Decision
5(5), 1-6.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from ..acoustics import range_factor
from .._cancel import checkpoint
from .._validate import (MAX_COORDINATE, as_covariance, as_flag, as_finite, as_per_run_scalar, as_range_array,
                        common_runs, readonly)
from ..models.dead_reckoning import DeadReckoning
from ..models.range import RangeToBeacon
from .base import FilterResult
from .engine import ExtendedKalmanFilter, _runs_first
from ._packed import (N_ROWS, ROW_PXX, ROW_PXY, ROW_PYX, ROW_PYY, ROW_X, ROW_Y, check_variances_where_measured,
                      fixed_beacon, initial_state, noise_parameters, pack, predict_step, result_fields, runs_first,
                      sequence_inputs, steps_and_times, unpack_runs_last, update_step)

__all__ = [
    "range_factor_moments",
    "fading_ekf",
    "FadingEKF",
    "FadingResult",
]

# Rows of the packed (6, M) fading memory: prior mean m (2), second moment Xi (xx, xy, yy) and V.
_MX, _MY, _XXX, _XXY, _XYY, _V = range(6)

#: Names of the per-step outputs in ``FilterResult.extras`` (besides ``"updated"``).
_EXTRAS = ("fading_factor", "weakening_factor", "innovation_power", "fading_numerator", "fading_denominator",
           "multiplicative_variance")


def range_factor_moments(assumed_speed: float = 1470.0, effective_speed: float = 1500.0,
                         speed_sigma: float = 1.0) -> tuple[float, float]:
    r"""Mean and standard deviation of the multiplicative range factor :math:`\gamma` from sound-speed errors.

    A vehicle converting the travel time :math:`\tau = r / c'_k` with the speed :math:`c` reports
    :math:`r_k = (c / c'_k)\, r`. With the true speed :math:`c'_k = c_\mathrm e + \epsilon_k`,
    :math:`\epsilon_k \sim N(0, \sigma_c^2)` (the book's :math:`c = c_\mathrm e + \Delta c + \delta c`,
    :math:`\Delta c = c - c_\mathrm e`), to first order in :math:`\sigma_c / c_\mathrm e`

    .. math::

        \mu_\gamma = \frac{c}{c_\mathrm e} = 1 + \frac{\Delta c}{c_\mathrm e}, \qquad
        \sigma_\gamma = \frac{c}{c_\mathrm e}\,\frac{\sigma_c}{c_\mathrm e}.

    Paper D (eq. 4) writes :math:`\mu_\gamma = 1 + \Delta c / c'` and :math:`\sigma_\gamma = \sigma_c / c'` (its
    :math:`c'` is the book's :math:`c_\mathrm e`); the factor :math:`c / c_\mathrm e` in :math:`\sigma_\gamma`
    (0.98 here) is second order. For 1470 against 1500 m/s, :math:`\mu_\gamma = 0.98`: ranges 2 % short (paper
    D's eq. 30 prints 1.02, a sign slip).

    Parameters
    ----------
    assumed_speed : float, default 1470
        Speed :math:`c` the vehicle converts with [m/s], > 0.
    effective_speed : float, default 1500
        Mean true effective speed :math:`c_\mathrm e` [m/s], > 0.
    speed_sigma : float, default 1
        Standard deviation :math:`\sigma_c` of the true speed from ping to ping [m/s], >= 0.

    Returns
    -------
    mu_gamma : float
        :math:`\mu_\gamma`.
    sigma_gamma : float
        :math:`\sigma_\gamma`.

    Examples
    --------
    >>> from uwtutor.filters.fading import range_factor_moments
    >>> mu, sigma = range_factor_moments(1470.0, 1500.0, 1.0)
    >>> round(mu, 4), round(sigma * 1500, 4)
    (0.98, 0.98)
    """
    c = _positive_scalar("assumed_speed", assumed_speed)
    ce = _positive_scalar("effective_speed", effective_speed)
    if not 1.0 <= ce <= 1e5:          # a sound speed is a few km/s: [1, 1e5] m/s bounds every medium (and c / ce^2)
        raise ValueError(f"effective_speed must lie in [1, 1e5] m/s (a sound speed); got {ce:g}")
    sc = float(as_finite("speed_sigma", speed_sigma, ndim=0))
    if sc < 0:
        raise ValueError(f"speed_sigma must be >= 0 (a standard deviation); got {sc:g}")
    mu, sigma = range_factor(c, ce, sc)
    return float(mu), float(sigma)


def _positive_scalar(name: str, value: Any) -> float:
    v = float(as_finite(name, value, ndim=0))
    if v <= 0:
        raise ValueError(f"{name} must be > 0; got {v:g}")
    return v


# --- the step (the only implementation of the fading arithmetic) ----------------------------------------------------

@dataclass(frozen=True)
class _Params:
    """Validated filter parameters; ``mu``/``sigma2`` are floats or (M,) arrays, ``beta`` a float or None (range)."""

    q4: np.ndarray                                 # (4, 1), or (K, 4, 1) one per step
    Q: np.ndarray                                  # (2, 2), or (K, 2, 2)
    R: Any                                         # a float, or (K,) one per step
    beacon: tuple[float, float]
    mu: Any
    sigma2: Any
    rho: float
    beta: float | None
    fading: bool


def _fading_step(s: np.ndarray, mem: np.ndarray, started: np.ndarray, u: np.ndarray, z: np.ndarray,
                 use: np.ndarray, p: _Params, prior: np.ndarray, post: np.ndarray, y_out: np.ndarray,
                 S_out: np.ndarray, diag: np.ndarray) -> np.ndarray:
    """One predict + update of the packed states ``s`` (6, M) with the fading memory ``mem`` (6, M, in place).

    ``started`` (M,) bool marks the runs whose ``V`` has been initialized (updated in place). ``prior`` and
    ``post`` (6, M) receive the prediction (with the fading factor applied) and the posterior; ``y_out``/``S_out``
    (M,) the innovation and its variance; ``diag`` (6, M) the per-step diagnostics in the order of ``_EXTRAS``.
    Returns the ``use`` array actually applied (runs whose prediction is on the beacon removed).
    """
    mx, my = mem[_MX], mem[_MY]
    ux, uy = u[0], u[1]
    # moments of the state's prior distribution (paper D, eqs. 14-15; F = G = I)
    mem[_XXX] += 2.0 * mx * ux + ux * ux + p.Q[0, 0]
    mem[_XXY] += mx * uy + ux * my + ux * uy + p.Q[0, 1]
    mem[_XYY] += 2.0 * my * uy + uy * uy + p.Q[1, 1]
    mx += ux
    my += uy
    # prediction without fading: x + u, P + Q (the EKF's step), then linearize at x-
    predict_step(s, u, p.q4, prior)
    bx, by = p.beacon
    dx = prior[ROW_X] - bx if bx else prior[ROW_X]
    dy = prior[ROW_Y] - by if by else prior[ROW_Y]
    r = np.sqrt(dx * dx + dy * dy)
    safe_r = np.where(r > 0.0, r, 1.0)
    cx = dx / safe_r                                 # C = (x- - b)^T / |x- - b|
    cy = dy / safe_r
    d = -(cx * bx + cy * by)                         # d = h(x-) - C x- = -C b
    cm = cx * mx + cy * my                           # C m
    T = cx * cx * mem[_XXX] + 2.0 * cx * cy * mem[_XXY] + cy * cy * mem[_XYY] + 2.0 * cm * d + d * d
    np.maximum(T, 0.0, out=T)                        # E[(C x + d)^2] >= 0 (can fail only with S_1 = P_1)
    mult = p.sigma2 * T                              # sigma_gamma^2 E[(C x + d)^2]
    beta = cm + d if p.beta is None else np.full_like(r, p.beta)
    ztil = z - p.mu * r                              # innovation z - mu h(x-)
    # innovation power with the forgetting factor (eq. 20); unused ranges leave V unchanged
    used = use != 0.0
    first = used & ~started
    V = mem[_V]
    np.copyto(V, np.where(first, ztil * ztil, np.where(used, (p.rho * V + ztil * ztil) / (1.0 + p.rho), V)))
    started |= used
    mu2 = p.mu * p.mu
    cqc = cx * cx * p.Q[0, 0] + 2.0 * cx * cy * p.Q[0, 1] + cy * cy * p.Q[1, 1]
    pxx, pxy, pyy = s[ROW_PXX], s[ROW_PXY], s[ROW_PYY]       # the previous posterior P_{k-1}
    num = V - mult - mu2 * cqc - beta * p.R          # script M (eq. 26)
    den = mu2 * (cx * cx * pxx + 2.0 * cx * cy * pxy + cy * cy * pyy)   # script N (eq. 19)
    if p.fading:
        ratio = np.divide(num, den, out=np.zeros_like(num), where=den > 0.0)
        lam = np.where(used, np.maximum(ratio, 1.0), 1.0)
        grow = lam - 1.0                             # P- = lam P + Q = (P + Q) + (lam - 1) P
        prior[ROW_PXX] += grow * pxx
        prior[ROW_PXY] += grow * pxy
        prior[ROW_PYY] += grow * pyy
        prior[ROW_PYX] = prior[ROW_PXY]
    else:
        lam = np.ones_like(r)
    # the update: the EKF's, for the range z / mu with noise variance (sigma^2 T + R) / mu^2
    applied = update_step(prior, z / p.mu, use, (mult + p.R) / mu2, p.beacon, post, y_out, S_out)
    y_out *= p.mu                                    # back to z - mu h(x-) and R_delta
    S_out *= mu2
    diag[0] = lam
    diag[1] = beta
    diag[2] = V
    diag[3] = num
    diag[4] = den
    diag[5] = mult
    return applied


# --- validation ----------------------------------------------------------------------------------------------------

def _fading_parameters(Q: Any, R: Any, beacon: Any, mu_gamma: Any, sigma_gamma: Any, rho: Any, beta: Any,
                       fading: Any, n_steps: int | None = None) -> tuple[_Params, int | None]:
    """The validated parameters; with ``n_steps``, ``Q`` (K, 2, 2) and ``R`` (K,) may give one value per step."""
    Qm, R_val, q4 = noise_parameters(Q, R, n_steps, where="fading_ekf")
    b = fixed_beacon(beacon)
    mu, m_mu = as_per_run_scalar("mu_gamma", mu_gamma, minimum=0.0, strict=True)
    sigma, m_sigma = as_per_run_scalar("sigma_gamma", sigma_gamma, minimum=0.0, strict=False)
    rho_v = float(as_finite("rho", rho, ndim=0))
    if not 0.0 < rho_v <= 1.0:
        raise ValueError(f"rho is a forgetting factor and must lie in (0, 1]; got {rho_v:g} (paper D: 0.95)")
    if isinstance(beta, str):
        if beta != "range":
            raise ValueError(f'beta must be "range" (paper D: beta = C m, about the predicted range) or a number '
                             f'>= 0 (Zhou and Xi: 1); got {beta!r}')
        beta_v = None
    else:
        beta_v = float(as_finite("beta", beta, ndim=0))
        if beta_v < 0:
            raise ValueError(f'beta must be >= 0 (or "range"); got {beta_v:g}')
    fading = as_flag("fading", fading)
    M = common_runs(dict(mu_gamma=m_mu, sigma_gamma=m_sigma))
    sigma2 = sigma * sigma
    return _Params(q4, Qm, R_val, b, mu, sigma2, rho_v, beta_v, bool(fading)), M


def _second_moment(x0: np.ndarray, P0: np.ndarray, second_moment0: Any, M: int) -> np.ndarray:
    """Initial second moment (M, 2, 2): ``P0 + x0 x0^T`` by default, else the given one (e.g. paper D's ``P0``)."""
    x = np.broadcast_to(x0, (M, 2))
    if second_moment0 is None:
        default: np.ndarray = np.broadcast_to(P0, (M, 2, 2)) + x[:, :, None] * x[:, None, :]
        return default
    S = as_finite("second_moment0", second_moment0, ndim=(2, 3))
    if S.shape[-2:] != (2, 2) or (S.ndim == 3 and S.shape[0] != M):
        raise ValueError(f"second_moment0 must have shape (2, 2) or (M, 2, 2) with M = {M}; got {S.shape}")
    S = as_covariance("second_moment0", S, 2, allow_singular=True)    # E[x x^T]: symmetric PSD, not overflowing
    return np.broadcast_to(S, (M, 2, 2))


def _memory(x0: np.ndarray, Xi0: np.ndarray) -> np.ndarray:
    M = Xi0.shape[0]
    mem = np.zeros((6, M))
    mem[_MX:_MY + 1] = np.broadcast_to(x0, (M, 2)).T
    mem[_XXX] = Xi0[:, 0, 0]
    mem[_XXY] = 0.5 * (Xi0[:, 0, 1] + Xi0[:, 1, 0])
    mem[_XYY] = Xi0[:, 1, 1]
    return mem


# --- results ---------------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class FadingResult(FilterResult):
    r"""What a fading EKF run produced: a :class:`~uwtutor.filters.base.FilterResult` plus the fading diagnostics.

    The ``extras`` dictionary holds, per step (shape (K,) or (M, K)): ``"fading_factor"`` :math:`\lambda_k`
    (1 where no range was used or ``fading=False``), ``"weakening_factor"`` :math:`\beta_k`,
    ``"innovation_power"`` :math:`V_k`, ``"fading_numerator"`` :math:`\mathcal M_k` and ``"fading_denominator"``
    :math:`\mathcal N_k` (NaN where no range was used), ``"multiplicative_variance"``
    :math:`\sigma_\gamma^2 T_k` (the part of the innovation variance due to the multiplicative noise) and
    ``"updated"`` (True where a range was used). ``innovations`` are
    :math:`\tilde z_k = z_k - \mu_\gamma h(\hat{\mathbf x}^-_k)` and ``innovation_cov`` is :math:`R_\delta`.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.filters import fading_ekf
    >>> u = np.tile([1.0, 0.0], (5, 1))
    >>> truth = np.array([100.0, 50.0]) + np.cumsum(u, axis=0)
    >>> res = fading_ekf(
    ...     [102.0, 48.0],
    ...     np.eye(2) * 25.0,
    ...     u,
    ...     np.linalg.norm(truth, axis=1),
    ...     Q=np.eye(2) * 0.01,
    ...     R=1.0,
    ...     mu_gamma=1.0,
    ... )
    >>> type(res).__name__, res.x.shape
    ('FadingResult', (5, 2))
    >>> # the fading factor lambda_k of each step (>= 1)
    >>> bool(np.all(res.extras["fading_factor"] >= 1.0))
    True
    """

    @property
    def fading_factor(self) -> np.ndarray:
        r"""The fading factor :math:`\lambda_k \ge 1` of every step, shape (K,) or (M, K)."""
        factor: np.ndarray = self.extras["fading_factor"]
        return factor

    @property
    def weakening_factor(self) -> np.ndarray:
        r"""The weakening factor :math:`\beta_k` of every step, shape (K,) or (M, K)."""
        factor: np.ndarray = self.extras["weakening_factor"]
        return factor


def _run(s0: np.ndarray, mem0: np.ndarray, u: np.ndarray, z: np.ndarray, p: _Params, times: np.ndarray,
         batched: bool) -> tuple[FadingResult, np.ndarray, np.ndarray, np.ndarray]:
    """K steps from the packed states ``s0`` and memory ``mem0`` (copied). Returns the result and the last state."""
    M = s0.shape[1]
    K = len(times)
    if u.ndim == 3:
        u_steps = np.ascontiguousarray(np.moveaxis(u, 0, -1))       # (K, 2, M)
    else:
        u_steps = u[:, :, None]
    z_fill = np.array(np.broadcast_to(z, (M, K)).T, order="C")     # (K, M)
    use = np.isfinite(z_fill).astype(float)
    z_fill[use == 0.0] = 0.0
    prior = np.empty((K, N_ROWS, M))
    post = np.empty((K, N_ROWS, M))
    innov = np.empty((K, M))
    innov_var = np.empty((K, M))
    diag = np.empty((K, len(_EXTRAS), M))
    mem = mem0.copy()
    started = np.zeros(M, dtype=bool)
    s = s0
    q_steps = p.q4.ndim == 3                       # one Q per step, (K, 2, 2)
    r_steps = isinstance(p.R, np.ndarray)          # one R per step, (K,)
    for k in range(K):
        checkpoint()                                # a widget's refinement no longer wanted stops here
        p_k = p
        if q_steps or r_steps:
            p_k = replace(p, Q=p.Q[k] if q_steps else p.Q, q4=p.q4[k] if q_steps else p.q4,
                          R=float(p.R[k]) if r_steps else p.R)
        applied = _fading_step(s, mem, started, u_steps[k], z_fill[k], use[k], p_k, prior[k], post[k], innov[k],
                               innov_var[k], diag[k])
        if applied is not use[k]:
            use[k] = applied
        s = post[k]
    unused = use == 0.0
    innov[unused] = np.nan
    innov_var[unused] = np.nan
    for name in ("fading_numerator", "fading_denominator"):     # undefined without a range
        diag[:, _EXTRAS.index(name)][unused] = np.nan

    extras = {name: runs_first(diag[:, i].T, batched) for i, name in enumerate(_EXTRAS)}
    extras["updated"] = runs_first(~unused.T, batched)
    result = FadingResult(**result_fields(times, post, prior, innov, innov_var, batched), extras=extras)
    return result, post[-1].copy(), mem, started


def fading_ekf(x0: ArrayLike, P0: ArrayLike, u: ArrayLike, z: ArrayLike, Q: ArrayLike, R: ArrayLike, *,
               mu_gamma: ArrayLike = 1.0, sigma_gamma: ArrayLike = 0.0, rho: float = 0.95,
               beta: Literal["range"] | float = "range", fading: bool = True, second_moment0: ArrayLike | None = None,
               beacon: ArrayLike = (0.0, 0.0), times: ArrayLike | None = None) -> FadingResult:
    r"""Run the fading EKF for multiplicative range noise (paper D's ISFEKF by default), one run or ``M`` at once.

    Each step ``k`` predicts with the DR displacement ``u[..., k, :]``, computes the fading factor
    :math:`\lambda_k` from the innovation of the range ``z[..., k]`` and updates (equations in the module
    docstring). A NaN range means no reply: that step is predict only (:math:`\lambda_k = 1`, :math:`V` kept).

    Parameters
    ----------
    x0 : array_like, shape (2,) or (M, 2)
        Initial position estimate [m].
    P0 : array_like, shape (2, 2) or (M, 2, 2)
        Its covariance (positive definite) [m^2]; paper D: ``diag(dr^2, dr^2)`` with ``dr`` the initial error.
    u : array_like, shape (K, 2) or (M, K, 2)
        DR displacement from epoch ``k - 1`` to epoch ``k`` [m].
    z : array_like, shape (K,) or (M, K)
        Measured ranges [m] (finite and >= 0, NaN where missing).
    Q : array_like, shape (2, 2) or (K, 2, 2)
        DR noise covariance per step [m^2] (paper D: ``diag(0.81, 0.81)``); or one per step (a log whose steps
        differ in length or in quality).
    R : float or array_like, shape (K,)
        Additive range noise variance [m^2] (paper D: 0.49); or one per step (NaN allowed at a step without a
        range).
    mu_gamma : float or array_like, shape (M,), default 1
        Mean :math:`\mu_\gamma > 0` of the multiplicative factor (paper D's simulation: 0.98, see
        :func:`range_factor_moments`); one per run allowed (e.g. from a pre-location).
    sigma_gamma : float or array_like, shape (M,), default 0
        Its standard deviation :math:`\sigma_\gamma \ge 0` (paper D: 1/1500).
    rho : float, default 0.95
        Forgetting factor :math:`0 < \rho \le 1` of the innovation power.
    beta : {"range"} or float, default "range"
        Weakening factor: ``"range"`` for paper D's :math:`\beta_k = \mathbf C_k(\mathbf m_k - \mathbf b)`
        (ISFEKF), a number :math:`\ge 0` for a constant one (1: Zhou and Xi's suboptimal fading EKF).
    fading : bool, default True
        ``False`` keeps :math:`\lambda_k = 1` (the multiplicative-noise EKF without fading).
    second_moment0 : array_like, shape (2, 2) or (M, 2, 2), optional
        Initial second moment :math:`\boldsymbol\Xi_0` of the state; default :math:`\mathbf P_0 +
        \hat{\mathbf x}_0\hat{\mathbf x}_0^\mathsf T`. Pass ``P0`` to follow paper D's text literally.
    beacon : array_like, shape (2,), optional
        Beacon position [m], the origin by default.
    times : array_like, shape (K,), optional
        Epoch times for the result (default ``0..K-1``).

    Returns
    -------
    FadingResult
        With a runs axis first if any input had one: ``x`` (M, K, 2), ``P`` (M, K, 2, 2), the predictions,
        the innovations :math:`\tilde z_k` (M, K, 1) and :math:`R_\delta` (M, K, 1, 1), and per step the
        ``fading_factor`` :math:`\lambda_k` and ``weakening_factor`` :math:`\beta_k` (M, K) with the other
        diagnostics in ``extras``. The arrays are views into shared buffers: copy one before changing it.

    Raises
    ------
    ValueError
        On a wrong shape, non-finite inputs, a negative range, a ``Q`` that is not positive semi-definite, an
        ``R``/``P0`` that is not positive definite, ``mu_gamma <= 0``, ``sigma_gamma < 0``, ``rho`` outside
        (0, 1] or a ``beta`` that is neither ``"range"`` nor a number >= 0; the message names the argument.

    Warns
    -----
    BeaconSingularityWarning
        When a prediction falls exactly on the beacon (that run's update is skipped).

    See Also
    --------
    FadingEKF : the same filter one step at a time.
    uwtutor.pipelines.ls_fading.ls_fading_ekf : paper D's LS-ISFEKF and LS-EKF (grid-search pre-location first).
    uwtutor.filters.ekf.range_only_ekf : the plain EKF (``mu_gamma=1, sigma_gamma=0, fading=False`` here).

    References
    ----------
    Zhu et al. (2019), paper D, eqs. (12)-(27); Zhou and Xi (1990).

    Examples
    --------
    Paper D's simulation (approach with one turn, 1470 m/s assumed against 1500 m/s), 200 runs at once:

    >>> import numpy as np
    >>> from uwtutor import scenarios
    >>> from uwtutor.filters.fading import fading_ekf, range_factor_moments
    >>> sc = scenarios.approach_with_turn_scenario(
    ...     np.random.default_rng(3), n_runs=200
    ... )
    >>> mu, sigma = range_factor_moments(1470.0, 1500.0, 1.0)
    >>> # 30 m initial error
    >>> x0 = sc.true_positions[:, 0] + [30.0, 0.0]
    >>> res = fading_ekf(
    ...     x0,
    ...     np.eye(2) * 30.0**2,
    ...     sc.dr_displacements,
    ...     sc.ranges,
    ...     Q=np.eye(2) * 0.81,
    ...     R=0.49,
    ...     mu_gamma=mu,
    ...     sigma_gamma=sigma,
    ...     rho=0.95,
    ...     beta="range",
    ...     times=sc.times,
    ... )
    >>> res.x.shape, res.fading_factor.shape, res.weakening_factor.shape
    ((200, 151, 2), (200, 151), (200, 151))
    >>> err = np.linalg.norm(res.x[:, -1] - sc.true_positions[:, -1], axis=-1)
    >>> bool(np.sqrt(np.mean(err**2)) < 15.0), bool(
    ...     np.all(res.fading_factor >= 1.0)
    ... )
    (True, True)
    """
    x0, P0, u, z, times, run_sizes = sequence_inputs(x0, P0, u, z, times)
    p, m_par = _fading_parameters(Q, R, beacon, mu_gamma, sigma_gamma, rho, beta, fading, n_steps=len(times))
    p = replace(p, R=check_variances_where_measured(p.R, z))
    M = common_runs({**run_sizes, "mu_gamma_or_sigma_gamma": m_par})
    # the engine with the fading back-end (FadingEKF), given the checked parameters (Q and R may be per step here)
    return FadingEKF._on_checked(x0, P0, p, second_moment0, M)._fading_steps(u, z, times)


class FadingEKF(ExtendedKalmanFilter):
    r"""Paper D's fading EKF for multiplicative range noise as an object: ``predict(u)``, ``update(z)``.

    The engine (:class:`~uwtutor.filters.engine.ExtendedKalmanFilter`) built from the model pair of the fading
    filter's deterministic parts, ``DeadReckoning(Q)`` + ``RangeToBeacon(beacon, R)``, with the fading back-end: its
    steps are this module's (the moments, the innovation power and the fading factor it carries besides the
    estimate). Same model and arithmetic as :func:`fading_ekf` (both call this module's step function). The fading
    factor
    needs the range, so ``predict(u)`` moves the estimate (``x`` becomes :math:`\hat{\mathbf x}^-_k`, ``P``
    becomes :math:`\mathbf P_{k-1} + \mathbf Q`, i.e. :math:`\lambda_k = 1` provisionally) and ``update(z)``
    computes :math:`\lambda_k`, applies :math:`\mathbf P^-_k = \lambda_k\mathbf P_{k-1} + \mathbf Q` and then
    corrects. Two ``predict`` calls in a row make the first a predict-only step; ``update`` must follow a
    ``predict``.

    Parameters
    ----------
    x0 : array_like, shape (2,) or (M, 2)
        Initial position estimate; a leading axis runs ``M`` filters at once.
    P0 : array_like, shape (2, 2) or (M, 2, 2)
        Initial covariance (positive definite).
    Q : array_like, shape (2, 2)
        Process (DR) noise covariance per step.
    R : float
        Additive range noise variance.
    mu_gamma : float or array_like, shape (M,), default 1
        Mean of the multiplicative factor.
    sigma_gamma : float or array_like, shape (M,), default 0
        Its standard deviation.
    rho : float, default 0.95
        Forgetting factor.
    beta : {"range"} or float, default "range"
        Weakening factor (see :func:`fading_ekf`).
    fading : bool, default True
        ``False`` keeps the fading factor at 1.
    second_moment0 : array_like, optional
        Initial second moment of the state (default ``P0 + x0 x0^T``).
    beacon : array_like, shape (2,), optional
        Beacon position, the origin by default.

    Attributes
    ----------
    x : ndarray
        Current estimate, shape (2,) or (M, 2).
    P : ndarray
        Current covariance, shape (2, 2) or (M, 2, 2).
    y : ndarray
        Innovation :math:`\tilde z_k` of the last update, shape (1,) or (M, 1) (NaN where no range was used).
    S : ndarray
        Its variance :math:`R_\delta`, shape (1, 1) or (M, 1, 1).
    x_prior : ndarray
        The prediction of the last step.
    P_prior : ndarray
        Its covariance, with the fading factor applied.
    fading_factor : ndarray
        :math:`\lambda_k` of the last update, shape () or (M,).
    weakening_factor : ndarray
        :math:`\beta_k` of the last update, shape () or (M,).
    innovation_power : ndarray
        :math:`V_k` of the last update, shape () or (M,).
    fading_numerator : ndarray
        :math:`\mathcal M_k` of the last update, shape () or (M,).
    fading_denominator : ndarray
        :math:`\mathcal N_k` of the last update, shape () or (M,).
    multiplicative_variance : ndarray
        :math:`\sigma_\gamma^2 T_k` of the last update, shape () or (M,) (see :class:`FadingResult`).
    updated : ndarray of bool
        Whether the last update used a range, shape () or (M,).
    extra_outputs : tuple of str
        The attributes :func:`uwtutor.filters.base.run_filter` records per step.
    Q, R, beacon
        The model parameters (read-only arrays); assigning one takes effect from the next step, checked as in the
        constructor. The other parameters (``mu_gamma``, ``sigma_gamma``, ``rho``, ``beta``, ``fading``) are
        fixed: assigning one raises (build a new filter). ``y``, ``S`` and the per-step diagnostics are
        read-only.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.filters.fading import FadingEKF
    >>> f = FadingEKF(
    ...     [1000.0, 0.0],
    ...     np.eye(2) * 100.0,
    ...     Q=np.eye(2) * 0.81,
    ...     R=0.49,
    ...     mu_gamma=0.98,
    ...     sigma_gamma=1 / 1500,
    ...     beta=1.0,
    ... )
    >>> f.predict([-20.0, 0.0])
    >>> # a range 60 m longer than the model expects
    >>> f.update(0.98 * 980.0 + 60.0)
    >>> bool(f.fading_factor > 1.0), f.y.shape
    (True, (1,))
    """

    extra_outputs = _EXTRAS + ("updated",)
    result_type = FadingResult
    _parameters = ("Q", "R", "beacon")
    _fixed = ExtendedKalmanFilter._fixed + ("mu_gamma", "sigma_gamma", "rho", "beta", "fading", "second_moment0")
    _diagnostics: tuple[str, ...] = ("y", "S", "accepted") + extra_outputs

    def __init__(self, x0: ArrayLike, P0: ArrayLike, Q: ArrayLike, R: ArrayLike, *, mu_gamma: ArrayLike = 1.0,
                 sigma_gamma: ArrayLike = 0.0, rho: float = 0.95, beta: Literal["range"] | float = "range",
                 fading: bool = True, second_moment0: ArrayLike | None = None, beacon: ArrayLike = (0.0, 0.0)) -> None:
        x0, P0 = initial_state(x0, P0)
        p, m_par = _fading_parameters(Q, R, beacon, mu_gamma, sigma_gamma, rho, beta, fading)
        M = common_runs(dict(x0=x0.shape[0] if x0.ndim == 2 else None, P0=P0.shape[0] if P0.ndim == 3 else None,
                             mu_gamma_or_sigma_gamma=m_par))
        self._start_fading(x0, P0, p, second_moment0, M)

    @classmethod
    def _on_checked(cls, x0: np.ndarray, P0: np.ndarray, p: _Params, second_moment0: Any,
                    M: int | None) -> "FadingEKF":
        """The filter from parameters ``fading_ekf`` has checked (with ``Q`` and ``R`` possibly per step)."""
        filt = cls.__new__(cls)
        filt._start_fading(x0, P0, p, second_moment0, M)
        object.__setattr__(filt, "_configured", True)           # the configuration rule holds (base.Configurable)
        return filt

    def _start_fading(self, x0: np.ndarray, P0: np.ndarray, p: _Params, second_moment0: Any, M: int | None) -> None:
        """The engine on the model pair of the fading filter's deterministic parts (its runs axis from any input),
        and the fading back-end's own state."""
        ExtendedKalmanFilter.__init__(self, DeadReckoning(p.Q), RangeToBeacon(p.beacon, p.R),
                                      x0 if M is None else np.broadcast_to(x0, (M, 2)), P0)
        self._p = p
        self._mem = _memory(x0, _second_moment(x0, P0, second_moment0, self._M))
        self._started = np.zeros(self._M, dtype=bool)
        self._pending: np.ndarray | None = None        # the DR displacement of a prediction awaiting its range
        self._start = self._packed_state()              # the estimate the pending step started from
        diag = np.full((len(_EXTRAS), self._M), np.nan)
        diag[0] = 1.0
        self._set_diagnostics(diag)

    # -- parameters --
    @property
    def Q(self) -> np.ndarray:
        """Process noise covariance (2, 2) (read-only; assign a new one to change it)."""
        return readonly(self._p.Q)

    @property
    def R(self) -> float:
        """Additive range noise variance."""
        return self._p.R

    @property
    def beacon(self) -> np.ndarray:
        """Beacon position (2,) (read-only; assign a new one to change it)."""
        return readonly(np.array(self._p.beacon))

    @property
    def updated(self) -> np.ndarray:
        """Whether the last update used a range, shape () or (M,) (the engine's ``accepted``)."""
        return self._out(self._accepted)

    def _apply(self, name: str, value: Any) -> None:
        """A new ``Q``, ``R`` or ``beacon`` (base.Configurable), checked as in the constructor, used from the next
        step on (with everything computed from it: the packed ``Q`` the prediction adds, the model pair)."""
        if name == "beacon":
            self._p = replace(self._p, beacon=fixed_beacon(value))
        else:
            Q, R, q4 = noise_parameters(value if name == "Q" else self._p.Q, value if name == "R" else self._p.R)
            self._p = replace(self._p, Q=Q, R=R, q4=q4)
        self._use_models(DeadReckoning(self._p.Q), RangeToBeacon(self._p.beacon, self._p.R), name)

    # -- state: the engine's, with the estimate the pending step started from --
    @property
    def x(self) -> np.ndarray:
        """Current estimate (the prediction between ``predict`` and ``update``), shape (2,) or (M, 2) (read-only;
        assign a new one between steps to set it)."""
        return self._out(self._x)

    @x.setter
    def x(self, value: Any) -> None:
        x = as_finite("x", value, max_abs=MAX_COORDINATE)
        if x.shape not in ((2,), (self._M, 2)):
            raise ValueError(f"x must have shape (2,) or (M, 2) with M = {self._M}; got {x.shape}")
        self._set_state(np.broadcast_to(x, (self._M, 2)), _runs_first(self._P), "x")

    @property
    def P(self) -> np.ndarray:
        """Current covariance (``P + Q`` between ``predict`` and ``update``), shape (2, 2) or (M, 2, 2) (read-only;
        assign a new one between steps to set it)."""
        return self._out(_runs_first(self._P))

    @P.setter
    def P(self, value: Any) -> None:
        P = as_covariance("P", value, 2)
        if P.shape not in ((2, 2), (self._M, 2, 2)):
            raise ValueError(f"P must have shape (2, 2) or (M, 2, 2) with M = {self._M}; got {P.shape}")
        self._set_state(self._x, np.broadcast_to(P, (self._M, 2, 2)), "P")

    def _set_state(self, x: np.ndarray, P: np.ndarray, name: str) -> None:
        if self._pending is not None:
            raise RuntimeError(f"{name} can be set before predict or after update, not between them: the fading "
                               "factor is computed at the update from the estimate the step started with")
        self._start = pack(x, P)
        self._x, self._P = unpack_runs_last(self._start)

    @property
    def P_prior(self) -> np.ndarray:
        r"""The covariance of the prediction as the update used it, :math:`\lambda_k P_{k-1} + Q` (``P + Q`` until
        the update has computed :math:`\lambda_k`), shape (2, 2) or (M, 2, 2) (read-only)."""
        return self._out(_runs_first(self._P_prior))

    def _set_diagnostics(self, diag: np.ndarray) -> None:
        for name, values in zip(_EXTRAS, diag):
            self._set_diagnostic(name, values.copy() if self._batched else np.array(values[0]))

    def _u_column(self, u: Any) -> np.ndarray:
        if u is None:
            return np.zeros((2, 1))
        arr = as_finite("u", u)
        if arr.shape == (2,):
            return arr[:, None]
        if self._batched and arr.shape == (self._M, 2):
            return arr.T.copy()
        raise ValueError(f"u must have shape (2,) or (M, 2) with M = {self._M}; got {arr.shape}")

    def _step(self, u_col: np.ndarray, z: np.ndarray, use: np.ndarray) -> None:
        """The fading back-end's step (``_fading_step``) from the estimate the step started with."""
        prior = np.empty_like(self._start)
        post = np.empty_like(self._start)
        y = np.empty(self._M)
        S = np.empty(self._M)
        diag = np.empty((len(_EXTRAS), self._M))
        applied = _fading_step(self._start, self._mem, self._started, np.broadcast_to(u_col, (2, self._M)), z, use,
                               self._p, prior, post, y, S, diag)
        unused = applied == 0.0
        y[unused] = np.nan
        S[unused] = np.nan
        for name in ("fading_numerator", "fading_denominator"):     # undefined without a range
            diag[_EXTRAS.index(name)][unused] = np.nan
        self._start = post
        self._set_packed_state(post, prior)
        self._y, self._S, self._accepted = y[:, None], S[:, None, None], ~unused
        self._set_diagnostics(diag)

    # -- the protocol: the fading back-end's steps on the engine's state --
    def predict(self, u: ArrayLike | None = None) -> None:
        """Move the estimate by the DR displacement ``u`` (shape (2,) or (M, 2); ``None``: no move)."""
        u_col = self._u_column(u)
        if self._pending is not None:               # the previous prediction got no range: predict-only step
            self._step(self._pending, np.zeros(self._M), np.zeros(self._M))
        self._pending = u_col
        shown = np.empty_like(self._start)
        predict_step(self._start, u_col, self._p.q4, shown)
        self._set_packed_state(shown, shown)
        self.k += 1

    def update(self, z: ArrayLike) -> None:
        """Fading factor, then correction with the range ``z`` (scalar, or (M,) when batched; NaN: no range)."""
        if self._pending is None:
            raise RuntimeError("call predict(u) before update(z): the fading factor scales the prediction's "
                               "covariance, so each update needs its own prediction")
        z = as_range_array("z", z, allow_nan=True, max_abs=MAX_COORDINATE)
        if z.size == 1 and z.ndim <= 1:
            z = np.broadcast_to(z.reshape(()), (self._M,))
        elif z.shape != (self._M,) or not self._batched:
            raise ValueError(f"z must be a scalar or, for a batched filter, shape ({self._M},); got {z.shape}")
        has = np.isfinite(z)
        u_col, self._pending = self._pending, None
        self._step(u_col, np.where(has, z, 0.0), has.astype(float))

    def run(self, z: ArrayLike, u: ArrayLike | None = None, times: ArrayLike | None = None, *,
            keep_priors: bool = True) -> FadingResult:
        """Predict with ``u[..., k, :]`` and update with ``z[..., k]`` for every step; return the history.

        ``z`` has shape (K,) or, batched, (M, K) (NaN: predict only); ``u`` (K, 2) or (M, K, 2) (``None``: no
        displacement). Uses the loop of :func:`fading_ekf`, so the result is identical to calling it with this
        filter's state; the filter is left at the last step. ``keep_priors=False``: the result's priors are None.
        """
        if self._pending is not None:
            raise RuntimeError("run() starts from an updated state: call update(z) for the pending prediction first")
        keep_priors = as_flag("keep_priors", keep_priors)
        z = as_range_array("z", z, allow_nan=True, ndim=(2 if self._batched else 1, 1), max_abs=MAX_COORDINATE)
        if z.ndim == 2 and z.shape[0] != self._M:
            raise ValueError(f"z must have shape (K,) or (M, K) with M = {self._M}; got {z.shape}")
        K = z.shape[-1]
        u = np.zeros((K, 2)) if u is None else as_finite("u", u, ndim=(3 if self._batched else 2, 2))
        if u.shape[-2:] != (K, 2) or (u.ndim == 3 and u.shape[0] != self._M):
            raise ValueError(f"u must have shape ({K}, 2) or (M, {K}, 2), one input per step of z; got {u.shape}")
        times = steps_and_times(K, times)
        result = self._fading_steps(u, z, times)
        return result if keep_priors else replace(result, x_prior=None, P_prior=None)

    def _fading_steps(self, u: np.ndarray, z: np.ndarray, times: np.ndarray) -> FadingResult:
        """The fading loop (``_run``) over checked inputs from the filter's state; the filter is left at the last
        step."""
        result, last, mem, started = _run(self._start, self._mem, u, z, self._p, times, self._batched)
        x_prior, P_prior = result.priors()
        self._start = last
        self._set_packed_state(last, pack(np.array(x_prior[..., -1, :], ndmin=2),
                                          np.array(P_prior[..., -1, :, :], ndmin=3)))
        self._mem = mem
        self._started = started
        self.k += len(times)
        self._y = np.array(result.innovations[..., -1, :], ndmin=2)
        self._S = np.array(result.innovation_cov[..., -1, :, :], ndmin=3)
        self._accepted = np.array(result.extras["updated"][..., -1], ndmin=1)
        self._set_diagnostics(np.array([np.array(result.extras[name][..., -1], ndmin=1) for name in _EXTRAS]))
        return result


# --- LS-EKF and LS-ISFEKF --------------------------------------------------------------------------------------------
