"""nfex_slam stands on its own: none of its modules reaches the server (nfex_core, service) or the graph stack,
and only the replay needs the HTTP client — what lets clients/slam install without the server (issue 19)."""
from __future__ import annotations

import os
import pkgutil
import subprocess
import sys
from pathlib import Path

import nfex_slam

CLIENT = Path(__file__).resolve().parents[2] / "clients" / "python"  # nfex_client, for the replay, when not installed

SERVER_SIDE = ("nfex_core", "service", "rdflib", "pyoxigraph", "pyshacl", "fastapi", "torch")


def test_no_module_of_nfex_slam_imports_the_server_or_the_graph_stack() -> None:
    modules = sorted(m.name for m in pkgutil.walk_packages(nfex_slam.__path__, "nfex_slam.") if m.name != "nfex_slam.__main__")
    assert {"nfex_slam.vo.pipeline", "nfex_slam.datasets.kitti", "nfex_slam.trajectory.ate", "nfex_slam.replay"} <= set(modules)
    code = (
        "import importlib, sys\n"
        f"for m in {modules!r}: importlib.import_module(m)\n"
        f"print(','.join(h for h in {SERVER_SIDE!r} if h in sys.modules))"
    )
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(CLIENT), os.environ.get("PYTHONPATH")]))}
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, env=env)
    assert p.returncode == 0, p.stderr
    assert p.stdout.strip() == ""


def test_the_front_end_does_not_need_the_http_client() -> None:
    code = ("import sys\nimport nfex_slam.vo, nfex_slam.datasets, nfex_slam.trajectory\n"
            "print(','.join(h for h in ('httpx', 'nfex_client') if h in sys.modules))")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert p.returncode == 0 and p.stdout.strip() == "", p.stderr
