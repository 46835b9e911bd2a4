"""Per frame of one VO run: its step length against the truth's, and its rotation error next to the chained two-view one.

    python bench/vo_drift.py [--sequence 00] [--extractor ORB_GRID] [--seed 2] [--scale map] [--every 1]
        [--rotation-sigma-deg DEG]

Runs ``run_vo`` once (``VOParams(seed, scale)``, no front-end checks) over a whole KITTI sequence and prints, for
frame k: the step length ‖c_k − c_k−1‖ over the truth's, divided by the run's median of that ratio (1 where the
scale holds); the rotation error of the pose, ∠(R_0ᵀR_k, R*_0ᵀR*_k) in degrees; the same for the accepted pairs'
two-view estimates chained (``FrameRecord.estimate``, lost pairs skipped); and how the frame was placed
(``FrameRecord.located``: p = PnP, e = essential matrix, r = the map started again, - = first or lost). It shows where a run's scale or heading
goes, and whether the map or the pairs took it there. ``--rotation-sigma-deg`` sets ``VOParams.rotation_sigma_deg``
(0: the window's adjustment without the pairs' rotations).
"""
from __future__ import annotations

import argparse
import os
import tempfile

import numpy as np
from nfex_slam.datasets import open_sequence
from nfex_slam.vo import VOParams, fixed, run_vo, window_errors

from nfex_core.knowledge import open_graph
from nfex_core.vision.registry import ExtractorRegistry


def _angle(R: np.ndarray) -> float:
    return float(np.degrees(np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1))))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sequence", default="00")
    ap.add_argument("--extractor", default="ORB_GRID")
    ap.add_argument("--seed", type=int, default=2)
    ap.add_argument("--scale", default="map")
    ap.add_argument("--every", type=int, default=1, help="print every n-th frame")
    ap.add_argument("--rotation-sigma-deg", type=float, default=None, help="VOParams.rotation_sigma_deg (0: no rotation factors)")
    args = ap.parse_args()
    registry = ExtractorRegistry.from_vocabulary(open_graph(tempfile.mkdtemp(prefix="nfex-drift-")).vocabulary())
    data = os.environ.get("NFEX_DATA", os.path.join(os.path.dirname(__file__), "..", "..", "shared", "data"))
    seq = open_sequence(os.path.join(data, "kitti"), "kitti", args.sequence)
    assert seq.poses is not None
    res = run_vo(seq, fixed(args.extractor), registry=registry, params=VOParams(seed=args.seed, scale=args.scale,
                                                                           rotation_sigma_deg=args.rotation_sigma_deg))
    gt = np.linalg.inv(seq.poses[0]) @ seq.poses[: len(res.poses)]
    est = np.linalg.norm(np.diff(res.poses[:, :3, 3], axis=0), axis=1)
    truth = np.linalg.norm(np.diff(gt[:, :3, 3], axis=0), axis=1)
    ratio = est / np.maximum(truth, 1e-9)
    ratio /= np.median(ratio)
    sigma = "" if args.rotation_sigma_deg is None else f", rotation σ {args.rotation_sigma_deg}°"
    print(f"KITTI {args.sequence}, {args.extractor} defaults, seed {args.seed}, scale {args.scale}{sigma}: "
          f"ATE {window_errors(seq, res)[0]:.3f} m")
    print(f"{'frame':>5} {'step/truth':>10} {'rot err':>8} {'pairs rot err':>13} {'placed':>6}")
    chained = np.eye(3)
    for k in range(1, len(res.frames)):
        f = res.frames[k]
        if f.estimate is not None and not f.lost:
            chained = chained @ f.estimate[0].T  # R maps camera k−1 to camera k: camera k's orientation is Rᵀ
        if k % args.every == 0 or k == len(res.frames) - 1:
            rot = _angle(res.poses[k, :3, :3].T @ gt[k, :3, :3])
            pairs = _angle(chained.T @ gt[k, :3, :3])
            placed = {"pnp": "p", "essential": "e", "restart": "r"}.get(f.located, "-")
            print(f"{f.index:5d} {ratio[k - 1]:10.2f} {rot:8.2f} {pairs:13.2f} {placed:>6}")


if __name__ == "__main__":
    main()
