"""filter_from_start_epochs: each run equals its own filter started at its own epoch; bad input is named."""

import numpy as np
import pytest

from uwtutor.filters import range_only_ekf
from uwtutor.pipelines import filter_from_start_epochs


def _inputs(M=4, K=30, seed=2):
    rng = np.random.default_rng(seed)
    theta = np.linspace(0.0, np.pi, K)
    truth = 300.0 * np.column_stack([np.cos(theta), np.sin(theta)]) + [50.0, 0.0]
    u = np.broadcast_to(np.diff(np.vstack([truth[:1], truth]), axis=0), (M, K, 2)).copy()
    z = np.linalg.norm(truth, axis=1) + rng.normal(0.0, 1.0, (M, K))
    z[rng.random((M, K)) < 0.2] = np.nan
    return truth, u, z


def test_each_run_equals_its_own_filter_from_its_start_epoch():
    truth, u, z = _inputs()
    start = np.array([0, 7, 29, 30])                  # the last run never starts
    x_start = truth[np.minimum(start, 29)] + 5.0
    x_start[3] = np.nan
    run = filter_from_start_epochs(range_only_ekf, start, x_start, np.eye(2) * 25.0, u, z, Q=np.eye(2) * 0.1, R=1.0)
    np.testing.assert_array_equal(run.runs, [0, 1, 2])
    x = run.at_epochs(run.filter_result.x, np.nan)
    for m in range(3):
        k0 = start[m]
        if k0 + 1 < z.shape[1]:
            own = range_only_ekf(x_start[m], np.eye(2) * 25.0, u[m, k0 + 1:], z[m, k0 + 1:], np.eye(2) * 0.1, 1.0)
            np.testing.assert_array_equal(x[m, k0 + 1:], own.x)
        assert np.isnan(x[m, :k0 + 1]).all()
    assert np.isnan(x[3]).all()
    np.testing.assert_array_equal(run.after_start, np.arange(30)[None, :] > start[:, None])


def test_bad_input_is_named():
    truth, u, z = _inputs()
    kw = dict(Q=np.eye(2) * 0.1, R=1.0)
    with pytest.raises(ValueError, match="start must hold one integer epoch per run"):
        filter_from_start_epochs(range_only_ekf, [0.5, 1, 2, 3], truth[:4], np.eye(2), u, z, **kw)
    with pytest.raises(ValueError, match="start must be >= 0"):
        filter_from_start_epochs(range_only_ekf, [-1, 1, 2, 3], truth[:4], np.eye(2), u, z, **kw)
    with pytest.raises(ValueError, match="z must have the runs and epochs of u"):
        filter_from_start_epochs(range_only_ekf, [0, 1, 2, 3], truth[:4], np.eye(2), u, z[:, :5], **kw)
    with pytest.raises(ValueError, match="no run has a finite x_start"):
        filter_from_start_epochs(range_only_ekf, [0, 1, 2, 3], np.full((4, 2), np.nan), np.eye(2), u, z, **kw)


def test_without_the_padding_every_epoch_is_the_same_bit_for_bit():
    truth, u, z = _inputs()
    kw = dict(Q=np.eye(2) * 0.1, R=1.0)
    for start in (np.array([12, 7, 29, 30]), np.array([30, 30, 30, 30]), np.array([0, 3, 3, 9])):
        x_start = truth[np.minimum(start, 29)] + 5.0
        padded = filter_from_start_epochs(range_only_ekf, start, x_start, np.eye(2) * 25.0, u, z, **kw)
        trimmed = filter_from_start_epochs(range_only_ekf, start, x_start, np.eye(2) * 25.0, u, z, **kw,
                                           trim_padding=True)
        steps = max(1, 30 - 1 - start.min())
        assert trimmed.filter_result.x.shape == (4, steps, 2) and padded.filter_result.x.shape == (4, 30, 2)
        assert trimmed.n_epochs == padded.n_epochs == 30
        for name in ("x", "P", "innovations"):
            a = padded.at_epochs(getattr(padded.filter_result, name), np.nan)
            b = trimmed.at_epochs(getattr(trimmed.filter_result, name), np.nan)
            assert a.tobytes() == b.tobytes(), (start, name)
    with pytest.raises(TypeError, match="trim_padding"):
        filter_from_start_epochs(range_only_ekf, start, x_start, np.eye(2), u, z, **kw, trim_padding="yes")
