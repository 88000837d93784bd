import dataclasses
import json
from collections import Counter

import numpy as np
import pytest
import torch

from e2vlib.data import (
    BuildConfig,
    E2VDataset,
    build_dataset,
    load_sample,
    mesh_to_sample,
    plan_samples,
    read_manifest,
    save_sample,
    synthevox3d_time_scale,
)

from .conftest import REPO

TINY = BuildConfig(categories=("chair", "table"), per_category=3, resolution=32, frame_size=16,
                   seed=7)


def test_plan_splits_8_1_1_per_category_and_is_deterministic():
    config = BuildConfig(categories=("chair", "lamp"), per_category=10, seed=3)
    specs = plan_samples(config)
    assert len(specs) == 20 and len({s.id for s in specs}) == 20
    for category in ("chair", "lamp"):
        counts = Counter(s.split for s in specs if s.category == category)
        assert counts == {"train": 8, "val": 1, "test": 1}
    assert specs == plan_samples(config)
    other = plan_samples(BuildConfig(categories=("chair", "lamp"), per_category=10, seed=4))
    assert [s.seed for s in other] != [s.seed for s in specs]


def test_sample_file_round_trip_is_bit_exact(tmp_path):
    rng = np.random.default_rng(0)
    frames = (rng.random((100, 16, 16)) < 0.1).astype(np.uint8)
    voxels = rng.random((32, 32, 32)) < 0.2
    save_sample(tmp_path / "s.npz", frames, voxels, n_events=123)
    f2, v2 = load_sample(tmp_path / "s.npz")
    np.testing.assert_array_equal(f2, frames)
    np.testing.assert_array_equal(v2, voxels)
    (tmp_path / "s.npz").write_bytes((tmp_path / "s.npz").read_bytes()[:200])
    with pytest.raises(ValueError, match="s.npz"):
        load_sample(tmp_path / "s.npz")


@pytest.fixture(scope="module")
def tiny_dataset(tmp_path_factory):
    root = tmp_path_factory.mktemp("tiny")
    build_dataset(root, TINY, progress=False)
    return root


def test_build_writes_manifest_samples_and_events(tiny_dataset):
    rows = read_manifest(tiny_dataset)
    assert len(rows) == 6
    # 3 per category: round(0.1 * 3) = 0, but at least one each for val and test
    assert Counter(r["split"] for r in rows) == {"train": 2, "val": 2, "test": 2}
    assert all(r["n_events"] > 100 for r in rows)
    assert len(list((tiny_dataset / "events").glob("*.npz"))) == 2  # one test sample each
    assert json.loads((tiny_dataset / "config.json").read_text())["frame_size"] == 16


def test_dataset_items_follow_the_contract(tiny_dataset):
    ds = E2VDataset(tiny_dataset, "train")
    assert len(ds) == 2 and ds.input_shape == (100, 16, 16)
    item = ds[0]
    assert set(item) == {"frames", "voxels", "category", "id"}
    assert item["frames"].shape == (100, 16, 16) and item["frames"].dtype == torch.float32
    assert item["voxels"].shape == (32, 32, 32) and item["voxels"].dtype == torch.float32
    assert set(torch.unique(item["frames"]).tolist()) <= {0.0, 1.0}
    assert item["frames"].sum() > 0 and item["voxels"].sum() > 0
    assert item["category"] in ("chair", "table") and item["id"].startswith(item["category"])
    with pytest.raises(ValueError, match="split"):
        E2VDataset(tiny_dataset, "validation")


def test_build_is_deterministic_and_resumable(tiny_dataset, tmp_path):
    # a second build of one shard elsewhere gives bit-identical samples
    build_dataset(tmp_path, TINY, shard=(1, 3), progress=False)
    built = sorted(p.name for p in (tmp_path / "samples").glob("*.npz"))
    assert len(built) == 2
    for name in built:
        a, b = load_sample(tmp_path / "samples" / name), load_sample(
            tiny_dataset / "samples" / name)
        np.testing.assert_array_equal(a[0], b[0])
        np.testing.assert_array_equal(a[1], b[1])
    # resuming skips finished samples: their files are not rewritten
    stamps = {p.name: p.stat().st_mtime_ns for p in (tmp_path / "samples").iterdir()}
    build_dataset(tmp_path, TINY, progress=False)
    assert all((tmp_path / "samples" / n).stat().st_mtime_ns == t for n, t in stamps.items())
    assert len(read_manifest(tmp_path)) == 6
    assert not [p for p in tmp_path.rglob("*.tmp*")]


def test_build_refuses_a_folder_with_other_settings(tiny_dataset):
    other = BuildConfig(categories=("chair",), per_category=3, resolution=32, frame_size=16)
    with pytest.raises(ValueError, match="different settings"):
        build_dataset(tiny_dataset, other, progress=False)


