"""A mission as data (DESIGN §10): start, shape, goals, obstacles, events, planner, limits.

Validated strictly: finite numbers only, bounded lists, coordinates inside the arena, goals and
start outside obstacles, unknown fields rejected. The same model backs mission files and
``POST /missions``.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Container
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    field_validator,
    model_validator,
)
from pydantic import Strict as StrictNumber  # no bool or string coerced into a number

from domain.lattice import LatticeSettings
from primitives.coverage import covers
from primitives.shapes import FIXED_SHAPES, SHAPES, shape_named
from sim.obstacles import Obstacle, obstacle_from_dict
from sim.robot import DEFAULT_GEOMETRY
from sim.world import Bounds, World, footprint

ARRIVE_FRACTION = 0.4  # a goal is marked reached within this fraction of its tolerance

MAX_GOALS = 50
MAX_OBSTACLES = 200
MAX_EVENTS = 20
MAX_CHAIN = 50
ARENA_LIMIT = 500.0  # metres from the origin
MAX_ARENA_CELLS = 1_000_000  # lattice cells: bounds planning memory and each distance map's time
Coord = Annotated[
    float, StrictNumber(), Field(allow_inf_nan=False, ge=-ARENA_LIMIT, le=ARENA_LIMIT)
]
Angle = Annotated[float, StrictNumber(), Field(allow_inf_nan=False, ge=-100.0, le=100.0)]
Joint = Annotated[
    float, StrictNumber(), Field(allow_inf_nan=False, ge=-math.pi / 2, le=math.pi / 2)
]
Positive = Annotated[float, StrictNumber(), Field(allow_inf_nan=False, gt=0)]


class Strict(BaseModel):
    # Attribute docstrings are the fields' descriptions (units included) in the OpenAPI schema.
    model_config = ConfigDict(extra="forbid", frozen=True, use_attribute_docstrings=True)


class Pose(Strict):
    """A pose of the robot's tracked point (the head) in the world frame."""

    x: Coord = 0.0
    """x, metres"""
    y: Coord = 0.0
    """y, metres"""
    psi: Angle = 0.0
    """heading ψ of the head, radians counter-clockwise from +x (the body trails behind)"""


class Point(Strict):
    """A point in the world frame."""

    x: Coord
    """x, metres"""
    y: Coord
    """y, metres"""


class GoalSpec(Strict):
    """A goal for the tracked point (the head)."""

    x: Coord
    """goal x, metres (world frame)"""
    y: Coord
    """goal y, metres (world frame)"""
    tolerance: Annotated[float, StrictNumber(), Field(allow_inf_nan=False, gt=0, le=5.0)] = 0.1
    """metres: the goal counts as reached within 0.4 of this distance"""


class JointsShape(Strict):
    """A body shape given by its joint angles (it must match a library shape)."""

    joints: tuple[Joint, Joint, Joint]
    """joint angles φ1..φ3, radians (±π/2)"""


class CircleSpec(Strict):
    """A circular obstacle."""

    type: Literal["circle"]
    """the obstacle kind"""
    x: Coord
    """centre x, metres"""
    y: Coord
    """centre y, metres"""
    radius: Annotated[float, StrictNumber(), Field(allow_inf_nan=False, gt=0, le=100)]
    """metres"""
    known: bool = True
    """known to the planner from the start; false: hidden, found by the sensors"""


class RectangleSpec(Strict):
    """A (rotated) rectangular obstacle."""

    type: Literal["rectangle"]
    """the obstacle kind"""
    x: Coord
    """centre x, metres"""
    y: Coord
    """centre y, metres"""
    width: Annotated[float, StrictNumber(), Field(allow_inf_nan=False, gt=0, le=1000)]
    """extent along its own x axis, metres"""
    height: Annotated[float, StrictNumber(), Field(allow_inf_nan=False, gt=0, le=1000)]
    """extent along its own y axis, metres"""
    angle: Angle = 0.0
    """rotation about its centre, radians counter-clockwise"""
    known: bool = True
    """known to the planner from the start; false: hidden, found by the sensors"""


class PolygonSpec(Strict):
    """A polygonal obstacle."""

    type: Literal["polygon"]
    """the obstacle kind"""
    points: Annotated[list[tuple[Coord, Coord]], Field(min_length=3, max_length=64)]
    """vertices [x, y] in order, metres"""
    known: bool = True
    """known to the planner from the start; false: hidden, found by the sensors"""


ObstacleSpec = Annotated[CircleSpec | RectangleSpec | PolygonSpec, Field(discriminator="type")]


