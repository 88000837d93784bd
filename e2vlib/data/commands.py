"""The ``python -m e2vlib make-data`` command lines that build (or finish) a dataset.

Error messages and the sharded-build helpers name these, spelled out from the settings,
so a command copied from a message gives exactly the config it names.
"""

from __future__ import annotations

import os

from e2vlib import paper
from e2vlib.data.checks import SPLITS, read_config, rebuild_hint
from e2vlib.data.config import BuildConfig


def make_data_command(config: BuildConfig, out: str | os.PathLike,
                      shard: str | None = None) -> str:
    """The ``python -m e2vlib make-data`` command line that builds ``config`` into ``out``
    (only shard ``"i/n"`` of it when given); every setting is spelled out, so the command
    gives this exact config whatever the defaults.

    Examples
    --------
    >>> config = BuildConfig(categories=("chair",), per_category=2, resolution=32,
    ...                      frame_size=16, oversample=1)
    >>> print(make_data_command(config, "data_chairs", shard="0/2").replace(" --", "\\n  --"))
    python -m e2vlib make-data
      --out data_chairs
      --categories chair
      --per-category 2
      --resolution 32
      --frame-size 16
      --oversample 1
      --seed 0
      --raw-events-per-category 1
      --n-frames 100
      --dt-us 5000
      --windows fixed
      --shard 0/2
    """
    parts = ["python", "-m", "e2vlib", "make-data", "--out", str(out)]
    if tuple(config.categories) != tuple(paper.CATEGORIES):
        parts += ["--categories", ",".join(config.categories)]
    parts += ["--per-category", str(config.per_category), "--resolution", str(config.resolution),
              "--frame-size", str(config.frame_size), "--oversample", str(config.oversample)]
    if config.contrast != paper.CONTRAST_THRESHOLD:
        parts += ["--contrast", repr(float(config.contrast))]
    parts += ["--seed", str(config.seed),
              "--raw-events-per-category", str(config.raw_events_per_category),
              "--n-frames", str(config.n_frames), "--dt-us", str(config.dt_us),
              "--windows", config.windows]
    if config.grey_video:
        parts.append("--grey-video")
    if config.noise != "clean":
        parts += ["--noise", config.noise]
    if tuple(config.splits) != SPLITS:
        parts += ["--splits", *config.splits]
    if config.anti_aliasing != "ssaa":
        parts += ["--anti-aliasing", config.anti_aliasing]
    if shard is not None:
        parts += ["--shard", shard]
    return " ".join(parts)


def build_command(root: str | os.PathLike) -> str:
    """The make-data command (quoted) that finishes the build of ``root``, spelled out from
    its config.json where that is a full build config; a generic one otherwise.

    Examples
    --------
    >>> import json, tempfile
    >>> from pathlib import Path
    >>> root = Path(tempfile.mkdtemp())
    >>> build_command(root) == rebuild_hint(root)  # no config.json yet: the generic hint
    True
    >>> config = BuildConfig(categories=("chair",), per_category=2, oversample=1)
    >>> _ = (root / "config.json").write_text(json.dumps(config.to_dict()))
    >>> build_command(root) == f"`{make_data_command(config, root)}`"
    True
    """
    try:
        return f"`{make_data_command(BuildConfig.from_dict(read_config(root)), root)}`"
    except (TypeError, ValueError):
        return rebuild_hint(root)
