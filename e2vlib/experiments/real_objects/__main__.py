"""The recorded commands that build the real-object catalogue (issue #38, stage 1).

    python -m e2vlib.experiments.real_objects download --cache cache/real_objects
    python -m e2vlib.experiments.real_objects extract  --cache cache/real_objects
    python -m e2vlib.experiments.real_objects grids    --cache cache/real_objects
    python -m e2vlib.experiments.real_objects sheets   --cache cache/real_objects
    python -m e2vlib.experiments.real_objects catalogue --cache cache/real_objects

``download`` and ``extract`` fetch and unpack the Debian packages
(:mod:`~e2vlib.experiments.real_objects.sources`); ``grids`` loads every candidate in our
frame (its reviewed rotation, else its source's default) and stores its surface grid and
the parts left out under ``<cache>/grids``; ``sheets`` draws the contact sheets to look at
(``<cache>/sheets``); ``catalogue`` joins the candidates, the review
(``<cache>/review.csv``: key, category, rotation, keep, note, written by the person who
looked), the duplicates and the reviewed Sweet Home 3D rows into
``experiments/real_objects/catalogue.csv`` with its split.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import re
import sys
import time
from pathlib import Path

import numpy as np

from e2vlib.experiments.real_objects.sources import (
    PACKAGES,
    Candidate,
    download,
    extract,
    find_candidates,
)

DEFAULT_ROTATION = {
    "flightgear-data-base": "z90", "flightgear-data-ai": "z90",
    "flightgear-data-models": "z90", "torcs-data": "z90", "ufoai-data": "z-90",
    "openarena-data": "z-90", "gl-117-data": "", "minetest-mod-homedecor": "",
    "sweethome3d": "",
}
"""The turn (after the format's own, :data:`~e2vlib.experiments.real_objects.readers.FORMAT_TURNS`)
that puts most models of each source upright and facing -y; the review overrides it per
model."""


def candidate_key(c: Candidate) -> str:
    """A plain file-name key of a candidate: package code and path, lower case."""
    tail = c.path.split("::")[-1]
    tail = re.sub(r"^(usr/share/games/flightgear/|usr/share/games/[^/]+/)", "", tail)
    slug = re.sub(r"[^a-z0-9]+", "_", tail.lower().rsplit(".", 1)[0]).strip("_")
    return f"{PACKAGES[c.source][0]}__{slug}"


def read_review(cache: Path) -> dict[str, dict]:
    path = cache / "review.csv"
    if not path.is_file():
        return {}
    with open(path, newline="") as f:
        return {row["key"]: row for row in csv.DictReader(f)}


def _write_atomic(path: Path, data: bytes) -> None:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_bytes(data)
    os.replace(tmp, path)


def cmd_grids(cache: Path, only: str | None = None) -> None:
    from e2vlib.experiments.real_objects.look import surface_grid
    from e2vlib.experiments.real_objects.readers import load_model

    review = read_review(cache)
    out = cache / "grids"
    out.mkdir(parents=True, exist_ok=True)
    cands = find_candidates(cache)
    start = time.monotonic()
    for i, c in enumerate(cands):
        key = candidate_key(c)
        if only and not re.search(only, key):
            continue
        rotation = review.get(key, {}).get("rotation", DEFAULT_ROTATION[c.source])
        file = out / f"{key}.npz"
        if file.is_file():
            old = np.load(file)
            if str(old["rotation"]) == rotation:
                continue
        removed: list[str] = []
        try:
            mesh = load_model(cache / "pkgs" / c.source, c.path, rotation, removed)
            occ = surface_grid(mesh)
            info = {"faces": len(mesh.faces), "parts": int(mesh.body_count)
                    if len(mesh.faces) < 200_000 else -1, "error": ""}
        except Exception as err:  # recorded: the review sees the failure on the sheet
            occ, info = np.zeros((1, 1, 1), bool), {"error": f"{type(err).__name__}: {err}"}
        tmp = out / f"{key}.tmp.npz"
        np.savez_compressed(tmp, occ=np.packbits(occ), shape=occ.shape, rotation=rotation,
                            removed=json.dumps(sorted(set(removed))), info=json.dumps(info))
        os.replace(tmp, file)
        print(f"{i + 1}/{len(cands)} {key} {info.get('error', '')[:80]} "
              f"{time.monotonic() - start:.0f}s", flush=True)


def load_grid(cache: Path, key: str) -> tuple[np.ndarray | None, dict]:
    file = cache / "grids" / f"{key}.npz"
    if not file.is_file():
        return None, {"error": "no grid"}
    z = np.load(file)
    info = json.loads(str(z["info"]))
    info["removed"] = json.loads(str(z["removed"]))
    info["rotation"] = str(z["rotation"])
    if info.get("error"):
        return None, info
    shape = tuple(z["shape"])
    occ = np.unpackbits(z["occ"])[:int(np.prod(shape))].reshape(shape).astype(bool)
    return occ, info


def cmd_sheets(cache: Path, per_sheet: int = 30, only: str | None = None) -> None:
    from e2vlib.experiments.real_objects.look import contact_sheet

    out = cache / "sheets"
    out.mkdir(parents=True, exist_ok=True)
    cands = [c for c in find_candidates(cache) if not only or re.search(only, candidate_key(c))]
    cands.sort(key=lambda c: (c.category, c.source, c.path))
    index = []
    for s in range(0, len(cands), per_sheet):
        cells = []
        for j, c in enumerate(cands[s:s + per_sheet]):
            key = candidate_key(c)
            occ, info = load_grid(cache, key)
            n = s // per_sheet
            cells.append((f"{n}.{j} {key.split('__', 1)[1][-30:]}", occ))
            index.append({"sheet": n, "cell": j, "key": key, "category": c.category,
                          "error": info.get("error", ""), "removed": info.get("removed", [])})
        name = f"sheet_{s // per_sheet:03d}.png"
        contact_sheet(cells).save(out / name)
    _write_atomic(out / "index.json", json.dumps(index, indent=0).encode())
    print(f"{len(index)} models on {-(-len(index) // per_sheet)} sheets in {out}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m e2vlib.experiments.real_objects",
                                     description=__doc__.split("\n")[0])
    parser.add_argument("step", choices=["download", "extract", "candidates", "grids",
                                         "sheets", "catalogue"])
    parser.add_argument("--cache", type=Path, default=Path("cache/real_objects"))
    parser.add_argument("--only", default=None, help="regex on candidate keys")
    args = parser.parse_args(argv)
    start = time.monotonic()
    if args.step == "download":
        print(download(args.cache))
    elif args.step == "extract":
        print(extract(args.cache))
    elif args.step == "candidates":
        for c in find_candidates(args.cache):
            print(candidate_key(c), c.category, c.source, c.path, c.licence, sep=",")
    elif args.step == "grids":
        cmd_grids(args.cache, args.only)
    elif args.step == "sheets":
        cmd_sheets(args.cache, only=args.only)
    elif args.step == "catalogue":
        from e2vlib.experiments.real_objects.build import write_catalogue
        write_catalogue(args.cache)
    print(f"{args.step}: {time.monotonic() - start:.0f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
