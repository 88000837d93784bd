"""Real objects, stage 2: solid labels for open, many-part meshes, and the
builder that turns catalogue rows into a dataset folder.

The labels have known answers: a closed box gives exactly :func:`e2vlib.voxels.voxelize`'s
grid, and so (tolerance: no voxel differs) do a box missing one triangle, a box missing a
whole side, and a box of six separate, overlapping faces turned either way; a flat plane
stays a one-voxel shell. The builder runs on a tiny package written here (an OBJ box under
``<cache>/pkgs``) with 16 px renders; no Debian package is needed.
"""

import csv
import json
from pathlib import Path

import numpy as np
import pytest
import trimesh

from e2vlib import paper
from e2vlib.data import E2VDataset, load_sample, mesh_to_sample, read_manifest
from e2vlib.data.checks import DatasetError
from e2vlib.experiments.real_objects import catalogue as cat
from e2vlib.experiments.real_objects import labels, samples
from e2vlib.shapes import make_shape, normalize_mesh
from e2vlib.voxels import voxelize

BOX = trimesh.creation.box(extents=(0.5, 0.5, 0.5))


def iou(a: np.ndarray, b: np.ndarray) -> float:
    return float((a & b).sum() / (a | b).sum())


def six_faces(half: float = 0.25, reach: float = 0.255, seed: int = 0) -> trimesh.Trimesh:
    """A box of six separate squares, each reaching ``reach - half`` past its edges (so
    they overlap at the box's edges), each turned a random way."""
    rng = np.random.default_rng(seed)
    parts = []
    square = np.array([[-reach, -reach], [reach, -reach], [reach, reach], [-reach, reach]])
    for axis in range(3):
        others = [a for a in range(3) if a != axis]
        for sign in (-1, 1):
            v = np.zeros((4, 3))
            v[:, others[0]], v[:, others[1]] = square[:, 0], square[:, 1]
            v[:, axis] = sign * half
            f = np.array([[0, 1, 2], [0, 2, 3]])
            parts.append(trimesh.Trimesh(v, f[:, ::-1] if rng.random() < 0.5 else f,
                                         process=False))
    return trimesh.util.concatenate(parts)


def test_closed_box_gives_voxelize_grid():
    grid, record = labels.solid_labels(BOX)
    assert np.array_equal(grid, voxelize(BOX))
    assert int(grid.sum()) == 16 ** 3 and record["fill"] == "enclosed"


@pytest.mark.parametrize("missing", ["one triangle", "one side"])
def test_open_box_gives_closed_box_grid(missing):
    top = np.flatnonzero(np.isclose(BOX.triangles_center[:, 2], 0.25))
    drop = top[:1] if missing == "one triangle" else top
    open_box = trimesh.Trimesh(BOX.vertices, np.delete(BOX.faces, drop, axis=0))
    assert not open_box.is_watertight
    grid, record = labels.solid_labels(open_box)
    assert np.array_equal(grid, voxelize(BOX))  # tolerance: no voxel differs
    assert record["fill"] == "voted"  # nothing encloses: the six directions filled it


@pytest.mark.parametrize("seed", [0, 1])
def test_six_separate_overlapping_faces_give_closed_box_grid(seed):
    mesh = six_faces(seed=seed)
    assert mesh.body_count == 6 and not mesh.is_watertight
    grid, _ = labels.solid_labels(mesh)
    assert np.array_equal(grid, voxelize(BOX))  # tolerance: no voxel differs


def test_gap_between_parts_is_sealed():
    # two open halves of a box, 0.01 apart (a third of a voxel): the closing seals the gap
    halves = []
    for sign in (-1, 1):
        half = trimesh.creation.box(extents=(0.245, 0.5, 0.5))
        half.apply_translation((sign * 0.1275, 0, 0))
        keep = ~np.isclose(half.triangles_center[:, 0], sign * 0.005)  # drop the inner side
        halves.append(trimesh.Trimesh(half.vertices, half.faces[keep]))
    grid, record = labels.solid_labels(trimesh.util.concatenate(halves))
    assert record["fill"] == "enclosed"
    assert (grid != voxelize(BOX)).sum() == 0


def test_flat_plane_stays_a_thin_shell():
    plane = trimesh.Trimesh([[-0.4, -0.4, 0.01], [0.4, -0.4, 0.01], [0.4, 0.4, 0.01],
                             [-0.4, 0.4, 0.01]], [[0, 1, 2], [0, 2, 3]])
    grid, record = labels.solid_labels(plane)
    assert record["fill"] == "shell"
    assert np.unique(np.argwhere(grid)[:, 2]).tolist() == [16]  # one layer
    assert int(grid.sum()) == record["surface"] == 26 * 26


