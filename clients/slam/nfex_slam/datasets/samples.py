"""A few frames of each sequence in the data folder, for trying a selection by hand (the workbench).

Each sequence found under ``<data>/<format>/`` (KITTI's ``sequences/NN``, EuRoC's and the handheld
set's sequence folders) gives ``per_sequence`` frames spread over it, with the context its loader
knows (a KITTI sequence: agent car, scene outdoor). Frames are listed by an id, never by a path, so a
caller can only read what this function found.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from ..errors import NfexError
from . import open_sequence
from .frames import ImageSequence


@dataclass(frozen=True)
class Sample:
    id: str  # "<format>-<sequence>-<frame index>"
    dataset: str
    sequence: str
    index: int
    path: Path
    context: dict[str, str] = field(default_factory=dict)

    def as_dict(self) -> dict[str, object]:
        return {"id": self.id, "dataset": self.dataset, "sequence": self.sequence, "index": self.index,
                "file": self.path.name, "context": dict(self.context)}


def _sequences(data: Path) -> list[tuple[str, Path, str]]:
    """(format, dataset folder, sequence name) for every sequence folder in ``data``."""
    found: list[tuple[str, Path, str]] = []
    kitti = data / "kitti" / "sequences"
    if kitti.is_dir():
        found += [("kitti", data / "kitti", p.name) for p in sorted(kitti.iterdir()) if p.is_dir()]
    for fmt in ("euroc", "handheld", "tum"):
        root = data / fmt
        if root.is_dir():
            found += [(fmt, root, p.name) for p in sorted(root.iterdir()) if p.is_dir()]
    return found


def samples(data: Path, per_sequence: int = 3) -> list[Sample]:
    """Frames spread over each readable sequence of ``data`` (first, middle, last for 3); unreadable
    sequences are skipped."""
    out: list[Sample] = []
    for fmt, root, name in _sequences(data):
        try:
            seq = open_sequence(root, fmt, name)
        except (NfexError, OSError, ValueError):
            continue
        if not isinstance(seq, ImageSequence) or len(seq) == 0:
            continue
        paths = seq.paths
        n = len(paths)
        picks = sorted({round(i * (n - 1) / max(1, per_sequence - 1)) for i in range(per_sequence)})
        out += [Sample(f"{fmt}-{name}-{i}", fmt, name, i, paths[i], dict(seq.context)) for i in picks]
    return out
