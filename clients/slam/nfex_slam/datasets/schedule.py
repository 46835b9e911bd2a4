"""Condition schedules: conditions that change along a sequence, where adaptation has to pay.

A schedule names a corruption (``datasets.corruptions``, or ``none``) per range of frame positions:

    none:0-12,dark:13-25,motion_blur:26-38,overexposed:39-50

Ranges are inclusive, given in the positions of the sequence as evaluated (after ``--step``/``--frames``),
and must cover it exactly: a gap, an overlap or a range past the end is an error that names it. Each
frame is corrupted by its segment's corruption, seeded as ``corrupt`` seeds it (the same frame and seed
give the same image whatever the schedule), and carries that segment's context labels. The pairs
(k−1, k) where k starts a segment straddle a change of conditions: ``Schedule.transitions``.

A segment may carry its own severity: ``dark:13-25@0.5`` is constant, ``dark:13-25@0.2-0.9`` ramps
linearly over the segment's frames, s_i = a + (b − a)·(i − start)/(end − start) (a tunnel darkens over
seconds, not between two frames); without ``@`` the segment takes the schedule's severity (``--severity``).
Frame i of a ramped segment is the image the whole sequence corrupted at s_i gives there; a frame at
s = 0 is unchanged and unlabelled. Ramps into and out of a condition are segments of their own:
``none:0-9,dark:10-19@0-0.8,dark:20-29@0.8,dark:30-39@0.8-0``.

>>> s = Schedule.parse("none:0-1,dark:2-3", frames=4)
>>> [seg.corruption for seg in s.segments], s.transitions
(['none', 'dark'], [2])
>>> r = Schedule.parse("none:0-1,dark:2-6@0.2-0.6", frames=7)
>>> [round(r.severity_at(i, 0.7), 2) for i in range(7)], r.text
([0.0, 0.0, 0.2, 0.3, 0.4, 0.5, 0.6], 'none:0-1,dark:2-6@0.2-0.6')
"""
from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from ..errors import BadInput
from .base import Frame, Sequence
from .corruptions import LABELS, NAMES, CorruptedSequence

_NUM = r"(\d+(?:\.\d*)?|\.\d+)"
_SEGMENT = re.compile(rf"^\s*([A-Za-z_]+)\s*:\s*(\d+)\s*-\s*(\d+)\s*(?:@\s*{_NUM}\s*(?:-\s*{_NUM})?)?\s*$")


@dataclass(frozen=True)
class Segment:
    corruption: str  # a corruption name or "none"
    start: int
    end: int  # inclusive
    severity: tuple[float, float] | None = None  # (first frame's, last frame's); None: the schedule's severity

    @property
    def label(self) -> str:
        return f"{self.corruption}:{self.start}-{self.end}" + self._severity_text()

    def _severity_text(self) -> str:
        if self.severity is None:
            return ""
        a, b = self.severity
        return f"@{a:g}" if a == b else f"@{a:g}-{b:g}"

    @property
    def ramped(self) -> bool:
        return self.severity is not None and self.severity[0] != self.severity[1]

    def severity_at(self, i: int, default: float) -> float:
        """s_i of frame ``i`` in this segment (module docstring); 0 for ``none``."""
        if self.corruption == "none":
            return 0.0
        if self.severity is None:
            return float(default)
        a, b = self.severity
        return a if self.end == self.start else a + (b - a) * (i - self.start) / (self.end - self.start)

    def __contains__(self, i: object) -> bool:
        return isinstance(i, int) and self.start <= i <= self.end


