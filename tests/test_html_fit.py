"""The built book fits a laptop (1280 px) and a phone (390 px): nothing overflows sideways (issue 24).

One Chromium (the browser test's: offline, every request off 127.0.0.1 aborted), one page per width, reused for
every page of the table of contents. On each page, measured in the DOM once MathJax has typeset and the frozen
widgets have rendered:

- **code blocks** (every visible ``pre``, inputs and outputs): ``scrollWidth > clientWidth`` is an overflow;
- **display equations** (MathJax's ``mjx-container[display]``): wider than the box they sit in is an overflow,
  unless the equation scrolls *visibly*: its box scrolls (``overflow-x: auto|scroll``) and shows that it does
  (a scroll shadow, a background gradient, as ``_static/fit.css`` gives ``div.math``). An equation that can be
  broken is broken (``aligned``/``split``); the visible scroll is for what cannot be;
- **the page itself**: ``document.documentElement.scrollWidth > clientWidth`` (the reader would scroll the whole
  page sideways); the test names the widest elements that stick out.

``python tests/test_html_fit.py [HTML_DIR]`` prints the same counts for a built book without pytest
(``-v``: every overflow; ``-kNAME``: only the pages whose name holds NAME) (for instance
the main checkout's ``_build/html``), page by page.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from book_paths import HTML_DIR, toc_docnames  # noqa: E402
from test_browser import WAIT_FOR_MATHJAX, browser, site  # noqa: E402,F401  (fixtures: one server, one Chromium)

pytestmark = pytest.mark.browser

WIDTHS = {"laptop": 1280, "phone": 390}
HEIGHT = 800
DOCNAMES = toc_docnames()

# Wait (bounded) for the frozen widgets of a page to render: their width counts as much as the rest.
WAIT_FOR_WIDGETS = """() => Array.from(document.querySelectorAll(
    'script[type="application/vnd.jupyter.widget-view+json"]'))
    .every(s => s.parentElement.querySelector('.widget-subarea > *'))"""

# Everything that overflows sideways on the page as it is laid out now.
MEASURE = r"""() => {
  const TOL = 1;  // px: sub-pixel rounding
  const visible = el => el.offsetParent !== null && el.clientWidth > 0;
  const where = el => {
    const sec = el.closest('section[id]');
    return sec ? '#' + sec.id : '';
  };
  const code = [];
  for (const pre of document.querySelectorAll('pre')) {
    if (!visible(pre) || pre.scrollWidth <= pre.clientWidth + TOL) continue;
    const kind = pre.closest('.cell_input') ? 'input' : pre.closest('.cell_output') ? 'output' : 'other';
    const lines = pre.textContent.split('\n');
    const longest = lines.reduce((a, b) => (b.length > a.length ? b : a), '');
    code.push({kind, where: where(pre), hidden_px: pre.scrollWidth - pre.clientWidth,
               longest: longest.length, text: longest.slice(0, 100)});
  }
  const equations = [];
  let scrolling = 0;
  for (const mj of document.querySelectorAll('mjx-container[display="true"]')) {
    if (!visible(mj.parentElement || mj)) continue;
    // The box the equation sits in: its own container and the Sphinx div.math around it.
    const boxes = [mj, mj.parentElement].filter(Boolean);
    const inner = mj.firstElementChild;
    const need = inner ? inner.getBoundingClientRect().width : mj.scrollWidth;
    const over = boxes.find(b => b.scrollWidth > b.clientWidth + TOL || need > b.clientWidth + TOL);
    if (!over) continue;
    const scroller = boxes.find(b => ['auto', 'scroll'].includes(getComputedStyle(b).overflowX));
    const cue = scroller && /gradient/.test(getComputedStyle(scroller).backgroundImage);
    if (scroller && cue) { scrolling += 1; continue; }
    const tex = (mj.querySelector('mjx-assistive-mml') || mj).textContent.replace(/\s+/g, ' ');
    equations.push({where: where(mj), hidden_px: Math.round(need - over.clientWidth),
                    scrolls: !!scroller, text: tex.slice(0, 80)});
  }
  const root = document.documentElement;
  const page = root.scrollWidth > root.clientWidth + TOL;
  const culprits = [];
  if (page) {
    const limit = root.clientWidth + TOL;
    const clipped = el => {  // inside a box that scrolls or clips: it cannot widen the page
      for (let a = el.parentElement; a && a !== document.body; a = a.parentElement) {
        if (getComputedStyle(a).overflowX !== 'visible') return true;
      }
      return false;
    };
    for (const el of document.body.querySelectorAll('*')) {
      const r = el.getBoundingClientRect();
      if (r.width === 0 || r.right <= limit) continue;
      if (el.parentElement && el.parentElement.getBoundingClientRect().right > limit) continue;  // outermost only
      if (clipped(el)) continue;
      culprits.push(`${el.tagName.toLowerCase()}.${String(el.className).split(' ')[0]} ${where(el)} ` +
                    `(right edge ${Math.round(r.right)} px)`);
      if (culprits.length >= 5) break;
    }
  }
  return {code, equations, scrolling, page: page ? {scrollWidth: root.scrollWidth, clientWidth: root.clientWidth,
          culprits} : null};
}"""


def measure(page, url: str) -> dict:
    """Load ``url`` in ``page`` (at its viewport) and return what overflows (see MEASURE)."""
    page.goto(url, wait_until="load", timeout=60_000)
    page.evaluate(WAIT_FOR_MATHJAX)
    if page.locator('script[type="application/vnd.jupyter.widget-state+json"]').count():
        try:
            page.wait_for_function(WAIT_FOR_WIDGETS, timeout=20_000)
        except Exception:  # an empty widget is test_browser's failure; measure what is there
            pass
    page.evaluate("() => new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))")
    return page.evaluate(MEASURE)


def problems(facts: dict) -> list[str]:
    out = [f"code block ({c['kind']}, {c['where']}) {c['hidden_px']} px too wide; "
           f"longest line {c['longest']} chars: {c['text']!r}" for c in facts["code"]]
    out += [f"display equation ({e['where']}) cut by {e['hidden_px']} px"
            f"{' (scrolls with no visible cue)' if e['scrolls'] else ''}: {e['text']!r}" for e in facts["equations"]]
    if facts["page"]:
        p = facts["page"]
        out.append(f"the page scrolls sideways ({p['scrollWidth']} px in {p['clientWidth']} px); "
                   "sticking out: " + "; ".join(p["culprits"]))
    return out


@pytest.fixture(scope="module")
def pages(browser):  # noqa: F811  (the fixture imported above)
    """One tab per width, reused for every page of the book."""
    context, _external = browser
    tabs = {}
    for name, width in WIDTHS.items():
        tab = context.new_page()
        tab.set_viewport_size({"width": width, "height": HEIGHT})
        tabs[name] = tab
    yield tabs
    for tab in tabs.values():
        tab.close()


@pytest.mark.parametrize("width", list(WIDTHS))
@pytest.mark.parametrize("docname", DOCNAMES)
def test_page_fits(pages, site, browser, docname, width):  # noqa: F811  (the fixtures imported above)
    _context, external = browser
    external.clear()
    if not (HTML_DIR / f"{docname}.html").is_file():
        pytest.fail(f"{docname}.html was not built", pytrace=False)
    found = problems(measure(pages[width], site + f"{docname}.html"))
    assert not external, f"{docname}.html requested {sorted(set(external))}"
    if found:
        pytest.fail(f"{docname}.html at {WIDTHS[width]} px: {len(found)} overflow(s)\n  " + "\n  ".join(found),
                    pytrace=False)


# --- the counts, without pytest --------------------------------------------------------------------------------

def main(argv: list[str]) -> int:
    """Print, page by page and width by width, how many code blocks, equations and pages overflow."""
    import tempfile

    from playwright.sync_api import sync_playwright

    from book_paths import serve_directory
    from test_browser import CHROMIUM, CHROMIUM_FLAGS

    verbose = "-v" in argv
    only = [a[2:] for a in argv if a.startswith("-k")]
    paths = [a for a in argv if not a.startswith("-")]
    html = Path(paths[0]).resolve() if paths else HTML_DIR
    totals = {w: {"code": 0, "input": 0, "output": 0, "equations": 0, "scrolling": 0, "pages": 0} for w in WIDTHS}
    with serve_directory(html) as base, sync_playwright() as pw, tempfile.TemporaryDirectory() as profile:
        context = pw.chromium.launch_persistent_context(
            profile, executable_path=str(CHROMIUM), headless=True, args=CHROMIUM_FLAGS, service_workers="block")
        context.route("**/*", lambda r: r.continue_() if r.request.url.startswith(base) else r.abort())
        tabs = {}
        for name, width in WIDTHS.items():
            tabs[name] = context.new_page()
            tabs[name].set_viewport_size({"width": width, "height": HEIGHT})
        print(f"{'page':38s} " + " ".join(f"{w + ' code/eq/page':>22s}" for w in WIDTHS))
        for doc in DOCNAMES:
            if only and not any(o in doc for o in only):
                continue
            row = []
            for name in WIDTHS:
                facts = measure(tabs[name], base + f"{doc}.html")
                t = totals[name]
                t["code"] += len(facts["code"])
                for c in facts["code"]:
                    t[c["kind"]] = t.get(c["kind"], 0) + 1
                t["equations"] += len(facts["equations"])
                t["scrolling"] += facts["scrolling"]
                t["pages"] += bool(facts["page"])
                row.append(f"{len(facts['code']):>12d}/{len(facts['equations'])}/{int(bool(facts['page']))}"
                           f"{'':>6s}")
                if verbose:
                    for line in problems(facts):
                        print(f"    [{name}] {line}")
            print(f"{doc:38s} " + " ".join(f"{r:>22s}" for r in row))
        context.close()
    for name, t in totals.items():
        print(f"{name} ({WIDTHS[name]} px): {t['code']} code blocks overflow ({t['input']} inputs, {t['output']} "
              f"outputs), {t['equations']} display equations cut ({t['scrolling']} scroll visibly), "
              f"{t['pages']} pages scroll sideways")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
