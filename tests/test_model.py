"""Tests for e2vlib.model: shapes, parameter counts, seeding, gradients, errors.

Checkpoint files are tested in test_checkpoint.py.
"""

from dataclasses import replace

import pytest
import torch

from e2vlib import paper
from e2vlib.model import (
    PAPER_PARAMETERS,
    PRESETS,
    BasicBlock,
    Bottleneck,
    Bridge,
    E2VConfig,
    Frames2dEncoder,
    Frames2dGRUEncoder,
    ResNetEncoder,
    UNetDecoder,
    activation_bytes,
    build_e2v,
    count_parameters,
    parameter_breakdown,
)
from e2vlib.model.config import GRID_SIDE
from e2vlib.model.summary import format_layer_table, layer_table

SMALL = (16, 32, 32)  # a quick input: stem -> 8x16x16, pool -> 4x8x8, ... -> 1x1x1


def small_model(**overrides):
    kw = {"input_shape": SMALL, "seed": 0} | overrides
    return build_e2v("tiny", **kw)


@pytest.fixture(scope="module")
def paper_meta():
    with torch.device("meta"):
        return build_e2v("paper")


# ----------------------------------------------------------------------------- shapes


@pytest.mark.parametrize(
    "overrides",
    [
        {},
        {"bridge": "interp", "hidden_channels": 3},
        {"bridge": "fc", "seed_size": 8, "bottleneck": "conv"},
        {"depth": 18, "norm": "group", "bottleneck": "none"},
        {"depth": 50, "base_width": 4, "decoder_widths": (8, 16)},
        {"depth": 10, "block": "bottleneck", "stem_kernel": 7, "stem_pool": False},
        {"encoder": "frames2d"},
        {"encoder": "frames2d_gru"},
        {"encoder": "frames2d_gru", "gru_pool": 2, "gru_hidden": 32},
        {"input_shape": (9, 20, 28)},  # odd sizes round up through every stride
    ],
)
def test_output_shape_for_several_configs(overrides):
    model = small_model(**overrides)
    x = torch.rand(2, *model.input_shape)
    y = model(x)
    assert y.shape == (2, 32, 32, 32)
    assert y.dtype == torch.float32 and torch.isfinite(y).all()


def test_tiny_preset_matches_data_small_frames_and_is_small():
    model = build_e2v("tiny")
    assert model.input_shape == (100, 64, 64)
    assert count_parameters(model) < 5_000_000
    # (100, 64, 64): stem stride 2 -> (50, 32, 32), pool -> (25, 16, 16), then halve 3x
    assert model.encoder_shape == (64, 4, 2, 2)
    assert model.bridge.kind == "fc"  # the global bridge the prototype needed
    with torch.no_grad():
        assert model.eval()(torch.zeros(1, 100, 64, 64)).shape == (1, 32, 32, 32)


@pytest.mark.parametrize(
    ("input_shape", "channels"),
    # ResNet-152 ends with 2048 channels; each of d, h, w shrinks by 32 (rounding up):
    # (50, 256, 256) -> (2, 8, 8): 2048 * 128 = 8 * 32^3; (20, 128, 128) -> (1, 4, 4):
    # 2048 * 16 = 1 * 32^3. (The paper's (100, 256, 256) -> C = 16 is checked below.)
    [((50, 256, 256), 8), ((20, 128, 128), 1)],
)
def test_reshape_bridge_channels_follow_input_shape(input_shape, channels):
    with torch.device("meta"):
        model = build_e2v("paper", input_shape=input_shape)
        y = model(torch.empty(1, *input_shape))
    assert model.hidden_channels == channels
    assert count_parameters(model.head) == channels + 1
    assert y.shape == (1, 32, 32, 32)


def test_reshape_bridge_rejects_inputs_that_do_not_fill_32_cubed():
    # (30, 64, 64) -> (1, 2, 2): 2048 * 4 = 8192 values, a quarter of 32^3.
    with pytest.raises(ValueError, match=r"\(2048, 1, 2, 2\).*multiple of 32\^3"):
        with torch.device("meta"):
            build_e2v("paper", input_shape=(30, 64, 64))


# ----------------------------------------------------------------------------- the paper


