"""``experiments.build_cache``: a cached build is the build, byte for byte, and is made once."""

from __future__ import annotations

from pathlib import Path

import pytest

from e2vlib.data import BuildConfig
from e2vlib.experiments import build_cache
from e2vlib.experiments.build_cache import build_once, cache_key, cache_root

TINY = BuildConfig(categories=("chair",), per_category=10, resolution=16, frame_size=8,
                   oversample=1, raw_events_per_category=1, splits=("test",))
"""One chair in the test split, 16 px: a build of about a second."""


def files(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture
def counted_builds(monkeypatch):
    """Every call of ``build_dataset`` made through ``build_once``, by folder."""
    from e2vlib import data

    calls, real = [], data.build_dataset

    def counting(root, config, **kwargs):
        calls.append(Path(root))
        return real(root, config, **kwargs)

    monkeypatch.setattr(data, "build_dataset", counting)
    return calls


def test_a_cached_build_is_the_same_files_and_is_built_once(tmp_path, monkeypatch,
                                                             counted_builds):
    monkeypatch.setenv("E2V_BUILD_CACHE", "0")
    build_once(tmp_path / "direct", TINY, progress=False)
    monkeypatch.setenv("E2V_BUILD_CACHE", str(tmp_path / "cache"))
    build_once(tmp_path / "first", TINY, progress=False)
    build_once(tmp_path / "second", TINY, progress=False)
    direct = files(tmp_path / "direct")
    assert any(name.startswith("samples/") for name in direct) and "manifest.csv" in direct
    assert files(tmp_path / "first") == direct == files(tmp_path / "second")
    # one build without the cache, one into it; the second call only copies
    partial = tmp_path / "cache" / f"{cache_key(TINY)}.partial"
    assert counted_builds == [tmp_path / "direct", partial]
    assert (tmp_path / "cache" / cache_key(TINY)).is_dir()
    assert not partial.exists()


def test_a_folder_that_holds_a_build_is_finished_in_place(tmp_path, monkeypatch,
                                                          counted_builds):
    monkeypatch.setenv("E2V_BUILD_CACHE", "0")
    folder = tmp_path / "data"
    build_once(folder, TINY, progress=False)
    whole = files(folder)
    sample = next(folder.glob("samples/*.npz"))
    sample.unlink()  # an interrupted build
    monkeypatch.setenv("E2V_BUILD_CACHE", str(tmp_path / "cache"))
    build_once(folder, TINY, progress=False)
    assert counted_builds == [folder, folder]
    assert not (tmp_path / "cache").exists()
    assert files(folder) == whole


def test_the_key_names_every_field_and_the_source(monkeypatch):
    keys = {cache_key(TINY), cache_key(BuildConfig(**{**TINY.__dict__, "noise": "medium"})),
            cache_key(BuildConfig(**{**TINY.__dict__, "grey_video": True}))}
    assert len(keys) == 3
    monkeypatch.setattr(build_cache, "source_digest", lambda: "an edited simulator")
    assert cache_key(TINY) not in keys


def test_the_cache_folder_is_chosen_by_the_environment(monkeypatch, tmp_path):
    monkeypatch.setenv("E2V_BUILD_CACHE", "0")
    assert cache_root() is None
    monkeypatch.setenv("E2V_BUILD_CACHE", str(tmp_path))
    assert cache_root() == tmp_path
    monkeypatch.delenv("E2V_BUILD_CACHE")
    assert cache_root().name == "e2v-build-cache"
