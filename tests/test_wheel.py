"""A regular install: the wheel built from this checkout, installed into a fresh virtualenv, answers a
selection from the full graph (ontology, rules, the shipped measurements and model) without the checkout."""
from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import sysconfig
import time
from pathlib import Path

import httpx
import pytest

REPO = Path(__file__).resolve().parent.parent


def _run(args: list[str], **kw: object) -> subprocess.CompletedProcess[str]:
    p = subprocess.run(args, capture_output=True, text=True, timeout=300, **kw)  # type: ignore[call-overload]
    assert p.returncode == 0, f"{args[:3]} exited {p.returncode}:\n{p.stdout[-2000:]}\n{p.stderr[-3000:]}"
    return p  # type: ignore[no-any-return]


@pytest.mark.slow
def test_an_installed_wheel_answers_from_the_full_graph(tmp_path: Path) -> None:
    work = tmp_path / "elsewhere"  # not the checkout: it must not be on sys.path (nor a stray nfex.egg-info in it)
    work.mkdir()
    env = {k: v for k, v in os.environ.items() if not k.startswith("NFEX_") and k not in ("PYTHONPATH", "PYTHONHOME")}
    env["NFEX_STORE"] = str(tmp_path / "store")
    dist = tmp_path / "dist"
    # no build isolation: the build backend (hatchling, in the dev extra) comes from this environment
    _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q", "-w", str(dist), str(REPO)],
         cwd=work, env=env)
    wheel = next(dist.glob("nfex-*.whl"))

    venv = tmp_path / "venv"
    _run([sys.executable, "-m", "venv", "--without-pip", str(venv)])
    python = venv / "bin" / "python"
    # installed before the dependencies below are on its path: pip must not see this environment's nfex
    _run([sys.executable, "-m", "pip", "--python", str(python), "install", "--no-deps", "--no-index", "--force-reinstall",
          "-q", str(wheel)], cwd=work, env=env)
    site = Path(_run([str(python), "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"]).stdout.strip())
    assert (site / "nfex_core" / "_home" / "ontology" / "nfex.ttl").is_file()
    # the two edges beside the core: the command line (the console script's module) and the service
    assert (site / "cli" / "main.py").is_file() and (site / "service" / "main.py").is_file()
    # nfex itself only from the wheel; its third-party dependencies from this environment, to keep the test fast
    # (a plain path line: the .pth files there, e.g. an editable nfex, are not processed)
    (site / "zz-deps.pth").write_text(sysconfig.get_path("purelib") + "\n")

    where = _run([str(python), "-c", "import nfex_core, nfex_core.config as c; print(nfex_core.__file__); print(c.Settings.from_env().home)"],
                 cwd=work, env=env).stdout.split()
    assert Path(where[0]).is_relative_to(venv) and Path(where[1]).is_relative_to(venv), where

    p = _run([str(venv / "bin" / "nfex"), "select", "--context", "agent=car", "--json"], cwd=work, env=env)
    sel = json.loads(p.stdout)
    assert sel["versions"]["graph"] == 1 and sel["versions"]["rules"] >= 4 and sel["versions"]["programs"]
    assert sel["versions"]["model"]["name"] == "default"  # models/ came with the wheel
    # the shipped KITTI 00 sweep's measurements are in the graph and decide Θ′
    assert any((c.get("evidence") or {}).get("windows") for c in sel["candidates"])
    reasons = [b["kind"] for c in sel["candidates"] for a in c["adjustments"] for b in a["because"]]
    assert "measured" in reasons

    # the service's SHACL worker, started from the wheel, imports the wheel's nfex_core and judges as this process
    check = """
import json
from rdflib import Literal, URIRef
from nfex_core.knowledge import open_graph
from nfex_core.kg import ChangeSet
from nfex_core.kg.shacl.validation import validate_change
N = "https://w3id.org/nfex#"
kg = open_graph()
shapes = kg.shapes()
bad = ChangeSet.adding([(URIRef(N + "cfg_w"), URIRef(N + "ofExtractor"), URIRef(N + "ORB")),
                        (URIRef(N + "cfg_w"), URIRef("http://www.w3.org/1999/02/22-rdf-syntax-ns#type"), URIRef(N + "Configuration")),
                        (URIRef(N + "cfg_w"), URIRef(N + "hasSetting"), URIRef(N + "cfg_w_sf")),
                        (URIRef(N + "cfg_w_sf"), URIRef("http://www.w3.org/1999/02/22-rdf-syntax-ns#type"), URIRef(N + "ParameterSetting")),
                        (URIRef(N + "cfg_w_sf"), URIRef(N + "parameter"), URIRef(N + "ORB_scaleFactor")),
                        (URIRef(N + "cfg_w_sf"), URIRef(N + "value"), Literal(0.5))])
here = validate_change(kg.backend, bad, shapes)
worker = kg.use_shacl_process()
there = validate_change(kg.backend, bad, shapes, worker.run)
print(json.dumps({"same": there == here, "conforms": there.conforms, "package": worker.worker_package, **worker.status()}))
kg.close()
"""
    out = json.loads(_run([str(python), "-c", check], cwd=work, env=env).stdout.strip().splitlines()[-1])
    assert out["same"] and not out["conforms"] and out["fallbacks"] == 0 and out["starts"] == 1
    assert Path(out["package"]).is_relative_to(venv), out["package"]

    # a stranger's first `nfex serve`: an empty HOME, no NFEX_STORE; /sparql is answered through a query worker
    # process that the wheel's python starts (its store and checkpoints under that HOME)
    home = tmp_path / "empty-home"
    home.mkdir()
    serve_env = {k: v for k, v in env.items() if k != "NFEX_STORE"} | {"HOME": str(home)}
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    log = (tmp_path / "serve.log").open("w")
    svc = subprocess.Popen([str(venv / "bin" / "nfex"), "serve", "--port", str(port)], cwd=work, env=serve_env,
                           stdout=log, stderr=subprocess.STDOUT)
    try:
        base = f"http://127.0.0.1:{port}"
        deadline = time.monotonic() + 240
        while True:
            assert svc.poll() is None, (tmp_path / "serve.log").read_text()[-3000:]
            try:
                if httpx.get(base + "/readyz", timeout=5).status_code == 200:
                    break
            except httpx.HTTPError:
                pass
            assert time.monotonic() < deadline, (tmp_path / "serve.log").read_text()[-3000:]
            time.sleep(0.5)
        r = httpx.get(base + "/sparql", params={"query": "ASK { <https://w3id.org/nfex#ORB> a <https://w3id.org/nfex#FeatureExtractor> }"},
                      headers={"Accept": "application/sparql-results+json"}, timeout=60)
        assert r.status_code == 200 and r.json()["boolean"] is True, r.text
        assert any(p.name.endswith(".query-checkpoints") for p in home.rglob("*.query-checkpoints")), \
            sorted(str(p) for p in home.rglob("*"))[:20]
    finally:
        svc.terminate()
        svc.wait(timeout=60)
        log.close()
