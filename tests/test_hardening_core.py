"""Hardening of core against hostile files (issue 39): size bombs refused before anything
is allocated, silent casts and wrong answers refused, and paths that are not files named
for what they are. One test per case; known answers, no timing."""

import io
import os
import zipfile
from pathlib import Path

import h5py
import numpy as np
import pytest
import torch
import trimesh

from e2vlib import io as event_io
from e2vlib import voxels
from e2vlib.data import BuildConfig
from e2vlib.data.config import frame_settings
from e2vlib.events import make_events
from e2vlib.io import load_events, save_events
from e2vlib.model import (
    DIGEST_KEY,
    CheckpointError,
    build_e2v,
    check_frames_match,
    load_checkpoint,
    read_checkpoint,
    save_checkpoint,
    slim_checkpoint,
    weights_digest,
)
from e2vlib.model import checkpoint as checkpoint_module
from e2vlib.shapes import load_mesh, normalize_mesh
from e2vlib.voxels import voxelize

SMALL = (16, 32, 32)


def small_checkpoint(path: Path, **extra) -> Path:
    return save_checkpoint(path, build_e2v("tiny", input_shape=SMALL, seed=0), **extra)


def write_obj(path: Path, vertices, faces_text: str) -> Path:
    lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in np.asarray(vertices, dtype=float).tolist()]
    path.write_text("\n".join(lines) + "\n" + faces_text)
    return path


def box_obj(path: Path, offset=(0.0, 0.0, 0.0), size: float = 1.0) -> Path:
    box = trimesh.creation.box(extents=(size, size * 0.5, size * 0.25))
    faces = "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in box.faces)
    return write_obj(path, box.vertices + np.asarray(offset), faces)


# --------------------------------------------------------------------------- bad: memory


def many_large_triangles(n: int = 400) -> trimesh.Trimesh:
    """``n`` triangles, each as large as the grid cube's cross-section (not watertight)."""
    rng = np.random.default_rng(0)
    tri = rng.uniform(-0.5, 0.5, (n, 3, 3))
    tri[:, 0, :2], tri[:, 1, :2], tri[:, 2, :2] = (-0.5, -0.5), (0.5, -0.5), (0.0, 0.5)
    return trimesh.Trimesh(tri.reshape(-1, 3), np.arange(3 * n).reshape(-1, 3), process=False)


def test_voxelize_refuses_work_over_its_bound_naming_the_mesh_file(tmp_path, monkeypatch):
    path = tmp_path / "soup.ply"
    many_large_triangles().export(path)
    mesh = load_mesh(path)
    monkeypatch.setattr(voxels, "MAX_RAY_TESTS", 100_000)  # 400 triangles x ~1000 columns
    with pytest.raises(ValueError, match=rf"{path}.*MAX_RAY_TESTS = 1e\+05"):
        voxelize(mesh)


def test_voxelize_refuses_too_many_faces_naming_the_mesh_file(tmp_path, monkeypatch):
    path = tmp_path / "ball.stl"
    trimesh.creation.icosphere(subdivisions=2, radius=0.4).export(path)
    monkeypatch.setattr(voxels, "MAX_FACES", 100)  # the sphere has 320
    with pytest.raises(ValueError, match=rf"{path} has 320 faces.*MAX_FACES = 100"):
        voxelize(load_mesh(path))


def test_voxelize_in_small_chunks_gives_the_same_grid(monkeypatch):
    soup, box = many_large_triangles(50), trimesh.creation.box((0.5, 0.5, 0.5))
    chair = trimesh.creation.annulus(0.2, 0.45, 0.3)  # watertight, with a hole
    expected = [voxelize(m) for m in (soup, box, chair)]
    monkeypatch.setattr(voxels, "_CHUNK", 7)  # a few triangles at a time
    for mesh, grid in zip((soup, box, chair), expected, strict=True):
        np.testing.assert_array_equal(voxelize(mesh), grid)
    assert voxelize(box).sum() == 16**3


