"""The lessons' colours and default views: polarity, probability, truth and mesh colours.

ON events orange and OFF events blue (:data:`ON_COLOR`, :data:`OFF_COLOR`, the Okabe-Ito
pair, distinct for every common colour-vision deficiency and, being light against dark, in
grey print); signed ON - OFF images use :data:`POLARITY_CMAP` (blue, white, orange);
probabilities use viridis (:data:`PROBABILITY_CMAP`: its lightness rises monotonically, so
grey print keeps the order). 3D scenes look at the object from :data:`OBJECT_VIEW` and
frame the unit cube :data:`UNIT_CUBE_BOUNDS` the voxel grids cover.
"""

from __future__ import annotations

from matplotlib.colors import LinearSegmentedColormap

ON_COLOR, OFF_COLOR = "#e69f00", "#0072b2"  # Okabe-Ito orange and blue
POLARITY_CMAP = LinearSegmentedColormap.from_list("e2v_polarity", [OFF_COLOR, "#ffffff", ON_COLOR])
"""Signed ON - OFF counts: OFF blue (dark in grey), zero white, ON orange (mid grey)."""
PROBABILITY_CMAP = "viridis"
"""Colormap of probabilities in [0, 1] (matplotlib and pyvista name)."""
OBJECT_VIEW = (1.6, -2.4, 1.4)
"""Default viewing direction on the object: front-right and above (the object faces -y)."""
TRUTH_COLOR, MESH_COLOR = "#8fa8c8", "#d2b48c"
UNIT_CUBE_BOUNDS = (-0.5, 0.5, -0.5, 0.5, -0.5, 0.5)
"""``(xmin, xmax, ymin, ymax, zmin, zmax)`` in metres of the cube the voxel grids cover."""
