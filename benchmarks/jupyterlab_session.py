"""A real JupyterLab driven by Debian's Chromium, offline: for ``tests/test_jupyterlab.py`` and ``run.py --browser``.

``lab_session(root, work)`` starts ``jupyter lab`` from the project's environment on 127.0.0.1 (a random token, no
browser, its config, runtime, settings and workspaces directories under ``work``, so nothing of the user's is read
or written; autosave off, so opened notebooks are never rewritten), and a Chromium (Playwright, ``/usr/bin/chromium``,
never a downloaded browser) with a fresh profile in which every request that leaves 127.0.0.1 is aborted and recorded.
The notebook helpers (``open_notebook``, ``cells``, ``run_cell``, ``set_cell_source``, ``slider_latency``) act as
a person would where it matters (typing into a cell, moving a slider with the keyboard) and run cells through
JupyterLab's own "Run Selected Cell" command.
"""

from __future__ import annotations

import contextlib
import json
import os
import secrets
import socket
import subprocess
import sys
import time
import urllib.request
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_FLAGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
]
VIEWPORT = {"width": 1280, "height": 900}
LOCAL_HOSTS = {"127.0.0.1", "localhost"}
SERVER_START_TIMEOUT = 90.0

#: JupyterLab user settings of the session: no news or update checks (they would leave the machine), no autosave
#: (an opened copy is never rewritten behind the test's back), every cell in the DOM (no windowing).
LAB_SETTINGS = {
    "@jupyterlab/apputils-extension/notification.jupyterlab-settings": {"fetchNews": "false",
                                                                        "checkForUpdates": False},
    "@jupyterlab/docmanager-extension/plugin.jupyterlab-settings": {"autosave": False},
    "@jupyterlab/notebook-extension/tracker.jupyterlab-settings": {"windowingMode": "none"},
}


class Unavailable(RuntimeError):
    """Chromium or Playwright is missing (the caller decides: skip, or fail under CI)."""


@dataclass
class LabSession:
    """A running JupyterLab and a browser context on it."""

    base: str
    token: str
    root: Path
    context: Any
    external: list[str] = field(default_factory=list)
    server_log: Path | None = None

    def url(self, path: str, workspace: str | None = None) -> str:
        """The URL that opens ``path`` (relative to the server's root) in JupyterLab, in a fresh ``workspace``
        if one is named (no tab of an earlier page is restored into it)."""
        where = f"/lab/workspaces/{workspace}" if workspace else "/lab"
        return f"{self.base}{where}/tree/{path}?reset&token={self.token}"


def jupyter_exe() -> str:
    """The ``jupyter`` of the running interpreter's environment (the project's venv)."""
    beside = Path(sys.executable).with_name("jupyter")
    if not beside.exists():
        raise RuntimeError(f"{beside} not found: run `make setup` (JupyterLab is in the lab extra)")
    return str(beside)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextlib.contextmanager
def jupyterlab_server(root: Path, work: Path) -> Iterator[tuple[str, str, Path]]:
    """Run ``jupyter lab`` on ``root``; yields (base URL, token, log file). Stopped (its process group) on exit."""
    work.mkdir(parents=True, exist_ok=True)
    settings = work / "settings"
    for rel, values in LAB_SETTINGS.items():
        path = settings / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(values), encoding="utf-8")
    env = {k: v for k, v in os.environ.items() if not k.startswith(("JUPYTER", "JPY_"))}
    env.update(JUPYTER_CONFIG_DIR=str(work / "config"), JUPYTER_RUNTIME_DIR=str(work / "runtime"),
               JUPYTERLAB_SETTINGS_DIR=str(settings), JUPYTERLAB_WORKSPACES_DIR=str(work / "workspaces"))
    port, token = _free_port(), secrets.token_hex(16)
    cmd = [jupyter_exe(), "lab", "--no-browser", "--ServerApp.ip=127.0.0.1", f"--ServerApp.port={port}",
           "--ServerApp.port_retries=0", f"--IdentityProvider.token={token}", f"--ServerApp.root_dir={root}",
           "--LabApp.news_url=None", "--LabApp.check_for_updates_class=jupyterlab.NeverCheckForUpdate",
           "--ServerApp.open_browser=False", "--LabApp.expose_app_in_browser=True"]
    if hasattr(os, "getuid") and os.getuid() == 0:
        cmd.append("--allow-root")
    log_path = work / "jupyterlab.log"
    with open(log_path, "w", encoding="utf-8") as log:
        server = subprocess.Popen(cmd, env=env, stdout=log, stderr=subprocess.STDOUT, cwd=root,
                                  start_new_session=True)
    base = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + SERVER_START_TIMEOUT
        while True:
            try:
                urllib.request.urlopen(f"{base}/api/status?token={token}", timeout=2).close()
                break
            except OSError:
                if server.poll() is not None or time.monotonic() > deadline:
                    raise RuntimeError(f"jupyter lab did not start on port {port}; log:\n"
                                       + log_path.read_text(encoding="utf-8", errors="replace")[-4000:]) from None
                time.sleep(0.2)
        yield base, token, log_path
    finally:
        if server.poll() is None:
            os.killpg(server.pid, 15)
            try:
                server.wait(timeout=15)
            except subprocess.TimeoutExpired:
                os.killpg(server.pid, 9)
                server.wait(timeout=10)


