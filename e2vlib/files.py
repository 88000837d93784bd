"""Crash-safe file writing: write to a temporary file beside the target, then rename.

The lowest layer of e2vlib (imports nothing from it), so every module that writes files
can use it. Introduced in notebooks/01_events.ipynb.
"""

from __future__ import annotations

import os
import re
import uuid
from pathlib import Path

_TMP_PATTERN = r"^\.{name}\.(\d+)\.[0-9a-f]{{8}}\.tmp"


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
    pattern = re.compile(_TMP_PATTERN.format(name=re.escape(path.name)))
    stale = []
    for candidate in path.parent.iterdir():
        match = pattern.match(candidate.name)
        if match and not _pid_alive(int(match.group(1))):
            stale.append(candidate)
    return sorted(stale)


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
        # ending (".txt.gz", ".npz") for libraries that look at it. The file is not
        # created here, so the writer creates it with the usual permissions.
        self.tmp = self.path.parent / (
            f".{self.path.name}.{os.getpid()}.{uuid.uuid4().hex[:8]}.tmp"
            + "".join(self.path.suffixes))
        return self.tmp

    def __exit__(self, exc_type, exc, tb) -> None:
        assert self.tmp is not None
        if exc_type is None:
            os.replace(self.tmp, self.path)
        else:
            self.tmp.unlink(missing_ok=True)
