"""The FastAPI application: ``create_app()`` wires the store, the routers and the error handler."""
from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

from fastapi import FastAPI

from nfex_core import __version__
from nfex_core.kg import KnowledgeGraph

from . import problems
from .config import Settings
from .routes import health, vocabulary


def create_app(settings: Settings | None = None) -> FastAPI:
    settings = settings or Settings()

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        core = settings.core()
        app.state.settings = settings
        app.state.kg = KnowledgeGraph.open(core.store, settings=core)
        try:
            yield
        finally:
            app.state.kg.close()

    app = FastAPI(
        title="nFEX",
        version=__version__,
        summary="Which feature extractor to run, with which parameters, and why.",
        lifespan=lifespan,
    )
    problems.install(app)
    app.include_router(health.router)
    app.include_router(vocabulary.router)
    return app
