"""Exercises: answer checkers that explain mistakes, and the generator of student versions.

- ``Feedback``: the verdict on an answer (truthy when correct; displays as a coloured note in a notebook);
- ``check_number``, ``check_array``, ``check_function``, ``check_choice`` and ``Case``: generic checkers that recognise
  common mistakes (a factor of 2, a wrong sign, a unit conversion, a transposed array, an exception in the student's
  code, a lower-case letter where the capital is asked);
- ``uwtutor.exercises.ch01`` ...: the checkers of each chapter's exercises;
- ``uwtutor.exercises.labs``: the hidden tests of the course labs (``check_part``), computed in the library so that
  nbgrader's feedback shows a student what failed, never the answer;
- ``make_student_version``, ``write_student_versions``, ``list_exercise_sources``: turn the solution sources in the
  repository's ``exercises/`` directory into student versions (also the command ``uwtutor exercises DIR``).
"""

from .checks import Case, check_array, check_choice, check_function, check_number
from .feedback import Feedback
from .generate import WriteReport, list_exercise_sources, make_student_version, write_student_versions

__all__ = [
    "Feedback",
    "Case",
    "check_number",
    "check_array",
    "check_function",
    "check_choice",
    "make_student_version",
    "write_student_versions",
    "list_exercise_sources",
    "WriteReport",
]
