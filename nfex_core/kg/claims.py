"""Claims on the next graph version: how writers on a shared SPARQL server take turns.

A SPARQL server gives each update atomically but offers no compare-and-swap (Oxigraph 0.5 evaluates a
DELETE/INSERT … WHERE on a snapshot, so two guarded updates can both pass). So a writer first *claims*
version head+1 — inserts ``<urn:nfex:claim:N:id> nfex:claimsVersion N`` — and then reads every claim
on N: if two writers both found theirs alone, each read would precede the other's insert, which
precede their own reads, a cycle. The writer alone commits; the commit deletes every claim up to N.

A writer can die between its claim and its commit (``kill -9``, a lost connection). Its claim must not
block the others for long, so every claim carries its server-side time (``NOW()`` in the update: the
writers' clocks never meet) and a time to live: ``BASE_TTL_S`` plus what sending its change takes
(``TRIPLES_PER_S``, a third of what ``oxigraph serve`` took on the project's loaded 2-core machine:
60k triples/s). A claim past its time is ignored, and a live writer that has not sent its commit by half
its time to live gives its claim up and retries rather than commit on an expired claim.

An embedded store needs none of this: its folder is locked by one process, whose threads take turns
on a lock (``Backend.exclusive``), so no claim can be left behind by a dead writer.
"""
from __future__ import annotations

import uuid
from dataclasses import dataclass
from datetime import datetime

from rdflib.namespace import XSD
from rdflib.term import Literal, URIRef

from .backends import Backend
from .namespaces import NFEX
from .terms import n3, py

META = URIRef("urn:nfex:meta")
BASE_TTL_S = 3.0
TRIPLES_PER_S = 20_000.0


def ttl_for(triples: int) -> float:
    """How long a claim for a change of ``triples`` triples may stand (module docstring)."""
    return BASE_TTL_S + triples / TRIPLES_PER_S


@dataclass(frozen=True)
class Claim:
    iri: URIRef
    version: int
    ttl_s: float


@dataclass(frozen=True)
class Rival:
    """Another writer's live claim on the same version, and how long it may still stand."""

    iri: str
    left_s: float


def take(backend: Backend, version: int, ttl_s: float) -> Claim:
    """Insert a claim on ``version`` stamped with the server's clock."""
    claim = URIRef(f"urn:nfex:claim:{version}:{uuid.uuid4().hex}")
    backend.update(
        f"INSERT {{ GRAPH {n3(META)} {{ {n3(claim)} {n3(NFEX.claimsVersion)} {version} ; "
        f"{n3(NFEX.claimedAt)} ?now ; {n3(NFEX.claimTtl)} {n3(Literal(ttl_s, datatype=XSD.double))} }} }} "
        "WHERE { BIND (NOW() AS ?now) }"
    )
    return Claim(claim, version, ttl_s)


def rivals(backend: Backend, claim: Claim) -> list[Rival]:
    """The other claims on ``claim.version`` still within their time to live, by the server's clock.

    Claims without a time to live (written before claims expired this way) are not rivals."""
    rows = backend.select(
        f"SELECT ?c ?at ?ttl (NOW() AS ?now) WHERE {{ GRAPH {n3(META)} {{ ?c {n3(NFEX.claimsVersion)} {claim.version} ; "
        f"{n3(NFEX.claimedAt)} ?at ; {n3(NFEX.claimTtl)} ?ttl }} FILTER (?c != {n3(claim.iri)}) }}"
    ).rows
    out: list[Rival] = []
    for r in rows:
        at, now, ttl = py(r["at"]), py(r["now"]), py(r["ttl"])
        if not isinstance(at, datetime) or not isinstance(now, datetime):
            continue
        left = float(ttl) - (now - at).total_seconds()
        if left > 0:
            out.append(Rival(str(r["c"]), left))
    return out


def release(backend: Backend, claim: Claim) -> None:
    backend.update(f"DELETE WHERE {{ GRAPH {n3(META)} {{ {n3(claim.iri)} ?p ?o }} }}")


def settle_update(version: int) -> str:
    """The update part that drops every claim on versions up to ``version`` (losers' and dead writers')."""
    return (
        f"DELETE {{ GRAPH {n3(META)} {{ ?c ?p ?o }} }} WHERE {{ GRAPH {n3(META)} {{ ?c {n3(NFEX.claimsVersion)} ?n ; ?p ?o . "
        f"FILTER (?n <= {version}) }} }}"
    )
