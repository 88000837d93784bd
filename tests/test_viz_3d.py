"""3D views (pyvista, off screen), screenshots, the interactive viewer, and exports."""

import os
import subprocess
import sys

import numpy as np
import pytest

pv = pytest.importorskip("pyvista")

from e2vlib import _headless, viz  # noqa: E402
from e2vlib.events import make_events  # noqa: E402
from e2vlib.voxels import read_binvox  # noqa: E402


def _block(lo: int, hi: int, size: int = 32) -> np.ndarray:
    grid = np.zeros((size,) * 3, dtype=bool)
    grid[lo:hi, lo:hi, lo:hi] = True
    return grid


def _object(image: np.ndarray) -> np.ndarray:
    """Pixels of shaded cubes: darker than the white background and the grey floor grid
    (#c8c8c8 = 200, lighter still where anti-aliased)."""
    return image.max(axis=2) < 190


def _texts(plotter) -> str:
    out = []
    for renderer in plotter.renderers:
        for actor in renderer.actors.values():
            if type(actor).__name__ == "CornerAnnotation":
                out += [actor.GetText(i) or "" for i in range(8)]
            elif hasattr(actor, "GetInput") and isinstance(actor.GetInput(), str):
                out.append(actor.GetInput())
    return "\n".join(out)


@pytest.fixture
def closing():
    """Collects plotters and closes them after the test."""
    made = []
    yield made.append
    for plotter in made:
        plotter.close()


# --- events ---------------------------------------------------------------------------------


def test_event_cloud_places_events_at_x_t_y_up():
    ev = make_events(x=[0, 3, 1], y=[0, 2, 1], t=[1000, 3000, 5000], p=[1, -1, 1])
    cloud = viz.event_cloud(ev, (4, 3), t_scale=2.0)
    # x in px, (t - t_first) in ms times 2 px/ms, y flipped: height - 1 - y
    np.testing.assert_allclose(cloud.points, [[0, 0, 2], [3, 4, 0], [1, 8, 1]])
    assert cloud.point_data["polarity"].tolist() == [1, -1, 1]
    # default scale: the stream spans twice the sensor width (2 * 4 px over 4 ms)
    default = viz.event_cloud(ev, (4, 3))
    assert np.isclose(np.ptp(default.points[:, 1]), 8.0)
    assert np.isclose(default.field_data["t_scale"][0], 2.0)
    with pytest.raises(ValueError, match="no events"):
        viz.event_cloud(ev[:0], (4, 3))
    with pytest.raises(ValueError, match="t_scale"):
        viz.event_cloud(ev, (4, 3), t_scale=0)


def test_event_cloud_subsamples_and_leaves_input_alone(random_events):
    ev, size = random_events
    before = ev.copy()
    cloud = viz.event_cloud(ev, size, max_events=500)
    assert cloud.n_points == 500
    assert np.all(np.diff(cloud.point_data["t_ms"]) >= 0)  # still in time order
    assert np.array_equal(ev, before)


def test_view_events_shows_both_polarities(random_events, closing):
    ev, size = random_events
    plotter = viz.view_events(ev, size, max_events=5000, off_screen=True, window_size=(400, 300))
    closing(plotter)
    image = viz.screenshot(plotter)
    assert image.shape == (300, 400, 3) and image.dtype == np.uint8
    rgb = image.astype(int)
    red = (rgb[..., 0] > 150) & (rgb[..., 2] < 100)
    blue = (rgb[..., 2] > 120) & (rgb[..., 0] < 80)
    assert red.sum() > 200 and blue.sum() > 200


# --- voxels ---------------------------------------------------------------------------------


def test_view_voxels_object_visible_and_grows_with_voxels(closing):
    counts = []
    for lo, hi in ((16, 16), (13, 19), (8, 24)):  # empty, 6^3, 16^3 centred blocks
        plotter = viz.view_voxels(_block(lo, hi), off_screen=True, window_size=(300, 300))
        closing(plotter)
        image = viz.screenshot(plotter)[40:270]  # leave out the texts at the edges
        counts.append((_object(image).sum(), _object(image[100:120, 140:160]).mean()))
    (empty, _), (small, small_centre), (large, large_centre) = counts
    assert empty == 0  # nothing drawn but the grey floor grid
    assert small > 300 and large > 4 * small  # area grows about as the side squared
    assert small_centre > 0.9 and large_centre > 0.9  # the centred object covers the centre


