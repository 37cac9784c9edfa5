"""Sphinx extension: the book's widgets, frozen in the HTML, say so and do not pretend to answer.

A live widget needs a Python kernel. The HTML book shows each one from the widget state saved when its chapter was
executed (the figure at the controls' default settings), rendered by the offline widget manager; left alone, its
sliders would still move their readouts while the figure stays the same, which looks broken. A small script on
every page with widgets waits for the manager to render them and then, in each widget of a cell's output:

- disables every control (inputs, dropdowns, check boxes, the slider handles and their editable readouts; the
  handles leave the keyboard's tab order), greys them a little, and marks the widget ``uwtutor-frozen``;
- puts a note above it (``p.uwtutor-frozen-note``) saying that this is the view at the default settings and how to
  run the live version: the chapter's notebook in JupyterLab or the widget's own call (``from uwtutor.widgets
  import NAME``, read from the cell's code), with the library's wheel that the HTML book carries (its address from
  the ``uwtutor-wheel`` meta tag that book/_ext/reader_edition.py writes).

``tests/test_browser.py`` opens a chapter with widgets and checks all of it. Pages without widgets are left alone.
"""

from __future__ import annotations

from typing import Any

from sphinx.application import Sphinx

__version__ = "1.0"

NOTE_CLASS = "uwtutor-frozen-note"
FROZEN_CLASS = "uwtutor-frozen"

FROZEN_WIDGETS_JS = r"""
(function () {
  "use strict";
  var CONTROLS = ".widget-slider, .widget-dropdown, .widget-checkbox, .widget-text, .widget-toggle-button, "
               + ".widget-button, .widget-radio, .widget-select";
  var STYLE = "." + "FROZEN" + " .widget-slider, ." + "FROZEN" + " .widget-dropdown, ." + "FROZEN"
            + " .widget-checkbox { opacity: 0.6; pointer-events: none; }"
            + " p." + "NOTE" + " { font-size: 0.9em; font-style: italic; margin: 0.2em 0 0.4em 0; }";

  function widgetName(output) {
    var cell = output.closest(".cell");
    var code = cell ? cell.querySelector(".cell_input pre") : null;
    var match = code ? /(\w+_widget)\s*\(/.exec(code.textContent) : null;
    return match ? match[1] : null;
  }

  function note(name) {
    var p = document.createElement("p");
    p.className = "NOTE";
    var meta = document.querySelector('meta[name="uwtutor-wheel"]');
    var wheel = meta ? meta.getAttribute("content") : "";
    var file = wheel.split("/").pop();
    p.appendChild(document.createTextNode("A frozen view at the default settings: its controls do nothing here. "
      + "The live widget runs in JupyterLab: open this chapter there (make lab in the book's repository, or its "
      + "notebook from the page's download menu) and run "
      + "its cells" + (name ? ", or run " : ".")));
    if (name) {
      var code = document.createElement("code");
      code.textContent = "from uwtutor.widgets import " + name + "; " + name + "()";
      p.appendChild(code);
      p.appendChild(document.createTextNode(" in any notebook"));
    }
    if (wheel) {
      p.appendChild(document.createTextNode(" after installing the library this book was built with, "));
      var link = document.createElement("a");
      link.href = wheel;
      link.textContent = file;
      p.appendChild(link);
      p.appendChild(document.createTextNode(": "));
      var install = document.createElement("code");
      install.textContent = "pip install \"./" + file + "[lab]\"";
      p.appendChild(install);
    }
    p.appendChild(document.createTextNode("."));
    return p;
  }

  function freeze(output) {
    var root = output.querySelector(".jupyter-widgets");
    if (!root || !output.querySelector(CONTROLS)) return false;
    output.querySelectorAll("input, select, textarea, button").forEach(function (el) {
      el.disabled = true;
      el.tabIndex = -1;
    });
    output.querySelectorAll(".noUi-target").forEach(function (el) { el.setAttribute("disabled", ""); });
    output.querySelectorAll(".noUi-handle").forEach(function (el) { el.setAttribute("tabindex", "-1"); });
    output.querySelectorAll("[contenteditable]").forEach(function (el) {
      el.setAttribute("contenteditable", "false");
    });
    output.querySelectorAll(CONTROLS).forEach(function (el) { el.setAttribute("aria-disabled", "true"); });
    output.classList.add("FROZEN");
    if (!output.querySelector("p.NOTE")) output.insertBefore(note(widgetName(output)), output.firstChild);
    return true;
  }

  function sweep() {
    var left = 0;
    document.querySelectorAll('script[type="application/vnd.jupyter.widget-view+json"]').forEach(function (s) {
      var output = s.parentElement;
      if (!output.classList.contains("FROZEN") && !freeze(output)) left += 1;
    });
    return left;
  }

  function start() {
    if (!document.querySelector('script[type="application/vnd.jupyter.widget-view+json"]')) return;
    var style = document.createElement("style");
    style.textContent = STYLE;
    document.head.appendChild(style);
    if (!sweep()) return;
    var observer = new MutationObserver(function () { if (!sweep()) observer.disconnect(); });
    observer.observe(document.body, {childList: true, subtree: true});
  }

  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", start);
  else start();
})();
""".replace("FROZEN", FROZEN_CLASS).replace("NOTE", NOTE_CLASS)


def setup(app: Sphinx) -> dict[str, Any]:
    app.add_js_file(None, body=FROZEN_WIDGETS_JS)
    return {"version": __version__, "parallel_read_safe": True, "parallel_write_safe": True}
