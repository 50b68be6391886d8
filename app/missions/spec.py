"""A mission as data (docs/mission-format.md): start, shape, goals, obstacles, events, planner, limits.

Validated strictly: finite numbers only, bounded lists, coordinates inside the arena, goals and
start outside obstacles, unknown fields rejected. The same model backs mission files and
``POST /missions``.
"""

from __future__ import annotations

import json
from collections.abc import Container, Sequence
from pathlib import Path
from typing import Annotated, Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import (
    BaseModel,
    Field,
    PrivateAttr,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_validator,
)
from pydantic import Strict as StrictNumber  # no bool or string coerced into a number

from app.missions.chain import ChainStep
from app.missions.maps import MapEntry, MapsNeeded, resolve, union_extent
from app.missions.parts import (
    ARRIVE_FRACTION,
    MAX_CHAIN,
    MAX_EVENTS,
    MAX_GOALS,
    MAX_MAPS,
    BoundsSpec,
    Coord,
    DropoutEvent,
    EventSpec,
    ExpectSpec,
    GoalSpec,
    Joint,
    JointsShape,
    ObstacleSpec,
    PlannerSpec,
    Pose,
    SensorSpec,
    Strict,
    _range_sensor,
    _xy,
)
from app.settings import max_obstacles
from primitives.coverage import covers
from primitives.shapes import FIXED_SHAPES, SHAPES, is_shape, shape_named
from sim.obstacles import Obstacle, obstacle_from_dict
from sim.raster import OccupancyRaster
from sim.robot import DEFAULT_GEOMETRY
from sim.world import Bounds, World, footprint

__all__ = [  # the pieces a caller may take from here as well
    "ARRIVE_FRACTION",
    "ChainStep",
    "Coord",
    "DropoutEvent",
    "GoalSpec",
    "Joint",
    "MapsNeeded",
    "MissionFileError",
    "MissionSpec",
    "ObstacleSpec",
    "Pose",
    "body_overlap",
    "goal_misplaced",
    "goal_out_of_reach",
    "load_mission",
    "parse_mission",
]


def obstacle_boxes(obstacles: Sequence[Obstacle]) -> NDArray[np.float64]:
    """The obstacles' bounding boxes ``[N, (x0, y0, x1, y1)]``: which obstacles can matter at
    a point is one vectorised test, not a loop over all of them (thousands)."""
    return np.array([o.bounding_box() for o in obstacles], dtype=float).reshape(-1, 4)


def _near(boxes: NDArray[np.float64], x: float, y: float, reach: float) -> list[int]:
    """The obstacles whose boxes come within ``reach`` of (x, y), in order."""
    close = (
        (boxes[:, 0] <= x + reach)
        & (boxes[:, 2] >= x - reach)
        & (boxes[:, 1] <= y + reach)
        & (boxes[:, 3] >= y - reach)
    )
    return [int(j) for j in np.flatnonzero(close)]


def goal_misplaced(
    bounds: Bounds,
    obstacles: Sequence[Obstacle],
    x: float,
    y: float,
    boxes: NDArray[np.float64] | None = None,
    rasters: Sequence[OccupancyRaster] = (),
) -> str | None:
    """Why a goal at (x, y) is where no robot can be: ``outside the bounds``, ``inside
    obstacles.j`` or ``inside an occupied cell of maps.k``; None when it is not. (A posted
    mission's goals and a goal added live; ``boxes``: ``obstacle_boxes`` if at hand.)"""
    if not bounds.contains(x, y):
        return "outside the bounds"
    boxes = obstacle_boxes(obstacles) if boxes is None else boxes
    for j in _near(boxes, x, y, 0.0):
        if obstacles[j].contains(_xy(x, y))[0]:
            return f"inside obstacles.{j}"
    for k, raster in enumerate(rasters):
        if raster.occupied_at(_xy(x, y))[0]:
            return f"inside an occupied cell of maps.{k}"
    return None


