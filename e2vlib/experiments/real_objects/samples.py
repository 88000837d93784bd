"""The real objects as samples a model trains on.

:func:`build_samples` (:data:`SAMPLES_COMMAND`) turns every kept row of the committed
catalogue (:func:`~e2vlib.experiments.real_objects.catalogue.read_catalogue`) into one sample
of a dataset folder that :class:`e2vlib.data.E2VDataset` reads, in the row's split: the
model in our frame (:func:`load_row_mesh`: the stage-1 readers with the row's rotation and
parts removed; the reviewed Sweet Home 3D / crrcsim rows through
:mod:`e2vlib.experiments.real_meshes`), its frames by data_small's protocol
(:func:`e2vlib.data.mesh_to_sample` with :func:`sample_config`: ``--preset small``'s
128 px renders pooled to 64 px, 100 frames of 5 ms, so models trained on data_small read
it) and its label by :func:`~e2vlib.experiments.real_objects.labels.solid_labels` (solid
32^3 grids that tolerate open, many-part meshes) in place of
:func:`e2vlib.voxels.voxelize`'s, whose agreement is recorded.

Layout under ``--out`` (all under ``cache/``: the samples derive from GPL and CC-BY-SA
models and are never committed)::

    config.json          the build settings, the catalogue's sha256, the packages used
    manifest.csv         id, category, split (the catalogue's), seed, n_events, sha256
    samples/<id>.npz     frames and solid labels (e2vlib.data.save_sample)
    records/<id>.json    what the sample was made from and what the labels found
    objects.csv          the records in one table (fill, voxels, IoU with voxelize, ...)

Resumable: a sample whose record says it was made from the row as it stands is kept;
models that cannot be read are recorded (``error``) and left out of the manifest. The
Sweet Home 3D rows need Debian's ``sweethome3d-furniture`` and ``crrcsim-data``
(:data:`EXTRA_PACKAGES`), downloaded and unpacked under the cache like the others
(``download`` and ``extract`` fetch them too), or installed; without them those rows are
skipped with a message naming the step.
"""

from __future__ import annotations

import csv
import hashlib
import json
import os
import shutil
import signal
import time
from collections import Counter
from pathlib import Path

from e2vlib import paper
from e2vlib.experiments.real_objects.catalogue import CATALOGUE_CSV, RealObject, read_catalogue
from e2vlib.experiments.real_objects.readers import (
    ASSIMP,
    ASSIMP_HINT,
    ASSIMP_SUFFIXES,
    GROUND_SQUARE,
    LIGHT_CONE,
    RealMeshError,
)
from e2vlib.metrics import iou

DATA_DIR = "cache/real_objects/data"
"""Where the samples are built: the real objects as a dataset folder (never committed)."""
SAMPLES_COMMAND = ("python -m e2vlib.experiments.real_objects samples --cache cache/real_objects "
                   f"--out {DATA_DIR}")
"""The recorded command that builds the samples (after ``download`` and ``extract``)."""
EXTRA_PACKAGES = ("sweethome3d-furniture", "crrcsim-data")
"""Debian packages of the reviewed Sweet Home 3D / crrcsim rows
(:mod:`e2vlib.experiments.real_meshes`)."""
SH3D_SOURCES = ("sweethome3d-furniture", "crrcsim-data")
"""Catalogue sources read through :mod:`e2vlib.experiments.real_meshes`."""
FURNITURE_SUBDIR = "usr/share/sweethome3d/furniture"
CRRCSIM_SUBDIR = "usr/share/games/crrcsim/objects"
SMALL_PRESET = {"per_category": 64, "resolution": 128, "frame_size": 64, "seed": 0}
"""``make-data --preset small`` (data_small's settings; ``per_category`` is unused here)."""
RECORD_FIELDS = ("id", "category", "split", "source", "licence", "fill", "surface",
                 "voxels", "voxelize_iou", "faces", "seconds", "error", "made_from")
"""Columns of ``objects.csv``."""
MANIFEST_EVERY = 20
"""Samples built between manifest rewrites (a stopped build keeps a readable folder)."""


def sample_config(**overrides):
    """The :class:`e2vlib.data.BuildConfig` of the samples: data_small's (``--preset
    small``) over the 13 categories, with ``overrides`` (tests use tiny renders).

    Examples
    --------
    >>> c = sample_config()
    >>> c.resolution, c.frame_size, c.n_frames, c.dt_us, c.oversample
    (128, 64, 100, 5000, 3)
    """
    from e2vlib.data import BuildConfig

    return BuildConfig(categories=paper.CATEGORIES, **{**SMALL_PRESET, **overrides})


