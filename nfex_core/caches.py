"""Files nFEX keeps in a cache folder to start faster (the computed seed, seed_content.py; the compiled rule
table, rules/persisted.py): written whole or not at all, and only the most recently used few kept."""
from __future__ import annotations

import os
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import BinaryIO


def write_atomically(path: Path, write: Callable[[BinaryIO], object], *, folder_mode: int = 0o777) -> None:
    """``write(f)`` into a temporary file beside ``path``, then put it in ``path``'s place in one step: a reader sees the
    old file or the new one, never part of one. Raises OSError; no temporary file is left behind."""
    path.parent.mkdir(mode=folder_mode, parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=path.name, suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            write(f)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def prune(folder: Path, pattern: str, keep: int) -> None:
    """Keep the ``keep`` most recently used files of ``pattern`` (the readers touch what they use), and no temporary
    file of a writer killed an hour ago or more; another process pruning the same folder at once is no error."""
    def mtime(path: Path) -> float:
        try:
            return path.stat().st_mtime
        except OSError:
            return 0.0

    for old in sorted(folder.glob(pattern), key=mtime, reverse=True)[keep:]:
        old.unlink(missing_ok=True)
    for tmp in folder.glob("*.tmp"):
        if time.time() - mtime(tmp) > 3600:
            tmp.unlink(missing_ok=True)
