"""Reconstruction metrics: voxel IoU and surface F-score, as in Pix2Vox / Pix2Vox++.

Predictions are occupancy probabilities in [0, 1] (``sigmoid(logits)``), ground truth is
a 0/1 grid; both ``(32, 32, 32)`` or batched ``(B, 32, 32, 32)``, numpy or torch.

Introduced in notebooks/07_evaluation.ipynb.
"""

from __future__ import annotations

import numpy as np

from e2vlib import paper

IOU_THRESHOLDS = paper.IOU_THRESHOLDS  # the thresholds Pix2Vox reports (our choice to follow)

FSCORE_DISTANCES = {"fscore@1%": paper.FSCORE_DISTANCE,
                    "fscore@20%": paper.FSCORE_DISTANCE_REPORTED}
"""The F-score columns: the metric key and its distance (fraction of the object's extent)."""

METRIC_KEYS = tuple(f"iou@{t}" for t in IOU_THRESHOLDS) + tuple(FSCORE_DISTANCES)
"""Every metric of a score table, in the column order of the paper's Tables I and II."""


MAX_SURFACE_POINTS = 2**20
"""Most surface points :func:`fscore` samples per grid (1,048,576; 8192 is usual): two
k-d trees of that many points take about 100 MiB."""


def check_threshold(threshold: float) -> float:
    """``threshold`` as a float if it is a number in [0, 1], else ValueError: a
    probability threshold outside it (or NaN) would score every grid as empty or full.

    >>> check_threshold(0.3)
    0.3
    >>> check_threshold(2)
    Traceback (most recent call last):
    ...
    ValueError: threshold must be a probability in [0, 1] (0.3 is usual), got 2
    """
    if isinstance(threshold, bool) or not isinstance(threshold, int | float | np.number) or \
            not 0.0 <= float(threshold) <= 1.0:  # NaN fails the comparison
        raise ValueError(f"threshold must be a probability in [0, 1] (0.3 is usual), got "
                         f"{threshold!r}")
    return float(threshold)


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
    threshold = check_threshold(threshold)
    pred, gt = _check_pair(pred, gt)
    p = pred >= threshold
    g = gt > 0.5
    axes = tuple(range(p.ndim - 3, p.ndim))
    inter = np.logical_and(p, g).sum(axis=axes)
    union = np.logical_or(p, g).sum(axis=axes)
    result = np.where(union > 0, inter / np.maximum(union, 1), 1.0)
    return float(result) if result.ndim == 0 else result


def grid_surface(grid: np.ndarray, level: float = 0.5) -> tuple[np.ndarray, np.ndarray]:
    """Marching-cubes iso-surface ``grid == level`` of a ``(R, R, R)`` grid, padded by one
    layer of zeros so it closes at the border: ``(vertices (n, 3) in metres, faces (m, 3))``,
    voxel ``i`` centred at ``-0.5 + (i + 0.5) / R`` (the unit cube of the labels). Both the
    F-score's surface samples and the 3D views' meshes come from here.

    Examples
    --------
    >>> grid = np.zeros((4, 4, 4)); grid[1:3, 1:3, 1:3] = 1   # the middle 2^3 of 4^3
    >>> vertices, faces = grid_surface(grid)
    >>> float(vertices.min()), float(vertices.max()), faces.shape[1]  # halfway to the empty
    (-0.25, 0.25, 3)
    """
    from skimage.measure import marching_cubes

    grid = np.asarray(grid, dtype=np.float32)
    vertices, faces, _, _ = marching_cubes(np.pad(grid, 1), level=float(level))
    return (vertices - 1 + 0.5) / grid.shape[0] - 0.5, faces  # padded index -> metres


