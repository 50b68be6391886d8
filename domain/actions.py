"""What a planned action means physically: heading, shape, target, and the primitives behind it."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from domain.pddl import wrap_degrees
from primitives.library import Library, Primitive
from primitives.shapes import SHAPES

LIBRARY_MATCH_DEG = 5.0  # a primitive within this of the wanted direction is used as it is
PERIODIC_REACH_DEG = 22.5  # periodic primitives are not interpolated: nearest within this


@dataclass(frozen=True)
class PlannedAction:
    """One plan step: PDDL text and arguments, and for moves the heading (world frame, degrees),
    shape, target point and how it will be grounded."""

    name: str
    args: tuple[str, ...]
    heading: float | None = None
    shape: str | None = None
    target: tuple[float, float] | None = None
    grounding: dict[str, Any] = field(default_factory=dict)
    goal: int | None = None  # index (in the mission's goals) this action reaches

    @property
    def pddl(self) -> str:
        return f"({' '.join((self.name, *self.args))})"

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "args": list(self.args),
            "heading": self.heading,
            "shape": self.shape,
            "target": None if self.target is None else {"x": self.target[0], "y": self.target[1]},
            "grounding": self.grounding,
            "goal": self.goal,
        }


def angular_gap(a: float, b: float) -> float:
    return abs(wrap_degrees(a - b))


def nearest_by_direction(entries: list[Primitive], direction: float) -> Primitive | None:
    if not entries:
        return None
    return min(entries, key=lambda e: angular_gap(e.direction, direction))


def describe_grounding(
    library: Library, shape: str, heading: float, psi_deg: float
) -> dict[str, Any]:
    """How ``move(heading, shape)`` is grounded from pose heading ψ: a library entry when one
    points that way, else the generaliser's blend of the two bracketing primitives."""
    direction = wrap_degrees(heading - psi_deg)  # in the start frame of the current pose
    entries = library.of_shape(shape)
    best = nearest_by_direction(entries, direction)
    if best is None:
        return {"method": "none", "primitives": [], "direction": direction}
    if angular_gap(best.direction, direction) <= LIBRARY_MATCH_DEG or SHAPES[shape].periodic:
        return {"method": "library", "primitives": [best.id], "direction": direction}
    ahead = [e for e in entries if wrap_degrees(e.direction - direction) > 0]
    behind = [e for e in entries if wrap_degrees(e.direction - direction) <= 0]
    left = min(ahead, key=lambda e: wrap_degrees(e.direction - direction), default=best)
    right = max(behind, key=lambda e: wrap_degrees(e.direction - direction), default=best)
    return {"method": "interpolated", "primitives": [right.id, left.id], "direction": direction}


def groundable_headings(
    library: Library, shape: str, psi_deg: float, headings: list[float]
) -> list[float]:
    """Headings the library can ground in ``shape`` from pose heading ψ.

    Fixed shapes with primitives around the start ground every direction (by blending);
    periodic primitives only their own directions (±22.5°), as the paper interpolates only
    non-periodic ones.
    """
    entries = library.of_shape(shape)
    if not entries:
        return []
    if not SHAPES[shape].periodic and len(entries) >= 3:
        spread = max(angular_gap(a.direction, b.direction) for a in entries for b in entries)
        if spread > 90:
            return list(headings)
    out = []
    for h in headings:
        best = nearest_by_direction(entries, wrap_degrees(h - psi_deg))
        if (
            best is not None
            and angular_gap(best.direction, wrap_degrees(h - psi_deg)) <= PERIODIC_REACH_DEG
        ):
            out.append(h)
    return out
