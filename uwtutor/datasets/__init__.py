r"""Real navigation logs: a dataset type you build from your own arrays, and the CMU Plaza sets.

The rest of ``uwtutor`` simulates. This package brings recorded data into the same flow,
**dataset -> measurements -> filter -> result -> metrics**: a :class:`RangeDataset` holds

* ``times`` (K,) -- the odometry epochs [s];
* ``odometry`` (K, 2) -- body-frame ``[distance travelled, heading change]`` per step, row k from ``times[k-1]``
  to ``times[k]`` (row 0 unused, normally zeros);
* ``ranges`` (J, 3) -- the range log, rows ``[time, beacon id, range]`` sorted by time;
* ``beacons`` -- ``{id: (x, y)}``, the beacons' known positions;
* optionally ``truth`` (K, 3) ``[x, y, heading]``, and ``start`` (3,) / ``start_cov`` (3, 3) for the filters.

:meth:`RangeDataset.dead_reckoning` integrates the odometry (heading counter-clockwise from +x; each step moves
along the previous heading, then turns); :meth:`RangeDataset.ranges_on_epochs` places the range log on the epochs as a
``(K, B)`` array with NaN where a beacon was not heard, thinned to an acoustic modem's rate with ``min_period``.

:func:`plaza` loads the two CMU Plaza sets (a robot with wheel odometry ranging by radio to 4 beacons, with
ground truth; Djugash, Hamner and Roth 2009) from the copies in GTSAM's wheel: ``pip install "uwtutor[data]"``.

:func:`navigate` is the recommended filter for such a log in one call: heading, gyro bias and range scale in the
state, gated, smoothed when asked; :func:`navigation_models` gives its model pair, for any other filter (the
particle filter). The dataset type and the loaders import only numpy, scipy and the lower layers of
``uwtutor`` (``_validate``, ``motion``); ``navigate`` (module ``navigation``) sits on top of the models and filters.

Examples
--------
>>> import numpy as np
>>> from uwtutor.datasets import RangeDataset
>>> data = RangeDataset(
...     times=[0.0, 2.0, 4.0],
...     odometry=[[0, 0], [2, 0], [2, 0]],
...     ranges=[[2.1, 1, 3.0]],
...     beacons={1: (2.0, 3.0)},
...     start=[0.0, 0.0, 0.0],
... )
>>> data.ranges_on_epochs([1])
array([[nan],
       [ 3.],
       [nan]])
"""

from ._core import DEFAULT_START_SIGMAS, RangeDataset, square_log
from ._plaza import PLAZA_HEADING_OFFSET, plaza
from .navigation import CANDIDATES, NavigationModels, NavigationResult, navigate, navigation_gate, navigation_models

__all__ = ["RangeDataset", "plaza", "navigate", "navigation_models", "navigation_gate", "NavigationModels",
           "NavigationResult", "CANDIDATES", "DEFAULT_START_SIGMAS",
           "PLAZA_HEADING_OFFSET", "square_log"]
