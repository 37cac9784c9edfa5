r"""The dataset type: a log of odometry and ranges to beacons at known positions, built from your own arrays."""

from __future__ import annotations

import os
import types
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, TypeAlias

import numpy as np

from .._linalg import distances
from .._validate import (as_choice, as_covariance, as_finite, as_float_array, as_instance, as_int, as_positive,
                         as_times, readonly)
from ..motion import integrate_odometry

__all__ = ["RangeDataset", "DEFAULT_START_SIGMAS", "square_log"]

#: The beacons a method uses: one beacon id, a sequence of them, or None for every beacon of the log.
BeaconIds: TypeAlias = "int | Sequence[int] | None"

#: Standard deviations ``(x [m], y [m], heading [rad])`` of the default ``start_cov``: a start known about as
#: well as a survey-grade GPS fix and a good compass know it (0.1 m, 1 degree).
DEFAULT_START_SIGMAS: tuple[float, float, float] = (0.1, 0.1, float(np.radians(1.0)))

_SORT_HINT = "sort them with ranges[np.argsort(ranges[:, 0], kind='stable')]"


def _as_beacons(value: Any) -> Mapping[int, tuple[float, float]]:
    """A read-only ``{int id: (x, y)}`` mapping, checked entry by entry."""
    if not isinstance(value, Mapping):
        raise TypeError("beacons must be a dict {beacon id: (x, y)}, e.g. {0: (10.0, -5.0), 1: (40.0, 3.5)}; "
                        f"got {type(value).__name__}")
    out: dict[int, tuple[float, float]] = {}
    for key, xy in value.items():
        try:
            ident = as_int("a beacon id (a key of beacons)", key)
        except TypeError as exc:
            raise TypeError(f"{exc}. The beacon ids must be integers, as in column 1 of ranges") from None
        pos = as_finite(f"beacons[{ident}]", xy, shape=(2,))
        out[ident] = (float(pos[0]), float(pos[1]))
    return types.MappingProxyType(dict(sorted(out.items())))


def _check_ranges(arr: np.ndarray, times: np.ndarray, beacons: Mapping[int, Any]) -> None:
    """Column by column: times finite, sorted and inside the epochs' span; ids integral and known; ranges >= 0."""
    if arr.shape[0] == 0:
        return
    t, ids, r = arr[:, 0], arr[:, 1], arr[:, 2]
    bad = ~np.isfinite(t)
    if bad.any():
        j = int(np.argmax(bad))
        raise ValueError(f"ranges[:, 0] (the times) must be finite; got {t[j]} at row {j}")
    back = np.diff(t) < 0
    if back.any():
        j = int(np.argmax(back)) + 1
        raise ValueError(f"ranges must be sorted by time (column 0): ranges[{j}, 0] = {t[j]:g} s comes after "
                         f"{t[j - 1]:g} s. {_SORT_HINT[0].upper() + _SORT_HINT[1:]} (rows at the same time may "
                         "stay in any order)")
    outside = (t < times[0]) | (t > times[-1])
    if outside.any():
        j = int(np.argmax(outside))
        raise ValueError(f"ranges[{j}, 0] = {t[j]:g} s lies outside the epochs' span [{times[0]:g}, {times[-1]:g}] s: "
                         "every range needs an odometry epoch to sit on. Drop the rows outside, e.g. "
                         "ranges[(ranges[:, 0] >= times[0]) & (ranges[:, 0] <= times[-1])]")
    whole = np.isfinite(ids) & (ids == np.round(ids))
    if not whole.all():
        j = int(np.argmax(~whole))
        raise ValueError(f"ranges[:, 1] (the beacon ids) must be whole numbers; got {ids[j]} at row {j}")
    known = np.isin(ids, np.array(list(beacons), dtype=float))
    if not known.all():
        j = int(np.argmax(~known))
        unknown = sorted({int(i) for i in ids[~known]})
        raise ValueError(f"ranges[{j}, 1] names beacon {int(ids[j])}, which is not in beacons (known ids: "
                         f"{list(beacons)}; unknown ids in ranges: {unknown}). Add its position to beacons or drop "
                         "its rows")
    bad = ~np.isfinite(r) | (r < 0)
    if bad.any():
        j = int(np.argmax(bad))
        raise ValueError(f"ranges[:, 2] (the ranges) must be finite and >= 0; got {r[j]} at row {j}. A range "
                         "that was not measured has no row (NaN is not needed here)")


