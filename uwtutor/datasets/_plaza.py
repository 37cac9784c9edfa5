r"""The CMU Plaza 1 and Plaza 2 range-only data sets, read from the copies that ship in GTSAM's wheel."""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path
from typing import Any

import numpy as np

from .._validate import as_int
from ._core import RangeDataset

__all__ = ["plaza", "PLAZA_HEADING_OFFSET"]

#: What :func:`plaza` adds to the heading column of each set's ground truth so that the heading points along the
#: direction of travel, as the odometry integrates it. Plaza 2's file gives the opposite direction; GTSAM's own
#: Plaza examples add the same half turn to its first pose.
PLAZA_HEADING_OFFSET: dict[int, float] = {1: 0.0, 2: float(np.pi)}

_INSTALL_HINT = 'pip install "uwtutor[data]"'


def _wrap(angle: np.ndarray) -> np.ndarray:
    """Angles wrapped into [-pi, pi)."""
    return (np.asarray(angle) + np.pi) % (2.0 * np.pi) - np.pi


def _locate(number: int, folder: Any) -> Path:
    """The path of ``Plaza{number}_.mat``: in ``folder`` if given, else in the installed gtsam package."""
    filename = f"Plaza{number}_.mat"
    if folder is not None:
        if not isinstance(folder, (str, os.PathLike)):
            raise TypeError(f"folder must be a path (str or pathlib.Path); got {type(folder).__name__}")
        path = Path(folder) / filename
        if not path.is_file():
            raise FileNotFoundError(f"{filename} is not in the folder {str(folder)!r}. plaza() needs the .mat file: "
                                    "only it holds the ground truth (GT) and the beacon positions (TL), which the "
                                    f"Plaza{number}_DR.txt and _TD.txt files lack")
        return path
    spec = importlib.util.find_spec("gtsam")
    if spec is None:
        raise ModuleNotFoundError(f"plaza({number}) reads the Plaza data shipped with GTSAM, which is not installed: "
                                  f"{_INSTALL_HINT} (or pip install \"gtsam>=4.3,<4.4\"), or pass folder= a folder "
                                  f"holding {filename}")
    for location in spec.submodule_search_locations or ():
        candidate = Path(location) / "Data" / filename
        if candidate.is_file():
            return candidate
    try:                                   # another layout of the wheel: ask GTSAM itself
        import gtsam

        return Path(gtsam.findExampleDataFile(filename))
    except Exception as exc:               # gtsam raises a bare RuntimeError when the file is missing
        raise FileNotFoundError(f"the installed gtsam package holds no {filename} ({exc}); install gtsam 4.3 with "
                                f"{_INSTALL_HINT}, or pass folder= a folder holding {filename}") from None


def _table(mat: dict[str, Any], key: str, columns: int, path: Path) -> np.ndarray:
    if key not in mat:
        raise ValueError(f"{path.name} holds no {key} table; is it a Plaza file from GTSAM 4.3?")
    arr = np.asarray(mat[key], dtype=float)
    if arr.ndim != 2 or arr.shape[1] != columns or not np.all(np.isfinite(arr)):
        raise ValueError(f"{path.name}: the {key} table should be a finite (n, {columns}) array; got shape "
                         f"{arr.shape}")
    return arr


