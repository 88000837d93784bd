"""Building a dataset: :func:`build_dataset` (resumable, sharded, in worker processes).

The build checks its folder first (:func:`check_build_folder`), writes config.json, runs
:func:`~e2vlib.data.samples.mesh_to_sample` for every planned sample not yet on disk through
:func:`run_jobs` (the worker pool other builds use too), then rewrites the manifest.
Introduced in notebooks/04_building_the_dataset.ipynb.
"""

from __future__ import annotations

import functools
import json
import multiprocessing
import os
from collections.abc import Callable, Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

from tqdm.auto import tqdm
from tqdm.contrib.concurrent import process_map

from e2vlib.data.checks import DatasetError, read_config
from e2vlib.data.config import BuildConfig
from e2vlib.data.grey import GREY_DIR, save_grey_video
from e2vlib.data.manifest import write_manifest
from e2vlib.data.plan import SampleSpec, plan_samples, raw_event_ids
from e2vlib.data.samples import mesh_to_sample, save_sample
from e2vlib.files import atomic_path
from e2vlib.io import save_events
from e2vlib.orbit import rendered_times_us

SHARDS_DIR = "shards"
"""Folder of a dataset holding one ``<i>-of-<n>.json`` per ``--shard i/n`` run."""


DATASET_ENTRIES = ("samples", "events", GREY_DIR, "shards", "manifest.csv", "config.json")
"""What a folder being built holds; make-data refuses a folder holding anything else
before its config.json is written."""


def _build_one(args: tuple[BuildConfig, SampleSpec, str, bool, Callable | None]) -> dict:
    config, spec, root, keep_events, renderer = args
    from e2vlib.shapes import make_shape

    sample = mesh_to_sample(make_shape(spec.category, spec.seed), config, seed=spec.seed,
                            renderer=renderer)
    root_path = Path(root)
    if keep_events:
        save_events(root_path / "events" / f"{spec.id}.npz", sample.events, sample.sensor_size)
    if sample.grey is not None:  # written before the sample file, which marks it done
        save_grey_video(root_path / GREY_DIR / f"{spec.id}.npz", sample.grey, sample.grey_index,
                        rendered_times_us(oversample=config.oversample)[sample.grey_index])
    save_sample(root_path / "samples" / f"{spec.id}.npz", sample.frames, sample.voxels,
                len(sample.events))
    return {**asdict(spec), "n_events": len(sample.events)}


def check_build_folder(root: str | os.PathLike, config: BuildConfig) -> None:
    """Refuse to build ``config`` into ``root`` (DatasetError, before anything is written)
    when ``root`` is a file, a dataset of other settings, or a non-empty folder of files
    that are not a dataset's (:data:`DATASET_ENTRIES`), as ``merge-data`` refuses.

    Examples
    --------
    >>> import tempfile
    >>> root = Path(tempfile.mkdtemp())
    >>> config = BuildConfig(categories=("chair",), per_category=2, oversample=1)
    >>> check_build_folder(root, config)  # an empty folder: fine
    >>> _ = (root / "notes.txt").write_text("mine")
    >>> check_build_folder(root, config)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.data.checks.DatasetError: ... is not a dataset (no config.json; it holds notes.txt); ...
    """
    root = Path(root)
    if root.exists() and not root.is_dir():
        raise DatasetError(f"{root} is a file; give make-data a folder (new or empty)")
    config_path = root / "config.json"
    if config_path.exists():
        try:
            stored = BuildConfig.from_dict(read_config(root)).to_dict()
        except (TypeError, ValueError) as err:
            raise DatasetError(f"{config_path} holds no valid build settings "
                               f"({' '.join(str(err).split())}); use another --out folder or "
                               "delete it to rebuild") from None
        if stored != config.to_dict():
            raise DatasetError(f"{config_path} was built with different settings {stored}; "
                               "use another --out folder or delete it to rebuild")
        return
    if not root.is_dir():
        return
    foreign = sorted(p.name for p in root.iterdir() if p.name not in DATASET_ENTRIES
                     and not p.name.startswith(".config.json."))
    if foreign:
        listed = ", ".join(foreign[:3]) + (f" and {len(foreign) - 3} more"
                                           if len(foreign) > 3 else "")
        raise DatasetError(f"{root} exists and is not a dataset (no config.json; it holds "
                           f"{listed}); make-data builds into a new or empty folder, or "
                           "finishes a dataset of the same settings: choose another --out")


