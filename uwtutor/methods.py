r"""Every navigation method of the book behind one signature: ``method(inputs) -> FilterResult``.

A method takes the :class:`~uwtutor.scenarios.suite.SuiteInputs` of ``n`` runs -- what the vehicle has: an
initial guess, DR displacements, ranges, the beacon's positions and the noise it was told about -- and returns a
batched :class:`~uwtutor.filters.base.FilterResult` with the position first in its state, one estimate per ranging
epoch. Each entry of :data:`REGISTRY` is a :class:`Method`: the function, the paper and chapter it comes from,
and the scenarios it can run on (a method that needs a fixed beacon does not claim the moving-beacon scenario; the
cooperative filter needs a leader). Nothing here is a new algorithm: each function sets a library filter up for
the suite's inputs, with the settings of its chapter.

Conventions shared by all of them:

* a method that starts late (after a test on its least-squares start, papers A and D) navigates by dead
  reckoning from the initial guess until it starts, with the DR covariance :math:`P_0 + kQ`: its estimate is
  what the vehicle has at every epoch;
* a method with no covariance of its own (the grid pre-location) reports NaN for ``P``: its NEES is NaN, not
  invented;
* a method that draws random numbers (the particle filter) draws them from ``inputs.method_seed``, which the
  condition drew from the study's seeded stream: the same study gives the same numbers on any executor.

:func:`run` is the path from names to a result: a scenario and a condition of :mod:`uwtutor.scenarios.suite`,
drawn with a Generator, then one method.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np
from numpy.typing import ArrayLike

from ._validate import as_choice, as_flag, as_int, as_positive, as_rng
from .errors import IllConditionedWarning
from .filters import (BootstrapParticleFilter, FilterResult, bias_ekf, cooperative_ekf, fading_ekf,
                      range_only_ekf)
from .models import DeadReckoning, RangeToBeacon
from .pipelines import ls_fading_ekf, prepositioned_bias_ekf
from .scenarios.suite import CONDITIONS, SCENARIOS, SuiteInputs

__all__ = ["Method", "REGISTRY", "names", "get", "run", "claims", "suite_bounds", "compare_suite", "load_comparison",
           "ls_prepositioning", "grid_prelocation", "prelocate", "ekf", "iekf", "prepositioned_iekf", "sfekf",
           "isfekf", "ls_isfekf", "cooperative", "or_vmlbl", "particle_filter", "gated_ekf", "dataset_inputs",
           "log_draw"]


def _inputs(inputs: Any) -> SuiteInputs:
    if not isinstance(inputs, SuiteInputs):
        raise TypeError("inputs must be the SuiteInputs of a condition of uwtutor.scenarios.suite (the first item "
                        f"of condition(rng, runs)): every method takes them; got {type(inputs).__name__}")
    return inputs


def _result(inputs: SuiteInputs, x: np.ndarray, P: np.ndarray, innovations: Any = None, innovation_cov: Any = None,
            extras: dict[str, Any] | None = None) -> FilterResult:
    n, K = inputs.n_runs, inputs.n_epochs
    y = np.full((n, K, 1), np.nan) if innovations is None else innovations
    S = np.full((n, K, 1, 1), np.nan) if innovation_cov is None else innovation_cov
    return FilterResult(times=inputs.times, x=x, P=P, x_prior=x, P_prior=P, innovations=y, innovation_cov=S,
                        extras=extras or {})


def _dead_reckoning(inputs: SuiteInputs) -> tuple[np.ndarray, np.ndarray]:
    """Writable ``(x, P)`` of dead reckoning from the initial guess, ``(n, K, 2)`` and ``(n, K, 2, 2)``: what every
    method reports where it has nothing better."""
    n, K = inputs.n_runs, inputs.n_epochs
    return np.array(inputs.dr_track()), np.array(np.broadcast_to(inputs.dr_covariance(), (n, K, 2, 2)))


def _dr_before(inputs: SuiteInputs, result: FilterResult, started: np.ndarray) -> FilterResult:
    """``result`` where ``started`` (n, K), dead reckoning from the initial guess elsewhere."""
    dr_x, dr_P = _dead_reckoning(inputs)
    n_state = result.x.shape[-1]
    x = np.array(result.x[..., :2])
    P = np.array(result.P[..., :2, :2])
    x[~started] = dr_x[~started]
    P[~started] = dr_P[~started]
    if n_state > 2:       # keep the extra states (bias) where the filter ran; NaN before
        x = np.concatenate([x, np.where(started[..., None], result.x[..., 2:], np.nan)], axis=-1)
        full = np.full(result.P.shape, np.nan)
        full[..., :2, :2] = P
        full[started] = result.P[started]
        P = full
    y = np.where(started[..., None], result.innovations, np.nan)
    S = np.where(started[..., None, None], result.innovation_cov, np.nan)
    return _result(inputs, x, P, y, S, {"started": started})


# ---------------------------------------------------------------------------------------------------------------------
# the methods
# ---------------------------------------------------------------------------------------------------------------------
#: Precision factor below which :func:`ls_prepositioning` accepts a fix (paper A's test, chapter 7).
LS_MAX_ALPHA = 2.0


def ls_prepositioning(inputs: SuiteInputs) -> FilterResult:
    r"""Paper A's pre-positioning as a navigator: at every epoch, a least-squares fix from all the ranges so far.

    At epoch :math:`k` the ranges of epochs :math:`1..k` are ranges from the current position to virtual
    beacons :math:`b_i - d_i` (:math:`d_i` the DR displacement from epoch :math:`i` to :math:`k`), solved by
    ``uwtutor.lsq.linearized_lsq`` with the range bias as a third unknown (three Gauss-Newton iterations from
    the current estimate carried by DR). A fix is accepted when its precision factor is below
    ``LS_MAX_ALPHA`` (paper A's test); where it is refused, the estimate is dead reckoning from the last
    accepted one (from the initial guess before the first). Covariance: the fix's
    :math:`\sigma_r^2 (A^\mathsf T A)^{-1}`. The fix ignores the DR error accumulated over the track, which
    grows with its length: that is the method's limit (chapter 7).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor import methods
    >>> from uwtutor.scenarios import suite
    >>> rng = np.random.default_rng(0)
    >>> inputs, truth = suite.CONDITIONS["white"](rng, suite.SCENARIOS["circle"](rng, 2))
    >>> result = methods.ls_prepositioning(inputs)
    >>> result.x.shape, result.extras["fixed"].shape
    ((2, 150, 2), (2, 150))
    >>> # three unknowns: no fix before the fourth range
    >>> bool(result.extras["fixed"][:, :3].any())
    False
    """
    from . import lsq

    s = _inputs(inputs)
    n, K = s.n_runs, s.n_epochs
    dr = s.dr_track()
    x, P = _dead_reckoning(s)
    fixed = np.zeros((n, K), dtype=bool)
    sigma = np.sqrt(s.R)
    z_all = np.where(np.isfinite(s.z), s.z, 0.0)
    for k in range(K):
        if k > 0:              # carry the previous estimate by DR
            x[:, k] = x[:, k - 1] + s.u[:, k]
            P[:, k] = P[:, k - 1] + s.Q
        if k < 3:              # three unknowns
            continue
        d = dr[:, :k + 1] - dr[:, k:k + 1]                      # minus the DR displacement from epoch i to now
        with warnings.catch_warnings():     # paper A's test on alpha decides, not the generic conditioning warning
            warnings.simplefilter("ignore", IllConditionedWarning)
            fix = lsq.linearized_lsq(z_all[:, :k + 1], s.beacon[:, :k + 1] - d, x[:, k], unknown_bias=True,
                                     iterations=3, sigma=sigma)
        pos = np.asarray(fix.position)
        cov = np.asarray(fix.covariance)[..., :2, :2]
        good = (np.isfinite(pos).all(axis=1) & np.isfinite(cov).all(axis=(1, 2))
                & (np.asarray(fix.alpha) < LS_MAX_ALPHA))
        x[good, k] = pos[good]
        P[good, k] = cov[good]
        fixed[good, k] = True
    return _result(s, x, P, extras={"fixed": fixed})


#: Sound-speed errors searched by :func:`grid_prelocation` and :func:`ls_isfekf` [m/s]: effective speeds from
#: 1550 down to 1420 m/s every 10 m/s. Paper D searches down to 1300 m/s (26 speeds); sea water stays within
#: 1420-1550 m/s, and the grid's cost grows with its size.
SPEED_ERROR_GRID = 1470.0 - np.arange(1550.0, 1419.0, -10.0)


def prelocate(inputs: SuiteInputs) -> Any:
    """Paper D's grid search (``uwtutor.lsq.grid_prelocation``) on the suite's inputs, on the grid
    ``SPEED_ERROR_GRID``: what :func:`grid_prelocation` and :func:`ls_isfekf` start from.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor import methods
    >>> from uwtutor.scenarios import suite
    >>> rng = np.random.default_rng(0)
    >>> inputs, truth = suite.CONDITIONS["white"](rng, suite.SCENARIOS["circle"](rng, 2))
    >>> pre = methods.prelocate(inputs)
    >>> type(pre).__name__, pre.position.shape, pre.cost_map.shape[0]
    ('Prelocation', (2, 150, 2), 2)
    """
    from . import lsq

    s = _inputs(inputs)
    return lsq.grid_prelocation(ranges=s.z, dr_displacements=s.u, speed_error_grid=SPEED_ERROR_GRID,
                                assumed_speed=s.parameters.assumed_speed, beacon=s.fixed_beacon)


def grid_prelocation(inputs: SuiteInputs) -> FilterResult:
    """Paper D's grid-search pre-location on its own: the best (start bearing, sound-speed error) cell at every
    epoch, from all the ranges so far. It has no covariance: ``P`` is NaN.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor import methods
    >>> from uwtutor.scenarios import suite
    >>> rng = np.random.default_rng(0)
    >>> inputs, truth = suite.CONDITIONS["white"](rng, suite.SCENARIOS["circle"](rng, 2))
    >>> result = methods.grid_prelocation(inputs)
    >>> result.x.shape, bool(np.isnan(result.P).all())
    ((2, 150, 2), True)
    """
    s = _inputs(inputs)
    pre = prelocate(s)
    n, K = s.n_runs, s.n_epochs
    return _result(s, np.asarray(pre.position), np.full((n, K, 2, 2), np.nan),
                   extras={"range_scale": np.asarray(pre.range_scale)})


def ekf(inputs: SuiteInputs) -> FilterResult:
    """The range-only EKF of chapter 4 (Joseph form), told the suite's Q and R.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor import methods
    >>> from uwtutor.scenarios import suite
    >>> rng = np.random.default_rng(0)
    >>> inputs, truth = suite.CONDITIONS["white"](rng, suite.SCENARIOS["circle"](rng, 2))
    >>> result = methods.ekf(inputs)
    >>> result.x.shape, result.P.shape, truth.shape
    ((2, 150, 2), (2, 150, 2, 2), (2, 150, 2))
    """
    s = _inputs(inputs)
    return range_only_ekf(s.x0, s.P0, s.u, s.z, s.Q, s.R, beacon=s.beacon, times=s.times)


#: The gated EKF's chi-square gate probability and the rejections in a row after which it re-acquires.
GATE_PROBABILITY, GATE_PATIENCE = 0.999, 10


def gated_ekf(inputs: SuiteInputs) -> FilterResult:
    r"""The EKF of chapter 4 with chapter 9's gate: each range tested against :math:`\chi^2_1` at
    ``GATE_PROBABILITY`` (:class:`~uwtutor.filters.gates.ChiSquareGate`), inside a
    :class:`~uwtutor.filters.gates.ReacquiringGate` that inflates the covariance and forces an update after
    ``GATE_PATIENCE`` rejections in a row (a gate alone can lock a lost filter out for good).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor import methods
    >>> from uwtutor.scenarios import suite
    >>> rng = np.random.default_rng(0)
    >>> inputs, truth = suite.CONDITIONS["outliers"](rng, suite.SCENARIOS["circle"](rng, 2))
    >>> result = methods.gated_ekf(inputs)
    >>> result.x.shape, result.extras["updated"].shape
    ((2, 150, 2), (2, 150))
    """
    from .filters import ChiSquareGate, ReacquiringGate

    s = _inputs(inputs)
    gate = ReacquiringGate(ChiSquareGate(GATE_PROBABILITY), patience=GATE_PATIENCE)
    return range_only_ekf(s.x0, s.P0, s.u, s.z, s.Q, s.R, beacon=s.beacon, times=s.times, gate=gate)


def _bias_noise(s: SuiteInputs) -> tuple[np.ndarray, np.ndarray]:
    p = s.parameters
    Q3 = np.diag([p.dr_sigma**2, p.dr_sigma**2, p.bias_step_variance])
    P3 = np.diag([p.start_sigma**2, p.start_sigma**2, p.bias_mean**2 + p.bias_sigma**2])
    return Q3, P3


def iekf(inputs: SuiteInputs) -> FilterResult:
    """Paper A's IEKF: the state carries the range bias, a random walk (chapter 7), from bias 0.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor import methods
    >>> from uwtutor.scenarios import suite
    >>> rng = np.random.default_rng(0)
    >>> inputs, truth = suite.CONDITIONS["white"](rng, suite.SCENARIOS["circle"](rng, 2))
    >>> result = methods.iekf(inputs)
    >>> # [x, y, range bias]
    >>> result.x.shape
    (2, 150, 3)
    """
    s = _inputs(inputs)
    Q3, P3 = _bias_noise(s)
    x0 = np.concatenate([s.x0, np.zeros((s.n_runs, 1))], axis=1)
    return bias_ekf(x0, P3, s.u, s.z, Q3, s.R, beacon=s.beacon, times=s.times)


def prepositioned_iekf(inputs: SuiteInputs) -> FilterResult:
    """Paper A's pre-positioning, then its IEKF (chapter 7): the filter starts once the precision factor of the
    least-squares fix is below 2; dead reckoning from the initial guess until then.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor import methods
    >>> from uwtutor.scenarios import suite
    >>> rng = np.random.default_rng(0)
    >>> inputs, truth = suite.CONDITIONS["white"](rng, suite.SCENARIOS["circle"](rng, 2))
    >>> result = methods.prepositioned_iekf(inputs)
    >>> result.x.shape, result.extras["started"].shape
    ((2, 150, 3), (2, 150))
    >>> # dead reckoning from the initial guess before the start: no range bias there
    >>> bool(np.isnan(result.x[..., 2][~result.extras["started"]]).all())
    True
    """
    s = _inputs(inputs)
    Q3, _ = _bias_noise(s)
    res = prepositioned_bias_ekf(s.x0, None, s.u, s.z, Q3, s.R, beacon=s.fixed_beacon, times=s.times)
    started = np.isfinite(res.x[..., 0]) & np.isfinite(res.P[..., 0, 0])
    return _dr_before(s, res, started)


def _fading(s: SuiteInputs, beta: Any) -> FilterResult:
    return fading_ekf(s.x0, s.P0, s.u, s.z, s.Q, s.R, mu_gamma=1.0, sigma_gamma=s.parameters.speed_factor_sigma,
                      beta=beta, beacon=s.fixed_beacon, times=s.times)


def sfekf(inputs: SuiteInputs) -> FilterResult:
    """The suboptimal fading EKF (constant weakening factor 1) for multiplicative noise (chapter 5), told the
    assumed sound speed is right (mean factor 1) with paper D's ping-to-ping scatter.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor import methods
    >>> from uwtutor.scenarios import suite
    >>> rng = np.random.default_rng(0)
    >>> inputs, truth = suite.CONDITIONS["white"](rng, suite.SCENARIOS["circle"](rng, 2))
    >>> result = methods.sfekf(inputs)
    >>> result.x.shape, "fading_factor" in result.extras
    ((2, 150, 2), True)
    """
    return _fading(_inputs(inputs), 1.0)


def isfekf(inputs: SuiteInputs) -> FilterResult:
    """Paper D's ISFEKF: the fading EKF with the range-dependent weakening factor (chapter 5).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor import methods
    >>> from uwtutor.scenarios import suite
    >>> rng = np.random.default_rng(0)
    >>> inputs, truth = suite.CONDITIONS["white"](rng, suite.SCENARIOS["circle"](rng, 2))
    >>> result = methods.isfekf(inputs)
    >>> result.x.shape, "weakening_factor" in result.extras
    ((2, 150, 2), True)
    """
    return _fading(_inputs(inputs), "range")


def ls_isfekf(inputs: SuiteInputs) -> FilterResult:
    """Paper D's LS-ISFEKF: grid pre-location, accepted after a turn and 10 stable fixes, then the ISFEKF with its
    speed estimate; dead reckoning from the initial guess until the start (chapter 5).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor import methods
    >>> from uwtutor.scenarios import suite
    >>> rng = np.random.default_rng(0)
    >>> inputs, truth = suite.CONDITIONS["white"](rng, suite.SCENARIOS["circle"](rng, 2))
    >>> result = methods.ls_isfekf(inputs)
    >>> result.x.shape, result.extras["started"].shape
    ((2, 150, 2), (2, 150))
    """
    s = _inputs(inputs)
    pre = prelocate(s)
    res = ls_fading_ekf(np.eye(2) * 50.0**2, s.u, s.z, s.Q, s.R, sigma_gamma=s.parameters.speed_factor_sigma,
                        assumed_speed=s.parameters.assumed_speed, beacon=s.fixed_beacon, times=s.times,
                        prelocation=pre)
    started = np.arange(s.n_epochs)[None, :] > np.asarray(res.start_epoch)[:, None]
    return _dr_before(s, res, started)


def cooperative(inputs: SuiteInputs) -> FilterResult:
    r"""Paper B's cooperative EKF (chapter 8): state :math:`[x, y, U_x, U_y]` with the current, updated with pairs
    of consecutive ranges to the leader, which broadcasts its position; tuned to the suite's noise (the
    "consistent" formulation, each range's information counted once).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor import methods
    >>> from uwtutor.scenarios import suite
    >>> rng = np.random.default_rng(0)
    >>> inputs, truth = suite.CONDITIONS["white"](rng,
    ...                                  suite.SCENARIOS["moving beacon"](rng, 2))
    >>> result = methods.cooperative(inputs)
    >>> # [x, y, Ux, Uy]: the position and the current
    >>> result.x.shape
    (2, 150, 4)
    """
    s = _inputs(inputs)
    p = s.parameters
    dr, cu = p.dr_sigma, 1e-3
    Q = np.diag([0.5**2, 0.5**2, dr**2, dr**2, cu**2, cu**2])
    leader_sigma = 0.5             # the broadcast positions are exact here; the filter needs a positive variance
    R = np.diag([2 * s.R] * 2 + [2 * leader_sigma**2] * 4 + [dr**2, dr**2, cu**2, cu**2])
    x0 = np.concatenate([s.x0, np.zeros((s.n_runs, 2))], axis=1)
    P0 = np.diag([p.start_sigma**2] * 2 + [p.current_sigma**2] * 2)
    leader = np.concatenate([s.beacon0[:, None], s.beacon], axis=1)
    ranges = np.concatenate([s.z0[:, None], s.z], axis=1)
    return cooperative_ekf(x0, P0, s.u, ranges, Q, R, s.times, leader=leader, dt=s.interval)


#: Acceleration variance of the cascade filter on the fixes [(m/s)²/s³]: the suite's vehicles turn sharply between
#: fixes 10 s apart, where paper E's default (1e-4, for a submersible running straight at 1 s) locks the filter
#: out after the first corner; with it the filter also re-acquires after 5 rejected fixes in a row.
VMLBL_FIX_Q = 1e-2

#: Epochs between the four epochs of a virtual-baseline fix in :func:`or_vmlbl` (200 s at the suite's pings).
VMLBL_SPACING = 20


def or_vmlbl(inputs: SuiteInputs) -> FilterResult:
    """Paper E's OR-VMLBL-KF (chapter 9): ranges cleaned by the robust range filter (its chi-square gate: the
    paper's relative test is tuned to 1 s epochs), four-epoch virtual long-baseline fixes ``VMLBL_SPACING``
    epochs apart, a gated constant-velocity filter on the fixes (``VMLBL_FIX_Q``); dead reckoning from the
    initial guess until the first fix.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor import methods
    >>> from uwtutor.scenarios import suite
    >>> rng = np.random.default_rng(0)
    >>> inputs, truth = suite.CONDITIONS["white"](rng, suite.SCENARIOS["circle"](rng, 2))
    >>> result = methods.or_vmlbl(inputs)
    >>> result.x.shape, bool(result.extras["started"][:, 0].any())
    ((2, 150, 2), False)
    """
    from .pipelines import NoUsableFixError, or_vmlbl_kf

    s = _inputs(inputs)
    dr_x, dr_P = _dead_reckoning(s)
    started = np.zeros((s.n_runs, s.n_epochs), dtype=bool)
    try:
        with warnings.catch_warnings():      # runs without any usable fix navigate by DR (below)
            warnings.simplefilter("ignore", IllConditionedWarning)
            out = or_vmlbl_kf(dr_x, s.z, ship_positions=s.beacon, depth=0.0, times=s.times, spacing=VMLBL_SPACING,
                              range_options=dict(r=s.R, test="chi2"), fix_q=VMLBL_FIX_Q,
                              fix_options=dict(reacquire=5))
    except NoUsableFixError:                 # not one fix in any run (a straight track): dead reckoning throughout
        return _result(s, dr_x, dr_P, extras={"started": started})
    now = np.asarray(out.now)
    started[:, now] = np.isfinite(out.track.x[..., :2]).all(axis=-1)   # a run without fixes keeps its DR
    x, P = dr_x, dr_P
    x[started] = out.track.x[..., :2][started[:, now]]
    P[started] = out.track.P[..., :2, :2][started[:, now]]
    return _result(s, x, P, extras={"started": started})


#: Particles per run of :func:`particle_filter`.
N_PARTICLES = 500


def particle_filter(inputs: SuiteInputs) -> FilterResult:
    """A bootstrap particle filter on the 2-D range-only problem (chapter 6's filter on chapter 4's models): the
    EKF's model pair, :class:`~uwtutor.models.dead_reckoning.DeadReckoning` with the suite's Q (the DR displacements as
    the input ``u``) and :class:`~uwtutor.models.range.RangeToBeacon` with each run's beacon path (a moving beacon is
    only another measurement model input); ``N_PARTICLES`` particles from :math:`N(x_0, P_0)`, resampling (systematic)
    when the effective sample size falls below half. It can hold both mirror solutions of a straight
    track.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor import methods
    >>> from uwtutor.scenarios import suite
    >>> rng = np.random.default_rng(0)
    >>> inputs, truth = suite.CONDITIONS["white"](rng, suite.SCENARIOS["circle"](rng, 2))
    >>> result = methods.particle_filter(inputs)
    >>> result.x.shape, sorted(result.extras)
    ((2, 150, 2), ['ess', 'resampled'])
    """
    s = _inputs(inputs)
    rng = np.random.default_rng(s.method_seed)
    pf = BootstrapParticleFilter.from_gaussian(DeadReckoning(s.Q), RangeToBeacon(s.beacon, R=s.R), s.x0, s.P0,
                                               N_PARTICLES, rng, n_runs=s.n_runs, ess_threshold=0.5)
    return pf.run(s.z, s.u, times=s.times)


# ---------------------------------------------------------------------------------------------------------------------
# the registry
# ---------------------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Method:
    """A method of the book as the comparison runs it.

    Attributes
    ----------
    name : str
        Its name in tables and figures.
    estimate : callable
        ``estimate(inputs) -> FilterResult`` (a module-level function: a process pool can pickle it).
    paper : str
        The paper it comes from (``"A"``-``"E"``), or ``""`` for the textbook filters.
    chapter : int
        The chapter that builds it.
    needs : str
        ``"any"``, ``"fixed beacon"`` or ``"leader"`` (a beacon that moves and broadcasts its position).
    summary : str
        One line on what it is.

    Examples
    --------
    >>> from uwtutor import methods
    >>> m = methods.get("IEKF")
    >>> m.paper, m.chapter, m.needs, m.runs_on("moving beacon")
    ('A', 7, 'any', True)
    """

    name: str
    estimate: Callable[[SuiteInputs], FilterResult]
    paper: str
    chapter: int
    needs: str
    summary: str

    def __call__(self, inputs: SuiteInputs) -> FilterResult:
        return self.estimate(inputs)

    def runs_on(self, scenario: str) -> bool:
        """Whether the method claims the scenario of :data:`~uwtutor.scenarios.suite.SCENARIOS` named ``scenario``."""
        moving = scenario == "moving beacon"
        return {"any": True, "fixed beacon": not moving, "leader": moving}[self.needs]


_METHODS = (
    Method("LS pre-positioning", ls_prepositioning, "A", 7, "any",
           "least squares on all the ranges so far, a bias unknown"),
    Method("grid pre-location", grid_prelocation, "D", 5, "fixed beacon",
           "grid search over start bearing and sound speed"),
    Method("EKF", ekf, "", 4, "any", "range-only extended Kalman filter"),
    Method("IEKF", iekf, "A", 7, "any", "EKF with a range-bias state"),
    Method("pre-positioned IEKF", prepositioned_iekf, "A", 7, "fixed beacon",
           "IEKF started from a least-squares fix with precision factor < 2"),
    Method("SFEKF", sfekf, "D", 5, "fixed beacon", "fading EKF for multiplicative noise, constant weakening"),
    Method("ISFEKF", isfekf, "D", 5, "fixed beacon", "fading EKF with range-dependent weakening"),
    Method("LS-ISFEKF", ls_isfekf, "D", 5, "fixed beacon", "grid pre-location, then the ISFEKF"),
    Method("cooperative EKF", cooperative, "B", 8, "leader", "EKF on range pairs with a current state"),
    Method("OR-VMLBL-KF", or_vmlbl, "E", 9, "any", "outlier-rejecting virtual long-baseline fixes, filtered"),
    Method("particle filter", particle_filter, "", 6, "any", "bootstrap particle filter, 500 particles"),
    Method("gated EKF", gated_ekf, "", 9, "any", "EKF with a chi-square gate (99.9 %) and re-acquisition"),
)

#: Every method by name, in the chapter's order.
REGISTRY: dict[str, Method] = {m.name: m for m in _METHODS}


def names() -> list[str]:
    """The registered method names, in order.

    Examples
    --------
    >>> from uwtutor import methods
    >>> methods.names()[:3]
    ['LS pre-positioning', 'grid pre-location', 'EKF']
    """
    return list(REGISTRY)


def get(name: str) -> Method:
    """The :class:`Method` called ``name`` (a ValueError listing the names otherwise).

    Examples
    --------
    >>> from uwtutor import methods
    >>> methods.get("EKF").summary
    'range-only extended Kalman filter'
    >>> methods.get("EKF2")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
        ...
    ValueError: no method called 'EKF2': name must be one of [...]
    """
    if not isinstance(name, str) or name not in REGISTRY:
        raise ValueError(f"no method called {name!r}: name must be one of {names()}")
    return REGISTRY[name]


def claims() -> dict[str, list[str]]:
    """``method name -> the scenarios it runs on``: the ``only`` argument of :func:`uwtutor.montecarlo.compare`.

    Examples
    --------
    >>> from uwtutor import methods
    >>> methods.claims()["cooperative EKF"]
    ['moving beacon']
    """
    return {m.name: [s for s in SCENARIOS if m.runs_on(s)] for m in _METHODS}


def run(name: str, scenario: str, condition: str, rng: np.random.Generator,
        n_runs: int = 1) -> tuple[FilterResult, np.ndarray]:
    """Draw ``n_runs`` runs of a scenario under a condition with ``rng`` and run the method ``name`` on them.

    Returns
    -------
    result : FilterResult
        The method's estimates, ``x`` of shape ``(n_runs, K, n_state)``.
    truth : ndarray, shape (n_runs, K, 2)
        The true positions.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor import methods
    >>> res, truth = methods.run(
    ...     "EKF", "circle", "white", np.random.default_rng(7), n_runs=20
    ... )
    >>> res.x.shape, truth.shape
    ((20, 150, 2), (20, 150, 2))
    >>> err = np.linalg.norm(res.x[:, -1] - truth[:, -1], axis=-1)
    >>> bool(np.sqrt(np.mean(err**2)) < 20.0)
    True
    """
    method = get(name)
    scenario = as_choice("scenario", scenario, SCENARIOS)
    condition = as_choice("condition", condition, CONDITIONS)
    if not method.runs_on(scenario):
        raise ValueError(f"{name} needs a {method.needs}; it does not run on the scenario {scenario!r}")
    rng = as_rng(rng)
    n_runs = as_int("n_runs", n_runs, minimum=1)
    try:
        drawn = SCENARIOS[scenario](rng, n_runs)
    except ValueError as exc:              # rng and n_runs are checked: the scenario refuses the number of runs
        raise ValueError(f"n_runs = {n_runs} is too many runs for one call: {exc}") from None
    inputs, truth = CONDITIONS[condition](rng, drawn)
    return method(inputs), truth


def _names(name: str, value: Any, known: Any) -> list[str]:
    """A list of names from ``known`` (``None``: all of them); a bare string, an unknown name or an empty list is
    refused by the argument's name."""
    if value is None:
        return list(known)
    if isinstance(value, (str, bytes)):
        raise TypeError(f"{name} must be a list of names, e.g. [{value!r}]; got the bare string {value!r}")
    try:
        chosen = list(value)
    except TypeError:
        raise TypeError(f"{name} must be a list of names from {list(known)}; got {type(value).__name__}") from None
    unknown = [x for x in chosen if not isinstance(x, str) or x not in known]
    if unknown:
        raise ValueError(f"{name} must be names from {list(known)}; got {unknown}")
    if not chosen:
        raise ValueError(f"{name} must name at least one of {list(known)} (or be None for all of them)")
    return chosen


