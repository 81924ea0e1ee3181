"""Whole files written atomically: a reader (or a crash) sees the old file or the new one, never half of one.

The one implementation for everything the project persists as a whole file — the VLM quota state,
report.json and its pictures, GIFs, rendered trees, benchmark results, regenerated docs. The data goes to
a temp file in the target's own directory (so the rename never crosses a file system), is flushed and
fsync'ed, gets the mode a plainly created file would have (or the existing file's mode), and is renamed
over the target with ``os.replace``; the directory is fsync'ed so the rename itself survives a power cut.
Any failure — an exception while writing, a full disk — removes the temp file and leaves the target as
it was. Append-only logs (JSON lines) are not written this way: their readers skip a torn last line.

Outputs a long run writes at its end are checked at its start: :func:`ensure_dir` / :func:`ensure_parent`
create where they go, and :func:`unwritable` says in words why a path cannot be written.
"""

from __future__ import annotations

import contextlib
import errno
import os
import shutil
import stat
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path

__all__ = ["atomic_path", "atomic_write_bytes", "atomic_write_text", "ensure_dir", "ensure_parent", "unwritable"]


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


def _no_file_in_the_way(directory: Path) -> None:
    """NotADirectoryError naming `directory` or its first ancestor that is a file (mkdir would say
    "File exists", which misleads)."""
    for p in (directory, *directory.parents):
        if p.exists() and not p.is_dir():
            raise NotADirectoryError(errno.ENOTDIR, os.strerror(errno.ENOTDIR), str(p))


def ensure_parent(path: str | Path) -> Path:
    """Create `path`'s directory (and its parents); OSError says which parent is a file, if one is."""
    parent = Path(path).parent
    _no_file_in_the_way(parent)
    parent.mkdir(parents=True, exist_ok=True)
    return parent


def ensure_dir(path: str | Path) -> Path:
    """Create directory `path` (and its parents) and check that files can be created in it, before anything
    slow starts (a probe file is made and removed: permissions, a read-only file system). OSError otherwise;
    a NotADirectoryError's filename is `path` or the ancestor that is a file."""
    path = Path(path)
    _no_file_in_the_way(path)
    path.mkdir(parents=True, exist_ok=True)
    try:
        with tempfile.TemporaryFile(dir=path, prefix=".write-probe."):
            pass
    except OSError as err:  # name the directory, not the probe
        raise type(err)(err.errno, err.strerror, str(path)) from None
    return path


def unwritable(err: OSError, path: str | Path, *, directory: bool = False) -> str:
    """Why `path` (a directory when `directory`, else a file) cannot be written, from the OSError that
    :func:`ensure_dir`, :func:`ensure_parent` or opening it raised, in words naming the culprit:
    ``expected a directory, but it is a file`` / ``cannot create it: out is a file, not a directory`` /
    ``expected a file, but it is a directory`` / ``cannot write (Permission denied)``."""
    path = Path(path)
    culprit = Path(err.filename) if isinstance(err.filename, str) else None
    if isinstance(err, NotADirectoryError) and culprit is not None and culprit.is_file():
        if culprit == path:
            return "expected a directory, but it is a file"
        return f"cannot create it: {culprit} is a file, not a directory"
    if isinstance(err, IsADirectoryError) or (not directory and path.is_dir()):
        return "expected a file, but it is a directory"
    where = "" if culprit in (None, path) else f": {culprit}"
    return f"cannot write ({err.strerror or err}{where})"


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temp path (same directory, same suffix) to write `path`'s new content to; renamed into place
    when the block ends without an exception, deleted when it raises.

    For writers that want a file name rather than bytes (``fig.savefig(tmp)``, ``image.save(tmp)``)::

        with atomic_path(out / "trajectory.png") as tmp:
            fig.savefig(tmp)
    """
    path = Path(path)
    if _special(path):  # a device, a FIFO, /dev/stdout: written through, never renamed over
        yield from _through(path)
        return
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


def _special(path: Path) -> bool:
    """Whether `path` exists and is not a regular file (after symlinks): a character device, a FIFO."""
    try:
        return not stat.S_ISREG(path.stat().st_mode) and not path.is_dir()
    except OSError:
        return False


def _through(path: Path) -> Iterator[Path]:
    """For a special file: the writer writes a temp file elsewhere, which is then copied into `path` (a rename
    would replace the device itself — as root, /dev/full or /dev/stdout — with a regular file)."""
    fd, name = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=f".tmp{path.suffix}")
    os.close(fd)
    tmp = Path(name)
    try:
        yield tmp
        with open(tmp, "rb") as src, open(path, "wb") as dst:
            shutil.copyfileobj(src, dst)
    finally:
        tmp.unlink(missing_ok=True)


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    """Replace `path` with `data` atomically (parents created); returns the path."""
    path = Path(path)
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        fh.write(data)
    return path


def atomic_write_text(path: str | Path, text: str, encoding: str = "utf-8") -> Path:
    """Replace `path` with `text` atomically (parents created); returns the path."""
    return atomic_write_bytes(path, text.encode(encoding))


class StreamedFile:
    """An output file written while the run goes on (a tick log, a .btlog), so it cannot be written atomically.

    A write that fails — the disk is full, the device is gone — must not stop the run or leave half a file that
    looks whole: the file is closed and removed, and :attr:`failure` says once, naming the option and the file,
    what happened, and `warn` is given it once. Later writes are ignored."""

    def __init__(
        self, path: Path, option: str, binary: bool = False, warn: Callable[[str], None] = lambda message: None
    ) -> None:
        from mission.core.errors import MissionError

        self.path = path
        self.option = option
        self.warn = warn
        self.failure = ""
        self.writes = 0
        try:
            ensure_parent(path)
            self._fh = path.open("wb") if binary else path.open("w", encoding="utf-8")
        except OSError as err:
            raise MissionError(f"{option} {path}: {unwritable(err, path)}") from None

    def write(self, data: str | bytes) -> bool:
        """Write and flush; False (and :attr:`failure` set) when it could not be, now or before."""
        if self._fh is None:
            return False
        try:
            self._fh.write(data)  # type: ignore[arg-type]
            self._fh.flush()
        except OSError as err:
            self._give_up(err)
            return False
        self.writes += 1
        return True

    def _give_up(self, err: OSError) -> None:
        with contextlib.suppress(OSError):
            self._fh.close()  # type: ignore[union-attr]
        self._fh = None
        removed = ""
        if self.path.is_file():  # not a device: what was written is removed, not left looking complete
            with contextlib.suppress(OSError):
                self.path.unlink()
                removed = " and removed"
        self.failure = (
            f"{self.option} {self.path}: cannot write ({err.strerror or err}) after {self.writes} writes: "
            f"stopped{removed}; the run goes on"
        )
        self.warn(self.failure)

    def close(self) -> None:
        if self._fh is not None:
            try:
                self._fh.close()
            except OSError as err:
                self._give_up(err)
            self._fh = None