def test_resnet152_3d_trunk_parameter_count(paper_meta):
    assert paper_meta.encoder.out_channels == 2048
    assert count_parameters(paper_meta.encoder) == 117_359_936


def test_paper_preset_within_two_percent_of_paper(paper_meta):
    total = count_parameters(paper_meta)
    assert abs(total - PAPER_PARAMETERS) / PAPER_PARAMETERS < 0.02
    parts = parameter_breakdown(paper_meta)
    assert parts["total"] == total
    assert parts["bridge"] == 0  # reshape has no weights
    assert parts["head"] == 16 + 1  # 1x1x1 conv from C = 16 channels, with bias


def test_paper_shapes_on_meta(paper_meta):
    assert paper_meta.input_shape == (100, 256, 256)
    rows = {r["name"]: r for r in layer_table(paper_meta, batch_size=2)}
    assert rows["encoder.stem"]["shape"] == (2, 64, 25, 64, 64)
    assert rows["encoder.layer4"]["shape"] == (2, 2048, 4, 8, 8)
    # 2048 * 4 * 8 * 8 = 524,288 = 16 * 32^3 -> C = 16
    assert rows["bridge"]["shape"] == (2, 16, 32, 32, 32)
    assert paper_meta.hidden_channels == 16
    assert rows["decoder.down3"]["shape"] == (2, 128, 4, 4, 4)
    assert rows["head"]["shape"] == (2, 1, 32, 32, 32)
    y = paper_meta(torch.empty(2, 100, 256, 256, device="meta"))
    assert y.shape == (2, 32, 32, 32) and y.device.type == "meta"


def test_layer_table_counts_add_up_and_activations_scale_with_batch():
    model = build_e2v("tiny")
    rows = layer_table(model)
    assert sum(r["params"] for r in rows) == count_parameters(model)
    assert all(r["shape"] is not None for r in rows)
    assert [r["name"] for r in rows][:2] == ["encoder.stem", "encoder.layer1"]
    assert "total" in format_layer_table(rows)
    one, four = activation_bytes(model, 1), activation_bytes(model, 4)
    # The input alone (100*64*64 float32) is saved by the first conv.
    assert one > 100 * 64 * 64 * 4
    assert abs(four - 4 * one) < 0.01 * one  # linear in the batch (tiny per-call constants)


def test_layer_table_matches_real_saved_tensors_on_cpu():
    model = small_model().eval()
    keys: dict[int, int] = {}
    weights = {p.data_ptr() for p in model.parameters()}

    def pack(t):
        ptr = t.untyped_storage().data_ptr()
        if t.ndim >= 2 and ptr not in weights:
            keys[ptr] = t.untyped_storage().nbytes()
        return t

    with torch.autograd.graph.saved_tensors_hooks(pack, lambda t: t):
        out = model(torch.rand(3, *SMALL))
    assert out.shape == (3, 32, 32, 32)
    assert activation_bytes(model, 3) == sum(keys.values())


def test_hand_counted_tiny_encoder_stages():
    rows = {r["name"]: r["params"] for r in layer_table(small_model())}
    # stem: 3x3x3 conv 1 -> 8 (216) + BatchNorm (2 * 8)
    assert rows["encoder.stem"] == 27 * 8 + 16
    # layer1: one BasicBlock 8 -> 8: two 3x3x3 convs + two BatchNorms, identity shortcut
    assert rows["encoder.layer1"] == 2 * (27 * 8 * 8 + 16)
    # layer2: 8 -> 16 with stride 2: convs 27*8*16 + 27*16*16, 1x1x1 projection 8*16, 3 BNs
    assert rows["encoder.layer2"] == 27 * 8 * 16 + 27 * 16 * 16 + 8 * 16 + 3 * 32


# ----------------------------------------------------------------------------- seeding, grads


def test_seed_makes_weights_and_outputs_reproducible():
    state = torch.random.get_rng_state()
    a, b, c = small_model(seed=0), small_model(seed=0), small_model(seed=1)
    assert torch.equal(torch.random.get_rng_state(), state)  # global RNG untouched
    x = torch.rand(2, *SMALL, generator=torch.Generator().manual_seed(5))
    a.eval(), b.eval(), c.eval()
    with torch.no_grad():
        assert torch.equal(a(x), b(x))
        assert not torch.allclose(a(x), c(x))
    for (name, p), q in zip(a.state_dict().items(), b.state_dict().values(), strict=True):
        assert torch.equal(p, q), name


