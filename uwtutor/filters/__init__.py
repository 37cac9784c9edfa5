"""Filters for single-beacon navigation, all following the protocol of :mod:`uwtutor.filters.base`."""

from .base import Filter, FilterResult, run_filter
from .kalman import KalmanFilter

__all__ = ["Filter", "FilterResult", "run_filter", "KalmanFilter"]
