"""pybullet writes to the C-level stdout/stderr (build banner at import, loader chatter at connect/load).

The CLI's and pytest's output must stay clean, so every pybullet call that can print goes through
:func:`quiet`, which points file descriptors 1 and 2 at /dev/null for the duration of the call, and
the module itself is imported through :func:`pybullet`. This is the only place in ``sim/`` that
touches file descriptors.
"""

from __future__ import annotations

import contextlib
import os
import sys
import threading
from collections.abc import Iterator
from types import ModuleType

_lock = threading.RLock()
_depth = 0
_saved: list[int] = []
_module: ModuleType | None = None


@contextlib.contextmanager
def quiet() -> Iterator[None]:
    """Silence fds 1 and 2 (re-entrant). Python-level output written meanwhile is flushed first."""
    global _depth
    with _lock:
        if _depth == 0:
            for stream in (sys.stdout, sys.stderr):
                with contextlib.suppress(Exception):
                    stream.flush()
            devnull = os.open(os.devnull, os.O_WRONLY)
            try:
                _saved[:] = [os.dup(1), os.dup(2)]
                os.dup2(devnull, 1)
                os.dup2(devnull, 2)
            finally:
                os.close(devnull)
        _depth += 1
        try:
            yield
        finally:
            _depth -= 1
            if _depth == 0:
                for stream in (sys.stdout, sys.stderr):
                    with contextlib.suppress(Exception):
                        stream.flush()
                out, err = _saved
                os.dup2(out, 1)
                os.dup2(err, 2)
                os.close(out)
                os.close(err)
                _saved.clear()


def pybullet() -> ModuleType:
    """The pybullet module, imported without its build-time banner."""
    global _module
    if _module is None:
        with quiet():
            import pybullet as pb

        _module = pb
    return _module