def row_parts(row: RealObject) -> str:
    """The parts to remove by shape (:data:`~e2vlib.experiments.real_objects.readers.PART_KINDS`)
    that the row's ``removed`` column records.

    Examples
    --------
    >>> from dataclasses import replace
    >>> row = RealObject("lamp_fg_x", "flightgear-data-base", "x.ac", "GPL-2.0-or-later",
    ...                  "lamp", "z90", "light cone (by shape) x1; shadow x1", True, "train",
    ...                  "looked: a lamp")
    >>> row_parts(row), row_parts(replace(row, removed=""))
    ('cones', '')
    """
    return " ".join(kind for kind, name in (("ground", GROUND_SQUARE), ("cones", LIGHT_CONE))
                    if name in row.removed)


def made_from(row: RealObject) -> str:
    """What the sample of ``row`` is made from: source, path, rotation and parts (a resumed
    build makes a sample again when this changes)."""
    return f"{row.source} {row.path} | {row.rotation} | {row_parts(row)}"


def sh3d_folders(cache: str | os.PathLike) -> tuple[Path, Path]:
    """The Sweet Home 3D furniture and crrcsim folders: unpacked under ``<cache>/pkgs``
    when there, else Debian's installed ones."""
    from e2vlib.experiments.real_meshes.catalogue import CRRCSIM_DIR, FURNITURE_DIR

    pkgs = Path(cache) / "pkgs"
    furniture = pkgs / "sweethome3d-furniture" / FURNITURE_SUBDIR
    crrcsim = pkgs / "crrcsim-data" / CRRCSIM_SUBDIR
    return (furniture if furniture.is_dir() else FURNITURE_DIR,
            crrcsim if crrcsim.is_dir() else CRRCSIM_DIR)


def sh3d_entries(cache: str | os.PathLike, rows: list[RealObject]) -> tuple[dict, str]:
    """``{id: (mapping row, catalogue entry)}`` of the Sweet Home 3D / crrcsim ``rows``
    and an empty string, or ``{}`` and why they are skipped (packages absent)."""
    from e2vlib.experiments.real_meshes.mapping import read_mapping, resolve

    wanted = {r.id for r in rows if r.source in SH3D_SOURCES}
    if not wanted:
        return {}, ""
    mapped = [m for m in read_mapping() if m.id in wanted]
    furniture, crrcsim = sh3d_folders(cache)
    try:
        pairs = resolve(mapped, furniture, crrcsim)
    except (FileNotFoundError, ValueError) as err:
        return {}, (f"skipping the {len(wanted)} Sweet Home 3D / crrcsim rows: {err} (or "
                    f"unpack {' and '.join(EXTRA_PACKAGES)} under {Path(cache) / 'pkgs'}: "
                    "python -m e2vlib.experiments.real_objects download, then extract)")
    return {m.id: (m, e) for m, e in pairs}, ""


def load_row_mesh(cache: str | os.PathLike, row: RealObject, sh3d: dict | None = None):
    """The model of catalogue ``row`` in our frame (z up, front -y, centred, longest side
    1): the stage-1 readers (:func:`~e2vlib.experiments.real_objects.readers.load_model`
    with the row's rotation and :func:`row_parts`) for the packages under
    ``<cache>/pkgs``, :func:`e2vlib.experiments.real_meshes.meshes.load_entry_mesh` with the
    row's pose for the Sweet Home 3D / crrcsim rows (their entries in ``sh3d``,
    :func:`sh3d_entries`)."""
    from e2vlib.experiments.real_objects.readers import load_model
    from e2vlib.shapes import normalize_mesh

    if row.source in SH3D_SOURCES:
        from e2vlib.experiments.real_meshes.meshes import load_entry_mesh

        if not sh3d or row.id not in sh3d:
            raise FileNotFoundError(f"{row.id}: its package ({row.source}) is not unpacked "
                                    "or installed")
        mapped, entry = sh3d[row.id]
        return load_entry_mesh(entry, sh3d_folders(cache)[0], pose=mapped.pose)
    return normalize_mesh(load_model(Path(cache) / "pkgs" / row.source, row.path,
                                     row.rotation, [], row_parts(row)))


def samples_config(config, catalogue: Path, packages: list[str]) -> dict:
    """config.json of the samples: ``config``'s settings (``per_category`` dropped: the
    catalogue sets the objects), the 13 categories, and the source: the catalogue and its
    sha256, the packages used, the labels and the command."""
    from e2vlib.experiments.real_objects import labels

    d = config.to_dict()
    d.pop("per_category")
    d["categories"] = list(paper.CATEGORIES)
    d["source"] = {"catalogue": str(catalogue),
                   "catalogue_sha256": hashlib.sha256(catalogue.read_bytes()).hexdigest(),
                   "packages": packages, "command": SAMPLES_COMMAND,
                   "labels": (f"e2vlib.experiments.real_objects.labels.solid_labels (factor "
                              f"{labels.FACTOR}, closing {labels.CLOSE_CELLS}, votes "
                              f"{labels.VOTES})")}
    return d


