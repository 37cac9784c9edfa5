"""GM(1,1) grey prediction (uwtutor.grey): worked examples, closed-form checks, the vectorized forms, bad input.

About the worked example. The series 2.874, 3.278, 3.337, 3.390, 3.679 is the classic worked example of the
grey-systems textbooks (e.g. Liu and Lin, *Grey Systems: Theory and Applications*, 2010, the GM(1,1) chapter).
We could not check the published values of ``a`` and ``b`` against the book itself, so the tests do not assert
them; they check the fit on that series against two independent computations (paper C's explicit formulas of eq.
(10) and ``numpy.linalg.lstsq``) and against a case whose answer is known in closed form: for an exactly geometric
series ``x0(k) = c q^(k-1)`` the discrete grey equation holds exactly with ``a = 2(1-q)/(1+q)`` and
``b = 2c/(1+q)`` (derived in ``test_geometric_series_has_a_closed_form_fit``).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from uwtutor import grey

CLASSIC = np.array([2.874, 3.278, 3.337, 3.390, 3.679])


def paper_c_formulas(x0, alpha=0.5):
    """a and b by paper C's eq. (10), written with its sums over k = 2..n."""
    x1 = np.cumsum(x0)
    Z = alpha * x1[1:] + (1 - alpha) * x1[:-1]
    Y = x0[1:]
    m = len(Y)                                   # n - 1
    den = m * np.sum(Z**2) - np.sum(Z) ** 2
    a = (np.sum(Z) * np.sum(Y) - m * np.sum(Z * Y)) / den
    b = (np.sum(Z**2) * np.sum(Y) - np.sum(Z) * np.sum(Z * Y)) / den
    return a, b


def test_classic_example_matches_two_independent_computations():
    m = grey.fit_gm11(CLASSIC)
    a_p, b_p = paper_c_formulas(CLASSIC)
    x1 = np.cumsum(CLASSIC)
    B = np.column_stack([-0.5 * (x1[1:] + x1[:-1]), np.ones(4)])
    a_l, b_l = np.linalg.lstsq(B, CLASSIC[1:], rcond=None)[0]
    assert m.a == pytest.approx(a_p, rel=1e-12) and m.b == pytest.approx(b_p, rel=1e-12)
    assert m.a == pytest.approx(a_l, rel=1e-12) and m.b == pytest.approx(b_l, rel=1e-12)
    # the values printed in the chapter (and in the docstring example)
    assert m.a == pytest.approx(-0.037204, abs=1e-6)
    assert m.b == pytest.approx(3.065363, abs=1e-6)
    np.testing.assert_allclose(m.fitted, [2.874, 3.2320, 3.3545, 3.4817, 3.6137], atol=1e-4)
    assert m.level_ratio.passed
    assert m.posterior_variance_ratio < 0.35            # a "good" grade


def test_restored_series_is_the_difference_of_the_time_response():
    m = grey.fit_gm11(CLASSIC)
    x1_hat = m.time_response(np.arange(0.0, 8.0))
    np.testing.assert_allclose(m.fitted[1:], np.diff(x1_hat)[:4], rtol=1e-12)
    np.testing.assert_allclose(m.forecast(3), np.diff(x1_hat)[4:7], rtol=1e-12)
    # the time response in paper C's eq. (11) form
    k = np.arange(0.0, 8.0)
    np.testing.assert_allclose(x1_hat, (CLASSIC[0] - m.b / m.a) * np.exp(-m.a * k) + m.b / m.a, rtol=1e-12)
    # and the restored values in the corrected eq. (12) form, (1 - e^a)
    k = np.arange(1.0, 7.0)
    restored = (1 - np.exp(m.a)) * (CLASSIC[0] - m.b / m.a) * np.exp(-m.a * k)
    np.testing.assert_allclose(np.concatenate([m.fitted[1:], m.forecast(2)]), restored, rtol=1e-12)


def test_paper_c_printed_factor_gives_minus_the_next_forecast():
    m = grey.fit_gm11(CLASSIC)
    n = CLASSIC.size
    printed = (1 - np.exp(-m.a)) * (CLASSIC[0] - m.b / m.a) * np.exp(-m.a * n)
    # (1 - e^-a) = -e^-a (1 - e^a): the misprint forecasts minus the value one step further
    assert printed == pytest.approx(-m.forecast(2)[1], rel=1e-12)


