"""The repository: missions, their append-only transitions, plans, replans, trajectories, jobs.

Every call is its own short transaction. Writes are serialised by a lock (SQLite has one writer;
for PostgreSQL the lock only costs a little concurrency).
"""

from __future__ import annotations

import hashlib
import threading
import uuid
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import Any

from sqlalchemy import Engine, delete, func, select, text, union, update
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import sessionmaker

from app import timing
from app.missions.status import ACTIVE, TERMINAL, can_follow
from app.store import blobs
from app.store.db import DatabaseFile
from app.store.models import (
    BlobRow,
    JobRow,
    LearnedPrimitiveRow,
    LibraryVersionRow,
    MapRow,
    MissionRow,
    PlanRow,
    ReplanRow,
    TrajectoryRow,
    TransitionRow,
)


@dataclass(frozen=True)
class StoredPlan:
    """A plan version as stored: its PDDL (empty when not asked for), steps and actions. A
    version stored by a worker has no problem text but what regenerates it (``source``,
    ``app.executor.plan_versions.render``; None when not asked for)."""

    version: int
    domain: str
    domain_pddl: str
    problem_pddl: str
    plan: list[str]
    actions: list[dict[str, Any]]
    source: bytes | None = None


NewMission = tuple[str, dict[str, Any], str | None]  # name, request, idempotency key


def now() -> datetime:
    return datetime.now(UTC)


