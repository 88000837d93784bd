"""Training and evaluation of E2V: AdamW + binary cross-entropy, as in the paper.

:func:`fit` is the library's one training loop (with the paper's BCE, or a focal or BCE + Dice
loss from :mod:`e2vlib.losses`): per epoch it trains on shuffled batches, one
:func:`train_step` each (forward, loss, backward, AdamW step), scores the validation split,
keeps a history, and writes ``last.pt`` and ``best.pt`` (by validation IoU at
:data:`e2vlib.paper.IOU_THRESHOLD`) atomically, with the data config in both.
:func:`evaluate` reports the Pix2Vox protocol (IoU at :data:`e2vlib.paper.IOU_THRESHOLDS`
and F-scores, overall and per category, with mean-shape baselines), scored by
:mod:`e2vlib.metrics`. Resuming, bf16, channels-last and data-parallel runs (``torchrun``)
are opt-in: :func:`e2vlib.scale.training.fit_at_scale` runs ``fit`` with them, through the
places :class:`FitHooks` names in its loop. The names a lesson or a user calls are
importable from here (``from e2vlib.train import fit, evaluate``); the code lives in four
modules, each with one job:

========================  ==================================================================
``train.recipes``         :class:`Recipe`, :data:`RECIPES` (``"paper"``, ``"tiny"``,
                          ``"tiny_step"``, ...), :func:`get_recipe`, the learning rate per
                          epoch (:func:`lr_schedule`) and per step with warm-up
                          (:func:`lr_at_step`)
``train.devices``         :func:`resolve_device` (``"auto"``: CUDA where there is one, else
                          the CPU)
``train.evaluation``      :func:`predict`, :func:`evaluate`, :func:`category_mean_shapes`,
                          and ``validation_scores`` (fit's validation pass)
``train.loop``            :func:`fit`, :func:`train_step`, :class:`FitHooks`,
                          :func:`epoch_batches` (the seeded sample order),
                          :func:`init_output_prior`, and fit's helpers (``save_run``,
                          ``epoch_line``, ``fit_settings``, ``fit_data``)
========================  ==================================================================

``recipes`` and ``devices`` import no other module of this package; ``evaluation`` imports
those two, ``loop`` all three; none imports this ``__init__``. A split held in memory
(:class:`~e2vlib.inputs.TensorSet`, :func:`~e2vlib.inputs.preload`) lives in
:mod:`e2vlib.inputs`; the score tables (:func:`~e2vlib.metrics.score_predictions`,
:func:`~e2vlib.metrics.format_category_table`) in :mod:`e2vlib.metrics`.

Introduced in notebooks/06_training.ipynb and notebooks/07_evaluation.ipynb.
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "devices": ["resolve_device"],
        "evaluation": ["category_mean_shapes", "evaluate", "predict"],
        "loop": ["FitHooks", "epoch_batches", "fit", "init_output_prior", "train_step"],
        "recipes": ["COSINE_FLOOR", "RECIPES", "Recipe", "get_recipe", "lr_at_step",
                    "lr_schedule"],
    },
)
