"""Seed spread of the VO's monocular ATE: std/mean over runs that differ only by the RANSAC seed.

    python bench/seed_spread.py [--code CHECKOUT] [--scale map|triangulated|...] [--sequences 00,01,07]
        [--configs SIFT,ORB_GRID] [--params JSON] [--runs 10] [--frames N] [--checks] [--jobs 16] [--out spread.json]

For each KITTI sequence and configuration (the extractor's defaults, or with ``--params``: those parameters, e.g.
``'{"nfeatures": 1500}'``, for every configuration) it runs ``run_vo`` ``--runs`` times with
``VOParams(seed=r)``, r = 0 … runs−1, no front-end checks (``--checks``: the sequence's agent's, as ``nfex evaluate``
applies them by default), over the whole shared sequence (or its first ``--frames``),
and reports per cell the Sim(3) ATE RMSE of each run, their mean, std and spread = std/mean (population std), and
the lost pairs; and where the runs' error comes from: each run's Sim(3)-aligned position error e_r(t) is split into
the part every run shares and the part its seed adds (e_r(t) minus the runs' mean at frame t), each an RMS over
frames: "shared" and "by seed" (m, ``_split``; shared² + by seed² = the runs' mean ATE²). The larger the seed's
part against the shared one, the larger std/mean. "path m" is the ground truth's length over the frames run.
``--code`` is the checkout whose ``nfex_core`` and ``nfex_slam`` run (default: this one), so the same script
measures another implementation, e.g. main's; ``--scale`` is passed to ``VOParams`` only when given (a checkout
without the option keeps its own default). Runs of one cell share one worker process and its
extraction cache: identical images and configuration give identical features, so only the first run extracts.
``--jobs`` cells run at once (a process pool; each worker imports from ``--code``). Each run's line goes to stderr
as it ends; ``--summarise FILE ...`` prints the table from such lines, or from the JSON ``--out`` writes, instead of
running (a measurement stopped before its last cell, with each cell's runs counted; "shared" and "by seed" only
for a cell read whole from one JSON: they need the runs' errors, which neither keeps), and with ``--against JSON``
each cell's runs beside the same seeds' runs there: that mean, in how many seeds this one's ATE is lower, and
Wilcoxon's signed-rank test (two-sided, exact) over the seeds both have.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent


def _use(code: str) -> None:
    """Import nfex_core and nfex_slam from checkout ``code`` in this (fresh, spawned) process."""
    for p in (code, os.path.join(code, "clients", "slam")):
        sys.path.insert(0, p)


class _Cached:
    """The registry's extract and resolve, with extraction memoised on (extractor, params, image bytes)."""

    def __init__(self, registry: Any) -> None:
        self.registry, self.cache = registry, {}  # type: ignore[var-annotated]

    def extract(self, name: str, image: Any, params: Any = None) -> Any:
        key = (name, json.dumps(params or {}, sort_keys=True, default=str), image.shape,
               hashlib.blake2b(image.tobytes(), digest_size=16).hexdigest())
        if key not in self.cache:
            self.cache[key] = self.registry.extract(name, image, params)
        return self.cache[key]

    def resolve(self, name: str, params: Any = None) -> Any:
        return self.registry.resolve(name, params)


def label(extractor: str, params: dict[str, Any] | None) -> str:
    """A configuration's name in tables: ``orb_grid-default``, ``orb_grid-nfeatures=1500`` (the parameters as
    given: ``{"nfeatures": 500}`` is named apart from the default it equals)."""
    return f"{extractor.lower()}-" + (",".join(f"{k}={v}" for k, v in sorted(params.items())) if params else "default")


def check(code: str, extractor: str, params: dict[str, Any] | None) -> str | None:
    """Why ``extractor`` with ``params`` cannot run (an unknown extractor or parameter, a value out of range), or None."""
    _use(code)
    from nfex_core.errors import NfexError
    from nfex_core.knowledge import open_graph
    from nfex_core.vision.registry import ExtractorRegistry

    registry = ExtractorRegistry.from_vocabulary(open_graph(tempfile.mkdtemp(prefix="nfex-spread-")).vocabulary())
    try:
        registry.resolve(extractor, params)
    except NfexError as e:
        return f"{extractor}: {e}"
    return None


