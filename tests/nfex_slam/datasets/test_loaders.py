"""Loaders on the real sequences in ../shared/data, and on small folders made here to check the
conventions and the DataMissing messages of incomplete folders."""
from __future__ import annotations

import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest
from nfex_slam.datasets import open_sequence
from nfex_slam.datasets.base import Sequence
from nfex_slam.datasets.euroc import read_sensor_yaml
from nfex_slam.datasets.handheld import rodrigues
from nfex_slam.trajectory import read_trajectory

from nfex_core.errors import BadInput, DataMissing


def _check_sequence(seq: Sequence, n: int, shape: tuple[int, int]) -> None:
    assert len(seq) == n
    first, last = seq[0], seq[-1]
    assert first.image.shape == shape and first.image.dtype == np.uint8
    assert last.index == n - 1
    assert np.all(np.diff(seq.timestamps) > 0)
    poses = seq.poses
    assert poses is not None and poses.shape == (n, 4, 4)
    rot = poses[:, :3, :3]
    assert np.allclose(rot @ rot.transpose(0, 2, 1), np.eye(3), atol=1e-4)
    assert (seq.intrinsics.height, seq.intrinsics.width) == shape
    window = seq[2:7]
    assert len(window) == 5 and np.allclose(window.poses, poses[2:7])
    assert np.array_equal(window[0].image, seq[2].image)
    assert window[0].index == 2 and window[1:3][0].index == 3


def test_kitti_00(data_dir: Path) -> None:
    seq = open_sequence(data_dir / "kitti", "kitti", "00")
    _check_sequence(seq, 200, (376, 1241))
    assert seq.key == "kitti/00" and seq.context == {"agent": "car", "scene": "outdoor"}
    assert (seq.intrinsics.fx, seq.intrinsics.cx, seq.intrinsics.cy) == (718.856, 607.1928, 185.2157)
    # the README: 145 m of driving; the car drives along the camera's +z axis
    path = np.sum(np.linalg.norm(np.diff(seq.poses[:, :3, 3], axis=0), axis=1))
    assert 140 < path < 150
    assert seq[1].pose[2, 3] > 0.5
    # a sequence folder works too, and the poses are those of the file
    same = open_sequence(data_dir / "kitti" / "sequences" / "00", "kitti")
    ref = read_trajectory(data_dir / "kitti" / "poses" / "00.txt", "kitti")
    assert np.allclose(same.poses, ref.poses)


def test_kitti_07_reads_its_own_calibration_and_poses(data_dir: Path) -> None:
    seq = open_sequence(data_dir / "kitti", "kitti", "07")
    _check_sequence(seq, 160, (370, 1226))
    assert (seq.intrinsics.fx, seq.intrinsics.fy, seq.intrinsics.cx, seq.intrinsics.cy) == (707.0912, 707.0912, 601.8873, 183.1104)
    ref = read_trajectory(data_dir / "kitti" / "poses" / "07.txt", "kitti")
    assert np.allclose(seq.poses, ref.poses) and np.allclose(seq.poses[0], np.eye(4), atol=1e-6)
    # the data README: 91 m of urban driving with a 95° turn at a junction
    path = np.sum(np.linalg.norm(np.diff(seq.poses[:, :3, 3], axis=0), axis=1))
    heading = np.degrees(np.arctan2(seq.poses[:, 0, 2], seq.poses[:, 2, 2]))
    assert 85 < path < 97 and 85 < np.ptp(heading) < 105


def test_euroc_micro(data_dir: Path) -> None:
    seq = open_sequence(data_dir / "euroc", "euroc", "V1_01_easy_micro")
    _check_sequence(seq, 95, (480, 752))
    intr = seq.intrinsics
    assert (intr.fx, intr.fy, intr.cx, intr.cy) == (458.654, 457.296, 367.215, 248.375)
    assert intr.distortion == pytest.approx((-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05))
    assert intr.distortion_model == "radtan"
    assert seq.context == {"agent": "drone", "scene": "indoor"}
    assert seq.timestamps[0] == pytest.approx(1403715273.262142976)
    # camera pose = body pose (ground truth) · T_BS
    root = data_dir / "euroc" / "V1_01_easy_micro"
    gt = read_trajectory(root / "groundtruth_tum.txt", "tum")
    t_bs = np.array(read_sensor_yaml(root / "mav0" / "cam0" / "sensor.yaml")["T_BS"]["data"]).reshape(4, 4)
    k = int(np.argmin(np.abs(gt.timestamps - seq.timestamps[10])))
    assert np.allclose(seq[10].pose, gt.poses[k] @ t_bs)
    assert not np.allclose(seq[10].pose, gt.poses[k])