def describe_build(root: str | os.PathLike, config: BuildConfig,
                   shard: tuple[int, int] = (0, 1)) -> str:
    """One line: how many samples the build of ``config`` (shard ``i/n``) into ``root``
    plans, how many are there already and how many it will make.

    Examples
    --------
    >>> import tempfile
    >>> config = BuildConfig(categories=("chair", "lamp"), per_category=5, resolution=32,
    ...                      frame_size=16)
    >>> line = describe_build(Path(tempfile.mkdtemp()), config)
    >>> line[:49], line[-28:]
    ('plan: 10 samples (2 categories x 5 objects; split', '0 already built, 10 to build')
    """
    root = Path(root)
    index, count = shard
    mine = [s for k, s in enumerate(plan_samples(config))
            if k % count == index and s.split in config.splits]
    done = sum(_sample_done(root, s.id, config) for s in mine)
    where = f"; shard {index}/{count}" if count > 1 else ""
    return (f"plan: {len(mine)} samples ({len(config.categories)} categories x "
            f"{config.per_category} objects; splits {', '.join(config.splits)}{where}): "
            f"{done} already built, {len(mine) - done} to build")


def build_dataset(
    root: str | os.PathLike,
    config: BuildConfig,
    workers: int = 1,
    shard: tuple[int, int] = (0, 1),
    progress: bool = True,
    renderer: Callable | None = None,
) -> Path:
    """Build (or finish building) a dataset in ``root``; return the manifest path.

    Deterministic for a config; resumable: samples whose file exists are skipped, and
    every file is written under a temporary name, then renamed. ``shard=(i, n)`` builds
    every n-th sample starting at i, so n processes or cluster jobs can share the work
    (into one shared folder or one folder each, joined by
    :func:`e2vlib.scale.shards.merge_datasets`); it leaves ROOT/shards/<i>-of-<n>.json so a
    merge can name a missing shard. Each run rewrites the manifest from the sample files
    present. ``renderer`` renders each orbit (default :func:`e2vlib.render.render_orbit`, a
    fresh plotter per sample; ``make-data`` lends
    :func:`e2vlib.scale.render_cache.render_orbit_cached`, which reuses one per process).
    Introduced in notebooks/04_building_the_dataset.ipynb.

    Examples
    --------
    One test sample of 16 px (the lessons build 128 px):

    >>> import tempfile
    >>> from e2vlib.data.manifest import read_manifest
    >>> config = BuildConfig(categories=("chair",), per_category=3, resolution=16, frame_size=8,
    ...                      oversample=1, splits=("test",))
    >>> manifest = build_dataset(Path(tempfile.mkdtemp()) / "data", config, progress=False)
    >>> [(row["id"], row["split"]) for row in read_manifest(manifest.parent)]
    [('chair_0002', 'test')]
    >>> sorted(p.name for p in manifest.parent.iterdir())
    ['config.json', 'events', 'manifest.csv', 'samples']
    """
    root = Path(root)
    check_build_folder(root, config)
    (root / "samples").mkdir(parents=True, exist_ok=True)
    (root / "events").mkdir(exist_ok=True)
    config_path = root / "config.json"
    if not config_path.exists():
        with atomic_path(config_path) as tmp:
            tmp.write_text(json.dumps(config.to_dict(), indent=2) + "\n")

    specs = plan_samples(config)
    keep = raw_event_ids(specs, config.raw_events_per_category)
    index, count = shard
    if count > 1:
        marker = root / SHARDS_DIR / f"{index}-of-{count}.json"
        marker.parent.mkdir(exist_ok=True)
        with atomic_path(marker) as tmp:
            tmp.write_text(json.dumps({"shard": f"{index}/{count}"}) + "\n")
    todo = [s for k, s in enumerate(specs) if k % count == index and s.split in config.splits
            and not _sample_done(root, s.id, config)]
    jobs = [(config, s, str(root), s.id in keep, renderer) for s in todo]
    run_jobs(_build_one, jobs, workers, f"building {root.name}", "sample", progress,
             names=[f"sample {s.id}" for s in todo])
    return write_manifest(root, specs)


