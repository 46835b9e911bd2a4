"""HTML documentation of the ontology (``make docs``), rendered by pyLODE from the modules in ``ontology/``.

pyLODE documents one ontology: the modules are merged into one graph under the core ontology's header
(``owl_only`` collapses their headers and imports), the generated measurements left out — they are data,
not vocabulary. The page is written to a folder that is not committed (default ``out/docs/ontology``):
it is a build product of the Turtle files, regenerated on every change, and a committed copy would drift.

    python -m nfex_core.kg.vocabulary.docs [DEST]      # needs the ``docs`` extra (pyLODE)
"""
from __future__ import annotations

import sys
from pathlib import Path

import rdflib

from ...config import Settings
from .owl import owl_only


def ontology_modules(settings: Settings | None = None) -> rdflib.Graph:
    """The modules of ``ontology/`` (not ``ontology/measurements/``) merged, as OWL."""
    settings = settings or Settings.from_env()
    merged = rdflib.Graph()
    for path in sorted(settings.ontology_dir.glob("*.ttl")):
        merged.parse(path)
    return owl_only(merged)


def render(dest: Path, settings: Settings | None = None) -> Path:
    """Write ``dest/index.html`` documenting the ontology; returns its path."""
    from pylode import OntPub  # the docs extra; imported here so nfex_core never needs it

    dest.mkdir(parents=True, exist_ok=True)
    page = dest / "index.html"
    OntPub(ontology=ontology_modules(settings)).make_html(destination=page)
    return page


if __name__ == "__main__":
    print(render(Path(sys.argv[1] if len(sys.argv) > 1 else "out/docs/ontology")))
