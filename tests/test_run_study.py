"""run_study: the same numbers serially, on a process pool and on a Dask cluster; chunked sums; bounded memory."""

from __future__ import annotations

import functools
import multiprocessing
import sys
import tracemalloc
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest

from uwtutor.filters import range_only_ekf
from uwtutor.montecarlo import StudyResult, run_monte_carlo, run_study

K = 120
Q_STD, R_STD, P0_STD = 0.3, 2.0, 5.0


def _track(K: int = K) -> np.ndarray:
    theta = np.linspace(0.0, 1.5 * np.pi, K + 1)
    return 200.0 * np.column_stack([np.cos(theta), np.sin(theta)])


def draw_circle(rng: np.random.Generator, n: int, K: int = K) -> tuple[dict, np.ndarray]:
    """n runs of a vehicle circling the beacon: DR noise, range noise, a few missing ranges, an initial error."""
    track = _track(K)
    truth = track[1:] + np.cumsum(rng.normal(0.0, Q_STD, (n, K, 2)), axis=1)
    z = np.linalg.norm(truth, axis=-1) + rng.normal(0.0, R_STD, (n, K))
    z[rng.random((n, K)) < 0.1] = np.nan
    x0 = track[0] + rng.normal(0.0, P0_STD, (n, 2))
    return {"x0": x0, "z": z, "u": np.diff(track, axis=0)}, truth


def estimate_ekf(inputs: dict) -> object:
    return range_only_ekf(inputs["x0"], P0_STD**2 * np.eye(2), inputs["u"], inputs["z"], Q_STD**2 * np.eye(2),
                          R_STD**2)


NUMBERS = ("final_errors", "rmse", "mean_nees", "mean_nis", "times")


def assert_same_study(a: StudyResult, b: StudyResult) -> None:
    for name in NUMBERS:
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    assert a.nees_bounds == b.nees_bounds
    for x, y in zip(a.nis_bounds, b.nis_bounds):
        np.testing.assert_array_equal(x, y)
    assert (a.seed, a.chunk_size, a.n_chunks, a.n_runs, a.components, a.versions) == \
           (b.seed, b.chunk_size, b.n_chunks, b.n_runs, b.components, b.versions)


@pytest.fixture(scope="module")
def process_pool():
    # forkserver: workers do not inherit the threads of a Dask cluster running in this process
    with ProcessPoolExecutor(max_workers=2, mp_context=multiprocessing.get_context("forkserver")) as pool:
        yield pool


@pytest.fixture(scope="module")
def dask_executor():
    distributed = pytest.importorskip("distributed", reason="the optional extra uwtutor[scale] is not installed")
    import cloudpickle

    cloudpickle.register_pickle_by_value(sys.modules[__name__])      # the workers cannot import this test file
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0")
    client = distributed.Client(cluster)
    try:
        yield client.get_executor()
    finally:
        client.close()
        cluster.close()
        cloudpickle.unregister_pickle_by_value(sys.modules[__name__])


STUDY = dict(seed=20261201, chunk_size=300)


@pytest.fixture(scope="module")
def serial_study():
    study = run_study(draw_circle, estimate_ekf, 1000, **STUDY)
    assert study.n_chunks == 4 and study.final_errors.shape == (1000,)
    return study


def test_serial_and_process_pool_give_identical_numbers(serial_study, process_pool):
    assert_same_study(serial_study, run_study(draw_circle, estimate_ekf, 1000, executor=process_pool, **STUDY))
    # and a partial of a module-level function travels too
    short = functools.partial(draw_circle, K=40)
    assert_same_study(run_study(short, estimate_ekf, 200, seed=1, chunk_size=64),
                      run_study(short, estimate_ekf, 200, seed=1, chunk_size=64, executor=process_pool))


def test_serial_and_dask_give_identical_numbers(serial_study, dask_executor):
    assert_same_study(serial_study, run_study(draw_circle, estimate_ekf, 1000, executor=dask_executor, **STUDY))


def test_another_seed_or_chunk_size_draws_other_runs():
    a = run_study(draw_circle, estimate_ekf, 400, seed=5, chunk_size=200)
    b = run_study(draw_circle, estimate_ekf, 400, seed=6, chunk_size=200)
    c = run_study(draw_circle, estimate_ekf, 400, seed=5, chunk_size=100)
    assert not np.array_equal(a.final_errors, b.final_errors)
    assert not np.array_equal(a.final_errors, c.final_errors)


