"""The navigation strategy: plans on the primitive lattice and runs the plan primitive by primitive.

Each ``move`` runs one library primitive's parameters for its duration. The robot is never
exactly on the lattice, so a move is grounded from the real pose towards the planned state:
the primitive as it is when it lands close enough, else the primitive blended with small
library primitives (``primitives.grounding``). A ``visit`` is a final approach that puts the
tracked point on the goal, also blended from library primitives. Everything known of a
primitive comes from its library entry; nothing probes a simulator or inverts the model.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from domain.clearance_tiers import Tier, tier_clearance
from domain.lattice import LatticeSettings, MotionTable, compose, motion_table, relative
from domain.lattice_pddl import lattice_domain_text
from domain.lattice_plan import LatticeAction, LatticePlan
from domain.lattice_planner import LatticePlanner
from domain.lattice_task import LatticeTask, primitive_name
from domain.plan_guard import Lookahead
from domain.pyperplan_adapter import CancelFlag
from domain.reshape import reshape_clear, reshape_duration
from domain.strategy import Command, Replanned, Situation
from domain.tier_walk import TierWalk
from domain.triggers import Contact, NoProgress, PathBlocked, ReplanRecord, Trigger
from primitives.grounding import TICK, Grounded, correction_basis, ground
from primitives.library import Library, Primitive
from primitives.shapes import SHAPES
from sim.controls import FixedShape
from sim.robot import rotate

OFF_PLAN = (0.3, math.radians(35))  # further than this from a planned state: replan
ARRIVE_TRIES = 4  # final approaches to one goal before giving up on the plan
LOOKAHEAD = 16  # plan steps re-checked against the world model when it changes
BACK_OFF = {"front": 0, "rear": 180, "left": 90, "right": 270}  # body angle away from a side
BACK_OFF_STEPS = 2  # short library translations away from a contact before replanning
MAX_REPAIRS = 4  # local plan repairs in a row before the whole way is planned again
MAX_RECOVERIES = 3  # recovery spins after a planning timeout before the mission fails
SPIN_STEPS = 1  # turns of a recovery spin (each checked free before it runs)
TURNS_BEFORE_LONG = 1  # recovery turns to sense before a long search (``TierWalk.plan``)


@dataclass
class Running:
    """The grounded move being executed and the model time it has left."""

    action: LatticeAction
    grounded: Grounded
    left: float


def held_joints(joints: Sequence[float]) -> tuple[float, float, float]:
    """The joint angles a body's lattice is made for: the sensed ones to 0.05 rad (the
    footprint of the real body; one motion table per rounded shape)."""
    a, b, c = (round(v / 0.05) * 0.05 for v in joints)
    return (a, b, c)


class NavigationStrategy:
    """Plans on the lattice of the body's shape; executes moves as grounded primitives."""

    name = "navigation"

    def __init__(
        self,
        library: Library,
        planner: LatticePlanner,
    ) -> None:
        self.library = library
        self.planner = planner
        self.settings: LatticeSettings = planner.settings
        self._tables: dict[tuple[str, tuple[float, ...]], MotionTable | None] = {}
        self.plan: LatticePlan | None = None
        self.table: MotionTable | None = None
        self.index = 0
        self.running: Running | None = None
        self.arrive_tries = 0
        self._checked: tuple[int, int] = (-1, -1)  # (world version, plan index) last checked
        self._lookahead = Lookahead(LOOKAHEAD)  # the next moves' sweeps the guard checks
        self.clearance: Any = None  # what plans are checked against (sensed cells inflated)
        self.backoff: list[Primitive] = []
        self.recoveries = 0
        self.repairs = 0  # plans repaired in a row since the last full plan
        self.tiers = TierWalk(planner)  # which tier's plan runs, and which tiers are doubted

    # -- the lattice of the current body --------------------------------------------------------
    def table_for(self, shape: str, joints: tuple[float, float, float]) -> MotionTable | None:
        key = (shape, held_joints(joints))
        if key not in self._tables:
            self._tables[key] = motion_table(self.library, shape, key[1], self.settings)
        return self._tables[key]

    # -- PlanningStrategy ----------------------------------------------------------------------
    def replan(
        self, situation: Situation, trigger: Trigger, cancel: CancelFlag | None = None
    ) -> Replanned:
        s = situation
        t0 = time.perf_counter()
        old = self.plan.pddl_plan[self.index :] if self.plan else []
        table = self.table_for(s.shape, s.joints)
        # What remains of a full plan on this lattice may only need a local repair.
        # Repairs keep the old plan's far part, planned on older knowledge: only for what the
        # range sensors found on the way (a contact says the old plan ran along something
        # unseen: it is planned again whole), and after a few in a row, the whole way again.
        remaining: list[LatticeAction] = []
        last = self.plan
        if (
            last is not None
            and last.solved
            and not last.partial
            and table is self.table
            and isinstance(trigger, PathBlocked)
            and self.repairs < MAX_REPAIRS
        ):
            remaining = last.actions[self.index :]
        self.running, self.index, self.arrive_tries = None, 0, 0
        if table is None:
            self.plan = LatticePlan(
                "no-primitives", f"body shape {s.shape} has no primitives in the library"
            )
        else:
            self.backoff = self._back_off(trigger, table) if isinstance(trigger, Contact) else []
            pose = np.asarray(s.pose, dtype=float)
            for entry in self.backoff:  # plan from where backing off will leave the robot
                pose = compose(pose, np.asarray(entry.end_pose))
            table = self._plan(table, s, pose, cancel, remaining)
        self.table = table
        latency = (time.perf_counter() - t0) * 1e3
        plan = self.plan
        assert plan is not None  # both branches above set it
        record = ReplanRecord(
            trigger.kind, trigger.detail(), round(s.t, 3), latency, old, plan.pddl_plan, plan.status
        )
        first = plan.actions[0] if plan.actions else None
        reshaped = s.shape if first is not None and first.name == "reshape" else None
        lattice_shape = table.shape if table is not None else s.shape
        self._checked = (s.world.version, 0)

        def export() -> str:  # the plan's graph is not changed after this replan
            if plan.status == "cancelled":
                return ""  # no plan, and its graph may be a whole grounded lattice to write
            exported = plan.problem(lattice_shape, reshaped)
            return exported.text() if exported is not None else ""

        return Replanned(
            plan.solved,
            plan.reason,
            record,
            lattice_domain_text(),
            export,
            plan.pddl_plan,
            plan.release,
        )

    def _plan(
        self,
        table: MotionTable,
        s: Situation,
        pose: Any,
        cancel: CancelFlag | None,
        remaining: Sequence[LatticeAction],
    ) -> MotionTable:
        """Plans from ``pose`` (``self.plan``, kept against ``self.clearance``); returns the
        table of the shape it runs on. When no tier finds a way near, the robot turns in place
        to sense (Nav2-style recovery) before any tier searches long (``TURNS_BEFORE_LONG``);
        after a long search that finds none either, it turns again, up to ``MAX_RECOVERIES``
        times, and the timeout then stands. A shape that finds no plan tries the others first
        (``_reshaped``)."""
        long = self.recoveries >= TURNS_BEFORE_LONG
        self.plan, self.clearance = self.tiers.plan(table, s, pose, cancel, remaining, long=long)
        spin: list[Primitive] = []
        if self.plan.status == "timeout" and not long:
            spin = self._spin(table, pose)
            if not spin:  # no free turn to sense with: search long at once
                long = True
                self.plan, self.clearance = self.tiers.plan(
                    table, s, pose, cancel, remaining, probed=True
                )
        status = self.plan.status
        gave_up = status in ("unreachable", "unsolvable") or (status == "timeout" and long)
        if gave_up and not s.deformed:
            table = self._reshaped(table, s, pose, cancel) or table
        if cancel is not None and cancel.is_set() and self.plan.status != "cancelled":
            # (cancelled between searches, e.g. before the looser tiers' probes: what the walk
            # ended in is no answer, and no turn to sense is handed out for the mission to run)
            self.plan = LatticePlan("cancelled", "planning cancelled")
            return table
        self.repairs = self.repairs + 1 if self.plan.repaired else 0
        if self.plan.solved and not self.plan.partial:
            self.recoveries = 0
        elif self.plan.status == "timeout" and self.recoveries < MAX_RECOVERIES:
            spin = spin or self._spin(table, pose)
            if spin:
                self.recoveries += 1
                self.backoff += spin
                self.plan = LatticePlan("solved", "recovery", partial=True)
        return table

    def _reshaped(
        self,
        table: MotionTable,
        s: Situation,
        pose: Any,
        cancel: CancelFlag | None,
    ) -> MotionTable | None:
        """When the body's shape finds no plan: the nearest other library shape that can be
        taken here (its sweep keeps the margin) and finds one. The plan starts with the change;
        returns the new shape's table (``None`` if no shape helps, the plan left as it was)."""
        here = np.asarray(table.joints, dtype=float)
        others = sorted(
            (name for name in self.library.lattice_shapes() if name != table.shape),
            key=lambda name: float(np.max(np.abs(np.asarray(SHAPES[name].joints) - here))),
        )
        clearance = tier_clearance(s.world, Tier("none"))
        for name in others:
            if cancel is not None and cancel.is_set():
                return None  # a cancelled mission tries no other shape
            joints = tuple(float(v) for v in SHAPES[name].joints)
            other = self.table_for(name, (joints[0], joints[1], joints[2]))
            if other is None or not reshape_clear(
                pose, table.joints, joints, clearance, self.settings.margin
            ):
                continue
            if not self.tiers.may_reach(other, s, pose, cancel):
                continue  # not even the loosest tier lets this body through: skip its searches
            plan, kept = self.tiers.plan(other, s, pose, cancel)
            if not plan.solved or plan.partial:
                continue  # change shape only for a way all the way there
            target = (float(pose[0]), float(pose[1]), float(pose[2]))
            change = LatticeAction(
                "reshape",
                f"(reshape {primitive_name(table.shape)} {primitive_name(name)})",
                None,
                target,
                reshape_duration(table.joints, joints, TICK),
            )
            plan.actions.insert(0, change)
            # (only a plan that runs changes what is guarded: a recovery turn after shapes
            # that found none is checked against this shape's tier, not the last one tried)
            self.plan, self.clearance = plan, kept
            return other
        return None

    def broken(self, situation: Situation) -> Trigger | None:
        """Re-check the next moves' swept footprints whenever the world model changed."""
        plan, table = self.plan, self.table
        if plan is None or table is None or not plan.solved:
            return None
        now = (situation.world.version, self.index)
        if now == self._checked:
            return None
        self._checked = now
        first = self.index + (1 if self.running is not None else 0)
        blocked = self._lookahead.first_blocked(
            plan, table, first, self.planner.grid, self.settings.margin, self.clearance
        )
        if blocked is None:
            return None
        action, (x, y) = blocked
        return PathBlocked(action.pddl, (round(x, 3), round(y, 3)))

    def command(self, situation: Situation) -> Command | Trigger | None:
        plan, table = self.plan, self.table
        if plan is None or table is None or not plan.solved:
            return None
        while True:
            if self.running is None and self.backoff:
                entry = self.backoff.pop(0)
                assert entry.end_pose is not None
                grounded = ground(entry.end_pose, [], entry)  # the primitive as it is
                name = f"(back-off {entry.id})"
                action = LatticeAction(
                    "back-off", name, entry.id, situation.pose, grounded.duration
                )
                self.running = Running(action, grounded, grounded.duration)
            if self.running is not None:
                if self.running.left > 1e-9:
                    self.running.left -= TICK
                    return self._command(self.running)
                done, self.running = self.running.action, None
                if done.name == "back-off":
                    continue
                if done.name == "reshape":
                    self.index += 1
                    continue
                if done.name == "move":
                    self.index += 1
                    off = self._offset(situation, done.target)
                    if math.hypot(off[0], off[1]) > OFF_PLAN[0] or abs(off[2]) > OFF_PLAN[1]:
                        return NoProgress(done.pddl, "the move ended far from its planned state")
            if self.index >= len(plan.actions):
                return None
            action = plan.actions[self.index]
            if action.name == "reshape":
                joints = np.asarray(table.joints, dtype=float)
                change = Grounded(np.zeros(4), joints, action.duration, "library", (), np.zeros(3))
                self.running = Running(action, change, action.duration)
                continue
            if action.name == "visit":
                remaining = {g.index for g in situation.goals}
                if action.goal not in remaining:
                    self.index += 1
                    self.arrive_tries = 0
                    continue
                self.arrive_tries += 1
                if self.arrive_tries > ARRIVE_TRIES:
                    return NoProgress(action.pddl, "the final approach did not reach the goal")
                self.running = self._approach(situation, table, action)
                continue
            off = self._offset(situation, action.target)
            if math.hypot(off[0], off[1]) > OFF_PLAN[0] + 0.3 or abs(off[2]) > OFF_PLAN[1] + 0.3:
                return NoProgress(action.pddl, "the robot is off the plan")
            assert action.primitive is not None
            entry = self.library.get(action.primitive)
            grounded = ground(off, correction_basis(self.library.lattice(table.shape)), entry)
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
                    "grounding": grounding,
                    "goal": a.goal,
                }
            )
        return out

    # -- helpers -------------------------------------------------------------------------------
    @staticmethod
    def _offset(situation: Situation, target: tuple[float, float, float]) -> np.ndarray:
        return relative(np.asarray(situation.pose, dtype=float), np.asarray(target, dtype=float))

    def _approach(self, situation: Situation, table: MotionTable, action: LatticeAction) -> Running:
        """A final approach that puts the tracked point on the goal, heading kept."""
        goal = next(g for g in situation.goals if g.index == action.goal)
        x, y, psi = situation.pose
        d = rotate(np.array([goal.x - x, goal.y - y]), np.array(-psi))
        basis = [e for e in correction_basis(self.library.lattice(table.shape)) if e.turn == 0.0]
        grounded = ground((float(d[0]), float(d[1]), 0.0), basis)
        return Running(action, grounded, grounded.duration)

    def _spin(self, table: MotionTable, pose: Any) -> list[Primitive]:
        """The largest library turn whose swept footprint keeps the planning margin from the
        state ``pose`` snaps to: where the turn runs, after any back-off from a contact (checked
        at the touching pose, a turn free there may sweep what backing off moved towards)."""
        key = self.planner.key_of(table, pose)
        margin = self.settings.margin
        task = LatticeTask(
            self.planner.grid, table, self.clearance, key, (0.0, 0.0), 0.0, margin, margin
        )
        free = {table.motions[m].primitive for _, m in task.valid_motions(key)}
        turns = sorted(
            (e for e in self.library.lattice(table.shape) if e.turn != 0.0 and e.id in free),
            key=lambda e: -abs(e.turn),
        )
        return turns[:1] * SPIN_STEPS

    def _back_off(self, trigger: Contact, table: MotionTable) -> list[Primitive]:
        """Short library translations away from the touched side (a bumper's reflex)."""
        angle = BACK_OFF.get(trigger.side, 0)
        if trigger.part == 4 and trigger.side in ("front", "rear"):
            angle = 180  # the tail's end touched: go head first
        name = f"lat-{table.shape}-t005-a{angle:03d}"
        if name not in self.library:
            return []
        return [self.library.get(name)] * BACK_OFF_STEPS

    def _command(self, running: Running) -> Command:
        g = running.grounded
        control = FixedShape.of(g.theta, g.joints)
        shape = self.table.shape if running.action.name == "reshape" and self.table else None
        return Command(control, running.action.pddl, g.to_dict(), shape)
