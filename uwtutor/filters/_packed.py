"""The packed 2x2 arithmetic of the single-beacon range EKFs, shared by :mod:`.ekf` and :mod:`.fading`.

The state is a horizontal position and the measurement a scalar range, so every product is written out as 2x2
algebra on arrays of length ``M`` (one entry per Monte Carlo run). The filter state of all runs lives in one
``(6, M)`` array (rows ``x, y, Pxx, Pxy, Pyx, Pyy``). This module is private to :mod:`uwtutor.filters`: the two
range filters are its only users, and ``tests/test_filter_contract.py`` holds both to the generic engine.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._validate import as_covariance, as_finite, as_int, as_range_array
from ..errors import BeaconSingularityWarning, warn

ROW_X, ROW_Y, ROW_PXX, ROW_PXY, ROW_PYX, ROW_PYY = range(6)
N_ROWS = 6




# --- packing ----------------------------------------------------------------------------------------------------

def pack(x: np.ndarray, P: np.ndarray) -> np.ndarray:
    """Pack estimates ``x`` (M, 2) and covariances ``P`` (M, 2, 2) into one ``(6, M)`` state array."""
    s = np.empty((N_ROWS, x.shape[0]))
    s[ROW_X:ROW_Y + 1] = x.T
    s[ROW_PXX:] = P.reshape(-1, 4).T
    s[ROW_PYX] = s[ROW_PXY] = 0.5 * (s[ROW_PXY] + s[ROW_PYX])   # exact symmetry from the start
    return s


def x_view(s: np.ndarray) -> np.ndarray:
    """Estimates ``(..., M, 2)`` as a view of packed states ``(..., 6, M)``."""
    return np.moveaxis(s[..., ROW_X:ROW_Y + 1, :], -1, -2)


def P_view(s: np.ndarray) -> np.ndarray:
    """Covariances ``(..., M, 2, 2)`` as a view of packed states ``(..., 6, M)``."""
    block = s[..., ROW_PXX:, :]
    return np.moveaxis(block.reshape(block.shape[:-2] + (2, 2, block.shape[-1])), -1, -3)


# --- the two steps (the only implementation of the filter's arithmetic) ------------------------------------------

def predict_step(s: np.ndarray, u: np.ndarray, q4: np.ndarray, out: np.ndarray) -> None:
    """Prediction ``x + u``, ``P + Q`` of the packed states ``s`` (6, M), written into ``out`` (6, M).

    ``u`` has shape (2, M) or (2, 1); ``q4`` is ``[Qxx, Qxy, Qxy, Qyy]`` as a (4, 1) column.
    """
    np.add(s[ROW_X:ROW_Y + 1], u, out=out[ROW_X:ROW_Y + 1])
    np.add(s[ROW_PXX:], q4, out=out[ROW_PXX:])


def update_step(s: np.ndarray, z: np.ndarray, use: np.ndarray, R: float, beacon: tuple[float, float],
                 out: np.ndarray, y_out: np.ndarray, S_out: np.ndarray) -> np.ndarray:
    """Range update of the predicted packed states ``s`` (6, M); the posterior is written into ``out``.

    ``z`` (M,) holds the ranges with missing ones replaced by any finite value and ``use`` (M,) is 1.0 where
    the range is to be used and 0.0 where it is missing: a zero gain leaves those runs exactly at their
    prediction. The innovation and its variance go to ``y_out`` and ``S_out`` (meaningless where unused).
    Returns the ``use`` array actually applied (runs whose prediction is on the beacon removed).
    """
    xp, yp = s[ROW_X], s[ROW_Y]
    pxx, pxy, pyy = s[ROW_PXX], s[ROW_PXY], s[ROW_PYY]
    bx, by = beacon                                  # floats, or arrays (M,)/(1,) for a moving beacon
    dx = xp - bx if (np.ndim(bx) or bx) else xp
    dy = yp - by if (np.ndim(by) or by) else yp
    r = np.sqrt(dx * dx + dy * dy)                   # predicted range h(x-)
    if r.min() == 0.0:                               # H = (x - b)^T / |x - b| is 0/0 there
        on_beacon = r == 0.0
        if (use[on_beacon] != 0.0).any():
            warn("the predicted position is exactly on the beacon, where the range Jacobian is "
                 "undefined: the range update is skipped for that step (predict only)", BeaconSingularityWarning)
        use = np.where(on_beacon, 0.0, use)
        r = np.where(on_beacon, 1.0, r)              # then H = 0 and the gain below is exactly 0
    hx = dx / r                                      # H = [hx, hy], the unit line of sight
    hy = dy / r
    ax = pxx * hx + pxy * hy                         # a = P- H^T
    ay = pxy * hx + pyy * hy
    S = np.add(hx * ax + hy * ay, R, out=S_out)      # S = H P- H^T + R
    g = use / S
    kx = ax * g                                      # K = P- H^T / S (zero where no range is used)
    ky = ay * g
    y = np.subtract(z, r, out=y_out)                 # innovation r - h(x-)
    np.add(xp, kx * y, out=out[ROW_X])
    np.add(yp, ky * y, out=out[ROW_Y])
    # Joseph form P = A P- A^T + R K K^T with A = I - K H, factored as B A^T + R K K^T = B - d K^T:
    bxx = pxx - kx * ax                              # B = A P- = P- - K a^T
    bxy = pxy - kx * ay
    byx = pxy - ky * ax
    byy = pyy - ky * ay
    vx = bxx * hx + bxy * hy - R * kx                # d = B H^T - R K
    vy = byx * hx + byy * hy - R * ky
    np.subtract(bxx, vx * kx, out=out[ROW_PXX])         # P = B - d K^T (upper triangle; P is symmetric)
    np.subtract(bxy, vx * ky, out=out[ROW_PXY])
    np.subtract(byy, vy * ky, out=out[ROW_PYY])
    out[ROW_PYX] = out[ROW_PXY]
    return use


# --- validation -------------------------------------------------------------------------------------------------

def noise_parameters(Q: Any, R: Any) -> tuple[np.ndarray, float, np.ndarray]:
    Q = as_covariance("Q", Q, 2, allow_singular=True)
    if Q.shape != (2, 2):
        raise ValueError(f"Q must be one 2x2 matrix shared by all runs; got shape {Q.shape}")
    R_arr = as_covariance("R", R, 1)
    if R_arr.shape != (1, 1):
        raise ValueError(f"R must be the range variance, a scalar (or a 1x1 matrix); got shape {R_arr.shape}")
    q4 = np.array([Q[0, 0], Q[0, 1], Q[0, 1], Q[1, 1]]).reshape(4, 1)
    return Q, float(R_arr[0, 0]), q4


def fixed_beacon(beacon: Any) -> tuple[float, float]:
    b = as_finite("beacon", beacon, shape=(2,))
    return float(b[0]), float(b[1])


def beacon_path(beacon: Any, n_steps: int) -> tuple[tuple[float, float] | np.ndarray, int | None]:
    """A fixed beacon ``(bx, by)``, or a moving one as a step-major path (K, 2, M) / (K, 2, 1); with the size of
    its runs axis (None if it has none)."""
    b = as_finite("beacon", beacon, ndim=(1, 2, 3))
    if b.shape[-1] != 2 or (b.ndim > 1 and b.shape[-2] != n_steps):
        raise ValueError(f"beacon must be a position [x, y], or one position per step: shape (2,), "
                         f"({n_steps}, 2) or (M, {n_steps}, 2); got {b.shape}")
    if b.ndim == 1:
        return (float(b[0]), float(b[1])), None
    if b.ndim == 2:
        return np.ascontiguousarray(b[:, :, None]), None
    return np.ascontiguousarray(np.moveaxis(b, 0, -1)), b.shape[0]


def initial_state(x0: Any, P0: Any) -> tuple[np.ndarray, np.ndarray]:
    x0 = as_finite("x0", x0, ndim=(1, 2))
    if x0.shape[-1] != 2:
        raise ValueError(f"x0 must be a horizontal position [x, y], shape (2,) or (M, 2); got shape {x0.shape}")
    P0 = as_covariance("P0", P0, 2)
    if P0.ndim not in (2, 3):
        raise ValueError(f"P0 must have shape (2, 2) or (M, 2, 2); got {P0.shape}")
    return x0, P0


def sequence_inputs(x0: Any, P0: Any, u: Any, z: Any,
                     times: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict]:
    """Validate the inputs every functional single-beacon filter takes: the initial state, DR displacements ``u``
    (K, 2) or (M, K, 2) and ranges ``z`` (K,) or (M, K), NaN allowed. Returns them with the times and, for
    ``common_runs``, the size of each input's runs axis (None where it has none)."""
    x0, P0 = initial_state(x0, P0)
    u = as_finite("u", u, ndim=(2, 3))
    if u.shape[-1] != 2:
        raise ValueError(f"u must hold displacements [dx, dy], shape (K, 2) or (M, K, 2); got shape {u.shape}")
    z = as_range_array("z", z, allow_nan=True, ndim=(1, 2))
    K = u.shape[-2]
    if z.shape[-1] != K:
        raise ValueError(f"z must have one range per step of u ({K} steps); got shape {z.shape}")
    run_sizes = dict(x0=x0.shape[0] if x0.ndim == 2 else None, P0=P0.shape[0] if P0.ndim == 3 else None,
                     u=u.shape[0] if u.ndim == 3 else None, z=z.shape[0] if z.ndim == 2 else None)
    return x0, P0, u, z, steps_and_times(K, times), run_sizes


