"""A mission's status: one enum for the store, the supervisor, the API and the websocket."""

from __future__ import annotations

from enum import StrEnum


class MissionStatus(StrEnum):
    """Where a mission is in its life: queued, active (planning ... cancelling) or terminal."""

    QUEUED = "queued"
    PLANNING = "planning"
    EXECUTING = "executing"
    PAUSED = "paused"
    REPLANNING = "replanning"
    CANCELLING = "cancelling"
    SUCCEEDED = "succeeded"
    FAILED = "failed"
    CANCELLED = "cancelled"

    @property
    def terminal(self) -> bool:
        return self in TERMINAL


TERMINAL = frozenset({MissionStatus.SUCCEEDED, MissionStatus.FAILED, MissionStatus.CANCELLED})
ACTIVE = frozenset(
    {
        MissionStatus.PLANNING,
        MissionStatus.EXECUTING,
        MissionStatus.PAUSED,
        MissionStatus.REPLANNING,
        MissionStatus.CANCELLING,
    }
)
