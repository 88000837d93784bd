"""Known answers for e2vlib.geometry: visual hull and events-only ray voting."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from scipy import ndimage

from e2vlib import geometry as G
from e2vlib.events import make_events
from e2vlib.metrics import iou
from e2vlib.orbit import orbit_cameras, project_points
from e2vlib.render import render_orbit
from e2vlib.simulate import simulate_events
from e2vlib.voxels import voxelize

RES = 64


def box_label() -> np.ndarray:
    return voxelize(trimesh.creation.box((0.5, 0.5, 0.5)))  # the central 16^3 block


def splat_silhouettes(points: np.ndarray, cameras: np.ndarray, res: int) -> np.ndarray:
    """Silhouettes from dense points of a solid, one pixel wider all round (conservative)."""
    out = np.zeros((len(cameras), res, res), dtype=bool)
    for k, camera in enumerate(cameras):
        col, row = np.rint(project_points(points, camera, res)).astype(int).T
        out[k, row, col] = True
    return ndimage.binary_dilation(out, structure=np.ones((1, 3, 3), bool))


def test_sample_points_are_voxel_centres_and_sub_cells():
    centres = G.sample_points(4, 1).reshape(4, 4, 4, 3)
    np.testing.assert_allclose(centres[1, 2, 3], [-0.5 + 1.5 / 4, -0.5 + 2.5 / 4, -0.5 + 3.5 / 4])
    sub = G.sample_points(4, 2).reshape(4, 4, 4, 8, 3)
    np.testing.assert_allclose(sub.mean(axis=3), centres)  # sub-cells centre on their voxel
    assert np.all(np.abs(sub - centres[..., None, :]) == 1 / 16)


def test_orbit_camera_at_matches_the_render_orbit():
    t_video = np.arange(120) * 1e6 / 240
    np.testing.assert_allclose(G.orbit_camera_at(t_video), orbit_cameras(120), atol=1e-9)
    # the video's whole-microsecond stamps are off by up to 0.5 us: 0.04 mm of orbit
    t_dense = np.round(np.arange(358) * 1e6 / 720)  # oversample 3
    np.testing.assert_allclose(G.orbit_camera_at(t_dense), orbit_cameras(358), atol=1e-4)
    np.testing.assert_allclose(G.orbit_camera_at([-5, 10**7]), orbit_cameras(120)[[0, -1]])


def test_visual_hull_of_analytic_box_contains_it():
    # exact (one pixel conservative) silhouettes of the box from 24 orbit views
    cameras = orbit_cameras(24)
    label = box_label()
    solid = G.sample_points(32, 2).reshape(32, 32, 32, 8, 3)[label].reshape(-1, 3)
    hull = G.visual_hull(splat_silhouettes(solid, cameras, RES), cameras, RES, samples=1)
    assert hull.shape == (32, 32, 32) and hull.dtype == np.float32
    assert np.all(hull[label] == 1)  # hull property: no box voxel carved away
    assert iou(hull, label) > 0.5  # measured 0.537 (a 64 px, 24-view hull of a cube)
    # a single view carves only a cone: far more than the box survives
    one = G.visual_hull(splat_silhouettes(solid, cameras[:1], RES), cameras[:1], RES)
    assert one.sum() > 2 * hull.sum()


@pytest.fixture(scope="module")
def rendered_sphere():
    sphere = trimesh.creation.icosphere(3, 0.4)
    video, _ = render_orbit(sphere, n_video_frames=12, resolution=RES)
    return voxelize(sphere), video


def test_visual_hull_from_rendered_silhouettes(rendered_sphere):
    label, video = rendered_sphere
    silhouettes = G.silhouettes_from_video(video)
    assert silhouettes[:, 0, 0].sum() == 0 and silhouettes[:, RES // 2, RES // 2].all()
    hull = G.visual_hull(silhouettes, orbit_cameras(12), RES)
    assert np.all(hull[label] == 1)  # no true voxel carved away
    assert iou(hull, label) > 0.65  # measured 0.699
    # more samples per voxel give a share of points: still everything of the sphere kept
    fine = G.visual_hull(silhouettes, orbit_cameras(12), RES, samples=2)
    assert np.all(fine[label] > 0) and set(np.unique(fine * 8)) <= set(range(9))
    # with a silhouette blanked, the strict hull loses everything, a 90 % vote does not
    silhouettes[3] = False
    assert G.visual_hull(silhouettes, orbit_cameras(12), RES).sum() == 0
    tolerant = G.visual_hull(silhouettes, orbit_cameras(12), RES, min_fraction=0.9)
    assert np.all(tolerant[label] == 1)


def test_silhouettes_from_video_uint8_and_tolerance():
    video = np.full((2, 4, 4), 255, np.uint8)
    video[0, 1, 2], video[1, 3, 3] = 254, 100
    sil = G.silhouettes_from_video(video)
    assert sil.sum() == 2 and sil[0, 1, 2] and sil[1, 3, 3]
    assert G.silhouettes_from_video(video, tolerance=2 / 255).sum() == 1


def test_silhouettes_from_events_fill_rows_between_outline_events():
    # a U-shaped outline (no events on the top edge, as when the image moves along rows)
    frame = np.zeros((1, 10, 10), bool)
    frame[0, 2:8, 2] = frame[0, 2:8, 7] = frame[0, 7, 2:8] = True
    sil = G.silhouettes_from_events(frame, merge_frames=1)
    expected = np.zeros((10, 10), bool)
    expected[2:8, 2:8] = True
    np.testing.assert_array_equal(sil[0], expected)
    # merging: an empty frame between two frames borrows their events
    frames = np.zeros((3, 10, 10), bool)
    frames[0, 4, 1] = frames[2, 4, 8] = True
    merged = G.silhouettes_from_events(frames, merge_frames=3)
    assert merged[1, 4, 1:9].all() and merged[1].sum() == 8
    assert not G.silhouettes_from_events(frames, merge_frames=1)[1].any()


def test_fill_solid_fills_a_shell():
    shell = np.zeros((32, 32, 32))
    shell[8:24, 8:24, 8:24] = 1.0
    shell[9:23, 9:23, 9:23] = 0.0  # hollow box: its walls hold the evidence
    shell[8, 15, 15] = 0.5  # a one-voxel gap in a wall below the threshold
    solid = G.fill_solid(shell, 0.9)
    assert solid.dtype == bool and solid.sum() == 16**3  # gap bridged, inside filled
    assert G.fill_solid(shell, 1.5).sum() == 0


@pytest.fixture(scope="module")
def box_events():
    box = trimesh.creation.box((0.5, 0.5, 0.5))
    video, t_us = render_orbit(box, resolution=RES)  # the paper's 0.5 s orbit, 120 frames
    return simulate_events(video, t_us, 0.2, 0.2)


def test_events_only_method_on_a_box(box_events):
    label = box_label()
    density = G.event_ray_density(box_events, G.orbit_camera_at, RES)
    assert density.shape == (32, 32, 32) and 0 <= density.min() and density.max() <= 1
    solid = G.fill_solid(density)
    assert iou(solid, label) > 0.6  # measured 0.673 (64 px events, 100 frames of 5 ms)
    # raw event rays (EMVS-style, no silhouettes) see the edges only: a poor solid
    raw = G.event_ray_density(box_events, G.orbit_camera_at, RES, fill_frames=False)
    assert iou(G.fill_solid(raw, 0.05), label) < iou(solid, label)


def test_score_occupancy_keys_and_perfect_score():
    label = box_label()
    scores = G.score_occupancy(label, label, n_points=1024)
    # the keys of e2vlib.train.score_predictions (metrics.METRIC_KEYS; not imported: torch)
    assert tuple(scores) == ("iou@0.2", "iou@0.3", "iou@0.4", "iou@0.5", "fscore@1%",
                             "fscore@20%")
    assert all(value == 1.0 for value in scores.values())
    assert G.score_occupancy(np.zeros((32, 32, 32)), label, n_points=256)["iou@0.3"] == 0.0


@pytest.mark.parametrize("call, match", [
    (lambda: G.visual_hull(np.zeros((2, 8, 8)), np.ones((3, 3)), 8), r"cameras must be \(2, 3\)"),
    (lambda: G.visual_hull(np.zeros((2, 8, 8)), orbit_cameras(2), 16), "does not match"),
    (lambda: G.visual_hull(np.full((2, 8, 8), 0.5), orbit_cameras(2)), "binary"),
    (lambda: G.visual_hull(np.zeros((2, 8, 6)), orbit_cameras(2)), "square"),
    (lambda: G.visual_hull(np.zeros((2, 8, 8)), orbit_cameras(2), min_fraction=0),
     "min_fraction"),
    (lambda: G.visual_hull(np.zeros((2, 8, 8)), orbit_cameras(2), samples=0), "samples"),
    (lambda: G.silhouettes_from_video(np.zeros((2, 4))), "shape"),
    (lambda: G.silhouettes_from_video(np.full((1, 2, 2), np.nan)), "NaN"),
    (lambda: G.orbit_camera_at([np.nan]), "NaN"),
    (lambda: G.event_ray_density(make_events([1], [1], [5], [1]), "orbit", 8),
     "cameras_at_time must be a function"),
    (lambda: G.event_ray_density(make_events([], [], [], []), G.orbit_camera_at, 8),
     "no events"),
    (lambda: G.frames_ray_density(np.zeros((2, 8, 8)), orbit_cameras(2)), "all event frames"),
    (lambda: G.fill_solid(np.zeros((4, 4, 5)), 0.5), "cubic"),
    (lambda: G.fill_solid(np.zeros((4, 4, 4)), float("nan")), "threshold"),
])
def test_bad_input_raises_clear_errors(call, match):
    with pytest.raises(ValueError, match=match):
        call()
