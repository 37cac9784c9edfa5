"""Random streams for batches of Monte Carlo runs: one ``numpy.random.Generator`` per run.

A model that draws noise for ``M`` runs at once draws run ``m``'s share from the ``m``-th generator, so that a
batched run ``m`` is, draw for draw, the single run given that generator. :func:`per_run_generators` turns the
``rng`` a user gives into that sequence; :func:`standard_normal_per_run` draws from it.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

__all__ = ["per_run_generators", "standard_normal_per_run"]


def per_run_generators(rng: Any, n_runs: int, *, spawn: bool = True) -> tuple[np.random.Generator, ...]:
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
    if isinstance(rng, np.random.Generator):
        if n_runs == 1:
            return (rng,)
        if not spawn:
            raise ValueError(f"rng must be a sequence of {n_runs} Generators (one per run); got one Generator")
        return tuple(rng.spawn(n_runs))
    if isinstance(rng, (str, bytes)) or not hasattr(rng, "__len__"):
        raise TypeError(f"rng must be a numpy.random.Generator (e.g. numpy.random.default_rng(seed)) or a sequence "
                        f"of {n_runs} of them (one per run); got {rng!r}")
    rngs = tuple(rng)
    if len(rngs) != n_runs or not all(isinstance(r, np.random.Generator) for r in rngs):
        raise ValueError(f"rng must be a sequence of {n_runs} numpy.random.Generator objects (one per run); got "
                         f"{len(rngs)} item(s) of type(s) {sorted({type(r).__name__ for r in rngs})}")
    return rngs


def standard_normal_per_run(rngs: Sequence[np.random.Generator], shape: tuple[int, ...]) -> np.ndarray:
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
    if len(rngs) == 1:
        return rngs[0].standard_normal(shape)[None]
    out = np.empty((len(rngs),) + tuple(shape))
    for m, r in enumerate(rngs):
        r.standard_normal(out=out[m])
    return out
