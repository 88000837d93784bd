"""Building the real-mesh test set: every kept model, by the data_small protocol.

:func:`build_real_dataset` (``python -m e2vlib make-data --preset small --real-meshes
data_small/real/catalogue.csv``, :data:`BUILD_COMMAND`) makes one test sample per kept row
of the reviewed table with :func:`e2vlib.data.mesh_to_sample`, in a dataset folder that
:class:`e2vlib.data.E2VDataset` reads; :mod:`e2vlib.experiments.real_study` scores models on it.

Scored by :mod:`e2vlib.experiments.real_study` (experiments/results/real_meshes.json).
"""

from __future__ import annotations

import os
from pathlib import Path

from e2vlib import paper
from e2vlib.experiments.real_meshes.catalogue import (
    CRRCSIM,
    CRRCSIM_DIR,
    FURNITURE_DIR,
    INSTALL_HINT,
    RealMeshError,
    installed_libraries,
)
from e2vlib.experiments.real_meshes.mapping import MAPPING_CSV, read_mapping, resolve
from e2vlib.experiments.real_meshes.meshes import load_entry_mesh

BUILD_COMMAND = ("apt-get install -y sweethome3d-furniture crrcsim-data && "
                 "python -m e2vlib make-data "
                 "--preset small --real-meshes data_small/real/catalogue.csv "
                 "--out cache/real_meshes")
"""The recorded command that builds the real-mesh test set (install step first)."""


def real_sample_seed(seed: int, sample_id: str) -> int:
    """A stable 31-bit simulator seed for the real object ``sample_id``.

    Examples
    --------
    >>> real_sample_seed(0, "chair_bs0_armchair")
    1592418502
    >>> real_sample_seed(1, "chair_bs0_armchair") != real_sample_seed(0, "chair_bs0_armchair")
    True
    """
    import hashlib

    digest = hashlib.sha256(f"{seed}/real/{sample_id}".encode()).digest()
    return int.from_bytes(digest[:4], "little") & 0x7FFFFFFF


def real_config(config, catalogue: str | os.PathLike = MAPPING_CSV,
                folder: str | os.PathLike = FURNITURE_DIR) -> dict:
    """config.json of a real-mesh dataset: the frame and render settings of ``config`` (a
    :class:`e2vlib.data.BuildConfig`; ``per_category`` dropped, as the catalogue sets the
    objects), the categories present, and where the meshes came from (the libraries'
    folder and the catalogue, as given, with the catalogue's sha256, and each kept row's
    ``"library entry_id pose"``: what its sample is made from).

    Examples
    --------
    >>> from e2vlib.data import BuildConfig
    >>> d = real_config(BuildConfig(categories=("chair",), per_category=4))
    >>> "per_category" in d, len(d["categories"]), "rifle" in d["categories"]  # no real rifle
    (False, 12, False)
    >>> d["source"]["packages"], d["source"]["install"]
    (['sweethome3d-furniture', 'crrcsim-data'], 'apt-get install sweethome3d-furniture \
crrcsim-data')
    """
    import hashlib

    catalogue = Path(catalogue)
    d = config.to_dict()
    d.pop("per_category")
    rows = read_mapping(catalogue)
    d["categories"] = [c for c in paper.CATEGORIES if any(m.category == c for m in rows)]
    aircraft = any(m.library == CRRCSIM for m in rows)
    d["source"] = {"packages": ["sweethome3d-furniture", *([CRRCSIM] if aircraft else [])],
                   "install": INSTALL_HINT + (" crrcsim-data" if aircraft else ""),
                   "folder": str(folder), "catalogue": str(catalogue),
                   "catalogue_sha256": hashlib.sha256(catalogue.read_bytes()).hexdigest(),
                   "rows": {m.id: row_source(m) for m in rows}}
    return d


