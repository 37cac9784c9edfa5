"""The packed 2x2 arithmetic of the single-beacon range EKFs, shared by :mod:`.ekf` and :mod:`.fading`.

The state is a horizontal position and the measurement a scalar range, so every product is written out as 2x2
algebra on arrays of length ``M`` (one entry per Monte Carlo run). The filter state of all runs lives in one
``(6, M)`` array (rows ``x, y, Pxx, Pxy, Pyx, Pyy``). This module is private to :mod:`uwtutor.filters`: the engine's
packed and fading back-ends (:mod:`.engine`, :mod:`.ekf`, :mod:`.fading`) are its only users, and
``tests/test_filter_contract.py`` holds both to the generic arithmetic.
"""

from __future__ import annotations

from typing import Any, overload

import numpy as np
from numpy.typing import ArrayLike

from .._validate import MAX_COORDINATE, as_covariance, as_finite, as_float_array, as_int, as_range_array
from ..errors import BeaconSingularityWarning, IllConditionedError, warn

ROW_X, ROW_Y, ROW_PXX, ROW_PXY, ROW_PYX, ROW_PYY = range(6)
N_ROWS = 6

_min = np.minimum.reduce                              # a.min() without numpy's Python wrapper (run once per step)
_all = np.logical_and.reduce




# --- packing ----------------------------------------------------------------------------------------------------

def pack(x: np.ndarray, P: np.ndarray) -> np.ndarray:
    """Pack estimates ``x`` (M, 2) and covariances ``P`` (M, 2, 2) into one ``(6, M)`` state array."""
    s = np.empty((N_ROWS, x.shape[0]))
    s[ROW_X:ROW_Y + 1] = x.T
    s[ROW_PXX:] = P.reshape(-1, 4).T
    s[ROW_PYX] = s[ROW_PXY] = 0.5 * (s[ROW_PXY] + s[ROW_PYX])   # exact symmetry from the start
    return s


def pack_runs_last(x: np.ndarray, P: np.ndarray) -> np.ndarray:
    """:func:`pack` for covariances held runs-last, ``P`` (2, 2, M), as the generic engine holds them."""
    s = np.empty((N_ROWS, x.shape[0]))
    s[ROW_X:ROW_Y + 1] = x.T
    s[ROW_PXX:] = P.reshape(4, -1)
    s[ROW_PYX] = s[ROW_PXY] = 0.5 * (s[ROW_PXY] + s[ROW_PYX])   # exact symmetry, as pack makes it
    return s


