"""Namespaces used across nFEX.

Every nFEX term lives under one base namespace, ``https://w3id.org/nfex#`` (prefix ``nfex:``).
Graph bookkeeping (versions, change sets) uses ``urn:nfex:`` IRIs in named graphs so that the
default graph holds the knowledge itself.
"""
from __future__ import annotations

from rdflib import Namespace
from rdflib.namespace import DCTERMS, OWL, PROV, RDF, RDFS, SH, SOSA, XSD

NFEX = Namespace("https://w3id.org/nfex#")
NFEX_ONTOLOGY = "https://w3id.org/nfex"
# Skolem IRIs for blank nodes (RDF 1.1 Concepts §3.5): a store cannot address blank nodes across requests.
GENID = "https://w3id.org/nfex/.well-known/genid/"

PREFIXES: dict[str, str] = {
    "nfex": str(NFEX),
    "rdf": str(RDF),
    "rdfs": str(RDFS),
    "owl": str(OWL),
    "xsd": str(XSD),
    "sh": str(SH),
    "sosa": str(SOSA),
    "prov": str(PROV),
    "dcterms": str(DCTERMS),
}


def sparql_prefixes() -> str:
    """PREFIX declarations for every namespace above, for queries written in the code."""
    return "".join(f"PREFIX {p}: <{ns}>\n" for p, ns in PREFIXES.items())


__all__ = ["NFEX", "NFEX_ONTOLOGY", "GENID", "PREFIXES", "sparql_prefixes", "RDF", "RDFS", "OWL", "XSD", "SH", "SOSA", "PROV", "DCTERMS"]
