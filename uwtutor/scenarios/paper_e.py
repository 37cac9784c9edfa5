r"""Paper E's simulation: a manned submersible ranging to its GPS-positioned mother ship, ranges with outliers.

``PaperEParameters`` holds the paper's published parameters (sec. 2) beside the few this project had to choose (marked
*chosen* below); ``make(rng, n_runs)`` draws ``n_runs`` dives at once as a ``Dive``: the horizontal scenario of
``scenarios.ship_and_submersible_scenario`` (the same tracks, DR noise and range errors) with the submersible at a
known depth, so that the measured ranges are *slant* ranges, as an acoustic system measures them.

Published (paper E, sec. 2): 1200 s at 1 s; the ship weaves on an S-shaped track, right then left, at a turn rate of
"0.3" (read as 0.3 deg/s: 0.3 rad/s would turn the ship round every 21 s), starting at 2 m/s north and 2 m/s east;
the submersible goes straight at 1 m/s north and 1 m/s east; range-filter process and measurement noise variance 2;
outliers of amplitude 80 m, 10 one-sided ones at 300 s and 20 two-sided ones at 700 s; :math:`\delta = 0.03`;
50 000 Monte Carlo runs for the error budget (Fig. 6).

Chosen (not given in the paper): the start positions (ranges of 1.2 to 2.2 km), the depth (1000 m), the spacing of
the four epochs of a virtual-beacon fix (100 s) and the DR noise (0.1 m per axis per second).

References
----------
Paper E: virtual moving long baseline positioning of the manned submersible *Jiaolong*, with outlier rejection
(``vmlbl_jiaolong`` in the book's bibliography), sec. 2.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np

from .._linalg import distances
from .._validate import as_finite, as_flag, as_in_range, as_int, as_point, as_scalar
from ..errors import deprecated_aliases
from ..ranging import add_range_errors
from . import Scenario, ship_and_submersible_scenario

__all__ = ["PaperEParameters", "PARAMETERS", "Dive", "make"]


@dataclass(frozen=True)
class PaperEParameters:
    """Paper E's simulation and filter parameters (published ones first, then the chosen ones).

    Attributes
    ----------
    duration : float
        1200 s.
    interval : float
        A range every 1 s.
    ship_velocity : tuple of float
        Initial ship velocity [m/s], (2, 2).
    turn_rate_deg : float
        Ship's turn rate, 0.3 deg/s, right first (then left after ``half_period``).
    sub_velocity : tuple of float
        Submersible velocity [m/s], (1, 1).
    range_noise_variance : float
        White range noise variance [m²], 2 (the paper's "variance 2").
    q : float
        Range filter's process noise (acceleration) variance, 2.
    r : float
        Range filter's measurement noise variance, 2 m².
    outlier_amplitude : float
        80 m.
    outlier_onsets : tuple of float
        Starts of the outlier patches, (300, 700) s.
    outlier_counts : tuple of int
        Their lengths, (10, 20) epochs.
    outlier_two_sided : tuple of bool
        (one-sided, two-sided).
    delta : float
        The tolerance of the paper's test, 0.03.
    budget_runs : int
        Monte Carlo runs of the error budget (Fig. 6), 50 000.
    half_period : float
        Time the ship turns each way [s], 600 (chosen: one right and one left turn in 1200 s).
    ship_start : tuple of float
        Ship's start position [m] (chosen).
    sub_start : tuple of float
        Submersible's start position [m] (chosen).
    depth : float
        Submersible depth [m], 1000 (chosen).
    spacing : float
        Time between the four epochs of a virtual-beacon fix [s], 100 (chosen; chapter 3 measures its effect).
    dr_sigma : float
        DR noise per axis per epoch [m], 0.1 (chosen).

    Examples
    --------
    >>> from uwtutor.scenarios.paper_e import PaperEParameters
    >>> p = PaperEParameters()
    >>> p.duration, p.depth, p.outlier_counts
    (1200.0, 1000.0, (10, 20))
    """

    duration: float = 1200.0
    interval: float = 1.0
    ship_velocity: tuple[float, float] = (2.0, 2.0)
    turn_rate_deg: float = 0.3
    sub_velocity: tuple[float, float] = (1.0, 1.0)
    range_noise_variance: float = 2.0
    q: float = 2.0
    r: float = 2.0
    outlier_amplitude: float = 80.0
    outlier_onsets: tuple[float, ...] = (300.0, 700.0)
    outlier_counts: tuple[int, ...] = (10, 20)
    outlier_two_sided: tuple[bool, ...] = (False, True)
    delta: float = 0.03
    budget_runs: int = 50_000
    half_period: float = 600.0
    ship_start: tuple[float, float] = (0.0, 0.0)
    sub_start: tuple[float, float] = (-1000.0, -1000.0)
    depth: float = 1000.0
    spacing: float = 100.0
    dr_sigma: float = 0.1

    def __post_init__(self) -> None:
        for name in ("duration", "interval", "q", "r", "half_period", "spacing"):
            as_scalar(name, getattr(self, name), domain="positive")
        for name in ("range_noise_variance", "outlier_amplitude", "depth", "dr_sigma"):
            as_scalar(name, getattr(self, name), domain="nonnegative")
        as_scalar("turn_rate_deg", self.turn_rate_deg)
        for name in ("ship_velocity", "sub_velocity", "ship_start", "sub_start"):
            as_point(name, getattr(self, name))
        as_in_range("delta", as_scalar("delta", self.delta), 0.0, 1.0, closed=(False, False))
        as_int("budget_runs", self.budget_runs, minimum=1)
        onsets = as_finite("outlier_onsets", self.outlier_onsets, ndim=1)
        for name in ("outlier_counts", "outlier_two_sided"):
            value = getattr(self, name)
            if not isinstance(value, (tuple, list)):
                raise TypeError(f"{name} must be a tuple with one entry per patch of outliers; got "
                                f"{type(value).__name__}")
            if len(value) != len(onsets):
                raise ValueError(f"outlier_onsets, outlier_counts and outlier_two_sided must have the same length; "
                                 f"{name} has {len(value)}, outlier_onsets {len(onsets)}")
        for i, (count, two_sided) in enumerate(zip(self.outlier_counts, self.outlier_two_sided)):
            as_int(f"outlier_counts[{i}]", count, minimum=1)
            as_flag(f"outlier_two_sided[{i}]", two_sided)


#: Paper E's parameters (``PaperEParameters()``).
PARAMETERS = PaperEParameters()


@dataclass(frozen=True, eq=False)
class Dive:
    r"""``M`` simulated dives of paper E (returned by ``make``).

    Attributes
    ----------
    scenario : Scenario
        The horizontal scenario: times, true positions, DR displacements, ship positions, horizontal ranges and
        the range errors with their outlier mask, shapes ``(M, K, ...)``.
    depth : float
        Submersible depth :math:`h` [m] (the ship is at the surface).
    true_slant_ranges : ndarray, shape (M, K)
        :math:`\sqrt{\lVert p_k - AB_k\rVert^2 + h^2}` [m].
    slant_ranges : ndarray, shape (M, K)
        Measured ranges: ``true_slant_ranges`` plus the scenario's range errors (noise and outliers) [m], added
        by ``ranging.add_range_errors`` (a negative sum would be read as its magnitude).
    parameters : PaperEParameters
        The parameters the dives were drawn with.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.scenarios import paper_e
    >>> dive = paper_e.make(
    ...     np.random.default_rng(0), 2, duration=60.0, outlier_onsets=(),
    ...     outlier_counts=(), outlier_two_sided=(),
    ... )
    >>> dive.n_runs, dive.times.shape, dive.ship_positions.shape
    (2, (61,), (2, 61, 2))
    >>> # slant ranges from 1000 m below the ship
    >>> bool((dive.true_slant_ranges > dive.depth).all())
    True
    """

    scenario: Scenario
    depth: float
    true_slant_ranges: np.ndarray
    slant_ranges: np.ndarray
    parameters: PaperEParameters = field(default_factory=PaperEParameters)

    @property
    def times(self) -> np.ndarray:
        """Epoch times [s], shape ``(K,)``."""
        return self.scenario.times

    @property
    def ship_positions(self) -> np.ndarray:
        """Ship (beacon) positions :math:`AB_k` [m], shape ``(M, K, 2)``."""
        return self.scenario.beacon_positions

    @property
    def true_positions(self) -> np.ndarray:
        """True horizontal submersible positions [m], shape ``(M, K, 2)``."""
        return self.scenario.true_positions

    @property
    def dr_positions(self) -> np.ndarray:
        """The submersible's dead-reckoned positions [m], shape ``(M, K, 2)``."""
        return self.scenario.dr_positions

    @property
    def outlier_mask(self) -> np.ndarray:
        """True where a range carries an outlier, shape ``(M, K)``."""
        return cast(np.ndarray, self.scenario.outlier_mask)  # never None in a Scenario (all False when not given)

    @property
    def n_runs(self) -> int:
        """Number of dives M."""
        return self.scenario.n_runs


def make(rng: np.random.Generator, n_runs: int = 1, params: PaperEParameters | None = None, **changes: Any) -> Dive:
    r"""Draw ``n_runs`` dives of paper E's simulation.

    The horizontal geometry, the DR noise and the range errors (white noise of variance 2 m² plus the outlier
    patches) come from ``scenarios.ship_and_submersible_scenario``; the measured slant range is

    .. math::

        \tilde r_k = \sqrt{\lVert p_k - AB_k \rVert^2 + h^2} + e_k .

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of randomness.
    n_runs : int, default 1
        Number of dives M.
    params : PaperEParameters, optional
        Parameters (default: :data:`PARAMETERS`, the paper's values).
    **changes
        Fields of ``PaperEParameters`` to change, e.g. ``outlier_onsets=()`` (with the counts and sides) for no
        outliers.

    Returns
    -------
    Dive

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.scenarios import paper_e
    >>> dive = paper_e.make(np.random.default_rng(0), n_runs=2)
    >>> dive.slant_ranges.shape, int(dive.outlier_mask[0].sum())
    ((2, 1201), 30)
    """
    p = params if params is not None else PARAMETERS
    if not isinstance(p, PaperEParameters):
        raise TypeError(f"params must be a paper_e.PaperEParameters; got {type(p).__name__}")
    if changes:
        unknown = sorted(set(changes) - set(PaperEParameters.__dataclass_fields__))
        if unknown:
            raise TypeError(f"unknown PaperEParameters field(s) {unknown}; see paper_e.PaperEParameters for the names")
        p = PaperEParameters(**{**p.__dict__, **changes})
    m = as_int("n_runs", n_runs, minimum=1)
    sc = ship_and_submersible_scenario(
        rng, m, duration=p.duration, interval=p.interval, ship_start=p.ship_start, ship_velocity=p.ship_velocity,
        turn_rate=-np.deg2rad(p.turn_rate_deg), half_period=p.half_period, sub_start=p.sub_start,
        sub_velocity=p.sub_velocity, noise_sigma=np.sqrt(p.range_noise_variance),
        outlier_amplitude=p.outlier_amplitude, outlier_onsets=p.outlier_onsets, outlier_counts=p.outlier_counts,
        outlier_two_sided=p.outlier_two_sided, dr_sigma=p.dr_sigma)
    # the ship at the surface, the submersible `depth` below it: the slant range is their distance in 3-D
    sub = np.concatenate([sc.true_positions, np.full(sc.true_positions.shape[:-1] + (1,), -float(p.depth))], axis=-1)
    ship = np.concatenate([sc.beacon_positions, np.zeros(sc.beacon_positions.shape[:-1] + (1,))], axis=-1)
    true_slant = distances(sub, ship)
    slant = add_range_errors(true_slant, sc.range_errors)
    for a in (true_slant, slant):
        a.setflags(write=False)
    return Dive(scenario=sc, depth=float(p.depth), true_slant_ranges=true_slant, slant_ranges=slant, parameters=p)


#: The former name of the parameters class (one release).
__getattr__ = deprecated_aliases(__name__, {"PaperE": "PaperEParameters"})
