"""The README's pictures (e2vlib.experiments.figures), from data_small and its checkpoint."""

import numpy as np
import pytest

pytest.importorskip("pyvista")

from e2vlib.experiments.figures import README_CATEGORIES, render_readme_figures  # noqa: E402

from .conftest import REPO  # noqa: E402


def test_readme_figures_need_a_checkpoint(tmp_path):
    with pytest.raises(FileNotFoundError, match="train one"):
        render_readme_figures(tmp_path / "figs", REPO / "data_small", tmp_path / "none.pt")
    assert not (tmp_path / "figs").exists()  # failed before writing anything


def test_readme_figures_name_missing_categories_before_writing(tmp_path):
    checkpoint = REPO / "data_small" / "checkpoints" / "first_recipe.pt"
    if not checkpoint.is_file():
        pytest.skip("no trained checkpoint in data_small/checkpoints")
    with pytest.raises(ValueError, match=r"no test samples of \['unicorn'\]"):
        render_readme_figures(tmp_path / "figs", REPO / "data_small", checkpoint,
                              categories=("chair", "unicorn"))
    assert not (tmp_path / "figs").exists()


def test_readme_categories_all_have_test_samples_in_data_small():
    from e2vlib.data import E2VDataset

    groups = E2VDataset(REPO / "data_small", "test").category_indices()
    assert set(README_CATEGORIES) <= set(groups)  # the defaults work on the shipped data


def test_readme_figures_render_small_pictures(tmp_path):
    from PIL import Image

    checkpoint = REPO / "data_small" / "checkpoints" / "first_recipe.pt"
    if not checkpoint.is_file():
        pytest.skip("no trained checkpoint in data_small/checkpoints")
    paths = render_readme_figures(tmp_path, REPO / "data_small", checkpoint,
                                  categories=("chair", "car"))
    assert sorted(paths) == ["event_frames", "events_space_time", "reconstruction"]
    assert sum(p.stat().st_size for p in paths.values()) < 1_000_000
    for path in paths.values():
        image = np.asarray(Image.open(path).convert("L"))
        assert (image < 200).mean() > 0.01  # something is drawn
    width, height = Image.open(paths["reconstruction"]).size
    assert width == 2 * 260 and height == 2 * 260  # two columns, truth above prediction
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        f"{name}.png" for name in paths)  # no temporary file left behind
