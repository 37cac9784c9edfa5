"""The ``uwtutor`` command: fresh student copies of the exercise notebooks and of the course labs.

Usage::

    uwtutor exercises DIR [--source SRC] [--force]
    uwtutor labs DIR [--source SRC] [--lab NAME ...] [--force]

writes the student version of every exercise notebook into ``DIR`` (created if needed). A notebook that already
exists in ``DIR`` is never overwritten, so running the command again is safe: it only adds what is missing and says
which files it skipped. ``--force`` overwrites them (the work in them is lost). ``--source`` names the directory of the
solution sources when uwtutor is not installed from a clone of the repository. ``uwtutor labs`` does the same for the
labs, one folder per lab (``DIR/NAME/NAME.ipynb``); ``--lab NAME`` picks labs.

Exit status: 0 on success (also when some files were skipped), 1 when a file cannot be read or written, 2 on a usage
error (unknown option, missing sources, ``DIR`` is a file).
"""

from __future__ import annotations

import argparse
import shutil
import sys
from collections.abc import Sequence
from pathlib import Path

__all__ = ["main", "build_parser"]

_DESCRIPTION = """\
uwtutor: companion command of the textbook "Single-Beacon Underwater Acoustic Navigation".

Use "uwtutor exercises DIR" to get your own copies of the exercise notebooks, and "uwtutor labs DIR"
for the course labs, then open them in JupyterLab."""

_EXERCISES_DESCRIPTION = """\
Write fresh student versions of the exercise notebooks into DIR (created if needed).

Each exercise has an answer cell (write your code below "# YOUR CODE HERE" and delete the
"raise NotImplementedError(...)" line) and a check cell that tells you what is wrong and why.

A notebook that already exists in DIR is never overwritten (it holds your work): it is skipped
and reported. To get a fresh copy, rename or delete yours and run the command again, write to
another directory, or pass --force."""

_EXERCISES_EPILOG = """\
examples:
  uwtutor exercises ./my-work            # first time: writes every notebook
  uwtutor exercises ./my-work            # later: adds only the notebooks you do not have yet
  uwtutor exercises ./my-work --force    # start again from fresh copies (your changes are lost)
  uwtutor exercises ./lab --source path/to/uwtutor/exercises"""


_LABS_DESCRIPTION = """\
Write fresh student versions of the course labs into DIR: one folder per lab, DIR/NAME/NAME.ipynb.

A lab is a graded assignment of about 90 minutes. Answer cells are marked "# YOUR CODE HERE"
(delete the "raise NotImplementedError(...)" line) or "YOUR ANSWER HERE" (a written answer);
the test cell below each answer runs the visible checks. Your instructor may hand out the same
labs through nbgrader instead; then use the copies they give you.

A file that already exists in DIR is never overwritten (it holds your work): it is skipped and
reported. To get a fresh copy, rename or delete yours and run the command again, or pass --force."""

_LABS_EPILOG = """\
examples:
  uwtutor labs ./labs                          # every lab
  uwtutor labs ./labs --lab ekf_consistency    # one lab
  uwtutor labs ./labs --source path/to/uwtutor/exercises/labs"""



