"""Storage models (separate from the API's pydantic schemas)."""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Any

from sqlalchemy import (
    JSON,
    DateTime,
    Float,
    ForeignKey,
    Integer,
    LargeBinary,
    String,
    Text,
    UniqueConstraint,
)
from sqlalchemy.engine import Dialect
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column
from sqlalchemy.types import TypeDecorator


class UTCDateTime(TypeDecorator[datetime]):
    """Timezone-aware UTC timestamps on every backend (SQLite stores them naive)."""

    impl = DateTime(timezone=True)
    cache_ok = True

    def process_result_value(self, value: datetime | None, dialect: Dialect) -> datetime | None:
        if value is not None and value.tzinfo is None:
            return value.replace(tzinfo=UTC)
        return value


class Base(DeclarativeBase):
    pass


class MissionRow(Base):
    __tablename__ = "missions"
    id: Mapped[str] = mapped_column(String(36), primary_key=True)
    name: Mapped[str] = mapped_column(String(120))
    status: Mapped[str] = mapped_column(String(16), index=True)
    reason: Mapped[str] = mapped_column(Text, default="")
    created_at: Mapped[datetime] = mapped_column(UTCDateTime, index=True)
    updated_at: Mapped[datetime] = mapped_column(UTCDateTime)
    idempotency_key: Mapped[str | None] = mapped_column(String(200), unique=True, nullable=True)
    request: Mapped[dict[str, Any]] = mapped_column(JSON)
    state: Mapped[dict[str, Any]] = mapped_column(
        JSON, default=dict
    )  # goals, pose, model_time, ...


class TransitionRow(Base):
    __tablename__ = "transitions"
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    mission_id: Mapped[str] = mapped_column(
        ForeignKey("missions.id", ondelete="CASCADE"), index=True
    )
    status: Mapped[str] = mapped_column(String(16))
    at: Mapped[datetime] = mapped_column(UTCDateTime)
    reason: Mapped[str] = mapped_column(Text, default="")


class PlanRow(Base):
    __tablename__ = "plans"
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    mission_id: Mapped[str] = mapped_column(
        ForeignKey("missions.id", ondelete="CASCADE"), index=True
    )
    version: Mapped[int] = mapped_column(Integer)
    domain: Mapped[str] = mapped_column(String(16))
    domain_pddl: Mapped[str] = mapped_column(Text)
    problem_pddl: Mapped[str] = mapped_column(Text)
    plan: Mapped[list[str]] = mapped_column(JSON)
    actions: Mapped[list[dict[str, Any]]] = mapped_column(JSON)
    # Newer rows keep the texts, plan and actions in blobs (above: "" and []); older inline.
    domain_ref: Mapped[str | None] = mapped_column(String(64), nullable=True)
    problem_ref: Mapped[str | None] = mapped_column(String(64), nullable=True)
    steps_ref: Mapped[str | None] = mapped_column(String(64), nullable=True)  # plan, actions
    # What regenerates the problem (``app.executor.plan_versions.render``; its text is then
    # empty): written by the worker instead of the text, which is rendered when asked.
    source_ref: Mapped[str | None] = mapped_column(String(64), nullable=True)


class ReplanRow(Base):
    __tablename__ = "replans"
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    mission_id: Mapped[str] = mapped_column(
        ForeignKey("missions.id", ondelete="CASCADE"), index=True
    )
    trigger: Mapped[str] = mapped_column(String(32))
    at: Mapped[float] = mapped_column(Float)
    latency_ms: Mapped[float] = mapped_column(Float)
    detail: Mapped[dict[str, Any]] = mapped_column(JSON)
    old: Mapped[list[str]] = mapped_column(JSON)
    new: Mapped[list[str]] = mapped_column(JSON)
    status: Mapped[str] = mapped_column(String(16))
    plans_ref: Mapped[str | None] = mapped_column(String(64), nullable=True)  # old, new


class TrajectoryRow(Base):
    __tablename__ = "trajectories"
    mission_id: Mapped[str] = mapped_column(
        ForeignKey("missions.id", ondelete="CASCADE"), primary_key=True
    )
    points: Mapped[list[list[float]]] = mapped_column(JSON)
    points_ref: Mapped[str | None] = mapped_column(String(64), nullable=True)
    # The world model's changes over model time (app.service.world_history), for the replay.
    world_ref: Mapped[str | None] = mapped_column(String(64), nullable=True)


class BlobRow(Base):
    """A text or JSON document stored once (by its SHA-256), compressed."""

    __tablename__ = "blobs"
    sha256: Mapped[str] = mapped_column(String(64), primary_key=True)
    codec: Mapped[str] = mapped_column(String(8))
    size: Mapped[int] = mapped_column(Integer)  # bytes before compression
    data: Mapped[bytes] = mapped_column(LargeBinary)


class LibraryVersionRow(Base):
    __tablename__ = "library_versions"
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    sha256: Mapped[str] = mapped_column(String(64), unique=True)
    code_version: Mapped[str] = mapped_column(String(40))
    entries: Mapped[int] = mapped_column(Integer)
    source: Mapped[str] = mapped_column(Text)
    loaded_at: Mapped[datetime] = mapped_column(UTCDateTime)


class LearnedPrimitiveRow(Base):
    """A lattice primitive learned by the service (a mission or a learning job) for a shape
    the bundled library lacks, with its provenance. The library the service runs on is the
    bundled file plus these rows, in ``id`` order; the file itself is never written."""

    __tablename__ = "learned_primitives"
    __table_args__ = (UniqueConstraint("primitive", name="uq_learned_primitives_primitive"),)
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    shape: Mapped[str] = mapped_column(String(64), index=True)
    primitive: Mapped[str] = mapped_column(String(64))
    entry: Mapped[dict[str, Any]] = mapped_column(JSON)  # the library entry, as in the file
    mission_id: Mapped[str | None] = mapped_column(String(36), nullable=True)
    job_id: Mapped[str | None] = mapped_column(String(36), nullable=True)
    seed: Mapped[int] = mapped_column(Integer)
    learner: Mapped[str] = mapped_column(String(40))
    rollouts: Mapped[int] = mapped_column(Integer)
    library_version: Mapped[str] = mapped_column(String(64))  # the version it joined
    created_at: Mapped[datetime] = mapped_column(UTCDateTime)


class JobRow(Base):
    __tablename__ = "jobs"
    id: Mapped[str] = mapped_column(String(36), primary_key=True)
    kind: Mapped[str] = mapped_column(String(16))
    status: Mapped[str] = mapped_column(String(16), index=True)
    reason: Mapped[str] = mapped_column(Text, default="")
    created_at: Mapped[datetime] = mapped_column(UTCDateTime)
    request: Mapped[dict[str, Any]] = mapped_column(JSON)
    progress: Mapped[dict[str, Any]] = mapped_column(JSON, default=dict)
    result: Mapped[dict[str, Any] | None] = mapped_column(JSON, nullable=True)


class MapRow(Base):
    """An occupancy-grid map, stored once: ``id`` is its content hash (image and parameters),
    ``meta`` its parameters and what was read off it (size, extent, cell counts), ``image``
    the image file as posted (PGM or PNG)."""

    __tablename__ = "maps"
    id: Mapped[str] = mapped_column(String(32), primary_key=True)
    name: Mapped[str] = mapped_column(String(120))
    created_at: Mapped[datetime] = mapped_column(UTCDateTime, index=True)
    meta: Mapped[dict[str, Any]] = mapped_column(JSON)
    image: Mapped[bytes] = mapped_column(LargeBinary)
