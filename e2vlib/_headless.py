"""VTK's environment for headless machines and notebooks, set before any plotter is made.

Two environment variables, each set only where the user has not set it:

* ``VTK_DEFAULT_OPENGL_WINDOW`` (:func:`headless_opengl_window`): on Linux without a
  display, VTK's EGL (or OSMesa) window, so VTK does not first probe for an X server;
* ``VTK_WASM_DIR_OVERRIDE`` (:func:`offline_wasm_bundle`): with trame-vtklocal installed
  but VTK's WebAssembly bundle not on disk, an empty folder, so pyvista's trame view does
  not download the bundle at run time.

:func:`e2vlib.render.render_orbit` calls the first before its plotters,
:func:`e2vlib.viz.new_plotter` both; ``e2vlib.render`` and ``e2vlib.viz`` re-export them.
Imports nothing of e2vlib, nor VTK at import time.
"""

from __future__ import annotations

import ctypes.util
import functools
import os
import sys
import tempfile
from pathlib import Path

_OPENGL_WINDOW = "VTK_DEFAULT_OPENGL_WINDOW"
_WASM_OVERRIDE = "VTK_WASM_DIR_OVERRIDE"


@functools.cache
def _headless_window_class() -> str | None:
    """VTK's window class for the headless OpenGL library installed here (EGL first)."""
    if ctypes.util.find_library("EGL"):
        return "vtkEGLRenderWindow"
    if ctypes.util.find_library("OSMesa"):
        return "vtkOSOpenGLRenderWindow"
    return None


def headless_opengl_window() -> str | None:
    """Choose VTK's headless OpenGL window on a Linux machine without a display.

    VTK (9.4 and later) first tries an X window on Linux and, when there is no X server,
    prints ``bad X server connection. DISPLAY=`` before it falls back to EGL or OSMesa.
    Where ``DISPLAY`` is unset this sets the environment variable
    ``VTK_DEFAULT_OPENGL_WINDOW`` to ``vtkEGLRenderWindow`` (or ``vtkOSOpenGLRenderWindow``
    where only OSMesa is installed) so VTK goes there directly. A value the user set is
    never changed; with a display, or with neither library, nothing is set. Returns the
    value in force (None when VTK chooses itself). :func:`e2vlib.render.render_orbit` and
    :func:`e2vlib.viz.new_plotter` call it before every plotter they make (lessons never
    need to); call it yourself before a ``pyvista.Plotter`` made by hand.

    Examples
    --------
    >>> import os
    >>> from unittest import mock
    >>> with mock.patch.dict(os.environ, {"VTK_DEFAULT_OPENGL_WINDOW": "vtkOSOpenGLRenderWindow"}):
    ...     headless_opengl_window()  # the user's choice stands
    'vtkOSOpenGLRenderWindow'
    >>> with mock.patch.dict(os.environ, {"DISPLAY": ":0"}):  # a display: VTK chooses
    ...     _ = os.environ.pop("VTK_DEFAULT_OPENGL_WINDOW", None)
    ...     print(headless_opengl_window())
    None
    """
    if (_OPENGL_WINDOW not in os.environ and sys.platform.startswith("linux")
            and not os.environ.get("DISPLAY")):
        window = _headless_window_class()
        if window is not None:
            os.environ[_OPENGL_WINDOW] = window
    return os.environ.get(_OPENGL_WINDOW)


def offline_wasm_bundle() -> str | None:
    """Keep pyvista's trame view from downloading VTK's WebAssembly bundle at run time.

    pyvista's trame backend loads ``trame-vtklocal`` when it is installed (``pyvista[jupyter]``
    pulls it in), and that module fetches VTK's WebAssembly build from gitlab.kitware.com the
    first time a view starts: offline, the cell shows a long traceback. Where the bundle is
    not on disk and ``VTK_WASM_DIR_OVERRIDE`` is unset, this points that variable at an empty
    folder, so nothing is fetched and the view renders as usual (on the server, or with
    vtk.js in the browser). Returns the value in force (None without trame-vtklocal).
    :func:`e2vlib.viz.new_plotter` calls it; introduced in
    notebooks/08_visualizing_in_3d.ipynb.

    Examples
    --------
    >>> import os
    >>> from unittest import mock
    >>> with mock.patch.dict(os.environ, {"VTK_WASM_DIR_OVERRIDE": "/my/own/wasm"}):
    ...     offline_wasm_bundle()  # the user's choice stands
    '/my/own/wasm'
    """
    empty = Path(tempfile.gettempdir()) / "e2v-no-vtk-wasm"
    if _WASM_OVERRIDE in os.environ:
        if os.environ[_WASM_OVERRIDE] == str(empty):
            _quiet_about(empty)
        return os.environ[_WASM_OVERRIDE]
    try:
        from trame_vtklocal.module import wasm_serve_path
        from trame_vtklocal.module.wasm import has_required_files
        from vtkmodules.vtkCommonCore import vtkVersion
    except ImportError:
        return None
    version = vtkVersion().GetVTKVersion()
    if has_required_files(Path(wasm_serve_path) / "wasm32" / version, version):
        return None  # downloaded before (or bundled): let trame use it
    empty.mkdir(exist_ok=True)
    os.environ[_WASM_OVERRIDE] = str(empty)
    _quiet_about(empty)
    return str(empty)


def _quiet_about(folder: Path) -> None:
    """Drop trame-vtklocal's ``Using wasm_dir: <folder>`` line for our own empty folder (it
    would print above every 3D view); every other line it prints, and the same line for a
    folder the user chose, still appear."""
    import builtins

    try:
        from trame_vtklocal.module import wasm
    except ImportError:
        return
    ours = f"Using wasm_dir: {folder}"

    def print_unless_ours(*args, **kwargs) -> None:
        if not (len(args) == 1 and str(args[0]) == ours):
            builtins.print(*args, **kwargs)

    wasm.print = print_unless_ours
