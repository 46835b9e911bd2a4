"""The SLAM replay client over real KITTI 01 frames against the running service."""
from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import pytest

from tests.service.conftest import REPORTER, Service

ROOT = Path(__file__).resolve().parent.parent.parent
sys.path.insert(0, str(ROOT / "clients" / "slam"))


@pytest.mark.slow
def test_replay_kitti01_through_a_session(service: Service, data_dir: Path, tmp_path: Path) -> None:
    from nfex_slam.datasets import open_sequence
    from nfex_slam.replay import replay
    from nfex_slam.trajectory import read_trajectory

    seq = open_sequence(data_dir / "kitti", "kitti", "01")
    before = service.version()
    res = replay(service.url, seq, tmp_path / "kitti01.tum", window=10, frames=20, token=REPORTER)
    assert res.frames == 20 and len(res.selections) == 20
    assert read_trajectory(tmp_path / "kitti01.tum", "tum").poses.shape == (20, 4, 4)
    assert len(res.feedback) == 2 and service.version() == before + 2
    assert res.failed or (res.ate_rmse is not None and res.ate_rmse >= 0)


def _replay_and_evaluate(template: Path, settings: Any, data_dir: Path, tmp_path: Path, frames: int,
                         *programs_: Path) -> tuple[Any, Any]:
    """The replay through a running service on one copy of ``template`` and `nfex evaluate`'s nfex run 0 on
    another, deciding as a session does (``programs_`` applied to both first)."""
    import shutil

    from nfex_slam.datasets import open_sequence
    from nfex_slam.replay import replay

    from nfex_core.evaluation import evaluate
    from nfex_core.kg import KnowledgeGraph
    from nfex_core.rules.dsl import programs
    from tests.conftest import stop_process
    from tests.service.conftest import start_service

    for name in ("served", "local"):
        shutil.copytree(template, tmp_path / name, ignore=shutil.ignore_patterns("LOCK"))
        for program in programs_:
            kg = KnowledgeGraph.open(str(tmp_path / name), settings=settings)
            try:
                p, graph = programs.load(program, kg.vocabulary(), settings)
                programs.apply(kg, graph, p.name, author="pytest")
            finally:
                kg.close()
    seq = open_sequence(data_dir / "kitti", "kitti", "01")
    svc = start_service(str(tmp_path / "served"), tmp_path / "service.log")
    try:
        res = replay(svc.url, seq, tmp_path / "kitti01.tum", frames=frames, report=False, seed=0)
    finally:
        stop_process(svc.proc)
    kg = KnowledgeGraph.open(str(tmp_path / "local"), settings=settings)
    try:
        [run] = evaluate(seq, kg, methods=["nfex"], runs=1, frames=frames, session=True, control=False).records
    finally:
        kg.close()
    return res, run


@pytest.mark.slow
def test_replay_prints_the_ate_nfex_evaluate_reports(shipped_template: tuple[Path, Any], data_dir: Path, tmp_path: Path) -> None:
    """The issue's check: through a running service (its own copy of the shipped graph) the replay's ATE
    equals `nfex evaluate`'s for nfex (run 0) on another copy, frame for frame the same choices."""
    res, run = _replay_and_evaluate(*shipped_template, data_dir, tmp_path, 20)
    assert [s["extractor"] for s in res.selections] == [s["extractor"] for s in run.selections]
    assert [s["params"] for s in res.selections] == [s["params"] for s in run.selections]
    assert res.ate_rmse is not None and res.ate_rmse == pytest.approx(run.ate_rmse, abs=1e-9)


@pytest.mark.slow
def test_a_verified_replay_is_judged_by_the_service_as_nfex_evaluate_judges_it(shipped_template: tuple[Path, Any], data_dir: Path, tmp_path: Path) -> None:
    """With the learned verification program applied on both sides, the replay tries the frame's proposals and
    asks the service's /verdict after each; its trajectory equals `nfex evaluate`'s, pair by pair the same
    verdicts, so the HTTP protocol and the in-process loop are one policy."""
    program = ROOT / "rules" / "verification" / "verification.nfex"
    # this client runs OpenCV recipes only, so XFeat (a learned backend) is kept out of both sides' proposals
    opencv_only = tmp_path / "opencv_only.nfex"
    opencv_only.write_text('program opencv_only\nprune XFEAT\n    because "the replay client runs OpenCV recipes only"\n')
    res, run = _replay_and_evaluate(*shipped_template, data_dir, tmp_path, 12, program, opencv_only)
    assert run.result is not None and run.tries > 1  # the loop did escalate: verification was in force
    assert [s["extractor"] for s in res.selections] == [s["extractor"] for s in run.selections]
    assert res.ate_rmse is not None and res.ate_rmse == pytest.approx(run.ate_rmse, abs=1e-9)


def test_a_proposal_on_a_learned_backend_is_noted_and_refused_only_when_run() -> None:
    """Regression: one verification proposal of XFeat (no OpenCV constructor in its recipe) made the replay
    fail on receipt, before the VO had tried anything; it now fails, with the reason, only if the VO runs it."""
    import numpy as np
    from nfex_slam.errors import BadInput
    from nfex_slam.replay import SelectionExtractors

    ex = SelectionExtractors()
    ex.learn("XFEAT", {"top_k": 4096}, {"constructor": "", "norm": "NORM_L2", "args": {"top_k": 4096}})
    ex.learn("ORB", {"nfeatures": 500}, {"constructor": "ORB_create", "norm": "NORM_HAMMING", "args": {"nfeatures": 500}})
    image = np.zeros((64, 64), np.uint8)
    assert ex.extract("ORB", image, {"nfeatures": 500}).xy.shape[1] == 2
    with pytest.raises(BadInput, match="XFEAT runs on a learned backend"):
        ex.extract("XFEAT", image, {"top_k": 4096})
