"""Wrong answers for the appendix notebook, notebooks/appendix_going_further.ipynb (see
tests/wrong_answers/__init__.py)."""

WRONG = {
    # reading (a) computed at the literal 20 % of the cube instead of 0.2 voxel
    1: """answer_1 = {n: metrics.fscores(probs, labels, T, (D1, D20), n_points=n)
            for n in (512, 8192)}
""",
}