class BoundsSpec(Strict):
    """The arena: walls on all four sides."""

    xmin: Coord = -10.0
    """west wall, metres"""
    xmax: Coord = 10.0
    """east wall, metres"""
    ymin: Coord = -10.0
    """south wall, metres"""
    ymax: Coord = 10.0
    """north wall, metres"""

    @model_validator(mode="after")
    def _ordered(self) -> BoundsSpec:
        if self.xmin >= self.xmax or self.ymin >= self.ymax:
            raise ValueError("need xmin < xmax and ymin < ymax")
        r = LatticeSettings().resolution
        cells = math.ceil((self.xmax - self.xmin) / r) * math.ceil((self.ymax - self.ymin) / r)
        if cells > MAX_ARENA_CELLS:
            raise ValueError(
                f"the arena has {cells} planning cells of {r:g} m; at most {MAX_ARENA_CELLS} "
                "(e.g. 50 m x 50 m): each planning map covers the whole arena"
            )
        return self

    def bounds(self) -> Bounds:
        return Bounds(self.xmin, self.xmax, self.ymin, self.ymax)


class DeformEvent(Strict):
    """At ``t`` the body is forced into other joint angles (and holds them)."""

    t: Annotated[float, StrictNumber(), Field(allow_inf_nan=False, ge=0, le=1e6)]
    """when, model seconds"""
    type: Literal["deform"]
    """the event kind"""
    joints: tuple[Joint, Joint, Joint]
    """the forced joint angles φ1..φ3, radians"""


class DropoutEvent(Strict):
    """From ``t`` for ``duration`` model seconds the named sensors read nothing (data model only)."""

    t: Annotated[
        float,
        StrictNumber(),
        Field(allow_inf_nan=False, ge=0, le=1e6, description="start, model s"),
    ]
    type: Literal["dropout"]
    """the event kind"""
    sensors: Annotated[
        list[str],
        Field(
            min_length=1,
            max_length=64,
            description='sensors that go silent: "ir", "ring0".."ring{N-1}" or "joints"',
        ),
    ]
    duration: Annotated[
        float,
        StrictNumber(),
        Field(allow_inf_nan=False, gt=0, le=1e6, description="how long, model s"),
    ]

    @field_validator("sensors")
    @classmethod
    def _names(cls, sensors: list[str]) -> list[str]:
        for name in sensors:
            if name not in ("ir", "joints") and not _RING_NAME.fullmatch(name):
                raise ValueError(f"unknown sensor {name!r} (ir, ring0..ring{{N-1}}, joints)")
        return sensors


_RING_NAME = re.compile(r"ring(0|[1-9][0-9]?)")
EventSpec = Annotated[DeformEvent | DropoutEvent, Field(discriminator="type")]


class ExpectSpec(Strict):
    """What a benchmark mission should end with; the runner ignores it."""

    status: Annotated[
        Literal["succeeded", "failed", "cancelled"], Field(description="expected terminal status")
    ]
    reason: Annotated[
        str | None,
        Field(max_length=200, description="a substring of the expected terminal reason"),
    ] = None
    fast: Annotated[
        bool, Field(description="cheap enough (< ~5 s wall) for the test suite to run it")
    ] = False


class PlannerSpec(Strict):
    """How the mission plans."""

    domain: Literal["navigation", "reactive"] = "navigation"
    """navigation: a state lattice over the library's primitives; reactive: the paper's
    Table 3 domain"""
    search: Literal["gbf", "astar", "wastar", "ehs", "bfs"] = "gbf"
    """pyperplan's search algorithm"""
    heuristic: Annotated[
        Literal["lattice", "roadmap", "hff", "hadd", "hmax", "lmcut", "landmark", "blind"],
        Field(
            description=(
                "lattice: footprint-aware 2-D distances (fast; 'roadmap' is an old name for it);"
                " the others are pyperplan's, over the whole reachable lattice"
            )
        ),
    ] = "lattice"
    time_limit: Annotated[float, StrictNumber(), Field(allow_inf_nan=False, gt=0, le=120)] = 5.0
    """planning time per (re)plan, wall seconds"""
    spacing: Annotated[
        float,
        StrictNumber(),
        Field(
            allow_inf_nan=False,
            ge=0.1,
            le=5,
            deprecated=True,
            description=(
                "ignored: the old roadmap's waypoint spacing (m); the lattice's resolution is "
                "0.05 m cells and 64 orientations. Accepted so older requests still validate."
            ),
        ),
    ] = 0.5
    margin: Annotated[
        float,
        StrictNumber(),
        Field(
            allow_inf_nan=False,
            ge=0,
            le=0.2,
            description="metres the planned swept footprint keeps from anything known or sensed",
        ),
    ] = 0.02
    operators: Annotated[
        dict[Literal["po1", "po2", "po3"], Annotated[str, Field(min_length=1, max_length=64)]],
        Field(
            description=(
                "reactive domain: the Table 2 primitive (id or label) grounding an operator, as "
                "the paper selects them (Fig. 10: po1 P4s, po2 P2z); unnamed operators use the "
                "body shape's primitives (PO1: interpolated towards the goal)"
            )
        ),
    ] = {}
    threshold: Annotated[
        float,
        StrictNumber(),
        Field(
            allow_inf_nan=False,
            gt=0,
            le=5,
            description="reactive domain: obstacle(direction) holds while a range there reads below this (m)",
        ),
    ] = 0.6
    clearance: Annotated[
        float,
        StrictNumber(),
        Field(
            allow_inf_nan=False,
            ge=0,
            le=5,
            description="reactive domain: metres PO2/PO3 go on once the goal direction is clear",
        ),
    ] = 0.6
    timeout_return: Annotated[
        bool,
        Field(
            description=(
                "reactive domain, Fig. 9b: after an avoidance go back to Set 1 for a time-out, "
                "then take the other side's primitive back towards the goal"
            )
        ),
    ] = False


