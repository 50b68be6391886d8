"""The ASGI app (``app.main:app``): routers, problem+json errors, and the lifespan that owns
the store, the library, the websocket hub, the mission supervisor and the learning jobs."""

from __future__ import annotations

import gc
import sys
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

from anyio import CapacityLimiter, to_thread
from fastapi import FastAPI
from fastapi.middleware.cors import CORSMiddleware
from fastapi_offline import FastAPIOffline

from app.api import (
    docs,
    errors,
    exports,
    faults,
    health,
    jobs,
    limits,
    maps,
    missions,
    primitives,
    replay,
    simulate,
    updates,
    viewer,
    ws,
)
from app.api.deps import Services
from app.api.limits import RequestGuard
from app.api.server_timing import ServerTiming
from app.service.hub import Hub
from app.service.intake import Intake
from app.service.jobs import Jobs
from app.service.library import SharedLibrary
from app.service.live import LiveUpdates
from app.service.metrics import Metrics
from app.service.supervisor import Supervisor
from app.service.validation import Validation
from app.settings import Settings, missing_extra
from app.store.db import make_engine, migrate
from app.store.repo import Store
from primitives.build import code_version
from primitives.library import Library, bundled_library_path


class MissingExtra(RuntimeError):
    """The settings ask for an optional package that is not installed."""


def create_app(settings: Settings | None = None) -> FastAPI:
    config = settings or Settings.from_env()
    needed = missing_extra(config)
    if needed is not None:
        raise MissingExtra(needed)
    db_health = faults.DbHealth()

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        engine = make_engine(config.database())
        db_health.watch(engine)
        migrate(engine)
        store = Store(engine)
        path = config.library or bundled_library_path()
        library = Library.load(path)  # once: missions get this copy, the file may go away
        shared = SharedLibrary(store, library, str(path))  # with the shapes learned before
        metrics = Metrics()
        hub = Hub(config.ws_queue)
        supervisor = Supervisor(store, shared, hub, config, metrics)
        learning = Jobs(
            store,
            metrics,
            max_queued=config.max_queued_jobs,
            library=shared,
            budget=config.learn_budget,
        )
        # FastAPI's thread pool (sync routes and dependencies, run_in_threadpool) is anyio's
        # default limiter, per event loop: sized here, once the loop runs.
        to_thread.current_default_thread_limiter().total_tokens = config.api_threads
        snapshots = CapacityLimiter(config.ws_snapshot_threads)
        validation = Validation(config.validation_workers, config.worker_nice)
        await to_thread.run_sync(validation.start)  # processes started before any request
        app.state.services = Services(
            config,
            store,
            shared,
            hub,
            supervisor,
            learning,
            metrics,
            snapshots,
            Intake(store, supervisor, metrics, config.post_batch),
            validation,
            LiveUpdates(store, supervisor, validation, config),
        )
        await supervisor.start()
        # What the server holds from start to end (the library, the app's models, the ORM's
        # metadata, imported modules) leaves the cyclic collector's full passes: one over it
        # after a burst of posts stalled every thread of the server for 120-240 ms.
        gc.collect()
        gc.freeze()
        # The event loop shares the GIL with the threads writing the store and building large
        # answers (a mission of 10,000 obstacles): with Python's 5 ms switch interval a /livez
        # waited up to 5 ms per hand-over behind them (p99 104 ms while 10,000-obstacle
        # missions were posted; at 0.5 ms, 25 ms).
        switch = sys.getswitchinterval()
        sys.setswitchinterval(config.switch_interval)
        try:
            yield
        finally:
            sys.setswitchinterval(switch)
            gc.unfreeze()  # (an app started and stopped inside a longer process: tests)
            await supervisor.stop()
            learning.stop()
            await to_thread.run_sync(validation.stop)
            engine.dispose()

    # Swagger UI and ReDoc from the installed fastapi-offline package: the docs work offline.
    app = FastAPIOffline(
        title="screwsnake",
        summary="Goal-directed locomotion of a screw-drive snake robot: missions, plans, primitives.",
        description=docs.DESCRIPTION,
        version=code_version(),
        lifespan=lifespan,
        openapi_tags=docs.TAGS,
        static_url="/docs-assets",
        redoc_url=None,  # app.api.docs serves ReDoc, its bundle's CDN badge inlined
    )
    app.state.db_health = db_health
    errors.install(app)
    faults.install(app, db_health)
    limits.install(app)
    errors.document(app)
    # Added last = runs first: CORS answers preflights, then the guard, before any body is read.
    app.add_middleware(RequestGuard, settings=config)
    if config.allowed_origins:
        app.add_middleware(
            CORSMiddleware,
            allow_origins=config.allowed_origins,
            allow_methods=["GET", "POST"],
            allow_headers=["Authorization", "Content-Type", "Idempotency-Key"],
            expose_headers=["Location", "Retry-After"],
        )
    if config.server_timing:  # outermost: its total covers the guard and CORS too
        app.add_middleware(ServerTiming)
    for module in (
        missions,
        exports,
        maps,
        updates,
        replay,
        primitives,
        simulate,
        jobs,
        health,
        ws,
        viewer,
        docs,
    ):
        app.include_router(module.router)
    return app


try:
    app = create_app()
except MissingExtra as exc:  # one line and a non-zero exit, not a traceback from the lifespan
    raise SystemExit(f"screwsnake: {exc}") from None
