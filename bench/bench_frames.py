"""Frame accumulation: e2vlib's accumulators against tonic's ToFrame, mode by mode.

10 million random events on a 256 x 256 sensor over [0, 500000) us, 100 windows of
5 ms (the paper's setting). For each mode (binary, count, polarity) it times tonic's
nearest equivalent, the numpy version the lessons read (``e2vlib.frames.accumulate``) and
the compiled one (``e2vlib.scale.frames_numba.accumulate_fast``, where numba is installed),
with fixed windows and with the paper's Eq. 5 groups (``windows="paper"``), plus the
first call's compile time. Run:
`python bench/bench_frames.py` (tonic needed: `pip install -r
environment/bench-requirements.txt`). Writes the "Frame accumulation" section of
bench/RESULTS.md.
"""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import machine, spread, timeit, write_section  # noqa: E402

from e2vlib.events import make_events  # noqa: E402
from e2vlib.frames import accumulate  # noqa: E402

try:
    from e2vlib.scale import frames_numba
except ImportError:  # numba is not installed: only the numpy rows
    frames_numba = None

N_EVENTS, SIZE, DT, N_FRAMES = 10_000_000, 256, 5000, 100
MODES = ("binary", "count", "polarity")
ROOT = Path(__file__).resolve().parent.parent

# a fresh interpreter's first call: import, compile (or load the cache), run
FIRST_CALL = """
import time
start = time.perf_counter()
from e2vlib.events import make_events
from {module} import {name} as accumulate
ev = make_events([0, 1], [0, 0], [0, 7], [1, -1])
for windows in ("fixed", "paper"):
    for mode in ("binary", "count", "polarity"):
        accumulate(ev, (2, 1), dt_us=5, mode=mode, windows=windows)
print(time.perf_counter() - start)
"""
FAST = {"module": "e2vlib.scale.frames_numba", "name": "accumulate_fast"}
PLAIN = {"module": "e2vlib.frames", "name": "accumulate"}


