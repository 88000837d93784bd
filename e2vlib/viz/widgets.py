"""Widgets around a matplotlib picture that still shows where no widget can run.

An ipywidgets ``interact``/``interactive_output`` draws into an Output widget, whose
content only a live widget frontend shows: an executed notebook read without the kernel
(nbmake, a notebook viewer) shows "interactive(children=...)" instead of the picture.
:func:`interactive_figure` shows the picture as an ordinary PNG output below the widgets
and replaces that output (a display id) whenever a control moves, which JupyterLab and
the classic notebook both apply. ipywidgets loads on the first call.

Introduced in notebooks/02_event_frames.ipynb.
"""

from __future__ import annotations

import matplotlib.pyplot as plt


def _png_of(figure) -> bytes:
    import io

    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", bbox_inches="tight")
    return buffer.getvalue()


def _stack_pngs(pngs: list[bytes]) -> bytes:
    """One PNG of several, stacked top to bottom on white (left-aligned)."""
    import io

    from PIL import Image

    images = [Image.open(io.BytesIO(png)).convert("RGB") for png in pngs]
    out = Image.new("RGB", (max(i.width for i in images), sum(i.height for i in images)),
                    "white")
    y = 0
    for image in images:
        out.paste(image, (0, y))
        y += image.height
    buffer = io.BytesIO()
    out.save(buffer, format="PNG")
    return buffer.getvalue()


def _render_call(function, values: dict) -> tuple[str, bytes | None]:
    """Run ``function(**values)`` and return ``(printed text, PNG bytes or None)``.

    Whatever the call prints becomes the text; the picture is what it draws with
    matplotlib: the figures it shows with ``plt.show()`` in a notebook, or else those it
    leaves open and a ``Figure`` it returns (several are stacked top to bottom). The
    figures it made are closed. Exceptions propagate.
    """
    import base64

    from IPython.utils.capture import capture_output
    from matplotlib.figure import Figure

    before = set(plt.get_fignums())
    try:
        with capture_output(stdout=True, stderr=False, display=True) as captured:
            result = function(**values)
        pngs = []
        for output in captured.outputs:  # figures shown inline by plt.show()
            data = output.data.get("image/png")
            if data is not None:
                pngs.append(base64.b64decode(data) if isinstance(data, str) else bytes(data))
        if not pngs:  # nothing shown inline: take what it drew and left open or returned
            figures = [plt.figure(n) for n in plt.get_fignums() if n not in before]
            if isinstance(result, Figure) and result not in figures:
                figures.append(result)
            pngs = [_png_of(figure) for figure in figures]
    finally:
        for n in set(plt.get_fignums()) - before:
            plt.close(n)
    png = None if not pngs else pngs[0] if len(pngs) == 1 else _stack_pngs(pngs)
    return captured.stdout.rstrip("\n"), png


_INTERACTIVE_FIGURE = None


