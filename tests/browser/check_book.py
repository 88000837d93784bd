"""Open every page of the built book in headless Chromium and check what a reader sees.

``make book-check`` runs this after ``make book`` (or ``make book QUICK=1``). It serves
``build/book`` on loopback (a free port) and, through Playwright and Debian's Chromium, checks:

* every page loads with no console error, no uncaught script error, no failed request, and
  nothing from outside the site (a reader offline sees the same page);
* every lesson page has figures (images), none of them broken (all decoded, non-zero size),
  and every image has alt text or sits in a figure with a caption;
* every animation steps to another frame when its "Next frame" button is clicked;
* no page shows an error output or the word "Traceback";
* the navigation of the front page reaches every lesson of ``notebooks/``;
* the search page finds "Eq. 5";
* axe-core's accessibility rules (``axe.min.js`` from the ``axe-playwright-python`` wheel,
  read from disk) report no serious or critical violation on three pages.

``--figures DIR`` also saves screenshots of two pages there (the README shows them).
Exits 0 when every check passes, 1 when one fails, 2 on a setup problem.
"""

from __future__ import annotations

import argparse
import functools
import http.server
import json
import re
import shutil
import sys
import threading
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
CHROMIUM = "/usr/bin/chromium" if Path("/usr/bin/chromium").exists() else shutil.which("chromium")
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                 "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync"]
AXE_PAGES = ["book/index.html", "notebooks/02_event_frames.html", "notebooks/07_evaluation.html"]
SCREENSHOTS = {"book_lesson02.png": ("notebooks/02_event_frames.html", None),
               # the whole lesson graph, every lesson in it, not the window's first 900 px
               "book_map.png": ("book/_generated/map.html", "img[src*='lesson_graph']")}
SEARCH = "Eq. 5"

JS_IMAGES = """() => Array.from(document.querySelectorAll('article img')).map(img => ({
  src: img.getAttribute('src'), ok: img.complete && img.naturalWidth > 0,
  alt: (img.getAttribute('alt') || '').trim(),
  caption: !!(img.closest('figure') && img.closest('figure').querySelector('figcaption'))
}))"""


class Quiet(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args) -> None:
        pass


def serve(root: Path) -> tuple[http.server.ThreadingHTTPServer, str]:
    handler = functools.partial(Quiet, directory=str(root))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return server, f"http://127.0.0.1:{server.server_address[1]}/"


class Checks:
    def __init__(self) -> None:
        self.failed: list[str] = []
        self.passed = 0

    def check(self, ok: bool, message: str) -> None:
        if ok:
            self.passed += 1
        else:
            self.failed.append(message)
        print(("PASS " if ok else "FAIL ") + message, flush=True)


def lesson_pages() -> list[str]:
    lessons = sorted((REPO / "notebooks").glob("[0-9][0-9]_*.ipynb"))
    return [f"notebooks/{p.stem}.html" for p in lessons]


TABLE_AS_TEXT = re.compile(r"^\s*\|.*\w.*\|\s+\|\s*:?-{3,}")
"""A Markdown table left as text in a paragraph: its header and ``| --- |`` rule run into one
line (a rendered table's text has no pipes; a table printed by code stays a preformatted
block of separate lines, as in JupyterLab, and is not matched)."""


def check_page(page, base: str, path: str, checks: Checks, lesson: bool) -> None:
    errors: list[str] = []
    outside: list[str] = []
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.on("requestfailed", lambda r: errors.append(f"{r.url[:90]}: {r.failure}"))
    page.on("response", lambda r: errors.append(f"{r.url[:90]}: {r.status}")
            if r.status >= 400 else None)
    page.on("request", lambda r: None if r.url.startswith((base, "data:", "blob:"))
            else outside.append(r.url[:90]))
    response = page.goto(base + path, wait_until="load")
    page.wait_for_load_state("networkidle")
    status = response.status if response is not None else "no response"
    checks.check(response is not None and response.ok, f"{path}: loads ({status})")
    checks.check(not errors, f"{path}: no console error {errors[:4]}")
    checks.check(not outside, f"{path}: loads nothing from outside the site {outside[:3]}")
    text = page.inner_text("article") if page.query_selector("article") else page.inner_text("body")
    checks.check("Traceback" not in text, f"{path}: no 'Traceback' on the page")
    raw_tables = [line[:60] for line in text.splitlines() if TABLE_AS_TEXT.match(line)]
    checks.check(not raw_tables, f"{path}: every Markdown table renders as a table, not as "
                                 f"text {raw_tables[:2]}")
    error_outputs = page.query_selector_all("div.output.traceback, div.output.error")
    checks.check(not error_outputs, f"{path}: no error output ({len(error_outputs)})")
    page.evaluate("() => document.querySelectorAll('details').forEach(d => d.open = true)")
    page.evaluate("() => Array.from(document.images).forEach(i => i.loading = 'eager')")
    page.wait_for_load_state("networkidle")
    images = page.evaluate(JS_IMAGES)
    broken = [i["src"][:60] for i in images if not i["ok"]]
    unlabelled = [i["src"][:60] for i in images if not i["alt"] and not i["caption"]]
    if lesson:
        checks.check(len(images) > 0, f"{path}: {len(images)} figures")
    checks.check(not broken, f"{path}: no broken image {broken[:3]}")
    players = page.query_selector_all("img[id^='_anim_img']")
    if players:
        checks.check(all(animation_steps(page, img) for img in players),
                     f"{path}: {len(players)} animation(s) step to another frame")
    checks.check(not unlabelled, f"{path}: every image has alt text or a caption {unlabelled[:3]}")


