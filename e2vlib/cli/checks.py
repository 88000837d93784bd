"""Checks of command-line values before any work starts: argument types, devices, output
paths, category lists, and frames that must match a checkpoint's.

Each raises :class:`~e2vlib.experiments.errors.UsageError` (exit status 2) naming the flag and the
fix, except :func:`model_frames_check`, whose data is wrong rather than the command line
(:class:`~e2vlib.experiments.errors.CommandError` or ValueError, exit status 1).
"""

from __future__ import annotations

import argparse
import math
import os
from pathlib import Path

from e2vlib.experiments.errors import CommandError, UsageError
from e2vlib.files import kind_of_file

DEVICES = "auto, cpu, cuda, cuda:N (the N-th GPU), mps"
"""What ``--device`` accepts, for messages."""

PICTURE_TYPES = (".png", ".jpg", ".jpeg", ".pdf", ".svg")
"""Endings ``reconstruct --png`` can write."""


# --------------------------------------------------------------------------- argument types

def whole_number(minimum: int):
    """An argparse type: a whole number >= ``minimum``.

    Examples
    --------
    >>> at_least_one = whole_number(1)
    >>> at_least_one("3")
    3
    >>> at_least_one("0")
    Traceback (most recent call last):
    ...
    argparse.ArgumentTypeError: must be a whole number >= 1, got 0
    """

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"expected a whole number >= {minimum}, got {text!r}") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(
                f"must be a whole number >= {minimum}, got {value}")
        return value

    parse.__name__ = f"whole number >= {minimum}"
    return parse


def bounded(minimum: int, maximum: int):
    """An argparse type: a whole number from ``minimum`` to ``maximum``.

    Examples
    --------
    >>> bounded(1, 8192)("8192")
    8192
    >>> bounded(1, 8192)("9000")
    Traceback (most recent call last):
    ...
    argparse.ArgumentTypeError: must be a whole number from 1 to 8192, got 9000
    """
    parse_low = whole_number(minimum)

    def parse(text: str) -> int:
        value = parse_low(text)
        if value > maximum:
            raise argparse.ArgumentTypeError(
                f"must be a whole number from {minimum} to {maximum}, got {value}")
        return value

    parse.__name__ = f"whole number {minimum}..{maximum}"
    return parse


def positive_number(text: str) -> float:
    """An argparse type: a finite number > 0.

    Examples
    --------
    >>> positive_number("1e-3")
    0.001
    >>> positive_number("nan")
    Traceback (most recent call last):
    ...
    argparse.ArgumentTypeError: must be a finite number > 0, got nan
    """
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number > 0, got {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text}")
    return value


# --------------------------------------------------------------------------- checks


def check_device(text: str) -> None:
    """Refuse a ``--device`` torch cannot use here, listing the valid ones.

    Examples
    --------
    >>> check_device("cpu")  # usable here: no answer
    >>> check_device("tpu")
    Traceback (most recent call last):
    ...
    e2vlib.experiments.errors.UsageError: --device 'tpu' is not a device; use one of auto, cpu, \
cuda, \
cuda:N (the N-th GPU), mps
    """
    import torch

    from e2vlib.train import resolve_device

    if text != "auto":
        try:
            device = torch.device(text)
        except (RuntimeError, ValueError, TypeError):
            raise UsageError(f"--device {text!r} is not a device; use one of {DEVICES}") from None
        if device.type not in ("cpu", "cuda", "mps"):
            raise UsageError(f"--device {text!r} is not supported; use one of {DEVICES}")
        if device.type == "mps" and not torch.backends.mps.is_available():
            raise UsageError("--device mps: this machine has no Apple GPU (MPS); use --device "
                             "cpu or auto")
        if device.type == "cuda" and device.index is not None and torch.cuda.is_available():
            count = torch.cuda.device_count()
            if device.index >= count:
                raise UsageError(f"--device {text}: this machine has {count} GPU(s), "
                                 f"cuda:0 .. cuda:{count - 1}; pick one of those or auto")
    try:
        resolve_device(text)
    except ValueError as err:
        raise UsageError(f"--device {text}: {err}") from None


