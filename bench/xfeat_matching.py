"""How XFeat's correspondences are matched decides its two-view accuracy: SIFT against XFeat under three matchers.

    python bench/xfeat_matching.py [--sequences 01,07] [--pairs 50] [--localisation] [--out docs/results/xfeat-matching.json]

For each consecutive frame pair of the shared KITTI sequences, both extractors at their graph defaults, the
pair's relative pose from the essential matrix (the VO's own ``relative_pose``, one RANSAC seed), and its errors
against the ground truth: rotation error and translation-direction error (degrees), the pair's error the larger
of the two (a pair without a model: 180°), pose AUC at 5/10/20° over the pairs, as the feature-matching
literature reports it. XFeat is matched three ways:

- ``mutual-ratio``: mutual nearest neighbours that also pass Lowe's ratio test at 0.8 (the graph's matcher);
- ``mutual``: mutual nearest neighbours alone;
- ``mutual-cos0.82``: mutual nearest neighbours with cosine similarity above 0.82 (XFeat's authors' matcher).

Then where the correspondences lose accuracy (``--localisation``), every arm matched as the graph matches it:

- ``SIFT ratio, whole px``: SIFT's keypoints rounded to whole pixels, as XFeat's heatmap maxima are; what SIFT
  loses so is what sub-pixel localisation is worth on these frames;
- ``XFEAT s=0.5`` and ``s=0.75``: the graph's ``input_scale`` below its default of 1;
- ``XFEAT sub-px``: XFeat's keypoints moved to the vertex of a parabola through the heatmap at each keypoint and
  its two neighbours in x and in y (a diagnostic of the bench, not the extractor's behaviour);
- ``XFEAT ×1.5``: the frame enlarged 1.5× (bilinear) before extraction and the positions scaled back, so a
  whole pixel of the network's heatmap is 2/3 of a frame pixel (outside the graph's range, a diagnostic only).

Each arm is compared with SIFT pair by pair (Wilcoxon signed-rank on the pair errors), the localisation arms also
with their own base arm. Tune nothing to these figures: two short sequences, one seed.
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

from nfex_core.evaluation.stats import compare  # noqa: E402

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


def whole_pixels(f: Any) -> Any:
    """The same features with their positions rounded to whole pixels."""
    from dataclasses import replace

    return replace(f, xy=np.round(f.xy).astype(np.float32))


def enlarged(registry: Any, name: str, image: np.ndarray, factor: float) -> Any:
    """Features of ``image`` enlarged by ``factor`` (bilinear), their positions mapped back to ``image``."""
    from dataclasses import replace

    import cv2

    big = cv2.resize(image, None, fx=factor, fy=factor, interpolation=cv2.INTER_LINEAR)
    f = registry.extract(name, big)
    return replace(f, xy=(f.xy / factor).astype(np.float32), size=(f.size / factor).astype(np.float32),
                   image_shape=tuple(image.shape[:2]))


def _parabola_offset(left: np.ndarray, centre: np.ndarray, right: np.ndarray) -> np.ndarray:
    """The vertex of the parabola through (−1, left), (0, centre), (1, right), within half a pixel."""
    curvature = left - 2.0 * centre + right
    safe = np.where(curvature < 0, curvature, -1.0)
    return np.where(curvature < 0, np.clip(0.5 * (left - right) / safe, -0.5, 0.5), 0.0)


def subpixel(registry: Any, image: np.ndarray) -> Any:
    """XFeat at its defaults with each keypoint refined on the heatmap by a parabola in x and in y."""
    from nfex_core.vision.learned import xfeat

    plain = xfeat.sparse_features

    def refined(feats: np.ndarray, logits: np.ndarray, reliability: np.ndarray, top_k: int, threshold: float) -> Any:
        pos, scores, desc = plain(feats, logits, reliability, top_k, threshold)
        h8, w8 = reliability.shape
        cell = xfeat.CELL
        z = np.exp(logits - logits.max(axis=0, keepdims=True))
        cells = z[: cell * cell] / z.sum(axis=0, keepdims=True)
        heat = np.pad(cells.reshape(cell, cell, h8, w8).transpose(2, 0, 3, 1).reshape(h8 * cell, w8 * cell), 1)
        x, y = pos[:, 0].astype(int) + 1, pos[:, 1].astype(int) + 1
        dx = _parabola_offset(heat[y, x - 1], heat[y, x], heat[y, x + 1])
        dy = _parabola_offset(heat[y - 1, x], heat[y, x], heat[y + 1, x])
        return pos + np.stack([dx, dy], axis=1), scores, desc

    xfeat.sparse_features = refined
    try:
        return registry.extract("XFEAT", image)
    finally:
        xfeat.sparse_features = plain


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
    ap.add_argument("--localisation", action="store_true",
                    help="add the arms that locate the gap: SIFT at whole pixels, XFeat's input scales, an enlarged frame")
    args = ap.parse_args()
    data = Path(os.environ.get("NFEX_DATA", ROOT.parent / "shared" / "data")) / "kitti"
    from nfex_core.config import Settings
    from nfex_core.kg.shipped import ontology_vocabulary
    from nfex_core.vision.registry import ExtractorRegistry

    registry = ExtractorRegistry.from_vocabulary(ontology_vocabulary(Settings.from_env()))
    arms = [("SIFT", "ratio"), ("XFEAT", "mutual-ratio"), ("XFEAT", "mutual"), ("XFEAT", f"mutual-cos{COS}")]
    # an arm's features: (extractor, how its frames are extracted); its matcher is the graph's for that extractor
    variants: dict[str, tuple[str, Any]] = {}
    if args.localisation:
        variants = {
            "SIFT ratio, whole px": ("SIFT", lambda img, f: whole_pixels(f)),
            "XFEAT s=0.5": ("XFEAT", lambda img, f: registry.extract("XFEAT", img, {"input_scale": 0.5})),
            "XFEAT s=0.75": ("XFEAT", lambda img, f: registry.extract("XFEAT", img, {"input_scale": 0.75})),
            "XFEAT sub-px": ("XFEAT", lambda img, f: subpixel(registry, img)),
            "XFEAT ×1.5": ("XFEAT", lambda img, f: enlarged(registry, "XFEAT", img, 1.5)),
        }
    base = {"SIFT ratio, whole px": "SIFT ratio"} | {k: "XFEAT mutual-ratio" for k in variants if k.startswith("XFEAT")}
    errors: dict[str, list[float]] = {f"{x} {m}": [] for x, m in arms} | {k: [] for k in variants}
    inliers: dict[str, list[int]] = {k: [] for k in errors}
    for name in args.sequences.split(","):
        seq = open_sequence(data, "kitti", name)
        n = min(len(seq), args.pairs + 1)
        truth = relative(seq.poses[:n])
        images = [seq[i].image for i in range(n)]
        feats = {x: [registry.extract(x, img) for img in images] for x in ("SIFT", "XFEAT")}
        for key, (x, how) in variants.items():
            feats[key] = [how(img, f) for img, f in zip(images, feats[x], strict=True)]
        for k in range(n - 1):
            for x, m in arms:
                e, inl = pair_error(seq, feats[x][k], feats[x][k + 1], "mutual-cos" if "cos" in m else m, truth[k])
                errors[f"{x} {m}"].append(e)
                inliers[f"{x} {m}"].append(inl)
            for key, (x, _) in variants.items():
                e, inl = pair_error(seq, feats[key][k], feats[key][k + 1], "ratio" if x == "SIFT" else "mutual-ratio",
                                    truth[k])
                errors[key].append(e)
                inliers[key].append(inl)
    sift = np.array(errors["SIFT ratio"])
    rows = []
    print(f"KITTI {args.sequences}, {len(sift)} consecutive pairs, defaults, one RANSAC seed")
    print(f"{'arm':26s} {'AUC@5':>6s} {'AUC@10':>6s} {'AUC@20':>6s} {'median err':>10s} {'inliers':>8s}  vs SIFT (Wilcoxon)")
    for key, errs in errors.items():
        e = np.array(errs)
        auc = pose_auc(e)
        # the project's paired verdict (evaluation/stats.py): better or worse only where Wilcoxon's p < 0.05
        vs_sift = None if key == "SIFT ratio" else compare(list(e), list(sift), "SIFT ratio")
        rows.append({"arm": key, "auc": {str(k): v for k, v in auc.items()}, "median_error_deg": float(np.median(e)),
                     "median_inliers": float(np.median(inliers[key])),
                     "p_vs_sift": vs_sift.p_wilcoxon if vs_sift else None, "errors_deg": e.tolist()})
        vs = "" if vs_sift is None else f"p = {vs_sift.p_wilcoxon:.3g} ({vs_sift.verdict})"
        if key in base:
            vs_base = compare(list(e), errors[base[key]], base[key])
            rows[-1]["p_vs_base"] = {"base": base[key], "p": vs_base.p_wilcoxon}
            vs += f"; vs {base[key]}: p = {vs_base.p_wilcoxon:.3g} ({vs_base.verdict})"
        print(f"{key:26s} {auc[AUC_THRESHOLDS[0]]:6.3f} {auc[AUC_THRESHOLDS[1]]:6.3f} {auc[AUC_THRESHOLDS[2]]:6.3f} "
              f"{np.median(e):10.3f} {np.median(inliers[key]):8.0f}  {vs}")
    if args.out:
        Path(args.out).write_text(json.dumps({"sequences": args.sequences, "pairs": len(sift), "arms": rows}, indent=1))


if __name__ == "__main__":
    main()
