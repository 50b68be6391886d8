"""Live updates of running missions, with one authoritative owner of their goals and obstacles.

The update routes used to read a mission's goals from the state its worker saves about once a
second and to send updates blind: five goals added in a row were all answered ``goal: 1``, caps
were passed by speed, a goal inside an obstacle added a moment before was accepted. Here the
server keeps, for each running mission, a ``LiveMission``: its goals (as posted, then as added
here, with what the worker reports of them: reached, removed), the known obstacles added live,
whether it is paused. Every update of a mission runs under that mission's own lock, in order:
it is checked against this account (caps, the last goal, pause twice), validated against the
mission's current world like a new mission (in the validation pool, off the event loop), then
sent to the worker and written into the account before the answer. The worker applies updates
in the order they were sent, so its indices are the ones answered; an update that no longer
applies when the worker gets it (the goal was reached meanwhile, the robot moved onto the new
obstacle) is refused there with an ``update`` event, never by ending the mission.
"""

from __future__ import annotations

import asyncio
import threading
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from anyio import to_thread

from app.missions.maps import StoredMap, referenced
from app.missions.spec import body_overlap, goal_misplaced, goal_out_of_reach
from app.missions.status import TERMINAL, MissionStatus
from app.service.messages import (
    AddGoal,
    AddObstacle,
    Ended,
    Pause,
    RemoveGoal,
    Resume,
    SaveState,
    Transition,
    Update,
    WorkerMessage,
    frames_of,
)
from app.service.validation import Validation
from app.settings import Settings, max_map_pixels, max_obstacles
from app.store.repo import Store
from primitives.shapes import shape_named
from sim.maps import load_raster
from sim.obstacles import obstacle_from_dict
from sim.robot import DEFAULT_GEOMETRY
from sim.world import Bounds

if TYPE_CHECKING:
    from app.service.supervisor import Supervisor

NO_PLANNER = "runs a chain of primitives: it has no planner to update (goals, obstacles)"


class Refused(Exception):
    """An update that is not applied: ``status`` (404, 409, 422) and why, naming ``field``."""

    def __init__(self, status: int, detail: str, field: str | None = None) -> None:
        super().__init__(detail)
        self.status, self.detail, self.field = status, detail, field


def goal_view(goal: dict[str, Any]) -> dict[str, Any]:
    """A goal as the mission resource shows it."""
    return {
        "x": goal["x"],
        "y": goal["y"],
        "tolerance": goal.get("tolerance", 0.1),
        "reached": bool(goal.get("reached", False)),
        "error": goal.get("error"),
        "reached_at": goal.get("reached_at"),
        "removed": bool(goal.get("removed", False)),
    }


@dataclass
class LiveMission:
    """The server's account of one running mission (see the module's docstring)."""

    mission_id: str
    request: dict[str, Any]
    goals: list[dict[str, Any]]
    obstacles: list[dict[str, Any]] = field(default_factory=list)  # added live, known
    paused: bool = False
    status: MissionStatus = MissionStatus.PLANNING
    stopping: str = ""  # why no update applies any more ("cancelling", "ended")
    pose: dict[str, Any] | None = None  # as last reported (x, y, psi, joints)
    guard: threading.Lock = field(default_factory=threading.Lock)  # the fields, from any thread
    turn: asyncio.Lock = field(default_factory=asyncio.Lock)  # one update at a time, in order
    maps: list[StoredMap] = field(default_factory=list)  # the mission's maps, in its order

    @classmethod
    def of(
        cls, mission_id: str, request: dict[str, Any], stored: dict[str, StoredMap] | None = None
    ) -> LiveMission:
        goals = [goal_view(g) for g in request.get("goals", [])]
        found = stored or {}
        maps = [found[i] for i in referenced(request) if i in found]
        return cls(mission_id, request, goals, maps=maps)

    @property
    def planner(self) -> bool:
        """Whether it plans (goals), not a manual chain of primitives."""
        return bool(self.request.get("goals"))

    def goals_now(self) -> list[dict[str, Any]]:
        with self.guard:
            return [dict(g) for g in self.goals]

    def observe(self, message: WorkerMessage) -> None:
        """What the worker reports (called for each of its messages, before they are relayed):
        goals reached, the robot's pose, its end."""
        with self.guard:
            for frame in frames_of(message):
                if frame.get("type") == "state" and isinstance(frame.get("pose"), dict):
                    self.pose = frame["pose"]
                elif frame.get("kind") == "goal_reached" and isinstance(frame.get("goal"), int):
                    index = frame["goal"]
                    if 0 <= index < len(self.goals):
                        goal = self.goals[index]
                        goal["reached"], goal["reached_at"] = True, frame.get("t")
                        goal["error"] = frame.get("error")
            if isinstance(message, SaveState | Transition | Ended) and message.state:
                self._merge(message.state)
            if isinstance(message, Ended):
                self.stopping = "ended"

    def _merge(self, state: dict[str, Any]) -> None:
        """The worker's goals (those it has: later additions are on their way to it)."""
        if isinstance(state.get("pose"), dict):
            self.pose = state["pose"]
        for goal, reported in zip(self.goals, state.get("goals") or [], strict=False):
            removed = goal["removed"] or bool(reported.get("removed"))
            goal.update(goal_view(reported), removed=removed)

    def world(self) -> tuple[dict[str, Any], list[dict[str, Any]]]:
        """The mission's bounds and obstacles now: posted (known and hidden), then added live."""
        with self.guard:
            posted = list(self.request.get("obstacles", []))
            return dict(self.request.get("bounds", {})), posted + list(self.obstacles)

    def body(self) -> tuple[tuple[float, float, float], list[float]]:
        """The robot's pose and joints as last reported (the start before any report)."""
        with self.guard:
            pose = self.pose
        if pose is None:
            start = self.request.get("start", {})
            pose = {**start, "joints": None}
        joints = pose.get("joints")
        if joints is None:
            joints = list(start_joints(self.request))
        return (float(pose.get("x", 0)), float(pose.get("y", 0)), float(pose.get("psi", 0))), [
            float(j) for j in joints
        ]


