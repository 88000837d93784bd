"""Grey video beside the events (issue 13) and merging sharded builds (issue 15)."""

import json
import shutil

import numpy as np
import pytest

from e2vlib.__main__ import main
from e2vlib.data import (
    BuildConfig,
    E2VDataset,
    build_dataset,
    grey_frame_cameras,
    grey_frame_indices,
    load_grey_video,
    npz_digest,
    plan_samples,
    read_manifest,
    save_sample,
    video_to_grey,
)
from e2vlib.orbit import rendered_times_us
from e2vlib.scale.shards import MergeError, merge_datasets

from .conftest import REPO

# two samples, one per shard; chair_0000 keeps its raw events
GREY = BuildConfig(categories=("chair",), per_category=2, resolution=16, frame_size=8,
                   oversample=1, grey_video=True)


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """``{"whole": unsharded build, "s0", "s1": shards 0/2 and 1/2 in their own folders}``."""
    root = tmp_path_factory.mktemp("shards")
    folders = {"whole": root / "whole", "s0": root / "s0", "s1": root / "s1"}
    build_dataset(folders["whole"], GREY, progress=False)
    build_dataset(folders["s0"], GREY, shard=(0, 2), progress=False)
    build_dataset(folders["s1"], GREY, shard=(1, 2), progress=False)
    return folders


def _files(root):
    return sorted(str(p.relative_to(root)) for kind in ("samples", "events", "grey")
                  for p in (root / kind).glob("*.npz"))


# --- grey video ----------------------------------------------------------------------------


def test_grey_video_is_the_rendered_frame_nearest_each_window_centre(built):
    from e2vlib.render import orbit_cameras, render_orbit
    from e2vlib.shapes import make_shape, normalize_mesh

    root = built["whole"]
    spec = plan_samples(GREY)[1]
    grey = load_grey_video(root, spec.id)
    assert grey.dtype == np.uint8 and grey.shape == (100, 8, 8)
    ds = E2VDataset(root, "train")
    np.testing.assert_array_equal(ds.grey_video(ds.ids.index(spec.id)), grey)

    video, t_us = render_orbit(normalize_mesh(make_shape(spec.category, spec.seed)),
                               resolution=16, oversample=1)
    np.testing.assert_array_equal(t_us, rendered_times_us(oversample=GREY.oversample))
    index = grey_frame_indices(GREY)
    centres = (np.arange(100) + 0.5) * GREY.dt_us
    inside = centres <= t_us[-1]
    assert np.all(np.abs(t_us[index] - centres)[inside] <= 0.5 * 1e6 / 240)
    assert np.all(index[~inside] == len(t_us) - 1)  # windows past the video: last frame
    k = 37
    levels = np.rint(video[index[k]].astype(np.float64) * 255).reshape(8, 2, 8, 2)
    direct = np.floor(levels.mean(axis=(1, 3)) + 0.5)  # area average, rounded half up
    np.testing.assert_array_equal(grey[k], direct.astype(np.uint8))
    np.testing.assert_array_equal(grey, video_to_grey(video, index, 8))
    with np.load(root / "grey" / f"{spec.id}.npz") as stored:
        np.testing.assert_array_equal(stored["frame_index"], index)
        np.testing.assert_array_equal(stored["t_us"], t_us[index])
    cameras = grey_frame_cameras(GREY)
    assert cameras.shape == (100, 3)
    np.testing.assert_array_equal(cameras, orbit_cameras(len(t_us))[index])


def test_grey_video_errors_name_the_fix(built, tmp_path):
    plain = tmp_path / "plain"
    shutil.copytree(built["s0"], plain)
    (plain / "config.json").write_text(json.dumps(
        {k: v for k, v in GREY.to_dict().items() if k != "grey_video"}))
    with pytest.raises(ValueError, match=r"built without --grey-video.*make-data --out "
                                         r".*plain_grey .*--grey-video"):
        load_grey_video(plain, "chair_0000")
    with pytest.raises(ValueError, match="no sample 'chair_0009'"):
        load_grey_video(built["s0"], "chair_0009")
    with pytest.raises(FileNotFoundError, match="not a dataset made by"):
        load_grey_video(tmp_path, "chair_0000")
    broken = tmp_path / "broken"
    shutil.copytree(built["s0"], broken)
    (broken / "grey" / "chair_0000.npz").write_bytes(b"PK\x03\x04 truncated")
    with pytest.raises(ValueError, match="corrupted or truncated grey video"):
        load_grey_video(broken, "chair_0000")
    (broken / "grey" / "chair_0000.npz").unlink()
    with pytest.raises(ValueError, match="grey/chair_0000.npz is missing"):
        load_grey_video(broken, "chair_0000")
    with pytest.raises(ValueError, match="grey_video must be True or False"):
        BuildConfig(categories=("chair",), per_category=2, oversample=1, grey_video="yes")


def test_old_configs_and_manifests_read_unchanged():
    stored = json.loads((REPO / "data_small" / "config.json").read_text())
    config = BuildConfig.from_dict(stored)
    assert config.grey_video is False and config.to_dict() == stored  # no new key
    assert "grey_video" not in BuildConfig(categories=("chair",), per_category=2,
                                           oversample=1).to_dict()
    assert BuildConfig.from_dict(GREY.to_dict()) == GREY
    rows = read_manifest(REPO / "data_small")
    assert set(rows[0]) == {"id", "category", "split", "seed", "n_events", "sha256"}


