"""On what size of image F_metrics gives the same decision: α* scored at full, half and quarter resolution.

    python bench/bench_resolution.py [--step 10] [--out docs/results/resolution.json]

For frames of every shared sequence (KITTI 00, 01, 07 at 1241×376; EuRoC V1_01 at 752×480; the handheld
checkerboard JPEGs at 752×480; every --step-th frame) and every agent (car, drone, human) with and without a
20 ms budget, the advisor (symbolic: F_metrics + H·A decide) scores the candidates on a copy of the frame of
several sizes — the full frame, half and quarter of its side, and the fixed pixel counts QVGA (320×240) and
QQVGA (160×120) — and the bench reports, per size, how often α* equals α* at full resolution, the mean
extractions and pixels per selection, and the mean selection time. Single frames (no temporal metrics).
Θ′ does not depend on the scoring size (it is fitted at the frame's size); only α* can change.
"""
from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from nfex_core.advisor import Advisor  # noqa: E402
from nfex_core.config import Settings  # noqa: E402
from nfex_core.knowledge import open_graph  # noqa: E402

CONTEXTS: dict[str, dict[str, object]] = {
    f"{agent}{' 20 ms' if budget else ''}": {"agent": agent, **({"budget_ms": 20} if budget else {})}
    for agent in ("car", "drone", "human") for budget in (False, True)
}
SIZES = ("full", "half", "quarter", "QVGA", "QQVGA")


def sequences(data: Path, step: int) -> dict[str, list[np.ndarray]]:
    folders = {"KITTI 00": data / "kitti/sequences/00/image_0", "KITTI 01": data / "kitti/sequences/01/image_0",
               "KITTI 07": data / "kitti/sequences/07/image_0"}
    out = {name: sorted(f.glob("*.png"))[::step] for name, f in folders.items()}
    out["EuRoC V1_01"] = sorted((data / "euroc").rglob("cam0/data/*.png"))[::step]
    out["handheld"] = sorted((data / "handheld/checkerboard/images").glob("*.jpg"))[:: step * 4]
    return {k: [cv2.imread(str(p), cv2.IMREAD_GRAYSCALE) for p in v] for k, v in out.items() if v}


def pixels_for(size: str, image: np.ndarray) -> int:
    n = int(image.shape[0] * image.shape[1])
    return {"full": n, "half": n // 4, "quarter": n // 16, "QVGA": 320 * 240, "QQVGA": 160 * 120}[size]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--step", type=int, default=10, help="every step-th frame of each sequence (handheld: 4×step)")
    ap.add_argument("--out", type=Path, default=ROOT / "docs/results/resolution.json")
    args = ap.parse_args()
    kg = open_graph(str(Path(tempfile.mkdtemp(prefix="nfex-bench-resolution-")) / "store"))
    advisor = Advisor(kg, neural="symbolic")
    frames = sequences(Settings.from_env().data, args.step)
    rows: dict[str, dict[str, list[float]]] = {s: {"agree": [], "ms": [], "extractions": [], "pixels": []} for s in SIZES}
    per_sequence: dict[str, dict[str, list[float]]] = {}
    disagreements = []
    for name, images in frames.items():
        for i, image in enumerate(images):
            for label, ctx in CONTEXTS.items():
                answers = {}
                for size in SIZES:
                    advisor.scorer.score_pixels = pixels_for(size, image)
                    t = time.perf_counter()
                    sel = advisor.select(ctx, image)
                    ms = (time.perf_counter() - t) * 1000
                    assert sel.scoring is not None
                    answers[size] = sel.extractor
                    r = rows[size]
                    r["ms"].append(ms)
                    r["extractions"].append(sel.scoring.extractions)
                    r["pixels"].append(sel.scoring.pixels)
                    agree = float(sel.extractor == answers["full"])
                    r["agree"].append(agree)
                    per_sequence.setdefault(name, {}).setdefault(size, []).append(agree)
                if len(set(answers.values())) > 1:
                    disagreements.append({"sequence": name, "frame": i * args.step, "context": label, "alpha": answers})
    summary = {size: {"alpha_agreement_with_full": round(statistics.mean(r["agree"]), 4),
                      "selections": len(r["agree"]),
                      "mean_ms": round(statistics.mean(r["ms"]), 3),
                      "mean_extractions": round(statistics.mean(r["extractions"]), 3),
                      "mean_pixels_extracted": round(statistics.mean(r["pixels"]))}
               for size, r in rows.items()}
    out = {"command": "python bench/bench_resolution.py " + " ".join(sys.argv[1:]),
           "frames": {k: len(v) for k, v in frames.items()}, "contexts": CONTEXTS, "summary": summary,
           "agreement_per_sequence": {k: {s: round(statistics.mean(v), 4) for s, v in d.items()} for k, d in per_sequence.items()},
           "disagreements": disagreements}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(out, indent=1, ensure_ascii=False) + "\n")
    print(f"{'size':<8} {'α* = full':>10} {'ms':>8} {'extractions':>12} {'pixels':>10}")
    for size, s in summary.items():
        print(f"{size:<8} {s['alpha_agreement_with_full']:>10.3f} {s['mean_ms']:>8.2f} {s['mean_extractions']:>12.2f} "
              f"{s['mean_pixels_extracted']:>10}")
    kg.close()


if __name__ == "__main__":
    main()