def make_stream(seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    t = np.sort(rng.integers(0, N_FRAMES * DT, N_EVENTS))
    return make_events(rng.integers(0, SIZE, N_EVENTS), rng.integers(0, SIZE, N_EVENTS), t,
                       rng.integers(0, 2, N_EVENTS))


ONE_THREAD = "numba, 1 thread"


@contextlib.contextmanager
def one_thread():
    """accumulate_fast without its threaded parts: one loop over the whole stream."""
    saved = frames_numba.THREADED_MIN_EVENTS
    frames_numba.THREADED_MIN_EVENTS = 2**62
    try:
        yield
    finally:
        frames_numba.THREADED_MIN_EVENTS = saved


def read_bandwidth(nbytes: int) -> float:
    """Bytes/s of a plain read of ``nbytes`` (a float64 sum), the memory roof of one pass."""
    data = np.ones(nbytes // 8)
    return nbytes / timeit(data.sum, repeat=7)["median"]


def first_call_seconds() -> dict[str, float]:
    """Wall seconds of a new interpreter's first calls (all modes, both window kinds).

    ``"compile"``: ``accumulate_fast`` with an empty numba cache (what its first call on a
    machine pays), ``"cached"`` run again with that cache, ``"numpy"``: ``accumulate``.
    """
    result = {}
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache}
        for name in ("compile", "cached"):
            out = subprocess.run([sys.executable, "-c", FIRST_CALL.format(**FAST)], env=env,
                                 cwd=ROOT,
                                 capture_output=True, text=True, check=True)
            result[name] = float(out.stdout.split()[-1])
    out = subprocess.run([sys.executable, "-c", FIRST_CALL.format(**PLAIN)], cwd=ROOT,
                         capture_output=True, text=True, check=True)
    result["numpy"] = float(out.stdout.split()[-1])
    return result


def tonic_runs(events: np.ndarray, repeat: int) -> tuple[dict, int]:
    """tonic's ``ToFrame`` for each mode (timings) and the events its default drops.

    tonic has no binary mode: its count frames are thresholded (``> 0``) inside the timing.
    Its one-channel sensor wants a single polarity, so ``count`` gets a copy with p = 0.
    """
    import tonic.transforms as T

    both = np.empty(N_EVENTS, dtype=[(f, "<i8") for f in "xytp"])
    for f in "xyt":
        both[f] = events[f]
    both["p"] = events["p"] > 0  # tonic wants polarity 0/1 as a channel index
    single = both.copy()
    single["p"] = 0
    two = T.ToFrame(sensor_size=(SIZE, SIZE, 2), time_window=DT, include_incomplete=True)
    one = T.ToFrame(sensor_size=(SIZE, SIZE, 1), time_window=DT, include_incomplete=True)
    calls = {"binary": lambda: (one(single) > 0).astype(np.uint8),
             "count": lambda: one(single), "polarity": lambda: two(both)}
    for mode, call in calls.items():  # same frames as ours, checked before timing
        ours = accumulate(events, (SIZE, SIZE), DT, 0, N_FRAMES, mode)
        theirs = call().reshape(ours.shape)
        assert np.array_equal(theirs, ours), f"tonic and e2vlib disagree ({mode})"
    timings = {mode: timeit(call, repeat=repeat) for mode, call in calls.items()}
    default = T.ToFrame(sensor_size=(SIZE, SIZE, 2), time_window=DT)(both)
    return timings, N_EVENTS - int(default.sum())


def main(repeat: int = 5) -> str:
    events = make_stream()
    fast = frames_numba is not None
    backend = "numba" if fast else "numpy"
    calls = {"numpy": accumulate}
    if fast:
        calls["numba"] = frames_numba.accumulate_fast
    ours = {}
    for mode in MODES:
        for windows in ("fixed", "paper"):
            for name, call in calls.items():
                ours[mode, windows, name] = timeit(
                    lambda m=mode, w=windows, c=call: c(
                        events, (SIZE, SIZE), DT, 0, N_FRAMES, m, w), repeat=repeat)
            if fast:  # the same kernel in one thread (the parts are counted in threads)
                with one_thread():
                    ours[mode, windows, ONE_THREAD] = timeit(
                        lambda m=mode, w=windows: frames_numba.accumulate_fast(
                            events, (SIZE, SIZE), DT, 0, N_FRAMES, m, w), repeat=repeat)
    try:
        tonic, dropped = tonic_runs(events, repeat)
    except ImportError:
        tonic, dropped = {}, None
    bandwidth = read_bandwidth(events.nbytes)
    cores = frames_numba._cores() if fast else 1
    no_tonic = ("" if tonic else " tonic is not installed here (`pip install -r "
                "environment/bench-requirements.txt`), so no row compares with it.")
    first = first_call_seconds() if fast else None
    first_text = ("numba is not installed here: no compiled rows." if first is None else
                  "First call in a new interpreter (import, then all three modes and both "
                  "window kinds on two\nevents): `accumulate_fast` "
                  f"{first['compile']:.1f} s with an empty numba cache (numba compiles the "
                  f"kernels once\nper machine), {first['cached']:.1f} s once they are cached; "
                  f"`accumulate` {first['numpy']:.1f} s.")
    groups = len(accumulate(events, (SIZE, SIZE), DT, 0, None, "binary", "paper"))

    def row(label: str, result: dict, mode: str) -> str:
        rate = N_EVENTS / result["median"]
        vs = f"{tonic[mode]['median'] / result['median']:.1f}x" if tonic else "n/a"
        roof = events.nbytes / result["median"] / bandwidth
        return (f"| {label} | {spread(result, 1e3, 'ms')} | {rate / 1e6:.0f} M/s | {vs} "
                f"| {roof:.0%} |")

    rows = []
    for mode in MODES:
        if tonic:
            rows.append(row(f"tonic `ToFrame`, {mode}", tonic[mode], mode))
        for windows in ("fixed", "paper"):
            for name in dict.fromkeys(("numpy", backend, ONE_THREAD if fast else "numpy")):
                label = f"e2vlib `{mode}`, `{windows}`, {name}"
                rows.append(row(f"**{label}**" if name == backend else label,
                                ours[mode, windows, name], mode))
    body = f"""Command: `python bench/bench_frames.py`. Machine: {machine()}.

{N_EVENTS:,} random events, {SIZE}x{SIZE} sensor, {N_FRAMES} windows of {DT} us over
[0, {N_FRAMES * DT}) us. tonic 1.7 `ToFrame(include_incomplete=True)` gives the same frames
as `accumulate` with fixed windows (checked for every mode): its two-channel frames are our
`polarity` mode, its one-channel frames (events given p = 0) our `count` mode, and those
thresholded `> 0` (inside the timing; tonic has no binary mode) our `binary` mode. tonic has
no Eq. 5 grouping, so `paper` rows are compared with tonic's fixed windows of the same mode
(Eq. 5 cuts this stream into {groups} groups of at most 5001 us; the first {N_FRAMES} are
kept). `numpy` is `e2vlib.frames.accumulate`, the version the lessons read; bold: `numba`,
`e2vlib.scale.frames_numba.accumulate_fast` (opt-in, identical frames; a stream this long is
cut at window or group starts into one part per core, {cores} here, counted at once in
threads); "numba, 1 thread" is the same loop over the whole stream in one thread, like tonic
and numpy.{no_tonic}
The event array is {events.nbytes / 1e6:.0f} MB (13 bytes per event); a plain read (one
thread) of that many bytes runs at {bandwidth / 1e9:.1f} GB/s here, so "of memory roof" is
(event bytes / time) / that bandwidth: 100% would mean the events are read once at full
speed and nothing else costs time.

| implementation | time per call | events/s | vs tonic (same mode) | of memory roof |
| --- | --- | --- | --- | --- |
{chr(10).join(rows)}

{first_text}

tonic's default `ToFrame(time_window=...)` (include_incomplete=False) drops the last, partial
window: here it lost {dropped if dropped is not None else 'n/a'} events; `accumulate` keeps
every event up to the window holding the last one.
"""
    write_section("Frame accumulation", body)
    return body


if __name__ == "__main__":
    print(main())