def test_a_manifest_written_before_the_sha256_column_still_reads(tmp_path):
    lines = (REPO / "data_small" / "manifest.csv").read_text().splitlines()
    old = [",".join(line.split(",")[:5]) for line in lines]  # drop the sha256 column
    (tmp_path / "manifest.csv").write_text("\n".join(old) + "\n")
    rows = read_manifest(tmp_path)
    assert set(rows[0]) == {"id", "category", "split", "seed", "n_events"}
    assert len(rows) == len(lines) - 1


# --- merging shards --------------------------------------------------------------------------


def test_merged_shards_equal_an_unsharded_build(built, tmp_path):
    whole, dest = built["whole"], tmp_path / "merged"
    report = merge_datasets(dest, [built["s0"], built["s1"]])
    assert report.n_samples == 2 and report.linked + report.copied == 5
    assert _files(dest) == _files(whole) == [
        "events/chair_0000.npz", "grey/chair_0000.npz", "grey/chair_0001.npz",
        "samples/chair_0000.npz", "samples/chair_0001.npz"]
    for name in _files(dest):
        # same arrays as the unsharded build (np.savez stamps write times into the zip) ...
        assert npz_digest(dest / name) == npz_digest(whole / name)
        # ... and byte for byte the shard's file
        shard = built["s0"] if "0000" in name else built["s1"]
        assert (dest / name).read_bytes() == (shard / name).read_bytes()
    assert (dest / "config.json").read_text() == (whole / "config.json").read_text()
    assert read_manifest(dest) == read_manifest(whole)
    assert all(len(r["sha256"]) == 64 for r in read_manifest(dest))
    assert not list(dest.rglob("*.tmp*")) and not (dest / "shards").exists()
    # merging again keeps everything; forced copies give the same files
    assert merge_datasets(dest, [built["s0"], built["s1"]]).kept == 5
    copied = merge_datasets(tmp_path / "copied", [built["s0"], built["s1"]], link=False)
    assert copied.copied == 5 and _files(tmp_path / "copied") == _files(whole)


def test_a_missing_shard_is_named_with_its_command(built, tmp_path):
    with pytest.raises(MergeError, match=r"1 of 2 planned samples missing: shard 1/2 is missing "
                                         r"\(no folder given holds it\): 1 sample\(s\) "
                                         r"\(chair_0001\); build them with `python -m e2vlib "
                                         r"make-data --out SHARD_DIR .*--shard 1/2`"):
        merge_datasets(tmp_path / "dest", [built["s0"]])
    assert not (tmp_path / "dest").exists()  # checked before anything is written


def test_mismatched_or_differing_shards_are_refused(built, tmp_path):
    other = tmp_path / "other"
    shutil.copytree(built["s1"], other)
    (other / "config.json").write_text(json.dumps(GREY.to_dict() | {"seed": 5}))
    with pytest.raises(MergeError, match=r"other settings than .*s0 \(different seed\)"):
        merge_datasets(tmp_path / "dest", [built["s0"], other])
    # the same sample with other frames in two shards
    twin = tmp_path / "twin"
    shutil.copytree(built["s0"], twin)
    (twin / "manifest.csv").unlink()
    save_sample(twin / "samples" / "chair_0000.npz", np.zeros((100, 8, 8), np.uint8),
                np.zeros((32, 32, 32), bool), 0)
    with pytest.raises(MergeError, match=r"samples/chair_0000.npz differs between .*s0 and "
                                         r".*twin"):
        merge_datasets(tmp_path / "dest", [built["s0"], built["s1"], twin])
    # a file changed after its manifest recorded its sha256
    shutil.copy(twin / "samples" / "chair_0000.npz", tmp_path / "changed.npz")
    changed = tmp_path / "changed"
    shutil.copytree(built["s0"], changed)
    shutil.copy(tmp_path / "changed.npz", changed / "samples" / "chair_0000.npz")
    with pytest.raises(MergeError, match="does not match the sha256 its manifest recorded"):
        merge_datasets(tmp_path / "dest", [changed, built["s1"]])
    with pytest.raises(MergeError, match="not a dataset folder"):
        merge_datasets(tmp_path / "dest", [built["s0"], tmp_path])
    assert not (tmp_path / "dest").exists()


def test_shards_in_one_shared_folder_verify_in_place(built, tmp_path):
    shared = tmp_path / "shared"  # what two jobs writing into one folder leave behind
    shutil.copytree(built["s0"], shared)
    shutil.copytree(built["s1"], shared, dirs_exist_ok=True)  # manifest: shard 1's only
    report = merge_datasets(shared)
    assert report.kept == 5 and not report.sources
    assert [r["id"] for r in read_manifest(shared)] == ["chair_0000", "chair_0001"]
    (shared / "samples" / "chair_0001.npz").unlink()
    with pytest.raises(MergeError, match=r"shard 1/2 in .*shared is incomplete: 1 sample\(s\) "
                                         r"\(chair_0001\); build them with `.* --out .*shared "
                                         r".*--shard 1/2`"):
        merge_datasets(shared)


def test_merge_data_command_line(built, tmp_path, capsys):
    dest = tmp_path / "merged"
    assert main(["merge-data", "--out", str(dest), str(built["s0"]), str(built["s1"])]) == 0
    assert "merged 2 samples from 2 folder(s)" in capsys.readouterr().out
    assert main(["merge-data", "--out", str(dest)]) == 0
    assert "all 2 planned samples present" in capsys.readouterr().out
    assert main(["merge-data", "--out", str(tmp_path / "half"), str(built["s1"])]) == 1
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "shard 0/2 is missing" in err and "--shard 0/2" in err
