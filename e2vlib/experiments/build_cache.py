"""Datasets built once per machine and copied where a lesson asks for them.

Lessons 09-15 each build the same mini dataset (:func:`~e2vlib.experiments.classroom.
build_mini_dataset`) into a folder of their own. :func:`build_once` builds a config the first
time into a cache folder (:func:`cache_root`, the system's temporary folder unless
``E2V_BUILD_CACHE`` names another; ``E2V_BUILD_CACHE=0`` turns the cache off) and copies that
build on later calls: the same files ``build_dataset`` would write, in a fraction of the time.
A cached build is named by its config and a digest of the library's source
(:func:`cache_key`), so a changed simulator or renderer never hands back old data. Processes
that ask for one config at once take turns (a ``filelock`` lock); the first builds, into a
``.partial`` folder that a later call resumes if it is interrupted, and renames it when done.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import os
import shutil
import tempfile
from pathlib import Path

CACHE_ENV = "E2V_BUILD_CACHE"
"""Environment variable: the cache folder, or ``0`` for no cache."""
LOCK_TIMEOUT_S = 3600.0
"""Seconds a process waits for another one building the same config (a full-mode class
dataset takes a few minutes) before it builds into its own folder instead."""


def cache_root() -> Path | None:
    """The cache folder: ``$E2V_BUILD_CACHE``, by default ``e2v-build-cache`` in the system's
    temporary folder; None when ``E2V_BUILD_CACHE=0``."""
    value = os.environ.get(CACHE_ENV, "")
    if value == "0":
        return None
    return Path(value) if value else Path(tempfile.gettempdir()) / "e2v-build-cache"


@functools.lru_cache(maxsize=1)
def source_digest() -> str:
    """SHA-256 (hex) of every ``.py`` file of the installed e2vlib, names and bytes."""
    package = Path(__file__).resolve().parents[1]
    digest = hashlib.sha256()
    for path in sorted(package.rglob("*.py")):
        digest.update(path.relative_to(package).as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def cache_key(config) -> str:
    """The name of ``config``'s cached build: 20 hex digits of a digest of every
    :class:`~e2vlib.data.BuildConfig` field and :func:`source_digest`.

    >>> from e2vlib.data import BuildConfig
    >>> a, b = (BuildConfig(categories=("chair",), per_category=n) for n in (3, 4))
    >>> cache_key(a) == cache_key(BuildConfig(categories=("chair",), per_category=3))
    True
    >>> cache_key(a) == cache_key(b)
    False
    """
    fields = json.dumps(dataclasses.asdict(config), sort_keys=True, default=list)
    return hashlib.sha256((fields + source_digest()).encode()).hexdigest()[:20]


def build_once(folder: str | os.PathLike, config, progress: bool = True) -> Path:
    """``build_dataset(folder, config)``, from the cache when this machine has built
    ``config`` before; return ``folder``. A ``folder`` that already holds files is built (or
    finished) in place, as ``build_dataset`` resumes it."""
    from filelock import FileLock, Timeout

    from e2vlib.data import build_dataset

    folder, root = Path(folder), cache_root()
    if root is None or (folder.is_dir() and any(folder.iterdir())):
        build_dataset(folder, config, progress=progress)
        return folder
    cached = root / cache_key(config)
    lock = FileLock(root / f"{cached.name}.lock")
    try:
        root.mkdir(parents=True, exist_ok=True)
        lock.acquire(timeout=LOCK_TIMEOUT_S)
    except (OSError, Timeout):  # no writable cache, or a build elsewhere that never ends
        build_dataset(folder, config, progress=progress)
        return folder
    try:
        if not cached.is_dir():
            partial = root / f"{cached.name}.partial"
            build_dataset(partial, config, progress=progress)
            os.replace(partial, cached)
    finally:
        lock.release()
    shutil.copytree(cached, folder, dirs_exist_ok=True)
    return folder