def test_view_voxels_colours_probabilities_and_respects_threshold(closing):
    grid = np.zeros((32, 32, 32), dtype=np.float32)
    grid[8:24, 8:24, 8:24] = 0.5
    grid[8:24, 8:24, 20:24] = 0.95
    high = viz.view_voxels(grid, threshold=0.9, off_screen=True, window_size=(300, 300))
    low = viz.view_voxels(grid, threshold=0.3, off_screen=True, window_size=(300, 300))
    closing(high)
    closing(low)
    assert "1024 voxels >= 0.9" in _texts(high)  # 16 x 16 x 4
    assert "4096 voxels >= 0.3" in _texts(low)
    # coloured by value: viridis gives saturated (non-grey) colours
    image = viz.screenshot(low).astype(int)
    saturated = (image.max(axis=2) - image.min(axis=2)) > 60
    assert saturated.sum() > 2000


def test_view_reconstructions_links_2_by_n_views(closing):
    gt = _block(2, 6, size=8)
    pred = gt * np.float32(0.9)
    pred[2, 2, 2] = 0.1  # one voxel missed: IoU 63 / 64
    plotter = viz.view_reconstructions([gt, gt, gt], [pred, pred, gt], titles=["a", "b", "c"],
                                       off_screen=True, panel_size=120)
    closing(plotter)
    assert plotter.shape == (2, 3) and len(plotter.renderers) == 6
    cameras = {r.GetActiveCamera().GetAddressAsString("vtkCamera") for r in plotter.renderers}
    assert len(cameras) == 1  # linked: one camera for all views
    text = _texts(plotter)
    assert text.count("IoU@0.3 = 0.98") == 2 and text.count("IoU@0.3 = 1.00") == 1
    assert "a\nground truth" in text
    assert list(plotter.scalar_bars.keys()) == ["probability"]  # one bar for the whole figure
    unlinked = viz.view_reconstructions(gt, pred, off_screen=True, link=False)
    closing(unlinked)
    assert unlinked.shape == (2, 1)
    assert len({r.GetActiveCamera().GetAddressAsString("vtkCamera")
                for r in unlinked.renderers}) == 2
    with pytest.raises(ValueError, match="as many truths"):
        viz.view_reconstructions([gt, gt], [pred])
    with pytest.raises(ValueError, match="titles"):
        viz.view_reconstructions([gt], [pred], titles=["a", "b"])


def test_view_mesh_voxels_draws_mesh_and_edges(closing):
    import trimesh

    mesh = trimesh.creation.box(extents=(0.5, 0.5, 0.5))
    plotter = viz.view_mesh_voxels(mesh, _block(8, 24), off_screen=True, window_size=(300, 300))
    closing(plotter)
    image = viz.screenshot(plotter).astype(int)
    tan = (image[..., 0] > image[..., 2] + 25) & (image[..., 0] > 120)
    dark_blue = (image[..., 2] > image[..., 0] + 30) & (image[..., 0] < 110)
    assert tan.sum() > 2000 and dark_blue.sum() > 500
    assert "4096 voxels" in _texts(plotter)
    with pytest.raises(ValueError, match="opacity"):
        viz.view_mesh_voxels(mesh, _block(8, 24), mesh_opacity=0)


# --- the building blocks lessons compose their own scenes from -------------------------------


def test_new_plotter_add_voxels_and_aim_at_object_compose_a_scene(closing):
    plotter = viz.new_plotter(off_screen=True, window_size=(320, 160), shape=(1, 2))
    closing(plotter)
    assert plotter.shape == (1, 2) and tuple(plotter.window_size) == (320, 160)
    plotter.subplot(0, 0)
    assert viz.add_voxels(plotter, _block(8, 24), 0.5) == 16**3
    viz.aim_at_object(plotter)
    position, focus, up = plotter.camera_position
    assert np.allclose(focus, 0) and np.allclose(up, (0, 0, 1))
    direction = np.asarray(position) / np.linalg.norm(position)
    assert np.allclose(direction, np.asarray(viz.OBJECT_VIEW) / np.linalg.norm(viz.OBJECT_VIEW))
    angle = plotter.camera.view_angle
    viz.aim_at_object(plotter, zoom=2.0)
    assert np.isclose(angle / plotter.camera.view_angle, 2.0)  # zoom 2: half the view angle
    plotter.subplot(0, 1)
    probs = _block(8, 24) * np.float32(0.4)
    assert viz.add_voxels(plotter, probs, 0.5, cmap="viridis", scalar_bar=False) == 0
    assert "no voxel >= 0.5" in _texts(plotter)
    viz.aim_at_object(plotter)
    image = viz.screenshot(plotter)
    assert image.shape == (160, 320, 3)
    body = image[30:]  # below the corner texts
    left, right = _object(body[:, :160]), _object(body[:, 160:])
    assert left.sum() > 1000 and right.sum() == 0  # cubes only where some were added
    assert np.all(image[2, 2] == 255)  # white background
    with pytest.raises(ValueError, match="direction"):
        viz.aim_at_object(plotter, direction=(0, 0, 0))
    with pytest.raises(ValueError, match="along z"):
        viz.aim_at_object(plotter, direction=(0, 0, 2))
    with pytest.raises(ValueError, match="zoom"):
        viz.aim_at_object(plotter, zoom=0)


