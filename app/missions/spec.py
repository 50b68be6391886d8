"""A mission as data (DESIGN §10): start, shape, goals, obstacles, events, planner, limits.

Validated strictly: finite numbers only, bounded lists, coordinates inside the arena, goals and
start outside obstacles, unknown fields rejected. The same model backs mission files and
``POST /missions``.
"""

from __future__ import annotations

import json
import math
import re
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
    model_config = ConfigDict(extra="forbid", frozen=True)


class Pose(Strict):
    x: Coord = 0.0
    y: Coord = 0.0
    psi: Angle = 0.0


class Point(Strict):
    x: Coord
    y: Coord


class GoalSpec(Strict):
    x: Coord
    y: Coord
    tolerance: Annotated[float, StrictNumber(), Field(allow_inf_nan=False, gt=0, le=5.0)] = 0.1


class JointsShape(Strict):
    joints: tuple[Joint, Joint, Joint]


class CircleSpec(Strict):
    type: Literal["circle"]
    x: Coord
    y: Coord
    radius: Annotated[float, StrictNumber(), Field(allow_inf_nan=False, gt=0, le=100)]
    known: bool = True


class RectangleSpec(Strict):
    type: Literal["rectangle"]
    x: Coord
    y: Coord
    width: Annotated[float, StrictNumber(), Field(allow_inf_nan=False, gt=0, le=1000)]
    height: Annotated[float, StrictNumber(), Field(allow_inf_nan=False, gt=0, le=1000)]
    angle: Angle = 0.0
    known: bool = True


class PolygonSpec(Strict):
    type: Literal["polygon"]
    points: Annotated[list[tuple[Coord, Coord]], Field(min_length=3, max_length=64)]
    known: bool = True


ObstacleSpec = Annotated[CircleSpec | RectangleSpec | PolygonSpec, Field(discriminator="type")]


class BoundsSpec(Strict):
    xmin: Coord = -10.0
    xmax: Coord = 10.0
    ymin: Coord = -10.0
    ymax: Coord = 10.0

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
    t: Annotated[float, StrictNumber(), Field(allow_inf_nan=False, ge=0, le=1e6)]
    type: Literal["deform"]
    joints: tuple[Joint, Joint, Joint]


class DropoutEvent(Strict):
    """From ``t`` for ``duration`` model seconds the named sensors read nothing (data model only)."""

    t: Annotated[
        float,
        StrictNumber(),
        Field(allow_inf_nan=False, ge=0, le=1e6, description="start, model s"),
    ]
    type: Literal["dropout"]
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
    domain: Literal["navigation", "reactive"] = "navigation"
    search: Literal["gbf", "astar", "wastar", "ehs", "bfs"] = "gbf"
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
    ring: Annotated[int, Field(ge=0, le=32)] = 8
    range: Annotated[float, StrictNumber(), Field(allow_inf_nan=False, gt=0, le=10)] = 1.0
    ir_range: Annotated[float, StrictNumber(), Field(allow_inf_nan=False, gt=0, le=10)] = 0.8
    noise: Annotated[float, StrictNumber(), Field(allow_inf_nan=False, ge=0, le=0.5)] = 0.0


class Reach(Strict):
    x: Coord
    y: Coord
    tolerance: Annotated[float, StrictNumber(), Field(allow_inf_nan=False, gt=0, le=5.0)] = 0.1


class Until(Strict):
    """When a chain step ends: a point reached, a duration, or a sensor threshold."""

    reach: Reach | None = None
    duration: Annotated[float, StrictNumber(), Field(allow_inf_nan=False, gt=0, le=1e5)] | None = (
        None
    )
    sensor: str | None = None
    below: Annotated[float, StrictNumber(), Field(allow_inf_nan=False)] | None = None
    above: Annotated[float, StrictNumber(), Field(allow_inf_nan=False)] | None = None
    timeout: Annotated[float, StrictNumber(), Field(allow_inf_nan=False, gt=0, le=1e5)] | None = (
        None
    )

    @model_validator(mode="after")
    def _one(self) -> Until:
        kinds = [self.reach is not None, self.duration is not None, self.sensor is not None]
        if sum(kinds) != 1:
            raise ValueError("give exactly one of reach, duration or sensor")
        if self.sensor is not None and (self.below is None) == (self.above is None):
            raise ValueError("a sensor condition needs exactly one of below or above")
        return self


class InterpolateSpec(Strict):
    from_: Annotated[list[str], Field(alias="from", min_length=3, max_length=3)]
    goal: tuple[Coord, Coord]
    model_config = ConfigDict(extra="forbid", frozen=True, populate_by_name=True)


class ChainStep(Strict):
    primitive: str | None = None
    interpolate: InterpolateSpec | None = None
    until: Until
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
    # No NUL: PostgreSQL cannot store it in a text column.
    name: Annotated[str, Field(max_length=120, pattern=r"^[^\x00]*$")] = "mission"
    start: Pose = Pose()
    shape: str | JointsShape = "straight"
    goals: Annotated[list[GoalSpec], Field(max_length=MAX_GOALS)] = []
    order: Literal["given", "any"] = "given"
    obstacles: Annotated[list[ObstacleSpec], Field(max_length=MAX_OBSTACLES)] = []
    bounds: BoundsSpec = BoundsSpec()
    events: Annotated[list[EventSpec], Field(max_length=MAX_EVENTS)] = []
    planner: PlannerSpec = PlannerSpec()
    sensors: SensorSpec = SensorSpec()
    chain: Annotated[list[ChainStep], Field(max_length=MAX_CHAIN)] = []
    speed: Annotated[float, StrictNumber(), Field(allow_inf_nan=False, ge=0, le=10_000)] = 0.0
    seed: Annotated[int, Field(ge=0, le=2**32 - 1)] = 0
    time_limit: Annotated[float, StrictNumber(), Field(allow_inf_nan=False, gt=0, le=36_000)] = (
        1800.0
    )
    max_replans: Annotated[int, Field(ge=0, le=10_000)] = 500
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
