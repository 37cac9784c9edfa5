"""Resamplers: identical to filterpy's given the same uniforms, unbiased, variance ordering, validation.

How the draws are made equal: filterpy's resamplers call ``numpy.random.random`` (the global legacy
``RandomState``, an MT19937). After ``np.random.seed(s)`` we read that state with ``np.random.get_state()`` and
load it into a fresh ``numpy.random.MT19937`` bit generator wrapped in a ``numpy.random.Generator``. For MT19937,
``Generator.random()`` builds each double from two 32-bit outputs exactly as ``RandomState.random_sample`` does,
so the replaying Generator yields the very uniforms filterpy consumes (checked in
``test_replay_generator_reproduces_the_global_uniforms``).
"""

import numpy as np
import pytest
from filterpy.monte_carlo import resampling as fp
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from uwtutor.resampling import (WEIGHT_SUM_TOL, effective_sample_size, multinomial_resample, residual_resample,
                                stratified_resample, systematic_resample)

ALL = [multinomial_resample, systematic_resample, stratified_resample, residual_resample]


def replay_generator(seed):
    """A Generator that produces the uniforms ``np.random.random`` produces after ``np.random.seed(seed)``."""
    np.random.seed(seed)
    _, key, pos, *_ = np.random.get_state()
    bit_gen = np.random.MT19937()
    bit_gen.state = {"bit_generator": "MT19937", "state": {"key": key, "pos": pos}}
    return np.random.Generator(bit_gen)


def random_weights(rng, N, zeros=0.2):
    w = rng.random(N) ** 3
    w[rng.random(N) < zeros] = 0.0
    w[rng.integers(N)] += 0.1                      # never all zero
    return w / w.sum()


def filterpy_residual_fixed(weights):
    """filterpy's residual_resample with its residual corrected to ``N*w - floor(N*w)`` (filterpy issue #290)."""
    N = len(weights)
    indexes = np.zeros(N, "i")
    num_copies = np.floor(N * np.asarray(weights)).astype(int)
    k = 0
    for i in range(N):
        for _ in range(num_copies[i]):
            indexes[k] = i
            k += 1
    if k == N:                                     # nothing left to draw (filterpy would divide 0 by 0)
        return indexes
    residual = N * np.asarray(weights) - num_copies
    residual /= sum(residual)
    cumulative_sum = np.cumsum(residual)
    cumulative_sum[-1] = 1.0
    indexes[k:N] = np.searchsorted(cumulative_sum, np.random.random(N - k))
    return indexes


def test_replay_generator_reproduces_the_global_uniforms():
    np.random.seed(123)
    expected = np.random.random(50)
    np.testing.assert_array_equal(replay_generator(123).random(50), expected)


@pytest.mark.parametrize("seed", range(8))
@pytest.mark.parametrize("N", [1, 7, 100, 1000])
@pytest.mark.parametrize("ours, theirs", [
    (multinomial_resample, fp.multinomial_resample),
    (systematic_resample, fp.systematic_resample),
    (stratified_resample, fp.stratified_resample),
    (residual_resample, filterpy_residual_fixed),
])
def test_identical_to_filterpy_given_the_same_uniforms(seed, N, ours, theirs):
    w = random_weights(np.random.default_rng(1000 + seed), N)
    rng = replay_generator(seed)
    np.random.seed(seed)
    expected = theirs(w)
    np.testing.assert_array_equal(ours(w, rng), expected)


def test_residual_equals_filterpy_where_filterpy_is_right():
    # filterpy's residual_resample is only right when no uniforms are needed (every N*w an integer)
    w = np.array([0.25, 0.5, 0.0, 0.25])
    np.random.seed(0)
    np.testing.assert_array_equal(residual_resample(w, replay_generator(0)), fp.residual_resample(w))


@pytest.mark.parametrize("resample", ALL)
def test_unbiased_counts(resample):
    """E[N_i] = N w_i: the mean count over R repetitions is within 5 standard errors.

    The standard error uses the multinomial variance N w_i (1 - w_i), an upper bound for every scheme here
    (Douc and Cappé 2005; for systematic resampling Var N_i = f (1 - f) with f the fractional part of N w_i).
    """
    rng = np.random.default_rng(2024)
    w = np.array([0.31, 0.0, 0.05, 0.17, 0.002, 0.2, 0.268])
    N, R = w.size, 20000
    counts = np.zeros((R, N))
    for r in range(R):
        counts[r] = np.bincount(resample(w, rng), minlength=N)
    assert (counts.sum(axis=1) == N).all()
    sigma = np.sqrt(N * w * (1 - w) / R)
    np.testing.assert_array_less(np.abs(counts.mean(axis=0) - N * w), 5 * sigma + 1e-12)
    assert (counts[:, 1] == 0).all()                             # zero weight: never drawn