def surface_points(occupancy: np.ndarray, n_points: int = 8192, seed: int = 0) -> np.ndarray:
    """``(n_points, 3)`` points sampled uniformly on the surface of a binary grid.

    The surface is the marching-cubes iso-surface (level 0.5) of the grid padded by one
    empty voxel, mapped to the unit cube ``[-0.5, 0.5]^3`` (voxel ``i`` is centred at
    ``-0.5 + (i + 0.5) / R``). An empty grid gives ``(0, 3)``.
    """
    import trimesh

    occupancy = np.asarray(occupancy, dtype=bool)
    if not occupancy.any():
        return np.zeros((0, 3))
    vertices, faces = grid_surface(occupancy, 0.5)
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

    threshold = check_threshold(threshold)
    if isinstance(n_points, bool) or not isinstance(n_points, int | np.integer) or not (
            1 <= n_points <= MAX_SURFACE_POINTS):
        raise ValueError(f"n_points must be a positive integer of at most "
                         f"{MAX_SURFACE_POINTS} (8192 is usual), got {n_points!r}")
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


def surface_voxels(occupancy) -> np.ndarray:
    """The surface voxels of a binary grid: occupied, with an empty face neighbour.

    A voxel is on the surface when at least one of its 6 face neighbours is empty;
    outside the grid counts as empty, so occupied voxels on the grid's border are surface
    voxels. Returns a ``bool`` array of the grid's shape ``(D, H, W)``.
    Introduced in notebooks/07_evaluation.ipynb.

    Examples
    --------
    >>> grid = np.zeros((32, 32, 32), dtype=bool); grid[8:11, 8:11, 8:11] = True
    >>> int(surface_voxels(grid).sum())     # a 3^3 block: all but its centre voxel
    26
    >>> bool(surface_voxels(grid)[9, 9, 9])
    False
    """
    from scipy import ndimage

    occupancy = np.asarray(occupancy, dtype=bool)
    if occupancy.ndim != 3:
        raise ValueError(f"surface_voxels needs one (D, H, W) grid, got shape {occupancy.shape}; "
                         "loop over a batch")
    faces = ndimage.generate_binary_structure(3, 1)  # the 6 face neighbours
    interior = ndimage.binary_erosion(occupancy, structure=faces, border_value=0)
    return occupancy & ~interior


def surface_voxel_fscore(pred, gt, threshold: float = paper.IOU_THRESHOLD,
                         tolerance_voxels: float = 0.0):
    """F-score of the surface voxels of ``pred >= threshold`` and ``gt > 0.5``.

    One reading of the paper's unexplained F-Score@20 % (notebooks/07_evaluation.ipynb
    tests it against Table II): no points are sampled; the surface voxels
    (:func:`surface_voxels`) of the two grids are compared directly. Precision is the share
    of predicted surface voxels whose centre lies within ``tolerance_voxels`` (Euclidean,
    in voxels) of a ground-truth surface voxel's centre, recall the reverse, and
    F = 2PR / (P + R). With the default ``tolerance_voxels=0`` only surface voxels that
    coincide exactly count. Two grids without surface score 1, one without 0 (as
    :func:`fscore`). Returns a float for one grid, ``(B,)`` for a batch.

    Examples
    --------
    >>> gt = np.zeros((32, 32, 32)); gt[8:11, 8:11, 8:11] = 1   # 26 surface voxels
    >>> pred = np.roll(gt, 1, axis=0)           # moved one voxel along x: 16 of 26 coincide
    >>> round(surface_voxel_fscore(pred, gt), 4)                 # P = R = 16 / 26
    0.6154
    >>> surface_voxel_fscore(pred, gt, tolerance_voxels=1)       # all within one voxel
    1.0
    """
    from scipy import ndimage

    if isinstance(tolerance_voxels, bool) or not np.isfinite(tolerance_voxels) \
            or tolerance_voxels < 0:
        raise ValueError("tolerance_voxels must be a distance in voxels >= 0 (0: surface "
                         f"voxels must coincide), got {tolerance_voxels!r}")
    threshold = check_threshold(threshold)
    pred, gt = _check_pair(pred, gt)
    if pred.ndim == 4:
        return np.array([surface_voxel_fscore(p, g, threshold, tolerance_voxels)
                         for p, g in zip(pred, gt, strict=True)])
    pred_surface, gt_surface = surface_voxels(pred >= threshold), surface_voxels(gt > 0.5)
    if not pred_surface.any() or not gt_surface.any():
        return 1.0 if pred_surface.any() == gt_surface.any() else 0.0
    if tolerance_voxels == 0:
        pred_hits = gt_hits = pred_surface & gt_surface
    else:  # distance of every voxel centre to the nearest surface voxel of the other grid
        pred_hits = pred_surface & (ndimage.distance_transform_edt(~gt_surface)
                                    <= tolerance_voxels)
        gt_hits = gt_surface & (ndimage.distance_transform_edt(~pred_surface)
                                <= tolerance_voxels)
    precision = pred_hits.sum() / pred_surface.sum()
    recall = gt_hits.sum() / gt_surface.sum()
    total = precision + recall
    return 0.0 if total == 0 else float(2 * precision * recall / total)


