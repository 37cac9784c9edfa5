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
  page sideways); the test names the widest elements that stick out;
- **tables** wider than their box: they must scroll and show it (a scroll shadow no opaque row hides).

The phone is 390x844 CSS px at device scale 3 with touch (Chromium's device emulation). There, also (MEASURE_MEDIA):
slider tracks under MIN_TRACK_PX, widget controls past the column's right edge, animations wider than the column,
figures that do not open full size on a tap, and, for every figure (a cell's PNG, a frozen widget's picture, an
animation's frame): the height of its 10-pt text opened full size (MIN_OPENED_TEXT_PX, from the PNG's own
resolution), its sharpness there (screen pixels per image pixel, MAX_SCREEN_PX_PER_IMAGE_PX) and its proportions.

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
MEASURE = r"""(PHONE) => {
  const TOL = 1;  // px: sub-pixel rounding
  const visible = el => el.offsetParent !== null && el.clientWidth > 0;
  const where = el => {
    const sec = el.closest('section[id]');
    return sec ? '#' + sec.id : '';
  };
  // A box that scrolls sideways and shows it (a scroll shadow: a background gradient, as _static/fit.css gives).
  const scrollsVisibly = el => ['auto', 'scroll'].includes(getComputedStyle(el).overflowX) &&
                               /gradient/.test(getComputedStyle(el).backgroundImage);
  const code = [];
  let codeScrolling = 0;
  for (const pre of document.querySelectorAll('pre')) {
    if (!visible(pre) || pre.scrollWidth <= pre.clientWidth + TOL) continue;
    if (PHONE && scrollsVisibly(pre)) { codeScrolling += 1; continue; }
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
  // Tables wider than their box scroll inside it, and show that they do.
  const tables = [];
  let tablesScrolling = 0;
  for (const table of document.querySelectorAll('article table')) {
    if (!visible(table) || table.scrollWidth <= table.clientWidth + TOL) continue;
    // the shadow is the table's background: an opaque row or cell (the theme's zebra stripes) would hide it
    const opaque = Array.from(table.querySelectorAll('tr, th, td')).some(
      e => /^rgb\(/.test(getComputedStyle(e).backgroundColor));
    if (scrollsVisibly(table) && !opaque) { tablesScrolling += 1; continue; }
    tables.push({where: where(table), hidden_px: table.scrollWidth - table.clientWidth, opaque,
                 text: table.textContent.trim().replace(/\s+/g, ' ').slice(0, 60)});
  }
  return {code, codeScrolling, equations, scrolling, tables, tablesScrolling,
          page: page ? {scrollWidth: root.scrollWidth, clientWidth: root.clientWidth, culprits} : null};
}"""

#: Slider tracks narrower than this (CSS px) cannot be set by a finger.
MIN_TRACK_PX = 80
#: 10-pt text of a figure must show at least this high (CSS px) once the figure is opened full size.
MIN_OPENED_TEXT_PX = 9.0
#: A figure opened full size is sharp when each of its image pixels covers at most this many screen pixels across
#: (a PNG at the figure's resolution, 100 dpi, covers 3 on a 3x screen: blurry; a "retina" PNG 1.5).
MAX_SCREEN_PX_PER_IMAGE_PX = 2.0
#: A picture shown out of its proportions by more than this (relative error of the aspect ratio) is squashed.
MAX_ASPECT_ERROR = 0.02
#: The phone: CSS px, device scale, touch (as tools/screenshots.py --phone).
PHONE = {"width": 390, "height": 844, "deviceScaleFactor": 3, "mobile": True}

# Widgets, animations and figures on a phone: slider tracks, controls past the column's right edge, animations wider
# than the column, figures (a cell's PNG, a widget's picture, an animation's frame) that do not open, and for each
# the size of its 10-pt text in the page and opened full size (a tap on the figure; the view is closed
# again) and how many screen pixels each of its image pixels covers. A figure's text size comes from its real
# resolution: the PNG's own pHYs chunk (matplotlib writes the dpi it drew at; a "retina" PNG has twice the figure's).
MEASURE_MEDIA = r"""async () => {
  const TOL = 1;
  const where = el => { const sec = el.closest('section[id]'); return sec ? '#' + sec.id : ''; };
  const article = document.querySelector('article.bd-article') || document.body;
  const column = article.getBoundingClientRect().right;
  const clipped = el => {
    for (let a = el.parentElement; a && a !== document.body; a = a.parentElement) {
      if (!['visible', 'clip'].includes(getComputedStyle(a).overflowX)) return true;
    }
    return false;
  };
  // The PNG's resolution (pHYs, pixels per metre) in dots per inch; null when it has none.
  const dpiOf = async img => {
    try {
      const data = new DataView(await (await fetch(img.currentSrc || img.src)).arrayBuffer());
      for (let at = 8; at + 12 <= data.byteLength; ) {
        const length = data.getUint32(at);
        const type = String.fromCharCode(...[4, 5, 6, 7].map(i => data.getUint8(at + i)));
        if (type === 'pHYs') return data.getUint8(at + 16) === 1 ? data.getUint32(at + 8) * 0.0254 : null;
        if (type === 'IDAT') return null;
        at += 12 + length;
      }
    } catch (e) { /* not a PNG */ }
    return null;
  };
  const sliders = [], pastEdge = [], animations = [], unzoomable = [], figures = [];
  for (const track of document.querySelectorAll('.jupyter-widgets .widget-hslider .slider-container')) {
    const w = track.getBoundingClientRect().width;
    const label = track.parentElement.querySelector('.widget-label');
    sliders.push({where: where(track), width: Math.round(w), label: label ? label.textContent.trim() : ''});
  }
  for (const el of document.querySelectorAll('.jupyter-widgets .widget-inline-hbox, .jupyter-widgets select, '
                                             + '.jupyter-widgets button, .jupyter-widgets .widget-readout')) {
    const r = el.getBoundingClientRect();
    if (r.width > 0 && r.right > column + TOL && !clipped(el)) {
      pastEdge.push({where: where(el), what: el.className.split(' ')[0] || el.tagName.toLowerCase(),
                     past_px: Math.round(r.right - column)});
    }
  }
  for (const anim of document.querySelectorAll('div.cell_output .animation')) {
    let right = anim.getBoundingClientRect().right;
    for (const el of anim.querySelectorAll('*')) right = Math.max(right, el.getBoundingClientRect().right);
    if (right > column + TOL) animations.push({where: where(anim), past_px: Math.round(right - column)});
  }
  const ratio = window.devicePixelRatio;
  const text10 = (dpi, cssPerImagePx) => dpi === null ? null : +(10 / 72 * dpi * cssPerImagePx).toFixed(1);
  for (const img of document.querySelectorAll('div.cell_output img')) {
    if (img.offsetParent === null || !img.naturalWidth) continue;
    const kind = img.closest('.animation') ? 'animation' : img.closest('.jupyter-widgets') ? 'widget' : 'figure';
    if (kind !== 'widget' && !img.classList.contains('uwtutor-zoomable')) {
      unzoomable.push({where: where(img)});
      continue;
    }
    const dpi = await dpiOf(img);
    const box = img.getBoundingClientRect();
    const inPage = box.width / img.naturalWidth;  // CSS px per image px
    // a width and a height attribute (a retina PNG's display size) must not squash the picture in a narrow column
    const squashed = box.height > 0 && Math.abs(box.width / box.height * img.naturalHeight / img.naturalWidth - 1);
    let opened = null, fits = false;
    img.click();  // a tap opens the figure, the widget's picture, the animation's frame
    const view = document.querySelector('div.uwtutor-zoom');
    if (view) {
      opened = view.querySelector('img').getBoundingClientRect().width / img.naturalWidth;
      fits = document.documentElement.scrollWidth <= document.documentElement.clientWidth + TOL;
      view.querySelector('button').click();
    }
    const closed = !document.querySelector('div.uwtutor-zoom');
    figures.push({where: where(img), kind, dpi: dpi === null ? null : Math.round(dpi),
                  image_px: img.naturalWidth, page_text_px: text10(dpi, inPage),
                  opened_text_px: opened === null ? null : text10(dpi, opened),
                  page_screen_px: +(ratio * inPage).toFixed(2),
                  opened_screen_px: opened === null ? null : +(ratio * opened).toFixed(2),
                  squashed: +(squashed || 0).toFixed(3), page_fits: fits, closed});
  }
  return {sliders, pastEdge, animations, unzoomable, figures, devicePixelRatio: ratio};
}"""


def phone_tab(context):
    """A tab of ``context`` that plays the phone (PHONE: 390x844 CSS px, device scale 3, touch), by Chromium's
    device emulation (the shared browser context is not a phone's)."""
    tab = context.new_page()
    cdp = context.new_cdp_session(tab)
    cdp.send("Emulation.setDeviceMetricsOverride", PHONE)
    cdp.send("Emulation.setTouchEmulationEnabled", {"enabled": True, "maxTouchPoints": 5})
    tab._uwtutor_cdp = cdp  # kept alive with the tab
    return tab


def measure(page, url: str, phone: bool = False) -> dict:
    """Load ``url`` in ``page`` (at its viewport) and return what overflows (see MEASURE), and on a phone what
    MEASURE_MEDIA finds."""
    page.goto(url, wait_until="load", timeout=60_000)
    page.evaluate(WAIT_FOR_MATHJAX)
    if page.locator('script[type="application/vnd.jupyter.widget-state+json"]').count():
        try:
            page.wait_for_function(WAIT_FOR_WIDGETS, timeout=20_000)
        except Exception:  # an empty widget is test_browser's failure; measure what is there
            pass
    page.evaluate("() => new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))")
    facts = page.evaluate(MEASURE, phone)
    if phone:
        page.evaluate("() => Promise.all(Array.from(document.images).map(i => i.decode().catch(() => null)))")
        facts.update(page.evaluate(MEASURE_MEDIA))
    return facts


def problems(facts: dict) -> list[str]:
    out = [f"code block ({c['kind']}, {c['where']}) {c['hidden_px']} px too wide; "
           f"longest line {c['longest']} chars: {c['text']!r}" for c in facts["code"]]
    out += [f"display equation ({e['where']}) cut by {e['hidden_px']} px"
            f"{' (scrolls with no visible cue)' if e['scrolls'] else ''}: {e['text']!r}" for e in facts["equations"]]
    out += [f"table ({t['where']}) scrolls {t['hidden_px']} px with no visible cue"
            f"{' (opaque rows hide its shadow)' if t['opaque'] else ''}: {t['text']!r}"
            for t in facts["tables"]]
    out += [f"slider track ({s['where']}, {s['label']!r}) {s['width']} px wide (under {MIN_TRACK_PX})"
            for s in facts.get("sliders", []) if s["width"] < MIN_TRACK_PX]
    out += [f"widget control {c['what']} ({c['where']}) {c['past_px']} px past the column's edge"
            for c in facts.get("pastEdge", [])]
    out += [f"animation ({a['where']}) {a['past_px']} px wider than the column" for a in facts.get("animations", [])]
    out += [f"figure ({u['where']}) does not open full size on a tap" for u in facts.get("unzoomable", [])]
    for f in facts.get("figures", []):
        name = f"{f['kind']} ({f['where']})"
        if f["dpi"] is None:
            out.append(f"{name}: its PNG does not say its resolution (no pHYs): its text size cannot be measured")
        if f["squashed"] > MAX_ASPECT_ERROR:
            out.append(f"{name}: shown {100 * f['squashed']:.0f} % out of its proportions")
        if f["opened_screen_px"] is None or not f["closed"]:
            out.append(f"{name}: the full-size view did not open and close")
            continue
        if f["dpi"] is not None and f["opened_text_px"] < MIN_OPENED_TEXT_PX:
            out.append(f"{name}: 10-pt text {f['opened_text_px']} px high opened full size "
                       f"(under {MIN_OPENED_TEXT_PX})")
        if f["opened_screen_px"] > MAX_SCREEN_PX_PER_IMAGE_PX:
            out.append(f"{name}: blurry opened full size: each image pixel covers {f['opened_screen_px']} screen "
                       f"pixels (over {MAX_SCREEN_PX_PER_IMAGE_PX}; a PNG at twice the figure's resolution is sharp)")
        if not f["page_fits"]:
            out.append(f"{name}: the full-size view widens the page")
    if facts["page"]:
        p = facts["page"]
        out.append(f"the page scrolls sideways ({p['scrollWidth']} px in {p['clientWidth']} px); "
                   "sticking out: " + "; ".join(p["culprits"]))
    return out


@pytest.fixture(scope="module")
def pages(browser):  # noqa: F811  (the fixture imported above)
    """One tab per width, reused for every page of the book."""
    context, _external = browser
    tabs = {"laptop": context.new_page(), "phone": phone_tab(context)}
    tabs["laptop"].set_viewport_size({"width": WIDTHS["laptop"], "height": HEIGHT})
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
    found = problems(measure(pages[width], site + f"{docname}.html", phone=width == "phone"))
    assert not external, f"{docname}.html requested {sorted(set(external))}"
    if found:
        pytest.fail(f"{docname}.html at {WIDTHS[width]} px: {len(found)} overflow(s)\n  " + "\n  ".join(found),
                    pytrace=False)


# --- the counts, without pytest --------------------------------------------------------------------------------

def main(argv: list[str]) -> int:
    """Print, page by page and width by width, how many code blocks, equations, pages and tables overflow, and the
    phone's widgets, animations and figures."""
    import tempfile

    from playwright.sync_api import sync_playwright

    from book_paths import serve_directory
    from test_browser import CHROMIUM, CHROMIUM_FLAGS

    verbose = "-v" in argv
    only = [a[2:] for a in argv if a.startswith("-k")]
    paths = [a for a in argv if not a.startswith("-")]
    html = Path(paths[0]).resolve() if paths else HTML_DIR
    totals = {w: {"code": 0, "input": 0, "output": 0, "code_scrolling": 0, "equations": 0, "scrolling": 0,
                  "pages": 0, "tables": 0, "tables_scrolling": 0} for w in WIDTHS}
    media: dict[str, list] = {"sliders": [], "pastEdge": [], "animations": [], "unzoomable": [], "figures": []}
    with serve_directory(html) as base, sync_playwright() as pw, tempfile.TemporaryDirectory() as profile:
        context = pw.chromium.launch_persistent_context(
            profile, executable_path=str(CHROMIUM), headless=True, args=CHROMIUM_FLAGS, service_workers="block")
        context.route("**/*", lambda r: r.continue_() if r.request.url.startswith(base) else r.abort())
        tabs = {"laptop": context.new_page(), "phone": phone_tab(context)}
        tabs["laptop"].set_viewport_size({"width": WIDTHS["laptop"], "height": HEIGHT})
        print(f"{'page':38s} " + " ".join(f"{w + ' code/eq/page/table':>24s}" for w in WIDTHS))
        for doc in DOCNAMES:
            if only and not any(o in doc for o in only):
                continue
            row = []
            for name in WIDTHS:
                facts = measure(tabs[name], base + f"{doc}.html", phone=name == "phone")
                t = totals[name]
                t["code"] += len(facts["code"])
                for c in facts["code"]:
                    t[c["kind"]] = t.get(c["kind"], 0) + 1
                t["code_scrolling"] += facts["codeScrolling"]
                t["equations"] += len(facts["equations"])
                t["scrolling"] += facts["scrolling"]
                t["pages"] += bool(facts["page"])
                t["tables"] += len(facts["tables"])
                t["tables_scrolling"] += facts["tablesScrolling"]
                for key in media:
                    media[key] += facts.get(key, [])
                row.append(f"{len(facts['code']):>12d}/{len(facts['equations'])}/{int(bool(facts['page']))}"
                           f"/{len(facts['tables'])}{'':>6s}")
                if verbose:
                    for line in problems(facts):
                        print(f"    [{name}] {line}")
            print(f"{doc:38s} " + " ".join(f"{r:>24s}" for r in row))
        context.close()
    for name, t in totals.items():
        print(f"{name} ({WIDTHS[name]} px): {t['code']} code blocks overflow ({t['input']} inputs, {t['output']} "
              f"outputs; {t['code_scrolling']} more scroll visibly), {t['equations']} display equations cut "
              f"({t['scrolling']} scroll visibly), {t['pages']} pages scroll sideways, {t['tables']} tables scroll "
              f"with no cue ({t['tables_scrolling']} with one)")
    figs = media["figures"]
    short = [s for s in media["sliders"] if s["width"] < MIN_TRACK_PX]
    print(f"phone widgets: {len(short)} of {len(media['sliders'])} slider tracks under {MIN_TRACK_PX} px (narrowest "
          f"{min((s['width'] for s in media['sliders']), default=0)} px), {len(media['pastEdge'])} controls past the "
          f"column's edge; {len(media['animations'])} animations wider than the column")
    for kind in ("figure", "widget", "animation"):
        group = [f for f in figs if f["kind"] == kind]
        if not group:
            continue
        page_px = sorted(f["page_text_px"] or 0.0 for f in group)
        page_scr = sorted(f["page_screen_px"] for f in group)
        line = (f"phone {kind}s: {len(group)}; 10-pt text in the page {page_px[0]}-{page_px[-1]} px (median "
                f"{page_px[len(group) // 2]}; {sum(p < 7 for p in page_px)} under 7 px); screen px per image px in "
                f"the page: median {page_scr[len(group) // 2]}; no resolution (pHYs): "
                f"{sum(f['dpi'] is None for f in group)}; dpi {sorted({f['dpi'] for f in group}, key=str)}")
        opened = sorted(f["opened_text_px"] or 0.0 for f in group)
        opened_scr = sorted(f["opened_screen_px"] or 0.0 for f in group)
        line += (f"; opened: 10-pt text {opened[0]}-{opened[-1]} px, screen px per image px {opened_scr[0]}-"
                 f"{opened_scr[-1]} ({sum(x > MAX_SCREEN_PX_PER_IMAGE_PX for x in opened_scr)} over "
                 f"{MAX_SCREEN_PX_PER_IMAGE_PX})")
        print(line)
    print(f"phone figures that do not open on a tap: {len(media['unzoomable'])}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
