"""What the bundled library holds: every shape × the eight Fig. 6 goals, with Table 2 labels."""

from __future__ import annotations

import math
from dataclasses import dataclass

from primitives.params import ParameterSpace
from primitives.shapes import SHAPES

# Fig. 6: G1..G8 as start-frame displacements (kinematics.md §9).
FIG6_GOALS: tuple[tuple[float, float], ...] = (
    (2.0, 2.0),
    (0.0, 2.0),
    (-2.0, 2.0),
    (-2.0, 0.0),
    (-2.0, -2.0),
    (0.0, -2.0),
    (2.0, -2.0),
    (2.0, 0.0),
)
# Table 2 labels outside the systematic P{n}{s,a,z} scheme: goal index -> label per shape.
SPECIAL_LABELS: dict[tuple[str, int], str] = {
    ("semi-arc", 2): "P9",
    ("semi-zigzag", 4): "P10",
    ("semi-zigzag", 3): "P11",
    ("semi-zigzag", 2): "P12",
    ("semi-zigzag", 8): "P13",
    ("periodic", 6): "P4pe",  # Table 2: "move at −90° with periodic body movements"
}
# P5pe moves at the paper's −30° (clockwise labels: direction (−cos 30°, −sin 30°)), 2 m.
P5PE_GOAL = (-2.0 * math.cos(math.radians(30)), -2.0 * math.sin(math.radians(30)))


@dataclass(frozen=True)
class PrimitiveSpec:
    """One primitive to learn: its id, label, shape and start-frame goal."""

    id: str
    label: str | None
    shape: str
    goal: tuple[float, float]

    def space(self) -> ParameterSpace:
        return ParameterSpace.for_shape(self.shape)


def label_for(shape: str, goal_index: int) -> str | None:
    if (shape, goal_index) in SPECIAL_LABELS:
        return SPECIAL_LABELS[(shape, goal_index)]
    suffix = SHAPES[shape].suffix
    if suffix and suffix != "pe":
        return f"P{goal_index}{suffix}"
    return None


def default_specs(shapes: tuple[str, ...] = tuple(SHAPES)) -> list[PrimitiveSpec]:
    """Every shape × G1..G8 (DESIGN §4), plus the paper's P5pe."""
    specs = []
    for shape in shapes:
        for i, goal in enumerate(FIG6_GOALS, start=1):
            specs.append(PrimitiveSpec(f"{shape}-g{i}", label_for(shape, i), shape, goal))
    if "periodic" in shapes:
        specs.append(PrimitiveSpec("periodic-m30", "P5pe", "periodic", P5PE_GOAL))
    return specs


def grid_specs(
    shapes: tuple[str, ...], headings: int = 8, distances: tuple[float, ...] = (1.0, 2.0, 3.0)
) -> list[PrimitiveSpec]:
    """A larger library: ``headings`` directions × ``distances`` per shape (no paper labels)."""
    specs = []
    for shape in shapes:
        for h in range(headings):
            angle = 2 * math.pi * h / headings
            for d in distances:
                goal = (round(d * math.cos(angle), 6), round(d * math.sin(angle), 6))
                deg = round(math.degrees(angle))
                specs.append(PrimitiveSpec(f"{shape}-h{deg:03d}-d{d:g}", None, shape, goal))
    return specs