def common_runs(**batched: int | None) -> int | None:
    """The common number of runs among the arguments that have a runs axis (None if none has)."""
    sizes = {name: m for name, m in batched.items() if m is not None}
    if len(set(sizes.values())) > 1:
        described = ", ".join(f"{name} has {m}" for name, m in sizes.items())
        raise ValueError(f"the arguments with a leading runs axis disagree on the number of runs M: {described}")
    return next(iter(sizes.values()), None)



def runs_first(a: np.ndarray, batched: bool) -> np.ndarray:
    """A (M, K, ...) result array as returned to the caller: without the runs axis for an unbatched call."""
    return a if batched else a[0]


def result_fields(times: np.ndarray, post: np.ndarray, prior: np.ndarray, innov: np.ndarray,
                   innov_var: np.ndarray, batched: bool) -> dict[str, np.ndarray]:
    """The common ``FilterResult`` fields of a run held in packed (K, rows, M) buffers, runs axis first."""
    return dict(
        times=times,
        x=runs_first(np.moveaxis(x_view(post), 0, 1), batched),
        P=runs_first(np.moveaxis(P_view(post), 0, 1), batched),
        x_prior=runs_first(np.moveaxis(x_view(prior), 0, 1), batched),
        P_prior=runs_first(np.moveaxis(P_view(prior), 0, 1), batched),
        innovations=runs_first(innov.T[:, :, None], batched),
        innovation_cov=runs_first(innov_var.T[:, :, None, None], batched),
    )


def steps_and_times(n_steps: int, times: Any) -> np.ndarray:
    as_int("the number of steps K", n_steps, minimum=1)
    if times is None:
        return np.arange(n_steps, dtype=float)
    times = as_finite("times", times, ndim=1)
    if len(times) != n_steps:
        raise ValueError(f"times must have one entry per step ({n_steps}); got {len(times)}")
    return times
