"""Joins the candidates, the review, the duplicates and the reviewed Sweet Home 3D rows into
the committed catalogue (:data:`~e2vlib.experiments.real_objects.catalogue.CATALOGUE_CSV`).

The review, ``<cache>/review.csv`` (:data:`REVIEW_FIELDS`), is what a person wrote after
looking at the contact sheets (:func:`review_from_notes`); every candidate needs a row there.
Without it the committed catalogue is read back as the review (:func:`review_from_catalogue`),
so the grids and the catalogue rebuild from the packages and the committed table. Kept models
whose surface grids match an earlier kept model of their category (IoU above
:data:`~e2vlib.experiments.real_objects.look.DEDUP_IOU`) are dropped as duplicates; the
split is assigned by :func:`~e2vlib.experiments.real_objects.catalogue.assign_splits`.
"""

from __future__ import annotations

import csv
import io
import json
import os
import re
import time
from collections import Counter
from pathlib import Path

import numpy as np

from e2vlib.experiments.real_meshes.mapping import read_mapping
from e2vlib.experiments.real_objects.catalogue import CATALOGUE_CSV, assign_splits, write_rows
from e2vlib.experiments.real_objects.readers import GROUND_SQUARE, LIGHT_CONE
from e2vlib.experiments.real_objects.sources import PACKAGES, Candidate, find_candidates

DEFAULT_ROTATION = {
    "flightgear-data-base": "z90", "flightgear-data-ai": "z90",
    "flightgear-data-models": "z90", "torcs-data": "z90", "ufoai-data": "z-90",
    "openarena-data": "z-90", "gl-117-data": "none", "minetest-mod-homedecor": "none",
    "sweethome3d": "none",
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


REVIEW_FIELDS = ("key", "category", "rotation", "parts", "keep", "note")
"""Columns of ``<cache>/review.csv``."""


def review_from_notes(cache: Path) -> int:
    """Write ``<cache>/review.csv`` from the notes typed while looking at the sheets,
    ``<cache>/review/*.txt``: one line per cell, ``sheet.cell|y or n|category|rotation|what
    looking showed|parts`` (an empty category or rotation keeps the candidate's and its
    source's default; parts: :data:`~e2vlib.experiments.real_objects.readers.PART_KINDS`),
    matched to candidates through the sheets' ``index.json``. Returns the rows written."""
    index = json.loads((cache / "sheets" / "index.json").read_text())
    by_cell = {f"{i['sheet']}.{i['cell']}": i for i in index}
    sources = {candidate_key(c): c.source for c in find_candidates(cache)}
    rows = {}
    for file in sorted((cache / "review").glob("*.txt")):
        for n, line in enumerate(file.read_text().splitlines(), start=1):
            if not line.strip():
                continue
            fields = line.split("|")
            if len(fields) not in (5, 6) or fields[0] not in by_cell or fields[1] not in "yn":
                raise ValueError(f"{file} line {n}: expected 'sheet.cell|y|category|rotation|"
                                 f"note[|parts]' for a cell on the sheets, got {line[:80]!r}")
            cell = by_cell[fields[0]]
            key = cell["key"]
            rows[key] = {"key": key, "category": fields[2] or cell["category"],
                         "rotation": fields[3] or DEFAULT_ROTATION[sources[key]],
                         "parts": fields[5] if len(fields) == 6 else "",
                         "keep": "yes" if fields[1] == "y" else "no",
                         "note": "looked: " + fields[4].strip()}
    old = read_review(cache)
    for key, row in old.items():  # rows reviewed on earlier sheets keep their review
        rows.setdefault(key, row)
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, REVIEW_FIELDS, lineterminator="\n")
    writer.writeheader()
    writer.writerows(sorted(rows.values(), key=lambda r: r["key"]))
    _write_atomic(cache / "review.csv", buffer.getvalue().encode())
    return len(rows)


def read_review(cache: Path) -> dict[str, dict]:
    """The review rows written after looking (``<cache>/review.csv``), by candidate key."""
    path = cache / "review.csv"
    if not path.is_file():
        return {}
    with open(path, newline="") as f:
        return {row["key"]: row for row in csv.DictReader(f)}


def _write_atomic(path: Path, data: bytes) -> None:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_bytes(data)
    os.replace(tmp, path)


