"""A model trained once per session on a generated table (the schema of the sweep's training table)."""
from __future__ import annotations

from pathlib import Path

import pytest

from nfex_core.kg import KnowledgeGraph
from nfex_core.kg.vocab import Vocabulary
from nfex_core.neural.artifacts import NeuralModel
from nfex_core.neural.training.train import TrainReport, train

from .tablegen import make_table


@pytest.fixture(scope="session")
def vocab(seeded_template: Path, tmp_path_factory: pytest.TempPathFactory) -> Vocabulary:
    """The seeded graph's vocabulary (the store is closed again, so tests may open their own copies)."""
    import shutil

    d = tmp_path_factory.mktemp("vocab") / "store"
    shutil.copytree(seeded_template, d, ignore=shutil.ignore_patterns("LOCK"))
    kg = KnowledgeGraph.open(str(d))
    try:
        return kg.vocabulary()
    finally:
        kg.close()


@pytest.fixture(scope="session")
def trained(seeded_template: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[TrainReport, NeuralModel]:
    d = tmp_path_factory.mktemp("neural")
    import shutil

    shutil.copytree(seeded_template, d / "store", ignore=shutil.ignore_patterns("LOCK"))
    kg = KnowledgeGraph.open(str(d / "store"))
    try:
        vocab = kg.vocabulary()
        table = make_table(d / "table.csv", vocab, labelled=0.5)
        report = train(table, d / "model", vocab, epochs=150, log=lambda _m: None)
    finally:
        kg.close()
    return report, NeuralModel.load(report.path)
