"""Output files are written to a temporary file beside them and renamed into place, so an
interrupted or failed write never leaves a truncated file where the previous one was."""

from __future__ import annotations

import contextlib
import os
from pathlib import Path


@contextlib.contextmanager
def atomic_output(path):
    """Yield a temporary path (same directory, same suffix) to write; on success it replaces
    `path`, on an exception it is removed."""
    path = Path(path)
    tmp = path.with_name(f".{path.stem}.tmp-{os.getpid()}{path.suffix}")
    try:
        yield tmp
        os.replace(tmp, path)
    finally:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
