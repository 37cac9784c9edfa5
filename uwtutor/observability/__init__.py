r"""Range-only observability and the limits of accuracy: Jacobians, Fisher information, the Cramér–Rao bound.

A range to a beacon at :math:`b` is :math:`r = \|p - b\| + \eta`, :math:`\eta \sim N(0, \sigma^2)`. Everything in this
module follows from its Jacobian, the unit line-of-sight vector

.. math::

    h(p) = \frac{\partial r}{\partial p} = \frac{(p - b)^\mathsf{T}}{\|p - b\|},

stacked over beacons (real ones, or the *virtual* beacons :math:`b - d_k` that dead reckoning makes of one beacon
pinged from several points of a track) and over the extra unknowns a chapter adds to the state: a constant range
bias :math:`\upsilon` (Liu et al., paper A: one more column of ones) or a constant current :math:`U` (paper B: a
column block :math:`(t_k - t_\mathrm{ref})\,h_k`). With the stacked Jacobian :math:`H` and independent range errors
of standard deviations :math:`\sigma_k`,

.. math::

    J = H^\mathsf{T} R^{-1} H = \sum_k \frac{h_k^\mathsf{T} h_k}{\sigma_k^2}, \qquad
    \operatorname{Cov}(\hat x) \succeq J^{-1} \quad\text{(the Cramér–Rao lower bound, CRLB)},

and :math:`J` is also the (linearized) observability Gramian of the range measurements: the state is locally
observable exactly when :math:`J` has full rank.

=====================================  ==============================================================================
``range_jacobian``                     unit line-of-sight vectors :math:`\partial r / \partial p`
``squared_range_jacobian``             :math:`\partial r^2 / \partial p = 2 (p - b)` (paper B measures :math:`r^2`)
``beacons_at_bearings``                beacons placed at given bearings and distances from a position
``virtual_beacons``                    :math:`b_k - (p_k - p_\mathrm{ref})`: one beacon seen from a whole track
``fisher_information``                 :math:`J` of a static position (and bias) ranged from several beacons
``position_crlb``                      the CRLB :math:`J^{-1}` of that position (and bias)
``cramer_rao_bound``                   :math:`J^{-1}` of any information matrix, infinite where :math:`J` is singular
``rmse_bound``                         :math:`\sqrt{\operatorname{tr}}` of the position block of a bound
``gdop``                               GDOP, :math:`\sqrt{\operatorname{tr}(H^\mathsf{T}H)^{-1}}`
``precision_factor``                   paper A's :math:`\alpha = \operatorname{tr}(X^\mathsf{T}X)^{-1}`
``track_jacobian``                     the stacked Jacobian of the ranges along a track (position, bias, current)
``track_fisher_information``           its information matrix, for the whole track or epoch by epoch
``track_crlb``                         the bound on the position at each epoch from the ranges so far
``observability_rank``                 the numerical rank of the information along a track, epoch by epoch
``numerical_rank``                     the rank of any matrix with a relative tolerance (columns scaled first)
``two_range_fix``                      the two mirror solutions of two ranges and one displacement
``mirror_point``                       the reflection of a point across a line through the beacon
``error_ellipse``                      points of a covariance ellipse, for plots
``posterior_crlb``                     the posterior bound of a filter with process noise (and bias, current)
``model_posterior_crlb``               the posterior bound of any motion/measurement model pair on a true track
=====================================  ==============================================================================

The package holds one module per job: :mod:`~uwtutor.observability.jacobians` (the Jacobians),
:mod:`~uwtutor.observability.information` (Fisher information and rank), :mod:`~uwtutor.observability.bounds`
(the Cramér–Rao bounds of a fix and of a track), :mod:`~uwtutor.observability.posterior` (the posterior bound of a
filter) and :mod:`~uwtutor.observability.geometry` (mirror fixes, ellipses); every name above is imported from
``uwtutor.observability`` itself.

Degenerate geometry is a normal case, never a crash and never a silent finite number: a singular information
matrix gives a bound that is infinite along its unobservable directions, with an ``UnobservableWarning`` that names
them (silence it with ``warnings.catch_warnings`` when the degeneracy is expected).

References
----------
Y. Bar-Shalom, X. R. Li and T. Kirubarajan, *Estimation with Applications to Tracking and Navigation*, Wiley, 2001
(Fisher information and the CRLB for nonlinear measurements).
T. L. Song, "Observability of target tracking with range-only measurements", IEEE J. Oceanic Eng. 24(3), 1999.
A. S. Gadre and D. J. Stilwell, "A complete solution to underwater navigation in the presence of unknown currents
based on range measurements from a single location", IROS 2005.
G. Indiveri, D. De Palma and G. Parlangeli, "Single range localization in 3-D: observability and robustness issues",
IEEE Trans. Control Syst. Technol. 24(5), 2016.
P. Stoica and T. L. Marzetta, "Parameter estimation problems with singular information matrices", IEEE Trans.
Signal Process. 49(1), 2001 (the bound of the estimable parameters when the information is singular).
P. Tichavský, C. H. Muravchik and A. Nehorai, "Posterior Cramér–Rao bounds for discrete-time nonlinear filtering",
IEEE Trans. Signal Process. 46(5), 1998 (the posterior bound of a filter with process noise).
"""

from __future__ import annotations

from ..errors import UnobservableWarning
from ._common import DEFAULT_RTOL
from .bounds import cramer_rao_bound, gdop, position_crlb, precision_factor, rmse_bound, track_crlb
from .geometry import error_ellipse, mirror_point, two_range_fix
from .information import fisher_information, numerical_rank, observability_rank, track_fisher_information
from .jacobians import beacons_at_bearings, range_jacobian, squared_range_jacobian, track_jacobian, virtual_beacons
from .posterior import model_posterior_crlb, posterior_crlb

__all__ = [
    "DEFAULT_RTOL",
    "UnobservableWarning",
    "range_jacobian",
    "squared_range_jacobian",
    "beacons_at_bearings",
    "virtual_beacons",
    "fisher_information",
    "position_crlb",
    "cramer_rao_bound",
    "rmse_bound",
    "gdop",
    "precision_factor",
    "track_jacobian",
    "track_fisher_information",
    "track_crlb",
    "observability_rank",
    "numerical_rank",
    "two_range_fix",
    "mirror_point",
    "error_ellipse",
    "posterior_crlb",
    "model_posterior_crlb",
]
