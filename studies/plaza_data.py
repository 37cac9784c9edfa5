"""What the CMU Plaza 1 and 2 logs hold, measured against their ground truth (issue 22, "Bring your own data").

Prints, for each set: epochs, duration and odometry rate; ranges per beacon (count, rate, spacing); the range log's
out-of-order rows; the range scale (least squares of the range on the true distance, per beacon and overall) and
the residual noise (overall and by distance); dead reckoning alone from the true start (RMSE, median, final and
largest position error) and its heading drift. Deterministic (no randomness); about 2 s.

    .venv/bin/python studies/plaza_data.py

The true distance of a range is taken at the range's own time (the truth's position interpolated linearly
between its epochs, at 5 or 10 per second), not at the epoch it is placed on.
"""

from __future__ import annotations

import numpy as np
from scipy.io import loadmat

from uwtutor.datasets import plaza
from uwtutor.datasets._plaza import _locate


def wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2 * np.pi) - np.pi


def integrate(start: np.ndarray, odometry: np.ndarray, alpha: float) -> np.ndarray:
    """Positions when step k moves along psi_{k-1} + alpha * delta_k (0: turn after the distance, 0.5: mean
    heading, 1: turn first)."""
    d, turn = odometry[1:, 0], odometry[1:, 1]
    before = start[2] + np.concatenate([[0.0], np.cumsum(turn)[:-1]])
    h = before + alpha * turn
    return start[:2] + np.concatenate([[[0.0, 0.0]], np.cumsum(d[:, None] * np.c_[np.cos(h), np.sin(h)], axis=0)])


def convention_errors(data, window: float, alpha: float) -> float:
    """RMS end error of dead reckoning restarted from the truth at the start of consecutive windows."""
    t, truth = data.times, data.truth
    errs = []
    s = 0
    while True:
        e = int(np.searchsorted(t, t[s] + window))
        if e >= len(t):
            break
        xy = integrate(truth[s], data.odometry[s:e + 1], alpha)
        errs.append(np.hypot(*(xy[-1] - truth[e, :2])))
        s = e
    return float(np.sqrt(np.mean(np.square(errs))))


def heading_lead(data) -> float:
    """The time shift [s] of the truth's heading that best aligns it with the direction of its own steps."""
    t, truth = data.times, data.truth
    h = np.unwrap(truth[:, 2])
    lag = 5
    step = truth[lag:, :2] - truth[:-lag, :2]
    moving = np.hypot(*step.T) > 0.25
    direction = np.arctan2(step[:, 1], step[:, 0])
    mid = (t[lag:] + t[:-lag]) / 2
    shifts = np.round(np.arange(-0.30, 0.301, 0.01), 2)
    spread = [np.std(wrap(direction - np.interp(mid + s, t, h))[moving]) for s in shifts]
    return float(-shifts[int(np.argmin(spread))])


