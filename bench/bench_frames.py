"""Frame accumulation: e2vlib.frames.accumulate against tonic's ToFrame.

10 million random events on a 256 x 256 sensor over [0, 500000) us, 100 windows of
5 ms (the paper's setting). Run: `python bench/bench_frames.py` (tonic needed:
`pip install -r environment/bench-requirements.txt`). Writes the "Frame accumulation"
section of bench/RESULTS.md.
"""

from __future__ import annotations

import sys

import numpy as np

sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parent))
from common import machine, spread, timeit, write_section  # noqa: E402

from e2vlib.events import make_events  # noqa: E402
from e2vlib.frames import accumulate  # noqa: E402

N_EVENTS, SIZE, DT, N_FRAMES = 10_000_000, 256, 5000, 100


def make_stream(seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    t = np.sort(rng.integers(0, N_FRAMES * DT, N_EVENTS))
    return make_events(rng.integers(0, SIZE, N_EVENTS), rng.integers(0, SIZE, N_EVENTS), t,
                       rng.integers(0, 2, N_EVENTS))


def read_bandwidth(nbytes: int) -> float:
    """Bytes/s of a plain read of ``nbytes`` (a float64 sum), the memory roof of one pass."""
    data = np.ones(nbytes // 8)
    return nbytes / timeit(data.sum, repeat=7)["median"]


def main(repeat: int = 5) -> str:
    events = make_stream()
    rows = []
    ours = {}
    for mode in ("binary", "count", "polarity"):
        ours[mode] = timeit(lambda m=mode: accumulate(events, (SIZE, SIZE), DT, 0, N_FRAMES, m),
                            repeat=repeat)
    try:
        import tonic.transforms as T

        tonic_events = np.empty(N_EVENTS, dtype=[(f, "<i8") for f in "xytp"])
        for f in "xyt":
            tonic_events[f] = events[f]
        tonic_events["p"] = events["p"] > 0  # tonic wants polarity 0/1 as a channel index
        to_frame = T.ToFrame(sensor_size=(SIZE, SIZE, 2), time_window=DT,
                             include_incomplete=True)
        reference = to_frame(tonic_events)
        ours_polarity = accumulate(events, (SIZE, SIZE), DT, 0, N_FRAMES, "polarity")
        assert reference.shape == ours_polarity.shape
        assert np.array_equal(reference, ours_polarity), "tonic and e2vlib disagree"
        tonic = timeit(lambda: to_frame(tonic_events), repeat=repeat)
        tonic_default = T.ToFrame(sensor_size=(SIZE, SIZE, 2), time_window=DT)(tonic_events)
        dropped = N_EVENTS - int(tonic_default.sum())
    except ImportError:
        tonic, dropped = None, None

    bandwidth = read_bandwidth(events.nbytes)
    for mode, result in ours.items():
        rate = N_EVENTS / result["median"]
        vs = f"{tonic['median'] / result['median']:.1f}x" if tonic else "n/a"
        roof = events.nbytes / result["median"] / bandwidth
        rows.append(f"| e2vlib `{mode}` | {spread(result, 1e3, 'ms')} | {rate / 1e6:.0f} M/s "
                    f"| {vs} | {roof:.0%} |")
    if tonic:
        rows.append(f"| tonic `ToFrame` (include_incomplete=True) | {spread(tonic, 1e3, 'ms')} "
                    f"| {N_EVENTS / tonic['median'] / 1e6:.0f} M/s | 1.0x | "
                    f"{events.nbytes / tonic['median'] / bandwidth:.0%} |")
    body = f"""Command: `python bench/bench_frames.py`. Machine: {machine()}.

{N_EVENTS:,} random events, {SIZE}x{SIZE} sensor, {N_FRAMES} windows of {DT} us over
[0, {N_FRAMES * DT}) us. Identical windows for both libraries; tonic's polarity frames equal
e2vlib's `polarity` mode exactly (checked). The event array is {events.nbytes / 1e6:.0f} MB
(13 bytes per event); a plain read of that many bytes runs at {bandwidth / 1e9:.1f} GB/s here, so
"of memory roof" is (event bytes / time) / that bandwidth: 100% would mean the events are read
once at full speed and nothing else costs time.

| implementation | time per call | events/s | vs tonic | of memory roof |
| --- | --- | --- | --- | --- |
{chr(10).join(rows)}

tonic's default `ToFrame(time_window=...)` (include_incomplete=False) drops the last, partial
window: here it lost {dropped if dropped is not None else 'n/a'} events; `accumulate` keeps
every event up to the window holding the last one.
"""
    write_section("Frame accumulation", body)
    return body


if __name__ == "__main__":
    print(main())