def suite_bounds(scenarios: Any = None, conditions: Any = None) -> dict[tuple[str, str], np.ndarray]:
    r"""The RMSE bound :math:`B_k = \sqrt{\operatorname{tr} J_k^{-1}}` (position block of the posterior CRLB) of
    every (scenario, condition) of the suite, from :func:`uwtutor.scenarios.suite.crlb_inputs`.

    Parameters
    ----------
    scenarios, conditions : list of str, optional
        Names from :data:`~uwtutor.scenarios.suite.SCENARIOS` and :data:`~uwtutor.scenarios.suite.CONDITIONS`
        (all of them by default).

    Returns
    -------
    dict
        ``(scenario, condition) -> B_k``, an array of shape ``(K,)`` [m].

    Examples
    --------
    >>> from uwtutor import methods
    >>> bounds = methods.suite_bounds(["circle"], ["white"])
    >>> B = bounds["circle", "white"]
    >>> B.shape, bool(B[-1] < B[0])
    ((150,), True)
    """
    from .observability import posterior_crlb, rmse_bound
    from .scenarios.suite import crlb_inputs

    return {(s, c): np.asarray(rmse_bound(posterior_crlb(**crlb_inputs(s, c))))
            for s in _names("scenarios", scenarios, SCENARIOS)
            for c in _names("conditions", conditions, CONDITIONS)}


