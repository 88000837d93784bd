"""A dataset folder is untrusted input (issue 26): reads stay inside the folder, sample files
are checked against config.json, the manifest and config.json are validated, every error
names the file and the fix; a killed build resumes into a verified dataset."""

from __future__ import annotations

import contextlib
import csv
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import textwrap
import time
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from e2vlib.data import (
    BuildConfig,
    DatasetError,
    E2VDataset,
    build_dataset,
    check_build_folder,
    describe_build,
    load_grey_video,
    load_sample,
    read_manifest,
    save_sample,
    verify_dataset,
)

from .conftest import REPO

TINY = BuildConfig(categories=("chair", "table"), per_category=3, resolution=32, frame_size=16,
                   seed=7)


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    root = tmp_path_factory.mktemp("hardening") / "data"
    build_dataset(root, TINY, progress=False)
    return root


@pytest.fixture
def data(built, tmp_path):
    """A fresh copy of the built dataset to damage."""
    return Path(shutil.copytree(built, tmp_path / "data"))


def _rows(root: Path) -> list[dict]:
    with open(root / "manifest.csv", newline="") as f:
        return list(csv.DictReader(f))


def _write_rows(root: Path, rows: list[dict], fields=None) -> None:
    fields = fields or list(rows[0])
    with open(root / "manifest.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=fields)
        writer.writeheader()
        writer.writerows(rows)


def _train_ids(root: Path) -> list[str]:
    return [r["id"] for r in _rows(root) if r["split"] == "train"]


# --- reads outside the root ---------------------------------------------------------------


@pytest.mark.parametrize("bad_id", ["../../../x", "/etc/passwd", "samples/../x", "a/b", "..",
                                    ".hidden", "a\\b", "", "x" * 129])
def test_ids_that_are_not_plain_file_names_are_refused(data, bad_id):
    rows = _rows(data)
    rows[1]["id"] = bad_id
    _write_rows(data, rows)
    with pytest.raises(DatasetError, match=r"manifest.csv line 3: sample id .* is not a plain "
                                           r"file name"):
        E2VDataset(data, "train")


def test_a_row_pointing_outside_would_have_served_a_foreign_file(data, tmp_path):
    # the attack: a valid sample file outside the dataset, reached by ../
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    shutil.copy(data / "samples" / f"{_train_ids(data)[0]}.npz", outside / "x.npz")
    rows = _rows(data)
    rows[0]["id"] = "../../elsewhere/x"
    _write_rows(data, rows)
    with pytest.raises(DatasetError, match="not a plain file name"):
        E2VDataset(data, rows[0]["split"])


def test_sample_files_linked_outside_the_root_are_refused(data, tmp_path):
    sample_id = _train_ids(data)[0]
    target = data / "samples" / f"{sample_id}.npz"
    foreign = tmp_path / "foreign.npz"
    shutil.move(target, foreign)
    target.symlink_to(foreign)
    dataset = E2VDataset(data, "train")
    index = dataset.ids.index(sample_id)
    with pytest.raises(DatasetError, match=f"{target} points outside the dataset {data} "
                                           f"\\(to {foreign}\\)"):
        dataset[index]
    # a link that stays inside the folder is fine: it reads the same arrays
    inside = data / "samples" / "kept.npz"
    shutil.move(foreign, inside)
    target.unlink()
    target.symlink_to(inside)
    frames = dataset[index]["frames"]
    np.testing.assert_array_equal(frames.numpy(), load_sample(inside)[0])


def test_a_linked_samples_folder_is_refused_too(data, tmp_path):
    moved = tmp_path / "moved_samples"
    shutil.move(data / "samples", moved)
    (data / "samples").symlink_to(moved, target_is_directory=True)
    with pytest.raises(DatasetError, match="points outside the dataset"):
        E2VDataset(data, "train")[0]


def test_raw_events_linked_outside_are_refused(data, tmp_path):
    dataset = E2VDataset(data, "test")
    index = next(i for i in range(len(dataset)) if dataset.raw_events_path(i) is not None)
    path = dataset.raw_events_path(index)
    shutil.move(path, tmp_path / "ev.npz")
    path.symlink_to(tmp_path / "ev.npz")
    with pytest.raises(DatasetError, match="points outside the dataset"):
        dataset.raw_events_path(index)


def test_grey_video_reads_and_names_only_files_inside_the_root(tmp_path):
    root = tmp_path / "grey"
    config = BuildConfig(categories=("chair",), per_category=1, resolution=16, frame_size=8,
                         grey_video=True, n_frames=10)
    build_dataset(root, config, progress=False)
    with pytest.raises(DatasetError, match="not a plain file name"):
        load_grey_video(root, "../../etc/passwd")
    grey = root / "grey" / "chair_0000.npz"
    outside = tmp_path / "outside.npz"
    shutil.move(grey, outside)
    grey.symlink_to(outside)
    with pytest.raises(DatasetError, match="points outside the dataset"):
        load_grey_video(root, "chair_0000")
    grey.unlink()
    # the file to delete, named in the message, is the dataset's own sample file
    with pytest.raises(ValueError, match=f"is missing; delete {root / 'samples'}/"
                                         "chair_0000.npz and finish the build"):
        load_grey_video(root, "chair_0000")


def test_synthevox3d_scans_linked_outside_are_refused(tmp_path):
    from .test_data import make_synthevox3d

    root = tmp_path / "release"
    make_synthevox3d(root, n_scans=4)
    dataset = E2VDataset(root, "train", frame_size=64)
    scan = dataset.items[0][2]
    shutil.move(scan / "events.npz", tmp_path / "events.npz")
    (scan / "events.npz").symlink_to(tmp_path / "events.npz")
    with pytest.raises(DatasetError, match="events.npz points outside the dataset"):
        dataset[0]
    assert tuple(dataset[1]["frames"].shape) == (100, 64, 64)  # the others still load


# --- sample files checked against config.json and the manifest -----------------------------


def _replace_sample(root: Path, frames_shape, voxels_shape=(32, 32, 32)) -> str:
    sample_id = _train_ids(root)[0]
    rng = np.random.default_rng(1)
    save_sample(root / "samples" / f"{sample_id}.npz",
                (rng.random(frames_shape) < 0.5).astype(np.uint8),
                rng.random(voxels_shape) < 0.5, 10)
    return sample_id


@pytest.mark.parametrize("frames_shape, voxels_shape", [
    ((5, 16, 16), (32, 32, 32)), ((100, 64, 64), (32, 32, 32)), ((20, 64, 64), (32, 32, 32)),
    ((100, 16, 16), (16, 16, 16))])
def test_samples_of_other_shapes_are_refused_on_load(data, frames_shape, voxels_shape):
    sample_id = _replace_sample(data, frames_shape, voxels_shape)
    dataset = E2VDataset(data, "train")
    which = "frames" if frames_shape != (100, 16, 16) else "voxels"
    shown = frames_shape if which == "frames" else voxels_shape
    with pytest.raises(DatasetError, match=rf"{sample_id}.npz: {which} of shape "
                                           rf"\({', '.join(map(str, shown))}\), but the "
                                           r"dataset's config.json makes"):
        dataset[dataset.ids.index(sample_id)]
    # the other samples still load, with the configured shapes
    other = next(i for i, s in enumerate(dataset.ids) if s != sample_id)
    assert tuple(dataset[other]["frames"].shape) == (100, 16, 16)


def _raw_sample(path: Path, **arrays) -> None:
    with open(path, "wb") as f:
        np.savez(f, **arrays)


def test_a_packed_array_shorter_than_its_shape_is_refused_not_zero_padded(tmp_path):
    frames = np.ones((100, 16, 16), np.uint8)
    path = tmp_path / "short.npz"
    _raw_sample(path, frames=np.packbits(frames)[:-4], frames_shape=np.array([100, 16, 16]),
                voxels=np.packbits(np.ones(32 ** 3, bool)), voxels_shape=np.array([32, 32, 32]),
                n_events=np.int64(1))
    with pytest.raises(DatasetError, match=r"short.npz: frames holds uint8 \(3196,\), not the "
                                           r"3200 packed bytes"):
        load_sample(path)


def test_a_tiny_file_declaring_a_huge_shape_is_refused_before_allocating(tmp_path):
    path = tmp_path / "bomb.npz"
    _raw_sample(path, frames=np.zeros(8, np.uint8), frames_shape=np.array([4000, 1000, 1000]),
                voxels=np.zeros(4096, np.uint8), voxels_shape=np.array([32, 32, 32]),
                n_events=np.int64(1))
    tracemalloc.start()
    try:
        with pytest.raises(DatasetError, match=r"bomb.npz: frames_shape \[4000, 1000, 1000\] "
                                               r"holds more than"):
            load_sample(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 5 * 2**20  # megabytes, not the 3.7 GiB the shape asks for
    # within the bound but not matching the file: refused by the packed length, unread
    _raw_sample(path, frames=np.zeros(8, np.uint8), frames_shape=np.array([100, 1000, 1000]),
                voxels=np.zeros(4096, np.uint8), voxels_shape=np.array([32, 32, 32]),
                n_events=np.int64(1))
    with pytest.raises(DatasetError, match="frames holds uint8 \\(8,\\), not the 12500000"):
        load_sample(path)


@pytest.mark.parametrize("content, says", [
    (os.urandom(300), "corrupted or truncated sample file"),
    (b"", "corrupted or truncated sample file"),
])
def test_garbage_sample_files_name_the_file(data, content, says):
    sample_id = _train_ids(data)[0]
    path = data / "samples" / f"{sample_id}.npz"
    path.write_bytes(content)
    dataset = E2VDataset(data, "train")
    with pytest.raises(DatasetError, match=f"{path}: {says}") as info:
        dataset[dataset.ids.index(sample_id)]
    assert "allow_pickle" not in str(info.value)  # no advice to load it unsafely


def test_a_single_npy_array_named_npz_is_refused(tmp_path):
    path = tmp_path / "one.npz"
    with open(path, "wb") as f:
        np.save(f, np.zeros(3))
    with pytest.raises(DatasetError, match="one.npz is a single .npy array"):
        load_sample(path)


def test_a_listed_sample_missing_on_disk_names_it_and_the_rebuild(data):
    sample_id = _train_ids(data)[0]
    (data / "samples" / f"{sample_id}.npz").unlink()
    dataset = E2VDataset(data, "train")
    with pytest.raises(DatasetError, match=rf"sample '{sample_id}' listed in "
                                           rf"{data / 'manifest.csv'} is missing on disk .*"
                                           rf"make-data --out {data}"):
        dataset[dataset.ids.index(sample_id)]


def test_verify_checks_the_manifest_sha256(data, built):
    assert len(E2VDataset(built, "train", verify=True)) == 2
    sample_id = _replace_sample(data, (100, 16, 16))  # right shapes, other arrays
    E2VDataset(data, "train")[0]  # the default checks shapes only: this loads
    with pytest.raises(DatasetError, match=rf"1 of 2 train samples .* are bad: .*{sample_id}"
                                           r".npz does not match the sha256 its manifest "
                                           r"recorded"):
        E2VDataset(data, "train", verify=True)
    checked, problems, _ = verify_dataset(data)
    assert checked == 6 and len(problems) == 1 and sample_id in problems[0]
    assert verify_dataset(built) == (6, [], 0)


def test_verify_names_every_bad_sample(data):
    ids = [r["id"] for r in _rows(data)]
    (data / "samples" / f"{ids[0]}.npz").unlink()
    (data / "samples" / f"{ids[3]}.npz").write_bytes(b"junk")
    checked, problems, _ = verify_dataset(data)
    assert checked == 6 and len(problems) == 2
    assert any(f"'{ids[0]}'" in p and "missing on disk" in p for p in problems)
    assert any(f"{ids[3]}.npz: corrupted" in p for p in problems)


def test_verify_needs_the_sha256_column(data):
    rows = _rows(data)
    for row in rows:
        del row["sha256"]
    _write_rows(data, rows)
    assert len(E2VDataset(data, "train")) == 2  # older manifests read as before
    with pytest.raises(DatasetError, match=r"records no sha256 for 2 of 2 train samples \(an "
                                           r"older build\), so verify=True cannot check them; "
                                           rf"record them with `python -m e2vlib make-data "
                                           rf"--out {data} --categories chair,table"):
        E2VDataset(data, "train", verify=True)
    # verify_dataset checks what it can (shapes) and counts what it could not
    assert verify_dataset(data) == (6, [], 6)
    build_dataset(data, TINY, progress=False)  # the command named: records the digests
    assert verify_dataset(data) == (6, [], 0)


# --- config.json values -----------------------------------------------------------------------


@pytest.mark.parametrize("change, says", [
    ({"n_frames": -5}, r"n_frames must be a whole number >= 1, got -5 \(int\)"),
    ({"frame_size": "16"}, r"frame_size must be a whole number >= 1 at most 32768, got '16' "
                           r"\(str\)"),
    ({"frame_size": None}, r"frame_size must be a whole number >= 1 at most 32768, got None"),
    ({"dt_us": 2.5}, r"dt_us must be a whole number >= 1, got 2.5"),
    ({"n_frames": True}, r"n_frames must be a whole number >= 1, got True"),
    ({"windows": "Fixed"}, r"windows must be one of fixed, paper, got 'Fixed'"),
    ({"categories": ["dragon"]}, r"categories must be a list of some of"),
    ({"contrast": -1}, r"invalid build settings \(contrast must be a positive number"),
    ({"n_frames": 10_000, "frame_size": 2048}, r"10000 frames of 2048 px are 41943040000 "
                                               r"values per sample, more than the 1073741824"),
])
def test_config_values_are_checked_on_read(data, change, says):
    config = json.loads((data / "config.json").read_text())
    (data / "config.json").write_text(json.dumps({**config, **change}))
    with pytest.raises(DatasetError, match=f"{data / 'config.json'}: {says}"):
        E2VDataset(data, "train")


@pytest.mark.parametrize("text, says", [
    ("{not json", "is not valid JSON"), ("[1, 2]", "holds a JSON list, not an object"),
    ("null", "holds a JSON NoneType"), ('{"resolution": 32}', "has no frame_size"),
    ("\xff\xfe", "is not a text config"),
])
def test_config_garbage_names_the_file_and_the_fix(data, text, says):
    (data / "config.json").write_bytes(text.encode("latin-1"))
    with pytest.raises(DatasetError, match=says) as info:
        E2VDataset(data, "train")
    assert str(data / "config.json") in str(info.value) and "rebuild" in str(info.value)


def test_a_folder_with_config_but_no_manifest_is_not_read_as_synthevox3d(data):
    (data / "manifest.csv").unlink()  # a build stopped before it wrote the manifest
    with pytest.raises(DatasetError, match=r"config.json but no manifest.csv.*rerun"):
        E2VDataset(data, "train")


def test_a_missing_config_names_the_file(data):
    (data / "config.json").unlink()
    with pytest.raises(DatasetError, match=f"{data / 'config.json'} is missing: .*rebuild"):
        E2VDataset(data, "train")
    (data / "config.json").mkdir()
    with pytest.raises(DatasetError, match=f"{data / 'config.json'} is a folder, not a config"):
        E2VDataset(data, "train")


# --- manifest rows ------------------------------------------------------------------------------


def test_an_unknown_split_is_an_error_naming_the_row(data):
    rows = _rows(data)
    rows[2]["split"] = "TRAIN"
    _write_rows(data, rows)
    with pytest.raises(DatasetError, match=rf"line 4 \(sample '{rows[2]['id']}'\): split "
                                           r"'TRAIN' is not one of train, val, test"):
        E2VDataset(data, "test")


def test_a_duplicated_row_is_an_error(data):
    rows = _rows(data)
    _write_rows(data, rows + [rows[0]])
    with pytest.raises(DatasetError, match=rf"line 8 \(sample '{rows[0]['id']}'\): the id is "
                                           r"listed twice \(also on line 2\)"):
        read_manifest(data)


def test_an_unknown_category_is_an_error(data):
    rows = _rows(data)
    rows[0]["category"] = "dragon"
    _write_rows(data, rows)
    with pytest.raises(DatasetError, match="category 'dragon' is not one of the paper's 13"):
        E2VDataset(data, "train")
    rows[0]["category"] = "lamp"  # a paper category, but not one this dataset was built with
    _write_rows(data, rows)
    with pytest.raises(DatasetError, match=r"is a lamp, which config.json's categories "
                                           r"\(chair, table\) do not include"):
        E2VDataset(data, "train")


@pytest.mark.parametrize("edit, says", [
    (lambda text: text.replace("id,", "name,", 1), r"the header lacks the column\(s\) id"),
    (lambda text: text.splitlines()[0] + "\nchair_0000,chair,train\n", r"line 2: 6 fields "
                                                                         r"expected"),
    (lambda text: text.splitlines()[0] + "\nchair_0000,chair,train,1,2,,extra\n",
     r"line 2: 6 fields expected"),
    (lambda text: text.splitlines()[0] + "\nchair_0000,chair,train,-1,2,\n",
     r"seed must be a whole number >= 0, got '-1'"),
    (lambda text: text.splitlines()[0] + "\nchair_0000,chair,train,1,2,abc\n",
     r"sha256 'abc' is not 64 hex digits"),
    (lambda text: "\x00\x01\x02PK" + text, "holds NUL bytes"),
    (lambda text: "", r"the header lacks the column\(s\) id, category"),
])
def test_bad_manifests_name_the_file_and_the_row(data, edit, says):
    path = data / "manifest.csv"
    path.write_text(edit(path.read_text()))
    with pytest.raises(DatasetError, match=says) as info:
        E2VDataset(data, "train")
    assert str(path) in str(info.value)


def test_a_bad_seed_names_the_row(data):
    rows = _rows(data)
    rows[0]["seed"] = "seven"
    _write_rows(data, rows)
    with pytest.raises(DatasetError, match=rf"manifest.csv line 2 \(sample '{rows[0]['id']}'\):"
                                           r" seed must be a whole number >= 0, got 'seven'"):
        E2VDataset(data, "train")


def test_binary_manifests_name_the_file(data):
    (data / "manifest.csv").write_bytes(b"id,category\n\xff\xfe\x00\x81")
    with pytest.raises(DatasetError, match=r"manifest.csv is not a text manifest \(binary "
                                           r"content at byte 12\)"):
        E2VDataset(data, "train")


def test_a_manifest_without_samples_gives_no_dataset(data):
    (data / "manifest.csv").write_text("id,category,split,seed,n_events,sha256\n")
    with pytest.raises(DatasetError, match="no samples in split 'train'"):
        E2VDataset(data, "train")
    with pytest.raises(DatasetError, match="lists no samples"):
        verify_dataset(data)


# --- mixed shapes in training: the sample is named, not "stack expects ..." -----------------------


def test_training_on_mixed_shapes_names_the_sample(data, capsys, tmp_path):
    from e2vlib.__main__ import main

    sample_id = _replace_sample(data, (100, 8, 8))
    code = main(["train", "--data", str(data), "--out", str(tmp_path / "run"), "--epochs", "1",
                 "--device", "cpu", "--batch-size", "2"])
    err = capsys.readouterr().err
    assert code == 1 and f"{sample_id}.npz: frames of shape (100, 8, 8)" in err
    assert "stack expects" not in err


# --- the property: random manifests and config files load consistent items or raise one error ----

GOOD_IDS = [f"{c}_{k:04d}" for c in ("chair", "lamp") for k in range(4)]
BAD_CONFIG = {  # a value config.json must not hold, per key
    "frame_size": [0, -4, "4", None, 4.0, True, 2 ** 40, "<absent>"],
    "n_frames": [0, -5, "3", None, 1.5],
    "windows": ["FIXED", 3, None],
    "categories": [["dragon"], [], "chair", ["chair", 1]],
}
BAD_TEXT = ["[1]", "{", "null", "", '"frame_size"']
BAD_ROW = {  # a value a manifest row must not hold, per column
    0: ["../x", "/abs", "a/b", ".x", "", "..", "chair_0000/../../x"],
    1: ["dragon", "", "CHAIR", "table"],  # table: a paper category, not in this dataset
    2: ["TRAIN", "", "dev", "Test"],
    3: ["-1", "x", "1e3", "", "1.5"],
    4: ["-1", "x", "1e3", "", "1.5"],
}
FILES = ["good", "good", "good", "good", "shape", "short", "garbage", "missing", "bomb"]


def _write_file(path: Path, kind: str) -> None:
    rng = np.random.default_rng(len(kind))
    if kind == "missing":
        return
    if kind == "garbage":
        path.write_bytes(rng.bytes(64))
        return
    frames = (rng.random((3, 4, 4)) < 0.5).astype(np.uint8)
    voxels = rng.random((32, 32, 32)) < 0.5
    if kind == "good":
        save_sample(path, frames, voxels, 5)
    elif kind == "shape":
        save_sample(path, np.ones((3, 8, 8), np.uint8), voxels, 5)
    else:
        shape = [3, 4, 4] if kind == "short" else [10 ** 4, 10 ** 4, 10 ** 4]
        _raw_sample(path, frames=np.packbits(frames)[:-1], frames_shape=np.array(shape),
                    voxels=np.packbits(voxels), voxels_shape=np.array([32, 32, 32]),
                    n_events=np.int64(5))


@st.composite
def dataset_folders(draw):
    """``(config.json text, manifest rows + file kind, broken)``: a sound folder, with up to
    two things broken (``broken`` says whether any was)."""
    config = {"frame_size": 4, "n_frames": 3, "resolution": 8,
              "windows": draw(st.sampled_from(["fixed", "paper"])),
              "categories": ["chair", "lamp"]}
    if draw(st.booleans()):
        del config["categories"]  # older configs have none
    ids = draw(st.lists(st.sampled_from(GOOD_IDS), max_size=5, unique=True))
    rows = [[sample_id, sample_id.split("_")[0], draw(st.sampled_from(["train", "val", "test"])),
             str(draw(st.integers(0, 2**31))), str(draw(st.integers(0, 10**6))),
             draw(st.sampled_from(FILES))] for sample_id in ids]
    broken = False
    for what in draw(st.lists(st.sampled_from(["config", "text", "row", "twice"]), max_size=2)):
        if what == "config":
            key = draw(st.sampled_from(sorted(BAD_CONFIG)))
            value = draw(st.sampled_from(BAD_CONFIG[key]))
            if value == "<absent>":
                config.pop(key)
            else:
                config[key] = value
            broken = True
        elif what == "text":
            return draw(st.sampled_from(BAD_TEXT)), rows, True
        elif rows and what == "row":
            row, column = draw(st.sampled_from(rows)), draw(st.sampled_from(sorted(BAD_ROW)))
            row[column] = draw(st.sampled_from(BAD_ROW[column]))
            # "table" is only wrong where config.json lists the categories
            broken = broken or not (row[column] == "table" and "categories" not in config)
        elif rows and what == "twice":
            rows.append(list(draw(st.sampled_from(rows))))
            broken = True
    return json.dumps(config), rows, broken


@given(dataset_folders())
def test_random_folders_load_consistent_items_or_raise_dataset_error(folder):
    config_text, rows, broken = folder
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        (root / "samples").mkdir()
        (root / "config.json").write_text(config_text)
        lines = ["id,category,split,seed,n_events"] + [",".join(r[:5]) for r in rows]
        (root / "manifest.csv").write_text("\n".join(lines) + "\n")
        for row in rows:
            if row[0] in GOOD_IDS:
                _write_file(root / "samples" / f"{row[0]}.npz", row[5])
        folder_ok = not broken
        for split in ("train", "val", "test"):
            mine = [r for r in rows if r[2] == split]
            try:
                dataset = E2VDataset(root, split)
            except DatasetError:
                assert not (folder_ok and mine), "a valid folder was refused"
                continue
            assert folder_ok and mine, "an invalid folder was accepted"
            assert dataset.ids == [r[0] for r in mine]
            assert dataset.input_shape == (3, 4, 4)
            for i, row in enumerate(mine):
                try:
                    item = dataset[i]
                except DatasetError:
                    assert row[5] != "good", f"a good sample was refused: {row}"
                    continue
                assert row[5] == "good", f"a {row[5]} sample file loaded"
                assert tuple(item["frames"].shape) == (3, 4, 4)
                assert tuple(item["voxels"].shape) == (32, 32, 32)
                assert set(item["frames"].unique().tolist()) <= {0.0, 1.0}
                assert (item["id"], item["category"]) == (row[0], row[1])


# --- folder rules -------------------------------------------------------------------------------


def test_make_data_refuses_a_folder_of_unrelated_files(tmp_path):
    folder = tmp_path / "photos"
    folder.mkdir()
    (folder / "holiday.jpg").write_bytes(b"\xff\xd8")
    with pytest.raises(DatasetError, match=r"photos exists and is not a dataset \(no "
                                           r"config.json; it holds holiday.jpg\)"):
        build_dataset(folder, TINY, progress=False)
    assert sorted(p.name for p in folder.iterdir()) == ["holiday.jpg"]  # nothing written
    # a folder a killed build left before writing config.json is resumed
    (folder / "holiday.jpg").unlink()
    (folder / "samples").mkdir()
    check_build_folder(folder, TINY)
    assert describe_build(folder, TINY).startswith("plan: 6 samples (2 categories x 3 objects")


def test_a_dataset_folder_with_garbage_config_is_refused_by_name(built, tmp_path):
    folder = Path(shutil.copytree(built, tmp_path / "d"))
    (folder / "config.json").write_text("[]")
    with pytest.raises(DatasetError, match="config.json holds no valid build settings"):
        build_dataset(folder, TINY, progress=False)


# --- a build killed mid-sample, then resumed ------------------------------------------------------

KILLED_BUILD = textwrap.dedent("""
    import sys, time
    from pathlib import Path
    import e2vlib.data.build as data

    real, calls = data.save_sample, []

    def slow_save(path, frames, voxels, n_events):
        calls.append(path)
        if len(calls) == 3:  # the third sample: half written, then the process is killed
            with data.atomic_path(path) as tmp:
                tmp.write_bytes(b"PK\\x03\\x04 half a sample")
                Path(sys.argv[2]).write_text(str(path))
                time.sleep(300)
        real(path, frames, voxels, n_events)

    data.save_sample = slow_save
    from e2vlib.__main__ import main
    sys.exit(main(["make-data", "--out", sys.argv[1], "--categories", "chair,table",
                   "--per-category", "3", "--resolution", "32", "--frame-size", "16",
                   "--seed", "7"]))
""")


@pytest.mark.slow  # end to end, seconds: runs in make test-all
def test_a_build_killed_mid_sample_resumes_into_a_verified_dataset(built, tmp_path):
    root, marker = tmp_path / "killed", tmp_path / "marker"
    process = subprocess.Popen([sys.executable, "-c", KILLED_BUILD, str(root), str(marker)],
                               cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    try:
        deadline = time.monotonic() + 240
        while not marker.exists():
            assert process.poll() is None, process.stdout.read().decode()[-2000:]
            assert time.monotonic() < deadline, "the build never reached its third sample"
            time.sleep(0.2)
    finally:
        process.send_signal(signal.SIGKILL)
        process.wait()
    out = process.stdout.read().decode()
    assert "plan: 6 samples (2 categories x 3 objects" in out  # printed before the work
    half = Path(marker.read_text())
    assert not half.exists() and len(list(half.parent.glob(f".{half.name}.*.tmp*"))) == 1
    whole = [p.name for p in (root / "samples").glob("*.npz") if not p.name.startswith(".")]
    assert len(whole) == 2  # two whole samples, no third
    build_dataset(root, TINY, progress=False)  # the rerun
    assert not list(root.rglob("*.tmp*"))  # the killed run's temporary file is gone
    assert verify_dataset(root) == (6, [], 0)
    digests = {r["id"]: r["sha256"] for r in read_manifest(root)}
    assert digests == {r["id"]: r["sha256"] for r in read_manifest(built)}


# --- read-only dataset folders, for real (as root too) ------------------------------------------


@contextlib.contextmanager
def read_only_view(folder: Path, view: Path):
    """``view``: a read-only bind mount of ``folder``. Root may write into a folder whatever
    its permission bits, but not into a read-only mount."""
    view.mkdir()
    try:
        subprocess.run(["mount", "--bind", str(folder), str(view)], check=True,
                       capture_output=True)
    except (OSError, subprocess.CalledProcessError) as err:
        pytest.skip(f"needs a read-only bind mount (root with CAP_SYS_ADMIN): {err}")
    try:
        subprocess.run(["mount", "-o", "remount,bind,ro", str(view)], check=True,
                       capture_output=True)
        yield view
    finally:
        subprocess.run(["umount", str(view)], check=False, capture_output=True)


def test_reading_and_verifying_never_write_into_the_dataset(built, tmp_path, capsys):
    from e2vlib.__main__ import main

    with read_only_view(built, tmp_path / "ro") as view:
        with pytest.raises(OSError):
            (view / "probe").write_text("x")  # the view really is read-only, for root too
        dataset = E2VDataset(view, "train", verify=True)
        assert tuple(dataset[0]["frames"].shape) == (100, 16, 16)
        assert main(["verify-data", "--data", str(view)]) == 0
        assert f"verified {view}: all 6 samples" in capsys.readouterr().out
        code = main(["make-data", "--out", str(view / "more"), "--categories", "chair",
                     "--per-category", "3", "--resolution", "32", "--frame-size", "16"])
        assert code == 2 and "(permission denied or read-only)" in capsys.readouterr().err


def test_the_shipped_data_small_verifies_with_every_sha256():
    """data_small's manifest records a sha256 per sample, and every file matches it."""
    from e2vlib.data import verify_dataset

    from .conftest import REPO

    found = verify_dataset(REPO / "data_small")
    assert (found.checked, found.problems, found.unhashed) == (832, [], 0)