def test_checkpoint_with_an_edited_config_is_refused_before_a_model_is_built(
        tmp_path, monkeypatch):
    path = small_checkpoint(tmp_path / "m.pt")
    ckpt = torch.load(path, weights_only=True)
    ckpt["config"].update(base_width=4096, bottleneck_features=300_000)  # digest still fine
    torch.save(ckpt, path)

    def no_build(*args, **kwargs):
        raise AssertionError("a model was built")

    monkeypatch.setattr(checkpoint_module, "E2V", no_build)
    with pytest.raises(CheckpointError, match=rf"{path}: its config describes a model of "
                                              r"\d+ parameters, more than model.MAX_PARAMETERS"):
        load_checkpoint(path)


def test_checkpoint_whose_zip_member_inflates_is_refused_before_torch_load(tmp_path):
    model = build_e2v("tiny", input_shape=SMALL, seed=0)
    with torch.no_grad():
        for tensor in model.state_dict().values():
            tensor.zero_()  # 26 MB of zeros, deflated to about 30 kB
    path = save_checkpoint(tmp_path / "m.pt", model)
    deflated = tmp_path / "bomb.pt"
    with zipfile.ZipFile(path) as src, zipfile.ZipFile(deflated, "w",
                                                       zipfile.ZIP_DEFLATED) as dst:
        for info in src.infolist():
            dst.writestr(info.filename, src.read(info))
    assert deflated.stat().st_size < path.stat().st_size / 10
    with pytest.raises(CheckpointError, match=rf"{deflated}: its zip members declare \d+ "
                                              "bytes, more than model.MAX_INFLATION = 4"):
        read_checkpoint(deflated)


def test_a_data_config_whose_video_is_too_large_is_refused_naming_the_bound():
    with pytest.raises(ValueError, match=r"resolution 4096 px with oversample 3 renders 360 "
                                         r"video frames of 22.5 GiB.*MAX_VIDEO_BYTES = 4 GiB"):
        BuildConfig(categories=("chair",), per_category=1, resolution=4096, frame_size=64,
                    oversample=3)
    with pytest.raises(ValueError, match="MAX_FRAMES_PER_SAMPLE"):
        frame_settings({"n_frames": 100_000, "frame_size": 4096})
    with pytest.raises(ValueError, match="the data config of checkpoint m.pt: .*"
                                         "MAX_FRAMES_PER_SAMPLE"):
        check_frames_match({"n_frames": 100_000, "frame_size": 4096}, {"n_frames": 100},
                           "checkpoint m.pt")
    BuildConfig(categories=("chair",), per_category=1, resolution=512, frame_size=64)


def npz_bytes(**arrays) -> bytes:
    buffer = io.BytesIO()
    np.savez_compressed(buffer, **arrays)
    return buffer.getvalue()


def test_npz_event_file_that_inflates_past_the_bound_is_refused(tmp_path, monkeypatch):
    path = tmp_path / "bomb.npz"
    n = 1_000_000  # 13 MB of columns, compressed to a few kB
    path.write_bytes(npz_bytes(x=np.zeros(n, np.uint16), y=np.zeros(n, np.uint16),
                               t=np.zeros(n, np.int64), p=np.ones(n, np.int8),
                               sensor_size=np.array([4, 4])))
    assert path.stat().st_size < 100_000
    monkeypatch.setattr(event_io, "MAX_EVENT_BYTES", 1_000_000)
    with pytest.raises(ValueError, match=rf"{path}: the event arrays declare .* GiB "
                                         r"\(x \[1000000\], .*MAX_EVENT_BYTES"):
        load_events(path)


