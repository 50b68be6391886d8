"""Plans tours of goals on the lattice of one body: ``PlanRequest -> Plan | Failure``.

One replan: the costmap's two views read once (``inputs``); per goal, the obstacle heuristic's
map (an infinite distance at the start proves the goal enclosed), unordered goals ordered by
those maps, and per leg the relaxed body's flood (``Feasibility``, about a millisecond: a
proof the search would give only at its end) before one cost search. A leg whose search spends
its budget ends the plan at its best node (a partial plan: the robot goes there, senses, and
plans again) if that is closer, else the walk over valid motions decides between a proof that
the goal is out of reach and a timeout. A goal proven out of reach by its own side's walk keeps
that proof (``search.reach.GoalProof``): a later leg to it asks the proof, or walks that side
again, before it searches. ``Failure``s are typed; soft costs never cause one.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from domain.goal_order import LegGoal, order_goals
from domain.navigation import search as searches
from domain.navigation.feasibility import Feasibility
from domain.navigation.lattice.cache import MotionCache
from domain.navigation.lattice.costs import (
    CostInputs,
    KernelTable,
    cost_parameters,
    flat_cells,
    kernel_table,
    start_costs,
    with_start_margins,
)
from domain.navigation.lattice.grid import Key, LatticeGrid
from domain.navigation.lattice.motions import MotionTable, body_key
from domain.navigation.lattice.states import StatePool
from domain.navigation.lattice.task import LatticeTask
from domain.navigation.plan import Failure, Plan, PlanAction, PlanRequest, Proof, leg_reach
from domain.navigation.search.heuristic import CostHeuristic, cost_map, step_weights
from domain.navigation.search.reach import (
    GoalProof,
    goal_side_proof,
    lattice_reaches,
    leaves_start,
)
from domain.navigation.settings import NavigationSettings
from domain.pyperplan_adapter import HEURISTICS, CancelFlag, SearchStopped, stop_if_due
from domain.world import WorldModel
from sim.robot import Array, head_tip
from sim.world import Bounds

CACHES_KEPT = 8  # motion caches kept (one per body and margin); the least recently used goes
MAPS_KEPT = 64  # heuristic maps kept (then all are dropped: a new world needs new ones)
PROOFS_KEPT = 8  # goals' proofs of being out of reach kept (the oldest goes)
REPROOF_GROWTH = 2  # a re-proof walks at most this many times its last proof's states


class Planner:
    """Plans on the lattice of a body against a world model's costmap."""

    def __init__(
        self,
        bounds: Bounds,
        settings: NavigationSettings = NavigationSettings(),  # noqa: B008 (frozen)
        search: str = searches.COST_SEARCH,
        heuristic: str = "cost",
        time_limit: float = 5.0,
    ) -> None:
        if search not in searches.SEARCH_NAMES:
            raise ValueError(f"search: one of {', '.join(searches.SEARCH_NAMES)}")
        if heuristic != "cost" and heuristic not in HEURISTICS:
            raise ValueError(f"heuristic: 'cost' or one of {', '.join(HEURISTICS)}")
        if search == searches.COST_SEARCH and heuristic != "cost":
            raise ValueError("heuristic: the cost search takes the cost heuristic")
        self.grid = LatticeGrid(bounds, settings)
        self.settings = settings
        self.search, self.heuristic, self.time_limit = search, heuristic, time_limit
        self.states = StatePool()  # search states shared by every search on this grid
        self._caches: dict[tuple[Any, ...], MotionCache] = {}
        self._maps: dict[tuple[Any, ...], Array] = {}
        # Per body, margin and goal: the last proof that the goal is out of reach (its walk's
        # states that could reach it), which a later replan's start may still be cut off by,
        # with the motion table it was found on (a proof holds for that table's motions only).
        self._proofs: dict[tuple[Any, ...], tuple[MotionTable, GoalProof]] = {}
        # (body, goal)s walked from the goal's side on another body's proof without a proof of
        # their own: the search answers for them until one comes.
        self._walked: set[tuple[Any, ...]] = set()
        # The last start's table: a replan asks for it for the check of the start and for
        # the first leg.
        self._start: tuple[MotionTable, Key, Array, tuple[KernelTable, bool]] | None = None

    # -- lattice states ---------------------------------------------------------------------
    def key_of(self, table: MotionTable, pose: Sequence[float]) -> Key:
        """The lattice state of a real pose: its centroid's cell and nearest orientation."""
        p = np.asarray(pose, dtype=float)
        c = table.centroid(p)
        i, j = self.grid.cell(float(c[0]), float(c[1]))
        k = round(float(p[2]) / self.settings.step) % self.settings.orientations
        return i, j, k

    def pose_of(self, table: MotionTable, key: Key) -> Array:
        """The tracked-point pose of ``table``'s body at lattice state ``key``."""
        return np.array(self.pose_tuple(table, key))

    def pose_tuple(self, table: MotionTable, key: Key) -> tuple[float, float, float]:
        """``pose_of`` as three floats."""
        i, j, k = key
        return table.pose_tuple(*self.grid.centre_xy(i, j), k)

    # -- what one replan reads --------------------------------------------------------------
    def inputs(
        self,
        world: WorldModel,
        table: MotionTable,
        near: tuple[float, float, float] | None = None,
    ) -> CostInputs:
        """The costmap's views as ``table``'s cost evaluation reads them, never-observed space
        priced from where the robot is and where its head looks (``near``, its pose; ``None``:
        as if it were everywhere)."""
        grid, b = self.grid, self.grid.bounds
        lethal = world.lethal_clearance()
        if lethal.shape != (grid.nx, grid.ny):
            raise ValueError("the world model's grid and the lattice's differ")
        gf = np.array([b.xmin, b.ymin, self.settings.resolution])
        geo = np.array([b.xmin, b.ymin, self.settings.resolution, b.xmin, b.xmax, b.ymin, b.ymax])
        params = cost_parameters(self.settings.costs)
        c = self.settings.costs
        at, facing = None, None
        if near is not None:
            tip = head_tip(np.asarray(near, dtype=float), world.geometry)
            at, facing = (near[0], near[1]), (float(tip[0]), float(tip[1]), near[2] + math.pi)
        risk = world.risk(at, c.sensing_horizon, c.beyond_horizon, facing)
        blocked = world.blocked()
        flat = flat_cells(risk, blocked, table.cell_reach_new + 1)
        return CostInputs(grid.nx, grid.ny, gf, lethal, geo, risk, blocked, flat, params)

    def start_table(
        self, table: MotionTable, start: Key, inputs: CostInputs
    ) -> tuple[KernelTable, bool]:
        """The motions out of where the robot rests (the table of its bin, ``KernelTable.bin``)
        and whether it rests closer to something than ``start_margin``: at ``start_margin``,
        but near where the resting body already keeps less (it just stopped against
        something, or sensing rounds a surface it passes closely onto the cells round it), as
        close as it already is and no closer: a body can always move in a way that brings no
        part of it nearer to anything than it is, and it must not swing its far end in as
        deep."""
        last = self._start
        if last is not None and last[0] is table and last[1] == start and last[2] is inputs.values:
            return last[3]
        out = self._start_table(table, start, inputs)
        self._start = (table, start, inputs.values, out)
        return out

    def _start_table(
        self, table: MotionTable, start: Key, inputs: CostInputs
    ) -> tuple[KernelTable, bool]:
        s = self.settings
        i, j, k = start
        kt = kernel_table(table, s.start_margin).bin(k)
        r = self.settings.resolution
        body = table.body_checks[k]  # the resting body's cells, as the checks read them
        bi, bj = i + body[:, 0], j + body[:, 1]
        inside = (bi >= 0) & (bi < self.grid.nx) & (bj >= 0) & (bj < self.grid.ny)
        clear = np.full(len(body), -np.inf)
        clear[inside] = inputs.values[bi[inside], bj[inside]]
        slack = clear - table.body_check_needs[k]
        close = slack < s.start_margin
        if not close.any():
            return kt, False
        relaxed = min(s.start_margin, float(np.min(slack)) - s.touch_deeper)
        sites = body[close] * r

        def near(points: NDArray[np.floating]) -> NDArray[np.bool_]:
            gap = points[:, None, :] - sites[None, :, :]
            out: NDArray[np.bool_] = (
                np.min(np.einsum("nsd,nsd->ns", gap, gap), axis=1) <= s.touch_radius**2
            )
            return out

        shift = np.where(near(table.checks[k] * r), relaxed - s.start_margin, 0.0)
        point_shift = np.where(near(table.grouped[k][:, :2]), relaxed - s.start_margin, 0.0)
        return with_start_margins(kt, shift, point_shift), True

    def cache(self, table: MotionTable, world: WorldModel, inputs: CostInputs) -> MotionCache:
        """The body's motion cache, refreshed to the world model (one per body and margin;
        the least recently used goes past ``CACHES_KEPT``)."""
        s = self.settings
        key = (*body_key(table), s.margin)
        cache = self._caches.pop(key, None)
        if cache is None:
            if len(self._caches) >= CACHES_KEPT:
                del self._caches[next(iter(self._caches))]
            cap = table.largest_need + s.margin + s.costs.inflation_radius + s.resolution
            cache = MotionCache(self.grid, table, cap)
        self._caches[key] = cache  # (the newest last)
        version = (id(world), world.version, world.soft_version, inputs.risk.ctypes.data)
        cache.refresh(inputs.values, inputs.risk, inputs.blocked, version)
        return cache

    def heuristic_map(
        self,
        table: MotionTable,
        world: WorldModel,
        goal: LegGoal,
        start: tuple[float, float] | None,
        static: bool = False,
    ) -> Array:
        """The obstacle heuristic's map of ``goal`` for this body (cells near ``start``
        passable), on the lethal layer or, with ``static``, on the known map alone."""
        version = ("static", len(world.known)) if static else world.version
        key = (id(world), version, body_key(table), goal.x, goal.y, goal.tolerance, start)
        got = self._maps.get(key)
        if got is None:
            clear = world.static_clearance() if static else world.lethal_clearance()
            at = np.ascontiguousarray(clear, dtype=float).ravel()
            beyond = None if static else world.continuation().ravel()
            weights = step_weights(
                at, self.settings.margin, self.settings.costs, beyond, self.settings.resolution
            )
            free = float(np.linalg.norm(table.offset)) + goal.tolerance
            need = table.centroid_need()
            got = cost_map(
                self.grid,
                at,
                (goal.x, goal.y),
                need,
                free,
                weights,
                start,
                roomy=need + self.settings.margin,
                narrow_weight=self.settings.costs.narrow_weight,
                turning=need + self.settings.margin + table.turn_room,
                cramped_weight=self.settings.costs.cramped_weight,
            )
            if len(self._maps) >= MAPS_KEPT:
                self._maps.clear()
            self._maps[key] = got
        return got

    def task(
        self,
        table: MotionTable,
        inputs: CostInputs,
        cache: MotionCache,
        start: Key,
        goal: LegGoal,
        first: bool,
        deadline: float,
        cancel: CancelFlag | None,
    ) -> LatticeTask:
        """The task of one leg: from ``start`` to the tracked point on ``goal``."""
        kt = kernel_table(table, self.settings.margin)
        kt_start = self.start_table(table, start, inputs)[0] if first else kt.bin(start[2])
        task = LatticeTask(
            self.grid,
            table,
            inputs,
            kt,
            kt_start,
            start,
            (goal.x, goal.y),
            leg_reach(goal),
            goal.index,
            self.states,
            cache,
        )
        task.deadline, task.cancel = deadline, cancel
        return task

    def leg_heuristic(self, task: LatticeTask, distances: Array) -> CostHeuristic:
        """A leg's obstacle heuristic with the turn onto the way (``CostHeuristic``)."""
        table = task.table
        reach = float(np.linalg.norm(table.offset))
        align = (
            task.inputs.risk,
            table.turn_cost,
            table.blind_per_radian,
            self.settings.costs.contact_cost,
            self.settings.costs.reverse_penalty,
        )
        return CostHeuristic(task, distances, reach, align=align)

    # -- planning -----------------------------------------------------------------------------
    def plan(self, request: PlanRequest) -> Plan | Failure:
        """A plan from the request's pose through its goals, or why there is none."""
        started = time.monotonic()
        deadline = started + self.time_limit
        try:
            out = self._plan(request, started, deadline)
        except SearchStopped as stop:
            if stop.status == "cancelled":
                out = Failure("cancelled", "planning cancelled")
            else:
                out = Failure(
                    "timeout",
                    f"planning timeout: no plan within {self.time_limit:g} s",
                )
        elapsed = (time.monotonic() - started) * 1e3
        if isinstance(out, Failure):
            return Failure(out.kind, out.reason, out.proof, out.goal, out.expansions, elapsed)
        out.search_ms = elapsed
        return out

    def _plan(self, request: PlanRequest, started: float, deadline: float) -> Plan | Failure:
        table, world = request.table, request.world
        inputs = self.inputs(world, table, request.pose)
        cache = self.cache(table, world, inputs)
        start = self.key_of(table, request.pose)
        kt_start, touching = self.start_table(table, start, inputs)
        if start_costs(self.grid.encode(start), inputs, kt_start)[0] == 0:
            return self._blocked(table.shape, 0)
        si, sj, _ = start
        here = self.grid.centre_xy(si, sj)
        maps: dict[int, Array] = {}
        for g in request.goals:
            stop_if_due(request.cancel, deadline)
            maps[g.index] = self.heuristic_map(table, world, g, here)
            if not math.isfinite(maps[g.index][si, sj]):
                known = self.heuristic_map(table, world, g, here, static=True)
                proof: Proof = "sensed" if math.isfinite(known[si, sj]) else "known"
                by = "known obstacles" if proof == "known" else "sensed obstacles"
                return Failure(
                    "unreachable",
                    f"unreachable: goal {g.index} at ({g.x:g}, {g.y:g}) enclosed by {by}",
                    proof,
                    g.index,
                )
        order = (
            list(request.goals)
            if request.ordered
            else order_goals(self.grid, request.goals, maps, (si, sj))
        )
        plan = Plan([], [g.index for g in order], shape=table.shape)
        here_key = start
        feasible = Feasibility(self.grid, table, inputs.values, self.settings.margin)
        for leg, goal in enumerate(order):
            task = self.task(
                table, inputs, cache, here_key, goal, leg == 0, deadline, request.cancel
            )
            heuristic = self.leg_heuristic(task, maps[goal.index])
            s = self.settings.search
            # A start resting closer than its margin moves out by its own relaxed motions
            # only: a search that never got past them says nothing of the goal (start
            # blocked; the recoveries back the body off first). Once it did, what it ran out
            # of is what the body reaches at its margin.
            out_of_start = 1 + len(table.motions)
            # The relaxed body's flood is a proof in about a millisecond that a search would
            # give only after exhausting every state it reaches or its whole budget: asked
            # first, within a few milliseconds' worth (``flood_first``: where both sides are
            # large the search answers sooner, and the whole check follows a spent budget).
            # A start resting closer than its margin asks it after the search, which tells a
            # body blocked where it rests from a goal out of reach.
            first_resting = touching and leg == 0
            flooded = (
                None
                if first_resting
                else feasible.flood_decides(
                    here_key, (goal.x, goal.y), leg_reach(goal), s.flood_first
                )
            )
            if flooded is False:
                return self._unreachable(world, goal, table.shape, "body", plan.expansions)
            proof_key = (*body_key(table), self.settings.margin, goal.x, goal.y, leg_reach(goal))
            if self._proven_before(task, proof_key, heuristic, first_resting, out_of_start):
                return self._unreachable(world, goal, table.shape, "search", plan.expansions)
            found = searches.run(
                task,
                heuristic,
                self.search,
                s.weight,
                s.expansions,
                None if self.heuristic == "cost" else self.heuristic,
                stall=searches.Stall(s.stall_after, s.stalled_weight),
            )
            plan.expansions += found.expansions
            plan.legs.append(task)
            if found.status == "solved":
                assert found.plan is not None
                actions, here_key = self.actions_of(
                    task, [op.name for op in found.plan], found.plan
                )
                self.keep_for_export(task, actions, here_key)
                plan.actions += actions
                continue
            if found.status == "exhausted":
                if first_resting and found.expansions <= out_of_start:
                    return self._blocked(table.shape, plan.expansions)
                return self._unreachable(world, goal, table.shape, "search", plan.expansions)
            # The budget ran out: go towards the best node if it is closer, unless the
            # lethal layer proves the goal out of reach (the relaxed body's whole check,
            # unless its flood decided before the search, then the walk over valid motions).
            if flooded is None and not feasible.reaches(
                here_key, (goal.x, goal.y), leg_reach(goal)
            ):
                return self._unreachable(world, goal, table.shape, "body", plan.expansions)
            walk = lattice_reaches(task, heuristic, s.reach_states)
            if walk.proof is not None:
                self._keep_proof(proof_key, table, walk.proof)
            if walk.reaches is False:
                if first_resting and walk.side == "start" and walk.met <= out_of_start:
                    return self._blocked(table.shape, plan.expansions)
                return self._unreachable(world, goal, table.shape, "search", plan.expansions)
            start_h = heuristic(_Root(task.initial_state))
            if found.best and found.best_h < start_h - s.progress:
                actions, end = self.actions_of(task, [op.name for op in found.best], found.best)
                self.keep_for_export(task, actions, end)
                plan.actions += actions
                plan.partial = True
                return plan
            if plan.actions:
                plan.partial = True  # the legs before it stand: go there, plan again
                return plan
            spent = (
                f"within {s.expansions:,} expansions"
                if found.expansions >= s.expansions
                else f"(the {self.search} search gave up after {found.expansions:,} expansions)"
            )
            return Failure(
                "timeout",
                f"planning timeout: no plan to goal {goal.index} at ({goal.x:g}, {goal.y:g}) "
                f"{spent}",
                None,
                goal.index,
                plan.expansions,
            )
        return plan

    def _proven_before(
        self,
        task: LatticeTask,
        key: tuple[Any, ...],
        heuristic: CostHeuristic,
        first_resting: bool,
        out_of_start: int,
    ) -> bool:
        """Whether a goal proven out of reach before (``key``: body, margin, goal) is proven
        again without a search: this table's kept proof still holds, or its side of the goal,
        walked first (within a few times the states the last proof of the goal found, this
        body's or another's), runs out. A start resting closer than its margin asks only when
        its own side holds more than ``out_of_start`` states (else the search tells it is
        blocked)."""
        entry = self._proofs.get(key)
        kept = entry[1] if entry is not None and entry[0] is task.table else None
        if kept is not None:
            bound = kept.states
        elif key in self._walked:
            return False
        else:  # the newest proof of the same goal (the key's last three: x, y, reach)
            goal = [p.states for k, (_, p) in self._proofs.items() if k[-3:] == key[-3:]]
            if not goal:
                return False
            bound = goal[-1]
        if first_resting and not leaves_start(task, heuristic, out_of_start):
            return False
        if kept is not None and kept.holds(task):
            return True
        again = goal_side_proof(task, REPROOF_GROWTH * bound + 1)
        if again is not None:
            self._keep_proof(key, task.table, again)
            return True
        # the goal's side grew or met the start: the search answers from now on
        self._proofs.pop(key, None)
        self._walked.add(key)
        return False

    def _keep_proof(self, key: tuple[Any, ...], table: MotionTable, proof: GoalProof) -> None:
        """Keep a goal's proof of being out of reach for ``table`` (the newest last; the oldest
        goes past ``PROOFS_KEPT``)."""
        self._proofs.pop(key, None)
        if len(self._proofs) >= PROOFS_KEPT:
            del self._proofs[next(iter(self._proofs))]
        self._proofs[key] = (table, proof)
        self._walked.discard(key)

    @staticmethod
    def _blocked(shape: str, expansions: int) -> Failure:
        """The robot rests closer to something than any plan may pass it, and nothing leads
        out from there: no proof about the goal (the recoveries back it off first)."""
        return Failure(
            "start_blocked",
            f"start blocked: the {shape} body rests closer to something than its margin and no "
            "plan leads out from where it stands",
            None,
            None,
            expansions,
        )

    def _unreachable(
        self,
        world: WorldModel,
        goal: LegGoal,
        shape: str,
        why: str,
        expansions: int,
    ) -> Failure:
        """No plan reaches ``goal`` (the legs planned before it are no plan either: a later
        goal of the tour is out of reach)."""
        proof: Proof = "sensed" if world.sensed_occupied().any() else "known"
        if why == "search":
            reason = (
                f"unreachable: no collision-free sequence of {shape} primitives brings the "
                f"body to goal {goal.index} at ({goal.x:g}, {goal.y:g})"
            )
        else:
            reason = (
                f"unreachable: goal {goal.index} at ({goal.x:g}, {goal.y:g}): no "
                f"collision-free motion of the {shape} body brings its head there"
            )
        return Failure("unreachable", reason, proof, goal.index, expansions)

    def keep_for_export(self, task: LatticeTask, actions: list[PlanAction], end: Key) -> None:
        """Bound what the leg keeps of its search to what its PDDL problem lists."""
        states = {self.grid.encode(a.source) for a in actions if a.source is not None}
        states.add(self.grid.encode(end))
        task.keep_for_export(states, self.settings.search.exported_states)

    def actions_of(
        self, task: LatticeTask, names: list[str], operators: Sequence[Any] = ()
    ) -> tuple[list[PlanAction], Key]:
        """A searched plan's operator names (``task``'s) as plan actions, and where it ends."""
        table = task.table
        by_name = {name: i for i, name in enumerate(table.names)}
        costs = [float(getattr(op, "cost", 0.0)) for op in operators] or [0.0] * len(names)
        here = task.start_key
        out = []
        for name, cost in zip(names, costs, strict=True):
            verb, *args = name.strip("()").split()
            if verb == "move":
                source, here = here, self.grid.decode(int(args[1][1:]))
                m = by_name[args[2]]
                motion = table.motions[m]
                target = self.pose_tuple(table, here)
                out.append(
                    PlanAction(
                        "move",
                        name,
                        motion.primitive,
                        target,
                        motion.duration,
                        None,
                        source,
                        m,
                        cost,
                    )
                )
            else:
                target = self.pose_tuple(table, here)
                out.append(PlanAction("visit", name, None, target, 0.0, task.goal_index))
        return out, here


class _Root:
    """A stand-in search node for evaluating the heuristic at a state."""

    def __init__(self, state: Any) -> None:
        self.state = state