@pytest.mark.parametrize("overrides", [{}, {"bridge": "interp"}, {"encoder": "frames2d"},
                                       {"encoder": "frames2d_gru"}])
def test_gradient_reaches_every_parameter(overrides):
    model = small_model(**overrides).train()
    g = torch.Generator().manual_seed(0)
    x = (torch.rand(3, *SMALL, generator=g) < 0.2).float()
    target = (torch.rand(3, 32, 32, 32, generator=g) < 0.3).float()
    loss = torch.nn.functional.binary_cross_entropy_with_logits(model(x), target)
    loss.backward()
    for name, p in model.named_parameters():
        assert p.grad is not None, f"{name} got no gradient"
        assert torch.isfinite(p.grad).all(), name
        assert p.grad.abs().sum() > 0, f"{name} got an all-zero gradient"


# ----------------------------------------------------------------------------- bad input


def test_wrong_input_shape_names_expected_and_got_shape():
    model = small_model()
    with pytest.raises(ValueError, match=r"\(batch, 16, 32, 32\).*got \(2, 16, 64, 64\)"):
        model(torch.rand(2, 16, 64, 64))
    with pytest.raises(ValueError, match="unsqueeze"):
        model(torch.rand(*SMALL))
    with pytest.raises(ValueError, match="got \\(2, 1, 16, 32, 32\\)"):
        model(torch.rand(2, 1, *SMALL))
    with pytest.raises(ValueError, match=r"x\.float\(\)"):
        model(torch.ones(2, *SMALL, dtype=torch.uint8))


def test_bad_config_and_preset_errors():
    with pytest.raises(ValueError, match="unknown preset"):
        build_e2v("huge")
    with pytest.raises(ValueError, match="unknown E2V config fields \\['widths'\\]"):
        build_e2v("tiny", widths=(1, 2))
    with pytest.raises(ValueError, match="depth must be one of"):
        build_e2v("tiny", depth=11)
    with pytest.raises(ValueError, match="bridge must be one of"):
        build_e2v("tiny", bridge="magic")
    with pytest.raises(ValueError, match="seed_size"):
        build_e2v("tiny", seed_size=5)


def test_config_dict_round_trip():
    for config in PRESETS.values():
        d = config.to_dict()
        assert isinstance(d["input_shape"], list)
        assert E2VConfig.from_dict(d) == config
    with pytest.raises(ValueError, match="unknown E2V config keys"):
        E2VConfig.from_dict({**PRESETS["tiny"].to_dict(), "extra": 1})


# ----------------------------------------------------------------------------- layout, names


def test_public_names_come_from_the_submodules_and_paper_constants():
    import importlib

    import e2vlib.model
    from e2vlib.model import checkpoint, networks

    summary_module = importlib.import_module("e2vlib.model.summary")

    assert networks.E2V is build_e2v("tiny").__class__
    homes = {"encoders": (BasicBlock, Bottleneck, ResNetEncoder, Frames2dEncoder,
                          Frames2dGRUEncoder), "decoder": (Bridge, UNetDecoder)}
    for home, classes in homes.items():
        for cls in classes:  # one home each, listed once by the package face
            assert cls.__module__ == f"e2vlib.model.{home}"
            assert getattr(e2vlib.model, cls.__name__) is cls
            assert cls.__name__ not in networks.__all__
    assert checkpoint.load_checkpoint.__module__ == "e2vlib.model.checkpoint"
    assert summary_module.layer_table is layer_table
    # one definition of the paper's numbers
    assert PAPER_PARAMETERS == paper.N_PARAMETERS == 149_155_905
    assert GRID_SIDE == paper.GRID_SIDE == 32
    assert PRESETS["paper"].input_shape == (paper.N_EVENT_FRAMES, paper.INPUT_SIZE_PX,
                                            paper.INPUT_SIZE_PX)
    assert PRESETS["paper"].depth == paper.RESNET_DEPTH == 152