def _dir_argument(text: str) -> Path:
    """The DIR argument: a folder name (an empty one would silently mean the current directory)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("DIR is empty: give the folder to write into, e.g. my-work")
    return Path(text)

def _version() -> str:
    try:
        from uwtutor import __version__
    except ImportError:  # pragma: no cover - the package is always importable when this runs
        return "unknown"
    return __version__


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``uwtutor`` command.

    Returns
    -------
    argparse.ArgumentParser
        The parser, with two sub-commands, ``exercises`` and ``labs``.

    Examples
    --------
    >>> args = build_parser().parse_args(["labs", "my-labs", "--lab", "ekf_consistency"])
    >>> args.command, args.dir.name, args.lab, args.force
    ('labs', 'my-labs', ['ekf_consistency'], False)
    """
    parser = argparse.ArgumentParser(prog="uwtutor", description=_DESCRIPTION,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    commands = parser.add_subparsers(dest="command", title="commands", metavar="COMMAND")
    exercises = commands.add_parser(
        "exercises", help="write fresh student copies of the exercise notebooks into a directory",
        description=_EXERCISES_DESCRIPTION, epilog=_EXERCISES_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    exercises.add_argument("dir", metavar="DIR", type=_dir_argument,
                           help="where to write the notebooks (created if it does not exist)")
    exercises.add_argument("--source", metavar="SRC", type=Path, default=None,
                           help="the directory of the exercise notebooks (sources with solutions, or student "
                                "versions); default: the student versions shipped with uwtutor, or the exercises/ "
                                "directory of the repository uwtutor is installed from")
    exercises.add_argument("--force", action="store_true",
                           help="overwrite notebooks that already exist in DIR (your changes in them are lost)")
    labs = commands.add_parser(
        "labs", help="write fresh student copies of the course labs into a directory (one folder per lab)",
        description=_LABS_DESCRIPTION, epilog=_LABS_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    labs.add_argument("dir", metavar="DIR", type=_dir_argument,
                      help="where to write the labs, DIR/NAME/NAME.ipynb (created if it does not exist)")
    labs.add_argument("--source", metavar="SRC", type=Path, default=None,
                      help="the directory of the lab folders (sources or student versions); default: the "
                           "student versions shipped with uwtutor, or exercises/labs/ of the "
                           "repository uwtutor is installed from")
    labs.add_argument("--lab", metavar="NAME", action="append", default=None,
                      help="only this lab (repeat for several); default: every lab")
    labs.add_argument("--force", action="store_true",
                      help="overwrite files that already exist in DIR (your changes in them are lost)")
    return parser


def jupyterlab_available() -> bool:
    """Whether JupyterLab can be started from this environment (``jupyter-lab`` beside Python, or on ``PATH``)."""
    return Path(sys.executable).with_name("jupyter-lab").exists() or shutil.which("jupyter-lab") is not None


def _next_step(dest: Path, then: str) -> str:
    """What to do after writing the notebooks: open them in JupyterLab, or first install it."""
    if jupyterlab_available():
        return f"Next: open them in JupyterLab (jupyter lab {dest}) and {then}."
    return (f"Next: open them in JupyterLab and {then}. JupyterLab is not installed in this environment: "
            f'install it with pip install "uwtutor[lab]" (JupyterLab, a Python kernel, MyST and the widgets), '
            f"then run jupyter lab {dest}")


def _error(message: str, command: str = "exercises") -> None:
    print(f"uwtutor {command}: error: {message}", file=sys.stderr)


def _exercises(args: argparse.Namespace) -> int:
    from .generate import ExerciseSourceError, exercise_source_dir, list_exercise_sources, write_student_versions

    try:
        source_dir = args.source if args.source is not None else exercise_source_dir()
        list_exercise_sources(source_dir)
    except FileNotFoundError as exc:
        _error(str(exc))
        return 2
    dest: Path = args.dir
    try:
        report = write_student_versions(source_dir, dest, overwrite=args.force)
    except ExerciseSourceError as exc:
        _error(f"a source notebook is malformed: {exc}")
        return 1
    except (ValueError, NotADirectoryError) as exc:     # a bad DIR: the user's argument, exit status 2
        _error(str(exc))
        return 2
    except OSError as exc:
        _error(f"could not write the notebooks: {exc}")
        return 1
    print(report.summary(force_hint=f"run 'uwtutor exercises {dest} --force'"))
    if report.written:
        print(_next_step(dest, "run the cells in order"))
    return 0


def _labs(args: argparse.Namespace) -> int:
    from .generate import ExerciseSourceError, lab_source_dir, list_lab_sources, write_lab_versions

    try:
        labs_dir = args.source if args.source is not None else lab_source_dir()
        list_lab_sources(labs_dir)
    except FileNotFoundError as exc:
        _error(str(exc), "labs")
        return 2
    dest: Path = args.dir
    try:
        report = write_lab_versions(labs_dir, dest, overwrite=args.force, names=args.lab)
    except ExerciseSourceError as exc:
        _error(f"a lab notebook is malformed: {exc}", "labs")
        return 1
    except FileNotFoundError as exc:
        _error(str(exc), "labs")
        return 2
    except (ValueError, NotADirectoryError) as exc:     # a bad DIR: the user's argument, exit status 2
        _error(str(exc), "labs")
        return 2
    except OSError as exc:
        _error(f"could not write the labs: {exc}", "labs")
        return 1
    print(report.summary(force_hint=f"run 'uwtutor labs {dest} --force'"))
    if report.written:
        print(_next_step(dest, "work through each lab from the top"))
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``uwtutor`` command.

    Parameters
    ----------
    argv : sequence of str, optional
        The arguments (without the program name); default ``sys.argv[1:]``.

    Returns
    -------
    int
        The exit status: 0 on success, 1 when files cannot be read or written, 2 on a usage error. ``--help`` and
        ``--version`` print and return 0; argparse's own messages go to the standard streams as usual.

    Examples
    --------
    >>> import shutil, tempfile
    >>> from pathlib import Path
    >>> import nbformat
    >>> tmp = Path(tempfile.mkdtemp())
    >>> (tmp / "sources").mkdir()
    >>> nbformat.write(nbformat.v4.new_notebook(), tmp / "sources" / "ex1.ipynb")
    >>> argv = ["exercises", str(tmp / "my-work"), "--source", str(tmp / "sources")]
    >>> main(argv)  # doctest: +ELLIPSIS
    Wrote 1 notebook to .../my-work:
      ex1.ipynb
    Next: ...
    0
    >>> # a usage error (an empty DIR), explained on the standard error stream
    >>> main(["exercises", ""])
    2
    >>> shutil.rmtree(tmp)
    """
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help, --version, or a usage error reported by argparse
        return exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
    if args.command is None:
        parser.print_help(sys.stderr)
        return 2
    if args.command == "labs":
        return _labs(args)
    return _exercises(args)


if __name__ == "__main__":  # python -m uwtutor.exercises.cli
    sys.exit(main())
