"""The supervisor: runs queued missions concurrently (bounded), off the event loop.

Each running mission owns a worker thread that steps its ``MissionRunner`` one control interval
at a time, paces it (real time × speed, or as fast as possible), writes every transition, plan
and replan to the store *before* broadcasting it, and always ends in a terminal state.
"""

from __future__ import annotations

import asyncio
import logging
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from typing import Any

from app.executor.runner import MissionError, MissionRunner
from app.missions.spec import MissionSpec
from app.service.hub import Frame, Hub
from app.service.metrics import Metrics
from app.settings import Settings
from app.store.repo import Store
from primitives.library import Library
from primitives.steering import Steering
from sim.obstacles import Circle

log = logging.getLogger("screwsnake.supervisor")
STATE_SAVE_SECONDS = 1.0  # wall seconds between state writes of a running mission


def reactive_actions(plan: list[str], goal: tuple[float, float] | None) -> list[dict[str, Any]]:
    """The reactive plan's move(angle, shape) actions, as the plan resource lists them."""
    out = []
    for text in plan:
        name, shape = text.strip("()").split()
        angle = {"po1": 0.0, "po2": 90.0, "po3": -90.0}[name]
        out.append(
            {
                "name": name,
                "args": [shape],
                "heading": angle,
                "shape": shape,
                "target": None if goal is None else {"x": goal[0], "y": goal[1]},
                "grounding": {
                    "method": "steering",
                    "primitives": [],
                    "relative_to": "goal direction",
                },
            }
        )
    return out


def mission_state(runner: MissionRunner) -> dict[str, Any]:
    ctx = runner.ctx
    x, y, psi = ctx.pose
    return {
        "goals": [g.to_dict() for g in ctx.goals],
        "pose": {"x": x, "y": y, "psi": psi, "joints": [float(j) for j in ctx.sim.joints]},
        "model_time": round(ctx.t, 3),
        "collisions": ctx.sim.collisions,
        "replans": sum(1 for r in ctx.replans if r.trigger != "initial"),
        "shape": ctx.shape,
        "action": ctx.current_action,
        "sensed": [
            [round(o.x, 3), round(o.y, 3)] for o in ctx.knowledge.sensed if isinstance(o, Circle)
        ],
    }


