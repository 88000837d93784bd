"""Crash-safe file writing: write to a temporary file beside the target, then rename.

The lowest layer of e2vlib (imports nothing from it), so every module that writes files
can use it. Introduced in notebooks/01_events.ipynb.
"""

from __future__ import annotations

import errno
import os
import re
import stat
import uuid
from pathlib import Path

_TMP_PATTERN = r"^\.{name}\.(\d+)\.[0-9a-f]{{8}}\.tmp"

NAME_MAX = 255
"""The longest file name, in bytes, that common file systems take (ext4, APFS, NTFS). A
temporary name of :class:`atomic_path` that would be longer names the target by a digest."""


def _temp_parts(path: Path) -> tuple[str, str]:
    """``(stem, ending)`` of the temporary names of ``path``: its own name and full ending
    when ``.{name}.{pid}.{8 hex}.tmp{ending}`` fits :data:`NAME_MAX` for any pid, else the
    first 16 hex digits of the name's sha256 and its last ending (at most 16 characters)."""
    import hashlib

    ending = "".join(path.suffixes)
    if len(f".{path.name}.{'9' * 10}.{'f' * 8}.tmp{ending}".encode()) <= NAME_MAX:
        return path.name, ending
    suffix = path.suffix if len(path.suffix) <= 16 else ""
    return hashlib.sha256(path.name.encode()).hexdigest()[:16], suffix


def _pid_alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # alive, owned by someone else
        return True
    return True


def stale_temp_files(path: str | os.PathLike) -> list[Path]:
    """Temporary files that :class:`atomic_path` left beside ``path`` in a killed process.

    A temporary file is stale when the process that made it (its pid is in the name) no
    longer runs. Returns them sorted by name.

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> _ = (folder / ".a.npz.999999999.0123abcd.tmp.npz").write_bytes(b"partial")
    >>> [p.name for p in stale_temp_files(folder / "a.npz")]
    ['.a.npz.999999999.0123abcd.tmp.npz']
    """
    path = Path(path)
    if not path.parent.is_dir():
        return []
    pattern = re.compile(_TMP_PATTERN.format(name=re.escape(_temp_parts(path)[0])))
    stale = []
    for candidate in path.parent.iterdir():
        match = pattern.match(candidate.name)
        if match and not _pid_alive(int(match.group(1))):
            stale.append(candidate)
    return sorted(stale)


def kind_of_file(mode: int) -> str:
    """What a non-regular file is, in words, from its ``st_mode``: ``"a FIFO (named pipe)"``,
    ``"a character device"``, ``"a block device"``, ``"a socket"``."""
    for test, words in ((stat.S_ISFIFO, "a FIFO (named pipe)"),
                        (stat.S_ISCHR, "a character device"),
                        (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return words
    return "not a regular file"


def input_file(path: str | os.PathLike, what: str) -> Path:
    """``path`` as a Path if it is a regular file (or a link to one), else an error that
    says what it is instead, naming ``what`` (``"mesh file"``, ``"checkpoint"``...).

    FileNotFoundError for a missing path or a link to nothing, IsADirectoryError for a
    folder, ValueError for a FIFO, a device, a socket or a symlink loop: reading those
    would block, never end, or fail with a misleading "not found".

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> input_file(folder, "mesh file")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    IsADirectoryError: mesh file ... is a directory, not a file; give a file inside it
    >>> input_file("/dev/zero", "event file")
    Traceback (most recent call last):
    ...
    ValueError: event file /dev/zero is a character device, not a regular file; give a file
    """
    path = Path(path)
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        broken = " (a symbolic link to nothing)" if path.is_symlink() else ""
        raise FileNotFoundError(f"{what} {path} does not exist{broken}; check the path") from None
    except OSError as err:
        if err.errno == errno.ELOOP:
            raise ValueError(f"{what} {path} is a symbolic link loop, not a file; point the "
                             "link at a file") from None
        raise
    if stat.S_ISDIR(mode):
        raise IsADirectoryError(f"{what} {path} is a directory, not a file; give a file "
                                "inside it")
    if not stat.S_ISREG(mode):
        raise ValueError(f"{what} {path} is {kind_of_file(mode)}, not a regular file; give a file")
    return path


def read_bounded(path: str | os.PathLike, what: str, limit: int) -> bytes:
    """The bytes of the regular file ``path`` (:func:`input_file`), refused with a
    ValueError naming ``what`` and the file when it holds more than ``limit`` bytes; at most
    ``limit + 1`` bytes are ever read, so a file that grows while read is refused too.

    Examples
    --------
    >>> import tempfile
    >>> path = Path(tempfile.mkdtemp()) / "r.json"
    >>> _ = path.write_text("{}")
    >>> read_bounded(path, "results file", 10)
    b'{}'
    >>> read_bounded(path, "results file", 1)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: results file .../r.json is 2 bytes, more than the 1 bytes such a file can be; \
is it the right file?
    """
    path = input_file(path, what)
    # opened without blocking and checked again: a FIFO swapped in after the check above
    # would otherwise hang the open
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    with os.fdopen(fd, "rb") as f:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            raise ValueError(f"{what} {path} is not a regular file; give a file")
        data = f.read(limit + 1)
    if len(data) > limit:
        size = max(len(data), os.stat(path).st_size)
        raise ValueError(f"{what} {path} is {size} bytes, more than the {limit} bytes such a "
                         "file can be; is it the right file?")
    return data


class atomic_path:  # noqa: N801  (used like a function: ``with atomic_path(p) as tmp``)
    """Context manager yielding a temporary path next to ``path``; renamed on success.

    On an exception the temporary file is removed and ``path`` is left as it was. Entering
    also removes stale temporary files of the same target left by a killed earlier run
    (see :func:`stale_temp_files`). An existing directory at ``path`` is refused before
    anything is written.

    Examples
    --------
    >>> import tempfile
    >>> target = Path(tempfile.mkdtemp()) / "note.txt"
    >>> with atomic_path(target) as tmp:
    ...     _ = tmp.write_text("hello")
    >>> target.read_text()
    'hello'
    """

    def __init__(self, path: str | os.PathLike):
        self.path = Path(path)
        self.tmp: Path | None = None

    def __enter__(self) -> Path:
        if self.path.is_dir():
            raise IsADirectoryError(
                f"{self.path} is a directory; give a file name (for example "
                f"{self.path / ('out' + ''.join(self.path.suffixes))})")
        for stale in stale_temp_files(self.path):
            stale.unlink(missing_ok=True)
        # A unique name in the same folder (so the rename is atomic), keeping the full
        # ending (".txt.gz", ".npz") for libraries that look at it; a name too long for
        # that is replaced by its digest (_temp_parts). The file is not created here, so
        # the writer creates it with the usual permissions.
        stem, ending = _temp_parts(self.path)
        self.tmp = self.path.parent / f".{stem}.{os.getpid()}.{uuid.uuid4().hex[:8]}.tmp{ending}"
        return self.tmp

    def __exit__(self, exc_type, exc, tb) -> None:
        assert self.tmp is not None
        if exc_type is None:
            os.replace(self.tmp, self.path)
        else:
            self.tmp.unlink(missing_ok=True)
