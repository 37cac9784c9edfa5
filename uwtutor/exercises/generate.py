"""Student versions of the exercise sources: solutions replaced, hidden tests removed, outputs cleared.

The sources (``exercises/*.ipynb`` in the repository) hold the solutions between nbgrader's markers, each marker on a
line of its own::

    speed = None
    ### BEGIN SOLUTION
    speed = 1448.96 + 4.591 * T + ...
    ### END SOLUTION

In the student version the region between (and including) the markers of a code cell becomes, at the indentation of
the ``BEGIN`` marker::

    # YOUR CODE HERE
    raise NotImplementedError(STUB_MESSAGE)

(the message written out: ``STUB_MESSAGE`` below),

so that running the student notebook stops at the first unanswered exercise; in a Markdown cell it becomes
``YOUR ANSWER HERE``. Regions between ``### BEGIN HIDDEN TESTS`` and ``### END HIDDEN TESTS`` are removed (a cell
left empty by that is dropped). Outputs and execution counts are cleared and the metadata reduced to the kernel's
name and the cells' tags. Since the markers are nbgrader's, an instructor can also hand the sources to nbgrader.
"""

from __future__ import annotations

import copy
import json
import os
import re
import sys
import tempfile
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import nbformat

__all__ = [
    "make_student_version",
    "write_student_versions",
    "list_exercise_sources",
    "exercise_source_dir",
    "lab_source_dir",
    "list_lab_sources",
    "write_lab_versions",
    "WriteReport",
    "ExerciseSourceError",
    "CODE_STUB",
    "STUB_MESSAGE",
    "TEXT_STUB",
    "KERNELSPEC",
    "python_language_info",
]

#: The message of the stub's ``NotImplementedError``: what the student is to do.
STUB_MESSAGE = "not answered yet: write your code in place of this line, then run the cell again"
#: The lines that replace a solution region in a code cell (nbgrader's stub, with a message that says what to do).
CODE_STUB = ("# YOUR CODE HERE", f"raise NotImplementedError({STUB_MESSAGE!r})")
#: The line that replaces a solution region in a Markdown cell.
TEXT_STUB = "YOUR ANSWER HERE"

#: The kernelspec of the Python kernel as JupyterLab writes it (ipykernel's ``python3``). A notebook that carries
#: another ``display_name`` (``"Python 3"``) is rewritten, and so marked modified, as soon as JupyterLab opens it.
KERNELSPEC = {"display_name": "Python 3 (ipykernel)", "language": "python", "name": "python3"}


def python_language_info() -> dict[str, Any]:
    """The ``language_info`` that ipykernel reports for this Python, as JupyterLab writes it into a notebook.

    JupyterLab replaces a notebook's ``language_info`` by the kernel's when the kernel starts, and a notebook whose
    ``language_info`` differs (a shorter one, another Python version) is marked modified before the student has done
    anything. The student versions carry this one, made by the Python that writes them (``uwtutor exercises`` runs in
    the student's environment, whose Python the kernel is).

    Returns
    -------
    dict
        ``name``, ``version``, ``mimetype``, ``codemirror_mode``, ``pygments_lexer``, ``nbconvert_exporter``,
        ``file_extension``.

    Examples
    --------
    >>> info = python_language_info()
    >>> info["name"], info["file_extension"], info["codemirror_mode"]["name"]
    ('python', '.py', 'ipython')
    """
    return {"codemirror_mode": {"name": "ipython", "version": sys.version_info[0]}, "file_extension": ".py",
            "mimetype": "text/x-python", "name": "python", "nbconvert_exporter": "python",
            "pygments_lexer": "ipython3", "version": sys.version.split()[0]}


_MARKER = re.compile(r"^\s*#+\s*(BEGIN|END)\s+(SOLUTION|HIDDEN TESTS)\s*$")
_MARKER_TEXT = re.compile(r"(BEGIN|END)\s+(SOLUTION|HIDDEN TESTS)")


