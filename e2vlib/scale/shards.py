"""Sharded dataset builds: join the shards of ``make-data --shard i/n`` and verify them.

A cluster job array runs ``python -m e2vlib make-data ... --shard i/n`` once per shard,
into one shared folder or one folder each. :func:`merge_datasets` (CLI ``merge-data``)
checks that every shard was built with the same config, that every planned sample is
present exactly once (a sample found in two shards must hold the same arrays), that each
file loads, and writes the joined folder's manifest; missing samples are named with the
``make-data`` command that builds them. See docs/developer.md, "Sharded builds and grey video".
"""

from __future__ import annotations

import json
import os
import shutil
import zipfile
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from e2vlib import paper
from e2vlib.data.build import SHARDS_DIR
from e2vlib.data.commands import make_data_command
from e2vlib.data.config import BuildConfig
from e2vlib.data.grey import GREY_DIR
from e2vlib.data.manifest import manifest_digests, npz_digest, write_manifest
from e2vlib.data.plan import SampleSpec, parse_shard, plan_samples, raw_event_ids
from e2vlib.data.samples import load_sample
from e2vlib.files import atomic_path


class MergeError(ValueError):
    """Shards that cannot be merged (other settings, differing or missing samples).

    Examples
    --------
    >>> issubclass(MergeError, ValueError)
    True
    """


@dataclass
class MergeReport:
    """What :func:`merge_datasets` did: ``n_samples`` planned and present in ``root``;
    files ``linked`` (hard links), ``copied`` and ``kept`` (already in ``root``).

    Examples
    --------
    >>> MergeReport(root=Path("whole"), manifest=Path("whole/manifest.csv"), n_samples=3).linked
    0
    """

    root: Path
    manifest: Path
    n_samples: int
    sources: list[Path] = field(default_factory=list)
    linked: int = 0
    copied: int = 0
    kept: int = 0


def _read_config(root: Path) -> BuildConfig:
    path = root / "config.json"
    if not path.is_file():
        raise MergeError(f"{root} is not a dataset folder (no config.json); give folders "
                         "built by `python -m e2vlib make-data --shard i/n`")
    try:
        return BuildConfig.from_dict(json.loads(path.read_text()))
    except (ValueError, TypeError) as err:
        raise MergeError(f"{path}: unreadable build settings ({err})") from err


def _shard_markers(roots: Sequence[Path]) -> dict[tuple[int, int], list[Path]]:
    """``{(i, n): folders}`` of the shard runs recorded in ROOT/shards/ of each root."""
    found: dict[tuple[int, int], list[Path]] = {}
    for root in roots:
        for marker in sorted((root / SHARDS_DIR).glob("*-of-*.json")):
            try:
                shard = parse_shard(marker.stem.replace("-of-", "/"))
            except ValueError:
                continue
            found.setdefault(shard, []).append(root)
    return found


def _missing_message(config: BuildConfig, specs: Sequence[SampleSpec],
                     missing: Sequence[int], roots: Sequence[Path], fallback: Path) -> str:
    """Which planned samples (positions ``missing`` in ``specs``) no folder holds, grouped
    by the shard that builds them, each with the make-data command to run."""
    markers = _shard_markers(roots)
    counts = {n for _, n in markers}
    parts = []
    if len(counts) == 1:
        n = counts.pop()
        for i in range(n):
            ids = [specs[k].id for k in missing if k % n == i]
            if not ids:
                continue
            where = markers.get((i, n))
            state = (f"shard {i}/{n} in {where[0]} is incomplete" if where else
                     f"shard {i}/{n} is missing (no folder given holds it)")
            listed = ", ".join(ids[:5]) + (f" and {len(ids) - 5} more" if len(ids) > 5 else "")
            out = where[0] if where else "SHARD_DIR"
            parts.append(f"{state}: {len(ids)} sample(s) ({listed}); build them with "
                         f"`{make_data_command(config, out, f'{i}/{n}')}`")
    else:
        ids = [specs[k].id for k in missing]
        listed = ", ".join(ids[:5]) + (f" and {len(ids) - 5} more" if len(ids) > 5 else "")
        parts.append(f"{len(ids)} sample(s) ({listed}) are in none of the folders; build them "
                     f"with `{make_data_command(config, fallback)}` (builds only what is "
                     "missing)")
    return (f"{len(missing)} of {len(specs)} planned samples missing: " + "; ".join(parts)
            + "; then rerun merge-data")


