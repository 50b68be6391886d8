"""What the bundled library holds: every shape × the eight Fig. 6 goals, with Table 2 labels,
and the lattice primitives (short translations and turns in place) of every shape."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

from primitives.params import ParameterSpace
from primitives.shapes import SHAPES

Family = Literal["paper", "lattice"]
FAMILIES: tuple[Family, ...] = ("paper", "lattice")

# Fig. 6: G1..G8 as start-frame displacements (docs/robot-model.md, "Frames and the paper's angle labels").
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


# Lattice primitives: body-frame translation angles (deg), distances (m), turns (deg).
LATTICE_ANGLES: tuple[int, ...] = tuple(range(0, 360, 45))
LATTICE_DISTANCES: tuple[float, ...] = (0.05, 0.25)
LATTICE_TURNS: tuple[float, ...] = (-45.0, -22.5, -5.625, 5.625, 22.5, 45.0)


@dataclass(frozen=True)
class PrimitiveSpec:
    """One primitive to learn: its id, label, shape and start-frame goal; a lattice primitive
    moves the centroid by ``goal`` and turns by ``turn`` (radians)."""

    id: str
    label: str | None
    shape: str
    goal: tuple[float, float]
    family: Family = "paper"
    turn: float = 0.0

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
    """Every shape × G1..G8, plus the paper's P5pe."""
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


def lattice_id(shape: str, distance: float = 0.0, angle: int = 0, turn_deg: float = 0.0) -> str:
    """PDDL-safe ids: ``lat-straight-t025-a180`` (0.25 m at body angle 180°),
    ``lat-zigzag-rm22p5`` / ``lat-zigzag-rp05p6`` (turn by −22.5° / +5.625°)."""
    if turn_deg:
        sign = "p" if turn_deg > 0 else "m"
        return f"lat-{shape}-r{sign}{abs(turn_deg):04.1f}".replace(".", "p")
    return f"lat-{shape}-t{round(distance * 100):03d}-a{angle:03d}"


def lattice_specs(shapes: tuple[str, ...] = tuple(SHAPES)) -> list[PrimitiveSpec]:
    """Per shape, named or learned: translations of the centroid at body angles 0°, 45°, …,
    315° × 0.05 m and 0.25 m, then turns in place by ±5.625°, ±22.5°, ±45° (the periodic gait's
    as whole gait cycles from its lattice phases, primitives/lattice.py)."""
    specs = []
    for shape in shapes:
        for d in LATTICE_DISTANCES:
            for a in LATTICE_ANGLES:
                rad = math.radians(a)
                goal = (round(d * math.cos(rad), 12) + 0.0, round(d * math.sin(rad), 12) + 0.0)
                specs.append(PrimitiveSpec(lattice_id(shape, d, a), None, shape, goal, "lattice"))
        for t in LATTICE_TURNS:
            specs.append(
                PrimitiveSpec(
                    lattice_id(shape, turn_deg=t),
                    None,
                    shape,
                    (0.0, 0.0),
                    "lattice",
                    math.radians(t),
                )
            )
    return specs
