r"""The recommended filter for a real log, in one call: :func:`navigate`.

A real range log differs from the book's simulations in two errors that the position-only models leave out
(chapter 11 measures both on the Plaza sets):

* a **range scale** :math:`s`: every range is :math:`s\,\lVert p - b\rVert` with :math:`s \neq 1` (7 % on the
  Plaza radios; a sound-speed error does the same to an acoustic range, paper D's :math:`\mu_\gamma`) -- a
  constant to *estimate*, not a known factor;
* a **gyro bias** :math:`b_g`: the odometry's heading drifts (by more than 100 degrees over Plaza 2).

:func:`navigate` therefore runs the library's generic EKF (:func:`uwtutor.filters.engine.extended_kalman_filter`) on the
state :math:`[x, y, \theta, b_g, s]` with :class:`uwtutor.models.odometry.OdometryMotion` (each step moves along the
previous heading, then turns: the convention of the data, :meth:`RangeDataset.dead_reckoning`) and
:class:`uwtutor.models.BeaconRanges` (:math:`z_j = s\,\lVert p - b_j\rVert + v_j`, the beacons heard at an epoch,
the others skipped), behind a chi-square gate that cannot lock out (:class:`uwtutor.filters.gates.ReacquiringGate`),
and smooths it with :func:`uwtutor.filters.smoother.rts_smoother` when asked. Nothing here is a new loop: a model pair,
the engine and its gate.

:func:`navigation_models` gives that model pair, its start and the log's inputs and measurements, so that the
same pair runs in any other filter of the library -- the particle filter, on a log where the EKF's Gaussian is
not enough::

    nav = navigation_models(data)
    pf = BootstrapParticleFilter.from_gaussian(nav.motion, nav.measurement, nav.x0, nav.P0, 2000,
                                               numpy.random.default_rng(0), ess_threshold=0.5)
    result = pf.run(nav.z, nav.u, times=nav.times)

The noise defaults describe wheel odometry and radio ranges like the Plaza sets' (range noise about 0.55 m,
odometry good to about 0.1 m over 2 s); pass your own for other sensors.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .._validate import as_finite, as_flag, as_nonnegative, as_scalar
from ..filters import ChiSquareGate, FilterResult, ReacquiringGate, extended_kalman_filter, rts_smoother
from ..models import BeaconRanges, OdometryMotion
from ._core import BeaconIds, RangeDataset

__all__ = ["navigate", "navigation_models", "navigation_gate", "NavigationModels", "NavigationResult", "CANDIDATES",
           "LOST_TRACK_REJECTED"]


def _positive(name: str, value: Any) -> float:
    # bounded so that its square (a variance) neither underflows to 0 nor overflows
    return as_scalar(name, value, domain="positive", low=1e-9, high=1e6)


def navigate(data: RangeDataset, beacon_ids: BeaconIds = None, *, min_period: float | None = None, offset: float = 0.0,
             thinning: str = "per beacon", smooth: bool = False, gyro_bias: bool | None = None,
             scale: bool | None = None, range_sigma: float = 0.6, distance_sigma: tuple[float, float] = (0.01, 0.02),
             heading_noise: float = 1e-3, gyro_bias_prior: float = 0.01, gyro_bias_walk: float = 1e-4,
             scale_prior: float = 0.1, scale_walk: float = 1e-5, gate: bool = True) -> "NavigationResult":
    r"""Navigate a range log from its start pose: odometry, ranges to known beacons, heading, gyro bias and scale.

    The state is :math:`[x, y, \theta, b_g, s]` (fewer with ``gyro_bias=False`` or ``scale=False``), the motion

    .. math::

        p_k = p_{k-1} + d_k \begin{bmatrix}\cos\theta_{k-1}\\ \sin\theta_{k-1}\end{bmatrix},\qquad
        \theta_k = \theta_{k-1} + \Delta\theta_k - b_{g}\,\Delta t_k,

    with the odometry noise :math:`\sigma_{d,k} = a + c\,|d_k|` on the distance and
    :math:`\sigma_{\theta,k} = q_\theta\sqrt{\Delta t_k}` on the heading change, slow random walks on :math:`b_g`
    and :math:`s`, and the ranges :math:`z_{k,j} = s\,\lVert p_k - b_j\rVert + v_{k,j}`,
    :math:`v \sim N(0, \sigma_r^2)`, to the beacons heard at epoch :math:`k`.

    Parameters
    ----------
    data : RangeDataset
        The log; it must have a start pose (``data.start``, ``data.start_cov``).
    beacon_ids : sequence, optional
        The beacons to use (default: all of ``data.beacons``), e.g. ``[5]`` for one.
    min_period : float, optional
        Use at most one range per beacon every ``min_period`` seconds (an acoustic modem's rate), as
        :meth:`RangeDataset.ranges_on_epochs` thins them.
    smooth : bool, default False
        Return the Rauch--Tung--Striebel smoothed estimates (every range, past and future, behind every epoch)
        instead of the filtered ones.
    offset : float, default 0
        With ``min_period``: the thinning's schedule starts ``offset`` seconds after the first epoch (one log gives
        one schedule per offset; see :meth:`RangeDataset.ranges_on_epochs`).
    thinning : {"per beacon", "in total"}, default "per beacon"
        With ``min_period``: one range per beacon per period, or one range per period in total (a modem that
        interrogates one beacon at a time).
    gyro_bias, scale : bool or None, default None
        Estimate a gyro bias [rad/s] and a range scale (True), leave it out (False), or let the log decide
        (None): the candidates -- pose only, + scale, + gyro bias, + both, those that the switches given allow --
        are each run and the one whose innovations the ranges make most likely is returned (Notes). An unneeded
        state that a single beacon observes weakly costs accuracy: on a log whose heading does not drift, the
        gyro-bias state lets the heading wander.
    range_sigma : float, default 0.6
        :math:`\sigma_r` [m], the range noise.
    distance_sigma : (float, float), default (0.01, 0.02)
        :math:`(a, c)`: the distance noise of a step, :math:`a` [m] plus :math:`c` times the distance.
    heading_noise : float, default 1e-3
        :math:`q_\theta` [rad/√s], the heading-change noise density.
    gyro_bias_prior, gyro_bias_walk : float, default 0.01, 1e-4
        Prior standard deviation of :math:`b_g` about 0 [rad/s], and its random walk [rad/s/√s].
    scale_prior, scale_walk : float, default 0.1, 1e-5
        Prior standard deviation of :math:`s` about 1, and its random walk [1/√s].
    gate : bool, default True
        Reject ranges outside the 99.9 % chi-square gate, component by component, with re-acquisition after 10
        rejected epochs in a row (:class:`uwtutor.filters.gates.ReacquiringGate`), so that the gate never locks out.

    Returns
    -------
    NavigationResult
        At ``data.times``: ``x[:, :2]`` the positions, ``x[:, 2]`` the heading, then :math:`b_g` and :math:`s`
        (those estimated, in that order: ``state_names``); with ``smooth=True`` the smoothed ``x`` and ``P``
        beside the filter's priors and innovations. ``extras["ranges"]`` holds the ranges used, ``(K, B)``, NaN
        where none; with ``smooth=True``, ``extras["filtered"]`` holds the filter's own result (its ``x`` and
        ``P``). ``chosen`` names the candidate returned and ``evidence`` gives every candidate's log predictive
        likelihood (Notes).

    Warns
    -----
    UserWarning
        When the log looks wrong for the model: the ranges disagree with the odometry far beyond their noise
        (median normalized innovation more than 20 times its chi-square median) or the range scale comes out
        more than 30 % from 1 -- most often a heading in degrees or measured clockwise from north, beacons in
        another frame, or ranges in other units. Also when the gate rejected more than a fifth of the ranging
        epochs (``LOST_TRACK_REJECTED``): a log with that many outliers, or, more often, a filter that has lost
        the track between ranges too sparse for its model -- its estimate may then be worse than the odometry
        alone. On the Plaza logs (``studies/plaza_navigation.py``'s schedules) the chosen filter never rejected
        more than a tenth of its epochs at the logged rate or at one range every 10 s; at one every 30 s it rejected
        more than a fifth in 8 of 120 schedules, among them the 3 where it ended worse than the odometry.

    Notes
    -----
    **Choosing the states from the log.** Each candidate :math:`c` is run through the gated filter, and scored by
    the log predictive likelihood of *every* range of the log (the gate's rejects included, from the candidate's
    own prediction, so that every candidate is scored on the same ranges):

    .. math::

        \ell_c = \sum_k \log \mathcal N\big(z_k;\ h(\hat x^c_{k|k-1}),\ H P^c_{k|k-1} H^\mathsf{T} + R\big),

    the sum of each epoch's ranges' joint density given everything before them (the prequential score of Dawid
    1984; a Bayes factor between the candidates when the filters are exact). A candidate that lost the track
    predicts the next ranges badly or vaguely and scores low, however few ranges its gate let in. The largest
    :math:`\ell_c` wins; a candidate with more states must beat a smaller one by more than one unit per extra
    state (Akaike's penalty). The candidates run as the runs of one batched filter (each with the states it
    leaves out known exactly), at about the cost of one run.

    Raises
    ------
    ValueError
        If the dataset has no start pose, a beacon id is unknown, or a noise parameter is not positive.

    Examples
    --------
    A square driven twice with a 3 % range scale and a gyro bias of 0.002 rad/s, one beacon in the middle:

    >>> import numpy as np
    >>> from uwtutor.datasets import RangeDataset, navigate
    >>> rng = np.random.default_rng(0)
    >>> K, dt = 1601, 0.5
    >>> turn = np.where(np.arange(K) % 200 == 0, np.pi / 2, 0.0)
    >>> turn[0] = 0.0
    >>> odometry = np.column_stack([np.full(K, 0.5), turn + 0.002 * dt])
    >>> odometry[0] = 0.0
    >>> truth = RangeDataset(
    ...     times=dt * np.arange(K),
    ...     odometry=np.column_stack([odometry[:, 0], turn]),
    ...     ranges=np.empty((0, 3)),
    ...     beacons={7: (50.0, 50.0)},
    ...     start=[0.0, 0.0, 0.0],
    ... ).dead_reckoning()
    >>> heard = np.arange(1, K, 4)
    >>> r = 1.03 * np.linalg.norm(
    ...     truth[heard, :2] - [50.0, 50.0], axis=1
    ... ) + rng.normal(0.0, 0.3, heard.size)
    >>> data = RangeDataset(
    ...     times=dt * np.arange(K),
    ...     odometry=odometry,
    ...     ranges=np.column_stack([dt * heard, np.full(heard.size, 7), r]),
    ...     beacons={7: (50.0, 50.0)},
    ...     start=[0.0, 0.0, 0.0],
    ...     truth=truth,
    ... )
    >>> result = navigate(data, range_sigma=0.3)
    >>> result.x.shape
    (1601, 5)
    >>> round(float(result.x[-1, 4]), 2), round(float(result.x[-1, 3]), 3)
    (1.03, 0.002)
    >>> bool(np.linalg.norm(result.x[-1, :2] - truth[-1, :2]) < 1.0)
    True
    """
    smooth, gate = as_flag("smooth", smooth), as_flag("gate", gate)
    fixed_bias = None if gyro_bias is None else as_flag("gyro_bias", gyro_bias)
    fixed_scale = None if scale is None else as_flag("scale", scale)
    options = dict(min_period=min_period, offset=offset, thinning=thinning, range_sigma=range_sigma,
                   distance_sigma=distance_sigma, heading_noise=heading_noise, gyro_bias_prior=gyro_bias_prior,
                   gyro_bias_walk=gyro_bias_walk, scale_prior=scale_prior, scale_walk=scale_walk)
    candidates = [(name, flags) for name, flags in CANDIDATES.items()
                  if fixed_bias in (None, flags[0]) and fixed_scale in (None, flags[1])]
    runs = _run_candidates(data, beacon_ids, candidates, gate, options)
    evidence = {name: float(run[2][0]) for name, run in runs.items()}
    chosen = min(runs, key=lambda name: (-(evidence[name] - _n_extra(name)), _n_extra(name)))
    nav, result, (_, per_range) = runs[chosen]
    _check_plausible(data, nav, result, per_range)
    extras = dict(result.extras, ranges=nav.z)
    candidate_runs = {name: run[1] for name, run in runs.items()}
    x, P = result.x, result.P
    if smooth:
        smoothed = rts_smoother(result, nav.motion, nav.u)
        x, P = smoothed.x, smoothed.P
        extras["filtered"] = result
    return NavigationResult(result.times, x, P, result.x_prior, result.P_prior, result.innovations,
                            result.innovation_cov, extras, state_names=nav.motion.layout.names, chosen=chosen,
                            evidence=evidence, models=nav, candidates=candidate_runs)


#: navigate's candidate models: name -> ``(gyro_bias, scale)``.
CANDIDATES: dict[str, tuple[bool, bool]] = {"pose only": (False, False), "+ scale": (False, True),
                                            "+ gyro bias": (True, False), "+ scale and gyro bias": (True, True)}


def _n_extra(name: str) -> int:
    return sum(CANDIDATES[name])


def navigation_gate() -> ReacquiringGate:
    r"""The gate of :func:`navigate`, new (a gate keeps a count of the rejections in a row, so each run takes its own).

    A chi-square test of each beacon's range at 99.9 % (:class:`~uwtutor.filters.gates.ChiSquareGate` with
    ``per_component=True``: one outlying beacon does not take the others with it), re-acquiring after 10 rejections
    in a row (:class:`~uwtutor.filters.gates.ReacquiringGate`: a filter that has lost the track widens its
    covariance instead of turning every range away for good). For a filter of your own on a log, with the models of
    :func:`navigation_models`.

    Examples
    --------
    >>> from uwtutor.datasets import navigation_gate
    >>> gate = navigation_gate()
    >>> type(gate).__name__, gate.patience
    ('ReacquiringGate', 10)
    """
    return ReacquiringGate(ChiSquareGate(0.999, per_component=True), patience=10)


def _run_candidates(data: RangeDataset, beacon_ids: BeaconIds, candidates: list[tuple[str, tuple[bool, bool]]],
                    gate: bool, options: dict[str, Any]) -> dict[str, tuple["NavigationModels", FilterResult, Any]]:
    """Run every candidate through the gated filter and score it: name -> (its models, its result, its
    ``_log_predictive``).

    A single candidate runs alone. Several run as the runs of one batched filter on the largest model,
    :math:`[x, y, \theta, b_g, s]`: a candidate without a state starts it with zero variance (at :math:`b_g = 0`,
    :math:`s = 1`, where its own model has it) and gives it no random walk, so that the state never moves, its
    rows of :math:`P` stay exactly 0 and the other states see that candidate's own model. The engine then steps
    the candidates at the per-step cost of one run (about 4 times faster than one run each). Each candidate's
    result is its states' part of its run: the same numbers as the candidate run alone up to round-off
    (tests/test_navigate.py checks it).
    """
    def new_gate() -> ReacquiringGate | None:
        return navigation_gate() if gate else None

    models = {name: navigation_models(data, beacon_ids, gyro_bias=with_bias, scale=with_scale, **options)
              for name, (with_bias, with_scale) in candidates}
    if len(candidates) == 1:
        nav = next(iter(models.values()))
        result = extended_kalman_filter(nav.motion, nav.measurement, nav.x0, nav.P0, nav.u, nav.z,
                                        times=nav.times, gate=new_gate())
        return {name: (nav, result, _log_predictive(nav, result)) for name in models}
    full = models.get("+ scale and gyro bias") or navigation_models(data, beacon_ids, gyro_bias=True, scale=True,
                                                                    **options)
    layout = full.motion.layout
    walks = np.zeros((len(candidates), layout.n))
    P0 = np.repeat(full.P0[None], len(candidates), axis=0)
    known = np.zeros((len(candidates), layout.n), dtype=bool)
    kept = {}
    for run, (name, (with_bias, with_scale)) in enumerate(candidates):
        for index, present, walk in ((layout.gyro_bias, with_bias, options["gyro_bias_walk"]),
                                     (layout.scale, with_scale, options["scale_walk"])):
            if present:
                walks[run, index] = float(walk)               # validated by navigation_models above
            else:
                P0[run, index, :] = P0[run, :, index] = 0.0
                known[run, index] = True
        kept[name] = [layout.names.index(state) for state in models[name].motion.layout.names]
    batch = extended_kalman_filter(full.motion._with_walks_per_run(walks), full.measurement, full.x0, P0, full.u,
                                   full.z, times=full.times, gate=new_gate(), known_states=known)
    runs = {}
    for run, (name, _) in enumerate(candidates):
        states, block = kept[name], np.ix_(kept[name], kept[name])
        x_prior, P_prior = batch.priors()
        result = FilterResult(times=batch.times, x=batch.x[run][:, states], P=batch.P[run][:, block[0], block[1]],
                              x_prior=x_prior[run][:, states], P_prior=P_prior[run][:, block[0], block[1]],
                              innovations=batch.innovations[run], innovation_cov=batch.innovation_cov[run],
                              extras={key: value[run] for key, value in batch.extras.items()})
        runs[name] = (models[name], result, _log_predictive(models[name], result))
    return runs


def _log_predictive(nav: "NavigationModels", result: FilterResult) -> tuple[float, np.ndarray]:
    """The log predictive likelihood of every range (Notes of :func:`navigate`), and the normalized innovation
    squared per range of every epoch with ranges, from the filter's priors (the gate's rejects included)."""
    z = nav.z
    heard = np.isfinite(z)
    epochs = np.nonzero(heard.any(axis=1))[0]
    if epochs.size == 0:
        return 0.0, np.empty(0)
    x_prior, P_prior = result.priors()
    predicted, H, _ = nav.measurement.linearize(x_prior[epochs], 0)
    S = H @ P_prior[epochs] @ np.swapaxes(H, -1, -2) + nav.measurement.R(x_prior[epochs], 0) * np.eye(z.shape[1])
    mask = heard[epochs]
    y = np.where(mask, z[epochs] - predicted, 0.0)
    # the missing components decoupled (unit variance, zero innovation): their terms are then 0 and dropped
    S = np.where(mask[:, :, None] & mask[:, None, :], S, 0.0) + np.einsum("kb,bc->kbc", ~mask, np.eye(z.shape[1]))
    q = np.einsum("kb,kb->k", y, np.linalg.solve(S, y[..., None])[..., 0])
    m = mask.sum(axis=1)
    logdet = np.linalg.slogdet(S)[1]
    return float(-0.5 * np.sum(q + logdet + m * np.log(2.0 * np.pi))), q / m


def _check_plausible(data: RangeDataset, nav: "NavigationModels", result: FilterResult, per_range: np.ndarray) -> None:
    """Warn when the log looks wrong for the model (navigate's Warns section)."""
    hints = ("check that headings are in radians, counter-clockwise from +x (RangeDataset's heading_unit and "
             "heading_convention), that the beacons are in the frame of the start pose, and that the ranges are "
             "in metres")
    if per_range.size >= 10 and np.median(per_range) > 20.0 * _CHI2_1_MEDIAN:
        warnings.warn(f"{data.name}: the ranges disagree with the odometry far beyond their noise (median "
                      f"normalized innovation {np.median(per_range):.3g}, about {_CHI2_1_MEDIAN:.2f} expected): "
                      + hints, UserWarning, stacklevel=3)
    scale_index = nav.motion.layout.scale
    if scale_index is not None and abs(result.x[-1, scale_index] - 1.0) > 0.3:
        warnings.warn(f"{data.name}: the range scale came out {result.x[-1, scale_index]:.3g}, far from 1: "
                      + hints, UserWarning, stacklevel=3)
    if "rejected" in result.extras:                                   # gate=False has no rejections to count
        epochs = int(np.isfinite(nav.z).any(axis=1).sum())
        rejected = int(np.count_nonzero(result.extras["rejected"]))
        if epochs >= 10 and rejected > LOST_TRACK_REJECTED * epochs:
            warnings.warn(f"{data.name}: the gate rejected the ranges of {rejected} of {epochs} ranging epochs "
                          f"({100.0 * rejected / epochs:.0f} %): the log has many outliers, or the filter has lost "
                          "the track between ranges too sparse for its model; compare the estimate with the odometry "
                          "alone (data.dead_reckoning()), and use more frequent ranges or more beacons",
                          UserWarning, stacklevel=3)


#: Fraction of the ranging epochs whose ranges the gate may reject before :func:`navigate` warns of a lost track.
LOST_TRACK_REJECTED = 0.2


_CHI2_1_MEDIAN = 0.454936


@dataclass(frozen=True)
class NavigationResult(FilterResult):
    """:func:`navigate`'s result: a :class:`~uwtutor.filters.base.FilterResult` and the model chosen from the log.

    Attributes
    ----------
    state_names : tuple of str
        The names of the state's components, e.g. ``('x', 'y', 'heading', 'scale')``.
    chosen : str
        The candidate returned (a key of ``CANDIDATES``).
    evidence : dict
        Every candidate run -> its log predictive likelihood of the log's ranges (navigate's Notes).
    candidates : dict
        Every candidate run -> its filter's :class:`~uwtutor.filters.base.FilterResult`.
    models : NavigationModels or None
        The chosen candidate's model pair and inputs (e.g. for :func:`uwtutor.filters.smoother.rts_smoother`).

    Examples
    --------
    >>> from uwtutor.datasets import navigate, square_log
    >>> # a 10 m square driven twice, ranging to two beacons; the ranges 5 % long
    >>> result = navigate(square_log(range_scale=1.05), range_sigma=0.1)
    >>> result.chosen, result.state_names
    ('+ scale', ('x', 'y', 'heading', 'scale'))
    >>> max(result.evidence, key=result.evidence.get)
    '+ scale'
    """

    state_names: tuple[str, ...] = ()
    chosen: str = ""
    evidence: dict[str, float] = field(default_factory=dict)
    candidates: dict[str, FilterResult] = field(default_factory=dict)
    models: "NavigationModels | None" = None


@dataclass(frozen=True)
class NavigationModels:
    """The model pair of :func:`navigate` for a log, with its start and the log's inputs and measurements.

    Attributes
    ----------
    motion : uwtutor.models.odometry.OdometryMotion
        The odometry with heading, gyro bias and range scale as :func:`navigate` sets it up.
    measurement : uwtutor.models.range.BeaconRanges
        The ranges to the chosen beacons.
    x0 : ndarray, shape (n,)
        The start state (the log's start pose; gyro bias 0, scale 1).
    P0 : ndarray, shape (n, n)
        Its covariance.
    u : ndarray, shape (K, 2)
        The odometry, the filters' input.
    z : ndarray, shape (K, B)
        The ranges on the epochs, NaN where a beacon was not heard.
    times : ndarray, shape (K,)
        The epochs [s].

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.datasets import square_log
    >>> # a 10 m square driven twice, ranging to two beacons in turn
    >>> data = square_log()
    >>> from uwtutor.datasets import navigation_models
    >>> nav = navigation_models(data, [3], gyro_bias=True, scale=True)
    >>> # the state [x, y, heading, gyro bias, scale]; one range column (beacon 3)
    >>> type(nav.motion).__name__, nav.x0.shape, nav.P0.shape, nav.z.shape
    ('OdometryMotion', (5,), (5, 5), (81, 1))
    """

    motion: OdometryMotion
    measurement: BeaconRanges
    x0: np.ndarray
    P0: np.ndarray
    u: np.ndarray
    z: np.ndarray
    times: np.ndarray


def navigation_models(data: RangeDataset, beacon_ids: BeaconIds = None, *, min_period: float | None = None,
                      offset: float = 0.0, thinning: str = "per beacon", gyro_bias: bool = True,
                      scale: bool = True, range_sigma: float = 0.6, distance_sigma: tuple[float, float] = (0.01, 0.02),
                      heading_noise: float = 1e-3, gyro_bias_prior: float = 0.01, gyro_bias_walk: float = 1e-4,
                      scale_prior: float = 0.1, scale_walk: float = 1e-5) -> NavigationModels:
    r"""The motion/measurement model pair of :func:`navigate` for a log, and what a filter runs it on.

    The same models, noise and start as :func:`navigate` (its parameters, with the same meaning and defaults),
    for any filter of the library: the EKF engine, the smoother, the posterior Cramér-Rao bound
    (:func:`uwtutor.observability.model_posterior_crlb`) or a particle filter.

    Returns
    -------
    NavigationModels

    Examples
    --------
    A straight 50 m drive with a beacon ahead, in the particle filter:

    >>> import numpy as np
    >>> from uwtutor.datasets import RangeDataset, navigation_models
    >>> from uwtutor.filters import BootstrapParticleFilter
    >>> K = 101
    >>> odometry = np.column_stack([np.r_[0.0, np.full(K - 1, 0.5)], np.zeros(K)])
    >>> truth = np.column_stack([0.5 * np.arange(K), np.zeros(K), np.zeros(K)])
    >>> heard = np.arange(1, K, 2)
    >>> ranges = np.column_stack(
    ...     [
    ...         heard * 0.5,
    ...         np.full(heard.size, 3),
    ...         1.02 * np.linalg.norm(truth[heard, :2] - [60.0, 10.0], axis=1),
    ...     ]
    ... )
    >>> data = RangeDataset(
    ...     times=0.5 * np.arange(K),
    ...     odometry=odometry,
    ...     ranges=ranges,
    ...     beacons={3: (60.0, 10.0)},
    ...     truth=truth,
    ... )
    >>> nav = navigation_models(data, range_sigma=0.3)
    >>> nav.motion.layout.names, nav.z.shape
    (('x', 'y', 'heading', 'gyro_bias', 'scale'), (101, 1))
    >>> pf = BootstrapParticleFilter.from_gaussian(
    ...     nav.motion,
    ...     nav.measurement,
    ...     nav.x0,
    ...     nav.P0,
    ...     2000,
    ...     np.random.default_rng(0),
    ...     ess_threshold=0.5,
    ... )
    >>> result = pf.run(nav.z, nav.u, times=nav.times)
    >>> bool(np.linalg.norm(result.x[-1, :2] - truth[-1, :2]) < 1.0)
    True
    """
    if not isinstance(data, RangeDataset):
        raise TypeError(f"data must be a uwtutor.datasets.RangeDataset; got {type(data).__name__}")
    if data.start is None:
        raise ValueError("data has no start pose: build the RangeDataset with start=(x, y, heading) (and "
                         "start_cov), or with truth, whose first row is the default start")
    gyro_bias, scale = as_flag("gyro_bias", gyro_bias), as_flag("scale", scale)
    ids = list(data.beacons) if beacon_ids is None else beacon_ids
    z = data.ranges_on_epochs(ids, min_period=min_period, offset=offset, thinning=thinning)
    beacons = data.beacon_positions(ids)
    sigma_r = _positive("range_sigma", range_sigma)
    # standard deviations: their squares stay within the covariances' bound, 1e150
    a, c = (float(v) for v in as_nonnegative("distance_sigma", distance_sigma, shape=(2,), max_abs=1e75))
    q_heading = _positive("heading_noise", heading_noise)
    if a <= 0.0:
        raise ValueError(f"distance_sigma[0] must be > 0 (a step's distance is never exact); got {a}")

    dt = np.diff(data.times, prepend=data.times[0])
    distance = np.abs(data.odometry[:, 0])
    # a step of zero length (the first) still gets a tiny heading noise, so that Q is never singular
    sigma_heading = q_heading * np.sqrt(dt) + 1e-9
    motion = OdometryMotion(a + c * distance, sigma_heading, gyro_bias=gyro_bias, scale=scale, times=data.times,
                            order="move-first",
                            gyro_bias_walk=_positive("gyro_bias_walk", gyro_bias_walk) if gyro_bias else 0.0,
                            scale_walk=_positive("scale_walk", scale_walk) if scale else 0.0)
    measurement = BeaconRanges(beacons, R=sigma_r**2, layout=motion.layout)
    extra = {}
    if gyro_bias:
        extra["gyro_bias"] = (0.0, _positive("gyro_bias_prior", gyro_bias_prior))
    if scale:
        extra["scale"] = (1.0, _positive("scale_prior", scale_prior))
    x0, P0 = motion.layout.initial_state(as_finite("data.start", data.start, shape=(3,)), data.start_cov, **extra)
    return NavigationModels(motion=motion, measurement=measurement, x0=x0, P0=P0, u=data.odometry, z=z,
                            times=data.times)
