"""The particle filter on logs of real-data shape, with the EKF's model pair for wheel odometry and ranges.

* a simulated log the size of the CMU Plaza sets (4091 epochs of 0.1 s, four beacons heard about once a second
  each, a 7 % range scale and a gyro bias): the PF with N = 2000 tracks within 0.35 m RMS (about 0.21 m here, the
  EKF's 0.20 m; dead reckoning ends 80 m off) and recovers the scale and the bias;
* the Plaza 2 log itself (skipped without gtsam): within 0.45 m RMS (0.30 m, as ``navigate``);
* one model pair in every place that takes one: the EKF engine, the RTS smoother, the posterior Cramér-Rao bound and
  the particle filter, on a Monte Carlo study of that log's model; and roughening (Gordon et al. 1993) keeping the
  PF's constant states (bias, scale) from collapsing.
"""

from __future__ import annotations

import numpy as np
import pytest

from uwtutor.datasets import RangeDataset, navigate, navigation_models
from uwtutor.filters import BootstrapParticleFilter, extended_kalman_filter, rts_smoother
from uwtutor.models import BeaconRanges, OdometryMotion
from uwtutor.observability import model_posterior_crlb

BEACONS = {0: (-10.0, -10.0), 1: (60.0, -10.0), 5: (60.0, 70.0), 6: (-10.0, 70.0)}
STEP, SPEED, GYRO_BIAS, SCALE = 0.1, 3.3, 0.004, 1.07


def _path(K: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Epoch times, true odometry [distance, heading change] and true poses of a vehicle looping among the beacons
    (each step moves along the previous heading, then turns: the Plaza logs' convention)."""
    t = STEP * np.arange(K)
    d = np.full(K, SPEED * STEP)
    turn = (0.1 + 0.06 * np.sin(2 * np.pi * t / 90.0)) * STEP
    d[0] = turn[0] = 0.0
    odometry = np.column_stack([d, turn])
    return t, odometry, OdometryMotion(0.0, 0.0, order="move-first").integrate([20.0, 5.0, 0.0], odometry)


def simulated_log(seed: int = 0, K: int = 4091) -> RangeDataset:
    """A Plaza-sized log: noisy odometry with a gyro bias, 0.5 m ranges scaled by 7 %, each beacon heard at 12 % of
    the epochs."""
    rng = np.random.default_rng(seed)
    t, odometry, truth = _path(K)
    d = odometry[:, 0]
    measured = odometry + np.column_stack([rng.normal(0.0, 0.01 + 0.02 * d),
                                           GYRO_BIAS * STEP + rng.normal(0.0, 3e-4, K)])
    measured[0] = 0.0
    rows = []
    for beacon, position in BEACONS.items():
        heard = np.flatnonzero(rng.random(K) < 0.12)
        r = SCALE * np.linalg.norm(truth[heard, :2] - position, axis=1) + rng.normal(0.0, 0.5, heard.size)
        rows.append(np.column_stack([t[heard], np.full(heard.size, beacon), r]))
    ranges = np.concatenate(rows)
    return RangeDataset(times=t, odometry=measured, ranges=ranges[np.argsort(ranges[:, 0], kind="stable")],
                        beacons=BEACONS, truth=truth)


def _rms(x: np.ndarray, truth: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum((x[..., :2] - truth[..., :2]) ** 2, axis=-1))))


def test_the_pf_tracks_a_plaza_sized_log_with_the_odometry_pair():
    data = simulated_log()
    nav = navigation_models(data)
    assert nav.z.shape == (4091, 4) and 0.8 < np.isfinite(nav.z).mean() / 0.12 < 1.2
    pf = BootstrapParticleFilter.from_gaussian(nav.motion, nav.measurement, nav.x0, nav.P0, 2000,
                                               np.random.default_rng(0), ess_threshold=0.5, roughening=0.1)
    res = pf.run(nav.z, nav.u, times=nav.times)
    pf_rms, ekf_rms = _rms(res.x, data.truth), _rms(navigate(data).x, data.truth)
    assert pf_rms < 0.35 and pf_rms < 1.3 * ekf_rms
    assert np.max(np.linalg.norm(res.x[:, :2] - data.truth[:, :2], axis=1)) < 1.0
    assert np.linalg.norm(data.dead_reckoning()[-1, :2] - data.truth[-1, :2]) > 50.0       # the ranges do it
    assert abs(res.x[-1, 4] - SCALE) < 0.005 and abs(res.x[-1, 3] - GYRO_BIAS) < 5e-4
    # the heading goes round several times; its estimate is the circular mean, right where it crosses +-pi too
    assert (np.abs(np.diff(data.truth[:, 2])) > np.pi).sum() >= 5
    heading_error = np.abs(np.angle(np.exp(1j * (res.x[:, 2] - data.truth[:, 2]))))
    assert heading_error.max() < 0.1 and heading_error.mean() < 0.01


def test_the_pf_on_the_plaza_2_log():
    pytest.importorskip("gtsam")
    from uwtutor.datasets import plaza

    data = plaza(2)
    nav = navigation_models(data)
    res = BootstrapParticleFilter.from_gaussian(nav.motion, nav.measurement, nav.x0, nav.P0, 2000,
                                                np.random.default_rng(0), ess_threshold=0.5,
                                                roughening=0.1).run(nav.z, nav.u, times=nav.times)
    pf_rms = _rms(res.x, data.truth)
    assert pf_rms < 0.45 and pf_rms < 1.2 * _rms(navigate(data).x, data.truth)
    assert abs(res.x[-1, 4] - 1.07) < 0.01                      # the Plaza radios' range scale (chapter 11)


