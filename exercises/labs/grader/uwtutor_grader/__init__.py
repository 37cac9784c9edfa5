"""The hidden tests of uwtutor's course labs: the instructor's grader, never shipped to students.

This package lives beside the lab sources (``exercises/labs/grader/`` of the repository and of uwtutor's sdist) and
is installed by the instructor only (``pip install ./exercises/labs/grader``); uwtutor's wheel, which every student
gets, carries neither it nor any reference value. nbgrader's feedback shows every test cell as it is, hidden tests
included, so a hidden test that recomputed the reference in the cell would show the student the solution of the part
they failed. Each hidden test (between the lab's ``### BEGIN HIDDEN TESTS`` and ``### END HIDDEN TESTS`` lines) is
therefore a call and an ``assert``::

    from uwtutor_grader import check_part
    _verdict = check_part(LAB, CHECK, globals())       # e.g. check_part("bias_tracking_iekf", "C", globals())
    assert _verdict, _verdict

``check_part`` reads the part's answers (and the lab's given data) from the notebook's namespace, computes the
references with uwtutor, and returns a ``Feedback``: correct, or the first check that fails, with a message that
names the answer, recognises the lab's common mistakes (those its instructor notes list) and hints at the cause,
but never shows the expected value. A part with several steps is graded as several checks (``"B1"``, ``"B2"``),
one test cell and its points each; a part that builds on an earlier answer is checked against the student's own
earlier answer, so that one mistake is counted once.

A lab whose grading needs a package that is not installed (``real_ranges_plaza`` needs ``gtsam``, which carries
the Plaza logs) is not graded zero in silence: ``check_part`` raises ``LabDependencyMissing``, whose message says
what to install, in the test cell and on the kernel's standard error, which ``nbgrader autograde`` shows in its log.

Examples
--------
>>> import numpy as np
>>> from uwtutor_grader import check_part, lab_parts
>>> lab_parts("range_error_budget")
('A', 'B1', 'B2', 'C', 'D1', 'D2', 'E')
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
import os
import sys
from collections.abc import Mapping
from typing import Any

from uwtutor.exercises.feedback import Feedback
from ._common import run_part

__all__ = ["check_part", "lab_parts", "lab_requirements", "LabDependencyMissing", "LAB_NAMES"]

#: The labs that have hidden tests here (one module each, named like the lab's folder).
LAB_NAMES = ("bias_tracking_iekf", "cooperative_current", "depth_pf_vs_ekf", "ekf_consistency", "fading_sound_speed",
             "observable_track", "outlier_rejection_vmlbl", "range_error_budget", "real_ranges_plaza")


def _module(lab: Any) -> Any:
    if not isinstance(lab, str) or lab not in LAB_NAMES:
        raise ValueError(f"lab must be one of {', '.join(LAB_NAMES)}; got {lab!r}")
    return importlib.import_module(f"{__name__}.{lab}")


class LabDependencyMissing(RuntimeError):
    """The grading environment lacks a package a lab needs: grading it would give every student zero."""


def lab_requirements(lab: str) -> dict[str, str]:
    """The packages (beyond uwtutor's own dependencies) that grading ``lab`` needs, and how to install each.

    Parameters
    ----------
    lab : str
        The lab's name (its folder in ``exercises/labs/``).

    Returns
    -------
    dict
        Importable module name -> the ``pip install`` argument that brings it (empty when the lab needs nothing else).

    Examples
    --------
    >>> lab_requirements("real_ranges_plaza")
    {'gtsam': 'uwtutor[data]'}
    >>> lab_requirements("ekf_consistency")
    {}
    """
    return dict(getattr(_module(lab), "REQUIRES", {}))


def _require(lab: str) -> None:
    """Raise ``LabDependencyMissing`` (and say so on the kernel's standard error) if a package ``lab`` needs is
    missing."""
    for name, extra in lab_requirements(lab).items():
        try:
            importlib.import_module(name)
        except ImportError as exc:
            message = (f"cannot grade the lab {lab}: the package {name!r} is not installed in the grading "
                       f"environment ({type(exc).__name__}: {exc}). Install it with pip install \"{extra}\" (or "
                       f"\"uwtutor[instructor]\", which includes it) and autograde this lab again; every score of "
                       f"this run of {lab} is void.")
            _to_process_stderr(f"[uwtutor_grader] ERROR | {message}\n")
            raise LabDependencyMissing(message) from None


def _to_process_stderr(line: str) -> None:
    """Write ``line`` to the process's own standard error, past a Jupyter kernel's capture.

    In a kernel, ``sys.stderr`` (and file descriptor 2) go to the notebook; ``sys.stderr.fileno()`` is a copy of the
    kernel process's original standard error, inherited from whoever started the kernel: for ``nbgrader autograde``,
    its own terminal and log. Outside a kernel it is descriptor 2.
    """
    try:
        os.write(sys.stderr.fileno(), line.encode("utf-8", "replace"))
    except (AttributeError, OSError, ValueError):    # no file descriptor (io.UnsupportedOperation is an OSError)
        print(line, end="", file=sys.__stderr__, flush=True)


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
    LabDependencyMissing
        If a package the lab needs (``lab_requirements``) cannot be imported: grading is impossible here.

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
    _require(lab)
    return run_part(module.PARTS[part], namespace, f"part {part} of {lab}")
