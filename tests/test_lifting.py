"""Lifting event frames into the grid through the known orbit, and the hybrid models."""

import numpy as np
import pytest
import torch

from e2vlib import geometry
from e2vlib.model import E2VConfig, build_e2v, count_parameters
from e2vlib.orbit import orbit_cameras, project_points


def test_table_entry_is_the_projected_voxel_centre_by_hand():
    table = geometry.lifting_table(n_frames=3, dt_us=5000, resolution=16, grid=4)
    camera = geometry.window_centre_cameras(3, 5000)[1]
    centre = geometry.sample_points(4)[5]  # voxel (0, 1, 1)
    col, row = np.rint(project_points(centre[None], camera, 16))[0].astype(int)
    assert table[1, 5] == row * 16 + col


def test_window_centre_cameras_are_the_orbit_at_mid_window():
    # 119 video frames of 1e6/240 us span the orbit: window k's centre is (k + 1/2) dt
    cams = geometry.window_centre_cameras(1, dt_us=2 * round(1e6 * 119 / 240))
    assert np.allclose(cams[0], orbit_cameras(120)[-1], atol=1e-4)  # 0.3 us off the frame


def test_lift_frames_equals_event_carving_density(tiny_frames):
    cams = geometry.window_centre_cameras(len(tiny_frames), 5000)
    table = geometry.lifting_table(len(tiny_frames), 5000, tiny_frames.shape[1], grid=8)
    lifted = geometry.lift_frames(tiny_frames, table)
    vote = geometry.frames_ray_density(tiny_frames, cams, grid=8)
    rays = geometry.frames_ray_density(tiny_frames, cams, grid=8, fill_frames=False)
    assert lifted.shape == (2, 8, 8, 8)
    np.testing.assert_array_equal(lifted[0], vote)
    np.testing.assert_array_equal(lifted[1], rays)


def test_lift_frames_refuses_a_table_of_other_frames(tiny_frames):
    table = geometry.lifting_table(len(tiny_frames) + 1, 5000, tiny_frames.shape[1], grid=4)
    with pytest.raises(ValueError, match="lifting_table"):
        geometry.lift_frames(tiny_frames, table)


@pytest.fixture
def tiny_frames() -> np.ndarray:
    """12 frames of 16 px with a square outline moving one pixel a frame, two left empty."""
    rng = np.random.default_rng(0)
    frames = np.zeros((12, 16, 16), bool)
    for k in range(12):
        frames[k, 4:12, 3 + k // 3] = frames[k, 4:12, 10 + k // 4] = True
    frames[3] = frames[7] = False
    frames |= rng.random(frames.shape) < 0.01
    return frames


def test_torch_lifting_gives_the_numpy_volume(tiny_frames):
    model = build_e2v("lifted_unet", seed=0, input_shape=(12, 16, 16)).eval()
    table = geometry.lifting_table(12, 5000, 16)
    batch = torch.from_numpy(np.stack([tiny_frames, tiny_frames[::-1].copy()])).float()
    lifted = model.lifting(batch).numpy()
    for sample, frames in zip(lifted, batch.numpy().astype(bool), strict=True):
        np.testing.assert_allclose(sample, geometry.lift_frames(frames, table), atol=1e-6)


@pytest.mark.parametrize("preset", ["hybrid_early", "hybrid_late", "lifted_unet"])
def test_hybrids_map_frames_to_logits_and_round_trip_their_config(preset):
    model = build_e2v(preset, seed=0, input_shape=(12, 16, 16)).eval()
    assert model(torch.zeros(2, 12, 16, 16)).shape == (2, 32, 32, 32)
    assert E2VConfig.from_dict(model.config.to_dict()) == model.config
    # the look-up table is rebuilt from the config, never stored with the weights
    assert not any("look_up" in key for key in model.state_dict())


def test_lifted_unet_has_no_encoder_and_early_hybrid_adds_little():
    e2v, early = build_e2v("tiny_norm", seed=0), build_e2v("hybrid_early", seed=0)
    alone = build_e2v("lifted_unet", seed=0)
    assert not hasattr(alone, "encoder")
    assert 0 < count_parameters(early) - count_parameters(e2v) < 20_000
    assert count_parameters(alone) < count_parameters(e2v)


def test_an_e2v_config_stores_the_lift_defaults():
    config = E2VConfig(lift_width=3, lift_dt_us=17)  # no lift: unused fields reset
    assert (config.lift, config.lift_width, config.lift_dt_us) == ("none", 8, 5000)
    with pytest.raises(ValueError, match="lift must be one of"):
        E2VConfig(lift="middle")
    with pytest.raises(ValueError, match="one-channel square"):
        E2VConfig(lift="early", in_channels=2)


def test_models_of_one_orbit_share_one_look_up_and_keep_it_unchanged(tiny_frames):
    from e2vlib.model.lifting import look_up_matrix

    first = build_e2v("lifted_unet", seed=0, input_shape=(12, 16, 16))
    second = build_e2v("hybrid_early", seed=1, input_shape=(12, 16, 16))
    other = build_e2v("lifted_unet", seed=0, input_shape=(10, 16, 16))
    assert first.lifting.look_up is second.lifting.look_up  # built once for the orbit
    assert other.lifting.look_up.shape[1] == 10 * (16 * 16 + 1)  # its own frames
    before = look_up_matrix(12, 16, 5000).to_dense().clone()
    first.double()  # a conversion makes the model its own copy, the shared one stays float
    assert first.lifting.look_up.dtype == torch.float64
    assert second.lifting.look_up.dtype == torch.float32
    assert torch.equal(look_up_matrix(12, 16, 5000).to_dense(), before)
