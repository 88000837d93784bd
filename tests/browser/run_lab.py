"""Run lessons in a real JupyterLab, driven by headless Chromium, and check what a student sees.

``make browser`` runs this script. It starts a private JupyterLab on loopback
(:mod:`lab_server`), opens each lesson in Debian's Chromium through Playwright, runs every
cell from the Run menu, waits until the kernel is idle and checks (pictures: :mod:`pictures`):

* every code cell ran and no cell shows an error (an ``error`` output in the notebook model,
  a stderr output with a traceback or an ``...Error``, a widget that failed to render);
* each interactive 3D view (pyvista's trame viewer, an iframe in the output area) draws a
  picture: its render view has many colours and a clear spread of pixel values;
* in the dataset explorer (lesson 08) the picture changes when another category is chosen.

Pictures of every check go to ``--out`` (default ``build/browser``); ``--figures DIR`` also
writes the README's two screenshots there. The run has an overall deadline (``--timeout``);
JupyterLab, its kernels and the browser are shut down at the end, also after a failure.
Exits 0 when every check passes, 1 when one fails, 2 on a setup problem, 124 on timeout.
Not pytest modules: pytest does not collect ``tests/browser`` (see its conftest.py).
"""

from __future__ import annotations

import argparse
import io
import json
import os
import re
import shutil
import signal
import sys
import tempfile
import threading
import time
import urllib.error
import urllib.request
from contextlib import suppress
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from lab_server import REPO, RUNNING, Lab, SetupError, kill_group, pids_with, running_lab
from pictures import is_drawn, picture_difference, picture_stats, save_figure

CHROMIUM = "/usr/bin/chromium" if Path("/usr/bin/chromium").exists() else shutil.which("chromium")
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                 "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync"]
LESSONS = ["notebooks/00_start_here.ipynb", "notebooks/08_visualizing_in_3d.ipynb"]
EXPLORER_LESSON = "08_visualizing_in_3d.ipynb"
VIEWPORT = {"width": 1440, "height": 960}
ERROR_WORD = re.compile(r"Traceback|\b\w*Error\b")
WIDGET_FAILED = ("Error displaying widget", "Failed to load model class", "Error rendering")


class CheckFailed(Exception):
    """A check on what the lab shows failed (exit status 1)."""


@dataclass
class Report:
    """What passed and failed, with a time for each step, printed at the end."""

    passed: list[str] = field(default_factory=list)
    failed: list[str] = field(default_factory=list)
    start: float = field(default_factory=time.monotonic)

    def log(self, message: str) -> None:
        print(f"[{time.monotonic() - self.start:6.1f} s] {message}", flush=True)

    def check(self, ok: bool, message: str) -> bool:
        (self.passed if ok else self.failed).append(message)
        self.log(("PASS " if ok else "FAIL ") + message)
        return ok


# --- the browser ----------------------------------------------------------------------------

JS_KERNEL_STATUS = """() => {
  const w = window.jupyterapp && window.jupyterapp.shell.currentWidget;
  if (!w || !w.sessionContext) return 'no-notebook';
  const s = w.sessionContext.session;
  return s && s.kernel ? s.kernel.status : 'no-kernel';
}"""
JS_NOTEBOOK_JSON = """() => JSON.stringify(
  window.jupyterapp.shell.currentWidget.content.model.toJSON())"""
JS_NOTEBOOK_READY = """() => {
  const w = window.jupyterapp && window.jupyterapp.shell.currentWidget;
  return !!(w && w.content && w.content.model && w.sessionContext);
}"""
JS_WIDE = """() => {
  const shell = window.jupyterapp.shell;
  shell.collapseLeft();
  shell.collapseRight();
}"""
PANEL = ".jp-NotebookPanel:visible"


