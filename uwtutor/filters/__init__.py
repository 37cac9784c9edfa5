"""Filters for single-beacon navigation, all following the protocol of :mod:`uwtutor.filters.base`."""

from .base import Filter, FilterResult, run_filter
from .ekf import BeaconSingularityWarning, RangeOnlyEKF, range_only_ekf
from .kalman import KalmanFilter
from .particle import (
    BootstrapParticleFilter,
    DepthSpeedPitchModel,
    LinearGaussianModel,
    ParticleDegeneracyError,
    ParticleModel,
)

__all__ = [
    "Filter", "FilterResult", "run_filter", "KalmanFilter",
    "range_only_ekf", "RangeOnlyEKF", "BeaconSingularityWarning",
    "BootstrapParticleFilter", "ParticleModel", "DepthSpeedPitchModel", "LinearGaussianModel",
    "ParticleDegeneracyError",
]
