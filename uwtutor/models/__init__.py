"""Motion and measurement models: what the filters of :mod:`uwtutor.filters` filter.

Each model answers for a batch of Monte Carlo runs at once (shapes in :mod:`uwtutor.models.base`). A filter
family is written once against these two interfaces -- the Kalman family through :math:`f, F, Q` and
:math:`h, H, R`, the particle filters through ``sample`` and ``log_likelihood`` -- so that one model pair runs in
every filter, the smoother and the posterior Cramér-Rao bound; a new method is a new pair of models.
"""

from .base import MeasurementModel, ModelPair, MotionModel
from .blocks import (BlockMeasurement, BlockMotion, Current, OdometryPose, OffsetAndRate, Position,
                     RandomWalk, StateBlock)
from .bias import BiasRateDeadReckoning, bias_rate_process_noise, paper_a_process_noise
from .clock import OneWayTravelTimeRanges
from .cooperative import CooperativeMotion, SquaredRangePair, leader_range
from .dead_reckoning import DeadReckoning
from .depth import DepthSensors, DepthSpeedPitch, DepthSpeedPitchModel, PitchManeuver, PitchManeuverModel
from .linear import DirectMeasurement, LinearMeasurement, LinearMotion
from .odometry import OdometryMotion, StateLayout, wrap_angle
from .range import BeaconRanges, BlockRanges, MultiplicativeRange, NoiseSchedule, RangeToBeacon, line_of_sight
from .robust import ConstantVelocity, PositionMeasurement

__all__ = [
    "MotionModel", "MeasurementModel", "ModelPair",
    "DeadReckoning", "LinearMotion", "LinearMeasurement", "DirectMeasurement",
    "DepthSpeedPitch", "PitchManeuver", "DepthSensors", "DepthSpeedPitchModel", "PitchManeuverModel",
    "RangeToBeacon", "MultiplicativeRange", "line_of_sight", "BeaconRanges", "NoiseSchedule",
    "OdometryMotion", "StateLayout", "wrap_angle",
    "BiasRateDeadReckoning", "paper_a_process_noise", "bias_rate_process_noise",
    "CooperativeMotion", "SquaredRangePair", "leader_range",
    "ConstantVelocity", "PositionMeasurement",
    "StateBlock", "BlockMotion", "BlockMeasurement", "BlockRanges", "OdometryPose", "Position", "RandomWalk",
    "Current", "OffsetAndRate", "OneWayTravelTimeRanges",
]
