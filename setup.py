"""Build hook: the wheel carries the *student versions* of the exercises and labs, never their solutions.

All metadata is in ``pyproject.toml``. The sources live in the repository's top-level ``exercises/`` directory (where
instructors find them and where nbgrader's ``source/`` layout is mirrored), with the solutions and hidden tests marked
the nbgrader way, and the labs' instructor notes in ``exercises/labs/instructor-notes/``. A wheel is what every
student who runs ``pip install uwtutor`` gets, so this ``build_py`` writes into the built package, as
``uwtutor/_data/exercises/``, what the project's own generator (``uwtutor/exercises/generate.py``) makes of them:

- ``chNN_*.ipynb``: the student version of each exercise notebook (solutions replaced by the stub, hidden tests
  removed, outputs cleared);
- ``labs/NAME/NAME.ipynb``: the student version of each lab (and any data file of its folder);

and nothing else: no source notebook, no README (the authors' guide quotes the markers), no instructor note. So
``uwtutor exercises DIR`` and ``uwtutor labs DIR`` work after ``pip install`` of the wheel, and the answers stay with
the instructor, who takes the sources from the repository or from the sdist (``MANIFEST.in`` grafts ``exercises/``).

An editable install (``pip install -e .``) reads ``exercises/`` in the clone instead. The generator is loaded from
its file (the build environment has ``nbformat``, the generator's only dependency, but not numpy and the rest of the
package).
"""

from __future__ import annotations

import importlib.util
import os
import shutil
import sys
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

SOURCE_DIR = "exercises"
GENERATOR = Path("uwtutor", "exercises", "generate.py")
TARGET = ("uwtutor", "_data", "exercises")


def _generator():
    """The project's student-version generator, loaded from its file (not through the ``uwtutor`` package)."""
    spec = importlib.util.spec_from_file_location("_uwtutor_build_generate", GENERATOR)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module        # dataclasses look the module up while it is executed
    spec.loader.exec_module(module)
    return module


class BuildPyWithStudentVersions(build_py):
    """``build_py`` that also writes the student versions of ``exercises/`` into ``<build_lib>/uwtutor/_data``."""

    def run(self) -> None:
        super().run()
        if self.editable_mode:          # the clone's exercises/ is read in place
            return
        source = Path(SOURCE_DIR)
        if not source.is_dir():
            raise FileNotFoundError(f"{source.resolve()} is missing: the wheel is built from the exercise sources "
                                    "(build from a clone of the repository or from its sdist)")
        target = Path(self.build_lib, *TARGET)
        if target.exists():
            shutil.rmtree(target)
        generate = _generator()
        generate.write_student_versions(source, target)
        generate.write_lab_versions(source / "labs", target / "labs")

    def get_outputs(self, include_bytecode: bool = True) -> list[str]:
        outputs = super().get_outputs(include_bytecode)
        target = Path(self.build_lib, *TARGET)
        if target.is_dir():
            outputs += [os.fspath(p) for p in sorted(target.rglob("*")) if p.is_file()]
        return outputs


setup(cmdclass={"build_py": BuildPyWithStudentVersions})