class SensorSpec(Strict):
    """The head's range sensors."""

    ring: Annotated[int, Field(ge=0, le=32)] = 8
    """how many range sensors in a ring around the head (0: the forward IR only)"""
    range: Annotated[float, StrictNumber(), Field(allow_inf_nan=False, gt=0, le=10)] = 1.0
    """the ring sensors' range, metres"""
    ir_range: Annotated[float, StrictNumber(), Field(allow_inf_nan=False, gt=0, le=10)] = 0.8
    """the forward IR sensor's range, metres"""
    noise: Annotated[float, StrictNumber(), Field(allow_inf_nan=False, ge=0, le=0.5)] = 0.0
    """standard deviation of the range noise, metres (seeded by the mission's seed)"""


class Reach(Strict):
    """A chain step ends when the tracked point is this close to a point."""

    x: Coord
    """x, metres"""
    y: Coord
    """y, metres"""
    tolerance: Annotated[float, StrictNumber(), Field(allow_inf_nan=False, gt=0, le=5.0)] = 0.1
    """metres"""


class Until(Strict):
    """When a chain step ends: a point reached, a duration, or a sensor threshold."""

    reach: Reach | None = None
    """end when this point is reached"""
    duration: Annotated[float, StrictNumber(), Field(allow_inf_nan=False, gt=0, le=1e5)] | None = (
        None
    )
    """end after this long, model seconds"""
    sensor: str | None = None
    """end on this sensor's reading ("ir", "ring0", ...) crossing below or above"""
    below: Annotated[float, StrictNumber(), Field(allow_inf_nan=False)] | None = None
    """the sensor threshold, metres: end when the reading falls below it"""
    above: Annotated[float, StrictNumber(), Field(allow_inf_nan=False)] | None = None
    """the sensor threshold, metres: end when the reading rises above it"""
    timeout: Annotated[float, StrictNumber(), Field(allow_inf_nan=False, gt=0, le=1e5)] | None = (
        None
    )
    """give up (the mission fails) after this long, model seconds"""

    @model_validator(mode="after")
    def _one(self) -> Until:
        kinds = [self.reach is not None, self.duration is not None, self.sensor is not None]
        if sum(kinds) != 1:
            raise ValueError("give exactly one of reach, duration or sensor")
        if self.sensor is not None and (self.below is None) == (self.above is None):
            raise ValueError("a sensor condition needs exactly one of below or above")
        return self


class InterpolateSpec(Strict):
    """A primitive interpolated from three library primitives (the paper's eqs. 16-18)."""

    from_: Annotated[list[str], Field(alias="from", min_length=3, max_length=3)]
    """three library primitive ids or labels"""
    goal: tuple[Coord, Coord]
    """the displacement to reach (start frame), metres"""
    model_config = ConfigDict(
        extra="forbid", frozen=True, populate_by_name=True, use_attribute_docstrings=True
    )


class ChainStep(Strict):
    """One step of a manual chain: a primitive (or an interpolated one) until a condition."""

    primitive: str | None = None
    """a library primitive's id or label (e.g. P4s)"""
    interpolate: InterpolateSpec | None = None
    """or a primitive interpolated from three"""
    until: Until
    """when the step ends"""
    heading: Annotated[
        float | None,
        StrictNumber(),
        Field(
            allow_inf_nan=False,
            ge=-360,
            le=360,
            description=(
                "turn in place to this world heading (degrees) before the step, with the step "
                "shape's library turns: a primitive then moves as it was learned from the start pose"
            ),
        ),
    ] = None

    @model_validator(mode="after")
    def _one(self) -> ChainStep:
        if (self.primitive is None) == (self.interpolate is None):
            raise ValueError("give exactly one of primitive or interpolate")
        return self