def plaza(number: int, *, folder: str | os.PathLike[str] | None = None) -> RangeDataset:
    r"""Load the CMU Plaza 1 or Plaza 2 data set: wheel odometry and ranges to 4 beacons, with ground truth.

    A robot of Carnegie Mellon's Robotics Institute drove 1.9 km in 32 minutes (Plaza 1) and 1.4 km in 7 minutes
    (Plaza 2) with wheel odometry (distance travelled and heading change, about 5 times a second in Plaza 1 and
    10 in Plaza 2) and an ultra-wideband
    radio ranging to 4 beacons at surveyed positions; a GPS/inertial system gave the ground truth (Djugash, Hamner
    and Roth 2009). It is the mathematics of this book on land: dead reckoning plus ranges to beacons at known
    positions. The files ship with GTSAM (Dellaert and GTSAM contributors), whose wheel
    (``pip install "uwtutor[data]"``) brings them along; nothing is downloaded at run time.

    Parameters
    ----------
    number : {1, 2}
        Which set.
    folder : str or path-like, optional
        Read ``Plaza{number}_.mat`` from this folder instead of the installed ``gtsam`` package.

    Returns
    -------
    RangeDataset
        ``times`` = the ground-truth epochs; ``odometry`` = the DR rows (row 0 is ``[0, 0]``); ``ranges`` =
        ``[time, beacon id, range]`` from TD, sorted by time; ``beacons`` from TL; ``truth`` = GT with its heading
        turned to the direction of travel (``PLAZA_HEADING_OFFSET``); ``start`` = ``truth[0]``. Its
        ``notes`` say what was changed.

    Raises
    ------
    ModuleNotFoundError
        Without ``folder``, when gtsam is not installed (the message says how to install it).
    FileNotFoundError
        When the ``.mat`` file is not where it is looked for.

    Notes
    -----
    What the files hold, as read here and checked against the ground truth (``tests/test_datasets.py`` repeats
    these checks on an independent reading of the files):

    * ``Plaza{n}_.mat`` holds every table: GT ``[t, x, y, heading]`` (K rows), DR ``[t, distance, heading
      change]`` (K - 1 rows), TD ``[t, sender, beacon id, range]``, TL ``[beacon id, x, y]``, and DRp (the
      authors' own dead-reckoned path, not used). ``Plaza{n}_DR.txt`` and ``_TD.txt`` repeat DR and TD exactly;
      only the ``.mat`` has the truth and the beacons, so it is what is read.
    * DR row :math:`i` is stamped with the time of GT row :math:`i + 1`: it is the motion from GT epoch
      :math:`i` to :math:`i + 1`. The odometry therefore gets a zero row in front and shares the truth's epochs.
    * Units are metres, radians and seconds; headings are counter-clockwise from +x. The distance of each DR row
      matches the ground truth's step (its sum over the run is within 0.2 % of the truth's path length). Plaza
      2's GT heading points *against* the direction of travel (a median 179 degrees off the direction of the
      truth's own steps), Plaza 1's along it: a half turn is added to Plaza 2's.
    * The odometry follows the truth best when each step moves along the previous heading and turns after it
      (the rule of :meth:`RangeDataset.dead_reckoning`): restarted from the truth every 2 s, it ends nearer the
      truth than moving along the mean heading of the step or turning first. The headings (GT's and DR's alike)
      are stamped 0.07-0.08 s ahead of GT's positions, so a logged heading change mostly acts on the next step.
    * Plaza 1's DR heading changes are, to round-off, the differences of its GT heading: that odometry carries
      no heading error, and its dead reckoning drifts only through the distances. Plaza 2's heading changes
      come from the robot and drift from the truth's by more than 100 degrees over the run.
    * TD's sender column is always 2 (the robot's radio) and is dropped. Plaza 1's TD goes back in time twice
      (by 64 s and 50 s: two blocks of rows logged late); their residuals against the truth are as small as
      the others', so the time stamps are right and the rows are sorted by time (stably); the notes give the
      count of rows moved.
    * Every range is about 1.07 times the true distance (a scale, not an offset), with a residual of about
      0.55 m that does not grow with the range.

    References
    ----------
    Djugash, J., Hamner, B. and Roth, S. (2009). Navigating with ranging radios: five data sets with ground truth.
    Journal of Field Robotics. doi:10.1002/rob.20311.

    Dellaert, F. and GTSAM contributors. GTSAM (Georgia Tech Smoothing and Mapping), version 4.3, BSD licence.
    doi:10.5281/zenodo.5794541. The files are ``gtsam/Data/Plaza{1,2}_.mat`` of its wheel; its examples
    ``RangeISAMExample_plaza2.cpp`` and ``RangeISAMExample_plaza.m`` read them too.

    Examples
    --------
    >>> import pytest
    >>> gtsam = pytest.importorskip("gtsam")   # the data come with uwtutor[data]
    >>> from uwtutor.datasets import plaza
    >>> data = plaza(2)
    >>> data
    RangeDataset('Plaza 2': 4091 epochs over 409.5 s, 1816 ranges to beacons [0, 1, 5, 6], with truth)
    >>> data.ranges_on_epochs(min_period=10.0).shape
    (4091, 4)
    """
    n = as_int("number", number)
    if n not in (1, 2):
        raise ValueError(f"number must be 1 or 2 (Plaza 1 or Plaza 2); got {n}")
    path = _locate(n, folder)
    from scipy.io import loadmat

    mat = loadmat(path)
    gt = _table(mat, "GT", 4, path)
    dr = _table(mat, "DR", 3, path)
    td = _table(mat, "TD", 4, path)
    tl = _table(mat, "TL", 3, path)
    if len(dr) != len(gt) - 1 or not np.allclose(dr[:, 0], gt[1:, 0], rtol=0.0, atol=1e-6):
        raise ValueError(f"{path.name}: DR should hold one row per step between GT epochs, stamped with the later "
                         f"epoch ({len(gt) - 1} rows); got {len(dr)} rows that do not match GT's times")

    notes = [f"odometry: DR of {path.name}, row i = motion from GT epoch i to i + 1; a zero row put first"]
    order = np.argsort(td[:, 0], kind="stable")
    moved = int(np.count_nonzero(order != np.arange(len(td))))
    back = np.diff(td[:, 0]) < 0
    if moved:
        jumps = -np.diff(td[:, 0])[back]
        notes.append(f"ranges: TD goes back in time {int(back.sum())} time(s) (by up to {jumps.max():.3g} s); "
                     f"sorted by time (stable), which moved {moved} of {len(td)} rows")
    else:
        notes.append(f"ranges: TD already in time order ({len(td)} rows)")
    td = td[order]
    offset = PLAZA_HEADING_OFFSET[n]
    if offset:
        notes.append(f"truth: GT heading + {np.degrees(offset):.0f} deg (the file's heading points against the "
                     "direction of travel)")
    truth = np.column_stack([gt[:, 1:3], _wrap(gt[:, 3] + offset)])
    beacons = {int(round(i)): (float(x), float(y)) for i, x, y in tl}
    return RangeDataset(times=gt[:, 0], odometry=np.vstack([[0.0, 0.0], dr[:, 1:3]]),
                        ranges=td[:, [0, 2, 3]], beacons=beacons, truth=truth, name=f"Plaza {n}",
                        notes=tuple(notes))