def goal_out_of_reach(
    bounds: Bounds,
    obstacles: Sequence[Obstacle],
    x: float,
    y: float,
    tolerance: float,
    boxes: NDArray[np.float64] | None = None,
    rasters: Sequence[OccupancyRaster] = (),
) -> str | None:
    """Why the tracked point cannot come near enough to a goal: the first unit's capsule
    (radius r) is centred on the tracked point's axis, so the point can get no closer than r to
    anything, and a goal counts within 0.4 of its tolerance. None when it can."""
    r = DEFAULT_GEOMETRY.unit_radius
    need = r - ARRIVE_FRACTION * tolerance
    p = _xy(x, y)
    far = f"than the robot can reach ({r:g} m around the tracked point, less 0.4 of the tolerance)"
    if float(bounds.wall_clearance(p)[0]) < need:
        return f"closer to a wall {far}"
    boxes = obstacle_boxes(obstacles) if boxes is None else boxes
    for j in _near(boxes, x, y, max(need, 0.0)):
        if float(obstacles[j].segment_clearance(p, p)[0]) < need:
            return f"closer to obstacles.{j} {far}"
    for k, raster in enumerate(rasters):
        if need > 0 and float(raster.point_distance(p, need)[0]) < need:
            return f"closer to an occupied cell of maps.{k} {far}"
    return None


def body_overlap(
    bounds: Bounds,
    obstacles: Sequence[Obstacle],
    pose: tuple[float, float, float],
    joints: Sequence[float],
    rasters: Sequence[OccupancyRaster] = (),
) -> str | None:
    """What the robot's whole body (head and four units) at ``pose`` overlaps: ``a wall``,
    ``obstacles.j`` or ``maps.k``; None when it is clear."""
    contact = World(bounds, tuple(obstacles), tuple(rasters)).contact(
        footprint(np.asarray(pose, dtype=float), np.asarray(joints, dtype=float))
    )
    if contact is None:
        return None
    if contact.obstacle < 0:
        return "a wall"
    if contact.obstacle >= len(obstacles):
        return f"an occupied cell of maps.{contact.obstacle - len(obstacles)}"
    return f"obstacles.{contact.obstacle}"


