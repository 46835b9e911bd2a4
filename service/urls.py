"""The service's own URLs as its clients see them, behind a gateway too.

A gateway (docker-compose's nginx, service/nginx.conf) forwards ``X-Forwarded-Proto``, ``-Host``, ``-Port``
and ``-Prefix``; ``public_url`` builds absolute URLs from them (the SPARQL service description names its
endpoints with these), falling back to the request's own scheme and ``Host``. A malformed value is
ignored rather than copied into an IRI. Only the answer to the request that carries them is affected.
"""
from __future__ import annotations

import re

from fastapi import Request

_HOST = re.compile(r"^(?:\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9.-]+)(?::\d{1,5})?$")
_PREFIX = re.compile(r"^[A-Za-z0-9._~!$&'()*+,;=:@%/-]*$")
_DEFAULT_PORT = {"http": "80", "https": "443"}


def _first(request: Request, name: str) -> str:
    """The first value of a (possibly comma-separated, proxy-appended) header, or ''."""
    return (request.headers.get(name) or "").split(",")[0].strip()


def public_base(request: Request) -> str:
    """``scheme://host[:port][/prefix]`` of this service as the client addressed it (no trailing slash)."""
    proto = _first(request, "x-forwarded-proto").lower()
    if proto not in _DEFAULT_PORT:
        proto = request.url.scheme
    host = _first(request, "x-forwarded-host")
    if not _HOST.match(host):
        host = request.headers.get("host") or request.url.netloc
    port = _first(request, "x-forwarded-port")
    has_port = re.search(r":\d+$", host) is not None
    if port.isdigit() and not has_port and port != _DEFAULT_PORT[proto]:
        host = f"{host}:{port}"
    prefix = _first(request, "x-forwarded-prefix").strip("/")
    prefix = f"/{prefix}" if prefix and _PREFIX.match(prefix) else ""
    root = str(request.scope.get("root_path") or "").rstrip("/")
    return f"{proto}://{host}{prefix}{root}"


def public_url(request: Request, path: str) -> str:
    """``path`` (absolute, e.g. ``/sparql``) under ``public_base``."""
    return public_base(request) + path
