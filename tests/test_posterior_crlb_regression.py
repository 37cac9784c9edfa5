"""posterior_crlb against the bounds its former, hand-assembled implementation gave (saved arrays).

``posterior_crlb`` once assembled its own transition, process noise and range rows; it is now a front end that
builds the state from the blocks of :mod:`uwtutor.models.blocks` and the range model
:class:`~uwtutor.models.RangeToBeacon`, and runs :func:`~uwtutor.observability.model_posterior_crlb`'s recursion.
The sums are ordered differently, so the last bits may change: this test bounds the change to round-off over every
kind of input the function takes. ``tests/data/posterior_crlb_before.npz`` holds the bounds of the former
implementation (commit 52dad1d) on the cases below; ``python tests/test_posterior_crlb_regression.py --save``
rewrites it with the installed implementation (only ever needed if a case is added, and then from the former code).
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from uwtutor.errors import UnobservableWarning
from uwtutor.observability import posterior_crlb

SAVED = Path(__file__).parent / "data" / "posterior_crlb_before.npz"
K, M, DT = 60, 6, 2.0


def _track(K: int = K) -> np.ndarray:
    """A turn then a straight leg, 150-400 m from the beacon at the origin."""
    s = np.linspace(0.0, 1.0, K)
    theta = 0.2 + 2.5 * np.minimum(s, 0.6)
    radius = 150.0 + 250.0 * s
    return np.column_stack([radius * np.cos(theta), radius * np.sin(theta)])


def _coupled(n: int, rng: np.random.Generator, scale: float) -> np.ndarray:
    """A positive-definite (n, n) matrix with off-diagonal terms (a process noise that couples the states)."""
    A = rng.normal(size=(n, n))
    return scale * (A @ A.T / n + 0.1 * np.eye(n))


def cases() -> dict[str, dict]:
    """The calls compared, by name (every input drawn from fixed seeds)."""
    rng = np.random.default_rng(20261207)
    p = _track()
    tracks = p + np.cumsum(rng.normal(0.0, 1.0, (M, K, 2)), axis=1)
    sigma = np.linspace(1.0, 3.0, K)
    gaps = sigma.copy()
    gaps[[0, 7, 8, 9, 30]] = np.inf                                  # epochs without a range
    sigma_runs = rng.uniform(1.0, 3.0, (M, K))
    sigma_runs[rng.random((M, K)) < 0.2] = np.inf
    ship = np.column_stack([np.linspace(-100.0, 300.0, K), np.full(K, -50.0)])
    ships = ship + rng.normal(0.0, 5.0, (M, K, 2))
    times = DT * np.arange(K)
    times_x0 = np.concatenate([[-1.5], DT * np.arange(K) + 0.25 * rng.random(K)])   # K + 1, uneven steps
    P0 = {2: np.diag([400.0, 100.0]), 3: np.diag([400.0, 100.0, 9.0]), 4: np.diag([400.0, 100.0, 0.04, 0.04]),
          5: np.diag([400.0, 100.0, 9.0, 0.04, 0.04])}
    Q2 = np.array([[0.25, 0.05], [0.05, 0.16]])
    return {
        "plain": dict(positions=p, beacon=[0.0, 0.0], sigma=sigma, Q=Q2, P0=P0[2]),
        "bias": dict(positions=p, beacon=[10.0, -20.0], sigma=gaps, Q=np.diag([0.25, 0.25, 1e-4]), P0=P0[3],
                     bias=True),
        "bias, position-only Q": dict(positions=p, beacon=[10.0, -20.0], sigma=2.0, Q=Q2, P0=P0[3], bias=True),
        "current": dict(positions=p, beacon=[0.0, 0.0], sigma=2.0, Q=Q2, P0=P0[4], times=times, current=True),
        "current, K + 1 uneven times": dict(positions=p, beacon=[0.0, 0.0], sigma=gaps,
                                            Q=np.diag([0.25, 0.25, 1e-6, 1e-6]), P0=P0[4], times=times_x0,
                                            current=True),
        "bias and current": dict(positions=p, beacon=[0.0, 0.0], sigma=sigma, Q=np.diag([0.25, 0.25, 1e-4, 1e-6, 1e-6]),
                                 P0=P0[5], times=times, bias=True, current=True),
        "bias and current, coupled Q": dict(positions=p, beacon=[0.0, 0.0], sigma=sigma, Q=_coupled(5, rng, 0.1),
                                            P0=P0[5], times=times_x0, bias=True, current=True),
        "moving beacon, gaps": dict(positions=p, beacon=ship, sigma=gaps, Q=Q2, P0=P0[2]),
        "per-step Q (K, 2, 2)": dict(positions=p, beacon=[0.0, 0.0], sigma=sigma,
                                     Q=np.stack([Q2 * (1 + 0.5 * np.sin(k)) for k in range(K)]), P0=P0[3],
                                     bias=True),
        "per-step Q (K, n, n)": dict(positions=p, beacon=ship, sigma=gaps,
                                     Q=np.stack([_coupled(4, rng, 0.05) for _ in range(K)]), P0=P0[4], times=times,
                                     current=True),
        "per run": dict(positions=tracks, beacon=ships, sigma=sigma_runs, Q=Q2,
                        P0=np.stack([P0[3] * (1 + j) for j in range(M)]), bias=True),
        "per run, shared track": dict(positions=p, beacon=ships, sigma=sigma_runs, Q=Q2, P0=P0[2]),
        "mean over runs": dict(positions=tracks, beacon=[0.0, 0.0], sigma=2.0, Q=Q2, P0=P0[2], mean_over_runs=True),
        "mean over runs, bias, per-run sigma": dict(positions=tracks, beacon=ships, sigma=sigma_runs,
                                                    Q=np.diag([0.25, 0.25, 1e-4]), P0=P0[3], bias=True,
                                                    mean_over_runs=True),
        "mean over runs, bias and current": dict(positions=tracks, beacon=[0.0, 0.0], sigma=gaps,
                                                 Q=np.diag([0.25, 0.25, 1e-4, 1e-6, 1e-6]), P0=P0[5], times=times,
                                                 bias=True, current=True, mean_over_runs=True),
        "sigma as one-element arrays": dict(positions=tracks, beacon=[0.0, 0.0], sigma=[[2.0]], Q=Q2, P0=P0[2]),
        "sigma one per run (M, 1)": dict(positions=tracks, beacon=[0.0, 0.0], sigma=sigma_runs[:, :1], Q=Q2,
                                         P0=P0[3], bias=True),
        "sigma one row (1, K), beacon (1, K, 2)": dict(positions=tracks, beacon=ship[None], sigma=gaps[None], Q=Q2,
                                                       P0=P0[2], mean_over_runs=True),
        "no range at all": dict(positions=p, beacon=[0.0, 0.0], sigma=np.inf, Q=Q2, P0=P0[3], bias=True),
        "nearly uninformative prior, Q = 0": dict(positions=p, beacon=[0.0, 0.0], sigma=2.0, Q=np.zeros((2, 2)),
                                                  P0=1e12 * np.eye(3), bias=True),
    }


def _bound(kwargs: dict) -> np.ndarray:
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnobservableWarning)           # no case puts a position on the beacon
        return posterior_crlb(**kwargs, full=True)


@pytest.mark.parametrize("name", list(cases()))
def test_equals_the_former_implementation_to_round_off(name):
    before = np.load(SAVED)[name]
    after = _bound(cases()[name])
    assert after.shape == before.shape
    # relative to each bound's largest entry: the off-diagonal terms may be near zero
    scale = np.abs(before).max(axis=(-2, -1), keepdims=True)
    assert np.max(np.abs(after - before) / scale) < 1e-10


if __name__ == "__main__":
    if sys.argv[1:] != ["--save"]:
        sys.exit(f"usage: python {sys.argv[0]} --save  (rewrites {SAVED} with the installed posterior_crlb)")
    SAVED.parent.mkdir(exist_ok=True)
    np.savez_compressed(SAVED, **{name: _bound(kwargs) for name, kwargs in cases().items()})
    print(f"wrote {SAVED}")
