"""How pytest runs the book's notebooks (nbval): loaded for every notebook under book/, whatever the command line.

``make test`` runs ``pytest --nbval ... book``; so does anyone checking one chapter
(``pytest --nbval --nbval-current-env --nbval-sanitize-with tests/nbval_sanitize.cfg book/ch04_range_only_ekf.ipynb``).
Both get the same two adjustments of nbval, made here rather than in tests/conftest.py, which pytest only
loads when tests/ is collected.
"""

from __future__ import annotations

from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def pytest_configure(config):
    if getattr(config.option, "nbval", False):
        _nbval_runs_cells_like_jupyter()
        _nbval_kernels_play_another_cpu()


def _nbval_kernels_play_another_cpu() -> None:
    """Start nbval's kernels as another CPU than the one the committed outputs were made on.

    ``make notebooks`` writes the outputs with the kernel environment ``cpu_variants.MAKE`` (OpenBLAS's
    Haswell kernels, NumPy without AVX-512); nbval re-runs them with ``cpu_variants.CHECK`` (Sandybridge
    kernels, NumPy's baseline loops, libm without FMA). An output that shows round-off digits, which differ
    between CPUs, then fails here on any machine instead of on the next person's (``tools/cpu_variants.py``).
    Only the kernels change: the tests in this process run on the machine's own choices.
    """
    import nbval.kernel

    if getattr(nbval.kernel.start_new_kernel, "_plays_another_cpu", False):
        return
    variants = _load_cpu_variants()
    original = nbval.kernel.start_new_kernel

    def start_new_kernel(*args, **kwargs):
        kwargs.setdefault("env", variants.kernel_env(variants.CHECK))
        return original(*args, **kwargs)

    start_new_kernel._plays_another_cpu = True
    nbval.kernel.start_new_kernel = start_new_kernel


def _load_cpu_variants():
    import importlib.util

    spec = importlib.util.spec_from_file_location("cpu_variants", REPO / "tools" / "cpu_variants.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _nbval_runs_cells_like_jupyter() -> None:
    """Make nbval execute cells with ``store_history=True``, as Jupyter and nbclient do.

    nbval >= 0.10 sends ``store_history=False``, and IPython then ignores a trailing ``;``
    (it looks for the ``;`` in the last *stored* input: ipython/ipython#14162,
    computationalmodelling/nbval#194): ``plt.plot(...);`` gains an ``[<Line2D ...>]`` output that the
    committed notebook does not have and the strict comparison fails. Storing history restores
    what the notebooks were executed with (tools/execute_notebooks.py uses nbclient).
    """
    try:
        from nbval.kernel import RunningKernel
    except ImportError:
        return
    if getattr(RunningKernel.execute_cell_input, "_stores_history", False):
        return

    def execute_cell_input(self, cell_input, allow_stdin=None):
        return self.kc.execute(cell_input, store_history=True, allow_stdin=allow_stdin, stop_on_error=False)

    execute_cell_input._stores_history = True
    RunningKernel.execute_cell_input = execute_cell_input
