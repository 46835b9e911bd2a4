"""The documents name what exists: every repository path, ``make`` target and ``nfex`` command named in README.md
and docs/*.md is checked against the tree, the Makefile and the CLI's own command tree (typer's), and the README's
configuration table lists every ``NFEX_*`` variable the code reads. A rename cannot leave a stale document.

What counts as a repository path: a path (in a code span, a code block or a Markdown link) that starts with one of
the repository's top-level folders, or a Markdown link relative to the document. The documents also name modules
relative to their package (``rules/engine.py`` for ``nfex_core/rules/engine.py``): such a path counts when it
exists in one of the packages. Build products (``out/``, ``…/build/``), the data folder (``../shared/data``,
``$NFEX_DATA``) and placeholders (``<…>``, ``…``) are not checked.
"""
from __future__ import annotations

import glob
import re
from pathlib import Path

import pytest
import typer

from cli.main import app
from service.config import Settings as ServiceSettings

REPO = Path(__file__).resolve().parent.parent
DOCS = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]
TOP = tuple(sorted(p.name for p in REPO.iterdir() if not p.name.startswith(".") and p.name not in {"out", "build"}))
FENCE = re.compile(r"```[^\n]*\n(.*?)```", re.S)
SPAN = re.compile(r"`([^`\n]+)`")
LINK = re.compile(r"\]\(([^)\s#]+)(?:#[^)]*)?\)")
PATH = re.compile(r"(?<![\w./$~-])((?:" + "|".join(re.escape(t) for t in TOP) + r")(?:/[\w.*@+-]+)+/?)")
MAKE = re.compile(r"(?<![\w-])make ((?:[a-z][\w-]*)(?: [a-z][\w-]*)*)")
NFEX = re.compile(r"(?:^|[\s|;(&`$])nfex ([a-z][\w-]*)(?: ([a-z][\w-]*))?")


def _code(text: str) -> list[str]:
    """The document's code: fenced blocks and inline spans."""
    blocks = FENCE.findall(text)
    rest = FENCE.sub("", text)
    return blocks + SPAN.findall(rest)


def _paths(doc: Path) -> set[str]:
    text = doc.read_text()
    found = {m for chunk in _code(text) for m in PATH.findall(chunk)}
    for link in LINK.findall(text):
        if "://" in link or link.startswith("mailto:"):
            continue
        found.add(str((doc.parent / link).resolve().relative_to(REPO)) if (doc.parent / link).resolve().is_relative_to(REPO)
                  else link)
    return {p.rstrip("/.,;:") for p in found if "…" not in p and "<" not in p and "/build/" not in p}


PACKAGES = ("", "nfex_core/", "service/", "clients/slam/nfex_slam/", "clients/python/nfex_client/")


def _exists(path: str) -> bool:
    return any(glob.glob(str(REPO / (package + path)), recursive=True) for package in PACKAGES)


def _make_targets() -> set[str]:
    return set(re.findall(r"^([a-z][\w-]*):", (REPO / "Makefile").read_text(), re.M))


def _commands() -> dict[str, set[str]]:
    """``nfex``'s commands: each top-level name with its subcommands (empty for a plain command)."""
    root = typer.main.get_command(app)
    return {name: set(getattr(cmd, "commands", {})) for name, cmd in getattr(root, "commands", {}).items()}


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.name)
def test_every_repository_path_named_exists(doc: Path) -> None:
    missing = sorted(p for p in _paths(doc) if not _exists(p))
    assert not missing, f"{doc.relative_to(REPO)} names paths that do not exist: {missing}"


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.name)
def test_every_make_target_named_exists(doc: Path) -> None:
    targets = _make_targets()
    named = {t for chunk in _code(doc.read_text()) for m in MAKE.findall(chunk) for t in m.split()}
    assert not named - targets, f"{doc.relative_to(REPO)} names make targets the Makefile lacks: {sorted(named - targets)}"


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.name)
def test_every_nfex_command_named_exists(doc: Path) -> None:
    commands = _commands()
    wrong = []
    for chunk in _code(doc.read_text()):
        for first, second in NFEX.findall(chunk):
            if first not in commands:
                wrong.append(f"nfex {first}")
            elif commands[first] and second and second not in commands[first]:
                wrong.append(f"nfex {first} {second}")
    assert not wrong, f"{doc.relative_to(REPO)} names nfex commands that do not exist: {sorted(set(wrong))}"


