"""Sphinx extension: make the HTML book self-contained (no CDN loads).

By default Sphinx loads MathJax from a CDN and myst-nb loads require.js and the
Jupyter widget manager (``@jupyter-widgets/html-manager``) from two more CDNs. The
book must work at sea, with no connection, so the three are pinned in
``package.json`` / ``package-lock.json`` (installed with ``npm ci``) and this
extension copies the files the pages need from ``node_modules`` into a staging
directory (``<outdir>/../.offline_assets``) that it appends to ``html_extra_path``:
Sphinx then copies it verbatim into the build, as ``_static/_vendor/``.

``_config.yml`` points ``mathjax_path`` and ``nb_ipywidgets_js`` at the copies with
paths relative to ``_static/`` (``_vendor/...``), as Sphinx expects of local assets;
Sphinx writes them relative to each page (``../_static/_vendor/...`` from
``book/ch01.html``), so the book also works opened from disk.

The extension refuses to build HTML (clear error, never a silent CDN fallback)
when ``node_modules`` is missing or incomplete, or when ``mathjax_path`` or
``nb_ipywidgets_js`` still point at a URL or at a file that is not staged.

The staging directory is deliberately *not* the book's source ``_static/``: Jupyter
Book injects every ``.js`` file found there into every page.
"""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path
from typing import Any

from sphinx.application import Sphinx
from sphinx.config import Config
from sphinx.errors import ConfigError, ExtensionError
from sphinx.util import logging

__version__ = "1.0"

logger = logging.getLogger(__name__)

VENDOR = "_static/_vendor"  # in the build; config paths are relative to _static/
STAGING_NAME = ".offline_assets"

# Loaded between require.js and embed-amd.js (see nb_ipywidgets_js in _config.yml).
WIDGETS_SETUP_JS = """\
/* Written by book/_ext/offline_assets.py; loaded after require.js and before
   embed-amd.js on pages that show Jupyter widgets. */
(function () {
  var s = document.currentScript;
  var dir = s && s.src ? s.src.replace(/[^\\/]*$/, "") : "";
  if (dir && window.requirejs) {
    /* embed-amd.js derives the URL of its fonts (webpack public path) from the
       require.js URL of its modules, by default relative to the page: map the
       modules to the directory this file is served from. */
    window.__jupyter_widgets_assets_path__ = dir;
    var base = dir.replace(/\\/$/, "");
    window.requirejs.config({
      paths: {
        "@jupyter-widgets/html-manager/dist": base,
        "@jupyter-widgets/html-manager": base + "/html-manager",
        "@jupyter-widgets/base": base + "/base",
        "@jupyter-widgets/base7": base + "/base7",
        "@jupyter-widgets/controls": base + "/controls",
        "@jupyter-widgets/controls7": base + "/controls7"
      }
    });
  }
  /* ipywidgets 8 typesets widget labels through the MathJax 2 API
     (MathJax.Hub.Queue; jupyter-widgets/ipywidgets#3829), the book loads
     MathJax 3: bridge the call (widgets render on window "load", after this). */
  document.addEventListener("DOMContentLoaded", function () {
    var MJ = window.MathJax;
    if (MJ && MJ.version && !MJ.Hub) {
      MJ.Hub = {
        Queue: function (job) {
          var el = job && job[2];
          if (!(MJ.startup && MJ.startup.promise && MJ.typesetPromise)) return;
          MJ.startup.promise
            .then(function () { return MJ.typesetPromise(el ? [el] : undefined); })
            .catch(function (e) { console.warn("MathJax: widget label not typeset", e); });
        }
      };
    }
  });
})();
"""

NPM_HINT = (
    "run `npm ci` in the repository root (or `make setup`) to install the pinned "
    "JavaScript assets from package-lock.json"
)


def _files_to_copy(nm: Path) -> list[tuple[Path, str]]:
    """(source, destination relative to the build root) for every vendored asset.

    Directories are copied whole. Raises ExtensionError naming what is missing.
    """
    hm = nm / "@jupyter-widgets" / "html-manager"
    plan: list[tuple[Path, str]] = [
        # MathJax 3: the whole es5 tree, because the combined component loads TeX
        # extensions, fonts, the menu and the accessibility code lazily from it.
        (nm / "mathjax" / "es5", f"{VENDOR}/mathjax"),
        (nm / "requirejs" / "require.js", f"{VENDOR}/requirejs/require.js"),
        (hm / "dist" / "embed-amd.js", f"{VENDOR}/jupyter-widgets/embed-amd.js"),
    ]
    # The Font Awesome files the widget bundle references (webpack assets).
    dist = hm / "dist"
    if dist.is_dir():
        for font in sorted(dist.iterdir()):
            if font.suffix in {".woff", ".woff2", ".ttf", ".eot", ".svg"}:
                plan.append((font, f"{VENDOR}/jupyter-widgets/{font.name}"))
    missing = [str(src) for src, _ in plan if not src.exists()]
    if missing:
        raise ExtensionError(
            "offline_assets: JavaScript assets missing from node_modules "
            f"({', '.join(missing)}): {NPM_HINT}."
        )
    # License texts travel with the code where the packages ship them.
    for src, dest in [
        (nm / "mathjax" / "LICENSE", f"{VENDOR}/mathjax/LICENSE"),
        (dist / "embed.js.LICENSE.txt", f"{VENDOR}/jupyter-widgets/THIRD-PARTY-LICENSES.txt"),
    ]:
        if src.exists():
            plan.append((src, dest))
    return plan


