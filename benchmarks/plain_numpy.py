"""Plain-numpy references for ``make bench``: the same work as two of the library's filters, written for the purpose.

Each function here does what one library call does -- the same equations, the same inputs and the same outputs, in
the same order of floating-point operations, so that the results agree bit for bit -- and nothing else: no
validation of the inputs, no guard against a covariance that loses positive semi-definiteness, no handling of a
prediction that falls on the beacon, no filter protocol. ``benchmarks/run.py`` times each beside the library call
in the same process (``--only ekf_vs_numpy``, ``--only pf_vs_numpy``) and reports the ratio of the two times: what
the library's checks, guards and generality cost on top of the arithmetic.

* :func:`range_only_ekf` -- ``uwtutor.filters.range_only_ekf`` on ``M`` runs of ``K`` steps, the beacon at the
  origin, one ``Q`` and one ``R`` for every step: the state of the runs as arrays of length ``M`` (one per
  component of the estimate and of its covariance), the explicit 2x2 algebra of the range update, the Joseph-form
  covariance in the factorization ``B - d K^T`` that the library uses.
* :func:`bootstrap_pf` -- ``uwtutor.filters.BootstrapParticleFilter`` on paper C's depth/speed/pitch model
  (``uwtutor.models.DepthSpeedPitchModel``), one run of ``N`` particles, systematic resampling after every
  measurement, every draw from the same generator in the same order as the library.
"""

from __future__ import annotations

from typing import Any

import numpy as np


def range_only_ekf(x0: np.ndarray, P0: np.ndarray, u: np.ndarray, z: np.ndarray, Q: np.ndarray,
                   R: float) -> dict[str, np.ndarray]:
    """The range-only EKF, ``M`` runs at once, beacon at the origin.

    ``x0`` (M, 2), ``P0`` (2, 2), ``u`` (M, K, 2), ``z`` (M, K) with NaN for a missing range, ``Q`` (2, 2), ``R`` a
    float. Returns the step-major histories: ``x`` and ``x_prior`` (K, 2, M), ``P`` and ``P_prior`` (K, 4, M) (rows
    Pxx, Pxy, Pyx, Pyy), ``y`` and ``S`` (K, M), NaN where no range was used.
    """
    M, K = z.shape
    U = np.ascontiguousarray(u.transpose(1, 2, 0))            # (K, 2, M): each step reads contiguous rows
    Z = np.ascontiguousarray(z.T)                             # (K, M), a copy
    use = np.isfinite(Z).astype(float)                        # 1.0 where a range is used, 0.0 where missing
    Z[use == 0.0] = 0.0                                       # with a zero gain any finite value does
    X, Xp = np.empty((K, 2, M)), np.empty((K, 2, M))
    P, Pp = np.empty((K, 4, M)), np.empty((K, 4, M))
    Y, S = np.empty((K, M)), np.empty((K, M))
    qxx, qxy, qyy = float(Q[0, 0]), float(Q[0, 1]), float(Q[1, 1])
    x, y = x0[:, 0], x0[:, 1]
    pxx, pxy, pyy = np.full(M, float(P0[0, 0])), np.full(M, float(P0[0, 1])), np.full(M, float(P0[1, 1]))
    for k in range(K):
        # predict: x- = x + u, P- = P + Q
        xp = np.add(x, U[k, 0], out=Xp[k, 0])
        yp = np.add(y, U[k, 1], out=Xp[k, 1])
        ppxx = np.add(pxx, qxx, out=Pp[k, 0])
        ppxy = np.add(pxy, qxy, out=Pp[k, 1])
        Pp[k, 2] = ppxy
        ppyy = np.add(pyy, qyy, out=Pp[k, 3])
        # update with the range: H = (x- - b)^T / |x- - b|, S = H P- H^T + R, K = P- H^T / S
        r = np.sqrt(xp * xp + yp * yp)
        hx = xp / r
        hy = yp / r
        ax = ppxx * hx + ppxy * hy
        ay = ppxy * hx + ppyy * hy
        s = np.add(hx * ax + hy * ay, R, out=S[k])
        g = use[k] / s
        kx = ax * g
        ky = ay * g
        inn = np.subtract(Z[k], r, out=Y[k])
        x = np.add(xp, kx * inn, out=X[k, 0])
        y = np.add(yp, ky * inn, out=X[k, 1])
        # Joseph form (I - K H) P- (I - K H)^T + K R K^T, as B - d K^T with B = P- - K (P- H^T)^T, d = B H^T - R K
        bxx = ppxx - kx * ax
        bxy = ppxy - kx * ay
        byx = ppxy - ky * ax
        byy = ppyy - ky * ay
        vx = bxx * hx + bxy * hy - R * kx
        vy = byx * hx + byy * hy - R * ky
        pxx = np.subtract(bxx, vx * kx, out=P[k, 0])
        pxy = np.subtract(bxy, vx * ky, out=P[k, 1])
        P[k, 2] = pxy
        pyy = np.subtract(byy, vy * ky, out=P[k, 3])
    unused = use == 0.0
    Y[unused] = np.nan
    S[unused] = np.nan
    return {"x": X, "P": P, "x_prior": Xp, "P_prior": Pp, "y": Y, "S": S}


