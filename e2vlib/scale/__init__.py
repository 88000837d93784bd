"""Speed and scale: opt-in modules beside core that core's readable path never needs.

Each module here makes a core function faster, larger or harder to break, and a test shows it
gives core's answer. Core never imports this package; the lab, the command line and a user who
asks for speed do (``from e2vlib.scale.frames_numba import ...``). Nothing is re-exported here:
import a module by its name, so that reading one never loads the others (numba, torch's
distributed package, VTK).

Module map::

    frames_numba   compiled (numba) kernels behind a fast frames.accumulate
    shards         sharded dataset builds and merging them (``python -m e2vlib merge-data``)
"""
