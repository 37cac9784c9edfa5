"""The robustness contract's specifications of the simulation modules: ``uwtutor.ranging`` and ``uwtutor.scenarios``
(with its papers' modules and the suite of chapter 10).

Merged into ``SPECS`` / ``EXEMPT`` at the end of ``robustness_spec.py``. Every valid call is small (a few epochs,
one or two runs) so that the hostile calls take milliseconds.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from robustness_kinds import Choice, Flag, Func, Hostile, Instance, Int, Kind, Real
from robustness_spec import Spec

_T = np.arange(6.0) * 10.0                       # six epochs, 10 s apart
_R = np.array([1000.0, 1010.0, 1025.0, 1030.0, 1050.0, 1049.0])


def _rng():
    return np.random.default_rng(7)


@dataclass(frozen=True)
class _OptionalInt(Int):
    """An integer whose default ``None`` is a documented value (``n_runs=None``: no runs axis)."""

    def hostile(self, valid):
        return [h for h in super().hostile(valid) if h.value is not None]


@dataclass(frozen=True)
class _Text(Kind):
    """A free text (a description): anything but a string is refused."""

    def hostile(self, valid):
        return [Hostile("int", 1, True), Hostile("None", None, True), Hostile("bytes", b"abc", True)]


_N_RUNS_OPT = _OptionalInt(minimum=1, unbounded_work=True)
_N_RUNS = Int(minimum=1, unbounded_work=True)
_OPT = Instance(optional=True)


# --- ranging -------------------------------------------------------------------------------------------------------
def _sample(model_factory):
    """Build an error model from the keyword arguments and draw its errors for six epochs of three runs."""
    def call(**kw):
        return model_factory(**kw).sample(_R, _T, _rng(), n_runs=3)
    return call


def _gaussian(**kw):
    from uwtutor.ranging import GaussianNoise
    return GaussianNoise(**kw)


def _sample_base(**kw):
    """``RangeErrorModel.sample`` (the base class's validation of every model's draw), through GaussianNoise."""
    from uwtutor.ranging import GaussianNoise
    return GaussianNoise(1.0).sample(**kw)


def _composite(**kw):
    from uwtutor.ranging import RangeErrorSum
    return RangeErrorSum(**kw)


def _sound(**kw):
    from uwtutor.ranging import SoundSpeedMismatch
    return SoundSpeedMismatch(**kw)


def _slow(**kw):
    from uwtutor.ranging import SlowBias
    return SlowBias(**kw)


def _outliers(**kw):
    from uwtutor.ranging import Outliers
    return Outliers(**kw)


def _add_errors(true_ranges, errors):
    from uwtutor.ranging import add_range_errors
    return add_range_errors(true_ranges, errors)


def _parts():
    from uwtutor.ranging import GaussianNoise, SlowBias
    return (GaussianNoise(1.0), SlowBias(2.0, 1.0, 100.0))


_RANGES = Real((None,), "nonneg")
_TIMES = Real((None,))

SPECS_SCEN: dict[str, Spec] = {
    "uwtutor.ranging:RangeErrorModel": Spec(
        lambda: dict(true_ranges=_R, times=_T, rng=_rng(), n_runs=3), call=_sample_base,
        kinds=dict(true_ranges=_RANGES, times=_TIMES, n_runs=_N_RUNS_OPT)),
    "uwtutor.ranging:RangeErrorSum": Spec(lambda: dict(parts=_parts()), call=_sample(_composite),
                                           kinds=dict(parts=Instance())),
    "uwtutor.ranging:GaussianNoise": Spec(lambda: dict(sigma=0.7), call=_sample(_gaussian),
                                          kinds=dict(sigma=Real((), "nonneg"))),
    "uwtutor.ranging:SoundSpeedMismatch": Spec(
        lambda: dict(true_speed=1500.0, assumed_speed=1470.0, speed_sigma=1.0), call=_sample(_sound),
        kinds=dict(true_speed=Real((), "pos"), assumed_speed=Real((), "pos"), speed_sigma=Real((), "nonneg"))),
    "uwtutor.ranging:SlowBias": Spec(
        lambda: dict(mean=5.0, sigma=3.0, time_constant=600.0), call=_sample(_slow),
        kinds=dict(mean=Real(()), sigma=Real((), "nonneg"), time_constant=Real((), "pos"))),
    "uwtutor.ranging:Outliers": Spec(
        lambda: dict(onset_times=20.0, count=2, amplitude=80.0, two_sided=True, probability=0.1),
        call=_sample(_outliers),
        kinds=dict(onset_times=Real((), vector_ok=True), count=Int(minimum=1), amplitude=Real((), "nonneg"),
                   two_sided=Flag(), probability=Real((), "prob", optional=True))),
    "uwtutor.ranging:measure_ranges": Spec(
        lambda: dict(true_ranges=_R, times=_T, error=_parts()[0], rng=_rng(), n_runs=2, return_errors=True),
        kinds=dict(true_ranges=_RANGES, times=_TIMES, error=_OPT, n_runs=_N_RUNS_OPT, return_errors=Flag())),
    "uwtutor.ranging:add_range_errors": Spec(
        lambda: dict(true_ranges=_R[:3], errors=np.array([1.5, np.nan, -8.0])), call=_add_errors,
        kinds=dict(true_ranges=Real((3,), "nonneg"), errors=Real((3,), nan_ok=True))),
    "uwtutor.ranging:reception_times": Spec(
        lambda: dict(ping_times=np.arange(4.0) * 10.0, beacon_position_at=(0.0, 0.0),
                     vehicle_position_at=lambda t: np.stack([1500.0 + 2.0 * t, 0.0 * t], axis=-1),
                     sound_speed=1500.0, max_iter=50, tol=1e-9),
        kinds=dict(ping_times=_TIMES, beacon_position_at=Real((2,)), vehicle_position_at=Func(),
                   max_iter=Int(minimum=1), tol=Real((), "pos"))),
}

EXEMPT_SCEN: dict[str, str] = {}


def _add(key: str, spec: Spec) -> None:
    SPECS_SCEN[key] = spec


# --- scenarios (the package) ----------------------------------------------------------------------------------------
def _track():
    from uwtutor.motion import straight_track
    return straight_track(_T, (-500.0, 200.0), 2.0, 0.0)


@functools.lru_cache(maxsize=1)
def _small_scenario():
    from uwtutor.ranging import GaussianNoise
    from uwtutor.scenarios import make_scenario
    return make_scenario(_track(), (0.0, 0.0), GaussianNoise(1.0), np.random.default_rng(3), n_runs=2, dr_sigma=0.5)


def _scenario_fields():
    sc = _small_scenario()
    return dict(times=np.array(sc.times), true_positions=np.array(sc.true_positions),
                dr_displacements=np.array(sc.dr_displacements), beacon_positions=np.array(sc.beacon_positions),
                true_ranges=np.array(sc.true_ranges), ranges=np.array(sc.ranges),
                range_errors=np.array(sc.range_errors), description="a line", outlier_mask=np.zeros((2, 6), bool))


class _Mask(Kind):
    def hostile(self, valid):
        return [Hostile("floats", np.zeros(np.shape(valid)), True), Hostile("wrong shape", np.zeros((1, 6), bool),
                                                                               True),
                Hostile("string", "abc", True)]


_add("uwtutor.scenarios:Scenario", Spec(
    _scenario_fields,
    kinds=dict(times=_TIMES, true_positions=Real((2, 6, 2)), dr_displacements=Real((2, 6, 2)),
               beacon_positions=Real((2, 6, 2)), true_ranges=Real((2, 6), "nonneg"),
               ranges=Real((2, 6), nan_ok=True), range_errors=Real((2, 6)), description=_Text(),
               outlier_mask=_Mask())))
EXEMPT_SCEN["uwtutor.scenarios:ScenarioRun"] = ("a view of one run that Scenario.run builds from a checked Scenario "
                                               "(its index is checked by run)")
_add("uwtutor.scenarios:make_scenario", Spec(
    lambda: dict(track=_track(), beacon=(0.0, 0.0), error=_parts()[0], rng=_rng(), n_runs=2, dr_sigma=0.5,
                 description="a line"),
    kinds=dict(track=Instance(), beacon=Real((2,)), error=_OPT, n_runs=_N_RUNS, dr_sigma=Real((), "nonneg"),
               description=_Text())))
_add("uwtutor.scenarios:circling_scenario", Spec(
    lambda: dict(rng=_rng(), n_runs=2, radius=1500.0, speed=2.0, interval=5.0, duration=50.0, center=(0.0, 0.0),
                 noise_sigma=2.0, gamma=0.005, bias_mean=5.0, bias_sigma=3.0, bias_time_constant=600.0,
                 dr_sigma=0.5),
    kinds=dict(n_runs=_N_RUNS, interval=Real((), "pos"), duration=Real((), "pos"), center=Real((2,)),
               noise_sigma=Real((), "nonneg"), gamma=Real(()), bias_mean=Real(()), bias_sigma=Real((), "nonneg"),
               bias_time_constant=Real((), "pos"), dr_sigma=Real((), "nonneg"))))
_add("uwtutor.scenarios:approach_with_turn_scenario", Spec(
    lambda: dict(rng=_rng(), n_runs=2, start=(-3000.0, -1500.0), speed=2.0, headings=(0.26, 1.05), turn_time=30.0,
                 ping_interval=10.0, duration=60.0, true_speed=1500.0, assumed_speed=1470.0, speed_sigma=1.0,
                 noise_sigma=0.7, dr_sigma=0.9),
    kinds=dict(n_runs=_N_RUNS, start=Real((2,)), headings=Real((2,)), turn_time=Real(()),
               ping_interval=Real((), "pos"), duration=Real((), "pos"), true_speed=Real((), "pos"),
               assumed_speed=Real((), "pos"), speed_sigma=Real((), "nonneg"), noise_sigma=Real((), "nonneg"),
               dr_sigma=Real((), "nonneg")), per_argument=4))
_add("uwtutor.scenarios:ship_and_submersible_scenario", Spec(
    lambda: dict(rng=_rng(), n_runs=2, duration=40.0, interval=1.0, ship_start=(0.0, 0.0), ship_velocity=(2.0, 2.0),
                 turn_rate=-0.005, half_period=20.0, sub_start=(-1000.0, -1000.0), sub_velocity=(1.0, 1.0),
                 noise_sigma=1.4, outlier_amplitude=80.0, outlier_onsets=(10.0, 25.0), outlier_counts=(3, 4),
                 outlier_two_sided=(False, True), dr_sigma=0.1),
    kinds=dict(n_runs=_N_RUNS, duration=Real((), "pos"), interval=Real((), "pos"), ship_start=Real((2,)),
               ship_velocity=Real((2,)), turn_rate=Real(()), half_period=Real((), "pos"), sub_start=Real((2,)),
               sub_velocity=Real((2,)), noise_sigma=Real((), "nonneg"), outlier_amplitude=Real((), "nonneg"),
               outlier_onsets=Real((2,)), outlier_counts=Instance(), outlier_two_sided=Instance(),
               dr_sigma=Real((), "nonneg")), per_argument=4))


# --- paper A ----------------------------------------------------------------------------------------------------------
def _paper_a_params(**kw):
    from uwtutor.scenarios.paper_a import PaperAParameters
    return PaperAParameters(**{**dict(n_obs=20, leg_time=30.0), **kw})


def _lake_params(**kw):
    from uwtutor.scenarios.paper_a import LakeTrialParameters
    return LakeTrialParameters(**{**dict(group_duration=20.0, gap=10.0, interval=2.0), **kw})


_add("uwtutor.scenarios.paper_a:PaperAParameters", Spec(
    lambda: dict(n_obs=20, interval=5.0, radius=1500.0, speed=2.0, track="turns", leg_time=30.0, noise_variance=5.0,
                 gamma=0.01, gamma_sigma=0.0, bias_mean=50.0, bias_sigma=5.0, bias_time_constant=3000.0,
                 dr_sigma=1.0),
    kinds=dict(n_obs=Int(minimum=2, unbounded_work=True), interval=Real((), "pos"), track=Choice(),
               leg_time=Real((), "pos"), noise_variance=Real((), "pos"), gamma=Real(()), gamma_sigma=Real((), "nonneg"),
               bias_mean=Real(()), bias_sigma=Real((), "nonneg"), bias_time_constant=Real((), "pos"),
               dr_sigma=Real((), "nonneg")), per_argument=4))
_add("uwtutor.scenarios.paper_a:make", Spec(
    lambda: dict(rng=_rng(), n_runs=2, params=_paper_a_params()), kinds=dict(n_runs=_N_RUNS, params=_OPT)))
_add("uwtutor.scenarios.paper_a:make_with_truth", Spec(
    lambda: dict(rng=_rng(), n_runs=2, params=_paper_a_params(track="circle")),
    kinds=dict(n_runs=_N_RUNS, params=_OPT)))
_add("uwtutor.scenarios.paper_a:random_turn_track", Spec(
    lambda: dict(rng=_rng(), times=np.arange(0.0, 300.0, 5.0), radius=1500.0, speed=2.0, leg_time=60.0,
                 start_angle=-1.5),
    kinds=dict(times=_TIMES, leg_time=Real((), "pos"), start_angle=Real(()))))
_add("uwtutor.scenarios.paper_a:variance_split", Spec(
    lambda: dict(bias_share=0.25, total_sigma=20.0, params=_paper_a_params(), mean_range=1500.0),
    kinds=dict(bias_share=Real((), "prob"), total_sigma=Real((), "nonneg"), params=_OPT,
               mean_range=Real((), "pos", optional=True))))
_add("uwtutor.scenarios.paper_a:LakeTrialParameters", Spec(
    lambda: dict(range_m=800.0, bearings_deg=(50.0, 50.0, 320.0, 320.0), group_duration=20.0, gap=10.0, interval=2.0,
                 receiver_speed=1.5, sender_speed=1.0, group_bias=(10.0, 9.0, 11.0, 10.0),
                 group_noise=(1.0, 3.0, 2.0, 4.0), bias_sigma=2.0, bias_time_constant=300.0, gnss_sigma=0.5),
    kinds=dict(range_m=Real((), "pos"), bearings_deg=Real((4,)), group_duration=Real((), "pos"), gap=Real((), "pos"),
               interval=Real((), "pos"), receiver_speed=Real((), "nonneg"), sender_speed=Real((), "nonneg"),
               group_bias=Real((4,)), group_noise=Real((4,), "pos"), bias_sigma=Real((), "nonneg"),
               bias_time_constant=Real((), "pos"), gnss_sigma=Real((), "nonneg")), per_argument=4))
_add("uwtutor.scenarios.paper_a:make_lake_trial", Spec(
    lambda: dict(rng=_rng(), n_runs=2, params=_lake_params()), kinds=dict(n_runs=_N_RUNS, params=_OPT)))
EXEMPT_SCEN["uwtutor.scenarios.paper_a:LakeTrial"] = ("the result container make_lake_trial builds from checked "
                                                      "LakeTrialParameters")


# --- paper B ----------------------------------------------------------------------------------------------------------
def _paper_b_params(**kw):
    from uwtutor.scenarios.paper_b import PaperBParameters
    return PaperBParameters(**{**dict(duration=40.0), **kw})


_add("uwtutor.scenarios.paper_b:PaperBParameters", Spec(
    lambda: dict(speed=2.0, duration=40.0, depth=10.0, dr_step=1.0, interval=8.0, current=(0.5, 0.5),
                 initial_estimate=(10.0, -100.0, 0.0, 0.0), initial_covariance_diag=(1e8, 1e8, 1e7, 1e7),
                 process_noise_diag=(100.0, 100.0, 4.0, 4.0, 0.0025, 0.0025),
                 measurement_noise_diag=(100.0,) * 6 + (4.0, 4.0, 0.0025, 0.0025),
                 follower_start=(0.0, 0.0), follower_heading=0.0, leader_pattern="zigzag",
                 leader_start=(500.0, -300.0), zigzag_angle=1.3, leg_duration=200.0, circle_radius=400.0,
                 range_sigma=5.0, leader_sigma=5.0, dr_speed_sigma=0.05, dr_heading_sigma=0.017, packet_loss=0.1,
                 current_after=(0.2, 0.0), change_time=20.0, leader_drift=(0.0, 0.0), owtt=True, clock_offset=0.0,
                 clock_drift=0.0, sound_speed=1500.0, ambiguity_period=1.0),
    kinds=dict(speed=Real((), "pos"), duration=Real((), "pos"), depth=Real((), "nonneg"), dr_step=Real((), "pos"),
               interval=Real((), "pos"), current=Real((2,)), initial_estimate=Real((4,)),
               initial_covariance_diag=Real((4,), "pos"), process_noise_diag=Real((6,), "nonneg"),
               measurement_noise_diag=Real((10,), "pos"), follower_start=Real((2,)), follower_heading=Real(()),
               leader_pattern=Choice(), leader_start=Real((2,)), zigzag_angle=Real(()), leg_duration=Real((), "pos"),
               circle_radius=Real((), "pos"), range_sigma=Real((), "nonneg"), leader_sigma=Real((), "nonneg"),
               dr_speed_sigma=Real((), "nonneg"), dr_heading_sigma=Real((), "nonneg"),
               packet_loss=Real((), "prob"), current_after=Real((2,)), change_time=Real(()),
               leader_drift=Real((2,)), owtt=Flag(), clock_offset=Real(()), clock_drift=Real(()),
               sound_speed=Real((), "pos"), ambiguity_period=Real((), "pos", optional=True)), per_argument=4))
_add("uwtutor.scenarios.paper_b:make_followers", Spec(
    lambda: dict(rng=_rng(), n_runs=2, followers=[((0.0, 0.0), 0.0), ((0.0, 100.0), 0.1)],
                 params=_paper_b_params()),
    kinds=dict(n_runs=_N_RUNS, followers=Instance(), params=_OPT)))
_add("uwtutor.scenarios.paper_b:paper_tuning", Spec(lambda: dict(params=_paper_b_params()),
                                                    kinds=dict(params=_OPT)))
EXEMPT_SCEN["uwtutor.scenarios.paper_b:CooperativeScenario"] = "the result container paper_b.make builds"
EXEMPT_SCEN["uwtutor.scenarios.paper_b:FilterTuning"] = ("the tuning paper_tuning and matched_tuning build; "
                                                         "cooperative_ekf checks the P0, Q and R it hands on")


# --- paper C ----------------------------------------------------------------------------------------------------------
_add("uwtutor.scenarios.paper_c:PaperCParameters", Spec(
    lambda: dict(T=0.05, n_particles=1000, n_grey=100, grey_window=30, noise_window=50, polynomial_order=5,
                 wavelet="db6", sensor_std=np.array([0.2, 0.05, 0.0087]), process_std=np.array([0.2, 0.01, 0.0087]),
                 Q_as_printed=np.eye(3)),
    kinds=dict(T=Real((), "pos"), n_particles=Int(minimum=1), n_grey=Int(minimum=0), grey_window=Int(minimum=4),
               noise_window=Int(minimum=1), polynomial_order=Int(minimum=0), wavelet=Choice(),
               sensor_std=Real((3,), "pos"), process_std=Real((3,), "nonneg"), Q_as_printed=Real((3, 3))),
    per_argument=4))
_add("uwtutor.scenarios.paper_c:maneuvering_depth_profile", Spec(
    lambda: dict(duration=3.0, T=0.05, dive_pitch_deg=20.0, climb_pitch_deg=-25.0, noise_factors=(1.0, 3.0),
                 noise_change_times=(30.0,), sensor_std=(0.2, 0.05, 0.0087)),
    kinds=dict(duration=Real((), "pos"), T=Real((), "pos"), dive_pitch_deg=Real(()), climb_pitch_deg=Real(()),
               noise_factors=Real((2,), "pos"), noise_change_times=Real((1,)),
               sensor_std=Real((3,), "pos", optional=True))))


def _profile():
    from uwtutor.scenarios.paper_c import maneuvering_depth_profile
    return maneuvering_depth_profile(duration=3.0)


_add("uwtutor.scenarios.paper_c:simulate_depth_sensors", Spec(
    lambda: dict(profile=_profile(), n_runs=2, rng=_rng()), kinds=dict(profile=Instance(), n_runs=_N_RUNS)))
_add("uwtutor.scenarios.paper_c:make", Spec(
    lambda: dict(rng=_rng(), n_runs=2, params=None, duration=3.0),
    kinds=dict(n_runs=_N_RUNS, params=_OPT, duration=Real((), "pos"))))
EXEMPT_SCEN["uwtutor.scenarios.paper_c:DepthProfile"] = "the profile maneuvering_depth_profile builds"
EXEMPT_SCEN["uwtutor.scenarios.paper_c:PaperCScenario"] = "the result container paper_c.make builds"


# --- papers D and E ---------------------------------------------------------------------------------------------------
_add("uwtutor.scenarios.paper_d:PaperDParameters", Spec(
    lambda: dict(Q=0.81, R=0.49, rho=0.95, true_speed=1500.0, speed_sigma=1.0, assumed_speed=1470.0,
                 ping_interval=10.0, duration=1500.0, n_runs=1000),
    kinds=dict(Q=Real((), "nonneg"), R=Real((), "nonneg"), rho=Real((), "prob"), true_speed=Real((), "pos"),
               speed_sigma=Real((), "nonneg"), assumed_speed=Real((), "pos"), ping_interval=Real((), "pos"),
               duration=Real((), "pos"), n_runs=Int(minimum=1)), per_argument=4))
_add("uwtutor.scenarios.paper_d:make", Spec(
    lambda: dict(rng=_rng(), n_runs=2, params=None, duration=60.0),
    kinds=dict(n_runs=_N_RUNS, params=_OPT, duration=Real((), "pos"))))
_add("uwtutor.scenarios.paper_e:PaperEParameters", Spec(
    lambda: dict(duration=1200.0, interval=1.0, ship_velocity=(2.0, 2.0), turn_rate_deg=0.3, sub_velocity=(1.0, 1.0),
                 range_noise_variance=2.0, q=2.0, r=2.0, outlier_amplitude=80.0, outlier_onsets=(300.0, 700.0),
                 outlier_counts=(10, 20), outlier_two_sided=(False, True), delta=0.03, budget_runs=50_000,
                 half_period=600.0, ship_start=(0.0, 0.0), sub_start=(-1000.0, -1000.0), depth=1000.0,
                 spacing=100.0, dr_sigma=0.1),
    kinds=dict(duration=Real((), "pos"), interval=Real((), "pos"), ship_velocity=Real((2,)), turn_rate_deg=Real(()),
               sub_velocity=Real((2,)), range_noise_variance=Real((), "nonneg"), q=Real((), "pos"),
               r=Real((), "pos"), outlier_amplitude=Real((), "nonneg"), outlier_onsets=Real((2,)),
               outlier_counts=Instance(), outlier_two_sided=Instance(), delta=Real((), "open01"),
               budget_runs=Int(minimum=1), half_period=Real((), "pos"), ship_start=Real((2,)),
               sub_start=Real((2,)), depth=Real((), "nonneg"), spacing=Real((), "pos"),
               dr_sigma=Real((), "nonneg")), per_argument=4))
_add("uwtutor.scenarios.paper_e:make", Spec(
    lambda: dict(rng=_rng(), n_runs=2, params=None, duration=40.0, outlier_onsets=(10.0,), outlier_counts=(3,),
                 outlier_two_sided=(True,)),
    kinds=dict(n_runs=_N_RUNS, params=_OPT, duration=Real((), "pos")), per_argument=4))
EXEMPT_SCEN["uwtutor.scenarios.paper_e:Dive"] = "the result container paper_e.make builds"


# --- the suite of chapter 10 ------------------------------------------------------------------------------------------
def _suite_params(**kw):
    from uwtutor.scenarios.suite import SuiteParameters
    return SuiteParameters(**{**dict(n_epochs=8), **kw})


_SUITE_FIELDS = dict(n_epochs=8, interval=10.0, speed=2.0, dr_sigma=1.0, range_sigma=2.0, start_sigma=100.0,
                     true_speed=1500.0, assumed_speed=1470.0, speed_sigma=1.0, bias_mean=5.0, bias_sigma=5.0,
                     bias_time_constant=3000.0, outlier_amplitude=80.0, outlier_probability=0.03,
                     outlier_patch_time=600.0, outlier_patch_length=10, current_velocity=(0.07, 0.07),
                     current_sigma=0.2)
_add("uwtutor.scenarios.suite:SuiteParameters", Spec(
    lambda: dict(_SUITE_FIELDS),
    kinds=dict(n_epochs=Int(minimum=1, unbounded_work=True), interval=Real((), "pos"), speed=Real((), "pos"),
               dr_sigma=Real((), "nonneg"), range_sigma=Real((), "pos"), start_sigma=Real((), "pos"),
               true_speed=Real((), "pos"), assumed_speed=Real((), "pos"), speed_sigma=Real((), "nonneg"),
               bias_mean=Real(()), bias_sigma=Real((), "nonneg"), bias_time_constant=Real((), "pos"),
               outlier_amplitude=Real((), "nonneg"), outlier_probability=Real((), "prob"),
               outlier_patch_time=Real(()), outlier_patch_length=Int(minimum=1), current_velocity=Real((2,)),
               current_sigma=Real((), "pos")), per_argument=4))
for _name in ("turn", "line", "lawnmower", "moving_beacon"):
    _add(f"uwtutor.scenarios.suite:{_name}", Spec(
        lambda: dict(rng=_rng(), n_runs=2, params=_suite_params()), kinds=dict(params=_OPT)))


def _suite_runs():
    from uwtutor.scenarios.suite import turn
    return turn(np.random.default_rng(5), 2, _suite_params())


for _name in ("white", "sound_speed", "bias", "outliers", "current"):
    _add(f"uwtutor.scenarios.suite:{_name}", Spec(lambda: dict(rng=_rng(), runs=_suite_runs()),
                                                  kinds=dict(runs=Instance())))
EXEMPT_SCEN["uwtutor.scenarios.suite:SuiteRuns"] = ("the runs a scenario of SCENARIOS builds (from checked "
                                                    "SuiteParameters); the conditions check that they get one")
EXEMPT_SCEN["uwtutor.scenarios.suite:SuiteInputs"] = "the inputs a condition of CONDITIONS builds for the methods"


# --- the renames of issue 27 ------------------------------------------------------------------------------------------
EXEMPT_SCEN["uwtutor.errors:deprecated_aliases"] = (
    "library plumbing: builds a module's __getattr__ at import time from old and new names written in the library "
    "(never called with user data); tests/test_deprecated_names.py reads every alias")