def test_one_chunk_equals_run_monte_carlo_on_the_same_draws():
    seed, n = 77, 500
    study = run_study(draw_circle, estimate_ekf, n, seed=seed, chunk_size=n)
    rng = np.random.default_rng(np.random.SeedSequence(seed).spawn(1)[0])     # the stream of chunk 0
    inputs, truth = draw_circle(rng, n)
    mc = run_monte_carlo(lambda **kw: estimate_ekf(kw), truth, **inputs)
    np.testing.assert_array_equal(study.final_errors, mc.final_errors)
    np.testing.assert_allclose(study.rmse, mc.rmse, rtol=1e-13)
    np.testing.assert_allclose(study.mean_nees, mc.mean_nees, rtol=1e-13)
    np.testing.assert_allclose(study.mean_nis, mc.mean_nis, rtol=1e-13)
    assert study.nees_bounds == mc.nees_bounds
    np.testing.assert_array_equal(study.nis_bounds[0], mc.nis_bounds[0])
    assert study.nees_fraction_within() == mc.nees_fraction_within()
    assert study.nis_fraction_within() == mc.nis_fraction_within()


class RunIndexedDraw:
    """Run j always draws the same numbers, however the runs are chunked (it counts the runs it has made).

    Serial use only: it keeps its place between calls, which is what makes chunkings comparable.
    """

    def __init__(self, seed: int) -> None:
        self.seed, self.next_run, self.sizes = seed, 0, []

    def __call__(self, rng, n):
        parts = [draw_circle(np.random.default_rng([self.seed, j]), 1) for j in range(self.next_run, self.next_run + n)]
        self.next_run += n
        self.sizes.append(n)
        inputs = {"x0": np.concatenate([p[0]["x0"] for p in parts]), "z": np.concatenate([p[0]["z"] for p in parts]),
                  "u": parts[0][0]["u"]}
        return inputs, np.concatenate([p[1] for p in parts])


def test_chunked_sums_equal_one_chunk():
    whole = run_study(RunIndexedDraw(9), estimate_ekf, 230, seed=0, chunk_size=230)
    draw = RunIndexedDraw(9)
    chunked = run_study(draw, estimate_ekf, 230, seed=0, chunk_size=50)
    assert draw.sizes == [50, 50, 50, 50, 30]
    np.testing.assert_array_equal(chunked.final_errors, whole.final_errors)
    np.testing.assert_allclose(chunked.rmse, whole.rmse, rtol=1e-12)
    np.testing.assert_allclose(chunked.mean_nees, whole.mean_nees, rtol=1e-12)
    np.testing.assert_allclose(chunked.mean_nis, whole.mean_nis, rtol=1e-12)
    assert chunked.n_chunks == 5 and whole.n_chunks == 1


class CountingDraw:
    def __init__(self) -> None:
        self.sizes: list[int] = []

    def __call__(self, rng, n):
        self.sizes.append(n)
        return draw_circle(rng, n)


def test_memory_is_bounded_by_the_chunk():
    chunk = 100
    draw = CountingDraw()
    seen = []

    def estimate(inputs):
        seen.append(inputs["z"].shape)
        return estimate_ekf(inputs)

    def peak_bytes(n_runs):
        tracemalloc.start()
        try:
            study = run_study(draw, estimate, n_runs, seed=3, chunk_size=chunk)
            return tracemalloc.get_traced_memory()[1], study
        finally:
            tracemalloc.stop()

    small, _ = peak_bytes(2 * chunk)
    large, study = peak_bytes(16 * chunk)
    assert max(draw.sizes) == chunk and sum(draw.sizes) == 18 * chunk
    assert max(s[0] for s in seen) == chunk
    one_chunk_of_trajectories = chunk * K * (2 + 4) * 8     # x and P of one chunk, in bytes
    assert small > one_chunk_of_trajectories                 # the measurement sees the chunk's arrays...
    assert large < small + 2 * one_chunk_of_trajectories     # ...and 8 times the runs cost no more chunks
    # nothing of size n_runs x K is kept
    for name, value in study.as_dict().items():
        assert np.size(value) < 16 * chunk * K, name


