"""Hidden tests of the lab ``outlier_rejection_vmlbl`` (chapter 9, paper E): multipath patches and a lock-out.

Each step is checked with the student's own earlier answers: ``n_reacquire`` against the student's
``longest_patch``, the re-acquiring filter of part C with the student's ``n_reacquire``, the noise gains of part D
from the fix the student's fix errors come from (the raw ranges give another noise gain). Part C is graded in two
checks (C1: the lock-out's start, the longest patch and ``n_reacquire``, 1 point; C2: the re-acquisition epoch and
the RMS errors, 2 points) and part D in two (D1: the fix errors, 2 points; D2: the noise gains, 2 points).

Recognised mistakes (the instructor notes list them): the small-S approximation ±δẑ/2 and D without S in paper E's
gate; the default ``reacquire=20`` left on in part B; the number of outliers for the longest patch; ``n_reacquire``
not ``longest_patch + 5``; the epochs of the virtual-beacon fix listed newest first; the raw ranges instead of the
filtered ones.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from uwtutor.filters import robust_range_kf
from uwtutor.filters.robust import moment_gate_interval
from uwtutor.lsq import virtual_beacon_lsq
from uwtutor.exercises.checks import check_number
from uwtutor.exercises.feedback import Feedback
from ._common import Answers, cached, call, fail, own_number

__all__ = ["PARTS"]


def _filter(ns: Answers, test: str, reacquire: int | None, defaults: bool = False) -> object:
    ranges = ns["ranges"]
    kwargs = {} if defaults else {"q": ns["q"], "r": ns["r"], "delta": ns["delta"]}
    return cached("outlier_rejection_vmlbl.kf", (ranges, kwargs, test, reacquire, defaults),
                  lambda: robust_range_kf(ranges, test=test, **kwargs, **({} if defaults else
                                                                          {"reacquire": reacquire})))


def _runs(flags: np.ndarray) -> list[tuple[int, int]]:
    edges = np.diff(np.concatenate([[0], np.asarray(flags, dtype=int), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    return list(zip(starts.tolist(), (ends - starts).tolist()))


def part_a(ns: Answers) -> Iterator[Feedback]:
    paper_gate = ns["paper_gate"]
    for z, zp, S, d in [(640.0, 610.0, 9.0, 0.03), (300.0, 310.0, 400.0, 0.03), (905.0, 900.0, 2.5, 0.01),
                        (120.0, 100.0, 900.0, 0.1)]:
        lo, hi = (float(v) for v in moment_gate_interval(zp, S, d))
        where = f" (z = {z:g}, z_pred = {zp:g}, S = {S:g}, delta = {d:g})"
        got, problem = call(paper_gate, z, zp, S, d, name=f"paper_gate{where}")
        if problem is not None:
            yield problem
        if not (isinstance(got, tuple) and len(got) == 3):
            yield fail(f"paper_gate returned {type(got).__name__}; it returns (lower, upper, accepted).")
        yield check_number(got[0], lo, rtol=1e-9, name="the lower end" + where, units="m", common_mistakes={
            -d * zp / 2: "That is the small-S approximation -delta z_pred / 2: compute it exactly from "
                         "D = S + z_pred².",
            float(np.sqrt((1 - d) * zp**2) - zp): "D includes the innovation variance: D = S + z_pred²."},
            reveal_expected=False)
        yield check_number(got[1], hi, rtol=1e-9, name="the upper end" + where, units="m", common_mistakes={
            d * zp / 2: "That is the small-S approximation +delta z_pred / 2: compute it exactly from D = S + z_pred².",
            float(np.sqrt((1 + d) * zp**2) - zp): "D includes the innovation variance: D = S + z_pred²."},
            reveal_expected=False)
        if bool(got[2]) != bool(lo <= z - zp <= hi):
            yield fail(f"accepted is wrong{where}.", hint="Accept when the innovation z − z_pred lies in "
                                                          "[lower, upper].")
    yield Feedback(True, "Correct.")


def part_b(ns: Answers) -> Iterator[Feedback]:
    counts, is_outlier = ns["counts"], ns["is_outlier"]
    for test in ("paper", "chi2"):
        flagged = _filter(ns, test, None).extras["outlier"]
        reference = {"flagged": int(flagged.sum()), "missed": int(np.sum(is_outlier & ~flagged)),
                     "false": int(np.sum(flagged & ~is_outlier))}
        default_flags = _filter(ns, test, 20, defaults=True).extras["outlier"]
        default = {"flagged": int(default_flags.sum()), "missed": int(np.sum(is_outlier & ~default_flags)),
                   "false": int(np.sum(default_flags & ~is_outlier))}
        for key, value in reference.items():
            mistakes = {} if default[key] == value else {
                float(default[key]): "Without re-acquisition: pass reacquire=None (the default re-acquires after 20 "
                                     "rejections)."}
            yield check_number(counts[test][key], value, atol=0.5, name=f"counts[{test!r}][{key!r}]",
                               common_mistakes=mistakes, hint="Count with `extras['outlier']` of a run without "
                                                              "re-acquisition, against `is_outlier`.",
                               reveal_expected=False)


def _lockout_start(ns: Answers) -> int:
    false_rejections = _filter(ns, "paper", None).extras["outlier"] & ~ns["is_outlier"]
    k = next((s for s, n in _runs(false_rejections) if n >= 15), None)
    if k is None:  # pragma: no cover - the lab's scenario has a lock-out
        raise RuntimeError("the lab's scenario has no lock-out")
    return k


def part_c1(ns: Answers) -> Iterator[Feedback]:
    is_outlier = ns["is_outlier"]
    yield check_number(ns["lockout_start"], _lockout_start(ns), atol=0.5, name="lockout_start",
                       hint="The start of the first run of at least 15 consecutive *good* ranges rejected by paper E's "
                            "gate without re-acquisition.", reveal_expected=False)
    longest = max(n for _, n in _runs(is_outlier))
    yield check_number(ns["longest_patch"], longest, atol=0.5, name="longest_patch", common_mistakes={
        float(is_outlier.sum()): "That is the number of outliers; the question asks for the longest run of them."},
        hint="The longest run of consecutive True values of `is_outlier`.", reveal_expected=False)
    own_longest = own_number(ns, "longest_patch")
    if own_longest is None or ns["n_reacquire"] != own_longest + 5:
        yield fail(f"n_reacquire = {ns['n_reacquire']!r} is not longest_patch + 5.",
                   hint="Below the longest patch, the patch itself is taken for the truth.")
    yield Feedback(True, "Correct.")


def _student_reacquire(ns: Answers) -> int:
    """The student's ``n_reacquire`` (C1) when it is a positive whole number, else the longest patch + 5: C2 runs the
    re-acquiring filter with it."""
    own = own_number(ns, "n_reacquire")
    if own is not None and own >= 1 and own == int(own):
        return int(own)
    return max(n for _, n in _runs(ns["is_outlier"])) + 5


def part_c2(ns: Answers) -> Iterator[Feedback]:
    k = _lockout_start(ns)
    with_reacq = _filter(ns, "paper", _student_reacquire(ns))
    yield check_number(ns["recovered_at"], k + int(np.argmax(with_reacq.extras["reacquired"][k:])), atol=0.5,
                       name="recovered_at", hint="The first epoch from the lock-out's start on where the filter with "
                                                 "your n_reacquire re-acquired (`extras['reacquired']`).",
                       reveal_expected=False)
    rms_after, truth = ns["rms_after"], ns["true_ranges"]

    def rms(e: np.ndarray) -> float:
        return float(np.sqrt(np.mean(np.square(e))))

    no_reacq = _filter(ns, "paper", None)
    yield check_number(rms_after["no re-acquisition"], rms(no_reacq.x[k:, 0] - truth[k:]), rtol=1e-6,
                       name="rms_after['no re-acquisition']", units="m",
                       hint="The RMS range error from the lock-out's start to the end.", reveal_expected=False)
    yield check_number(rms_after["re-acquisition"], rms(with_reacq.x[k:, 0] - truth[k:]), rtol=1e-6,
                       name="rms_after['re-acquisition']", units="m",
                       hint="The same, for the filter with your n_reacquire.", reveal_expected=False)


def _fixes(ns: Answers, s: int) -> dict:
    """Part D's fix for spacing ``s`` from the filtered ranges (epochs oldest first), and its two recognised slips."""
    k_fix, ship, dr, depth = ns["k_fix"], ns["ship"], ns["dr"], ns["depth"]
    filtered = _filter(ns, "paper", 30).x[:, 0]
    epochs = k_fix - s * np.arange(3, -1, -1)
    return {"right": virtual_beacon_lsq(filtered[epochs], ship[epochs], dr[epochs], depth=depth),
            "newest first": virtual_beacon_lsq(filtered[epochs[::-1]], ship[epochs[::-1]], dr[epochs[::-1]],
                                               depth=depth),
            "raw": virtual_beacon_lsq(ns["ranges"][epochs], ship[epochs], dr[epochs], depth=depth)}


