"""e2vlib: the thin, tested helper library behind the e2v notebooks.

One module per step of the E2V pipeline (Chen et al., ICVR 2023), data flowing one way::

    shapes -> voxels ; shapes -> render -> simulate -> events/io -> frames -> data
    -> model -> train -> metrics -> viz

Importing the package does no work: no seeds, no downloads, no plotting backend changes.
"""

__version__ = "0.1.0"
