"""Condition schedules: parsing names what is wrong; frames take their segment's corruption and labels."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
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


def test_a_segment_takes_a_constant_or_ramped_severity_and_none_keeps_the_default() -> None:
    s = Schedule.parse("none:0-12,dark:13-25@0.2-0.9,motion_blur:26-38@0.5,overexposed:39-50", 51)
    assert s.text == "none:0-12,dark:13-25@0.2-0.9,motion_blur:26-38@0.5,overexposed:39-50" and s.ramps
    assert s.severity_at(13, 0.7) == pytest.approx(0.2) and s.severity_at(25, 0.7) == pytest.approx(0.9)
    assert s.severity_at(19, 0.7) == pytest.approx(0.55)
    assert {s.severity_at(i, 0.7) for i in range(26, 39)} == {0.5}
    assert s.severity_at(45, 0.7) == 0.7 and s.severity_at(3, 0.7) == 0.0
    assert s.transitions == [13, 26, 39] and not Schedule.parse(TEXT, 51).ramps


@settings(max_examples=50, deadline=None)
@given(start=st.integers(0, 30), length=st.integers(0, 30), a=st.floats(0, 1), b=st.floats(0, 1))
def test_a_ramp_runs_from_its_first_to_its_last_severity_monotonically(start: int, length: int, a: float, b: float) -> None:
    end = start + length
    text = (f"none:0-{start - 1}," if start else "") + f"dark:{start}-{end}@{a:.6f}-{b:.6f}"
    s = Schedule.parse(text, end + 1)
    values = [s.severity_at(i, 0.7) for i in range(start, end + 1)]
    assert values[0] == pytest.approx(a, abs=1e-6) and (length == 0 or values[-1] == pytest.approx(b, abs=1e-6))
    assert all(min(a, b) - 1e-6 <= v <= max(a, b) + 1e-6 for v in values)
    steps = np.diff(values)
    assert np.all(steps >= -1e-12) or np.all(steps <= 1e-12)


@pytest.mark.parametrize(("text", "says"), [
    ("none:0-12,dark:13-50@1.2", "severity must lie in"),
    ("none:0-12@0.5,dark:13-50", "'none' has no severity"),
    ("none:0-12,dark:14-50@0.2-0.9", "frames 13-13 uncovered"),
    ("none:0-12,dark:10-50@0.5", "covers frames 10-12 twice"),
    ("none:0-12,dark:13-50@0.2-", "not CORRUPTION:START-END"),
])
def test_a_bad_ramp_names_what_is_wrong(text: str, says: str) -> None:
    with pytest.raises(BadInput, match=says):
        Schedule.parse(text, 51)


@pytest.mark.parametrize("name", ["dark", "overexposed", "motion_blur", "low_texture", "glare"])
def test_a_ramped_frame_is_the_frame_of_the_sequence_corrupted_at_its_severity(name: str) -> None:
    seq = make_sequence(7, width=96, height=64)
    sched = Schedule.parse(f"none:0-1,{name}:2-6@0.2-0.6", len(seq))
    scheduled = apply_schedule(seq, sched, 0.9, seed=4)
    for i, s in ((2, 0.2), (4, 0.4), (6, 0.6)):
        np.testing.assert_array_equal(scheduled[i].image, corrupt(seq, name, s, seed=4)[i].image)
    assert scheduled[3].context == corrupt(seq, name, 0.3, seed=4)[3].context
    ramp_from_zero = apply_schedule(seq, Schedule.parse(f"none:0-1,{name}:2-6@0-0.8", len(seq)), 0.9, seed=4)
    np.testing.assert_array_equal(ramp_from_zero[2].image, seq[2].image)
    assert ramp_from_zero[2].context == seq[2].context and ramp_from_zero[3].context != seq[3].context
