"""Tests for e2vlib.voxels: solid voxelization with known answers, and the binvox format."""

from __future__ import annotations

import os

import numpy as np
import pytest
import trimesh

from e2vlib.shapes import shapenet_to_zup
from e2vlib.voxels import (
    VoxelError,
    read_binvox,
    shapenet_voxels_to_zup,
    voxelize,
    write_binvox,
)

R = 32


def central_block(resolution: int = R, lo: int = 8, hi: int = 24) -> np.ndarray:
    grid = np.zeros((resolution,) * 3, dtype=bool)
    grid[lo:hi, lo:hi, lo:hi] = True
    return grid


def half_box() -> trimesh.Trimesh:
    """Axis-aligned cube of half-size 0.25 centred at the origin."""
    return trimesh.creation.box(extents=(0.5, 0.5, 0.5))


# --------------------------------------------------------------------------- voxelize


def test_centred_box_is_exactly_the_central_block():
    # faces at +-0.25 lie exactly on voxel boundaries 8 and 24 of 32
    grid = voxelize(half_box(), R)
    assert grid.dtype == bool and grid.shape == (R, R, R)
    np.testing.assert_array_equal(grid, central_block())


def test_box_at_other_resolution():
    np.testing.assert_array_equal(voxelize(half_box(), 8), central_block(8, 2, 6))


def test_sphere_fills_pi_over_six():
    sphere = trimesh.creation.icosphere(subdivisions=4, radius=0.5)
    fraction = voxelize(sphere, R).mean()
    assert abs(fraction - np.pi / 6) < 0.01


def test_axis_order_is_x_y_z():
    # extents 0.5 x 0.25 x 0.125 -> 16 x 8 x 4 voxels, then shifted +x by 0.25 (8 voxels)
    box = trimesh.creation.box(extents=(0.5, 0.25, 0.125)).apply_translation((0.25, 0, 0))
    grid = voxelize(box, R)
    i, j, k = np.nonzero(grid)
    assert (i.min(), i.max()) == (16, 31)
    assert (j.min(), j.max()) == (12, 19)
    assert (k.min(), k.max()) == (14, 17)
    assert grid.sum() == 16 * 8 * 4


@pytest.mark.parametrize("axis", [0, 1, 2])
@pytest.mark.parametrize("sign", [-1, 1])
def test_box_with_a_missing_face_is_still_solid(axis, sign):
    box = half_box()
    box.update_faces(~np.isclose(box.face_normals[:, axis], sign))
    assert not box.is_watertight
    np.testing.assert_array_equal(voxelize(box, R), central_block())


def test_inside_out_mesh_gives_the_same_grid():
    box = half_box()
    box.invert()
    np.testing.assert_array_equal(voxelize(box, R), central_block())


def test_thin_plate_is_kept_as_one_layer():
    # 0.01 thick (a third of a voxel), lying inside voxel layer 16: no voxel centre inside it
    plate = trimesh.creation.box(extents=(0.5, 0.5, 0.01))
    plate.apply_translation((0, 0, (16.3 / R) - 0.5))
    grid = voxelize(plate, R)
    expected = np.zeros_like(grid)
    expected[8:24, 8:24, 16] = True
    np.testing.assert_array_equal(grid, expected)


def test_thin_rod_is_kept_unbroken():
    # radius 0.005 on the x = y = 0 voxel boundary, from z = -0.3 to 0.3 (layers 6..25)
    rod = trimesh.creation.cylinder(radius=0.005, height=0.6, sections=8)
    grid = voxelize(rod, R)
    layers = np.nonzero(grid.any(axis=(0, 1)))[0]
    np.testing.assert_array_equal(layers, np.arange(6, 26))
    assert grid[15:17, 15:17, 6:26].all() and grid.sum() == 4 * 20


