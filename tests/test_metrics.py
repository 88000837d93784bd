import numpy as np
import pytest
import torch

from e2vlib import paper
from e2vlib.metrics import (
    category_means,
    fscore,
    iou,
    score_table,
    surface_points,
    surface_voxel_fscore,
    surface_voxels,
)


def block(lo, hi, shape=(32, 32, 32)):
    grid = np.zeros(shape, dtype=np.float32)
    grid[lo[0]:hi[0], lo[1]:hi[1], lo[2]:hi[2]] = 1
    return grid


def test_iou_by_hand():
    a = block((8, 8, 8), (16, 16, 16))  # 512 voxels
    b = block((12, 8, 8), (20, 16, 16))  # shifted by 4 in x: overlap 4*8*8 = 256
    assert iou(a, b) == pytest.approx(256 / (512 + 512 - 256))
    assert iou(a, a) == 1.0
    assert iou(a, np.zeros_like(a)) == 0.0
    assert iou(np.zeros_like(a), np.zeros_like(a)) == 1.0  # both empty: a perfect match


def test_iou_threshold_is_inclusive():
    gt = block((0, 0, 0), (2, 2, 2))
    pred = gt * 0.3  # exactly at the threshold: occupied (pred >= threshold)
    assert iou(pred, gt, threshold=0.3) == 1.0
    assert iou(pred, gt, threshold=0.31) == 0.0


def test_iou_batches_per_sample_and_accepts_torch():
    a = block((8, 8, 8), (16, 16, 16))
    b = block((12, 8, 8), (20, 16, 16))
    pred = torch.tensor(np.stack([a, a]))
    gt = torch.tensor(np.stack([a, b]))
    np.testing.assert_allclose(iou(pred, gt), [1.0, 1 / 3])


def test_bad_shapes_and_nan():
    with pytest.raises(ValueError, match="same shape"):
        iou(np.zeros((32, 32, 32)), np.zeros((16, 16, 16)))
    with pytest.raises(ValueError, match="NaN"):
        iou(np.full((4, 4, 4), np.nan), np.zeros((4, 4, 4)))


def test_surface_points_lie_on_the_block_surface():
    grid = block((8, 8, 8), (24, 24, 24)).astype(bool)  # the cube [-0.25, 0.25]^3
    points = surface_points(grid, n_points=2000)
    assert points.shape == (2000, 3)
    # marching cubes at level 0.5 puts faces half a voxel outside the centres of the
    # outer voxels, i.e. exactly on the block's faces at +-0.25
    assert np.allclose(np.abs(points).max(axis=1), 0.25, atol=1 / 32)
    assert surface_points(np.zeros((32, 32, 32), bool)).shape == (0, 3)


def test_fscore_known_cases():
    a = block((8, 8, 8), (24, 24, 24))
    assert fscore(a, a) == 1.0
    shifted = block((10, 8, 8), (26, 24, 24))  # 2 voxels = 0.0625 away on two faces
    f1 = fscore(shifted, a, distance=0.01)
    f20 = fscore(shifted, a, distance=0.2)
    assert f20 == 1.0 and 0.3 < f1 < 0.95
    assert fscore(np.zeros_like(a), a) == 0.0
    assert fscore(np.zeros_like(a), np.zeros_like(a)) == 1.0
    batch = fscore(np.stack([a, shifted]), np.stack([a, a]))
    assert batch.shape == (2,) and batch[0] == 1.0 and batch[1] == pytest.approx(f1)


@pytest.mark.parametrize("n_points", [0, -5, 2.5, True])
def test_fscore_refuses_no_surface_samples(n_points):
    # with zero samples every method used to score 1.0
    gt = np.zeros((32, 32, 32))
    gt[8:24, 8:24, 8:24] = 1
    with pytest.raises(ValueError, match="n_points must be a positive integer"):
        fscore(np.zeros_like(gt), gt, n_points=n_points)


def test_surface_voxels_by_hand():
    grid = block((8, 8, 8), (16, 16, 16)).astype(bool)  # 8^3 box: 8^3 - 6^3 = 296 on the surface
    surface = surface_voxels(grid)
    assert surface.sum() == 512 - 216
    assert not surface[9:15, 9:15, 9:15].any() and surface[8, 12, 12] and surface[15, 9, 9]
    edge = block((0, 0, 0), (2, 32, 32)).astype(bool)  # on the grid border: outside is empty
    assert surface_voxels(edge).sum() == 2 * 32 * 32
    assert surface_voxels(np.zeros((32, 32, 32), bool)).sum() == 0
    with pytest.raises(ValueError, match="one \\(D, H, W\\) grid"):
        surface_voxels(np.zeros((2, 32, 32, 32), bool))


