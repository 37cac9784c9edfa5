r"""Random streams for batches of Monte Carlo runs, and the Gaussian noise of the models.

A model that draws noise for ``M`` runs at once draws run ``m``'s share from the ``m``-th generator, so that a
batched run ``m`` is, draw for draw, the single run given that generator. :func:`per_run_generators` turns the
``rng`` a user gives into that sequence; :func:`standard_normal_per_run` draws from it.

The two Gaussian computations every model shares by default (:mod:`uwtutor.models.base`) live here too:

* drawing :math:`w \sim N(0, Q)` as :math:`w = L\varepsilon`, :math:`\varepsilon \sim N(0, I)`, with any
  :math:`L L^\mathsf{T} = Q` (:func:`psd_sqrt`: a Cholesky factor, or :math:`V \Lambda^{1/2}` from the
  eigendecomposition when :math:`Q` is singular -- a state that does not move, a noise that enters through fewer
  inputs than states);
* the log-likelihood of a measurement under :math:`N(h(x), R)` with its missing components marginalised out
  (:func:`gaussian_log_likelihood`): the marginal of a Gaussian over some components is the Gaussian of those
  components, :math:`N(h_{\mathcal P}(x), R_{\mathcal{PP}})`.
"""

from __future__ import annotations

from typing import Callable, Sequence, TypeAlias

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validate import as_flag, as_int, check_work

__all__ = ["per_run_generators", "standard_normal_per_run", "psd_sqrt", "gaussian_noise", "gaussian_log_likelihood"]


#: One Generator, or one per run: what the particle filters and :func:`per_run_generators` take as ``rng``.
RunGenerators: TypeAlias = "np.random.Generator | Sequence[np.random.Generator]"


def per_run_generators(rng: RunGenerators, n_runs: int, *, spawn: bool = True) -> tuple[np.random.Generator, ...]:
    """One Generator per run from ``rng``: a Generator or a sequence of ``n_runs`` Generators.

    Parameters
    ----------
    rng : numpy.random.Generator or sequence of numpy.random.Generator
        A single Generator serves one run as it is; for ``n_runs > 1`` it is split into ``n_runs`` independent
        child streams with :meth:`numpy.random.Generator.spawn` (when ``spawn`` is True). A sequence must hold
        exactly ``n_runs`` Generators, used in order.
    n_runs : int
        Number of runs ``M``.
    spawn : bool, optional
        Whether a single Generator may be split for ``n_runs > 1`` (otherwise that is an error).

    Returns
    -------
    tuple of numpy.random.Generator

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.models.noise import per_run_generators
    >>> rngs = per_run_generators(np.random.default_rng(0), 3)
    >>> len(rngs), float(rngs[1].random()) == float(
    ...     np.random.default_rng(0).spawn(3)[1].random()
    ... )
    (3, True)
    """
    n_runs = as_int("n_runs", n_runs, minimum=1)
    spawn = as_flag("spawn", spawn)
    if isinstance(rng, np.random.Generator):
        if n_runs == 1:
            return (rng,)
        if not spawn:
            raise ValueError(f"rng must be a sequence of {n_runs} Generators (one per run); got one Generator")
        # a spawned Generator holds about 1 kB (125 floats) of state: a million runs is a gigabyte
        check_work("n_runs", 125 * n_runs, "values of random-stream state (about 1 kB a run)")
        return tuple(rng.spawn(n_runs))
    if isinstance(rng, (str, bytes)) or not hasattr(rng, "__len__"):
        raise TypeError(f"rng must be a numpy.random.Generator (e.g. numpy.random.default_rng(seed)) or a sequence "
                        f"of {n_runs} of them (one per run); got {rng!r}")
    rngs = tuple(rng)
    if len(rngs) != n_runs or not all(isinstance(r, np.random.Generator) for r in rngs):
        raise ValueError(f"rng must be a sequence of {n_runs} numpy.random.Generator objects (one per run); got "
                         f"{len(rngs)} item(s) of type(s) {sorted({type(r).__name__ for r in rngs})}")
    return rngs


