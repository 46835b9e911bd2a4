"""``nfex serve``: the HTTP service with uvicorn."""
from __future__ import annotations

from typing import Annotated

import typer


def serve(
    host: Annotated[str, typer.Option(envvar="NFEX_HOST", help="Interface to bind.")] = "127.0.0.1",
    port: Annotated[int, typer.Option(envvar="NFEX_PORT", help="Port to bind.")] = 8000,
    workers: Annotated[int, typer.Option(help="Worker processes (remote store only: an embedded store has one writer).")] = 1,
    log_level: Annotated[str, typer.Option(envvar="NFEX_LOG_LEVEL")] = "info",
) -> None:
    """Run the nFEX HTTP service (the store comes from --store / $NFEX_STORE)."""
    import uvicorn

    from .common import state

    # the app logs JSON itself (service/observability.py): keep uvicorn from installing its own handlers
    if workers == 1:  # the settings go to the app object directly
        from service.config import Settings
        from service.main import create_app

        app = create_app(Settings(store=state.store) if state.store else Settings())
        uvicorn.run(app, host=host, port=port, log_level=log_level, log_config=None, access_log=False)
        return
    # several workers are processes that import the factory: only the environment reaches them
    import os

    if state.store:
        os.environ["NFEX_STORE"] = state.store
    uvicorn.run("service.main:create_app", factory=True, workers=workers, host=host, port=port, log_level=log_level,
                log_config=None, access_log=False)
