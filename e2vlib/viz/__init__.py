"""Pictures of events, frames, voxels and meshes: matplotlib figures and pyvista scenes.

Matplotlib functions (``plot_*``, ``show_frame``, ``animate_frames``) give static figures
that work headless; each draws into an ``ax``/``fig`` it is given or makes one, and
returns it. PyVista functions (``view_*``) build 3D scenes and return the plotter unshown:
``.show()`` is interactive in JupyterLab (trame) and an image under
``PYVISTA_JUPYTER_BACKEND=static``; :func:`screenshot` renders one off screen. Every public
name is importable from here (``from e2vlib import viz; viz.view_voxels(...)``); the code
lives in seven modules, each with one job:

=====================  =====================================================================
``viz.style``          colours and default views: :data:`ON_COLOR`, :data:`OFF_COLOR`,
                       :data:`POLARITY_CMAP`, :data:`PROBABILITY_CMAP`, :data:`TRUTH_COLOR`,
                       :data:`MESH_COLOR`, :data:`OBJECT_VIEW`, :data:`UNIT_CUBE_BOUNDS`
``viz.plots``          matplotlib figures: :func:`plot_events_3d`, :func:`plot_event_rate`,
                       :func:`plot_frame_grid`, :func:`show_frame`, :func:`plot_voxels`,
                       :func:`plot_reconstruction`
``viz.animation``      :func:`animate_frames` and :func:`animation_html` (a self-contained,
                       labelled HTML player)
``viz.scenes``         pyvista scenes of voxels and meshes: :func:`new_plotter`,
                       :func:`aim_at_object`, :func:`screenshot`, :func:`voxel_mesh`,
                       :func:`add_voxels`, :func:`view_voxels`, :func:`view_reconstructions`,
                       :func:`view_mesh_voxels`
``viz.recording``      pyvista scenes of the recording: :func:`event_cloud`,
                       :func:`view_events`, :func:`camera_frustum`, :func:`view_orbit`
``viz.widgets``        :func:`interactive_figure`: controls around a matplotlib picture that
                       also shows (at its current values) where no widget can run
``viz.export``         a prediction for other tools: :func:`probability_mesh` (marching
                       cubes, metres), :func:`export_reconstruction`, :data:`EXPORT_SUFFIXES`
=====================  =====================================================================

``style``, ``animation`` and ``widgets`` import no e2vlib module; ``plots`` imports
``style``, ``e2vlib.events``, ``frames`` and ``metrics``; ``scenes`` imports ``style``,
``e2vlib._headless`` (VTK's environment for headless machines and notebooks, shared with
:mod:`e2vlib.render`), ``metrics`` and ``files``; ``recording`` imports ``plots``,
``scenes``, ``e2vlib.orbit`` and ``render``; ``export`` imports ``scenes``, ``files`` and
``voxels``; none imports this package's ``__init__``. Importing the package loads
matplotlib but not pyvista, ipywidgets or torch (they load on first use). The package
attribute ``viz.animation`` is the module; matplotlib's is ``matplotlib.animation``.

This package draws what it is given; it never reads datasets or runs models (the README's
pictures, which do both, live in :mod:`e2vlib.experiments.figures`).

Introduced in notebooks/01_events.ipynb, notebooks/02_event_frames.ipynb and
notebooks/08_visualizing_in_3d.ipynb.
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "animation": ["animate_frames", "animation_html"],
        "export": ["EXPORT_SUFFIXES", "export_reconstruction", "probability_mesh"],
        "plots": [
            "plot_event_rate", "plot_events_3d", "plot_frame_grid", "plot_reconstruction",
            "plot_voxels", "show_frame",
        ],
        "recording": ["camera_frustum", "event_cloud", "view_events", "view_orbit"],
        "scenes": [
            "add_voxels", "aim_at_object", "new_plotter", "screenshot", "view_mesh_voxels",
            "view_reconstructions", "view_voxels", "voxel_mesh",
        ],
        "style": [
            "MESH_COLOR", "OBJECT_VIEW", "OFF_COLOR", "ON_COLOR", "POLARITY_CMAP",
            "PROBABILITY_CMAP", "TRUTH_COLOR",
        ],
        "widgets": ["interactive_figure"],
    },
)
