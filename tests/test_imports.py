"""nfex_core never imports the CLI, HTTP, plotting or training frameworks (the evo rule), nor its edges: the
command line (``cli``) and the service (``service``) are packages beside it."""
from __future__ import annotations

import pkgutil
import subprocess
import sys

import nfex_core

# click is not here: httpx (the remote store's client) imports it for its own command line; the import contracts
# (pyproject.toml) forbid nfex_core importing it itself
HEAVY = ("typer", "fastapi", "matplotlib", "torch", "uvicorn", "starlette", "service", "cli")


def library_modules() -> list[str]:
    return sorted(m.name for m in pkgutil.walk_packages(nfex_core.__path__, "nfex_core."))


def test_library_modules_do_not_import_frameworks() -> None:
    modules = library_modules()
    code = (
        "import importlib, sys\n"
        f"for m in {modules!r}: importlib.import_module(m)\n"
        f"print(','.join(h for h in {HEAVY!r} if h in sys.modules))"
    )
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    assert p.stdout.strip() == ""


def test_cli_help_does_not_import_torch_or_cv2() -> None:
    code = "import sys\nfrom cli.main import app\nprint(','.join(h for h in ('torch','cv2') if h in sys.modules))"
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert p.returncode == 0 and p.stdout.strip() == "", p.stderr
