"""The service's settings: nFEX's one ``Settings`` (nfex_core/config.py) with the HTTP service's own fields added,
read from the same ``NFEX_*`` variables in the same pass. README.md's configuration table lists them all.
"""
from __future__ import annotations

from dataclasses import dataclass

from nfex_core.config import Settings as CoreSettings
from nfex_core.errors import BadInput

ROLES = ("reader", "reporter", "editor")  # ordered: each role may do what the ones before it may


@dataclass(frozen=True)
class Token:
    name: str
    secret: str
    role: str


class Settings(CoreSettings):
    """The core's settings and the service's: one object, handed to the core as it is (a ``CoreSettings``)."""

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
