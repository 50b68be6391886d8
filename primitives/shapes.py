"""Named body shapes of the library and classification of sensed joint angles."""

from __future__ import annotations

import math
from dataclasses import dataclass

from numpy.typing import ArrayLike


@dataclass(frozen=True)
class Shape:
    """A body shape: fixed joint angles, or ``periodic`` (the gait of eq. 13, joints from
    phases; ``joints`` is then the gait's start shape A sin ϕ of the lattice phases)."""

    name: str
    joints: tuple[float, float, float]
    periodic: bool = False
    suffix: str = ""  # the paper's label suffix: P1s, P2a, P4z, P4pe
    phases: tuple[float, float, float] | None = None  # a periodic shape's lattice gait phases


SHAPES: dict[str, Shape] = {
    s.name: s
    for s in (
        Shape("straight", (0.0, 0.0, 0.0), suffix="s"),
        Shape("zigzag", (0.5, -0.5, 0.5), suffix="z"),
        Shape("arc", (0.3, 0.3, 0.3), suffix="a"),
        Shape("semi-arc", (0.3, 0.3, 0.0)),
        Shape("semi-zigzag", (0.5, -0.5, -0.1)),
        # The lattice's gait: a standing wave, φ = 0.2 sin(0.6 t) (1, −1, 1). Every motion
        # starts and ends straight (the body a lattice state holds), and of the phase patterns
        # tried (in phase, travelling at 2π/3, the paper's Exp4) it sweeps least: the tail
        # swings ±0.09 m (docs/navigation.md, "The periodic gait").
        Shape("periodic", (0.0, 0.0, 0.0), periodic=True, suffix="pe", phases=(0.0, math.pi, 0.0)),
    )
}
FIXED_SHAPES = tuple(name for name, s in SHAPES.items() if not s.periodic)


def shape_named(name: str) -> Shape:
    try:
        return SHAPES[name]
    except KeyError:
        raise ValueError(f"shape: unknown {name!r}; known: {', '.join(SHAPES)}") from None


def classify_shape(joints: ArrayLike, tolerance: float = 0.15) -> str | None:
    """The fixed named shape within ``tolerance`` (max-abs) of sensed ``joints``, else None:
    the ``library`` case of ``primitives.coverage.covers`` over every named shape."""
    from primitives.coverage import covers

    found = covers(joints, FIXED_SHAPES, tolerance)
    return found.shape if found.kind == "library" else None
