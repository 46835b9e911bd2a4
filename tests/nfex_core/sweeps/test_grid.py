from __future__ import annotations

import json

from nfex_core.kg import KnowledgeGraph
from nfex_core.sweeps.grid import canonical, grid


def test_presets_give_24_valid_sets_with_the_default_first(kg: KnowledgeGraph) -> None:
    vocab = kg.vocabulary()
    for x in ("ORB", "SIFT"):
        spec = vocab.extractor(x)
        sets = grid(spec)
        assert len(sets) == 24
        assert sets[0] == spec.resolve({})
        assert len({canonical(s) for s in sets}) == 24
        for s in sets:
            assert spec.resolve(s) == s  # every value inside the graph's range


def test_sample_is_seeded_and_keeps_the_default(kg: KnowledgeGraph) -> None:
    spec = kg.vocabulary().extractor("ORB")
    a, b, c = grid(spec, sample=5, seed=1), grid(spec, sample=5, seed=1), grid(spec, sample=5, seed=2)
    assert len(a) == 5 and a == b and a != c
    assert a[0] == spec.resolve({})


def test_explicit_values_and_canonical_text(kg: KnowledgeGraph) -> None:
    spec = kg.vocabulary().extractor("ORB")
    sets = grid(spec, {"nfeatures": [500, 800]})
    assert [s["nfeatures"] for s in sets] == [500, 800]
    text = canonical(sets[1])
    assert json.loads(text) == sets[1] and text == canonical(dict(reversed(list(sets[1].items()))))
