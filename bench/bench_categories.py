"""How varied each category's labels are, and how much a per-category mean shape explains.

For every category, ``--n`` objects (seeds ``0 .. n-1``) are built with ``make_shape`` and
voxelized (32^3, solid). Two numbers per category:

* **pairwise IoU**: the mean IoU between the voxel grids of every pair of different seeds
  (threshold 0.5 on both). Low: the labels differ from one another.
* **oracle IoU@0.3**: the category's occupancy frequency over the first ``--train`` seeds
  (the per-category mean voxel grid), thresholded at 0.3 and scored against each held-out
  seed. This is the score a model reaches by recognising the category only; the gap between
  it and a model's IoU is what reading the object's own shape adds.

``--before REV`` also measures the shapes package as it was at git revision ``REV`` (read
with ``git show``, imported as a separate package), for a before/after table; meshes of
categories whose builders did not change are checked to be identical.

``--gallery PNG`` draws one row of six objects per changed category (every sub-type, then
repeats) with pyvista off screen: docs/figures/category_gallery.png.

Run: ``python bench/bench_categories.py --before REV --gallery docs/figures/category_gallery.png``;
writes the "Category variety (issue 12)" section of bench/RESULTS.md.
"""

from __future__ import annotations

import argparse
import importlib
import itertools
import re
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import machine, write_section  # noqa: E402

from e2vlib import paper  # noqa: E402
from e2vlib.metrics import iou  # noqa: E402
from e2vlib.shapes import CATEGORIES, SUB_TYPES, make_shape, shape_kind  # noqa: E402
from e2vlib.voxels import voxelize  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
TITLE = "Category variety (issue 12)"
CHANGED = ("cabinet", "display", "speaker", "telephone")
VIEWS = {"cabinet": (0.9, -2.7, 1.4)}  # gallery cameras: cabinets from the front (open doors)
VIEW = (2.4, -1.7, 1.3)  # the others from the front-right, more from the side than viz.OBJECT_VIEW


def load_shapes_at(rev: str, where: Path) -> Callable[[str, int], object]:
    """``make_shape`` of ``e2vlib/shapes`` at git revision ``rev``, imported as package
    ``shapes_at_<rev>`` from a copy under ``where`` (git state is only read)."""
    names = subprocess.run(
        ["git", "ls-tree", "--name-only", f"{rev}:e2vlib/shapes"],
        cwd=ROOT,
        check=True,
        capture_output=True,
        text=True,
    ).stdout.split()
    package = "shapes_at_" + re.sub(r"\W", "_", rev)
    folder = where / package
    folder.mkdir(parents=True)
    for name in names:
        if name.endswith(".py"):
            text = subprocess.run(
                ["git", "show", f"{rev}:e2vlib/shapes/{name}"],
                cwd=ROOT,
                check=True,
                capture_output=True,
                text=True,
            ).stdout
            (folder / name).write_text(text.replace("e2vlib.shapes", package))
    sys.path.insert(0, str(where))
    return importlib.import_module(f"{package}.builders").make_shape


def category_grids(build: Callable[[str, int], object], category: str, n: int) -> np.ndarray:
    """Voxel labels ``(n, 32, 32, 32)`` bool of seeds ``0 .. n-1``."""
    return np.stack([voxelize(build(category, seed)) for seed in range(n)])


def pairwise_iou(grids: np.ndarray) -> float:
    """Mean IoU over all pairs of different grids (threshold 0.5)."""
    pairs = list(itertools.combinations(range(len(grids)), 2))
    return float(np.mean([iou(grids[a].astype(np.float32), grids[b], 0.5) for a, b in pairs]))


def oracle_iou(grids: np.ndarray, held_out: np.ndarray) -> float:
    """IoU at the default threshold (0.3) of the occupancy frequency of the grids not
    ``held_out`` (a bool mask), averaged over the held-out ones: the per-category
    mean-shape oracle."""
    mean = grids[~held_out].mean(axis=0)
    held = grids[held_out]
    return float(np.mean(iou(np.broadcast_to(mean, held.shape), held, paper.IOU_THRESHOLD)))


