"""Benchmark e2vlib.simulate against the plain numpy ESIM, and e2vlib.render's frame rate.

Run from the repository root:  .venv/bin/python bench/bench_simulate.py [--reps 5] [--no-write]

Renders a simple object (boxes and a ball built with trimesh) along the paper's orbit,
times both simulators on the same video (median of --reps runs), checks that they give
identical events, times render_orbit at several resolutions, and rewrites the
"## Simulation and rendering" section of bench/RESULTS.md (other sections are kept).
Uses bench/common.py for timing, the machine line and the section writer.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np
import trimesh

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import machine, spread, timeit, write_section  # noqa: E402
from reference_esim import reference_esim  # noqa: E402

from e2vlib.orbit import pixel_motion_per_frame, required_oversample  # noqa: E402
from e2vlib.render import render_orbit  # noqa: E402
from e2vlib.simulate import simulate_events  # noqa: E402

TITLE = "Simulation and rendering"


def bench_object() -> trimesh.Trimesh:
    """A table-like object: a slab on two legs plus a ball, inside the unit cube."""
    parts = []
    slab_and_legs = (((0.9, 0.5, 0.08), (0, 0, 0.1)),
                     ((0.08, 0.08, 0.55), (0.35, 0.18, -0.22)),
                     ((0.08, 0.08, 0.55), (-0.35, -0.18, -0.22)))
    for extents, offset in slab_and_legs:
        box = trimesh.creation.box(extents)
        box.apply_translation(offset)
        parts.append(box)
    ball = trimesh.creation.icosphere(subdivisions=3, radius=0.18)
    ball.apply_translation((-0.15, 0.05, 0.32))
    parts.append(ball)
    return trimesh.util.concatenate(parts)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reps", type=int, default=5)
    parser.add_argument("--no-write", action="store_true", help="print only")
    args = parser.parse_args()

    load_start = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    mesh = bench_object()
    lines = [f"Machine: {machine()}, pyvista/VTK off screen.",
             "Command: `.venv/bin/python bench/bench_simulate.py` (times: median (min-max, n "
             "runs) after one warm-up; object: a slab on two legs plus a ball, in the unit "
             "cube; the reference is bench/reference_esim.py, a full-frame float64 numpy ESIM "
             "with a loop over the crossing index).", ""]

    lines += ["### ESIM simulation (C = 0.2, other settings default)", "",
              "| video | events | e2vlib.simulate | reference numpy ESIM | speed-up "
              "| e2vlib events/s | identical events |", "|---|---|---|---|---|---|---|"]
    cases = [(256, 1), (256, required_oversample(120, 256)), (128, required_oversample(120, 128))]
    for res, k in cases:
        video, t_us = render_orbit(mesh, n_frames=120, fps=240, resolution=res, oversample=k)
        events = simulate_events(video, t_us)
        same = np.array_equal(events, reference_esim(video, t_us))
        lib = timeit(lambda v=video, t=t_us: simulate_events(v, t), repeat=args.reps)
        ref = timeit(lambda v=video, t=t_us: reference_esim(v, t), repeat=args.reps)
        label = f"{len(video)} frames x {res}^2 px (120 @ 240 fps, oversample {k})"
        lines.append(f"| {label} | {len(events):,} | {spread(lib)} | {spread(ref)} "
                     f"| {ref['median'] / lib['median']:.1f}x "
                     f"| {len(events) / lib['median']:,.0f} | {'yes' if same else 'NO'} |")
        print(lines[-1], flush=True)

    lines += ["", "### render_orbit (120 frames, one plotter per call, off screen)", "",
              "| resolution | anti-aliasing | time per call | frames/s | max motion px/frame "
              "| oversample for <= 1 px |", "|---|---|---|---|---|---|"]
    for res, aa in ((128, True), (256, True), (256, False), (512, True)):
        result = timeit(lambda r=res, a=aa: render_orbit(mesh, 120, 240, r, anti_aliasing=a),
                        repeat=1 if res >= 512 else 3, warmup=0)
        lines.append(f"| {res} | {'SSAA' if aa else 'off'} | {spread(result)} "
                     f"| {120 / result['median']:.0f} "
                     f"| {pixel_motion_per_frame(120, res).max():.2f} "
                     f"| {required_oversample(120, res)} |")
        print(lines[-1], flush=True)
    lines += ["", "Time per call includes creating and closing the plotter. Max motion: the "
              "largest image displacement between consecutive frames of any point of the unit "
              "cube (`e2vlib.orbit.pixel_motion_per_frame`); `oversample` from "
              "`e2vlib.orbit.required_oversample`."]

    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    lines.append(f"\nLoad average (1 min) at the start: {load_start:.1f}, at the end: {load:.1f} "
                 f"(other jobs share the {os.cpu_count()} cores when it exceeds about 1).")
    body = "\n".join(lines)
    print(body)
    if not args.no_write:
        write_section(TITLE, body)
        print("wrote bench/RESULTS.md")


if __name__ == "__main__":
    main()