def test_variance_ordering():
    """Residual and stratified resampling have smaller count variances than multinomial (Douc and Cappé 2005)."""
    rng = np.random.default_rng(7)
    w = random_weights(rng, 30, zeros=0.0)
    N, R = w.size, 6000
    var = {}
    for resample in ALL:
        counts = np.array([np.bincount(resample(w, rng), minlength=N) for _ in range(R)])
        var[resample.__name__] = counts.var(axis=0)
    multinomial_theory = N * w * (1 - w)
    np.testing.assert_allclose(var["multinomial_resample"], multinomial_theory, rtol=0.15, atol=0.02)
    for name in ("residual_resample", "stratified_resample", "systematic_resample"):
        assert var[name].sum() < var["multinomial_resample"].sum()
        np.testing.assert_array_less(var[name], 1.1 * multinomial_theory + 0.02)
    n_rest = N - np.floor(N * w).sum()                          # multinomial draws left after the copies
    w_rest = (N * w - np.floor(N * w)) / n_rest
    residual_theory = n_rest * w_rest * (1 - w_rest)
    np.testing.assert_allclose(var["residual_resample"], residual_theory, rtol=0.15, atol=0.02)


@pytest.mark.parametrize("resample", ALL)
def test_batched_rows_equal_sequential_calls(resample):
    weights = np.stack([random_weights(np.random.default_rng(s), 50) for s in range(4)])
    batched = resample(weights, np.random.default_rng(5))
    rng = np.random.default_rng(5)
    assert batched.shape == (4, 50)
    for m in range(4):
        np.testing.assert_array_equal(batched[m], resample(weights[m], rng))


@pytest.mark.parametrize("resample", ALL)
def test_unnormalized_weights_are_normalized(resample):
    w = random_weights(np.random.default_rng(3), 200)
    a = resample(w, np.random.default_rng(9))
    b = resample(w * 37.5, np.random.default_rng(9))
    np.testing.assert_array_equal(a, b)
    c = resample(w * (1 + WEIGHT_SUM_TOL / 10), np.random.default_rng(9))    # within the tolerance: used as is
    np.testing.assert_array_equal(a, c)


@settings(max_examples=60, deadline=None)
@given(w=arrays(np.float64, st.integers(1, 60), elements=st.floats(0.0, 1e3)), seed=st.integers(0, 2**32 - 1))
def test_property_valid_indices_never_zero_weight(w, seed):
    if w.sum() <= 0:
        w[0] = 1.0
    for resample in ALL:
        idx = resample(w, np.random.default_rng(seed))
        assert idx.shape == w.shape and idx.dtype.kind == "i"
        assert (w[idx] > 0).all()


def test_systematic_counts_are_floor_or_ceil():
    w = random_weights(np.random.default_rng(4), 500, zeros=0.0)
    counts = np.bincount(systematic_resample(w, np.random.default_rng(0)), minlength=500)
    assert ((counts >= np.floor(500 * w) - 1e-9) & (counts <= np.ceil(500 * w) + 1e-9)).all()


def test_effective_sample_size():
    assert effective_sample_size(np.ones(10)) == pytest.approx(10.0)
    assert effective_sample_size([0.0, 1.0, 0.0]) == pytest.approx(1.0)
    np.testing.assert_allclose(effective_sample_size([[1.0, 1.0], [1.0, 0.0]]), [2.0, 1.0])


@pytest.mark.parametrize("resample", ALL)
@pytest.mark.parametrize("weights, message", [
    ([0.5, np.nan, 0.5], "weights must be finite and >= 0; got nan at index 1"),
    ([0.5, np.inf], "weights must be finite and >= 0"),
    ([0.5, -0.1, 0.6], "weights must be finite and >= 0; got -0.1 at index 1"),
    ([0.0, 0.0], "weights must have a positive sum"),
    ([], "at least one particle"),
    (np.ones((2, 2, 2)), "weights must have 1 or 2 dimension"),
])
def test_bad_weights(resample, weights, message):
    with pytest.raises(ValueError, match=message):
        resample(weights, np.random.default_rng(0))


@pytest.mark.parametrize("resample", ALL)
def test_rng_must_be_a_generator(resample):
    with pytest.raises(TypeError, match="rng must be a numpy.random.Generator"):
        resample([0.5, 0.5], np.random.RandomState(0))
    with pytest.raises(TypeError, match="rng must be a numpy.random.Generator"):
        resample([0.5, 0.5], None)


def test_huge_weights_do_not_overflow():
    idx = systematic_resample([1e308, 1e308, 0.0], np.random.default_rng(0))
    assert set(idx.tolist()) <= {0, 1}


def test_the_filters_systematic_resampler_is_the_public_one():
    """The particle filters resample their own (checked, normalized) weights with a private copy of
    systematic_resample that skips the checks: the same indices and the same use of the generator, also for
    trailing zero weights and for weights whose sum is off by more than the tolerance."""
    from uwtutor.filters.particle.bootstrap import _systematic_own_weights as _systematic_trusted

    rng = np.random.default_rng(11)
    for N in (1, 2, 7, 1000):
        for case in range(4):
            w = rng.random(N) ** 8
            if case == 1 and N > 2:
                w[-2:] = 0.0
            w = w / w.sum()
            if case == 2:
                w = w * 1.01
            a, b = np.random.default_rng(case), np.random.default_rng(case)
            np.testing.assert_array_equal(_systematic_trusted(w, a), systematic_resample(w, b))
            assert a.random() == b.random()
