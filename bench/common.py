"""Shared helpers for the benchmarks: repeated timing, machine description, RESULTS.md.

Each benchmark script measures one area and replaces its own ``## <title>`` section of
bench/RESULTS.md, so scripts can run alone or all together (`make bench`).
"""

from __future__ import annotations

import os
import platform
import re
import statistics
import time
from collections.abc import Callable
from pathlib import Path

from e2vlib.experiments import cpu_name

RESULTS = Path(__file__).resolve().parent / "RESULTS.md"
HEADER = (
    "# Benchmark results\n\n"
    "Written by the scripts in bench/ (`make bench` runs them all). Each section says the\n"
    "command that produced it, the machine, and the median and spread of repeated runs.\n"
)


def timeit(fn: Callable[[], object], repeat: int = 5, warmup: int = 1) -> dict[str, float]:
    """Run ``fn`` ``warmup + repeat`` times; return median/min/max seconds of the timed runs."""
    for _ in range(warmup):
        fn()
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return {"median": statistics.median(times), "min": min(times), "max": max(times),
            "repeat": repeat}


def spread(result: dict[str, float], scale: float = 1.0, unit: str = "s") -> str:
    """``'0.123 s (0.120-0.130, n=5)'`` from a :func:`timeit` result."""
    return (f"{result['median'] * scale:.3g} {unit} "
            f"({result['min'] * scale:.3g}-{result['max'] * scale:.3g}, n={result['repeat']})")


def machine() -> str:
    """One line: CPU model, cores, Python and key library versions."""
    cpu = cpu_name()
    versions = []
    for name in ("numpy", "torch", "vtk", "trimesh", "tonic"):
        try:
            module = __import__(name)
            versions.append(f"{name} {module.__version__}")
        except ImportError:
            pass
    return (f"{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}, "
            + ", ".join(versions))


def write_section(title: str, body: str) -> None:
    """Replace (or append) the ``## title`` section of bench/RESULTS.md with ``body``."""
    text = RESULTS.read_text() if RESULTS.exists() else HEADER
    section = f"## {title}\n\n{body.strip()}\n\n"
    pattern = re.compile(rf"^## {re.escape(title)}\n.*?(?=^## |\Z)", re.S | re.M)
    text = pattern.sub(lambda _: section, text) if pattern.search(text) else (
        text.rstrip() + "\n\n" + section)
    tmp = RESULTS.with_suffix(".tmp")
    tmp.write_text(text.rstrip() + "\n")
    os.replace(tmp, RESULTS)
