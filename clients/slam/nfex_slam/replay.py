"""Replay a dataset sequence through the nFEX service, as a SLAM front end would use it.

    nfex-slam-replay --service http://127.0.0.1:8000 --format kitti --path ../shared/data/kitti \\
        --sequence 01 --out kitti01.tum [--window 50] [--context agent=car]

Per frame, the VO (``nfex_slam.vo.run_vo``) asks the service which extractor and parameters to run,
through one session (``POST /v1/sessions/{id}/frames``: the service keeps the previous frame for the
temporal metrics, as the in-process advisor does in ``nfex evaluate``). Where the graph's verification is in
force, the VO tries the frame's proposals in order and the service judges each pair
(``POST /v1/sessions/{id}/verdict``: accept, the next proposal, or the motion prior). The frame goes as a lossless
PNG, so the service scores exactly the pixels the in-process advisor would. After the run it reports
one feedback per window (ATE over the window, frames with tracking lost, mean inliers/matches/
keypoints, extraction time, under the configuration used on most of the window's frames), writes the
estimated trajectory in TUM format and prints the ATE, computed as ``nfex evaluate`` computes it
(``nfex_slam.vo.window_errors``). Each extractor runs from the recipe the service sends with the selection
and with each proposal (``opencv``: constructor, arguments, norm, grid, matcher; ``nfex_slam.features``) —
the code the server's registry runs too, so both sides find the same features without the client reading
the graph.
"""
from __future__ import annotations

import argparse
import json
import sys
from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from nfex_client import NfexClient

from .datasets import open_sequence
from .errors import BadInput
from .features import Features, Recipe, extract
from .pairs import PairEvidence, Verdict
from .trajectory import Trajectory, ate, write_tum
from .vo import Choice, Proposals, VOParams, run_vo, window_errors


class SelectionExtractors:
    """The VO's extractors (``nfex_slam.vo.Extractors``) from the service's answers: each (α, Θ′) the service
    named runs from the recipe it sent with it. Θ′ in a selection is the full parameter set, so ``resolve`` is
    the identity."""

    def __init__(self) -> None:
        self.recipes: dict[tuple[str, str], Recipe] = {}
        self.learned: set[tuple[str, str]] = set()  # named with a learned backend: no OpenCV recipe to run

    @staticmethod
    def _key(name: str, params: Mapping[str, Any] | None) -> tuple[str, str]:
        return name, json.dumps(dict(params or {}), sort_keys=True, default=str)

    def learn(self, name: str, params: Mapping[str, Any], opencv: Mapping[str, Any] | None) -> None:
        """Keep the recipe of (α, Θ′). One without an OpenCV constructor (a learned backend such as XFeat) is
        noted, not refused: a verification proposal may name it without the VO ever trying it."""
        if opencv and opencv.get("constructor"):
            self.recipes[self._key(name, params)] = Recipe.from_selection(opencv)
        elif opencv:
            self.learned.add(self._key(name, params))

    def extract(self, name: str, image: np.ndarray, params: Mapping[str, Any] | None = None) -> Features:
        key = self._key(name, params)
        recipe = self.recipes.get(key)
        if recipe is None and key in self.learned:
            raise BadInput(f"{name} runs on a learned backend, which this client cannot run from a recipe; "
                           "keep it out of the session (prune it with a rule)")
        if recipe is None:
            raise KeyError(f"the service sent no recipe for {name} with {dict(params or {})}")
        return extract(name, recipe, image)

    def resolve(self, name: str, params: Mapping[str, Any] | None = None) -> dict[str, Any]:
        return dict(params or {})


@dataclass
class ServiceChooser:
    """A VO chooser (``chooser(frame, history) -> (extractor, params)``) backed by a service session."""

    client: NfexClient
    session_id: str
    extractors: SelectionExtractors = field(default_factory=SelectionExtractors)
    selections: list[dict[str, Any]] = field(default_factory=list)

    def __call__(self, frame: Any, history: list[Any]) -> Choice | Proposals:
        sel = self.client.session_frame(self.session_id, frame.image, context=dict(frame.context) or None)
        self.selections.append({"frame": frame.index, "extractor": sel["extractor"], "params": sel["params"],
                                "pruned": [p["extractor"] for p in sel["pruned"]]})
        self.extractors.learn(sel["extractor"], sel["params"], sel.get("opencv"))
        verification = sel["verification"]
        if not verification["accept"]:
            return Choice(sel["extractor"], dict(sel["params"]))
        for p in verification["proposals"]:
            self.extractors.learn(p["extractor"], p["params"], p.get("opencv"))
        proposals = tuple(Choice(p["extractor"], dict(p["params"])) for p in verification["proposals"])
        return Proposals(proposals, self.judge)

    def judge(self, tried: list[PairEvidence], remaining: int) -> Verdict:
        """The pair's verdict from the service (POST /v1/sessions/{id}/verdict, which keeps the motion prior), for
        the VO."""
        out = self.client.verdict(self.session_id, [_tried(e) for e in tried])
        return Verdict(out["action"], out.get("accepted"), None, out["reason"])


def _tried(e: PairEvidence) -> dict[str, Any]:
    """A VO pair estimate as the service reads it: R and t = −R·d."""
    out: dict[str, Any] = {"extractor": e.extractor, "params": dict(e.params), "keypoints": e.keypoints, "matches": e.matches,
                           "inliers": e.inliers, "parallax_px": e.parallax_px, "extraction_ms": e.extraction_ms,
                           "rejected": e.rejected, "R": None, "t": None}
    if e.rotation is not None and e.direction is not None:
        R = e.matrix()
        out["R"], out["t"] = R.tolist(), (-R @ np.asarray(e.direction, dtype=float)).tolist()
    return out


