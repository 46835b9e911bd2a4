"""The FastAPI application: ``create_app()`` wires the store, the advisor, sessions, limits and routers."""
from __future__ import annotations

import gc
import logging
import os
import sys
import threading
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

from fastapi import FastAPI

from nfex_core import __version__
from nfex_core.advisor import Advisor
from nfex_core.feedback import ReportWriter
from nfex_core.knowledge import open_graph

from . import openapi, problems
from .bodies import JsonBodyGuard
from .config import Settings
from .methods import MethodsMiddleware
from .observability import Metrics, ServiceMiddleware, setup_logging
from .routes import (
    conditions,
    effects,
    extractors,
    feedback,
    graph_store,
    health,
    programs,
    queries,
    rules,
    samples,
    select,
    sessions,
    sparql,
    ui,
    versions,
    vocabulary,
)
from .security import ReadOnlyCORS, TokenBook, TokenInUrlGuard
from .sessions import SessionStore
from .sparql_exec import QueryRunner

log = logging.getLogger("nfex.service")

DESCRIPTION = """nFEX tells a SLAM front end which feature extractor (α) to run, with which parameters (Θ′),
and why. Reads are open; feedback needs `Authorization: Bearer <token>` with the reporter role, every
other write the editor role (`NFEX_TOKENS`; roles reader < reporter < editor). A token in the URL is
refused. Every error is RFC 9457 `application/problem+json`. Writes accept `If-Match: "<graph version>"`
and answer 412 when the head moved."""


def _warm(app: FastAPI) -> None:
    """Build the advisor's snapshot (vocabulary, compiled rule table) so /readyz means ready to answer."""
    try:
        snap = app.state.advisor.snapshot()
        if app.state.settings.gc_freeze:
            # what start-up built (modules, the vocabulary, shapes) mostly lives as long as the process: out of the
            # collector's sight, a full collection no longer stops every thread for ~100 ms to walk it. What of it
            # dies in a cycle later (the first rule table, shapes replaced by an edit) is kept: once, bounded.
            gc.collect()
            gc.freeze()
        app.state.ready.set()
        log.info("ready", extra={"fields": {"graph_version": snap.version}})
    except Exception as e:  # reported by /readyz
        app.state.warmup_error = f"{type(e).__name__}: {e}"
        log.exception("warm-up failed")
        return
    kg = app.state.kg
    if kg.shacl is not None:  # started once ready, not beside the first compile (2 cores): a first write waits for it
        try:
            kg.shacl.warm(kg.shapes())
        except Exception:  # the first write validates in process or starts the worker itself
            log.exception("the SHACL worker's warm-up failed")
    try:  # what a write's validation reads of the shapes (~0.3 s on the shipped graph), else the first write's
        _ = kg.shapes().footprint
    except Exception:
        log.exception("reading the shapes' footprint failed")


def create_app(settings: Settings | None = None) -> FastAPI:
    settings = settings or Settings()
    os.environ.setdefault("OPENCV_LOG_LEVEL", "ERROR")  # OpenCV's own warnings bypass Python logging
    setup_logging(settings.log_level, settings.log_json)
    if settings.switch_interval_ms > 0:  # process-wide; what it buys: bench/bench_fleet.py (docs/service.md)
        sys.setswitchinterval(settings.switch_interval_ms / 1000)
    metrics = Metrics()

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        app.state.settings = settings
        app.state.tokens = TokenBook(settings.parsed_tokens().values())
        app.state.metrics = metrics
        app.state.kg = kg = open_graph(settings.store, settings=settings)
        if settings.shacl_process:
            kg.use_shacl_process()
        app.state.advisor = advisor = Advisor(kg, background=settings.background_compile,
                                              poll_interval_s=max(0.0, settings.poll_interval_s),
                                              compile_pause=max(0.0, settings.compile_pause), compiled_cache=settings.compiled_cache)
        app.state.reports = ReportWriter(kg, max_items=max(1, settings.feedback_batch),
                                         window_s=max(0.0, settings.feedback_window_ms) / 1000)
        app.state.sessions = SessionStore(
            ttl_s=settings.session_ttl_s, max_sessions=settings.max_sessions, memory_bytes=settings.session_memory_bytes,
            # one client cannot take every slot: by default an eighth of them (at least one)
            max_per_owner=settings.max_sessions_per_client or max(1, settings.max_sessions // 8),
        )
        app.state.queries = QueryRunner(
            kg.backend, timeout_s=settings.sparql_timeout_s, max_bytes=settings.sparql_max_bytes,
            concurrency=settings.sparql_concurrency, version=lambda: kg.version,
        )
        app.state.ready = threading.Event()
        app.state.warmup_error = None
        threading.Thread(target=_warm, args=(app,), name="nfex-warmup", daemon=True).start()
        try:
            yield
        finally:
            app.state.queries.close()
            app.state.reports.close()
            try:
                advisor.close()
            finally:
                kg.close()
            gc.unfreeze()  # a process that runs the app again (tests, an embedding host) starts from a collectable heap

    app = FastAPI(title="nFEX", version=__version__, summary="Which feature extractor to run, with which parameters, and why.",
                  description=DESCRIPTION, lifespan=lifespan, docs_url=None, redoc_url=None)
    problems.install(app)
    for module in (health, vocabulary, select, sessions, feedback, sparql, graph_store, extractors, conditions, rules, effects, programs,
                   versions, queries, samples):
        app.include_router(module.router)
    openapi.install(app)
    app.add_middleware(MethodsMiddleware)
    ui.mount(app)
    # added last is outermost: a JSON body is judged inside the URL-token guard and CORS, so a refused body of a
    # cross-origin read still carries its CORS headers, and a token in the URL is refused before a body is read
    app.add_middleware(JsonBodyGuard)
    app.add_middleware(TokenInUrlGuard, tokens=lambda: getattr(app.state, "tokens", None))
    app.add_middleware(ReadOnlyCORS, origins=settings.parsed_cors_origins())
    app.add_middleware(ServiceMiddleware, metrics=metrics, max_body_bytes=settings.max_body_bytes,
                       body_timeout_s=settings.body_timeout_s)
    return app