class ExerciseSourceError(ValueError):
    """A source notebook's markers are malformed (unmatched, nested, or not on a line of their own).

    Examples
    --------
    >>> import nbformat
    >>> cell = nbformat.v4.new_code_cell("### BEGIN SOLUTION\\nx = 1")
    >>> source = nbformat.v4.new_notebook(cells=[cell])
    >>> try:
    ...     make_student_version(source)
    ... except ExerciseSourceError as exc:
    ...     print(exc)
    the notebook, cell 0 (code): '### BEGIN SOLUTION' without a matching '### END SOLUTION'
    """


def _strip_regions(source: str, *, cell_type: str, where: str) -> tuple[str, bool]:
    """Replace solution regions by the stub and drop hidden-test regions; return the new source and if it changed."""
    new_lines: list[str] = []
    region: str | None = None  # "SOLUTION" or "HIDDEN TESTS" while inside one
    changed = False
    lines = source.split("\n")
    for number, line in enumerate(lines, start=1):
        match = _MARKER.match(line)
        if match is None:
            if _MARKER_TEXT.search(line) and "###" in line:
                raise ExerciseSourceError(f"{where}, line {number}: a marker must stand on a line of its own "
                                          f"(for example '### BEGIN SOLUTION'); got {line.strip()!r}")
            if region is None:
                new_lines.append(line)
            continue
        kind, what = match.group(1), match.group(2)
        changed = True
        if kind == "BEGIN":
            if region is not None:
                raise ExerciseSourceError(f"{where}, line {number}: '### BEGIN {what}' inside an open "
                                          f"'### BEGIN {region}' region (regions cannot be nested)")
            region = what
            if what == "SOLUTION":
                indent = line[:len(line) - len(line.lstrip())]
                if cell_type == "code":
                    new_lines.extend(indent + stub for stub in CODE_STUB)
                else:
                    new_lines.append(indent + TEXT_STUB)
        else:
            if region != what:
                opened = f"an open '### BEGIN {region}' region" if region else "no open region"
                raise ExerciseSourceError(f"{where}, line {number}: '### END {what}' with {opened}")
            region = None
    if region is not None:
        raise ExerciseSourceError(f"{where}: '### BEGIN {region}' without a matching '### END {region}'")
    new_source = "\n".join(new_lines)
    if changed:
        new_source = re.sub(r"\n{3,}", "\n\n", new_source).strip("\n")
    return new_source, changed


def _read(source_nb: Any) -> tuple[nbformat.NotebookNode, str]:
    """The notebook and its label; a file that is not a valid notebook is an ``ExerciseSourceError`` naming it."""
    if isinstance(source_nb, (str, os.PathLike)):
        path = Path(source_nb)
        label = path.name
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except UnicodeDecodeError:
            raise ExerciseSourceError(f"{label} is not a notebook: it is not UTF-8 text") from None
        except json.JSONDecodeError as exc:
            raise ExerciseSourceError(f"{label} is not a notebook: its JSON is invalid ({exc.msg}, line "
                                      f"{exc.lineno})") from None
    elif isinstance(source_nb, dict):
        data, label = copy.deepcopy(source_nb), "the notebook"
    else:
        raise TypeError(f"source_nb must be a notebook (nbformat.NotebookNode) or a path; got "
                        f"{type(source_nb).__name__}")
    if not isinstance(data, dict) or not isinstance(data.get("cells"), list):
        kind = "a " + type(data).__name__ if not isinstance(data, dict) else "an object without a list of 'cells'"
        raise ExerciseSourceError(f"{label} is not a notebook: its JSON is {kind}; a notebook is an object with "
                                  "'cells', 'metadata', 'nbformat'")
    try:
        nb = nbformat.reads(json.dumps(data), as_version=4)
        nbformat.validate(nb)
    except Exception as exc:      # nbformat's ValidationError, or a KeyError/TypeError on a malformed dict
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ExerciseSourceError(f"{label} is not a valid notebook (nbformat 4 schema): {first[:200]}") from None
    return nb, label


