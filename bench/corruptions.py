"""Milliseconds per frame of each corruption on KITTI 00 frames, and the ratio to loading the frame.

    PYTHONPATH=. python bench/corruptions.py [--frames 20] [--severity 0.5]
"""
from __future__ import annotations

import argparse
import time

from nfex_slam.datasets import corrupt, open_sequence
from nfex_slam.datasets.corruptions import NAMES

from nfex_core.config import Settings


def per_frame_ms(seq, n: int) -> float:  # type: ignore[no-untyped-def]
    t = time.perf_counter()
    for i in range(n):
        seq[i].image  # noqa: B018 - reading the frame is the work measured
    return (time.perf_counter() - t) / n * 1000.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--frames", type=int, default=20)
    ap.add_argument("--severity", type=float, default=0.5)
    args = ap.parse_args()
    seq = open_sequence(Settings.from_env().data / "kitti", "kitti", "00")
    base = per_frame_ms(seq, args.frames)
    print(f"{'load (baseline)':<16} {base:8.1f} ms/frame   1.0×")
    for name in NAMES:
        ms = per_frame_ms(corrupt(seq, name, args.severity), args.frames)
        print(f"{name:<16} {ms:8.1f} ms/frame  {ms / base:5.1f}×")


if __name__ == "__main__":
    main()
