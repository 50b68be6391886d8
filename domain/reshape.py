"""Shape changes as plan actions: the body switches, in place, to another shape whose lattice
primitives the library has (the paper's Figs. 11-12 chain primitives of different shapes).

The tracked point (the head) stays where it is while the joints turn to the new shape, so the
rest of the body sweeps between the two footprints. A change is valid where every intermediate
body (joints interpolated) keeps the planning margin; it takes the joints' travel at
``JOINT_RATE`` (at least one control tick).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike

from domain.lattice import capsule_samples
from domain.touching import TouchAllowance, touch_allowance
from sim.robot import Array
from sim.world import footprint

JOINT_RATE = 0.5  # rad per model second the joints turn during a commanded shape change
SWEEP_SAMPLES = 8  # intermediate bodies checked along a change


def reshape_duration(joints_from: ArrayLike, joints_to: ArrayLike, tick: float) -> float:
    """Model seconds a change takes: the largest joint travel at ``JOINT_RATE``, in ticks."""
    travel = float(np.max(np.abs(np.subtract(joints_to, joints_from))))
    return max(1, math.ceil(travel / JOINT_RATE / tick)) * tick


def reshape_clear(
    pose: Sequence[float],
    joints_from: ArrayLike,
    joints_to: ArrayLike,
    clearance: Callable[[Array], Array],
    margin: float,
) -> bool:
    """Whether the body sweeping from one shape to the other at ``pose`` keeps ``margin`` (or,
    near where the body already keeps less, never gets closer than it is)."""
    p = np.asarray(pose, dtype=float)
    a, b = np.asarray(joints_from, dtype=float), np.asarray(joints_to, dtype=float)
    allowance: TouchAllowance | None = None
    for s in np.linspace(0.0, 1.0, SWEEP_SAMPLES):
        fp = footprint(p, a + s * (b - a))
        points, needs = capsule_samples(fp.starts, fp.ends, fp.radii)
        slack = clearance(points) - needs
        if allowance is None:
            allowance = touch_allowance(points, slack, margin)
        elif np.any(slack < allowance.at(points)):
            return False
    return True
