r"""The multiple-model (jump-Markov) bootstrap particle filter: every particle carries a motion mode.

``J`` motion models (the *modes*, e.g. cruise, dive and climb) share one measurement model. Particle ``i`` carries a
mode :math:`r^{(i)}_k \in \{0, \dots, J-1\}` that switches as a Markov chain with transition matrix
:math:`\Pi_{jl} = \Pr(r_k = l \mid r_{k-1} = j)` before each step, and moves with its mode's model (McGinnity and
Irwin 2000; Boers and Driessen 2003):

.. math::

    r^{(i)}_k \sim \Pi_{r^{(i)}_{k-1}, \cdot}, \qquad x^{(i)}_k \sim p(x_k \mid x^{(i)}_{k-1}, u_k, r^{(i)}_k),
    \qquad w^{(i)}_k \propto w^{(i)}_{k-1}\, p(z_k \mid x^{(i)}_k), \qquad
    \mu^j_k = \sum_{i:\, r^{(i)}_k = j} w^{(i)}_k .

The estimate is the weighted mean over all particles (the mixture of the modes' estimates by their probabilities
:math:`\mu^j_k`); resampling copies the modes with the particles. The modes are motion models of
:mod:`uwtutor.models` -- the same the EKF takes -- each drawing with its
:meth:`~uwtutor.models.base.MotionModel.sample`; everything else (likelihood, missing components, effective sample
size, resampling rule, batches of runs) is that of
:class:`~uwtutor.filters.particle.bootstrap.BootstrapParticleFilter`.

References
----------
McGinnity, S. and Irwin, G. W. (2000). Multiple model bootstrap filter for maneuvering target tracking. *IEEE
Trans. Aerospace and Electronic Systems* 36(3), 1006-1012.

Boers, Y. and Driessen, J. N. (2003). Interacting multiple model particle filter. *IEE Proceedings - Radar, Sonar
and Navigation* 150(5), 344-349.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np
from numpy.typing import ArrayLike

from ..._validate import as_nonnegative
from ...models.base import MeasurementModel, ModelPair, MotionModel
from ...models.noise import RunGenerators
from ...resampling import Resampler, systematic_resample
from .bootstrap import BootstrapParticleFilter, _check_model, _shift_for_pair

__all__ = ["MultipleModelParticleFilter"]


def _same_noise(a: MeasurementModel, b: MeasurementModel) -> bool:
    """Whether two measurement models of mode pairs are the same likelihood (same type, same R at step 0)."""
    if a is b:
        return True
    if type(a) is not type(b) or a.m != b.m or a.n != b.n:
        return False
    probe = np.zeros((1, 1, a.n))
    Ra, Rb = np.asarray(a.R(probe, 0), dtype=float), np.asarray(b.R(probe, 0), dtype=float)
    return Ra.shape == Rb.shape and bool(np.allclose(Ra, Rb))


class MultipleModelParticleFilter(BootstrapParticleFilter):
    r"""Multiple-model (jump-Markov) bootstrap particle filter: every particle carries a motion mode.

    Equations in the module docstring.

    Parameters
    ----------
    motions : sequence of uwtutor.models.MotionModel
        The ``J`` mode models, for the same state (e.g. :class:`~uwtutor.models.depth.PitchManeuver` with the pitch
        targets of cruise, dive and climb). A sequence of :class:`~uwtutor.models.base.ModelPair` may stand for
        ``motions`` and ``measurement`` (their motion models the modes; their measurement models the same).
    measurement : uwtutor.models.MeasurementModel
        The one measurement model (one likelihood for every mode).
    particles : array_like, shape (N, n) or (M, N, n)
        Initial particles (of ``M`` runs).
    rng : numpy.random.Generator or sequence of numpy.random.Generator
        Source of all randomness (mode switches, motion noise, resampling), one per run as in
        :class:`~uwtutor.filters.particle.bootstrap.BootstrapParticleFilter`.
    transition : array_like, shape (J, J)
        Mode transition matrix: entries >= 0, each row summing to 1.
    modes : array_like of int, shape (N,) or (M, N), optional
        Initial mode of each particle; drawn from ``mode_probabilities`` when not given.
    mode_probabilities : array_like, shape (J,), optional
        Initial mode probabilities, >= 0 (normalized here, as the weights are; equal by default); used only
        when ``modes`` is not given.
    weights : array_like, shape (N,) or (M, N), optional
        Initial weights; equal by default.
    resampler : callable, optional
        ``resampler(weights, rng) -> indices`` (systematic by default).
    ess_threshold : float, optional
        As in the bootstrap filter (1.0: resample at every measurement).

    Attributes
    ----------
    modes : ndarray of int, shape (N,) or (M, N)
        Current mode of each particle.
    mode_probabilities : ndarray, shape (J,) or (M, J)
        :math:`\mu^j` after the last step (after ``update``: the posterior, before any resampling).
    motions : list of MotionModel
        The mode models.
    transition : ndarray, shape (J, J)
        The transition matrix.

    Examples
    --------
    Paper C's dive, with the modes cruise, dive and climb (pitch targets 0, +0.3 and -0.3 rad):

    >>> import numpy as np
    >>> from uwtutor.filters import MultipleModelParticleFilter
    >>> from uwtutor.models import DepthSensors, PitchManeuver, PitchManeuverModel
    >>> modes = [PitchManeuver(pitch_target=p) for p in (0.0, 0.3, -0.3)]
    >>> Pi = np.full((3, 3), 0.005) + np.eye(3) * 0.985
    >>> rng = np.random.default_rng(0)
    >>> truth, meas = PitchManeuverModel(pitch_target=0.3).simulate(
    ...     [10.0, 1.5, 0.0], 200, rng
    ... )
    >>> sensors = DepthSensors()
    >>> mmpf = MultipleModelParticleFilter.from_gaussian(
    ...     modes, sensors, meas[0], sensors.R(None, 0), 600, rng, transition=Pi
    ... )
    >>> res = mmpf.run(meas)
    >>> res.extras["mode_probabilities"].shape
    (200, 3)
    >>> # the dive mode wins
    >>> int(np.argmax(res.extras["mode_probabilities"][-50:].mean(axis=0)))
    1
    """

    extra_outputs = ("ess", "resampled", "mode_probabilities")
    _fixed = BootstrapParticleFilter._fixed + ("motions", "transition")     # base.Configurable
    _run_state = BootstrapParticleFilter._run_state + ("_modes", "_mu")

    motions: list[MotionModel]                      # the mode models (_split_models makes the list)

    def __init__(self, motions: Sequence[MotionModel] | Sequence[ModelPair], measurement: Any = None,
                 particles: ArrayLike | None = None, rng: RunGenerators | None = None, *,
                 transition: ArrayLike, modes: ArrayLike | None = None, mode_probabilities: ArrayLike | None = None,
                 weights: ArrayLike | None = None, resampler: Resampler = systematic_resample,
                 ess_threshold: float = 1.0) -> None:
        models, measurement, (particles, rng) = self._split_models(motions, measurement, (particles, rng))
        J = len(models)
        Pi = as_nonnegative("transition", transition, shape=(J, J))
        rows = Pi.sum(axis=1)
        if np.abs(rows - 1.0).max() > 1e-9:
            raise ValueError(f"transition must be row-stochastic (each row sums to 1); its rows sum to {rows}")
        self.motions = models
        self.transition = Pi / rows[:, None]
        self._cum_transition = np.cumsum(self.transition, axis=1)
        self._modes = np.empty((0, 0), dtype=np.intp)
        super().__init__(models[0], measurement, particles, rng, weights=weights, resampler=resampler,
                         ess_threshold=ess_threshold)
        M, N = self._w.shape
        if modes is not None:
            m = np.asarray(modes)
            want = (M, N) if self._batched else (N,)
            if m.shape != want or m.dtype.kind not in "iu" or (m < 0).any() or (m >= J).any():
                raise ValueError(f"modes must be integers in 0..{J - 1} of shape {want} (one per particle); "
                                 f"got {modes!r}")
            self._modes = m.astype(np.intp).reshape(M, N)
        else:
            if mode_probabilities is None:
                p = np.full(J, 1.0 / J)
            else:
                p = as_nonnegative("mode_probabilities", mode_probabilities, shape=(J,))
                if not p.sum() > 0:
                    raise ValueError("mode_probabilities must have a positive sum")
                p = p / p.sum()
            cum = np.cumsum(p)
            self._modes = np.stack([np.minimum(np.searchsorted(cum, r.random(N), side="right"), J - 1)
                                    for r in self.rngs])
        self._set_estimate()

    @classmethod
    def _split_models(cls, first: Any, second: Any, rest: tuple[Any, ...]) -> tuple[Any, Any, tuple[Any, ...]]:
        """The mode motion models, the shared measurement model and the other arguments; a sequence of
        :class:`~uwtutor.models.base.ModelPair` stands for the first two."""
        items = list(first) if isinstance(first, (list, tuple)) else [first]
        if not items:
            raise TypeError("motions must be a non-empty list of motion models (one per mode)")
        if all(isinstance(p, ModelPair) for p in items):
            measurement = items[0].measurement
            for j, pair in enumerate(items[1:], start=1):
                if pair.n != items[0].n or not _same_noise(pair._measurement, items[0]._measurement):
                    raise ValueError(f"the mode models must share the state size and the measurement noise R (one "
                                     f"likelihood for all modes); model {j} differs from model 0")
            return [p.motion for p in items], measurement, _shift_for_pair(second, rest)
        for j, model in enumerate(items):
            _check_model(f"motions[{j}]", model, MotionModel)
            if model.n != items[0].n:
                raise ValueError(f"the mode models must share the state size; motions[{j}] has {model.n} states, "
                                 f"motions[0] has {items[0].n}")
            if getattr(model, "n_runs", None) is not None:
                raise ValueError(f"motions[{j}] ({type(model).__name__}) holds per-run parameters: the mode models "
                                 "of a multiple-model filter must be shared by every run")
        return items, second, rest

    def _models(self) -> list[tuple[str, Any]]:
        return [(f"motions[{j}]", m) for j, m in enumerate(self.motions)] + [("measurement", self.measurement)]

    @property
    def modes(self) -> np.ndarray:
        """Mode index of each particle, shape (N,) or (M, N)."""
        modes: np.ndarray = self._out(self._modes)
        return modes

    @property
    def n_modes(self) -> int:
        """Number of modes ``J``."""
        return len(self.motions)

    @property
    def mode_probabilities(self) -> np.ndarray:
        r""":math:`\mu^j` of each run: (J,) or (M, J)."""
        mu: np.ndarray = self._out(self._mu)
        return mu

    def _set_estimate(self) -> None:
        super()._set_estimate()
        J = self.n_modes
        if self._modes.shape != self._w.shape:                 # during construction, before the modes exist
            self._mu = np.full((self._w.shape[0], J), np.nan)
        elif self._w.shape[0] == 1:
            self._mu = np.bincount(self._modes[0], weights=self._w[0], minlength=J)[None]
        else:
            M = self._w.shape[0]
            flat = (self._modes + J * np.arange(M)[:, None]).ravel()
            self._mu = np.bincount(flat, weights=self._w.ravel(), minlength=M * J).reshape(M, J)

    def _predict(self, u: Any) -> None:
        """Switch every particle's mode (Markov chain), then move it with its mode's model (run by run)."""
        self.k += 1
        J = self.n_modes
        for r in range(self.n_runs):
            draws = self.rngs[r].random(self.n_particles)
            new_modes = np.minimum((draws[:, None] >= self._cum_transition[self._modes[r]]).sum(axis=1), J - 1)
            # group the particles by mode (their order carries no meaning) so that each model moves one block
            order = np.argsort(new_modes, kind="stable")
            counts = np.bincount(new_modes, minlength=J)
            grouped = self._rows_p[r].take(order, axis=1)
            u_run = u[r:r + 1] if u is not None and np.ndim(u) == 3 else u
            pieces, start = [], 0
            for j, (model, count) in enumerate(zip(self.motions, counts)):
                if count:
                    block = grouped[None, :, start:start + count]
                    pieces.append(self._sample(model, block, u_run, self.k, (self.rngs[r],),
                                               name=f"motions[{j}]")[0])
                    start += count
            self._rows_p[r] = np.concatenate(pieces, axis=1)
            self._modes[r] = new_modes[order]
            if not self._uniform[r]:
                self._w[r] = self._w[r][order]
        self._set_prior()

    def _take(self, run: int, idx: np.ndarray) -> None:
        """Resampling copies the modes with the particles."""
        super()._take(run, idx)
        self._modes[run] = self._modes[run].take(idx)
