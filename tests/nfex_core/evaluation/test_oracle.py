"""The hindsight oracles pick, per frame pair or per segment, the static estimate closest to the truth."""
from __future__ import annotations

import math

import numpy as np
from nfex_slam.datasets.schedule import Schedule
from nfex_slam.vo import Choice, FrameRecord, VOResult

from nfex_core.evaluation.oracle import pair_error, per_pair, per_segment, replay


def _run(name: str, errors: list[float | None]) -> VOResult:
    """A static method's run whose pair k has rotation error ``errors[k]`` (None: lost); frame 0 has no pair."""
    frames = [FrameRecord(0, 0.0, name, {"n": 1}, 100, 0, 0, 1.0, 0.0, False)]
    for k, e in enumerate(errors, start=1):
        frames.append(FrameRecord(k, 0.1 * k, name, {"n": 1}, 100, 50, 40, 1.0, 1.0, e is None, "" if e is not None else "lost",
                                  errors=None if e is None else (e, 0.0)))
    return VOResult(np.tile(np.eye(4), (len(frames), 1, 1)), np.arange(len(frames)) * 0.1, frames)


def test_per_pair_takes_the_least_error_and_skips_lost_pairs() -> None:
    runs = {"a": _run("A", [1.0, 50.0, None, 2.0]), "b": _run("B", [3.0, 0.5, 4.0, None])}
    choices = per_pair(runs, fallback="a")
    assert [c.extractor for c in choices] == ["A", "A", "B", "B", "A"]  # frame 0 takes frame 1's choice
    assert math.isinf(pair_error(runs["a"].frames[3]))


def test_where_every_method_lost_the_pair_the_fallback_runs() -> None:
    runs = {"a": _run("A", [None]), "b": _run("B", [None])}
    assert [c.extractor for c in per_pair(runs, fallback="b")] == ["B", "B"]


def test_per_segment_takes_the_least_total_per_segment() -> None:
    runs = {"a": _run("A", [1.0, 1.0, 90.0, 90.0]), "b": _run("B", [2.0, 2.0, 1.0, 1.0])}
    sched = Schedule.parse("none:0-2,dark:3-4", 5)
    choices, taken = per_segment(runs, sched, fallback="a")
    assert taken == {"none:0-2": "a", "dark:3-4": "b"}
    assert [c.extractor for c in choices] == ["A", "A", "A", "B", "B"]
    whole, taken = per_segment(runs, None, fallback="a")
    assert taken == {"all": "b"} and len(whole) == 5


def test_replay_answers_by_frame_position() -> None:
    choose = replay([Choice("A"), Choice("B")])
    assert choose(None, []).extractor == "A" and choose(None, [None]).extractor == "B"  # type: ignore[arg-type,list-item]
    assert choose(None, [None, None, None]).extractor == "B"  # type: ignore[arg-type,list-item]