def test_time_response_solves_the_whitening_equation():
    m = grey.fit_gm11(CLASSIC)
    sol = solve_ivp(lambda t, y: m.b - m.a * y, (0.0, 6.0), [CLASSIC[0]], t_eval=np.arange(7.0), rtol=1e-11,
                    atol=1e-12)
    np.testing.assert_allclose(m.time_response(np.arange(7.0)), sol.y[0], rtol=1e-8)


@pytest.mark.parametrize("c, q", [(2.0, 1.1), (5.0, 0.9), (0.3, 1.02)])
def test_geometric_series_has_a_closed_form_fit(c, q):
    # x0(k) = c q^(k-1): x1(k) = c (1 - q^k)/(1 - q), z1(k) = c/(1-q) - c q^(k-1) (1+q) / (2(1-q)).
    # x0(k) = -a z1(k) + b for every k requires a (1+q) / (2(1-q)) = 1 and b = a c / (1-q).
    x0 = c * q ** np.arange(8)
    m = grey.fit_gm11(x0)
    a_exact = 2 * (1 - q) / (1 + q)
    assert m.a == pytest.approx(a_exact, rel=1e-9)
    assert m.b == pytest.approx(2 * c / (1 + q), rel=1e-9)
    z = m.background
    np.testing.assert_allclose(x0[1:] + m.a * z, m.b, rtol=1e-9)         # the grey equation holds exactly
    # GM(1,1)'s restored series grows by e^-a per step, close to q but not equal: its known bias
    ratio = m.fitted[2:] / m.fitted[1:-1]
    np.testing.assert_allclose(ratio, math.exp(-a_exact), rtol=1e-9)
    assert math.exp(-a_exact) != pytest.approx(q, rel=1e-9)
    assert math.exp(-a_exact) == pytest.approx(q, rel=2e-3)


def test_constant_series_is_the_a_equals_zero_limit():
    m = grey.fit_gm11([4.0, 4.0, 4.0, 4.0, 4.0])
    assert m.a == pytest.approx(0.0, abs=1e-12)
    assert m.b == pytest.approx(4.0)
    np.testing.assert_allclose(m.forecast(3), 4.0)
    np.testing.assert_allclose(m.time_response([0.0, 1.0, 2.5]), [4.0, 8.0, 14.0])
    assert m.posterior_variance_ratio == 0.0 and m.small_error_probability == 1.0


def test_grades_by_hand():
    m = grey.fit_gm11(CLASSIC)
    e = CLASSIC - m.fitted
    np.testing.assert_allclose(m.residuals, e)
    assert m.residuals[0] == 0.0
    np.testing.assert_allclose(m.relative_errors, np.abs(e) / CLASSIC)
    assert m.posterior_variance_ratio == pytest.approx(np.std(e) / np.std(CLASSIC))
    s1 = np.std(CLASSIC)
    assert m.small_error_probability == pytest.approx(np.mean(np.abs(e - e.mean()) < 0.6745 * s1))


def test_background_weight_changes_the_fit():
    x0 = np.array([1.0, 1.3, 1.5, 1.9, 2.2, 2.8])
    for alpha in (0.0, 0.3, 1.0):
        m = grey.fit_gm11(x0, background_weight=alpha)
        assert (m.a, m.b) == pytest.approx(paper_c_formulas(x0, alpha), rel=1e-10)
        assert m.background_weight == alpha


def test_level_ratio_test():
    n = 5
    t = grey.level_ratio_test(CLASSIC)
    assert t.lower == pytest.approx(math.exp(-2 / (n + 1))) and t.upper == pytest.approx(math.exp(2 / (n + 1)))
    np.testing.assert_allclose(t.ratios, CLASSIC[:-1] / CLASSIC[1:])
    assert bool(t) is True
    steep = grey.level_ratio_test([1.0, 3.0, 9.0, 27.0])
    assert not steep and not steep.passed
    # shifting a steep series by a constant flattens its ratios towards 1
    assert grey.level_ratio_test(np.array([1.0, 3.0, 9.0, 27.0]) + 100.0).passed


def test_vectorized_forecast_equals_the_fit_of_each_series():
    rng = np.random.default_rng(0)
    series = 5.0 + np.cumsum(rng.random((4, 3, 12)), axis=-1)
    out = grey.gm11_forecast(series, 3)
    assert out.shape == (4, 3, 3)
    a, b = grey.gm11_coefficients(series)
    assert a.shape == b.shape == (4, 3)
    for i in range(4):
        for j in range(3):
            m = grey.fit_gm11(series[i, j])
            np.testing.assert_allclose(out[i, j], m.forecast(3), rtol=1e-12)
            assert a[i, j] == pytest.approx(m.a) and b[i, j] == pytest.approx(m.b)


