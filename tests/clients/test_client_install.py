"""clients/python and clients/slam install on their own into a fresh virtualenv and work against the running
service, with the server package (nfex_core, service) not importable there.

To stay fast and offline, the new environment reaches the test environment's site-packages through a
path line in a .pth file, for the client's dependencies only (httpx, numpy, OpenCV; setuptools to
build it): a path added that way is on sys.path, but the .pth files inside it — the editable nfex
install among them — are not processed, so the server stays out; the test checks that it does.
"""
from __future__ import annotations

import json
import re
import shutil
import subprocess
import sysconfig
import venv
from pathlib import Path
from typing import Any

import pytest

from tests.service.conftest import Service

ROOT = Path(__file__).resolve().parent.parent.parent

USE_THE_SERVICE = """
import importlib.util, json, sys
import cv2
from nfex_client import NfexClient, Unprocessable, extractor_from_selection

def code(name):  # a package with code; the test environment's editable nfex leaves a data-only nfex_core/_home
    spec = importlib.util.find_spec(name)  # in its site-packages, which this venv shares for its dependencies
    return spec is not None and spec.origin not in (None, "namespace")

out = {"server_importable": [m for m in ("nfex_core", "service") if code(m)],
       "client_at": importlib.util.find_spec("nfex_client").origin}
url, frame_path = sys.argv[1], sys.argv[2]
frame = cv2.imread(frame_path, cv2.IMREAD_GRAYSCALE)
with NfexClient(url) as nfex:
    sel = nfex.select({"agent": "car", "scene": "outdoor"}, frame=frame)
    out["extractor"] = sel["extractor"]
    out["keypoints"] = len(extractor_from_selection(sel).detect(frame))
    out["extractors"] = len(nfex.sparql("SELECT ?x WHERE { ?x a nfex:FeatureExtractor }")["results"]["bindings"])
    try:
        nfex.select({"agent": "submarine"})
    except Unprocessable as e:
        out["allowed"] = e.allowed
print(json.dumps(out))
"""


@pytest.fixture(scope="module")
def client_venv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A fresh virtualenv (with pip) into which ``pip install clients/python[opencv] clients/slam`` installed
    both clients, as clients/README.md says."""
    home = tmp_path_factory.mktemp("client-venv")
    env_dir = home / "venv"
    venv.EnvBuilder(with_pip=True).create(env_dir)
    python = env_dir / "bin" / "python"
    site = subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                          capture_output=True, text=True, check=True).stdout.strip()
    (Path(site) / "nfex_test_dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    # Python 3.11's venv bundles setuptools 65, older than the client's build needs (>= 77); without it
    # the build uses the test environment's (with build isolation pip would fetch one from the index)
    subprocess.run([str(python), "-m", "pip", "uninstall", "-y", "-q", "setuptools"], capture_output=True, check=False)
    # copies: the builds leave nothing in the checkout
    python_client = shutil.copytree(ROOT / "clients" / "python", home / "python", ignore=shutil.ignore_patterns("build", "*.egg-info"))
    slam_client = shutil.copytree(ROOT / "clients" / "slam", home / "slam", ignore=shutil.ignore_patterns("build", "*.egg-info"))
    r = subprocess.run([str(env_dir / "bin" / "pip"), "install", "--no-index", "--no-build-isolation",
                        "--disable-pip-version-check", "-q", f"{python_client}[opencv]", str(slam_client)],
                       capture_output=True, text=True, timeout=300, cwd=home)
    assert r.returncode == 0, r.stdout + r.stderr
    return env_dir


def test_the_client_installs_alone_and_talks_to_the_service(client_venv: Path, service: Service, data_dir: Path) -> None:
    frame = data_dir / "kitti" / "sequences" / "01" / "image_0" / "000000.png"
    r = subprocess.run([str(client_venv / "bin" / "python"), "-c", USE_THE_SERVICE, service.url, str(frame)],
                       capture_output=True, text=True, timeout=120, cwd=client_venv)
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["server_importable"] == []  # neither nfex_core nor service: the client stands alone
    assert out["client_at"].startswith(str(client_venv))
    assert out["extractor"] and out["keypoints"] > 100 and out["extractors"] >= 5
    assert "car" in out["allowed"]


@pytest.mark.slow
def test_the_slam_client_installs_alone_and_replays_kitti01_as_nfex_evaluate_runs_it(
    client_venv: Path, shipped_template: tuple[Path, Any], data_dir: Path, tmp_path: Path
) -> None:
    """The issue's check: in the fresh virtualenv, ``nfex-slam-replay`` on KITTI 01 against a service on one copy
    of the shipped graph prints the ATE that `nfex evaluate`'s nfex run 0 (the same seed) reports on another
    copy; the replay ran from the installed nfex_slam, with nfex_core not importable."""
    from nfex_slam.datasets import open_sequence

    from nfex_core.evaluation import evaluate
    from nfex_core.kg import KnowledgeGraph
    from tests.conftest import stop_process
    from tests.service.conftest import start_service

    template, settings = shipped_template
    for name in ("served", "local"):
        shutil.copytree(template, tmp_path / name, ignore=shutil.ignore_patterns("LOCK"))
    svc = start_service(str(tmp_path / "served"), tmp_path / "service.log")
    try:
        r = subprocess.run(
            [str(client_venv / "bin" / "nfex-slam-replay"), "--service", svc.url, "--format", "kitti",
             "--path", str(data_dir / "kitti"), "--sequence", "01", "--out", str(tmp_path / "kitti01.tum"),
             "--no-feedback", "--seed", "0"],
            capture_output=True, text=True, timeout=600, cwd=client_venv)
        where = subprocess.run([str(client_venv / "bin" / "python"), "-c", WHERE], capture_output=True, text=True,
                               timeout=60, cwd=client_venv)
    finally:
        stop_process(svc.proc)
    assert r.returncode == 0, r.stdout + r.stderr
    assert where.returncode == 0, where.stderr
    found = json.loads(where.stdout)
    assert found["server_importable"] == [] and found["nfex_slam"].startswith(str(client_venv))
    printed = re.search(r"ATE RMSE: ([0-9.]+) m", r.stdout)
    assert printed is not None, r.stdout

    seq = open_sequence(data_dir / "kitti", "kitti", "01")
    kg = KnowledgeGraph.open(str(tmp_path / "local"), settings=settings)
    try:
        [run] = evaluate(seq, kg, methods=["nfex"], runs=1, session=True, control=False).records
    finally:
        kg.close()
    assert run.ate_rmse is not None
    assert float(printed.group(1)) == pytest.approx(run.ate_rmse, abs=1e-6)  # printed with 6 decimals
    assert f"{len(seq)} frames" in r.stdout


WHERE = """
import importlib.util, json
import nfex_slam.replay, nfex_slam.vo, nfex_slam.datasets
def code(name):
    spec = importlib.util.find_spec(name)
    return spec is not None and spec.origin not in (None, "namespace")
print(json.dumps({"server_importable": [m for m in ("nfex_core", "service") if code(m)],
                  "nfex_slam": importlib.util.find_spec("nfex_slam").origin}))
"""
