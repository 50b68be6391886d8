"""The reactive strategy's moves: how far a paper move's one-tick motion turns off its chord,
learned from sensed poses, and the queued runs of PO1 (Fig. 9b's time-out and return).

A Table 2 primitive (or an interpolation of them) reaches its recorded end along an arc: our
learned primitives turn the body as they go, so over one control tick the robot moves off the
straight line to the recorded end by an angle that is constant for fixed parameters (the body
twist is constant). The reactive strategy re-aims PO1 every tick; aiming past that angle keeps
its direction. Nothing here looks at the simulator: only the poses the robot reports.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from primitives.paper_moves import Move

BIAS_LIMIT = math.radians(75)  # the largest chord-to-motion angle believed
BIAS_GAIN = 0.5  # how fast a new measurement of that angle replaces the old one
MIN_MOTION = 1e-4  # metres: a tick that moved less says nothing about the direction

Pose = tuple[float, float, float]


def move_key(move: Move) -> tuple[str, ...]:
    """Moves with one shape and one set of sources share their chord-to-motion angle."""
    return (move.shape, *move.primitives)


class ChordBias:
    """Per move key: the angle (rad, counter-clockwise) from the move's chord to its motion."""

    def __init__(self) -> None:
        self.bias: dict[tuple[str, ...], float] = {}
        self.sent: tuple[tuple[str, ...], float, Pose, str] | None = None

    def get(self, move: Move) -> float | None:
        return self.bias.get(move_key(move))

    def commanded(self, move: Move, pose: Pose, shape: str) -> None:
        """The move about to run for one tick from ``pose`` with the body in ``shape``."""
        self.sent = (move_key(move), move.direction, pose, shape)

    def forget_tick(self) -> None:
        """The next tick runs something else (no paper move): nothing to learn from it."""
        self.sent = None

    def observe(self, pose: Pose, shape: str) -> tuple[float, float] | None:
        """Learn from where the last commanded tick took the robot; returns that tick's
        motion (world dx, dy), or None when there is nothing to learn from."""
        if self.sent is None:
            return None
        key, chord, (x, y, psi), sent_shape = self.sent
        self.sent = None
        dx, dy = pose[0] - x, pose[1] - y
        if sent_shape != shape or math.hypot(dx, dy) < MIN_MOTION:
            return None  # the body changed shape during the tick: its motion says nothing
        seen = math.remainder(math.atan2(dy, dx) - psi - chord, 2 * math.pi)
        seen = max(-BIAS_LIMIT, min(BIAS_LIMIT, seen))
        old = self.bias.get(key)
        self.bias[key] = seen if old is None else old + BIAS_GAIN * (seen - old)
        return dx, dy


@dataclass
class Leg:
    """One queued run: an action name, its move and how long (model seconds) it runs."""

    action: str
    move: Move | None  # None: Set 1 towards its first world direction
    seconds: float
    started: float | None = None
