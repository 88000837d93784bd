"""Pictures for `make browser` (tests/browser/run_lab.py): tell a drawn screenshot from a
blank one, compare two, and save one for the README under a size limit."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

FIGURE_MAX_BYTES = 480_000


def picture_stats(png: bytes) -> dict:
    """Numbers that tell a drawn picture from a blank one, for PNG bytes of a screenshot.

    Returns ``{"shape": (H, W), "colours": distinct RGB colours, "std": standard deviation
    of all RGB values (0-255), "foreground": fraction of pixels that differ (by more than
    16 in some channel) from the most common colour, the background}``.
    """
    from PIL import Image

    rgb = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.int16)
    flat = rgb.reshape(-1, 3)
    codes = (flat[:, 0].astype(np.int32) << 16) | (flat[:, 1] << 8) | flat[:, 2]
    values, counts = np.unique(codes, return_counts=True)
    background = values[np.argmax(counts)]
    bg = np.array([(background >> 16) & 255, (background >> 8) & 255, background & 255])
    foreground = float(np.mean(np.abs(flat - bg).max(axis=1) > 16))
    return {"shape": rgb.shape[:2], "colours": int(len(values)), "std": float(rgb.std()),
            "foreground": foreground}


def is_drawn(stats: dict, min_colours: int = 64, min_std: float = 8.0,
             min_foreground: float = 0.02) -> bool:
    """True when a picture has many colours, a clear spread and some foreground."""
    return (stats["colours"] >= min_colours and stats["std"] >= min_std
            and stats["foreground"] >= min_foreground)


def picture_difference(png_a: bytes, png_b: bytes) -> float:
    """Fraction of pixels that differ by more than 16 (any channel) between two pictures;
    1.0 when their sizes differ."""
    from PIL import Image

    a = np.asarray(Image.open(io.BytesIO(png_a)).convert("RGB"), dtype=np.int16)
    b = np.asarray(Image.open(io.BytesIO(png_b)).convert("RGB"), dtype=np.int16)
    if a.shape != b.shape:
        return 1.0
    return float(np.mean(np.abs(a - b).max(axis=2) > 16))


def save_figure(png: bytes, path: Path, max_bytes: int = FIGURE_MAX_BYTES) -> int:
    """Write a screenshot as PNG under ``max_bytes`` (reduced to 256 colours, then scaled
    down while needed); return its size in bytes. Written with ``e2vlib.files.atomic_path``."""
    from PIL import Image

    from e2vlib.files import atomic_path

    image = Image.open(io.BytesIO(png)).convert("RGB")
    data, scale = png, 1.0
    while len(data) > max_bytes:
        size = (round(image.width * scale), round(image.height * scale))
        smaller = image.resize(size, Image.Resampling.LANCZOS) if scale < 1 else image
        buffer = io.BytesIO()
        smaller.quantize(colors=256, method=Image.Quantize.MEDIANCUT,
                         dither=Image.Dither.NONE).save(buffer, "PNG", optimize=True)
        data = buffer.getvalue()
        scale *= 0.85
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        Path(tmp).write_bytes(data)
    return len(data)
