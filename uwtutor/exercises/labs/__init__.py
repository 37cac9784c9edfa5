"""The hidden tests of the course labs, computed inside the library so that a lab's feedback shows no answer.

nbgrader's feedback shows every test cell as it is, hidden tests included. A hidden test that recomputed the
reference in the cell would show the student the solution of the part they failed. So each hidden test (between the
lab's ``### BEGIN HIDDEN TESTS`` and ``### END HIDDEN TESTS`` lines) is a call and an ``assert``::

    from uwtutor.exercises.labs import check_part
    _verdict = check_part(LAB, PART, globals())       # e.g. check_part("bias_tracking_iekf", "C", globals())
    assert _verdict, _verdict

``check_part`` reads the part's answers (and the lab's given data) from the notebook's namespace, computes the
references with the library, and returns a ``Feedback``: correct, or the first check that fails, with a message that
names the answer, recognises the lab's common mistakes (those its instructor notes list) and hints at the cause,
but never shows the expected value. The ``assert`` in the cell raises the ``AssertionError`` that nbgrader scores,
from the cell itself, so the traceback shows only the call and the message.

Examples
--------
>>> import numpy as np
>>> from uwtutor.exercises.labs import check_part, lab_parts
>>> lab_parts("range_error_budget")
('A', 'B', 'C', 'D', 'E')
>>> cast = dict(
...     cast_temperature=np.array([14.2, 7.0]),
...     cast_salinity=np.array([30.5, 34.9]),
...     cast_depth=np.array([0.0, 180.0]),
... )
>>> check_part(
...     "range_error_budget",
...     "A",
...     {**cast, "profile_speeds": np.array([1500.0, 1480.0])},
... )
✘ Not yet: 2 of 2 elements of profile_speeds are off; the worst is at index 1: got 1480 m/s.
  Hint: Pass temperature, salinity and depth of the cast, in that order, to `sound_speed`.
>>> check_part("range_error_budget", "A", cast)
✘ No answer yet: `profile_speeds` is not defined.
  Hint: Run the notebook's cells from the top down to this one (Run > Run All Above Selected Cell), then
  this one.
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from typing import Any

from ..feedback import Feedback
from ._common import run_part

__all__ = ["check_part", "lab_parts", "LAB_NAMES"]

#: The labs that have hidden tests here (one module each, named like the lab's folder).
LAB_NAMES = ("bias_tracking_iekf", "cooperative_current", "depth_pf_vs_ekf", "ekf_consistency", "fading_sound_speed",
             "observable_track", "outlier_rejection_vmlbl", "range_error_budget", "real_ranges_plaza")


def _module(lab: Any) -> Any:
    if not isinstance(lab, str) or lab not in LAB_NAMES:
        raise ValueError(f"lab must be one of {', '.join(LAB_NAMES)}; got {lab!r}")
    return importlib.import_module(f"{__name__}.{lab}")


def lab_parts(lab: str) -> tuple[str, ...]:
    """The parts of ``lab`` that have hidden tests, in order.

    Parameters
    ----------
    lab : str
        The lab's name (its folder in ``exercises/labs/``).

    Returns
    -------
    tuple of str
        The part letters.

    Raises
    ------
    ValueError
        If ``lab`` is not one of ``LAB_NAMES``.

    Examples
    --------
    >>> lab_parts("observable_track")
    ('A', 'B', 'C', 'D')
    >>> all(lab_parts(lab) for lab in LAB_NAMES)
    True
    """
    return tuple(_module(lab).PARTS)


def check_part(lab: str, part: str, namespace: Mapping[str, Any]) -> Feedback:
    """The hidden tests of one part of a lab, run on the notebook's namespace.

    Parameters
    ----------
    lab : str
        The lab's name, e.g. ``"bias_tracking_iekf"``.
    part : str
        The part's letter, e.g. ``"C"``.
    namespace : mapping
        The notebook's ``globals()``: the answers of the part and the lab's given data.

    Returns
    -------
    Feedback
        Correct when every hidden check of the part passes; otherwise the first failing check, its message naming
        the answer and (where the lab's instructor notes list it) the mistake, without the expected value.

    Raises
    ------
    ValueError
        If ``lab`` or ``part`` does not exist (a mistake in the test cell, not in the answer).

    Examples
    --------
    >>> import numpy as np
    >>> from uwtutor.acoustics import sound_speed
    >>> cast = dict(cast_temperature=np.array([14.2, 7.0]),
    ...             cast_salinity=np.array([30.5, 34.9]),
    ...             cast_depth=np.array([0.0, 180.0]))
    >>> wrong = {**cast, "profile_speeds": np.array([1500.0, 1480.0])}
    >>> check_part("range_error_budget", "A", wrong).correct
    False
    >>> speeds = sound_speed(cast["cast_temperature"], cast["cast_salinity"],
    ...                      cast["cast_depth"])
    >>> right = {**cast, "profile_speeds": speeds}
    >>> check_part("range_error_budget", "A", right).correct
    True
    """
    module = _module(lab)
    if part not in module.PARTS:
        raise ValueError(f"part must be one of {', '.join(module.PARTS)} for the lab {lab}; got {part!r}")
    return run_part(module.PARTS[part], namespace, f"part {part} of {lab}")