class MissionSpec(BaseModel):
    """A mission: goals (or a chain of primitives) in an arena with obstacles and events."""

    model_config = Strict.model_config  # as strict as its pieces

    # No NUL: PostgreSQL cannot store it in a text column.
    name: Annotated[str, Field(max_length=120, pattern=r"^[^\x00]*$")] = "mission"
    """a name for people"""
    start: Pose = Pose()
    """the start pose"""
    shape: str | JointsShape = "straight"
    """the start body shape: a library shape's name, or joint angles"""
    goals: Annotated[list[GoalSpec], Field(max_length=MAX_GOALS)] = []
    """the goals; their indices (as posted) name them in results and live updates"""
    order: Literal["given", "any"] = "given"
    """visit the goals in the given order, or in any order (the planner picks)"""
    obstacles: list[ObstacleSpec] = []
    """obstacles, known to the planner or hidden (at most SCREWSNAKE_MAX_OBSTACLES of them,
    10,000 by default)"""
    maps: Annotated[list[MapEntry], Field(max_length=MAX_MAPS)] = []
    """occupancy-grid maps in ROS map_server's format (inline, or stored by POST /maps and
    named by id): known ones are the planner's static layer, hidden ones ground truth to sense"""
    bounds: BoundsSpec = BoundsSpec()
    """the arena's walls; with maps and no bounds, the union of the maps' extents"""
    events: Annotated[list[EventSpec], Field(max_length=MAX_EVENTS)] = []
    """things that happen at model times: deformations, sensor dropouts"""
    planner: PlannerSpec = PlannerSpec()
    """how to plan"""
    sensors: SensorSpec = SensorSpec()
    """the range sensors"""
    chain: Annotated[list[ChainStep], Field(max_length=MAX_CHAIN)] = []
    """instead of goals: primitives run one after the other"""
    speed: Annotated[float, StrictNumber(), Field(allow_inf_nan=False, ge=0, le=10_000)] = 0.0
    """model seconds per wall second; 0 runs as fast as possible"""
    seed: Annotated[int, Field(ge=0, le=2**32 - 1)] = 0
    """seeds the sensor noise: a mission and seed run the same every time"""
    time_limit: Annotated[float, StrictNumber(), Field(allow_inf_nan=False, gt=0, le=36_000)] = (
        1800.0
    )
    """the mission fails after this long, model seconds"""
    max_replans: Annotated[int, Field(ge=0, le=10_000)] = 500
    """the mission fails after this many replans"""
    expect: Annotated[
        ExpectSpec | None, Field(description="the expected outcome (benchmarks); not used to run")
    ] = None

    @field_validator("obstacles")
    @classmethod
    def _obstacle_cap(cls, obstacles: list[ObstacleSpec]) -> list[ObstacleSpec]:
        cap = max_obstacles()
        if len(obstacles) > cap:
            raise ValueError(
                f"at most {cap} obstacles (SCREWSNAKE_MAX_OBSTACLES), got {len(obstacles)}"
            )
        return obstacles

    # Set once this instance passed ``_consistent``: an instance validated elsewhere (a
    # request's body in a validation process, ``app.service.validation``) and handed over as
    # it is is not checked again (pydantic runs after-validators on instances too).
    _checked: bool = PrivateAttr(default=False)
    # The maps decoded (raster, known), in order: set by ``_consistent``.
    _rasters: list[tuple[OccupancyRaster, bool]] = PrivateAttr(default_factory=list)

    @model_validator(mode="after")
    def _consistent(self, info: ValidationInfo) -> MissionSpec:
        if self._checked:
            return self
        self._rasters = resolve(self.maps, info.context) if self.maps else []
        if self._rasters and "bounds" not in self.model_fields_set:
            xmin, xmax, ymin, ymax = union_extent([r for r, _ in self._rasters])
            try:
                arena = BoundsSpec(xmin=xmin, xmax=xmax, ymin=ymin, ymax=ymax)
            except ValidationError as exc:
                why = exc.errors()[0]["msg"].removeprefix("Value error, ")
                raise ValueError(f"bounds: the maps' union as the arena: {why}") from exc
            # The model is frozen; the default arena is filled in once, while validating.
            self.__dict__["bounds"] = arena
        if not self.goals and not self.chain:
            raise ValueError("goals: give at least one goal, or a chain of primitives")
        if self.goals and self.chain:
            raise ValueError("chain: give goals or a chain of primitives, not both")
        if isinstance(self.shape, str) and not is_shape(self.shape):
            raise ValueError(
                f"shape: unknown {self.shape!r}; known: {', '.join(SHAPES)}, a learned shape's "
                'name, or {"joints": [...]}'
            )
        limit = DEFAULT_GEOMETRY.max_joint_angle
        joints = self.start_joints()
        if max(abs(v) for v in joints) > limit:
            raise ValueError(
                f"shape.joints: {list(joints)} is outside the joint limits (±{limit:.2f} rad)"
            )
        # A lattice planner learns a shape it lacks; the paper's moves and chains blend the
        # paper primitives of library shapes, so their shape must be such a blend.
        lattice = bool(self.goals) and self.planner.domain == "navigation"
        named = isinstance(self.shape, str) and self.shape in SHAPES
        if not (lattice or named) and covers(joints, FIXED_SHAPES).kind == "none":
            raise ValueError(
                f"shape.joints: {list(joints)} is a shape the library does not cover "
                f"(no joint-wise match within 0.15 rad of, nor blend of, {', '.join(FIXED_SHAPES)})"
            )
        for i, step in enumerate(self.chain):
            name = step.until.sensor
            if name is not None and not _range_sensor(name, self.sensors.ring):
                raise ValueError(
                    f"chain.{i}.until.sensor: no range sensor {name!r} (ir, "
                    f"ring0..ring{self.sensors.ring - 1})"
                )
        for i, event in enumerate(self.events):
            if isinstance(event, DropoutEvent):
                for name in event.sensors:
                    if name.startswith("ring") and int(name[4:]) >= self.sensors.ring:
                        raise ValueError(f"events.{i}.sensors: no sensor {name!r}")
        bounds = self.bounds.bounds()
        obstacles = self.world_obstacles()
        boxes = obstacle_boxes(obstacles)
        rasters = [r for r, _ in self._rasters]
        if not bounds.contains(self.start.x, self.start.y):
            raise ValueError("start: outside the bounds")
        for i, g in enumerate(self.goals):
            misplaced = goal_misplaced(bounds, obstacles, g.x, g.y, boxes, rasters)
            if misplaced is not None:
                raise ValueError(f"goals.{i}: {misplaced}")
        for j in _near(boxes, self.start.x, self.start.y, 0.0):
            if obstacles[j].contains(_xy(self.start.x, self.start.y))[0]:
                raise ValueError(f"start: inside obstacles.{j}")
        for k, raster in enumerate(rasters):
            if raster.occupied_at(_xy(self.start.x, self.start.y))[0]:
                raise ValueError(f"start: inside an occupied cell of maps.{k}")
        self._body_fits(bounds, obstacles, boxes, rasters)
        self._checked = True
        return self

    def _body_fits(
        self,
        bounds: Bounds,
        obstacles: list[Obstacle],
        boxes: NDArray[np.float64],
        rasters: list[OccupancyRaster],
    ) -> None:
        """The whole start body clear, and every goal reachable by the tracked point."""
        start = (self.start.x, self.start.y, self.start.psi)
        overlap = body_overlap(bounds, obstacles, start, self.start_joints(), rasters)
        if overlap is not None:
            raise ValueError(f"start: the robot's body (head and four units) overlaps {overlap}")
        for i, g in enumerate(self.goals):
            unreachable = goal_out_of_reach(
                bounds, obstacles, g.x, g.y, g.tolerance, boxes, rasters
            )
            if unreachable is not None:
                raise ValueError(f"goals.{i}: {unreachable}")

    def world_maps(self) -> list[tuple[OccupancyRaster, bool]]:
        """The mission's maps decoded, each with whether it is known (after validation)."""
        return list(self._rasters)

    def unknown_primitive(self, known: Container[str]) -> tuple[int, str] | None:
        """The first chain step naming a primitive that is not in ``known``: (step, name)."""
        for i, step in enumerate(self.chain):
            names = [step.primitive] if step.primitive else []
            names += list(step.interpolate.from_) if step.interpolate else []
            for name in names:
                if name not in known:
                    return i, name
        return None

    def world_obstacles(self) -> list[Obstacle]:
        return [obstacle_from_dict(o.model_dump()) for o in self.obstacles]

    def start_joints(self) -> tuple[float, float, float]:
        if isinstance(self.shape, JointsShape):
            return self.shape.joints
        return shape_named(self.shape).joints

    def shape_name(self) -> str:
        return self.shape if isinstance(self.shape, str) else "custom"


