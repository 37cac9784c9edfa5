r"""The common ground of chapter 10: five geometries, five error conditions, one set of inputs for every method.

No paper compares its method with the others on the same runs. This module makes the runs they can share:

* a **scenario** ``scenario(rng, n_runs) -> SuiteRuns`` is a geometry: the true track of ``n_runs`` runs, sampled at
  :math:`K + 1` epochs (epoch 0 is the start, where the vehicle has only its initial guess), and the beacon's
  position at each epoch (:data:`SCENARIOS`);
* a **condition** ``condition(rng, runs) -> (SuiteInputs, truth)`` measures those runs under one error model --
  what the vehicle's dead reckoning and ranging deliver -- and returns the inputs every method takes
  (:data:`CONDITIONS`) and the true positions at epochs :math:`1..K`.

Together they are the ``draw`` of :func:`uwtutor.montecarlo.run_study` (``scenario_draw(scenario, condition)``),
so every method of :mod:`uwtutor.methods` sees the same draws (common random numbers).

The numbers are those of :class:`SuiteParameters`: pings every 10 s for 25 minutes, 2 m/s, ranges of
:math:`\sigma_r` = 2 m, dead reckoning that errs by 1 m per axis per ping, an initial guess 100 m (per axis)
off, in the ranges (0.3-3 km) of the papers' simulations.

Randomness: the runs are drawn the way the filters and the bound assume the world is. The vehicle plans a track
and dead-reckons along it (its DR displacements :math:`\mathbf u_k` are the planned ones); its true start lies
:math:`\mathcal N(\mathbf 0, P_0)` from the planned start, where its initial guess is, and each ping its true
motion departs from the DR displacement by :math:`\mathbf w_k \sim \mathcal N(\mathbf 0, Q)`, so that
:math:`\mathbf p_k = \mathbf p_{k-1} + \mathbf u_k + \mathbf w_k` holds exactly. A scenario draws the true tracks
with its ``rng`` (first the starts, then the steps); a condition then draws the range errors and a seed for a
method that draws random numbers (a particle filter), from two child streams of its ``rng``. The true tracks
scatter about the planned one, so the posterior Cramér-Rao bound is the average of the range information over
sampled true tracks (:func:`crlb_inputs`), as Tichavský et al. define it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from .._linalg import distances
from .._validate import (as_choice, as_finite, as_in_range, as_instance, as_int, as_rng, as_scalar, as_seed,
                         check_work)
from ..errors import deprecated_aliases
from ..motion import Track, circle_track, lawnmower_track, straight_track, turning_track
from ..ranging import GaussianNoise, Outliers, SlowBias, SoundSpeedMismatch, measure_ranges

__all__ = [
    "SuiteParameters", "PARAMETERS", "SuiteRuns", "SuiteInputs",
    "circle", "turn", "line", "lawnmower", "moving_beacon", "SCENARIOS",
    "white", "sound_speed", "bias", "outliers", "current", "CONDITIONS",
    "crlb_inputs", "BOUND_TRACKS", "BOUND_SEED",
]


@dataclass(frozen=True)
class SuiteParameters:
    r"""The numbers of the common suite (:data:`PARAMETERS` holds the defaults).

    Attributes
    ----------
    n_epochs : int
        Ranging epochs :math:`K` after the start (150, as paper D's simulation).
    interval : float
        Time between pings [s] (10).
    speed : float
        Vehicle speed through the water [m/s] (2).
    dr_sigma : float
        Dead-reckoning error per ping and axis [m] (1): the filters' :math:`Q = \sigma_\mathrm{DR}^2 I`.
    range_sigma : float
        White range noise :math:`\sigma_r` [m] (2).
    start_sigma : float
        Error of the initial guess per axis [m] (100): :math:`P_0 = \sigma_0^2 I`.
    true_speed : float
        The sound-speed condition (paper D's numbers): the true mean effective speed, 1500 m/s.
    assumed_speed : float
        The speed the vehicle converts travel times with, 1470 m/s.
    speed_sigma : float
        Ping-to-ping scatter of the true speed, 1 m/s.
    bias_mean : float
        The slowly varying bias (paper A's model, :class:`uwtutor.ranging.SlowBias`): its mean, 5 m.
    bias_sigma : float
        Its standard deviation, 5 m.
    bias_time_constant : float
        Its correlation time, 3000 s.
    outlier_amplitude : float
        Outliers (paper E's kind): their size, 80 m, of random sign.
    outlier_probability : float
        Probability of an isolated outlier at each epoch, 3 %.
    outlier_patch_time : float
        Start of a patch of consecutive outliers, 600 s.
    outlier_patch_length : int
        Epochs in the patch, 10.
    current_velocity : tuple of float
        The unknown current of the current condition [m/s] (0.1 m/s towards the north-east; 150 m of drift in a run).
    current_sigma : float
        Prior standard deviation of a current state [m/s] per axis (0.2), for the filters that carry one and for
        the bound.

    Examples
    --------
    >>> from uwtutor.scenarios.suite import PARAMETERS, SuiteParameters
    >>> PARAMETERS.n_epochs, PARAMETERS.R, PARAMETERS.P0.tolist()
    (150, 4.0, [[10000.0, 0.0], [0.0, 10000.0]])
    >>> float(SuiteParameters(n_epochs=10).times[-1])
    100.0
    """

    n_epochs: int = 150
    interval: float = 10.0
    speed: float = 2.0
    dr_sigma: float = 1.0
    range_sigma: float = 2.0
    start_sigma: float = 100.0
    true_speed: float = 1500.0
    assumed_speed: float = 1470.0
    speed_sigma: float = 1.0
    bias_mean: float = 5.0
    bias_sigma: float = 5.0
    bias_time_constant: float = 3000.0
    outlier_amplitude: float = 80.0
    outlier_probability: float = 0.03
    outlier_patch_time: float = 600.0
    outlier_patch_length: int = 10
    current_velocity: tuple[float, float] = (0.1 * 0.5**0.5, 0.1 * 0.5**0.5)
    current_sigma: float = 0.2

    def __post_init__(self) -> None:
        n = as_int("n_epochs", self.n_epochs, minimum=1)
        check_work("n_epochs", n, "epochs")
        for name in ("interval", "speed", "range_sigma", "start_sigma", "true_speed", "assumed_speed",
                     "bias_time_constant", "current_sigma"):
            as_scalar(name, getattr(self, name), domain="positive")
        for name in ("dr_sigma", "speed_sigma", "bias_sigma", "outlier_amplitude"):
            as_scalar(name, getattr(self, name), domain="nonnegative")
        for name in ("bias_mean", "outlier_patch_time"):
            as_scalar(name, getattr(self, name))
        as_in_range("outlier_probability", as_scalar("outlier_probability", self.outlier_probability), 0.0, 1.0)
        as_int("outlier_patch_length", self.outlier_patch_length, minimum=1)
        as_finite("current_velocity", self.current_velocity, shape=(2,))

    @property
    def times(self) -> np.ndarray:
        """The :math:`K + 1` epoch times [s], from 0 (the start)."""
        return self.interval * np.arange(self.n_epochs + 1, dtype=float)

    @property
    def Q(self) -> np.ndarray:
        """DR noise covariance per step, :math:`\\sigma_\\mathrm{DR}^2 I` [m²]."""
        return self.dr_sigma**2 * np.eye(2)

    @property
    def P0(self) -> np.ndarray:
        """Covariance of the initial guess, :math:`\\sigma_0^2 I` [m²]."""
        return self.start_sigma**2 * np.eye(2)

    @property
    def R(self) -> float:
        """Nominal range variance :math:`\\sigma_r^2` [m²]."""
        return self.range_sigma**2

    @property
    def bias_step_variance(self) -> float:
        r"""Variance of the bias's change over one interval, :math:`\sigma_\upsilon^2 (1 - e^{-2\Delta t/T})`
        [m²]: the random walk a bias filter (and the bound) uses for it."""
        return float(self.bias_sigma**2 * -np.expm1(-2.0 * self.interval / self.bias_time_constant))

    @property
    def speed_factor_sigma(self) -> float:
        r""":math:`\sigma_\gamma \approx c\,\sigma_c / \bar c_\mathrm e^2`, the ping-to-ping scatter of the range
        factor."""
        return float(self.assumed_speed * self.speed_sigma / self.true_speed**2)


#: The suite's numbers.
PARAMETERS = SuiteParameters()


@dataclass(frozen=True, eq=False)
class SuiteRuns:
    """``n`` runs of one geometry (returned by a scenario of :data:`SCENARIOS`).

    Attributes
    ----------
    name : str
        The scenario's key in :data:`SCENARIOS`.
    times : ndarray, shape (K + 1,)
        Epoch times [s]; epoch 0 is the start.
    planned : ndarray, shape (K + 1, 2)
        The planned track [m]: what the vehicle's dead reckoning integrates, from its initial guess.
    positions : ndarray, shape (n, K + 1, 2)
        True positions through the water [m]: the planned track, shifted by each run's start error and wandering
        from it by the DR error of every ping (a current, if the condition has one, carries them further).
    beacon : ndarray, shape (n, K + 1, 2)
        The beacon's position at each epoch [m] (it moves in ``moving_beacon``), known to the vehicle.
    moving : bool
        Whether the beacon moves (a ship or a leader broadcasting its position).
    parameters : SuiteParameters
    description : str

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.scenarios.suite import SuiteParameters, line
    >>> runs = line(np.random.default_rng(0), 2, SuiteParameters(n_epochs=10))
    >>> runs.name, runs.n_runs, runs.n_epochs, runs.positions.shape
    ('line', 2, 10, (2, 11, 2))
    """

    name: str
    times: np.ndarray
    planned: np.ndarray
    positions: np.ndarray
    beacon: np.ndarray
    moving: bool
    parameters: SuiteParameters = field(repr=False)
    description: str = ""

    @property
    def n_runs(self) -> int:
        """Number of runs ``n``."""
        return self.positions.shape[0]

    @property
    def n_epochs(self) -> int:
        """Number of ranging epochs ``K`` (after the start)."""
        return self.positions.shape[1] - 1


@dataclass(frozen=True, eq=False)
class SuiteInputs:
    r"""What the vehicle has in ``n`` runs: the inputs of every method of :mod:`uwtutor.methods`.

    Attributes
    ----------
    scenario : str
        Name of the geometry.
    condition : str
        Name of the error condition.
    times : ndarray, shape (K,)
        Times of the ranging epochs :math:`1..K` [s].
    interval : float
        Time between epochs [s].
    x0 : ndarray, shape (n, 2)
        Initial guess of the position at epoch 0 [m].
    P0 : ndarray, shape (2, 2)
        Its covariance.
    u : ndarray, shape (n, K, 2)
        DR displacements from epoch ``k - 1`` to ``k`` (``u[:, k - 1]`` ends at epoch ``k``) [m].
    z : ndarray, shape (n, K)
        Measured ranges at epochs :math:`1..K` [m].
    z0 : ndarray, shape (n,)
        The range measured at epoch 0 (paper B's filter pairs consecutive ranges and needs it).
    beacon : ndarray, shape (n, K, 2)
        The beacon's (broadcast) positions at epochs :math:`1..K`; ``beacon0`` at epoch 0.
    beacon0 : ndarray, shape (n, 2)
    moving : bool
        Whether the beacon moves.
    Q : ndarray, shape (2, 2)
        DR noise covariance per step the methods are told [m²].
    R : float
        Range noise variance the methods are told [m²].
    method_seed : int
        A seed for a method that draws random numbers (a particle filter), drawn from the condition's stream.
    parameters : SuiteParameters

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.scenarios.suite import SuiteParameters, line, white
    >>> runs = line(np.random.default_rng(0), 2, SuiteParameters(n_epochs=10))
    >>> inputs, truth = white(np.random.default_rng(1), runs)
    >>> inputs.z.shape, inputs.u.shape, truth.shape, inputs.dr_track().shape
    ((2, 10), (2, 10, 2), (2, 10, 2), (2, 10, 2))
    >>> inputs.fixed_beacon.tolist()
    [0.0, 0.0]
    """

    scenario: str
    condition: str
    times: np.ndarray
    interval: float
    x0: np.ndarray
    P0: np.ndarray
    u: np.ndarray
    z: np.ndarray
    z0: np.ndarray
    beacon: np.ndarray
    beacon0: np.ndarray
    moving: bool
    Q: np.ndarray
    R: float
    method_seed: int
    parameters: SuiteParameters = field(repr=False)

    @property
    def n_runs(self) -> int:
        """Number of runs ``n``."""
        return self.z.shape[0]

    @property
    def n_epochs(self) -> int:
        """Number of ranging epochs ``K``."""
        return self.z.shape[1]

    @property
    def fixed_beacon(self) -> np.ndarray:
        """The beacon's one position ``(2,)`` (a ValueError if it moves)."""
        if self.moving:
            raise ValueError(f"scenario {self.scenario!r} has a moving beacon: this method needs a fixed one")
        return self.beacon0[0]

    def dr_track(self) -> np.ndarray:
        """``(n, K, 2)``: the dead-reckoned positions from the initial guess, :math:`x_0 + \\sum_{j \\le k} u_j`."""
        return self.x0[:, None, :] + np.cumsum(self.u, axis=1)

    def dr_covariance(self) -> np.ndarray:
        """``(K, 2, 2)``: the covariance of ``dr_track``, :math:`P_0 + kQ`."""
        k = np.arange(1, self.n_epochs + 1, dtype=float)[:, None, None]
        return self.P0 + k * self.Q


# ---------------------------------------------------------------------------------------------------------------------
# scenarios: the geometries (deterministic; rng unused, kept for the draw signature)
# ---------------------------------------------------------------------------------------------------------------------
def _params(params: Any) -> SuiteParameters:
    """The suite's numbers: ``PARAMETERS`` for None, else a SuiteParameters (anything else refused by name)."""
    return PARAMETERS if params is None else as_instance("params", params, SuiteParameters)


def _runs(name: str, rng: Any, n_runs: Any, track: Track, beacon: Any, description: str,
          p: SuiteParameters) -> SuiteRuns:
    n = as_int("n_runs", n_runs, minimum=1)
    rng = as_rng(rng)
    K1 = len(track.times)
    check_work("n_runs", 6 * n * K1, "floats (n_runs x the epochs x 2 coordinates, three arrays)")
    start_error = rng.normal(0.0, p.start_sigma, (n, 1, 2))
    steps = np.zeros((n, K1, 2))
    steps[:, 1:] = rng.normal(0.0, p.dr_sigma, (n, K1 - 1, 2))
    b = np.broadcast_to(np.asarray(beacon, dtype=float), (K1, 2))
    return SuiteRuns(name=name, times=track.times, planned=track.positions,
                     positions=track.positions + start_error + np.cumsum(steps, axis=1),
                     beacon=np.broadcast_to(b, (n, K1, 2)), moving=bool(np.ptp(b, axis=0).max() > 0),
                     parameters=p, description=description)


def circle(rng: np.random.Generator, n_runs: int, params: SuiteParameters | None = None) -> SuiteRuns:
    """Circling the beacon at 1 km (paper A's geometry): about 170 degrees of arc in 25 minutes.

    >>> import numpy as np
    >>> runs = circle(np.random.default_rng(0), 3)
    >>> runs.positions.shape, runs.planned.shape, runs.moving
    ((3, 151, 2), (151, 2), False)
    """
    p = _params(params)
    return _runs("circle", rng, n_runs, circle_track(p.times, 1000.0, p.speed), (0.0, 0.0),
                 "circling the beacon at 1 km", p)


def turn(rng: np.random.Generator, n_runs: int, params: SuiteParameters | None = None) -> SuiteRuns:
    """An approach with one turn (paper D's geometry): east for 12.5 minutes, then north-east.

    >>> import numpy as np
    >>> runs = turn(np.random.default_rng(0), 1)
    >>> # planned to start 2.2 km from the beacon
    >>> float(np.linalg.norm(runs.planned[0]))
    2236.06797749979
    """
    p = _params(params)
    track = turning_track(p.times, (-2000.0, -1000.0), p.speed, np.deg2rad([0.0, 60.0]), [p.times[-1] / 2])
    return _runs("turn", rng, n_runs, track, (0.0, 0.0), "approach with one turn", p)


def line(rng: np.random.Generator, n_runs: int, params: SuiteParameters | None = None) -> SuiteRuns:
    """A straight line passing 300 m from the beacon: the mirror image across the line fits the ranges as well.

    >>> import numpy as np
    >>> runs = line(np.random.default_rng(0), 1)
    >>> runs.planned[[0, -1]].tolist()
    [[-1500.0, 300.0], [1500.0, 300.0]]
    """
    p = _params(params)
    track = straight_track(p.times, (-1500.0, 300.0), p.speed, 0.0)
    return _runs("line", rng, n_runs, track, (0.0, 0.0), "straight line 300 m from the beacon", p)


def lawnmower(rng: np.random.Generator, n_runs: int, params: SuiteParameters | None = None) -> SuiteRuns:
    """A survey: 750 m legs 300 m apart over the beacon.

    >>> import numpy as np
    >>> runs = lawnmower(np.random.default_rng(0), 1)
    >>> runs.planned[0].tolist()
    [-375.0, -600.0]
    """
    p = _params(params)
    track = lawnmower_track(p.times, (-375.0, -600.0), p.speed, 750.0, 300.0)
    return _runs("lawnmower", rng, n_runs, track, (0.0, 0.0), "lawnmower survey over the beacon", p)


def moving_beacon(rng: np.random.Generator, n_runs: int, params: SuiteParameters | None = None) -> SuiteRuns:
    """A straight run ranging to a leader (a ship or a vehicle) that zigzags across its track while overtaking it.

    The leader starts 700 m behind, gains 1 m/s and swings ±600 m across the vehicle's track every 10 minutes,
    broadcasting its position with each ping (paper B's cooperative setting; paper E's ship does the same): the
    vehicle knows where the beacon was at every epoch. Seen from the vehicle, the leader draws a zigzag, so
    the bearing keeps changing although the vehicle never turns.

    >>> import numpy as np
    >>> runs = moving_beacon(np.random.default_rng(0), 1)
    >>> runs.moving, runs.beacon[0, 0].tolist()
    (True, [-2200.0, 600.0])
    """
    p = _params(params)
    track = straight_track(p.times, (-1500.0, 0.0), p.speed, 0.0)
    period = 600.0                              # s: a zigzag of +-600 m across the vehicle's track
    phase = (p.times / period) % 1.0
    across = 600.0 * (4.0 * np.abs(phase - 0.5) - 1.0)
    along = -700.0 + 1.0 * p.times
    leader = track.positions + np.column_stack([along, across])
    return _runs("moving beacon", rng, n_runs, track, leader, "straight run ranging to a zigzagging leader", p)


#: The scenarios by name, in the chapter's order.
SCENARIOS: dict[str, Callable[..., SuiteRuns]] = {
    "circle": circle, "turn": turn, "line": line, "lawnmower": lawnmower, "moving beacon": moving_beacon,
}


# ---------------------------------------------------------------------------------------------------------------------
# conditions: what the vehicle measures
# ---------------------------------------------------------------------------------------------------------------------
def _checked(runs: Any) -> SuiteRuns:
    if not isinstance(runs, SuiteRuns):
        raise TypeError(f"runs must come from a scenario of uwtutor.scenarios.suite (a SuiteRuns); got "
                        f"{type(runs).__name__}")
    return runs


def _measure(name: str, rng: np.random.Generator, runs: SuiteRuns, error: Any, *,
             water_current: Any = None) -> tuple[SuiteInputs, np.ndarray]:
    rng = as_rng(rng)
    range_rng, method_rng = rng.spawn(2)
    p = runs.parameters
    n, K = runs.n_runs, runs.n_epochs
    truth = runs.positions
    if water_current is not None:          # the water carries the vehicle; its DR (through the water) does not know
        truth = truth + np.asarray(water_current, dtype=float) * (runs.times - runs.times[0])[:, None]
    u = np.broadcast_to(np.diff(runs.planned, axis=0), (n, K, 2))
    true_ranges = distances(truth, runs.beacon, "norm")
    z = measure_ranges(true_ranges, runs.times, error, range_rng, n_runs=n)   # a negative sum: read as its size
    inputs = SuiteInputs(scenario=runs.name, condition=name, times=runs.times[1:], interval=float(p.interval),
                         x0=np.broadcast_to(runs.planned[0], (n, 2)), P0=p.P0, u=u, z=z[:, 1:], z0=z[:, 0],
                         beacon=runs.beacon[:, 1:], beacon0=runs.beacon[:, 0], moving=runs.moving, Q=p.Q, R=p.R,
                         method_seed=int(method_rng.integers(2**63)), parameters=p)
    return inputs, truth[:, 1:]


def white(rng: np.random.Generator, runs: SuiteRuns) -> tuple[SuiteInputs, np.ndarray]:
    """White Gaussian range noise :math:`\\sigma_r` only: the model every filter assumes.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.scenarios.suite import SuiteParameters, circle, white
    >>> runs = circle(np.random.default_rng(0), 200, SuiteParameters(n_epochs=10))
    >>> inputs, truth = white(np.random.default_rng(1), runs)
    >>> error = inputs.z - np.linalg.norm(truth - inputs.beacon, axis=-1)
    >>> # sigma_r = 2 m
    >>> bool(abs(error.std() - 2.0) < 0.1)
    True
    """
    runs = _checked(runs)
    return _measure("white", rng, runs, GaussianNoise(runs.parameters.range_sigma))


def sound_speed(rng: np.random.Generator, runs: SuiteRuns) -> tuple[SuiteInputs, np.ndarray]:
    """A wrong sound speed (paper D): ranges scaled by :math:`\\gamma_k = c/c_{\\mathrm e,k}` (about 0.98), plus
    white noise.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.scenarios.suite import SuiteParameters, circle, sound_speed
    >>> runs = circle(np.random.default_rng(0), 200, SuiteParameters(n_epochs=10))
    >>> inputs, truth = sound_speed(np.random.default_rng(1), runs)
    >>> ratio = inputs.z / np.linalg.norm(truth - inputs.beacon, axis=-1)
    >>> # 1470 / 1500 on average
    >>> round(float(ratio.mean()), 3)
    0.98
    """
    p = _checked(runs).parameters
    error = SoundSpeedMismatch(p.true_speed, p.assumed_speed, p.speed_sigma) + GaussianNoise(p.range_sigma)
    return _measure("sound speed", rng, runs, error)


def bias(rng: np.random.Generator, runs: SuiteRuns) -> tuple[SuiteInputs, np.ndarray]:
    """A slowly varying range bias (paper A): 5 ± 5 m, 3000 s correlation, plus white noise.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.scenarios.suite import SuiteParameters, circle, bias
    >>> runs = circle(np.random.default_rng(0), 200, SuiteParameters(n_epochs=10))
    >>> inputs, truth = bias(np.random.default_rng(1), runs)
    >>> error = inputs.z - np.linalg.norm(truth - inputs.beacon, axis=-1)
    >>> # a mean of 5 m
    >>> bool(abs(error.mean() - 5.0) < 1.0)
    True
    """
    p = _checked(runs).parameters
    error = SlowBias(p.bias_mean, p.bias_sigma, p.bias_time_constant) + GaussianNoise(p.range_sigma)
    return _measure("bias", rng, runs, error)


def outliers(rng: np.random.Generator, runs: SuiteRuns) -> tuple[SuiteInputs, np.ndarray]:
    """Outliers (paper E): isolated 80 m ones (3 % of the epochs) and a patch of 10 from 600 s, plus white noise.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.scenarios.suite import SuiteParameters, circle, outliers
    >>> runs = circle(np.random.default_rng(0), 20, SuiteParameters(n_epochs=100))
    >>> inputs, truth = outliers(np.random.default_rng(1), runs)
    >>> error = inputs.z - np.linalg.norm(truth - inputs.beacon, axis=-1)
    >>> # the patch of 10 from 600 s (epochs 60 to 69), then about 3 % of the rest
    >>> (bool((np.abs(error[:, 59:69]) > 60.0).all()),
    ...  bool(np.mean(np.abs(error) > 60.0) < 0.2))
    (True, True)
    """
    p = _checked(runs).parameters
    error = (Outliers((p.outlier_patch_time,), p.outlier_patch_length, p.outlier_amplitude, two_sided=True,
                      probability=p.outlier_probability) + GaussianNoise(p.range_sigma))
    return _measure("outliers", rng, runs, error)


def current(rng: np.random.Generator, runs: SuiteRuns) -> tuple[SuiteInputs, np.ndarray]:
    """An unknown current (paper B): the vehicle drifts with it, its DR (through the water) does not see it.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.scenarios.suite import SuiteParameters, current, line
    >>> runs = line(np.random.default_rng(0), 1, SuiteParameters(n_epochs=10))
    >>> inputs, truth = current(np.random.default_rng(1), runs)
    >>> # the current has carried the vehicle 0.1 m/s x 100 s away from its dead reckoning
    >>> drift = truth[0, -1] - runs.positions[0, -1]
    >>> np.round(drift, 2).tolist()
    [7.07, 7.07]
    """
    p = _checked(runs).parameters
    return _measure("current", rng, runs, GaussianNoise(p.range_sigma), water_current=p.current_velocity)


#: The error conditions by name, in the chapter's order.
CONDITIONS: dict[str, Callable[..., tuple[SuiteInputs, np.ndarray]]] = {
    "white": white, "sound speed": sound_speed, "bias": bias, "outliers": outliers, "current": current,
}


#: Sampled true tracks per (scenario, condition) over which :func:`crlb_inputs` averages the range information.
BOUND_TRACKS = 2000
#: The seed of those tracks. Any fixed seed would do; the bound is an expectation, and these tracks its Monte
#: Carlo estimate.
BOUND_SEED = 1998


def crlb_inputs(scenario: str, condition: str, params: SuiteParameters | None = None, *,
                n_tracks: int = BOUND_TRACKS, seed: int = BOUND_SEED) -> dict[str, Any]:
    r"""The arguments of :func:`uwtutor.observability.posterior_crlb` for a (scenario, condition) of the suite.

    The expectation :math:`\operatorname{E}[\mathbf H_k^\mathsf T R_k^{-1} \mathbf H_k]` is over the true
    tracks, which scatter about the planned one by the start error and the DR error: it is evaluated as the
    mean over ``n_tracks`` tracks drawn as the scenario draws them (``mean_over_runs=True``), the Monte Carlo
    evaluation of Tichavský et al. Per condition:

    * white and outliers: the nominal model (:math:`\sigma_r`, :math:`Q`, :math:`P_0`). With outliers the bound
      is that of the clean ranges -- the information a method would have if it knew which ranges were bad;
    * sound speed: the range variance grows by :math:`(\sigma_\gamma r_k)^2`, the ping-to-ping scatter of the
      factor; its mean (0.98) is treated as known, so the bound is lower than one that must also estimate it;
    * bias: a bias state that random-walks with the per-interval variance of the slow bias, prior
      :math:`\mu_\upsilon^2 + \sigma_\upsilon^2` (the filter does not know the mean);
    * current: a constant current state with the prior :math:`\sigma_U^2 I`, the tracks carried by the current.

    Returns
    -------
    dict
        ``positions`` (``n_tracks``, K, 2), ``beacon``, ``sigma``, ``Q``, ``P0``, ``times``, the
        ``bias``/``current`` flags and ``mean_over_runs=True``.

    Examples
    --------
    >>> from uwtutor.observability import posterior_crlb, rmse_bound
    >>> bound = rmse_bound(
    ...     posterior_crlb(**crlb_inputs("circle", "white", n_tracks=200))
    ... )
    >>> bound.shape, bool(bound[-1] < bound[0] < 100.0 * 2**0.5)
    ((150,), True)
    """
    as_choice("scenario", scenario, SCENARIOS)
    as_choice("condition", condition, CONDITIONS)
    seed = as_seed("seed", seed)                  # None would draw OS entropy: a different bound every call
    n_tracks = as_int("n_tracks", n_tracks, minimum=1)
    p = _params(params)
    try:
        runs = SCENARIOS[scenario](np.random.default_rng(seed), n_tracks, p)
    except ValueError as exc:                      # the scenario names its count "n_runs": say which argument it was
        raise ValueError(str(exc).replace("n_runs asks", "n_tracks asks", 1)) from None
    pos = runs.positions
    if condition == "current":
        pos = pos + np.asarray(p.current_velocity) * (runs.times - runs.times[0])[:, None]
    pos, b = pos[:, 1:], runs.beacon[:, 1:]
    sigma: Any = p.range_sigma
    Q, P0 = p.Q, p.P0
    flags = dict(bias=False, current=False)
    if condition == "sound speed":
        r = distances(pos, b, "norm")
        sigma = np.sqrt(p.range_sigma**2 + (p.speed_factor_sigma * r) ** 2)
    elif condition == "bias":
        flags["bias"] = True
        Q = np.diag([p.dr_sigma**2, p.dr_sigma**2, p.bias_step_variance])
        P0 = np.diag([p.start_sigma**2, p.start_sigma**2, p.bias_mean**2 + p.bias_sigma**2])
    elif condition == "current":
        flags["current"] = True
        P0 = np.diag([p.start_sigma**2] * 2 + [p.current_sigma**2] * 2)
    return dict(positions=pos, beacon=b, sigma=sigma, Q=Q, P0=P0, times=runs.times, mean_over_runs=True, **flags)


#: The former name of the default parameters (one release): every scenario module calls its own ``PARAMETERS``.
__getattr__ = deprecated_aliases(__name__, {"SUITE": "PARAMETERS"})