def make_student_version(source_nb: nbformat.NotebookNode | Mapping[str, Any] | str | os.PathLike[str], *,
                         nbgrader: bool = False) -> nbformat.NotebookNode:
    """Make the student version of an exercise source notebook.

    Parameters
    ----------
    source_nb : nbformat.NotebookNode, dict, str or path
        The source notebook (with solutions), or the path of its file. It is not modified.
    nbgrader : bool, default False
        Keep each cell's ``nbgrader`` metadata (grade id, points, locked), and lock the cells nbgrader's release
        locks (``editable``/``deletable`` false), as ``nbgrader generate_assignment`` would: what a lab's copy
        needs so that ``nbgrader autograde`` finds its answer and test cells (a copy without it scores 0).

    Returns
    -------
    nbformat.NotebookNode
        A new notebook: every ``### BEGIN SOLUTION`` ... ``### END SOLUTION`` region replaced by ``# YOUR CODE
        HERE`` and ``raise NotImplementedError(STUB_MESSAGE)`` (code) or ``YOUR ANSWER HERE`` (Markdown); every
        ``### BEGIN HIDDEN TESTS`` ... ``### END HIDDEN TESTS`` region removed, and cells left empty by that
        dropped; outputs and execution counts cleared; notebook metadata reduced to ``kernelspec`` and
        ``language_info`` (for Python, as JupyterLab writes them: ``KERNELSPEC`` and ``python_language_info()``, so
        that opening the notebook does not mark it modified), cell metadata to ``tags`` (and, with ``nbgrader``,
        nbgrader's cell metadata).

    Raises
    ------
    ValueError
        An ``ExerciseSourceError`` (a ``ValueError``) if a marker is unmatched, nested, or not on a line of its own;
        the message names the cell and the line.

    Examples
    --------
    >>> import nbformat
    >>> source = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(
    ...     "speed = None\\n### BEGIN SOLUTION\\nspeed = 1500.0\\n### END SOLUTION")])
    >>> print(make_student_version(source).cells[0].source)  # doctest: +ELLIPSIS
    speed = None
    # YOUR CODE HERE
    raise NotImplementedError('not answered yet: ...')
    >>> source.cells[0].metadata["nbgrader"] = {"grade_id": "A_answer", "solution": True,
    ...     "grade": False, "locked": False, "schema_version": 3, "task": False}
    >>> make_student_version(source, nbgrader=True).cells[0].metadata["nbgrader"]["grade_id"]
    'A_answer'
    >>> "nbgrader" in make_student_version(source).cells[0].metadata
    False
    """
    nb, label = _read(source_nb)
    nb = copy.deepcopy(nb)
    cells = []
    for index, cell in enumerate(nb.cells):
        where = f"{label}, cell {index} ({cell.cell_type})"
        if cell.cell_type in ("code", "markdown"):
            source, changed = _strip_regions(cell.source, cell_type=cell.cell_type, where=where)
            if changed and not source.strip():
                continue  # the cell held only hidden tests
            cell.source = source
        if cell.cell_type == "code":
            cell.outputs = []
            cell.execution_count = None
        tags = cell.get("metadata", {}).get("tags")
        grading = dict(cell.get("metadata", {}).get("nbgrader") or {}) if nbgrader else {}
        cell.metadata = nbformat.NotebookNode({"tags": list(tags)} if tags else {})
        if grading:
            grading.pop("checksum", None)           # autograde takes the checksums from its gradebook
            cell.metadata["nbgrader"] = nbformat.NotebookNode(grading)
            # nbgrader's LockCells: given and test cells cannot be edited or deleted, answer cells not deleted
            if grading.get("locked") or (grading.get("grade") and not grading.get("solution")):
                cell.metadata["editable"] = False
                cell.metadata["deletable"] = False
            elif grading.get("solution"):
                cell.metadata["deletable"] = False
        cells.append(cell)
    nb.cells = cells
    kernelspec = dict(nb.metadata.get("kernelspec") or KERNELSPEC)
    language = (nb.metadata.get("language_info") or {}).get("name", kernelspec.get("language", "python"))
    if kernelspec.get("name") == KERNELSPEC["name"]:        # Python: as JupyterLab and ipykernel write them
        kernelspec, language_info = dict(KERNELSPEC), python_language_info()
    else:
        language_info = {"name": language}
    nb.metadata = nbformat.NotebookNode({
        "kernelspec": nbformat.NotebookNode(kernelspec),
        "language_info": nbformat.NotebookNode(language_info),
    })
    nbformat.validate(nb)
    return nb


