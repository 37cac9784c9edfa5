"""Read the built book as a person would: Debian's Chromium (driven by Playwright) opens every page
of the table of contents from a local web server, with every request that would leave 127.0.0.1
aborted and recorded.

For each page: no failed request and no HTTP status >= 400, nothing requested from outside, no
console error (but the theme's known harmless one), math typeset by MathJax (no raw TeX left in
the text), every image decoded, every Jupyter widget rendered; and a first-screen screenshot
(1280x800) saved as ``_build/screenshots/<page>.png``. The search page finds chapter 1.

Chromium missing: the tests are skipped, unless CI=true, where they fail.
"""

from __future__ import annotations

import os
from pathlib import Path
from urllib.parse import urlsplit

import pytest

from book_paths import BUILD_DIR, HTML_DIR, serve_directory, toc_docnames

pytestmark = pytest.mark.browser

CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_FLAGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
]
VIEWPORT = {"width": 1280, "height": 800}
SCREENSHOTS = BUILD_DIR / "screenshots"
LOCAL_HOSTS = {"127.0.0.1", "localhost"}

# Console errors that are known and harmless, with the reason.
# (sphinx-thebe's `const THEBE_JS_URL` script, added twice by Sphinx 7.4, threw "already declared" on every page until
# book/_ext/reader_edition.py kept one copy of each inline script: it is an error again.)
KNOWN_CONSOLE_ERRORS: list[str] = []

# Chapter 1 is found by this word on the search page.
SEARCH_WORD = "Mackenzie"
#: Every wait of these tests waits for an event (the page's load, MathJax's startup promise, the widgets drawn, the
#: network idle, the search results listed) and returns as soon as it happens, however busy the machine. This bound
#: only ends a wait for an event that never comes (a broken page): it is not a speed limit, so it is generous.
EVENT_WAIT_MS = 600_000

DOCNAMES = toc_docnames()
FIRST_CHAPTER = next((d for d in DOCNAMES[1:] if "ch01" in d), DOCNAMES[1] if len(DOCNAMES) > 1 else DOCNAMES[0])


def _unavailable(reason: str):
    if os.environ.get("CI", "").lower() == "true":
        pytest.fail(f"CI=true and {reason}: the browser test must run in CI "
                    "(.ci/run installs Debian's chromium: apt-get install chromium)", pytrace=False)
    pytest.skip(reason)


# --- fixtures --------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def site(book_build):
    """Serve _build/html on a free port of 127.0.0.1; yields the base URL."""
    if not (HTML_DIR / "index.html").is_file():
        pytest.fail(f"no book in {HTML_DIR} (the build failed: see test_book_build)", pytrace=False)
    try:
        server = serve_directory(HTML_DIR)
        base = server.__enter__()
    except RuntimeError as exc:
        pytest.fail(str(exc))
    try:
        yield base
    finally:
        server.__exit__(None, None, None)


@pytest.fixture(scope="module")
def browser(site, tmp_path_factory):
    """A Chromium context with a fresh profile; every request off 127.0.0.1 is aborted and recorded.

    Yields (context, external_requests): the list is shared by all pages, tests clear it.
    """
    if not CHROMIUM.exists():
        _unavailable(f"{CHROMIUM} is not installed")
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        _unavailable("the playwright package is not installed")
    external: list[str] = []

    def guard(route):
        url = route.request.url
        parts = urlsplit(url)
        if parts.scheme in ("http", "https", "ws", "wss") and parts.hostname in LOCAL_HOSTS:
            route.continue_()
        else:
            external.append(url)
            route.abort()

    with sync_playwright() as pw:
        context = pw.chromium.launch_persistent_context(
            str(tmp_path_factory.mktemp("chromium-profile")),
            executable_path=str(CHROMIUM),
            headless=True,
            args=CHROMIUM_FLAGS,
            viewport=VIEWPORT,
            service_workers="block",
            timeout=EVENT_WAIT_MS,
        )
        context.set_default_timeout(EVENT_WAIT_MS)        # every other wait (locators, clicks) waits for its event
        try:
            context.route("**/*", guard)
            yield context, external
        finally:
            context.close()


class PageWatch:
    """Collects what goes wrong while a page loads."""

    def __init__(self, page, base: str):
        self.base = base
        self.console_errors: list[str] = []
        self.failed: list[str] = []
        page.on("console", self._console)
        page.on("pageerror", self._pageerror)
        page.on("requestfailed", lambda req: self.failed.append(f"{req.url} ({req.failure})"))
        page.on("response", self._response)

    def _console(self, msg):
        if msg.type == "error" and not any(k in msg.text for k in KNOWN_CONSOLE_ERRORS):
            loc = msg.location or {}
            self.console_errors.append(f"{msg.text} [{loc.get('url', '')}:{loc.get('lineNumber', '')}]")

    def _pageerror(self, exc):
        if not any(k in str(exc) for k in KNOWN_CONSOLE_ERRORS):
            self.console_errors.append(f"uncaught exception: {exc}")

    def _response(self, resp):
        if resp.status >= 400:
            self.failed.append(f"{resp.url} (HTTP {resp.status})")