@contextlib.contextmanager
def lab_session(root: Path, work: Path) -> Iterator[LabSession]:
    """JupyterLab on ``root`` and a guarded Chromium context on it (see the module docstring)."""
    if not CHROMIUM.exists():
        raise Unavailable(f"{CHROMIUM} is not installed")
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        raise Unavailable("the playwright package is not installed") from None
    with jupyterlab_server(root, work) as (base, token, log_path), sync_playwright() as pw:
        external: list[str] = []

        def guard(route: Any) -> None:
            parts = urlsplit(route.request.url)
            if parts.scheme in ("http", "https", "ws", "wss") and parts.hostname in LOCAL_HOSTS:
                route.continue_()
            else:
                external.append(route.request.url)
                route.abort()

        context = pw.chromium.launch_persistent_context(
            str(work / "chromium-profile"), executable_path=str(CHROMIUM), headless=True, args=CHROMIUM_FLAGS,
            viewport=VIEWPORT, service_workers="block")
        try:
            context.route("**/*", guard)
            yield LabSession(base=base, token=token, root=root, context=context, external=external,
                             server_log=log_path)
        finally:
            context.close()


# --- acting on a notebook -------------------------------------------------------------------------------------

def open_notebook(session: LabSession, path: str, workspace: str | None = None, timeout: float = 90_000) -> Any:
    """Open ``path`` in a new page; returns the page once the notebook's cells are shown and the kernel is idle."""
    page = session.context.new_page()
    page.goto(session.url(path, workspace), wait_until="domcontentloaded", timeout=timeout)
    page.wait_for_function("""() => { const w = window.jupyterapp && window.jupyterapp.shell.currentWidget;
                                      return w && w.context && w.context.isReady && w.content.widgets.length > 0; }""",
                           timeout=timeout)
    page.wait_for_selector(".jp-NotebookPanel .jp-Notebook .jp-Cell", timeout=timeout)
    wait_kernel_idle(page, timeout)
    return page


def wait_kernel_idle(page: Any, timeout: float = 120_000) -> None:
    """Wait until the notebook's kernel is started, connected and idle (the session's own status: the toolbar's
    indicator reads "idle" before the kernel exists, and a cell run then is dropped)."""
    page.wait_for_function(
        """() => { const ctx = window.jupyterapp.shell.currentWidget.sessionContext;
                   const kernel = ctx.session && ctx.session.kernel;
                   return !!kernel && kernel.connectionStatus === 'connected' && kernel.status === 'idle'
                          && ctx.kernelDisplayStatus === 'idle'; }""", timeout=timeout)


def cells(page: Any) -> Any:
    """The locator of the open notebook's cells."""
    return page.locator(".jp-NotebookPanel:not(.lm-mod-hidden) .jp-Notebook .jp-Cell")


def cell_index(page: Any, text: str) -> int:
    """The index of the first cell whose source contains ``text`` (read from the notebook's model: the server runs
    with ``expose_app_in_browser``)."""
    sources = page.evaluate("""() => {
        const nb = window.jupyterapp.shell.currentWidget.content;
        return Array.from({length: nb.model.cells.length}, (_, i) => nb.model.cells.get(i).sharedModel.getSource());
    }""")
    for index, source in enumerate(sources):
        if text in source:
            return index
    raise LookupError(f"no cell contains {text!r}")