def interval95(values) -> tuple[float, float]:
    """95 % interval of the mean of ``values`` (Student's t with n - 1 degrees of freedom);
    ``(nan, nan)`` for fewer than two values. The one interval of every study and table.

    Examples:
        >>> low, high = interval95([0.4, 0.5, 0.6])  # mean 0.5, s 0.1, t(0.975, 2) 4.303
        >>> round(low, 3), round(high, 3)
        (0.252, 0.748)
    """
    from scipy import stats

    v = np.asarray(values, dtype=np.float64).ravel()
    if len(v) < 2:
        return (float("nan"), float("nan"))
    half = float(stats.t.ppf(0.975, len(v) - 1)) * float(v.std(ddof=1)) / np.sqrt(len(v))
    return (float(v.mean() - half), float(v.mean() + half))


def category_means(values, categories) -> dict[str, float]:
    """Mean of per-sample ``values`` ``(N,)`` over the samples of each category.

    ``categories`` holds one name per sample (``(N,)``); the result is ``{category: mean}``
    in first-seen order. This is how per-category columns of the paper's Tables I and II
    are averaged (the overall number is the mean over all samples, not over categories).
    Introduced in notebooks/07_evaluation.ipynb.

    Examples
    --------
    >>> category_means([0.25, 0.75, 0.9], ["chair", "chair", "lamp"])
    {'chair': 0.5, 'lamp': 0.9}
    """
    values = np.asarray(_to_numpy(values), dtype=float)
    cats = np.asarray(categories)
    if values.ndim != 1 or values.shape != cats.shape:
        raise ValueError(f"values and categories need one entry per sample, got shapes "
                         f"{values.shape} and {cats.shape}")
    return {str(c): float(values[cats == c].mean()) for c in dict.fromkeys(cats)}


def score_table(scores, categories) -> dict:
    """Per-sample scores -> the layout of :func:`e2vlib.train.evaluate`'s result.

    ``scores`` maps a metric name to per-sample values ``(N,)`` (for example the output of
    :func:`score_predictions`), ``categories`` holds one name per sample.
    Returns ``{"overall": {metric: mean over all samples}, "per_category": {category:
    {metric: mean over its samples, "n": count}}}`` (categories in first-seen order), so
    :func:`format_category_table` prints it in the layout of the paper's Tables I and
    II; notebooks/07_evaluation.ipynb uses it for the per-category oracle.

    Examples
    --------
    >>> table = score_table({"iou@0.3": [0.25, 0.75, 1.0]}, ["chair", "chair", "lamp"])
    >>> table["overall"], table["per_category"]["chair"]
    ({'iou@0.3': 0.6666666666666666}, {'iou@0.3': 0.5, 'n': 2})
    """
    per_metric = {key: category_means(values, categories) for key, values in scores.items()}
    cats = list(dict.fromkeys(np.asarray(categories).tolist()))
    counts = {c: int(np.sum(np.asarray(categories) == c)) for c in cats}
    return {
        "overall": {key: float(np.mean(_to_numpy(values))) for key, values in scores.items()},
        "per_category": {c: {**{key: means[c] for key, means in per_metric.items()},
                             "n": counts[c]} for c in cats},
    }