def row_source(mapped) -> str:
    """What the sample of the mapping row ``mapped`` is made from: ``"library entry_id
    pose"`` (a resumed build rebuilds a sample whose row says otherwise).

    Examples
    --------
    >>> from e2vlib.experiments.real_meshes.mapping import MappedEntry
    >>> row_source(MappedEntry("telephone_bs0_phone", "BlendSwap-CC-0.sh3f", "Test#phone",
    ...                        "Phone", "X", "CC0-1.0", "LICENSE.TXT", "telephone", "stood_up",
    ...                        True, "looked: a phone"))
    'BlendSwap-CC-0.sh3f Test#phone stood_up'
    """
    return f"{mapped.library} {mapped.entry_id} {mapped.pose}"


def _build_real_one(args: tuple) -> str:
    config, mapped, entry, root, folder = args
    from e2vlib.data import mesh_to_sample, save_sample
    from e2vlib.scale.render_cache import render_orbit_cached

    mesh = load_entry_mesh(entry, folder, pose=mapped.pose)
    sample = mesh_to_sample(mesh, config, seed=real_sample_seed(config.seed, mapped.id),
                            renderer=render_orbit_cached)
    save_sample(Path(root) / "samples" / f"{mapped.id}.npz", sample.frames, sample.voxels,
                len(sample.events))
    return mapped.id


def build_real_dataset(root: str | os.PathLike, config,
                       catalogue: str | os.PathLike = MAPPING_CSV,
                       folder: str | os.PathLike = FURNITURE_DIR, workers: int = 1,
                       progress: bool = True,
                       crrcsim_folder: str | os.PathLike | None = None) -> Path:
    """Build (or finish) the real-mesh test set in ``root``; return its manifest path.

    Every kept row of ``catalogue`` (:func:`read_mapping`) becomes one test sample, made
    from its installed model (:func:`load_entry_mesh`) by :func:`e2vlib.data.mesh_to_sample`
    with ``config``'s settings (the data_small protocol with ``--preset small``), so models
    trained on data_small read it as they read its test split. The layout is a dataset's
    (``config.json`` from :func:`real_config`, ``manifest.csv``, ``samples/<id>.npz``), so
    :class:`e2vlib.data.E2VDataset` (split ``test``) and ``evaluate`` read it. Resumable:
    samples on disk are skipped, except those whose catalogue row changed (library, entry
    or pose: :func:`row_source`) or went, which are made again; every file is written to a
    temporary name and renamed. ``crrcsim_folder``: crrcsim-data's aircraft (default
    :data:`CRRCSIM_DIR`). Raises FileNotFoundError naming the install step when the package
    is absent, and refuses (before writing) a ``config`` with ``grey_video`` (the set stores
    none) or a catalogue that keeps no row.

    Examples
    --------
    Without Debian's package the build stops before it writes anything, naming the install:

    >>> import tempfile
    >>> from pathlib import Path
    >>> from e2vlib.data import BuildConfig
    >>> root = Path(tempfile.mkdtemp()) / "real"
    >>> build_real_dataset(root, BuildConfig(categories=("chair",), per_category=1),
    ...                    folder=root.parent / "no_package")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    FileNotFoundError: no .sh3f furniture libraries in ...: sweethome3d-furniture is not \
installed; apt-get install sweethome3d-furniture
    >>> root.exists()
    False
    """
    import json

    from e2vlib.data import SampleSpec, npz_digest, run_jobs, write_manifest
    from e2vlib.files import atomic_path

    root = Path(root)
    _check_real_build(config, catalogue, folder)
    wanted = real_config(config, catalogue, folder)
    config_path = root / "config.json"
    stored = _stored_real_config(root, wanted)
    (root / "samples").mkdir(parents=True, exist_ok=True)
    # a changed catalogue keeps the samples whose rows it keeps as they were; samples of rows
    # that changed or went are removed before the new catalogue is recorded, so a resumed
    # build never keeps a sample its config.json does not describe
    for sample_id, was in _changed_rows(root, stored, wanted).items():
        if progress:
            print(f"removing the sample of {sample_id}: its catalogue row changed or went "
                  f"(it was made from {was})")
        (root / "samples" / f"{sample_id}.npz").unlink()
    with atomic_path(config_path) as tmp:
        tmp.write_text(json.dumps(wanted, indent=2) + "\n")
    crrcsim = CRRCSIM_DIR if crrcsim_folder is None else crrcsim_folder
    pairs = resolve(read_mapping(catalogue), folder, crrcsim)
    specs, seen = [], {}
    for mapped, _ in pairs:
        index = seen[mapped.category] = seen.get(mapped.category, -1) + 1
        specs.append(SampleSpec(id=mapped.id, category=mapped.category, index=index,
                                split="test", seed=real_sample_seed(config.seed, mapped.id)))
    todo = [(m, e) for m, e in pairs if not (root / "samples" / f"{m.id}.npz").exists()]
    jobs = [(config, m, e, str(root), str(folder)) for m, e in todo]
    run_jobs(_build_real_one, jobs, workers, f"building {root.name}", "object", progress,
             names=[f"object {m.id}" for m, _ in todo])
    digests = {m.id: npz_digest(root / "samples" / f"{m.id}.npz") for m, _ in todo}
    return write_manifest(root, specs, digests)