def wait_until(predicate, timeout: float, what: str, interval: float = 0.5, stable: int = 1):
    """Poll ``predicate`` until it returns a true value ``stable`` times in a row; return the
    value. Raises :class:`CheckFailed` naming ``what`` after ``timeout`` seconds."""
    end, streak = time.monotonic() + timeout, 0
    while True:
        value = predicate()
        streak = streak + 1 if value else 0
        if streak >= stable:
            return value
        if time.monotonic() > end:
            raise CheckFailed(f"timed out after {timeout:.0f} s waiting for {what}")
        time.sleep(interval)


def kernel_status(page) -> str:
    return page.evaluate(JS_KERNEL_STATUS)


def open_notebook(context, lab: Lab, notebook: str, report: Report, timeout: float = 180.0):
    """A new page with ``notebook`` (path from the repository root) open in a workspace of
    its own, side panels closed, its kernel started and idle; returns the page."""
    page = context.new_page()
    page.on("pageerror", lambda error: report.log(f"  page error: {error.name}: "
                                                  f"{error.message[:300]}"))
    workspace = re.sub(r"\W", "", Path(notebook).stem)
    url = f"{lab.base}/lab/workspaces/{workspace}/tree/{notebook}?token={lab.token}"
    page.goto(url, wait_until="domcontentloaded", timeout=timeout * 1000)
    page.wait_for_function(JS_NOTEBOOK_READY, timeout=timeout * 1000)
    page.locator(f"{PANEL} .jp-Cell").first.wait_for(timeout=timeout * 1000)
    wait_until(lambda: kernel_status(page) == "idle", timeout, f"the kernel of {notebook}",
               stable=2)
    page.evaluate(JS_WIDE)
    report.log(f"opened {notebook}; kernel idle")
    return page


def running_prompts(page) -> int:
    """Cells of the open notebook whose prompt shows ``[*]`` (queued or running)."""
    return page.locator(f"{PANEL} .jp-InputPrompt", has_text="*").count()


def run_all_cells(page, notebook: str, report: Report, timeout: float) -> float:
    """Run > Run All Cells from the menu bar, as a student does; wait until no cell runs and
    the kernel stays idle; return the seconds it took."""
    t0 = time.monotonic()
    page.locator(".lm-MenuBar-itemLabel", has_text=re.compile(r"^Run$")).click()
    page.locator(".lm-Menu-itemLabel", has_text=re.compile(r"^Run All Cells$")).click()
    wait_until(lambda: running_prompts(page) > 0 or kernel_status(page) == "busy", 30,
               f"{notebook} to start running", interval=0.2)
    wait_until(lambda: running_prompts(page) == 0 and kernel_status(page) == "idle", timeout,
               f"all cells of {notebook} to finish", interval=1.0, stable=3)
    seconds = time.monotonic() - t0
    report.log(f"ran all cells of {notebook} in {seconds:.0f} s")
    return seconds


def output_text(output: dict) -> str:
    text = output.get("text", "")
    return "".join(text) if isinstance(text, list) else text


def check_no_errors(page, notebook: str, report: Report) -> None:
    """Every code cell ran; no error output, no traceback on stderr, no broken widget."""
    model = json.loads(page.evaluate(JS_NOTEBOOK_JSON))
    code = [(i, c) for i, c in enumerate(model["cells"]) if c["cell_type"] == "code"]
    not_run = [i for i, c in code if c.get("execution_count") is None]
    report.check(not not_run, f"{notebook}: all {len(code)} code cells ran"
                 + (f" (cells {not_run} did not)" if not_run else ""))
    errors = [(i, o.get("ename"), o.get("evalue")) for i, c in code for o in c["outputs"]
              if o["output_type"] == "error"]
    report.check(not errors, f"{notebook}: no cell shows an error"
                 + "".join(f"\n    cell {i}: {name}: {value}" for i, name, value in errors))
    stderr = [(i, output_text(o)) for i, c in code for o in c["outputs"]
              if o["output_type"] == "stream" and o.get("name") == "stderr"]
    for i, text in stderr:
        report.log(f"  stderr of cell {i}: {text.strip()[:300]!r}")
    bad = [i for i, text in stderr if ERROR_WORD.search(text)]
    shown = page.locator(f'{PANEL} .jp-OutputArea-output'
                         '[data-mime-type="application/vnd.jupyter.stderr"]')
    shown_bad = [text[:200] for text in shown.all_text_contents() if ERROR_WORD.search(text)]
    report.check(not bad and not shown_bad, f"{notebook}: no traceback or error on stderr"
                 + (f" (cells {bad}; shown: {shown_bad})" if bad or shown_bad else ""))
    texts = page.locator(f"{PANEL} .jp-OutputArea-output").all_text_contents()
    broken = [text[:200] for text in texts if any(m in text for m in WIDGET_FAILED)]
    report.check(not broken, f"{notebook}: every widget rendered"
                 + (f" (shown: {broken})" if broken else ""))


