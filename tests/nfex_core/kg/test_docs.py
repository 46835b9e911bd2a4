"""`make docs`: pyLODE renders one HTML page documenting every class and property of the ontology modules."""
from __future__ import annotations

import re
from pathlib import Path

import pytest
from rdflib.namespace import OWL, RDF

from nfex_core.kg.docs import ontology_modules, render
from nfex_core.kg.namespaces import NFEX


def test_the_page_documents_every_class_and_property(tmp_path: Path) -> None:
    pytest.importorskip("pylode")
    page = render(tmp_path / "ontology")
    html = page.read_text()
    assert "<title>nFEX" in html
    assert len(re.findall(r'id="([^"]+)"', html)) > 100  # a section per term
    onto = ontology_modules()
    terms = {t for kind in (OWL.Class, OWL.ObjectProperty, OWL.DatatypeProperty) for t in onto.subjects(RDF.type, kind)
             if str(t).startswith(str(NFEX))}
    assert len(terms) > 100
    assert sorted(str(t) for t in terms if str(t) not in html) == []  # each term's section gives its IRI
    assert "#meas_" not in html  # the vocabulary, not the measured data
