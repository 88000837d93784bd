"""Sphinx configuration of the e2v notebooks book (``make book``; docs/developer.md, "The book").

The source folder is the repository root (``sphinx-build -c book . build/book``), so the
lessons are read where they live (``notebooks/*.ipynb``) and run from there, finding
``../data_small`` as in JupyterLab, and so are the guides (``docs/*.md``). Pages generated from
the library (the README with its figures, the lesson map, the paper's facts) are written to
``book/_generated/`` first.
"""

from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "book"))

from pages import write_pages  # noqa: E402

QUICK = os.environ.get("E2V_QUICK") == "1"
INLINE_BACKEND = "module://matplotlib_inline.backend_inline"
"""The plotting backend whose figures land in a lesson's page."""


def kernel_environment(environ=os.environ) -> None:
    """Set what the lessons' kernels inherit from this process: 3D views as pictures in the
    page, and figures by the inline backend, replacing any ``MPLBACKEND`` of the shell (a
    server's ``Agg`` would build a book whose lessons have no figures, silently)."""
    environ["PYVISTA_JUPYTER_BACKEND"] = "static"
    if environ.get("MPLBACKEND", INLINE_BACKEND) != INLINE_BACKEND:
        print(f"book: MPLBACKEND={environ['MPLBACKEND']} of the shell replaced by the inline "
              "backend for the lessons' kernels", file=sys.stderr)
    environ["MPLBACKEND"] = INLINE_BACKEND


kernel_environment()
write_pages(ROOT / "book" / "_generated")

project = "e2v notebooks"
author = "the e2v notebooks authors"
copyright = "2026, the e2v notebooks authors; code MIT, lessons and figures CC BY 4.0"
root_doc = "book/index"
extensions = ["myst_nb"]
include_patterns = ["book/index.md", "book/_generated/*.md", "docs/*.md",
                    "notebooks/[0-9][0-9]_*.ipynb",
                    "notebooks/appendix_going_further.ipynb"]
exclude_patterns = ["build", ".venv", "**/.ipynb_checkpoints"]
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "html_image"]
myst_heading_anchors = 3
# Markdown that a lesson's code displays (display(Markdown(...))) is parsed as MyST, which has
# tables, as JupyterLab renders them; CommonMark, the default, would show their pipes as text.
nb_render_markdown_format = "myst"
suppress_warnings = ["myst.header", "misc.highlighting_failure"]

# Execution: every lesson runs in a fresh kernel from notebooks/; jupyter-cache keeps the outputs
# of a lesson whose code is unchanged, so a rebuild runs only the lessons that changed. The cache
# of the quick build is kept apart from the full one.
#
# jupyter-cache keys a lesson on its code cells only, but a lesson's outputs also come from the
# library, the shipped data and the recorded results it reads. Their digest names the cache
# folder, so that changing any of them re-runs every lesson (older caches are removed).
INPUTS = ("e2vlib", "data_small", "experiments/results", "bench/RESULTS.md")


def inputs_digest() -> str:
    """sha256 (first 12 hex digits) over the paths and bytes of every file in ``INPUTS``."""
    import hashlib

    digest = hashlib.sha256()
    for name in INPUTS:
        path = ROOT / name
        files = [path] if path.is_file() else sorted(p for p in path.rglob("*") if p.is_file())
        for file in files:
            if "__pycache__" not in file.parts:
                digest.update(str(file.relative_to(ROOT)).encode() + b"\0" + file.read_bytes())
    return digest.hexdigest()[:12]


def cache_folder() -> Path:
    parent = ROOT / "build" / ("jupyter_cache_quick" if QUICK else "jupyter_cache")
    folder = parent / inputs_digest()
    if parent.exists():
        for old in parent.iterdir():
            if old != folder and old.is_dir():
                shutil.rmtree(old)
    return folder


nb_execution_mode = "cache"
nb_execution_cache_path = str(cache_folder())
nb_execution_timeout = 1800
nb_execution_raise_on_error = True  # any cell error fails the build
nb_execution_show_tb = True  # with the lesson, the cell and its traceback on stderr
nb_merge_streams = True
nb_output_stderr = "remove"  # progress bars' stderr lines; their widget view stays
# Widgets need a kernel: the page shows each one's still picture, and loads no widget scripts
# (they would come from a CDN).
nb_mime_priority_overrides = [("html", "application/vnd.jupyter.widget-view+json", None)]
nb_ipywidgets_js = {}

html_theme = "sphinx_book_theme"
html_title = "e2v notebooks" + (" (quick build)" if QUICK else "")
html_theme_options = {
    "show_toc_level": 2,
    "use_download_button": True,
    "home_page_in_toc": True,
    "navigation_with_keys": False,
}
html_context = {"default_mode": "light"}  # no console error about an unset mode
html_static_path = []
html_favicon = "favicon.svg"
mathjax_path = "mathjax/tex-chtml.js"  # served from the site itself: no CDN at read time
html_extra_path = ["extra"]
html_last_updated_fmt = None
html_show_sourcelink = False


def fold_solutions(app, docname: str, source: list[str]) -> None:
    """Fold every exercise solution (cells tagged ``solution``) behind "Show code cell
    content": a student opens it on purpose. The notebooks themselves stay as they are."""
    import json

    if not docname.startswith("notebooks/"):
        return
    nb = json.loads(source[0])
    for cell in nb["cells"]:
        tags = cell.setdefault("metadata", {}).setdefault("tags", [])
        if "solution" in tags and "hide-cell" not in tags:
            tags.append("hide-cell")
    source[0] = json.dumps(nb)


def copy_mathjax(app, error) -> None:
    """Copy MathJax (from the pinned ``sphinx-mathjax-offline`` wheel) into ``_static/mathjax``:
    the TeX-to-HTML component with what it loads on demand (TeX extensions, the CHTML fonts,
    the menu and the accessibility tools), not the other combined builds."""
    import importlib.util

    if error is not None:
        return
    spec = importlib.util.find_spec("sphinx-mathjax-offline")
    if spec is None or spec.origin is None:
        raise RuntimeError("MathJax is missing: pip install -r environment/book-requirements.txt")
    source = Path(spec.origin).parent / "static" / "mathjax"
    target = Path(app.outdir) / "_static" / "mathjax"
    target.mkdir(parents=True, exist_ok=True)
    shutil.copy2(source / "tex-chtml.js", target / "tex-chtml.js")
    for part in ("input", "output/chtml", "a11y", "sre", "ui", "adaptors"):
        shutil.copytree(source / part, target / part, dirs_exist_ok=True)


def setup(app):
    app.connect("source-read", fold_solutions)
    app.connect("build-finished", copy_mathjax)
    return {"parallel_read_safe": True}