def animation_steps(page, img) -> bool:
    """Click the "Next frame" button of the matplotlib player around ``img``; True when the
    picture changes."""
    before = img.get_attribute("src")
    player = img.evaluate_handle("i => i.closest('.animation')")
    player.as_element().query_selector("button[title='Next frame']").click()
    page.wait_for_timeout(200)
    return img.get_attribute("src") != before


def check_navigation(page, base: str, checks: Checks, lessons: list[str]) -> None:
    page.goto(base + "book/index.html", wait_until="load")
    hrefs = page.evaluate("() => Array.from(document.querySelectorAll('nav a')).map(a => a.href)")
    reached = {re.sub(r"[#?].*$", "", h).removeprefix(base) for h in hrefs}
    missing = [p for p in lessons if p not in reached]
    checks.check(not missing, f"navigation reaches all {len(lessons)} lessons (missing {missing})")


def check_search(page, base: str, checks: Checks) -> None:
    page.goto(base + "search.html?q=" + SEARCH.replace(" ", "+"), wait_until="load")
    page.wait_for_function("() => document.querySelectorAll('#search-results li, ul.search li')"
                           ".length > 0 || /did not match/.test(document.body.innerText)",
                           timeout=30_000)
    hits = page.evaluate("() => Array.from(document.querySelectorAll('#search-results li, "
                         "ul.search li')).map(li => li.innerText.split('\\n')[0])")
    checks.check(len(hits) > 0, f"search finds {SEARCH!r}: {len(hits)} pages {hits[:4]}")


def check_accessibility(page, base: str, checks: Checks, out: Path) -> list[dict]:
    import axe_playwright_python

    axe = Path(axe_playwright_python.__file__).parent / "axe.min.js"
    found = []
    for path in AXE_PAGES:
        page.goto(base + path, wait_until="load")
        page.add_script_tag(path=str(axe))
        result = page.evaluate("async () => await axe.run(document, {resultTypes: ['violations']})")
        for v in result["violations"]:
            found.append({"page": path, "id": v["id"], "impact": v["impact"],
                          "nodes": len(v["nodes"]), "help": v["help"],
                          "example": v["nodes"][0]["html"][:160] if v["nodes"] else ""})
        serious = [v["id"] for v in result["violations"] if v["impact"] in ("serious", "critical")]
        checks.check(not serious, f"{path}: no serious accessibility violation {serious}")
    (out / "axe.json").write_text(json.dumps(found, indent=1))
    return found


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--book", type=Path, default=REPO / "build" / "book")
    parser.add_argument("--out", type=Path, default=REPO / "build" / "book-check")
    parser.add_argument("--figures", type=Path, help="also save two page screenshots here")
    parser.add_argument("--chromium", default=CHROMIUM)
    args = parser.parse_args(argv)
    if not (args.book / "book" / "index.html").exists():
        print(f"no book at {args.book}: run `make book` (or `make book QUICK=1`) first",
              file=sys.stderr)
        return 2
    if not args.chromium or not Path(args.chromium).exists():
        print("Chromium is missing: apt-get install -y chromium", file=sys.stderr)
        return 2
    from playwright.sync_api import sync_playwright

    args.out.mkdir(parents=True, exist_ok=True)
    server, base = serve(args.book)
    checks = Checks()
    lessons = lesson_pages()
    pages = ["book/index.html", "book/_generated/readme.html", "book/_generated/map.html",
             "book/_generated/paper.html", "docs/instructors.html", "docs/setup.html",
             "docs/developer.html"] + lessons
    try:
        with sync_playwright() as playwright:
            browser = playwright.chromium.launch(executable_path=args.chromium, headless=True,
                                                 args=CHROMIUM_ARGS)
            try:
                for path in pages:
                    page = browser.new_page(viewport={"width": 1280, "height": 900})
                    check_page(page, base, path, checks, lesson=path in lessons)
                    page.close()
                page = browser.new_page(viewport={"width": 1280, "height": 900})
                check_navigation(page, base, checks, lessons)
                check_search(page, base, checks)
                found = check_accessibility(page, base, checks, args.out)
                print(f"axe-core: {len(found)} violations of any impact on {len(AXE_PAGES)} "
                      f"pages, listed in {args.out / 'axe.json'}")
                if args.figures:
                    args.figures.mkdir(parents=True, exist_ok=True)
                    for name, (path, element) in SCREENSHOTS.items():
                        page.goto(base + path, wait_until="load")
                        page.wait_for_load_state("networkidle")
                        shot = page.locator(element).first if element else page
                        shot.screenshot(path=str(args.figures / name))
                        print(f"wrote {args.figures / name}")
            finally:
                browser.close()
    finally:
        server.shutdown()
    print(f"{checks.passed} checks passed, {len(checks.failed)} failed")
    for message in checks.failed:
        print("  FAIL", message)
    return 1 if checks.failed else 0


if __name__ == "__main__":
    sys.exit(main())
