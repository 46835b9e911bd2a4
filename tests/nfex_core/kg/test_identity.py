"""One identity per sequence: feedback, sweeps and the evaluation's hold-out all reach the IRI that
``identity.sequence_iri`` mints from (dataset, sequence), whether the sequence comes as its id ("01") or
as a dataset key ("kitti/01", what a client's Sequence.key gives) — never matched by label."""
from __future__ import annotations

import rdflib
from hypothesis import given
from hypothesis import strategies as st
from nfex_slam.datasets.synthetic import make_sequence

from nfex_core.feedback import Feedback, measurement_graph
from nfex_core.kg import KnowledgeGraph
from nfex_core.kg.identity import sequence_iri
from nfex_core.kg.namespaces import NFEX
from nfex_core.sweeps.records import sequence_triples

NAMES = st.from_regex(r"[a-z0-9][a-z0-9_-]{0,11}", fullmatch=True)


@given(dataset=NAMES, sequence=NAMES)
def test_a_key_and_an_id_mint_the_same_iri(dataset: str, sequence: str) -> None:
    assert sequence_iri(dataset, f"{dataset}/{sequence}") == sequence_iri(dataset, sequence)
    assert sequence_iri(dataset, sequence) != sequence_iri(None, sequence)  # the dataset is part of it


def test_feedback_and_sweeps_name_the_sequence_the_evaluation_holds_out(bare_kg: KnowledgeGraph) -> None:
    held = sequence_iri("kitti", "01")  # what nfex evaluate holds out for KITTI 01
    g, m = measurement_graph(bare_kg.vocabulary(), Feedback(extractor="ORB", sequence="kitti/01", dataset="kitti",
                                                            ate_rmse=0.5, reporter="carol"))
    assert g.value(m, NFEX.sequence) == held
    assert sequence_triples(rdflib.Graph(), "kitti", "01") == held
    seq = make_sequence(2)
    assert sequence_iri(seq.dataset, seq.key) == sequence_iri(seq.dataset, seq.name)