def run_cell(page: Any, index: int, timeout: float = 120_000) -> Any:
    """Run cell ``index`` (JupyterLab's "Run Selected Cell", as Shift+Enter) and wait until it has finished;
    returns its locator.

    The cell's execution count is cleared first (in the page's model), so that the new count the kernel gives it
    marks the end of this run. The command is run through the application's command registry rather than a key
    press, which is lost when the notebook does not have the keyboard focus yet.
    """
    cell = cells(page).nth(index)
    cell.scroll_into_view_if_needed()
    page.evaluate("""(i) => { const panel = window.jupyterapp.shell.currentWidget, nb = panel.content;
                              nb.widgets[i].model.executionCount = null;
                              nb.activeCellIndex = i; nb.mode = 'command';
                              return window.jupyterapp.commands.execute('notebook:run-cell'); }""", index)
    page.wait_for_function(
        """(i) => { const cell = window.jupyterapp.shell.currentWidget.content.widgets[i];
                    return cell.model.executionCount !== null && !cell.node.querySelector('.jp-InputPrompt')
                           .innerText.includes('*'); }""",
        arg=index, timeout=timeout)
    wait_kernel_idle(page, timeout)
    return cell


def set_cell_source(page: Any, index: int, text: str) -> None:
    """Replace the source of cell ``index`` by ``text``, typed into its editor."""
    cell = cells(page).nth(index)
    cell.scroll_into_view_if_needed()
    cell.locator(".cm-content").click()
    page.keyboard.press("Control+a")
    page.keyboard.press("Delete")
    page.keyboard.insert_text(text)
    page.keyboard.press("Escape")


# --- a slider move, timed as a person sees it -----------------------------------------------------------------

_ARM_LATENCY = """(i) => {
  const node = window.jupyterapp.shell.currentWidget.content.widgets[i].node;
  const old = new Set(Array.from(node.querySelectorAll('.jp-OutputArea img')).map(img => img.src));
  window.__uwtutorKeyTime = null;
  window.__uwtutorLatencyMs = null;
  const onKey = (e) => { if (window.__uwtutorKeyTime === null) window.__uwtutorKeyTime = e.timeStamp; };
  document.addEventListener('keydown', onKey, {capture: true});
  document.addEventListener('input', onKey, {capture: true});     // a dropdown's choice (select_option)
  window.__uwtutorLatency = new Promise((resolve) => {
    let done = false;
    const check = async () => {
      if (done) return;
      const img = Array.from(node.querySelectorAll('.jp-OutputArea img')).find(im => !old.has(im.src));
      if (!img) return;
      done = true;
      observer.disconnect();
      try { await img.decode(); } catch (e) { /* an image replaced meanwhile: the next frame shows the newest */ }
      requestAnimationFrame(() => requestAnimationFrame(() => {
        document.removeEventListener('keydown', onKey, {capture: true});
        document.removeEventListener('input', onKey, {capture: true});
        window.__uwtutorLatencyMs = performance.now() - window.__uwtutorKeyTime;
        resolve(window.__uwtutorLatencyMs);
      }));
    };
    const observer = new MutationObserver(check);
    observer.observe(node, {subtree: true, childList: true, attributes: true, attributeFilter: ['src']});
  });
}"""


def slider_latency(page: Any, index: int, slider: int = 0, key: str = "ArrowRight", timeout: float = 60_000) -> float:
    """Move slider ``slider`` of the widget in cell ``index`` by one step (a key press on its handle, which
    sends the new value as a release of the mouse does) and return the milliseconds from the key press to the
    first frame painted with the new figure decoded in place (the kernel's compute and drawing, both round trips
    and the browser's decoding included)."""
    cell = cells(page).nth(index)
    handles = cell.locator(".widget-slider .noUi-handle")
    if not handles.count():     # a widget of choices only (chapter 10): choose the next (previous) option
        select = cell.locator(".widget-dropdown select").nth(slider)
        select.scroll_into_view_if_needed()
        options = select.locator("option").all_text_contents()
        i = options.index(select.input_value()) + (1 if key == "ArrowRight" else -1)
        page.evaluate(_ARM_LATENCY, index)
        select.select_option(options[min(max(i, 0), len(options) - 1)])     # timed from its input event
        page.wait_for_function("() => window.__uwtutorLatencyMs !== null", timeout=timeout)
        return float(page.evaluate("() => window.__uwtutorLatencyMs"))
    handle = handles.nth(slider)
    handle.scroll_into_view_if_needed()
    handle.focus()
    page.evaluate(_ARM_LATENCY, index)
    handle.press(key)
    page.wait_for_function("() => window.__uwtutorLatencyMs !== null", timeout=timeout)
    return float(page.evaluate("() => window.__uwtutorLatencyMs"))