def _check_file(kind: str, path: Path, config: BuildConfig) -> None:
    """Load one file of a sample to prove it is whole (raises MergeError naming it)."""
    try:
        if kind == "samples":
            load_sample(path, (config.n_frames, config.frame_size, config.frame_size),
                        (paper.GRID_SIDE,) * 3)
        elif kind == GREY_DIR:
            with np.load(path, allow_pickle=False) as data:
                grey = data["grey"]
                if grey.dtype != np.uint8 or grey.shape != (
                        config.n_frames, config.frame_size, config.frame_size):
                    raise ValueError(f"grey frames {grey.dtype} {grey.shape}")
        else:
            from e2vlib.io import load_events

            load_events(path)
    except (ValueError, KeyError, OSError, EOFError, zipfile.BadZipFile) as err:
        raise MergeError(f"{path} is damaged ({' '.join(str(err).split())}); delete it and "
                         "its sample file, rebuild with make-data, then rerun merge-data"
                         ) from err


def _place(src: Path, dst: Path, link: bool) -> str:
    """Hard-link (when ``link`` and on one filesystem) or copy ``src`` to ``dst`` under a
    temporary name, then rename; return ``"linked"`` or ``"copied"``."""
    dst.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(dst) as tmp:
        if link:
            try:
                os.link(src, tmp)
                return "linked"
            except OSError:  # another filesystem, or links not allowed there
                pass
        shutil.copyfile(src, tmp)
        if tmp.stat().st_size != src.stat().st_size:
            raise OSError(f"copying {src} to {dst} wrote {tmp.stat().st_size} bytes, not "
                          f"{src.stat().st_size}; check the free space in {dst.parent}")
    return "copied"


