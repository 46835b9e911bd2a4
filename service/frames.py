"""Reading a selection request (multipart frame + context, or JSON context) and running the advisor."""
from __future__ import annotations

from typing import Any

import numpy as np
from fastapi import Request
from pydantic import ValidationError
from starlette.datastructures import UploadFile

from nfex_core.advisor import Selection
from nfex_core.errors import BadInput

from .bodies import media_type, strict_json
from .config import Settings
from .images import PayloadTooLarge, UnsupportedMediaType, decode_frame
from .schemas import SelectRequest


def parse_context(text: str | bytes | None) -> dict[str, str | None]:
    """The multipart ``context`` part: a JSON object of condition dimension → value (or ``{"context": {…}}``).
    A value may be a string, a finite number (``budget_ms``: ``20`` or ``"20"``) or null; every 400 names the
    key and what was wrong with it."""
    if text is None or (isinstance(text, str | bytes) and not text.strip()):
        return {}
    data = strict_json(text, "the context part")
    if isinstance(data, dict) and set(data) == {"context"} and isinstance(data["context"], dict):
        data = data["context"]
    if not isinstance(data, dict):
        raise BadInput(f'context must be a JSON object of condition dimension → value, e.g. {{"light": "dark"}}, '
                       f"not {type(data).__name__ if not isinstance(data, list) else 'an array'}")
    return context_values(data)


def context_values(data: dict[str, Any]) -> dict[str, str | None]:
    """Condition dimension → value as strings; numbers (not booleans) are written as the client sent them."""
    out: dict[str, str | None] = {}
    for key, value in data.items():
        if value is None or isinstance(value, str):
            out[key] = value
        elif isinstance(value, int | float) and not isinstance(value, bool):
            out[key] = str(value)
        else:
            kind = {bool: "a boolean", dict: "an object", list: "an array"}.get(type(value), type(value).__name__)
            raise BadInput(f"context[{key!r}] is {kind}; a condition value is a string, a number (budget_ms) or null",
                           key=key)
    return out


async def read_select(request: Request, settings: Settings, *, frame_required: bool = False) -> tuple[dict[str, str | None], np.ndarray | None]:
    """(context, frame or None) from a JSON body or a multipart form with ``frame`` and ``context``."""
    media = media_type(request.headers.get("content-type"))
    if media == "application/json":
        body = await request.body()
        try:
            req = SelectRequest.model_validate_json(body or b"{}")
        except ValidationError as e:
            first = e.errors()[0]
            raise BadInput(f"invalid JSON body: {'.'.join(str(x) for x in first['loc'])}: {first['msg']}",
                           errors=[{"loc": list(x["loc"]), "msg": x["msg"]} for x in e.errors()]) from None
        if frame_required:
            raise BadInput("a stream frame needs an image: send multipart/form-data with a 'frame' part")
        return req.context, None
    if media == "multipart/form-data":
        try:
            form = await request.form(max_files=1, max_fields=4, max_part_size=settings.max_image_bytes + 1)
        except PayloadTooLarge:
            raise
        except Exception as e:  # python-multipart / starlette raise several types for broken forms
            if "exceed" in str(e).lower() or "too large" in str(e).lower():
                raise PayloadTooLarge(f"a form part is too large: {e}", limit=settings.max_image_bytes) from e
            raise BadInput(f"the multipart form cannot be read: {e}") from e
        try:
            unknown = set(form.keys()) - {"frame", "context"}
            if unknown:
                raise BadInput(f"unknown form fields {sorted(unknown)}; send 'frame' (PNG/JPEG) and 'context' (JSON)")
            ctx_part = form.get("context")
            ctx_text: str | bytes | None = await ctx_part.read() if isinstance(ctx_part, UploadFile) else ctx_part
            context = parse_context(ctx_text)
            part = form.get("frame")
            if part is None:
                if frame_required:
                    raise BadInput("no 'frame' part in the form")
                return context, None
            if not isinstance(part, UploadFile):
                raise BadInput("'frame' must be a file part (PNG or JPEG)")
            data = await part.read(settings.max_image_bytes + 1)
            image = decode_frame(data, part.content_type, max_bytes=settings.max_image_bytes, max_pixels=settings.max_pixels,
                                 max_decoded_bytes=settings.max_decoded_bytes)
            return context, image
        finally:
            await form.close()
    raise UnsupportedMediaType(
        f"send application/json ({{\"context\": …}}) or multipart/form-data (frame + context), not {media or 'nothing'!r}"
    )


KEYPOINTS_SHOWN = 5000  # the strongest keypoints listed (by response); ``count`` gives them all


def keypoints_flag(text: str) -> bool:
    value = text.strip().lower()
    if value not in ("1", "true", "yes", "0", "false", "no", ""):
        raise BadInput(f"keypoints must be true or false, not {text!r}")
    return value in ("1", "true", "yes")


def keypoints_of(vocab: Any, selection: Selection, frame: np.ndarray | None) -> dict[str, Any]:
    """The keypoints α* finds with Θ′ on the full frame, as a client would extract them: pixel positions
    (x right, y down) and diameters, strongest first."""
    if frame is None:
        raise BadInput("keypoints need a frame: send multipart/form-data with a 'frame' part")
    from nfex_core.vision.registry import ExtractorRegistry

    feats = ExtractorRegistry.from_vocabulary(vocab).extract(selection.extractor, frame, selection.params)
    order = np.argsort(-feats.response, kind="stable")[:KEYPOINTS_SHOWN]
    xy = np.round(feats.xy[order].astype(float), 1)
    size = np.round(feats.size[order].astype(float), 1)
    return {
        "extractor": selection.extractor,
        "count": len(feats),
        "width": int(frame.shape[1]),
        "height": int(frame.shape[0]),
        "xy": xy.tolist(),
        "size": size.tolist(),
        "extraction_ms": round(feats.elapsed_ms, 3),
    }
