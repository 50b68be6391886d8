"""The mission worker: runs missions one after another and reports everything as messages.

Missions are CPU work (numpy, planning, the behaviour tree); in threads they would share the
GIL with the API and slow every request. So they run in worker processes (a warm pool started
with the service, ``app.service.pool``) or Ray actors (``app.service.ray_pool``), and the
supervisor's thread in the server turns the messages into store writes and websocket frames,
in order. The channels are duck-typed: multiprocessing queues and events in a pool process,
``queue.Queue`` and ``threading.Event`` inside a Ray actor.
"""

from __future__ import annotations

import contextlib
import json
import os
import queue as queue_module
import socket
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol

import py_trees

from app.executor.context import MissionContext
from app.executor.learning import LearningSettings
from app.executor.runner import MissionError, MissionRunner, UpdateRefused
from app.executor.warm import unfreeze_mission
from app.missions.spec import MissionSpec, body_overlap
from app.missions.status import MissionStatus
from app.service import world_map
from app.service.messages import (
    AddGoal,
    AddObstacle,
    Addressed,
    Ended,
    Events,
    Frame,
    Job,
    Learned,
    Pause,
    PlanMade,
    Publish,
    RemoveGoal,
    Replanned,
    Resume,
    SaveState,
    TrajectoryDone,
    Transition,
    Update,
    WorkerMessage,
)
from app.service.world_history import WorldHistory
from domain.navigation import planner as navigation_planner
from domain.navigation.lattice import cache as motion_cache
from primitives.library import Library, Primitive
from sim.obstacles import obstacle_from_dict


class Outbox(Protocol):
    """Where a worker's messages go (a multiprocessing or a thread queue)."""

    def put(self, item: WorkerMessage) -> None: ...


class UpdateInbox(Protocol):
    """Live updates for the running mission; ``get_nowait`` raises ``queue.Empty``."""

    def get_nowait(self) -> Addressed: ...


class JobInbox(Protocol):
    """The next mission to run; None asks the worker to exit."""

    def get(self) -> Job | None: ...


class CancelFlag(Protocol):
    """A threading or multiprocessing event, set to cancel the running mission."""

    def is_set(self) -> bool: ...

    def wait(self, timeout: float | None = None) -> bool: ...


class Flag(Protocol):
    """A flag the worker raises (its warm-up ended): shared memory, or a threading event."""

    def set(self) -> None: ...


WarmUp = Callable[[Library], object]  # a worker's warm-up (``app.executor.warm.warm_up``)


class SharedFlag:
    """A flag in shared memory, for a pool process: its cancel flag, and the flag it raises
    once warm. Unlike a multiprocessing Event, setting it never blocks: ``Event.set`` waits
    until its sleepers wake, so a hung (e.g. stopped) worker would hang whoever cancels its
    mission."""

    def __init__(self, value: Any) -> None:
        self.value = value  # a RawValue("b") of the pool's multiprocessing context

    def is_set(self) -> bool:
        return bool(self.value.value)

    def set(self) -> None:
        self.value.value = 1

    def clear(self) -> None:
        self.value.value = 0

    def wait(self, timeout: float | None = None) -> bool:
        """Sleep until set or ``timeout`` seconds pass; whether it is set."""
        deadline = time.monotonic() + (float("inf") if timeout is None else timeout)
        while not self.is_set():
            left = deadline - time.monotonic()
            if left <= 0:
                return False
            time.sleep(min(left, FLAG_POLL_SECONDS))
        return True


FLAG_POLL_SECONDS = 0.02  # how often a waiting worker looks at its cancel flag
STATE_SAVE_SECONDS = 1.0  # wall seconds between state writes of a running mission
PAUSED_POLL_SECONDS = 0.05  # how often a paused mission looks for resume or cancel
EVENTS_KEPT = 1000  # events kept in a mission's stored state (the newest)
PACE_SLICE = 0.25  # longest wait while pacing: cancels and the wall clock are checked between
# Wall seconds between looks at the live-update queue: a multiprocessing queue's look takes a
# lock and a poll (~5% of an unpaced mission's CPU, were it made every control tick).
UPDATE_POLL_SECONDS = 0.02