@pytest.mark.slow  # end to end, seconds: runs in make test-all
def test_plotters_made_headless_print_no_x_server_warning(capfd):
    """VTK probes for an X server before falling back to EGL and says so on stderr
    ("bad X server connection"); viz picks the headless window first.

    Runs in a fresh interpreter without DISPLAY (VTK probes once per process), writing to
    this process's stderr, which capfd reads. The control run, a bare pyvista plotter,
    shows that the warning does appear on this machine without the fix.
    """
    if not sys.platform.startswith("linux"):
        pytest.skip("the X probe happens on Linux only")
    env = {k: v for k, v in os.environ.items()
           if k not in ("DISPLAY", "WAYLAND_DISPLAY", "VTK_DEFAULT_OPENGL_WINDOW")}
    render = ("plotter.add_mesh(pyvista.Sphere()); "
              "print('rendered', plotter.screenshot(return_img=True).shape)")
    via_viz = ("import pyvista; from e2vlib import viz; "
               "plotter = viz.new_plotter(off_screen=True, window_size=(64, 48)); " + render)
    bare = ("import pyvista; "
            "plotter = pyvista.Plotter(off_screen=True, window_size=(64, 48)); " + render)
    capfd.readouterr()
    subprocess.run([sys.executable, "-c", bare], env=env, check=True, timeout=120)
    control = capfd.readouterr()
    if "bad X server" not in control.err:
        pytest.skip("this VTK build does not probe for X here; nothing to show")
    subprocess.run([sys.executable, "-c", via_viz], env=env, check=True, timeout=120)
    fixed = capfd.readouterr()
    assert "rendered (48, 64, 3)" in fixed.out
    assert "bad X server" not in fixed.err and "bad X server" not in fixed.out


def test_headless_opengl_window_respects_the_user_and_a_display(monkeypatch):
    monkeypatch.setenv("VTK_DEFAULT_OPENGL_WINDOW", "vtkOSOpenGLRenderWindow")
    assert _headless.headless_opengl_window() == "vtkOSOpenGLRenderWindow"  # the user's choice
    monkeypatch.delenv("VTK_DEFAULT_OPENGL_WINDOW")
    monkeypatch.setenv("DISPLAY", ":0")
    assert _headless.headless_opengl_window() is None  # a display: VTK chooses (X)
    assert "VTK_DEFAULT_OPENGL_WINDOW" not in os.environ


# --- the camera orbit -----------------------------------------------------------------------


def test_camera_frustum_geometry():
    from e2vlib.orbit import VIEW_ANGLE_DEG

    position = np.array([0.0, -4.0, 2.0])
    lines, base = viz.camera_frustum(position, depth=2.0)
    np.testing.assert_allclose(lines.points[0], position)
    direction = -position / np.linalg.norm(position)
    np.testing.assert_allclose(base.points.mean(axis=0), position + 2.0 * direction, atol=1e-12)
    half = 2.0 * np.tan(np.radians(VIEW_ANGLE_DEG / 2))
    np.testing.assert_allclose(np.linalg.norm(base.points[0] - base.points[1]), 2 * half)
    assert base.points[0, 2] > base.points[3, 2]  # first corner at the top (image top-left)
    assert base.points[0, 0] < base.points[1, 0]  # ... and left: +x is right seen from -y
    with pytest.raises(ValueError, match="z axis"):
        viz.camera_frustum((0.0, 0.0, 3.0))