def start_joints(request: dict[str, Any]) -> tuple[float, ...]:
    """The joints a mission starts with (a library shape's, or the posted joint angles)."""
    shape = request.get("shape", "straight")
    if isinstance(shape, dict):
        return tuple(float(j) for j in shape["joints"])
    return shape_named(str(shape)).joints


# -- checks run in the validation pool (plain data in, a message or None out) ---------------------
def _bounds(bounds: dict[str, Any]) -> Bounds:
    return Bounds(
        float(bounds.get("xmin", -10.0)),
        float(bounds.get("xmax", 10.0)),
        float(bounds.get("ymin", -10.0)),
        float(bounds.get("ymax", 10.0)),
    )


def goal_problem(
    bounds: dict[str, Any],
    obstacles: list[dict[str, Any]],
    goal: dict[str, Any],
    maps: list[StoredMap] | None = None,
) -> str | None:
    """Why a goal cannot join this world (a posted mission's own checks: inside the bounds,
    outside every obstacle and occupied map cell, reachable by the tracked point); None when it
    can."""
    arena = _bounds(bounds)
    world = [obstacle_from_dict(o) for o in obstacles]
    rasters = [load_raster(m.image, m.params, max_map_pixels()) for m in maps or []]
    x, y, tolerance = float(goal["x"]), float(goal["y"]), float(goal["tolerance"])
    return goal_misplaced(arena, world, x, y, rasters=rasters) or goal_out_of_reach(
        arena, world, x, y, tolerance, rasters=rasters
    )


def obstacle_problem(
    bounds: dict[str, Any],
    obstacle: dict[str, Any],
    body: tuple[tuple[float, float, float], list[float]],
    goals: list[tuple[int, dict[str, Any]]],
) -> str | None:
    """Why a known obstacle cannot join this world: it overlaps the robot's body where it last
    was, or a goal still to reach would be inside it or out of the robot's reach; None if not."""
    arena = _bounds(bounds)
    new = [obstacle_from_dict(obstacle)]
    pose, joints = body
    if body_overlap(arena, new, pose, joints) is not None:
        return (
            "overlaps the robot's body (head and four units) where it last was "
            f"({pose[0]:.2f}, {pose[1]:.2f})"
        )
    for index, goal in goals:
        x, y, tolerance = float(goal["x"]), float(goal["y"]), float(goal["tolerance"])
        if goal_misplaced(arena, new, x, y) is not None:
            return f"covers goal {index}, not reached yet"
        if goal_out_of_reach(arena, new, x, y, tolerance) is not None:
            return (
                f"comes closer to goal {index} than the robot can reach "
                f"({DEFAULT_GEOMETRY.unit_radius:g} m around the tracked point, less 0.4 of the "
                "tolerance)"
            )
    return None


