"""One dataset sample end to end, per stage; throughput with workers; paper-scale projection.

Times ``e2vlib.data.mesh_to_sample`` (normalize + voxelize + render orbit + simulate +
frames) after a warm-up sample, at 128 px (data_small's setting) and 256 px, over the PROBE
objects, with the datasets' anti-aliasing (``"ssaa"``) and without (``"none"``), and compares
the two modes' events and frames (also over every data_small object when
``cache/render_none`` is built, ``e2vlib.experiments.RENDER_COMMAND``); the stages are
timed inside that same call (the library functions it looks up are wrapped by a timer while
the benchmark runs). Each time is given as wall-clock seconds and as
the process's CPU seconds (``getrusage``: user + system of every thread, Mesa's llvmpipe
render threads included), which stays meaningful when other jobs share the cores. Then the
render stage alone with every anti-aliasing mode of ``render_orbit``, then a small dataset
built with ``--workers 1`` and ``2`` in both modes for samples per hour, and the projection
to the paper's 39,739 scans.

Run: ``python bench/bench_dataset.py`` (writes the "Dataset building" section of
bench/RESULTS.md); ``--no-write`` only prints; ``--quick`` skips throughput and the modes.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import resource
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parent))
from common import machine, write_section  # noqa: E402

import e2vlib.data  # noqa: E402
import e2vlib.scale.render_cache  # noqa: E402
import e2vlib.simulate  # noqa: E402
import e2vlib.voxels  # noqa: E402
from e2vlib.data import (  # noqa: E402
    BuildConfig,
    build_dataset,
    load_sample,
    mesh_to_sample,
    read_manifest,
)
from e2vlib.experiments import RENDER_CACHE, RENDER_COMMAND, REPO  # noqa: E402
from e2vlib.scale.render_cache import render_orbit_cached  # noqa: E402
from e2vlib.shapes import CATEGORIES, make_shape, normalize_mesh  # noqa: E402

PAPER_SCANS = 39_739
PROBE = ("chair", "airplane", "cabinet", "lamp")
TARGETS = {128: 0.5, 256: 2.0}  # issue 15: seconds per sample on quiet cores
SAMPLE_MODES = ("ssaa", "none")  # the datasets' anti-aliasing, and the fast opt-in one
# the stages of mesh_to_sample: (module, function) that it looks up when called
STAGES = {"voxelize": (e2vlib.voxels, "voxelize"),
          "render": (e2vlib.scale.render_cache, "render_orbit_cached"),
          "simulate": (e2vlib.simulate, "simulate_events"),
          "frames": (e2vlib.data.samples, "orbit_input")}


def kept_plotter_renderer(*args, **kwargs):
    """The renderer the samples are made with: ``render_orbit_cached`` (one plotter kept per
    process), looked up when called so that the stage timer sees it."""
    return e2vlib.scale.render_cache.render_orbit_cached(*args, **kwargs)


def cpu_seconds() -> float:
    """User + system CPU seconds of this process, all threads (llvmpipe's included)."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


class Clock:
    """Wall and CPU seconds of a block: ``with Clock() as c: ...; c.wall, c.cpu``."""

    def __enter__(self) -> Clock:
        self._wall, self._cpu = time.perf_counter(), cpu_seconds()
        return self

    def __exit__(self, *exc) -> None:
        self.wall = time.perf_counter() - self._wall
        self.cpu = cpu_seconds() - self._cpu


@contextlib.contextmanager
def timed_stages(log: dict[str, list[tuple[float, float]]]):
    """Wrap the STAGES functions so each call appends ``(wall, cpu)`` to ``log[stage]``."""
    saved = {}
    for stage, (module, name) in STAGES.items():
        original = saved[stage] = getattr(module, name)

        def wrapper(*args, _f=original, _stage=stage, **kwargs):
            with Clock() as clock:
                result = _f(*args, **kwargs)
            log.setdefault(_stage, []).append((clock.wall, clock.cpu))
            return result

        setattr(module, name, wrapper)
    try:
        yield
    finally:
        for stage, (module, name) in STAGES.items():
            setattr(module, name, saved[stage])


def median_spread(values: list[float], digits: int = 2) -> str:
    """``'0.41 (0.38-0.47)'``: median and range."""
    return (f"{statistics.median(values):.{digits}f} "
            f"({min(values):.{digits}f}-{max(values):.{digits}f})")


def config_for(resolution: int, anti_aliasing: str = "ssaa") -> BuildConfig:
    return BuildConfig(categories=CATEGORIES, per_category=1, resolution=resolution,
                       frame_size=resolution // 2, anti_aliasing=anti_aliasing)


def time_samples(resolution: int, repeat: int, anti_aliasing: str = "ssaa") -> dict:
    """mesh_to_sample over PROBE x ``repeat`` after one warm-up sample, with its stages;
    ``samples`` keeps each object's (n_events, frames) of the first pass."""
    config = config_for(resolution, anti_aliasing)
    mesh_to_sample(make_shape("chair", 99), config, seed=99,
                   renderer=kept_plotter_renderer)  # warm-up: imports, plotter
    totals, stages, n_events, samples = [], {}, [], {}
    for _ in range(repeat):
        for k, category in enumerate(PROBE):
            mesh = make_shape(category, k)
            log: dict[str, list[tuple[float, float]]] = {}
            with timed_stages(log), Clock() as clock:
                sample = mesh_to_sample(mesh, config, seed=k, renderer=kept_plotter_renderer)
            totals.append((clock.wall, clock.cpu))
            spent = {stage: tuple(map(sum, zip(*log[stage], strict=True))) for stage in STAGES}
            spent["other"] = (clock.wall - sum(v[0] for v in spent.values()),
                              clock.cpu - sum(v[1] for v in spent.values()))
            for stage, value in spent.items():
                stages.setdefault(stage, []).append(value)
            n_events.append(len(sample.events))
            samples.setdefault(category, (len(sample.events), sample.frames.astype(bool)))
    return {"config": config, "totals": totals, "stages": stages,
            "events": statistics.median(n_events), "samples": samples}


def frame_agreement(smooth: np.ndarray, plain: np.ndarray) -> tuple[float, float]:
    """(active pixels of ``plain`` / of ``smooth``, IoU of the two binary frame stacks)."""
    return float(plain.sum() / smooth.sum()), float((smooth & plain).sum() / (smooth | plain).sum())


def event_difference_row(label: str, pairs: list[tuple[int, int, np.ndarray, np.ndarray]]) -> str:
    """A table row comparing ``(n_ssaa, n_none, frames_ssaa, frames_none)`` per object."""
    ratios = [b / a for a, b, _, _ in pairs]
    active, overlap = zip(*(frame_agreement(f, g) for _, _, f, g in pairs), strict=True)
    return (f"| {label} | {len(pairs)} | {median_spread(ratios)} | {median_spread(active)} | "
            f"{median_spread(overlap)} |")


def dataset_difference_row(smooth_root: Path, plain_root: Path, label: str) -> str | None:
    """The same comparison over every sample of two builds of the same objects (None when
    ``plain_root`` is not built)."""
    if not (plain_root / "manifest.csv").exists():
        return None
    rows = {root: {r["id"]: r for r in read_manifest(root)} for root in (smooth_root, plain_root)}
    if rows[smooth_root].keys() != rows[plain_root].keys():
        raise ValueError(f"{plain_root} holds other objects than {smooth_root}")
    pairs = []
    for sample_id in rows[smooth_root]:
        f, v = load_sample(smooth_root / "samples" / f"{sample_id}.npz")
        g, w = load_sample(plain_root / "samples" / f"{sample_id}.npz")
        if not np.array_equal(v, w):
            raise ValueError(f"{sample_id}: the two builds' voxels differ")
        pairs.append((int(rows[smooth_root][sample_id]["n_events"]),
                      int(rows[plain_root][sample_id]["n_events"]), f.astype(bool),
                      g.astype(bool)))
    resolution = json.loads((smooth_root / "config.json").read_text())["resolution"]
    return event_difference_row(f"{label}, every sample, {resolution} px", pairs)


def time_render_modes(resolution: int,
                      modes=("ssaa", "msaa", "supersample", "none")) -> list[str]:
    """The render stage alone with each anti-aliasing mode (median over PROBE)."""
    k = config_for(resolution).oversample
    rows = []
    for mode in modes:
        render_orbit_cached(normalize_mesh(make_shape("chair", 99)), 120, 240, resolution,
                            oversample=k, anti_aliasing=mode)  # warm-up of this mode's plotter
        walls, cpus = [], []
        for i, category in enumerate(PROBE):
            mesh = normalize_mesh(make_shape(category, i))
            with Clock() as clock:
                render_orbit_cached(mesh, 120, 240, resolution, oversample=k,
                                    anti_aliasing=mode)
            walls.append(clock.wall)
            cpus.append(clock.cpu)
        rows.append(f"| {resolution} px | `{mode}`{' (datasets)' if mode == 'ssaa' else ''} | "
                    f"{median_spread(walls)} | {median_spread(cpus)} |")
        print(rows[-1], flush=True)
    return rows


def throughput(workers: int, n_per_category: int = 8, anti_aliasing: str = "ssaa") -> float:
    """Samples per hour building a 13-category set with ``workers`` processes."""
    config = BuildConfig(categories=CATEGORIES, per_category=n_per_category,
                         anti_aliasing=anti_aliasing)
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        build_dataset(tmp, config, workers=workers, progress=False)
        seconds = time.perf_counter() - start
    return len(CATEGORIES) * n_per_category / seconds * 3600


def main(argv: list[str] | None = None) -> str:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=2, help="passes over the probe objects")
    parser.add_argument("--no-write", action="store_true", help="print, leave RESULTS.md")
    parser.add_argument("--quick", action="store_true",
                        help="only the per-sample timings (no modes, no throughput)")
    args, _ = parser.parse_known_args(argv)  # bench/run_all.py passes its own arguments
    load_start = os.getloadavg()[0]

    stage_rows, total_rows, difference_rows, medians = [], [], [], {}
    for resolution in (128, 256):
        results = {}
        for mode in SAMPLE_MODES:
            result = results[mode] = time_samples(resolution, args.repeat, mode)
            config, totals = result["config"], result["totals"]
            walls, cpus = [t[0] for t in totals], [t[1] for t in totals]
            medians[resolution, mode] = statistics.median(walls)
            target = TARGETS[resolution]
            total_rows.append(
                f"| {resolution} px (oversample {config.oversample}, {len(totals)} samples) | "
                f"`{mode}` | **{median_spread(walls)}** | {median_spread(cpus)} | {target} | "
                f"{'yes' if medians[resolution, mode] <= target else 'no'} | "
                f"{result['events'] / 1e3:.0f} k |")
            cells = []
            for stage in (*STAGES, "other"):
                wall = statistics.median(v[0] for v in result["stages"][stage])
                cpu = statistics.median(v[1] for v in result["stages"][stage])
                cells.append(f"{wall:.3f} / {cpu:.3f}")
            stage_rows.append(f"| {resolution} px | `{mode}` | " + " | ".join(cells) + " |")
            print(total_rows[-1], stage_rows[-1], sep="\n", flush=True)
        smooth, plain = results["ssaa"]["samples"], results["none"]["samples"]
        difference_rows.append(event_difference_row(
            f"{', '.join(PROBE)}, {resolution} px",
            [(smooth[c][0], plain[c][0], smooth[c][1], plain[c][1]) for c in PROBE]))
    whole = dataset_difference_row(REPO / "data_small", REPO / RENDER_CACHE,
                                   f"`{RENDER_CACHE}` vs `data_small`")
    difference_rows.append(whole or f"| every data_small object: build `{RENDER_CACHE}` with "
                           f"`{RENDER_COMMAND}` | | | | |")
    print(*difference_rows, sep="\n", flush=True)

    mode_rows = []
    per_hour = {}
    if not args.quick:
        for resolution in (128, 256):
            mode_rows += time_render_modes(resolution)
        for mode in SAMPLE_MODES:
            per_hour[1, mode] = throughput(1, anti_aliasing=mode)
            per_hour[2, mode] = throughput(2, anti_aliasing=mode)
    projection = []
    for workers in (2, 16, 64, 256):
        cells = []
        for mode in SAMPLE_MODES:
            hours = PAPER_SCANS / (per_hour.get((2, mode), float("nan")) / 2 * workers)
            cells += [f"{hours:.1f} h", f"{hours * medians[256, mode] / medians[128, mode]:.1f} h"]
        projection.append(f"| {workers} | " + " | ".join(cells) + " |")
    throughput_rows = [f"| `{mode}` | {per_hour.get((1, mode), float('nan')):.0f} | "
                       f"{per_hour.get((2, mode), float('nan')):.0f} |" for mode in SAMPLE_MODES]
    load_end = os.getloadavg()[0]
    nl = "\n"
    body = f"""Command: `python bench/bench_dataset.py`. Machine: {machine()}.
Load average (1 min): {load_start:.1f} at the start, {load_end:.1f} at the end (other jobs
share the {os.cpu_count()} cores when it is above about 1; then trust the CPU column).

One sample end to end, `e2vlib.data.mesh_to_sample` after a warm-up sample, over
{args.repeat} x {len(PROBE)} objects ({", ".join(PROBE)}), orbit rendered with the
oversampling that keeps motion within 1 px per frame, with the datasets' anti-aliasing
(`"ssaa"`, VTK's supersampling) and without any (`"none"`, `make-data --anti-aliasing
none`); median (min-max) seconds. Wall is the clock; CPU is the process's user + system time
over all its threads (Mesa's llvmpipe renders on several), so CPU can exceed wall:

| resolution | anti_aliasing | wall [s] | CPU [s] | target [s] | met (wall) | events |
| --- | --- | --- | --- | --- | --- | --- |
{nl.join(total_rows)}

Per stage inside those calls, median wall / CPU seconds ("other": normalizing the mesh and
packing the sample):

| resolution | anti_aliasing | voxelize | render | simulate | frames | other |
| --- | --- | --- | --- | --- | --- | --- |
{nl.join(stage_rows)}

Rendering dominates with `"ssaa"`: VTK's supersampling pass renders each frame sqrt(5) x
larger on each side (5 x the pixels) and filters it down in two more passes, all on the CPU
(Mesa llvmpipe). The plotter is made once per process and resolution and reused
(`e2vlib.scale.render_cache.render_orbit_cached`); frames are read straight from the window.
The render stage alone with every mode, median (min-max) seconds:

| resolution | anti_aliasing | wall [s] | CPU [s] |
| --- | --- | --- | --- |
{nl.join(mode_rows)}

What `"none"` changes (same objects, same simulator seed; median (min-max) per object):
events of `"none"` / events of `"ssaa"`; active pixels of the stored binary frames
(`"none"` / `"ssaa"`); and the IoU of the two binary frame stacks (1 = identical). Without
anti-aliasing a pixel on a moving edge jumps from object to background grey in one rendered
frame, so it fires all its events at once; with SSAA the edge is a 2-3 px ramp whose pixels
each cross fewer thresholds. So `"none"` makes about as many or more events on about a third
fewer pixels: thinner, jagged outlines in the frames, which share only about 55-65 % of
their active pixels with the datasets' frames. The render study (`python -m e2vlib
experiment render`, experiments/results/render.json, lesson 04) measures what that does to
learning: nothing measurable at 3 seeds.

| objects | n | events none / ssaa | active frame pixels none / ssaa | frame IoU |
| --- | --- | --- | --- | --- |
{nl.join(difference_rows)}

Building 104 samples (8 per category, 128 px) end to end with `build_dataset`, samples per
hour (including the workers' start-up, a few seconds each):

| anti_aliasing | 1 worker | `--workers 2` |
| --- | --- | --- |
{nl.join(throughput_rows)}

The paper's {PAPER_SCANS:,} scans, assuming throughput grows linearly with workers (one per
core; use `--shard i/n` to spread them over machines or cluster jobs; 256 px scaled by the
per-sample time):

| workers | `ssaa` at 128 px | `ssaa` at 256 px | `none` at 128 px | `none` at 256 px |
| --- | --- | --- | --- | --- |
{nl.join(projection)}
"""
    print(body)
    if not args.no_write and not args.quick:
        write_section("Dataset building", body)
    return body


if __name__ == "__main__":
    main()
