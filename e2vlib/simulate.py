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

Sensor noise (all off by default; then the output is exactly the noise-free model above).
The names follow v2e (Hu, Liu, Delbruck, CVPRW 2021), whose command-line options are given
in brackets:

* threshold mismatch ``contrast_sigma`` [``--sigma_thres``, also accepted as
  ``sigma_thres=``]: every pixel's ON and OFF thresholds are drawn once from normal
  distributions around ``contrast_pos`` / ``contrast_neg`` (clipped at
  :data:`MIN_CONTRAST`), the spread v2e draws (:func:`draw_thresholds`);
* leak events ``leak_rate_hz`` [``--leak_rate_hz``, Hz per pixel]: as in v2e, each pixel's
  reference drifts down by ``C_on * leak_rate_hz`` per second, so a static pixel emits ON
  events at ``leak_rate_hz``. Because the drift is linear in time it is simulated exactly:
  the pixel's log intensity gets the ramp ``+ C_on * leak_rate_hz * (t - t_us[0])`` and the
  rules above run unchanged. Each pixel starts at a random phase (its reference is lowered
  by ``u * C_on``, ``u`` uniform in [0, 1)), so leak events are spread evenly in time
  instead of firing together;
* shot noise ``shot_noise_rate_hz`` [``--shot_noise_rate_hz``, Hz per pixel, ON + OFF]:
  each pixel also emits events as a Poisson process of this rate over ``[t_us[0],
  t_us[-1])``, at whole microseconds, each ON or OFF with probability 1/2. They do not move
  the reference (a spurious reset back to the same level). Unlike v2e, the rate is the same
  for dark and bright pixels;
* refractory period ``refractory_us`` [``--refractory_period`` in seconds, the emulator's
  ``refractory_period_s``, also accepted as ``refractory_period_s=``]: applies to signal,
  leak and shot-noise events alike (a noise event too blocks its pixel).

v2e's finite photoreceptor bandwidth (``--cutoff_hz``), leak jitter and rate spread across
pixels (``--leak_jitter_fraction``, ``--noise_rate_cov_decades``) and its lin-log intensity
curve are not modelled. :data:`NOISE_LEVELS` holds presets for a noise study. With
``seed`` given the noise is reproducible; thresholds come from ``default_rng(seed)`` as
before and the noise from an independent stream spawned from the same seed, so adding
noise does not change the thresholds. Within one microsecond and pixel, signal events come
before shot-noise events.

Memory is bounded: before the events of a frame pair are made, their number is known
exactly (the sum of ``K``), and a run that would exceed ``max_events`` (default
:data:`MAX_EVENTS`) raises :class:`TooManyEventsError` with an upper bound for the whole
video (:func:`event_count_bound`) instead of allocating. Frame times must lie within
:data:`MAX_ABS_TIME_US` so that event times are exact in float64.

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

MAX_EVENTS: int = 50_000_000
"""Most events :func:`simulate_events` makes unless ``max_events=`` says otherwise. Each
event takes about 30 bytes while the stream is assembled (1.5 GB at this limit), and the
frame pair being simulated about 80 bytes per event of its own; a video needing more
(usually a contrast threshold far below the usual 0.1-0.5) raises
:class:`TooManyEventsError`."""

MAX_ABS_TIME_US: int = 2**53
"""Frame times must lie in ``[-MAX_ABS_TIME_US, MAX_ABS_TIME_US]`` (about 285 years): there
float64, in which event times are interpolated, holds every microsecond exactly."""