def test_open_sheet_gives_only_its_surface():
    square = trimesh.Trimesh(
        vertices=[
            [-0.25, -0.25, 0.01],
            [0.25, -0.25, 0.01],
            [0.25, 0.25, 0.01],
            [-0.25, 0.25, 0.01],
        ],
        faces=[[0, 1, 2], [0, 2, 3]],
    )
    grid = voxelize(square, R)
    assert grid.sum() == 16 * 16 and grid[8:24, 8:24, 16].all()


def test_overlapping_parts_count_as_their_union():
    a = trimesh.creation.box(bounds=[[-0.25, -0.25, -0.25], [0.125, 0.25, 0.25]])
    b = trimesh.creation.box(bounds=[[-0.125, -0.25, -0.25], [0.25, 0.25, 0.25]])
    concatenated = trimesh.util.concatenate([a, b])  # self-overlapping, winding 2 inside
    np.testing.assert_array_equal(voxelize(concatenated, R), central_block())


def test_enclosed_cavity_is_filled():
    outer = trimesh.creation.icosphere(subdivisions=3, radius=0.4)
    inner = trimesh.creation.icosphere(subdivisions=3, radius=0.2)
    shell = trimesh.boolean.difference([outer, inner], engine="manifold")
    np.testing.assert_array_equal(voxelize(shell, R), voxelize(outer, R))


def test_parts_outside_the_cube_are_clipped():
    assert voxelize(trimesh.creation.box(extents=(2, 2, 2)), R).all()
    slab = trimesh.creation.box(bounds=[[0.25, -2, -2], [1.0, 2, 2]])
    grid = voxelize(slab, R)
    assert grid[24:].all() and not grid[:24].any()


def test_mesh_is_not_modified_or_renormalized():
    box = trimesh.creation.box(extents=(0.25, 0.25, 0.25))
    before = box.vertices.copy()
    grid = voxelize(box, R)
    np.testing.assert_array_equal(box.vertices, before)
    assert grid.sum() == 8**3  # a 0.25 cube stays 8 voxels wide: no rescaling to the grid


def test_boolean_union_and_plain_concatenation_agree():
    # a little table: a top and four legs that overlap it, as the shape generators build
    top = trimesh.creation.box(bounds=[[-0.4, -0.3, 0.1], [0.4, 0.3, 0.15]])
    legs = [
        trimesh.creation.cylinder(radius=0.03, segment=[[x, y, -0.4], [x, y, 0.12]], sections=12)
        for x in (-0.35, 0.35)
        for y in (-0.25, 0.25)
    ]
    union = trimesh.boolean.union([top, *legs], engine="manifold")
    grid = voxelize(union, R)
    np.testing.assert_array_equal(grid, voxelize(trimesh.util.concatenate([top, *legs]), R))
    # each leg (0.06 wide, centre at voxel coordinate 27.2 or 4.8) holds 2x2 voxel centres
    assert grid[:, :, 20].sum() > grid[:, :, 10].sum() == 4 * 4


@pytest.mark.parametrize(
    "bad, match",
    [
        (trimesh.Trimesh(), "no faces"),
        (trimesh.Scene(), "Scene"),
        (np.zeros((3, 3)), "Trimesh"),
        (
            trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [np.nan, 1, 0]], [[0, 1, 2]], process=False),
            "NaN",
        ),
    ],
)
def test_voxelize_rejects_bad_meshes(bad, match):
    with pytest.raises(ValueError, match=match):
        voxelize(bad)


@pytest.mark.parametrize("resolution", [0, -4, 2.5, True, 5000])
def test_voxelize_rejects_bad_resolution(resolution):
    with pytest.raises(ValueError, match="resolution"):
        voxelize(half_box(), resolution)


# --------------------------------------------------------------------------- y-up to z-up