def _ate(sequence: Any, result: Any) -> float | None:
    value, _ = window_errors(sequence, result)
    return None if value is None else float(value)


@dataclass
class ReplayResult:
    ate_rmse: float | None
    failed: bool
    frames: int
    lost: int
    trajectory: Path
    selections: list[dict[str, Any]]
    feedback: list[dict[str, Any]]


def _window_feedback(sequence: Any, result: Any, start: int, stop: int) -> dict[str, Any]:
    records = result.frames[start:stop]
    counts = Counter((r.extractor, tuple(sorted(r.params.items()))) for r in records)
    (extractor, params), _ = counts.most_common(1)[0]
    fields: dict[str, Any] = {
        "extractor": extractor, "params": dict(params), "window_start": records[0].index, "window_end": records[-1].index + 1,
        "tracking_lost": sum(1 for r in records if r.lost), "mean_keypoints": float(np.mean([r.keypoints for r in records])),
        "extraction_ms": float(np.mean([r.extraction_ms for r in records])),
    }
    pairs = records[1:] if start == 0 else records
    if pairs:
        fields["mean_matches"] = float(np.mean([r.matches for r in pairs]))
        fields["mean_inliers"] = float(np.mean([r.inliers for r in pairs]))
    if sequence.poses is not None and stop - start >= 3:
        gt = Trajectory(sequence.timestamps[start:stop], sequence.poses[start:stop])
        est = Trajectory(result.timestamps[start:stop], result.poses[start:stop])
        if not any(r.lost for r in records):
            fields["ate_rmse"] = float(ate(gt, est, align="sim3").rmse)
    fields["tracking_failed"] = fields["tracking_lost"] > result.max_lost_fraction * max(1, len(pairs))
    return fields


def replay(
    base_url: str,
    sequence: Any,
    out: Path,
    *,
    context: Mapping[str, str] | None = None,
    window: int | None = None,
    frames: int | None = None,
    report: bool = True,
    client: NfexClient | None = None,
    seed: int = 0,
    token: str | None = None,
) -> ReplayResult:
    """Run the VO over ``sequence`` through a session; report feedback per window; write TUM; return ATE.

    ``seed`` is the VO's RANSAC draw (``VOParams.seed``): with seed r the run is the one ``nfex evaluate``
    makes as its run r, so both print the same ATE on the same graph. Feedback needs ``token`` with the
    reporter role (or a ``client`` built with one)."""
    own = client is None
    client = client or NfexClient(base_url, token=token)
    try:
        ctx = {**{k: v for k, v in sequence.context.items() if v}, **dict(context or {})}
        session = client.open_session(ctx, client="nfex-slam-replay")
        chooser = ServiceChooser(client, session["id"])
        try:
            result = run_vo(sequence, chooser, registry=chooser.extractors, stop=frames, params=VOParams(seed=seed))
            feedback: list[dict[str, Any]] = []
            n = len(result.frames)
            size = window or n
            if report:
                for start in range(0, n, size):
                    fields = _window_feedback(sequence, result, start, min(n, start + size))
                    fields.update(sequence=sequence.key, dataset=sequence.dataset, session_id=session["id"])
                    feedback.append({**fields, "iri": client.feedback(**fields)["iri"]})
        finally:
            client.close_session(session["id"])
        write_tum(out, Trajectory(result.timestamps, result.poses))
        ate_rmse = None if result.failed else _ate(sequence, result)
        return ReplayResult(ate_rmse, result.failed, n, result.lost_count, out, chooser.selections, feedback)
    finally:
        if own:
            client.close()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--service", default="http://127.0.0.1:8000")
    ap.add_argument("--format", required=True, choices=["kitti", "euroc", "tum", "handheld"])
    ap.add_argument("--path", required=True, type=Path)
    ap.add_argument("--sequence")
    ap.add_argument("--out", required=True, type=Path, help="estimated trajectory, TUM format")
    ap.add_argument("--window", type=int, help="frames per feedback window (default: the whole run)")
    ap.add_argument("--frames", type=int, help="replay only the first N frames")
    ap.add_argument("--context", action="append", default=[], metavar="DIM=VALUE")
    ap.add_argument("--no-feedback", action="store_true")
    ap.add_argument("--token-file", type=Path, help="a file holding a bearer token with the reporter role (for feedback)")
    ap.add_argument("--seed", type=int, default=0, help="RANSAC draw: `nfex evaluate`'s run number (default 0)")
    args = ap.parse_args(argv)
    context = dict(item.split("=", 1) for item in args.context)
    seq = open_sequence(args.path, args.format, args.sequence)
    res = replay(args.service, seq, args.out, context=context, window=args.window, frames=args.frames,
                 report=not args.no_feedback, seed=args.seed,
                 token=args.token_file.read_text().strip() if args.token_file else None)
    used = Counter(s["extractor"] for s in res.selections)
    print(f"{seq.key}: {res.frames} frames, {res.lost} lost, extractors {dict(used)}, trajectory {res.trajectory}")
    for fb in res.feedback:
        print(f"feedback {fb['window_start']}-{fb['window_end']}: {fb['extractor']} ate={fb.get('ate_rmse')} -> {fb['iri']}")
    print("ATE RMSE: failed" if res.ate_rmse is None else f"ATE RMSE: {res.ate_rmse:.6f} m")
    return 1 if res.failed else 0


if __name__ == "__main__":
    sys.exit(main())
