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
  its pixel (compared on the rounded times) is dropped (:func:`apply_refractory`);
* output order: by time; ties by the frame pair that made them, then by pixel index
  ``y * W + x``, then by ``k``.

Threshold mismatch ``contrast_sigma`` (v2e's ``--sigma_thres``) gives every pixel its own ON
and OFF thresholds, drawn once around ``contrast_pos`` / ``contrast_neg``
(:func:`draw_thresholds`). The other kinds of sensor noise (shot noise, leak events) live in
:mod:`e2vlib.noise`.

Memory is bounded: before the events of a frame pair are made, their number is known
exactly (the sum of ``K``), and a run that would exceed ``max_events`` (default
:data:`MAX_EVENTS`) raises :class:`TooManyEventsError` with an upper bound for the whole
video (:func:`event_count_bound`) instead of allocating. Frame times must lie within
:data:`MAX_ABS_TIME_US` so that event times are exact in float64.

Introduced in notebooks/03_simulating_events.ipynb.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike

from e2vlib import paper
from e2vlib.events import EVENT_DTYPE

MIN_CONTRAST = 0.01
"""Per-pixel thresholds drawn with ``contrast_sigma`` are clipped from below at this value."""

MAX_EVENTS: int = 50_000_000
"""Most events :func:`simulate_events` makes unless ``max_events=`` says otherwise. Each
event takes about 30 bytes while the stream is assembled (1.5 GB at this limit); a video
needing more (usually a contrast threshold far below the usual 0.1-0.5) raises
:class:`TooManyEventsError`."""

MAX_ABS_TIME_US: int = 2**53
"""Frame times must lie in ``[-MAX_ABS_TIME_US, MAX_ABS_TIME_US]`` (about 285 years): there
float64, in which event times are interpolated, holds every microsecond exactly."""


class TooManyEventsError(ValueError):
    """The simulation would make more events than its ``max_events`` limit allows.

    Examples
    --------
    One pixel brightening from 0.1 to 0.3 makes 5 events, more than a limit of 2:

    >>> video = np.array([[[0.1, 0.5]], [[0.3, 0.5]]])
    >>> simulate_events(video, [0, 1000], max_events=2)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.simulate.TooManyEventsError: the simulation would make more than max_events=2 \
events (5 in the first 1 of 1 frame pairs; up to 5 for the whole video, ...

    Introduced in notebooks/03_simulating_events.ipynb.
    """


def simulate_events(
    video: ArrayLike,
    t_us: ArrayLike,
    contrast_pos: float | np.ndarray = paper.CONTRAST_THRESHOLD,
    contrast_neg: float | np.ndarray = paper.CONTRAST_THRESHOLD,
    contrast_sigma: float = 0.0,
    refractory_us: float = 0,
    log_eps: float = 1e-3,
    seed: int | np.random.Generator | None = None,
    *,
    drift_per_us: float | np.ndarray = 0.0,
    reference_offset: float | np.ndarray = 0.0,
    max_events: int = MAX_EVENTS,
) -> np.ndarray:
    """Events (:data:`~e2vlib.events.EVENT_DTYPE`, sorted by ``t``) that ``video`` would make.

    ``video``: ``(n, H, W)`` uint8 (read as ``I / 255``) or float in [0, 1]; ``t_us``: the
    ``n`` frame times, strictly increasing integer microseconds. The sensor size of the result
    is ``(W, H)``. ``contrast_pos`` / ``contrast_neg`` are the ON / OFF thresholds in log
    intensity (numbers, or ``(H, W)`` arrays of per-pixel thresholds); ``contrast_sigma`` > 0
    gives every pixel its own thresholds, drawn once with ``seed`` (an int, a
    ``numpy.random.Generator`` or None; see :func:`draw_thresholds`); ``refractory_us`` drops
    events that come sooner than that after the pixel's last emitted event (the reference
    still moves); ``log_eps`` keeps ``log(I + log_eps)`` finite for black pixels. The exact
    rules (event times, rounding, tie order) are in this module's docstring.

    ``drift_per_us`` and ``reference_offset`` (numbers or ``(H, W)``, log intensity; zero by
    default) let a caller model a pixel whose reference drifts: the log intensity gets the
    ramp ``drift_per_us * (t - t_us[0])`` and the first reference is shifted by
    ``reference_offset``. :func:`e2vlib.noise.simulate_noisy_events` uses them for leak
    events. ``max_events`` (default :data:`MAX_EVENTS`) bounds the memory: a run that would
    make more events raises :class:`TooManyEventsError` (a ValueError) before allocating.

    Examples
    --------
    A 1 x 2 px video of two frames 1 ms apart: the left pixel brightens from 0.1 to 0.3, a
    log change of ``log(0.301 / 0.101) = 1.092``, i.e. ``floor(1.092 / 0.2) = 5`` ON events
    at the times the interpolated log intensity crosses each level (``1000 * 0.2 k /
    1.092`` us); the right pixel stays at 0.5 and says nothing:

    >>> video = np.array([[[0.1, 0.5]], [[0.3, 0.5]]])  # (n, H, W) = (2, 1, 2)
    >>> events = simulate_events(video, [0, 1000])
    >>> events["t"].tolist(), events["x"].tolist(), events["p"].tolist()
    ([183, 366, 549, 733, 916], [0, 0, 0, 0, 0], [1, 1, 1, 1, 1])
    >>> len(simulate_events(video, [0, 1000], contrast_pos=0.5))  # floor(1.092 / 0.5)
    2
    >>> len(simulate_events(video, [0, 1000], refractory_us=300))  # 183, 549, 916 kept
    3

    Introduced in notebooks/03_simulating_events.ipynb.
    """
    video, t = check_inputs(video, t_us, log_eps, refractory_us, max_events,
                            drift_per_us, reference_offset)
    n, height, width = video.shape
    frames = video.reshape(n, height * width)  # one row per frame; pixel index y * W + x
    log_of = _log_intensity(video.dtype, log_eps)  # a frame's L = log(I + log_eps), float64
    c_on, c_off = draw_thresholds((height, width), contrast_pos, contrast_neg,
                                  contrast_sigma, seed)
    c_on, c_off = c_on.ravel(), c_off.ravel()
    drift, offset = np.ravel(drift_per_us), np.ravel(reference_offset)

    level = log_of(frames[0])  # L of the latest frame, per pixel
    reference = level + offset  # L_ref: the level at which the pixel last fired
    chunks, n_made = [], 0
    for j in range(n - 1):
        t0, t1 = float(t[j]), float(t[j + 1])
        l0, level = level, log_of(frames[j + 1]) + drift * float(t[j + 1] - t[0])
        up = level > reference  # ON side of the reference, else OFF side
        contrast = np.where(up, c_on, c_off)
        count = np.floor(np.abs(level - reference) / contrast)  # K thresholds crossed
        count[level == l0] = 0  # a pixel whose L did not change says nothing
        _check_budget(n_made + count.sum(), max_events, j, video, c_on, c_off, log_eps)
        fire = np.flatnonzero(count)
        k_max = count[fire].astype(np.int64)
        step = np.where(up[fire], contrast[fire], -contrast[fire])  # +C_on or -C_off

        # one row per event: pixel fire[i] repeated k_max[i] times, with its k = 1..k_max[i]
        owner = np.repeat(np.arange(fire.size), k_max)
        k = np.arange(owner.size) - np.repeat(np.cumsum(k_max) - k_max, k_max) + 1
        crossed = reference[fire][owner] + k * step[owner]  # the level of the k-th crossing
        start, end = l0[fire][owner], level[fire][owner]
        frac = np.clip((crossed - start) / (end - start), 0.0, 1.0)  # linear in time
        when = np.rint(t0 + frac * (t1 - t0)).astype(np.int64)
        pixel, polarity = fire[owner], np.sign(step[owner]).astype(np.int8)
        order = np.lexsort((pixel, when))  # this frame pair's events by time, then pixel
        chunks.append((when[order], pixel[order], polarity[order]))
        reference[fire] += k_max * step  # the reference follows the K crossings
        n_made += owner.size

    events = _to_events(chunks, width)  # frame pair after frame pair: sorted by time
    return apply_refractory(events, refractory_us)


def apply_refractory(events: np.ndarray, refractory_us: float) -> np.ndarray:
    """``events`` without those less than ``refractory_us`` after the last kept event of
    their pixel (microseconds; 0 keeps all). Order is kept.

    A pixel's events are taken in the order of the stream (time order for a sorted stream;
    at equal times the earlier one wins). Loops over the rank of an event within its pixel
    (as many passes as the busiest pixel has events), vectorized over pixels.

    Examples
    --------
    >>> from e2vlib.events import make_events
    >>> events = make_events([0, 0, 1, 0], [0, 0, 0, 0], [0, 200, 250, 450], [1, 1, -1, 1])
    >>> apply_refractory(events, 300)["t"].tolist()  # 200 is too soon after 0; 450 is not
    [0, 250, 450]

    Introduced in notebooks/03_simulating_events.ipynb.
    """
    refractory = _check_number("refractory_us", refractory_us, allow_zero=True)
    if refractory == 0 or len(events) == 0:
        return events
    by_pixel = np.lexsort((events["x"], events["y"]))  # stable: stream order within a pixel
    t, x, y = events["t"][by_pixel], events["x"][by_pixel], events["y"][by_pixel]
    first = np.flatnonzero(np.r_[True, (x[1:] != x[:-1]) | (y[1:] != y[:-1])])
    counts = np.diff(np.r_[first, len(t)])
    last = np.full(len(first), np.iinfo(np.int64).min // 2)  # a pixel that has not fired
    keep = np.zeros(len(t), dtype=bool)
    for rank in range(int(counts.max())):
        active = np.flatnonzero(counts > rank)
        rows = first[active] + rank
        ok = t[rows] - last[active] >= refractory
        keep[rows[ok]] = True
        last[active[ok]] = t[rows[ok]]
    return events[np.sort(by_pixel[keep])]


def draw_thresholds(
    shape: tuple[int, int],
    contrast_pos: float | np.ndarray = paper.CONTRAST_THRESHOLD,
    contrast_neg: float | np.ndarray = paper.CONTRAST_THRESHOLD,
    contrast_sigma: float = 0.0,
    seed: int | np.random.Generator | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Per-pixel ON and OFF thresholds, each float64 of ``shape`` ``(H, W)``.

    Normal around ``contrast_pos`` / ``contrast_neg`` (numbers or arrays of ``shape``) with
    standard deviation ``contrast_sigma`` (ON drawn first, then OFF, from
    ``np.random.default_rng(seed)``), clipped from below at :data:`MIN_CONTRAST`. With
    ``contrast_sigma = 0`` they are the given thresholds, and nothing is drawn.
    ``contrast_sigma`` is v2e's ``sigma_thres`` (a normal spread of both thresholds per pixel).

    Examples
    --------
    >>> on, off = draw_thresholds((2, 3))  # no spread: the paper's C = 0.2 everywhere
    >>> on.shape, on.dtype, float(on.min()), float(off.max())
    ((2, 3), dtype('float64'), 0.2, 0.2)
    >>> on, off = draw_thresholds((2, 3), contrast_sigma=0.05, seed=0)
    >>> on.round(3)
    array([[0.206, 0.193, 0.232],
           [0.205, 0.173, 0.218]])
    >>> bool((on != off).any() and on.min() >= MIN_CONTRAST)
    True

    Introduced in notebooks/03_simulating_events.ipynb.
    """
    c_on = _check_contrast("contrast_pos", contrast_pos, shape)
    c_off = _check_contrast("contrast_neg", contrast_neg, shape)
    sigma = _check_number("contrast_sigma", contrast_sigma, allow_zero=True)
    if sigma == 0.0:
        return np.full(shape, c_on, dtype=np.float64), np.full(shape, c_off, dtype=np.float64)
    rng = np.random.default_rng(seed)
    on = np.maximum(rng.normal(c_on, sigma, size=shape), MIN_CONTRAST)
    off = np.maximum(rng.normal(c_off, sigma, size=shape), MIN_CONTRAST)
    return on, off


def event_count_bound(
    video: ArrayLike,
    contrast_pos: float | np.ndarray = paper.CONTRAST_THRESHOLD,
    contrast_neg: float | np.ndarray = paper.CONTRAST_THRESHOLD,
    log_eps: float = 1e-3,
) -> float:
    """An upper bound on the number of events :func:`simulate_events` makes from ``video``.

    Per pixel, the reference level ends every frame pair within one threshold ``C`` of the
    log intensity, so the events of a pixel never exceed the total variation of its log
    intensity, ``sum_j |L_{j+1} - L_j|``, divided by its smaller threshold. The bound is
    that sum over the pixels (float; up to rounding). The thresholds may be numbers or
    per-pixel ``(H, W)`` arrays (:func:`draw_thresholds`). Reads the video one frame pair
    at a time, so it needs no more memory than a frame.

    Examples
    --------
    >>> video = np.array([0.1, 0.9, 0.1]).reshape(3, 1, 1)   # up, then down again
    >>> round(event_count_bound(video, 0.2, 0.2), 2)        # 2 * ln(0.901 / 0.101) / 0.2
    21.88
    >>> len(simulate_events(video, [0, 1000, 2000], 0.2, 0.2))
    20
    """
    v = _check_video(video)
    n, height, width = v.shape
    eps = _check_number("log_eps", log_eps)
    c_min = np.minimum(np.broadcast_to(np.asarray(contrast_pos, np.float64), (height, width)),
                       np.broadcast_to(np.asarray(contrast_neg, np.float64), (height, width)))
    if not (np.all(np.isfinite(c_min)) and np.all(c_min > 0)):
        raise ValueError("contrast thresholds must be finite numbers > 0")
    c_min = c_min.ravel()
    frames = v.reshape(n, height * width)
    log_of = _log_intensity(v.dtype, eps)
    total, previous = 0.0, log_of(frames[0])
    for j in range(1, n):
        current = log_of(frames[j])
        total += float(np.sum(np.abs(current - previous) / c_min))
        previous = current
    return total


# --- input checks, the event budget and assembly (hardening beside the idea above) -----------


def check_inputs(
    video: ArrayLike,
    t_us: ArrayLike,
    log_eps: float = 1e-3,
    refractory_us: float = 0,
    max_events: int = MAX_EVENTS,
    drift_per_us: float | np.ndarray = 0.0,
    reference_offset: float | np.ndarray = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """``(video, t)`` for :func:`simulate_events` after checking its inputs: ``video`` as an
    ``(n, H, W)`` uint8 or float array in [0, 1], ``t`` as int64 microseconds, strictly
    increasing and within :data:`MAX_ABS_TIME_US`. Raises ValueError naming the problem."""
    v = _check_video(video)
    t = _check_times(t_us, len(v))
    _check_number("log_eps", log_eps)
    _check_number("refractory_us", refractory_us, allow_zero=True)
    for name, value in (("drift_per_us", drift_per_us), ("reference_offset", reference_offset)):
        a = np.asarray(value)
        if a.ndim != 0 and a.shape != v.shape[1:] or not np.all(np.isfinite(a)):
            raise ValueError(f"{name} must be a finite number or one per pixel {v.shape[1:]}, "
                             f"got {'shape ' + str(a.shape) if a.ndim else repr(value)}")
    if isinstance(max_events, bool) or not isinstance(max_events, (int, np.integer)) \
            or max_events < 0:
        raise ValueError(f"max_events must be a whole number >= 0, got {max_events!r}")
    return v, t


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
    elif not np.issubdtype(t.dtype, np.integer) or t.dtype == bool:
        raise ValueError(f"t_us must be integer microseconds, got dtype {t.dtype}")
    # Checked before the cast to int64, so that no time can wrap around.
    outside = (t < -MAX_ABS_TIME_US) | (t > MAX_ABS_TIME_US)
    if np.any(outside):
        k = int(np.flatnonzero(outside)[0])
        raise ValueError(
            f"t_us must lie within +-{MAX_ABS_TIME_US} us (about 285 years, "
            f"simulate.MAX_ABS_TIME_US), where event times are exact; frame {k} is at "
            f"{t[k].item()} us. Subtract the first frame's time (t_us - t_us[0])")
    t = t.astype(np.int64)
    later = t[1:] > t[:-1]
    if not np.all(later):
        k = int(np.flatnonzero(~later)[0])
        raise ValueError(
            f"t_us must be strictly increasing; frame {k + 1} ({t[k + 1]} us) is not after "
            f"frame {k} ({t[k]} us)"
        )
    return t


def _check_number(name: str, value: float, allow_zero: bool = False) -> float:
    ok = isinstance(value, (int, float, np.integer, np.floating)) and math.isfinite(value)
    if not ok or value < 0 or (value == 0 and not allow_zero):
        need = ">= 0" if allow_zero else "> 0"
        raise ValueError(f"{name} must be a finite number {need}, got {value!r}")
    return float(value)


def _check_contrast(name: str, value: float | np.ndarray, shape: tuple[int, int]
                    ) -> float | np.ndarray:
    """A threshold as a float, or as a float64 array of ``shape`` (per pixel), all > 0."""
    if np.ndim(value) == 0:
        return _check_number(name, value)
    c = np.asarray(value, dtype=np.float64)
    if c.shape != tuple(shape):
        raise ValueError(f"{name} must be a number or one threshold per pixel {tuple(shape)}, "
                         f"got shape {c.shape}")
    if not (np.all(np.isfinite(c)) and np.all(c > 0)):
        raise ValueError(f"{name} must hold finite thresholds > 0 (smallest: {c.min()!r})")
    return c


def _log_intensity(dtype: np.dtype, log_eps: float) -> Callable[[np.ndarray], np.ndarray]:
    """A function from frame values to ``log(I + log_eps)`` in float64 (uint8: ``I = v / 255``,
    looked up in a table of the 256 values)."""
    if dtype == np.uint8:
        table = np.log(np.arange(256, dtype=np.float64) / 255.0 + log_eps)
        return lambda values: table[values]
    return lambda values: np.log(values.astype(np.float64) + log_eps)


def _check_budget(n_events: float, max_events: int, pair: int, video: np.ndarray,
                  c_on: np.ndarray, c_off: np.ndarray, log_eps: float) -> None:
    """Raise :class:`TooManyEventsError` when ``n_events`` (the events made up to and with
    frame pair ``pair``, counted before they are made) exceeds ``max_events``."""
    if n_events <= max_events:  # a float, exact below 2**53; checked before any cast
        return
    n, height, width = video.shape
    bound = event_count_bound(video, c_on.reshape(height, width), c_off.reshape(height, width),
                              log_eps)
    raise TooManyEventsError(
        f"the simulation would make more than max_events={max_events:,} events "
        f"({n_events:,.0f} in the first {pair + 1} of {n - 1} frame pairs; up to {bound:,.0f} "
        "for the whole video, simulate.event_count_bound), about 30 bytes each. Raise the "
        f"contrast thresholds (contrast_pos={c_on.min():g}, contrast_neg={c_off.min():g}; "
        "the usual range is 0.1-0.5), use a shorter or smaller video, or pass a larger "
        "max_events if the memory is there")


def _to_events(chunks: list[tuple[np.ndarray, np.ndarray, np.ndarray]], width: int
               ) -> np.ndarray:
    """Concatenate ``(times, pixels, polarities)`` chunks, already in output order, into an
    EVENT_DTYPE array (pixel index ``y * width + x``)."""
    total = sum(len(c[0]) for c in chunks)
    events = np.empty(total, dtype=EVENT_DTYPE)
    if total == 0:
        return events
    events["t"] = np.concatenate([c[0] for c in chunks])
    events["y"], events["x"] = np.divmod(np.concatenate([c[1] for c in chunks]), width)
    events["p"] = np.concatenate([c[2] for c in chunks])
    return events