def make_synthevox3d(root, n_scans=12):
    rng = np.random.default_rng(0)
    for k in range(n_scans):
        scan = root / "03001627" / f"scan{k:02d}"  # chair
        scan.mkdir(parents=True)
        n = 500
        t = np.sort(rng.uniform(0, 0.5, n))  # seconds, as floats
        table = np.column_stack([t, rng.integers(0, 512, n), rng.integers(0, 512, n),
                                 rng.integers(0, 2, n)]).astype(np.float64)
        table[0] = [0.0123, 100, 200, 1]  # a known event: frame 2, pixel (100, 200)
        table = table[np.argsort(table[:, 0])]
        np.savez(scan / "events.npz", table)
        np.savez(scan / "model_normalized.npz", rng.random((32, 32, 32)) < 0.1)


def test_synthevox3d_layout(tmp_path):
    make_synthevox3d(tmp_path)
    splits = {s: E2VDataset(tmp_path, s, frame_size=64) for s in ("train", "val", "test")
              if _has(tmp_path, s)}
    assert sum(len(d) for d in splits.values()) == 12
    ds = splits["train"]
    frames, voxels = ds.arrays(0)
    assert frames.shape == (100, 64, 64) and voxels.shape == (32, 32, 32)
    assert ds[0]["category"] == "chair"
    # 512 px events max-pooled by 8: the known event lands in frame 2 at (y, x) = (25, 12)
    assert frames[2, 200 // 8, 100 // 8] == 1
    full = E2VDataset(tmp_path, "train")
    assert full.arrays(0)[0].shape == (100, 256, 256)  # the paper's 512 -> 256 by default


def _has(root, split):
    try:
        E2VDataset(root, split)
        return True
    except ValueError:
        return False


def test_time_unit_is_settled_by_the_value_range():
    assert synthevox3d_time_scale(np.array([0.0, 0.499])) == 1e6  # seconds
    assert synthevox3d_time_scale(np.array([0.0, 499.0])) == 1e3  # milliseconds
    assert synthevox3d_time_scale(np.array([0.0, 499_000.0])) == 1.0  # microseconds
    assert synthevox3d_time_scale(np.array([0.0, 4.99e8])) == 1e-3  # nanoseconds


def test_missing_and_foreign_folders(tmp_path):
    with pytest.raises(FileNotFoundError):
        E2VDataset(tmp_path / "nope", "train")
    (tmp_path / "junk").mkdir()
    with pytest.raises(ValueError, match="neither an e2vlib dataset"):
        E2VDataset(tmp_path, "train")


@pytest.mark.slow  # end to end, seconds: runs in make test-all
def test_data_small_regenerates_identically(tmp_path):
    """A slice of the committed data_small/, rebuilt from its config, is bit-identical."""
    root = REPO / "data_small"
    full = BuildConfig.from_dict(json.loads((root / "config.json").read_text()))
    (tmp_path / "config.json").write_text(json.dumps(full.to_dict(), indent=2) + "\n")
    build_dataset(tmp_path, full, shard=(0, 97), progress=False)  # samples 0, 97, 194, ...
    rebuilt = sorted((tmp_path / "samples").glob("*.npz"))
    assert len(rebuilt) >= 3
    for path in rebuilt:
        frames, voxels = load_sample(path)
        committed = load_sample(root / "samples" / path.name)
        np.testing.assert_array_equal(voxels, committed[1])
        np.testing.assert_array_equal(frames, committed[0])


def test_build_config_records_how_frames_are_made():
    config = BuildConfig(categories=("chair",), per_category=2, oversample=3, n_frames=50,
                         dt_us=10_000, windows="paper")
    d = config.to_dict()
    assert (d["n_frames"], d["dt_us"], d["windows"]) == (50, 10_000, "paper")
    assert BuildConfig.from_dict(json.loads(json.dumps(d))) == config
    # configs written before the frame settings existed read as 100 fixed 5 ms windows
    old = {k: v for k, v in d.items() if k not in ("n_frames", "dt_us", "windows")}
    assert BuildConfig.from_dict(old).to_dict() | {"n_frames": 50, "dt_us": 10_000,
                                                  "windows": "paper"} == d
    assert (BuildConfig.from_dict(old).n_frames, BuildConfig.from_dict(old).windows) == (
        100, "fixed")
    with pytest.raises(ValueError, match="unknown build settings"):
        BuildConfig.from_dict(d | {"bogus": 1})


def test_data_small_records_its_frame_grouping():
    stored = json.loads((REPO / "data_small" / "config.json").read_text())
    assert (stored["n_frames"], stored["dt_us"], stored["windows"]) == (100, 5000, "fixed")
    assert E2VDataset(REPO / "data_small", "test").config["windows"] == "fixed"


@pytest.mark.parametrize("change, problem", [
    ({"oversample": 0}, "oversample"), ({"per_category": 0}, "per_category"),
    ({"categories": ()}, "categories"), ({"categories": ("bogus",)}, "bogus"),
    ({"windows": "clock"}, "windows"), ({"dt_us": -1}, "dt_us"), ({"contrast": 0.0}, "contrast"),
    ({"frame_size": 0}, "frame_size"), ({"anti_aliasing": "fxaa"}, "anti_aliasing"),
])
def test_build_config_refuses_bad_settings_by_name(change, problem):
    settings = {"categories": ("chair",), "per_category": 2, "oversample": 3} | change
    with pytest.raises(ValueError, match=problem):
        BuildConfig(**settings)


def test_a_paper_windows_build_stores_eq5_frames(tmp_path):
    from e2vlib.inputs import orbit_input
    from e2vlib.io import load_events

    config = BuildConfig(categories=("chair",), per_category=3, resolution=32, frame_size=16,
                         oversample=1, windows="paper", n_frames=100)
    build_dataset(tmp_path, config, progress=False)
    ds = E2VDataset(tmp_path, "test")
    assert ds.config["windows"] == "paper"
    events, sensor = load_events(ds.raw_events_path(0))
    expected = orbit_input(events, sensor, 16, t0_us=0, windows="paper")
    np.testing.assert_array_equal(ds.arrays(0)[0], expected)
    assert ds.arrays(0)[0][: int(expected.any(axis=(1, 2)).sum())].any(axis=(1, 2)).all()


def test_anti_aliasing_is_a_build_setting_that_old_configs_read_as_ssaa():
    from e2vlib.render import render_orbit
    from e2vlib.shapes import make_shape, normalize_mesh
    from e2vlib.simulate import simulate_events

    stored = json.loads((REPO / "data_small" / "config.json").read_text())
    assert "anti_aliasing" not in stored  # written only when not the default
    assert BuildConfig.from_dict(stored).anti_aliasing == "ssaa"
    config = BuildConfig(categories=("chair",), per_category=3, resolution=32, frame_size=16,
                         oversample=2, anti_aliasing="none")
    assert config.to_dict()["anti_aliasing"] == "none"
    assert BuildConfig.from_dict(json.loads(json.dumps(config.to_dict()))) == config
    # the sample is made from the un-anti-aliased render: the same voxels, other events
    mesh = make_shape("chair", 0)
    fast = mesh_to_sample(mesh, config, seed=1)
    smooth = mesh_to_sample(mesh, dataclasses.replace(config, anti_aliasing="ssaa"), seed=1)
    np.testing.assert_array_equal(fast.voxels, smooth.voxels)
    video, t_us = render_orbit(normalize_mesh(mesh), 120, 240, 32, oversample=2,
                               anti_aliasing="none")
    events = simulate_events(video, t_us, contrast_pos=0.2, contrast_neg=0.2, seed=1)
    np.testing.assert_array_equal(fast.events, events)
    assert not np.array_equal(fast.frames, smooth.frames)


def test_run_jobs_gives_the_same_answers_in_this_process_and_in_workers():
    from e2vlib.data.build import run_jobs

    jobs = ["3", "1", "4", "1", "5"]
    one = run_jobs(int, jobs, workers=1, desc="parsing", unit="number", progress=False)
    two = run_jobs(int, jobs, workers=2, desc="parsing", unit="number", progress=False)
    assert one == two == [3, 1, 4, 1, 5]  # in job order, whichever worker finished first
    assert run_jobs(int, [], workers=2, desc="parsing", unit="number", progress=False) == []


@pytest.mark.parametrize("workers", [1, 2])
def test_run_jobs_names_the_failing_job(workers):
    from e2vlib.data.build import JobError, run_jobs

    with pytest.raises(JobError, match=r"^sample chair_0002 failed: ValueError: invalid "
                                       r"literal for int\(\) with base 10: 'x'$"):
        run_jobs(int, ["1", "x"], workers, "parsing", "sample", False,
                 names=["sample chair_0001", "sample chair_0002"])
    with pytest.raises(ValueError, match="2 jobs but 1 names"):
        run_jobs(int, ["1", "2"], workers, "parsing", "sample", False, names=["one"])


def test_frame_settings_fill_in_older_configs_and_refuse_malformed_values():
    from e2vlib.data.config import frame_settings

    assert frame_settings({"frame_size": 64}) == {  # missing keys: the defaults of old builds
        "n_frames": 100, "dt_us": 5000, "windows": "fixed", "frame_size": 64}
    assert frame_settings({}) == {
        "n_frames": 100, "dt_us": 5000, "windows": "fixed", "frame_size": None}
    assert frame_settings({"n_frames": np.int64(20), "frame_size": None}) == {
        "n_frames": 20, "dt_us": 5000, "windows": "fixed", "frame_size": None}
    assert type(frame_settings({"n_frames": np.int64(20)})["n_frames"]) is int
    for bad, problem in [({"n_frames": "20"}, r"n_frames must be a whole number >= 1, got '20' "
                                              r"\(str\); write it as a number"),
                         ({"n_frames": None}, r"n_frames .* got None .* default 100"),
                         ({"dt_us": 0}, r"dt_us .* got 0"),
                         ({"dt_us": True}, r"dt_us .* got True"),
                         ({"frame_size": 64.0}, r"frame_size .* got 64.0 \(float\).* if unknown"),
                         ({"windows": None}, r"windows must be one of fixed, paper, got None"),
                         ({"windows": "Fixed"}, r"windows must be one of .*'Fixed'")]:
        with pytest.raises(ValueError, match=problem):
            frame_settings(bad)
