"""The `nfex` command line as a user runs it: real processes, one line on errors, distinct exit codes."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from tests.conftest import run_cli

BAD_CONFIG = """@prefix nfex: <https://w3id.org/nfex#> .
nfex:cfg_bad a nfex:Configuration ; nfex:ofExtractor nfex:ORB ; nfex:hasSetting nfex:cfg_bad_sf .
nfex:cfg_bad_sf a nfex:ParameterSetting ; nfex:parameter nfex:ORB_scaleFactor ; nfex:value 0.5 .
"""
GOOD_CONFIG = BAD_CONFIG.replace("0.5", "1.5").replace("cfg_bad", "cfg_good")
PARAMS_QUERY = "SELECT ?p WHERE { ?p a nfex:Parameter }"


def test_sparql_lists_every_parameter(cli_env: dict[str, str]) -> None:
    p = run_cli(["sparql", PARAMS_QUERY], cli_env)
    assert p.returncode == 0, p.stderr
    for name in ("ORB_nfeatures", "ORB_scaleFactor", "ORB_nlevels", "ORB_edgeThreshold", "ORB_fastThreshold",
                 "SIFT_nfeatures", "SIFT_nOctaveLayers", "SIFT_contrastThreshold", "SIFT_edgeThreshold", "SIFT_sigma"):
        assert f"nfex:{name}" in p.stdout
    assert "(40 rows)" in p.stdout  # ORB 9, ORB_GRID 11, SIFT 6, AKAZE 8, BRISK 3, XFEAT 3


def test_sparql_on_a_fresh_empty_folder_seeds_it(tmp_path: Path, cli_env: dict[str, str]) -> None:
    env = dict(cli_env, NFEX_STORE=str(tmp_path / "new"))
    p = run_cli(["sparql", PARAMS_QUERY, "--format", "json"], env)
    assert p.returncode == 0, p.stderr
    assert len(json.loads(p.stdout)["results"]["bindings"]) == 40


def test_sparql_formats(cli_env: dict[str, str], tmp_path: Path) -> None:
    q = "SELECT ?x ?label WHERE { ?x a nfex:FeatureExtractor ; rdfs:label ?label } ORDER BY ?x"
    csv = run_cli(["sparql", q, "--format", "csv"], cli_env).stdout.splitlines()
    assert csv[0] == "x,label" and csv[1] == "https://w3id.org/nfex#AKAZE,AKAZE"
    tsv = run_cli(["sparql", q, "--format", "tsv"], cli_env).stdout.splitlines()
    assert tsv[0] == "?x\t?label" and tsv[1] == '<https://w3id.org/nfex#AKAZE>\t"AKAZE"@en'
    f = tmp_path / "q.rq"
    f.write_text("ASK { nfex:ORB a nfex:FeatureExtractor }")
    assert run_cli(["sparql", "--file", str(f)], cli_env).stdout.strip() == "true"
    construct = run_cli(["sparql", "CONSTRUCT { nfex:ORB ?p ?o } WHERE { nfex:ORB ?p ?o }"], cli_env)
    assert "opencvConstructor" in construct.stdout


def test_validate_exits_0_when_the_graph_conforms(cli_env: dict[str, str]) -> None:
    p = run_cli(["validate"], cli_env)
    assert p.returncode == 0 and p.stdout.startswith("conforms")


def test_rejected_add_exits_1_naming_shape_and_node_and_adds_no_version(cli_env: dict[str, str], tmp_path: Path) -> None:
    f = tmp_path / "bad.ttl"
    f.write_text(BAD_CONFIG)
    p = run_cli(["kg", "add", str(f)], cli_env)
    assert p.returncode == 1
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1
    assert "ConfigurationShape" in lines[0] and "cfg_bad" in lines[0] and "1.01" in lines[0]
    versions = json.loads(run_cli(["kg", "versions", "--json"], cli_env).stdout)
    assert [v["version"] for v in versions] == [1]


def test_add_versions_rollback_export(cli_env: dict[str, str], tmp_path: Path) -> None:
    f = tmp_path / "good.ttl"
    f.write_text(GOOD_CONFIG)
    p = run_cli(["kg", "add", str(f), "-m", "a good one"], cli_env)
    assert p.returncode == 0 and p.stdout.startswith("version 2")
    table = run_cli(["kg", "versions"], cli_env).stdout
    assert "a good one" in table and "test" in table
    diff = run_cli(["kg", "diff", "2"], cli_env).stdout
    assert diff.count("\n+ ") + diff.startswith("+ ") == 6
    assert run_cli(["kg", "rollback", "1"], cli_env).stdout.startswith("version 3")
    exported = run_cli(["kg", "export", "--format", "nt"], cli_env).stdout
    assert "cfg_good" not in exported and "ORB_scaleFactor" in exported
    assert run_cli(["kg", "remove", str(f)], cli_env).stdout.startswith("no change")


def test_expect_version_conflict_exits_5(cli_env: dict[str, str], tmp_path: Path) -> None:
    f = tmp_path / "good.ttl"
    f.write_text(GOOD_CONFIG)
    p = run_cli(["kg", "add", str(f), "--expect-version", "7"], cli_env)
    assert p.returncode == 5 and "version 1, not 7" in p.stderr


def test_bad_input_exits_2_with_one_line(cli_env: dict[str, str], tmp_path: Path) -> None:
    cases = [
        ["sparql", "SELEC ?x"],
        ["sparql", "INSERT DATA { <a:b> <a:c> <a:d> }"],
        ["sparql"],
        ["kg", "add", str(tmp_path / "missing.ttl")],
        ["kg", "add", str(tmp_path / "file.csv")],
        ["sparql", "SELECT ?x WHERE { ?x ?y }"],
    ]
    (tmp_path / "file.csv").write_text("a,b")
    for args in cases:
        p = run_cli(args, cli_env)
        assert p.returncode == 2, (args, p.stderr)
        assert len(p.stderr.strip().splitlines()) == 1, (args, p.stderr)
        assert "Traceback" not in p.stderr


def test_syntax_error_in_turtle_names_the_file(cli_env: dict[str, str], tmp_path: Path) -> None:
    f = tmp_path / "broken.ttl"
    f.write_text("@prefix nfex: <https://w3id.org/nfex#> .\nnfex:a nfex:b .\n")
    p = run_cli(["kg", "add", str(f)], cli_env)
    assert p.returncode == 2 and "broken.ttl" in p.stderr


def test_unknown_version_exits_4_and_debug_shows_the_traceback(cli_env: dict[str, str]) -> None:
    p = run_cli(["kg", "rollback", "42"], cli_env)
    assert p.returncode == 4 and "no graph version 42" in p.stderr and "Traceback" not in p.stderr
    p = run_cli(["--debug", "kg", "rollback", "42"], cli_env)
    assert p.returncode == 4 and "Traceback" in p.stderr


def test_store_in_use_exits_6(cli_env: dict[str, str]) -> None:
    from nfex_core.kg import KnowledgeGraph

    kg = KnowledgeGraph.open(cli_env["NFEX_STORE"])
    try:
        p = run_cli(["sparql", PARAMS_QUERY], cli_env)
        assert p.returncode == 6 and "in use by another process" in p.stderr
    finally:
        kg.close()


def test_export_to_a_file_keeps_stdout_clean(cli_env: dict[str, str], tmp_path: Path) -> None:
    out = tmp_path / "graph.nt"
    p = run_cli(["kg", "export", "--format", "nt", "-o", str(out)], cli_env)
    assert p.returncode == 0, p.stderr
    assert p.stdout == "" and p.stderr.strip() == f"wrote {out}"
    assert "ORB_scaleFactor" in out.read_text()


def test_version(cli_env: dict[str, str]) -> None:
    from nfex_core import __version__

    p = run_cli(["--version"], cli_env)
    assert p.returncode == 0 and p.stdout == f"nfex {__version__}\n"


def test_shell_completion(cli_env: dict[str, str]) -> None:
    # as a user runs it from bash (typer detects the shell from the parent process; `; exit` keeps bash
    # from exec-ing the command in its place)
    script = subprocess.run(["bash", "-c", '"$0" -m cli.main --show-completion; exit $?', sys.executable],
                            env=cli_env, capture_output=True, text=True, timeout=120)
    assert script.returncode == 0, script.stderr
    assert "_nfex_completion" in script.stdout and "complete " in script.stdout
    # what bash asks when the user presses TAB after `nfex kg ex`
    env = dict(cli_env, _NFEX_COMPLETE="complete_bash", COMP_WORDS="nfex kg ex", COMP_CWORD="2")
    p = run_cli([], env)
    assert p.returncode == 0 and p.stdout.split() == ["export"]
    env.update(COMP_WORDS="nfex program ", COMP_CWORD="2")
    assert {"apply", "check", "list", "remove", "show"} <= set(run_cli([], env).stdout.split())
