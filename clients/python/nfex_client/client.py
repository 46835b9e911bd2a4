"""Sync and async clients for the nFEX service. Both share ``_Requests``, which builds each request and
reads each answer; only the transport differs (``httpx.Client`` vs ``httpx.AsyncClient``)."""
from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import httpx

from .errors import raise_for_problem
from .schema import (
    Diff,
    Health,
    Ready,
    Selection,
    Session,
    SessionSelection,
    Verdict,
    VersionInfo,
    Vocabulary,
    WriteResult,
)

Context = Mapping[str, str | None]


@dataclass(frozen=True)
class Call:
    method: str
    path: str
    kwargs: dict[str, Any]
    parse: str = "json"  # json | text | none


def _frame_bytes(frame: Any) -> tuple[bytes, str]:
    if isinstance(frame, bytes | bytearray | memoryview):
        data = bytes(frame)
        return data, "image/jpeg" if data[:3] == b"\xff\xd8\xff" else "image/png"
    from .opencv import encode_png

    return encode_png(frame), "image/png"


def _tried(t: Mapping[str, Any]) -> dict[str, Any]:
    """One tried candidate as the service reads it: numpy arrays (R, t) become lists."""
    out = dict(t)
    for k in ("R", "t"):
        if out.get(k) is not None and hasattr(out[k], "tolist"):
            out[k] = out[k].tolist()
    return out


def _if_match(version: int | None) -> dict[str, str]:
    return {"If-Match": f'"{version}"'} if version is not None else {}


class _Requests:
    """Request builders: one per endpoint."""

    @staticmethod
    def select(context: Context | None, frame: Any, consistency: str = "snapshot") -> Call:
        params = {"params": {"consistency": consistency}} if consistency != "snapshot" else {}
        if frame is None:
            return Call("POST", "/v1/select", {"json": {"context": dict(context or {})}, **params})
        data, media = _frame_bytes(frame)
        return Call("POST", "/v1/select", {"files": {"frame": ("frame", data, media)}, "data": {"context": json.dumps(dict(context or {}))},
                                           **params})

    @staticmethod
    def session_frame(session_id: str, frame: Any, context: Context | None) -> Call:
        data, media = _frame_bytes(frame)
        form = {"context": json.dumps(dict(context))} if context else {}
        return Call("POST", f"/v1/sessions/{session_id}/frames", {"files": {"frame": ("frame", data, media)}, "data": form})

    @staticmethod
    def verdict(session_id: str, tried: list[Mapping[str, Any]]) -> Call:
        return Call("POST", f"/v1/sessions/{session_id}/verdict", {"json": {"tried": [_tried(t) for t in tried]}})

    @staticmethod
    def sparql(query: str, accept: str) -> Call:
        parse = "json" if "json" in accept else "text"
        return Call("POST", "/sparql", {"content": query.encode(), "headers": {"Content-Type": "application/sparql-query", "Accept": accept}}, parse)

    @staticmethod
    def update(update: str, if_match: int | None) -> Call:
        return Call("POST", "/sparql/update", {"content": update.encode(), "headers": {"Content-Type": "application/sparql-update", **_if_match(if_match)}})

    @staticmethod
    def feedback(fields: dict[str, Any], idempotency_key: str | None) -> Call:
        headers = {"Idempotency-Key": idempotency_key} if idempotency_key else {}
        return Call("POST", "/v1/feedback", {"json": fields, "headers": headers})


def _result(call: Call, response: httpx.Response) -> Any:
    raise_for_problem(response)
    if call.parse == "none" or response.status_code == 204:
        return None
    if call.parse == "text":
        return response.text
    return response.json()