@pytest.mark.slow  # 7 s of voxelizing; CI runs it (make test-all)
def test_sphere_and_procedural_shapes_agree_with_voxelize():
    sphere = trimesh.creation.icosphere(4, radius=0.5)
    assert iou(labels.solid_labels(sphere)[0], voxelize(sphere)) > 0.99
    scores = [iou(labels.solid_labels(m)[0], voxelize(m))
              for m in (normalize_mesh(make_shape(c, 1)) for c in paper.CATEGORIES)]
    assert np.median(scores) > 0.85 and min(scores) > 0.5


# ----------------------------------------------------------------------------- the builder

TINY = {"resolution": 16, "frame_size": 8, "oversample": 1}
OBJ_DIR = "usr/share/games/minetest/mods/homedecor/models"


def _row(rid: str, split: str, path: str, rotation: str = "none", source="minetest-mod-homedecor",
         keep: str = "yes") -> dict:
    return {"id": rid, "source": source, "path": path, "licence": "CC-BY-SA-4.0",
            "category": rid.split("_")[0], "rotation": rotation, "removed": "", "keep": keep,
            "split": split if keep == "yes" else "", "note": "looked: a box"}


def _write_catalogue(path: Path, rows: list[dict]) -> Path:
    cat.write_rows(path, rows)
    return path


@pytest.fixture()
def tiny(tmp_path):
    """A cache with two OBJ models (a box and an open box) and a catalogue of four rows:
    two built, one whose file is missing, one Sweet Home 3D row without its package."""
    models = tmp_path / "cache" / "pkgs" / "minetest-mod-homedecor" / OBJ_DIR
    models.mkdir(parents=True)
    box = trimesh.creation.box(extents=(0.6, 0.3, 0.4))
    (models / "box.obj").write_text(trimesh.exchange.obj.export_obj(box))
    side = np.isclose(box.triangles_center[:, 0], 0.3)
    open_box = trimesh.Trimesh(box.vertices, box.faces[~side])  # one side missing
    (models / "open.obj").write_text(trimesh.exchange.obj.export_obj(open_box))
    rows = [_row("cabinet_hd_box", "train", f"{OBJ_DIR}/box.obj"),
            _row("cabinet_hd_open", "test", f"{OBJ_DIR}/open.obj"),
            _row("table_hd_gone", "val", f"{OBJ_DIR}/gone.obj"),
            {**_row("chair_bs0_armchair", "train", "BlendSwap-CC-0.sh3f::x#y",
                    source="sweethome3d-furniture"), "licence": "CC0-1.0",
             "rotation": "as_placed"}]
    catalogue = _write_catalogue(tmp_path / "catalogue.csv", rows)
    return tmp_path / "cache", catalogue, tmp_path / "data"


def _build(tiny, **kw):
    cache, catalogue, out = tiny
    return samples.build_samples(cache, out, catalogue, samples.sample_config(**TINY),
                                 progress=False, **kw)


def test_builder_makes_a_dataset_models_read(tiny, monkeypatch):
    cache, catalogue, out = tiny
    monkeypatch.setattr(samples, "sh3d_folders",
                        lambda c: (Path(c) / "none", Path(c) / "none"))
    result = _build(tiny)
    assert result["built"] == {"cabinet": 2}
    assert result["failed"] == ["table_hd_gone"]
    assert "sweethome3d-furniture" in result["skipped"] and "skipping the 1" in result["skipped"]
    rows = {r["id"]: r for r in read_manifest(out)}
    assert {k: r["split"] for k, r in rows.items()} == {"cabinet_hd_box": "train",
                                                        "cabinet_hd_open": "test"}
    train, test = E2VDataset(out, "train", verify=True), E2VDataset(out, "test")
    item = train[0]
    assert tuple(item["frames"].shape) == (100, 8, 8) and tuple(item["voxels"].shape) == (32,) * 3
    config = json.loads((out / "config.json").read_text())
    assert config["frame_size"] == 8 and "per_category" not in config
    assert config["source"]["command"] == samples.SAMPLES_COMMAND
    with open(out / "objects.csv", newline="") as f:
        records = {r["id"]: r for r in csv.DictReader(f)}
    assert records["cabinet_hd_box"]["fill"] == "enclosed"
    assert records["cabinet_hd_open"]["fill"] == "voted"
    assert "not found" in records["table_hd_gone"]["error"]
    assert float(records["cabinet_hd_box"]["voxelize_iou"]) > 0.95
    # the open box's label is the closed box's (its open side lies on the grid's border,
    # where two corner voxels of 11,268 differ)
    _, voxels = load_sample(out / "samples" / "cabinet_hd_open.npz")
    _, closed = load_sample(out / "samples" / "cabinet_hd_box.npz")
    assert (voxels != closed).sum() <= 2 and closed.sum() > 10_000
    assert len(test) == 1