def oracle_folds(grids: np.ndarray, n_train: int) -> tuple[float, float]:
    """The oracle with the last ``n - n_train`` seeds held out, and its mean over all
    folds of that size (each seed held out once; ``n`` a multiple of the fold size)."""
    n, k = len(grids), len(grids) - n_train
    masks = [np.isin(np.arange(n), np.arange(f * k, (f + 1) * k)) for f in range(n // k)]
    return oracle_iou(grids, masks[-1]), float(np.mean([oracle_iou(grids, m) for m in masks]))


def same_meshes(a: Callable, b: Callable, category: str, seeds: range) -> bool:
    """Whether two ``make_shape`` give bit-identical vertices and faces for ``seeds``."""
    for seed in seeds:
        ma, mb = a(category, seed), b(category, seed)
        if not (np.array_equal(ma.vertices, mb.vertices) and np.array_equal(ma.faces, mb.faces)):
            return False
    return True


def measure(build: Callable, n: int, n_train: int) -> dict[str, tuple[float, float, float]]:
    """Per category ``(pairwise IoU, oracle IoU, oracle IoU over all folds)``."""
    out = {}
    for category in CATEGORIES:
        grids = category_grids(build, category, n)
        out[category] = (pairwise_iou(grids), *oracle_folds(grids, n_train))
        print(
            f"  {category:<11} pairwise {out[category][0]:.3f}  oracle {out[category][1]:.3f}"
            f"  oracle, all folds {out[category][2]:.3f}",
            flush=True,
        )
    return out


def table(after: dict, before: dict | None = None) -> str:
    """Markdown table of :func:`measure` results, before beside after where given."""
    names = ["pairwise IoU", "oracle IoU@0.3", "oracle IoU@0.3, all folds"]
    cols = ["category", "sub-types"]
    for name in names:
        cols += [f"before {name}", f"after {name}"] if before else [name]
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    rows = [
        (c, f"**{c}**" if c in SUB_TYPES else c, str(len(SUB_TYPES.get(c, ())) or "-"))
        for c in CATEGORIES
    ]
    for category, name, kinds in rows + [(None, "mean of 13", "")]:
        cells = [name, kinds]
        for k in range(len(names)):
            for d in [before, after] if before else [after]:
                value = d[category][k] if category else np.mean([d[c][k] for c in CATEGORIES])
                cells.append(f"{value:.3f}")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def gallery_seeds(category: str, n: int = 6) -> list[tuple[int, str]]:
    """``n`` ``(seed, sub-type)`` of ``category``: the first seed of every sub-type (in
    :data:`SUB_TYPES` order), then the next unused seeds of each sub-type in turn."""
    by_kind: dict[str, list[int]] = {k: [] for k in SUB_TYPES[category]}
    seed = 0
    while min(len(v) for v in by_kind.values()) < n:
        by_kind[shape_kind(category, seed)].append(seed)
        seed += 1
    picked: list[tuple[int, str]] = []
    for rank in range(n):
        for kind, seeds in by_kind.items():
            if len(picked) < n:
                picked.append((seeds[rank], kind))
    return picked


def draw_gallery(path: Path, categories=CHANGED, n: int = 6, cell=(260, 230)) -> None:
    """One row per category of ``n`` objects (:func:`gallery_seeds`), rendered off screen,
    each labelled with its sub-type and seed; written as a PNG (temporary file, renamed)."""
    import pyvista as pv
    from PIL import Image

    from e2vlib import _headless, viz
    from e2vlib.files import atomic_path

    if hasattr(viz, "headless_opengl_window"):
        _headless.headless_opengl_window()
    rows = len(categories)
    plotter = pv.Plotter(
        off_screen=True,
        shape=(rows, n),
        border=False,
        window_size=(cell[0] * n, cell[1] * rows),
        lighting="three lights",
    )
    plotter.set_background("white")
    for r, category in enumerate(categories):
        for c, (seed, kind) in enumerate(gallery_seeds(category, n)):
            plotter.subplot(r, c)
            mesh = make_shape(category, seed)
            plotter.add_mesh(pv.wrap(mesh), color=viz.MESH_COLOR, smooth_shading=False)
            plotter.add_text(
                f"{category}: {kind} (seed {seed})",
                position=(6, cell[1] - 18),
                font_size=7,
                color="black",
            )
            plotter.camera_position = [VIEWS.get(category, VIEW), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0)]
            plotter.reset_camera(bounds=(-0.5, 0.5, -0.5, 0.5, -0.5, 0.5))
            plotter.camera.zoom(1.25)
    image = plotter.screenshot(return_img=True)
    plotter.close()
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        Image.fromarray(image[..., :3]).quantize(64).save(tmp, format="PNG", optimize=True)


def main(argv: list[str] | None = None) -> str:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=40, help="objects per category (seeds 0..n-1)")
    parser.add_argument("--train", type=int, default=32, help="seeds the oracle averages")
    parser.add_argument("--before", default=None, help="git revision to compare against")
    parser.add_argument("--no-write", action="store_true", help="print only, keep RESULTS.md")
    parser.add_argument("--gallery", type=Path, default=None, help="also draw this PNG")
    parser.add_argument("--gallery-only", action="store_true", help="draw the PNG, measure nothing")
    args = parser.parse_args(argv)
    held = args.n - args.train
    if not (2 <= args.train < args.n and args.n % held == 0):
        parser.error(
            f"need 2 <= --train < --n and --n a multiple of --n minus --train; "
            f"got --train {args.train} --n {args.n}"
        )
    if args.gallery:
        draw_gallery(args.gallery)
        print(f"wrote {args.gallery} ({args.gallery.stat().st_size / 1024:.0f} KiB)")
        if args.gallery_only:
            return ""
    start = time.perf_counter()
    print("after (working tree):", flush=True)
    after = measure(make_shape, args.n, args.train)
    before, unchanged, rev = None, [], None
    if args.before:
        rev = subprocess.run(
            ["git", "rev-parse", "--short", args.before],
            cwd=ROOT,
            check=True,
            capture_output=True,
            text=True,
        ).stdout.strip()
        with tempfile.TemporaryDirectory() as tmp:
            old = load_shapes_at(rev, Path(tmp))
            print(f"before ({rev}):", flush=True)
            before = measure(old, args.n, args.train)
            unchanged = [c for c in CATEGORIES if same_meshes(old, make_shape, c, range(5))]
    seconds = time.perf_counter() - start

    text = table(after, before)
    print(text)
    options = (f" --before {rev}" if rev else "") + (
        f" --gallery {args.gallery}" if args.gallery else ""
    )
    body = (
        f"Machine: {machine()}.\n"
        f"Command: `.venv/bin/python bench/bench_categories.py{options}` ({args.n} objects "
        f"per category, seeds 0..{args.n - 1}, `make_shape` + `e2vlib.voxels.voxelize`, 32^3 "
        f"solid labels; {seconds:.0f} s{'; before: the shapes package at ' + rev if rev else ''}"
        ").\n\n"
        "Pairwise IoU: mean IoU between the labels of every two different seeds (threshold "
        f"0.5). Oracle: the category's occupancy frequency over seeds 0..{args.train - 1} "
        f"scored at IoU@{paper.IOU_THRESHOLD:g} against seeds {args.train}..{args.n - 1}, "
        "what knowing the category alone scores; *all folds*: the same with each block of "
        f"{held} seeds held out in turn ({args.n // held} folds, mean), less noisy than one "
        f"split of {held}. Lower numbers mean a model must read more of the object's own shape. "
        "Bold: the categories built from named sub-types (`e2vlib.shapes.SUB_TYPES`, "
        "issue 12).\n\n" + text + "\n"
    )
    if before:
        body += (
            "\nIdentical meshes before and after (seeds 0..4, vertices and faces "
            f"bit-identical): {', '.join(unchanged) or 'none'}.\n"
        )
    if not args.no_write:
        write_section(TITLE, body)
    return body


if __name__ == "__main__":
    main()
