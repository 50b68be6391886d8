"""The mission worker process: runs one mission and reports everything as messages.

Missions are CPU work (numpy, planning, the behaviour tree); in threads they would share the
GIL with the API and slow every request. So each runs in its own process, and the supervisor's
thread in the server turns the messages into store writes and websocket frames, in order.
"""

from __future__ import annotations

import contextlib
import os
import threading
import time
from multiprocessing.queues import Queue
from multiprocessing.synchronize import Event
from typing import Any

from app.executor.runner import MissionError, MissionRunner
from app.missions.spec import MissionSpec
from primitives.library import Library

WORKER_NICENESS = 10
STATE_SAVE_SECONDS = 1.0  # wall seconds between state writes of a running mission
EVENTS_KEPT = 1000  # events kept in a mission's stored state (the newest)
PACE_SLICE = 0.25  # longest wait while pacing: cancels and the wall clock are checked between
Message = tuple[Any, ...]


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
        # For the viewer's replay: every event (the newest EVENTS_KEPT), and the model time at
        # which each plan version was made (index = version - 1).
        "events": ctx.events[-EVENTS_KEPT:],
        "plan_times": [round(r.at, 3) for r in ctx.replans],
    }


def plan_messages(runner: MissionRunner, seen: int) -> list[Message]:
    """("plan", ...) and ("replan", ...) messages for plans made since version ``seen``."""
    ctx = runner.ctx
    out: list[Message] = []
    domain = ctx.spec.planner.domain
    for entry, record in zip(ctx.pddl[seen:], ctx.replans[seen:], strict=False):
        actions = runner.plan_actions() if entry["version"] == ctx.plan_version else []
        out.append(
            (
                "plan",
                entry["version"],
                domain,
                entry["domain"],
                entry["problem"],
                entry["plan"],
                actions,
            )
        )
        if record.trigger != "initial":
            out.append(("replan", record.to_dict()))
    return out


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


def run_mission_process(
    mission_id: str,
    request: dict[str, Any],
    library: Library,
    ws_rate: float,
    queue: Queue[Message],
    cancel: Event,
    server_pid: int,
    wall_limit: float = float("inf"),
) -> None:
    """The process target: run the mission, report through ``queue``, always end with ("end", ...)."""
    threading.Thread(
        target=watch_server, args=(server_pid,), daemon=True, name="watch-server"
    ).start()
    with contextlib.suppress(OSError):
        os.nice(WORKER_NICENESS)  # the API process keeps priority: requests stay fast under load
    try:
        _run(mission_id, request, library, ws_rate, queue, cancel, wall_limit)
    except Exception as exc:  # report, never die silently (and never with a server path)
        queue.put(("end", "failed", f"server error ({type(exc).__name__})", None))


def _run(
    mission_id: str,
    request: dict[str, Any],
    library: Library,
    ws_rate: float,
    queue: Queue[Message],
    cancel: Event,
    wall_limit: float,
) -> None:
    begun = time.perf_counter()  # the wall-clock limit counts planning too
    spec = MissionSpec.model_validate(request)
    queue.put(("transition", "planning", "", None))
    try:
        runner = MissionRunner(spec, library, mission_id=mission_id.replace("-", ""), cancel=cancel)
    except MissionError as exc:
        queue.put(("end", "failed", str(exc), None))
        return
    started = time.perf_counter()
    last_state = last_save = 0.0
    versions, events_sent, executing = 0, 0, False
    period = 1.0 / ws_rate
    while True:
        done = runner.step()
        ctx = runner.ctx
        if ctx.plan_version > versions:
            for message in plan_messages(runner, versions):
                queue.put(message)
            versions = ctx.plan_version
        for event in ctx.events[events_sent:]:
            queue.put(("frame", {"type": "event", **event}))
        events_sent = len(ctx.events)
        if done:
            break
        if time.perf_counter() - begun > wall_limit:
            runner.abort("failed", f"wall-clock limit: {wall_limit:g} s reached")
            break
        if not executing:
            queue.put(("transition", "executing", "", mission_state(runner)))
            executing = True
        wall = time.perf_counter()
        if wall - last_state >= period:
            queue.put(("frame", {"type": "state", **runner.snapshot()}))
            last_state = wall
        if wall - last_save >= STATE_SAVE_SECONDS:
            queue.put(("state", mission_state(runner)))
            last_save = wall
        if spec.speed > 0:  # pace model time against the wall clock
            ahead = ctx.t / spec.speed - (time.perf_counter() - started)
            if ahead > 0:
                cancel.wait(min(ahead, PACE_SLICE))
    queue.put(("trajectory", runner.trajectory()))
    queue.put(("end", runner.status, runner.reason, mission_state(runner)))
