"""``nfex serve``: the HTTP service with uvicorn."""
from __future__ import annotations

from typing import Annotated

import typer


def serve(
    host: Annotated[str | None, typer.Option(help="Interface to bind; default $NFEX_HOST, else 127.0.0.1.")] = None,
    port: Annotated[int | None, typer.Option(help="Port to bind; default $NFEX_PORT, else 8000.")] = None,
    workers: Annotated[int, typer.Option(help="Worker processes (remote store only: an embedded store has one writer).")] = 1,
    log_level: Annotated[str | None, typer.Option(help="uvicorn's log level; default $NFEX_LOG_LEVEL, else info.")] = None,
) -> None:
    """Run the nFEX HTTP service (the store comes from --store / $NFEX_STORE)."""
    import uvicorn

    from service.config import Settings

    from .common import state

    # the service's settings, read once from NFEX_*; the options given here win over them
    settings = Settings(store=state.store) if state.store else Settings()
    host = settings.host if host is None else host
    port = settings.port if port is None else port
    log_level = settings.log_level if log_level is None else log_level
    # the app logs JSON itself (service/observability.py): keep uvicorn from installing its own handlers
    if workers == 1:  # the settings go to the app object directly
        from service.main import create_app

        app = create_app(settings.replace(host=host, port=port, log_level=log_level))
        uvicorn.run(app, host=host, port=port, log_level=log_level, log_config=None, access_log=False)
        return
    # several workers are processes that import the factory: only the environment reaches them
    import os

    if state.store:
        os.environ["NFEX_STORE"] = state.store
    uvicorn.run("service.main:create_app", factory=True, workers=workers, host=host, port=port, log_level=log_level,
                log_config=None, access_log=False)
