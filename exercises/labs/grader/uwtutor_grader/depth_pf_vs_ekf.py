"""Hidden tests of the lab ``depth_pf_vs_ekf`` (chapter 6, paper C): wave spikes on a depth sensor.

Part B is graded in two checks: B1 the log-density near zero (2 points), B2 far out, where ``np.log(a + b)`` is
−inf (1 point), so that the log of the sum costs B2 only. Part C too: C1 the sensor and the two EKFs (2 points), C2
the two particle filters (2 points).

Recognised mistakes (the instructor notes list them): weights not normalised in ``ess``; the normalising constants
of the mixture density dropped; ``np.log(a + b)``, which is −inf far out; R inflated with the spike variance alone;
spikes flagged with the inflated-R EKF instead of the plain one; the fraction *not* flagged as the false-alarm rate.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
from scipy import stats

from uwtutor.filters import BootstrapParticleFilter, DepthEKF, DepthSpeedPitchModel
from uwtutor.resampling import effective_sample_size
from uwtutor.exercises.checks import check_array, check_number
from uwtutor.exercises.feedback import Feedback
from ._common import Answers, cached, call, fail

__all__ = ["PARTS"]


def part_a(ns: Answers) -> Iterator[Feedback]:
    w = np.random.default_rng(3).random(500) ** 4
    got, problem = call(ns["ess"], w * 7.0, name="ess(w)")
    if problem is not None:
        yield problem
    yield check_number(got, effective_sample_size(w / w.sum()), rtol=1e-9, name="ess(w) of 500 weights that do not "
                       "sum to 1", common_mistakes={float(1.0 / np.sum((w * 7.0) ** 2)):
                                                   "Normalise the weights first (w / w.sum())."},
                       reveal_expected=False)


def part_b1(ns: Answers) -> Iterator[Feedback]:
    p, s, s_spike = 0.08, 0.2, 2.0
    x = np.linspace(-6.0, 6.0, 61)
    got, problem = call(ns["mixture_log_likelihood"], x.copy(), s, p, s_spike, name="mixture_log_likelihood(d, ...)")
    if problem is not None:
        yield problem
    expected = np.log((1 - p) * stats.norm.pdf(x, 0, s) + p * stats.norm.pdf(x, 0, s_spike))
    no_constants = np.logaddexp(np.log1p(-p) - 0.5 * (x / s) ** 2, np.log(p) - 0.5 * (x / s_spike) ** 2)
    constants_hint = ("The normalising constants 1/(σ√(2π)) are missing: the filter would not mind (a common "
                      "factor), but the task asks for the log-density itself.")
    mistakes = [(no_constants, constants_hint)]
    try:
        shift = np.asarray(got, dtype=float) - expected
        if shift.shape == x.shape and np.all(np.isfinite(shift)) and np.ptp(shift) < 1e-9 and abs(shift[0]) > 1e-6:
            mistakes.append((got, constants_hint))
    except (TypeError, ValueError):
        pass
    yield check_array(got, expected, rtol=1e-9, atol=1e-9, name="mixture_log_likelihood(d) on 61 residuals from "
                      "−6 to 6 m", common_mistakes=mistakes, reveal_expected=False)


def part_b2(ns: Answers) -> Iterator[Feedback]:
    p, s_spike = 0.08, 2.0
    s = 0.2
    far = np.array([30.0, -80.0])
    got, problem = call(ns["mixture_log_likelihood"], far.copy(), s, p, s_spike, name="mixture_log_likelihood(d, ...)")
    if problem is not None:
        yield problem
    if not np.all(np.isfinite(np.asarray(got, dtype=float))):
        yield fail("your log-likelihood is not finite far out (d = 30 m and −80 m): it must stay finite far out.",
                   hint="`np.log(a + b)` underflows to log(0) = −inf when both densities are tiny: combine the two "
                        "log-densities with `np.logaddexp` instead.")
    yield check_array(got, np.log(p) + stats.norm.logpdf(far, 0, s_spike), rtol=1e-6,
                      name="the log-likelihood far out (d = 30 m and −80 m)", reveal_expected=False)


def _ekf(ns: Answers, depth_variance: float | None = None) -> object:
    model, meas = ns["model"], ns["measurements"]
    R = model.R.copy()
    if depth_variance is not None:
        R[0, 0] = depth_variance
    return cached("depth_pf_vs_ekf.ekf", (meas, model.R, ns["Q"], R),
                  lambda: DepthEKF(x0=meas[:, 0], P0=model.R, Q=ns["Q"], R=R).run(meas))


class _Mixture(DepthSpeedPitchModel):
    """The reference mixture model (the student's is built on their part B)."""

    def __init__(self, p: float, s_spike: float) -> None:
        super().__init__()
        self._p, self._s_spike = p, s_spike

    def log_likelihood(self, particles: np.ndarray, z: np.ndarray) -> np.ndarray:
        # particles (M, N, n) and z (M, m) of a batched filter, or (N, n) and (m,)
        r = self.measure(particles) - np.asarray(z)[..., None, :]
        sd = np.sqrt(np.diag(self.R))
        g = -0.5 * (r[..., 0] / sd[0]) ** 2 - np.log(sd[0]) + np.log1p(-self._p)
        s = -0.5 * (r[..., 0] / self._s_spike) ** 2 - np.log(self._s_spike) + np.log(self._p)
        return -0.5 * np.sum((r[..., 1:] / sd[1:]) ** 2, axis=-1) + np.logaddexp(g, s)


def _pf_rmse(ns: Answers, which: str) -> float:
    meas, model, p, s_spike = ns["measurements"], ns["model"], ns["spike_probability"], ns["spike_sigma"]
    pf_model = model if which == "gaussian" else _Mixture(p, s_spike)

    def compute() -> float:
        estimates = np.array([BootstrapParticleFilter.from_gaussian(pf_model, meas[m, 0], model.R, 300,
                                                                    np.random.default_rng(100 + m)).run(meas[m]).x
                              for m in range(len(meas))])
        return ns["depth_rmse"](estimates)

    return cached("depth_pf_vs_ekf.pf." + which, (meas, model.R, ns["truth"], p, s_spike), compute)


def part_c1(ns: Answers) -> Iterator[Feedback]:
    table, model, p = ns["rmse_table"], ns["model"], ns["spike_probability"]
    depth_rmse = ns["depth_rmse"]
    var = model.R[0, 0]
    mixture_var = (1 - p) * var + p * (var + ns["spike_sigma"] ** 2)
    exact = {"depth sensor": (lambda: depth_rmse(ns["measurements"]), {}),
             "EKF": (lambda: depth_rmse(_ekf(ns).x), {}),
             "EKF, inflated R": (lambda: depth_rmse(_ekf(ns, mixture_var).x), {
                 "spike": lambda: depth_rmse(_ekf(ns, ns["spike_sigma"] ** 2).x)})}
    for key, (reference, mistakes) in exact.items():
        if key not in table:
            yield fail(f"rmse_table has no entry {key!r}.")
        value = reference()
        known = {}
        if "spike" in mistakes and not np.isclose(float(table[key]), value, rtol=1e-6):
            known[mistakes["spike"]()] = ("That R holds the spike variance alone (σ_s² = 4 m²); the mixture's "
                                          "variance is (1 − p)σ² + p(σ² + σ_s²).")
        yield check_number(table[key], value, rtol=1e-6, name=f"rmse_table[{key!r}]", units="m",
                           common_mistakes=known, reveal_expected=False)


def part_c2(ns: Answers) -> Iterator[Feedback]:
    table = ns["rmse_table"]
    for key, which in (("PF, Gaussian", "gaussian"), ("PF, mixture", "mixture")):
        if key not in table:
            yield fail(f"rmse_table has no entry {key!r}.")
        yield check_number(table[key], _pf_rmse(ns, which), rtol=0.15, name=f"rmse_table[{key!r}]", units="m",
                           hint="300 particles from `from_gaussian(model, measurements[m, 0], model.R, 300, rng_m)` "
                                "with rng_m = np.random.default_rng(100 + m), run on each run m.",
                           reveal_expected=False)


def part_d(ns: Answers) -> Iterator[Feedback]:
    spikes = ns["spikes"]

    def flags_of(result: object) -> np.ndarray:
        return np.abs(result.innovations[..., 0]) > 3.0 * np.sqrt(result.innovation_cov[..., 0, 0])

    expected = flags_of(_ekf(ns))
    flags = ns["flags"]
    model, p = ns["model"], ns["spike_probability"]
    inflated = flags_of(_ekf(ns, (1 - p) * model.R[0, 0] + p * (model.R[0, 0] + ns["spike_sigma"] ** 2)))
    if np.shape(flags) == expected.shape and np.array_equal(np.asarray(flags, dtype=bool), inflated) \
            and not np.array_equal(inflated, expected):
        yield fail("those flags come from the EKF with the inflated R.",
                   hint="The question asks for the plain EKF of part C (R = model.R).")
    yield check_array(flags, expected, name="flags", hint="Flag where |y_{k,z}| > 3 √S_{k,zz} of the plain EKF.",
                      reveal_expected=False)
    yield check_number(ns["detection_rate"], float(np.mean(expected[spikes])), atol=1e-12, name="detection_rate",
                       hint="The fraction of the true spikes that are flagged.", reveal_expected=False)
    yield check_number(ns["false_alarm_rate"], float(np.mean(expected[~spikes])), atol=1e-12,
                       name="false_alarm_rate", common_mistakes={
                           float(np.mean(~expected[~spikes])): "That is the fraction not flagged."},
                       hint="The fraction of the samples without a spike that are flagged.", reveal_expected=False)


PARTS = {"A": part_a, "B1": part_b1, "B2": part_b2, "C1": part_c1, "C2": part_c2, "D": part_d}