NOISE_LEVELS: dict[str, dict[str, float]] = {
    "clean": {"contrast_sigma": 0.0, "shot_noise_rate_hz": 0.0, "leak_rate_hz": 0.0,
              "refractory_us": 0.0},
    "low": {"contrast_sigma": 0.03, "shot_noise_rate_hz": 0.001, "leak_rate_hz": 0.01,
            "refractory_us": 500.0},
    "medium": {"contrast_sigma": 0.04, "shot_noise_rate_hz": 0.5, "leak_rate_hz": 0.05,
               "refractory_us": 500.0},
    "high": {"contrast_sigma": 0.05, "shot_noise_rate_hz": 5.0, "leak_rate_hz": 0.1,
             "refractory_us": 500.0},
}
"""Sensor-noise presets for a noise study: ``simulate_events(video, t, **NOISE_LEVELS[k])``.

* ``clean``: no noise at all, the exact model the datasets are built with (v2e's own
  ``--dvs_params clean`` keeps a small ``sigma_thres`` of 0.02);
* ``low``: v2e's command-line defaults, documented there as typical of a DAVIS camera in
  good light (``--sigma_thres 0.03``, ``--leak_rate_hz 0.01``, ``--shot_noise_rate_hz
  0.001``, ``--refractory_period 0.0005`` s);
* ``high``: v2e's ``--dvs_params noisy`` preset (``sigma_thres`` 0.05, leak 0.1 Hz, shot
  noise 5 Hz per pixel; dim light), with the default 0.5 ms refractory period kept;
* ``medium``: our choice between the two (about geometric means of the rates).

At the dataset's 128 x 128 px over 0.5 s, ``high`` adds about 41,000 shot-noise and 800
leak events to the 20,000-30,000 signal events of an object."""


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
events (5 in the first 1 of 1 frame pairs; up to 7 for the whole video, ...

    Introduced in notebooks/03_simulating_events.ipynb.
    """

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
    seed: int | np.random.Generator | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Per-pixel ON and OFF thresholds, each float64 of ``shape`` ``(H, W)``.

    Normal around ``contrast_pos`` / ``contrast_neg`` with standard deviation
    ``contrast_sigma`` (ON drawn first, then OFF, from ``np.random.default_rng(seed)``),
    clipped from below at :data:`MIN_CONTRAST`. With ``contrast_sigma = 0`` they are constant.
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
    seed: int | np.random.Generator | None = None,
    max_events: int = MAX_EVENTS,
    *,
    shot_noise_rate_hz: float = 0.0,
    leak_rate_hz: float = 0.0,
    sigma_thres: float | None = None,
    refractory_period_s: float | None = None,
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

    Sensor noise, off by default (module docstring; presets in :data:`NOISE_LEVELS`):
    ``shot_noise_rate_hz`` (Hz per pixel, ON + OFF, Poisson) and ``leak_rate_hz`` (Hz per
    pixel, ON events of a static pixel), both keyword-only and ``>= 0``. v2e's names
    ``sigma_thres`` (= ``contrast_sigma``) and ``refractory_period_s`` (seconds, =
    ``refractory_us / 1e6``) are accepted instead of ours. ``seed`` (an int, a
    ``numpy.random.Generator``, or None for fresh randomness) makes thresholds and noise
    reproducible.

    ``max_events`` (default :data:`MAX_EVENTS`) bounds the memory: each frame pair's events
    are counted before they are made, and a run that would go past the limit raises
    :class:`TooManyEventsError` (a ValueError) naming an upper bound for the whole video;
    raise the contrast thresholds, or ``max_events`` if the memory is there.

    Work per frame pair is one comparison of the two frames plus arithmetic on the pixels
    whose intensity changed and on the events they make; nothing loops over pixels (with
    leak events every pixel changes in every pair).

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
    v = _check_video(video)
    n, height, width = v.shape
    t = _check_times(t_us, n)
    eps = _check_positive("log_eps", log_eps)
    contrast_sigma = _alias("contrast_sigma", contrast_sigma, 0.0, "sigma_thres", sigma_thres)
    if refractory_period_s is not None:
        seconds = _check_positive("refractory_period_s", refractory_period_s, allow_zero=True)
        refractory_us = _alias("refractory_us", refractory_us, 0, "refractory_period_s",
                               seconds * 1e6)
    refractory = _check_positive("refractory_us", refractory_us, allow_zero=True)
    shot_rate = _check_positive("shot_noise_rate_hz", shot_noise_rate_hz, allow_zero=True)
    leak_rate = _check_positive("leak_rate_hz", leak_rate_hz, allow_zero=True)
    if isinstance(max_events, bool) or not isinstance(max_events, (int, np.integer)) \
            or max_events < 0:
        raise ValueError(f"max_events must be a whole number >= 0, got {max_events!r}")
    c_on, c_off = draw_thresholds((height, width), contrast_pos, contrast_neg,
                                  contrast_sigma, seed)
    c_on, c_off = c_on.ravel(), c_off.ravel()
    n_pixels = height * width
    noisy = shot_rate > 0 or leak_rate > 0
    noise_rng = _noise_rng(seed) if noisy else None

    frames = v.reshape(n, n_pixels)
    if v.dtype == np.uint8:
        table = np.log(np.arange(256, dtype=np.float64) / 255.0 + eps)

        def log_of(values: np.ndarray) -> np.ndarray:
            return table[values]
    else:

        def log_of(values: np.ndarray) -> np.ndarray:
            return np.log(values.astype(np.float64) + eps)

    level_now = log_of(frames[0])  # log intensity of the latest frame, per pixel
    reference = level_now.copy()
    drift = None  # leak: log-intensity ramp per microsecond, per pixel
    if leak_rate > 0:
        drift = c_on * (leak_rate * 1e-6)
        reference -= noise_rng.random(n_pixels) * c_on  # random phase of the first leak event
    shot = _shot_noise(noise_rng, t, n_pixels, shot_rate, max_events) if shot_rate > 0 \
        else None
    n_shot = 0 if shot is None else len(shot[0])
    last_t = np.full(n_pixels, _NEVER, dtype=np.int64)
    chunks: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
    n_made = 0  # events kept so far
    # (time - t_j) * pixels + pixel fits int64 for every pair: one sort key, else lexsort
    single_key = (int(np.max(np.diff(t))) + 1) * n_pixels < 2**62
    every_pixel = np.arange(n_pixels)

    for j in range(n - 1):
        noise = None
        if shot is not None:
            lo, hi = np.searchsorted(shot[0], (t[j], t[j + 1]))
            if hi > lo:
                noise = (shot[0][lo:hi], shot[1][lo:hi], shot[2][lo:hi])
        if drift is None:
            changed = np.flatnonzero(frames[j] != frames[j + 1])
            l1 = log_of(frames[j + 1][changed])
        else:  # the leak ramp changes every pixel
            changed = every_pixel
            l1 = log_of(frames[j + 1]) + drift * float(t[j + 1] - t[0])
        if changed.size == 0 and noise is None:
            continue
        l0 = level_now[changed]
        level_now[changed] = l1
        ref = reference[changed]
        up = l1 > ref
        contrast = np.where(up, c_on[changed], c_off[changed])
        count = np.floor(np.abs(l1 - ref) / contrast)
        count[l1 == l0] = 0  # distinct tiny floats can share one log value: no change
        fire = np.flatnonzero(count > 0)
        if fire.size == 0 and noise is None:
            continue
        n_pair = float(count[fire].sum())  # exact below 2**53; checked before any cast
        n_noise = 0 if noise is None else len(noise[0])
        if n_made + n_pair + n_noise > max_events:
            bound = event_count_bound(v, c_on.reshape(height, width),
                                      c_off.reshape(height, width), eps)
            bound += n_shot + n_pixels * (1 + leak_rate * 1e-6 * float(t[-1] - t[0]))
            raise TooManyEventsError(
                f"the simulation would make more than max_events={max_events:,} events "
                f"({n_made + n_pair + n_noise:,.0f} in the first {j + 1} of {n - 1} frame "
                f"pairs; up to {bound:,.0f} for the whole video, simulate.event_count_bound "
                "plus noise), about 30 bytes each. Raise the "
                f"contrast thresholds (contrast_pos={contrast_pos:g}, "
                f"contrast_neg={contrast_neg:g}; the usual range is 0.1-0.5), use a shorter "
                "or smaller video, or pass a larger max_events if the memory is there")
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

        if noise is not None:
            chunks.append(_merge_noise(times, pix_e, polarity, noise, last_t, refractory,
                                       n_pixels, t[j], single_key))
            n_made += len(chunks[-1][0])
            continue
        if refractory > 0:
            keep = _refractory_mask(times, pix, k_max, starts, last_t, refractory)
            times, pix_e, polarity = times[keep], pix_e[keep], polarity[keep]
        # pixel-major rows -> order by (time, pixel). Rows with equal keys are the same
        # pixel at the same microsecond with the same polarity: identical events, so an
        # unstable (SIMD) sort still gives a unique result.
        if single_key:
            order = np.argsort((times - t[j]) * n_pixels + pix_e)
        else:
            order = np.lexsort((pix_e, times))
        chunks.append((times[order], pix_e[order], polarity[order]))
        n_made += len(times)

    return _assemble(chunks, width)


def _alias(name: str, value: float, default: float, v2e_name: str,
           v2e_value: float | None) -> float:
    """``value``, or ``v2e_value`` when the v2e-named argument was given instead."""
    if v2e_value is None:
        return value
    if value != default:
        raise ValueError(f"give {name} or its v2e name {v2e_name}, not both "
                         f"({name}={value!r}, {v2e_name}={v2e_value!r})")
    return v2e_value


def _noise_rng(seed: int | np.random.Generator | None) -> np.random.Generator:
    """The noise's random stream: ``seed``'s own Generator, or a child of its SeedSequence
    (independent of the thresholds, which :func:`draw_thresholds` draws from the root)."""
    if isinstance(seed, np.random.Generator):
        return seed
    return np.random.default_rng(np.random.SeedSequence(seed).spawn(1)[0])


def _shot_noise(rng: np.random.Generator, t: np.ndarray, n_pixels: int, rate_hz: float,
                max_events: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Shot-noise events of the whole video as ``(times, pixels, polarities)``, by time.

    A Poisson process of ``rate_hz`` per pixel over ``[t[0], t[-1])`` at whole microseconds:
    the total is Poisson, and each event gets a uniform time, pixel and polarity.
    """
    duration_us = int(t[-1] - t[0])
    mean = rate_hz * 1e-6 * duration_us * n_pixels
    if mean > max_events:  # refuse before drawing (an expected count far past the limit)
        raise TooManyEventsError(
            f"shot noise of {rate_hz:g} Hz on {n_pixels:,} pixels over {duration_us:,} us "
            f"makes about {mean:,.0f} events, more than max_events={max_events:,}; lower "
            "shot_noise_rate_hz (v2e's range is about 0.001-5 Hz) or pass a larger max_events")
    total = int(rng.poisson(mean))
    times = rng.integers(t[0], t[-1], size=total, dtype=np.int64)
    pixels = rng.integers(0, n_pixels, size=total, dtype=np.int64)
    polarity = np.where(rng.random(total) < 0.5, 1, -1).astype(np.int8)
    order = np.argsort(times, kind="stable")
    return times[order], pixels[order], polarity[order]


def _merge_noise(
    times: np.ndarray, pix_e: np.ndarray, polarity: np.ndarray,
    noise: tuple[np.ndarray, np.ndarray, np.ndarray], last_t: np.ndarray,
    refractory: float, n_pixels: int, t_start: int, single_key: bool,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One frame pair's signal events (pixel-major rows) joined with its shot noise.

    Both kinds go through the refractory period together, per pixel in time order (signal
    first within a microsecond); returns the chunk ordered by (time, pixel), stably.
    """
    times = np.concatenate([times, noise[0]])
    pix_e = np.concatenate([pix_e, noise[1]])
    polarity = np.concatenate([polarity, noise[2]])
    if refractory > 0:
        source = np.zeros(len(times), dtype=np.int8)
        source[len(times) - len(noise[0]):] = 1
        rows = np.lexsort((source, times, pix_e))  # pixel-major, by time within a pixel
        times, pix_e, polarity = times[rows], pix_e[rows], polarity[rows]
        first = np.flatnonzero(np.r_[True, pix_e[1:] != pix_e[:-1]])
        counts = np.diff(np.r_[first, len(times)])
        keep = _refractory_mask(times, pix_e[first], counts, first, last_t, refractory)
        times, pix_e, polarity = times[keep], pix_e[keep], polarity[keep]
    if single_key:
        order = np.argsort((times - t_start) * n_pixels + pix_e, kind="stable")
    else:
        order = np.lexsort((pix_e, times))
    return times[order], pix_e[order], polarity[order]


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
    eps = _check_positive("log_eps", log_eps)
    c_min = np.minimum(np.broadcast_to(np.asarray(contrast_pos, np.float64), (height, width)),
                       np.broadcast_to(np.asarray(contrast_neg, np.float64), (height, width)))
    if not (np.all(np.isfinite(c_min)) and np.all(c_min > 0)):
        raise ValueError("contrast thresholds must be finite numbers > 0")
    c_min = c_min.ravel()
    frames = v.reshape(n, height * width)
    table = np.log(np.arange(256, dtype=np.float64) / 255.0 + eps)

    def log_of(values: np.ndarray) -> np.ndarray:
        return table[values] if v.dtype == np.uint8 else np.log(values.astype(np.float64) + eps)

    total, previous = 0.0, log_of(frames[0])
    for j in range(1, n):
        current = log_of(frames[j])
        total += float(np.sum(np.abs(current - previous) / c_min))
        previous = current
    return total


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