def _check_real_build(config, catalogue: str | os.PathLike, folder: str | os.PathLike
                      ) -> None:
    """Refuse, before anything is written, a build without the package, of settings the
    real-mesh set does not keep (grey video), or of a catalogue that keeps no row."""
    from e2vlib.data.checks import DatasetError

    installed_libraries(folder)  # names the install step when the package is absent
    if config.grey_video:
        raise DatasetError("the real-mesh test set stores no grey video (its visual hull "
                           "renders each mesh again); build it without --grey-video")
    if not read_mapping(catalogue):
        raise RealMeshError(f"{catalogue} keeps no row (keep=yes): the real-mesh test set "
                            "would be empty; give the reviewed table, "
                            "data_small/real/catalogue.csv")


def _stored_real_config(root: Path, wanted: dict) -> dict | None:
    """The config.json already in ``root`` (None when there is none), refused when it was
    built with other settings or ``root`` is not a real-mesh dataset."""
    import json

    from e2vlib.data.checks import DatasetError

    config_path = root / "config.json"
    if not config_path.exists():
        if root.exists() and any(p.name not in ("samples", "manifest.csv")
                                 for p in root.iterdir()):
            raise DatasetError(f"{root} exists and is not a real-mesh dataset; choose another "
                               "--out folder")
        return None
    stored = json.loads(config_path.read_text())
    settings = {k: v for k, v in stored.items() if k not in ("categories", "source")}
    if "source" not in stored or settings != {
            k: v for k, v in wanted.items() if k not in ("categories", "source")}:
        raise DatasetError(f"{config_path} was built with other settings ({stored}); use "
                           "another --out folder or delete it to rebuild")
    return stored


def _changed_rows(root: Path, stored: dict | None, wanted: dict) -> dict[str, str]:
    """``{id: what it was made from}`` of the samples on disk that the new catalogue makes
    otherwise, or no longer lists; refused for a build that recorded no rows (before they
    were recorded) made from another catalogue."""
    from e2vlib.data.checks import DatasetError

    source = (stored or {}).get("source", {})
    new = wanted["source"]["rows"]
    if stored is not None and "rows" not in source:
        if source.get("catalogue_sha256") == wanted["source"]["catalogue_sha256"]:
            return {}
        raise DatasetError(f"{root / 'config.json'} was built from another catalogue and "
                           "records no row's source, so its samples cannot be matched to "
                           f"the rows of {wanted['source']['catalogue']}; delete {root} to "
                           "rebuild it")
    old = source.get("rows", {})
    on_disk = sorted(p.stem for p in (root / "samples").glob("*.npz"))
    return {sid: old.get(sid, "not recorded") for sid in on_disk
            if old.get(sid) != new.get(sid)}
