"""A mission's status: one enum for the store, the supervisor, the API and the websocket."""

from __future__ import annotations

from enum import StrEnum


class MissionStatus(StrEnum):
    """Where a mission is in its life: queued, active (planning ... cancelling) or terminal.
    A shape without a lattice goes ``executing → learning → replanning → executing`` (or
    ``planning → learning → executing`` for the start shape)."""

    QUEUED = "queued"
    PLANNING = "planning"
    EXECUTING = "executing"
    PAUSED = "paused"
    REPLANNING = "replanning"
    LEARNING = "learning"  # the body's shape has no lattice: its primitives are being learned
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
        MissionStatus.LEARNING,
        MissionStatus.CANCELLING,
    }
)

# Where each status may go next (docs/mission-format.md lists the lifecycle). A running mission moves freely among the active
# statuses; ``queued`` only starts (``planning``), is cancelled or fails (reconciliation); once
# ``cancelling`` only a terminal status may follow (``succeeded``: it finished first), and nothing follows a terminal one. The
# store refuses anything else: a worker's message still in flight after a cancel (``executing``,
# ``replanning``) must not bring a cancelled mission back to life.
_RUNNING = ACTIVE - {MissionStatus.CANCELLING}
NEXT: dict[MissionStatus, frozenset[MissionStatus]] = {
    MissionStatus.QUEUED: frozenset(
        {
            MissionStatus.PLANNING,
            MissionStatus.CANCELLING,
            MissionStatus.CANCELLED,
            MissionStatus.FAILED,
        }
    ),
    **{status: ACTIVE - {MissionStatus.PLANNING} | TERMINAL for status in _RUNNING},
    MissionStatus.CANCELLING: TERMINAL,
    **{status: frozenset() for status in TERMINAL},
}


def can_follow(current: str, new: str) -> bool:
    """Whether a mission in status ``current`` may enter ``new`` (unknown statuses may not)."""
    try:
        return MissionStatus(new) in NEXT[MissionStatus(current)]
    except ValueError:
        return False