# ---------------------------------------------------------------------------------------------------------------------
# real logs: the same methods, the same inputs
# ---------------------------------------------------------------------------------------------------------------------
def dataset_inputs(data: Any, beacon_id: int, schedules: Any = None, *, min_period: Any = None,
                   range_sigma: ArrayLike | None = None, distance_sigma: Any = None,
                   method_seed: int = 0) -> SuiteInputs:
    r"""A recorded log as the :class:`~uwtutor.scenarios.suite.SuiteInputs` every registered method takes: one run per
    range schedule.

    The log's epochs are the method's epochs (``times``; epoch 0 is the first row of the log, reached from the start
    pose by a zero displacement), the displacements are the differences of the log's own dead reckoning
    (:func:`uwtutor.datasets.baselines.world_displacements`), the ranges are those of ``beacon_id`` on the epochs
    (:meth:`~uwtutor.datasets.RangeDataset.ranges_on_epochs`, thinned to one per ``min_period`` seconds), and
    each run keeps the ranges its schedule keeps (NaN elsewhere: the method predicts only). The noise the methods
    are told: :math:`\sigma_r` = ``range_sigma`` (0.6 m), :math:`\mathbf Q` the mean over the steps of
    :math:`(a + c\,d_k)^2\mathbf I` (``distance_sigma`` = ``(a, c)``, (0.01, 0.02)), :math:`\mathbf P_0` the log's
    start covariance; a bias state (IEKF) starts at 0 with 5 m standard deviation.

    Parameters
    ----------
    data : uwtutor.datasets.RangeDataset
        The log, with a start pose.
    beacon_id : int
        The one beacon the methods range to (every method of the registry is a single-beacon method).
    schedules : array_like of bool, shape (n, K), optional
        ``schedules[j, k]``: run ``j`` uses the range of epoch ``k`` (if there is one). Default: one run, every range.
    min_period : float, optional
        At most one range every ``min_period`` seconds (before the schedules).
    range_sigma, distance_sigma : optional
        The noise the methods are told (defaults of :mod:`uwtutor.datasets.baselines`).
    method_seed : int, default 0
        The seed of a method that draws random numbers (the particle filter).

    Returns
    -------
    SuiteInputs
        ``scenario`` and ``condition`` are ``"log"`` and ``"schedule"``; ``moving`` is False. Paper D's grid
        pre-location and the LS-ISFEKF start from the ring of the first range: they refuse a log (or a schedule)
        without a range at epoch 0.

    Examples
    --------
    The small synthetic log, every range and every other range: two runs, each registered method runs on them:

    >>> import numpy as np
    >>> from uwtutor import methods
    >>> from uwtutor.datasets import square_log
    >>> data = square_log()
    >>> K = data.n_epochs
    >>> schedules = np.array([np.ones(K, bool), np.arange(K) % 2 == 0])
    >>> inputs = methods.dataset_inputs(data, 3, schedules)
    >>> inputs.n_runs, inputs.n_epochs
    (2, 81)
    >>> result = methods.get("EKF")(inputs)
    >>> err = np.linalg.norm(result.x[:, -1] - data.truth[-1, :2], axis=-1)
    >>> bool(np.all(err < 1.0))
    True
    """
    from dataclasses import replace

    from .datasets import RangeDataset
    from .datasets.baselines import DISTANCE_SIGMA, RANGE_SIGMA, displacement_covariance, world_displacements
    from .scenarios.suite import PARAMETERS

    if not isinstance(data, RangeDataset):
        raise TypeError(f"data must be a uwtutor.datasets.RangeDataset; got {type(data).__name__}")
    if data.start is None:
        raise ValueError("data has no start pose: build the RangeDataset with start= (or truth=)")
    beacon_id = as_int("beacon_id", beacon_id)
    if beacon_id not in data.beacons:
        raise ValueError(f"beacon_id must be one of the log's beacons {sorted(data.beacons)}; got {beacon_id}")
    K = data.n_epochs
    z1 = data.ranges_on_epochs([beacon_id], min_period=min_period)[:, 0]
    if schedules is None:
        keep = np.ones((1, K), dtype=bool)
    else:
        keep = np.asarray(schedules)
        if keep.dtype != bool or keep.ndim != 2 or keep.shape[1] != K or keep.shape[0] < 1:
            raise ValueError(f"schedules must be a boolean array of shape (n_runs, {K}) (one row per run, one "
                             f"column per epoch of the log); got {keep.dtype} of shape {keep.shape}")
    n = keep.shape[0]
    sigma_r = float(RANGE_SIGMA if range_sigma is None else as_positive("range_sigma", range_sigma))
    Q = displacement_covariance(data, DISTANCE_SIGMA if distance_sigma is None else distance_sigma).mean(axis=0)
    start, cov = data.start, data.start_cov
    if start is None or cov is None:    # refused above; RangeDataset gives a start pose its covariance
        raise ValueError("data has no start pose: build the RangeDataset with start= (or truth=)")
    P0 = np.asarray(cov[:2, :2], dtype=float)
    x0 = np.broadcast_to(np.asarray(start[:2], dtype=float), (n, 2)).copy()
    b = np.asarray(data.beacons[beacon_id], dtype=float)
    times = np.asarray(data.times, dtype=float)
    interval = float(np.median(np.diff(times))) if K > 1 else 1.0
    params = replace(PARAMETERS, n_epochs=K, interval=interval, dr_sigma=float(np.sqrt(Q[0, 0])),
                     range_sigma=sigma_r, start_sigma=float(np.sqrt(np.mean(np.diag(P0)))), bias_mean=0.0,
                     bias_sigma=5.0)
    return SuiteInputs(scenario="log", condition="schedule", times=times, interval=interval, x0=x0, P0=P0,
                       u=np.broadcast_to(world_displacements(data), (n, K, 2)).copy(),
                       z=np.where(keep, z1, np.nan), z0=np.full(n, np.nan),
                       beacon=np.broadcast_to(b, (n, K, 2)).copy(), beacon0=np.broadcast_to(b, (n, 2)).copy(),
                       moving=False, Q=Q, R=sigma_r**2, method_seed=as_int("method_seed", method_seed, minimum=0),
                       parameters=params)


