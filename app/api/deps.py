"""Dependencies: the app's services, settings, and the optional API key for writes."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated

from anyio import CapacityLimiter
from fastapi import Depends, Path, Request
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer

from app.api.errors import ApiError
from app.api.limits import key_ok
from app.service.hub import Hub
from app.service.intake import Intake
from app.service.jobs import Jobs
from app.service.library import SharedLibrary
from app.service.live import LiveUpdates
from app.service.metrics import Metrics
from app.service.supervisor import Supervisor
from app.service.validation import Validation
from app.settings import Settings
from app.store.repo import Store
from primitives.library import Library


@dataclass
class Services:
    settings: Settings
    store: Store
    shared: SharedLibrary  # the library file plus the shapes learned since (a new version each)
    hub: Hub
    supervisor: Supervisor
    jobs: Jobs
    metrics: Metrics
    snapshots: CapacityLimiter  # bounds the websocket snapshots built at once
    intake: Intake  # stores and queues posted missions, in batches
    validation: Validation  # request bodies (and live updates) validated off the event loop
    live: LiveUpdates  # the rules of live updates of running missions

    @property
    def library(self) -> Library:
        """The library now (its newest version)."""
        return self.shared.library

    @property
    def library_version(self) -> str:
        return self.shared.version


# The dependencies are ``async``: FastAPI runs a plain ``def`` dependency in its thread pool,
# a hop (and a wait for a thread and the GIL) per dependency per request for no I/O at all.
async def services(request: Request) -> Services:
    found: Services = request.app.state.services
    return found


Svc = Annotated[Services, Depends(services)]
MissionId = Annotated[str, Path(description="the mission's id (a UUID)")]
JobId = Annotated[str, Path(description="the job's id (a UUID)")]
bearer = HTTPBearer(auto_error=False)


async def writer(
    svc: Svc,
    request: Request,
    credentials: Annotated[HTTPAuthorizationCredentials | None, Depends(bearer)],
) -> None:
    """Writes need ``Authorization: Bearer <key>`` when an API key is set (``credentials``
    documents the scheme; the key is compared by ``key_ok``, the middleware's own function, on
    the header's raw bytes)."""
    if svc.settings.api_key is None:
        return
    if not key_ok(svc.settings, request.scope):
        raise ApiError(
            401, "a valid API key is required for writes", headers={"WWW-Authenticate": "Bearer"}
        )