def score_predictions(probabilities, voxels, fscore_points: int = 8192) -> dict[str, np.ndarray]:
    """Per-sample metrics of predictions ``(N, 32, 32, 32)`` against labels of the same
    shape: ``{"iou@0.2": (N,), ..., "fscore@1%": (N,), "fscore@20%": (N,)}``
    (:data:`METRIC_KEYS`).

    F-scores use :data:`e2vlib.paper.IOU_THRESHOLD` (Pix2Vox++'s choice) and
    ``fscore_points`` surface samples.

    Examples
    --------
    >>> gt = np.zeros((2, 32, 32, 32)); gt[:, 8:24, 8:24, 8:24] = 1
    >>> p = np.stack([gt[0] * 0.9, gt[1] * 0.35])   # sample 1 is occupied only below 0.4
    >>> scores = score_predictions(p, gt, fscore_points=512)
    >>> list(scores) == list(METRIC_KEYS), scores["iou@0.3"].tolist(), scores["iou@0.4"].tolist()
    (True, [1.0, 1.0], [1.0, 0.0])
    """
    scores = {f"iou@{t}": np.atleast_1d(iou(probabilities, voxels, threshold=t))
              for t in IOU_THRESHOLDS}
    f = fscores(probabilities, voxels, threshold=paper.IOU_THRESHOLD,
                distances=tuple(FSCORE_DISTANCES.values()), n_points=fscore_points)
    for column, key in enumerate(FSCORE_DISTANCES):
        scores[key] = np.atleast_2d(f)[:, column]
    return scores


def score_split(probabilities, voxels, categories, fscore_points: int = 8192) -> dict:
    """Score predictions of a whole split: :func:`score_table` of :func:`score_predictions`,
    plus ``"scores"`` (the per-sample arrays). What :func:`e2vlib.train.evaluate`, the
    experiment runner and the geometry study report.

    Examples
    --------
    >>> gt = np.zeros((3, 32, 32, 32)); gt[:, :16] = 1
    >>> p = np.stack([gt[0] * 0.9, gt[1] * 0.9, 1 - gt[2]])   # the lamp is inside out
    >>> result = score_split(p, gt, ["chair", "chair", "lamp"], fscore_points=512)
    >>> result["per_category"]["chair"]["iou@0.3"], result["per_category"]["lamp"]["iou@0.3"]
    (1.0, 0.0)
    >>> round(result["overall"]["iou@0.3"], 3), result["scores"]["iou@0.3"].shape
    (0.667, (3,))
    """
    scores = score_predictions(probabilities, voxels, fscore_points)
    return {**score_table(scores, categories), "scores": scores}


def format_category_table(result: dict, categories=None, keys=METRIC_KEYS) -> str:
    """The per-category table of a :func:`score_table` / :func:`score_split` result (or
    :func:`e2vlib.train.evaluate`'s, with its baselines) in the layout of the paper's
    Tables I and II, as text; ``categories`` default to the paper's order.

    Examples
    --------
    >>> result = score_table({"iou@0.3": [0.25, 0.75]}, ["chair", "chair"])
    >>> print(format_category_table(result, keys=("iou@0.3",)))
    category        n    iou@0.3
    ----------------------------
    chair           2      0.500
    ----------------------------
    overall         2      0.500
    """
    categories = categories or [c for c in paper.CATEGORIES if c in result["per_category"]]
    header = f"{'category':<12} {'n':>4} " + " ".join(f"{k:>10}" for k in keys)
    lines = [header, "-" * len(header)]
    for c in categories:
        row = result["per_category"][c]
        lines.append(f"{c:<12} {row['n']:>4} " + " ".join(f"{row[k]:>10.3f}" for k in keys))
    lines.append("-" * len(header))
    n = sum(result["per_category"][c]["n"] for c in categories)
    lines.append(f"{'overall':<12} {n:>4} "
                 + " ".join(f"{result['overall'][k]:>10.3f}" for k in keys))
    for name, label in (("baseline_mean_shape", "mean shape"),
                        ("baseline_category_mean", "cat. mean")):
        if name in result:
            lines.append(f"{label:<12} {'':>4} "
                         + " ".join(f"{result[name][k]:>10.3f}" for k in keys))
    return "\n".join(lines)
