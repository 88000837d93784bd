"""Where a record was made: the library's git commit, the CPU model, Debian package versions."""

from __future__ import annotations

import subprocess
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
"""The repository's root (the folder holding ``e2vlib/``)."""


def git_commit() -> str:
    """The short commit of the checkout, ``-dirty`` when ``e2vlib/`` has uncommitted
    changes; ``"unknown"`` outside a git checkout. Every study record carries it."""
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=REPO, text=True,
                              capture_output=True, check=True, timeout=30).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "e2vlib"], cwd=REPO, text=True,
                               capture_output=True, check=True, timeout=30).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return head + ("-dirty" if dirty else "")


def cpu_name() -> str:
    """The CPU's model name (``/proc/cpuinfo``, else :func:`platform.processor`).

    Floating-point results of training depend on the CPU's vector kernels: the same
    protocol and seed give the same run on one CPU model, bit for bit, but not across models
    (measured: three seeds trained on an AMD EPYC and an Intel Xeon differed by 0.008-0.026
    test IoU@0.3). Records carry it, and :func:`~e2vlib.experiments.find_same_run` copies
    only runs of the same CPU.
    """
    import platform

    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown"


def package_version(name: str) -> str:
    """The installed version of Debian package ``name`` (``dpkg-query``), or ``"unknown"``.

    Examples
    --------
    >>> package_version("no-such-package-e2v")
    'unknown'
    """
    try:
        out = subprocess.run(["dpkg-query", "-W", "-f=${Version}", name], capture_output=True,
                             text=True, timeout=10)
        return out.stdout.strip() or "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"