def _check_stored(out: Path, wanted: dict) -> None:
    from e2vlib.data.checks import DatasetError

    path = out / "config.json"
    if not path.is_file():
        if out.is_dir() and any(p.name not in ("samples", "records", "manifest.csv",
                                               "objects.csv") for p in out.iterdir()):
            raise DatasetError(f"{out} exists and is not a real-object sample folder; choose "
                               "another --out")
        return
    stored = json.loads(path.read_text())
    keys = set(stored) | set(wanted)
    differ = sorted(k for k in keys - {"categories", "source"} if stored.get(k) != wanted.get(k))
    if differ or stored.get("source", {}).get("labels") != wanted["source"]["labels"]:
        raise DatasetError(f"{path} was built with other settings ({', '.join(differ) or 'labels'}"
                           "); use another --out or delete it to rebuild")


def _order(rows: list[RealObject]) -> list[RealObject]:
    """Test rows first, then val, then train; within each, categories in turn, so a build
    stopped early has every category."""
    rank: Counter = Counter()
    keyed = []
    for row in sorted(rows, key=lambda r: (("test", "val", "train").index(r.split), r.id)):
        keyed.append(((("test", "val", "train").index(row.split), rank[(row.split,
                                                                        row.category)],
                       paper.CATEGORIES.index(row.category)), row))
        rank[(row.split, row.category)] += 1
    return [row for _, row in sorted(keyed, key=lambda kr: kr[0])]


def _read_record(out: Path, sample_id: str) -> dict | None:
    path = out / "records" / f"{sample_id}.json"
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


def _write_json(path: Path, data: dict) -> None:
    from e2vlib.files import atomic_path

    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(data, indent=1) + "\n")


def make_sample(cache: str | os.PathLike, row: RealObject, out: str | os.PathLike, config,
                sh3d: dict | None = None) -> dict:
    """Build the sample of ``row`` into ``out/samples/<id>.npz`` and return its record
    (written to ``out/records/<id>.json`` after the sample): its frames by
    :func:`e2vlib.data.mesh_to_sample`, its label by :func:`solid_labels` (and its IoU with
    :func:`~e2vlib.voxels.voxelize`'s label). A model that cannot be read or sampled gives a
    record with ``error`` and no sample."""
    from e2vlib.data import mesh_to_sample, save_sample
    from e2vlib.experiments.real_meshes.build import real_sample_seed
    from e2vlib.experiments.real_objects.labels import solid_labels
    from e2vlib.scale.render_cache import render_orbit_cached

    out = Path(out)
    start = time.monotonic()
    record = {"id": row.id, "category": row.category, "split": row.split,
              "source": row.source, "licence": row.licence, "made_from": made_from(row),
              "error": ""}
    try:
        mesh = load_row_mesh(cache, row, sh3d)
        record["faces"] = len(mesh.faces)
        voxels, found = solid_labels(mesh)
        record.update(found)
        sample = mesh_to_sample(mesh, config, seed=real_sample_seed(config.seed, row.id),
                                renderer=render_orbit_cached)
        record["voxelize_iou"] = round(iou(voxels, sample.voxels), 4)
        save_sample(out / "samples" / f"{row.id}.npz", sample.frames, voxels,
                    len(sample.events))
    except Exception as err:  # recorded: one bad model (reader, assimp, limits) stops nothing
        record["error"] = f"{type(err).__name__}: {err}"[:300]
        (out / "samples" / f"{row.id}.npz").unlink(missing_ok=True)
    record["seconds"] = round(time.monotonic() - start, 1)
    _write_json(out / "records" / f"{row.id}.json", record)
    return record