def unpack_runs_last(s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The estimates (M, 2) and runs-last covariances (2, 2, M) of packed states ``s`` (6, M), as new arrays."""
    return s[ROW_X:ROW_Y + 1].T.copy(), s[ROW_PXX:].reshape(2, 2, -1).copy()


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
    add = np.add                                     # row by row: cheaper than one broadcast over the block
    add(s[ROW_X], u[0], out=out[ROW_X])
    add(s[ROW_Y], u[1], out=out[ROW_Y])
    qxx, qxy, qyx, qyy = q4[:, 0]
    add(s[ROW_PXX], qxx, out=out[ROW_PXX])
    add(s[ROW_PXY], qxy, out=out[ROW_PXY])
    add(s[ROW_PYX], qyx, out=out[ROW_PYX])
    add(s[ROW_PYY], qyy, out=out[ROW_PYY])


def update_step(s: np.ndarray, z: np.ndarray, use: np.ndarray, R: Any, beacon: tuple[Any, Any] | None,
                out: np.ndarray, y_out: np.ndarray, S_out: np.ndarray, guard: bool = True) -> np.ndarray:
    """Range update of the predicted packed states ``s`` (6, M); the posterior is written into ``out``.

    ``z`` (M,) holds the ranges with missing ones replaced by any finite value and ``use`` (M,) is 1.0 where
    the range is to be used and 0.0 where it is missing: a zero gain leaves those runs exactly at their
    prediction. ``beacon`` is ``(bx, by)``, floats or arrays (M,)/(1,) for a moving beacon, or None for the
    origin. The innovation and its variance go to ``y_out`` and ``S_out`` (meaningless where unused).
    Returns the ``use`` array actually applied (runs whose prediction is on the beacon removed).

    ``guard=False`` leaves out the test for a prediction on the beacon and the test of the posterior: for a
    caller that tests the posteriors of many steps at once (:func:`first_unsound`; a prediction on the beacon
    makes its posterior NaN) and redoes, with ``guard=True``, the steps from the first that fails.
    """
    xp, yp, pxx, pxy, _, pyy = s                     # the rows (views)
    if beacon is None:                               # the origin
        dx, dy = xp, yp
    else:
        bx, by = beacon                              # floats, or arrays (M,)/(1,) for a moving beacon
        dx = xp - bx if (np.ndim(bx) or bx) else xp
        dy = yp - by if (np.ndim(by) or by) else yp
    r = np.sqrt(dx * dx + dy * dy)                   # predicted range h(x-)
    if guard and _min(r) == 0.0:                     # H = (x - b)^T / |x - b| is 0/0 there
        on_beacon = r == 0.0
        if (use[on_beacon] != 0.0).any():
            warn("the predicted position is exactly on the beacon, where the range Jacobian is "
                 "undefined: the range update is skipped for that step (predict only)", BeaconSingularityWarning)
        use = np.where(on_beacon, 0.0, use)
        dx = np.where(on_beacon, 1.0, dx)            # any unit direction: the gain below is exactly 0 there
        r = np.where(on_beacon, 1.0, r)
    hx = dx / r                                      # H = [hx, hy], the unit line of sight
    hy = dy / r
    ax = pxx * hx + pxy * hy                         # a = P- H^T
    ay = pxy * hx + pyy * hy
    a_los = hx * ax + hy * ay                        # H P- H^T
    S = np.add(a_los, R, out=S_out)                  # S = H P- H^T + R
    g = use / S
    kx = ax * g                                      # K = P- H^T / S (zero where no range is used)
    ky = ay * g
    y = np.subtract(z, r, out=y_out)                 # innovation r - h(x-)
    np.add(xp, kx * y, out=out[ROW_X])
    np.add(yp, ky * y, out=out[ROW_Y])
    # Covariance: the Joseph form P = A P- A^T + R K K^T (A = I - K H), first as the factorization
    # B - d K^T with B = A P- and d = B H^T - R K (algebraically equal, 25 array operations). It keeps P
    # positive semi-definite while R / S is not tiny; every result is tested (variances >= 0, det >= 0, finite)
    # and where the test fails -- an update whose dynamic range float64 cannot carry, such as P0 = 1e12 I with
    # R = 1e-6 -- the whole step is recomputed in the line-of-sight frame (``_los_update``), which is PSD to
    # rounding by construction.
    bxx = pxx - kx * ax                              # B = A P- = P- - K a^T
    bxy = pxy - kx * ay
    byx = pxy - ky * ax
    byy = pyy - ky * ay
    vx = bxx * hx + bxy * hy - R * kx                # d = B H^T - R K
    vy = byx * hx + byy * hy - R * ky
    nxx = np.subtract(bxx, vx * kx, out=out[ROW_PXX])   # P = B - d K^T (upper triangle; P is symmetric)
    nxy = np.subtract(bxy, vx * ky, out=out[ROW_PXY])
    nyy = np.subtract(byy, vy * ky, out=out[ROW_PYY])
    out[ROW_PYX] = nxy
    if not guard:
        return use
    det = nxx * nyy
    det -= nxy * nxy
    if not (_min(det) >= 0.0 and _min(out[ROW_PXX::3], axis=None) >= 0.0):   # rows Pxx, Pyy; False for a NaN
        _los_update(s, hx, hy, ax, ay, a_los, g, use, R, out)
        # a+ >= 0 and b+^2 <= a+ c+ hold there by construction; what remains to refuse is a prediction that was
        # not PSD (a < 0), a value that overflowed, or round-off of the rotation beyond the stated tolerance
        check_psd(out, R)
    return use


def first_unsound(post: np.ndarray) -> int | None:
    """The first of the packed posteriors ``post`` (B, 6, M) of consecutive steps that :func:`update_step`'s test
    refuses (a variance or the determinant below 0, or NaN, in any run), or None.

    The determinant is computed as in the step, so that a step passes here exactly when it passes there.
    """
    pxx, pxy, pyy = post[:, ROW_PXX], post[:, ROW_PXY], post[:, ROW_PYY]
    det = pxx * pyy
    det -= pxy * pxy
    low = np.minimum(pxx, pyy)
    np.minimum(low, det, out=low)
    least = _min(low, axis=1)                        # (B,): NaN where any entry is NaN
    ok = least >= 0.0
    if _all(ok):
        return None
    return int(np.argmin(ok))


def _los_update(s: np.ndarray, hx: np.ndarray, hy: np.ndarray, ax: np.ndarray, ay: np.ndarray, a_los: np.ndarray,
                g: np.ndarray, use: np.ndarray, R: Any, out: np.ndarray) -> None:
    """The covariance update in the frame of the line of sight, PSD to rounding whatever the conditioning."""
    pxx, pxy, pyy = s[ROW_PXX], s[ROW_PXY], s[ROW_PYY]
    # Covariance update in the frame of the line of sight (u = H^T along it, v = (-hy, hx) across it), where it
    # is exact algebra with no cancellation: with a = u^T P- u (= H P- H^T), b = u^T P- v, c = v^T P- v and
    # w = R / S where the range is used (1 where it is not),
    #     a+ = a w,   b+ = b w,   c+ = c - b^2 / S,
    # the Joseph form's value (A P- A^T + K R K^T, A = I - K H). Exactly, b^2 w / a <= c+ <= c (the first is
    # det(P+) >= 0, the second "a range never adds uncertainty"); c+ is held in that interval, so that rounding
    # cannot make P+ indefinite (det P+ = a+ c+ - b+^2 >= 0). Rotated back,
    # P+ = a+ u u^T + b+ (u v^T + v u^T) + c+ v v^T. The literal Joseph product and the factorization
    # P- - K a^T both lose positive semi-definiteness once R << H P- H^T (P0 = 1e12 I with R = 1e-6).
    b_los = hx * ay - hy * ax
    hxx, hxy = hx * hx, hx * hy
    hyy = hy * hy
    cross = pxy * hxy
    cross += cross
    c_los = hyy * pxx + hxx * pyy                    # v^T P- v (computed directly: the trace minus a loses the
    c_los -= cross                                   # small variance of an ill-conditioned P-)
    w = R * g                                        # R / S where the range is used, 1 where it is not (no
    w += 1.0 - use                                   # cancellation of 1 - a / S when R << a)
    a_post = a_los * w
    b_post = b_los * w
    bb = b_los * b_los
    c_post = c_los - bb * g
    with np.errstate(invalid="ignore", divide="ignore"):
        np.fmax(c_post, bb * w / a_los, out=c_post)  # fmax: 0/0 (a = b = 0) leaves c+ alone
    # back from the line-of-sight frame: P+ = a+ u u^T + b+ (u v^T + v u^T) + c+ v v^T (each variance a sum of
    # its two frames' terms: writing it as c+ I + (a+ - c+) u u^T would cancel when c+ >> a+)
    t = b_post * hxy
    t += t
    np.add(a_post * hxx - t, c_post * hyy, out=out[ROW_PXX])
    np.add((a_post - c_post) * hxy, b_post * (hxx - hyy), out=out[ROW_PXY])
    np.add(a_post * hyy + t, c_post * hxx, out=out[ROW_PYY])
    out[ROW_PYX] = out[ROW_PXY]
    if use.min() == 0.0:                             # unused ranges: P stays the prediction's, bit for bit
        np.copyto(out[ROW_PXX:], s[ROW_PXX:], where=use == 0.0)


def check_psd(s: np.ndarray, R: Any) -> None:
    """Refuse posteriors that float64 could not keep positive semi-definite.

    The Joseph form keeps P symmetric PSD to within rounding as long as the update's dynamic range fits in
    float64's 16 digits. When the variance along the line of sight drops from ``H P- H^T`` to about ``R`` with a
    ratio beyond ~1e16 (e.g. ``P0 = 1e12 I`` with ``R = 1e-6``), the small eigenvalue is below the rounding of the
    large entries and the computed P can be indefinite; the fading factor would then magnify it. Tolerance:
    ``det P >= -1e-9 Pxx Pyy`` and non-negative variances.
    """
    pxx, pxy, pyy = s[ROW_PXX], s[ROW_PXY], s[ROW_PYY]
    prod = pxx * pyy
    det = prod - pxy * pxy
    if det.min() >= -1e-9 * prod.max() and pxx.min() >= 0.0 and pyy.min() >= 0.0 and np.isfinite(det).all():
        return
    bad = ~((det >= -1e-9 * prod) & (pxx >= 0.0) & (pyy >= 0.0) & np.isfinite(det))
    if not bad.any():
        return
    m = int(np.argmax(bad))
    r_m = float(np.ravel(R)[m] if np.ndim(R) else R)
    raise IllConditionedError(
        f"the covariance lost positive semi-definiteness at a range update (run {m}: Pxx = {pxx[m]:.3g}, "
        f"Pxy = {pxy[m]:.3g}, Pyy = {pyy[m]:.3g}, range variance R = {r_m:.3g}): the ratio of the predicted variance "
        "to R exceeds what float64's 16 digits can carry. Start from a smaller P0 (an honest initial uncertainty, "
        "e.g. 1e4 to 1e6 m^2) or use a larger R")


# --- validation -------------------------------------------------------------------------------------------------

def noise_parameters(Q: Any, R: Any, n_steps: int | None = None,
                     where: str = "range_only_ekf") -> tuple[np.ndarray, Any, np.ndarray]:
    """``Q`` (2, 2) and the range variance ``R`` (a float); with ``n_steps`` also one per step: ``Q`` (K, 2, 2) and
    ``R`` (K,) (NaN allowed at steps without a range). Returns ``(Q, R, q4)`` with ``q4`` the packed ``[Qxx, Qxy,
    Qxy, Qyy]`` as a (4, 1) column, or (K, 4, 1) per step."""
    Q = as_covariance("Q", Q, 2, allow_singular=True)
    per_step = n_steps is not None and Q.shape == (n_steps, 2, 2)
    if Q.shape != (2, 2) and not per_step:
        if n_steps is None:
            raise ValueError(f"Q must be one 2x2 matrix shared by all runs; got shape {Q.shape} (one Q per step is "
                             f"taken by {where}'s functional form)")
        raise ValueError(f"Q must be one 2x2 matrix shared by all runs, or one per step ({n_steps}, 2, 2); got shape "
                         f"{Q.shape}")
    R_val = range_variances(R, n_steps)
    if per_step:
        q4 = np.stack([Q[:, 0, 0], Q[:, 0, 1], Q[:, 0, 1], Q[:, 1, 1]], axis=1)[:, :, None]
    else:
        q4 = np.array([Q[0, 0], Q[0, 1], Q[0, 1], Q[1, 1]]).reshape(4, 1)
    return Q, R_val, q4


@overload
def range_variances(R: ArrayLike, n_steps: None = None) -> float: ...
@overload
def range_variances(R: ArrayLike, n_steps: int | None) -> float | np.ndarray: ...
def range_variances(R: ArrayLike, n_steps: int | None = None) -> float | np.ndarray:
    """The range variance: a float (from a scalar or a 1x1 matrix), or, with ``n_steps``, one per step (K,),
    > 0, NaN allowed at steps without a range."""
    R_arr = as_float_array("R", R)
    if n_steps is not None and R_arr.ndim == 1:
        if R_arr.shape != (n_steps,):
            raise ValueError(f"R must be the range variance, or one per step ({n_steps},); got shape {R_arr.shape}")
        bad = np.isinf(R_arr) | (R_arr <= 0)
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise ValueError(f"R must hold range variances > 0 (NaN at a step without a range); got {R_arr[k]:g} at "
                             f"step {k}")
        return R_arr
    if n_steps is None and R_arr.ndim == 1 and R_arr.size > 1:
        raise ValueError(f"R must be one range variance here; got shape {R_arr.shape} (one variance per step is "
                         "taken by the functional forms range_only_ekf and bias_ekf)")
    R_arr = as_covariance("R", R, 1)
    if R_arr.shape != (1, 1):
        per = f", or one variance per step ({n_steps},)" if n_steps is not None else ""
        raise ValueError(f"R must be the range variance, a scalar (or a 1x1 matrix){per}; got shape {R_arr.shape}")
    return float(R_arr[0, 0])


def check_variances_where_measured(R: Any, z: np.ndarray) -> Any:
    """Per-step range variances ``R`` (K,) may be NaN only where no range is present in ``z`` (..., K): refuse one
    where a range is present; return ``R`` with those NaNs replaced by 1 (any finite value: they are not used)."""
    if not isinstance(R, np.ndarray) or not np.isnan(R).any():
        return R
    bad = np.isnan(R) & np.isfinite(z).reshape(-1, z.shape[-1]).any(axis=0)
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise ValueError(f"R is NaN at step {k}, where a range is present: give its variance")
    return np.where(np.isnan(R), 1.0, R)


def fixed_beacon(beacon: Any) -> tuple[float, float]:
    b = as_finite("beacon", beacon, shape=(2,), max_abs=MAX_COORDINATE)
    return float(b[0]), float(b[1])


def beacon_path(beacon: Any, n_steps: int) -> tuple[tuple[float, float] | np.ndarray, int | None]:
    """A fixed beacon ``(bx, by)``, or a moving one as a step-major path (K, 2, M) / (K, 2, 1); with the size of
    its runs axis (None if it has none)."""
    b = as_finite("beacon", beacon, ndim=(1, 2, 3), max_abs=MAX_COORDINATE, nonempty=True)
    if b.shape[-1] != 2 or (b.ndim > 1 and b.shape[-2] != n_steps):
        raise ValueError(f"beacon must be a position [x, y], or one position per step: shape (2,), "
                         f"({n_steps}, 2) or (M, {n_steps}, 2); got {b.shape}")
    if b.ndim == 1:
        return (float(b[0]), float(b[1])), None
    if b.ndim == 2:
        return np.ascontiguousarray(b[:, :, None]), None
    return np.ascontiguousarray(np.moveaxis(b, 0, -1)), b.shape[0]


def initial_state(x0: Any, P0: Any) -> tuple[np.ndarray, np.ndarray]:
    x0 = as_finite("x0", x0, ndim=(1, 2), max_abs=MAX_COORDINATE, nonempty=True)
    if x0.shape[-1] != 2:
        raise ValueError(f"x0 must be a horizontal position [x, y], shape (2,) or (M, 2); got shape {x0.shape}")
    P0 = as_covariance("P0", P0, 2)
    if P0.ndim not in (2, 3):
        raise ValueError(f"P0 must have shape (2, 2) or (M, 2, 2); got {P0.shape}")
    return x0, P0


def sequence_inputs(x0: Any, P0: Any, u: Any, z: Any,
                     times: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                          dict[str, int | None]]:
    """Validate the inputs every functional single-beacon filter takes: the initial state, DR displacements ``u``
    (K, 2) or (M, K, 2) and ranges ``z`` (K,) or (M, K), NaN allowed. Returns them with the times and, for
    ``_validate.common_runs``, the size of each input's runs axis (None where it has none)."""
    x0, P0 = initial_state(x0, P0)
    u = as_finite("u", u, ndim=(2, 3), max_abs=MAX_COORDINATE)
    if u.ndim == 3 and u.shape[0] == 0:
        raise ValueError(f"u has no runs (shape {u.shape}): give at least one run, or drop the runs axis")
    if u.shape[-1] != 2:
        raise ValueError(f"u must hold displacements [dx, dy], shape (K, 2) or (M, K, 2); got shape {u.shape}")
    z = as_range_array("z", z, allow_nan=True, ndim=(1, 2), max_abs=MAX_COORDINATE)
    if z.ndim == 2 and z.shape[0] == 0:
        raise ValueError(f"z has no runs (shape {z.shape}): give at least one run, or drop the runs axis")
    K = u.shape[-2]
    if z.shape[-1] != K:
        raise ValueError(f"z must have one range per step of u ({K} steps); got shape {z.shape}")
    run_sizes = dict(x0=x0.shape[0] if x0.ndim == 2 else None, P0=P0.shape[0] if P0.ndim == 3 else None,
                     u=u.shape[0] if u.ndim == 3 else None, z=z.shape[0] if z.ndim == 2 else None)
    return x0, P0, u, z, steps_and_times(K, times), run_sizes



def runs_first(a: np.ndarray, batched: bool) -> np.ndarray:
    """A (M, K, ...) result array as returned to the caller: without the runs axis for an unbatched call."""
    return a if batched else a[0]


def result_fields(times: np.ndarray, post: np.ndarray, prior: np.ndarray, innov: np.ndarray,
                   innov_var: np.ndarray, batched: bool, keep_priors: bool = True) -> dict[str, Any]:
    """The common ``FilterResult`` fields of a run held in packed (K, rows, M) buffers, runs axis first (the
    priors None without ``keep_priors``: the result then holds no view of the ``prior`` buffer)."""
    return dict(
        times=times,
        x=runs_first(np.moveaxis(x_view(post), 0, 1), batched),
        P=runs_first(np.moveaxis(P_view(post), 0, 1), batched),
        x_prior=runs_first(np.moveaxis(x_view(prior), 0, 1), batched) if keep_priors else None,
        P_prior=runs_first(np.moveaxis(P_view(prior), 0, 1), batched) if keep_priors else None,
        innovations=runs_first(innov.T[:, :, None], batched),
        innovation_cov=runs_first(innov_var.T[:, :, None, None], batched),
    )


def steps_and_times(n_steps: int, times: Any) -> np.ndarray:
    as_int("the number of steps K", n_steps, minimum=1)
    if times is None:
        return np.arange(n_steps, dtype=float)
    stamps = as_finite("times", times, ndim=1)
    if len(stamps) != n_steps:
        raise ValueError(f"times must have one entry per step ({n_steps}); got {len(stamps)}")
    return stamps
