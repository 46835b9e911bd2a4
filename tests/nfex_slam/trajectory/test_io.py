"""Trajectory files: TUM, KITTI and EuRoC csv read, written and read back; bad files refused."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from nfex_slam.trajectory import Trajectory, read_trajectory, write_trajectory
from nfex_slam.trajectory.io import matrix_to_quaternion, quaternion_to_matrix

from nfex_core.errors import BadInput, DataMissing, ParseError


def _random(n: int = 12, seed: int = 0) -> Trajectory:
    rng = np.random.default_rng(seed)
    poses = np.tile(np.eye(4), (n, 1, 1))
    poses[:, :3, :3] = quaternion_to_matrix(rng.normal(size=(n, 4)))
    poses[:, :3, 3] = rng.normal(size=(n, 3)) * 10
    return Trajectory(1.4e9 + np.arange(n) * 0.05, poses)


@pytest.mark.parametrize("fmt", ["tum", "kitti", "euroc"])
def test_round_trip(tmp_path: Path, fmt: str) -> None:
    traj = _random()
    write_trajectory(tmp_path / "t.txt", traj, fmt)
    back = read_trajectory(tmp_path / "t.txt", fmt)
    assert np.allclose(back.poses, traj.poses, atol=1e-7)
    if fmt == "kitti":
        assert back.timestamps.tolist() == list(range(len(traj)))
    else:
        assert np.allclose(back.timestamps, traj.timestamps, atol=1e-6)


def test_quaternion_round_trip() -> None:
    rng = np.random.default_rng(1)
    for q in rng.normal(size=(200, 4)):
        r = quaternion_to_matrix(q)
        assert np.allclose(r @ r.T, np.eye(3), atol=1e-12)
        assert np.allclose(quaternion_to_matrix(matrix_to_quaternion(r)), r, atol=1e-12)


def test_reads_the_shared_files(data_dir: Path) -> None:
    d = data_dir / "trajectories" / "evo"
    tum = read_trajectory(d / "freiburg1_xyz-groundtruth.txt", "tum")
    assert tum.timestamps[0] == pytest.approx(1305031098.6659)
    assert np.allclose(tum.positions[0], [1.3563, 0.6305, 1.6380])
    euroc = read_trajectory(d / "V102_groundtruth.csv", "euroc")
    assert euroc.timestamps[0] == pytest.approx(1403715524.907143168)
    assert np.allclose(euroc.positions[0], [0.515356, 1.996773, 0.971104])
    # q_RS (w, x, y, z) = (0.161996, 0.789985, -0.205376, 0.554528)
    assert np.allclose(matrix_to_quaternion(euroc.poses[0, :3, :3]), np.array([0.789985, -0.205376, 0.554528, 0.161996]) / np.linalg.norm([0.161996, 0.789985, -0.205376, 0.554528]), atol=1e-9)
    kitti = read_trajectory(d / "KITTI_00_gt.txt", "kitti")
    assert len(kitti) == 4541


def test_bad_files(tmp_path: Path) -> None:
    with pytest.raises(DataMissing, match="does not exist"):
        read_trajectory(tmp_path / "nope.txt", "tum")
    bad = tmp_path / "bad.txt"
    bad.write_text("1 2 3\n")
    with pytest.raises(ParseError, match="expected 8 numbers"):
        read_trajectory(bad, "tum")
    bad.write_text("# only a comment\n")
    with pytest.raises(ParseError, match="no poses"):
        read_trajectory(bad, "kitti")
    bad.write_text("1 2 x 4 5 6 7 8\n")
    with pytest.raises(ParseError, match=":1:"):
        read_trajectory(bad, "tum")
    with pytest.raises(BadInput, match="unknown trajectory format"):
        read_trajectory(bad, "g2o")


def test_from_sequence_drops_frames_without_ground_truth() -> None:
    from nfex_slam.datasets import ArraySequence, Intrinsics
    from nfex_slam.trajectory import from_sequence

    poses = np.tile(np.eye(4), (4, 1, 1))
    poses[2] = np.nan
    seq = ArraySequence("t", "x", Intrinsics(1, 1, 0, 0, 2, 2), [np.zeros((2, 2), np.uint8)] * 4, np.arange(4.0), poses)
    traj = from_sequence(seq)
    assert traj.timestamps.tolist() == [0.0, 1.0, 3.0] and traj.poses.shape == (3, 4, 4)
    with pytest.raises(BadInput, match="no ground-truth"):
        from_sequence(ArraySequence("t", "y", seq.intrinsics, [np.zeros((2, 2), np.uint8)], np.zeros(1), None))
