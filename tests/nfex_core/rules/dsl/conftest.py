"""A vocabulary read from the repository's ontology files (no store, ~0.1 s)."""
from __future__ import annotations

import pytest

from nfex_core.config import Settings
from nfex_core.kg.shipped import ontology_vocabulary
from nfex_core.kg.vocabulary.vocab import Vocabulary


@pytest.fixture(scope="session")
def vocab() -> Vocabulary:
    return ontology_vocabulary(Settings.from_env())
