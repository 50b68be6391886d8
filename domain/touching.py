"""Margins for moving away from where the robot stands too close to something.

A contact stops the robot touching an obstacle, so the resting body may be closer to it than
the planning margin (or even inside its inflation). Motions out of there must be allowed to
keep as close as the body already is, or nothing could move; but only *where* it is that
close. A single allowance for the whole body let the far end of the body swing into another
surface as deep as the touching end already was (a tail touching one wall of a hidden U, its
side then brushing the next)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sim.robot import Array

TOUCH_RADIUS = 0.15  # metres round a too-close body point within which the allowance holds
DEEPER = 0.005  # metres a point near a too-close one may come closer than the start already is


@dataclass(frozen=True)
class TouchAllowance:
    """The margin each point of a motion out of a start keeps: ``relaxed`` within
    ``TOUCH_RADIUS`` of ``sites`` (the resting body's points closer than ``margin``),
    ``margin`` elsewhere."""

    margin: float
    relaxed: float
    sites: Array  # [S, 2] world points

    def at(self, points: Array) -> Array:
        """The margin kept at each world point of ``points`` ``[N, 2]``."""
        points = np.asarray(points, dtype=float)
        if len(self.sites) == 0:
            return np.full(len(points), self.margin)
        gap = points[:, None, :] - self.sites[None, :, :]
        near = np.min(np.einsum("nsd,nsd->ns", gap, gap), axis=1) <= TOUCH_RADIUS**2
        return np.where(near, self.relaxed, self.margin)


def touch_allowance(points: Array, slack: Array, margin: float) -> TouchAllowance:
    """The allowance of a resting body whose sample ``points`` ``[N, 2]`` keep ``slack``
    ``[N]`` (clearance less each point's need) against a wanted ``margin``."""
    close = slack < margin
    relaxed = min(margin, float(np.min(slack)) - DEEPER) if close.any() else margin
    return TouchAllowance(margin, relaxed, np.asarray(points, dtype=float)[close])