def test_frame_axis_and_resnet_depth_are_told_apart():
    model = small_model(depth=18)
    assert model.input_shape == SMALL and model.n_frames == model.config.n_frames == SMALL[0]
    assert model.config.depth == 18
    # one name for the ResNet depth: no second spelling is read
    with pytest.raises(ValueError, match="resnet_depth"):
        build_e2v("tiny", input_shape=SMALL, resnet_depth=34)
    stored = PRESETS["tiny"].to_dict()
    stored["resnet_depth"] = stored.pop("depth")
    with pytest.raises(ValueError, match="resnet_depth"):
        E2VConfig.from_dict(stored)
    with pytest.raises(ValueError, match="ResNet depth, not the frame axis"):
        build_e2v("tiny", depth=100)
    with pytest.raises(ValueError, match=r"\(batch, n_frames, height, width\)"):
        model(torch.rand(2, 8, 32, 32))


def test_frames2d_encoder_pools_the_frame_axis_into_time_bins():
    model = small_model(encoder="frames2d")
    # (16, 32, 32): 2D stem stride 2 -> 16x16, pool -> 8x8, three halvings -> 1x1; the 16
    # frames are max-pooled into 4 time bins
    assert model.encoder_shape == (64, 4, 1, 1)
    short = small_model(encoder="frames2d", input_shape=(3, 32, 32))
    assert short.encoder_shape == (64, 3, 1, 1)  # fewer frames than bins: one bin each


# ----------------------------------------------------------------------------- in_channels


def _grad_check(model, x):
    target = (torch.rand(x.shape[0], 32, 32, 32, generator=torch.Generator().manual_seed(1))
              < 0.3).float()
    y = model(x)
    assert y.shape == (x.shape[0], 32, 32, 32) and torch.isfinite(y).all()
    torch.nn.functional.binary_cross_entropy_with_logits(y, target).backward()
    for name, p in model.named_parameters():
        assert p.grad is not None and torch.isfinite(p.grad).all(), name
        assert p.grad.abs().sum() > 0, f"{name} got an all-zero gradient"


@pytest.mark.parametrize("encoder", ["resnet3d", "frames2d", "frames2d_gru"])
def test_two_channel_input_forward_and_backward(encoder):
    model = small_model(encoder=encoder, in_channels=2).train()
    assert model.in_channels == 2 and model.input_shape == SMALL
    assert model.sample_shape == (2, *SMALL) == model.config.sample_shape
    x = (torch.rand(3, 2, *SMALL, generator=torch.Generator().manual_seed(0)) < 0.2).float()
    _grad_check(model, x)
    stem = model.encoder.stem[0] if encoder == "resnet3d" else model.encoder.net.stem[0]
    assert stem.in_channels == 2
    # both channels reach the output: changing only the ON channel changes the logits
    model.eval()
    y = x.clone()
    y[:, 1] = 1 - y[:, 1]
    with torch.no_grad():
        assert not torch.allclose(model(x), model(y))


@pytest.mark.parametrize(("encoder", "kernel_volume"),
                         [("resnet3d", 27), ("frames2d", 9), ("frames2d_gru", 9)])
@pytest.mark.parametrize("channels", [2, 3])
def test_only_the_first_convolution_grows_with_channels(encoder, kernel_volume, channels):
    one = small_model(encoder=encoder)
    many = small_model(encoder=encoder, in_channels=channels)
    base_width = one.config.base_width  # the stem's output channels (8 in tiny)
    extra = (channels - 1) * kernel_volume * base_width  # 3x3x3 (3D) or 3x3 (2D) kernels
    assert count_parameters(many) - count_parameters(one) == extra
    # every other tensor has the same shape
    a, b = one.state_dict(), many.state_dict()
    assert a.keys() == b.keys()
    differ = [k for k in a if a[k].shape != b[k].shape]
    assert len(differ) == 1 and differ[0].endswith("stem.0.weight")
    assert b[differ[0]].shape[1] == channels


