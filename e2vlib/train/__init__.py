"""Training and evaluation of E2V: AdamW + binary cross-entropy, as in the paper.

:func:`fit` trains (with the paper's BCE, or a focal or BCE + Dice loss from
:mod:`e2vlib.losses`) with progress bars, keeps a per-epoch history, writes ``last.pt`` and
``best.pt`` (by validation IoU at :data:`e2vlib.paper.IOU_THRESHOLD`) atomically every
epoch, stores the data config in both, resumes exactly from ``last.pt``, and runs
data-parallel when launched with ``torchrun``. :func:`evaluate` reports the Pix2Vox
protocol (IoU at :data:`e2vlib.paper.IOU_THRESHOLDS` and F-scores, overall and per
category, with mean-shape baselines), scored by :mod:`e2vlib.metrics`. Every public name is
importable from here (``from e2vlib.train import fit, evaluate, TensorSet``); the code lives
in four modules, each with one job:

========================  ==================================================================
``train.recipes``         :class:`Recipe`, :data:`RECIPES` (``"paper"``, ``"tiny"``,
                          ``"tiny_step"``), :func:`get_recipe`, the learning rate per epoch
                          (:func:`lr_schedule`) and per step with warm-up
                          (:func:`lr_at_step`)
``train.devices``         :func:`resolve_device`, :func:`bf16_is_fast`,
                          :func:`to_channels_last`, :data:`PRECISIONS`,
                          :func:`init_distributed_from_env`
``train.loop``            :func:`fit`, :func:`init_output_prior` and what resuming checks
                          (:func:`resume_problems`, :func:`read_resume_state`)
``train.evaluation``      :func:`predict`, :func:`evaluate`, :func:`category_mean_shapes`
========================  ==================================================================

``recipes`` and ``devices`` import no other module of this package; ``evaluation`` imports
those two, ``loop`` all three; none imports this ``__init__``. :class:`TensorSet` and
:func:`preload` (a split held in memory) live in :mod:`e2vlib.inputs` and are re-exported
here, as are the score tables
(:func:`~e2vlib.metrics.score_predictions`, :func:`~e2vlib.metrics.format_table`,
:data:`~e2vlib.metrics.METRIC_KEYS`) of :mod:`e2vlib.metrics`.

Introduced in notebooks/06_training.ipynb and notebooks/07_evaluation.ipynb.
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "devices": [
            "PRECISIONS", "bf16_is_fast", "init_distributed_from_env", "resolve_device",
            "to_channels_last",
        ],
        "evaluation": ["VAL_BATCH", "category_mean_shapes", "evaluate", "predict"],
        "loop": [
            "LEGACY_LOSS", "RESUME_KEYS", "fit", "init_output_prior", "read_resume_state",
            "resume_problems",
        ],
        "recipes": [
            "COSINE_FLOOR", "RECIPES", "WARMUP_STEPS", "get_recipe", "lr_at_step", "lr_schedule",
            "Recipe",
        ],
    },
)
