"""Turn a video into events with the ESIM model of an event camera.

Each pixel keeps a reference log intensity ``L_ref``, set by the first frame, where the log
intensity is ``L = log(I + log_eps)`` for intensity ``I`` in [0, 1]. Between two frames
``L`` is interpolated linearly in time. Whenever it reaches ``L_ref + C_on`` the pixel emits
an ON event (+1) and ``L_ref`` moves up by ``C_on``; whenever it reaches ``L_ref - C_off`` it
emits an OFF event (-1) and ``L_ref`` moves down by ``C_off``. The reference carries over
from one frame pair to the next, so small changes add up until they cross a threshold.

Exact rules implemented here (they make the output reproducible to the microsecond):

* crossings in a frame pair: ``K = floor((L1 - L_ref) / C_on)`` ON events if ``L1 > L_ref``,
  ``K = floor((L_ref - L1) / C_off)`` OFF events otherwise (float64 arithmetic); pixels
  whose log intensity did not change between the two frames emit nothing;
* the ``k``-th event (``k = 1..K``) sits at level ``L_ref +- k C`` and time
  ``t0 + (level - L0) / (L1 - L0) * (t1 - t0)`` (fraction clipped to [0, 1]), rounded to the
  nearest microsecond (``np.rint``, halves to even);
* ``L_ref`` moves by ``+- K C`` whether or not the events are emitted;
* refractory period: an event less than ``refractory_us`` after the last *emitted* event of
  its pixel (compared on the rounded times) is dropped;
* output order: by time; ties by the frame pair that made them, then by pixel index
  ``y * W + x``, then by ``k``.

Introduced in notebooks/03_simulating_events.ipynb.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from e2vlib import paper
from e2vlib.events import EVENT_DTYPE

MIN_CONTRAST = 0.01
"""Per-pixel thresholds drawn with ``contrast_sigma`` are clipped from below at this value."""

_NEVER = np.iinfo(np.int64).min // 2  # "last event time" of a pixel that has not fired yet


def _check_video(video: ArrayLike) -> np.ndarray:
    """Return ``video`` as an (n, H, W) uint8 or float array after checking it."""
    v = np.asarray(video)
    if v.ndim != 3:
        raise ValueError(
            f"video must have shape (n_frames, height, width), got shape {v.shape}; "
            "convert colour frames to gray first"
        )
    n, h, w = v.shape
    if n < 2:
        raise ValueError(f"video needs at least 2 frames to make events, got {n}")
    if h == 0 or w == 0:
        raise ValueError(f"video frames are empty (height {h}, width {w})")
    if w > 65536 or h > 65536:
        raise ValueError(f"video frames of {w}x{h} px do not fit uint16 event coordinates")
    if v.dtype == np.uint8:
        return v
    if not np.issubdtype(v.dtype, np.floating):
        raise ValueError(
            f"video must be uint8 (0-255) or float in [0, 1], got dtype {v.dtype}; "
            "convert with video.astype(np.float32) / max_value"
        )
    lo, hi = float(v.min()), float(v.max())  # NaN propagates, so this also finds NaN/inf
    if not (math.isfinite(lo) and math.isfinite(hi)):
        bad = np.flatnonzero(~np.isfinite(v).reshape(n, -1).all(axis=1))
        raise ValueError(
            f"video has NaN/inf values in {len(bad)} frames (first: frame {bad[0]}); "
            "fix or drop those frames"
        )
    if lo < 0.0 or hi > 1.0:
        raise ValueError(
            f"float video must lie in [0, 1], got values in [{lo:g}, {hi:g}]; "
            "rescale it (for 8-bit data pass uint8 or divide by 255)"
        )
    return v


def _check_times(t_us: ArrayLike, n: int) -> np.ndarray:
    """Return the frame times as int64 microseconds after checking them."""
    t = np.asarray(t_us)
    if t.ndim != 1 or len(t) != n:
        raise ValueError(f"t_us must be 1-D with one time per frame ({n}), got shape {t.shape}")
    if np.issubdtype(t.dtype, np.floating):
        if not np.all(np.isfinite(t)) or not np.all(t == np.round(t)):
            raise ValueError("t_us must hold whole microseconds (finite integers)")
    elif not np.issubdtype(t.dtype, np.integer):
        raise ValueError(f"t_us must be integer microseconds, got dtype {t.dtype}")
    t = t.astype(np.int64)
    steps = np.diff(t)
    if np.any(steps <= 0):
        k = int(np.flatnonzero(steps <= 0)[0])
        raise ValueError(
            f"t_us must be strictly increasing; frame {k + 1} ({t[k + 1]} us) is not after "
            f"frame {k} ({t[k]} us)"
        )
    return t


def _check_positive(name: str, value: float, allow_zero: bool = False) -> float:
    ok = isinstance(value, (int, float, np.integer, np.floating)) and math.isfinite(value)
    if not ok or value < 0 or (value == 0 and not allow_zero):
        need = ">= 0" if allow_zero else "> 0"
        raise ValueError(f"{name} must be a finite number {need}, got {value!r}")
    return float(value)


def draw_thresholds(
    shape: tuple[int, int],
    contrast_pos: float = paper.CONTRAST_THRESHOLD,
    contrast_neg: float = paper.CONTRAST_THRESHOLD,
    contrast_sigma: float = 0.0,
    seed: int | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Per-pixel ON and OFF thresholds, each float64 of ``shape`` ``(H, W)``.

    Normal around ``contrast_pos`` / ``contrast_neg`` with standard deviation
    ``contrast_sigma`` (ON drawn first, then OFF, from ``np.random.default_rng(seed)``),
    clipped from below at :data:`MIN_CONTRAST`. With ``contrast_sigma = 0`` they are constant.

    Introduced in notebooks/03_simulating_events.ipynb.
    """
    c_on = _check_positive("contrast_pos", contrast_pos)
    c_off = _check_positive("contrast_neg", contrast_neg)
    sigma = _check_positive("contrast_sigma", contrast_sigma, allow_zero=True)
    if sigma == 0.0:
        return np.full(shape, c_on), np.full(shape, c_off)
    rng = np.random.default_rng(seed)
    on = np.maximum(rng.normal(c_on, sigma, size=shape), MIN_CONTRAST)
    off = np.maximum(rng.normal(c_off, sigma, size=shape), MIN_CONTRAST)
    return on, off