# JavaScript run in the page -------------------------------------------------------------------

WAIT_FOR_MATHJAX = """async () => {
  const MJ = window.MathJax;
  if (!MJ || !MJ.startup || !MJ.startup.promise) return false;
  await MJ.startup.promise;
  return true;
}"""

PAGE_FACTS = r"""() => {
  const skip = 'script, style, pre, code, textarea, mjx-container, mjx-assistive-mml, .highlight, template';
  const raw = [];
  const walker = document.createTreeWalker(document.body, NodeFilter.SHOW_TEXT);
  for (let n = walker.nextNode(); n; n = walker.nextNode()) {
    const t = n.nodeValue;
    if (!/\\\(|\\\)|\\\[|\\\]|\$\$|\\begin\{/.test(t)) continue;
    if (n.parentElement && n.parentElement.closest(skip)) continue;
    raw.push(t.trim().slice(0, 120));
  }
  const views = Array.from(document.querySelectorAll('script[type="application/vnd.jupyter.widget-view+json"]'));
  return {
    mathNodes: document.querySelectorAll('.math').length,
    mjx: document.querySelectorAll('mjx-container').length,
    mjxErrors: Array.from(document.querySelectorAll('mjx-merror')).map(e => e.textContent.slice(0, 120)),
    rawTex: raw,
    widgetViews: views.length,
    widgetsEmpty: views.filter(s => !s.parentElement.querySelector('.widget-subarea > *')).length,
  };
}"""

IMAGES_LOADED = """async () => {
  const imgs = Array.from(document.images);
  imgs.forEach(i => { i.loading = 'eager'; });
  await Promise.all(imgs.map(i => i.decode().catch(() => null)));
  return imgs.filter(i => !(i.complete && i.naturalWidth > 0))
             .map(i => (i.getAttribute('src') || '(no src)').slice(0, 120));
}"""


def _screenshot_path(docname: str) -> Path:
    path = SCREENSHOTS / f"{docname}.png"
    path.parent.mkdir(parents=True, exist_ok=True)
    return path


# --- tests ---------------------------------------------------------------------------------------

@pytest.mark.parametrize("docname", DOCNAMES)
def test_page_renders_offline(browser, site, docname):
    context, external = browser
    external.clear()
    if not (HTML_DIR / f"{docname}.html").is_file():
        pytest.fail(f"{docname}.html was not built", pytrace=False)
    page = context.new_page()
    watch = PageWatch(page, site)
    problems: list[str] = []
    try:
        page.goto(site + f"{docname}.html", wait_until="load", timeout=EVENT_WAIT_MS)
        has_mathjax = page.evaluate(WAIT_FOR_MATHJAX)
        facts = page.evaluate(PAGE_FACTS)
        has_state = page.locator('script[type="application/vnd.jupyter.widget-state+json"]').count() > 0
        if facts["widgetViews"] and has_state:
            try:
                page.wait_for_function(
                    """() => Array.from(document.querySelectorAll(
                         'script[type="application/vnd.jupyter.widget-view+json"]'))
                         .every(s => s.parentElement.querySelector('.widget-subarea > *'))""",
                    timeout=EVENT_WAIT_MS)
            except Exception:  # reported below through facts["widgetsEmpty"]
                pass
        broken_images = page.evaluate(IMAGES_LOADED)
        page.wait_for_load_state("networkidle", timeout=EVENT_WAIT_MS)
        facts = page.evaluate(PAGE_FACTS)
        page.evaluate("() => window.scrollTo(0, 0)")
        page.screenshot(path=str(_screenshot_path(docname)), full_page=False)
    finally:
        page.close()

    if external:
        problems.append("requests leaving 127.0.0.1 (aborted):\n  " + "\n  ".join(sorted(set(external))))
    local_failed = [f for f in watch.failed if not any(f.startswith(u) for u in external)]
    if local_failed:
        problems.append("failed requests:\n  " + "\n  ".join(local_failed))
    if watch.console_errors:
        problems.append("console errors:\n  " + "\n  ".join(watch.console_errors))
    if facts["mathNodes"]:
        if not has_mathjax:
            problems.append(f"{facts['mathNodes']} math element(s) but MathJax did not start")
        elif facts["mjx"] < facts["mathNodes"]:
            problems.append(f"MathJax typeset {facts['mjx']} of {facts['mathNodes']} math elements")
    if facts["mjxErrors"]:
        problems.append("MathJax errors: " + "; ".join(facts["mjxErrors"]))
    if facts["rawTex"]:
        problems.append("raw TeX left in the text:\n  " + "\n  ".join(facts["rawTex"][:20]))
    if broken_images:
        problems.append("images that did not load: " + ", ".join(broken_images))
    if facts["widgetsEmpty"]:
        why = "" if has_state else " (the page has no widget state: was the notebook executed with store_widget_state?)"
        problems.append(f"{facts['widgetsEmpty']} of {facts['widgetViews']} Jupyter widget(s) rendered nothing{why}")
    if problems:
        pytest.fail(f"{docname}.html:\n" + "\n".join(problems), pytrace=False)


