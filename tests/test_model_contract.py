"""The model contract: every motion and measurement model of the library, found by discovery, is held to what the
filters assume of it.

- ``F`` (``H``) is the Jacobian of ``f`` (``h``): checked against central finite differences at random states;
- ``linearize`` returns the same ``f, F, Q`` as the separate calls of a motion model, and the same ``h, H`` of a
  measurement model with a mask that is True wherever the Jacobian is defined (a fused kernel must not drift);
- a batch is the stack of its single runs (``M`` runs at once equal ``M`` calls with ``M = 1``);
- ``Q`` and ``R`` are symmetric positive semi-definite;
- ``sample`` draws with the mean ``f`` (``h``) and the covariance ``Q`` (``R``), to within the statistical error of
  the draws (first order for a model whose noise enters through its inputs);
- ``log_likelihood`` is the Gaussian log-density of ``z`` around ``h`` with covariance ``R`` (up to a constant
  per run).

A new public model class of ``uwtutor`` without a case here fails :func:`test_every_model_has_a_case`.
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import pytest

import uwtutor
from uwtutor import models
from uwtutor.models import MeasurementModel, MotionModel, ModelPair
from uwtutor.models.bias import BiasRateDeadReckoning, bias_rate_process_noise
from uwtutor.models.cooperative import CooperativeMotion, SquaredRangePair
from uwtutor.models.robust import ConstantVelocity, PositionMeasurement, step_lengths


@dataclass
class MotionCase:
    """A motion model, a state around which to test it (``(n,)``; runs are drawn around it with ``spread``), the
    input of the step and the step index."""

    model: MotionModel
    state: np.ndarray
    spread: np.ndarray
    u: Any
    k: int = 0
    #: True where the noise enters through the inputs, so that the mean and covariance of ``sample`` equal ``f``
    #: and ``Q`` to first order only (the tolerance then allows the second-order terms of the small noise used).
    first_order: bool = False


@dataclass
class MeasurementCase:
    model: MeasurementModel
    state: np.ndarray
    spread: np.ndarray
    k: int = 0


BEACONS = {"A": (0.0, 0.0), "B": (40.0, 0.0), "C": (40.0, 30.0)}


def _block_state() -> models.BlockMotion:
    """A state of four blocks: a pose turned by a gyro bias, the bias, a range scale and a clock."""
    return models.BlockMotion(
        models.OdometryPose(0.02, 0.003, gyro_bias="gyro_bias"), models.RandomWalk("gyro_bias", 1e-4),
        models.RandomWalk("scale", 1e-5), models.OffsetAndRate("clock", rate_walk=1e-7, offset_walk=1e-6), dt=0.5)


def _motion_cases() -> dict[str, Callable[[], MotionCase]]:
    return {
        "DeadReckoning": lambda: MotionCase(
            models.DeadReckoning(Q=np.diag([0.25, 0.25, 0.01])), np.array([100.0, 0.0, 3.0]),
            np.array([20.0, 20.0, 1.0]), np.array([2.0, 1.0])),
        "BiasRateDeadReckoning": lambda: MotionCase(
            BiasRateDeadReckoning(bias_rate_process_noise(0.5, rate_sigma=0.01, dt=5.0), dt=5.0),
            np.array([50.0, -20.0, 5.0, 0.1]), np.array([20.0, 20.0, 2.0, 0.05]), np.array([1.0, 2.0])),
        "CooperativeMotion": lambda: MotionCase(
            CooperativeMotion(8.0, np.diag([100.0, 100.0, 4.0, 4.0, 0.05**2, 0.05**2])),
            np.array([0.0, 0.0, 0.5, 0.5]), np.array([50.0, 50.0, 0.3, 0.3]), np.array([16.0, 0.0])),
        "DepthSpeedPitch": lambda: MotionCase(
            models.DepthSpeedPitch(T=0.5, process_std=[0.1, 0.05, 0.01]), np.array([10.0, 2.0, 0.3]),
            np.array([5.0, 0.5, 0.2]), None),
        "PitchManeuver": lambda: MotionCase(
            models.PitchManeuver(pitch_target=0.3, time_constant=1.0, T=0.05, process_std=[0.1, 0.05, 0.01]),
            np.array([10.0, 2.0, 0.1]), np.array([5.0, 0.5, 0.2]), None, k=3),
        "LinearMotion": lambda: MotionCase(
            models.LinearMotion(F=[[1.0, 1.0], [0.0, 1.0]], Q=np.diag([0.01, 0.04]), B=[[0.5], [1.0]]),
            np.array([10.0, 2.0]), np.array([5.0, 1.0]), np.array([0.3])),
        "OdometryMotion": lambda: MotionCase(
            models.OdometryMotion(0.02, 0.003, gyro_bias=True, scale=True, dt=0.5),
            np.array([20.0, 5.0, 0.4, 0.004, 1.05]), np.array([10.0, 10.0, 1.0, 0.002, 0.02]),
            np.array([0.5, 0.06]), first_order=True),
        "BlockMotion": lambda: MotionCase(
            _block_state(), np.array([20.0, 5.0, 0.4, 0.004, 1.05, 1e-3, 2e-5]),
            np.array([10.0, 10.0, 1.0, 0.002, 0.02, 1e-3, 1e-5]), np.array([0.5, 0.06]), k=2, first_order=True),
        "ConstantVelocity": lambda: MotionCase(
            ConstantVelocity(d=2, q=2.0, steps=step_lengths(5, dt=1.0)), np.array([1500.0, -20.0, -2.0, 1.0]),
            np.array([50.0, 50.0, 1.0, 1.0]), None, k=2),
    }


def _measurement_cases() -> dict[str, Callable[[], MeasurementCase]]:
    return {
        "RangeToBeacon": lambda: MeasurementCase(
            models.RangeToBeacon((0.0, 0.0), R=4.0, n=3, bias_index=2), np.array([300.0, 400.0, 1.5]),
            np.array([50.0, 50.0, 1.0])),
        "MultiplicativeRange": lambda: MeasurementCase(
            models.MultiplicativeRange((0.0, 0.0), R=0.49, mu_gamma=0.98, sigma_gamma=1 / 1500),
            np.array([3000.0, 4000.0]), np.array([300.0, 300.0])),
        "BeaconRanges": lambda: MeasurementCase(
            models.BeaconRanges(BEACONS, R=0.01, layout=models.StateLayout.odometry(scale=True)),
            np.array([13.0, 14.0, 0.3, 1.07]), np.array([5.0, 5.0, 0.5, 0.02])),
        "BlockRanges": lambda: MeasurementCase(
            models.BlockRanges(BEACONS, R=0.01, scale="scale", bias="range_bias", state=models.BlockMotion(
                models.RandomWalk("scale"), models.OdometryPose(0.02, 0.003), models.RandomWalk("range_bias", size=3))),
            np.array([1.07, 13.0, 14.0, 0.3, 0.5, -0.2, 0.1]), np.array([0.02, 5.0, 5.0, 0.5, 0.3, 0.3, 0.3])),
        "OneWayTravelTimeRanges": lambda: MeasurementCase(
            models.OneWayTravelTimeRanges(BEACONS, R=0.25, state=_block_state(), scale="scale"),
            np.array([13.0, 14.0, 0.3, 0.004, 1.07, 1e-3, 2e-5]),
            np.array([5.0, 5.0, 0.5, 0.002, 0.02, 1e-3, 1e-5])),
        "SquaredRangePair": lambda: MeasurementCase(
            SquaredRangePair(np.array([[0.0, 0.0], [5.0, 3.0]]), np.array([[30.0, 40.0]]), 10.0, np.eye(10)),
            np.array([30.0, 40.0, 0.2, -0.1]), np.array([10.0, 10.0, 0.1, 0.1])),
        "LinearMeasurement": lambda: MeasurementCase(
            models.LinearMeasurement(H=[[1.0, 0.5]], R=4.0), np.array([10.0, 2.0]), np.array([5.0, 1.0])),
        "DirectMeasurement": lambda: MeasurementCase(
            models.DirectMeasurement(n=4, indices=[0, 2], R=[[4.0, 1.0], [1.0, 2.0]]),
            np.array([10.0, 2.0, -3.0, 0.5]), np.array([5.0, 1.0, 2.0, 0.2])),
        "DepthSensors": lambda: MeasurementCase(
            models.DepthSensors(), np.array([12.0, 1.5, 0.1]), np.array([3.0, 0.3, 0.05])),
        "PositionMeasurement": lambda: MeasurementCase(
            PositionMeasurement(2, np.array([np.eye(2), [[4.0, 1.0], [1.0, 3.0]]])),
            np.array([3.0, 4.0, 1.0, 0.0]), np.array([5.0, 5.0, 1.0, 1.0]), k=1),
    }


MOTION_CASES = _motion_cases()
MEASUREMENT_CASES = _measurement_cases()
#: Model pairs are checked through their two halves, which are cases above.
PAIR_CLASSES = {"DepthSpeedPitchModel", "PitchManeuverModel", "LinearGaussianModel"}
#: Bases a user subclasses, without a model of their own: each of their library subclasses is a case above.
ABSTRACT_BASES = {"BlockMeasurement"}


def _all_subclasses(base: type) -> set[type]:
    found: set[type] = set()
    for sub in base.__subclasses__():
        found |= {sub} | _all_subclasses(sub)
    return found


def _discover() -> dict[str, set[str]]:
    skip = (".widgets", ".exercises")
    for module in pkgutil.walk_packages(uwtutor.__path__, "uwtutor."):
        if not module.name.endswith(skip) and not any(s + "." in module.name for s in skip):
            try:
                importlib.import_module(module.name)
            except ImportError:      # an optional dependency that is not installed (gtsam, dask)
                continue
    public = {c for c in _all_subclasses(MotionModel) | _all_subclasses(MeasurementModel) | _all_subclasses(ModelPair)
              if c.__module__.startswith("uwtutor.") and not c.__name__.startswith("_")}
    public = {c for c in public if c.__name__ not in ABSTRACT_BASES}
    return {
        "motion": {c.__name__ for c in public if issubclass(c, MotionModel)},
        "measurement": {c.__name__ for c in public if issubclass(c, MeasurementModel)},
        "pair": {c.__name__ for c in public if issubclass(c, ModelPair)},
    }


def test_every_model_has_a_case():
    found = _discover()
    assert found["motion"] - set(MOTION_CASES) == set(), "motion models without a case in this contract"
    assert found["measurement"] - set(MEASUREMENT_CASES) == set(), "measurement models without a case"
    assert found["pair"] - PAIR_CLASSES == set(), "model pairs without an entry in PAIR_CLASSES"
    # and no case names a class that is gone
    assert set(MOTION_CASES) <= found["motion"] and set(MEASUREMENT_CASES) <= found["measurement"]


def _states(case: MotionCase | MeasurementCase, M: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return case.state + case.spread * rng.uniform(-1.0, 1.0, (M, case.state.size))


def _numeric_jacobian(fun: Callable[[np.ndarray], np.ndarray], x: np.ndarray) -> np.ndarray:
    """Central differences of ``fun`` ``(M, n) -> (M, q)`` at ``x``: ``(M, q, n)``; each step scaled to its
    coordinate so that both metres and radians are resolved."""
    cols = []
    for i in range(x.shape[-1]):
        eps = 1e-6 * np.maximum(1.0, np.abs(x[:, i]))
        dx = np.zeros_like(x)
        dx[:, i] = eps
        cols.append((fun(x + dx) - fun(x - dx)) / (2 * eps[:, None]))
    return np.stack(cols, axis=-1)


def _batched(J: np.ndarray, M: int, rows: int, n: int) -> np.ndarray:
    J = np.asarray(J, dtype=float)
    return np.broadcast_to(J, (M, rows, n)) if J.ndim == 2 else J


def _assert_psd(C: np.ndarray, what: str) -> None:
    C = np.asarray(C, dtype=float)
    np.testing.assert_allclose(C, np.swapaxes(C, -1, -2), atol=1e-12 * max(1.0, np.abs(C).max()),
                               err_msg=f"{what} is not symmetric")
    assert np.linalg.eigvalsh(C).min() >= -1e-9 * max(1.0, np.abs(C).max()), f"{what} is not positive semi-definite"


def _sample_covariance_tolerance(cov: np.ndarray, N: int) -> np.ndarray:
    """Six standard errors of a sample covariance of N Gaussian draws: sd(S_ij) = sqrt((C_ij^2 + C_ii C_jj) / N)."""
    d = np.diag(cov)
    return 6.0 * np.sqrt((cov**2 + np.outer(d, d)) / N)


# --- motion models ---------------------------------------------------------------------------------------------

@pytest.mark.parametrize("name", sorted(MOTION_CASES))
def test_motion_jacobian_is_the_derivative_of_f(name):
    case = MOTION_CASES[name]()
    model, M = case.model, 4
    x = _states(case, M)
    F = _batched(model.F(x, case.u, case.k), M, model.n, model.n)
    numeric = _numeric_jacobian(lambda s: model.f(s, case.u, case.k), x)
    np.testing.assert_allclose(F, numeric, rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("name", sorted(MOTION_CASES))
def test_motion_linearize_and_batches_agree(name):
    case = MOTION_CASES[name]()
    model, M = case.model, 5
    x = _states(case, M, seed=1)
    f, F, Q = model.linearize(x, case.u, case.k)
    np.testing.assert_allclose(f, model.f(x, case.u, case.k), rtol=1e-13, atol=1e-12)
    np.testing.assert_allclose(F, model.F(x, case.u, case.k), rtol=1e-13, atol=1e-12)
    np.testing.assert_allclose(Q, model.Q(x, case.u, case.k), rtol=1e-13, atol=1e-15)
    assert np.shape(f) == (M, model.n)
    Fb = _batched(F, M, model.n, model.n)
    Qb = _batched(Q, M, model.n, model.n)
    for i in range(M):
        one = x[i:i + 1]
        np.testing.assert_allclose(model.f(one, case.u, case.k)[0], f[i], rtol=1e-13, atol=1e-12)
        np.testing.assert_allclose(_batched(model.F(one, case.u, case.k), 1, model.n, model.n)[0], Fb[i],
                                   rtol=1e-13, atol=1e-12)
        np.testing.assert_allclose(_batched(model.Q(one, case.u, case.k), 1, model.n, model.n)[0], Qb[i],
                                   rtol=1e-13, atol=1e-15)
        _assert_psd(Qb[i], f"{name}.Q")


@pytest.mark.parametrize("name", sorted(MOTION_CASES))
def test_motion_sample_has_mean_f_and_covariance_Q(name):
    case = MOTION_CASES[name]()
    model, N = case.model, 40_000
    x = case.state[None, None, :] * np.ones((1, N, 1))
    draws = model.sample(x, case.u, case.k, [np.random.default_rng(7)])[0]
    mean = model.f(case.state[None], case.u, case.k)[0]
    Q = _batched(model.Q(case.state[None], case.u, case.k), 1, model.n, model.n)[0]
    deviation = np.asarray(model.difference(draws, mean)) if hasattr(model, "difference") else draws - mean
    sd = np.sqrt(np.diag(Q))
    # six standard errors of a mean; a model whose noise enters through its inputs is Gaussian to first order
    slack = 1.05 if case.first_order else 1.0
    assert np.all(np.abs(deviation.mean(axis=0)) <= 6.0 * sd / np.sqrt(N) * slack + 1e-12), "sample mean is not f"
    cov = np.cov(deviation, rowvar=False).reshape(model.n, model.n)
    tol = _sample_covariance_tolerance(Q, N) * slack + 1e-15
    np.testing.assert_array_less(np.abs(cov - Q), tol + 0.02 * np.abs(Q) * case.first_order)


# --- measurement models ----------------------------------------------------------------------------------------

@pytest.mark.parametrize("name", sorted(MEASUREMENT_CASES))
def test_measurement_jacobian_is_the_derivative_of_h(name):
    case = MEASUREMENT_CASES[name]()
    model, M = case.model, 4
    x = _states(case, M)
    h = np.asarray(model.h(x, case.k), dtype=float)
    H = _batched(model.H(x, case.k), M, h.shape[-1], x.shape[-1])
    numeric = _numeric_jacobian(lambda s: np.asarray(model.h(s, case.k), dtype=float), x)
    np.testing.assert_allclose(H, numeric, rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("name", sorted(MEASUREMENT_CASES))
def test_measurement_linearize_and_batches_agree(name):
    case = MEASUREMENT_CASES[name]()
    model, M = case.model, 5
    x = _states(case, M, seed=2)
    h, H, defined = model.linearize(x, case.k)
    m, n = np.shape(h)[-1], x.shape[-1]
    np.testing.assert_allclose(h, model.h(x, case.k), rtol=1e-13, atol=1e-12)
    np.testing.assert_allclose(H, model.H(x, case.k), rtol=1e-13, atol=1e-12)
    defined = np.asarray(defined)
    assert defined.dtype == bool and defined.shape in {(M,), (M, m)} and defined.all(), \
        "linearize's mask must be True (shape (M,) or (M, m)) at states where the Jacobian is defined"
    Hb, Rb = _batched(H, M, m, n), _batched(model.R(x, case.k), M, m, m)
    for i in range(M):
        one = x[i:i + 1]
        np.testing.assert_allclose(np.asarray(model.h(one, case.k))[0], np.asarray(h)[i], rtol=1e-13, atol=1e-12)
        np.testing.assert_allclose(_batched(model.H(one, case.k), 1, m, n)[0], Hb[i], rtol=1e-13, atol=1e-12)
        np.testing.assert_allclose(_batched(model.R(one, case.k), 1, m, m)[0], Rb[i], rtol=1e-13, atol=1e-15)
        _assert_psd(Rb[i], f"{name}.R")


@pytest.mark.parametrize("name", sorted(MEASUREMENT_CASES))
def test_measurement_sample_has_mean_h_and_covariance_R(name):
    case = MEASUREMENT_CASES[name]()
    model, N = case.model, 40_000
    x = case.state[None, None, :] * np.ones((1, N, 1))
    draws = model.sample(x, case.k, [np.random.default_rng(11)])[0]
    h = np.asarray(model.h(case.state[None], case.k), dtype=float)[0]
    m = h.size
    R = _batched(model.R(case.state[None], case.k), 1, m, m)[0]
    assert np.all(np.abs((draws - h).mean(axis=0)) <= 6.0 * np.sqrt(np.diag(R) / N) + 1e-12)
    cov = np.cov(draws - h, rowvar=False).reshape(m, m)
    np.testing.assert_array_less(np.abs(cov - R), _sample_covariance_tolerance(R, N) + 1e-15)


@pytest.mark.parametrize("name", sorted(MEASUREMENT_CASES))
def test_measurement_log_likelihood_is_gaussian_in_h_and_R(name):
    from scipy.stats import multivariate_normal

    case = MEASUREMENT_CASES[name]()
    model = case.model
    particles = _states(case, 6, seed=3)[None]                       # one run, six particles (1, 6, n)
    z = np.asarray(model.sample(case.state[None], case.k, [np.random.default_rng(5)]), dtype=float)  # (1, m)
    logl = np.asarray(model.log_likelihood(particles, z, case.k), dtype=float)
    assert logl.shape == (1, 6)
    h = np.asarray(model.h(particles, case.k), dtype=float)[0]
    m = z.shape[-1]
    R = np.asarray(model.R(particles, case.k), dtype=float)
    R = np.broadcast_to(R, (6, m, m)) if R.ndim == 2 else R.reshape(-1, m, m)
    R = np.broadcast_to(R, (6, m, m))
    expected = np.array([multivariate_normal(h[j], R[j]).logpdf(z[0]) for j in range(6)])
    # up to a constant that is the same for every state of a run (the documented convention); a covariance that
    # depends on the state keeps its log-determinant, which differs between the particles
    np.testing.assert_allclose(logl[0] - logl[0, 0], expected - expected[0], rtol=1e-9, atol=1e-9)