def bootstrap_pf(x0: np.ndarray, P0: np.ndarray, z: np.ndarray, n_particles: int, rng: np.random.Generator,
                 T: float, process_std: np.ndarray, R: np.ndarray) -> dict[str, np.ndarray]:
    """The bootstrap particle filter on paper C's depth/speed/pitch model, one run, resampling every step.

    Initial particles from N(``x0``, ``P0``) (Cholesky factor); each step draws the process noise ``(3, N)`` from
    ``rng``, moves the particles with :math:`g(x + u)`, weighs them by the Gaussian likelihood of the direct
    measurement ``z[k]`` (3,) with the diagonal ``R``, records the moments, and resamples systematically (one
    uniform from ``rng``). Returns ``x``, ``x_prior`` (K, 3), ``P``, ``P_prior``, ``S`` (K, 3, 3), ``y`` (K, 3),
    ``ess`` (K,).
    """
    K = z.shape[0]
    N = int(n_particles)
    particles = x0 + rng.standard_normal((N, 3)) @ np.linalg.cholesky(P0).T
    rows = np.ascontiguousarray(particles.T)                  # (3, N): each component contiguous
    std = process_std[:, None]
    white = (1.0 / np.sqrt(np.diag(R)))[:, None]              # R diagonal: the whitening is 1 / sigma
    strata = np.arange(N, dtype=float)
    w0 = np.full(N, 1.0 / N)
    X, Xp = np.empty((K, 3)), np.empty((K, 3))
    P, Pp = np.empty((K, 3, 3)), np.empty((K, 3, 3))
    Y, S, ess = np.empty((K, 3)), np.empty((K, 3, 3)), np.empty(K)
    for k in range(K):
        # predict: x = g(x + u), u ~ N(0, diag(std^2)); z_k = s_z + s_v sin(s_phi) T
        noise = rng.standard_normal((3, N))
        noise *= std
        s = np.add(rows, noise, out=noise)
        dz = np.sin(s[2])
        dz *= s[1]
        dz *= T
        s[0] += dz
        rows = s
        mean = rows @ w0                                      # prior moments (equal weights after resampling)
        d = rows - mean[:, None]
        Xp[k], Pp[k] = mean, (d * w0) @ d.T
        # update: h(x) = x, so the innovation statistics are the prior moments
        Y[k] = z[k] - Xp[k]
        S[k] = Pp[k] + R
        e = rows - z[k][:, None]
        e *= white
        e *= e
        logw = np.add.reduce(e, axis=0)
        logw *= -0.5
        w = logw - logw.max()
        np.exp(w, out=w)
        w /= np.add.reduce(w)
        mean = rows @ w
        d = rows - mean[:, None]
        X[k], P[k] = mean, (d * w) @ d.T
        ess[k] = 1.0 / float(w @ w)
        # systematic resampling: points (j + U) / N in the cumulative weights
        points = strata + rng.random()
        points /= N
        c = np.add.accumulate(w)
        c[-1] = 1.0
        rows = rows.take(c.searchsorted(points, side="right"), axis=1)
    return {"x": X, "P": P, "x_prior": Xp, "P_prior": Pp, "y": Y, "S": S, "ess": ess}