@dataclass(frozen=True)
class Schedule:
    segments: tuple[Segment, ...]

    @classmethod
    def parse(cls, text: str, frames: int) -> Schedule:
        """The schedule ``text`` for a sequence of ``frames`` positions; BadInput names what is wrong."""
        segments: list[Segment] = []
        for part in filter(None, (p.strip() for p in text.split(","))):
            m = _SEGMENT.match(part)
            if m is None:
                raise BadInput(f"schedule segment {part!r} is not CORRUPTION:START-END[@S or @S0-S1] "
                               "(e.g. dark:13-25, dark:13-25@0.5, dark:13-25@0.2-0.9)")
            name, a, b = m.group(1), int(m.group(2)), int(m.group(3))
            if name != "none" and name not in LABELS:
                raise BadInput(f"schedule segment {part!r}: unknown corruption {name!r}; known: none, {', '.join(NAMES)}")
            if b < a:
                raise BadInput(f"schedule segment {part!r}: its end {b} is before its start {a}")
            severity = None
            if m.group(4) is not None:
                if name == "none":
                    raise BadInput(f"schedule segment {part!r}: 'none' has no severity")
                s0 = float(m.group(4))
                s1 = float(m.group(5)) if m.group(5) is not None else s0
                if not (0.0 <= s0 <= 1.0 and 0.0 <= s1 <= 1.0):
                    raise BadInput(f"schedule segment {part!r}: a severity must lie in [0, 1]")
                severity = (s0, s1)
            segments.append(Segment(name, a, b, severity))
        if not segments:
            raise BadInput("the schedule is empty; give CORRUPTION:START-END segments separated by commas")
        segments.sort(key=lambda s: s.start)
        expected = 0
        for s in segments:
            if s.start > expected:
                raise BadInput(f"the schedule leaves frames {expected}-{s.start - 1} uncovered (gap before {s.label})")
            if s.start < expected:
                raise BadInput(f"the schedule covers frames {s.start}-{min(s.end, expected - 1)} twice ({s.label} overlaps)")
            expected = s.end + 1
        if expected < frames:
            raise BadInput(f"the schedule leaves frames {expected}-{frames - 1} uncovered (the sequence has {frames} frames)")
        if expected > frames:
            raise BadInput(f"the schedule runs to frame {expected - 1} but the sequence has {frames} frames (0-{frames - 1})")
        return cls(tuple(segments))

    @property
    def text(self) -> str:
        return ",".join(s.label for s in self.segments)

    def segment_of(self, i: int) -> Segment:
        for s in self.segments:
            if i in s:
                return s
        raise IndexError(f"frame {i} is outside the schedule {self.text}")

    @property
    def transitions(self) -> list[int]:
        """The positions k (> 0) that start a segment: the pair (k−1, k) straddles a change of conditions."""
        return [s.start for s in self.segments[1:]]

    def transition_name(self, k: int) -> str:
        return f"{self.segment_of(k - 1).corruption}→{self.segment_of(k).corruption}"

    def severity_at(self, i: int, default: float) -> float:
        """The severity of frame ``i``: its segment's (ramped or constant), else ``default``."""
        return self.segment_of(i).severity_at(i, default)

    @property
    def ramps(self) -> bool:
        """Whether any segment's severity changes along it."""
        return any(s.ramped for s in self.segments)


class ScheduledSequence(Sequence):
    """``base`` with each frame corrupted by its segment's corruption at its severity — the segment's own,
    ramped or constant, else ``severity`` (module docstring)."""

    def __init__(self, base: Sequence, schedule: Schedule, severity: float, seed: int = 0) -> None:
        self.base = base
        self.schedule = schedule
        self.severity = float(severity)
        self.seed = int(seed)
        self.dataset, self.name = base.dataset, base.name
        self.intrinsics, self.context = base.intrinsics, dict(base.context)
        # one lazily corrupted view per corruption, over the whole base (motion blur sees true neighbours)
        self._views: dict[str, CorruptedSequence] = {
            c: CorruptedSequence(base, c, severity, seed) for c in {s.corruption for s in schedule.segments} if c != "none"
        }

    def __len__(self) -> int:
        return len(self.base)

    def __getitem__(self, i):
        if isinstance(i, slice):
            raise BadInput("slice the sequence before applying a schedule (the schedule's ranges are its positions)")
        seg = self.schedule.segment_of(int(i))
        if seg.corruption not in self._views:
            return self.base[int(i)]
        frame: Frame = self._views[seg.corruption].at(int(i), seg.severity_at(int(i), self.severity))
        return frame

    @property
    def timestamps(self) -> np.ndarray:
        return self.base.timestamps

    @property
    def poses(self) -> np.ndarray | None:
        return self.base.poses


def apply_schedule(seq: Sequence, schedule: Schedule, severity: float, seed: int = 0) -> Sequence:
    """``seq`` under ``schedule`` (its length must be what the schedule was parsed for)."""
    if schedule.segments[-1].end != len(seq) - 1:
        raise BadInput(f"the schedule {schedule.text} was made for {schedule.segments[-1].end + 1} frames, "
                       f"the sequence has {len(seq)}")
    if not 0.0 <= float(severity) <= 1.0:
        raise BadInput(f"corruption severity must lie in [0, 1], got {severity}")
    return ScheduledSequence(seq, schedule, severity, seed)


SCHEDULE = "schedule"  # the condition name of a scheduled sequence (sweep tables, evaluate's conditions)


def under(seq: Sequence, condition: str, severity: float, seed: int = 0, schedule: Schedule | str | None = None) -> Sequence:
    """``seq`` under one condition: ``none`` (itself), a corruption name (``corrupt``), or ``schedule`` with the
    schedule (text is parsed for ``seq``'s length). The one dispatch the sweeps, ``nfex evaluate`` and the
    neural training's frames share, so the three see the same images."""
    if condition == SCHEDULE:
        if schedule is None:
            raise BadInput("the condition 'schedule' needs a schedule")
        parsed = Schedule.parse(schedule, len(seq)) if isinstance(schedule, str) else schedule
        return apply_schedule(seq, parsed, severity, seed=seed)
    if condition in ("", "none"):
        return seq
    from .corruptions import corrupt

    return corrupt(seq, condition, severity, seed=seed)
