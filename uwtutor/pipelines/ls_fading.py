r"""Paper D's start: a grid pre-location of the start and the sound-speed factor by least squares, accepted after a
turn, then the fading EKF from it (:func:`ls_fading_ekf`, its result :class:`LSFadingResult`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from .._validate import (MAX_COORDINATE, as_covariance, as_finite, as_per_run_scalar, as_float_array, as_int,
                        as_range_array, as_scalar)
from ..filters.base import FilterResult
from ..lsq import Prelocation, PrelocationAcceptance
from ..filters._packed import steps_and_times
from ..filters.fading import FadingResult, fading_ekf
from .staggered import filter_from_start_epochs

__all__ = ["ls_fading_ekf", "LSFadingResult"]


@dataclass(frozen=True, kw_only=True)
class LSFadingResult(FilterResult):
    r"""Paper D's two-stage estimate: grid-search pre-location until accepted, then a filter (``ls_fading_ekf``).

    Shapes: ``M`` runs (always a runs axis), ``K`` epochs.

    Attributes
    ----------
    times : ndarray, shape (K,)
        Epoch times.
    x : ndarray, shape (M, K, 2)
        The estimate of the method: the pre-location's position up to and including the start epoch, the
        filter's after it.
    P : ndarray, shape (M, K, 2, 2)
        The filter's covariance (NaN up to the start epoch: the grid search gives none).
    x_prior : ndarray
        The filter's predictions (the pre-location up to the start epoch).
    P_prior : ndarray
        Their covariances (NaN up to the start epoch).
    innovations : ndarray, shape (M, K, 1)
        The filter's innovations (NaN up to the start epoch and where no range was used).
    innovation_cov : ndarray, shape (M, K, 1, 1)
        Their covariances, so that NIS statistics (e.g. ``run_monte_carlo``) cover the filtered epochs.
    extras : dict
        ``"fading_factor"`` :math:`\lambda_k`, ``"weakening_factor"`` :math:`\beta_k` (NaN up to the start
        epoch) and ``"updated"`` (True where the filter used a range), shape (M, K).
    start_epoch : ndarray of int, shape (M,)
        The epoch at which the pre-location was accepted and the filter started from it; ``K`` for a run whose
        pre-location was never accepted (then ``x`` is the pre-location throughout).
    mu_gamma : ndarray, shape (M,)
        The multiplicative-noise mean the filter used (the pre-location's :math:`c / \hat c_\mathrm e` with
        ``mu_gamma="prelocation"``).
    prelocation : object
        The grid search at every epoch, a ``uwtutor.lsq.Prelocation`` (from ``grid_prelocation``).
    acceptance : object
        The acceptance test, a ``uwtutor.lsq.PrelocationAcceptance`` (from ``prelocation_acceptance``).
    filter_result : FadingResult
        The filter's own run over the accepted runs (in order), in *filter time*: step ``j`` of accepted run
        ``m`` is epoch ``start_epoch[m] + 1 + j`` (steps past the last epoch are padding without ranges); see
        :func:`uwtutor.pipelines.staggered.filter_from_start_epochs`.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor import scenarios
    >>> from uwtutor.pipelines import ls_fading_ekf
    >>> sc = scenarios.approach_with_turn_scenario(np.random.default_rng(5), n_runs=2)
    >>> res = ls_fading_ekf(
    ...     np.eye(2) * 50.0**2,
    ...     sc.dr_displacements,
    ...     sc.ranges,
    ...     Q=np.eye(2) * 0.81,
    ...     R=0.49,
    ...     times=sc.times,
    ... )
    >>> res.x.shape, res.start_epoch.shape, res.mu_gamma.shape
    ((2, 151, 2), (2,), (2,))
    >>> # the filter's covariance starts after the pre-location's epoch
    >>> k0 = int(res.start_epoch[0])
    >>> bool(np.isnan(res.P[0, k0]).all() and np.isfinite(res.P[0, k0 + 1]).all())
    True
    """

    start_epoch: np.ndarray
    mu_gamma: np.ndarray
    prelocation: Prelocation
    acceptance: PrelocationAcceptance
    filter_result: FadingResult

    @property
    def fading_factor(self) -> np.ndarray:
        r""":math:`\lambda_k` of every epoch, shape (M, K) (NaN up to the start epoch)."""
        factor: np.ndarray = self.extras["fading_factor"]
        return factor

    @property
    def weakening_factor(self) -> np.ndarray:
        r""":math:`\beta_k` of every epoch, shape (M, K) (NaN up to the start epoch)."""
        factor: np.ndarray = self.extras["weakening_factor"]
        return factor

    @property
    def accepted(self) -> np.ndarray:
        """Whether the pre-location was accepted and the filter ran, one boolean per run, shape (M,)."""
        return self.start_epoch < len(self.times)


def ls_fading_ekf(P0: ArrayLike, dr_displacements: ArrayLike, ranges: ArrayLike, Q: ArrayLike, R: float, *,
                  mu_gamma: ArrayLike = "prelocation", sigma_gamma: float = 0.0, rho: float = 0.95,
                  beta: Literal["range"] | float = "range", fading: bool = True, assumed_speed: float = 1470.0,
                  beacon: ArrayLike = (0.0, 0.0), times: ArrayLike | None = None, n_consecutive: int = 10,
                  max_shift: float = 50.0, min_heading_change: float = np.deg2rad(10.0),
                  prelocation: Prelocation | None = None,
                  acceptance: PrelocationAcceptance | None = None) -> LSFadingResult:
    r"""Paper D's LS-ISFEKF (and LS-EKF): grid-search pre-location, then a fading EKF started from it.

    1. **Pre-location** (``uwtutor.lsq.grid_prelocation``): at every epoch, the start bearing and sound-speed
       error whose DR track best fits the travel times :math:`\tau_k = r_k / c` (paper D, eq. 6).
    2. **Acceptance** (``uwtutor.lsq.prelocation_acceptance``): a heading change of more than
       ``min_heading_change``, then ``n_consecutive`` (:math:`K_\mathrm{stop}`) consecutive fixes moving less than
       ``max_shift`` (:math:`D_\mathrm{stop}`); paper D's simulation: 10 degrees, 10, 50 m.
    3. **Filter** from the accepted epoch :math:`k_\mathrm a`: :func:`~uwtutor.filters.fading.fading_ekf` with
       :math:`\hat{\mathbf x}_{k_\mathrm a} =` the pre-location's position, covariance ``P0``, and (with
       ``mu_gamma="prelocation"``) :math:`\mu_\gamma = c / \hat c_\mathrm e`, the pre-location's range scale,
       "passing on its sound-speed error estimate". The filter processes epochs :math:`k_\mathrm a + 1, \dots`.

    LS-ISFEKF: the defaults with paper D's ``sigma_gamma``; LS-EKF: ``mu_gamma=1.0, sigma_gamma=0.0,
    fading=False`` (the additive-noise EKF, which ignores the speed estimate). All runs are processed at once:
    each run's arrays are shifted so that its filter starts at step 0.

    The arguments come in the filters' order ``(P0, u, z, Q, R)`` (the pre-location gives the start, so there is
    no ``x0``).

    Parameters
    ----------
    P0 : array_like, shape (2, 2)
        Covariance of the pre-location when the filter starts [m^2] (paper D: "can be set slightly smaller" than
        for an unknown start; its trial uses ``diag(100^2, 100^2)``).
    dr_displacements : array_like, shape (M, K, 2)
        DR displacements (row 0 not used).
    ranges : array_like, shape (M, K)
        Measured ranges, converted with ``assumed_speed`` (e.g. ``Scenario.ranges``); NaN where missing (not at
        epoch 0).
    Q : array_like, shape (2, 2)
        DR noise covariance per step [m^2].
    R : float
        Additive range noise variance [m^2].
    mu_gamma : {"prelocation"} or float or array_like, shape (M,), default "prelocation"
        Mean multiplicative factor for the filter; ``"prelocation"`` takes each run's estimate.
    sigma_gamma : float, default 0
        Standard deviation of the factor (paper D: 1/1500).
    rho : float, default 0.95
        Forgetting factor.
    beta : {"range"} or float, default "range"
        Weakening factor (see :func:`~uwtutor.filters.fading.fading_ekf`).
    fading : bool, default True
        ``False``: no fading (the filter is a multiplicative-noise EKF, or the plain EKF with ``mu_gamma=1,
        sigma_gamma=0``).
    assumed_speed : float, default 1470
        The speed the ranges were converted with [m/s].
    beacon : array_like, shape (2,), optional
        Beacon position [m].
    times : array_like, shape (K,), optional
        Epoch times (default ``0..K-1``).
    n_consecutive : int, default 10
        :math:`K_\mathrm{stop}`.
    max_shift : float, default 50
        :math:`D_\mathrm{stop}` [m].
    min_heading_change : float, default 10 degrees
        Heading change required [rad].
    prelocation : object, optional
        A grid search already computed for these ranges (it does not depend on the filter: pass it to compare
        several filters without repeating the search).
    acceptance : object, optional
        Its acceptance, likewise.

    Returns
    -------
    LSFadingResult

    Raises
    ------
    ValueError
        On inputs of the wrong shape, or a ``prelocation``/``acceptance`` that does not match them.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor import scenarios
    >>> from uwtutor.pipelines import ls_fading_ekf
    >>> sc = scenarios.approach_with_turn_scenario(
    ...     np.random.default_rng(5), n_runs=50
    ... )
    >>> res = ls_fading_ekf(
    ...     np.eye(2) * 50.0**2,
    ...     sc.dr_displacements,
    ...     sc.ranges,
    ...     Q=np.eye(2) * 0.81,
    ...     R=0.49,
    ...     sigma_gamma=1 / 1500,
    ...     times=sc.times,
    ... )
    >>> res.x.shape, bool(res.accepted.all())
    ((50, 151, 2), True)
    >>> err = np.linalg.norm(res.x[:, -1] - sc.true_positions[:, -1], axis=-1)
    >>> bool(np.sqrt(np.mean(err**2)) < 30.0)
    True
    """
    from .. import lsq   # imported here: lsq is a sibling top-level module of the filters package

    z = as_range_array("ranges", ranges, allow_nan=True, ndim=2, nonempty=True, max_abs=MAX_COORDINATE)
    u = as_finite("dr_displacements", dr_displacements, ndim=3, max_abs=MAX_COORDINATE)
    as_finite("beacon", beacon, shape=(2,), max_abs=MAX_COORDINATE)
    # a sound speed is a few km/s: [1, 1e5] m/s bounds every medium (and the ranges it rescales)
    as_scalar("assumed_speed", assumed_speed, domain="positive", low=1.0, high=1e5)
    M, K = z.shape
    if u.shape != (M, K, 2):
        raise ValueError(f"dr_displacements must have shape (M, K, 2) = {(M, K, 2)} to match ranges; got {u.shape}")
    as_int("n_consecutive", n_consecutive, minimum=1)
    times = steps_and_times(K, times)
    P0 = as_covariance("P0", P0, 2)
    if P0.shape != (2, 2):
        raise ValueError(f"P0 must be one 2x2 matrix; got shape {P0.shape}")
    if prelocation is None:
        prelocation = lsq.grid_prelocation(ranges=z, dr_displacements=u, assumed_speed=assumed_speed,
                                           beacon=beacon)
    pos = as_float_array("prelocation.position", prelocation.position)
    if pos.shape != (M, K, 2):
        raise ValueError(f"prelocation must come from these ranges: its positions have shape {pos.shape}, "
                         f"expected {(M, K, 2)}")
    if acceptance is None:
        acceptance = lsq.prelocation_acceptance(prelocation.start, u, min_heading_change=min_heading_change,
                                                n_consecutive=n_consecutive, max_shift=max_shift)
    epoch = np.asarray(acceptance.epoch)
    if epoch.shape != (M,):
        raise ValueError(f"acceptance must come from these ranges: its epochs have shape {epoch.shape}, "
                         f"expected ({M},)")
    start = np.where(epoch >= 0, epoch, K).astype(int)
    take = np.minimum(start, K - 1)
    rows = np.arange(M)
    x_start = pos[rows, take]
    if isinstance(mu_gamma, str):
        if mu_gamma != "prelocation":
            raise ValueError(f'mu_gamma must be "prelocation" or a number > 0; got {mu_gamma!r}')
        mu = np.asarray(prelocation.range_scale, dtype=float)[rows, take]
    else:
        mu = np.broadcast_to(as_per_run_scalar("mu_gamma", mu_gamma, minimum=0.0, strict=True)[0], (M,)).astype(float)

    # every accepted run's filter starts at its own epoch, all in one call
    staggered = filter_from_start_epochs(fading_ekf, start, x_start, P0, u, z, per_run={"mu_gamma": mu}, Q=Q, R=R,
                                         sigma_gamma=sigma_gamma, rho=rho, beta=beta, fading=fading, beacon=beacon,
                                         times=np.arange(K, dtype=float))
    filt = staggered.filter_result
    at_epochs = staggered.at_epochs

    extras = {"fading_factor": at_epochs(filt.fading_factor, np.nan),
              "weakening_factor": at_epochs(filt.weakening_factor, np.nan),
              "updated": at_epochs(filt.extras["updated"], False)}
    return LSFadingResult(times=times, x=at_epochs(filt.x, pos), P=at_epochs(filt.P, np.nan),
                          x_prior=None if filt.x_prior is None else at_epochs(filt.x_prior, pos),
                          P_prior=None if filt.P_prior is None else at_epochs(filt.P_prior, np.nan),
                          innovations=at_epochs(filt.innovations, np.nan),
                          innovation_cov=at_epochs(filt.innovation_cov, np.nan), extras=extras,
                          start_epoch=start, mu_gamma=mu, prelocation=prelocation, acceptance=acceptance,
                          filter_result=filt)