class NfexClient:
    """Blocking client. ``token``: a bearer token — the reporter role for feedback, editor for edits (reads need none)."""

    def __init__(self, base_url: str, *, token: str | None = None, timeout: float = 30.0, **httpx_kwargs: Any) -> None:
        headers = {"Authorization": f"Bearer {token}"} if token else {}
        self.http = httpx.Client(base_url=base_url, timeout=timeout, headers=headers, **httpx_kwargs)

    def __enter__(self) -> NfexClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        self.http.close()

    def _do(self, call: Call) -> Any:
        return _result(call, self.http.request(call.method, call.path, **call.kwargs))

    def _json(self, method: str, path: str, **kwargs: Any) -> Any:
        return self._do(Call(method, path, kwargs))

    # -- selection and streams
    def select(self, context: Context | None = None, frame: Any = None, consistency: str = "snapshot") -> Selection:
        """α, Θ′ and why, for a context and optionally a frame (numpy array, or PNG/JPEG bytes). ``consistency``:
        ``snapshot`` (the last compiled graph version answers at once) or ``latest`` (wait for the head's compile,
        e.g. to see one's own feedback)."""
        return self._do(_Requests.select(context, frame, consistency))

    def open_session(self, context: Context | None = None, client: str | None = None) -> Session:
        return self._json("POST", "/v1/sessions", json={"context": dict(context or {}), "client": client})

    def session_frame(self, session_id: str, frame: Any, context: Context | None = None) -> SessionSelection:
        return self._do(_Requests.session_frame(session_id, frame, context))

    def verdict(self, session_id: str, tried: list[Mapping[str, Any]]) -> Verdict:
        """Judge the last frame's pair: ``tried`` holds, in the order of the frame's ``verification.proposals``,
        what each estimate showed (extractor, params, R, t — numpy or lists; None for a lost pair — keypoints,
        matches, inliers, parallax_px, extraction_ms, rejected). The answer's ``action`` is accept (use
        ``tried[accepted]``), next (extract and match ``next``, then call again with it appended) or fallback
        (use the motion prior)."""
        return self._do(_Requests.verdict(session_id, tried))

    def close_session(self, session_id: str) -> None:
        self._do(Call("DELETE", f"/v1/sessions/{session_id}", {}, "none"))

    def feedback(self, *, idempotency_key: str | None = None, **fields: Any) -> WriteResult:
        """Report a measured result (extractor, params, context, window, ate_rmse, tracking_lost…). Send the same
        ``idempotency_key`` when retrying a report whose answer was lost: the service stores it once."""
        return self._do(_Requests.feedback(fields, idempotency_key))

    # -- reading
    def health(self) -> Health:
        return self._json("GET", "/healthz")

    def ready(self) -> Ready:
        return self._json("GET", "/readyz")

    def vocabulary(self) -> Vocabulary:
        return self._json("GET", "/v1/vocabulary")

    def sparql(self, query: str, accept: str = "application/sparql-results+json") -> Any:
        """JSON results as a dict; other formats (CSV, Turtle…) as text."""
        return self._do(_Requests.sparql(query, accept))

    def versions(self, limit: int = 100) -> list[VersionInfo]:
        return self._json("GET", "/v1/graph/versions", params={"limit": limit})["versions"]

    def graph_version(self) -> int:
        return int(self._json("GET", "/v1/graph")["version"])

    def diff(self, since: int, until: int | None = None) -> Diff:
        params = {"since": since, **({"until": until} if until is not None else {})}
        return self._json("GET", "/v1/graph/diff", params=params)

    # -- editing (token with the editor role)
    def update(self, update: str, *, if_match: int | None = None) -> WriteResult:
        return self._do(_Requests.update(update, if_match))

    def rollback(self, to: int, *, if_match: int | None = None) -> WriteResult:
        return self._json("POST", "/v1/graph/rollback", json={"to": to}, headers=_if_match(if_match))

    def put_rule(self, rule_id: str, label: str, query: str, *, comment: str | None = None, enabled: bool = True,
                 if_match: int | None = None) -> WriteResult:
        body = {"label": label, "query": query, "comment": comment, "enabled": enabled}
        return self._json("PUT", f"/v1/rules/{rule_id}", json=body, headers=_if_match(if_match))

    def delete_rule(self, rule_id: str, *, if_match: int | None = None) -> WriteResult:
        return self._json("DELETE", f"/v1/rules/{rule_id}", headers=_if_match(if_match))

    def add_condition_value(self, dimension: str, name: str, label: str | None = None, *, if_match: int | None = None) -> WriteResult:
        return self._json("POST", f"/v1/conditions/{dimension}/values", json={"name": name, "label": label},
                          headers=_if_match(if_match))

    def patch_parameter(self, extractor: str, parameter: str, *, if_match: int | None = None, **fields: Any) -> WriteResult:
        return self._json("PATCH", f"/v1/extractors/{extractor}/parameters/{parameter}", json=fields,
                          headers=_if_match(if_match))

    def put_extractor(self, name: str, turtle: str, *, if_match: int | None = None) -> WriteResult:
        return self._json("PUT", f"/v1/extractors/{name}", content=turtle.encode(),
                          headers={"Content-Type": "text/turtle", **_if_match(if_match)})

    def put_program(self, name: str, text: str, *, if_match: int | None = None) -> WriteResult:
        return self._json("PUT", f"/v1/programs/{name}", content=text.encode(),
                          headers={"Content-Type": "text/plain", **_if_match(if_match)})


class AsyncNfexClient:
    """The same API, awaitable (``async with AsyncNfexClient(url) as c: await c.select(...)``)."""

    def __init__(self, base_url: str, *, token: str | None = None, timeout: float = 30.0, **httpx_kwargs: Any) -> None:
        headers = {"Authorization": f"Bearer {token}"} if token else {}
        self.http = httpx.AsyncClient(base_url=base_url, timeout=timeout, headers=headers, **httpx_kwargs)

    async def __aenter__(self) -> AsyncNfexClient:
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.aclose()

    async def aclose(self) -> None:
        await self.http.aclose()

    async def _do(self, call: Call) -> Any:
        return _result(call, await self.http.request(call.method, call.path, **call.kwargs))

    async def select(self, context: Context | None = None, frame: Any = None, consistency: str = "snapshot") -> Selection:
        return await self._do(_Requests.select(context, frame, consistency))

    async def open_session(self, context: Context | None = None, client: str | None = None) -> Session:
        return await self._do(Call("POST", "/v1/sessions", {"json": {"context": dict(context or {}), "client": client}}))

    async def session_frame(self, session_id: str, frame: Any, context: Context | None = None) -> SessionSelection:
        return await self._do(_Requests.session_frame(session_id, frame, context))

    async def verdict(self, session_id: str, tried: list[Mapping[str, Any]]) -> Verdict:
        return await self._do(_Requests.verdict(session_id, tried))

    async def close_session(self, session_id: str) -> None:
        await self._do(Call("DELETE", f"/v1/sessions/{session_id}", {}, "none"))

    async def feedback(self, *, idempotency_key: str | None = None, **fields: Any) -> WriteResult:
        return await self._do(_Requests.feedback(fields, idempotency_key))

    async def ready(self) -> Ready:
        return await self._do(Call("GET", "/readyz", {}))

    async def vocabulary(self) -> Vocabulary:
        return await self._do(Call("GET", "/v1/vocabulary", {}))

    async def sparql(self, query: str, accept: str = "application/sparql-results+json") -> Any:
        return await self._do(_Requests.sparql(query, accept))

    async def update(self, update: str, *, if_match: int | None = None) -> WriteResult:
        return await self._do(_Requests.update(update, if_match))

    async def rollback(self, to: int, *, if_match: int | None = None) -> WriteResult:
        return await self._do(Call("POST", "/v1/graph/rollback", {"json": {"to": to}, "headers": _if_match(if_match)}))
