"""EuRoC MAV (ASL layout): ``mav0/cam0/{data/*.png, data.csv, sensor.yaml}`` and body ground truth.

Ground truth is the body (IMU) pose T_WB, either ``groundtruth_tum.txt`` beside ``mav0`` (TUM format)
or ``mav0/state_groundtruth_estimate0/data.csv`` (EuRoC csv). The camera pose is T_WC = T_WB · T_BS with
T_BS the camera-to-body transform of ``cam0/sensor.yaml``. Each image takes the ground-truth pose
nearest in time within ``gt_max_diff`` seconds (evo's association); frames without one get no pose.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..errors import DataMissing, ParseError
from ..trajectory.ate import matching_indices
from ..trajectory.io import Trajectory, read_euroc, read_tum
from .base import Intrinsics
from .frames import ImageSequence

CONTEXT = {"agent": "drone", "scene": "indoor"}


def read_sensor_yaml(path: Path) -> dict[str, Any]:
    """An ASL ``sensor.yaml`` (OpenCV's ``%YAML:1.0`` header is dropped so that PyYAML reads it)."""
    import yaml

    if not path.is_file():
        raise DataMissing(f"EuRoC camera calibration {path} does not exist")
    text = "\n".join(line for line in path.read_text().splitlines() if not line.startswith("%"))
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as e:
        raise ParseError(f"{path}: not YAML: {e}") from None
    for key in ("T_BS", "intrinsics", "resolution"):
        if key not in data:
            raise ParseError(f"{path}: no {key}")
    return dict(data)


def _root(path: Path, sequence: str | None) -> Path:
    root = path / sequence if sequence else path
    if root.name == "mav0":
        root = root.parent
    if not (root / "mav0").is_dir():
        raise DataMissing(f"EuRoC folder {root / 'mav0'} does not exist")
    return root


def _ground_truth(root: Path) -> Trajectory | None:
    tum = root / "groundtruth_tum.txt"
    if tum.is_file():
        return read_tum(tum)
    csv = root / "mav0" / "state_groundtruth_estimate0" / "data.csv"
    if csv.is_file():
        return read_euroc(csv)
    return None


def load_euroc(path: str | Path, sequence: str | None = None, gt_max_diff: float = 0.01) -> ImageSequence:
    """An EuRoC sequence from its folder (the one holding ``mav0``) or from the dataset root + ``sequence``."""
    root = _root(Path(path), sequence)
    cam = root / "mav0" / "cam0"
    index = cam / "data.csv"
    if not index.is_file():
        raise DataMissing(f"EuRoC image list {index} does not exist")
    sensor = read_sensor_yaml(cam / "sensor.yaml")
    stamps_ns: list[int] = []
    paths: list[Path] = []
    for lineno, line in enumerate(index.read_text().splitlines(), start=1):
        if not line.strip() or line.startswith("#"):
            continue
        parts = [p.strip() for p in line.split(",")]
        if len(parts) < 2 or not parts[0].isdigit():
            raise ParseError(f"{index}:{lineno}: expected 'timestamp_ns,filename'", line=lineno)
        stamps_ns.append(int(parts[0]))
        paths.append(cam / "data" / parts[1])
    if not paths:
        raise DataMissing(f"{index} lists no images")
    for p in paths:
        if not p.is_file():
            raise DataMissing(f"EuRoC image {p} does not exist (listed in {index.name})")
    timestamps = np.array(stamps_ns, dtype=np.float64) * 1e-9
    t_bs = np.array(sensor["T_BS"]["data"], dtype=float).reshape(4, 4)
    poses = None
    gt = _ground_truth(root)
    if gt is not None:
        poses = np.full((len(paths), 4, 4), np.nan)
        i_img, i_gt = matching_indices(timestamps, gt.timestamps, gt_max_diff)
        poses[i_img] = gt.poses[i_gt] @ t_bs
    fu, fv, cu, cv = (float(v) for v in sensor["intrinsics"])
    w, h = (int(v) for v in sensor["resolution"])
    model = str(sensor.get("distortion_model", "radial-tangential"))
    intr = Intrinsics(
        fu, fv, cu, cv, w, h,
        distortion=tuple(float(v) for v in sensor.get("distortion_coefficients", ())),
        distortion_model="radtan" if model == "radial-tangential" else model,
    )
    return ImageSequence("euroc", root.name, intr, paths, timestamps, poses, CONTEXT)
