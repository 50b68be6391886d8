"""The pieces of a mission request: poses, goals, obstacles, bounds, events, planner, sensors,
chain steps, each validated strictly (``app.missions.spec`` puts them together)."""

from __future__ import annotations

import math
import re
from typing import Annotated, Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    field_validator,
    model_validator,
)
from pydantic import Strict as StrictNumber  # no bool or string coerced into a number

from domain.navigation import NavigationSettings
from sim.world import Bounds

ARRIVE_FRACTION = 0.4  # a goal is marked reached within this fraction of its tolerance

MAX_GOALS = 50
MAX_EVENTS = 20
MAX_CHAIN = 50
MAX_MAPS = 16
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
    """A body shape given by its joint angles (within the joint limits; a goals mission on the
    lattice learns its lattice primitives first when the library has no shape near it)."""

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
        r = NavigationSettings().resolution
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
    search: Annotated[
        Literal["cost", "gbf", "astar", "wastar", "ehs", "bfs"],
        Field(
            description=(
                "navigation: 'cost' is weighted A* on the motions' costs (their length, more "
                "near obstacles and where the body sweeps unseen space) with an anytime best "
                "node; the others are pyperplan's unit-cost searches on the same lattice (a "
                "check; they ignore the costs). reactive: pyperplan's search of Table 3"
            )
        ),
    ] = "cost"
    heuristic: Annotated[
        Literal["cost", "lattice", "roadmap", "hff", "hadd", "hmax", "lmcut", "landmark", "blind"],
        Field(
            description=(
                "cost: the obstacle heuristic, a cost-aware 2-D distance to the goal ('lattice' "
                "and 'roadmap' are older names for it); the others are pyperplan's, over the "
                "whole reachable lattice (with a pyperplan search only)"
            )
        ),
    ] = "cost"
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

    @model_validator(mode="after")
    def _search_and_heuristic(self) -> PlannerSpec:
        pyperplan_heuristic = self.heuristic not in ("cost", "lattice", "roadmap")
        if self.domain == "navigation" and self.search == "cost" and pyperplan_heuristic:
            raise ValueError(
                "heuristic: the cost search takes the cost heuristic; pyperplan's heuristics "
                "go with pyperplan's searches (gbf, astar, wastar, ehs)"
            )
        return self


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


def _range_sensor(name: str, ring: int) -> bool:
    """``ir`` or ``ring<k>`` with k below the ring's size: the sensors a chain can wait on."""
    return name == "ir" or (_RING_NAME.fullmatch(name) is not None and int(name[4:]) < ring)


def _xy(x: float, y: float) -> Any:
    import numpy as np

    return np.array([[x, y]])
