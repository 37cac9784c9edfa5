"""uwtutor benchmark suite: ``make bench`` prints one table; ``--save`` also records it.

Measured in one run, on this machine:

1. the range-only EKF Monte Carlo study (1000 runs x 1500 steps, one batched call), best of a few repeats, and
   its speed-up over filterpy's ``ExtendedKalmanFilter`` stepped in a Python loop (a sample of runs is timed and
   the time scaled to 1000 runs); and the generic batched EKF on paper A's 3-state model (position + range bias)
   against filterpy's 3-state EKF in the same way;
2. the bootstrap particle filter on paper C's depth/speed/pitch model, N = 1000 particles, 2000 steps, in steps
   per second, and the same filter with filterpy's loop-based ``systematic_resample``;
3. the same PF batched over 100 Monte Carlo runs (N = 1000, 500 steps, one call) against 100 single-run calls;
4. each widget's compute function at its default parameters (``uwtutor.widgets.COMPUTE_FUNCTIONS``), in ms;
5. each live widget's update as a person sees it: in JupyterLab (a local server and Debian's Chromium, offline;
   ``jupyterlab_session.py``), from the key press that moves its first slider to the first frame painted with the
   new figure, against the same widget built the way widgets updated before; and what the kernel alone spends on
   that update (compute, draw, PNG), in this process; ``--no-browser`` leaves JupyterLab out;
6. the range-only EKF study and the particle filter of 2. against the same filters written in plain numpy for the
   purpose (``plain_numpy.py``: the same arithmetic and outputs, no checks), timed in turn in this process: the
   ratio of the two CPU times (the wall times beside it) is what the library's validation, guards and generality
   cost (``--only ekf_vs_numpy``, ``--only pf_vs_numpy``);
7. the peak memory of the 1000-run EKF study, in a fresh subprocess;
8. the generic EKF on a real-data-sized odometry log: wheel odometry with a gyro bias and a range scale in the state,
   4091 epochs x 4 beacons (the size of the CMU Plaza logs), one run; ``navigate`` on the real Plaza 2 log; and the
   bootstrap particle filter with the same odometry model pair on Plaza 2, N = 2000 (``--only pf_plaza``; skipped
   without the ``data`` extra).

``--only NAME`` runs one benchmark and prints its numbers (nothing is saved); ``--only widget_latency`` (with
``--widgets ch07`` to keep some) times every control of the widgets in JupyterLab and prints them as a table.

``--save`` writes ``benchmarks/results.json`` and regenerates the table of ``book/appendix_performance.md``
between its marker comments, so that the committed page always shows the committed results (the book build
never times anything). Speed numbers are never asserted by the unit tests.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path
from typing import Any, Callable

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:                   # time this checkout's uwtutor, not another installed copy
    sys.path.insert(0, str(ROOT))
RESULTS_FILE = ROOT / "benchmarks" / "results.json"
PAGE_FILE = ROOT / "book" / "appendix_performance.md"
START_MARKER = "<!-- BENCH-TABLE:START -->"
END_MARKER = "<!-- BENCH-TABLE:END -->"

EKF_RUNS, EKF_STEPS = 1000, 1500
ODOMETRY_EPOCHS, ODOMETRY_BEACONS = 4091, 4
FILTERPY_SAMPLE_RUNS = 20
PF_PARTICLES, PF_STEPS = 1000, 2000

#: Targets on the project's reference machine (2 cores); see book/appendix_performance.md.
TARGETS = {
    "ekf_study_s": ("<=", 0.25),
    "ekf_speedup_vs_filterpy": (">=", 100.0),
    "generic_ekf_speedup_vs_filterpy": (">=", 50.0),
    "pf_steps_per_s": (">=", 5000.0),
    "widget_ms": ("<=", 150.0),
    "widget_latency_ms": ("<=", 150.0),
    "peak_memory_mb": ("<=", 500.0),
    "odometry_ekf_s": ("<=", 1.0),
    "navigate_plaza2_s": ("<=", 1.0),
    "single_run_ratio": ("<=", 2.0),
    "first_visit_ms": ("<=", 120.0),
    "pf_plaza2_s": ("<=", 10.0),
    "ekf_vs_numpy_ratio": ("<=", 1.2),
    "pf_vs_numpy_ratio": ("<=", 1.2),
}

#: Particles of the particle filter on Plaza 2.
PF_PLAZA_PARTICLES = 2000


# --- inputs ---------------------------------------------------------------------------------------------------

def ekf_study_inputs(M: int = EKF_RUNS, K: int = EKF_STEPS, seed: int = 0) -> dict[str, Any]:
    """A vehicle circling a beacon: noisy dead reckoning and ranges (10 % missing) for M runs of K epochs."""
    import numpy as np

    rng = np.random.default_rng(seed)
    theta = np.linspace(0.0, 6 * np.pi, K + 1)
    track = np.column_stack([500.0 + 300.0 * np.cos(theta), 300.0 * np.sin(theta)])
    truth = track[1:] + np.cumsum(rng.normal(0.0, 0.5, (M, K, 2)), axis=1)
    u = np.broadcast_to(np.diff(track, axis=0), (M, K, 2)) + rng.normal(0.0, 0.05, (M, K, 2))
    z = np.linalg.norm(truth, axis=-1) + rng.normal(0.0, 2.0, (M, K))
    z[rng.random((M, K)) < 0.1] = np.nan
    x0 = track[0] + rng.normal(0.0, 20.0, (M, 2))
    return dict(x0=x0, P0=np.eye(2) * 400.0, u=u, z=z, Q=np.eye(2) * 0.25, R=4.0)


def odometry_inputs(K: int = ODOMETRY_EPOCHS, seed: int = 0) -> dict[str, Any]:
    """A robot wandering among four beacons for K epochs of 0.5 s: odometry [distance, heading change] with noise and
    a gyro bias of 0.004 rad/s, ranges 1.07 times the distance with 5 cm noise, 30 % of them missing."""
    import numpy as np

    from uwtutor.models import BeaconRanges, OdometryMotion

    rng = np.random.default_rng(seed)
    beacons = np.array([[0.0, 0.0], [40.0, 0.0], [40.0, 30.0], [0.0, 30.0]])
    t = 0.5 * np.arange(K)
    u_true = np.column_stack([np.full(K, 0.5), (0.12 + 0.08 * np.sin(2 * np.pi * t / 90.0)) * 0.5])
    u_true[0] = 0.0
    truth = OdometryMotion(0.0, 0.0).integrate([20.0, 5.0, 0.0], u_true)
    u = u_true + np.column_stack([rng.normal(0, 0.02, K), rng.normal(0, 0.003, K) + 0.002])
    u[0] = 0.0
    z = 1.07 * np.linalg.norm(truth[:, None, :2] - beacons, axis=-1) + rng.normal(0, 0.05, (K, len(beacons)))
    z[rng.random(z.shape) < 0.3] = np.nan
    motion = OdometryMotion(0.02, 0.003, gyro_bias=True, scale=True, times=t, gyro_bias_walk=1e-6, scale_walk=1e-6)
    x0, P0 = motion.layout.initial_state([20.0, 5.0, 0.0], np.diag([1.0, 1.0, 0.01]), gyro_bias=(0.0, 0.01),
                                         scale=(1.0, 0.1))
    return dict(motion=motion, measurement=BeaconRanges(beacons, R=0.05**2, layout=motion.layout), x0=x0, P0=P0,
                u=u, z=z, times=t)


def best_time(fn: Callable[[], Any], repeats: int) -> float:
    """Best wall time of ``repeats`` calls (the least disturbed by other processes)."""
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def filterpy_range_loop(x0: Any, P0: Any, Q: Any, R: float, u: Any, z: Any, bias: bool) -> None:
    """The reference: filterpy's ``ExtendedKalmanFilter`` stepped in a Python loop over ``FILTERPY_SAMPLE_RUNS``
    runs, ranges to a beacon at the origin (plus a bias state when ``bias``), F = I, the DR displacement as input."""
    import numpy as np
    from filterpy.kalman import ExtendedKalmanFilter

    n = 3 if bias else 2

    def hx(x: np.ndarray) -> np.ndarray:
        return np.array([[np.sqrt(x[0, 0] ** 2 + x[1, 0] ** 2) + (x[2, 0] if bias else 0.0)]])

    def jacobian(x: np.ndarray) -> np.ndarray:
        r = np.sqrt(x[0, 0] ** 2 + x[1, 0] ** 2)
        return np.array([[x[0, 0] / r, x[1, 0] / r] + ([1.0] if bias else [])])

    for m in range(FILTERPY_SAMPLE_RUNS):
        ekf = ExtendedKalmanFilter(dim_x=n, dim_z=1, dim_u=2)
        ekf.x = np.asarray(x0[m], dtype=float).reshape(n, 1).copy()
        ekf.P = np.array(P0, dtype=float)
        ekf.F = np.eye(n)
        ekf.B = np.vstack([np.eye(2), np.zeros((n - 2, 2))])
        ekf.Q = Q
        ekf.R = np.array([[R]])
        for uk, zk in zip(u[m], z[m]):
            ekf.predict(u=uk.reshape(2, 1))
            if zk == zk:                                   # not NaN
                ekf.update(np.array([[zk]]), jacobian, hx)


# --- the measurements -----------------------------------------------------------------------------------------

def bench_ekf(repeats: int) -> dict[str, Any]:

    from uwtutor.filters import range_only_ekf

    inputs = ekf_study_inputs()
    range_only_ekf(**{**inputs, "x0": inputs["x0"][:10], "u": inputs["u"][:10], "z": inputs["z"][:10]})  # warm-up
    batched = best_time(lambda: range_only_ekf(**inputs), repeats)

    def filterpy_sample() -> None:
        filterpy_range_loop(inputs["x0"], inputs["P0"], inputs["Q"], inputs["R"], inputs["u"], inputs["z"],
                            bias=False)

    sample = best_time(filterpy_sample, max(1, min(2, repeats)))
    filterpy_full = sample * EKF_RUNS / FILTERPY_SAMPLE_RUNS
    return {"ekf_study_s": batched, "filterpy_sample_s": sample, "filterpy_sample_runs": FILTERPY_SAMPLE_RUNS,
            "filterpy_scaled_s": filterpy_full, "ekf_speedup_vs_filterpy": filterpy_full / batched}


def interleaved_best(first: Callable[[], Any], second: Callable[[], Any],
                     repeats: int) -> tuple[float, float, float, float]:
    """Best wall times of ``first`` and ``second`` called in turn ``repeats`` times each, so that both see the
    same load of the machine (a ratio of the two is then steadier than either time; the ratio benchmarks take
    three times ``--repeats``), then the best CPU times of this process for each: the ratio of the CPU times is the
    one compared with the target, since other processes on a shared machine disturb it far less than the wall
    time (on a quiet machine the two agree)."""
    wall = [float("inf"), float("inf")]
    cpu = [float("inf"), float("inf")]
    for _ in range(repeats):
        for i, fn in enumerate((first, second)):
            c0, t0 = time.process_time(), time.perf_counter()
            fn()
            wall[i] = min(wall[i], time.perf_counter() - t0)
            cpu[i] = min(cpu[i], time.process_time() - c0)
    return wall[0], wall[1], cpu[0], cpu[1]


def _plain_numpy() -> Any:
    """``benchmarks/plain_numpy.py``, the plain-numpy references (imported by path: ``benchmarks`` is no package)."""
    import importlib.util

    name = "uwtutor_bench_plain_numpy"
    if name not in sys.modules:
        spec = importlib.util.spec_from_file_location(name, Path(__file__).resolve().parent / "plain_numpy.py")
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
    return sys.modules[name]


def bench_import_time(repeats: int) -> dict[str, Any]:
    """The CPU time of ``import uwtutor`` and ``import uwtutor.filters`` (``import_time.py``, loaded by path)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("uwtutor_bench_import_time",
                                                  Path(__file__).with_name("import_time.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    results = module.bench_import_time(repeats)
    results["import_rows"] = module.rows(results)
    return results


def bench_ekf_vs_numpy(repeats: int) -> dict[str, Any]:
    """The study of ``bench_ekf`` (1000 runs x 1500 steps) with ``range_only_ekf`` and with the plain-numpy EKF of
    ``plain_numpy.py`` (the same arithmetic, no checks), in turn in this process; their outputs must agree to 1e-9
    (relative). The ratio of the CPU times is what the library's validation, guards and generality cost."""
    from uwtutor.filters import range_only_ekf

    plain = _plain_numpy()
    inputs = ekf_study_inputs()
    args = [inputs[k] for k in ("x0", "P0", "u", "z", "Q", "R")]
    max_rel = plain.assert_ekf_agrees(range_only_ekf(**inputs), plain.range_only_ekf(*args))   # also a warm-up
    ours, theirs, ours_cpu, theirs_cpu = interleaved_best(lambda: range_only_ekf(**inputs),
                                                          lambda: plain.range_only_ekf(*args), 3 * repeats)
    return {"ekf_vs_numpy_s": ours, "ekf_numpy_s": theirs, "ekf_vs_numpy_wall_ratio": ours / theirs,
            "ekf_vs_numpy_ratio": ours_cpu / theirs_cpu, "ekf_vs_numpy_max_rel_diff": max_rel}


def _bit_for_bit(pairs: list[tuple[Any, Any]], what: str) -> None:
    """Refuse a library output that is not exactly the plain-numpy reference's (NaN where it has NaN)."""
    import numpy as np

    for i, (a, b) in enumerate(pairs):
        if not (np.shape(a) == np.shape(b) and np.array_equal(a, b, equal_nan=True)):
            raise AssertionError(f"{what}: output {i} is not the plain-numpy reference's bit for bit")


def bench_single_run(repeats: int) -> dict[str, Any]:
    """One run (no Monte Carlo axis) of three filters against a plain-numpy loop doing the same arithmetic, the
    outputs checked equal bit for bit first: the range-only EKF (``range_only_ekf`` against
    ``plain_numpy.range_only_ekf``, 1500 steps), paper A's bias EKF (``bias_ekf``) and ``navigate``'s model pair
    (odometry with a gyro bias and a range scale, ranges to four beacons, 4091 epochs; ``extended_kalman_filter``)
    against ``plain_numpy.generic_ekf`` (the engine's equations with no checks). The CPU time per step of each and
    the ratio, interleaved as in ``interleaved_best``; the goal is a ratio of at most 2."""
    import numpy as np

    from uwtutor.filters import bias_ekf, extended_kalman_filter, range_only_ekf
    from uwtutor.filters.bias import bias_model_pair

    plain = _plain_numpy()
    out: dict[str, Any] = {}
    study = ekf_study_inputs(M=1)
    x0, P0, u, z, Q, R = (study[k] for k in ("x0", "P0", "u", "z", "Q", "R"))
    Qb = np.diag([Q[0, 0], Q[1, 1], 0.01])
    x0b = np.append(x0[0], 0.0)
    odo = odometry_inputs()
    cases = {
        "range_only": (lambda: range_only_ekf(x0[0], P0, u[0], z[0], Q, R),
                       lambda: plain.range_only_ekf(x0, P0, u, z, Q, R), z.shape[1]),
        "bias": (lambda: bias_ekf(x0b, np.eye(3) * 400.0, u[0], z[0], Qb, R),
                 lambda: plain.generic_ekf(*bias_model_pair(Qb, R, (0.0, 0.0), z.shape[1]), x0b,
                                           np.eye(3) * 400.0, u[0], z[0]), z.shape[1]),
        "navigate_model": (lambda: extended_kalman_filter(odo["motion"], odo["measurement"], odo["x0"], odo["P0"],
                                                          odo["u"], odo["z"], times=odo["times"]),
                           lambda: plain.generic_ekf(odo["motion"], odo["measurement"], odo["x0"], odo["P0"],
                                                     odo["u"], odo["z"]), odo["z"].shape[0]),
    }
    for name, (ours, theirs, steps) in cases.items():
        a, b = ours(), theirs()                                              # also a warm-up
        if name == "range_only":
            _bit_for_bit([(a.x, b["x"][:, :, 0]), (a.x_prior, b["x_prior"][:, :, 0]),
                          (a.P.reshape(-1, 4), b["P"][:, :, 0]), (a.P_prior.reshape(-1, 4), b["P_prior"][:, :, 0]),
                          (a.innovations[:, 0], b["y"][:, 0]), (a.innovation_cov[:, 0, 0], b["S"][:, 0])], name)
        else:
            _bit_for_bit([(a.x, b["x"]), (a.P, b["P"]), (a.x_prior, b["x_prior"]), (a.P_prior, b["P_prior"]),
                          (a.innovations, b["y"]), (a.innovation_cov, b["S"])], name)
        _, _, ours_cpu, theirs_cpu = interleaved_best(ours, theirs, 3 * repeats)
        out[f"single_{name}_us_per_step"] = 1e6 * ours_cpu / steps
        out[f"single_{name}_numpy_us_per_step"] = 1e6 * theirs_cpu / steps
        out[f"single_{name}_ratio"] = ours_cpu / theirs_cpu
    return out


def bench_first_visit(repeats: int) -> dict[str, Any]:
    """Every control of every widget on settings never seen before and seen before (``first_visit.py``)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("first_visit", ROOT / "benchmarks" / "first_visit.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    results = module.measure_all()
    return {"first_visit": results, "first_visit_table": module.render(results)}


def bench_pf_vs_numpy(repeats: int) -> dict[str, Any]:
    """The particle filter of ``bench_pf`` (paper C's model, N = 1000, 2000 steps, one run, systematic resampling
    every step, initial particles included) with ``BootstrapParticleFilter`` and with the plain-numpy filter of
    ``plain_numpy.py`` on the same random stream, in turn in this process; their outputs must agree to 1e-9
    (relative; they are equal draw for draw)."""
    import numpy as np

    from uwtutor.filters import BootstrapParticleFilter
    from uwtutor.models import DepthSpeedPitchModel

    plain = _plain_numpy()
    model = DepthSpeedPitchModel()
    _, measurements = model.simulate([20.0, 1.5, 0.05], PF_STEPS, np.random.default_rng(1))

    def ours() -> Any:
        return BootstrapParticleFilter.from_gaussian(model.motion, model.measurement, measurements[0], model.R,
                                                     PF_PARTICLES, np.random.default_rng(2)).run(measurements)

    def theirs() -> Any:
        return plain.bootstrap_pf(measurements[0], model.R, measurements, PF_PARTICLES, np.random.default_rng(2),
                                  model.motion.T, model.motion.process_std, model.R)

    max_rel = plain.assert_pf_agrees(ours(), theirs())
    ours_s, theirs_s, ours_cpu, theirs_cpu = interleaved_best(ours, theirs, 3 * repeats)
    return {"pf_vs_numpy_s": ours_s, "pf_numpy_s": theirs_s, "pf_vs_numpy_wall_ratio": ours_s / theirs_s,
            "pf_vs_numpy_ratio": ours_cpu / theirs_cpu, "pf_vs_numpy_max_rel_diff": max_rel}


def bench_generic_ekf(repeats: int) -> dict[str, Any]:
    """The generic batched EKF on paper A's 3-state model (position + range bias), against filterpy's 3-state
    ``ExtendedKalmanFilter`` stepped in a Python loop, on the same inputs and in the same run."""
    import numpy as np

    from uwtutor.filters import extended_kalman_filter
    from uwtutor.models import DeadReckoning, RangeToBeacon

    inputs = ekf_study_inputs()
    M = inputs["x0"].shape[0]
    x0 = np.column_stack([inputs["x0"], np.zeros(M)])
    P0 = np.diag([400.0, 400.0, 25.0])
    Q = np.diag([0.25, 0.25, 0.01])
    motion, measurement = DeadReckoning(Q), RangeToBeacon((0.0, 0.0), R=inputs["R"], n=3, bias_index=2)
    extended_kalman_filter(motion, measurement, x0[:10], P0, inputs["u"][:10], inputs["z"][:10])   # warm-up
    ours = best_time(lambda: extended_kalman_filter(motion, measurement, x0, P0, inputs["u"], inputs["z"]),
                     repeats)

    def filterpy_sample() -> None:
        filterpy_range_loop(x0, P0, Q, inputs["R"], inputs["u"], inputs["z"], bias=True)

    sample = best_time(filterpy_sample, max(1, min(2, repeats)))
    scaled = sample * EKF_RUNS / FILTERPY_SAMPLE_RUNS
    return {"generic_ekf_s": ours, "generic_filterpy_sample_s": sample, "generic_filterpy_scaled_s": scaled,
            "generic_ekf_speedup_vs_filterpy": scaled / ours}


def bench_odometry_ekf(repeats: int) -> dict[str, Any]:
    """The generic EKF with the odometry model (heading, gyro bias, range scale: 5 states) and the ranges to four
    beacons with missing components, over 4091 epochs: the size of a real log (CMU Plaza)."""
    from uwtutor.filters import extended_kalman_filter

    inputs = odometry_inputs()
    args = [inputs[k] for k in ("motion", "measurement", "x0", "P0", "u", "z")]
    extended_kalman_filter(*args[:4], inputs["u"][:50], inputs["z"][:50])                 # warm-up
    seconds = best_time(lambda: extended_kalman_filter(*args, times=inputs["times"]), repeats)
    return {"odometry_ekf_s": seconds, "odometry_epochs": ODOMETRY_EPOCHS, "odometry_beacons": ODOMETRY_BEACONS}


def bench_navigate(repeats: int) -> dict[str, Any]:
    """``datasets.navigate`` on the real Plaza 2 log (4091 epochs, 4 beacons; the gtsam wheel's copy): the whole
    call a user makes at its defaults -- the four candidate models run (as one batch) and scored, the ranges placed
    on the epochs -- best wall time and best CPU time. Skipped without the ``data`` extra."""
    try:
        from uwtutor.datasets import navigate, plaza

        data = plaza(2)
    except ModuleNotFoundError as exc:
        print(f"navigate on Plaza 2 skipped: {exc}")
        return {}
    navigate(data, [0])                                                                     # warm-up
    cpu = float("inf")
    for _ in range(repeats):
        c0 = time.process_time()
        result = navigate(data)
        cpu = min(cpu, time.process_time() - c0)
    return {"navigate_plaza2_s": best_time(lambda: navigate(data), repeats), "navigate_plaza2_cpu_s": cpu,
            "navigate_plaza2_candidates": len(result.evidence), "navigate_plaza2_epochs": int(data.times.size)}


def bench_pf_plaza(repeats: int) -> dict[str, Any]:
    """The bootstrap particle filter, N = 2000 (resampling below N/2, roughening 0.1), on the real Plaza 2 log (4091
    epochs, 4 beacons) with ``navigate``'s odometry model pair (heading, gyro bias, range scale): the whole run, one
    call. Skipped without the ``data`` extra; a warm-up on 50 epochs first."""
    try:
        from uwtutor.datasets import navigation_models, plaza

        data = plaza(2)
    except ModuleNotFoundError as exc:
        print(f"the particle filter on Plaza 2 skipped: {exc}")
        return {}
    import numpy as np

    from uwtutor.filters import BootstrapParticleFilter

    nav = navigation_models(data)

    def run(steps: int | None = None) -> Any:
        pf = BootstrapParticleFilter.from_gaussian(nav.motion, nav.measurement, nav.x0, nav.P0, PF_PLAZA_PARTICLES,
                                                   np.random.default_rng(0), ess_threshold=0.5, roughening=0.1)
        return pf.run(nav.z[:steps], nav.u[:steps], times=nav.times[:steps])

    run(50)                                                                                 # warm-up
    seconds = best_time(run, max(1, min(3, repeats)))
    error = np.linalg.norm(run().x[:, :2] - data.truth[:, :2], axis=1)
    return {"pf_plaza2_s": seconds, "pf_plaza2_particles": PF_PLAZA_PARTICLES, "pf_plaza2_epochs": int(data.n_epochs),
            "pf_plaza2_rms_error_m": float(np.sqrt(np.mean(error**2)))}


def bench_pf(repeats: int) -> dict[str, Any]:
    import numpy as np
    from filterpy.monte_carlo import systematic_resample as filterpy_systematic

    from uwtutor.filters import BootstrapParticleFilter
    from uwtutor.models import DepthSpeedPitchModel

    model = DepthSpeedPitchModel()
    truth, measurements = model.simulate([20.0, 1.5, 0.05], PF_STEPS, np.random.default_rng(1))

    def run(resampler: Any = None) -> None:
        kwargs = {} if resampler is None else {"resampler": resampler}
        pf = BootstrapParticleFilter.from_gaussian(model.motion, model.measurement, measurements[0], model.R,
                                                   PF_PARTICLES, np.random.default_rng(2), **kwargs)
        pf.run(measurements)

    def with_filterpy(weights: Any, rng: Any) -> Any:
        return filterpy_systematic(weights)                   # global numpy.random state

    np.random.seed(3)
    ours = best_time(run, repeats)
    theirs = best_time(lambda: run(with_filterpy), max(1, min(2, repeats)))
    return {"pf_s": ours, "pf_steps_per_s": PF_STEPS / ours, "pf_filterpy_resampler_s": theirs,
            "pf_filterpy_resampler_steps_per_s": PF_STEPS / theirs, "pf_speedup_vs_filterpy_resampler": theirs / ours}


def bench_depth_filters(repeats: int) -> dict[str, Any]:
    """Chapter 6's cost table: time per step of the EKF, bootstrap PF, GPF and MMPF on one run of its dive."""
    import numpy as np

    from uwtutor.widgets import ch06

    profile = ch06.maneuvering_depth_profile()
    Z = ch06.simulate_depth_sensors(profile, 1, np.random.default_rng(2013))
    per_step_ms = {}
    for name in ("EKF", "PF", "GPF", "MMPF"):
        seconds = best_time(lambda name=name: ch06.run_depth_study(profile, Z, (name,)), repeats)
        per_step_ms[name] = 1000.0 * seconds / profile.n_steps
    return {"depth_filters": {"steps": int(profile.n_steps), "per_step_ms": per_step_ms,
                              "date": machine_info()["date"]}}


PF_BATCH_RUNS, PF_BATCH_STEPS = 100, 500


def bench_pf_batched(repeats: int) -> dict[str, Any]:
    """Batched PFs: 100 runs x N = 1000 x 500 steps of the bootstrap PF on paper C's model in one call, and the
    ratio to 100 single-run calls (same streams: run m of the batch is the single run on ``spawn(100)[m]``)."""
    import numpy as np

    from uwtutor.filters import BootstrapParticleFilter
    from uwtutor.models import DepthSpeedPitchModel

    model = DepthSpeedPitchModel()
    motion, sensors = model.motion, model.measurement
    rng = np.random.default_rng(1)
    z = np.stack([model.simulate([20.0, 1.5, 0.05], PF_BATCH_STEPS, rng)[1] for _ in range(PF_BATCH_RUNS)])

    def batched() -> None:
        BootstrapParticleFilter.from_gaussian(motion, sensors, z[:, 0], model.R, PF_PARTICLES,
                                              np.random.default_rng(2), n_runs=PF_BATCH_RUNS).run(z)

    def singles() -> None:
        rngs = np.random.default_rng(2).spawn(PF_BATCH_RUNS)
        for m in range(PF_BATCH_RUNS):
            BootstrapParticleFilter.from_gaussian(motion, sensors, z[m, 0], model.R, PF_PARTICLES,
                                                  rngs[m]).run(z[m])

    n = max(1, min(2, repeats))
    one_call = best_time(batched, n)
    loop = best_time(singles, n)
    return {"pf_batched": {"runs": PF_BATCH_RUNS, "particles": PF_PARTICLES, "steps": PF_BATCH_STEPS,
                           "one_call_s": one_call, "single_calls_s": loop, "speedup": loop / one_call}}


def bench_widgets(repeats: int) -> dict[str, Any]:
    """ms per update of each registered widget compute function (``widgets_ms``), or a note why there are none."""
    try:
        import importlib

        widgets = importlib.import_module("uwtutor.widgets")
    except ModuleNotFoundError as exc:
        if exc.name != "uwtutor.widgets":
            raise
        return {"widgets_ms": {}, "widgets_note": "no uwtutor.widgets module: no widgets registered"}
    functions = getattr(widgets, "COMPUTE_FUNCTIONS", None)
    if not functions:
        return {"widgets_ms": {}, "widgets_note": "uwtutor.widgets.COMPUTE_FUNCTIONS is empty or missing: "
                                                  "no widgets registered"}
    out = {}
    for name, fn in functions.items():
        fn()                                                    # warm-up (imports, caches)
        out[name] = best_time(fn, repeats) * 1000.0
    return {"widgets_ms": out, "widgets_note": ""}


def widget_factories() -> dict[str, str]:
    """Every live widget of the book: label (``"ch01 sound_speed_widget"``) -> name in ``uwtutor.widgets``."""
    from uwtutor import widgets

    found = {}
    for name in widgets.__all__:
        obj = getattr(widgets, name)
        if name.endswith("_widget") and callable(obj):
            found[f"{obj.__module__.rsplit('.', 1)[-1]} {name}"] = name
    return dict(sorted(found.items()))


def _first_slider_and_image(panel: Any) -> tuple[Any, Any]:
    """The first slider of a ``slider_panel`` (its first dropdown if it has no slider) and its figure."""
    import ipywidgets as w

    def walk(widget: Any) -> Any:
        yield widget
        for child in getattr(widget, "children", ()):
            yield from walk(child)

    every = list(walk(panel))
    slider = next((x for x in every if isinstance(x, (w.FloatSlider, w.IntSlider, w.FloatLogSlider))),
                  None) or next(x for x in every if isinstance(x, w.Dropdown))     # choices only: a dropdown
    image = next(x for x in every if isinstance(x, w.Image))
    return slider, image


def _step(slider: Any, up: bool) -> Any:
    """The slider's value one step up or down (as one key press moves it), kept within its range."""
    import ipywidgets as w

    if isinstance(slider, w.Dropdown):               # the next (or previous) option, as an arrow key does
        options = [value for _, value in slider.options] if isinstance(slider.options[0], tuple) \
            else list(slider.options)
        i = options.index(slider.value) + (1 if up else -1)
        return options[min(max(i, 0), len(options) - 1)]
    if isinstance(slider, w.FloatLogSlider):
        import math

        exponent = math.log(slider.value, slider.base) + (slider.step if up else -slider.step)
        return slider.base ** min(max(exponent, slider.min), slider.max)
    return min(max(slider.value + (slider.step if up else -slider.step), slider.min), slider.max)


def _farther_end_is_up(slider: Any) -> bool:
    """Whether the slider's farther end (in steps) is above its value."""
    import ipywidgets as w

    if isinstance(slider, w.Dropdown):
        options = [value for _, value in slider.options] if isinstance(slider.options[0], tuple) \
            else list(slider.options)
        return options.index(slider.value) < len(options) / 2
    if isinstance(slider, w.FloatLogSlider):
        import math

        return math.log(slider.value, slider.base) < (slider.min + slider.max) / 2
    return slider.value < (slider.min + slider.max) / 2


def bench_widget_updates(repeats: int) -> dict[str, Any]:
    """What the kernel spends on one slider move of each widget (compute, draw, PNG), in ms, in this process.

    Each widget is built as in a notebook (the book's style on); its first slider is moved one step at a time
    towards its farther end, so that every move asks for a value not seen before (a panel shows a value seen
    before from the pictures it keeps), and the time of the assignment is taken: the panel's observer runs inside
    it, so it covers the computation, the redraw of the figure and its PNG, up to the new image being handed to the
    widget. The median of ``repeats`` moves after one warm-up move.
    """
    import statistics

    import matplotlib.pyplot as plt

    from uwtutor import widgets
    from uwtutor.plotting import use_book_style

    use_book_style()
    out = {}
    for label, name in widget_factories().items():
        panel = getattr(widgets, name)()
        slider, image = _first_slider_and_image(panel)
        times = []
        up, seen = _farther_end_is_up(slider), {slider.value}
        for move in range(repeats + 1):
            before = image.value
            value = _step(slider, up=up)
            if value in seen:                              # an end reached: the other way, if anything is new there
                up = not up
                value = _step(slider, up=up)
                if value in seen:
                    break
            seen.add(value)
            t0 = time.perf_counter()
            slider.value = value
            elapsed = time.perf_counter() - t0
            if image.value == before:
                raise RuntimeError(f"{label}: moving {slider.description!r} did not change the figure")
            if move:
                times.append(elapsed * 1000.0)
            else:
                warm_up = elapsed * 1000.0
        out[label] = statistics.median(times) if times else warm_up     # a short dropdown: one new value only
        plt.close("all")
    return {"widget_updates_ms": out}


#: The notebook code of the benchmark's JupyterLab session: the book's style, and ``build(name, legacy)``, which makes
#: a widget with the library's panel or, for reference, with the way widgets updated before (a new figure per update,
#: shown by ``plt.show()`` inside an ``Output`` widget, through the inline backend).
LATENCY_SETUP = """\
import importlib

import ipywidgets as w
import matplotlib.pyplot as plt

from uwtutor import widgets
from uwtutor.plotting import use_book_style

use_book_style()


def legacy_panel(sliders, draw):
    out = w.Output()

    def refresh(_change=None):
        with out:
            out.clear_output(wait=True)
            draw(None, **{name: s.value for name, s in sliders.items()})
            plt.show()

    for s in sliders.values():
        s.observe(refresh, names="value")
    refresh()
    return w.VBox([w.HBox(list(sliders.values())[:3]), w.HBox(list(sliders.values())[3:]), out])


def floor():
    # the least a widget update can cost here: one slider over a book-sized figure of one line, updated in place
    import numpy as np
    from uwtutor.widgets._panel import slider_panel

    x = np.linspace(0.0, 1.0, 200)

    def draw(fig, a):
        fig = fig or plt.figure(figsize=(7.6, 3.6))
        ax = fig.subplots()
        ax.plot(x, a * x)
        ax.set_ylim(-1.0, 1.0)
        return fig

    def update(fig, a):
        line = fig.axes[0].lines[0]
        line.set_ydata(a * x)
        return [line]

    return slider_panel({"a": w.FloatSlider(value=0.0, min=-1.0, max=1.0, step=0.01, description="a",
                                            continuous_update=False)}, draw, update)


def build(name, legacy):
    module = importlib.import_module(getattr(widgets, name).__module__)
    panel = module.slider_panel
    module.slider_panel = legacy_panel if legacy else panel
    try:
        return getattr(widgets, name)()
    finally:
        module.slider_panel = panel
"""


#: Medians per control measured with the same session before the widgets were made to answer at once (the commit
#: named in the file), printed beside today's by ``make bench``.
LATENCY_BASELINE_FILE = ROOT / "benchmarks" / "widget_latency_baseline.json"


def bench_widget_latency(repeats: int, only: str | None = None) -> dict[str, Any]:
    """End-to-end latency of every control of every widget in a real JupyterLab: key press -> new figure, in ms.

    A notebook runs in JupyterLab (``jupyterlab_session``: a local server and Debian's Chromium, offline) with one
    cell per widget, built as the library builds it (see ``LATENCY_SETUP``). Each control in turn is changed with the
    keyboard: a slider moves one step, always the same way (towards its farther end), so that every move asks for a
    value the widget has not shown yet and no cache flatters it; a dropdown takes its next option and a checkbox
    toggles (their few values come round again, as they do for a reader). One warm-up move, then ``repeats`` moves,
    of which the median and the worst are kept. ``only`` keeps the widgets whose label contains it. Needs Chromium
    and Playwright; without them the result says why.
    """
    import statistics
    import tempfile

    import nbformat

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import jupyterlab_session as lab

    factories = {label: name for label, name in widget_factories().items() if not only or only in label}
    code = [LATENCY_SETUP, "floor()"] + [f"build({name!r}, legacy=False)" for name in factories.values()]
    nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(c) for c in code])
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
    out: dict[str, dict[str, Any]] = {}
    with tempfile.TemporaryDirectory(prefix="uwtutor-bench-lab-") as tmp:
        root, work = Path(tmp, "root"), Path(tmp, "work")
        root.mkdir()
        nbformat.write(nb, root / "widgets.ipynb")
        try:
            with lab.lab_session(root, work) as session:
                page = lab.open_notebook(session, "widgets.ipynb")
                lab.run_cell(page, 0)
                # the floor of this machine at this moment: a one-line figure updated in place
                lab.run_cell(page, 1).locator(".jp-OutputArea img").first.wait_for(timeout=120_000)
                floor_ms = [lab.control_latency(page, 1, 0) for _ in range(repeats + 1)][1:]
                print(f"  floor (one line, in place): {statistics.median(floor_ms):.0f} ms", flush=True)
                for k, label in enumerate(factories):
                    index = 2 + k
                    lab.run_cell(page, index).locator(".jp-OutputArea img").first.wait_for(timeout=120_000)
                    controls: dict[str, dict[str, Any]] = {}
                    for c, control in enumerate(lab.widget_controls(page, index)):
                        forward = True
                        if control["kind"] == "slider":
                            below, above = lab.slider_room(page, index, c)
                            forward = above >= below
                        start = lab.control_value(page, index, c) if control["kind"] == "dropdown" else None
                        times = [lab.control_latency(page, index, c, forward, timeout=30_000)
                                 for _ in range(repeats + 1)][1:]
                        if start and lab.control_value(page, index, c) != start:
                            lab.control_latency(page, index, c, value=start, timeout=30_000)   # as it was
                        times = [ms for ms in times if ms == ms] or [float("nan")]      # NaN: no new figure
                        controls[control["label"] or f"control {c}"] = {
                            "kind": control["kind"], "median_ms": statistics.median(times), "max_ms": max(times)}
                    medians = [v["median_ms"] for v in controls.values()]
                    out[label] = {"controls": controls, "median_ms": max(medians),
                                  "max_ms": max(v["max_ms"] for v in controls.values())}
                    print(f"  {label}: " + ", ".join(f"{name} {v['median_ms']:.0f}" for name, v in controls.items())
                          + " ms", flush=True)
                if session.external:
                    raise RuntimeError(f"JupyterLab requested addresses off this machine: {session.external}")
        except lab.Unavailable as exc:
            return {"widget_latency": {}, "widget_latency_note": f"not measured in JupyterLab: {exc}"}
    return {"widget_latency": out, "widget_latency_note": "", "widget_latency_floor_ms": statistics.median(floor_ms)}


def latency_baseline() -> dict[str, Any]:
    """The committed medians per control from before (``{"commit": ..., "widgets": {label: {control: ms}}}``), or
    an empty record."""
    try:
        return json.loads(LATENCY_BASELINE_FILE.read_text(encoding="utf-8"))
    except FileNotFoundError:
        return {"commit": "", "widgets": {}}


def render_latency_table(latency: dict[str, Any], repeats: int, baseline: dict[str, Any] | None = None,
                         floor_ms: float | None = None) -> str:
    """Every control of every widget: median (and worst) key press -> new figure in JupyterLab, beside the median
    before (``baseline``), as Markdown; ``floor_ms``, the same for a one-line figure updated in place in the same
    session (what the machine costs at that moment whatever the widget does)."""
    baseline = latency_baseline() if baseline is None else baseline
    before = baseline.get("widgets", {})
    commit = baseline.get("commit", "")[:10] or "–"
    rows = ["| Widget | Control | Median now | Worst now | Median before (" + commit + ") | ≤ 150 ms |",
            "|:---|:---|---:|---:|---:|:---:|"]
    limit = TARGETS["widget_latency_ms"][1]
    for label in sorted(latency):
        for control, v in latency[label].get("controls", {}).items():
            old = before.get(label, {}).get(control)
            rows.append(f"| {label} | {control} | {v['median_ms']:.0f} ms | {v['max_ms']:.0f} ms | "
                        + (f"{old:.0f} ms" if old is not None else "–") + " | "
                        + ("PASS" if v["median_ms"] <= limit else "MISS") + " |")
    floor = "" if floor_ms is None else (f" The floor in the same session (a one-line figure updated in place): "
                                         f"{floor_ms:.0f} ms.")
    return "\n".join(rows) + f"\n\nMedians of {repeats} moves per control (after one warm-up move).{floor}"


def _memory_probe() -> None:
    """Run the 1000-run EKF study in this (fresh) process and print its memory use as JSON."""
    import tracemalloc

    from uwtutor.filters import range_only_ekf

    tracemalloc.start()
    inputs = ekf_study_inputs()
    inputs_mb = tracemalloc.get_traced_memory()[0] / 2**20
    tracemalloc.reset_peak()
    result = range_only_ekf(**inputs)
    study_peak_mb = tracemalloc.get_traced_memory()[1] / 2**20
    del result
    tracemalloc.stop()
    print(json.dumps({"peak_memory_mb": _peak_rss_mb(), "inputs_mb": inputs_mb,
                      "study_traced_peak_mb": study_peak_mb}))


def _peak_rss_mb() -> float:
    """The peak resident memory of this process [MB]: Linux's VmHWM, which starts afresh at exec. (getrusage's
    ru_maxrss does not: a process started from a large parent reports the parent's size, as the benchmark's own
    probe did once the parent had grown to 700 MB.)"""
    import resource

    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return float(line.split()[1]) / 1024                           # kB
    except OSError:                                                             # pragma: no cover - not Linux
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def bench_memory() -> dict[str, float]:
    proc = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--memory-probe"], capture_output=True,
                          text=True, check=True, cwd=ROOT)
    return json.loads(proc.stdout.strip().splitlines()[-1])


