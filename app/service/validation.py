"""Request validation off the event loop, in a pool of processes.

Validating a request can cost seconds of pure Python (a mission's 50 goals against 200 polygons
of 64 points: 1.4 s; maps and 10,000 obstacles more): on the event loop that stalls every other
request and websocket, and in a thread too (threads share the GIL). So every request body is
parsed and validated in one of a few processes (``SCREWSNAKE_VALIDATION_WORKERS``), and the
validated model comes back pickled: the server's loop only awaits it. The routes' signatures,
and so the OpenAPI schema and the 422 answers, stay as they were: ``app.api.validated``'s route
class hands the validated instance to FastAPI in place of the parsed JSON, which FastAPI accepts
as it is (a model's own costly checks run once per instance: ``MissionSpec._checked``). Any
other costly check (a live update against a mission's world) runs in the same pool (``run``).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import os
import threading
from collections.abc import Callable
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from typing import Any, TypeVar

from pydantic import BaseModel, ValidationError

from app.missions.maps import MapsNeeded
from app.service.pool import CONTEXT
from app.service.worker import watch_server

log = logging.getLogger("screwsnake.validation")
T = TypeVar("T")


class ValidationUnavailable(Exception):
    """The validation processes are gone and could not be replaced (a 503)."""


@dataclass(frozen=True)
class Invalid:
    """A body that failed validation: FastAPI's errors (``loc`` starting with ``body``)."""

    errors: list[dict[str, Any]]


@dataclass(frozen=True)
class Unparsable:
    """A body that is neither JSON nor a JSON syntax error (e.g. not UTF-8, nested too deep)."""


@dataclass(frozen=True)
class NeedsMaps:
    """A body naming stored maps: validated again with them in the context (``ids``)."""

    ids: list[str]


def _portable(error: dict[str, Any]) -> dict[str, Any]:
    """A pydantic error as the 422 handler reads it, small and picklable: no ``input`` (for a
    model-level error, the whole body), ``ctx`` values as text."""
    out = {k: v for k, v in error.items() if k not in ("input", "ctx", "url")}
    out["loc"] = ("body", *error.get("loc", ()))
    if "ctx" in error:
        out["ctx"] = {
            k: v if isinstance(v, int | float | str) else str(v) for k, v in error["ctx"].items()
        }
    return out


def parse_body(
    model: type[BaseModel], body: bytes, context: dict[str, Any] | None = None
) -> BaseModel | Invalid | Unparsable | NeedsMaps:
    """In a validation process: the body as FastAPI would parse and validate it for a route
    whose body is ``model``: the instance, or the errors FastAPI would answer with; a mission
    naming stored maps that ``context`` does not hold asks for them (``NeedsMaps``)."""
    try:
        data = json.loads(body)
    except json.JSONDecodeError as exc:
        error = {"type": "json_invalid", "loc": ("body", exc.pos), "msg": "JSON decode error"}
        return Invalid([{**error, "ctx": {"error": exc.msg}}])
    except Exception:  # not UTF-8, nested past the parser's depth: FastAPI's 400
        return Unparsable()
    try:
        return model.model_validate(data, from_attributes=True, context=context)
    except MapsNeeded as exc:
        return NeedsMaps(exc.ids)
    except ValidationError as exc:
        return Invalid([_portable(dict(e)) for e in exc.errors(include_url=False)])


def _begin(niceness: int, server_pid: int, environment: dict[str, str]) -> None:
    """A validation process's start: the server's ``SCREWSNAKE_*`` environment as it is now
    (limits read wherever a mission is validated, e.g. ``SCREWSNAKE_MAX_OBSTACLES``: the
    forkserver's copy dates from its own start); it exits as soon as the server is gone
    (SIGKILLed: nobody would ever stop it); and it runs below the server's priority, like the
    mission workers (on a busy machine the server's event loop gets the CPU first)."""
    for name in [n for n in os.environ if n.startswith("SCREWSNAKE_")]:
        del os.environ[name]
    os.environ.update(environment)
    threading.Thread(
        target=watch_server, args=(server_pid,), daemon=True, name="watch-server"
    ).start()
    if niceness:
        with contextlib.suppress(OSError):
            os.nice(niceness)


def screwsnake_environment() -> dict[str, str]:
    """This process's ``SCREWSNAKE_*`` variables."""
    return {k: v for k, v in os.environ.items() if k.startswith("SCREWSNAKE_")}


def _ready() -> bool:
    """A validation process's first job: it runs (its modules came with the forkserver), with
    the maps' compiled kernel loaded (a mission's map is checked against the robot's body)."""
    from sim import raster

    raster.warm()
    return True


class Validation:
    """The pool of validation processes (started with the service, replaced if broken)."""

    def __init__(self, workers: int, niceness: int = 0) -> None:
        self.workers, self.niceness = workers, niceness
        self.executor: ProcessPoolExecutor | None = None

    def start(self) -> None:
        """Start the processes now (not at the first request), each answering once."""
        self.executor = ProcessPoolExecutor(
            self.workers,
            mp_context=CONTEXT,
            initializer=_begin,
            initargs=(self.niceness, os.getpid(), screwsnake_environment()),
        )
        warm: list[Future[bool]] = [self.executor.submit(_ready) for _ in range(self.workers)]
        for future in warm:
            future.result(timeout=60)

    def stop(self) -> None:
        """Stop the processes (after the validation running now, if any: a second or two)."""
        executor, self.executor = self.executor, None
        if executor is not None:
            executor.shutdown(wait=True, cancel_futures=True)

    async def run(self, fn: Callable[..., T], *args: Any) -> T:
        """``fn(*args)`` in a validation process (``fn`` and its arguments picklable); a pool
        broken by a process that died (e.g. killed) is replaced once."""
        loop = asyncio.get_running_loop()
        for attempt in (1, 2):
            executor = self.executor
            if executor is None:
                raise ValidationUnavailable("the validation processes are not running")
            try:
                return await loop.run_in_executor(executor, fn, *args)
            except BrokenProcessPool:
                if attempt == 2:
                    break
                log.warning("a validation process died: the pool is replaced")
                if self.executor is executor:
                    executor.shutdown(wait=False, cancel_futures=True)
                    self.executor = None
                    await loop.run_in_executor(None, self.start)
        raise ValidationUnavailable("the validation processes keep dying")

    async def body(
        self, model: type[BaseModel], body: bytes, context: dict[str, Any] | None = None
    ) -> BaseModel | Invalid | Unparsable | NeedsMaps:
        """A JSON body validated as ``model`` (``parse_body``), in a validation process."""
        return await self.run(parse_body, model, body, context)