# The planner's motion caches kept between replans, per process: the share of a worker's memory
# limit (``SCREWSNAKE_WORKER_MEMORY``) they may take together, and the bytes a state's row holds.
CACHE_SHARE = 0.5  # (the default limit keeps the planner's own default)
ROW_BYTES = 200  # a state's row in one part (``domain.navigation.lattice.cache``, ~200 B)
# The planner's own limit (what a worker with memory to spare keeps), read before any sizing.
DEFAULT_ROWS = motion_cache.ROWS_LIMIT


def budget_caches(memory: int) -> int:
    """Size the planner's motion caches in this process to ``memory`` bytes (the worker's
    limit): never above their default, which fits the default limit; a smaller limit gets
    smaller caches (each of ``CACHES_KEPT`` caches keeps two parts of rows), so that a mission
    staying within it is not ended by what the planner merely remembers. Returns the rows each
    part may keep."""
    parts = 2 * navigation_planner.CACHES_KEPT
    rows = max(1000, min(DEFAULT_ROWS, int(memory * CACHE_SHARE) // (parts * ROW_BYTES)))
    motion_cache.ROWS_LIMIT = rows
    return rows


# The learned shapes this process has parsed, and the library last made with them (one object
# while nothing new was learned: the motion tables are kept per library object).
_PARSED: dict[str, tuple[Primitive, ...]] = {}
_LIBRARY: dict[str, Any] = {}


def library_for(base: Library, learned: tuple[tuple[str, str], ...]) -> Library:
    """``base`` with the learned shapes it lacks, in the store's order (each parsed once)."""
    if not learned:
        return base
    key = (id(base), tuple(shape for shape, _ in learned))
    if _LIBRARY.get("key") == key:
        library: Library = _LIBRARY["library"]
        return library
    for shape, text in learned:
        if shape not in _PARSED:
            _PARSED[shape] = tuple(Primitive.model_validate(e) for e in json.loads(text))
    library = base.with_entries(e for shape, _ in learned for e in _PARSED[shape])
    _LIBRARY.update(key=key, library=library)
    return library


def learned_messages(runner: MissionRunner, sent: int, known: tuple[str, ...]) -> list[Learned]:
    """A ``Learned`` message per shape the mission learned since ``sent`` (``known``: the
    learned shapes its library started with)."""
    out = []
    shapes = list(known)
    for i, learned in enumerate(runner.learned):
        shapes.append(learned.shape)
        if i >= sent:
            _PARSED.setdefault(learned.shape, learned.entries)
            text = "[" + ",".join(e.model_dump_json() for e in learned.entries) + "]"
            out.append(Learned(learned.shape, text, tuple(shapes)))
    return out


def mission_state(runner: MissionRunner) -> dict[str, Any]:
    ctx = runner.ctx
    x, y, psi = ctx.pose
    world = ctx.world.to_dict()
    return {
        "goals": [g.to_dict() for g in ctx.goals],
        "pose": {"x": x, "y": y, "psi": psi, "joints": list(ctx.sensed_joints())},
        "model_time": round(ctx.t, 3),
        "collisions": ctx.contacts,
        "replans": sum(1 for r in ctx.replans if r.trigger != "initial"),
        "shape": ctx.shape,
        "action": ctx.current_action,
        "sensed": world.get("sensed", []),
        "contacts": world.get("contact", []),
        "resolution": world.get("resolution"),
        # the world model as map_saver would write it (GET /missions/{id}/world.yaml, .pgm)
        "map": world_map.pack(ctx.world, world["origin"], world["resolution"]),
        # For the viewer's replay and the event log (GET /missions/{id}/events): every event
        # (the newest EVENTS_KEPT), and the model time at which each plan version was made
        # (index = version - 1).
        "events": ctx.events[-EVENTS_KEPT:],
        "plan_times": [round(r.at, 3) for r in ctx.replans],
    }


def plan_message(runner: MissionRunner, index: int) -> PlanMade:
    """The plan message of plan version ``index + 1``."""
    ctx = runner.ctx
    entry = ctx.pddl[index]
    actions = runner.plan_actions() if entry.version == ctx.plan_version else []
    return PlanMade(
        entry.version,
        ctx.spec.planner.domain,
        entry.domain,
        entry.source(),
        entry.plan,
        actions,
    )


def news(runner: MissionRunner, events_sent: int, versions: int) -> list[WorkerMessage]:
    """What happened since: events in order; a replan as its record, then its plan (so the
    ``replanning`` status comes before the new ``plan`` frame); a first plan after them."""
    ctx = runner.ctx
    out: list[WorkerMessage] = []
    for event in ctx.events[events_sent:]:
        if event["kind"] == "replan":
            version = int(event["version"])
            record = ctx.replans[version - 1].to_dict()
            out.append(Replanned(record, version, float(event["t"])))
            out.append(plan_message(runner, version - 1))
            versions = max(versions, version)
        else:
            out.append(Publish({"type": "event", **event}))
    for index in range(versions, ctx.plan_version):  # plans without a replan: the first
        out.append(plan_message(runner, index))
    return out


def last_open_goal(runner: MissionRunner, index: int) -> bool:
    """Whether goal ``index`` is the only goal neither reached nor removed."""
    goals = runner.ctx.goals
    others = (g for i, g in enumerate(goals) if i != index and not (g.reached or g.removed))
    return 0 <= index < len(goals) and not goals[index].reached and next(others, None) is None


def apply_update(runner: MissionRunner, update: Update) -> list[WorkerMessage]:
    """Apply a live update to the runner; the status change it causes, if any. The server
    checked it against its account of the mission; what changed since (a goal reached, the
    robot moved) is checked again here, and an update that no longer applies is refused with
    an ``update`` event: it never ends the mission (a removed last goal would end it
    ``succeeded`` with nothing reached, an obstacle on the body in a false ``unreachable``)."""
    try:
        if isinstance(update, AddGoal):
            index = runner.add_goal(update.x, update.y, update.tolerance)
            if 0 <= update.index != index:  # the server's account and the runner disagree
                detail = {"answered": update.index, "index": index}
                runner.ctx.event("update", update="add_goal index differs", detail=detail)
        elif isinstance(update, RemoveGoal):
            if last_open_goal(runner, update.index):
                raise UpdateRefused(
                    f"goal {update.index} is the last goal not reached: cancel the mission instead"
                )
            runner.remove_goal(update.index)
        elif isinstance(update, AddObstacle):
            obstacle = obstacle_from_dict(update.obstacle)
            ctx = runner.ctx
            overlap = body_overlap(
                ctx.spec.bounds.bounds(), [obstacle], ctx.pose, ctx.sensed_joints()
            )
            if overlap is not None:
                raise UpdateRefused("the obstacle overlaps the robot's body where it is now")
            runner.add_obstacle(obstacle)
        elif isinstance(update, Pause):
            runner.pause()
            return [Transition(MissionStatus.PAUSED, "pause requested", mission_state(runner))]
        elif isinstance(update, Resume):
            runner.resume()
            return [Transition(MissionStatus.EXECUTING, "resumed", mission_state(runner))]
    except UpdateRefused as exc:  # raced with the mission (e.g. the goal was reached meanwhile)
        runner.ctx.event("update", update=f"{update.kind} refused", detail={"reason": str(exc)})
    return []


def watch_server(server_pid: int, period: float = 1.0) -> None:
    """Exit as soon as the server process is gone (e.g. SIGKILLed): nobody reads our messages
    any more, and a worker must never outlive its server or hang on a full pipe."""
    while True:
        time.sleep(period)
        try:
            os.kill(server_pid, 0)
        except (
            ProcessLookupError,
            PermissionError,
        ):  # gone (or the pid now belongs to another user)
            os._exit(3)


def resident_bytes(pid: int | None = None) -> int | None:
    """A process's resident memory (RSS) in bytes, this one's by default; None if unknown."""
    try:
        fields = Path(f"/proc/{pid or 'self'}/statm").read_text().split()
        return int(fields[1]) * PAGE_SIZE
    except (OSError, ValueError, IndexError):
        return None


PAGE_SIZE = os.sysconf("SC_PAGE_SIZE") if hasattr(os, "sysconf") else 4096


class EventBatch:
    """An outbox that holds event frames back and sends them together as one ``Events``
    message: before any other message (so the order stays), or once the oldest has waited
    ``period`` wall seconds (``flush_due``, at every tick). An obstacle is sensed at most ticks
    of a mission: one message each was a pickle, a pipe write, a validation and a wake of the
    server's event loop per tick, on the core the mission runs on."""

    def __init__(self, queue: Outbox, period: float) -> None:
        self.queue, self.period = queue, period
        self.frames: list[Frame] = []
        self.since = 0.0  # when the oldest frame held came

    def put(self, item: WorkerMessage) -> None:
        if isinstance(item, Publish) and item.frame.get("type") == "event":
            if not self.frames:
                self.since = time.perf_counter()
            self.frames.append(item.frame)
            return
        self.flush()
        self.queue.put(item)

    def flush_due(self) -> None:
        """Send the frames held if the oldest has waited ``period``."""
        if self.frames and time.perf_counter() - self.since >= self.period:
            self.flush()

    def flush(self) -> None:
        if self.frames:
            self.queue.put(Events(tuple(self.frames)))
            self.frames = []


def where() -> str:
    """This worker, as the ``planning`` transition names it: which process on which host."""
    return f"worker pid {os.getpid()} on {socket.gethostname()}"


def run_mission(
    job: Job,
    library: Library,
    ws_rate: float,
    queue: Outbox,
    cancel: CancelFlag,
    updates: UpdateInbox | None = None,
) -> None:
    """Run one mission, report through ``queue``, always end with Ended; leave nothing of it
    behind for the next mission this worker runs."""
    batch = EventBatch(queue, 1.0 / ws_rate)
    try:
        _run(job, library, ws_rate, batch, cancel, updates)
    except Exception as exc:  # report, never die silently (and never with a server path)
        batch.put(Ended(MissionStatus.FAILED, f"server error ({type(exc).__name__})"))
    finally:
        py_trees.blackboard.Blackboard.clear()  # the behaviour trees' keys and clients
        unfreeze_mission()


def serve_missions(
    jobs: JobInbox,
    queue: Outbox,
    cancel: CancelFlag,
    updates: UpdateInbox,
    library: Library,
    ws_rate: float,
    server_pid: int,
    niceness: int = 10,
    warm: WarmUp | None = None,
    warmed: Flag | None = None,
    memory: int | None = None,
) -> None:
    """A pool process's target: size the planner's caches to ``memory`` (its limit), warm up
    (``warm``, if any), raise ``warmed``, then run each job as it comes until None (or the
    server is gone)."""
    threading.Thread(
        target=watch_server, args=(server_pid,), daemon=True, name="watch-server"
    ).start()
    if niceness:
        with contextlib.suppress(OSError):
            os.nice(niceness)  # the API process keeps priority: requests stay fast under load
    if memory is not None:
        budget_caches(memory)
    if warm is not None:
        warm(library)  # kernels and motion tables loaded before the first mission comes
    if warmed is not None:
        warmed.set()  # the service counts this worker warm from now on (``/readyz``)
    while (job := jobs.get()) is not None:
        run_mission(job, library, ws_rate, queue, cancel, updates)


def pending(updates: UpdateInbox | None, mission_id: str) -> list[Update]:
    """The live updates for this mission the API sent since the last tick (none without a
    queue); updates left over for an earlier mission are dropped."""
    out: list[Update] = []
    while updates is not None:
        try:
            item = updates.get_nowait()
        except queue_module.Empty:
            break
        if item.mission_id == mission_id:
            out.append(item.update)
    return out


def _run(
    job: Job,
    library: Library,
    ws_rate: float,
    queue: Outbox,
    cancel: CancelFlag,
    updates: UpdateInbox | None,
) -> None:
    begun = time.perf_counter()  # the wall-clock limit counts planning too
    mission_id, wall_limit = job.mission_id, job.wall_limit
    spec = MissionSpec.model_validate(job.request, context={"maps": job.maps})
    queue.put(Transition(MissionStatus.PLANNING, where()))
    period = 1.0 / ws_rate
    last_state = last_save = 0.0
    learning_since: float | None = None  # wall time learning began (None: not learning)
    versions, events_sent = 0, 0

    def on_learning(ctx: MissionContext) -> None:
        """Learning began or got on: the ``learning`` status once, then state frames with
        its progress (at the websocket rate)."""
        nonlocal last_state, learning_since, events_sent, versions
        if learning_since is None:
            learning_since = time.perf_counter()
            for message in news(runner, events_sent, versions):  # the deformation first
                queue.put(message)
            events_sent, versions = len(ctx.events), ctx.plan_version
            shape = ctx.learning["shape"] if ctx.learning else ctx.shape
            queue.put(Transition(MissionStatus.LEARNING, f"learning shape {shape}"))
        if time.perf_counter() - last_state >= period:
            queue.put(Publish({"type": "state", **runner.snapshot()}))
            last_state = time.perf_counter()

    try:
        runner = MissionRunner(
            spec,
            library_for(library, job.learned),
            mission_id=mission_id.replace("-", ""),
            cancel=cancel,
            learning=LearningSettings(budget=job.learn_budget),
            on_learning=on_learning,
        )
    except MissionError as exc:
        queue.put(Ended(MissionStatus.FAILED, str(exc)))
        return
    known = tuple(shape for shape, _ in job.learned)
    started = time.perf_counter()
    executing, learned_sent, last_poll = False, 0, 0.0
    history = WorldHistory()  # what the replay shows of the world model at each model time
    paused_since: float | None = None
    while True:
        if (now := time.perf_counter()) - last_poll >= UPDATE_POLL_SECONDS:
            last_poll = now
            for update in pending(updates, mission_id):
                for message in apply_update(runner, update):
                    queue.put(message)
        if runner.paused and paused_since is None:
            paused_since = time.perf_counter()
        elif not runner.paused and paused_since is not None:
            started += time.perf_counter() - paused_since  # pacing ignores the pause
            paused_since = None
        done = runner.step()
        ctx = runner.ctx
        if learning_since is not None:  # model time stood still: pacing ignores the learning
            started += time.perf_counter() - learning_since
            learning_since = None
        for message in learned_messages(runner, learned_sent, known):
            queue.put(message)
        learned_sent = len(runner.learned)
        history.observe(ctx.t, ctx.world)
        for message in news(runner, events_sent, versions):
            queue.put(message)
        events_sent, versions = len(ctx.events), ctx.plan_version
        if isinstance(queue, EventBatch):
            queue.flush_due()
        if done:
            break
        if time.perf_counter() - begun > wall_limit:
            runner.abort("failed", f"wall-clock limit: {wall_limit:g} s reached")
            break
        if not executing and not runner.paused:  # a pause before the first tick stays paused
            queue.put(Transition(MissionStatus.EXECUTING, "", mission_state(runner)))
            executing = True
            # Pacing counts from here: the first plan (seconds on a cold worker) is no model
            # time to catch up on by running the first stretch unpaced.
            if spec.speed > 0:
                started = time.perf_counter() - ctx.t / spec.speed
        wall = time.perf_counter()
        if wall - last_state >= period:
            queue.put(Publish({"type": "state", **runner.snapshot()}))
            last_state = wall
        if wall - last_save >= STATE_SAVE_SECONDS:
            queue.put(SaveState(mission_state(runner)))
            last_save = wall
        if runner.paused:
            cancel.wait(PAUSED_POLL_SECONDS)
        elif spec.speed > 0:  # pace model time against the wall clock
            ahead = ctx.t / spec.speed - (time.perf_counter() - started)
            if ahead > 0:
                cancel.wait(min(ahead, PACE_SLICE))
    # the last state frame: the tree as it ended (its root SUCCESS or FAILURE, not RUNNING)
    queue.put(Publish({"type": "state", **runner.snapshot()}))
    history.record(runner.ctx.t, runner.ctx.world)
    queue.put(TrajectoryDone(runner.trajectory(), history.changes))
    final = mission_state(runner) | {"tree": runner.snapshot()["tree"]}
    queue.put(Ended(MissionStatus(runner.status), runner.reason, final))
