r"""Least squares before filtering: a first fix, and an honest measure of how good it is.

A filter needs a starting point. The three methods of this module find one from a batch of ranges and
dead-reckoned (DR) displacements, and each says how far it can be trusted:

=================================  ==================================================================================
``linearized_lsq``                 Gauss-Newton steps of range least squares about a provisional position, with an
                                   optional constant range bias; reports paper A's precision factor
``prepositioning``                 paper A's pre-positioning: the same on a DR track (virtual beacons), fix *now*
``nonlinear_lsq``                  the reference: ``scipy.optimize.least_squares`` on the exact range model
``precision_factor``               :math:`\alpha = \operatorname{tr}(A^\mathsf{T}A)^{-1} = \sum_i 1/\lambda_i`
``condition_number``               :math:`\kappa(A) = s_\mathrm{max}/s_\mathrm{min}` (singular values of A)
``precision_factor_history``       :math:`\alpha` after each epoch along a track (paper A, Fig. 2)
``prelocation_cost``               paper D's travel-time cost over a grid of start bearing and sound-speed error
``grid_prelocation``               paper D's grid-search pre-location, at every epoch, batched over runs
``prelocation_acceptance``         paper D's two acceptance conditions (a heading change; K stable fixes)
``virtual_beacon_lsq``             paper E's virtual-beacon (VMLBL) fix from pairwise-differenced spheres
=================================  ==================================================================================

**Linearized range least squares** (Liu et al., paper A). A range to beacon :math:`b^\mathrm{v}_i` (a real
beacon, or a *virtual* one: the beacon moved by the vehicle's DR displacement since epoch :math:`i`) with a constant
bias :math:`\upsilon` is :math:`r_i = \lVert p - b^\mathrm{v}_i \rVert + \upsilon + \eta_i`, :math:`i = 1..K`. About
a provisional position :math:`p_0`, with the predicted range :math:`\hat r_i = \lVert p_0 - b^\mathrm{v}_i \rVert`
(paper A: :math:`\rho_k`) and the unit line of sight :math:`h_i = (p_0 - b^\mathrm{v}_i)^\mathsf{T}/\hat r_i`,

.. math::

    r_i - \hat r_i \approx h_i\,\delta p + \upsilon + \eta_i, \qquad
    y = A\zeta + \eta, \quad A = \begin{bmatrix} h_1 & 1 \\ \vdots & \vdots \\ h_K & 1 \end{bmatrix},
    \quad \zeta = \begin{bmatrix} \delta p \\ \upsilon \end{bmatrix},

so :math:`\hat\zeta = (A^\mathsf{T}A)^{-1}A^\mathsf{T}y` (paper A: :math:`\hat\beta`), :math:`\hat p = p_0 +
\delta\hat p`, and for white noise of variance :math:`\sigma_r^2` :math:`\operatorname{Cov}\hat\zeta = \sigma_r^2
(A^\mathsf{T}A)^{-1}`: the mean squared error of the three unknowns is :math:`\alpha\sigma_r^2`, with the
**precision factor**
:math:`\alpha = \operatorname{tr}(A^\mathsf{T}A)^{-1} = \sum_i 1/\lambda_i(A^\mathsf{T}A)` (paper A, eqs. 10-11).
Paper A trusts the fix, and starts its filter, once :math:`\alpha < 2`. The same covariance is the Cramér-Rao bound of
position and bias (chapter 2), so :math:`\alpha\sigma^2` is the trace of that bound.

**Ill-conditioned problems warn, never fail silently.** Every fix carries its precision factor, the condition
number :math:`\kappa(A)` and a *noise gain* (RMS error of the unknowns per unit range noise). A problem whose
:math:`\kappa` exceeds ``max_condition`` or whose noise gain exceeds ``max_noise_gain`` gives its fix with an
:class:`IllConditionedWarning`; a singular one (:math:`\kappa > 10^7`: too few epochs, no change of bearing,
collinear virtual beacons) gives NaN with the warning.

References
----------
Liu J., Han S., Xu J., Yang G. "An improved EKF positioning algorithm for underwater acoustic beacon" (paper A),
sec. 1.2, eqs. (3)-(11).
Zhu Z., Han S., Guo Z., Liu J. (2019). "Single beacon location algorithm based on nonlinear fading filter under
multiplicative noise background". J. Electronics & Information Technology 41(1), 165-171 (paper D), sec. 3.1, eq.
(6)-(7).
Paper E (VMLBL for the manned submersible *Jiaolong*), sec. 1.2, eqs. (14)-(17).
Björck, Å. (1996). *Numerical Methods for Least Squares Problems*. SIAM (conditioning of least squares).
"""

from ..errors import IllConditionedWarning
from ._common import SINGULAR_RTOL
from .conditioning import condition_number, precision_factor, precision_factor_history
from .prelocation import (Prelocation, PrelocationAcceptance, grid_prelocation, prelocation_acceptance,
                          prelocation_cost)
from .prepositioning import LSQFix, linearized_lsq, nonlinear_lsq, prepositioning
from .virtual_baseline import VirtualBeaconFix, virtual_beacon_lsq

__all__ = [
    "IllConditionedWarning",
    "SINGULAR_RTOL",
    "precision_factor",
    "condition_number",
    "precision_factor_history",
    "LSQFix",
    "linearized_lsq",
    "prepositioning",
    "nonlinear_lsq",
    "Prelocation",
    "prelocation_cost",
    "grid_prelocation",
    "PrelocationAcceptance",
    "prelocation_acceptance",
    "VirtualBeaconFix",
    "virtual_beacon_lsq",
]

# Documented (and referred to) as uwtutor.lsq.NAME, wherever each is written.
for _obj in (condition_number, precision_factor, precision_factor_history, Prelocation, PrelocationAcceptance,
             grid_prelocation, prelocation_acceptance, prelocation_cost, LSQFix, linearized_lsq, nonlinear_lsq,
             prepositioning, VirtualBeaconFix, virtual_beacon_lsq):
    _obj.__module__ = __name__
del _obj