# ---------------------------------------------------------------------------------------------------------------------
# finding the sources and writing the student versions
# ---------------------------------------------------------------------------------------------------------------------
def exercise_source_dir() -> Path:
    """The directory of the exercise sources: shipped in the installed package, or ``exercises/`` of a clone.

    Returns
    -------
    pathlib.Path
        ``uwtutor/_data/exercises`` inside the installed package when it is there (a wheel install: the build copies
        the repository's ``exercises/`` there), otherwise the repository's ``exercises/`` directory beside the
        package (an editable install from a clone, ``pip install -e .``).

    Raises
    ------
    FileNotFoundError
        If neither exists: pass the source directory explicitly instead (``--source`` on the command line).

    Examples
    --------
    >>> exercise_source_dir().name
    'exercises'
    """
    import uwtutor

    package = Path(uwtutor.__file__).resolve().parent
    for directory in (package / "_data" / "exercises", package.parent / "exercises"):
        if directory.is_dir():
            return directory
    raise FileNotFoundError(
        f"the exercise sources were found neither in the installed package ({package / '_data' / 'exercises'}) "
        f"nor in a clone of the repository ({package.parent / 'exercises'}). Reinstall uwtutor (pip install "
        "uwtutor, or pip install -e . in a clone), or pass the directory that holds the source notebooks "
        "(--source DIR on the command line, source_dir=... in Python).")


def list_exercise_sources(source_dir: str | os.PathLike[str] | None = None) -> list[Path]:
    """The exercise source notebooks, sorted by name.

    Parameters
    ----------
    source_dir : str or path, optional
        Where the sources are; by default the repository's ``exercises/`` directory.

    Returns
    -------
    list of pathlib.Path
        The ``*.ipynb`` files directly in ``source_dir`` (hidden files and checkpoints left out).

    Raises
    ------
    FileNotFoundError
        If the directory does not exist or holds no notebook.

    Examples
    --------
    >>> list_exercise_sources()[0].name
    'ch01_positioning_and_errors.ipynb'
    """
    directory = exercise_source_dir() if source_dir is None else Path(source_dir)
    if not directory.is_dir():
        what = "is a file, not a directory" if directory.is_file() else "does not exist"
        raise FileNotFoundError(f"the exercise source directory {directory} {what}")
    sources = sorted(p for p in directory.glob("*.ipynb") if not p.name.startswith("."))
    if not sources:
        raise FileNotFoundError(f"no exercise notebooks (*.ipynb) in {directory}")
    return sources


@dataclass(frozen=True)
class WriteReport:
    """What ``write_student_versions`` did.

    ``dest_dir`` is the directory the student versions went to; ``written`` the files written (new, or overwritten
    with ``overwrite=True``); ``skipped`` the files left alone because they already existed; ``overwritten`` the files
    among ``written`` that existed before. All are ``pathlib.Path`` objects, the last three in tuples. ``str(report)``
    and ``report.summary()`` describe them for a person.

    Examples
    --------
    >>> from pathlib import Path
    >>> report = WriteReport(Path("my-work"), written=(Path("my-work/ch01.ipynb"),),
    ...                      skipped=(Path("my-work/ch02.ipynb"),))
    >>> print("\\n".join(report.summary().splitlines()[:4]))
    Wrote 1 notebook to my-work:
      ch01.ipynb
    Skipped 1 notebook that already exists (your work is never overwritten):
      ch02.ipynb
    """

    dest_dir: Path
    written: tuple[Path, ...] = field(default_factory=tuple)
    skipped: tuple[Path, ...] = field(default_factory=tuple)
    overwritten: tuple[Path, ...] = field(default_factory=tuple)

    def summary(self, *, force_hint: str | None = "pass --force") -> str:
        """A human-readable summary: what was written, what was skipped and how to get a fresh copy.

        Parameters
        ----------
        force_hint : str or None
            How to overwrite, as the user would type it; ``None`` to leave that advice out.

        Returns
        -------
        str
            Several lines of text.
        """
        lines = []

        def plural(n: int) -> str:
            return f"{n} notebook" + ("" if n == 1 else "s")

        if self.written:
            lines.append(f"Wrote {plural(len(self.written))} to {self.dest_dir}:")
            lines.extend(f"  {self._shown(p)}" + ("  (overwritten)" if p in self.overwritten else "")
                         for p in self.written)
        else:
            lines.append(f"Wrote nothing to {self.dest_dir}.")
        if self.skipped:
            lines.append(f"Skipped {plural(len(self.skipped))} that already exist"
                         + ("s" if len(self.skipped) == 1 else "") + " (your work is never overwritten):")
            lines.extend(f"  {self._shown(p)}" for p in self.skipped)
            advice = ("To get a fresh copy of a skipped notebook, rename or delete your copy and run this again, or "
                      "write to another directory")
            if force_hint:
                advice += f", or {force_hint} to overwrite it (your changes to it are lost)"
            lines.append(advice + ".")
        return "\n".join(lines)

    def _shown(self, path: Path) -> str:
        """A written or skipped file as the summary shows it: relative to ``dest_dir`` (``lab/lab.ipynb``)."""
        try:
            return path.relative_to(self.dest_dir).as_posix()
        except ValueError:
            return path.name

    def __str__(self) -> str:
        return self.summary(force_hint="pass overwrite=True")