def test_voxel_and_mesh_frame_conversions_agree():
    # an asymmetric object in ShapeNet's frame (y up): a post, offset to +x and -z
    yup = trimesh.creation.box(bounds=[[0.1, -0.4, -0.3], [0.3, 0.4, -0.1]])
    np.testing.assert_array_equal(
        voxelize(shapenet_to_zup(yup), R), shapenet_voxels_to_zup(voxelize(yup, R))
    )
    up = voxelize(shapenet_to_zup(yup), R)
    i, j, k = np.nonzero(up)
    assert k.max() - k.min() == 25  # the long axis (y in ShapeNet) is now z


# --------------------------------------------------------------------------- binvox

HEADER_3 = b"#binvox 1\ndim 3 3 3\ntranslate -0.5 -0.5 -0.5\nscale 1.0\ndata\n"


def test_read_hand_made_file_pins_axis_order(tmp_path):
    # one voxel at (x, y, z) = (2, 0, 1): binvox flat index x*9 + z*3 + y = 21
    path = tmp_path / "one.binvox"
    path.write_bytes(HEADER_3 + bytes([0, 21, 1, 1, 0, 5]))
    grid = read_binvox(path)
    assert grid.dtype == bool and grid.shape == (3, 3, 3)
    assert list(zip(*np.nonzero(grid), strict=True)) == [(2, 0, 1)]


def _header_and_runs(raw: bytes) -> tuple[list[bytes], bytes]:
    """Header lines without comments, and the run bytes after the 'data' line."""
    head, runs = raw.split(b"\ndata\n", 1)
    return [line for line in head.split(b"\n") if not line.startswith(b"# ")], runs


def test_write_matches_hand_made_bytes(tmp_path):
    grid = np.zeros((3, 3, 3), dtype=bool)
    grid[2, 0, 1] = True
    path = tmp_path / "one.binvox"
    write_binvox(path, grid)
    assert _header_and_runs(path.read_bytes()) == _header_and_runs(
        HEADER_3 + bytes([0, 21, 1, 1, 0, 5]))


def _old_writer_bytes(grid: np.ndarray) -> bytes:
    """The bytes the earlier hand-written writer produced: header, then runs of <= 255."""
    d = grid.shape[0]
    flat = grid.transpose(0, 2, 1).ravel()
    starts = np.concatenate([[0], np.flatnonzero(flat[1:] != flat[:-1]) + 1])
    runs = []
    for start, stop in zip(starts, [*starts[1:], flat.size], strict=True):
        length = int(stop - start)
        while length:
            runs += [int(flat[start]), min(length, 255)]
            length -= min(length, 255)
    header = f"#binvox 1\ndim {d} {d} {d}\ntranslate -0.5 -0.5 -0.5\nscale 1.0\ndata\n"
    return header.encode("ascii") + bytes(runs)


@pytest.mark.parametrize("density", [0.0, 0.02, 0.5, 1.0])
def test_files_of_the_earlier_writer_read_the_same_and_runs_match(tmp_path, density):
    # runs of exactly 510 and 255 empty voxels, which must not be split as 255 + 0
    flat = np.random.default_rng(7).random(32**3) < density  # in file order [x, z, y]
    flat[:510], flat[510], flat[511:766], flat[766] = False, True, False, True
    grid = flat.reshape(32, 32, 32).transpose(0, 2, 1)
    (tmp_path / "old.binvox").write_bytes(_old_writer_bytes(grid))
    np.testing.assert_array_equal(read_binvox(tmp_path / "old.binvox"), grid)
    write_binvox(tmp_path / "new.binvox", grid)
    assert _header_and_runs((tmp_path / "new.binvox").read_bytes()) == _header_and_runs(
        _old_writer_bytes(grid))


@pytest.mark.parametrize("resolution", [1, 5, 32])
def test_round_trip_random_grids(tmp_path, resolution):
    rng = np.random.default_rng(resolution)
    for density in (0.0, 0.1, 0.5, 1.0):
        grid = rng.random((resolution,) * 3) < density
        path = tmp_path / f"g{resolution}_{density}.binvox"
        write_binvox(path, grid)
        np.testing.assert_array_equal(read_binvox(path), grid)


