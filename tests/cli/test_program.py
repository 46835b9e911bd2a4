"""`nfex program` as a user runs it: check with line and column, apply as a version, show, list, remove."""
from __future__ import annotations

import json
from pathlib import Path

from tests.conftest import run_cli

SITE = '''# site knowledge
program site
prune BRISK when light is dark because "measured: lost tracking at night"
weight motion 2.0 when motion is fast
'''


def test_check_accepts_a_valid_program(cli_env: dict[str, str], tmp_path: Path) -> None:
    f = tmp_path / "site.nfex"
    f.write_text(SITE)
    p = run_cli(["program", "check", str(f)], cli_env)
    assert p.returncode == 0, p.stderr
    assert p.stdout.strip() == "ok: program site, 2 statements"


def test_check_reports_syntax_errors_with_line_and_column(cli_env: dict[str, str], tmp_path: Path) -> None:
    f = tmp_path / "bad.nfex"
    f.write_text("program bad\nadjust ORB.nfeatures 1.6 when light is dark\n")
    p = run_cli(["program", "check", str(f)], cli_env)
    assert p.returncode == 2
    [line] = p.stderr.strip().splitlines()
    assert line == f"nfex: parse error: {f}:2:22: unexpected '1.6'; expected 'by'"


def test_check_lists_every_unknown_name_once_on_stderr_only(cli_env: dict[str, str], tmp_path: Path) -> None:
    f = tmp_path / "bad.nfex"
    f.write_text("program bad\nprune SURF\nweight texturedness 2.0 when light is dim\n")
    p = run_cli(["program", "check", str(f)], cli_env)
    assert p.returncode == 2
    assert p.stdout == ""  # results only on stdout; each problem printed once, on stderr
    assert p.stderr.splitlines() == [
        f"nfex: unknown name: {f}:2:7: unknown extractor 'SURF'; known: AKAZE, BRISK, ORB, ORB_GRID, SIFT, XFEAT",
        f"nfex: unknown name: {f}:3:39: unknown value of light 'dim'; known: bright, dark",
    ]


def test_apply_show_list_remove(cli_env: dict[str, str], tmp_path: Path) -> None:
    f = tmp_path / "site.nfex"
    f.write_text(SITE)
    p = run_cli(["program", "apply", str(f), "-m", "night rules"], cli_env)
    assert p.returncode == 0, p.stderr
    assert p.stdout.startswith("version 2: program site, 2 statements")
    versions = json.loads(run_cli(["kg", "versions", "--json"], cli_env).stdout)
    assert versions[0]["message"] == "night rules" and versions[0]["author"] == "test"
    again = run_cli(["program", "apply", str(f)], cli_env)
    assert again.stdout.startswith("no change")
    shown = run_cli(["program", "show", "site"], cli_env).stdout
    assert shown == (
        "program site\n\nprune BRISK when light is dark\n    because \"measured: lost tracking at night\"\n"
        "weight motion 2.0 when motion is fast\n"
    )
    listed = json.loads(run_cli(["program", "list", "--json"], cli_env).stdout)
    assert {(i["name"], i["statements"]) for i in listed} >= {("site", 2), ("default", 33)}
    assert run_cli(["program", "remove", "site"], cli_env).returncode == 0
    missing = run_cli(["program", "show", "site"], cli_env)
    assert missing.returncode == 4 and "no program named 'site'" in missing.stderr


def test_a_shipped_opt_in_program_is_applied_by_name(cli_env: dict[str, str]) -> None:
    """`nfex program apply verification` finds the learned program in the installed rules (a wheel user has no
    checkout to point at); an unknown name says what is shipped, with exit code 4."""
    p = run_cli(["program", "apply", "verification"], cli_env)
    assert p.returncode == 0, p.stderr
    assert "program verification" in p.stdout
    assert "accept pair if" in run_cli(["program", "show", "verification"], cli_env).stdout
    missing = run_cli(["program", "apply", "nonesuch"], cli_env)
    assert missing.returncode == 4 and "shipped: verification" in missing.stderr
