"""Filters for single-beacon navigation, all following the protocol of :mod:`uwtutor.filters.base`.

A filter here runs on measurements it is given; a method that first computes a least-squares fix and then starts a
filter from it (paper A's prepositioning, paper D's pre-location, a filter started at each run's own epoch) is a
pipeline: :mod:`uwtutor.pipelines`.
"""

from .base import Filter, FilterResult, run_filter
from .bias import BiasEKF, bias_ekf, bias_model_pair
from .cooperative import CooperativeEKF, cooperative_ekf
from .engine import ExtendedKalmanFilter, extended_kalman_filter
from .ekf import BeaconSingularityWarning, RangeOnlyEKF, range_only_ekf
from .fading import FadingEKF, FadingResult, fading_ekf, range_factor_moments
from .gates import ChiSquareGate, Gate, GateContext, ReacquiringGate
from .kalman import KalmanFilter
from .robust import RobustGate, SecondMomentGate, cascade_kf, robust_range_kf
from .smoother import SmootherResult, rts_smoother
from .particle import (BootstrapParticleFilter, GreyParticleFilter, MultipleModelParticleFilter,
                       ParticleCollapseWarning, ParticleDegeneracyError)
# Names kept for chapter 6 and the lab depth_pf_vs_ekf, which import them from here (see uwtutor.filters.legacy):
from .legacy import DepthEKF, LinearGaussianModel
from ..models.depth import DepthSpeedPitchModel, PitchManeuverModel

__all__ = [
    "Filter", "FilterResult", "run_filter", "KalmanFilter",
    "ExtendedKalmanFilter", "extended_kalman_filter", "Gate", "GateContext", "ChiSquareGate", "ReacquiringGate",
    "range_only_ekf", "RangeOnlyEKF", "BeaconSingularityWarning",
    "BootstrapParticleFilter", "MultipleModelParticleFilter", "GreyParticleFilter", "ParticleDegeneracyError",
    "ParticleCollapseWarning",
    "DepthEKF", "LinearGaussianModel", "DepthSpeedPitchModel", "PitchManeuverModel",
    "cooperative_ekf", "CooperativeEKF",
    "robust_range_kf", "cascade_kf", "RobustGate", "SecondMomentGate", "rts_smoother", "SmootherResult",
    "fading_ekf", "FadingEKF", "FadingResult", "range_factor_moments",
    "bias_ekf", "BiasEKF", "bias_model_pair",
]
