"""docker-compose.yml is accepted by `docker compose config` where the plugin exists, and is coherent
with the settings the service tests run with."""
from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import yaml

from tests.service.conftest import TEST_ENV

ROOT = Path(__file__).resolve().parent.parent


def test_compose_file_structure() -> None:
    doc = yaml.safe_load((ROOT / "docker-compose.yml").read_text())
    services = doc["services"]
    assert {"sparql", "nfex", "gateway"} <= set(services)
    env = services["nfex"]["environment"]
    assert env["NFEX_STORE"] == "http://sparql:7878"
    for key, value in TEST_ENV.items():  # the replicas run with the tests' settings
        if key != "NFEX_TOKENS":
            assert str(env[key]) == value, key
    assert "NFEX_TOKENS" in env
    assert services["nfex"]["deploy"]["replicas"] >= 2
    assert "serve" in services["sparql"]["command"] and "--timeout-s" in services["sparql"]["command"]
    for volume in services["gateway"]["volumes"]:
        assert (ROOT / volume.split(":")[0]).exists()
    assert (ROOT / "Dockerfile").exists()


def test_docker_compose_config_accepts_it() -> None:
    docker = shutil.which("docker")
    if docker is None or subprocess.run([docker, "compose", "version"], capture_output=True).returncode != 0:
        import pytest

        pytest.skip("the docker compose plugin is not installed here")
    p = subprocess.run([docker, "compose", "config", "--quiet"], cwd=ROOT, capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
