"""A mission's plan versions, each with its PDDL problem written only when someone reads it.

Every replan makes a plan version: its domain, its problem and its plan. Writing the problem
(every lattice state a search expanded, with all its successors) costs as much as a cheap
replan, and a mission run from the CLI or a bench never reads most of them. So a version keeps
the replan's export and writes the text on the first read. What the export reads is compact
(each expanded state with its free motions as one bitmask: far smaller than the text it
becomes); what else the searches held (the world's grids, caches) ``settle`` lets go of once a
version is no longer among the newest few.

The service's worker is gone when someone asks for a version's problem, so it hands over the
version's ``source``: what the export reads, pickled without what only searching reads (a
tenth of the text, in a fraction of a millisecond), which ``render`` (in the server's process
pool, on request) turns into the same text. It is not compressed: most of it is each expanded
state's motion costs (float64), which zlib's fastest level shrinks by a third at six times the
pickling's time, on the mission's path.
"""

from __future__ import annotations

import io
import pickle
import zlib
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from domain.navigation import MotionTable, NavigationStrategy, Plan
from domain.navigation.lattice.cache import MotionCache
from domain.navigation.lattice.costs import CostInputs, KernelTable
from domain.navigation.lattice.states import StatePool
from domain.pyperplan_adapter import Fact
from domain.strategy import PlanningStrategy, Replanned

SEARCHES_KEPT = 4  # newest plan versions whose searches keep all they held (older ones release)
SOURCE_HEADER = b"screwsnake-pddl-source/2\n"  # a source's first bytes: a pickle follows
ZLIB_SOURCE_HEADER = b"screwsnake-pddl-source/1\n"  # an older source: a zlib'd pickle follows


class SourceUnreadable(ValueError):
    """A stored source that this version of the service cannot render (another format)."""


@dataclass(frozen=True)
class ExportedMotions:
    """A motion table as a plan's export reads it: its motions' PDDL names (one per motion),
    without the swept geometry that only searching reads (megabytes per shape)."""

    names: list[str]

    @property
    def motions(self) -> range:
        return range(len(self.names))


# What a leg's search held that its export never reads: each is left out of a source.
_SEARCH_ONLY = (KernelTable, CostInputs, MotionCache, StatePool, Fact)


class _SourcePickler(pickle.Pickler):
    def reducer_override(self, obj: Any) -> Any:
        if isinstance(obj, _SEARCH_ONLY) or callable(getattr(obj, "is_set", None)):
            return type(None), ()  # (a cancel flag: only searching reads it)
        if isinstance(obj, MotionTable):
            return ExportedMotions, (list(obj.names),)
        return NotImplemented


def source_of(plan: Plan | None, text: str | None = None) -> bytes:
    """What regenerates a plan version's problem: a navigation plan's export (its legs'
    expanded states), or ``text`` as it is (another strategy's problems are a few lines); no
    plan and no text: an empty problem."""
    buffer = io.BytesIO()
    _SourcePickler(buffer, protocol=pickle.HIGHEST_PROTOCOL).dump(plan if text is None else text)
    return SOURCE_HEADER + buffer.getvalue()


def render(source: bytes) -> str:
    """The PDDL problem text a ``source_of`` source regenerates (as ``PlanVersion.problem``),
    or an older one (zlib'd)."""
    try:
        if source.startswith(SOURCE_HEADER):
            data = source[len(SOURCE_HEADER) :]
        elif source.startswith(ZLIB_SOURCE_HEADER):
            data = zlib.decompress(source[len(ZLIB_SOURCE_HEADER) :])
        else:
            raise SourceUnreadable("not a PDDL source of this service's format")
        # Only the service's own store holds sources: written by its workers, never posted.
        payload = pickle.loads(data)
    except (zlib.error, pickle.UnpicklingError, EOFError, AttributeError, ImportError) as exc:
        raise SourceUnreadable(f"the PDDL source cannot be read ({exc})") from exc
    if isinstance(payload, str):
        return payload
    if payload is None:
        return ""
    problem = payload.problem()
    return problem.text() if problem is not None else ""


class PlanVersion(Mapping[str, Any]):
    """One plan version as the API and the store read it: ``version``, ``domain``,
    ``problem`` (written on the first read) and ``plan``; ``source()`` for the service."""

    KEYS = ("version", "domain", "problem", "plan")

    def __init__(
        self, version: int, replanned: Replanned, strategy: PlanningStrategy | None = None
    ) -> None:
        self.version = version
        self.domain = replanned.domain_pddl
        self.plan = list(replanned.plan)
        self._replanned: Replanned | None = replanned
        self._problem: str | None = None
        self.released = False  # what its searches held beyond the export's needs is gone
        # The navigation strategy's plan, as this replan made it (its export reads it); None
        # for another strategy (its problems are written for the source: a few lines).
        self._plan = strategy.plan if isinstance(strategy, NavigationStrategy) else None
        self._navigation = isinstance(strategy, NavigationStrategy)

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
            self._plan = None
        return self._problem

    def source(self) -> bytes:
        """What regenerates ``problem`` (``render``) without writing it, unless written."""
        if self._problem is not None or not self._navigation:
            return source_of(None, self.problem)
        return source_of(self._plan)

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