def build_grids(cache: Path, only: str | None = None) -> None:
    """Load every candidate (or those whose key matches ``only``) in our frame and store its
    surface grid, rotation and removed parts in ``<cache>/grids/<key>.npz``; a model that
    cannot be read is stored with its error (the sheets show it grey)."""
    from e2vlib.experiments.real_objects.look import surface_grid
    from e2vlib.experiments.real_objects.readers import load_model

    review = read_review(cache) or review_from_catalogue(cache)
    out = cache / "grids"
    out.mkdir(parents=True, exist_ok=True)
    cands = find_candidates(cache)
    start = time.monotonic()
    for i, c in enumerate(cands):
        key = candidate_key(c)
        if only and not re.search(only, key):
            continue
        rotation = review.get(key, {}).get("rotation", DEFAULT_ROTATION[c.source])
        parts = review.get(key, {}).get("parts", "")
        file = out / f"{key}.npz"
        if file.is_file():
            old = np.load(file)
            if str(old["rotation"]) == rotation and str(old.get("parts", "")) == parts:
                continue
        removed: list[str] = []
        try:
            mesh = load_model(cache / "pkgs" / c.source, c.path, rotation, removed, parts)
            occ = surface_grid(mesh)
            info = {"faces": len(mesh.faces), "parts": int(mesh.body_count)
                    if len(mesh.faces) < 200_000 else -1, "error": ""}
        except Exception as err:  # recorded: the review sees the failure on the sheet
            occ, info = np.zeros((1, 1, 1), bool), {"error": f"{type(err).__name__}: {err}"}
        tmp = out / f"{key}.tmp.npz"
        np.savez_compressed(tmp, occ=np.packbits(occ), shape=occ.shape, rotation=rotation,
                            parts=parts,
                            removed=json.dumps(sorted(set(removed))), info=json.dumps(info))
        os.replace(tmp, file)
        print(f"{i + 1}/{len(cands)} {key} {info.get('error', '')[:80]} "
              f"{time.monotonic() - start:.0f}s", flush=True)


def load_grid(cache: Path, key: str) -> tuple[np.ndarray | None, dict]:
    """The stored grid of candidate ``key`` (None when it failed) and its facts."""
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


def build_sheets(cache: Path, per_sheet: int = 30, only: str | None = None) -> None:
    """Draw contact sheets of the candidates no one has looked at yet (absent from
    ``<cache>/review.csv``; with ``only``, those whose key matches), as
    ``<cache>/sheets/sheet_NNN.png`` numbered on from the sheets already drawn, cells
    labelled ``sheet.cell key``, and add them to the sheets' ``index.json``."""
    from e2vlib.experiments.real_objects.look import contact_sheet

    out = cache / "sheets"
    out.mkdir(parents=True, exist_ok=True)
    index_file = out / "index.json"
    index = json.loads(index_file.read_text()) if index_file.is_file() else []
    drawn, reviewed = {i["key"] for i in index}, read_review(cache)
    first = 1 + max((i["sheet"] for i in index), default=-1)
    cands = [c for c in find_candidates(cache) if (not only or re.search(only, candidate_key(c)))
             and candidate_key(c) not in reviewed and candidate_key(c) not in drawn]
    cands.sort(key=lambda c: (c.category, c.source, c.path))
    for s in range(0, len(cands), per_sheet):
        cells, n = [], first + s // per_sheet
        for j, c in enumerate(cands[s:s + per_sheet]):
            key = candidate_key(c)
            occ, info = load_grid(cache, key)
            cells.append((f"{n}.{j} {key.split('__', 1)[1][-30:]}", occ))
            index.append({"sheet": n, "cell": j, "key": key, "category": c.category,
                          "error": info.get("error", ""), "removed": info.get("removed", [])})
        contact_sheet(cells).save(out / f"sheet_{n:03d}.png")
    _write_atomic(index_file, json.dumps(index, indent=0).encode())
    print(f"{len(cands)} models not yet looked at on {-(-len(cands) // per_sheet)} new sheets "
          f"in {out}")


def removed_summary(names: list[str]) -> str:
    """The parts a reader left out, summarized by kind (``shadow x2; lod x1``).

    Examples
    --------
    >>> removed_summary(["shadow", "Shadow.001", "LOD 1000/5000", "light-cone"])
    'light cone x1; lod copy x1; shadow x2'
    """
    kinds = Counter()
    for name in names:
        low = name.lower()
        kind = (name if name.endswith("(by shape)")
                else "shadow" if "shadow" in low else "lod copy" if "lod" in low
                else "light cone" if "cone" in low or "beam" in low
                else "halo/glow" if re.search("halo|glow|flare", low)
                else "ground" if "ground" in low else "other")
        kinds[kind] += 1
    return "; ".join(f"{k} x{n}" for k, n in sorted(kinds.items()))