def machine_info() -> dict[str, Any]:
    import filterpy
    import numpy as np
    import scipy

    cpu = platform.processor() or ""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            cpu = next((line.split(":", 1)[1].strip() for line in fh if line.startswith("model name")), cpu)
    except OSError:
        pass
    return {"cpu_count": os.cpu_count(), "cpu": cpu, "python": platform.python_version(),
            "numpy": np.__version__, "scipy": scipy.__version__, "filterpy": filterpy.__version__,
            "platform": platform.platform(terse=True), "date": _dt.date.today().isoformat()}


def run_all(repeats: int, browser: bool = True) -> dict[str, Any]:
    results: dict[str, Any] = {"machine": machine_info(), "repeats": repeats,
                               "sizes": {"ekf_runs": EKF_RUNS, "ekf_steps": EKF_STEPS,
                                         "pf_particles": PF_PARTICLES, "pf_steps": PF_STEPS},
                               "targets": {k: list(v) for k, v in TARGETS.items()}}
    results.update(bench_ekf(repeats))
    results.update(bench_generic_ekf(repeats))
    results.update(bench_odometry_ekf(repeats))
    results.update(bench_navigate(repeats))
    results.update(bench_pf(repeats))
    results.update(bench_ekf_vs_numpy(repeats))
    results.update(bench_pf_vs_numpy(repeats))
    results.update(bench_pf_batched(repeats))
    results.update(bench_depth_filters(repeats))
    results.update(bench_pf_plaza(repeats))
    results.update(bench_single_run(repeats))
    results.update(bench_widgets(repeats))
    results.update(bench_widget_updates(repeats))
    print("Timing every control of every widget on new settings, in this process (a few minutes)...", flush=True)
    results.update(bench_first_visit(repeats))
    if browser:
        print("Timing every control of every widget in JupyterLab (about ten minutes)...", flush=True)
        results.update(bench_widget_latency(repeats))
    else:
        results.update({"widget_latency": {}, "widget_latency_note": "not measured in JupyterLab (--no-browser)"})
    results.update(bench_memory())
    results.update(bench_import_time(repeats))
    return results


