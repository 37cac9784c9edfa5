"""Motion and measurement models: what the filters of :mod:`uwtutor.filters` filter.

Each model answers for a batch of Monte Carlo runs at once (shapes in :mod:`uwtutor.models.base`). A filter
family is written once against these two interfaces; a new method is a new pair of models.
"""

from .base import MeasurementModel, MotionModel
from .dead_reckoning import DeadReckoning
from .linear import DirectMeasurement, LinearMeasurement, LinearMotion
from .range import RangeToBeacon, line_of_sight
from .robust import ConstantVelocity, PositionMeasurement

__all__ = [
    "MotionModel", "MeasurementModel",
    "DeadReckoning", "LinearMotion", "LinearMeasurement", "DirectMeasurement",
    "RangeToBeacon", "line_of_sight",
    "ConstantVelocity", "PositionMeasurement",
]
