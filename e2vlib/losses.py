"""Training losses on occupancy logits: the paper's BCE, focal loss, BCE + soft Dice.

Every loss takes ``logits`` and ``targets`` of the same shape (``(B, 32, 32, 32)`` for
E2V; any shape ``(B, ...)`` works), targets in ``{0, 1}`` (floats), and returns a scalar
tensor; lower is better. Most voxels of a 32^3 grid are empty, so a loss that counts every
voxel alike (BCE) is dominated by the empty ones early in training (about 95 % of an
untrained model's BCE on a typical object, a quarter once trained; measured in lesson 10);
the focal loss weighs down voxels that are already classified well, and the Dice term
scores the overlap of the occupied voxels only. :func:`make_loss` gives a loss by name for
:func:`e2vlib.train.fit`.

Introduced in notebooks/10_architectures_and_losses.ipynb.
"""

from __future__ import annotations

from collections.abc import Callable

import lazy_loader

# torch loads on first use, so reading LOSSES (the command line's choices) stays torch-free
torch = lazy_loader.load("torch")

LOSSES: dict[str, str] = {
    "bce": "mean binary cross-entropy on logits (the paper's loss)",
    "focal": "sigmoid focal loss (Lin et al. 2017), gamma = 2, alpha = 0.25",
    "bce_dice": "BCE + soft Dice loss (1 - Dice of the probabilities), per sample",
}
"""Loss name -> one-line description; the names :func:`make_loss` accepts."""

FOCAL_GAMMA = 2.0
"""Focusing exponent of the focal loss (Lin et al. 2017; torchvision's default)."""

FOCAL_ALPHA = 0.25
"""Weight of the positive (occupied) class in the focal loss (Lin et al.; torchvision)."""

DICE_SMOOTH = 1.0
"""Added to the Dice numerator and denominator (in voxels): an empty target predicted
empty scores 0 instead of 0/0, and the gradient stays finite. Small next to the hundreds
to thousands of occupied voxels of a typical 32^3 object."""


def _check(logits: torch.Tensor, targets: torch.Tensor) -> None:
    if logits.shape != targets.shape:
        raise ValueError(f"logits {tuple(logits.shape)} and targets {tuple(targets.shape)} "
                         "must have the same shape (one target per logit)")


def bce(logits: torch.Tensor, targets: torch.Tensor) -> torch.Tensor:
    """Mean binary cross-entropy on logits: the paper's loss.

    ``-mean(t * log(sigmoid(z)) + (1 - t) * log(1 - sigmoid(z)))`` over every voxel of
    every sample, computed stably from the logits ``z``.

    Parameters
    ----------
    logits
        ``(B, ...)`` raw network outputs (any real numbers).
    targets
        Same shape, 0 or 1 (float).

    Returns
    -------
    torch.Tensor
        A scalar, in nats per voxel.

    Examples
    --------
    One voxel with logit 0 (probability 0.5) costs ln 2 whatever its target:

    >>> round(bce(torch.zeros(1), torch.ones(1)).item(), 4)
    0.6931
    >>> round(bce(torch.tensor([2.0, -1.0]), torch.tensor([1.0, 0.0])).item(), 4)
    0.2201
    """
    _check(logits, targets)
    return torch.nn.functional.binary_cross_entropy_with_logits(logits, targets)


def focal(logits: torch.Tensor, targets: torch.Tensor, gamma: float = FOCAL_GAMMA,
          alpha: float | None = FOCAL_ALPHA) -> torch.Tensor:
    """Sigmoid focal loss (Lin et al. 2017, "Focal Loss for Dense Object Detection"), mean.

    With ``p = sigmoid(z)`` and ``p_t = p`` where the target is 1, ``1 - p`` where it is 0,
    each voxel costs ``alpha_t * (1 - p_t) ** gamma * BCE``, ``alpha_t = alpha`` for
    occupied and ``1 - alpha`` for empty voxels (no weighting when ``alpha`` is None).
    ``gamma`` > 0 weighs down voxels that are already right (``p_t`` near 1). The same
    formula as torchvision's ``sigmoid_focal_loss`` with ``reduction="mean"``.

    Parameters
    ----------
    logits, targets
        As :func:`bce`.
    gamma
        Focusing exponent, >= 0 (0: plain BCE times ``alpha_t``).
    alpha
        Weight of the occupied class in ``[0, 1]``, or None for none.

    Returns
    -------
    torch.Tensor
        A scalar (mean over every voxel), in nats per voxel.

    Examples
    --------
    With ``gamma=0`` and ``alpha=None`` it is BCE:

    >>> z, t = torch.tensor([2.0, -1.0, 0.5]), torch.tensor([1.0, 0.0, 0.0])
    >>> bool(torch.isclose(focal(z, t, gamma=0, alpha=None), bce(z, t)))
    True

    One occupied voxel at logit 0: ``p_t = 0.5``, so ``0.25 * 0.5**2 * ln 2``:

    >>> round(focal(torch.zeros(1), torch.ones(1)).item(), 5)
    0.04332
    """
    _check(logits, targets)
    if gamma < 0:
        raise ValueError(f"gamma must be >= 0, got {gamma}")
    if alpha is not None and not 0 <= alpha <= 1:
        raise ValueError(f"alpha must be in [0, 1] or None, got {alpha}")
    ce = torch.nn.functional.binary_cross_entropy_with_logits(logits, targets, reduction="none")
    p = torch.sigmoid(logits)
    p_t = p * targets + (1 - p) * (1 - targets)
    loss = ce * (1 - p_t) ** gamma
    if alpha is not None:
        loss = loss * (alpha * targets + (1 - alpha) * (1 - targets))
    return loss.mean()


