"""The graph as the SPARQL pruning rules see it: admitted evidence only, with robust summaries.

Pruning rules are SPARQL text stored in the graph (rules/pruning/*.rq, or an editor's), so they cannot
call ``trust.admit`` or ``aggregate.robust``. The rule engine therefore evaluates them, once per graph
version, on a *view*: an in-memory copy of the default graph where

- the Measurements that ``admit`` did not admit are absent (every triple they are the subject of), so
  a rule that reads ``?m a nfex:Measurement`` sees admitted evidence only, whoever wrote the rule;
- each (extractor, condition value) with admitted windows has an ``nfex:EvidenceSummary`` carrying the
  robust aggregates (aggregate.py) of those windows, which the shipped measured rules read:

      nfex:ofExtractor, nfex:underCondition        the extractor and the condition value
      nfex:windows, nfex:failedWindows             windows, and those that failed outright
      nfex:ateWindows, nfex:medianAte, nfex:ateOutliers            windows with an ATE, their median, outliers
      nfex:lossWindows, nfex:medianLossRate        windows with a tracking-loss count, median lost/frames
      nfex:sources                                 distinct sources (sweep runs, reporters)

The summaries exist in the view only; ``GET /sparql`` shows the stored graph. Copying costs one
N-Triples dump and load per compile (``bench/bench_rules.py`` prints it).
"""
from __future__ import annotations

import hashlib
import io
from collections.abc import Iterable, Mapping
from typing import TYPE_CHECKING

import pyoxigraph as ox

from ..kg.backends import EmbeddedBackend
from ..namespaces import NFEX
from .aggregate import robust
from .observations import Observation
from .trust import Admission

if TYPE_CHECKING:
    from ..kg.store import KnowledgeGraph

_XSD = "http://www.w3.org/2001/XMLSchema#"


def _lit(v: float | int) -> str:
    return f'"{int(v)}"^^<{_XSD}integer>' if isinstance(v, int) else f'"{float(v)!r}"^^<{_XSD}double>'


def summaries(
    admitted: Iterable[Observation], extractor_iris: Mapping[str, str], value_iris: Mapping[tuple[str, str], str]
) -> str:
    """The ``nfex:EvidenceSummary`` nodes (module docstring) for ``admitted``, as N-Triples."""
    groups: dict[tuple[str, tuple[str, str]], list[Observation]] = {}
    for o in admitted:
        for cond in o.conditions:
            groups.setdefault((o.extractor, cond), []).append(o)
    lines: list[str] = []
    for (x, cond), obs in sorted(groups.items()):
        if x not in extractor_iris or cond not in value_iris:
            continue
        s = "<" + str(NFEX["evidence_" + hashlib.sha1(f"{x}|{cond[0]}|{cond[1]}".encode()).hexdigest()[:16]]) + ">"
        facts: dict[str, str] = {
            "ofExtractor": f"<{extractor_iris[x]}>", "underCondition": f"<{value_iris[cond]}>",
            "windows": _lit(len(obs)), "failedWindows": _lit(sum(o.failed for o in obs)),
            "sources": _lit(len({o.source for o in obs})),
        }
        ates = [o.ate for o in obs if o.ate is not None]
        facts["ateWindows"] = _lit(len(ates))
        if ates:
            agg = robust(ates)
            facts["medianAte"], facts["ateOutliers"] = _lit(agg.value), _lit(agg.outliers)
        rates = [o.lost / o.frames for o in obs if o.lost is not None and o.frames]
        facts["lossWindows"] = _lit(len(rates))
        if rates:
            facts["medianLossRate"] = _lit(robust(rates).value)
        lines.append(f"{s} <http://www.w3.org/1999/02/22-rdf-syntax-ns#type> <{NFEX.EvidenceSummary}> .")
        lines += [f"{s} <{NFEX[k]}> {v} ." for k, v in facts.items()]
    return "\n".join(lines) + "\n"


def evidence_view(
    kg: KnowledgeGraph, admission: Admission, admitted: Iterable[Observation],
    extractor_iris: Mapping[str, str], value_iris: Mapping[tuple[str, str], str],
) -> EmbeddedBackend:
    """An in-memory store holding the view of the module docstring."""
    dump = io.BytesIO()
    kg.backend.query_to("CONSTRUCT { ?s ?p ?o } WHERE { ?s ?p ?o }", "application/n-triples", dump)
    view = EmbeddedBackend(None)
    store: ox.Store = view._store
    store.load(dump.getvalue(), format=ox.RdfFormat.N_TRIPLES)
    out = list(admission.quarantined)
    for i in range(0, len(out), 500):
        values = " ".join(f"<{m}>" for m in out[i : i + 500])
        store.update(f"DELETE {{ ?m ?p ?o }} WHERE {{ VALUES ?m {{ {values} }} ?m ?p ?o }}")
    store.load(summaries(admitted, extractor_iris, value_iris).encode(), format=ox.RdfFormat.N_TRIPLES)
    return view
