"""Saved SPARQL queries (``$NFEX_HOME/docs/queries/*.rq``): the workbench's examples.

A file's leading ``#`` comment lines are its title; the rest is the query, as the service runs it
(nFEX's prefixes are predeclared)."""
from __future__ import annotations

from typing import Any

from fastapi import APIRouter

from ..deps import SettingsDep

router = APIRouter(prefix="/v1/queries", tags=["workbench"])


@router.get("", summary="The saved SPARQL queries, with their titles")
def saved_queries(settings: SettingsDep) -> dict[str, Any]:
    folder = settings.home / "docs" / "queries"
    out = []
    for path in sorted(folder.glob("*.rq")) if folder.is_dir() else []:
        text = path.read_text(encoding="utf-8")
        lines = text.splitlines()
        title = " ".join(line.lstrip("# ").strip() for line in lines if line.startswith("#")) or path.stem
        out.append({"name": path.stem, "title": title, "query": text})
    return {"queries": out}
