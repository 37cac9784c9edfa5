"""Tests of uwtutor.datasets: the RangeDataset type, ranges on epochs, and the Plaza loader against the files.

The loader is checked against an independent reading of GTSAM's files (scipy.io.loadmat of the .mat, numpy.loadtxt
of the .txt); those tests skip when gtsam (the optional extra uwtutor[data]) is not installed.
"""

from __future__ import annotations

import dataclasses
import shutil

import numpy as np
import pytest
import scipy.io

from uwtutor.datasets import DEFAULT_START_SIGMAS, PLAZA_HEADING_OFFSET, RangeDataset, plaza
from uwtutor.datasets import _plaza
from uwtutor.motion import integrate_odometry


def wrap(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


# ----------------------------------------------------------------------------------------------------------------
# a small hand-made dataset

def small(**changes):
    """Five epochs one second apart, driving east at 1 m/s, two beacons."""
    fields = dict(
        times=[0.0, 1.0, 2.0, 3.0, 4.0],
        odometry=[[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [1.0, 0.0], [1.0, 0.0]],
        ranges=[[0.2, 1, 10.0], [0.5, 2, 20.0], [0.7, 1, 11.0], [1.1, 1, 12.0], [1.1, 2, 21.0],
                [2.5, 1, 13.0], [3.9, 2, 22.0]],
        beacons={1: (0.0, 10.0), 2: (5.0, -20.0)},
        truth=[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [3.0, 0.0, 0.0], [4.0, 0.0, 0.0]],
        name="small",
    )
    fields.update(changes)
    return RangeDataset(**fields)


def test_fields_are_stored_read_only_and_frozen():
    data = small()
    assert data.n_epochs == 5 and data.n_ranges == 7 and data.duration == 4.0
    assert data.beacon_ids == (1, 2)
    for arr in (data.times, data.odometry, data.ranges, data.truth, data.start, data.start_cov):
        with pytest.raises(ValueError):
            arr.flat[0] = 99.0
    with pytest.raises(AttributeError):
        data.name = "other"
    with pytest.raises(TypeError):
        data.beacons[3] = (1.0, 1.0)


def test_start_defaults_to_the_first_true_pose_and_the_default_covariance():
    data = small()
    np.testing.assert_array_equal(data.start, data.truth[0])
    np.testing.assert_allclose(np.sqrt(np.diag(data.start_cov)), DEFAULT_START_SIGMAS)
    own = small(start=[1.0, 2.0, 0.5], start_cov=np.eye(3))
    np.testing.assert_array_equal(own.start, [1.0, 2.0, 0.5])
    np.testing.assert_array_equal(own.start_cov, np.eye(3))
    bare = small(truth=None)
    assert bare.start is None and bare.start_cov is None
    zero = small(start_cov=np.zeros((3, 3)))             # semi-definite: a start known exactly
    assert not zero.start_cov.any()


def test_no_start_or_no_truth_is_said_when_needed():
    bare = small(truth=None)
    with pytest.raises(ValueError, match="dead_reckoning needs a start pose.*start=\\(x, y, heading\\)"):
        bare.dead_reckoning()
    with pytest.raises(ValueError, match="true_ranges needs the truth"):
        bare.true_ranges()


GOOD_RANGES = [[0.5, 1, 10.0]]


@pytest.mark.parametrize("changes, error, match", [
    # times
    (dict(times=[0.0, 2.0, 1.0, 3.0, 4.0]), ValueError, r"times must be strictly increasing; times\[2\] = 1"),
    (dict(times=[0.0, 1.0, 1.0, 3.0, 4.0]), ValueError, r"times must be strictly increasing"),
    (dict(times=[0.0, np.nan, 2.0, 3.0, 4.0]), ValueError, r"times must be finite; got nan at index 1"),
    (dict(times=[[0.0, 1.0, 2.0, 3.0, 4.0]]), ValueError, r"times must have 1 dimension"),
    (dict(times=["0", "1", "2", "3", "4"]), TypeError, r"times must hold numbers"),
    # odometry
    (dict(odometry=[[1.0, 0.0]] * 4), ValueError, r"odometry must have one row per epoch, K = len\(times\) = 5; got 4"
                                                   r".*put a row \[0, 0\] first"),
    (dict(odometry=np.zeros((5, 3))), ValueError, r"odometry must have 2 columns, \[distance travelled, heading"),
    (dict(odometry=[[0, 0], [1, 0], [1, np.nan], [1, 0], [1, 0]]), ValueError,
     r"odometry must be finite; got nan at row 2 \(heading change\)"),
    (dict(odometry=[[0, 0], [1, 0], [1, 0], [np.inf, 0], [1, 0]]), ValueError,
     r"odometry must be finite; got inf at row 3 \(distance\)"),
    # ranges
    (dict(ranges=np.zeros((2, 2))), ValueError, r"ranges must have 3 columns, \[time, beacon id, range\]"),
    (dict(ranges=[[1.0, 1, 10.0], [0.5, 2, 20.0]]), ValueError,
     r"ranges must be sorted by time \(column 0\): ranges\[1, 0\] = 0.5 s comes after 1 s\. Sort them with"),
    (dict(ranges=[[5.5, 1, 10.0]]), ValueError, r"ranges\[0, 0\] = 5.5 s lies outside the epochs' span \[0, 4\]"),
    (dict(ranges=[[np.nan, 1, 10.0]]), ValueError, r"ranges\[:, 0\] \(the times\) must be finite"),
    (dict(ranges=[[0.5, 1, 10.0], [0.6, 3, 10.0]]), ValueError,
     r"ranges\[1, 1\] names beacon 3, which is not in beacons \(known ids: \[1, 2\]; unknown ids in ranges: \[3\]\)"),
    (dict(ranges=[[0.5, 1.5, 10.0]]), ValueError, r"ranges\[:, 1\] \(the beacon ids\) must be whole numbers"),
    (dict(ranges=[[0.5, 1, -0.1]]), ValueError, r"ranges\[:, 2\] \(the ranges\) must be finite and >= 0; got -0.1 "
                                                 r"at row 0"),
    (dict(ranges=[[0.5, 1, np.nan]]), ValueError, r"ranges\[:, 2\] \(the ranges\) must be finite and >= 0; got nan"),
    (dict(ranges=[[0.5, 1, np.inf]]), ValueError, r"ranges\[:, 2\] \(the ranges\) must be finite and >= 0; got inf"),
    # beacons
    (dict(beacons=[(0.0, 10.0), (5.0, -20.0)]), TypeError, r"beacons must be a dict \{beacon id: \(x, y\)\}"),
    (dict(beacons={1.0: (0.0, 10.0)}, ranges=GOOD_RANGES), TypeError, r"beacon id.*must be an integer.*integers"),
    (dict(beacons={1: (0.0, 10.0, 3.0)}, ranges=GOOD_RANGES), ValueError, r"beacons\[1\] must have shape \(2\)"),
    (dict(beacons={1: (0.0, np.nan)}, ranges=GOOD_RANGES), ValueError, r"beacons\[1\] must be finite"),
    # truth, start, start_cov
    (dict(truth=np.zeros((4, 3))), ValueError, r"truth must have shape \(K, 3\) = \(5, 3\)"),
    (dict(truth=np.full((5, 3), np.nan)), ValueError, r"truth must be finite"),
    (dict(start=[0.0, 0.0]), ValueError, r"start must have shape \(3\)"),
    (dict(start_cov=np.diag([1.0, 1.0, -1.0])), ValueError, r"start_cov must be positive semi-definite"),
    (dict(start_cov=[[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]), ValueError, r"start_cov must be symmetric"),
    (dict(start_cov=np.eye(2)), ValueError, r"start_cov must be 3x3"),
    (dict(truth=None, start_cov=np.eye(3)), ValueError, r"start_cov is given but there is no start pose"),
    (dict(name=3), TypeError, r"name must be a builtins.str"),
    (dict(notes="sorted"), TypeError, r"notes must be a tuple of strings"),
])
def test_bad_fields_are_refused_by_name(changes, error, match):
    with pytest.raises(error, match=match):
        small(**changes)


def test_an_empty_range_log_is_allowed():
    data = small(ranges=np.zeros((0, 3)))
    assert data.n_ranges == 0
    assert np.isnan(data.ranges_on_epochs()).all()


# ----------------------------------------------------------------------------------------------------------------
# ranges on epochs

def test_ranges_land_on_the_nearest_epoch_one_column_per_beacon():
    got = small().ranges_on_epochs([1, 2])
    # beacon 1: 0.2 -> epoch 0; 0.7 and 1.1 -> epoch 1 (1.1 is nearer: 12 kept); 2.5 -> tie between 2 and 3 -> 2.
    # beacon 2: 0.5 -> tie between 0 and 1 -> 0; 1.1 -> 1; 3.9 -> 4.
    expected = np.array([[10.0, 20.0],
                         [12.0, 21.0],
                         [13.0, np.nan],
                         [np.nan, np.nan],
                         [np.nan, 22.0]])
    np.testing.assert_array_equal(got, expected)


def test_column_order_follows_beacon_ids_and_one_id_gives_one_column():
    data = small()
    both = data.ranges_on_epochs()
    np.testing.assert_array_equal(data.ranges_on_epochs([2, 1]), both[:, ::-1])
    np.testing.assert_array_equal(data.ranges_on_epochs(2), both[:, 1:])
    np.testing.assert_array_equal(data.ranges_on_epochs(np.int64(1)), both[:, :1])


def test_a_tie_in_time_keeps_the_earlier_row():
    data = small(ranges=[[0.75, 1, 5.0], [1.25, 1, 6.0]])      # both 0.25 s from epoch 1
    np.testing.assert_array_equal(data.ranges_on_epochs(1)[:, 0], [np.nan, 5.0, np.nan, np.nan, np.nan])


def test_every_range_is_placed_when_no_two_share_an_epoch():
    times = np.linspace(0.0, 10.0, 11)
    rng = np.random.default_rng(20261222)
    t = np.sort(rng.uniform(0.0, 10.0, 6))
    t = t[np.concatenate([[True], np.diff(np.round(t)) > 0])]  # at most one range per nearest epoch
    r = rng.uniform(5.0, 50.0, len(t))
    data = RangeDataset(times, np.zeros((11, 2)), np.column_stack([t, np.full(len(t), 4), r]), {4: (0.0, 0.0)})
    got = data.ranges_on_epochs(4)[:, 0]
    expected = np.full(11, np.nan)
    expected[np.argmin(np.abs(times[:, None] - t[None, :]), axis=0)] = r
    np.testing.assert_array_equal(got, expected)


def test_min_period_keeps_a_range_then_the_next_one_at_least_that_long_after():
    times = np.arange(0.0, 21.0)
    t = np.array([0.0, 1.0, 2.5, 3.0, 6.0, 6.5, 12.0, 14.9, 15.0, 20.0])
    data = RangeDataset(times, np.zeros((21, 2)), np.column_stack([t, np.full(len(t), 7), np.arange(len(t)) + 1.0]),
                        {7: (0.0, 0.0)})
    got = data.ranges_on_epochs(7, min_period=3.0)[:, 0]
    kept_times = [0.0, 3.0, 6.0, 12.0, 15.0, 20.0]       # greedy: each >= 3 s after the last kept one
    expected = np.full(21, np.nan)
    for tk in kept_times:
        expected[int(tk)] = np.flatnonzero(t == tk)[0] + 1.0
    np.testing.assert_array_equal(got, expected)
    # a period shorter than every gap keeps every range
    np.testing.assert_array_equal(data.ranges_on_epochs(7, min_period=0.01), data.ranges_on_epochs(7))


def test_min_period_thins_each_beacon_on_its_own():
    data = small()
    thin = data.ranges_on_epochs(min_period=2.0)
    # beacon 1 keeps 0.2 and 2.5; beacon 2 keeps 0.5 and 3.9
    expected = np.array([[10.0, 20.0], [np.nan, np.nan], [13.0, np.nan], [np.nan, np.nan], [np.nan, 22.0]])
    np.testing.assert_array_equal(thin, expected)


@pytest.mark.parametrize("kwargs, error, match", [
    (dict(beacon_ids=[1, 3]), ValueError, r"beacon_ids names \[3\], not in this dataset's beacons \[1, 2\]"),
    (dict(beacon_ids=[1, 1]), ValueError, r"beacon_ids must not repeat an id"),
    (dict(beacon_ids=[]), ValueError, r"beacon_ids is empty"),
    (dict(beacon_ids="1"), TypeError, r"beacon_ids must be a beacon id or a list of them"),
    (dict(beacon_ids=[1.0]), TypeError, r"beacon_ids\[\.\.\.\] must be an integer"),
    (dict(min_period=0.0), ValueError, r"min_period must be > 0"),
    (dict(min_period=np.nan), ValueError, r"min_period must be finite"),
])
def test_bad_selections_are_refused_by_name(kwargs, error, match):
    with pytest.raises(error, match=match):
        small().ranges_on_epochs(**kwargs)


def test_beacon_positions_and_true_ranges():
    data = small()
    np.testing.assert_array_equal(data.beacon_positions([2, 1]), [[5.0, -20.0], [0.0, 10.0]])
    np.testing.assert_array_equal(data.beacon_positions(), [[0.0, 10.0], [5.0, -20.0]])
    got = data.true_ranges([2, 1])
    x = np.arange(5.0)
    np.testing.assert_allclose(got[:, 0], np.sqrt((x - 5.0) ** 2 + 20.0 ** 2))
    np.testing.assert_allclose(got[:, 1], np.sqrt(x ** 2 + 10.0 ** 2))
    assert got.shape == (5, 2)


# ----------------------------------------------------------------------------------------------------------------
# dead reckoning

def loop_dead_reckoning(start, odometry):
    """A plain loop: move d along the previous heading, then turn by delta."""
    x, y, psi = start
    out = [(x, y, psi)]
    for d, delta in odometry[1:]:
        x, y = x + d * np.cos(psi), y + d * np.sin(psi)
        psi = psi + delta
        out.append((x, y, psi))
    return np.array(out)


def test_dead_reckoning_moves_then_turns_counter_clockwise():
    odometry = [[0.0, 0.0], [2.0, np.pi / 2], [3.0, 0.0]]     # 2 m east, turn left, 3 m north
    data = RangeDataset([0.0, 1.0, 2.0], odometry, np.zeros((0, 3)), {}, start=[1.0, 1.0, 0.0])
    np.testing.assert_allclose(data.dead_reckoning(), [[1.0, 1.0, 0.0], [3.0, 1.0, np.pi / 2],
                                                       [3.0, 4.0, np.pi / 2]], atol=1e-12)


def test_integrate_odometry_equals_a_plain_loop_and_batches():
    rng = np.random.default_rng(7)
    odometry = np.column_stack([rng.uniform(0.0, 2.0, 50), rng.normal(0.0, 0.3, 50)])
    starts = rng.normal(size=(3, 3))
    expected = np.stack([loop_dead_reckoning(s, odometry) for s in starts])
    np.testing.assert_allclose(integrate_odometry(starts[0], odometry), expected[0], atol=1e-12)
    np.testing.assert_allclose(integrate_odometry(starts, odometry), expected, atol=1e-12)
    logs = odometry + rng.normal(0.0, 0.01, (3, 50, 2))
    np.testing.assert_allclose(integrate_odometry(starts[1], logs),
                               np.stack([loop_dead_reckoning(starts[1], log) for log in logs]), atol=1e-12)
    assert integrate_odometry(starts, logs).shape == (3, 50, 3)


def test_row_zero_of_the_odometry_is_not_used():
    a = small().dead_reckoning()
    b = small(odometry=[[5.0, 1.0], [1.0, 0.0], [1.0, 0.0], [1.0, 0.0], [1.0, 0.0]]).dead_reckoning()
    np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("start, odometry, match", [
    ([0.0, 0.0], [[0.0, 0.0]], r"start must be a pose"),
    ([0.0, 0.0, 0.0], [[0.0, 0.0, 0.0]], r"odometry must hold \[distance, heading change\]"),
    ([0.0, 0.0, 0.0], np.zeros((0, 2)), r"odometry must hold at least one row"),
    (np.zeros((2, 3)), np.zeros((3, 4, 2)), r"start holds 2 runs but odometry holds 3"),
    ([0.0, 0.0, np.nan], [[0.0, 0.0]], r"start must be finite"),
])
def test_integrate_odometry_refuses_bad_input(start, odometry, match):
    with pytest.raises(ValueError, match=match):
        integrate_odometry(start, odometry)


# ----------------------------------------------------------------------------------------------------------------
# round trips and display

def assert_same(a: RangeDataset, b: RangeDataset) -> None:
    for f in ("times", "odometry", "ranges", "truth", "start", "start_cov"):
        x, y = getattr(a, f), getattr(b, f)
        assert (x is None) == (y is None), f
        if x is not None:
            np.testing.assert_array_equal(x, y, err_msg=f)
    assert dict(a.beacons) == dict(b.beacons)
    assert (a.name, a.notes) == (b.name, b.notes)


@pytest.mark.parametrize("changes", [dict(), dict(truth=None), dict(truth=None, start=[0.0, 1.0, 2.0]),
                                     dict(notes=("a note", "another")), dict(ranges=np.zeros((0, 3)))])
def test_save_and_load_give_the_same_dataset(tmp_path, changes):
    data = small(**changes)
    data.save(tmp_path / "log.npz")
    assert_same(RangeDataset.load(tmp_path / "log.npz"), data)


def test_rebuilding_from_the_fields_gives_the_same_dataset():
    data = small(notes=("x",))
    fields = {f.name: getattr(data, f.name) for f in dataclasses.fields(data)}
    assert_same(RangeDataset(**fields), data)
    renamed = dataclasses.replace(data, name="renamed")
    assert renamed.name == "renamed"
    np.testing.assert_array_equal(renamed.ranges, data.ranges)


def test_repr_and_summary_tell_the_counts():
    data = small(notes=("made by hand",))
    assert repr(data) == "RangeDataset('small': 5 epochs over 4 s, 7 ranges to beacons [1, 2], with truth)"
    text = data.summary()
    counts = {b: int(np.sum(data.ranges[:, 1] == b)) for b in data.beacon_ids}
    assert f"{data.n_epochs} epochs over 4 s" in text
    assert f"{data.n_ranges} ranges to 2 beacons" in text
    for b, n in counts.items():
        assert f"beacon {b} at" in text and f"{n} ranges" in text
    assert "note: made by hand" in text


# ----------------------------------------------------------------------------------------------------------------
# the Plaza loader against an independent reading of the files

@pytest.fixture(scope="module")
def gtsam():
    return pytest.importorskip("gtsam", reason="the Plaza data come with the optional extra uwtutor[data]")


@pytest.fixture(scope="module")
def raw(gtsam):
    """Each set's tables as the files hold them, read here without uwtutor."""
    out = {}
    for n in (1, 2):
        mat = scipy.io.loadmat(gtsam.findExampleDataFile(f"Plaza{n}_.mat"))
        out[n] = {key: np.asarray(mat[key], dtype=float) for key in ("GT", "DR", "TD", "TL")}
        out[n]["DR.txt"] = np.loadtxt(gtsam.findExampleDataFile(f"Plaza{n}_DR.txt"))
        out[n]["TD.txt"] = np.loadtxt(gtsam.findExampleDataFile(f"Plaza{n}_TD.txt"))
    return out


@pytest.fixture(scope="module")
def loaded(gtsam):
    return {n: plaza(n) for n in (1, 2)}


@pytest.mark.parametrize("n", [1, 2])
def test_the_txt_files_repeat_the_mat_tables(raw, n):
    np.testing.assert_array_equal(raw[n]["DR.txt"], raw[n]["DR"])
    np.testing.assert_array_equal(raw[n]["TD.txt"], raw[n]["TD"])


@pytest.mark.parametrize("n", [1, 2])
def test_plaza_counts_first_and_last_rows(raw, loaded, n):
    GT, DR, TD, TL = (raw[n][k] for k in ("GT", "DR", "TD", "TL"))
    data = loaded[n]
    assert data.name == f"Plaza {n}"
    assert data.n_epochs == len(GT) == len(DR) + 1
    assert data.n_ranges == len(TD)
    np.testing.assert_array_equal(data.times, GT[:, 0])
    np.testing.assert_array_equal(data.odometry[0], [0.0, 0.0])
    np.testing.assert_array_equal(data.odometry[1], DR[0, 1:])
    np.testing.assert_array_equal(data.odometry[-1], DR[-1, 1:])
    np.testing.assert_array_equal(data.truth[:, :2], GT[:, 1:3])
    first, last = np.argmin(TD[:, 0]), np.argmax(TD[:, 0])
    np.testing.assert_array_equal(data.ranges[0], TD[first, [0, 2, 3]])
    np.testing.assert_array_equal(data.ranges[-1], TD[last, [0, 2, 3]])
    assert data.beacons == {int(i): (x, y) for i, x, y in TL}
    assert set(np.unique(TD[:, 2]).astype(int)) == set(data.beacon_ids)
    np.testing.assert_array_equal(data.start, data.truth[0])


@pytest.mark.parametrize("n", [1, 2])
def test_dr_rows_are_the_steps_between_truth_epochs(raw, n):
    GT, DR = raw[n]["GT"], raw[n]["DR"]
    np.testing.assert_array_equal(DR[:, 0], GT[1:, 0])      # row i is stamped with GT epoch i + 1
    step = np.hypot(*np.diff(GT[:, 1:3], axis=0).T)
    assert abs(DR[:, 1].sum() / step.sum() - 1.0) < 2e-3     # distances in metres: the truth's path length


@pytest.mark.parametrize("n", [1, 2])
def test_ranges_are_sorted_stably_and_the_notes_count_the_moved_rows(raw, loaded, n):
    TD = raw[n]["TD"]
    data = loaded[n]
    order = np.argsort(TD[:, 0], kind="stable")
    np.testing.assert_array_equal(data.ranges, TD[order][:, [0, 2, 3]])
    assert np.all(np.diff(data.ranges[:, 0]) >= 0)
    moved = int(np.count_nonzero(order != np.arange(len(TD))))
    backs = int(np.count_nonzero(np.diff(TD[:, 0]) < 0))
    text = " ".join(data.notes)
    if moved:
        assert f"moved {moved} of {len(TD)} rows" in text and f"back in time {backs} time(s)" in text
    else:
        assert "already in time order" in text
    assert np.all(TD[:, 1] == 2)                              # the sender column that is dropped


def test_plaza_1_is_the_set_with_out_of_order_blocks_and_their_stamps_are_right(raw, loaded):
    TD = raw[1]["TD"]
    assert np.count_nonzero(np.diff(TD[:, 0]) < 0) > 0
    assert np.count_nonzero(np.diff(raw[2]["TD"][:, 0]) < 0) == 0
    # the late-logged blocks fit the truth as well as the rest: sorting by their stamps is right
    data = loaded[1]
    t, b, r = data.ranges.T
    pos = np.column_stack([np.interp(t, data.times, data.truth[:, 0]), np.interp(t, data.times, data.truth[:, 1])])
    dist = np.hypot(*(pos - np.array([data.beacons[int(i)] for i in b])).T)
    scale = r @ dist / (dist @ dist)
    residual = r - scale * dist
    late = np.zeros(len(TD), bool)
    for j in np.flatnonzero(np.diff(TD[:, 0]) < 0) + 1:      # rows stamped before the row logged ahead of them
        late[j:] |= TD[j:, 0] < TD[j - 1, 0]
    late_rows = {tuple(row) for row in TD[late][:, [0, 2, 3]]}
    in_late = np.array([tuple(row) in late_rows for row in data.ranges])
    assert in_late.sum() == late.sum() > 0
    assert residual[in_late].std() < 1.2 * residual[~in_late].std()


@pytest.mark.parametrize("n", [1, 2])
def test_truth_heading_points_along_the_direction_of_travel(raw, loaded, n):
    GT = raw[n]["GT"]
    step = np.diff(GT[:, 1:3], axis=0)
    moving = np.hypot(*step.T) > 0.05
    direction = np.arctan2(step[:, 1], step[:, 0])[moving]
    raw_off = np.median(np.abs(wrap(direction - GT[:-1, 3][moving])))
    fixed_off = np.median(np.abs(wrap(direction - loaded[n].truth[:-1, 2][moving])))
    assert fixed_off < np.radians(3.0)
    # the file's own heading: along the motion in Plaza 1, against it in Plaza 2, hence the offsets
    assert (raw_off > np.radians(170.0)) == (PLAZA_HEADING_OFFSET[n] == np.pi)
    np.testing.assert_allclose(wrap(loaded[n].truth[:, 2] - GT[:, 3] - PLAZA_HEADING_OFFSET[n]), 0.0, atol=1e-12)
    assert np.all(loaded[n].truth[:, 2] >= -np.pi) and np.all(loaded[n].truth[:, 2] < np.pi)


# Largest dead-reckoning error over the first 20 m travelled, measured (studies/plaza_data.py conventions): 0.97 m in
# Plaza 1, 2.08 m in Plaza 2; with the heading changes' sign flipped, 15.4 m and 25.2 m.
TRACK_TOLERANCE = {1: 1.5, 2: 3.0}


@pytest.mark.parametrize("n", [1, 2])
def test_dead_reckoning_from_the_true_start_tracks_the_truth_at_first(loaded, n):
    data = loaded[n]
    travelled = np.concatenate([[0.0], np.cumsum(data.odometry[1:, 0])])
    early = travelled <= 20.0
    err = np.hypot(*(data.dead_reckoning()[early, :2] - data.truth[early, :2]).T)
    assert err.max() < TRACK_TOLERANCE[n]
    mirrored = integrate_odometry(data.start, data.odometry * [1.0, -1.0])
    err_mirrored = np.hypot(*(mirrored[early, :2] - data.truth[early, :2]).T)
    assert err_mirrored.max() > 5 * TRACK_TOLERANCE[n]     # the sign of the heading change is not a guess


def windowed_error(data, alpha: float, window: float = 2.0) -> float:
    """RMS end error of dead reckoning restarted from the truth every ``window`` seconds, step k moving along
    psi_{k-1} + alpha * delta_k (written here independently of the library)."""
    t, truth, odo = data.times, data.truth, data.odometry
    errs, s = [], 0
    while (e := int(np.searchsorted(t, t[s] + window))) < len(t):
        x, y, psi = truth[s]
        for d, delta in odo[s + 1:e + 1]:
            h = psi + alpha * delta
            x, y, psi = x + d * np.cos(h), y + d * np.sin(h), psi + delta
        errs.append(np.hypot(x - truth[e, 0], y - truth[e, 1]))
        s = e
    return float(np.sqrt(np.mean(np.square(errs))))


@pytest.mark.parametrize("n", [1, 2])
def test_the_odometry_follows_the_truth_best_when_turning_after_the_distance(loaded, n):
    data = loaded[n]
    after, mean, first = (windowed_error(data, a) for a in (0.0, 0.5, 1.0))
    assert after < mean < first
    # and the library's rule is that one
    t = data.times
    e = int(np.searchsorted(t, t[0] + 120.0))
    lib = integrate_odometry(data.truth[0], data.odometry[:e + 1])
    np.testing.assert_allclose(lib, loop_dead_reckoning(data.truth[0], data.odometry[:e + 1]), atol=1e-9)


def test_plaza_1_odometry_heading_is_the_truths_and_plaza_2_drifts(raw, loaded):
    np.testing.assert_allclose(raw[1]["DR"][:, 2], wrap(np.diff(raw[1]["GT"][:, 3])), atol=1e-9)
    data = loaded[2]
    drift = data.dead_reckoning()[:, 2] - np.unwrap(data.truth[:, 2])
    assert abs(np.degrees(drift[-1] - drift[0])) > 100.0


@pytest.mark.parametrize("n", [1, 2])
def test_ranges_are_a_scaled_true_distance_with_noise_that_does_not_grow(loaded, n):
    """What the loader's docstring says of the ranges: about 1.07 x the true distance, about 0.55 m of noise."""
    data = loaded[n]
    measured = data.ranges_on_epochs()
    true = data.true_ranges()
    for col in range(len(data.beacon_ids)):
        ok = ~np.isnan(measured[:, col])
        scale = measured[ok, col] @ true[ok, col] / (true[ok, col] @ true[ok, col])
        assert 1.06 < scale < 1.08
    ok = ~np.isnan(measured)
    scale = measured[ok] @ true[ok] / (true[ok] @ true[ok])
    residual = measured[ok] - scale * true[ok]
    assert 0.45 < residual.std() < 0.65
    near, far = true[ok] < np.median(true[ok]), true[ok] >= np.median(true[ok])
    assert residual[far].std() < 1.15 * residual[near].std()


def test_plaza_from_a_folder_gives_the_same_dataset(gtsam, loaded, tmp_path):
    shutil.copy(gtsam.findExampleDataFile("Plaza2_.mat"), tmp_path / "Plaza2_.mat")
    assert_same(plaza(2, folder=tmp_path), loaded[2])
    assert_same(plaza(2, folder=str(tmp_path)), loaded[2])


def test_plaza_round_trips_through_save_and_load(loaded, tmp_path):
    loaded[1].save(tmp_path / "plaza1.npz")
    assert_same(RangeDataset.load(tmp_path / "plaza1.npz"), loaded[1])


def test_plaza_refuses_a_file_whose_tables_disagree(gtsam, tmp_path):
    mat = scipy.io.loadmat(gtsam.findExampleDataFile("Plaza2_.mat"))
    scipy.io.savemat(tmp_path / "Plaza2_.mat", {"GT": mat["GT"], "DR": mat["DR"][1:], "TD": mat["TD"],
                                                "TL": mat["TL"]})
    with pytest.raises(ValueError, match="DR should hold one row per step between GT epochs"):
        plaza(2, folder=tmp_path)
    scipy.io.savemat(tmp_path / "Plaza2_.mat", {"GT": mat["GT"], "DR": mat["DR"], "TD": mat["TD"]})
    with pytest.raises(ValueError, match="holds no TL table"):
        plaza(2, folder=tmp_path)


# ----------------------------------------------------------------------------------------------------------------
# the loader's errors (none of these needs gtsam)

@pytest.mark.parametrize("number, error, match", [
    (3, ValueError, r"number must be 1 or 2"),
    ("2", TypeError, r"number must be an integer"),
    (2.0, TypeError, r"number must be an integer"),
])
def test_plaza_refuses_a_bad_number(number, error, match):
    with pytest.raises(error, match=match):
        plaza(number)


def test_plaza_without_gtsam_says_how_to_install_it(monkeypatch):
    monkeypatch.setattr(_plaza.importlib.util, "find_spec", lambda name: None)
    with pytest.raises(ModuleNotFoundError, match=r'pip install "uwtutor\[data\]"'):
        plaza(2)


def test_plaza_from_a_folder_without_the_file(tmp_path):
    (tmp_path / "Plaza2_DR.txt").write_text("")
    with pytest.raises(FileNotFoundError, match=r"Plaza2_\.mat is not in the folder.*only it holds the ground truth"):
        plaza(2, folder=tmp_path)
    with pytest.raises(TypeError, match="folder must be a path"):
        plaza(2, folder=3)


def test_schedule_offsets_and_thinning_in_total():
    from uwtutor.datasets import square_log

    data = square_log()
    per_beacon = data.ranges_on_epochs(min_period=10.0)
    shifted = data.ranges_on_epochs(min_period=10.0, offset=3.0)
    in_total = data.ranges_on_epochs(min_period=10.0, thinning="in total")
    heard = [np.nonzero(np.isfinite(a).any(axis=1))[0] for a in (per_beacon, shifted, in_total)]
    assert heard[1][0] >= 3 and not np.array_equal(heard[0], heard[1])
    assert np.isfinite(in_total).sum() == np.isfinite(in_total).any(axis=1).sum()      # one range per epoch at most
    assert np.diff(data.times[heard[2]]).min() >= 10.0
    assert np.isfinite(in_total).sum() < np.isfinite(per_beacon).sum()
    with pytest.raises(ValueError, match="min_period"):
        data.ranges_on_epochs(offset=2.0)
    with pytest.raises(ValueError, match="thinning"):
        data.ranges_on_epochs(min_period=5.0, thinning="each")
