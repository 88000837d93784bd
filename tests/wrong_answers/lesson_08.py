"""Wrong answers for lesson 08 (see tests/wrong_answers/__init__.py)."""

WRONG = {
    # the extent along x (column 0) instead of the time axis (column 1)
    1: """cloud_1ms = viz.event_cloud(events, sensor_size, max_events=MAX_POINTS, t_scale=1.0)
answer_1 = float(np.ptp(cloud_1ms.points[:, 0]))
""",
    # a voxel's volume left in cubic metres instead of litres
    2: """voxel_m3 = (1 / paper.GRID_SIDE) ** 3
litres = [float(np.sum(probabilities >= t) * voxel_m3) for t in THRESHOLDS]
gap_2 = np.abs(np.array(litres) - label.sum() * voxel_m3)
answer_2 = {"litres": litres, "closest": THRESHOLDS[int(np.argmin(gap_2))]}
""",
    # each cut edge's prism taken as a square, not a right triangle (the 1/2 left out)
    3: """h = 1 / (2 * paper.GRID_SIDE)
answer_3 = 0.125 - 12 * 0.5 * h**2
""",
    # the STL's volume left in cubic metres
    4: """label_paths = viz.export_reconstruction(label.astype(np.float32), out_dir, threshold=0.5,
                                        name="label", formats=("binvox", "stl"))
stl = trimesh.load(label_paths["stl"], force="mesh")
answer_4 = {"binvox": voxels.read_binvox(label_paths["binvox"]), "stl_litres": float(stl.volume)}
""",
    # the voxels' volume instead of the marching-cubes mesh's
    5: """answer_5 = [float(np.sum(probabilities >= t) * 1000 / paper.GRID_SIDE ** 3)
            for t in THRESHOLDS]
""",
}