def test_npz_event_file_declaring_gigabytes_is_refused_from_its_headers(tmp_path):
    path = tmp_path / "liar.npz"
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        header, {"descr": "<i8", "fortran_order": False, "shape": (800_000_000,)})
    small = {k: np.zeros(1, d) for k, d in (("x", np.uint16), ("y", np.uint16),
                                             ("p", np.int8))}
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
        for name, array in {**small, "sensor_size": np.array([4, 4])}.items():
            buffer = io.BytesIO()
            np.save(buffer, array)
            archive.writestr(f"{name}.npy", buffer.getvalue())
        archive.writestr("t.npy", header.getvalue() + bytes(1000))  # 6.4 GB declared
    with pytest.raises(ValueError, match=r"declare 5.96 GiB .*MAX_EVENT_BYTES = 4 GiB"):
        load_events(path)


def test_hdf5_event_file_declaring_more_than_the_bound_is_refused(tmp_path, monkeypatch):
    path = tmp_path / "bomb.h5"
    with h5py.File(path, "w") as f:  # chunked and never written: a few kB on disk
        for name, dtype in (("x", "u2"), ("y", "u2"), ("t", "i8"), ("p", "i1")):
            f.create_dataset(f"events/{name}", shape=(2_000_000,), dtype=dtype, chunks=True)
    assert path.stat().st_size < 100_000
    monkeypatch.setattr(event_io, "MAX_EVENT_BYTES", 1_000_000)  # 26 MB declared
    with pytest.raises(ValueError, match=rf"{path}: the event arrays declare .*"
                                         r"events/t \[2000000\].*MAX_EVENT_BYTES"):
        load_events(path)


def test_hdf5_declaring_13_gb_is_refused_before_reading(tmp_path):
    path = tmp_path / "v2e.h5"
    with h5py.File(path, "w") as f:
        f.create_dataset("events", shape=(400_000_000, 4), dtype="f8", chunks=(1024, 4))
    with pytest.raises(ValueError, match=r"declare 11.9 GiB .*MAX_EVENT_BYTES = 4 GiB"):
        load_events(path)


# --------------------------------------------------------------------------- bad: silent


def test_a_box_far_from_the_origin_voxelizes_as_the_same_box(tmp_path):
    near = voxelize(normalize_mesh(load_mesh(box_obj(tmp_path / "near.obj"))))
    far_mesh = load_mesh(box_obj(tmp_path / "far.obj", offset=(1e11, -3e11, 2e11)))
    assert len(far_mesh.vertices) == 8 and far_mesh.is_watertight
    np.testing.assert_array_equal(voxelize(normalize_mesh(far_mesh)), near)
    assert near.sum() > 0


def test_a_tiny_mesh_keeps_its_shape(tmp_path):
    near = voxelize(normalize_mesh(load_mesh(box_obj(tmp_path / "near.obj"))))
    tiny = load_mesh(box_obj(tmp_path / "tiny.obj", size=1e-9))
    np.testing.assert_array_equal(voxelize(normalize_mesh(tiny)), near)


@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # trimesh, on the huge test mesh
def test_absurd_coordinates_are_refused_naming_the_mesh(tmp_path):
    path = box_obj(tmp_path / "huge.obj", size=1e308)
    with pytest.raises(ValueError, match=rf"{path} has vertex coordinates up to 5e\+307, "
                                         "beyond shapes.MAX_MESH_COORDINATE = 1e\\+12"):
        load_mesh(path)
    huge = trimesh.creation.box((1.0, 1.0, 1.0))
    huge.vertices = np.sign(huge.vertices) * 1e308  # corners at +-1e308
    with pytest.raises(ValueError, match="the mesh has vertex coordinates up to 1e\\+308"):
        normalize_mesh(huge)
    with pytest.raises(ValueError, match="MAX_MESH_COORDINATE"):
        voxelize(huge)


@pytest.mark.parametrize("faces, index", [("f 1 2 3\nf 2 3 0\n", "index 0"),
                                          ("f 1 2 3\nf 1/1 0/2 3/3\n", "index 0"),
                                          ("f 1 2 3\nf 1 2 9\n", "index 9"),
                                          ("f 1 2 3\nf -1 -2 -5\n", "index -5")])