def part_d1(ns: Answers) -> Iterator[Feedback]:
    truth, k_fix, fix_errors = ns["truth"], ns["k_fix"], ns["fix_errors"]
    for s in (10, 60):
        fixes = _fixes(ns, s)
        error = {kind: float(np.linalg.norm(fix.position - truth[k_fix])) for kind, fix in fixes.items()}
        yield check_number(fix_errors[s], error["right"], rtol=1e-6, name=f"fix_errors[{s}]", units="m",
                           common_mistakes={
                               error["newest first"]: "List the epochs oldest first: the fix is the position at the "
                                                      "last epoch passed.",
                               error["raw"]: "Use the filtered ranges, not the raw ones."},
                           reveal_expected=False)


def part_d2(ns: Answers) -> Iterator[Feedback]:
    truth, k_fix, fix_errors, noise_gains = ns["truth"], ns["k_fix"], ns["fix_errors"], ns["noise_gains"]
    for s in (10, 60):
        fixes = _fixes(ns, s)
        gain = float(fixes["right"].noise_gain)
        own_error = own_number(Answers(fix_errors), s) if isinstance(fix_errors, dict) else None
        for kind, fix in fixes.items():     # the fix the student's fix_errors[s] comes from (a slip counted in D1)
            if own_error is not None and np.isclose(own_error, float(np.linalg.norm(fix.position - truth[k_fix])),
                                                    rtol=1e-6):
                gain = float(fix.noise_gain)
        yield check_number(noise_gains[s], gain, rtol=1e-6, name=f"noise_gains[{s}]",
                           hint="`noise_gain` of the same fix as fix_errors.", reveal_expected=False)


PARTS = {"A": part_a, "B": part_b, "C1": part_c1, "C2": part_c2, "D1": part_d1, "D2": part_d2}