def _write_new(path: Path, text: str) -> bool:
    """Create ``path`` with ``text``; return False (and leave it alone) if it already exists."""
    try:
        with open(path, "x", encoding="utf-8") as handle:
            handle.write(text)
    except FileExistsError:
        return False
    return True


def _write_replace(path: Path, text: str) -> None:
    """Write ``path`` atomically (a temporary file in the same directory, then a rename)."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as handle:
            handle.write(text)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _as_dest(dest_dir: Any) -> Path:
    """The destination directory, or a one-line error: empty, too long a name, or not a path."""
    if not isinstance(dest_dir, (str, os.PathLike)):
        raise TypeError(f"dest_dir must be a directory path; got {type(dest_dir).__name__}")
    text = os.fspath(dest_dir)
    if isinstance(text, bytes):
        text = os.fsdecode(text)
    if not text.strip():
        raise ValueError("dest_dir is empty: give the folder to write into (e.g. my-work); an empty name would "
                         "write into the current directory")
    dest = Path(text)
    for part in dest.parts:
        if len(os.fsencode(part)) > 255:
            raise ValueError(f"dest_dir has a folder name of {len(part)} characters ({part[:20]}...); file systems "
                             "allow at most 255 bytes per name: choose a shorter one")
    try:
        exists, is_dir = dest.exists(), dest.is_dir()
    except OSError as exc:
        raise ValueError(f"dest_dir {text[:80]!r} cannot be used: {exc.strerror or exc}") from None
    if exists and not is_dir:
        raise NotADirectoryError(f"{dest} exists and is not a directory")
    return dest


def write_student_versions(source_dir: str | os.PathLike[str] | None, dest_dir: str | os.PathLike[str], *,
                           overwrite: bool = False, names: Iterable[str] | None = None) -> WriteReport:
    """Write the student version of every exercise source into ``dest_dir``, never clobbering existing files.

    Every student version is made before anything is written, so a malformed source writes nothing.

    Parameters
    ----------
    source_dir : str, path or None
        The directory of the sources; ``None`` for the repository's ``exercises/`` directory.
    dest_dir : str or path
        Where to write (created if needed). It must not be the source directory.
    overwrite : bool
        Replace files that already exist (default: leave them alone and report them as skipped).
    names : iterable of str, optional
        Only these source file names (default: all).

    Returns
    -------
    WriteReport
        The files written and the files skipped.

    Raises
    ------
    FileNotFoundError
        If there are no sources (see ``list_exercise_sources``) or a requested name is not among them.
    NotADirectoryError
        If ``dest_dir`` exists and is not a directory.
    ValueError
        If ``dest_dir`` is the source directory, or a source's markers are malformed (``ExerciseSourceError``).

    Examples
    --------
    >>> import shutil, tempfile
    >>> from pathlib import Path
    >>> import nbformat
    >>> tmp = Path(tempfile.mkdtemp())
    >>> (tmp / "sources").mkdir()
    >>> cell = nbformat.v4.new_code_cell(
    ...     "x = None\\n### BEGIN SOLUTION\\nx = 1\\n### END SOLUTION")
    >>> nbformat.write(nbformat.v4.new_notebook(cells=[cell]), tmp / "sources" / "ex1.ipynb")
    >>> [p.name for p in write_student_versions(tmp / "sources", tmp / "my-work").written]
    ['ex1.ipynb']
    >>> # never overwritten
    >>> [p.name for p in write_student_versions(tmp / "sources", tmp / "my-work").skipped]
    ['ex1.ipynb']
    >>> shutil.rmtree(tmp)
    """
    sources = list_exercise_sources(source_dir)
    if names is not None:
        wanted = set(names)
        missing = wanted - {p.name for p in sources}
        if missing:
            raise FileNotFoundError(f"no exercise source named {', '.join(sorted(missing))}; "
                                    f"available: {', '.join(p.name for p in sources)}")
        sources = [p for p in sources if p.name in wanted]
    dest = _as_dest(dest_dir)
    if dest.exists() and dest.resolve() == sources[0].parent.resolve():
        raise ValueError(f"refusing to write student versions into the source directory {dest}")
    rendered = [(src.name, nbformat.writes(make_student_version(src)) + "\n") for src in sources]
    dest.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    skipped: list[Path] = []
    overwritten: list[Path] = []
    for filename, text in rendered:
        target = dest / filename
        if overwrite:
            if target.exists():
                overwritten.append(target)
            _write_replace(target, text)
            written.append(target)
        elif _write_new(target, text):
            written.append(target)
        else:
            skipped.append(target)
    return WriteReport(dest_dir=dest, written=tuple(written), skipped=tuple(skipped), overwritten=tuple(overwritten))


# ---------------------------------------------------------------------------------------------------------------------
# labs: one folder per lab, each an nbgrader assignment
# ---------------------------------------------------------------------------------------------------------------------
def lab_source_dir(source_dir: str | os.PathLike[str] | None = None) -> Path:
    """The directory that holds the lab folders: ``labs/`` inside the exercise sources.

    Parameters
    ----------
    source_dir : str or path, optional
        The exercise source directory (default: ``exercise_source_dir()``).

    Returns
    -------
    pathlib.Path
        ``source_dir / "labs"``.

    Raises
    ------
    FileNotFoundError
        If the exercise sources cannot be found (see ``exercise_source_dir``).

    Examples
    --------
    >>> lab_source_dir("exercises").as_posix()
    'exercises/labs'
    """
    return (exercise_source_dir() if source_dir is None else Path(source_dir)) / "labs"


def list_lab_sources(labs_dir: str | os.PathLike[str] | None = None) -> dict[str, list[Path]]:
    """The labs and their notebooks: every folder of ``labs_dir`` that holds at least one notebook.

    Each lab folder is one nbgrader assignment (copy it to ``source/NAME/`` of an nbgrader course). Other folders
    (for example the instructor notes) and hidden files are left out.

    Parameters
    ----------
    labs_dir : str or path, optional
        Where the lab folders are (default: ``lab_source_dir()``).

    Returns
    -------
    dict
        Lab name (its folder's name) -> its ``*.ipynb`` files, sorted; the labs sorted by name.

    Raises
    ------
    FileNotFoundError
        If the directory does not exist or holds no lab.

    Examples
    --------
    >>> labs = list_lab_sources()
    >>> [p.name for p in labs["ekf_consistency"]]
    ['ekf_consistency.ipynb']
    """
    directory = lab_source_dir() if labs_dir is None else Path(labs_dir)
    if not directory.is_dir():
        what = "is a file, not a directory" if directory.is_file() else "does not exist"
        raise FileNotFoundError(f"the lab source directory {directory} {what}")
    labs = {}
    for folder in sorted(p for p in directory.iterdir() if p.is_dir() and not p.name.startswith((".", "_"))):
        notebooks = sorted(p for p in folder.glob("*.ipynb") if not p.name.startswith("."))
        if notebooks:
            labs[folder.name] = notebooks
    if not labs:
        raise FileNotFoundError(f"no labs (folders holding *.ipynb) in {directory}")
    return labs


def write_lab_versions(labs_dir: str | os.PathLike[str] | None, dest_dir: str | os.PathLike[str], *,
                       overwrite: bool = False, names: Iterable[str] | None = None) -> WriteReport:
    """Write the student version of every lab into ``dest_dir/NAME/``, never clobbering existing files.

    The student version of a lab notebook is made as for the exercises, with nbgrader's cell metadata kept
    (``make_student_version(..., nbgrader=True)``), so that ``nbgrader autograde`` grades a copy made here exactly
    as one released by ``nbgrader generate_assignment``; other
    files of a lab folder (data, figures) are copied as they are, also never over existing ones. Every notebook is
    converted before anything is written, so a malformed source writes nothing.

    Parameters
    ----------
    labs_dir : str, path or None
        The directory of the lab folders; ``None`` for ``lab_source_dir()``.
    dest_dir : str or path
        Where to write (created if needed); each lab goes into its own sub-directory.
    overwrite : bool
        Replace files that already exist (default: leave them alone and report them as skipped).
    names : iterable of str, optional
        Only these labs (folder names; default: all).

    Returns
    -------
    WriteReport
        The files written and skipped (paths inside ``dest_dir``).

    Raises
    ------
    FileNotFoundError
        If there are no labs or a requested lab does not exist.
    NotADirectoryError
        If ``dest_dir`` exists and is not a directory.
    ValueError
        If ``dest_dir`` is the lab source directory, or a source's markers are malformed.

    Examples
    --------
    >>> import shutil, tempfile
    >>> from pathlib import Path
    >>> import nbformat
    >>> tmp = Path(tempfile.mkdtemp())
    >>> (tmp / "labs" / "demo").mkdir(parents=True)
    >>> nbformat.write(nbformat.v4.new_notebook(), tmp / "labs" / "demo" / "demo.ipynb")
    >>> _ = (tmp / "labs" / "demo" / "data.csv").write_text("t,r\\n0,100\\n")
    >>> report = write_lab_versions(tmp / "labs", tmp / "course")
    >>> sorted(p.relative_to(tmp / "course").as_posix() for p in report.written)
    ['demo/data.csv', 'demo/demo.ipynb']
    >>> shutil.rmtree(tmp)
    """
    directory = lab_source_dir() if labs_dir is None else Path(labs_dir)
    labs = list_lab_sources(directory)
    if names is not None:
        wanted = set(names)
        missing = wanted - set(labs)
        if missing:
            raise FileNotFoundError(f"no lab named {', '.join(sorted(missing))}; available: {', '.join(labs)}")
        labs = {name: nbs for name, nbs in labs.items() if name in wanted}
    dest = _as_dest(dest_dir)
    if dest.exists() and dest.resolve() == directory.resolve():
        raise ValueError(f"refusing to write student versions into the lab source directory {dest}")
    planned: list[tuple[Path, str | bytes]] = []
    for name, notebooks in labs.items():
        for nb_path in notebooks:
            planned.append((Path(name) / nb_path.name,
                            nbformat.writes(make_student_version(nb_path, nbgrader=True)) + "\n"))
        for extra in sorted((directory / name).rglob("*")):
            relative = extra.relative_to(directory / name)
            if (extra.is_file() and extra.suffix != ".ipynb" and ".ipynb_checkpoints" not in relative.parts
                    and "__pycache__" not in relative.parts and not relative.name.startswith(".")):
                planned.append((Path(name) / relative, extra.read_bytes()))
    written: list[Path] = []
    skipped: list[Path] = []
    overwritten: list[Path] = []
    for relative, content in planned:
        target = dest / relative
        target.parent.mkdir(parents=True, exist_ok=True)
        text = content if isinstance(content, str) else None
        if overwrite:
            if target.exists():
                overwritten.append(target)
            if text is not None:
                _write_replace(target, text)
            else:
                target.write_bytes(content)  # type: ignore[arg-type]
            written.append(target)
        elif text is not None and _write_new(target, text):
            written.append(target)
        elif text is None and not target.exists():
            with open(target, "xb") as handle:
                handle.write(content)  # type: ignore[arg-type]
            written.append(target)
        else:
            skipped.append(target)
    return WriteReport(dest_dir=dest, written=tuple(written), skipped=tuple(skipped), overwritten=tuple(overwritten))
