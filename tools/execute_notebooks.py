"""Re-execute the book's notebooks in place so that their committed outputs match the library.

Usage: ``python tools/execute_notebooks.py book [more notebooks or folders...]``

Every chapter is a notebook whose outputs are committed and compared by nbval, so after changing a chapter or
the library run ``make notebooks`` and commit the result. Execution is deterministic by construction (seeded
``numpy.random.default_rng``, no timings in outputs); widget state is stored so the HTML can show widgets.
"""

from __future__ import annotations

import sys
from pathlib import Path

import nbformat
from nbclient import NotebookClient

from uwtutor.exercises.generate import KERNELSPEC


def notebooks_in(paths: list[str]) -> list[Path]:
    found: list[Path] = []
    for name in paths:
        path = Path(name)
        if path.is_dir():
            found.extend(p for p in sorted(path.glob("*.ipynb")) if ".ipynb_checkpoints" not in p.parts)
        elif path.suffix == ".ipynb":
            found.append(path)
        else:
            raise SystemExit(f"not a notebook or a folder of notebooks: {name}")
    return found


def execute(path: Path) -> None:
    nb = nbformat.read(path, as_version=4)
    # The kernelspec as JupyterLab writes it (another display_name, and JupyterLab rewrites it, marking the chapter
    # modified as soon as it is opened); the kernel writes language_info. jupytext's pairing metadata is left over
    # from authoring and nothing reads it.
    nb.metadata["kernelspec"] = dict(KERNELSPEC)
    nb.metadata.pop("jupytext", None)
    client = NotebookClient(nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(path.parent)}},
                            store_widget_state=True)
    client.execute()
    nbformat.write(nb, path)
    print(f"executed {path}")


def main(argv: list[str]) -> int:
    if not argv:
        print(__doc__)
        return 2
    for path in notebooks_in(argv):
        execute(path)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
