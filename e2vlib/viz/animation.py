"""Matplotlib animations of frame stacks, shown as self-contained, accessible HTML.

Introduced in notebooks/02_event_frames.ipynb.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
from matplotlib import animation


def animate_frames(frames: np.ndarray, interval_ms: int = 50, dt_us: int | None = None,
                   cmap: str = "gray_r"):
    """A matplotlib animation of frames ``(n, H, W)``; show it with :func:`animation_html`.

    No ffmpeg needed. Introduced in notebooks/02_event_frames.ipynb.

    Examples
    --------
    >>> import matplotlib; matplotlib.use("Agg")  # off screen
    >>> anim = animate_frames(np.zeros((3, 4, 4)), dt_us=5000)
    >>> type(anim).__name__, 'alt="three frames"' in animation_html(anim, "three frames")
    ('FuncAnimation', True)
    """
    frames = np.asarray(frames)
    if frames.ndim != 3 or len(frames) == 0:
        raise ValueError(f"frames must be a non-empty (n, H, W) stack, got {frames.shape}")
    fig, ax = plt.subplots(figsize=(4, 4 * frames.shape[1] / frames.shape[2]))
    image = ax.imshow(frames[0], cmap=cmap, vmin=0, vmax=max(1, float(frames.max())),
                      interpolation="nearest")
    ax.axis("off")

    def draw(k):
        image.set_data(frames[k])
        ax.set_title(f"{k * dt_us / 1e3:.0f} ms" if dt_us else f"frame {k}")
        return (image,)

    anim = animation.FuncAnimation(fig, draw, frames=len(frames), interval=interval_ms, blit=True)
    plt.close(fig)
    return anim


def animation_html(anim: animation.Animation, description: str) -> str:
    """``anim`` as a self-contained HTML player that reads well to everyone.

    matplotlib's ``to_jshtml()`` with ``description`` as the picture's alt text and as the
    frame slider's label, and without its link to an icon font on a CDN (JupyterLab and the
    book ship the icons), so that the page loads nothing from outside.

    Examples
    --------
    >>> anim = animate_frames(np.zeros((2, 4, 4)))
    >>> html = animation_html(anim, "two empty frames")
    >>> 'alt="two empty frames"' in html, "bootstrapcdn" in html
    (True, False)
    """
    import html as html_text
    import re

    if not description.strip():
        raise ValueError("describe the animation for readers who cannot see it: a non-empty "
                         "description is its alt text")
    label = html_text.escape(description, quote=True)
    page = anim.to_jshtml()
    page = re.sub(r'<link rel="stylesheet"\s+href="https://[^"]*font-awesome[^"]*">', "", page)
    page = re.sub(r'<img id="(_anim_img\w+)">', rf'<img id="\1" alt="{label}">', page)
    page = re.sub(r'<input id="(_anim_slider\w+)" type="range"',
                  rf'<input id="\1" type="range" aria-label="frame of: {label}"', page)
    return page
