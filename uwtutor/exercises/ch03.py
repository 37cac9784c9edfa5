"""Checkers for the exercises of chapter 3, "Least squares before filtering".

Each checker computes the expected value from the exercise's data (the constants below) with ``uwtutor.lsq`` and
returns a ``Feedback`` that recognises the usual mistakes of that exercise:

============================================  ==========================================================================
checker                                       exercise
============================================  ==========================================================================
``check_precision_factor(alpha)``             paper A's precision factor of four ranges over a quarter turn, by hand
``check_ranges_until_trusted(n)``             the number of ranges on paper A's circle until alpha < 2
``check_vmlbl_system(vmlbl_system)``          paper E's pairwise-differenced sphere equations, as a function
``check_travel_time_cost(travel_time_cost)``  paper D's travel-time cost of one grid cell, as a function
============================================  ==========================================================================

The exercises themselves are in the repository's ``exercises/ch03_least_squares.ipynb``.

References
----------
Liu et al., paper A (precision factor, eq. 11); Zhu et al. (2019), paper D (eq. 6); paper E (eq. 16).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .. import lsq, motion
from .checks import Case, _answer_shape, check_array, check_function, check_number
from .feedback import Feedback

__all__ = [
    "check_precision_factor",
    "check_ranges_until_trusted",
    "check_vmlbl_system",
    "check_travel_time_cost",
    "QUARTER_TURN_BEARINGS_DEG",
    "CIRCLE_RADIUS",
    "CIRCLE_SPEED",
    "RANGE_INTERVAL",
    "ALPHA_THRESHOLD",
    "vmlbl_system_reference",
    "travel_time_cost_reference",
]

# -- the data of the exercises -----------------------------------------------------------------------------------------
#: Exercise 3.1: bearings (degrees, from the beacon, counter-clockwise from east) of the four ranging points.
QUARTER_TURN_BEARINGS_DEG = (0.0, 30.0, 60.0, 90.0)
#: Exercise 3.2: paper A's circle: radius (m) around the beacon ...
CIRCLE_RADIUS = 1500.0
#: ... speed along it (m/s) ...
CIRCLE_SPEED = 2.0
#: ... time between two ranges (s) ...
RANGE_INTERVAL = 5.0
#: ... and paper A's acceptance threshold on the precision factor.
ALPHA_THRESHOLD = 2.0


# -- exercise 3.1: the precision factor by hand ------------------------------------------------------------------------
def _design(bearings_deg: Any, bias: bool = True, radians: bool = True) -> np.ndarray:
    phi = np.radians(bearings_deg) if radians else np.asarray(bearings_deg, dtype=float)
    cols = [np.cos(phi), np.sin(phi)] + ([np.ones_like(phi)] if bias else [])
    return np.column_stack(cols)


def check_precision_factor(answer: Any) -> Feedback:
    r"""Check paper A's precision factor :math:`\alpha = \operatorname{tr}(A^\mathsf{T}A)^{-1}` of exercise 3.1.

    Four ranges from bearings 0, 30, 60 and 90 degrees; rows :math:`[\cos\phi_i, \sin\phi_i, 1]` (line of sight and
    bias).

    Parameters
    ----------
    answer : float or None
        The student's :math:`\alpha`.

    Returns
    -------
    Feedback
        The verdict; the trace of :math:`A^\mathsf{T}A` itself, the inverse of that trace, the GDOP
        :math:`\sqrt\alpha`, the position-only :math:`\alpha` (no bias column), only the position block of the
        inverse, and degrees passed as radians are recognised.

    Examples
    --------
    >>> from uwtutor import lsq
    >>> phi = np.radians(QUARTER_TURN_BEARINGS_DEG)
    >>> A = np.column_stack((np.cos(phi), np.sin(phi), np.ones_like(phi)))
    >>> # the trace of AᵀA, not of its inverse
    >>> check_precision_factor(np.trace(A.T @ A)).correct
    False
    >>> check_precision_factor(lsq.precision_factor(A)).correct
    True
    """
    A = _design(QUARTER_TURN_BEARINGS_DEG)
    expected = float(lsq.precision_factor(A))
    normal = A.T @ A
    inv = np.linalg.inv(normal)
    no_bias = _design(QUARTER_TURN_BEARINGS_DEG, bias=False)
    mistakes = {
        float(np.trace(normal)): "That is the trace of AᵀA itself; α is the trace of its *inverse*, "
                                 "np.trace(np.linalg.inv(A.T @ A)) (equivalently the sum of 1/λ over its "
                                 "eigenvalues).",
        1.0 / float(np.trace(normal)): "1/trace(AᵀA) is not trace((AᵀA)⁻¹): invert the matrix first, then take "
                                       "the trace (or sum 1/λᵢ over the eigenvalues).",
        float(np.sqrt(expected)): "That is √α (the GDOP of the three unknowns); α itself is the trace, not its "
                                  "square root.",
        float(lsq.precision_factor(no_bias)): "The design matrix has three columns: the line of sight "
                                              "(cos φ, sin φ) *and* a column of ones for the bias.",
        float(inv[0, 0] + inv[1, 1]): "That is the position block only; paper A's α sums all three diagonal "
                                      "elements, the bias included.",
        float(lsq.precision_factor(_design(QUARTER_TURN_BEARINGS_DEG, radians=False))):
            "NumPy's cos and sin take radians: convert the bearings with np.radians first.",
    }
    # rtol 1e-3: α rounded to three significant digits (26.5) passes; every recognised slip is far off
    return check_number(answer, expected, rtol=1e-3, name="the precision factor α", common_mistakes=mistakes,
                        hint="Build A with rows [cos φ, sin φ, 1] (φ in radians), then α = trace(inv(AᵀA)).",
                        explanation="Above 2, so paper A would not trust this fix yet: a quarter turn in four "
                                    "ranges leaves the bias and the range direction hard to tell apart.")


# -- exercise 3.2: ranges until the fix can be trusted -----------------------------------------------------------------
def _circle_alpha(n: int, bias: bool = True) -> np.ndarray:
    times = RANGE_INTERVAL * np.arange(n)
    track = motion.circle_track(times, CIRCLE_RADIUS, CIRCLE_SPEED, start_angle=-np.pi / 2)
    return lsq.precision_factor_history(track.positions, unknown_bias=bias)


def _first_count_below(alpha: np.ndarray, threshold: float) -> int:
    below = np.flatnonzero(alpha < threshold)
    if below.size == 0:
        raise RuntimeError("the exercise's track never reaches the threshold: lengthen it")
    return int(below[0]) + 1


def check_ranges_until_trusted(answer: Any) -> Feedback:
    r"""Check the number of ranges on paper A's circle after which :math:`\alpha < 2` for the first time.

    The circle: radius 1500 m around the beacon, 2 m/s counter-clockwise from due south, a range every 5 s (the
    first at the start); :math:`\alpha` from the rows of all ranges so far, linearized at the true positions.

    Parameters
    ----------
    answer : int or None
        The student's number of ranges (a count, the first range counting as 1).

    Returns
    -------
    Feedback
        The verdict; the 0-based index, the count for :math:`\alpha < 1`, the elapsed time in seconds and the
        count without the bias column are recognised.

    Examples
    --------
    >>> from uwtutor import lsq, motion
    >>> times = RANGE_INTERVAL * np.arange(600)
    >>> track = motion.circle_track(times, CIRCLE_RADIUS, CIRCLE_SPEED,
    ...                             start_angle=-np.pi / 2)
    >>> alpha = lsq.precision_factor_history(track.positions, unknown_bias=True)
    >>> first = int(np.flatnonzero(alpha < ALPHA_THRESHOLD)[0])  # a 0-based index
    >>> check_ranges_until_trusted(first).correct
    False
    >>> # the first range counts as 1
    >>> check_ranges_until_trusted(first + 1).correct
    True
    """
    alpha = _circle_alpha(600)
    expected = _first_count_below(alpha, ALPHA_THRESHOLD)
    at_one = _first_count_below(alpha, 1.0)
    no_bias = _first_count_below(_circle_alpha(600, bias=False), ALPHA_THRESHOLD)
    mistakes = {
        float(expected - 1): "Off by one: that is the 0-based index of the range; the task asks for the number of "
                             "ranges (the index plus 1).",
        float(at_one): "That is where α falls below 1; paper A's threshold for trusting the fix is α < 2.",
        float(RANGE_INTERVAL * (expected - 1)): "That is the elapsed time in seconds; the task asks for the number "
                                                "of ranges.",
        float(RANGE_INTERVAL * expected): "That is a time in seconds; the task asks for the number of ranges.",
        float(no_bias): "Without the bias column α falls much sooner: paper A's regressors include a column of ones "
                        "for the range bias.",
    }
    turn_rate = np.degrees(CIRCLE_SPEED / CIRCLE_RADIUS * RANGE_INTERVAL)       # degrees of bearing per range
    bearing, bearing_one = turn_rate * (expected - 1), turn_rate * (at_one - 1)
    return check_number(answer, expected, rtol=0.0, atol=0.5, name="the number of ranges",
                        common_mistakes=mistakes,
                        hint="Compute α after each range (e.g. lsq.precision_factor_history) and find the first "
                             "index where it is below 2; then add 1 to turn the index into a count.",
                        explanation=f"By then the bearing to the buoy has turned by {bearing:.0f}°; α reaches 1 "
                                    f"after {at_one} ranges ({bearing_one:.0f}°), paper A's 'about 200 "
                                    "observations, about 90 degrees' (Fig. 2).")


# -- exercise 3.3: paper E's linear system -----------------------------------------------------------------------------
def vmlbl_system_reference(ranges: ArrayLike, virtual_beacons: ArrayLike, depth: float,
                           beacon_depths: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    r"""The reference answer of exercise 3.3: paper E's pairwise-differenced system :math:`A X = B`.

    Rows :math:`i = 1..N` pair epoch :math:`i` with :math:`j = i + 1` (cyclically, the last with the first):
    :math:`A_i = [x_j - x_i, y_j - y_i]`,
    :math:`B_i = (r_i^2 - r_j^2 + d_j^2 - d_i^2)/2 - z (z^\mathrm{a}_j - z^\mathrm{a}_i)`,
    :math:`d_i^2 = x_i^2 + y_i^2 + (z^\mathrm{a}_i)^2`, with the vehicle at depth :math:`z` and the ship's transducer
    at depth :math:`z^\mathrm{a}_i` (the book's notation).

    Parameters
    ----------
    ranges : array_like, shape (N,)
        Ranges to the virtual beacons [m].
    virtual_beacons : array_like, shape (N, 2)
        Horizontal positions of the virtual beacons [m].
    depth : float
        Vehicle depth z [m].
    beacon_depths : array_like, shape (N,)
        Depths of the ship's transducer at the virtual beacons, z^a_i [m].

    Returns
    -------
    tuple of ndarray
        ``A`` of shape (N, 2) and ``B`` of shape (N,).

    Examples
    --------
    >>> vb = np.array([[0.0, 0.0], [400.0, 0.0], [400.0, 300.0]])
    >>> ranges = np.sqrt(np.sum((vb - [-500.0, 200.0]) ** 2, axis=1) + 100.0 ** 2)
    >>> A, B = vmlbl_system_reference(ranges, vb, 100.0, np.zeros(3))
    >>> A.shape, B.shape
    ((3, 2), (3,))
    >>> # the vehicle's horizontal position
    >>> np.round(np.linalg.lstsq(A, B, rcond=None)[0], 3)
    array([-500.,  200.])
    """
    r = np.asarray(ranges, dtype=float)
    vb = np.asarray(virtual_beacons, dtype=float)
    z = np.asarray(beacon_depths, dtype=float)
    j = np.roll(np.arange(len(r)), -1)
    d2 = np.sum(vb**2, axis=1) + z**2
    return vb[j] - vb, 0.5 * (r**2 - r[j] ** 2 + d2[j] - d2) - depth * (z[j] - z)


def _vmlbl_cases() -> list[Case]:
    rng = np.random.default_rng(2013)
    vb = np.array([[0.0, 0.0], [420.0, 60.0], [760.0, 330.0], [900.0, 780.0]])
    sub = np.array([-700.0, -950.0])
    surface = np.zeros(4)
    r_surface = np.sqrt(np.sum((sub - vb) ** 2, axis=1) + 1000.0**2)
    z_var = np.array([0.0, 5.0, 12.0, 3.0])
    r_var = np.sqrt(np.sum((sub - vb) ** 2, axis=1) + (1000.0 - z_var) ** 2) + rng.normal(0.0, 1.0, 4)
    vb5 = np.vstack([vb, [[700.0, 1100.0]]])
    r5 = np.sqrt(np.sum((sub - vb5) ** 2, axis=1) + 500.0**2)
    vb3 = vb[:3]
    return [
        Case((r_surface, vb, 1000.0, surface), label="a surface ship, four epochs (paper E)"),
        Case((r_var, vb, 1000.0, z_var), label="beacons at different depths",
             hint="With beacons at different depths the term −h (z_{i+1} − z_i) no longer vanishes, and d_i² "
                  "includes z_i²."),
        Case((r5, vb5, 500.0, np.zeros(5)), label="five epochs",
             hint="Write it for any number N of epochs: use the length of `ranges`, not a fixed 4."),
        Case((r_surface[:3], vb3, 1000.0, surface[:3]), label="three epochs",
             hint="Write it for any number N of epochs: use the length of `ranges`, not a fixed 4."),
    ]


def _compare_system(got: Any, expected: tuple[np.ndarray, np.ndarray]) -> Feedback:
    if not isinstance(got, (tuple, list)) or len(got) != 2:
        return Feedback(False, "Not yet: the function should return two things, `A, B`.",
                        hint="End it with `return A, B`.")
    A, B = got
    A_exp, B_exp = expected
    if _answer_shape(A) == (A_exp.shape[0] - 1, 2) or _answer_shape(B) == (B_exp.shape[0] - 1,):
        return Feedback(False, f"Not yet: one equation short ({A_exp.shape[0] - 1} rows instead of "
                               f"{A_exp.shape[0]}).",
                        hint="Paper E closes the cycle: the last row pairs the last epoch with the first "
                             "(`j = np.roll(np.arange(N), -1)`).")
    fb = check_array(A, A_exp, rtol=1e-9, atol=1e-9, name="A", units="m",
                     common_mistakes=[(-A_exp, "A's rows are x_{i+1} − x_i (the next epoch minus this one).")])
    if not fb:
        return fb
    return check_array(B, B_exp, rtol=1e-9, atol=1e-6, name="B", units="m²",
                       common_mistakes=[(-B_exp, "B_i = (r_i² − r_{i+1}² + d_{i+1}² − d_i²)/2 − h (z_{i+1} − z_i): "
                                                 "this epoch's squared range minus the next one's."),
                                        (2 * B_exp, "Divide the bracket by 2: differencing the spheres leaves "
                                                    "2 (x_{i+1} − x_i) x + ... on the left.")])


def check_vmlbl_system(func: Any) -> Feedback:
    r"""Check a student's ``vmlbl_system(ranges, virtual_beacons, depth, beacon_depths)`` returning ``A, B``.

    The specification (also in the notebook) is paper E's eq. (16) for N epochs; see ``vmlbl_system_reference``.

    Parameters
    ----------
    func : callable or None
        The student's function.

    Returns
    -------
    Feedback
        The verdict; a missing cyclic row, reversed differences, a flipped sign of B and a missing factor 1/2 are
        recognised.

    Examples
    --------
    >>> # one equation short
    >>> def no_cycle(ranges, virtual_beacons, depth, beacon_depths):
    ...     A, B = vmlbl_system_reference(ranges, virtual_beacons, depth,
    ...                                   beacon_depths)
    ...     return A[:-1], B[:-1]
    >>> check_vmlbl_system(no_cycle).correct
    False
    >>> check_vmlbl_system(vmlbl_system_reference).correct
    True
    """
    return check_function(func, vmlbl_system_reference, _vmlbl_cases(), name="vmlbl_system",
                          compare=_compare_system,
                          hint="Expand (x − x_i)² + (y − y_i)² + (h − z_i)² = r_i² and subtract the equation of "
                               "epoch i + 1 from that of epoch i: x² + y² + h² cancels.",
                          explanation="Solving A X = B by least squares (np.linalg.lstsq) gives paper E's fix; "
                                      "lsq.virtual_beacon_lsq does the same and reports its conditioning.")


# -- exercise 3.4: paper D's cost of one cell --------------------------------------------------------------------------
def travel_time_cost_reference(travel_times: ArrayLike, dr_offsets: ArrayLike, bearing: float, speed_error: float,
                               assumed_speed: float) -> float:
    r"""The reference answer of exercise 3.4: paper D's cost :math:`L(\theta, \Delta c)` of one grid cell.

    Computed with ``uwtutor.lsq.prelocation_cost`` on a one-cell grid: start
    :math:`p_0 = c_\mathrm{e}\tau_0[\cos\theta, \sin\theta]` with :math:`c_\mathrm{e} = c - \Delta c`, then
    :math:`p_k = p_0 + D_k`, :math:`L = \sum_k (\lVert p_k\rVert / c_\mathrm{e} - \tau_k)^2` (beacon at the origin).

    Parameters
    ----------
    travel_times : array_like, shape (K,)
        One-way travel times [s].
    dr_offsets : array_like, shape (K, 2)
        DR offsets :math:`D_k` from epoch 0 (the first row is zero) [m].
    bearing : float
        Start bearing :math:`\theta` [rad].
    speed_error : float
        :math:`\Delta c = c - c_\mathrm{e}` [m/s].
    assumed_speed : float
        :math:`c` [m/s].

    Returns
    -------
    float
        :math:`L` [s²].

    Examples
    --------
    >>> positions = np.array([[1000.0, 0.0], [1000.0, 100.0], [1000.0, 200.0]])
    >>> tau = np.hypot(*positions.T) / 1500.0
    >>> offsets = positions - positions[0]
    >>> cost = travel_time_cost_reference(tau, offsets, 0.0, 0.0, 1500.0)
    >>> bool(cost < 1e-20)  # the true cell fits exactly
    True
    >>> # three degrees off in bearing (0.1 rad)
    >>> bool(travel_time_cost_reference(tau, offsets, 0.1, 0.0, 1500.0) > 0)
    True
    """
    D = np.asarray(dr_offsets, dtype=float)
    displacements = np.diff(D, axis=0, prepend=np.zeros((1, 2)))
    cost = lsq.prelocation_cost(np.asarray(travel_times, dtype=float), displacements, [bearing], [speed_error],
                                assumed_speed=assumed_speed)
    return float(cost[0, 0])


def _cost_cases() -> list[Case]:
    times = 10.0 * np.arange(12)
    track = motion.turning_track(times, start=(-2500.0, -1200.0), speed=2.0,
                                 headings=np.radians([15.0, 60.0]), turn_times=[60.0])
    D = track.positions - track.positions[0]
    tau = np.hypot(*track.positions.T) / 1500.0
    rng = np.random.default_rng(5)
    tau_noisy = tau + rng.normal(0.0, 5e-4, tau.shape)
    theta = float(np.arctan2(track.positions[0, 1], track.positions[0, 0]))
    sign_hint = ("The book writes c = c_e + Δc (assumed = effective + error), so the effective speed is "
                 "c_e = c − Δc: with c = 1470 and Δc = −30, c_e = 1500 m/s.")
    return [
        Case((tau_noisy, D, theta, -30.0, 1470.0), label="the true cell",
             hint="At the true start bearing and sound speed the predicted travel times differ from the measured "
                  "ones by the noise only. " + sign_hint),
        Case((tau, D, theta, -30.0, 1470.0), label="the true cell, exact travel times",
             hint="With exact travel times the true cell fits perfectly: L should be (almost) 0."),
        Case((tau_noisy, D, theta + 0.05, -30.0, 1470.0), label="3 degrees off in bearing",
             hint="The start is p_0 = c_e τ_0 [cos θ, sin θ] and p_k = p_0 + D_k; the predicted travel time is "
                  "‖p_k‖ / c_e."),
        Case((tau_noisy, D, theta, 0.0, 1470.0), label="no speed error assumed",
             hint="Compare travel times (seconds), not ranges: L = Σ (‖p_k‖ / c_e − τ_k)²."),
        Case((tau_noisy, D, theta - 0.1, -60.0, 1470.0), label="wrong bearing and speed", hint=sign_hint),
    ]


def _cost_slip(*, assumed_divisor: bool = False, flipped_error: bool = False, root: bool = False,
               ranges: bool = False, assumed_start: bool = False) -> Any:
    """A ``travel_time_cost`` written with one typical slip, for ``check_function``'s ``mistakes``."""

    def cost(travel_times: Any, dr_offsets: Any, bearing: float, speed_error: float, assumed_speed: float) -> float:
        tau, D = np.asarray(travel_times, dtype=float), np.asarray(dr_offsets, dtype=float)
        c_e = assumed_speed + speed_error if flipped_error else assumed_speed - speed_error
        p0 = (assumed_speed if assumed_start else c_e) * tau[0] * np.array([np.cos(bearing), np.sin(bearing)])
        dist = np.linalg.norm(p0 + D, axis=1)
        if ranges:
            misfit = dist - c_e * tau
        else:
            misfit = dist / (assumed_speed if assumed_divisor else c_e) - tau
        total = float(np.sum(misfit**2))
        return float(np.sqrt(total)) if root else total

    return cost


#: Exercise 3.4's typical slips, each with the hint that names it (``check_function`` recognises them).
_COST_SLIPS = (
    (_cost_slip(assumed_divisor=True),
     "The predicted travel time divides by the effective speed c_e = c − Δc, not by the assumed c: the cell's Δc "
     "is the very thing being tested, so it must enter the prediction."),
    (_cost_slip(assumed_divisor=True, assumed_start=True),
     "Both the start p_0 = c_e τ_0 [cos θ, sin θ] and the prediction ‖p_k‖ / c_e use the effective speed "
     "c_e = c − Δc; yours uses the assumed c, so every Δc gives the same cost."),
    (_cost_slip(flipped_error=True),
     "The book writes c = c_e + Δc (assumed = effective + error), so the effective speed is c_e = c − Δc: with "
     "c = 1470 and Δc = −30, c_e = 1500 m/s."),
    (_cost_slip(root=True),
     "That is √L, the root of the sum: paper D's cost is the sum of the squared travel-time differences itself."),
    (_cost_slip(ranges=True),
     "Compare travel times (seconds), not ranges: L = Σ (‖p_k‖ / c_e − τ_k)²."),
)


def check_travel_time_cost(func: Any) -> Feedback:
    r"""Check a student's ``travel_time_cost(travel_times, dr_offsets, bearing, speed_error, assumed_speed)``.

    The specification (also in the notebook) is paper D's eq. (6) for one cell; see
    ``travel_time_cost_reference``.

    Parameters
    ----------
    func : callable or None
        The student's function.

    Returns
    -------
    Feedback
        The verdict, with the failing case and a hint.

    Examples
    --------
    >>> def zero_cost(travel_times, dr_offsets, bearing, speed_error,
    ...               assumed_speed):
    ...     return 0.0
    >>> check_travel_time_cost(zero_cost).correct
    False
    >>> check_travel_time_cost(travel_time_cost_reference).correct
    True
    """
    return check_function(func, travel_time_cost_reference, _cost_cases(), name="travel_time_cost",
                          rtol=1e-6, atol=1e-12, mistakes=_COST_SLIPS,
                          hint="Start on the ring of the first travel time, p_0 = c_e τ_0 [cos θ, sin θ] with "
                               "c_e = c − Δc; move by the DR offsets; sum the squared travel-time differences.",
                          explanation="lsq.grid_prelocation evaluates exactly this for every cell of the grid at "
                                      "once, and for every epoch.")
