r"""Dead reckoning as a motion model: the vehicle moves by the displacement its own sensors measured.

Between two ranging epochs the vehicle's horizontal position moves by the dead-reckoned (DR) displacement
:math:`u_k = [\Delta x_k, \Delta y_k]`, itself in error by the DR noise :math:`w_k`:

.. math::

    p_k = p_{k-1} + u_k + w_k, \qquad w_k \sim N(0, Q).

The state may carry more than the position: any further components (a range bias, paper A; the ranges' scale)
are kept by the prediction and get their own rows of :math:`Q` (a random walk when their variance is positive, a
constant when it is zero). They do not move the position: a current that carries the vehicle is
:class:`~uwtutor.models.blocks.Position` with ``current=`` (paper B's
:class:`~uwtutor.models.cooperative.CooperativeMotion`). The position is always ``x[..., :2]``.

The state is made of the blocks of :mod:`uwtutor.models.blocks`: a :class:`~uwtutor.models.blocks.Position`
(slot ``position``) and, for the further components, one :class:`~uwtutor.models.blocks.RandomWalk` per name the
caller gives them (``names=("range_bias",)``), so that a measurement model finds them by name
(``RangeToBeacon(beacon, R, state=motion, bias="range_bias")``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .._validate import as_covariance, as_int
from .base import MotionModel
from .blocks import BlockMotion, Position, RandomWalk, StateBlock, _displacement, _name

__all__ = ["DeadReckoning"]


def _further_slots(names: Any, count: int) -> dict[str, int]:
    """The slot names of the ``count`` components after the position, each with its number of components: from
    ``names`` (a sequence of names, one component each, or a dict name -> number of components), or
    ``state_2``, ``state_3``, ... (one per component, by its index) when ``names`` is None."""
    if names is None:
        return {f"state_{i}": 1 for i in range(2, 2 + count)}
    if isinstance(names, str):
        raise TypeError(f"names must be a sequence of slot names (e.g. ('range_bias',)) or a dict of name -> number "
                        f"of components; got the string {names!r}")
    if isinstance(names, dict):
        sizes = {_name(key, "names"): as_int(f"names[{key!r}]", size, minimum=1) for key, size in names.items()}
    else:
        try:
            listed = list(names)
        except TypeError:
            raise TypeError(f"names must be a sequence of slot names (e.g. ('range_bias',)) or a dict of name -> "
                            f"number of components; got {type(names).__name__}") from None
        sizes = {}
        for name in listed:
            if _name(name, "names") in sizes:
                raise ValueError(f"names gives {name!r} twice: give each further component its own name")
            sizes[name] = 1
    if "position" in sizes:
        raise ValueError("names must name the components after the position; 'position' is the slot of x and y")
    if sum(sizes.values()) != count:
        raise ValueError(f"names must name the {count} components of the state after the position (Q is "
                         f"{count + 2}x{count + 2}); they name {sum(sizes.values())}: {list(sizes)}")
    return sizes


class DeadReckoning(BlockMotion):
    r"""Position moved by the DR displacement; further state components constant up to their process noise.

    .. math::

        f(x, u) = x + [u_x, u_y, 0, \dots, 0]^T, \qquad F = I_n.

    A :class:`~uwtutor.models.blocks.BlockMotion` of a :class:`~uwtutor.models.blocks.Position` (slot
    ``position``) and one :class:`~uwtutor.models.blocks.RandomWalk` per further slot, each with its diagonal block
    of ``Q`` as the covariance of its step. ``Q`` itself is given whole: it may correlate the position with the
    further components, so :meth:`Q` returns it as given and ``sample`` draws :math:`f + L\varepsilon`,
    :math:`L L^\mathsf{T} = Q`.

    Parameters
    ----------
    Q : array_like, shape (n, n) or (K, n, n)
        Process noise covariance per step, positive semi-definite; its size sets the state size ``n >= 2``. One
        per step, ``(K, n, n)``, for a DR whose error changes along the run (step ``k`` uses ``Q[k]``).
    names : sequence of str, or dict of str to int, optional
        The slot names of the ``n - 2`` components after the position, in the order of the state: one name per
        component (``("range_bias",)``), or a dict of name -> number of components (``{"biases": 2}``, a slot of
        two). Default: ``state_2``, ``state_3``, ... (one per component, by its index).

    Attributes
    ----------
    n : int
        Size of the state.
    n_steps : int or None
        Number of steps a per-step ``Q`` covers (None for one ``Q`` for every step).
    names : tuple of str
        The label of each component (``x``, ``y``, then the further ones).

    Examples
    --------
    A position plus a range bias (paper A's state), the bias named so that the range model finds it:

    >>> import numpy as np
    >>> from uwtutor.models import DeadReckoning, RangeToBeacon
    >>> dr = DeadReckoning(Q=np.diag([0.25, 0.25, 0.01]), names=("range_bias",))
    >>> dr.n, dr.f(np.array([[100.0, 0.0, 3.0]]), np.array([2.0, 1.0]), 0)
    (3, array([[102.,   1.,   3.]]))
    >>> dr.slot("position"), dr.slot("range_bias"), dr.names
    (array([0, 1]), array([2]), ('x', 'y', 'range_bias'))
    >>> ranges = RangeToBeacon((0.0, 0.0), R=4.0, state=dr, bias="range_bias")
    >>> ranges.h(np.array([[30.0, 40.0, 3.0]]), 0)
    array([[53.]])

    The start of a filter, slot by slot (mean, standard deviation):

    >>> x0, P0 = dr.initial_state(
    ...     position=([30.0, 40.0], [10.0, 10.0]), range_bias=(0.0, 5.0)
    ... )
    >>> x0, np.diag(P0)
    (array([30., 40.,  0.]), array([100., 100.,  25.]))
    """

    covariances_checked = True      # Q is checked when the model is made (one, or one per step)

    # Q given whole (it may correlate the blocks): today's arithmetic on the whole state, F the identity, and the
    # plain differences and Gaussian draws of a motion model without an angle
    linearize = MotionModel.linearize
    difference = MotionModel.difference
    normalize = MotionModel.normalize

    def __init__(self, Q: ArrayLike, *, names: Sequence[str] | Mapping[str, int] | None = None) -> None:
        self._Q = as_covariance("Q", Q, allow_singular=True)
        if self._Q.ndim not in (2, 3) or self._Q.shape[-1] < 2:
            raise ValueError("Q must be one (n, n) matrix with n >= 2 (the position comes first), or one per step "
                             f"(K, n, n); got shape {self._Q.shape}")
        n = self._Q.shape[-1]
        blocks: list[StateBlock] = [Position(self._Q[..., :2, :2])]
        start = 2
        for name, size in _further_slots(names, n - 2).items():
            blocks.append(RandomWalk(name, size=size, Q=self._Q[..., start:start + size, start:start + size]))
            start += size
        super().__init__(*blocks)
        self._I = np.eye(self.n)

    def f(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        if u is None:
            return x.copy()
        out = x.copy()
        out[..., :2] += _displacement(u)
        return out

    def F(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        return self._I

    def Q(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        if self._Q.ndim == 2:
            return self._Q
        if not 0 <= k < len(self._Q):
            raise IndexError(f"Q has {len(self._Q)} per-step matrices; step {k} is beyond them. Give one per step "
                             "of the run")
        return self._Q[k]

    def sample(self, x: np.ndarray, u: Any, k: int, rng: Any) -> np.ndarray:
        r""":math:`f + L\varepsilon`, :math:`L L^\mathsf{T} = Q_k`, with the whole ``Q`` (it may correlate the
        position and the further components): :meth:`MotionModel.sample <uwtutor.models.base.MotionModel.sample>`.

        Examples
        --------
        >>> import numpy as np
        >>> from uwtutor.models import DeadReckoning
        >>> # the bias has no noise: it stays
        >>> dr = DeadReckoning(np.diag([1.0, 1.0, 0.0]), names=("range_bias",))
        >>> x = dr.sample(
        ...     np.tile([0.0, 0.0, 2.5], (1, 500, 1)),
        ...     np.array([10.0, 0.0]),
        ...     0,
        ...     [np.random.default_rng(0)],
        ... )
        >>> round(float(x[0, :, 0].mean())), bool(np.all(x[..., 2] == 2.5))
        (10, True)
        """
        return MotionModel.sample(self, x, u, k, rng)
