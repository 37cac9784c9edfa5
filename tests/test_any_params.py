"""The public API's parameters annotated ``Any`` may only become fewer: ``tools/any_params.py`` lists them, and
``tests/any_params_pending.txt`` holds the list of today (the exercises' student answers are not in it).

A new public parameter annotated ``Any`` fails: give it its type (``ArrayLike``, a ``Generator``, a model class, a
``Literal`` of the choices...). A listed parameter that is no longer ``Any`` (or no longer exists) fails too: remove
its line (or rewrite the list with ``python tools/any_params.py --write-pending``).
"""

from __future__ import annotations

import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tools"))

import any_params  # noqa: E402


def read_pending(path: Path = any_params.PENDING) -> set[str]:
    lines = (line.split("#", 1)[0].strip() for line in path.read_text(encoding="utf-8").splitlines())
    return {line for line in lines if line}


def test_no_new_public_parameter_is_typed_any():
    found = set(any_params.census().any_params)
    pending = read_pending()
    new = sorted(found - pending)
    assert not new, ("public parameters annotated Any that tests/any_params_pending.txt does not list (give them "
                     "their type):\n  " + "\n  ".join(new))
    fixed = sorted(pending - found)
    assert not fixed, ("tests/any_params_pending.txt lists parameters that are no longer annotated Any (remove "
                       "their lines, or run python tools/any_params.py --write-pending):\n  " + "\n  ".join(fixed))


def test_the_census_sees_an_any_parameter_and_skips_student_answers():
    """The rule itself on known cases: an ``Any`` of a library callable counts, a checker's answer does not."""
    assert any_params._is_any("Any") and any_params._is_any("Any | None") and not any_params._is_any("ArrayLike")
    assert any_params._is_answer("uwtutor.exercises.ch05.check_mu_gamma", "answer")
    assert any_params._is_answer("uwtutor.exercises.checks.run_student", "func")
    assert not any_params._is_answer("uwtutor.filters.engine.extended_kalman_filter", "times")
    assert not any_params._is_answer("uwtutor.exercises.ch05.isfekf_step_reference", "x")