def merge_datasets(dest: str | os.PathLike, sources: Sequence[str | os.PathLike] = (),
                   link: bool = True) -> MergeReport:
    """Join shard folders into ``dest`` and check the result is the whole dataset.

    Every source (and ``dest``, if it already holds a dataset) must have the same
    config.json. Each sample planned by :func:`plan_samples` must be in some folder, with
    its raw events (when the build keeps them) and grey video (``grey_video``); a sample in
    several folders must have the same arrays (:func:`npz_digest`) everywhere. Files are
    loaded, and sample files checked against the ``sha256`` their manifest recorded.
    Everything is checked before anything is written; then the files are hard-linked
    (``link=True`` and the same filesystem; files are only ever replaced, never edited, so
    a link is as good as a copy) or copied, each under a temporary name, and ``dest``'s
    config.json and manifest.csv are written. With no ``sources`` it verifies ``dest`` in
    place (shards built into one shared folder) and rewrites its manifest. Raises
    :class:`MergeError` naming the folders and, for missing samples, the make-data
    command of each shard that would build them.

    Examples
    --------
    Two shard folders of three empty samples written by hand (``make-data --shard i/2`` would
    render them), joined; one shard alone is refused:

    >>> import tempfile
    >>> from e2vlib.data import read_manifest, save_sample
    >>> work = Path(tempfile.mkdtemp())
    >>> config = BuildConfig(categories=("chair",), per_category=3, resolution=16,
    ...                      frame_size=8, oversample=1, raw_events_per_category=0)
    >>> frames, label = np.zeros((100, 8, 8)), np.zeros((32, 32, 32))
    >>> for i in (0, 1):  # shard i of 2 holds samples i, i + 2, ...
    ...     shard = work / f"shard{i}"
    ...     (shard / "samples").mkdir(parents=True)
    ...     _ = (shard / "config.json").write_text(json.dumps(config.to_dict()))
    ...     for spec in plan_samples(config)[i::2]:
    ...         save_sample(shard / "samples" / f"{spec.id}.npz", frames, label, n_events=0)
    >>> report = merge_datasets(work / "whole", [work / "shard0", work / "shard1"])
    >>> report.n_samples, report.linked + report.copied, len(read_manifest(work / "whole"))
    (3, 3, 3)
    >>> merge_datasets(work / "half", [work / "shard0"])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.scale.shards.MergeError: 1 of 3 planned samples missing: ...
    """
    dest = Path(dest)
    roots, seen = [], set()
    for source in [Path(p) for p in sources]:
        if not source.is_dir():
            raise MergeError(f"shard folder {source} does not exist; give folders built by "
                             "make-data --shard")
        if source.resolve() not in seen and source.resolve() != dest.resolve():
            seen.add(source.resolve())
            roots.append(source)
    dest_is_data = (dest / "config.json").is_file()
    if dest_is_data:
        roots.insert(0, dest)
    elif dest.exists() and (not dest.is_dir() or any(dest.iterdir())):
        raise MergeError(f"{dest} exists and is not a dataset (no config.json); choose an "
                         "empty or new --out folder")
    if not roots:
        raise MergeError(f"nothing to merge: {dest} holds no dataset and no shard folders "
                         "were given; list the shard folders after --out")

    configs = [(root, _read_config(root)) for root in roots]
    first_root, config = configs[0]
    for root, other in configs[1:]:
        if other != config:
            a, b = config.to_dict(), other.to_dict()
            differ = sorted(k for k in set(a) | set(b) if a.get(k) != b.get(k))
            raise MergeError(f"{root} was built with other settings than {first_root} "
                             f"(different {', '.join(differ)}); merge only shards of one "
                             "make-data command")

    specs = plan_samples(config)
    keep = raw_event_ids(specs, config.raw_events_per_category)
    recorded = {root: manifest_digests(root) for root in roots}
    plan: list[tuple[str, Path, Path]] = []  # (kind, source file, destination file)
    digests: dict[str, str] = {}
    missing: list[int] = []
    for k, spec in enumerate(specs):
        kinds = ["samples"] + (["events"] if spec.id in keep else []) + (
            [GREY_DIR] if config.grey_video else [])
        holders = [r for r in roots if (r / "samples" / f"{spec.id}.npz").is_file()]
        if not holders:
            missing.append(k)
            continue
        chosen: dict[str, tuple[Path, str]] = {}
        for root in holders:
            for kind in kinds:
                path = root / kind / f"{spec.id}.npz"
                if not path.is_file():
                    raise MergeError(
                        f"{root / 'samples' / (spec.id + '.npz')} has no {kind}/{spec.id}.npz "
                        f"(an interrupted or edited build); delete the sample file, rerun "
                        f"its make-data into {root}, then rerun merge-data")
                if kind in chosen and os.path.samefile(chosen[kind][0], path):
                    continue  # the same file (a hard link): nothing to compare
                digest = npz_digest(path)
                if kind == "samples" and recorded[root].get(spec.id) not in (None, digest):
                    raise MergeError(f"{path} does not match the sha256 its manifest recorded "
                                     "(changed or damaged since it was built); delete it, "
                                     "rebuild it with make-data, then rerun merge-data")
                if kind in chosen and chosen[kind][1] != digest:
                    raise MergeError(f"{kind}/{spec.id}.npz differs between "
                                     f"{chosen[kind][0].parents[1]} and {root}; they are not "
                                     "shards of one build: delete the wrong one and rebuild it")
                if kind not in chosen:
                    _check_file(kind, path, config)
                    chosen[kind] = (path, digest)
        digests[spec.id] = chosen["samples"][1]
        plan.extend((kind, path, dest / kind / f"{spec.id}.npz")
                    for kind, (path, _) in chosen.items())
    if missing:
        raise MergeError(_missing_message(config, specs, missing, roots, dest))

    report = MergeReport(root=dest, manifest=dest / "manifest.csv", n_samples=len(specs),
                         sources=[r for r in roots if r != dest])
    for sub in ("samples", "events") + ((GREY_DIR,) if config.grey_video else ()):
        (dest / sub).mkdir(parents=True, exist_ok=True)
    if not dest_is_data:
        with atomic_path(dest / "config.json") as tmp:
            tmp.write_text(json.dumps(config.to_dict(), indent=2) + "\n")
    # samples last, so an interrupted merge never leaves a sample without its other files
    for _kind, src, dst in sorted(plan, key=lambda item: item[0] == "samples"):
        if dst.exists() and os.path.samefile(src, dst):
            report.kept += 1
            continue
        if _place(src, dst, link) == "linked":
            report.linked += 1
        else:
            report.copied += 1
    write_manifest(dest, specs, digests)
    return report
