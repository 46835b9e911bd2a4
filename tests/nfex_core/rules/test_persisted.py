"""The compiled table kept on disk (rules/persisted.py): read back at a start it answers as a fresh compile would,
later compiles carry from it, and it is not used for another store, another commit, other code, other missing
backends or a file that does not read."""
from __future__ import annotations

import logging
import random
import shutil
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from nfex_core.feedback import ReportWriter
from nfex_core.kg import KnowledgeGraph
from nfex_core.knowledge import open_graph
from nfex_core.rules import persisted
from nfex_core.rules.engine import RuleEngine, backend_citations, compile_table
from nfex_core.rules.persisted import CompiledCache, store_key
from tests.conftest import CARRIED_EXAMPLES

from ..evidence.test_index import OPS, _apply
from .test_setup import CONFIGURATION, _configure, _same


def _engine(kg: KnowledgeGraph, folder: Path) -> RuleEngine:
    key = store_key(kg)
    assert key is not None
    return RuleEngine(kg, CompiledCache(folder, key))


def _absent(kg: KnowledgeGraph) -> dict:  # type: ignore[type-arg]
    return backend_citations(kg, kg.vocabulary().extractors)


def test_a_kept_table_answers_as_a_fresh_compile(shipped_kg: KnowledgeGraph, tmp_path: Path) -> None:
    first = _engine(shipped_kg, tmp_path)
    compiled = first.table()
    first.save()
    again = _engine(shipped_kg, tmp_path)
    kept = again.table()
    assert kept.kept_in is not None and compiled.kept_in is None
    _same(kept, compile_table(shipped_kg))


@CARRIED_EXAMPLES
@given(ops=st.lists(st.sampled_from((*OPS, *CONFIGURATION)), min_size=1, max_size=3), seed=st.integers(0, 2**32 - 1))
def test_compiles_carried_from_a_kept_table_equal_full_compiles(shipped_kg: KnowledgeGraph, tmp_path_factory: pytest.TempPathFactory,
                                                                 ops: list[str], seed: int) -> None:
    """Changes made while the service is down (the CLI, another replica) and after it starts again."""
    rng = random.Random(seed)
    folder = tmp_path_factory.mktemp("compiled")
    engine = _engine(shipped_kg, folder)
    engine.table()
    engine.save()
    writer = ReportWriter(shipped_kg, max_items=1)
    try:
        down, up = ops[: len(ops) // 2], ops[len(ops) // 2:]
        for op in down:
            _configure(shipped_kg, op, rng) if op in CONFIGURATION else _apply(shipped_kg, op, rng, writer)
        restarted = _engine(shipped_kg, folder)
        _same(restarted.table(), compile_table(shipped_kg))
        for op in up:
            _configure(shipped_kg, op, rng) if op in CONFIGURATION else _apply(shipped_kg, op, rng, writer)
            _same(restarted.table(), compile_table(shipped_kg))
    finally:
        writer.close()


def test_the_kept_table_of_another_store_or_commit_is_not_used(shipped_kg: KnowledgeGraph, tmp_path: Path) -> None:
    engine = _engine(shipped_kg, tmp_path / "compiled")
    engine.table()
    engine.save()
    key = store_key(shipped_kg)
    assert key is not None
    assert CompiledCache(tmp_path / "compiled", key).load(shipped_kg, _absent(shipped_kg)) is not None
    # another store at the same place: seeded again, its version 1 is another commit
    other = tmp_path / "other"
    with open_graph(str(other)) as kg:
        assert CompiledCache(tmp_path / "compiled", key).load(kg, _absent(kg)) is None
    # other code, other missing backends, a file that does not read
    cache = CompiledCache(tmp_path / "compiled", key)
    old = persisted._CODE  # noqa: SLF001
    try:
        persisted._CODE = "other code"  # noqa: SLF001
        assert cache.load(shipped_kg, _absent(shipped_kg)) is None
    finally:
        persisted._CODE = old  # noqa: SLF001
    assert cache.load(shipped_kg, {"XFEAT": "not installed"}) is None
    cache.path.write_bytes(cache.path.read_bytes()[:1000])
    assert cache.load(shipped_kg, _absent(shipped_kg)) is None


def test_a_store_restored_from_an_older_copy_is_compiled(seeded_template: Path, tmp_path: Path,
                                                          caplog: pytest.LogCaptureFixture) -> None:
    """The kept table is of version n; the folder then holds a copy from before n (a backup put back)."""
    store = tmp_path / "store"
    shutil.copytree(seeded_template, store, ignore=shutil.ignore_patterns("LOCK"))
    backup = tmp_path / "backup"
    shutil.copytree(store, backup)
    kg = KnowledgeGraph.open(str(store))
    kg.update("PREFIX nfex: <https://w3id.org/nfex#> INSERT DATA { nfex:ORB nfex:note \"a\" }", author="test")
    engine = _engine(kg, tmp_path / "compiled")
    engine.table()
    engine.save()
    kg.close()
    shutil.rmtree(store)
    shutil.copytree(backup, store)
    with KnowledgeGraph.open(str(store)) as kg, caplog.at_level(logging.INFO, logger="nfex.rules"):
        table = _engine(kg, tmp_path / "compiled").table()
        assert table.kept_in is None and table.version == kg.version
        assert "not of this store's version" in caplog.text
