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


def test_render_and_geometry_reexport_the_orbit():
    for name in ("orbit_cameras", "orbit_angles", "project_points", "pixel_motion_per_frame",
                 "required_oversample", "VIEW_ANGLE_DEG", "FOCAL_LENGTH_MM", "SENSOR_SIZE_MM",
                 "Z_TOP_M", "Z_BOTTOM_M", "RADIUS_END_M", "RADIUS_MID_M", "AZIMUTH_START_DEG"):
        assert getattr(render, name) is getattr(orbit, name), name
    assert geometry.orbit_camera_at is orbit.orbit_camera_at
    assert render._n_rendered(120, 3) == orbit.n_rendered(120, 3) == 358


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
    from e2vlib.data import (
        BuildConfig,
        grey_frame_cameras,
        grey_frame_indices,
        nearest_frames,
        rendered_times_us,
    )

    config = BuildConfig(categories=("chair",), per_category=1, oversample=oversample,
                         n_frames=n_frames, dt_us=dt_us)
    t = orbit.rendered_times_us(oversample=oversample)
    assert (t == rendered_times_us(config)).all()
    index = orbit.window_frame_indices(n_frames, dt_us, oversample=oversample)
    assert (index == grey_frame_indices(config)).all()
    assert (orbit.window_cameras(n_frames, dt_us, oversample=oversample)
            == grey_frame_cameras(config)).all()
    assert (orbit.nearest_frames(t, n_frames, dt_us) == nearest_frames(t, n_frames, dt_us)).all()


def test_the_clock_refuses_bad_settings():
    with pytest.raises(ValueError, match="time stamps would coincide"):
        orbit.rendered_times_us(120, 600_000, oversample=2)
    with pytest.raises(ValueError, match="fps"):
        orbit.rendered_times_us(120, 0)
    with pytest.raises(ValueError, match="oversample"):
        orbit.n_rendered(120, 0)
    with pytest.raises(ValueError, match="n_windows"):
        orbit.window_frame_indices(0, 5000)
