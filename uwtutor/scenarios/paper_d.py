r"""Paper D's simulation: an approach to a beacon with one turn, under a sound-speed (multiplicative) range error.

Zhu, Han, Guo and Liu (2019), sec. 4.1, eqs. 28-30: the beacon pings every 10 s for 1500 s; the vehicle converts
travel times with 1470 m/s while the effective sound speed is :math:`N(1500, 1^2)` m/s per ping, so each range
is off by a factor :math:`\gamma_k = c_a / c'_k` (mean :math:`\mu_\gamma \approx 0.98`); white range noise of
variance 0.49 m² and DR noise of variance 0.81 m² per axis per ping; 1000 Monte Carlo runs. The paper does not
draw its track: :func:`uwtutor.scenarios.approach_with_turn_scenario` is the book's (from about 3.4 km to
0.9 km, one 45° turn at 700 s).

Examples
--------
>>> import numpy as np
>>> from uwtutor.scenarios import paper_d
>>> paper_d.PARAMETERS.mu_gamma_true
0.98
>>> sc = paper_d.make(np.random.default_rng(0), n_runs=3)
>>> sc.ranges.shape
(3, 151)
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from .._validate import as_in_range, as_instance, as_int, as_scalar
from ..acoustics import range_factor
from ..errors import deprecated_aliases
from . import Scenario, approach_with_turn_scenario

__all__ = ["PaperDParameters", "PARAMETERS", "make"]


@dataclass(frozen=True)
class PaperDParameters:
    """Paper D's simulation and filter parameters, with the paper's values as defaults.

    Attributes
    ----------
    Q : float
        DR noise variance per axis per ping [m²] (the filters' ``Q = Q I``).
    R : float
        Additive range noise variance [m²].
    rho : float
        Forgetting factor of the innovation power.
    true_speed : float
        Mean of the effective sound speed [m/s].
    speed_sigma : float
        Its standard deviation from ping to ping [m/s].
    assumed_speed : float
        The speed the vehicle converts travel times with [m/s].
    ping_interval : float
        Ping period [s].
    duration : float
        Time span of the pings [s].
    n_runs : int
        Number of Monte Carlo runs of the paper's figures.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.scenarios.paper_d import PaperDParameters
    >>> p = PaperDParameters(R=1.0)
    >>> p.mu_gamma_true, p.as_dict()["R"]
    (0.98, 1.0)
    >>> p.make(np.random.default_rng(0), n_runs=2, duration=100.0).ranges.shape
    (2, 11)
    """

    Q: float = 0.81
    R: float = 0.49
    rho: float = 0.95
    true_speed: float = 1500.0
    speed_sigma: float = 1.0
    assumed_speed: float = 1470.0
    ping_interval: float = 10.0
    duration: float = 1500.0
    n_runs: int = 1000

    def __post_init__(self) -> None:
        for name in ("Q", "R", "speed_sigma"):
            as_scalar(name, getattr(self, name), domain="nonnegative")
        for name in ("true_speed", "assumed_speed", "ping_interval", "duration"):
            as_scalar(name, getattr(self, name), domain="positive")
        as_in_range("rho", as_scalar("rho", self.rho), 0.0, 1.0, closed=(False, True))
        as_int("n_runs", self.n_runs, minimum=1)

    @property
    def mu_gamma_true(self) -> float:
        r"""The mean range factor :math:`c_a / c` to first order (0.98)."""
        return round(float(range_factor(self.assumed_speed, self.true_speed)[0]), 12)

    def as_dict(self) -> dict[str, Any]:
        """The parameters by name."""
        return asdict(self)

    def make(self, rng: np.random.Generator, n_runs: Any = 1, **overrides: Any) -> Scenario:
        """The scenario with these parameters (``overrides`` go to ``approach_with_turn_scenario``)."""
        kwargs = dict(true_speed=self.true_speed, assumed_speed=self.assumed_speed, speed_sigma=self.speed_sigma,
                      noise_sigma=float(np.sqrt(self.R)), dr_sigma=float(np.sqrt(self.Q)),
                      ping_interval=self.ping_interval, duration=self.duration)
        kwargs.update(overrides)
        return approach_with_turn_scenario(rng, n_runs, **kwargs)


#: Paper D's own values.
PARAMETERS = PaperDParameters()


def make(rng: np.random.Generator, n_runs: Any = 1, params: PaperDParameters | None = None,
         **overrides: Any) -> Scenario:
    """Paper D's scenario for ``n_runs`` Monte Carlo runs (see :class:`PaperDParameters`).

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of randomness.
    n_runs : int, default 1
        Number of Monte Carlo runs.
    params : PaperDParameters, optional
        The parameters (default :data:`PARAMETERS`, the paper's values).
    **overrides
        Further arguments of :func:`uwtutor.scenarios.approach_with_turn_scenario` (``duration``, ``turn_time``,
        ...), which take precedence over ``params``.

    Returns
    -------
    Scenario

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.scenarios import paper_d
    >>> sc = paper_d.make(np.random.default_rng(0), n_runs=2, duration=100.0)
    >>> sc.ranges.shape, sc.dr_displacements.shape
    ((2, 11), (2, 11, 2))
    >>> quiet = paper_d.make(
    ...     np.random.default_rng(0), 1, params=paper_d.PaperDParameters(R=0.0),
    ...     duration=100.0,
    ... )
    >>> "range noise std 0 m" in quiet.description
    True
    """
    p = PARAMETERS if params is None else as_instance("params", params, PaperDParameters)
    return p.make(rng, n_runs, **overrides)


#: The former name of the parameters class (one release).
__getattr__ = deprecated_aliases(__name__, {"PaperD": "PaperDParameters"})
