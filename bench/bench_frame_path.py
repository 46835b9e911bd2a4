"""The frame path in process, one checkout against another: ``Advisor.select`` with a frame for every agent ×
budget on KITTI 00 and EuRoC frames, each checkout in its own process, the two alternating round by round.

    python bench/bench_frame_path.py --code <other checkout> [--rounds 3] [--frames 10]

Each round starts one process per checkout (this one, then ``--code``, then the order swapped next round); a
process seeds a fresh store, warms every row once, then times each row over ``--frames`` frames. Printed: per
row the median ms of each checkout over all rounds and their ratio (this / other). A ratio is a comparison on
one machine in one run, not a verdict: the machine is shared and noisy.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
AGENTS = ("car", "drone", "human")
BUDGETS = (None, 20.0)


def measure(frames: int) -> dict[str, list[float]]:
    """In this process (run with the checkout first on sys.path): row → ms per select."""
    from nfex_slam.datasets import open_sequence

    from nfex_core.advisor import Advisor
    from nfex_core.knowledge import open_graph

    data = Path(os.environ.get("NFEX_DATA", ROOT.parent / "shared" / "data"))
    euroc = sorted(p.name for p in (data / "euroc").iterdir() if p.is_dir())[0]
    images = {
        "KITTI 00": [open_sequence(data / "kitti", "kitti", "00")[i].image for i in range(0, 6 * frames, 6)],
        "EuRoC": [open_sequence(data / "euroc", "euroc", euroc)[i].image for i in range(0, 6 * frames, 6)],
    }
    advisor = Advisor(open_graph(str(Path(tempfile.mkdtemp(prefix="nfex-frame-path-")) / "store")))
    out: dict[str, list[float]] = {}
    for warm in (True, False):
        for name, fs in images.items():
            for agent in AGENTS:
                for budget in BUDGETS:
                    row = f"{name}, {agent}, {'20 ms' if budget else 'no budget'}"
                    for f in fs:
                        t = time.perf_counter()
                        advisor.select({"agent": agent}, f, budget_ms=budget)
                        if not warm:
                            out.setdefault(row, []).append((time.perf_counter() - t) * 1000)
    return out


def run(code: Path, frames: int) -> dict[str, list[float]]:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(code), str(code / "clients" / "slam")]))
    done = subprocess.run([sys.executable, __file__, "--child", str(frames)], env=env, capture_output=True, text=True,
                          check=True, cwd=code)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--code", type=Path, help="the other checkout")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--frames", type=int, default=10)
    ap.add_argument("--child", type=int, default=None, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child is not None:
        print(json.dumps(measure(args.child)))
        return
    if args.code is None:
        ap.error("--code: the checkout to compare with")
    this: dict[str, list[float]] = {}
    other: dict[str, list[float]] = {}
    for r in range(args.rounds):
        order = [(ROOT, this), (args.code.resolve(), other)]
        for code, into in order if r % 2 == 0 else order[::-1]:
            for row, ms in run(code, args.frames).items():
                into.setdefault(row, []).extend(ms)
    print(f"Advisor.select with a frame, {args.frames} frames × {args.rounds} rounds; this = {ROOT}, other = {args.code}")
    print(f"{'row':32s} {'this ms':>8s} {'other ms':>9s} {'ratio':>6s}")
    for row in this:
        a, b = statistics.median(this[row]), statistics.median(other.get(row, [float('nan')]))
        print(f"{row:32s} {a:8.2f} {b:9.2f} {a / b:6.2f}")


if __name__ == "__main__":
    main()
