"""Which robust estimator of the essential matrix the VO's front end runs: accuracy and seed spread of a pair's pose.

    python bench/essential_estimators.py [--sequences 00,01,07] [--extractors ORB_GRID,SIFT] [--frames 51]
        [--seeds 10] [--out docs/results/essential-estimators.json]

For each consecutive frame pair of the shared KITTI sequences (the first ``--frames`` of each), each extractor at
its graph defaults, ratio-test matches as the VO matches (``geometry.match``), and ``--seeds`` orders of those
matches (the VO's ``VOParams.seed`` shuffle), the pair's relative pose by each estimator, then ``cv2.recoverPose``:

- ``RANSAC``: ``cv2.findEssentialMat(method=cv2.RANSAC, prob=0.999, threshold=1 px)``, Nistér's five points in
  plain RANSAC;
- ``MAGSAC++``: ``method=cv2.USAC_MAGSAC``, the same threshold and probability (Barath et al. 2020: a model is
  scored by its likelihood marginalised over the noise scale, and polished on its inliers);
- ``MAGSAC++ 1e-5``: MAGSAC++ with a failure probability of 10⁻⁵ and at most 10,000 iterations, the front end's.

Per estimator, over pairs × seeds: the mean rotation error and translation-direction error against the ground truth
(degrees), pose AUC at 5/10/20° of the pair error (the larger of the two; no model: 180°), the pairs' mean standard
deviation across seeds (how much the RANSAC draw alone moves a pair's estimate), and the milliseconds per estimate.
Each estimator is compared with RANSAC pair by pair (each pair's error averaged over seeds; Wilcoxon's signed-rank
test). Tune nothing to these figures: three sequences of one dataset.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "clients" / "slam")]

from nfex_slam.datasets import open_sequence  # noqa: E402
from nfex_slam.motion import pair_errors, relative_truth  # noqa: E402
from nfex_slam.trajectory.frontend import AUC_THRESHOLDS, pose_auc  # noqa: E402
from nfex_slam.vo.geometry import match, undistort  # noqa: E402

from nfex_core.evaluation.stats import compare  # noqa: E402

Estimator = Callable[[np.ndarray, np.ndarray, np.ndarray], tuple[Any, Any]]
ESTIMATORS: dict[str, Estimator] = {
    "RANSAC": lambda p1, p2, K: cv2.findEssentialMat(p1, p2, K, method=cv2.RANSAC, prob=0.999, threshold=1.0),
    "MAGSAC++": lambda p1, p2, K: cv2.findEssentialMat(p1, p2, K, method=cv2.USAC_MAGSAC, prob=0.999, threshold=1.0),
    "MAGSAC++ 1e-5": lambda p1, p2, K: cv2.findEssentialMat(p1, p2, K, method=cv2.USAC_MAGSAC, prob=0.99999,
                                                            threshold=1.0, maxIters=10000),
}


def errors(seq: Any, a: Any, b: Any, truth: tuple[np.ndarray, np.ndarray], seeds: int,
           ms: dict[str, list[float]]) -> dict[str, np.ndarray]:
    """Per estimator, a (seeds, 2) array of (rotation, direction) errors of one pair; 180° where no model."""
    m = match(a, b)
    n = len(m.query)
    out = {name: np.full((seeds, 2), 180.0) for name in ESTIMATORS}
    if n < 5:
        return out
    K = seq.intrinsics.K
    for s in range(seeds):
        order = np.random.default_rng((s, len(a), len(b), n)).permutation(n)  # the VO's seeded order
        p1 = undistort(a.xy[m.query[order]], seq.intrinsics)
        p2 = undistort(b.xy[m.train[order]], seq.intrinsics)
        for name, estimate in ESTIMATORS.items():
            t0 = time.perf_counter()
            E, mask = estimate(p1, p2, K)
            ms[name].append((time.perf_counter() - t0) * 1000)
            if E is None or mask is None or E.shape != (3, 3):
                continue
            _, R, t, _, _ = cv2.recoverPose(E, p1, p2, K, distanceThresh=1e6, mask=mask.copy())
            out[name][s] = pair_errors(R, t.ravel() / max(float(np.linalg.norm(t)), 1e-12), truth)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sequences", default="00,01,07")
    ap.add_argument("--extractors", default="ORB_GRID,SIFT")
    ap.add_argument("--frames", type=int, default=51)
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--out", default="")
    args = ap.parse_args()
    from nfex_core.knowledge import open_graph
    from nfex_core.vision.registry import ExtractorRegistry

    registry = ExtractorRegistry.from_vocabulary(open_graph(tempfile.mkdtemp(prefix="nfex-essential-")).vocabulary())
    data = os.environ.get("NFEX_DATA", str(ROOT.parent / "shared" / "data"))
    result: dict[str, Any] = {"seeds": args.seeds, "frames": args.frames, "extractors": {}}
    print(f"KITTI {args.sequences}, first {args.frames} frames, {args.seeds} seeds per pair; errors in degrees")
    for ext in args.extractors.split(","):
        per: dict[str, list[np.ndarray]] = {name: [] for name in ESTIMATORS}
        ms: dict[str, list[float]] = {name: [] for name in ESTIMATORS}
        for sid in args.sequences.split(","):
            seq = open_sequence(os.path.join(data, "kitti"), "kitti", sid)
            n = min(args.frames, len(seq))
            feats = [registry.extract(ext, seq[i].image) for i in range(n)]
            for k in range(1, n):
                truth = relative_truth(seq[k - 1].pose, seq[k].pose)
                for name, e in errors(seq, feats[k - 1], feats[k], truth, args.seeds, ms).items():
                    per[name].append(e)
        print(f"\n{ext} defaults, {len(per['RANSAC'])} pairs")
        print(f"{'estimator':15s} {'rot':>6s} {'dir':>6s} {'AUC@5':>6s} {'AUC@10':>6s} {'AUC@20':>6s} "
              f"{'rot sd':>6s} {'dir sd':>6s} {'ms':>5s}  vs RANSAC (pair error, mean over seeds)")
        ref = np.array(per["RANSAC"]).max(axis=2).mean(axis=1)
        rows = {}
        for name, arr in per.items():
            e = np.array(arr)  # pairs × seeds × 2
            auc = pose_auc(e.max(axis=2).ravel())
            mine = e.max(axis=2).mean(axis=1)
            c = compare(list(mine), list(ref), name)
            rows[name] = {"rotation": float(e[..., 0].mean()), "direction": float(e[..., 1].mean()),
                          "auc": {str(k): v for k, v in auc.items()},
                          "rotation_seed_sd": float(e[..., 0].std(axis=1).mean()),
                          "direction_seed_sd": float(e[..., 1].std(axis=1).mean()),
                          "ms": float(np.mean(ms[name])), "vs_ransac": {"relative": c.relative, "p": c.p_wilcoxon}}
            versus = "" if name == "RANSAC" else (
                f"{100 * (c.relative or 0):+.1f} %, p = {c.p_wilcoxon:.2g}" if c.p_wilcoxon is not None else "n/a")
            print(f"{name:15s} {rows[name]['rotation']:6.3f} {rows[name]['direction']:6.2f} "
                  + " ".join(f"{auc[th]:6.3f}" for th in AUC_THRESHOLDS)
                  + f" {rows[name]['rotation_seed_sd']:6.3f} {rows[name]['direction_seed_sd']:6.2f} {rows[name]['ms']:5.2f}  {versus}")
        result["extractors"][ext] = rows
    if args.out:
        Path(args.out).write_text(json.dumps(result, indent=1) + "\n")


if __name__ == "__main__":
    main()