def test_search_finds_chapter_one(browser, site):
    context, external = browser
    external.clear()
    page = context.new_page()
    watch = PageWatch(page, site)
    try:
        page.goto(site + f"search.html?q={SEARCH_WORD}", wait_until="load", timeout=EVENT_WAIT_MS)
        page.wait_for_selector("#search-results ul.search li", timeout=EVENT_WAIT_MS)
        page.wait_for_function(
            "() => document.querySelector('#search-results .search-summary')?.textContent.trim().length > 0",
            timeout=EVENT_WAIT_MS)
        hrefs = page.eval_on_selector_all("#search-results ul.search li a", "as => as.map(a => a.href)")
        page.screenshot(path=str(_screenshot_path("search")), full_page=False)
    finally:
        page.close()
    assert not external, f"search page requested {external}"
    assert not watch.failed, f"search page: failed requests {watch.failed}"
    assert not watch.console_errors, f"search page: console errors {watch.console_errors}"
    assert any(urlsplit(h).path.endswith(f"/{FIRST_CHAPTER}.html") for h in hrefs), (
        f"searching {SEARCH_WORD!r} did not list {FIRST_CHAPTER}.html; results: {hrefs}")


# A chapter whose page shows widgets: frozen views in the HTML (book/_ext/frozen_widgets.py).
WIDGET_PAGE = next((d for d in DOCNAMES if "ch07" in d), None)

FROZEN_FACTS = """() => {
  const views = Array.from(document.querySelectorAll('script[type="application/vnd.jupyter.widget-view+json"]'))
                     .map(s => s.parentElement);
  // form controls, and the sliders (noUiSlider divs: disabled by their attribute)
  const controls = views.flatMap(v => Array.from(v.querySelectorAll('input, select, textarea, button, .noUi-target')));
  return {
    views: views.length,
    frozen: views.filter(v => v.classList.contains('uwtutor-frozen')).length,
    notes: views.map(v => { const p = v.querySelector(':scope > p.uwtutor-frozen-note');
                            return p ? p.innerText : null; }),
    controls: controls.length,
    enabled: controls.filter(c => c.classList.contains('noUi-target') ? !c.hasAttribute('disabled')
                                                                        : !c.disabled).length,
    sliders: views.flatMap(v => Array.from(v.querySelectorAll('.widget-slider'))).length,
    focusableHandles: views.flatMap(v => Array.from(v.querySelectorAll('.noUi-handle')))
                           .filter(h => h.getAttribute('tabindex') !== '-1').length,
    editableReadouts: views.flatMap(v => Array.from(v.querySelectorAll('[contenteditable="true"]'))).length,
  };
}"""


def test_frozen_widgets_say_so_and_do_not_move(browser, site):
    """In the HTML a widget is the view at its default settings: every control is disabled, a note above it says
    where the live version runs, and neither a key press nor a drag moves a slider's readout."""
    if WIDGET_PAGE is None:
        pytest.skip("no chapter 7 in the table of contents")
    context, external = browser
    external.clear()
    page = context.new_page()
    watch = PageWatch(page, site)
    try:
        page.goto(site + f"{WIDGET_PAGE}.html", wait_until="load", timeout=EVENT_WAIT_MS)
        page.wait_for_function(
            """() => Array.from(document.querySelectorAll(
                 'script[type="application/vnd.jupyter.widget-view+json"]'))
                 .every(s => s.parentElement.classList.contains('uwtutor-frozen'))""", timeout=EVENT_WAIT_MS)
        facts = page.evaluate(FROZEN_FACTS)
        slider = page.locator(".uwtutor-frozen .widget-slider").first
        slider.scroll_into_view_if_needed()
        readout = slider.locator(".widget-readout")
        before = readout.inner_text()
        handle = slider.locator(".noUi-handle")
        handle.focus()                                    # focus() works on any element; the keys must do nothing
        for key in ("ArrowRight", "ArrowRight", "End"):
            page.keyboard.press(key)
        box = slider.locator(".noUi-target").bounding_box()
        page.mouse.click(box["x"] + 0.9 * box["width"], box["y"] + box["height"] / 2)   # a click on the track
        after = readout.inner_text()
        widget = page.locator(".uwtutor-frozen").first
        widget.screenshot(path=str(_screenshot_path(f"{WIDGET_PAGE}-frozen-widget")))
    finally:
        page.close()
    assert not external, f"requests left 127.0.0.1: {external}"
    assert not watch.console_errors, f"console errors: {watch.console_errors}"
    assert facts["views"] >= 1 and facts["frozen"] == facts["views"], facts
    assert facts["controls"] >= 3 and facts["enabled"] == 0, f"controls left enabled: {facts}"
    assert facts["sliders"] >= 1 and facts["focusableHandles"] == 0 and facts["editableReadouts"] == 0, facts
    for note in facts["notes"]:
        assert note and "frozen view" in note and "JupyterLab" in note and "make lab" in note, facts["notes"]
    assert any("from uwtutor.widgets import bias_tracking_widget" in n for n in facts["notes"]), facts["notes"]
    assert after == before, f"a frozen slider moved: its readout went from {before!r} to {after!r}"