def test_surface_voxel_fscore_by_hand():
    a = block((8, 8, 8), (16, 16, 16))
    moved = block((9, 8, 8), (17, 16, 16))  # one voxel along x
    # surfaces meet in x = 9..15: rings of 8*8 - 6*6 = 28 voxels in the 7 slices -> 196 of 296
    assert surface_voxel_fscore(moved, a) == pytest.approx(196 / 296)
    assert surface_voxel_fscore(moved, a, tolerance_voxels=1) == 1.0
    assert surface_voxel_fscore(a, a) == 1.0
    # a plate one voxel thick is all surface: coinciding surface voxels are the overlap
    plate = block((8, 8, 8), (9, 24, 24))
    half = block((8, 8, 8), (9, 24, 16))  # half of the plate: P = 1, R = 1/2, F = 2/3
    assert surface_voxel_fscore(half, plate) == pytest.approx(2 / 3)
    far = block((19, 8, 8), (27, 16, 16))  # its face x = 19 is 4 voxels from `a`'s x = 15
    assert surface_voxel_fscore(far, a) == 0.0
    assert surface_voxel_fscore(far, a, tolerance_voxels=3.9) == 0.0
    # at 4 voxels only the two facing 8 x 8 faces match: P = R = 64 / 296
    assert surface_voxel_fscore(far, a, tolerance_voxels=4) == pytest.approx(64 / 296)
    assert surface_voxel_fscore(np.zeros_like(a), a) == 0.0
    assert surface_voxel_fscore(np.zeros_like(a), np.zeros_like(a)) == 1.0


def test_surface_voxel_fscore_threshold_batch_and_errors():
    a = block((8, 8, 8), (16, 16, 16))
    assert surface_voxel_fscore(a * paper.IOU_THRESHOLD, a) == 1.0  # inclusive threshold
    assert surface_voxel_fscore(a * 0.29, a) == 0.0
    moved = block((9, 8, 8), (17, 16, 16))
    batch = surface_voxel_fscore(torch.tensor(np.stack([a, moved])), torch.tensor(np.stack([a, a])))
    np.testing.assert_allclose(batch, [1.0, 196 / 296])
    for bad in (-1, float("nan"), True):
        with pytest.raises(ValueError, match="tolerance_voxels must be"):
            surface_voxel_fscore(a, a, tolerance_voxels=bad)


def test_fscore_at_a_fifth_of_a_voxel_rewards_coinciding_samples_only():
    # reading (a) of the paper's F@20 %: d = 0.2 voxel; samples must (nearly) coincide
    a = block((8, 8, 8), (24, 24, 24))
    d = 0.2 / paper.GRID_SIDE
    assert fscore(a, a, distance=d) == 1.0  # same grid, same seeded samples
    shifted = block((10, 8, 8), (26, 24, 24))  # faces 2 voxels apart: nothing coincides there
    dense = fscore(shifted, a, distance=d, n_points=8192)
    sparse = fscore(shifted, a, distance=d, n_points=512)
    assert sparse < dense < fscore(shifted, a, distance=0.01, n_points=8192) < 1


def test_category_means():
    means = category_means(np.array([0.25, 0.75, 0.9, 0.1]), ["chair", "chair", "lamp", "lamp"])
    assert list(means) == ["chair", "lamp"]
    assert means["chair"] == 0.5 and means["lamp"] == pytest.approx(0.5)
    assert category_means(torch.tensor([1.0, 0.0]), ["car", "sofa"]) == {"car": 1.0, "sofa": 0.0}
    with pytest.raises(ValueError, match="one entry per sample"):
        category_means([0.1, 0.2], ["chair"])


def test_score_table_matches_the_evaluate_layout():
    from e2vlib.metrics import format_category_table

    scores = {"iou@0.3": np.array([0.25, 0.75, 0.9]), "fscore@1%": torch.tensor([0.0, 1.0, 0.5])}
    table = score_table(scores, ["chair", "chair", "lamp"])
    assert table["overall"] == {"iou@0.3": pytest.approx(1.9 / 3), "fscore@1%": 0.5}
    assert table["per_category"]["chair"] == {"iou@0.3": 0.5, "fscore@1%": 0.5, "n": 2}
    assert table["per_category"]["lamp"] == {"iou@0.3": 0.9, "fscore@1%": 0.5, "n": 1}
    text = format_category_table(table, keys=("iou@0.3", "fscore@1%"))
    assert "chair" in text and "0.500" in text and text.splitlines()[-1].split()[1] == "3"
