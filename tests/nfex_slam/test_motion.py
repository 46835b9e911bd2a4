"""Front-end checks: what an agent's motion can produce between two frames."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from nfex_slam.motion import (
    NO_CHECKS,
    StepChecks,
    angle_between,
    motion_direction,
    pair_errors,
    relative_truth,
    rotation_deg,
)


def _rot_y(deg: float) -> np.ndarray:
    a = np.radians(deg)
    return np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])


@given(st.floats(-179, 179))
def test_rotation_angle_is_the_axis_angle(deg: float) -> None:
    assert rotation_deg(_rot_y(deg)) == pytest.approx(abs(deg), abs=1e-6)


def test_rotation_and_heading_limits_scale_with_the_time_step() -> None:
    car = StepChecks(100.0, 300.0, "car")
    forward = np.array([0.0, 0.0, -1.0])  # X2 = X1 + t: the camera moved along +z
    assert car.verdict(_rot_y(5), forward, 0.1, None, True) == ""
    assert "rotation 20.0° exceeds 10.0° per frame for agent car" in car.verdict(_rot_y(20), forward, 0.1, None, True)
    assert car.verdict(_rot_y(20), forward, 0.5, None, True) == ""  # 50° allowed over half a second
    sideways = np.array([-1.0, 0.0, 0.0])  # moved along +x after moving along +z: a 90° turn of heading
    previous = (np.eye(3), forward)
    assert "heading change 90.0° exceeds 30.0°" in car.verdict(np.eye(3), sideways, 0.1, previous, True)
    assert car.verdict(np.eye(3), sideways, 0.1, previous, moved=False) == ""  # no translation: no heading to check
    assert car.verdict(np.eye(3), sideways, 0.1, None, True) == ""  # nothing accepted before
    assert NO_CHECKS.verdict(_rot_y(170), sideways, 0.1, previous, True) == "" and not NO_CHECKS.active


def test_pair_errors_against_the_truth_are_zero_for_the_truth() -> None:
    a = np.eye(4)
    b = np.eye(4)
    b[:3, :3] = _rot_y(3)
    b[:3, 3] = [0.2, 0.0, 1.0]
    R, t = relative_truth(a, b)
    assert pair_errors(R, t, (R, t)) == pytest.approx((0.0, 0.0), abs=1e-6)
    assert pair_errors(R, -t, (R, t)) == pytest.approx((0.0, 180.0), abs=1e-6)
    # the motion direction is the camera centre's, -Rᵀt: a rotation error about y turns it by as much
    assert pair_errors(R @ _rot_y(2), t, (R, t)) == pytest.approx((2.0, 2.0), abs=1e-6)
    assert angle_between(motion_direction(R, t), b[:3, 3]) == pytest.approx(0.0, abs=1e-6)