def _log_draw(data: Any, beacon_id: int, schedules: np.ndarray, options: dict[str, Any], rng: Any,
              n: int) -> tuple[SuiteInputs, np.ndarray]:
    if n != len(schedules):
        raise ValueError(f"a log's runs are its {len(schedules)} schedules, drawn in one chunk: call the study with "
                         f"n_runs = chunk_size = {len(schedules)}; got a chunk of {n}")
    seed = int(rng.integers(2**31))
    inputs = dataset_inputs(data, beacon_id, schedules, method_seed=seed, **options)
    truth = np.broadcast_to(np.asarray(data.truth, dtype=float)[:, :2], (n, data.n_epochs, 2))
    return inputs, truth


def log_draw(data: Any, beacon_id: int, schedules: Any, **options: Any) -> Callable[..., Any]:
    """The ``draw(rng, n)`` of :func:`uwtutor.montecarlo.run_study` for a recorded log: its runs are the log under
    each schedule (:func:`dataset_inputs`), the truth the log's ground truth. ``n`` must be the number of schedules
    (one chunk); ``rng`` only seeds a method that draws random numbers. Picklable (a process pool takes it).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor import methods
    >>> from uwtutor.datasets import square_log
    >>> from uwtutor.montecarlo import run_study
    >>> data = square_log()
    >>> schedules = np.array([np.arange(data.n_epochs) % s == 0 for s in (1, 2, 3)])
    >>> draw = methods.log_draw(data, 3, schedules)
    >>> study = run_study(
    ...     draw, methods.get("IEKF").estimate, 3, seed=0, chunk_size=3, components=(0, 1)
    ... )
    >>> study.final_errors.shape, bool(study.final_errors.max() < 1.0)
    ((3,), True)
    """
    import functools

    from .datasets import RangeDataset

    if not isinstance(data, RangeDataset) or data.truth is None:
        raise TypeError("data must be a uwtutor.datasets.RangeDataset with a ground truth (truth=): a study scores "
                        f"against it; got {type(data).__name__}")
    keep = np.asarray(schedules)
    dataset_inputs(data, beacon_id, keep, **options)          # every argument checked here, once
    return functools.partial(_log_draw, data, int(beacon_id), keep, dict(options))


