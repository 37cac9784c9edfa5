"""Dev-only: full-page screenshots of every page of the built book, to look at before a release.

Usage: ``.venv/bin/python tools/screenshots.py [--out _build/screenshots/full] [--width 1280] [page ...]``

``--phone`` plays a phone (390x844 CSS px, device scale 3, touch) and, instead of whole pages, saves views of what a
phone reader meets: ``--element CSS`` the first element matching a selector, scrolled into view (a widget:
``.jupyter-widgets``; a table: ``article table``), ``--open-figure N`` the N-th figure of the page opened full size
by a tap.

Serves ``_build/html`` on 127.0.0.1 (build it first: ``make book``), opens each page of ``_toc.yml``
(or the pages named, e.g. ``book/ch01_positioning_and_errors``) in Debian's Chromium with every
request off 127.0.0.1 blocked, waits for MathJax and the widgets, and saves the whole page as PNG.
The browser test (tests/test_browser.py) saves first-screen views in ``_build/screenshots``.
"""

from __future__ import annotations

import argparse
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path
from urllib.parse import urlsplit

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))

from conftest import HTML_DIR, toc_docnames  # noqa: E402
from test_browser import CHROMIUM, CHROMIUM_FLAGS, IMAGES_LOADED, LOCAL_HOSTS, WAIT_FOR_MATHJAX  # noqa: E402
from test_html_fit import WAIT_FOR_WIDGETS  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("pages", nargs="*", help="docnames (default: every page of _toc.yml)")
    ap.add_argument("--out", type=Path, default=REPO / "_build" / "screenshots" / "full")
    ap.add_argument("--width", type=int, default=1280)
    ap.add_argument("--phone", action="store_true", help="390x844 CSS px, device scale 3, touch")
    ap.add_argument("--element", help="save the view of the first element matching this CSS selector")
    ap.add_argument("--open-figure", type=int, help="tap the N-th figure (from 1) and save the full-size view")
    args = ap.parse_args()
    if not (HTML_DIR / "index.html").is_file():
        sys.exit(f"no book in {HTML_DIR}: run `make book` first")
    from playwright.sync_api import sync_playwright

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    server = subprocess.Popen([sys.executable, "-m", "http.server", "--bind", "127.0.0.1",
                               "--directory", str(HTML_DIR), str(port)],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    base = f"http://127.0.0.1:{port}/"
    blocked: list[str] = []
    try:
        for _ in range(200):
            try:
                urllib.request.urlopen(base + "index.html", timeout=2).close()
                break
            except OSError:
                time.sleep(0.1)
        with sync_playwright() as pw, tempfile.TemporaryDirectory() as profile:
            device = ({"viewport": {"width": 390, "height": 844}, "device_scale_factor": 3, "is_mobile": True,
                       "has_touch": True} if args.phone else {"viewport": {"width": args.width, "height": 800}})
            ctx = pw.chromium.launch_persistent_context(
                profile, executable_path=str(CHROMIUM), headless=True, args=CHROMIUM_FLAGS, **device)

            def guard(route):
                if urlsplit(route.request.url).hostname in LOCAL_HOSTS:
                    route.continue_()
                else:
                    blocked.append(route.request.url)
                    route.abort()

            ctx.route("**/*", guard)
            page = ctx.new_page()
            for doc in args.pages or toc_docnames():
                page.goto(base + f"{doc}.html", wait_until="load")
                page.evaluate(WAIT_FOR_MATHJAX)
                if page.locator('script[type="application/vnd.jupyter.widget-state+json"]').count():
                    page.wait_for_function(WAIT_FOR_WIDGETS, timeout=20_000)  # the frozen widgets drawn
                page.evaluate(IMAGES_LOADED)
                page.wait_for_load_state("networkidle")
                page.wait_for_timeout(500)
                out = args.out / f"{doc}.png"
                out.parent.mkdir(parents=True, exist_ok=True)
                if args.open_figure:
                    figure = page.locator("img.uwtutor-zoomable").nth(args.open_figure - 1)
                    figure.scroll_into_view_if_needed()
                    figure.tap() if args.phone else figure.click()
                    page.wait_for_selector("div.uwtutor-zoom img")
                    page.wait_for_timeout(300)
                    out = out.with_name(f"{out.stem}-figure{args.open_figure}.png")
                    page.screenshot(path=str(out))
                elif args.element:
                    element = page.locator(args.element).first
                    element.scroll_into_view_if_needed()
                    page.wait_for_timeout(300)
                    out = out.with_name(f"{out.stem}-element.png")
                    page.screenshot(path=str(out))
                else:
                    page.screenshot(path=str(out), full_page=True)
                print(out)
            ctx.close()
    finally:
        server.terminate()
        server.wait(timeout=10)
    if blocked:
        print("blocked requests off 127.0.0.1:", *sorted(set(blocked)), sep="\n  ")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
