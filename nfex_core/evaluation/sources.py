"""Which sequences an evaluation runs on: a data folder with ``--sequence`` ids, and/or a manifest.

A manifest is a TOML file with one ``[[sequence]]`` table per sequence, for sequences of several datasets in
one command (each with its own format and frame step):

```toml
[[sequence]]
path = "kitti"            # relative to the data folder ($NFEX_DATA), or absolute
sequence = "07"           # format defaults to kitti, step to 1

[[sequence]]
path = "handheld"
format = "handheld"
sequence = "checkerboard"
step = 4                  # every 4th frame of the 30 Hz video
```
"""
from __future__ import annotations

import tomllib
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from ..errors import BadInput

if TYPE_CHECKING:
    from nfex_slam.datasets.base import Sequence

_KEYS = {"path", "format", "sequence", "step"}


@dataclass(frozen=True)
class Source:
    path: Path
    format: str = "kitti"
    sequence: str | None = None
    step: int = 1

    def open(self) -> Sequence:
        """The sequence, every ``step``-th frame; BadInput where it has no ground truth."""
        from nfex_slam.datasets import open_sequence

        seq = open_sequence(self.path, self.format, self.sequence)
        if self.step > 1:
            seq = seq[:: self.step]
        if seq.poses is None:
            raise BadInput(f"{self.path} {self.sequence or ''}: the sequence has no ground truth; ATE needs it".replace("  ", " "))
        return seq


def from_arguments(path: Path | None, format: str, sequences: Iterable[str], step: int) -> list[Source]:  # noqa: A002
    """One source per ``--sequence`` id of ``path`` (the folder itself where none is given)."""
    if path is None:
        return []
    ids = list(sequences)
    return [Source(path, format, s, step) for s in ids] if ids else [Source(path, format, None, step)]


def read_manifest(manifest: Path, data: Path) -> list[Source]:
    """The sources of a manifest (module docstring); BadInput names what is wrong."""
    try:
        doc = tomllib.loads(manifest.read_text())
    except OSError as e:
        raise BadInput(f"{manifest}: cannot read the manifest ({e.strerror})") from e
    except tomllib.TOMLDecodeError as e:
        raise BadInput(f"{manifest}: not TOML ({e})") from e
    entries = doc.get("sequence")
    if not isinstance(entries, list) or not entries:
        raise BadInput(f"{manifest}: no [[sequence]] tables")
    out = []
    for i, entry in enumerate(entries, start=1):
        unknown = set(entry) - _KEYS
        if unknown or "path" not in entry:
            raise BadInput(f"{manifest}: sequence {i} needs a path and takes only {', '.join(sorted(_KEYS))}"
                           + (f" (unknown: {', '.join(sorted(unknown))})" if unknown else ""))
        step = entry.get("step", 1)
        if not isinstance(step, int) or step < 1:
            raise BadInput(f"{manifest}: sequence {i}: step must be a whole number ≥ 1")
        p = Path(str(entry["path"]))
        out.append(Source(p if p.is_absolute() else data / p, str(entry.get("format", "kitti")),
                          None if entry.get("sequence") is None else str(entry["sequence"]), step))
    return out