#: Most runs per row :func:`compare_suite` accepts (the book's table has 1000; a million takes about a day).
MAX_STUDY_RUNS = 10**6


def compare_suite(n_runs: int, seed: int, executor: Any = None, *, methods: Any = None, scenarios: Any = None,
                  conditions: Any = None, chunk_size: int = 1000, measure_cost: bool = True,
                  timing_runs: int = 100) -> Any:
    """Chapter 10's table: the registered methods on the suite's scenarios and conditions, against the bound.

    :func:`uwtutor.montecarlo.compare` with every method on the scenarios it claims, the bounds of
    :func:`suite_bounds`, and the default divergence threshold (50 m). ``methods``, ``scenarios`` and
    ``conditions`` (lists of names) choose a part of the table: the rows computed are the same numbers as in the
    whole table, for the same ``seed`` and ``chunk_size`` (each row's study depends on nothing else).

    Examples
    --------
    >>> from uwtutor import methods
    >>> table = methods.compare_suite(
    ...     200,
    ...     seed=3,
    ...     methods=["EKF", "IEKF"],
    ...     scenarios=["circle"],
    ...     conditions=["bias"],
    ...     measure_cost=False,
    ... )
    >>> [(r["method"], round(r["efficiency"], 1) > 0.9) for r in table.rows()]
    [('EKF', True), ('IEKF', True)]
    """
    from .montecarlo import compare

    chosen = _names("methods", methods, REGISTRY)
    scen = _names("scenarios", scenarios, SCENARIOS)
    cond = _names("conditions", conditions, CONDITIONS)
    n_runs = as_int("n_runs", n_runs, minimum=1, maximum=MAX_STUDY_RUNS)
    timing_runs = as_int("timing_runs", timing_runs, minimum=1)
    measure_cost = as_flag("measure_cost", measure_cost)
    only = {m: [s for s in scen if get(m).runs_on(s)] for m in chosen}
    keep = [m for m in chosen if only[m]]
    if not keep:
        raise ValueError(f"none of the methods {chosen} runs on the scenarios {scen}")
    return compare({m: REGISTRY[m].estimate for m in keep}, {s: SCENARIOS[s] for s in scen},
                   {c: CONDITIONS[c] for c in cond}, n_runs, seed, executor, chunk_size=chunk_size,
                   bounds=suite_bounds(scen, cond), only={m: only[m] for m in keep},
                   measure_cost=measure_cost, timing_runs=min(timing_runs, n_runs))