def cell(code: str, data: str, sequence: str, extractor: str, runs: int, frames: int | None, scale: str | None,
         checks: bool = False, params: dict[str, Any] | None = None) -> dict[str, Any]:
    """Every run of one (sequence, configuration) cell in this process."""
    _use(code)
    import numpy as np
    from nfex_slam.datasets import ArraySequence, open_sequence
    from nfex_slam.trajectory import from_sequence
    from nfex_slam.vo import VOParams, fixed, run_vo, window_errors

    from nfex_core.knowledge import open_graph
    from nfex_core.vision.registry import ExtractorRegistry

    kg = open_graph(tempfile.mkdtemp(prefix="nfex-spread-"))
    registry = _Cached(ExtractorRegistry.from_vocabulary(kg.vocabulary()))
    seq = open_sequence(data, "kitti", sequence)
    step_checks: Any = None
    if checks:  # the sequence's agent's front-end checks, as nfex evaluate applies them by default
        from nfex_core.rules.engine import RuleEngine

        step_checks = RuleEngine(kg).table().step_checks.get(seq.context.get("agent") or "")
    n = len(seq) if frames is None else min(frames, len(seq))
    loaded = [seq[i] for i in range(n)]  # decode once for every run
    assert seq.poses is not None
    mem = ArraySequence(seq.dataset, seq.name, seq.intrinsics, [f.image for f in loaded], seq.timestamps[:n], seq.poses[:n],
                        seq.context)
    out: list[dict[str, Any]] = []
    errors: list[Any] = []  # each run's aligned position error, frames × 3
    for r in range(runs):
        t0 = time.perf_counter()
        vo = VOParams(seed=r) if scale is None else VOParams(seed=r, scale=scale)
        res = run_vo(mem, fixed(extractor, params), registry=registry, params=vo,
                     **({"checks": step_checks} if step_checks is not None else {}))
        ate = window_errors(mem, res)[0]
        if ate is not None:
            errors.append(_aligned_error(mem, res))
        out.append({"seed": r, "ate": ate, "lost": res.lost_count, "failed": res.failed, "s": time.perf_counter() - t0})
        print(f"{sequence} {label(extractor, params)} seed {r}: ATE {ate if ate is None else round(ate, 3)} m, "
              f"{res.lost_count} lost, {out[-1]['s']:.0f} s", file=sys.stderr, flush=True)
    ates = np.array([o["ate"] for o in out if o["ate"] is not None], float)
    mean = float(ates.mean()) if len(ates) else None
    std = float(ates.std()) if len(ates) else None
    return {"sequence": sequence, "config": label(extractor, params), "frames": n, "runs": out, "mean": mean,
            "std": std, "spread": std / mean if mean else None, "undefined": runs - len(ates), **_split(errors),
            "path": from_sequence(mem).path_length()}


def _aligned_error(seq: Any, res: Any) -> Any:
    """A run's position error after the Sim(3) alignment its ATE is taken with (frames × 3, metres)."""
    from nfex_slam.trajectory import Trajectory, associate_and_align, from_sequence

    r, e, _ = associate_and_align(from_sequence(seq), Trajectory(res.timestamps.copy(), res.poses.copy()), "sim3")
    return e.positions - r.positions


def _split(errors: list[Any]) -> dict[str, float | None]:
    """The error the runs share and the error each run's seed adds, as RMS over frames (m), from n runs' aligned errors
    e_r: by seed² = n/(n−1) · mean_r,t ‖e_r − ē‖² (ē the runs' mean at each frame), shared² = mean_t ‖ē‖² − by seed²/n
    (ē still carries 1/n of the seed's variance), so that shared² + by seed² = the runs' mean ATE². None without two
    runs of equal length."""
    import numpy as np

    n = len(errors)
    if n < 2 or len({e.shape for e in errors}) != 1:
        return {"shared": None, "by_seed": None}
    E = np.stack(errors)
    mean = E.mean(axis=0)
    seed2 = float(((E - mean) ** 2).sum(axis=-1).mean()) * n / (n - 1)
    shared2 = float((mean**2).sum(axis=-1).mean()) - seed2 / n
    return {"shared": float(np.sqrt(max(shared2, 0.0))), "by_seed": float(np.sqrt(seed2))}


