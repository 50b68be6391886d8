"""What "a shape the library covers" means, defined once: a body shape (three joint
angles) is covered when it is a library shape within a stated joint tolerance, or when it can
be interpolated between library shapes as the paper's Figs. 8 and 13b do.

The paper's bilinear interpolation (eqs. 16-18) blends whole parameter vectors, joints included,
with non-negative weights and f(O) = 0: Fig. 8 blends P1s (straight) with P12 and P13
(semi-zigzag) and so runs a body half-way between the two shapes. The joints such a blend can
produce are the convex combinations of the library shapes' joints and of f(O)'s zero joints;
a sensed shape within the tolerance of that set is covered by interpolation, and its sources are
the shapes with a weight in the nearest combination.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import nnls

from primitives.shapes import SHAPES

JOINT_TOLERANCE = 0.15  # rad (max-abs over the three joints): a library shape "as it is"
# A lattice motion run on joints this far from its shape's lands within one lattice cell
# (5 cm) and one heading bin (5.625°) of its recorded end: the worst over the five fixed
# shapes' 110 motions and six directions of offset was 2.6 cm and 3.0° at 0.05 rad, but
# 5.6 cm and 6.8° at 0.15 rad (docs/navigation.md, "Shapes the library lacks").
LATTICE_TOLERANCE = 0.05  # rad
MIN_WEIGHT = 1e-3  # weights below this are not named as sources
Kind = Literal["library", "interpolated", "none"]


@dataclass(frozen=True)
class Coverage:
    """How the library covers one body shape.

    ``kind`` is ``library`` (``shape`` is the library shape within ``tolerance``),
    ``interpolated`` (``sources`` are the library shapes whose convex combination with
    ``weights`` lies within ``tolerance``; ``shape`` is the nearest of them, whose primitives a
    planner runs with the sensed joints held) or ``none``. ``error`` is the max-abs joint
    distance (rad) to the library shape or to the interpolated combination.
    """

    kind: Kind
    shape: str | None
    sources: tuple[str, ...] = ()
    weights: tuple[float, ...] = ()
    error: float = math.inf
    tolerance: float = JOINT_TOLERANCE

    @property
    def covered(self) -> bool:
        return self.kind != "none"

    def describe(self) -> str:
        """One line for logs and failure reasons."""
        if self.kind == "library":
            return f"library shape {self.shape} (within {self.error:.2f} rad)"
        if self.kind == "interpolated":
            parts = ", ".join(
                f"{s} {w:.2f}" for s, w in zip(self.sources, self.weights, strict=True)
            )
            return f"interpolated between library shapes ({parts}; within {self.error:.2f} rad)"
        return (
            f"no library shape within {self.tolerance:g} rad and not interpolable between "
            "library shapes"
        )

    def to_dict(self) -> dict[str, object]:
        return {
            "kind": self.kind,
            "shape": self.shape,
            "sources": list(self.sources),
            "weights": [round(w, 4) for w in self.weights],
            "error": None if math.isinf(self.error) else round(self.error, 4),
        }


def covers(
    joints: ArrayLike, shapes: Iterable[str], tolerance: float = JOINT_TOLERANCE
) -> Coverage:
    """How the fixed library ``shapes`` (names in ``primitives.shapes.SHAPES``) cover ``joints``.

    Bad input (not three finite angles) is covered by nothing.
    """
    j = np.asarray(joints, dtype=float)
    fixed = sorted({s for s in shapes if s in SHAPES and not SHAPES[s].periodic})
    if j.shape != (3,) or not np.all(np.isfinite(j)) or not fixed:
        return Coverage("none", None, tolerance=tolerance)
    table = np.array([SHAPES[s].joints for s in fixed])  # [S, 3]
    dist = np.max(np.abs(table - j), axis=1)
    nearest = int(np.argmin(dist))
    if dist[nearest] <= tolerance:
        return Coverage("library", fixed[nearest], error=float(dist[nearest]), tolerance=tolerance)
    weights = _convex_weights(table, j)
    blend = weights[:-1] @ table  # the last column is f(O) = 0
    error = float(np.max(np.abs(blend - j)))
    if error > tolerance:
        return Coverage("none", None, error=error, tolerance=tolerance)
    names = [*fixed, "origin"]
    picked = [(names[i], float(w)) for i, w in enumerate(weights) if w > MIN_WEIGHT]
    # f(O)'s zero joints are the straight shape's when the library has it.
    if "straight" in fixed:
        merged: dict[str, float] = {}
        for name, w in picked:
            key = "straight" if name == "origin" else name
            merged[key] = merged.get(key, 0.0) + w
        picked = list(merged.items())
    return Coverage(
        "interpolated",
        fixed[nearest],
        tuple(n for n, _ in picked),
        tuple(w for _, w in picked),
        error,
        tolerance,
    )


def nearest_shape(
    joints: ArrayLike,
    shapes: Mapping[str, Sequence[float]],
    tolerance: float = LATTICE_TOLERANCE,
) -> Coverage:
    """The shape of ``shapes`` (name -> joints) nearest to ``joints`` (max-abs) when within
    ``tolerance``: a ``library`` coverage; else ``none`` (no blends: a lattice motion's end
    holds for its own joints only). Ties go to the first name in sorted order."""
    j = np.asarray(joints, dtype=float)
    if j.shape != (3,) or not np.all(np.isfinite(j)) or not shapes:
        return Coverage("none", None, tolerance=tolerance)
    names = sorted(shapes)
    dist = np.max(np.abs(np.array([shapes[n] for n in names], dtype=float) - j), axis=1)
    best = int(np.argmin(dist))
    if dist[best] <= tolerance:
        return Coverage("library", names[best], error=float(dist[best]), tolerance=tolerance)
    return Coverage("none", None, error=float(dist[best]), tolerance=tolerance)


def _convex_weights(table: np.ndarray, joints: np.ndarray) -> np.ndarray:
    """Non-negative weights summing to one over the shapes and f(O) = 0 whose joint blend is
    nearest to ``joints`` (least squares, with the sum enforced by a heavily weighted row)."""
    columns = np.vstack([table, np.zeros(3)]).T  # [3, S + 1]
    heavy = 1e3
    a = np.vstack([columns, heavy * np.ones(columns.shape[1])])
    b = np.concatenate([joints, [heavy]])
    weights, _ = nnls(a, b)
    return np.asarray(weights / max(float(weights.sum()), 1e-12))
