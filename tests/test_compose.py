"""docker-compose.yml is accepted by `docker compose config` where the plugin exists, and is coherent
with the settings the service tests run with; images are pinned, start-up waits for health, the build
context holds no local state and the service does not run as root. (No Docker daemon here: these read
the files as Docker would.)"""
from __future__ import annotations

import fnmatch
import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
import yaml

from tests.service.conftest import TEST_ENV

ROOT = Path(__file__).resolve().parent.parent


def test_compose_file_structure() -> None:
    doc = yaml.safe_load((ROOT / "docker-compose.yml").read_text())
    services = doc["services"]
    assert {"sparql", "nfex", "gateway"} <= set(services)
    env = services["nfex"]["environment"]
    assert env["NFEX_STORE"] == "http://sparql:7878"
    for key, value in TEST_ENV.items():  # the replicas run with the tests' settings (where the kept table goes is the host's)
        if key not in ("NFEX_TOKENS", "NFEX_COMPILED_CACHE"):
            assert str(env[key]) == value, key
    assert "NFEX_TOKENS" in env
    assert services["nfex"]["deploy"]["replicas"] >= 2
    assert "serve" in services["sparql"]["command"] and "--timeout-s" in services["sparql"]["command"]
    assert services["nfex"]["build"]["target"] == "service" and services["sparql"]["build"]["target"] == "sparql"
    for volume in services["gateway"]["volumes"]:
        assert (ROOT / volume.split(":")[0]).exists()
    assert (ROOT / "Dockerfile").exists()


@pytest.mark.may_skip("no Docker daemon or compose plugin on the project's machines: the one declared exception")
def test_docker_compose_config_accepts_it() -> None:
    docker = shutil.which("docker")
    if docker is None or subprocess.run([docker, "compose", "version"], capture_output=True).returncode != 0:
        pytest.skip("the docker compose plugin is not installed here")
    p = subprocess.run([docker, "compose", "config", "--quiet"], cwd=ROOT, capture_output=True, text=True)
    assert p.returncode == 0, p.stderr


def _stages(dockerfile: str) -> dict[str, list[str]]:
    """Instructions per build stage, keyed by the stage's name (``FROM … AS name``)."""
    stages: dict[str, list[str]] = {}
    current: list[str] = []
    for line in dockerfile.splitlines():
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        m = re.match(r"FROM\s+(\S+)(?:\s+AS\s+(\S+))?", line, re.IGNORECASE)
        if m:
            current = stages.setdefault(m.group(2) or m.group(1), [])
        current.append(line)
    return stages


def test_every_image_is_pinned() -> None:
    doc = yaml.safe_load((ROOT / "docker-compose.yml").read_text())
    dockerfile = (ROOT / "Dockerfile").read_text()
    images = [svc["image"] for svc in doc["services"].values() if "image" in svc]
    args = dict(re.findall(r"^ARG\s+(\w+)=(\S+)", dockerfile, re.MULTILINE))
    for image in re.findall(r"^FROM\s+(\S+)", dockerfile, re.MULTILINE | re.IGNORECASE):
        images.append(re.sub(r"\$\{(\w+)\}", lambda m: args[m.group(1)], image))
    for image in images:
        tag = image.rsplit(":", 1)[1] if ":" in image.split("/")[-1] else ""
        assert tag and tag != "latest" and re.search(r"\d", tag), f"{image} is not pinned to a version"
    # Oxigraph: one version in the compose file and the Dockerfile's default, the series the tests run
    version = doc["services"]["sparql"]["build"]["args"]["OXIGRAPH_VERSION"]
    assert re.fullmatch(r"\d+\.\d+\.\d+", version)
    assert f"ARG OXIGRAPH_VERSION={version}" in dockerfile
    exe = shutil.which("oxigraph") or str(Path(sys.executable).parent / "oxigraph")
    if Path(exe).exists():
        tested = subprocess.run([exe, "--version"], capture_output=True, text=True).stdout.split()[-1]
        assert version.split(".")[:2] == tested.split(".")[:2], (version, tested)


def test_start_up_waits_for_healthy_dependencies() -> None:
    services = yaml.safe_load((ROOT / "docker-compose.yml").read_text())["services"]
    for name, svc in services.items():
        for dep, cond in (svc.get("depends_on") or {}).items():
            assert cond == {"condition": "service_healthy"}, (name, dep, cond)
            assert services[dep]["healthcheck"]["test"], dep
    assert "sparql" in services["nfex"]["depends_on"] and "nfex" in services["gateway"]["depends_on"]
    # the SPARQL server's image is distroless: its healthcheck runs the busybox the Dockerfile adds
    probe = services["sparql"]["healthcheck"]["test"]
    assert probe[1] in " ".join(_stages((ROOT / "Dockerfile").read_text())["sparql"])


def test_the_build_context_leaves_local_state_out() -> None:
    patterns = [p.strip() for p in (ROOT / ".dockerignore").read_text().splitlines() if p.strip() and not p.startswith("#")]

    def ignored(path: str) -> bool:
        return any(fnmatch.fnmatch(path, p) or fnmatch.fnmatch(path, p.removeprefix("**/")) or path.startswith(p.rstrip("/") + "/")
                   or fnmatch.fnmatch(path.rsplit("/", 1)[-1], p.removeprefix("**/")) for p in patterns)

    for path in (".venv", ".venv/lib/python3.11/site-packages/torch/__init__.py", ".git", "out", "out/eval/plot.png", "build",
                 "dist", "nfex.egg-info", "nfex_core/__pycache__", "nfex_core/kg/__pycache__/store.cpython-311.pyc",
                 ".pytest_cache", ".mypy_cache", ".ruff_cache", ".hypothesis"):
        assert ignored(path), path
    for path in ("pyproject.toml", "README.md", "nfex_core/kg/store.py", "service/main.py", "ontology/nfex.ttl",
                 "rules/nfex.lark", "models/default/manifest.json", "clients/slam/nfex_slam/vo/pipeline.py"):
        assert not ignored(path), path
    # what the service stage copies exists, is in the build context, and holds every package the wheel ships
    copied = {source for line in _stages((ROOT / "Dockerfile").read_text())["service"]
              if line.upper().startswith("COPY ") and "--from" not in line for source in line.split()[1:-1]}
    for source in copied:
        assert (ROOT / source).exists() and not ignored(source), source
    wheel = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["hatch"]["build"]["targets"]["wheel"]
    for package in wheel["packages"]:
        assert package in copied, f"the wheel ships {package}; the Dockerfile does not copy it"


def test_the_service_image_runs_as_a_user() -> None:
    service = _stages((ROOT / "Dockerfile").read_text())["service"]
    users = [line.split()[1] for line in service if line.upper().startswith("USER ")]
    assert users and users[-1] not in ("root", "0"), users
    # installed from a wheel (its data inside), not an editable checkout that needs the source at run time
    install = next(line for line in service if "pip install" in line)
    assert " -e " not in install and "NFEX_HOME" not in " ".join(service)