def report(number: int) -> None:
    data = plaza(number)
    raw_td = loadmat(_locate(number, None))["TD"]
    t, K, T = data.times, data.n_epochs, data.duration
    print(f"=== {data.name}")
    dt = np.diff(t)
    print(f"epochs K = {K}, duration {T:.1f} s, odometry {(K - 1) / T:.2f} Hz "
          f"(step median {np.median(dt):.3f} s, min {dt.min():.3f}, max {dt.max():.3f})")
    path = data.odometry[1:, 0].sum()
    print(f"path: {path:.1f} m by odometry, {np.hypot(*np.diff(data.truth[:, :2], axis=0).T).sum():.1f} m by "
          f"the truth; median speed {np.median(data.odometry[1:, 0] / dt):.2f} m/s")

    back = np.diff(raw_td[:, 0]) < 0
    moved = np.count_nonzero(np.argsort(raw_td[:, 0], kind="stable") != np.arange(len(raw_td)))
    print(f"range log: {len(raw_td)} rows; time goes back {back.sum()} time(s) "
          f"{np.round(-np.diff(raw_td[:, 0])[back], 3).tolist()} s; a stable sort moves {moved} rows")

    r_t, r_id, r = data.ranges.T
    x = np.interp(r_t, t, data.truth[:, 0])
    y = np.interp(r_t, t, data.truth[:, 1])
    b = np.array([data.beacons[int(i)] for i in r_id])
    d = np.hypot(x - b[:, 0], y - b[:, 1])
    print("beacon   n   per s  median/max gap [s]  scale (LS, through 0)  affine fit       residual std [m]")
    for beacon in [*data.beacon_ids, None]:
        sel = np.ones(len(r), bool) if beacon is None else r_id == beacon
        rr, dd, tt = r[sel], d[sel], r_t[sel]
        s = rr @ dd / (dd @ dd)
        slope, icpt = np.polyfit(dd, rr, 1)
        res = rr - s * dd
        gaps = np.diff(tt)
        label = "all" if beacon is None else str(beacon)
        gap = f"{np.median(gaps):6.2f} / {gaps.max():6.1f}" if beacon is not None else " " * 15
        print(f"{label:>6} {len(rr):5d} {len(rr) / T:6.3f}  {gap}      {s:.4f}             "
              f"{slope:.4f} d {icpt:+.3f}   {res.std():.3f}")
    s = r @ d / (d @ d)
    res = r - s * d
    edges = [0, 15, 30, 45, 60, 100]
    parts = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        sel = (d >= lo) & (d < hi)
        if sel.sum() >= 10:
            parts.append(f"[{lo},{hi}) m: {res[sel].std():.3f} (n={sel.sum()})")
    print("residual std by true distance: " + "; ".join(parts))
    k_fit = np.polyfit(d, np.abs(res), 1)[0]
    print(f"|residual| vs true distance: slope {k_fit * 1000:+.2f} mm per m; "
          f"largest |residual| {np.abs(res).max():.2f} m ({np.abs(res).max() / res.std():.1f} std); "
          f"excess kurtosis {((res - res.mean()) ** 4).mean() / res.var() ** 2 - 3:+.3f}")

    # on the epochs, as a filter would see them
    on = data.ranges_on_epochs()
    true_on = data.true_ranges()
    ok = ~np.isnan(on)
    s_on = on[ok] @ true_on[ok] / (true_on[ok] @ true_on[ok])
    print(f"placed on epochs: {ok.sum()} ranges kept of {len(r)}; scale {s_on:.4f}, residual std "
          f"{(on[ok] - s_on * true_on[ok]).std():.3f} m")
    for period in (5.0, 10.0, 30.0):
        n_kept = (~np.isnan(data.ranges_on_epochs(min_period=period))).sum(axis=0)
        print(f"  min_period {period:4.0f} s: ranges kept per beacon {n_kept.tolist()}")

    dr = data.dead_reckoning()
    err = np.hypot(*(dr[:, :2] - data.truth[:, :2]).T)
    drift = np.unwrap(dr[:, 2]) - np.unwrap(data.truth[:, 2])
    drift -= drift[0]
    i60 = np.searchsorted(t - t[0], 60.0)
    print(f"dead reckoning from the true start: RMSE {np.sqrt(np.mean(err ** 2)):.2f} m, median {np.median(err):.2f} "
          f"m, final {err[-1]:.2f} m, largest {err.max():.2f} m; after 60 s {err[i60]:.2f} m")
    print(f"heading drift (DR - truth): final {np.degrees(drift[-1]):+.1f} deg, largest "
          f"{np.degrees(drift[np.argmax(np.abs(drift))]):+.1f} deg")
    step = np.diff(data.truth[:, :2], axis=0)
    moving = np.hypot(*step.T) > 0.05
    along = np.degrees(np.median(np.abs(wrap(np.arctan2(step[:, 1], step[:, 0]) - data.truth[:-1, 2])[moving])))
    print(f"truth heading vs direction of its steps: median |difference| {along:.2f} deg")
    for window in (2.0, 5.0):
        errs = {name: convention_errors(data, window, a) for name, a in (("turn after", 0.0), ("mean heading", 0.5),
                                                                          ("turn first", 1.0))}
        print(f"dead reckoning restarted from the truth every {window:g} s, RMS end error: "
              + ", ".join(f"{k} {v:.4f} m" for k, v in errs.items()))
    print(f"the truth's heading leads its positions by {heading_lead(data):.2f} s")
    print()


if __name__ == "__main__":
    for n in (1, 2):
        report(n)
