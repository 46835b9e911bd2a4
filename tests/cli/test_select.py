"""`nfex select`: from the context alone, and on a real KITTI frame where the vision modules exist."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from nfex_core.config import Settings
from nfex_core.kg.shipped import ontology_vocabulary
from tests.conftest import run_cli


def test_context_only_json(bare_cli_env: dict[str, str]) -> None:
    p = run_cli(["select", "--context", "agent=car,motion=fast,light=dark", "--json"], bare_cli_env)
    assert p.returncode == 0, p.stderr
    sel = json.loads(p.stdout)
    assert sel["mode"] in ("prior", "selectornet") and sel["extractor"] in {"ORB", "ORB_GRID", "AKAZE", "BRISK"}
    [sift] = [x for x in sel["pruned"] if x["extractor"] == "SIFT"]
    assert sift["because"][0]["rule"] == "https://w3id.org/nfex#rule_expert_fast_car_gradient_histograms"
    sources = {c["dimension"]: c["source"] for c in sel["context"]}
    assert sources == {"agent": "given", "motion": "given", "light": "given", "scene": "unknown", "reflectance": "unknown", "texture": "unknown"}
    orb = next(c for c in sel["candidates"] if c["extractor"] == "ORB")
    assert orb["params"]["fastThreshold"] == 10  # 20 × 0.5 in the dark (default.nfex)


def test_context_only_text(bare_cli_env: dict[str, str]) -> None:
    p = run_cli(["select", "-c", "agent=car,motion=fast"], bare_cli_env)
    assert p.returncode == 0, p.stderr
    assert "pruned:\n  SIFT: its gradient-histogram descriptor failed" in p.stdout
    # ORB or the grid-spread ORB: both adjusted for cars by default.nfex
    assert "nfeatures = " in p.stdout and ".nfeatures by 1.5 when agent is car" in p.stdout


@pytest.mark.parametrize(
    ("args", "code", "says"),
    [
        (["select", "--context", "light=dim"], 2, "unknown value of light 'dim'; known: bright, dark"),
        (["select", "--context", "light"], 2, "dimension=value pairs"),
        (["select", "missing.png"], 2, "no image file missing.png"),
    ],
)
def test_errors_exit_by_kind(cli_env: dict[str, str], args: list[str], code: int, says: str) -> None:
    p = run_cli(args, cli_env)
    assert p.returncode == code and says in p.stderr and len(p.stderr.strip().splitlines()) == 1


def test_a_kitti_frame_with_context(cli_env: dict[str, str], data_dir: Path) -> None:
    frames = data_dir / "kitti" / "sequences" / "00" / "image_0"
    p = run_cli(["select", str(frames / "000010.png"), "--previous", str(frames / "000009.png"),
                 "--context", "agent=car,scene=outdoor", "--json"], cli_env)
    assert p.returncode == 0, p.stderr
    sel = json.loads(p.stdout)
    assert sel["mode"] in ("metrics", "selectornet")  # the shipped model decides where it validated
    best = next(c for c in sel["candidates"] if c["extractor"] == sel["extractor"])
    # α* was extracted on the scoring copy, or SelectorNet's bounds chose it without (advisor/scoring.py)
    assert (best["keypoints"] or 0) > 0 and best["metrics"] or "whatever the unmeasured metrics" in best["evidence"]["not_scored"]
    assert {c["dimension"]: c["source"] for c in sel["context"]}["agent"] == "given"
    spec = ontology_vocabulary(Settings.from_env()).extractor(sel["extractor"])
    assert set(sel["params"]) == set(spec.parameters)
    for name, value in sel["params"].items():
        assert spec.parameter(name).validate(value) == value


def test_a_budget_in_the_context_prunes_by_measured_cost(shipped_cli_env: dict[str, str]) -> None:
    cli_env = shipped_cli_env
    # the shipped KITTI 00 sweep (ontology/measurements) measured SIFT far above 20 ms per 1241×376 frame
    free = json.loads(run_cli(["select", "-c", "agent=car,scene=outdoor", "--json"], cli_env).stdout)
    assert free["budget"] is None and not any(c["kind"] == "budget" for p in free["pruned"] for c in p["because"])
    p = run_cli(["select", "-c", "agent=car,scene=outdoor,budget_ms=20"], cli_env)
    assert p.returncode == 0, p.stderr
    assert "SIFT: expected" in p.stdout and 'rule https://w3id.org/nfex#rule_budget "Expected extraction cost over the budget"' in p.stdout
    assert "budget: 20 ms per frame (given" in p.stdout
    bad = run_cli(["select", "-c", "agent=car,budget_ms=fast"], cli_env)
    assert bad.returncode == 2 and "budget_ms must be a number" in bad.stderr


def test_with_the_shipped_measurements_the_measured_extractor_wins(shipped_cli_env: dict[str, str]) -> None:
    """The shipped KITTI 00 sweep measured SIFT best for cars under motion blur: the expert prior yields."""
    p = run_cli(["select", "--context", "agent=car,motion=fast", "--json"], shipped_cli_env)
    assert p.returncode == 0, p.stderr
    sel = json.loads(p.stdout)
    sift = next(c for c in sel["candidates"] if c["extractor"] == "SIFT")
    assert sift["evidence"]["windows"] > 0 and sift["evidence"]["ate_m"] > 0
    assert all(not b["rule"].endswith("rule_expert_fast_car_gradient_histograms") for x in sel["pruned"] for b in x["because"])


def test_without_xfeat_weights_select_says_what_to_install(bare_cli_env: dict[str, str], tmp_path: Path) -> None:
    p = run_cli(["select", "-c", "light=dark"], {**bare_cli_env, "NFEX_XFEAT_WEIGHTS": str(tmp_path / "x.pt")})
    assert p.returncode == 0, p.stderr
    line = next(ln for ln in p.stdout.splitlines() if ln.strip().startswith("XFEAT:"))
    assert "x.pt does not exist" in line and "rule_backend_available" in line and "Traceback" not in p.stderr
