"""Frames per second of the monocular VO per extractor (defaults) on real KITTI frames.

    python bench/bench_vo.py [--sequence 00] [--frames 30] [--repeat 2] [--extractors ORB,SIFT,AKAZE,BRISK,XFEAT]

Runs ``nfex_slam.vo.run_vo`` with each extractor's default parameters over the first N frames (images
decoded once, before timing) and prints, per extractor, frames per second of the whole VO step,
extraction and matching ms per frame, and the ratio of its FPS to ORB's measured in the same run.
An extractor whose backend cannot run here (XFeat without the `learned` extra) is listed with why.
"""
from __future__ import annotations

import argparse
import os
import tempfile
import time

from nfex_slam.datasets import ArraySequence, open_sequence
from nfex_slam.vo import fixed, run_vo

from nfex_core.config import Settings
from nfex_core.knowledge import open_graph
from nfex_core.vision.backends import unavailable
from nfex_core.vision.registry import ExtractorRegistry


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sequence", default="00")
    ap.add_argument("--frames", type=int, default=30)
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--extractors", default="ORB,SIFT,AKAZE,BRISK,XFEAT")
    args = ap.parse_args()

    kg = open_graph(tempfile.mkdtemp(prefix="nfex-bench-"))
    registry = ExtractorRegistry.from_vocabulary(kg.vocabulary())
    seq = open_sequence(Settings.from_env().data / "kitti", "kitti", args.sequence)
    frames = [seq[i] for i in range(min(args.frames, len(seq)))]  # decode once: time the VO, not PNG reading
    mem = ArraySequence(seq.dataset, seq.name, seq.intrinsics, [f.image for f in frames],
                        seq.timestamps[: len(frames)], seq.poses[: len(frames)] if seq.poses is not None else None)
    h, w = frames[0].image.shape
    print(f"KITTI {args.sequence}: {len(frames)} frames of {w}x{h}, best of {args.repeat}; "
          f"{os.cpu_count()} CPUs, load {os.getloadavg()[0]:.1f}")
    print(f"{'extractor':10} {'fps':>7} {'ms/frame':>9} {'extract':>8} {'match':>7} {'lost':>5} {'vs ORB':>7}")
    fps: dict[str, float] = {}
    absent = unavailable(kg.vocabulary().extractors)
    for x in [e.strip() for e in args.extractors.split(",") if e.strip()]:
        if x in absent:
            print(f"{x:10} skipped: {absent[x].detail}")
            continue
        walls, res = [], None
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            res = run_vo(mem, fixed(x), registry=registry)
            walls.append(time.perf_counter() - t0)
        assert res is not None
        wall = min(walls)
        fps[x] = len(frames) / wall
        ratio = fps[x] / fps["ORB"] if "ORB" in fps else float("nan")
        print(f"{x:10} {fps[x]:7.1f} {1000 * wall / len(frames):9.1f} {res.mean('extraction_ms'):8.1f} "
              f"{res.mean('matching_ms', skip_first=True):7.1f} {res.lost_count:5d} {ratio:7.2f}x")


if __name__ == "__main__":
    main()
