"""``nfex ate`` as a user runs it: evo's published KITTI 00 figure, JSON output, one-line errors."""
from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest
from nfex_slam.trajectory import Trajectory, write_tum

from tests.conftest import run_cli


@pytest.fixture
def env() -> dict[str, str]:
    return dict(os.environ)


def test_kitti_00_orb_json(data_dir: Path, env: dict[str, str]) -> None:
    d = data_dir / "trajectories" / "evo"
    p = run_cli(
        ["ate", "--ref", str(d / "KITTI_00_gt.txt"), "--est", str(d / "KITTI_00_ORB.txt"), "--format", "kitti", "--json"],
        env,
    )
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout)
    assert out["rmse"] == pytest.approx(1.3034497, abs=1e-6)
    assert out["pairs"] == 4541 and out["align"] == "se3"
    for key in ("mean", "median", "max", "std", "min", "sse"):
        assert isinstance(out[key], float)


def test_table_sim3_and_rpe(tmp_path: Path, env: dict[str, str]) -> None:
    rng = np.random.default_rng(0)
    n = 50
    poses = np.tile(np.eye(4), (n, 1, 1))
    poses[:, :3, 3] = np.cumsum(rng.normal(size=(n, 3)), axis=0)
    ts = np.arange(n) * 0.1
    write_tum(tmp_path / "ref.txt", Trajectory(ts, poses))
    est = poses.copy()
    est[:, :3, 3] = 2.5 * poses[:, :3, 3] + 7.0  # a scaled, shifted copy: Sim(3) alignment removes it
    write_tum(tmp_path / "est.txt", Trajectory(ts + 0.003, est))
    args = ["ate", "--ref", str(tmp_path / "ref.txt"), "--est", str(tmp_path / "est.txt"), "--format", "tum"]
    p = run_cli([*args, "--align", "sim3", "--rpe-delta", "2"], env)
    assert p.returncode == 0, p.stderr
    assert "Sim(3)" in p.stdout and "scale  0.400000" in p.stdout and "RPE" in p.stdout
    rmse = float(next(line.split()[1] for line in p.stdout.splitlines() if line.strip().startswith("rmse")))
    assert rmse < 1e-6
    se3 = json.loads(run_cli([*args, "--align", "se3", "--json"], env).stdout)
    assert se3["rmse"] > 1.0 and se3["pairs"] == n
    # a stricter tolerance than the stamp offset associates nothing: a bad-input error
    p = run_cli([*args, "--t-max-diff", "0.001"], env)
    assert p.returncode == 2 and "no matching timestamps" in p.stderr


def test_bad_files_give_one_line_and_exit_2(tmp_path: Path, env: dict[str, str]) -> None:
    p = run_cli(["ate", "--ref", str(tmp_path / "missing.txt"), "--est", str(tmp_path / "x.txt"), "--format", "tum"], env)
    assert p.returncode == 2
    assert p.stderr.count("\n") == 1 and "missing.txt" in p.stderr
    bad = tmp_path / "bad.txt"
    bad.write_text("1 2 3 4\n")
    p = run_cli(["ate", "--ref", str(bad), "--est", str(bad), "--format", "kitti"], env)
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and "expected 12 numbers" in p.stderr
    p = run_cli(["ate", "--ref", str(bad), "--est", str(bad), "--format", "g2o"], env)
    assert p.returncode == 2


def test_usage_errors_exit_2(env: dict[str, str]) -> None:
    # a missing option or a non-number is a usage error (2), not an internal error (3)
    p = run_cli(["ate", "--ref", "a", "--est", "b"], env)
    assert p.returncode == 2 and "--format" in p.stderr
    p = run_cli(["ate", "--ref", "a", "--est", "b", "--format", "tum", "--t-max-diff", "abc"], env)
    assert p.returncode == 2 and "internal error" not in p.stderr
