r"""Paper A's improved EKF (IEKF): the range-only EKF with the slowly varying range bias in its state.

**Model** (Liu et al., paper A, eqs. 1-2). The range error :math:`\xi_k = \eta_k + \upsilon_k` is white noise
:math:`\eta_k \sim N(0, R)` plus a slowly varying bias :math:`\upsilon_k`; the bias joins the state as a random
walk,

.. math::

    \mathbf X_k = [x_k, y_k, \upsilon_k]^\mathsf T = \mathbf X_{k-1} + [\Delta x_k, \Delta y_k, 0]^\mathsf T
    + \boldsymbol\omega_k, \quad \boldsymbol\omega_k \sim N(\mathbf 0, \mathbf Q), \qquad
    r_k = \lVert \mathbf p_k - \mathbf b_k \rVert + \upsilon_k + \eta_k,

    \mathbf H_k = \Big[\frac{(\hat{\mathbf p}^-_k - \mathbf b_k)^\mathsf T}{\lVert \hat{\mathbf p}^-_k -
    \mathbf b_k \rVert},\ 1\Big],

with :math:`\mathbf Q = \operatorname{diag}(\sigma_x^2, \sigma_y^2, q_\upsilon)` and paper A's rule
:math:`q_\upsilon = (\sigma_x^2 + \sigma_y^2)/2` (``uwtutor.models.bias.paper_a_process_noise``). The
beacon :math:`\mathbf b_k` is fixed or moves (one position per epoch). The filter is the generic engine
(``uwtutor.filters.ExtendedKalmanFilter``) on the model pair ``DeadReckoning(Q)`` +
``RangeToBeacon(beacon, R, n=3, bias_index=2)``: this module only names it.

**Start.** The bias makes the filter sensitive to its initial value: paper A first computes a least-squares
fix of position and bias on the dead-reckoned track (``uwtutor.lsq.prepositioning``) and starts the filter
only once that fix's precision factor :math:`\alpha = \operatorname{tr}(\mathbf A^\mathsf T\mathbf A)^{-1}` is
below 2 (:func:`prepositioned_bias_ekf`).

Forms: :func:`bias_ekf` runs one run or ``M`` runs over whole sequences in one call; :class:`BiasEKF` is the same
filter one step at a time (the filter protocol); :func:`prepositioned_bias_ekf` is paper A's "pre-positioning,
then IEKF" for a batch of runs.

References
----------
Liu J., Han S., Xu J., Yang G. "An improved EKF positioning algorithm for underwater acoustic beacon" (paper A),
sec. 1.1 (eqs. 1-2) and sec. 1.2 (eqs. 3-11).
Grewal M. S., Andrews A. P. (2015). *Kalman Filtering: Theory and Practice with MATLAB*, 4th ed., Wiley-IEEE
Press (state augmentation for correlated noise; paper A's ref. [13]).
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from .. import lsq
from .._validate import as_covariance, as_finite, as_float_array, as_int, as_positive
from ._packed import range_variances
from ..models import DeadReckoning, RangeToBeacon
from .base import FilterResult
from .staggered import filter_from_start_epochs
from .engine import ExtendedKalmanFilter, extended_kalman_filter

__all__ = ["bias_ekf", "BiasEKF", "prepositioned_bias_ekf"]


def _bias_models(Q: Any, R: Any, beacon: Any, n_steps: int | None = None) -> tuple[DeadReckoning, RangeToBeacon]:
    """Paper A's model pair: DR with a random-walk bias, range plus bias (state [x, y, bias]); with ``n_steps``,
    ``Q`` (K, 3, 3) and ``R`` (K,) may give one value per step."""
    Q = as_covariance("Q", Q, 3, allow_singular=True)
    if Q.shape != (3, 3) and not (n_steps is not None and Q.shape == (n_steps, 3, 3)):
        per = f", or one per step ({n_steps}, 3, 3)" if n_steps is not None else ""
        raise ValueError(f"Q must be one 3x3 matrix diag(sigma_x^2, sigma_y^2, sigma_bias^2) for the state "
                         f"[x, y, bias]{per}; got shape {Q.shape}")
    R = range_variances(R, n_steps)
    return DeadReckoning(Q), RangeToBeacon(beacon, R, n=3, bias_index=2)


def bias_ekf(x0: Any, P0: Any, u: Any, z: Any, Q: Any, R: Any, beacon: Any = (0.0, 0.0),
             times: Any = None, *, gate: Any = None) -> FilterResult:
    r"""Run paper A's IEKF (state ``[x, y, bias]``) over whole sequences, one run or ``M`` at once.

    Each step ``k`` predicts with the DR displacement ``u[..., k, :]`` (the bias is kept, its variance grows by
    ``Q[2, 2]``) and updates with the range ``z[..., k]`` (equations in the module docstring). A NaN range
    means no reply: predict only. ``Q`` and ``R`` may change from step to step; a ``gate`` tests each range
    before it is used.

    Parameters
    ----------
    x0 : array_like, shape (3,) or (M, 3)
        Initial ``[x, y, bias]`` [m].
    P0 : array_like, shape (3, 3) or (M, 3, 3)
        Its covariance, positive definite [m²] (paper A: the identity).
    u : array_like, shape (K, 2) or (M, K, 2)
        DR displacement from epoch ``k - 1`` to epoch ``k`` [m].
    z : array_like, shape (K,) or (M, K)
        Measured ranges [m], NaN where missing.
    Q : array_like, shape (3, 3) or (K, 3, 3)
        Process noise per epoch (e.g. ``uwtutor.models.bias.paper_a_process_noise``) [m²]; or one per epoch.
    R : float or array_like, shape (K,)
        Variance of the white part :math:`\eta_k` of the range error [m²], > 0; or one per epoch (NaN allowed
        where there is no range).
    beacon : array_like, shape (2,), (K, 2) or (M, K, 2), optional
        Beacon position: fixed (the origin by default), one per epoch, or one per run and epoch (a moving
        beacon, e.g. the other boat of paper A's lake trial).
    times : array_like, shape (K,), optional
        Epoch times for the result (default ``0..K-1``).
    gate : uwtutor.filters.Gate, optional
        An outlier test on each innovation (e.g. ``ReacquiringGate()``); None uses every range.

    Returns
    -------
    FilterResult
        ``x`` (…, K, 3) with the bias estimate in ``x[..., 2]``, ``P`` (…, K, 3, 3), the priors, innovations
        (…, K, 1) and their covariances, ``extras["accepted"]`` (…, K) (and the gate's per-step outputs).

    Raises
    ------
    ValueError
        On wrong shapes, non-finite inputs, a ``Q`` that is not 3x3 positive semi-definite, ``R <= 0`` or a
        ``P0`` that is not positive definite (the message names the argument).

    Warns
    -----
    uwtutor.errors.BeaconSingularityWarning
        When a prediction falls exactly on the beacon (that run's update is skipped).

    See Also
    --------
    BiasEKF : the same filter step by step.
    prepositioned_bias_ekf : paper A's least-squares start, then this filter.
    uwtutor.filters.ekf.range_only_ekf : the plain EKF (no bias state).

    Examples
    --------
    A platform circling a buoy, ranges 30 m too long; the bias is found and the position stays close:

    >>> import numpy as np
    >>> from uwtutor.filters import bias_ekf
    >>> from uwtutor.models.bias import paper_a_process_noise
    >>> angle = np.linspace(0.0, 2 * np.pi, 401)
    >>> track = 1500.0 * np.column_stack([np.cos(angle), np.sin(angle)])
    >>> u = np.diff(track, axis=0, prepend=track[:1])
    >>> z = 1500.0 + 30.0 + np.random.default_rng(0).normal(0.0, 2.0, 401)
    >>> res = bias_ekf(
    ...     [track[0, 0] + 20.0, 0.0, 0.0],
    ...     np.diag([400.0, 400.0, 900.0]),
    ...     u,
    ...     z,
    ...     Q=paper_a_process_noise(0.1),
    ...     R=4.0,
    ... )
    >>> bool(abs(res.x[-1, 2] - 30.0) < 2.0), bool(
    ...     np.linalg.norm(res.x[-1, :2] - track[-1]) < 3.0
    ... )
    (True, True)
    """
    zz = as_float_array("z", z)
    motion, measurement = _bias_models(Q, R, beacon, zz.shape[-1] if zz.ndim else None)
    return extended_kalman_filter(motion, measurement, x0, P0, u, z, times=times, gate=gate)


class BiasEKF(ExtendedKalmanFilter):
    r"""Paper A's IEKF one step at a time: the generic engine on the bias model pair (see :func:`bias_ekf`).

    Parameters
    ----------
    x0 : array_like, shape (3,) or (M, 3)
        Initial ``[x, y, bias]`` [m].
    P0 : array_like, shape (3, 3) or (M, 3, 3)
        Its covariance [m²].
    Q : array_like, shape (3, 3)
        Process noise per epoch [m²].
    R : float
        White range noise variance [m²].
    beacon : array_like, shape (2,), (K, 2) or (M, K, 2), optional
        Beacon position, fixed or one per epoch (then step ``k`` uses ``beacon[..., k, :]``).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.filters import BiasEKF
    >>> filt = BiasEKF(
    ...     [1000.0, 0.0, 0.0],
    ...     np.eye(3) * 100.0,
    ...     Q=np.diag([0.25, 0.25, 0.25]),
    ...     R=5.0,
    ... )
    >>> filt.predict([0.0, 10.0])
    >>> filt.update(1012.0)
    >>> filt.x.shape, filt.P.shape, round(float(filt.bias), 3)
    ((3,), (3, 3), 5.83)
    """

    def __init__(self, x0: Any, P0: Any, Q: Any, R: Any, beacon: Any = (0.0, 0.0)) -> None:
        motion, measurement = _bias_models(Q, R, beacon)
        super().__init__(motion, measurement, x0, P0)

    @property
    def bias(self) -> np.ndarray:
        """The current bias estimate [m], ``()`` or ``(M,)``."""
        return self.x[..., 2]


def _alpha_on_finite(provisional: np.ndarray, finite: np.ndarray, beacon: np.ndarray) -> np.ndarray:
    """Precision factor after each epoch (M, K), counting only the epochs with a range (held between them)."""
    M, K = finite.shape
    alpha = np.full((M, K), np.inf)
    patterns, which = np.unique(finite, axis=0, return_inverse=True)
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


def prepositioned_bias_ekf(ranges: Any, dr_displacements: Any, provisional_start: Any, Q: Any, R: Any, *,
                           P0: Any = None, max_alpha: Any = 2.0, beacon: Any = (0.0, 0.0), iterations: int = 3,
                           times: Any = None) -> FilterResult:
    r"""Paper A's pre-positioning, then its IEKF: every run starts at its first epoch with :math:`\alpha <` ``max_alpha``.

    1. **Provisional track.** ``provisional_start`` carried by the DR displacements:
       :math:`\tilde{\mathbf p}_k = \tilde{\mathbf p}_0 + \sum_{j \le k}\mathbf u_j`.
    2. **Precision factor** after each epoch along it (``uwtutor.lsq.precision_factor_history``, three unknowns,
       only the epochs with a range): the first epoch :math:`k_0` with :math:`\alpha_{k_0} <` ``max_alpha``
       (paper A: 2) is the run's start.
    3. **Fix** at :math:`k_0`: ``uwtutor.lsq.prepositioning`` (position *and* bias, ``iterations`` Gauss-Newton
       steps from :math:`\tilde{\mathbf p}_{k_0}`) on the ranges of epochs :math:`0..k_0`.
    4. **Filter** from :math:`k_0`: :func:`bias_ekf` from the fix with covariance ``P0``, over epochs
       :math:`k_0 + 1, \dots` (all runs in one call: each run's arrays are shifted to start at step 0).

    Parameters
    ----------
    ranges : array_like, shape (M, K)
        Measured ranges [m], NaN where missing.
    dr_displacements : array_like, shape (M, K, 2)
        DR displacements (row 0: from the provisional start to epoch 0, usually zeros).
    provisional_start : array_like, shape (2,) or (M, 2)
        Provisional position at epoch 0 [m] (e.g. the position the vehicle believed it started from).
    Q : array_like, shape (3, 3)
        Process noise of the IEKF [m²].
    R : float
        White range noise variance [m²] (also the :math:`\sigma^2` of the fix's covariance).
    P0 : array_like, shape (3, 3) or (M, 3, 3), optional
        Covariance the filter starts with; default the fix's own :math:`R\,(\mathbf A^\mathsf T\mathbf A)^{-1}`
        (paper A starts from the identity).
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
        provisional track up to the last run's start (NaN after it, where it was not needed). A run whose :math:`\alpha` never falls below ``max_alpha`` has no start (all NaN).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.scenarios import paper_a
    >>> from uwtutor.filters import prepositioned_bias_ekf
    >>> from uwtutor.models.bias import paper_a_process_noise
    >>> sc = paper_a.make(np.random.default_rng(0), n_runs=20)
    >>> # believed start 150 m off
    >>> start = sc.true_positions[:, 0] + [150.0, 0.0]
    >>> res = prepositioned_bias_ekf(
    ...     sc.ranges,
    ...     sc.dr_displacements,
    ...     start,
    ...     paper_a_process_noise(1.0),
    ...     5.0,
    ...     P0=np.eye(3),
    ... )
    >>> k0 = np.argmax(res.extras["started"], axis=1)
    >>> bool(np.all((150 < k0) & (k0 < 400)))
    True
    >>> err = np.linalg.norm(res.x[:, -1, :2] - sc.true_positions[:, -1], axis=-1)
    >>> bool(np.sqrt(np.mean(err**2)) < 30.0)
    True
    """
    z = as_float_array("ranges", ranges, ndim=2)
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
    _bias_models(Q, R, b)                                      # validates Q and R before any work
    R = float(R)
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
            group = np.flatnonzero(start == k0)
            patterns, which = np.unique(finite[group, :k0 + 1], axis=0, return_inverse=True)
            for p, pattern in enumerate(patterns):
                runs = group[which.ravel() == p]
                cols = np.flatnonzero(pattern)
                fix = lsq.prepositioning(z[runs][:, cols], provisional[runs][:, cols], provisional[runs, k0], b,
                                         iterations=steps, sigma=np.sqrt(R))
                fix_state[runs] = fix.estimate
                fix_cov[runs] = fix.covariance
    P_start = fix_cov if P0 is None else np.broadcast_to(P0, (M, 3, 3))
    epochs = np.arange(K)[None, :]
    out = {name: np.full(shape, np.nan) for name, shape in
           (("x", (M, K, 3)), ("P", (M, K, 3, 3)), ("x_prior", (M, K, 3)), ("P_prior", (M, K, 3, 3)),
            ("innovations", (M, K, 1)), ("innovation_cov", (M, K, 1, 1)))}
    accepted = np.zeros((M, K), dtype=bool)
    if has_start.any():
        # every started run's filter begins after its own start epoch, all in one call
        staggered = filter_from_start_epochs(bias_ekf, start, fix_state, P_start, u, z, Q=Q, R=R, beacon=b)
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
