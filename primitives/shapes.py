"""Named body shapes of the library, learned shapes named by their joints, and classification
of sensed joint angles."""

from __future__ import annotations

import hashlib
import math
import re
from collections.abc import Sequence
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


# A learned shape is named by its joints rounded to LEARNED_STEP rad: ``body-p090-m030-p060``
# is (0.90, −0.30, 0.60). The name is its identity everywhere (library entries, lattice ids,
# the store), so the same joints give the same name, seed and entries on any executor.
LEARNED_PREFIX = "body"
LEARNED_STEP = 0.01  # rad
_LEARNED = re.compile(rf"^{LEARNED_PREFIX}(-[pm]\d{{3}}){{3}}$")


def learned_name(joints: Sequence[float]) -> str:
    """The stable name of the fixed shape ``joints`` (three angles, rounded to LEARNED_STEP)."""
    if len(joints) != 3 or not all(math.isfinite(v) for v in joints):
        raise ValueError(f"shape.joints: need three finite angles, got {list(joints)}")
    parts = []
    for v in joints:
        steps = round(v / LEARNED_STEP)
        parts.append(f"{'m' if steps < 0 else 'p'}{abs(steps):03d}")
    return "-".join([LEARNED_PREFIX, *parts])


def learned_joints(name: str) -> tuple[float, float, float] | None:
    """The joints a learned shape's name stands for, or None when ``name`` is not one."""
    if not _LEARNED.match(name):
        return None
    a, b, c = (
        (-1 if part[0] == "m" else 1) * int(part[1:]) * LEARNED_STEP for part in name.split("-")[1:]
    )
    return (round(a, 6), round(b, 6), round(c, 6))


def shape_seed(name: str) -> int:
    """A seed derived from the shape's name alone (not Python's salted ``hash``)."""
    return int(hashlib.sha256(name.encode()).hexdigest()[:8], 16) % (2**31 - 2**20)


def is_shape(name: str) -> bool:
    """A named library shape or a learned shape's name."""
    return name in SHAPES or learned_joints(name) is not None


def shape_named(name: str) -> Shape:
    """A named library shape, or the fixed shape a learned shape's name stands for."""
    found = SHAPES.get(name)
    if found is not None:
        return found
    joints = learned_joints(name)
    if joints is not None:
        return Shape(name, joints)
    raise ValueError(
        f"shape: unknown {name!r}; known: {', '.join(SHAPES)} or a learned shape "
        f"({LEARNED_PREFIX}-p090-m030-p060)"
    )


def classify_shape(joints: ArrayLike, tolerance: float = 0.15) -> str | None:
    """The fixed named shape within ``tolerance`` (max-abs) of sensed ``joints``, else None:
    the ``library`` case of ``primitives.coverage.covers`` over every named shape."""
    from primitives.coverage import covers

    found = covers(joints, FIXED_SHAPES, tolerance)
    return found.shape if found.kind == "library" else None
