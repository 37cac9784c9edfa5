"""Motion and measurement models: what the filters of :mod:`uwtutor.filters` filter.

Each model answers for a batch of Monte Carlo runs at once (shapes in :mod:`uwtutor.models.base`). A filter
family is written once against these two interfaces; a new method is a new pair of models.
"""

from .base import MeasurementModel, MotionModel
from .bias import BiasRateDeadReckoning, bias_rate_process_noise, paper_a_process_noise
from .cooperative import CooperativeMotion, SquaredRangePair, leader_range
from .dead_reckoning import DeadReckoning
from .depth import DepthSpeedPitch
from .linear import DirectMeasurement, LinearMeasurement, LinearMotion
from .odometry import OdometryMotion, StateLayout, wrap_angle
from .range import BeaconRanges, MultiplicativeRange, NoiseSchedule, RangeToBeacon, line_of_sight
from .robust import ConstantVelocity, PositionMeasurement

__all__ = [
    "MotionModel", "MeasurementModel",
    "DeadReckoning", "DepthSpeedPitch", "LinearMotion", "LinearMeasurement", "DirectMeasurement",
    "RangeToBeacon", "MultiplicativeRange", "line_of_sight", "BeaconRanges", "NoiseSchedule",
    "OdometryMotion", "StateLayout", "wrap_angle",
    "BiasRateDeadReckoning", "paper_a_process_noise", "bias_rate_process_noise",
    "CooperativeMotion", "SquaredRangePair", "leader_range",
    "ConstantVelocity", "PositionMeasurement",
]