def test_handheld_checkerboard(data_dir: Path) -> None:
    seq = open_sequence(data_dir / "handheld", "handheld", "checkerboard")
    _check_sequence(seq, 736, (480, 752))
    assert seq.context == {"agent": "human", "scene": "indoor"}
    assert seq.intrinsics.distortion_model == "radial_pixel"
    rows = np.loadtxt(data_dir / "handheld" / "checkerboard" / "poses.txt")
    # camera-to-world is the inverse of the file's world-to-camera (R(r), t)
    for i in (0, 300, 735):
        r = rodrigues(rows[i, :3])
        t_cw = np.eye(4)
        t_cw[:3, :3], t_cw[:3, 3] = r, rows[i, 3:]
        assert np.allclose(seq.poses[i] @ t_cw, np.eye(4), atol=1e-9)
        assert np.allclose(r, cv2.Rodrigues(rows[i, :3])[0], atol=1e-12)
    # the board's origin lies in front of the camera and projects into the image in most frames
    inside = 0
    for pose in seq.poses:
        x = np.linalg.inv(pose) @ np.array([0, 0, 0, 1.0])
        if x[2] > 0:
            u, v, _ = seq.intrinsics.K @ (x[:3] / x[2])
            inside += 0 <= u < 752 and 0 <= v < 480
    assert inside > 0.8 * len(seq)


def _mini_kitti(root: Path, n: int = 3) -> Path:
    folder = root / "sequences" / "05"
    (folder / "image_0").mkdir(parents=True)
    for i in range(n):
        cv2.imwrite(str(folder / "image_0" / f"{i:06d}.png"), np.full((20, 30), i * 10, np.uint8))
    (folder / "times.txt").write_text("".join(f"{i * 0.1:e}\n" for i in range(n)))
    (folder / "calib.txt").write_text("P0: 100 0 15 0 0 100 10 0 0 0 1 0\n")
    (root / "poses").mkdir()
    rows = [f"1 0 0 0 0 1 0 0 0 0 1 {i}" for i in range(n)]
    (root / "poses" / "05.txt").write_text("\n".join(rows) + "\n")
    return root


def test_kitti_incomplete_folders_name_the_missing_file(tmp_path: Path) -> None:
    root = _mini_kitti(tmp_path / "k")
    seq = open_sequence(root, "kitti", "5")
    assert len(seq) == 3 and seq.intrinsics.fx == 100 and seq[2].pose[2, 3] == 2
    (root / "sequences" / "05" / "image_0" / "000002.png").unlink()
    with pytest.raises(DataMissing, match="000002.png"):
        open_sequence(root, "kitti", "05")
    (root / "sequences" / "05" / "calib.txt").unlink()
    with pytest.raises(DataMissing, match="calib.txt"):
        open_sequence(root, "kitti", "05")
    with pytest.raises(DataMissing, match="07"):
        open_sequence(root, "kitti", "07")


def test_euroc_incomplete_folder(tmp_path: Path, data_dir: Path) -> None:
    src = data_dir / "euroc" / "V1_01_easy_micro"
    dst = tmp_path / "V1"
    shutil.copytree(src, dst)
    (dst / "mav0" / "cam0" / "sensor.yaml").unlink()
    with pytest.raises(DataMissing, match="sensor.yaml"):
        open_sequence(dst, "euroc")
    shutil.copy(src / "mav0" / "cam0" / "sensor.yaml", dst / "mav0" / "cam0" / "sensor.yaml")
    first = sorted((dst / "mav0" / "cam0" / "data").iterdir())[0]
    first.unlink()
    with pytest.raises(DataMissing, match=first.name):
        open_sequence(dst, "euroc")
    with pytest.raises(DataMissing, match="mav0"):
        open_sequence(tmp_path, "euroc", "nothing")