def _finish(out: Path, rows: list[RealObject], config) -> dict:
    """Write manifest.csv (the rows whose sample is on disk and up to date) and
    objects.csv; return the built samples per category."""
    from e2vlib.data import SampleSpec, write_manifest
    from e2vlib.experiments.real_meshes.build import real_sample_seed

    specs, records, built = [], [], Counter()
    index: Counter = Counter()
    for row in sorted(rows, key=lambda r: (paper.CATEGORIES.index(r.category), r.id)):
        rec = _read_record(out, row.id)
        k = index[row.category]
        index[row.category] += 1
        if rec is None:
            continue
        records.append(rec)
        if rec.get("made_from") == made_from(row) and not rec.get("error") and (
                out / "samples" / f"{row.id}.npz").is_file():
            specs.append(SampleSpec(id=row.id, category=row.category, index=k,
                                    split=row.split, seed=real_sample_seed(config.seed, row.id)))
            built[row.category] += 1
    write_manifest(out, specs)
    from e2vlib.files import atomic_path

    with atomic_path(out / "objects.csv") as tmp, open(tmp, "w", newline="") as f:
        writer = csv.DictWriter(f, RECORD_FIELDS, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(records)
    return dict(sorted(built.items(), key=lambda kv: paper.CATEGORIES.index(kv[0])))


def needs_assimp(row: RealObject) -> bool:
    """Whether a catalogue row's model is read through assimp (``archive::member`` paths by
    the member's name)."""
    return Path(row.path.rsplit("::", 1)[-1]).suffix.lower() in ASSIMP_SUFFIXES


def build_samples(cache: str | os.PathLike, out: str | os.PathLike,
                  catalogue: str | os.PathLike = CATALOGUE_CSV, config=None,
                  only: str | None = None, limit: int | None = None,
                  progress: bool = True) -> dict:
    """Build (or finish) the samples of the catalogue's kept rows into ``out``; return
    ``{"built": {category: samples}, "failed": [ids], "skipped": message, "seconds": s}``.

    ``only``: a regex on ids; ``limit``: stop after making this many samples (a build in
    pieces); ``config``: :func:`sample_config` by default. Samples on disk whose record
    matches their row are kept; samples of rows that went or changed are removed first. A
    row whose model failed is not tried again, unless it failed for want of assimp; with
    rows to build through assimp and no assimp, nothing is built (the error says how to
    install it).
    Stopping it (Ctrl-C, SIGTERM) finishes the current sample's files atomically and
    writes the manifest of what is built. Refuses a folder built with other settings.
    """
    import re

    cache, out, catalogue = Path(cache), Path(out), Path(catalogue)
    config = config or sample_config()
    rows = [r for r in read_catalogue(catalogue) if not only or re.search(only, r.id)]
    sh3d, skipped = sh3d_entries(cache, rows)
    if skipped and progress:
        print(skipped, flush=True)
    packages = sorted({r.source for r in rows if r.source not in SH3D_SOURCES or sh3d})
    wanted = samples_config(config, catalogue, packages)
    _check_stored(out, wanted)
    (out / "samples").mkdir(parents=True, exist_ok=True)
    (out / "records").mkdir(parents=True, exist_ok=True)
    by_id = {r.id: r for r in read_catalogue(catalogue)}
    for path in sorted((out / "samples").glob("*.npz")):
        rec = _read_record(out, path.stem)
        row = by_id.get(path.stem)
        if row is None or rec is None or rec.get("made_from") != made_from(row):
            if progress:
                print(f"removing the sample of {path.stem}: its row changed or went", flush=True)
            path.unlink()
    _write_json(out / "config.json", wanted)
    todo = []
    for row in _order(rows):
        if row.source in SH3D_SOURCES and not sh3d:
            continue
        rec = _read_record(out, row.id)
        failed_here = bool(rec and rec.get("error")) and ASSIMP_HINT not in rec["error"]
        if rec is not None and rec.get("made_from") == made_from(row) and (
                failed_here or (out / "samples" / f"{row.id}.npz").is_file()):
            continue  # made, or failed for the model's own sake (a missing tool is retried)
        todo.append(row)
    assimp_rows = [r.id for r in todo if needs_assimp(r)]
    if assimp_rows and shutil.which(ASSIMP) is None:
        raise RealMeshError(f"{len(assimp_rows)} rows to build (e.g. {assimp_rows[0]}) are "
                            f"{' or '.join(ASSIMP_SUFFIXES)} models, read through assimp, "
                            f"which is not installed: {ASSIMP_HINT}, then run this again")
    if limit is not None:
        todo = todo[:limit]
    start, failed = time.monotonic(), []
    stop = {"now": False}

    def _stop(signum, frame):  # finish the sample in hand, then write the manifest
        stop["now"] = True

    old = signal.signal(signal.SIGTERM, _stop)
    try:
        for i, row in enumerate(todo):
            if stop["now"]:
                break
            rec = make_sample(cache, row, out, config, sh3d)
            if rec["error"]:
                failed.append(row.id)
            if progress:
                print(f"{i + 1}/{len(todo)} {row.id} {row.split} {rec.get('fill', '')} "
                      f"iou={rec.get('voxelize_iou', '')} {rec['seconds']}s "
                      f"{rec['error'][:100]} [{time.monotonic() - start:.0f}s]", flush=True)
            if (i + 1) % MANIFEST_EVERY == 0:
                _finish(out, rows, config)
    except KeyboardInterrupt:
        if progress:
            print("stopped: writing the manifest of what is built", flush=True)
    finally:
        signal.signal(signal.SIGTERM, old)
        built = _finish(out, rows, config)
    seconds = time.monotonic() - start
    if progress:
        print(f"{sum(built.values())} samples in {out} ({len(failed)} failed this run, "
              f"{seconds:.0f} s): {built}", flush=True)
    return {"built": built, "failed": failed, "skipped": skipped, "seconds": seconds}