class MissionFileError(ValueError):
    """A mission file that cannot be used, with the field and the reason."""


def load_mission(path: Path, maps: Sequence[dict[str, object]] = ()) -> MissionSpec:
    """A mission file, with ``maps`` (inline maps, e.g. the CLI's ``--map``) after its own."""
    try:
        text = path.read_text()
    except OSError as exc:
        raise MissionFileError(f"{path}: cannot read ({exc.strerror})") from exc
    return parse_mission(text, str(path), maps)


def parse_mission(
    text: str, source: str = "mission", maps: Sequence[dict[str, object]] = ()
) -> MissionSpec:
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise MissionFileError(
            f"{source}: not valid JSON ({exc.msg} at line {exc.lineno})"
        ) from exc
    if maps and isinstance(data, dict):
        own = data.get("maps")
        data["maps"] = [*(own if isinstance(own, list) else []), *maps]
    try:
        return MissionSpec.model_validate(data)
    except MapsNeeded as exc:
        raise MissionFileError(
            f"{source}: maps: stored maps ({exc}) are the service's: give the map's YAML "
            "instead (screwsnake mission FILE --map office.yaml)"
        ) from exc
    except ValidationError as exc:
        first = exc.errors()[0]
        loc = first["loc"]
        # The events union's tag ("deform", "dropout") is not a field: events.0.joints, as before.
        where = ".".join(str(p) for i, p in enumerate(loc) if not (i == 2 and loc[0] == "events"))
        msg = first["msg"]
        if not where and msg.startswith("Value error, "):  # a model-level check names its field
            msg = msg.removeprefix("Value error, ")
            where, _, msg = msg.partition(": ")
        where = where or "mission"
        raise MissionFileError(f"{source}: {where}: {msg}") from exc
