"""nfex_core's library modules never import the CLI, HTTP, plotting or training frameworks (the evo rule)."""
from __future__ import annotations

import pkgutil
import subprocess
import sys

import nfex_core

HEAVY = ("typer", "fastapi", "matplotlib", "torch", "uvicorn", "starlette")


def library_modules() -> list[str]:
    return sorted(
        m.name
        for m in pkgutil.walk_packages(nfex_core.__path__, "nfex_core.")
        if not m.name.startswith("nfex_core.cli")
    )


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
    code = "import sys\nfrom nfex_core.cli.main import app\nprint(','.join(h for h in ('torch','cv2') if h in sys.modules))"
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert p.returncode == 0 and p.stdout.strip() == "", p.stderr