def writable_folder(folder: Path, flag: str, target: Path) -> None:
    """Refuse ``folder`` (where ``target`` goes) if it or its nearest existing parent is
    not a writable folder: fail before the work, not after it.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> blocker = Path(tempfile.mkdtemp()) / "file.txt"
    >>> _ = blocker.write_text("x")
    >>> writable_folder(blocker / "run", "--out", blocker / "run")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.experiments.errors.UsageError: --out .../file.txt/run: .../file.txt is a file, not a \
folder; \
choose another --out
    """
    existing = folder.absolute()
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if not existing.is_dir():
        raise UsageError(f"{flag} {target}: {existing} is a file, not a folder; choose another "
                         f"{flag}")
    if not os.access(existing, os.W_OK | os.X_OK) or not _can_create_in(existing):
        raise UsageError(f"{flag} {target}: cannot write into {existing} (permission denied "
                         f"or read-only); choose another {flag} or fix the folder's permissions")


def _can_create_in(folder: Path) -> bool:
    """True when a file can really be made in ``folder`` (``os.access`` says yes to root
    everywhere, ``/proc`` included): a hidden probe file is made and removed."""
    import tempfile

    try:
        with tempfile.NamedTemporaryFile(dir=folder, prefix=".e2v-probe-"):
            return True
    except OSError:
        return False


def output_file(text: str, flag: str, example: str) -> Path:
    """Check an output file path (not a folder, in a writable folder) before the work.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> folder = Path(tempfile.mkdtemp())
    >>> output_file(str(folder / "new" / "r.npz"), "--out", "r.npz") == folder / "new" / "r.npz"
    True
    >>> output_file(str(folder), "--out", "r.npz")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.experiments.errors.UsageError: --out ... is a directory; give a file name, e.g. .../r.npz
    """
    path = Path(text)
    if path.is_dir():
        raise UsageError(f"{flag} {path} is a directory; give a file name, e.g. "
                         f"{path / example}")
    if text.endswith(("/", os.sep)):
        raise UsageError(f"{flag} {text!r} ends with a folder separator; give a file name, "
                         f"e.g. {path / example}")
    if path.exists() and not path.is_file():
        kind = kind_of_file(path.stat().st_mode)
        raise UsageError(f"{flag} {path} exists and is {kind}, not a regular file; choose "
                         f"another {flag} (such a path is never replaced, --overwrite or not)")
    writable_folder(path.parent, flag, path)
    return path


def separate_paths(outputs: dict[str, Path | None], inputs: dict[str, str | None]) -> None:
    """Refuse an output that is an input or another output (it would be destroyed, or
    written over by the next one), whatever ``--overwrite`` says.

    ``outputs`` and ``inputs`` map flags to paths (None: not given); two paths are one when
    they name the same file (links followed) or, for a file not yet made, the same place.

    Examples
    --------
    >>> separate_paths({"--out": Path("r.npz"), "--png": Path("./r.npz")}, {})
    Traceback (most recent call last):
    ...
    e2vlib.experiments.errors.UsageError: --out and --png are both r.npz; give each output its \
own file
    >>> separate_paths({"--out": Path("e.npz")}, {"--events": "e.npz"})
    Traceback (most recent call last):
    ...
    e2vlib.experiments.errors.UsageError: --out e.npz is the --events input; write the output to \
another file (an output never replaces an input)
    """
    def same(a: Path, b: Path) -> bool:
        if a.exists() and b.exists():
            return os.path.samefile(a, b)
        return a.resolve() == b.resolve()

    given = [(flag, path) for flag, path in outputs.items() if path is not None]
    for k, (flag, path) in enumerate(given):
        for other_flag, other in given[k + 1:]:
            if same(path, other):
                raise UsageError(f"{flag} and {other_flag} are both {path}; give each output "
                                 "its own file")
        for in_flag, text in inputs.items():
            if text is not None and same(path, Path(text)):
                raise UsageError(f"{flag} {path} is the {in_flag} input; write the output to "
                                 "another file (an output never replaces an input)")


def output_folder(text: str, flag: str) -> Path:
    """Check an output folder path (not a file, writable) before the work.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> blocker = Path(tempfile.mkdtemp()) / "file.txt"
    >>> _ = blocker.write_text("x")
    >>> output_folder(str(blocker.parent / "run"), "--out").name  # created later if missing
    'run'
    >>> output_folder(str(blocker), "--out")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.experiments.errors.UsageError: --out .../file.txt is a file; give a folder (it is \
created if \
missing)
    """
    path = Path(text)
    if path.exists() and not path.is_dir():
        raise UsageError(f"{flag} {path} is a file; give a folder (it is created if missing)")
    writable_folder(path, flag, path)
    return path


