"""Sensor noise of a DVS pixel, added to the events of :mod:`e2vlib.simulate`.

The names and the model follow v2e (Hu, Liu, Delbruck, CVPRW 2021), whose command-line
options are given in brackets. Threshold mismatch and the refractory period are arguments
of :func:`~e2vlib.simulate.simulate_events` itself; this module adds the rest:

* shot noise ``shot_noise_rate_hz`` [``--shot_noise_rate_hz``, Hz per pixel, ON + OFF]
  (:func:`add_shot_noise`): each pixel also emits events as a Poisson process of this rate
  over ``[t_us[0], t_us[-1])``, at whole microseconds, each ON or OFF with probability 1/2.
  They do not move the reference (a spurious reset back to the same level). Unlike v2e, the
  rate is the same for dark and bright pixels;
* leak events ``leak_rate_hz`` [``--leak_rate_hz``, Hz per pixel] (:func:`leak_drift`): as
  in v2e, each pixel's reference drifts down by ``C_on * leak_rate_hz`` per second, so a
  static pixel emits ON events at ``leak_rate_hz``. The drift is linear in time, so it is
  simulated exactly: the log intensity gets the ramp ``+ C_on * leak_rate_hz * (t -
  t_us[0])`` and the simulator's rules run unchanged. Each pixel starts at a random phase
  (its reference is lowered by ``u * C_on``, ``u`` uniform in [0, 1)), so leak events are
  spread evenly in time instead of firing together. A leak is not a stream of its own: it
  adds to (or cancels) the crossings the scene makes;
* the refractory period ``refractory_us`` [``--refractory_period``, in seconds there]
  applies to signal, leak and shot-noise events alike (a noise event too blocks its pixel).

:func:`simulate_noisy_events` puts them together; :data:`NOISE_LEVELS` holds presets for a
noise study. v2e's finite photoreceptor bandwidth (``--cutoff_hz``), leak jitter and rate
spread across pixels (``--leak_jitter_fraction``, ``--noise_rate_cov_decades``) and its
lin-log intensity curve are not modelled.

Introduced in notebooks/12_noise_and_data.ipynb.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from e2vlib import paper
from e2vlib.events import EVENT_DTYPE
from e2vlib.simulate import (
    MAX_EVENTS,
    TooManyEventsError,
    apply_refractory,
    check_inputs,
    draw_thresholds,
    simulate_events,
)

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
"""Sensor-noise presets for a noise study: ``simulate_noisy_events(video, t, **NOISE_LEVELS[k])``.

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


def simulate_noisy_events(
    video: ArrayLike,
    t_us: ArrayLike,
    contrast_pos: float = paper.CONTRAST_THRESHOLD,
    contrast_neg: float = paper.CONTRAST_THRESHOLD,
    contrast_sigma: float = 0.0,
    refractory_us: float = 0,
    log_eps: float = 1e-3,
    seed: int | np.random.Generator | None = None,
    *,
    shot_noise_rate_hz: float = 0.0,
    leak_rate_hz: float = 0.0,
    max_events: int = MAX_EVENTS,
) -> np.ndarray:
    """:func:`~e2vlib.simulate.simulate_events` with shot noise and leak events added.

    The arguments before ``*`` are those of ``simulate_events`` (same units);
    ``shot_noise_rate_hz`` (Hz per pixel, ON + OFF, Poisson) and ``leak_rate_hz`` (Hz per
    pixel, ON events of a static pixel) are ``>= 0``; with both 0 the result is exactly
    ``simulate_events``'s. ``seed`` (an int, a ``numpy.random.Generator``, or None for fresh
    randomness) makes thresholds and noise reproducible: thresholds come from
    ``default_rng(seed)``, the noise from an independent stream spawned from the same seed
    (a Generator is used for both), so adding noise does not change the thresholds. Events
    are sorted by time, then pixel ``y * W + x``; within one microsecond and pixel, signal
    events come before shot-noise events, and the refractory period applies to all.

    Examples
    --------
    A static 2 x 2 px scene for 10 s: with leak at 0.5 Hz each pixel fires an ON event
    every 2 s, from a random phase (5 per pixel):

    >>> video, t = np.full((2, 2, 2), 0.5), [0, 10_000_000]
    >>> len(simulate_noisy_events(video, t))
    0
    >>> leak = simulate_noisy_events(video, t, leak_rate_hz=0.5, seed=0)
    >>> len(leak), set(leak["p"].tolist())
    (20, {1})

    Introduced in notebooks/12_noise_and_data.ipynb.
    """
    video, t = check_inputs(video, t_us, log_eps, refractory_us, max_events)
    shot_rate = _check_rate("shot_noise_rate_hz", shot_noise_rate_hz)
    leak_rate = _check_rate("leak_rate_hz", leak_rate_hz)
    n, height, width = video.shape
    c_on, c_off = draw_thresholds((height, width), contrast_pos, contrast_neg,
                                  contrast_sigma, seed)
    rng = noise_rng(seed) if shot_rate > 0 or leak_rate > 0 else None
    drift, offset = leak_drift(c_on, leak_rate, rng) if leak_rate > 0 else (0.0, 0.0)
    events = simulate_events(video, t, c_on, c_off, 0.0, 0, log_eps, drift_per_us=drift,
                             reference_offset=offset, max_events=max_events)
    if shot_rate > 0:
        events = add_shot_noise(events, (width, height), t[0], t[-1], shot_rate, rng,
                                max_events)
    return apply_refractory(events, refractory_us)


