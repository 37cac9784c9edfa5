"""The robustness specifications of the core share (issue 26): methods, lsq, observability, metrics, reporting,
plotting, _linalg, grey, wavelet, acoustics, resampling, owtt and motion.

Merged into ``robustness_spec.SPECS`` / ``EXEMPT`` by the two lines at the end of ``robustness_spec.py``.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any

import numpy as np

from robustness_kinds import Choice, Flag, Hostile, Instance, Int, Kind, Real, Rng, Seed
from robustness_spec import _BEACONS, _RANGES, _TRACK, Spec, _models


@dataclass(frozen=True)
class OptionalInt(Int):
    """An integer whose documented default is ``None`` (``n_runs=None``: no runs axis)."""

    def hostile(self, valid: Any):
        return [h for h in super().hostile(valid) if h.value is not None]


_N_RUNS = OptionalInt(minimum=1, unbounded_work=True)


@dataclass(frozen=True)
class Names(Kind):
    """An optional list of registry names (methods, scenarios, conditions): a bare string, an unknown name, an empty
    list and things that are not lists of strings are refused."""

    def hostile(self, valid: Any):
        return [Hostile("bare string", valid[0], True), Hostile("unknown name", ["no-such-name"], True),
                Hostile("int", 1, True), Hostile("list with an int", [1], True), Hostile("empty list", [], True),
                Hostile("list with None", [None], True)]


# --- helpers ----------------------------------------------------------------------------------------------------------
def _on_axes(fn, *, log: bool = False):
    """Call a figure helper on fresh Agg axes (closed afterwards): the axes are the helper's, the data the user's."""
    def call(**kw):
        import matplotlib
        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots()
        try:
            if log:
                ax.semilogy([1.0, 2.0, 3.0], [3.0, 30.0, 300.0])
            return fn(ax, **kw)
        finally:
            plt.close(fig)
    return call


def _plotting(name: str):
    import uwtutor.plotting as p
    return getattr(p, name)


@functools.lru_cache(maxsize=1)
def _tiny_animation():
    import matplotlib
    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    from matplotlib.animation import FuncAnimation
    fig, ax = plt.subplots(figsize=(1.0, 1.0), dpi=20)
    (line,) = ax.plot([0.0, 1.0], [0.0, 1.0])
    anim = FuncAnimation(fig, lambda i: (line.set_ydata([0.0, float(i)]),), frames=2, blit=False)
    plt.close(fig)
    return anim


def _tiny_png():
    import io
    fig = _tiny_animation()._fig
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png")
    return buffer.getvalue()


_WEIGHTS = np.array([0.1, 0.0, 0.5, 0.4])
_SIGNAL = np.sin(np.arange(40) / 5.0) + 0.01 * np.cos(np.arange(40) * 7.0)
_SERIES = np.array([10.0, 11.0, 12.5, 13.0, 14.2, 15.1])
_FOLLOWER = np.array([1500.0, 0.0])
_W = dict(weights=Real((None,), "nonneg"))


def _nan_means_lost(value: Any, baseline: Any) -> list[str]:
    """resolve_travel_time: a NaN input (a lost message) gives NaN, as documented; an infinity never."""
    return ["an infinite travel time"] if np.isinf(value).any() else []


# a vehicle that drives east then turns north, 8 epochs, beacon at the origin (paper D's pre-location, paper A's
# pre-positioning, paper E's virtual baseline on the same small geometry)
_LEG = np.array([[400.0 + 50.0 * k, -300.0] for k in range(5)] + [[600.0, -300.0 + 50.0 * k] for k in range(1, 4)])
_DR = np.vstack([np.zeros(2), np.diff(_LEG, axis=0)])
_TAU = np.linalg.norm(_LEG, axis=1) / 1500.0
_SHIP = np.array([[0.0, 0.0], [400.0, 100.0], [700.0, 400.0], [800.0, 800.0]])
_SUB = np.array([[-900.0, -1100.0], [-850.0, -1050.0], [-800.0, -1000.0], [-750.0, -950.0]])
_SLANT = np.sqrt(np.sum((_SHIP - _SUB) ** 2, axis=1) + 1000.0**2)
_PHI = np.radians([0.0, 90.0, 180.0, 270.0])
_DESIGN = np.column_stack([np.cos(_PHI), np.sin(_PHI), np.ones(4)])


@functools.lru_cache(maxsize=2)
def _suite_inputs(scenario: str = "circle"):
    """One run of a suite scenario under white noise: what every method of the registry takes."""
    from uwtutor.scenarios import suite
    rng = np.random.default_rng(0)
    return suite.CONDITIONS["white"](rng, suite.SCENARIOS[scenario](rng, 1))[0]


def _method(name: str, scenario: str = "circle") -> Spec:
    return Spec(lambda: dict(inputs=_suite_inputs(scenario)), kinds=dict(inputs=Instance()))


def _track():
    from uwtutor.motion import straight_track
    return straight_track(np.arange(6.0), (0.0, 0.0), 2.0, 0.3)


SPECS_CORE: dict[str, Spec] = {
    # resampling
    "uwtutor.resampling:multinomial_resample": Spec(lambda: dict(weights=_WEIGHTS, rng=np.random.default_rng(0)),
                                                    kinds=_W),
    "uwtutor.resampling:stratified_resample": Spec(lambda: dict(weights=_WEIGHTS, rng=np.random.default_rng(0)),
                                                   kinds=_W),
    "uwtutor.resampling:systematic_resample": Spec(lambda: dict(weights=_WEIGHTS, rng=np.random.default_rng(0)),
                                                   kinds=_W),
    "uwtutor.resampling:residual_resample": Spec(lambda: dict(weights=_WEIGHTS, rng=np.random.default_rng(0)),
                                                 kinds=_W),
    "uwtutor.resampling:effective_sample_size": Spec(lambda: dict(weights=_WEIGHTS), kinds=_W),
    # wavelet (paper C's noise estimate)
    "uwtutor.wavelet:as_wavelet": Spec(lambda: dict(wavelet="db2"), kinds=dict(wavelet=Choice())),
    "uwtutor.wavelet:mad_sigma": Spec(lambda: dict(coefficients=np.array([0.5, -1.0, 0.2, 2.0, -0.7]), axis=-1),
                                      kinds=dict(coefficients=Real((None,), extra_axis_ok=True), axis=Int())),
    "uwtutor.wavelet:detail_matrix": Spec(lambda: dict(n_samples=8, wavelet="db2"),
                                          kinds=dict(n_samples=Int(minimum=4, unbounded_work=True),
                                                     wavelet=Choice())),
    "uwtutor.wavelet:detail_coefficients": Spec(lambda: dict(signal=_SIGNAL, wavelet="db2", mode="valid"),
                                                kinds=dict(signal=Real((None,)), wavelet=Choice(), mode=Choice())),
    "uwtutor.wavelet:noise_sigma": Spec(lambda: dict(signal=_SIGNAL, wavelet="db2", mode="valid"),
                                        kinds=dict(signal=Real((None,)), wavelet=Choice(), mode=Choice())),
    "uwtutor.wavelet:sliding_noise_sigma": Spec(
        lambda: dict(signal=_SIGNAL, window=10, wavelet="db2", mode="valid"),
        # a window longer than the signal is allowed (every entry NaN, as documented): the work is that of the signal
        kinds=dict(signal=Real((None,), nan_ok=True, extra_axis_ok=True), window=Int(minimum=4), wavelet=Choice(),
                   mode=Choice())),
    # one-way travel time ranging
    "uwtutor.owtt:clock_error": Spec(lambda: dict(times=2.0, offset=1e-3, drift=1e-6),
                                     kinds=dict(times=Real((), vector_ok=True), offset=Real(()), drift=Real(()))),
    "uwtutor.owtt:clock_range_error": Spec(lambda: dict(times=2.0, offset=1e-3, drift=1e-6, sound_speed=1500.0),
                                           kinds=dict(times=Real((), vector_ok=True), offset=Real(()),
                                                      drift=Real(()))),
    "uwtutor.owtt:ambiguity_range": Spec(lambda: dict(sound_speed=1500.0, period=1.0),
                                         kinds=dict(period=Real((), "pos"))),
    "uwtutor.owtt:wrap_travel_time": Spec(lambda: dict(travel_times=1.25, period=1.0),
                                          kinds=dict(travel_times=Real((), "nonneg", vector_ok=True),
                                                     period=Real((), "pos"))),
    "uwtutor.owtt:resolve_travel_time": Spec(
        lambda: dict(wrapped=np.array([0.25, 0.5]), predicted_range=np.array([2700.0, 800.0]), sound_speed=1500.0,
                     period=1.0),
        kinds=dict(wrapped=Real((2,), "nonneg", nan_ok=True), predicted_range=Real((2,), "nonneg", nan_ok=True),
                   period=Real((), "pos")),
        check=_nan_means_lost),
    "uwtutor.owtt:simulate_owtt": Spec(
        lambda: dict(send_times=np.arange(3.0), leader_position_at=(0.0, 0.0), follower_position_at=_FOLLOWER,
                     sound_speed=1500.0, assumed_sound_speed=1480.0, clock_offset=1e-3, clock_drift=1e-6,
                     period=1.0),
        kinds=dict(send_times=Real((None,)), leader_position_at=Real((2,)), follower_position_at=Real((2,)),
                   assumed_sound_speed=Real((), "pos", optional=True), clock_offset=Real(()), clock_drift=Real(()),
                   period=Real((), "pos", optional=True))),
    # numbers for the text
    "uwtutor.reporting:as_shown": Spec(lambda: dict(value=184.2023, fmt=".1f"),
                                       kinds=dict(value=Real((), inf_ok=True, nan_ok=True), fmt=Choice()),
                                       # NaN and infinities are returned unchanged (documented): only they may be
                                       check=lambda v, b: [] if isinstance(v, float) else ["not a float"]),
    "uwtutor.reporting:below_or_value": Spec(lambda: dict(value=7.08e-13, bound=1e-9, fmt=".3g"),
                                             kinds=dict(value=Real((), inf_ok=True, nan_ok=True),
                                                        bound=Real((), "pos"), fmt=Choice())),
    # acoustics
    "uwtutor.acoustics:effective_sound_speed": Spec(
        lambda: dict(profile_depths=np.array([0.0, 500.0, 1000.0]), profile_speeds=np.array([1500.0, 1490.0, 1520.0]),
                     source_depth=10.0, receiver_depth=900.0),
        kinds=dict(profile_depths=Real((3,)), profile_speeds=Real((3,), "pos"), source_depth=Real((), vector_ok=True),
                   receiver_depth=Real((), vector_ok=True))),
    "uwtutor.acoustics:sound_speed_error_range_bias": Spec(
        lambda: dict(true_range=1000.0, assumed_speed=1470.0, true_speed=1500.0),
        kinds=dict(true_range=Real((), "nonneg", vector_ok=True), assumed_speed=Real((), "pos", vector_ok=True),
                   true_speed=Real((), "pos", vector_ok=True))),
    # metrics
    "uwtutor.metrics:positive_definite": Spec(
        lambda: dict(covariances=np.array([np.eye(2), [[1.0, 2.0], [2.0, 1.0]]])),
        kinds=dict(covariances=Real((None, 2, 2), nan_ok=True, inf_ok=True))),
    # figure helpers that draw the user's data on the user's axes (here fresh Agg axes)
    "uwtutor.plotting:mark_beacon": Spec(lambda: dict(position=(0.0, 0.0), label="beacon"),
                                         call=_on_axes(_plotting("mark_beacon")),
                                         kinds=dict(position=Real((2,)))),
    "uwtutor.plotting:plot_track": Spec(lambda: dict(positions=_TRACK, label="track"),
                                        call=_on_axes(_plotting("plot_track")),
                                        kinds=dict(positions=Real((None, 2), nan_ok=True))),
    "uwtutor.plotting:plain_log_ticks": Spec(lambda: dict(axis="y"), call=_on_axes(_plotting("plain_log_ticks"),
                                                                                   log=True),
                                             kinds=dict(axis=Choice())),
    "uwtutor.plotting:legend_overlaps": Spec(lambda: dict(fig=_tiny_animation()._fig),
                                             kinds=dict(fig=Instance()), check=lambda v, b: []),
    "uwtutor.plotting:palette_png": Spec(lambda: dict(png=_tiny_png(), colors=256, max_error=24),
                                         kinds=dict(png=Instance(), colors=Int(minimum=2, maximum=256),
                                                    max_error=Int(minimum=0, maximum=255)),
                                         check=lambda v, b: []),
    "uwtutor.plotting:animation_html": Spec(lambda: dict(animation=_tiny_animation(), default_mode="once"),
                                            kinds=dict(animation=Instance(), default_mode=Choice()),
                                            check=lambda v, b: []),
    # grey models (paper C)
    "uwtutor.grey:level_ratio_test": Spec(lambda: dict(series=_SERIES), kinds=dict(series=Real((None,), "pos"))),
    "uwtutor.grey:fit_gm11": Spec(lambda: dict(series=_SERIES, background_weight=0.5),
                                  kinds=dict(series=Real((None,), "pos"), background_weight=Real((), "prob"))),
    "uwtutor.grey:gm11_coefficients": Spec(lambda: dict(series=_SERIES, background_weight=0.5),
                                           kinds=dict(series=Real((None,), "pos", extra_axis_ok=False),
                                                      background_weight=Real((), "prob"))),
    "uwtutor.grey:gm11_forecast": Spec(lambda: dict(series=_SERIES, steps=2, background_weight=0.5),
                                       kinds=dict(series=Real((None,), "pos"),
                                                  steps=Int(minimum=1, unbounded_work=True),
                                                  background_weight=Real((), "prob"))),
    "uwtutor.grey:rolling_gm11_forecast": Spec(
        lambda: dict(series=np.r_[_SERIES, _SERIES + 5.0], window=4, offset=0.0, background_weight=0.5),
        kinds=dict(series=Real((None,), extra_axis_ok=True), window=Int(minimum=4), offset=Real(()),
                   background_weight=Real((), "prob"))),
    # tracks and dead reckoning
    "uwtutor.motion:Track": Spec(lambda: dict(times=np.arange(6.0), positions=_TRACK, velocities=np.diff(_TRACK, axis=0,
                                                                                                      prepend=0.0)),
                                 kinds=dict(times=Real((6,)), positions=Real((6, 2)), velocities=Real((6, 2)))),
    "uwtutor.motion:turning_track": Spec(
        lambda: dict(times=np.arange(6.0), start=(0.0, 0.0), speed=2.0, headings=[0.0, 1.0], turn_times=[2.5]),
        kinds=dict(start=Real((2,)), speed=Real((), "nonneg"), headings=Real((2,)), turn_times=Real((1,)))),
    "uwtutor.motion:s_turn_track": Spec(
        lambda: dict(times=np.arange(6.0), start=(0.0, 0.0), speed=2.0, heading=0.3, turn_rate=0.1, half_period=2.0),
        kinds=dict(start=Real((2,)), speed=Real((), "nonneg"), heading=Real(()), turn_rate=Real(()),
                   half_period=Real((), "pos"))),
    "uwtutor.motion:lawnmower_track": Spec(
        lambda: dict(times=np.arange(6.0), start=(0.0, 0.0), speed=2.0, leg_length=4.0, spacing=3.0, heading=0.2),
        kinds=dict(start=Real((2,)), speed=Real((), "nonneg"), leg_length=Real((), "pos"), spacing=Real(()),
                   heading=Real(()))),
    "uwtutor.motion:with_current": Spec(lambda: dict(track=_track(), current=(0.1, -0.2)),
                                        kinds=dict(track=Instance(), current=Real((2,)))),
    "uwtutor.motion:dead_reckoning": Spec(
        lambda: dict(track=_track(), rng=np.random.default_rng(0), speed_sigma=0.05, heading_sigma=0.01,
                     heading_bias=0.02, speed_scale=1.01, n_runs=2),
        kinds=dict(track=Instance(), speed_sigma=Real((), "nonneg"), heading_sigma=Real((), "nonneg"),
                   heading_bias=Real(()), speed_scale=Real((), "pos"), n_runs=_N_RUNS)),
    "uwtutor.motion:displacement_noise": Spec(
        lambda: dict(displacements=np.diff(_TRACK, axis=0), rng=np.random.default_rng(0), sigma=0.1, n_runs=2),
        kinds=dict(displacements=Real((None, 2)), sigma=Real((), "nonneg"), n_runs=_N_RUNS)),
    "uwtutor.motion:integrate_odometry": Spec(
        lambda: dict(start=[0.0, 0.0, 0.1], odometry=[[0.0, 0.0], [1.0, 0.1], [1.0, -0.2]]),
        kinds=dict(start=Real((3,)), odometry=Real((None, 2)))),
    # observability and bounds
    "uwtutor.observability.jacobians:squared_range_jacobian": Spec(
        lambda: dict(position=[30.0, -40.0], beacons=_BEACONS)),
    "uwtutor.observability.jacobians:beacons_at_bearings": Spec(
        lambda: dict(position=[30.0, -40.0], bearings=[0.0, 1.0, 2.5], distances=1000.0),
        kinds=dict(bearings=Real((None,)), distances=Real((), "pos", vector_ok=True))),
    "uwtutor.observability.jacobians:virtual_beacons": Spec(
        lambda: dict(beacon=(0.0, 0.0), positions=_TRACK, reference=-1), kinds=dict(reference=Int())),
    "uwtutor.observability.bounds:precision_factor": Spec(lambda: dict(beacons=_BEACONS, position=[30.0, -40.0],
                                                                unknown_bias=True),
                                                   kinds=dict(unknown_bias=Flag())),
    "uwtutor.observability.jacobians:track_jacobian": Spec(
        lambda: dict(positions=_TRACK, beacon=(0.0, 0.0), times=np.arange(6.0), unknown_bias=True,
                     unknown_current=True, reference=-1),
        kinds=dict(positions=Real((6, 2)), times=Real((6,), optional=True), unknown_bias=Flag(), unknown_current=Flag(),
                   reference=Int())),
    "uwtutor.observability.information:track_fisher_information": Spec(
        lambda: dict(positions=_TRACK, beacon=(0.0, 0.0), sigma=1.0, times=np.arange(6.0), unknown_bias=True,
                     unknown_current=False, cumulative=True),
        kinds=dict(positions=Real((6, 2)), times=Real((6,), optional=True), sigma=Real((), "pos", vector_ok=True),
                   unknown_bias=Flag(), unknown_current=Flag(), cumulative=Flag())),
    "uwtutor.observability.bounds:track_crlb": Spec(
        lambda: dict(positions=_TRACK, beacon=(0.0, 0.0), sigma=1.0, times=np.arange(6.0), unknown_bias=False,
                     unknown_current=False, rtol=1e-6),
        kinds=dict(positions=Real((6, 2)), times=Real((6,), optional=True), sigma=Real((), "pos", vector_ok=True),
                   unknown_bias=Flag(), unknown_current=Flag(), rtol=Real((), "open01"))),
    "uwtutor.observability.information:observability_rank": Spec(
        lambda: dict(positions=_TRACK, beacon=(0.0, 0.0), times=np.arange(6.0), unknown_bias=True,
                     unknown_current=False, cumulative=True, rtol=1e-6),
        kinds=dict(positions=Real((6, 2)), times=Real((6,), optional=True), unknown_bias=Flag(), unknown_current=Flag(),
                   cumulative=Flag(), rtol=Real((), "open01"))),
    "uwtutor.observability.information:numerical_rank": Spec(
        lambda: dict(matrix=[[1.0, 2.0], [2.0, 4.0], [0.0, 1.0]], rtol=1e-6),
        kinds=dict(matrix=Real((None, 2), extra_axis_ok=True), rtol=Real((), "open01"))),
    "uwtutor.observability.geometry:two_range_fix": Spec(
        lambda: dict(beacon=(0.0, 0.0), ranges=[100.0, 104.0], displacement=[10.0, 0.0]),
        kinds=dict(ranges=Real((2,), "nonneg"), displacement=Real((2,)))),
    "uwtutor.observability.geometry:mirror_point": Spec(
        lambda: dict(point=[30.0, -40.0], beacon=(0.0, 0.0), direction=[1.0, 0.5]),
        kinds=dict(point=Real((2,)), direction=Real((2,)))),
    "uwtutor.observability.posterior:model_posterior_crlb": Spec(
        lambda: dict(motion=_models()[0], measurement=_models()[1], x0=_TRACK[0], P0=np.eye(2) * 100.0,
                     truth=_TRACK[1:], u=np.diff(_TRACK, axis=0), measured=np.ones(5, dtype=bool), full=True),
        kinds=dict(motion=Instance(), measurement=Instance(), x0=Real((2,)), truth=Real((5, 2)),
                   u=Real((5, 2), optional=True),
                   measured=Kind(), full=Flag(), mean_over_runs=Flag())),
    # least squares
    "uwtutor.lsq:precision_factor": Spec(lambda: dict(A=_DESIGN), kinds=dict(A=Real((None, 3), extra_axis_ok=True))),
    "uwtutor.lsq:condition_number": Spec(lambda: dict(A=_DESIGN), kinds=dict(A=Real((None, 3), extra_axis_ok=True))),
    "uwtutor.lsq:precision_factor_history": Spec(lambda: dict(positions=_LEG, beacon=(0.0, 0.0), unknown_bias=True),
                                                 kinds=dict(positions=Real((None, 2)), unknown_bias=Flag())),
    "uwtutor.lsq:grid_prelocation": Spec(
        lambda: dict(travel_times=_TAU, dr_displacements=_DR, bearing_grid=np.linspace(-np.pi, np.pi, 12,
                                                                                        endpoint=False),
                     speed_error_grid=[-20.0, 0.0, 20.0], assumed_speed=1470.0, beacon=(0.0, 0.0)),
        kinds=dict(travel_times=Real((8,), "nonneg"), dr_displacements=Real((8, 2)),
                   bearing_grid=Real((None,), optional=True),
                   speed_error_grid=Real((None,), optional=True), assumed_speed=Real((), "pos"), beacon=Real((2,)))),
    "uwtutor.lsq:prelocation_cost": Spec(
        lambda: dict(ranges=_TAU * 1470.0, dr_displacements=_DR, bearing_grid=np.linspace(-np.pi, np.pi, 12,
                                                                                           endpoint=False),
                     speed_error_grid=[-20.0, 0.0, 20.0], assumed_speed=1470.0, beacon=(0.0, 0.0)),
        kinds=dict(ranges=Real((8,), "nonneg"), dr_displacements=Real((8, 2)),
                   bearing_grid=Real((None,), optional=True),
                   speed_error_grid=Real((None,), optional=True), assumed_speed=Real((), "pos"), beacon=Real((2,)))),
    "uwtutor.lsq:prelocation_acceptance": Spec(
        lambda: dict(starts=np.tile([400.0, -300.0], (8, 1)) + 1.0, dr_displacements=_DR, min_heading_change=0.17,
                     n_consecutive=2, max_shift=50.0, heading_window=2),
        kinds=dict(starts=Real((8, 2)), dr_displacements=Real((8, 2)), min_heading_change=Real((), "pos"),
                   n_consecutive=Int(minimum=1), max_shift=Real((), "pos"), heading_window=Int(minimum=1))),
    "uwtutor.lsq:nonlinear_lsq": Spec(
        lambda: dict(ranges=_RANGES, beacons=_BEACONS, initial=[0.0, 0.0, 0.0], unknown_bias=True, sigma=1.0,
                     max_condition=1e3, max_noise_gain=100.0),
        kinds=dict(ranges=Real((4,), "nonneg"), initial=Real((3,)), unknown_bias=Flag(),
                   sigma=Real((), "pos", optional=True, vector_ok=True), max_condition=Real((), "pos"),
                   max_noise_gain=Real((), "pos"))),
    "uwtutor.lsq:prepositioning": Spec(
        lambda: dict(ranges=np.linalg.norm(_LEG, axis=1) + 2.0, dr_positions=np.cumsum(_DR, axis=0),
                     provisional=[610.0, -160.0], beacon=(0.0, 0.0), unknown_bias=True, iterations=2, sigma=1.0,
                     max_condition=1e3, max_noise_gain=100.0),
        kinds=dict(ranges=Real((8,), "nonneg"), dr_positions=Real((8, 2)), provisional=Real((2,)),
                   beacon=Real((2,)), unknown_bias=Flag(), iterations=Int(minimum=1),
                   sigma=Real((), "pos", optional=True, vector_ok=True), max_condition=Real((), "pos"),
                   max_noise_gain=Real((), "pos"))),
    "uwtutor.lsq:virtual_beacon_lsq": Spec(
        lambda: dict(ranges=_SLANT, beacon_positions=_SHIP, dr_positions=_SUB, depth=1000.0, beacon_depths=0.0,
                     max_condition=1e3, max_noise_gain=100.0),
        kinds=dict(ranges=Real((4,), "nonneg"), beacon_positions=Real((4, 2)), dr_positions=Real((4, 2)),
                   depth=Real(()), beacon_depths=Real((), vector_ok=True), max_condition=Real((), "pos"),
                   max_noise_gain=Real((), "pos"))),
    # the registry of methods (chapter 10): each method on one run of a suite scenario
    **{f"uwtutor.methods:{fn}": _method(fn) for fn in (
        "ls_prepositioning", "grid_prelocation", "prelocate", "ekf", "iekf", "prepositioned_iekf", "sfekf", "isfekf",
        "ls_isfekf", "or_vmlbl", "particle_filter")},
    "uwtutor.methods:cooperative": _method("cooperative", "moving beacon"),
    "uwtutor.methods:get": Spec(lambda: dict(name="EKF"), kinds=dict(name=Choice())),
    "uwtutor.methods:run": Spec(
        lambda: dict(name="EKF", scenario="circle", condition="white", rng=np.random.default_rng(0), n_runs=1),
        kinds=dict(name=Choice(), scenario=Choice(), condition=Choice(), rng=Rng(),
                   n_runs=Int(minimum=1, unbounded_work=True))),
    "uwtutor.methods:suite_bounds": Spec(lambda: dict(scenarios=["circle"], conditions=["white"]),
                                         kinds=dict(scenarios=Names(), conditions=Names())),
    "uwtutor.methods:compare_suite": Spec(
        lambda: dict(n_runs=2, seed=1, methods=["EKF"], scenarios=["circle"], conditions=["white"], chunk_size=1000,
                     measure_cost=False, timing_runs=2),
        kinds=dict(n_runs=Int(minimum=1, unbounded_work=True), seed=Seed(), methods=Names(), scenarios=Names(),
                   conditions=Names(), chunk_size=Int(minimum=1), measure_cost=Flag(), timing_runs=Int(minimum=1)),
        check=lambda v, b: [], per_argument=4),
}

EXEMPT_CORE: dict[str, str] = {
    "uwtutor.owtt:OWTTMeasurements": "a result container simulate_owtt builds (specified)",
    "uwtutor.methods:Method": "a registry entry (REGISTRY) the library builds; calling it calls its method, "
                              "specified with the methods",
    "uwtutor.methods:names": "no arguments: the registered method names",
    "uwtutor.datasets.navigation:navigation_gate": "no arguments: a new gate of navigate's settings",
    "uwtutor.methods:claims": "no arguments: the scenarios each registered method runs on",
    "uwtutor.methods:load_comparison": "no arguments: reads the committed comparison of chapter 10",
    "uwtutor.lsq:LSQFix": "a result container linearized_lsq, nonlinear_lsq and prepositioning build (specified)",
    "uwtutor.lsq:Prelocation": "a result container grid_prelocation builds (specified)",
    "uwtutor.lsq:PrelocationAcceptance": "a result container prelocation_acceptance builds (specified)",
    "uwtutor.lsq:VirtualBeaconFix": "a result container virtual_beacon_lsq builds (specified)",
    "uwtutor.motion:DeadReckoningResult": "a result container dead_reckoning builds (specified)",
    "uwtutor.grey:GM11": "a result container fit_gm11 builds (specified)",
    "uwtutor.grey:LevelRatioTest": "a result container level_ratio_test builds (specified)",
    "uwtutor._linalg:positive_definite": "the unchecked kernel of uwtutor.metrics:positive_definite (specified), on "
                                         "the scores' and gates' per-step path: their inputs are checked once",
    "uwtutor._linalg:quadratic_form": "the unchecked kernel of the NEES, NIS and gates (metrics.nees, metrics.nis, "
                                      "filters.gates: specified), called with their checked arrays",
    "uwtutor._linalg:psd_violations": "the filter engine's per-step check of its own covariances (runs-last arrays "
                                      "the engine builds), never called with user data",
    "uwtutor._linalg:distances": "the unchecked kernel of the ranges the models' h, the scenarios and the datasets "
                                 "compute, called with the positions they built or checked",
    "uwtutor._cancel:checkpoint": "no arguments: the filter loops' test for a cancellation asked in this thread",
    "uwtutor._cancel:cancel_when": "takes one callable, refused with a TypeError naming it otherwise "
                                   "(tests/test_cancel.py); its one caller is the widget panel's refinement thread",
    "uwtutor.plotting:use_book_style": "no arguments: applies the book's matplotlib rcParams",
    "uwtutor.plotting:check_legends_on_display": "no arguments: wraps IPython's figure formatter, if there is one",
    "uwtutor.plotting:use_sharp_figures": "no arguments: sets IPython's figure format, if there is one",
}