def load_comparison() -> Any:
    """The committed comparison of chapter 10 (``make study``: 1000 runs per row), with its curves and its runs.

    Returns
    -------
    uwtutor.montecarlo.ComparisonTable
        Read from the package's ``data/comparison.csv``, ``data/comparison_curves.npz`` and
        ``data/comparison_runs.npz`` (every row's final errors and final NEES: the paired comparisons).

    Examples
    --------
    >>> from uwtutor import methods
    >>> table = methods.load_comparison()
    >>> int(table.n_runs[0]), table.rmse_curves.shape[1]
    (1000, 150)
    """
    from pathlib import Path

    from .montecarlo import ComparisonTable

    data = Path(__file__).parent / "data"
    with np.load(data / "comparison_runs.npz") as runs:
        n_rows = len(runs["method"])
    table = ComparisonTable.from_csv(data / "comparison.csv", curves=data / "comparison_curves.npz")
    if n_rows != len(table):              # a runs file older than the table: the table without its runs
        warnings.warn(f"{data / 'comparison_runs.npz'} holds {n_rows} rows, the table {len(table)}: the paired "
                      "comparisons need both from the same make study", RuntimeWarning, stacklevel=2)
        return table
    return ComparisonTable.from_csv(data / "comparison.csv", curves=data / "comparison_curves.npz",
                                    runs=data / "comparison_runs.npz")