def _check_versions(nm: Path) -> None:
    """MathJax must be v3 (mathjax3_config, es5/ layout)."""
    pkg = json.loads((nm / "mathjax" / "package.json").read_text(encoding="utf-8"))
    if not str(pkg.get("version", "")).startswith("3."):
        raise ExtensionError(
            f"offline_assets: node_modules holds mathjax {pkg.get('version')}, the book "
            f"needs MathJax 3 as pinned in package.json: {NPM_HINT}."
        )


def _fingerprint(nm: Path, plan: list[tuple[Path, str]]) -> str:
    """Cheap identity of what would be staged: lock file + versions + our code."""
    h = hashlib.sha256(__version__.encode())
    h.update(WIDGETS_SETUP_JS.encode())
    lock = nm / ".package-lock.json"  # written by npm into node_modules
    if lock.exists():
        h.update(lock.read_bytes())
    for src, dest in plan:
        st = src.stat()
        h.update(f"{src}|{dest}|{st.st_size}|{st.st_mtime_ns}".encode())
    return h.hexdigest()


def _stage(nm: Path, staging: Path) -> None:
    plan = _files_to_copy(nm)
    _check_versions(nm)
    stamp = staging.with_name(staging.name + ".stamp")  # outside what Sphinx copies
    fp = _fingerprint(nm, plan)
    if stamp.exists() and stamp.read_text() == fp and (staging / VENDOR).is_dir():
        return
    stamp.unlink(missing_ok=True)  # an interrupted copy must not look complete
    shutil.rmtree(staging, ignore_errors=True)
    staging.mkdir(parents=True)
    for src, dest in plan:
        target = staging / dest
        target.parent.mkdir(parents=True, exist_ok=True)
        if src.is_dir():
            shutil.copytree(src, target, dirs_exist_ok=True)
        else:
            shutil.copy2(src, target)
    (staging / VENDOR / "jupyter-widgets" / "widgets-setup.js").write_text(WIDGETS_SETUP_JS)
    stamp.write_text(fp)
    logger.info("offline_assets: staged %s from %s", VENDOR, nm)


def _is_url(path: str) -> bool:
    return "://" in path or path.startswith("//")


def _check_config(app: Sphinx, staging: Path) -> None:
    """mathjax_path and nb_ipywidgets_js must name staged local files."""
    wanted: dict[str, str] = {"mathjax_path": app.config.mathjax_path}
    for i, key in enumerate(getattr(app.config, "nb_ipywidgets_js", {}) or {}):
        wanted[f"nb_ipywidgets_js[{i}]"] = key
    for name, value in wanted.items():
        if _is_url(value):
            raise ConfigError(
                f"offline_assets: {name} = {value!r} loads from the network; the book must "
                "work offline: point it at a file under _vendor/ (see _config.yml)."
            )
        if not (staging / "_static" / value).is_file():
            raise ConfigError(
                f"offline_assets: {name} = {value!r} is not among the staged assets "
                f"(look under {staging / VENDOR})."
            )
    for key, attrs in (getattr(app.config, "nb_ipywidgets_js", {}) or {}).items():
        for attr, val in (attrs or {}).items():
            if _is_url(str(val)):
                raise ConfigError(
                    f"offline_assets: nb_ipywidgets_js[{key!r}][{attr!r}] = {val!r} points "
                    "at the network; use a local path."
                )


def _staging_dir(app: Sphinx) -> Path:
    return Path(app.outdir).resolve().parent / STAGING_NAME


def _on_config_inited(app: Sphinx, config: Config) -> None:
    # Runs before Sphinx validates html_extra_path (priority 800): the entry must
    # exist by then, so create the (possibly still empty) directory now.
    staging = _staging_dir(app)
    staging.mkdir(parents=True, exist_ok=True)
    if str(staging) not in [str(p) for p in config.html_extra_path]:
        config.html_extra_path.append(str(staging))


def _on_builder_inited(app: Sphinx) -> None:
    if app.builder.format != "html":
        return
    nm_setting = app.config.offline_assets_node_modules
    nm = Path(nm_setting) if nm_setting else Path(app.srcdir) / "node_modules"
    if not nm.is_absolute():
        nm = Path(app.srcdir) / nm
    if not nm.is_dir():
        raise ExtensionError(
            f"offline_assets: {nm} does not exist, so MathJax, require.js and the "
            f"widget manager cannot be bundled into the offline book: {NPM_HINT}."
        )
    staging = _staging_dir(app)
    _stage(nm, staging)
    _check_config(app, staging)


def setup(app: Sphinx) -> dict[str, Any]:
    app.add_config_value("offline_assets_node_modules", "", "env", [str])
    app.connect("config-inited", _on_config_inited, priority=100)
    app.connect("builder-inited", _on_builder_inited)
    return {"version": __version__, "parallel_read_safe": True, "parallel_write_safe": True}
