r"""The two kinds of model every Kalman-family filter of ``uwtutor`` is made of.

A filter never knows what it filters: it asks a **motion model** how the state moves between two epochs and a
**measurement model** what a measurement should be, and both answer for a whole batch of Monte Carlo runs at
once. A new method of the book is a pair of models plus a filter family, never a new loop.

Shapes inside the engine always carry a leading runs axis ``M`` (a single run is ``M = 1``):

========================  =====================================================================================
``x``                     states, ``(M, n)``
``u``                     the input of one step, ``(p,)`` (shared by every run) or ``(M, p)``, or ``None``
``k``                     the 0-based index of the step (used by models with per-epoch parameters,
                          e.g. a beacon that moves)
``F``, ``Q``              ``(n, n)`` (shared) or ``(M, n, n)``
``z``, ``h(x)``           ``(M, m)``
``H``, ``R``              ``(M, m, n)``; ``(m, m)`` or ``(M, m, m)``
========================  =====================================================================================

A motion model with a noise map :math:`W` (noise entering through some other space, as in paper B) returns
:math:`W Q W^T` from :meth:`MotionModel.Q`; a measurement model with a noise map :math:`V` returns
:math:`V R V^T` from :meth:`MeasurementModel.R`. A filter asks for :math:`f, F, Q` at once through
:meth:`MotionModel.linearize` and for :math:`h, H` through :meth:`MeasurementModel.linearize`; override them when
the pieces share work.

A measurement vector may have components missing at a step (NaN in ``z``, e.g. a beacon that did not answer):
the filters update with the components present, and a model may return NaN for the components that are not
measured (its Jacobian row, its prediction, its noise).

.. rubric:: The same pair in the particle filters

The particle filters (:mod:`uwtutor.filters.particle`) run on the same two models. They need no Jacobian: they
draw from the motion model (:meth:`MotionModel.sample`) and weigh by the likelihood of the measurement model
(:meth:`MeasurementModel.log_likelihood`). For them the states carry one axis more, the ``N`` particles of each
run:

========================  =====================================================================================
``x``                     particles, ``(M, N, n)`` (``f`` and ``h`` must broadcast over the extra axis)
``u``                     ``(p,)`` shared by every run, or ``(M, 1, p)``: one per run, aligned with ``x``
``h(x)``                  ``(M, N, m)``
``Q``, ``R``              shared ``(n, n)``/``(m, m)``, per run ``(M, n, n)``/``(M, m, m)``, or per particle
                          ``(M, N, n, n)``/``(M, N, m, m)`` where they depend on the state
``rng``                   a sequence of ``M`` ``numpy.random.Generator``: run ``m`` draws from ``rng[m]``
========================  =====================================================================================

The defaults are Gaussian -- :math:`x_k = f(x_{k-1}, u_k, k) + L_k\varepsilon`, :math:`L_k L_k^\mathsf{T} =
Q_k` (any square root: :math:`Q_k` may be singular), and the Gaussian likelihood of :math:`h` and :math:`R` with
the missing components marginalised out -- so that every model of the library runs in every filter. A model
overrides :meth:`MotionModel.sample` where it can draw more exactly or faster than through :math:`Q` (the
odometry's noise in its inputs, paper C's noise inside its kinematics) or where its noise is not Gaussian, and
:meth:`MeasurementModel.log_likelihood` for a measurement noise that is not Gaussian (a mixture for outliers).

A :class:`ModelPair` holds a motion and a measurement model in one object (paper C's
:class:`~uwtutor.models.depth.DepthSpeedPitchModel`); every filter that takes ``motion, measurement`` also takes
one pair in their place.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._validate import CovarianceCheck, as_model_output
from .noise import gaussian_log_likelihood, gaussian_noise, psd_sqrt

__all__ = ["MotionModel", "MeasurementModel", "ModelPair"]


def _checked(model: Any, method: str) -> CovarianceCheck:
    """The covariance check of ``model.method`` (``Q`` or ``R``), kept with the model so that a model that returns
    the same matrix at every step is checked once."""
    checks = model.__dict__.setdefault("_covariance_checks", {})
    if method not in checks:
        role = "motion" if method == "Q" else "measurement"
        checks[method] = CovarianceCheck(f"the {role} model {type(model).__name__}.{method}", model, method)
    return checks[method]


class MotionModel:
    r"""How the state moves in one step: :math:`x_k = f(x_{k-1}, u_k, k) + w_k`, :math:`w_k \sim N(0, Q_k)`.

    Subclasses set ``n`` and implement :meth:`f`, :meth:`F` and :meth:`Q`; a particle filter draws through
    :meth:`sample` (Gaussian by default; override it for a model with its own sampler).

    Attributes
    ----------
    n : int
        Size of the state.

    Examples
    --------
    A motion model of your own: the position drifts by a known current of 0.1 m per step on top of the DR
    displacement (``f``, its Jacobian ``F`` and the noise ``Q``, for every run at once):

    >>> import numpy as np
    >>> from uwtutor.filters import extended_kalman_filter
    >>> from uwtutor.models import MotionModel, RangeToBeacon
    >>> class Drift(MotionModel):
    ...     n = 2
    ...     def f(self, x, u, k):
    ...         return x + u + [0.1, 0.0]
    ...     def F(self, x, u, k):
    ...         return np.eye(2)
    ...     def Q(self, x, u, k):
    ...         return np.eye(2) * 0.01
    >>> Drift().f(np.zeros((1, 2)), np.array([1.0, 2.0]), 0)
    array([[1.1, 2. ]])
    >>> res = extended_kalman_filter(
    ...     Drift(),
    ...     RangeToBeacon((0.0, 0.0), R=1.0),
    ...     [30.0, 40.0],
    ...     np.eye(2),
    ...     np.zeros((3, 2)),
    ...     [50.1, 50.2, 50.3],
    ... )
    >>> res.x.shape
    (3, 2)
    """

    n: int = 0
    #: True for a library model whose covariances were checked when it was made (a checked schedule, or
    #: :math:`G \Sigma G^\mathsf{T}` of checked variances): the filters do not check them again at each step. A model
    #: of your own leaves it False, and the engine checks every new covariance it returns.
    covariances_checked: bool = False

    def f(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        """The predicted states ``(M, n)`` of the states ``x`` ``(M, n)`` moved by the input ``u`` of step ``k``."""
        raise NotImplementedError

    def F(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        r"""The Jacobian :math:`\partial f / \partial x` at ``x``: ``(n, n)`` or ``(M, n, n)``."""
        raise NotImplementedError

    def Q(self, x: np.ndarray, u: Any, k: int) -> np.ndarray:
        """The process noise covariance of step ``k`` in state space: ``(n, n)`` or ``(M, n, n)``."""
        raise NotImplementedError

    def linearize(self, x: np.ndarray, u: Any, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``f``, ``F`` and ``Q`` of one step at once (what a filter's prediction needs); override it when the three
        share work (a heading's sine and cosine), as :class:`~uwtutor.models.odometry.OdometryMotion` does."""
        F = self.F(x, u, k)
        Q = self.Q(x, u, k)
        return self.f(x, u, k), F, Q

    def difference(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        r"""The difference ``a - b`` of two states ``(..., n)``; a model with an angle in its state wraps it (the
        smoother's correction must not see a heading jump by :math:`2\pi` where it crosses :math:`\pm\pi`)."""
        return a - b

    def normalize(self, x: np.ndarray) -> np.ndarray:
        """A state ``(..., n)`` put back in its canonical range (an angle wrapped); the identity by default."""
        return x

    def sample(self, x: np.ndarray, u: Any, k: int, rng: Any) -> np.ndarray:
        r"""Draw the next states of states ``x``: :math:`x_k = f(x_{k-1}, u_k, k) + L_k \varepsilon`,
        :math:`\varepsilon \sim N(0, I)`, :math:`L_k L_k^\mathsf{T} = Q_k`.

        The square root is :func:`~uwtutor.models.noise.psd_sqrt`'s: a Cholesky factor, or one from the
        eigendecomposition when :math:`Q_k` is singular (a constant state, noise that enters through fewer inputs
        than states), so that no component gets noise it should not have. Override it for a model that draws
        more exactly than :math:`f + w` (noise inside the kinematics, or in the inputs), or whose noise is not
        Gaussian.

        Parameters
        ----------
        x : ndarray, shape (M, N, n) or (M, n)
            The states of ``M`` runs (``N`` particles each).
        u : array_like or None
            The input of step ``k``: ``(p,)`` shared, or one per run aligned with ``x`` (``(M, 1, p)`` for
            particles, ``(M, p)`` for ``(M, n)`` states).
        k : int
            The index of the step.
        rng : sequence of numpy.random.Generator
            One per run: run ``m`` draws from ``rng[m]``.

        Returns
        -------
        ndarray, the shape of ``x``

        Examples
        --------
        >>> import numpy as np
        >>> from uwtutor.models import LinearMotion
        >>> # the second state is constant
        >>> walk = LinearMotion(F=np.eye(2), Q=np.diag([1.0, 0.0]))
        >>> x = walk.sample(
        ...     np.zeros((1, 4, 2)), None, 0, [np.random.default_rng(0)]
        ... )
        >>> x.shape, bool(np.all(x[..., 1] == 0.0))
        ((1, 4, 2), True)
        """
        name = f"the motion model {type(self).__name__}"
        mean = as_model_output(f"{name}.f", self.f(x, u, k))
        if mean.shape != np.shape(x):
            raise ValueError(f"{name}.f must return the shape of the states it moves, {np.shape(x)}; got {mean.shape}")
        if not np.isfinite(mean).all():
            raise ValueError(f"{name}.f returned a non-finite value at step {k}: check the model there")
        Q = as_model_output(f"{name}.Q", self.Q(x, u, k))
        if Q.shape[-2:] != (self.n, self.n):
            raise ValueError(f"{name}.Q must return ({self.n}, {self.n}) matrices (the state size); got {Q.shape}")
        _checked(self, "Q")(Q)                       # real, symmetric PSD: the checks the EKF engine makes
        return mean + gaussian_noise(psd_sqrt(Q), rng, mean.shape)


class MeasurementModel:
    r"""What a measurement should be: :math:`z_k = h_k(x_k) + v_k`, :math:`v_k \sim N(0, R_k)`.

    Subclasses set ``m`` and ``n`` and implement :meth:`h`, :meth:`H` and :meth:`R`; a model whose
    Jacobian is undefined somewhere (the range on the beacon) overrides :meth:`linearize` and reports it there. A
    particle filter weighs through :meth:`log_likelihood` (Gaussian by default; override it for another noise).
    A model with parameters per Monte Carlo run (a beacon path per run) sets ``n_runs`` and provides
    ``select_runs(runs)``, the same model for some of the runs (a particle filter takes its runs block by block).

    Attributes
    ----------
    m : int
        Size of one measurement.
    n : int
        Size of the state the model reads.

    Examples
    --------
    A measurement model of your own: a pressure sensor that reads the first state (a depth), with a noise of
    0.1 m:

    >>> import numpy as np
    >>> from uwtutor.filters import extended_kalman_filter
    >>> from uwtutor.models import LinearMotion, MeasurementModel
    >>> class Depth(MeasurementModel):
    ...     m, n = 1, 2
    ...     def h(self, x, k):
    ...         return x[:, :1]
    ...     def H(self, x, k):
    ...         return np.tile([[1.0, 0.0]], (x.shape[0], 1, 1))
    ...     def R(self, x, k):
    ...         return np.array([[0.01]])
    >>> Depth().h(np.array([[12.0, 0.5]]), 0)
    array([[12.]])
    >>> res = extended_kalman_filter(
    ...     LinearMotion(F=[[1.0, 1.0], [0.0, 1.0]], Q=np.eye(2) * 1e-4),
    ...     Depth(),
    ...     [10.0, 0.5],
    ...     np.eye(2),
    ...     None,
    ...     [10.5, 11.0, 11.5],
    ... )
    >>> np.round(res.x[-1], 2)
    array([11.5,  0.5])
    """

    m: int = 1
    n: int = 0
    #: True for a library model whose covariances were checked when it was made (a checked schedule, or
    #: :math:`G \Sigma G^\mathsf{T}` of checked variances): the filters do not check them again at each step. A model
    #: of your own leaves it False, and the engine checks every new covariance it returns.
    covariances_checked: bool = False

    def __init_subclass__(cls, **kwargs: Any) -> None:
        """A subclass that overrides ``h`` and inherits a library ``linearize`` (which computes the prediction and
        the Jacobian together, without calling ``h``) gets a ``linearize`` that predicts with its own ``h``: an
        override is never silently left out of the EKF."""
        super().__init_subclass__(**kwargs)
        inherited = cls.linearize
        if "h" in cls.__dict__ and "linearize" not in cls.__dict__ and inherited is not MeasurementModel.linearize:
            def linearize(self: Any, x: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
                _, H, defined = inherited(self, x, k)
                return self.h(x, k), H, defined
            linearize.__doc__ = inherited.__doc__
            cls.linearize = linearize                  # type: ignore[method-assign]
    #: True for a model whose measurements are ranges, never negative (NaN where missing); the engine's ``run``
    #: and ``extended_kalman_filter`` then refuse a negative one by name. Set it on a range model of your own.
    nonnegative: bool = False

    def h(self, x: np.ndarray, k: int) -> np.ndarray:
        """The predicted measurements ``(M, m)`` of the states ``x`` ``(M, n)`` at step ``k``."""
        raise NotImplementedError

    def H(self, x: np.ndarray, k: int) -> np.ndarray:
        r"""The Jacobian :math:`\partial h / \partial x` at ``x``: ``(M, m, n)``."""
        raise NotImplementedError

    def R(self, x: np.ndarray, k: int) -> np.ndarray:
        """The measurement noise covariance at step ``k``: ``(m, m)`` or ``(M, m, m)``."""
        raise NotImplementedError

    def linearize(self, x: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Predicted measurement ``(M, m)``, Jacobian ``(M, m, n)`` and a mask ``(M,)`` of the runs where both are
        defined -- or ``(M, m)``, component by component. Where the mask is False the filter skips the update of
        that run (or component) and warns. A component that is not measured at step ``k`` may be NaN here: the
        filters never use it."""
        return self.h(x, k), self.H(x, k), np.ones(x.shape[0], dtype=bool)

    def residual(self, z: np.ndarray, z_pred: np.ndarray) -> np.ndarray:
        """The innovation ``z - z_pred`` (override for angles or other wrapped quantities)."""
        return z - z_pred

    def log_likelihood(self, x: np.ndarray, z: np.ndarray, k: int) -> np.ndarray:
        r"""The log-likelihood :math:`\log p(z_k \mid x)` of the measurement ``z`` for every state of ``x``.

        Gaussian by default, :math:`N(h_k(x), R_k)`, with the components missing from ``z`` (NaN) marginalised
        out and up to a constant that is the same for every state of a run
        (:func:`~uwtutor.models.noise.gaussian_log_likelihood`); a run whose ``z`` is all NaN gets 0. Override it
        for a measurement noise that is not Gaussian (it must then take the runs axis and skip NaN components).

        Parameters
        ----------
        x : ndarray, shape (M, N, n)
            ``N`` states (particles) of each of ``M`` runs.
        z : ndarray, shape (M, m)
            The measurement of each run, NaN where a component is missing.
        k : int
            The index of the step.

        Returns
        -------
        ndarray, shape (M, N)

        Examples
        --------
        >>> import numpy as np
        >>> from uwtutor.models import RangeToBeacon
        >>> ranges = RangeToBeacon((0.0, 0.0), R=4.0)
        >>> # one run: ranges 5 and 10
        >>> particles = np.array([[[3.0, 4.0], [6.0, 8.0]]])
        >>> # -(7 - r)^2 / (2 * 4)
        >>> ranges.log_likelihood(particles, np.array([[7.0]]), 0)
        array([[-0.5  , -1.125]])
        """
        return gaussian_log_likelihood(np.asarray(self.h(x, k), dtype=float), z, np.asarray(self.R(x, k), float),
                                       self.residual)

    def sample(self, x: np.ndarray, k: int, rng: Any) -> np.ndarray:
        r"""Draw measurements of states ``x`` ``(M, ..., n)``: :math:`z = h_k(x) + L\varepsilon`,
        :math:`L L^\mathsf{T} = R_k` (``rng`` one Generator per run; to simulate data).

        Examples
        --------
        >>> import numpy as np
        >>> from uwtutor.models import RangeToBeacon
        >>> z = RangeToBeacon((0.0, 0.0), R=4.0).sample(
        ...     np.array([[3.0, 4.0]]), 0, [np.random.default_rng(0)]
        ... )
        >>> # 5 m, give or take 2 m noise
        >>> z.shape, bool(abs(z[0, 0] - 5.0) < 8.0)
        ((1, 1), True)
        """
        name = f"the measurement model {type(self).__name__}"
        mean = as_model_output(f"{name}.h", self.h(x, k))
        R = as_model_output(f"{name}.R", self.R(x, k))
        if R.shape[-2:] != (self.m, self.m):
            raise ValueError(f"{name}.R must return ({self.m}, {self.m}) matrices (the measurement size); got "
                             f"{R.shape}")
        _checked(self, "R")(R)
        return mean + gaussian_noise(psd_sqrt(R), rng, mean.shape)


class ModelPair:
    r"""A motion model and a measurement model in one object: a state-space model.

    Every filter that takes ``motion, measurement`` also takes one pair in their place, e.g.
    ``BootstrapParticleFilter.from_gaussian(pair, x0, P0, n_particles, rng)``.

    A subclass may override :meth:`log_likelihood` for **one run** -- ``particles`` ``(N, n)`` and ``z``
    ``(m,)``, returning ``(N,)`` -- the way a student writes a likelihood (a mixture for a sensor that spikes):
    the filters then call it run by run (and skip a run whose ``z`` is all NaN), reading the predicted
    measurements from :meth:`measure`.

    Parameters
    ----------
    motion : MotionModel
    measurement : MeasurementModel
        Built for the same state (``measurement.n == motion.n``).

    Attributes
    ----------
    n, m : int
        Sizes of the state and of a measurement.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.models import LinearMeasurement, LinearMotion, ModelPair
    >>> pair = ModelPair(
    ...     LinearMotion(F=[[1.0]], Q=[[1.0]]), LinearMeasurement(H=[[1.0]], R=4.0)
    ... )
    >>> truth, z = pair.simulate([0.0], 5, np.random.default_rng(1))
    >>> truth.shape, z.shape
    ((5, 1), (5, 1))
    """

    def __init__(self, motion: MotionModel, measurement: MeasurementModel) -> None:
        if not isinstance(motion, MotionModel):
            raise TypeError(f"motion must be a uwtutor.models.MotionModel; got {type(motion).__name__}")
        if not isinstance(measurement, MeasurementModel):
            raise TypeError(f"measurement must be a uwtutor.models.MeasurementModel; got {type(measurement).__name__}")
        if measurement.n != motion.n:
            raise ValueError(f"the measurement model reads a state of size {measurement.n} but the motion model's "
                             f"state has size {motion.n}: build both for the same state")
        self.motion = motion
        self._measurement = measurement
        self._k = 0

    @property
    def n(self) -> int:
        """Size of the state."""
        return self.motion.n

    @property
    def m(self) -> int:
        """Size of a measurement."""
        return self._measurement.m

    @property
    def measurement(self) -> MeasurementModel:
        """The measurement model, as the filters use it (with this pair's one-run :meth:`log_likelihood` when a
        subclass overrides it)."""
        if type(self).log_likelihood is ModelPair.log_likelihood:
            return self._measurement
        return _OneRunLikelihood(self)

    def measure(self, particles: np.ndarray, k: int | None = None) -> np.ndarray:
        """The noise-free measurements :math:`h(x)` of states ``(..., n)``: ``(..., m)`` (``k``: the step, by
        default the one the filter is weighing)."""
        x = np.asarray(particles, dtype=float)
        flat = x.reshape((-1, 1, x.shape[-1]))
        hx = np.asarray(self._measurement.h(flat, self._k if k is None else k), dtype=float)
        return hx.reshape(x.shape[:-1] + (hx.shape[-1],))

    def log_likelihood(self, particles: np.ndarray, z: np.ndarray) -> np.ndarray:
        """The measurement model's log-likelihood of ``z`` ``(m,)`` for one run's particles ``(N, n)``: ``(N,)``."""
        x = np.asarray(particles, dtype=float)
        zz = np.asarray(z, dtype=float).reshape(1, -1)
        return self._measurement.log_likelihood(x[None], zz, self._k)[0]

    def simulate(self, x0: Any, n_steps: int, rng: np.random.Generator, u: Any = None) -> tuple[np.ndarray, np.ndarray]:
        """A true trajectory drawn from the motion model and its measurements.

        Parameters
        ----------
        x0 : array_like, shape (n,)
            The state before the first step.
        n_steps : int
            Number of steps ``K``.
        rng : numpy.random.Generator
            Source of the process noise (step by step) and then of the measurement noise (all steps at once).
        u : array_like, shape (K, p), optional
            The inputs of the steps.

        Returns
        -------
        truth : ndarray, shape (K, n)
            States after each step.
        measurements : ndarray, shape (K, m)
            ``h(truth)`` plus noise drawn from ``R``.
        """
        from .._validate import as_finite, as_int, as_rng, check_work

        x = as_finite("x0", x0, shape=(self.n,))[None, None, :]
        K = as_int("n_steps", n_steps, minimum=1)
        check_work("n_steps", K * (self.n + self.m), "values of truth and measurements")
        rng = as_rng(rng)
        inputs = None if u is None else as_finite("u", u, ndim=2)
        if inputs is not None and len(inputs) != K:
            raise ValueError(f"u must give one input per step ({K}); got shape {inputs.shape}")
        truth = np.empty((K, self.n))
        for k in range(K):
            x = self.motion.sample(x, None if inputs is None else inputs[k], k, (rng,))
            truth[k] = x[0, 0]
        hx = np.stack([np.asarray(self._measurement.h(truth[k][None, None], k), dtype=float)[0, 0]
                       for k in range(K)])
        Rs = [np.asarray(self._measurement.R(truth[k][None, None], k), dtype=float) for k in range(K)]
        eps = rng.standard_normal((K, hx.shape[-1]))
        if all(R is Rs[0] for R in Rs) and Rs[0].ndim == 2:           # one R: one product, as a table of noise
            return truth, hx + eps @ psd_sqrt(Rs[0]).T
        roots = np.stack([psd_sqrt(R.reshape(R.shape[-2:])) for R in Rs])
        return truth, hx + np.einsum("kij,kj->ki", roots, eps)


class _OneRunLikelihood(MeasurementModel):
    """A pair's measurement model whose log-likelihood is the pair's one-run override, called run by run."""

    def __init__(self, pair: ModelPair) -> None:
        self.pair = pair
        self.base = pair._measurement
        self.m, self.n = self.base.m, self.base.n
        self.n_runs = getattr(self.base, "n_runs", None)

    def h(self, x: np.ndarray, k: int) -> np.ndarray:
        return self.base.h(x, k)

    def H(self, x: np.ndarray, k: int) -> np.ndarray:
        return self.base.H(x, k)

    def R(self, x: np.ndarray, k: int) -> np.ndarray:
        return self.base.R(x, k)

    def linearize(self, x: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return self.base.linearize(x, k)

    def residual(self, z: np.ndarray, z_pred: np.ndarray) -> np.ndarray:
        return self.base.residual(z, z_pred)

    def log_likelihood(self, x: np.ndarray, z: np.ndarray, k: int) -> np.ndarray:
        self.pair._k = k
        out = np.zeros(x.shape[:2])
        for run in range(x.shape[0]):
            if np.isnan(z[run]).all():
                continue
            ll = np.asarray(self.pair.log_likelihood(x[run], z[run]), dtype=float)
            if ll.shape != (x.shape[1],):
                raise ValueError(f"{type(self.pair).__name__}.log_likelihood must return one value per particle of "
                                 f"the run, shape ({x.shape[1]},); got {ll.shape}")
            out[run] = ll
        return out
