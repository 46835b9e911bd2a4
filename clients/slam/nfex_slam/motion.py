"""Front-end checks on a frame pair's relative pose: what the agent's motion can produce.

A real SLAM front end does not accept a relative pose its platform cannot have made (ORB-SLAM's motion
model, a car's non-holonomic motion). For a pair (k−1, k) with estimated rotation R and unit translation
t (a point X in camera k−1 is R·X + t in camera k; the camera moved along d_k = −Rᵀt, in camera k−1):

- rotation:  θ(R) = arccos((tr R − 1) / 2)                 must not exceed ω_max · Δt;
- direction: ∠(R_{k−1}·d_{k−1}, d_k), the heading change from the last accepted step (its direction
  carried into camera k−1), must not exceed φ_max · Δt — checked only when both steps translated.

ω_max and φ_max are per-agent data in the graph (``nfex:maxRotationRate``, ``nfex:maxHeadingChangeRate``,
degrees per second, ontology/frontend.ttl; read by ``nfex_core.rules.motion.load_step_checks``); Δt is the pair's time step. A pair that fails is treated as
lost: the pose follows the last accepted motion (constant velocity). The same checks score a pair
against the ground truth (``pair_errors``) and let a verifier compare candidates (``angle_between``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def rotation_deg(R: np.ndarray) -> float:
    """θ(R) in degrees."""
    c = (float(np.trace(R)) - 1.0) / 2.0
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


def motion_direction(R: np.ndarray, t: np.ndarray) -> np.ndarray:
    """d = −Rᵀt: the unit direction the camera moved in, in the previous camera's frame."""
    d = -R.T @ np.asarray(t, dtype=float).reshape(3)
    n = float(np.linalg.norm(d))
    return d / n if n > 0 else d


def angle_between(a: np.ndarray, b: np.ndarray) -> float:
    """The angle between two directions, degrees (0 where either is zero)."""
    na, nb = float(np.linalg.norm(a)), float(np.linalg.norm(b))
    if na == 0 or nb == 0:
        return 0.0
    return math.degrees(math.acos(max(-1.0, min(1.0, float(a @ b) / (na * nb)))))


@dataclass(frozen=True)
class StepChecks:
    """The per-agent limits (degrees per second); None: that check is off."""

    max_rotation_rate: float | None = None
    max_heading_change_rate: float | None = None
    agent: str = ""

    @property
    def active(self) -> bool:
        return self.max_rotation_rate is not None or self.max_heading_change_rate is not None

    def verdict(
        self, R: np.ndarray, t: np.ndarray, dt: float, previous: tuple[np.ndarray, np.ndarray] | None, moved: bool
    ) -> str:
        """"" when the pair passes, else why it fails. ``previous``: the last accepted step's (R, t) when
        it translated; ``moved``: whether this step translated (parallax above the still threshold)."""
        dt = dt if dt > 0 else 0.1
        who = f" for agent {self.agent}" if self.agent else ""
        if self.max_rotation_rate is not None:
            limit = min(180.0, self.max_rotation_rate * dt)
            angle = rotation_deg(R)
            if angle > limit:
                return f"check: rotation {angle:.1f}° exceeds {limit:.1f}° per frame{who}"
        if self.max_heading_change_rate is not None and previous is not None and moved:
            limit = min(180.0, self.max_heading_change_rate * dt)
            before = previous[0] @ motion_direction(*previous)
            change = angle_between(before, motion_direction(R, t))
            if change > limit:
                return f"check: heading change {change:.1f}° exceeds {limit:.1f}° per frame{who}"
        return ""


NO_CHECKS = StepChecks()


def relative_truth(pose_a: np.ndarray, pose_b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The true (R, unit t) of a pair from camera-to-world poses: X_b = R·X_a + t."""
    T = np.linalg.inv(pose_b) @ pose_a
    t = T[:3, 3]
    n = float(np.linalg.norm(t))
    return T[:3, :3], (t / n if n > 0 else t)


def pair_errors(R: np.ndarray, t: np.ndarray, truth: tuple[np.ndarray, np.ndarray]) -> tuple[float, float]:
    """(rotation error, direction error) in degrees of an estimate against the true relative pose; the
    direction error is that of the motion direction (undefined scale: only its direction counts)."""
    R_true, t_true = truth
    rot = rotation_deg(R_true.T @ R)
    direction = angle_between(motion_direction(R, t), motion_direction(R_true, t_true)) if np.linalg.norm(t_true) > 0 else 0.0
    return rot, direction
