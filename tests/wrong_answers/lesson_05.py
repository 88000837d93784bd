"""Wrong answers for lesson 05 (see tests/wrong_answers/__init__.py)."""

WRONG = {
    # the two BatchNorms forgotten
    1: """answer_1 = 2 * 27 * 64 * 64
""",
    # the stages' halving rounded down instead of up
    2: """dims = [conv_out(conv_out(n, 7, 2, 3), 3, 2, 1) for n in (100, 128, 128)]
for _ in range(3):
    dims = [n // 2 for n in dims]
answer_2 = 2048 * int(np.prod(dims)) // G**3
""",
    # the biases of the two Linear layers left out
    3: """extra_features = 2048 - paper_net.config.bottleneck_features
predicted_3 = count_parameters(paper_net) + extra_features * 2 * 128 * 4**3
with torch.device("meta"):
    measured_3 = count_parameters(build_e2v("paper", bottleneck_features=2048))
""",
    # the whole models compared instead of their encoders
    4: """answer_4 = count_parameters(build_e2v("tiny2d")) / count_parameters(tiny)
""",
    # every part assumed to grow with the frame's pixel count
    5: """saved = {r["name"]: r["saved_bytes"] for r in layer_table(tiny)}
predicted_5 = 4 * sum(saved.values())
with torch.device("meta"):
    measured_5 = activation_bytes(build_e2v("tiny", input_shape=(100, 128, 128)), batch_size=1)
""",
}
