"""The reactive strategy: the paper's Table 3 domain (PO1-PO3) planned with pyperplan.

The state is {ongoal, obstacle(togoal), obstacle(togoal ± 90°)}, read from the head's range
sensors and the world model (would the body, moved a little that way, come near something
known?). PO1 moves towards the goal; PO2/PO3 sidestep at ±90° until the goal direction has been
clear for ``CLEARANCE`` metres (the effect obstacle(togoal) = F), then PO1 again (§5.1.1, §6.1.1).
Each move(angle, shape) is grounded for one tick by blending library primitives.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from domain.pyperplan_adapter import CancelFlag
from domain.reactive import (
    ReactiveState,
    ReactiveStep,
    plan_reactive,
    reactive_domain,
    reactive_problem,
)
from domain.strategy import Command, Replanned, Situation
from domain.triggers import NoProgress, PathBlocked, ReplanRecord, Trigger
from primitives.grounding import correction_basis, ground
from primitives.library import Library
from sim.controls import FixedShape
from sim.world import footprint

CRUISE_SPEED = 0.06  # m/s (screw speeds stay within ±0.8 rad/s)
THRESHOLD = 0.6  # metres: obstacle(direction) is true below this range
CONE = math.radians(25)  # sensors within this of a direction look that way
CLEARANCE = 0.6  # metres to keep sidestepping after the goal direction is clear
BODY_LOOKAHEAD = 0.3  # metres the body is swept ahead when checking a direction
BODY_MARGIN = 0.08
TICK = 0.25


class ReactiveStrategy:
    """Plans and executes the paper's PO1-PO3 one goal at a time."""

    name = "reactive"

    def __init__(
        self,
        library: Library,
        search: str = "gbf",
        heuristic: str = "hff",
        time_limit: float = 2.0,
    ) -> None:
        self.library = library
        self.search, self.heuristic, self.time_limit = search, heuristic, time_limit
        self.steps: list[ReactiveStep] = []
        self.cleared = 0.0
        self.goal: tuple[float, float] | None = None
        self.shape = "straight"

    # -- sensing -------------------------------------------------------------------------------
    @staticmethod
    def range_towards(s: Situation, direction: float) -> tuple[float, tuple[float, float] | None]:
        """The nearest echo of sensors looking within CONE of a world direction, and where."""
        best, where = math.inf, None
        for _, r in s.ranges:
            gap = abs(math.remainder(r.angle - direction, 2 * math.pi))
            if gap <= CONE and r.hit and not math.isnan(r.distance) and r.distance < best:
                best = r.distance
                where = (
                    r.origin[0] + r.distance * math.cos(r.angle),
                    r.origin[1] + r.distance * math.sin(r.angle),
                )
        return best, where

    @staticmethod
    def body_blocked(s: Situation, direction: float) -> bool:
        """Would the whole body, moved a little in ``direction``, come near something the
        world model holds? The head's sensors cannot see what the trailing body touches."""
        x, y, psi = s.pose
        step = BODY_LOOKAHEAD * np.array([math.cos(direction), math.sin(direction)])
        poses = np.array([[x, y, psi], [x + step[0], y + step[1], psi]])
        fp = footprint(poses, np.asarray(s.joints))
        n = 5
        t = np.linspace(0, 1, n)[:, None, None, None]
        pts = fp.starts[None] + t * (fp.ends - fp.starts)[None]  # [n, 2, 5, 2]
        gap = s.world.clearance_at(pts) - fp.radii
        now, ahead = float(np.min(gap[:, 0])), float(np.min(gap[:, 1]))
        return ahead < BODY_MARGIN and ahead <= now

    def blocked(self, s: Situation, direction: float) -> bool:
        return self.range_towards(s, direction)[0] < THRESHOLD or self.body_blocked(s, direction)

    # -- PlanningStrategy ----------------------------------------------------------------------
    def replan(
        self, situation: Situation, trigger: Trigger, cancel: CancelFlag | None = None
    ) -> Replanned:
        s = situation
        t0 = time.perf_counter()
        goal = s.goals[0]
        self.goal, self.shape = (goal.x, goal.y), s.shape
        to_goal = self._to_goal(s)
        state = ReactiveState(
            False,
            self.blocked(s, to_goal),
            self.blocked(s, to_goal + math.pi / 2),
            self.blocked(s, to_goal - math.pi / 2),
        )
        result, steps = plan_reactive(state, s.shape, self.search, self.heuristic, self.time_limit)
        old = [f"({st.operator.lower()} {st.shape})" for st in self.steps]
        latency = (time.perf_counter() - t0) * 1e3
        record = ReplanRecord(
            trigger.kind, trigger.detail(), round(s.t, 3), latency, old, result.plan, result.status
        )
        self.steps, self.cleared = (steps if result.solved else []), 0.0
        reason = "" if result.solved else f"unreachable: boxed in on three sides ({result.reason})"
        problem = reactive_problem(state, s.shape).text()
        return Replanned(
            result.solved, reason, record, reactive_domain().text(), problem, result.plan
        )

    def broken(self, situation: Situation) -> Trigger | None:
        s = situation
        if self.steps and self.steps[0].operator == "PO1":
            d, where = self.range_towards(s, self._to_goal(s))
            if d < THRESHOLD or self.body_blocked(s, self._to_goal(s)):
                at = where or (s.pose[0], s.pose[1])
                return PathBlocked("po1", (round(at[0], 3), round(at[1], 3)))
        return None

    def command(self, situation: Situation) -> Command | Trigger | None:
        s = situation
        if not s.goals or not self.steps:
            return None
        goal = s.goals[0]
        x, y, _ = s.pose
        to_goal = self._to_goal(s)
        step = self.steps[0]
        action = f"(move {step.operator.lower()} {step.relative_angle:+.0f} {step.shape})"
        if step.operator == "PO1":
            speed = min(CRUISE_SPEED, max(math.hypot(goal.x - x, goal.y - y), 0.005) / 2.0)
            return self._steer(s, to_goal, speed, action)
        side = to_goal + math.radians(step.relative_angle)
        if self.blocked(s, side):
            _d, where = self.range_towards(s, side)
            at = where or (x, y)
            return PathBlocked(action, (round(at[0], 3), round(at[1], 3)))
        if self.blocked(s, to_goal):
            self.cleared = 0.0
        else:
            self.cleared += CRUISE_SPEED * TICK
            if self.cleared >= CLEARANCE:
                self.steps.pop(0)  # effect reached: obstacle(togoal) = F
                self.cleared = 0.0
                return self.command(s)
        return self._steer(s, side, CRUISE_SPEED, action)

    def actions(self) -> list[dict[str, Any]]:
        out = []
        for st in self.steps:
            out.append(
                {
                    "name": st.operator.lower(),
                    "args": [st.shape],
                    "heading": st.relative_angle,
                    "shape": st.shape,
                    "target": None if self.goal is None else {"x": self.goal[0], "y": self.goal[1]},
                    "duration": None,
                    "grounding": {
                        "method": "interpolated",
                        "primitives": [],
                        "relative_to": "goal direction",
                    },
                }
            )
        return out

    # -- helpers -------------------------------------------------------------------------------
    @staticmethod
    def _to_goal(s: Situation) -> float:
        goal = s.goals[0]
        return math.atan2(goal.y - s.pose[1], goal.x - s.pose[0])

    def _steer(
        self, s: Situation, direction: float, speed: float, action: str
    ) -> Command | Trigger:
        """move(angle, shape) for one tick: the shape's short library translations blended
        towards the world ``direction`` (their recorded motions, eqs. 16-18 style)."""
        basis = [e for e in correction_basis(self.library.lattice(s.shape)) if e.turn == 0.0]
        if not basis:
            return NoProgress(action, f"body shape {s.shape} has no primitives in the library")
        duration = max(e.rollout.duration for e in basis)
        local = direction - s.pose[2]  # start frame of the current pose
        offset = (speed * duration * math.cos(local), speed * duration * math.sin(local), 0.0)
        grounded = ground(offset, basis)
        control = FixedShape.of(grounded.theta, np.asarray(s.joints))
        return Command(control, action, grounded.to_dict())