def test_rolling_forecast_uses_the_window_before_each_sample():
    rng = np.random.default_rng(1)
    x = 0.1 * np.cumsum(rng.normal(size=(2, 60)), axis=-1) + 0.05 * rng.normal(size=(2, 60))   # signed values
    L, c = 30, 5.0
    out = grey.rolling_gm11_forecast(x, L, offset=c)
    assert out.shape == x.shape
    assert np.isnan(out[:, :L]).all() and np.isfinite(out[:, L:]).all()
    for k in (L, 45, 59):
        expected = grey.fit_gm11(x[1, k - L:k] + c).forecast(1)[0] - c
        assert out[1, k] == pytest.approx(expected, rel=1e-12)
    assert np.isnan(grey.rolling_gm11_forecast(x[0, :20], 30)).all()           # too short: all NaN


def test_bad_input():
    with pytest.raises(ValueError, match="series must be > 0 for GM.*Shift the series"):
        grey.fit_gm11([1.0, -0.5, 2.0, 3.0])
    with pytest.raises(ValueError, match="at least 4 values"):
        grey.fit_gm11([1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="series must be finite"):
        grey.fit_gm11([1.0, np.nan, 2.0, 3.0])
    with pytest.raises(ValueError, match="must have 1 dimension"):
        grey.fit_gm11(np.ones((2, 5)))
    with pytest.raises(ValueError, match="background_weight must lie in"):
        grey.fit_gm11(CLASSIC, background_weight=1.5)
    with pytest.raises(ValueError, match="steps must be >= 1"):
        grey.fit_gm11(CLASSIC).forecast(0)
    with pytest.raises(TypeError, match="steps must be an integer"):
        grey.gm11_forecast(CLASSIC, 1.5)
    with pytest.raises(ValueError, match="k must be >= 0"):
        grey.fit_gm11(CLASSIC).time_response(-1.0)
    with pytest.raises(ValueError, match="got a scalar"):
        grey.gm11_forecast(3.0)
    with pytest.raises(ValueError, match="window must be >= 4"):
        grey.rolling_gm11_forecast(CLASSIC, 3)
    with pytest.raises(ValueError, match=r"series must be > 0.*index \(0, 1\)"):
        grey.gm11_forecast([[1.0, 0.0, 2.0, 3.0]])
    with pytest.raises(ValueError, match="series must be > 0"):
        grey.rolling_gm11_forecast(np.linspace(-1.0, 1.0, 40), 30)            # forgot the offset
    with pytest.raises(ValueError, match="level-ratio|at least 4"):
        grey.level_ratio_test([1.0, 2.0])


def test_gm11_next_is_the_one_step_forecast():
    rng = np.random.default_rng(8)
    series = 1.0 + rng.random((4, 3, 30))
    np.testing.assert_array_equal(grey.gm11_next(series), grey.gm11_forecast(series, 1)[..., 0])
    assert grey.gm11_next(CLASSIC) == pytest.approx(grey.fit_gm11(CLASSIC).forecast(1)[0], rel=1e-14)
    with pytest.raises(ValueError, match="finite and > 0"):
        grey.gm11_next([1.0, 2.0, np.nan, 3.0])
    with pytest.raises(ValueError, match="finite and > 0"):
        grey.gm11_next([1.0, 2.0, -1.0, 3.0])
    with pytest.raises(ValueError, match="at least 4 values"):
        grey.gm11_next([1.0, 2.0, 3.0])


def test_series_far_from_one_are_fitted_in_their_own_units():
    """GM(1,1) on 1e-320 or 1e300 used to give NaN (underflow / overflow in the sums of squares)."""
    import numpy as np

    from uwtutor import grey

    base = np.array([1.0, 2.0, 3.0, 4.0, 5.0])
    ref = grey.fit_gm11(base)
    for scale in (1e-318, 1e-200, 1e200, 1e300):
        fit = grey.fit_gm11(base * scale)
        assert np.isfinite(fit.a) and np.isfinite(fit.b)
        assert abs(fit.a - ref.a) <= 1e-9 * abs(ref.a) + 1e-12
        forecast = grey.gm11_forecast(base * scale, 2)
        np.testing.assert_allclose(forecast / scale, grey.gm11_forecast(base, 2), rtol=1e-6)