def standard_normal_per_run(rngs: Sequence[np.random.Generator], shape: tuple[int, ...]) -> NDArray[np.float64]:
    """Standard normal draws of shape ``(M,) + shape``; block ``m`` is exactly ``rngs[m].standard_normal(shape)``.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.models.noise import standard_normal_per_run
    >>> a = standard_normal_per_run(
    ...     [np.random.default_rng(1), np.random.default_rng(2)], (2, 3)
    ... )
    >>> a.shape, bool(
    ...     (a[1] == np.random.default_rng(2).standard_normal((2, 3))).all()
    ... )
    ((2, 2, 3), True)
    """
    try:
        if len(rngs) == 1:
            return rngs[0].standard_normal(shape)[None]
        out = np.empty((len(rngs),) + tuple(shape))
        for m, r in enumerate(rngs):
            r.standard_normal(out=out[m])
    except (TypeError, AttributeError) as exc:       # checked only when it fails: a per-step kernel
        if not isinstance(rngs, (list, tuple)) or not all(isinstance(r, np.random.Generator) for r in rngs):
            raise TypeError("rngs must be a list or tuple of numpy.random.Generator, one per run (see "
                            f"per_run_generators); got {type(rngs).__name__}") from None
        raise TypeError(f"shape must be a tuple of ints; got {shape!r} ({exc})") from None
    return out


def psd_sqrt(Q: ArrayLike) -> np.ndarray:
    r"""A square root :math:`L` of positive semi-definite matrices, :math:`L L^\mathsf{T} = Q`, ``(..., n, n)``.

    The Cholesky factor when every matrix of the stack is positive definite; otherwise
    :math:`L = V \operatorname{diag}(\sqrt{\max(\lambda, 0)})` from the eigendecomposition
    :math:`Q = V \operatorname{diag}(\lambda) V^\mathsf{T}`, which tolerates zero eigenvalues (a component
    without noise) and clips the round-off negatives of a semi-definite matrix.

    Parameters
    ----------
    Q : array_like, shape (..., n, n)
        Symmetric positive semi-definite matrices (not checked here: the models check theirs once).

    Returns
    -------
    ndarray, shape (..., n, n)

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.models.noise import psd_sqrt
    >>> # the second state does not move
    >>> Q = np.diag([4.0, 0.0])
    >>> L = psd_sqrt(Q)
    >>> np.allclose(L @ L.T, Q)
    True
    """
    Qa = np.asarray(Q, dtype=float)
    root: np.ndarray
    try:
        root = np.linalg.cholesky(Qa)
    except np.linalg.LinAlgError:
        vals, vecs = np.linalg.eigh(Qa)
        root = vecs * np.sqrt(np.clip(vals, 0.0, None))[..., None, :]
    return root


def gaussian_noise(L: np.ndarray, rngs: Sequence[np.random.Generator], shape: tuple[int, ...]) -> np.ndarray:
    r"""Draws :math:`w = L \varepsilon`, :math:`\varepsilon \sim N(0, I_n)`, for ``M`` runs of ``shape[1:-1]`` each.

    Run ``m`` draws its :math:`\varepsilon` of shape ``shape[1:]`` from ``rngs[m]``
    (:func:`standard_normal_per_run`), so that a batched run is draw for draw the single run on the same Generator.

    Parameters
    ----------
    L : ndarray
        Square roots of the covariances (:func:`psd_sqrt`): ``(n, n)`` shared by every run, ``(M, n, n)`` one per
        run, or ``shape[:-1] + (n, n)`` one per draw (e.g. per particle).
    rngs : sequence of numpy.random.Generator
        One per run, ``M = shape[0]``.
    shape : tuple of int
        ``(M, ..., n)``.

    Returns
    -------
    ndarray, shape ``shape``

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.models.noise import gaussian_noise
    >>> w = gaussian_noise(
    ...     np.diag([2.0, 0.0]), [np.random.default_rng(0)], (1, 50000, 2)
    ... )
    >>> np.round(w[0].std(axis=0), 1)
    array([2., 0.])
    """
    eps = standard_normal_per_run(rngs, tuple(shape[1:]))
    noise: np.ndarray
    if L.ndim == 2:
        if eps.shape[0] == 1:                                  # one run: a plain 2-D product
            noise = (eps[0] @ L.T)[None] if eps.ndim == 3 else eps @ L.T
        else:
            noise = eps @ L.T
    elif L.ndim == 3 and L.shape[0] == len(rngs) and eps.ndim == 3:    # one per run, (M, N, n)
        noise = eps @ np.swapaxes(L, -1, -2)
    else:
        noise = np.einsum("...ij,...j->...i", L, eps)
    return noise


