"""Condition schedules: parsing names what is wrong; frames take their segment's corruption and labels."""
from __future__ import annotations

import numpy as np
import pytest
from nfex_slam.datasets.corruptions import corrupt
from nfex_slam.datasets.schedule import Schedule, apply_schedule
from nfex_slam.datasets.synthetic import make_sequence

from nfex_core.errors import BadInput

TEXT = "none:0-12,dark:13-25,motion_blur:26-38,overexposed:39-50"


def test_the_issue_schedule_parses_with_its_transitions() -> None:
    s = Schedule.parse(TEXT, 51)
    assert [x.corruption for x in s.segments] == ["none", "dark", "motion_blur", "overexposed"]
    assert s.transitions == [13, 26, 39] and s.transition_name(26) == "dark→motion_blur"
    assert s.segment_of(25).corruption == "dark" and s.text == TEXT


@pytest.mark.parametrize(("text", "says"), [
    ("none:0-12,dark:14-50", "frames 13-13 uncovered"),
    ("none:0-12,dark:10-50", "covers frames 10-12 twice"),
    ("none:0-40", "frames 41-50 uncovered"),
    ("none:0-60", "runs to frame 60 but the sequence has 51 frames"),
    ("none:5-50", "frames 0-4 uncovered"),
    ("fog:0-50", "unknown corruption 'fog'"),
    ("dark:20-10", "end 10 is before its start 20"),
    ("dark 0-50", "not CORRUPTION:START-END"),
    ("", "empty"),
])
def test_a_bad_schedule_names_what_is_wrong(text: str, says: str) -> None:
    with pytest.raises(BadInput, match=says):
        Schedule.parse(text, 51)


def test_frames_take_their_segments_corruption_and_labels() -> None:
    seq = make_sequence(6, width=96, height=64)
    sched = Schedule.parse("none:0-1,dark:2-3,overexposed:4-5", len(seq))
    scheduled = apply_schedule(seq, sched, 0.7, seed=3)
    dark = corrupt(seq, "dark", 0.7, seed=3)
    assert np.array_equal(scheduled[0].image, seq[0].image) and "light" not in scheduled[0].context
    assert np.array_equal(scheduled[2].image, dark[2].image) and scheduled[2].context["light"] == "dark"
    assert scheduled[5].context["light"] == "bright"
    with pytest.raises(BadInput, match="was made for 6 frames"):
        apply_schedule(seq[:4], sched, 0.7)


def test_under_is_the_one_dispatch_of_none_corruption_and_schedule() -> None:
    """The sweeps, evaluate and the neural training's frames all call ``under``: each condition gives what its
    own function gives, frame for frame."""
    from nfex_slam.datasets.schedule import SCHEDULE, under

    seq = make_sequence(6, width=96, height=64)
    assert under(seq, "none", 0.7, 3) is seq and under(seq, "", 0.7, 3) is seq
    np.testing.assert_array_equal(under(seq, "dark", 0.7, 3)[2].image, corrupt(seq, "dark", 0.7, seed=3)[2].image)
    text = "none:0-2,dark:3-5"
    from_text, from_parsed = under(seq, SCHEDULE, 0.7, 3, text), apply_schedule(seq, Schedule.parse(text, 6), 0.7, seed=3)
    for i in range(6):
        np.testing.assert_array_equal(from_text[i].image, from_parsed[i].image)
    with pytest.raises(BadInput, match="needs a schedule"):
        under(seq, SCHEDULE, 0.7)
