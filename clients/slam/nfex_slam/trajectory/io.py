"""Trajectory files: TUM (``t tx ty tz qx qy qz qw``), KITTI (3×4 row-major pose per line, no time)
and EuRoC ground-truth csv (``t[ns], px, py, pz, qw, qx, qy, qz, …``), read into one type.

Poses are 4×4 matrices as the file gives them (for the datasets here: camera- or body-to-world).
KITTI files carry no timestamps: a KITTI trajectory gets the frame index as its timestamp, so two
KITTI files associate frame by frame (as evo compares KITTI files pose by pose).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import BadInput, DataMissing, ParseError

FORMATS = ("tum", "kitti", "euroc")


@dataclass(frozen=True)
class Trajectory:
    """Stamped poses: ``timestamps`` (N,) seconds, ``poses`` (N, 4, 4)."""

    timestamps: np.ndarray
    poses: np.ndarray

    def __post_init__(self) -> None:
        ts = np.asarray(self.timestamps, dtype=float).reshape(-1)
        poses = np.asarray(self.poses, dtype=float)
        if poses.ndim != 3 or poses.shape[1:] != (4, 4) or poses.shape[0] != ts.shape[0]:
            raise BadInput(f"a trajectory needs (N,) timestamps and (N,4,4) poses, got {ts.shape} and {poses.shape}")
        object.__setattr__(self, "timestamps", ts)
        object.__setattr__(self, "poses", poses)

    def __len__(self) -> int:
        return int(self.timestamps.shape[0])

    @property
    def positions(self) -> np.ndarray:
        """(N, 3) translations of the poses."""
        return self.poses[:, :3, 3]

    def subset(self, ids: np.ndarray | list[int]) -> Trajectory:
        idx = np.asarray(ids, dtype=int)
        return Trajectory(self.timestamps[idx], self.poses[idx])

    def path_length(self) -> float:
        """Length of the polyline through the positions (metres)."""
        if len(self) < 2:
            return 0.0
        return float(np.sum(np.linalg.norm(np.diff(self.positions, axis=0), axis=1)))


def from_sequence(seq: Any) -> Trajectory:
    """The ground truth of a ``datasets.Sequence`` as a trajectory (frames without a pose left out)."""
    poses = seq.poses
    if poses is None:
        raise BadInput(f"{seq.key} has no ground-truth poses")
    keep = ~np.isnan(poses).reshape(len(poses), -1).any(axis=1)
    return Trajectory(np.asarray(seq.timestamps)[keep], poses[keep])


def quaternion_to_matrix(q: np.ndarray) -> np.ndarray:
    """(…, 4) quaternions (x, y, z, w) → (…, 3, 3) rotation matrices; the quaternion is normalised first."""
    q = np.asarray(q, dtype=float)
    norm = np.linalg.norm(q, axis=-1, keepdims=True)
    if np.any(norm < 1e-12):
        raise BadInput("a quaternion of (near) zero norm")
    x, y, z, w = np.moveaxis(q / norm, -1, 0)
    r = np.empty(q.shape[:-1] + (3, 3))
    r[..., 0, 0] = 1 - 2 * (y * y + z * z)
    r[..., 0, 1] = 2 * (x * y - z * w)
    r[..., 0, 2] = 2 * (x * z + y * w)
    r[..., 1, 0] = 2 * (x * y + z * w)
    r[..., 1, 1] = 1 - 2 * (x * x + z * z)
    r[..., 1, 2] = 2 * (y * z - x * w)
    r[..., 2, 0] = 2 * (x * z - y * w)
    r[..., 2, 1] = 2 * (y * z + x * w)
    r[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return r


def matrix_to_quaternion(r: np.ndarray) -> np.ndarray:
    """(3, 3) rotation → (x, y, z, w) with w ≥ 0 (Shepperd's method, stable for every angle)."""
    m = np.asarray(r, dtype=float)
    tr = float(np.trace(m))
    diag = [tr, m[0, 0], m[1, 1], m[2, 2]]
    k = int(np.argmax(diag))
    if k == 0:
        s = 2.0 * np.sqrt(1.0 + tr)
        q = np.array([(m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, s / 4])
    elif k == 1:
        s = 2.0 * np.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = np.array([s / 4, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s, (m[2, 1] - m[1, 2]) / s])
    elif k == 2:
        s = 2.0 * np.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = np.array([(m[0, 1] + m[1, 0]) / s, s / 4, (m[1, 2] + m[2, 1]) / s, (m[0, 2] - m[2, 0]) / s])
    else:
        s = 2.0 * np.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = np.array([(m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, s / 4, (m[1, 0] - m[0, 1]) / s])
    q /= np.linalg.norm(q)
    return -q if q[3] < 0 else q


def poses_from_tq(t: np.ndarray, q_xyzw: np.ndarray) -> np.ndarray:
    """(N,3) translations and (N,4) quaternions (x, y, z, w) → (N,4,4) poses."""
    n = t.shape[0]
    poses = np.tile(np.eye(4), (n, 1, 1))
    poses[:, :3, :3] = quaternion_to_matrix(q_xyzw)
    poses[:, :3, 3] = t
    return poses


def _load_table(path: Path, delimiter: str | None, min_cols: int) -> np.ndarray:
    if not path.is_file():
        raise DataMissing(f"trajectory file {path} does not exist")
    rows: list[list[float]] = []
    with path.open() as fh:
        for lineno, line in enumerate(fh, start=1):
            text = line.strip()
            if not text or text.startswith("#"):
                continue
            parts = [p for p in (text.split(delimiter) if delimiter else text.split()) if p.strip() != ""]
            try:
                values = [float(p) for p in parts]
            except ValueError:
                raise ParseError(f"{path}:{lineno}: not a row of numbers: {text[:60]!r}", line=lineno) from None
            if len(values) < min_cols:
                raise ParseError(f"{path}:{lineno}: expected {min_cols} numbers, found {len(values)}", line=lineno)
            rows.append(values[:min_cols])
    if not rows:
        raise ParseError(f"{path}: no poses in the file")
    return np.array(rows, dtype=float)


def read_tum(path: str | Path) -> Trajectory:
    data = _load_table(Path(path), None, 8)
    return Trajectory(data[:, 0], poses_from_tq(data[:, 1:4], data[:, 4:8]))


def read_kitti(path: str | Path, timestamps: np.ndarray | None = None) -> Trajectory:
    """KITTI poses; timestamps are the frame indices unless given (e.g. from ``times.txt``)."""
    data = _load_table(Path(path), None, 12)
    poses = np.tile(np.eye(4), (data.shape[0], 1, 1))
    poses[:, :3, :4] = data.reshape(-1, 3, 4)
    ts = np.arange(len(poses), dtype=float) if timestamps is None else np.asarray(timestamps, dtype=float)
    if ts.shape[0] != poses.shape[0]:
        raise BadInput(f"{path}: {poses.shape[0]} poses but {ts.shape[0]} timestamps")
    return Trajectory(ts, poses)


def read_euroc(path: str | Path) -> Trajectory:
    """EuRoC csv: nanosecond stamps, position, quaternion in w, x, y, z order (extra columns ignored)."""
    data = _load_table(Path(path), ",", 8)
    q_xyzw = data[:, [5, 6, 7, 4]]
    return Trajectory(data[:, 0] * 1e-9, poses_from_tq(data[:, 1:4], q_xyzw))


def read_trajectory(path: str | Path, format: str) -> Trajectory:  # noqa: A002 - the CLI's word
    """Read a trajectory file in ``format`` (tum | kitti | euroc)."""
    fmt = format.lower()
    if fmt == "tum":
        return read_tum(path)
    if fmt == "kitti":
        return read_kitti(path)
    if fmt == "euroc":
        return read_euroc(path)
    raise BadInput(f"unknown trajectory format {format!r}; known: {', '.join(FORMATS)}")


def _stamped_tq(traj: Trajectory):
    """(t, x, y, z, quaternion x, y, z, w) per pose, for the writers of quaternion formats."""
    for t, pose in zip(traj.timestamps, traj.poses, strict=True):
        yield (t, *pose[:3, 3], *matrix_to_quaternion(pose[:3, :3]))


def write_tum(path: str | Path, traj: Trajectory) -> None:
    with Path(path).open("w") as fh:
        fh.write("# timestamp tx ty tz qx qy qz qw\n")
        for t, x, y, z, qx, qy, qz, qw in _stamped_tq(traj):
            fh.write(f"{t:.9f} {x:.9f} {y:.9f} {z:.9f} {qx:.9f} {qy:.9f} {qz:.9f} {qw:.9f}\n")


def write_kitti(path: str | Path, traj: Trajectory) -> None:
    with Path(path).open("w") as fh:
        for pose in traj.poses:
            fh.write(" ".join(f"{v:.9e}" for v in pose[:3, :4].reshape(-1)) + "\n")


def write_euroc(path: str | Path, traj: Trajectory) -> None:
    with Path(path).open("w") as fh:
        fh.write("#timestamp [ns], p_x [m], p_y [m], p_z [m], q_w [], q_x [], q_y [], q_z []\n")
        for t, x, y, z, qx, qy, qz, qw in _stamped_tq(traj):
            fh.write(f"{round(t * 1e9)},{x:.9f},{y:.9f},{z:.9f},{qw:.9f},{qx:.9f},{qy:.9f},{qz:.9f}\n")


def write_trajectory(path: str | Path, traj: Trajectory, format: str) -> None:  # noqa: A002
    writers = {"tum": write_tum, "kitti": write_kitti, "euroc": write_euroc}
    if format.lower() not in writers:
        raise BadInput(f"unknown trajectory format {format!r}; known: {', '.join(FORMATS)}")
    writers[format.lower()](path, traj)
