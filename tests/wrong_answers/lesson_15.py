"""Wrong answers for lesson 15 (see tests/wrong_answers/__init__.py)."""

WRONG = {
    # row and column swapped in the flat index (column * size + row)
    1: """i, j, kk = 20, 9, 27
X = -0.5 + (np.array([i, j, kk]) + 0.5) / paper.GRID_SIDE
C = cameras[37]
forward, right, up = camera_axes(C)
f = 0.5 * size / np.tan(np.radians(VIEW_ANGLE_DEG / 2))
c0 = (size - 1) / 2
depth = (X - C) @ forward
column = round(c0 + f * ((X - C) @ right) / depth)
row = round(c0 - f * ((X - C) @ up) / depth)
answer_1 = column * size + row
""",
    # the silhouette estimates' share (the other channel) instead of the raw event pixels
    2: """_v2 = (16 * paper.GRID_SIDE + 16) * paper.GRID_SIDE + 12
_silhouettes = geometry.silhouettes_from_events(frames).reshape(n, -1)
_used = frames.reshape(n, -1).any(axis=1)
answer_2 = _silhouettes[np.arange(n), table[:, _v2]][_used].mean()
""",
    # section 2's hull (exact poses) reused at every level: only the hybrid was re-run
    3: """answer_3 = {}
for level in ("exact", "angle_5deg"):
    seen = pose_study.perturbed_object(lamp, config, level)
    p = predict(models["hybrid_early.pt"], torch.from_numpy(seen["frames"]).float()[None], "cpu")
    answer_3[level] = (float(iou(hull, label)), float(iou(p[0].numpy(), seen["label"])))
""",
    # the categories where the hybrid trails E2V's per-object scores, not the hull's
    4: """_by = {}
for _id, _value in per_object[best].items():
    _other = per_object.get("e2v", per_object["events_carving"])
    _by.setdefault(category[_id], []).append(_value - _other[_id])
answer_4 = sorted(c for c, d in _by.items() if np.mean(d) < 0)
""",
}