def test_long_runs_are_split_at_255(tmp_path):
    path = tmp_path / "full.binvox"
    write_binvox(path, np.ones((32, 32, 32), dtype=bool))
    _, body = _header_and_runs(path.read_bytes())
    counts = np.frombuffer(body, dtype=np.uint8)[1::2]
    assert len(counts) == -(-(32**3) // 255) and counts.max() == 255 and counts.sum() == 32**3


def test_write_accepts_01_ints_and_leaves_input_alone(tmp_path):
    grid = np.zeros((4, 4, 4), dtype=np.uint8)
    grid[1, 2, 3] = 1
    copy = grid.copy()
    write_binvox(tmp_path / "a.binvox", grid, translate=(0, 0, 0), scale=2.0)
    np.testing.assert_array_equal(grid, copy)
    assert b"translate 0.0 0.0 0.0\nscale 2.0\n" in (tmp_path / "a.binvox").read_bytes()
    np.testing.assert_array_equal(read_binvox(tmp_path / "a.binvox"), grid.astype(bool))


def test_write_replaces_atomically_and_keeps_old_file_on_error(tmp_path):
    path = tmp_path / "x.binvox"
    write_binvox(path, np.ones((2, 2, 2), dtype=bool))
    old = path.read_bytes()
    with pytest.raises(VoxelError):
        write_binvox(path, np.full((2, 2, 2), 0.5))
    assert path.read_bytes() == old
    write_binvox(path, np.zeros((2, 2, 2), dtype=bool))
    assert not read_binvox(path).any()
    assert os.listdir(tmp_path) == ["x.binvox"]  # no temporary files left behind


@pytest.mark.parametrize(
    "voxels, match",
    [
        (np.zeros((2, 3, 2), dtype=bool), "cubic"),
        (np.zeros((4, 4), dtype=bool), "cubic"),
        (np.full((2, 2, 2), 0.5), "0/1"),
    ],
)
def test_write_rejects_bad_grids(tmp_path, voxels, match):
    with pytest.raises(VoxelError, match=match):
        write_binvox(tmp_path / "bad.binvox", voxels)
    assert not (tmp_path / "bad.binvox").exists()


@pytest.mark.parametrize(
    "content, match",
    [
        (HEADER_3 + bytes([0, 21, 1, 1, 0]), "odd number of bytes"),  # cut mid-pair
        (HEADER_3 + bytes([0, 21, 1, 1]), "add up to 22"),  # cut after a pair
        (HEADER_3 + bytes([0, 255, 0, 255]), "add up to 510"),  # too many voxels
        (HEADER_3 + bytes([0, 21, 7, 1, 0, 5]), "0 or 1"),
        (b"#binvox 1\ndim 3 3 3\ntranslate 0 0 0\n", "truncated"),  # no data line
        (b"PLY\nformat ascii\n", "not a binvox"),
        (b"#binvox 1\ndim 3 3\ndata\n" + bytes([0, 27]), "dim"),
        (b"#binvox 1\ndim 2 3 4\ndata\n" + bytes([0, 24]), "cubic"),
        (b"#binvox 1\ntranslate 0 0 0\ndata\n" + bytes([0, 27]), "dim"),
    ],
)
def test_read_rejects_corrupt_files_naming_them(tmp_path, content, match):
    path = tmp_path / "corrupt.binvox"
    path.write_bytes(content)
    with pytest.raises(VoxelError, match=match) as info:
        read_binvox(path)
    assert "corrupt.binvox" in str(info.value)


def test_read_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError):
        read_binvox(tmp_path / "nope.binvox")


def test_a_huge_unnormalized_mesh_is_refused_before_allocating():
    # a 1 km box would need ~1e12 surface samples at 32^3; refuse it and name the fix
    mesh = trimesh.creation.box((1000.0, 1000.0, 1000.0))
    with pytest.raises(ValueError, match="normalize it first"):
        voxelize(mesh)