def test_view_orbit_scene(closing):
    import trimesh

    mesh = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    plotter = viz.view_orbit(mesh, n_frames=41, every=20, off_screen=True, window_size=(300, 200))
    closing(plotter)
    # path + object + 3 frusta (frames 0, 20, 40) x (lines, base, sight line) + labels
    assert len(plotter.renderer.actors) >= 2 + 3 * 3
    assert viz.screenshot(plotter).std() > 5
    video = np.zeros((41, 8, 8), dtype=np.float32)
    textured = viz.view_orbit(mesh, n_frames=41, video=video, off_screen=True)
    closing(textured)
    with pytest.raises(ValueError, match="video"):
        viz.view_orbit(mesh, n_frames=41, video=video[:5])
    with pytest.raises(ValueError, match="every"):
        viz.view_orbit(mesh, every=0)


def _path_times(plotter) -> np.ndarray:
    """The "time [ms]" of the camera path drawn by view_orbit."""
    for actor in plotter.renderer.actors.values():
        data = getattr(getattr(actor, "mapper", None), "dataset", None)
        if data is not None and "time [ms]" in data.point_data:
            return np.asarray(data.point_data["time [ms]"])
    raise AssertionError("no camera path in the scene")


def test_view_orbit_counts_video_frames_under_either_name(closing):
    import trimesh

    mesh = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    new = viz.view_orbit(mesh, n_video_frames=41, every=20, off_screen=True)
    old = viz.view_orbit(mesh, n_frames=41, every=20, off_screen=True)  # the old keyword
    default = viz.view_orbit(mesh, every=20, off_screen=True)
    for plotter in (new, old, default):
        closing(plotter)
    assert len(new.renderer.actors) == len(old.renderer.actors)
    assert len(default.renderer.actors) > len(new.renderer.actors)  # 120 frames: more frusta
    assert np.isclose(_path_times(new).max(), 40 / 240 * 1e3)  # frame 40 at 240 fps
    assert np.isclose(_path_times(default).max(), 119 / 240 * 1e3)  # the paper's 120 frames
    with pytest.raises(ValueError, match=r"video must be \(41, H, W\)"):
        viz.view_orbit(mesh, 41, video=np.zeros((5, 8, 8)))
    with pytest.raises(TypeError, match="not both"):
        viz.view_orbit(mesh, n_video_frames=30, n_frames=41)


# --- screenshots and the interactive viewer -------------------------------------------------


def test_screenshot_of_unshown_plotter_and_png(tmp_path, closing):
    from PIL import Image

    plotter = viz.view_voxels(_block(8, 24), window_size=(200, 160))  # off_screen=None
    closing(plotter)
    path = tmp_path / "sub" / "voxels.png"
    image = viz.screenshot(plotter, path)
    assert image.shape == (160, 200, 3)
    assert np.array_equal(np.asarray(Image.open(path).convert("RGB")), image)
    assert [p.name for p in path.parent.iterdir()] == ["voxels.png"]  # no temp file left
    plotter.close()
    with pytest.raises(ValueError, match="closed"):
        viz.screenshot(plotter)


def test_interactive_trame_viewer_can_be_built(closing):
    """The JupyterLab path: pyvista's trame backend builds a viewer for our scenes.

    No browser or server is started: this builds the trame UI (the page a browser would
    load) around the plotter, which is what ``.show()`` does with the trame backend.
    """
    trame_app = pytest.importorskip("trame.app")
    trame_jupyter = pytest.importorskip("trame_pyvista.jupyter")
    grid = _block(8, 24)
    for name, plotter in (
        ("voxels", viz.view_voxels(grid, off_screen=True)),
        ("linked", viz.view_reconstructions([grid, grid], [grid, grid], off_screen=True)),
    ):
        closing(plotter)
        server = trame_app.get_server(name=f"e2v-test-{name}", client_type="vue3")
        viewer = trame_jupyter.initialize(server, plotter, mode="trame")
        html = viewer.layout.html
        assert "vtk-remote-local-view" in html  # the interactive VTK view widget
        assert not server.running


def test_backend_comes_from_the_environment():
    env = {**os.environ, "PYVISTA_JUPYTER_BACKEND": "static"}
    code = "import pyvista; print(pyvista.global_theme.jupyter_backend)"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         check=True, timeout=120)
    assert out.stdout.strip() == "static"


@pytest.mark.parametrize("name", ["00_start_here.ipynb", "08_visualizing_in_3d.ipynb"])
def test_lessons_leave_the_backend_to_the_environment(name):
    import json
    from pathlib import Path

    nb = json.loads((Path(__file__).resolve().parents[1] / "notebooks" / name).read_text())
    code = "\n".join("".join(c["source"]) for c in nb["cells"] if c["cell_type"] == "code")
    assert ".show()" in code  # the 3D views are shown through pyvista's backend ...
    for forbidden in ("jupyter_backend=", "set_jupyter_backend", "PYVISTA_JUPYTER_BACKEND",
                      "pv.OFF_SCREEN"):
        assert forbidden not in code  # ... which the notebook never chooses


