"""The orbit's clock and geometry (e2vlib.orbit): one home, the same numbers everywhere.

render, geometry and the dataset's grey video all read the orbit from e2vlib.orbit; these
tests check that the old names are the same objects and that the clock primitives give
exactly what the dataset's functions compute from a config.
"""

import subprocess
import sys

import numpy as np
import pytest

from e2vlib import geometry, orbit, paper, render


def test_the_orbit_has_one_home():
    # render keeps orbit_cameras (its public name); the rest is read from e2vlib.orbit only
    assert render.orbit_cameras is orbit.orbit_cameras
    for name in ("orbit_angles", "project_points", "pixel_motion_per_frame",
                 "required_oversample", "FOCAL_LENGTH_MM", "SENSOR_SIZE_MM", "Z_TOP_M",
                 "Z_BOTTOM_M", "RADIUS_END_M", "RADIUS_MID_M", "AZIMUTH_START_DEG",
                 "n_rendered", "_n_rendered", "to_polydata", "release_plotters",
                 "headless_opengl_window"):
        assert not hasattr(render, name), name
    assert "VIEW_ANGLE_DEG" not in render.__all__  # render uses it; orbit exports it
    assert geometry.orbit_camera_at is orbit.orbit_camera_at


def test_camera_axes_are_orthonormal_and_keep_z_up():
    cams = orbit.orbit_cameras(37)
    forward, right, up = orbit.camera_axes(cams)  # a stack of cameras at once
    assert forward.shape == right.shape == up.shape == (37, 3)
    for a, b in ((forward, right), (forward, up), (right, up)):
        np.testing.assert_allclose(np.sum(a * b, axis=1), 0.0, atol=1e-12)
    for axis in (forward, right, up):
        np.testing.assert_allclose(np.linalg.norm(axis, axis=1), 1.0)
    np.testing.assert_allclose(forward, -cams / np.linalg.norm(cams, axis=1, keepdims=True))
    assert np.all(right[:, 2] == 0) and np.all(up[:, 2] > 0)  # level right, +z up in the image
    np.testing.assert_allclose(np.cross(right, up), -forward, atol=1e-12)  # right-handed
    for i in (0, 18, 36):  # one camera at a time gives the same axes
        for stacked, single in zip((forward, right, up), orbit.camera_axes(cams[i]),
                                   strict=True):
            np.testing.assert_array_equal(single, stacked[i])
    with pytest.raises(ValueError, match="z axis"):
        orbit.camera_axes([0.0, 0.0, 5.0])


def test_project_points_uses_the_camera_axes():
    cam = orbit.orbit_cameras(5)[1]
    forward, right, up = orbit.camera_axes(cam)
    res = 64
    focal = 0.5 * res / np.tan(np.radians(orbit.VIEW_ANGLE_DEG / 2))
    point = 0.2 * right + 0.1 * up  # in the plane through the origin facing the camera
    depth = float(np.dot(point - cam, forward))
    col, row = orbit.project_points([point], cam, res)[0]
    assert col == pytest.approx((res - 1) / 2 + focal * 0.2 / depth)
    assert row == pytest.approx((res - 1) / 2 - focal * 0.1 / depth)


def test_orbit_imports_only_numpy_and_paper():
    code = ("import sys, e2vlib.orbit; "
            "print(sorted(m for m in sys.modules if m.startswith('e2vlib.')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, timeout=120)
    assert out.stdout.strip() == "['e2vlib.orbit', 'e2vlib.paper']"


@pytest.mark.parametrize("oversample", [1, 2, 3, 5])
def test_the_clock_and_cameras_agree(oversample):
    t = orbit.rendered_times_us(paper.N_VIDEO_FRAMES, paper.VIDEO_FPS, oversample)
    cams = orbit.rendered_cameras(paper.N_VIDEO_FRAMES, oversample)
    assert t.dtype == np.int64 and len(t) == len(cams) == orbit.n_rendered(120, oversample)
    assert (t[::oversample] == orbit.rendered_times_us()).all()
    assert (cams[::oversample] == orbit.orbit_cameras()).all()
    # the camera at a rendered frame's time is that frame's camera
    np.testing.assert_allclose(orbit.orbit_camera_at(t), cams, atol=2e-4)


@pytest.mark.parametrize(("oversample", "n_frames", "dt_us"),
                         [(1, 100, 5000), (3, 100, 5000), (2, 50, 10_000), (3, 120, 4000)])
def test_window_primitives_equal_the_dataset_grey_video(oversample, n_frames, dt_us):
    from e2vlib.data import BuildConfig, grey_frame_cameras, grey_frame_indices

    config = BuildConfig(categories=("chair",), per_category=1, oversample=oversample,
                         n_frames=n_frames, dt_us=dt_us)
    index = orbit.window_frame_indices(n_frames, dt_us, oversample=oversample)
    assert (index == grey_frame_indices(config)).all()
    assert (orbit.window_cameras(n_frames, dt_us, oversample=oversample)
            == grey_frame_cameras(config)).all()
    t = orbit.rendered_times_us(oversample=oversample)
    assert (index == orbit.nearest_frames(t, n_frames, dt_us)).all()


def test_the_clock_refuses_bad_settings():
    with pytest.raises(ValueError, match="time stamps would coincide"):
        orbit.rendered_times_us(120, 600_000, oversample=2)
    with pytest.raises(ValueError, match="fps"):
        orbit.rendered_times_us(120, 0)
    with pytest.raises(ValueError, match="oversample"):
        orbit.n_rendered(120, 0)
    with pytest.raises(ValueError, match="n_windows"):
        orbit.window_frame_indices(0, 5000)