class MissionSpec(Strict):
    """A mission: goals (or a chain of primitives) in an arena with obstacles and events."""

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
    obstacles: Annotated[list[ObstacleSpec], Field(max_length=MAX_OBSTACLES)] = []
    """obstacles, known to the planner or hidden"""
    bounds: BoundsSpec = BoundsSpec()
    """the arena's walls"""
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

    @model_validator(mode="after")
    def _consistent(self) -> MissionSpec:
        if not self.goals and not self.chain:
            raise ValueError("goals: give at least one goal, or a chain of primitives")
        if self.goals and self.chain:
            raise ValueError("chain: give goals or a chain of primitives, not both")
        if isinstance(self.shape, str) and self.shape not in SHAPES:
            raise ValueError(f"shape: unknown {self.shape!r}; known: {', '.join(SHAPES)}")
        if (
            isinstance(self.shape, JointsShape)
            and covers(self.shape.joints, FIXED_SHAPES).kind == "none"
        ):
            raise ValueError(
                f"shape.joints: {list(self.shape.joints)} is a shape the library does not cover "
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
        if not bounds.contains(self.start.x, self.start.y):
            raise ValueError("start: outside the bounds")
        for i, g in enumerate(self.goals):
            if not bounds.contains(g.x, g.y):
                raise ValueError(f"goals.{i}: outside the bounds")
            for j, ob in enumerate(obstacles):
                if ob.contains(_xy(g.x, g.y))[0]:
                    raise ValueError(f"goals.{i}: inside obstacles.{j}")
        for j, ob in enumerate(obstacles):
            if ob.contains(_xy(self.start.x, self.start.y))[0]:
                raise ValueError(f"start: inside obstacles.{j}")
        self._body_fits(bounds, obstacles)
        return self

    def _body_fits(self, bounds: Bounds, obstacles: list[Obstacle]) -> None:
        """The whole start body clear, and every goal reachable by the tracked point."""
        import numpy as np

        pose = np.array([self.start.x, self.start.y, self.start.psi])
        contact = World(bounds, tuple(obstacles)).contact(
            footprint(pose, np.asarray(self.start_joints()))
        )
        if contact is not None:
            what = "a wall" if contact.obstacle < 0 else f"obstacles.{contact.obstacle}"
            raise ValueError(f"start: the robot's body (head and four units) overlaps {what}")
        # The first unit's capsule (radius r) is centred on the tracked point's axis: the point
        # can get no closer than r to anything, and a goal counts within 0.4 of its tolerance.
        r = DEFAULT_GEOMETRY.unit_radius
        for i, g in enumerate(self.goals):
            need = r - ARRIVE_FRACTION * g.tolerance
            p = _xy(g.x, g.y)
            if float(bounds.wall_clearance(p)[0]) < need:
                raise ValueError(
                    f"goals.{i}: closer to a wall than the robot can reach ({r:g} m around "
                    "the tracked point, less 0.4 of the tolerance)"
                )
            for j, ob in enumerate(obstacles):
                if float(ob.segment_clearance(p, p)[0]) < need:
                    raise ValueError(
                        f"goals.{i}: closer to obstacles.{j} than the robot can reach "
                        f"({r:g} m around the tracked point, less 0.4 of the tolerance)"
                    )

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


def _range_sensor(name: str, ring: int) -> bool:
    """``ir`` or ``ring<k>`` with k below the ring's size: the sensors a chain can wait on."""
    return name == "ir" or (_RING_NAME.fullmatch(name) is not None and int(name[4:]) < ring)


def _xy(x: float, y: float) -> Any:
    import numpy as np

    return np.array([[x, y]])


class MissionFileError(ValueError):
    """A mission file that cannot be used, with the field and the reason."""


def load_mission(path: Path) -> MissionSpec:
    try:
        text = path.read_text()
    except OSError as exc:
        raise MissionFileError(f"{path}: cannot read ({exc.strerror})") from exc
    return parse_mission(text, str(path))


def parse_mission(text: str, source: str = "mission") -> MissionSpec:
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise MissionFileError(
            f"{source}: not valid JSON ({exc.msg} at line {exc.lineno})"
        ) from exc
    try:
        return MissionSpec.model_validate(data)
    except ValidationError as exc:
        first = exc.errors()[0]
        loc = first["loc"]
        # The events union's tag ("deform", "dropout") is not a field: events.0.joints, as before.
        where = ".".join(str(p) for i, p in enumerate(loc) if not (i == 2 and loc[0] == "events"))
        where = where or "mission"
        raise MissionFileError(f"{source}: {where}: {first['msg']}") from exc