# --- exports --------------------------------------------------------------------------------


def test_probability_mesh_of_a_block_follows_voxel_faces():
    mesh = viz.probability_mesh(_block(8, 24).astype(np.float32), threshold=0.5)
    assert mesh.is_watertight and mesh.volume > 0  # closed, normals outwards
    np.testing.assert_allclose(mesh.bounds, [[-0.25] * 3, [0.25] * 3], atol=1e-9)
    # a 0.5 m cube with its 12 edges cut diagonally (legs of half a voxel, h = 1/64 m):
    # 0.125 - 12 * 0.5 * h^2 / 2, up to the corners
    assert abs(mesh.volume - (0.125 - 3 / 64**2)) < 5e-5
    with pytest.raises(ValueError, match="no voxel"):
        viz.probability_mesh(np.zeros((8, 8, 8)), 0.5)
    with pytest.raises(ValueError, match="threshold"):
        viz.probability_mesh(np.ones((8, 8, 8)), 1.0)


def test_export_reconstruction_round_trips(tmp_path):
    import trimesh

    rng = np.random.default_rng(0)
    probs = np.clip(_block(6, 20) * 0.8 + rng.random((32, 32, 32)) * 0.25, 0, 1)
    probs[0, :, :] = 0.9  # touches the border: the mesh must stay inside the cube
    probs = probs.astype(np.float32)
    before = probs.copy()
    (tmp_path / "chair.binvox").write_text("old")  # replaced, never appended to
    paths = viz.export_reconstruction(probs, tmp_path, threshold=0.3, name="chair")
    assert sorted(paths) == sorted(viz.EXPORT_SUFFIXES)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        f"chair{s}" for s in viz.EXPORT_SUFFIXES.values())  # nothing else left behind
    assert np.array_equal(read_binvox(paths["binvox"]), probs >= 0.3)
    obj = trimesh.load(paths["obj"], force="mesh")
    assert obj.is_watertight
    assert np.all(obj.bounds >= -0.5) and np.all(obj.bounds <= 0.5)
    assert np.isclose(obj.bounds[0, 0], -0.5)  # the border slab reaches the cube's face
    stl = trimesh.load(paths["stl"], force="mesh")
    assert np.isclose(stl.volume, obj.volume, rtol=1e-4)
    image = pv.read(paths["vti"])
    np.testing.assert_allclose(
        np.asarray(image.cell_data["probability"]).reshape((32, 32, 32), order="F"), probs)
    assert pv.read(paths["vtu"]).n_cells == int((probs >= 0.3).sum())
    assert pv.read(paths["vtp"]).n_cells > 0
    assert pv.read(paths["png"]).n_points > 0
    assert np.array_equal(probs, before)


def test_export_reconstruction_subset_and_errors(tmp_path):
    probs = _block(8, 24).astype(np.float32)
    paths = viz.export_reconstruction(probs, tmp_path / "new", formats=("binvox", "vtu"))
    assert sorted(p.name for p in (tmp_path / "new").iterdir()) == [
        "reconstruction.binvox", "reconstruction.vtu"]
    assert sorted(paths) == ["binvox", "vtu"]
    with pytest.raises(ValueError, match="unknown formats"):
        viz.export_reconstruction(probs, tmp_path, formats=("fbx",))
    with pytest.raises(ValueError, match="cube"):
        viz.export_reconstruction(np.zeros((4, 4, 5)), tmp_path)
    with pytest.raises(ValueError, match="name"):
        viz.export_reconstruction(probs, tmp_path, name="../x")




def test_trame_never_downloads_its_webassembly_bundle(monkeypatch):
    pytest.importorskip("trame_vtklocal")
    monkeypatch.setenv("VTK_WASM_DIR_OVERRIDE", "/my/own/wasm")
    assert _headless.offline_wasm_bundle() == "/my/own/wasm"  # the user's choice stands
    monkeypatch.delenv("VTK_WASM_DIR_OVERRIDE")
    chosen = _headless.offline_wasm_bundle()  # this machine has no bundle on disk
    assert chosen is not None and os.environ["VTK_WASM_DIR_OVERRIDE"] == chosen
    assert os.path.isdir(chosen)
