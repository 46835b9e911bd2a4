"""`nfex program show --shapes` prints each require's SHACL shape back as a DSL line."""
from __future__ import annotations

from pathlib import Path

from tests.conftest import run_cli


def test_show_prints_the_shapes_of_require_statements(cli_env: dict[str, str], tmp_path: Path) -> None:
    f = tmp_path / "site.nfex"
    f.write_text("program site\nrequire ORB.nlevels <= 4 when agent is not one of (car, human)\nprune BRISK when light is dark\n")
    assert run_cli(["program", "apply", str(f)], cli_env).returncode == 0
    p = run_cli(["program", "show", "site", "--shapes"], cli_env)
    assert p.returncode == 0, p.stderr
    lines = p.stdout.splitlines()
    assert "require ORB.nlevels <= 4 when agent is not one of (car, human)" in lines
    [shape] = [ln for ln in lines if ln.startswith("# shape: ")]
    assert shape.startswith("# shape: require ORB.nlevels <= 4 when agent is not one of (car, human)   # https://w3id.org/nfex#statement_site_")