def test_channel_mismatch_errors_name_both_shapes_and_the_fix():
    one, two = small_model(), small_model(in_channels=2)
    with pytest.raises(ValueError, match=r"\(batch, 16, 32, 32\).*got \(2, 2, 16, 32, 32\)"
                                         r".*in_channels=2"):
        one(torch.rand(2, 2, *SMALL))
    with pytest.raises(ValueError, match=r"\(batch, 2, 16, 32, 32\) = \(batch, channels, "
                                         r"n_frames, height, width\), got \(3, 16, 32, 32\)"
                                         r".*built for 2 input channels"):
        two(torch.rand(3, *SMALL))
    with pytest.raises(ValueError, match=r"got \(2, 3, 16, 32, 32\).*built for 2 input"):
        two(torch.rand(2, 3, *SMALL))
    with pytest.raises(ValueError, match=r"got \(2, 2, 16, 64, 64\)\. Give it"):
        two(torch.rand(2, 2, 16, 64, 64))
    # (2, 16, 32, 32) is one 2-channel sample, or a batch of two 1-channel ones: both named
    with pytest.raises(ValueError, match=r"one sample \(2, 16, 32, 32\).*unsqueeze\(0\).*"
                                         r"in_channels=2"):
        two(torch.rand(2, *SMALL))
    with pytest.raises(ValueError, match="in_channels must be >= 1"):
        small_model(in_channels=0)


def test_gru_fields_matter_only_to_the_gru_encoder():
    # the shipped checkpoint was written while gru_pool defaulted to 2: still the tiny preset
    assert E2VConfig(gru_pool=2, gru_hidden=8) == E2VConfig()
    assert replace(PRESETS["tiny"], gru_pool=2) == PRESETS["tiny"]
    assert PRESETS["tiny"].to_dict()["gru_pool"] == 1
    gru = PRESETS["tiny_gru"]
    assert replace(gru, gru_pool=2) != gru and replace(gru, gru_pool=2).gru_pool == 2


def test_old_configs_without_the_new_fields_are_one_channel():
    stored = PRESETS["tiny"].to_dict()
    for key in ("in_channels", "gru_hidden", "gru_pool"):
        del stored[key]
    config = E2VConfig.from_dict(stored)
    assert config == PRESETS["tiny"] and config.in_channels == 1
    assert config.sample_shape == config.input_shape == (100, 64, 64)


def test_the_normalised_bridge_ignores_the_scale_of_its_linear_layer():
    """bridge_norm's point: in training mode the seed volume does not grow with the fully
    connected layer's weights (multiplying weight and bias by 1000 changes nothing but BN's
    eps), while the unnormalised bridge's output grows 1000-fold."""
    config = E2VConfig(input_shape=(8, 16, 16), bridge_norm=True)
    z = torch.randn(6, 64, 1, 1, 1, generator=torch.Generator().manual_seed(0))
    for norm, grows in ((True, 1.0), (False, 1000.0)):
        bridge = Bridge(replace(config, bridge_norm=norm), (64, 1, 1, 1)).train()
        before = bridge(z).detach()
        with torch.no_grad():
            bridge.fc[2].weight.mul_(1000)
            bridge.fc[2].bias.mul_(1000)
        after = bridge(z).detach()
        assert torch.allclose(after, before * grows, rtol=1e-3, atol=1e-3), norm
    normed = Bridge(config, (64, 1, 1, 1)).train()(z).detach()
    seed = torch.nn.functional.interpolate(normed, size=(4, 4, 4), mode="nearest")
    assert float(seed.min()) >= 0 and 0 < float((seed > 0).float().mean()) < 1  # a ReLU after


def test_bridge_norm_adds_one_norm_and_old_checkpoints_load_without_it():
    tiny, normed = PRESETS["tiny"], PRESETS["tiny_norm"]
    assert replace(tiny, bridge_norm=True) == normed
    assert PRESETS["tiny_gru_norm"] == replace(PRESETS["tiny_gru"], bridge_norm=True)
    # 4 hidden channels: the norm's scale and shift add 8 parameters
    assert (count_parameters(build_e2v("tiny_norm", seed=0))
            - count_parameters(build_e2v("tiny", seed=0))) == 2 * tiny.hidden_channels == 8
    stored = tiny.to_dict()
    del stored["bridge_norm"]  # a checkpoint written before the field existed
    assert E2VConfig.from_dict(stored) == tiny
    old_keys = set(build_e2v("tiny", seed=0).state_dict())
    assert not any("seed_norm" in k for k in old_keys)
    assert old_keys < set(build_e2v("tiny_norm", seed=0).state_dict())
    # only the fully connected bridge has an unnormalised output: elsewhere it is stored off
    assert E2VConfig(bridge="interp", bridge_norm=True).bridge_norm is False
    with pytest.raises(ValueError, match="bridge_norm must be True or False"):
        E2VConfig(bridge_norm="yes")


