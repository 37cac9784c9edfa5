r"""The particle filters, one module per family, all on the motion/measurement model pairs of :mod:`uwtutor.models`.

=================================================================  ==================================================
:mod:`~uwtutor.filters.particle.bootstrap`                         the bootstrap (SIR) filter: propose from the motion
                                                                   model, weigh by the likelihood, resample
:mod:`~uwtutor.filters.particle.multiple_model`                    the multiple-model filter: a motion model per mode,
                                                                   the modes a Markov chain (paper C's MMPF)
:mod:`~uwtutor.filters.particle.grey`                              the grey particle filter of paper C: grey-forecast
                                                                   particles and a wavelet noise estimate
=================================================================  ==================================================

Each takes the model pair the generic EKF takes (``motion, measurement``; or one
:class:`~uwtutor.models.base.ModelPair`), runs ``M`` Monte Carlo runs at once with one explicit
``numpy.random.Generator`` per run, and follows the filter protocol of :mod:`uwtutor.filters.base`
(``tests/test_filter_contract_pf.py``).
"""

from .bootstrap import BootstrapParticleFilter, ParticleCollapseWarning, ParticleDegeneracyError
from .grey import GreyParticleFilter
from .multiple_model import MultipleModelParticleFilter

__all__ = ["BootstrapParticleFilter", "MultipleModelParticleFilter", "GreyParticleFilter", "ParticleDegeneracyError",
           "ParticleCollapseWarning"]
