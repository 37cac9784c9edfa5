r"""Paper A's start: a least-squares prepositioning fix of position and range bias, then the bias EKF from it
(:func:`prepositioned_bias_ekf`).

A pipeline, not a filter: the precision factor along the provisional track
(:func:`uwtutor.lsq.precision_factor_history`)
chooses the epoch of the fix, :func:`uwtutor.lsq.prepositioning` computes it, and
:func:`uwtutor.filters.bias.bias_ekf` runs from it (each run from its own epoch,
:func:`~uwtutor.pipelines.staggered.filter_from_start_epochs`).
"""

from __future__ import annotations

import warnings

import numpy as np
from numpy.typing import ArrayLike

from .. import lsq
from .._cancel import checkpoint
from .._validate import as_covariance, as_finite, as_float_array, as_int, as_positive
from ..filters.base import FilterResult
from ..filters.bias import bias_ekf, bias_model_pair
from ..filters._packed import range_variances
from .staggered import filter_from_start_epochs

__all__ = ["prepositioned_bias_ekf"]


def _row_patterns(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``np.unique(mask, axis=0, return_inverse=True)`` of a boolean (runs, epochs) mask with at least one epoch:
    the distinct rows (in the same order) and the index of each run's row among them. Each row is compared as one
    string of bytes: ``unique`` with ``axis=0`` makes a structured type of one field per epoch, which costs
    milliseconds for a few hundred epochs, and this is called once per start epoch."""
    rows = np.ascontiguousarray(mask, dtype=bool)
    distinct, which = np.unique(rows.view(np.dtype((np.void, rows.shape[1]))).ravel(), return_inverse=True)
    return distinct.view(bool).reshape(-1, rows.shape[1]), which.ravel()


def _alpha_on_finite(provisional: np.ndarray, finite: np.ndarray, beacon: np.ndarray) -> np.ndarray:
    """Precision factor after each epoch (M, K), counting only the epochs with a range (held between them)."""
    M, K = finite.shape
    alpha = np.full((M, K), np.inf)
    patterns, which = _row_patterns(finite)
    for p, pattern in enumerate(patterns):
        runs = np.flatnonzero(which.ravel() == p)
        cols = np.flatnonzero(pattern)
        if cols.size == 0:
            continue
        a = lsq.precision_factor_history(provisional[runs][:, cols], beacon)
        held = np.full((runs.size, K), np.nan)
        held[:, cols] = a
        first = np.maximum.accumulate(np.where(np.isnan(held), 0, np.arange(K)), axis=1)   # last epoch with a range
        held = np.take_along_axis(held, first, axis=1)
        alpha[runs] = np.where(np.isnan(held), np.inf, held)
    return alpha


def prepositioned_bias_ekf(provisional_start: ArrayLike, P0: ArrayLike | None, dr_displacements: ArrayLike,
                           ranges: ArrayLike, Q: ArrayLike, R: float, *, max_alpha: ArrayLike = 2.0,
                           beacon: ArrayLike = (0.0, 0.0), iterations: int = 3,
                           times: ArrayLike | None = None) -> FilterResult:
    r"""Paper A's pre-positioning, then its IEKF: every run starts at its first epoch with :math:`\alpha <`
    ``max_alpha``.

    1. **Provisional track.** ``provisional_start`` carried by the DR displacements:
       :math:`\tilde{\mathbf p}_k = \tilde{\mathbf p}_0 + \sum_{j \le k}\mathbf u_j`.
    2. **Precision factor** after each epoch along it (``uwtutor.lsq.precision_factor_history``, three unknowns,
       only the epochs with a range): the first epoch :math:`k_0` with :math:`\alpha_{k_0} <` ``max_alpha``
       (paper A: 2) is the run's start.
    3. **Fix** at :math:`k_0`: ``uwtutor.lsq.prepositioning`` (position *and* bias, ``iterations`` Gauss-Newton
       steps from :math:`\tilde{\mathbf p}_{k_0}`) on the ranges of epochs :math:`0..k_0`.
    4. **Filter** from :math:`k_0`: :func:`~uwtutor.filters.bias.bias_ekf` from the fix with covariance ``P0``,
       over epochs :math:`k_0 + 1, \dots` (all runs in one call: each run's arrays are shifted to start at step 0).

    The arguments come in the filters' order ``(x0, P0, u, z, Q, R)``: the provisional start, the covariance the
    filter starts with, the DR displacements, the ranges, then the noise.

    Parameters
    ----------
    provisional_start : array_like, shape (2,) or (M, 2)
        Provisional position at epoch 0 [m] (e.g. the position the vehicle believed it started from).
    P0 : array_like, shape (3, 3) or (M, 3, 3), or None
        Covariance the filter starts with; ``None``: the fix's own :math:`R\,(\mathbf A^\mathsf T\mathbf A)^{-1}`
        (paper A starts from the identity).
    dr_displacements : array_like, shape (M, K, 2)
        DR displacements (row 0: from the provisional start to epoch 0, usually zeros).
    ranges : array_like, shape (M, K)
        Measured ranges [m], NaN where missing.
    Q : array_like, shape (3, 3)
        Process noise of the IEKF [m²].
    R : float
        White range noise variance [m²] (also the :math:`\sigma^2` of the fix's covariance).
    max_alpha : float, default 2
        Acceptance threshold on the precision factor.
    beacon : array_like, shape (2,), optional
        Fixed beacon position [m] (for a moving one, work in the frame of the beacon as paper A's lake trial does:
        ``u = u_receiver - u_sender``).
    iterations : int, default 3
        Gauss-Newton steps of the fix (paper A takes one; three make it independent of a provisional error of
        a hundred metres or more, chapter 3).
    times : array_like, shape (K,), optional
        Epoch times for the result.

    Returns
    -------
    FilterResult
        Arrays of shape (M, K, ...) on the epochs: NaN before each run's start, the fix (with ``P0``) at its
        start, the filter after. ``extras``: ``"accepted"`` (M, K), True where a range was used by the filter;
        ``"started"`` (M, K), True from the start epoch on; ``"alpha"`` (M, K), the precision factor on the
        provisional track up to the last run's start (NaN after it, where it was not needed). A run whose :math:`\alpha`
        never falls below ``max_alpha`` has no start (all NaN).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.scenarios import paper_a
    >>> from uwtutor.pipelines import prepositioned_bias_ekf
    >>> from uwtutor.models.bias import paper_a_process_noise
    >>> sc = paper_a.make(np.random.default_rng(0), n_runs=20)
    >>> # believed start 150 m off
    >>> start = sc.true_positions[:, 0] + [150.0, 0.0]
    >>> res = prepositioned_bias_ekf(
    ...     start,
    ...     np.eye(3),
    ...     sc.dr_displacements,
    ...     sc.ranges,
    ...     paper_a_process_noise(1.0),
    ...     5.0,
    ... )
    >>> k0 = np.argmax(res.extras["started"], axis=1)
    >>> bool(np.all((150 < k0) & (k0 < 400)))
    True
    >>> err = np.linalg.norm(res.x[:, -1, :2] - sc.true_positions[:, -1], axis=-1)
    >>> bool(np.sqrt(np.mean(err**2)) < 30.0)
    True
    """
    z = as_float_array("ranges", ranges, ndim=2, nonempty=True)
    if np.isinf(z).any() or (z < 0).any():
        raise ValueError("ranges must be finite and >= 0, or NaN where missing")
    M, K = z.shape
    u = as_finite("dr_displacements", dr_displacements, shape=(M, K, 2))
    p0 = as_finite("provisional_start", provisional_start, ndim=(1, 2))
    if p0.shape not in ((2,), (M, 2)):
        raise ValueError(f"provisional_start must have shape (2,) or ({M}, 2); got {p0.shape}")
    b = as_finite("beacon", beacon, shape=(2,))
    a_max = float(as_positive("max_alpha", max_alpha, ndim=0))
    steps = as_int("iterations", iterations, minimum=1)
    bias_model_pair(Q, R, b)                                      # validates Q and R before any work
    R = range_variances(R)                                         # a float from 4.0, [[4.0]] or its array
    if P0 is not None:
        P0 = as_covariance("P0", P0, 3)
        if P0.shape not in ((3, 3), (M, 3, 3)):
            raise ValueError(f"P0 must have shape (3, 3) or ({M}, 3, 3); got {P0.shape}")
    provisional = p0 + np.cumsum(u, axis=1) if p0.ndim == 1 else p0[:, None, :] + np.cumsum(u, axis=1)
    finite = np.isfinite(z)
    # alpha on a growing prefix of the track: the start is usually found long before the end
    window = min(K, 512)
    while True:
        alpha = _alpha_on_finite(provisional[:, :window], finite[:, :window], b)
        if window == K or (alpha < a_max).any(axis=1).all():
            break
        window = min(K, 2 * window)
    alpha = np.concatenate([alpha, np.full((M, K - window), np.nan)], axis=1)
    ok = alpha < a_max
    has_start = ok.any(axis=1)
    start = np.where(has_start, np.argmax(ok, axis=1), K)
    # the fixes, grouped by start epoch (and pattern of missing ranges)
    fix_state = np.full((M, 3), np.nan)
    fix_cov = np.full((M, 3, 3), np.nan)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", lsq.IllConditionedWarning)   # judged by alpha, as paper A does
        for k0 in np.unique(start[has_start]):
            checkpoint()                                # a widget's refinement no longer wanted stops here
            group = np.flatnonzero(start == k0)
            patterns, which = _row_patterns(finite[group, :k0 + 1])
            for p, pattern in enumerate(patterns):
                runs = group[which.ravel() == p]
                cols = np.flatnonzero(pattern)
                fix = lsq.prepositioning(z[runs][:, cols], provisional[runs][:, cols], provisional[runs, k0], b,
                                         iterations=steps, sigma=np.sqrt(R))
                fix_state[runs] = fix.estimate
                fix_cov[runs] = fix.covariance
    singular = has_start & ~np.isfinite(fix_state).all(axis=1)
    if singular.any():
        run = int(np.flatnonzero(singular)[0])
        raise ValueError(f"max_alpha = {a_max:g} accepted a fix that is singular (run {run}, epoch {int(start[run])}, "
                         f"alpha = {alpha[run, start[run]]:.3g}): no start can be computed from it. Use a smaller "
                         "max_alpha (paper A: 2)")
    P_start = fix_cov if P0 is None else np.broadcast_to(P0, (M, 3, 3))
    epochs = np.arange(K)[None, :]
    out = {name: np.full(shape, np.nan) for name, shape in
           (("x", (M, K, 3)), ("P", (M, K, 3, 3)), ("x_prior", (M, K, 3)), ("P_prior", (M, K, 3, 3)),
            ("innovations", (M, K, 1)), ("innovation_cov", (M, K, 1, 1)))}
    accepted = np.zeros((M, K), dtype=bool)
    if has_start.any():
        # every started run's filter begins after its own start epoch, all in one call
        staggered = filter_from_start_epochs(bias_ekf, start, fix_state, P_start, u, z, Q=Q, R=R, beacon=b,
                                             trim_padding=True)
        filt = staggered.filter_result
        for name in out:
            out[name] = staggered.at_epochs(getattr(filt, name), np.nan)
        accepted = staggered.at_epochs(filt.extras["accepted"], False)
        at = epochs == start[:, None]                            # the start epoch itself shows the fix
        out["x"] = np.where(at[..., None], fix_state[:, None, :], out["x"])
        out["P"] = np.where(at[..., None, None], P_start[:, None], out["P"])
    t = np.arange(K, dtype=float) if times is None else as_finite("times", times, shape=(K,))
    return FilterResult(times=t, extras={"accepted": accepted, "started": epochs >= start[:, None],
                                         "alpha": alpha}, **out)
