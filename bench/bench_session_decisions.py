"""How often a session re-decides on real streams, with and without the dead band about the condition thresholds.

    python bench/bench_session_decisions.py [--context '{"agent": "car"}']

Every shared sequence (KITTI 00, 01, 07, EuRoC V1_01, the handheld JPEGs) is sent frame by frame as one session
(``Advisor.select(..., session=True)``, in process, symbolic advisor) twice: with the shipped
nfex:sessionConditionConfidence (a changed estimate counts only with at least that confidence) and with it set to
0 (every changed estimate counts). Printed per sequence: frames, decisions (frames not reused), the least number of
decisions nfex:sessionDecisionFrames allows (one per that many frames), extractions, and how often each estimated
dimension changed from one frame to the next. Counts, not times: the same on any machine.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
from collections import Counter
from pathlib import Path

import cv2

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "clients" / "slam"))

from nfex_core.advisor import Advisor  # noqa: E402
from nfex_core.advisor.reuse import ReuseTerms  # noqa: E402
from nfex_core.config import Settings  # noqa: E402
from nfex_core.knowledge import open_graph  # noqa: E402


def sequences(data: Path) -> dict[str, list[Path]]:
    out = {f"KITTI {s}": sorted((data / f"kitti/sequences/{s}/image_0").glob("*.png")) for s in ("00", "01", "07")}
    out["EuRoC V1_01"] = sorted((data / "euroc").rglob("cam0/data/*.png"))
    out["handheld"] = sorted((data / "handheld/checkerboard/images").glob("*.jpg"))
    return {k: v for k, v in out.items() if v}


def run(advisor: Advisor, paths: list[Path], context: dict[str, object]) -> dict[str, object]:
    state, decided, extractions, last = None, 0, 0, None
    flips: Counter[str] = Counter()
    for p in paths:
        sel = advisor.select(context, cv2.imread(str(p), cv2.IMREAD_GRAYSCALE), state, session=True)
        state = sel.state
        estimate = {e.dimension: e.value for e in sel.context if e.source == "estimated"}
        flips.update(d for d in estimate if last is not None and estimate[d] != last.get(d))
        last = estimate
        decided += sel.reused == 0
        extractions += sel.scoring.extractions if sel.scoring is not None else 0
    return {"decisions": decided, "extractions": extractions, "estimate changes": dict(sorted(flips.items()))}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--context", default='{"agent": "car"}', help="the session's context (JSON)")
    args = ap.parse_args()
    context = json.loads(args.context)
    kg = open_graph(str(Path(tempfile.mkdtemp(prefix="nfex-bench-sessions-")) / "store"))
    terms = ReuseTerms.load(kg)
    banded = Advisor(kg, neural="symbolic")
    rows = {name: {"frames": len(paths), "floor": math.ceil(len(paths) / max(1, terms.session)),
                   "dead band": run(banded, paths, context)} for name, paths in sequences(Settings.from_env().data).items()}
    kg.update("""PREFIX nfex: <https://w3id.org/nfex#> DELETE { nfex:sessionConditionConfidence nfex:value ?c }
                 INSERT { nfex:sessionConditionConfidence nfex:value 0.0 } WHERE { nfex:sessionConditionConfidence nfex:value ?c }""",
              author="bench")
    every = Advisor(kg, neural="symbolic")
    for name, paths in sequences(Settings.from_env().data).items():
        rows[name]["no band"] = run(every, paths, context)
    kg.close()
    print(f"context {context}; nfex:sessionConditionConfidence {terms.firm:g}, nfex:sessionConditionFrames {terms.hold}, "
          f"nfex:sessionDecisionFrames {terms.session}")
    print(f"{'sequence':12s} {'frames':>6s} {'floor':>5s} {'decisions (band / none)':>24s} {'extractions (band / none)':>26s}  "
          "estimate changes frame to frame")
    for name, r in rows.items():
        b, n = r["dead band"], r["no band"]
        print(f"{name:12s} {r['frames']:6d} {r['floor']:5d} {b['decisions']:>12d} / {n['decisions']:<9d} "  # type: ignore[index]
              f"{b['extractions']:>13d} / {n['extractions']:<10d}  {b['estimate changes']}")  # type: ignore[index]


if __name__ == "__main__":
    main()
