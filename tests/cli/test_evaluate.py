from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.conftest import run_cli


@pytest.mark.slow
def test_nfex_evaluate_json_and_files(cli_env: dict[str, str], data_dir: Path, tmp_path: Path) -> None:
    out = tmp_path / "ev"
    r = run_cli(["evaluate", str(data_dir / "kitti"), "--format", "kitti", "--sequence", "01", "--frames", "6",
                 "--methods", "orb-default,orb-dyn", "--runs", "1", "--out", str(out), "--json", "--no-plots"], cli_env)
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    assert doc["runs"] == 1 and doc["conditions"] == ["none"]
    m = doc["methods"]["orb-default"]["by_condition"]["none"]
    assert len(m["ate_runs"]) + m["failed_runs"] == 1 and m["extraction_ms_mean"] > 0
    assert set(doc["methods"]) == {"orb-default", "orb-dyn", "motion-prior"}  # the control joins every table
    assert "\n| Method |" in (out / "table.md").read_text()
    assert (out / "runs.csv").exists() and json.loads((out / "result.json").read_text())["sequence"] == "01"
    assert (out / "selections.csv").read_text().startswith("method,budget_ms")  # header only: no nfex run
    frames = (out / "frames.csv").read_text().splitlines()
    assert len(frames) == 1 + 3 * 6  # a header, then a row per method (and the control) and frame


def test_nfex_evaluate_unknown_method_exits_2(cli_env: dict[str, str], data_dir: Path, tmp_path: Path) -> None:
    r = run_cli(["evaluate", str(data_dir / "kitti"), "--sequence", "01", "--methods", "magic"], cli_env)
    assert r.returncode == 2 and "orb-default" in r.stderr


def test_nfex_evaluate_with_the_local_map(cli_env: dict[str, str], data_dir: Path, tmp_path: Path) -> None:
    r = run_cli(["evaluate", str(data_dir / "kitti"), "--sequence", "01", "--vo", "bundle"], cli_env)
    assert r.returncode == 2 and "two-view, map" in r.stderr
    r = run_cli(["evaluate", str(data_dir / "kitti"), "--sequence", "01", "--vo", "map", "-m", "sift-default", "--runs", "1",
                 "--frames", "16", "--no-plots", "--json", "--out", str(tmp_path / "map")], cli_env)
    assert r.returncode == 0, r.stderr


@pytest.mark.slow
def test_nfex_evaluate_xfeat_default_runs_and_without_weights_exits_2(cli_env: dict[str, str], data_dir: Path,
                                                                       tmp_path: Path) -> None:
    """`-m xfeat-default` is a static baseline like ORB's; with its weights missing: one line, exit 2."""
    from nfex_core.config import Settings
    from nfex_core.vision.learned.model import availability

    if not availability(Settings.from_env()).ok:
        pytest.skip("the learned extra is not installed")
    args = ["evaluate", str(data_dir / "kitti"), "--sequence", "01", "--frames", "4", "--methods", "xfeat-default",
            "--runs", "1", "--out", str(tmp_path / "ev"), "--json", "--no-plots"]
    r = run_cli(args, cli_env)
    assert r.returncode == 0, r.stderr
    m = json.loads(r.stdout)["methods"]["xfeat-default"]["by_condition"]["none"]
    assert len(m["ate_runs"]) + m["failed_runs"] == 1 and m["extraction_ms_mean"] > 0
    missing = run_cli(args, {**cli_env, "NFEX_XFEAT_WEIGHTS": str(tmp_path / "gone.pt")})
    assert missing.returncode == 2, missing.stderr
    assert "gone.pt" in missing.stderr and "Traceback" not in missing.stderr and len(missing.stderr.strip().splitlines()) == 1


def test_nfex_evaluate_a_schedule_with_a_gap_exits_2_naming_it(cli_env: dict[str, str], data_dir: Path) -> None:
    r = run_cli(["evaluate", str(data_dir / "kitti"), "--sequence", "01", "--runs", "1", "-m", "orb-default",
                 "--schedule", "none:0-12,dark:15-50"], cli_env)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert "13-14" in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr


@pytest.mark.slow
def test_nfex_evaluate_pools_several_sequences_and_a_manifest(cli_env: dict[str, str], data_dir: Path, tmp_path: Path) -> None:
    """KITTI 01 and 07 by --sequence, the handheld sequence through a manifest: tables per sequence and pooled,
    result.json with each sequence, a pooled section with paired tests over (sequence, run) pairs, a ramped schedule."""
    manifest = tmp_path / "m.toml"
    manifest.write_text('[[sequence]]\npath = "handheld"\nformat = "handheld"\nsequence = "checkerboard"\nstep = 4\n')
    out = tmp_path / "ev"
    r = run_cli(["evaluate", str(data_dir / "kitti"), "--sequence", "01", "--sequence", "07", "--manifest", str(manifest),
                 "--frames", "5", "-m", "orb-default,sift-default", "--runs", "2", "--schedule", "none:0-1,dark:2-4@0.3-0.9",
                 "--out", str(out), "--json", "--no-plots"], cli_env)
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    labels = ["kitti/01", "kitti/07", "handheld/checkerboard"]
    assert doc["sequence_labels"] == labels and list(doc["sequences"]) == labels and doc["schedule"].endswith("@0.3-0.9")
    seven = doc["sequences"]["kitti/07"]
    assert seven["frames"] == 5 and "kitti_07" in seven["evidence"] and "kitti_01" not in seven["evidence"]  # LOSO
    fig = seven["methods"]["orb-default"]["by_condition"]["schedule"]["figures"]
    assert len(fig["auc10"]["runs"]) == 2 and all(0 <= v <= 1 for v in fig["auc10"]["runs"])
    pooled = doc["pooled"]["conditions"]["schedule"]
    ref = pooled["best_static"]["auc10"]
    assert ref in ("orb-default", "sift-default")
    other = ({"orb-default", "sift-default"} - {ref}).pop()
    assert pooled["methods"][other]["auc10"]["vs_best_static"]["pairs"] == 6  # 3 sequences × 2 runs
    assert pooled["methods"]["motion-prior"]["ate"]["reference"] is not None
    table = (out / "table.md").read_text()
    assert "### Pooled over kitti/01, kitti/07, handheld/checkerboard: schedule" in table and "Front-end accuracy" in table
    rows = (out / "runs.csv").read_text().splitlines()
    assert len(rows) == 1 + 3 * 3 * 2 and rows[0].startswith("method,")


def test_nfex_evaluate_a_schedule_that_does_not_fit_every_sequence_exits_2_naming_it(cli_env: dict[str, str],
                                                                                      data_dir: Path) -> None:
    r = run_cli(["evaluate", str(data_dir / "kitti"), "--sequence", "01,07", "--runs", "1", "-m", "orb-default",
                 "--schedule", "none:0-50"], cli_env)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert "kitti/07" in r.stderr and "51-159" in r.stderr, r.stderr
