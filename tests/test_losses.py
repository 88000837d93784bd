"""Tests for e2vlib.losses: hand-computed values of BCE, focal and Dice losses."""

import math

import pytest
import torch

from e2vlib.losses import (
    DICE_SMOOTH,
    FOCAL_ALPHA,
    FOCAL_GAMMA,
    LOSSES,
    bce,
    bce_dice,
    dice_loss,
    focal,
    make_loss,
)

LN2 = math.log(2)


def sigmoid(z: float) -> float:
    return 1 / (1 + math.exp(-z))


def test_bce_by_hand():
    assert bce(torch.zeros(1), torch.ones(1)).item() == pytest.approx(LN2)
    assert bce(torch.zeros(3), torch.zeros(3)).item() == pytest.approx(LN2)
    # logit 2 with target 1, logit -1 with target 0: -ln(sigmoid(2)), -ln(1 - sigmoid(-1))
    want = (-math.log(sigmoid(2)) - math.log(1 - sigmoid(-1))) / 2
    got = bce(torch.tensor([2.0, -1.0]), torch.tensor([1.0, 0.0])).item()
    assert got == pytest.approx(want, rel=1e-6)
    assert want == pytest.approx(0.22009, abs=1e-5)


def test_focal_defaults_are_lin_et_al():
    assert (FOCAL_GAMMA, FOCAL_ALPHA) == (2.0, 0.25)


@pytest.mark.parametrize(("z", "t"), [(0.0, 1.0), (0.0, 0.0), (2.0, 1.0), (2.0, 0.0),
                                      (-3.0, 1.0), (-3.0, 0.0)])
def test_focal_single_voxel_by_hand(z, t):
    p = sigmoid(z)
    ce = -math.log(p) if t == 1 else -math.log(1 - p)
    p_t = p if t == 1 else 1 - p
    alpha_t = 0.25 if t == 1 else 0.75
    want = alpha_t * (1 - p_t) ** 2 * ce
    got = focal(torch.tensor([z]), torch.tensor([t])).item()
    assert got == pytest.approx(want, rel=1e-5)


def test_focal_known_values():
    # logit 0, target 1: 0.25 * 0.5^2 * ln 2; target 0: 0.75 * 0.5^2 * ln 2
    assert focal(torch.zeros(1), torch.ones(1)).item() == pytest.approx(0.0625 * LN2)
    assert focal(torch.zeros(1), torch.zeros(1)).item() == pytest.approx(0.1875 * LN2)
    # the mean of the two
    assert focal(torch.zeros(2), torch.tensor([1.0, 0.0])).item() == pytest.approx(
        0.125 * LN2)
    # gamma=0, alpha=None is BCE; gamma=0 with alpha is alpha_t-weighted BCE
    z = torch.tensor([2.0, -1.0, 0.5, -4.0])
    t = torch.tensor([1.0, 0.0, 0.0, 1.0])
    assert torch.isclose(focal(z, t, gamma=0, alpha=None), bce(z, t))
    ce = torch.nn.functional.binary_cross_entropy_with_logits(z, t, reduction="none")
    weighted = (ce * torch.tensor([0.25, 0.75, 0.75, 0.25])).mean()
    assert torch.isclose(focal(z, t, gamma=0), weighted)


def test_focal_weighs_down_easy_voxels():
    # a well-classified voxel (p_t = 0.95) loses far more than a hard one (p_t = 0.3)
    easy, hard = torch.tensor([math.log(0.95 / 0.05)]), torch.tensor([math.log(0.3 / 0.7)])
    ratio_bce = bce(easy, torch.ones(1)) / bce(hard, torch.ones(1))
    ratio_focal = focal(easy, torch.ones(1)) / focal(hard, torch.ones(1))
    assert ratio_focal.item() == pytest.approx(ratio_bce.item() * (0.05 / 0.7) ** 2, rel=1e-4)


