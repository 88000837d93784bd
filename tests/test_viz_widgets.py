"""viz.interactive_figure: widgets whose picture also shows without a widget frontend."""

import base64

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

widgets = pytest.importorskip("ipywidgets")

from e2vlib import viz  # noqa: E402


def _draw(k=1, scale=1.0):
    """Prints its values and plots k + 1 points (k = 0 is refused)."""
    if k == 0:
        raise ValueError("k must be at least 1")
    print(f"k = {k}, scale = {scale:g}")
    fig, ax = plt.subplots(figsize=(2, 2))
    ax.plot(np.arange(k + 1) * scale)
    plt.show()  # a no-op under Agg: the helper takes the open figure


def test_draws_the_default_state_and_redraws_on_change():
    k = widgets.IntSlider(value=2, min=0, max=5)
    scale = widgets.FloatSlider(value=0.5, min=0.5, max=2.0)
    fig = viz.interactive_figure(_draw, rows=[["k", "scale"]], k=k, scale=scale)
    assert isinstance(fig, widgets.VBox)
    assert isinstance(fig.children[0], widgets.HBox) and fig.children[0].children == (k, scale)
    assert isinstance(fig.children[-1], widgets.Output)
    assert fig.values == {"k": 2, "scale": 0.5} and fig.text == "k = 2, scale = 0.5"
    assert fig.png.startswith(b"\x89PNG")
    first = fig.png
    k.value = 4
    assert fig.text == "k = 4, scale = 0.5" and fig.png != first
    assert plt.get_fignums() == []  # every figure it drew is closed
    drawn = fig.png
    k.value = 0  # the function raises: the message replaces the text, the picture stays
    assert fig.text == "ValueError: k must be at least 1" and fig.png == drawn
    k.value = 1
    assert fig.text == "k = 1, scale = 0.5"


def test_a_returned_figure_is_the_picture_and_errors_are_named():
    def returns(n=3):
        fig, ax = plt.subplots(figsize=(1, 1))
        ax.bar(range(n), range(n))
        return fig

    fig = viz.interactive_figure(returns, n=widgets.IntSlider(value=3))
    assert fig.text == "" and fig.png.startswith(b"\x89PNG")
    assert len(fig.children) == 2  # one row per control by default, then the Output
    with pytest.raises(ValueError, match="k must be at least 1"):  # the default state
        viz.interactive_figure(_draw, k=widgets.IntSlider(value=0))
    with pytest.raises(ValueError, match="exactly once"):
        viz.interactive_figure(_draw, rows=[["k"]], k=widgets.IntSlider(value=1),
                               scale=widgets.FloatSlider(value=1.0))
    with pytest.raises(ValueError, match="at least one control"):
        viz.interactive_figure(_draw)
    plt.close("all")


def test_in_a_kernel_the_picture_is_an_ordinary_output_that_follows_the_widget():
    """Run by a real kernel as nbmake does: the cell's outputs hold the text and the PNG
    (not only the widget), and a later change of the slider replaces both in place."""
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    first = (
        "import ipywidgets as w\n"
        "import matplotlib.pyplot as plt\n"
        "from e2vlib import viz\n"
        "def draw(k=1):\n"
        "    print(f'k = {k}')\n"
        "    fig, ax = plt.subplots(figsize=(2, 2))\n"
        "    ax.plot(range(k + 1))\n"
        "    plt.show()\n"
        "fig = viz.interactive_figure(draw, k=w.IntSlider(value=2, min=1, max=5))\n"
        "fig"
    )
    second = "fig.controls['k'].value = 4\nprint(fig.text)"
    silent = "viz.interactive_figure(lambda n=1: plt.plot(range(n)), n=w.IntSlider(value=2))"
    nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(first),
                                         nbformat.v4.new_code_cell(second),
                                         nbformat.v4.new_code_cell(silent)])
    nbclient.NotebookClient(nb, timeout=120, kernel_name="python3").execute()
    outputs = nb.cells[0].outputs
    assert [o.output_type for o in outputs] == ["display_data"] * 3
    controls, text, image = (o.data for o in outputs)
    assert "application/vnd.jupyter.widget-view+json" in controls
    assert controls["text/plain"].startswith("[controls k: move them in JupyterLab")
    assert "VBox(" not in controls["text/plain"]
    assert text["text/plain"] == "k = 4"  # updated in place by the second cell
    assert base64.b64decode(image["image/png"]).startswith(b"\x89PNG")
    assert "{'k': 4}" in image["text/plain"]
    assert nb.cells[1].outputs[0].text.strip() == "k = 4"
    # a function that prints nothing: the controls and the picture, no empty text output
    silent_outputs = [o.data for o in nb.cells[2].outputs]
    assert len(silent_outputs) == 2 and "image/png" in silent_outputs[1]
