"""Cooperative cancellation (``uwtutor._cancel``): the filter loops' checkpoints stop a computation no longer wanted,
and change nothing otherwise.

Every long loop a widget's refinement runs is covered: the engine's step loop (``bias_ekf``, ``robust_range_kf``),
the packed EKF's blocks (``range_only_ekf``) and ``run_filter``'s loop (``cooperative_ekf``). For each: the result
computed inside a ``cancel_when`` whose test stays false is the result computed outside, bit for bit, and the test
was asked at the loop's steps; a test that turns true mid-run raises ``Cancelled`` at once (no slower fallback run
after it) and a later run gives the full result again.
"""

from __future__ import annotations

import dataclasses
import threading

import numpy as np
import pytest

from uwtutor._cancel import Cancelled, cancel_when, checkpoint
from uwtutor.filters import bias_ekf, cooperative_ekf, range_only_ekf, robust_range_kf
from uwtutor.models.bias import paper_a_process_noise
from uwtutor.scenarios import paper_a, paper_b


def _bias():
    sc = paper_a.make(np.random.default_rng(3), n_runs=4, params=paper_a.PaperAParameters(n_obs=300))
    x0 = np.column_stack([np.asarray(sc.true_positions)[:, 0] + 20.0, np.zeros(4)])
    return lambda: bias_ekf(x0, np.eye(3), sc.dr_displacements, sc.ranges, paper_a_process_noise(1.0), 5.0)


def _range_only():
    rng = np.random.default_rng(1)
    theta = np.linspace(0.0, 4 * np.pi, 301)
    track = 300.0 * np.column_stack([np.cos(theta), np.sin(theta)])
    u = np.diff(track, axis=0) + rng.normal(0.0, 0.5, (5, 300, 2))
    z = np.linalg.norm(track[1:], axis=1) + rng.normal(0.0, 2.0, (5, 300))
    z[:, ::7] = np.nan
    x0 = track[0] + rng.normal(0.0, 20.0, (5, 2))
    return lambda: range_only_ekf(x0, np.eye(2) * 400.0, u, z, np.eye(2) * 0.25, 4.0)


def _robust():
    t = np.arange(400.0)
    z = 1500.0 + 2.0 * t + np.random.default_rng(0).normal(0.0, np.sqrt(2.0), 400)
    z[100:110] += 80.0
    return lambda: robust_range_kf(z, 1.0)


def _cooperative():
    sc = paper_b.make(np.random.default_rng(0), n_runs=3)
    p = paper_b.PARAMETERS
    return lambda: cooperative_ekf(p.x1, np.diag([1e4, 1e4, 1.0, 1.0]), sc.dr_displacements, sc.ranges, p.Q, p.R,
                                   leader=sc.leader_broadcast, dt=p.interval)


#: Each filter path a widget's refinement runs, with the least number of checkpoints a run of it passes.
RUNS = {"engine (bias_ekf)": (_bias, 300), "packed EKF blocks (range_only_ekf)": (_range_only, 300 // 32),
        "engine with a gate (robust_range_kf)": (_robust, 400), "run_filter (cooperative_ekf)": (_cooperative, 50)}


def _same(a, b):
    for f in dataclasses.fields(a):
        x, y = getattr(a, f.name), getattr(b, f.name)
        if isinstance(x, dict):
            assert x.keys() == y.keys()
            for name in x:
                np.testing.assert_array_equal(x[name], y[name], err_msg=f"extras[{name!r}]")
        elif x is None:
            assert y is None, f.name
        else:
            np.testing.assert_array_equal(x, y, err_msg=f.name)


class _Counter:
    """A cancellation test that says "stop" from its ``stop_at``-th call on (never when None), counting calls."""

    def __init__(self, stop_at=None):
        self.calls, self.stop_at = 0, stop_at

    def __call__(self):
        self.calls += 1
        return self.stop_at is not None and self.calls >= self.stop_at


@pytest.mark.parametrize("name", RUNS)
def test_a_run_not_cancelled_is_the_same_bit_for_bit(name):
    make, least = RUNS[name]
    run = make()
    plain = run()
    asked = _Counter()
    with cancel_when(asked):
        watched = run()
    _same(plain, watched)
    assert asked.calls >= least             # the loop did ask, once per step (or block of steps)


@pytest.mark.parametrize("name", RUNS)
def test_a_run_cancelled_mid_way_stops_at_once_and_leaves_nothing(name):
    make, least = RUNS[name]
    run = make()
    plain = run()
    stop = _Counter(stop_at=max(2, least // 2))
    with pytest.raises(Cancelled), cancel_when(stop):
        run()
    assert stop.calls == stop.stop_at       # raised at the first "stop", not caught by a fallback that runs on
    _same(plain, run())                     # a later run is whole


def test_the_checkpoint_is_silent_outside_and_in_other_threads():
    checkpoint()                            # nothing asked in this thread
    stopped = threading.Event()
    result = {}

    def other():
        with cancel_when(stopped.is_set):
            stopped.set()
            try:
                checkpoint()
            except Cancelled:
                result["other"] = "cancelled"

    thread = threading.Thread(target=other)
    with cancel_when(lambda: False):
        thread.start()
        thread.join(30.0)
        checkpoint()                        # this thread's test, not the other's
    assert result == {"other": "cancelled"}


def test_blocks_nest_and_the_outer_test_comes_back():
    with cancel_when(lambda: True):
        with cancel_when(lambda: False):
            checkpoint()
        with pytest.raises(Cancelled):
            checkpoint()
    checkpoint()


def test_cancel_when_refuses_what_is_not_callable():
    with pytest.raises(TypeError, match="test must be a callable"):
        cancel_when(True)