def leak_drift(c_on: np.ndarray, rate_hz: float, seed: int | np.random.Generator | None = None
               ) -> tuple[np.ndarray, np.ndarray]:
    """``(drift_per_us, reference_offset)`` for :func:`~e2vlib.simulate.simulate_events` that
    make leak events at ``rate_hz`` per pixel (Hz), each ``(H, W)`` like ``c_on``.

    The reference drifts down by ``c_on * rate_hz`` per second, i.e. the log intensity gets
    that ramp up (``c_on * rate_hz * 1e-6`` per microsecond); the first reference is lowered
    by ``u * c_on``, ``u`` uniform in [0, 1) per pixel (one draw from ``seed``).

    Examples
    --------
    >>> drift, offset = leak_drift(np.full((1, 2), 0.2), 0.5, seed=0)
    >>> drift.tolist()  # 0.2 * 0.5 per second
    [[1e-07, 1e-07]]
    >>> bool(np.all((offset <= 0) & (offset > -0.2)))
    True
    """
    rate = _check_rate("leak_rate_hz", rate_hz)
    rng = np.random.default_rng(seed)
    c_on = np.asarray(c_on, dtype=np.float64)
    offset = -(rng.random(c_on.shape) * c_on)
    return c_on * (rate * 1e-6), offset


def add_shot_noise(
    events: np.ndarray,
    sensor_size: tuple[int, int],
    t_start_us: int,
    t_end_us: int,
    rate_hz: float,
    seed: int | np.random.Generator | None = None,
    max_events: int = MAX_EVENTS,
) -> np.ndarray:
    """``events`` with shot noise of ``rate_hz`` per pixel (Hz, ON + OFF) added over
    ``[t_start_us, t_end_us)``, sorted by time, then pixel ``y * W + x``.

    A Poisson process per pixel at whole microseconds: the total is Poisson with mean
    ``rate_hz * 1e-6 * (t_end_us - t_start_us) * W * H``, and each event gets a uniform
    time, pixel and polarity (drawn in that order from ``seed``). At equal time and pixel,
    ``events`` come first, in their own order, then the noise. Raises
    :class:`~e2vlib.simulate.TooManyEventsError` before drawing when the stream would pass
    ``max_events``.

    Examples
    --------
    >>> noise = add_shot_noise(np.empty(0, EVENT_DTYPE), (40, 50), 0, 10_000_000, 2.0, seed=0)
    >>> abs(len(noise) - 40_000) < 800  # 2 Hz x 2000 px x 10 s, sd 200
    True

    Introduced in notebooks/12_noise_and_data.ipynb.
    """
    width, height = sensor_size
    rate = _check_rate("shot_noise_rate_hz", rate_hz)
    duration_us = int(t_end_us) - int(t_start_us)
    mean = rate * 1e-6 * duration_us * width * height
    if len(events) + mean > max_events:  # refuse before drawing
        raise TooManyEventsError(
            f"shot noise of {rate:g} Hz on {width * height:,} pixels over {duration_us:,} us "
            f"makes about {mean:,.0f} events, more than max_events={max_events:,} with the "
            f"{len(events):,} events already there; lower shot_noise_rate_hz (v2e's range is "
            "about 0.001-5 Hz) or pass a larger max_events")
    rng = np.random.default_rng(seed)
    total = int(rng.poisson(mean))
    noise = np.empty(total, dtype=EVENT_DTYPE)
    noise["t"] = rng.integers(t_start_us, t_end_us, size=total, dtype=np.int64)
    noise["y"], noise["x"] = np.divmod(rng.integers(0, width * height, size=total,
                                                    dtype=np.int64), width)
    noise["p"] = np.where(rng.random(total) < 0.5, 1, -1)
    both = np.concatenate([events, noise])
    return both[np.lexsort((both["x"], both["y"], both["t"]))]  # stable: events first


def noise_rng(seed: int | np.random.Generator | None) -> np.random.Generator:
    """The noise's random stream: ``seed`` itself when it is a Generator, else a child of its
    SeedSequence (independent of the thresholds, which
    :func:`~e2vlib.simulate.draw_thresholds` draws from the root)."""
    if isinstance(seed, np.random.Generator):
        return seed
    return np.random.default_rng(np.random.SeedSequence(seed).spawn(1)[0])


def _check_rate(name: str, value: float) -> float:
    ok = isinstance(value, (int, float, np.integer, np.floating)) and math.isfinite(value)
    if not ok or value < 0:
        raise ValueError(f"{name} must be a finite number >= 0 (Hz per pixel), got {value!r}")
    return float(value)
