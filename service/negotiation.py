"""Content negotiation for SPARQL results and graphs (SPARQL 1.1 Protocol §2.1, Graph Store Protocol §5).

``Accept`` with q-values decides, after aliases clients really send are mapped to the media types served;
``format=``/``output=``/``results=`` (what SPARQLWrapper sends in its default mode, with words such as
``json``, ``json-ld``, ``rdf+xml``, ``n3`` or a MIME type) take precedence where they name a format the
query form can carry, and are ignored where they do not, so ``Accept`` decides then.
"""
from __future__ import annotations

from nfex_core.errors import NfexError
from nfex_core.kg.storage.backends import GRAPH_FORMATS, RESULT_FORMATS


class NotAcceptable(NfexError):
    status = 406
    type = "not-acceptable"
    title = "Not acceptable"
    exit_code = 2


GRAPH_FORMS = ("construct", "describe")
# Media types clients send that name one we serve, per kind of result. A client asking for JSON or XML
# gets the JSON or XML serialisation of what the query form returns: rdflib's SPARQLStore with
# returnFormat="json" sends only application/sparql-results+json, for a CONSTRUCT too.
RESULT_ALIASES = {
    "application/json": "application/sparql-results+json",
    "text/javascript": "application/sparql-results+json",
    "application/javascript": "application/sparql-results+json",
    "application/xml": "application/sparql-results+xml",
    "text/xml": "application/sparql-results+xml",
}
GRAPH_ALIASES = {
    "application/json": "application/ld+json",
    "application/sparql-results+json": "application/ld+json",
    "application/x-json+ld": "application/ld+json",
    "application/xml": "application/rdf+xml",
    "text/xml": "application/rdf+xml",
    "application/sparql-results+xml": "application/rdf+xml",
    "text/plain": "application/n-triples",
    "application/x-turtle": "text/turtle",
    "application/turtle": "text/turtle",
    "text/n3": "text/turtle",  # Turtle is N3 (what N3 clients parse)
    "text/rdf+n3": "text/turtle",
    "application/n3": "text/turtle",
}
# Words in format= / output= / results= (SPARQLWrapper sends all three; Virtuoso reads format, Joseki
# output): (for SELECT/ASK, for CONSTRUCT/DESCRIBE).
FORMAT_WORDS: dict[str, tuple[str | None, str | None]] = {
    "json": ("application/sparql-results+json", "application/ld+json"),
    "xml": ("application/sparql-results+xml", "application/rdf+xml"),
    "csv": ("text/csv", None),
    "tsv": ("text/tab-separated-values", None),
    "turtle": (None, "text/turtle"),
    "ttl": (None, "text/turtle"),
    "n3": (None, "text/turtle"),
    "ntriples": (None, "application/n-triples"),
    "n-triples": (None, "application/n-triples"),
    "nt": (None, "application/n-triples"),
    "json-ld": (None, "application/ld+json"),
    "jsonld": (None, "application/ld+json"),
    "rdf+xml": (None, "application/rdf+xml"),
    "rdfxml": (None, "application/rdf+xml"),
    "rdf": (None, "application/rdf+xml"),
}
FORMAT_PARAMS = ("format", "output", "results")


def offered(form: str) -> list[str]:
    """What a ``form`` query can be answered in, the default first."""
    return list(GRAPH_FORMATS) if form in GRAPH_FORMS else list(RESULT_FORMATS)


def alias(media: str, form: str) -> str:
    return (GRAPH_ALIASES if form in GRAPH_FORMS else RESULT_ALIASES).get(media, media)


def from_format_params(values: list[str], form: str) -> str | None:
    """The first of ``values`` (format=, output=, results=) that names a format for ``form``, else None.

    A word (json, xml, csv, tsv, turtle, n3, json-ld, rdf+xml…) or a media type; values that name
    nothing this form can carry are ignored, so Accept decides (SPARQLWrapper sends its format word
    whatever the form, and a MIME type beside the words it fears servers reject)."""
    graph = form in GRAPH_FORMS
    for value in values:
        v = value.strip().lower()
        if "/" in v:
            media: str | None = alias(v.split(";")[0].strip(), form)
        else:
            media = FORMAT_WORDS.get(v, (None, None))[graph]
        if media in offered(form):
            return media
    return None


def negotiate(accept: str | None, form: str) -> str:
    """The media type to answer a ``form`` query with, from an Accept header (q-values honoured)."""
    choices = offered(form)
    if not accept:
        return choices[0]
    ranked: list[tuple[float, int, str]] = []
    for i, part in enumerate(accept.split(",")):
        fields = [f.strip() for f in part.split(";")]
        media = fields[0].lower()
        q = 1.0
        for f in fields[1:]:
            if f.startswith("q="):
                try:
                    q = float(f[2:])
                except ValueError:
                    q = 0.0
        ranked.append((q, -i, alias(media, form)))
    for q, _, media in sorted(ranked, reverse=True):
        if q <= 0:
            continue
        if media in choices:
            return media
        if media in ("*/*", "*"):
            return choices[0]
        if media.endswith("/*") and any(o.startswith(media[:-1]) for o in choices):
            return next(o for o in choices if o.startswith(media[:-1]))
    raise NotAcceptable(
        f"none of {accept!r} can carry a {form.upper()} result; offered: {', '.join(choices)}", offered=choices
    )
