"""Service settings from the environment (SCREWSNAKE_*), with embedded defaults."""

from __future__ import annotations

import importlib.util
import os
from functools import cache
from pathlib import Path
from typing import Literal

from pydantic import BaseModel, Field, field_validator, model_validator

from app.missions.parts import MAX_GOALS


def default_data_dir() -> Path:
    """Where the service keeps its files unless told: ``$XDG_DATA_HOME/screwsnake`` (by default
    ``~/.local/share/screwsnake``), the same whichever directory the server starts in."""
    base = os.environ.get("XDG_DATA_HOME") or str(Path.home() / ".local" / "share")
    return Path(base) / "screwsnake"


def cores() -> int:
    """The CPU cores this process may use (at least 1)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return max(1, os.cpu_count() or 1)


def machine_memory() -> int:
    """This machine's physical memory in bytes (0 when it cannot be told)."""
    try:
        return int(os.sysconf("SC_PHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, OSError, ValueError):
        return 0


MEMORY_SHARE = 0.8  # of the machine's memory, shared by the workers and the server process
MIN_WORKER_MEMORY = 64 << 20  # the least SCREWSNAKE_WORKER_MEMORY may be (tests go this low)
DEFAULT_MIN_WORKER_MEMORY = 1 << 30  # the default is at least this (a warm worker is ~0.3 GB)
UNITS = {"": 1, "k": 1 << 10, "m": 1 << 20, "g": 1 << 30, "t": 1 << 40}


def default_worker_memory(workers: int) -> int:
    """A worker's share: ``MEMORY_SHARE`` of the machine split between the workers and the
    server, at least ``DEFAULT_MIN_WORKER_MEMORY``."""
    share = int(MEMORY_SHARE * machine_memory() / (workers + 1))
    return max(DEFAULT_MIN_WORKER_MEMORY, share)


def parse_bytes(value: object) -> object:
    """``2G``, ``1500M``, ``512MiB``, ``1073741824``: bytes (binary units)."""
    if not isinstance(value, str):
        return value
    text = value.strip().lower().removesuffix("ib").removesuffix("b")
    number = text.rstrip("kmgt")
    unit = text[len(number) :]
    try:
        return int(float(number) * UNITS[unit])
    except (KeyError, ValueError):
        return value  # pydantic says what is wrong with it


class Settings(BaseModel):
    data_dir: Path = Field(default_factory=default_data_dir)  # SCREWSNAKE_DATA_DIR
    database_url: str | None = None  # None: SQLite at data_dir/screwsnake.db
    retention_days: float = Field(
        90.0, ge=0, le=100_000
    )  # finished missions older than this are deleted (0: kept forever)
    library: Path | None = None  # None: the bundled library
    api_key: str | None = None  # bearer token required (see `auth`) when set
    auth: Literal["writes", "all"] = "writes"  # what the API key guards: writes, or everything
    allowed_origins: list[str] = []  # browser origins allowed (CORS, websocket); same-origin always
    # Worker processes (or Ray actors) in the warm pool = missions executing at once; more queue.
    max_running: int = Field(default_factory=lambda: min(cores(), 256), ge=1, le=256)
    worker_nice: int = Field(
        10, ge=0, le=19
    )  # niceness of mission workers: the API keeps priority over mission CPU (0: same priority)
    # Each worker first runs a short untimed mission, loading compiled kernels and motion
    # tables before its first real one (off: the first mission of each worker pays for them).
    warm_up: bool = True
    # Workers that must have finished their warm-up for /readyz to answer 200 (0: do not wait;
    # more than the pool: all of it).
    ready_workers: int = Field(1, ge=0, le=256)
    executor: Literal["local", "ray"] = "local"  # where missions run: local processes or Ray
    ray_address: str | None = None  # a Ray cluster (e.g. ray://head:10001); None: a local Ray
    max_queued: int = Field(1000, ge=0, le=1_000_000)  # waiting missions before POST answers 503
    # Request body bytes (else 413): 4 MB holds 10,000 obstacles; maps have `max_map_body`.
    max_body: int = Field(4_000_000, ge=1024, le=1_000_000_000)
    # Obstacles one mission may list (422 naming `obstacles` beyond): the mission model reads
    # it through `max_obstacles()` wherever a mission is validated.
    max_obstacles: int = Field(10_000, ge=1, le=100_000)
    # Pixels one map image may have (422 naming its `image` beyond), read like
    # `max_obstacles` through `max_map_pixels()` wherever a map is decoded.
    max_map_pixels: int = Field(4_000_000, ge=1, le=100_000_000)
    # Body bytes of `POST /maps` (its own limit: a 1000 x 1000 map in base64 is 1.3 MB, past the
    # missions' `max_body`); larger is 413 before the body is read.
    max_map_body: int = Field(20_000_000, ge=1024, le=1_000_000_000)
    # PDDL text bytes one answer may hold: a plan version's problem (GET /missions/{id}/pddl/
    # {version}) larger than this is 413; GET /missions/{id}/pddl holds problems inline up to
    # `pddl_inline` bytes in all, and names where the others are.
    max_pddl_answer: int = Field(64_000_000, ge=1024, le=4_000_000_000)
    pddl_inline: int = Field(4_000_000, ge=0, le=4_000_000_000)
    wall_limit: float = Field(3600.0, gt=0, le=7 * 86400)  # wall-clock seconds per mission
    # Wall seconds a mission may spend learning the lattice set of a shape the library lacks
    # (past it: failed, "learning: ..."; about 0.3 s on one core, bench/learning.py shapes).
    learn_budget: float = Field(30.0, gt=0, le=3600)
    min_speed: float = Field(0.01, gt=0, le=10_000)  # slowest real-time pacing (0 = unpaced)
    reconcile_seconds: float = Field(30.0, gt=0, le=86400)  # how often lost missions are ended
    ws_rate: float = Field(10.0, gt=0, le=200)  # state frames per second and client
    # A Server-Timing header on every HTTP answer: where the request's time went (off: none).
    server_timing: bool = True
    # Threads serving requests' blocking work (store reads and writes) at once; past a few,
    # threads only queue for the GIL and slow the event loop (FastAPI's default is 40).
    api_threads: int = Field(8, ge=1, le=1000)
    # Missions posted at once that are stored in one transaction (more wait for the next).
    post_batch: int = Field(50, ge=1, le=10_000)
    # Websocket snapshots (store reads) built at once: a burst of clients connecting waits its
    # turn instead of taking every thread from the API's requests.
    ws_snapshot_threads: int = Field(2, ge=1, le=256)
    ws_queue: int = Field(
        256, ge=8, le=100_000
    )  # undeliverable event frames before a client is dropped
    # Goals a mission may have, posted and added live (removed ones count: indices stay).
    max_goals: int = Field(MAX_GOALS, ge=1, le=MAX_GOALS)
    # Known obstacles added live to one running mission.
    max_live_obstacles: int = Field(200, ge=0, le=10_000)
    # Learning jobs waiting for the learner; beyond, POST /jobs/learn is 503 with Retry-After.
    max_queued_jobs: int = Field(16, ge=0, le=100_000)
    # RSS bytes a mission worker (or Ray actor) may use: past it the mission ends failed
    # (memory limit) and the worker is replaced; the planner's caches are sized by it.
    # None: the default, a share of the machine (``default_worker_memory``).
    worker_memory: int | None = Field(None, ge=MIN_WORKER_MEMORY, le=1 << 50)
    # Seconds the service's shutdown may take: running missions are asked to stop, then their
    # workers are killed, stuck or not.
    shutdown_seconds: float = Field(10.0, gt=0, le=3600)
    # Seconds a thread of the server may hold the GIL while another waits for it
    # (`sys.setswitchinterval`): short, so the event loop waits little behind the threads
    # writing the store and building large answers.
    switch_interval: float = Field(0.0005, ge=0.0001, le=0.1)
    # Processes validating request bodies and live updates (and running POST /simulate) off
    # the event loop.
    validation_workers: int = Field(default_factory=lambda: min(cores(), 2), ge=1, le=64)

    @field_validator("worker_memory", mode="before")
    @classmethod
    def _bytes(cls, value: object) -> object:
        return parse_bytes(value)

    @model_validator(mode="after")
    def _worker_share(self) -> Settings:
        if self.worker_memory is None:
            self.worker_memory = default_worker_memory(self.max_running)
        return self

    @property
    def worker_memory_bytes(self) -> int:
        """``worker_memory``, filled in (never None once validated)."""
        return self.worker_memory or default_worker_memory(self.max_running)

    @field_validator("allowed_origins", mode="before")
    @classmethod
    def _comma_list(cls, value: object) -> object:
        """``SCREWSNAKE_ALLOWED_ORIGINS=https://a.example,https://b.example``."""
        if isinstance(value, str):
            return [v.strip().rstrip("/") for v in value.split(",") if v.strip()]
        return value

    def database(self) -> str:
        """The database URL: the one given, or a SQLite file in the data directory."""
        if self.database_url:
            return self.database_url
        return f"sqlite:///{self.data_dir.expanduser().resolve() / 'screwsnake.db'}"

    @classmethod
    def from_env(cls) -> Settings:
        env = os.environ
        data: dict[str, object] = {}
        for field in cls.model_fields:
            key = f"SCREWSNAKE_{field.upper()}"
            if key in env:
                data[field] = env[key]
        return cls.model_validate(data)


def max_obstacles() -> int:
    """``SCREWSNAKE_MAX_OBSTACLES`` as ``Settings`` validates it (its default when unset).

    Read from the environment each time a mission is validated rather than from a ``Settings``
    object: the API, the service's workers (which inherit the environment), the CLI and the
    benches then apply one cap, and none of them needs a server's settings at hand."""
    return _max_obstacles(os.environ.get("SCREWSNAKE_MAX_OBSTACLES"))


@cache
def _max_obstacles(raw: str | None) -> int:
    if raw is None:
        default: int = Settings.model_fields["max_obstacles"].default
        return default
    return Settings.model_validate({"max_obstacles": raw}).max_obstacles


def max_map_pixels() -> int:
    """``SCREWSNAKE_MAX_MAP_PIXELS`` as ``Settings`` validates it, read as ``max_obstacles``."""
    return _max_map_pixels(os.environ.get("SCREWSNAKE_MAX_MAP_PIXELS"))


@cache
def _max_map_pixels(raw: str | None) -> int:
    if raw is None:
        default: int = Settings.model_fields["max_map_pixels"].default
        return default
    return Settings.model_validate({"max_map_pixels": raw}).max_map_pixels


def missing_extra(settings: Settings) -> str | None:
    """What to install before these settings can run (one line), or None: an executor whose
    package is absent would otherwise fail at start with a bare ModuleNotFoundError."""
    if settings.executor == "ray" and importlib.util.find_spec("ray") is None:
        return (
            "SCREWSNAKE_EXECUTOR=ray needs Ray, which is not installed: "
            "pip install 'screwsnake[ray]' (or unset SCREWSNAKE_EXECUTOR to run missions locally)"
        )
    return None