_RUN = re.compile(r"^(\S+) (\S+) seed (\d+): ATE (\S+) m, (\d+) lost")


def summarise(logs: list[str]) -> list[dict[str, Any]]:
    """Cells from JSON written by ``--out``, or from the per-run lines ``cell`` writes to stderr (frames unknown: 0),
    in the order they first appear; a seed met again in a cell (the same run in another file) counts once."""
    import numpy as np

    cells: dict[tuple[str, str], list[dict[str, Any]]] = {}
    frames: dict[tuple[str, str], int] = {}
    split: dict[tuple[str, str], dict[str, Any]] = {}  # a cell read whole from one JSON keeps its shared / by seed
    paths: dict[tuple[str, str], float | None] = {}
    for log in logs:
        if log.endswith(".json"):
            for c in json.loads(Path(log).read_text())["cells"]:
                key = (c["sequence"], c["config"])
                if key in cells:
                    split.pop(key, None)
                else:
                    split[key] = {"shared": c.get("shared"), "by_seed": c.get("by_seed")}
                paths[key] = c.get("path")
                runs = cells.setdefault(key, [])
                runs.extend(r for r in c["runs"] if r["seed"] not in {o["seed"] for o in runs})
                frames[key] = c["frames"]
            continue
        for line in Path(log).read_text().splitlines():
            m = _RUN.match(line)
            if m:
                ate = None if m[4] == "None" else float(m[4])
                split.pop((m[1], m[2]), None)
                runs = cells.setdefault((m[1], m[2]), [])
                if int(m[3]) not in {o["seed"] for o in runs}:
                    runs.append({"seed": int(m[3]), "ate": ate, "lost": int(m[5])})
    out = []
    for (sequence, config), runs in cells.items():
        ates = np.array([r["ate"] for r in runs if r["ate"] is not None], float)
        mean = float(ates.mean()) if len(ates) else None
        std = float(ates.std()) if len(ates) else None
        out.append({"sequence": sequence, "config": config, "frames": frames.get((sequence, config), 0), "runs": runs,
                    "mean": mean, "std": std,
                    "spread": std / mean if mean else None, "undefined": len(runs) - len(ates),
                    **split.get((sequence, config), {}), "path": paths.get((sequence, config))})
    return out


def _print(cells: list[dict[str, Any]], against: list[dict[str, Any]] | None = None) -> None:
    fmt = (lambda v: f"{v:.3f}" if v is not None else "-")  # noqa: E731
    ref = {(c["sequence"], c["config"]): {r["seed"]: r["ate"] for r in c["runs"]} for c in against or []}
    w = max([18, *(len(c["config"]) for c in cells)])
    print(f"{'sequence':9} {'config':{w}} {'frames':>6} {'runs':>4} {'mean ATE':>9} {'std':>7} {'spread':>7} {'lost':>5}"
          f" {'shared':>7} {'by seed':>7} {'path m':>7}"
          + ("   against: mean ATE, lower in, Wilcoxon p" if against is not None else ""))
    for c in cells:
        lost = sum(r["lost"] for r in c["runs"])
        line = (f"{c['sequence']:9} {c['config']:{w}} {c['frames'] or '-':>6} {len(c['runs']):4d} {fmt(c['mean']):>9} "
                f"{fmt(c['std']):>7} {fmt(c['spread']):>7} {lost:5d} {fmt(c.get('shared')):>7} {fmt(c.get('by_seed')):>7} "
                f"{fmt(c.get('path')):>7}")
        other = ref.get((c["sequence"], c["config"]), {})
        pairs = [(r["ate"], other[r["seed"]]) for r in c["runs"] if r["ate"] is not None and other.get(r["seed"]) is not None]
        if against is not None and pairs:
            from scipy.stats import wilcoxon

            p = float(wilcoxon([a for a, _ in pairs], [b for _, b in pairs]).pvalue) if len(pairs) > 1 else float("nan")
            lower = sum(a < b for a, b in pairs)
            line += f"   {sum(b for _, b in pairs) / len(pairs):9.3f} {lower:3d} of {len(pairs):<3d} {p:.4f}"
        print(line)


