"""Frames of the data folder's sequences (``NFEX_DATA``) to try a selection on, by id (the workbench's
"pick a dataset frame"). Only frames ``nfex_slam.datasets.samples`` found can be read."""
from __future__ import annotations

from functools import lru_cache
from pathlib import Path
from typing import Any

from fastapi import APIRouter
from fastapi.responses import FileResponse
from nfex_slam.datasets.samples import Sample, samples

from nfex_core.errors import NotFound

from ..deps import SettingsDep
from ..schemas import PROBLEM_RESPONSES

router = APIRouter(prefix="/v1/samples", tags=["workbench"], responses=PROBLEM_RESPONSES)
MEDIA = {".png": "image/png", ".jpg": "image/jpeg", ".jpeg": "image/jpeg"}


@lru_cache(maxsize=4)
def _found(data: Path) -> tuple[Sample, ...]:
    return tuple(s for s in samples(data) if s.path.suffix.lower() in MEDIA)


@router.get("", summary="Frames of the shared datasets, with the context their sequence is known for")
def list_samples(settings: SettingsDep) -> dict[str, Any]:
    data = settings.data
    return {"data": str(data), "samples": [s.as_dict() for s in _found(data)]}


IMAGE = {"schema": {"type": "string", "format": "binary"}}


@router.get("/{sample_id}", summary="One frame's image (PNG or JPEG)", response_class=FileResponse,
            responses={200: {"content": {"image/png": IMAGE, "image/jpeg": IMAGE}, "description": "The frame's file."}})
def get_sample(sample_id: str, settings: SettingsDep) -> FileResponse:
    for s in _found(settings.data):
        if s.id == sample_id:
            return FileResponse(s.path, media_type=MEDIA[s.path.suffix.lower()])
    raise NotFound(f"no sample {sample_id!r}; GET /v1/samples lists them")
