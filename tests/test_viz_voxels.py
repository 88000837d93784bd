import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from e2vlib import viz  # noqa: E402


def test_voxel_mesh_places_cubes_in_the_unit_cube():
    grid = np.zeros((32, 32, 32), dtype=np.float32)
    grid[0, 0, 0] = 1.0
    grid[31, 5, 2] = 0.7
    grid[10, 10, 10] = 0.2  # below the threshold
    mesh = viz.voxel_mesh(grid, threshold=0.5)
    assert mesh.n_cells == 2
    centres = np.sort(mesh.cell_centers().points, axis=0)
    expected = np.sort(np.array([[0, 0, 0], [31, 5, 2]]) * (1 / 32) - 0.5 + 1 / 64, axis=0)
    np.testing.assert_allclose(centres, expected, atol=1e-6)
    assert viz.voxel_mesh(grid, threshold=0.1).n_cells == 3
    with pytest.raises(ValueError, match="cube"):
        viz.voxel_mesh(np.zeros((4, 4, 5)))


def test_plot_reconstruction_reports_iou():
    gt = np.zeros((8, 8, 8))
    gt[2:6, 2:6, 2:6] = 1
    pred = gt * 0.9
    pred[2, 2, 2] = 0.1
    fig = viz.plot_reconstruction(pred, gt, threshold=0.3)
    titles = [ax.get_title() for ax in fig.axes]
    assert titles[0] == "ground truth"
    assert f"IoU {63 / 64:.2f}" in titles[1]
    assert len(viz.plot_reconstruction(pred).axes) == 1  # no ground truth: one panel
    plt.close("all")
