"""The SLAM replay client over real KITTI 01 frames against the running service.

Needs the VO, the loaders and the ATE (branches wt-vo / wt-data) and frame scoring (wt-vision); skips
where this build lacks them."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

from tests.service.conftest import Service

ROOT = Path(__file__).resolve().parent.parent.parent
sys.path.insert(0, str(ROOT / "clients" / "slam"))

pytest.importorskip("nfex_core.vo")
pytest.importorskip("nfex_core.datasets.kitti")
pytest.importorskip("nfex_core.trajectory")
pytest.importorskip("nfex_core.vision.metrics")
pytest.importorskip("nfex_core.vision.context")


@pytest.mark.slow
def test_replay_kitti01_through_a_session(service: Service, data_dir: Path, tmp_path: Path) -> None:
    from nfex_slam import replay

    from nfex_core.datasets import open_sequence
    from nfex_core.trajectory import read_trajectory

    seq = open_sequence(data_dir / "kitti", "kitti", "01")
    before = service.version()
    res = replay(service.url, seq, tmp_path / "kitti01.tum", window=10, frames=20)
    assert res.frames == 20 and len(res.selections) == 20
    assert read_trajectory(tmp_path / "kitti01.tum", "tum").poses.shape == (20, 4, 4)
    assert len(res.feedback) == 2 and service.version() == before + 2
    assert res.failed or (res.ate_rmse is not None and res.ate_rmse >= 0)
