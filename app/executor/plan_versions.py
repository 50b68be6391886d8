"""A mission's plan versions, each with its PDDL problem written only when someone reads it.

Every replan makes a plan version: its domain, its problem and its plan. Writing the problem
(every lattice state a search expanded, with all its successors) costs as much as a cheap
replan, and a mission run from the CLI or a bench never reads most of them. So a version keeps
the replan's export and writes the text on the first read. What the export reads is compact
(each expanded state with its free motions as one bitmask: far smaller than the text it
becomes); what else the searches held (the world's grids, caches) ``settle`` lets go of once a
version is no longer among the newest few.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from typing import Any

from domain.strategy import Replanned

SEARCHES_KEPT = 4  # newest plan versions whose searches keep all they held (older ones release)


class PlanVersion(Mapping[str, Any]):
    """One plan version as the API and the store read it: ``version``, ``domain``,
    ``problem`` (written on the first read) and ``plan``."""

    KEYS = ("version", "domain", "problem", "plan")

    def __init__(self, version: int, replanned: Replanned) -> None:
        self.version = version
        self.domain = replanned.domain_pddl
        self.plan = list(replanned.plan)
        self._replanned: Replanned | None = replanned
        self._problem: str | None = None
        self.released = False  # what its searches held beyond the export's needs is gone

    @property
    def written(self) -> bool:
        """Whether the problem's text exists (the search graph is released then)."""
        return self._problem is not None

    @property
    def problem(self) -> str:
        """The PDDL problem this version's plan solves."""
        if self._problem is None:
            assert self._replanned is not None
            self._problem = self._replanned.problem_pddl
            self._replanned = None  # the graph behind it may go
        return self._problem

    def release(self) -> None:
        """Let go of what the plan's searches held that writing its problem does not need."""
        if not self.released and self._replanned is not None:
            self._replanned.release()
        self.released = True

    def __getitem__(self, key: str) -> Any:
        if key not in self.KEYS:
            raise KeyError(key)
        return getattr(self, key)

    def __iter__(self) -> Iterator[str]:
        return iter(self.KEYS)

    def __len__(self) -> int:
        return len(self.KEYS)

    def to_dict(self) -> dict[str, Any]:
        """A plain dict (the problem written)."""
        return {key: self[key] for key in self.KEYS}

    def __repr__(self) -> str:
        state = "written" if self.written else "unwritten"
        return f"PlanVersion({self.version}, {len(self.plan)} steps, problem {state})"


def settle(versions: Sequence[PlanVersion], kept: int = SEARCHES_KEPT) -> None:
    """Release (``PlanVersion.release``) every version but the newest ``kept``: a long
    mission keeps what the export reads of each plan, not every search's working state."""
    if kept < 1:
        raise ValueError(f"kept: at least 1 plan version (the one being run), got {kept}")
    for version in versions[: max(0, len(versions) - kept)]:
        if not version.released:
            version.release()
