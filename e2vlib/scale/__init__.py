"""Speed and scale: opt-in modules beside core that core's readable path never needs.

Each module here makes a core function faster, larger or harder to break, and a test shows it
gives core's answer. Core never imports this package (``.importlinter`` enforces it); the lab,
the command line and a user who asks for speed do. Nothing is re-exported here: import a module
by its name (``from e2vlib.scale.training import fit_at_scale``), so that reading one never
loads the others' heavy dependencies (numba, torch's distributed package, VTK).

Module map::

    frames_numba   accumulate_fast: frames.accumulate's answer from compiled (numba) kernels,
                   and the memory guard (psutil) that sizes long streams
    render_cache   render_orbit_cached: render.render_orbit with one plotter kept per process
                   and size (make-data builds lend it to the dataset builder)
    training       fit_at_scale: train.fit's epochs with resume, bf16, channels-last, a
                   per-step learning rate and data-parallel runs (torchrun)
    options        the choices those options take (PRECISIONS), without importing torch
    shards         sharded dataset builds joined and checked (python -m e2vlib merge-data)
"""
