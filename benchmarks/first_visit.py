"""Kernel-side time of every control of every widget, on settings never seen before and on settings seen before.

Each widget is built as in a notebook (the book's style on). For every control in turn, from the widget's default
setting, the control is moved to up to ``NEW_VALUES`` values it has not had in this process (a slider one step at a
time towards its farther end, a dropdown's next options, a check box toggled once), and the time of the assignment
is taken: the panel's observer runs inside it, so it covers the computation, the redraw and the PNG. That is the
*first-visit* time: neither the panel's kept pictures nor the widget's caches can answer. The control is then moved
back through the values it just had (the *cached* time: a picture kept, or a result cached) and left at its
default. The median of each control's moves is reported (wall time, and this process's CPU time beside it: on a
shared machine the wall time carries the other processes' load), and for each widget its worst control.

A widget that gives a coarse answer first (``slider_panel``'s ``refine``) is measured as a reader in JupyterLab meets
it: background refinement on (``_panel.REFINE_IN_BACKGROUND = True``), the first-visit time is the time to the
*first* picture (the coarse one); the CPU time is the whole process's, so it also counts what the refining thread
ran meanwhile. The time until the full picture is shown is reported beside it ("full", wall ms); the benchmark
waits for it (untimed) before the next move, so one move's refinement is not counted in the next.

Run on its own (``.venv/bin/python benchmarks/first_visit.py [ch07 ...]``) or through ``benchmarks/run.py``
(``--only first_visit``). Speed is measured here, never asserted by the tests.
"""

from __future__ import annotations

import math
import statistics
import sys
import time
from pathlib import Path
from typing import Any, Iterator

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:                   # time this checkout's uwtutor, not another installed copy
    sys.path.insert(0, str(ROOT))

#: New values tried per control (fewer where the control has fewer).
NEW_VALUES = 3
#: The kernel-side target of a widget update, ms.
TARGET_MS = 120.0


def _walk(widget: Any) -> Iterator[Any]:
    yield widget
    for child in getattr(widget, "children", ()):
        yield from _walk(child)


def controls(panel: Any) -> list[Any]:
    """The controls of a ``slider_panel`` (sliders, dropdowns, check boxes), in order."""
    import ipywidgets as w

    kinds = (w.FloatSlider, w.IntSlider, w.FloatLogSlider, w.Dropdown, w.Checkbox, w.ToggleButtons,
             w.RadioButtons)
    return [x for x in _walk(panel) if isinstance(x, kinds)]


def new_values(control: Any, count: int = NEW_VALUES) -> list[Any]:
    """Up to ``count`` values of ``control`` other than its current one, in the order a person would reach them:
    a slider's next steps towards its farther end, a choice's next options (wrapping), a check box's other state."""
    import ipywidgets as w

    value = control.value
    if isinstance(control, w.Checkbox):
        return [not value]
    if isinstance(control, (w.Dropdown, w.ToggleButtons, w.RadioButtons)):
        options = [o[1] if isinstance(o, tuple) else o for o in control.options]
        i = options.index(value)
        return [options[(i + j) % len(options)] for j in range(1, min(count, len(options) - 1) + 1)]
    if isinstance(control, w.FloatLogSlider):
        e = math.log(value, control.base)
        up = (control.max - e) >= (e - control.min)
        steps = [e + (j if up else -j) * control.step for j in range(1, count + 1)]
        return [control.base ** s for s in steps if control.min - 1e-9 <= s <= control.max + 1e-9]
    up = (control.max - value) >= (value - control.min)
    steps = [value + (j if up else -j) * control.step for j in range(1, count + 1)]
    return [s for s in steps if control.min <= s <= control.max]


def measure_widget(factory: Any, count: int = NEW_VALUES) -> dict[str, dict[str, float]]:
    """For each control of the widget ``factory()`` makes: the median ms of its first-visit moves and of its
    cached moves (see the module docstring)."""
    import matplotlib.pyplot as plt

    from uwtutor.widgets import _panel

    _panel.REFINE_IN_BACKGROUND = True              # as in a live kernel: the coarse picture first
    panel = factory()
    out = {}
    for control in controls(panel):
        default = control.value
        values = new_values(control, count)
        first, first_cpu, full, cached = [], [], [], []
        for v in values:
            t0, c0 = time.perf_counter(), time.process_time()
            control.value = v
            first.append((time.perf_counter() - t0) * 1000.0)
            first_cpu.append((time.process_time() - c0) * 1000.0)
            _panel.wait_refined(panel)
            full.append((time.perf_counter() - t0) * 1000.0)
        for v in list(reversed(values[:-1])) + [default]:
            t0 = time.perf_counter()
            control.value = v
            cached.append((time.perf_counter() - t0) * 1000.0)
            _panel.wait_refined(panel)
        label = control.description or type(control).__name__
        out[label] = {"first_ms": statistics.median(first), "first_max_ms": max(first),
                      "first_cpu_ms": statistics.median(first_cpu), "full_ms": statistics.median(full),
                      "cached_ms": statistics.median(cached), "moves": len(first)}
    plt.close("all")
    return out


def measure_all(only: list[str] | None = None, count: int = NEW_VALUES) -> dict[str, dict[str, dict[str, float]]]:
    """``measure_widget`` for every live widget of the book (``only``: chapter prefixes such as ``"ch07"``)."""
    from uwtutor import widgets
    from uwtutor.plotting import use_book_style

    use_book_style()
    found = {}
    for name in widgets.__all__:
        obj = getattr(widgets, name)
        if name.endswith("_widget") and callable(obj):
            found[f"{obj.__module__.rsplit('.', 1)[-1]} {name}"] = obj
    results = {}
    for label, factory in sorted(found.items()):
        if only and not any(label.startswith(o) for o in only):
            continue
        results[label] = measure_widget(factory, count)
    return results


def _first(v: dict[str, float]) -> str:
    """A control's first-visit cell: wall ms (CPU ms), and the wall ms until the full picture where a coarse one
    came first."""
    cell = f"{v['first_ms']:.0f} ({v['first_cpu_ms']:.0f})"
    full = v.get("full_ms", v["first_ms"])
    return cell if full <= 1.05 * v["first_ms"] + 1.0 else f"{cell}, full {full:.0f}"


def render(results: dict[str, dict[str, dict[str, float]]], every_control: bool = False) -> str:
    """The table: each widget's worst control on a first visit, its ms, and the same control's cached ms."""
    lines = [f"| widget | worst control (first visit) | first visit ms (CPU ms)[, full] | cached ms | "
             f"≤ {TARGET_MS:.0f} ms |", "|---|---|---|---|---|"]
    for label, per in results.items():
        if not per:
            continue
        name, worst = max(per.items(), key=lambda kv: kv[1]["first_ms"])
        status = "PASS" if worst["first_ms"] <= TARGET_MS else "MISS"
        lines.append(f"| {label} | {name} | {_first(worst)} | {worst['cached_ms']:.0f} | {status} |")
        if every_control:
            for cname, v in per.items():
                if cname != name:
                    lines.append(f"|  | {cname} | {_first(v)} | {v['cached_ms']:.0f} | |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    args = list(sys.argv[1:] if argv is None else argv)
    every = "--all-controls" in args
    only = [a for a in args if not a.startswith("--")] or None
    print(render(measure_all(only), every_control=every))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