def _present_patterns(present: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """The runs (indices) sharing each pattern of present components, and the pattern; runs without any skipped."""
    if present.shape[0] == 1:
        return [(np.zeros(1, dtype=np.intp), present[0])] if present[0].any() else []
    patterns, inverse = np.unique(present, axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    return [(np.flatnonzero(inverse == i), p) for i, p in enumerate(patterns) if p.any()]


def gaussian_log_likelihood(hx: np.ndarray, z: np.ndarray, R: np.ndarray,
                            residual: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None) -> np.ndarray:
    r"""The log-likelihood of ``z`` under :math:`N(h(x), R)` for many states, missing components marginalised out.

    .. math::

        \log p(z \mid x) = -\tfrac12\, y^\mathsf{T} R_{\mathcal{PP}}^{-1}\, y
        - \tfrac12 \log\det R_{\mathcal{PP}} + c, \qquad y = z_{\mathcal P} - h_{\mathcal P}(x),

    over the components :math:`\mathcal P` present in ``z`` (its entries that are not NaN). The term
    :math:`\log\det R` is kept only where ``R`` differs from state to state (one per ``hx`` row); where it is one
    per run it is, like :math:`c`, the same for every state of the run and is dropped (it cancels in normalised
    weights). A run with no component present gets 0: its weights do not change.

    Parameters
    ----------
    hx : ndarray, shape (M, N, m)
        The predicted measurements of ``N`` states of each of ``M`` runs.
    z : ndarray, shape (M, m)
        The measurement of each run, NaN where a component is missing.
    R : ndarray
        ``(m, m)`` shared, ``(M, m, m)`` per run, or ``(M, N, m, m)`` per state; positive definite over the
        components present.
    residual : callable, optional
        ``residual(z, hx) -> y`` (a model's :meth:`~uwtutor.models.base.MeasurementModel.residual`, for angles);
        ``z - hx`` by default.

    Returns
    -------
    ndarray, shape (M, N)

    Examples
    --------
    The marginal over the components present is the likelihood of the model of those components alone:

    >>> import numpy as np
    >>> from uwtutor.models.noise import gaussian_log_likelihood
    >>> # one run, two states, m = 3
    >>> hx = np.array([[[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]]])
    >>> R = np.diag([1.0, 4.0, 9.0])
    >>> # -(1 + 9/9)/2 and -(0 + 4/9)/2
    >>> gaussian_log_likelihood(hx, np.array([[1.0, np.nan, 3.0]]), R)
    array([[-1.        , -0.22222222]])
    """
    M, N, m = hx.shape
    y = (z[:, None, :] - hx) if residual is None else np.asarray(residual(z[:, None, :], hx), dtype=float)
    present = ~np.isnan(z)
    per_state = R.ndim == 4
    out = np.zeros((M, N))
    groups: Sequence[tuple[np.ndarray | None, np.ndarray]]     # (runs, components present); None: every run
    if present.all():
        groups = [(None, np.ones(m, dtype=bool))]
    else:
        groups = _present_patterns(present)
    for runs, pattern in groups:
        yy = y if runs is None else y[runs][:, :, pattern]
        if R.ndim == 2:
            RR = R if runs is None else R[np.ix_(pattern, pattern)]
        elif runs is None:
            RR = R
        else:
            sel = R[runs]
            RR = sel[..., pattern[:, None] & pattern[None, :]].reshape(sel.shape[:-2] + (pattern.sum(),) * 2)
        L = np.linalg.cholesky(RR)
        if RR.ndim == 2:
            w = np.linalg.solve(L, yy.reshape(-1, yy.shape[-1]).T).T.reshape(yy.shape)
        elif not per_state:                                     # (R, m, m) per run
            w = np.swapaxes(np.linalg.solve(L, np.swapaxes(yy, -1, -2)), -1, -2)
        else:                                                   # (R, N, m, m) per state
            w = np.linalg.solve(L, yy[..., None])[..., 0]
        ll = -0.5 * np.einsum("...i,...i->...", w, w)
        if per_state:
            ll -= np.log(np.diagonal(L, axis1=-2, axis2=-1)).sum(axis=-1)
        if runs is None:
            out = ll
        else:
            out[runs] = ll
    return out
