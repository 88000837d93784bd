"""e2vlib: the thin, tested helper library behind the e2v notebooks.

One module per step of the E2V pipeline (Chen et al., ICVR 2023), data flowing one way::

    shapes -> voxels ; shapes -> render -> simulate -> events/io -> frames -> inputs -> data
    -> model -> losses/train -> metrics -> viz -> explore/figures ; experiments (on top)

``paper`` holds the paper's facts and our documented choices (every module may import it);
``files`` holds crash-safe writing. ``tests/test_layout.py`` checks that no import cycle exists.

Importing the package does no work: no seeds, no downloads, no plotting backend changes.
"""

__version__ = "0.1.0"
