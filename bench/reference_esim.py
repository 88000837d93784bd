"""A plain, full-frame vectorized numpy ESIM: the benchmark reference for e2vlib.simulate.

Same model and the same rules as :func:`e2vlib.simulate.simulate_events` (see that module's
docstring), written the obvious way: every frame pair does its arithmetic on the whole
frame in float64, finds the pixels with crossings with ``np.nonzero``, then loops over the
crossing index ``k = 1..max K`` to make the events, and one global sort at the end orders
them. It must give identical events; bench/bench_simulate.py checks that and times both.
"""

from __future__ import annotations

import numpy as np

from e2vlib.events import EVENT_DTYPE
from e2vlib.simulate import draw_thresholds


def reference_esim(
    video: np.ndarray,
    t_us: np.ndarray,
    contrast_pos: float = 0.2,
    contrast_neg: float = 0.2,
    contrast_sigma: float = 0.0,
    refractory_us: float = 0,
    log_eps: float = 1e-3,
    seed: int | None = None,
) -> np.ndarray:
    """Events of ``video`` (n, H, W) at frame times ``t_us`` (us); no input checks."""
    n, height, width = video.shape
    c_on, c_off = draw_thresholds((height, width), contrast_pos, contrast_neg,
                                  contrast_sigma, seed)
    if video.dtype == np.uint8:
        intensity = video.astype(np.float64) / 255.0
    else:
        intensity = video.astype(np.float64)
    t = np.asarray(t_us, dtype=np.int64)

    reference = np.log(intensity[0] + log_eps)
    previous = reference.copy()
    last_t = np.full((height, width), np.iinfo(np.int64).min // 2, dtype=np.int64)
    out_t, out_x, out_y, out_p, out_pair = [], [], [], [], []

    for j in range(n - 1):
        current = np.log(intensity[j + 1] + log_eps)
        up = current > reference
        contrast = np.where(up, c_on, c_off)
        count = np.floor(np.abs(current - reference) / contrast)
        count[current == previous] = 0  # unchanged pixels never fire
        signed_c = np.where(up, contrast, -contrast)
        ys, xs = np.nonzero(count)
        if len(ys):
            k_of = count[ys, xs]
            ref, c = reference[ys, xs], signed_c[ys, xs]
            l0, l1 = previous[ys, xs], current[ys, xs]
            t0, t1 = float(t[j]), float(t[j + 1])
            for k in range(1, int(k_of.max()) + 1):
                m = k_of >= k
                level = ref[m] + float(k) * c[m]
                frac = np.clip((level - l0[m]) / (l1[m] - l0[m]), 0.0, 1.0)
                times = np.rint(t0 + frac * (t1 - t0)).astype(np.int64)
                y, x = ys[m], xs[m]
                ok = times - last_t[y, x] >= refractory_us
                last_t[y[ok], x[ok]] = times[ok]
                out_t.append(times[ok])
                out_x.append(x[ok])
                out_y.append(y[ok])
                out_p.append(np.where(c[m][ok] > 0, 1, -1))
                out_pair.append(np.full(int(ok.sum()), j))
        reference = reference + count * signed_c
        previous = current

    events = np.empty(sum(len(a) for a in out_t), dtype=EVENT_DTYPE)
    if len(events) == 0:
        return events
    tt, xx, yy = np.concatenate(out_t), np.concatenate(out_x), np.concatenate(out_y)
    pair = np.concatenate(out_pair)
    order = np.lexsort((yy * width + xx, pair, tt))  # time, then frame pair, then pixel
    events["t"], events["x"], events["y"] = tt[order], xx[order], yy[order]
    events["p"] = np.concatenate(out_p)[order]
    return events