def parse_categories(text: str) -> tuple[str, ...]:
    """``--categories`` as a tuple of known names, refusing empty, unknown and repeated ones.

    Examples
    --------
    >>> parse_categories("chair, table")
    ('chair', 'table')
    >>> parse_categories("chair,chairs")
    Traceback (most recent call last):
    ...
    e2vlib.experiments.errors.UsageError: --categories: unknown ['chairs']; choose from \
airplane,bench,\
cabinet,car,chair,display,lamp,speaker,rifle,sofa,table,telephone,watercraft
    """
    from e2vlib.paper import CATEGORIES

    names = [name.strip() for name in text.split(",") if name.strip()]
    if not names:
        raise UsageError(f"--categories {text!r} names no category; give a comma-separated "
                         f"subset of {','.join(CATEGORIES)} (or leave the option out for all "
                         f"{len(CATEGORIES)})")
    unknown = [name for name in names if name not in CATEGORIES]
    if unknown:
        raise UsageError(f"--categories: unknown {unknown}; choose from {','.join(CATEGORIES)}")
    repeated = sorted({name for name in names if names.count(name) > 1})
    if repeated:
        raise UsageError(f"--categories names {repeated} more than once; list each once")
    return tuple(names)


def model_frames_check(model, ckpt: dict, checkpoint: str, data_config: dict | None,
                        input_shape, source: str) -> None:
    """Refuse data whose frames differ from those the checkpoint's model was trained on.

    Examples
    --------
    >>> from e2vlib.model import build_e2v
    >>> model = build_e2v("tiny", input_shape=(10, 16, 16))
    >>> ckpt = {"data_config": {"n_frames": 10, "frame_size": 16, "dt_us": 5000}}
    >>> model_frames_check(model, ckpt, "m.pt", {"frame_size": 16, "n_frames": 10},
    ...                    (10, 16, 16), "dataset d")  # the same frames: no answer
    >>> model_frames_check(model, ckpt, "m.pt", None, (10, 32, 32), "dataset d")
    Traceback (most recent call last):
    ...
    e2vlib.experiments.errors.CommandError: checkpoint m.pt takes frames of shape (10, 16, 16) \
(n_frames, H, W) but dataset d has (10, 32, 32); use data built with the checkpoint's \
settings (make-data --frame-size), or a model trained on it
    """
    from e2vlib.model import check_frames_match, checkpoint_data_config

    check_frames_match(checkpoint_data_config(ckpt), data_config, f"checkpoint {checkpoint}",
                       source)
    if input_shape is not None and tuple(input_shape) != tuple(model.input_shape):
        raise CommandError(
            f"checkpoint {checkpoint} takes frames of shape {tuple(model.input_shape)} "
            f"(n_frames, H, W) but {source} has {tuple(input_shape)}; use data built with "
            "the checkpoint's settings (make-data --frame-size), or a model trained on it")


def real_meshes_flags_check(args: argparse.Namespace) -> None:
    """Refuse ``make-data --real-meshes`` with flags the real-mesh test set cannot honour,
    each with its reason, before any work (:class:`~e2vlib.experiments.errors.UsageError`).

    Examples
    --------
    >>> from e2vlib.cli.parser import build_parser
    >>> parse = build_parser(figures=print).parse_args
    >>> real_meshes_flags_check(parse(["make-data", "--out", "d", "--real-meshes", "c.csv",
    ...                                "--per-category", "3", "--grey-video"]))
    Traceback (most recent call last):
    ...
    e2vlib.experiments.errors.UsageError: --real-meshes builds one test sample per kept catalogue \
row, so these flags cannot apply: --per-category (the catalogue sets the objects); \
--grey-video (the real-mesh set stores no grey video); drop them
    """
    from e2vlib.data import SPLITS

    refused = {
        "--categories": (args.categories is not None, "the catalogue sets the categories"),
        "--per-category": (args.per_category is not None, "the catalogue sets the objects"),
        "--raw-events-per-category": (args.raw_events_per_category != 1,
                                      "the real-mesh set keeps no raw events"),
        "--grey-video": (args.grey_video, "the real-mesh set stores no grey video"),
        "--splits": (tuple(args.splits) != tuple(SPLITS), "every real object is a test sample"),
        "--shard": (args.shard != "0/1", "the real-mesh set is built whole (use --workers)"),
    }
    given = [f"{flag} ({why})" for flag, (on, why) in refused.items() if on]
    if given:
        raise UsageError("--real-meshes builds one test sample per kept catalogue row, so "
                         f"these flags cannot apply: {'; '.join(given)}; drop them")
