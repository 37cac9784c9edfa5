"""What ``import uwtutor`` and ``import uwtutor.filters`` pull in: heavy and optional dependencies are imported
where they are used (their CPU time is measured by ``make bench``, benchmarks/import_time.py; never asserted here).
"""

import subprocess
import sys


def _modules_after(statement: str, block: tuple[str, ...] = ()) -> set[str]:
    """The modules loaded by ``statement`` in a fresh interpreter (``block``: modules made unimportable)."""
    code = ("import sys\n" + "".join(f"sys.modules[{name!r}] = None\n" for name in block) + statement +
            "\nprint('\\n'.join(sorted(sys.modules)))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return set(out.stdout.split())


def test_importing_the_filters_does_not_load_scipy_stats_or_optional_dependencies():
    loaded = _modules_after("import uwtutor, uwtutor.filters")
    for heavy in ("scipy.stats", "pywt", "gtsam", "dask", "matplotlib"):
        assert heavy not in loaded, f"import uwtutor.filters loads {heavy}"


def test_widgets_import_without_pywavelets():
    loaded = _modules_after("import uwtutor.widgets, uwtutor.filters.particle", block=("pywt",))
    assert "uwtutor.widgets.ch06" in loaded


def test_the_wavelet_estimate_without_pywavelets_names_the_package():
    code = ("import sys; sys.modules['pywt'] = None\nfrom uwtutor.wavelet import noise_sigma\n"
            "try:\n    noise_sigma([0.0] * 64)\nexcept ImportError as exc:\n    print(exc)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert "pip install PyWavelets" in out.stdout
