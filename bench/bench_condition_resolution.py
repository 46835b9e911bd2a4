"""Could the frame statistics run on the scoring copy? The condition estimates on it against the 320-px analysis copy.

    python bench/bench_condition_resolution.py [--frames 200]

For the first --frames consecutive frames of KITTI 00, KITTI 07, EuRoC V1_01 and the handheld JPEGs (as a stream:
the motion estimate reads the previous frame's copy), the frame statistics are computed on the 320-px analysis copy
the context thresholds were calibrated on (``vision.statistics.analysis_image``) and on the advisor's 160×120 scoring
copy (``advisor.scoring.downscale``); printed per sequence: how often each estimated dimension (light, texture,
motion, reflectance) is the same on both, and the mean ms per frame of each (resize + statistics, this process).
"""
from __future__ import annotations

import argparse
import sys
import time
from collections import Counter
from pathlib import Path

import cv2

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "clients" / "slam"))

from nfex_core.advisor.scoring import SCORE_PIXELS, downscale  # noqa: E402
from nfex_core.config import Settings  # noqa: E402
from nfex_core.vision import context, statistics  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=200)
    args = ap.parse_args()
    data = Settings.from_env().data
    seqs = {"KITTI 00": sorted((data / "kitti/sequences/00/image_0").glob("*.png")),
            "KITTI 07": sorted((data / "kitti/sequences/07/image_0").glob("*.png")),
            "EuRoC V1_01": sorted((data / "euroc").rglob("cam0/data/*.png")),
            "handheld": sorted((data / "handheld/checkerboard/images").glob("*.jpg"))}
    copies = {"320-px analysis copy": statistics.analysis_image, "scoring copy": lambda im: downscale(im, SCORE_PIXELS)}
    for name, paths in seqs.items():
        same: Counter[str] = Counter()
        ms: Counter[str] = Counter()
        previous: dict[str, object] = {}
        paths = paths[: args.frames]
        for p in paths:
            image = cv2.imread(str(p), cv2.IMREAD_GRAYSCALE)
            labels = {}
            for kind, make in copies.items():
                t0 = time.perf_counter()
                a = make(image)
                s = statistics.frame_statistics(image, analysis=a, previous_analysis=previous.get(kind))  # type: ignore[arg-type]
                ms[kind] += (time.perf_counter() - t0) * 1000
                labels[kind] = {d: est(s, kind in previous)[0] for d, est in context.ESTIMATORS.items()}
                previous[kind] = a
            first, second = labels.values()
            same.update(d for d in first if first[d] == second[d])
        n = len(paths)
        print(f"{name:12s} {n:4d} frames  same estimate: " + ", ".join(f"{d} {same[d] / n:.0%}" for d in context.ESTIMATORS)
              + "  ms/frame: " + ", ".join(f"{k} {v / n:.2f}" for k, v in ms.items()))


if __name__ == "__main__":
    main()
