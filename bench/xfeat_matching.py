"""How XFeat's correspondences are matched decides its two-view accuracy: SIFT against XFeat under three matchers.

    python bench/xfeat_matching.py [--sequences 01,07] [--pairs 50] [--out docs/results/xfeat-matching.json]

For each consecutive frame pair of the shared KITTI sequences, both extractors at their graph defaults, the
pair's relative pose from the essential matrix (the VO's own ``relative_pose``, one RANSAC seed), and its errors
against the ground truth: rotation error and translation-direction error (degrees), the pair's error the larger
of the two (a pair without a model: 180°), pose AUC at 5/10/20° over the pairs, as the feature-matching
literature reports it. XFeat is matched three ways:

- ``mutual-ratio``: mutual nearest neighbours that also pass Lowe's ratio test at 0.8 (the graph's matcher);
- ``mutual``: mutual nearest neighbours alone;
- ``mutual-cos0.82``: mutual nearest neighbours with cosine similarity above 0.82 (XFeat's authors' matcher).

Each XFeat variant is compared with SIFT pair by pair (Wilcoxon signed-rank on the pair errors). Tune nothing to
these figures: two short sequences, one seed.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "clients" / "slam")]

from nfex_slam.datasets import open_sequence  # noqa: E402
from nfex_slam.trajectory.frontend import (  # noqa: E402
    AUC_THRESHOLDS,
    direction_errors,
    pose_auc,
    relative,
    rotation_errors,
)
from nfex_slam.vo.geometry import mutual_ratio_l2, relative_pose, undistort  # noqa: E402
from scipy.stats import wilcoxon  # noqa: E402

COS = 0.82


def matches(method: str, a: Any, b: Any) -> tuple[np.ndarray, np.ndarray]:
    if method == "ratio":  # SIFT: Lowe's test, as the VO matches it
        from nfex_slam.vo.geometry import match

        m = match(a, b)
        return m.query, m.train
    if method == "mutual-ratio":
        return mutual_ratio_l2(a.descriptors, b.descriptors, 0.8)
    q, t = mutual_ratio_l2(a.descriptors, b.descriptors, 1.0 + 1e-6)  # ratio 1: every mutual pair passes
    if method == "mutual":
        return q, t
    da = np.asarray(a.descriptors, np.float32)[q]
    db = np.asarray(b.descriptors, np.float32)[t]
    cos = np.einsum("ij,ij->i", da, db) / np.maximum(np.linalg.norm(da, axis=1) * np.linalg.norm(db, axis=1), 1e-12)
    keep = cos > COS
    return q[keep], t[keep]


def pair_error(seq: Any, a: Any, b: Any, method: str, truth: np.ndarray) -> tuple[float, int]:
    q, t = matches(method, a, b)
    if len(q) < 5:
        return 180.0, 0
    import cv2

    cv2.setRNGSeed(0)  # OpenCV's RANSAC draws from its own generator
    rel = relative_pose(undistort(a.xy[q], seq.intrinsics), undistort(b.xy[t], seq.intrinsics), seq.intrinsics.K)
    if rel is None:
        return 180.0, len(q)
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = rel.R.T, -rel.R.T @ rel.t  # camera k in camera k−1: what ``relative`` gives
    e = max(float(rotation_errors(T[None], truth[None])[0]), float(direction_errors(T[None], truth[None])[0]))
    return e, int(rel.inliers.sum())


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sequences", default="01,07")
    ap.add_argument("--pairs", type=int, default=50)
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    data = Path(os.environ.get("NFEX_DATA", ROOT.parent / "shared" / "data")) / "kitti"
    from nfex_core.config import Settings
    from nfex_core.kg.shipped import ontology_vocabulary
    from nfex_core.vision.registry import ExtractorRegistry

    registry = ExtractorRegistry.from_vocabulary(ontology_vocabulary(Settings.from_env()))
    arms = [("SIFT", "ratio"), ("XFEAT", "mutual-ratio"), ("XFEAT", "mutual"), ("XFEAT", f"mutual-cos{COS}")]
    errors: dict[str, list[float]] = {f"{x} {m}": [] for x, m in arms}
    inliers: dict[str, list[int]] = {f"{x} {m}": [] for x, m in arms}
    for name in args.sequences.split(","):
        seq = open_sequence(data, "kitti", name)
        n = min(len(seq), args.pairs + 1)
        truth = relative(seq.poses[:n])
        feats = {x: [registry.extract(x, seq[i].image) for i in range(n)] for x in ("SIFT", "XFEAT")}
        for k in range(n - 1):
            for x, m in arms:
                e, inl = pair_error(seq, feats[x][k], feats[x][k + 1], "mutual-cos" if "cos" in m else m, truth[k])
                errors[f"{x} {m}"].append(e)
                inliers[f"{x} {m}"].append(inl)
    sift = np.array(errors["SIFT ratio"])
    rows = []
    print(f"KITTI {args.sequences}, {len(sift)} consecutive pairs, defaults, one RANSAC seed")
    print(f"{'arm':26s} {'AUC@5':>6s} {'AUC@10':>6s} {'AUC@20':>6s} {'median err':>10s} {'inliers':>8s}  vs SIFT (Wilcoxon)")
    for key, errs in errors.items():
        e = np.array(errs)
        auc = pose_auc(e)
        p = None if key == "SIFT ratio" or np.allclose(e, sift) else float(wilcoxon(e, sift).pvalue)
        rows.append({"arm": key, "auc": {str(k): v for k, v in auc.items()}, "median_error_deg": float(np.median(e)),
                     "median_inliers": float(np.median(inliers[key])), "p_vs_sift": p, "errors_deg": e.tolist()})
        vs = "" if p is None else f"p = {p:.3g} ({'XFeat worse' if np.median(e - sift) > 0 else 'XFeat better'})"
        print(f"{key:26s} {auc[AUC_THRESHOLDS[0]]:6.3f} {auc[AUC_THRESHOLDS[1]]:6.3f} {auc[AUC_THRESHOLDS[2]]:6.3f} "
              f"{np.median(e):10.3f} {np.median(inliers[key]):8.0f}  {vs}")
    if args.out:
        Path(args.out).write_text(json.dumps({"sequences": args.sequences, "pairs": len(sift), "arms": rows}, indent=1))


if __name__ == "__main__":
    main()
