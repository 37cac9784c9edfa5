"""Exercises: answer checkers that explain mistakes, and the generator of student versions.

- ``Feedback``: the verdict on an answer (truthy when correct; displays as a coloured note in a notebook);
- ``check_number``, ``check_array``, ``check_function``, ``check_choice`` and ``Case``: generic checkers that recognise
  common mistakes (a factor of 2, a wrong sign, a unit conversion, a transposed array, an exception in the student's
  code, a lower-case letter where the capital is asked);
- ``uwtutor.exercises.ch01`` ...: the checkers of each chapter's exercises;
- the course labs' hidden tests are not here: they are the instructor's (the package ``uwtutor_grader`` beside the
  lab sources, ``exercises/labs/grader/``), so that no student installation can compute a graded answer;
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