class Supervisor:
    def __init__(
        self, store: Store, library: Library, hub: Hub, settings: Settings, metrics: Metrics
    ) -> None:
        self.store, self.library, self.hub, self.settings, self.metrics = (
            store,
            library,
            hub,
            settings,
            metrics,
        )
        self.steering = Steering(library)
        self.pool = ThreadPoolExecutor(settings.max_running, thread_name_prefix="mission")
        self.cancels: dict[str, threading.Event] = {}
        self.running: set[str] = set()
        self.shutting_down = threading.Event()
        self.loop: asyncio.AbstractEventLoop | None = None
        self.queue: asyncio.Queue[str] | None = None
        self.slots: asyncio.Semaphore | None = None
        self.tasks: set[asyncio.Task[Any]] = set()

    # -- lifecycle (event loop side) ----------------------------------------------------------
    async def start(self) -> None:
        self.loop = asyncio.get_running_loop()
        self.queue = asyncio.Queue()
        self.slots = asyncio.Semaphore(self.settings.max_running)
        for mission_id in self.store.interrupt_unfinished():
            log.warning(
                "mission %s was running when the server stopped: failed/interrupted", mission_id
            )
        self.store.interrupt_jobs()
        for mission_id in self.store.queued():
            self.submit(mission_id)
        self._keep(asyncio.create_task(self._dispatch()))

    async def stop(self) -> None:
        self.shutting_down.set()
        for event in self.cancels.values():
            event.set()
        for task in list(self.tasks):
            task.cancel()
        await asyncio.get_running_loop().run_in_executor(None, self.pool.shutdown, True)

    def _keep(self, task: asyncio.Task[Any]) -> None:
        self.tasks.add(task)  # a held reference: an unreferenced task can vanish
        task.add_done_callback(self.tasks.discard)

    def submit(self, mission_id: str) -> None:
        assert self.queue is not None
        self.cancels.setdefault(mission_id, threading.Event())
        self.queue.put_nowait(mission_id)
        self.metrics.queued.inc()

    async def _dispatch(self) -> None:
        assert self.queue is not None and self.slots is not None and self.loop is not None
        while True:
            mission_id = await self.queue.get()
            self.metrics.queued.dec()
            await self.slots.acquire()
            self._keep(asyncio.create_task(self._run(mission_id)))

    async def _run(self, mission_id: str) -> None:
        assert self.slots is not None and self.loop is not None
        try:
            await self.loop.run_in_executor(self.pool, self._work, mission_id)
        except Exception:  # the worker itself already recorded the failure
            log.exception("mission %s worker crashed", mission_id)
        finally:
            self.slots.release()

    def cancel(self, mission_id: str) -> bool:
        """Ask a mission to stop: queued ones end now, running ones within one interval."""
        row = self.store.get_mission(mission_id)
        if row is None or row.status in ("succeeded", "failed", "cancelled"):
            return False
        if mission_id in self.running:
            if self.store.transition(mission_id, "cancelling", "cancel requested"):
                self._publish(
                    mission_id, {"type": "event", "kind": "status", "status": "cancelling"}
                )
            self.cancels.setdefault(mission_id, threading.Event()).set()
            return True
        self.cancels.setdefault(mission_id, threading.Event()).set()
        if self.store.transition(mission_id, "cancelled", "cancelled before it started"):
            self.metrics.finished.labels("cancelled").inc()
            self._publish(
                mission_id,
                {"type": "end", "status": "cancelled", "reason": "cancelled before it started"},
            )
        return True

    # -- worker thread side --------------------------------------------------------------------
    def _publish(self, mission_id: str, frame: Frame) -> None:
        if self.loop is not None and not self.loop.is_closed():
            self.loop.call_soon_threadsafe(self.hub.publish, mission_id, frame)

    def _transition(
        self, mission_id: str, status: str, reason: str = "", state: dict[str, Any] | None = None
    ) -> None:
        if self.store.transition(mission_id, status, reason, state):  # written before broadcast
            self._publish(
                mission_id, {"type": "event", "kind": "status", "status": status, "reason": reason}
            )

    def _work(self, mission_id: str) -> None:
        row = self.store.get_mission(mission_id)
        cancel = self.cancels.setdefault(mission_id, threading.Event())
        if row is None or row.status != "queued" or cancel.is_set():
            return
        self.running.add(mission_id)
        self.metrics.running.inc()
        try:
            self._execute(mission_id, MissionSpec.model_validate(row.request), cancel)
        except Exception as exc:  # never leave a mission active: fail it with the reason
            log.exception("mission %s failed unexpectedly", mission_id)
            self._end(mission_id, "failed", f"internal error: {type(exc).__name__}: {exc}", None)
        finally:
            self.running.discard(mission_id)
            self.metrics.running.dec()

    def _execute(self, mission_id: str, spec: MissionSpec, cancel: threading.Event) -> None:
        self._transition(mission_id, "planning")
        try:
            runner = MissionRunner(
                spec,
                self.library,
                self.steering,
                mission_id=mission_id.replace("-", ""),
                cancel=cancel,
            )
        except MissionError as exc:
            self._end(mission_id, "failed", str(exc), None)
            return
        started = time.perf_counter()
        last_state, last_save = 0.0, 0.0
        versions, events_sent, executing = 0, 0, False
        period = 1.0 / self.settings.ws_rate
        while True:
            done = runner.step()
            ctx = runner.ctx
            if ctx.plan_version > versions:
                versions = self._new_plans(mission_id, runner, versions)
            for event in ctx.events[events_sent:]:
                self._publish(mission_id, {"type": "event", **event})
            events_sent = len(ctx.events)
            if done:
                break
            if not executing:
                self._transition(mission_id, "executing", state=mission_state(runner))
                executing = True
            wall = time.perf_counter()
            if wall - last_state >= period:
                self._publish(mission_id, {"type": "state", **runner.snapshot()})
                last_state = wall
            if wall - last_save >= STATE_SAVE_SECONDS:
                self.store.save_state(mission_id, mission_state(runner))
                last_save = wall
            if spec.speed > 0:  # pace model time against the wall clock
                ahead = ctx.t / spec.speed - (time.perf_counter() - started)
                if ahead > 0:
                    cancel.wait(ahead)
        status = runner.status
        reason = runner.reason
        if status == "cancelled" and self.shutting_down.is_set():
            status, reason = "failed", "interrupted (server shut down)"
        self.store.save_trajectory(mission_id, runner.trajectory())
        self._end(mission_id, status, reason, mission_state(runner))

    def _new_plans(self, mission_id: str, runner: MissionRunner, seen: int) -> int:
        ctx = runner.ctx
        for entry, record in zip(ctx.pddl[seen:], ctx.replans[seen:], strict=False):
            if (
                ctx.plan is not None
                and entry["version"] == ctx.plan_version
                and ctx.spec.planner.domain == "navigation"
            ):
                actions = [a.to_dict() for a in ctx.plan.actions]
            else:
                left = ctx.remaining_goals()
                goal = (ctx.goals[left[0]].x, ctx.goals[left[0]].y) if left else None
                actions = (
                    reactive_actions(entry["plan"], goal)
                    if ctx.spec.planner.domain == "reactive"
                    else []
                )
            self.store.add_plan(
                mission_id,
                entry["version"],
                ctx.spec.planner.domain,
                entry["domain"],
                entry["problem"],
                entry["plan"],
                actions,
            )
            if record.trigger != "initial":
                self.store.add_replan(mission_id, record.to_dict())
                self.metrics.replan_latency.observe(record.latency_ms / 1000)
                self._transition(mission_id, "replanning", record.trigger)
                self._transition(mission_id, "executing")
            self._publish(
                mission_id,
                {
                    "type": "plan",
                    "version": entry["version"],
                    "plan": entry["plan"],
                    "actions": actions,
                },
            )
        return ctx.plan_version

    def _end(self, mission_id: str, status: str, reason: str, state: dict[str, Any] | None) -> None:
        if self.store.transition(mission_id, status, reason, state):
            self.metrics.finished.labels(status).inc()
        row = self.store.get_mission(mission_id)
        final = row.status if row else status
        self._publish(
            mission_id, {"type": "end", "status": final, "reason": row.reason if row else reason}
        )