@dataclass(frozen=True, eq=False, repr=False)
class RangeDataset:
    r"""A navigation log: body-frame odometry at epochs, ranges to beacons at known positions, and maybe the truth.

    Build one from your own arrays (every field is checked, with an error that names the field and says how to
    fix it), or load a real one with :func:`uwtutor.datasets.plaza`. The arrays are stored read-only.

    Parameters
    ----------
    times : array_like, shape (K,)
        The odometry epochs :math:`t_k` [s], strictly increasing.
    odometry : array_like, shape (K, 2)
        Body-frame motion per step, ``[distance travelled, heading change]`` :math:`[d_k, \delta_k]` [m, rad]:
        row :math:`k` is the motion from ``times[k-1]`` to ``times[k]``. Row 0 would be the motion *before* the
        first epoch: it is not used (the pose at ``times[0]`` is ``start``) and is normally ``[0, 0]``. A
        distance may be negative (reversing); no value may be NaN or infinite. How the rows integrate into poses
        is :meth:`dead_reckoning`.
    ranges : array_like, shape (J, 3)
        One row per measured range: ``[time [s], beacon id, range [m]]``, sorted by time (rows at the same time,
        to different beacons, are fine). Rows out of time order are refused, not silently sorted: sort them with
        ``ranges[np.argsort(ranges[:, 0], kind="stable")]`` after checking why they were out of order. Every time
        must lie within ``[times[0], times[-1]]``; every id must be a key of ``beacons``; every range finite and
        >= 0. ``J = 0`` (shape ``(0, 3)``) is allowed.
    beacons : dict
        ``{beacon id (int): (x, y)}`` [m], the known beacon positions in the frame of ``truth`` and ``start``.
    truth : array_like, shape (K, 3), optional
        The true pose ``[x, y, heading]`` [m, m, rad] at every epoch, for studies and metrics. The heading is
        measured as everywhere in ``uwtutor``: from +x, counter-clockwise positive, in the direction of travel.
    start : array_like, shape (3,), optional
        The pose ``[x, y, heading]`` at ``times[0]`` from which to dead-reckon. Default: ``truth[0]`` when the
        truth is given, otherwise ``None`` (then :meth:`dead_reckoning` asks for it).
    start_cov : array_like, shape (3, 3), optional
        Covariance of ``start`` [m², m², rad²]: symmetric positive semi-definite. Default (when there is a start):
        ``diag(DEFAULT_START_SIGMAS)**2``, i.e. 0.1 m and 1 degree.
    name : str, default "dataset"
        A label for plots and summaries.
    notes : tuple of str, default ()
        Provenance: what a loader found and changed in the files (shown by :meth:`summary`).
    heading_unit : {"rad", "deg"}, default "rad"
        The unit of the heading changes (``odometry[:, 1]``), of the truth's and the start's headings, and of
        the heading entries of ``start_cov``. Degrees are converted to radians on construction.
    heading_convention : {"ccw-from-x", "cw-from-north"}, default "ccw-from-x"
        How those headings are measured: counter-clockwise from +x (the library's), or clockwise from north
        (a compass's, with x east and y north): :math:`\theta = \pi/2 - \psi`, a turn to the right positive.
        Converted on construction; the dataset then holds the library's convention (and says so in ``notes``).

    Warns
    -----
    UserWarning
        When the headings look like another unit or convention than the one given: a heading change of more than
        :math:`\pi` in one step (degrees read as radians), or odometry that turns against the truth (a clockwise
        convention read as counter-clockwise).

    Notes
    -----
    Data flow one way, as everywhere in ``uwtutor``: a dataset stands where a simulated scenario does, and
    :meth:`ranges_on_epochs` turns its range log into the ``(K, B)`` array of ranges per epoch (NaN where a beacon
    was not heard) that the filters take, with the odometry rows as their inputs.

    Examples
    --------
    A vehicle drives east at 1 m/s for 4 s, hearing two beacons:

    >>> import numpy as np
    >>> from uwtutor.datasets import RangeDataset
    >>> data = RangeDataset(
    ...     times=[0.0, 1.0, 2.0, 3.0, 4.0],
    ...     odometry=[[0, 0], [1, 0], [1, 0], [1, 0], [1, 0]],
    ...     ranges=[[0.9, 7, 10.1], [1.0, 3, 5.0], [2.2, 7, 8.2], [3.6, 3, 5.1]],
    ...     beacons={3: (2.0, 5.0), 7: (10.0, 0.0)},
    ...     start=[0.0, 0.0, 0.0],
    ...     name="east")
    >>> data
    RangeDataset('east': 5 epochs over 4 s, 4 ranges to beacons [3, 7], no truth)
    >>> data.dead_reckoning()[-1]
    array([4., 0., 0.])
    >>> data.ranges_on_epochs([3, 7])
    array([[ nan,  nan],
           [ 5. , 10.1],
           [ nan,  8.2],
           [ nan,  nan],
           [ 5.1,  nan]])

    A bad field is named, with the fix:

    >>> RangeDataset(times=[0.0, 1.0], odometry=[[0, 0]], ranges=np.zeros((0, 3)),
    ...              beacons={})  # doctest: +ELLIPSIS
    Traceback (most recent call last):
        ...
    ValueError: odometry must have one row per epoch, K = len(times) = 2; got 1 row(s). Row k is the motion from ...
    """

    times: np.ndarray
    odometry: np.ndarray
    ranges: np.ndarray
    beacons: Mapping[int, tuple[float, float]]
    truth: np.ndarray | None = None
    start: np.ndarray | None = None
    start_cov: np.ndarray | None = None
    name: str = "dataset"
    notes: tuple[str, ...] = field(default=())
    heading_unit: str = "rad"
    heading_convention: str = "ccw-from-x"

    def __post_init__(self) -> None:
        t = as_times("times", self.times)
        K = len(t)
        odo = as_float_array("odometry", self.odometry, ndim=2)
        if odo.shape[1] != 2:
            raise ValueError(f"odometry must have 2 columns, [distance travelled, heading change]; got shape "
                             f"{odo.shape}")
        if odo.shape[0] != K:
            raise ValueError(f"odometry must have one row per epoch, K = len(times) = {K}; got {odo.shape[0]} "
                             "row(s). Row k is the motion from times[k-1] to times[k]; if your log has K - 1 steps, "
                             "put a row [0, 0] first for the first epoch")
        bad = ~np.isfinite(odo)
        if bad.any():
            k, c = (int(i) for i in np.argwhere(bad)[0])
            what = ("distance" if c == 0 else "heading change")
            raise ValueError(f"odometry must be finite; got {odo[k, c]} at row {k} ({what}). A step without motion "
                             "is [0, 0]; fill or interpolate a gap in the log rather than writing NaN")
        beacons = _as_beacons(self.beacons)
        rng = as_float_array("ranges", self.ranges, ndim=2)
        if rng.shape[1] != 3:
            raise ValueError(f"ranges must have 3 columns, [time, beacon id, range]; got shape {rng.shape}")
        _check_ranges(rng, t, beacons)

        truth = None
        if self.truth is not None:
            truth = as_finite("truth", self.truth, ndim=2)
            if truth.shape != (K, 3):
                raise ValueError(f"truth must have shape (K, 3) = ({K}, 3), a pose [x, y, heading] at each epoch; "
                                 f"got {truth.shape}")
        start = self.start
        if start is None and truth is not None:
            start = truth[0]
        if start is not None:
            start = as_finite("start", start, shape=(3,))
        cov = self.start_cov
        if cov is not None and start is None:
            raise ValueError("start_cov is given but there is no start pose: give start=(x, y, heading) too "
                             "(or the truth, whose first row is then the start)")
        if cov is None and start is not None:
            cov = np.diag(np.square(DEFAULT_START_SIGMAS))
        if cov is not None:
            cov = as_covariance("start_cov", cov, 3, allow_singular=True)
        name = as_instance("name", self.name, str)
        notes = self.notes
        if isinstance(notes, str) or not all(isinstance(n, str) for n in notes):
            raise TypeError("notes must be a tuple of strings, e.g. ('ranges sorted by time',)")

        odo, truth, start, cov, notes = _to_library_headings(self.heading_unit, self.heading_convention, odo, truth,
                                                             start, cov, tuple(notes))
        _check_headings(odo, truth, t)
        object.__setattr__(self, "heading_unit", "rad")
        object.__setattr__(self, "heading_convention", "ccw-from-x")
        for key, value in (("times", t), ("odometry", odo), ("ranges", rng), ("truth", truth), ("start", start),
                           ("start_cov", cov)):
            object.__setattr__(self, key, None if value is None else readonly(value))
        object.__setattr__(self, "beacons", beacons)
        object.__setattr__(self, "name", name)
        object.__setattr__(self, "notes", tuple(notes))

    # ------------------------------------------------------------------------------------------------------------
    # sizes

    @property
    def beacon_ids(self) -> tuple[int, ...]:
        """The beacons' ids, sorted."""
        return tuple(self.beacons)

    @property
    def n_epochs(self) -> int:
        """Number of odometry epochs :math:`K`."""
        return len(self.times)

    @property
    def n_ranges(self) -> int:
        """Number of range rows :math:`J`."""
        return len(self.ranges)

    @property
    def duration(self) -> float:
        """``times[-1] - times[0]`` [s]."""
        return float(self.times[-1] - self.times[0])

    # ------------------------------------------------------------------------------------------------------------
    # beacons

    def _ids(self, beacon_ids: BeaconIds) -> list[int]:
        """Validate a selection of beacons: one id, a sequence of distinct known ids, or None for all."""
        if beacon_ids is None:
            return list(self.beacon_ids)
        if isinstance(beacon_ids, (int, np.integer)) and not isinstance(beacon_ids, (bool, np.bool_)):
            beacon_ids = [beacon_ids]
        if isinstance(beacon_ids, (str, bytes)) or not hasattr(beacon_ids, "__iter__"):
            raise TypeError(f"beacon_ids must be a beacon id or a list of them, e.g. {list(self.beacon_ids)}; "
                            f"got {beacon_ids!r}")
        ids = [as_int("beacon_ids[...]", b) for b in beacon_ids]
        if not ids:
            raise ValueError(f"beacon_ids is empty; name at least one of {list(self.beacon_ids)}")
        unknown = [b for b in ids if b not in self.beacons]
        if unknown:
            raise ValueError(f"beacon_ids names {unknown}, not in this dataset's beacons {list(self.beacon_ids)}")
        if len(set(ids)) != len(ids):
            raise ValueError(f"beacon_ids must not repeat an id; got {ids}")
        return ids

    def beacon_positions(self, beacon_ids: BeaconIds = None) -> np.ndarray:
        """The positions of the beacons, in the order asked.

        Parameters
        ----------
        beacon_ids : int or sequence of int, optional
            Which beacons (default: all, sorted by id).

        Returns
        -------
        ndarray, shape (B, 2)
            ``[x, y]`` [m] of each.

        Examples
        --------
        >>> from uwtutor.datasets import RangeDataset
        >>> data = RangeDataset(
        ...     [0.0, 1.0],
        ...     [[0, 0], [1, 0]],
        ...     [[0.5, 2, 3.0]],
        ...     {1: (0.0, 5.0), 2: (3.0, 4.0)},
        ... )
        >>> data.beacon_positions([2, 1])
        array([[3., 4.],
               [0., 5.]])
        """
        return np.array([self.beacons[b] for b in self._ids(beacon_ids)], dtype=float).reshape(-1, 2)

    # ------------------------------------------------------------------------------------------------------------
    # what the filters take

    def dead_reckoning(self) -> np.ndarray:
        r"""Poses integrated from ``start`` with the odometry alone: the track a vehicle without ranges believes.

        With :math:`[d_k, \delta_k]` = ``odometry[k]`` and :math:`[x_0, y_0, \psi_0]` = ``start``, each step moves
        :math:`d_k` along the previous heading, then turns by :math:`\delta_k`
        (:func:`uwtutor.motion.integrate_odometry`):

        .. math::

            \begin{bmatrix} x_k \\ y_k \end{bmatrix} = \begin{bmatrix} x_{k-1} \\ y_{k-1} \end{bmatrix}
            + d_k \begin{bmatrix} \cos\psi_{k-1} \\ \sin\psi_{k-1} \end{bmatrix}, \qquad
            \psi_k = \psi_{k-1} + \delta_k.

        The heading :math:`\psi` is measured from +x, counter-clockwise positive; a positive heading change turns
        left. Of the usual rules (turn before the distance, after it, or move along the mean heading) this is the
        one the Plaza logs follow best (see :func:`uwtutor.datasets.plaza`).

        Returns
        -------
        ndarray, shape (K, 3)
            ``[x, y, heading]`` at each epoch; row 0 is ``start``. The heading is not wrapped (continuous).

        Examples
        --------
        Round a 1 m square, turning left a quarter turn at each corner:

        >>> import numpy as np
        >>> from uwtutor.datasets import RangeDataset
        >>> turn = np.pi / 2
        >>> data = RangeDataset(
        ...     np.arange(5.0),
        ...     [[0, 0], [1, turn], [1, turn], [1, turn], [1, turn]],
        ...     np.zeros((0, 3)),
        ...     {},
        ...     start=[0.0, 0.0, 0.0],
        ... )
        >>> data.dead_reckoning()[:, :2].round(6) + 0.0
        array([[0., 0.],
               [1., 0.],
               [1., 1.],
               [0., 1.],
               [0., 0.]])
        """
        if self.start is None:
            raise ValueError(f"dead_reckoning needs a start pose, and {self.name!r} has none: build the dataset "
                             "with start=(x, y, heading), or with truth= (whose first row is the start)")
        return integrate_odometry(self.start, self.odometry)

    def _thin(self, rows: np.ndarray, min_period: float, start: float = -np.inf) -> np.ndarray:
        """Indices into ``rows`` (sorted by time) kept by the greedy ``min_period`` rule from ``start`` on."""
        keep: list[int] = []
        last = start - min_period
        for j, t in enumerate(rows[:, 0]):
            if t - last >= min_period:
                keep.append(j)
                last = t
        return np.asarray(keep, dtype=int)

    def ranges_on_epochs(self, beacon_ids: BeaconIds = None, min_period: float | None = None, offset: float = 0.0,
                         thinning: str = "per beacon") -> np.ndarray:
        r"""The range log placed on the odometry epochs: one column per beacon, NaN where a beacon was not heard.

        The rules, in order, beacon by beacon:

        1. **Thinning** (with ``min_period``): the first range at or after ``times[0] + offset`` is kept, then
           every range at least ``min_period`` seconds after the last one kept; the others are dropped. This turns
           a fast radio log (the Plaza sets range each beacon about every 1-2 s) into the sparse pings of an
           acoustic modem (every few seconds or more), without randomness; each ``offset`` in
           ``[0, min_period)`` gives another schedule of the same log. ``thinning="per beacon"`` thins each
           beacon's ranges on its own (B beacons give about B ranges per period); ``"in total"`` thins the
           ranges of all the chosen beacons together, one range per period in all (a modem that interrogates one
           beacon at a time).
        2. **Placement**: each range goes to the epoch nearest in time, :math:`k = \arg\min_k |t - t_k|` (a tie
           goes to the earlier epoch). Its time is thus moved by at most half an epoch spacing; the vehicle's
           motion in that time is the error this adds (at 1 m/s and 5 epochs per second, 0.1 m at most).
        3. **One per epoch**: if several ranges of one beacon land on the same epoch, the one nearest in time to
           it is kept (a tie keeps the earlier row).

        Different beacons are independent: one epoch may hold ranges to several beacons.

        Parameters
        ----------
        beacon_ids : int or sequence of int, optional
            The beacons, one column each, in this order (default: all, sorted by id).
        min_period : float, optional
            The shortest time [s] between two ranges kept (for one beacon, or in all), > 0 (default: keep every
            range).
        offset : float, default 0
            The thinning starts this many seconds after ``times[0]`` (>= 0; needs ``min_period``).
        thinning : {"per beacon", "in total"}, default "per beacon"
            Thin each beacon on its own, or all the chosen beacons' ranges together.

        Returns
        -------
        ndarray, shape (K, B)
            Ranges [m]; NaN where the beacon has no range at that epoch.

        Examples
        --------
        >>> from uwtutor.datasets import RangeDataset
        >>> data = RangeDataset(
        ...     times=[0.0, 1.0, 2.0, 3.0],
        ...     odometry=[[0, 0], [1, 0], [1, 0], [1, 0]],
        ...     ranges=[
        ...         [0.2, 5, 10.0],
        ...         [0.7, 5, 11.0],
        ...         [1.1, 5, 12.0],
        ...         [1.1, 9, 20.0],
        ...         [2.9, 5, 13.0],
        ...     ],
        ...     beacons={5: (0.0, 10.0), 9: (20.0, 0.0)},
        ...     start=[0.0, 0.0, 0.0],
        ... )
        >>> data.ranges_on_epochs()
        array([[10., nan],
               [12., 20.],
               [nan, nan],
               [13., nan]])

        The range at 0.7 s lands on epoch 1 (nearest) together with the one at 1.1 s, which is nearer and kept.
        Thinned to one range every 2 s per beacon:

        >>> data.ranges_on_epochs([5], min_period=2.0)
        array([[10.],
               [nan],
               [nan],
               [13.]])

        The same schedule started 0.5 s later, and one range every 2 s to either beacon:

        >>> data.ranges_on_epochs([5], min_period=2.0, offset=0.5)
        array([[nan],
               [11.],
               [nan],
               [13.]])
        >>> data.ranges_on_epochs(min_period=2.0, thinning="in total")
        array([[10., nan],
               [nan, nan],
               [nan, nan],
               [13., nan]])
        """
        ids = self._ids(beacon_ids)
        period = None if min_period is None else float(as_positive("min_period", min_period, ndim=0))
        thinning = as_choice("thinning", thinning, ("per beacon", "in total"))
        shift = float(as_finite("offset", offset, ndim=0, max_abs=1e12))
        if shift < 0.0:
            raise ValueError(f"offset must be >= 0 (seconds after times[0]); got {shift:g}")
        if shift > 0.0 and period is None:
            raise ValueError("offset shifts the thinning's schedule: give min_period too (e.g. min_period=10.0, "
                             "offset=3.0)")
        K = self.n_epochs
        out = np.full((K, len(ids)), np.nan)
        times = self.times
        start = float(times[0]) + shift
        log = self.ranges
        if period is not None and thinning == "in total":
            log = log[np.isin(log[:, 1], ids)]
            log = log[self._thin(log, period, start)]
        for col, beacon in enumerate(ids):
            rows = log[log[:, 1] == beacon]
            if period is not None and thinning == "per beacon" and len(rows):
                rows = rows[self._thin(rows, period, start)]
            if not len(rows):
                continue
            t = rows[:, 0]
            right = np.clip(np.searchsorted(times, t, side="left"), 0, K - 1)
            left = np.clip(right - 1, 0, K - 1)
            k = np.where(np.abs(t - times[left]) <= np.abs(times[right] - t), left, right)
            gap = np.abs(t - times[k])
            order = np.lexsort((np.arange(len(t)), gap, k))          # by epoch, then nearest, then first row
            k_sorted = k[order]
            first = np.concatenate([[True], k_sorted[1:] != k_sorted[:-1]])
            chosen = order[first]
            out[k[chosen], col] = rows[chosen, 2]
        return out

    def true_ranges(self, beacon_ids: BeaconIds = None) -> np.ndarray:
        r"""Distances from the true positions at the epochs to the beacons, :math:`\|p_k - b\|` (for studies).

        Parameters
        ----------
        beacon_ids : int or sequence of int, optional
            The beacons, one column each (default: all, sorted by id).

        Returns
        -------
        ndarray, shape (K, B)
            True horizontal distances [m], on the same grid as :meth:`ranges_on_epochs`: the two can be compared
            column by column (e.g. to measure a range scale factor or the range noise).

        Examples
        --------
        >>> from uwtutor.datasets import RangeDataset
        >>> data = RangeDataset(
        ...     [0.0, 1.0],
        ...     [[0, 0], [3, 0]],
        ...     [[1.0, 0, 5.1]],
        ...     {0: (3.0, 4.0)},
        ...     truth=[[0.0, 0.0, 0.0], [3.0, 0.0, 0.0]],
        ... )
        >>> data.true_ranges()
        array([[5.],
               [4.]])
        """
        if self.truth is None:
            raise ValueError(f"true_ranges needs the truth, and {self.name!r} has none (truth=None)")
        b = self.beacon_positions(beacon_ids)
        return distances(self.truth[:, None, :2], b[None, :, :])

    # ------------------------------------------------------------------------------------------------------------
    # saving and showing

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write the dataset to a ``.npz`` file (plain arrays, no pickle); :meth:`load` reads it back.

        Parameters
        ----------
        path : str or path-like
            The file to write (numpy adds ``.npz`` if the name lacks it).
        """
        ids = np.array(self.beacon_ids, dtype=np.int64)
        arrays: dict[str, Any] = {
            "times": self.times, "odometry": self.odometry, "ranges": self.ranges,
            "beacon_ids": ids, "beacon_xy": self.beacon_positions(list(ids)) if len(ids) else np.zeros((0, 2)),
            "name": np.array(self.name), "notes": np.array(self.notes, dtype=str),
        }
        for key in ("truth", "start", "start_cov"):
            value = getattr(self, key)
            if value is not None:
                arrays[key] = value
        np.savez(path, **arrays)

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> "RangeDataset":
        """Read a dataset written by :meth:`save` (every field is checked again).

        Parameters
        ----------
        path : str or path-like
            A ``.npz`` file written by :meth:`save`.

        Returns
        -------
        RangeDataset

        Examples
        --------
        >>> import tempfile, pathlib
        >>> from uwtutor.datasets import RangeDataset
        >>> data = RangeDataset(
        ...     [0.0, 1.0],
        ...     [[0, 0], [1, 0]],
        ...     [[0.5, 2, 3.0]],
        ...     {2: (3.0, 4.0)},
        ...     start=[0, 0, 0],
        ... )
        >>> with tempfile.TemporaryDirectory() as folder:
        ...     path = pathlib.Path(folder) / "log.npz"
        ...     data.save(path)
        ...     again = RangeDataset.load(path)
        >>> again
        RangeDataset('dataset': 2 epochs over 1 s, 1 ranges to beacons [2], no truth)
        """
        with np.load(path, allow_pickle=False) as f:
            ids = f["beacon_ids"]
            xy = f["beacon_xy"]
            beacons = {int(i): (float(p[0]), float(p[1])) for i, p in zip(ids, xy)}
            return cls(times=f["times"], odometry=f["odometry"], ranges=f["ranges"], beacons=beacons,
                       truth=f["truth"] if "truth" in f else None, start=f["start"] if "start" in f else None,
                       start_cov=f["start_cov"] if "start_cov" in f else None, name=str(f["name"]),
                       notes=tuple(str(n) for n in f["notes"]))

    def __repr__(self) -> str:
        return (f"RangeDataset({self.name!r}: {self.n_epochs} epochs over {self.duration:.4g} s, {self.n_ranges} "
                f"ranges to beacons {list(self.beacon_ids)}, {'with' if self.truth is not None else 'no'} truth)")

    def summary(self) -> str:
        """A few lines on what the dataset holds: epochs, odometry rate, ranges per beacon, truth, start, notes.

        Examples
        --------
        >>> from uwtutor.datasets import RangeDataset
        >>> data = RangeDataset(
        ...     [0.0, 1.0, 2.0],
        ...     [[0, 0], [1, 0], [1, 0]],
        ...     [[0.5, 2, 3.0], [1.5, 2, 2.5]],
        ...     {2: (3.0, 4.0), 4: (0.0, -1.0)},
        ...     start=[0, 0, 0],
        ...     name="demo",
        ... )
        >>> print(data.summary())
        demo: 3 epochs over 2 s (odometry at 1 Hz), 2 m travelled by odometry
        2 ranges to 2 beacons:
          beacon 2 at (3, 4) m: 2 ranges (1 per s), 2.5 to 3 m
          beacon 4 at (0, -1) m: no ranges
        truth: none
        start: (0, 0) m, heading 0 deg
        """
        K, J = self.n_epochs, self.n_ranges
        T = self.duration
        rate = f"odometry at {(K - 1) / T:.3g} Hz" if K > 1 else "a single epoch"
        lines = [f"{self.name}: {K} epochs over {T:.4g} s ({rate}), "
                 f"{np.abs(self.odometry[1:, 0]).sum():.5g} m travelled by odometry",
                 f"{J} ranges to {len(self.beacons)} beacons:"]
        for b, (x, y) in self.beacons.items():
            r = self.ranges[self.ranges[:, 1] == b, 2]
            where = f"  beacon {b} at ({x:.4g}, {y:.4g}) m: "
            if len(r) == 0:
                lines.append(where + "no ranges")
            else:
                per_s = f" ({len(r) / T:.3g} per s)" if T > 0 else ""
                lines.append(where + f"{len(r)} ranges{per_s}, {r.min():.3g} to {r.max():.3g} m")
        lines.append("truth: " + ("[x, y, heading] at every epoch" if self.truth is not None else "none"))
        if self.start is None:
            lines.append("start: none")
        else:
            lines.append(f"start: ({self.start[0]:.4g}, {self.start[1]:.4g}) m, heading "
                         f"{np.degrees(self.start[2]):.4g} deg")
        lines.extend(f"note: {n}" for n in self.notes)
        return "\n".join(lines)


def _to_library_headings(unit: Any, convention: Any, odo: np.ndarray, truth: np.ndarray | None,
                         start: np.ndarray | None, cov: np.ndarray | None, notes: tuple[str, ...]) -> tuple[Any, ...]:
    """The headings in radians, counter-clockwise from +x (RangeDataset's heading_unit and heading_convention)."""
    unit = as_choice("heading_unit", unit, ("rad", "deg"))
    convention = as_choice("heading_convention", convention, ("ccw-from-x", "cw-from-north"))
    if unit == "rad" and convention == "ccw-from-x":
        return odo, truth, start, cov, notes
    factor = np.pi / 180.0 if unit == "deg" else 1.0
    sign = -1.0 if convention == "cw-from-north" else 1.0
    turn = np.array([1.0, 1.0, sign * factor])            # d(library heading) / d(given heading), per component
    odo = odo * np.array([1.0, sign * factor])
    if truth is not None:
        truth = truth.copy()
        truth[:, 2] = truth[:, 2] * sign * factor + (np.pi / 2 if sign < 0 else 0.0)
    if start is not None:
        start = start.copy()
        start[2] = start[2] * sign * factor + (np.pi / 2 if sign < 0 else 0.0)
    if cov is not None:
        cov = cov * np.outer(turn, turn)
    what = ("degrees" if unit == "deg" else "radians") + (", clockwise from north" if sign < 0 else "")
    return odo, truth, start, cov, notes + (f"headings converted from {what} to radians counter-clockwise from +x",)


def _check_headings(odo: np.ndarray, truth: np.ndarray | None, times: np.ndarray) -> None:
    """Warn when the headings look like another unit or convention (RangeDataset's Warns section)."""
    hint = ("pass heading_unit='deg' if they are in degrees, heading_convention='cw-from-north' if they are "
            "measured clockwise from north")
    big = np.abs(odo[1:, 1]) > np.pi
    if big.any():
        warnings.warn(f"odometry[:, 1] holds heading changes of up to {np.abs(odo[1:, 1]).max():.4g} rad in one "
                      f"step ({int(big.sum())} steps beyond pi): not radians? {hint}", UserWarning, stacklevel=4)
    if truth is None or len(times) < 3:
        return
    true_turn = np.diff(np.unwrap(truth[:, 2]))
    moving = np.abs(odo[1:, 1]) + np.abs(true_turn) > 0
    if moving.sum() >= 10 and np.std(odo[1:, 1][moving]) > 0 and np.std(true_turn[moving]) > 0:
        corr = float(np.corrcoef(odo[1:, 1][moving], true_turn[moving])[0, 1])
        if corr < -0.5:
            warnings.warn(f"the odometry turns against the truth (correlation {corr:.2f} of their heading "
                          f"changes): the two headings are measured in opposite senses; {hint}", UserWarning,
                          stacklevel=4)


def square_log(range_scale: float = 1.0, range_offset: float = 0.0) -> RangeDataset:
    r"""A small synthetic log in the form of the real ones: a 10 m square driven twice, ranging to two beacons.

    The vehicle drives 1 m an epoch and turns 90° every 10 epochs (81 epochs, odometry ``[distance, heading
    change]``), and ranges at every epoch after the first, to beacon 7 at (-4, 3) m and beacon 3 at (5, 12) m in
    turn. The ranges are :math:`r = s\,d + b` for the true distance :math:`d` (no noise): ``range_scale`` :math:`s`
    (a sound-speed error in all but name) and ``range_offset`` :math:`b`. The truth is the odometry integrated from
    the origin, heading east. Every filter of :mod:`uwtutor.datasets` runs on it in milliseconds, which is what the
    examples of this package use it for.

    Parameters
    ----------
    range_scale : float, default 1
        Scale factor :math:`s` of the ranges, > 0.
    range_offset : float, default 0
        Offset :math:`b` added to every range [m], >= 0.

    Returns
    -------
    RangeDataset
        With ``truth``.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.datasets import square_log
    >>> data = square_log()
    >>> data.times.shape, data.ranges.shape, sorted(data.beacons)
    ((81,), (80, 3), [3, 7])
    >>> # noise-free ranges: the truth's distance to each beacon
    >>> beacon = np.array([data.beacons[int(i)] for i in data.ranges[:, 1]])
    >>> d = np.linalg.norm(data.truth[1:, :2] - beacon, axis=1)
    >>> scaled = square_log(1.05).ranges[:, 2]
    >>> bool(np.allclose(data.ranges[:, 2], d)), bool(np.allclose(scaled, 1.05 * d))
    (True, True)
    """
    s = as_positive("range_scale", range_scale, ndim=0, max_abs=1e6)      # bounded, as range_offset is
    b = float(as_finite("range_offset", range_offset, ndim=0, max_abs=1e6))
    if b < 0.0:
        raise ValueError(f"range_offset must be >= 0 (a range is never negative); got {b:g}")
    K = 81
    turn = np.where(np.arange(K) % 10 == 1, np.pi / 2, 0.0)
    turn[:2] = 0.0
    odometry = np.column_stack([np.r_[0.0, np.ones(K - 1)], turn])
    beacons = {3: (5.0, 12.0), 7: (-4.0, 3.0)}
    times = np.arange(K, dtype=float)
    truth = RangeDataset(times=times, odometry=odometry, ranges=np.empty((0, 3)), beacons=beacons,
                         start=np.zeros(3)).dead_reckoning()
    ids = np.where(np.arange(1, K) % 2 == 0, 3, 7)
    r = float(s) * distances(truth[1:, :2], np.array([beacons[i] for i in ids]), "norm") + b
    return RangeDataset(times=times, odometry=odometry, ranges=np.column_stack([np.arange(1.0, K), ids, r]),
                        beacons=beacons, truth=truth)
