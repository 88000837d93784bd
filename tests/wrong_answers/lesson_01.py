"""Wrong answers for lesson 01 (see tests/wrong_answers/__init__.py)."""

WRONG = {
    # ON and OFF swapped
    1: """first_100ms = events[: np.searchsorted(events["t"], events["t"][0] + 100_000)]
answer_1 = (int(np.sum(first_100ms["p"] == -1)), int(np.sum(first_100ms["p"] == 1)))
""",
    # time left in seconds and polarity kept as 0
    2: "answer_2 = (17, 4, 0.0125, 0)\n",
    # x and y swapped (the image is indexed [y, x])
    3: """per_pixel = np.bincount(events["y"].astype(int) * width + events["x"],
                        minlength=width * height)
y_max, x_max = divmod(int(per_pixel.argmax()), width)
answer_3 = (y_max, x_max, int(per_pixel.max()))
""",
    # one event per started multiple of C (ceil), and the "measurement" copied from it
    4: """predicted_4 = {c: (int(np.ceil(np.log(1 / 0.3) / c)),) * 2 for c in (0.1, 0.2, 0.4)}
measured_4 = dict(predicted_4)
""",
    # events counted instead of fired pixels (a pixel that fires twice counts twice)
    5: """answer_5 = (np.sum(events["t"] < events["t"][0] + 10 * paper.DT_US)
            / np.sum(events["t"] < events["t"][0] + paper.DT_US))
""",
}