def _params(text: str) -> dict[str, Any]:
    try:
        value = json.loads(text)
    except json.JSONDecodeError as e:
        raise argparse.ArgumentTypeError(f"not JSON: {e}") from None
    if not isinstance(value, dict):
        raise argparse.ArgumentTypeError("not a JSON object of parameter: value")
    odd = [k for k, v in value.items() if not isinstance(v, (bool, int, float, str)) or (isinstance(v, str) and " " in v)]
    if odd:
        raise argparse.ArgumentTypeError(f"a value must be a number, a boolean or a string without spaces: {', '.join(odd)}")
    return value


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--code", default=str(ROOT), help="checkout whose nfex_core and nfex_slam run (default: this one)")
    ap.add_argument("--data", default=None, help="KITTI folder (default: $NFEX_DATA/kitti, else ../shared/data/kitti)")
    ap.add_argument("--sequences", default="00,01,07")
    ap.add_argument("--configs", default="SIFT,ORB_GRID", help="extractors (with their default parameters unless --params)")
    ap.add_argument("--params", type=_params, default=None, metavar="JSON",
                    help="the configurations' parameters, as a JSON object (default: each extractor's defaults)")
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--frames", type=int, default=None)
    ap.add_argument("--scale", default=None, help="VOParams.scale (default: the checkout's own default)")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--checks", action="store_true", help="the sequence's agent's front-end checks (nfex evaluate's default)")
    ap.add_argument("--out", default=None, help="write the cells as JSON here")
    ap.add_argument("--summarise", nargs="+", default=None, metavar="FILE",
                    help="print the table from runs' stderr lines or --out JSON files")
    ap.add_argument("--against", default=None, metavar="JSON", help="with --summarise: compare with these runs, seed by seed")
    args = ap.parse_args()
    if args.summarise:
        print(f"from {', '.join(args.summarise)}: the runs each file holds"
              + (f"; against {args.against}, the same seeds" if args.against else ""))
        _print(summarise(args.summarise), json.loads(Path(args.against).read_text())["cells"] if args.against else None)
        return
    code = str(Path(args.code).resolve())
    data = args.data or str(Path(os.environ.get("NFEX_DATA", ROOT.parent / "shared" / "data")) / "kitti")
    cells = [(s, x) for s in args.sequences.split(",") for x in args.configs.split(",")]
    with ProcessPoolExecutor(max_workers=args.jobs, mp_context=get_context("spawn")) as pool:
        if args.params:  # a bad parameter stops the command before any run, not in a worker after others ran
            for why in pool.map(check, *zip(*[(code, x, args.params) for x in args.configs.split(",")], strict=True)):
                if why:
                    ap.error(why)
        futures = [pool.submit(cell, code, data, s, x, args.runs, args.frames, args.scale, args.checks,
                               args.params) for s, x in cells]
        results = [f.result() for f in futures]
    try:
        rev = subprocess.run(["git", "-C", code, "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    except OSError:
        rev = ""
    rev = rev or "revision unknown: not a git checkout, say which in the results"
    print(f"code {code} ({rev}), scale {args.scale or 'default'}, {args.runs} runs per cell, "
          + ("the agent's front-end checks" if args.checks else "no front-end checks"))
    _print(results)
    if args.out:
        Path(args.out).write_text(json.dumps({"code": code, "revision": rev, "scale": args.scale, "runs": args.runs,
                                              "checks": args.checks, "cells": results}, indent=1))


if __name__ == "__main__":
    main()