# --- the table ------------------------------------------------------------------------------------------------

def _status(key: str, value: float, targets: dict[str, list[Any]]) -> str:
    op, limit = targets[key]
    ok = value <= limit if op == "<=" else value >= limit
    return "PASS" if ok else "MISS"


def _target(key: str, targets: dict[str, list[Any]], unit: str) -> str:
    op, limit = targets[key]
    sign = "≤" if op == "<=" else "≥"
    return f"{sign} {limit:g}{unit}"


def _agreement(max_rel_diff: float) -> str:
    """How the library's outputs compare with the plain-numpy reference's, in words."""
    if max_rel_diff == 0.0:
        return "outputs equal bit for bit"
    return f"outputs within {max_rel_diff:.0e} relative"


def _wall(results: dict[str, Any], name: str) -> str:
    """The wall times of the library and of plain numpy, and their ratio."""
    ours, theirs = results[f"{name}_vs_numpy_s"], results[f"{name}_numpy_s"]
    return f"{ours:.3f} s against {theirs:.3f} s of wall time ({ours / theirs:.2f}×)"


def render_table(results: dict[str, Any]) -> str:
    """The benchmark table as Markdown (deterministic: the same results always give the same text)."""
    t = results["targets"]
    sizes = results["sizes"]
    rows = [("Benchmark", "Measured", "Target", "Status")]
    ekf = results["ekf_study_s"]
    rows.append((f"Range-only EKF study, {sizes['ekf_runs']} runs × {sizes['ekf_steps']} steps, one batched call",
                 f"{ekf:.3f} s", _target("ekf_study_s", t, " s"), _status("ekf_study_s", ekf, t)))
    speedup = results["ekf_speedup_vs_filterpy"]
    rows.append((f"Speed-up over filterpy's EKF in a Python loop ({results['filterpy_sample_runs']} runs timed: "
                 f"{results['filterpy_sample_s']:.2f} s, scaled to {sizes['ekf_runs']}: "
                 f"{results['filterpy_scaled_s']:.1f} s)",
                 f"{speedup:.0f}×", _target("ekf_speedup_vs_filterpy", t, "×"),
                 _status("ekf_speedup_vs_filterpy", speedup, t)))
    if "generic_ekf_s" in results:
        g = results["generic_ekf_speedup_vs_filterpy"]
        rows.append((f"Generic batched EKF, 3-state model (position + range bias), {sizes['ekf_runs']} runs × "
                     f"{sizes['ekf_steps']} steps: {results['generic_ekf_s']:.2f} s; speed-up over filterpy's "
                     f"3-state EKF in a loop ({results['filterpy_sample_runs']} runs timed: "
                     f"{results['generic_filterpy_sample_s']:.2f} s, "
                     f"scaled: {results['generic_filterpy_scaled_s']:.1f} s)",
                     f"{g:.0f}×", _target("generic_ekf_speedup_vs_filterpy", t, "×"),
                     _status("generic_ekf_speedup_vs_filterpy", g, t)))
    if "odometry_ekf_s" in results:
        o = results["odometry_ekf_s"]
        rows.append((f"Generic EKF, odometry with gyro bias and range scale (5 states), {results['odometry_epochs']} "
                     f"epochs × {results['odometry_beacons']} beacons with missing ranges, one run",
                     f"{o:.2f} s", _target("odometry_ekf_s", t, " s"), _status("odometry_ekf_s", o, t)))
    if "navigate_plaza2_s" in results:
        n = results["navigate_plaza2_s"]
        cpu = results.get("navigate_plaza2_cpu_s")
        rows.append((f"navigate on the real Plaza 2 log, 4 beacons, {results['navigate_plaza2_epochs']} epochs, at "
                     f"its defaults: {results.get('navigate_plaza2_candidates', 4)} candidate models run as one "
                     "batch and scored" + (f" (CPU {cpu:.2f} s)" if cpu is not None else "") + "; the goal of a "
                     "quick answer is 0.3 s", f"{n:.2f} s", _target("navigate_plaza2_s", t, " s"),
                     _status("navigate_plaza2_s", n, t)))
    pf = results["pf_steps_per_s"]
    rows.append((f"Bootstrap PF, paper C depth/speed/pitch model, N = {sizes['pf_particles']}, "
                 f"{sizes['pf_steps']} steps (systematic resampling every step)",
                 f"{pf:,.0f} steps/s", _target("pf_steps_per_s", t, " steps/s"), _status("pf_steps_per_s", pf, t)))
    rows.append(("Same PF with filterpy's loop-based systematic_resample",
                 f"{results['pf_filterpy_resampler_steps_per_s']:,.0f} steps/s "
                 f"(ours {results['pf_speedup_vs_filterpy_resampler']:.1f}× faster)", "(reference)", "–"))
    if "ekf_vs_numpy_ratio" in results:
        r = results["ekf_vs_numpy_ratio"]
        rows.append((f"Range-only EKF study against the same EKF in plain numpy (benchmarks/plain_numpy.py: the "
                     f"same arithmetic, no checks), in turn in one process: {_wall(results, 'ekf')}; "
                     f"{_agreement(results['ekf_vs_numpy_max_rel_diff'])}; measured: the ratio of the CPU times",
                     f"{r:.2f}×",
                     _target("ekf_vs_numpy_ratio", t, "×"), _status("ekf_vs_numpy_ratio", r, t)))
    if "pf_vs_numpy_ratio" in results:
        r = results["pf_vs_numpy_ratio"]
        rows.append((f"Bootstrap PF above against the same PF in plain numpy on the same random stream, in turn in "
                     f"one process: {_wall(results, 'pf')}; {_agreement(results['pf_vs_numpy_max_rel_diff'])}; "
                     "measured: the ratio of the CPU times", f"{r:.2f}×",
                     _target("pf_vs_numpy_ratio", t, "×"), _status("pf_vs_numpy_ratio", r, t)))
    if "pf_plaza2_s" in results:
        p = results["pf_plaza2_s"]
        rows.append((f"Bootstrap PF, N = {results['pf_plaza2_particles']}, with the odometry model pair of navigate "
                     f"(heading, gyro bias, range scale) on the real Plaza 2 log, {results['pf_plaza2_epochs']} "
                     f"epochs × 4 beacons (position RMS error {results['pf_plaza2_rms_error_m']:.2f} m)",
                     f"{p:.2f} s", _target("pf_plaza2_s", t, " s"), _status("pf_plaza2_s", p, t)))
    labels = {"range_only": "range-only EKF (range_only_ekf), 1500 steps",
              "bias": "paper A's bias EKF (bias_ekf), 1500 steps",
              "navigate_model": "navigate's model pair (odometry, gyro bias, range scale; 4 beacons), 4091 epochs"}
    for name, label in labels.items():
        if f"single_{name}_ratio" in results:
            r = results[f"single_{name}_ratio"]
            rows.append((f"One run of the {label}, CPU per step against a plain-numpy loop doing the same arithmetic "
                         f"(outputs equal bit for bit): {results[f'single_{name}_us_per_step']:.0f} µs against "
                         f"{results[f'single_{name}_numpy_us_per_step']:.0f} µs", f"{r:.2f}×",
                         _target("single_run_ratio", t, "×"), _status("single_run_ratio", r, t)))
    batch = results.get("pf_batched")
    if batch:
        rows.append((f"Batched PFs: {batch['runs']} runs × N = {batch['particles']} × {batch['steps']} steps in one "
                     f"call (same PF; {batch['runs']} single-run calls: {batch['single_calls_s']:.2f} s)",
                     f"{batch['one_call_s']:.2f} s ({batch['speedup']:.2f}× the single calls)", "(reported)", "–"))
    depth = results.get("depth_filters")
    if depth:
        ms = depth["per_step_ms"]
        rows.append((f"Chapter 6's depth filters, one run of {depth['steps']} steps, time per step (EKF, bootstrap PF, "
                     "GPF, MMPF; N = 1000)",
                     " / ".join(f"{ms[k]:.2f}" for k in ("EKF", "PF", "GPF", "MMPF")) + " ms", "(reported)", "–"))
    widgets = results["widgets_ms"]
    if not widgets:
        rows.append(("Widget compute functions", results["widgets_note"], _target("widget_ms", t, " ms"), "–"))
    else:
        for name in sorted(widgets):
            ms = widgets[name]
            rows.append((f"Widget “{name}”: compute at default parameters", f"{ms:.1f} ms",
                         _target("widget_ms", t, " ms"), _status("widget_ms", ms, t)))
    latency = results.get("widget_latency", {})
    for label, kernel_ms in sorted(results.get("widget_updates_ms", {}).items()):
        if label in latency and "controls" in latency[label]:          # every control measured
            lat = latency[label]
            for control, v in lat["controls"].items():
                rows.append((f"Widget “{label}”, control “{control}”: key press → new figure in JupyterLab, median "
                             f"of {results['repeats']} moves (worst {v['max_ms']:.0f} ms; first slider in the kernel "
                             f"{kernel_ms:.0f} ms)", f"{v['median_ms']:.0f} ms", _target("widget_latency_ms", t, " ms"),
                             _status("widget_latency_ms", v["median_ms"], t)))
        elif label in latency:                                            # the first slider only (older results)
            lat = latency[label]
            rows.append((f"Widget “{label}”: slider → new figure in JupyterLab, median of {results['repeats']} "
                         f"moves (worst {lat['max_ms']:.0f} ms; in the kernel {kernel_ms:.0f} ms; the way before "
                         f"this panel: {lat['legacy_median_ms']:.0f} ms, worst {lat['legacy_max_ms']:.0f} ms)",
                         f"{lat['median_ms']:.0f} ms", _target("widget_latency_ms", t, " ms"),
                         _status("widget_latency_ms", lat["median_ms"], t)))
        else:
            rows.append((f"Widget “{label}”: slider → new figure, in the kernel only (compute, draw, PNG); "
                         f"{results.get('widget_latency_note', '')}", f"{kernel_ms:.0f} ms",
                         _target("widget_latency_ms", t, " ms"), _status("widget_latency_ms", kernel_ms, t)))
    for label, per in results.get("first_visit", {}).items():
        if per:
            control, v = max(per.items(), key=lambda kv: kv[1]["first_ms"])
            # a widget that refines in the background: its first picture is partial, and the full one comes later
            full = v.get("full_ms", v["first_ms"])
            partial = (f"; a first, partial picture, the full answer after {full:.0f} ms"
                       if full > 1.05 * v["first_ms"] + 1.0 else "")
            rows.append((f"Widget “{label}”, its slowest control “{control}” on a setting never seen before (compute, "
                         f"redraw, PNG in the kernel; CPU {v['first_cpu_ms']:.0f} ms{partial}), median of up to 3 new "
                         f"values; back on a setting seen before: {v['cached_ms']:.0f} ms", f"{v['first_ms']:.0f} ms",
                         _target("first_visit_ms", t, " ms"), _status("first_visit_ms", v["first_ms"], t)))
    mem = results["peak_memory_mb"]
    rows.append((f"Peak memory of the {sizes['ekf_runs']}-run EKF study (RSS of a fresh process; inputs "
                 f"{results['inputs_mb']:.0f} MB, study allocations {results['study_traced_peak_mb']:.0f} MB)",
                 f"{mem:.0f} MB", _target("peak_memory_mb", t, " MB"), _status("peak_memory_mb", mem, t)))
    rows += [tuple(r) for r in results.get("import_rows", [])]
    m = results["machine"]
    lines = ["| " + " | ".join(r) + " |" for r in rows]
    lines.insert(1, "|:---|---:|---:|:---:|")
    lines += ["", f"Measured {m['date']} on {m['cpu_count']} CPU(s) ({m['cpu'] or 'unknown CPU'}), "
                  f"Python {m['python']}, numpy {m['numpy']}, scipy {m['scipy']}, filterpy {m['filterpy']}; "
                  f"times are the best of {results['repeats']} repeats"
                  + (f", widget updates the median of {results['repeats']} slider moves." if results.get(
                      "widget_updates_ms") else ".")]
    return "\n".join(lines)


