"""The lessons' colours stay readable in grey print and for colour-blind readers.

Colours are compared in CIELAB (D65): L* is the lightness a grey print keeps, and dE is the
distance between two colours. Colour-vision deficiencies are simulated with the full-severity
matrices of Machado, Oliveira and Fernandes (IEEE TVCG 2009), applied in linear RGB.
"""

from __future__ import annotations

import matplotlib
import numpy as np
import pytest

from e2vlib import viz

MACHADO = {
    "protanopia": [[0.152286, 1.052583, -0.204868], [0.114503, 0.786281, 0.099216],
                   [-0.003882, -0.048116, 1.051998]],
    "deuteranopia": [[0.367322, 0.860646, -0.227968], [0.280085, 0.672501, 0.047413],
                     [-0.011820, 0.042940, 0.968881]],
    "tritanopia": [[1.255528, -0.076749, -0.178779], [-0.078411, 0.930809, 0.147602],
                   [0.004733, 0.691367, 0.303900]],
}
SRGB_TO_XYZ = np.array([[0.4124, 0.3576, 0.1805], [0.2126, 0.7152, 0.0722],
                        [0.0193, 0.1192, 0.9505]])
WHITE = SRGB_TO_XYZ.sum(axis=1)


def linear_rgb(color) -> np.ndarray:
    c = np.asarray(matplotlib.colors.to_rgb(color), dtype=float)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def lab(linear: np.ndarray) -> np.ndarray:
    xyz = SRGB_TO_XYZ @ np.clip(linear, 0, 1) / WHITE
    f = np.where(xyz > (6 / 29) ** 3, np.cbrt(xyz), xyz / (3 * (6 / 29) ** 2) + 4 / 29)
    return np.array([116 * f[1] - 16, 500 * (f[0] - f[1]), 200 * (f[1] - f[2])])


def lightness_gap(a, b) -> float:
    return abs(lab(linear_rgb(a))[0] - lab(linear_rgb(b))[0])


def test_lab_of_known_colours():
    assert lab(linear_rgb("white"))[0] == pytest.approx(100, abs=0.01)
    assert lab(linear_rgb("black"))[0] == pytest.approx(0, abs=0.01)
    assert lab(linear_rgb("#777777"))[0] == pytest.approx(50.0, abs=0.3)  # mid grey


def test_on_and_off_differ_in_grey():
    assert lightness_gap(viz.ON_COLOR, viz.OFF_COLOR) >= 20
    # the tab10 red and blue pair differ by about 1 L*: a grey print loses them
    assert lightness_gap("#d62728", "#1f77b4") < 10


@pytest.mark.parametrize("deficiency", sorted(MACHADO))
def test_on_and_off_stay_apart_for_colour_blind_readers(deficiency):
    simulate = np.array(MACHADO[deficiency])
    on = lab(simulate @ linear_rgb(viz.ON_COLOR))
    off = lab(simulate @ linear_rgb(viz.OFF_COLOR))
    assert np.linalg.norm(on - off) >= 40, f"{deficiency}: dE {np.linalg.norm(on - off):.0f}"


def test_the_polarity_map_runs_off_white_on_and_keeps_them_apart_in_grey():
    cmap = viz.POLARITY_CMAP
    off, zero, on = (cmap(v)[:3] for v in (0.0, 0.5, 1.0))
    assert np.allclose(off, matplotlib.colors.to_rgb(viz.OFF_COLOR), atol=0.01)
    assert np.allclose(zero, (1, 1, 1), atol=0.01)
    assert np.allclose(on, matplotlib.colors.to_rgb(viz.ON_COLOR), atol=0.01)
    for a, b in ((off, zero), (zero, on), (off, on)):
        assert lightness_gap(a, b) >= 20


def test_the_probability_map_gets_lighter_with_probability():
    cmap = matplotlib.colormaps[viz.PROBABILITY_CMAP]
    lightness = [lab(linear_rgb(cmap(v)[:3]))[0] for v in np.linspace(0, 1, 33)]
    assert np.all(np.diff(lightness) > 0), "grey print must keep the order of probabilities"
    assert lightness[-1] - lightness[0] >= 60
