"""The paper's bilinear parameter interpolation (eqs. 16-18, quadrants A-D, f(O) = 0).

Three primitives span a quadrant: one on its x axis (x2, 0), one on its y axis (0, y2) and one
on its diagonal (x2, y2); the origin O = (0, 0) has f(O) = 0. Fig. 6's quadrants are A (+x, +y:
P1, P2, P8), B (−x, +y: P2, P3, P4), C (−x, −y: P4, P5, P6) and D (+x, −y: P6, P7, P8).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from primitives.catalogue import FIG6_GOALS
from primitives.library import Library, Primitive
from primitives.params import ParameterSpace
from sim.controls import Control
from sim.robot import Array

QUADRANTS = {"A": (1, 1), "B": (-1, 1), "C": (-1, -1), "D": (1, -1)}
# Fig. 6 goal indices (1-based) on each quadrant's x axis, y axis and diagonal.
QUADRANT_GOALS = {"A": (8, 2, 1), "B": (4, 2, 3), "C": (4, 6, 5), "D": (8, 6, 7)}


def quadrant_of(goal: tuple[float, float]) -> str:
    """The quadrant A-D holding ``goal`` (the axes belong to both neighbours; A/B/C/D order)."""
    x, y = goal
    if x >= 0 and y >= 0:
        return "A"
    if x < 0 <= y:
        return "B"
    if x < 0 and y < 0:
        return "C"
    return "D"


def bilinear(
    goal: tuple[float, float],
    f_x: Array,
    f_y: Array,
    f_xy: Array,
    x2: float,
    y2: float,
    f_o: Array | None = None,
) -> Array:
    """Eqs. 16-18 with x1 = y1 = 0: f(G) from f at (x2, 0), (0, y2), (x2, y2) and f(O)."""
    if x2 == 0 or y2 == 0:
        raise ValueError("corners: the axis primitives must not sit at the origin")
    x, y = goal
    origin = np.zeros_like(f_x) if f_o is None else f_o
    wx = x / x2  # (x − x1)/(x2 − x1)
    wy = y / y2
    f_s1 = (1 - wx) * origin + wx * f_x  # eq. 16, S1 = (x, y1)
    f_s2 = (1 - wx) * f_y + wx * f_xy  # eq. 17, S2 = (x, y2)
    out: Array = (1 - wy) * f_s1 + wy * f_s2  # eq. 18
    return out


@dataclass(frozen=True)
class Interpolated:
    """A generated behaviour (the paper's IM): parameters U = [θ̇, φ] and where they came from."""

    goal: tuple[float, float]
    params: Array
    sources: tuple[str, ...]
    method: str = "bilinear"
    quadrant: str = ""
    extra: dict[str, object] = field(default_factory=dict)

    @property
    def theta(self) -> Array:
        return self.params[:4]

    @property
    def joints(self) -> Array:
        return self.params[4:]

    def control(self) -> Control:
        return ParameterSpace("U2").control(self.params)


_CORNERS: dict[tuple[Any, ...], tuple[int, int, int]] = {}  # by the entries' goals
CORNERS_KEPT = 256


def corners_of(entries: Sequence[Primitive]) -> tuple[Primitive, Primitive, Primitive]:
    """Sort three primitives into (x-axis, y-axis, diagonal) by their goals (remembered per
    three entries: a reactive move re-aims every tick)."""
    key = tuple((tuple(e.goal), e.periodic) for e in entries)  # all the sorting reads
    known = _CORNERS.get(key)
    if known is not None:
        return entries[known[0]], entries[known[1]], entries[known[2]]
    corners = _corners(entries)
    if len(_CORNERS) >= CORNERS_KEPT:
        _CORNERS.clear()
    _CORNERS[key] = (
        _index(entries, corners[0]),
        _index(entries, corners[1]),
        _index(entries, corners[2]),
    )
    return corners


def _index(entries: Sequence[Primitive], entry: Primitive) -> int:
    return next(i for i, e in enumerate(entries) if e is entry)


def _corners(entries: Sequence[Primitive]) -> tuple[Primitive, Primitive, Primitive]:
    if len(entries) != 3:
        raise ValueError("from: bilinear interpolation takes exactly three primitives")
    if any(e.periodic for e in entries):
        raise ValueError("from: only non-periodic primitives can be interpolated (paper §5.2)")

    def axis_score(e: Primitive, axis: int) -> float:
        return abs(e.goal[1 - axis]) / max(1e-9, math.hypot(*e.goal))

    on_x = min(entries, key=lambda e: axis_score(e, 0))
    on_y = min((e for e in entries if e is not on_x), key=lambda e: axis_score(e, 1))
    diagonal = next(e for e in entries if e is not on_x and e is not on_y)
    if axis_score(on_x, 0) > 0.1 or axis_score(on_y, 1) > 0.1:
        raise ValueError("from: need one primitive on each axis of the quadrant and one between")
    return on_x, on_y, diagonal


def interpolate_entries(
    entries: Sequence[Primitive], goal: tuple[float, float], hold_joints: Array | None = None
) -> Interpolated:
    """Bilinear interpolation from three named primitives (e.g. Fig. 8: P1s, P12, P13).

    ``hold_joints`` keeps the body shape fixed (the robot cannot change it, e.g. after a
    deformation): then only the screw speeds are interpolated, with f(O) = 0 on them.
    """
    on_x, on_y, diagonal = corners_of(entries)
    x2, y2 = on_x.goal[0], on_y.goal[1]
    f_o = None
    fx, fy, fxy = on_x.params(), on_y.params(), diagonal.params()
    if hold_joints is not None:
        f_o = np.concatenate([np.zeros(4), hold_joints])
        fx, fy, fxy = (np.concatenate([f[:4], hold_joints]) for f in (fx, fy, fxy))
    params = bilinear(goal, fx, fy, fxy, x2, y2, f_o)
    params[4:] = np.clip(params[4:], -math.pi / 2, math.pi / 2)
    params[:4] = np.clip(params[:4], -1.0, 1.0)
    names = (on_x.name, on_y.name, diagonal.name)
    return Interpolated(goal, params, names, "bilinear", quadrant_of(goal))


def interpolate_in_shape(
    library: Library, goal: tuple[float, float], shape: str, hold_shape: bool = True
) -> Interpolated:
    """The paper's scheme within one shape: the quadrant's three Fig. 6 primitives of ``shape``."""
    quadrant = quadrant_of(goal)
    by_goal = {e.goal: e for e in library.of_shape(shape) if not e.periodic}
    try:
        entries = [by_goal[FIG6_GOALS[i - 1]] for i in QUADRANT_GOALS[quadrant]]
    except KeyError:
        raise KeyError(
            f"the library lacks a Fig. 6 primitive of shape {shape!r} for quadrant {quadrant}"
        ) from None
    hold = np.asarray(entries[0].joints) if hold_shape else None
    return interpolate_entries(entries, goal, hold)
