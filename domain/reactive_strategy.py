"""The reactive strategy: the paper's Table 3 domain (PO1-PO3) planned with pyperplan, each
operator grounded by Table 2 primitives as in Figs. 9b and 10 (§6.1, §6.1.1).

The state is {ongoal, obstacle(togoal), obstacle(togoal ± 90°)}, read from the range sensors
(below ``threshold``) and the world model (would the body, moved a little that way, come near
something known?). Angles follow the paper's labels, which read clockwise in our frame
(docs/robot-model.md, "Frames and the paper's angle labels"): PO2's "angletoGoal + 90°" is the world direction to the goal minus 90°,
the side P2 moves to.

Grounding, from library data only (primitives/paper_moves.py), evaluated every control tick
as the paper's planner evaluates "at every action interval" (§5.1.1):
- PO1, move(angletoGoal, shape): the primitive the mission selected (Fig. 10's P4s) while it
  goes that way, else the shape's primitive or the paper's interpolation (eqs. 16-18) of its
  quadrant primitives towards the goal ("Set 1"; after a deformation the new shape's, Fig. 13b's
  IM4 from P10, P11, P12). Re-aiming every tick keeps the direction although our learned
  primitives turn the body as they go.
- PO2/PO3: the selected primitive, else the shape's Table 2 primitive nearest their direction
  (P2s and P6s from a straight start), run as it is until the goal direction has been clear
  for ``clearance`` metres of travel (the effect obstacle(togoal) = F).
- With ``timeout_return`` (Fig. 9b), after an avoidance PO1 goes back to Set 1 (its first world
  direction) for a time-out, then runs the other side's primitive (P6s) back towards the goal;
  the two durations split the offset to the goal with the library's velocities. Then PO1 aims
  at the goal again for what is left.
- Correction steps (the shape's short lattice primitives blended, primitives/grounding.py)
  take the last ``APPROACH`` metres, and over from a paper move that keeps leading away.
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
from domain.reactive_aim import ChordBias, Leg
from domain.strategy import Command, Replanned, Situation
from domain.triggers import NoProgress, PathBlocked, ReplanRecord, Trigger
from primitives.grounding import correction_basis, ground
from primitives.library import Library, Primitive
from primitives.paper_moves import Move, aim, nearest, of_entry, split
from sim.controls import FixedShape
from sim.world import footprint

THRESHOLD = 0.6  # metres: obstacle(direction) is true below this range
CONE = math.radians(25)  # sensors within this of a direction look that way
CLEARANCE = 0.6  # metres to keep sidestepping after the goal direction is clear
BODY_LOOKAHEAD = 0.3  # metres the body is swept ahead when checking a direction
BODY_MARGIN = 0.08
_ALONG = np.linspace(0, 1, 5)[:, None, None, None]  # where along each capsule the body is checked
APPROACH = 0.25  # metres from the goal where short library primitives take over
ASTRAY_TICKS = 8  # ticks moving away from the goal before correction steps take over
CORRECTION_TICKS = 40  # ... and how many ticks they then keep it
CORRECTION_SPEED = 0.04  # m/s of a correction step (screw speeds well within their limits)
REARM = 0.8  # PO1 breaks on a range below this fraction of the threshold (no chattering at it)
MIN_RETURN = 0.02  # metres: a return move shorter than this is left to the next leg
OPERATORS = ("po1", "po2", "po3")


class ReactiveStrategy:
    """Plans and executes the paper's PO1-PO3 one goal at a time."""

    name = "reactive"

    def __init__(
        self,
        library: Library,
        search: str = "gbf",
        heuristic: str = "hff",
        time_limit: float = 2.0,
        operators: dict[str, str] | None = None,
        threshold: float = THRESHOLD,
        clearance: float = CLEARANCE,
        timeout_return: bool = False,
    ) -> None:
        self.library = library
        self.search, self.heuristic, self.time_limit = search, heuristic, time_limit
        self.operators = dict(operators or {})
        for op, name in self.operators.items():
            if op not in OPERATORS:
                raise ValueError(f"operators: unknown operator {op!r} (po1, po2, po3)")
            if library.get(name).periodic:  # KeyError names a primitive the library lacks
                raise ValueError(f"operators: {name} is periodic (no fixed shape to hold)")
        self.threshold, self.clearance = threshold, clearance
        self.timeout_return = timeout_return
        self.set1_direction: float | None = None  # world direction of Set 1 (PO1's first move)
        self.last_po1: Move | None = None
        self.approach = APPROACH
        self.astray = 0  # ticks a paper move carried the robot away from the goal
        self.correcting = 0  # ticks of correction steps left after it went astray
        self.chord = ChordBias()  # per move: the angle its one-tick motion makes with its chord
        self.steps: list[ReactiveStep] = []
        self.goal: tuple[float, float] | None = None
        self.side: Move | None = None  # the running avoidance's move
        self.legs: list[Leg] = []  # PO1's queue: Set 1 for a time-out, then a return
        self.cleared = 0.0
        self.last_xy: tuple[float, float] | None = None

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
        pts = fp.starts[None] + _ALONG * (fp.ends - fp.starts)[None]  # [n, 2, 5, 2]
        gap = s.world.clearance_at(pts) - fp.radii
        now, ahead = float(np.min(gap[:, 0])), float(np.min(gap[:, 1]))
        return ahead < BODY_MARGIN and ahead <= now

    def blocked(self, s: Situation, direction: float) -> bool:
        near = self.range_towards(s, direction)[0] < self.threshold
        return near or self.body_blocked(s, direction)

    # -- grounding -----------------------------------------------------------------------------
    def named(self, s: Situation, op: str) -> Primitive | None:
        """The primitive the mission selected for ``op``, if the body can take its shape."""
        name = self.operators.get(op)
        if name is None:
            return None
        entry = self.library.get(name)
        return entry if entry.shape == s.shape or not s.deformed else None

    def toward(self, s: Situation, world_direction: float) -> Move:
        """PO1's grounding towards a world direction from the current pose: the selected
        primitive when it goes that way, else the shape's primitive or interpolation."""
        entry = self.named(s, "po1")
        shape = entry.shape if entry is not None else s.shape
        local = world_direction - s.pose[2]
        keep = (self.last_po1.quadrant or None) if self.last_po1 is not None else None
        want = (math.cos(local), math.sin(local))
        move = aim(self.library, shape, want, entry, snap=False, keep=keep)
        bias = self.chord.get(move)
        if bias is None:
            return move
        # A primitive reaches its recorded end along an arc (it turns the body as it goes), so
        # over one tick it moves off its chord by an angle the last ticks measured: aim past it.
        local -= bias
        want = (math.cos(local), math.sin(local))
        # ... within the quadrant the goal's own direction chose: the same three sources
        keep = move.quadrant or None
        return aim(self.library, shape, want, entry, snap=False, keep=keep, force_keep=True)

    def _observe(self, s: Situation) -> None:
        """Learn from the last tick's motion; count ticks a paper move led away from the goal."""
        motion = self.chord.observe(s.pose, s.shape)
        if motion is None or self.goal is None or not self.steps:
            return
        if self.steps[0].operator == "PO1":
            x, y = s.pose[0] - motion[0], s.pose[1] - motion[1]
            to_goal = math.atan2(self.goal[1] - y, self.goal[0] - x)
            off = abs(math.remainder(math.atan2(motion[1], motion[0]) - to_goal, 2 * math.pi))
            if off > math.pi / 2:
                self.astray += 1

    def side_move(self, s: Situation, op: str, world_direction: float) -> Move:
        """PO2/PO3's grounding: the selected primitive, else the shape's Table 2 primitive
        nearest the direction (P2s and P6s from a straight start), run as it is."""
        entry = self.named(s, op)
        if entry is not None:
            return of_entry(entry)
        return nearest(self.library, s.shape, world_direction - s.pose[2])

    @staticmethod
    def side_direction(to_goal: float, relative_angle: float) -> float:
        """World direction of "angletoGoal + relative_angle" in the paper's clockwise labels."""
        return to_goal - math.radians(relative_angle)

    # -- PlanningStrategy ----------------------------------------------------------------------
    def replan(
        self, situation: Situation, trigger: Trigger, cancel: CancelFlag | None = None
    ) -> Replanned:
        s = situation
        t0 = time.perf_counter()
        goal = s.goals[0]
        if self.goal != (goal.x, goal.y):
            self.set1_direction = None  # a new goal gets its own Set 1
        self.goal = (goal.x, goal.y)
        to_goal = self._to_goal(s)
        state = ReactiveState(
            False,
            self.blocked(s, to_goal),
            self.blocked(s, self.side_direction(to_goal, 90.0)),
            self.blocked(s, self.side_direction(to_goal, -90.0)),
        )
        result, steps = plan_reactive(state, s.shape, self.search, self.heuristic, self.time_limit)
        old = [f"({st.operator.lower()} {st.shape})" for st in self.steps]
        latency = (time.perf_counter() - t0) * 1e3
        record = ReplanRecord(
            trigger.kind, trigger.detail(), round(s.t, 3), latency, old, result.plan, result.status
        )
        self.steps = steps if result.solved else []
        self.side, self.legs, self.cleared = None, [], 0.0
        reason = "" if result.solved else f"unreachable: boxed in on three sides ({result.reason})"
        shape = s.shape
        return Replanned(
            result.solved,
            reason,
            record,
            reactive_domain().text(),
            lambda: reactive_problem(state, shape).text(),
            result.plan,
        )

    def broken(self, situation: Situation) -> Trigger | None:
        s = situation
        if self.steps and self.steps[0].operator == "PO1":
            if self.legs and self.legs[0].action.startswith("(return"):
                return None  # a return move is checked on its own side by ``command``
            ahead = self._to_goal(s)
            if self.legs and self.legs[0].move is None and self.set1_direction is not None:
                ahead = self.set1_direction  # the time-out runs parallel to the first line
            d, where = self.range_towards(s, ahead)
            if d < REARM * self.threshold or self.body_blocked(s, ahead):
                at = where or (s.pose[0], s.pose[1])
                return PathBlocked("po1", (round(at[0], 3), round(at[1], 3)))
        return None

    def command(self, situation: Situation) -> Command | Trigger | None:
        s = situation
        self._observe(s)
        if not s.goals or not self.steps:
            return None
        step = self.steps[0]
        try:
            if step.operator == "PO1":
                return self._po1(s, step)
            return self._avoid(s, step)
        except KeyError as exc:
            return NoProgress(f"({step.operator.lower()} {s.shape})", str(exc).strip("'\""))

    def _po1(self, s: Situation, step: ReactiveStep) -> Command | Trigger:
        assert self.goal is not None
        to_goal = self._to_goal(s)
        if self.set1_direction is None:
            self.set1_direction = to_goal  # Set 1: the move towards the goal, from the start
        while self.legs:
            leg = self.legs[0]
            if leg.started is None:
                leg.started = s.t
            if s.t - leg.started < leg.seconds - 1e-9:
                break
            self.legs.pop(0)
        if not self.legs:
            goal_distance = math.hypot(self.goal[0] - s.pose[0], self.goal[1] - s.pose[1])
            if self.astray >= ASTRAY_TICKS:
                self.correcting = CORRECTION_TICKS  # the paper move went astray: correct a while
                self.astray = 0
            if goal_distance < self.approach or self.correcting > 0:
                self.correcting = max(0, self.correcting - 1)
                return self._correct(s, to_goal, f"(po1 {s.shape} approach)")
            self.last_po1 = self.toward(s, to_goal)
            return self._run(s, self.last_po1, f"(po1 {self._shape_of_po1(s)})")
        leg = self.legs[0]
        if leg.move is None:  # back to Set 1 for the time-out
            self.last_po1 = self.toward(s, self.set1_direction)
            return self._run(s, self.last_po1, leg.action)
        direction = s.pose[2] + leg.move.direction
        if self.blocked(s, direction):
            _d, where = self.range_towards(s, direction)
            at = where or (s.pose[0], s.pose[1])
            return PathBlocked(leg.action, (round(at[0], 3), round(at[1], 3)))
        return self._run(s, leg.move, leg.action)

    def _shape_of_po1(self, s: Situation) -> str:
        entry = self.named(s, "po1")
        return entry.shape if entry is not None else s.shape

    def _time_out(self, s: Situation, avoided: str) -> list[Leg]:
        """Fig. 9b after an avoidance: Set 1 (its first world direction) for a time-out, then
        the other side's primitive back onto the goal; the two durations split the offset to
        the goal with the library's velocities. None when the split has no positive answer."""
        assert self.goal is not None and self.set1_direction is not None
        other = "po3" if avoided == "po2" else "po2"
        to_goal = self._to_goal(s)
        back = self.side_move(
            s, other, self.side_direction(to_goal, 90.0 if other == "po2" else -90.0)
        )
        set1 = self.toward(s, self.set1_direction)
        psi = s.pose[2]
        rot = np.array([[math.cos(psi), -math.sin(psi)], [math.sin(psi), math.cos(psi)]])
        offset = (self.goal[0] - s.pose[0], self.goal[1] - s.pose[1])
        seconds = split(offset, rot @ set1.velocity, rot @ back.velocity)
        if seconds is None:
            return []
        a, b = seconds
        shape = self._shape_of_po1(s)
        legs = [Leg(f"(po1 {shape})", None, a)]
        if b * float(np.linalg.norm(back.velocity)) >= MIN_RETURN:
            legs.append(Leg(f"(return {other} {back.shape})", back, b))
        return legs

    def _avoid(self, s: Situation, step: ReactiveStep) -> Command | Trigger:
        to_goal = self._to_goal(s)
        op = step.operator.lower()
        side = self.side_direction(to_goal, step.relative_angle)
        if self.side is None:
            self.side = self.side_move(s, op, side)
            self.last_xy = (s.pose[0], s.pose[1])
        action = f"({op} {self.side.shape})"
        if self.blocked(s, side):
            _d, where = self.range_towards(s, side)
            at = where or (s.pose[0], s.pose[1])
            return PathBlocked(action, (round(at[0], 3), round(at[1], 3)))
        moved = math.dist(self.last_xy or s.pose[:2], s.pose[:2])
        self.last_xy = (s.pose[0], s.pose[1])
        if self.blocked(s, to_goal):
            self.cleared = 0.0
        else:
            self.cleared += moved
            if self.cleared >= self.clearance:
                self.steps.pop(0)  # effect reached: obstacle(togoal) = F
                self.side, self.cleared = None, 0.0
                self.legs = self._time_out(s, op) if self.timeout_return else []
                after = self.command(s)
                return after if after is not None else NoProgress(action, "plan finished")
        return self._run(s, self.side, action)

    def _correct(self, s: Situation, direction: float, action: str) -> Command | Trigger:
        """A correction step from the library's short primitives: the body shape's lattice
        translations blended towards ``direction`` for one tick (their recorded end poses,
        primitives/grounding.py), used for the last ``approach`` metres and when a paper move
        keeps carrying the robot away from the goal."""
        basis = [e for e in correction_basis(self.library.lattice(s.shape)) if e.turn == 0.0]
        if not basis:
            return NoProgress(
                action, f"body shape {s.shape} has no short primitives in the library"
            )
        duration = max(e.rollout.duration for e in basis)
        local = direction - s.pose[2]
        assert self.goal is not None
        speed = min(CORRECTION_SPEED, math.dist(self.goal, s.pose[:2]) / 2.0)
        offset = (speed * duration * math.cos(local), speed * duration * math.sin(local), 0.0)
        grounded = ground(offset, basis)
        control = FixedShape.of(grounded.theta, np.asarray(s.joints))
        self.chord.forget_tick()
        return Command(control, action, grounded.to_dict())

    def _run(self, s: Situation, move: Move, action: str) -> Command:
        joints = np.asarray(s.joints) if s.deformed else move.joints
        control = FixedShape.of(move.theta, joints)
        self.chord.commanded(move, s.pose, s.shape if s.deformed else move.shape)
        shape = None if s.deformed else move.shape
        return Command(control, action, move.grounding(), shape)

    def actions(self) -> list[dict[str, Any]]:
        out = []
        for i, st in enumerate(self.steps):
            op = st.operator.lower()
            move = self.last_po1 if op == "po1" else (self.side if i == 0 else None)
            grounding: dict[str, Any] = {"relative_to": "goal direction (paper labels)"}
            if move is not None:
                grounding.update(move.grounding())
            else:
                grounding.update({"method": "library", "primitives": []})
                if op in self.operators:
                    grounding["primitives"] = [self.library.get(self.operators[op]).id]
            out.append(
                {
                    "name": op,
                    "args": [st.shape],
                    "heading": st.relative_angle,
                    "shape": st.shape if move is None else move.shape,
                    "target": None if self.goal is None else {"x": self.goal[0], "y": self.goal[1]},
                    "duration": None,
                    "grounding": grounding,
                }
            )
        return out

    # -- helpers -------------------------------------------------------------------------------
    @staticmethod
    def _to_goal(s: Situation) -> float:
        goal = s.goals[0]
        return math.atan2(goal.y - s.pose[1], goal.x - s.pose[0])
