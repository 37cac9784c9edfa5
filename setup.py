"""Build hook: the wheel carries the exercise and lab sources as package data.

All metadata is in ``pyproject.toml``. The sources live in the repository's top-level ``exercises/`` directory (where
instructors find them and where nbgrader's ``source/`` layout is mirrored), outside the ``uwtutor`` package; a plain
``package-data`` entry cannot reach them. This ``build_py`` copies that tree into the built package as
``uwtutor/_data/exercises/`` (same layout, ``labs/`` included), so that ``uwtutor exercises DIR`` works after
``pip install`` of the wheel. An editable install (``pip install -e .``) reads ``exercises/`` in the clone instead.
The sdist carries ``exercises/`` (``MANIFEST.in``), so a wheel built from the sdist has them too.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

SOURCE_DIR = "exercises"
TARGET = ("uwtutor", "_data", "exercises")
#: Never shipped: hidden files (``.ipynb_checkpoints``), Python caches, an nbgrader gradebook left by a trial run.
IGNORED = shutil.ignore_patterns(".*", "__pycache__", "*.pyc", "gradebook.db")


class BuildPyWithExerciseSources(build_py):
    """``build_py`` that also copies ``exercises/`` into ``<build_lib>/uwtutor/_data/exercises``."""

    def run(self) -> None:
        super().run()
        if self.editable_mode:          # the clone's exercises/ is read in place
            return
        source = Path(SOURCE_DIR)
        if not source.is_dir():
            raise FileNotFoundError(f"{source.resolve()} is missing: the wheel must carry the exercise sources "
                                    "(build from a clone of the repository or from its sdist)")
        target = Path(self.build_lib, *TARGET)
        if target.exists():
            shutil.rmtree(target)
        shutil.copytree(source, target, ignore=IGNORED)

    def get_outputs(self, include_bytecode: bool = True) -> list[str]:
        outputs = super().get_outputs(include_bytecode)
        target = Path(self.build_lib, *TARGET)
        if target.is_dir():
            outputs += [os.fspath(p) for p in sorted(target.rglob("*")) if p.is_file()]
        return outputs


setup(cmdclass={"build_py": BuildPyWithExerciseSources})