def trame_views(page):
    """The pyvista trame viewers (iframes) in the open notebook's outputs."""
    return page.locator(f"{PANEL} .jp-OutputArea-output iframe")


def view_picture(view) -> bytes:
    """A screenshot of a trame viewer's render area: the iframe without the toolbar band
    along its top (the toolbar floats over the picture)."""
    from PIL import Image

    image = Image.open(io.BytesIO(view.screenshot()))
    band = min(80, image.height // 5)
    buffer = io.BytesIO()
    image.crop((0, band, image.width, image.height)).save(buffer, "PNG")
    return buffer.getvalue()


def check_3d_views(page, notebook: str, report: Report, out: Path, timeout: float = 90.0):
    """Each trame viewer in the notebook draws a picture (many colours, a clear spread, a
    few percent of pixels off the background) within ``timeout`` seconds."""
    views = trame_views(page)
    count = views.count()
    report.check(count > 0, f"{notebook}: {count} interactive 3D views (trame iframes)")
    for k in range(count):
        view = views.nth(k)
        view.scroll_into_view_if_needed()
        stats: dict = {}

        def drawn(view=view, stats=stats):
            stats.update(picture_stats(view_picture(view)))
            return is_drawn(stats)

        try:
            wait_until(drawn, timeout, f"3D view {k + 1}", interval=2.0)
            ok = True
        except CheckFailed:
            ok = False
        (out / f"{Path(notebook).stem}_view{k + 1}.png").write_bytes(view.screenshot())
        report.check(ok, f"{notebook}: 3D view {k + 1} of {count} draws a picture "
                     f"({stats.get('colours')} colours, std {stats.get('std', 0):.1f}, "
                     f"{stats.get('foreground', 0):.1%} foreground; "
                     f"src {view.get_attribute('src')})")


def explorer_cell(page):
    """The cell whose output holds the dataset explorer (a Dropdown labelled category) and
    that dropdown."""
    label = page.locator("label", has_text=re.compile(r"^category$"))
    dropdown = page.locator(f"{PANEL} .jp-OutputArea-output .widget-dropdown", has=label)
    if dropdown.count() == 0:
        raise CheckFailed("no dataset explorer (a Dropdown labelled 'category') in the outputs")
    dropdown = dropdown.first
    cell = page.locator(f"{PANEL} .jp-Cell", has=page.locator(".widget-dropdown", has=label))
    return cell.first, dropdown


def check_explorer(page, notebook: str, report: Report, out: Path, timeout: float = 180.0):
    """Choose another category in the explorer; its picture (the image output below the
    controls) changes and no error is shown. Returns the explorer cell."""
    cell, dropdown = explorer_cell(page)
    picture = cell.locator(".jp-OutputArea-output img").last
    picture.wait_for(timeout=30_000)
    cell.scroll_into_view_if_needed()
    before_src, before = picture.get_attribute("src"), picture.screenshot()
    (out / "explorer_before.png").write_bytes(before)
    select = dropdown.locator("select")
    options = select.locator("option").all_inner_texts()
    current = select.input_value()
    others = [o for o in options if o != current]
    if not others:
        raise CheckFailed(f"the explorer offers one category only ({options})")
    choice = "airplane" if "airplane" in others else others[0]
    t0 = time.monotonic()
    select.select_option(label=choice)
    wait_until(lambda: picture.get_attribute("src") != before_src, timeout,
               f"the explorer's picture to change after choosing {choice!r}", interval=0.5)
    wait_until(lambda: kernel_status(page) == "idle", timeout, "the kernel after the redraw",
               stable=3)
    after = picture.screenshot()
    (out / "explorer_after.png").write_bytes(after)
    changed = picture_difference(before, after)
    report.check(changed > 0.01, f"{notebook}: explorer picture changes from {current!r} to "
                 f"{choice!r} ({changed:.1%} of pixels differ, {time.monotonic() - t0:.1f} s)")
    report.check(is_drawn(picture_stats(after)), f"{notebook}: explorer picture for {choice!r}"
                 " is drawn")
    errors = [t for t in cell.locator(".jp-OutputArea-output").all_text_contents()
              if ERROR_WORD.search(t) and "Traceback" in t]
    report.check(not errors, f"{notebook}: explorer shows no traceback after the change"
                 + (f" ({errors[0][:300]})" if errors else ""))
    return cell


def largest_view_cell(page):
    """The cell of the largest 3D view (by area) in the open notebook."""
    views = trame_views(page)
    areas = []
    for k in range(views.count()):
        box = views.nth(k).bounding_box() or {"width": 0, "height": 0}
        areas.append(box["width"] * box["height"])
    view = views.nth(int(np.argmax(areas)))
    return view.locator("xpath=ancestor::div[contains(concat(' ', normalize-space(@class), ' '),"
                        " ' jp-Cell ')][1]")


def page_shot(page, element=None) -> bytes:
    """A screenshot of the whole lab window with ``element`` scrolled to the top."""
    if element is not None:
        element.evaluate("e => e.scrollIntoView({block: 'start'})")
        page.wait_for_timeout(1500)
    return page.screenshot()


def shutdown_kernels(lab: Lab) -> None:
    """End every session (and its kernel) through the REST API."""
    with suppress(OSError, urllib.error.URLError, ValueError):
        for session in lab.api("/api/sessions") or []:
            lab.api(f"/api/sessions/{session['id']}", method="DELETE")


# --- the run --------------------------------------------------------------------------------


def run(args, report: Report, home: Path) -> None:
    """Start the lab and the browser, run each lesson and its checks."""
    from playwright.sync_api import Error as PlaywrightError
    from playwright.sync_api import sync_playwright

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if not args.chromium or not Path(args.chromium).exists():
        raise SetupError(f"{args.chromium} is missing; install Debian's chromium "
                         "(apt-get install -y chromium)")
    with running_lab(home, out / "jupyter.log", quick=not args.full) as lab:
        report.log(f"JupyterLab at {lab.base} (log {out / 'jupyter.log'}); "
                   f"{'full' if args.full else 'quick (E2V_QUICK=1)'} mode")
        with sync_playwright() as playwright:
            try:
                context = playwright.chromium.launch_persistent_context(
                    str(home / "chromium"), executable_path=args.chromium, headless=True,
                    args=CHROMIUM_ARGS, viewport=VIEWPORT, timeout=60_000)
            except PlaywrightError as err:
                raise SetupError(f"Chromium did not start: {err}") from err
            try:
                for notebook in args.notebooks:
                    lesson(context, lab, notebook, args, report, out)
            finally:
                context.close()


def lesson(context, lab: Lab, notebook: str, args, report: Report, out: Path) -> None:
    """Open one lesson, run all its cells and check it; its kernel is shut down after."""
    name = Path(notebook).name
    page = open_notebook(context, lab, notebook, report)
    try:
        run_all_cells(page, notebook, report, timeout=args.cell_timeout)
        check_no_errors(page, notebook, report)
        check_3d_views(page, notebook, report, out)
        if args.figures and name == Path(LESSONS[0]).name and trame_views(page).count():
            write_figure(page_shot(page, largest_view_cell(page)),
                         Path(args.figures) / "lab_lesson00.png", report)
        if name == EXPLORER_LESSON:
            cell = check_explorer(page, notebook, report, out)
            if args.figures:
                write_figure(page_shot(page, cell), Path(args.figures) / "lab_explorer.png",
                             report)
        (out / f"{Path(notebook).stem}_end.png").write_bytes(page.screenshot(full_page=True))
    except Exception as err:  # a failed check or a browser step that timed out
        lines = str(err).splitlines()  # Playwright appends Chromium's whole log
        report.check(False, f"{notebook}: {type(err).__name__}: " + "\n    ".join(lines[:4]))
        with suppress(Exception):
            (out / f"{Path(notebook).stem}_failed.png").write_bytes(page.screenshot())
    finally:
        page.close()
        shutdown_kernels(lab)


def write_figure(png: bytes, path: Path, report: Report) -> None:
    size = save_figure(png, path)
    report.log(f"wrote {path} ({size / 1e3:.0f} kB)")


def parse_args(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("notebooks", nargs="*", default=LESSONS,
                        help="lessons to run, paths from the repository root (default: 00, 08)")
    parser.add_argument("--full", action="store_true",
                        help="run the full lessons (default: quick, E2V_QUICK=1)")
    parser.add_argument("--out", default=str(REPO / "build" / "browser"),
                        help="folder for screenshots of each check and the JupyterLab log")
    parser.add_argument("--figures", default=None,
                        help="also write the README's lab_lesson00.png and lab_explorer.png here")
    parser.add_argument("--chromium", default=CHROMIUM, help="the Chromium executable")
    parser.add_argument("--timeout", type=float, default=600.0,
                        help="overall limit in seconds; the run is stopped after it")
    parser.add_argument("--cell-timeout", type=float, default=420.0,
                        help="seconds one lesson may take to run all its cells")
    return parser.parse_args(argv)


def main(argv=None) -> int:
    args = parse_args(argv)
    report = Report()
    home = Path(tempfile.mkdtemp(prefix="e2v_lab_"))

    fired = threading.Event()

    def on_timeout():  # the last resort: stop everything this run started, then exit
        fired.set()
        report.log(f"FAIL the run took longer than {args.timeout:.0f} s; stopping it")
        for lab in list(RUNNING):  # the server first, or it restarts the kernels
            kill_group(lab.process.pid, grace=2)
        for pid in pids_with(str(home)):  # kernels (runtime folder), Chromium (profile)
            kill_group(pid, grace=2)
        shutil.rmtree(home, ignore_errors=True)
        os._exit(124)

    # `kill` or Ctrl-C: leave through the finally blocks, which stop the lab and the browser
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    watchdog = threading.Timer(args.timeout, on_timeout)
    watchdog.daemon = True
    watchdog.start()
    try:
        run(args, report, home)
    except SetupError as err:
        report.log(f"SETUP {err}")
        return 2
    except CheckFailed as err:
        report.check(False, str(err))
    finally:
        watchdog.cancel()
        if fired.is_set():  # let the watchdog finish stopping everything; it exits 124
            watchdog.join()
        shutil.rmtree(home, ignore_errors=True)
    seconds = time.monotonic() - report.start
    print(f"\n{len(report.passed)} checks passed, {len(report.failed)} failed in {seconds:.0f} s")
    for message in report.failed:
        print(f"  FAILED: {message}")
    return 1 if report.failed else 0


if __name__ == "__main__":
    sys.exit(main())