class LiveUpdates:
    """The live-update rules (the routes in ``app.api.updates`` only translate)."""

    def __init__(
        self, store: Store, supervisor: Supervisor, validation: Validation, settings: Settings
    ) -> None:
        self.store, self.supervisor = store, supervisor
        self.validation, self.settings = validation, settings

    async def _live(self, mission_id: str) -> LiveMission:
        """The running mission's account: 404 unknown, 409 ended, queued or cancelling."""
        live = self.supervisor.live.get(mission_id)
        if live is not None and not live.stopping:
            return live
        row = await to_thread.run_sync(self.store.get_mission, mission_id)
        if row is None:
            raise Refused(404, f"mission {mission_id} not found")
        if row.status in TERMINAL:
            raise Refused(409, f"mission {mission_id} already ended ({row.status})")
        if row.status in (MissionStatus.QUEUED, MissionStatus.CANCELLING):
            raise Refused(
                409, f"mission {mission_id} is {row.status}: only running missions update"
            )
        why = "ending" if live is not None else "starting"  # a moment either way
        raise Refused(409, f"mission {mission_id} is {why}: not running on a worker now")

    def _send(self, live: LiveMission, update: Update) -> None:
        """To the worker (after every check; under the mission's turn)."""
        if live.stopping or not self.supervisor.update(live.mission_id, update):
            raise Refused(409, f"mission {live.mission_id} is not running any more")

    @staticmethod
    def _planner(live: LiveMission) -> None:
        if not live.planner:
            raise Refused(409, f"mission {live.mission_id} {NO_PLANNER}")

    async def add_goal(self, mission_id: str, goal: dict[str, Any]) -> tuple[int, MissionStatus]:
        """Append a goal: its index (the next after those posted and added) and the status."""
        live = await self._live(mission_id)
        async with live.turn:
            self._planner(live)
            cap = self.settings.max_goals
            if len(live.goals) >= cap:
                raise Refused(
                    422,
                    f"goals: the mission has {len(live.goals)} goals, at most {cap} "
                    "(SCREWSNAKE_MAX_GOALS; removed goals count)",
                    "goals",
                )
            bounds, obstacles = live.world()
            problem = await self.validation.run(goal_problem, bounds, obstacles, goal, live.maps)
            if problem is not None:
                raise Refused(422, f"goal: {problem}", "body")
            index = len(live.goals)
            self._send(live, AddGoal(goal["x"], goal["y"], goal["tolerance"], index))
            with live.guard:
                live.goals.append(goal_view(goal))
            return index, live.status

    async def remove_goal(self, mission_id: str, index: int) -> MissionStatus:
        """Stop pursuing goal ``index``; never the last one not reached (cancel instead)."""
        live = await self._live(mission_id)
        async with live.turn:
            self._planner(live)
            goals = live.goals_now()
            if index >= len(goals):
                raise Refused(
                    404, f"mission {mission_id} has no goal {index} (0..{len(goals) - 1})"
                )
            if goals[index]["reached"]:
                raise Refused(409, f"goal {index} was already reached")
            if goals[index]["removed"]:
                raise Refused(409, f"goal {index} was already removed")
            left = [i for i, g in enumerate(goals) if not (g["reached"] or g["removed"])]
            if left == [index]:
                raise Refused(
                    409,
                    f"goal {index} is the last goal not reached: cancel the mission instead",
                )
            self._send(live, RemoveGoal(index))
            with live.guard:
                live.goals[index]["removed"] = True
            return live.status

    async def add_obstacle(
        self, mission_id: str, obstacle: dict[str, Any]
    ) -> tuple[int, MissionStatus]:
        """Add a known obstacle: its index among the mission's obstacles (posted, then live)."""
        live = await self._live(mission_id)
        async with live.turn:
            self._planner(live)
            cap = self.settings.max_live_obstacles
            if len(live.obstacles) >= cap:
                raise Refused(
                    422,
                    f"obstacles: {len(live.obstacles)} obstacles were added to this mission, at "
                    f"most {cap} (SCREWSNAKE_MAX_LIVE_OBSTACLES)",
                    "obstacles",
                )
            bounds, obstacles = live.world()
            if len(obstacles) >= max_obstacles():  # as many as a posted mission may list
                raise Refused(
                    422,
                    f"obstacles: the mission has {len(obstacles)} obstacles, at most "
                    f"{max_obstacles()} (SCREWSNAKE_MAX_OBSTACLES)",
                    "obstacles",
                )
            open_goals = [
                (i, g) for i, g in enumerate(live.goals_now()) if not (g["reached"] or g["removed"])
            ]
            problem = await self.validation.run(
                obstacle_problem, bounds, obstacle, live.body(), open_goals
            )
            if problem is not None:
                raise Refused(422, f"obstacle: {problem}", "obstacle")
            index = len(obstacles)
            self._send(live, AddObstacle(obstacle))
            with live.guard:
                live.obstacles.append(obstacle)
            return index, live.status

    async def pause(self, mission_id: str) -> MissionStatus:
        live = await self._live(mission_id)
        async with live.turn:
            if live.paused:
                raise Refused(409, f"mission {mission_id} is already paused")
            self._send(live, Pause())
            live.paused = True
            return live.status

    async def resume(self, mission_id: str) -> MissionStatus:
        live = await self._live(mission_id)
        async with live.turn:
            if not live.paused:
                raise Refused(409, f"mission {mission_id} is not paused ({live.status})")
            self._send(live, Resume())
            live.paused = False
            return live.status