def test_components_score_the_position_of_a_bias_state():
    from uwtutor.filters import extended_kalman_filter
    from uwtutor.models import DeadReckoning, RangeToBeacon

    def draw(rng, n):
        inputs, truth = draw_circle(rng, n)
        inputs["z"] = inputs["z"] + 3.0                        # a constant range bias
        return inputs, truth

    def estimate(inputs):
        x0 = np.column_stack([inputs["x0"], np.zeros(len(inputs["x0"]))])
        return extended_kalman_filter(DeadReckoning(np.diag([Q_STD**2, Q_STD**2, 1e-6])),
                                      RangeToBeacon([0.0, 0.0], R=R_STD**2, n=3, bias_index=2), x0,
                                      np.diag([P0_STD**2, P0_STD**2, 16.0]), inputs["u"], inputs["z"])

    study = run_study(draw, estimate, 200, seed=4, chunk_size=100, components=(0, 1))
    assert study.components == (0, 1)
    assert study.nees_bounds == run_study(draw_circle, estimate_ekf, 200, seed=4, chunk_size=100).nees_bounds
    with pytest.raises(ValueError,
                       match="truth \\(from draw\\) must have shape .* hold the 3 state components or the 1"):
        run_study(draw, estimate, 10, seed=4, components=(2,))


def test_a_shared_truth_and_a_filter_without_innovations():
    from types import SimpleNamespace

    def draw(rng, n):                                       # every run has the same true track
        inputs, _ = draw_circle(rng, n)
        return inputs, _track()[1:]

    def estimate(inputs):
        res = estimate_ekf(inputs)
        return SimpleNamespace(x=res.x, P=res.P, times=res.times)

    study = run_study(draw, estimate, 60, seed=2, chunk_size=25)
    assert study.mean_nis is None and study.nis_bounds is None
    with pytest.raises(ValueError, match="no NIS"):
        study.nis_fraction_within()
    rng = np.random.default_rng(np.random.SeedSequence(2).spawn(3)[0])
    inputs, truth = draw(rng, 25)
    errors = np.linalg.norm(estimate(inputs).x - truth, axis=-1)
    np.testing.assert_array_equal(study.final_errors[:25], errors[:, -1])


def _not_a_pair(rng, n):
    return draw_circle(rng, n)[0]


def _too_few_runs(inputs):
    res = estimate_ekf(inputs)
    return type(res)(**{**res.__dict__, "x": res.x[:-1]})


@pytest.mark.parametrize("kwargs, error, match", [
    (dict(n_runs=0), ValueError, "n_runs must be >= 1"),
    (dict(n_runs=2.5), TypeError, "n_runs must be an integer"),
    (dict(chunk_size=0), ValueError, "chunk_size must be >= 1"),
    (dict(seed=-1), ValueError, "seed must be >= 0"),
    (dict(seed=None), TypeError, "seed must be an integer"),
    (dict(draw=3), TypeError, "draw must be a function"),
    (dict(estimate=None), TypeError, "estimate must be a function"),
    (dict(draw=_not_a_pair), TypeError, "must return a pair"),
    (dict(estimate=lambda inputs: inputs), TypeError, "must return a FilterResult"),
    (dict(estimate=_too_few_runs), ValueError, "must return the 10 runs"),
    (dict(components=[0, 0]), ValueError, "components must be a non-empty list of distinct"),
    (dict(components=[0, 5]), ValueError, "beyond the 2"),
    (dict(executor=object()), TypeError, "executor must have a submit"),
    (dict(confidence=1.0), ValueError, "confidence must lie strictly between 0 and 1"),
])
def test_bad_input_is_named(kwargs, error, match):
    args = dict(draw=draw_circle, estimate=estimate_ekf, n_runs=20, seed=1, chunk_size=10)
    args.update(kwargs)
    with pytest.raises(error, match=match):
        run_study(args.pop("draw"), args.pop("estimate"), args.pop("n_runs"), **args)


def test_a_process_pool_needs_picklable_functions(process_pool):
    with pytest.raises(TypeError, match="estimate must be picklable.*functools.partial"):
        run_study(draw_circle, lambda inputs: estimate_ekf(inputs), 20, seed=1, executor=process_pool)
