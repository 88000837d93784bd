"""The choices of :func:`e2vlib.scale.training.fit_at_scale`'s options, importable without
torch (the command line's help lists them).
"""

PRECISIONS = ("fp32", "bf16")
"""The ``precision=`` choices of :func:`~e2vlib.scale.training.fit_at_scale` (``train
--precision``): float32 everywhere, or the training forward pass under bfloat16 autocast."""