def test_one_model_pair_in_the_ekf_the_smoother_the_pcrb_and_the_pf():
    """The odometry pair of a 1000-epoch log, 10 Monte Carlo runs: the EKF and the PF are near the posterior
    Cramér-Rao bound of the same pair, the smoother below both; without roughening the PF loses runs."""
    M, K = 10, 1000
    rng = np.random.default_rng(0)
    t, odometry, _ = _path(K)
    odometry[1:, 1] += GYRO_BIAS * STEP                                   # the biased gyro's reading
    sd_distance = 0.01 + 0.02 * SPEED * STEP
    motion = OdometryMotion(sd_distance, 3e-4, gyro_bias=True, scale=True, times=t, order="move-first",
                            gyro_bias_walk=1e-4, scale_walk=1e-5)
    truth = motion.integrate([20.0, 5.0, 0.0, GYRO_BIAS, SCALE], odometry)          # (K, 5): every state
    u = odometry + rng.normal(0.0, [sd_distance, 3e-4], (M, K, 2))
    u[:, 0] = 0.0
    positions = np.array(list(BEACONS.values()))
    z = SCALE * np.linalg.norm(truth[:, None, :2] - positions, axis=-1) + rng.normal(0.0, 0.5, (M, K, 4))
    z[rng.random(z.shape) > 0.12] = np.nan
    ranges = BeaconRanges(positions, R=0.5**2, layout=motion.layout)
    x0, P0 = motion.layout.initial_state([20.0, 5.0, 0.0], np.diag([0.1, 0.1, 0.001]), gyro_bias=(0.0, 0.01),
                                         scale=(1.0, 0.1))
    x0 = np.tile(x0, (M, 1))

    ekf = extended_kalman_filter(motion, ranges, x0, P0, u, z, times=t)
    smoothed = rts_smoother(ekf, motion, u)
    pf = BootstrapParticleFilter.from_gaussian(motion, ranges, x0, P0, 1000, np.random.default_rng(1),
                                               ess_threshold=0.5, roughening=0.1).run(z, u, times=t)
    bound = model_posterior_crlb(motion, ranges, np.array([20.0, 5.0, 0.0, GYRO_BIAS, SCALE]), P0, truth,
                                 odometry, measured=np.isfinite(z))
    B = np.sqrt(np.trace(bound, axis1=-2, axis2=-1)).mean(axis=0)        # (K,): the RMSE bound of the position
    late = slice(500, None)

    def rmse(x: np.ndarray) -> np.ndarray:
        return np.sqrt(np.mean(np.sum((x[..., :2] - truth[:, :2]) ** 2, axis=-1), axis=0))

    ratio = {name: float(np.mean(rmse(r.x)[late] / B[late])) for name, r in
             (("EKF", ekf), ("PF", pf), ("smoother", smoothed))}
    # 10 runs carry about 20 % of Monte Carlo error in an RMSE: both filters sit at the bound, the smoother below it
    assert 0.7 < ratio["EKF"] < 1.4 and 0.7 < ratio["PF"] < 1.5, ratio
    assert ratio["smoother"] < 0.8 * ratio["EKF"], ratio
    # without roughening the resampled copies of the constant states (bias, scale) collapse and runs are lost
    plain = BootstrapParticleFilter.from_gaussian(motion, ranges, x0, P0, 1000, np.random.default_rng(1),
                                                  ess_threshold=0.5).run(z[:, :400], u[:, :400], times=t[:400])
    lost = np.linalg.norm(plain.x[:, -1, :2] - truth[399, :2], axis=-1) > 2.0
    assert lost.sum() >= 3 and (np.linalg.norm(pf.x[:, 399, :2] - truth[399, :2], axis=-1) < 1.0).all()


def test_roughening_adds_the_papers_jitter_from_the_runs_generator():
    """After a resampling, component j of every particle moves by K E_j N^(-1/n) times a standard normal drawn from
    the run's Generator (E_j the spread of the resampled particles)."""
    from uwtutor.models import LinearMeasurement, LinearMotion

    drawn = {}

    def recording(w, rng):
        drawn["idx"] = np.sort(rng.integers(0, w.size, w.size))
        drawn["state"] = rng.bit_generator.state
        return drawn["idx"]

    particles = np.random.default_rng(0).normal(size=(50, 2)) * [1.0, 10.0]
    pf = BootstrapParticleFilter(LinearMotion(np.eye(2), np.zeros((2, 2))), LinearMeasurement(np.eye(2), np.eye(2)),
                                 particles, np.random.default_rng(1), resampler=recording, roughening=0.2)
    pf.update([0.0, 0.0])
    copies = particles[drawn["idx"]]
    replay = np.random.default_rng(1)
    replay.bit_generator.state = drawn["state"]
    sigma = 0.2 * np.ptp(copies, axis=0) * 50 ** (-1 / 2)
    np.testing.assert_allclose(pf.particles, copies + (replay.standard_normal((2, 50)) * sigma[:, None]).T,
                               rtol=1e-12)
    with pytest.raises(ValueError, match="roughening must be >= 0"):
        BootstrapParticleFilter(LinearMotion(np.eye(2), np.eye(2)), LinearMeasurement(np.eye(2), np.eye(2)),
                                particles, np.random.default_rng(1), roughening=-0.1)