class _SpawnedWorkersBar(tqdm):
    """tqdm's bar, given a lock that "spawn" workers can take: tqdm makes its own lock in the
    default ("fork") context, which Python refuses to send to spawned processes."""


class JobError(RuntimeError):
    """One job of :func:`run_jobs` failed; the message names it and the original error.

    ``expected`` says whether that error was a refusal of bad input (a ValueError or an
    OSError, which the command line prints as one plain line) rather than a bug; it travels
    in ``args``, so it survives the trip back from a worker process.
    """

    def __init__(self, message: str, expected: bool = False) -> None:
        super().__init__(message, expected)
        self.expected = expected

    def __str__(self) -> str:
        return self.args[0]


def _named_job(work: Callable[[Any], Any], job: Any, name: str) -> Any:
    """``work(job)``, with an error turned into a :class:`JobError` that names the job."""
    try:
        return work(job)
    except Exception as err:
        raise JobError(f"{name} failed: {type(err).__name__}: {err}",
                       expected=isinstance(err, ValueError | OSError)) from err


def run_jobs(work: Callable[[Any], Any], jobs: Sequence[Any], workers: int, desc: str,
             unit: str, progress: bool, names: Sequence[str] | None = None) -> list:
    """``[work(job) for job in jobs]`` with a progress bar of ``unit``s; in ``workers``
    fresh processes (tqdm's ``process_map``) when more than one, else in this process.

    ``work`` must be a module-level function when ``workers > 1`` (it is pickled). A failing
    job raises :class:`JobError` naming it by ``names[k]`` (default ``"<unit> <k>"``).

    Examples
    --------
    >>> run_jobs(str.upper, ["a", "b"], workers=1, desc="shouting", unit="word", progress=False)
    ['A', 'B']
    >>> run_jobs(int, ["1", "x"], 1, "parsing", "number", False, names=["one", "ex"])
    Traceback (most recent call last):
    ...
    e2vlib.data.build.JobError: ex failed: ValueError: invalid literal for int() with base 10: 'x'
    """
    names = [f"{unit} {k}" for k in range(len(jobs))] if names is None else list(names)
    if len(names) != len(jobs):
        raise ValueError(f"run_jobs got {len(jobs)} jobs but {len(names)} names; give one name "
                         "per job")
    task = functools.partial(_named_job, work)
    if workers > 1 and len(jobs) > 1:
        # "spawn": each worker starts a fresh interpreter with its own VTK/OpenGL state.
        spawn = multiprocessing.get_context("spawn")
        _SpawnedWorkersBar.set_lock(spawn.RLock())
        return process_map(task, jobs, names, max_workers=workers, chunksize=1,
                           mp_context=spawn, tqdm_class=_SpawnedWorkersBar, desc=desc,
                           unit=unit, disable=not progress)
    return [task(job, name) for job, name in tqdm(list(zip(jobs, names, strict=True)),
                                                  desc=desc, unit=unit, disable=not progress)]


def _sample_done(root: Path, sample_id: str, config: BuildConfig) -> bool:
    """True when the sample file exists (and its grey video, if the build stores one)."""
    return (root / "samples" / f"{sample_id}.npz").exists() and (
        not config.grey_video or (root / GREY_DIR / f"{sample_id}.npz").exists())
