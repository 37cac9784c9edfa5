# nbgrader_config.py of a course that grades uwtutor's labs: copy it into the course directory (beside source/) and
# set the course's id. `configure` (uwtutor_grader.course, the instructor's grader) sets uwtutor's answer stub for
# the release, refuses in autograde a submission whose test cells lost nbgrader's metadata (instead of a silent 0),
# and names each graded cell of the feedback by its part.
from uwtutor_grader.course import configure

c = get_config()  # noqa: F821 (nbgrader's config loader defines get_config)
c.CourseDirectory.course_id = "uwtutor-labs"
configure(c)
