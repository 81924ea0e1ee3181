"""Whole files written atomically: a reader (or a crash) sees the old file or the new one, never half of one.

The one implementation for everything the project persists as a whole file — the VLM quota state,
report.json and its pictures, GIFs, rendered trees, benchmark results, regenerated docs. The data goes to
a temp file in the target's own directory (so the rename never crosses a file system), is flushed and
fsync'ed, gets the mode a plainly created file would have (or the existing file's mode), and is renamed
over the target with ``os.replace``; the directory is fsync'ed so the rename itself survives a power cut.
Any failure — an exception while writing, a full disk — removes the temp file and leaves the target as
it was. Append-only logs (JSON lines) are not written this way: their readers skip a torn last line.
"""

from __future__ import annotations

import contextlib
import errno
import os
import stat
import tempfile
from collections.abc import Iterator
from pathlib import Path

__all__ = ["atomic_path", "atomic_write_bytes", "atomic_write_text", "ensure_parent"]


def _umask() -> int:
    """The process umask, read without changing it where /proc allows (os.umask alone must set it)."""
    with contextlib.suppress(OSError, ValueError):
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _fsync_dir(directory: Path) -> None:
    with contextlib.suppress(OSError):  # not every file system lets a directory be opened and synced
        fd = os.open(directory, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def ensure_parent(path: str | Path) -> Path:
    """Create `path`'s directory (and its parents); OSError says which parent is a file, if one is."""
    parent = Path(path).parent
    for p in (parent, *parent.parents):
        if p.exists() and not p.is_dir():  # mkdir would say "File exists", which misleads
            raise NotADirectoryError(errno.ENOTDIR, os.strerror(errno.ENOTDIR), str(p))
    parent.mkdir(parents=True, exist_ok=True)
    return parent


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temp path (same directory, same suffix) to write `path`'s new content to; renamed into place
    when the block ends without an exception, deleted when it raises.

    For writers that want a file name rather than bytes (``fig.savefig(tmp)``, ``image.save(tmp)``)::

        with atomic_path(out / "trajectory.png") as tmp:
            fig.savefig(tmp)
    """
    path = Path(path)
    ensure_parent(path)
    fd, name = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem}.", suffix=f".tmp{path.suffix}")
    os.close(fd)
    tmp = Path(name)
    try:
        yield tmp
        try:
            mode = stat.S_IMODE(path.stat().st_mode)  # replacing a file keeps its permissions
        except FileNotFoundError:
            mode = 0o666 & ~_umask()  # a new file: what open() would have made (mkstemp makes 0600)
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        os.chmod(tmp, mode)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    _fsync_dir(path.parent)


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    """Replace `path` with `data` atomically (parents created); returns the path."""
    path = Path(path)
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        fh.write(data)
    return path


def atomic_write_text(path: str | Path, text: str, encoding: str = "utf-8") -> Path:
    """Replace `path` with `text` atomically (parents created); returns the path."""
    return atomic_write_bytes(path, text.encode(encoding))
