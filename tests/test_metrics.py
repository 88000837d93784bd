import numpy as np
import pytest
import torch

from e2vlib.metrics import fscore, iou, surface_points


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
