"""clients/python installs on its own into a fresh virtualenv and works against the running service,
with the server package (nfex_core, service) not importable there.

To stay fast and offline, the new environment reaches the test environment's site-packages through a
path line in a .pth file, for the client's dependencies only (httpx, numpy, OpenCV; setuptools to
build it): a path added that way is on sys.path, but the .pth files inside it — the editable nfex
install among them — are not processed, so the server stays out; the test checks that it does.
"""
from __future__ import annotations

import json
import shutil
import subprocess
import sysconfig
import venv
from pathlib import Path

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
    """A fresh virtualenv (with pip) into which ``pip install clients/python[opencv]`` installed the client."""
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
    source = shutil.copytree(ROOT / "clients" / "python", home / "python")  # the build leaves nothing in the checkout
    r = subprocess.run([str(env_dir / "bin" / "pip"), "install", "--no-index", "--no-build-isolation",
                        "--disable-pip-version-check", "-q", f"{source}[opencv]"],
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
