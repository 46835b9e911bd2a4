"""Service settings, from ``NFEX_*`` environment variables (pydantic-settings).

| variable                   | meaning                                                            | default   |
|----------------------------|--------------------------------------------------------------------|-----------|
| NFEX_STORE                 | a folder (embedded Oxigraph) or an http(s) SPARQL endpoint          | core's    |
| NFEX_TOKENS                | ``name:token:role,…``, role reader < reporter < editor (service/security.py) | none |
| NFEX_CORS_ORIGINS          | origins (``https://a.example,…`` or ``*``) browser tools may read from | none      |
| NFEX_MAX_BODY_BYTES        | largest request body (413 above)                                   | 16 MiB    |
| NFEX_MAX_IMAGE_BYTES       | largest encoded frame                                              | 12 MiB    |
| NFEX_MAX_PIXELS            | largest frame, width × height, read from the header before decoding | 16 Mpx    |
| NFEX_MAX_DECODED_BYTES     | largest decoded frame, pixels × channels × bytes a sample (a 4K colour frame fits) | 24 MiB |
| NFEX_BODY_TIMEOUT_S        | longest wait for the next part of a request body (408 after it)    | 30 s      |
| NFEX_SPARQL_TIMEOUT_S      | time limit per SPARQL query                                        | 10 s      |
| NFEX_SPARQL_MAX_BYTES      | result-size limit per SPARQL query (serialised bytes)              | 32 MiB    |
| NFEX_SPARQL_CONCURRENCY    | queries running at once per process (slots held by runaway ones)   | 4         |
| NFEX_SESSION_TTL_S         | idle time after which a session expires                            | 300 s     |
| NFEX_MAX_SESSIONS          | sessions held at once (429 above)                                  | 256       |
| NFEX_MAX_SESSIONS_PER_CLIENT | sessions one client (token, else address) holds at once (429 with Retry-After) | max sessions / 8 |
| NFEX_SESSION_MEMORY_BYTES  | memory all sessions' previous frames may hold (LRU eviction)       | 512 MiB   |
| NFEX_LOG_JSON              | one JSON object per log line                                       | true      |
| NFEX_BACKGROUND_COMPILE    | a stale rule table answers while the next compiles in the background (false: a select after a commit waits for it) | true |
| NFEX_COMPILE_PAUSE         | while commits stream in, a background compile waits this many times as long as the last one took (0: none; nfex_core/advisor/snapshots.py) | 1 |
| NFEX_GC_FREEZE             | after the warm-up, keep what start-up built out of Python's full garbage collections (gc.freeze) | true |
| NFEX_POLL_INTERVAL_S       | how often, at most, a selection reads the store's head: the delay before commits other replicas make to a shared store start compiling here | 0.25 s |
| NFEX_FEEDBACK_BATCH        | most reports committed together in one transaction (1: one commit per report) | 64 |
| NFEX_FEEDBACK_WINDOW_MS    | how long the first report of a batch waits for others              | 20 ms     |
"""
from __future__ import annotations

from dataclasses import dataclass

from pydantic_settings import BaseSettings, SettingsConfigDict

from nfex_core.config import Settings as CoreSettings
from nfex_core.errors import BadInput

ROLES = ("reader", "reporter", "editor")  # ordered: each role may do what the ones before it may


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
    cors_origins: str = ""
    max_body_bytes: int = 16 * 1024 * 1024
    max_image_bytes: int = 12 * 1024 * 1024
    max_pixels: int = 16_000_000
    max_decoded_bytes: int = 24 * 1024 * 1024
    body_timeout_s: float = 30.0
    sparql_timeout_s: float = 10.0
    sparql_max_bytes: int = 32 * 1024 * 1024
    sparql_concurrency: int = 4
    session_ttl_s: float = 300.0
    max_sessions: int = 256
    max_sessions_per_client: int | None = None
    session_memory_bytes: int = 512 * 1024 * 1024
    background_compile: bool = True
    compile_pause: float = 1.0
    poll_interval_s: float = 0.25  # one head read (~0.5 ms on a loopback `oxigraph serve`) per interval at most
    feedback_batch: int = 64
    feedback_window_ms: float = 20.0
    # writes' pySHACL runs in a worker process, off the interpreter lock the selections and the compile share
    # (nfex_core/kg/shacl_process.py; what it buys: bench/bench_fleet.py)
    shacl_process: bool = True
    # how long a thread may hold the GIL while another waits (Python's default 5 ms): the event loop answering a
    # select waits on the background compile and the commits' validation at most this long per switch
    switch_interval_ms: float = 0.5
    # after the warm-up, move what start-up built out of the garbage collector's full collections (gc.freeze)
    gc_freeze: bool = True

    def core(self) -> CoreSettings:
        core = CoreSettings.from_env()
        if self.store:
            from dataclasses import replace

            core = replace(core, store=self.store)
        return core

    def parsed_tokens(self) -> dict[str, Token]:
        """``NFEX_TOKENS`` as secret → Token; a malformed entry stops start-up with a clear message."""
        out: dict[str, Token] = {}
        names: set[str] = set()
        for item in filter(None, (x.strip() for x in self.tokens.split(","))):
            parts = item.split(":")
            if len(parts) != 3 or not all(parts) or parts[2] not in ROLES:
                raise BadInput(f"NFEX_TOKENS entry {parts[0]!r}…: expected name:token:role with role in {ROLES}")
            if parts[0] in names or parts[1] in out:
                raise BadInput(f"NFEX_TOKENS entry {parts[0]!r}…: names and tokens must be unique (a name is whom writes are attributed to)")
            names.add(parts[0])
            out[parts[1]] = Token(parts[0], parts[1], parts[2])
        return out

    def parsed_cors_origins(self) -> tuple[str, ...]:
        """``NFEX_CORS_ORIGINS`` as a tuple of origins (``scheme://host[:port]``) or ``("*",)``."""
        origins = tuple(o.strip().rstrip("/") for o in self.cors_origins.split(",") if o.strip())
        for o in origins:
            if o != "*" and not o.startswith(("http://", "https://")):
                raise BadInput(f"NFEX_CORS_ORIGINS entry {o!r}: expected an origin like https://tools.example or *")
        return origins