def simulate_events(
    video: ArrayLike,
    t_us: ArrayLike,
    contrast_pos: float = paper.CONTRAST_THRESHOLD,
    contrast_neg: float = paper.CONTRAST_THRESHOLD,
    contrast_sigma: float = 0.0,
    refractory_us: float = 0,
    log_eps: float = 1e-3,
    seed: int | None = None,
) -> np.ndarray:
    """Events (:data:`~e2vlib.events.EVENT_DTYPE`, sorted by ``t``) that ``video`` would make.

    ``video``: ``(n, H, W)`` uint8 (read as ``I / 255``) or float in [0, 1]; ``t_us``: the
    ``n`` frame times, strictly increasing integer microseconds. The sensor size of the result
    is ``(W, H)``. ``contrast_pos`` / ``contrast_neg`` are the ON / OFF thresholds in log
    intensity; ``contrast_sigma`` > 0 gives every pixel its own thresholds, drawn once with
    ``seed`` (see :func:`draw_thresholds`); ``refractory_us`` drops events that come sooner
    than that after the pixel's last emitted event (the reference still moves);
    ``log_eps`` keeps ``log(I + log_eps)`` finite for black pixels. The exact rules (event
    times, rounding, tie order) are in this module's docstring.

    Work per frame pair is one comparison of the two frames plus arithmetic on the pixels
    whose intensity changed and on the events they make; nothing loops over pixels.

    Introduced in notebooks/03_simulating_events.ipynb.
    """
    v = _check_video(video)
    n, height, width = v.shape
    t = _check_times(t_us, n)
    eps = _check_positive("log_eps", log_eps)
    refractory = _check_positive("refractory_us", refractory_us, allow_zero=True)
    c_on, c_off = draw_thresholds((height, width), contrast_pos, contrast_neg,
                                  contrast_sigma, seed)
    c_on, c_off = c_on.ravel(), c_off.ravel()

    frames = v.reshape(n, height * width)
    if v.dtype == np.uint8:
        table = np.log(np.arange(256, dtype=np.float64) / 255.0 + eps)

        def log_of(values: np.ndarray) -> np.ndarray:
            return table[values]
    else:

        def log_of(values: np.ndarray) -> np.ndarray:
            return np.log(values.astype(np.float64) + eps)

    level_now = log_of(frames[0])  # log intensity of the latest frame, per pixel
    reference = level_now.copy()
    last_t = np.full(height * width, _NEVER, dtype=np.int64)
    chunks: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []

    for j in range(n - 1):
        changed = np.flatnonzero(frames[j] != frames[j + 1])
        if changed.size == 0:
            continue
        l1 = log_of(frames[j + 1][changed])
        l0 = level_now[changed]
        level_now[changed] = l1
        ref = reference[changed]
        up = l1 > ref
        contrast = np.where(up, c_on[changed], c_off[changed])
        count = np.floor(np.abs(l1 - ref) / contrast)
        count[l1 == l0] = 0  # distinct tiny floats can share one log value: no change
        fire = np.flatnonzero(count > 0)
        if fire.size == 0:
            continue
        pix = changed[fire]
        k_max = count[fire].astype(np.int64)
        signed_c = np.where(up[fire], contrast[fire], -contrast[fire])
        reference[pix] = ref[fire] + k_max * signed_c

        # one row per event, pixel by pixel, k = 1..K within a pixel
        total = int(k_max.sum())
        owner = np.repeat(np.arange(fire.size), k_max)
        starts = np.cumsum(k_max) - k_max
        k = (np.arange(total) - starts[owner] + 1).astype(np.float64)
        level = ref[fire][owner] + k * signed_c[owner]
        l0_e, l1_e = l0[fire][owner], l1[fire][owner]
        frac = np.clip((level - l0_e) / (l1_e - l0_e), 0.0, 1.0)
        t0, t1 = float(t[j]), float(t[j + 1])
        times = np.rint(t0 + frac * (t1 - t0)).astype(np.int64)
        pix_e = pix[owner]
        polarity = np.where(signed_c > 0, 1, -1).astype(np.int8)[owner]

        if refractory > 0:
            keep = _refractory_mask(times, pix, k_max, starts, last_t, refractory)
            times, pix_e, polarity = times[keep], pix_e[keep], polarity[keep]
        # pixel-major rows -> order by (time, pixel). Rows with equal keys are the same
        # pixel at the same microsecond with the same polarity: identical events, so an
        # unstable (SIMD) sort still gives a unique result.
        order = np.argsort((times - t[j]) * (height * width) + pix_e)
        chunks.append((times[order], pix_e[order], polarity[order]))

    return _assemble(chunks, width)