def assert_ekf_agrees(library: Any, plain: dict[str, np.ndarray], rtol: float = 1e-9) -> float:
    """Check that a ``FilterResult`` of ``range_only_ekf`` (runs axis first) and :func:`range_only_ekf`'s output
    agree to ``rtol`` relative (NaN where the other has NaN); return the largest relative difference."""
    K, M = plain["y"].shape
    pairs = [
        (library.x, np.moveaxis(plain["x"], 2, 0)),
        (library.x_prior, np.moveaxis(plain["x_prior"], 2, 0)),
        (library.P, np.moveaxis(plain["P"], 2, 0).reshape(M, K, 2, 2)),
        (library.P_prior, np.moveaxis(plain["P_prior"], 2, 0).reshape(M, K, 2, 2)),
        (library.innovations[..., 0], plain["y"].T),
        (library.innovation_cov[..., 0, 0], plain["S"].T),
    ]
    return _assert_close(pairs, rtol, "range-only EKF")


def assert_pf_agrees(library: Any, plain: dict[str, np.ndarray], rtol: float = 1e-9) -> float:
    """The same check for a single-run ``BootstrapParticleFilter.run`` result and :func:`bootstrap_pf`'s output."""
    pairs = [(library.x, plain["x"]), (library.x_prior, plain["x_prior"]), (library.P, plain["P"]),
             (library.P_prior, plain["P_prior"]), (library.innovations, plain["y"]),
             (library.innovation_cov, plain["S"]), (library.extras["ess"], plain["ess"])]
    return _assert_close(pairs, rtol, "bootstrap particle filter")


def _assert_close(pairs: list[tuple[np.ndarray, np.ndarray]], rtol: float, what: str) -> float:
    worst = 0.0
    for i, (a, b) in enumerate(pairs):
        a, b = np.asarray(a), np.asarray(b)
        if a.shape != b.shape or not np.array_equal(np.isnan(a), np.isnan(b)):
            raise AssertionError(f"{what}: output {i} differs from the plain-numpy reference in shape or NaNs")
        ok = ~np.isnan(a)
        scale = np.maximum(np.abs(b[ok]), np.abs(b[ok]).max() * 1e-12 + 1e-300)
        rel = float((np.abs(a[ok] - b[ok]) / scale).max()) if ok.any() else 0.0
        if not rel <= rtol:
            raise AssertionError(f"{what}: output {i} differs from the plain-numpy reference by {rel:.3g} "
                                 f"(relative; allowed {rtol:g})")
        worst = max(worst, rel)
    return worst