def _short(path: str) -> str:
    tail = path.split("::")[-1]
    parts = [re.sub(r"[^a-z0-9]+", "_", p.lower()).strip("_") for p in tail.split("/")]
    parts[-1] = re.sub(r"_(ac|acc|obj|md2|md3|3ds)$", "", parts[-1])
    return "_".join(parts[-2:]) if len(parts) > 1 else parts[-1]


def review_from_catalogue(cache: Path, path: str | Path = CATALOGUE_CSV) -> dict[str, dict]:
    """The review rows read back from a written catalogue (category, rotation, keep, note;
    the parts removed by shape from its ``removed`` column), by candidate key: the
    committed catalogue is the review when ``<cache>/review.csv`` is absent."""
    from e2vlib.experiments.real_objects.catalogue import read_catalogue

    keys = {(c.source, c.path): candidate_key(c) for c in find_candidates(cache)}
    out = {}
    for row in read_catalogue(path, kept_only=False):
        key = keys.get((row.source, row.path))
        if key is None:
            continue
        parts = " ".join(kind for kind, name in (("ground", GROUND_SQUARE), ("cones", LIGHT_CONE))
                         if name in row.removed)
        note = re.sub(r"; duplicate of \S+ by geometry \(IoU [0-9.]+\)$", "", row.note)
        note = re.sub(r" \(unreadable: .*\)$", "", note)
        keep = row.keep or "; duplicate of " in row.note
        out[key] = {"key": key, "category": row.category, "rotation": row.rotation,
                    "parts": parts, "keep": "yes" if keep else "no", "note": note}
    return out


def write_catalogue(cache: str | Path, out: str | Path = CATALOGUE_CSV,
                    reviewed: str | Path = CATALOGUE_CSV) -> dict[str, int]:
    """Write the catalogue ``out`` from the candidates under ``cache`` and their review
    (``<cache>/review.csv``, else the catalogue ``reviewed`` read back); returns the kept
    objects per category. Raises KeyError naming candidates no one has looked at."""
    from e2vlib.experiments.real_objects.look import duplicates, pool

    cache = Path(cache)
    review = read_review(cache) or review_from_catalogue(cache, reviewed)
    cands = find_candidates(cache)
    missing = [candidate_key(c) for c in cands if candidate_key(c) not in review]
    if missing:
        raise KeyError(f"{len(missing)} candidates have no review row in {cache}/review.csv "
                       f"({', '.join(missing[:5])}...): look at their sheets first")
    rows, grids, cats, used = [], {}, {}, set()
    for c in cands:
        key = candidate_key(c)
        r = review[key]
        occ, info = load_grid(cache, key)
        category = r["category"]
        rid = f"{category}_{PACKAGES[c.source][0]}_{_short(c.path)}"
        base, k = rid, 2
        while rid in used:
            rid, k = f"{base}_{k}", k + 1
        used.add(rid)
        keep = r["keep"] == "yes" and occ is not None
        note = r["note"] if occ is not None else f"{r['note']} (unreadable: {info['error']})"
        rows.append({"id": rid, "source": c.source, "path": c.path, "licence": c.licence,
                     "category": category, "rotation": r["rotation"],
                     "removed": removed_summary(info.get("removed", [])),
                     "keep": "yes" if keep else "no", "split": "", "note": note})
        if keep:
            grids[rid], cats[rid] = pool(occ), category
    dups = duplicates(grids, cats)
    for row in rows:
        if row["id"] in dups:
            other, score = dups[row["id"]]
            row["keep"] = "no"
            row["note"] += f"; duplicate of {other} by geometry (IoU {score})"
    for m in read_mapping():
        source = "crrcsim-data" if m.library == "crrcsim-data" else "sweethome3d-furniture"
        path = m.entry_id if source == "crrcsim-data" else f"{m.library}::{m.entry_id}"
        rows.append({"id": m.id, "source": source, "path": path, "licence": m.licence,
                     "category": m.category, "rotation": m.pose, "removed": "",
                     "keep": "yes", "split": "", "note": m.note})
    by_cat: dict[str, list[str]] = {}
    for row in rows:
        if row["keep"] == "yes":
            by_cat.setdefault(row["category"], []).append(row["id"])
    splits = assign_splits(by_cat)
    for row in rows:
        row["split"] = splits.get(row["id"], "")
    rows.sort(key=lambda r: (r["category"], r["id"]))
    write_rows(out, rows)
    counts = {cat: len(ids) for cat, ids in sorted(by_cat.items())}
    print(f"{sum(counts.values())} kept of {len(rows)} rows: {counts}")
    return counts