#: Every control of a widget panel, in the order the page shows them: slider handles, dropdowns, checkboxes.
CONTROL_SELECTOR = ".widget-slider .noUi-handle, .widget-dropdown select, .widget-checkbox input"


def widget_controls(page: Any, index: int) -> list[dict[str, Any]]:
    """The controls of the widget in cell ``index``: ``kind`` ("slider", "dropdown" or "checkbox") and ``label``
    (the description shown beside it), in page order."""
    return page.evaluate("""([i, selector]) => {
      const node = window.jupyterapp.shell.currentWidget.content.widgets[i].node;
      return Array.from(node.querySelectorAll(selector)).map((el) => {
        const box = el.closest('.widget-slider, .widget-dropdown, .widget-checkbox');
        const kind = box.classList.contains('widget-slider') ? 'slider'
                     : box.classList.contains('widget-dropdown') ? 'dropdown' : 'checkbox';
        const labels = Array.from(box.querySelectorAll('.widget-label-basic, .widget-label, label'))
                            .map((l) => l.innerText.replace(/\u200b/g, '').trim()).filter((t) => t);
        return {kind, label: labels.length ? labels[0] : ''};
      });
    }""", [index, CONTROL_SELECTOR])


def control_value(page: Any, index: int, control: int) -> str:
    """The value of dropdown ``control`` of the widget in cell ``index`` (its option's value in the page)."""
    return cells(page).nth(index).locator(CONTROL_SELECTOR).nth(control).evaluate("(el) => el.value")


def control_latency(page: Any, index: int, control: int, forward: bool = True, timeout: float = 60_000,
                    value: str | None = None) -> float:
    """Change control ``control`` of the widget in cell ``index`` as a person would with the keyboard and return the
    milliseconds from the key press to the first frame painted with the new figure (as ``slider_latency``).

    A slider moves one step (right when ``forward``, else left); a dropdown takes its next option (the first after
    the last), or ``value``; a checkbox is toggled with the space bar. NaN if no new figure came within ``timeout``
    (the control does not change the view in the widget's present state).
    """
    element = cells(page).nth(index).locator(CONTROL_SELECTOR).nth(control)
    element.scroll_into_view_if_needed()
    tag = element.evaluate("(el) => el.tagName.toLowerCase() + ':' + (el.type || '')")
    if tag.startswith("select"):
        options, now = element.evaluate("(el) => [Array.from(el.options).map((o) => o.value), el.value]")
        if value is None:                             # nothing chosen yet (index -1): the first option
            value = options[(options.index(now) + 1 if now in options else 0) % len(options)]
        page.evaluate(_ARM_LATENCY, index)
        element.select_option(value=value)            # timed from its input event
    else:
        element.focus()
        page.evaluate(_ARM_LATENCY, index)
        element.press(" " if tag == "input:checkbox" else ("ArrowRight" if forward else "ArrowLeft"))
    try:
        page.wait_for_function("() => window.__uwtutorLatencyMs !== null", timeout=timeout)
    except Exception as exc:                          # Playwright's TimeoutError
        if "Timeout" not in type(exc).__name__:
            raise
        return float("nan")
    return float(page.evaluate("() => window.__uwtutorLatencyMs"))


def slider_room(page: Any, index: int, control: int) -> tuple[float, float]:
    """Steps' worth of room of slider ``control`` below and above its value (from its ARIA values), as
    (value - min, max - value)."""
    element = cells(page).nth(index).locator(CONTROL_SELECTOR).nth(control)
    now, low, high = (float(element.get_attribute(a)) for a in ("aria-valuenow", "aria-valuemin", "aria-valuemax"))
    return now - low, high - now