def page_table(page_text: str) -> str:
    """The text between the benchmark markers of the Performance page."""
    try:
        start = page_text.index(START_MARKER) + len(START_MARKER)
        end = page_text.index(END_MARKER, start)
    except ValueError:
        raise ValueError(f"{PAGE_FILE.name} must contain the markers {START_MARKER} and {END_MARKER}") from None
    return page_text[start:end].strip("\n")


def update_page(results: dict[str, Any], page: Path = PAGE_FILE) -> None:
    """Replace the table between the markers of the Performance page by the one rendered from ``results``."""
    text = page.read_text(encoding="utf-8")
    page_table(text)                                            # checks the markers
    start = text.index(START_MARKER) + len(START_MARKER)
    end = text.index(END_MARKER, start)
    page.write_text(text[:start] + "\n" + render_table(results) + "\n" + text[end:], encoding="utf-8")


#: The benchmarks ``--only`` can run alone.
SINGLE_BENCHMARKS: dict[str, Callable[[int], dict[str, Any]]] = {
    "ekf": bench_ekf, "generic_ekf": bench_generic_ekf, "odometry_ekf": bench_odometry_ekf,
    "navigate": bench_navigate, "pf": bench_pf, "ekf_vs_numpy": bench_ekf_vs_numpy, "pf_vs_numpy": bench_pf_vs_numpy,
    "pf_batched": bench_pf_batched, "depth_filters": bench_depth_filters, "pf_plaza": bench_pf_plaza,
    "single_run": bench_single_run, "first_visit": bench_first_visit, "import_time": bench_import_time,
}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--save", action="store_true",
                        help=f"write {RESULTS_FILE.relative_to(ROOT)} and the table of {PAGE_FILE.relative_to(ROOT)}")
    parser.add_argument("--repeats", type=int, default=5, help="timing repeats; the best is kept (default 5)")
    parser.add_argument("--no-browser", action="store_true",
                        help="skip the widget latency in JupyterLab (needs Debian's chromium and playwright)")
    parser.add_argument("--widgets", metavar="TEXT",
                        help="with --only widget_latency: only the widgets whose label contains TEXT (e.g. ch07)")
    parser.add_argument("--only", choices=sorted(SINGLE_BENCHMARKS) + ["widget_latency"],
                        help="run one benchmark and print its numbers (nothing is saved)")
    parser.add_argument("--memory-probe", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.memory_probe:
        _memory_probe()
        return 0
    if args.repeats < 1:
        parser.error("--repeats must be >= 1")
    if args.only:
        if args.save:
            parser.error("--only cannot be combined with --save (the table needs every benchmark)")
        if args.only == "widget_latency":       # every control of every widget in JupyterLab, as a table
            print("Timing every control of every widget in JupyterLab...", flush=True)
            latency = bench_widget_latency(args.repeats, only=args.widgets)
            print(json.dumps(latency, indent=2, sort_keys=True))
            print()
            print(latency["widget_latency_note"] or render_latency_table(latency["widget_latency"], args.repeats,
                                                                         floor_ms=latency.get("widget_latency_floor_ms")))
            return 0
        measured = SINGLE_BENCHMARKS[args.only](args.repeats)
        table = measured.pop("first_visit_table", None)
        print(json.dumps(measured, indent=2, sort_keys=True))
        if table:
            print()
            print(table)
        return 0
    print("Running the uwtutor benchmarks (about a minute)...", flush=True)
    results = run_all(args.repeats, browser=not args.no_browser)
    print()
    print(render_table(results))
    if results.get("first_visit_table"):
        print()
        print("Every widget's worst control on a setting never seen before (first visit: compute, redraw, PNG, in "
              "the kernel), and the same control back on a setting seen before (cached):")
        print(results["first_visit_table"])
    if results.get("widget_latency"):
        print()
        print("Every widget control, key press -> new figure in JupyterLab (before: "
              f"{LATENCY_BASELINE_FILE.relative_to(ROOT)}):")
        print(render_latency_table(results["widget_latency"], results["repeats"],
                                   floor_ms=results.get("widget_latency_floor_ms")))
    if args.save:
        RESULTS_FILE.write_text(json.dumps(results, indent=2, sort_keys=True) + "\n", encoding="utf-8")
        update_page(json.loads(RESULTS_FILE.read_text(encoding="utf-8")))     # the file's table, as the test reads it
        print(f"\nSaved {RESULTS_FILE.relative_to(ROOT)} and updated the table in {PAGE_FILE.relative_to(ROOT)}.")
    missed = [row for row in render_table(results).splitlines() if row.endswith("| MISS |")]
    if missed:
        print(f"\n{len(missed)} target(s) missed on this machine.")
    return 0


if __name__ == "__main__":
    sys.exit(main())