def _interactive_figure_class():
    """The widget class, made on first use so importing viz does not import ipywidgets."""
    global _INTERACTIVE_FIGURE
    if _INTERACTIVE_FIGURE is not None:
        return _INTERACTIVE_FIGURE
    import base64
    import traceback
    import uuid

    import ipywidgets as widgets

    class InteractiveFigure(widgets.VBox):
        """Rows of controls, then an Output widget for errors; the text and picture of
        the current values are separate outputs below it (see :func:`interactive_figure`)."""

        def __init__(self, function, controls: dict, rows: list[list[str]]):
            self.function, self.controls = function, controls
            self.errors = widgets.Output()
            boxes = [widgets.HBox([controls[name] for name in row]) for row in rows]
            super().__init__([*boxes, self.errors])
            self._display_ids = {"text": uuid.uuid4().hex, "image": uuid.uuid4().hex}
            self._shown: set[str] = set()  # the outputs displayed so far
            self._drawn = self.values
            self.text, self.png = _render_call(function, self._drawn)  # the default state
            for control in controls.values():
                control.observe(self._redraw, names="value")

        @property
        def values(self) -> dict:
            """``{name: value}`` of the controls now."""
            return {name: control.value for name, control in self.controls.items()}

        def _redraw(self, _change=None) -> None:
            values = self.values
            if values == self._drawn:  # e.g. a control reset by another one's callback
                return
            self._drawn = values
            try:
                self.text, self.png = _render_call(self.function, values)
                self.errors.clear_output()
            except Exception as err:  # say what went wrong and keep the last picture
                self.text = f"{type(err).__name__}: {err}"
                with self.errors:
                    traceback.print_exc()
            if self._shown:
                from IPython.display import update_display

                for part in self._shown:
                    update_display(self._bundle(part), display_id=self._display_ids[part],
                                   raw=True)

        def _bundle(self, part: str) -> dict:
            if part == "text":
                return {"text/plain": self.text}
            if self.png is None:
                return {"text/plain": "(nothing drawn)"}
            return {"image/png": base64.b64encode(self.png).decode("ascii"),
                    "text/plain": f"<picture at {self._drawn}>"}

        def _ipython_display_(self, **kwargs) -> None:
            from IPython.display import display

            bundle = self._repr_mimebundle_(**kwargs)
            bundle["text/plain"] = (f"[controls {', '.join(self.controls)}: move them in "
                                    "JupyterLab; the picture below follows them]")
            display(bundle, raw=True)
            # text only for a function that prints (no empty output for one that only draws)
            for part in ("text", "image") if self.text else ("image",):
                display(self._bundle(part), raw=True, display_id=self._display_ids[part])
                self._shown.add(part)

    _INTERACTIVE_FIGURE = InteractiveFigure
    return InteractiveFigure


def interactive_figure(function, /, *, rows=None, **controls):
    """Widgets around a matplotlib picture that also shows where widgets cannot run.

    ``controls`` maps each keyword of ``function`` to an ipywidgets control (a slider, a
    dropdown); ``function(**values)`` prints text and draws one matplotlib figure (shown
    with ``plt.show()``, left open or returned). The default values are drawn at once
    (errors raise here). Displayed (the last expression of a cell), it shows the controls
    and, below them, the printed text and the picture as ordinary outputs: an executed
    notebook read without its kernel (nbmake, a notebook viewer) still shows the default
    state, and in JupyterLab each move of a control redraws and replaces them. ``rows``
    lists the control names per row (default: one per row). Returns an
    ``ipywidgets.VBox`` with one ``HBox`` per row and last an ``Output`` that shows the
    traceback of a redraw that failed; ``.values``, ``.text`` and ``.png`` (bytes) hold the
    state drawn last. Introduced in notebooks/02_event_frames.ipynb.

    Examples
    --------
    >>> import ipywidgets
    >>> def report(n):
    ...     print(f"n = {n}")  # prints only; a drawing function's picture lands in .png
    >>> box = interactive_figure(report, n=ipywidgets.IntSlider(value=2, max=5))
    >>> box.values, box.text, box.png is None  # the default state, drawn at once
    ({'n': 2}, 'n = 2', True)
    >>> import contextlib, io
    >>> with contextlib.redirect_stdout(io.StringIO()):  # outside a kernel it clears a line
    ...     box.controls["n"].value = 3  # what moving the slider does
    >>> box.text
    'n = 3'
    """
    if not controls:
        raise ValueError("give at least one control, e.g. dt_ms=ipywidgets.FloatSlider()")
    rows = [[name] for name in controls] if rows is None else [list(row) for row in rows]
    placed = [name for row in rows for name in row]
    if sorted(placed) != sorted(controls):
        raise ValueError(f"rows must place every control exactly once: rows name {placed}, "
                         f"controls are {list(controls)}")
    return _interactive_figure_class()(function, dict(controls), rows)