def test_handheld_and_tum_missing_files(tmp_path: Path) -> None:
    (tmp_path / "hh" / "images").mkdir(parents=True)
    (tmp_path / "hh" / "poses.txt").write_text("0 0 0 0 0 1\n")
    with pytest.raises(DataMissing, match="K.txt"):
        open_sequence(tmp_path / "hh", "handheld")
    with pytest.raises(DataMissing, match="rgb.txt"):
        open_sequence(tmp_path, "tum", "rgbd_dataset_freiburg1_xyz")
    with pytest.raises(BadInput, match="unknown dataset format"):
        open_sequence(tmp_path, "nuscenes")


def test_tum_layout(tmp_path: Path) -> None:
    folder = tmp_path / "rgbd_dataset_freiburg1_test"
    (folder / "rgb").mkdir(parents=True)
    lines, gt = [], []
    for i in range(4):
        t = 1305031102.0 + i * 0.033
        name = f"rgb/{t:.6f}.png"
        cv2.imwrite(str(folder / name), np.full((12, 16, 3), 40 * i, np.uint8))
        lines.append(f"{t:.6f} {name}")
        if i != 2:  # one frame without ground truth
            gt.append(f"{t + 0.004:.4f} {i} 0 0 0 0 0 1")
    (folder / "rgb.txt").write_text("# color images\n" + "\n".join(lines) + "\n")
    (folder / "groundtruth.txt").write_text("# ground truth\n" + "\n".join(gt) + "\n")
    seq = open_sequence(folder, "tum")
    assert seq.intrinsics.fx == 517.3 and len(seq.intrinsics.distortion) == 5
    assert seq[1].image.shape == (12, 16) and seq[1].image[0, 0] == 40
    assert seq[2].pose is None and seq[3].pose[0, 3] == 3
    assert np.isnan(seq.poses[2]).all()
    assert seq.context["agent"] == "human"


def test_handheld_poses_and_lens_model_explain_the_checkerboard(data_dir: Path) -> None:
    """Project the board's 9×6 inner corners (4 cm squares, origin at the first corner) with the
    loaded camera-to-world pose, K and the radial_pixel model; compare with the detected corners."""
    from nfex_slam.datasets.camera import distort_points, undistort_points

    seq = open_sequence(data_dir / "handheld", "handheld", "checkerboard")
    board = np.array([[0.04 * x, 0.04 * y, 0.0, 1.0] for y in range(6) for x in range(9)])
    checked = 0
    for i in (0, 150, 400, 700):
        img = seq[i].image
        found, corners = cv2.findChessboardCorners(img, (9, 6))
        if not found:
            continue
        corners = cv2.cornerSubPix(img, corners, (5, 5), (-1, -1), (3, 30, 1e-3)).reshape(-1, 2)
        x_c = (np.linalg.inv(seq.poses[i]) @ board.T)[:3]
        ideal = (seq.intrinsics.K @ (x_c / x_c[2]))[:2].T
        err = np.linalg.norm(distort_points(seq.intrinsics, ideal) - corners, axis=1)
        assert np.median(err) < 1.0, f"frame {i}: median reprojection error {np.median(err):.2f} px"
        # the lens model straightens the board's rows (the wrong direction would bend them more)
        rows = undistort_points(seq.intrinsics, corners).reshape(6, 9, 2)
        resid = [np.linalg.svd(r - r.mean(0))[1][-1] for r in rows]
        raw = [np.linalg.svd(r - r.mean(0))[1][-1] for r in corners.reshape(6, 9, 2)]
        assert np.mean(resid) < 0.2 * np.mean(raw)
        checked += 1
    assert checked >= 3


def test_euroc_reads_the_asl_ground_truth_csv(tmp_path: Path, data_dir: Path) -> None:
    """Without groundtruth_tum.txt the loader reads mav0/state_groundtruth_estimate0/data.csv."""
    from nfex_slam.trajectory import write_euroc

    src = data_dir / "euroc" / "V1_01_easy_micro"
    dst = tmp_path / "V1"
    shutil.copytree(src, dst)
    (dst / "groundtruth_tum.txt").unlink()
    assert open_sequence(dst, "euroc").poses is None
    gt = read_trajectory(src / "groundtruth_tum.txt", "tum")
    write_euroc(dst / "mav0" / "state_groundtruth_estimate0" / "data.csv", gt)
    a, b = open_sequence(dst, "euroc"), open_sequence(src, "euroc")
    assert np.allclose(a.poses, b.poses, atol=1e-6)
