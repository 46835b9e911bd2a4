"""Frames per second of the monocular VO per extractor (defaults) on real KITTI frames, with the local map and
two-view.

    python bench/bench_vo.py [--sequence 00] [--frames 30] [--repeat 2] [--extractors ORB,SIFT,AKAZE,BRISK,XFEAT]
        [--scales map,triangulated]

Runs ``nfex_slam.vo.run_vo`` with each extractor's default parameters over the first N frames (images
decoded once, before timing), once per ``VOParams.scale`` in ``--scales`` (``map``: the local map with its window
bundle adjustment; ``triangulated``: the two-view VO), and prints, per extractor and scale, frames per second of
the whole VO step, extraction and matching ms per frame, the ratio of its FPS to ORB's with the same scale, and
the map's FPS against the two-view VO's for the extractor — all measured in the same run.
An extractor whose backend cannot run here (XFeat without the `learned` extra) is listed with why.
"""
from __future__ import annotations

import argparse
import os
import tempfile
import time

from nfex_slam.datasets import ArraySequence, open_sequence
from nfex_slam.vo import VOParams, fixed, run_vo

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
    ap.add_argument("--scales", default="map,triangulated", help="VOParams.scale values to time (the first is the one compared)")
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
    scales = [x.strip() for x in args.scales.split(",") if x.strip()]
    print(f"{'extractor':10} {'scale':13} {'fps':>7} {'ms/frame':>9} {'extract':>8} {'match':>7} {'lost':>5} {'vs ORB':>7} "
          f"{'vs ' + scales[-1]:>16}")
    fps: dict[tuple[str, str], float] = {}
    absent = unavailable(kg.vocabulary().extractors)
    for x in [e.strip() for e in args.extractors.split(",") if e.strip()]:
        if x in absent:
            print(f"{x:10} skipped: {absent[x].detail}")
            continue
        for scale in reversed(scales):  # the baseline first, so that each line can name its ratio to it
            walls, res = [], None
            for _ in range(args.repeat):
                t0 = time.perf_counter()
                res = run_vo(mem, fixed(x), registry=registry, params=VOParams(scale=scale))
                walls.append(time.perf_counter() - t0)
            assert res is not None
            wall = min(walls)
            fps[x, scale] = len(frames) / wall
            ratio = fps[x, scale] / fps["ORB", scale] if ("ORB", scale) in fps else float("nan")
            base = fps[x, scale] / fps[x, scales[-1]]
            print(f"{x:10} {scale:13} {fps[x, scale]:7.1f} {1000 * wall / len(frames):9.1f} {res.mean('extraction_ms'):8.1f} "
                  f"{res.mean('matching_ms', skip_first=True):7.1f} {res.lost_count:5d} {ratio:7.2f}x {base:15.2f}x")


if __name__ == "__main__":
    main()
