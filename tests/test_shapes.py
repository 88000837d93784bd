"""Tests for e2vlib.shapes: procedural categories and their sub-types, normalization, mesh
files, ShapeNet folders."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
import trimesh
from scipy import ndimage

from e2vlib.paper import SHAPENET_SYNSETS
from e2vlib.shapes import (
    CATEGORIES,
    SUB_TYPES,
    iter_shapenet,
    load_mesh,
    make_shape,
    normalize_mesh,
    shape_kind,
    shapenet_to_zup,
)
from e2vlib.voxels import voxelize

PAPER_ORDER = (
    "airplane bench cabinet car chair display lamp speaker rifle sofa table telephone watercraft"
).split()


def test_categories_are_the_papers_13_in_table_order():
    assert CATEGORIES == tuple(PAPER_ORDER)


def test_shapenet_synsets():
    assert sorted(SHAPENET_SYNSETS.values()) == sorted(CATEGORIES)
    assert SHAPENET_SYNSETS["03001627"] == "chair"
    assert SHAPENET_SYNSETS["04379243"] == "table"
    assert SHAPENET_SYNSETS["02691156"] == "airplane"
    assert SHAPENET_SYNSETS["04530566"] == "watercraft"
    assert all(len(k) == 8 and k.isdigit() for k in SHAPENET_SYNSETS)


# --------------------------------------------------------------------------- make_shape


@pytest.mark.parametrize("category", CATEGORIES)
def test_make_shape_is_normalized_watertight_and_one_piece(category):
    for seed in (0, 1, 2):
        mesh = make_shape(category, seed)
        assert isinstance(mesh, trimesh.Trimesh)
        lo, hi = mesh.bounds
        np.testing.assert_allclose((lo + hi) / 2, 0, atol=1e-9)
        assert abs((hi - lo).max() - 1) < 1e-9
        assert mesh.is_watertight and mesh.volume > 0
        assert mesh.body_count == 1  # parts overlap, so the union is one connected solid
        assert voxelize(mesh).any()


@pytest.mark.parametrize("category", CATEGORIES)
def test_make_shape_is_deterministic_and_varies_with_seed(category):
    a, b = make_shape(category, 7), make_shape(category, 7)
    np.testing.assert_array_equal(a.vertices, b.vertices)
    np.testing.assert_array_equal(a.faces, b.faces)
    c = make_shape(category, 8)
    assert a.vertices.shape != c.vertices.shape or not np.allclose(a.vertices, c.vertices)


@pytest.mark.parametrize("category", CATEGORIES)
def test_shapes_vary_inside_a_category(category):
    # a model must look at the object: labels of one category are far from identical
    grids = [voxelize(make_shape(category, seed)) for seed in range(6)]
    ious = [(a & b).sum() / (a | b).sum() for a, b in itertools.combinations(grids, 2)]
    assert np.mean(ious) < 0.8
    assert min(ious) < 0.7


def _centroid(grid: np.ndarray) -> np.ndarray:
    return np.argwhere(grid).mean(axis=0)


@pytest.mark.parametrize("category", ["chair", "sofa"])
def test_seat_backs_are_at_plus_y(category):
    # front faces -y: whatever rises above the seat (the back) sits behind it, at +y
    for seed in range(5):
        grid = voxelize(make_shape(category, seed))
        k = np.nonzero(grid.any(axis=(0, 1)))[0]
        top = grid.copy()
        top[:, :, : k.min() + int(0.75 * (k.max() - k.min()))] = False
        assert _centroid(top)[1] > 16, seed


def test_rifle_points_its_muzzle_to_minus_y():
    for seed in range(5):
        grid = voxelize(make_shape("rifle", seed))
        j = np.nonzero(grid.any(axis=(0, 2)))[0]
        assert j.min() == 0 and j.max() == 31  # the rifle's length runs along y
        height = grid.any(axis=0).sum(axis=1)  # occupied z voxels per y slice
        assert height[j.min() : j.min() + 4].max() < height[-8:].max(), seed  # thin muzzle


@pytest.mark.parametrize("category", ["car", "watercraft", "rifle"])
def test_long_objects_lie_along_y(category):
    for seed in range(5):
        lo, hi = make_shape(category, seed).bounds
        ext = hi - lo
        assert ext[1] > ext[0], seed


# --------------------------------------------------------------------------- sub-types

BOXY = ("cabinet", "display", "speaker", "telephone")  # once plain boxes; now sub-types


def _seeds_of(category: str, kind: str, n: int = 4) -> list[int]:
    seeds = [s for s in range(60) if shape_kind(category, s) == kind][:n]
    assert len(seeds) == n, (category, kind)
    return seeds


def test_sub_types_are_named_for_the_four_boxy_categories():
    assert sorted(SUB_TYPES) == sorted(BOXY)
    for category, kinds in SUB_TYPES.items():
        assert len(kinds) >= 3, category
        assert abs(sum(kinds.values()) - 1) < 1e-9, category


@pytest.mark.parametrize("category", BOXY)
def test_thirty_seeds_give_every_sub_type_watertight_and_normalized(category):
    kinds = [shape_kind(category, seed) for seed in range(30)]
    assert set(kinds) <= set(SUB_TYPES[category])
    assert len(set(kinds)) >= 3
    assert set(kinds) == set(SUB_TYPES[category])  # in fact all of them, for these seeds
    assert kinds == [shape_kind(category, seed) for seed in range(30)]  # deterministic
    for seed in range(30):
        mesh = make_shape(category, seed)
        lo, hi = mesh.bounds
        np.testing.assert_allclose((lo + hi) / 2, 0, atol=1e-9)
        assert abs((hi - lo).max() - 1) < 1e-9, (seed, kinds[seed])
        assert mesh.is_watertight and mesh.body_count == 1, (seed, kinds[seed])


def test_shape_kind_rejects_bad_input():
    with pytest.raises(ValueError, match="no named sub-types; only cabinet"):
        shape_kind("chair", 0)
    with pytest.raises(ValueError, match="unknown category"):
        shape_kind("spaceship", 0)
    with pytest.raises(ValueError, match="seed"):
        shape_kind("cabinet", -1)


def _seen(occupied: np.ndarray, axis: int, from_high: bool) -> np.ndarray:
    """Whether an occupied voxel lies on the low (or high) side of each voxel along axis."""
    grid = np.flip(occupied, axis) if from_high else occupied
    seen = np.logical_or.accumulate(grid, axis=axis)
    return np.flip(seen, axis) if from_high else seen


def _front_pockets(grid: np.ndarray) -> float:
    """Fraction of the bounding box that is empty compartments open only to the front:
    empty voxels with the object to their left and right (x), below and above (z) and
    behind (+y), at least 2 voxels behind the object's front (so not the gaps between
    handles on a closed front)."""
    pocket = ~grid
    for axis, from_high in ((0, False), (0, True), (2, False), (2, True), (1, True)):
        pocket &= _seen(grid, axis, from_high)
    idx = np.argwhere(grid)
    lo, hi = idx.min(axis=0), idx.max(axis=0)
    pocket[:, : lo[1] + 2, :] = False
    return float(pocket.sum() / np.prod(hi - lo + 1))


def test_open_cabinets_have_empty_compartments_closed_ones_lack():
    # labels are solid only where a cavity is enclosed: open shelves and an opened cupboard
    # stay empty, a closed chest is solid all through
    for kind in ("shelves", "open_door"):
        for seed in _seeds_of("cabinet", kind):
            assert _front_pockets(voxelize(make_shape("cabinet", seed))) > 0.025, (kind, seed)
    for seed in _seeds_of("cabinet", "chest"):
        assert _front_pockets(voxelize(make_shape("cabinet", seed))) < 0.005, seed
    # the pockets are really the compartments: filling the open front closes them
    seed = _seeds_of("cabinet", "shelves", 1)[0]
    grid = voxelize(make_shape("cabinet", seed))
    closed = grid.copy()
    j0 = np.argwhere(grid)[:, 1].min()
    closed[:, j0, :] |= grid.any(axis=1)  # a door over the whole front silhouette
    assert _front_pockets(ndimage.binary_fill_holes(closed)) < 0.005


def test_speakers_on_a_stand_have_a_thin_waist():
    for seed in _seeds_of("speaker", "stand"):
        grid = voxelize(make_shape("speaker", seed))
        k = np.nonzero(grid.any(axis=(0, 1)))[0]
        lo, span = k.min(), k.max() - k.min()
        waist, box = (grid[:, :, lo + int(f * span)].sum() for f in (0.35, 0.85))
        assert waist < 0.3 * box, seed  # the post(s) under the box


def test_mobiles_are_thin_slabs_and_flip_phones_bend_back():
    for seed in _seeds_of("telephone", "mobile"):
        ext = make_shape("telephone", seed).extents
        assert ext[2] == pytest.approx(1.0) and ext[1] < 0.12, seed  # upright, thin in y
    for seed in _seeds_of("telephone", "flip"):
        ext = make_shape("telephone", seed).extents
        assert ext[2] == pytest.approx(1.0) and ext[1] > 0.15, seed  # the lid leans back


def test_make_shape_rejects_bad_input():
    with pytest.raises(ValueError, match="airplane, bench, cabinet"):
        make_shape("spaceship", 0)
    with pytest.raises(ValueError, match="seed"):
        make_shape("chair", -1)
    with pytest.raises(ValueError, match="seed"):
        make_shape("chair", 1.5)
    assert make_shape("chair", np.int64(3)).vertices.shape == make_shape("chair", 3).vertices.shape


# --------------------------------------------------------------------------- normalize_mesh


def test_normalize_mesh_known_answer():
    box = trimesh.creation.box(bounds=[[1, 2, 3], [3, 3, 7]])
    before = box.vertices.copy()
    out = normalize_mesh(box)
    np.testing.assert_allclose(out.bounds, [[-0.25, -0.125, -0.5], [0.25, 0.125, 0.5]])
    np.testing.assert_array_equal(box.vertices, before)  # the input is left alone
    np.testing.assert_allclose(normalize_mesh(out).vertices, out.vertices)  # idempotent


def test_normalize_mesh_errors():
    with pytest.raises(ValueError, match="empty"):
        normalize_mesh(trimesh.Trimesh())
    point = trimesh.Trimesh([[1, 1, 1]] * 3, [[0, 1, 2]], process=False)
    with pytest.raises(ValueError, match="zero extent"):
        normalize_mesh(point)
    nan = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [0, np.nan, 0]], [[0, 1, 2]], process=False)
    with pytest.raises(ValueError, match="NaN"):
        normalize_mesh(nan)


# --------------------------------------------------------------------------- load_mesh


@pytest.mark.parametrize("suffix", [".obj", ".ply", ".stl", ".off", ".glb"])
def test_load_mesh_formats(tmp_path, suffix):
    box = trimesh.creation.box(bounds=[[0, 0, 0], [1, 2, 3]])
    path = tmp_path / f"box{suffix}"
    box.export(path)
    mesh = load_mesh(path)
    assert isinstance(mesh, trimesh.Trimesh)
    np.testing.assert_allclose(mesh.bounds, box.bounds, atol=1e-6)  # as stored: not normalized
    assert mesh.volume == pytest.approx(6.0)


@pytest.mark.parametrize("suffix", [".glb", ".obj"])
def test_load_mesh_merges_scenes_with_their_transforms(tmp_path, suffix):
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.creation.box(extents=(1, 1, 1)), node_name="a")
    moved = np.eye(4)
    moved[:3, 3] = (3, 0, 0)
    scene.add_geometry(trimesh.creation.box(extents=(1, 1, 1)), node_name="b", transform=moved)
    path = tmp_path / f"scene{suffix}"
    scene.export(path)
    mesh = load_mesh(path)
    assert len(mesh.faces) == 24
    np.testing.assert_allclose(mesh.bounds, [[-0.5, -0.5, -0.5], [3.5, 0.5, 0.5]], atol=1e-6)


def test_load_mesh_errors_name_the_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="missing.obj"):
        load_mesh(tmp_path / "missing.obj")
    garbage = tmp_path / "garbage.stl"
    garbage.write_bytes(b"not a mesh\x00\x01" * 8)
    with pytest.raises(ValueError, match="garbage.stl"):
        load_mesh(garbage)
    cut = tmp_path / "cut.ply"
    cut.write_bytes(b"ply\nformat ascii 1.0\nelement vertex 3\n")
    with pytest.raises(ValueError, match="cut.ply"):
        load_mesh(cut)
    empty = tmp_path / "empty.obj"
    empty.write_text("# no geometry\n")
    with pytest.raises(ValueError, match="empty.obj"):
        load_mesh(empty)
    other = tmp_path / "mesh.xyz"
    other.write_text("0 0 0\n")
    with pytest.raises(ValueError, match="unsupported"):
        load_mesh(other)


# --------------------------------------------------------------------------- ShapeNet


def test_shapenet_to_zup_sends_up_to_z_and_front_to_minus_y():
    # ShapeNetCore v2: +y up, front -z. Mark the top and the front with small boxes.
    body = trimesh.creation.box(extents=(0.2, 0.2, 0.2))
    top = trimesh.creation.box(extents=(0.05, 0.05, 0.05)).apply_translation((0, 0.5, 0))
    front = trimesh.creation.box(extents=(0.05, 0.05, 0.05)).apply_translation((0, 0, -0.5))
    mesh = trimesh.util.concatenate([body, top, front])
    before = mesh.vertices.copy()
    out = shapenet_to_zup(mesh)
    np.testing.assert_array_equal(mesh.vertices, before)
    np.testing.assert_allclose(out.bounds[1, 2], 0.525)  # top now along +z
    np.testing.assert_allclose(out.bounds[0, 1], -0.525)  # front now along -y
    assert out.volume == pytest.approx(mesh.volume)  # a rotation: not mirrored inside out
    np.testing.assert_allclose(
        shapenet_to_zup(trimesh.Trimesh([[1, 2, 3]] * 3, [[0, 1, 2]], process=False)).vertices[0],
        [-1, 3, 2],
    )


def _touch(path):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("v 0 0 0\n")


def test_iter_shapenet_reads_v1_and_v2_layouts(tmp_path):
    _touch(tmp_path / "03001627" / "b2" / "models" / "model_normalized.obj")  # chair, v2
    _touch(tmp_path / "03001627" / "a1" / "models" / "model_normalized.obj")
    (tmp_path / "03001627" / "c3" / "models").mkdir(parents=True)  # no mesh: skipped
    _touch(tmp_path / "02691156" / "p1" / "model.obj")  # airplane, v1
    _touch(tmp_path / "03797390" / "m1" / "models" / "model_normalized.obj")  # mug: not ours
    (tmp_path / "taxonomy.json").write_text("[]")
    found = list(iter_shapenet(tmp_path))
    assert [(c, m) for c, m, _ in found] == [("airplane", "p1"), ("chair", "a1"), ("chair", "b2")]
    assert found[0][2] == tmp_path / "02691156" / "p1" / "model.obj"
    assert found[1][2].name == "model_normalized.obj"
    assert [m for _, m, _ in iter_shapenet(tmp_path, ["chair"])] == ["a1", "b2"]
    assert list(iter_shapenet(tmp_path, "table")) == []


def test_iter_shapenet_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="nowhere"):
        list(iter_shapenet(tmp_path / "nowhere"))
    with pytest.raises(ValueError, match="mug"):
        list(iter_shapenet(tmp_path, ["mug"]))


def test_category_facts_have_one_home():
    from e2vlib import paper, shapes

    assert shapes.CATEGORIES is paper.CATEGORIES
    assert not hasattr(shapes, "SHAPENET_SYNSETS")  # one home: e2vlib.paper