def test_dice_by_hand_per_sample():
    g = torch.zeros(2, 8)
    g[0, :2] = 1  # sample 0: predicted perfectly
    g[1, 0] = 1   # sample 1: probabilities 0.5 everywhere
    z = torch.stack([torch.where(g[0] > 0, 40.0, -40.0), torch.zeros(8)])
    # sample 1: |P| = 4, |G| = 1, |P n G| = 0.5 -> 1 - (2 * 0.5 + 1) / (4 + 1 + 1) = 2/3
    assert dice_loss(z[1:], g[1:]).item() == pytest.approx(2 / 3)
    assert dice_loss(z[:1], g[:1]).item() == pytest.approx(0.0, abs=1e-6)
    # the mean over the batch of per-sample losses (1/3), not one Dice over the whole
    # batch: that would be 1 - (2 * 2.5 + 1) / (6 + 3 + 1) = 0.4
    assert dice_loss(z, g).item() == pytest.approx(1 / 3)


def test_dice_extremes():
    g = torch.zeros(1, 8, 8, 8)
    g[0, :4] = 1
    perfect = torch.where(g > 0, 30.0, -30.0)
    assert dice_loss(perfect, g).item() == pytest.approx(0.0, abs=1e-6)
    # no overlap: 1 - smooth / (|P| + |G| + smooth) with |P| = |G| = 256
    assert dice_loss(-perfect, g).item() == pytest.approx(1 - DICE_SMOOTH / 513, abs=1e-6)
    # an empty target predicted empty scores 0 (the smoothing avoids 0/0)
    empty = torch.zeros(1, 8, 8, 8)
    assert dice_loss(torch.full_like(empty, -30.0), empty).item() == pytest.approx(0, abs=1e-6)
    # single voxel at logit 0: 1 - (2 * 0.5 + 1) / (0.5 + 1 + 1)
    assert dice_loss(torch.zeros(1, 1), torch.ones(1, 1)).item() == pytest.approx(0.2)


def test_bce_dice_is_the_sum():
    g = (torch.rand(3, 6, 6, 6, generator=torch.Generator().manual_seed(0)) < 0.3).float()
    z = torch.randn(3, 6, 6, 6, generator=torch.Generator().manual_seed(1))
    assert torch.isclose(bce_dice(z, g), bce(z, g) + dice_loss(z, g))
    assert bce_dice(torch.zeros(1, 1), torch.ones(1, 1)).item() == pytest.approx(LN2 + 0.2)


@pytest.mark.parametrize("name", list(LOSSES))
def test_every_loss_has_finite_gradients_even_at_extreme_logits(name):
    loss = make_loss(name)
    z = torch.tensor([[-100.0, 100.0, 0.0, 100.0]], requires_grad=True)
    t = torch.tensor([[1.0, 0.0, 1.0, 1.0]])
    value = loss(z, t)
    value.backward()
    assert torch.isfinite(value) and torch.isfinite(z.grad).all()
    # pushing the wrong voxels towards their targets lowers the loss
    assert z.grad[0, 0] < 0 and z.grad[0, 1] > 0


def test_make_loss_names_and_errors():
    assert list(LOSSES) == ["bce", "focal", "bce_dice"]
    assert make_loss("bce") is bce and make_loss("focal") is focal
    assert make_loss("bce_dice") is bce_dice
    with pytest.raises(ValueError, match="unknown loss 'dice'; choose one of bce, focal, "
                                         "bce_dice"):
        make_loss("dice")
    with pytest.raises(ValueError, match=r"logits \(2, 3\) and targets \(3, 2\)"):
        bce(torch.zeros(2, 3), torch.zeros(3, 2))
    with pytest.raises(ValueError, match="gamma must be >= 0"):
        focal(torch.zeros(1), torch.ones(1), gamma=-1)
    with pytest.raises(ValueError, match="alpha must be in"):
        focal(torch.zeros(1), torch.ones(1), alpha=1.5)
