"""Analytic checks of the orbit and pixel checks of small off-screen renders (e2vlib.render,
and the plotters e2vlib.scale.render_cache keeps for reuse)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

from e2vlib import render
from e2vlib.orbit import (
    VIEW_ANGLE_DEG,
    camera_axes,
    orbit_angles,
    orbit_cameras,
    pixel_motion_per_frame,
    project_points,
    required_oversample,
)
from e2vlib.render import ANTI_ALIASING, make_plotter, render_orbit
from e2vlib.scale import render_cache
from e2vlib.scale.render_cache import release_plotters, render_orbit_cached

RES = 48


def test_view_angle_is_80mm_lens_on_36mm_sensor():
    assert VIEW_ANGLE_DEG == pytest.approx(25.3608, abs=1e-3)


def test_orbit_spiral_shape():
    cams = orbit_cameras(121)
    assert cams.shape == (121, 3) and cams.dtype == np.float64
    z = cams[:, 2]
    assert z[0] == 2.0 and z[-1] == -2.0 and z[60] == pytest.approx(0.0, abs=1e-12)
    np.testing.assert_allclose(np.diff(z), -4.0 / 120)  # linear descent
    radius = np.hypot(cams[:, 0], cams[:, 1])
    np.testing.assert_allclose(radius, 6.0 - z**2 / 2)
    assert radius[0] == pytest.approx(4.0) and radius[-1] == pytest.approx(4.0)
    assert radius[60] == pytest.approx(6.0) and radius.max() == pytest.approx(6.0)
    # starts (and ends) on the -y side; one full counter-clockwise turn
    np.testing.assert_allclose(cams[0], [0.0, -4.0, 2.0], atol=1e-12)
    np.testing.assert_allclose(cams[-1], [0.0, -4.0, -2.0], atol=1e-12)
    azimuth = np.unwrap(np.arctan2(cams[:, 1], cams[:, 0]))
    assert np.all(np.diff(azimuth) > 0)
    assert azimuth[-1] - azimuth[0] == pytest.approx(2 * math.pi)


def test_orbit_angles_and_distance():
    azimuth, elevation, distance = orbit_angles(5)
    np.testing.assert_allclose(azimuth, [-90, 0, 90, 180, 270])
    edge = math.degrees(math.atan2(2, 4))  # 26.57 degrees above / below
    np.testing.assert_allclose(elevation, [edge, math.degrees(math.atan2(1, 5.5)), 0,
                                           -math.degrees(math.atan2(1, 5.5)), -edge])
    np.testing.assert_allclose(distance, np.linalg.norm(orbit_cameras(5), axis=1))
    assert distance[0] == pytest.approx(math.sqrt(20)) and distance[2] == pytest.approx(6.0)


def test_orbit_needs_two_frames():
    with pytest.raises(ValueError, match="n_frames"):
        orbit_cameras(1)


def test_project_points_orientation():
    cam = orbit_cameras(3)[0]  # on the -y side, above the object
    centre = (RES - 1) / 2
    uv = project_points([[0, 0, 0], [0.3, 0, 0], [0, 0, 0.3]], cam, RES)
    np.testing.assert_allclose(uv[0], [centre, centre])
    assert uv[1, 0] > centre + 1 and uv[1, 1] == pytest.approx(centre)  # +x is to the right
    assert uv[2, 1] < centre - 1  # +z is up (smaller row)
    # 1 m at 6 m distance spans res / (2 tan(12.68 deg)) / 6 pixels
    uv = project_points([[0.5, 0, 0]], [0, -6.0, 0], 256)
    focal = 128 / math.tan(math.radians(VIEW_ANGLE_DEG / 2))
    assert uv[0, 0] - 127.5 == pytest.approx(focal * 0.5 / 6)


def test_pixel_motion_shrinks_with_oversampling():
    plain = pixel_motion_per_frame(120, 256)
    dense = pixel_motion_per_frame(120, 256, oversample=4)
    assert plain.shape == (119,) and dense.shape == (4 * 119,)
    assert plain.max() > 3.0  # the paper's 240 fps orbit moves > 1 px per frame at 256 px
    # a frame step is the sum of its 4 sub-steps: at least a quarter, about a quarter
    assert plain.max() / 4 <= dense.max() <= 1.05 * plain.max() / 4
    assert pixel_motion_per_frame(120, 128).max() == pytest.approx(plain.max() / 2)
    k = required_oversample(120, 256, max_motion_px=1.0)
    assert pixel_motion_per_frame(120, 256, k).max() <= 1.0
    assert pixel_motion_per_frame(120, 256, k - 1).max() > 1.0


def upright_cone() -> trimesh.Trimesh:
    """A cone with its base at z = -0.5 and its tip at z = +0.5."""
    cone = trimesh.creation.cone(radius=0.4, height=1.0, sections=24)
    cone.apply_translation([0, 0, -0.5])
    return cone


@pytest.fixture(scope="module")
def cone_video():
    return render_orbit(upright_cone(), n_frames=3, fps=240, resolution=RES)


def test_video_shape_dtype_range_and_times(cone_video):
    video, t_us = cone_video
    assert video.shape == (3, RES, RES) and video.dtype == np.float32
    assert video.min() >= 0.0 and video.max() <= 1.0
    assert t_us.dtype == np.int64 and t_us.tolist() == [0, 4167, 8333]
    # 8-bit gray levels
    np.testing.assert_array_equal(video * 255, np.rint(video * 255))


def test_background_white_object_in_centre(cone_video):
    video, _ = cone_video
    for frame in video:
        assert np.all(frame[[0, 0, -1, -1], [0, -1, 0, -1]] == 1.0)  # corners: background
        assert frame[RES // 2 + 4, RES // 2] < 0.9  # the cone's body covers the centre
        dark = frame < 0.95
        rows, cols = np.nonzero(dark)
        assert abs(cols.mean() - (RES - 1) / 2) < 2.5  # symmetric about the vertical axis


def test_cone_is_upright_from_above_and_below(cone_video):
    video, _ = cone_video
    cams = orbit_cameras(3)
    for frame, cam in zip(video, cams, strict=True):
        dark = frame < 0.95
        top, bottom = dark[: RES // 2].sum(), dark[RES // 2:].sum()
        assert top < bottom  # narrow tip at the top of the image, wide base below
        tip_row = project_points([[0, 0, 0.5]], cam, RES)[0, 1]
        first_dark_row = np.flatnonzero(dark.any(axis=1))[0]
        assert abs(first_dark_row - tip_row) <= 2


def test_off_centre_sphere_lands_where_projected():
    centre = np.array([0.3, 0.2, 0.25])
    ball = trimesh.creation.icosphere(subdivisions=2, radius=0.1)
    ball.apply_translation(centre)
    video, _ = render_orbit(ball, n_frames=4, resolution=64)
    for frame, cam in zip(video, orbit_cameras(4), strict=True):
        rows, cols = np.nonzero(frame < 0.99)
        col, row = project_points([centre], cam, 64)[0]
        assert abs(cols.mean() - col) < 1.0 and abs(rows.mean() - row) < 1.0


def test_render_is_deterministic_and_accepts_polydata(cone_video):
    import pyvista as pv

    cone = upright_cone()
    again, _ = render_orbit(cone, n_frames=3, resolution=RES)
    np.testing.assert_array_equal(again, cone_video[0])
    faces = np.hstack([np.full((len(cone.faces), 1), 3), cone.faces]).ravel()
    poly = pv.PolyData(np.asarray(cone.vertices), faces)
    from_poly, _ = render_orbit(poly, n_frames=3, resolution=RES)
    np.testing.assert_array_equal(from_poly, cone_video[0])


def test_oversampling_samples_the_same_path_densely(cone_video):
    video, t_us = render_orbit(upright_cone(), n_frames=3, fps=240, resolution=RES,
                               oversample=2)
    assert video.shape == (5, RES, RES)
    assert t_us.tolist() == [0, 2083, 4167, 6250, 8333]
    np.testing.assert_array_equal(video[::2], cone_video[0])
    assert not np.array_equal(video[1], video[0])


@pytest.mark.parametrize("renderer", [render_orbit, render_orbit_cached])
def test_plotter_closed_when_rendering_fails(monkeypatch, renderer):
    import pyvista as pv

    made = []

    class FailingPlotter(pv.Plotter):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            made.append(self)

        def add_mesh(self, *args, **kwargs):
            raise RuntimeError("boom")

    monkeypatch.setattr(pv, "Plotter", FailingPlotter)
    with pytest.raises(RuntimeError, match="boom"):
        renderer(upright_cone(), n_frames=2, resolution=16)
    assert len(made) == 1 and made[0].render_window is None  # closed
    kept = [plotter for _, plotter in render_cache._PLOTTERS.values()]
    assert all(plotter is not made[0] for plotter in kept)  # not kept


@pytest.mark.parametrize(
    "mesh, kwargs, match",
    [
        ("not a mesh", {}, "trimesh.Trimesh or pyvista.PolyData"),
        (trimesh.Trimesh(), {}, "empty"),
        (None, {"n_frames": 1}, "n_frames"),
        (None, {"resolution": 0}, "resolution"),
        (None, {"oversample": 0}, "oversample"),
        (None, {"fps": 0}, "fps"),
    ],
)
def test_bad_input(mesh, kwargs, match):
    with pytest.raises(ValueError, match=match):
        render_orbit(upright_cone() if mesh is None else mesh, **kwargs)



def test_video_frame_count_keeps_its_old_keyword():
    np.testing.assert_array_equal(orbit_cameras(n_frames=7), orbit_cameras(n_video_frames=7))
    np.testing.assert_array_equal(orbit_cameras(7), orbit_cameras(n_video_frames=7))
    with pytest.raises(TypeError, match="not both"):
        orbit_cameras(n_video_frames=5, n_frames=7)


def test_render_refuses_frame_rates_beyond_microsecond_stamps():
    with pytest.raises(ValueError, match="time stamps would coincide"):
        render_orbit(trimesh.creation.box((0.5, 0.5, 0.5)), n_video_frames=3, fps=1e9)


@pytest.mark.parametrize("scale, offset, problem", [
    (1.0, (5.0, 0.0, 0.0), "from the origin"),
    (100.0, (0.0, 0.0, 0.0), "longest side"),
    (1e-4, (0.0, 0.0, 0.0), "longest side"),
])
def test_render_refuses_objects_the_orbit_cannot_frame(scale, offset, problem):
    mesh = trimesh.creation.box((scale, scale, scale))
    mesh.apply_translation(offset)
    with pytest.raises(ValueError, match=problem):
        render_orbit(mesh, n_video_frames=3, resolution=16)


def _kept(resolution: int) -> list:
    return [plotter for key, (_, plotter) in render_cache._PLOTTERS.items()
            if key[1] == resolution]


def test_reused_plotter_renders_each_mesh_as_a_fresh_one(cone_video):
    ball = trimesh.creation.icosphere(subdivisions=2, radius=0.3)
    fresh_ball, _ = render_orbit(ball, n_frames=3, resolution=RES)
    render_orbit_cached(upright_cone(), n_frames=3, resolution=RES)
    cached_ball, _ = render_orbit_cached(ball, n_frames=3, resolution=RES)  # after the cone
    np.testing.assert_array_equal(cached_ball, fresh_ball)
    again, _ = render_orbit_cached(upright_cone(), n_frames=3, resolution=RES)  # after the ball
    np.testing.assert_array_equal(again, cone_video[0])
    assert len(_kept(RES)) == 1  # one plotter for this resolution and anti-aliasing, reused
    plotter = _kept(RES)[0]
    assert plotter.render_window is not None and len(plotter.renderer.actors) == 0  # mesh gone
    assert len(plotter.renderer.lights) == 3  # lights stay


@pytest.mark.parametrize("anti_aliasing", ANTI_ALIASING)
def test_kept_plotters_render_the_videos_of_fresh_ones(anti_aliasing):
    # every mode, several meshes one after another, plain and oversampled: identical videos
    meshes = [upright_cone(), trimesh.creation.icosphere(subdivisions=2, radius=0.3),
              trimesh.creation.box((0.2, 0.6, 0.4))]
    for oversample in (1, 2):
        for mesh in meshes:
            kw = {"n_video_frames": 4, "resolution": 24, "oversample": oversample,
                  "anti_aliasing": anti_aliasing}
            fresh, t_fresh = render_orbit(mesh, **kw)
            kept, t_kept = render_orbit_cached(mesh, **kw)
            np.testing.assert_array_equal(kept, fresh)
            np.testing.assert_array_equal(t_kept, t_fresh)


def test_a_lent_plotter_is_left_open_and_empty(cone_video):
    plotter = make_plotter(RES, True)
    try:
        for _ in range(2):
            video, _ = render_orbit(upright_cone(), n_frames=3, resolution=RES, plotter=plotter)
            np.testing.assert_array_equal(video, cone_video[0])
            assert plotter.render_window is not None and len(plotter.renderer.actors) == 0
        with pytest.raises(ValueError, match="make_plotter"):  # made for another size
            render_orbit(upright_cone(), n_frames=3, resolution=RES + 1, plotter=plotter)
    finally:
        plotter.close()


def test_busy_cache_falls_back_to_a_private_plotter(cone_video):
    before = dict(render_cache._PLOTTERS)
    with render_cache._LOCK:  # as if another thread were rendering with the kept plotters
        video, _ = render_orbit_cached(upright_cone(), n_frames=3, resolution=RES)
    np.testing.assert_array_equal(video, cone_video[0])
    assert render_cache._PLOTTERS == before


def test_release_plotters_closes_the_cached_ones():
    render_orbit_cached(upright_cone(), n_frames=2, resolution=20)
    plotters = [plotter for _, plotter in render_cache._PLOTTERS.values()]
    assert release_plotters() == len(plotters) >= 1
    assert not render_cache._PLOTTERS and all(p.render_window is None for p in plotters)
    video, _ = render_orbit_cached(upright_cone(), n_frames=2, resolution=20)  # made again
    assert video.shape == (2, 20, 20)


def test_plotter_cache_is_bounded():
    release_plotters()
    for res in range(16, 16 + render_cache.MAX_CACHED_PLOTTERS + 2):
        render_orbit_cached(upright_cone(), n_frames=2, resolution=res)
    assert len(render_cache._PLOTTERS) == render_cache.MAX_CACHED_PLOTTERS
    assert [key[1] for key in render_cache._PLOTTERS][-1] == res  # most recent kept


def test_pyvista_wrap_keeps_the_trimesh_faces():
    import pyvista as pv

    cone = upright_cone()
    poly = pv.wrap(cone)
    np.testing.assert_array_equal(poly.regular_faces, cone.faces)
    np.testing.assert_array_equal(poly.points, cone.vertices)


def test_screenshot_reads_the_pixels_pyvista_returns(cone_video):
    plotter = make_plotter(RES, True)
    try:
        plotter.add_mesh(render._checked_polydata(upright_cone()), smooth_shading=False,
                         **render._MATERIAL)
        position = orbit_cameras(3)[1]
        render.aim_camera(plotter.camera, position, camera_axes(position)[2])
        fast = render._screenshot(plotter)
        np.testing.assert_array_equal(fast, plotter.screenshot(return_img=True))
        assert np.array_equal(render._to_grey(fast, 1), cone_video[0][1])
    finally:
        plotter.close()


def test_the_renderer_aims_with_the_orbit_camera_axes():
    # VTK's view matrix has rows right, up, -forward: those of e2vlib.orbit.camera_axes, so
    # project_points (tests above and in test_geometry.py) sees what the renderer draws
    import vtk

    camera = vtk.vtkCamera()
    for position in orbit_cameras(7):
        forward, right, up = camera_axes(position)
        render.aim_camera(camera, position, up)
        matrix = camera.GetViewTransformMatrix()
        rows = np.array([[matrix.GetElement(r, c) for c in range(3)] for r in range(3)])
        np.testing.assert_allclose(rows, [right, up, -forward], atol=1e-12)
        assert camera.GetViewAngle() == VIEW_ANGLE_DEG


def test_anti_aliasing_modes():
    assert ANTI_ALIASING == ("ssaa", "msaa", "supersample", "none")
    cone = upright_cone()
    videos = {aa: render_orbit(cone, n_frames=3, resolution=RES, anti_aliasing=aa)[0]
              for aa in ANTI_ALIASING}
    np.testing.assert_array_equal(render_orbit(cone, n_frames=3, resolution=RES,
                                               anti_aliasing=False)[0], videos["msaa"])
    for aa, video in videos.items():
        assert video.shape == (3, RES, RES) and video.dtype == np.float32, aa
        np.testing.assert_array_equal(video * 255, np.rint(video * 255))  # 8-bit levels
        assert np.all(video[:, 0, 0] == 1.0), aa  # white background
        # the same silhouette up to the edge pixels that anti-aliasing greys
        assert np.mean((video < 0.9) != (videos["ssaa"] < 0.9)) < 0.03, aa
    # without anti-aliasing every edge pixel is either object or background: fewer greys
    def n_levels(v):
        return len(np.unique(v))
    assert n_levels(videos["none"]) < n_levels(videos["supersample"])
    with pytest.raises(ValueError, match="anti_aliasing"):
        render_orbit(cone, n_frames=3, resolution=RES, anti_aliasing="fxaa")
