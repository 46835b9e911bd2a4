"""Service settings, from ``NFEX_*`` environment variables (pydantic-settings).

| variable                   | meaning                                                            | default   |
|----------------------------|--------------------------------------------------------------------|-----------|
| NFEX_STORE                 | a folder (embedded Oxigraph) or an http(s) SPARQL endpoint          | core's    |
| NFEX_TOKENS                | editors: ``name:token:role,…`` (role ``editor``; reads stay open)  | none      |
| NFEX_MAX_BODY_BYTES        | largest request body (413 above)                                   | 16 MiB    |
| NFEX_MAX_IMAGE_BYTES       | largest encoded frame                                              | 12 MiB    |
| NFEX_MAX_PIXELS            | largest frame, width × height, read from the header before decoding | 16 Mpx    |
| NFEX_SPARQL_TIMEOUT_S      | time limit per SPARQL query                                        | 10 s      |
| NFEX_SPARQL_MAX_BYTES      | result-size limit per SPARQL query (serialised bytes)              | 32 MiB    |
| NFEX_SPARQL_CONCURRENCY    | queries running at once per process (slots held by runaway ones)   | 4         |
| NFEX_SESSION_TTL_S         | idle time after which a session expires                            | 300 s     |
| NFEX_MAX_SESSIONS          | sessions held at once (429 above)                                  | 256       |
| NFEX_SESSION_MEMORY_BYTES  | memory all sessions' previous frames may hold (LRU eviction)       | 512 MiB   |
| NFEX_LOG_JSON              | one JSON object per log line                                       | true      |
"""
from __future__ import annotations

from dataclasses import dataclass

from pydantic_settings import BaseSettings, SettingsConfigDict

from nfex_core.config import Settings as CoreSettings
from nfex_core.errors import BadInput

ROLES = ("editor", "reader")


@dataclass(frozen=True)
class Token:
    name: str
    secret: str
    role: str


class Settings(BaseSettings):
    model_config = SettingsConfigDict(env_prefix="NFEX_", extra="ignore")

    store: str | None = None
    """A folder (embedded Oxigraph store) or an http(s) SPARQL endpoint shared by several nodes."""
    host: str = "127.0.0.1"
    port: int = 8000
    log_level: str = "info"
    log_json: bool = True
    tokens: str = ""
    max_body_bytes: int = 16 * 1024 * 1024
    max_image_bytes: int = 12 * 1024 * 1024
    max_pixels: int = 16_000_000
    sparql_timeout_s: float = 10.0
    sparql_max_bytes: int = 32 * 1024 * 1024
    sparql_concurrency: int = 4
    session_ttl_s: float = 300.0
    max_sessions: int = 256
    session_memory_bytes: int = 512 * 1024 * 1024

    def core(self) -> CoreSettings:
        core = CoreSettings.from_env()
        if self.store:
            from dataclasses import replace

            core = replace(core, store=self.store)
        return core

    def parsed_tokens(self) -> dict[str, Token]:
        """``NFEX_TOKENS`` as secret → Token; a malformed entry stops start-up with a clear message."""
        out: dict[str, Token] = {}
        for item in filter(None, (x.strip() for x in self.tokens.split(","))):
            parts = item.split(":")
            if len(parts) != 3 or not all(parts) or parts[2] not in ROLES:
                raise BadInput(f"NFEX_TOKENS entry {parts[0]!r}…: expected name:token:role with role in {ROLES}")
            out[parts[1]] = Token(parts[0], parts[1], parts[2])
        return out
