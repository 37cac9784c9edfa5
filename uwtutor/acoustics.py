r"""Underwater acoustics for ranging: sound speed, travel time and range, and what a wrong sound speed costs.

A single-beacon navigator never measures a range directly. It measures a travel time :math:`\tau` and converts it
with a sound speed :math:`c` that it *assumes*, :math:`r = c\,\tau`. Every function here serves that conversion:

* ``sound_speed`` -- the speed of sound in sea water from temperature, salinity and depth (Mackenzie 1981);
* ``range_from_travel_time`` / ``travel_time_from_range`` -- the conversion itself, one-way or two-way;
* ``effective_sound_speed`` -- the single speed that turns the travel time along a path through a layered
  ocean into the path's length (the harmonic mean of :math:`c(z)` along the path);
* ``sound_speed_error_range_bias`` -- the range error made when the assumed speed is wrong; it grows in
  proportion to the range, which is why papers A and D model it as *multiplicative* noise.

References
----------
Mackenzie, K. V. (1981). Nine-term equation for sound speed in the oceans. J. Acoust. Soc. Am. 70(3), 807-812.

Zhu Z., Han S., Guo Z., Liu J. (2019). Single-beacon location under multiplicative noise (paper D).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .errors import UwtutorWarning, warn
from ._validate import (as_finite, as_flag, as_in_range, as_nonnegative, as_positive, as_range_array,
                        check_finite_result)

__all__ = [
    "MACKENZIE_VALIDITY",
    "sound_speed",
    "range_from_travel_time",
    "travel_time_from_range",
    "effective_sound_speed",
    "sound_speed_error_range_bias",
    "range_factor",
]

#: Published validity range of the Mackenzie (1981) equation, as ``(min, max)`` pairs of temperature
#: (degrees C), salinity (PSU) and depth (metres).
MACKENZIE_VALIDITY = {"temperature": (2.0, 30.0), "salinity": (25.0, 40.0), "depth": (0.0, 8000.0)}
#: Beyond these the polynomial is not an extrapolation of sea water any more (ice, steam, above the surface of a
#: deep trench, ten times the ocean's salinity): refused instead of warned about.
MACKENZIE_PHYSICAL = {"temperature": (-5.0, 100.0), "salinity": (0.0, 100.0), "depth": (-100.0, 12000.0)}


def _scalar_or_array(arr: np.ndarray) -> float | np.ndarray:
    """Return a Python float for a 0-d result, the array otherwise."""
    return float(arr) if arr.ndim == 0 else arr


def sound_speed(temperature: ArrayLike, salinity: ArrayLike, depth: ArrayLike) -> float | np.ndarray:
    r"""Speed of sound in sea water by the nine-term equation of Mackenzie (1981).

    .. math::

        c = {} & 1448.96 + 4.591\,T - 5.304\times10^{-2}\,T^2 + 2.374\times10^{-4}\,T^3 \\
            & + 1.340\,(S - 35) + 1.630\times10^{-2}\,D + 1.675\times10^{-7}\,D^2 \\
            & - 1.025\times10^{-2}\,T\,(S - 35) - 7.139\times10^{-13}\,T\,D^3

    with :math:`T` in degrees Celsius, :math:`S` in PSU (parts per thousand) and :math:`D` in metres.
    The published standard error is about 0.07 m/s.

    Parameters
    ----------
    temperature : float or array_like
        Water temperature :math:`T` [deg C].
    salinity : float or array_like
        Salinity :math:`S` [PSU].
    depth : float or array_like
        Depth :math:`D` [m], positive down.
        The three arguments broadcast against each other (e.g. a temperature profile against a depth grid).

    Returns
    -------
    float or ndarray
        Sound speed [m/s]; a float when all three inputs are scalars.

    Warns
    -----
    UserWarning
        When an input lies outside the range over which Mackenzie fitted the equation
        (T 2-30 deg C, S 25-40 PSU, D 0-8000 m). The value is still returned: it is an extrapolation.

    References
    ----------
    Mackenzie, K. V. (1981). Nine-term equation for sound speed in the oceans. J. Acoust. Soc. Am. 70(3), 807-812.

    Examples
    --------
    The check value published with the equation:

    >>> from uwtutor.acoustics import sound_speed
    >>> round(sound_speed(25.0, 35.0, 1000.0), 3)
    1550.744
    """
    T = as_finite("temperature", temperature)
    S = as_finite("salinity", salinity)
    D = as_finite("depth", depth)
    try:
        T, S, D = np.broadcast_arrays(T, S, D)
    except ValueError:
        raise ValueError("temperature, salinity and depth must broadcast against each other; "
                         f"got shapes {T.shape}, {S.shape} and {D.shape}") from None
    for name, arr in (("temperature", T), ("salinity", S), ("depth", D)):
        plo, phi = MACKENZIE_PHYSICAL[name]
        if arr.size and (arr.min() < plo or arr.max() > phi):
            raise ValueError(f"{name} must lie in [{plo:g}, {phi:g}] (sea water; the equation's own validity range "
                             f"is [{MACKENZIE_VALIDITY[name][0]:g}, {MACKENZIE_VALIDITY[name][1]:g}]); got values in "
                             f"[{arr.min():g}, {arr.max():g}]. Check the units (degrees C, PSU, metres)")
        lo, hi = MACKENZIE_VALIDITY[name]
        if arr.size and (arr.min() < lo or arr.max() > hi):
            warn(f"{name} outside the validity range of the Mackenzie (1981) equation "
                 f"[{lo:g}, {hi:g}]: got values in [{arr.min():g}, {arr.max():g}]; "
                          "the sound speed returned is an extrapolation", UwtutorWarning)
    s35 = S - 35.0
    c = (1448.96 + 4.591 * T - 5.304e-2 * T**2 + 2.374e-4 * T**3
         + 1.340 * s35 + 1.630e-2 * D + 1.675e-7 * D**2
         - 1.025e-2 * T * s35 - 7.139e-13 * T * D**3)
    return _scalar_or_array(np.asarray(c, dtype=float))


def range_from_travel_time(travel_time: ArrayLike, sound_speed: ArrayLike, two_way: bool = False) -> float | np.ndarray:
    r"""Convert an acoustic travel time into a range: :math:`r = c\,\tau` (one-way) or :math:`r = c\,\tau/2` (two-way).

    A two-way (round-trip, transponder) travel time covers the path twice, so the range is half of it.

    Parameters
    ----------
    travel_time : float or array_like
        Travel time :math:`\tau` [s], finite and >= 0.
    sound_speed : float or array_like
        Sound speed :math:`c` used for the conversion [m/s], > 0; broadcasts against ``travel_time``.
    two_way : bool, default False
        True for a round-trip travel time.

    Returns
    -------
    float or ndarray
        Range [m]; a float for scalar inputs. ``travel_time_from_range`` is the inverse.

    Examples
    --------
    >>> from uwtutor.acoustics import range_from_travel_time
    >>> range_from_travel_time(2.0, 1500.0)
    3000.0
    >>> range_from_travel_time(2.0, 1500.0, two_way=True)
    1500.0
    """
    two_way = as_flag("two_way", two_way)
    tau = as_nonnegative("travel_time", travel_time)
    c = as_positive("sound_speed", sound_speed)
    with np.errstate(over="ignore", invalid="ignore"):
        r = c * tau
    if two_way:
        r = r / 2.0
    check_finite_result(r, "travel_time", "sound_speed", what="the range")
    return _scalar_or_array(np.asarray(r, dtype=float))


def travel_time_from_range(slant_range: ArrayLike, sound_speed: ArrayLike, two_way: bool = False) -> float | np.ndarray:
    r"""Convert a range into an acoustic travel time: :math:`\tau = r/c` (one-way) or :math:`\tau = 2r/c` (two-way).

    Parameters
    ----------
    slant_range : float or array_like
        Straight-line (slant) range [m], finite and >= 0.
    sound_speed : float or array_like
        Sound speed :math:`c` [m/s], > 0; broadcasts against ``slant_range``.
    two_way : bool, default False
        True for the round-trip travel time.

    Returns
    -------
    float or ndarray
        Travel time [s]; a float for scalar inputs. ``range_from_travel_time`` is the inverse.

    Examples
    --------
    >>> from uwtutor.acoustics import travel_time_from_range
    >>> travel_time_from_range(1500.0, 1500.0)
    1.0
    >>> travel_time_from_range(1500.0, 1500.0, two_way=True)
    2.0
    """
    two_way = as_flag("two_way", two_way)
    r = as_range_array("slant_range", slant_range)
    c = as_positive("sound_speed", sound_speed)
    with np.errstate(over="ignore", invalid="ignore"):
        tau = r / c
        if two_way:
            tau = 2.0 * tau
    check_finite_result(tau, "slant_range", "sound_speed", what="the travel time")
    return _scalar_or_array(np.asarray(tau, dtype=float))


def _log_mean(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    r"""Logarithmic mean :math:`(b - a)/\ln(b/a)` of positive numbers, stable when ``b`` is close to ``a``.

    Written as :math:`a\,x/\mathrm{log1p}(x)` with :math:`x = (b - a)/a` (the difference first: it is exact for
    close speeds, where ``b / a - 1`` would lose digits); the ratio tends to ``a`` as ``x -> 0``.
    """
    x = (b - a) / a
    small = np.abs(x) < 1e-8
    x_safe = np.where(small, 1.0, x)  # keeps log1p(x)/x away from 0/0 where the series limit is used instead
    ratio = np.where(small, 1.0 - x / 2.0, np.log1p(x_safe) / x_safe)
    return a / ratio


def effective_sound_speed(profile_depths: ArrayLike, profile_speeds: ArrayLike, source_depth: ArrayLike,
                          receiver_depth: ArrayLike) -> float | np.ndarray:
    r"""Effective sound speed between two depths: the harmonic mean of the profile :math:`c(z)` over the path.

    A pulse travelling (nearly) vertically from depth :math:`z_1` to :math:`z_2` takes
    :math:`\tau = \int_{z_1}^{z_2} dz / c(z)`. The effective speed is the constant speed that gives the same
    travel time over the same distance,

    .. math::

        \bar c = \frac{|z_2 - z_1|}{\left|\int_{z_1}^{z_2} \frac{dz}{c(z)}\right|}.

    The profile is piecewise linear between the given points, so the integral is exact: on a layer where
    :math:`c` goes linearly from :math:`c_a` to :math:`c_b` over a thickness :math:`h` (gradient
    :math:`g = (c_b - c_a)/h`),

    .. math::

        \int \frac{dz}{c(z)} = \frac{1}{g}\ln\frac{c_b}{c_a} = \frac{h}{L(c_a, c_b)}, \qquad
        L(c_a, c_b) = \frac{c_b - c_a}{\ln(c_b / c_a)},

    :math:`L` being the logarithmic mean (which tends to :math:`c_a` as :math:`g \to 0`). For a single linear
    layer :math:`\bar c = \Delta z\, g / \ln(c_2/c_1)`. When the two depths are equal the result is :math:`c`
    at that depth. Using :math:`\bar c` instead of the surface speed is what removes most of the sound-speed
    range bias discussed by Zhu et al. (2019), paper D. (Ray bending for oblique paths is ignored.)

    Parameters
    ----------
    profile_depths : array_like, shape (N,)
        Depths of the profile points [m], strictly increasing.
    profile_speeds : array_like, shape (N,)
        Sound speed at those depths [m/s], > 0 (e.g. from ``sound_speed``).
    source_depth, receiver_depth : float or array_like
        End points of the path [m]; they broadcast against each other and must lie within the profile.

    Returns
    -------
    float or ndarray
        Effective (harmonic-mean) sound speed [m/s]; a float for scalar depths.

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.acoustics import effective_sound_speed
    >>> c = effective_sound_speed([0.0, 1000.0], [1500.0, 1520.0], 0.0, 1000.0)
    >>> bool(np.isclose(c, 20.0 / np.log(1520.0 / 1500.0)))
    True
    """
    z = as_finite("profile_depths", profile_depths, ndim=1)
    c = as_positive("profile_speeds", profile_speeds, ndim=1)
    if len(z) != len(c):
        raise ValueError(f"profile_speeds must have one speed per depth: profile_depths has {len(z)} points, "
                         f"profile_speeds has {len(c)}")
    if len(z) == 0:
        raise ValueError("profile_depths must hold at least one point")
    if np.any(np.diff(z) <= 0):
        raise ValueError("profile_depths must be strictly increasing")
    z1 = as_finite("source_depth", source_depth)
    z2 = as_finite("receiver_depth", receiver_depth)
    for name, arr in (("source_depth", z1), ("receiver_depth", z2)):
        if arr.size and (arr.min() < z[0] or arr.max() > z[-1]):
            raise ValueError(f"{name} must lie within the profile [{z[0]:g}, {z[-1]:g}] m; "
                             f"got values in [{arr.min():g}, {arr.max():g}]")
    try:
        z1, z2 = np.broadcast_arrays(z1, z2)
    except ValueError:
        raise ValueError("source_depth and receiver_depth must broadcast against each other; "
                         f"got shapes {z1.shape} and {z2.shape}") from None
    lo = np.minimum(z1, z2)[..., None]
    hi = np.maximum(z1, z2)[..., None]
    c_at_lo = np.interp(lo[..., 0], z, c)
    if len(z) == 1:
        return _scalar_or_array(np.asarray(c_at_lo, dtype=float))
    # Clip every layer to the path [lo, hi]; layers outside it get zero thickness and contribute nothing.
    a = np.clip(z[:-1], lo, hi)
    b = np.clip(z[1:], lo, hi)
    slowness_integral = np.sum((b - a) / _log_mean(np.interp(a, z, c), np.interp(b, z, c)), axis=-1)
    thickness = hi[..., 0] - lo[..., 0]
    same = thickness == 0
    c_eff = np.where(same, c_at_lo, thickness / np.where(same, 1.0, slowness_integral))
    return _scalar_or_array(np.asarray(c_eff, dtype=float))


def range_factor(assumed_speed: ArrayLike, true_speed: ArrayLike, speed_sigma: ArrayLike = 0.0) -> tuple[Any, Any]:
    r"""The multiplicative range factor of a sound-speed error, and its spread: the library's one formula.

    A travel time :math:`\tau = r / c` converted with the speed :math:`c_a` gives :math:`\gamma r` with
    :math:`\gamma = c_a / c`. When the true speed varies from ping to ping, :math:`c \sim N(c_e, \sigma_c^2)`,
    to first order in :math:`\sigma_c / c_e`

    .. math::

        \mu_\gamma = \frac{c_a}{c_e}, \qquad \sigma_\gamma = \frac{c_a}{c_e}\,\frac{\sigma_c}{c_e}.

    Parameters
    ----------
    assumed_speed : float or array_like
        The speed :math:`c_a` the navigator converts with [m/s], > 0.
    true_speed : float or array_like
        The (mean) true effective speed [m/s], > 0 (broadcasts with ``assumed_speed``).
    speed_sigma : float or array_like, default 0
        Standard deviation of the true speed from ping to ping [m/s], >= 0.

    Returns
    -------
    mu_gamma, sigma_gamma : float or ndarray
        :math:`\mu_\gamma` and :math:`\sigma_\gamma`.

    Examples
    --------
    >>> from uwtutor.acoustics import range_factor
    >>> mu, sigma = range_factor(1470.0, 1500.0, 1.0)
    >>> round(mu, 6), round(sigma * 1500.0, 6)
    (0.98, 0.98)
    """
    # a sound speed is a few km/s; 1e5 m/s bounds every medium and keeps ct^2 finite
    ca = as_in_range("assumed_speed", as_positive("assumed_speed", assumed_speed), 0.0, 1e5)
    ct = as_in_range("true_speed", as_positive("true_speed", true_speed), 0.0, 1e5)
    sc = as_in_range("speed_sigma", as_nonnegative("speed_sigma", speed_sigma), 0.0, 1e5)
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        mu = ca / ct
        sigma = ca * sc / ct**2
    check_finite_result(np.asarray(mu, dtype=float), "assumed_speed", "true_speed", what="the range factor")
    check_finite_result(np.asarray(sigma, dtype=float), "assumed_speed", "true_speed", "speed_sigma",
                        what="the range factor's spread")
    return _scalar_or_array(np.asarray(mu, dtype=float)), _scalar_or_array(np.asarray(sigma, dtype=float))


def sound_speed_error_range_bias(true_range: ArrayLike, assumed_speed: ArrayLike,
                                 true_speed: ArrayLike) -> float | np.ndarray:
    r"""Range error made by converting a travel time with the wrong sound speed.

    The travel time is :math:`\tau = r/c_{true}`; converting it with :math:`c_{assumed}` gives
    :math:`r_{meas} = c_{assumed}\,\tau`, so

    .. math::

        r_{meas} - r_{true} = r_{true}\left(\frac{c_{assumed}}{c_{true}} - 1\right)
        \approx \frac{\Delta c}{c}\, r_{true}.

    The error is proportional to the range: a multiplicative error (Liu et al., paper A; Zhu et al. (2019),
    paper D). With 1470 m/s assumed for a true 1500 m/s, every kilometre of range is measured 20 m short.

    Parameters
    ----------
    true_range : float or array_like
        True range [m], finite and >= 0.
    assumed_speed : float or array_like
        Sound speed the navigator uses [m/s], > 0.
    true_speed : float or array_like
        Actual (effective) sound speed along the path [m/s], > 0. All three broadcast.

    Returns
    -------
    float or ndarray
        :math:`r_{meas} - r_{true}` [m]; negative when the assumed speed is too low.

    Examples
    --------
    >>> from uwtutor.acoustics import sound_speed_error_range_bias
    >>> round(sound_speed_error_range_bias(1000.0, 1470.0, 1500.0), 6)
    -20.0
    """
    r = as_range_array("true_range", true_range)
    gamma, _ = range_factor(assumed_speed, true_speed)
    return _scalar_or_array(np.asarray(r * (gamma - 1.0), dtype=float))
