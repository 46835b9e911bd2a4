from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.conftest import run_cli


@pytest.mark.slow
def test_nfex_sweep_tiny_then_resume(cli_env: dict[str, str], data_dir: Path, tmp_path: Path) -> None:
    csv = tmp_path / "t.csv"
    args = ["sweep", str(data_dir / "kitti"), "--sequence", "00", "-x", "ORB", "--sample", "1", "--window", "3",
            "--max-windows", "1", "--csv", str(csv), "--workers", "1", "--json", "--no-progress",
            "--export", str(tmp_path / "m.ttl")]
    first = run_cli(args, cli_env)
    assert first.returncode == 0, first.stderr
    assert json.loads(first.stdout)["ran"] == 1 and csv.exists() and (tmp_path / "m.ttl").exists()
    again = run_cli(args, cli_env)
    assert again.returncode == 0 and json.loads(again.stdout)["skipped"] == 1
    q = run_cli(["sparql", "SELECT ?m WHERE { ?m a nfex:Measurement ; nfex:underCondition nfex:agent_car ; nfex:frameCount 3 }",
                 "--format", "csv"], cli_env)
    assert q.returncode == 0 and q.stdout.count("meas_") == 1


def test_nfex_sweep_bad_input_exits_2(cli_env: dict[str, str], tmp_path: Path) -> None:
    r = run_cli(["sweep", str(tmp_path / "nowhere")], cli_env)
    assert r.returncode == 2 and "not a folder" in r.stderr
