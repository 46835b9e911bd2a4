"""Hindsight oracles over the static methods' own estimates: how much room a selector has.

For run r of a condition, each static method m measured every frame pair (k−1, k) with its own
configuration; its pair error against the ground truth is

    e_k(m) = rotation error + direction error (degrees, ``motion.pair_errors``),   ∞ if the pair was lost,

(and a pair the front-end checks rejected counts as lost). Two oracles choose among the static methods
with the ground truth, then run the same VO as every method (so scale, re-extraction on a switch and the
checks are the same):

- ``oracle-segment``: per segment of the schedule (the whole sequence without one), the static method
  with the least Σ_k e_k over the segment's pairs (a lost pair counts 360°), its configuration per frame;
- ``oracle-pair``: per frame k ≥ 1, the configuration of the static method with the least e_k (frame 0
  takes frame 1's); where every method lost the pair, the best static method's.

Neither is a method: they bound what choosing among these configurations could gain on this sequence.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

from nfex_slam.datasets.base import Frame
from nfex_slam.datasets.schedule import Schedule
from nfex_slam.vo import Choice, Chooser, FrameRecord, VOResult

from ..verification import LOST_PAIR_DEG


def pair_error(f: FrameRecord) -> float:
    """e_k of one frame record (module docstring); ∞ where the pair was lost or has no ground truth."""
    if f.lost or f.errors is None:
        return math.inf
    return f.errors[0] + f.errors[1]


def _choice(f: FrameRecord) -> Choice:
    return Choice(f.extractor, dict(f.params))


def per_pair(runs: Mapping[str, VOResult], fallback: str) -> list[Choice]:
    """oracle-pair's configuration per frame."""
    n = min(len(r.frames) for r in runs.values())
    out: list[Choice] = []
    for k in range(1, n):
        m = min(runs, key=lambda name: (pair_error(runs[name].frames[k]), name))
        if math.isinf(pair_error(runs[m].frames[k])):
            m = fallback
        out.append(_choice(runs[m].frames[k]))
    return [out[0], *out] if out else []


def per_segment(runs: Mapping[str, VOResult], schedule: Schedule | None, fallback: str) -> tuple[list[Choice], dict[str, str]]:
    """oracle-segment's configuration per frame, and the static method it took for each segment."""
    n = min(len(r.frames) for r in runs.values())
    segments = schedule.segments if schedule is not None else None
    spans = [(s.label, s.start, s.end) for s in segments] if segments else [("all", 0, n - 1)]
    choices: list[Choice] = []
    taken: dict[str, str] = {}
    for label, start, end in spans:
        def cost(name: str, start: int = start, end: int = end) -> float:
            errs = [pair_error(runs[name].frames[k]) for k in range(max(1, start), min(end, n - 1) + 1)]
            return sum(LOST_PAIR_DEG if math.isinf(e) else e for e in errs)

        m = min(runs, key=lambda name: (cost(name), name)) if runs else fallback
        taken[label] = m
        choices += [_choice(runs[m].frames[k]) for k in range(start, min(end, n - 1) + 1)]
    return choices, taken


def replay(choices: Sequence[Choice]) -> Chooser:
    """A chooser that answers ``choices[k]`` at frame position k."""
    def choose(frame: Frame, history: list[FrameRecord]) -> Choice:
        return choices[min(len(history), len(choices) - 1)]
    return choose
