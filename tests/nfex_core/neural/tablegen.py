"""A small sweep training table that follows the agreed schema, with a learnable rule planted in it.

Planted: in dark windows the best ORB configuration has a low fastThreshold and many features and ORB
wins; in bright windows the best ORB has a high threshold and SIFT wins. Frame statistics carry the
light level (with noise), so ParamNet and SelectorNet can learn both from the context or the frame.
"""
from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

from nfex_core.kg.vocabulary.vocab import Vocabulary

DIMS = ("agent", "motion", "scene", "light", "reflectance", "texture")
METRICS = ("texturedness", "dissimilarity", "motion", "stability", "density", "distinctiveness", "repeatability")


def columns() -> list[str]:
    return [
        "dataset", "sequence", "corruption", "severity", "seed", "window_start", "window_end", "frames",
        *[f"ctx.{d}" for d in DIMS], "extractor", "params", "ate_rmse", "rpe_rmse", "tracking_lost", "failed",
        "mean_matches", "mean_inliers", "mean_keypoints", "extraction_ms", "matching_ms", "width", "height",
        *[f"m.{m}" for m in METRICS], "stat.mean", "stat.contrast", "best_overall", "best_for_extractor",
    ]  # fmt: skip


def make_table(
    path: Path, vocab: Vocabulary, sequences: tuple[str, ...] = ("00", "01"), windows: int = 12, seed: int = 0,
    labelled: float = 1.0, winner: str | None = None,
) -> Path:
    """``labelled`` is the share of windows whose ctx.light is given; in the others only the frame statistics
    tell dark from bright, which a lookup by condition labels cannot learn. ``winner`` makes one extractor
    best in every window."""
    rng = np.random.default_rng(seed)
    rows: list[dict[str, object]] = []
    for seq in sequences:
        for k in range(windows):
            for corruption in ("none", "dark"):
                dark = corruption == "dark"
                light = ("dark" if dark else "bright") if rng.uniform() < labelled else ""
                mean = (40.0 if dark else 120.0) + rng.normal(0, 5)
                window = []
                for x in vocab.extractors:
                    spec = vocab.extractor(x)
                    for c in range(3):
                        theta = spec.defaults()
                        for name, p in spec.parameters.items():
                            if p.tunable and p.datatype != "boolean" and p.min is not None and p.max is not None:
                                lo, hi = float(p.min), float(p.max)
                                frac = [0.05, 0.15, 0.3][c]
                                v = lo + frac * (hi - lo)
                                theta[name] = int(round(v)) if p.datatype == "integer" else v
                        # ATE planted: dark favours low thresholds (c == 0) and ORB; bright favours c == 2 and SIFT
                        good = (c == 0) if dark else (c == 2)
                        base = {"ORB": 0.5 if dark else 1.0, "SIFT": 1.0 if dark else 0.4}.get(x, 1.5)
                        if winner is not None:
                            base = 0.2 if x == winner else 1.0
                        failed = int(x == "BRISK" and c == 1)
                        ate = base * (0.6 if good else 1.0) + rng.uniform(0, 0.05)
                        window.append((x, c, theta, None if failed else ate, failed))
                ok = [r for r in window if not r[4]]
                best = min(ok, key=lambda r: r[3])
                best_x = {x: min((r for r in ok if r[0] == x), key=lambda r: r[3]) for x in {r[0] for r in ok}}
                for r in window:
                    x, c, theta, ate, failed = r
                    rows.append({
                        "dataset": "kitti", "sequence": seq, "corruption": corruption, "severity": 1 if dark else "",
                        "seed": 0, "window_start": k * 10, "window_end": k * 10 + 10, "frames": 10,
                        "ctx.agent": "car", "ctx.motion": "", "ctx.scene": "outdoor", "ctx.light": light,
                        "ctx.reflectance": "", "ctx.texture": "", "extractor": x, "params": json.dumps(theta),
                        "ate_rmse": "" if ate is None else round(ate, 4), "rpe_rmse": 0.1, "tracking_lost": 0,
                        "failed": failed, "mean_matches": 100, "mean_inliers": 80, "mean_keypoints": 500,
                        "extraction_ms": 5.0, "matching_ms": 1.0, "width": 1241, "height": 376,
                        **{f"m.{m}": round(float(rng.uniform(0, 1)), 3) for m in METRICS},
                        "stat.mean": round(mean, 3), "stat.contrast": round(float(rng.uniform(10, 50)), 3),
                        "best_overall": int(r is best), "best_for_extractor": int(best_x.get(x) is r),
                    })  # fmt: skip
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=columns())
        w.writeheader()
        w.writerows(rows)
    return path
