"""Model inputs: events (or grey frames) -> what the E2V network family reads, and a split of
them held in memory. Every public name is importable from here
(``from e2vlib.inputs import orbit_input, REPRESENTATIONS, TensorSet``); the code lives in
two modules:

===========================  ===============================================================
``inputs.representations``   the seven event representations (:data:`REPRESENTATIONS`,
                             :func:`input_channels`) made by one pair of functions:
                             :func:`orbit_input` (a simulated orbit's clock, what the
                             dataset builder stores) and :func:`recording_input` (a
                             recording's own clock and sensor); ``events_to_input``, the
                             published contract's order of ``orbit_input``'s arguments;
                             grey-frame inputs
                             (:data:`GREY_INPUTS`, :func:`grey_input`)
``inputs.tensors``           :class:`TensorSet` (inputs and labels of a split as tensors,
                             indexed like a dataset) and :func:`preload`
===========================  ===============================================================

``representations`` imports only numpy, ``frames``, ``events`` and ``paper``: the dataset
builder (``e2vlib.data``) uses it, so it must not import ``data``. ``tensors`` imports torch,
so it loads on first use of :class:`TensorSet` or :func:`preload` (importing this package
loads no torch). Reading a study's splits from dataset folders into a TensorSet, with an
in-memory cache, is :func:`e2vlib.experiments.load_split`: it reads datasets, so it sits
above ``data``.
Introduced in notebooks/09_event_representations_and_time.ipynb.
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "representations": [
            "GREY_INPUTS", "REPRESENTATIONS", "events_to_input", "grey_input",
            "input_channels", "orbit_input", "recording_input",
        ],
        "tensors": ["TensorSet", "preload"],
    },
)
