"""Parity of the verification stage: one stream of pair evidence gets the same verdicts from a ``PairJudge`` in
process as from a real ``nfex serve`` session's ``/verdict``, with and without a budget (the budget window)."""
from __future__ import annotations

import json
import math
import shutil
from pathlib import Path
from typing import Any

import cv2
import httpx
import numpy as np
import pytest
from nfex_slam.pairs import NEXT, PairEvidence

from nfex_core.advisor import Advisor
from nfex_core.config import Settings
from nfex_core.kg import KnowledgeGraph
from nfex_core.rules.dsl import programs
from nfex_core.verification import PairJudge, judge
from tests.conftest import stop_process

from .conftest import start_service

ROOT = Path(__file__).resolve().parents[2]
FRAMES = 8


def _estimate(rng: np.random.Generator, k: int) -> dict[str, Any]:
    """A reported estimate: lost now and then, else a small yaw and heading, wild on some tries (so that pairs
    escalate, fall back and accept)."""
    if rng.random() < 0.1:
        return {"R": None, "t": None, "rejected": "too few matches"}
    wild = rng.random() < 0.5
    a = math.radians(rng.normal(0.3, 0.1) + (40.0 * (k + 1) if wild else 0.0))
    h = math.radians(rng.normal(1.0, 0.3) + (90.0 + 30 * k if wild else 0.0))
    R = np.array([[math.cos(a), 0, math.sin(a)], [0, 1, 0], [-math.sin(a), 0, math.cos(a)]])
    t = -R @ np.array([math.sin(h), 0.0, math.cos(h)])
    return {"R": R.tolist(), "t": t.tolist(), "rejected": ""}


def _evidence(extractor: str, params: dict[str, Any], est: dict[str, Any]) -> PairEvidence:
    """What the route makes of a reported estimate (service/routes/sessions.py ``_evidence``)."""
    measured = {"keypoints": 2000, "matches": 600, "inliers": 400, "parallax_px": 8.0, "extraction_ms": 5.0}
    if est["R"] is None:
        return PairEvidence(extractor, dict(params), rejected=est["rejected"], **measured)
    t = np.asarray(est["t"], dtype=float)
    return PairEvidence.of(extractor, params, np.asarray(est["R"], dtype=float), t / np.linalg.norm(t), **measured)


def _stores(template: Path, settings: Settings, tmp_path: Path) -> tuple[Path, Path]:
    out = []
    for name in ("served", "local"):
        shutil.copytree(template, tmp_path / name, ignore=shutil.ignore_patterns("LOCK"))
        kg = KnowledgeGraph.open(str(tmp_path / name), settings=settings)
        try:
            p, graph = programs.load(ROOT / "rules" / "verification" / "verification.nfex", kg.vocabulary(), settings)
            programs.apply(kg, graph, p.name, author="pytest")
        finally:
            kg.close()
        out.append(tmp_path / name)
    return out[0], out[1]


def _stream(url: str, advisor: Advisor, frames: list[np.ndarray], context: dict[str, Any], seed: int) -> tuple[list[Any], int]:
    """Each frame to the session and to the in-process advisor; each pair's tries to /verdict and to the PairJudge.
    Returns both sides' verdicts and how many escalations the budget window cut."""
    sid = httpx.post(url + "/v1/sessions", json={"context": {"agent": context["agent"]}}).json()["id"]
    pj = PairJudge(advisor.snapshot().table.budget_terms)
    rng = np.random.default_rng(seed)
    state, out, cut = None, [], 0
    for i, image in enumerate(frames):
        ok, buf = cv2.imencode(".png", image)
        r = httpx.post(f"{url}/v1/sessions/{sid}/frames", files={"frame": ("f.png", bytes(buf), "image/png")},
                       data={"context": json.dumps(context)}, timeout=120)
        assert r.status_code == 200, r.text
        served = r.json()["verification"]
        sel = advisor.select(dict(context), image, state, session=True, verdict_held=pj.held)
        state = sel.state
        pj.begin(sel)
        assert [(p["extractor"], p["params"]) for p in served["proposals"]] == [(c.extractor, c.params) for c in sel.proposals]
        if i == 0:
            continue
        proposals = list(sel.proposals)
        tried: list[dict[str, Any]] = []
        while True:
            c = proposals[len(tried)]
            tried.append({"extractor": c.extractor, "params": c.params, "keypoints": 2000, "matches": 600, "inliers": 400,
                          "parallax_px": 8.0, "extraction_ms": 5.0, **_estimate(rng, len(tried))})
            evidence = [_evidence(t["extractor"], t["params"], t) for t in tried]
            alone = judge(pj.policy, evidence, pj.prior, len(proposals) - len(tried))
            mine = pj.judge(evidence)
            cut += alone.action == NEXT and mine.action != NEXT
            theirs = httpx.post(f"{url}/v1/sessions/{sid}/verdict", json={"tried": tried}, timeout=30).json()
            out.append(((mine.action, mine.accepted, mine.reason), (theirs["action"], theirs.get("accepted"), theirs["reason"])))
            if mine.action != NEXT:
                break
    return out, cut


@pytest.mark.slow
def test_the_same_pair_evidence_gets_the_same_verdicts_in_process_and_from_a_session(
        shipped_template: tuple[Path, Settings], data_dir: Path, tmp_path: Path) -> None:
    served, local = _stores(*shipped_template, tmp_path)
    images = [cv2.imread(str(data_dir / "kitti" / "sequences" / "00" / "image_0" / f"{i:06d}.png"), cv2.IMREAD_GRAYSCALE)
              for i in range(FRAMES)]
    svc = start_service(str(served), tmp_path / "service.log")
    kg = KnowledgeGraph.open(str(local), settings=shipped_template[1])
    advisor = Advisor(kg)
    try:
        plain, _ = _stream(svc.url, advisor, images, {"agent": "car"}, seed=1)
        budgeted, cut = _stream(svc.url, advisor, images, {"agent": "car", "budget_ms": 20}, seed=1)
    finally:
        stop_process(svc.proc)
        advisor.close()
        kg.close()
    for verdicts in (plain, budgeted):
        assert [m for m, _ in verdicts] == [s for _, s in verdicts]
        assert {m[0] for m, _ in verdicts} >= {"accept", "next"}
    assert cut > 0  # the window let some escalations through and decided other pairs on the tries made
