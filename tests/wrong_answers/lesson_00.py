"""Wrong answers for lesson 00 (see tests/wrong_answers/__init__.py)."""

WRONG = {
    # precision (TP / predicted) in place of IoU
    1: """answer_1 = {t: float(np.sum((probabilities >= t) & label) / np.sum(probabilities >= t))
            for t in paper.IOU_THRESHOLDS}
best_threshold_1 = max(answer_1, key=answer_1.get)
""",
    # FP and FN swapped
    2: """predicted = probabilities >= THRESHOLD
answer_2 = (int(np.sum(predicted & label)), int(np.sum(~predicted & label)),
            int(np.sum(predicted & ~label)))
""",
    # scored at 0.5 instead of our threshold
    3: """ant = examples.load_ant()
ant_mesh = trimesh.Trimesh(ant.points, ant.faces.reshape(-1, 4)[:, 1:])
ant_sample = data.mesh_to_sample(ant_mesh, config, seed=0)
ant_probs = train.predict(model, torch.from_numpy(ant_sample.frames)[None],
                          device="cpu")[0].numpy()
answer_3 = (metrics.iou(ant_probs, ant_sample.voxels, threshold=0.5),
            metrics.iou(mean_shape, ant_sample.voxels, threshold=0.5))
""",
    # C = 0.2 and 0.4 simulated, C = 0.1 guessed from 1 / C (twice the events, the same IoU)
    4: """answer_4 = {}
for c in (0.2, 0.4):
    ev = simulate.simulate_events(video, t_us, contrast_pos=c, contrast_neg=c, seed=0)
    stack = inputs.orbit_input(ev, (RES, RES), frame_size=64)
    probs = train.predict(model, torch.from_numpy(stack)[None], device="cpu")[0].numpy()
    answer_4[c] = (len(ev), metrics.iou(probs, label, threshold=THRESHOLD))
answer_4[0.1] = (2 * answer_4[0.2][0], answer_4[0.2][1])
""",
}