def test_builder_frames_are_the_sample_pipelines(tiny):
    from e2vlib.experiments.real_meshes.build import real_sample_seed
    from e2vlib.experiments.real_objects.catalogue import read_catalogue

    cache, catalogue, out = tiny
    _build(tiny, only="box")
    row = next(r for r in read_catalogue(catalogue) if r.id == "cabinet_hd_box")
    config = samples.sample_config(**TINY)
    mesh = samples.load_row_mesh(cache, row)
    expected = mesh_to_sample(mesh, config, seed=real_sample_seed(config.seed, row.id))
    frames, voxels = load_sample(out / "samples" / "cabinet_hd_box.npz")
    assert np.array_equal(frames, expected.frames)
    assert np.array_equal(voxels, labels.solid_labels(mesh)[0])


def test_builder_resumes_and_remakes_changed_rows(tiny, monkeypatch):
    cache, catalogue, out = tiny
    _build(tiny, limit=1)
    assert len(read_manifest(out)) == 1  # stopped after one: a readable folder
    made = []
    real = samples.make_sample
    monkeypatch.setattr(samples, "make_sample",
                        lambda *a, **k: made.append(a[1].id) or real(*a, **k))
    _build(tiny)
    assert made == ["table_hd_gone", "cabinet_hd_box"]  # test rows first: open was made
    made.clear()
    _build(tiny)
    assert made == []  # nothing left to do (the failed row stays recorded)
    rows = list(csv.DictReader(open(catalogue, newline="")))
    rows[0]["rotation"] = "z90"
    _write_catalogue(catalogue, rows)
    _build(tiny)
    assert made == [rows[0]["id"]]
    rows = [r for r in rows if r["id"] != "cabinet_hd_open"]
    _write_catalogue(catalogue, rows)
    _build(tiny)
    assert not (out / "samples" / "cabinet_hd_open.npz").exists()
    assert [r["id"] for r in read_manifest(out)] == ["cabinet_hd_box"]


def test_without_assimp_nothing_is_built_and_its_failures_are_retried_once_it_is_there(
        tiny, monkeypatch):
    cache, catalogue, out = tiny
    rows = list(csv.DictReader(open(catalogue, newline="")))
    rows.append(_row("rifle_oa_gun", "train", "baseoa/pak0.pk3::models/gun/gun.md3",
                     source="openarena-data"))
    _write_catalogue(catalogue, rows)
    monkeypatch.setattr(samples.shutil, "which", lambda tool: None)
    with pytest.raises(samples.RealMeshError, match="apt-get install assimp-utils"):
        _build(tiny)
    assert not list((out / "samples").glob("*.npz"))  # refused before any sample
    # a record from a build that had no assimp (the error the reader gives) is tried again,
    # a model's own failure is not
    _build(tiny, only="hd_")
    (out / "records" / "rifle_oa_gun.json").write_text(json.dumps({
        "id": "rifle_oa_gun", "made_from": samples.made_from(
            next(r for r in samples.read_catalogue(catalogue) if r.id == "rifle_oa_gun")),
        "error": "RealMeshError: gun.md3: assimp is not installed; apt-get install "
                 "assimp-utils"}))
    made = []
    monkeypatch.setattr(samples.shutil, "which", lambda tool: "/usr/bin/" + tool)
    monkeypatch.setattr(samples, "make_sample", lambda cache, row, *a: made.append(row.id) or {
        "error": "", "seconds": 0})
    _build(tiny)
    assert made == ["rifle_oa_gun"]  # not table_hd_gone, whose file is missing
    assert samples.needs_assimp(samples.read_catalogue(catalogue)[-1])


def test_builder_refuses_other_settings(tiny):
    cache, catalogue, out = tiny
    _build(tiny, only="box")
    with pytest.raises(DatasetError, match="other settings"):
        samples.build_samples(cache, out, catalogue,
                              samples.sample_config(resolution=32, frame_size=8,
                                                    oversample=1), progress=False)


def test_samples_stay_out_of_git():
    # the data folder is under cache/, which git ignores
    import subprocess

    root = Path(__file__).resolve().parents[1]
    done = subprocess.run(["git", "check-ignore", "-q", "cache/real_objects/data/x.npz"],
                          cwd=root)
    assert done.returncode == 0
    assert samples.SAMPLES_COMMAND.endswith("--out cache/real_objects/data")


def test_the_recorded_command_runs_the_builder(monkeypatch):
    from e2vlib.experiments.real_objects import __main__ as cli

    calls = []
    monkeypatch.setattr(cli, "build_samples", lambda *a, **k: calls.append((a, k)))
    argv = samples.SAMPLES_COMMAND.split()[3:]  # after "python -m <module>"
    assert cli.main(argv) == 0
    assert calls == [((Path("cache/real_objects"), Path("cache/real_objects/data")),
                      {"only": None, "limit": None})]
