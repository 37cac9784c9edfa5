"""The library's filters on the real Plaza logs: odometry alone, the position-only EKF, and ``datasets.navigate``.

For Plaza 1 and 2, each beacon alone and all four, at the logged rate and at an acoustic rate (one range per
beacon every 10 s): RMSE, median and final position error against the ground truth, of

* odometry alone (dead reckoning from the start pose);
* the position-only EKF the book used on simulations: state [x, y], the odometry turned into world-frame
  displacements by dead reckoning, ranges taken at face value (``DeadReckoning`` + ``BeaconRanges`` on the generic
  engine; with one beacon this is ``range_only_ekf``'s model);
* ``navigate``: heading, gyro bias and range scale in the state, gated (filtered and RTS-smoothed);
* ``navigate`` without the gyro-bias state (Plaza 1's heading does not drift);

and the time of one ``navigate`` call on Plaza 2 with four beacons. Deterministic (no randomness).

    .venv/bin/python studies/plaza_navigation.py            # about a minute
"""

from __future__ import annotations

import time

import numpy as np

from uwtutor.datasets import navigate, plaza
from uwtutor.filters import extended_kalman_filter
from uwtutor.models import BeaconRanges, DeadReckoning

ACOUSTIC_PERIOD = 10.0  # s: one range per beacon every 10 s, an acoustic modem's rate


def errors(positions: np.ndarray, truth: np.ndarray) -> tuple[float, float, float]:
    e = np.linalg.norm(positions[:, :2] - truth[:, :2], axis=1)
    return float(np.sqrt(np.mean(e**2))), float(np.median(e)), float(e[-1])


def position_only_ekf(data, ids, min_period=None, range_sigma=0.6, distance_sigma=(0.01, 0.02)):
    """[x, y] moved by dead-reckoned world displacements, ranges as logged (no scale, no heading)."""
    dr = data.dead_reckoning()
    u = np.diff(dr[:, :2], axis=0, prepend=dr[:1, :2])
    sigma = distance_sigma[0] + distance_sigma[1] * np.abs(data.odometry[:, 0])
    Q = sigma[:, None, None] ** 2 * np.eye(2)
    z = data.ranges_on_epochs(ids, min_period=min_period)
    P0 = data.start_cov[:2, :2]
    return extended_kalman_filter(DeadReckoning(Q), BeaconRanges(data.beacon_positions(ids), R=range_sigma**2),
                                  data.start[:2], P0, u, z, times=data.times).x


def main() -> None:
    rows = []
    for number in (1, 2):
        data = plaza(number)
        ids = list(data.beacons)
        alone = errors(data.dead_reckoning(), data.truth)
        for rate, period in (("full", None), ("10 s", ACOUSTIC_PERIOD)):
            for chosen in [[b] for b in ids] + [ids]:
                label = "all 4" if len(chosen) > 1 else f"beacon {chosen[0]}"
                row = {"set": f"Plaza {number}", "beacons": label, "rate": rate, "odometry": alone,
                       "position EKF": errors(position_only_ekf(data, chosen, period), data.truth)}
                filtered = navigate(data, chosen, min_period=period)
                smoothed = navigate(data, chosen, min_period=period, smooth=True)
                no_gyro = navigate(data, chosen, min_period=period, gyro_bias=False)
                row["navigate"] = errors(filtered.x, data.truth)
                row["navigate RTS"] = errors(smoothed.x, data.truth)
                row["no gyro state"] = errors(no_gyro.x, data.truth)
                row["scale"] = float(filtered.x[-1, 4])
                rows.append(row)
    columns = ["odometry", "position EKF", "navigate", "navigate RTS", "no gyro state"]
    print("RMSE / median / final position error [m]")
    print(f"{'set':8} {'beacons':9} {'rate':5} " + " ".join(f"{c:>19}" for c in columns) + f" {'scale':>7}")
    for row in rows:
        cells = " ".join(f"{row[c][0]:6.2f}/{row[c][1]:5.2f}/{row[c][2]:6.2f}" for c in columns)
        print(f"{row['set']:8} {row['beacons']:9} {row['rate']:5} {cells} {row['scale']:7.4f}")
    data = plaza(2)
    times = []
    for _ in range(3):
        start = time.perf_counter()
        navigate(data)
        times.append(time.perf_counter() - start)
    print(f"navigate on Plaza 2 ({data.times.size} epochs, 4 beacons): {min(times):.2f} s (best of 3)")


if __name__ == "__main__":
    main()