def test_obj_face_indices_outside_the_vertices_are_refused(tmp_path, faces, index):
    path = write_obj(tmp_path / "bad.obj", np.eye(4, 3), faces)
    with pytest.raises(ValueError, match=rf"{path}: .*{index}.*OBJ indices"):
        load_mesh(path)
    good = write_obj(tmp_path / "good.obj", np.eye(4, 3), "f 1 2 3\nf -1 -2 -3\n")
    assert load_mesh(good).faces.tolist() == [[0, 1, 2], [3, 2, 1]]


@pytest.mark.parametrize("dtype", [torch.int32, torch.bool])
def test_checkpoint_with_integer_or_bool_weights_is_refused_naming_the_key(tmp_path, dtype):
    path = small_checkpoint(tmp_path / "m.pt")
    ckpt = torch.load(path, weights_only=True)
    ckpt["model"]["head.weight"] = ckpt["model"]["head.weight"].to(dtype)
    ckpt[DIGEST_KEY] = weights_digest(ckpt["model"])  # recomputed: the digest passes
    torch.save(ckpt, path)
    with pytest.raises(CheckpointError, match=rf"{path} does not match an E2V model: "
                                              rf"'head.weight' holds {dtype}"):
        load_checkpoint(path)


# --------------------------------------------------------------------------- poor


def test_zero_extent_mesh_is_refused_naming_its_file(tmp_path):
    path = write_obj(tmp_path / "point.obj", np.ones((3, 3)), "f 1 2 3\n")
    with pytest.raises(ValueError, match=rf"mesh {path} has zero extent"):
        normalize_mesh(load_mesh(path))


def special_paths(tmp_path: Path, suffix: str) -> dict[str, tuple[Path, str]]:
    folder = tmp_path / f"folder{suffix}"
    folder.mkdir()
    fifo = tmp_path / f"pipe{suffix}"
    os.mkfifo(fifo)
    device = tmp_path / f"zero{suffix}"
    device.symlink_to("/dev/zero")
    loop = tmp_path / f"loop{suffix}"
    loop.symlink_to(loop)
    return {"folder": (folder, "is a directory"), "fifo": (fifo, "is a FIFO"),
            "device": (device, "is a character device"), "loop": (loop, "symbolic link loop")}


@pytest.mark.parametrize("reader, suffix", [(load_mesh, ".obj"), (load_events, ".npz"),
                                            (read_checkpoint, ".pt")])
def test_paths_that_are_not_files_are_named_for_what_they_are(tmp_path, reader, suffix):
    for path, what in special_paths(tmp_path, suffix).values():
        with pytest.raises((ValueError, OSError), match=what) as err:
            reader(path)
        assert str(path) in str(err.value) and "not found" not in str(err.value)


def test_a_bad_config_in_a_checkpoint_names_the_checkpoint(tmp_path):
    path = small_checkpoint(tmp_path / "m.pt")
    ckpt = torch.load(path, weights_only=True)
    ckpt["config"]["depth"] = 11
    torch.save(ckpt, path)
    for action in (lambda: slim_checkpoint(path, tmp_path / "slim.pt"),
                   lambda: load_checkpoint(path)):
        with pytest.raises(CheckpointError, match=rf"checkpoint {path} .*depth"):
            action()


def test_ordinary_files_still_load(tmp_path):
    events = make_events([1, 2], [0, 3], [500, 1500], [1, -1])
    for name in ("ev.npz", "ev.h5"):
        loaded, size = load_events(save_events(tmp_path / name, events, (4, 4)))
        np.testing.assert_array_equal(loaded, events) and size == (4, 4)
    model = load_checkpoint(small_checkpoint(tmp_path / "m.pt"))
    assert model.input_shape == SMALL