def generic_ekf(motion: Any, measurement: Any, x0: np.ndarray, P0: np.ndarray, u: np.ndarray | None,
                z: np.ndarray) -> dict[str, np.ndarray]:
    """``uwtutor.filters.extended_kalman_filter`` for **one run** (no gate): the model pair's own ``linearize`` for
    f, F, Q and h, H, R (the models' arithmetic), then the engine's equations in the engine's order of operations
    -- ``einsum`` on runs-last (n, n, 1) covariances, the masked update where some components of ``z`` are missing,
    the Joseph form as written, symmetrized -- with no validation, no test of the values the models return and no
    guard against a covariance that loses positive semi-definiteness.

    ``x0`` (n,), ``P0`` (n, n), ``u`` (K, p) or None, ``z`` (K,) or (K, m) with NaN where missing. Returns the
    step-major histories ``x``, ``x_prior`` (K, n), ``P``, ``P_prior`` (K, n, n), ``y`` (K, m), ``S`` (K, m, m), as
    the engine's result holds them for an unbatched run.
    """
    n, m = motion.n, measurement.m
    K = z.shape[0]
    Z = z.reshape(K, 1, m)
    eye = np.eye(n)
    eye_m = np.eye(m)
    out = {"x": np.empty((K, n)), "x_prior": np.empty((K, n)), "P": np.empty((K, n, n)),
           "P_prior": np.empty((K, n, n)), "y": np.empty((K, m)), "S": np.empty((K, m, m))}
    x = np.array(x0, dtype=float).reshape(1, n)
    P = np.ascontiguousarray(np.asarray(P0, dtype=float).reshape(1, n, n).transpose(1, 2, 0))   # (n, n, 1)
    for k in range(K):
        # predict: x- = f(x, u), P- = F P F^T + Q, symmetrized
        x, F, Q = motion.linearize(x, None if u is None else u[k], k)
        if F.ndim == 2 and np.array_equal(F, eye):
            P = P.copy()
        elif F.ndim == 2:
            P = np.einsum("ikm,jk->ijm", np.tensordot(F, P, axes=(1, 0)), F)
        else:
            Fc = np.ascontiguousarray(F.transpose(1, 2, 0))
            P = np.einsum("ikm,jkm->ijm", np.einsum("ikm,kjm->ijm", Fc, P), Fc)
        P += Q[:, :, None] if Q.ndim == 2 else np.ascontiguousarray(Q.transpose(1, 2, 0))
        P += P.transpose(1, 0, 2)
        P *= 0.5
        out["x_prior"][k] = x[0]
        out["P_prior"][k] = P[:, :, 0]
        # update: S = H P- H^T + R, K = P- H^T S^-1, the Joseph form, with the missing components masked out
        z_pred, H, _ = measurement.linearize(x, k)
        z_pred = z_pred.reshape(1, m)
        R = measurement.R(x, k)
        zk = Z[k]
        present = np.isfinite(zk)
        has = present.any(axis=1)
        if not np.isfinite(z_pred.sum() + H.sum() + R.sum()) or bool((has & ~present.all(axis=1)).any()):
            H = np.where(present[:, :, None], H, 0.0)
            R = np.where(present[:, :, None] & present[:, None, :], R, eye_m)
            masked = True
        else:
            masked = False
        Hc = np.ascontiguousarray(H.transpose(1, 2, 0))
        Rc = R[:, :, None] if R.ndim == 2 else np.ascontiguousarray(R.transpose(1, 2, 0))
        PHT = np.einsum("ikm,jkm->ijm", P, Hc)
        S = np.einsum("ikm,kjm->ijm", Hc, PHT) + Rc
        y = measurement.residual(zk, z_pred)
        y_used = np.where(present, y, 0.0)
        if m == 1:
            gain = PHT / S[0, 0]
        else:
            gain = np.ascontiguousarray(np.swapaxes(np.linalg.solve(S.transpose(2, 0, 1),
                                                                    PHT.transpose(2, 0, 1).swapaxes(-1, -2)),
                                                    -1, -2)).transpose(1, 2, 0)
            gain = np.ascontiguousarray(gain)
        gain *= has
        x = x + np.einsum("ijm,mj->mi", gain, y_used)
        A = eye[:, :, None] - np.einsum("ikm,kjm->ijm", gain, Hc)
        P = np.einsum("ikm,jkm->ijm", np.einsum("ikm,kjm->ijm", A, P), A)
        P += np.einsum("ikm,jkm->ijm", np.einsum("ikm,kjm->ijm", gain, Rc), gain)
        P += P.transpose(1, 0, 2)
        P *= 0.5
        out["x"][k] = x[0]
        out["P"][k] = P[:, :, 0]
        S = S.transpose(2, 0, 1)
        if masked:
            out["y"][k] = np.where(present, y, np.nan)[0]
            out["S"][k] = np.where(present[:, :, None] & present[:, None, :], S, np.nan)[0]
        else:
            out["y"][k] = np.where(has[:, None], y, np.nan)[0]
            out["S"][k] = np.where(has[:, None, None], S, np.nan)[0]
    return out
