"""uwtutor's labs as an nbgrader course: the settings of the course's ``nbgrader_config.py``.

A course directory's ``nbgrader_config.py`` calls ``configure`` (``exercises/labs/nbgrader_config.py`` is the
example)::

    from uwtutor_grader.course import configure
    c = get_config()
    c.CourseDirectory.course_id = "my-course"
    configure(c)

which sets

- the answer stub of nbgrader's release to uwtutor's own (``raise NotImplementedError('not answered yet: …')``,
  the line the labs' instructions quote);
- ``RequireGradeCells`` before nbgrader's ``OverwriteCells`` in ``autograde``: a submission whose test cells lost
  nbgrader's metadata (a copy made by an older uwtutor, whose ``uwtutor labs`` wrote no metadata, or a notebook the
  student typed again) would get no hidden test and score 0 without a word; it is refused, with the reason in
  autograde's log, and autograde ends with an error;
- the feedback template ``uwtutor_feedback``, which names each graded cell by its part ("Part B, check B1") where
  nbgrader writes "Test cell".
"""

from __future__ import annotations

import os
from typing import Any

import nbgrader
from nbgrader import preprocessors as pp
from nbgrader.api import Gradebook

from uwtutor.exercises.generate import CODE_STUB

__all__ = ["configure", "RequireGradeCells", "SubmissionWithoutGradeCells", "TEMPLATE_DIR", "FEEDBACK_TEMPLATE"]

#: The folder of the feedback template (its subfolder ``FEEDBACK_TEMPLATE``).
TEMPLATE_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "templates")
#: The feedback template's name (nbconvert's ``HTMLExporter.template_name``; its file is NAME.html.j2, so that it
#: can extend nbgrader's own ``index.html.j2``).
FEEDBACK_TEMPLATE = "uwtutor_feedback"


class SubmissionWithoutGradeCells(RuntimeError):
    """A submitted notebook lacks test cells the assignment grades: nbgrader would score them 0 in silence."""


class RequireGradeCells(pp.NbGraderPreprocessor):
    """Refuse a submission that lacks any autograded test cell of its notebook (matched by nbgrader's
    ``grade_id`` metadata), naming the missing cells and the likely cause, instead of letting it score 0.

    Runs in ``nbgrader autograde`` before ``OverwriteCells`` (``configure`` puts it there). nbgrader logs the
    exception with the submission's name, skips that submission, goes on with the others and exits with an
    error at the end.
    """

    def preprocess(self, nb: Any, resources: dict) -> tuple[Any, dict]:
        meta = resources["nbgrader"]
        with Gradebook(meta["db_url"]) as gradebook:
            notebook = gradebook.find_notebook(meta["notebook"], meta["assignment"])
            tests = sorted(cell.name for cell in notebook.grade_cells if cell.cell_type == "code")
        present = {cell.metadata["nbgrader"].get("grade_id") for cell in nb.cells
                   if isinstance(cell.metadata.get("nbgrader"), dict)}
        missing = [name for name in tests if name not in present]
        if missing:
            kind = ("has no nbgrader metadata at all" if not present - {None} else
                    f"lacks {len(missing)} of the {len(tests)} test cells")
            raise SubmissionWithoutGradeCells(
                f"the submission {meta.get('student', '?')}/{meta['assignment']}/{meta['notebook']}.ipynb {kind} "
                f"(missing: {', '.join(missing)}): nbgrader would run none of their tests and score them 0. "
                "It was probably made by an older uwtutor (whose `uwtutor labs` wrote no metadata) or typed "
                "again by hand. Ask the student to copy their answers into a fresh copy (`uwtutor labs DIR "
                "--lab NAME` of this uwtutor, or nbgrader's release) and submit it again; this submission was not "
                "graded.")
        return nb, resources


def configure(c: Any) -> None:
    """Set the labs' course settings on the traitlets config ``c`` of an ``nbgrader_config.py``.

    Parameters
    ----------
    c : traitlets.config.Config
        The configuration ``get_config()`` returns in ``nbgrader_config.py``.

    Examples
    --------
    >>> from traitlets.config import Config
    >>> c = Config()
    >>> configure(c)
    >>> c.HTMLExporter.template_name
    'uwtutor_feedback'
    >>> [p.__name__ for p in c.Autograde.sanitize_preprocessors][3:5]
    ['RequireGradeCells', 'OverwriteCells']
    >>> c.ClearSolutions.code_stub["python"].splitlines()[0]
    '# YOUR CODE HERE'
    """
    c.ClearSolutions.code_stub = {"python": "\n".join(CODE_STUB)}
    c.Autograde.sanitize_preprocessors = [pp.ClearOutput, pp.DeduplicateIds, pp.OverwriteKernelspec,
                                          RequireGradeCells, pp.OverwriteCells, pp.CheckCellMetadata]
    nbgrader_templates = os.path.join(os.path.dirname(os.path.abspath(nbgrader.__file__)), "server_extensions",
                                      "formgrader", "templates")
    c.HTMLExporter.template_name = FEEDBACK_TEMPLATE
    c.HTMLExporter.template_file = f"{FEEDBACK_TEMPLATE}.html.j2"
    c.HTMLExporter.extra_template_basedirs = [TEMPLATE_DIR, nbgrader_templates]