SETTINGS_MODULE = REPO / "nfex_core" / "config.py"
# a read of an NFEX_* variable that bypasses Settings: os.environ / getenv, or a command-line option's envvar
BYPASS = re.compile(r"(?:getenv|environ\.get|environ\.setdefault|envvar=)\(?\s*[\"']NFEX_|environ\[[\"']NFEX_\w+[\"']\](?!\s*=[^=])")


def _sources(*folders: str) -> list[Path]:
    return [source for folder in folders for source in sorted((REPO / folder).rglob("*.py"))]


def _variables_read() -> set[str]:
    """``NFEX_*`` variables nFEX reads: the settings' fields (pydantic-settings reads ``NFEX_<FIELD>``; the
    service's Settings extends the core's), and the names the code and the suite spell out (the suite's switches)."""
    names = {f"NFEX_{field.upper()}" for field in ServiceSettings.model_fields}
    for source in _sources("nfex_core", "service", "cli", "tests"):
        names |= set(re.findall(r"[\"'](NFEX_[A-Z0-9_]+)[\"']", source.read_text()))
    # the ontology's IRI (a constant, not a variable); NFEX_TEST_*: what the suite hands its own child processes
    # (the C++ client's service tests, clients/cpp/README.md), not a setting
    return {n for n in names if n != "NFEX_ONTOLOGY" and not n.startswith("NFEX_TEST_")}


def _readme_table() -> set[str]:
    readme = (REPO / "README.md").read_text()
    table = readme[readme.index("## Configuration"):]
    table = table[: table.index("\n## ", 1)]
    return set(re.findall(r"NFEX_[A-Z0-9_]+", table))


def test_the_readme_configuration_table_lists_every_variable_the_code_reads() -> None:
    read, listed = _variables_read(), _readme_table()
    assert not read - listed, f"README's configuration table lacks: {sorted(read - listed)}"
    assert not listed - read, f"README's configuration table lists variables nothing reads: {sorted(listed - read)}"


def test_only_the_settings_read_nfex_variables() -> None:
    """One source of truth: outside nfex_core/config.py no module reads an ``NFEX_*`` variable itself."""
    readers = [f"{source.relative_to(REPO)}:{text.count(chr(10), 0, m.start()) + 1}"
               for source in _sources("nfex_core", "service", "cli") if source != SETTINGS_MODULE
               for text in [source.read_text()] for m in BYPASS.finditer(text)]
    assert not readers, f"these read NFEX_* variables around Settings: {readers}"
    caught = ['os.environ.get("NFEX_STORE")', "os.getenv('NFEX_DATA')", 'typer.Option(envvar="NFEX_HOST")',
              'os.environ["NFEX_NEURAL"] or 1']
    assert all(BYPASS.search(c) for c in caught) and not BYPASS.search('os.environ["NFEX_STORE"] = store')


def test_the_checks_can_fail(tmp_path: Path) -> None:
    """A stale name is caught by each check."""
    doc = REPO / "docs" / "_stale_check.md"
    doc.write_text("`nfex_core/nothing_here.py`, [gone](img/none.png), `make nothing-here`, `nfex kg frobnicate`, `nfex nope`\n")
    try:
        assert {"nfex_core/nothing_here.py", "docs/img/none.png"} <= {p for p in _paths(doc) if not _exists(p)}
        with pytest.raises(AssertionError, match="nothing-here"):
            test_every_make_target_named_exists(doc)
        with pytest.raises(AssertionError, match=r"nfex kg frobnicate.*nfex nope"):
            test_every_nfex_command_named_exists(doc)
    finally:
        doc.unlink()


STAGE = re.compile(r"─► ([a-z]+)")


def _flow(text: str, start: str) -> tuple[str, ...]:
    """The stage names of the flow picture that starts at ``start``: the words after each ─► up to the closing fence."""
    block = text[text.index(start):]
    return tuple(STAGE.findall(block[: block.index("```")]))


def test_the_flow_pictures_name_the_advisor_pipeline_stages() -> None:
    """README's flow, docs/architecture.md's diagram, the advisor's stage tuple and so the timings_ms keys agree."""
    from nfex_core.advisor.pipeline import STAGES

    assert _flow((REPO / "README.md").read_text(), "frame + context\n") == STAGES
    assert _flow((REPO / "docs" / "architecture.md").read_text(), "frame + context ─►") == STAGES
    assert _flow("frame + context\n  ─► conditions\n  ─► choice\n```", "frame + context\n") != STAGES
