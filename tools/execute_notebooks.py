"""Re-execute the book's notebooks in place so that their committed outputs match the library.

Usage: ``python tools/execute_notebooks.py book [more notebooks or folders...]``

Every chapter is a notebook whose outputs are committed and compared by nbval, so after changing a chapter or
the library run ``make notebooks`` and commit the result. Execution is deterministic by construction (seeded
``numpy.random.default_rng``, no timings in outputs, no digit that depends on the CPU: ``tools/cpu_variants.py``);
widget state is stored so the HTML can show widgets.
"""

from __future__ import annotations

import sys
from pathlib import Path

import nbformat
from nbclient import NotebookClient

sys.path.insert(0, str(Path(__file__).resolve().parent))
import cpu_variants  # noqa: E402  (tools/cpu_variants.py: the CPU the committed outputs are made on)
from uwtutor.exercises.generate import KERNELSPEC  # noqa: E402


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
    # The kernel plays the CPU of cpu_variants.MAKE; `make test` checks the outputs on another (CHECK).
    client.execute(env=cpu_variants.kernel_env(cpu_variants.MAKE))
    for cell in nb.cells:  # execution timestamps: noise in every diff
        cell.metadata.pop("execution", None)
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
