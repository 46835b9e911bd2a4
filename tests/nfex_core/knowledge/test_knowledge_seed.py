"""Seeding refuses to build a store from a home without an ontology (it would be silently empty)."""
from __future__ import annotations

from pathlib import Path

import pytest

from nfex_core.config import Settings
from nfex_core.errors import DataMissing
from nfex_core.knowledge import open_graph


def test_a_home_without_an_ontology_is_a_clear_error(tmp_path: Path) -> None:
    settings = Settings.from_env().replace(home=tmp_path / "empty-home")
    with pytest.raises(DataMissing, match="no ontology to seed from"):
        open_graph(str(tmp_path / "store"), settings=settings)
