"""Wrong answers for lesson 04 (see tests/wrong_answers/__init__.py)."""

WRONG = {
    # halves rounded up (school rounding), and the paper's training count per category taken as
    # the whole category
    1: """answer_1 = {25: (19, 3, 3), 35: (27, 4, 4), "paper": paper.N_TRAIN // len(CATEGORIES)}
""",
    # one byte per pixel: the frames counted as uint8, not bit-packed
    2: """bytes_ours = frames_np.size
bytes_paper = paper.N_EVENT_FRAMES * paper.INPUT_SIZE_PX**2
answer_2 = (bytes_ours, bytes_paper, paper.N_SCANS * bytes_paper / 1e9)
""",
    # the splits assumed to follow the seeds as well
    3: """answer_3 = (True, 8)
""",
    # oversample fixed at 1 for every resolution (lesson 03: finer renders need more)
    4: """answer_4 = {}
for res in RESOLUTIONS:
    config = data.BuildConfig(("chair",), 1, resolution=res, frame_size=res // 2, oversample=1)
    start = time.perf_counter()
    sample = data.mesh_to_sample(mesh, config, seed=1)
    answer_4[res] = (len(sample.events), time.perf_counter() - start)
exponent_4 = np.polyfit(np.log(RESOLUTIONS), np.log([answer_4[r][0] for r in RESOLUTIONS]), 1)[0]
""",
}
