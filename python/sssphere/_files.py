"""Output files are written to a temporary file beside them and renamed into place, so an
interrupted or failed write never leaves a truncated file where the previous one was."""

from __future__ import annotations

import contextlib
import itertools
import os
from pathlib import Path

_count = itertools.count()


def missing_input(path: Path, what: str) -> str:
    """Why `path` cannot be read as `what` ("training-data file"), for a path that is not a
    file: "is a directory, not a training-data file" or "training-data file does not
    exist"."""
    return f"is a directory, not a {what}" if path.is_dir() else f"{what} does not exist"


@contextlib.contextmanager
def atomic_output(path):
    """Yield a temporary path (same directory, same suffix) to write; on success it replaces
    `path`, on an exception it is removed."""
    path = Path(path)
    # not built from the name, so that any name the directory takes has room for it
    tmp = path.with_name(f".sss-{os.getpid()}-{next(_count)}{path.suffix}")
    try:
        yield tmp
        with open(tmp, "rb+") as f:  # on the disk before it replaces the previous file
            os.fsync(f.fileno())
        os.replace(tmp, path)
    finally:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
