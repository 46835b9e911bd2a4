"""Dependencies shared by the routers (FastAPI ``Annotated`` aliases)."""
from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Request

from nfex_core.kg import KnowledgeGraph


def get_kg(request: Request) -> KnowledgeGraph:
    return request.app.state.kg  # type: ignore[no-any-return]


KGDep = Annotated[KnowledgeGraph, Depends(get_kg)]
