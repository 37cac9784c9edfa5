r"""Paper C's comparison as one call: every filter of the chapter on every Monte Carlo run of a depth profile
(:func:`run_depth_study`, its result :class:`DepthStudy`). An experiment runner, so it lives with the pipelines, not
with the scenario (:mod:`uwtutor.scenarios.paper_c`) that makes its inputs.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike

from .._validate import as_finite, as_instance, as_int, as_nonnegative, as_scalar, check_work
from ..filters import (BootstrapParticleFilter, GreyParticleFilter, MultipleModelParticleFilter,
                       extended_kalman_filter)
from ..models.depth import DepthSensors, DepthSpeedPitch, PitchManeuver
from ..scenarios.paper_c import FILTER_NAMES, PARAMETERS, PITCH_OFFSET, DepthProfile
from ..wavelet import sliding_noise_sigma

__all__ = ["DepthStudy", "run_depth_study"]


@dataclass(frozen=True)
class DepthStudy:
    """The estimates of several filters on the same Monte Carlo runs (see :func:`run_depth_study`).

    Attributes
    ----------
    profile : DepthProfile
        The truth.
    measurements : ndarray, shape (M, K, 3)
        The sensor readings of the ``M`` runs.
    estimates : dict of ndarray
        For each filter, its estimates, shape (M, K, 3).
    ess : dict of ndarray
        For each particle filter, the effective sample size after each update, shape (M, K).
    extras : dict
        ``"GPF noise_std"`` (M, K, 3): the wavelet noise estimates the GPF used; ``"MMPF mode_probabilities"``
        (M, K, J): the posterior probabilities of the MMPF's modes.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.pipelines import run_depth_study
    >>> from uwtutor.scenarios import paper_c
    >>> sc = paper_c.make(np.random.default_rng(0), n_runs=2, duration=2.0)
    >>> study = run_depth_study(sc.profile, sc.measurements, ("EKF",))
    >>> list(study.estimates), study.estimates["EKF"].shape
    (['EKF'], (2, 40, 3))
    >>> # RMSE over the runs of depth, speed and pitch at each step [m, m/s, rad]
    >>> study.rmse("EKF").shape
    (40, 3)
    """

    profile: DepthProfile
    measurements: np.ndarray
    estimates: dict[str, np.ndarray]
    ess: dict[str, np.ndarray] = field(default_factory=dict)
    extras: dict[str, np.ndarray] = field(default_factory=dict)

    def rmse(self, name: str) -> np.ndarray:
        """RMSE over the runs at each step of filter ``name``, per component, shape (K, 3)."""
        err = self.estimates[name] - self.profile.truth
        rmse: np.ndarray = np.sqrt(np.mean(err**2, axis=0))
        return rmse

    def rmse_over(self, name: str, mask: ArrayLike | None = None) -> np.ndarray:
        """RMSE over the runs and the steps selected by ``mask`` (all by default), per component, shape (3,)."""
        err = self.estimates[name] - self.profile.truth
        if mask is not None:
            err = err[:, np.asarray(mask, dtype=bool)]
        rmse: np.ndarray = np.sqrt(np.mean(err**2, axis=(0, 1)))
        return rmse


def _mmpf_models(process_std: np.ndarray, T: float, targets_deg: np.ndarray,
                 time_constant: float) -> list[PitchManeuver]:
    return [PitchManeuver(pitch_target=np.radians(p), time_constant=time_constant, T=T, process_std=process_std)
            for p in targets_deg]


def _mmpf_transition(stay: float, J: int) -> np.ndarray:
    off = (1.0 - stay) / (J - 1) if J > 1 else 0.0
    return np.full((J, J), off) + np.eye(J) * (stay - off)


def run_depth_study(profile: DepthProfile, measurements: ArrayLike, filters: Sequence[str] = ("EKF", "MMPF", "GPF"), *,
                    n_particles: int = 1000, grey_fraction: float = 0.1, grey_window: int = 30,
                    noise_window: int = 50, process_std: ArrayLike | None = None,
                    mmpf_targets_deg: Sequence[float] = (0.0, 20.0, -20.0), mmpf_time_constant: float = 1.0,
                    mmpf_stay: float = 0.995, seed: int = 0) -> DepthStudy:
    """Run the filters of paper C's comparison on every Monte Carlo run of a depth profile.

    All filters start from the first measurement with covariance ``R`` and use paper C's nominal
    ``R = diag(0.2², 0.05², (0.5°)²)`` (m, m/s, rad) and the process noise ``process_std`` (the diagonal of the
    paper's Q by default). The filters:

    ``"EKF"``
        The generic EKF (:func:`~uwtutor.filters.engine.extended_kalman_filter`) on paper C's models
        (:class:`~uwtutor.models.depth.DepthSpeedPitch`, :class:`~uwtutor.models.depth.DepthSensors`) with the fixed
        ``R``.
    ``"MMPF"``
        :class:`~uwtutor.filters.particle.multiple_model.MultipleModelParticleFilter` over one
        :class:`~uwtutor.models.depth.PitchManeuver` mode per pitch target in ``mmpf_targets_deg`` (by
        default cruise 0°, dive +20°, climb -20°), time constant ``mmpf_time_constant``, staying in a mode with
        probability ``mmpf_stay`` per step and switching to each other mode with equal probability; fixed ``R``.
    ``"GPF"``
        :class:`~uwtutor.filters.particle.grey.GreyParticleFilter`: ``grey_fraction`` of the particles from the GM(1,1)
        forecast of the last ``grey_window`` measurements (pitch shifted by 1 rad), wavelet ``R_k`` from
        ``noise_window`` samples (db6).
    ``"PF"``, ``"PF + wavelet R"``, ``"EKF + wavelet R"``
        The pieces of the GPF: the bootstrap filter with the fixed ``R``; the GPF without grey particles; the EKF
        with the GPF's wavelet ``R_k`` (``DepthSensors`` with one ``R`` per run and step).

    Every filter runs on the same model pair, ``DepthSpeedPitch(T, process_std)`` and ``DepthSensors(R)``.

    Parameters
    ----------
    profile : DepthProfile
        The truth.
    measurements : array_like, shape (M, K, 3)
        Sensor readings (:func:`~uwtutor.scenarios.paper_c.simulate_depth_sensors`).
    filters : sequence of str, optional
        Names from ``FILTER_NAMES``.
    n_particles : int, optional
        ``N`` of every particle filter (paper C: 1000).
    grey_fraction : float, optional
        :math:`N_\\mathrm{grey}/N` of the GPF (paper C: 0.1).
    grey_window : int, optional
        ``L`` of the GPF (paper C: 30).
    noise_window : int, optional
        Length of the wavelet window (paper C: 50).
    process_std : array_like, shape (3,), optional
        Process noise standard deviations per step [m, m/s, rad].
    mmpf_targets_deg : sequence of float, optional
        Pitch targets of the MMPF's modes [deg] (at least one).
    mmpf_time_constant : float, optional
        Time constant of the MMPF modes [s].
    mmpf_stay : float, optional
        Probability of staying in a mode at each step.
    seed : int, optional
        Seed of the particle filters' generators: run ``m`` of a filter draws from ``default_rng(seed + m)``
        (each particle filter runs its ``M`` runs in one batched call).

    Returns
    -------
    DepthStudy

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.scenarios import paper_c
    >>> sc = paper_c.make(np.random.default_rng(0), n_runs=2, duration=12.0)
    >>> study = run_depth_study(
    ...     sc.profile, sc.measurements, ("EKF", "GPF"), n_particles=200
    ... )
    >>> study.estimates["GPF"].shape, study.extras["GPF noise_std"].shape
    ((2, 240, 3), (2, 240, 3))
    >>> # depth RMSE [m]
    >>> {
    ...     name: round(float(study.rmse_over(name)[0]), 3)
    ...     for name in study.estimates
    ... }
    {'EKF': 0.244, 'GPF': 0.213}
    """
    unknown = [f for f in filters if f not in FILTER_NAMES]
    if unknown or not filters:
        raise ValueError(f"filters must be names from {FILTER_NAMES}; got {list(filters)!r}")
    as_instance("profile", profile, DepthProfile, "e.g. uwtutor.scenarios.paper_c.make(rng).profile")
    # readings up to 1e75: the process noise (v T)^2 sigma^2 of a state read from them stays finite
    Z = as_finite("measurements", measurements, nonempty=True, max_abs=1e75)
    if Z.ndim != 3 or Z.shape[1:] != (profile.n_steps, 3):
        raise ValueError(f"measurements must have shape (M, {profile.n_steps}, 3); got {Z.shape}")
    N = as_int("n_particles", n_particles, minimum=10)
    check_work("n_particles", Z.shape[0] * N * 3, "particle values")
    # every filter's parameters are checked, whichever filters run (none is ignored silently)
    grey_fraction = as_scalar("grey_fraction", grey_fraction, low=0.0)
    grey_window = as_int("grey_window", grey_window, minimum=4)
    noise_window = as_int("noise_window", noise_window, minimum=1)
    mmpf_time_constant = as_scalar("mmpf_time_constant", mmpf_time_constant, domain="positive")
    q = PARAMETERS.process_std if process_std is None else as_nonnegative("process_std", process_std, shape=(3,))
    seed = as_int("seed", seed, minimum=0)
    targets = as_finite("mmpf_targets_deg", mmpf_targets_deg, ndim=1)
    if targets.size < 1:
        raise ValueError("mmpf_targets_deg must hold at least one pitch target")
    stay = as_scalar("mmpf_stay", mmpf_stay)
    if not 0.0 < stay <= 1.0:
        raise ValueError(f"mmpf_stay must lie in (0, 1]; got {stay}")
    T = profile.T
    R = np.diag(PARAMETERS.sensor_std ** 2)
    M = Z.shape[0]
    motion, sensors = DepthSpeedPitch(T=T, process_std=q), DepthSensors(R)
    gpf_kw: dict[str, Any] = dict(grey_window=grey_window, noise_window=noise_window,
                                  grey_offset=[0.0, 0.0, PITCH_OFFSET])
    makers: dict[str, Callable[[np.ndarray, Sequence[np.random.Generator]], Any]] = {
        "PF": lambda z0, rngs: BootstrapParticleFilter.from_gaussian(motion, sensors, z0, R, N, rngs),
        "MMPF": lambda z0, rngs: MultipleModelParticleFilter.from_gaussian(
            _mmpf_models(q, T, targets, mmpf_time_constant), sensors, z0, R, N, rngs,
            transition=_mmpf_transition(stay, targets.size)),
        "GPF": lambda z0, rngs: GreyParticleFilter.from_gaussian(motion, sensors, z0, R, N, rngs,
                                                                 grey_fraction=grey_fraction, **gpf_kw),
        "PF + wavelet R": lambda z0, rngs: GreyParticleFilter.from_gaussian(motion, sensors, z0, R, N, rngs,
                                                                            grey_fraction=0.0, **gpf_kw),
    }
    estimates: dict[str, np.ndarray] = {}
    ess: dict[str, np.ndarray] = {}
    extras: dict[str, np.ndarray] = {}
    for name in filters:
        if name == "EKF":
            estimates[name] = extended_kalman_filter(motion, sensors, Z[:, 0], R, None, Z).x
            continue
        if name == "EKF + wavelet R":
            continue                                     # after the GPF (it uses the GPF's noise estimates)
        # all M runs in one batched filter; run m draws from its own generator, seeded seed + m
        rngs = [np.random.default_rng(seed + m) for m in range(M)]
        res = makers[name](Z[:, 0], rngs).run(Z)
        estimates[name], ess[name] = res.x, res.extras["ess"]
        for key in ("noise_std", "mode_probabilities"):
            if key in res.extras:
                extras[f"{name} {key}"] = res.extras[key]
    if "EKF + wavelet R" in filters:
        sd = extras.get("GPF noise_std")
        if sd is None:
            sd = extras.get("PF + wavelet R noise_std")
        if sd is None:                                   # compute the GPF's noise estimates without its particles
            sd = np.moveaxis(sliding_noise_sigma(np.moveaxis(Z, -1, 1), noise_window), 1, -1)
            sd = np.where(np.isnan(sd), PARAMETERS.sensor_std, np.maximum(sd, 0.01 * PARAMETERS.sensor_std))
        Rs = np.zeros(Z.shape + (3,))
        Rs[..., [0, 1, 2], [0, 1, 2]] = sd**2
        estimates["EKF + wavelet R"] = extended_kalman_filter(motion, DepthSensors(Rs), Z[:, 0], R, None, Z).x
    estimates = {name: estimates[name] for name in filters}
    return DepthStudy(profile=profile, measurements=Z, estimates=estimates, ess=ess, extras=extras)
