"""The navigation strategy: plans on the primitive lattice and follows the plan primitive by primitive.

Each ``move`` runs one library primitive's parameters for its duration (a periodic body's, its
gait of whole cycles clocked from the move's first tick). The robot is never
exactly on the lattice, so a move is grounded from the real pose towards the planned state:
the primitive as it is when it lands close enough, else the primitive blended with small
library primitives (``primitives.grounding``). A ``visit`` is a final approach that puts the
tracked point on the goal, also blended from library primitives. Everything known of a
primitive comes from its library entry; nothing probes a simulator or inverts the model.

A move of the gait that a replan cut short leaves the body mid-cycle: the next move waits, the
screws still, while the joints finish the cycle (no jump in the joints, no motion of the body:
the paper's quasi-static joints move nothing without the screws).

The strategy plans and follows; it never recovers. A failure to plan comes back typed
(``Replanned.failure``) for the behaviour tree's recoveries to act on.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from domain.navigation.guard import Lookahead
from domain.navigation.lattice.grid import relative
from domain.navigation.lattice.motions import HeadView, MotionTable, held_joints, motion_table
from domain.navigation.lattice.pddl import lattice_domain_text
from domain.navigation.plan import Failure, Plan, PlanAction, PlanRequest
from domain.navigation.planner import Planner
from domain.pyperplan_adapter import CancelFlag
from domain.strategy import Command, Replanned, Situation
from domain.triggers import NoProgress, PathBlocked, ReplanRecord, Trigger
from primitives.grounding import TICK, Grounded, correction_basis, ground
from primitives.library import Library, Primitive
from primitives.shapes import SHAPES
from sim.controls import PeriodicGait
from sim.robot import rotate


@dataclass
class Running:
    """The grounded move being executed and the model time it has left."""

    action: PlanAction
    grounded: Grounded
    left: float
    started: float | None = None  # model time of its first tick (a gait's clock)
    command: Command | None = None  # every tick's (the move's control does not change)


class NavigationStrategy:
    """Plans on the lattice of the body's shape; executes moves as grounded primitives."""

    name = "navigation"

    def __init__(self, library: Library, planner: Planner, view: HeadView | None = None) -> None:
        self.library = library
        self.planner = planner
        self.settings = planner.settings
        self.view = view if view is not None else HeadView.default()
        self._tables: dict[tuple[str, tuple[float, ...]], MotionTable | None] = {}
        self._bases: dict[str, tuple[Library, list[Primitive]]] = {}
        self.plan: Plan | None = None
        self.table: MotionTable | None = None
        self.index = 0
        self.running: Running | None = None
        self.arrive_tries = 0
        self._checked: tuple[int, int] = (-1, -1)  # (world version, plan index) last checked
        self._lookahead = Lookahead(self.settings.follow.lookahead)
        self._gait: PeriodicGait | None = None  # the last gait move's control (its clock)

    # -- the lattice of the current body --------------------------------------------------------
    def table_for(self, shape: str, joints: Sequence[float]) -> MotionTable | None:
        """The table of the body: held joints as sensed, or a gait's start shape (the joints
        a gait's sensors read move on purpose)."""
        known = SHAPES.get(shape)
        key = (shape, held_joints(known.joints if known and known.periodic else joints))
        if key not in self._tables:
            self._tables[key] = motion_table(self.library, shape, key[1], self.settings, self.view)
        return self._tables[key]

    def basis(self, shape: str) -> list[Primitive]:
        """The shape's correction basis in the library as it is now (made once per library
        and shape: every move grounds with it)."""
        got = self._bases.get(shape)
        if got is None or got[0] is not self.library:  # (learning brings a new library)
            got = self._bases[shape] = (self.library, correction_basis(self.library.lattice(shape)))
        return got[1]

    # -- PlanningStrategy ----------------------------------------------------------------------
    def replan(
        self, situation: Situation, trigger: Trigger, cancel: CancelFlag | None = None
    ) -> Replanned:
        s = situation
        t0 = time.perf_counter()
        old = self.plan.pddl_plan[self.index :] if self.plan else []
        table = self.table_for(s.shape, s.joints)
        self.running, self.index, self.arrive_tries = None, 0, 0
        if table is None:
            out: Plan | Failure = Failure(
                "no_primitives", f"body shape {s.shape} has no primitives in the library"
            )
        else:
            request = PlanRequest(
                tuple(float(v) for v in s.pose),  # type: ignore[arg-type]
                table,
                s.goals,
                s.ordered,
                s.world,
                cancel,
            )
            out = self.planner.plan(request)
        self.plan = out if isinstance(out, Plan) else None
        self.table = table
        self._checked = (s.world.version, 0)
        latency = (time.perf_counter() - t0) * 1e3
        new = out.pddl_plan if isinstance(out, Plan) else []
        status = "solved" if isinstance(out, Plan) else out.status
        record = ReplanRecord(
            trigger.kind, trigger.detail(), round(s.t, 3), latency, old, new, status
        )
        plan = out if isinstance(out, Plan) else None

        def export() -> str:  # the plan's graph is not changed after this replan
            problem = plan.problem() if plan is not None else None
            return problem.text() if problem is not None else ""

        if plan is None:
            assert isinstance(out, Failure)
            return Replanned(
                False,
                out.reason,
                record,
                lattice_domain_text(),
                export,
                failure=out.kind,
                proof=out.proof,
            )
        reason = "partial" if plan.partial else ""
        return Replanned(
            True, reason, record, lattice_domain_text(), export, new, release=plan.release
        )

    def broken(self, situation: Situation) -> Trigger | None:
        """Re-check the next moves' swept footprints whenever the lethal layer changed."""
        plan, table = self.plan, self.table
        if plan is None or table is None:
            return None
        now = (situation.world.version, self.index)
        if now == self._checked:
            return None
        self._checked = now
        first = self.index + (1 if self.running is not None else 0)
        blocked = self._lookahead.first_blocked(
            plan,
            table,
            first,
            self.planner.grid,
            self.settings.margin,
            situation.world.clearance_at,
            situation.world.version,
        )
        if blocked is None:
            return None
        action, (x, y) = blocked
        return PathBlocked(action.pddl, (round(x, 3), round(y, 3)))

    def command(self, situation: Situation) -> Command | Trigger | None:
        plan, table = self.plan, self.table
        if plan is None or table is None:
            return None
        follow = self.settings.follow
        while True:
            if self.running is not None:
                if self.running.left > 1e-9:
                    if self.running.started is None:  # its first tick
                        settle = self._finish_cycle(self.running, situation.t)
                        if settle is not None:
                            return settle
                        self.running.started = situation.t
                    self.running.left -= TICK
                    return self._command(self.running)
                done, self.running = self.running.action, None
                if done.name == "move":
                    self.index += 1
                    off = self._offset(situation, done.target)
                    if (
                        math.hypot(off[0], off[1]) > follow.off_plan
                        or abs(off[2]) > follow.off_plan_turn
                    ):
                        return NoProgress(done.pddl, "the move ended far from its planned state")
            if self.index >= len(plan.actions):
                return None
            action = plan.actions[self.index]
            if action.name == "visit":
                remaining = {g.index for g in situation.goals}
                if action.goal not in remaining:
                    self.index += 1
                    self.arrive_tries = 0
                    continue
                self.arrive_tries += 1
                if self.arrive_tries > follow.arrive_tries:
                    return NoProgress(action.pddl, "the final approach did not reach the goal")
                self.running = self._approach(situation, table, action)
                continue
            off = self._offset(situation, action.target)
            if (
                math.hypot(off[0], off[1]) > follow.off_plan + 0.3
                or abs(off[2]) > follow.off_plan_turn + 0.3
            ):
                return NoProgress(action.pddl, "the robot is off the plan")
            assert action.primitive is not None
            entry = self.library.get(action.primitive)
            grounded = ground(off, self.basis(table.shape), entry)
            self.running = Running(action, grounded, grounded.duration)

    def actions(self) -> list[dict[str, Any]]:
        if self.plan is None:
            return []
        out = []
        for i, a in enumerate(self.plan.actions):
            verb, *args = a.pddl.strip("()").split()
            grounding: dict[str, Any] = {
                "method": "library",
                "primitives": [a.primitive] if a.primitive else [],
            }
            if self.running is not None and i == self.index:
                grounding = self.running.grounded.to_dict()
            out.append(
                {
                    "name": verb,
                    "args": args,
                    "heading": math.degrees(a.target[2]),
                    "shape": self.table.shape if self.table else None,
                    "target": {"x": a.target[0], "y": a.target[1]},
                    "duration": a.duration,
                    "cost": round(a.cost, 4),
                    "grounding": grounding,
                    "goal": a.goal,
                }
            )
        return out

    def forget(self) -> None:
        """Drop the plan (a recovery moved the robot: the next tick plans afresh)."""
        self.plan, self.running, self.index, self._gait = None, None, 0, None

    # -- helpers -------------------------------------------------------------------------------
    @staticmethod
    def _offset(situation: Situation, target: tuple[float, float, float]) -> np.ndarray:
        return relative(situation.pose, target)

    def _approach(self, situation: Situation, table: MotionTable, action: PlanAction) -> Running:
        """A final approach that puts the tracked point on the goal, heading kept."""
        goal = next(g for g in situation.goals if g.index == action.goal)
        x, y, psi = situation.pose
        d = rotate(np.array([goal.x - x, goal.y - y]), np.array(-psi))
        basis = [e for e in self.basis(table.shape) if e.turn == 0.0]
        grounded = ground((float(d[0]), float(d[1]), 0.0), basis)
        return Running(action, grounded, grounded.duration)

    def _command(self, running: Running) -> Command:
        if running.command is not None:
            return running.command
        g = running.grounded
        assert running.started is not None
        control = g.control(running.started)
        if isinstance(control, PeriodicGait):
            self._gait = control
        running.command = Command(control, running.action.pddl, g.to_dict(), None)
        return running.command

    def _finish_cycle(self, running: Running, t: float) -> Command | None:
        """Before a gait move, while the last gait move's cycles are not over (a replan cut it
        short): one tick of that gait with the screws still, so the joints end the cycle in
        the shape the next move starts from."""
        gait = self._gait
        if running.grounded.phases is None or gait is None or t >= gait.t_end - 1e-9:
            return None
        still = PeriodicGait(
            np.zeros_like(gait.theta), gait.phases, gait.amplitude, gait.omega, gait.t0, gait.t_end
        )
        grounding: dict[str, object] = {"method": "gait", "primitives": [], "duration": TICK}
        return Command(still, "(finish the gait cycle)", grounding, None)