class Store:
    def __init__(self, engine: Engine) -> None:
        self.engine = engine
        self.sessions = sessionmaker(engine, expire_on_commit=False)
        self.lock = threading.RLock()
        # A SQLite file as opened: every write first makes sure it is still that file.
        self.file = DatabaseFile.of(engine)

    @contextmanager
    def _writing(self) -> Iterator[None]:
        """The write lock, held for the block; the wait for it (``lock``) and the block
        (``write``) are spans of the request being served, if any. Nothing is written to a
        database file that was deleted or replaced (``DatabaseLost``)."""
        with timing.span("lock"):
            self.lock.acquire()
        try:
            if self.file is not None:
                self.file.check()
            with timing.span("write"):
                yield
        finally:
            self.lock.release()

    def probe(self) -> None:
        """Readiness: the file is the one opened and a write commits (a row rewritten as it is:
        a real write transaction, on SQLite and PostgreSQL alike). Raises what fails."""
        with self._writing(), self.engine.begin() as conn:
            conn.execute(text("UPDATE alembic_version SET version_num = version_num"))

    # -- missions ---------------------------------------------------------------------------
    def create_mission(
        self, name: str, request: dict[str, Any], idempotency_key: str | None
    ) -> tuple[MissionRow, bool]:
        """Insert a queued mission (and its first transition); ``(row, False)`` for a retried key."""
        return self.create_missions([(name, request, idempotency_key)])[0]

    def create_missions(self, items: Sequence[NewMission]) -> list[tuple[MissionRow, bool]]:
        """Insert queued missions in one transaction, each ``(name, request, idempotency key)``;
        per item ``(row, created)``: a key already used (before, or earlier in ``items``)
        gives the mission it created and False."""
        try:
            return self._insert_missions(items)
        except IntegrityError:  # a key taken meanwhile by another writer (another process)
            if len(items) > 1:  # one at a time: only the item that raced is a replay
                return [self.create_missions([item])[0] for item in items]
            key = items[0][2]
            with self.sessions() as s:
                found = s.scalar(select(MissionRow).where(MissionRow.idempotency_key == key))
            assert found is not None
            return [(found, False)]

    def _insert_missions(self, items: Sequence[NewMission]) -> list[tuple[MissionRow, bool]]:
        with self._writing(), self.sessions() as s:
            keys = [key for _, _, key in items if key]
            seen: dict[str, MissionRow] = {}
            if keys:
                query = select(MissionRow).where(MissionRow.idempotency_key.in_(keys))
                seen = {row.idempotency_key or "": row for row in s.scalars(query)}
            out: list[tuple[MissionRow, bool]] = []
            t = now()
            for name, request, key in items:
                if key and key in seen:
                    out.append((seen[key], False))
                    continue
                row = MissionRow(
                    id=str(uuid.uuid4()),
                    name=name,
                    status="queued",
                    reason="",
                    created_at=t,
                    updated_at=t,
                    idempotency_key=key,
                    request=request,
                    state={},
                )
                s.add(row)
                s.add(TransitionRow(mission_id=row.id, status="queued", at=t, reason=""))
                if key:
                    seen[key] = row
                out.append((row, True))
            s.commit()
            return out

    def missions_by_key(self, keys: Sequence[str]) -> dict[str, MissionRow]:
        """The missions these Idempotency-Keys created (those that did)."""
        if not keys:
            return {}
        with self.sessions() as s:
            query = select(MissionRow).where(MissionRow.idempotency_key.in_(list(keys)))
            return {row.idempotency_key or "": row for row in s.scalars(query)}

    def get_mission(self, mission_id: str) -> MissionRow | None:
        with self.sessions() as s:
            return s.get(MissionRow, mission_id)

    def latest_mission(self) -> MissionRow | None:
        with self.sessions() as s:
            return s.scalar(select(MissionRow).order_by(MissionRow.created_at.desc()).limit(1))

    def list_missions(
        self, status: str | None, limit: int, offset: int
    ) -> tuple[list[MissionRow], int]:
        with self.sessions() as s:
            q = select(MissionRow)
            count = select(func.count()).select_from(MissionRow)
            if status:
                q = q.where(MissionRow.status == status)
                count = count.where(MissionRow.status == status)
            rows = s.scalars(
                q.order_by(MissionRow.created_at.desc(), MissionRow.id).limit(limit).offset(offset)
            )
            return list(rows), int(s.scalar(count) or 0)

    def transitions(self, mission_id: str) -> list[TransitionRow]:
        with self.sessions() as s:
            q = (
                select(TransitionRow)
                .where(TransitionRow.mission_id == mission_id)
                .order_by(TransitionRow.id)
            )
            return list(s.scalars(q))

    def transition(
        self, mission_id: str, status: str, reason: str = "", state: dict[str, Any] | None = None
    ) -> bool:
        """Append a transition and set the status; False (nothing written) when the lifecycle
        forbids it (``app.missions.status.NEXT``): after an end, after ``cancelling`` anything
        but an end, a mission going back to ``queued`` or ``planning``."""
        with self._writing(), self.sessions() as s:
            row = s.get(MissionRow, mission_id)
            if row is None or not can_follow(row.status, status):
                return False
            t = now()
            row.status, row.reason, row.updated_at = str(status), reason, t
            if state is not None:
                row.state = state
            s.add(TransitionRow(mission_id=mission_id, status=str(status), at=t, reason=reason))
            s.commit()
            return True

    def save_state(self, mission_id: str, state: dict[str, Any]) -> None:
        with self._writing(), self.sessions() as s:
            s.execute(
                update(MissionRow)
                .where(MissionRow.id == mission_id)
                .values(state=state, updated_at=now())
            )
            s.commit()

    def interrupt_unfinished(self) -> list[str]:
        """At start-up: missions left active by a crash become failed/interrupted."""
        with self._writing(), self.sessions() as s:
            rows = list(s.scalars(select(MissionRow).where(MissionRow.status.in_(sorted(ACTIVE)))))
            t = now()
            for row in rows:
                row.status, row.reason, row.updated_at = "failed", "interrupted", t
                s.add(TransitionRow(mission_id=row.id, status="failed", at=t, reason="interrupted"))
            s.commit()
            return [r.id for r in rows]

    def queued(self, before: datetime | None = None) -> list[str]:
        """Queued missions, oldest first (only those created before ``before`` if given)."""
        with self.sessions() as s:
            q = select(MissionRow.id).where(MissionRow.status == "queued")
            if before is not None:
                q = q.where(MissionRow.created_at < before)
            return list(s.scalars(q.order_by(MissionRow.created_at)))

    def active(self) -> list[str]:
        """Missions a worker should be running (planning, executing, replanning, cancelling)."""
        with self.sessions() as s:
            return list(s.scalars(select(MissionRow.id).where(MissionRow.status.in_(ACTIVE))))

    # -- plans, replans, trajectories ----------------------------------------------------------
    def add_plan(
        self,
        mission_id: str,
        version: int,
        domain: str,
        domain_pddl: str,
        problem_pddl: str,
        plan: Sequence[str],
        actions: Sequence[dict[str, Any]],
        source: bytes | None = None,
    ) -> None:
        """A plan version; its PDDL and actions go to blobs (the domain text is stored once);
        ``source``: what regenerates its problem (stored as it is), instead of the text."""
        with self.sessions() as s:  # compressed before the write lock, not under it
            texts = (
                blobs.prepare(s, domain_pddl),
                blobs.prepare(s, problem_pddl) if source is None else None,
                blobs.prepare_json(s, {"plan": list(plan), "actions": list(actions)}),
                blobs.prepare_bytes(s, source) if source is not None else None,
            )
        with self._writing(), self.sessions() as s:
            domain_ref, problem_ref, steps_ref, source_ref = (
                blobs.put(s, b) if b is not None else None for b in texts
            )
            s.add(
                PlanRow(
                    mission_id=mission_id,
                    version=version,
                    domain=domain,
                    domain_pddl="",
                    problem_pddl="",
                    plan=[],
                    actions=[],
                    domain_ref=domain_ref,
                    problem_ref=problem_ref,
                    steps_ref=steps_ref,
                    source_ref=source_ref,
                )
            )
            s.commit()

    def plans(
        self, mission_id: str, texts: bool = True, last: bool = False, version: int | None = None
    ) -> list[StoredPlan]:
        """The mission's plan versions, oldest first (only the newest with ``last``, only
        ``version`` given one); the PDDL texts and sources are read only with ``texts`` (they
        are the bulk)."""
        with self.sessions() as s:
            q = select(PlanRow).where(PlanRow.mission_id == mission_id)
            if version is not None:
                q = q.where(PlanRow.version == version)
            if last:
                q = q.order_by(PlanRow.version.desc()).limit(1)
            rows = sorted(s.scalars(q), key=lambda r: r.version)

            def text(ref: str | None, inline: str) -> str:
                return blobs.get_text(s, ref) if ref and texts else inline

            out = []
            for r in rows:
                steps = blobs.get_json(s, r.steps_ref) if r.steps_ref else {}
                out.append(
                    StoredPlan(
                        version=r.version,
                        domain=r.domain,
                        domain_pddl=text(r.domain_ref, r.domain_pddl),
                        problem_pddl=text(r.problem_ref, r.problem_pddl),
                        plan=steps.get("plan", r.plan),
                        actions=steps.get("actions", r.actions),
                        source=blobs.get_bytes(s, r.source_ref) if r.source_ref and texts else None,
                    )
                )
            return out

    def add_replan(self, mission_id: str, record: dict[str, Any]) -> None:
        with self.sessions() as s:
            plans = blobs.prepare_json(s, {"old": record["old"], "new": record["new"]})
        with self._writing(), self.sessions() as s:
            s.add(
                ReplanRow(
                    mission_id=mission_id,
                    trigger=record["trigger"],
                    at=record["at"],
                    latency_ms=record["latency_ms"],
                    detail=record["detail"],
                    old=[],
                    new=[],
                    status=record["status"],
                    plans_ref=blobs.put(s, plans),
                )
            )
            s.commit()

    def replans(self, mission_id: str) -> list[ReplanRow]:
        """The mission's replans, oldest first, their old and new plans filled in (the rows
        are detached: what is filled in is never written back)."""
        with self.sessions() as s:
            q = select(ReplanRow).where(ReplanRow.mission_id == mission_id)
            rows = list(s.scalars(q.order_by(ReplanRow.id)))
            s.expunge_all()  # detached first: filling them in is no change to flush
            for row in rows:
                if row.plans_ref:
                    plans = blobs.get_json(s, row.plans_ref)
                    row.old, row.new = plans["old"], plans["new"]
            return rows

    def save_trajectory(
        self,
        mission_id: str,
        points: list[list[float]],
        world: list[dict[str, Any]] | None = None,
    ) -> None:
        """The trajectory and, if given, the world model's changes over model time."""
        with self.sessions() as s:
            blob = blobs.prepare_json(s, points)
            world_blob = None if world is None else blobs.prepare_json(s, world)
        with self._writing(), self.sessions() as s:
            ref = blobs.put(s, blob)
            world_ref = None if world_blob is None else blobs.put(s, world_blob)
            row = TrajectoryRow(
                mission_id=mission_id, points=[], points_ref=ref, world_ref=world_ref
            )
            s.merge(row)
            s.commit()

    def trajectory(self, mission_id: str) -> list[list[float]] | None:
        with self.sessions() as s:
            row = s.get(TrajectoryRow, mission_id)
            if row is None:
                return None
            points: list[list[float]] = (
                blobs.get_json(s, row.points_ref) if row.points_ref else list(row.points)
            )
            return points

    def world_history(self, mission_id: str) -> list[dict[str, Any]] | None:
        """The world model's changes over the mission's model time (None: not stored, e.g. a
        mission still running or stored before histories were kept)."""
        with self.sessions() as s:
            row = s.get(TrajectoryRow, mission_id)
            if row is None or not row.world_ref:
                return None
            changes: list[dict[str, Any]] = blobs.get_json(s, row.world_ref)
            return changes

    def prune(self, before: datetime) -> int:
        """Delete missions that ended before ``before`` (with everything of theirs) and the
        blobs nothing refers to any more; returns how many missions went."""
        with self._writing(), self.sessions() as s:
            ids = list(
                s.scalars(
                    select(MissionRow.id).where(
                        MissionRow.status.in_(sorted(TERMINAL)), MissionRow.updated_at < before
                    )
                )
            )
            for table in (TransitionRow, PlanRow, ReplanRow, TrajectoryRow):
                s.execute(delete(table).where(table.mission_id.in_(ids)))
            s.execute(delete(MissionRow).where(MissionRow.id.in_(ids)))
            refs = (
                PlanRow.domain_ref,
                PlanRow.problem_ref,
                PlanRow.steps_ref,
                PlanRow.source_ref,
                ReplanRow.plans_ref,
                TrajectoryRow.points_ref,
                TrajectoryRow.world_ref,
            )
            # NULLs left out: NOT IN over a set with a NULL matches nothing
            used = union(*(select(ref).where(ref.is_not(None)) for ref in refs))
            s.execute(delete(BlobRow).where(BlobRow.sha256.not_in(select(used.subquery().c[0]))))
            s.commit()
            return len(ids)

    # -- maps ------------------------------------------------------------------------------------
    def add_map(
        self, map_id: str, name: str, meta: dict[str, Any], image: bytes
    ) -> tuple[MapRow, bool]:
        """Store a map once by its id (a content hash): ``(row, True)`` if it is new, the row
        already there and False if the same map was stored before (a race included)."""
        with self.sessions() as s:
            found = s.get(MapRow, map_id)
        if found is not None:
            return found, False
        row = MapRow(id=map_id, name=name, created_at=now(), meta=meta, image=image)
        try:
            with self._writing(), self.sessions() as s:
                s.add(row)
                s.commit()
        except IntegrityError:  # stored meanwhile by another writer: the same content
            with self.sessions() as s:
                again = s.get(MapRow, map_id)
            assert again is not None
            return again, False
        return row, True

    def get_map(self, map_id: str) -> MapRow | None:
        with self.sessions() as s:
            return s.get(MapRow, map_id)

    def maps(self, ids: Sequence[str]) -> dict[str, MapRow]:
        """The stored maps among ``ids``, by id."""
        if not ids:
            return {}
        with self.sessions() as s:
            rows = s.scalars(select(MapRow).where(MapRow.id.in_(sorted(set(ids)))))
            return {row.id: row for row in rows}

    def list_maps(self, limit: int, offset: int) -> tuple[list[MapRow], int]:
        """A page of maps, newest first (their images left unloaded), and how many there are."""
        with self.sessions() as s:
            total = s.scalar(select(func.count()).select_from(MapRow)) or 0
            rows = s.execute(
                select(MapRow.id, MapRow.name, MapRow.created_at, MapRow.meta)
                .order_by(MapRow.created_at.desc(), MapRow.id)
                .limit(limit)
                .offset(offset)
            ).all()
            out = [MapRow(id=r.id, name=r.name, created_at=r.created_at, meta=r.meta) for r in rows]
            return out, int(total)

    # -- library versions and jobs ---------------------------------------------------------------
    def record_library(self, text: str, code_version: str, entries: int, source: str) -> str:
        digest = hashlib.sha256(text.encode()).hexdigest()
        with self._writing(), self.sessions() as s:
            if (
                s.scalar(select(LibraryVersionRow).where(LibraryVersionRow.sha256 == digest))
                is None
            ):
                s.add(
                    LibraryVersionRow(
                        sha256=digest,
                        code_version=code_version,
                        entries=entries,
                        source=source,
                        loaded_at=now(),
                    )
                )
                s.commit()
        return digest

    def add_learned(
        self,
        shape: str,
        entries: Sequence[dict[str, Any]],
        provenance: dict[str, Any],
        library_version: str,
    ) -> bool:
        """Store a learned shape's entries (each as in the library file) once; False, with
        nothing written, when that shape is stored already (another learner was first)."""
        with self._writing(), self.sessions() as s:
            taken = select(LearnedPrimitiveRow.id).where(LearnedPrimitiveRow.shape == shape)
            if s.scalar(taken.limit(1)) is not None:
                return False
            stamp = now()
            for entry in entries:
                s.add(
                    LearnedPrimitiveRow(
                        shape=shape,
                        primitive=str(entry["id"]),
                        entry=entry,
                        mission_id=provenance.get("mission_id"),
                        job_id=provenance.get("job_id"),
                        seed=int(entry["seed"]),
                        learner=str(entry["learner"]),
                        rollouts=int(entry["rollouts"]),
                        library_version=library_version,
                        created_at=stamp,
                    )
                )
            try:
                s.commit()
            except IntegrityError:  # a primitive of that shape got there first
                s.rollback()
                return False
        return True

    def learned(self, shape: str | None = None) -> list[LearnedPrimitiveRow]:
        """Learned primitives (of one shape), in the order they were stored."""
        query = select(LearnedPrimitiveRow).order_by(LearnedPrimitiveRow.id)
        if shape is not None:
            query = query.where(LearnedPrimitiveRow.shape == shape)
        with self.sessions() as s:
            return list(s.scalars(query))

    def create_job(self, kind: str, request: dict[str, Any]) -> JobRow:
        with self._writing(), self.sessions() as s:
            row = JobRow(
                id=str(uuid.uuid4()),
                kind=kind,
                status="queued",
                reason="",
                created_at=now(),
                request=request,
                progress={},
                result=None,
            )
            s.add(row)
            s.commit()
            return row

    def update_job(self, job_id: str, **values: Any) -> None:
        with self._writing(), self.sessions() as s:
            s.execute(update(JobRow).where(JobRow.id == job_id).values(**values))
            s.commit()

    def get_job(self, job_id: str) -> JobRow | None:
        with self.sessions() as s:
            return s.get(JobRow, job_id)

    def interrupt_jobs(self) -> None:
        with self._writing(), self.sessions() as s:
            s.execute(
                update(JobRow)
                .where(JobRow.status.in_(("queued", "running")))
                .values(status="failed", reason="interrupted")
            )
            s.commit()
