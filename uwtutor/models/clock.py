r"""One-way-travel-time ranges measured by a receiver whose clock drifts.

A beacon sends at a scheduled time :math:`t^{\text{emit}}` on a clock that is right; the vehicle times the arrival
on its own clock, which is :math:`\delta` seconds fast, and turns the travel time into a range with the sound
speed :math:`c`:

.. math::

    z_{k,j} = c\,(t^{\text{arrival}}_{k,j} + \delta_k - t^{\text{emit}}_{k,j})
            = s\,\lVert p_k - b_j \rVert + c\,\delta_k + v_{k,j}, \qquad
    H = \Big[\ s\,\frac{(p_k - b_j)^\mathsf{T}}{\lVert p_k - b_j\rVert}\ \Big|\ c\ \Big|\ 0\ \Big|\
    \lVert p_k - b_j \rVert\ \Big]

on the slots ``position``, ``clock`` (offset :math:`\delta` [s], drift :math:`\dot\delta` [s/s]) and, when the
model is given one, a range ``scale`` :math:`s` (a sound speed that is not the one assumed; :math:`s = 1`
without). The clock is a :class:`~uwtutor.models.blocks.OffsetAndRate` block: a clock that gains 20 µs every
second adds 30 m of range every 1000 s at :math:`c = 1500` m/s, which a filter without the clock in its state
reads as position.

References
----------
Eustice, R. M., Singh, H. and Whitcomb, L. L. (2011). Synchronous-clock, one-way-travel-time acoustic navigation
for underwater vehicles. *Journal of Field Robotics* 28(1), 121-136 (the OWTT range and the clock's drift).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .._validate import as_positive
from .blocks import BlockMotion
from .odometry import StateLayout
from .range import BlockRanges

__all__ = ["OneWayTravelTimeRanges"]


class OneWayTravelTimeRanges(BlockRanges):
    r"""Ranges from one-way travel times timed by a drifting clock: :math:`z_j = s\,\lVert p - b_j\rVert + c\,\delta`.

    The ranges of :class:`~uwtutor.models.range.BlockRanges` (position, and scale when given) plus the clock's term
    :math:`c\,\delta`, read from the ``clock`` slot.

    Parameters
    ----------
    beacons : array_like, shape (B, 2), or dict of id to (x, y)
        The beacons, one measurement component each.
    R : float or array_like
        The range noise [m²]: a variance, ``(B, B)``, or one per step.
    state : BlockMotion or StateLayout
        A state with a ``position`` slot and a ``clock`` slot of two components, the offset then the rate (an
        :class:`~uwtutor.models.blocks.OffsetAndRate` named ``"clock"``).
    sound_speed : float, default 1500
        :math:`c` [m/s], the speed the receiver turns travel times into ranges with.
    slots : dict of str to str, optional
        Other names for ``position`` and ``clock`` in the state.
    scale : str, optional
        The slot of a range scale :math:`s` to read too (e.g. ``"scale"``, a
        :class:`~uwtutor.models.blocks.RandomWalk`).

    Examples
    --------
    A clock 2 ms fast adds 3 m to every range:

    >>> import numpy as np
    >>> from uwtutor.models import (
    ...     BlockMotion,
    ...     OffsetAndRate,
    ...     OneWayTravelTimeRanges,
    ...     Position,
    ... )
    >>> state = BlockMotion(
    ...     Position(np.eye(2)), OffsetAndRate("clock", rate_walk=1e-7), dt=1.0
    ... )
    >>> ranges = OneWayTravelTimeRanges([[0.0, 0.0]], R=0.25, state=state)
    >>> ranges.h(np.array([[30.0, 40.0, 2e-3, 20e-6]]), 0)
    array([[53.]])
    """

    def __init__(self, beacons: Mapping[Any, ArrayLike] | ArrayLike, R: ArrayLike, state: BlockMotion | StateLayout,
                 *, sound_speed: float = 1500.0,
                 slots: dict[str, str] | None = None, scale: str | None = None) -> None:
        renames = dict(slots or {})
        unknown = set(renames) - {"position", "clock"}
        if unknown:
            raise ValueError(f"slots renames {sorted(unknown)}, which this model does not read; it reads "
                             f"['position', 'clock'] (and the scale given by scale=)")
        super().__init__(beacons, R, state, scale=scale, position=renames.get("position", "position"))
        clock = self.add_read(state, "clock", renames.get("clock", "clock"))
        if clock.size != 2:
            raise ValueError(f"the clock slot {renames.get('clock', 'clock')!r} must have 2 components, the offset "
                             f"[s] then the rate [s/s] (an OffsetAndRate block); it has {clock.size}")
        self._offset = int(clock[0])
        self.sound_speed = float(as_positive("sound_speed", sound_speed, ndim=0))

    def linearize(self, x: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Predicted ranges ``(M, B)``, Jacobian ``(M, B, n)``, and a mask
        ``(M, B)``, False where the position is exactly on a beacon."""
        z, H, defined = super().linearize(x, k)      # the ranges: s ||p - b||, its H
        c = self.sound_speed
        H[..., self._offset] = c                     # d z / d delta
        return z + c * x[..., self._offset, None], H, defined

    def h(self, x: np.ndarray, k: int) -> np.ndarray:
        return super().h(x, k) + self.sound_speed * x[..., self._offset, None]