def dice_loss(logits: torch.Tensor, targets: torch.Tensor,
              smooth: float = DICE_SMOOTH) -> torch.Tensor:
    """Soft Dice loss on probabilities, per sample, mean over the batch.

    For each sample with probabilities ``P = sigmoid(z)`` and target ``G`` (sums over its
    voxels): ``1 - (2 * sum(P * G) + smooth) / (sum(P) + sum(G) + smooth)``, i.e.
    ``1 - 2|P ∩ G| / (|P| + |G|)`` smoothed. 0 for a perfect prediction, near 1 for no
    overlap.

    Parameters
    ----------
    logits, targets
        ``(B, ...)``, as :func:`bce`; each of the ``B`` samples is scored on its own.
    smooth
        Added to numerator and denominator (:data:`DICE_SMOOTH`), >= 0.

    Returns
    -------
    torch.Tensor
        A scalar in ``[0, 1)``, dimensionless.

    Examples
    --------
    A perfect prediction (probabilities 1 and 0) scores about 0:

    >>> g = torch.zeros(1, 4, 4, 4); g[0, :2] = 1
    >>> dice_loss(torch.where(g > 0, 30.0, -30.0), g).item() < 1e-6
    True

    One occupied voxel at logit 0: ``P = 0.5``, so ``1 - (2 * 0.5 + 1) / (0.5 + 1 + 1)``:

    >>> round(dice_loss(torch.zeros(1, 1), torch.ones(1, 1)).item(), 4)
    0.2
    """
    _check(logits, targets)
    if logits.ndim < 1:
        raise ValueError("dice_loss needs a batch axis: logits of shape (B, ...)")
    if smooth < 0:
        raise ValueError(f"smooth must be >= 0, got {smooth}")
    p = torch.sigmoid(logits).flatten(1)
    g = targets.flatten(1)
    overlap = (p * g).sum(1)
    dice = (2 * overlap + smooth) / (p.sum(1) + g.sum(1) + smooth)
    return (1 - dice).mean()


def bce_dice(logits: torch.Tensor, targets: torch.Tensor) -> torch.Tensor:
    """BCE plus soft Dice: :func:`bce` + :func:`dice_loss`, equal weights.

    BCE gives every voxel a gradient; the Dice term rewards overlap with the occupied
    voxels whatever their share of the grid.

    Examples
    --------
    One occupied voxel at logit 0: ``ln 2 + 0.2``:

    >>> round(bce_dice(torch.zeros(1, 1), torch.ones(1, 1)).item(), 4)
    0.8931
    """
    return bce(logits, targets) + dice_loss(logits, targets)


_FUNCTIONS: dict[str, Callable[[torch.Tensor, torch.Tensor], torch.Tensor]] = {
    "bce": bce, "focal": focal, "bce_dice": bce_dice}


def make_loss(name: str) -> Callable[[torch.Tensor, torch.Tensor], torch.Tensor]:
    """The loss called ``name`` (one of :data:`LOSSES`): ``loss(logits, targets) -> scalar``.

    Examples
    --------
    >>> loss = make_loss("focal")
    >>> round(loss(torch.zeros(1), torch.ones(1)).item(), 5)
    0.04332
    >>> sorted(LOSSES)
    ['bce', 'bce_dice', 'focal']
    """
    if name not in _FUNCTIONS:
        raise ValueError(f"unknown loss {name!r}; choose one of {', '.join(LOSSES)}")
    return _FUNCTIONS[name]