# ----------------------------------------------------------------------------- GRU encoder


def test_preset_parameter_counts_are_within_2x_of_each_other():
    counts = {name: count_parameters(build_e2v(name)) for name in ("tiny", "tiny2d",
                                                                   "tiny_gru")}
    assert counts == {"tiny": 2_827_829, "tiny2d": 2_680_229, "tiny_gru": 2_730_917}
    assert max(counts.values()) <= 2 * min(counts.values())
    gru = build_e2v("tiny_gru")
    # the three share the decoder exactly; only the encoder and the bridge's input differ
    assert parameter_breakdown(gru)["decoder"] == parameter_breakdown(build_e2v("tiny"))[
        "decoder"]


def test_tiny_gru_hand_counted_parts():
    model = build_e2v("tiny_gru")
    assert model.config.encoder == "frames2d_gru"
    assert (model.config.gru_hidden, model.config.gru_pool) == (256, 1)
    enc = model.encoder
    assert isinstance(enc, Frames2dGRUEncoder)
    # the same 2D ResNet-10 trunk as tiny2d
    assert count_parameters(enc.net) == count_parameters(build_e2v("tiny2d").encoder)
    # the 64 x 2 x 2 map, globally average-pooled -> 64 features; GRU: 3 gates x
    # (W_i, W_h, b_i, b_h)
    assert enc.features == 64
    assert count_parameters(enc.gru) == 3 * (64 * 256 + 256 * 256 + 2 * 256)
    # a 2x2 pool instead: 4x the features, 3 x 256 x 192 more input weights
    pooled = build_e2v("tiny_gru", gru_pool=2)
    assert pooled.encoder.features == 256
    assert count_parameters(pooled) - count_parameters(model) == 3 * 256 * (256 - 64)
    # the fc bridge from the 256 hidden units to a 4 x 4^3 seed
    assert model.encoder_shape == (256, 1, 1, 1)
    assert count_parameters(model.bridge) == 256 * 256 + 256


def test_tiny_gru_forward_backward_on_a_small_input():
    model = build_e2v("tiny_gru", input_shape=(20, 32, 32), seed=0).train()
    x = (torch.rand(2, 20, 32, 32, generator=torch.Generator().manual_seed(0)) < 0.2).float()
    _grad_check(model, x)


def test_gru_encoder_is_the_gru_over_per_frame_features_in_time_order():
    # 64 x 64 px: each frame's feature map is 2 x 2, pooled to 2 x 2 (gru_pool=2)
    model = small_model(encoder="frames2d_gru", input_shape=(5, 64, 64), gru_hidden=16,
                        gru_pool=2).eval()
    enc = model.encoder
    x = torch.rand(2, 1, 5, 64, 64, generator=torch.Generator().manual_seed(0))
    with torch.no_grad():
        # by hand: the same 2D network on every frame, 2x2 average pool, GRU over the 5
        feats = torch.stack([torch.nn.functional.adaptive_avg_pool2d(enc.net(x[:, :, k]), 2)
                             .flatten(1) for k in range(5)], dim=1)
        _, h = enc.gru(feats)
        out = enc(x)
        assert out.shape == (2, 16, 1, 1, 1)
        assert torch.allclose(out.flatten(1), h[0], atol=1e-6)
        # the recurrence sees the order of the frames (max pooling over a bin would not)
        assert not torch.allclose(enc(x.flip(2)), out, atol=1e-4)


def test_layer_table_of_the_gru_model():
    model = build_e2v("tiny_gru")
    rows = {r["name"]: r for r in layer_table(model, batch_size=2)}
    assert rows["encoder.cnn"]["shape"] == (2 * 100, 64, 2, 2)  # every frame of both
    assert rows["encoder.gru"]["shape"] == (2, 100, 256)
    assert rows["bridge"]["shape"] == (2, 4, 32, 32, 32)
    assert sum(r["params"] for r in rows.values()) == count_parameters(model)
    two = build_e2v("tiny", in_channels=2)
    # the input saved by the first conv doubles: 2 x 100 x 64 x 64 float32 more
    assert activation_bytes(two) - activation_bytes(build_e2v("tiny")) == 100 * 64 * 64 * 4
