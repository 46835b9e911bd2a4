"""The API's vocabulary, read from the graph: condition dimensions and values, extractors, metrics."""
from __future__ import annotations

from fastapi import APIRouter

from ..deps import KGDep
from ..schemas import Vocabulary

router = APIRouter(prefix="/v1", tags=["vocabulary"])


@router.get("/vocabulary", summary="Condition values, extractors and metrics the graph knows", response_model=Vocabulary)
def vocabulary(kg: KGDep) -> dict[str, object]:
    v = kg.vocabulary()
    return {
        "graph_version": v.version,
        "context": {d.name: {"values": list(d.values), "estimable": d.estimable} for d in v.dimensions.values()},
        "extractors": {
            x.name: {
                "constructor": x.constructor,
                "norm": x.norm,
                "parameters": {
                    p.name: {"role": p.role, "datatype": p.datatype, "default": p.default, "range": p.range_text()}
                    for p in x.parameters.values()
                },
            }
            for x in v.extractors.values()
        },
        "metrics": {m.name: {"symbol": m.symbol, "temporal": m.temporal} for m in v.metrics.values()},
    }
