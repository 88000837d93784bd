"""Reconstruction metrics: voxel IoU and surface F-score, as in Pix2Vox / Pix2Vox++.

Predictions are occupancy probabilities in [0, 1] (``sigmoid(logits)``), ground truth is
a 0/1 grid; both ``(32, 32, 32)`` or batched ``(B, 32, 32, 32)``, numpy or torch.

Introduced in notebooks/07_evaluation.ipynb.
"""

from __future__ import annotations

import numpy as np

from e2vlib import paper

IOU_THRESHOLDS = paper.IOU_THRESHOLDS  # the thresholds Pix2Vox reports (our choice to follow)


def _to_numpy(a) -> np.ndarray:
    if hasattr(a, "detach"):
        a = a.detach().cpu().numpy()
    return np.asarray(a)


def _check_pair(pred, gt) -> tuple[np.ndarray, np.ndarray]:
    pred, gt = _to_numpy(pred), _to_numpy(gt)
    if pred.shape != gt.shape or pred.ndim not in (3, 4):
        raise ValueError(
            f"pred and gt must both be (D, H, W) or (B, D, H, W) grids of the same shape, "
            f"got {pred.shape} and {gt.shape}"
        )
    if not np.all(np.isfinite(pred)):
        raise ValueError("pred holds NaN or inf; pass probabilities (sigmoid of the logits)")
    return pred, gt


def iou(pred, gt, threshold: float = paper.IOU_THRESHOLD):
    """Intersection over union of ``pred >= threshold`` and ``gt > 0.5``.

    Returns a float for one grid, a numpy array ``(B,)`` for a batch (one IoU per sample,
    as Pix2Vox computes it before averaging). Two empty grids count as a perfect match
    (IoU 1). The default threshold 0.3 is our choice (Pix2Vox's convention; the paper does
    not state its threshold). Introduced in notebooks/07_evaluation.ipynb.

    Examples
    --------
    >>> gt = np.zeros((32, 32, 32)); gt[:8] = 1          # 8 of 32 slabs
    >>> pred = np.zeros((32, 32, 32)); pred[4:12] = 0.9  # shifted by 4: overlap 4, union 12
    >>> round(iou(pred, gt), 4)
    0.3333
    >>> iou(pred, gt, threshold=0.95)                    # nothing predicted at 0.95
    0.0
    """
    pred, gt = _check_pair(pred, gt)
    p = pred >= threshold
    g = gt > 0.5
    axes = tuple(range(p.ndim - 3, p.ndim))
    inter = np.logical_and(p, g).sum(axis=axes)
    union = np.logical_or(p, g).sum(axis=axes)
    result = np.where(union > 0, inter / np.maximum(union, 1), 1.0)
    return float(result) if result.ndim == 0 else result


def surface_points(occupancy: np.ndarray, n_points: int = 8192, seed: int = 0) -> np.ndarray:
    """``(n_points, 3)`` points sampled uniformly on the surface of a binary grid.

    The surface is the marching-cubes iso-surface (level 0.5) of the grid padded by one
    empty voxel, mapped to the unit cube ``[-0.5, 0.5]^3`` (voxel ``i`` is centred at
    ``-0.5 + (i + 0.5) / R``). An empty grid gives ``(0, 3)``.
    """
    import trimesh
    from skimage.measure import marching_cubes

    occupancy = np.asarray(occupancy, dtype=bool)
    if not occupancy.any():
        return np.zeros((0, 3))
    resolution = occupancy.shape[0]
    padded = np.pad(occupancy, 1).astype(np.float32)
    vertices, faces, _, _ = marching_cubes(padded, level=0.5)
    vertices = (vertices - 1 + 0.5) / resolution - 0.5
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    points, _ = trimesh.sample.sample_surface(mesh, n_points, seed=seed)
    return np.asarray(points)


def fscore(pred, gt, threshold: float = paper.IOU_THRESHOLD,
           distance: float = paper.FSCORE_DISTANCE,
           n_points: int = 8192, seed: int = 0):
    """F-score of the surfaces of ``pred >= threshold`` and ``gt`` at ``distance``.

    ``n_points`` points are sampled (seeded) on each surface (:func:`surface_points`);
    precision is the share of predicted points within ``distance`` of a ground-truth
    point, recall the reverse, F = 2PR / (P + R). ``distance`` is a fraction of the unit
    cube's side: 0.01 is Pix2Vox++'s F-Score@1%. Two empty grids score 1, one empty grid
    0. Returns a float, or ``(B,)`` for a batch. Introduced in notebooks/07_evaluation.ipynb.

    Examples
    --------
    >>> gt = np.zeros((32, 32, 32)); gt[8:24, 8:24, 8:24] = 1
    >>> fscore(gt, gt)                          # the same surface, the same samples
    1.0
    >>> fscore(np.zeros_like(gt), gt)           # nothing predicted
    0.0
    """
    scores = fscores(pred, gt, threshold, (distance,), n_points, seed)
    return scores[..., 0] if scores.ndim == 2 else float(scores[0])


def fscores(pred, gt, threshold: float = paper.IOU_THRESHOLD,
            distances=(paper.FSCORE_DISTANCE, paper.FSCORE_DISTANCE_REPORTED),
            n_points: int = 8192, seed: int = 0) -> np.ndarray:
    """:func:`fscore` at several distances from one set of surface samples.

    Returns ``(len(distances),)`` for one grid or ``(B, len(distances))`` for a batch.
    """
    from scipy.spatial import cKDTree

    if isinstance(n_points, bool) or not isinstance(n_points, int | np.integer) or n_points < 1:
        raise ValueError(f"n_points must be a positive integer (8192 is usual), got {n_points!r}")
    distances = tuple(distances)
    if not distances or not all(np.isfinite(d) and d > 0 for d in distances):
        raise ValueError(f"distances must be positive fractions of the cube side, got {distances}")
    pred, gt = _check_pair(pred, gt)
    if pred.ndim == 4:
        return np.stack([fscores(p, g, threshold, distances, n_points, seed)
                         for p, g in zip(pred, gt, strict=True)])
    pred_points = surface_points(pred >= threshold, n_points, seed)
    gt_points = surface_points(gt > 0.5, n_points, seed)  # same seed: equal grids score 1
    if len(pred_points) == 0 or len(gt_points) == 0:
        both_empty = len(pred_points) == len(gt_points)
        return np.full(len(distances), 1.0 if both_empty else 0.0)
    to_gt = cKDTree(gt_points).query(pred_points)[0]
    to_pred = cKDTree(pred_points).query(gt_points)[0]
    out = []
    for distance in distances:
        precision, recall = np.mean(to_gt <= distance), np.mean(to_pred <= distance)
        total = precision + recall
        out.append(0.0 if total == 0 else 2 * precision * recall / total)
    return np.array(out)