def _refractory_mask(
    times: np.ndarray,
    pix: np.ndarray,
    k_max: np.ndarray,
    starts: np.ndarray,
    last_t: np.ndarray,
    refractory: float,
) -> np.ndarray:
    """Which events of one frame pair survive the refractory period; updates ``last_t``.

    Events are in pixel-major rows (pixel ``pix[i]`` owns rows ``starts[i]:starts[i]+k_max[i]``).
    Loops over the event index within a pixel (at most ``k_max.max()`` passes), vectorized
    over pixels.
    """
    keep = np.zeros(len(times), dtype=bool)
    for k in range(int(k_max.max())):
        active = np.flatnonzero(k_max > k)
        rows = starts[active] + k
        ok = times[rows] - last_t[pix[active]] >= refractory
        keep[rows[ok]] = True
        last_t[pix[active[ok]]] = times[rows[ok]]
    return keep


def _assemble(chunks: list[tuple[np.ndarray, np.ndarray, np.ndarray]], width: int) -> np.ndarray:
    """Concatenate per-frame-pair event chunks (already in output order) into EVENT_DTYPE."""
    total = sum(len(c[0]) for c in chunks)
    events = np.empty(total, dtype=EVENT_DTYPE)
    if total == 0:
        return events
    times = np.concatenate([c[0] for c in chunks])
    pix = np.concatenate([c[1] for c in chunks])
    events["t"] = times
    events["y"], events["x"] = np.divmod(pix, width)
    events["p"] = np.concatenate([c[2] for c in chunks])
    return events
